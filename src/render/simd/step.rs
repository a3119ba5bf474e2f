//! One sample in every active lane of a packet, in either width: the object point, its cell,
//! the trilinear value and the zero test, opacity and colour, the opacity correction, the
//! lighting ([`shade`]) and the front-to-back composite ([`Packets::step`]),
//! written once over [`Simd`] and compiled per width by [`Packets::step8`] and
//! [`Packets::step16`]. Not here: which samples the lanes take ([`runs`]), the
//! reads of nodes and voxels ([`nodes`]), the tables ([`tables`]).

use super::*;

impl Packets<'_> {
    /// [`Packets::step`] in eight lanes.
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn step8(
        &self,
        st: &mut LaneState<W>,
        active: u32,
        cache: &mut CellGradients,
    ) -> u32 {
        // SAFETY: this function has AVX2 and FMA.
        let s = unsafe { Avx2::new() };
        self.step(s, st, active, cache)
    }

    /// [`Packets::step`] in sixteen lanes (tables in registers: [`Packets::new`]).
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    pub(super) fn step16(
        &self,
        st: &mut LaneState<V>,
        active: u32,
        cache: &mut CellGradients,
    ) -> u32 {
        // SAFETY: this function has every feature `Avx512` stands for.
        let s = unsafe { Avx512::new() };
        self.step(s, st, active, cache)
    }

    /// One sample of each lane in `active` (at `st.mid`, `st.len`): shaded and composited
    /// into the lane's state. Returns the lanes whose rays end there (transmittance below the
    /// termination bound).
    #[inline(always)]
    fn step<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        st: &mut LaneState<N>,
        active: u32,
        cache: &mut CellGradients,
    ) -> u32 {
        let zero = s.zero();
        let one = s.splat(1.0);
        // The lanes with a sample of positive length (`pass_bits`: a NaN length passes).
        let live = active & !s.le_zero_d(&st.len);
        #[cfg(vlib_counters)]
        counters::add(0, live);
        if live == 0 {
            return 0;
        }
        // The cells (every sample here lies in one that may reach the bound: `to_take`).
        let Some(Sampled {
            p,
            f,
            base,
            interior,
            mut pass,
            nodes,
            rows,
            v,
        }) = self.sample(s, st, &st.mid, live)
        else {
            return 0;
        };
        // The zero test.
        pass &= s.bits(s.gt(v, s.splat(self.z)));
        #[cfg(vlib_counters)]
        counters::add(1, pass);
        if pass == 0 {
            return 0;
        }
        let (o, rgb) = match &self.segments {
            Some(t) => t.eval(s, v),
            None => s.pairs_eval(self, v, pass),
        };
        // The samples with opacity.
        let shown = pass & s.bits(s.gt(o, zero));
        #[cfg(vlib_counters)]
        counters::add(2, shown);
        if shown == 0 {
            return 0;
        }
        // The opacity correction: 1 − (1 − o)^(len / reference).
        let common = s.scaled_eq_d(&st.len, self.inv_ref, self.common);
        let mut tr = transmit_lanes(s, self.common, s.sub(one, o));
        let odd = shown & !common;
        if odd != 0 {
            let mut oa = [0f32; N];
            let mut ta = [0f32; N];
            s.st(&mut oa, o);
            s.st(&mut ta, tr);
            self.transmit_odd(&oa, &st.len, odd, &mut ta);
            tr = s.ld(&ta);
        }
        let alpha = s.keep(s.of_bits(shown), s.sub(one, tr));
        // The lit colour.
        let col = match &self.light {
            Light32::Unlit { ka_ambient } => {
                let mut c = rgb;
                for (ch, c) in c.iter_mut().enumerate() {
                    *c = s.mul(s.splat(ka_ambient[ch]), rgb[ch]);
                }
                finite(s, c)
            }
            Light32::Lit { .. } => {
                let g = self.gradient(
                    s,
                    &p,
                    &f,
                    base,
                    interior,
                    shown,
                    cache,
                    &nodes,
                    rows.as_ref(),
                );
                let view = [s.ld(&st.view[0]), s.ld(&st.view[1]), s.ld(&st.view[2])];
                self.lit(s, &view, g, rgb)
            }
        };
        // Front to back.
        let mut t = s.ld(&st.t);
        let w = s.mul(t, alpha);
        for (ch, x) in col.into_iter().enumerate() {
            let acc = s.ld(&st.col[ch]);
            s.st(&mut st.col[ch], s.fmadd(w, x, acc));
        }
        t = s.mul(t, s.sub(one, alpha));
        s.st(&mut st.t, t);
        shown & s.bits(s.lt(t, s.splat(self.stop)))
    }

    /// The samples of the lanes in `live` at ray parameters `mid` (`st.mid`, or other points
    /// of the lanes' rays): their object points (f64, then
    /// rounded to f32 as `ray_point`), cells ([`Packets::cells`]), the lanes among them
    /// inside the dataset (`Dataset::covers`; NaN is outside), their eight nodes (and the
    /// central rows of voxels where the voxels are read) and trilinear values, normalised
    /// and clamped to [0, 1] as `clamp_field`. `None` where no lane is inside the dataset.
    /// What [`Packets::step`] and the pre-integrated march's `Packets::values` read alike.
    #[inline(always)]
    pub(super) fn sample<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        st: &LaneState<N>,
        mid: &[f64; N],
        live: u32,
    ) -> Option<Sampled<S, N>> {
        let zero = s.zero();
        let mut p = [zero; 3];
        for (axis, pa) in p.iter_mut().enumerate() {
            let (o, d) = (&st.ro[axis], &st.rd[axis]);
            let lo = s.add_d(s.ld_d(o, 0), s.mul_d(s.ld_d(mid, 0), s.ld_d(d, 0)));
            let hi = s.add_d(s.ld_d(o, 1), s.mul_d(s.ld_d(mid, 1), s.ld_d(d, 1)));
            *pa = s.narrow(lo, hi);
        }
        let (f, base, interior) = self.cells(s, &p);
        let mut pass = live;
        if self.clip {
            // Outside the dataset its value is 0, which fails the zero test (z ≥ 0): those
            // lanes drop out here.
            let (lo, hi) = (s.splat(-FACE_TOLERANCE), s.splat(1.0 + FACE_TOLERANCE));
            for pa in p {
                pass &= s.bits(s.and_m(s.ge(pa, lo), s.le(pa, hi)));
            }
            if pass == 0 {
                return None;
            }
        }
        // The eight nodes and the trilinear value (`trilinear_rows`' lerps).
        let (base, nodes, rows) = self.cell_nodes(s, base, pass);
        let v = trilinear_lanes(s, &nodes, f);
        // (Raw voxels: the value normalised once, `raw·scale + offset`.)
        let v = match &self.raw8 {
            Some(r8) => s.fmadd(v, s.splat(r8.scale), s.splat(r8.offset)),
            None => v,
        };
        let v = s.min(s.max(v, zero), s.splat(1.0));
        Some(Sampled {
            p,
            f,
            base,
            interior,
            pass,
            nodes,
            rows,
            v,
        })
    }

    /// The nodes of the cells whose first nodes are `base`, in the lanes of `pass`: that
    /// `base` with node 0 in the other lanes (so that they cause no memory traffic), the
    /// cells' eight nodes, and the voxels' central rows where the 8-bit voxels are read.
    #[inline(always)]
    pub(super) fn cell_nodes<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        base: S::I,
        pass: u32,
    ) -> CellNodes<S::I, S::F> {
        let base = s.keep_i(pass, base);
        match (&self.raw8, &self.raw16) {
            (Some(r8), _) => {
                let rows = r8.central_rows(s, base, pass, self.sy, self.sz);
                (base, rows.cell_nodes(s), Some(rows))
            }
            (None, Some(r16)) if r16.exact() => {
                (base, r16.cell_nodes(s, base, self.sy, self.sz), None)
            }
            _ => (base, s.value_nodes(self, base), None),
        }
    }

    /// The cells of object points `p`, as `Dataset::trilinear8` finds them: the weights
    /// within the cell, the cell's first node's index and the lanes whose cell's 4³
    /// neighbourhood lies inside the grid (`Dataset::interior8`).
    #[inline(always)]
    pub(super) fn cells<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        p: &[S::F; 3],
    ) -> ([S::F; 3], S::I, S::M) {
        let zero = s.zero();
        let one = s.splat(1.0);
        let mut f = [zero; 3];
        let mut c = [s.zero_i(); 3];
        let mut inside = [s.eq(zero, zero); 3];
        for axis in 0..3 {
            let l = s.splat(self.last[axis]);
            let ua = s.min(s.max(s.mul(p[axis], l), zero), l);
            let cu = s.min(ua, s.splat(self.top[axis]));
            let ci = s.trunc(cu);
            f[axis] = s.sub(ua, s.to_f(ci));
            c[axis] = ci;
            inside[axis] = s.and_m(s.ge(cu, one), s.lt(cu, s.splat(self.inner[axis])));
        }
        let interior = s.and_m(inside[0], s.and_m(inside[1], inside[2]));
        let base = s.add_i(
            c[0],
            s.add_i(
                s.mullo_i(c[1], s.splat_i(self.sy)),
                s.mullo_i(c[2], s.splat_i(self.sz)),
            ),
        );
        (f, base, interior)
    }
}

