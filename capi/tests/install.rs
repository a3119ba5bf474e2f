//! The installed library (docs/install.md). `cargo xtask install` into a temporary prefix lays
//! out `libvlib.so.X.Y.Z` with the links `libvlib.so.X` (its SONAME) and `libvlib.so`,
//! `libvlib.a`, `vlib.h`, `vlaux.h` and `vlib.pc`; the libraries are stripped, the shared one
//! still exports every command and nothing but vlib's names, the archive still links; `vlib.pc`'s
//! `Libs.private` holds what rustc reports for a static library. `examples/c/figure2.c` builds
//! against the prefix with `cc $(pkg-config --cflags --libs vlib)`, linked to the shared
//! library, and statically: with `pkg-config --static` against a prefix holding only the
//! archive, and naming `-l:libvlib.a` against the full one; all three programs write the image
//! the build tree's figure2 writes. README's static link line names `Libs.private`. `cargo xtask
//! uninstall` then removes every file of the prefix and leaves its directories. When cargo-c is
//! installed (CI installs it), `cargo cinstall` is checked the same way, and uninstalled by
//! `cargo xtask uninstall`.
//!
//! Needs binutils, pkg-config and, for the cargo-c half, cargo-c: `.ci/run` installs them;
//! elsewhere a missing pkg-config or cargo-c skips its part with a message (under `CI` it fails).

#[path = "../src/commands.rs"]
#[allow(dead_code)] // COMMAND_COUNT
mod commands;
mod common;

use common::{TempDir, SONAME};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The full version in the shared library's file name, `libvlib.so.X.Y.Z`.
const FULL: &str = concat!("libvlib.so.", env!("CARGO_PKG_VERSION"));

fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false")
}

/// Whether `cmd` runs and succeeds; under `CI` a missing tool fails the test.
fn available(mut cmd: Command, install_hint: &str) -> bool {
    let ok = cmd.output().is_ok_and(|o| o.status.success());
    if !ok {
        assert!(!in_ci(), "{cmd:?} does not run ({install_hint})");
        eprintln!("{cmd:?} does not run: skipped ({install_hint})");
    }
    ok
}

fn pkg_config_available() -> bool {
    let mut cmd = Command::new("pkg-config");
    cmd.arg("--version");
    available(cmd, ".ci/run installs it: apt-get install pkg-config")
}

fn cargo() -> Command {
    Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()))
}

