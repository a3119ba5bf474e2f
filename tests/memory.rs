//! Peak memory of an image render: within 2× the output's own bytes. Each case runs in a child
//! process (this test binary run again with `VLIB_MEMORY_CHILD` set), which renders a small
//! image first (so the thread pool and the code are in memory), reads its peak resident size
//! (`VmHWM` in `/proc/self/status`), renders the large image to a file, and reads it again; the
//! parent asserts the growth. An 8192 × 8192 image is 192 MiB of 8-bit pixels: the render may
//! grow the peak by at most twice that (the output held whole for the encoder, a strip of
//! about 2²⁰ pixels at 32 bytes each, and for PNG the compressed stream, small here).

#[path = "common/status.rs"]
mod status;

use std::process::Command;
use vlib::{Camera, Fields, Library};

/// The peak resident size of this process, in bytes.
fn peak() -> u64 {
    status::status_bytes("VmHWM")
}

/// Renders a sphere of radius a quarter of the view to `path` at `side × side`.
fn render(path: &std::path::Path, side: u32) {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.image(path, 1.0, side as i32, side as i32).unwrap();
    vl.camera(&Camera {
        eye: [0.0, 0.0, -4.0],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov: 40.0,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.step_size(0.1, 1.0).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.function(Fields::O, |s| {
        let v = vlib::vlaux::sphere(s.position());
        let _ = s.set(Fields::O, if v > 0.5 { 0.5 } else { 0.0 });
    })
    .unwrap();
    vl.set(Fields::COLORS | Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    vl.end().unwrap();
}

/// In the child: warm up, render `side²` to a file named `name`, print the peak's growth.
fn measure(name: &str, side: u32) {
    let dir = std::env::temp_dir().join(format!("vlib-memory-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    render(&dir.join("warm.ppm"), 64);
    let before = peak();
    let out = dir.join(name);
    render(&out, side);
    let after = peak();
    let size = std::fs::metadata(&out).unwrap().len();
    std::fs::remove_dir_all(&dir).unwrap();
    println!("growth {} file {size}", after - before);
}

/// Runs the case `name` at `side` in a child; returns the peak's growth in bytes.
fn growth(name: &str, side: u32) -> u64 {
    let exe = std::env::current_exe().unwrap();
    let out = Command::new(exe)
        .args(["--exact", "child", "--nocapture", "--test-threads=1"])
        .env("VLIB_MEMORY_CHILD", format!("{name} {side}"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // (The test harness prints `test child ... ` before it on the same line.)
    let mut words = stdout.split_whitespace().skip_while(|w| *w != "growth");
    words
        .nth(1)
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no measurement: {stdout}"))
}

/// What the child runs (nothing when run as a test).
#[test]
fn child() {
    if let Ok(case) = std::env::var("VLIB_MEMORY_CHILD") {
        let (name, side) = case.split_once(' ').unwrap();
        measure(name, side.parse().unwrap());
    }
}

#[test]
fn an_image_render_peaks_within_twice_its_pixels() {
    let side = 8192u32;
    let output = side as u64 * side as u64 * 3;
    for name in ["big.ppm", "big.png"] {
        let g = growth(name, side);
        assert!(
            g <= 2 * output,
            "{name}: the peak grew by {} MiB, the output is {} MiB",
            g >> 20,
            output >> 20
        );
        eprintln!("{name}: {} MiB for {} MiB of pixels", g >> 20, output >> 20);
    }
}
