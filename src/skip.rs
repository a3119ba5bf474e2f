//! Exact empty-space skipping.
//!
//! For an object whose opacity is computed from datasets (through any chain of `vlDataset`,
//! `vlMap` and `vlSet` instructions), the part of its program that determines opacity is
//! evaluated over *intervals*, once per block of the object: each dataset contributes the range
//! of node values its filter can read anywhere in the block ([`Dataset::bricks`]), each mapping
//! the exact range of Φ over its input interval ([`crate::mapping::Mapping::range`]), each
//! constant itself, and each field function the whole [0, 1] (nothing is known of it). A block
//! whose opacity interval is [0, 0] is *empty*: every sample in it has o = 0 and contributes
//! nothing. Rays walk the block grid (a 3D DDA) and skip the segments whose sample points lie in
//! empty blocks; the remaining samples are exactly the ones that would have been taken, so
//! skipping never changes a pixel.

use crate::dataset::{bc_abs_sum, Bricks, CellMask, Dataset, Filter, BRICK};
use crate::program::Instr;
use crate::types::FIELD_COUNT;
use glam::{DMat3, DMat4, DVec3};
use rayon::prelude::*;

mod rect;

/// The blocks of one object and which of them are empty.
pub(crate) struct SkipGrid {
    dims: [usize; 3],
    /// Object-space corner of block (0, 0, 0).
    origin: DVec3,
    /// Object-space size of a block.
    cell: DVec3,
    /// Its reciprocal per axis.
    inv_cell: DVec3,
    /// The last block's index per axis (dims − 1), as f64.
    last: DVec3,
    /// Per block: 0 if it may hold opacity, else the chessboard distance (in blocks, capped at
    /// [`MAX_LEAP`]) to the nearest such block: every block within `dist − 1` of it is empty.
    dist: Vec<u8>,
    /// The shell: every block that may hold opacity and has an empty block, or the grid's
    /// outside, among its 26 neighbours, as boxes. A ray that starts outside the grid and
    /// meets a block that may hold opacity meets a shell block first (see [`EntryMap`]).
    shell: Boxes,
    /// The boxes of the dataset's cells that can pass a zero test, by 4³ cells (see
    /// [`SkipGrid::passing_boxes`]), made by the first render that asks.
    passing: std::sync::OnceLock<Option<std::sync::Arc<Boxes>>>,
}

/// Object-space boxes an [`EntryMap`] projects, and the size per axis of the blocks or cells
/// they are made of (the map grows each box by an eighth of it).
pub(crate) struct Boxes {
    /// Each box's lowest and highest corner.
    corners: Vec<(DVec3, DVec3)>,
    unit: DVec3,
}

/// The largest leap, in blocks.
const MAX_LEAP: u8 = 16;

/// Empty runs whose chessboard distance is at most this are crossed block by block (a DDA
/// step is cheaper than relocating the walk after a leap over so few blocks).
const STEP_BELOW: i64 = 4;

/// The chessboard (L∞) distance transform of `dist` in place: on entry 0 for occupied blocks
/// and `MAX_LEAP` for empty ones; on exit each empty block holds min(distance, MAX_LEAP).
/// Separable: along x the distance to the nearest occupied block of the row (two sweeps: the
/// entry is 0 or the cap); then along y and along z, d(x) = min over y of max(|x − y|,
/// d_prev(y)), |x − y| below the cap, a whole row (y) or plane (z) of blocks at a time in
/// byte lanes. Rows, planes and columns are independent: in parallel, the same numbers for
/// any number of threads.
fn chessboard(dist: &mut [u8], dims: [usize; 3]) {
    let [nx, ny, nz] = dims;
    if dist.is_empty() || nx * ny * nz != dist.len() {
        return;
    }
    let cap = MAX_LEAP as usize;
    dist.par_chunks_mut(nx).for_each(|row| {
        let mut d = MAX_LEAP;
        for v in row.iter_mut() {
            d = if *v == 0 {
                0
            } else {
                d.saturating_add(1).min(MAX_LEAP)
            };
            *v = d;
        }
        let mut d = MAX_LEAP;
        for v in row.iter_mut().rev() {
            d = (*v).min(d.saturating_add(1).min(MAX_LEAP));
            *v = d;
        }
    });
    // `out[i] = min over |e| < cap of max(|e|, src[i + e·unit])` for units of `unit` elements
    // (a row along y, a plane along z) out of `count`, `out` and `src` whole lines.
    fn window(out: &mut [u8], src: &[u8], unit: usize, count: usize, at: usize, cap: usize) {
        out.copy_from_slice(&src[at * unit..(at + 1) * unit]);
        let lo = at.saturating_sub(cap - 1);
        let hi = (at + cap - 1).min(count - 1);
        for other in lo..=hi {
            if other == at {
                continue;
            }
            let e = at.abs_diff(other) as u8;
            for (o, &v) in out.iter_mut().zip(&src[other * unit..(other + 1) * unit]) {
                *o = (*o).min(v.max(e));
            }
        }
    }
    // Along y: plane by plane, a row at a time.
    dist.par_chunks_mut(nx * ny)
        .for_each_init(Vec::new, |copy: &mut Vec<u8>, plane| {
            copy.clear();
            copy.extend_from_slice(plane);
            for (y, out) in plane.chunks_mut(nx).enumerate() {
                window(out, copy, nx, ny, y, cap);
            }
        });
    // Along z: a plane at a time.
    let copy = dist.to_vec();
    dist.par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(z, out)| window(out, &copy, nx * ny, nz, z, cap));
}

/// The occupied blocks (distance 0) of a distance map with a block of distance > 0 or the
/// outside of the grid among their 26 neighbours, by index, in order.
fn shell(dist: &[u8], dims: [usize; 3]) -> Vec<usize> {
    let at = |i: usize, j: usize, k: usize| dist[i + dims[0] * (j + dims[1] * k)];
    // In parallel over planes, in order.
    (0..dims[2])
        .into_par_iter()
        .flat_map_iter(|k| {
            (0..dims[1])
                .flat_map(move |j| (0..dims[0]).map(move |i| (i, j)))
                .filter_map(move |(i, j)| {
                    if at(i, j, k) != 0 {
                        return None;
                    }
                    let edge = [i, j, k]
                        .iter()
                        .zip(dims)
                        .any(|(&c, n)| c == 0 || c + 1 == n);
                    let open = edge
                        || (k - 1..=k + 1).any(|kk| {
                            (j - 1..=j + 1).any(|jj| (i - 1..=i + 1).any(|ii| at(ii, jj, kk) != 0))
                        });
                    open.then_some(i + dims[0] * (j + dims[1] * k))
                })
        })
        .collect()
}

/// The [`GroupCode`]s of the row of groups (gi, gj, gk), gi = 0, 1, …, of `data`'s cells
/// (`cells` per axis, in groups of `BRICK` per axis): each group's lowest and highest passing
/// cell per axis and whether all pass (`passing_in`, the tests' oracle), found together. Each
/// of the groups' rows of cells is read from `mask` 64 cells at a time and split among the
/// groups (whole groups to a word: 64 is a multiple of `BRICK`), where reading each group's rows
/// apart cost a node index and a run of the mask per row and group: most of the passing boxes'
/// instructions.
fn passing_groups_row(
    data: &Dataset,
    mask: &CellMask,
    cells: [usize; 3],
    (gj, gk): (usize, usize),
    out: &mut [GroupCode],
) {
    const _: () = assert!(64 % BRICK == 0);
    let groups = cells[0].div_ceil(BRICK);
    debug_assert_eq!(out.len(), groups);
    // Per group: lowest and highest passing offset per axis (u8::MAX / 0: none yet), all.
    let mut first = vec![[u8::MAX; 3]; groups];
    let mut last = vec![[0u8; 3]; groups];
    let mut all = vec![true; groups];
    // The rows of cells along y and z that the groups cover.
    let lo = [gj * BRICK, gk * BRICK];
    let hi = [(lo[0] + BRICK).min(cells[1]), (lo[1] + BRICK).min(cells[2])];
    for k in lo[1]..hi[1] {
        for j in lo[0]..hi[0] {
            let row = data.node_index([0, j, k]);
            let (dj, dk) = ((j - lo[0]) as u8, (k - lo[1]) as u8);
            for (w, x0) in (0..cells[0]).step_by(64).enumerate() {
                let width = (cells[0] - x0).min(64);
                let word = mask.run(row + x0, width);
                for g in 64 / BRICK * w..(64 / BRICK * (w + 1)).min(groups) {
                    let at = g * BRICK - x0;
                    let n = (width - at).min(BRICK);
                    let ones = (1u64 << n) - 1;
                    let bits = word >> at & ones;
                    // (All n set: a comparison, where `count_ones` is a software population
                    // count on the x86-64 baseline.)
                    all[g] &= bits == ones;
                    if bits == 0 {
                        continue;
                    }
                    let (a, b) = (bits.trailing_zeros() as u8, 63 - bits.leading_zeros() as u8);
                    let (f, l) = (&mut first[g], &mut last[g]);
                    for (axis, c) in [(0, a), (1, dj), (2, dk)] {
                        f[axis] = f[axis].min(c);
                    }
                    for (axis, c) in [(0, b), (1, dj), (2, dk)] {
                        l[axis] = l[axis].max(c);
                    }
                }
            }
        }
    }
    for (g, code) in out.iter_mut().enumerate() {
        *code = if first[g][0] == u8::MAX {
            GroupCode::NONE
        } else {
            GroupCode::of_offsets(first[g], last[g], all[g])
        };
    }
}

/// Of the cells [lo, hi) (by their first nodes' indices per axis) of `data`: the lowest and
/// highest index per axis of those that `mask` lets pass, and whether all pass; `None` when
/// none does. (The oracle of [`passing_groups_row`].)
#[cfg(test)]
fn passing_in(
    data: &Dataset,
    mask: &CellMask,
    lo: [usize; 3],
    hi: [usize; 3],
) -> Option<([usize; 3], [usize; 3], bool)> {
    let (mut first, mut last, mut all) = ([usize::MAX; 3], [0usize; 3], true);
    // A row of the group's cells along x at a time, as bits of the mask.
    let width = hi[0] - lo[0];
    for k in lo[2]..hi[2] {
        for j in lo[1]..hi[1] {
            let row = mask.run(data.node_index([lo[0], j, k]), width);
            all &= row.count_ones() as usize == width;
            if row == 0 {
                continue;
            }
            let (a, b) = (row.trailing_zeros(), 63 - row.leading_zeros());
            first[0] = first[0].min(lo[0] + a as usize);
            last[0] = last[0].max(lo[0] + b as usize);
            for (axis, c) in [(1, j), (2, k)] {
                first[axis] = first[axis].min(c);
                last[axis] = last[axis].max(c);
            }
        }
    }
    (first[0] != usize::MAX).then_some((first, last, all))
}

