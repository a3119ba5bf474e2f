//! The extensions: C functions beyond the 44 commands of the paper's API, declared after them
//! in `include/vlib.h` under their own banner and listed in `commands::EXTENSIONS`
//! (`docs/extensions.md`). A program that uses none of them sees the paper's API unchanged.
//!
//! - `vlProgress` registers a progress function for the renders of the library's scenes.
//! - `vlCancel` stops the render in progress, from any thread.
//! - `vlRenderBuffer` renders the open scene into the caller's memory.
//! - `vlGradientFilter` chooses how the gradients of dataset fields are reconstructed.
//! - `vlVersion` returns the version of the running library (`VLIB_VERSION`'s encoding).
//!
//! The core's [`vlib_core::RenderControl`] and [`Library::render_into`] do the work; this
//! module holds the C forms: the process's cancel flag, the wrapper of the C progress
//! function, the checks of the buffer's pointer, size and format, and the version number
//! (the constants of `types`, compiled in).

use crate::ffi::{ffi_boundary, null, rendering, state_outside_render, Rendering};
use crate::types::{
    vlfloat, vlint, VLIB_VERSION, VL_FALSE, VL_GRADIENT_CUBIC, VL_GRADIENT_NODES, VL_TRUE,
};
use std::os::raw::{c_ulong, c_void};
use std::sync::{Arc, OnceLock};
use vlib_core::{
    CancelFlag, Error, ErrorCode, GradientFilter, Library, PixelFormat, RenderControl, Result,
};

/// The process's cancel flag: set by `vlCancel` while a scene renders, cleared when a render
/// starts and when it ends.
pub(crate) fn cancel_flag() -> &'static CancelFlag {
    static FLAG: OnceLock<CancelFlag> = OnceLock::new();
    FLAG.get_or_init(CancelFlag::new)
}

/// The render control a new library of the C interface starts with: the process's cancel flag,
/// no progress function.
pub(crate) fn initial_control() -> RenderControl {
    RenderControl {
        cancel: Some(cancel_flag().clone()),
        progress: None,
    }
}

/// A C progress function with its `misc` pointer.
#[derive(Clone, Copy)]
struct CProgress {
    f: unsafe extern "C" fn(done: vlfloat, misc: *mut c_void) -> vlint,
    misc: *mut c_void,
}

// SAFETY: the core calls a progress function on one of its rendering threads, one call at a
// time (never concurrently with itself), as `vlProgress` documents; we never dereference
// `misc` ourselves.
unsafe impl Send for CProgress {}
// SAFETY: as above.
unsafe impl Sync for CProgress {}

impl CProgress {
    fn call(&self, done: f32) -> bool {
        // SAFETY: a valid C function by the contract of `vlProgress`.
        unsafe { (self.f)(done, self.misc) != 0 }
    }
}

/// ======== Extensions: functions beyond the 44 commands of the paper's API ========
/// (`docs/extensions.md`). A program that uses none of them sees the paper's API.
///
/// Extension. Registers `f` as the progress function of the library's renders: while a
/// scene's `vlEnd` renders its images and volumes, `f` is called with `misc` and the fraction
/// done, in [0, 1] and never decreasing (as an image's tiles end, at most every 0.1 s, after
/// each strip of image rows and each slab of voxelized nodes, and with 1 at the end, also
/// where an output failed), while other rendering threads may be calling the scene's field
/// functions, on one of the
/// library's rendering threads (the thread that called `vlEnd` waits meanwhile), one call at
/// a time. Returning 0 cancels the render: its `vlEnd` records `VL_CANCELLED` and writes no
/// file of the output it was making (the answer to the final 1 is not asked for: every output
/// is done). Inside `f` only `vlCancel`, `vlSample`, `vlError` and
/// `vlErrorString` are legal. NULL removes the function. Legal at library and scene scope;
/// kept until the library's final `vlEnd`.
#[no_mangle]
pub extern "C" fn vlProgress(
    f: Option<unsafe extern "C" fn(done: vlfloat, misc: *mut c_void) -> vlint>,
    misc: *mut c_void,
) {
    ffi_boundary((), || {
        let mut state = state_outside_render("vlProgress")?;
        let lib: &mut Library = match state.as_mut() {
            Some(lib) if lib.scope() != vlib_core::Scope::Object => lib,
            Some(_) => return scope_error(),
            None => return scope_error(),
        };
        let progress = f.map(|f| {
            let c = CProgress { f, misc };
            Arc::new(move |done: f32| c.call(done)) as vlib_core::ProgressFn
        });
        lib.set_render_control(RenderControl {
            progress,
            ..initial_control()
        });
        Ok(())
    })
}