/// [`Packets::cell_nodes`]: the cells' first nodes, their eight nodes and the voxels'
/// central rows where read.
pub(super) type CellNodes<I, F> = (I, [F; 8], Option<Rows<I>>);

/// A packet's samples as [`Packets::sample`] reads them: object points, weights within their
/// cells, the cells' first nodes (node 0 for lanes not in `pass`), the interior lanes, the
/// lanes inside the dataset, the cell nodes, the voxels' central rows (where read) and the
/// values.
pub(super) struct Sampled<S: Simd<N>, const N: usize> {
    pub(super) p: [S::F; 3],
    pub(super) f: [S::F; 3],
    pub(super) base: S::I,
    pub(super) interior: S::M,
    pub(super) pass: u32,
    pub(super) nodes: [S::F; 8],
    pub(super) rows: Option<Rows<S::I>>,
    pub(super) v: S::F,
}

/// The trilinear value of a cell's eight `nodes` (x fastest) at weights `f`: `trilinear_rows`'
/// seven lerps, unfused, in its order.
#[inline(always)]
pub(super) fn trilinear_lanes<S: Simd<N>, const N: usize>(
    s: S,
    nodes: &[S::F; 8],
    [fx, fy, fz]: [S::F; 3],
) -> S::F {
    let [n000, n100, n010, n110, n001, n101, n011, n111] = *nodes;
    let c00 = lerp(s, n000, n100, fx);
    let c10 = lerp(s, n010, n110, fx);
    let c01 = lerp(s, n001, n101, fx);
    let c11 = lerp(s, n011, n111, fx);
    lerp(s, lerp(s, c00, c10, fy), lerp(s, c01, c11, fy), fz)
}

