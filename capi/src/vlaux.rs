//! vlaux, the auxiliary library (`vlaux.h`): camera shorthand, noise, turbulence, splines and
//! ready-made field functions, all thin wrappers over `vlib_core::vlaux` and `vlib_core::cvg`,
//! which own the algorithms. `vlaux.h` is written by hand; cbindgen never reads this module (its
//! `mod` line in `lib.rs` carries `cbindgen:ignore`), so nothing here reaches `vlib.h`.
//!
//! These are not commands and have no scope of their own, except that the field functions write
//! as `vlSet` does, `vluCamera` sets the camera as `vlCamera` does, and the CVG operators
//! (`VLU_UNION`, `VLU_INTERSECTION`, `VLU_DIFFERENCE`, `VLU_BLEND`) work only inside a field
//! function (elsewhere `VL_BADSCOPE`). Errors (NULL pointers, bad counts) are recorded for
//! `vlError` and yield 0. Like every export, each function's body is one `ffi_boundary` call.

use crate::data;
use crate::errors;
use crate::ffi::{ffi_boundary, library, null, read_floats};
use crate::object;
use crate::sample;
use crate::types::{vlfloat, vlint, VL_ALLFIELDS};
use std::os::raw::c_void;
use vlib_core::cvg::Operator;
use vlib_core::DatasetId;
use vlib_core::{Camera, Command, Error, ErrorCode, Fields, Result, SampleRole};

/// The most knots `vluSpline` accepts.
pub const MAX_SPLINE_KNOTS: vlint = 1 << 16;

/// Sets the camera at eye (ex, ey, ez) looking at (lx, ly, lz), +y up, default field of view:
/// `vlCamera` with that camera (its scope, its checks, its errors).
#[no_mangle]
pub extern "C" fn vluCamera(
    ex: vlfloat,
    ey: vlfloat,
    ez: vlfloat,
    lx: vlfloat,
    ly: vlfloat,
    lz: vlfloat,
) {
    ffi_boundary((), || {
        library(Command::Camera, |lib| {
            lib.camera(&Camera {
                eye: [ex, ey, ez],
                at: [lx, ly, lz],
                up: [0.0, 1.0, 0.0],
                fov: vlib_core::DEFAULT_FOV,
            })
        })
    })
}

/// Places the current object where dataset `id`'s nodes lie in physical space
/// (`Library::place_dataset`: its scope, its checks, its errors).
#[no_mangle]
pub extern "C" fn vluPlace(id: vlint) {
    ffi_boundary((), || {
        library(Command::Matrix, |lib| lib.place_dataset(DatasetId(id)))
    })
}

/// Perlin noise in [-1, 1] at `p * size`, with a seeded permutation (0 = Perlin's).
///
/// # Safety
/// `p` must be NULL or point to 3 floats.
#[no_mangle]
pub unsafe extern "C" fn vluNoise(p: *const vlfloat, size: vlfloat, seed: vlint) -> vlfloat {
    ffi_boundary(0.0, || {
        // SAFETY: `p` is NULL or 3 floats long by the caller's contract.
        let p = unsafe { read_floats::<3>("vluNoise", "p", p) }?;
        Ok(vlib_core::vlaux::noise(p, size, seed))
    })
}

/// Perlin turbulence in [0, 2): the sum of |noise| over `octaves` octaves from `size`.
///
/// # Safety
/// `p` must be NULL or point to 3 floats.
#[no_mangle]
pub unsafe extern "C" fn vluTurbulence(
    p: *const vlfloat,
    size: vlfloat,
    octaves: vlint,
    seed: vlint,
) -> vlfloat {
    ffi_boundary(0.0, || {
        // SAFETY: `p` is NULL or 3 floats long by the caller's contract.
        let p = unsafe { read_floats::<3>("vluTurbulence", "p", p) }?;
        Ok(vlib_core::vlaux::turbulence(p, size, octaves, seed))
    })
}

