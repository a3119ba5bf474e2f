//! The workspace's task runner, `cargo xtask <task>` (an alias in `.cargo/config.toml`). It owns
//! the command line of the tasks: `install` lives in [`install`] (building and copying) and
//! [`pc`] (the pkg-config file), `uninstall` in [`uninstall`], `test` in [`suite`]. It needs
//! only cargo, a C toolchain's `strip`, the standard library, `serde_json` (for cargo's JSON
//! messages) and `libc` (for `openat` and its flags); it is not part of the C library or of the
//! published crates.

mod install;
mod pc;
mod suite;
mod uninstall;

use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "\
usage: cargo xtask install [options]
       cargo xtask uninstall [--prefix DIR] [--libdir DIR] [--includedir DIR] [--destdir DIR]
                             [--dry-run]
       cargo xtask test

Builds the C library (package vlib-capi) and installs it into a prefix:
  <libdir>/libvlib.so.X.Y.Z, its links libvlib.so.X (the SONAME) and libvlib.so,
  <libdir>/libvlib.a, <includedir>/vlib.h and vlaux.h, <libdir>/pkgconfig/vlib.pc.
The libraries are stripped (strip, or $STRIP).

options:
  --prefix DIR          install under DIR (default /usr/local)
  --libdir DIR          libraries, relative to the prefix or absolute (default lib)
  --includedir DIR      headers, relative to the prefix or absolute (default include)
  --destdir DIR         stage the files under DIR; vlib.pc still names the prefix
  --library-type TYPE   cdylib (libvlib.so) or staticlib (libvlib.a); repeat for both
                        (default both)
  --profile NAME        the cargo profile to build (default release)
  --features LIST       features of vlib-capi to build with (comma-separated; repeatable):
                        mpi for the MPI build (docs/mpi.md)
  --from-stage DIR      build nothing: install what an earlier run with --destdir DIR and
                        the same --prefix, --libdir and --includedir staged there (run the
                        xtask binary as root this way to install what you built as yourself)
  -h, --help            this text

uninstall removes what install put under the prefix (the same --prefix, --libdir,
--includedir and --destdir): libvlib.so.X.Y.Z of any version, the links to them,
libvlib.a, vlib.h, vlaux.h and pkgconfig/vlib.pc. It removes nothing where one of them is
not what install makes or vlib.pc names another prefix; directories are left.
  --dry-run             list what would be removed, remove nothing

test runs every test: cargo test --release --workspace, then the MPI build's tests where
Open MPI (mpicc, mpirun) and libclang are there or CI is set (else a note says they were
skipped). It takes no options.";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: &[String]) -> Result<(), String> {
    match args.first().map(String::as_str) {
        Some("install") if !args[1..].iter().any(|a| a == "-h" || a == "--help") => {
            install::install(&parse_install(&args[1..])?)
        }
        Some("uninstall") if !args[1..].iter().any(|a| a == "-h" || a == "--help") => {
            uninstall::uninstall(&parse_uninstall(&args[1..])?)
        }
        Some("test") if args.len() == 1 => suite::test(&install::workspace_root()),
        Some("test") if args[1..].iter().all(|a| a == "-h" || a == "--help") => {
            println!("{USAGE}");
            Ok(())
        }
        Some("test") => Err(format!(
            "test takes no options (`{}`)\n\n{USAGE}",
            args[1..].join(" ")
        )),
        Some("install" | "uninstall" | "-h" | "--help" | "help") => {
            println!("{USAGE}");
            Ok(())
        }
        Some(other) => Err(format!("unknown task `{other}`\n\n{USAGE}")),
        None => Err(format!("no task given\n\n{USAGE}")),
    }
}

/// Which of the two libraries to install.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LibraryTypes {
    pub shared: bool,
    pub archive: bool,
}

/// The options of `install`.
#[derive(Debug, PartialEq, Eq)]
pub struct InstallOptions {
    pub prefix: PathBuf,
    pub libdir: PathBuf,
    pub includedir: PathBuf,
    pub destdir: Option<PathBuf>,
    pub types: LibraryTypes,
    pub profile: String,
    /// The features of vlib-capi to build with, one a string.
    pub features: Vec<String>,
    /// Install the files staged under this directory instead of building.
    pub from_stage: Option<PathBuf>,
}

