//! Numerical stability under hard cases, as property tests with a fixed seed: absurd and near-
//! singular transforms, cameras inside objects and at lights, field functions returning NaN,
//! ±Inf and ±1e30, steps from 10⁻⁴ to 10⁶ of the object's size, extreme opacity references,
//! mapping tables with a_1 = 0 or a_n = 1, DSR/MIP/shadows/secondary rays switched on at
//! random. Nothing panics, every pixel is finite and in [0, 1], transmittance never increases
//! along a ray, and the image does not depend on the thread count.

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use vlib::MappingId;
use vlib::{Attenuation, Camera, Feature, Fields, Library, MappingType, RenderType};

/// Values a field function may return, hostile ones included.
fn hostile() -> impl Strategy<Value = f32> {
    prop_oneof![
        3 => 0.0f32..1.0,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(1e30f32),
        1 => Just(-1e30f32),
        1 => -2.0f32..3.0,
    ]
}

#[derive(Clone, Debug)]
struct Case {
    scale: [f32; 3],
    rotate: [f32; 3],
    translate: [f32; 3],
    step_rel: f32,
    reference_rel: f32,
    eye: [f32; 3],
    opacity: f32,
    colour: f32,
    geometry: [f32; 2],
    mapping_ends: (bool, bool),
    render_type: u8,
    toggles: u8,
    light_at_eye: bool,
    super_sample: i32,
}

fn case() -> impl Strategy<Value = Case> {
    let scale = prop_oneof![4 => 0.1f32..100.0, 1 => 1e-4f32..1e-2, 1 => 1e3f32..1e5];
    (
        (
            [scale.clone(), scale.clone(), scale],
            [-360f32..360.0, -360f32..360.0, -360f32..360.0],
            [-50f32..50.0, -50f32..50.0, -50f32..50.0],
            // Steps from 1e-4 to 1e6 of the object size (log-uniform), references likewise.
            -4.0f32..6.0,
            -6.0f32..6.0,
            [-3f32..3.0, -3f32..3.0, -3f32..3.0],
        ),
        (
            hostile(),
            hostile(),
            [hostile(), hostile()],
            (any::<bool>(), any::<bool>()),
            0u8..3,
            any::<u8>(),
            any::<bool>(),
            1i32..3,
        ),
    )
        .prop_map(
            |(
                (scale, rotate, translate, step_rel, reference_rel, eye),
                (
                    opacity,
                    colour,
                    geometry,
                    mapping_ends,
                    render_type,
                    toggles,
                    light_at_eye,
                    super_sample,
                ),
            )| Case {
                scale,
                rotate,
                translate,
                step_rel,
                reference_rel,
                eye,
                opacity,
                colour,
                geometry,
                mapping_ends,
                render_type,
                toggles,
                light_at_eye,
                super_sample,
            },
        )
}

/// Builds the case's scene; commands may refuse hostile values (that is fine: a refused call
/// changes nothing), but nothing may panic.
fn build(c: &Case) -> Library {
    let mut vl = Library::new();
    let (a1, an) = (
        if c.mapping_ends.0 { 0.0 } else { 0.1 },
        if c.mapping_ends.1 { 1.0 } else { 0.9 },
    );
    vl.mapping(MappingId(1), MappingType::Ramp, 2, 1, &[a1, 0.3, an, 0.9])
        .unwrap();
    vl.scene().unwrap();
    let size = c.scale.iter().fold(0.0f32, |m, v| m.max(*v));
    // The eye at a multiple of the object's size from its centre: inside it for small values.
    let centre = c.translate;
    let eye = [
        centre[0] + c.eye[0] * size,
        centre[1] + c.eye[1] * size,
        centre[2] + c.eye[2] * size,
    ];
    let _ = vl.camera(&Camera {
        eye,
        at: centre,
        up: [0.0, 1.0, 0.0],
        fov: 50.0,
    });
    let _ = vl.step_size(
        size * 10f32.powf(c.step_rel),
        size * 10f32.powf(c.reference_rel),
    );
    let _ = vl.super_sample(c.super_sample);
    vl.ambient(1.0, 1.0, 1.0, 0.4).unwrap();
    let light = if c.light_at_eye {
        eye
    } else {
        [centre[0], centre[1] + 3.0 * size, centre[2]]
    };
    let _ = vl.point_light(light, Attenuation::InverseSquare, [1.0; 3], 1.0);
    vl.render_type(RenderType::from_raw(c.render_type as i32).unwrap())
        .unwrap();
    let _ = vl.surface(Fields::F, 0.5);
    for (bit, f) in [
        Feature::CastShadows,
        Feature::ReceiveShadows,
        Feature::CastReflections,
        Feature::ReceiveReflections,
        Feature::Refract,
        Feature::FlipNormals,
        Feature::ReflectBackground,
    ]
    .iter()
    .enumerate()
    {
        vl.toggle(*f, c.toggles & (1 << bit) != 0).unwrap();
    }
    vl.object().unwrap();
    let _ = vl.translate(-0.5, -0.5, -0.5);
    let _ = vl.scale(c.scale[0], c.scale[1], c.scale[2]);
    let _ = vl.rotate(c.rotate[0], c.rotate[1], c.rotate[2]);
    let _ = vl.translate(c.translate[0], c.translate[1], c.translate[2]);
    let (g0, g1, o, col) = (c.geometry[0], c.geometry[1], c.opacity, c.colour);
    vl.function(Fields::F, move |s| {
        let p = s.position();
        let v = if p[0] < 0.5 {
            g0
        } else {
            g1 * vlib::vlaux::sphere(p)
        };
        let _ = s.set(Fields::F, v);
    })
    .unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    vl.function(
        Fields::O | Fields::COLORS | Fields::KS | Fields::RF,
        move |s| {
            let f = s.value(9);
            let _ = s.set(Fields::O, o * f + (1.0 - f) * 0.2);
            let _ = s.set(Fields::COLORS, col);
            let _ = s.set(Fields::KS, 0.5);
            let _ = s.set(Fields::RF, 0.3);
        },
    )
    .unwrap();
    vl.set(Fields::KA | Fields::KD, 0.6).unwrap();
    vl.end().unwrap();
    vl
}

