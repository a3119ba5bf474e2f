//! The library's pool starts at most four threads a core whatever `RAYON_NUM_THREADS` asks
//! (`src/pool.rs`): with 100 000 asked, a render keeps at most that many threads running
//! (rayon's idle threads spin, so thousands on a few cores made a small frame take minutes),
//! and its image is the one thread's, byte for byte. A test binary of its own: the variable
//! must be set before the process's first render builds the pool.

use vlib::{Fields, Library};

/// The threads of this process now (the entries of `/proc/self/task`).
fn threads_now() -> usize {
    std::fs::read_dir("/proc/self/task").unwrap().count()
}

/// A 32² preview of a lit ball, as its pixels' bytes.
fn ball(vl: &mut Library) -> Vec<u8> {
    vl.scene().unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.object().unwrap();
    vl.function(Fields::O, |s| {
        let v = vlib::vlaux::sphere(s.position());
        let _ = s.set(Fields::O, v);
    })
    .unwrap();
    vl.set(Fields::COLORS | Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    vl.render_preview(32, 32, 1.0).unwrap().to_rgba8()
}

#[test]
fn a_hundred_thousand_threads_asked_for_start_at_most_four_a_core() {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // (The only test of this binary, run before any render: no other thread reads the
    // environment now.)
    std::env::set_var("RAYON_NUM_THREADS", "100000");
    let before = threads_now();
    let mut vl = Library::new();
    let many = ball(&mut vl);
    // The pool's threads stay for later renders.
    let started = threads_now() - before;
    assert!(
        (1..=4 * cores).contains(&started),
        "{started} threads started on {cores} core(s)"
    );
    // The same bytes as one thread gives (rendered inside a pool of one).
    let one_pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let one = one_pool.install(|| ball(&mut Library::new()));
    assert!(many.iter().any(|&b| b != 0), "the ball is seen");
    assert_eq!(many, one);
}
