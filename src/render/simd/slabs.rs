//! The slabs of the pre-integrated packet march in lanes ([`LaneSlabs`],
//! [`Packets::slabs_in_lanes`]): where a lane's sample follows the last position its ray took
//! (`PreMarch::follows`: the common case, a run's consecutive samples) and the slab between
//! the two can show something, the slab goes into a batch of the step's slabs, and the
//! values at the middles and the quarters of a batch's slabs are read together in lanes, the
//! sample's own reads ([`Packets::values`]) at those points of the slabs' rays: the scalar
//! `PreMarch::value`'s bits. The rest (the halving tests, the tables, the composite in f64,
//! the lighting) is the scalar code's, `PreMarch::slab_with` given those values: the pieces
//! composited are those of the scalar march, bit for bit. (The tables are not read in lanes:
//! gathering a piece's four entries of five f32 cost more than the scalar reads.)
//!
//! Not here: which samples the lanes take and when a ray ends ([`Packets::tile_pre`]), the
//! tables (`render::preint`), the pieces' compositing and lighting (`integrate::preint`,
//! [`preint`]).

use super::*;

/// A batch of slabs of a step of the pre-integrated packet march, one a lane: in lane k < `n`,
/// the slab from ray parameter `ta` (value `va`) to `tb` (value `vb`) of the ray in the
/// march's lane `from[k]`, whose object-space origin and direction are lane k's of `rays`;
/// and what [`Packets::slabs_in_lanes`] reads of them, the values at their middles and their
/// quarters.
pub(super) struct LaneSlabs<const N: usize> {
    pub(super) n: usize,
    pub(super) from: [usize; N],
    rays: LaneState<N>,
    ta: [f64; N],
    tb: [f64; N],
    va: [f32; N],
    vb: [f32; N],
    /// The values at the middles, the first quarters and the last quarters.
    values: [[f32; N]; 3],
}

impl<const N: usize> Default for LaneSlabs<N> {
    fn default() -> Self {
        LaneSlabs {
            n: 0,
            from: [0; N],
            rays: LaneState::default(),
            ta: [0.0; N],
            tb: [0.0; N],
            va: [0.0; N],
            vb: [0.0; N],
            values: [[0.0; N]; 3],
        }
    }
}

impl<const N: usize> LaneSlabs<N> {
    /// Adds the slab from ray parameter `ta` (value `va`) to `tb` (value `vb`) of the ray of
    /// the march's lane `from`, carried by lane `l` of `st` (there is room: `n` < N).
    #[inline(always)]
    pub(super) fn push(
        &mut self,
        from: usize,
        (st, l): (&LaneState<N>, usize),
        (ta, va): (f64, f32),
        (tb, vb): (f64, f32),
    ) {
        let k = self.n;
        debug_assert!(k < N);
        self.n += 1;
        self.from[k] = from;
        for axis in 0..3 {
            self.rays.ro[axis][k] = st.ro[axis][l];
            self.rays.rd[axis][k] = st.rd[axis][l];
        }
        (self.ta[k], self.va[k], self.tb[k], self.vb[k]) = (ta, va, tb, vb);
    }

    /// Slab `k`: its front and back (ray parameter, value), the value at its middle and those
    /// at its quarters, as `PreMarch::pieces` takes them.
    #[inline(always)]
    pub(super) fn slab(&self, k: usize) -> ((f64, f32), (f64, f32), f32, [f32; 2]) {
        (
            (self.ta[k], self.va[k]),
            (self.tb[k], self.vb[k]),
            self.values[0][k],
            [self.values[1][k], self.values[2][k]],
        )
    }
}

impl Packets<'_> {
    /// [`Packets::slabs_in_lanes`] in eight lanes.
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn slabs8(&self, slabs: &mut LaneSlabs<W>) {
        // SAFETY: this function has AVX2 and FMA.
        let s = unsafe { Avx2::new() };
        self.slabs_in_lanes(s, slabs)
    }

    /// [`Packets::slabs_in_lanes`] in sixteen lanes.
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    pub(super) fn slabs16(&self, slabs: &mut LaneSlabs<V>) {
        // SAFETY: this function has every feature `Avx512` stands for.
        let s = unsafe { Avx512::new() };
        self.slabs_in_lanes(s, slabs)
    }

    /// The values at the middles and the quarters of the `slabs.n` slabs of `slabs`
    /// (`PreMarch::slab`'s f64 operations for the points, [`Packets::values`]' reads).
    #[inline(always)]
    fn slabs_in_lanes<S: Simd<N>, const N: usize>(&self, s: S, slabs: &mut LaneSlabs<N>) {
        if slabs.n == 0 {
            return;
        }
        let live = u32::MAX >> (32 - slabs.n);
        let (mut m, mut qa, mut qb) = ([0f64; N], [0f64; N], [0f64; N]);
        let half = s.splat_d(0.5);
        for h in 0..2 {
            let (ta, tb) = (s.ld_d(&slabs.ta, h), s.ld_d(&slabs.tb, h));
            let mid = s.mul_d(half, s.add_d(ta, tb));
            s.st_d(&mut m, h, mid);
            s.st_d(&mut qa, h, s.mul_d(half, s.add_d(ta, mid)));
            s.st_d(&mut qb, h, s.mul_d(half, s.add_d(mid, tb)));
        }
        // (A loop, not a closure, which would not have the caller's target features.)
        for (out, at) in slabs.values.iter_mut().zip([&m, &qa, &qb]) {
            self.values(s, &slabs.rays, at, live, out);
        }
    }
}
