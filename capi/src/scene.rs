//! The scene commands: opening a scene, its outputs (image, voxelization), the camera, the
//! lights and the rendering parameters. Each converts its C arguments and calls one method of
//! the core's `Library`, which checks the scope and the values and owns what they mean.

use crate::ffi::{c_path, ffi_boundary, library, null};
use crate::types::{vlfloat, vlint, VLCAMERA, VL_FALSE, VL_TRUE};
use std::os::raw::c_char;
use vlib_core::{
    Attenuation, Camera, Command, Error, ErrorCode, Feature, Fields, Interpolation, RenderType,
};

/// Opens a scene; it starts from the settings made at library scope.
#[no_mangle]
pub extern "C" fn vlScene() {
    ffi_boundary((), || library(Command::Scene, |lib| lib.scene()))
}

/// Requests an image of the scene, written when the scene ends. `aspect` is the view plane's
/// width / height; the format follows the extension: `.ppm` (binary P6) or `.png`.
///
/// # Safety
/// `file` must be NULL or a NUL-terminated string.
#[no_mangle]
pub unsafe extern "C" fn vlImage(
    file: *const c_char,
    aspect: vlfloat,
    width: vlint,
    height: vlint,
) {
    ffi_boundary((), || {
        library(Command::Image, |lib| {
            // SAFETY: `file` is NULL or NUL-terminated by the caller's contract.
            let path = unsafe { c_path(Command::Image.name(), "file", file) }?;
            lib.image(path, aspect, width, height)
        })
    })
}

/// Requests voxelization of the world box (x0..x1, y0..y1, z0..z1) at nx·ny·nz nodes into one
/// `<prefix>_<field>.vlb` file per field of `fields`, with 1 or 2 bytes per voxel.
///
/// # Safety
/// `prefix` must be NULL or a NUL-terminated string.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn vlVolume(
    prefix: *const c_char,
    fields: vlint,
    x0: vlfloat,
    y0: vlfloat,
    z0: vlfloat,
    x1: vlfloat,
    y1: vlfloat,
    z1: vlfloat,
    nx: vlint,
    ny: vlint,
    nz: vlint,
    bytes: vlint,
) {
    ffi_boundary((), || {
        library(Command::Volume, |lib| {
            // SAFETY: `prefix` is NULL or NUL-terminated by the caller's contract.
            let prefix = unsafe { c_path(Command::Volume.name(), "prefix", prefix) }?;
            lib.volume(
                prefix,
                Fields::from_raw(fields)?,
                [x0, y0, z0],
                [x1, y1, z1],
                [nx, ny, nz],
                bytes,
            )
        })
    })
}

/// Sets the camera.
///
/// # Safety
/// `camera` must be NULL or point to a `VLCAMERA`.
#[no_mangle]
pub unsafe extern "C" fn vlCamera(camera: *const VLCAMERA) {
    ffi_boundary((), || {
        library(Command::Camera, |lib| {
            // SAFETY: `camera` is NULL or points to a VLCAMERA by the caller's contract.
            let c =
                unsafe { camera.as_ref() }.ok_or_else(|| null(Command::Camera.name(), "camera"))?;
            lib.camera(&Camera {
                eye: c.eye,
                at: c.at,
                up: c.up,
                fov: c.fov,
            })
        })
    })
}

/// Sets the background colour (components in [0, 1]).
#[no_mangle]
pub extern "C" fn vlBackground(r: vlfloat, g: vlfloat, b: vlfloat) {
    ffi_boundary((), || {
        library(Command::Background, |lib| lib.background(r, g, b))
    })
}

/// Adaptive super-sampling with up to n×n samples per pixel; 1 = one sample per pixel.
#[no_mangle]
pub extern "C" fn vlSuperSample(n: vlint) {
    ffi_boundary((), || {
        library(Command::SuperSample, |lib| lib.super_sample(n))
    })
}

/// Sets the ambient light: colour in [0, 1] and intensity ≥ 0.
#[no_mangle]
pub extern "C" fn vlAmbient(r: vlfloat, g: vlfloat, b: vlfloat, intensity: vlfloat) {
    ffi_boundary((), || {
        library(Command::Ambient, |lib| lib.ambient(r, g, b, intensity))
    })
}

