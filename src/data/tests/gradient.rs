//! Tests of the cubic gradient filter: the derivative kernel against the kernel's difference
//! quotients, polynomials the BC-splines reproduce given exact gradients at arbitrary points,
//! the gradient of random data the derivative of the cubic value filter, and the paper's
//! gradient unchanged under `GradientFilter::Nodes`.

use super::*;
use crate::data::filter::{bc_abs_sum, bc_kernel};
use crate::data::gradient::bc_derivative;

/// The BC-splines that reproduce quadratics up to a constant (B + 2C = 1): Catmull–Rom,
/// Mitchell's, the cubic B-spline.
const QUADRATIC: [(f32, f32); 3] = [(0.0, 0.5), (1.0 / 3.0, 1.0 / 3.0), (1.0, 0.0)];

/// A 16-bit dataset whose raw values are the integer quadratic 1000 + 7i + 30j + 20k + 3i² +
/// 5j² + 2k² + ij + 2jk + ik (about 2 100 at most on the grid below: no clamping), normalised
/// by a = 0, b = 65535, and its gradient per object unit at continuous index `u`.
fn quadratic(dims: [usize; 3]) -> (Dataset, impl Fn([f64; 3]) -> [f64; 3]) {
    let q = |[i, j, k]: [f64; 3]| {
        1000.0
            + 7.0 * i
            + 30.0 * j
            + 20.0 * k
            + 3.0 * i * i
            + 5.0 * j * j
            + 2.0 * k * k
            + i * j
            + 2.0 * j * k
            + i * k
    };
    let mut raw = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let v = q([i, j, k].map(|x| x as f64));
                assert!(v <= 65535.0);
                raw.push(v as u16);
            }
        }
    }
    let d = Dataset::new(dims, Voxels::U16(raw), 0.0, 65535.0).unwrap();
    let last = dims.map(|n| (n - 1) as f64);
    let grad = move |[i, j, k]: [f64; 3]| {
        [
            (7.0 + 6.0 * i + j + k) * last[0] / 65535.0,
            (30.0 + 10.0 * j + i + 2.0 * k) * last[1] / 65535.0,
            (20.0 + 4.0 * k + 2.0 * j + i) * last[2] / 65535.0,
        ]
    };
    (d, grad)
}

/// Each node value is the f32 rounding of a value in [0, 1] (error at most 2⁻²⁵), and the
/// gradient per grid step is a sum of node values with weights of total magnitude at most
/// Σ|k′| · (Σ|k|)² (Σ|k′| < 2 for the kernels tested, Σ|k| their `bc_abs_sum`), so its error is
/// below 2 · bc_abs_sum² · 2⁻²⁵ per grid step, (n − 1) times that per object unit; twice that
/// for the f64 sums' rounding (far smaller) and the bound's slack.
fn tolerance(b: f32, c: f32, n: usize) -> f64 {
    let s = bc_abs_sum(b as f64, c as f64);
    2.0 * 2.0 * s * s * 2f64.powi(-25) * (n - 1) as f64
}

#[test]
fn the_derivative_kernel_is_the_kernels_slope() {
    // Central difference quotients of the piecewise cubic, away from its knots (|x| = 0, 1,
    // 2, where k″ may jump): error h²/6 · |k‴| ≤ h² · 2 (|k‴| ≤ 12 for these B, C), plus
    // rounding 2⁻⁵² / h.
    let h = 1e-5;
    for (b, c) in [(0.0, 0.5), (1.0, 0.0), (1.0 / 3.0, 1.0 / 3.0), (0.5, 0.1)] {
        for i in 0..400 {
            let x = -2.2 + 4.4 * (i as f64 + 0.5) / 400.0;
            if [0.0, 1.0, 2.0]
                .iter()
                .any(|k| (x.abs() - k).abs() < 2.0 * h)
            {
                continue;
            }
            let want = (bc_kernel(x + h, b, c) - bc_kernel(x - h, b, c)) / (2.0 * h);
            let got = bc_derivative(x, b, c);
            assert!(
                (got - want).abs() < 1e-9,
                "B {b} C {c} x {x}: {got} vs {want}"
            );
        }
        // An even kernel's slope is odd, and 0 at the centre and beyond the support.
        assert_eq!(bc_derivative(0.0, b, c), 0.0);
        assert_eq!(bc_derivative(2.0, b, c), 0.0);
        assert_eq!(bc_derivative(-0.3, b, c), -bc_derivative(0.3, b, c));
    }
}

