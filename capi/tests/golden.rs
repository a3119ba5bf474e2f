//! Every gallery image, byte for byte: each `examples/c/*.c` program (at the sizes the other
//! tests use), the Rust `figure2` example, and, when `../shared/data` holds the MNI template,
//! the MNI frame (256², the benchmark scene), the twisted brain and the MIP brain (128²). Each
//! image file's FNV-1a 64-bit hash is compared with `capi/tests/golden/hashes.txt`.
//!
//! The hashes guard work that must not change an image (refactoring, speed-ups). A change that
//! is meant to change images re-records them with `VLIB_BLESS=1 cargo test --release -p
//! vlib-capi --test golden`, and says why in its commit.

mod common;

use common::TempDir;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// FNV-1a, 64 bits: enough to tell two images apart, no dependency.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The image files (`.ppm`, `.png`) directly in `dir`.
fn images(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("read {}: {e}", dir.display()))
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".ppm") || n.ends_with(".png"))
        .collect()
}

/// Hashes the images in `dir` that are not in `before`, as `tag/name`.
fn record(hashes: &mut BTreeMap<String, u64>, tag: &str, dir: &Path, before: &BTreeSet<String>) {
    let made: Vec<String> = images(dir).difference(before).cloned().collect();
    assert!(!made.is_empty(), "{tag} wrote no image");
    for name in made {
        let bytes = std::fs::read(dir.join(&name)).expect("read image");
        hashes.insert(format!("{tag}/{name}"), fnv1a(&bytes));
    }
}

/// The MNI template, when `../shared/data` holds it.
fn mni_source() -> Option<PathBuf> {
    let p = common::workspace_root()
        .join("../shared/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz");
    p.is_file().then_some(p)
}

/// Renders every gallery scene; returns the hash of each image file.
fn render_gallery() -> BTreeMap<String, u64> {
    let mut hashes = BTreeMap::new();
    for source in common::c_files("examples/c") {
        let bin = TempDir::new("golden-bin");
        let exe = common::compile_c(&source, bin.path(), &[]);
        let cwd = TempDir::new("golden-run");
        let args = common::prepare(&source, cwd.path());
        let before = images(cwd.path());
        common::run(&exe, cwd.path(), &args);
        let tag = Path::new(&source).file_stem().unwrap().to_string_lossy();
        record(&mut hashes, &tag, cwd.path(), &before);
    }
    let rust = ["figure2", "mni", "twisted_brain", "mip_brain"];
    let examples = common::ensure_examples(&rust).join("examples");
    let cwd = TempDir::new("golden-rust");
    let dir = cwd.path();
    let before = images(dir);
    common::run(&examples.join("figure2"), dir, &["figure2.png".into()]);
    record(&mut hashes, "figure2-rust", dir, &before);
    match mni_source() {
        Some(nii) => {
            let nii = nii.to_string_lossy().into_owned();
            common::tool("vlconvert", &["nifti", &nii, "mni.vlb"], dir);
            let brain = |name: &str, size: &str| -> Vec<String> {
                vec![
                    "mni.vlb".into(),
                    format!("{name}.png"),
                    format!("--size={size}"),
                ]
            };
            for (name, size) in [
                ("mni", "256"),
                ("twisted_brain", "128"),
                ("mip_brain", "128"),
            ] {
                let before = images(dir);
                common::run(&examples.join(name), dir, &brain(name, size));
                record(&mut hashes, name, dir, &before);
            }
        }
        None => println!("(no MNI template in ../shared/data: the brain images are not checked)"),
    }
    hashes
}

fn parse(text: &str) -> BTreeMap<String, u64> {
    text.lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| {
            let (name, hash) = l.split_once(' ').expect("`name hash` lines");
            let hash = u64::from_str_radix(hash.trim(), 16).expect("a hexadecimal hash");
            (name.to_string(), hash)
        })
        .collect()
}

/// Every gallery image has the bytes recorded in `capi/tests/golden/hashes.txt`.
#[test]
fn gallery_images_are_byte_identical() {
    let file = common::workspace_root().join("capi/tests/golden/hashes.txt");
    let got = render_gallery();
    if std::env::var_os("VLIB_BLESS").is_some() {
        let mut text =
            String::from("# capi/tests/golden.rs: image file -> FNV-1a 64 of its bytes\n");
        for (name, hash) in &got {
            text.push_str(&format!("{name} {hash:016x}\n"));
        }
        std::fs::write(&file, text).expect("write hashes");
        return;
    }
    let want = parse(&std::fs::read_to_string(&file).expect("read the recorded hashes"));
    let mut wrong = Vec::new();
    for (name, hash) in &want {
        match got.get(name) {
            Some(h) if h == hash => {}
            Some(h) => wrong.push(format!("{name}: {h:016x}, recorded {hash:016x}")),
            None if name.contains('/') && mni_source().is_none() && is_brain(name) => {}
            None => wrong.push(format!("{name}: not rendered")),
        }
    }
    for name in got.keys().filter(|n| !want.contains_key(*n)) {
        wrong.push(format!("{name}: rendered but not recorded"));
    }
    assert!(wrong.is_empty(), "images changed:\n{}", wrong.join("\n"));
}

/// The Rust `figure2` example and the paper's C Figure 2 are one scene: the same bytes.
#[test]
fn figure2_in_rust_and_in_c_write_the_same_image() {
    let got = render_gallery_figure2();
    assert_eq!(got.0, got.1, "Rust's stone.ppm differs from C's");
}

/// Renders Figure 2 in C and in Rust; returns both `stone.ppm` files' bytes.
fn render_gallery_figure2() -> (Vec<u8>, Vec<u8>) {
    let bin = TempDir::new("figure2-bin");
    let exe = common::compile_c("examples/c/figure2.c", bin.path(), &[]);
    let c = TempDir::new("figure2-c");
    common::run(&exe, c.path(), &[]);
    let rust = TempDir::new("figure2-rust");
    let examples = common::ensure_examples(&["figure2"]).join("examples");
    common::run(
        &examples.join("figure2"),
        rust.path(),
        &["stone.ppm".into()],
    );
    let read = |d: &TempDir| std::fs::read(d.path().join("stone.ppm")).expect("stone.ppm");
    (read(&c), read(&rust))
}

/// Whether `name` is one of the images that need the MNI template.
fn is_brain(name: &str) -> bool {
    ["mni/", "twisted_brain/", "mip_brain/"]
        .iter()
        .any(|p| name.starts_with(p))
}
