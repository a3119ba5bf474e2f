//! The specialised trilinear path: what the renderer's inner loops call for one point.
//!
//! This file owns finding a point's trilinear cell in f32 index arithmetic (in SSE lanes where
//! the grid allows, else axis by axis), the cell's value from its nodes read as x-rows
//! ([`Dataset::trilinear`]), and the interior trilinear gradient read from the cell's 4×4×4
//! neighbourhood, with the [`CellGradients`] cache that consecutive samples of a ray share.
//! Both read the node values where they are made, else the voxels through the table of their
//! normalisation (the same bits), so that they never make the node values.
//! Every path gives the numbers of the code it specialises bit for bit (the tests hold the
//! plain versions). Not here: the filters' definitions and the generic paths these fall back
//! to (the `filter` module), and eight points at once (the `lanes` module).

use super::{CellMask, Dataset, Voxels};

/// The central differences (per grid step) at the eight nodes of the cell a trilinear
/// gradient last read, per corner (x fastest) and axis (x, y, z), for
/// [`Dataset::gradient_cached`]; `lo` is the first node of
/// the 4×4×4 neighbourhood they were read from (`usize::MAX`: none yet). Valid for one dataset.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CellGradients {
    pub(super) lo: usize,
    /// Per corner, its differences along y, z and x, and a lane not read (one SSE register).
    diffs: [[f32; 4]; 8],
}

impl Default for CellGradients {
    fn default() -> CellGradients {
        CellGradients {
            lo: usize::MAX,
            diffs: [[0.0; 4]; 8],
        }
    }
}

/// The trilinear value of a cell, clamped to [0, 1], from its eight nodes as two pairs of
/// x-rows, `z0 = [r00, r01]` and `z1 = [r10, r11]` (`rYZ` the row at y + Y, z + Z, its two
/// nodes along x), at weights `f` of the second nodes: the lerps `a + (b − a)·t` along x, then
/// y, then z (`c00 = lerp(r00[0], r00[1], fx)`, …,
/// `lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz)`), the x-lerps and the y-lerps in
/// SSE lanes: lanes 0 and 2 of each register hold the two rows' first nodes, lanes 1 and 3
/// their second, so lerping each register against itself shifted down a lane leaves c00 and
/// c01 (c10 and c11) in lanes 0 and 2, and lerping the two results leaves both y-lerps there
/// (lanes 1 and 3 are never read). Each lane is the same f32 subtraction, product and sum, with
/// no fused multiply-add, so the same bits as the scalar lerps
/// (`trilinear_rows_is_the_scalar_lerps`); it takes the pairs as the two rows' 8-byte loads,
/// which scalar lerps would shuffle about.
#[inline(always)]
pub(super) fn trilinear_rows(z0: [f32; 4], z1: [f32; 4], [fx, fy, fz]: [f32; 3]) -> f32 {
    use wide::f32x4;
    let x = |r: [f32; 4]| {
        let a = f32x4::new(r);
        a + (f32x4::new([r[1], r[1], r[3], r[3]]) - a) * f32x4::splat(fx)
    };
    let (a, b) = (x(z0), x(z1));
    let d = (a + (b - a) * f32x4::splat(fy)).to_array();
    (d[0] + (d[2] - d[0]) * fz).clamp(0.0, 1.0)
}

impl Dataset {
    /// The trilinear cell of object point `p` in f32 index arithmetic: first node and weight of
    /// the second per axis (for an axis of one node: (0, 0)).
    #[inline]
    pub(super) fn cell32(&self, p: [f32; 3]) -> ([usize; 3], [f32; 3]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(lanes) = &self.lanes {
            return Self::cell_in_lanes(p, lanes).0;
        }
        self.cell32_scalar(p)
    }

