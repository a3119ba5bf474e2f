//! The small value types of the API: field masks, enumerations and their integer encodings.
//!
//! The integers are the values of the C constants (`VL_O`, `VL_DVR`, …); the C layer passes raw
//! integers to the `from_raw` constructors here, so validation of every enum lives in one place.
//!
//! It owns these values and their encodings, nothing that uses them: the base layer below
//! every other module.

use crate::error::{err, ErrorCode, Result};
use std::fmt;

/// A set of the ten fields, as a bit mask (`VL_O | VL_KS`, …).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Fields(u32);

/// The number of fields of a volume object.
pub const FIELD_COUNT: usize = 10;

/// The short names of the fields, in bit order (used in file names and messages).
pub const FIELD_NAMES: [&str; FIELD_COUNT] = ["o", "r", "g", "b", "ka", "kd", "ks", "n", "rf", "f"];

impl Fields {
    /// No field.
    pub const NONE: Fields = Fields(0);
    /// Opacity.
    pub const O: Fields = Fields(1 << 0);
    /// Red.
    pub const R: Fields = Fields(1 << 1);
    /// Green.
    pub const G: Fields = Fields(1 << 2);
    /// Blue.
    pub const B: Fields = Fields(1 << 3);
    /// Ambient reflection coefficient.
    pub const KA: Fields = Fields(1 << 4);
    /// Diffuse reflection coefficient.
    pub const KD: Fields = Fields(1 << 5);
    /// Specular reflection coefficient.
    pub const KS: Fields = Fields(1 << 6);
    /// Specular exponent, normalised by [`MAX_SPECULAR`].
    pub const N: Fields = Fields(1 << 7);
    /// Index of refraction, normalised by [`refraction_to_field`].
    pub const RF: Fields = Fields(1 << 8);
    /// Geometry: drives normals and iso-surfaces.
    pub const F: Fields = Fields(1 << 9);
    /// Red, green and blue.
    pub const COLORS: Fields = Fields(0b1110);
    /// All ten fields.
    pub const ALL: Fields = Fields((1 << FIELD_COUNT) - 1);

    /// Validates a raw mask: non-empty and without unknown bits.
    pub fn from_raw(raw: i32) -> Result<Fields> {
        if raw == 0 {
            return err(ErrorCode::BadField, "empty field mask");
        }
        if raw < 0 || (raw as u32) & !Fields::ALL.0 != 0 {
            return err(
                ErrorCode::BadField,
                format!("field mask {raw:#x} has bits that name no field"),
            );
        }
        Ok(Fields(raw as u32))
    }

    /// Validates a raw mask that must name exactly one field; returns its index (0 = opacity … 9 =
    /// geometry).
    pub fn single_from_raw(raw: i32) -> Result<usize> {
        let f = Fields::from_raw(raw)?;
        f.single_index().ok_or_else(|| {
            crate::error::Error::new(
                ErrorCode::BadField,
                format!("field mask {raw:#x} must name exactly one field"),
            )
        })
    }

    /// Checks that the set is non-empty and names only the ten fields (a `Fields` built from
    /// the constants always does; one built with [`Fields::from_bits_unchecked`] may not).
    pub fn validate(self) -> Result<Fields> {
        Fields::from_raw(self.0 as i32)
    }

    /// Checks that the set names exactly one field and returns its index.
    pub fn validate_single(self) -> Result<usize> {
        Fields::single_from_raw(self.0 as i32)
    }

    /// A set from raw bits without validation; commands validate it.
    pub fn from_bits_unchecked(bits: u32) -> Fields {
        Fields(bits)
    }

    /// The raw bits.
    pub fn bits(self) -> u32 {
        self.0
    }

    /// The index of the only field in the set, if it has exactly one: `None` for an empty set,
    /// several fields, or a bit that names no field.
    pub fn single_index(self) -> Option<usize> {
        (self.0.count_ones() == 1 && self.0 & !Fields::ALL.0 == 0)
            .then(|| self.0.trailing_zeros() as usize)
    }

    /// Whether the set contains field number `index`.
    pub fn contains_index(self, index: usize) -> bool {
        index < FIELD_COUNT && self.0 & (1 << index) != 0
    }

    /// Whether the two sets share a field.
    pub fn intersects(self, other: Fields) -> bool {
        self.0 & other.0 != 0
    }

    /// The set with only field number `index` (0 = opacity … 9 = geometry).
    ///
    /// # Panics
    ///
    /// If `index` is not below [`FIELD_COUNT`], as indexing the ten fields with it would.
    pub fn from_index(index: usize) -> Fields {
        assert!(
            index < FIELD_COUNT,
            "Fields::from_index: {index} is no field index (0 … {})",
            FIELD_COUNT - 1
        );
        Fields(1 << index)
    }

    /// The indices of the fields in the set, in bit order.
    pub fn indices(self) -> impl Iterator<Item = usize> {
        (0..FIELD_COUNT).filter(move |i| self.contains_index(*i))
    }
}

impl std::ops::BitOr for Fields {
    type Output = Fields;
    fn bitor(self, rhs: Fields) -> Fields {
        Fields(self.0 | rhs.0)
    }
}

impl std::ops::BitAnd for Fields {
    type Output = Fields;
    fn bitand(self, rhs: Fields) -> Fields {
        Fields(self.0 & rhs.0)
    }
}

