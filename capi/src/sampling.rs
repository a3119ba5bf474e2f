//! The sampling commands: what a field or normal function may ask about the current point. They
//! read the current sample (`sample`); the core computes every answer.
//!
//! All of them are legal only in sample scope; elsewhere they record `VL_BADSCOPE`. Children are
//! counted from 1 in declaration order; a bad index records `VL_BADINDEX`.

use crate::ffi::{either, ffi_boundary, never, null};
use crate::types::{vlfloat, vlint};
use vlib_core::{Command, Fields};

/// Inside a field or normal function: the current value of one field at this point; 0 on error.
#[no_mangle]
pub extern "C" fn vlField(field: vlint) -> vlfloat {
    ffi_boundary(0.0, || {
        either(
            Command::Field,
            |s| s.field(Fields::from_raw(field)?),
            |_| never(Command::Field),
        )
    })
}

/// Inside a field or normal function: writes the world-space position of the current point.
///
/// # Safety
/// `world` must be NULL or point to 3 writable floats.
#[no_mangle]
pub unsafe extern "C" fn vlPosition(world: *mut vlfloat) {
    ffi_boundary((), || {
        either(
            Command::Position,
            |s| {
                if world.is_null() {
                    return Err(null(Command::Position.name(), "world"));
                }
                let w = s.world_position();
                // SAFETY: non-NULL and 3 writable floats by the caller's contract.
                unsafe { std::ptr::copy_nonoverlapping(w.as_ptr(), world, 3) };
                Ok(())
            },
            |_| never(Command::Position),
        )
    })
}

/// Inside a field function: the number of children of the object being evaluated.
#[no_mangle]
pub extern "C" fn vlChildCount() -> vlint {
    ffi_boundary(0, || {
        either(
            Command::ChildCount,
            |s| Ok(s.child_count() as vlint),
            |_| never(Command::ChildCount),
        )
    })
}

/// Inside a field function: whether the current point lies inside child `child` (from 1);
/// `VL_TRUE` or `VL_FALSE`.
#[no_mangle]
pub extern "C" fn vlChildHit(child: vlint) -> vlint {
    ffi_boundary(0, || {
        either(
            Command::ChildHit,
            |s| s.child_hit(child).map(vlint::from),
            |_| never(Command::ChildHit),
        )
    })
}

/// Inside a field function: a field of child `child` (from 1) at the current point, from the
/// child's own program in the child's space (0 outside its boundary).
#[no_mangle]
pub extern "C" fn vlChildField(child: vlint, field: vlint) -> vlfloat {
    ffi_boundary(0.0, || {
        either(
            Command::ChildField,
            |s| s.child_field(child, Fields::from_raw(field)?),
            |_| never(Command::ChildField),
        )
    })
}

/// Inside a normal function: writes the world-space normal of child `child` (from 1) at the
/// current point.
///
/// # Safety
/// `n` must be NULL or point to 3 writable floats.
#[no_mangle]
pub unsafe extern "C" fn vlChildNormal(child: vlint, n: *mut vlfloat) {
    ffi_boundary((), || {
        either(
            Command::ChildNormal,
            |s| {
                s.may_take_child_normals()?;
                if n.is_null() {
                    return Err(null(Command::ChildNormal.name(), "n"));
                }
                let v = s.child_normal(child)?;
                // SAFETY: non-NULL and 3 writable floats by the caller's contract.
                unsafe { std::ptr::copy_nonoverlapping(v.as_ptr(), n, 3) };
                Ok(())
            },
            |_| never(Command::ChildNormal),
        )
    })
}
