//! An effect a scene switches on but cannot show costs nothing: a light of no radiance sends no
//! shadow rays and leaves the image as without it, a mirror of ks 0 and a glass of index 1 (RF
//! 0) trace no secondary rays, and an opaque surface ends the search along its ray (what lies
//! behind it cannot show). The work is counted in calls of a field function, which do not
//! depend on the clock; each scene's image is compared with the scene without the effect, byte
//! for byte.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use vlib::{Attenuation, Camera, Feature, Fields, Library, RenderType};

/// A field function's calls, counted.
fn counter() -> (Arc<AtomicUsize>, impl Fn() -> usize) {
    let calls = Arc::new(AtomicUsize::new(0));
    let read = {
        let calls = calls.clone();
        move || calls.load(Ordering::Relaxed)
    };
    (calls, read)
}

fn camera(vl: &mut Library) {
    vl.camera(&Camera {
        eye: [0.0, 0.0, -300.0],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov: 30.0,
    })
    .unwrap();
}

/// Adds a smooth ball of medium of diameter 100 at the origin, opacity rising towards its
/// centre, from a field function that counts its calls in `calls`; step 2.
fn ball(vl: &mut Library, calls: Arc<AtomicUsize>) {
    vl.step_size(2.0, 1.0).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(100.0, 100.0, 100.0).unwrap();
    vl.function(Fields::F | Fields::O, move |s| {
        calls.fetch_add(1, Ordering::Relaxed);
        let p = s.position();
        let r2 = p.iter().map(|&c| (c - 0.5) * (c - 0.5)).sum::<f32>();
        let f = (1.0 - 4.0 * r2).max(0.0);
        let _ = s.set(Fields::F, f);
        let _ = s.set(Fields::O, 0.05 * f);
    })
    .unwrap();
    vl.set(Fields::R | Fields::G, 0.8).unwrap();
    vl.set(Fields::B, 0.4).unwrap();
    vl.set(Fields::KA | Fields::KD, 0.7).unwrap();
    vl.end().unwrap();
}

/// The [`ball`] (casting and receiving shadows), lit by the `lights` given as (position,
/// colour, intensity) and an ambient light; its image at 32² and the field function's calls.
fn lit_ball(lights: &[([f32; 3], [f32; 3], f32)], shadows: bool) -> (Vec<u8>, usize) {
    let (calls, read) = counter();
    let mut vl = Library::new();
    vl.scene().unwrap();
    camera(&mut vl);
    vl.ambient(1.0, 1.0, 1.0, 0.3).unwrap();
    for &(at, rgb, i) in lights {
        vl.point_light(at, Attenuation::None, rgb, i).unwrap();
    }
    vl.toggle(Feature::CastShadows, shadows).unwrap();
    vl.toggle(Feature::ReceiveShadows, shadows).unwrap();
    ball(&mut vl, calls);
    let plan = vl.render_plan().unwrap();
    let image = vl.render_preview(32, 32, 1.0).unwrap().to_rgb8();
    assert_eq!(
        plan.shadows,
        shadows && lights.iter().any(|l| l.1 != [0.0; 3] && l.2 != 0.0),
        "the plan's shadows for lights {lights:?}"
    );
    (image, read())
}

#[test]
fn a_light_of_no_radiance_costs_nothing() {
    const BRIGHT: ([f32; 3], [f32; 3], f32) = ([-200.0, 250.0, -200.0], [1.0; 3], 0.9);
    const DARK: ([f32; 3], [f32; 3], f32) = ([150.0, 0.0, -100.0], [1.0; 3], 0.0);
    const BLACK: ([f32; 3], [f32; 3], f32) = ([150.0, 0.0, -100.0], [0.0; 3], 1.0);
    // With shadows, the only light dark: no shadow rays (the calls of the scene without
    // shadows), and the image of the scene without the light.
    let (none, none_calls) = lit_ball(&[], true);
    for dark in [DARK, BLACK] {
        let (image, calls) = lit_ball(&[dark], true);
        assert_eq!(calls, none_calls, "{dark:?}: shadow rays were traced");
        assert!(image == none, "{dark:?}: the image is not the unlit one");
    }
    // Beside a bright light: the image and the work of the bright light alone.
    let (bright, bright_calls) = lit_ball(&[BRIGHT], true);
    let (both, both_calls) = lit_ball(&[BRIGHT, DARK], true);
    assert!(both == bright, "a dark second light changed the image");
    assert_eq!(both_calls, bright_calls);
    // The bright light's shadow rays do call the function (the count can tell).
    let (_, unshadowed_calls) = lit_ball(&[BRIGHT], false);
    assert!(
        bright_calls > 2 * unshadowed_calls,
        "{bright_calls} calls with shadows, {unshadowed_calls} without"
    );
}

