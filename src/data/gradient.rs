//! The gradient filters: how a dataset field's gradient, which lights its samples, is
//! reconstructed from the nodes.
//!
//! [`GradientFilter::Nodes`] is the paper's: central differences at the nodes (one-sided on the
//! faces), interpolated with the dataset's value filter (`filter` and `trilinear` modules). Under
//! the trilinear filter that gradient is only continuous: its direction bends at every cell face,
//! and lit iso-surfaces of scanned data show it as fine grid-aligned hatching.
//! [`GradientFilter::Cubic`] is the exact gradient of the separable Mitchell–Netravali BC-spline
//! reconstruction of the node values: along each axis the derivative kernel k′, along the other
//! two the kernel k, over the 4×4×4 nodes around the point. Its gradient is as smooth as the
//! spline's derivative (continuous for every B and C, continuously differentiable for the cubic
//! B-spline, B = 1, C = 0), whatever filter the values use. The taps outside the grid are the
//! linear extrapolation of the two nodes nearest the face along that axis (node −1 is
//! 2·v₀ − v₁, node n is 2·v_(n−1) − v_(n−2), and so on). The BC-splines with B + 2C = 1
//! (Catmull–Rom, the B-spline, Mitchell's B = C = ⅓) reproduce linear functions, and quadratics
//! up to a constant: under them a linear field's gradient is exact everywhere, faces included,
//! and a quadratic field's wherever every tap is a node. Other B and C reproduce only constants.
//!
//! This file owns [`GradientFilter`], the derivative kernel and the cubic gradient; not the
//! value filters, the paper's gradient paths and their caches (`filter`, `trilinear`), or which
//! render path calls which (`render`).

use super::filter::{bc_finite, bc_kernel, floor, Cubics};
use super::{CellGradients, Dataset, Filter};

/// How a dataset field's gradient (its samples' normals) is reconstructed from the nodes
/// (`Library::gradient_filter`, `vlGradientFilter`): captured with the interpolation at
/// `vlDataset`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[non_exhaustive]
pub enum GradientFilter {
    /// The paper's (the default): central differences at the nodes, one-sided on the faces,
    /// interpolated with the dataset's value filter.
    #[default]
    Nodes,
    /// The exact gradient of the BC-spline reconstruction of the node values with parameters
    /// B and C (B = 1, C = 0: the cubic B-spline's, the smoothest; B = 0, C = ½: Catmull–Rom's).
    Cubic {
        /// Mitchell–Netravali B.
        b: f32,
        /// Mitchell–Netravali C.
        c: f32,
    },
}

/// The derivative k′(x) of the BC-spline kernel [`bc_kernel`], support |x| < 2.
pub(crate) fn bc_derivative(x: f64, b: f64, c: f64) -> f64 {
    let (s, x) = (x.signum(), x.abs());
    let d = if x < 1.0 {
        (3.0 * (12.0 - 9.0 * b - 6.0 * c) * x * x + 2.0 * (-18.0 + 12.0 * b + 6.0 * c) * x) / 6.0
    } else if x < 2.0 {
        (3.0 * (-b - 6.0 * c) * x * x + 2.0 * (6.0 * b + 30.0 * c) * x + (-12.0 * b - 48.0 * c))
            / 6.0
    } else {
        0.0
    };
    s * d
}

/// One axis of the cubic gradient: the first node of the window of at most four nodes its
/// taps reach (after folding the outside ones in), the window's length, and per node of the
/// window the weight of its value (k) and of its derivative (k′, per grid step).
struct AxisTaps {
    first: usize,
    len: usize,
    value: [f64; 4],
    slope: [f64; 4],
}

