//! Volume datasets: a regular grid of normalised voxels, read from `.vlb` files and sampled
//! through interpolation filters.
//!
//! A [`Dataset`] is a regular grid of nodes (node i of n lies at object coordinate i/(n − 1); a
//! dimension of 1 is constant along its axis) holding 8- or 16-bit voxels normalised by
//! `min(1, max(0, (v − a)/(b − a)))`. It is immutable once loaded and shared by `Arc` between
//! every object that casts it, so 32 chess pieces made from six datasets hold six grids.
//!
//! This file owns the grid itself: the [`Dataset`] struct with its construction, its accessors,
//! the raw [`Voxels`], the normalisation, and the node values made from the voxels on first use.
//! The concerns built on it live in submodules, each adding its own `impl Dataset` block:
//!
//! - `vlb`: the `.vlb` file format ([`MAGIC`], [`HEADER_LEN`], parsing, loading, the bytes to
//!   save; the file itself is written by the output layer, `Dataset::save`);
//! - `geometry`: the placement a dataset carries ([`Geometry`]) and its `.vlb.geom` sidecar;
//! - `filter`: the [`Filter`]s (nearest node, trilinear, the Mitchell–Netravali BC family of
//!   tricubic filters) and the generic value and gradient paths;
//! - `gradient`: the [`GradientFilter`]s (the paper's node differences, or the exact gradient of
//!   a BC-spline by its derivative kernels);
//! - `trilinear`: the specialised trilinear path the renderer's inner loops call (the cell in
//!   SSE lanes, the cell's value, the interior gradient and its `CellGradients` cache);
//! - `lanes`: the trilinear values of eight points at once (`Cells8`) for the batched march;
//! - `bricks`: the brick ranges ([`Bricks`], [`BRICK`]) of empty-space skipping;
//! - `cells`: the `CellMask`s, which trilinear cells may reach a bound.
//!
//! Not here: what the values mean (transfer functions and field programs, `model`), the
//! skipping structures built from the brick ranges (`accel`), the packet march that reads the
//! values or voxels directly (`render::simd`, through `Dataset::packet_parts`), other file
//! formats (the `vlconvert` tool converts them to `.vlb`), and atomic file output (`output`).
//!
//! The caches a render fills (node values, brick ranges, cell masks) are made once per dataset
//! on first use and then shared; they never change what a dataset is ([`PartialEq`] compares
//! the dimensions, normalisation and voxels).

mod bricks;
mod cells;
mod filter;
mod geometry;
mod gradient;
mod lanes;
#[cfg(test)]
mod tests;
mod trilinear;
mod vlb;

pub use bricks::{Bricks, BRICK};
pub(crate) use cells::CellMask;
use cells::CellMasks;
pub use filter::Filter;
pub(crate) use filter::{bc_abs_sum, box_covered, FACE_TOLERANCE};
pub use geometry::Geometry;
pub use gradient::GradientFilter;
pub(crate) use lanes::Cells8;
pub(crate) use trilinear::CellGradients;
pub(crate) use vlb::header as vlb_header;
pub use vlb::{open_regular, HEADER_LEN, MAGIC};

use crate::error::{err, Error, ErrorCode, Result};

/// The largest number of voxels a dataset may have (2^32; 16 GiB of normalised values).
pub const MAX_VOXELS: u64 = 1 << 32;

/// The most nodes a dataset may have along one axis (2^31 − 1): a sample's cell is found as an
/// i32 index, and a `.vlb` header's u32 could not say 2^32 (with the others 1, the most
/// [`MAX_VOXELS`] would allow).
pub const MAX_AXIS_NODES: usize = i32::MAX as usize;

/// The voxels of a dataset of dimensions `dims`, or `BadDimensions` (its message starting with
/// `what`) for a dimension of 0, one of more than [`MAX_AXIS_NODES`], or more than
/// [`MAX_VOXELS`] voxels in all, in that order.
pub(crate) fn voxels_of(dims: [usize; 3], what: &str) -> Result<u64> {
    let refuse = |why: String| err(ErrorCode::BadDimensions, format!("{what} {dims:?} {why}"));
    if dims.contains(&0) {
        return refuse("contain 0".into());
    }
    if dims.iter().any(|&d| d > MAX_AXIS_NODES) {
        return refuse(format!("exceed {MAX_AXIS_NODES} nodes along an axis"));
    }
    match dims
        .iter()
        .try_fold(1u64, |acc, &d| acc.checked_mul(d as u64))
    {
        Some(n) if n <= MAX_VOXELS => Ok(n),
        _ => refuse(format!("exceed {MAX_VOXELS} voxels")),
    }
}

/// The raw voxels of a dataset, as stored in the file.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
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

