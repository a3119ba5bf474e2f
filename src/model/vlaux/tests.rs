//! Unit tests of `vlaux`.

use super::*;
use crate::types::DatasetId;

/// Permutation table for `seed`: seed 0 is Perlin's table; other seeds apply a Fisher-Yates
/// shuffle driven by xorshift64, whose state is a splitmix64 hash of the seed.
fn permutation(seed: i32) -> [u8; 256] {
    with_permutation(seed, |t| *t)
}

/// Deterministic xorshift32 stream of f32 in [lo, hi).
fn rng(seed: u32) -> impl FnMut(f32, f32) -> f32 {
    let mut s = seed | 1;
    move |lo, hi| {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        lo + (hi - lo) * (s >> 8) as f32 / (1u32 << 24) as f32
    }
}

/// The lattice split without library calls is the library's floor and Euclidean
/// remainder: on values around integers, negatives, and magnitudes up to and beyond 2⁶³.
#[test]
fn split_matches_floor_and_rem_euclid() {
    let reference = |c: f64| {
        let f = c.floor();
        (f.rem_euclid(256.0) as usize & 255, (c - f).clamp(0.0, 1.0))
    };
    let mut cs = vec![
        0.0,
        -0.0,
        0.5,
        -0.5,
        255.5,
        256.0,
        -256.0,
        -257.25,
        1e15 + 0.5,
    ];
    for e in [20, 40, 52, 53, 62, 63, 64, 80, 300] {
        let m = 2f64.powi(e);
        cs.extend([m, -m, m + 3.0 * m * f64::EPSILON, -m * 1.5, m.next_down()]);
    }
    for i in -3000..3000 {
        let c = i as f64 * 0.173;
        cs.extend([c, c.next_up(), c.next_down()]);
    }
    for c in cs {
        let (i, f) = split(c);
        let (ri, rf) = reference(c);
        assert_eq!((i, f.to_bits()), (ri, rf.to_bits()), "split({c:e})");
    }
}

#[test]
fn seed_zero_is_reference_and_seeds_are_permutations() {
    assert_eq!(permutation(0), PERLIN_PERMUTATION);
    for seed in [0, 1, -1, 42, i32::MAX, i32::MIN] {
        let mut seen = [false; 256];
        permutation(seed)
            .iter()
            .for_each(|&v| seen[v as usize] = true);
        assert!(seen.iter().all(|&b| b), "seed {seed} is not a permutation");
    }
    assert_ne!(permutation(1), PERLIN_PERMUTATION);
    assert_ne!(permutation(1), permutation(2));
}

#[test]
fn cached_tables_are_the_shuffles_of_their_seeds() {
    // More seeds than the cache holds, in an order that hits, misses and evicts.
    let seeds: Vec<i32> = (0..3 * CACHED_TABLES as i32)
        .map(|i| (i * 7) % (CACHED_TABLES as i32 + 3) + 1)
        .collect();
    for &seed in seeds.iter().chain(seeds.iter().rev()) {
        assert_eq!(permutation(seed), shuffled(seed), "seed {seed}");
        let p = [0.3, 1.7, -2.2];
        let fresh = noise_raw(&shuffled(seed), scaled(p, 3.0)) as f32;
        assert_eq!(noise(p, 3.0, seed), fresh, "seed {seed}");
    }
}

#[test]
#[allow(clippy::approx_constant)] // the literal inputs of the published reference values
fn noise_matches_perlin_reference_values() {
    // Published outputs of Perlin's Java ImprovedNoise (f32 inputs: small tolerance).
    assert!((noise([3.14, 42.0, 7.0], 1.0, 0) - 0.136_919_96).abs() < 1e-5);
    assert!((noise([1.4142, 1.2589, 2.718], 1.0, 0) + 0.172_456_64).abs() < 1e-5);
}