/// The Catmull-Rom spline through `count` knots at `v` in [0, 1]. A negative count or more than
/// 65536 knots is `VL_BADVALUE`; NULL knots with a positive count is `VL_NULLPOINTER`.
///
/// # Safety
/// `knots` must be NULL or point to `count` floats.
#[no_mangle]
pub unsafe extern "C" fn vluSpline(v: vlfloat, count: vlint, knots: *const vlfloat) -> vlfloat {
    ffi_boundary(0.0, || {
        if !(0..=MAX_SPLINE_KNOTS).contains(&count) {
            return Err(Error::new(
                ErrorCode::BadValue,
                format!("vluSpline: {count} knots (must be 0 … {MAX_SPLINE_KNOTS})"),
            ));
        }
        if count == 0 {
            return Ok(vlib_core::vlaux::spline(v, &[]));
        }
        if knots.is_null() {
            return Err(null("vluSpline", "knots"));
        }
        // SAFETY: non-NULL and `count` floats long by the caller's contract (count ≤ 65536).
        let knots = unsafe { std::slice::from_raw_parts(knots, count as usize) };
        Ok(vlib_core::vlaux::spline(v, knots))
    })
}

/// Evaluates `field` at `p` and writes the value as `vlSet(VL_ALLFIELDS, value)` does: in a field
/// function, to the fields its `vlFunction` call named.
///
/// # Safety
/// `p` must be NULL or point to 3 floats.
unsafe fn set_all(name: &str, p: *mut vlfloat, field: fn([f32; 3]) -> f32) -> Result<()> {
    // SAFETY: `p` is NULL or 3 floats long by the caller's contract.
    let p = unsafe { read_floats::<3>(name, "p", p) }?;
    object::set(VL_ALLFIELDS, field(p))
}

/// Field function: the paraboloid 1 − 4·|p − c|² about the cube centre c (0 outside the
/// inscribed sphere), written through `vlSet(VL_ALLFIELDS, …)`. `misc` is not read.
///
/// # Safety
/// `p` must be NULL or point to 3 floats.
#[no_mangle]
pub unsafe extern "C" fn VL_PARAB1(p: *mut vlfloat, _misc: *mut c_void) {
    ffi_boundary((), || {
        // SAFETY: `p` is NULL or 3 floats long by the caller's contract.
        unsafe { set_all("VL_PARAB1", p, vlib_core::vlaux::parab1) }
    })
}

/// Field function: the spherical distance field 1 − 2·|p − c|, written through
/// `vlSet(VL_ALLFIELDS, …)`. `misc` is not read.
///
/// # Safety
/// `p` must be NULL or point to 3 floats.
#[no_mangle]
pub unsafe extern "C" fn VLU_SPHERE(p: *mut vlfloat, _misc: *mut c_void) {
    ffi_boundary((), || {
        // SAFETY: `p` is NULL or 3 floats long by the caller's contract.
        unsafe { set_all("VLU_SPHERE", p, vlib_core::vlaux::sphere) }
    })
}

/// Field function: the cylindrical distance field about the z axis through the cube centre,
/// written through `vlSet(VL_ALLFIELDS, …)`. `misc` is not read.
///
/// # Safety
/// `p` must be NULL or point to 3 floats.
#[no_mangle]
pub unsafe extern "C" fn VLU_CYLINDER(p: *mut vlfloat, _misc: *mut c_void) {
    ffi_boundary((), || {
        // SAFETY: `p` is NULL or 3 floats long by the caller's contract.
        unsafe { set_all("VLU_CYLINDER", p, vlib_core::vlaux::cylinder) }
    })
}

