//! The MNI brain scene of `../shared/bench/README.md` (the VTK peer benchmark), built with the
//! Rust API; shared by `examples/mni.rs`, `benches/mni.rs` and the tests.
//!
//! One voxel is one world unit (1 mm). The dataset's nodes span [0, n − 1] per axis, so the unit
//! cube is scaled by (196, 232, 188). NIfTI's RAS axes are right-handed and vlib's world is
//! left-handed, so the object is flipped in x: the image then shows the subject's right on the
//! left, as VTK (and a radiologist facing the patient) does.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use vlib::{Attenuation, Camera, Fields, Library, MappingType};
use vlib::{DatasetId, MappingId};

/// The converted MNI template: `$VLIB_MNI_VLB`, or `target/bench-data/mni.vlb`, made on first
/// use from `../shared/data/…nii.gz` by `convert(nii, vlb)` (which runs `vlconvert nifti`).
pub fn dataset_path(
    convert: impl FnOnce(&Path, &Path) -> Result<(), String>,
) -> Result<PathBuf, String> {
    if let Some(p) = std::env::var_os("VLIB_MNI_VLB") {
        return Ok(p.into());
    }
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let out = root.join("target/bench-data/mni.vlb");
    if out.exists() {
        return Ok(out);
    }
    let nii = root.join("../shared/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz");
    if !nii.exists() {
        return Err(format!("no {} and no $VLIB_MNI_VLB", nii.display()));
    }
    let dir = out.parent().expect("has a parent");
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    convert(&nii, &out)?;
    Ok(out)
}

/// Runs `vlconvert` (its own workspace package) with `args`, building it first with
/// `cargo build --release -p vlconvert` (once per process; quick when it is up to date).
pub fn vlconvert(args: &[&std::ffi::OsStr]) -> Result<(), String> {
    use std::sync::OnceLock;
    static BUILT: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    let exe = BUILT.get_or_init(|| {
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let st = std::process::Command::new(cargo)
            .args(["build", "--release", "--quiet", "-p", "vlconvert"])
            .current_dir(&root)
            .status()
            .map_err(|e| format!("run cargo: {e}"))?;
        if !st.success() {
            return Err("cargo build -p vlconvert failed".into());
        }
        let target = std::env::var_os("CARGO_TARGET_DIR")
            .map(PathBuf::from)
            .unwrap_or_else(|| root.join("target"));
        Ok(target.join("release/vlconvert"))
    });
    let exe = exe.as_ref().map_err(Clone::clone)?;
    let st = std::process::Command::new(exe)
        .args(args)
        .stdout(std::process::Stdio::null())
        .status()
        .map_err(|e| format!("run {}: {e}", exe.display()))?;
    if st.success() {
        Ok(())
    } else {
        Err(format!("vlconvert {args:?} failed"))
    }
}

/// [`dataset_path`] with `vlconvert nifti` as the conversion.
pub fn converted_dataset() -> Result<PathBuf, String> {
    dataset_path(|nii, vlb| vlconvert(&["nifti".as_ref(), nii.as_os_str(), vlb.as_os_str()]))
}

/// Mapping ids used by the scene.
pub const OPACITY: MappingId = MappingId(1);
const COLOUR: MappingId = MappingId(2);

/// Dataset id of the brain.
pub const BRAIN: DatasetId = DatasetId(1);

/// The gradient filter of the gallery's brain images: the exact gradient of the cubic B-spline
/// of the voxels, whose normals are smooth across the cells (the paper's trilinearly
/// interpolated node differences bend at every cell face and hatch the cortex along the grid;
/// `docs/accuracy.md`, gradient filters). The peer benchmark keeps the paper's (`nodes`).
pub const GALLERY_GRADIENT: vlib::GradientFilter = vlib::GradientFilter::Cubic { b: 1.0, c: 0.0 };

/// The gradient filter a command line names: `nodes` (the paper's), `bspline` (the cubic
/// B-spline's exact gradient) or `catmull-rom` (Catmull–Rom's).
pub fn gradient_named(name: &str) -> Result<vlib::GradientFilter, String> {
    match name {
        "nodes" => Ok(vlib::GradientFilter::Nodes),
        "bspline" => Ok(vlib::GradientFilter::Cubic { b: 1.0, c: 0.0 }),
        "catmull-rom" => Ok(vlib::GradientFilter::Cubic { b: 0.0, c: 0.5 }),
        _ => Err(format!(
            "--gradient={name}: one of nodes, bspline, catmull-rom"
        )),
    }
}

/// The early-termination threshold of VTK's CPU ray caster (`Optimise::termination` terms): it
/// stops a ray once its fixed-point remaining opacity falls below 0xff of 0x7fff.
pub const VTK_TERMINATION: f64 = 255.0 / 32767.0;