/// A loaded dataset: dimensions, raw voxels, normalisation and the normalised node values.
#[derive(Clone, Debug)]
pub struct Dataset {
    dims: [usize; 3],
    a: f32,
    b: f32,
    raw: Voxels,
    /// Normalised node values, x fastest: computed on first use ([`Dataset::values`]). A
    /// render that reads only the raw voxels (the packet march of 8-bit voxels, the brick
    /// ranges, the cell masks, trilinear values and gradients through `table8` or
    /// [`Dataset::table16`]) never makes them: for a scan, four times its voxels' memory,
    /// and a large part of its first image's time.
    values: std::sync::OnceLock<Vec<f32>>,
    /// For 16-bit voxels, the node value of every voxel value (entry v is the normalisation of
    /// v, the same f32 as a node's): made on first use ([`Dataset::table16`]), 256 KiB, so that
    /// the packet march reads 16-bit voxels without the node values' four bytes a voxel.
    table16: std::sync::OnceLock<Box<[f32; 1 << 16]>>,
    /// The node value of every 8-bit voxel value (entry v is the normalisation of v, the same
    /// f32 as a node's), 1 KiB: the node values are made from it, and the trilinear values and
    /// gradients read 8-bit voxels through it while they are not made.
    table8: Box<[f32; 256]>,
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
    /// Where its nodes lie in physical space, when known ([`Geometry`]).
    geometry: Option<Geometry>,
}

impl PartialEq for Dataset {
    /// Datasets are equal when their contents are (caches aside).
    fn eq(&self, other: &Dataset) -> bool {
        self.dims == other.dims
            && self.a.to_bits() == other.a.to_bits()
            && self.b.to_bits() == other.b.to_bits()
            && self.raw == other.raw
            && self.geometry == other.geometry
    }
}

impl Dataset {
    /// Where the dataset's nodes lie in physical space, when known: from the sidecar of the
    /// file it was loaded from, or [`Dataset::with_geometry`].
    pub fn geometry(&self) -> Option<&Geometry> {
        self.geometry.as_ref()
    }

    /// The dataset placed in physical space by `geometry`.
    pub fn with_geometry(mut self, geometry: Geometry) -> Dataset {
        self.geometry = Some(geometry);
        self
    }

