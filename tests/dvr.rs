//! Closed-form tests of the DVR renderer through the safe Rust API: exact Beer–Lambert
//! transmittance through constant media for any step, the illumination model, attenuation,
//! and thread-count independence of the output.

#[path = "common/slab.rs"]
mod slab;

use slab::{head_on, slab_object};
use vlib::{Attenuation, Camera, Fields, Image, Library};

/// A scene with a constant slab [-w/2, w/2]² × [0, depth] in world space, seen head-on from
/// z = −100, lit by ambient white light only, so a pixel is exactly the accumulated opacity.
fn slab_scene(opacity: f32, depth: f32, step: f32, reference: f32) -> Library {
    let mut vl = Library::new();
    vl.scene().unwrap();
    head_on(&mut vl);
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.background(0.0, 0.0, 0.0).unwrap();
    vl.step_size(step, reference).unwrap();
    slab_object(&mut vl, depth);
    vl.set(Fields::O, opacity).unwrap();
    vl.set(Fields::COLORS | Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    vl
}

fn preview(vl: &Library, w: u32, h: u32) -> Image {
    vl.render_preview(w, h, w as f32 / h as f32).unwrap()
}

/// The unit direction of the ray through pixel (x, y) of a `size`² image for the slab camera.
fn ray_dir(x: u32, y: u32, size: u32) -> [f64; 3] {
    let half = (10.0f64).to_radians().tan();
    let sx = ((x as f64 + 0.5) / size as f64 * 2.0 - 1.0) * half;
    let sy = (1.0 - (y as f64 + 0.5) / size as f64 * 2.0) * half;
    let n = (sx * sx + sy * sy + 1.0).sqrt();
    [sx / n, sy / n, 1.0 / n]
}

#[test]
fn constant_slab_is_exact_beer_lambert_for_any_step() {
    let (o, depth, reference) = (0.1f32, 10.0f32, 1.0f32);
    for step in [0.37f32, 1.0, 2.9, 7.0] {
        let vl = slab_scene(o, depth, step, reference);
        let img = preview(&vl, 5, 5);
        let expected = 1.0 - (1.0 - o as f64).powf(depth as f64 / reference as f64);
        let centre = img.pixel(2, 2);
        let got8 = img.to_rgb8()[(2 * 5 + 2) * 3] as f64 / 255.0;
        assert!(
            (got8 - expected).abs() <= 1.0 / 255.0,
            "step {step}: {got8} vs {expected}"
        );
        // The float result is exact up to f32 rounding of the inputs.
        assert!(
            (centre[0] as f64 - expected).abs() < 1e-5,
            "step {step}: {centre:?} vs {expected}"
        );
        // Oblique rays see the slab over depth / cos θ, still exactly.
        let d = ray_dir(0, 0, 5);
        let expected = 1.0 - (1.0 - o as f64).powf(depth as f64 / d[2] / reference as f64);
        assert!(
            (img.pixel(0, 0)[1] as f64 - expected).abs() < 1e-5,
            "step {step} oblique"
        );
    }
}

#[test]
fn opacity_reference_scales_the_exponent() {
    // The same slab with reference 2.5: transmittance (1 − o)^(L / 2.5).
    for (o, reference) in [(0.3f32, 2.5f32), (0.05, 0.5), (0.9, 40.0)] {
        let vl = slab_scene(o, 10.0, 0.75, reference);
        let img = preview(&vl, 3, 3);
        let expected = 1.0 - (1.0 - o as f64).powf(10.0 / reference as f64);
        let got = img.pixel(1, 1)[0] as f64;
        // Early termination may drop at most T_MIN of the remaining light.
        assert!(
            (got - expected).abs() < 1e-5 + vlib::T_MIN,
            "o {o} ref {reference}: {got} vs {expected}"
        );
    }
}

#[test]
fn background_shows_through_by_the_transmittance() {
    let mut vl = slab_scene(0.2, 5.0, 1.3, 1.0);
    vl.background(0.0, 1.0, 0.5).unwrap();
    let img = preview(&vl, 3, 3);
    let t = (0.8f64).powf(5.0);
    let p = img.pixel(1, 1);
    assert!((p[0] as f64 - (1.0 - t)).abs() < 1e-5);
    assert!((p[1] as f64 - 1.0).abs() < 1e-5, "(1 − T)·1 + T·1 = 1");
    assert!((p[2] as f64 - ((1.0 - t) + 0.5 * t)).abs() < 1e-5);
}

/// An opaque slab with F = 1 inside, lit by one light: the centre pixel is the illumination
/// model evaluated at the first sample with the normal −z.
fn lit_slab(
    light: impl FnOnce(&mut Library),
    ka: f32,
    kd: f32,
    ks: f32,
    exponent: f32,
) -> [f32; 3] {
    let mut vl = Library::new();
    vl.scene().unwrap();
    head_on(&mut vl);
    vl.ambient(1.0, 1.0, 1.0, 0.5).unwrap();
    vl.step_size(1.0, 1.0).unwrap();
    // Offsets reach outside the slab from the first sample (0.5 deep), so ∇F is along z.
    vl.neighborhood(1.0, 1.0, 1.0).unwrap();
    light(&mut vl);
    slab_object(&mut vl, 10.0);
    vl.set(Fields::O | Fields::F, 1.0).unwrap();
    vl.set(Fields::R, 0.8).unwrap();
    vl.set(Fields::G, 0.6).unwrap();
    vl.set(Fields::B, 0.4).unwrap();
    vl.set(Fields::KA, ka).unwrap();
    vl.set(Fields::KD, kd).unwrap();
    vl.set(Fields::KS, ks).unwrap();
    vl.set(Fields::N, vlib::types::specular_to_field(exponent))
        .unwrap();
    vl.end().unwrap();
    preview(&vl, 3, 3).pixel(1, 1)
}

#[test]
fn illumination_model_matches_the_formula() {
    let c = [0.8f64, 0.6, 0.4];
    let (ka, kd, ks, e) = (0.2f64, 0.6f64, 0.5f64, 10.0f64);
    // Light travelling along (sin 30°, 0, cos 30°): L = −(that), N = (0, 0, −1), V = (0, 0, −1).
    let th = 30f64.to_radians();
    let p = lit_slab(
        |vl| {
            vl.directional_light(
                [th.sin() as f32, 0.0, th.cos() as f32],
                [1.0, 1.0, 1.0],
                0.9,
            )
            .unwrap()
        },
        ka as f32,
        kd as f32,
        ks as f32,
        e as f32,
    );
    let ndl = th.cos();
    // R = 2(N·L)N − L; L = (−sin, 0, −cos); R·V = −R_z = 2cos² − cos... computed directly:
    let l = [-th.sin(), 0.0, -th.cos()];
    let n = [0.0, 0.0, -1.0];
    let r: Vec<f64> = (0..3).map(|i| 2.0 * ndl * n[i] - l[i]).collect();
    let rv = -r[2];
    for i in 0..3 {
        let expected = ka * 0.5 * c[i] + 0.9 * (kd * c[i] * ndl + ks * rv.powf(e));
        assert!(
            (p[i] as f64 - expected.min(1.0)).abs() < 2e-4,
            "channel {i}: {} vs {expected}",
            p[i]
        );
    }
}

#[test]
fn light_behind_the_surface_leaves_only_ambient() {
    let p = lit_slab(
        |vl| {
            vl.directional_light([0.0, 0.0, -1.0], [1.0, 1.0, 1.0], 1.0)
                .unwrap()
        },
        0.3,
        0.7,
        0.5,
        8.0,
    );
    assert!((p[0] as f64 - 0.3 * 0.5 * 0.8).abs() < 1e-5, "{p:?}");
}

#[test]
fn point_light_attenuation_modes() {
    // Light on the axis at z = −50; the first sample is at z = 0.5, so d = 50.5, N·L = 1,
    // and R·V = 1 (the light is straight in front of the surface).
    let d = 50.5f64;
    for (att, factor) in [
        (Attenuation::None, 1.0),
        (Attenuation::Inverse, 1.0 / d),
        (Attenuation::InverseSquare, 1.0 / (d * d)),
    ] {
        let p = lit_slab(
            |vl| {
                vl.point_light([0.0, 0.0, -50.0], att, [1.0, 1.0, 1.0], 1.0)
                    .unwrap()
            },
            0.0,
            1.0,
            0.0,
            1.0,
        );
        let expected = factor * 0.8;
        assert!(
            (p[0] as f64 - expected).abs() < 1e-4,
            "{att:?}: {} vs {expected}",
            p[0]
        );
    }
}

fn textured_scene() -> Library {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [0.5, 0.7, -1.2],
        at: [0.5, 0.5, 0.5],
        up: [0.0, 1.0, 0.0],
        fov: 50.0,
    })
    .unwrap();
    vl.super_sample(3).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 0.3).unwrap();
    vl.step_size(0.01, 0.02).unwrap();
    vl.point_light([-1.0, 2.0, -1.0], Attenuation::None, [1.0, 1.0, 1.0], 1.0)
        .unwrap();
    vl.object().unwrap();
    vl.function(Fields::F, |s| {
        let _ = s.set(Fields::F, vlib::vlaux::parab1(s.position()));
    })
    .unwrap();
    vl.function(Fields::O | Fields::COLORS, |s| {
        let f = s.value(9);
        let t = vlib::vlaux::turbulence(s.position(), 6.0, 4, 3);
        let _ = s.set(Fields::O, if f > 0.2 { 0.6 } else { 0.0 });
        let _ = s.set(Fields::R, 0.5 + t);
        let _ = s.set(Fields::G, 0.4 + 0.5 * t);
        let _ = s.set(Fields::B, 0.3);
    })
    .unwrap();
    vl.set(Fields::KA | Fields::KD, 0.7).unwrap();
    vl.set(Fields::KS, 0.4).unwrap();
    vl.set(Fields::N, vlib::types::specular_to_field(20.0))
        .unwrap();
    vl.end().unwrap();
    vl
}

