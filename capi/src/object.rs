//! The object commands: opening an object, its transforms, its boundary and the instructions
//! of its field program (`vlSet`, `vlFunction`, `vlDataset`, `vlMap`), its spatial and normal
//! functions. Each converts its C arguments and calls one method of the core's `Library` (or,
//! for `vlSet` in a field function, of the current sample); C function pointers become core
//! closures in `callbacks`.

use crate::callbacks::{CField, CNormal, CSpatial};
use crate::ffi::{either, ffi_boundary, library, null, read_floats};
use crate::types::{vlfloat, vlint};
use std::os::raw::c_void;
use vlib_core::{Command, DatasetId, Fields, MappingId, Result};

/// Opens an object; it captures the rendering parameters in force.
#[no_mangle]
pub extern "C" fn vlObject() {
    ffi_boundary((), || library(Command::Object, |lib| lib.object()))
}

/// Scales the object (non-zero factors).
#[no_mangle]
pub extern "C" fn vlScale(x: vlfloat, y: vlfloat, z: vlfloat) {
    ffi_boundary((), || library(Command::Scale, |lib| lib.scale(x, y, z)))
}

/// Translates the object.
#[no_mangle]
pub extern "C" fn vlTranslate(x: vlfloat, y: vlfloat, z: vlfloat) {
    ffi_boundary((), || {
        library(Command::Translate, |lib| lib.translate(x, y, z))
    })
}

/// Rotates the object by degrees about x, then y, then z.
#[no_mangle]
pub extern "C" fn vlRotate(x: vlfloat, y: vlfloat, z: vlfloat) {
    ffi_boundary((), || library(Command::Rotate, |lib| lib.rotate(x, y, z)))
}

/// Mirrors object space (p → 1 − p) on the axes `VL_X | VL_Y | VL_Z` named.
#[no_mangle]
pub extern "C" fn vlFlip(axes: vlint) {
    ffi_boundary((), || library(Command::Flip, |lib| lib.flip(axes)))
}

/// Applies a general affine 4×4 transform, row-major (bottom row 0 0 0 1).
///
/// # Safety
/// `m` must be NULL or point to 16 floats.
#[no_mangle]
pub unsafe extern "C" fn vlMatrix(m: *const vlfloat) {
    ffi_boundary((), || {
        library(Command::Matrix, |lib| {
            // SAFETY: `m` is NULL or 16 floats long by the caller's contract.
            let m = unsafe { read_floats::<16>(Command::Matrix.name(), "m", m) }?;
            lib.matrix(&m)
        })
    })
}

/// Scales the object's boundary box about its centre without scaling the object.
#[no_mangle]
pub extern "C" fn vlBoundary(x: vlfloat, y: vlfloat, z: vlfloat) {
    ffi_boundary((), || {
        library(Command::Boundary, |lib| lib.boundary(x, y, z))
    })
}

/// Adds a spatial transfer function, which may rewrite p for the instructions after it.
///
/// # Safety
/// `f` must be NULL or a function that is safe to call concurrently with `misc`.
#[no_mangle]
pub unsafe extern "C" fn vlSpatial(
    f: Option<unsafe extern "C" fn(p: *mut vlfloat, misc: *mut c_void)>,
    misc: *mut c_void,
) {
    ffi_boundary((), || {
        library(Command::Spatial, |lib| {
            let f = CSpatial::new(f, misc).ok_or_else(|| null(Command::Spatial.name(), "f"))?;
            lib.spatial_arc(f.into_core())
        })
    })
}

/// In an object: an instruction assigning `value` to `fields`. In a field function: assigns
/// `value` at the current point to the fields of `fields` that the `vlFunction` call named.
/// Values are clamped to [0, 1]; NaN becomes 0.
#[no_mangle]
pub extern "C" fn vlSet(fields: vlint, value: vlfloat) {
    ffi_boundary((), || set(fields, value))
}

/// `vlSet` inside the caller's panic boundary (the vlaux field functions write through it).
pub(crate) fn set(fields: vlint, value: vlfloat) -> Result<()> {
    either(
        Command::Set,
        // (The function's role first: a normal or spatial function's vlSet is VL_BADSCOPE
        // whatever its mask.)
        |s| {
            s.may_set()?;
            s.set(Fields::from_raw(fields)?, value)
        },
        |lib| lib.set(Fields::from_raw(fields)?, value),
    )
}

/// An instruction running the field function `f` at every sample point; it may write `fields`.
///
/// # Safety
/// `f` must be NULL or a function that is safe to call concurrently from several threads with
/// `misc`, for as long as the scene that uses it is being rendered.
#[no_mangle]
pub unsafe extern "C" fn vlFunction(
    fields: vlint,
    f: Option<unsafe extern "C" fn(p: *mut vlfloat, misc: *mut c_void)>,
    misc: *mut c_void,
) {
    ffi_boundary((), || {
        library(Command::Function, |lib| {
            // (The mask, the first parameter, before the function pointer.)
            let fields = Fields::from_raw(fields)?;
            let f = CField::new(f, misc).ok_or_else(|| null(Command::Function.name(), "f"))?;
            lib.function_arc(fields, f.into_core())
        })
    })
}

/// An instruction casting dataset `id` to `fields`, with the interpolation in force now.
#[no_mangle]
pub extern "C" fn vlDataset(fields: vlint, id: vlint) {
    ffi_boundary((), || {
        library(Command::Dataset, |lib| {
            lib.dataset(Fields::from_raw(fields)?, DatasetId(id))
        })
    })
}

/// An instruction: `targets` = Φ(`mapping`)(value of field `source`), output `output` (from 1).
#[no_mangle]
pub extern "C" fn vlMap(targets: vlint, source: vlint, mapping: vlint, output: vlint) {
    ffi_boundary((), || {
        library(Command::Map, |lib| {
            lib.map(
                Fields::from_raw(targets)?,
                Fields::from_raw(source)?,
                MappingId(mapping),
                output,
            )
        })
    })
}

/// Appends a normal function to the object's chain; it may rewrite the normal n at point p.
///
/// # Safety
/// `f` must be NULL or a function that is safe to call concurrently from several threads with
/// `misc`.
#[no_mangle]
pub unsafe extern "C" fn vlNormal(
    f: Option<unsafe extern "C" fn(n: *mut vlfloat, p: *mut vlfloat, misc: *mut c_void)>,
    misc: *mut c_void,
) {
    ffi_boundary((), || {
        library(Command::Normal, |lib| {
            let f = CNormal::new(f, misc).ok_or_else(|| null(Command::Normal.name(), "f"))?;
            lib.normal_arc(f.into_core())
        })
    })
}
