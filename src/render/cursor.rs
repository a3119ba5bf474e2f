//! The sampling cursor: one object's segments along a ray (segment k spans
//! [t0 + k·step, t0 + (k + 1)·step], the last one ending at t1, its sample at its midpoint),
//! with the block walk that passes over segments in empty blocks, one sample at a time
//! ([`Cursor::peek`], [`Cursor::take`]) or in runs of up to eight ([`Cursor::next_run`]), and
//! the exact helpers they rest on (segment counts, index conversion, the run's zero test). It
//! decides where samples are, not what they show (`integrate`, `shade`).

use super::*;

/// The number of segments of `x` steps (the span over the step): ⌈x⌉, at least 1, saturating
/// at `u64::MAX` (NaN: 1). For 0 < x < 2⁵², the usual case, by truncation: ⌈x⌉ is the
/// truncation where that is x and one more where it is below, both exact there; elsewhere by
/// the rounding function (`segment_count_is_the_rounded_up_span` checks the two agree).
#[inline]
pub(super) fn segment_count(x: f64) -> u64 {
    if x > 0.0 && x < 4_503_599_627_370_496.0 {
        let t = x as i64;
        return (t + ((t as f64) < x) as i64) as u64;
    }
    let n = crate::num::ceil(x).max(1.0);
    if n.is_finite() && n < u64::MAX as f64 {
        n as u64
    } else {
        u64::MAX
    }
}

/// Segment number `k` of a cursor of `n` segments (k ≤ n) as f64, the same value as
/// `k as f64`: where n < 2⁶³ (every count a cursor meets in practice) by the signed
/// conversion, one `cvtsi2sd`, where `k as f64` is six instructions on the SSE2 baseline
/// (which has no unsigned conversion); the same integer, rounded the same way. The test is on
/// n, not k: the compiler turns a signed conversion under `k ≤ i64::MAX` back into the
/// unsigned one. Taken for every midpoint a cursor looks at
/// (`index_f64_is_the_unsigned_conversion`).
#[inline(always)]
pub(super) fn index_f64(k: u64, n: u64) -> f64 {
    debug_assert!(k <= n);
    if n <= i64::MAX as u64 {
        k as i64 as f64
    } else {
        k as f64
    }
}

/// One object's segments along a ray: segment k spans [t0 + k·step, t0 + (k + 1)·step], the last
/// one ending at t1; its sample is at its midpoint.
pub(super) struct Cursor {
    pub(super) object: usize,
    pub(super) t0: f64,
    pub(super) t1: f64,
    pub(super) step: f64,
    pub(super) k: u64,
    pub(super) n: u64,
    pub(super) walk: Option<Walk>,
    /// The ray in the object's coordinates: the object point of ray parameter t is
    /// `o + t·d`.
    pub(super) o: DVec3,
    pub(super) d: DVec3,
    /// Samples before this ray parameter lie in the occupied block the walk last reported:
    /// they are taken without consulting the walk.
    pub(super) occupied_until: f64,
    /// The segment number from which [`Cursor::stopping`] looks again at whether the render
    /// is to stop.
    pub(super) probe_at: u64,
}

/// Segments a cursor passes between two looks at whether its render is to stop
/// ([`Cursor::stopping`]): a few microseconds of work, so that a cancelled render stops
/// within a ray, however many samples the ray (or each of its samples' shadow rays) takes.
pub(super) const PROBE_EVERY: u64 = 4096;

impl Cursor {
    /// The segments of object `obj` (number `index`) over [t0, t1] of a ray, given in the
    /// object's coordinates ([`CObj::object_ray`]), with a block walk when empty-space skipping
    /// is on. `from` (< t1): every sample before it lies in an empty block (an [`EntryMap`]
    /// bound, or −∞): with a walk, those are passed over at once and the walk starts there.
    pub(super) fn new(
        scene: &Compiled,
        obj: &CObj,
        index: usize,
        ray: (DVec3, DVec3),
        span: (f64, f64),
        from: f64,
    ) -> Cursor {
        let mut c = Cursor::unstarted(obj, index, ray, span);
        c.start(scene, obj, from);
        c
    }

