//! Volume datasets: the `.vlb` file format, normalisation, and interpolation filters.
//!
//! A [`Dataset`] is a regular grid of nodes (node i of n lies at object coordinate i/(n − 1); a
//! dimension of 1 is constant along its axis) holding 8- or 16-bit voxels normalised by
//! `min(1, max(0, (v − a)/(b − a)))`. It is immutable once loaded and shared by `Arc` between
//! every object that casts it, so 32 chess pieces made from six datasets hold six grids.
//!
//! Filters ([`Filter`]): nearest node, trilinear, and the Mitchell–Netravali BC family of
//! tricubic filters (B = 0, C = 0.5 is Catmull–Rom, the default; B = 1, C = 0 the cubic B-spline).
//! Values and gradients use the same filter: the gradient at a point is the filter applied to the
//! central-difference gradients of the nodes (one-sided at the faces), so a linear field has an
//! exact gradient everywhere. Points outside [0, 1]^3 take the value of the nearest face
//! (clamp to edge).
//!
//! The reader refuses a malformed file before allocating anything: the header's claims are
//! checked against each other and against the file's real length.

use crate::error::{err, Error, ErrorCode, Result};
use crate::types::Interpolation;
use std::io::Read;
use std::path::Path;

/// The magic number of a `.vlb` file.
pub const MAGIC: &[u8; 4] = b"VLB1";
/// The size of the `.vlb` header in bytes.
pub const HEADER_LEN: usize = 28;
/// The largest number of voxels a dataset may have (2^32; 16 GiB of normalised values).
pub const MAX_VOXELS: u64 = 1 << 32;

/// The raw voxels of a dataset, as stored in the file.
#[derive(Clone, Debug, PartialEq)]
pub enum Voxels {
    /// One byte per voxel.
    U8(Vec<u8>),
    /// Two bytes per voxel.
    U16(Vec<u16>),
}

impl Voxels {
    /// Bytes per voxel.
    pub fn width(&self) -> u32 {
        match self {
            Voxels::U8(_) => 1,
            Voxels::U16(_) => 2,
        }
    }

    fn len(&self) -> usize {
        match self {
            Voxels::U8(v) => v.len(),
            Voxels::U16(v) => v.len(),
        }
    }

    fn get(&self, i: usize) -> f64 {
        match self {
            Voxels::U8(v) => v[i] as f64,
            Voxels::U16(v) => v[i] as f64,
        }
    }
}

/// An interpolation filter with its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Filter {
    /// The nearest node.
    Nearest,
    /// Trilinear interpolation (the default).
    #[default]
    Trilinear,
    /// The separable BC-spline with parameters B and C.
    Cubic {
        /// Mitchell–Netravali B.
        b: f32,
        /// Mitchell–Netravali C.
        c: f32,
    },
}

impl Filter {
    /// The filter for an interpolation type and the cubic parameters in force.
    pub fn new(kind: Interpolation, cubic: (f32, f32)) -> Filter {
        match kind {
            Interpolation::Nearest => Filter::Nearest,
            Interpolation::Trilinear => Filter::Trilinear,
            Interpolation::Tricubic => Filter::Cubic {
                b: cubic.0,
                c: cubic.1,
            },
        }
    }
}

/// The largest sum of |weights| of the BC-spline filter along one axis, over all positions: a
/// value interpolated in 3D lies within min − (P − 1)(max − min) … max + (P − 1)(max − min),
/// P = (S³ + 1)/2 the largest total positive weight. Sampled on a fine grid, plus a margin.
pub fn bc_abs_sum(b: f64, c: f64) -> f64 {
    let mut worst: f64 = 1.0;
    for i in 0..=1024 {
        let t = i as f64 / 1024.0;
        let s: f64 = (-1..=2).map(|m| bc_kernel(t - m as f64, b, c).abs()).sum();
        worst = worst.max(s);
    }
    worst * (1.0 + 1e-6)
}

/// The Mitchell–Netravali BC-spline kernel k(x), support |x| < 2.
pub fn bc_kernel(x: f64, b: f64, c: f64) -> f64 {
    let x = x.abs();
    if x < 1.0 {
        ((12.0 - 9.0 * b - 6.0 * c) * x * x * x
            + (-18.0 + 12.0 * b + 6.0 * c) * x * x
            + (6.0 - 2.0 * b))
            / 6.0
    } else if x < 2.0 {
        ((-b - 6.0 * c) * x * x * x
            + (6.0 * b + 30.0 * c) * x * x
            + (-12.0 * b - 48.0 * c) * x
            + (8.0 * b + 24.0 * c))
            / 6.0
    } else {
        0.0
    }
}

/// The normalisation of raw voxel values to node values, `(v − a)/(b − a)` clamped to [0, 1],
/// in f64 and then rounded to f32: the node values ([`Dataset::new`]) and the brick ranges
/// found from raw extremes ([`Dataset::bricks`]) both come from it. Monotone in v
/// (non-decreasing for b > a, non-increasing for b < a): each step (a subtraction, a division
/// by a constant, a clamp, a rounding) is, so the extremes of the node values over any set of
/// nodes are the normalised extremes of their raw values.
fn normaliser(a: f32, b: f32) -> impl Fn(f64) -> f32 + Copy + Sync {
    let (af, bf) = (a as f64, b as f64);
    move |v: f64| ((v - af) / (bf - af)).clamp(0.0, 1.0) as f32
}

/// Nodes per side of a brick, the unit of empty-space skipping.
pub const BRICK: usize = 4;

/// The range of node values that any point of each brick can read under a filter: brick
/// (i, j, k) covers object coordinates of node indices [4i, 4i + 4] × …, and its range is taken
/// over every node the filter can reach from there, including from points a rounding error
/// outside it.
#[derive(Clone, Debug)]
pub struct Bricks {
    /// Brick counts per axis.
    pub dims: [usize; 3],
    /// Smallest value per brick, x fastest.
    pub min: Vec<f32>,
    /// Largest value per brick.
    pub max: Vec<f32>,
}

impl Bricks {
    /// The (min, max) of brick (i, j, k); indices are clamped to the grid.
    #[inline]
    pub fn get(&self, i: usize, j: usize, k: usize) -> (f32, f32) {
        let d = self.dims;
        let idx = i.min(d[0] - 1) + d[0] * (j.min(d[1] - 1) + d[1] * k.min(d[2] - 1));
        (self.min[idx], self.max[idx])
    }
}

/// Lowers each of `min` to the matching value of `lo` where that is smaller, and raises each of
/// `max` to the matching value of `hi` where that is larger (raw voxels: no NaN among them).
fn widen<T: Copy + PartialOrd>(min: &mut [T], max: &mut [T], lo: &[T], hi: &[T]) {
    // (As selects rather than conditional stores, so that they compile to lanes of minima and
    // maxima.)
    for (m, &x) in min.iter_mut().zip(lo) {
        *m = if x < *m { x } else { *m };
    }
    for (m, &x) in max.iter_mut().zip(hi) {
        *m = if x > *m { x } else { *m };
    }
}

/// How far below a bound z a trilinear cell's largest node may lie and still count as reaching
/// it in a [`CellMask`]: far above the rounding of the three nested f32 lerps of
/// [`Dataset::trilinear`] (each within 3·2⁻²⁴ of the exact value for values in [0, 1], so at
/// most about 5.4·10⁻⁷ above the largest node in all), and below the spacing of 16-bit values
/// (1/65535), so the only cells kept needlessly are those whose largest node lies within it
/// below z.
const CELL_MASK_MARGIN: f32 = 1.0 / (1 << 18) as f32;

/// The words of a [`CellMask`] one task of its construction fills (64 nodes a word).
const CELL_MASK_RUN: usize = 1024;

/// Up to 64 flags (each 0 or 1) as the bits of a word, flag b as bit b. Eight at a time: for
/// bytes x_k ∈ {0, 1} (k = 0 … 7, little-endian), the product of their word with
/// Σ_k 2^(56 − 7k) holds x_k at bit 56 + k, every other term lying below bit 56 (at distinct
/// bits, so without carries) or above bit 63.
fn pack_flags(flags: &[u8]) -> u64 {
    const SPREAD: u64 = 0x0102_0408_1020_4080;
    let byte = |x: u64, b: usize| (x.wrapping_mul(SPREAD) >> 56) << (8 * b);
    // Whole words of eight flags read as they are; the last, shorter group padded with zeros
    // (apart: padding every group cost a copy per eight flags).
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
    bits: Vec<u64>,
    /// The bits as 32-bit words (word w holds bits 32w … 32w + 31), for the packet march's
    /// gathers: made on first use, then shared by every image that uses the mask.
    words32: std::sync::OnceLock<Vec<u32>>,
}

/// The cell masks of a dataset, each with the bits of its bound.
type CellMasks = Vec<(u32, std::sync::Arc<CellMask>)>;

impl CellMask {
    /// The mask's bits as 32-bit words: bit `c & 31` of word `c >> 5` for the cell with first
    /// node `c` (a cell past their end may reach the bound). For the packet march
    /// (`render::packet`), made once per mask.
    pub(crate) fn words32(&self) -> &[u32] {
        self.words32.get_or_init(|| {
            self.bits
                .iter()
                .flat_map(|&w| [w as u32, (w >> 32) as u32])
                .collect()
        })
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
fn reaches(bits: &[u64], c: usize) -> bool {
    bits.get(c >> 6).is_none_or(|w| w >> (c & 63) & 1 != 0)
}

/// The cells of [`Dataset::trilinear8`]'s points, handed out so that the batched march can
/// take a shaded sample's gradient in its cell ([`Dataset::trilinear_gradient_in`]) instead of
/// finding the cell again from the point.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Cells8 {
    /// Per point, its cell's first node's index.
    pub(crate) at: [u32; 8],
    /// Per axis and point, the weight of the cell's second node.
    pub(crate) f: [[f32; 8]; 3],
    /// Per axis and point, the clamped coordinate the cell was found from (min(u, n − 2), see
    /// [`Dataset::cell_in_lanes`]), for [`Dataset::interior8`].
    pub(crate) cu: [[f32; 8]; 3],
    /// How many of the points (the first) the cells were found for in lanes (0: none, those
    /// points keep the gradient's own path).
    pub(crate) count: u32,
}

/// The central differences (per grid step) at the eight nodes of the cell a trilinear
/// gradient last read, per corner (x fastest) and axis (x, y, z), for
/// [`Dataset::gradient_cached`]; `lo` is the first node of
/// the 4×4×4 neighbourhood they were read from (`usize::MAX`: none yet). Valid for one dataset.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CellGradients {
    lo: usize,
    /// Per corner, its differences along y, z and x, and a lane not read (one SSE register).
    diffs: [[f32; 4]; 8],
}

impl Default for CellGradients {
    fn default() -> CellGradients {
        CellGradients {
            lo: usize::MAX,
            diffs: [[0.0; 4]; 8],
        }
    }
}

/// The trilinear value of a cell, clamped to [0, 1], from its eight nodes as two pairs of
/// x-rows, `z0 = [r00, r01]` and `z1 = [r10, r11]` (`rYZ` the row at y + Y, z + Z, its two
/// nodes along x), at weights `f` of the second nodes: the lerps `a + (b − a)·t` along x, then
/// y, then z, of the scalar code (`c00 = lerp(r00[0], r00[1], fx)`, …,
/// `lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz)`), but the x-lerps and the y-lerps in
/// SSE lanes: lanes 0 and 2 of each register hold the two rows' first nodes, lanes 1 and 3
/// their second, so lerping each register against itself shifted down a lane leaves c00 and
/// c01 (c10 and c11) in lanes 0 and 2, and lerping the two results leaves both y-lerps there
/// (lanes 1 and 3 are never read). Each lane is the same f32 subtraction, product and sum, with
/// no fused multiply-add, so the same bits (`trilinear_rows_is_the_scalar_lerps`); it takes
/// the pairs as the two rows' 8-byte loads, where the scalar lerps shuffled them about.
#[inline(always)]
fn trilinear_rows(z0: [f32; 4], z1: [f32; 4], [fx, fy, fz]: [f32; 3]) -> f32 {
    use wide::f32x4;
    let x = |r: [f32; 4]| {
        let a = f32x4::new(r);
        a + (f32x4::new([r[1], r[1], r[3], r[3]]) - a) * f32x4::splat(fx)
    };
    let (a, b) = (x(z0), x(z1));
    let d = (a + (b - a) * f32x4::splat(fy)).to_array();
    (d[0] + (d[2] - d[0]) * fz).clamp(0.0, 1.0)
}

/// A loaded dataset: dimensions, raw voxels, normalisation and the normalised node values.
#[derive(Clone, Debug)]
pub struct Dataset {
    dims: [usize; 3],
    a: f32,
    b: f32,
    raw: Voxels,
    /// Normalised node values, x fastest: computed on first use ([`Dataset::values`]). A
    /// render that reads only the raw voxels (the packet march of 8-bit voxels, the brick
    /// ranges, the cell masks) never makes them: for a scan, four times its voxels' memory,
    /// and a large part of its first image's time.
    values: std::sync::OnceLock<Vec<f32>>,
    /// Brick ranges, computed on first use: for reach 1 (nearest, trilinear) and 2 (cubic).
    bricks: [std::sync::OnceLock<Bricks>; 2],
    /// Cell masks built so far, by the bits of their bound (see [`Dataset::cells_above`]).
    cell_masks: std::sync::Arc<std::sync::Mutex<CellMasks>>,
    /// n − 1 per axis, as f64 (int ↔ float conversions of usize are slow on x86-64).
    last: [f64; 3],
    /// 0.5·(n − 1) per axis (exact), the scale of a gradient's central differences.
    half_last: [f64; 3],
    /// The offset of node (1, 1, 1) from node (0, 0, 0) along a cell's neighbourhood: 1 + nx +
    /// nx·ny (see [`Dataset::neighbourhood_lo`]).
    lo_offset: usize,
    /// n − 1 per axis, as f32.
    last32: [f32; 3],
    /// The last cell's first node per axis, max(n − 2, 0), as i32 (saturated).
    top32: [i32; 3],
    /// For [`Dataset::cell32`] in SSE lanes: (n − 1, max(n − 2, 0), n − 2) per axis as f32 (a
    /// fourth lane of 0, 0, 1), when every n is at most 2²⁴ (so they are exact); else `None`.
    lanes: Option<[[f32; 4]; 3]>,
    /// Node strides (1, nx, nx·ny), 0 along axes of one node.
    strides: [usize; 3],
    /// The strides as f32 when there are at most 2²⁴ nodes (every node index, and every
    /// product and sum of [`Dataset::node_index`], is then an integer exact in f32), for
    /// [`Dataset::trilinear8`]'s cells' first nodes in lanes; else `None`.
    index_lanes: Option<[f32; 3]>,
    /// [`Dataset::lanes`]' three rows and [`Dataset::index_lanes`] (0s where that is `None`),
    /// each number splatted across eight aligned lanes: [`Dataset::trilinear8`] then reads a
    /// splat as one load, or as the memory operand of its first use, instead of a scalar load
    /// and a shuffle.
    splats: ([[wide::f32x4; 3]; 4], [[wide::f32x8; 3]; 4]),
}

