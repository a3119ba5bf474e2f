//! `cargo xtask test`: every test of the workspace, the command README.md gives and `.ci/run`
//! runs. First `cargo test --release --workspace` (the core, the C layer, vlconvert, the tasks
//! here); then the MPI build's tests (the C programs under `mpirun`, the team's Rust API), which
//! need Open MPI and libclang (for rsmpi's bindings): run where `mpicc` and `mpirun` answer and
//! a libclang is found, else skipped with a note, and always run where `CI` is set (`.ci/run`
//! installs what they need, so a missing tool fails them there). Each command's output is the
//! terminal's; the first that fails ends the run.

use std::path::Path;
use std::process::{Command, Stdio};

/// The commands, in order: the workspace's tests, then the MPI build's.
pub const WORKSPACE: &[&str] = &["test", "--release", "--workspace"];
pub const MPI: [&[&str]; 2] = [
    &[
        "test",
        "--release",
        "-p",
        "vlib-capi",
        "--features",
        "mpi",
        "--test",
        "mpi",
    ],
    &[
        "test",
        "--release",
        "-p",
        "vlib-volume",
        "--features",
        "mpi",
        "--test",
        "mpi",
    ],
];

/// Whether the MPI tests run, and if not, why.
#[derive(Debug, PartialEq, Eq)]
pub enum Mpi {
    Run,
    Skip(&'static str),
}

/// The MPI tests run under `CI` whatever is installed; elsewhere where Open MPI's compiler and
/// launcher and a libclang are there.
pub fn mpi_decision(ci: bool, open_mpi: bool, libclang: bool) -> Mpi {
    match (ci, open_mpi, libclang) {
        (true, _, _) | (false, true, true) => Mpi::Run,
        (false, false, _) => Mpi::Skip("mpicc or mpirun is not on the PATH (Open MPI)"),
        (false, true, false) => Mpi::Skip("no libclang found (rsmpi's bindings need it)"),
    }
}

pub fn test(root: &Path) -> Result<(), String> {
    cargo(root, WORKSPACE)?;
    let ci = std::env::var_os("CI").is_some_and(|v| !v.is_empty());
    match mpi_decision(ci, answers("mpicc") && answers("mpirun"), libclang_found()) {
        Mpi::Run => {
            for args in MPI {
                cargo(root, args)?;
            }
        }
        Mpi::Skip(why) => println!(
            "note: the MPI tests were skipped: {why}; docs/mpi.md says what they need \
             (.ci/run installs it)"
        ),
    }
    Ok(())
}

/// `cargo <args>` in `root`, its output the terminal's.
fn cargo(root: &Path, args: &[&str]) -> Result<(), String> {
    let shown = format!("cargo {}", args.join(" "));
    println!("== {shown}");
    let status = crate::install::cargo()
        .args(args)
        .current_dir(root)
        .status()
        .map_err(|e| format!("run {shown}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{shown} failed ({status})"))
    }
}

/// Whether `program --version` runs and succeeds.
fn answers(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Whether a libclang shared library is where clang-sys (rsmpi's bindgen) looks first:
/// `$LIBCLANG_PATH`, `llvm-config --libdir`, the system's library directories and LLVM's
/// versioned ones.
fn libclang_found() -> bool {
    let mut dirs: Vec<std::path::PathBuf> = Vec::new();
    if let Some(p) = std::env::var_os("LIBCLANG_PATH") {
        dirs.push(p.into());
    }
    if let Ok(out) = Command::new("llvm-config").arg("--libdir").output() {
        if out.status.success() {
            dirs.push(String::from_utf8_lossy(&out.stdout).trim().into());
        }
    }
    for d in [
        "/usr/lib",
        "/usr/lib64",
        "/usr/local/lib",
        "/usr/lib/x86_64-linux-gnu",
    ] {
        dirs.push(d.into());
    }
    for base in ["/usr/lib", "/usr/lib64"] {
        if let Ok(entries) = std::fs::read_dir(base) {
            for e in entries.flatten() {
                if e.file_name().to_string_lossy().starts_with("llvm") {
                    dirs.push(e.path().join("lib"));
                }
            }
        }
    }
    dirs.iter().any(|d| {
        std::fs::read_dir(d).is_ok_and(|entries| {
            entries
                .flatten()
                .any(|e| is_libclang(&e.file_name().to_string_lossy()))
        })
    })
}

/// Whether a file name is libclang's shared library as clang-sys looks for it: `libclang.so`,
/// `libclang.so.<version>` or `libclang-<version>.so…` (not `libclang-cpp`, not the runtimes).
pub fn is_libclang(name: &str) -> bool {
    name.starts_with("libclang.so")
        || name.strip_prefix("libclang-").is_some_and(|rest| {
            rest.starts_with(|c: char| c.is_ascii_digit()) && rest.contains(".so")
        })
}
