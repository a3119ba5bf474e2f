//! The description of a scene as the state machine builds it: camera, lights, rendering state,
//! outputs, and objects with their programs and transforms.
//!
//! These are plain data, with no caches and nothing compiled: the state machine fills them in
//! command by command and hands a finished [`SceneDesc`] to the output layer when the scene
//! closes. How they are rendered is not this module's business.

use crate::data::GradientFilter;
use crate::error::{err, ErrorCode, Result};
use crate::model::program::{Instr, NormalFn};
use crate::types::{Attenuation, Feature, Fields, Interpolation, RenderType};
use glam::{DMat4, DVec3};
use std::fmt;
use std::path::PathBuf;

/// The camera (`VLCAMERA`): eye, look-at point, up vector and the full field of view in degrees
/// across the shorter side of the view plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: [f32; 3],
    /// Point looked at.
    pub at: [f32; 3],
    /// Up direction (need not be orthogonal to the view direction, only not parallel to it).
    pub up: [f32; 3],
    /// Full field of view in degrees across the shorter side, in (0, 180).
    pub fov: f32,
}

/// The field of view `vluCamera` and the default camera use, in degrees.
pub const DEFAULT_FOV: f32 = 60.0;

impl Default for Camera {
    /// Looks at the centre of the unit cube from 2 units in front of it (−z), +y up, 60°.
    fn default() -> Camera {
        Camera {
            eye: [0.5, 0.5, -1.5],
            at: [0.5, 0.5, 0.5],
            up: [0.0, 1.0, 0.0],
            fov: DEFAULT_FOV,
        }
    }
}

impl Camera {
    /// Checks that the camera defines a view: finite values, eye ≠ look-at point, up not parallel
    /// to the view direction, field of view in (0°, 180°).
    pub fn validate(&self) -> Result<()> {
        let all = self.eye.iter().chain(&self.at).chain(&self.up);
        if all.clone().any(|v| !v.is_finite()) || !self.fov.is_finite() {
            return err(ErrorCode::BadValue, "vlCamera: values must be finite");
        }
        if !(self.fov > 0.0 && self.fov < 180.0) {
            return err(
                ErrorCode::BadValue,
                format!(
                    "vlCamera: field of view {} must lie in (0, 180) degrees",
                    self.fov
                ),
            );
        }
        // (f32 points as f64: their difference is exact, 0 only where they are equal, and
        // never so small that normalising it underflows; at any scale distinct points give a
        // view direction.)
        let (f, up) = (self.forward_raw(), v3(self.up));
        if f == DVec3::ZERO {
            return err(
                ErrorCode::BadValue,
                "vlCamera: eye and look-at point coincide",
            );
        }
        let (fl, ul) = (f.length(), up.length());
        if ul == 0.0 || f.cross(up).length() <= 1e-9 * fl * ul {
            return err(
                ErrorCode::BadValue,
                "vlCamera: up vector is zero or parallel to the view direction",
            );
        }
        Ok(())
    }

    fn forward_raw(&self) -> DVec3 {
        v3(self.at) - v3(self.eye)
    }

    /// The orthonormal basis (right, up, forward) of the view, left-handed as in RenderMan:
    /// looking along +z with +y up, +x is to the right.
    pub(crate) fn basis(&self) -> (DVec3, DVec3, DVec3) {
        let f = self.forward_raw().normalize();
        let r = v3(self.up).cross(f).normalize();
        let u = f.cross(r);
        (r, u, f)
    }
}

/// Converts a float triple to a double vector.
pub fn v3(a: [f32; 3]) -> DVec3 {
    DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

/// A light source, with colour premultiplied by intensity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// A point light.
    Point {
        /// Position.
        position: DVec3,
        /// Attenuation with distance.
        attenuation: Attenuation,
        /// Colour × intensity.
        radiance: [f32; 3],
    },
    /// A directional light.
    Directional {
        /// Unit vector pointing towards the light (against its direction of travel).
        to_light: DVec3,
        /// Colour × intensity.
        radiance: [f32; 3],
    },
}