    /// A dataset from raw voxels (x fastest, then y, then z) and normalisation a, b. Refused,
    /// with the codes `vlLoad` gives a file of the same header: `BadDimensions` for a
    /// dimension of 0, one of more than [`MAX_AXIS_NODES`] or more than [`MAX_VOXELS`]
    /// voxels, `BadRange` for an a or b that is not finite or a = b; and `BadValue` for
    /// voxels fewer or more than the dimensions call for.
    pub fn new(dims: [usize; 3], raw: Voxels, a: f32, b: f32) -> Result<Dataset> {
        let n = voxels_of(dims, "dataset dimensions")?;
        if n != raw.len() as u64 {
            return err(
                ErrorCode::BadValue,
                format!(
                    "dataset dimensions {dims:?} call for {n} voxels, not {}",
                    raw.len()
                ),
            );
        }
        if !a.is_finite() || !b.is_finite() || a == b {
            return err(
                ErrorCode::BadRange,
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
            geometry: None,
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
            table16: std::sync::OnceLock::new(),
            table8: Box::new(std::array::from_fn(|v| normaliser(a, b)(v as f64))),
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
    /// what the packet march (`render::simd`) reads besides the values or voxels.
    pub(crate) fn packet_parts(&self) -> ([usize; 3], [f64; 3]) {
        (self.strides, self.half_last)
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
    ///
    /// # Panics
    ///
    /// If the node lies outside the grid (i ≥ nx, j ≥ ny or k ≥ nz), as indexing a slice past
    /// its end does: a coordinate past its axis never reads another node.
    #[inline]
    #[track_caller]
    pub fn node(&self, i: usize, j: usize, k: usize) -> f32 {
        let at = self.node_in_grid([i, j, k], "node");
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

    /// [`Dataset::node_index`] of a node of the grid; a panic naming `what` (the public
    /// method called) and the node for one outside it.
    #[inline]
    #[track_caller]
    fn node_in_grid(&self, node: [usize; 3], what: &str) -> usize {
        if node.iter().zip(&self.dims).any(|(c, n)| c >= n) {
            outside_the_grid(what, node, self.dims);
        }
        self.node_index(node)
    }

    /// The normalised node values, x fastest: made on first use (in parallel), then kept.
    ///
    /// # Panics
    ///
    /// Where they cannot be allocated: it unwinds, with the `NoMemory` [`Error`] as the
    /// payload and printing nothing, instead of aborting; [`Dataset::try_values`] returns
    /// that error instead.
    #[inline]
    pub fn values(&self) -> &[f32] {
        or_unwind(self.try_values())
    }

    /// [`Dataset::values`], or `NoMemory` where they cannot be allocated (nothing is kept then:
    /// a later call tries again).
    #[inline]
    pub fn try_values(&self) -> Result<&[f32]> {
        match self.values.get() {
            Some(v) => Ok(v),
            None => self.make_values(),
        }
    }

    /// [`Dataset::try_values`] where they are not made yet (out of line: the renderer reads
    /// the values at every sample of a cubic filter).
    #[cold]
    #[inline(never)]
    fn make_values(&self) -> Result<&[f32]> {
        get_or_try_init(&self.values, || self.compute_values()).map(|v| v.as_slice())
    }

    /// For 16-bit voxels, the node value of each voxel value v at entry v (the node values'
    /// normalisation, so `table16()[raw[i]]` is bit for bit `values()[i]`), made on first use;
    /// `None` for 8-bit voxels.
    pub(crate) fn table16(&self) -> Option<&[f32; 1 << 16]> {
        let Voxels::U16(_) = self.raw else {
            return None;
        };
        Some(self.table16.get_or_init(|| {
            let norm = normaliser(self.a, self.b);
            // (Built on the heap: 256 KiB would not fit every worker thread's stack.)
            let table: Vec<f32> = (0..1u32 << 16).map(|v| norm(v as f64)).collect();
            table.into_boxed_slice().try_into().expect("2^16 entries")
        }))
    }

    /// Whether the node values have been made ([`Dataset::values`]): a render that reads only
    /// the voxels leaves them unmade.
    #[doc(hidden)]
    pub fn values_made(&self) -> bool {
        self.values.get().is_some()
    }

    /// The node values of the raw voxels ([`normaliser`]), on as many threads as the library's
    /// pool has ([`crate::pool::width`]: no pool is built for them), but on threads of their
    /// own ([`crate::pool::fill`]), which also make the values' memory (written once, not
    /// filled first). Not on the pool's: made from inside a render's parallel loop (a first
    /// read there), a rayon job that waits for its parts may run another part of the render
    /// meanwhile, which would ask for the values again, in the thread that is making them.
    /// Where threads cannot be started the calling thread makes them all.
    fn compute_values(&self) -> Result<Vec<f32>> {
        let norm = normaliser(self.a, self.b);
        let len = self.raw.len();
        let mut values = crate::num::try_with_capacity::<f32>(len, "a dataset's node values")?;
        let threads = crate::pool::width().clamp(1, 64);
        let chunk = len.div_ceil(threads).max(1 << 16);
        let (lut, raw) = (&*self.table8, &self.raw);
        crate::pool::fill(
            &mut values.spare_capacity_mut()[..len],
            chunk,
            threads,
            |out, from| match raw {
                Voxels::U8(v) => {
                    for (o, &x) in out.iter_mut().zip(&v[from..]) {
                        o.write(lut[x as usize]);
                    }
                }
                Voxels::U16(v) => {
                    for (o, &x) in out.iter_mut().zip(&v[from..]) {
                        o.write(norm(x as f64));
                    }
                }
            },
        );
        // SAFETY: `fill` wrote every one of the first `len` elements of the capacity: each
        // part's zip runs to the part's end, as the voxels from its start are at least as
        // many (a panic in a part would have unwound out of `fill`, before this line).
        unsafe { values.set_len(len) };
        Ok(values)
    }

    /// The raw value of node (i, j, k) before normalisation.
    ///
    /// # Panics
    ///
    /// If the node lies outside the grid, as [`Dataset::node`] does.
    #[track_caller]
    pub fn raw_node(&self, i: usize, j: usize, k: usize) -> f64 {
        self.raw.get(self.node_in_grid([i, j, k], "raw_node"))
    }
}

/// The panic of a node read outside the grid ([`Dataset::node`], [`Dataset::raw_node`]).
#[cold]
#[inline(never)]
#[track_caller]
fn outside_the_grid(what: &str, [i, j, k]: [usize; 3], [nx, ny, nz]: [usize; 3]) -> ! {
    panic!("Dataset::{what}: node ({i}, {j}, {k}) lies outside the {nx}×{ny}×{nz} grid")
}

/// `cell.get_or_init(init)` for an `init` that may fail: its error is returned and the cell
/// left empty (a later call tries again). (The failure leaves `get_or_init` by unwinding with
/// `resume_unwind`, which runs no panic hook and prints nothing, and is caught here; threads
/// waiting on the cell meanwhile then run their own `init`.)
fn get_or_try_init<T>(
    cell: &std::sync::OnceLock<T>,
    init: impl FnOnce() -> Result<T>,
) -> Result<&T> {
    if let Some(v) = cell.get() {
        return Ok(v);
    }
    struct Failed(Error);
    let run = std::panic::AssertUnwindSafe(|| {
        cell.get_or_init(|| {
            init().unwrap_or_else(|e| std::panic::resume_unwind(Box::new(Failed(e))))
        })
    });
    match std::panic::catch_unwind(run) {
        Ok(v) => Ok(v),
        Err(payload) => match payload.downcast::<Failed>() {
            Ok(f) => Err(f.0),
            Err(other) => std::panic::resume_unwind(other),
        },
    }
}

/// The value of a cache the renderer reads through an infallible accessor ([`Dataset::values`],
/// [`Dataset::bricks`], [`Dataset::cells_above`], [`CellMask::words32`]), or, where it could not
/// be allocated, an unwind carrying the error ([`crate::error::raise`]) that the render's panic
/// boundary ([`crate::error::catch`]) returns as it is (`NoMemory`), instead of the process's
/// abort. Nothing is printed.
pub(crate) fn or_unwind<T>(r: Result<T>) -> T {
    r.unwrap_or_else(|e| crate::error::raise(e))
}
