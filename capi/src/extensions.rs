//! The extensions: C functions beyond the 44 commands of the paper's API, declared after them
//! in `include/vlib.h` under their own banner and listed in `commands::EXTENSIONS`
//! (`docs/extensions.md`). A program that uses none of them sees the paper's API unchanged.
//!
//! - `vlProgress` registers a progress function for the renders of the library's scenes.
//! - `vlCancel` stops the render in progress, from any thread.
//!
//! The core's [`vlib_core::RenderControl`] does the work; this module holds the C forms: the
//! process's cancel flag and the wrapper of the C progress function.

use crate::ffi::{ffi_boundary, lock_state, rendering};
use crate::sample;
use crate::types::{vlfloat, vlint};
use std::os::raw::c_void;
use std::sync::{Arc, OnceLock};
use vlib_core::{CancelFlag, Error, ErrorCode, Library, RenderControl, Result};

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
/// done, in [0, 1] and never decreasing (after each strip of image rows and each slab of
/// voxelized nodes, and with 1 at the end, also where an output failed), on one of the
/// library's rendering threads (the thread that called `vlEnd` waits meanwhile), one call at
/// a time. Returning 0 cancels the render: its `vlEnd` records `VL_CANCELLED` and writes no
/// file of the output it was making. Inside `f` only `vlCancel`, `vlSample`, `vlError` and
/// `vlErrorString` are legal. NULL removes the function. Legal at library and scene scope;
/// kept until the library's final `vlEnd`.
#[no_mangle]
pub extern "C" fn vlProgress(
    f: Option<unsafe extern "C" fn(done: vlfloat, misc: *mut c_void) -> vlint>,
    misc: *mut c_void,
) {
    ffi_boundary((), || {
        if sample::active() || rendering() {
            return Err(Error::new(
                ErrorCode::BadScope,
                "vlProgress: not while a scene renders",
            ));
        }
        let mut state = lock_state();
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
/// stops after the pixel (or tile of 32 x 32 rays, or voxelized node) it is working on; the
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
