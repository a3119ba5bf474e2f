//! Rays started four pixels at a time in f64 lanes ([`Packets::make_starts`]): the scalar
//! march's direction, object-space direction, box clip, segment count and first segment past
//! the entry map's bound, lane for lane the same numbers, and the pixels whose ray takes no
//! sample. The same for both widths (AVX2 f64 lanes). Not here: the march of the started rays
//! ([`runs`], [`step`]).

use super::*;

impl Packets<'_> {
    /// The starts of the tile's next pixels, up to four of one row, into `q` (in pixel order),
    /// and the colours of those whose ray takes no sample into `out`: [`Compiled::trace_ray`]'s
    /// one-volume path up to its march, four rays in f64 lanes, each lane the scalar code's
    /// operations in its order, so the same numbers: the direction of `Pinhole::ray`, the
    /// object-space direction of `transform_vector3`, the span of [`CObj::clip`], the count of
    /// `Cursor::unstarted` and the first segment not before the entry bound of
    /// `Cursor::start_at` (by the estimate `Cursor::pass_before` starts from, where its
    /// neighbours show it final; the cursor's own search elsewhere)
    /// (`ray_start_lanes_are_the_scalar_starts`).
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn make_starts(&self, q: &mut Starts, tile: &TileRays<'_>, out: &mut [Pixel]) {
        let obj = self.obj;
        let (tw, _) = tile.size;
        let (row, col) = (q.next / tw, q.next % tw);
        let lanes = (tw - col).min(4) as usize;
        let first = q.next as usize;
        q.next += lanes as u32;
        q.len = 0;
        q.at = 0;
        let (x0, y) = (tile.origin.0 + col, tile.origin.1 + row);
        let bound: [f64; 4] = std::array::from_fn(|l| {
            let x = x0 + (l.min(lanes - 1)) as u32;
            tile.entry.map_or(f64::NEG_INFINITY, |e| e.bound(x, y))
        });
        // Pixels whose bound is +∞ where that is known to show a colour: no ray.
        if let Some(c) = tile.unbounded {
            if bound[..lanes].iter().all(|&b| b == f64::INFINITY) {
                out[first..first + lanes].fill(c);
                return;
            }
        }
        let (dir, d) = ray_lanes(tile.view, &obj.to_object, x0, y);
        let o = tile.image.origin_o;
        let (t0, t1, ok) = clip_lanes(o, &d, obj.box_min, obj.box_max);
        let n = count_lanes(t0, t1, obj.step);
        let from = _mm256_max_pd(ld4(&bound), t0);
        let k = first_segments(t0, t1, obj.step, n, from);
        let (dir, d, t0, t1, from) = (st4(dir), st4(d), st4d(t0), st4d(t1), st4d(from));
        let background = tile.image.background;
        let unsampled = DVec3::ZERO + 1.0 * background;
        let bits = |v: DVec3| v.to_array().map(f64::to_bits);
        for (l, &bound) in bound.iter().enumerate().take(lanes) {
            let px = first + l;
            if bound == f64::INFINITY {
                if let Some(c) = tile.unbounded {
                    out[px] = c;
                    continue;
                }
                if bits(unsampled) == bits(background) {
                    out[px] = pixel(unsampled, 1.0);
                    continue;
                }
            }
            if ok >> l & 1 == 0 {
                out[px] = pixel(background, 1.0);
                continue;
            }
            if bound >= t1[l] {
                out[px] = pixel(unsampled, 1.0);
                continue;
            }
            let n = if n[l] != 0 {
                n[l]
            } else {
                segment_count((t1[l] - t0[l]) / obj.step)
            };
            let k = match (self.grid, k[l]) {
                (None, _) => Start::At(0),
                (Some(_), Some(k)) => Start::At(k),
                (Some(_), None) => Start::Before(from[l]),
            };
            q.ready[q.len] = RayStart {
                px: px as u32,
                d: [d[0][l], d[1][l], d[2][l]],
                view: [-dir[0][l] as f32, -dir[1][l] as f32, -dir[2][l] as f32],
                t0: t0[l],
                t1: t1[l],
                n,
                k,
            };
            q.len += 1;
        }
    }
}

/// What a tile's rays share: the camera, the entry map, the image's rays, the colour of an
/// unbounded pixel, the tile's corner and size.
pub(super) struct TileRays<'a> {
    pub(super) view: &'a Pinhole,
    pub(super) entry: Option<&'a EntryMap>,
    pub(super) image: &'a ImageRays,
    pub(super) unbounded: Option<Pixel>,
    pub(super) origin: (u32, u32),
    pub(super) size: (u32, u32),
}

