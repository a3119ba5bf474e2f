//! The same scene rendered by separate processes with `RAYON_NUM_THREADS=1` and `=2` gives
//! identical bytes (the Figure 2 example, built by `cargo test` alongside this test).

use std::process::Command;

mod common;
use common::example;

#[test]
fn figure2_bytes_do_not_depend_on_the_thread_count() {
    let bin = example("figure2");
    assert!(bin.exists(), "{} not built", bin.display());
    let dir = std::env::temp_dir().join(format!("vlib-threads-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut outputs = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.join(format!("stone-{threads}.ppm"));
        let status = Command::new(&bin)
            .arg(&out)
            .env("RAYON_NUM_THREADS", threads)
            .status()
            .unwrap();
        assert!(status.success());
        outputs.push(std::fs::read(&out).unwrap());
    }
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(outputs[0].starts_with(b"P6\n100 100\n255\n"));
    assert_eq!(outputs[0].len(), 15 + 100 * 100 * 3);
    assert!(
        outputs[0] == outputs[1],
        "RAYON_NUM_THREADS=1 and =2 differ"
    );
}

/// The library's rendering threads have the stack a C program's main thread usually has
/// (8 MiB): a field function that keeps 4 MiB on its stack runs there as it would on the main
/// thread (a thread Rust starts has 2 MiB, where it overflowed and aborted the process).
#[test]
fn a_field_function_may_use_megabytes_of_stack() {
    use vlib::{Fields, Library};
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.step_size(0.25, 1.0).unwrap();
    vl.object().unwrap();
    vl.function(Fields::O, |s| {
        let big = [1u8; 4 << 20];
        let big = std::hint::black_box(&big);
        let v = vlib::vlaux::sphere(s.position()) * big[big.len() / 2] as f32;
        let _ = s.set(Fields::O, v * 0.1);
    })
    .unwrap();
    vl.set(Fields::COLORS | Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    let image = vl.render_preview(8, 8, 1.0).unwrap();
    assert!(
        image.transmittance.iter().any(|&t| t < 0.99),
        "the ball is seen"
    );
}
