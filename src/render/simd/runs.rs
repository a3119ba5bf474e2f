//! Which samples the lanes take: a ray's segments in runs of sixteen ([`Packets::run16`], from
//! its cursor, [`segments_from`]), tested against the cell mask together ([`Packets::to_take`])
//! or taken on trust ([`TRUSTED_RUNS`]), the block walk asked after a run of which nothing is
//! taken ([`Packets::next_taken`]), and the next segment to take of each lane's run
//! ([`next_segments`]). Written once over [`Simd`] but for [`next_segments`] (see the module
//! docs of [`simd`](super)). Not here: the samples' arithmetic ([`step`]).

use super::*;

impl Packets<'_> {
    /// [`Packets::next_taken`] in eight lanes.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn next_taken8(&self, c: &mut Cursor, run: &mut Run16, trusted: &mut u32) -> u32 {
        // SAFETY: this function has AVX2 and FMA.
        let s = unsafe { Avx2::new() };
        self.next_taken(s, c, run, trusted)
    }

    /// [`Packets::next_taken`] in sixteen lanes.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    pub(super) fn next_taken16(&self, c: &mut Cursor, run: &mut Run16, trusted: &mut u32) -> u32 {
        // SAFETY: this function has every feature `Avx512` stands for.
        let s = unsafe { Avx512::new() };
        self.next_taken(s, c, run, trusted)
    }

    /// The next run of cursor `c`'s ray with a segment to take, as [`Packets::to_take`]'s
    /// bits (0: the ray has no sample left), its segments in `run`. The runs of segments are
    /// tested against the cell mask, which decides what is taken (exact, as the block walk
    /// is), but for the `trusted` runs after one it passed whole ([`TRUSTED_RUNS`]: all
    /// their segments of positive length taken); the walk is asked only after a run of which
    /// nothing is taken, and only where the ray is past the occupied blocks it last reported,
    /// to leap over empty blocks.
    #[inline(always)]
    fn next_taken<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        c: &mut Cursor,
        run: &mut Run16,
        trusted: &mut u32,
    ) -> u32 {
        loop {
            if c.k >= c.n || c.stopping() {
                return 0;
            }
            let test = *trusted == 0;
            *trusted = trusted.saturating_sub(1);
            let (m, candidates, keep) = self.run16(s, c, run, test);
            if test && keep != 0 && keep == candidates {
                *trusted = self.trusted_runs;
            }
            c.k += m as u64;
            if keep != 0 {
                return keep;
            }
            if c.k >= c.n {
                return 0;
            }
            self.after_nothing_taken(c);
        }
    }

    /// Cursor `c`'s next segments, up to sixteen (there is one), into `run` ([`segments_from`]'s
    /// numbers in runs of `N` lanes, from the cursor's next segment), and those
    /// [`Packets::to_take`] takes, by bit: their number, the bits of the segments of positive
    /// length (or NaN) and the bits taken, those of the former the mask passes (all of them,
    /// untested, where `test` is false). Sixteen segments are tested together: the cell mask's
    /// gather latency paid once for them in sixteen lanes, and in eight for two gathers that
    /// overlap. A cursor near 2⁵³ segments, or without a mask, takes runs of eight
    /// ([`segments_lanes`]; tested, and as candidates the complement of those taken: never
    /// passed whole).
    #[inline(always)]
    pub(super) fn run16<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        c: &Cursor,
        run: &mut Run16,
        test: bool,
    ) -> (usize, u32, u32) {
        if index_f64(c.k, c.n) >= (1u64 << 53) as f64 - 32.0 || self.mask.is_empty() {
            let mids: &mut [f64; W] = (&mut run.mids[..W]).try_into().expect("eight");
            let lens: &mut [f64; W] = (&mut run.lens[..W]).try_into().expect("eight");
            // SAFETY: every `Simd` stands for AVX2 and FMA among its features (its contract).
            let (eight, m) = unsafe { (Avx2::new(), segments_lanes(c, mids, lens)) };
            let keep = self.to_take(eight, c, mids, lens, m);
            return (m, !keep, keep);
        }
        // (The mask is not empty past the return above, as `mask_bits` needs.)
        let (mut m, mut candidates, mut keep) = (0, 0, 0);
        for h in 0..2 * W / N {
            let from = c.k + (N * h) as u64;
            if from >= c.n {
                break;
            }
            let mids: &mut [f64; N] = (&mut run.mids[N * h..N * h + N]).try_into().expect("N");
            let lens: &mut [f64; N] = (&mut run.lens[N * h..N * h + N]).try_into().expect("N");
            let n = segments_from(s, c, from, mids, lens);
            let cand = first_positive(s, lens, n);
            let taken = if test && cand != 0 {
                cand & self.mask_bits(s, &object_points(s, c, mids))
            } else {
                if !test {
                    self.count_untested();
                }
                cand
            };
            m += n;
            candidates |= cand << (N * h);
            keep |= taken << (N * h);
        }
        (m, candidates, keep)
    }

    /// After a run of cursor `c` of which nothing was taken (and with a segment left): where
    /// its next sample is past the occupied blocks the walk last reported, asks the walk (made
    /// here on first use) about it alone, and passes over the empty blocks it reports. No
    /// horizon: the next run tests its samples against the cell mask whatever blocks they lie
    /// in, so stepping through the occupied blocks after the sample's would only cost.
    #[inline]
    pub(super) fn after_nothing_taken(&self, c: &mut Cursor) {
        let next = c.mid(c.k);
        if next >= c.occupied_until {
            if let Some(grid) = self.grid {
                let walk = match c.walk.as_mut() {
                    Some(w) => w,
                    None => grid.walk_into(&mut c.walk, c.o, c.d, next),
                };
                match walk.skip_until(grid, next, next) {
                    Ok(exit) => c.pass_before(exit),
                    Err(until) => c.occupied_until = until,
                }
            }
        }
    }

    /// The segments of a run (`m` of them, 1 to `N`, at midpoints `mids` with lengths `lens`
    /// on the ray of cursor `c`) that [`Packets::step`] must take, by bit: those of positive
    /// length (or NaN) whose sample lies in a cell the cell mask says may reach the bound.
    /// Every other segment adds nothing to its ray (the scalar march drops it too), so it
    /// needs no lane: in the MNI frame about half of the segments the block walk gives.
    #[inline(always)]
    fn to_take<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        c: &Cursor,
        mids: &[f64; N],
        lens: &[f64; N],
        m: usize,
    ) -> u32 {
        let keep = first_positive(s, lens, m);
        if self.mask.is_empty() || keep == 0 {
            return keep;
        }
        keep & self.mask_bits(s, &object_points(s, c, mids))
    }

    /// By bit, the object points `p` whose cell the cell mask says may reach the bound (a
    /// cell past the mask's end may); the mask is not empty.
    #[inline(always)]
    fn mask_bits<S: Simd<N>, const N: usize>(&self, s: S, p: &[S::F; 3]) -> u32 {
        let (_, base, _) = self.cells(s, p);
        let word = s.shr5_i(base);
        let last = s.splat_i(self.mask.len() as i32 - 1);
        let at = s.min_i(s.max_i(word, s.zero_i()), last);
        assert!(!self.mask.is_empty());
        // SAFETY: every lane of `at` is clamped to [0, mask.len() − 1], and the mask is not
        // empty (asserted).
        let words = unsafe { s.gather_words(self.mask, at) };
        let bit = s.srlv_i(words, s.and_i(base, s.splat_i(31)));
        s.bits(s.or_m(s.odd_i(bit), s.gt_i(word, last)))
    }
}