impl AxisTaps {
    /// The taps at continuous index `u` (in [0, n − 1]) of an axis of `n` nodes, the kernel's
    /// cubics `k`.
    #[inline(always)]
    fn new(u: f64, n: usize, b: f64, c: f64, k: &Cubics) -> AxisTaps {
        if n == 1 {
            // Constant along the axis: the value is the node's, the slope 0.
            return AxisTaps {
                first: 0,
                len: 1,
                value: [1.0, 0.0, 0.0, 0.0],
                slope: [0.0; 4],
            };
        }
        let f = floor(u);
        let t = u - f as f64;
        let last = n as i64 - 1;
        if f >= 1 && f + 2 <= last {
            // Every tap a node: taps f − 1 … f + 2 at distances t + 1, t, 1 − t, 2 − t (the
            // derivative odd: negative on the far side), each its own node's weight.
            let (k0, d0) = k.outer(t + 1.0);
            let (k1, d1) = k.inner(t);
            let (k2, d2) = k.inner(1.0 - t);
            let (k3, d3) = k.outer(2.0 - t);
            return AxisTaps {
                first: (f - 1) as usize,
                len: 4,
                value: [k0, k1, k2, k3],
                slope: [d0, d1, -d2, -d3],
            };
        }
        // The window: four nodes around the taps f − 1 … f + 2, moved inside the grid (fewer
        // for a grid of fewer nodes); every in-grid tap and both nodes an outside tap folds
        // onto (0 and 1, or n − 2 and n − 1) lie in it.
        let len = n.min(4);
        let first = (f - 1).clamp(0, n as i64 - len as i64);
        let mut taps = AxisTaps {
            first: first as usize,
            len,
            value: [0.0; 4],
            slope: [0.0; 4],
        };
        for m in 0..4 {
            let i = f - 1 + m;
            let x = t - (m as f64 - 1.0);
            let (k, dk) = (bc_kernel(x, b, c), bc_derivative(x, b, c));
            // Node i as a combination of nodes: itself inside the grid, else the linear
            // extrapolation of the two nodes nearest that face.
            let parts: [(i64, f64); 2] = if i < 0 {
                [(0, 1.0 - i as f64), (1, i as f64)]
            } else if i > last {
                let m = (i - last) as f64;
                [(last, 1.0 + m), (last - 1, -m)]
            } else {
                [(i, 1.0), (i, 0.0)]
            };
            for (node, share) in parts {
                let at = (node - first) as usize;
                taps.value[at] += share * k;
                taps.slope[at] += share * dk;
            }
        }
        taps
    }
}

impl Dataset {
    /// The gradient of the normalised field with respect to object coordinates at `p` under
    /// gradient filter `gradient`, `filter` being the dataset's value filter (which
    /// [`GradientFilter::Nodes`] interpolates the node differences with). A
    /// [`GradientFilter::Cubic`] whose B or C is not finite (one `vlGradientFilter` refuses)
    /// gives 0 everywhere, as [`Dataset::gradient`] does under such a [`Filter::Cubic`].
    ///
    /// # Panics
    ///
    /// A [`GradientFilter::Cubic`], or [`GradientFilter::Nodes`] under a [`Filter::Cubic`],
    /// reads the node values ([`Dataset::values`]): where they are not made yet and cannot be
    /// allocated, it unwinds as that does.
    #[inline]
    pub fn gradient_with(&self, p: [f32; 3], filter: Filter, gradient: GradientFilter) -> [f64; 3] {
        self.gradient_by(p, filter, gradient, &mut CellGradients::default())
    }

    /// [`Dataset::gradient_with`], with the paper's gradient through [`CellGradients`] (see
    /// [`Dataset::gradient_cached`]).
    #[inline]
    pub(crate) fn gradient_by(
        &self,
        p: [f32; 3],
        filter: Filter,
        gradient: GradientFilter,
        cache: &mut CellGradients,
    ) -> [f64; 3] {
        match gradient {
            GradientFilter::Nodes => self.gradient_cached(p, filter, cache),
            GradientFilter::Cubic { b, c } if !bc_finite(b, c) => [0.0; 3],
            GradientFilter::Cubic { b, c } => self.cubic_gradient(p, b as f64, c as f64),
        }
    }

