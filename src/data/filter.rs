//! Interpolation filters and the generic paths of values and gradients.
//!
//! Filters ([`Filter`]): nearest node, trilinear, and the Mitchell–Netravali BC family of
//! tricubic filters (B = 0, C = 0.5 is Catmull–Rom, the default; B = 1, C = 0 the cubic B-spline).
//! Values and gradients use the same filter: the gradient at a point is the filter applied to the
//! central-difference gradients of the nodes (one-sided at the faces), so a linear field has an
//! exact gradient everywhere. A dataset is a bounded field: 0, with a gradient of 0, outside
//! [0, 1]^3 ([`Dataset::covers`]); points within [`FACE_TOLERANCE`] outside a face (where
//! round-off puts a point computed on it) take the value at the face.
//!
//! This file owns the filters' definitions (the BC kernel and its bound), the public entry points
//! [`Dataset::sample`] and [`Dataset::gradient`], the generic filter every path must agree with
//! ([`Dataset::filter`]), and the cubic filter's interior fast paths, which give the generic
//! filter's value bit for bit. The trilinear filter's fast paths, which the entry points take
//! first, are the `trilinear` module's; the values of eight points at once are the `lanes`
//! module's.

use super::{CellGradients, Dataset};
use crate::error::{err, ErrorCode, Result};
use crate::types::Interpolation;

