//! Pre-integrated transfer functions (Engel, Kraus and Ertl 2001) for the direct-shading
//! programs of the lean kernel ([`DirectShading`]: a dataset's value through an opacity table
//! and a colour table). A *slab* of a ray runs between two consecutive samples; with the
//! dataset's value taken as linear along it, from `vf` at its front to `vb` at its back, its
//! opacity and colour are the emission–absorption integral
//!
//! ```text
//! α = 1 − exp(−κ ∫₀¹ σ(v(s)) ds),   C = κ ∫₀¹ c(v(s)) σ(v(s)) exp(−κ ∫₀ˢ σ(v(u)) du) ds,
//! ```
//!
//! where `v(s) = vf + (vb − vf)·s`, κ is the slab's length in reference lengths, `σ(v) =
//! −ln(1 − o(v))` the extinction of the opacity table's value o (an opacity per reference
//! length, as `CObj::alpha` reads it) and c the colour table's colour; `C` is the
//! opacity-weighted (premultiplied) colour. The integral is evaluated by cutting the slab into
//! sub-slabs of at most one table cell of value each, each taken at its midpoint value with the
//! exact transmittance `(1 − o)^(κ/M)` of its length: a constant value (`vf = vb`) is one
//! sub-slab, the midpoint rule's value exactly.
//!
//! [`PreIntegrated`] holds the tables of one object: the slab of the step's length, of half and
//! of a quarter of it (the halves `integrate::preint` cuts where the data bends within a slab)
//! for `TABLE_NODES`² (front, back) value pairs, read with bilinear interpolation; slabs of
//! another length (the ends of a ray's interval in the box) are integrated on the spot
//! ([`PreIntegrated::integrate`]). Built in O(n³) operations on n nodes, fewer where the
//! opacity table is 0 or 1 over part of its range, by the first compilation of a scene that
//! needs them, and kept for later ones (`compile::Caches`). The slabs that use them are
//! composited by `integrate::preint` (for its scalar march and for the packet march of
//! `simd::preint`); the transfer functions themselves are `model`'s.

use crate::data::or_unwind;
use crate::error::ErrorCode;
use crate::render::kernel::DirectShading;
use rayon::prelude::*;

/// Table nodes per axis (value spacing 1/(n − 1)): 128² entries of five f32, 320 KiB a table,
/// built with the compiled scene in O(n³) operations (`docs/accuracy.md`, pre-integration).
pub(super) const TABLE_NODES: usize = 128;

/// How many times a slab may be halved where the data is not linear along it (see
/// `integrate::preint`): down to a quarter of the step. A table per level.
pub(super) const REFINE_LEVELS: u32 = 2;

/// A slab is halved where the value at its middle differs from the mean of its ends by more
/// than this: half a table cell of value, below which the table cannot tell the two apart.
pub(super) const REFINE_TOLERANCE: f32 = 0.5 / (TABLE_NODES - 1) as f32;

/// The pre-integration tables of one object's transfer functions (see the module
/// documentation).
pub(crate) struct PreIntegrated {
    /// The transfer functions, for slabs integrated on the spot and constant slabs.
    pub(super) shading: DirectShading,
    /// Per level l (0 to [`REFINE_LEVELS`]), per (front node i, back node j), at
    /// `i·TABLE_NODES + j`: the [`Slab`] of 1/2^l of the step's length from value i/(n − 1) to
    /// j/(n − 1).
    tables: Vec<Vec<Slab>>,
}

/// One sub-slab's transfer-function values: ln(1 − o) (−∞ where o = 1) and the colour.
#[derive(Clone, Copy)]
struct Cell {
    ln_t: f64,
    rgb: [f64; 3],
}

impl Cell {
    /// The transfer functions at value `v` (in [0, 1]).
    fn at(shading: &DirectShading, v: f32) -> Cell {
        let (o, rgb) = shading.opacity_colour(v);
        let rgb = rgb.unwrap_or([0.0; 3]).map(|x| x as f64);
        let t = 1.0 - (o as f64).clamp(0.0, 1.0);
        Cell { ln_t: t.ln(), rgb }
    }
}