    /// The exact gradient of the BC-spline reconstruction at object point `p` (clamped to the
    /// grid as the value filters clamp it; NaN → 0): the sums of the 4×4×4 window's nodes with
    /// the weights k′⊗k⊗k, k⊗k′⊗k and k⊗k⊗k′, each row along x read once.
    #[inline(never)]
    pub(crate) fn cubic_gradient(&self, p: [f32; 3], b: f64, c: f64) -> [f64; 3] {
        let k = Cubics::new(b, c);
        // (Three calls, not a closure, which the compiler may leave out of line.)
        let (x, y, z) = (
            AxisTaps::new(self.index(p[0], 0), self.dims[0], b, c, &k),
            AxisTaps::new(self.index(p[1], 1), self.dims[1], b, c, &k),
            AxisTaps::new(self.index(p[2], 2), self.dims[2], b, c, &k),
        );
        let values = self.values();
        if (x.len, y.len, z.len) == (4, 4, 4) {
            return self.cubic_gradient4(values, [&x, &y, &z]);
        }
        let mut g = [0.0f64; 3];
        for kz in 0..z.len {
            for ky in 0..y.len {
                let o = self.node_index([x.first, y.first + ky, z.first + kz]);
                // (Always there: the window lies inside the grid.)
                let Some(row) = values.get(o..o + x.len) else {
                    continue;
                };
                let (mut value, mut slope) = (0.0, 0.0);
                for (kx, &v) in row.iter().enumerate() {
                    value += x.value[kx] * v as f64;
                    slope += x.slope[kx] * v as f64;
                }
                g[0] += z.value[kz] * y.value[ky] * slope;
                g[1] += z.value[kz] * y.slope[ky] * value;
                g[2] += z.slope[kz] * y.value[ky] * value;
            }
        }
        // Per grid step to per object unit: × (n − 1) (0 along an axis of one node, whose
        // slope weights are 0).
        std::array::from_fn(|a| g[a] * self.last[a])
    }

    /// [`Dataset::cubic_gradient`] over a window of 4×4×4 nodes (`values`, the node values):
    /// per row along x its sums with k and k′, then per layer along y, then along z.
    #[inline(always)]
    fn cubic_gradient4(&self, values: &[f32], [x, y, z]: [&AxisTaps; 3]) -> [f64; 3] {
        // Per layer kz and row ky: the row's sums with x's value and slope weights.
        let (mut value, mut slope) = ([[0.0f64; 4]; 4], [[0.0f64; 4]; 4]);
        for kz in 0..4 {
            for ky in 0..4 {
                let o = self.node_index([x.first, y.first + ky, z.first + kz]);
                // (Always there: the window lies inside the grid.)
                let Some(&[v0, v1, v2, v3]) = values.get(o..o + 4) else {
                    continue;
                };
                let r = [v0, v1, v2, v3].map(f64::from);
                let dot = |w: &[f64; 4]| (w[0] * r[0] + w[1] * r[1]) + (w[2] * r[2] + w[3] * r[3]);
                value[kz][ky] = dot(&x.value);
                slope[kz][ky] = dot(&x.slope);
            }
        }
        // Per layer: along y, the three sums the gradient's components take.
        let dot =
            |w: &[f64; 4], r: &[f64; 4]| (w[0] * r[0] + w[1] * r[1]) + (w[2] * r[2] + w[3] * r[3]);
        let layers: [[f64; 3]; 4] = std::array::from_fn(|kz| {
            [
                dot(&y.value, &slope[kz]),
                dot(&y.slope, &value[kz]),
                dot(&y.value, &value[kz]),
            ]
        });
        let along_z = |w: &[f64; 4], i: usize| {
            (w[0] * layers[0][i] + w[1] * layers[1][i])
                + (w[2] * layers[2][i] + w[3] * layers[3][i])
        };
        let g = [
            along_z(&z.value, 0),
            along_z(&z.value, 1),
            along_z(&z.slope, 2),
        ];
        std::array::from_fn(|a| g[a] * self.last[a])
    }
}
