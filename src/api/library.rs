//! The state machine: one [`Library`] value is one `vlInit … vlEnd` session.
//!
//! Every method is one command of the API. Each first checks its scope against the table in
//! [`crate::api::scope`], then validates every argument, and only then changes state, so a call that
//! returns `Err` has changed nothing. The C interface calls these methods one to one; Rust users
//! call them directly (field functions are closures).

use crate::api::scope::{require, Command, Scope};
use crate::data::{Dataset, Filter};
use crate::error::{err, Error, ErrorCode, Result};
use crate::model::mapping::Mapping;
use crate::model::program::{clamp_field, Instr, NormalFn, Sample};
use crate::model::scene::{Camera, ImageRequest, Light, ObjectDesc, SceneDesc, Settings};
use crate::types::{axes, Attenuation, Feature, Fields, Interpolation, MappingType, RenderType};
use glam::{DMat4, DVec4};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

/// The largest image side in pixels.
pub const MAX_IMAGE_SIDE: i32 = 1 << 15;
/// The largest number of pixels of one image.
pub const MAX_IMAGE_PIXELS: u64 = 1 << 28;
/// The largest super-sampling rate n (n×n samples per pixel).
pub const MAX_SUPER_SAMPLE: i32 = 16;
/// The largest recursion depth.
pub const MAX_RECURSION: i32 = 64;
/// The most iso-surfaces in force at once.
pub const MAX_SURFACES: usize = 64;
/// The deepest nesting of objects.
pub const MAX_DEPTH: usize = 64;
/// The most nodes one voxelization may have (2²⁷: it holds ten f32 fields per node while it
/// runs, 5 GiB at this size).
pub const MAX_VOLUME_NODES: u64 = 1 << 27;

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
struct OpenScene {
    settings: Settings,
    lights: Vec<Light>,
    images: Vec<ImageRequest>,
    volumes: Vec<crate::model::scene::VolumeRequest>,
    objects: Vec<ObjectDesc>,
    /// Objects being specified (nested ones after their parents).
    open: Vec<ObjectDesc>,
    /// The empty-space grids of `objects`, shared by every render of the scene.
    grids: crate::render::Grids,
}

/// One session of the API (`vlInit` … `vlEnd`).
#[derive(Debug, Default)]
pub struct Library {
    /// Defaults that each new scene starts from (set at library scope).
    defaults: Settings,
    mappings: BTreeMap<i32, Arc<Mapping>>,
    datasets: crate::model::program::Datasets,
    scene: Option<OpenScene>,
    ended: bool,
}

fn finite(cmd: &str, vals: &[f32]) -> Result<()> {
    if let Some(v) = vals.iter().find(|v| !v.is_finite()) {
        return err(ErrorCode::BadValue, format!("{cmd}: {v} is not finite"));
    }
    Ok(())
}

fn colour(cmd: &str, c: [f32; 3]) -> Result<()> {
    finite(cmd, &c)?;
    if c.iter().any(|v| !(0.0..=1.0).contains(v)) {
        return err(
            ErrorCode::BadValue,
            format!("{cmd}: colour {c:?} must lie in [0, 1]"),
        );
    }
    Ok(())
}

fn intensity(cmd: &str, i: f32) -> Result<()> {
    finite(cmd, &[i])?;
    if i < 0.0 {
        return err(
            ErrorCode::BadValue,
            format!("{cmd}: intensity {i} is negative"),
        );
    }
    Ok(())
}

fn positive(cmd: &str, vals: &[f32]) -> Result<()> {
    finite(cmd, vals)?;
    if let Some(v) = vals.iter().find(|v| **v <= 0.0) {
        return err(ErrorCode::BadValue, format!("{cmd}: {v} must be positive"));
    }
    Ok(())
}

