//! Opacity and colour of a packet's values: the transfer functions as at most eight linear
//! pieces in registers ([`Segments`], generic over [`Simd`]), or, for tables of more rows, by
//! their segment pairs gathered ([`Packets::pairs_eval`], eight lanes). Not here: the tables
//! themselves ([`crate::render::kernel::DirectShading`], [`Mapping`]).

use super::*;

impl Packets<'_> {
    /// Opacity and colour of values `v` from the tables' segment pairs (gathers), the lanes
    /// of `pass` whose bucket has none by the tables' general evaluation.
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn pairs_eval(&self, v: __m256, pass: u32) -> (__m256, [__m256; 3]) {
        let zero = _mm256_setzero_ps();
        let one = _mm256_set1_ps(1.0);
        let bucket = _mm256_cvttps_epi32(_mm256_mul_ps(v, _mm256_set1_ps(1024.0)));
        let pair = gather_i32(&self.bucket_pair, bucket);
        let general = pass
            & _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(
                _mm256_setzero_si256(),
                pair,
            ))) as u32;
        let q = |k: usize| gather(&self.pairs[k], pair);
        let clamp = |x: __m256| _mm256_min_ps(_mm256_max_ps(x, zero), one);
        let dxo = _mm256_sub_ps(v, q(0));
        let dxc = _mm256_sub_ps(v, q(1));
        let mut o = clamp(_mm256_fmadd_ps(dxo, q(6), q(2)));
        let mut rgb = [
            clamp(_mm256_fmadd_ps(dxc, q(7), q(3))),
            clamp(_mm256_fmadd_ps(dxc, q(8), q(4))),
            clamp(_mm256_fmadd_ps(dxc, q(9), q(5))),
        ];
        if general != 0 {
            let mut vs = [0f32; W];
            st8(&mut vs, v);
            let mut oa = [0f32; W];
            let mut ca = [[0f32; W]; 3];
            st8(&mut oa, o);
            for ch in 0..3 {
                st8(&mut ca[ch], rgb[ch]);
            }
            for i in 0..W {
                if general >> i & 1 != 0 {
                    let (oi, ci) = self.tables.opacity_colour_general(vs[i]);
                    oa[i] = oi;
                    let ci = ci.unwrap_or([0.0; 3]);
                    for ch in 0..3 {
                        ca[ch][i] = ci[ch];
                    }
                }
            }
            o = ld8(&oa);
            for ch in 0..3 {
                rgb[ch] = ld8(&ca[ch]);
            }
        }
        (o, rgb)
    }
}

/// A transfer function's output column as linear pieces, by the number k of breakpoints
/// below the input (the segment [`Mapping::locate`] finds): `Φ(v) = base[k] + (v −
/// start[k])·slope[k]` for v in (0, 1] (the pieces of [`Mapping::eval_at`], in f32; an
/// input of 0 never gets here: it fails the zero test), then clamped as a field value.
pub(super) struct Segs {
    pub(super) a: Vec<f32>,
    pub(super) start: [f32; 8],
    pub(super) base: [f32; 8],
    pub(super) slope: [f32; 8],
}

impl Segs {
    /// The pieces of column `j` of `m`, where it has at most seven rows.
    pub(super) fn new(m: &Mapping, j: usize) -> Option<Segs> {
        let a = m.breakpoints();
        let n = a.len();
        if n > 7 {
            return None;
        }
        let (mut start, mut base, mut slope) = ([0f32; 8], [0f32; 8], [0f32; 8]);
        let b = |i: usize| m.b(i, j) as f64;
        for k in 0..=n {
            let (s0, b0, sl) = match m.kind() {
                MappingType::Lookup => (0.0, if k == 0 || k == n { 0.0 } else { b(k) }, 0.0),
                MappingType::Ramp if k == 0 => {
                    // 0 < v ≤ a_1: v·b_1/a_1 (a_1 > 0 there).
                    let a1 = a[0] as f64;
                    (0.0, 0.0, if a1 > 0.0 { b(0) / a1 } else { 0.0 })
                }
                MappingType::Ramp if k == n => {
                    // a_n < v ≤ 1: towards (1, 1).
                    let an = a[n - 1] as f64;
                    let s = if an < 1.0 {
                        (1.0 - b(n - 1)) / (1.0 - an)
                    } else {
                        0.0
                    };
                    (an, b(n - 1), s)
                }
                MappingType::Ramp => {
                    // Between rows k − 1 and k: the mapping's own segment (a, b, slope).
                    let seg = m.segment(k - 1);
                    (seg[0], seg[1 + 2 * j], seg[2 + 2 * j])
                }
            };
            start[k] = s0 as f32;
            base[k] = b0 as f32;
            slope[k] = sl as f32;
        }
        Some(Segs {
            a: a.to_vec(),
            start,
            base,
            slope,
        })
    }
}

/// The opacity and colour tables as [`Segs`].
pub(super) struct Segments {
    pub(super) o: Segs,
    pub(super) rgb: [Segs; 3],
}

impl Segments {
    /// Opacity and colour of values `v` (in [0, 1]), each clamped to [0, 1].
    #[inline(always)]
    pub(super) fn eval<S: Simd<N>, const N: usize>(&self, s: S, v: S::F) -> (S::F, [S::F; 3]) {
        let ko = count(s, &self.o.a, v);
        let kc = count(s, &self.rgb[0].a, v);
        (
            piece(s, &self.o, ko, v),
            [
                piece(s, &self.rgb[0], kc, v),
                piece(s, &self.rgb[1], kc, v),
                piece(s, &self.rgb[2], kc, v),
            ],
        )
    }
}

/// Per lane, how many of the breakpoints `a` lie below the value `v`.
#[inline(always)]
fn count<S: Simd<N>, const N: usize>(s: S, a: &[f32], v: S::F) -> S::I {
    let mut k = s.zero_i();
    for &x in a {
        k = s.count(k, s.lt(s.splat(x), v));
    }
    k
}

/// `seg`'s piece `k` at `v` per lane, clamped to [0, 1].
#[inline(always)]
fn piece<S: Simd<N>, const N: usize>(s: S, seg: &Segs, k: S::I, v: S::F) -> S::F {
    let start = s.permute8(&seg.start, k);
    let x = s.fmadd(
        s.sub(v, start),
        s.permute8(&seg.slope, k),
        s.permute8(&seg.base, k),
    );
    s.min(s.max(x, s.zero()), s.splat(1.0))
}
