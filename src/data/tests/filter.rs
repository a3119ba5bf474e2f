//! Tests of the filters: linear fields reproduced with exact gradients, nodes interpolated,
//! the BC kernel a partition of unity, and the cubic interior paths the generic filter bit for
//! bit.

use super::*;
use crate::data::filter::{bc_kernel, Cubics};
use crate::data::gradient::bc_derivative;

#[test]
fn trilinear_reproduces_linear_functions() {
    let mut rng = Lcg(1);
    for dims in [[5, 7, 3], [2, 2, 2], [9, 1, 4]] {
        let (d, f) = linear(dims);
        for _ in 0..2000 {
            // Includes points outside [0, 1]^3, where the dataset is 0.
            let p = [
                rng.next() * 1.2 - 0.1,
                rng.next() * 1.2 - 0.1,
                rng.next() * 1.2 - 0.1,
            ];
            let got = d.sample(p.map(|x| x as f32), Filter::Trilinear) as f64;
            let q = p.map(|x| x as f32 as f64);
            let want = if q.iter().all(|x| (0.0..=1.0).contains(x)) {
                f(q)
            } else {
                0.0
            };
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

/// The kernel's cubics by Horner's rule ([`Cubics`], what the cubic filters evaluate) are the
/// kernel and its derivative ([`bc_kernel`], [`bc_derivative`], by their textbook branches)
/// at the four taps of every offset t in [0, 1), t = 0 and the last f64 below 1 among them,
/// for the usual kernels and large B and C: each a cubic of |x| ≤ 2 whose terms (the
/// derivative's among them) reach some 36 + 48|C| + 12|B| in size, so the two ways of
/// rounding differ by a few units of 10⁻¹⁶ times that (the tolerance: 10⁻¹⁴ times it; a wrong
/// coefficient or sign is off by 10⁻³ or more).
#[test]
fn the_kernels_cubics_are_the_kernel() {
    let kernels = [
        (0.0, 0.5),
        (1.0, 0.0),
        (1.0 / 3.0, 1.0 / 3.0),
        (0.0, 0.0),
        (0.7, -0.2),
        (100.0, -40.0),
    ];
    let mut rng = Lcg(11);
    let ts: Vec<f64> = [0.0, 0.5, 1.0 - f64::EPSILON / 2.0, f64::MIN_POSITIVE]
        .into_iter()
        .chain((0..2000).map(|_| rng.next()))
        .collect();
    for (b, c) in kernels {
        let k = Cubics::new(b, c);
        let tolerance = 1e-14 * (36.0 + 48.0 * f64::abs(c) + 12.0 * f64::abs(b));
        for &t in &ts {
            let w = k.weights(t);
            let taps = [
                k.outer(t + 1.0),
                k.inner(t),
                k.inner(1.0 - t),
                k.outer(2.0 - t),
            ];
            for m in 0..4 {
                let x = t - (m as f64 - 1.0);
                let (want, slope) = (bc_kernel(x, b, c), bc_derivative(x, b, c));
                assert!(
                    (w[m] - want).abs() <= tolerance,
                    "b {b} c {c} t {t} tap {m}"
                );
                assert!(
                    (taps[m].0 - want).abs() <= tolerance,
                    "b {b} c {c} t {t} tap {m}"
                );
                // The cubics' derivative is k′(|x|): the far taps' (x < 0) is its negative.
                let sign = if m >= 2 { -1.0 } else { 1.0 };
                assert!(
                    (sign * taps[m].1 - slope).abs() <= tolerance,
                    "b {b} c {c} t {t} tap {m}: {} against {slope}",
                    sign * taps[m].1
                );
            }
        }
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
            // (Outside the cube the dataset is 0: `a_dataset_is_zero_outside_its_cube`.)
            let want = if d.covers(p) { generic } else { 0.0 };
            assert_eq!(
                d.sample(p, f).to_bits(),
                (want as f32).clamp(0.0, 1.0).to_bits()
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

/// A dataset is a bounded field: 0, with a gradient of 0, at every point outside [0, 1]³ by
/// more than the face tolerance 2⁻²⁰, for every filter (the value of a constant dataset of 1
/// would be 1 anywhere under clamping, so a 0 can only come from the bound); within the
/// tolerance a point reads the face, exactly as the point on the face does.
#[test]
fn a_dataset_is_zero_outside_its_cube() {
    use crate::data::FACE_TOLERANCE;
    let filters = [
        Filter::Nearest,
        Filter::Trilinear,
        Filter::Cubic { b: 0.0, c: 0.5 },
        Filter::Cubic { b: 1.0, c: 0.0 },
    ];
    let ones = Dataset::new([4, 5, 3], Voxels::U8(vec![255; 60]), 0.0, 255.0).unwrap();
    let (lin, _) = linear([6, 5, 4]);
    let slab = random_u8([5, 1, 4], 9);
    let mut rng = Lcg(21);
    let tol = FACE_TOLERANCE;
    for filter in filters {
        for d in [&ones, &lin, &slab] {
            for _ in 0..300 {
                let inner: [f32; 3] = std::array::from_fn(|_| rng.next() as f32);
                for axis in 0..3 {
                    // Beyond either face, by 2.5 tolerances up to half the cube.
                    for out in [
                        -2.5 * tol,
                        1.0 + 2.5 * tol,
                        -0.5 * rng.next() as f32 - 2.5 * tol,
                        1.0 + 0.5 * rng.next() as f32 + 2.5 * tol,
                    ] {
                        let mut p = inner;
                        p[axis] = out;
                        assert!(!d.covers(p));
                        assert_eq!(d.sample(p, filter), 0.0, "{filter:?} {:?} {p:?}", d.dims);
                        assert_eq!(d.gradient(p, filter), [0.0; 3], "{filter:?} {p:?}");
                    }
                    // Within the tolerance: the face's value and gradient.
                    for (near, face) in [(-0.5 * tol, 0.0), (1.0 + 0.5 * tol, 1.0)] {
                        let (mut p, mut q) = (inner, inner);
                        p[axis] = near;
                        q[axis] = face;
                        assert!(d.covers(p));
                        assert_eq!(d.sample(p, filter), d.sample(q, filter), "{filter:?}");
                        assert_eq!(d.gradient(p, filter), d.gradient(q, filter), "{filter:?}");
                    }
                }
            }
            // NaN is no point of the cube.
            assert_eq!(d.sample([f32::NAN, 0.5, 0.5], filter), 0.0);
        }
        // Inside, the constant dataset is 1 everywhere (the bound is the cube's faces, not
        // a fade inside them).
        for p in [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.0, 0.5, 1.0]] {
            assert_eq!(ones.sample(p, filter), 1.0, "{filter:?} {p:?}");
        }
    }
}

/// `Filter::new` refuses a B or C that is not finite with `BadValue`, whatever the
/// interpolation (as `vlCubicFilter` does), and builds the filter of finite ones.
#[test]
fn filters_of_parameters_that_are_not_finite_are_refused() {
    use crate::types::Interpolation;
    for kind in Interpolation::ALL.iter().copied() {
        for cubic in [
            (f32::NAN, 0.0),
            (0.0, f32::NAN),
            (f32::INFINITY, 0.5),
            (1.0, f32::NEG_INFINITY),
        ] {
            let e = Filter::new(kind, cubic).unwrap_err();
            assert_eq!(e.code, ErrorCode::BadValue, "{kind:?} {cubic:?}");
        }
    }
    let built = |kind| Filter::new(kind, (1.0, -0.25)).unwrap();
    assert_eq!(built(Interpolation::Nearest), Filter::Nearest);
    assert_eq!(built(Interpolation::Trilinear), Filter::Trilinear);
    assert_eq!(
        built(Interpolation::Tricubic),
        Filter::Cubic { b: 1.0, c: -0.25 }
    );
}

/// A `Filter::Cubic` or `GradientFilter::Cubic` whose B or C is not finite (built directly,
/// past `Filter::new`) reads 0 everywhere, value and gradient, instead of NaN: inside the
/// cube, on its faces and in its interior (where the fast paths run). The largest finite
/// parameters give finite values in [0, 1] and finite gradients.
#[test]
fn cubic_filters_of_parameters_that_are_not_finite_read_zero() {
    use crate::data::GradientFilter;
    let d = random_u8([9, 8, 7], 5);
    let mut rng = Lcg(17);
    let mut points: Vec<[f32; 3]> = vec![[0.5; 3], [0.0; 3], [1.0, 0.5, 0.0], [0.31, 0.62, 0.47]];
    points.extend((0..200).map(|_| std::array::from_fn(|_| rng.next() as f32)));
    let bad = [
        (f32::NAN, 0.0),
        (0.0, f32::NAN),
        (f32::INFINITY, 0.0),
        (0.0, f32::NEG_INFINITY),
    ];
    for p in &points {
        for (b, c) in bad {
            let f = Filter::Cubic { b, c };
            assert_eq!(d.sample(*p, f).to_bits(), 0, "{p:?} B = {b}, C = {c}");
            assert_eq!(d.gradient(*p, f), [0.0; 3], "{p:?} B = {b}, C = {c}");
            for value in [Filter::Trilinear, Filter::Cubic { b: 0.0, c: 0.5 }, f] {
                let g = d.gradient_with(*p, value, GradientFilter::Cubic { b, c });
                assert_eq!(g, [0.0; 3], "{p:?} {value:?} B = {b}, C = {c}");
            }
            assert_eq!(d.gradient_with(*p, f, GradientFilter::Nodes), [0.0; 3]);
        }
        for (b, c) in [
            (f32::MAX, f32::MAX),
            (-f32::MAX, f32::MAX),
            (f32::MAX, -f32::MAX),
        ] {
            let v = d.sample(*p, Filter::Cubic { b, c });
            assert!((0.0..=1.0).contains(&v), "{p:?} B = {b}, C = {c}: {v}");
            let grads = [
                d.gradient(*p, Filter::Cubic { b, c }),
                d.gradient_with(*p, Filter::Trilinear, GradientFilter::Cubic { b, c }),
            ];
            for g in grads {
                assert!(
                    g.iter().all(|x| x.is_finite()),
                    "{p:?} B = {b}, C = {c}: {g:?}"
                );
            }
        }
    }
}