/// Adds a point light: `VL_NOATTENUATION`, `VL_INVERSE` or `VL_INVERSESQUARE`.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub extern "C" fn vlPointLight(
    x: vlfloat,
    y: vlfloat,
    z: vlfloat,
    attenuation: vlint,
    r: vlfloat,
    g: vlfloat,
    b: vlfloat,
    intensity: vlfloat,
) {
    ffi_boundary((), || {
        library(Command::PointLight, |lib| {
            let att = Attenuation::from_raw(attenuation)?;
            lib.point_light([x, y, z], att, [r, g, b], intensity)
        })
    })
}

/// Adds a light travelling in direction (dx, dy, dz).
#[no_mangle]
pub extern "C" fn vlDirectionalLight(
    dx: vlfloat,
    dy: vlfloat,
    dz: vlfloat,
    r: vlfloat,
    g: vlfloat,
    b: vlfloat,
    intensity: vlfloat,
) {
    ffi_boundary((), || {
        library(Command::DirectionalLight, |lib| {
            lib.directional_light([dx, dy, dz], [r, g, b], intensity)
        })
    })
}

/// Selects the rendering algorithm: `VL_DVR` (default), `VL_DSR` or `VL_MIP`.
#[no_mangle]
pub extern "C" fn vlRenderType(r#type: vlint) {
    ffi_boundary((), || {
        library(Command::RenderType, |lib| {
            lib.render_type(RenderType::from_raw(r#type)?)
        })
    })
}

/// Sets the world-space sampling interval and the interval over which opacity is exact. Until it
/// is called, the reference is 1 and each object samples at min(1, d / 256), d the diagonal of
/// its world box (docs/compat.md, "The default step").
#[no_mangle]
pub extern "C" fn vlStepSize(step: vlfloat, reference: vlfloat) {
    ffi_boundary((), || {
        library(Command::StepSize, |lib| lib.step_size(step, reference))
    })
}

/// Adds an iso-surface of one field at `threshold` (for `VL_DSR`).
#[no_mangle]
pub extern "C" fn vlSurface(field: vlint, threshold: vlfloat) {
    ffi_boundary((), || {
        library(Command::Surface, |lib| {
            lib.surface(Fields::from_raw(field)?, threshold)
        })
    })
}

/// Switches a rendering feature (`VL_CASTSHADOWS` …) on (`VL_TRUE`) or off (`VL_FALSE`); any
/// other state is `VL_BADVALUE`.
#[no_mangle]
pub extern "C" fn vlToggle(feature: vlint, state: vlint) {
    ffi_boundary((), || {
        library(Command::Toggle, |lib| {
            let feature = Feature::from_raw(feature)?;
            let on = match state {
                VL_TRUE => true,
                VL_FALSE => false,
                _ => {
                    return Err(Error::new(
                        ErrorCode::BadValue,
                        format!("vlToggle: state {state} (must be VL_TRUE or VL_FALSE)"),
                    ))
                }
            };
            lib.toggle(feature, on)
        })
    })
}

/// Sets the maximum depth of reflection and refraction rays.
#[no_mangle]
pub extern "C" fn vlRecursion(depth: vlint) {
    ffi_boundary((), || {
        library(Command::Recursion, |lib| lib.recursion(depth))
    })
}

/// Selects dataset interpolation: `VL_NEAREST`, `VL_TRILINEAR` (default) or `VL_TRICUBIC`.
#[no_mangle]
pub extern "C" fn vlInterpolationType(r#type: vlint) {
    ffi_boundary((), || {
        library(Command::InterpolationType, |lib| {
            lib.interpolation(Interpolation::from_raw(r#type)?)
        })
    })
}

/// Sets B and C of the tricubic BC-spline filter (default Catmull-Rom: 0, 0.5).
#[no_mangle]
pub extern "C" fn vlCubicFilter(b: vlfloat, c: vlfloat) {
    ffi_boundary((), || {
        library(Command::CubicFilter, |lib| lib.cubic_filter(b, c))
    })
}

/// Sets the central-difference neighbourhood for normals of function-defined geometry.
#[no_mangle]
pub extern "C" fn vlNeighborhood(dx: vlfloat, dy: vlfloat, dz: vlfloat) {
    ffi_boundary((), || {
        library(Command::Neighborhood, |lib| lib.neighborhood(dx, dy, dz))
    })
}