/// [`Cursor::segments`] in lanes: the cursor's next segments (there is one), up to eight,
/// their midpoints and lengths written into `mids` and `lens`, the same numbers bit for bit
/// (`lanes_segments_are_the_cursors`); their number returned. Boundary j of the run is
/// `t0 + (k + j)·step` (k + j exact in f64: k below 2⁵³ − 16, else the cursor's own loop), a
/// segment ends at the next boundary where that is below t1 and at t1 otherwise, and the
/// cursor's last segment at t1.
#[inline]
#[target_feature(enable = "avx2")]
pub(in crate::render) fn segments_lanes(
    c: &Cursor,
    mids: &mut [f64; W],
    lens: &mut [f64; W],
) -> usize {
    if index_f64(c.k, c.n) >= (1u64 << 53) as f64 - 16.0 {
        return c.segments(mids, lens);
    }
    // SAFETY: this function has AVX2, and so do its callers: FMA too (`segments_lanes`'s
    // callers are the march's, after `Packets::new` found both, and the unit tests', likewise).
    segments_from(unsafe { Avx2::new() }, c, c.k, mids, lens)
}

/// [`segments_lanes`] from segment `from` (below the count and 2⁵³ − 32) instead of the
/// cursor's next, in `N` lanes.
#[inline(always)]
pub(super) fn segments_from<S: Simd<N>, const N: usize>(
    s: S,
    c: &Cursor,
    from: u64,
    mids: &mut [f64; N],
    lens: &mut [f64; N],
) -> usize {
    let k = s.splat_d(index_f64(from, c.n));
    let t0 = s.splat_d(c.t0);
    let t1 = s.splat_d(c.t1);
    let step = s.splat_d(c.step);
    // The count as f64: exact up to 2⁵³; above, every k + j + 1 here is below it.
    let n = s.splat_d(index_f64(c.n, c.n));
    let one = s.splat_d(1.0);
    for h in 0..2 {
        let j = s.add_d(k, s.iota_d(h));
        let a = s.add_d(t0, s.mul_d(j, step));
        let j1 = s.add_d(j, one);
        let next = s.add_d(t0, s.mul_d(j1, step));
        // `at_most` (minpd gives its second operand unless the first is below it), then t1
        // for the cursor's last segment (and the meaningless lanes past it).
        let b = s.below_or_d(j1, n, s.min_d(next, t1), t1);
        s.st_d(mids, h, s.mul_d(s.splat_d(0.5), s.add_d(a, b)));
        s.st_d(lens, h, s.sub_d(b, a));
    }
    (c.n - from).min(N as u64) as usize
}