/// Where a started ray's cursor begins: at segment k, or at the first segment whose midpoint
/// is not before t (`Cursor::start_at`).
#[derive(Clone, Copy, Debug)]
pub(super) enum Start {
    At(u64),
    Before(f64),
}

/// A tile's ray that takes samples ([`Packets::make_starts`]): its pixel (in the tile), its
/// object-space direction, its view direction (towards the eye, as the lighting takes it),
/// its span [t0, t1] in the object's box, its segment count and its first segment.
#[derive(Clone, Copy, Debug)]
pub(super) struct RayStart {
    pub(super) px: u32,
    pub(super) d: [f64; 3],
    pub(super) view: [f32; 3],
    pub(super) t0: f64,
    pub(super) t1: f64,
    pub(super) n: u64,
    pub(super) k: Start,
}

/// The started rays of a tile's last four pixels not yet given a lane, and the next pixel.
pub(super) struct Starts {
    pub(super) ready: [RayStart; 4],
    pub(super) len: usize,
    pub(super) at: usize,
    pub(super) next: u32,
}

impl Default for Starts {
    fn default() -> Starts {
        let none = RayStart {
            px: 0,
            d: [0.0; 3],
            view: [0.0; 3],
            t0: 0.0,
            t1: 0.0,
            n: 0,
            k: Start::At(0),
        };
        Starts {
            ready: [none; 4],
            len: 0,
            at: 0,
            next: 0,
        }
    }
}

/// The unit directions of `Pinhole::ray` through the centres of pixels (x0 + l, y) for l in
/// 0..4, and their object-space directions by `to_object.transform_vector3`, in f64 lanes by
/// axis: each lane those functions' operations in their order, so the same numbers
/// (`ray_lanes_are_the_rays`).
#[inline]
#[target_feature(enable = "avx2")]
pub(in crate::render) fn ray_lanes(
    view: &Pinhole,
    to_object: &DMat4,
    x0: u32,
    y: u32,
) -> ([__m256d; 3], [__m256d; 3]) {
    let splat = _mm256_set1_pd;
    let x: [f64; 4] = std::array::from_fn(|l| (x0 + l as u32) as f64 + 0.5);
    let sy = 1.0 - (y as f64 + 0.5) / view.height as f64 * 2.0;
    let sx = _mm256_sub_pd(
        _mm256_mul_pd(_mm256_div_pd(ld4(&x), splat(view.width as f64)), splat(2.0)),
        splat(1.0),
    );
    // (forward + sx·right) + sy·up, then times 1/√(v·v). (Loops, not `from_fn` closures,
    // which the compiler may leave out of line.)
    let mut v = [sx; 3];
    for (c, v) in v.iter_mut().enumerate() {
        *v = _mm256_add_pd(
            _mm256_add_pd(
                splat(view.forward[c]),
                _mm256_mul_pd(sx, splat(view.right[c])),
            ),
            splat(sy * view.up[c]),
        );
    }
    let dot = _mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(v[0], v[0]), _mm256_mul_pd(v[1], v[1])),
        _mm256_mul_pd(v[2], v[2]),
    );
    let recip = _mm256_div_pd(splat(1.0), _mm256_sqrt_pd(dot));
    let dir = [
        _mm256_mul_pd(v[0], recip),
        _mm256_mul_pd(v[1], recip),
        _mm256_mul_pd(v[2], recip),
    ];
    // z·dz + (y·dy + x·dx).
    let m = to_object;
    let mut d = dir;
    for (c, d) in d.iter_mut().enumerate() {
        *d = _mm256_add_pd(
            _mm256_mul_pd(splat(m.z_axis[c]), dir[2]),
            _mm256_add_pd(
                _mm256_mul_pd(splat(m.y_axis[c]), dir[1]),
                _mm256_mul_pd(splat(m.x_axis[c]), dir[0]),
            ),
        );
    }
    (dir, d)
}