impl PartialEq for Dataset {
    /// Datasets are equal when their contents are (caches aside).
    fn eq(&self, other: &Dataset) -> bool {
        self.dims == other.dims
            && self.a.to_bits() == other.a.to_bits()
            && self.b.to_bits() == other.b.to_bits()
            && self.raw == other.raw
    }
}

fn bad(code: ErrorCode, msg: impl Into<String>) -> Error {
    Error::new(code, msg)
}

impl Dataset {
    /// A dataset from raw voxels (x fastest, then y, then z) and normalisation a, b.
    pub fn new(dims: [usize; 3], raw: Voxels, a: f32, b: f32) -> Result<Dataset> {
        if dims.contains(&0) {
            return err(
                ErrorCode::BadValue,
                format!("dataset dimensions {dims:?} contain 0"),
            );
        }
        let n = dims
            .iter()
            .try_fold(1u64, |acc, &d| acc.checked_mul(d as u64));
        match n {
            Some(n) if n <= MAX_VOXELS && n as usize == raw.len() => {}
            _ => {
                return err(
                    ErrorCode::BadValue,
                    format!(
                        "dataset dimensions {dims:?} do not match {} voxels",
                        raw.len()
                    ),
                )
            }
        }
        if !a.is_finite() || !b.is_finite() || a == b {
            return err(
                ErrorCode::BadValue,
                format!("dataset normalisation a = {a}, b = {b}: both finite and different"),
            );
        }
        let strides = [
            usize::from(dims[0] > 1),
            if dims[1] > 1 { dims[0] } else { 0 },
            if dims[2] > 1 { dims[0] * dims[1] } else { 0 },
        ];
        Ok(Dataset {
            dims,
            a,
            b,
            bricks: Default::default(),
            cell_masks: Default::default(),
            last: dims.map(|n| (n - 1) as f64),
            half_last: dims.map(|n| 0.5 * (n - 1) as f64),
            lo_offset: 1 + dims[0] + dims[0] * dims[1],
            last32: dims.map(|n| (n - 1) as f32),
            top32: dims.map(|n| i32::try_from(n.saturating_sub(2)).unwrap_or(i32::MAX)),
            lanes: dims.iter().all(|&n| n <= 1 << 24).then(|| {
                let lane =
                    |f: &dyn Fn(usize) -> f32, w: f32| [f(dims[0]), f(dims[1]), f(dims[2]), w];
                [
                    lane(&|n| (n - 1) as f32, 0.0),
                    lane(&|n| n.saturating_sub(2) as f32, 0.0),
                    lane(&|n| n as f32 - 2.0, 1.0),
                ]
            }),
            strides,
            index_lanes: (raw.len() <= 1 << 24).then(|| strides.map(|s| s as f32)),
            splats: Default::default(),
            values: std::sync::OnceLock::new(),
            raw,
        }
        .with_splats())
    }

    /// The dataset with its [`Dataset::splats`] filled in.
    fn with_splats(mut self) -> Dataset {
        let rows = self.lanes.unwrap_or_default();
        let strides = self.index_lanes.unwrap_or_default();
        let rows = [
            [rows[0][0], rows[0][1], rows[0][2]],
            [rows[1][0], rows[1][1], rows[1][2]],
            [rows[2][0], rows[2][1], rows[2][2]],
            strides,
        ];
        self.splats = (
            rows.map(|r| r.map(wide::f32x4::splat)),
            rows.map(|r| r.map(wide::f32x8::splat)),
        );
        self
    }

    /// The node strides (1, nx, nx·ny; 0 along an axis of one node) and 0.5·(n − 1) per axis:
    /// what the packet march (`render::packet`) reads besides the values or voxels.
    pub(crate) fn packet_parts(&self) -> ([usize; 3], [f64; 3]) {
        (self.strides, self.half_last)
    }

    /// The brick ranges for `filter` (computed once per dataset and reach, then shared).
    pub fn bricks(&self, filter: Filter) -> &Bricks {
        let reach = match filter {
            Filter::Nearest | Filter::Trilinear => 1,
            Filter::Cubic { .. } => 2,
        };
        self.bricks[reach - 1].get_or_init(|| self.compute_bricks(reach))
    }

    /// The [`CellMask`] of bound `z`, built on first use (in parallel) and kept for the
    /// dataset's life: an object's zero test asks for one bound, so a dataset holds few.
    pub(crate) fn cells_above(&self, z: f32) -> std::sync::Arc<CellMask> {
        // A poisoned lock only means another thread panicked while building: the list itself
        // is always in a consistent state (entries are pushed whole).
        let mut masks = self
            .cell_masks
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some((_, m)) = masks.iter().find(|(b, _)| *b == z.to_bits()) {
            return m.clone();
        }
        let m = std::sync::Arc::new(self.compute_cell_mask(z));
        masks.push((z.to_bits(), m.clone()));
        m
    }

