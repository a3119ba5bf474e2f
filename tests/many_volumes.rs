//! Many DVR volumes along one ray: their samples are composited in depth order, and where
//! samples of several lie at the same depth, in the order of the objects, whether the ray
//! meets a few volumes (each one's next sample looked at every step) or more than eight (the
//! next samples waiting in a heap). Closed forms for constant media: a slab of opacity o per
//! reference length, d deep, lets (1 − o)^d through, whatever the step.

#[path = "common/slab.rs"]
mod slab;

use slab::{head_on, slab_object};
use vlib::{Fields, Library};

/// Constant slabs seen head-on (ambient white light, KA 1, so a sample's colour is its RGB),
/// reference length 1, step 0.5: slab i of `slabs` is [−200, 200]² × [z_i, z_i + depth], of
/// opacity o_i and colour c_i. Returns the centre pixel of a 5² preview.
fn centre(slabs: &[(f32, f32, f32, [f32; 3])]) -> [f64; 3] {
    let mut vl = Library::new();
    vl.scene().unwrap();
    head_on(&mut vl);
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.background(0.0, 0.0, 0.0).unwrap();
    vl.step_size(0.5, 1.0).unwrap();
    for &(z, depth, o, [r, g, b]) in slabs {
        slab_object(&mut vl, depth);
        vl.translate(0.0, 0.0, z).unwrap();
        vl.set(Fields::O, o).unwrap();
        vl.set(Fields::R, r).unwrap();
        vl.set(Fields::G, g).unwrap();
        vl.set(Fields::B, b).unwrap();
        vl.set(Fields::KA, 1.0).unwrap();
        vl.end().unwrap();
    }
    vl.render_preview(5, 5, 1.0)
        .unwrap()
        .pixel(2, 2)
        .map(f64::from)
}

/// Front-to-back compositing of (α, colour) in the order given.
fn composite(layers: impl IntoIterator<Item = (f64, [f32; 3])>) -> [f64; 3] {
    let (mut c, mut t) = ([0.0; 3], 1.0);
    for (alpha, colour) in layers {
        for k in 0..3 {
            c[k] += t * alpha * colour[k] as f64;
        }
        t *= 1.0 - alpha;
    }
    c
}

fn close(got: [f64; 3], want: [f64; 3], what: &str) {
    for k in 0..3 {
        // f32 pixels of f64 sums: within 10⁻⁵ (the slabs' exact opacities, `tests/dvr.rs`).
        assert!(
            (got[k] - want[k]).abs() < 1e-5,
            "{what}: {got:?} vs {want:?}"
        );
    }
}

/// The colour of slab i: red, green and blue in turn, each a little darker than the last.
fn colour(i: usize) -> [f32; 3] {
    let mut c = [0.0; 3];
    c[i % 3] = 1.0 - 0.04 * i as f32;
    c
}

#[test]
fn slabs_one_behind_another_are_composited_front_to_back() {
    for n in [4, 12] {
        // Declared back to front, so that object order is not depth order.
        let slabs: Vec<(f32, f32, f32, [f32; 3])> = (0..n)
            .rev()
            .map(|i| (i as f32, 1.0, 0.1 + 0.02 * i as f32, colour(i)))
            .collect();
        let mut by_depth = slabs.clone();
        by_depth.sort_by(|a, b| a.0.total_cmp(&b.0));
        let want = composite(
            by_depth
                .iter()
                .map(|&(_, d, o, c)| (1.0 - (1.0 - o as f64).powf(d as f64), c)),
        );
        let backwards = composite(
            by_depth
                .iter()
                .rev()
                .map(|&(_, d, o, c)| (1.0 - (1.0 - o as f64).powf(d as f64), c)),
        );
        assert!(want
            .iter()
            .zip(&backwards)
            .any(|(a, b)| (a - b).abs() > 1e-3));
        close(centre(&slabs), want, &format!("{n} slabs"));
    }
}

#[test]
fn samples_at_the_same_depth_are_composited_in_object_order() {
    for n in [4, 12] {
        // One slab [0, 4] for all: 100 to 104 along the centre ray, eight segments of 0.5
        // each (exact in binary), every one at the same depths in every object.
        let slabs: Vec<(f32, f32, f32, [f32; 3])> = (0..n)
            .map(|i| (0.0, 4.0, 0.01 + 0.008 * i as f32, colour(i)))
            .collect();
        let steps = |order: &mut dyn Iterator<Item = usize>| -> Vec<(f64, [f32; 3])> {
            let order: Vec<usize> = order.collect();
            (0..8)
                .flat_map(|_| {
                    order.iter().map(|&i| {
                        let (_, _, o, c) = slabs[i];
                        (1.0 - (1.0 - o as f64).powf(0.5), c)
                    })
                })
                .collect()
        };
        let want = composite(steps(&mut (0..n)));
        let reversed = composite(steps(&mut (0..n).rev()));
        assert!(want
            .iter()
            .zip(&reversed)
            .any(|(a, b)| (a - b).abs() > 1e-3));
        close(centre(&slabs), want, &format!("{n} slabs at one depth"));
    }
}
