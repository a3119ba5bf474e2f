//! Trilinear values of eight points at once, for the batched march.
//!
//! This file owns [`Dataset::trilinear8`] (the points' cells found in 4 or 8 lanes, each value
//! then read and interpolated by the `trilinear` module's cell code, cells a [`CellMask`]
//! rejects skipped), the [`Cells8`] it hands out, the interior test of those cells
//! ([`Dataset::interior8`]) and the gradient in one of them
//! ([`Dataset::trilinear_gradient_in`]). Each lane performs the operations of the one-point
//! path, so the values are [`Dataset::trilinear`]'s bit for bit. Not here: the march itself
//! (`render`), nor the packet march's own gathers (`render::simd`).

use super::cells::reaches;
use super::filter::FACE_TOLERANCE;
use super::{CellGradients, CellMask, Dataset, Filter};

/// The cells of [`Dataset::trilinear8`]'s points, handed out so that the batched march can
/// take a shaded sample's gradient in its cell ([`Dataset::trilinear_gradient_in`]) instead of
/// finding the cell again from the point.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Cells8 {
    /// Per point, its cell's first node's index.
    pub(crate) at: [u32; 8],
    /// Per axis and point, the weight of the cell's second node.
    pub(crate) f: [[f32; 8]; 3],
    /// Per axis and point, the clamped coordinate the cell was found from (min(u, n − 2), see
    /// [`Dataset::cell_in_lanes`]), for [`Dataset::interior8`].
    pub(crate) cu: [[f32; 8]; 3],
    /// How many of the points (the first) the cells were found for in lanes (0: none, those
    /// points keep the gradient's own path).
    pub(crate) count: u32,
}

impl Dataset {
    /// [`Dataset::trilinear`] at the first `count` of eight points given by axis (`p[axis]`
    /// holds the eight coordinates along it), or 0 where `mask` knows the value is at most its
    /// bound (the eight nodes are not read then; a mask's bound is never below 0, see
    /// [`Dataset::cells_above`]). The cells are found in lanes across the points, with the
    /// operations of [`Dataset::cell_in_lanes`] lane for lane, so the same values. The other
    /// values are 0. (Written into `out`, all eight values, rather than returned: the batched
    /// march keeps one array for every run, and a returned array would be copied from the
    /// return slot to the caller's, one f32 at a time, on every run.) `cells` receives the points'
    /// cells, for their gradients (see [`Cells8`]).
    #[inline]
    pub(crate) fn trilinear8(
        &self,
        p: &[[f32; 8]; 3],
        count: usize,
        mask: Option<&CellMask>,
        out: &mut [f32; 8],
        cells: &mut Cells8,
    ) {
        *out = [0f32; 8];
        cells.count = 0;
        let count = count.min(8);
        #[cfg(target_arch = "x86_64")]
        if self.lanes.is_some() {
            use wide::{f32x4, f32x8, i32x4, i32x8};
            // The cells of the points along one axis, in lanes of `$F` (`$I` for the indices).
            macro_rules! cells {
                ($F:ty, $I:ty, $N:literal, $S:tt) => {{
                    let mut c = [<$I>::default(); 3];
                    let mut cf = [<$F>::ZERO; 3];
                    let (f, cus) = (&mut cells.f, &mut cells.cu);
                    // The lanes whose points the dataset covers (`Dataset::covers`: NaN fails
                    // both comparisons).
                    let mut covered = <$F>::splat(-1.0).simd_eq(<$F>::splat(-1.0));
                    for axis in 0..3 {
                        let l = self.splats.$S[0][axis];
                        let lanes: [f32; $N] = std::array::from_fn(|i| p[axis][i]);
                        let x = <$F>::new(lanes);
                        covered = covered
                            & x.simd_ge(<$F>::splat(-FACE_TOLERANCE))
                            & x.simd_le(<$F>::splat(1.0 + FACE_TOLERANCE));
                        let u = (x * l).fast_max(<$F>::ZERO).fast_min(l);
                        let cu = u.fast_min(self.splats.$S[1][axis]);
                        cus[axis][..$N].copy_from_slice(&cu.to_array());
                        c[axis] = cu.fast_trunc_int();
                        cf[axis] = c[axis].round_float();
                        f[axis][..$N].copy_from_slice(&(u - cf[axis]).to_array());
                    }
                    if self.index_lanes.is_some() {
                        // The first nodes' indices in lanes: integers below 2²⁴, so exact.
                        let s = |axis: usize| self.splats.$S[3][axis];
                        let at = cf[0] * s(0) + cf[1] * s(1) + cf[2] * s(2);
                        let at: $I = at.fast_trunc_int();
                        let at = at.to_array().map(|a| a as u32);
                        cells.at[..$N].copy_from_slice(&at);
                        cells.count = count as u32;
                        // Below 2²⁴ as well, so the conversions are exact.
                        let rows = (
                            self.strides[1] as u32 as usize,
                            self.strides[2] as u32 as usize,
                        );
                        self.values_in_cells(at, |a| a as usize, rows, &cells.f, count, mask, out);
                    } else {
                        let [cx, cy, cz] = c.map(|c| c.to_array());
                        let at: [usize; $N] = std::array::from_fn(|i| {
                            self.node_index([cx[i], cy[i], cz[i]].map(|c| c as usize))
                        });
                        let rows = (self.strides[1], self.strides[2]);
                        self.values_in_cells(at, |a| a, rows, &cells.f, count, mask, out);
                    }
                    // Outside the dataset: 0 (the cells found there, clamped onto a face,
                    // are never interior, so no gradient is taken in them).
                    let outside = !(covered.to_bitmask() as u32) & ((1u32 << count) - 1);
                    if outside != 0 {
                        for (i, v) in out.iter_mut().enumerate().take(count) {
                            if outside >> i & 1 != 0 {
                                *v = 0.0;
                            }
                        }
                    }
                }};
            }
            // A short run (the usual one at large sample distances) needs only half the lanes.
            if count <= 4 {
                cells!(f32x4, i32x4, 4, 0);
            } else {
                cells!(f32x8, i32x8, 8, 1);
            }
            return;
        }
        for (i, out) in out.iter_mut().enumerate().take(count) {
            *out = self.trilinear_in([p[0][i], p[1][i], p[2][i]], mask);
        }
    }