/// A group's passing cells ([`passing_groups_row`]) in 16 bits: each axis's lowest and
/// highest passing cell as offsets (0 … 3) from the group's first cell, two bits each, and
/// whether all pass (bit 12); [`GroupCode::NONE`] where none does.
#[derive(Clone, Copy, Debug, PartialEq)]
struct GroupCode(u16);

// Offsets within a group fit in two bits.
const _: () = assert!(BRICK <= 4);

impl GroupCode {
    const NONE: GroupCode = GroupCode(u16::MAX);

    /// The code of `passing` (cells within `BRICK` of `lo`, the group's first cell).
    #[cfg(test)]
    fn new(lo: [usize; 3], passing: Option<([usize; 3], [usize; 3], bool)>) -> GroupCode {
        let Some((first, last, all)) = passing else {
            return GroupCode::NONE;
        };
        let offsets = |c: [usize; 3]| std::array::from_fn(|a| (c[a] - lo[a]) as u8);
        GroupCode::of_offsets(offsets(first), offsets(last), all)
    }

    /// The code of a group whose passing cells lie between offsets `first` and `last` (each
    /// below `BRICK`) from its first cell per axis, all of its cells passing or not.
    fn of_offsets(first: [u8; 3], last: [u8; 3], all: bool) -> GroupCode {
        let mut c = u16::from(all) << 12;
        for a in 0..3 {
            debug_assert!(first[a] <= last[a] && (last[a] as usize) < BRICK);
            c |= u16::from(first[a]) << (2 * a);
            c |= u16::from(last[a]) << (6 + 2 * a);
        }
        GroupCode(c)
    }

    /// Whether all the group's cells pass.
    fn all(self) -> bool {
        self != GroupCode::NONE && self.0 >> 12 & 1 != 0
    }

    /// The passing cells again, for the group whose first cell is `lo`.
    fn get(self, lo: [usize; 3]) -> Option<([usize; 3], [usize; 3], bool)> {
        if self == GroupCode::NONE {
            return None;
        }
        let at = |shift: usize, a: usize| lo[a] + (self.0 >> shift & 3) as usize;
        Some((
            std::array::from_fn(|a| at(2 * a, a)),
            std::array::from_fn(|a| at(6 + 2 * a, a)),
            self.0 >> 12 & 1 != 0,
        ))
    }
}

/// See [`SkipGrid::passing_boxes`].
fn passing_boxes(data: &Dataset, mask: &CellMask, box_min: DVec3, box_max: DVec3) -> Option<Boxes> {
    let n = data.dims();
    if n.iter().any(|&k| k < 2) {
        return None;
    }
    let cells = n.map(|k| k - 1);
    let groups = cells.map(|c| c.div_ceil(BRICK));
    // Per group: the lowest and highest passing cell per axis, and whether all pass
    // ([`GroupCode`]: two bytes a group, where the decoded form took 56 and its 7.5 MB of fresh
    // memory for the MNI scan cost more than the cells' bits); in parallel over layers of
    // groups.
    let layers: Vec<Vec<GroupCode>> = (0..groups[2])
        .into_par_iter()
        .map(|gk| {
            let mut layer = vec![GroupCode::NONE; groups[0] * groups[1]];
            for (gj, row) in layer.chunks_exact_mut(groups[0]).enumerate() {
                passing_groups_row(data, mask, cells, (gj, gk), row);
            }
            layer
        })
        .collect();
    // Whether each group and its 26 neighbours all pass (outside the groups: not): the AND
    // over the 3×3×3 cube, one axis at a time (the cube is the product of three intervals).
    let [gx, gy, gz] = groups;
    let full: Vec<bool> = layers.iter().flatten().map(|c| c.all()).collect();
    // One axis: along it, of `n` groups `stride` apart (runs of `stride` consecutive groups
    // in blocks of n·stride).
    let erode = |v: &[bool], stride: usize, n: usize| -> Vec<bool> {
        let mut out = vec![false; v.len()];
        for (block, o) in v.chunks(n * stride).zip(out.chunks_mut(n * stride)) {
            for c in 1..n.saturating_sub(1) {
                let (before, at, after) = (
                    &block[(c - 1) * stride..c * stride],
                    &block[c * stride..(c + 1) * stride],
                    &block[(c + 1) * stride..(c + 2) * stride],
                );
                for (((o, &a), &b), &d) in o[c * stride..(c + 1) * stride]
                    .iter_mut()
                    .zip(before)
                    .zip(at)
                    .zip(after)
                {
                    *o = a && b && d;
                }
            }
        }
        out
    };
    let enclosed = erode(&erode(&erode(&full, 1, gx), gx, gy), gx * gy, gz);
    // The boxes in group order (x fastest), in parallel over layers of groups.
    let corners: Vec<(DVec3, DVec3)> = (0..gz)
        .into_par_iter()
        .flat_map_iter(|gk| {
            let layer = &layers[gk];
            let enclosed = &enclosed[gk * gx * gy..(gk + 1) * gx * gy];
            (0..gy)
                .flat_map(move |gj| (0..gx).map(move |gi| (gi, gj)))
                .filter_map(move |(gi, gj)| {
                    let at = gi + gx * gj;
                    if enclosed[at] || layer[at] == GroupCode::NONE {
                        return None;
                    }
                    let lo_cell = [gi * BRICK, gj * BRICK, gk * BRICK];
                    let (first, last, _) = layer[at].get(lo_cell)?;
                    let lo = DVec3::from_array(std::array::from_fn(|a| {
                        if first[a] == 0 {
                            box_min[a].min(0.0)
                        } else {
                            first[a] as f64 / cells[a] as f64
                        }
                    }));
                    let hi = DVec3::from_array(std::array::from_fn(|a| {
                        if last[a] + 1 == cells[a] {
                            box_max[a].max(1.0)
                        } else {
                            (last[a] + 1) as f64 / cells[a] as f64
                        }
                    }));
                    Some((lo, hi))
                })
        })
        .collect();
    let unit = DVec3::from_array(cells.map(|c| 1.0 / c as f64));
    Some(Boxes { corners, unit })
}

/// The hasher of the skip grid's memo of opacity intervals (keys: a few pairs of f32 bits, one
/// lookup per block): a multiplicative hash of each word (FxHash's), where the standard
/// SipHash cost about as much as the block's brick ranges themselves. The keys are the grid's
/// own numbers, not input an adversary chooses to collide.
#[derive(Default, Clone, Copy)]
struct MemoHash;

impl std::hash::BuildHasher for MemoHash {
    type Hasher = MemoHasher;
    fn build_hasher(&self) -> MemoHasher {
        MemoHasher(0)
    }
}

/// See [`MemoHash`].
struct MemoHasher(u64);