    /// [`Dataset::cell32`] where the cell's 4×4×4 neighbourhood lies inside the grid (its first
    /// node at least 1 and its last at most n − 1 along every axis: 1 ≤ c ≤ n − 3); else
    /// `None`.
    #[inline]
    pub(super) fn interior_cell32(&self, p: [f32; 3]) -> Option<([usize; 3], [f32; 3])> {
        #[cfg(target_arch = "x86_64")]
        if let Some(lanes) = &self.lanes {
            let (cell, interior) = Self::cell_in_lanes(p, lanes);
            return interior.then_some(cell);
        }
        let [nx, ny, nz] = self.dims;
        let ([x0, y0, z0], f) = self.cell32_scalar(p);
        let inside = |c: usize, n: usize| c >= 1 && c + 3 <= n;
        (inside(x0, nx) && inside(y0, ny) && inside(z0, nz)).then_some(([x0, y0, z0], f))
    }

    /// The three axes in SSE lanes: the same operations as [`Dataset::cell32_scalar`], so the
    /// same numbers (a zero weight may come out +0 where the scalar path gives −0). max(u, 0)
    /// (`maxps`) gives 0 for NaN as `f32::max` does; u ≤ n − 1 ≤ 2²⁴ converts exactly; and
    /// truncating min(u, n − 2) is min(truncation, n − 2), n − 2 being an integer. Also whether
    /// the cell is interior: its first node c = trunc(cu), cu = min(u, n − 2) ≥ 0, has
    /// 1 ≤ c ≤ n − 3 exactly when 1 ≤ cu < n − 2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn cell_in_lanes(
        p: [f32; 3],
        [last, top, inner]: &[[f32; 4]; 3],
    ) -> (([usize; 3], [f32; 3]), bool) {
        use wide::{f32x4, i32x4};
        let last = f32x4::new(*last);
        let u = (f32x4::new([p[0], p[1], p[2], 0.0]) * last)
            .fast_max(f32x4::ZERO)
            .fast_min(last);
        let cu = u.fast_min(f32x4::new(*top));
        let interior = (cu.simd_ge(f32x4::new([1.0, 1.0, 1.0, 0.0]))
            & cu.simd_lt(f32x4::new(*inner)))
        .to_bitmask()
            == 0b1111;
        let c: i32x4 = cu.fast_trunc_int();
        let f = (u - c.round_float()).to_array();
        // c ≥ 0 (cu ≥ 0), so through u32 (no sign extension) it is the same index.
        let c = c.to_array().map(|c| c as u32 as usize);
        (([c[0], c[1], c[2]], [f[0], f[1], f[2]]), interior)
    }

    /// [`Dataset::cell32`] axis by axis.
    #[inline]
    pub(super) fn cell32_scalar(&self, p: [f32; 3]) -> ([usize; 3], [f32; 3]) {
        let mut i = [0usize; 3];
        let mut f = [0f32; 3];
        for axis in 0..3 {
            let last = self.last32[axis];
            // max/min in this order map NaN to 0; for n = 1, last = 0 and the cell is (0, 0).
            // u ≥ 0, so its truncation is its floor and at least 0.
            let u = (p[axis] * last).max(0.0).min(last);
            let c = (u as i32).min(self.top32[axis]);
            i[axis] = c as usize;
            f[axis] = u - c as f32;
        }
        (i, f)
    }

    /// Trilinear interpolation, specialised for speed: f32 index arithmetic (its rounding,
    /// below 2⁻¹⁶ of a voxel for grids under 512 nodes a side, is far below anything visible),
    /// i32 conversions, and the cell's nodes read as four x-pairs (one bounds check each).
    /// 0 where the dataset does not [cover](Dataset::covers) `p`.
    #[inline]
    pub(crate) fn trilinear(&self, p: [f32; 3]) -> f32 {
        self.trilinear_in(p, None)
    }

    #[inline(always)]
    pub(super) fn trilinear_in(&self, p: [f32; 3], mask: Option<&CellMask>) -> f32 {
        if !self.covers(p) {
            return 0.0;
        }
        let (cell, f) = self.cell32(p);
        let base = self.node_index(cell);
        if mask.is_some_and(|m| !m.may_reach(base)) {
            return 0.0;
        }
        let rows = (self.strides[1], self.strides[2]);
        self.trilinear_cell(base, rows, f, self.strides[0] == 1)
            .unwrap_or(0.0)
    }

    /// The trilinear value in the cell whose first node has index `base`, at weights `f` of
    /// its second nodes (the callers test the cell mask first). `unit_x`: whether the x-stride
    /// is 1 (else 0, an axis of one node), given by the caller so that a loop over cells tests
    /// it once. `None` where the cell's nodes are not all in the node values or voxels, which
    /// never happens (the cell lies inside the grid): the caller keeps its 0 then, so no 0 is
    /// made in a register for that path on every cell.
    #[inline(always)]
    pub(super) fn trilinear_cell(
        &self,
        base: usize,
        (sy, sz): (usize, usize),
        f: [f32; 3],
        unit_x: bool,
    ) -> Option<f32> {
        // Where the node values are made they are read; else the cell's voxels, each through
        // the table of the normalisation (the node values' own, bit for bit), so that a
        // value does not make the node values (four bytes a voxel).
        match (self.values.get(), &self.raw) {
            (Some(v), _) => cell_of(v, base, (sy, sz), f, unit_x, |&x| x),
            (None, Voxels::U8(raw)) => {
                let table = &*self.table8;
                cell_of(raw, base, (sy, sz), f, unit_x, |&x| table[x as usize])
            }
            (None, Voxels::U16(raw)) => {
                let table = self.table16()?;
                cell_of(raw, base, (sy, sz), f, unit_x, |&x| table[x as usize])
            }
        }
    }

    /// The trilinear gradient where all the nodes it reads are interior (central differences
    /// everywhere): the same value as the generic path, with the 4×4×4 neighbourhood of the cell
    /// read as its twelve x-rows that are needed (under the bounds checks of the two furthest).
    #[inline]
    pub(super) fn trilinear_gradient_interior(
        &self,
        p: [f32; 3],
        cache: &mut CellGradients,
    ) -> Option<[f64; 3]> {
        let (cell, f) = self.interior_cell32(p)?;
        self.trilinear_gradient_at::<true>(self.neighbourhood_lo(cell), f, cache)
    }

    /// [`Dataset::trilinear_gradient_interior`] in the interior cell whose neighbourhood starts
    /// at node `lo` (see [`Dataset::neighbourhood_lo`]), at weights `f` of its second nodes.
    /// Without `SIGNED_ZEROS`, a component whose sum of products is −0 may come out −0
    /// instead of +0 (nothing else differs; see below).
    #[inline(always)]
    pub(super) fn trilinear_gradient_at<const SIGNED_ZEROS: bool>(
        &self,
        lo: usize,
        [fx, fy, fz]: [f32; 3],
        cache: &mut CellGradients,
    ) -> Option<[f64; 3]> {
        if cache.lo != lo {
            debug_assert!(self.strides.iter().all(|&s| s <= u32::MAX as usize));
            let (sy, sz) = (
                self.strides[1] as u32 as usize,
                self.strides[2] as u32 as usize,
            );
            let lo = u32::try_from(lo).ok()? as usize;
            // Whether the neighbourhood's last row (3, 3), not itself read, lies inside `len`
            // nodes: the node indices and strides are below 2³² (a dataset has at most 2³²
            // nodes, and a stride of more than one node spans at most half of them), given as
            // such, so no sum overflows, and the compiler derives every row's bounds check
            // from this one test (the rows grow with j and k). An interior cell's
            // neighbourhood lies inside the grid.
            let inside = |len: usize| lo + 3 * sy + 3 * sz + 4 <= len;
            // Where the node values are made they are read; else a row's four node values are
            // its voxels' entries in the table of the normalisation (the node values' own, bit
            // for bit), so that a gradient does not make them (four bytes a voxel) and reads a
            // quarter (8-bit) or half (16-bit) of their bytes.
            match (self.values.get(), &self.raw) {
                (Some(v), _) => {
                    if !inside(v.len()) {
                        return None;
                    }
                    differences(cache, lo, (sy, sz), |o| v.get(o..o + 4)?.try_into().ok())?
                }
                (None, Voxels::U8(raw)) => {
                    if !inside(raw.len()) {
                        return None;
                    }
                    let table = &*self.table8;
                    differences(cache, lo, (sy, sz), |o| {
                        let r: &[u8; 4] = raw.get(o..o + 4)?.try_into().ok()?;
                        Some(r.map(|x| table[x as usize]))
                    })?
                }
                (None, Voxels::U16(raw)) => {
                    if !inside(raw.len()) {
                        return None;
                    }
                    let table = self.table16()?;
                    differences(cache, lo, (sy, sz), |o| {
                        let r: &[u16; 4] = raw.get(o..o + 4)?.try_into().ok()?;
                        Some(r.map(|x| table[x as usize]))
                    })?
                }
            }
            cache.lo = lo;
        }
        // Trilinear weights of the cell's corners, in the order x fastest: the products
        // (wx·wy)·wz, four at a time in lanes.
        let (gx, gy, gz) = (1.0 - fx, 1.0 - fy, 1.0 - fz);
        let xy = wide::f32x4::new([gx, fx, gx, fx]) * wide::f32x4::new([gy, gy, fy, fy]);
        let near = (xy * wide::f32x4::splat(gz)).to_array();
        let far = (xy * wide::f32x4::splat(fz)).to_array();
        let weights = [
            near[0], near[1], near[2], near[3], far[0], far[1], far[2], far[3],
        ];
        // The three axes in the lanes of one register, each summed corner by corner in order
        // (as a scalar loop would).
        // The products summed from the first, not from a 0: ((0 + p0) + p1) + … differs from
        // (p0 + p1) + … only where a partial sum is −0 (which 0 + makes +0), and from then on
        // only there; so the first is the second plus +0 (which turns −0 into +0 and leaves
        // every other number as it is). Without `SIGNED_ZEROS` that last sum is left out.
        let p = |c: usize| wide::f32x4::splat(weights[c]) * wide::f32x4::new(cache.diffs[c]);
        let g = p(0) + p(1) + p(2) + p(3) + p(4) + p(5) + p(6) + p(7);
        let g = if SIGNED_ZEROS {
            g + wide::f32x4::ZERO
        } else {
            g
        };
        // 0.5·g·(n − 1) in f64, as g·(0.5·(n − 1)): halving is exact in both orders (g is
        // an f32, far from f64's subnormals), so both are the one rounding of the same product.
        // (The lanes hold y, z, x.)
        let g = g.to_array();
        Some([
            g[2] as f64 * self.half_last[0],
            g[0] as f64 * self.half_last[1],
            g[1] as f64 * self.half_last[2],
        ])
    }

    /// The first node of the 4×4×4 neighbourhood of an interior cell (first node at least 1
    /// along every axis; see [`Dataset::interior_cell32`]): the key of [`CellGradients`].
    #[inline]
    pub(super) fn neighbourhood_lo(&self, cell: [usize; 3]) -> usize {
        // node_index(cell − (1, 1, 1)), without the three subtractions: the cell's first node
        // is at least 1 along every axis, so no step wraps.
        self.node_index(cell) - self.lo_offset
    }
}

