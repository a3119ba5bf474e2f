//! What a sample reads: the cell's nodes and the neighbours its gradient needs, either from
//! the dataset's f32 node values by per-lane loads clamped into the values ([`Nodes`], eight
//! lanes, or each half of sixteen) or from its 8-bit voxels by gathers of four bytes
//! ([`Raw8`], generic over [`Simd`]); the cell nodes and the gradient's differences of 16-bit
//! voxels by gathers of two voxels ([`Raw16`]); and the clamped gathers of tables
//! ([`gather`]). Not here: what is done with the values ([`step`], [`shade`]).

use super::*;

impl Packets<'_> {
    /// The central differences along x, y and z at the eight corners (a + 2b + 4c) of the
    /// cells whose first nodes are `base`, for the lanes of `inner` (whose 4³ neighbourhoods
    /// lie inside the grid), from the node values (cell nodes `nodes`, the others by per-lane
    /// loads): the node on the far side minus the node on the near side, one of them a cell
    /// node.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn differences(
        &self,
        base: __m256i,
        inner: u32,
        nodes: &[__m256; 8],
    ) -> [[__m256; 3]; 8] {
        let (sy, sz) = (self.sy, self.sz);
        // The neighbourhood's first node: the cell's less (1, 1, 1).
        let lo = _mm256_sub_epi32(base, _mm256_set1_epi32(1 + sy + sz));
        let lo = _mm256_and_si256(lo, _mm256_castps_si256(lanes_mask(inner)));
        let hood = Nodes::new(self.values, lo, 3 + 3 * sy + 3 * sz);
        let o = |j: i32, k: i32| 1 + j * sy + k * sz;
        // The nodes beside the cell: along y and z as x-pairs (the cell's two x nodes),
        // along x the first and last of the cell's rows of four.
        let two = |j0: i32, k0: i32, j1: i32, k1: i32| {
            let [a, b, c, d] = hood.pairs2(o(j0, k0), o(j1, k1));
            [(a, b), (c, d)]
        };
        let (ym, yp) = (two(0, 1, 0, 2), two(3, 1, 3, 2));
        let (zm, zp) = (two(1, 0, 2, 0), two(1, 3, 2, 3));
        let r = |b: i32, c: i32| hood.row4(o(1 + b, 1 + c) - 1);
        let rows = [r(0, 0), r(1, 0), r(0, 1), r(1, 1)];
        let (xm, xp) = (rows.map(|r| r[0]), rows.map(|r| r[3]));
        let pick = |p: (__m256, __m256), a: usize| if a == 0 { p.0 } else { p.1 };
        // (A loop, not a `from_fn` closure, which the compiler may leave out of line.)
        let mut d = [[_mm256_setzero_ps(); 3]; 8];
        for (k, dk) in d.iter_mut().enumerate() {
            let (a, b, cc) = (k & 1, k >> 1 & 1, k >> 2);
            let node = |a: usize, b: usize, cc: usize| nodes[a + 2 * b + 4 * cc];
            let row = b + 2 * cc;
            let dx = if a == 0 {
                _mm256_sub_ps(node(1, b, cc), xm[row])
            } else {
                _mm256_sub_ps(xp[row], node(0, b, cc))
            };
            let dy = if b == 0 {
                _mm256_sub_ps(node(a, 1, cc), pick(ym[cc], a))
            } else {
                _mm256_sub_ps(pick(yp[cc], a), node(a, 0, cc))
            };
            let dz = if cc == 0 {
                _mm256_sub_ps(node(a, b, 1), pick(zm[b], a))
            } else {
                _mm256_sub_ps(pick(zp[b], a), node(a, b, 0))
            };
            *dk = [dx, dy, dz];
        }
        d
    }
}

/// A dataset's 8-bit voxels, where its normalisation `(v − a)/(b − a)` maps every byte into
/// [0, 1] (so it never clamps, and is linear): the packet march reads the voxels themselves,
/// four to a 32-bit lane by gathers, a quarter of the node values' memory, and normalises a
/// sample's interpolated value once (`raw·scale + offset`) and its gradient by `scale`
/// (the differences of bytes are exact integers). The node values are the voxels'
/// normalisations in f64 rounded to f32, so a sample's value differs from the value
/// interpolated from those by f32 rounding: relative errors of a few 10⁻⁷ (the packet march's
/// tolerance against the scalar march, `tests/packets.rs`).
pub(super) struct Raw8<'a> {
    pub(super) raw: &'a [u8],
    pub(super) scale: f32,
    pub(super) offset: f32,
}

