//! The skip grid of one object: its blocks (one brick of the finest dataset feeding opacity
//! each), which of them are empty by the interval evaluation of the opacity program over the
//! datasets' brick ranges (for a pre-integrated object, by those ranges against the zero
//! test's bound), the chessboard distance map over them and the shell of occupied
//! blocks. Owns the grid's construction and layout; the walk along a ray (`walk`), the passing
//! boxes (`passing`) and the entry map (`entry`) read it.

use crate::data::{bc_abs_sum, Bricks, Dataset, Filter, BRICK};
use crate::model::program::Instr;
use crate::types::FIELD_COUNT;
use glam::DVec3;
use rayon::prelude::*;

/// The blocks of one object and which of them are empty.
pub(crate) struct SkipGrid {
    pub(super) dims: [usize; 3],
    /// Object-space corner of block (0, 0, 0).
    pub(super) origin: DVec3,
    /// Object-space size of a block.
    pub(super) cell: DVec3,
    /// Its reciprocal per axis.
    pub(super) inv_cell: DVec3,
    /// The last block's index per axis (dims − 1), as f64.
    pub(super) last: DVec3,
    /// Per block: 0 if it may hold opacity, else the chessboard distance (in blocks, capped at
    /// [`MAX_LEAP`]) to the nearest such block: every block within `dist − 1` of it is empty.
    pub(super) dist: Vec<u8>,
    /// The shell: every block that may hold opacity and has an empty block, or the grid's
    /// outside, among its 26 neighbours, as boxes. A ray that starts outside the grid and
    /// meets a block that may hold opacity meets a shell block first (see [`super::EntryMap`]).
    pub(super) shell: Boxes,
    /// The boxes of the dataset's cells that can pass a zero test, by 4³ cells (see
    /// [`SkipGrid::passing_boxes`]), made by the first render that asks.
    pub(super) passing: std::sync::Mutex<super::passing::Passing>,
}

/// Object-space boxes an [`super::EntryMap`] projects, and the size per axis of the blocks or
/// cells they are made of (the map grows each box by an eighth of it).
pub(crate) struct Boxes {
    list: BoxList,
    pub(super) unit: DVec3,
}

/// The boxes of [`Boxes`]: the grid's blocks or the passing cells' groups, their corners
/// computed when read (eight bytes a box, not the 48 of its two corners).
enum BoxList {
    /// Boxes by their corners (the tests' own).
    #[cfg(test)]
    Corners(Vec<(DVec3, DVec3)>),
    /// Blocks of a grid of `dims` blocks of size `cell` from `origin`, by linear index.
    Blocks {
        index: Vec<u32>,
        dims: [usize; 3],
        origin: DVec3,
        cell: DVec3,
    },
    Groups(super::passing::Groups),
}

impl Boxes {
    /// The boxes of `corners` (lowest and highest corner each), of blocks or cells `unit` in
    /// size.
    #[cfg(test)]
    pub(super) fn of_corners(corners: Vec<(DVec3, DVec3)>, unit: DVec3) -> Boxes {
        Boxes {
            list: BoxList::Corners(corners),
            unit,
        }
    }

    /// The blocks `index` (linear indices) of a grid of `dims` blocks of size `cell` from
    /// `origin`.
    pub(super) fn of_blocks(
        index: Vec<u32>,
        dims: [usize; 3],
        origin: DVec3,
        cell: DVec3,
    ) -> Boxes {
        Boxes {
            list: BoxList::Blocks {
                index,
                dims,
                origin,
                cell,
            },
            unit: cell,
        }
    }

    /// The boxes of passing groups, of cells `unit` in size.
    pub(super) fn of_groups(groups: super::passing::Groups, unit: DVec3) -> Boxes {
        Boxes {
            list: BoxList::Groups(groups),
            unit,
        }
    }

    /// The passing groups' list ([`super::passing::Groups::list`]), where these are theirs.
    #[cfg(test)]
    pub(super) fn groups(&self) -> Option<&[(u32, super::passing::GroupCode)]> {
        match &self.list {
            BoxList::Groups(g) => Some(g.list()),
            _ => None,
        }
    }

    /// How many boxes.
    pub(super) fn len(&self) -> usize {
        match &self.list {
            #[cfg(test)]
            BoxList::Corners(c) => c.len(),
            BoxList::Blocks { index, .. } => index.len(),
            BoxList::Groups(g) => g.len(),
        }
    }

    /// Box `i` (below [`Boxes::len`]): its lowest and highest corner.
    pub(super) fn corners(&self, i: usize) -> (DVec3, DVec3) {
        match &self.list {
            #[cfg(test)]
            BoxList::Corners(c) => c[i],
            BoxList::Blocks {
                index,
                dims,
                origin,
                cell,
            } => block_box(*dims, *origin, *cell, index[i] as usize),
            BoxList::Groups(g) => g.corners(i),
        }
    }
}

/// Block `index` (linear, x fastest) of a grid of `dims` blocks of size `cell` from `origin`, as
/// an object-space box.
fn block_box(dims: [usize; 3], origin: DVec3, cell: DVec3, index: usize) -> (DVec3, DVec3) {
    let c = DVec3::new(
        (index % dims[0]) as f64,
        (index / dims[0] % dims[1]) as f64,
        (index / (dims[0] * dims[1])) as f64,
    );
    (origin + c * cell, origin + (c + 1.0) * cell)
}

/// The largest leap, in blocks.
pub(super) const MAX_LEAP: u8 = 16;

