//! The entry map's rasterisation: lowering a rectangle of a row-major `f64` map to a value,
//! in AVX-512 lanes where the processor has them. Owns that one operation; the entry map itself
//! (which rectangles, which values) lives in the parent module.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// `rows[y·w + x] = min(rows[y·w + x], v)` over the rectangle `xs` × `ys` (neither side NaN),
/// in SIMD lanes where the processor has them (the entry map's rasterisation).
pub(crate) fn lower_rect(
    rows: &mut [f64],
    w: usize,
    xs: std::ops::RangeInclusive<usize>,
    ys: std::ops::RangeInclusive<usize>,
    v: f64,
) {
    #[cfg(target_arch = "x86_64")]
    if lower_rect_wide(rows, w, &xs, &ys, v) {
        return;
    }
    for y in ys {
        for b in &mut rows[y * w + *xs.start()..=y * w + *xs.end()] {
            *b = if v < *b { v } else { *b };
        }
    }
}

#[cfg(target_arch = "x86_64")]
/// `rows[y·w + x] = min(rows[y·w + x], v)` for x in `xs` and y in `ys` (neither side NaN: the
/// compare-and-select of `f64::min` without its NaN cases; every index inside `rows`), in
/// AVX-512 lanes where the processor has them, eight to a register, a row's last ones by a
/// masked load and store: the entry map's rasterisation ([`super::EntryMap`]), whose
/// rectangles (about 160 pixels each, 8.3 times the image in all in the MNI frame) left the
/// compiler's loop mostly in its scalar remainders. The same numbers in any lanes (a minimum
/// is exact). False, doing nothing, without AVX-512 ([`lower_rect`] then loops).
pub(crate) fn lower_rect_wide(
    rows: &mut [f64],
    w: usize,
    xs: &std::ops::RangeInclusive<usize>,
    ys: &std::ops::RangeInclusive<usize>,
    v: f64,
) -> bool {
    let (x0, x1) = (*xs.start(), *xs.end());
    /// The rectangle in AVX-512 lanes.
    #[target_feature(enable = "avx512f")]
    fn wide(
        rows: &mut [f64],
        w: usize,
        (x0, x1): (usize, usize),
        ys: std::ops::RangeInclusive<usize>,
        v: f64,
    ) {
        let vv = _mm512_set1_pd(v);
        for y in ys {
            let row = &mut rows[y * w + x0..=y * w + x1];
            let mut chunks = row.chunks_exact_mut(8);
            for c in &mut chunks {
                let c: &mut [f64; 8] = c.try_into().expect("eight");
                // SAFETY: `c` is 8 f64, 64 readable and writable bytes; no alignment needed.
                unsafe {
                    let b = _mm512_loadu_pd(c.as_ptr());
                    let m = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(vv, b);
                    _mm512_mask_storeu_pd(c.as_mut_ptr(), m, vv);
                }
            }
            let rest = chunks.into_remainder();
            if !rest.is_empty() {
                let k = (1u8 << rest.len()).wrapping_sub(1);
                // SAFETY: the masked load and store touch only the first `rest.len()` f64
                // (masked-off lanes are neither read nor written, and do not fault).
                unsafe {
                    let b = _mm512_maskz_loadu_pd(k, rest.as_ptr());
                    let m = k & _mm512_cmp_pd_mask::<_CMP_LT_OQ>(vv, b);
                    _mm512_mask_storeu_pd(rest.as_mut_ptr(), m, vv);
                }
            }
        }
    }
    if !is_x86_feature_detected!("avx512f") {
        return false;
    }
    // SAFETY: AVX-512F was detected.
    unsafe { wide(rows, w, (x0, x1), ys.clone(), v) };
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `lower_rect` (in AVX-512 lanes where the processor has them: `lower_rect_wide`) is the
    /// plain minimum over its rectangle and leaves every other value alone: rectangles of
    /// every width from 1 to 40 (whole registers, remainders, both) at every third offset in
    /// a row, values above, below and equal to the map's, ±∞ and −0.
    #[test]
    fn lower_rect_is_the_plain_minimum() {
        let (w, h) = (53usize, 7usize);
        let rng = crate::testing::Xorshift::new(0x10e5_7ec7_0001);
        let next = || rng.next();
        for width in 1..=40usize {
            for x0 in (0..=w - width).step_by(3) {
                let init: Vec<f64> = (0..w * h)
                    .map(|i| match i % 11 {
                        0 => f64::INFINITY,
                        1 => -0.0,
                        _ => next() * 4.0 - 1.0,
                    })
                    .collect();
                let (y0, y1) = (x0 % h, (x0 % h + width % 4).min(h - 1));
                for v in [
                    next() * 4.0 - 1.0,
                    0.0,
                    f64::NEG_INFINITY,
                    init[y0 * w + x0],
                ] {
                    let mut got = init.clone();
                    lower_rect(&mut got, w, x0..=x0 + width - 1, y0..=y1, v);
                    for (i, (&g, &b)) in got.iter().zip(&init).enumerate() {
                        let (x, y) = (i % w, i / w);
                        let inside = (x0..x0 + width).contains(&x) && (y0..=y1).contains(&y);
                        let want = if inside && v < b { v } else { b };
                        assert_eq!(
                            g.to_bits(),
                            want.to_bits(),
                            "width {width} x0 {x0} at ({x}, {y})"
                        );
                    }
                }
            }
        }
    }
}