impl<'a> Raw8<'a> {
    /// The voxels of `data`, where they are 8-bit and its normalisation maps 0 and 255 into
    /// [0, 1] (every byte between, then: the normalisation is monotone).
    pub(super) fn of(data: &'a Dataset) -> Option<Raw8<'a>> {
        let Voxels::U8(raw) = data.raw() else {
            return None;
        };
        let (a, b) = data.range();
        let (a, b) = (a as f64, b as f64);
        let norm = |v: f64| (v - a) / (b - a);
        let inside = |x: f64| (0.0..=1.0).contains(&x);
        if !(inside(norm(0.0)) && inside(norm(255.0))) || raw.len() >= i32::MAX as usize / 2 {
            return None;
        }
        Some(Raw8 {
            raw,
            scale: (1.0 / (b - a)) as f32,
            offset: (-a / (b - a)) as f32,
        })
    }

    /// The central rows of the cells whose first nodes are `base`, for the lanes of `live`:
    /// for (b, c) in (0, 0), (1, 0), (0, 1), (1, 1), the four voxels x0 − 1 … x0 + 2 of row
    /// y0 + b, z0 + c, one per byte (the lowest first). A lane whose row reaches past either
    /// end of the voxels (the very first cell, or the last) is read voxel by voxel, with 0
    /// past the end (only interior cells, whose rows lie inside, read the outer two).
    #[inline(always)]
    pub(super) fn central_rows<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        base: S::I,
        live: u32,
        sy: i32,
        sz: i32,
    ) -> Rows<S::I> {
        let span = sy + sz + 3;
        assert!(sy >= 0 && sz >= 0 && (span as usize) < self.raw.len());
        let first = s.sub_i(base, s.splat_i(1));
        let hi = s.splat_i(self.raw.len() as i32 - 1 - span);
        let at = s.min_i(s.max_i(first, s.zero_i()), hi);
        let kept = s.bits(s.eq_i(at, first));
        if !kept & live != 0 {
            let mut lanes = [0i32; N];
            s.st_i(&mut lanes, first);
            let words = self.rows_one_by_one(&lanes, central_offsets(sy, sz));
            return Rows {
                r: [
                    s.ld_i(&words[0]),
                    s.ld_i(&words[1]),
                    s.ld_i(&words[2]),
                    s.ld_i(&words[3]),
                ],
            };
        }
        let mut r = [at; 4];
        for (w, off) in r.iter_mut().zip(central_offsets(sy, sz)) {
            // SAFETY: every lane of `at` is in [0, len − 4 − sy − sz] (clamped above, a range
            // that is not empty: asserted) and 0 ≤ off ≤ sy + sz, so every lane of
            // `at + off` is in [0, len − 4].
            *w = unsafe { s.gather_bytes(self.raw, s.add_i(at, s.splat_i(off))) };
        }
        Rows { r }
    }

    /// [`Raw8::central_rows`] voxel by voxel: the four voxels from `first + off` per lane
    /// and offset (lane by lane, `first` by lane), 0 where one lies outside.
    #[cold]
    #[inline(never)]
    fn rows_one_by_one<const N: usize>(&self, first: &[i32; N], offs: [i32; 4]) -> [[i32; N]; 4] {
        let byte = |i: i64| -> u32 {
            usize::try_from(i)
                .ok()
                .and_then(|i| self.raw.get(i))
                .map_or(0, |&v| v as u32)
        };
        offs.map(|off| {
            std::array::from_fn(|lane| {
                let i = first[lane] as i64 + off as i64;
                (0..4).fold(0u32, |w, k| w | byte(i + k) << (8 * k)) as i32
            })
        })
    }