fn scope_error() -> Result<()> {
    Err(Error::new(
        ErrorCode::BadScope,
        "vlProgress: at library or scene scope only",
    ))
}

/// Extension. Stops the render in progress, if a scene is rendering: each rendering thread
/// stops within the ray it is tracing (rays look every 4096 samples; no pixel, tile of 32 x 32
/// rays or voxelized node starts after it); the
/// scene's `vlEnd` records `VL_CANCELLED` and writes no file of the output it was making
/// (outputs it finished before are written). Legal anywhere and from any thread (a field
/// function, a progress function, another thread of the program); it never waits. Without a
/// render in progress it does nothing.
#[no_mangle]
pub extern "C" fn vlCancel() {
    ffi_boundary((), || {
        if rendering() {
            cancel_flag().cancel();
        }
        Ok(())
    })
}

/// Extension. Renders the open scene (at scene scope, outside objects) into `buf`, as `vlImage`
/// would render it but without closing the scene or writing a file: `width` x `height` pixels
/// whose view plane has the width / height `aspect`, in the pixel format `format` (`VL_RGB8`,
/// `VL_RGBA8`, `VL_RGB16`, `VL_RGBA16`, `VL_RGB32F`, `VL_RGBA32F`): row-major, top row first,
/// channels interleaved, 16-bit and float values in the machine's byte order, any alignment.
/// RGB formats show the scene over its background; RGBA formats render it against a
/// transparent backdrop, alpha 1 - T (T the transmittance of the pixel's primary ray), with
/// straight colour in the integer formats (as a PNG holds it) and premultiplied colour in
/// `VL_RGBA32F` (docs/images.md). The image takes width * height * (bytes of a pixel) bytes at
/// the start of `buf` (`bytes` is an `unsigned long`, as the header includes no other header
/// for `size_t`); the rest of its `bytes` is left as it is. Returns `VL_TRUE` when the
/// image was rendered, `VL_FALSE` on error (recorded for `vlError`): `VL_BADSCOPE` outside
/// scene scope or while a scene renders, `VL_BADENUM` for an unknown format,
/// `VL_NULLPOINTER` for a NULL `buf`, `VL_BADVALUE` for a size or aspect `vlImage` refuses or
/// a `bytes` too small for the image; such a call writes nothing. The render follows
/// `vlProgress` and stops at `vlCancel` like a scene's (then `VL_CANCELLED`); rows are
/// written as they are finished, so a render that fails after it started leaves the rows
/// finished before it written and the others as they were.
///
/// # Safety
/// `buf` must be NULL or point to `bytes` writable bytes, not accessed by another thread
/// during the call.
#[no_mangle]
pub unsafe extern "C" fn vlRenderBuffer(
    buf: *mut c_void,
    bytes: c_ulong,
    width: vlint,
    height: vlint,
    aspect: vlfloat,
    format: vlint,
) -> vlint {
    ffi_boundary(VL_FALSE, || {
        const NAME: &str = "vlRenderBuffer";
        let state = state_outside_render(NAME)?;
        let scope = || {
            Error::new(
                ErrorCode::BadScope,
                format!("{NAME}: at scene scope (outside objects) only"),
            )
        };
        let lib: &Library = state.as_ref().ok_or_else(scope)?;
        if lib.scope() != vlib_core::Scope::Scene {
            return Err(fail_the_team(lib, scope()));
        }
        let format = PixelFormat::from_raw(format).map_err(|e| fail_the_team(lib, e))?;
        let side = |v: vlint| u32::try_from(v).ok().filter(|&v| v >= 1);
        let (w, h) = match (buf.is_null(), side(width), side(height)) {
            (true, _, _) => return Err(fail_the_team(lib, null(NAME, "buf"))),
            (false, Some(w), Some(h)) => (w, h),
            _ => {
                let e = Error::new(
                    ErrorCode::BadValue,
                    format!("{NAME}: size {width}x{height}"),
                );
                return Err(fail_the_team(lib, e));
            }
        };
        // Only the image's bytes are handed on (a `bytes` too small is the core's error).
        let bytes = usize::try_from(bytes).unwrap_or(usize::MAX);
        let len = format
            .image_bytes(w, h)
            .map_or(bytes, |n| n.min(bytes))
            .min(isize::MAX as usize);
        // SAFETY: `buf` is not NULL and, by the caller's contract, `bytes` ≥ `len` writable
        // bytes that no one else accesses during the call; `len` ≤ isize::MAX. The slice is
        // only written, never read, so its bytes need not have been initialised.
        let buffer = unsafe { std::slice::from_raw_parts_mut(buf.cast::<u8>(), len) };
        let _rendering = Rendering::start(lib.sampler());
        #[cfg(feature = "mpi")]
        let mark = crate::errors::mark();
        let rendered = lib.render_into(w, h, aspect, format, buffer);
        #[cfg(feature = "mpi")]
        crate::mpi::share_errors(lib, mark);
        rendered?;
        Ok(VL_TRUE)
    })
}