#[test]
fn noise_zero_at_lattice_points() {
    for seed in [0, 7, -3] {
        for i in -20..20 {
            let p = [i as f32, (i * 7 % 13) as f32, (300 - i * 3) as f32];
            assert_eq!(noise(p, 1.0, seed), 0.0);
            let q = [2.0 * p[0], 2.0 * p[1], 2.0 * p[2]];
            assert_eq!(noise(q, 0.5, seed), 0.0);
        }
    }
}

#[test]
fn noise_bounded_and_nonconstant() {
    let mut r = rng(12345);
    let (mut lo, mut hi) = (0.0f32, 0.0f32);
    for _ in 0..100_000 {
        let v = noise([r(-50.0, 50.0), r(-50.0, 50.0), r(-50.0, 50.0)], 1.0, 0);
        assert!((-1.0..=1.0).contains(&v));
        lo = lo.min(v);
        hi = hi.max(v);
    }
    assert!(lo < -0.5 && hi > 0.5);
}

#[test]
fn noise_is_lipschitz() {
    // Per cell n = sum_c W_c * g_c.(d - c) with |g_c.(d - c)| <= 2 and sum W_c = 1. So
    // |dn/dx| <= max fade' * max|diff| + max|g_x| = 1.875 * 4 + 1 = 8.5 and
    // |grad n| <= 8.5 * sqrt(3) < 15; clamping does not increase it.
    let mut r = rng(99);
    for _ in 0..20_000 {
        let size = r(0.5, 4.0);
        let p = [r(-10.0, 10.0), r(-10.0, 10.0), r(-10.0, 10.0)];
        let q = [
            p[0] + r(-1e-3, 1e-3),
            p[1] + r(-1e-3, 1e-3),
            p[2] + r(-1e-3, 1e-3),
        ];
        let d = ((0..3).map(|i| ((p[i] - q[i]) as f64).powi(2)).sum::<f64>()).sqrt();
        let diff = (noise(p, size, 5) - noise(q, size, 5)).abs() as f64;
        assert!(diff <= 15.0 * size as f64 * d + 1e-6, "{diff} vs {d}");
    }
}

#[test]
fn seeds_give_different_fields() {
    let mut r = rng(7);
    let mut differing = 0;
    for _ in 0..200 {
        let p = [r(0.0, 10.0), r(0.0, 10.0), r(0.0, 10.0)];
        if (noise(p, 1.0, 0) - noise(p, 1.0, 1)).abs() > 1e-3 {
            differing += 1;
        }
        assert_eq!(noise(p, 1.0, 3), noise(p, 1.0, 3));
    }
    assert!(differing > 150);
}

#[test]
fn turbulence_is_the_explicit_sum() {
    let mut r = rng(3);
    for _ in 0..50 {
        let p = [r(-5.0, 5.0), r(-5.0, 5.0), r(-5.0, 5.0)];
        let expected: f64 = (0..6)
            .map(|i| noise(p, 1.5 * 2f32.powi(i), 9).abs() as f64 / 2f64.powi(i))
            .sum();
        let t = turbulence(p, 1.5, 6, 9);
        assert!((t as f64 - expected).abs() < 1e-5);
        assert!((0.0..2.0).contains(&t));
        assert_eq!(turbulence(p, 1.5, 0, 9), 0.0);
        assert_eq!(turbulence(p, 1.5, -4, 9), 0.0);
        assert_eq!(turbulence(p, 1.5, 1000, 9), turbulence(p, 1.5, 32, 9));
    }
}