#[test]
fn output_is_identical_for_any_thread_count() {
    let vl = textured_scene();
    let render = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| preview(&vl, 48, 40)).to_rgb8()
    };
    let one = render(1);
    assert_eq!(one, render(2));
    assert_eq!(one, render(3));
    // The scene is not trivially uniform.
    let distinct: std::collections::BTreeSet<_> = one.chunks(3).collect();
    assert!(distinct.len() > 50);
}

#[test]
fn super_sampling_refines_only_edges() {
    // A sharp-edged opaque disc: with n = 4, an edge pixel becomes the mean of 16 rays and so
    // takes intermediate values, while interior and background pixels stay exactly as they were.
    let build = |n: i32| {
        let mut vl = Library::new();
        vl.scene().unwrap();
        vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
        vl.super_sample(n).unwrap();
        vl.step_size(0.01, 0.01).unwrap();
        vl.object().unwrap();
        vl.function(Fields::O, |s| {
            let _ = s.set(
                Fields::O,
                if vlib::vlaux::sphere(s.position()) > 0.0 {
                    1.0
                } else {
                    0.0
                },
            );
        })
        .unwrap();
        vl.set(Fields::COLORS | Fields::KA, 1.0).unwrap();
        vl.end().unwrap();
        preview(&vl, 32, 32)
    };
    let (a, b) = (build(1), build(4));
    let grey = |img: &Image| {
        img.pixels
            .iter()
            .filter(|p| p[0] > 0.02 && p[0] < 0.98)
            .count()
    };
    assert_eq!(grey(&a), 0, "one ray per pixel gives a binary image");
    assert!(grey(&b) > 10, "edges are anti-aliased");
    assert_eq!(a.pixel(16, 16), b.pixel(16, 16));
    assert_eq!(a.pixel(0, 0), b.pixel(0, 0));
}