    /// [`Cursor::new`] before its walk is started ([`Cursor::start`]). Apart, so that a caller
    /// that starts it in place builds the cursor where it keeps it: a cursor whose address was
    /// taken (by the walk's start) before it is returned is built on the callee's stack and
    /// copied (a `memcpy` of the whole cursor a ray).
    #[inline]
    pub(super) fn unstarted(
        obj: &CObj,
        index: usize,
        (o, d): (DVec3, DVec3),
        (t0, t1): (f64, f64),
    ) -> Cursor {
        let n = segment_count((t1 - t0) / obj.step);
        Cursor {
            object: index,
            t0,
            t1,
            step: obj.step,
            k: 0,
            n,
            walk: None,
            o,
            d,
            occupied_until: f64::NEG_INFINITY,
            probe_at: PROBE_EVERY,
        }
    }

    /// Whether the render this thread works for is to stop (`control::stop_requested`),
    /// looked at once every [`PROBE_EVERY`] segments: then the cursor ends (k = n), so that
    /// the march over it ends as at the ray's end (a cancelled render's pixels are
    /// discarded).
    #[inline(always)]
    pub(super) fn stopping(&mut self) -> bool {
        self.k >= self.probe_at && self.look_at_stop()
    }

    /// [`Cursor::stopping`]'s look, out of line.
    #[cold]
    #[inline(never)]
    fn look_at_stop(&mut self) -> bool {
        self.probe_at = self.k.saturating_add(PROBE_EVERY);
        let stop = crate::control::stop_requested();
        if stop {
            self.k = self.n;
        }
        stop
    }

    /// Starts an [`Cursor::unstarted`] cursor's walk when empty-space skipping is on, at `from`
    /// as [`Cursor::new`] takes it.
    #[inline]
    pub(super) fn start(&mut self, scene: &Compiled, obj: &CObj, from: f64) {
        if let (Some(grid), true) = (&obj.skip, scene.settings.optimise.skip_empty) {
            self.start_walk(grid, from.max(self.t0));
        }
    }

    /// Starts the block walk through `grid` at `start` (the cursor's first segment's start, or
    /// later: an [`EntryMap`] bound) and passes over the segments whose midpoints are before
    /// it. The walk is built in the cursor's field (see [`SkipGrid::walk_into`]).
    #[inline(never)]
    pub(super) fn start_walk(&mut self, grid: &SkipGrid, start: f64) {
        grid.walk_into(&mut self.walk, self.o, self.d, start);
        self.start_at(start);
    }

    /// Passes over the segments whose midpoints are before `t` (none if the next one's is
    /// not; there is a next one).
    pub(super) fn start_at(&mut self, t: f64) {
        if self.mid(self.k) < t {
            self.pass_before(t);
        }
    }

    /// Passes over the next segment, whose midpoint is before `t`, and every later one whose
    /// midpoint is before `t`.
    #[inline]
    pub(super) fn pass_before(&mut self, t: f64) {
        // Where the first midpoint not before t should be: ⌈g⌉ for g not an integer, g + 1 for
        // one (the truncation, plus 1: no rounding call, and a saturating conversion of a
        // value known to be in range). Any start above `k` settles on the same segment below
        // (midpoints do not decrease), at most one step further here than from ⌈g⌉.
        let g = (t - self.t0) / self.step - 0.5;
        let mut k = if g > index_f64(self.k, self.n) {
            if g < 9.0e18 {
                (g as i64 as u64 + 1).min(self.n)
            } else {
                self.n
            }
        } else {
            self.k + 1
        };
        while k > self.k + 1 && self.mid(k - 1) >= t {
            k -= 1;
        }
        while k < self.n && self.mid(k) < t {
            k += 1;
        }
        self.k = k;
    }

    /// The object point of ray parameter `t`.
    #[inline]
    pub(super) fn object_point(&self, t: f64) -> [f32; 3] {
        ray_point(self.o, self.d, t)
    }

    /// Segment boundary number `k` (a count, exact in f64 below 2⁵³): `t0 + k·step`.
    #[inline]
    pub(super) fn boundary(&self, k: f64) -> f64 {
        self.t0 + k * self.step
    }