#[test]
fn spline_interpolates_and_reproduces_lines() {
    let knots = [3.0, -1.0, 4.0, 1.5, -9.0, 2.6, 5.0];
    let spans = knots.len() - 3;
    for k in 0..=spans {
        let v = spline(k as f32 / spans as f32, &knots);
        assert!((v - knots[k + 1]).abs() < 1e-5, "k={k}: {v}");
    }
    let mut r = rng(11);
    for n in 3..10 {
        let lin: Vec<f32> = (0..n).map(|i| 2.0 - 0.75 * i as f32).collect();
        for _ in 0..50 {
            let x = r(0.0, 1.0);
            assert!((spline(x, &vec![4.25; n]) - 4.25).abs() < 1e-5);
            if n >= 4 {
                let expected = 2.0 - 0.75 * (1.0 + x * (n - 3) as f32);
                assert!((spline(x, &lin) - expected).abs() < 1e-5);
            }
        }
    }
    // Edge cases and clamping.
    assert_eq!(spline(0.3, &[]), 0.0);
    assert_eq!(spline(0.3, &[5.0]), 5.0);
    assert!((spline(0.25, &[0.0, 4.0]) - 1.0).abs() < 1e-6);
    assert_eq!(spline(0.0, &[9.0, 1.0, 2.0]), 1.0);
    assert_eq!(spline(1.0, &[9.0, 1.0, 2.0]), 2.0);
    assert_eq!(spline(-5.0, &knots), knots[1]);
    assert_eq!(spline(f32::NAN, &knots), knots[1]);
    assert!((spline(7.0, &knots) - knots[5]).abs() < 1e-5);
}

#[test]
fn fields_match_formulas() {
    let mut r = rng(21);
    for _ in 0..10_000 {
        let p = [r(-0.5, 1.5), r(-0.5, 1.5), r(-0.5, 1.5)];
        let (dx, dy, dz) = (p[0] - 0.5, p[1] - 0.5, p[2] - 0.5);
        let r2 = dx * dx + dy * dy + dz * dz;
        let c01 = |v: f32| v.clamp(0.0, 1.0);
        assert!((parab1(p) - c01(1.0 - 4.0 * r2)).abs() < 1e-5);
        assert!((sphere(p) - c01(1.0 - 2.0 * r2.sqrt())).abs() < 1e-5);
        let rc = (dx * dx + dy * dy).sqrt();
        assert!((cylinder(p) - c01(1.0 - 2.0 * rc)).abs() < 1e-5);
    }
    for f in [parab1, sphere, cylinder] {
        assert_eq!(f([0.5; 3]), 1.0);
        for i in 0..8 {
            let c = [(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32];
            assert_eq!(f(c), 0.0);
        }
    }
    assert_eq!(cylinder([0.5, 0.5, 1e6]), 1.0);
    assert_eq!(sphere([1.0, 0.5, 0.5]), 0.0);
    assert_eq!(parab1([0.5, 0.5, 0.0]), 0.0);
}

#[test]
fn extreme_inputs_stay_finite() {
    let bad = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        1e30,
        -1e30,
        f32::MAX,
    ];
    for &a in &bad {
        for &b in &bad {
            let p = [a, 0.3, b];
            let outs = [
                noise(p, 1.0, 0),
                noise([0.3, 0.2, 0.1], a, 1),
                noise(p, b, -7),
                turbulence(p, 1.0, 8, 0),
                turbulence([0.3, 0.2, 0.1], a, 32, 2),
                spline(a, &[b, a, 1.0, b, a]),
                spline(0.5, &[f32::MAX, -f32::MAX, f32::MAX, -f32::MAX]),
                parab1(p),
                sphere(p),
                cylinder([a, b, 0.5]),
            ];
            assert!(outs.iter().all(|v| v.is_finite()), "{a} {b}: {outs:?}");
        }
    }
    assert_eq!(noise([f32::NAN, 0.3, 0.4], 1.0, 0), 0.0);
    assert_eq!(noise([0.2, 0.3, 0.4], f32::INFINITY, 0), 0.0);
    assert_eq!(parab1([f32::NAN, 0.5, 0.5]), 0.0);
}
#[test]
fn sweep_coords_measure_the_radius() {
    assert_eq!(sweep_coords([0.5, 0.3, 0.5]), Some([0.0, 0.3, 0.0]));
    assert_eq!(sweep_coords([1.0, 0.7, 0.5]), Some([1.0, 0.7, 0.0]));
    assert_eq!(sweep_coords([0.5, 0.1, 0.0]), Some([1.0, 0.1, 0.0]));
    let q = sweep_coords([0.65, 0.2, 0.7]).unwrap();
    assert!((q[0] - 2.0 * (0.15f32 * 0.15 + 0.2 * 0.2).sqrt()).abs() < 1e-6);
    assert_eq!(q[1], 0.2);
    // Outside the inscribed cylinder (the cube's corners), and non-finite points.
    assert_eq!(sweep_coords([0.0, 0.5, 0.0]), None);
    assert_eq!(sweep_coords([1.01, 0.5, 0.5]), None);
    assert_eq!(sweep_coords([f32::NAN, 0.5, 0.5]), None);
    assert_eq!(sweep_coords([0.5, f32::INFINITY, 0.5]), None);
    // Rotationally symmetric about the axis.
    let mut r = rng(8);
    for _ in 0..1000 {
        let (a, rad, y) = (r(0.0, std::f32::consts::TAU), r(0.0, 0.7), r(0.0, 1.0));
        let p = [0.5 + rad * a.cos(), y, 0.5 + rad * a.sin()];
        match sweep_coords(p) {
            Some(q) => {
                assert!(rad <= 0.5 + 1e-6);
                assert!((q[0] - 2.0 * rad).abs() < 1e-5 && q[1] == y && q[2] == 0.0);
            }
            None => assert!(rad > 0.5 - 1e-6),
        }
    }
}