/// Runs `cmd`, failing the test with its output if it fails; its standard output.
fn check_run(mut cmd: Command, what: &str) -> String {
    let out = cmd.output().unwrap_or_else(|e| panic!("run {what}: {e}"));
    assert!(
        out.status.success(),
        "{what} failed ({}):\n{}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// `cargo xtask install --prefix <prefix> <extra>`, built and run with this test's profile and
/// target directory.
fn xtask_install(prefix: &Path, extra: &[&str]) -> String {
    let exe = common::cargo_build(&["-p", "xtask"]).join("xtask");
    let mut cmd = Command::new(exe);
    cmd.args(["install", "--prefix"])
        .arg(prefix)
        .args(["--profile", &common::profile_name()])
        .args(extra)
        .env("CARGO_TARGET_DIR", target_dir())
        .current_dir(common::workspace_root());
    check_run(cmd, "cargo xtask install")
}

/// `cargo xtask uninstall --prefix <prefix> <extra>`, as [`xtask_install`] runs install; its
/// status and output.
fn xtask_uninstall(prefix: &Path, extra: &[&str]) -> std::process::Output {
    let exe = common::cargo_build(&["-p", "xtask"]).join("xtask");
    Command::new(exe)
        .args(["uninstall", "--prefix"])
        .arg(prefix)
        .args(extra)
        .output()
        .expect("run xtask uninstall")
}

/// Every path under `dir`, relative to it, sorted; directories end in `/`.
fn tree(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut dirs = vec![dir.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            let rel = path.strip_prefix(dir).unwrap().display().to_string();
            if std::fs::symlink_metadata(&path).unwrap().is_dir() {
                out.push(format!("{rel}/"));
                dirs.push(path);
            } else {
                out.push(rel);
            }
        }
    }
    out.sort();
    out
}

/// `cargo xtask uninstall` removes every file and link of the install in `prefix` and leaves its
/// directories; a dry run before it removes nothing, a second run says nothing is installed.
fn check_uninstall(prefix: &Path) {
    let before = tree(prefix);
    let dry = xtask_uninstall(prefix, &["--dry-run"]);
    assert!(dry.status.success(), "{dry:?}");
    assert_eq!(tree(prefix), before, "a dry run removed something");
    let out = xtask_uninstall(prefix, &[]);
    let log = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{out:?}");
    assert_eq!(
        tree(prefix),
        ["include/", "lib/", "lib/pkgconfig/"],
        "{log}"
    );
    let removed = log.lines().filter(|l| l.starts_with("removed ")).count();
    let files = before.iter().filter(|p| !p.ends_with('/')).count();
    assert_eq!(removed, files, "{log}");
    let again = xtask_uninstall(prefix, &[]);
    assert!(!again.status.success());
    assert!(
        String::from_utf8_lossy(&again.stderr).contains("no vlib is installed under"),
        "{again:?}"
    );
}

/// The documented cargo-c commands (docs/install.md) with `--prefix <prefix> <extra>`: `cargo
/// cinstall`, then `strip --strip-debug` on the archive, which cargo-c installs as built.
fn cargo_c_install(prefix: &Path, extra: &[&str]) {
    let profile = common::profile_name();
    let mut cmd = cargo();
    cmd.args(["cinstall", "--package", "vlib-capi", "--profile", &profile])
        .args(["--libdir", "lib", "--config"])
        .arg(format!("profile.{profile}.strip=true"))
        .arg("--prefix")
        .arg(prefix)
        .args(extra)
        .arg("--target-dir")
        .arg(target_dir())
        .current_dir(common::workspace_root());
    check_run(cmd, "cargo cinstall");
    let mut strip = Command::new("strip");
    strip.arg("--strip-debug").arg(prefix.join("lib/libvlib.a"));
    check_run(strip, "strip --strip-debug libvlib.a");
}

fn target_dir() -> PathBuf {
    common::profile_dir()
        .parent()
        .expect("target directory")
        .to_path_buf()
}

/// The sections `strip` removes that an ELF file, or any member of an archive, still has:
/// `.symtab` and the `.debug*` ones (from `readelf -S -W`).
fn unstripped(file: &Path) -> BTreeSet<String> {
    common::binutils("readelf", &["-S", "-W"], file)
        .lines()
        .filter_map(|line| {
            let rest = line.trim_start().strip_prefix('[')?;
            let rest = rest.split_once(']')?.1;
            rest.split_whitespace().next().map(str::to_string)
        })
        .filter(|name| name == ".symtab" || name.starts_with(".debug"))
        .collect()
}

/// The `Libs.private` line of a pkg-config file, as a list of flags.
fn libs_private(pc: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(pc).unwrap_or_else(|e| panic!("{}: {e}", pc.display()));
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix("Libs.private:"))
        .unwrap_or_else(|| panic!("{} has no Libs.private:\n{text}", pc.display()));
    line.split_whitespace().map(str::to_string).collect()
}

/// What rustc reports for a static library that holds nothing but the standard library: the
/// floor of any Rust archive's system libraries.
fn std_native_static_libs() -> Vec<String> {
    let dir = TempDir::new("probe");
    let src = dir.path().join("probe.rs");
    std::fs::write(&src, "").unwrap();
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let out = Command::new(rustc)
        .args(["--crate-type", "staticlib", "--crate-name", "probe"])
        .args(["--print", "native-static-libs", "--out-dir"])
        .arg(dir.path())
        .arg(&src)
        .output()
        .expect("run rustc");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "rustc: {stderr}");
    let line = stderr
        .lines()
        .find_map(|l| l.split_once("native-static-libs:").map(|(_, libs)| libs))
        .unwrap_or_else(|| panic!("rustc printed no native-static-libs:\n{stderr}"));
    line.split_whitespace().map(str::to_string).collect()
}

