//! The paper's Figure 6(b): the "twist" spatial transfer function (§4.7) applied to a head, here
//! the MNI ICBM152 brain with the transfer functions of `examples/mni.rs`
//! (`examples/common/mni_scene.rs`).
//!
//! ```text
//! target/release/vlconvert nifti ../shared/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz out/mni.vlb
//! cargo run --release --example twisted_brain -- out/mni.vlb out/twisted_brain.png [--size=N] [--step=S]
//!     [--gradient=G]
//! ```
//!
//! The paper twists about the object's vertical axis, y:
//! Ψ(x) = (r cos θ + 0.5, x_y, r sin θ + 0.5), θ = (π/2) x_y + arctan((x_z − 0.5)/(x_x − 0.5)),
//! r the distance from (0.5, x_y, 0.5). The brain's vertical axis is z (RAS: superior), so here
//! the roles of y and z swap: each horizontal slice (constant p[2]) turns about the axis through
//! (0.5, 0.5, p[2]) by (π/2) p[2], a quarter turn from the bottom of the box to its top, with
//! atan2 for the quadrant. The slices are not square (196 × 232 voxels), so the rotation is done
//! in millimetres (one world unit is one voxel): turning in object units would shear them.
//!
//! Ψ carries the point being rendered to the point of the original brain shown there, so the
//! brain appears turned by −(π/2) p[2]. Turned slices reach beyond the unit cube (a slice's
//! diagonal is longer than its sides), so the object's boundary is enlarged: vl.boundary(1.5,
//! 1.5, 1.5), which holds any turn of a slice (its half-diagonal is 152 mm, its half-sides
//! 98 and 116; 1.5 gives 147 and 174), and leaves z room as the paper's §4.7 example does.
//! Points Ψ carries outside the brain's grid read 0 (a dataset is 0 outside the unit cube,
//! `docs/compat.md`), so the margin shows only the turned brain: the last axial slice, which
//! cuts the brainstem, ends it there instead of repeating through the box's lower half.
//!
//! With a spatial function in its opacity program the object is rendered without empty-space
//! skipping, and its normals are central differences of the whole program (the dataset's own
//! gradients are not used once a point has moved), so this takes longer than `mni`. Those
//! differences read the dataset through the spline of the gradient filter, `--gradient=G`:
//! `bspline` (the default, the gallery's: smooth across cells), `catmull-rom`, or `nodes`
//! (the paper's: the trilinear values, whose differences bend at every cell face and hatch the
//! cortex along the grid).

#[path = "common/mni_scene.rs"]
mod mni_scene;

#[path = "common/say.rs"]
mod say;
use std::f64::consts::FRAC_PI_2;
use std::time::Instant;
use vlib::{Camera, Library, Sample};

/// The paper's severity: a quarter turn over the height of the box.
const TWIST: f64 = FRAC_PI_2;

/// The twist about the vertical (z) axis, in millimetres: `ext` is the box's size.
fn twist(p: [f32; 3], ext: [f32; 3]) -> [f32; 3] {
    let x = (p[0] as f64 - 0.5) * ext[0] as f64;
    let y = (p[1] as f64 - 0.5) * ext[1] as f64;
    let r = x.hypot(y);
    let theta = TWIST * p[2] as f64 + y.atan2(x);
    [
        (r * theta.cos() / ext[0] as f64 + 0.5) as f32,
        (r * theta.sin() / ext[1] as f64 + 0.5) as f32,
        p[2],
    ]
}

/// The brain object of `mni_scene::build`, twisted, with an enlarged boundary. The camera looks
/// at it from the front and a little above, as `mni` does (so the bottom of the brain faces the
/// viewer as there, and the top, turned by a quarter turn, shows its side), lit by two
/// directional lights from above the viewer.
fn build(
    vl: &mut Library,
    dims: [usize; 3],
    step: f32,
    gradient: vlib::GradientFilter,
) -> Result<(), vlib::Error> {
    let ext = dims.map(|n| (n - 1) as f32);
    let centre = ext.map(|e| e / 2.0);
    vl.camera(&Camera {
        eye: [centre[0], centre[1] + 360.0, centre[2] + 30.0],
        at: [centre[0], centre[1], centre[2] - 8.0],
        up: [0.0, 0.0, 1.0],
        fov: 36.0,
    })?;
    vl.background(0.0, 0.0, 0.0)?;
    vl.ambient(1.0, 1.0, 1.0, 1.0)?;
    vl.directional_light([0.45, -0.8, -0.4], [1.0, 1.0, 1.0], 0.8)?;
    vl.directional_light([0.6, -0.3, -0.75], [1.0, 0.95, 0.9], 0.35)?;
    vl.step_size(step, 1.0)?;
    vl.interpolation(vlib::Interpolation::Trilinear)?;
    vl.gradient_filter(gradient)?;
    vl.object()?;
    vl.flip(vlib::types::axes::X)?;
    vl.scale(ext[0], ext[1], ext[2])?;
    vl.boundary(1.5, 1.5, 1.5)?;
    vl.spatial(move |s: &mut Sample| {
        let q = twist(s.position(), ext);
        let _ = s.set_position(q);
    })?;
    mni_scene::fields(vl, true)?;
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
    let option = |name: &str| args.iter().find_map(|a| a.strip_prefix(name));
    let vlb = positional.first().copied().unwrap_or("out/mni.vlb");
    let png = positional
        .get(1)
        .copied()
        .unwrap_or("out/twisted_brain.png");
    let size: i32 = option("--size=")
        .map(str::parse)
        .transpose()?
        .unwrap_or(512);
    let step: f32 = option("--step=")
        .map(str::parse)
        .transpose()?
        .unwrap_or(0.5);
    let gradient = mni_scene::gradient_named(option("--gradient=").unwrap_or("bspline"))?;
    let start = Instant::now();
    let mut vl = Library::new();
    vl.load(mni_scene::BRAIN, vlb)?;
    let dims = vl.dataset_of(mni_scene::BRAIN).expect("loaded").dims();
    mni_scene::mappings(&mut vl)?;
    vl.scene()?;
    vl.image(png, 1.0, size, size)?;
    build(&mut vl, dims, step, gradient)?;
    vl.end()?;
    say::say(format_args!(
        "wrote {png} in {:.3} s",
        start.elapsed().as_secs_f64()
    ))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_twist_turns_slices_rigidly_by_a_quarter_turn_over_the_height() {
        let ext = [196.0, 232.0, 188.0];
        // The axis stays put; the bottom slice is not turned.
        assert_eq!(twist([0.5, 0.5, 0.7], ext), [0.5, 0.5, 0.7]);
        let q = twist([0.9, 0.3, 0.0], ext);
        assert!((q[0] - 0.9).abs() < 1e-6 && (q[1] - 0.3).abs() < 1e-6);
        // At the top, +x (in mm) goes to +y: a quarter turn, distances kept.
        let q = twist([0.5 + 50.0 / 196.0, 0.5, 1.0], ext);
        assert!((q[0] - 0.5).abs() < 1e-6);
        assert!(((q[1] - 0.5) * 232.0 - 50.0).abs() < 1e-3);
    }
}
