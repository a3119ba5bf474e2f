//! The MPI build of the C library (docs/mpi.md), with Open MPI's `mpicc` and `mpirun`: unchanged
//! C programs, started as `mpirun -np 2`, write the bytes one process of the plain library
//! writes (images, super-sampled images, voxelizations), rank 0 alone writing them; with one
//! rank, or without `mpirun`, the MPI build is the plain library. Run by `.ci/run` (it needs
//! Open MPI): `cargo test --release -p vlib-capi --features mpi --test mpi`.
//!
//! The MPI library is built with `--features mpi` and copied out of `target/<profile>/`
//! before the plain one is built there (both are `libvlib.so`).

mod common;

use common::{TempDir, SONAME};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The MPI build of `libvlib.so` (and its SONAME link) in a directory of its own.
fn mpi_library() -> &'static Path {
    static DIR: OnceLock<TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let built = common::cargo_build(&["-p", "vlib-capi", "--lib", "--features", "mpi"]);
        let dir = TempDir::new("mpi-lib");
        std::fs::copy(built.join("libvlib.so"), dir.path().join("libvlib.so"))
            .expect("copy the MPI libvlib.so");
        std::os::unix::fs::symlink("libvlib.so", dir.path().join(SONAME)).expect("link");
        // The plain library back in target/<profile>/ for the plain programs.
        common::ensure_libraries();
        dir
    })
    .path()
}