impl std::hash::Hasher for MemoHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
    fn write_u32(&mut self, x: u32) {
        self.write_u64(u64::from(x));
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

/// The most blocks a grid may have.
const MAX_BLOCKS: usize = 1 << 24;

/// The brick of `d`'s ranges `bricks` that holds object coordinate `x` along `axis` (clamped to
/// the grid).
fn brick_at(d: &Dataset, bricks: &Bricks, x: f64, axis: usize) -> usize {
    let n = d.dims()[axis];
    if n == 1 {
        return 0;
    }
    let u = crate::num::floor(x * (n - 1) as f64 / BRICK as f64);
    u.clamp(0.0, (bricks.dims[axis] - 1) as f64) as usize
}

/// Half the spacing of `d`'s nodes along `axis` in object coordinates (0 for an axis of one
/// node, which has one brick).
fn half_node(d: &Dataset, axis: usize) -> f64 {
    let n = d.dims()[axis];
    if n == 1 {
        0.0
    } else {
        0.5 / (n - 1) as f64
    }
}

/// Per axis of the blocks of a skip grid (`dims` blocks of size `cell` from `origin`), the first
/// and last brick of `d`'s ranges `bricks` whose ranges hold every value a sample in the
/// block's box [lo, lo + cell] along that axis can read: a block's box is the product of its
/// axes' intervals, so its bricks are too. Those are the bricks that [lo + h, lo + cell − h]
/// meets, h half a node: a brick's range covers every node a point up to a whole node outside
/// its box reads ([`Bricks`]: padded spans), so the points of the box within h of its ends are
/// covered by the bricks next to them. (The box itself meets the next brick at its end, a
/// brick of four nodes more: its range would widen the block's needlessly, and a block that
/// could be empty would not be.)
fn brick_spans(
    d: &Dataset,
    bricks: &Bricks,
    origin: DVec3,
    cell: DVec3,
    dims: [usize; 3],
) -> [Vec<(usize, usize)>; 3] {
    std::array::from_fn(|axis| {
        (0..dims[axis])
            .map(|c| {
                let lo = origin[axis] + c as f64 * cell[axis];
                let hi = lo + cell[axis];
                let h = half_node(d, axis);
                (
                    brick_at(d, bricks, lo + h, axis),
                    brick_at(d, bricks, hi - h, axis),
                )
            })
            .collect()
    })
}

/// The (min, max) of a dataset under `filter` over the bricks `spans` (first and last per axis)
/// of its ranges `bricks`: its range over any box those bricks cover. `overshoot` is the
/// filter's [`overshoot`].
fn bricks_range(
    bricks: &Bricks,
    filter: Filter,
    overshoot: f64,
    spans: [(usize, usize); 3],
) -> (f32, f32) {
    let [(i0, i1), (j0, j1), (k0, k1)] = spans;
    let (mut mn, mut mx) = (f32::INFINITY, f32::NEG_INFINITY);
    for k in k0..=k1 {
        for j in j0..=j1 {
            for i in i0..=i1 {
                let (a, b) = bricks.get(i, j, k);
                // Plain comparisons: brick ranges are never NaN.
                mn = if a < mn { a } else { mn };
                mx = if b > mx { b } else { mx };
            }
        }
    }
    if let Filter::Cubic { .. } = filter {
        // Negative lobes can overshoot the node range by (P − 1)·(max − min).
        let spread = (mx - mn) as f64 * overshoot;
        mn = (mn as f64 - spread).max(0.0) as f32;
        mx = (mx as f64 + spread).min(1.0) as f32;
    }
    (mn, mx)
}

/// P − 1 for a filter (0 for nearest and trilinear): how far, in multiples of the node range,
/// an interpolated value can overshoot it. Computed once per grid (it samples the kernel).
fn overshoot(filter: Filter) -> f64 {
    match filter {
        Filter::Cubic { b, c } => {
            let s = bc_abs_sum(b as f64, c as f64);
            (s * s * s + 1.0) / 2.0 - 1.0
        }
        _ => 0.0,
    }
}

impl SkipGrid {
    /// The grid for an object whose opacity is decided by `prefix` (its program up to the last
    /// instruction that may write opacity), over the boundary box [box_min, box_max]. `None`
    /// when no dataset feeds the opacity or no block is provably empty.
    pub(crate) fn build(prefix: &[Instr], box_min: DVec3, box_max: DVec3) -> Option<SkipGrid> {
        // A spatial transfer function moves points anywhere: no block bound holds after it.
        if prefix.iter().any(|i| matches!(i, Instr::Spatial { .. })) {
            return None;
        }
        // The finest dataset feeding the prefix sets the block size: one brick of it.
        let reference = prefix
            .iter()
            .filter_map(|i| match i {
                Instr::Dataset { data, .. } => Some(data),
                _ => None,
            })
            .max_by_key(|d| d.dims().iter().product::<usize>())?;
        let n = reference.dims();
        let mut cell = DVec3::ZERO;
        let mut first = [0i64; 3];
        let mut dims = [1usize; 3];
        for axis in 0..3 {
            if n[axis] == 1 {
                cell[axis] = box_max[axis] - box_min[axis];
                first[axis] = 0;
                continue;
            }
            cell[axis] = BRICK as f64 / (n[axis] - 1) as f64;
            let a = (box_min[axis] / cell[axis]).floor();
            let b = (box_max[axis] / cell[axis]).floor();
            if !(a.is_finite() && b.is_finite()) || b - a > MAX_BLOCKS as f64 {
                return None;
            }
            first[axis] = a as i64;
            dims[axis] = (b - a) as usize + 1;
        }
        let total = dims.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d))?;
        if total > MAX_BLOCKS {
            return None;
        }
        let origin = DVec3::new(
            if n[0] == 1 {
                box_min.x
            } else {
                first[0] as f64 * cell.x
            },
            if n[1] == 1 {
                box_min.y
            } else {
                first[1] as f64 * cell.y
            },
            if n[2] == 1 {
                box_min.z
            } else {
                first[2] as f64 * cell.z
            },
        );
        let mut dist = vec![0u8; total];
        // The datasets' brick ranges first (each built once, itself in parallel) and the
        // bricks each block meets along each axis, then the blocks plane by plane in parallel.
        type Source<'a> = (&'a Bricks, Filter, f64, [Vec<(usize, usize)>; 3]);
        let data: Vec<Source> = prefix
            .iter()
            .filter_map(|i| match i {
                Instr::Dataset { data, filter, .. } => {
                    let bricks = data.bricks(*filter);
                    let spans = brick_spans(data, bricks, origin, cell, dims);
                    Some((bricks, *filter, overshoot(*filter), spans))
                }
                _ => None,
            })
            .collect();
        let any = dist
            .par_chunks_mut(dims[0] * dims[1])
            .enumerate()
            .map(|(k, plane)| {
                // The opacity interval depends on the block only through the datasets' ranges
                // there, and blocks share few distinct ranges: evaluate the interval program
                // once per distinct set (per plane).
                let mut memo: std::collections::HashMap<Vec<(u32, u32)>, bool, MemoHash> =
                    Default::default();
                let mut key = Vec::with_capacity(data.len());
                let mut any = false;
                // The last block's key and answer: neighbours along x often share them.
                let mut last: Option<(Vec<(u32, u32)>, bool)> = None;
                for j in 0..dims[1] {
                    for i in 0..dims[0] {
                        key.clear();
                        key.extend(data.iter().map(|(bricks, f, over, spans)| {
                            let at = [spans[0][i], spans[1][j], spans[2][k]];
                            let (a, b) = bricks_range(bricks, *f, *over, at);
                            (a.to_bits(), b.to_bits())
                        }));
                        let known = match &last {
                            Some((k, e)) if *k == key => Some(*e),
                            _ => memo.get(&key).copied(),
                        };
                        let e = match known {
                            Some(e) => e,
                            None => {
                                let ranges: Vec<(f32, f32)> = key
                                    .iter()
                                    .map(|&(a, b)| (f32::from_bits(a), f32::from_bits(b)))
                                    .collect();
                                let e = opacity_range(prefix, &ranges).1 <= 0.0;
                                memo.insert(key.clone(), e);
                                e
                            }
                        };
                        match &mut last {
                            Some((k, le)) => {
                                k.clone_from(&key);
                                *le = e;
                            }
                            None => last = Some((key.clone(), e)),
                        }
                        plane[i + dims[0] * j] = if e { MAX_LEAP } else { 0 };
                        any |= e;
                    }
                }
                any
            })
            .reduce(|| false, |a, b| a || b);
        if !any {
            return None;
        }
        chessboard(&mut dist, dims);
        Some(SkipGrid::new(dims, origin, cell, dist))
    }

    /// The grid of `dims` blocks of size `cell` from `origin`, with distance map `dist`.
    fn new(dims: [usize; 3], origin: DVec3, cell: DVec3, dist: Vec<u8>) -> SkipGrid {
        let shell = shell(&dist, dims);
        let mut grid = SkipGrid {
            dims,
            origin,
            cell,
            inv_cell: cell.recip(),
            last: DVec3::from_array(dims.map(|n| (n - 1) as f64)),
            dist,
            shell: Boxes {
                corners: Vec::new(),
                unit: cell,
            },
            passing: Default::default(),
        };
        grid.shell.corners = shell.into_iter().map(|i| grid.block_box(i)).collect();
        grid
    }

    /// The block with linear index `index` as an object-space box.
    fn block_box(&self, index: usize) -> (DVec3, DVec3) {
        let c = DVec3::new(
            (index % self.dims[0]) as f64,
            (index / self.dims[0] % self.dims[1]) as f64,
            (index / (self.dims[0] * self.dims[1])) as f64,
        );
        (
            self.origin + c * self.cell,
            self.origin + (c + 1.0) * self.cell,
        )
    }

    /// For the batched march of `data` with the cell mask `mask` (its cells whose samples can
    /// pass the zero test) over the object box [box_min, box_max]: boxes that hold every
    /// sample whose opacity is above 0, or at least the first one along any ray, computed
    /// once per grid (the mask belongs to the grid's object).
    ///
    /// Per 4³ cells of the dataset, the box of those that can pass: a sample's value comes
    /// from the cell that holds its point, so a sample whose opacity is above 0 lies in such
    /// a box. A box whose cells touch a face of the dataset reaches to the object box there
    /// (a sample outside the dataset takes the value of the nearest edge cell). Left out: the
    /// groups whose cells all pass, with all 26 neighbouring groups the same: a ray that meets
    /// opacity first in one has crossed a neighbour's box before (or starts in a region of them,
    /// enclosed by boxes some of which are then behind the eye: no map). `None` for a
    /// dataset with an axis of one node.
    pub(crate) fn passing_boxes(
        &self,
        data: &Dataset,
        mask: &CellMask,
        box_min: DVec3,
        box_max: DVec3,
    ) -> Option<std::sync::Arc<Boxes>> {
        self.passing
            .get_or_init(|| passing_boxes(data, mask, box_min, box_max).map(std::sync::Arc::new))
            .clone()
    }

    #[inline]
    fn distance(&self, c: [i64; 3]) -> u8 {
        self.dist[c[0] as usize + self.dims[0] * (c[1] as usize + self.dims[1] * c[2] as usize)]
    }

    /// Starts a walk along the object-space ray `o + t·d` at parameter `t0` in `slot` (the
    /// caller's, e.g. a cursor's field): built in place, where a walk returned by value was
    /// built on the stack and copied (a `memcpy` call a ray). Inlined: called once a ray.
    #[inline]
    pub(crate) fn walk_into<'a>(
        &self,
        slot: &'a mut Option<Walk>,
        o: DVec3,
        d: DVec3,
        t0: f64,
    ) -> &'a mut Walk {
        let w = slot.insert(Walk {
            o,
            d,
            inv_d: d.recip(),
            cell: [0; 3],
            step: [0; 3],
            t_max: [f64::INFINITY; 3],
            t_delta: [f64::INFINITY; 3],
            done: false,
            entry: t0,
        });
        for axis in 0..3 {
            let size = self.cell[axis];
            if d[axis] > 0.0 {
                w.step[axis] = 1;
                w.t_delta[axis] = size / d[axis];
            } else if d[axis] < 0.0 {
                w.step[axis] = -1;
                w.t_delta[axis] = -size / d[axis];
            }
        }
        w.relocate(self, t0, [None; 3]);
        w
    }
}

#[cfg(test)]
impl SkipGrid {
    /// A grid of `dims` blocks of size `cell` from `origin` whose blocks that may hold opacity
    /// are `occupied` (x fastest), with the distance map `build` makes.
    pub(crate) fn of_occupied(
        dims: [usize; 3],
        origin: DVec3,
        cell: DVec3,
        occupied: &[bool],
    ) -> SkipGrid {
        let mut dist: Vec<u8> = occupied
            .iter()
            .map(|&o| if o { 0 } else { MAX_LEAP })
            .collect();
        chessboard(&mut dist, dims);
        SkipGrid::new(dims, origin, cell, dist)
    }
}

/// A pinhole camera as the image's primary rays see it: the ray through image position
/// (x, y) (pixels from the top-left corner of a `width × height` image) leaves `eye` along
/// `forward + sx·right + sy·up`, with sx = 2x/width − 1 and sy = 1 − 2y/height.
pub(crate) struct Pinhole {
    pub eye: DVec3,
    pub forward: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    pub width: u32,
    pub height: u32,
}

impl Pinhole {
    /// The unit direction of the ray through image position (x, y).
    #[inline]
    pub(crate) fn ray(&self, x: f64, y: f64) -> DVec3 {
        let sx = x / self.width as f64 * 2.0 - 1.0;
        let sy = 1.0 - y / self.height as f64 * 2.0;
        (self.forward + sx * self.right + sy * self.up).normalize()
    }
}

/// Per pixel of an image, a lower bound on the parameter t (distance from the eye along a unit
/// direction) at which a primary ray through any point of the pixel meets a block of one
/// object that may hold opacity; +∞ where no such ray meets one. A ray need not walk the
/// blocks before its bound: every sample there lies in an empty block, so starting later
/// never changes a pixel, and a pixel whose bound is +∞ shows the background.
///
/// Built per image by projecting the grid's shell (see [`SkipGrid`]): each shell block, grown
/// by an eighth of a block on every side (far more than any rounding of the walk or the
/// projection), is mapped to the image through its eight corners; the pixels whose square,
/// grown by a hundredth of a pixel, meets the corners' bounding rectangle take the block's
/// smallest depth along the view direction (a unit ray's t is at least the depth of its
/// point) as a bound.
/// The projection of a box wholly in front of the eye is the convex hull of its corners'
/// projections, so every ray that meets the block passes through a marked pixel.
///
/// Why the shell suffices: a ray's samples lie in the object's box, inside the grid. The
/// first block along the ray that may hold opacity is either where the ray starts (at the
/// eye, or where it enters the box, in an edge block: shell) or entered from a neighbour the
/// ray crossed before, which is then empty (shell again). An eye inside such a block is
/// enclosed by shell blocks, some of whose corners are then not in front of it: no map.
pub(crate) struct EntryMap {
    width: usize,
    bound: Vec<f64>,
}

