//! The C types and constants of `vlib.h`.
//!
//! Everything here is written as a literal so that cbindgen can copy it into the header; a
//! compile-time assertion next to each group ties the literal to the core's value (the
//! version numbers: to the package version of `Cargo.toml`), so the C numbers can never drift
//! from the Rust ones. This module owns no behaviour.

#![allow(non_camel_case_types)]

use std::os::raw::{c_float, c_int};

/// A real number of the API.
pub type vlfloat = c_float;
/// An integer of the API (also used for field masks, enumerations and Booleans).
pub type vlint = c_int;
/// A point or direction: x, y, z.
pub type vlvector = [vlfloat; 3];

/// A camera: eye position, look-at point, up vector and the full field of view in degrees across
/// the shorter side of the image (default 60).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VLCAMERA {
    /// Eye position.
    pub eye: [vlfloat; 3],
    /// Point looked at.
    pub at: [vlfloat; 3],
    /// Up direction (not parallel to the view direction).
    pub up: [vlfloat; 3],
    /// Full field of view in degrees, in (0, 180).
    pub fov: vlfloat,
}

// ---------------------------------------------------------------------------------------------
// Booleans

/// True (for `vlToggle`).
pub const VL_TRUE: vlint = 1;
/// False (for `vlToggle`).
pub const VL_FALSE: vlint = 0;

// ---------------------------------------------------------------------------------------------
// Fields (bit flags, combinable with `|`)

/// Opacity.
pub const VL_O: vlint = 1;
/// Red.
pub const VL_R: vlint = 2;
/// Green.
pub const VL_G: vlint = 4;
/// Blue.
pub const VL_B: vlint = 8;
/// Ambient reflection coefficient.
pub const VL_KA: vlint = 16;
/// Diffuse reflection coefficient.
pub const VL_KD: vlint = 32;
/// Specular reflection coefficient.
pub const VL_KS: vlint = 64;
/// Specular exponent, normalised with `VLSPECULAR`.
pub const VL_N: vlint = 128;
/// Index of refraction, normalised with `VLREFRACTION`.
pub const VL_RF: vlint = 256;
/// Geometry: drives normals and iso-surfaces.
pub const VL_F: vlint = 512;
/// `VL_R | VL_G | VL_B`.
pub const VL_COLORS: vlint = 14;
/// All ten fields.
pub const VL_ALLFIELDS: vlint = 1023;

// ---------------------------------------------------------------------------------------------
// Error codes (fixed numbers, never reused)

/// No error.
pub const VL_NOERROR: vlint = 0;
/// The command is not legal in the current scope.
pub const VL_BADSCOPE: vlint = 1;
/// A numeric argument is out of range, NaN or infinite.
pub const VL_BADVALUE: vlint = 2;
/// A field mask is empty, has unknown bits, or names several fields where one is required.
pub const VL_BADFIELD: vlint = 3;
/// An enumerated argument has no meaning.
pub const VL_BADENUM: vlint = 4;
/// A required pointer is NULL.
pub const VL_NULLPOINTER: vlint = 5;
/// No mapping or dataset has this id.
pub const VL_BADID: vlint = 6;
/// The command is valid but not implemented by this version.
pub const VL_UNSUPPORTED: vlint = 7;
/// A file could not be read or written.
pub const VL_IOERROR: vlint = 8;
/// A file's contents or name are malformed or of an unsupported format.
pub const VL_BADFILE: vlint = 9;
/// A requested size exceeds what can be allocated.
pub const VL_NOMEMORY: vlint = 10;
/// An internal failure (a caught panic).
pub const VL_INTERNAL: vlint = 11;
/// An index (mapping output, child number) is out of range.
pub const VL_BADINDEX: vlint = 12;
/// A dataset file does not start with the `.vlb` magic number.
pub const VL_BADMAGIC: vlint = 13;
/// A dataset's dimensions are zero or too large.
pub const VL_BADDIMENSIONS: vlint = 14;
/// A dataset's voxel width is not 1 or 2 bytes.
pub const VL_BADVOXELWIDTH: vlint = 15;
/// A dataset's normalisation a, b is not finite or a = b.
pub const VL_BADRANGE: vlint = 16;
/// A dataset file's size disagrees with its header (truncated or trailing data).
pub const VL_BADSIZE: vlint = 17;
/// Extension: the render was cancelled (`vlCancel`, or a progress function that returned 0).
pub const VL_CANCELLED: vlint = 18;

