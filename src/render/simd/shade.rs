//! The lighting of a packet's samples, in either width: the object-space gradient (the
//! trilinear interpolation of central differences, [`Packets::gradient`]), the headlight's
//! Phong terms ([`Packets::lit`]), the opacity correction's common powers ([`transmit_lanes`]) and
//! the colour's finiteness test ([`finite`]), written once over [`Simd`]; the bounds within
//! which the lanes light in f32 ([`MAX_LIT`], [`unit_scale`]); the lane-by-lane
//! scalar fallbacks for the rare samples they do not take; and the hand-over of the other
//! powers to [`power`](mod@super::power). Not here: the reads of the
//! differences' nodes and voxels ([`nodes`]).

use super::*;

impl Packets<'_> {
    /// The object-space gradients of the lanes in `shown` (at points `p`, cells `base` with
    /// weights `f`, `interior` as `Dataset::interior8`, cell nodes `nodes`, central rows of
    /// voxels `rows` where the voxels are read): in interior cells from the central
    /// differences ([`Raw8::differences`], [`Raw16::differences`], or from node values by
    /// per-lane loads), with `Dataset::trilinear_gradient_at`'s f32 operations in its order;
    /// in the others by `Dataset::gradient_cached`. The scale 0.5·(n − 1) applied (times the
    /// normalisation's slope for raw differences); where a gradient vanishes, NaN.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn gradient<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        p: &[S::F; 3],
        f: &[S::F; 3],
        base: S::I,
        interior: S::M,
        shown: u32,
        cache: &mut CellGradients,
        nodes: &[S::F; 8],
        rows: Option<&Rows<S::I>>,
    ) -> [S::F; 3] {
        let zero = s.zero();
        let one = s.splat(1.0);
        let inner = shown & s.bits(interior);
        let mut g = [zero; 3];
        if inner != 0 {
            let (d, scale) = match (&self.raw8, rows, &self.raw16) {
                (Some(r8), Some(rows), _) => (
                    r8.differences(s, rows, base, inner, self.sy, self.sz),
                    r8.scale,
                ),
                (_, _, Some(r16)) => (r16.differences(s, base, inner, self.sy, self.sz), r16.scale),
                _ => (s.value_differences(self, base, inner, nodes), 1.0),
            };
            let [fx, fy, fz] = *f;
            let wx = [s.sub(one, fx), fx];
            let wy = [s.sub(one, fy), fy];
            let wz = [s.sub(one, fz), fz];
            for (k, d) in d.iter().enumerate() {
                let (a, b, cc) = (k & 1, k >> 1 & 1, k >> 2);
                // The weight (wx·wy)·wz, as the scalar lanes take it.
                let w = s.mul(s.mul(wx[a], wy[b]), wz[cc]);
                for axis in 0..3 {
                    let prod = s.mul(w, d[axis]);
                    g[axis] = if k == 0 { prod } else { s.add(g[axis], prod) };
                }
            }
            for (axis, ga) in g.iter_mut().enumerate() {
                // (Raw differences: times the normalisation's scale too, in one product.)
                *ga = s.mul(*ga, s.splat(self.half_last[axis] * scale));
            }
        }
        let outer = shown & !inner;
        if outer != 0 {
            let mut pa = [[0f32; N]; 3];
            let mut ga = [[0f32; N]; 3];
            for axis in 0..3 {
                s.st(&mut pa[axis], p[axis]);
                s.st(&mut ga[axis], g[axis]);
            }
            self.gradients_one_by_one(&pa, outer, cache, &mut ga);
            for axis in 0..3 {
                g[axis] = s.ld(&ga[axis]);
            }
        }
        g
    }

    /// The lit colours of samples of colours `rgb` and object-space gradients `g`, seen
    /// along `view` (towards the eye): [`HeadlitLanes::colours_at`]'s operations in f32.
    #[inline(always)]
    pub(super) fn lit<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        view: &[S::F; 3],
        g: [S::F; 3],
        rgb: [S::F; 3],
    ) -> [S::F; 3] {
        let Light32::Lit {
            ka_ambient,
            kd,
            ks,
            e,
            to_light,
            radiance,
            flip,
            to_world,
            diagonal,
        } = &self.light
        else {
            unreachable!("lit lanes")
        };
        let zero = s.zero();
        let one = s.splat(1.0);
        let neg = s.splat(-0.0);
        // Vanishing: the largest component in magnitude at most `ZERO_GRADIENT`.
        let a = s.max(s.abs(g[0]), s.max(s.abs(g[1]), s.abs(g[2])));
        let vanishes = s.le(a, s.splat(ZERO_GRADIENT as f32));
        let mut w = g;
        for (i, w) in w.iter_mut().enumerate() {
            *w = if *diagonal {
                s.mul(s.splat(to_world[i][i]), g[i])
            } else {
                let [x, y, z] = to_world;
                let xy = s.fmadd(s.splat(y[i]), g[1], s.mul(s.splat(x[i]), g[0]));
                s.fmadd(s.splat(z[i]), g[2], xy)
            };
        }
        let g = w;
        let rcp = s.div(one, s.sqrt(dot(s, &g, &g)));
        let finite_rcp = s.and_m(s.gt(rcp, zero), s.lt(rcp, s.splat(f32::INFINITY)));
        let valid = s.andnot_m(vanishes, finite_rcp);
        let mut un = g;
        for u in un.iter_mut() {
            *u = s.mul(*u, rcp);
        }
        let l = [
            s.splat(to_light[0]),
            s.splat(to_light[1]),
            s.splat(to_light[2]),
        ];
        let ndl_u = dot(s, &un, &l);
        // Negated where the normal does not face the eye (`-0.0 ^`), or everywhere.
        let sign = if *flip {
            s.keep_unless(s.gt(dot(s, &un, view), zero), neg)
        } else {
            neg
        };
        let ndl = s.xor(ndl_u, sign);
        let lit = s.and_m(s.gt(ndl, zero), valid);
        // ndl where lit, 0 where valid and not lit, 1 where not valid.
        let m = s.blend(valid, one, s.keep(lit, ndl));
        let mut term = rgb;
        for (ch, t) in term.iter_mut().enumerate() {
            *t = s.mul(s.mul(s.splat(*kd), rgb[ch]), m);
        }
        if let Some(ks) = ks {
            let two = s.add(ndl_u, ndl_u);
            let mut r = un;
            for (i, r) in r.iter_mut().enumerate() {
                *r = s.fmsub(two, un[i], l[i]);
            }
            let rv = dot(s, &r, view);
            let spec = s.and_m(lit, s.gt(rv, zero));
            if s.bits(spec) != 0 {
                // rv^e by binary exponentiation.
                let (mut x, mut k, mut pw) = (rv, *e, one);
                loop {
                    if k & 1 != 0 {
                        pw = s.mul(pw, x);
                    }
                    k >>= 1;
                    if k == 0 {
                        break;
                    }
                    x = s.mul(x, x);
                }
                let p = s.keep(spec, s.mul(s.splat(*ks), pw));
                for t in term.iter_mut() {
                    *t = s.add(*t, p);
                }
            }
        }
        let mut col = term;
        for (ch, c) in col.iter_mut().enumerate() {
            let ambient = s.mul(s.splat(ka_ambient[ch]), rgb[ch]);
            *c = s.fmadd(s.splat(radiance[ch]), term[ch], ambient);
        }
        finite(s, col)
    }

    /// The opacity correction where a sample's exponent is not the step's common one (the
    /// lanes of `odd`, eight or sixteen of them): `1 − t` of opacities `o` over lengths `len`,
    /// as the scalar `transmit_at_most_one` gives it, into `t` ([`transmit_any`]).
    #[inline(always)]
    pub(super) fn transmit_odd<const N: usize>(
        &self,
        o: &[f32; N],
        len: &[f64; N],
        odd: u32,
        t: &mut [f32; N],
    ) {
        let e = len.map(|l| l * self.inv_ref);
        transmit_any(o, &e, odd, t);
    }

    /// The gradients lane by lane where a cell's 4³ neighbourhood is not inside the grid (the
    /// lanes of `outer`, eight or sixteen of them), at object points `p` (by axis), by the
    /// scalar `Dataset::gradient_cached`, into `g` (by axis).
    pub(super) fn gradients_one_by_one<const N: usize>(
        &self,
        p: &[[f32; N]; 3],
        outer: u32,
        cache: &mut CellGradients,
        g: &mut [[f32; N]; 3],
    ) {
        for i in 0..N {
            if outer >> i & 1 != 0 {
                let gi = self.data.gradient_cached(
                    [p[0][i], p[1][i], p[2][i]],
                    Filter::Trilinear,
                    cache,
                );
                for axis in 0..3 {
                    g[axis][i] = gi[axis] as f32;
                }
            }
        }
    }
}

