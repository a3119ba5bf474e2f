//! Unit tests of `scene`: the default sampling step, and which cameras are refused (only those
//! whose eye and look-at point coincide).

use super::*;

#[test]
fn the_default_step_is_a_256th_of_the_diagonal_at_most_one_unit() {
    let auto = RenderState::default();
    // √3 (the unit cube) / 256.
    let d = 3f64.sqrt();
    assert_eq!(auto.step_for(d), d / 256.0);
    // 256 units and more: the legacy step of 1.
    assert_eq!(auto.step_for(256.0), 1.0);
    assert_eq!(auto.step_for(548.0), 1.0);
    // Degenerate boxes take the legacy step rather than 0 or NaN.
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(auto.step_for(bad), 1.0, "diagonal {bad}");
    }
    // A step that was set is kept, whatever the object's size.
    let set = RenderState {
        step: Some(0.25),
        ..RenderState::default()
    };
    assert_eq!(set.step_for(d), 0.25);
    assert_eq!(set.step_for(1e6), 0.25);
}

/// The eye and the look-at point are refused only where they are equal: distinct points at any
/// scale give a view (a camera 10⁻³⁰ from its look-at point looks at it, as one at 10³⁰ does).
#[test]
fn cameras_are_refused_only_where_eye_and_look_at_point_coincide() {
    let camera = |eye: [f32; 3], at: [f32; 3]| Camera {
        eye,
        at,
        up: [0.0, 1.0, 0.0],
        fov: 40.0,
    };
    for s in [1e-45f32, 1e-38, 1e-30, 1e-16, 1.0, 1e30, f32::MAX / 4.0] {
        assert!(
            camera([0.0, 0.0, -2.0 * s], [0.0; 3]).validate().is_ok(),
            "{s:e}"
        );
        let c = camera([0.0, 0.0, -2.0 * s], [0.0; 3]);
        let (_, _, forward) = c.basis();
        assert!((forward - DVec3::Z).length() < 1e-12, "{s:e}: {forward}");
    }
    for p in [[0.0; 3], [1e-30, 0.0, 0.0], [3e38, -3e38, 1.0]] {
        let e = camera(p, p).validate().unwrap_err();
        assert_eq!(e.code, ErrorCode::BadValue);
    }
    // One f32 step apart far from the origin: a view.
    let x = 1e30f32;
    let next = f32::from_bits(x.to_bits() + 1);
    assert!(camera([x, 0.0, 0.0], [next, 0.0, 0.0]).validate().is_ok());
}
