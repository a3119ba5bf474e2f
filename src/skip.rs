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

use crate::dataset::{bc_abs_sum, Dataset, Filter, BRICK};
use crate::program::Instr;
use crate::types::FIELD_COUNT;
use glam::DVec3;

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
}

/// The largest leap, in blocks.
const MAX_LEAP: u8 = 16;

/// Empty runs whose chessboard distance is at most this are crossed block by block (a DDA
/// step is cheaper than relocating the walk after a leap over so few blocks).
const STEP_BELOW: i64 = 4;

/// The chessboard (L∞) distance transform of `dist` in place: on entry 0 for occupied blocks
/// and `MAX_LEAP` for empty ones; on exit each empty block holds min(distance, MAX_LEAP).
/// Separable: d(x) = min over y of max(|x − y|, d_prev(y)) along each axis in turn.
fn chessboard(dist: &mut [u8], dims: [usize; 3]) {
    let stride = [1, dims[0], dims[0] * dims[1]];
    for axis in 0..3 {
        let n = dims[axis];
        let (s, others) = (stride[axis], [0usize, 1, 2]);
        let lines: Vec<usize> = {
            // The first index of every line along `axis`.
            let o: Vec<usize> = others.iter().copied().filter(|&a| a != axis).collect();
            let mut v = Vec::with_capacity(dims[o[0]] * dims[o[1]]);
            for j in 0..dims[o[1]] {
                for i in 0..dims[o[0]] {
                    v.push(i * stride[o[0]] + j * stride[o[1]]);
                }
            }
            v
        };
        let mut line = vec![0u8; n];
        for start in lines {
            for (x, l) in line.iter_mut().enumerate() {
                *l = dist[start + x * s];
            }
            for x in 0..n {
                let mut best = line[x];
                let r = best as usize;
                let lo = x.saturating_sub(r);
                let hi = (x + r).min(n - 1);
                for (y, &v) in line.iter().enumerate().take(hi + 1).skip(lo) {
                    let d = (x.abs_diff(y) as u8).max(v);
                    best = best.min(d);
                }
                dist[start + x * s] = best;
            }
        }
    }
}

/// The most blocks a grid may have.
const MAX_BLOCKS: usize = 1 << 24;

/// The (min, max) of dataset `d` under `filter` over the object-space box [lo, hi].
/// `overshoot` is the filter's [`overshoot`].
fn dataset_range(d: &Dataset, filter: Filter, overshoot: f64, lo: DVec3, hi: DVec3) -> (f32, f32) {
    let bricks = d.bricks(filter);
    let dims = d.dims();
    let idx = |x: f64, axis: usize| -> usize {
        let n = dims[axis];
        if n == 1 {
            return 0;
        }
        let u = (x * (n - 1) as f64 / BRICK as f64).floor();
        u.clamp(0.0, (bricks.dims[axis] - 1) as f64) as usize
    };
    let (i0, i1) = (idx(lo.x, 0), idx(hi.x, 0));
    let (j0, j1) = (idx(lo.y, 1), idx(hi.y, 1));
    let (k0, k1) = (idx(lo.z, 2), idx(hi.z, 2));
    let (mut mn, mut mx) = (f32::INFINITY, f32::NEG_INFINITY);
    for k in k0..=k1 {
        for j in j0..=j1 {
            for i in i0..=i1 {
                let (a, b) = bricks.get(i, j, k);
                mn = mn.min(a);
                mx = mx.max(b);
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
        let mut any = false;
        // The opacity interval depends on the block only through the datasets' ranges there, and
        // blocks share few distinct ranges: evaluate the interval program once per distinct set.
        let mut memo: std::collections::HashMap<Vec<(u32, u32)>, bool> = Default::default();
        let data: Vec<(&Dataset, Filter, f64)> = prefix
            .iter()
            .filter_map(|i| match i {
                Instr::Dataset { data, filter, .. } => Some((&**data, *filter, overshoot(*filter))),
                _ => None,
            })
            .collect();
        let mut key = Vec::with_capacity(data.len());
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let lo = origin + DVec3::new(i as f64, j as f64, k as f64) * cell;
                    let hi = lo + cell;
                    key.clear();
                    key.extend(data.iter().map(|(d, f, over)| {
                        let (a, b) = dataset_range(d, *f, *over, lo, hi);
                        (a.to_bits(), b.to_bits())
                    }));
                    let e = match memo.get(&key) {
                        Some(&e) => e,
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
                    dist[i + dims[0] * (j + dims[1] * k)] = if e { MAX_LEAP } else { 0 };
                    any |= e;
                }
            }
        }
        if !any {
            return None;
        }
        chessboard(&mut dist, dims);
        Some(SkipGrid {
            dims,
            origin,
            cell,
            inv_cell: cell.recip(),
            last: DVec3::from_array(dims.map(|n| (n - 1) as f64)),
            dist,
        })
    }

    #[inline]
    fn distance(&self, c: [i64; 3]) -> u8 {
        self.dist[c[0] as usize + self.dims[0] * (c[1] as usize + self.dims[1] * c[2] as usize)]
    }

    /// Starts a walk along the object-space ray `o + t·d` at parameter `t0`.
    pub(crate) fn walk(&self, o: DVec3, d: DVec3, t0: f64) -> Walk {
        let mut w = Walk {
            o,
            d,
            inv_d: d.recip(),
            cell: [0; 3],
            step: [0; 3],
            t_max: [f64::INFINITY; 3],
            t_delta: [f64::INFINITY; 3],
            done: false,
            entry: t0,
        };
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

/// The block holding block coordinate `rel`: floor(rel) clamped to [0, last] (`last` an
/// integer ≥ 0), NaN to 0. Clamping first makes the truncation of `as` the floor.
#[inline]
fn block_index(rel: f64, last: f64) -> i64 {
    rel.clamp(0.0, last) as i64
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
    /// block (so rounding cannot put it back).
    fn relocate(&mut self, grid: &SkipGrid, t0: f64, forced: [Option<i64>; 3]) {
        let p = self.o + t0 * self.d;
        for axis in 0..3 {
            let c = match forced[axis] {
                Some(c) => c,
                None => {
                    let rel = (p[axis] - grid.origin[axis]) * grid.inv_cell[axis];
                    block_index(rel, grid.last[axis])
                }
            };
            if c < 0 || c >= grid.dims[axis] as i64 {
                self.done = true;
                return;
            }
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

    /// The ray parameter at which the current block is left.
    #[inline]
    fn exit(&self) -> f64 {
        self.t_max[0].min(self.t_max[1]).min(self.t_max[2])
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
        if self.step[axis] == 0 || self.cell[axis] < 0 || self.cell[axis] >= grid.dims[axis] as i64
        {
            self.done = true;
        }
    }

    /// If the sample at parameter `t` lies in an empty block, `Ok` with the parameter at which
    /// that block (and the empty blocks right after it) is left; else `Err` with the parameter
    /// up to which samples stay in the same occupied block (and must all be taken).
    /// Calls must come with non-decreasing `t`.
    #[inline]
    pub(crate) fn skip_until(&mut self, grid: &SkipGrid, t: f64) -> Result<f64, f64> {
        while !self.done && self.left_before(t) {
            self.advance(grid);
        }
        if self.done {
            return Err(f64::INFINITY);
        }
        if grid.distance(self.cell) == 0 {
            return Err(self.exit());
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
}