/// `a·b` of three-vectors in lanes: `a₂b₂ + (a₁b₁ + a₀b₀)`, fused.
#[inline(always)]
fn dot<S: Simd<N>, const N: usize>(s: S, a: &[S::F; 3], b: &[S::F; 3]) -> S::F {
    s.fmadd(a[2], b[2], s.fmadd(a[1], b[1], s.mul(a[0], b[0])))
}

/// `t^e` in each lane for a common exponent `e` (0.5, 1, 0.25, 2, 0.125 or 4: any other
/// gives t⁴), by square roots and products in f32: `transmit_common`'s operations.
#[inline(always)]
pub(super) fn transmit_lanes<S: Simd<N>, const N: usize>(s: S, e: f64, t: S::F) -> S::F {
    if e == 0.5 {
        s.sqrt(t)
    } else if e == 1.0 {
        t
    } else if e == 0.25 {
        s.sqrt(s.sqrt(t))
    } else if e == 2.0 {
        s.mul(t, t)
    } else if e == 0.125 {
        s.sqrt(s.sqrt(s.sqrt(t)))
    } else {
        let t2 = s.mul(t, t);
        s.mul(t2, t2)
    }
}

/// The colour, each lane zero where one of its channels is not finite (`Headlit::colour`):
/// `((x·0 + y)·0 + z)·0` is ±0 where all three are finite, else NaN.
#[inline(always)]
pub(super) fn finite<S: Simd<N>, const N: usize>(s: S, col: [S::F; 3]) -> [S::F; 3] {
    let zero = s.zero();
    let m = s.mul(
        s.add(s.mul(s.add(s.mul(col[0], zero), col[1]), zero), col[2]),
        zero,
    );
    let ok = s.eq(m, zero);
    [s.keep(ok, col[0]), s.keep(ok, col[1]), s.keep(ok, col[2])]
}