#[test]
fn instructions_after_the_last_opacity_write_run_only_where_opacity_is_positive() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    // Opacity: a ball; colour: a function that counts its calls. With the colour written after
    // the opacity, it runs only where o > 0; written before it, it runs everywhere. The images
    // must be identical.
    let build = |colour_first: bool, calls: Arc<AtomicUsize>| {
        let mut vl = Library::new();
        vl.scene().unwrap();
        vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
        vl.step_size(0.05, 0.1).unwrap();
        vl.object().unwrap();
        let colour = move |s: &mut vlib::Sample| {
            calls.fetch_add(1, Ordering::Relaxed);
            let p = s.position();
            let _ = s.set(Fields::R, p[0]);
            let _ = s.set(Fields::G, p[1]);
        };
        let opacity = |s: &mut vlib::Sample| {
            let _ = s.set(Fields::O, vlib::vlaux::sphere(s.position()));
        };
        if colour_first {
            vl.function(Fields::COLORS, colour).unwrap();
            vl.function(Fields::O, opacity).unwrap();
        } else {
            vl.function(Fields::O, opacity).unwrap();
            vl.function(Fields::COLORS, colour).unwrap();
        }
        vl.set(Fields::KA, 1.0).unwrap();
        vl.end().unwrap();
        preview(&vl, 24, 24)
    };
    let (lazy, eager) = (Arc::new(AtomicUsize::new(0)), Arc::new(AtomicUsize::new(0)));
    let a = build(false, lazy.clone());
    let b = build(true, eager.clone());
    assert_eq!(a, b);
    let (lazy, eager) = (lazy.load(Ordering::Relaxed), eager.load(Ordering::Relaxed));
    assert!(
        lazy > 0 && lazy * 3 < eager * 2,
        "lazy {lazy} eager {eager}"
    );
}

#[test]
fn a_field_last_set_to_a_constant_is_folded_for_normals() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    // F is a constant, set after a colour function: normals (central differences of F) must
    // not run that function again — the counts with and without a light are equal.
    let count = |lit: bool| {
        let calls = Arc::new(AtomicUsize::new(0));
        let c = calls.clone();
        let mut vl = Library::new();
        vl.scene().unwrap();
        vl.ambient(1.0, 1.0, 1.0, 0.5).unwrap();
        if lit {
            vl.directional_light([0.0, -1.0, 1.0], [1.0; 3], 1.0)
                .unwrap();
        }
        vl.step_size(0.05, 0.5).unwrap();
        vl.object().unwrap();
        vl.function(Fields::O | Fields::COLORS, move |s| {
            c.fetch_add(1, Ordering::Relaxed);
            let _ = s.set(Fields::O | Fields::COLORS, 0.5);
        })
        .unwrap();
        vl.set(Fields::F, 0.5).unwrap();
        vl.set(Fields::KA | Fields::KD, 1.0).unwrap();
        vl.end().unwrap();
        let img = preview(&vl, 6, 6);
        (calls.load(Ordering::Relaxed), img)
    };
    let (dark, _) = count(false);
    let (lit, img) = count(true);
    assert!(dark > 100);
    assert_eq!(lit, dark, "normal estimation re-ran the colour function");
    assert!(img.pixels.iter().all(|p| p[0].is_finite()));
}