/// [`CObj::clip`] of four rays from `o` along the directions `d` (by axis) in lanes: their
/// spans [t0, t1] and, by bit, those that meet the box [min, max]. Each axis is [`slab`]'s
/// operations in its order (a zero direction part by its test of `o`, NaN face parameters by
/// its choice of the other), so the same numbers.
#[inline]
#[target_feature(enable = "avx2")]
pub(in crate::render) fn clip_lanes(
    o: DVec3,
    d: &[__m256d; 3],
    min: DVec3,
    max: DVec3,
) -> (__m256d, __m256d, u32) {
    let mut t0 = _mm256_setzero_pd();
    let mut t1 = _mm256_set1_pd(f64::INFINITY);
    let mut fail = _mm256_setzero_pd();
    for axis in 0..3 {
        let da = d[axis];
        let zero = _mm256_cmp_pd::<_CMP_EQ_OQ>(da, _mm256_setzero_pd());
        // (A NaN `o` is not outside.)
        if o[axis] < min[axis] || o[axis] > max[axis] {
            fail = _mm256_or_pd(fail, zero);
        }
        let inv = _mm256_div_pd(_mm256_set1_pd(1.0), da);
        let a = _mm256_mul_pd(_mm256_set1_pd(min[axis] - o[axis]), inv);
        let b = _mm256_mul_pd(_mm256_set1_pd(max[axis] - o[axis]), inv);
        let a_nan = _mm256_cmp_pd::<_CMP_UNORD_Q>(a, a);
        let b_nan = _mm256_cmp_pd::<_CMP_UNORD_Q>(b, b);
        let x = _mm256_blendv_pd(a, b, a_nan);
        let lo = _mm256_blendv_pd(a, b, _mm256_cmp_pd::<_CMP_LT_OQ>(b, a));
        let hi = _mm256_blendv_pd(a, b, _mm256_cmp_pd::<_CMP_GT_OQ>(b, a));
        let either = _mm256_or_pd(a_nan, b_nan);
        let (lo, hi) = (
            _mm256_blendv_pd(lo, x, either),
            _mm256_blendv_pd(hi, x, either),
        );
        let t0_new = _mm256_blendv_pd(t0, lo, _mm256_cmp_pd::<_CMP_GT_OQ>(lo, t0));
        let t1_new = _mm256_blendv_pd(t1, hi, _mm256_cmp_pd::<_CMP_LT_OQ>(hi, t1));
        t0 = _mm256_blendv_pd(t0_new, t0, zero);
        t1 = _mm256_blendv_pd(t1_new, t1, zero);
    }
    // t0 < t1 and t1 finite (t1 is never NaN: it only takes values below it).
    let ok = _mm256_andnot_pd(
        fail,
        _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_LT_OQ>(t0, t1),
            _mm256_cmp_pd::<_CMP_LT_OQ>(t1, _mm256_set1_pd(f64::INFINITY)),
        ),
    );
    (t0, t1, _mm256_movemask_pd(ok) as u32)
}

/// `segment_count((t1 − t0)/step)` in lanes where the span over the step is in (0, 2⁵²)
/// (`segment_count`'s own fast path: ⌈x⌉ as its truncation, plus one where that is below x),
/// else 0 (the caller then takes `segment_count`).
#[inline]
#[target_feature(enable = "avx2")]
pub(in crate::render) fn count_lanes(t0: __m256d, t1: __m256d, step: f64) -> [u64; 4] {
    let x = _mm256_div_pd(_mm256_sub_pd(t1, t0), _mm256_set1_pd(step));
    let t = _mm256_round_pd::<{ _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC }>(x);
    let up = _mm256_and_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(t, x), _mm256_set1_pd(1.0));
    let n = st4d(_mm256_add_pd(t, up));
    let fast = _mm256_movemask_pd(_mm256_and_pd(
        _mm256_cmp_pd::<_CMP_GT_OQ>(x, _mm256_setzero_pd()),
        _mm256_cmp_pd::<_CMP_LT_OQ>(x, _mm256_set1_pd(4_503_599_627_370_496.0)),
    )) as u32;
    std::array::from_fn(|l| if fast >> l & 1 != 0 { n[l] as u64 } else { 0 })
}

