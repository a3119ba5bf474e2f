//! Error codes and the error type of the core.
//!
//! Every fallible operation of the core returns [`Result`]. Each [`ErrorCode`] has a fixed number
//! that the C interface exposes as a `VL_*` constant; numbers are never renumbered or reused (see
//! `docs/errors.md`). The C layer turns an `Err` into an entry of the `vlError` queue; Rust users
//! get the error value directly.
//!
//! This module owns the codes and the error value; which call fails with which code is decided
//! where the call is validated.

use std::fmt;

/// The error codes. The discriminant is the number `vlError` returns in C.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(i32)]
#[non_exhaustive]
pub enum ErrorCode {
    /// No error (`VL_NOERROR`).
    NoError = 0,
    /// The command is not legal in the current scope (`VL_BADSCOPE`).
    BadScope = 1,
    /// A numeric argument is out of range, NaN or infinite (`VL_BADVALUE`).
    BadValue = 2,
    /// A field mask is empty, has unknown bits, or names more than one field where one is
    /// required (`VL_BADFIELD`).
    BadField = 3,
    /// An enumerated argument has no meaning (`VL_BADENUM`).
    BadEnum = 4,
    /// A required pointer is NULL (`VL_NULLPOINTER`).
    NullPointer = 5,
    /// No mapping or dataset has this id (`VL_BADID`).
    BadId = 6,
    /// Valid, but not implemented (`VL_UNSUPPORTED`): reserved, no command reports it
    /// (`docs/errors.md`, `docs/compat.md`).
    Unsupported = 7,
    /// A file could not be read or written (`VL_IOERROR`).
    IoError = 8,
    /// A file's contents or name are malformed or of an unsupported format (`VL_BADFILE`).
    BadFile = 9,
    /// A requested size exceeds what can be allocated (`VL_NOMEMORY`).
    NoMemory = 10,
    /// An internal failure (a caught panic, for instance in a Rust callback) (`VL_INTERNAL`).
    Internal = 11,
    /// An index (mapping output, child number) is out of range (`VL_BADINDEX`).
    BadIndex = 12,
    /// A dataset file does not start with the `.vlb` magic number (`VL_BADMAGIC`).
    BadMagic = 13,
    /// A dataset's dimensions are zero or too large (`VL_BADDIMENSIONS`).
    BadDimensions = 14,
    /// A dataset's voxel width is not 1 or 2 bytes (`VL_BADVOXELWIDTH`).
    BadVoxelWidth = 15,
    /// A dataset's normalisation a, b is not finite or a = b (`VL_BADRANGE`).
    BadRange = 16,
    /// A dataset file's size disagrees with its header (truncated or trailing data)
    /// (`VL_BADSIZE`).
    BadSize = 17,
    /// The render was cancelled, by `vlCancel`, a progress function or a cancel flag
    /// (`VL_CANCELLED`, an extension: no command of the paper's API reports it unless the
    /// program used the extensions).
    Cancelled = 18,
}

impl ErrorCode {
    /// Every code, in numeric order.
    pub const ALL: [ErrorCode; 19] = [
        ErrorCode::NoError,
        ErrorCode::BadScope,
        ErrorCode::BadValue,
        ErrorCode::BadField,
        ErrorCode::BadEnum,
        ErrorCode::NullPointer,
        ErrorCode::BadId,
        ErrorCode::Unsupported,
        ErrorCode::IoError,
        ErrorCode::BadFile,
        ErrorCode::NoMemory,
        ErrorCode::Internal,
        ErrorCode::BadIndex,
        ErrorCode::BadMagic,
        ErrorCode::BadDimensions,
        ErrorCode::BadVoxelWidth,
        ErrorCode::BadRange,
        ErrorCode::BadSize,
        ErrorCode::Cancelled,
    ];

    /// The code with this number, if there is one.
    pub fn from_raw(code: i32) -> Option<ErrorCode> {
        ErrorCode::ALL.iter().copied().find(|c| *c as i32 == code)
    }

