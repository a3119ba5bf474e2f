//! The library as a dependency: a new Rust project that depends on `vlib-volume` (imported as
//! `vlib`) gets no command-line dependencies (clap, nifti: they belong to the `vlconvert`
//! package), and the published package holds the library's sources and docs, not the tests,
//! fixtures, examples or benchmarks; the C library and the converter name its version.

use std::path::{Path, PathBuf};
use std::process::Command;

fn cargo() -> Command {
    Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()))
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A new binary project in a scratch directory that depends on this package by path.
fn new_project(dir: &Path) {
    std::fs::create_dir_all(dir.join("src")).unwrap();
    std::fs::write(
        dir.join("Cargo.toml"),
        format!(
            "[package]\nname = \"newproj\"\nversion = \"0.1.0\"\nedition = \"2021\"\n\n\
             [dependencies]\nvlib = {{ package = \"vlib-volume\", path = {:?} }}\n\n[workspace]\n",
            root().display().to_string()
        ),
    )
    .unwrap();
    std::fs::write(
        dir.join("src/main.rs"),
        "fn main() { let _ = vlib::Library::new(); }\n",
    )
    .unwrap();
}

#[test]
fn a_project_that_depends_on_the_library_gets_no_cli_dependencies() {
    let dir = std::env::temp_dir().join(format!("vlib-newproj-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    new_project(&dir);
    // Offline: the workspace's own build has fetched every crate the library needs.
    let out = cargo()
        .args(["tree", "--offline", "-e", "normal", "--prefix", "none"])
        .current_dir(&dir)
        .output()
        .unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(
        out.status.success(),
        "cargo tree: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let tree = String::from_utf8_lossy(&out.stdout);
    let names: Vec<&str> = tree.lines().filter_map(|l| l.split(' ').next()).collect();
    assert!(names.contains(&"vlib-volume"), "{tree}");
    assert!(
        names.contains(&"rayon"),
        "the tree is the library's: {tree}"
    );
    for cli in ["clap", "clap_builder", "nifti", "vlconvert"] {
        assert!(
            !names.contains(&cli),
            "{cli} in a library user's tree:\n{tree}"
        );
    }
}

#[test]
fn the_package_holds_the_sources_and_docs_only() {
    let out = cargo()
        .args(["package", "--list", "--allow-dirty", "-p", "vlib-volume"])
        .current_dir(root())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "cargo package --list: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let list = String::from_utf8_lossy(&out.stdout);
    let files: Vec<&str> = list.lines().collect();
    for needed in [
        "Cargo.toml",
        "README.md",
        "LICENSE",
        "src/lib.rs",
        "docs/commands.md",
    ] {
        assert!(files.contains(&needed), "{needed} missing from:\n{list}");
    }
    for f in &files {
        let allowed = f.starts_with("src/")
            || f.starts_with("docs/")
            || [
                "Cargo.toml",
                "Cargo.toml.orig",
                "Cargo.lock",
                "README.md",
                "LICENSE",
                ".cargo_vcs_info.json",
            ]
            .contains(f);
        assert!(allowed, "{f} should not be published");
    }
}

/// The C library and the converter depend on this package by path and by version (which
/// `cargo package` needs), and the version they name is this package's: a new version of the
/// workspace that left them at the old one would not package.
#[test]
fn the_packages_that_use_the_library_name_its_version() {
    let want = format!("version = \"{}\"", env!("CARGO_PKG_VERSION"));
    for manifest in ["capi/Cargo.toml", "vlconvert/Cargo.toml"] {
        let text = std::fs::read_to_string(root().join(manifest)).unwrap();
        let line = text
            .lines()
            .find(|l| l.contains("package = \"vlib-volume\""))
            .unwrap_or_else(|| panic!("{manifest} does not depend on vlib-volume"));
        assert!(line.contains(&want), "{manifest}: {line} (want {want})");
        assert!(line.contains("path = \"..\""), "{manifest}: {line}");
    }
}
