//! The session commands: starting and ending the library, scenes and objects (`vlInit`,
//! `vlEnd`), and reading the error queue (`vlError`, `vlErrorString`). The queue itself is
//! `errors`; what `vlEnd` closes and renders is decided by the core.

use crate::errors;
use crate::ffi::{dispatch, ffi_boundary, never, scope_of, Rendering};
use crate::types::vlint;
use std::os::raw::c_char;
use vlib_core::scope::require;
use vlib_core::{Closed, Command, ErrorCode, Library, Scope};

/// Starts the library. Legal only when it is not running.
#[no_mangle]
pub extern "C" fn vlInit() {
    ffi_boundary((), || {
        dispatch(
            Command::Init,
            |_| never(Command::Init),
            |state| {
                require(Command::Init, scope_of(state))?;
                let mut lib = Library::new();
                lib.set_render_control(crate::extensions::initial_control());
                #[cfg(feature = "mpi")]
                crate::mpi::attach(&mut lib);
                *state = Some(lib);
                Ok(())
            },
        )
    })
}

/// Closes the innermost open object, the scene (rendering it and writing the outputs it
/// requested; if that fails the scene is closed all the same and the error recorded), or the
/// library.
#[no_mangle]
pub extern "C" fn vlEnd() {
    ffi_boundary((), || {
        dispatch(
            Command::End,
            |_| never(Command::End),
            |state| {
                require(Command::End, scope_of(state))?;
                let Some(lib) = state.as_mut() else {
                    return never(Command::End);
                };
                // Closing a scene renders it: threads outside its sample scope sample without
                // the state until the render ends.
                let _rendering =
                    (lib.scope() == Scope::Scene).then(|| Rendering::start(lib.sampler()));
                #[cfg(feature = "mpi")]
                let mark = crate::errors::mark();
                let closed = lib.end();
                #[cfg(feature = "mpi")]
                if _rendering.is_some() {
                    crate::mpi::share_errors(lib, mark);
                    crate::mpi::report(lib);
                }
                if closed? == Closed::Library {
                    *state = None;
                }
                Ok(())
            },
        )
    })
}

/// Returns the oldest error not yet reported and forgets it; `VL_NOERROR` when there is none.
/// At most 1024 errors are kept; later ones are dropped until some are reported. Legal
/// anywhere.
#[no_mangle]
pub extern "C" fn vlError() -> vlint {
    ffi_boundary(ErrorCode::NoError as vlint, || Ok(errors::pop() as vlint))
}

static UNKNOWN_CODE: &std::ffi::CStr = c"unknown error code";

/// A static, NUL-terminated description of an error code (never to be freed). Legal anywhere.
#[no_mangle]
pub extern "C" fn vlErrorString(code: vlint) -> *const c_char {
    ffi_boundary(UNKNOWN_CODE.as_ptr(), || {
        Ok(match ErrorCode::from_raw(code) {
            Some(c) => c.description_nul().as_ptr().cast(),
            None => UNKNOWN_CODE.as_ptr(),
        })
    })
}