    fn compute_cell_mask(&self, z: f32) -> CellMask {
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
        };
        CellMask {
            bits,
            words32: Default::default(),
        }
    }

    /// The bits of [`CellMask`] for bound `lo` (a cell's bit is set where its largest node
    /// value is above `lo`), from the raw voxels `v`; `UP`: the normalisation increases
    /// (b > a). (A constant, so that each loop below compiles to plain minima or maxima.)
    fn raw_cell_bits<T, const UP: bool>(&self, v: &[T], lo: f32) -> Vec<u64>
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
        let mut bits = vec![0u64; v.len().div_ceil(64)];
        let Some(t) = threshold else {
            return bits;
        };
        let t = T::try_from(t).ok().expect("a raw voxel value");
        let [nx, ny, _] = self.dims;
        let [sx, sy, sz] = self.strides;
        let top = self.top32.map(|t| t as usize);
        // The extreme that decides a cell: the largest raw voxel where increasing, the
        // smallest where decreasing. `t` is moved into the test: captured by reference, it was
        // loaded again for every cell (the flags written might have been it, for all the
        // compiler knew), and the loop did not compile to lanes.
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
            .for_each_init(
                || (vec![t; nx], vec![0u8; CELL_MASK_RUN * 64]),
                |(m, flags), (c, out)| {
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
                },
            );
        bits
    }

    fn compute_bricks(&self, reach: usize) -> Bricks {
        // Over the raw voxels (a quarter or half of the node values' memory, compared a byte
        // or two at a time), then normalised: `normaliser` is monotone, so the normalised
        // raw extremes are the extremes of the node values, the same numbers.
        let (min, max) = match &self.raw {
            Voxels::U8(v) => self.normalised(self.raw_brick_extremes(v, reach)),
            Voxels::U16(v) => self.normalised(self.raw_brick_extremes(v, reach)),
        };
        Bricks {
            dims: self.brick_counts(),
            min,
            max,
        }
    }

    /// The node-value ranges of raw ranges `(lo, hi)`: each end normalised, the two swapped
    /// where the normalisation decreases (b < a).
    fn normalised<T: Copy + Into<f64> + Sync>(
        &self,
        (lo, hi): (Vec<T>, Vec<T>),
    ) -> (Vec<f32>, Vec<f32>) {
        use rayon::prelude::*;
        let norm = normaliser(self.a, self.b);
        let up = self.b > self.a;
        // (In parallel: a brick's normalisation is two divisions, and a scan has some 10⁵
        // bricks.)
        lo.par_iter()
            .zip(&hi)
            .with_min_len(1 << 12)
            .map(|(&l, &h)| {
                let (l, h) = (norm(l.into()), norm(h.into()));
                if up {
                    (l, h)
                } else {
                    (h, l)
                }
            })
            .unzip()
    }

    /// Bricks per axis.
    fn brick_counts(&self) -> [usize; 3] {
        self.dims
            .map(|n| (n.saturating_sub(1)).div_ceil(BRICK).max(1))
    }

    /// The smallest and largest raw voxel of each brick's padded span of nodes (see
    /// [`Bricks`]), x fastest, from the raw voxels `v`.
    fn raw_brick_extremes<T>(&self, v: &[T], reach: usize) -> (Vec<T>, Vec<T>)
    where
        T: Copy + PartialOrd + Default + Send + Sync,
    {
        let d = self.dims;
        let counts = self.brick_counts();
        // Along each axis, a point of brick b has its continuous index u in [4b, 4b + 4], or a
        // rounding error outside. Trilinear (reach 1) reads nodes floor(u) and floor(u) + 1, so
        // [4b − 1, 4b + 5] covers u from just below 4b to just above 4b + 4; nearest reads
        // round(u), inside that; the cubic filter (reach 2) reads floor(u) − 1 … floor(u) + 2,
        // so [4b − 2, 4b + 6].
        let pad = reach;
        let span = |b: usize, n: usize| {
            let lo = (b * BRICK).saturating_sub(pad);
            let hi = (b * BRICK + BRICK + pad).min(n - 1);
            (lo, hi)
        };
        // Per plane of bricks (in parallel), separably: the extremes over the plane's slab of
        // nodes per (x, y) column, then over each brick row's span of y, then along x. Only
        // small scratch rows: a first image pays a page fault per 4 KiB of fresh memory, which
        // whole intermediate grids made a third of the ranges' time.
        use rayon::prelude::*;
        let [nx, ny, _] = d;
        let plane = counts[0] * counts[1];
        let zero = T::default();
        let (mut min, mut max) = (vec![zero; plane * counts[2]], vec![zero; plane * counts[2]]);
        let layer = |z: usize| &v[z * nx * ny..(z + 1) * nx * ny];
        min.par_chunks_mut(plane)
            .zip(max.par_chunks_mut(plane))
            .enumerate()
            .for_each_init(
                || {
                    (
                        vec![zero; nx * ny],
                        vec![zero; nx * ny],
                        vec![zero; nx],
                        vec![zero; nx],
                    )
                },
                |(zmin, zmax, ymin, ymax), (k, (min, max))| {
                    let (z0, z1) = span(k, d[2]);
                    zmin.copy_from_slice(layer(z0));
                    zmax.copy_from_slice(layer(z0));
                    for z in z0 + 1..=z1 {
                        widen(zmin, zmax, layer(z), layer(z));
                    }
                    for bj in 0..counts[1] {
                        let (y0, y1) = span(bj, ny);
                        ymin.copy_from_slice(&zmin[y0 * nx..(y0 + 1) * nx]);
                        ymax.copy_from_slice(&zmax[y0 * nx..(y0 + 1) * nx]);
                        for y in y0 + 1..=y1 {
                            let r = y * nx..(y + 1) * nx;
                            widen(ymin, ymax, &zmin[r.clone()], &zmax[r]);
                        }
                        for bi in 0..counts[0] {
                            let (x0, x1) = span(bi, nx);
                            let (mut mn, mut mx) = (ymin[x0], ymax[x0]);
                            for (&lo, &hi) in ymin[x0..=x1].iter().zip(&ymax[x0..=x1]) {
                                if lo < mn {
                                    mn = lo;
                                }
                                if hi > mx {
                                    mx = hi;
                                }
                            }
                            min[bi + counts[0] * bj] = mn;
                            max[bi + counts[0] * bj] = mx;
                        }
                    }
                },
            );
        (min, max)
    }

    /// Dimensions (nx, ny, nz).
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Normalisation parameters (a, b).
    pub fn range(&self) -> (f32, f32) {
        (self.a, self.b)
    }

    /// The raw voxels.
    pub fn raw(&self) -> &Voxels {
        &self.raw
    }

    /// The normalised value of node (i, j, k): from the node values where they have been
    /// made, else from its voxel (the same number: the values are the voxels' normalisations),
    /// so that a read of a few nodes does not make all of them.
    #[inline]
    pub fn node(&self, i: usize, j: usize, k: usize) -> f32 {
        let at = self.node_index([i, j, k]);
        match self.values.get() {
            Some(v) => v[at],
            None => normaliser(self.a, self.b)(self.raw.get(at)),
        }
    }

    /// The position of node (i, j, k) in the node arrays (x fastest).
    #[inline(always)]
    pub(crate) fn node_index(&self, [i, j, k]: [usize; 3]) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// The normalised node values, x fastest: made on first use (in parallel), then kept.
    pub fn values(&self) -> &[f32] {
        self.values.get_or_init(|| self.compute_values())
    }

    /// Whether the node values have been made ([`Dataset::values`]): a render that reads only
    /// the voxels leaves them unmade.
    pub fn values_made(&self) -> bool {
        self.values.get().is_some()
    }

    /// The node values of the raw voxels ([`normaliser`]), on as many threads as rayon's pool
    /// has, but threads of their own: made from inside a render's parallel loop (a first
    /// read there), a rayon job that waits for its parts may run another part of the render
    /// meanwhile, which would ask for the values again, in the thread that is making them.
    fn compute_values(&self) -> Vec<f32> {
        let norm = normaliser(self.a, self.b);
        let mut values = vec![0f32; self.raw.len()];
        let threads = rayon::current_num_threads().clamp(1, 64);
        let chunk = self.raw.len().div_ceil(threads).max(1 << 16);
        let lut: [f32; 256] = std::array::from_fn(|x| norm(x as f64));
        std::thread::scope(|scope| {
            for (k, out) in values.chunks_mut(chunk).enumerate() {
                let from = k * chunk;
                let raw = &self.raw;
                let lut = &lut;
                scope.spawn(move || match raw {
                    Voxels::U8(v) => {
                        for (o, &x) in out.iter_mut().zip(&v[from..]) {
                            *o = lut[x as usize];
                        }
                    }
                    Voxels::U16(v) => {
                        for (o, &x) in out.iter_mut().zip(&v[from..]) {
                            *o = norm(x as f64);
                        }
                    }
                });
            }
        });
        values
    }

    /// The raw value of node (i, j, k) before normalisation.
    pub fn raw_node(&self, i: usize, j: usize, k: usize) -> f64 {
        self.raw.get(self.node_index([i, j, k]))
    }

    /// Parses a `.vlb` file held in memory.
    pub fn from_vlb_bytes(bytes: &[u8]) -> Result<Dataset> {
        check_magic(bytes)?;
        let header = parse_header(bytes.get(..HEADER_LEN).ok_or_else(|| {
            bad(
                ErrorCode::BadSize,
                format!("truncated header: {} of {HEADER_LEN} bytes", bytes.len()),
            )
        })?)?;
        header.check_len(bytes.len() as u64)?;
        Dataset::from_body(&header, bytes[HEADER_LEN..].to_vec())
    }

    fn from_body(h: &Header, body: Vec<u8>) -> Result<Dataset> {
        // 8-bit voxels keep the buffer they were read into: a copy of a scan's bytes costs a
        // page fault per 4 KiB of fresh memory, a measurable part of the first image.
        let raw = if h.bytes == 1 {
            Voxels::U8(body)
        } else {
            Voxels::U16(
                body.chunks_exact(2)
                    .map(|c| u16::from_le_bytes([c[0], c[1]]))
                    .collect(),
            )
        };
        Dataset::new(h.dims, raw, h.a, h.b)
    }

    /// Reads a `.vlb` file: the header is checked against the file's length before the voxels
    /// are allocated, and nothing is read past the end.
    pub fn load(path: &Path) -> Result<Dataset> {
        let io =
            |e: std::io::Error| Error::new(ErrorCode::IoError, format!("{}: {e}", path.display()));
        let mut f = std::fs::File::open(path).map_err(io)?;
        let meta = f.metadata().map_err(io)?;
        if meta.is_dir() {
            return Err(Error::new(
                ErrorCode::IoError,
                format!("{}: is a directory", path.display()),
            ));
        }
        let len = meta.len();
        let named = |e: Error| bad(e.code, format!("{}: {}", path.display(), e.message));
        let mut head = [0u8; HEADER_LEN];
        let got = (len as usize).min(HEADER_LEN);
        f.read_exact(&mut head[..got]).map_err(io)?;
        // A file that is not a .vlb at all says so, however short it is.
        check_magic(&head[..got]).map_err(named)?;
        if len < HEADER_LEN as u64 {
            return Err(bad(
                ErrorCode::BadSize,
                format!("{}: truncated header ({len} bytes)", path.display()),
            ));
        }
        let h = parse_header(&head).map_err(named)?;
        h.check_len(len).map_err(named)?;
        let mut body = vec![0u8; (len - HEADER_LEN as u64) as usize];
        f.read_exact(&mut body).map_err(io)?;
        Dataset::from_body(&h, body)
    }

    /// The `.vlb` encoding of the dataset.
    pub fn to_vlb_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER_LEN + self.raw.len() * self.raw.width() as usize);
        out.extend_from_slice(MAGIC);
        for d in self.dims {
            out.extend_from_slice(&(d as u32).to_le_bytes());
        }
        out.extend_from_slice(&self.raw.width().to_le_bytes());
        out.extend_from_slice(&self.a.to_le_bytes());
        out.extend_from_slice(&self.b.to_le_bytes());
        match &self.raw {
            Voxels::U8(v) => out.extend_from_slice(v),
            Voxels::U16(v) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
        }
        out
    }

    /// Writes the dataset as a `.vlb` file, atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        crate::output::write_atomic(path, &self.to_vlb_bytes())
    }

    /// The continuous index of object coordinate `p` along axis `axis`, clamped to the grid
    /// (NaN → 0).
    #[inline]
    fn index(&self, p: f32, axis: usize) -> f64 {
        let last = self.last[axis];
        let u = p as f64 * last;
        // max/min in this order map NaN to 0.
        u.max(0.0).min(last)
    }

    /// The interpolated normalised value at object coordinates `p`.
    #[inline]
    pub fn sample(&self, p: [f32; 3], filter: Filter) -> f32 {
        if filter == Filter::Trilinear {
            return self.trilinear(p);
        }
        self.sample_generic(p, filter)
    }

    #[inline(never)]
    fn sample_generic(&self, p: [f32; 3], filter: Filter) -> f32 {
        let u = [
            self.index(p[0], 0),
            self.index(p[1], 1),
            self.index(p[2], 2),
        ];
        let values = self.values();
        let node = |i, j, k| values[self.node_index([i, j, k])] as f64;
        let v = match filter {
            Filter::Cubic { b, c } => self
                .cubic_interior(u, b as f64, c as f64)
                .unwrap_or_else(|| self.filter(u, filter, node)),
            _ => self.filter(u, filter, node),
        };
        (v as f32).clamp(0.0, 1.0)
    }

    /// The BC-spline filter of [`Dataset::filter`] where all 4×4×4 taps lie inside the grid,
    /// reading each x-row of four taps with one bounds check: the same weights, terms and order
    /// of summation, so the same value bit for bit. `None` near the faces.
    #[inline]
    fn cubic_interior(&self, u: [f64; 3], b: f64, c: f64) -> Option<f64> {
        let (i0, w) = self.cubic_taps(u, b, c, None)?;
        self.cubic_sum(i0, w, |o| {
            let r: [f32; 4] = self.values().get(o..o + 4)?.try_into().ok()?;
            Some(r.map(f64::from))
        })
    }

    /// The BC-spline filter of the node derivatives along `axis` where every tap lies inside
    /// the grid and, along `axis`, away from its faces (so each derivative is the central
    /// difference of [`Dataset::node_derivative`]): the same terms in the same order as the
    /// generic filter, so the same value bit for bit, with one bounds check per row. `None`
    /// elsewhere.
    #[inline]
    fn cubic_derivative_interior(&self, u: [f64; 3], b: f64, c: f64, axis: usize) -> Option<f64> {
        let (i0, w) = self.cubic_taps(u, b, c, Some(axis))?;
        let [nx, ny, _] = self.dims;
        let stride = [1, nx, nx * ny][axis];
        let row = |o: usize| -> Option<[f32; 4]> { self.values().get(o..o + 4)?.try_into().ok() };
        self.cubic_sum(i0, w, |o| {
            // The taps' neighbours below and above along `axis`.
            let (lo, hi) = if axis == 0 {
                let r: [f32; 6] = self.values().get(o - 1..o + 5)?.try_into().ok()?;
                ([r[0], r[1], r[2], r[3]], [r[2], r[3], r[4], r[5]])
            } else {
                (row(o - stride)?, row(o + stride)?)
            };
            Some(std::array::from_fn(|k| (hi[k] as f64 - lo[k] as f64) / 2.0))
        })
    }

    /// The first tap and the four weights per axis of the BC-spline filter at continuous index
    /// `u`, as [`Dataset::filter`] computes them; `None` unless every tap is a node and, along
    /// `derivative_axis`, so are the taps' neighbours.
    #[inline]
    fn cubic_taps(
        &self,
        u: [f64; 3],
        b: f64,
        c: f64,
        derivative_axis: Option<usize>,
    ) -> Option<([usize; 3], [[f64; 4]; 3])> {
        let mut i0 = [0usize; 3];
        let mut w = [[0.0f64; 4]; 3];
        for a in 0..3 {
            let f = u[a].floor();
            // Taps f − 1 … f + 2; along the derivative's axis their neighbours f − 2 … f + 3.
            let margin = if derivative_axis == Some(a) { 1.0 } else { 0.0 };
            if f < 1.0 + margin || f + 2.0 + margin > (self.dims[a] - 1) as f64 {
                return None;
            }
            i0[a] = f as usize - 1;
            let t = u[a] - f;
            for (m, wm) in w[a].iter_mut().enumerate() {
                *wm = bc_kernel(t - (m as f64 - 1.0), b, c);
            }
        }
        Some((i0, w))
    }

    /// Σ_z Σ_y w_z·w_y·Σ_x w_x·v, in the generic filter's order (zero y and z weights skipped),
    /// where `row(o)` gives the four values of the x-row starting at node offset `o`.
    #[inline]
    fn cubic_sum(
        &self,
        i0: [usize; 3],
        [wx, wy, wz]: [[f64; 4]; 3],
        row: impl Fn(usize) -> Option<[f64; 4]>,
    ) -> Option<f64> {
        let mut sum = 0.0;
        for (kz, &wzk) in wz.iter().enumerate() {
            if wzk == 0.0 {
                continue;
            }
            for (ky, &wyk) in wy.iter().enumerate() {
                if wyk == 0.0 {
                    continue;
                }
                let r = row(self.node_index([i0[0], i0[1] + ky, i0[2] + kz]))?;
                let mut acc = 0.0;
                for (&wxk, v) in wx.iter().zip(r) {
                    acc += wxk * v;
                }
                sum += wzk * wyk * acc;
            }
        }
        Some(sum)
    }

    /// The gradient of the normalised field with respect to object coordinates at `p`, from
    /// node gradients interpolated with `filter`.
    #[inline]
    pub fn gradient(&self, p: [f32; 3], filter: Filter) -> [f64; 3] {
        self.gradient_cached(p, filter, &mut CellGradients::default())
    }

    /// [`Dataset::gradient`], reusing the node differences of `cache` when `p` lies in the
    /// cell they were read for (consecutive samples of a ray often do), and leaving those of
    /// `p`'s cell there. The same value, bit for bit.
    #[inline]
    pub(crate) fn gradient_cached(
        &self,
        p: [f32; 3],
        filter: Filter,
        cache: &mut CellGradients,
    ) -> [f64; 3] {
        if filter == Filter::Trilinear {
            if let Some(g) = self.trilinear_gradient_interior(p, cache) {
                return g;
            }
        }
        self.gradient_generic(p, filter)
    }

    #[inline(never)]
    fn gradient_generic(&self, p: [f32; 3], filter: Filter) -> [f64; 3] {
        let u = [
            self.index(p[0], 0),
            self.index(p[1], 1),
            self.index(p[2], 2),
        ];
        let mut g = [0.0; 3];
        for (axis, g) in g.iter_mut().enumerate() {
            let n = self.dims[axis];
            if n == 1 {
                continue;
            }
            let interior = match filter {
                Filter::Cubic { b, c } => {
                    self.cubic_derivative_interior(u, b as f64, c as f64, axis)
                }
                _ => None,
            };
            let d = interior.unwrap_or_else(|| {
                self.filter(u, filter, |i, j, k| self.node_derivative(i, j, k, axis))
            });
            *g = d * (n - 1) as f64;
        }
        g
    }

    /// The trilinear cell of object point `p` in f32 index arithmetic: first node and weight of
    /// the second per axis (for an axis of one node: (0, 0)).
    #[inline]
    fn cell32(&self, p: [f32; 3]) -> ([usize; 3], [f32; 3]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(lanes) = &self.lanes {
            return Self::cell_in_lanes(p, lanes).0;
        }
        self.cell32_scalar(p)
    }

    /// [`Dataset::cell32`] where the cell's 4×4×4 neighbourhood lies inside the grid (its first
    /// node at least 1 and its last at most n − 1 along every axis: 1 ≤ c ≤ n − 3); else
    /// `None`.
    #[inline]
    fn interior_cell32(&self, p: [f32; 3]) -> Option<([usize; 3], [f32; 3])> {
        #[cfg(target_arch = "x86_64")]
        if let Some(lanes) = &self.lanes {
            let (cell, interior) = Self::cell_in_lanes(p, lanes);
            return interior.then_some(cell);
        }
        let [nx, ny, nz] = self.dims;
        let ([x0, y0, z0], f) = self.cell32_scalar(p);
        let inside = |c: usize, n: usize| c >= 1 && c + 3 <= n;
        (inside(x0, nx) && inside(y0, ny) && inside(z0, nz)).then_some(([x0, y0, z0], f))
    }

    /// The three axes in SSE lanes: the same operations as [`Dataset::cell32_scalar`], so the
    /// same numbers (a zero weight may come out +0 where the scalar path gives −0). max(u, 0)
    /// (`maxps`) gives 0 for NaN as `f32::max` does; u ≤ n − 1 ≤ 2²⁴ converts exactly; and
    /// truncating min(u, n − 2) is min(truncation, n − 2), n − 2 being an integer. Also whether
    /// the cell is interior: its first node c = trunc(cu), cu = min(u, n − 2) ≥ 0, has
    /// 1 ≤ c ≤ n − 3 exactly when 1 ≤ cu < n − 2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn cell_in_lanes(
        p: [f32; 3],
        [last, top, inner]: &[[f32; 4]; 3],
    ) -> (([usize; 3], [f32; 3]), bool) {
        use wide::{f32x4, i32x4};
        let last = f32x4::new(*last);
        let u = (f32x4::new([p[0], p[1], p[2], 0.0]) * last)
            .fast_max(f32x4::ZERO)
            .fast_min(last);
        let cu = u.fast_min(f32x4::new(*top));
        let interior = (cu.simd_ge(f32x4::new([1.0, 1.0, 1.0, 0.0]))
            & cu.simd_lt(f32x4::new(*inner)))
        .to_bitmask()
            == 0b1111;
        let c: i32x4 = cu.fast_trunc_int();
        let f = (u - c.round_float()).to_array();
        // c ≥ 0 (cu ≥ 0), so through u32 (no sign extension) it is the same index.
        let c = c.to_array().map(|c| c as u32 as usize);
        (([c[0], c[1], c[2]], [f[0], f[1], f[2]]), interior)
    }

    /// [`Dataset::cell32`] axis by axis.
    #[inline]
    fn cell32_scalar(&self, p: [f32; 3]) -> ([usize; 3], [f32; 3]) {
        let mut i = [0usize; 3];
        let mut f = [0f32; 3];
        for axis in 0..3 {
            let last = self.last32[axis];
            // max/min in this order map NaN to 0; for n = 1, last = 0 and the cell is (0, 0).
            // u ≥ 0, so its truncation is its floor and at least 0.
            let u = (p[axis] * last).max(0.0).min(last);
            let c = (u as i32).min(self.top32[axis]);
            i[axis] = c as usize;
            f[axis] = u - c as f32;
        }
        (i, f)
    }

    /// Trilinear interpolation, specialised for speed: f32 index arithmetic (its rounding,
    /// below 2⁻¹⁶ of a voxel for grids under 512 nodes a side, is far below anything visible),
    /// i32 conversions, and the cell's nodes read as four x-pairs (one bounds check each).
    #[inline]
    pub(crate) fn trilinear(&self, p: [f32; 3]) -> f32 {
        self.trilinear_in(p, None)
    }

    /// [`Dataset::trilinear`] at the first `count` of eight points given by axis (`p[axis]`
    /// holds the eight coordinates along it), or 0 where `mask` knows the value is at most its
    /// bound (the eight nodes are not read then; a mask's bound is never below 0, see
    /// [`Dataset::cells_above`]). The cells are found in lanes across the points, with the
    /// operations of [`Dataset::cell_in_lanes`] lane for lane, so the same values. The other
    /// values are 0. (Written into `out`, all eight values, rather than returned: the batched
    /// march keeps one array for every run, and a returned array was copied from the return
    /// slot to the caller's, one f32 at a time, on every run.) `cells` receives the points'
    /// cells, for their gradients (see [`Cells8`]).
    #[inline]
    pub(crate) fn trilinear8(
        &self,
        p: &[[f32; 8]; 3],
        count: usize,
        mask: Option<&CellMask>,
        out: &mut [f32; 8],
        cells: &mut Cells8,
    ) {
        *out = [0f32; 8];
        cells.count = 0;
        let count = count.min(8);
        #[cfg(target_arch = "x86_64")]
        if self.lanes.is_some() {
            use wide::{f32x4, f32x8, i32x4, i32x8};
            // The cells of the points along one axis, in lanes of `$F` (`$I` for the indices).
            macro_rules! cells {
                ($F:ty, $I:ty, $N:literal, $S:tt) => {{
                    let mut c = [<$I>::default(); 3];
                    let mut cf = [<$F>::ZERO; 3];
                    let (f, cus) = (&mut cells.f, &mut cells.cu);
                    for axis in 0..3 {
                        let l = self.splats.$S[0][axis];
                        let lanes: [f32; $N] = std::array::from_fn(|i| p[axis][i]);
                        let u = (<$F>::new(lanes) * l).fast_max(<$F>::ZERO).fast_min(l);
                        let cu = u.fast_min(self.splats.$S[1][axis]);
                        cus[axis][..$N].copy_from_slice(&cu.to_array());
                        c[axis] = cu.fast_trunc_int();
                        cf[axis] = c[axis].round_float();
                        f[axis][..$N].copy_from_slice(&(u - cf[axis]).to_array());
                    }
                    if self.index_lanes.is_some() {
                        // The first nodes' indices in lanes: integers below 2²⁴, so exact.
                        let s = |axis: usize| self.splats.$S[3][axis];
                        let at = cf[0] * s(0) + cf[1] * s(1) + cf[2] * s(2);
                        let at: $I = at.fast_trunc_int();
                        let at = at.to_array().map(|a| a as u32);
                        cells.at[..$N].copy_from_slice(&at);
                        cells.count = count as u32;
                        // Below 2²⁴ as well, so the conversions are exact.
                        let rows = (
                            self.strides[1] as u32 as usize,
                            self.strides[2] as u32 as usize,
                        );
                        self.values_in_cells(at, |a| a as usize, rows, &cells.f, count, mask, out);
                    } else {
                        let [cx, cy, cz] = c.map(|c| c.to_array());
                        let at: [usize; $N] = std::array::from_fn(|i| {
                            self.node_index([cx[i], cy[i], cz[i]].map(|c| c as usize))
                        });
                        let rows = (self.strides[1], self.strides[2]);
                        self.values_in_cells(at, |a| a, rows, &cells.f, count, mask, out);
                    }
                }};
            }
            // A short run (the usual one at large sample distances) needs only half the lanes.
            if count <= 4 {
                cells!(f32x4, i32x4, 4, 0);
            } else {
                cells!(f32x8, i32x8, 8, 1);
            }
            return;
        }
        for (i, out) in out.iter_mut().enumerate().take(count) {
            *out = self.trilinear_in([p[0][i], p[1][i], p[2][i]], mask);
        }
    }

    /// Bit `i`: point `i` of the last [`Dataset::trilinear8`] that filled `cells` (of the
    /// first [`Cells8::count`]) lies in an interior cell (its 4×4×4 neighbourhood inside the
    /// grid, see [`Dataset::interior_cell32`]): 1 ≤ cu < n − 2 along every axis (see
    /// [`Dataset::cell_in_lanes`]). Taken by the batched march only for runs with a sample to
    /// shade, not for every run as `trilinear8` did. The lower bound as one test of the three
    /// axes' least (`interior8_is_the_tests_axis_by_axis`).
    #[inline]
    pub(crate) fn interior8(&self, cells: &Cells8) -> u32 {
        #[cfg(target_arch = "x86_64")]
        if self.lanes.is_some() {
            use wide::f32x8;
            let cu = cells.cu.map(f32x8::new);
            // At least 1 along every axis where the least of the three is: `cu` is never NaN
            // (`max(u, 0)` by `maxps` maps NaN to 0), so the minima are the numbers' least.
            let low = cu[0].fast_min(cu[1]).fast_min(cu[2]).simd_ge(f32x8::ONE);
            let high = |axis: usize| cu[axis].simd_lt(self.splats.1[2][axis]);
            let count = cells.count.min(8);
            return (low & high(0) & high(1) & high(2)).to_bitmask() & ((1 << count) - 1);
        }
        0
    }

    /// The values at the first `count` of `N` points whose cells' first nodes are `at` (as
    /// `index` converts them to node indices) and whose weights `f` are given by axis (see
    /// [`Dataset::trilinear8`]), written into `out`, which holds 0s: a value the mask knows to
    /// be 0 is left as it is. (The mask tested here rather than in the cell's interpolation, the
    /// rejected cells skip the 0's store and the loads of their weights, which the compiler had
    /// hoisted above the test.)
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn values_in_cells<T: Copy, const N: usize>(
        &self,
        at: [T; N],
        index: impl Fn(T) -> usize,
        rows: (usize, usize),
        f: &[[f32; 8]; 3],
        count: usize,
        mask: Option<&CellMask>,
        out: &mut [f32; 8],
    ) {
        // The mask's bits as a slice, no mask as no bits (which let every cell through): the
        // cells then test neither the option nor reload the slice from the mask.
        let bits: &[u64] = mask.map_or(&[], |m| &m.bits);
        // The x-stride's test outside the cells: the compiler merges the two loops again, but
        // tests a register in each cell instead of reloading the stride from the dataset.
        // (The cells by index: iterating over `at` by value copied it and set up its
        // iterator on every run.)
        let mut cells = |unit_x: bool| {
            for i in 0..count.min(N) {
                let at = index(at[i]);
                if !reaches(bits, at) {
                    continue;
                }
                let f = [f[0][i], f[1][i], f[2][i]];
                if let Some(v) = self.trilinear_cell(at, rows, f, unit_x) {
                    out[i] = v;
                }
            }
        };
        if self.strides[0] == 1 {
            cells(true);
        } else {
            cells(false);
        }
    }

    #[inline(always)]
    fn trilinear_in(&self, p: [f32; 3], mask: Option<&CellMask>) -> f32 {
        let (cell, f) = self.cell32(p);
        let base = self.node_index(cell);
        if mask.is_some_and(|m| !m.may_reach(base)) {
            return 0.0;
        }
        let rows = (self.strides[1], self.strides[2]);
        self.trilinear_cell(base, rows, f, self.strides[0] == 1)
            .unwrap_or(0.0)
    }

    /// The trilinear value in the cell whose first node has index `base`, at weights `f` of
    /// its second nodes (the callers test the cell mask first). `unit_x`: whether the x-stride
    /// is 1 (else 0, an axis of one node), given by the caller so that a loop over cells tests
    /// it once. `None` where the cell's nodes are not all in the values, which never happens
    /// (the cell lies inside the grid): the caller keeps its 0 then, so no 0 is made in a
    /// register for that path on every cell.
    #[inline(always)]
    fn trilinear_cell(
        &self,
        base: usize,
        (sy, sz): (usize, usize),
        f: [f32; 3],
        unit_x: bool,
    ) -> Option<f32> {
        let v = self.values();
        if unit_x {
            // Four rows of two nodes along x, in the span [base, base + sz + sy + 2): the
            // first and last two nodes of its first sy + 2 and of its last sy + 2. Where base
            // and the strides are below 2³² (given as such) no sum overflows, and the span's
            // bounds check is the only one the compiler keeps.
            let rows = v.get(base..base + sz + sy + 2).and_then(|w| {
                let (lower, upper) = (w.get(..sy + 2)?, w.get(sz..)?);
                Some([
                    lower.first_chunk::<2>()?,
                    lower.last_chunk::<2>()?,
                    upper.first_chunk::<2>()?,
                    upper.last_chunk::<2>()?,
                ])
            });
            // (Always there: the cell lies inside the grid. The rows by reference: copied
            // out as arrays, they were loaded through integer registers.)
            let [r00, r10, r01, r11] = rows?;
            let z0 = [r00[0], r00[1], r01[0], r01[1]];
            Some(trilinear_rows(z0, [r10[0], r10[1], r11[0], r11[1]], f))
        } else {
            // (sx = 0: an axis of one node.)
            let w = v.get(base..=base + sy + sz)?; // (always there, as above)
            let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
            let [fx, fy, fz] = f;
            let (c00, c10, c01, c11) = (
                lerp(w[0], w[0], fx),
                lerp(w[sy], w[sy], fx),
                lerp(w[sz], w[sz], fx),
                lerp(w[sz + sy], w[sz + sy], fx),
            );
            Some(lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz).clamp(0.0, 1.0))
        }
    }

    /// The trilinear gradient where all the nodes it reads are interior (central differences
    /// everywhere): the same value as the generic path, with the 4×4×4 neighbourhood of the cell
    /// read as its twelve x-rows that are needed (under the bounds checks of the two furthest).
    #[inline]
    fn trilinear_gradient_interior(
        &self,
        p: [f32; 3],
        cache: &mut CellGradients,
    ) -> Option<[f64; 3]> {
        let (cell, f) = self.interior_cell32(p)?;
        self.trilinear_gradient_at::<true>(self.neighbourhood_lo(cell), f, cache)
    }

    /// [`Dataset::gradient_cached`] with the trilinear filter at a point of interior cell
    /// `cells` holds as its lane `i` (bit `i` of [`Dataset::interior8`] set): the batched march
    /// has found that cell for the point's value, so the gradient need not find it again. The
    /// same value, bit for bit (the same cell and weights, see [`Dataset::trilinear8`]), but
    /// for the sign of a zero component (see [`Dataset::trilinear_gradient_at`]'s
    /// `SIGNED_ZEROS`): for the lighting lanes, where that sign cannot change a colour. The
    /// point is lane `i` of `ps` (by axis, as `trilinear8` takes them), read only where the
    /// cell's rows are not all inside the values (never, for an interior cell): so the caller
    /// need not gather it.
    #[inline]
    pub(crate) fn trilinear_gradient_in(
        &self,
        ps: &[[f32; 8]; 3],
        cells: &Cells8,
        i: usize,
        cache: &mut CellGradients,
    ) -> [f64; 3] {
        let f = [cells.f[0][i], cells.f[1][i], cells.f[2][i]];
        (cells.at[i] as usize)
            .checked_sub(self.lo_offset)
            .and_then(|lo| self.trilinear_gradient_at::<false>(lo, f, cache))
            .unwrap_or_else(|| {
                self.gradient_generic([ps[0][i], ps[1][i], ps[2][i]], Filter::Trilinear)
            })
    }

    /// [`Dataset::trilinear_gradient_interior`] in the interior cell whose neighbourhood starts
    /// at node `lo` (see [`Dataset::neighbourhood_lo`]), at weights `f` of its second nodes.
    /// Without `SIGNED_ZEROS`, a component whose sum of products is −0 may come out −0
    /// instead of +0 (nothing else differs; see below).
    #[inline(always)]
    fn trilinear_gradient_at<const SIGNED_ZEROS: bool>(
        &self,
        lo: usize,
        [fx, fy, fz]: [f32; 3],
        cache: &mut CellGradients,
    ) -> Option<[f64; 3]> {
        // Row (j, k) holds nodes x0 − 1 … x0 + 2 at y0 − 1 + j, z0 − 1 + k; the corner rows of
        // the neighbourhood are never read.
        if cache.lo != lo {
            // The node indices and strides are below 2³² (a dataset has at most 2³² nodes, and
            // a stride of more than one node spans at most half of them): given as such, no
            // sum below overflows, and the compiler derives every row's bounds check from one
            // test, that the neighbourhood's last row (3, 3), not itself read, lies inside the
            // values (the rows grow with j and k). An interior cell's does: its neighbourhood
            // lies inside the grid.
            debug_assert!(self.strides.iter().all(|&s| s <= u32::MAX as usize));
            let (sy, sz) = (
                self.strides[1] as u32 as usize,
                self.strides[2] as u32 as usize,
            );
            let lo = u32::try_from(lo).ok()? as usize;
            let v = self.values();
            if lo + 3 * sy + 3 * sz + 4 > v.len() {
                return None;
            }
            let row = |j: usize, k: usize| -> Option<[f32; 4]> {
                let o = lo + j * sy + k * sz;
                v.get(o..o + 4)?.try_into().ok()
            };
            let (r10, r20) = (row(1, 0)?, row(2, 0)?);
            let (r01, r11, r21, r31) = (row(0, 1)?, row(1, 1)?, row(2, 1)?, row(3, 1)?);
            let (r02, r12, r22, r32) = (row(0, 2)?, row(1, 2)?, row(2, 2)?, row(3, 2)?);
            let (r13, r23) = (row(1, 3)?, row(2, 3)?);
            // Per corner row (j, k) of the cell (j, k in {1, 2}, y fastest): its row, the rows
            // below and above it in y, and the rows below and above it in z. Each gives two
            // corners (x nodes 1 and 2 of the row) their central differences (per grid
            // step) along x, y and z.
            let corners = [
                (r11, r01, r21, r10, r12),
                (r21, r11, r31, r20, r22),
                (r12, r02, r22, r11, r13),
                (r22, r12, r32, r21, r23),
            ];
            // Row by row in lanes: the row differences in y and z (lanes 1 and 2: the row's
            // two corners, x nodes 1 and 2), and x nodes 2, 3 minus nodes 0, 1 (lanes 0 and
            // 1); each corner's three differences then gathered into one register, in the
            // cache's order (y, z, x) (lane 3 is not read).
            use wide::f32x4;
            for (c, (r, ym, yp, zm, zp)) in corners.into_iter().enumerate() {
                let dy = (f32x4::new(yp) - f32x4::new(ym)).to_array();
                let dz = (f32x4::new(zp) - f32x4::new(zm)).to_array();
                let dx = (f32x4::new([r[2], r[3], r[2], r[3]]) - f32x4::new(r)).to_array();
                cache.diffs[2 * c] = [dy[1], dz[1], dx[0], dx[0]];
                cache.diffs[2 * c + 1] = [dy[2], dz[2], dx[1], dx[1]];
            }
            cache.lo = lo;
        }
        // Trilinear weights of the cell's corners, in the order x fastest: the products
        // (wx·wy)·wz, four at a time in lanes.
        let (gx, gy, gz) = (1.0 - fx, 1.0 - fy, 1.0 - fz);
        let xy = wide::f32x4::new([gx, fx, gx, fx]) * wide::f32x4::new([gy, gy, fy, fy]);
        let near = (xy * wide::f32x4::splat(gz)).to_array();
        let far = (xy * wide::f32x4::splat(fz)).to_array();
        let weights = [
            near[0], near[1], near[2], near[3], far[0], far[1], far[2], far[3],
        ];
        // The three axes in the lanes of one register, each summed corner by corner in order
        // (as a scalar loop would).
        // The products summed from the first, not from a 0: ((0 + p0) + p1) + … differs from
        // (p0 + p1) + … only where a partial sum is −0 (which 0 + makes +0), and from then on
        // only there; so the first is the second plus +0 (which turns −0 into +0 and leaves
        // every other number as it is). Without `SIGNED_ZEROS` that last sum is left out.
        let p = |c: usize| wide::f32x4::splat(weights[c]) * wide::f32x4::new(cache.diffs[c]);
        let g = p(0) + p(1) + p(2) + p(3) + p(4) + p(5) + p(6) + p(7);
        let g = if SIGNED_ZEROS {
            g + wide::f32x4::ZERO
        } else {
            g
        };
        // 0.5·g·(n − 1) in f64, as g·(0.5·(n − 1)): halving is exact in both orders (g is
        // an f32, far from f64's subnormals), so both are the one rounding of the same product.
        // (The lanes hold y, z, x.)
        let g = g.to_array();
        Some([
            g[2] as f64 * self.half_last[0],
            g[0] as f64 * self.half_last[1],
            g[1] as f64 * self.half_last[2],
        ])
    }

    /// The first node of the 4×4×4 neighbourhood of an interior cell (first node at least 1
    /// along every axis; see [`Dataset::interior_cell32`]): the key of [`CellGradients`].
    #[inline]
    fn neighbourhood_lo(&self, cell: [usize; 3]) -> usize {
        // node_index(cell − (1, 1, 1)), without the three subtractions: the cell's first node
        // is at least 1 along every axis, so no step wraps.
        self.node_index(cell) - self.lo_offset
    }

    /// The derivative along `axis` at a node, per grid step: central inside, one-sided at faces.
    fn node_derivative(&self, i: usize, j: usize, k: usize, axis: usize) -> f64 {
        let n = self.dims[axis];
        let mut lo = [i, j, k];
        let mut hi = [i, j, k];
        let c = lo[axis];
        lo[axis] = c.saturating_sub(1);
        hi[axis] = (c + 1).min(n - 1);
        let span = (hi[axis] - lo[axis]) as f64;
        (self.node(hi[0], hi[1], hi[2]) as f64 - self.node(lo[0], lo[1], lo[2]) as f64) / span
    }

    /// Applies `filter` at continuous index `u` to the node function `f`.
    #[inline]
    fn filter(&self, u: [f64; 3], filter: Filter, f: impl Fn(usize, usize, usize) -> f64) -> f64 {
        let d = self.dims;
        match filter {
            Filter::Nearest => {
                let r = |x: f64, n: usize| (x.round() as usize).min(n - 1);
                f(r(u[0], d[0]), r(u[1], d[1]), r(u[2], d[2]))
            }
            Filter::Trilinear => {
                let cell = |x: f64, n: usize| {
                    let i = (x.floor() as usize).min(n.saturating_sub(2));
                    (i, (i + 1).min(n - 1), x - i as f64)
                };
                let (x0, x1, fx) = cell(u[0], d[0]);
                let (y0, y1, fy) = cell(u[1], d[1]);
                let (z0, z1, fz) = cell(u[2], d[2]);
                let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
                let plane = |z: usize| {
                    lerp(
                        lerp(f(x0, y0, z), f(x1, y0, z), fx),
                        lerp(f(x0, y1, z), f(x1, y1, z), fx),
                        fy,
                    )
                };
                lerp(plane(z0), plane(z1), fz)
            }
            Filter::Cubic { b, c } => {
                let (b, c) = (b as f64, c as f64);
                let taps = |x: f64, n: usize| {
                    let i0 = x.floor() as i64;
                    let t = x - i0 as f64;
                    let mut idx = [0usize; 4];
                    let mut w = [0.0f64; 4];
                    for m in 0..4 {
                        let i = i0 - 1 + m as i64;
                        idx[m] = i.clamp(0, n as i64 - 1) as usize;
                        w[m] = bc_kernel(t - (m as f64 - 1.0), b, c);
                    }
                    (idx, w)
                };
                let (ix, wx) = taps(u[0], d[0]);
                let (iy, wy) = taps(u[1], d[1]);
                let (iz, wz) = taps(u[2], d[2]);
                let mut sum = 0.0;
                for kz in 0..4 {
                    if wz[kz] == 0.0 {
                        continue;
                    }
                    for ky in 0..4 {
                        if wy[ky] == 0.0 {
                            continue;
                        }
                        let mut row = 0.0;
                        for kx in 0..4 {
                            row += wx[kx] * f(ix[kx], iy[ky], iz[kz]);
                        }
                        sum += wz[kz] * wy[ky] * row;
                    }
                }
                sum
            }
        }
    }
}