fn render(vl: &Library, threads: usize) -> Vec<u8> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let img = pool.install(|| vl.render_preview(4, 3, 4.0 / 3.0)).unwrap();
    assert!(
        img.pixels
            .iter()
            .flatten()
            .all(|v| v.is_finite() && (0.0..=1.0).contains(v)),
        "{:?}",
        img.pixels
    );
    img.to_rgb8()
}

fn runner(cases: u32) -> TestRunner {
    let config = Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    };
    TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]))
}

#[test]
fn hostile_scenes_render_finite_pixels_identically_on_any_thread_count() {
    runner(6000)
        .run(&case(), |c| {
            let vl = build(&c);
            let one = render(&vl, 1);
            prop_assert_eq!(one, render(&vl, 2));
            Ok(())
        })
        .unwrap();
}

#[test]
fn transmittance_never_increases_along_a_ray() {
    // A black constant medium in front of a white background, seen head-on: the pixel is the
    // transmittance, which may only fall as the medium gets deeper, for any step and opacity.
    runner(4000)
        .run(
            &(0.0f32..1.0, 0.01f32..50.0, 0.01f32..50.0, -4.0f32..2.0),
            |(o, d1, extra, step_rel)| {
                let pixel = |depth: f32| {
                    let mut vl = Library::new();
                    vl.scene().unwrap();
                    vl.camera(&Camera {
                        eye: [0.0, 0.0, -100.0],
                        at: [0.0; 3],
                        up: [0.0, 1.0, 0.0],
                        fov: 10.0,
                    })
                    .unwrap();
                    vl.background(1.0, 1.0, 1.0).unwrap();
                    vl.step_size(depth.max(1e-3) * 10f32.powf(step_rel), 1.0)
                        .unwrap();
                    vl.object().unwrap();
                    vl.translate(-0.5, -0.5, 0.0).unwrap();
                    vl.scale(400.0, 400.0, depth).unwrap();
                    vl.set(Fields::O, o).unwrap();
                    vl.end().unwrap();
                    vl.render_preview(1, 1, 1.0).unwrap().pixel(0, 0)[0]
                };
                let (a, b) = (pixel(d1), pixel(d1 + extra));
                prop_assert!(b <= a + 1e-6, "T({}) = {a} < T({}) = {b}", d1, d1 + extra);
                prop_assert!((0.0..=1.0).contains(&a));
                Ok(())
            },
        )
        .unwrap();
}

/// A normal function that writes a NaN or an infinity hands the next one no normal, (0, 0, 0),
/// as where the gradient vanishes: no NaN or infinity reaches a user's function, and the
/// pixels stay finite. A first function writing a finite normal passes it on as it is.
#[test]
fn normal_functions_never_see_a_nan_or_an_infinity() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0] {
        let (calls, zero, hostile) = (
            Arc::new(AtomicUsize::new(0)),
            Arc::new(AtomicUsize::new(0)),
            Arc::new(AtomicUsize::new(0)),
        );
        let mut vl = Library::new();
        vl.scene().unwrap();
        vl.camera(&Camera {
            eye: [0.5, 0.5, -2.0],
            at: [0.5, 0.5, 0.5],
            up: [0.0, 1.0, 0.0],
            fov: 30.0,
        })
        .unwrap();
        vl.ambient(1.0, 1.0, 1.0, 0.2).unwrap();
        vl.directional_light([0.3, -0.4, 1.0], [1.0; 3], 1.0)
            .unwrap();
        vl.object().unwrap();
        // A ball: F falls from 1 at the centre.
        vl.function(Fields::F, |s| {
            let p = s.position();
            let r2: f32 = p.iter().map(|x| (x - 0.5) * (x - 0.5)).sum();
            let f = 1.0 - 4.0 * r2;
            s.set(Fields::F, f).unwrap();
        })
        .unwrap();
        vl.set(Fields::O, 0.5).unwrap();
        vl.set(Fields::COLORS | Fields::KD | Fields::KA, 1.0)
            .unwrap();
        vl.normal(move |n, _| *n = [bad, 0.0, 1.0]).unwrap();
        let (c, z, h) = (calls.clone(), zero.clone(), hostile.clone());
        vl.normal(move |n, _| {
            c.fetch_add(1, Ordering::Relaxed);
            if !n.iter().all(|x| x.is_finite()) {
                h.fetch_add(1, Ordering::Relaxed);
            }
            if *n == [0.0; 3] {
                z.fetch_add(1, Ordering::Relaxed);
            }
        })
        .unwrap();
        vl.end().unwrap();
        let image = vl.render_preview(16, 16, 1.0).unwrap();
        assert!(image.pixels.iter().flatten().all(|v| v.is_finite()));
        let calls = calls.load(Ordering::Relaxed);
        assert!(calls > 100, "{bad}: {calls} calls");
        assert_eq!(hostile.load(Ordering::Relaxed), 0, "{bad}");
        if bad.is_finite() {
            // (0, 0, 1) passed on as it is.
            assert_eq!(zero.load(Ordering::Relaxed), 0, "{bad}");
        } else {
            assert_eq!(zero.load(Ordering::Relaxed), calls, "{bad}");
        }
    }
}