/// Checks a prefix's files; `shared`/`archive`: which libraries it should hold.
fn check_prefix(prefix: &Path, shared: bool, archive: bool) {
    let lib = prefix.join("lib");
    let sos: Vec<String> = std::fs::read_dir(&lib)
        .unwrap_or_else(|e| panic!("{}: {e}", lib.display()))
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("libvlib.so"))
        .collect();
    if shared {
        let full = lib.join(FULL);
        assert!(
            std::fs::symlink_metadata(&full).is_ok_and(|m| m.is_file()),
            "{} is not a file",
            full.display()
        );
        for link in [SONAME, "libvlib.so"] {
            assert_eq!(
                std::fs::read_link(lib.join(link)).ok().as_deref(),
                Some(Path::new(FULL)),
                "{link} is not a link to {FULL}"
            );
        }
        assert_eq!(sos.len(), 3, "{sos:?}");
        assert_eq!(common::soname(&full).as_deref(), Some(SONAME), "readelf -d");
        let exports = common::exports(&full);
        let foreign: Vec<&String> = exports
            .iter()
            .filter(|n| !common::is_vlib_name(n))
            .collect();
        assert!(foreign.is_empty(), "exported beyond vl*/VL*: {foreign:?}");
        for name in commands::COMMANDS.iter().chain(&commands::EXTENSIONS) {
            assert!(exports.iter().any(|e| e == name), "{name} is not exported");
        }
        // Stripped: no symbol table beyond the dynamic one, no debugging information.
        let kept = unstripped(&full);
        assert!(kept.is_empty(), "{FULL} keeps {kept:?}");
    } else {
        assert!(sos.is_empty(), "a static-only prefix holds {sos:?}");
    }
    let a = lib.join("libvlib.a");
    assert_eq!(a.is_file(), archive, "{}", a.display());
    if archive {
        let kept: Vec<String> = unstripped(&a)
            .into_iter()
            .filter(|n| n != ".symtab")
            .collect();
        assert!(kept.is_empty(), "libvlib.a keeps {kept:?}");
        // The archive's symbol table is intact: the commands are defined.
        let symbols = common::binutils("nm", &["--defined-only"], &a);
        assert!(symbols.contains(" T vlInit\n"), "nm libvlib.a lacks vlInit");
    }
    for header in ["vlib.h", "vlaux.h"] {
        let installed = prefix.join("include").join(header);
        let ours = common::workspace_root().join("include").join(header);
        assert_eq!(
            std::fs::read(&installed).unwrap_or_else(|e| panic!("{}: {e}", installed.display())),
            std::fs::read(&ours).unwrap(),
            "{header}"
        );
    }
    // Libs.private comes from rustc: it holds at least what the standard library needs.
    let private = libs_private(&lib.join("pkgconfig/vlib.pc"));
    for flag in std_native_static_libs() {
        assert!(
            private.contains(&flag),
            "Libs.private {private:?} lacks {flag}"
        );
    }
}

/// `pkg-config <args> vlib` with the prefix's pkgconfig directory first in the search path.
fn pkg_config(prefix: &Path, args: &[&str]) -> Vec<String> {
    let mut cmd = Command::new("pkg-config");
    cmd.args(args)
        .arg("vlib")
        .env("PKG_CONFIG_PATH", prefix.join("lib/pkgconfig"));
    check_run(cmd, "pkg-config")
        .split_whitespace()
        .map(str::to_string)
        .collect()
}

