//! Small numeric helpers of the base layer: rounding to integers without a library call, and
//! the clamp of a value written to a field (scalar and in lanes). Owns no state and knows no
//! scene types.
//!
//! On the x86-64 baseline (SSE2) `f64::floor` and `f64::ceil` are calls into libm; the block
//! walk rounds several times per leap, and noise three times per octave, so they use these
//! inline forms instead. They return exactly what `floor` and `ceil` return, bit for bit, for
//! every input (zeros keep their sign; ±∞ and NaN are returned as they are).

/// 2⁵²: every f64 of at least this magnitude is an integer.
const INTEGRAL: f64 = 4_503_599_627_370_496.0;

/// The largest integer not above `x`.
#[inline]
pub(crate) fn floor(x: f64) -> f64 {
    if x.is_nan() || x == 0.0 || x.abs() >= INTEGRAL {
        return x; // NaN, ±0, ±∞ or an integer already
    }
    // Truncation towards 0, exact below 2⁵² (a zero here is +0, the floor of 0 < x < 1).
    let t = x as i64 as f64;
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

/// Clamps a value written to a field: into [0, 1], NaN to 0.
#[inline]
pub(crate) fn clamp_field(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

/// [`clamp_field`] in lanes, bit for bit: a lane not at least 0 (below it, or NaN) becomes
/// +0 and the rest the lesser of it and 1 (−0 stays −0, as `f32::clamp` leaves it). Four
/// vector operations instead of a NaN test and two comparisons per value.
#[inline]
pub(crate) fn clamp_fields(v: wide::f32x4) -> wide::f32x4 {
    use wide::f32x4;
    (v.simd_ge(f32x4::ZERO) & v).fast_min(f32x4::ONE)
}

#[cfg(test)]
mod tests;
