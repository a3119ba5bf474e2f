//! The state machine: one [`Library`] value is one `vlInit … vlEnd` session.
//!
//! Every method is one command of the API. Each first checks its scope against the table in
//! [`crate::api::scope`], then validates every argument, and only then changes state, so a call
//! that returns `Err` has changed nothing (the one exception: a scene's `vlEnd` closes the
//! scene even when writing an output fails, and says what was not written). The C interface
//! calls these methods one to one; Rust users call them directly (field functions are
//! closures). This file holds the state, the
//! session commands (`vlEnd`, `vlScene`), the scene-scope commands and the datasets and
//! transfer functions; the object-scope commands are in `object`, the Rust-only additions in
//! `preview`. The state machine builds plain scene data and hands it to the output layer when
//! a scene closes; it neither renders nor writes files itself.

use crate::api::scope::{require, Command, Scope};
use crate::data::{Dataset, Filter, GradientFilter};
use crate::error::{err, ErrorCode, Result};
use crate::model::mapping::Mapping;
use crate::model::scene::{Camera, ImageRequest, Light, ObjectDesc, SceneDesc, Settings};
use crate::types::{
    Attenuation, DatasetId, Feature, Fields, Interpolation, MappingId, MappingType, RenderType,
};
use glam::DMat4;
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

pub use crate::render::{MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE};
/// The largest super-sampling rate n (n×n samples per pixel).
pub const MAX_SUPER_SAMPLE: i32 = 16;
/// The largest recursion depth.
pub const MAX_RECURSION: i32 = 64;
/// The most iso-surfaces in force at once (`vlSurface`).
pub const MAX_SURFACES: usize = 64;
/// The deepest nesting of objects.
pub const MAX_DEPTH: usize = 64;
/// The most nodes one voxelization may have: the most voxels a `.vlb` file holds
/// ([`crate::data::MAX_VOXELS`], 2³²), as each field is written as one. Its memory does not
/// grow with the nodes (it samples a slab of 2¹⁶ nodes at a time and writes as it goes), so a
/// larger request is refused for what the format can say, not for memory.
pub const MAX_VOLUME_NODES: u64 = crate::data::MAX_VOXELS;

/// The datasets and interpolation of a [`Library`] at one moment ([`Library::sampler`]):
/// `vlSample` without the library.
#[derive(Clone, Debug)]
pub struct Sampler {
    datasets: Arc<crate::model::program::Datasets>,
    filter: Filter,
}

impl Sampler {
    /// `vlSample`: dataset `id`'s normalised value at dataset coordinates (x, y, z), as
    /// [`Library::sample`] gives it (the same errors, without the scope check).
    pub fn sample(&self, id: DatasetId, x: f32, y: f32, z: f32) -> Result<f32> {
        sample_caught(&self.datasets, id, [x, y, z], self.filter)
    }
}

/// `vlSample` outside a render: the node values a filter other than the trilinear one makes on
/// first use are `NoMemory` where they cannot be allocated, returned rather than unwound out of
/// the call (inside a render the render's own catch stops it).
fn sample_caught(
    datasets: &crate::model::program::Datasets,
    id: DatasetId,
    p: [f32; 3],
    filter: Filter,
) -> Result<f32> {
    crate::error::catch("vlSample", || {
        crate::model::program::sample_dataset(datasets, id, p, filter)
    })
}

/// What a successful `vlEnd` closed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Closed {
    /// An object (its definition is now part of the scene).
    Object,
    /// A scene (it was rendered and its outputs written).
    Scene,
    /// The library (the session is over).
    Library,
}

#[derive(Debug)]
pub(super) struct OpenScene {
    pub(super) settings: Settings,
    pub(super) lights: Vec<Light>,
    pub(super) images: Vec<ImageRequest>,
    pub(super) volumes: Vec<crate::model::scene::VolumeRequest>,
    pub(super) objects: Vec<ObjectDesc>,
    /// Objects being specified (nested ones after their parents).
    pub(super) open: Vec<ObjectDesc>,
    /// The empty-space grids and pre-integration tables of `objects`, shared by every render
    /// of the scene.
    pub(super) caches: crate::render::Caches,
}