impl PreIntegrated {
    /// The tables of `shading` for slabs `kappa` reference lengths long (κ > 0 and finite)
    /// and their halves and quarters. Unwinds with `NoMemory` where a table cannot be
    /// allocated (as the renderer's other caches, see [`or_unwind`]).
    pub(super) fn new(shading: &DirectShading, kappa: f64) -> PreIntegrated {
        let tables = (0..=REFINE_LEVELS)
            .map(|l| table(shading, kappa / (1u32 << l) as f64))
            .collect();
        PreIntegrated {
            shading: shading.clone(),
            tables,
        }
    }

    /// The [`Slab`] of a slab of level `level`'s length (1/2^level of the step) from value
    /// `vf` to value `vb` (both in [0, 1]): the table's bilinear interpolation.
    #[inline]
    pub(super) fn lookup(&self, level: u32, vf: f32, vb: f32) -> Slab {
        let table = &self.tables[level as usize];
        let n = TABLE_NODES;
        let last = (n - 1) as f32;
        let (x, y) = (vf.clamp(0.0, 1.0) * last, vb.clamp(0.0, 1.0) * last);
        // (Clamped so that i + 1 and j + 1 are nodes; x − i is then in [0, 1].)
        let (i, j) = ((x as usize).min(n - 2), (y as usize).min(n - 2));
        let (fx, fy) = (x - i as f32, y - j as f32);
        let at = |a: usize, b: usize| table[a * n + b];
        let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
        std::array::from_fn(|k| {
            let lo = a[k] + fy * (b[k] - a[k]);
            let hi = c[k] + fy * (d[k] - c[k]);
            lo + fx * (hi - lo)
        })
    }

    /// The [`Slab`] of a slab `kappa` reference lengths long from value `vf`
    /// to value `vb`, integrated on the spot: sub-slabs of at most one table cell of value
    /// each (at least one), at their midpoint values. The table's entries are this integral at
    /// its nodes.
    pub(super) fn integrate(&self, vf: f32, vb: f32, kappa: f64) -> Slab {
        let (vf, vb) = (vf.clamp(0.0, 1.0) as f64, vb.clamp(0.0, 1.0) as f64);
        let span = vb - vf;
        // ⌈|span|·(n − 1)⌉ sub-slabs, at most n − 1 (the span is at most 1); a constant slab is
        // one.
        let m = ((span.abs() * (TABLE_NODES - 1) as f64).ceil() as usize).clamp(1, TABLE_NODES - 1);
        // (Each sub-slab read as the composite reaches it: none past an opaque one, and no
        // buffer of them.)
        composite(
            m,
            (0..m).map(|s| {
                let v = vf + span * ((s as f64 + 0.5) / m as f64);
                let c = Cell::at(&self.shading, v as f32);
                (s, transmit_ln(c.ln_t, kappa, m as f64), c.rgb)
            }),
        )
    }
}

/// The table of slabs `kappa` reference lengths long (see [`PreIntegrated`]): rows built in
/// parallel, each entry independently, so the same bits on any thread count.
fn table(shading: &DirectShading, kappa: f64) -> Vec<Slab> {
    let n = TABLE_NODES;
    let mut table: Vec<Slab> = Vec::new();
    or_unwind(
        table
            .try_reserve_exact(n * n)
            .map_err(|_| crate::error::Error::new(ErrorCode::NoMemory, "pre-integration table")),
    );
    table.resize(n * n, [0.0; 5]);
    let h = 1.0 / (n - 1) as f64;
    // The transfer functions at the nodes (the diagonal) and at the cells' midpoints.
    let nodes: Vec<Cell> = (0..n)
        .map(|i| Cell::at(shading, (i as f64 * h) as f32))
        .collect();
    let mids: Vec<Cell> = (0..n - 1)
        .map(|c| Cell::at(shading, ((c as f64 + 0.5) * h) as f32))
        .collect();
    // Per slab of d cells (at d·(n − 1) + c), cell c's sub-slab transmittance for a length κ/d.
    let trans: Vec<f64> = (0..n * (n - 1))
        .map(|k| {
            let (d, c) = (k / (n - 1), k % (n - 1));
            if d == 0 {
                0.0
            } else {
                transmit_ln(mids[c].ln_t, kappa, d as f64)
            }
        })
        .collect();
    // The cells lo … hi − 1 hold every cell of positive opacity: the others are clear.
    let lo = mids.iter().position(|c| c.ln_t != 0.0).unwrap_or(n - 1);
    let hi = mids
        .iter()
        .rposition(|c| c.ln_t != 0.0)
        .map_or(lo, |c| c + 1);
    table.par_chunks_mut(n).enumerate().for_each(|(i, row)| {
        for (j, e) in row.iter_mut().enumerate() {
            *e = if i == j {
                constant(&nodes[i], kappa)
            } else if i < j {
                // Up: cells i … j − 1 in increasing order (cell c is sub-slab c − i).
                let d = j - i;
                let cells = i.max(lo)..j.min(hi);
                composite(
                    d,
                    cells.map(|c| (c - i, trans[d * (n - 1) + c], mids[c].rgb)),
                )
            } else {
                // Down: cells i − 1 … j in decreasing order (cell c is sub-slab i − 1 − c).
                let d = i - j;
                let cells = (j.max(lo)..i.min(hi)).rev();
                composite(
                    d,
                    cells.map(|c| (i - 1 - c, trans[d * (n - 1) + c], mids[c].rgb)),
                )
            };
        }
    });
    table
}

