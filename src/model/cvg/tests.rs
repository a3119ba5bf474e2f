//! Unit tests of `cvg`.

use super::*;

fn obj(o: f32, r: f32) -> [f32; FIELD_COUNT] {
    let mut f = [0.0; FIELD_COUNT];
    f[0] = o;
    f[1] = r;
    f
}

#[test]
fn operators_follow_their_definitions() {
    let a = obj(0.3, 0.9);
    let b = obj(0.6, 0.2);
    assert_eq!(combine(Operator::Union, &[a, b]), b);
    assert_eq!(combine(Operator::Intersection, &[a, b]), a);
    let d = combine(Operator::Difference, &[b, a]);
    assert_eq!(d[0], 0.6f32.min(1.0 - 0.3));
    assert_eq!(d[1], 0.2);
    let m = combine(Operator::Blend, &[a, b]);
    assert!((m[0] - (1.0 - 0.7 * 0.4)).abs() < 1e-6);
    assert!((m[1] - (0.3 * 0.9 + 0.6 * 0.2) / 0.9).abs() < 1e-6);
    // Ties keep the first; nothing in, nothing out; transparent blends have no colour.
    assert_eq!(
        combine(Operator::Union, &[obj(0.5, 0.1), obj(0.5, 0.7)])[1],
        0.1
    );
    assert_eq!(combine(Operator::Union, &[]), [0.0; FIELD_COUNT]);
    assert_eq!(
        combine(Operator::Blend, &[obj(0.0, 1.0)]),
        [0.0; FIELD_COUNT]
    );
}