/// One session of the API (`vlInit` … `vlEnd`).
#[derive(Debug, Default)]
pub struct Library {
    /// Defaults that each new scene starts from (set at library scope).
    pub(super) defaults: Settings,
    pub(super) mappings: BTreeMap<MappingId, Arc<Mapping>>,
    /// The loaded datasets, shared with the scenes and samplers made from them (changed by
    /// copy on write, so a scene being rendered keeps the map it was given).
    pub(super) datasets: Arc<crate::model::program::Datasets>,
    pub(super) scene: Option<OpenScene>,
    pub(super) ended: bool,
    /// How renders are followed and stopped ([`Library::set_render_control`]).
    pub(super) control: crate::control::RenderControl,
    /// The ranks renders are split over ([`Library::set_team`]).
    pub(super) team: Option<crate::team::Team>,
}

pub(super) fn finite(cmd: &str, vals: &[f32]) -> Result<()> {
    if let Some(v) = vals.iter().find(|v| !v.is_finite()) {
        return err(ErrorCode::BadValue, format!("{cmd}: {v} is not finite"));
    }
    Ok(())
}

pub(super) fn colour(cmd: &str, c: [f32; 3]) -> Result<()> {
    finite(cmd, &c)?;
    if c.iter().any(|v| !(0.0..=1.0).contains(v)) {
        return err(
            ErrorCode::BadValue,
            format!("{cmd}: colour {c:?} must lie in [0, 1]"),
        );
    }
    Ok(())
}

pub(super) fn intensity(cmd: &str, i: f32) -> Result<()> {
    finite(cmd, &[i])?;
    if i < 0.0 {
        return err(
            ErrorCode::BadValue,
            format!("{cmd}: intensity {i} is negative"),
        );
    }
    Ok(())
}

pub(super) fn positive(cmd: &str, vals: &[f32]) -> Result<()> {
    finite(cmd, vals)?;
    if let Some(v) = vals.iter().find(|v| **v <= 0.0) {
        return err(ErrorCode::BadValue, format!("{cmd}: {v} must be positive"));
    }
    Ok(())
}

/// Accepts an affine transform whose matrix and inverse are finite and whose determinant is not
/// negligible against the size of its entries.
pub(super) fn invertible(cmd: &str, m: &DMat4) -> Result<()> {
    let det = m.determinant();
    let scale =
        m.x_axis.truncate().length() * m.y_axis.truncate().length() * m.z_axis.truncate().length();
    let inv = m.inverse();
    if !det.is_finite() || !scale.is_finite() || det.abs() <= 1e-12 * scale || !inv.is_finite() {
        return err(
            ErrorCode::BadValue,
            format!("{cmd}: the object transform would become singular"),
        );
    }
    Ok(())
}

impl Library {
    /// `vlInit`: a new session in library scope.
    pub fn new() -> Library {
        Library::default()
    }

    /// The scope the session is in.
    pub fn scope(&self) -> Scope {
        match &self.scene {
            _ if self.ended => Scope::Uninitialised,
            None => Scope::Library,
            Some(s) if s.open.is_empty() => Scope::Scene,
            Some(_) => Scope::Object,
        }
    }

    pub(super) fn check(&self, cmd: Command) -> Result<()> {
        require(cmd, self.scope())
    }

    /// The settings a command at the current scope changes: the scene's, or the defaults.
    pub(super) fn settings_mut(&mut self) -> &mut Settings {
        match &mut self.scene {
            Some(s) => &mut s.settings,
            None => &mut self.defaults,
        }
    }

    pub(super) fn scene_mut(&mut self) -> &mut OpenScene {
        self.scene.as_mut().expect("scope checked: a scene is open")
    }

    pub(super) fn object_mut(&mut self) -> &mut ObjectDesc {
        self.scene_mut()
            .open
            .last_mut()
            .expect("scope checked: an object is open")
    }

