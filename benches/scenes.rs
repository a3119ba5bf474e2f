//! Representative scenes besides the MNI brain, each rendered to memory at 256×256 with
//! `render_preview`:
//!
//! - `figure2`: the paper's Figure 2 with a stone texture of its own: DVR, a paraboloid
//!   field through a lookup table, a turbulence texture, one point light;
//! - `hypertexture`: a semi-transparent sphere whose density is eaten into by turbulence
//!   (Perlin & Hoffert), DVR, one point light;
//! - `dsr`: five metaballs as two nested iso-surfaces (a translucent veil round opaque cores)
//!   with shadows, one point light;
//! - `threads`: each of the three, and the MNI brain of `benches/mni.rs` (at 256×256, one voxel
//!   per sample), on rayon pools of 1 and 2 threads. After the group the speed-up (median
//!   1-thread time / median 2-thread time, from interleaved timed repeats in this process) is
//!   printed per scene.
//!
//! ```text
//! cargo bench --bench scenes               # two to three minutes
//! cargo bench --bench scenes -- --quick    # a quick pass
//! cargo bench --bench scenes -- threads    # only the thread scaling
//! cargo bench --bench scenes -- '^dsr/'    # one scene (and no speed-ups)
//! ```
//!
//! The MNI scene needs the converted dataset (see `benches/mni.rs`); without it, it is skipped
//! with a message.

mod common;
#[path = "../examples/common/figure2_scene.rs"]
mod figure2_scene;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::time::Duration;
use vlib::MappingId;
use vlib::{vlaux, Attenuation, Camera, Feature, Fields, Library, MappingType, RenderType};

/// Image size of the scene benchmarks.
const SIDE: u32 = 256;

/// Interleaved timed repeats per thread count for the printed speed-ups: at least this many,
/// and more for a short frame ([`SECONDS`]).
const REPEATS: usize = 9;

/// Seconds of 1-thread frames a scene's speed-up is timed over at least: a frame of a few
/// milliseconds needs hundreds of repeats before a burst of load elsewhere on a shared host
/// moves its median by less than the speed-up's last digit.
const SECONDS: f64 = 2.0;

fn render(vl: &Library) -> vlib::Image {
    vl.render_preview(SIDE, SIDE, 1.0).unwrap()
}

/// The paper's Figure 2 with a simpler stone than `examples/figure2.rs` (the benchmark's scene
/// is kept as measured in `docs/performance.md`), without its image output.
fn figure2() -> Library {
    let mut vl = Library::new();
    let geometry = |s: &mut vlib::Sample| {
        let _ = s.set(Fields::F, vlaux::parab1(s.position()));
    };
    figure2_scene::build_with(&mut vl, None, geometry, figure2_scene::bench_stone, false).unwrap();
    vl
}

/// A hypertexture: a sphere of diameter 200 whose density falls off towards its rim and is
/// broken up by turbulence, semi-transparent (opacity exact over 6 world units, sampled every
/// 3), with a fiery colour ramp. The geometry F is the smooth sphere field, so the normals
/// (central differences of F, for the diffuse term) do not re-evaluate the turbulence.
fn hypertexture() -> Library {
    common::hypertexture::build(common::hypertexture::geometry, |s| {
        common::hypertexture::opacity_colours(s);
    })
}