/// `a + (b − a)·t`, unfused (the scalar code's lerp).
#[inline(always)]
fn lerp<S: Simd<N>, const N: usize>(s: S, a: S::F, b: S::F, t: S::F) -> S::F {
    s.add(a, s.mul(s.sub(b, a), t))
}

/// Counts of the samples [`Packets::step`] evaluates since the process began, for measuring
/// the march (`docs/performance.md`, "Samples taken"): compiled only with
/// `RUSTFLAGS="--cfg vlib_counters"`, and then read by [`sample_counts`].
#[cfg(vlib_counters)]
pub(crate) mod counters {
    use std::sync::atomic::{AtomicU64, Ordering};

    static COUNTS: [AtomicU64; 3] = [const { AtomicU64::new(0) }; 3];

    /// Adds the lanes set in `lanes` to count `k`.
    #[inline]
    pub(super) fn add(k: usize, lanes: u32) {
        COUNTS[k].fetch_add(lanes.count_ones() as u64, Ordering::Relaxed);
    }

    /// The samples the packet march has evaluated (in cells the mask passes), those of them
    /// above the opacity table's zero bound, and those with opacity above 0.
    pub fn sample_counts() -> [u64; 3] {
        COUNTS.each_ref().map(|c| c.load(Ordering::Relaxed))
    }
}