/// Accepts an affine transform whose matrix and inverse are finite and whose determinant is not
/// negligible against the size of its entries.
fn invertible(cmd: &str, m: &DMat4) -> Result<()> {
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

    fn check(&self, cmd: Command) -> Result<()> {
        require(cmd, self.scope())
    }

    /// The settings a command at the current scope changes: the scene's, or the defaults.
    fn settings_mut(&mut self) -> &mut Settings {
        match &mut self.scene {
            Some(s) => &mut s.settings,
            None => &mut self.defaults,
        }
    }

    fn scene_mut(&mut self) -> &mut OpenScene {
        self.scene.as_mut().expect("scope checked: a scene is open")
    }

    fn object_mut(&mut self) -> &mut ObjectDesc {
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
                    datasets: Arc::new(self.datasets.clone()),
                };
                crate::output::render_outputs(&desc, &s.grids)?;
                Ok(Closed::Scene)
            }
            _ => {
                self.ended = true;
                self.scene = None;
                self.mappings.clear();
                self.datasets.clear();
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
            grids: Default::default(),
        });
        Ok(())
    }

    /// `vlImage`: requests an image of the scene. The extension (`.ppm`, `.png`, any case) selects
    /// the format; `aspect` is the view plane's width / height.
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
        let prefix = prefix.as_ref();
        if prefix.as_os_str().is_empty() || prefix.file_name().is_none() {
            return err(
                ErrorCode::BadFile,
                format!("vlVolume: bad prefix {prefix:?}"),
            );
        }
        fields.validate()?;
        finite("vlVolume", &corner0)?;
        finite("vlVolume", &corner1)?;
        if !(bytes == 1 || bytes == 2) {
            return err(
                ErrorCode::BadValue,
                format!("vlVolume: {bytes} bytes per voxel (1 or 2)"),
            );
        }
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
        colour("vlDirectionalLight", rgb)?;
        intensity("vlDirectionalLight", i)?;
        let d = crate::model::scene::v3(dir);
        let len = d.length();
        if len.is_nan() || len <= 0.0 || !len.is_finite() {
            return err(ErrorCode::BadValue, "vlDirectionalLight: zero direction");
        }
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
    /// both finite and positive.
    pub fn step_size(&mut self, step: f32, reference: f32) -> Result<()> {
        self.check(Command::StepSize)?;
        positive("vlStepSize", &[step, reference])?;
        let r = &mut self.settings_mut().render;
        r.step = step;
        r.reference = reference;
        Ok(())
    }

    /// `vlSurface`: adds an iso-surface of `field` at `threshold` (in [0, 1]) to the surfaces
    /// later objects capture for DSR; any number, on any fields.
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
    pub fn load(&mut self, id: i32, path: impl AsRef<Path>) -> Result<()> {
        self.check(Command::Load)?;
        let d = Dataset::load(path.as_ref())?;
        self.datasets.insert(id, Arc::new(d));
        Ok(())
    }

    /// Files an in-memory dataset under `id` (the Rust counterpart of `vlLoad`). An
    /// `Arc<Dataset>` is shared, not copied: several libraries (or ids) can hold one dataset,
    /// and its caches (brick ranges) are computed once for all of them.
    pub fn add_dataset(&mut self, id: i32, dataset: impl Into<Arc<Dataset>>) -> Result<()> {
        self.check(Command::Load)?;
        self.datasets.insert(id, dataset.into());
        Ok(())
    }

    /// The dataset filed under `id`.
    pub fn dataset_of(&self, id: i32) -> Option<&Arc<Dataset>> {
        self.datasets.get(&id)
    }

    /// `vlUnload`: forgets dataset `id`; objects that cast it keep their reference, so the
    /// memory is freed when the last of them is gone.
    pub fn unload(&mut self, id: i32) -> Result<()> {
        self.check(Command::Unload)?;
        match self.datasets.remove(&id) {
            Some(_) => Ok(()),
            None => err(ErrorCode::BadId, format!("vlUnload: no dataset {id}")),
        }
    }

    fn settings(&self) -> &Settings {
        match &self.scene {
            Some(s) => &s.settings,
            None => &self.defaults,
        }
    }

    fn filter(&self) -> Filter {
        let r = &self.settings().render;
        Filter::new(r.interpolation, r.cubic)
    }

    /// `vlSample` outside sample scope: dataset `id`'s normalised value at dataset coordinates
    /// (x, y, z), under the interpolation in force.
    pub fn sample(&self, id: i32, x: f32, y: f32, z: f32) -> Result<f32> {
        self.check(Command::Sample)?;
        crate::model::program::sample_dataset(&self.datasets, id, [x, y, z], self.filter())
    }

    /// `vlMapping`: declares (or replaces) transfer function `id`. Objects that already mapped
    /// through the old definition keep it.
    pub fn mapping(
        &mut self,
        id: i32,
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

    /// `vlObject`: opens an object capturing the rendering state in force. Inside an object it
    /// opens a child, placed in its parent's space; only root objects are rendered.
    pub fn object(&mut self) -> Result<()> {
        self.check(Command::Object)?;
        if self.scene_mut().open.len() >= MAX_DEPTH {
            return err(
                ErrorCode::BadValue,
                format!("vlObject: objects nest at most {MAX_DEPTH} deep"),
            );
        }
        let s = self.scene_mut();
        let state = s.settings.render.clone();
        s.open.push(ObjectDesc::new(state));
        Ok(())
    }

    fn transform(&mut self, cmd: Command, m: DMat4) -> Result<()> {
        self.check(cmd)?;
        let obj = self.object_mut();
        let next = m * obj.to_world;
        invertible(cmd.name(), &next)?;
        obj.to_world = next;
        Ok(())
    }

    /// `vlScale`: non-zero finite factors (negative mirrors).
    pub fn scale(&mut self, x: f32, y: f32, z: f32) -> Result<()> {
        self.check(Command::Scale)?;
        finite("vlScale", &[x, y, z])?;
        if [x, y, z].contains(&0.0) {
            return err(
                ErrorCode::BadValue,
                "vlScale: a factor of 0 makes the object flat",
            );
        }
        self.transform(
            Command::Scale,
            DMat4::from_scale(crate::model::scene::v3([x, y, z])),
        )
    }

    /// `vlTranslate`.
    pub fn translate(&mut self, x: f32, y: f32, z: f32) -> Result<()> {
        self.check(Command::Translate)?;
        finite("vlTranslate", &[x, y, z])?;
        self.transform(
            Command::Translate,
            DMat4::from_translation(crate::model::scene::v3([x, y, z])),
        )
    }

    /// `vlRotate`: degrees about x, then y, then z.
    pub fn rotate(&mut self, x: f32, y: f32, z: f32) -> Result<()> {
        self.check(Command::Rotate)?;
        finite("vlRotate", &[x, y, z])?;
        let r = |d: f32| (d as f64).to_radians();
        let m = DMat4::from_rotation_z(r(z))
            * DMat4::from_rotation_y(r(y))
            * DMat4::from_rotation_x(r(x));
        self.transform(Command::Rotate, m)
    }

    /// `vlFlip`: mirrors object space (p → 1 − p) on the axes of the mask (`VL_X|VL_Y|VL_Z`).
    /// Flips act in object space, before every other transform, whenever they are issued.
    pub fn flip(&mut self, axes_mask: i32) -> Result<()> {
        self.check(Command::Flip)?;
        if axes_mask & !(axes::X | axes::Y | axes::Z) != 0 {
            return err(
                ErrorCode::BadEnum,
                format!("vlFlip: axis mask {axes_mask:#x} has unknown bits"),
            );
        }
        let obj = self.object_mut();
        for (i, bit) in [axes::X, axes::Y, axes::Z].iter().enumerate() {
            if axes_mask & bit != 0 {
                obj.flip[i] = !obj.flip[i];
            }
        }
        Ok(())
    }

    /// `vlMatrix`: a general affine 4×4 transform, row-major, acting on column vectors
    /// (translation in the last column); the bottom row must be (0, 0, 0, 1).
    pub fn matrix(&mut self, m: &[f32; 16]) -> Result<()> {
        self.check(Command::Matrix)?;
        finite("vlMatrix", m)?;
        if m[12..16] != [0.0, 0.0, 0.0, 1.0] {
            return err(
                ErrorCode::BadValue,
                "vlMatrix: only affine transforms (bottom row 0 0 0 1) are supported",
            );
        }
        let row = |i: usize| {
            DVec4::new(
                m[4 * i] as f64,
                m[4 * i + 1] as f64,
                m[4 * i + 2] as f64,
                m[4 * i + 3] as f64,
            )
        };
        let mat = DMat4::from_cols(row(0), row(1), row(2), row(3)).transpose();
        self.transform(Command::Matrix, mat)
    }

    /// `vlBoundary`: scales the boundary box about the cube centre (positive factors).
    pub fn boundary(&mut self, x: f32, y: f32, z: f32) -> Result<()> {
        self.check(Command::Boundary)?;
        positive("vlBoundary", &[x, y, z])?;
        self.object_mut().boundary = [x, y, z];
        Ok(())
    }

    /// `vlSpatial`: an instruction running a spatial transfer function, which may move the
    /// sample point ([`Sample::set_position`]); later instructions see the new point.
    pub fn spatial<F>(&mut self, f: F) -> Result<()>
    where
        F: Fn(&mut Sample) + Send + Sync + 'static,
    {
        self.spatial_arc(Arc::new(f))
    }

    /// `vlSpatial` with a shared function.
    pub fn spatial_arc(&mut self, f: crate::model::program::FieldFn) -> Result<()> {
        self.check(Command::Spatial)?;
        self.object_mut().program.push(Instr::Spatial { f });
        Ok(())
    }

    /// `vlSet` in an object: an instruction assigning a constant (clamped to [0, 1], NaN → 0).
    pub fn set(&mut self, fields: Fields, value: f32) -> Result<()> {
        self.check(Command::Set)?;
        fields.validate()?;
        self.object_mut().program.push(Instr::Set {
            fields,
            value: clamp_field(value),
        });
        Ok(())
    }

    /// `vlFunction`: an instruction running `f` at each sample; it may write `fields`.
    pub fn function<F>(&mut self, fields: Fields, f: F) -> Result<()>
    where
        F: Fn(&mut Sample) + Send + Sync + 'static,
    {
        self.function_arc(fields, Arc::new(f))
    }

    /// `vlFunction` with a shared function.
    pub fn function_arc(
        &mut self,
        fields: Fields,
        f: crate::model::program::FieldFn,
    ) -> Result<()> {
        self.check(Command::Function)?;
        fields.validate()?;
        self.object_mut()
            .program
            .push(Instr::Function { fields, f });
        Ok(())
    }

    /// `vlDataset`: an instruction writing dataset `id`, interpolated with the filter in force
    /// now, to `fields`.
    pub fn dataset(&mut self, fields: Fields, id: i32) -> Result<()> {
        self.check(Command::Dataset)?;
        fields.validate()?;
        let data =
            self.datasets.get(&id).cloned().ok_or_else(|| {
                Error::new(ErrorCode::BadId, format!("vlDataset: no dataset {id}"))
            })?;
        let filter = self.filter();
        self.object_mut().program.push(Instr::Dataset {
            fields,
            data,
            filter,
        });
        Ok(())
    }

    /// `vlMap`: targets = Φ(mapping)(source), with `output` counted from 1.
    pub fn map(
        &mut self,
        targets: Fields,
        source: Fields,
        mapping: i32,
        output: i32,
    ) -> Result<()> {
        self.check(Command::Map)?;
        targets.validate()?;
        let source = source.validate_single()?;
        let m =
            self.mappings.get(&mapping).cloned().ok_or_else(|| {
                Error::new(ErrorCode::BadId, format!("vlMap: no mapping {mapping}"))
            })?;
        if output < 1 || output as usize > m.outputs() {
            return err(
                ErrorCode::BadIndex,
                format!(
                    "vlMap: output {output} of mapping {mapping}, which has {} output(s)",
                    m.outputs()
                ),
            );
        }
        self.object_mut().program.push(Instr::Map {
            targets,
            source,
            mapping: m,
            output: output as usize - 1,
        });
        Ok(())
    }

    /// `vlNormal`: appends a normal function to the object's chain.
    pub fn normal<F>(&mut self, f: F) -> Result<()>
    where
        F: Fn(&mut [f32; 3], &mut Sample) + Send + Sync + 'static,
    {
        self.normal_arc(Arc::new(f))
    }

    /// `vlNormal` with a shared function.
    pub fn normal_arc(&mut self, f: NormalFn) -> Result<()> {
        self.check(Command::Normal)?;
        self.object_mut().normals.push(f);
        Ok(())
    }

    /// Renders the open scene (at scene scope) to an image in memory without closing it or
    /// writing its outputs: a preview for Rust users and tests. Not a command of the C API.
    pub fn render_preview(&self, width: u32, height: u32, aspect: f32) -> Result<crate::Image> {
        let desc = self.open_scene("render_preview")?;
        positive("render_preview", &[aspect])?;
        if width == 0 || height == 0 || width as u64 * height as u64 > MAX_IMAGE_PIXELS {
            return err(
                ErrorCode::BadValue,
                format!("render_preview: size {width}x{height}"),
            );
        }
        crate::render::render_image(&self.compile(&desc), width, height, aspect)
    }

    /// The open scene (at scene scope) compiled as it would render now (for tests of the
    /// renderer's internals).
    #[cfg(test)]
    pub(crate) fn compiled(&self) -> Result<crate::render::Compiled> {
        Ok(self.compile(&self.open_scene("compiled")?))
    }

    /// `desc`, the open scene, compiled with the scene's empty-space grids.
    fn compile(&self, desc: &SceneDesc) -> crate::render::Compiled {
        let grids = &self.scene.as_ref().expect("scene scope").grids;
        crate::render::Compiled::new(desc, grids)
    }

    /// The open scene (at scene scope) as it would render now, without its outputs.
    pub(crate) fn open_scene(&self, what: &str) -> Result<SceneDesc> {
        if self.scope() != Scope::Scene {
            return err(
                ErrorCode::BadScope,
                format!("{what} needs an open scene outside objects"),
            );
        }
        let s = self.scene.as_ref().expect("scene scope");
        Ok(SceneDesc {
            settings: s.settings.clone(),
            lights: s.lights.clone(),
            images: Vec::new(),
            volumes: Vec::new(),
            objects: s.objects.clone(),
            datasets: Arc::new(self.datasets.clone()),
        })
    }

    /// The render plan the open scene compiles to (which effects it calls for); at scene scope.
    /// Not a command of the C API.
    pub fn render_plan(&self) -> Result<crate::render::Plan> {
        let desc = self.open_scene("render_plan")?;
        Ok(self.compile(&desc).plan())
    }

    /// Switches the pixel-preserving speed-ups (empty-space skipping, early ray termination)
    /// on or off, for benchmarks, and sets early termination's threshold; at library or scene
    /// scope like the other settings. A threshold outside [0, 1) (NaN included) is refused
    /// with `BadValue` and nothing changes. Not a command of the C API.
    pub fn set_optimise(&mut self, optimise: crate::model::scene::Optimise) -> Result<()> {
        if !matches!(self.scope(), Scope::Library | Scope::Scene) {
            return err(
                ErrorCode::BadScope,
                "set_optimise: library or scene scope only",
            );
        }
        let t = optimise.termination;
        if !(0.0..1.0).contains(&t) {
            return err(
                ErrorCode::BadValue,
                format!("set_optimise: termination {t} (a transmittance in [0, 1))"),
            );
        }
        self.settings_mut().optimise = optimise;
        Ok(())
    }

    /// A textual snapshot of the whole state, for tests that check a refused call changed
    /// nothing.
    pub fn fingerprint(&self) -> String {
        format!("{self:?}")
    }
}