/// Default opacity reference, and the largest default sampling interval, in world units.
pub const DEFAULT_STEP: f32 = 1.0;

/// An object whose step was never set samples its world box's diagonal this many times, at a
/// step of at most [`DEFAULT_STEP`] (see [`RenderState::step_for`]).
pub const DEFAULT_SAMPLES_PER_DIAGONAL: f64 = 256.0;

/// The rendering state an object captures at its `vlObject`.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderState {
    /// Rendering algorithm.
    pub render_type: RenderType,
    /// World-space sampling interval; `None` until `vlStepSize` sets it, and while `None`
    /// [`RenderState::step_for`] derives it from the object's size.
    pub step: Option<f32>,
    /// World-space interval over which opacity is exact.
    pub reference: f32,
    /// Iso-surfaces: (field index, threshold).
    pub surfaces: Vec<(usize, f32)>,
    /// The eight toggles, indexed by [`Feature`].
    pub toggles: [bool; 8],
    /// Maximum depth of secondary rays.
    pub recursion: i32,
    /// Dataset interpolation.
    pub interpolation: Interpolation,
    /// B and C of the tricubic filter.
    pub cubic: (f32, f32),
    /// How dataset gradients are reconstructed (`Library::gradient_filter`).
    pub gradient: GradientFilter,
    /// Central-difference neighbourhood in world units; `None` = automatic (see
    /// `docs/compat.md`: half the step, at least 1/1000 of the object's smallest extent).
    pub neighborhood: Option<[f32; 3]>,
}

impl Default for RenderState {
    fn default() -> RenderState {
        let mut toggles = [false; 8];
        toggles[Feature::Visible as usize] = true;
        RenderState {
            render_type: RenderType::Dvr,
            step: None,
            reference: DEFAULT_STEP,
            surfaces: Vec::new(),
            toggles,
            recursion: 4,
            interpolation: Interpolation::Trilinear,
            cubic: (0.0, 0.5),
            gradient: GradientFilter::Nodes,
            neighborhood: None,
        }
    }
}

impl RenderState {
    /// The sampling interval of an object whose world box has diagonal `diagonal`: the step
    /// `vlStepSize` set, or else min([`DEFAULT_STEP`], diagonal / [`DEFAULT_SAMPLES_PER_DIAGONAL`]),
    /// so that a unit-scale object is not undersampled while a scene of hundreds of units (the
    /// paper's) keeps the step of 1. A degenerate box (diagonal 0 or not finite) takes
    /// [`DEFAULT_STEP`].
    pub fn step_for(&self, diagonal: f64) -> f64 {
        match self.step {
            Some(s) => s as f64,
            None if diagonal.is_finite() && diagonal > 0.0 => {
                (diagonal / DEFAULT_SAMPLES_PER_DIAGONAL).min(DEFAULT_STEP as f64)
            }
            None => DEFAULT_STEP as f64,
        }
    }

    /// The state of one toggle.
    pub fn toggle(&self, f: Feature) -> bool {
        self.toggles[f as usize]
    }
}

/// Scene-wide settings that the library scope may set as defaults for later scenes.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// The camera.
    pub camera: Camera,
    /// Background colour.
    pub background: [f32; 3],
    /// Super-sampling: up to n×n samples per pixel.
    pub super_sample: i32,
    /// Ambient colour × intensity.
    pub ambient: [f32; 3],
    /// The state objects capture.
    pub render: RenderState,
    /// Speed-ups that never change a pixel (switchable for benchmarks).
    pub optimise: Optimise,
}

