//! Scenes of many objects: what finding the objects a ray meets through a tree of their world
//! boxes saves against testing every object (`Optimise::skip_empty` off, which also stops the
//! skipping inside each object: for constant boxes there is nothing inside to skip, so the
//! difference is the tree's). A lattice of k³ small boxes of constant medium (k = 4, 8, 16: 64
//! to 4096 objects), each a quarter of its lattice cell across, seen whole at 256², ambient and
//! one point light; then the same with shadows at 128². Each case is timed in interleaved
//! rounds (tree, then every object), and the table gives the median frames and their ratio.
//!
//! ```text
//! cargo bench --bench objects              # about a minute on two cores
//! cargo bench --bench objects -- --rounds=5
//! ```

use std::time::Instant;
use vlib::{Attenuation, Camera, Feature, Fields, Library, Optimise};

/// A lattice of k³ boxes in [−50, 50]³, each half its cell's side, of opacity 0.05 per
/// reference length and a colour by its place; `shadows` toggles shadows for all.
fn lattice(k: usize, shadows: bool, skip_empty: bool) -> Library {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [0.0, 0.0, -300.0],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov: 30.0,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 0.3).unwrap();
    vl.point_light([-300.0, 400.0, -350.0], Attenuation::None, [1.0; 3], 0.9)
        .unwrap();
    vl.toggle(Feature::CastShadows, shadows).unwrap();
    vl.toggle(Feature::ReceiveShadows, shadows).unwrap();
    vl.step_size(0.5, 1.0).unwrap();
    let s = 100.0 / k as f32;
    for i in 0..k {
        for j in 0..k {
            for l in 0..k {
                let at = |n: usize| -50.0 + s * (n as f32 + 0.25);
                vl.object().unwrap();
                vl.translate(at(i), at(j), at(l)).unwrap();
                vl.scale(s * 0.5, s * 0.5, s * 0.5).unwrap();
                vl.set(Fields::O, 0.05).unwrap();
                vl.set(Fields::R, i as f32 / k as f32).unwrap();
                vl.set(Fields::G, j as f32 / k as f32).unwrap();
                vl.set(Fields::B | Fields::KD, 0.5).unwrap();
                vl.set(Fields::KA, 1.0).unwrap();
                vl.end().unwrap();
            }
        }
    }
    vl.set_optimise(Optimise {
        skip_empty,
        ..Default::default()
    })
    .unwrap();
    vl
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let rounds = std::env::args()
        .find_map(|a| {
            a.strip_prefix("--rounds=")
                .map(|n| n.parse::<usize>().unwrap())
        })
        .unwrap_or(3);
    println!(
        "| objects | shadows | image | tree (ms) | every object tested (ms) | tree / every object |"
    );
    println!("|---|---|---|---|---|---|");
    for (shadows, side) in [(false, 256u32), (true, 128)] {
        for k in [4usize, 8, 16] {
            let scenes = [lattice(k, shadows, true), lattice(k, shadows, false)];
            // The first frame compiles the scene; both images must be the same bytes.
            let first: Vec<Vec<u8>> = scenes
                .iter()
                .map(|vl| vl.render_preview(side, side, 1.0).unwrap().to_rgb8())
                .collect();
            assert!(first[0] == first[1], "the tree changed the image");
            let mut times = [Vec::new(), Vec::new()];
            for _ in 0..rounds {
                for (vl, t) in scenes.iter().zip(times.iter_mut()) {
                    let start = Instant::now();
                    std::hint::black_box(vl.render_preview(side, side, 1.0).unwrap());
                    t.push(start.elapsed().as_secs_f64() * 1e3);
                }
            }
            let [tree, all] = times.map(median);
            println!(
                "| {} | {} | {side}² | {tree:.1} | {all:.1} | {:.3} |",
                k * k * k,
                if shadows { "on" } else { "off" },
                tree / all
            );
        }
    }
}
