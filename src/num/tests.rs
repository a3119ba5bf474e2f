//! Unit tests of `num`.

use super::*;

/// Against the library functions, bit for bit, on integers, halves, values next to
/// integers, zeros of both signs, huge and special values.
#[test]
fn floor_and_ceil_match_the_library() {
    let mut xs = vec![
        0.0,
        -0.0,
        0.5,
        -0.5,
        1.0,
        -1.0,
        2.5,
        -2.5,
        1e-300,
        -1e-300,
        INTEGRAL,
        -INTEGRAL,
        INTEGRAL - 0.5,
        -(INTEGRAL - 0.5),
        1e300,
        -1e300,
        f64::MAX,
        f64::MIN,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for i in -2000..2000 {
        let x = i as f64 * 0.37;
        xs.extend([x, x.next_up(), x.next_down()]);
    }
    for x in xs {
        assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "floor({x:e})");
        assert_eq!(ceil(x).to_bits(), x.ceil().to_bits(), "ceil({x:e})");
    }
    assert!(floor(f64::NAN).is_nan() && ceil(f64::NAN).is_nan());
}