/// Fills `cache` with the central differences (per grid step) at the eight nodes of the cell
/// whose 4×4×4 neighbourhood starts at node `lo` (strides `sy`, `sz`; see
/// [`Dataset::trilinear_gradient_at`]), reading each x-row of four node values that it needs
/// by `row(first node)`; `None` where a row is not there (never, for an interior cell).
#[inline(always)]
fn differences(
    cache: &mut CellGradients,
    lo: usize,
    (sy, sz): (usize, usize),
    row: impl Fn(usize) -> Option<[f32; 4]>,
) -> Option<()> {
    // Row (j, k) holds nodes x0 − 1 … x0 + 2 at y0 − 1 + j, z0 − 1 + k; the corner rows of the
    // neighbourhood are never read.
    let row = |j: usize, k: usize| row(lo + j * sy + k * sz);
    let (r10, r20) = (row(1, 0)?, row(2, 0)?);
    let (r01, r11, r21, r31) = (row(0, 1)?, row(1, 1)?, row(2, 1)?, row(3, 1)?);
    let (r02, r12, r22, r32) = (row(0, 2)?, row(1, 2)?, row(2, 2)?, row(3, 2)?);
    let (r13, r23) = (row(1, 3)?, row(2, 3)?);
    // Per corner row (j, k) of the cell (j, k in {1, 2}, y fastest): its row, the rows below
    // and above it in y, and the rows below and above it in z. Each gives two corners (x
    // nodes 1 and 2 of the row) their central differences (per grid step) along x, y and z.
    let corners = [
        (r11, r01, r21, r10, r12),
        (r21, r11, r31, r20, r22),
        (r12, r02, r22, r11, r13),
        (r22, r12, r32, r21, r23),
    ];
    // Row by row in lanes: the row differences in y and z (lanes 1 and 2: the row's two
    // corners, x nodes 1 and 2), and x nodes 2, 3 minus nodes 0, 1 (lanes 0 and 1); each
    // corner's three differences then gathered into one register, in the cache's order (y, z,
    // x) (lane 3 is not read).
    use wide::f32x4;
    for (c, (r, ym, yp, zm, zp)) in corners.into_iter().enumerate() {
        let dy = (f32x4::new(yp) - f32x4::new(ym)).to_array();
        let dz = (f32x4::new(zp) - f32x4::new(zm)).to_array();
        let dx = (f32x4::new([r[2], r[3], r[2], r[3]]) - f32x4::new(r)).to_array();
        cache.diffs[2 * c] = [dy[1], dz[1], dx[0], dx[0]];
        cache.diffs[2 * c + 1] = [dy[2], dz[2], dx[1], dx[1]];
    }
    Some(())
}