/// The error of a `vlRenderBuffer` this rank refuses before the render (a scope, format,
/// buffer or size the C layer checks), `e`. Where `lib` renders with a team (an MPI job), the
/// other ranks wait in the render's first agreement and then share the errors recorded: this
/// rank takes part in both with `e` ([`Library::refuse_render`]), so every rank fails with the
/// error of the first rank that refused, which is what this rank's call then reports. Without
/// a team, `e`.
fn fail_the_team(lib: &Library, e: Error) -> Error {
    #[cfg(feature = "mpi")]
    if lib.team().is_some() {
        let mark = crate::errors::mark();
        let e = lib.refuse_render(e);
        crate::mpi::share_errors(lib, mark);
        return e;
    }
    #[cfg(not(feature = "mpi"))]
    let _ = lib;
    e
}

/// Extension. Chooses how the gradients of dataset fields, which light their samples, are
/// reconstructed from the nodes, for the datasets `vlDataset` casts from now on (it captures
/// the choice with the interpolation): `VL_GRADIENT_NODES` (the default, the paper's: central
/// differences at the nodes, interpolated with the dataset's filter; `b` and `c` are ignored)
/// or `VL_GRADIENT_CUBIC` (the exact gradient of the BC-spline with parameters `b`, `c` of the
/// node values, whatever the interpolation: smooth normals without grid-aligned hatching;
/// 1, 0 is the cubic B-spline's, the smoothest; 0, 0.5 Catmull-Rom's). Legal at library and
/// scene scope; `VL_BADENUM` for another `type`, `VL_BADVALUE` for a `b` or `c` that is not
/// finite.
#[no_mangle]
pub extern "C" fn vlGradientFilter(r#type: vlint, b: vlfloat, c: vlfloat) {
    ffi_boundary((), || {
        const NAME: &str = "vlGradientFilter";
        let mut state = state_outside_render(NAME)?;
        let lib: &mut Library = match state.as_mut() {
            Some(lib) if lib.scope() != vlib_core::Scope::Object => lib,
            _ => {
                return Err(Error::new(
                    ErrorCode::BadScope,
                    format!("{NAME}: at library or scene scope only"),
                ))
            }
        };
        let gradient = match r#type {
            VL_GRADIENT_NODES => GradientFilter::Nodes,
            VL_GRADIENT_CUBIC => GradientFilter::Cubic { b, c },
            t => {
                return Err(Error::new(
                    ErrorCode::BadEnum,
                    format!("{NAME}: {t} is not a gradient filter"),
                ))
            }
        };
        lib.gradient_filter(gradient)
    })
}

/// Extension. The version of the running library, major * 1000000 + minor * 1000 + patch:
/// the encoding of `VLIB_VERSION`, which holds the version of the header a program was
/// compiled with, so `vlVersion() == VLIB_VERSION` when the program runs with the library
/// of its header. Legal at any time and from any thread (before `vlInit`, after the final
/// `vlEnd`, while a scene renders, in field and progress functions); it needs no state and
/// records no error.
#[no_mangle]
pub extern "C" fn vlVersion() -> vlint {
    ffi_boundary(VLIB_VERSION, || Ok(VLIB_VERSION))
}