    /// The central differences along x, y and z at the eight corners (a + 2b + 4c) of the
    /// cells whose first nodes are `base` and central rows `rows`, for the lanes of `inner`
    /// (whose 4³ neighbourhoods lie inside the grid), in raw voxels: exact integers, as f32.
    /// The rows beside the cell along y and z by eight more gathers (two voxels of each).
    #[inline(always)]
    pub(super) fn differences<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        rows: &Rows<S::I>,
        base: S::I,
        inner: u32,
        sy: i32,
        sz: i32,
    ) -> [[S::F; 3]; 8] {
        assert!(self.raw.len() >= 4);
        let base = s.keep_i(inner, base);
        let hi = s.splat_i(self.raw.len() as i32 - 4);
        let zero = s.zero_i();
        let mut side = [zero; 8];
        // Rows y0 − 1 and y0 + 2 at z0 + c, rows z0 − 1 and z0 + 2 at y0 + b (from x0): the
        // index clamped (a no-op for an interior cell's lane).
        for (w, off) in side.iter_mut().zip(side_offsets(sy, sz)) {
            let at = s.add_i(base, s.splat_i(off));
            // SAFETY: every lane of the index is clamped to [0, len − 4] (len ≥ 4: asserted).
            *w = unsafe { s.gather_bytes(self.raw, s.min_i(s.max_i(at, zero), hi)) };
        }
        // Byte k of a row as i32: node x0 + a is byte 1 + a of a central row, byte a of a
        // side row.
        let mut rb = [[zero; 4]; 4];
        for (b, &x) in rb.iter_mut().zip(&rows.r) {
            *b = [
                s.byte::<0>(x),
                s.byte::<1>(x),
                s.byte::<2>(x),
                s.byte::<3>(x),
            ];
        }
        let mut two = [[zero; 2]; 8];
        for (t, &w) in two.iter_mut().zip(&side) {
            *t = [s.byte::<0>(w), s.byte::<1>(w)];
        }
        central_differences(s, &rb, two)
    }
}

/// A dataset's 16-bit voxels, where its normalisation `(v − a)/(b − a)` maps every voxel of the
/// grid into [0, 1] (so it clamps none, and is linear over them): the gradient's central
/// differences are read from the voxels themselves, as exact integers, and scaled once by the
/// normalisation's slope ([`Raw16::differences`]), where the node values' differences would
/// subtract two rounded f32 (an error of up to an f32 ulp of the value, against a difference
/// that a smooth scan's neighbours make thousands of times smaller). A cell's nodes are the
/// voxels normalised in f32 lanes, `(v − a)/(b − a)`, where that gives the node values' bits
/// (the quotient in f64 rounded to f32) for every voxel from the grid's smallest to its
/// largest, checked one by one against the table of node values ([`Raw16::cell_nodes`]);
/// else they come through the table ([`NodeValues::U16`]).
pub(super) struct Raw16<'a> {
    /// The voxels' bytes, two a voxel, the low byte first (little-endian: x86-64's order).
    bytes: &'a [u8],
    pub(super) scale: f32,
    /// a and b − a as f32, where the lanes' normalisation gives the node values' bits.
    exact: Option<(f32, f32)>,
}

