//! Maximum intensity projection (the paper's section 5.2: `vlRenderType(VL_MIP)`) of the MNI
//! ICBM152 T1 brain.
//!
//! ```text
//! target/release/vlconvert nifti ../shared/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz out/mni.vlb
//! cargo run --release --example mip_brain -- out/mni.vlb out/mip_brain.png [--size=N] [--step=S] [--view=top|side|front]
//! ```
//!
//! The object is `examples/mni.rs`'s (`examples/common/mni_scene.rs`): one world unit per voxel,
//! flipped in x so that the subject's right shows on the left. Its program casts the dataset to
//! F, maps F to opacity with its own ramp, and sets a white colour; the background is black.
//! A MIP object shows, along each ray, its sample of greatest opacity o as `o·(r, g, b)`
//! (without lighting) over `(1 − o)·background`: with white and black, the pixel's grey level
//! is the largest opacity on the ray.
//!
//! In this T1 image cerebrospinal fluid is dark (below about 100 of 255), grey matter about
//! 165 and white matter about 215; the brightest value on a ray through the brain is mostly
//! white matter, 215 to 235. So the ramp ignores everything up to 120 (fluid and the dark rim
//! of the image), gives grey matter about 0.15 and spends most of its range on white matter,
//! 0.35 at 210 to 1 at 240: a ray that meets only cortex shows a dim grey, one that crosses
//! white matter a light grey, and the brightest tracts (the corpus callosum, the internal
//! capsules, the white matter fanning out into the gyri) stand out in white, inside a dim rim of
//! cortex notched by the sulci.
//!
//! The dataset is sampled with the smoothing cubic B-spline (`vlInterpolationType(VL_TRICUBIC)`,
//! `vlCubicFilter(1, 0)`): the maximum of a trilinear reconstruction along a ray sits at the
//! grid nodes the ray passes closest to, and as that distance varies from pixel to pixel it
//! draws moiré fringes over smooth regions (the corpus callosum, seen from above), which the
//! B-spline removes. It costs about three times as much as trilinear.
//!
//! The default view looks down from above (`--view=top`: anterior up, the subject's right on
//! the right); `side` looks at the subject's right side (anterior to the right), `front` at the
//! face, as `examples/mni.rs` does.

#[path = "common/mni_scene.rs"]
mod mni_scene;

#[path = "common/say.rs"]
mod say;
use std::time::Instant;
use vlib::MappingId;
use vlib::{Camera, Fields, Library, MappingType, RenderType};

/// Mapping id of the opacity ramp.
const OPACITY: MappingId = MappingId(10);

/// The opacity ramp on the normalised scale (value / 255): `(value, opacity)` points; Φ_r
/// adds the segments from (0, 0) to the first point and from the last to (1, 1).
const RAMP: [(f32, f32); 4] = [(120.0, 0.0), (170.0, 0.15), (210.0, 0.35), (240.0, 1.0)];

/// The camera for `view` about the volume of `dims` nodes, one world unit per voxel.
fn camera(view: &str, dims: [usize; 3]) -> Result<Camera, String> {
    let ext = dims.map(|n| (n - 1) as f32);
    let c = ext.map(|e| e / 2.0);
    let (eye, up) = match view {
        // RAS: +z is superior, +y anterior, +x the subject's right (flipped by the scene).
        "top" => ([c[0], c[1], c[2] + 600.0], [0.0, 1.0, 0.0]),
        "side" => ([c[0] - 600.0, c[1], c[2]], [0.0, 0.0, 1.0]),
        "front" => ([c[0], c[1] + 600.0, c[2]], [0.0, 0.0, 1.0]),
        _ => return Err(format!("unknown view {view:?} (top, side or front)")),
    };
    Ok(Camera {
        eye,
        at: c,
        up,
        fov: 21.0,
    })
}

/// Builds the MIP scene in an open scene.
fn build(
    vl: &mut Library,
    dims: [usize; 3],
    step: f32,
    view: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    let ext = dims.map(|n| (n - 1) as f32);
    vl.camera(&camera(view, dims)?)?;
    vl.background(0.0, 0.0, 0.0)?;
    vl.step_size(step, 1.0)?;
    vl.interpolation(vlib::Interpolation::Tricubic)?;
    vl.cubic_filter(1.0, 0.0)?; // the smoothing B-spline: no moiré (see above)
    vl.render_type(RenderType::Mip)?;
    vl.object()?;
    vl.flip(vlib::types::axes::X)?;
    vl.scale(ext[0], ext[1], ext[2])?;
    vl.dataset(Fields::F, mni_scene::BRAIN)?;
    vl.map(Fields::O, Fields::F, OPACITY, 1)?;
    vl.set(Fields::COLORS, 1.0)?;
    vl.end()?;
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let positional: Vec<&str> = args
        .iter()
        .map(String::as_str)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let vlb = positional.first().copied().unwrap_or("out/mni.vlb");
    let png = positional.get(1).copied().unwrap_or("out/mip_brain.png");
    let option = |name: &str| {
        args.iter()
            .find_map(|a| a.strip_prefix(&format!("--{name}=")).map(str::to_string))
    };
    let size: i32 = option("size")
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(512);
    let step: f32 = option("step")
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(0.5);
    let view = option("view").unwrap_or_else(|| "top".to_string());

    let start = Instant::now();
    let mut vl = Library::new();
    vl.load(mni_scene::BRAIN, vlb)?;
    let dims = vl.dataset_of(mni_scene::BRAIN).expect("loaded").dims();
    let table: Vec<f32> = RAMP.iter().flat_map(|&(v, o)| [v / 255.0, o]).collect();
    vl.mapping(OPACITY, MappingType::Ramp, RAMP.len() as i32, 1, &table)?;
    vl.scene()?;
    vl.image(png, 1.0, size, size)?;
    build(&mut vl, dims, step, &view)?;
    vl.end()?;
    say::say(format_args!(
        "wrote {png} ({view} view, {size}x{size}, step {step}) in {:.3} s",
        start.elapsed().as_secs_f64()
    ))?;
    Ok(())
}
