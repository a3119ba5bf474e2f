//! The data-parallel scheme of `docs/dev/scale-out.md`, simulated in one process: the MNI brain
//! (`examples/mni.rs`'s scene) cut into K slabs across y (the view direction: the camera
//! looks down −y, so the slabs' order along every ray is their order in y), each slab a
//! dataset of its own rendered as the whole scene of one "rank" (colour over black and
//! transmittance per pixel), the K images composited front to back with the over operator,
//! and the result compared with the one-process render of the whole volume.
//!
//! ```text
//! cargo run --release --example bricks -- [K ...] [--size=N] [--unshaded]
//! ```
//!
//! Adjacent slabs share their boundary plane of nodes, so every cell lies inside one slab and
//! every trilinear value is the whole volume's; what can differ is where a slab's samples lie
//! (each object's segments start at its own box), the gradients at a slab's faces (no ghost
//! voxels beyond them), early termination (a slab does not know what lies in front of it)
//! and rounding. It prints, for each K: the largest difference of an 8-bit channel value
//! from the one-process image, how many differ by 1 and by more, and the time of the
//! compositing against the time of the slabs' renders.

#[path = "common/mni_scene.rs"]
mod mni_scene;
#[path = "common/say.rs"]
mod say;

use std::sync::Arc;
use std::time::Instant;
use vlib::{Backdrop, Dataset, Image, Library, PixelFormat, Voxels};

#[path = "common/flags.rs"]
mod flags;
use flags::flag;

/// The nodes `j0 ..= j1` in y of `data` (x fastest, then y, then z) as a dataset of their own,
/// on the same value scale.
fn slab(data: &Dataset, j0: usize, j1: usize) -> Result<Dataset, vlib::Error> {
    let [nx, ny, nz] = data.dims();
    let rows = |k: usize| (j0..=j1).map(move |j| nx * (j + ny * k));
    let (a, b) = data.range();
    let voxels = match data.raw() {
        Voxels::U8(v) => Voxels::U8(
            (0..nz)
                .flat_map(rows)
                .flat_map(|at| v[at..at + nx].iter().copied())
                .collect(),
        ),
        Voxels::U16(v) => Voxels::U16(
            (0..nz)
                .flat_map(rows)
                .flat_map(|at| v[at..at + nx].iter().copied())
                .collect(),
        ),
        _ => {
            return Err(vlib::Error::new(
                vlib::ErrorCode::BadValue,
                "8 or 16-bit voxels",
            ))
        }
    };
    Dataset::new([nx, j1 - j0 + 1, nz], voxels, a, b)
}

/// The scene of one slab (nodes `j0 ..= j1` of the whole volume of `dims`) in `vl`: the MNI
/// view and fields, the object placed where the slab lies in the whole volume.
fn slab_scene(
    vl: &mut Library,
    dims: [usize; 3],
    j0: usize,
    j1: usize,
    shaded: bool,
) -> Result<(), vlib::Error> {
    let ext = dims.map(|n| (n - 1) as f32);
    mni_scene::mappings(vl)?;
    vl.scene()?;
    vl.step_size(0.5, 1.0)?;
    mni_scene::view(vl, dims)?;
    vl.object()?;
    vl.flip(vlib::types::axes::X)?;
    vl.scale(ext[0], (j1 - j0) as f32, ext[2])?;
    vl.translate(0.0, j0 as f32, 0.0)?;
    mni_scene::fields(vl, shaded)?;
    vl.end().map(|_| ())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let all: Vec<String> = std::env::args().skip(1).collect();
    let ks: Vec<usize> = all
        .iter()
        .filter(|a| !a.starts_with("--"))
        .map(|a| a.parse())
        .collect::<Result<_, _>>()?;
    let ks = if ks.is_empty() { vec![2, 4] } else { ks };
    let size: u32 = flag(&all, "--size=", 512)?;
    let shaded = !all.iter().any(|a| a == "--unshaded");
    let vlb = mni_scene::converted_dataset()?;
    let whole = Arc::new(Dataset::load(&vlb)?);
    let dims = whole.dims();

    // One process: the whole volume.
    let mut vl = Library::new();
    vl.add_dataset(mni_scene::BRAIN, whole.clone())?;
    mni_scene::mappings(&mut vl)?;
    vl.scene()?;
    mni_scene::build(&mut vl, dims, 0.5, shaded)?;
    let t = Instant::now();
    let reference = vl.render(size, size, 1.0, Backdrop::Background)?;
    let one = t.elapsed().as_secs_f64();
    let reference = reference.to_bytes(PixelFormat::Rgb8);
    say::say(format_args!(
        "MNI {size}², {}: one process {one:.3} s",
        if shaded { "shaded" } else { "unshaded" }
    ))?;

    for k in ks {
        // Slab s holds nodes [cut[s], cut[s + 1]]; slab 0 is the one at the largest y (nearest
        // the eye, which looks down −y).
        let last = dims[1] - 1;
        let cut: Vec<usize> = (0..=k).map(|s| last - s * last / k).collect();
        let mut images: Vec<Image> = Vec::new();
        let mut render_s = Vec::new();
        for s in 0..k {
            let (j0, j1) = (cut[s + 1], cut[s]);
            let mut rank = Library::new();
            rank.add_dataset(mni_scene::BRAIN, slab(&whole, j0, j1)?)?;
            slab_scene(&mut rank, dims, j0, j1, shaded)?;
            let t = Instant::now();
            images.push(rank.render(size, size, 1.0, Backdrop::Transparent)?);
            render_s.push(t.elapsed().as_secs_f64());
        }
        // Front to back: C = C_0 + T_0·(C_1 + T_1·(…)), T = T_0·T_1·…; over black.
        let t = Instant::now();
        let n = (size * size) as usize;
        let mut colour = vec![[0f32; 3]; n];
        let mut trans = vec![1f32; n];
        for img in &images {
            for ((c, t), (src, t_src)) in colour
                .iter_mut()
                .zip(trans.iter_mut())
                .zip(img.pixels.iter().zip(&img.transmittance))
            {
                for (c, s) in c.iter_mut().zip(src) {
                    *c += *t * s;
                }
                *t *= t_src;
            }
        }
        let composite_s = t.elapsed().as_secs_f64();
        let composite = Image {
            width: size,
            height: size,
            pixels: colour,
            transmittance: trans,
            backdrop: Backdrop::Background,
        }
        .to_bytes(PixelFormat::Rgb8);
        let diff: Vec<u8> = reference
            .iter()
            .zip(&composite)
            .map(|(a, b)| a.abs_diff(*b))
            .collect();
        let max = diff.iter().max().copied().unwrap_or(0);
        let by_one = diff.iter().filter(|&&d| d == 1).count();
        let more = diff.iter().filter(|&&d| d > 1).count();
        let slowest = render_s.iter().copied().fold(0.0, f64::max);
        say::say(format_args!(
            "K = {k}: largest difference {max} levels; {by_one} of {} channel values differ by 1, \
             {more} by more; slab renders {} s (slowest {slowest:.3} s), compositing {:.4} s \
             ({:.1}% of the slowest slab)",
            diff.len(),
            render_s
                .iter()
                .map(|s| format!("{s:.3}"))
                .collect::<Vec<_>>()
                .join(" + "),
            composite_s,
            100.0 * composite_s / slowest
        ))?;
    }
    Ok(())
}