// ---------------------------------------------------------------------------------------------
// Render types

/// Direct volume rendering (the default).
pub const VL_DVR: vlint = 0;
/// Direct surface rendering of iso-surfaces.
pub const VL_DSR: vlint = 1;
/// Maximum intensity projection.
pub const VL_MIP: vlint = 2;

// ---------------------------------------------------------------------------------------------
// Point-light attenuation

/// No attenuation.
pub const VL_NOATTENUATION: vlint = 0;
/// 1/d.
pub const VL_INVERSE: vlint = 1;
/// 1/d².
pub const VL_INVERSESQUARE: vlint = 2;

// ---------------------------------------------------------------------------------------------
// Toggles

/// The object casts shadows.
pub const VL_CASTSHADOWS: vlint = 0;
/// The object receives shadows.
pub const VL_RECEIVESHADOWS: vlint = 1;
/// The object is seen in reflections.
pub const VL_CASTREFLECTIONS: vlint = 2;
/// The object shows reflections of others.
pub const VL_RECEIVEREFLECTIONS: vlint = 3;
/// The object refracts light.
pub const VL_REFRACT: vlint = 4;
/// The object is seen by primary rays.
pub const VL_VISIBLE: vlint = 5;
/// Normals facing away from the viewer are flipped.
pub const VL_FLIPNORMALS: vlint = 6;
/// Reflections show the background colour.
pub const VL_REFLECTBACKGROUND: vlint = 7;

// ---------------------------------------------------------------------------------------------
// Interpolation

/// Nearest node.
pub const VL_NEAREST: vlint = 0;
/// Trilinear (the default).
pub const VL_TRILINEAR: vlint = 1;
/// Tricubic BC-spline.
pub const VL_TRICUBIC: vlint = 2;

// ---------------------------------------------------------------------------------------------
// Transfer functions

/// Lookup table Φ_t.
pub const VL_LOOKUP: vlint = 0;
/// Linear ramp Φ_r.
pub const VL_RAMP: vlint = 1;

// ---------------------------------------------------------------------------------------------
// Axes (for `vlFlip`, combinable with `|`)

/// The x axis.
pub const VL_X: vlint = 1;
/// The y axis.
pub const VL_Y: vlint = 2;
/// The z axis.
pub const VL_Z: vlint = 4;

// ---------------------------------------------------------------------------------------------
// Pixel formats (extension: `vlRenderBuffer`; docs/images.md)

/// Extension: 8-bit RGB, 3 bytes a pixel, the scene over its background.
pub const VL_RGB8: vlint = 1;
/// Extension: 8-bit RGBA, 4 bytes a pixel, transparent backdrop, straight colour and alpha.
pub const VL_RGBA8: vlint = 2;
/// Extension: 16-bit RGB, 3 native-endian unsigned shorts a pixel.
pub const VL_RGB16: vlint = 3;
/// Extension: 16-bit RGBA, 4 native-endian unsigned shorts a pixel, straight colour.
pub const VL_RGBA16: vlint = 4;
/// Extension: float RGB, 3 native-endian floats a pixel, in [0, 1].
pub const VL_RGB32F: vlint = 5;
/// Extension: float RGBA, 4 native-endian floats a pixel, premultiplied colour and alpha.
pub const VL_RGBA32F: vlint = 6;

// ---------------------------------------------------------------------------------------------
// Gradient filters (extension: `vlGradientFilter`; docs/extensions.md)

/// Extension: the paper's dataset gradients, central differences at the nodes interpolated with
/// the dataset's filter (the default).
pub const VL_GRADIENT_NODES: vlint = 0;
/// Extension: the exact gradient of the BC-spline reconstruction of the node values.
pub const VL_GRADIENT_CUBIC: vlint = 1;

