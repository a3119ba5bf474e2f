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