/// The transfer functions of `peer_settings.py` on the normalised scale (value / 255).
pub fn mappings(vl: &mut Library) -> Result<(), vlib::Error> {
    let opacity: Vec<f32> = [
        (40.0, 0.0),
        (80.0, 0.10),
        (120.0, 0.35),
        (180.0, 0.60),
        (255.0, 0.85),
    ]
    .iter()
    .flat_map(|&(s, a): &(f32, f32)| [s / 255.0, a])
    .collect();
    vl.mapping(OPACITY, MappingType::Ramp, 5, 1, &opacity)?;
    // VTK's colour function starts at (0: black); Φ_r's implicit first segment from (0, 0) to the
    // first point gives exactly that.
    let colour: Vec<f32> = [
        (60.0, [0.55, 0.35, 0.30]),
        (110.0, [0.88, 0.66, 0.56]),
        (180.0, [0.96, 0.92, 0.86]),
        (255.0, [1.0, 1.0, 1.0]),
    ]
    .iter()
    .flat_map(|&(s, c): &(f32, [f32; 3])| [s / 255.0, c[0], c[1], c[2]])
    .collect();
    vl.mapping(COLOUR, MappingType::Ramp, 4, 3, &colour)
}

/// Builds the scene (camera, light, object) in an open scene; `step` is the sample distance in
/// voxels, `shaded` switches the diffuse and specular terms.
pub fn build(
    vl: &mut Library,
    dims: [usize; 3],
    step: f32,
    shaded: bool,
) -> Result<(), vlib::Error> {
    build_with(vl, dims, step, shaded, vlib::Interpolation::Trilinear)
}

/// [`build`] with another interpolation filter for the dataset (a reference image uses the
/// cubic filter; the peer scene is trilinear, as VTK's).
pub fn build_with(
    vl: &mut Library,
    dims: [usize; 3],
    step: f32,
    shaded: bool,
    interpolation: vlib::Interpolation,
) -> Result<(), vlib::Error> {
    build_scaled(vl, dims, step, shaded, interpolation, 1.0)
}

/// [`build_with`] for a volume of `scale` voxels per millimetre (the scaling table of
/// `benches/scaling.sh`: the template resampled or repeated): the camera `360 · scale` voxels
/// from the centre and opacity per `scale` voxels (1 mm), so that every such volume is seen
/// and weighted as the template is; `step` stays in voxels. A scale of 1 is [`build_with`].
pub fn build_scaled(
    vl: &mut Library,
    dims: [usize; 3],
    step: f32,
    shaded: bool,
    interpolation: vlib::Interpolation,
    scale: f32,
) -> Result<(), vlib::Error> {
    view_from(vl, dims, 360.0 * scale)?;
    vl.step_size(step, scale)?;
    vl.interpolation(interpolation)?;
    object(vl, dims, shaded)
}

/// The camera, background and lights of the peer scene (VTK's view of the brain).
pub fn view(vl: &mut Library, dims: [usize; 3]) -> Result<(), vlib::Error> {
    view_from(vl, dims, 360.0)
}

/// [`view`] with the eye `distance` voxels in front of the volume's centre.
pub fn view_from(vl: &mut Library, dims: [usize; 3], distance: f32) -> Result<(), vlib::Error> {
    let ext = dims.map(|n| (n - 1) as f32);
    let centre = ext.map(|e| e / 2.0);
    vl.camera(&Camera {
        eye: [centre[0], centre[1] + distance, centre[2]],
        at: centre,
        up: [0.0, 0.0, 1.0],
        fov: 30.0,
    })?;
    vl.background(0.0, 0.0, 0.0)?;
    vl.ambient(1.0, 1.0, 1.0, 1.0)?;
    // VTK's headlight: a white light travelling along the view direction.
    vl.directional_light([0.0, -1.0, 0.0], [1.0, 1.0, 1.0], 1.0)
}

/// The brain object, with the step, filter and other object state in force.
pub fn object(vl: &mut Library, dims: [usize; 3], shaded: bool) -> Result<(), vlib::Error> {
    let ext = dims.map(|n| (n - 1) as f32);
    vl.object()?;
    vl.flip(vlib::types::axes::X)?;
    vl.scale(ext[0], ext[1], ext[2])?;
    fields(vl, shaded)?;
    vl.end()?;
    Ok(())
}

/// The brain's field program inside an open object: F from the dataset, opacity and colour
/// through the peer transfer functions, and the shading constants.
pub fn fields(vl: &mut Library, shaded: bool) -> Result<(), vlib::Error> {
    vl.dataset(Fields::F, BRAIN)?;
    vl.map(Fields::O, Fields::F, OPACITY, 1)?;
    vl.map(Fields::R, Fields::F, COLOUR, 1)?;
    vl.map(Fields::G, Fields::F, COLOUR, 2)?;
    vl.map(Fields::B, Fields::F, COLOUR, 3)?;
    vl.set(Fields::KA, 0.2)?;
    if shaded {
        vl.set(Fields::KD, 0.7)?;
        vl.set(Fields::KS, 0.3)?;
        vl.set(Fields::N, vlib::types::specular_to_field(10.0))?;
    } else {
        // Unshaded, VTK shows the classified colour: ambient 1.
        vl.set(Fields::KA, 1.0)?;
    }
    let _ = Attenuation::None;
    Ok(())
}