struct Header {
    dims: [usize; 3],
    bytes: u32,
    a: f32,
    b: f32,
}

impl Header {
    /// Checks that the file length is exactly header + voxels.
    fn check_len(&self, len: u64) -> Result<()> {
        let voxels = voxel_count(self.dims).unwrap_or(u64::MAX);
        let need = voxels
            .checked_mul(self.bytes as u64)
            .and_then(|v| v.checked_add(HEADER_LEN as u64));
        match need {
            Some(n) if n == len => Ok(()),
            Some(n) if n > len => Err(bad(
                ErrorCode::BadSize,
                format!("file holds {len} bytes but its header claims {n} (truncated)"),
            )),
            Some(n) => Err(bad(
                ErrorCode::BadSize,
                format!("file holds {len} bytes but its header claims {n} (trailing data)"),
            )),
            None => Err(bad(
                ErrorCode::BadDimensions,
                "header claims an impossibly large volume",
            )),
        }
    }
}

/// nx·ny·nz, or `None` when the product overflows.
fn voxel_count(dims: [usize; 3]) -> Option<u64> {
    dims.iter()
        .try_fold(1u64, |acc, &d| acc.checked_mul(d as u64))
}

/// Checks the magic number as far as `bytes` reach (a file shorter than the magic is judged on
/// what it has; the length check reports it).
fn check_magic(bytes: &[u8]) -> Result<()> {
    let n = bytes.len().min(MAGIC.len());
    if bytes[..n] != MAGIC[..n] {
        return Err(bad(
            ErrorCode::BadMagic,
            format!("bad magic {:?} (expected \"VLB1\")", &bytes[..n]),
        ));
    }
    Ok(())
}

