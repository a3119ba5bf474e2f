//! Cell masks: which trilinear cells of a dataset may interpolate to a value above a bound, one
//! bit per node, so that the marches can skip a sample's eight node reads where a transfer
//! function is known to give 0.
//!
//! This file owns [`CellMask`], its construction from the raw voxels (once per dataset and bound,
//! in parallel, a run of words a task), and its queries (one cell, a run of cells, the bits as
//! 32-bit words for the packet march's gathers). Not here: choosing the bound (the zero test of an
//! object's transfer function; the renderer asks for the mask), and the marches that read the masks (the `lanes`
//! module's [`Dataset::trilinear8`], and `render::simd`).

use super::{normaliser, Dataset, Voxels};

/// How far below a bound z a trilinear cell's largest node may lie and still count as reaching
/// it in a [`CellMask`]: far above the rounding of the three nested f32 lerps of
/// [`Dataset::trilinear`] (each within 3·2⁻²⁴ of the exact value for values in [0, 1], so at
/// most about 5.4·10⁻⁷ above the largest node in all), and below the spacing of 16-bit values
/// (1/65535), so the only cells kept needlessly are those whose largest node lies within it
/// below z.
pub(super) const CELL_MASK_MARGIN: f32 = 1.0 / (1 << 18) as f32;

/// The words of a [`CellMask`] one task of its construction fills (64 nodes a word).
pub(super) const CELL_MASK_RUN: usize = 1024;

/// Up to 64 flags (each 0 or 1) as the bits of a word, flag b as bit b. Eight at a time: for
/// bytes x_k ∈ {0, 1} (k = 0 … 7, little-endian), the product of their word with
/// Σ_k 2^(56 − 7k) holds x_k at bit 56 + k, every other term lying below bit 56 (at distinct
/// bits, so without carries) or above bit 63.
pub(super) fn pack_flags(flags: &[u8]) -> u64 {
    const SPREAD: u64 = 0x0102_0408_1020_4080;
    let byte = |x: u64, b: usize| (x.wrapping_mul(SPREAD) >> 56) << (8 * b);
    // Whole words of eight flags read as they are; the last, shorter group padded with zeros
    // (apart: padding every group would cost a copy per eight flags).
    let mut eights = flags.chunks_exact(8);
    let mut w = 0;
    for (b, eight) in (&mut eights).enumerate() {
        w |= byte(u64::from_le_bytes(eight.try_into().expect("eight")), b);
    }
    let rest = eights.remainder();
    if !rest.is_empty() {
        let mut x = [0u8; 8];
        x[..rest.len()].copy_from_slice(rest);
        w |= byte(u64::from_le_bytes(x), flags.len() / 8);
    }
    w
}

/// Which trilinear cells of a dataset may interpolate to a value above a bound z: bit c (c the
/// node index of the cell's first node) is clear when all of the cell's nodes are at most
/// z − [`CELL_MASK_MARGIN`], so every [`Dataset::trilinear`] value in the cell is at most z.
/// A sample in such a cell is known to be at most z without reading its eight nodes (the
/// zero test of a transfer function that is 0 up to z; see [`Dataset::trilinear8`]).
/// One bit per node: 1/32 of the values' memory.
#[derive(Debug)]
pub(crate) struct CellMask {
    pub(super) bits: Vec<u64>,
    /// The bits as 32-bit words where the machine is big-endian (see [`CellMask::words32`]):
    /// made on first use, then shared by every image that uses the mask.
    #[cfg(target_endian = "big")]
    words32: std::sync::OnceLock<Vec<u32>>,
}

/// The cell masks of a dataset: each mask still in use, by the bits of its bound, held weakly
/// (the compiled objects of the scenes that use it hold it), and the one asked for last, held
/// (so that scenes one after another with the same transfer function share it). A bound no
/// longer used loses its mask, so a threshold moved from scene to scene does not leave one bit
/// a node behind per position.
#[derive(Debug, Default)]
pub(super) struct CellMasks {
    masks: std::collections::HashMap<u32, std::sync::Weak<CellMask>>,
    last: Option<std::sync::Arc<CellMask>>,
    /// The entries past which [`CellMasks::keep`] next drops those of masks nothing holds:
    /// twice what it kept the last time, so that the dropping costs a constant a mask kept.
    prune_at: usize,
}