/// Rows per parallel task filling an entry map.
const ENTRY_BAND: usize = 16;

/// A shell block's pixel rectangle (inclusive) and its smallest depth.
struct Mark {
    x: (usize, usize),
    y: (usize, usize),
    near: f64,
}

/// Rectangle pixels an entry map may mark, per image pixel, before it gives up (a camera
/// close to a finely divided volume): a marked pixel costs a comparison, a ray thousands of
/// instructions.
const ENTRY_BUDGET: usize = 64;

/// Boxes an entry map may project, per image pixel: projecting a box costs about what the map
/// saves a ray, so with more boxes than pixels (a small image of a large volume) the rays
/// walk from the object's box instead (the MNI brain's 13 300 boxes of passing cells: a loss
/// at 64², a gain of 11 % at 128²).
const ENTRY_BOXES_PER_PIXEL: usize = 1;

impl EntryMap {
    /// The map of `grid`'s object (whose object-to-world transform is `to_world`) seen by
    /// `camera`; `None` when it cannot help or cannot be proved: a shell corner not clearly
    /// in front of the eye (an eye in or next to a block that may hold opacity, a volume
    /// around or behind the eye), a singular camera basis, or more marking than
    /// [`ENTRY_BUDGET`] allows.
    pub(crate) fn build(grid: &SkipGrid, to_world: DMat4, camera: &Pinhole) -> Option<EntryMap> {
        Self::of_boxes(&grid.shell, to_world, camera)
    }

    /// The map of `boxes`, each grown by an eighth of their unit on every side, that hold the
    /// first sample with opacity above 0 of any ray (the shell's blocks, or
    /// [`SkipGrid::passing_boxes`]); `None` as for [`EntryMap::build`], and for more boxes
    /// than [`ENTRY_BOXES_PER_PIXEL`] allows.
    pub(crate) fn of_boxes(boxes: &Boxes, to_world: DMat4, camera: &Pinhole) -> Option<EntryMap> {
        let pixels = (camera.width as usize).saturating_mul(camera.height as usize);
        if boxes.corners.len() > pixels.saturating_mul(ENTRY_BOXES_PER_PIXEL) {
            return None;
        }
        let budget = pixels.saturating_mul(ENTRY_BUDGET);
        Self::build_within(boxes, to_world, camera, budget)
    }

    /// [`EntryMap::of_boxes`], giving up past `budget` marked rectangle pixels.
    fn build_within(
        boxes: &Boxes,
        to_world: DMat4,
        camera: &Pinhole,
        budget: usize,
    ) -> Option<EntryMap> {
        let (w, h) = (camera.width as usize, camera.height as usize);
        if w == 0 || h == 0 || boxes.corners.is_empty() {
            return None;
        }
        let margin = boxes.unit * 0.125;
        // Coefficients (depth, right, up) of an eye-relative vector: the rays' own basis.
        let basis = DMat3::from_cols(camera.forward, camera.right, camera.up);
        let det = basis.determinant().abs();
        if det.is_nan() || det <= 1e-12 {
            return None;
        }
        let to_view = basis.inverse();
        let unit_forward = camera.forward.normalize_or_zero();
        let (wf, hf) = (w as f64, h as f64);
        // A box's corners are lo + (a·e.x, b·e.y, c·e.z) for a, b, c in {0, 1} (e = hi − lo),
        // and their eye-relative vectors q, view coefficients v = to_view·q and depths
        // q·forward are affine in the object point: each corner's numbers are the lowest
        // corner's plus the terms of its axes, so a box costs the products of one corner and
        // three edges, not of eight corners. (Rounding differs from transforming each corner
        // by a few units in the last place, far inside the eighth of a block each box is
        // grown by.)
        let axes = [
            to_world.x_axis.truncate(),
            to_world.y_axis.truncate(),
            to_world.z_axis.truncate(),
        ];
        let origin_q = to_world.w_axis.truncate() - camera.eye;
        let view_axes = axes.map(|a| to_view * a);
        let origin_v = to_view * origin_q;
        let depth_axes = axes.map(|a| a.dot(unit_forward));
        let origin_depth = origin_q.dot(unit_forward);
        // Each box's pixel rectangle and depth, in parallel; `None` gives up.
        let project = |&(lo, hi): &(DVec3, DVec3)| -> Option<Option<Mark>> {
            let (lo, hi) = (lo - margin, hi + margin);
            let e = hi - lo;
            let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
            let (mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
            let mut near = f64::INFINITY;
            let q0 = origin_q + axes[0] * lo.x + axes[1] * lo.y + axes[2] * lo.z;
            let v0 = origin_v + view_axes[0] * lo.x + view_axes[1] * lo.y + view_axes[2] * lo.z;
            let n0 =
                origin_depth + depth_axes[0] * lo.x + depth_axes[1] * lo.y + depth_axes[2] * lo.z;
            let dq = [axes[0] * e.x, axes[1] * e.y, axes[2] * e.z];
            let dv = [view_axes[0] * e.x, view_axes[1] * e.y, view_axes[2] * e.z];
            let dn = [
                depth_axes[0] * e.x,
                depth_axes[1] * e.y,
                depth_axes[2] * e.z,
            ];
            for k in 0..8 {
                let (mut q, mut v, mut n) = (q0, v0, n0);
                for (a, ((dq, dv), dn)) in dq.iter().zip(&dv).zip(&dn).enumerate() {
                    if k >> a & 1 != 0 {
                        q += *dq;
                        v += *dv;
                        n += dn;
                    }
                }
                // Clearly in front (a corner at or behind the eye's plane breaks the hull
                // argument): v.x > 10⁻⁹·|q|, squared (v.x positive first); NaN fails too.
                if !(v.x > 0.0 && v.x * v.x > 1e-18 * q.length_squared()) {
                    return None;
                }
                let (x, y) = ((v.y / v.x + 1.0) * 0.5 * wf, (1.0 - v.z / v.x) * 0.5 * hf);
                if !(x.is_finite() && y.is_finite()) {
                    return None;
                }
                // `x0.min(x)` and the like, by comparisons: neither side is NaN (x and y are
                // finite here; the bounds start at ±∞ and only take them), where the NaN-aware
                // forms cost 7 instructions each (four a corner); and they agree on ties, as
                // neither x nor y can be −0: `r + 1` and `1 − r` round to +0, never −0, and
                // when not 0 are at least 2⁻⁵³ in magnitude, which halving and the image size
                // (≥ 1) cannot take to 0.
                if x < x0 {
                    x0 = x;
                }
                if x > x1 {
                    x1 = x;
                }
                if y < y0 {
                    y0 = y;
                }
                if y > y1 {
                    y1 = y;
                }
                near = near.min(n);
            }
            // Pixel squares [px, px + 1) meeting [x0 − ε, x1 + ε] (and likewise in y). (The
            // floor inline, bit for bit the library's, which is a call on the SSE2 baseline.)
            const EPS: f64 = 0.01;
            let floor = crate::num::floor;
            let (px0, px1) = (floor(x0 - EPS).max(0.0), floor(x1 + EPS).min(wf - 1.0));
            let (py0, py1) = (floor(y0 - EPS).max(0.0), floor(y1 + EPS).min(hf - 1.0));
            if px0 > px1 || py0 > py1 {
                return Some(None); // off the image
            }
            Some(Some(Mark {
                x: (px0 as usize, px1 as usize),
                y: (py0 as usize, py1 as usize),
                // Rounding of the depth itself: a relative slack far below the margin's.
                near: near - 1e-9 * near.abs(),
            }))
        };
        let marks: Vec<Mark> = boxes
            .corners
            .par_iter()
            .filter_map(|b| match project(b) {
                None => Some(None), // give up
                Some(None) => None, // off the image
                Some(mark) => Some(mark),
            })
            .collect::<Option<Vec<Mark>>>()?;
        let area = marks.iter().fold(0usize, |sum, m| {
            sum.saturating_add((m.x.1 - m.x.0 + 1) * (m.y.1 - m.y.0 + 1))
        });
        if area > budget {
            return None;
        }
        // The rectangles' minimum, in parallel over bands of rows (the same numbers in any
        // order), each band going through the rectangles that meet it.
        let mut in_band: Vec<Vec<u32>> = vec![Vec::new(); h.div_ceil(ENTRY_BAND)];
        for (i, m) in marks.iter().enumerate() {
            for band in &mut in_band[m.y.0 / ENTRY_BAND..=m.y.1 / ENTRY_BAND] {
                band.push(i as u32);
            }
        }
        // (Zeroed memory from the allocator, each band filled with +∞ by its own task: a
        // first touch of fresh pages, in parallel.)
        let mut bound = vec![0.0f64; w * h];
        bound
            .par_chunks_mut(ENTRY_BAND * w)
            .zip(&in_band)
            .enumerate()
            .for_each(|(band, (rows, in_band))| {
                rows.fill(f64::INFINITY);
                let first = band * ENTRY_BAND;
                let last = first + rows.len() / w - 1;
                for m in in_band.iter().map(|&i| &marks[i as usize]) {
                    let (y0, y1) = (m.y.0.max(first), m.y.1.min(last));
                    if y0 <= y1 {
                        let ys = y0 - first..=y1 - first;
                        rect::lower_rect(rows, w, m.x.0..=m.x.1, ys, m.near);
                    }
                }
            });
        Some(EntryMap { width: w, bound })
    }

    /// The bound of pixel (x, y).
    #[inline]
    pub(crate) fn bound(&self, x: u32, y: u32) -> f64 {
        self.bound[y as usize * self.width + x as usize]
    }
}

/// The block holding block coordinate `rel`: floor(rel) clamped to [0, last] (`last` an
/// integer ≥ 0), NaN to 0. Clamping first makes the truncation of `as` the floor. The clamp by
/// comparisons, NaN taking the lower end as `f64::clamp`'s NaN becomes 0 in the conversion:
/// `f64::clamp` checks `0 ≤ last` on every call (a branch to a panic).
#[inline]
fn block_index(rel: f64, last: f64) -> i64 {
    let r = if rel > 0.0 { rel } else { 0.0 };
    (if r < last { r } else { last }) as i64
}

/// Whether block index `c` lies outside `0..dims`: `c < 0 || c >= dims as i64` as one
/// unsigned comparison (a negative index is above every `dims` as u64; a grid's `dims` is far
/// below 2⁶³). The compiler cannot make the fold itself: it does not know `dims as i64` is not
/// negative.
#[inline]
fn outside(c: i64, dims: usize) -> bool {
    c as u64 >= dims as u64
}

/// The interval of every field after `prefix`, given the range of each of its `vlDataset`
/// instructions (in order) over a block; returns the opacity interval.
fn opacity_range(prefix: &[Instr], data_ranges: &[(f32, f32)]) -> (f32, f32) {
    let mut r = [(0.0f32, 0.0f32); FIELD_COUNT];
    let mut next = data_ranges.iter();
    for ins in prefix {
        let (fields, range) = match ins {
            Instr::Set { fields, value } => (*fields, (*value, *value)),
            Instr::Function { fields, .. } => (*fields, (0.0, 1.0)),
            Instr::Spatial { .. } => continue, // excluded by `build`
            Instr::Dataset { fields, .. } => {
                (*fields, *next.next().expect("one range per dataset"))
            }
            Instr::Map {
                targets,
                source,
                mapping,
                output,
            } => {
                let (a, b) = r[*source];
                (*targets, mapping.range(a, b, *output))
            }
        };
        for i in fields.indices() {
            r[i] = range;
        }
    }
    r[0]
}

/// A walk through the blocks of a [`SkipGrid`] along a ray (Amanatides & Woo), leaping over
/// runs of empty blocks with the distance map.
pub(crate) struct Walk {
    o: DVec3,
    d: DVec3,
    /// 1/d per axis (unused where d is 0): the walk's divisions by d are multiplications
    /// (a division's latency is several multiplications'; the results differ by rounding only,
    /// which the bricks' one-node margin already covers, see `Dataset::bricks`).
    inv_d: DVec3,
    cell: [i64; 3],
    step: [i64; 3],
    t_max: [f64; 3],
    t_delta: [f64; 3],
    /// The ray has left the grid (everything after is treated as non-empty).
    done: bool,
    /// The ray parameter at which the current block was entered.
    entry: f64,
}

impl Walk {
    /// Moves the walk to parameter `t0` (its start, or a leap): the block there and the
    /// parameters at which it is left (steps and deltas do not change along a ray). `forced`
    /// sets the block index on the axes where the ray is known to have just crossed into a
    /// block (so rounding cannot put it back). Always inlined: at a walk's start the forced
    /// axes are known to be none, and the tests of them go.
    #[inline(always)]
    fn relocate(&mut self, grid: &SkipGrid, t0: f64, forced: [Option<i64>; 3]) {
        let p = self.o + t0 * self.d;
        for axis in 0..3 {
            // Only a forced index can lie outside the grid: `block_index` clamps to it.
            let c = match forced[axis] {
                Some(c) => {
                    if outside(c, grid.dims[axis]) {
                        self.done = true;
                        return;
                    }
                    c
                }
                None => {
                    let rel = (p[axis] - grid.origin[axis]) * grid.inv_cell[axis];
                    block_index(rel, grid.last[axis])
                }
            };
            self.cell[axis] = c;
            let size = grid.cell[axis];
            let d = self.d[axis];
            let inv = self.inv_d[axis];
            if d > 0.0 {
                let boundary = grid.origin[axis] + (c + 1) as f64 * size;
                self.t_max[axis] = t0 + (boundary - p[axis]) * inv;
            } else if d < 0.0 {
                let boundary = grid.origin[axis] + c as f64 * size;
                self.t_max[axis] = t0 + (boundary - p[axis]) * inv;
            }
        }
    }

