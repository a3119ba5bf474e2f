//! The Rust API's team (the `mpi` feature, docs/mpi.md): a `Library` with `Team::world()`
//! under `mpirun -np 2` renders what one process renders, byte for byte, every rank getting
//! every pixel of `render` and rank 0 alone writing the scene's file. Run by `.ci/run` (it
//! needs Open MPI): `cargo test --release -p vlib-volume --features mpi --test mpi`.
//!
//! The ranks are this test binary itself, started by `mpirun` to run the ignored test
//! [`rank_of_a_job`], which reads where to write from `VLIB_MPI_TEST_DIR`.

#[path = "../examples/common/figure2_scene.rs"]
mod figure2_scene;

use std::path::Path;
use std::process::Command;
use vlib::{Backdrop, Library, PixelFormat, Team};

/// The image side of the scene: 120 is not a multiple of the tiles' sides (16, 32), so the
/// split has edge tiles.
const SIDE: i32 = 120;

/// Figure 2 at [`SIDE`]² with 2×2 super-sampling, its image file `out`, its scene left open.
fn scene(vl: &mut Library, out: &Path) {
    figure2_scene::build(vl, out.to_str().expect("utf-8 path"), SIDE).expect("the scene");
    vl.super_sample(2).expect("super-sampling");
}

/// The RGBA8 bytes of the open scene rendered against a transparent backdrop.
fn rgba(vl: &Library) -> Vec<u8> {
    let s = SIDE as u32;
    vl.render(s, s, 1.0, Backdrop::Transparent)
        .expect("render")
        .to_bytes(PixelFormat::Rgba8)
}

/// One rank of the job [`two_ranks_render_what_one_process_renders`] starts: renders the
/// scene in memory (every rank writes what it got as `rank<r>.rgba`) and ends it (rank 0
/// writes `split.png`).
#[test]
#[ignore = "a rank of the MPI job that two_ranks_render_what_one_process_renders starts"]
fn rank_of_a_job() {
    let dir = std::path::PathBuf::from(std::env::var_os("VLIB_MPI_TEST_DIR").expect("dir"));
    let team = Team::world().expect("the job's team");
    let mut vl = Library::new();
    vl.set_team(Some(team.clone()));
    scene(&mut vl, &dir.join("split.png"));
    let bytes = rgba(&vl);
    std::fs::write(dir.join(format!("rank{}.rgba", team.rank())), bytes).expect("write");
    std::fs::write(
        dir.join(format!("rank{}.size", team.rank())),
        team.size().to_string(),
    )
    .expect("write");
    vl.end().expect("the scene's end");
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

#[test]
fn two_ranks_render_what_one_process_renders() {
    let dir = std::env::temp_dir().join(format!("vlib-mpi-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a directory");
    // One process, no team.
    let mut vl = Library::new();
    scene(&mut vl, &dir.join("alone.png"));
    let alone = rgba(&vl);
    vl.end().expect("end");
    // Two ranks of one thread each.
    let exe = std::env::current_exe().expect("this test binary");
    let mut mpirun = Command::new("mpirun");
    mpirun.args(["-np", "2", "--oversubscribe"]);
    if is_root() {
        mpirun.arg("--allow-run-as-root");
    }
    let out = mpirun
        .args(["-x", "VLIB_MPI_TEST_DIR", "-x", "RAYON_NUM_THREADS"])
        .arg(&exe)
        .args(["--ignored", "--exact", "rank_of_a_job", "--test-threads=1"])
        .env("VLIB_MPI_TEST_DIR", &dir)
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .expect("run mpirun (Open MPI's openmpi-bin)");
    assert!(
        out.status.success(),
        "mpirun: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let read = |name: &str| std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    for r in 0..2 {
        assert_eq!(
            read(&format!("rank{r}.size")),
            b"2",
            "rank {r} was in a team of 2"
        );
        assert!(
            read(&format!("rank{r}.rgba")) == alone,
            "rank {r}'s pixels differ from one process's"
        );
    }
    assert!(read("split.png") == read("alone.png"), "the file differs");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A process that starts MPI itself with `MPI_Init` (thread level single), run by
/// [`a_team_needs_mpi_thread_serialized`]: `Team::world` refuses, naming the level.
#[test]
#[ignore = "a process that a_team_needs_mpi_thread_serialized starts"]
fn mpi_started_single() {
    let _universe = mpi::initialize().expect("MPI_Init");
    let level = mpi::environment::threading_support();
    let refused = Team::world().expect_err("a team after MPI_Init");
    // The message goes to stdout for the parent: the level MPI granted, and the refusal.
    println!("level {level:?}; {:?}: {}", refused.code, refused.message);
}

#[test]
fn a_team_needs_mpi_thread_serialized() {
    let exe = std::env::current_exe().expect("this test binary");
    let out = Command::new(&exe)
        .args(["--ignored", "--exact", "mpi_started_single", "--nocapture"])
        .args(["--test-threads=1"])
        .output()
        .expect("run this test binary");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // MPI_Init grants MPI_THREAD_SINGLE (Open MPI) or FUNNELED: both are refused.
    assert!(
        text.contains("level Single; BadValue: MPI was started with thread level Single")
            || text
                .contains("level Funneled; BadValue: MPI was started with thread level Funneled"),
        "{text}"
    );
}
