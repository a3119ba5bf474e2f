//! Transfer functions: the lookup table Φ_t and the linear ramp Φ_r of the paper (§4.4).
//!
//! A [`Mapping`] is validated once when it is declared (`vlMapping`) and is immutable afterwards;
//! objects hold it by `Arc`, so redefining an id later does not change objects already built. The
//! evaluation follows the paper's case analysis literally; where the formulas leave a value open
//! (Φ_r at v = 1 when a_n < 1, v = 0 when a_1 = 0) the choice is documented on [`Mapping::eval`]
//! and in `docs/compat.md`.
//!
//! It owns the tables and their evaluation; the lean kernel's fused forms of the same
//! arithmetic (segments located once for several outputs, segment pairs) are the renderer's.

use crate::error::{err, ErrorCode, Result};
use crate::num::{clamp_fields, try_with_capacity};
use crate::types::MappingType;

/// The largest number of rows a mapping may have.
pub const MAX_POINTS: usize = 1 << 20;
/// The largest number of outputs a mapping may have.
pub const MAX_OUTPUTS: usize = 64;

/// A validated transfer function.
#[derive(Clone, Debug, PartialEq)]
pub struct Mapping {
    kind: MappingType,
    /// The input points a_1 < … < a_n.
    a: Vec<f32>,
    /// Row-major outputs: b[i * outputs + j] = b_{i+1, j+1}.
    b: Vec<f32>,
    outputs: usize,
    /// The ramp's segments between rows, `1 + 2·outputs` numbers each: segment i (from row i
    /// to row i + 1, counted from 0) is a_i, then per output j: b_{i,j} and the slope
    /// (b_{i+1,j} − b_{i,j})/(a_{i+1} − a_i), all as f64.
    segments: Vec<f64>,
    /// Per input bucket b (the inputs v with ⌊v·[`BUCKETS`]⌋ = b, v in [0, 1]: see
    /// [`Mapping::clamp_and_bucket`]): the segment [`Mapping::locate`] finds for every one of
    /// them, or [`SCAN`] where a breakpoint falls in the bucket (the inputs are then counted
    /// against the breakpoints).
    buckets: Vec<u16>,
    /// Per block of [`BLOCK`] rows and output j, at `block · outputs + j`: the least and
    /// greatest of the values [`Mapping::range`] takes for the block's rows where they lie
    /// inside its interval (Φ_r at the breakpoint a_i, Φ_t the output b_{i+1} of the step
    /// after it), so that a wide interval costs a look per block, not per row. Empty for
    /// tables of at most [`SCANNED_ROWS`] rows.
    blocks: Vec<(f32, f32)>,
}

/// Rows a block of `Mapping::blocks` spans.
const BLOCK: usize = 64;
/// Tables of up to this many rows have no blocks: `range` scans their rows.
const SCANNED_ROWS: usize = 4 * BLOCK;

/// Input buckets of [`Mapping::locate`]'s table: v·BUCKETS is exact in f32 (a power of two).
const BUCKETS: usize = 1024;
/// A bucket whose inputs do not share one segment.
const SCAN: u16 = u16::MAX;

/// The buckets of breakpoints `a` (strictly increasing): see `Mapping::buckets`.
fn buckets(a: &[f32]) -> Vec<u16> {
    let mut below = 0; // breakpoints below the bucket's first input
    (0..=BUCKETS)
        .map(|b| {
            let lo = b as f32 / BUCKETS as f32;
            while below < a.len() && a[below] < lo {
                below += 1;
            }
            // The count is the same for every input of the bucket unless a breakpoint lies in
            // [lo, hi) (the last bucket holds the input 1 alone).
            let split = b < BUCKETS
                && a.get(below)
                    .is_some_and(|&x| x < (b + 1) as f32 / BUCKETS as f32);
            match u16::try_from(below) {
                Ok(k) if !split && k != SCAN => k,
                _ => SCAN,
            }
        })
        .collect()
}