impl CellMasks {
    /// The mask of the bound of bits `bound`, if one is still in use; it becomes the last
    /// asked for.
    fn take(&mut self, bound: u32) -> Option<std::sync::Arc<CellMask>> {
        let found = self.masks.get(&bound).and_then(std::sync::Weak::upgrade)?;
        self.last = Some(found.clone());
        Some(found)
    }

    /// Files `mask` under the bound of bits `bound` as the last asked for, dropping the
    /// entries of masks that nothing holds once they may be half of all.
    fn keep(&mut self, bound: u32, mask: &std::sync::Arc<CellMask>) {
        self.last = Some(mask.clone());
        self.masks.insert(bound, std::sync::Arc::downgrade(mask));
        if self.masks.len() > self.prune_at {
            self.masks.retain(|_, m| m.strong_count() > 0);
            self.prune_at = (2 * self.masks.len()).max(8);
        }
    }

    /// How many masks are in use (held by the dataset or elsewhere).
    #[cfg(test)]
    pub(super) fn in_use(&self) -> usize {
        self.masks.values().filter(|m| m.strong_count() > 0).count()
    }

    /// How many entries are filed, in use or not.
    #[cfg(test)]
    pub(super) fn entries(&self) -> usize {
        self.masks.len()
    }
}

impl CellMask {
    /// The mask of `bits` (bit c of word c >> 6 for the cell with first node c).
    pub(super) fn new(bits: Vec<u64>) -> CellMask {
        CellMask {
            bits,
            #[cfg(target_endian = "big")]
            words32: Default::default(),
        }
    }

    /// The mask's bits as 32-bit words: bit `c & 31` of word `c >> 5` for the cell with first
    /// node `c` (a cell past their end may reach the bound), for the packet march's gathers
    /// (`render::simd`). On a little-endian machine these are the 64-bit words' own bytes (no
    /// copy: word 2k is the low half of 64-bit word k); on a big-endian one a copy, made once
    /// per mask. Where that cannot be allocated this unwinds ([`super::or_unwind`]).
    pub(crate) fn words32(&self) -> &[u32] {
        super::or_unwind(self.try_words32())
    }

    /// [`CellMask::words32`], or `NoMemory` where the big-endian copy cannot be allocated
    /// (nothing is kept).
    pub(crate) fn try_words32(&self) -> crate::error::Result<&[u32]> {
        #[cfg(target_endian = "little")]
        {
            // SAFETY: the pointer is the u64 words', valid for their 8·len bytes and aligned
            // for u32 (u64's alignment is a multiple of it), so 2·len u32 lie inside them; u32
            // has no invalid bit patterns, and the slice borrows `self.bits`, which nothing
            // mutates while `self` is shared.
            Ok(unsafe {
                std::slice::from_raw_parts(self.bits.as_ptr().cast::<u32>(), 2 * self.bits.len())
            })
        }
        #[cfg(target_endian = "big")]
        {
            super::get_or_try_init(&self.words32, || {
                let mut w =
                    crate::num::try_with_capacity(2 * self.bits.len(), "a cell mask's words")?;
                w.extend(self.bits.iter().flat_map(|&w| [w as u32, (w >> 32) as u32]));
                Ok(w)
            })
            .map(|w| w.as_slice())
        }
    }

    /// Whether the cell with first node `c` may reach the bound.
    #[inline]
    pub(crate) fn may_reach(&self, c: usize) -> bool {
        reaches(&self.bits, c)
    }

    /// [`CellMask::may_reach`] of the `len` ≤ 64 cells with first nodes `c`, `c` + 1, … as
    /// the low bits of a word, cell `c` + b at bit b (cells past the mask's end may reach).
    #[inline]
    pub(crate) fn run(&self, c: usize, len: usize) -> u64 {
        debug_assert!(len <= 64);
        let word = |w: usize| self.bits.get(w).copied().unwrap_or(!0);
        let (w, shift) = (c >> 6, c & 63);
        let mut bits = word(w) >> shift;
        if shift != 0 && shift + len > 64 {
            bits |= word(w + 1) << (64 - shift);
        }
        if len < 64 {
            bits &= (1 << len) - 1;
        }
        bits
    }
}

