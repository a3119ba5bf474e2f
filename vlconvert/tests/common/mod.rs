//! What the converter's tests share: running `vlconvert` (with a time limit where an input
//! could make it wait), scratch directories, paths as arguments, a dataset's nodes normalised by
//! its a … b, and the comparison of a conversion with an independent writer's values.
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

/// Runs `vlconvert args`, failing the test if it has not ended within 20 seconds (it is then
/// killed): for inputs that could make a reader wait (a FIFO, a device).
pub fn run_within(args: &[&str]) -> Output {
    use std::process::Stdio;
    let mut child = Command::new(BIN)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > std::time::Duration::from_secs(20) {
            child.kill().unwrap();
            let _ = child.wait();
            panic!("vlconvert {args:?} still running after 20 s: killed");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// Runs `vlconvert args… input input.vlb` with its address space limited to `kib` KiB (far
/// less than what a hostile header declares) and asserts that it is refused: exit 1, a
/// message with each of `says` and the input's name, no panic, no output file.
pub fn refused_within(kib: u64, args: &[&str], input: &Path, says: &[&str]) {
    let out = input.with_extension("vlb");
    let o = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {kib} && exec \"$0\" \"$@\""))
        .arg(BIN)
        .args(args)
        .arg(input)
        .arg(&out)
        .output()
        .unwrap();
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{}: {err}", input.display());
    for say in says.iter().chain(&[s(input)]) {
        assert!(err.contains(say), "{say:?} not in {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out.exists());
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

/// The values an independent writer put in a fixture, from `NAME.txt` beside it: one a line,
/// in file order (x fastest).
pub fn writers_values(txt: &Path) -> Vec<f64> {
    std::fs::read_to_string(txt)
        .unwrap()
        .lines()
        .map(|l| l.parse().unwrap())
        .collect()
}

/// Converts fixture `tests/fixtures/<file>` with `vlconvert <sub>` and checks the dataset:
/// `dims` nodes of `width` bytes whose normalised values are the writer's
/// ([`assert_writers_values`]).
pub fn converts_like_the_writer(sub: &str, file: &str, dims: [usize; 3], width: u32, exact: bool) {
    let input = fixture(file);
    let want = writers_values(&fixture(&format!(
        "{}.txt",
        file.rsplit_once('.').unwrap().0
    )));
    let d = tmp(&file.replace(['/', '.'], "-"));
    let out = d.join("out.vlb");
    let o = run(&[sub, s(&input), s(&out)]);
    assert!(
        o.status.success(),
        "{file}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let v = Dataset::load(&out).unwrap();
    assert_eq!(v.dims(), dims, "{file}");
    assert_eq!(v.raw().width(), width, "{file}");
    assert_writers_values(file, &v, &want, exact);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Each node's normalised value in `v` is the writer's value placed in the data's range,
/// (w − min)/(max − min): within 10⁻⁶ where the type is kept `exact`ly (the slack is f32's in
/// a and b), within half a quantum of 16 bits (plus that) where it is quantised.
pub fn assert_writers_values(name: &str, v: &Dataset, want: &[f64], exact: bool) {
    let (lo, hi) = want
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let got = normalised(v);
    assert_eq!(got.len(), want.len(), "{name}: nodes");
    let tol = if exact { 1e-6 } else { 0.5 / 65535.0 + 1e-6 };
    for (n, (got, w)) in got.iter().zip(want).enumerate() {
        let expect = (w - lo) / (hi - lo);
        assert!(
            (got - expect).abs() <= tol,
            "{name} node {n}: {got} vs ({w} − {lo})/({hi} − {lo}) = {expect}"
        );
    }
}
