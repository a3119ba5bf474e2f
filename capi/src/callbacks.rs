//! C callbacks as core closures: the wrappers that enter sample scope and call the C function.
//! When and on which thread they run is the core's renderer's decision; the commands that
//! receive the pointers (`object`) check them for NULL.
//!
//! `vlFunction`, `vlNormal` and `vlSpatial` receive a C function pointer and a `misc` pointer. They
//! are wrapped into the closures the core stores; each call enters sample scope for the sample
//! being evaluated (see [`crate::sample`]) so that `vlSet`, `vlField` and friends reach it.

use crate::sample::Enter;
use crate::types::vlfloat;
use std::os::raw::c_void;
use std::sync::Arc;
use vlib_core::Sample;

/// A C field function (also the form of a spatial transfer function), as the commands receive
/// it: `p` is the current point in object space, `misc` the pointer given with the function.
/// The exported signatures spell this type out so that the header shows the plain C type.
pub(crate) type FieldFn = Option<unsafe extern "C" fn(p: *mut vlfloat, misc: *mut c_void)>;

/// A C normal function: may rewrite the normal `n` at object-space point `p`.
pub(crate) type NormalFn =
    Option<unsafe extern "C" fn(n: *mut vlfloat, p: *mut vlfloat, misc: *mut c_void)>;

/// A C field function with its `misc` pointer.
#[derive(Clone, Copy)]
pub(crate) struct CField {
    f: unsafe extern "C" fn(p: *mut vlfloat, misc: *mut c_void),
    misc: *mut c_void,
}

// SAFETY: the renderer calls field functions concurrently from worker threads; the API documents
// that C field functions (and whatever their `misc` points to) must be thread-safe. We never
// dereference `misc` ourselves.
unsafe impl Send for CField {}
// SAFETY: as above.
unsafe impl Sync for CField {}

impl CField {
    /// Wraps a non-NULL function; `None` for NULL.
    pub(crate) fn new(f: FieldFn, misc: *mut c_void) -> Option<CField> {
        f.map(|f| CField { f, misc })
    }

    /// The core closure: enters sample scope and calls `f` with a copy of the object-space point.
    pub(crate) fn into_core(self) -> vlib_core::FieldFn {
        // A method call captures the whole wrapper (not its raw-pointer fields one by one).
        Arc::new(move |s: &mut Sample<'_>| self.call(s))
    }

    fn call(&self, s: &mut Sample<'_>) {
        let mut p = s.position();
        let _scope = Enter::new(s);
        // SAFETY: `f` is a valid C function by the contract of `vlFunction`; `p` is 3 floats.
        unsafe { (self.f)(p.as_mut_ptr(), self.misc) }
    }
}

/// A C spatial transfer function with its `misc` pointer: it may rewrite the point in place.
#[derive(Clone, Copy)]
pub(crate) struct CSpatial(CField);

impl CSpatial {
    /// Wraps a non-NULL function; `None` for NULL.
    pub(crate) fn new(f: FieldFn, misc: *mut c_void) -> Option<CSpatial> {
        CField::new(f, misc).map(CSpatial)
    }

    /// The core closure: calls `f` on a copy of the point and moves the sample to wherever `f`
    /// left it (a non-finite point is refused and recorded).
    pub(crate) fn into_core(self) -> vlib_core::FieldFn {
        // A method call captures the whole wrapper (not its raw-pointer fields one by one).
        Arc::new(move |s: &mut Sample<'_>| self.call(s))
    }

    fn call(&self, s: &mut Sample<'_>) {
        let mut p = s.position();
        {
            let _scope = Enter::new(s);
            // SAFETY: a valid C function by the contract of `vlSpatial`; `p` is 3 floats.
            unsafe { (self.0.f)(p.as_mut_ptr(), self.0.misc) }
        }
        if p != s.position() {
            if let Err(e) = s.set_position(p) {
                crate::errors::record(e);
            }
        }
    }
}

/// A C normal function with its `misc` pointer.
#[derive(Clone, Copy)]
pub(crate) struct CNormal {
    f: unsafe extern "C" fn(n: *mut vlfloat, p: *mut vlfloat, misc: *mut c_void),
    misc: *mut c_void,
}

// SAFETY: as for `CField`: C normal functions must be thread-safe.
unsafe impl Send for CNormal {}
// SAFETY: as above.
unsafe impl Sync for CNormal {}

impl CNormal {
    /// Wraps a non-NULL function; `None` for NULL.
    pub(crate) fn new(f: NormalFn, misc: *mut c_void) -> Option<CNormal> {
        f.map(|f| CNormal { f, misc })
    }

    /// The core closure: enters sample scope and calls `f` on the normal and a copy of the point.
    pub(crate) fn into_core(self) -> vlib_core::NormalFn {
        Arc::new(move |n: &mut [f32; 3], s: &mut Sample<'_>| self.call(n, s))
    }

    fn call(&self, n: &mut [f32; 3], s: &mut Sample<'_>) {
        let mut p = s.position();
        let _scope = Enter::new(s);
        // SAFETY: `f` is a valid C function by the contract of `vlNormal`; `n` and `p` are
        // 3 floats each.
        unsafe { (self.f)(n.as_mut_ptr(), p.as_mut_ptr(), self.misc) }
    }
}