/// Builds `examples/c/figure2.c` with `cc -std=gnu89 figure2.c <flags>` (flags from pkg-config),
/// runs it (with `LD_LIBRARY_PATH`, if given, and no other) in a fresh directory and returns the
/// image it wrote, `stone.ppm`, with the libraries the program needs.
fn figure2_with(flags: &[String], ld_library_path: Option<&Path>) -> (Vec<u8>, Vec<String>) {
    let bin = TempDir::new("installed-bin");
    let exe = bin.path().join("figure2");
    let mut cc = Command::new("cc");
    cc.args(["-std=gnu89", "examples/c/figure2.c"])
        .args(flags)
        .arg("-o")
        .arg(&exe)
        .current_dir(common::workspace_root());
    check_run(cc, "cc figure2.c $(pkg-config ...)");
    let cwd = TempDir::new("installed-run");
    let mut run = Command::new(&exe);
    run.current_dir(cwd.path()).env_remove("LD_LIBRARY_PATH");
    if let Some(dir) = ld_library_path {
        run.env("LD_LIBRARY_PATH", dir);
    }
    let stdout = check_run(run, "figure2");
    // Figure 2 as printed asks for output 2 of a one-output table (line 20): one VL_BADINDEX.
    assert!(
        stdout.starts_with("vlError: 12 (index out of range)") && stdout.lines().count() == 1,
        "{stdout}"
    );
    let image = cwd.path().join("stone.ppm");
    let ppm = common::Ppm::read(&image);
    assert_eq!((ppm.width, ppm.height), (100, 100));
    (std::fs::read(&image).unwrap(), common::needed(&exe))
}

/// The image figure2 writes when built in the build tree as the gallery builds it.
fn figure2_in_the_build_tree() -> Vec<u8> {
    let bin = TempDir::new("tree-bin");
    let exe = common::compile_c("examples/c/figure2.c", bin.path(), &[]);
    let cwd = TempDir::new("tree-run");
    common::run(&exe, cwd.path(), &[]);
    std::fs::read(cwd.path().join("stone.ppm")).expect("figure2 wrote stone.ppm")
}

/// Builds figure2 against a full prefix, linked to the shared library and (naming the archive,
/// as docs/install.md shows) statically, and against a static-only prefix with `--static`;
/// checks what each executable needs, and that all three draw the build tree's image.
fn figure2_shared_and_static(full: &Path, archive_only: &Path) {
    let (shared_image, needs) = figure2_with(
        &pkg_config(full, &["--cflags", "--libs"]),
        Some(&full.join("lib")),
    );
    assert!(needs.iter().any(|n| n == SONAME), "linked to {needs:?}");
    let reference = figure2_in_the_build_tree();
    assert!(
        shared_image == reference,
        "the shared build drew another image"
    );

    let named: Vec<String> = pkg_config(full, &["--cflags", "--libs", "--static"])
        .into_iter()
        .map(|f| {
            if f == "-lvlib" {
                "-l:libvlib.a".into()
            } else {
                f
            }
        })
        .collect();
    let static_only = pkg_config(archive_only, &["--cflags", "--libs", "--static"]);
    for flags in [named, static_only] {
        let (image, needs) = figure2_with(&flags, None);
        assert!(
            !needs.iter().any(|n| n.starts_with("libvlib")),
            "{flags:?} linked to {needs:?}"
        );
        assert!(image == reference, "{flags:?} drew another image");
    }
}

/// What pkg-config says of the prefix's `vlib.pc`: the version, the header directory, and the
/// link line (the archive alone: `Libs` itself carries the system libraries).
fn check_pkg_config(prefix: &Path, archive_only: bool) {
    assert_eq!(
        pkg_config(prefix, &["--modversion"]),
        [env!("CARGO_PKG_VERSION")]
    );
    assert_eq!(
        pkg_config(prefix, &["--cflags"]),
        [format!("-I{}", prefix.join("include").display())]
    );
    let mut libs = vec![
        format!("-L{}", prefix.join("lib").display()),
        "-lvlib".to_string(),
    ];
    if archive_only {
        libs.extend(libs_private(&prefix.join("lib/pkgconfig/vlib.pc")));
    }
    assert_eq!(pkg_config(prefix, &["--libs"]), libs);
}