/// A DSR sphere of radius 40 (F = 1 − 2|p − c| in its box, surface F = 0.5, the box clipped
/// close round it) from a counted field function, with opacity `o`, toggles `toggles`, ks and RF as given (None: never
/// written), in front of a checked wall; its image at 48² and the calls.
fn sphere(o: f32, toggles: &[Feature], ks: Option<f32>, rf: Option<f32>) -> (Vec<u8>, usize) {
    let (calls, read) = counter();
    let mut vl = Library::new();
    vl.scene().unwrap();
    camera(&mut vl);
    vl.ambient(1.0, 1.0, 1.0, 0.4).unwrap();
    vl.point_light([-200.0, 250.0, -300.0], Attenuation::None, [1.0; 3], 0.8)
        .unwrap();
    vl.recursion(3).unwrap();
    vl.step_size(1.0, 1.0).unwrap();
    vl.render_type(RenderType::Dsr).unwrap();
    vl.surface(Fields::F, 0.5).unwrap();
    // The wall, which mirror and refracted rays would see.
    vl.toggle(Feature::CastReflections, true).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, 0.0).unwrap();
    vl.scale(300.0, 300.0, 10.0).unwrap();
    vl.translate(0.0, 0.0, 80.0).unwrap();
    vl.function(Fields::F | Fields::COLORS, |s| {
        let w = s.world_position();
        let check = ((w[0] / 20.0).floor() + (w[1] / 20.0).floor()).rem_euclid(2.0);
        let _ = s.set(Fields::F, 1.0);
        let _ = s.set(Fields::COLORS, 0.2 + 0.6 * check);
    })
    .unwrap();
    vl.set(Fields::O | Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    for &t in toggles {
        vl.toggle(t, true).unwrap();
    }
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(160.0, 160.0, 160.0).unwrap();
    // The box close round the sphere (±44 about its centre), so that most rays through the
    // box meet the sphere.
    vl.boundary(0.55, 0.55, 0.55).unwrap();
    vl.function(Fields::F, move |s| {
        calls.fetch_add(1, Ordering::Relaxed);
        let p = s.position();
        let r = p.iter().map(|&c| (c - 0.5) * (c - 0.5)).sum::<f32>().sqrt();
        let _ = s.set(Fields::F, 1.0 - 2.0 * r);
    })
    .unwrap();
    vl.set(Fields::O, o).unwrap();
    vl.set(Fields::R | Fields::G | Fields::B, 0.7).unwrap();
    vl.set(Fields::KA | Fields::KD, 0.6).unwrap();
    if let Some(ks) = ks {
        vl.set(Fields::KS, ks).unwrap();
    }
    if let Some(rf) = rf {
        vl.set(Fields::RF, rf).unwrap();
    }
    vl.end().unwrap();
    let plan = vl.render_plan().unwrap();
    let mirrors = toggles.contains(&Feature::ReceiveReflections) && ks.is_some_and(|k| k != 0.0);
    let glass = toggles.contains(&Feature::Refract) && rf.is_some_and(|r| r != 0.0);
    assert_eq!(
        (plan.reflections, plan.refraction),
        (mirrors, glass),
        "the plan for {toggles:?}, ks {ks:?}, rf {rf:?}"
    );
    let image = vl.render_preview(48, 48, 1.0).unwrap().to_rgb8();
    (image, read())
}

#[test]
fn a_mirror_of_no_ks_and_a_glass_of_index_one_cost_nothing() {
    let (plain, plain_calls) = sphere(0.6, &[], None, None);
    let cases: [(&[Feature], Option<f32>, Option<f32>); 4] = [
        (&[Feature::ReceiveReflections], None, None),
        (&[Feature::ReceiveReflections], Some(0.0), None),
        (&[Feature::Refract], None, None),
        (&[Feature::Refract], None, Some(0.0)),
    ];
    for (toggles, ks, rf) in cases {
        let (image, calls) = sphere(0.6, toggles, ks, rf);
        assert!(
            image == plain,
            "{toggles:?}, ks {ks:?}, rf {rf:?}: another image"
        );
        assert_eq!(calls, plain_calls, "{toggles:?}, ks {ks:?}, rf {rf:?}");
    }
    // A mirror and a glass that do show something trace their rays (and change the image).
    for (toggles, ks, rf) in [
        (&[Feature::ReceiveReflections][..], Some(0.5), None),
        (&[Feature::Refract][..], None, Some(0.25)),
    ] {
        let (image, calls) = sphere(0.6, toggles, ks, rf);
        assert!(image != plain, "{toggles:?}: the same image");
        assert!(calls > plain_calls, "{toggles:?}: {calls} calls");
    }
}