    /// `vlEnd`: closes the innermost open object, the scene (rendering it and writing its
    /// outputs), or the library. When a scene's rendering or output fails the scene is closed all
    /// the same and the error says what was not written.
    pub fn end(&mut self) -> Result<Closed> {
        self.check(Command::End)?;
        match self.scope() {
            Scope::Object => {
                let scene = self.scene_mut();
                let obj = scene.open.pop().expect("object scope");
                match scene.open.last_mut() {
                    Some(parent) => parent.children.push(obj),
                    None => scene.objects.push(obj),
                }
                Ok(Closed::Object)
            }
            Scope::Scene => {
                let s = self.scene.take().expect("scene scope");
                let desc = SceneDesc {
                    settings: s.settings,
                    lights: s.lights,
                    images: s.images,
                    volumes: s.volumes,
                    objects: s.objects,
                    datasets: self.datasets.clone(),
                };
                crate::pool::install(|| {
                    crate::output::render_outputs(
                        &desc,
                        &s.caches,
                        &self.control,
                        self.team.as_ref(),
                    )
                })?;
                Ok(Closed::Scene)
            }
            _ => {
                self.ended = true;
                self.scene = None;
                self.mappings.clear();
                self.datasets = Arc::default();
                Ok(Closed::Library)
            }
        }
    }

    /// `vlScene`: opens a scene that starts from the library-scope settings.
    pub fn scene(&mut self) -> Result<()> {
        self.check(Command::Scene)?;
        self.scene = Some(OpenScene {
            settings: self.defaults.clone(),
            lights: Vec::new(),
            images: Vec::new(),
            volumes: Vec::new(),
            objects: Vec::new(),
            open: Vec::new(),
            caches: Default::default(),
        });
        Ok(())
    }

    /// `vlImage`: requests an image of the scene. The end of the file's name (any case) selects
    /// the format (`docs/images.md`):
    /// `.ppm`, `.png`, `.rgb16.png`, `.rgb16.ppm`, `.rgba.png`, `.rgba16.png`, `.pfm`, and
    /// the spelled-out 8-bit forms `.rgb.png`, `.rgb8.png`, `.rgba8.png`, `.rgb.ppm`,
    /// `.rgb8.ppm`; `aspect` is the view plane's width / height.
    pub fn image(
        &mut self,
        path: impl AsRef<Path>,
        aspect: f32,
        width: i32,
        height: i32,
    ) -> Result<()> {
        self.check(Command::Image)?;
        let path = path.as_ref();
        crate::output::ImageFormat::from_path(path)?;
        positive("vlImage", &[aspect])?;
        if !(1..=MAX_IMAGE_SIDE).contains(&width) || !(1..=MAX_IMAGE_SIDE).contains(&height) {
            return err(
                ErrorCode::BadValue,
                format!("vlImage: size {width}x{height} (each side must be 1 … {MAX_IMAGE_SIDE})"),
            );
        }
        if width as u64 * height as u64 > MAX_IMAGE_PIXELS {
            return err(
                ErrorCode::NoMemory,
                format!("vlImage: {width}x{height} exceeds {MAX_IMAGE_PIXELS} pixels"),
            );
        }
        self.scene_mut().images.push(ImageRequest {
            path: path.to_path_buf(),
            aspect,
            width: width as u32,
            height: height as u32,
        });
        Ok(())
    }

    /// `vlVolume`: requests voxelization of the world box `corner0` … `corner1` at
    /// `nodes` nodes per axis (node i of n at corner0 + i/(n − 1)·(corner1 − corner0); a single
    /// node sits at corner0), one `.vlb` file per field named `<prefix>_<field>.vlb`, with 1 or 2
    /// bytes per voxel. Written when the scene closes.
    #[allow(clippy::too_many_arguments)]
    pub fn volume(
        &mut self,
        prefix: impl AsRef<Path>,
        fields: Fields,
        corner0: [f32; 3],
        corner1: [f32; 3],
        nodes: [i32; 3],
        bytes: i32,
    ) -> Result<()> {
        self.check(Command::Volume)?;
        // (The field mask before the values, as the C layer converts it before this call: an
        // empty prefix with an empty mask is `BadField` here too.)
        fields.validate()?;
        let prefix = prefix.as_ref();
        if prefix.as_os_str().is_empty() || prefix.file_name().is_none() {
            return err(
                ErrorCode::BadFile,
                format!("vlVolume: bad prefix {prefix:?}"),
            );
        }
        finite("vlVolume", &corner0)?;
        finite("vlVolume", &corner1)?;
        // (In the order of the parameters: the node counts, then the voxel width.)
        for axis in 0..3 {
            let n = nodes[axis];
            if n < 1 || n as u64 > crate::data::MAX_VOXELS {
                return err(
                    ErrorCode::BadValue,
                    format!("vlVolume: {n} nodes along an axis"),
                );
            }
            if n > 1 && corner1[axis] <= corner0[axis] {
                return err(
                    ErrorCode::BadValue,
                    format!("vlVolume: the box must have positive size along axis {axis}"),
                );
            }
        }
        let total = nodes
            .iter()
            .try_fold(1u64, |acc, &n| acc.checked_mul(n as u64))
            .unwrap_or(u64::MAX);
        if total > MAX_VOLUME_NODES {
            return err(
                ErrorCode::NoMemory,
                format!("vlVolume: {total} nodes exceed {MAX_VOLUME_NODES}"),
            );
        }
        if !(bytes == 1 || bytes == 2) {
            return err(
                ErrorCode::BadValue,
                format!("vlVolume: {bytes} bytes per voxel (1 or 2)"),
            );
        }
        self.scene_mut()
            .volumes
            .push(crate::model::scene::VolumeRequest {
                prefix: prefix.to_path_buf(),
                fields,
                corner0,
                corner1,
                nodes: nodes.map(|n| n as usize),
                bytes: bytes as u32,
            });
        Ok(())
    }