/// The chessboard (L∞) distance transform of `dist` in place: on entry 0 for occupied blocks
/// and `MAX_LEAP` for empty ones; on exit each empty block holds min(distance, MAX_LEAP).
/// Separable: along x the distance to the nearest occupied block of the row (two sweeps: the
/// entry is 0 or the cap); then along y and along z, d(x) = min over y of max(|x − y|,
/// d_prev(y)), |x − y| below the cap, a whole row (y) or plane (z) of blocks at a time in
/// byte lanes. Rows, planes and columns are independent: in parallel, the same numbers for
/// any number of threads.
pub(super) fn chessboard(dist: &mut [u8], dims: [usize; 3]) {
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
/// outside of the grid among their 26 neighbours, by index (below [`MAX_BLOCKS`], so in 32
/// bits), in order.
fn shell(dist: &[u8], dims: [usize; 3]) -> Vec<u32> {
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
                    open.then_some((i + dims[0] * (j + dims[1] * k)) as u32)
                })
        })
        .collect()
}

/// The hasher of the skip grid's memo of opacity intervals (keys: a few pairs of f32 bits, one
/// lookup per block): a multiplicative hash of each word (FxHash's); the standard SipHash costs
/// about as much as the block's brick ranges themselves. The keys are the grid's
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
// (A block's index fits 32 bits: the shell's are kept so.)
const _: () = assert!(MAX_BLOCKS <= u32::MAX as usize);

/// Where a block lies along one axis against the datasets' cube [0, 1] (a dataset is 0
/// outside it, `Dataset::covers`), in the order of their ranges' widening: every sample it
/// holds reads the datasets, some may read 0, or all read 0. Ordered, so that a block's place
/// is the greatest of its three axes'.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Outside {
    Inside,
    Partly,
    Wholly,
}

impl Outside {
    /// The place of the block [lo, hi] along an axis. A sample the walk attributes to the
    /// block lies in it up to the walk's round-off (relative 10⁻¹⁵, in object units): so a
    /// block whose box reaches past 0 or 1 at all may hold samples outside the dataset, and
    /// one whose box is further than twice the tolerance beyond a face holds no sample the
    /// dataset covers.
    fn of(lo: f64, hi: f64) -> Outside {
        let far = 2.0 * crate::data::FACE_TOLERANCE as f64;
        if hi < -far || lo > 1.0 + far {
            Outside::Wholly
        } else if lo < 0.0 || hi > 1.0 {
            Outside::Partly
        } else {
            Outside::Inside
        }
    }
}

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

impl SkipGrid {
    /// The grid for an object whose opacity is decided by `prefix` (its program up to the last
    /// instruction that may write opacity), over the boundary box [box_min, box_max]: a block
    /// is empty where its opacity is provably 0, or, with a `bound` z, where every dataset's
    /// value there is provably at most z (a pre-integrated object, whose slabs read values: a
    /// slab between a value above an opacity band and one below it crosses the band, though
    /// both ends have opacity 0). `None` when no dataset feeds the opacity or no block is
    /// provably empty.
    pub(crate) fn build(
        prefix: &[Instr],
        box_min: DVec3,
        box_max: DVec3,
        bound: Option<f32>,
    ) -> Option<SkipGrid> {
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
        // Where the box reaches outside the datasets' cube, where each block lies along each
        // axis (see [`Outside`]); all `Inside` where it does not.
        let clip = !crate::data::box_covered(box_min, box_max);
        let outside: [Vec<Outside>; 3] = std::array::from_fn(|axis| {
            (0..dims[axis])
                .map(|c| {
                    if !clip {
                        return Outside::Inside;
                    }
                    let lo = origin[axis] + c as f64 * cell[axis];
                    Outside::of(lo, lo + cell[axis])
                })
                .collect()
        });
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
                        let place = outside[0][i].max(outside[1][j]).max(outside[2][k]);
                        key.clear();
                        key.extend(data.iter().map(|(bricks, f, over, spans)| {
                            let at = [spans[0][i], spans[1][j], spans[2][k]];
                            let (a, b) = match place {
                                Outside::Inside => bricks_range(bricks, *f, *over, at),
                                // (0 is below every value: the range then starts there.)
                                Outside::Partly => (0.0, bricks_range(bricks, *f, *over, at).1),
                                Outside::Wholly => (0.0, 0.0),
                            };
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
                                let e = match bound {
                                    Some(z) => ranges.iter().all(|&(_, b)| b <= z),
                                    None => opacity_range(prefix, &ranges).1 <= 0.0,
                                };
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

    /// The grid of `dims` blocks (at most [`MAX_BLOCKS`]) of size `cell` from `origin`, with
    /// distance map `dist`.
    pub(super) fn new(dims: [usize; 3], origin: DVec3, cell: DVec3, dist: Vec<u8>) -> SkipGrid {
        debug_assert!(dist.len() <= MAX_BLOCKS);
        let shell = shell(&dist, dims);
        SkipGrid {
            dims,
            origin,
            cell,
            inv_cell: cell.recip(),
            last: DVec3::from_array(dims.map(|n| (n - 1) as f64)),
            dist,
            shell: Boxes::of_blocks(shell, dims, origin, cell),
            passing: Default::default(),
        }
    }

    /// The block with linear index `index` as an object-space box.
    #[cfg(test)]
    pub(super) fn block_box(&self, index: usize) -> (DVec3, DVec3) {
        block_box(self.dims, self.origin, self.cell, index)
    }

    /// The distance-map entry of block `c` (inside the grid).
    #[inline]
    pub(super) fn distance(&self, c: [i64; 3]) -> u8 {
        self.dist[c[0] as usize + self.dims[0] * (c[1] as usize + self.dims[1] * c[2] as usize)]
    }
}