/// Behind an opaque surface nothing shows, so the search along the ray ends at it: the opaque
/// sphere's rays stop at its front, where a sphere of opacity just below 1 is searched through
/// to its back (which its rays reach, faintly). Both images differ only where the back shows
/// through, by less than a level.
#[test]
fn an_opaque_surface_ends_the_search_behind_it() {
    let (opaque, opaque_calls) = sphere(1.0, &[], None, None);
    let (almost, almost_calls) = sphere(0.999, &[], None, None);
    // A ray through the sphere meets its surface twice; the search to the front surface
    // covers about half the samples of the whole chord (the front cap is shallow), and a ray
    // through the box's corners misses the sphere either way: under two thirds of the calls.
    assert!(
        3 * opaque_calls < 2 * almost_calls,
        "{opaque_calls} calls for the opaque sphere, {almost_calls} for the translucent one"
    );
    let largest = opaque
        .iter()
        .zip(&almost)
        .map(|(&a, &b)| (a as i32 - b as i32).abs())
        .max()
        .unwrap();
    assert!(largest <= 1, "the images differ by {largest} levels");
}

/// The [`ball`] (one bright light, no shadows) beside a second object no ray can
/// see anything of, made so by `hide` (called before its `object` and inside it); its image at
/// 32², the ball's calls and the second object's (a counted function giving its F, searched
/// for a surface at 0.5).
type Hide = (fn(&mut Library), fn(&mut Library));
fn ball_beside(hide: Option<Hide>) -> (Vec<u8>, usize, usize) {
    let (calls, read) = counter();
    let (other_calls, read_other) = counter();
    let mut vl = Library::new();
    vl.scene().unwrap();
    camera(&mut vl);
    vl.ambient(1.0, 1.0, 1.0, 0.3).unwrap();
    vl.point_light([-200.0, 250.0, -200.0], Attenuation::None, [1.0; 3], 0.9)
        .unwrap();
    ball(&mut vl, calls);
    if let Some((before, inside)) = hide {
        vl.render_type(RenderType::Dsr).unwrap();
        vl.surface(Fields::F, 0.5).unwrap();
        before(&mut vl);
        vl.object().unwrap();
        vl.translate(-0.5, -0.5, -0.5).unwrap();
        vl.scale(60.0, 60.0, 60.0).unwrap();
        vl.translate(30.0, 10.0, -20.0).unwrap();
        vl.function(Fields::F, move |s| {
            other_calls.fetch_add(1, Ordering::Relaxed);
            let x = s.position()[0];
            let _ = s.set(Fields::F, x);
        })
        .unwrap();
        vl.set(Fields::R | Fields::KA, 0.6).unwrap();
        inside(&mut vl);
        vl.end().unwrap();
    }
    let image = vl.render_preview(32, 32, 1.0).unwrap().to_rgb8();
    (image, read(), read_other())
}

/// An object of opacity 0 everywhere (never written, or set to 0) and an invisible one that
/// casts nothing are left out of what rays meet: the image and the ball's work are those of the
/// ball alone, and the hidden object's function never runs.
#[test]
fn an_object_that_shows_nothing_costs_nothing() {
    let (alone, alone_calls, _) = ball_beside(None);
    let hides: [(&str, Hide); 3] = [
        ("opacity never written", (|_| {}, |_| {})),
        ("opacity 0", (|_| {}, |vl| vl.set(Fields::O, 0.0).unwrap())),
        (
            "invisible, casting nothing",
            (
                |vl| vl.toggle(Feature::Visible, false).unwrap(),
                |vl| vl.set(Fields::O, 1.0).unwrap(),
            ),
        ),
    ];
    for (how, hide) in hides {
        let (image, calls, other) = ball_beside(Some(hide));
        assert!(image == alone, "{how}: another image");
        assert_eq!(calls, alone_calls, "{how}");
        assert_eq!(other, 0, "{how}: the hidden object's function ran");
    }
    // Shown (opacity 1), it is searched and seen.
    let (image, _, other) = ball_beside(Some((|_| {}, |vl| vl.set(Fields::O, 1.0).unwrap())));
    assert!(image != alone && other > 0);
}

/// A voxelization still sees an object no ray can see anything of: where it alone holds a node,
/// the node takes its fields (opacity 0, its red 0.6), and where the ball holds one too, the
/// ball's (the greater opacity).
#[test]
fn voxelization_keeps_an_object_that_shows_nothing() {
    let dir = std::env::temp_dir().join(format!("vlib-inert-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let prefix = dir.join("v");
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(20.0, 20.0, 20.0).unwrap();
    vl.set(Fields::O, 0.5).unwrap();
    vl.set(Fields::R, 0.2).unwrap();
    vl.end().unwrap();
    // Opacity 0 (never written): hidden from rays; it spans x from −30 to 30.
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(60.0, 20.0, 20.0).unwrap();
    vl.set(Fields::R, 0.6).unwrap();
    vl.end().unwrap();
    // Nodes at x = −25, −15, −5, 5, 15, 25 on the axis.
    vl.volume(
        &prefix,
        Fields::R,
        [-25.0, 0.0, 0.0],
        [25.0, 0.0, 0.0],
        [6, 1, 1],
        1,
    )
    .unwrap();
    vl.end().unwrap();
    let bytes = std::fs::read(dir.join("v_r.vlb")).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    // Header of 28 bytes, then one byte a node: round(255 · r).
    assert_eq!(&bytes[28..], &[153, 153, 51, 51, 153, 153]);
}