    /// The ray parameter at which the current block is left: `f64::min` of the three exits,
    /// by comparisons. A running minimum that takes a later exit only where it is below
    /// (false against NaN) skips NaN exits after the first and is, operand for operand,
    /// `f64::min`'s `minsd` with the NaN test on the accumulator; only a NaN first exit
    /// (a direction component of magnitude below 10⁻³⁰⁸, see [`Walk::advance`]) leaves it
    /// NaN, and that case takes `f64::min` of the other two, as the old chain did. Saves
    /// `f64::min`'s two NaN selects a call (`exit_is_the_nan_aware_minimum`).
    #[inline]
    fn exit(&self) -> f64 {
        let [a, b, c] = self.t_max;
        let mut m = a;
        if b < m {
            m = b;
        }
        if c < m {
            m = c;
        }
        if m.is_nan() {
            return b.min(c);
        }
        m
    }

    /// `t >= self.exit()`, without the NaN-aware minimum: t is at or past the block's exit if
    /// it is at or past the exit along some axis (comparisons with NaN are false, and
    /// `f64::min` ignores NaN, so the two agree there too).
    #[inline]
    fn left_before(&self, t: f64) -> bool {
        self.t_max[0] <= t || self.t_max[1] <= t || self.t_max[2] <= t
    }

    /// Steps into the next block, along the axis whose boundary comes first, and keeps the
    /// parameter at which the block was left in `entry` (the smallest exit along an axis, as
    /// [`Walk::exit`] gives it, unless an exit is NaN, which only a direction component of
    /// magnitude below 10⁻³⁰⁸ can make: the walk then follows the comparisons).
    fn advance(&mut self, grid: &SkipGrid) {
        let axis = if self.t_max[0] <= self.t_max[1] && self.t_max[0] <= self.t_max[2] {
            0
        } else if self.t_max[1] <= self.t_max[2] {
            1
        } else {
            2
        };
        self.entry = self.t_max[axis];
        self.cell[axis] += self.step[axis];
        self.t_max[axis] += self.t_delta[axis];
        if self.step[axis] == 0 || outside(self.cell[axis], grid.dims[axis]) {
            self.done = true;
        }
    }

    /// If the sample at parameter `t` lies in an empty block, `Ok` with the parameter at which
    /// that block (and the empty blocks right after it) is left; else `Err` with the parameter
    /// up to which samples stay in occupied blocks (and must all be taken): the exit of the
    /// sample's block, or, where the caller has samples up to `horizon` (≥ t) to place, of
    /// the last of the occupied blocks that follow it along the ray up to the first block
    /// leaving which passes `horizon` (∞ where the ray leaves the grid first). The blocks
    /// after the first are walked here rather than one question each: the same answer for
    /// every later sample, since each lies in an occupied block either way.
    /// Calls must come with non-decreasing `t`. Always inlined: from `Cursor::next_run` the
    /// compiler left it a call per question.
    #[inline(always)]
    pub(crate) fn skip_until(&mut self, grid: &SkipGrid, t: f64, horizon: f64) -> Result<f64, f64> {
        while !self.done && self.left_before(t) {
            self.advance(grid);
        }
        if self.done {
            return Err(f64::INFINITY);
        }
        if grid.distance(self.cell) == 0 {
            // (The exit of an occupied block whose samples end before the horizon: the next
            // block is the one a later sample would have asked about.)
            let mut exit = self.exit();
            while exit <= horizon {
                self.advance(grid);
                if self.done {
                    return Err(f64::INFINITY);
                }
                if grid.distance(self.cell) != 0 {
                    break;
                }
                exit = self.exit();
            }
            return Err(exit);
        }
        // Leave this and every following empty block at once.
        loop {
            let r = grid.distance(self.cell) as i64;
            if r == 0 {
                // The entry of this occupied block is where the empty run ended.
                return Ok(self.entry);
            }
            if r > STEP_BELOW {
                if let Some(t_exit) = self.leap(grid, r) {
                    if self.done {
                        return Ok(t_exit);
                    }
                    continue;
                }
            }
            // A short empty run, or no progress possible by leaping (a degenerate direction):
            // one block on (`advance` keeps the parameter at which the block was left).
            self.advance(grid);
            if self.done {
                return Ok(self.entry);
            }
        }
    }