impl fmt::Debug for Fields {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<&str> = self.indices().map(|i| FIELD_NAMES[i]).collect();
        write!(f, "Fields({})", names.join("|"))
    }
}

/// The specular exponent that a field value of 1 stands for: `VLSPECULAR(e) = e / 128`.
pub const MAX_SPECULAR: f32 = 128.0;

/// The refraction index that a field value of 1 stands for: `VLREFRACTION(eta) = (eta − 1) / 2`
/// maps indices 1 … 3 to 0 … 1.
pub const MAX_REFRACTION: f32 = 3.0;

/// The field value that encodes specular exponent `e` (the `VLSPECULAR` macro).
pub fn specular_to_field(e: f32) -> f32 {
    e / MAX_SPECULAR
}

/// The field value that encodes refraction index `eta` (the `VLREFRACTION` macro).
pub fn refraction_to_field(eta: f32) -> f32 {
    (eta - 1.0) / (MAX_REFRACTION - 1.0)
}

/// A dataset's id: the integer `vlLoad`, `vlDataset`, `vlUnload` and `vlSample` take in C.
/// Any `i32`; ids name datasets, they do not count them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DatasetId(pub i32);

/// A transfer function's id: the integer `vlMapping` declares and `vlMap` names in C. Any `i32`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MappingId(pub i32);

impl fmt::Display for DatasetId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

impl fmt::Display for MappingId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

macro_rules! int_enum {
    ($(#[$doc:meta])* $name:ident, $what:literal { $($(#[$vdoc:meta])* $variant:ident = $value:literal),+ $(,)? }) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[non_exhaustive]
        pub enum $name {
            $($(#[$vdoc])* $variant = $value),+
        }

        impl $name {
            /// Every value, in numeric order.
            pub const ALL: &'static [$name] = &[$($name::$variant),+];

            /// Validates a raw integer from the C interface.
            pub fn from_raw(raw: i32) -> $crate::error::Result<$name> {
                match raw {
                    $($value => Ok($name::$variant),)+
                    _ => $crate::error::err(
                        $crate::error::ErrorCode::BadEnum,
                        format!(concat!("{} is not a valid ", $what), raw),
                    ),
                }
            }

            /// The raw integer of the C interface.
            pub fn raw(self) -> i32 {
                self as i32
            }
        }
    };
}
/// The C interface's integer enums, for the layers above (`render::PixelFormat`).
pub(crate) use int_enum;

int_enum!(
    /// Rendering algorithms (`vlRenderType`).
    RenderType, "render type" {
        /// Direct volume rendering (`VL_DVR`, the default).
        Dvr = 0,
        /// Direct surface rendering of iso-surfaces (`VL_DSR`).
        Dsr = 1,
        /// Maximum intensity projection (`VL_MIP`).
        Mip = 2,
    }
);

int_enum!(
    /// Point-light attenuation with distance d (`vlPointLight`).
    Attenuation, "attenuation" {
        /// No attenuation (`VL_NOATTENUATION`).
        None = 0,
        /// 1/d (`VL_INVERSE`).
        Inverse = 1,
        /// 1/d² (`VL_INVERSESQUARE`).
        InverseSquare = 2,
    }
);

int_enum!(
    /// The Boolean rendering features of `vlToggle`.
    Feature, "toggle feature" {
        /// The object casts shadows (`VL_CASTSHADOWS`).
        CastShadows = 0,
        /// The object receives shadows (`VL_RECEIVESHADOWS`).
        ReceiveShadows = 1,
        /// The object is seen in reflections (`VL_CASTREFLECTIONS`).
        CastReflections = 2,
        /// The object shows reflections of others (`VL_RECEIVEREFLECTIONS`).
        ReceiveReflections = 3,
        /// The object refracts light (`VL_REFRACT`).
        Refract = 4,
        /// The object is seen by primary rays (`VL_VISIBLE`).
        Visible = 5,
        /// Normals facing away from the ray origin are flipped (`VL_FLIPNORMALS`).
        FlipNormals = 6,
        /// Reflections show the background colour (`VL_REFLECTBACKGROUND`).
        ReflectBackground = 7,
    }
);

int_enum!(
    /// Dataset interpolation filters (`vlInterpolationType`).
    Interpolation, "interpolation type" {
        /// Nearest node (`VL_NEAREST`).
        Nearest = 0,
        /// Trilinear (`VL_TRILINEAR`, the default).
        Trilinear = 1,
        /// Tricubic BC-spline (`VL_TRICUBIC`).
        Tricubic = 2,
    }
);

int_enum!(
    /// Transfer-function kinds (`vlMapping`).
    MappingType, "mapping type" {
        /// The lookup table Φ_t (`VL_LOOKUP`).
        Lookup = 0,
        /// The linear ramp Φ_r (`VL_RAMP`).
        Ramp = 1,
    }
);

/// The default of `Optimise::termination`: rays stop once their transmittance falls below
/// this, so what remains can change an 8-bit pixel by at most 1/512 < 1/510 (half a grey level
/// of an 8-bit image).
pub const T_MIN: f64 = 1.0 / 512.0;

/// Axes for `vlFlip`, as a bit mask.
pub mod axes {
    /// The x axis (`VL_X`).
    pub const X: i32 = 1;
    /// The y axis (`VL_Y`).
    pub const Y: i32 = 2;
    /// The z axis (`VL_Z`).
    pub const Z: i32 = 4;
}

#[cfg(test)]
mod tests;
