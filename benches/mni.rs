//! The MNI brain at 512×512, sample distance 0.5 voxel, shaded (the VTK peer scene of
//! `../shared/bench/README.md`): the steady frame with and without empty-space skipping and
//! early ray termination, measured in one process so the ratios are meaningful, plus the first
//! frame (dataset load and precomputation included) and the unshaded frame; and at 256×256,
//! adaptive super-sampling with its rays in packets and by the scalar march.
//!
//! ```text
//! cargo bench --bench mni            # or benches/peer.sh for the side-by-side with VTK
//! ```
//!
//! The dataset is converted from `../shared/data/…nii.gz` with `vlconvert` on first use
//! (into `target/bench-data/mni.vlb`), or taken from `$VLIB_MNI_VLB`.

mod common;

use common::{mni_dataset as dataset, mni_scene as scene};
use criterion::{criterion_group, criterion_main, Criterion};
use std::time::{Duration, Instant};
use vlib::Optimise;

fn bench(c: &mut Criterion) {
    let vlb = dataset();
    // The first frame: load, brick ranges, skip grid and render, as a user sees it once;
    // five times from a fresh load (one measurement on a shared host is mostly noise), the
    // median reported, with the fastest and slowest.
    let mut firsts: Vec<f64> = (0..5)
        .map(|_| {
            let t = Instant::now();
            let vl = scene(&vlb, 0.5, true, Optimise::default());
            vl.render_preview(512, 512, 1.0).unwrap();
            t.elapsed().as_secs_f64()
        })
        .collect();
    firsts.sort_by(f64::total_cmp);
    println!(
        "mni first frame (load + precomputation + render, median of 5 fresh loads): {:.3} s \
         (fastest {:.3} s, slowest {:.3} s)",
        firsts[2], firsts[0], firsts[4]
    );

    let mut g = c.benchmark_group("mni_512_sd0.5");
    g.sample_size(10).measurement_time(Duration::from_secs(8));
    let vtk_termination = common::mni_scene::VTK_TERMINATION;
    let t_min = vlib::T_MIN;
    let variants = [
        ("shaded", true, true, true, true, t_min),
        ("shaded_no_skipping", true, false, true, true, t_min),
        (
            "shaded_no_early_termination",
            true,
            true,
            false,
            true,
            t_min,
        ),
        ("shaded_neither", true, false, false, true, t_min),
        ("shaded_no_lean_kernel", true, true, true, false, t_min),
        ("shaded_scalar", true, true, true, true, t_min),
        ("shaded_eight_lanes", true, true, true, true, t_min),
        (
            "shaded_vtk_termination",
            true,
            true,
            true,
            true,
            vtk_termination,
        ),
        ("unshaded", false, true, true, true, t_min),
    ];
    for (name, shaded, skip_empty, early_termination, lean_kernel, termination) in variants {
        let vl = scene(
            &vlb,
            0.5,
            shaded,
            Optimise {
                skip_empty,
                early_termination,
                termination,
                lean_kernel,
                // ("shaded_scalar": every ray by the scalar march, not the packet march;
                // "shaded_eight_lanes": the packet march in AVX2's eight lanes, not AVX-512's
                // sixteen.)
                packets: name != "shaded_scalar",
                wide_lanes: name != "shaded_eight_lanes",
                trust_whole_runs: true,
                preintegrate: false,
            },
        );
        g.bench_function(name, |b| {
            b.iter(|| vl.render_preview(512, 512, 1.0).unwrap())
        });
    }
    g.finish();

    // The sample-distance sweep of the VTK peer script, shaded and unshaded.
    let mut g = c.benchmark_group("mni_sweep");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    for shaded in [true, false] {
        for sd in [2.0f32, 1.0, 0.5, 0.25, 0.125] {
            let vl = scene(&vlb, sd, shaded, Optimise::default());
            let name = format!("{}_sd{sd}", if shaded { "shade" } else { "noshade" });
            g.bench_function(name, |b| {
                b.iter(|| vl.render_preview(512, 512, 1.0).unwrap())
            });
        }
    }
    g.finish();

    // Adaptive super-sampling at 256×256 (the brain's texture has most pixels refined), its
    // rays in packets against the scalar march (`packets` off), with one ray a pixel as the
    // baseline: `docs/performance.md`, "Super-sampling".
    let mut g = c.benchmark_group("mni_256_super_sampled");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    for (n, packets) in [(1, true), (2, true), (2, false), (4, true), (4, false)] {
        let mut vl = scene(
            &vlb,
            0.5,
            true,
            Optimise {
                packets,
                ..Optimise::default()
            },
        );
        vl.super_sample(n).unwrap();
        let name = format!("ss{n}_{}", if packets { "packets" } else { "scalar" });
        g.bench_function(name, |b| {
            b.iter(|| vl.render_preview(256, 256, 1.0).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
