//! Scenes of many objects: what finding the objects a ray meets through a tree of their world
//! boxes saves against testing every object (`Optimise::skip_empty` off, which also stops the
//! skipping inside each object: for constant boxes there is nothing inside to skip, so the
//! difference is the tree's). A lattice of k³ small boxes of constant medium (k = 4, 8, 16: 64
//! to 4096 objects), each a quarter of its lattice cell across, seen whole at 256², ambient and
//! one point light up, left and in front of them; then the same with shadows at 128², and with
//! the light among the boxes (at their centre: a shadow ray looks only at the boxes before its
//! light, about half of those its line meets). Each case is timed in interleaved
//! rounds (tree, then every object), and the table gives the median frames and their ratio.
//!
//! ```text
//! cargo bench --bench objects              # about a minute on two cores
//! cargo bench --bench objects -- --rounds=5
//! ```

use std::time::Instant;
use vlib::{Attenuation, Camera, Feature, Fields, Library, Optimise};

/// The point light: outside the lattice, or among its boxes.
const OUTSIDE: [f32; 3] = [-300.0, 400.0, -350.0];
const AMONG: [f32; 3] = [1.0, 2.0, 3.0];

/// A lattice of k³ boxes in [−50, 50]³, each half its cell's side, of opacity 0.05 per
/// reference length and a colour by its place, lit by a point light at `light`; `shadows`
/// toggles shadows for all.
fn lattice(k: usize, shadows: bool, light: [f32; 3], skip_empty: bool) -> Library {
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
    vl.point_light(light, Attenuation::None, [1.0; 3], 0.9)
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
    for (shadows, side, light) in [
        (false, 256u32, OUTSIDE),
        (true, 128, OUTSIDE),
        (true, 128, AMONG),
    ] {
        for k in [4usize, 8, 16] {
            let scenes = [
                lattice(k, shadows, light, true),
                lattice(k, shadows, light, false),
            ];
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
                match (shadows, light == AMONG) {
                    (false, _) => "off",
                    (true, false) => "on",
                    (true, true) => "on, light among the boxes",
                },
                tree / all
            );
        }
    }
}
