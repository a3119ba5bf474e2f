//! The render plan: an effect that nothing in a scene can exhibit costs nothing, and what each
//! effect costs when it is used. One scene — a DSR sphere with a smooth field over a DVR floor,
//! one point light — rendered with each feature switched on in a way the scene cannot show
//! (the time must match the baseline within noise, < 2 %), with something added that shows
//! nothing (a second light of intensity 0, refraction of index 1, a clear object), and with
//! each feature in a way it can.
//!
//! ```text
//! cargo bench --bench plan
//! ```

use criterion::{criterion_group, criterion_main, Criterion};
use std::time::Duration;
use vlib::{Attenuation, Camera, Feature, Fields, Library, RenderType};

/// Which features the objects get: (sphere toggles, floor toggles).
type Toggles = (&'static [Feature], &'static [Feature]);

/// What is added to the scene that shows nothing.
#[derive(Clone, Copy, PartialEq)]
enum Extra {
    Nothing,
    /// A second point light, of intensity 0.
    DarkLight,
    /// The sphere refracts, with RF 0 (index 1).
    IndexOne,
    /// A third object, of opacity 0, across the view.
    ClearObject,
}

fn scene(toggles: Toggles, extra: Extra) -> Library {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [0.0, 60.0, -220.0],
        at: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov: 40.0,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 0.2).unwrap();
    vl.background(0.1, 0.1, 0.15).unwrap();
    vl.point_light([-150.0, 250.0, -150.0], Attenuation::None, [1.0; 3], 1.0)
        .unwrap();
    if extra == Extra::DarkLight {
        vl.point_light([150.0, 100.0, -150.0], Attenuation::None, [1.0; 3], 0.0)
            .unwrap();
    }
    vl.step_size(1.0, 1.0).unwrap();
    let set = |vl: &mut Library, on: &[Feature]| {
        for f in [
            Feature::CastShadows,
            Feature::ReceiveShadows,
            Feature::CastReflections,
            Feature::ReceiveReflections,
            Feature::Refract,
        ] {
            vl.toggle(f, on.contains(&f)).unwrap();
        }
    };
    // The sphere: DSR on a smooth radial field, a little glassy.
    set(&mut vl, toggles.0);
    if extra == Extra::IndexOne {
        vl.toggle(Feature::Refract, true).unwrap();
    }
    vl.render_type(RenderType::Dsr).unwrap();
    vl.surface(Fields::F, 0.5).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(120.0, 120.0, 120.0).unwrap();
    vl.translate(0.0, 40.0, 0.0).unwrap();
    vl.function(Fields::F, |s| {
        let v = vlib::vlaux::sphere(s.position());
        let _ = s.set(Fields::F, v);
    })
    .unwrap();
    vl.set(Fields::O, 0.6).unwrap();
    vl.set(Fields::R | Fields::KD, 0.7).unwrap();
    vl.set(Fields::G | Fields::B, 0.3).unwrap();
    vl.set(Fields::KA | Fields::KS, 0.4).unwrap();
    vl.set(Fields::N, vlib::types::specular_to_field(30.0))
        .unwrap();
    let index = if extra == Extra::IndexOne { 1.0 } else { 1.4 };
    vl.set(Fields::RF, vlib::types::refraction_to_field(index))
        .unwrap();
    vl.end().unwrap();
    // The floor: a DVR slab with a checker colour.
    set(&mut vl, toggles.1);
    vl.render_type(RenderType::Dvr).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -1.0, -0.5).unwrap();
    vl.scale(400.0, 6.0, 400.0).unwrap();
    vl.translate(0.0, -20.0, 0.0).unwrap();
    vl.function(Fields::COLORS, |s| {
        let p = s.position();
        let c = ((p[0] * 8.0).floor() + (p[2] * 8.0).floor()) as i32 & 1;
        let _ = s.set(Fields::COLORS, if c == 0 { 0.9 } else { 0.2 });
    })
    .unwrap();
    vl.set(Fields::O | Fields::F, 1.0).unwrap();
    vl.set(Fields::KA | Fields::KD, 0.8).unwrap();
    vl.end().unwrap();
    if extra == Extra::ClearObject {
        vl.object().unwrap();
        vl.translate(-0.5, -0.5, -0.5).unwrap();
        vl.scale(300.0, 200.0, 100.0).unwrap();
        vl.set(Fields::R | Fields::KA, 1.0).unwrap();
        vl.end().unwrap();
    }
    vl
}

fn bench(c: &mut Criterion) {
    use Extra::*;
    use Feature::*;
    let none: Toggles = (&[], &[]);
    let cases: [(&str, Toggles, Extra); 11] = [
        ("baseline", none, Nothing),
        // Features nothing can exhibit: casters without receivers, receivers without casters,
        // mirror casters without receivers.
        (
            "unused_cast_shadows",
            (&[CastShadows], &[CastShadows]),
            Nothing,
        ),
        (
            "unused_receive_shadows",
            (&[ReceiveShadows], &[ReceiveShadows]),
            Nothing,
        ),
        (
            "unused_cast_reflections",
            (&[CastReflections], &[CastReflections]),
            Nothing,
        ),
        // Something added that shows nothing (the same image as the baseline's: the rules
        // tests/inert_effects.rs checks; not rendered here, so that a filtered run's
        // instructions are its one case's).
        ("dark_light", none, DarkLight),
        ("index_one", none, IndexOne),
        ("clear_object", none, ClearObject),
        // Features in use.
        ("shadows", (&[CastShadows], &[ReceiveShadows]), Nothing),
        (
            "reflections",
            (&[ReceiveReflections], &[CastReflections]),
            Nothing,
        ),
        ("refraction", (&[Refract], &[]), Nothing),
        (
            "all",
            (
                &[CastShadows, ReceiveReflections, Refract],
                &[ReceiveShadows, CastReflections],
            ),
            Nothing,
        ),
    ];
    let mut g = c.benchmark_group("plan_320x240");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    for (name, toggles, extra) in cases {
        let vl = scene(toggles, extra);
        println!("{name}: plan {:?}", vl.render_plan().unwrap());
        g.bench_function(name, |b| {
            b.iter(|| vl.render_preview(320, 240, 320.0 / 240.0).unwrap())
        });
    }
    g.finish();
}

/// Writes the images of the cases that use features (for a look): `VLIB_PLAN_IMAGES=dir`.
fn images() {
    use Feature::*;
    let Some(dir) = std::env::var_os("VLIB_PLAN_IMAGES") else {
        return;
    };
    let all: Toggles = (
        &[CastShadows, ReceiveReflections, Refract],
        &[ReceiveShadows, CastReflections],
    );
    for (name, t) in [("baseline", (&[][..], &[][..])), ("all", all)] {
        let img = scene(t, Extra::Nothing)
            .render_preview(320, 240, 320.0 / 240.0)
            .unwrap();
        let path = std::path::Path::new(&dir).join(format!("plan_{name}.png"));
        vlib::write_image(&path, 320, 240, &img.to_rgb8()).unwrap();
    }
}

fn bench_all(c: &mut Criterion) {
    images();
    bench(c);
}

criterion_group!(benches, bench_all);
criterion_main!(benches);