// ---------------------------------------------------------------------------------------------
// Version (extension: `vlVersion`; docs/extensions.md). The package version of `Cargo.toml`,
// written out (cbindgen cannot evaluate `env!`) and checked against it below, with
// `VLIB_VERSION` its encoding.

/// Extension: the major version of the library this header belongs to (the number in the
/// shared library's SONAME, `libvlib.so.<major>`).
pub const VLIB_VERSION_MAJOR: vlint = 0;
/// Extension: the minor version of the library this header belongs to (0 ... 999).
pub const VLIB_VERSION_MINOR: vlint = 1;
/// Extension: the patch version of the library this header belongs to (0 ... 999).
pub const VLIB_VERSION_PATCH: vlint = 0;
/// Extension: the version of the library this header belongs to as one number,
/// major * 1000000 + minor * 1000 + patch, the encoding `vlVersion` returns.
pub const VLIB_VERSION: vlint = 1000;

// ---------------------------------------------------------------------------------------------
// Normalisation of the specular exponent and the refraction index

/// The specular exponent that the field value 1 stands for.
pub const VL_MAXSPECULAR: vlfloat = 128.0;
/// The refraction index that the field value 1 stands for.
pub const VL_MAXREFRACTION: vlfloat = 3.0;

// ---------------------------------------------------------------------------------------------
// The literals above against the core (compile-time).

mod checks {
    use super::*;
    use vlib_core::types::{axes, FIELD_COUNT, FIELD_NAMES, MAX_REFRACTION, MAX_SPECULAR};
    use vlib_core::{
        Attenuation, ErrorCode, Feature, Interpolation, MappingType, PixelFormat, RenderType,
    };

    macro_rules! same {
        ($($c:expr => $core:expr),+ $(,)?) => { $(const _: () = assert!($c as i64 == $core as i64);)+ };
    }

    /// String equality usable in constants.
    const fn eq(a: &str, b: &str) -> bool {
        let (a, b) = (a.as_bytes(), b.as_bytes());
        if a.len() != b.len() {
            return false;
        }
        let mut i = 0;
        while i < a.len() {
            if a[i] != b[i] {
                return false;
            }
            i += 1;
        }
        true
    }

    /// Whether `mask` is the single bit of the field the core names `name`.
    const fn field_is(mask: vlint, name: &str) -> bool {
        let mut i = 0;
        while i < FIELD_COUNT {
            if eq(FIELD_NAMES[i], name) {
                return mask == 1 << i;
            }
            i += 1;
        }
        false
    }

    // `Fields::bits` is not a `const fn`, so the masks are tied to the core's field order
    // (`FIELD_NAMES`) here and compared with `Fields::*.bits()` in `tests.rs`.
    const _: () = assert!(field_is(VL_O, "o"));
    const _: () = assert!(field_is(VL_R, "r"));
    const _: () = assert!(field_is(VL_G, "g"));
    const _: () = assert!(field_is(VL_B, "b"));
    const _: () = assert!(field_is(VL_KA, "ka"));
    const _: () = assert!(field_is(VL_KD, "kd"));
    const _: () = assert!(field_is(VL_KS, "ks"));
    const _: () = assert!(field_is(VL_N, "n"));
    const _: () = assert!(field_is(VL_RF, "rf"));
    const _: () = assert!(field_is(VL_F, "f"));
    const _: () = assert!(VL_COLORS == VL_R | VL_G | VL_B);
    const _: () = assert!(VL_ALLFIELDS == (1 << FIELD_COUNT) - 1);
    const _: () = assert!(VL_TRUE == 1 && VL_FALSE == 0);