/// [`segments_from`] in sixteen lanes from the cursor's next segment (below 2⁵³ − 32), into
/// `run`: [`Cursor::segments`]' numbers bit for bit (`wide_segments_are_the_cursors`, which
/// calls it; the march calls [`segments_from`]).
#[cfg(test)]
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
pub(in crate::render) fn segments16(c: &Cursor, run: &mut Run16) -> usize {
    debug_assert!(index_f64(c.k, c.n) < (1u64 << 53) as f64 - 32.0);
    // SAFETY: this function has every feature `Avx512` stands for.
    let s = unsafe { Avx512::new() };
    segments_from(s, c, c.k, &mut run.mids, &mut run.lens)
}

/// By bit, the first `m` (at most `N`) segments of lengths `lens` that are positive (or NaN).
#[inline(always)]
fn first_positive<S: Simd<N>, const N: usize>(s: S, lens: &[f64; N], m: usize) -> u32 {
    ((1u64 << m) - 1) as u32 & !s.le_zero_d(lens)
}

/// The object points of the segments with midpoints `mids` on cursor `c`'s ray, as
/// [`Packets::step`] makes them (f64, rounded to f32).
#[inline(always)]
fn object_points<S: Simd<N>, const N: usize>(s: S, c: &Cursor, mids: &[f64; N]) -> [S::F; 3] {
    let mut p = [s.zero(); 3];
    for (axis, p) in p.iter_mut().enumerate() {
        let (o, d) = (s.splat_d(c.o[axis]), s.splat_d(c.d[axis]));
        let lo = s.add_d(o, s.mul_d(s.ld_d(mids, 0), d));
        let hi = s.add_d(o, s.mul_d(s.ld_d(mids, 1), d));
        *p = s.narrow(lo, hi);
    }
    p
}

