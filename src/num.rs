//! Rounding to integers without a library call.
//!
//! On the x86-64 baseline (SSE2) `f64::floor` and `f64::ceil` are calls into libm; the block
//! walk rounds several times per leap, so it uses these inline forms instead. They return
//! exactly what `floor` and `ceil` return for every finite input and for ±∞ and NaN, except
//! perhaps the sign of a zero result (callers convert to integers, where it does not matter).

/// 2⁵²: every f64 of at least this magnitude is an integer.
const INTEGRAL: f64 = 4_503_599_627_370_496.0;

/// The largest integer not above `x`.
#[inline]
pub(crate) fn floor(x: f64) -> f64 {
    if x.is_nan() || x.abs() >= INTEGRAL {
        return x; // NaN, ±∞ or an integer already
    }
    let t = x as i64 as f64; // truncation towards 0, exact below 2⁵²
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// The smallest integer not below `x`.
#[inline]
pub(crate) fn ceil(x: f64) -> f64 {
    -floor(-x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the library functions on integers, halves, values next to integers, huge and
    /// special values (zeros compared by value, as documented).
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
            assert_eq!(floor(x), x.floor(), "floor({x:e})");
            assert_eq!(ceil(x), x.ceil(), "ceil({x:e})");
        }
        assert!(floor(f64::NAN).is_nan() && ceil(f64::NAN).is_nan());
    }
}
