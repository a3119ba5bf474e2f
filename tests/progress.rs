//! Progress and cancellation through the Rust API (`Library::set_render_control`,
//! `docs/extensions.md`): the progress function hears every image's pixels and every
//! voxelization's nodes, never decreasing, and 1 at the end, also where an output failed, and
//! hears the tiles of a strip as they end (a 0 answer stops the strip); a
//! panicking progress function is an error, not a panic out of `end`; a cancel flag set from
//! another thread stops a render that would otherwise take minutes, and its error counts the
//! outputs that failed before it; the flag stops a single pixel's work within its rays; a
//! preview wider than the largest image side is refused.

use std::sync::{Arc, Mutex};
use vlib::{CancelFlag, ErrorCode, Fields, Library, RenderControl};

/// A scratch directory, removed when dropped.
struct Dir(std::path::PathBuf);

impl Dir {
    fn new(tag: &str) -> Dir {
        let p = std::env::temp_dir().join(format!("vlib-progress-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Dir(p)
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A library whose progress function records what it hears (and answers `go_on`).
fn recording(go_on: fn(f32) -> bool) -> (Library, Arc<Mutex<Vec<f32>>>) {
    let heard = Arc::new(Mutex::new(Vec::new()));
    let log = heard.clone();
    let mut vl = Library::new();
    vl.set_render_control(RenderControl {
        cancel: None,
        progress: Some(Arc::new(move |f| {
            log.lock().unwrap().push(f);
            go_on(f)
        })),
    });
    (vl, heard)
}

/// Opens a scene of one ball with `step`.
fn ball(vl: &mut Library, step: f32) {
    vl.scene().unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.step_size(step, 1.0).unwrap();
    vl.object().unwrap();
    vl.function(Fields::O, |s| {
        let v = vlib::vlaux::sphere(s.position());
        let _ = s.set(Fields::O, v * 0.1);
    })
    .unwrap();
    vl.set(Fields::COLORS | Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
}

/// Two images of 3 000 and 1 000 pixels and a voxelization of 2 000 nodes: the fractions
/// rise, are the pixels and nodes done over 6 000 after each output, and end at exactly 1.
#[test]
fn progress_counts_pixels_and_nodes_and_ends_at_one() {
    let dir = Dir::new("counts");
    let (mut vl, heard) = recording(|_| true);
    ball(&mut vl, 0.05);
    vl.image(dir.0.join("a.ppm"), 1.0, 60, 50).unwrap();
    vl.image(dir.0.join("b.png"), 1.0, 40, 25).unwrap();
    vl.volume(
        dir.0.join("v"),
        Fields::O,
        [0.0; 3],
        [1.0; 3],
        [20, 10, 10],
        1,
    )
    .unwrap();
    vl.end().unwrap();
    let heard = heard.lock().unwrap().clone();
    assert!(heard.windows(2).all(|w| w[0] <= w[1]), "{heard:?}");
    for after in [3000.0 / 6000.0, 4000.0 / 6000.0] {
        assert!(heard.contains(&(after as f32)), "{after} in {heard:?}");
    }
    assert_eq!(heard.last(), Some(&1.0));
    assert!(dir.0.join("a.ppm").is_file() && dir.0.join("v_o.vlb").is_file());
}

/// The answer to the final 1 is not asked for: every output is done, and a 0 then (a cancel
/// button pressed as the render ends) neither discards the last output nor fails the scene.
#[test]
fn a_zero_answer_to_the_final_one_discards_nothing() {
    let dir = Dir::new("final");
    let (mut vl, heard) = recording(|f| f < 1.0);
    ball(&mut vl, 0.05);
    vl.image(dir.0.join("a.ppm"), 1.0, 30, 20).unwrap();
    vl.volume(
        dir.0.join("v"),
        Fields::O,
        [0.0; 3],
        [1.0; 3],
        [10, 10, 10],
        1,
    )
    .unwrap();
    vl.end().unwrap();
    assert_eq!(heard.lock().unwrap().last(), Some(&1.0));
    assert!(dir.0.join("a.ppm").is_file() && dir.0.join("v_o.vlb").is_file());
}

/// An image that cannot be written (its path is a directory) fails the scene with
/// `VL_IOERROR`; the others are written, and the progress function still hears 1.
#[test]
fn progress_ends_at_one_when_an_output_fails() {
    let dir = Dir::new("fails");
    std::fs::create_dir(dir.0.join("taken.ppm")).unwrap();
    let (mut vl, heard) = recording(|_| true);
    ball(&mut vl, 0.05);
    vl.image(dir.0.join("taken.ppm"), 1.0, 20, 20).unwrap();
    vl.image(dir.0.join("fine.ppm"), 1.0, 20, 20).unwrap();
    let e = vl.end().unwrap_err();
    assert_eq!(e.code, ErrorCode::IoError);
    assert!(dir.0.join("fine.ppm").is_file());
    assert_eq!(heard.lock().unwrap().last(), Some(&1.0));
}

/// A progress function that panics (here during a voxelization) makes the scene's `end` fail
/// with `Internal`; nothing unwinds out of it and no file of that output is written.
#[test]
fn a_panicking_progress_function_is_an_error() {
    let dir = Dir::new("panics");
    let (mut vl, _) = recording(|f| {
        assert!(f < 0.5, "a progress function that panics");
        true
    });
    ball(&mut vl, 0.05);
    vl.volume(
        dir.0.join("v"),
        Fields::O,
        [0.0; 3],
        [1.0; 3],
        [300, 300, 2],
        1,
    )
    .unwrap();
    let e = vl.end().unwrap_err();
    assert_eq!(e.code, ErrorCode::Internal, "{}", e.message);
    assert!(!dir.0.join("v_o.vlb").exists());
}

/// A cancel flag set from another thread, once the render has started, stops a render that
/// would take minutes (a million samples a ray at 64²): `Cancelled`, no file of that image,
/// and the image that failed before it counted in the message. The flag stays set: the next
/// render is cancelled before it starts, until the flag is reset.
#[test]
fn a_cancel_flag_stops_a_long_render_from_another_thread() {
    let dir = Dir::new("cancel");
    std::fs::create_dir(dir.0.join("taken.ppm")).unwrap();
    let flag = CancelFlag::new();
    let mut vl = Library::new();
    vl.set_render_control(RenderControl {
        cancel: Some(flag.clone()),
        progress: None,
    });
    let started = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let seen = started.clone();
    vl.scene().unwrap();
    vl.step_size(1e-6, 1.0).unwrap();
    vl.object().unwrap();
    vl.function(Fields::O, move |s| {
        seen.store(true, std::sync::atomic::Ordering::Relaxed);
        let _ = s.set(Fields::O, 1e-7);
    })
    .unwrap();
    vl.end().unwrap();
    vl.image(dir.0.join("taken.ppm"), 1.0, 8, 8).unwrap();
    vl.image(dir.0.join("slow.ppm"), 1.0, 64, 64).unwrap();
    let canceller = {
        let flag = flag.clone();
        std::thread::spawn(move || {
            while !started.load(std::sync::atomic::Ordering::Relaxed) {
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            flag.cancel();
        })
    };
    let e = vl.end().unwrap_err();
    canceller.join().unwrap();
    assert_eq!(e.code, ErrorCode::Cancelled);
    assert!(
        e.message.contains("1 output(s) failed before"),
        "{}",
        e.message
    );
    assert!(!dir.0.join("slow.ppm").exists());
    let names: Vec<_> = std::fs::read_dir(&dir.0).unwrap().collect();
    assert_eq!(names.len(), 1, "only the directory in the way: {names:?}");
    // Still set: the next render does not start.
    ball(&mut vl, 0.05);
    assert_eq!(
        vl.render_preview(8, 8, 1.0).unwrap_err().code,
        ErrorCode::Cancelled
    );
    flag.reset();
    assert!(vl.render_preview(8, 8, 1.0).is_ok());
}

/// Segments a ray takes between two looks at whether its render is to stop (`PROBE_EVERY` of
/// the renderer's cursor).
const PROBE_EVERY: u64 = 4096;

/// Renders 2 × 2 pixels (their corners meet at the object's middle) of a scene that `setup`
/// opens and whose one object's opacity at object
/// point p is `opacity(p)`, from a field function that sets the cancel flag at its `set_at`-th
/// call (so that what is measured does not depend on timing): the render must fail with
/// `Cancelled`, and the number of calls after the flag was set is returned.
fn calls_after_cancel(setup: fn(&mut Library), opacity: fn([f32; 3]) -> f32, set_at: u64) -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    let flag = CancelFlag::new();
    let mut vl = Library::new();
    vl.set_render_control(RenderControl {
        cancel: Some(flag.clone()),
        progress: None,
    });
    let calls = Arc::new(AtomicU64::new(0));
    let counted = calls.clone();
    vl.scene().unwrap();
    setup(&mut vl);
    vl.object().unwrap();
    vl.function(Fields::O, move |s| {
        if counted.fetch_add(1, Relaxed) + 1 == set_at {
            flag.cancel();
        }
        let _ = s.set(Fields::O, opacity(s.position()));
    })
    .unwrap();
    vl.set(Fields::COLORS | Fields::KA | Fields::KD, 1.0)
        .unwrap();
    vl.end().unwrap();
    let e = vl.render_preview(2, 2, 1.0).unwrap_err();
    assert_eq!(e.code, ErrorCode::Cancelled, "{}", e.message);
    calls.load(Relaxed) - set_at
}

/// A cancel flag stops a render within a pixel, whatever the pixel's work, each case making
/// 10⁸ to 10⁹ calls of the field function uncancelled; after the flag, each makes at most
/// what the rays under way take to their next look (every [`PROBE_EVERY`] segments), and no
/// ray starts:
/// - a pixel whose samples each send a shadow ray through the object (step 3·10⁻⁵ through the
///   unit cube: about 33 000 samples a ray, each with a shadow ray of up to as many): the
///   shadow ray under way runs to its next look, the primary ray to its own (one call a
///   sample, no more shadow rays sent);
/// - a DSR pixel whose surface search takes 10⁸ samples (step 10⁻⁸, an opacity under its
///   threshold everywhere): one look;
/// - a pixel super-sampled 16 × 16 whose rays take about 3 300 samples each (step 3·10⁻⁴,
///   under one look's worth; lit by an ambient light, an opacity x·y varying across the image
///   so that its sub-pixels are refined): the ray under way ends, and none of the others
///   starts.
#[test]
fn a_cancel_flag_stops_a_pixel_whose_rays_take_minutes() {
    let shadows = calls_after_cancel(
        |vl| {
            vl.step_size(3e-5, 1.0).unwrap();
            vl.point_light([0.0, 3.0, 0.0], vlib::Attenuation::None, [1.0; 3], 1.0)
                .unwrap();
            vl.toggle(vlib::Feature::CastShadows, true).unwrap();
            vl.toggle(vlib::Feature::ReceiveShadows, true).unwrap();
        },
        |_| 1e-6,
        100_000,
    );
    assert!(
        shadows <= 2 * PROBE_EVERY,
        "{shadows} calls after the flag (shadows)"
    );
    let surface = calls_after_cancel(
        |vl| {
            vl.step_size(1e-8, 1.0).unwrap();
            vl.render_type(vlib::RenderType::Dsr).unwrap();
            vl.surface(Fields::O, 0.5).unwrap();
        },
        |_| 0.25,
        100_000,
    );
    assert!(
        surface <= PROBE_EVERY,
        "{surface} calls after the flag (DSR)"
    );
    let super_sampled = calls_after_cancel(
        |vl| {
            vl.step_size(3e-4, 1.0).unwrap();
            vl.super_sample(16).unwrap();
            vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
        },
        |p| p[0] * p[1],
        10_000,
    );
    assert!(
        super_sampled <= PROBE_EVERY,
        "{super_sampled} calls after the flag (super-sampled)"
    );
}

/// A preview's sides are bounded like `vlImage`'s, not only its pixel count.
#[test]
fn a_preview_wider_than_the_largest_side_is_refused() {
    let mut vl = Library::new();
    ball(&mut vl, 0.05);
    let e = vl.render_preview(1 << 28, 1, 1.0).unwrap_err();
    assert_eq!(e.code, ErrorCode::BadValue);
    let side = vlib::limits::MAX_IMAGE_SIDE as u32;
    assert!(vl.render_preview(side, 1, 1.0).is_ok());
}

/// Within one strip of an image (a 64² image is one), the progress function hears the tiles
/// done as they end, at most every 0.1 s: rising fractions between 0 and 1 while the render
/// runs, then 1; with super-sampling too, whose second pass over the strip is counted (no 1
/// before the end). A 0 answer to one of them stops the render there: `Cancelled`, with far
/// fewer field calls than the whole image takes. On a pool of two threads, so that the
/// render's wall time (about a quarter of a second) does not depend on the machine's cores.
#[test]
fn progress_is_heard_within_a_strip_and_a_zero_answer_stops_it() {
    use std::sync::atomic::{AtomicU64, Ordering};
    use std::time::{Duration, Instant};
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    // A ball whose field function takes 50 µs a call: about half a second of work in all.
    let slow_ball = |vl: &mut Library, calls: Arc<AtomicU64>, super_sample: i32| {
        vl.scene().unwrap();
        vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
        vl.step_size(0.1, 1.0).unwrap();
        vl.super_sample(super_sample).unwrap();
        vl.object().unwrap();
        vl.function(Fields::O, move |s| {
            calls.fetch_add(1, Ordering::Relaxed);
            let t = Instant::now();
            while t.elapsed() < Duration::from_micros(50) {}
            let v = vlib::vlaux::sphere(s.position());
            let _ = s.set(Fields::O, v * 0.1);
        })
        .unwrap();
        vl.set(Fields::COLORS | Fields::KA, 1.0).unwrap();
        vl.end().unwrap();
    };
    let dir = Dir::new("strip");
    let mut all = 0;
    for super_sample in [1, 2] {
        let calls = Arc::new(AtomicU64::new(0));
        let (mut vl, heard) = recording(|_| true);
        slow_ball(&mut vl, calls.clone(), super_sample);
        vl.image(dir.0.join("a.ppm"), 1.0, 64, 64).unwrap();
        two.install(|| vl.end()).unwrap();
        let heard = heard.lock().unwrap().clone();
        let (last, before) = heard.split_last().unwrap();
        assert_eq!(*last, 1.0, "{heard:?}");
        assert!(
            before.len() >= 2,
            "super-sampling {super_sample}: {heard:?}"
        );
        assert!(before.iter().all(|&f| f > 0.0 && f < 1.0), "{heard:?}");
        assert!(heard.windows(2).all(|w| w[0] <= w[1]), "{heard:?}");
        if super_sample == 1 {
            all = calls.load(Ordering::Relaxed);
        }
    }
    // Stopped at the first fraction heard.
    let stopped_calls = Arc::new(AtomicU64::new(0));
    let (mut vl, heard) = recording(|f| f >= 1.0);
    slow_ball(&mut vl, stopped_calls.clone(), 1);
    vl.image(dir.0.join("b.ppm"), 1.0, 64, 64).unwrap();
    let e = two.install(|| vl.end()).unwrap_err();
    assert_eq!(e.code, ErrorCode::Cancelled, "{}", e.message);
    assert!(!dir.0.join("b.ppm").exists());
    let stopped = stopped_calls.load(Ordering::Relaxed);
    assert!(
        stopped < all / 2,
        "{stopped} field calls of {all}; heard {:?}",
        heard.lock().unwrap()
    );
}