/// [`CellMask::may_reach`] on the mask's bits (a cell past their end may reach the bound, so
/// no bits at all stand for no mask).
#[inline(always)]
pub(super) fn reaches(bits: &[u64], c: usize) -> bool {
    bits.get(c >> 6).is_none_or(|w| w >> (c & 63) & 1 != 0)
}

impl Dataset {
    /// The [`CellMask`] of bound `z`, built on first use (in parallel, holding no lock, as
    /// [`crate::pool::try_once`] makes a cache) and shared while it is in use ([`CellMasks`]:
    /// the dataset holds the last one asked for, the scenes that use a mask hold theirs).
    /// Where it cannot be allocated this unwinds ([`super::or_unwind`]);
    /// [`Dataset::try_cells_above`] reports it instead.
    pub(crate) fn cells_above(&self, z: f32) -> std::sync::Arc<CellMask> {
        super::or_unwind(self.try_cells_above(z))
    }

    /// [`Dataset::cells_above`], or `NoMemory` where the mask cannot be allocated (nothing is
    /// kept: a later call tries again).
    pub(crate) fn try_cells_above(&self, z: f32) -> crate::error::Result<std::sync::Arc<CellMask>> {
        // A poisoned lock only means another thread panicked while it held the lock: the list
        // itself is always in a consistent state (entries are pushed whole).
        let masks = || {
            self.cell_masks
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
        };
        if let Some(m) = masks().take(z.to_bits()) {
            return Ok(m);
        }
        // Made holding no lock, as `pool::try_once` makes a cache: the first mask kept for the
        // bound is the one every caller gets.
        let made = std::sync::Arc::new(self.compute_cell_mask(z)?);
        let mut masks = masks();
        if let Some(m) = masks.take(z.to_bits()) {
            return Ok(m);
        }
        masks.keep(z.to_bits(), &made);
        Ok(made)
    }

    fn compute_cell_mask(&self, z: f32) -> crate::error::Result<CellMask> {
        // Over the raw voxels, like the brick ranges: `normaliser` is monotone, so a cell's
        // largest node value is the normalised largest raw voxel of its nodes (smallest, where
        // the normalisation decreases), and "normalised above the bound" is a threshold on raw
        // voxels.
        let lo = z - CELL_MASK_MARGIN;
        let bits = match (&self.raw, self.b > self.a) {
            (Voxels::U8(v), true) => self.raw_cell_bits::<_, true>(v, lo),
            (Voxels::U8(v), false) => self.raw_cell_bits::<_, false>(v, lo),
            (Voxels::U16(v), true) => self.raw_cell_bits::<_, true>(v, lo),
            (Voxels::U16(v), false) => self.raw_cell_bits::<_, false>(v, lo),
        }?;
        Ok(CellMask::new(bits))
    }