    /// A static description of the code, as `vlErrorString` returns it (NUL-terminated, so the C
    /// layer can hand it out without copying).
    pub fn description_nul(self) -> &'static str {
        match self {
            ErrorCode::NoError => "no error\0",
            ErrorCode::BadScope => "command not legal in the current scope\0",
            ErrorCode::BadValue => "argument out of range, NaN or infinite\0",
            ErrorCode::BadField => "bad field mask\0",
            ErrorCode::BadEnum => "unknown enumerated value\0",
            ErrorCode::NullPointer => "NULL pointer argument\0",
            ErrorCode::BadId => "no mapping or dataset has this id\0",
            ErrorCode::Unsupported => "not supported by this version of vlib\0",
            ErrorCode::IoError => "file could not be read or written\0",
            ErrorCode::BadFile => "malformed file or unsupported file format\0",
            ErrorCode::NoMemory => "requested size too large\0",
            ErrorCode::Internal => "internal error (a panic was caught)\0",
            ErrorCode::BadIndex => "index out of range\0",
            ErrorCode::BadMagic => "not a .vlb dataset (bad magic number)\0",
            ErrorCode::BadDimensions => "dataset dimensions are zero or too large\0",
            ErrorCode::BadVoxelWidth => "dataset voxel width is not 1 or 2 bytes\0",
            ErrorCode::BadRange => "dataset normalisation a, b is not finite or a = b\0",
            ErrorCode::BadSize => "dataset file size disagrees with its header\0",
            ErrorCode::Cancelled => "rendering cancelled\0",
        }
    }

    /// A static description of the code.
    pub fn description(self) -> &'static str {
        let s = self.description_nul();
        &s[..s.len() - 1]
    }
}

/// An error: a code and a message saying what was wrong.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error {
    /// The code, as `vlError` reports it.
    pub code: ErrorCode,
    /// A human-readable explanation naming the command and the offending argument.
    pub message: String,
}

impl Error {
    /// An error with this code and message.
    pub fn new(code: ErrorCode, message: impl Into<String>) -> Error {
        Error {
            code,
            message: message.into(),
        }
    }

    /// The error an unwind's `payload` stands for: the [`Error`] it carries (raised by
    /// [`raise`], as a cache that could not be allocated is), else `Internal` with the message
    /// `internal` makes of the panic's. For the library's panic boundaries: [`catch`] here,
    /// and the C layer's around every exported function.
    #[doc(hidden)]
    pub fn from_unwind(
        payload: Box<dyn std::any::Any + Send>,
        internal: impl FnOnce(&str) -> String,
    ) -> Error {
        match payload.downcast::<Error>() {
            Ok(e) => *e,
            Err(payload) => {
                let msg = payload
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| payload.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "unknown panic".into());
                Error::new(ErrorCode::Internal, internal(&msg))
            }
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.code.description(), self.message)
    }
}

impl std::error::Error for Error {}

/// The result type of the core.
pub type Result<T> = std::result::Result<T, Error>;

/// Shorthand for an `Err` with a code and message.
pub(crate) fn err<T>(code: ErrorCode, message: impl Into<String>) -> Result<T> {
    Err(Error::new(code, message))
}

#[cfg(test)]
mod tests;

/// Runs `f`, turning an unwind into an error: one that carries an [`Error`] (raised by
/// [`raise`], as a cache that could not be allocated is) is that error; any other panic (in a
/// user's field function, say) is `Internal`, with `what` and the panic's message. The library's
/// panic boundary for renders and voxelizations, so that neither a Rust caller nor the C layer
/// sees a panic from them.
pub(crate) fn catch<T>(what: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(payload) => Err(Error::from_unwind(payload, |msg| {
            format!("{what} stopped by a panic (in a field function?): {msg}")
        })),
    }
}

/// Leaves the current computation by unwinding with `e`, for [`catch`] to return: where an
/// error arises deep in code that cannot return it (a cache filled on first use inside a
/// render). `resume_unwind` runs no panic hook, so nothing is printed.
pub(crate) fn raise(e: Error) -> ! {
    std::panic::resume_unwind(Box::new(e))
}