/// An interpolation filter with its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[non_exhaustive]
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
    /// The filter for an interpolation type and the cubic parameters (B, C) in force:
    /// `BadValue` where B or C is not finite (whatever the type, as `vlCubicFilter` refuses
    /// them before any interpolation is chosen).
    pub fn new(kind: Interpolation, cubic: (f32, f32)) -> Result<Filter> {
        if !(cubic.0.is_finite() && cubic.1.is_finite()) {
            return err(
                ErrorCode::BadValue,
                format!(
                    "cubic filter B = {}, C = {}: both must be finite",
                    cubic.0, cubic.1
                ),
            );
        }
        Ok(Filter::of_settings(kind, cubic))
    }

    /// [`Filter::new`] of a library's settings, whose B and C `vlCubicFilter` has checked.
    pub(crate) fn of_settings(kind: Interpolation, cubic: (f32, f32)) -> Filter {
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

/// Whether B and C of a BC-spline are both finite: a filter of others reads 0 everywhere
/// ([`Dataset::sample`], [`Dataset::gradient`]), where its weights would make NaN.
#[inline]
pub(crate) fn bc_finite(b: f32, c: f32) -> bool {
    b.is_finite() && c.is_finite()
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

/// The BC-spline kernel's two cubics (|x| < 1, inner; 1 ≤ |x| < 2, outer) as coefficients,
/// each already divided by 6, evaluated by Horner's rule: [`bc_kernel`] (to rounding) without
/// its branches and divisions, for the four taps around a point (the cubic value filter's
/// weights, `Cubics::weights`, and the cubic gradient's taps, `gradient::AxisTaps`).
pub(crate) struct Cubics {
    inner: [f64; 3],
    outer: [f64; 4],
}

impl Cubics {
    pub(crate) fn new(b: f64, c: f64) -> Cubics {
        let sixth = 1.0 / 6.0;
        Cubics {
            // x³, x², 1 (no x term).
            inner: [
                12.0 - 9.0 * b - 6.0 * c,
                -18.0 + 12.0 * b + 6.0 * c,
                6.0 - 2.0 * b,
            ]
            .map(|k| k * sixth),
            // x³, x², x, 1.
            outer: [
                -b - 6.0 * c,
                6.0 * b + 30.0 * c,
                -12.0 * b - 48.0 * c,
                8.0 * b + 24.0 * c,
            ]
            .map(|k| k * sixth),
        }
    }

    /// The kernel and its derivative at x in [0, 1] (the inner cubic).
    #[inline(always)]
    pub(crate) fn inner(&self, x: f64) -> (f64, f64) {
        let [a, b, c] = self.inner;
        ((a * x + b) * (x * x) + c, (3.0 * a * x + 2.0 * b) * x)
    }

    /// The kernel and its derivative at x in [1, 2] (the outer cubic).
    #[inline(always)]
    pub(crate) fn outer(&self, x: f64) -> (f64, f64) {
        let [a, b, c, d] = self.outer;
        (
            ((a * x + b) * x + c) * x + d,
            (3.0 * a * x + 2.0 * b) * x + c,
        )
    }

    /// The weights k(t + 1), k(t), k(1 − t), k(2 − t) of taps i − 1 … i + 2 of a point at
    /// t ∈ [0, 1) past node i.
    #[inline(always)]
    pub(crate) fn weights(&self, t: f64) -> [f64; 4] {
        let [a, b, c] = self.inner;
        let [p, q, r, s] = self.outer;
        let inner = |x: f64| (a * x + b) * (x * x) + c;
        let outer = |x: f64| ((p * x + q) * x + r) * x + s;
        [outer(t + 1.0), inner(t), inner(1.0 - t), outer(2.0 - t)]
    }
}

/// ⌊x⌋ of a continuous index (x ≥ 0, [`Dataset::index`]: its truncation, without a call to
/// libm's `floor`; NaN and negative x by `floor`).
#[inline(always)]
pub(crate) fn floor(x: f64) -> i64 {
    if x >= 0.0 {
        x as i64
    } else {
        x.floor() as i64
    }
}

/// How far outside [0, 1] an object coordinate may lie and still read the dataset (at its
/// face): 2⁻²⁰, far above the round-off of a point computed on a face (from a ray in f64,
/// then rounded to f32: at most an f32 ulp of the coordinate) and far below a node's spacing
/// (2⁻²⁰ of the cube is 5·10⁻⁴ of a voxel of a 512-node axis).
pub(crate) const FACE_TOLERANCE: f32 = 1.0 / (1u32 << 20) as f32;

/// Whether object coordinate `x` lies in [−[`FACE_TOLERANCE`], 1 + [`FACE_TOLERANCE`]]
/// (NaN does not).
#[inline(always)]
fn covered(x: f32) -> bool {
    (-FACE_TOLERANCE..=1.0 + FACE_TOLERANCE).contains(&x)
}

/// Whether the dataset covers every sample of an object whose box is [min, max] in object
/// space: the box lies inside [0, 1]³ (its points, computed in f64 up to round-off and rounded
/// to f32, are then covered), so that a march need not test its samples.
pub(crate) fn box_covered(min: glam::DVec3, max: glam::DVec3) -> bool {
    min.cmpge(glam::DVec3::ZERO).all() && max.cmple(glam::DVec3::ONE).all()
}

impl Dataset {
    /// Whether object point `p` reads the dataset: every coordinate in [0, 1] up to
    /// `FACE_TOLERANCE`. Elsewhere the dataset is 0 and so is its gradient (a dataset is a
    /// bounded field, as the paper's fields are: beyond its last node nothing continues it).
    #[inline(always)]
    pub fn covers(&self, p: [f32; 3]) -> bool {
        covered(p[0]) & covered(p[1]) & covered(p[2])
    }

    /// The continuous index of object coordinate `p` along axis `axis`, clamped to the grid
    /// (NaN → 0).
    #[inline]
    pub(super) fn index(&self, p: f32, axis: usize) -> f64 {
        let last = self.last[axis];
        let u = p as f64 * last;
        // max/min in this order map NaN to 0.
        u.max(0.0).min(last)
    }

    /// The interpolated normalised value at object coordinates `p`, in [0, 1]: 0 where the
    /// dataset does not [cover](Dataset::covers) `p`, and 0 everywhere under a
    /// [`Filter::Cubic`] whose B or C is not finite (one [`Filter::new`] refuses).
    ///
    /// # Panics
    ///
    /// A filter other than [`Filter::Trilinear`] reads the node values ([`Dataset::values`]):
    /// where they are not made yet and cannot be allocated, it unwinds as that does
    /// (the library's `vlSample` returns the `NoMemory` instead).
    #[inline]
    pub fn sample(&self, p: [f32; 3], filter: Filter) -> f32 {
        if filter == Filter::Trilinear {
            return self.trilinear(p);
        }
        self.sample_generic(p, filter)
    }

    #[inline(never)]
    fn sample_generic(&self, p: [f32; 3], filter: Filter) -> f32 {
        let finite = match filter {
            Filter::Cubic { b, c } => bc_finite(b, c),
            _ => true,
        };
        if !self.covers(p) || !finite {
            return 0.0;
        }
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
    pub(super) fn cubic_interior(&self, u: [f64; 3], b: f64, c: f64) -> Option<f64> {
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
    pub(super) fn cubic_derivative_interior(
        &self,
        u: [f64; 3],
        b: f64,
        c: f64,
        axis: usize,
    ) -> Option<f64> {
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
        let k = Cubics::new(b, c);
        let mut i0 = [0usize; 3];
        let mut w = [[0.0f64; 4]; 3];
        for a in 0..3 {
            let f = floor(u[a]) as f64;
            // Taps f − 1 … f + 2; along the derivative's axis their neighbours f − 2 … f + 3.
            let margin = if derivative_axis == Some(a) { 1.0 } else { 0.0 };
            if f < 1.0 + margin || f + 2.0 + margin > (self.dims[a] - 1) as f64 {
                return None;
            }
            i0[a] = f as usize - 1;
            w[a] = k.weights(u[a] - f);
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
    /// node gradients interpolated with `filter`: 0 where the dataset does not
    /// [cover](Dataset::covers) `p`, and 0 everywhere under a [`Filter::Cubic`] whose B or C
    /// is not finite (whose values [`Dataset::sample`] gives as 0).
    ///
    /// # Panics
    ///
    /// Under a [`Filter::Cubic`] it reads the node values ([`Dataset::values`]): where they are
    /// not made yet and cannot be allocated, it unwinds as that does.
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
    pub(super) fn gradient_generic(&self, p: [f32; 3], filter: Filter) -> [f64; 3] {
        // (The interior paths never see such a point: its clamped cell lies on a face.)
        let finite = match filter {
            Filter::Cubic { b, c } => bc_finite(b, c),
            _ => true,
        };
        if !self.covers(p) || !finite {
            return [0.0; 3];
        }
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

    /// The derivative along `axis` at a node, per grid step: central inside, one-sided at faces.
    pub(super) fn node_derivative(&self, i: usize, j: usize, k: usize, axis: usize) -> f64 {
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
    pub(super) fn filter(
        &self,
        u: [f64; 3],
        filter: Filter,
        f: impl Fn(usize, usize, usize) -> f64,
    ) -> f64 {
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
                let k = Cubics::new(b, c);
                let taps = |x: f64, n: usize| {
                    let i0 = floor(x);
                    let t = x - i0 as f64;
                    let at = |m: i64| (i0 - 1 + m).clamp(0, n as i64 - 1) as usize;
                    let idx = [at(0), at(1), at(2), at(3)];
                    (idx, k.weights(t))
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