/// Field function: the rotational sweep of a 2D profile dataset about the vertical axis through
/// (0.5, ·, 0.5). `misc` points to a `vlint` holding the id of a loaded profile (nx × ny × 1:
/// x from the axis to the rim, y the height). At p, with r the distance from the axis, the value
/// is `vlSample(id, 2r, p[1], 0)` for 2r ≤ 1 and 0 outside, written through
/// `vlSet(VL_ALLFIELDS, …)`. NULL `misc` (or `p`) records `VL_NULLPOINTER` and writes nothing;
/// an unknown id records `VL_BADID` (as `vlSample`) and writes 0.
///
/// # Safety
/// `p` must be NULL or point to 3 floats; `misc` NULL or point to a `vlint`.
#[no_mangle]
pub unsafe extern "C" fn VLU_SWEEP(p: *mut vlfloat, misc: *mut c_void) {
    ffi_boundary((), || {
        // SAFETY: `p` is NULL or 3 floats long by the caller's contract.
        let p = unsafe { read_floats::<3>("VLU_SWEEP", "p", p) }?;
        if misc.is_null() {
            return Err(null("VLU_SWEEP", "misc"));
        }
        // SAFETY: non-NULL and pointing to a vlint by the caller's contract; no alignment assumed.
        let id = unsafe { std::ptr::read_unaligned(misc as *const vlint) };
        // In a field function (the intended use) the core's sweep reads the dataset with the
        // object's interpolation and writes the sample; the value is written even when the id is
        // unknown (0, as vlSample returns).
        let swept = sample::with_current(|s| {
            let v = vlib_core::vlaux::sweep(s, DatasetId(id));
            s.set(Fields::ALL, *v.as_ref().unwrap_or(&0.0))?;
            v.map(|_| ())
        });
        if let Some(result) = swept {
            return result;
        }
        // Elsewhere it behaves as the same vlSample and vlSet calls would (vlSample reads the
        // library's datasets, its error is recorded and 0 written; vlSet reports its scope error
        // or, in an object, becomes an instruction), like the other field functions.
        let v = match vlib_core::vlaux::sweep_coords(p) {
            Some(q) => data::sample(id, q[0], q[1], q[2]).unwrap_or_else(|e| {
                errors::record(e);
                0.0
            }),
            None => 0.0,
        };
        object::set(VL_ALLFIELDS, v)
    })
}

/// Runs the CVG operator `op` (`docs/cvg.md`) on the current sample: it reads every child of the
/// object being evaluated and writes the fields the running `vlFunction` call named. Outside a
/// field function (library, scene or object scope, a normal or spatial function) it is
/// `VL_BADSCOPE`, as `vlChildCount` and the other sample-only commands it is made of would be, and
/// changes nothing: unlike `VLU_SPHERE`, an operator has no value to become an object instruction.
fn cvg_operator(name: &str, op: Operator) -> Result<()> {
    sample::with_current(|s| {
        if s.role() != SampleRole::Field {
            return Err(Error::new(
                ErrorCode::BadScope,
                format!("{name} is legal only inside a field function"),
            ));
        }
        vlib_core::cvg::apply(op, s)
    })
    .unwrap_or_else(|| {
        Err(Error::new(
            ErrorCode::BadScope,
            format!("{name} is legal only inside a field function (vlFunction)"),
        ))
    })
}

/// Field function: the CVG union of the children (`docs/cvg.md`): opacity max_i o_i, the other
/// fields from the child of largest opacity. `p` and `misc` are not read.
#[no_mangle]
pub extern "C" fn VLU_UNION(_p: *mut vlfloat, _misc: *mut c_void) {
    ffi_boundary((), || cvg_operator("VLU_UNION", Operator::Union))
}

/// Field function: the CVG intersection of the children (`docs/cvg.md`): opacity min_i o_i, the
/// other fields from the child of smallest opacity. `p` and `misc` are not read.
#[no_mangle]
pub extern "C" fn VLU_INTERSECTION(_p: *mut vlfloat, _misc: *mut c_void) {
    ffi_boundary((), || {
        cvg_operator("VLU_INTERSECTION", Operator::Intersection)
    })
}

/// Field function: the CVG difference, child 1 minus the others (`docs/cvg.md`): opacity
/// min(o_1, 1 − max_{i≥2} o_i), the other fields from child 1. `p` and `misc` are not read.
#[no_mangle]
pub extern "C" fn VLU_DIFFERENCE(_p: *mut vlfloat, _misc: *mut c_void) {
    ffi_boundary((), || cvg_operator("VLU_DIFFERENCE", Operator::Difference))
}

/// Field function: the CVG blend, a smooth union (`docs/cvg.md`): opacity 1 − Π_i (1 − o_i),
/// the other fields the opacity-weighted mean of the children's. `p` and `misc` are not read.
#[no_mangle]
pub extern "C" fn VLU_BLEND(_p: *mut vlfloat, _misc: *mut c_void) {
    ffi_boundary((), || cvg_operator("VLU_BLEND", Operator::Blend))
}