#[test]
fn xtask_install_gives_a_prefix_c_programs_build_against() {
    let dir = TempDir::new("xtask-install");
    let (full, archive_only) = (dir.path().join("full"), dir.path().join("static"));
    let log = xtask_install(&full, &[]);
    // It says what it installed: five files and two links.
    let lib = full.join("lib");
    for line in [
        format!("installed {}", lib.join(FULL).display()),
        format!("installed {} -> {FULL}", lib.join(SONAME).display()),
        format!("installed {} -> {FULL}", lib.join("libvlib.so").display()),
        format!("installed {}", lib.join("libvlib.a").display()),
        format!("installed {}", full.join("include/vlib.h").display()),
        format!("installed {}", full.join("include/vlaux.h").display()),
        format!("installed {}", lib.join("pkgconfig/vlib.pc").display()),
    ] {
        assert!(log.lines().any(|l| l == line), "{line:?} not in:\n{log}");
    }
    xtask_install(&archive_only, &["--library-type", "staticlib"]);
    check_prefix(&full, true, true);
    check_prefix(&archive_only, false, true);

    // README's static link line names the libraries rustc reports here.
    let readme = std::fs::read_to_string(common::workspace_root().join("README.md")).unwrap();
    let line = readme
        .lines()
        .find(|l| l.starts_with("cc prog.c -Iinclude target/release/libvlib.a"))
        .expect("README's static link line");
    let readme_libs: Vec<&str> = line
        .split('#')
        .next()
        .unwrap()
        .split_whitespace()
        .filter(|w| w.starts_with("-l"))
        .collect();
    assert_eq!(
        readme_libs,
        libs_private(&full.join("lib/pkgconfig/vlib.pc")),
        "README's static line against vlib.pc's Libs.private"
    );

    if pkg_config_available() {
        check_pkg_config(&full, false);
        check_pkg_config(&archive_only, true);
        figure2_shared_and_static(&full, &archive_only);
    }
    check_uninstall(&full);
    check_uninstall(&archive_only);
}

#[test]
fn xtask_install_stages_under_destdir() {
    let dir = TempDir::new("xtask-destdir");
    let stage = dir.path().join("stage");
    xtask_install(
        Path::new("/opt/vlib"),
        &[
            "--destdir",
            stage.to_str().unwrap(),
            "--library-type",
            "staticlib",
        ],
    );
    let pc = std::fs::read_to_string(stage.join("opt/vlib/lib/pkgconfig/vlib.pc")).unwrap();
    assert!(pc.starts_with("prefix=/opt/vlib\n"), "{pc}");
    // Everything went under the staging directory, and only the archive of the two libraries.
    let mut files = Vec::new();
    let mut dirs = vec![stage.clone()];
    while let Some(d) = dirs.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else {
                files.push(path.strip_prefix(&stage).unwrap().display().to_string());
            }
        }
    }
    files.sort();
    assert_eq!(
        files,
        [
            "opt/vlib/include/vlaux.h",
            "opt/vlib/include/vlib.h",
            "opt/vlib/lib/libvlib.a",
            "opt/vlib/lib/pkgconfig/vlib.pc"
        ]
    );
}

#[test]
fn cargo_c_installs_the_same_prefix() {
    let mut cinstall = cargo();
    cinstall.args(["cinstall", "--version"]);
    let hint = ".ci/run installs it: cargo install cargo-c --locked --version 0.10.24";
    if !available(cinstall, hint) {
        return;
    }
    let dir = TempDir::new("cargo-c");
    let (full, archive_only) = (dir.path().join("full"), dir.path().join("static"));
    cargo_c_install(&full, &[]);
    cargo_c_install(&archive_only, &["--library-type", "staticlib"]);
    check_prefix(&full, true, true);
    check_prefix(&archive_only, false, true);
    if pkg_config_available() {
        check_pkg_config(&full, false);
        check_pkg_config(&archive_only, true);
        figure2_shared_and_static(&full, &archive_only);
    }
    // What cargo-c installs, cargo xtask uninstall removes.
    check_uninstall(&full);
    check_uninstall(&archive_only);
}