/// Speed-ups of the render, switchable so that benchmarks can show what each is worth. Each
/// field's documentation says what switching it changes: `skip_empty`, `wide_lanes` and
/// `trust_whole_runs` change no pixel; `early_termination` changes a pixel by at most what
/// `termination` allows; `packets` (and `lean_kernel`, which the packet march needs) may
/// change the last bits of some pixels; `preintegrate` changes how a volume is sampled. All
/// are on by default except `preintegrate`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Optimise {
    /// Skip blocks where opacity is provably 0, and, in a scene of more than eight objects,
    /// find the objects a ray (or a voxelization's node) may meet through a tree of their
    /// world boxes instead of testing every one.
    pub skip_empty: bool,
    /// Stop rays whose transmittance falls below `termination`.
    pub early_termination: bool,
    /// The transmittance below which early termination stops a ray (primary and shadow rays):
    /// what the rest of the ray could still add to a pixel is at most this fraction of the
    /// light behind it. Also the weight in the pixel below which a mirror or refracted ray is
    /// not traced (`docs/compat.md`, reflection and refraction). Default [`crate::T_MIN`] =
    /// 1/512 (under half an 8-bit level); VTK's CPU ray caster stops at 255/32767 ≈ 1/128. In [0, 1); `set_optimise` refuses others.
    pub termination: f64,
    /// Evaluate programs of constants, datasets and transfer functions with the lean kernel
    /// (the same values, bit for bit, computed faster; see `docs/performance.md`). The packet
    /// march ([`Optimise::packets`]) runs only such programs, so with this off every ray takes
    /// the scalar march, whose image may differ from the packet march's as `packets` says.
    pub lean_kernel: bool,
    /// Trace the primary rays of a scanned volume eight at a time in SIMD lanes (AVX2 and FMA,
    /// where the processor has them), or sixteen (`wide_lanes`); `docs/performance.md`
    /// measures the speed-up and `docs/dev/simd.md` describes the design. On by default, with
    /// images that differ from the scalar march's in the last bits of f32 arithmetic (a level
    /// of 255 in a handful of pixels at most), so images on processors with and without AVX2
    /// may differ by as much.
    /// Off, every ray takes the scalar march, whose images are the same on every processor.
    pub packets: bool,
    /// Where the processor has AVX-512 and the scene fits (opacity and colour tables of at
    /// most seven rows, or any tables where the object is pre-integrated), the packet march
    /// takes sixteen rays a step instead of eight:
    /// the same samples and arithmetic lane for lane, so the same image bit for bit, faster
    /// on processors with two 512-bit units. On by default; off for comparison.
    pub wide_lanes: bool,
    /// In the packet march, after a run of samples the cell mask passed whole, take the next
    /// two runs without testing them against the mask (a sample the mask would have dropped
    /// fails the zero test, so the image is the same bit for bit): inside visible matter most
    /// runs pass whole, and at fine steps the test is a third of a sample's work. On by
    /// default; off, every run is tested.
    pub trust_whole_runs: bool,
    /// Pre-integrated transfer functions (Engel, Kraus and Ertl 2001) for a scanned volume
    /// whose opacity and colour come from its value through transfer functions (the lean
    /// kernel's direct-shading programs), rendered alone by DVR: each slab between two
    /// samples takes the opacity and colour of the value varying linearly along it, so that
    /// steep transfer functions reach the same error at a coarser step (`docs/accuracy.md`,
    /// pre-integration). The packet march then finds the samples and their values in SIMD
    /// lanes but composites each slab in scalar code, and at equal time its midpoint samples
    /// at a finer step are still more accurate, so it is off by default (every segment its
    /// midpoint sample).
    pub preintegrate: bool,
}

impl Optimise {
    /// The transmittance below which a primary ray stops: `termination` with early termination
    /// on, −∞ (never) with it off.
    pub(crate) fn stop_below(&self) -> f64 {
        if self.early_termination {
            self.termination
        } else {
            f64::NEG_INFINITY
        }
    }
}