impl<'a> Raw16<'a> {
    /// The 16-bit voxels of `data`, where its normalisation maps its smallest and largest
    /// voxel (`extremes`, those of its brick ranges) into [0, 1] and the voxels' bytes are
    /// fewer than 2³¹ (every byte offset an i32; `Packets::new` asks that of every march).
    pub(super) fn of(data: &'a Dataset, extremes: (f64, f64)) -> Option<Raw16<'a>> {
        let Voxels::U16(raw) = data.raw() else {
            return None;
        };
        let (a, b) = data.range();
        let (a, b) = (a as f64, b as f64);
        let norm = |v: f64| (v - a) / (b - a);
        let inside = |x: f64| (0.0..=1.0).contains(&x);
        if !(inside(norm(extremes.0)) && inside(norm(extremes.1)))
            || raw.len() >= i32::MAX as usize / 2
        {
            return None;
        }
        // SAFETY: a u16 slice's memory is 2·len initialised bytes, and u8 has no alignment.
        let bytes = unsafe { std::slice::from_raw_parts(raw.as_ptr().cast::<u8>(), 2 * raw.len()) };
        // (The extremes are voxels: integers in [0, 65535], exact in f32 as is v − a where a is
        // an integer below 2²⁴ in magnitude; the check does not rely on it.)
        let (lo, hi) = (extremes.0 as usize, extremes.1 as usize);
        let (a32, d32) = (data.range().0, data.range().1 - data.range().0);
        let exact = data.table16().and_then(|table| {
            let same = (lo..=hi).all(|v| ((v as f32 - a32) / d32).to_bits() == table[v].to_bits());
            same.then_some((a32, d32))
        });
        Some(Raw16 {
            bytes,
            scale: (1.0 / (b - a)) as f32,
            exact,
        })
    }

    /// Whether [`Raw16::cell_nodes`] gives the node values.
    pub(super) fn exact(&self) -> bool {
        self.exact.is_some()
    }

    /// The eight nodes (a + 2b + 4c: x0 + a of row y0 + b, z0 + c) of the cells whose first
    /// nodes are `base` (every lane's cell inside the grid, or `base` 0): the node values,
    /// bit for bit, where [`Raw16::exact`] (else 0), from one 32-bit gather of the two
    /// voxels of each row.
    #[inline(always)]
    pub(super) fn cell_nodes<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        base: S::I,
        sy: i32,
        sz: i32,
    ) -> [S::F; 8] {
        let Some((a, d)) = self.exact else {
            return [s.zero(); 8];
        };
        let base = s.add_i(base, base);
        let (a, d) = (s.splat(a), s.splat(d));
        let mut n = [s.zero(); 8];
        for (row, off) in central_offsets(sy, sz).into_iter().enumerate() {
            for (x, v) in self.pair(s, base, off).into_iter().enumerate() {
                // `(v − a)/(b − a)` in f32: the node value (`exact`).
                n[2 * row + x] = s.div(s.sub(s.to_f(v), a), d);
            }
        }
        n
    }

    /// The voxels `at + off` and `at + off + 1` of each lane of voxel indices `at` (as byte
    /// offsets, `2·at`), from one 32-bit gather clamped into the voxels (a no-op where both
    /// lie inside), as the word's low and high half.
    #[inline(always)]
    fn pair<S: Simd<N>, const N: usize>(&self, s: S, at: S::I, off: i32) -> [S::I; 2] {
        assert!(self.bytes.len() >= 4);
        let hi = s.splat_i(self.bytes.len() as i32 - 4);
        let at = s.min_i(s.max_i(s.add_i(at, s.splat_i(2 * off)), s.zero_i()), hi);
        // SAFETY: every lane of `at` is in [0, 2·len − 4] (2·len ≥ 4: asserted).
        let w = unsafe { s.gather_bytes(self.bytes, at) };
        [s.and_i(w, s.splat_i(0xFFFF)), s.srlv_i(w, s.splat_i(16))]
    }

    /// The central differences along x, y and z at the eight corners (a + 2b + 4c) of the
    /// cells whose first nodes are `base`, for the lanes of `inner` (whose 4³ neighbourhoods
    /// lie inside the grid), in raw voxels: exact integers, as f32 (the same nodes and
    /// subtractions as [`Raw8::differences`]). Each central row's four voxels by two gathers
    /// of two, each row beside the cell by one.
    #[inline(always)]
    pub(super) fn differences<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        base: S::I,
        inner: u32,
        sy: i32,
        sz: i32,
    ) -> [[S::F; 3]; 8] {
        // Voxel index → byte offset (`Raw16::of`: every one an i32).
        let base = s.add_i(s.keep_i(inner, base), s.keep_i(inner, base));
        let zero = s.zero_i();
        // Two voxels a lane from voxel `base + off` (`Raw16::pair`: clamped, a no-op for an
        // interior cell's lane). (Loops, not closures, which the compiler may leave out of
        // line, without this function's target features.)
        let mut offs = [0i32; 16];
        for (r, off) in central_offsets(sy, sz).into_iter().enumerate() {
            (offs[2 * r], offs[2 * r + 1]) = (off - 1, off + 1);
        }
        offs[8..].copy_from_slice(&side_offsets(sy, sz));
        let mut halves = [[zero; 2]; 16];
        for (h, off) in halves.iter_mut().zip(offs) {
            *h = self.pair(s, base, off);
        }
        // Central row (b, c): voxels x0 − 1 … x0 + 2; then rows y0 − 1 and y0 + 2 at z0 + c,
        // rows z0 − 1 and z0 + 2 at y0 + b: voxels x0, x0 + 1.
        let mut rb = [[zero; 4]; 4];
        for (r, row) in rb.iter_mut().enumerate() {
            let ([v0, v1], [v2, v3]) = (halves[2 * r], halves[2 * r + 1]);
            *row = [v0, v1, v2, v3];
        }
        let mut two = [[zero; 2]; 8];
        two.copy_from_slice(&halves[8..]);
        central_differences(s, &rb, two)
    }
}