/// Output `j` of a ramp segment (see [`Mapping::ramp_segment`]) at `dv` past its start:
/// `b + dv·slope`, rounded to f32.
#[inline]
pub(crate) fn segment_value(seg: &[f64], dv: f64, j: usize) -> f32 {
    (seg[1 + 2 * j] + dv * seg[2 + 2 * j]) as f32
}

impl Mapping {
    /// Validates a table of `points` rows `(a, b_1, …, b_outputs)`: every value finite and in
    /// [0, 1], the a strictly increasing, and the table exactly `points * (outputs + 1)` long
    /// (else `BadValue`). The rows and the ramp's segments are allocated fallibly: `NoMemory`
    /// where they do not fit.
    pub fn new(kind: MappingType, points: i32, outputs: i32, table: &[f32]) -> Result<Mapping> {
        if points < 1 || points as usize > MAX_POINTS {
            return err(
                ErrorCode::BadValue,
                format!("vlMapping: {points} points (must be 1 … {MAX_POINTS})"),
            );
        }
        if outputs < 1 || outputs as usize > MAX_OUTPUTS {
            return err(
                ErrorCode::BadValue,
                format!("vlMapping: {outputs} outputs (must be 1 … {MAX_OUTPUTS})"),
            );
        }
        let (n, k) = (points as usize, outputs as usize);
        if table.len() != n * (k + 1) {
            return err(
                ErrorCode::BadValue,
                format!(
                    "vlMapping: table holds {} values, expected {}",
                    table.len(),
                    n * (k + 1)
                ),
            );
        }
        if let Some(i) = table
            .iter()
            .position(|v| !v.is_finite() || !(0.0..=1.0).contains(v))
        {
            return err(
                ErrorCode::BadValue,
                format!(
                    "vlMapping: table value {} at index {i} is not in [0, 1]",
                    table[i]
                ),
            );
        }
        // The rows and the ramp's segments grow with points × outputs (about 1.3 GiB at the
        // largest sizes): allocated fallibly, a failure is `NoMemory` and nothing is kept.
        let mut a = try_with_capacity(n, "vlMapping's input points")?;
        let mut b = try_with_capacity(n * k, "vlMapping's outputs")?;
        for row in table.chunks_exact(k + 1) {
            if let Some(&last) = a.last() {
                if row[0] <= last {
                    return err(
                        ErrorCode::BadValue,
                        format!(
                            "vlMapping: input points must increase strictly ({} follows {last})",
                            row[0]
                        ),
                    );
                }
            }
            a.push(row[0]);
            b.extend_from_slice(&row[1..]);
        }
        let mut segments = try_with_capacity((n - 1) * (1 + 2 * k), "vlMapping's ramp segments")?;
        for i in 1..n {
            segments.push(a[i - 1] as f64);
            for j in 0..k {
                let (b0, b1) = (b[(i - 1) * k + j] as f64, b[i * k + j] as f64);
                segments.push(b0);
                segments.push((b1 - b0) / (a[i] as f64 - a[i - 1] as f64));
            }
        }
        let mut m = Mapping {
            kind,
            buckets: buckets(&a),
            a,
            b,
            outputs: k,
            segments,
            blocks: Vec::new(),
        };
        m.blocks = m.blocks()?;
        Ok(m)
    }

    /// The value [`Mapping::range`] takes for row i inside its interval, output j: Φ_r at the
    /// breakpoint a_i (evaluated on its segment: i breakpoints lie below it), or Φ_t's output
    /// b_{i+1} (for i below n − 1).
    #[inline]
    fn row_value(&self, i: usize, j: usize) -> f32 {
        match self.kind {
            MappingType::Ramp => self.eval_at(self.a[i], i, j),
            MappingType::Lookup => self.b(i + 1, j),
        }
    }

