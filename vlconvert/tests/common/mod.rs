//! What the converter's tests share: running `vlconvert`, scratch directories, paths as
//! arguments, and a dataset's nodes normalised by its a … b.
//!
//! A directory module, so that cargo does not take it for a test target of its own.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use vlib::Dataset;

/// The converter built for these tests.
pub const BIN: &str = env!("CARGO_BIN_EXE_vlconvert");

/// Runs `vlconvert args`; its exit status and both outputs.
pub fn run(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().unwrap()
}

/// Bytes a program wrote, as text.
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A fresh scratch directory of its own for each call (the tests of a binary run at once).
pub fn tmp(tag: &str) -> PathBuf {
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let d = std::env::temp_dir().join(format!("vlconvert-{tag}-{}-{call}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A path as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Fixture `name` (`nifti/…`, `dicom/…`, …) under `tests/fixtures`.
pub fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// Each node's normalised value, clamp((voxel − a)/(b − a), 0, 1), x fastest.
pub fn normalised(v: &Dataset) -> Vec<f64> {
    let [nx, ny, nz] = v.dims();
    let (a, b) = v.range();
    let (a, b) = (a as f64, b as f64);
    let mut out = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                out.push(((v.raw_node(i, j, k) - a) / (b - a)).clamp(0.0, 1.0));
            }
        }
    }
    out
}