/// Direct surface rendering: five metaballs (the blobs of `examples/c/metaballs.c`) as two
/// iso-surfaces of their summed field, a translucent veil at 0.3 round opaque cores at 0.55,
/// with specular highlights; the object casts and receives shadows (the veil shades the cores;
/// the surfaces do not shadow themselves: `dsr_surface_does_not_shadow_itself` in `tests/secondary.rs`).
fn dsr() -> Library {
    const S: f32 = 0.07;
    const CUT: f32 = 16.0;
    const TAIL: f32 = 1.0 / (1.0 + CUT);
    const BALLS: [([f32; 3], f32); 5] = [
        ([0.28, 0.57, 0.52], 1.25),
        ([0.55, 0.65, 0.44], 1.10),
        ([0.75, 0.45, 0.56], 1.15),
        ([0.48, 0.36, 0.42], 1.05),
        ([0.30, 0.28, 0.62], 0.95),
    ];
    let mut vl = Library::new();
    // F -> (O, R, G, B): a faint blue veil, then an opaque red core.
    #[rustfmt::skip]
    let table = [
        0.295, 0.0, 0.0, 0.0, 0.0,
        0.545, 0.3, 0.5, 0.75, 1.0,
        1.0, 1.0, 0.9, 0.2, 0.12,
    ];
    vl.mapping(MappingId(1), MappingType::Lookup, 3, 4, &table)
        .unwrap();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [-60.0, 90.0, -330.0],
        at: [0.0, -4.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov: 27.0,
    })
    .unwrap();
    vl.background(0.05, 0.06, 0.10).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 0.4).unwrap();
    vl.point_light([-300.0, 400.0, -350.0], Attenuation::None, [1.0; 3], 0.9)
        .unwrap();
    vl.step_size(3.0, 1.0).unwrap();
    vl.render_type(RenderType::Dsr).unwrap();
    vl.surface(Fields::F, 0.3).unwrap();
    vl.surface(Fields::F, 0.55).unwrap();
    vl.toggle(Feature::CastShadows, true).unwrap();
    vl.toggle(Feature::ReceiveShadows, true).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(200.0, 200.0, 200.0).unwrap();
    vl.function(Fields::F, |s| {
        let p = s.position();
        let mut f = 0.0;
        for (c, w) in BALLS {
            let q =
                ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)) / (S * S);
            if q < CUT {
                f += w * (1.0 / (1.0 + q) - TAIL) / (1.0 - TAIL);
            }
        }
        let _ = s.set(Fields::F, f);
    })
    .unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    vl.map(Fields::R, Fields::F, MappingId(1), 2).unwrap();
    vl.map(Fields::G, Fields::F, MappingId(1), 3).unwrap();
    vl.map(Fields::B, Fields::F, MappingId(1), 4).unwrap();
    vl.set(Fields::KA, 0.6).unwrap();
    vl.set(Fields::KD, 0.7).unwrap();
    vl.set(Fields::KS, 0.5).unwrap();
    vl.set(Fields::N, vlib::types::specular_to_field(40.0))
        .unwrap();
    vl.end().unwrap();
    vl
}

/// The MNI brain of `benches/mni.rs` at one voxel per sample, shaded, all speed-ups on; `None`
/// (with a message) when the dataset is not available.
fn mni() -> Option<Library> {
    match common::try_mni_dataset() {
        Ok(vlb) => Some(common::mni_scene(&vlb, 1.0, true, Default::default())),
        Err(e) => {
            println!("threads: MNI skipped ({e})");
            None
        }
    }
}

/// Writes the three scenes' images (for a look): `VLIB_SCENES_IMAGES=dir`.
fn images() {
    let Some(dir) = std::env::var_os("VLIB_SCENES_IMAGES") else {
        return;
    };
    for (name, build) in SCENES {
        let img = render(&build());
        let path = std::path::Path::new(&dir).join(format!("scene_{name}.png"));
        vlib::write_image(&path, SIDE, SIDE, &img.to_rgb8()).unwrap();
        println!("wrote {}", path.display());
    }
}

