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
//! [`PreIntegrated`] holds the table of one object: the slab of the step's length for
//! `TABLE_NODES`² (front, back) value pairs, read with bilinear interpolation; slabs of another
//! length (the ends of a ray's interval in the box) are integrated on the spot
//! ([`PreIntegrated::integrate`]). Built once per compiled scene, in O(n³) operations on n
//! nodes. The march that uses it is `integrate::preint`'s; the tables themselves are `model`'s.

use crate::data::or_unwind;
use crate::error::ErrorCode;
use crate::render::kernel::DirectShading;

/// Table nodes per axis (value spacing 1/(n − 1)): 128² entries of five f32, 320 KiB, built
/// with the compiled scene in O(n³) operations (`docs/accuracy.md`, pre-integration).
pub(super) const TABLE_NODES: usize = 128;

/// The pre-integration table of one object's transfer functions (see the module
/// documentation).
pub(crate) struct PreIntegrated {
    /// The transfer functions, for slabs integrated on the spot and constant slabs.
    pub(super) shading: DirectShading,
    /// Per (front node i, back node j), at `i·TABLE_NODES + j`: the [`Slab`] of the step's
    /// length from value i/(n − 1) to j/(n − 1).
    table: Vec<Slab>,
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
    /// The table of `shading` for slabs `kappa` reference lengths long (κ > 0 and finite).
    /// Unwinds with `NoMemory` where the table cannot be allocated (as the renderer's other
    /// caches, see [`or_unwind`]).
    pub(super) fn new(shading: &DirectShading, kappa: f64) -> PreIntegrated {
        let n = TABLE_NODES;
        let mut table: Vec<Slab> = Vec::new();
        or_unwind(
            table.try_reserve_exact(n * n).map_err(|_| {
                crate::error::Error::new(ErrorCode::NoMemory, "pre-integration table")
            }),
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
        // Per slab of d cells, each cell's sub-slab transmittance for a length κ/d.
        let mut trans = vec![0.0f64; n - 1];
        for i in 0..n {
            let diag = &nodes[i];
            let t = transmit_ln(diag.ln_t, kappa, 1.0);
            let a = 1.0 - t;
            // The constant slab's depth: ∫₀¹ s·k·e^(−k·s) ds = (1 − t)/k − t for k = −ln t.
            let k = -(diag.ln_t * kappa);
            let depth = if a > 0.0 && k.is_finite() {
                a / k - t
            } else {
                0.0
            };
            table[i * n + i] = [
                a as f32,
                (a * diag.rgb[0]) as f32,
                (a * diag.rgb[1]) as f32,
                (a * diag.rgb[2]) as f32,
                depth as f32,
            ];
        }
        for d in 1..n {
            for (tr, c) in trans.iter_mut().zip(&mids) {
                *tr = transmit_ln(c.ln_t, kappa, d as f64);
            }
            for i in 0..n - d {
                // Up: cells i … i + d − 1 in increasing order; down: the same cells reversed.
                table[i * n + i + d] = composite(d, (i..i + d).map(|c| (trans[c], &mids[c].rgb)));
                table[(i + d) * n + i] =
                    composite(d, (i..i + d).rev().map(|c| (trans[c], &mids[c].rgb)));
            }
        }
        PreIntegrated {
            shading: shading.clone(),
            table,
        }
    }

    /// The [`Slab`] of a slab of the table's length from value `vf` to
    /// value `vb` (both in [0, 1]): the table's bilinear interpolation.
    #[inline]
    pub(super) fn lookup(&self, vf: f32, vb: f32) -> Slab {
        let n = TABLE_NODES;
        let last = (n - 1) as f32;
        let (x, y) = (vf.clamp(0.0, 1.0) * last, vb.clamp(0.0, 1.0) * last);
        // (Clamped so that i + 1 and j + 1 are nodes; x − i is then in [0, 1].)
        let (i, j) = ((x as usize).min(n - 2), (y as usize).min(n - 2));
        let (fx, fy) = (x - i as f32, y - j as f32);
        let at = |a: usize, b: usize| self.table[a * n + b];
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
        let cells: Vec<(f64, [f64; 3])> = (0..m)
            .map(|s| {
                let v = vf + span * ((s as f64 + 0.5) / m as f64);
                let c = Cell::at(&self.shading, v as f32);
                (transmit_ln(c.ln_t, kappa, m as f64), c.rgb)
            })
            .collect();
        composite(m, cells.iter().map(|(t, rgb)| (*t, rgb)))
    }
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

/// The front-to-back composite of `m` sub-slabs of equal length (transmittance, colour), in
/// order: the [`Slab`], as f32.
#[inline]
fn composite<'a>(m: usize, cells: impl Iterator<Item = (f64, &'a [f64; 3])>) -> Slab {
    let mut t = 1.0f64;
    let mut col = [0.0f64; 4];
    let inv = 1.0 / m as f64;
    for (s, (tr, rgb)) in cells.enumerate() {
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
