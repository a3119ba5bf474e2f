//! The MPI build of the C library (docs/mpi.md), with Open MPI's `mpicc` and `mpirun`: unchanged
//! C programs, started as `mpirun -np 2`, write the bytes one process of the plain library
//! writes (images, super-sampled images, voxelizations), rank 0 alone writing them; with one
//! rank, or without `mpirun`, the MPI build is the plain library; a `vlRenderBuffer` call one
//! rank refuses fails on every rank, and the next goes on (`refused.c`, under a time limit). Run
//! by `.ci/run` (it needs Open MPI): `cargo test --release -p vlib-capi --features mpi --test
//! mpi`.
//!
//! The MPI library is built with `--features mpi` and copied out of `target/<profile>/`
//! before the plain one is built there (both are `libvlib.so`).

mod common;

use common::{TempDir, SONAME};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// The MPI build of `libvlib.so` (and its SONAME link) in a directory of its own beside the
/// profile's outputs, `target/<profile>/mpi-lib` (each run replaces its library, so runs leave
/// no directories behind; a static's temporary directory would never be dropped): the library
/// copied to a name of this process's, then renamed over the last one.
fn mpi_library() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let built = common::cargo_build(&["-p", "vlib-capi", "--lib", "--features", "mpi"]);
        let dir = built.join("mpi-lib");
        std::fs::create_dir_all(&dir).expect("make target/<profile>/mpi-lib");
        let part = dir.join(format!("libvlib.so.{}.part", std::process::id()));
        std::fs::copy(built.join("libvlib.so"), &part).expect("copy the MPI libvlib.so");
        std::fs::rename(&part, dir.join("libvlib.so")).expect("rename the MPI libvlib.so");
        // (Another run may have made the link meanwhile.)
        match std::os::unix::fs::symlink("libvlib.so", dir.join(SONAME)) {
            Err(e) if e.kind() != std::io::ErrorKind::AlreadyExists => panic!("link: {e}"),
            _ => {}
        }
        // The plain library back in target/<profile>/ for the plain programs.
        common::ensure_libraries();
        dir
    })
    .as_path()
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

/// The command that runs `exe` in `cwd` with the MPI library: under `mpirun -np <ranks>` (one
/// thread a rank; `mpirun_args` before the program), or directly for `None`. Extra
/// environment: `env`.
fn mpi_command(
    exe: &Path,
    cwd: &Path,
    ranks: Option<u32>,
    mpirun_args: &[&str],
    env: &[(&str, &str)],
) -> Command {
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
            c.args(mpirun_args).arg(exe);
            c
        }
        None => Command::new(exe),
    };
    cmd.current_dir(cwd)
        .env("LD_LIBRARY_PATH", &lib)
        .env("RAYON_NUM_THREADS", "1")
        .envs(env.iter().copied());
    cmd
}