    /// `vlCamera`.
    pub fn camera(&mut self, camera: &Camera) -> Result<()> {
        self.check(Command::Camera)?;
        camera.validate()?;
        self.settings_mut().camera = *camera;
        Ok(())
    }

    /// `vlBackground`: colour components in [0, 1].
    pub fn background(&mut self, r: f32, g: f32, b: f32) -> Result<()> {
        self.check(Command::Background)?;
        colour("vlBackground", [r, g, b])?;
        self.settings_mut().background = [r, g, b];
        Ok(())
    }

    /// `vlSuperSample`: adaptive super-sampling with up to n×n samples per pixel (1 … 16).
    pub fn super_sample(&mut self, n: i32) -> Result<()> {
        self.check(Command::SuperSample)?;
        if !(1..=MAX_SUPER_SAMPLE).contains(&n) {
            return err(
                ErrorCode::BadValue,
                format!("vlSuperSample: {n} (must be 1 … {MAX_SUPER_SAMPLE})"),
            );
        }
        self.settings_mut().super_sample = n;
        Ok(())
    }

    /// `vlAmbient`: ambient light colour in [0, 1] and intensity ≥ 0.
    pub fn ambient(&mut self, r: f32, g: f32, b: f32, i: f32) -> Result<()> {
        self.check(Command::Ambient)?;
        colour("vlAmbient", [r, g, b])?;
        intensity("vlAmbient", i)?;
        self.settings_mut().ambient = [r * i, g * i, b * i];
        Ok(())
    }

    /// `vlPointLight`.
    pub fn point_light(
        &mut self,
        position: [f32; 3],
        attenuation: Attenuation,
        rgb: [f32; 3],
        i: f32,
    ) -> Result<()> {
        self.check(Command::PointLight)?;
        finite("vlPointLight", &position)?;
        colour("vlPointLight", rgb)?;
        intensity("vlPointLight", i)?;
        self.scene_mut().lights.push(Light::Point {
            position: crate::model::scene::v3(position),
            attenuation,
            radiance: rgb.map(|c| c * i),
        });
        Ok(())
    }

    /// `vlDirectionalLight`: light travelling in direction `dir` (non-zero).
    pub fn directional_light(&mut self, dir: [f32; 3], rgb: [f32; 3], i: f32) -> Result<()> {
        self.check(Command::DirectionalLight)?;
        finite("vlDirectionalLight", &dir)?;
        // (The direction, the first parameter, before the colour and the intensity.)
        let d = crate::model::scene::v3(dir);
        let len = d.length();
        if len.is_nan() || len <= 0.0 || !len.is_finite() {
            return err(ErrorCode::BadValue, "vlDirectionalLight: zero direction");
        }
        colour("vlDirectionalLight", rgb)?;
        intensity("vlDirectionalLight", i)?;
        self.scene_mut().lights.push(Light::Directional {
            to_light: -d / len,
            radiance: rgb.map(|c| c * i),
        });
        Ok(())
    }