/// For every lane whose run has a segment left to take (a bit of its `keeps` word): that
/// segment's midpoint and length into `st` (the lowest bit's segment of its run), and the bit
/// cleared. Returns those lanes. In lanes: the lowest bit of each word by `x & −x`, its index
/// from the exponent of that power of two as f32, the segments by gathers from the runs.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn next_segments(keeps: &mut [u32; W], runs: &[Run16; W], st: &mut LaneState<W>) -> u32 {
    // SAFETY: `keeps` is 8 u32, 32 readable and writable bytes; no alignment requirement.
    let k = unsafe { _mm256_loadu_si256(keeps.as_ptr() as *const __m256i) };
    let zero = _mm256_setzero_si256();
    let has = _mm256_cmpeq_epi32(k, zero);
    let active = !(_mm256_movemask_ps(_mm256_castsi256_ps(has)) as u32) & 0xff;
    if active == 0 {
        return 0;
    }
    // Every bit is below 16 (runs of at most sixteen segments), so the lowest as f32 is
    // exact and its exponent field is 127 + its index; a word of 0 gives index
    // 15 & (0 − 127): in range, and its lane is not active.
    let low = _mm256_and_si256(k, _mm256_sub_epi32(zero, k));
    let e = _mm256_srli_epi32::<23>(_mm256_castps_si256(_mm256_cvtepi32_ps(low)));
    let j = _mm256_and_si256(
        _mm256_sub_epi32(e, _mm256_set1_epi32(127)),
        _mm256_set1_epi32(15),
    );
    let rest = _mm256_and_si256(k, _mm256_add_epi32(k, _mm256_set1_epi32(-1)));
    // SAFETY: as above.
    unsafe { _mm256_storeu_si256(keeps.as_mut_ptr() as *mut __m256i, rest) };
    // Lane i's segment j: f64 number 32·i + j of the runs (its midpoints), + 16 (its lengths).
    const RUN: i32 = (std::mem::size_of::<Run16>() / std::mem::size_of::<f64>()) as i32;
    let at = _mm256_add_epi32(
        _mm256_mullo_epi32(
            _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
            _mm256_set1_epi32(RUN),
        ),
        j,
    );
    let base = runs.as_ptr() as *const f64;
    for h in 0..2 {
        let idx = if h == 0 {
            _mm256_castsi256_si128(at)
        } else {
            _mm256_extracti128_si256::<1>(at)
        };
        // SAFETY: `Run16` is two arrays of 16 f64 (`repr(C)`), so f64 number 32·i + j and
        // 32·i + 16 + j (i in 0..8, j in 0..16) lie inside the 8 runs; gathers need no
        // alignment.
        let (mid, len) = unsafe {
            (
                _mm256_i32gather_pd::<8>(base, idx),
                _mm256_i32gather_pd::<8>(base.add(2 * W), idx),
            )
        };
        std8d(&mut st.mid, h, mid);
        std8d(&mut st.len, h, len);
    }
    active
}

/// [`next_segments`] in sixteen lanes: the lowest bit's index as 31 − its leading zeros.
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
pub(super) fn next_segments16(
    keeps: &mut [u32; V],
    runs: &[Run16; V],
    st: &mut LaneState<V>,
) -> u32 {
    // SAFETY: `keeps` is 16 u32, 64 readable and writable bytes; no alignment requirement.
    let k = unsafe { _mm512_loadu_si512(keeps.as_ptr() as *const _) };
    let active = _mm512_test_epi32_mask(k, k);
    if active == 0 {
        return 0;
    }
    let zero = _mm512_setzero_si512();
    let low = _mm512_and_si512(k, _mm512_sub_epi32(zero, k));
    let j = _mm512_and_si512(
        _mm512_sub_epi32(_mm512_set1_epi32(31), _mm512_lzcnt_epi32(low)),
        _mm512_set1_epi32(15),
    );
    let rest = _mm512_and_si512(k, _mm512_add_epi32(k, _mm512_set1_epi32(-1)));
    // SAFETY: as above.
    unsafe { _mm512_storeu_si512(keeps.as_mut_ptr() as *mut _, rest) };
    const RUN: i32 = (std::mem::size_of::<Run16>() / std::mem::size_of::<f64>()) as i32;
    let lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    let at = _mm512_add_epi32(_mm512_mullo_epi32(lane, _mm512_set1_epi32(RUN)), j);
    let base = runs.as_ptr() as *const f64;
    for h in 0..2 {
        let idx = if h == 0 {
            _mm512_castsi512_si256(at)
        } else {
            _mm512_extracti64x4_epi64::<1>(at)
        };
        // SAFETY: `Run16` is two arrays of 16 f64 (`repr(C)`), so f64 number 32·i + j and
        // 32·i + 16 + j (i, j in 0..16) lie inside the 16 runs; gathers need no alignment.
        let (mid, len) = unsafe {
            (
                _mm512_i32gather_pd::<8>(idx, base),
                _mm512_i32gather_pd::<8>(idx, base.add(V)),
            )
        };
        st8d(&mut st.mid, h, mid);
        st8d(&mut st.len, h, len);
    }
    active as u32
}