fn parse_header(h: &[u8]) -> Result<Header> {
    if &h[0..4] != MAGIC {
        return Err(bad(
            ErrorCode::BadMagic,
            format!("bad magic {:?} (expected \"VLB1\")", &h[0..4]),
        ));
    }
    let u = |o: usize| u32::from_le_bytes([h[o], h[o + 1], h[o + 2], h[o + 3]]);
    let f = |o: usize| f32::from_le_bytes([h[o], h[o + 1], h[o + 2], h[o + 3]]);
    let dims = [u(4) as usize, u(8) as usize, u(12) as usize];
    if dims.contains(&0) {
        return Err(bad(
            ErrorCode::BadDimensions,
            format!("dimensions {dims:?} contain 0"),
        ));
    }
    if voxel_count(dims).is_none_or(|v| v > MAX_VOXELS) {
        return Err(bad(
            ErrorCode::BadDimensions,
            format!("dimensions {dims:?} exceed {MAX_VOXELS} voxels"),
        ));
    }
    let bytes = u(16);
    if bytes != 1 && bytes != 2 {
        return Err(bad(
            ErrorCode::BadVoxelWidth,
            format!("voxel width {bytes} (must be 1 or 2 bytes)"),
        ));
    }
    let (a, b) = (f(20), f(24));
    if !a.is_finite() || !b.is_finite() || a == b {
        return Err(bad(
            ErrorCode::BadRange,
            format!("normalisation a = {a}, b = {b} (must be finite and different)"),
        ));
    }
    Ok(Header { dims, bytes, a, b })
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }

        /// A point of [−0.2, 1.2]³: the unit box and a margin around it, where reads clamp.
        fn point_around_box(&mut self) -> [f32; 3] {
            std::array::from_fn(|_| (self.next() * 1.4 - 0.2) as f32)
        }
    }

    /// A 16-bit dataset whose raw values are the integer linear function 1000 + 7i + 300j + 20k
    /// (no clamping: all within [0, 65535]), normalised by a = 0, b = 65535.
    fn linear(dims: [usize; 3]) -> (Dataset, impl Fn([f64; 3]) -> f64) {
        let mut raw = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    raw.push((1000 + 7 * i + 300 * j + 20 * k) as u16);
                }
            }
        }
        let d = Dataset::new(dims, Voxels::U16(raw), 0.0, 65535.0).unwrap();
        let n = dims.map(|n| (n.max(2) - 1) as f64);
        let f = move |p: [f64; 3]| {
            let c = |x: f64, axis: usize| {
                if dims[axis] == 1 {
                    0.0
                } else {
                    x.clamp(0.0, 1.0) * n[axis]
                }
            };
            (1000.0 + 7.0 * c(p[0], 0) + 300.0 * c(p[1], 1) + 20.0 * c(p[2], 2)) / 65535.0
        };
        (d, f)
    }

    #[test]
    fn trilinear_reproduces_linear_functions() {
        let mut rng = Lcg(1);
        for dims in [[5, 7, 3], [2, 2, 2], [9, 1, 4]] {
            let (d, f) = linear(dims);
            for _ in 0..2000 {
                // Includes points outside [0, 1]^3, which clamp to the faces.
                let p = [
                    rng.next() * 1.2 - 0.1,
                    rng.next() * 1.2 - 0.1,
                    rng.next() * 1.2 - 0.1,
                ];
                let got = d.sample(p.map(|x| x as f32), Filter::Trilinear) as f64;
                let want = f([p[0] as f32 as f64, p[1] as f32 as f64, p[2] as f32 as f64]);
                // f32 node values and result: a few ulps of values < 1.
                assert!((got - want).abs() < 1e-6, "{dims:?} {p:?}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn gradient_of_a_linear_field_is_exact_for_every_filter() {
        let (d, _) = linear([6, 5, 4]);
        let want = [
            7.0 * 5.0 / 65535.0,
            300.0 * 4.0 / 65535.0,
            20.0 * 3.0 / 65535.0,
        ];
        let mut rng = Lcg(2);
        for filter in [
            Filter::Nearest,
            Filter::Trilinear,
            Filter::Cubic { b: 0.0, c: 0.5 },
            Filter::Cubic { b: 1.0, c: 0.0 },
        ] {
            for _ in 0..500 {
                let p = [rng.next() as f32, rng.next() as f32, rng.next() as f32];
                let g = d.gradient(p, filter);
                for a in 0..3 {
                    // Node values are f32 (error ≤ 6e-8 each); a difference of two, times up to
                    // n − 1 = 5 per unit, stays below 1e-6.
                    assert!(
                        (g[a] - want[a]).abs() < 1e-6,
                        "{filter:?} {p:?} axis {a}: {g:?}"
                    );
                }
            }
        }
    }

    fn random_u8(dims: [usize; 3], seed: u64) -> Dataset {
        let mut rng = Lcg(seed);
        let n = dims.iter().product();
        let raw: Vec<u8> = (0..n).map(|_| (rng.next() * 256.0) as u8).collect();
        Dataset::new(dims, Voxels::U8(raw), 10.0, 240.0).unwrap()
    }

    /// Node values are made on first use, by any number of threads the same, and a node read
    /// before then (from its voxel) is the node value made after: for 8- and 16-bit voxels,
    /// normalisations that increase, decrease and clamp, sizes below and above a thread's
    /// share (65 536 voxels).
    #[test]
    fn node_values_are_made_on_first_use_the_same_on_any_threads() {
        let mut rng = Lcg(99);
        for (case, dims) in [[7, 5, 3], [61, 47, 29], [2, 1, 1]].into_iter().enumerate() {
            let n: usize = dims.iter().product();
            for (a, b) in [(0.0, 255.0), (240.0, 10.0), (1000.0, 60000.0), (-5.0, 3.0)] {
                let raw = if case % 2 == 0 {
                    Voxels::U8((0..n).map(|_| (rng.next() * 256.0) as u8).collect())
                } else {
                    Voxels::U16((0..n).map(|_| (rng.next() * 65536.0) as u16).collect())
                };
                let d = Dataset::new(dims, raw, a, b).unwrap();
                assert!(!d.values_made());
                let norm = normaliser(a, b);
                let before: Vec<u32> = (0..n)
                    .map(|at| {
                        let [i, j, k] = [
                            at % dims[0],
                            at / dims[0] % dims[1],
                            at / (dims[0] * dims[1]),
                        ];
                        d.node(i, j, k).to_bits()
                    })
                    .collect();
                assert!(!d.values_made(), "reading a node made the values");
                let want: Vec<u32> = (0..n).map(|at| norm(d.raw.get(at)).to_bits()).collect();
                assert_eq!(before, want);
                let made = |threads: usize| {
                    let e = d.clone();
                    rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap()
                        .install(|| e.values().iter().map(|v| v.to_bits()).collect::<Vec<_>>())
                };
                assert_eq!(made(1), want);
                assert_eq!(made(3), want);
                assert_eq!(d.values().len(), n);
                assert!(d.values_made());
            }
        }
    }

    /// [`CellGradients`] as it was before the differences were stored in the order (y, z, x).
    struct OldCellGradients {
        lo: usize,
        diffs: [[f32; 4]; 8],
    }

    /// `Dataset::trilinear_gradient_at` before its rows were bounds-checked through the two
    /// furthest rows and its differences gathered in the order (y, z, x), verbatim (`self` as
    /// `d`), the oracle of `gradient_rows_are_the_row_by_row_read`.
    fn old_trilinear_gradient_at(
        d: &Dataset,
        lo: usize,
        [fx, fy, fz]: [f32; 3],
        cache: &mut OldCellGradients,
    ) -> Option<[f64; 3]> {
        if cache.lo != lo {
            let (sy, sz) = (d.strides[1], d.strides[2]);
            let v = d.values();
            let last = v.len().checked_sub(4)?;
            let row = |j: usize, k: usize| -> Option<[f32; 4]> {
                let o = lo + j * sy + k * sz;
                if o > last {
                    return None;
                }
                v.get(o..o + 4)?.try_into().ok()
            };
            let (r10, r20) = (row(1, 0)?, row(2, 0)?);
            let (r01, r11, r21, r31) = (row(0, 1)?, row(1, 1)?, row(2, 1)?, row(3, 1)?);
            let (r02, r12, r22, r32) = (row(0, 2)?, row(1, 2)?, row(2, 2)?, row(3, 2)?);
            let (r13, r23) = (row(1, 3)?, row(2, 3)?);
            let corners = [
                (r11, r01, r21, r10, r12),
                (r21, r11, r31, r20, r22),
                (r12, r02, r22, r11, r13),
                (r22, r12, r32, r21, r23),
            ];
            use wide::f32x4;
            for (c, (r, ym, yp, zm, zp)) in corners.into_iter().enumerate() {
                let dx = f32x4::new([0.0, r[2], r[3], 0.0]) - f32x4::new([0.0, r[0], r[1], 0.0]);
                let dy = f32x4::new(yp) - f32x4::new(ym);
                let dz = f32x4::new(zp) - f32x4::new(zm);
                let [_, first, second, _] = f32x4::transpose([dx, dy, dz, f32x4::ZERO]);
                cache.diffs[2 * c] = first.to_array();
                cache.diffs[2 * c + 1] = second.to_array();
            }
            cache.lo = lo;
        }
        let (gx, gy, gz) = (1.0 - fx, 1.0 - fy, 1.0 - fz);
        let xy = wide::f32x4::new([gx, fx, gx, fx]) * wide::f32x4::new([gy, gy, fy, fy]);
        let near = (xy * wide::f32x4::splat(gz)).to_array();
        let far = (xy * wide::f32x4::splat(fz)).to_array();
        let weights = [
            near[0], near[1], near[2], near[3], far[0], far[1], far[2], far[3],
        ];
        let mut g = wide::f32x4::ZERO;
        for (wt, d) in weights.into_iter().zip(cache.diffs) {
            g += wide::f32x4::splat(wt) * wide::f32x4::new(d);
        }
        let g = g.to_array();
        Some([
            g[0] as f64 * d.half_last[0],
            g[1] as f64 * d.half_last[1],
            g[2] as f64 * d.half_last[2],
        ])
    }

    /// The same bits, or both NaN (a NaN's payload is not promised).
    fn same_f64(a: f64, b: f64) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    /// The trilinear gradient's rows read under the test of the neighbourhood's last row, and
    /// its differences gathered in the order (y, z, x), give what the row-by-row read gave:
    /// a gradient exactly for the neighbourhood starts whose last row lies inside the values
    /// (every interior cell's: `specialised_trilinear_paths_agree_with_the_generic_filter`),
    /// and there the same bits, through a cache that hits and misses, on values of every kind
    /// (random bits: NaNs, infinities, subnormals, ±0, huge) and awkward weights.
    #[test]
    fn gradient_rows_are_the_row_by_row_read() {
        let rng = crate::testing::Xorshift::new(0x5eed_6a0d);
        let weight = |rng: &crate::testing::Xorshift| -> f32 {
            match rng.bits() % 8 {
                0 => 0.0,
                1 => -0.0,
                2 => 1.0,
                3 => f32::from_bits(rng.bits() as u32),
                4 => f32::from_bits(1),
                _ => rng.next() as f32,
            }
        };
        for (dims, bits) in [
            ([4, 4, 4], false),
            ([5, 4, 6], false),
            ([7, 5, 4], true),
            ([4, 9, 5], true),
            ([6, 6, 6], true),
        ] {
            let mut d = random_u8(dims, 21);
            if bits {
                // Any f32 at all, to check the lanes' operations, not only the dataset's
                // values in [0, 1].
                let n = d.raw.len();
                d.values = std::sync::OnceLock::from(
                    (0..n)
                        .map(|i| match i % 13 {
                            0 => -0.0,
                            1 => f32::NAN,
                            2 => f32::INFINITY,
                            3 => f32::NEG_INFINITY,
                            4 => f32::from_bits(rng.bits() as u32 & 0x807f_ffff),
                            5 => f32::MAX,
                            _ => f32::from_bits(rng.bits() as u32),
                        })
                        .collect::<Vec<f32>>(),
                );
            }
            let (mut new, mut old) = (
                CellGradients::default(),
                OldCellGradients {
                    lo: usize::MAX,
                    diffs: [[0.0; 4]; 8],
                },
            );
            for lo in 0..d.raw.len() + 3 {
                for _ in 0..3 {
                    let f = [weight(&rng), weight(&rng), weight(&rng)];
                    let got = d.trilinear_gradient_at::<true>(lo, f, &mut new);
                    let (sy, sz) = (d.strides[1], d.strides[2]);
                    let inside = lo + 3 * sy + 3 * sz + 4 <= d.raw.len();
                    assert_eq!(got.is_some(), inside, "{dims:?} lo {lo}");
                    // (The old read where the new one reads, the same cache traffic.)
                    let want = if inside {
                        old_trilinear_gradient_at(&d, lo, f, &mut old)
                    } else {
                        None
                    };
                    assert_eq!(got.is_some(), want.is_some(), "{dims:?} lo {lo}");
                    if let (Some(g), Some(w)) = (got, want) {
                        assert!(
                            g.iter().zip(w).all(|(&g, w)| same_f64(g, w)),
                            "{dims:?} lo {lo} {f:?}: {g:?} vs {w:?}"
                        );
                    }
                    // A fresh cache: the miss's path at every start, not only the first.
                    let fresh =
                        d.trilinear_gradient_at::<true>(lo, f, &mut CellGradients::default());
                    // Without the signed zeros: the same but for the sign of a zero.
                    let unsigned =
                        d.trilinear_gradient_at::<false>(lo, f, &mut CellGradients::default());
                    assert_eq!(
                        unsigned.map(|g| g.map(|x| (x + 0.0).to_bits())),
                        fresh.map(|g| g.map(|x| (x + 0.0).to_bits())),
                        "{dims:?} lo {lo}"
                    );
                    assert_eq!(
                        fresh.map(|g| g.map(f64::to_bits)),
                        got.map(|g| g.map(f64::to_bits)),
                        "{dims:?} lo {lo}"
                    );
                }
            }
        }
    }

    #[test]
    fn brick_ranges_are_the_extremes_of_their_padded_spans() {
        // 8- and 16-bit voxels, normalisations that increase and decrease, unclamped (so
        // that the extremes differ between spans) and clamped (plateaus at 0 and 1): the
        // ranges come from the raw extremes, and must still be the node values' extremes.
        let cases = [
            ([13, 9, 11], 5, false, (0.0, 255.0)),
            ([2, 17, 6], 6, false, (0.0, 255.0)),
            ([9, 1, 5], 7, false, (0.0, 255.0)),
            ([13, 9, 11], 8, false, (200.0, 40.0)),
            ([11, 10, 9], 9, false, (90.0, 130.0)),
            ([13, 9, 11], 10, true, (-5000.0, 70000.0)),
            ([10, 12, 7], 11, true, (66000.0, -100.0)),
            ([10, 12, 7], 12, true, (30000.0, 36000.0)),
        ];
        for (dims, seed, wide, (na, nb)) in cases {
            let mut rng = Lcg(seed);
            let n: usize = dims.iter().product();
            let raw = if wide {
                Voxels::U16((0..n).map(|_| (rng.next() * 65536.0) as u16).collect())
            } else {
                Voxels::U8((0..n).map(|_| (rng.next() * 256.0) as u8).collect())
            };
            let d = Dataset::new(dims, raw, na, nb).unwrap();
            for (filter, pad) in [
                (Filter::Trilinear, 1),
                (Filter::Cubic { b: 0.0, c: 0.5 }, 2),
            ] {
                let b = d.bricks(filter);
                for (bk, bj, bi) in (0..b.dims[2]).flat_map(|k| {
                    (0..b.dims[1]).flat_map(move |j| (0..b.dims[0]).map(move |i| (k, j, i)))
                }) {
                    // By brute force: every node within `pad` of the brick's node span.
                    let span = |b: usize, n: usize| {
                        (
                            (b * BRICK).saturating_sub(pad),
                            (b * BRICK + BRICK + pad).min(n - 1),
                        )
                    };
                    let ((x0, x1), (y0, y1), (z0, z1)) =
                        (span(bi, dims[0]), span(bj, dims[1]), span(bk, dims[2]));
                    let (mut mn, mut mx) = (f32::INFINITY, f32::NEG_INFINITY);
                    for z in z0..=z1 {
                        for y in y0..=y1 {
                            for x in x0..=x1 {
                                mn = mn.min(d.node(x, y, z));
                                mx = mx.max(d.node(x, y, z));
                            }
                        }
                    }
                    let at = format!("{dims:?} a {na} b {nb} brick {bi} {bj} {bk}");
                    assert_eq!(b.get(bi, bj, bk), (mn, mx), "{at}");
                }
            }
        }
    }

    #[test]
    fn nearest_and_cardinal_cubics_pass_through_nodes() {
        let d = random_u8([5, 4, 6], 3);
        let [nx, ny, nz] = d.dims();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let p = [
                        i as f32 / (nx - 1) as f32,
                        j as f32 / (ny - 1) as f32,
                        k as f32 / (nz - 1) as f32,
                    ];
                    let node = d.node(i, j, k);
                    assert_eq!(d.sample(p, Filter::Nearest), node);
                    assert!((d.sample(p, Filter::Trilinear) - node).abs() < 1e-6);
                    for c in [0.0, 0.5, 1.0] {
                        let v = d.sample(p, Filter::Cubic { b: 0.0, c });
                        assert!(
                            (v - node).abs() < 1e-5,
                            "C={c} node ({i},{j},{k}): {v} vs {node}"
                        );
                    }
                }
            }
        }
        // The B-spline (B = 1) smooths: it does not interpolate a random field.
        let p = [0.5f32, 1.0 / 3.0, 0.4];
        let (i, j, k) = (2, 1, 2);
        assert!((d.sample(p, Filter::Cubic { b: 1.0, c: 0.0 }) - d.node(i, j, k)).abs() > 1e-4);
    }

    #[test]
    fn nearest_returns_node_values_between_nodes() {
        let d = random_u8([4, 4, 4], 4);
        let mut rng = Lcg(5);
        for _ in 0..1000 {
            let p = [rng.next() as f32, rng.next() as f32, rng.next() as f32];
            let idx = p.map(|x| (x as f64 * 3.0).round() as usize);
            assert_eq!(d.sample(p, Filter::Nearest), d.node(idx[0], idx[1], idx[2]));
        }
    }

    #[test]
    fn kernel_is_a_partition_of_unity() {
        for (b, c) in [(0.0, 0.5), (1.0, 0.0), (1.0 / 3.0, 1.0 / 3.0)] {
            for t in [0.0, 0.1, 0.5, 0.77] {
                let s: f64 = (-1..=2).map(|m| bc_kernel(t - m as f64, b, c)).sum();
                assert!((s - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn normalisation_clamps() {
        let d = Dataset::new([3, 1, 1], Voxels::U8(vec![0, 100, 255]), 50.0, 150.0).unwrap();
        assert_eq!(d.values(), &[0.0, 0.5, 1.0]);
        // b < a inverts.
        let d = Dataset::new([2, 1, 1], Voxels::U8(vec![0, 255]), 255.0, 0.0).unwrap();
        assert_eq!(d.values(), &[1.0, 0.0]);
        // A dimension of 1 is constant along its axis.
        assert_eq!(d.sample([1.0, 0.3, 0.9], Filter::Trilinear), 0.0);
    }

    #[test]
    fn vlb_round_trip_is_bit_exact() {
        let d8 = random_u8([7, 3, 5], 6);
        let back = Dataset::from_vlb_bytes(&d8.to_vlb_bytes()).unwrap();
        assert_eq!(back, d8);
        assert_eq!(back.to_vlb_bytes(), d8.to_vlb_bytes());
        let (d16, _) = linear([4, 3, 2]);
        let bytes = d16.to_vlb_bytes();
        assert_eq!(bytes.len(), HEADER_LEN + 4 * 3 * 2 * 2);
        assert_eq!(&bytes[..4], b"VLB1");
        assert_eq!(Dataset::from_vlb_bytes(&bytes).unwrap(), d16);
        // Files too.
        let path = std::env::temp_dir().join(format!("vlib-rt-{}.vlb", std::process::id()));
        d16.save(&path).unwrap();
        assert_eq!(Dataset::load(&path).unwrap(), d16);
        std::fs::remove_file(&path).unwrap();
    }

    #[test]
    fn malformed_files_are_refused_with_the_right_error() {
        let good = random_u8([3, 2, 2], 7).to_vlb_bytes();
        let patch = |at: usize, bytes: &[u8]| {
            let mut v = good.clone();
            v[at..at + bytes.len()].copy_from_slice(bytes);
            v
        };
        let cases: Vec<(&str, Vec<u8>, ErrorCode)> = vec![
            ("empty", vec![], ErrorCode::BadSize),
            ("short header", good[..20].to_vec(), ErrorCode::BadSize),
            ("short non-vlb file", b"P6\n".to_vec(), ErrorCode::BadMagic),
            ("bad magic", patch(0, b"VLB2"), ErrorCode::BadMagic),
            (
                "zero dimension",
                patch(8, &0u32.to_le_bytes()),
                ErrorCode::BadDimensions,
            ),
            (
                "10^15 voxels",
                {
                    let mut v = patch(4, &100_000u32.to_le_bytes());
                    v[8..12].copy_from_slice(&100_000u32.to_le_bytes());
                    v[12..16].copy_from_slice(&100_000u32.to_le_bytes());
                    v
                },
                ErrorCode::BadDimensions,
            ),
            (
                "voxel width 3",
                patch(16, &3u32.to_le_bytes()),
                ErrorCode::BadVoxelWidth,
            ),
            (
                "voxel width 0",
                patch(16, &0u32.to_le_bytes()),
                ErrorCode::BadVoxelWidth,
            ),
            (
                "a = b",
                patch(24, &10.0f32.to_le_bytes()),
                ErrorCode::BadRange,
            ),
            (
                "a NaN",
                patch(20, &f32::NAN.to_le_bytes()),
                ErrorCode::BadRange,
            ),
            (
                "b infinite",
                patch(24, &f32::INFINITY.to_le_bytes()),
                ErrorCode::BadRange,
            ),
            (
                "truncated voxels",
                good[..good.len() - 1].to_vec(),
                ErrorCode::BadSize,
            ),
            (
                "trailing data",
                [good.clone(), vec![0]].concat(),
                ErrorCode::BadSize,
            ),
            (
                "16-bit claim on 8-bit data",
                patch(16, &2u32.to_le_bytes()),
                ErrorCode::BadSize,
            ),
        ];
        let dir = std::env::temp_dir().join(format!("vlib-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (name, bytes, code) in cases {
            assert_eq!(
                Dataset::from_vlb_bytes(&bytes).unwrap_err().code,
                code,
                "{name} (memory)"
            );
            let path = dir.join("bad.vlb");
            std::fs::write(&path, &bytes).unwrap();
            assert_eq!(
                Dataset::load(&path).unwrap_err().code,
                code,
                "{name} (file)"
            );
        }
        assert_eq!(
            Dataset::load(&dir.join("missing.vlb")).unwrap_err().code,
            ErrorCode::IoError
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The interior trilinear gradient the plain way, for bit-for-bit comparisons: the cell
    /// axis by axis, each corner's central differences read node by node, the weights as
    /// products, each axis summed corner by corner in f32, then 0.5·g·(n − 1) in f64.
    fn plain_interior_gradient(d: &Dataset, p: [f32; 3]) -> [f64; 3] {
        let ([x0, y0, z0], [fx, fy, fz]) = d.cell32_scalar(p);
        let (gx, gy, gz) = (1.0 - fx, 1.0 - fy, 1.0 - fz);
        let mut g = [0f32; 3];
        for corner in 0..8 {
            let [i, j, k] = [
                x0 + (corner & 1),
                y0 + (corner >> 1 & 1),
                z0 + (corner >> 2),
            ];
            let w = [gx, fx][corner & 1] * [gy, fy][corner >> 1 & 1] * [gz, fz][corner >> 2];
            let diffs = [
                d.node(i + 1, j, k) - d.node(i - 1, j, k),
                d.node(i, j + 1, k) - d.node(i, j - 1, k),
                d.node(i, j, k + 1) - d.node(i, j, k - 1),
            ];
            for (g, diff) in g.iter_mut().zip(diffs) {
                *g += w * diff;
            }
        }
        std::array::from_fn(|axis| 0.5 * g[axis] as f64 * d.last[axis])
    }

    #[test]
    fn specialised_trilinear_paths_agree_with_the_generic_filter() {
        let d = random_u8([9, 7, 8], 8);
        let mut rng = Lcg(9);
        let (mut cache, mut hits) = (CellGradients::default(), 0);
        for _ in 0..5000 {
            let p = rng.point_around_box();
            let u = [d.index(p[0], 0), d.index(p[1], 1), d.index(p[2], 2)];
            let generic = d.filter(u, Filter::Trilinear, |i, j, k| d.node(i, j, k) as f64);
            // f32 index arithmetic: the weights are off by at most an ulp of the index (n < 16
            // here: 1e-6), times node differences of at most 1.
            assert!(
                (d.trilinear(p) as f64 - generic.clamp(0.0, 1.0)).abs() < 4e-6,
                "{p:?}"
            );
            // The cached path gives the same bits as a fresh read, whether the cache holds the
            // point's cell (a second point close by mostly shares it) or another one.
            for q in [p, [p[0] + 1e-3, p[1] - 1e-3, p[2] + 1e-3]] {
                let fresh = d.trilinear_gradient_interior(q, &mut CellGradients::default());
                let lo = d.interior_cell32(q).map(|(c, _)| d.neighbourhood_lo(c));
                // Every interior cell takes the specialised path (its rows are all inside).
                assert_eq!(fresh.is_some(), lo.is_some(), "{q:?}");
                hits += usize::from(fresh.is_some() && Some(cache.lo) == lo);
                assert_eq!(d.trilinear_gradient_interior(q, &mut cache), fresh, "{q:?}");
            }
            if let Some(g) = d.trilinear_gradient_interior(p, &mut CellGradients::default()) {
                let want = plain_interior_gradient(&d, p);
                assert_eq!(g.map(f64::to_bits), want.map(f64::to_bits), "{p:?}");
                for (axis, g) in g.into_iter().enumerate() {
                    let n = d.dims()[axis];
                    let want = d.filter(u, Filter::Trilinear, |i, j, k| {
                        d.node_derivative(i, j, k, axis)
                    }) * (n - 1) as f64;
                    assert!(
                        (g - want).abs() < 1e-5 * (n as f64),
                        "{p:?} axis {axis}: {g} vs {want}"
                    );
                }
            }
        }
        assert!(hits > 500, "only {hits} cache hits tested");
        // Degenerate axes take the generic route where needed and stay constant.
        let slab = random_u8([5, 4, 1], 10);
        let a = slab.sample([0.3, 0.6, 0.0], Filter::Trilinear);
        assert_eq!(a, slab.sample([0.3, 0.6, 0.9], Filter::Trilinear));
    }

    #[test]
    fn interior_cubic_path_is_the_generic_filter_bit_for_bit() {
        let d = random_u8([9, 7, 8], 8);
        let mut rng = Lcg(11);
        let (mut interior, mut derivative) = (0, 0);
        for (b, c) in [(0.0, 0.5), (1.0, 0.0), (1.0 / 3.0, 1.0 / 3.0)] {
            for _ in 0..3000 {
                let p = rng.point_around_box();
                let u = [d.index(p[0], 0), d.index(p[1], 1), d.index(p[2], 2)];
                let f = Filter::Cubic { b, c };
                let generic = d.filter(u, f, |i, j, k| d.node(i, j, k) as f64);
                if let Some(v) = d.cubic_interior(u, b as f64, c as f64) {
                    interior += 1;
                    assert_eq!(v.to_bits(), generic.to_bits(), "{p:?} b {b} c {c}");
                }
                assert_eq!(
                    d.sample(p, f).to_bits(),
                    (generic as f32).clamp(0.0, 1.0).to_bits()
                );
                for axis in 0..3 {
                    let want = d.filter(u, f, |i, j, k| d.node_derivative(i, j, k, axis));
                    if let Some(v) = d.cubic_derivative_interior(u, b as f64, c as f64, axis) {
                        derivative += 1;
                        assert_eq!(v.to_bits(), want.to_bits(), "{p:?} axis {axis}");
                    }
                }
            }
        }
        assert!(
            interior > 1000,
            "the interior path was taken {interior} times"
        );
        assert!(
            derivative > 1000,
            "the derivative path was taken {derivative} times"
        );
    }

    /// A mask built a run of words at a time sets exactly the bits of the cells some node of
    /// which lies above z − margin, and no bit of a node that starts no cell (the last node
    /// of an axis): over grids of several runs whose rows straddle the runs' ends.
    #[test]
    fn cell_mask_bits_are_the_cells_above_the_bound_across_runs() {
        let mut rng = Lcg(11);
        for dims in [[67, 31, 33], [300, 250, 2], [4100, 17, 1]] {
            let n: usize = dims.iter().product();
            assert!(n > 64 * CELL_MASK_RUN, "{dims:?} spans several runs");
            let raw = (0..n).map(|_| (rng.next().powi(4) * 255.0) as u8).collect();
            let d = Dataset::new(dims, Voxels::U8(raw), 0.0, 255.0).unwrap();
            let z = 100.0 / 255.0;
            let mask = d.cells_above(z);
            let [nx, ny, nz] = dims;
            let (mut set, mut clear) = (0, 0);
            for c in 0..n {
                let (i, j, k) = (c % nx, c / nx % ny, c / (nx * ny));
                let starts = |x: usize, n: usize| n == 1 || x + 1 < n;
                let want = starts(i, nx) && starts(j, ny) && starts(k, nz) && {
                    let at = |x: usize, s: usize, n: usize| (x + s).min(n - 1);
                    (0..8).any(|e: usize| {
                        d.node(at(i, e & 1, nx), at(j, e >> 1 & 1, ny), at(k, e >> 2, nz))
                            > z - CELL_MASK_MARGIN
                    })
                };
                assert_eq!(
                    mask.bits[c >> 6] >> (c & 63) & 1 != 0,
                    want,
                    "{dims:?} node {c}"
                );
                if want {
                    set += 1;
                } else {
                    clear += 1;
                }
            }
            assert!(set > 0 && clear > 0, "{dims:?}: {set} set, {clear} clear");
            assert_eq!(mask.bits.len(), n.div_ceil(64));
            // Runs of cells as words: bit b is cell c + b's, also across words and past the
            // end (where every cell may reach).
            for c in (0..n + 70).step_by(13).chain(n - 3..n + 2) {
                for len in [1, 4, 5, 37, 63, 64] {
                    let run = mask.run(c, len);
                    for b in 0..64 {
                        let want = b < len && mask.may_reach(c + b);
                        assert_eq!(run >> b & 1 != 0, want, "{dims:?} run {c} {len} bit {b}");
                    }
                }
            }
        }
    }

    /// Flags packed into a word are the word of their bits, for every length up to 64
    /// (whole groups of eight and a shorter last one).
    #[test]
    fn packed_flags_are_their_bits() {
        let mut rng = Lcg(31);
        for len in 0..=64 {
            for _ in 0..20 {
                let flags: Vec<u8> = (0..len).map(|_| u8::from(rng.next() < 0.5)).collect();
                let want = flags
                    .iter()
                    .enumerate()
                    .fold(0u64, |w, (b, &f)| w | u64::from(f) << b);
                assert_eq!(pack_flags(&flags), want, "{flags:?}");
            }
        }
    }

    /// Masks built from raw voxels are the node values' test: for 8- and 16-bit voxels,
    /// normalisations that increase and decrease, clamped and not, bounds that some, none and
    /// all cells pass, on a grid of several runs of words; each bit is brute-forced from the
    /// node values.
    #[test]
    fn cell_masks_from_raw_voxels_are_the_node_values_test() {
        let mut rng = Lcg(23);
        let dims = [67, 31, 33];
        let n: usize = dims.iter().product();
        assert!(n > 64 * CELL_MASK_RUN);
        let bytes: Vec<u8> = (0..n).map(|_| (rng.next() * 256.0) as u8).collect();
        let shorts: Vec<u16> = (0..n).map(|_| (rng.next() * 65536.0) as u16).collect();
        let cases = [
            (Voxels::U8(bytes.clone()), (220.0, 10.0)),
            (Voxels::U8(bytes), (0.0, 255.0)),
            (Voxels::U16(shorts.clone()), (30000.0, 36000.0)),
            (Voxels::U16(shorts), (66000.0, -100.0)),
        ];
        for (raw, (a, b)) in cases {
            let d = Dataset::new(dims, raw, a, b).unwrap();
            let [nx, ny, nz] = dims;
            for z in [0.0, 0.3, 0.77, 0.999, 1.0, 2.0] {
                let mask = d.cells_above(z);
                let mut set = 0;
                for c in 0..n {
                    let (i, j, k) = (c % nx, c / nx % ny, c / (nx * ny));
                    let want = i + 1 < nx && j + 1 < ny && k + 1 < nz && {
                        (0..8).any(|e: usize| {
                            d.node(i + (e & 1), j + (e >> 1 & 1), k + (e >> 2))
                                > z - CELL_MASK_MARGIN
                        })
                    };
                    assert_eq!(mask.may_reach(c), want, "a {a} b {b} z {z} node {c}");
                    set += usize::from(want);
                }
                let cells = (nx - 1) * (ny - 1) * (nz - 1);
                match z {
                    0.0 => assert_eq!(set, cells, "a {a} b {b}: every cell"),
                    2.0 => assert_eq!(set, 0, "a {a} b {b}: none"),
                    _ => {}
                }
            }
        }
    }

    /// A cell mask clears exactly the cells whose nodes are all at most z − margin, and a
    /// masked sample differs from the plain one only where both are at most z: over grids with
    /// one node along an axis, 8- and 16-bit values crowding the bound, and random points.
    #[test]
    fn cell_masks_drop_only_samples_at_most_their_bound() {
        let mut rng = Lcg(7);
        for dims in [[6, 5, 7], [1, 6, 5], [5, 1, 1], [2, 2, 2], [9, 4, 1]] {
            let n = dims.iter().product::<usize>();
            let data8 = Dataset::new(
                dims,
                Voxels::U8(
                    (0..n)
                        .map(|_| (30.0 + rng.next().powi(6) * 14.0) as u8)
                        .collect(),
                ),
                0.0,
                255.0,
            )
            .unwrap();
            let data16 = Dataset::new(
                dims,
                Voxels::U16((0..n).map(|_| (rng.next().powi(6) * 3.0) as u16).collect()),
                0.0,
                2.0,
            )
            .unwrap();
            for (d, z) in [(&data8, 40.0 / 255.0), (&data16, 0.5), (&data8, 0.0)] {
                let mask = d.cells_above(z);
                assert!(
                    std::sync::Arc::ptr_eq(&mask, &d.cells_above(z)),
                    "built once per bound"
                );
                let [nx, ny, nz] = d.dims;
                let (mut kept, mut dropped) = (0, 0);
                for k in 0..nz.saturating_sub(1).max(1) {
                    for j in 0..ny.saturating_sub(1).max(1) {
                        for i in 0..nx.saturating_sub(1).max(1) {
                            let mut top = 0f32;
                            for (a, b, c) in (0..8).map(|c| (c & 1, c >> 1 & 1, c >> 2)) {
                                let at = |x: usize, s: usize, n: usize| (x + s).min(n - 1);
                                let v = d.node(at(i, a, nx), at(j, b, ny), at(k, c, nz));
                                top = top.max(v);
                            }
                            let c = i + nx * (j + ny * k);
                            assert_eq!(mask.may_reach(c), top > z - CELL_MASK_MARGIN, "{dims:?}");
                            if mask.may_reach(c) {
                                kept += 1;
                            } else {
                                dropped += 1;
                            }
                        }
                    }
                }
                if z > 0.0 && n >= 30 {
                    assert!(
                        kept > 0 && dropped > 0,
                        "{dims:?} z {z}: {kept} / {dropped}"
                    );
                }
                for _ in 0..250 {
                    let ps: [[f32; 3]; 8] = std::array::from_fn(|_| rng.point_around_box());
                    let by_axis = std::array::from_fn(|axis| ps.map(|p| p[axis]));
                    for count in [8, 5, 4, 3] {
                        // (`values8` starts from 1s: a rejected cell's value must be set to 0.)
                        let masked = values8(d, &by_axis, count, Some(&mask));
                        for (i, (p, masked)) in ps.into_iter().zip(masked).enumerate() {
                            let plain = d.trilinear(p);
                            if i >= count {
                                assert_eq!(masked.to_bits(), 0, "{dims:?} {p:?}");
                            } else if plain > z {
                                assert_eq!(plain.to_bits(), masked.to_bits(), "{dims:?} {p:?}");
                            } else {
                                assert!(masked == plain || masked == 0.0, "{dims:?} {p:?}");
                            }
                            // Exactly: the value where the cell may reach z, else 0.
                            let reach = mask.may_reach(d.node_index(d.cell32(p).0));
                            let want = if i < count && reach { plain } else { 0.0 };
                            assert_eq!(masked.to_bits(), want.to_bits(), "{dims:?} {p:?}");
                        }
                    }
                }
            }
        }
    }

    /// The cell in SSE lanes is the cell axis by axis, and its interior test the test on the
    /// cell's indices; the values of eight points in lanes (`trilinear8`) are the values point
    /// by point: inside, on and outside the box, at NaN and infinities, on grids with axes of
    /// one to four nodes and the MNI grid's.
    #[test]
    fn cells_in_lanes_are_the_cells_axis_by_axis() {
        let mut rng = Lcg(11);
        let specials = [
            0.0,
            -0.0,
            1.0,
            0.5,
            1.0 - f32::EPSILON,
            1e-30,
            -1e-30,
            2.0,
            -3.0,
            1e30,
            -1e30,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
        ];
        for (seed, dims) in [
            [9, 7, 8],
            [1, 6, 5],
            [2, 2, 2],
            [197, 233, 189],
            [1, 1, 1],
            [3, 1, 2],
        ]
        .into_iter()
        .enumerate()
        {
            let d = random_u8(dims, 20 + seed as u64);
            assert!(d.lanes.is_some(), "{dims:?} is small enough for lanes");
            trilinear8_is_trilinear(&d, &mut rng, &specials);
            let mut points: Vec<[f32; 3]> = (0..3000).map(|_| rng.point_around_box()).collect();
            for &a in &specials {
                for &b in &specials {
                    points.push([a, b, 0.3]);
                    points.push([0.7, a, b]);
                }
            }
            for p in points {
                let ((i, f), (j, g)) = (d.cell32(p), d.cell32_scalar(p));
                // Interior: the neighbourhood x0 − 1 … x0 + 2 (and so on) inside the grid.
                let inside = (0..3).all(|a| j[a] >= 1 && j[a] + 2 < dims[a]);
                assert_eq!(
                    d.interior_cell32(p).map(|c| c.0),
                    inside.then_some(j),
                    "{p:?}"
                );
                assert_eq!(i, j, "{dims:?} {p:?}");
                // Equal as numbers: `maxps` makes max(−0, 0) = +0 where `f32::max` keeps −0,
                // a zero weight's sign that no lerp result depends on.
                assert_eq!(f, g, "{dims:?} {p:?}");
                assert!(f.iter().all(|w| w.is_finite() && (0.0..=1.0).contains(w)));
            }
        }
        // An axis longer than 2²⁴ nodes is not exact in f32 lanes: such a grid goes axis by
        // axis, in `trilinear8` too.
        let n = (1 << 24) + 2;
        let long = Dataset::new(
            [1, 1, n],
            Voxels::U8((0..n).map(|i| (i * 37 % 256) as u8).collect()),
            0.0,
            255.0,
        )
        .unwrap();
        assert!(long.lanes.is_none());
        trilinear8_is_trilinear(&long, &mut rng, &specials);
    }

    /// [`trilinear_rows`] in lanes against the scalar lerps it replaced (kept here verbatim),
    /// bit for bit, on nodes and weights drawn from awkward values (NaN, ±0, ±∞, subnormals,
    /// huge, the unit interval's ends) and from random bits, and on the usual nodes in [0, 1]
    /// with weights in [0, 1). Where both give NaN only that is required: Rust leaves a NaN's
    /// payload unspecified, and the compiler may swap a sum's or product's operands.
    #[test]
    fn trilinear_rows_is_the_scalar_lerps() {
        let old = |[r00, r10, r01, r11]: [[f32; 2]; 4], [fx, fy, fz]: [f32; 3]| {
            let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
            let (c00, c10, c01, c11) = (
                lerp(r00[0], r00[1], fx),
                lerp(r10[0], r10[1], fx),
                lerp(r01[0], r01[1], fx),
                lerp(r11[0], r11[1], fx),
            );
            lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz).clamp(0.0, 1.0)
        };
        let rng = crate::testing::Xorshift::new(0x9e37_79b9_7f4a_7c15u64);
        let specials = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            1.0 - f32::EPSILON / 2.0,
            f32::MIN_POSITIVE,
            f32::MIN_POSITIVE / 8.0,
            -f32::MIN_POSITIVE / 8.0,
            f32::from_bits(1),
            1e30,
            -1e30,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
        ];
        let special = || specials[(rng.bits() % specials.len() as u64) as usize];
        let awkward = || match rng.bits() % 4 {
            0 => f32::from_bits(rng.bits() as u32),
            1 => rng.next() as f32,
            _ => special(),
        };
        let unit = || rng.next() as f32;
        for round in 0..400_000 {
            let draw = || if round % 2 == 0 { awkward() } else { unit() };
            let rows: [[f32; 2]; 4] = std::array::from_fn(|_| [draw(), draw()]);
            let f: [f32; 3] = std::array::from_fn(|_| draw());
            let [r00, r10, r01, r11] = rows;
            let z0 = [r00[0], r00[1], r01[0], r01[1]];
            let new = trilinear_rows(z0, [r10[0], r10[1], r11[0], r11[1]], f);
            let want = old(rows, f);
            assert!(
                new.to_bits() == want.to_bits() || (new.is_nan() && want.is_nan()),
                "{rows:?} {f:?}: {new:?} against {want:?}"
            );
        }
    }

    /// [`Dataset::interior8`] against the test axis by axis it replaced (kept here verbatim),
    /// on clamped coordinates drawn from awkward numbers (±0, ±∞, subnormals, huge, 1 and the
    /// interior bound and their neighbours) and random bits, at every count: every number but
    /// NaN, which `trilinear8` never writes (checked here from NaN points).
    #[test]
    fn interior8_is_the_tests_axis_by_axis() {
        use wide::f32x8;
        let rng = crate::testing::Xorshift::new(0x2545_f491_4f6c_dd1du64);
        for dims in [[9, 7, 8], [4, 5, 4], [1, 6, 5], [3, 3, 3], [197, 233, 189]] {
            let d = random_u8(dims, 7);
            let Some([_, _, inner]) = d.lanes else {
                panic!("{dims:?} is small enough for lanes");
            };
            let old = |cells: &Cells8| {
                let inside = |axis: usize| {
                    let cu = f32x8::new(cells.cu[axis]);
                    cu.simd_ge(f32x8::ONE) & cu.simd_lt(f32x8::splat(inner[axis]))
                };
                let count = cells.count.min(8);
                (inside(0) & inside(1) & inside(2)).to_bitmask() & ((1 << count) - 1)
            };
            let mut specials = vec![
                0.0f32,
                -0.0,
                1.0,
                f32::MIN_POSITIVE,
                f32::from_bits(1),
                -f32::from_bits(1),
                1e30,
                -1e30,
                f32::MAX,
                f32::INFINITY,
                f32::NEG_INFINITY,
            ];
            for x in [1.0f32, inner[0], inner[1], inner[2]] {
                specials.extend([x, x.next_up(), x.next_down(), -x]);
            }
            let draw = || match rng.bits() % 4 {
                0 => loop {
                    let x = f32::from_bits(rng.bits() as u32);
                    if !x.is_nan() {
                        break x;
                    }
                },
                1 => (rng.next() * 4.0 - 1.0) as f32 * inner[(rng.bits() % 3) as usize],
                _ => specials[(rng.bits() % specials.len() as u64) as usize],
            };
            for round in 0..20_000 {
                let cells = Cells8 {
                    cu: std::array::from_fn(|_| std::array::from_fn(|_| draw())),
                    count: round % 10,
                    ..Cells8::default()
                };
                assert_eq!(d.interior8(&cells), old(&cells), "{dims:?} {cells:?}");
            }
            // NaN and infinite points give clamped coordinates that are numbers.
            let mut cells = Cells8::default();
            for a in [f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.5] {
                let p = [[a; 8], [0.5; 8], [a; 8]];
                for count in [3, 8] {
                    d.trilinear8(&p, count, None, &mut [0.0; 8], &mut cells);
                    let cu = cells.cu.as_flattened();
                    assert!(cu.iter().all(|x| !x.is_nan()), "{dims:?} {a}");
                }
            }
        }
    }

    /// A cell's value as the eight nodes read one by one (the second node along an axis of one
    /// node is the first) and interpolated in the order of [`Dataset::trilinear_cell`].
    fn trilinear_by_nodes(d: &Dataset, p: [f32; 3]) -> f32 {
        let ([i, j, k], [fx, fy, fz]) = d.cell32_scalar(p);
        let [nx, ny, nz] = d.dims;
        let n = |a: usize, b: usize, c: usize| {
            d.node(
                (i + a).min(nx - 1),
                (j + b).min(ny - 1),
                (k + c).min(nz - 1),
            )
        };
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let row = |b: usize, c: usize| lerp(n(0, b, c), n(1, b, c), fx);
        lerp(
            lerp(row(0, 0), row(1, 0), fy),
            lerp(row(0, 1), row(1, 1), fy),
            fz,
        )
        .clamp(0.0, 1.0)
    }

    /// The cells' nodes read from one span (and, in `trilinear8`, the cells' first nodes found
    /// in f32 lanes) give the values of the eight nodes read one by one, bit for bit: on grids
    /// with axes of one and two nodes, on the largest grid whose node indices are exact in f32
    /// (2²⁴ nodes, points near its last cells) and on one node more (indices computed
    /// axis by axis), with and without the lanes.
    #[test]
    fn cell_reads_are_the_nodes() {
        let mut rng = Lcg(13);
        let check = |d: &Dataset, points: &[[f32; 3]]| {
            let mut plain = d.clone();
            plain.index_lanes = None;
            for chunk in points.chunks(8) {
                let mut ps = [[0.5f32; 3]; 8];
                ps[..chunk.len()].copy_from_slice(chunk);
                let by_axis = std::array::from_fn(|axis| ps.map(|p| p[axis]));
                for count in [chunk.len(), chunk.len().min(4)] {
                    let (got, fallback) = (
                        values8(d, &by_axis, count, None),
                        values8(&plain, &by_axis, count, None),
                    );
                    for (i, p) in ps.iter().enumerate().take(count) {
                        let want = trilinear_by_nodes(d, *p).to_bits();
                        assert_eq!(d.trilinear(*p).to_bits(), want, "{:?} {p:?}", d.dims);
                        assert_eq!(got[i].to_bits(), want, "{:?} {p:?} lane {i}", d.dims);
                        assert_eq!(fallback[i].to_bits(), want, "{:?} {p:?}", d.dims);
                    }
                }
            }
        };
        for (seed, dims) in [
            [9, 7, 8],
            [1, 6, 5],
            [5, 1, 4],
            [4, 5, 1],
            [2, 2, 2],
            [1, 1, 1],
            [2, 1, 1],
            [197, 233, 189],
        ]
        .into_iter()
        .enumerate()
        {
            let d = random_u8(dims, 40 + seed as u64);
            assert!(d.index_lanes.is_some());
            let points: Vec<[f32; 3]> = (0..2000).map(|_| rng.point_around_box()).collect();
            check(&d, &points);
        }
        for (dims, exact) in [([2048, 2048, 4], true), ([2049, 2048, 4], false)] {
            let d = random_u8(dims, 50);
            assert!(d.lanes.is_some());
            assert_eq!(d.index_lanes.is_some(), exact, "{dims:?}");
            let mut points: Vec<[f32; 3]> = (0..2000)
                .map(|_| std::array::from_fn(|_| 1.0 - (rng.next() * 0.01) as f32))
                .collect();
            points.extend((0..200).map(|_| rng.point_around_box()));
            check(&d, &points);
        }
    }

    /// [`Dataset::trilinear8`]'s values, returned.
    fn values8(d: &Dataset, p: &[[f32; 8]; 3], count: usize, mask: Option<&CellMask>) -> [f32; 8] {
        let mut out = [1.0f32; 8]; // not 0: `trilinear8` sets every value
        d.trilinear8(p, count, mask, &mut out, &mut Cells8::default());
        out
    }

    /// [`Dataset::trilinear8`] at the first `count` points, for every count, against
    /// [`Dataset::trilinear`] point by point: the same bits, and 0 past the count.
    fn trilinear8_is_trilinear(d: &Dataset, rng: &mut Lcg, specials: &[f32]) {
        let mut points: Vec<[f32; 3]> = (0..400).map(|_| rng.point_around_box()).collect();
        for &a in specials {
            points.push([a, 0.4, 0.3]);
            points.push([0.7, a, 0.2]);
            points.push([0.1, 0.6, a]);
        }
        for (batch, chunk) in points.chunks(8).enumerate() {
            let mut ps = [[0.5f32; 3]; 8];
            ps[..chunk.len()].copy_from_slice(chunk);
            let by_axis = std::array::from_fn(|axis| ps.map(|p| p[axis]));
            let count = batch % 9;
            let got = values8(d, &by_axis, count, None);
            // A mask of no bits lets every cell through, as no mask does.
            let empty = CellMask {
                bits: Vec::new(),
                words32: Default::default(),
            };
            let unmasked = values8(d, &by_axis, count, Some(&empty));
            for (i, (p, got)) in ps.iter().zip(got).enumerate() {
                let want = if i < count { d.trilinear(*p) } else { 0.0 };
                assert_eq!(got.to_bits(), want.to_bits(), "{:?} {p:?} lane {i}", d.dims);
                assert_eq!(unmasked[i].to_bits(), want.to_bits(), "{:?} {p:?}", d.dims);
            }
        }
        trilinear8_cells(d, rng, specials);
    }

    /// [`Dataset::trilinear8`]'s cells against [`Dataset::interior_cell32`] point by point (an
    /// interior bit exactly where that finds an interior cell, and then the same cell and
    /// weights), and [`Dataset::trilinear_gradient_in`] in them against [`Dataset::gradient`],
    /// bit for bit (one cache across the points, as in a ray): at random points, points in
    /// the cells next to the faces and just either side of their nodes, and `specials`.
    fn trilinear8_cells(d: &Dataset, rng: &mut Lcg, specials: &[f32]) {
        let mut points: Vec<[f32; 3]> = (0..400).map(|_| rng.point_around_box()).collect();
        for axis in 0..3 {
            let n = d.dims[axis];
            let last = n.saturating_sub(1).max(1) as f32;
            for node in [0, 1, 2, 3, n.saturating_sub(3), n.saturating_sub(2), n - 1] {
                let at = node as f32 / last;
                for a in [at, at.next_down(), at.next_up(), at + 0.3 / last] {
                    let mut p = rng.point_around_box();
                    p[axis] = a;
                    points.push(p);
                }
            }
        }
        for &a in specials {
            points.push([a, 0.4, 0.3]);
            points.push([0.5, a, 0.6]);
        }
        let mut cache = CellGradients::default();
        let mut interior = 0;
        for (batch, chunk) in points.chunks(8).enumerate() {
            let mut ps = [[0.5f32; 3]; 8];
            ps[..chunk.len()].copy_from_slice(chunk);
            let by_axis = std::array::from_fn(|axis| ps.map(|p| p[axis]));
            let count = (batch + 5) % 9;
            // Not the defaults: `trilinear8` sets the count and the coordinates (the ones of
            // the eight lanes, interior in grids of more than 3 nodes a side, must go).
            let mut cells = Cells8 {
                count: 8,
                cu: [[1.0; 8]; 3],
                ..Cells8::default()
            };
            d.trilinear8(&by_axis, count, None, &mut [0.0; 8], &mut cells);
            let bits = d.interior8(&cells);
            assert_eq!(bits >> count, 0, "{:?}", d.dims);
            for (i, p) in ps.iter().enumerate().take(count) {
                let found = d.interior_cell32(*p);
                if bits >> i & 1 == 0 {
                    // Only where the cells were not found in lanes may an interior cell have
                    // no bit.
                    assert!(found.is_none() || d.index_lanes.is_none(), "{p:?}");
                    continue;
                }
                interior += 1;
                let (cell, f) = found.expect("an interior cell");
                assert_eq!(cells.at[i] as usize, d.node_index(cell), "{p:?}");
                let got = [cells.f[0][i], cells.f[1][i], cells.f[2][i]];
                assert_eq!(got.map(f32::to_bits), f.map(f32::to_bits), "{p:?}");
                let g = d.trilinear_gradient_in(&by_axis, &cells, i, &mut cache);
                let want = d.gradient(*p, Filter::Trilinear);
                // (But for the sign of a zero, which `trilinear_gradient_in` leaves.)
                let bits = |g: [f64; 3]| g.map(|x| (x + 0.0).to_bits());
                assert_eq!(bits(g), bits(want), "{p:?}");
            }
        }
        // A grid with interior cells had points in them.
        if d.dims.iter().all(|&n| n >= 4) && d.index_lanes.is_some() {
            assert!(interior > 10, "{:?}: {interior}", d.dims);
        }
    }
}
