//! The entry map's rasterisation: lowering a rectangle of a row-major `f64` map to a value,
//! in AVX-512 lanes where the processor has them. Owns that one operation; the entry map itself
//! (which rectangles, which values) lives in `entry`.

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
/// rectangles are rows of tens to hundreds of pixels, which a compiler-vectorised loop spends
/// mostly in its scalar remainders. The same numbers in any lanes (a minimum
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