/// The central differences along x, y and z at the eight corners (a + 2b + 4c) of a cell from
/// its voxels as i32 lanes ([`Raw8::differences`], [`Raw16::differences`]): `rb[b + 2c]` the
/// voxels x0 − 1 … x0 + 2 of central row y0 + b, z0 + c; `two` the voxels x0, x0 + 1 of rows
/// y0 − 1 and y0 + 2 at z0 + c, then of rows z0 − 1 and z0 + 2 at y0 + b ([`side_offsets`]).
/// Exact integers, as f32.
#[inline(always)]
fn central_differences<S: Simd<N>, const N: usize>(
    s: S,
    rb: &[[S::I; 4]; 4],
    two: [[S::I; 2]; 8],
) -> [[S::F; 3]; 8] {
    let [ym0, ym1, yp0, yp1, zm0, zm1, zp0, zp1] = two;
    let (ym, yp, zm, zp) = ([ym0, ym1], [yp0, yp1], [zm0, zm1], [zp0, zp1]);
    let mut d = [[s.zero(); 3]; 8];
    for (k, dk) in d.iter_mut().enumerate() {
        let (a, b, c) = (k & 1, k >> 1 & 1, k >> 2);
        let row = &rb[b + 2 * c];
        let dx = s.sub_i(row[2 + a], row[a]);
        let dy = if b == 0 {
            s.sub_i(rb[1 + 2 * c][1 + a], ym[c][a])
        } else {
            s.sub_i(yp[c][a], rb[2 * c][1 + a])
        };
        let dz = if c == 0 {
            s.sub_i(rb[b + 2][1 + a], zm[b][a])
        } else {
            s.sub_i(zp[b][a], rb[b][1 + a])
        };
        *dk = [s.to_f(dx), s.to_f(dy), s.to_f(dz)];
    }
    d
}

/// The central rows of a packet's cells ([`Raw8::central_rows`]): four voxels a lane, in its
/// bytes, in registers `I` of i32 lanes.
pub(super) struct Rows<I> {
    pub(super) r: [I; 4],
}

impl<I: Copy> Rows<I> {
    /// The eight cell nodes (a + 2b + 4c: x0 + a of row (b, c), its byte 1 + a) as f32.
    #[inline(always)]
    pub(super) fn cell_nodes<S: Simd<N, I = I>, const N: usize>(&self, s: S) -> [S::F; 8] {
        let mut n = [s.zero(); 8];
        for (k, n) in n.iter_mut().enumerate() {
            let w = self.r[k >> 1];
            *n = s.to_f(if k & 1 == 0 {
                s.byte::<1>(w)
            } else {
                s.byte::<2>(w)
            });
        }
        n
    }
}

/// The offsets of a cell's four central rows (y0 + b, z0 + c for b + 2c = 0 … 3) from its
/// first node's row, for node strides `sy`, `sz` ([`Raw8::central_rows`]).
pub(super) fn central_offsets(sy: i32, sz: i32) -> [i32; 4] {
    [0, sy, sz, sy + sz]
}

/// The offsets of the rows beside a cell that its gradient's differences read, from its
/// first node: rows y0 − 1 and y0 + 2 at z0 + c (c = 0, 1), then rows z0 − 1 and z0 + 2 at
/// y0 + b (b = 0, 1) ([`Raw8::differences`]).
pub(super) fn side_offsets(sy: i32, sz: i32) -> [i32; 8] {
    [
        -sy,
        -sy + sz,
        2 * sy,
        2 * sy + sz,
        -sz,
        sy - sz,
        2 * sz,
        sy + 2 * sz,
    ]
}

/// Eight node indices into `values`, each clamped so that it and every index up to `span`
/// past it lie inside the slice: [`Nodes::row4`] and [`Nodes::pairs2`] of offsets within
/// `0..=span` then read inside it in every lane.
pub(super) struct Nodes<'a> {
    pub(super) values: NodeValues<'a>,
    pub(super) at: __m256i,
    pub(super) span: i32,
}