    /// `vlRenderType`: `Dvr` (direct volume rendering), `Dsr` (the iso-surfaces of
    /// `vlSurface`) or `Mip` (maximum intensity projection), captured by later objects.
    pub fn render_type(&mut self, t: RenderType) -> Result<()> {
        self.check(Command::RenderType)?;
        self.settings_mut().render.render_type = t;
        Ok(())
    }

    /// `vlStepSize`: world-space sampling interval and the interval over which opacity is exact;
    /// both finite and positive, captured by later objects.
    ///
    /// Until it is called, the reference is 1 world unit and each object samples at
    /// min(1, d / 256) for its world box's diagonal d: 256 samples along the diagonal of a small
    /// object, and the step of 1 for objects over 256 units across, as in the paper's scenes
    /// (`docs/compat.md`, "The default step").
    pub fn step_size(&mut self, step: f32, reference: f32) -> Result<()> {
        self.check(Command::StepSize)?;
        positive("vlStepSize", &[step, reference])?;
        let r = &mut self.settings_mut().render;
        r.step = Some(step);
        r.reference = reference;
        Ok(())
    }

    /// `vlSurface`: adds an iso-surface of `field` at `threshold` (in [0, 1]) to the surfaces
    /// later objects capture for DSR, on any fields: up to [`MAX_SURFACES`] (64) in force at
    /// once, one more is `BadValue`.
    pub fn surface(&mut self, field: Fields, threshold: f32) -> Result<()> {
        self.check(Command::Surface)?;
        let index = field.validate_single()?;
        finite("vlSurface", &[threshold])?;
        if !(0.0..=1.0).contains(&threshold) {
            return err(
                ErrorCode::BadValue,
                format!("vlSurface: threshold {threshold} must lie in [0, 1]"),
            );
        }
        let surfaces = &mut self.settings_mut().render.surfaces;
        if surfaces.len() >= MAX_SURFACES {
            return err(
                ErrorCode::BadValue,
                format!("vlSurface: at most {MAX_SURFACES} surfaces"),
            );
        }
        surfaces.push((index, threshold));
        Ok(())
    }

    /// `vlToggle`: one of the eight features on or off for the objects defined after it.
    pub fn toggle(&mut self, feature: Feature, on: bool) -> Result<()> {
        self.check(Command::Toggle)?;
        self.settings_mut().render.toggles[feature as usize] = on;
        Ok(())
    }

    /// `vlRecursion`: maximum depth of secondary rays, 0 … 64.
    pub fn recursion(&mut self, depth: i32) -> Result<()> {
        self.check(Command::Recursion)?;
        if !(0..=MAX_RECURSION).contains(&depth) {
            return err(
                ErrorCode::BadValue,
                format!("vlRecursion: {depth} (must be 0 … {MAX_RECURSION})"),
            );
        }
        self.settings_mut().render.recursion = depth;
        Ok(())
    }

    /// `vlInterpolationType`.
    pub fn interpolation(&mut self, i: Interpolation) -> Result<()> {
        self.check(Command::InterpolationType)?;
        self.settings_mut().render.interpolation = i;
        Ok(())
    }

    /// `vlCubicFilter`: B and C of the BC-spline family, finite.
    pub fn cubic_filter(&mut self, b: f32, c: f32) -> Result<()> {
        self.check(Command::CubicFilter)?;
        finite("vlCubicFilter", &[b, c])?;
        self.settings_mut().render.cubic = (b, c);
        Ok(())
    }

    /// How the gradients of dataset fields, which light their samples, are reconstructed from
    /// the nodes, for the datasets cast from now on (`vlGradientFilter`, an extension): the
    /// paper's [`GradientFilter::Nodes`] (the default) or the exact gradient of a BC-spline,
    /// [`GradientFilter::Cubic`] with finite B and C (`docs/extensions.md`). Library and scene
    /// scope, like [`Library::interpolation`]; `vlDataset` captures it.
    pub fn gradient_filter(&mut self, gradient: GradientFilter) -> Result<()> {
        if !matches!(self.scope(), Scope::Library | Scope::Scene) {
            return err(
                ErrorCode::BadScope,
                "vlGradientFilter: library or scene scope only",
            );
        }
        if let GradientFilter::Cubic { b, c } = gradient {
            finite("vlGradientFilter", &[b, c])?;
        }
        self.settings_mut().render.gradient = gradient;
        Ok(())
    }