    /// The end of a segment whose next boundary is `next`: t1 for the last segment, else the
    /// boundary (never past t1).
    #[inline]
    pub(super) fn end(&self, next: f64, last: bool) -> f64 {
        if last {
            self.t1
        } else {
            at_most(next, self.t1)
        }
    }

    #[inline]
    pub(super) fn segment(&self, k: u64) -> (f64, f64) {
        let a = self.boundary(index_f64(k, self.n));
        (
            a,
            self.end(self.boundary(index_f64(k + 1, self.n)), k + 1 >= self.n),
        )
    }

    /// The length of the next segment, which is then passed.
    #[inline]
    pub(super) fn take(&mut self) -> f64 {
        let (a, b) = self.segment(self.k);
        self.k += 1;
        b - a
    }

    #[inline]
    pub(super) fn mid(&self, k: u64) -> f64 {
        let (a, b) = self.segment(k);
        0.5 * (a + b)
    }

    /// The next segments (there is one: `k < n`), up to eight: writes their midpoints and
    /// lengths into `mids` and `lens` and returns their number (the entries past the number
    /// are meaningless, possibly left from an earlier run). Each segment's end is the next
    /// one's start: one boundary per sample, the same numbers as [`Cursor::segment`]. In lanes
    /// across the segments while their boundary numbers are exact in f64 (below 2⁵³), so that
    /// k + j + 1 is one rounding-free addition.
    #[inline]
    pub(super) fn segments(&self, mids: &mut [f64; 8], lens: &mut [f64; 8]) -> usize {
        let left = (self.n - self.k).min(8) as usize; // k < n
        let last = self.k + left as u64 == self.n; // the run may reach the last segment
        let k = index_f64(self.k, self.n);
        if k < (1u64 << 53) as f64 - 16.0 {
            let next: [f64; 8] = std::array::from_fn(|j| self.boundary(k + (j + 1) as f64));
            let a: [f64; 8] = std::array::from_fn(|j| {
                if j == 0 {
                    self.boundary(k)
                } else {
                    next[j - 1]
                }
            });
            // `Cursor::end` lane by lane, written out in lanes rather than called per lane.
            let b = next.map(|x| at_most(x, self.t1));
            *mids = std::array::from_fn(|j| 0.5 * (a[j] + b[j]));
            *lens = std::array::from_fn(|j| b[j] - a[j]);
            if last {
                // The last segment ends at t1: its sample made again from its start, a[i]
                // (k + i is k + (i − 1 + 1), and k + 0 is k), so that `b` stays in registers
                // (its lane set in memory costs four stores a run).
                let i = left - 1;
                let a = self.boundary(k + i as f64);
                mids[i] = 0.5 * (a + self.t1);
                lens[i] = self.t1 - a;
            }
        } else {
            let mut a = self.boundary(k);
            let mut kf = k;
            for j in 0..left {
                kf += 1.0;
                let next = self.boundary(kf);
                let b = self.end(next, last && j + 1 == left);
                mids[j] = 0.5 * (a + b);
                lens[j] = b - a;
                a = next;
            }
        }
        left
    }