/// Runs `exe` in `cwd` with the MPI library, as [`mpi_command`] (`ranks`, `env`) makes it.
fn run_mpi(exe: &Path, cwd: &Path, args: &[String], ranks: Option<u32>, env: &[(&str, &str)]) {
    let mut cmd = mpi_command(exe, cwd, ranks, &[], env);
    cmd.args(args);
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

/// How long `mpirun` may run `refused.c`: its `--timeout` ends the job after this (a rank left
/// waiting for another waits forever), and the test kills `mpirun` itself if it is still
/// running half a minute later.
const LIMIT: Duration = Duration::from_secs(60);

/// What a run under `mpirun` gave: its exit status (`None` when it had to be killed), its
/// standard output and error.
struct Run {
    status: Option<ExitStatus>,
    stdout: String,
    stderr: String,
}

/// Runs `exe` in `cwd` under `mpirun -np <ranks>` with the MPI library, ended after [`LIMIT`].
fn run_mpi_within(exe: &Path, cwd: &Path, ranks: u32) -> Run {
    let logs = TempDir::new("mpi-logs");
    let (out, err) = (logs.path().join("stdout"), logs.path().join("stderr"));
    let create = |p: &Path| std::fs::File::create(p).expect("create a log");
    let limit = LIMIT.as_secs().to_string();
    let mut cmd = mpi_command(exe, cwd, Some(ranks), &["--timeout", &limit], &[]);
    cmd.stdin(Stdio::null())
        .stdout(create(&out))
        .stderr(create(&err));
    let mut child = cmd.spawn().expect("run mpirun (Open MPI's openmpi-bin)");
    let wait_until = |child: &mut std::process::Child, deadline: Instant| loop {
        if let Some(status) = child.try_wait().expect("wait for mpirun") {
            return Some(status);
        }
        if Instant::now() > deadline {
            return None;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let status = wait_until(&mut child, Instant::now() + LIMIT + Duration::from_secs(30));
    if status.is_none() {
        // SIGTERM: mpirun passes it on to the ranks (each in a process group of its own) and
        // ends; SIGKILL if it has not ten seconds later.
        let _ = Command::new("kill")
            .args(["-TERM", &child.id().to_string()])
            .status();
        if wait_until(&mut child, Instant::now() + Duration::from_secs(10)).is_none() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
    let read =
        |p: &Path| String::from_utf8_lossy(&std::fs::read(p).unwrap_or_default()).into_owned();
    Run {
        status,
        stdout: read(&out),
        stderr: read(&err),
    }
}

/// The lines `refused.c` prints, "<step> rank <r>: <result> <codes>", by step and rank: the
/// call's result (1 for `VL_TRUE`) and the codes `vlError` reported after it.
fn call_lines(stdout: &str) -> BTreeMap<(String, u32), (u32, Vec<i32>)> {
    let mut calls = BTreeMap::new();
    for line in stdout.lines() {
        let Some((head, tail)) = line.split_once(": ") else {
            continue;
        };
        let Some((step, rank)) = head.split_once(" rank ") else {
            continue;
        };
        let (Ok(rank), Some((result, codes))) = (rank.parse(), tail.split_once(' ')) else {
            continue;
        };
        let codes = match codes {
            "none" => Vec::new(),
            _ => codes
                .split(',')
                .map(|c| c.parse().expect("a code"))
                .collect(),
        };
        let result = result.parse().expect("a result");
        let old = calls.insert((step.to_string(), rank), (result, codes));
        assert!(old.is_none(), "{step} on rank {rank} twice:\n{stdout}");
    }
    calls
}

/// `refused.c`'s steps: a call rank 1 alone refuses, and the code both ranks record for it
/// (one process's: `VL_NULLPOINTER`, `VL_BADENUM`, `VL_BADVALUE`, `VL_BADSCOPE`): where the C
/// layer refuses it, rank 1 takes part in the render's first agreement with its error
/// (`fail_the_team`), as the core does with its own refusals.
const REFUSALS: [(&str, i32); 6] = [
    ("null", 5),
    ("format", 4),
    ("width", 2),
    ("aspect", 2),
    ("short", 2),
    ("scope", 1),
];

#[test]
fn a_render_call_one_rank_refuses_fails_on_every_rank_and_the_next_renders() {
    // Rank 1 refuses a vlRenderBuffer call that rank 0 makes validly (the C layer's checks: a
    // NULL buffer, an unknown format, a width of 0, the scope; the core's: an aspect of -1, a
    // buffer one byte short): both ranks return VL_FALSE, both with the one error REFUSALS
    // gives, rather than rank 0 waiting for rank 1 for ever (mpirun's --timeout ends such a
    // run), and the valid render after each gives both ranks the bytes one process renders.
    let source = "capi/tests/mpi/refused.c";
    let plain = plain_outputs(source);
    let bin = TempDir::new("mpi-bin");
    let exe = compile_mpi(source, bin.path());
    let cwd = TempDir::new("mpi-run");
    let run = run_mpi_within(&exe, cwd.path(), 2);
    let report = format!("stdout:\n{}\nstderr:\n{}", run.stdout, run.stderr);
    let status = run.status.unwrap_or_else(|| {
        panic!("{source}: mpirun still ran {LIMIT:?} + 30 s on, killed:\n{report}")
    });
    assert!(
        status.success(),
        "{source} under mpirun -np 2 exited with {status} (a timeout ends it after \
         {LIMIT:?}):\n{report}"
    );
    let calls = call_lines(&run.stdout);
    let mut renders = vec!["first".to_string()];
    for (step, code) in REFUSALS {
        for rank in 0..2 {
            assert_eq!(
                calls.get(&(step.to_string(), rank)),
                Some(&(0, vec![code])),
                "{step} on rank {rank}: VL_FALSE and the code {code} expected\n{report}"
            );
        }
        renders.push(format!("after-{step}"));
    }
    for step in &renders {
        for rank in 0..2 {
            assert_eq!(
                calls.get(&(step.clone(), rank)),
                Some(&(1, Vec::new())),
                "{step} on rank {rank}: rendered without an error expected\n{report}"
            );
        }
    }
    // Every valid render wrote its buffer: each rank's is one process's.
    let got = outputs(cwd.path(), &[]);
    let mut expected = Vec::new();
    for step in &renders {
        let name = format!("{step}.r0.ppm");
        let bytes = plain
            .get(&name)
            .unwrap_or_else(|| panic!("one process wrote no {name}"));
        for rank in 0..2 {
            let name = format!("{step}.r{rank}.ppm");
            assert!(got.get(&name) == Some(bytes), "{name} differs\n{report}");
            expected.push(name);
        }
    }
    expected.sort();
    assert_eq!(got.keys().cloned().collect::<Vec<_>>(), expected);
}