    /// The bits of [`CellMask`] for bound `lo` (a cell's bit is set where its largest node
    /// value is above `lo`), from the raw voxels `v`; `UP`: the normalisation increases
    /// (b > a). (A constant, so that each loop below compiles to plain minima or maxima.)
    fn raw_cell_bits<T, const UP: bool>(&self, v: &[T], lo: f32) -> crate::error::Result<Vec<u64>>
    where
        T: Copy + PartialOrd + TryFrom<u32> + Send + Sync,
    {
        use rayon::prelude::*;
        debug_assert_eq!(UP, self.b > self.a);
        let norm = normaliser(self.a, self.b);
        // Raw voxels are 0 ..= top. The voxels whose value is above `lo` are those from the
        // threshold t up (increasing normalisation) or up to it (decreasing): the first such
        // voxel from that end, found by bisection on the monotone test; `None` where none is.
        let top = if std::mem::size_of::<T>() == 1 {
            255u32
        } else {
            65535
        };
        let above = |x: u32| norm(x as f64) > lo;
        // (from the passing end: `at(0)` is top where increasing, 0 where decreasing)
        let at = |i: u32| if UP { top - i } else { i };
        let threshold = if !above(at(0)) {
            None
        } else {
            // The largest i with above(at(i)): above(at(0)) holds, and at(i) moves away from
            // the passing end as i grows.
            let (mut ok, mut bad) = (0u32, top + 1);
            while bad - ok > 1 {
                let mid = ok + (bad - ok) / 2;
                if above(at(mid)) {
                    ok = mid;
                } else {
                    bad = mid;
                }
            }
            Some(at(ok))
        };
        let mut bits = crate::num::try_vec(v.len().div_ceil(64), 0u64, "a cell mask")?;
        let Some(t) = threshold else {
            return Ok(bits);
        };
        let t = T::try_from(t).ok().expect("a raw voxel value");
        let [nx, ny, _] = self.dims;
        let [sx, sy, sz] = self.strides;
        let top = self.top32.map(|t| t as usize);
        // The extreme that decides a cell: the largest raw voxel where increasing, the
        // smallest where decreasing. `t` is moved into the test: captured by reference, it would
        // be loaded again for every cell (the flags written might be it, for all the compiler
        // knows), and the loop would not compile to lanes.
        let pick = |p: T, q: T| {
            if UP {
                if p > q {
                    p
                } else {
                    q
                }
            } else if p < q {
                p
            } else {
                q
            }
        };
        let passes = move |x: T| if UP { x >= t } else { x <= t };
        // A run of words at a time in parallel, each from a flag per node of the run (no flag
        // per node of the whole grid: a first image pays a page fault per 4 KiB of fresh
        // memory). Per x-row of nodes that meets the run: the extreme of each cell's nodes
        // (the four x-rows' extreme at each x, then of two neighbours along x) against the
        // threshold; nodes that start no cell keep a flag of 0.
        bits.par_chunks_mut(CELL_MASK_RUN)
            .enumerate()
            .try_for_each_init(
                || {
                    let what = "a cell mask's scratch rows";
                    Ok::<_, crate::error::Error>((
                        crate::num::try_vec(nx, t, what)?,
                        vec![0u8; CELL_MASK_RUN * 64],
                    ))
                },
                |scratch, (c, out)| {
                    let (m, flags) = scratch.as_mut().map_err(|e| e.clone())?;
                    let first = c * CELL_MASK_RUN * 64;
                    let end = (first + out.len() * 64).min(v.len());
                    let flags = &mut flags[..end - first];
                    flags.fill(0);
                    for r in first / nx..end.div_ceil(nx) {
                        let (j, k) = (r % ny, r / ny);
                        if j > top[1] || k > top[2] {
                            continue;
                        }
                        let o = r * nx;
                        let row = |r: usize| &v[r..r + nx];
                        let (a, b, c, d) = (row(o), row(o + sy), row(o + sz), row(o + sy + sz));
                        let rows = a.iter().zip(b).zip(c.iter().zip(d));
                        for (m, ((&a, &b), (&c, &d))) in m.iter_mut().zip(rows) {
                            *m = pick(pick(a, b), pick(c, d));
                        }
                        // The row's cells inside the run: first nodes o + i0 ..= o + i1.
                        let (i0, i1) = (first.saturating_sub(o), top[0].min(end - 1 - o));
                        if i0 > i1 {
                            continue;
                        }
                        // (Slices of one length: the loop then compiles to lanes.)
                        let len = i1 - i0 + 1;
                        let here = &mut flags[o + i0 - first..][..len];
                        let (p, q) = (&m[i0..][..len], &m[i0 + sx..][..len]);
                        for (f, (&p, &q)) in here.iter_mut().zip(p.iter().zip(q)) {
                            *f = u8::from(passes(pick(p, q)));
                        }
                    }
                    for (w, f) in out.iter_mut().zip(flags.chunks(64)) {
                        *w = pack_flags(f);
                    }
                    Ok(())
                },
            )?;
        Ok(bits)
    }
}