/// [`Dataset::trilinear_cell`] of the nodes `v`, whose node values are `value(node)` (the node
/// values themselves, or voxels through their table).
#[inline(always)]
fn cell_of<T>(
    v: &[T],
    base: usize,
    (sy, sz): (usize, usize),
    f: [f32; 3],
    unit_x: bool,
    value: impl Fn(&T) -> f32,
) -> Option<f32> {
    if unit_x {
        // Four rows of two nodes along x, in the span [base, base + sz + sy + 2): the first
        // and last two nodes of its first sy + 2 and of its last sy + 2. Where base and the
        // strides are below 2³² (given as such) no sum overflows, and the span's bounds check
        // is the only one the compiler keeps.
        let rows = v.get(base..base + sz + sy + 2).and_then(|w| {
            let (lower, upper) = (w.get(..sy + 2)?, w.get(sz..)?);
            Some([
                lower.first_chunk::<2>()?,
                lower.last_chunk::<2>()?,
                upper.first_chunk::<2>()?,
                upper.last_chunk::<2>()?,
            ])
        });
        // (Always there: the cell lies inside the grid. The rows by reference: copied out as
        // arrays, they would be loaded through integer registers.)
        let [r00, r10, r01, r11] = rows?;
        let z0 = [
            value(&r00[0]),
            value(&r00[1]),
            value(&r01[0]),
            value(&r01[1]),
        ];
        let z1 = [
            value(&r10[0]),
            value(&r10[1]),
            value(&r11[0]),
            value(&r11[1]),
        ];
        Some(trilinear_rows(z0, z1, f))
    } else {
        // (sx = 0: an axis of one node.)
        let w = v.get(base..=base + sy + sz)?; // (always there, as above)
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let [fx, fy, fz] = f;
        let (w0, wy, wz, wyz) = (
            value(&w[0]),
            value(&w[sy]),
            value(&w[sz]),
            value(&w[sz + sy]),
        );
        let (c00, c10, c01, c11) = (
            lerp(w0, w0, fx),
            lerp(wy, wy, fx),
            lerp(wz, wz, fx),
            lerp(wyz, wyz, fx),
        );
        Some(lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz).clamp(0.0, 1.0))
    }
}