/// `source` compiled with `mpicc` against the MPI library, into `dir`.
fn compile_mpi(source: &str, dir: &Path) -> PathBuf {
    let lib = mpi_library();
    let exe = dir.join(Path::new(source).file_stem().expect("name"));
    let out = Command::new("mpicc")
        .args(["-std=gnu89", source, "-Iinclude"])
        .arg(format!("-L{}", lib.display()))
        .args(["-lvlib", "-lm", "-o"])
        .arg(&exe)
        .current_dir(common::workspace_root())
        .output()
        .expect("run mpicc (Open MPI's libopenmpi-dev)");
    assert!(
        out.status.success(),
        "mpicc {source}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    exe
}

/// Runs `exe` in `cwd` with the MPI library: under `mpirun -np <ranks>` (one thread a rank),
/// or directly for `None`. Extra environment: `env`.
fn run_mpi(exe: &Path, cwd: &Path, args: &[String], ranks: Option<u32>, env: &[(&str, &str)]) {
    let lib = mpi_library().to_string_lossy().into_owned();
    let mut cmd = match ranks {
        Some(n) => {
            let mut c = Command::new("mpirun");
            c.args(["-np", &n.to_string(), "--oversubscribe"]);
            if is_root() {
                c.arg("--allow-run-as-root");
            }
            c.args(["-x", "LD_LIBRARY_PATH", "-x", "RAYON_NUM_THREADS"]);
            for (k, _) in env {
                c.args(["-x", k]);
            }
            c.arg(exe);
            c
        }
        None => Command::new(exe),
    };
    cmd.args(args)
        .current_dir(cwd)
        .env("LD_LIBRARY_PATH", &lib)
        .env("RAYON_NUM_THREADS", "1")
        .envs(env.iter().copied());
    let out = cmd.output().expect("run mpirun (Open MPI's openmpi-bin)");
    assert!(
        out.status.success(),
        "{} ({ranks:?} ranks) exited with {}:\n{}\n{}",
        exe.display(),
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

/// The files a program wrote in `dir` (images, voxelizations) that were not there before it
/// ran (`before`), with their bytes.
fn outputs(dir: &Path, before: &[String]) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .expect("read the run's directory")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| {
            [".ppm", ".png", ".vlb", ".pfm"]
                .iter()
                .any(|x| n.ends_with(x))
                && !before.contains(n)
        })
        .map(|n| {
            let bytes = std::fs::read(dir.join(&n)).expect("read an output");
            (n, bytes)
        })
        .collect()
}

fn names(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .expect("read dir")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect()
}

/// The outputs of `source` run by one process of the plain library.
fn plain_outputs(source: &str) -> BTreeMap<String, Vec<u8>> {
    let bin = TempDir::new("mpi-plain-bin");
    let exe = common::compile_c(source, bin.path(), &[]);
    let cwd = TempDir::new("mpi-plain-run");
    let args = common::prepare(source, cwd.path());
    let before = names(cwd.path());
    common::run(&exe, cwd.path(), &args);
    let out = outputs(cwd.path(), &before);
    assert!(!out.is_empty(), "{source} wrote nothing");
    out
}

/// The outputs of `source` built with `mpicc` and run with the MPI library (`ranks` as in
/// [`run_mpi`]), and the busy report of its ranks.
fn mpi_outputs(source: &str, ranks: Option<u32>) -> (BTreeMap<String, Vec<u8>>, Option<String>) {
    let bin = TempDir::new("mpi-bin");
    let exe = compile_mpi(source, bin.path());
    let cwd = TempDir::new("mpi-run");
    let args = common::prepare(source, cwd.path());
    let before = names(cwd.path());
    let busy = cwd.path().join("busy.txt");
    let busy_env = busy.to_string_lossy().into_owned();
    run_mpi(
        &exe,
        cwd.path(),
        &args,
        ranks,
        &[("VLIB_MPI_BUSY", busy_env.as_str())],
    );
    (
        outputs(cwd.path(), &before),
        std::fs::read_to_string(&busy).ok(),
    )
}

/// The C programs split over ranks here: the paper's Figure 2 (an image), metaballs
/// (super-sampling 3×3, PNG) and `split.c` (an RGBA image super-sampled 2×2, voxelizations to
/// 16- and 8-bit `.vlb` files, and an error a field function records on the rank that runs it,
/// which `vlError` must report on every rank: the program fails where it does not).
const PROGRAMS: [&str; 3] = [
    "examples/c/figure2.c",
    "examples/c/metaballs.c",
    "capi/tests/mpi/split.c",
];

fn assert_same(source: &str, plain: &BTreeMap<String, Vec<u8>>, got: &BTreeMap<String, Vec<u8>>) {
    assert_eq!(
        plain.keys().collect::<Vec<_>>(),
        got.keys().collect::<Vec<_>>(),
        "{source}: the files written"
    );
    for (name, bytes) in plain {
        assert!(got[name] == *bytes, "{source}: {name} differs");
    }
}

#[test]
fn two_ranks_write_the_bytes_of_one_process() {
    for source in PROGRAMS {
        let plain = plain_outputs(source);
        let (got, busy) = mpi_outputs(source, Some(2));
        assert_same(source, &plain, &got);
        // The busy report: a header and one line per rank, `rank seconds items`; every tile
        // and slab chunk was done by one of them.
        let busy = busy.unwrap_or_else(|| panic!("{source}: no VLIB_MPI_BUSY report"));
        let lines: Vec<Vec<&str>> = busy
            .lines()
            .skip(1)
            .map(|l| l.split(' ').collect())
            .collect();
        assert_eq!(lines.len(), 2, "{source}: {busy}");
        for (r, l) in lines.iter().enumerate() {
            assert_eq!(l[0], r.to_string());
            let seconds: f64 = l[1].parse().expect("seconds");
            assert!(seconds.is_finite() && seconds >= 0.0, "{busy}");
        }
        let items: u64 = lines.iter().map(|l| l[2].parse::<u64>().unwrap()).sum();
        assert!(items > 0, "{source}: {busy}");
    }
}

#[test]
fn one_rank_or_no_launcher_is_the_plain_library() {
    let source = "examples/c/figure2.c";
    let plain = plain_outputs(source);
    for ranks in [Some(1), None] {
        let (got, busy) = mpi_outputs(source, ranks);
        assert_same(source, &plain, &got);
        // Without a team of several ranks there is nothing to report.
        assert_eq!(busy, None, "{ranks:?} ranks");
    }
}