#[test]
fn sweep_samples_the_profile() {
    use crate::data::{Dataset, Filter, Voxels};
    use crate::model::program::{Datasets, SampleEnv};
    use crate::ErrorCode;
    use std::sync::Arc;
    // A 3 × 2 profile: bottom row (y = 0) 255, 255, 0; top row (y = 1) 255, 0, 0.
    let d = Dataset::new(
        [3, 2, 1],
        Voxels::U8(vec![255, 255, 0, 255, 0, 0]),
        0.0,
        255.0,
    )
    .unwrap();
    let mut sets = Datasets::new();
    sets.insert(DatasetId(7), Arc::new(d));
    let env = SampleEnv::new(Arc::new(sets), Filter::Trilinear);
    let at = |p: [f32; 3], id: i32| {
        let mut s = Sample::with_env(p, [0.0; 3], &env);
        sweep(&mut s, DatasetId(id))
    };
    assert_eq!(
        at([0.5, 0.0, 0.5], 7).unwrap(),
        1.0,
        "on the axis, at the bottom"
    );
    assert_eq!(
        at([0.5, 1.0, 0.5], 7).unwrap(),
        1.0,
        "on the axis, at the top"
    );
    // Radius 0.25 is profile x = 0.5 (the middle column): 1 at the bottom, 0 at the top,
    // 0.5 halfway; the same in every direction.
    for p in [[0.75, 0.0, 0.5], [0.5, 0.0, 0.25], [0.25, 0.0, 0.5]] {
        assert!((at(p, 7).unwrap() - 1.0).abs() < 1e-6, "{p:?}");
    }
    assert!((at([0.5, 0.5, 0.75], 7).unwrap() - 0.5).abs() < 1e-6);
    assert_eq!(at([0.5, 1.0, 0.75], 7).unwrap(), 0.0);
    // Outside the inscribed cylinder: 0 without reading the dataset.
    assert_eq!(at([0.0, 0.0, 0.0], 7).unwrap(), 0.0);
    assert_eq!(at([0.0, 0.0, 0.0], 8).unwrap(), 0.0);
    // Inside, an unknown id is vlSample's VL_BADID.
    assert_eq!(at([0.5, 0.5, 0.5], 8).unwrap_err().code, ErrorCode::BadId);
    // Without datasets in reach (a bare sample) the id is unknown too.
    let mut bare = Sample::new([0.5; 3], [0.0; 3]);
    assert_eq!(
        sweep(&mut bare, DatasetId(7)).unwrap_err().code,
        ErrorCode::BadId
    );
}