/// The options of `uninstall`.
#[derive(Debug, PartialEq, Eq)]
pub struct UninstallOptions {
    pub prefix: PathBuf,
    pub libdir: PathBuf,
    pub includedir: PathBuf,
    pub destdir: Option<PathBuf>,
    /// List what would be removed, remove nothing.
    pub dry_run: bool,
}

/// The option at `args[*i]`, one of `known`: its name and its value, given inline
/// (`--name=value`) or as the next argument (`--name value`, which moves `*i` past it); the
/// value must not be empty. `task` names the task in the message for an unknown option.
fn option_value<'a>(
    args: &'a [String],
    i: &mut usize,
    known: &[&str],
    task: &str,
) -> Result<(&'a str, String), String> {
    let arg = &args[*i];
    let (name, inline) = match arg.split_once('=') {
        Some((n, v)) if n.starts_with("--") => (n, Some(v.to_string())),
        _ => (arg.as_str(), None),
    };
    if !known.contains(&name) {
        return Err(format!("unknown option `{arg}`{task}\n\n{USAGE}"));
    }
    let value = match inline {
        Some(v) => v,
        None => {
            *i += 1;
            args.get(*i)
                .cloned()
                .ok_or_else(|| format!("{name} needs a value"))?
        }
    };
    if value.is_empty() {
        return Err(format!("{name} needs a non-empty value"));
    }
    Ok((name, value))
}

fn parse_uninstall(args: &[String]) -> Result<UninstallOptions, String> {
    let mut o = UninstallOptions {
        prefix: PathBuf::from("/usr/local"),
        libdir: PathBuf::from("lib"),
        includedir: PathBuf::from("include"),
        destdir: None,
        dry_run: false,
    };
    let mut i = 0;
    while i < args.len() {
        let arg = &args[i];
        if arg == "--dry-run" {
            o.dry_run = true;
            i += 1;
            continue;
        }
        let known = ["--prefix", "--libdir", "--includedir", "--destdir"];
        let (name, value) = option_value(args, &mut i, &known, " of uninstall")?;
        let value = PathBuf::from(value);
        match name {
            "--prefix" => o.prefix = value,
            "--libdir" => o.libdir = value,
            "--includedir" => o.includedir = value,
            _ => o.destdir = Some(value),
        }
        i += 1;
    }
    o.prefix = std::path::absolute(&o.prefix)
        .map_err(|e| format!("--prefix {}: {e}", o.prefix.display()))?;
    Ok(o)
}

fn parse_install(args: &[String]) -> Result<InstallOptions, String> {
    let mut prefix = PathBuf::from("/usr/local");
    let mut libdir = PathBuf::from("lib");
    let mut includedir = PathBuf::from("include");
    let mut destdir = None;
    let mut types: Option<LibraryTypes> = None;
    let mut profile = String::from("release");
    let mut features = Vec::new();
    let mut from_stage = None;
    // The build options given, which --from-stage refuses.
    let mut build_options = Vec::new();
    let mut i = 0;
    while i < args.len() {
        let known = [
            "--prefix",
            "--libdir",
            "--includedir",
            "--destdir",
            "--library-type",
            "--profile",
            "--features",
            "--from-stage",
        ];
        let (name, value) = option_value(args, &mut i, &known, "")?;
        if ["--destdir", "--library-type", "--profile", "--features"].contains(&name) {
            build_options.push(name);
        }
        match name {
            "--prefix" => prefix = PathBuf::from(value),
            "--libdir" => libdir = PathBuf::from(value),
            "--includedir" => includedir = PathBuf::from(value),
            "--destdir" => destdir = Some(PathBuf::from(value)),
            "--profile" => profile = value,
            "--features" => features.extend(
                value
                    .split([',', ' '])
                    .filter(|f| !f.is_empty())
                    .map(str::to_string),
            ),
            "--from-stage" => from_stage = Some(PathBuf::from(value)),
            _ => {
                let t = types.get_or_insert(LibraryTypes {
                    shared: false,
                    archive: false,
                });
                match value.as_str() {
                    "cdylib" => t.shared = true,
                    "staticlib" => t.archive = true,
                    other => {
                        return Err(format!(
                            "--library-type {other}: expected cdylib or staticlib"
                        ))
                    }
                }
            }
        }
        i += 1;
    }
    if let (Some(stage), Some(option)) = (&from_stage, build_options.first()) {
        return Err(format!(
            "--from-stage {} installs what that stage holds as it is; {option} belongs to the \
             run that staged it",
            stage.display()
        ));
    }
    let prefix =
        std::path::absolute(&prefix).map_err(|e| format!("--prefix {}: {e}", prefix.display()))?;
    // Before anything is built: vlib.pc must be able to name the directories.
    pc::check_paths(&prefix, &libdir, &includedir)?;
    Ok(InstallOptions {
        prefix,
        libdir,
        includedir,
        destdir,
        types: types.unwrap_or(LibraryTypes {
            shared: true,
            archive: true,
        }),
        profile,
        features,
        from_stage,
    })
}