/// Where the eight-lane march (and each half of the sixteen-lane one) reads node values: the
/// dataset's f32 node values, or its 16-bit voxels through the table of their normalised
/// values (`Dataset::table16`, entry v the node value of voxel v: the same f32, without the
/// node values' four bytes a voxel).
#[derive(Clone, Copy)]
pub(super) enum NodeValues<'a> {
    F32(&'a [f32]),
    U16(&'a [u16], &'a [f32; 1 << 16]),
}

impl NodeValues<'_> {
    /// The number of nodes.
    pub(super) fn len(&self) -> usize {
        match self {
            NodeValues::F32(v) => v.len(),
            NodeValues::U16(r, _) => r.len(),
        }
    }
}

impl<'a> Nodes<'a> {
    /// `at` clamped to `[0, values.len() − 1 − span]` (`values.len() > span`, which
    /// [`Packets::new`] ensures: every axis has at least 4 nodes; asserted all the same).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn new(values: NodeValues<'a>, at: __m256i, span: i32) -> Nodes<'a> {
        let len = values.len();
        assert!(span >= 0 && (span as usize) < len && len <= i32::MAX as usize);
        let hi = _mm256_set1_epi32((len - 1) as i32 - span);
        let at = _mm256_min_epi32(_mm256_max_epi32(at, _mm256_setzero_si256()), hi);
        Nodes { values, at, span }
    }
}

impl Nodes<'_> {
    /// The node values of the 16-bit voxels at `at + off` and `at + off + 1` per lane, through
    /// their table: one gather of 32 bits at each lane's voxel `at + off` (the two voxels, low
    /// and high half), then a gather of the table at each.
    ///
    /// # Safety
    /// `raw` must be this `Nodes`' voxels and `0 ≤ off < span`, so that both voxels lie inside
    /// `raw` (`at` is in [0, len − 1 − span], `Nodes::new`); the processor must have AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn voxel_pairs(&self, raw: &[u16], table: &[f32; 1 << 16], off: i32) -> [__m256; 2] {
        debug_assert!(off >= 0 && off < self.span);
        let at = _mm256_add_epi32(self.at, _mm256_set1_epi32(off));
        // SAFETY: the four bytes at voxel at + off are voxels at + off and at + off + 1, both in
        // `raw` (the caller's bound); a gather has no alignment requirement. Every index into
        // the table is a u16, below its 2^16 entries.
        unsafe {
            let both = _mm256_i32gather_epi32::<2>(raw.as_ptr() as *const i32, at);
            let lo = _mm256_and_si256(both, _mm256_set1_epi32(0xFFFF));
            let hi = _mm256_srli_epi32::<16>(both);
            [
                _mm256_i32gather_ps::<4>(table.as_ptr(), lo),
                _mm256_i32gather_ps::<4>(table.as_ptr(), hi),
            ]
        }
    }

    /// `values[at + off + k]` for k in 0..4, per lane, as four registers (register k holds
    /// the k-th of each lane's four): a 16-byte load per lane, then a transposition.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn row4(&self, off: i32) -> [__m256; 4] {
        assert!(off >= 0 && off + 3 <= self.span);
        if let NodeValues::U16(r, t) = self.values {
            // SAFETY: the nodes at + off … at + off + 3 lie inside `r` (as below).
            let [n0, n1] = unsafe { self.voxel_pairs(r, t, off) };
            let [n2, n3] = unsafe { self.voxel_pairs(r, t, off + 2) };
            return [n0, n1, n2, n3];
        }
        let at = self.indices();
        let off = off as usize;
        let lane = |i: usize| match self.values {
            // SAFETY: `at[i]` is in [0, len − 1 − span] (`Nodes::new`) and
            // 0 ≤ off ≤ span − 3, so the four f32 at `at[i] + off` lie inside `values`.
            NodeValues::F32(v) => unsafe { _mm_loadu_ps(v.as_ptr().add(at[i] + off)) },
            NodeValues::U16(..) => unreachable!("read above"),
        };
        transpose(std::array::from_fn(|i| {
            _mm256_set_m128(lane(i + 4), lane(i))
        }))
    }

    /// `values[at + a]`, `values[at + a + 1]`, `values[at + b]`, `values[at + b + 1]` per
    /// lane, as four registers: two 8-byte loads per lane, then a transposition.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn pairs2(&self, a: i32, b: i32) -> [__m256; 4] {
        assert!(a >= 0 && b >= 0 && a < self.span && b < self.span);
        if let NodeValues::U16(r, t) = self.values {
            // SAFETY: the nodes at + a, at + a + 1, at + b, at + b + 1 lie inside `r` (below).
            let [n0, n1] = unsafe { self.voxel_pairs(r, t, a) };
            let [n2, n3] = unsafe { self.voxel_pairs(r, t, b) };
            return [n0, n1, n2, n3];
        }
        let at = self.indices();
        let (a, b) = (a as usize, b as usize);
        let lane = |i: usize| match self.values {
            // SAFETY: `at[i]` is in [0, len − 1 − span] and 0 ≤ a, b < span, so the two
            // nodes at `at[i] + a` and the two at `at[i] + b` lie inside `values`; the loads
            // have no alignment requirement.
            NodeValues::F32(v) => unsafe {
                let p = v.as_ptr();
                let lo = _mm_castpd_ps(_mm_load_sd(p.add(at[i] + a) as *const f64));
                _mm_castpd_ps(_mm_loadh_pd(
                    _mm_castps_pd(lo),
                    p.add(at[i] + b) as *const f64,
                ))
            },
            NodeValues::U16(..) => unreachable!("read above"),
        };
        transpose(std::array::from_fn(|i| {
            _mm256_set_m128(lane(i + 4), lane(i))
        }))
    }

    /// The lanes of `at` as an array of indices (each in [0, len − 1 − span], `Nodes::new`;
    /// as usize, so that an offset is added without a sign extension per load).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn indices(&self) -> [usize; W] {
        let mut a = [0i32; W];
        // SAFETY: `a` is 8 i32, 32 writable bytes; the store has no alignment requirement.
        unsafe { _mm256_storeu_si256(a.as_mut_ptr() as *mut __m256i, self.at) };
        a.map(|x| x as u32 as usize)
    }
}

