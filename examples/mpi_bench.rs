//! A frame of the MNI brain (`examples/mni.rs`'s scene) or of the paper's Figure 2, rendered
//! by one process or split over the ranks of an MPI job (the `mpi` feature, docs/mpi.md):
//! `benches/mpi.sh` runs it both ways and compares the times and the bytes.
//!
//! ```text
//! cargo build --release --features mpi --example mpi_bench
//! RAYON_NUM_THREADS=1 target/release/examples/mpi_bench mni out/one.png --frames=5
//! RAYON_NUM_THREADS=1 mpirun -np 2 -x RAYON_NUM_THREADS target/release/examples/mpi_bench \
//!     mni out/two.png --frames=5
//! ```
//!
//! Arguments: the scene (`mni` or `figure2`), the image file the scene's `end` writes (rank 0
//! writes it), `--size=N` (512), `--frames=N` (5). Started by an MPI launcher it joins the
//! job's team (`Team::world`); otherwise it renders alone. It renders one frame to memory
//! first (the MNI scene's empty-space grid is built then), then `--frames` frames, and prints
//! (rank 0) the median frame time in seconds as `median_s <t>`, and each rank's busy time.

#[path = "common/figure2_scene.rs"]
mod figure2_scene;
#[path = "common/mni_scene.rs"]
mod mni_scene;
#[path = "common/say.rs"]
mod say;

use std::time::Instant;

#[path = "common/flags.rs"]
mod flags;
use flags::flag;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let all: Vec<String> = std::env::args().skip(1).collect();
    let args: Vec<&String> = all.iter().filter(|a| !a.starts_with("--")).collect();
    let scene = args.first().map_or("mni", |s| s.as_str());
    let out = args.get(1).map_or("mpi_bench.png", |s| s.as_str());
    let size: i32 = flag(&all, "--size=", 512)?;
    let frames: usize = flag(&all, "--frames=", 5)?.max(1);
    let mut vl = vlib::Library::new();
    if vlib::Team::launched() {
        vl.set_team(Some(vlib::Team::world()?));
    }
    let rank = vl.team().map_or(0, |t| t.rank());
    match scene {
        "mni" => {
            let vlb = mni_scene::converted_dataset()?;
            vl.load(mni_scene::BRAIN, &vlb)?;
            let dims = vl.dataset_of(mni_scene::BRAIN).expect("loaded").dims();
            mni_scene::mappings(&mut vl)?;
            vl.scene()?;
            vl.image(out, 1.0, size, size)?;
            mni_scene::build(&mut vl, dims, 0.5, true)?;
        }
        "figure2" => figure2_scene::build(&mut vl, out, size)?,
        other => return Err(format!("no scene {other}: mni or figure2").into()),
    }
    let side = size as u32;
    vl.render_preview(side, side, 1.0)?;
    let mut times: Vec<f64> = (0..frames)
        .map(|_| {
            let t = Instant::now();
            vl.render_preview(side, side, 1.0)
                .map(|_| t.elapsed().as_secs_f64())
        })
        .collect::<Result<_, _>>()?;
    times.sort_by(f64::total_cmp);
    vl.end()?;
    if rank == 0 {
        say::say(format_args!("median_s {:.6}", times[frames / 2]))?;
        if let Some(team) = vl.team() {
            say::say(format_args!("{}", team.stats_text().trim_end()))?;
        }
    }
    Ok(())
}