    /// The batched march's next run: the next sample to take ([`Cursor::peek`]) and those after
    /// it, up to eight, that lie in occupied blocks: where the walk's block ends inside the run,
    /// it asks the walk about the next sample itself and carries on while the answer is an
    /// occupied block. Writes the run's midpoints and
    /// lengths as [`Cursor::segments`] does, passes its segments and returns their number (0: no
    /// sample left). The same samples as the peek-then-run loop (`joined_runs_are_peek_and_run`);
    /// fewer questions to the walk: asked about a sample in an occupied block, the walk also
    /// steps through the occupied blocks after it that the run's last sample reaches
    /// ([`Walk::skip_until`]'s horizon), so a run inside occupied blocks asks once.
    #[inline(never)]
    pub(super) fn next_run(
        &mut self,
        grid: Option<&SkipGrid>,
        mids: &mut [f64; 8],
        lens: &mut [f64; 8],
    ) -> usize {
        if self.k >= self.n || self.stopping() {
            return 0;
        }
        let left = self.segments(mids, lens);
        let (Some(walk), Some(grid)) = (self.walk.as_mut(), grid) else {
            self.k += left as u64;
            return left;
        };
        // Samples before j are taken; sample j is taken if it lies before `until` or the
        // walk finds it in an occupied block.
        let (mut j, mut until) = (0, self.occupied_until);
        let exit = loop {
            while j < left && mids[j] < until {
                j += 1;
            }
            if j == left {
                break None;
            }
            match walk.skip_until(grid, mids[j], mids[left - 1]) {
                Err(u) => {
                    until = u;
                    j += 1;
                    // The midpoints do not decrease and none is NaN (the cursor's ends are
                    // finite, its step finite and positive): when the run's last lies before
                    // the block's end, every one from j on does (one comparison, where the
                    // loop above takes five a sample).
                    if mids[left - 1] < until {
                        j = left;
                        break None;
                    }
                }
                Ok(exit) => break Some(exit),
            }
        };
        self.occupied_until = until;
        self.k += j as u64;
        let Some(exit) = exit else {
            return j;
        };
        // Sample j lies in an empty block: pass it and those after it up to the exit.
        self.pass_before(exit);
        if j > 0 {
            return j;
        }
        // The run starts after the empty blocks (apart: as a loop here, the compiler keeps
        // the run's constants in registers across every call).
        self.next_run_after_gap(Some(grid), mids, lens)
    }

    /// [`Cursor::next_run`] again, where its first sample lay in an empty block.
    #[cold]
    #[inline(never)]
    fn next_run_after_gap(
        &mut self,
        grid: Option<&SkipGrid>,
        mids: &mut [f64; 8],
        lens: &mut [f64; 8],
    ) -> usize {
        self.next_run(grid, mids, lens)
    }

    /// The midpoint of the next segment that must be sampled, passing over segments whose
    /// samples lie in empty blocks.
    pub(super) fn peek(&mut self, grid: Option<&SkipGrid>) -> Option<f64> {
        loop {
            if self.k >= self.n || self.stopping() {
                return None;
            }
            let mid = self.mid(self.k);
            if mid < self.occupied_until {
                return Some(mid);
            }
            let (Some(walk), Some(grid)) = (self.walk.as_mut(), grid) else {
                return Some(mid);
            };
            let exit = match walk.skip_until(grid, mid, mid) {
                Err(until) => {
                    self.occupied_until = until;
                    return Some(mid);
                }
                Ok(exit) => exit,
            };
            self.pass_before(exit);
        }
    }
}

/// `x.min(t1)` for a `t1` that is not NaN (a cursor's end: [`CObj::clip`] gives finite
/// ends), as one comparison: t1 where x is NaN or not below it (`f64::min`'s NaN handling
/// costs a vector select per pair of lanes).
#[inline(always)]
pub(super) fn at_most(x: f64, t1: f64) -> f64 {
    if x < t1 {
        x
    } else {
        t1
    }
}

/// Bit i set where sample i of a run has a length and passes the zero test:
/// `!(lens[i] <= 0 || vs[i] <= z)` (a NaN fails neither comparison), in lanes.
#[inline]
pub(super) fn pass_bits(lens: &[f64; 8], vs: &[f32; 8], z: f32) -> u32 {
    use wide::{f32x4, f64x2};
    // By pairs and quadruples, each comparison's bits taken by one `movmskpd`/`movmskps`
    // (the compiler packs wider lanes' masks into bytes first: a dozen more instructions).
    let short = |j: usize| {
        f64x2::new([lens[j], lens[j + 1]])
            .simd_le(f64x2::ZERO)
            .to_bitmask()
            << j
    };
    let low = |j: usize| {
        f32x4::new([vs[j], vs[j + 1], vs[j + 2], vs[j + 3]])
            .simd_le(f32x4::splat(z))
            .to_bitmask()
            << j
    };
    let fail = short(0) | short(2) | short(4) | short(6) | low(0) | low(4);
    !fail & 0xff
}

/// The object point (f32, as samples see it) of parameter `t` on the object-space ray
/// `o + t·d`.
#[inline]
pub(super) fn ray_point(o: DVec3, d: DVec3, t: f64) -> [f32; 3] {
    (o + t * d).as_vec3().to_array()
}