    same! {
        VL_NOERROR => ErrorCode::NoError,
        VL_BADSCOPE => ErrorCode::BadScope,
        VL_BADVALUE => ErrorCode::BadValue,
        VL_BADFIELD => ErrorCode::BadField,
        VL_BADENUM => ErrorCode::BadEnum,
        VL_NULLPOINTER => ErrorCode::NullPointer,
        VL_BADID => ErrorCode::BadId,
        VL_UNSUPPORTED => ErrorCode::Unsupported,
        VL_IOERROR => ErrorCode::IoError,
        VL_BADFILE => ErrorCode::BadFile,
        VL_NOMEMORY => ErrorCode::NoMemory,
        VL_INTERNAL => ErrorCode::Internal,
        VL_BADINDEX => ErrorCode::BadIndex,
        VL_BADMAGIC => ErrorCode::BadMagic,
        VL_BADDIMENSIONS => ErrorCode::BadDimensions,
        VL_BADVOXELWIDTH => ErrorCode::BadVoxelWidth,
        VL_BADRANGE => ErrorCode::BadRange,
        VL_BADSIZE => ErrorCode::BadSize,
        VL_CANCELLED => ErrorCode::Cancelled,
        VL_DVR => RenderType::Dvr,
        VL_DSR => RenderType::Dsr,
        VL_MIP => RenderType::Mip,
        VL_NOATTENUATION => Attenuation::None,
        VL_INVERSE => Attenuation::Inverse,
        VL_INVERSESQUARE => Attenuation::InverseSquare,
        VL_CASTSHADOWS => Feature::CastShadows,
        VL_RECEIVESHADOWS => Feature::ReceiveShadows,
        VL_CASTREFLECTIONS => Feature::CastReflections,
        VL_RECEIVEREFLECTIONS => Feature::ReceiveReflections,
        VL_REFRACT => Feature::Refract,
        VL_VISIBLE => Feature::Visible,
        VL_FLIPNORMALS => Feature::FlipNormals,
        VL_REFLECTBACKGROUND => Feature::ReflectBackground,
        VL_NEAREST => Interpolation::Nearest,
        VL_TRILINEAR => Interpolation::Trilinear,
        VL_TRICUBIC => Interpolation::Tricubic,
        VL_LOOKUP => MappingType::Lookup,
        VL_RAMP => MappingType::Ramp,
        VL_X => axes::X,
        VL_Y => axes::Y,
        VL_Z => axes::Z,
        VL_RGB8 => PixelFormat::Rgb8,
        VL_RGBA8 => PixelFormat::Rgba8,
        VL_RGB16 => PixelFormat::Rgb16,
        VL_RGBA16 => PixelFormat::Rgba16,
        VL_RGB32F => PixelFormat::Rgb32F,
        VL_RGBA32F => PixelFormat::Rgba32F,
    }
    // Every pixel format of the core has a constant above.
    const _: () = assert!(PixelFormat::ALL.len() == 6);
    // Every code of the core has a constant above: a new core code fails the build here.
    const _: () = assert!(ErrorCode::ALL.len() == 19);
    const _: () = assert!(VL_MAXSPECULAR == MAX_SPECULAR);
    const _: () = assert!(VL_MAXREFRACTION == MAX_REFRACTION);

    /// The decimal number `s` (a part of the package version).
    const fn number(s: &str) -> i64 {
        let s = s.as_bytes();
        assert!(!s.is_empty());
        let (mut n, mut i) = (0, 0);
        while i < s.len() {
            assert!(s[i].is_ascii_digit());
            n = n * 10 + (s[i] - b'0') as i64;
            i += 1;
        }
        n
    }

    // The version constants are the package's (another version in `Cargo.toml` fails the build
    // here until they follow it), and the encoding keeps the three apart.
    same! {
        VLIB_VERSION_MAJOR => number(env!("CARGO_PKG_VERSION_MAJOR")),
        VLIB_VERSION_MINOR => number(env!("CARGO_PKG_VERSION_MINOR")),
        VLIB_VERSION_PATCH => number(env!("CARGO_PKG_VERSION_PATCH")),
    }
    const _: () = assert!(VLIB_VERSION_MINOR >= 0 && VLIB_VERSION_MINOR < 1000);
    const _: () = assert!(VLIB_VERSION_PATCH >= 0 && VLIB_VERSION_PATCH < 1000);
    const _: () = assert!(
        VLIB_VERSION as i64
            == VLIB_VERSION_MAJOR as i64 * 1_000_000
                + VLIB_VERSION_MINOR as i64 * 1_000
                + VLIB_VERSION_PATCH as i64
    );
}

#[cfg(test)]
mod tests;