    /// `vlNeighborhood`: central-difference offsets in world units, finite and positive.
    pub fn neighborhood(&mut self, dx: f32, dy: f32, dz: f32) -> Result<()> {
        self.check(Command::Neighborhood)?;
        positive("vlNeighborhood", &[dx, dy, dz])?;
        self.settings_mut().render.neighborhood = Some([dx, dy, dz]);
        Ok(())
    }

    /// `vlLoad`: reads a `.vlb` dataset and files it under `id`, replacing any dataset of that
    /// id (objects that already cast the old one keep it). A file that cannot be read or is
    /// malformed changes nothing.
    pub fn load(&mut self, id: DatasetId, path: impl AsRef<Path>) -> Result<()> {
        self.check(Command::Load)?;
        let d = Dataset::load(path.as_ref())?;
        Arc::make_mut(&mut self.datasets).insert(id, Arc::new(d));
        Ok(())
    }

    /// Files an in-memory dataset under `id` (the Rust counterpart of `vlLoad`). An
    /// `Arc<Dataset>` is shared, not copied: several libraries (or ids) can hold one dataset,
    /// and its caches (brick ranges) are computed once for all of them.
    pub fn add_dataset(&mut self, id: DatasetId, dataset: impl Into<Arc<Dataset>>) -> Result<()> {
        self.check(Command::Load)?;
        Arc::make_mut(&mut self.datasets).insert(id, dataset.into());
        Ok(())
    }

    /// The dataset filed under `id`.
    pub fn dataset_of(&self, id: DatasetId) -> Option<&Arc<Dataset>> {
        self.datasets.get(&id)
    }

    /// `vlUnload`: forgets dataset `id`; objects that cast it keep their reference, so the
    /// memory is freed when the last of them is gone.
    pub fn unload(&mut self, id: DatasetId) -> Result<()> {
        self.check(Command::Unload)?;
        match Arc::make_mut(&mut self.datasets).remove(&id) {
            Some(_) => Ok(()),
            None => err(ErrorCode::BadId, format!("vlUnload: no dataset {id}")),
        }
    }

    pub(super) fn settings(&self) -> &Settings {
        match &self.scene {
            Some(s) => &s.settings,
            None => &self.defaults,
        }
    }

    pub(super) fn filter(&self) -> Filter {
        let r = &self.settings().render;
        Filter::of_settings(r.interpolation, r.cubic)
    }

    /// `vlSample` outside sample scope: dataset `id`'s normalised value at dataset coordinates
    /// (x, y, z), under the interpolation in force. `BadScope` inside a scene's object,
    /// `BadId` for an unknown dataset, `BadValue` for a point not finite, `NoMemory` where the
    /// node values that a filter other than the trilinear one reads (made on first use, four
    /// bytes a voxel, then kept) cannot be allocated.
    pub fn sample(&self, id: DatasetId, x: f32, y: f32, z: f32) -> Result<f32> {
        self.check(Command::Sample)?;
        sample_caught(&self.datasets, id, [x, y, z], self.filter())
    }

    /// A snapshot of what `vlSample` reads (the datasets and the interpolation in force), for
    /// sampling from any thread while this library is busy, such as a helper thread of a field
    /// function during a render. Cheap: the datasets are shared, not copied. While a sampler
    /// lives, the next `load`, `add_dataset` or `unload` copies the library's table of
    /// datasets (a pointer each, not their voxels) so that the sampler keeps its snapshot:
    /// drop the samplers you are done with before loading many datasets.
    pub fn sampler(&self) -> Sampler {
        Sampler {
            datasets: self.datasets.clone(),
            filter: self.filter(),
        }
    }

    /// `vlMapping`: declares (or replaces) transfer function `id`. Objects that already mapped
    /// through the old definition keep it.
    pub fn mapping(
        &mut self,
        id: MappingId,
        kind: MappingType,
        points: i32,
        outputs: i32,
        table: &[f32],
    ) -> Result<()> {
        self.check(Command::Mapping)?;
        let m = Mapping::new(kind, points, outputs, table)?;
        self.mappings.insert(id, Arc::new(m));
        Ok(())
    }
}