/// A new empty directory `xtask-<name>-<pid>` under the temporary directory, for one test.
#[cfg(test)]
fn test_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("xtask-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> Result<InstallOptions, String> {
        parse_install(&args.iter().map(|s| s.to_string()).collect::<Vec<_>>())
    }

    #[test]
    fn defaults_install_both_libraries_under_usr_local() {
        let o = parse(&[]).unwrap();
        assert_eq!(o.prefix, PathBuf::from("/usr/local"));
        assert_eq!(o.libdir, PathBuf::from("lib"));
        assert_eq!(o.includedir, PathBuf::from("include"));
        assert_eq!(o.destdir, None);
        assert!(o.types.shared && o.types.archive);
        assert_eq!(o.profile, "release");
        assert!(o.features.is_empty());
        assert_eq!(o.from_stage, None);
    }

    #[test]
    fn options_take_separate_or_inline_values() {
        let o = parse(&[
            "--prefix=/opt/vlib",
            "--libdir",
            "lib64",
            "--library-type",
            "staticlib",
            "--destdir=/tmp/stage",
            "--profile",
            "dev",
        ])
        .unwrap();
        assert_eq!(o.prefix, PathBuf::from("/opt/vlib"));
        assert_eq!(o.libdir, PathBuf::from("lib64"));
        assert_eq!(o.destdir, Some(PathBuf::from("/tmp/stage")));
        assert_eq!(
            o.types,
            LibraryTypes {
                shared: false,
                archive: true
            }
        );
        assert_eq!(o.profile, "dev");
    }

    #[test]
    fn a_relative_prefix_is_taken_from_the_working_directory() {
        let o = parse(&["--prefix", "stage"]).unwrap();
        assert_eq!(o.prefix, std::env::current_dir().unwrap().join("stage"));
    }

    #[test]
    fn bad_options_are_refused_with_a_reason() {
        let err = |args: &[&str]| parse(args).unwrap_err();
        assert!(err(&["--prefx", "/x"]).contains("unknown option `--prefx`"));
        assert!(err(&["--prefix"]).contains("--prefix needs a value"));
        assert!(err(&["--prefix="]).contains("non-empty"));
        assert!(err(&["--library-type", "rlib"]).contains("expected cdylib or staticlib"));
        assert!(run(&["remove".into()])
            .unwrap_err()
            .contains("unknown task `remove`"));
        assert!(run(&[]).unwrap_err().contains("no task"));
    }

    #[test]
    fn features_accumulate_from_lists_and_repeats() {
        let o = parse(&["--features", "mpi", "--features=capi,mpi"]).unwrap();
        assert_eq!(o.features, ["mpi", "capi", "mpi"]);
        assert_eq!(
            parse(&["--features", "a b,,c"]).unwrap().features,
            ["a", "b", "c"]
        );
        assert!(parse(&["--features"])
            .unwrap_err()
            .contains("--features needs a value"));
    }

    #[test]
    fn from_stage_takes_the_stage_and_refuses_build_options() {
        let o = parse(&["--prefix", "/usr/local", "--from-stage", "/home/me/stage"]).unwrap();
        assert_eq!(o.from_stage, Some(PathBuf::from("/home/me/stage")));
        assert_eq!(o.prefix, PathBuf::from("/usr/local"));
        for option in [
            ["--destdir", "/x"],
            ["--library-type", "cdylib"],
            ["--profile", "dev"],
            ["--features", "mpi"],
        ] {
            let err = parse(&["--from-stage", "/s", option[0], option[1]]).unwrap_err();
            assert!(
                err.contains(&format!("{} belongs to the run that staged it", option[0])),
                "{err}"
            );
        }
    }

    fn parse_un(args: &[&str]) -> Result<UninstallOptions, String> {
        parse_uninstall(&args.iter().map(|s| s.to_string()).collect::<Vec<_>>())
    }

    #[test]
    fn uninstall_takes_the_install_directories_and_a_dry_run() {
        let o = parse_un(&[]).unwrap();
        assert_eq!(o.prefix, PathBuf::from("/usr/local"));
        assert_eq!(o.libdir, PathBuf::from("lib"));
        assert_eq!(o.includedir, PathBuf::from("include"));
        assert_eq!(o.destdir, None);
        assert!(!o.dry_run);
        let o = parse_un(&[
            "--prefix=/opt/v",
            "--libdir",
            "lib64",
            "--includedir=inc",
            "--destdir",
            "/tmp/s",
            "--dry-run",
        ])
        .unwrap();
        assert_eq!(o.prefix, PathBuf::from("/opt/v"));
        assert_eq!(o.libdir, PathBuf::from("lib64"));
        assert_eq!(o.includedir, PathBuf::from("inc"));
        assert_eq!(o.destdir, Some(PathBuf::from("/tmp/s")));
        assert!(o.dry_run);
        assert_eq!(
            parse_un(&["--prefix", "here"]).unwrap().prefix,
            std::env::current_dir().unwrap().join("here")
        );
        let err = |args: &[&str]| parse_un(args).unwrap_err();
        assert!(err(&["--profile", "dev"]).contains("unknown option `--profile` of uninstall"));
        assert!(err(&["--dry-run=yes"]).contains("unknown option `--dry-run=yes`"));
        assert!(err(&["--prefix"]).contains("--prefix needs a value"));
        assert!(err(&["--destdir="]).contains("non-empty"));
    }

    #[test]
    fn the_test_task_runs_the_mpi_tests_where_they_can_build_or_under_ci() {
        use suite::{mpi_decision, Mpi};
        assert_eq!(mpi_decision(true, false, false), Mpi::Run);
        assert_eq!(mpi_decision(false, true, true), Mpi::Run);
        assert!(matches!(mpi_decision(false, false, true), Mpi::Skip(w) if w.contains("mpicc")));
        assert!(matches!(mpi_decision(false, true, false), Mpi::Skip(w) if w.contains("libclang")));
        for name in [
            "libclang.so",
            "libclang.so.16",
            "libclang-19.so.19",
            "libclang-16.so.1",
        ] {
            assert!(suite::is_libclang(name), "{name}");
        }
        for name in [
            "libclang-cpp.so.19",
            "libclang_rt.asan.so",
            "libclangBasic.a",
            "clang.so",
        ] {
            assert!(!suite::is_libclang(name), "{name}");
        }
        assert!(run(&["test".into(), "--release".into()])
            .unwrap_err()
            .contains("test takes no options"));
    }

    /// README's two opening commands are the gallery and `cargo xtask test`, and `.ci/run` runs
    /// that same test command (and no other cargo test).
    #[test]
    fn readme_and_ci_run_the_same_test_command() {
        let root = install::workspace_root();
        let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
        let block: Vec<&str> = readme
            .split("```bash\n")
            .nth(1)
            .and_then(|b| b.split("```").next())
            .expect("README opens with a bash block")
            .lines()
            .map(|l| l.split('#').next().unwrap().trim())
            .collect();
        assert_eq!(block, ["bash examples/gallery.sh", "cargo xtask test"]);
        let ci = std::fs::read_to_string(root.join(".ci/run")).unwrap();
        let tests: Vec<&str> = ci
            .lines()
            .map(str::trim)
            .filter(|l| l.starts_with("cargo test") || l.starts_with("cargo xtask"))
            .collect();
        assert_eq!(tests, ["cargo xtask test"]);
    }

    #[test]
    fn paths_vlib_pc_cannot_name_are_refused_before_any_build() {
        // parse_install refuses them, so install() never starts cargo for them.
        let err = parse(&["--prefix", "/tmp/a#b"]).unwrap_err();
        assert!(err.contains("starts a comment"), "{err}");
        assert!(parse(&["--libdir", "lib dir"]).is_err());
        assert!(parse(&["--includedir", "$inc"]).is_err());
        assert!(run(&["install".into(), "--prefix=/tmp/a#b".into()])
            .unwrap_err()
            .contains("the prefix `/tmp/a#b`"));
    }
}