#[test]
fn a_linear_fields_cubic_gradient_is_exact_everywhere() {
    // The BC-splines with B + 2C = 1 reproduce linear functions, and the outside taps
    // extrapolate linearly, so the faces, clamped points outside the box and grids of one to
    // three nodes an axis are exact too (an axis of one node has gradient 0).
    let mut rng = Lcg(31);
    for dims in [[6, 5, 4], [2, 3, 9], [9, 1, 4], [1, 2, 2]] {
        let (d, _) = linear(dims);
        let per_step = [7.0, 300.0, 20.0];
        let want: [f64; 3] =
            std::array::from_fn(|a| per_step[a] * (dims[a].max(1) - 1) as f64 / 65535.0);
        for (b, c) in QUADRATIC {
            let tol = tolerance(b, c, *dims.iter().max().unwrap());
            let gradient = GradientFilter::Cubic { b, c };
            for _ in 0..500 {
                let p = rng.point_around_box();
                let got = d.gradient_with(p, Filter::Trilinear, gradient);
                for a in 0..3 {
                    assert!(
                        (got[a] - want[a]).abs() < tol,
                        "{dims:?} B {b} C {c} {p:?} axis {a}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }
    // Off that line a BC-spline reproduces only constants: its gradient of a linear field errs
    // by far more than the tolerance (so the test above can fail).
    let (d, _) = linear([6, 5, 4]);
    let got = d.gradient_with(
        [0.3, 0.5, 0.5],
        Filter::Trilinear,
        GradientFilter::Cubic { b: 0.5, c: 0.1 },
    );
    assert!((got[0] - 7.0 * 5.0 / 65535.0).abs() > 100.0 * tolerance(0.5, 0.1, 6));
}

#[test]
fn a_quadratic_fields_cubic_gradient_is_exact_where_every_tap_is_a_node() {
    let dims = [9, 8, 7];
    let (d, grad) = quadratic(dims);
    let mut rng = Lcg(32);
    for (b, c) in QUADRATIC {
        let tol = tolerance(b, c, 9);
        for _ in 0..2000 {
            // Continuous indices in [1, n − 2): the taps floor(u) − 1 … floor(u) + 2 are nodes.
            let u: [f64; 3] = std::array::from_fn(|a| 1.0 + rng.next() * (dims[a] - 3) as f64);
            let p: [f32; 3] = std::array::from_fn(|a| (u[a] / (dims[a] - 1) as f64) as f32);
            // The gradient where p (as f32) lies.
            let at: [f64; 3] = std::array::from_fn(|a| p[a] as f64 * (dims[a] - 1) as f64);
            let want = grad(at);
            // The value filter does not matter.
            for filter in [Filter::Trilinear, Filter::Nearest] {
                let got = d.gradient_with(p, filter, GradientFilter::Cubic { b, c });
                for a in 0..3 {
                    assert!(
                        (got[a] - want[a]).abs() < tol,
                        "B {b} C {c} {p:?} axis {a}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }
    // A BC-spline off the line B + 2C = 1 reproduces only linear functions: its gradient of
    // the quadratic is wrong, by much more than the tolerance (so the test above can fail).
    let p = [0.43, 0.51, 0.47];
    let at: [f64; 3] = std::array::from_fn(|a| p[a] as f64 * (dims[a] - 1) as f64);
    let off = d.gradient_with(
        p,
        Filter::Trilinear,
        GradientFilter::Cubic { b: 0.0, c: 0.0 },
    );
    let want = grad(at);
    assert!((0..3).any(|a| (off[a] - want[a]).abs() > 100.0 * tolerance(0.0, 0.0, 9)));
}

#[test]
fn the_cubic_gradient_is_the_slope_of_the_cubic_value_filter() {
    // On random data, inside the grid (where the value filter's repeated border nodes and the
    // gradient's extrapolated ones are not read), the gradient is the derivative of the value
    // filter's f64 sum: central difference quotients with h = 10⁻⁵ grid steps, away from the
    // knots (fractions within 0.01 of an integer), err by at most h²/6 · |f‴| (f‴ below
    // 12 · 4 · 1.2² per grid step³ for node values in [0, 1]: under 10⁻⁸) plus rounding 2⁻⁵²/h.
    let d = random_u8([10, 9, 8], 33);
    let dims = d.dims();
    let node = |i, j, k| d.node(i, j, k) as f64;
    let mut rng = Lcg(34);
    let h = 1e-5;
    for (b, c) in [(0.0, 0.5), (1.0, 0.0), (1.0 / 3.0, 1.0 / 3.0)] {
        let filter = Filter::Cubic { b, c };
        for _ in 0..500 {
            let u: [f64; 3] = std::array::from_fn(|a| {
                let f = 1.0 + (rng.next() * (dims[a] - 3) as f64).floor();
                f + 0.01 + 0.98 * rng.next()
            });
            let p: [f32; 3] = std::array::from_fn(|a| (u[a] / (dims[a] - 1) as f64) as f32);
            let u: [f64; 3] = std::array::from_fn(|a| d.index(p[a], a));
            let got = d.gradient_with(p, Filter::Trilinear, GradientFilter::Cubic { b, c });
            for a in 0..3 {
                let (mut lo, mut hi) = (u, u);
                lo[a] -= h;
                hi[a] += h;
                let slope = (d.filter(hi, filter, node) - d.filter(lo, filter, node)) / (2.0 * h);
                let want = slope * (dims[a] - 1) as f64;
                assert!(
                    (got[a] - want).abs() < 1e-8 * (dims[a] - 1) as f64,
                    "B {b} C {c} {p:?} axis {a}: {} vs {want}",
                    got[a]
                );
            }
        }
    }
}

#[test]
fn the_nodes_gradient_filter_is_the_papers_gradient_bit_for_bit() {
    let d = random_u8([12, 11, 10], 35);
    let mut rng = Lcg(36);
    for filter in [
        Filter::Nearest,
        Filter::Trilinear,
        Filter::Cubic { b: 0.0, c: 0.5 },
    ] {
        for _ in 0..500 {
            let p = rng.point_around_box();
            let want = d.gradient(p, filter).map(f64::to_bits);
            let got = d.gradient_with(p, filter, GradientFilter::Nodes);
            assert_eq!(got.map(f64::to_bits), want, "{filter:?} {p:?}");
        }
    }
}

#[test]
fn the_cubic_gradient_of_a_point_that_is_not_finite_is_finite() {
    // NaN reads as index 0 and the infinities clamp to the faces, as the value filters do.
    let d = random_u8([6, 6, 6], 37);
    let g = GradientFilter::Cubic { b: 1.0, c: 0.0 };
    for p in [
        [f32::NAN, 0.5, 0.5],
        [f32::INFINITY, f32::NEG_INFINITY, 0.5],
        [f32::NAN; 3],
    ] {
        let got = d.gradient_with(p, Filter::Trilinear, g);
        assert!(got.iter().all(|x| x.is_finite()), "{p:?}: {got:?}");
        let clamped = p.map(|x| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) });
        assert_eq!(got, d.gradient_with(clamped, Filter::Trilinear, g));
    }
}
