//! The sample context: which [`Sample`] the C callback running on this thread belongs to. It
//! owns the thread-local pointer only; what a sample holds and which commands are legal in
//! sample scope are the core's.
//!
//! While the renderer calls a C field or normal function, a thread-local pointer names the
//! sample being evaluated; this is the C API's *sample scope*. Commands test it before anything
//! else: in sample scope they must not lock the library state, which the rendering `vlEnd` holds
//! for the whole render. The pointer is set only by [`Enter`], whose `Drop` restores the previous
//! value, so it is reset even if the callback's wrapper unwinds.

use std::cell::Cell;
use std::ptr;
use vlib_core::Sample;

thread_local! {
    // The lifetime is erased: the pointer is only dereferenced while the `Enter` guard that set
    // it is alive, which is within the borrow the renderer handed to the callback.
    static CURRENT: Cell<*mut Sample<'static>> = const { Cell::new(ptr::null_mut()) };
}

/// Marks this thread as evaluating `sample` until dropped.
pub(crate) struct Enter {
    previous: *mut Sample<'static>,
}

impl Enter {
    /// Enters sample scope. `sample` must stay valid, and must not be used through any other
    /// reference, until the returned guard is dropped.
    pub(crate) fn new(sample: *mut Sample<'_>) -> Enter {
        let erased = sample.cast::<Sample<'static>>();
        Enter {
            previous: CURRENT.with(|c| c.replace(erased)),
        }
    }
}

impl Drop for Enter {
    fn drop(&mut self) {
        CURRENT.with(|c| c.set(self.previous));
    }
}

/// Whether this thread is in sample scope.
pub(crate) fn active() -> bool {
    !CURRENT.with(|c| c.get()).is_null()
}

/// Runs `f` on the current sample, or returns `None` outside sample scope.
pub(crate) fn with_current<R>(f: impl FnOnce(&mut Sample<'_>) -> R) -> Option<R> {
    let p = CURRENT.with(|c| c.get());
    if p.is_null() {
        return None;
    }
    // SAFETY: `p` was set by `Enter::new` from the `&mut Sample` the renderer handed to the
    // callback wrapper, which does not touch it again until the guard is dropped; the callback
    // runs on this thread, and no command calls user code while holding this reference, so it is
    // the only live reference.
    Some(f(unsafe { &mut *p }))
}

#[cfg(test)]
mod tests;