impl Default for Optimise {
    fn default() -> Optimise {
        Optimise {
            skip_empty: true,
            early_termination: true,
            termination: crate::types::T_MIN,
            wide_lanes: true,
            trust_whole_runs: true,
            preintegrate: false,
            lean_kernel: true,
            packets: true,
        }
    }
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            camera: Camera::default(),
            background: [0.0; 3],
            super_sample: 1,
            ambient: [0.0; 3],
            render: RenderState::default(),
            optimise: Optimise::default(),
        }
    }
}

/// An image request (`vlImage`).
#[derive(Clone, Debug, PartialEq)]
pub struct ImageRequest {
    /// Output file; the extension selects the format.
    pub path: PathBuf,
    /// Width / height of the view plane.
    pub aspect: f32,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// A voxelization request (`vlVolume`).
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeRequest {
    /// Output files are `<prefix>_<field>.vlb`.
    pub prefix: PathBuf,
    /// The fields to write.
    pub fields: Fields,
    /// World-space corner of node (0, 0, 0).
    pub corner0: [f32; 3],
    /// World-space corner of the last node.
    pub corner1: [f32; 3],
    /// Nodes per axis.
    pub nodes: [usize; 3],
    /// Bytes per voxel, 1 or 2.
    pub bytes: u32,
}

/// An object: its program, placement, boundary, normal chain and captured rendering state.
#[derive(Clone)]
pub struct ObjectDesc {
    /// The field program.
    pub program: Vec<Instr>,
    /// Object-to-parent transform (the world for a root), composed in issue order.
    pub to_world: DMat4,
    /// Object-space flips applied before `to_world`.
    pub flip: [bool; 3],
    /// Boundary scale about the cube centre (`vlBoundary`).
    pub boundary: [f32; 3],
    /// Normal functions, in order.
    pub normals: Vec<NormalFn>,
    /// Rendering state captured at `vlObject`.
    pub state: RenderState,
    /// Children (nested objects), in declaration order; placed in this object's space.
    pub children: Vec<ObjectDesc>,
}

impl ObjectDesc {
    /// A new object capturing `state`: identity transform, unit boundary, empty program.
    pub fn new(state: RenderState) -> ObjectDesc {
        ObjectDesc {
            program: Vec::new(),
            to_world: DMat4::IDENTITY,
            flip: [false; 3],
            boundary: [1.0; 3],
            normals: Vec::new(),
            state,
            children: Vec::new(),
        }
    }

    /// The full object-to-world matrix, flips included.
    pub fn matrix(&self) -> DMat4 {
        let mut f = DMat4::IDENTITY;
        for (axis, &on) in self.flip.iter().enumerate() {
            if on {
                let mut s = DVec3::ONE;
                let mut t = DVec3::ZERO;
                s[axis] = -1.0;
                t[axis] = 1.0;
                f = DMat4::from_translation(t) * DMat4::from_scale(s) * f;
            }
        }
        self.to_world * f
    }
}

impl fmt::Debug for ObjectDesc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ObjectDesc")
            .field("program", &self.program)
            .field("to_world", &self.to_world)
            .field("flip", &self.flip)
            .field("boundary", &self.boundary)
            .field(
                "normals",
                &self
                    .normals
                    .iter()
                    .map(|n| std::sync::Arc::as_ptr(n) as *const ())
                    .collect::<Vec<_>>(),
            )
            .field("state", &self.state)
            .field("children", &self.children)
            .finish()
    }
}

/// A complete scene, ready to render.
#[derive(Clone, Debug)]
pub struct SceneDesc {
    /// Scene-wide settings.
    pub settings: Settings,
    /// Lights, in definition order.
    pub lights: Vec<Light>,
    /// Image outputs.
    pub images: Vec<ImageRequest>,
    /// Voxelization outputs.
    pub volumes: Vec<VolumeRequest>,
    /// Root objects, in definition order.
    pub objects: Vec<ObjectDesc>,
    /// The library's datasets when the scene closed (for `vlSample` in field functions).
    pub datasets: std::sync::Arc<crate::model::program::Datasets>,
}

#[cfg(test)]
mod tests;
