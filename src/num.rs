//! Small numeric helpers of the base layer: rounding to integers without a library call, the
//! clamp of a value written to a field (scalar and in lanes), and the fallible allocation of
//! buffers whose size a user chose ([`try_vec`]). Owns no state and knows no scene types.
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

/// The error of an allocation of `bytes` bytes that failed (or whose size overflows): `what`
/// names the buffer.
pub(crate) fn no_memory(what: &str, bytes: Option<usize>) -> crate::error::Error {
    let size = match bytes {
        Some(b) => format!("{b} bytes"),
        None => "more bytes than an address space holds".to_string(),
    };
    crate::error::Error::new(
        crate::error::ErrorCode::NoMemory,
        format!("{what}: {size} could not be allocated"),
    )
}

/// An empty vector with room for exactly `len` elements, or `NoMemory` where they cannot be
/// allocated (instead of the abort of `Vec::with_capacity`): for every buffer whose size
/// grows with what a user asked for (a dataset's voxels, a voxelization's slabs).
pub(crate) fn try_with_capacity<T>(len: usize, what: &str) -> crate::error::Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(len)
        .map_err(|_| no_memory(what, len.checked_mul(std::mem::size_of::<T>())))?;
    Ok(v)
}

/// Elements from which [`try_vec`] fills its vector in parallel.
pub(crate) const PARALLEL_FILL: usize = 1 << 16;

/// `vec![value; len]`, or `NoMemory` where it cannot be allocated ([`try_with_capacity`]).
/// A long vector is filled in parallel on the library's pool (`pool::install`; never rayon's
/// global pool, whose threads a forked child would wait on): its first touch of fresh pages,
/// about 2 µs a page on the VMs measured, is most of a large buffer's cost. Where the pool's
/// threads cannot be started, `NoMemory` too.
pub(crate) fn try_vec<T: Clone + Send + Sync>(
    len: usize,
    value: T,
    what: &str,
) -> crate::error::Result<Vec<T>> {
    let mut v = try_with_capacity(len, what)?;
    if len >= PARALLEL_FILL {
        use rayon::prelude::*;
        // Into the room reserved above: no reallocation.
        crate::pool::install(|| {
            v.par_extend(rayon::iter::repeat_n(value, len));
            Ok(())
        })?;
    } else {
        v.resize(len, value);
    }
    Ok(v)
}

#[cfg(test)]
mod tests;