/// The [`Slab`] of a constant value (transfer-function values `cell`) over `kappa` reference
/// lengths: [`absorbed`] of its optical depth k = −ln t.
fn constant(cell: &Cell, kappa: f64) -> Slab {
    let (a, depth) = absorbed(-(cell.ln_t * kappa));
    [
        a as f32,
        (a * cell.rgb[0]) as f32,
        (a * cell.rgb[1]) as f32,
        (a * cell.rgb[2]) as f32,
        depth as f32,
    ]
}

/// The α, 1 − e^(−k), of a constant medium of optical depth k (+∞ where it is opaque) and its
/// depth ∫₀¹ s·k·e^(−k·s) ds = (1 − (1 + k)·e^(−k))/k (over α, where it is lit), without the
/// cancellation of those differences at small k, which made the depth of a nearly clear
/// medium noise (its ratio to α −27 or 8·10³ at k = 10⁻¹⁵, not ½): α by `exp_m1`, the depth
/// below k = 10⁻³ by its series k/2 − k²/3 + k³/8 (the next term, k⁴/30, under 10⁻¹⁰ of
/// it). An opaque medium is lit at its front (depth 0), a clear one (k = 0) adds nothing.
pub(super) fn absorbed(k: f64) -> (f64, f64) {
    if k.is_nan() || k <= 0.0 {
        return (0.0, 0.0);
    }
    if k == f64::INFINITY {
        return (1.0, 0.0);
    }
    let a = -(-k).exp_m1();
    let depth = if k < 1e-3 {
        k * (0.5 - k * (1.0 / 3.0 - k * 0.125))
    } else {
        (a - k * (-k).exp()) / k
    };
    (a, depth)
}

/// The transmittance `exp(ln_t·κ/m)` of a sub-slab `κ/m` reference lengths long through a
/// medium of per-reference transmittance `exp(ln_t)` (0 where that is 0: `ln_t` = −∞).
#[inline]
fn transmit_ln(ln_t: f64, kappa: f64, m: f64) -> f64 {
    if ln_t == f64::NEG_INFINITY {
        0.0
    } else {
        (ln_t * (kappa / m)).exp()
    }
}

/// A slab's α, premultiplied colour (r, g, b) and premultiplied depth: the weighted sum of
/// where in the slab (0 at its front, 1 at its back) its light comes from, each sub-slab
/// counted at its middle with its compositing weight; over α, the depth where the slab is
/// lit (`integrate::preint`).
pub(super) type Slab = [f32; 5];

/// The front-to-back composite of `m` sub-slabs of equal length, given in order as (position
/// in the slab, transmittance, colour): the [`Slab`], as f32. Sub-slabs left out are clear
/// (transmittance 1: they add nothing); those after the transmittance reaches 0 add nothing
/// either and are not read.
#[inline]
fn composite(m: usize, cells: impl Iterator<Item = (usize, f64, [f64; 3])>) -> Slab {
    let mut t = 1.0f64;
    let mut col = [0.0f64; 4];
    let inv = 1.0 / m as f64;
    for (s, tr, rgb) in cells {
        if t == 0.0 {
            break;
        }
        let w = t * (1.0 - tr);
        col[0] += w * rgb[0];
        col[1] += w * rgb[1];
        col[2] += w * rgb[2];
        col[3] += w * ((s as f64 + 0.5) * inv);
        t *= tr;
    }
    [
        (1.0 - t) as f32,
        col[0] as f32,
        col[1] as f32,
        col[2] as f32,
        col[3] as f32,
    ]
}