/// `Cursor::start_at(t)` of four new cursors (k = 0) over [t0, t1] in steps of `step` with
/// `n` segments (0: unknown), in lanes: per lane the first segment whose midpoint is not before
/// t, where it can be told without the cursor's search: 0 where segment 0's midpoint is not
/// before t; else `Cursor::pass_before`'s estimate (⌊(t − t0)/step − 0.5⌋ + 1, at least 1, at
/// most n) where the midpoints beside it show it final (the one before it below t, it at or
/// past t or the last); `None` otherwise (and for counts of 2⁵² or more), where the cursor
/// then searches. The midpoints are `Cursor::mid`'s operations (boundaries t0 + k·step, an end
/// at the next boundary where below t1, at t1 for the last segment).
#[inline]
#[target_feature(enable = "avx2")]
pub(in crate::render) fn first_segments(
    t0: __m256d,
    t1: __m256d,
    step: f64,
    n: [u64; 4],
    t: __m256d,
) -> [Option<u64>; 4] {
    let step_v = _mm256_set1_pd(step);
    let nf = _mm256_setr_pd(n[0] as f64, n[1] as f64, n[2] as f64, n[3] as f64);
    /// `Cursor::mid` of segments `k` in lanes.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn mid_lanes(k: __m256d, t0: __m256d, t1: __m256d, step: __m256d, n: __m256d) -> __m256d {
        let a = _mm256_add_pd(t0, _mm256_mul_pd(k, step));
        let k1 = _mm256_add_pd(k, _mm256_set1_pd(1.0));
        let next = _mm256_add_pd(t0, _mm256_mul_pd(k1, step));
        let b = _mm256_blendv_pd(
            _mm256_min_pd(next, t1),
            t1,
            _mm256_cmp_pd::<_CMP_GE_OQ>(k1, n),
        );
        _mm256_mul_pd(_mm256_set1_pd(0.5), _mm256_add_pd(a, b))
    }
    let zero = _mm256_setzero_pd();
    let one = _mm256_set1_pd(1.0);
    // Segment 0 needs no search where its midpoint is not before t.
    let stays = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_NLT_UQ>(
        mid_lanes(zero, t0, t1, step_v, nf),
        t,
    )) as u32;
    let g = _mm256_sub_pd(
        _mm256_div_pd(_mm256_sub_pd(t, t0), step_v),
        _mm256_set1_pd(0.5),
    );
    let est = _mm256_min_pd(
        _mm256_add_pd(
            _mm256_round_pd::<{ _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC }>(g),
            one,
        ),
        nf,
    );
    // g > 0 (and below 2⁵², where its truncation is exact): the estimate; else 1.
    let positive = _mm256_and_pd(
        _mm256_cmp_pd::<_CMP_GT_OQ>(g, zero),
        _mm256_cmp_pd::<_CMP_LT_OQ>(g, _mm256_set1_pd(4_503_599_627_370_496.0)),
    );
    let big = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_NLT_UQ>(
        g,
        _mm256_set1_pd(4_503_599_627_370_496.0),
    )) as u32;
    let k = _mm256_blendv_pd(one, est, positive);
    let before = _mm256_sub_pd(k, one);
    // Final: k = 1 or mid(k − 1) < t; and k = n or mid(k) ≥ t.
    let low = _mm256_or_pd(
        _mm256_cmp_pd::<_CMP_LE_OQ>(k, one),
        _mm256_cmp_pd::<_CMP_LT_OQ>(mid_lanes(before, t0, t1, step_v, nf), t),
    );
    let high = _mm256_or_pd(
        _mm256_cmp_pd::<_CMP_GE_OQ>(k, nf),
        _mm256_cmp_pd::<_CMP_GE_OQ>(mid_lanes(k, t0, t1, step_v, nf), t),
    );
    let fin = _mm256_movemask_pd(_mm256_and_pd(low, high)) as u32;
    let k = st4d(k);
    let mut out = [None; 4];
    for (l, o) in out.iter_mut().enumerate() {
        *o = if n[l] == 0 || n[l] >= 1 << 52 || big >> l & 1 != 0 {
            None
        } else if stays >> l & 1 != 0 {
            Some(0)
        } else if fin >> l & 1 != 0 {
            Some(k[l] as u64)
        } else {
            None
        };
    }
    out
}

/// The four f64 of `a` as a register.
#[inline]
#[target_feature(enable = "avx")]
pub(in crate::render) fn ld4(a: &[f64; 4]) -> __m256d {
    // SAFETY: `a` is 4 f64, 32 readable bytes; the load has no alignment requirement.
    unsafe { _mm256_loadu_pd(a.as_ptr()) }
}

/// The four lanes of `v`.
#[inline]
#[target_feature(enable = "avx")]
pub(in crate::render) fn st4d(v: __m256d) -> [f64; 4] {
    let mut a = [0f64; 4];
    // SAFETY: `a` is 4 f64, 32 writable bytes; the store has no alignment requirement.
    unsafe { _mm256_storeu_pd(a.as_mut_ptr(), v) };
    a
}

/// The lanes of three registers.
#[inline]
#[target_feature(enable = "avx")]
pub(super) fn st4(v: [__m256d; 3]) -> [[f64; 4]; 3] {
    [st4d(v[0]), st4d(v[1]), st4d(v[2])]
}
