//! # vlib: a volume graphics library
//!
//! A revival of the *vlib* API of Winter & Chen (2001). A volume object is ten co-spatial scalar
//! fields over the unit cube (opacity, r, g, b, ka, kd, ks, specular exponent, refraction index,
//! geometry), defined by an ordered program of constants, field functions and transfer functions,
//! placed in the world by transforms and rendered by a discrete ray tracer.
//!
//! This crate owns all meaning: the state machine ([`Library`], one method per command), the
//! object model, datasets, the ray tracer and the output files. The C interface (`capi/`, built
//! as `libvlib.a` / `libvlib.so`) is a thin layer over [`Library`].
//!
//! The public API is what this page lists: [`Library`] and the types its methods take and
//! return (among them the rendered [`Image`], its [`Backdrop`] and the [`PixelFormat`]s of
//! [`Library::render_into`]), the auxiliary library [`vlaux`], the CVG operators [`cvg`], the
//! command table [`scope`], the base [`types`], and two file helpers ([`write_image`],
//! [`write_atomic`]).
//! Everything else is internal, in layers that import downward only (`docs/dev/architecture.md`):
//! `api` (the state machine) → `output` (the one place that writes files) → `render` (scene →
//! immutable plan → pixels) → `accel` (empty-space skipping) → `model` (plain scene data and the
//! object model) → `data` (datasets) → the base (`types`, `error`, `num`, `pool`, `control`,
//! `team`).
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

mod accel;
mod api;
mod control;
mod data;
mod error;
mod model;
mod num;
mod output;
mod pool;
mod render;
mod team;
#[cfg(test)]
mod testing;
pub mod types;

pub use api::library::{Closed, Library, Sampler};
pub use api::scope;
pub use api::scope::{Command, Scope};
pub use control::{CancelFlag, ProgressFn, RenderControl};
pub use data::{Dataset, Filter, Geometry, GradientFilter, Voxels};
pub use error::{Error, ErrorCode, Result};
pub use model::program::{FieldFn, NormalFn, Sample, SampleRole};
pub use model::scene::{Camera, Optimise, DEFAULT_FOV};
pub use model::{cvg, vlaux};
pub use output::{write_atomic, write_image};
/// The packet march's sample counts (`docs/performance.md`, "Samples taken"), only in builds
/// with `RUSTFLAGS="--cfg vlib_counters"`.
#[cfg(all(vlib_counters, target_arch = "x86_64"))]
#[doc(hidden)]
pub use render::sample_counts;
pub use render::{Backdrop, Image, PixelFormat, Plan};
pub use team::{RankStats, Team};
pub use types::{
    Attenuation, DatasetId, Feature, Fields, Interpolation, MappingId, MappingType, RenderType,
    T_MIN,
};

/// The library's limits on what a call may ask for (`docs/commands.md`,
/// `docs/dev/robustness.md`). A larger request is refused, changing nothing, with this code:
///
/// - [`MAX_IMAGE_SIDE`](limits::MAX_IMAGE_SIDE), an image's width or height: `BadValue`
///   (`vlImage`, [`Library::render`], [`Library::render_into`], `vlRenderBuffer`).
/// - [`MAX_IMAGE_PIXELS`](limits::MAX_IMAGE_PIXELS), an image's pixels: `NoMemory` from
///   `vlImage` ([`Library::image`]), the code `docs/commands.md` gives that command for an
///   image too large to allocate when its scene closes; `BadValue` from the renders to
///   memory ([`Library::render`], [`Library::render_into`], `vlRenderBuffer`), which check it
///   with the other limits of their size arguments and render a strip at a time
///   (`docs/extensions.md`). Both codes are the C API's documented ones.
/// - [`MAX_SUPER_SAMPLE`](limits::MAX_SUPER_SAMPLE): `BadValue` (`vlSuperSample`).
/// - [`MAX_RECURSION`](limits::MAX_RECURSION): `BadValue` (`vlRecursion`).
/// - [`MAX_SURFACES`](limits::MAX_SURFACES), iso-surfaces in force: `BadValue` (`vlSurface`).
/// - [`MAX_DEPTH`](limits::MAX_DEPTH), objects nested: `BadValue` (`vlObject`).
/// - [`MAX_VOLUME_NODES`](limits::MAX_VOLUME_NODES), a voxelization's nodes: `NoMemory`
///   (`vlVolume`, as `docs/commands.md` gives it).
/// - [`MAX_VOXELS`](limits::MAX_VOXELS), a dataset's voxels, and
///   [`MAX_AXIS_NODES`](limits::MAX_AXIS_NODES), its nodes along one axis: `BadDimensions`
///   (`vlLoad`, [`Dataset::load`], [`Dataset::from_vlb_bytes`], [`Dataset::new`]).
/// - [`MAX_POINTS`](limits::MAX_POINTS) and [`MAX_OUTPUTS`](limits::MAX_OUTPUTS), a transfer
///   function's rows and outputs: `BadValue` (`vlMapping`).
/// - [`MAX_SAMPLES_PER_RAY`](limits::MAX_SAMPLES_PER_RAY), the samples of a ray through one
///   object: `BadValue`, from the render (a scene's `vlEnd`, [`Library::render`],
///   [`Library::render_into`], `vlRenderBuffer`) before any pixel.
pub mod limits {
    pub use crate::api::library::{
        MAX_DEPTH, MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE, MAX_RECURSION, MAX_SUPER_SAMPLE, MAX_SURFACES,
        MAX_VOLUME_NODES,
    };
    pub use crate::data::{MAX_AXIS_NODES, MAX_VOXELS};
    pub use crate::model::mapping::{MAX_OUTPUTS, MAX_POINTS};
    pub use crate::render::MAX_SAMPLES_PER_RAY;
}

/// The `.vlb` dataset format's constants (the format itself: [`Dataset::load`],
/// [`Dataset::save`], `docs/compat.md`), and how an input file is opened.
pub mod vlb {
    pub use crate::data::{open_regular, HEADER_LEN, MAGIC};
}
