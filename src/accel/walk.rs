//! The walk of one ray through a [`SkipGrid`]'s blocks (Amanatides & Woo), leaping over runs
//! of empty blocks by the distance map: for each sample parameter the caller asks about,
//! whether it lies in an empty block and where the empty (or occupied) run ends. Owns the
//! walk's state and stepping; the grid it reads is `grid`'s, the samples are the caller's.

use super::grid::SkipGrid;
use glam::DVec3;

/// Empty runs whose chessboard distance is at most this are crossed block by block (a DDA
/// step is cheaper than relocating the walk after a leap over so few blocks).
const STEP_BELOW: i64 = 4;

/// The block holding block coordinate `rel`: floor(rel) clamped to [0, last] (`last` an
/// integer ≥ 0), NaN to 0. Clamping first makes the truncation of `as` the floor. The clamp by
/// comparisons, NaN taking the lower end as `f64::clamp`'s NaN becomes 0 in the conversion:
/// `f64::clamp` checks `0 ≤ last` on every call (a branch to a panic).
#[inline]
pub(super) fn block_index(rel: f64, last: f64) -> i64 {
    let r = if rel > 0.0 { rel } else { 0.0 };
    (if r < last { r } else { last }) as i64
}

/// Whether block index `c` lies outside `0..dims`: `c < 0 || c >= dims as i64` as one
/// unsigned comparison (a negative index is above every `dims` as u64; a grid's `dims` is far
/// below 2⁶³). The compiler cannot make the fold itself: it does not know `dims as i64` is not
/// negative.
#[inline]
pub(super) fn outside(c: i64, dims: usize) -> bool {
    c as u64 >= dims as u64
}

/// A walk through the blocks of a [`SkipGrid`] along a ray (Amanatides & Woo), leaping over
/// runs of empty blocks with the distance map.
pub(crate) struct Walk {
    pub(super) o: DVec3,
    pub(super) d: DVec3,
    /// 1/d per axis (unused where d is 0): the walk's divisions by d are multiplications
    /// (a division's latency is several multiplications'; the results differ by rounding only,
    /// which the bricks' one-node margin already covers, see `Dataset::bricks`).
    pub(super) inv_d: DVec3,
    pub(super) cell: [i64; 3],
    pub(super) step: [i64; 3],
    pub(super) t_max: [f64; 3],
    pub(super) t_delta: [f64; 3],
    /// The ray has left the grid (everything after is treated as non-empty).
    pub(super) done: bool,
    /// The ray parameter at which the current block was entered.
    pub(super) entry: f64,
}

impl Walk {
    /// Moves the walk to parameter `t0` (its start, or a leap): the block there and the
    /// parameters at which it is left (steps and deltas do not change along a ray). `forced`
    /// sets the block index on the axes where the ray is known to have just crossed into a
    /// block (so rounding cannot put it back). Always inlined: at a walk's start the forced
    /// axes are known to be none, and the tests of them go.
    #[inline(always)]
    pub(super) fn relocate(&mut self, grid: &SkipGrid, t0: f64, forced: [Option<i64>; 3]) {
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
    /// NaN, and that case takes `f64::min` of the other two, as `a.min(b).min(c)` does. Saves
    /// `f64::min`'s two NaN selects a call (`exit_is_the_nan_aware_minimum`).
    #[inline]
    pub(super) fn exit(&self) -> f64 {
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
    /// Calls must come with non-decreasing `t`. Where `t` lies past the block after the walk's
    /// (a caller that has passed over blocks itself, as the packet march's runs do), the walk
    /// moves to `t`'s block at once ([`Walk::relocate`]) rather than step through the blocks
    /// between. Always inlined: otherwise the compiler leaves it a call per question in the
    /// callers' sample loops.
    #[inline(always)]
    pub(crate) fn skip_until(&mut self, grid: &SkipGrid, t: f64, horizon: f64) -> Result<f64, f64> {
        if !self.done && self.left_before(t) {
            self.advance(grid);
            if !self.done && self.left_before(t) {
                // (Rounding may put `t` in the block before its own: the loop below steps on.)
                self.relocate(grid, t, [None; 3]);
                self.entry = t;
            }
        }
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

impl SkipGrid {
    /// Starts a walk along the object-space ray `o + t·d` at parameter `t0` in `slot` (the
    /// caller's, e.g. a cursor's field): built in place, as a walk returned by value is built
    /// on the stack and copied (a `memcpy` call a ray). Inlined: called once a ray.
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
