//! The boxes of a dataset's cells whose samples can pass a zero test ([`CellMask`]), by groups
//! of 4³ cells, made once per skip grid for the batched march's entry map: per group its
//! passing cells' bounding box, leaving out the groups enclosed by full groups. Owns reading
//! the mask into [`GroupCode`]s and the boxes; projecting them is the entry map's (`entry`).

use super::grid::{Boxes, SkipGrid};
use crate::data::{CellMask, Dataset, BRICK};
use glam::DVec3;
use rayon::prelude::*;

/// The [`GroupCode`]s of the row of groups (gi, gj, gk), gi = 0, 1, …, of `data`'s cells
/// (`cells` per axis, in groups of `BRICK` per axis): each group's lowest and highest passing
/// cell per axis and whether all pass (`passing_in`, the tests' oracle), found together. Each
/// of the groups' rows of cells is read from `mask` 64 cells at a time and split among the
/// groups (whole groups to a word: 64 is a multiple of `BRICK`): reading each group's rows
/// apart would cost a node index and a run of the mask per row and group.
pub(super) fn passing_groups_row(
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

/// A group's passing cells ([`passing_groups_row`]) in 16 bits: each axis's lowest and
/// highest passing cell as offsets (0 … 3) from the group's first cell, two bits each, and
/// whether all pass (bit 12); [`GroupCode::NONE`] where none does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct GroupCode(pub(super) u16);

// Offsets within a group fit in two bits.
const _: () = assert!(BRICK <= 4);

impl GroupCode {
    pub(super) const NONE: GroupCode = GroupCode(u16::MAX);

    /// The code of a group whose passing cells lie between offsets `first` and `last` (each
    /// below `BRICK`) from its first cell per axis, all of its cells passing or not.
    pub(super) fn of_offsets(first: [u8; 3], last: [u8; 3], all: bool) -> GroupCode {
        let mut c = u16::from(all) << 12;
        for a in 0..3 {
            debug_assert!(first[a] <= last[a] && (last[a] as usize) < BRICK);
            c |= u16::from(first[a]) << (2 * a);
            c |= u16::from(last[a]) << (6 + 2 * a);
        }
        GroupCode(c)
    }

    /// Whether all the group's cells pass.
    pub(super) fn all(self) -> bool {
        self != GroupCode::NONE && self.0 >> 12 & 1 != 0
    }

    /// The passing cells again, for the group whose first cell is `lo`.
    pub(super) fn get(self, lo: [usize; 3]) -> Option<([usize; 3], [usize; 3], bool)> {
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

    /// A flag [`passing_boxes`] sets on a group whose eight neighbours in its layer of groups
    /// (along x and y) and itself all pass, the group not on the layer's edge. Outside the
    /// bits of [`GroupCode::of_offsets`], and no flagged code is [`GroupCode::NONE`] (bits 14
    /// and 15 stay clear).
    const PLANE_FULL: u16 = 1 << 13;

    /// Whether the group is flagged [`GroupCode::PLANE_FULL`].
    fn plane_full(self) -> bool {
        self != GroupCode::NONE && self.0 & GroupCode::PLANE_FULL != 0
    }

    /// The code without the flag [`GroupCode::PLANE_FULL`].
    fn without_flag(self) -> GroupCode {
        if self == GroupCode::NONE {
            self
        } else {
            GroupCode(self.0 & !GroupCode::PLANE_FULL)
        }
    }
}

/// Flags ([`GroupCode::PLANE_FULL`]) the groups of one layer (`gx` × `gy` codes, x fastest)
/// that pass with their eight neighbours in it, read in place (the flag leaves
/// [`GroupCode::all`] as it is): no scratch per group.
fn flag_plane_full(codes: &mut [GroupCode], gx: usize, gy: usize) {
    for j in 1..gy.saturating_sub(1) {
        for i in 1..gx.saturating_sub(1) {
            let at = j * gx + i;
            let square = [at - gx, at, at + gx];
            if square
                .iter()
                .all(|&c| codes[c - 1..=c + 1].iter().all(|g| g.all()))
            {
                codes[at].0 |= GroupCode::PLANE_FULL;
            }
        }
    }
}

/// What a [`SkipGrid`] keeps of its passing boxes ([`SkipGrid::passing_boxes`]).
#[derive(Default)]
pub(super) enum Passing {
    /// Not yet asked for.
    #[default]
    Unknown,
    /// None can be made: a dataset with an axis of one node, or memory that cannot be had.
    Unavailable,
    /// More of them than the image that asked could project: their number (not made).
    Many(usize),
    Made(std::sync::Arc<Boxes>),
}

/// See [`SkipGrid::passing_boxes`]; `Some(Err(n))` where there are `n` > `most` of them
/// (found, not made).
pub(super) fn passing_boxes(
    data: &Dataset,
    mask: &CellMask,
    box_min: DVec3,
    box_max: DVec3,
    most: usize,
) -> Option<Result<Boxes, usize>> {
    let n = data.dims();
    if n.iter().any(|&k| k < 2) {
        return None;
    }
    let cells = n.map(|k| k - 1);
    let groups = cells.map(|c| c.div_ceil(BRICK));
    // Per group: the lowest and highest passing cell per axis, and whether all pass
    // ([`GroupCode`]: two bytes a group; the decoded form takes 56, and filling that much fresh
    // memory costs more than reading the cells' bits), one layer of groups a task; then, in
    // the same task, which groups of the layer pass with their eight neighbours in the layer
    // ([`GroupCode::PLANE_FULL`]). Nothing else is kept per group: a group whose whole 3×3×3
    // neighbourhood passes is one flagged between two flagged ones along z.
    let [gx, gy, gz] = groups;
    let layer = gx * gy;
    let mut codes = crate::num::try_vec(layer * gz, GroupCode::NONE, "").ok()?;
    codes
        .par_chunks_mut(layer)
        .enumerate()
        .for_each(|(gk, codes)| {
            for (gj, row) in codes.chunks_exact_mut(gx).enumerate() {
                passing_groups_row(data, mask, cells, (gj, gk), row);
            }
            // (With fewer than three layers no group lies between two along z: none is enclosed.)
            if gz >= 3 {
                flag_plane_full(codes, gx, gy);
            }
        });
    let codes = &codes;
    // Group `at` of layer `gk`, unless its 26 neighbours and itself all pass (along z the
    // layers on either side; groups on the grid's faces are never enclosed).
    let kept = move |gk: usize, at: usize| -> Option<(u32, GroupCode)> {
        let code = codes[gk * layer + at];
        let flagged = |k: usize| codes[k * layer + at].plane_full();
        let enclosed = gk > 0 && gk + 1 < gz && flagged(gk - 1) && flagged(gk) && flagged(gk + 1);
        // (Below 2³²: a dataset has at most 2³² nodes, and a group holds 64 cells.)
        (code != GroupCode::NONE && !enclosed)
            .then(|| ((at + gk * layer) as u32, code.without_flag()))
    };
    // The boxes' groups in group order (x fastest), in parallel over runs of layers (at most
    // `MAX_RUNS` of them, whatever the grid's shape): counted, then filled into a vector of
    // exactly their number.
    const MAX_RUNS: usize = 4096;
    let per_run = gz.div_ceil(MAX_RUNS).max(1);
    let found = move |run: usize| {
        let layers = run * per_run..((run + 1) * per_run).min(gz);
        layers.flat_map(move |gk| (0..layer).filter_map(move |at| kept(gk, at)))
    };
    let runs = gz.div_ceil(per_run);
    let counts: Vec<usize> = (0..runs)
        .into_par_iter()
        .map(|run| found(run).count())
        .collect();
    let total = counts.iter().sum();
    if total > most {
        return Some(Err(total));
    }
    let mut boxes = crate::num::try_vec(total, (0, GroupCode::NONE), "").ok()?;
    let mut rest = boxes.as_mut_slice();
    let mut parts = Vec::with_capacity(runs);
    for &n in &counts {
        let (part, tail) = rest.split_at_mut(n);
        parts.push(part);
        rest = tail;
    }
    parts.into_par_iter().enumerate().for_each(|(run, part)| {
        for (slot, b) in part.iter_mut().zip(found(run)) {
            *slot = b;
        }
    });
    let unit = DVec3::from_array(cells.map(|c| 1.0 / c as f64));
    // Per axis, the object coordinate of each node plane k = 0 … cells: k / cells, and at the
    // dataset's faces out to where it still covers points (a box's low side at plane 0, its
    // high side at the last plane).
    let reach = crate::data::FACE_TOLERANCE as f64;
    let planes = |a: usize, face: f64, at: usize| -> Vec<f64> {
        (0..=cells[a])
            .map(|k| {
                if k == at {
                    face
                } else {
                    k as f64 / cells[a] as f64
                }
            })
            .collect()
    };
    let low = std::array::from_fn(|a| planes(a, box_min[a].max(-reach).min(0.0), 0));
    let high = std::array::from_fn(|a| planes(a, box_max[a].min(1.0 + reach).max(1.0), cells[a]));
    let groups = Groups {
        boxes,
        groups,
        low,
        high,
    };
    Some(Ok(Boxes::of_groups(groups, unit)))
}

/// The passing boxes of [`SkipGrid::passing_boxes`] as their groups: per box its group's index
/// (x fastest) and [`GroupCode`] (eight bytes), with what its corners are read from
/// ([`Groups::corners`]).
pub(super) struct Groups {
    boxes: Vec<(u32, GroupCode)>,
    /// Groups per axis.
    groups: [usize; 3],
    /// Per axis, the object coordinate of a box's low side at node plane k (k / cells, out to
    /// the object box at plane 0) and of its high side (k / cells, out at the last plane).
    low: [Vec<f64>; 3],
    high: [Vec<f64>; 3],
}

impl Groups {
    /// The boxes' groups: index (x fastest) and code.
    #[cfg(test)]
    pub(super) fn list(&self) -> &[(u32, GroupCode)] {
        &self.boxes
    }

    /// How many boxes.
    pub(super) fn len(&self) -> usize {
        self.boxes.len()
    }

    /// Box `i`'s lowest and highest corner: the node planes that bound its group's passing
    /// cells.
    #[inline]
    pub(super) fn corners(&self, i: usize) -> (DVec3, DVec3) {
        let (at, code) = self.boxes[i];
        let [gx, gy, _] = self.groups;
        // (In 32 bits where the groups of a row and of a layer fit them: a 32-bit division
        // takes a fraction of a 64-bit one's time on many processors.)
        let group = match (u32::try_from(gx), u32::try_from(gy), u32::try_from(gx * gy)) {
            (Ok(gx), Ok(gy), Ok(layer)) => [at % gx, at / gx % gy, at / layer].map(|c| c as usize),
            _ => {
                let at = at as usize;
                [at % gx, at / gx % gy, at / (gx * gy)]
            }
        };
        let lo_cell = group.map(|c| c * BRICK);
        // (Always there: only groups with passing cells are kept; none would be an empty box
        // at the group's first cell.)
        debug_assert!(code != GroupCode::NONE);
        let (first, last, _) = code.get(lo_cell).unwrap_or((lo_cell, lo_cell, false));
        (
            DVec3::from_array(std::array::from_fn(|a| self.low[a][first[a]])),
            DVec3::from_array(std::array::from_fn(|a| self.high[a][last[a] + 1])),
        )
    }
}

impl SkipGrid {
    /// For the batched march of `data` with the cell mask `mask` (its cells whose samples can
    /// pass the zero test) over the object box [box_min, box_max]: boxes that hold every
    /// sample whose opacity is above 0, or at least the first one along any ray, computed
    /// once per grid (the mask belongs to the grid's object), where there are at most `most`
    /// of them (the boxes an image can project, `EntryMarks::most_boxes`): `None` where there
    /// are more. Only their number is kept then; an image that can project them makes them
    /// again.
    ///
    /// Per 4³ cells of the dataset, the box of those that can pass: a sample's value comes
    /// from the cell that holds its point, so a sample whose opacity is above 0 lies in such
    /// a box. A box whose cells touch a face of the dataset reaches past it by
    /// `FACE_TOLERANCE` where the object box does (a sample there still reads the edge cell;
    /// further out the dataset is 0, `Dataset::covers`). Left out: the
    /// groups whose cells all pass, with all 26 neighbouring groups the same: a ray that meets
    /// opacity first in one has crossed a neighbour's box before (or starts in a region of them,
    /// enclosed by boxes some of which are then behind the eye: no map). `None` for a
    /// dataset with an axis of one node, and where the groups' codes or the boxes cannot be
    /// allocated (kept: the rays then walk from the grid's shell).
    pub(crate) fn passing_boxes(
        &self,
        data: &Dataset,
        mask: &CellMask,
        (box_min, box_max): (DVec3, DVec3),
        most: usize,
    ) -> Option<std::sync::Arc<Boxes>> {
        let kept = || self.passing.lock().unwrap_or_else(|e| e.into_inner());
        // What is kept answers, where it can.
        let known = |kept: &Passing| match kept {
            Passing::Made(b) => Some((b.len() <= most).then(|| b.clone())),
            Passing::Unavailable => Some(None),
            Passing::Many(n) if *n > most => Some(None),
            Passing::Many(_) | Passing::Unknown => None,
        };
        if let Some(answer) = known(&kept()) {
            return answer;
        }
        // Made holding no lock, as `pool::try_once` makes a cache: the first boxes (or
        // outcome) kept are what every later caller gets.
        let made = match passing_boxes(data, mask, box_min, box_max, most) {
            None => Passing::Unavailable,
            Some(Err(n)) => Passing::Many(n),
            Some(Ok(b)) => Passing::Made(std::sync::Arc::new(b)),
        };
        let mut kept = kept();
        if let Some(answer) = known(&kept) {
            return answer;
        }
        *kept = made;
        match &*kept {
            Passing::Made(b) => Some(b.clone()),
            _ => None,
        }
    }
}
