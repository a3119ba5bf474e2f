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