    /// `Mapping::blocks` of this table (allocated fallibly: it grows with the rows).
    fn blocks(&self) -> Result<Vec<(f32, f32)>> {
        let n = self.a.len();
        if n <= SCANNED_ROWS {
            return Ok(Vec::new());
        }
        // The rows `range` can take: every one of a ramp, all but the last of a lookup table.
        let rows = match self.kind {
            MappingType::Ramp => n,
            MappingType::Lookup => n - 1,
        };
        let k = self.outputs;
        let mut blocks = try_with_capacity(n.div_ceil(BLOCK) * k, "vlMapping's row blocks")?;
        for start in (0..n).step_by(BLOCK) {
            for j in 0..k {
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                for i in start..(start + BLOCK).min(rows) {
                    let v = self.row_value(i, j);
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
                blocks.push((lo, hi));
            }
        }
        Ok(blocks)
    }

    /// The kind of transfer function.
    pub fn kind(&self) -> MappingType {
        self.kind
    }

    /// The number of outputs per row.
    pub fn outputs(&self) -> usize {
        self.outputs
    }

    /// The input points a_1 < … < a_n.
    pub(crate) fn breakpoints(&self) -> &[f32] {
        &self.a
    }

    /// Output `j` of row `i` (both counted from 0): b_{i+1, j+1}.
    pub(crate) fn b(&self, i: usize, j: usize) -> f32 {
        self.b[i * self.outputs + j]
    }

    /// Φ(v, j) for output `j` counted from 0 (the API counts from 1). `v` is a field value, so it
    /// is clamped to [0, 1] first (NaN → 0).
    ///
    /// Φ_t: 0 if v ≤ a_1 or v > a_n, otherwise b_{i+1} where a_i < v ≤ a_{i+1}.
    ///
    /// Φ_r: v·b_1/a_1 on 0 < v ≤ a_1; linear between rows on a_i < v ≤ a_{i+1};
    /// b_n + (v − a_n)(1 − b_n)/(1 − a_n) on a_n < v < 1; the ramp's final segment ends at (1, 1),
    /// so Φ_r(1) = 1 when a_n < 1; and Φ_r(0) = 0 (every case of the paper excludes v = 0 except the
    /// last segment when a_1 = 0 — see `docs/compat.md`).
    pub fn eval(&self, v: f32, j: usize) -> f32 {
        let (v, k) = self.locate(v);
        self.eval_at(v, k, j)
    }

    /// The clamped input (NaN → 0) and its segment: k = the number of a_i strictly below it,
    /// so a_k < v ≤ a_{k+1} in 1-based terms. Shared by all outputs of one input.
    #[inline]
    pub fn locate(&self, v: f32) -> (f32, usize) {
        // (v ≥ 0 after the clamp, −0 included: the truncation is the floor.)
        let (v, b) = Self::clamp_and_bucket(v);
        let bucket = self.buckets[b];
        if bucket != SCAN {
            return (v, bucket as usize);
        }
        let k = if self.a.len() <= 16 {
            self.a.iter().take_while(|&&a| a < v).count()
        } else {
            self.a.partition_point(|&a| a < v)
        };
        (v, k)
    }

    /// Φ(v, j) for an input already placed by [`Mapping::locate`]: `eval(v, j)` is
    /// `eval_at(locate(v), j)`, so several outputs of one input share the search.
    #[inline]
    pub fn eval_at(&self, v: f32, k: usize, j: usize) -> f32 {
        debug_assert!(j < self.outputs);
        let n = self.a.len();
        match self.kind {
            MappingType::Lookup => {
                if k == 0 || k == n {
                    0.0
                } else {
                    self.b(k, j)
                }
            }
            MappingType::Ramp => {
                if v <= 0.0 {
                    return 0.0;
                }
                if k == 0 {
                    // 0 < v ≤ a_1 (a_1 > 0 here since v > 0 and v ≤ a_1).
                    let (a1, b1) = (self.a[0] as f64, self.b(0, j) as f64);
                    return (v as f64 * b1 / a1) as f32;
                }
                if k == n {
                    // a_n < v ≤ 1.
                    let (an, bn) = (self.a[n - 1] as f64, self.b(n - 1, j) as f64);
                    if v >= 1.0 {
                        return 1.0;
                    }
                    return (bn + (v as f64 - an) * (1.0 - bn) / (1.0 - an)) as f32;
                }
                let seg = self.segment(k - 1);
                segment_value(seg, v as f64 - seg[0], j)
            }
        }
    }

    /// Segment `i` of the ramp: a_i, then (b_{i,j}, slope) per output j.
    #[inline]
    pub(crate) fn segment(&self, i: usize) -> &[f64] {
        let stride = 1 + 2 * self.outputs;
        &self.segments[i * stride..(i + 1) * stride]
    }

    /// For a ramp and an input located by [`Mapping::locate`] strictly between its first and
    /// last rows (0 < k < n, v > 0), where Φ_r is linear: the segment (a, then [b, slope] per
    /// output), so that `eval_at(v, k, j)` is `segment_value(seg, v − a, j)`. `None` elsewhere.
    #[inline]
    pub fn ramp_segment(&self, v: f32, k: usize) -> Option<&[f64]> {
        if self.kind == MappingType::Ramp && k > 0 && k < self.a.len() && v > 0.0 {
            Some(self.segment(k - 1))
        } else {
            None
        }
    }

    /// A field value clamped as [`clamp_field`](crate::model::program::clamp_field) clamps it (into
    /// [0, 1], NaN → 0), and the bucket of [`Mapping::locate`]'s table holding the clamped
    /// value x: ⌊x·BUCKETS⌋, the same for every mapping, so one bucket index serves several
    /// tables. Computed in an f32 lane: the clamp as [`clamp_fields`] (bit for bit
    /// `clamp_field`), then the product's truncation by the vector instruction, which has no
    /// saturation to handle. The product is in [0, BUCKETS], so the truncation is exact and
    /// the bucket that of `(x * BUCKETS as f32) as usize`, in about half the instructions of
    /// the scalar clamp and that saturating conversion (some 15 on x86-64 on its own: the
    /// unsigned range above 2⁶³ has no instruction).
    #[inline]
    pub(crate) fn clamp_and_bucket(v: f32) -> (f32, usize) {
        use wide::f32x4;
        let x = clamp_fields(f32x4::splat(v));
        let b = (x * f32x4::splat(BUCKETS as f32)).fast_trunc_int();
        (x.to_array()[0], b.to_array()[0] as u32 as usize)
    }

    /// [`Mapping::clamp_and_bucket`]'s bucket of a value already in [0, 1] (−0 included),
    /// which the clamp leaves as it is.
    #[inline]
    pub(crate) fn bucket_in_range(x: f32) -> usize {
        use wide::f32x4;
        let b = (f32x4::splat(x) * f32x4::splat(BUCKETS as f32)).fast_trunc_int();
        b.to_array()[0] as u32 as usize
    }

    /// The number of buckets [`Mapping::clamp_and_bucket`] can return.
    pub(crate) const BUCKET_COUNT: usize = BUCKETS + 1;

    /// For bucket `b`, the ramp segment that every input v > 0 of the bucket is evaluated on
    /// (`eval(v, j)` is then `segment_value(seg, v − seg[0], j)`), where the bucket's inputs
    /// share one segment strictly between the first and last rows; `None` elsewhere (a
    /// breakpoint inside the bucket, the first or last stretch of a ramp, a lookup table).
    pub(crate) fn bucket_segment(&self, b: usize) -> Option<&[f64]> {
        match self.buckets.get(b) {
            // Every input of the bucket locates to k, and for v > 0 `ramp_segment` depends
            // on k alone.
            Some(&k) if k != SCAN => self.ramp_segment(f32::MIN_POSITIVE, k as usize),
            _ => None,
        }
    }

    /// The largest input z such that Φ(v, j) = 0 for every v in [0, z] (NaN counts as 0), found
    /// among 0 and the breakpoints as the last c whose exact [`Mapping::range`] over [0, c] has
    /// a largest value of at most 0; `None` if Φ(0, j) ≠ 0. A sample whose input is at most z
    /// needs no evaluation: its output is 0.
    ///
    /// One pass over the rows: as c moves from one breakpoint to the next, [0, c] takes in
    /// the one breakpoint (Φ_r) or step (Φ_t) that `range` sees inside it and the last did
    /// not, so the largest value of `range(0, c, j)` is kept as a running maximum, from the
    /// same evaluations (a `range` per candidate would make every compile of a scene
    /// quadratic in the rows: 18 s at 2¹⁶ rows).
    pub fn zero_below(&self, j: usize) -> Option<f32> {
        let (a, n) = (&self.a, self.a.len());
        // What `range(0, c, j)` takes besides Φ at c: Φ at 0, and the 0 a lookup table
        // takes for an interval that starts at or before a_1 (every one here, a_1 ≥ 0).
        let mut inside = match self.kind {
            MappingType::Lookup => self.eval(0.0, j).max(0.0),
            MappingType::Ramp => self.eval(0.0, j),
        };
        let mut z = None;
        for k in 0..=n {
            // Candidate k: 0, then a_1 … a_n (a_k as the kth, counted from 1).
            let c = if k == 0 { 0.0 } else { a[k - 1] };
            if k >= 2 {
                // Newly inside [0, c]: Φ_r's breakpoint a_{k−1} (where above 0), Φ_t's step
                // (a_{k−2}, a_{k−1}], of output b_{k−1}.
                match self.kind {
                    MappingType::Ramp if a[k - 2] > 0.0 => {
                        inside = inside.max(self.eval(a[k - 2], j))
                    }
                    MappingType::Ramp => {}
                    MappingType::Lookup => inside = inside.max(self.b(k - 1, j)),
                }
            }
            if inside.max(self.eval(c, j)) <= 0.0 {
                z = Some(c);
            } else {
                break;
            }
        }
        z
    }
}

impl Mapping {
    /// The smallest and largest value of Φ(v, j) over all v in [lo, hi] (clamped to [0, 1]):
    /// exact, from the values at the ends and at every breakpoint inside, and for Φ_t the
    /// output of every step the interval meets. It proves a region transparent.
    pub fn range(&self, lo: f32, hi: f32, j: usize) -> (f32, f32) {
        let clamp = |v: f32| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        let (lo, hi) = (clamp(lo), clamp(hi.max(lo)));
        let mut min = self.eval(lo, j).min(self.eval(hi, j));
        let mut max = self.eval(lo, j).max(self.eval(hi, j));
        let mut take = |v: f32| {
            min = min.min(v);
            max = max.max(v);
        };
        let (a, n) = (&self.a, self.a.len());
        // The rows in play, found by bisection (the breakpoints increase strictly): those
        // below `hi`, and from the first at or above `lo` (Φ_t) or above it (Φ_r).
        let below_hi = a.partition_point(|&x| x < hi);
        let rows = match self.kind {
            MappingType::Lookup => {
                // Φ_t is b_{i+1} on (a_i, a_{i+1}] and 0 outside (a_1, a_n]: the steps i with
                // a_i < hi and a_{i+1} ≥ lo.
                if lo <= a[0] || hi > a[n - 1] {
                    take(0.0);
                }
                a.partition_point(|&x| x < lo).saturating_sub(1)..below_hi.min(n - 1)
            }
            // Piecewise linear: extremes at the ends or at the breakpoints inside.
            MappingType::Ramp => a.partition_point(|&x| x <= lo)..below_hi,
        };
        // Each row's value, or a whole block's least and greatest at once.
        let mut i = rows.start;
        while i < rows.end {
            if i % BLOCK == 0 && i + BLOCK <= rows.end && !self.blocks.is_empty() {
                let (lo, hi) = self.blocks[i / BLOCK * self.outputs + j];
                take(lo);
                take(hi);
                i += BLOCK;
            } else {
                take(self.row_value(i, j));
                i += 1;
            }
        }
        (min, max)
    }
}

#[cfg(test)]
mod tests;