    /// Leaves in one step the cube of blocks within `r − 1` of the current one (all empty) and
    /// returns the parameter at which it did; `None` (and nothing moved) when the ray cannot
    /// leave it forwards.
    fn leap(&mut self, grid: &SkipGrid, r: i64) -> Option<f64> {
        let mut t_exit = f64::INFINITY;
        let mut axis_exit = 0;
        for axis in 0..3 {
            let (lo, hi) = (self.cell[axis] - (r - 1), self.cell[axis] + r);
            let t = match self.step[axis] {
                1 => {
                    (grid.origin[axis] + hi as f64 * grid.cell[axis] - self.o[axis])
                        * self.inv_d[axis]
                }
                -1 => {
                    (grid.origin[axis] + lo as f64 * grid.cell[axis] - self.o[axis])
                        * self.inv_d[axis]
                }
                _ => f64::INFINITY,
            };
            if t < t_exit {
                t_exit = t;
                axis_exit = axis;
            }
        }
        if !t_exit.is_finite() || t_exit <= self.entry {
            return None;
        }
        // The block just outside the cube on the axis the ray leaves it by.
        let mut forced = [None; 3];
        forced[axis_exit] = Some(self.cell[axis_exit] + self.step[axis_exit] * r);
        self.relocate(grid, t_exit, forced);
        self.entry = t_exit;
        Some(t_exit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift64*), uniform in [0, 1).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    impl Walk {
        fn clone_walk(&self) -> Walk {
            Walk { ..*self }
        }
    }

    /// A grid over the unit cube with the given occupied blocks (distance map as `build`
    /// makes it).
    fn grid_of(dims: [usize; 3], occupied: &[bool]) -> SkipGrid {
        let cell = DVec3::ONE / DVec3::from_array(dims.map(|n| n as f64));
        SkipGrid::of_occupied(dims, DVec3::ZERO, cell, occupied)
    }

    fn random_grid(rng: &mut Rng, fill: f64) -> SkipGrid {
        let dims = [
            5 + (rng.next() * 6.0) as usize,
            4 + (rng.next() * 6.0) as usize,
            6,
        ];
        let occupied: Vec<bool> = (0..dims.iter().product())
            .map(|_| rng.next() < fill)
            .collect();
        grid_of(dims, &occupied)
    }

    /// The distance map is, for every block, the chessboard (L∞) distance to the nearest
    /// occupied block capped at `MAX_LEAP` (0 for an occupied block, `MAX_LEAP` where none is
    /// nearer or there is none), checked by brute force over all pairs of blocks: grids with
    /// axes of one block, long thin ones (lines longer than the cap and than rayon's minimum
    /// share), empty, full and sparse ones; and the same map on one thread as on two.
    #[test]
    fn distance_map_is_the_capped_chessboard_distance() {
        let mut rng = Rng(0x5eed_c4e5);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let mut checked = 0usize;
        for case in 0..120 {
            let mut dims = [
                1 + (rng.next() * 12.0) as usize,
                1 + (rng.next() * 12.0) as usize,
                1 + (rng.next() * 12.0) as usize,
            ];
            if case % 5 == 0 {
                dims[case / 5 % 3] = 40 + (rng.next() * 30.0) as usize;
            }
            let fill = [0.0, 0.002, 0.02, 0.2, 0.9, 1.0][case % 6];
            let n: usize = dims.iter().product();
            let occupied: Vec<bool> = (0..n).map(|_| rng.next() < fill).collect();
            let start: Vec<u8> = occupied
                .iter()
                .map(|&o| if o { 0 } else { MAX_LEAP })
                .collect();
            let mut dist = start.clone();
            chessboard(&mut dist, dims);
            let mut alone = start;
            one.install(|| chessboard(&mut alone, dims));
            assert_eq!(dist, alone, "{dims:?}");
            let coords = |i: usize| [i % dims[0], i / dims[0] % dims[1], i / dims[0] / dims[1]];
            for (i, &d) in dist.iter().enumerate() {
                let a = coords(i);
                let want = (0..n)
                    .filter(|&j| occupied[j])
                    .map(|j| {
                        let b = coords(j);
                        (0..3).map(|k| a[k].abs_diff(b[k])).max().unwrap()
                    })
                    .min()
                    .map_or(MAX_LEAP, |m| m.min(MAX_LEAP as usize) as u8);
                assert_eq!(d, want, "{dims:?} block {a:?}");
                checked += 1;
            }
        }
        assert!(checked > 50_000, "{checked}");
    }

    /// The shell is exactly the occupied blocks with an empty block or the outside among their
    /// 26 neighbours (checked against signed neighbour coordinates).
    #[test]
    fn shell_is_the_occupied_blocks_with_an_open_neighbour() {
        let mut rng = Rng(0x5eed_0001);
        for fill in [0.0, 0.2, 0.6, 0.95, 1.0] {
            for _ in 0..20 {
                let g = random_grid(&mut rng, fill);
                let [nx, ny, nz] = g.dims.map(|n| n as i64);
                let occupied = |i: i64, j: i64, k: i64| {
                    (0..nx).contains(&i)
                        && (0..ny).contains(&j)
                        && (0..nz).contains(&k)
                        && g.distance([i, j, k]) == 0
                };
                let mut want = Vec::new();
                for k in 0..nz {
                    for j in 0..ny {
                        for i in 0..nx {
                            let open = (-1..=1).any(|c| {
                                (-1..=1).any(|b| (-1..=1).any(|a| !occupied(i + a, j + b, k + c)))
                            });
                            if occupied(i, j, k) && open {
                                want.push((i + nx * (j + ny * k)) as usize);
                            }
                        }
                    }
                }
                let want: Vec<_> = want.into_iter().map(|i| g.block_box(i)).collect();
                assert_eq!(g.shell.corners, want, "fill {fill}");
            }
        }
    }

    /// The parameter at which the object-space ray `o + t·d` first enters an occupied block
    /// (slab test against every one; ∞ if none).
    fn first_occupied(g: &SkipGrid, o: DVec3, d: DVec3) -> f64 {
        (0..g.dist.len())
            .filter(|&i| g.dist[i] == 0)
            .map(|i| entry(g.block_box(i), o, d))
            .fold(f64::INFINITY, f64::min)
    }

    /// The parameter t ≥ 0 at which `o + t·d` enters the box (lo, hi) (slab test); ∞ if it
    /// misses.
    fn entry((lo, hi): (DVec3, DVec3), o: DVec3, d: DVec3) -> f64 {
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for a in 0..3 {
            let (u, v) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
            t0 = t0.max(u.min(v));
            t1 = t1.min(u.max(v));
        }
        if t0 <= t1 {
            t0
        } else {
            f64::INFINITY
        }
    }

    /// A random object-to-world transform: scales of 20 to 40, any rotation, translations
    /// up to 50.
    fn random_placement(rng: &mut Rng) -> DMat4 {
        let angles = (rng.next() * 6.0, rng.next() * 6.0, rng.next() * 6.0);
        DMat4::from_scale_rotation_translation(
            DVec3::new(30.0, 20.0 + 20.0 * rng.next(), 25.0),
            glam::DQuat::from_euler(glam::EulerRot::XYZ, angles.0, angles.1, angles.2),
            DVec3::new(rng.next() * 100.0 - 50.0, 7.0, -3.0),
        )
    }

    /// Hits and bounds of rays checked against an entry map.
    #[derive(Default)]
    struct Tally {
        hits: usize,
        misses: usize,
        ratio: f64,
    }

    impl Tally {
        /// Checks `map` for the rays of `camera` through every pixel's centre, two corners and
        /// `random` random points: none meets what `first` finds (the parameter at which the
        /// object-space ray `o + t·d` first meets something that may hold opacity) before its
        /// pixel's bound, and none meets it at all where the bound is ∞.
        fn check(
            &mut self,
            rng: &mut Rng,
            (map, camera, to_world): (&EntryMap, &Pinhole, DMat4),
            random: usize,
            first: impl Fn(DVec3, DVec3) -> f64,
            case: usize,
        ) {
            let to_object = to_world.inverse();
            for py in 0..camera.height {
                for px in 0..camera.width {
                    let bound = map.bound(px, py);
                    let mut offsets = vec![(0.5, 0.5), (0.0, 0.0), (0.999_999, 0.999_999)];
                    offsets.extend((0..random).map(|_| (rng.next(), rng.next())));
                    for (dx, dy) in offsets {
                        let (x, y) = (px as f64 + dx, py as f64 + dy);
                        let dir = camera.ray(x, y);
                        let o = to_object.transform_point3(camera.eye);
                        let hit = first(o, to_object.transform_vector3(dir));
                        assert!(
                            bound <= hit,
                            "case {case} pixel ({px}, {py}) at ({x}, {y}): bound {bound} \
                             past the first hit at {hit}"
                        );
                        if hit.is_finite() {
                            self.hits += 1;
                            self.ratio += bound / hit;
                        } else if bound.is_infinite() {
                            self.misses += 1;
                        }
                    }
                }
            }
        }

        /// The bounds were informative: background pixels exist, and a hit ray's bound is
        /// close to its hit (a pixel's bound is the nearest depth of any box whose rectangle
        /// meets it: 0.86 of the hit on average in these tests; a map that knew nothing would
        /// give 0).
        fn informative(&self) {
            assert!(
                self.hits > 1000 && self.misses > 1000,
                "{} hits, {} bare misses",
                self.hits,
                self.misses
            );
            let mean = self.ratio / self.hits as f64;
            assert!(mean > 0.75, "mean bound / hit {mean}");
        }
    }

    /// A camera `distance` from the centre of the object `to_world` places, looking at it
    /// from direction `from`.
    fn camera_at(to_world: DMat4, from: DVec3, distance: f64, size: u32) -> Pinhole {
        let centre = to_world.transform_point3(DVec3::splat(0.5));
        let eye = centre + from.normalize() * distance;
        let forward = (centre - eye).normalize();
        let right = DVec3::Z.cross(forward).normalize() * 0.4;
        let up = forward.cross(right).normalize() * 0.35;
        Pinhole {
            eye,
            forward,
            right,
            up,
            width: size,
            height: size - 3,
        }
    }

    /// Every ray through every pixel (its centre, its corners and random points in it) meets
    /// no occupied block before the pixel's bound, and none at all where the bound is ∞, with
    /// the eye outside the grid or inside it in an empty slab; the bounds are informative
    /// (background pixels exist, and a hit ray's bound is close to its hit).
    #[test]
    fn entry_bounds_never_pass_an_occupied_block() {
        let mut rng = Rng(0x5eed_0002);
        let mut tally = Tally::default();
        for case in 0..32 {
            let mut g = random_grid(&mut rng, [0.03, 0.1, 0.3][case % 3]);
            let to_world = random_placement(&mut rng);
            let from = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
            let camera = if case < 24 {
                camera_at(to_world, from, 90.0 + 60.0 * rng.next(), 24)
            } else {
                // The eye inside the grid, in an empty slab (the first three layers), looking
                // along +z at the rest.
                let occupied: Vec<bool> = (0..g.dist.len())
                    .map(|i| i / (g.dims[0] * g.dims[1]) >= 3 && g.dist[i] == 0)
                    .collect();
                g = grid_of(g.dims, &occupied);
                let eye = DVec3::new(0.3 + 0.4 * rng.next(), 0.3 + 0.4 * rng.next(), 0.1);
                let forward = to_world.transform_vector3(DVec3::Z).normalize();
                let right = forward.any_orthonormal_vector() * 0.4;
                Pinhole {
                    eye: to_world.transform_point3(eye),
                    forward,
                    right,
                    up: forward.cross(right).normalize() * 0.35,
                    width: 24,
                    height: 21,
                }
            };
            let Some(map) = EntryMap::build(&g, to_world, &camera) else {
                panic!("case {case}: a camera with the volume in front gets a map");
            };
            let first = |o, d| first_occupied(&g, o, d);
            tally.check(&mut rng, (&map, &camera, to_world), 4, first, case);
        }
        tally.informative();
    }

    /// A dataset of `dims` nodes, 8-bit, with a few random spheres of 255 in 0 (each node
    /// 255 or 0).
    fn spheres(rng: &mut Rng, dims: [usize; 3], count: usize) -> Dataset {
        let centres: Vec<(DVec3, f64)> = (0..count)
            .map(|_| {
                let c = DVec3::new(rng.next(), rng.next(), rng.next());
                (c, 0.05 + 0.2 * rng.next())
            })
            .collect();
        let mut raw = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = DVec3::new(i as f64, j as f64, k as f64)
                        / DVec3::from_array(dims.map(|n| (n - 1) as f64));
                    let inside = centres.iter().any(|(c, r)| p.distance(*c) < *r);
                    raw.push(if inside { 255u8 } else { 0 });
                }
            }
        }
        Dataset::new(dims, crate::dataset::Voxels::U8(raw), 0.0, 255.0).unwrap()
    }

    /// The first parameter at which `o + t·d` (t ≥ 0) enters the box of a cell that can pass
    /// (a cell on a face of the dataset reaching to the object box there); ∞ if none.
    fn first_passing(
        data: &Dataset,
        mask: &CellMask,
        (box_min, box_max): (DVec3, DVec3),
        o: DVec3,
        d: DVec3,
    ) -> f64 {
        let n = data.dims();
        let cells = n.map(|k| k - 1);
        let mut first = f64::INFINITY;
        for k in 0..cells[2] {
            for j in 0..cells[1] {
                for i in 0..cells[0] {
                    if !mask.may_reach(data.node_index([i, j, k])) {
                        continue;
                    }
                    let c = [i, j, k];
                    let lo = DVec3::from_array(std::array::from_fn(|a| match c[a] {
                        0 => box_min[a].min(0.0),
                        v => v as f64 / cells[a] as f64,
                    }));
                    let hi = DVec3::from_array(std::array::from_fn(|a| {
                        if c[a] + 1 == cells[a] {
                            box_max[a].max(1.0)
                        } else {
                            (c[a] + 1) as f64 / cells[a] as f64
                        }
                    }));
                    first = first.min(entry((lo, hi), o, d));
                }
            }
        }
        first
    }

    /// A group's passing cells, read a row of mask bits at a time, are those its cells' own
    /// bits give: over random masks, groups at the grid's faces and runs crossing words.
    #[test]
    fn passing_cells_of_a_group_are_those_of_their_bits() {
        let mut rng = Rng(0x5eed_0017);
        for case in 0..12 {
            let dims = [70 + case, 9 + case % 4, 7];
            let data = spheres(&mut rng, dims, 1 + case % 3);
            let mask = data.cells_above(0.3 + 0.05 * (case % 5) as f32);
            let cells = dims.map(|n| n - 1);
            for gk in 0..cells[2].div_ceil(BRICK) {
                for gj in 0..cells[1].div_ceil(BRICK) {
                    for gi in 0..cells[0].div_ceil(BRICK) {
                        let lo = [gi, gj, gk].map(|g| g * BRICK);
                        let hi = std::array::from_fn(|a| (lo[a] + BRICK).min(cells[a]));
                        let (mut first, mut last, mut all) = ([usize::MAX; 3], [0; 3], true);
                        for k in lo[2]..hi[2] {
                            for j in lo[1]..hi[1] {
                                for i in lo[0]..hi[0] {
                                    if mask.may_reach(data.node_index([i, j, k])) {
                                        for (a, c) in [i, j, k].into_iter().enumerate() {
                                            first[a] = first[a].min(c);
                                            last[a] = last[a].max(c);
                                        }
                                    } else {
                                        all = false;
                                    }
                                }
                            }
                        }
                        let want = (first[0] != usize::MAX).then_some((first, last, all));
                        assert_eq!(passing_in(&data, &mask, lo, hi), want, "{dims:?} {lo:?}");
                    }
                }
            }
        }
    }

    /// A row of groups' codes, read from the mask a word at a time, are their groups' passing
    /// cells found group by group (`passing_in`): rows of cells shorter and longer than a
    /// word, multiples of the group and of the word and neither, sparse and dense masks.
    #[test]
    fn rows_of_groups_are_their_groups() {
        let mut rng = Rng(0x5eed_0031);
        let mut seen = [0usize; 3]; // none, some, all of a group's cells pass
        for (case, nx) in [2, 5, 17, 61, 64, 65, 66, 129, 130, 200]
            .into_iter()
            .enumerate()
        {
            let dims = [nx, 6 + case % 3, 5 + case % 4];
            let data = spheres(&mut rng, dims, 1 + case % 3);
            for z in [0.0, 0.05, 0.3, 0.6] {
                let mask = data.cells_above(z);
                let cells = dims.map(|n| n - 1);
                let groups = cells.map(|c| c.div_ceil(BRICK));
                for gk in 0..groups[2] {
                    for gj in 0..groups[1] {
                        let mut row = vec![GroupCode(0); groups[0]];
                        passing_groups_row(&data, &mask, cells, (gj, gk), &mut row);
                        for (gi, &code) in row.iter().enumerate() {
                            let lo = [gi, gj, gk].map(|g| g * BRICK);
                            let hi = std::array::from_fn(|a| (lo[a] + BRICK).min(cells[a]));
                            let want = passing_in(&data, &mask, lo, hi);
                            assert_eq!(code, GroupCode::new(lo, want), "{dims:?} z {z} {lo:?}");
                            seen[match want {
                                None => 0,
                                Some((_, _, false)) => 1,
                                Some((_, _, true)) => 2,
                            }] += 1;
                        }
                    }
                }
            }
        }
        assert!(
            seen.iter().all(|&n| n > 20),
            "every kind of group: {seen:?}"
        );
    }

    /// A group's code gives back every passing-cells triple a group can have (each axis's
    /// lowest and highest passing cell within `BRICK` of its first cell, all or not), and
    /// none where none passes; codes of different triples differ.
    #[test]
    fn group_codes_give_back_their_groups() {
        let pairs: Vec<(usize, usize)> = (0..BRICK)
            .flat_map(|f| (f..BRICK).map(move |l| (f, l)))
            .collect();
        let mut seen = std::collections::HashSet::new();
        for (n, lo) in [
            [0, 0, 0],
            [4, 8, 12],
            [196, 232, 188],
            [1 << 30, 4, 1 << 40],
        ]
        .into_iter()
        .enumerate()
        {
            assert_eq!(GroupCode::new(lo, None).get(lo), None);
            assert!(!GroupCode::NONE.all());
            for &x in &pairs {
                for &y in &pairs {
                    for &z in &pairs {
                        for all in [false, true] {
                            let g = (
                                [lo[0] + x.0, lo[1] + y.0, lo[2] + z.0],
                                [lo[0] + x.1, lo[1] + y.1, lo[2] + z.1],
                                all,
                            );
                            let code = GroupCode::new(lo, Some(g));
                            assert_ne!(code, GroupCode::NONE);
                            assert_eq!(code.get(lo), Some(g), "{lo:?}");
                            assert_eq!(code.all(), all);
                            if n == 0 {
                                assert!(seen.insert(code.0), "{g:?}");
                            }
                        }
                    }
                }
            }
        }
        assert_eq!(seen.len(), 2 * pairs.len().pow(3));
    }

    /// With the boxes of the cells that can pass the zero test, no ray through any pixel
    /// meets such a cell before its pixel's bound, none at all where the bound is ∞, for
    /// object boxes of 1 and 1.3 (samples outside the dataset take its edge cells' values),
    /// cameras outside and inside the volume; the enclosed groups left out are really
    /// enclosed (a full volume has boxes only at its faces); the bounds are informative.
    #[test]
    fn passing_boxes_bound_every_ray() {
        let mut rng = Rng(0x5eed_0004);
        let mut tally = Tally::default();
        for case in 0..24 {
            let dims = [13 + case % 5, 11 + case % 3, 12];
            let data = spheres(&mut rng, dims, 1 + case % 4);
            let mask = data.cells_above(0.5);
            let half = if case % 2 == 0 { 0.5 } else { 0.65 };
            let (box_min, box_max) = (DVec3::splat(0.5 - half), DVec3::splat(0.5 + half));
            let boxes = passing_boxes(&data, &mask, box_min, box_max).expect("3D");
            let to_world = random_placement(&mut rng);
            let from = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
            let camera = if case % 6 != 5 {
                camera_at(to_world, from, 90.0 + 60.0 * rng.next(), 24)
            } else {
                // Inside the volume: a map only if no box is around or behind the eye.
                Pinhole {
                    eye: to_world.transform_point3(DVec3::new(rng.next(), rng.next(), 0.02)),
                    ..camera_at(to_world, from, 90.0, 24)
                }
            };
            let Some(map) = EntryMap::of_boxes(&boxes, to_world, &camera) else {
                assert!(case % 6 == 5, "case {case}: an outside camera gets a map");
                continue;
            };
            let first = |o, d| first_passing(&data, &mask, (box_min, box_max), o, d);
            tally.check(&mut rng, (&map, &camera, to_world), 1, first, case);
        }
        tally.informative();
        // A volume whose every cell passes: only the groups at its faces have boxes.
        let raw = vec![255u8; 17 * 17 * 17];
        let full = Dataset::new([17; 3], crate::dataset::Voxels::U8(raw), 0.0, 255.0).unwrap();
        let boxes =
            passing_boxes(&full, &full.cells_above(0.5), DVec3::ZERO, DVec3::ONE).expect("3D");
        assert_eq!(boxes.corners.len(), 4 * 4 * 4 - 2 * 2 * 2);
    }

    /// No map where the walk's start cannot be proved: the eye in the grid, a shell corner
    /// behind the eye, or more marking than the budget; and a grid with no occupied block
    /// needs none.
    #[test]
    fn entry_map_refuses_what_it_cannot_prove() {
        let mut rng = Rng(0x5eed_0003);
        let g = random_grid(&mut rng, 0.3);
        let to_world = DMat4::from_scale(DVec3::splat(40.0));
        let outside = camera_at(to_world, DVec3::new(1.0, 0.3, 0.2), 100.0, 16);
        assert!(EntryMap::build(&g, to_world, &outside).is_some());
        // Within one block of the grid, the grid's corner included.
        for eye in [
            DVec3::splat(20.0),
            DVec3::ZERO,
            DVec3::splat(-40.0 / 6.0 + 0.1),
        ] {
            let inside = Pinhole {
                eye,
                ..camera_at(to_world, DVec3::X, 100.0, 16)
            };
            assert!(
                EntryMap::build(&g, to_world, &inside).is_none(),
                "eye at {eye}"
            );
        }
        // Outside, but looking away: the shell is behind the eye.
        let away = Pinhole {
            forward: -outside.forward,
            ..camera_at(to_world, DVec3::new(1.0, 0.3, 0.2), 100.0, 16)
        };
        assert!(EntryMap::build(&g, to_world, &away).is_none());
        // The budget: what the default marks, and one pixel less.
        let marked =
            |budget| EntryMap::build_within(&g.shell, to_world, &outside, budget).is_some();
        let need = (0..=16 * 13 * 64)
            .find(|&b| marked(b))
            .expect("within the default budget");
        assert!(need > 0 && !marked(need - 1));
        // More boxes than pixels: not worth projecting.
        let tiny = Pinhole {
            width: 2,
            height: 2,
            ..camera_at(to_world, DVec3::new(1.0, 0.3, 0.2), 100.0, 16)
        };
        assert!(g.shell.corners.len() > 4);
        assert!(EntryMap::of_boxes(&g.shell, to_world, &tiny).is_none());
        let few = Boxes {
            corners: g.shell.corners[..4].to_vec(),
            unit: g.shell.unit,
        };
        assert!(EntryMap::of_boxes(&few, to_world, &tiny).is_some());
        // Nothing occupied: nothing to project.
        let empty = grid_of(g.dims, &vec![false; g.dist.len()]);
        assert!(EntryMap::build(&empty, to_world, &outside).is_none());
    }

    /// [`EntryMap::build_within`] as it was with `f64::min` / `f64::max` for the rectangles
    /// and the corners picked by mask (sequential: the parallel form gives the same numbers).
    fn build_within_reference(
        boxes: &Boxes,
        to_world: DMat4,
        camera: &Pinhole,
        budget: usize,
    ) -> Option<EntryMap> {
        let (w, h) = (camera.width as usize, camera.height as usize);
        if w == 0 || h == 0 || boxes.corners.is_empty() {
            return None;
        }
        let margin = boxes.unit * 0.125;
        // Coefficients (depth, right, up) of an eye-relative vector: the rays' own basis.
        let basis = DMat3::from_cols(camera.forward, camera.right, camera.up);
        let det = basis.determinant().abs();
        if det.is_nan() || det <= 1e-12 {
            return None;
        }
        let to_view = basis.inverse();
        let unit_forward = camera.forward.normalize_or_zero();
        let (wf, hf) = (w as f64, h as f64);
        // Each box's pixel rectangle and depth, in parallel; `None` gives up.
        let project = |&(lo, hi): &(DVec3, DVec3)| -> Option<Option<Mark>> {
            let (lo, hi) = (lo - margin, hi + margin);
            let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
            let (mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
            let mut near = f64::INFINITY;
            for corner in 0..8 {
                let p = DVec3::select(
                    glam::BVec3::new(corner & 1 != 0, corner & 2 != 0, corner & 4 != 0),
                    hi,
                    lo,
                );
                let q = to_world.transform_point3(p) - camera.eye;
                let v = to_view * q;
                // Clearly in front (a corner at or behind the eye's plane breaks the hull
                // argument); NaN fails too.
                if v.x.partial_cmp(&(1e-9 * q.length())) != Some(std::cmp::Ordering::Greater) {
                    return None;
                }
                let (x, y) = ((v.y / v.x + 1.0) * 0.5 * wf, (1.0 - v.z / v.x) * 0.5 * hf);
                if !(x.is_finite() && y.is_finite()) {
                    return None;
                }
                (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
                near = near.min(q.dot(unit_forward));
            }
            // Pixel squares [px, px + 1) meeting [x0 − ε, x1 + ε] (and likewise in y).
            const EPS: f64 = 0.01;
            let (px0, px1) = (
                (x0 - EPS).floor().max(0.0),
                (x1 + EPS).floor().min(wf - 1.0),
            );
            let (py0, py1) = (
                (y0 - EPS).floor().max(0.0),
                (y1 + EPS).floor().min(hf - 1.0),
            );
            if px0 > px1 || py0 > py1 {
                return Some(None); // off the image
            }
            Some(Some(Mark {
                x: (px0 as usize, px1 as usize),
                y: (py0 as usize, py1 as usize),
                // Rounding of the depth itself: a relative slack far below the margin's.
                near: near - 1e-9 * near.abs(),
            }))
        };
        let marks: Vec<Mark> = boxes
            .corners
            .iter()
            .filter_map(|b| match project(b) {
                None => Some(None), // give up
                Some(None) => None, // off the image
                Some(mark) => Some(mark),
            })
            .collect::<Option<Vec<Mark>>>()?;
        let area = marks.iter().fold(0usize, |sum, m| {
            sum.saturating_add((m.x.1 - m.x.0 + 1) * (m.y.1 - m.y.0 + 1))
        });
        if area > budget {
            return None;
        }
        // The rectangles' minimum, in parallel over bands of rows (the same numbers in any
        // order).
        let mut bound = vec![f64::INFINITY; w * h];
        bound
            .chunks_mut(ENTRY_BAND * w)
            .enumerate()
            .for_each(|(band, rows)| {
                let first = band * ENTRY_BAND;
                let last = first + rows.len() / w - 1;
                for m in &marks {
                    let (y0, y1) = (m.y.0.max(first), m.y.1.min(last));
                    for y in y0..=y1 {
                        let row = &mut rows[(y - first) * w..(y - first + 1) * w];
                        for b in &mut row[m.x.0..=m.x.1] {
                            // (Neither is NaN: a comparison in lanes, not `f64::min`.)
                            *b = if m.near < *b { m.near } else { *b };
                        }
                    }
                }
            });
        Some(EntryMap { width: w, bound })
    }

    /// The map is the one the NaN-aware minima and maxima and each corner's own transform
    /// gave (the reference), up to the rounding of the affine corners: the same refusals, the
    /// same marked pixels, and every bound within a relative 10⁻¹² of the reference's (a
    /// rectangle's edge moves with rounding only where it lies within that of a pixel's edge,
    /// which these cases never do): random grids, placements and cameras, far and near
    /// (corners close to or behind the eye's plane: no map), looking away, tiny images and
    /// budgets.
    #[test]
    fn entry_map_is_the_nan_aware_projection() {
        let mut rng = Rng(0x5eed_0004);
        let (mut maps, mut refusals) = (0, 0);
        for case in 0..60 {
            let g = random_grid(&mut rng, [0.03, 0.1, 0.3][case % 3]);
            let to_world = random_placement(&mut rng);
            let from = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
            let distance = [90.0 + 60.0 * rng.next(), 40.0 * rng.next(), 1e-3][case % 3];
            let size = [24, 7, 4][case / 3 % 3];
            let mut camera = camera_at(to_world, from, distance, size);
            if case % 10 == 9 {
                camera.forward = -camera.forward;
            }
            for budget in [usize::MAX, 50] {
                let new = EntryMap::build_within(&g.shell, to_world, &camera, budget);
                let old = build_within_reference(&g.shell, to_world, &camera, budget);
                match (new, old) {
                    (None, None) => refusals += 1,
                    (Some(new), Some(old)) => {
                        assert_eq!(new.width, old.width);
                        for (a, b) in new.bound.iter().zip(&old.bound) {
                            assert_eq!(a.is_finite(), b.is_finite(), "case {case}: {a} {b}");
                            if b.is_finite() {
                                assert!(
                                    (a - b).abs() <= 1e-12 * b.abs(),
                                    "case {case}: {a} against {b}"
                                );
                            }
                        }
                        maps += 1;
                    }
                    (new, old) => panic!(
                        "case {case}, budget {budget}: {} against {}",
                        new.is_some(),
                        old.is_some()
                    ),
                }
            }
        }
        assert!(
            maps > 20 && refusals > 10,
            "{maps} maps, {refusals} refusals"
        );
    }

    /// The block index is the clamped floor, at block boundaries, just inside and outside the
    /// grid, far away, at infinities and NaN.
    #[test]
    fn block_index_is_the_clamped_floor() {
        for last in [0.0, 1.0, 49.0] {
            let mut rels = vec![
                f64::NAN,
                f64::INFINITY,
                f64::NEG_INFINITY,
                -0.0,
                1e300,
                -1e300,
                last,
                last + 0.5,
                last + 1.0,
            ];
            for i in -300..=300 {
                let r = i as f64 / 4.0;
                rels.extend([r, r - 1e-12, r + 1e-12]);
            }
            for rel in rels {
                let want = if rel.is_nan() {
                    0
                } else {
                    rel.floor().clamp(0.0, last) as i64
                };
                assert_eq!(block_index(rel, last), want, "{rel} in [0, {last}]");
            }
        }
    }

    /// `Walk::exit` by comparisons equals the `f64::min` chain it replaced, bit for bit, on
    /// every triple of awkward exits (±0, ±∞, NaN, subnormals, extremes) and random bits.
    #[test]
    fn exit_is_the_nan_aware_minimum() {
        let walk = |t_max: [f64; 3]| Walk {
            o: DVec3::ZERO,
            d: DVec3::X,
            inv_d: DVec3::X,
            cell: [0; 3],
            step: [0; 3],
            t_max,
            t_delta: [f64::INFINITY; 3],
            done: false,
            entry: 0.0,
        };
        let old = |t: [f64; 3]| {
            std::hint::black_box(t[0])
                .min(std::hint::black_box(t[1]))
                .min(std::hint::black_box(t[2]))
        };
        let mut vals = vec![
            0.0,
            -0.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
            f64::from_bits(1),
            -f64::from_bits(1),
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::MIN,
            1.0,
            -1.0,
            2.5,
        ];
        let rng = crate::testing::Xorshift::new(0x9e37_79b9_7f4a_7c15u64);
        vals.extend((0..20).map(|_| f64::from_bits(rng.bits())));
        for &a in &vals {
            for &b in &vals {
                for &c in &vals {
                    let t = [a, b, c];
                    let got = std::hint::black_box(walk(t)).exit();
                    assert_eq!(got.to_bits(), old(t).to_bits(), "{t:?}");
                }
            }
        }
    }

    /// `Walk::relocate` without the bounds test on unforced axes (`block_index` clamps into
    /// the grid) leaves the walk as the old body did, bit for bit, at awkward parameters and
    /// points (outside the grid, ±0, ±∞, NaN, subnormal and zero direction parts) and with
    /// forced indices in and out of the grid (NaN exits as NaN, whatever their bits).
    #[test]
    fn relocate_is_the_bounds_checked_relocate() {
        fn old(w: &mut Walk, grid: &SkipGrid, t0: f64, forced: [Option<i64>; 3]) {
            let p = w.o + t0 * w.d;
            for axis in 0..3 {
                let c = match forced[axis] {
                    Some(c) => c,
                    None => {
                        let rel = (p[axis] - grid.origin[axis]) * grid.inv_cell[axis];
                        block_index(rel, grid.last[axis])
                    }
                };
                if c < 0 || c >= grid.dims[axis] as i64 {
                    w.done = true;
                    return;
                }
                w.cell[axis] = c;
                let size = grid.cell[axis];
                let (d, inv) = (w.d[axis], w.inv_d[axis]);
                if d > 0.0 {
                    let boundary = grid.origin[axis] + (c + 1) as f64 * size;
                    w.t_max[axis] = t0 + (boundary - p[axis]) * inv;
                } else if d < 0.0 {
                    let boundary = grid.origin[axis] + c as f64 * size;
                    w.t_max[axis] = t0 + (boundary - p[axis]) * inv;
                }
            }
        }
        // A NaN's sign and payload follow the operand order the compiler picks for the
        // arithmetic (x86 keeps the first NaN operand's), not the code: NaNs compare as one.
        let bits = |t: f64| {
            if t.is_nan() {
                f64::NAN.to_bits()
            } else {
                t.to_bits()
            }
        };
        let state = |w: &Walk| (w.cell, w.t_max.map(bits), w.done, w.entry.to_bits());
        let grid = grid_of([5, 4, 3], &[false; 60]);
        let parts = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.3,
            -0.7,
            f64::from_bits(1),
            -f64::from_bits(1),
            1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let ts = [0.0, -0.0, 0.25, 1.0, -3.0, 1e300, f64::INFINITY, f64::NAN];
        let forceds = [
            [None, None, None],
            [Some(4), None, None],
            [None, Some(-1), None],
            [None, None, Some(3)],
            [Some(5), Some(0), None],
        ];
        let mut n = 0;
        for &ox in &parts {
            for &dx in &parts {
                for &dy in &parts {
                    let o = DVec3::new(ox, 0.4, -0.2);
                    let d = DVec3::new(dx, dy, 0.5);
                    let mut slot = None;
                    let start = grid.walk_into(&mut slot, o, d, 0.0);
                    for &t0 in &ts {
                        for forced in forceds {
                            let (mut a, mut b) = (start.clone_walk(), start.clone_walk());
                            a.relocate(&grid, t0, forced);
                            old(&mut b, &grid, t0, forced);
                            assert_eq!(state(&a), state(&b), "{o} {d} {t0} {forced:?}");
                            n += 1;
                        }
                    }
                }
            }
        }
        assert!(n > 0);
    }

    /// `outside` is the two-sided bounds test it replaced, at and around 0, the grid's size
    /// and the ends of i64.
    #[test]
    fn outside_is_the_two_sided_bounds_test() {
        for dims in [1usize, 2, 5, 255, 1 << 20] {
            let d = dims as i64;
            for c in [
                i64::MIN,
                i64::MIN + 1,
                -d - 1,
                -d,
                -2,
                -1,
                0,
                1,
                d - 1,
                d,
                d + 1,
            ]
            .into_iter()
            .chain([2 * d, i64::MAX - 1, i64::MAX])
            {
                assert_eq!(outside(c, dims), c < 0 || c >= d, "{c} in 0..{dims}");
            }
        }
    }
}