/// A scene's name and the function that builds it (the scene left open, ready to render).
type Scene = (&'static str, fn() -> Library);

/// The scenes of the per-scene groups.
const SCENES: [Scene; 3] = [
    ("figure2", figure2),
    ("hypertexture", hypertexture),
    ("dsr", dsr),
];

fn scene_benches(c: &mut Criterion) {
    images();
    for (name, build) in SCENES {
        let vl = build();
        let mut g = c.benchmark_group(name);
        g.sample_size(10).measurement_time(Duration::from_secs(4));
        g.bench_function(format!("{SIDE}x{SIDE}"), |b| b.iter(|| render(&vl)));
        g.finish();
    }
}

fn thread_scaling(c: &mut Criterion) {
    let pools: Vec<(usize, rayon::ThreadPool)> = [1, 2]
        .into_iter()
        .map(|n| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap();
            (n, pool)
        })
        .collect();
    let mut scenes: Vec<(&str, Library)> = SCENES.iter().map(|(n, b)| (*n, b())).collect();
    if let Some(vl) = mni() {
        // The first frame computes the brick ranges and the skip grid: not part of the scaling.
        render(&vl);
        scenes.push(("mni", vl));
    }

    let mut g = c.benchmark_group("threads");
    g.sample_size(10).measurement_time(Duration::from_secs(3));
    for (name, vl) in &scenes {
        for (n, pool) in &pools {
            g.bench_with_input(BenchmarkId::new(*name, n), n, |b, _| {
                b.iter(|| pool.install(|| render(vl)))
            });
        }
    }
    g.finish();

    // The speed-ups, from repeats interleaved 1, 2, 1, 2 … so that a burst of load from
    // elsewhere on the machine hits both thread counts alike.
    if !speedups_wanted() {
        return;
    }
    println!(
        "thread scaling at {SIDE}x{SIDE} (median of at least {REPEATS} interleaved frames each, \
         {SECONDS} s of 1-thread frames; load average {}):",
        load_average()
    );
    for (name, vl) in &scenes {
        let mut times: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
        let mut cpu = [0.0f64; 2];
        // Repeats from one 1-thread frame's time.
        let once = common::seconds(|| {
            pools[0].1.install(|| render(vl));
        });
        let repeats = REPEATS.max((SECONDS / once.max(1e-6)).ceil().min(1e4) as usize);
        for _ in 0..repeats {
            for (i, (_, pool)) in pools.iter().enumerate() {
                let c0 = cpu_seconds();
                times[i].push(common::seconds(|| {
                    pool.install(|| render(vl));
                }));
                cpu[i] += cpu_seconds().zip(c0).map_or(f64::NAN, |(a, b)| a - b);
            }
        }
        // How many cores the frames actually had: CPU time over wall time. Below 1 for the
        // 1-thread frames, or well below 2 for the 2-thread ones, the rest of the machine was
        // busy and the speed-up says little.
        let [busy1, busy2] = [0, 1].map(|i| cpu[i] / times[i].iter().sum::<f64>());
        let [t1, t2] = times.map(common::median);
        println!(
            "  {name:<13} 1 thread {:8.1} ms   2 threads {:8.1} ms   speed-up {:.2}   \
             (cores busy: {busy1:.2} and {busy2:.2}; {repeats} repeats)",
            1e3 * t1,
            1e3 * t2,
            t1 / t2
        );
    }
}

/// CPU time of this process's threads so far (user + system), in seconds: the sum of the
/// first field of each `/proc/self/task/*/schedstat` (nanoseconds on the CPU; Linux), or,
/// where that is missing, `/proc/self/stat`'s clock ticks taken as 1/100 s; `None` elsewhere.
/// (Ticks are too coarse for frames of a few milliseconds.) A thread that ended takes its time
/// along: the pools' threads live through the measurement.
fn cpu_seconds() -> Option<f64> {
    let from_tasks = || -> Option<f64> {
        let mut ns = 0u64;
        for task in std::fs::read_dir("/proc/self/task").ok()? {
            let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
            ns += stat.split_whitespace().next()?.parse::<u64>().ok()?;
        }
        Some(ns as f64 * 1e-9)
    };
    from_tasks().or_else(|| {
        let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
        // Fields after the command name (which is in parentheses and may hold spaces): state
        // is field 3, utime and stime fields 14 and 15.
        let rest = &stat[stat.rfind(')')? + 2..];
        let f: Vec<&str> = rest.split_whitespace().collect();
        let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
        Some(ticks / 100.0)
    })
}

/// Whether to time the speed-ups: not when listing or testing the benchmarks, nor when a
/// filter is given that leaves out the `threads` group (`cargo bench --bench scenes -- dsr`).
fn speedups_wanted() -> bool {
    // Criterion's options that take a value (which is not a filter).
    const WITH_VALUE: [&str; 15] = [
        "--baseline",
        "--color",
        "--confidence-level",
        "--format",
        "--load-baseline",
        "--measurement-time",
        "--noise-threshold",
        "--nresamples",
        "--output-format",
        "--plotting-backend",
        "--profile-time",
        "--sample-size",
        "--save-baseline",
        "--significance-level",
        "--warm-up-time",
    ];
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.iter().any(|a| a == "--list" || a == "--test") {
        return false;
    }
    let filters: Vec<&String> = args
        .iter()
        .enumerate()
        .filter(|(i, a)| {
            !a.starts_with('-') && (*i == 0 || !WITH_VALUE.contains(&args[i - 1].as_str()))
        })
        .map(|(_, a)| a)
        .collect();
    filters.is_empty()
        || filters
            .iter()
            .any(|f| f.contains("threads") || "threads".starts_with(f.as_str()))
}

/// The 1-minute load average (Linux), to judge how quiet the machine was; "?" elsewhere.
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(String::from))
        .unwrap_or_else(|| "?".into())
}

criterion_group!(benches, scene_benches, thread_scaling);
criterion_main!(benches);
