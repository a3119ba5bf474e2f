//! # vlib: a volume graphics library
//!
//! A revival of the *vlib* API of Winter & Chen (2001). A volume object is ten co-spatial scalar
//! fields over the unit cube (opacity, r, g, b, ka, kd, ks, specular exponent, refraction index,
//! geometry), defined by an ordered program of constants, field functions and transfer functions,
//! placed in the world by transforms and rendered by a discrete ray tracer.
//!
//! This crate owns all meaning: the state machine ([`Library`]), the object model
//! ([`program`], [`mapping`]), the ray tracer ([`render`]) and image output ([`output`]). The C
//! interface (`capi/`, built as `libvlib.a` / `libvlib.so`) is a thin layer over [`Library`].
//!
//! ```no_run
//! use vlib::{Camera, Fields, Library};
//! let mut vl = Library::new();
//! vl.scene()?;
//! vl.camera(&Camera::default())?;
//! vl.image("sphere.png", 1.0, 64, 64)?;
//! vl.ambient(1.0, 1.0, 1.0, 1.0)?;
//! vl.object()?;
//! vl.function(Fields::ALL, |s| {
//!     let v = vlib::vlaux::sphere(s.position());
//!     s.set(Fields::ALL, v).ok();
//! })?;
//! vl.end()?; // the object
//! vl.end()?; // the scene: renders sphere.png
//! # Ok::<(), vlib::Error>(())
//! ```

#![warn(missing_docs)]

pub mod cvg;
pub mod dataset;
pub mod error;
mod kernel;
pub mod library;
pub mod mapping;
mod num;
pub mod output;
pub mod program;
pub mod render;
pub mod scene;
pub mod scope;
mod skip;
#[cfg(test)]
mod testing;
pub mod types;
pub mod vlaux;

pub use error::{Error, ErrorCode, Result};
pub use library::{Closed, Library};
pub use program::{Sample, SampleRole};
pub use render::Image;
pub use scene::Camera;
pub use scope::{Command, Scope};
pub use types::{Attenuation, Feature, Fields, Interpolation, MappingType, RenderType};