/// Lane `i` of the result all ones where bit `i` of `bits` is set, else zero.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn lanes_mask(bits: u32) -> __m256 {
    let b = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    let m = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(bits as i32), b), b);
    _mm256_castsi256_ps(m)
}

/// The largest colour a lit sample may have in the lanes' f32 lighting ([`Light32::Lit`]): its
/// weighted sum over 2³² samples stays far below `f32::MAX` (2¹²⁸).
pub(super) const MAX_LIT: f64 = (1u128 << 64) as f64;

/// The power of two that brings `largest` (a matrix's largest entry in magnitude) into [1, 2);
/// 1 where it is 0 or not finite.
pub(super) fn unit_scale(largest: f64) -> f64 {
    if largest > 0.0 && largest.is_finite() {
        // (The exponent, clamped so that 2^−e is finite: a matrix whose largest entry is
        // below 2⁻¹⁰⁰⁰, which no f32 scene gives, is scaled short of [1, 2).)
        let e = largest.log2().floor().clamp(-1000.0, 1000.0) as i32;
        let s = 2f64.powi(-e);
        // (log2's rounding may leave it just outside: one step more.)
        match largest * s {
            x if x >= 2.0 => s * 0.5,
            x if x < 1.0 => s * 2.0,
            _ => s,
        }
    } else {
        1.0
    }
}
