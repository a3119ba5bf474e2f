//! The data commands: loading and freeing datasets, sampling them, and declaring transfer
//! functions. Each converts its C arguments and calls the core, which reads the files and owns
//! the datasets and mappings.

use crate::ffi::{c_path, either, ffi_boundary, library, null, render_sampler};
use crate::types::{vlfloat, vlint};
use std::os::raw::c_char;
use vlib_core::limits::{MAX_OUTPUTS, MAX_POINTS};
use vlib_core::{Command, Error, ErrorCode, MappingType, Result};
use vlib_core::{DatasetId, MappingId};

/// Loads a `.vlb` dataset under the id `id`.
///
/// # Safety
/// `file` must be NULL or a NUL-terminated string.
#[no_mangle]
pub unsafe extern "C" fn vlLoad(id: vlint, file: *const c_char) {
    ffi_boundary((), || {
        library(Command::Load, |lib| {
            // SAFETY: `file` is NULL or NUL-terminated by the caller's contract.
            let path = unsafe { c_path(Command::Load.name(), "file", file) }?;
            lib.load(DatasetId(id), path)
        })
    })
}

/// Frees the dataset `id`.
#[no_mangle]
pub extern "C" fn vlUnload(id: vlint) {
    ffi_boundary((), || {
        library(Command::Unload, |lib| lib.unload(DatasetId(id)))
    })
}

/// The normalised value of dataset `id` at dataset coordinates (x, y, z) in [0, 1]^3; 0 on
/// error.
#[no_mangle]
pub extern "C" fn vlSample(id: vlint, x: vlfloat, y: vlfloat, z: vlfloat) -> vlfloat {
    ffi_boundary(0.0, || sample(id, x, y, z))
}

/// `vlSample` inside the caller's panic boundary (`VLU_SWEEP` samples through it).
pub(crate) fn sample(id: vlint, x: vlfloat, y: vlfloat, z: vlfloat) -> Result<vlfloat> {
    // A thread outside sample scope during a render (a field function's helper thread) samples
    // the rendering scene's datasets without waiting for the state the render holds.
    if !crate::sample::active() {
        if let Some(s) = render_sampler() {
            return s.sample(DatasetId(id), x, y, z);
        }
    }
    let sampled = either(
        Command::Sample,
        |s| s.dataset(DatasetId(id), [x, y, z]),
        |lib| lib.sample(DatasetId(id), x, y, z),
    );
    // A render that started while this waited for the state: its datasets, as above.
    if let Err(e) = &sampled {
        if e.code == ErrorCode::BadScope && !crate::sample::active() {
            if let Some(s) = render_sampler() {
                return s.sample(DatasetId(id), x, y, z);
            }
        }
    }
    sampled
}

/// Declares transfer function `id`, `VL_LOOKUP` or `VL_RAMP`: `table` holds `points` rows of
/// (a, b_1 … b_outputs), the a strictly increasing.
///
/// # Safety
/// `table` must be NULL or point to `points * (outputs + 1)` floats.
#[no_mangle]
pub unsafe extern "C" fn vlMapping(
    id: vlint,
    r#type: vlint,
    points: vlint,
    outputs: vlint,
    table: *const vlfloat,
) {
    ffi_boundary((), || {
        library(Command::Mapping, |lib| {
            let kind = MappingType::from_raw(r#type)?;
            if table.is_null() {
                return Err(null(Command::Mapping.name(), "table"));
            }
            // The sizes are checked before the length is computed, so no huge slice is ever formed.
            if points < 1
                || points as usize > MAX_POINTS
                || outputs < 1
                || outputs as usize > MAX_OUTPUTS
            {
                return Err(Error::new(
                ErrorCode::BadValue,
                format!(
                    "vlMapping: {points} points, {outputs} outputs (must be 1 … {MAX_POINTS} and 1 … {MAX_OUTPUTS})"
                ),
            ));
            }
            let len = points as usize * (outputs as usize + 1);
            // SAFETY: non-NULL, and `len` floats long by the caller's contract.
            let table = unsafe { std::slice::from_raw_parts(table, len) };
            lib.mapping(MappingId(id), kind, points, outputs, table)
        })
    })
}