/// Four registers of lanes (i, i + 4) in their halves, four numbers each, transposed: register
/// k holds number k of lanes 0 to 7.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn transpose(y: [__m256; 4]) -> [__m256; 4] {
    let t0 = _mm256_unpacklo_ps(y[0], y[1]);
    let t1 = _mm256_unpackhi_ps(y[0], y[1]);
    let t2 = _mm256_unpacklo_ps(y[2], y[3]);
    let t3 = _mm256_unpackhi_ps(y[2], y[3]);
    [
        _mm256_shuffle_ps::<0x44>(t0, t2),
        _mm256_shuffle_ps::<0xEE>(t0, t2),
        _mm256_shuffle_ps::<0x44>(t1, t3),
        _mm256_shuffle_ps::<0xEE>(t1, t3),
    ]
}

/// `idx` with each lane clamped to `[0, len − 1]` (`len` not 0, at most `i32::MAX`): the
/// indices every gather below reads through.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn clamped(len: usize, idx: __m256i) -> __m256i {
    assert!(len != 0 && len <= i32::MAX as usize);
    let hi = _mm256_set1_epi32((len - 1) as i32);
    _mm256_min_epi32(_mm256_max_epi32(idx, _mm256_setzero_si256()), hi)
}

/// `data[idx]` per lane, each index first clamped to `[0, data.len() − 1]` (`data` not
/// empty, at most `i32::MAX` long).
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn gather(data: &[f32], idx: __m256i) -> __m256 {
    let idx = clamped(data.len(), idx);
    // SAFETY: every index is in [0, data.len() − 1] (`clamped`), so every lane reads an
    // element of `data`.
    unsafe { _mm256_i32gather_ps::<4>(data.as_ptr(), idx) }
}

/// [`gather`] of i32 numbers.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn gather_i32(data: &[i32], idx: __m256i) -> __m256i {
    let idx = clamped(data.len(), idx);
    // SAFETY: as in `gather`: every index is in [0, data.len() − 1].
    unsafe { _mm256_i32gather_epi32::<4>(data.as_ptr(), idx) }
}