    /// Bit `i`: point `i` of the last [`Dataset::trilinear8`] that filled `cells` (of the
    /// first [`Cells8::count`]) lies in an interior cell (its 4×4×4 neighbourhood inside the
    /// grid, see [`Dataset::interior_cell32`]): 1 ≤ cu < n − 2 along every axis (see
    /// [`Dataset::cell_in_lanes`]). Apart from `trilinear8`, so that the batched march takes it
    /// only for runs with a sample to shade. The lower bound as one test of the three
    /// axes' least (`interior8_is_the_tests_axis_by_axis`).
    #[inline]
    pub(crate) fn interior8(&self, cells: &Cells8) -> u32 {
        #[cfg(target_arch = "x86_64")]
        if self.lanes.is_some() {
            use wide::f32x8;
            let cu = cells.cu.map(f32x8::new);
            // At least 1 along every axis where the least of the three is: `cu` is never NaN
            // (`max(u, 0)` by `maxps` maps NaN to 0), so the minima are the numbers' least.
            let low = cu[0].fast_min(cu[1]).fast_min(cu[2]).simd_ge(f32x8::ONE);
            let high = |axis: usize| cu[axis].simd_lt(self.splats.1[2][axis]);
            let count = cells.count.min(8);
            return (low & high(0) & high(1) & high(2)).to_bitmask() & ((1 << count) - 1);
        }
        0
    }

    /// The values at the first `count` of `N` points whose cells' first nodes are `at` (as
    /// `index` converts them to node indices) and whose weights `f` are given by axis (see
    /// [`Dataset::trilinear8`]), written into `out`, which holds 0s: a value the mask knows to
    /// be 0 is left as it is. (The mask is tested here rather than in the cell's interpolation, so
    /// that the rejected cells skip the 0's store and the loads of their weights, which the
    /// compiler would hoist above the test there.)
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn values_in_cells<T: Copy, const N: usize>(
        &self,
        at: [T; N],
        index: impl Fn(T) -> usize,
        rows: (usize, usize),
        f: &[[f32; 8]; 3],
        count: usize,
        mask: Option<&CellMask>,
        out: &mut [f32; 8],
    ) {
        // The mask's bits as a slice, no mask as no bits (which let every cell through): the
        // cells then test neither the option nor reload the slice from the mask.
        let bits: &[u64] = mask.map_or(&[], |m| &m.bits);
        // The x-stride's test outside the cells: the compiler merges the two loops again, but
        // tests a register in each cell instead of reloading the stride from the dataset.
        // (The cells by index: iterating over `at` by value copied it and set up its
        // iterator on every run.)
        let mut cells = |unit_x: bool| {
            for i in 0..count.min(N) {
                let at = index(at[i]);
                if !reaches(bits, at) {
                    continue;
                }
                let f = [f[0][i], f[1][i], f[2][i]];
                if let Some(v) = self.trilinear_cell(at, rows, f, unit_x) {
                    out[i] = v;
                }
            }
        };
        if self.strides[0] == 1 {
            cells(true);
        } else {
            cells(false);
        }
    }

    /// [`Dataset::gradient_cached`] with the trilinear filter at a point of interior cell
    /// `cells` holds as its lane `i` (bit `i` of [`Dataset::interior8`] set): the batched march
    /// has found that cell for the point's value, so the gradient need not find it again. The
    /// same value, bit for bit (the same cell and weights, see [`Dataset::trilinear8`]), but
    /// for the sign of a zero component (see [`Dataset::trilinear_gradient_at`]'s
    /// `SIGNED_ZEROS`): for the lighting lanes, where that sign cannot change a colour. The
    /// point is lane `i` of `ps` (by axis, as `trilinear8` takes them), read only where the
    /// cell's rows are not all inside the node values or voxels (never, for an interior cell):
    /// so the caller need not gather it.
    #[inline]
    pub(crate) fn trilinear_gradient_in(
        &self,
        ps: &[[f32; 8]; 3],
        cells: &Cells8,
        i: usize,
        cache: &mut CellGradients,
    ) -> [f64; 3] {
        let f = [cells.f[0][i], cells.f[1][i], cells.f[2][i]];
        (cells.at[i] as usize)
            .checked_sub(self.lo_offset)
            .and_then(|lo| self.trilinear_gradient_at::<false>(lo, f, cache))
            .unwrap_or_else(|| {
                self.gradient_generic([ps[0][i], ps[1][i], ps[2][i]], Filter::Trilinear)
            })
    }
}
