//! The auxiliary library ("vlaux"): procedural helpers used to build volume objects and
//! textures. It owns Perlin's improved gradient noise and turbulence (with deterministic,
//! seedable permutation tables), the Catmull-Rom `spline` of Ebert et al., and the analytic
//! distance fields (`parab1`, `sphere`, `cylinder`) defined on the unit cube, and the rotational
//! sweep of a 2D profile dataset (`sweep`, `sweep_coords`). Every function but `sweep` is pure,
//! deterministic and total: any input, including NaN, infinities and huge values, yields a
//! finite result; `sweep` reads a dataset through the sample it is given.

use crate::error::Result;
use crate::program::Sample;

/// Ken Perlin's reference permutation of 0..=255 (from the "Improved Noise" reference code, 2002).
pub const PERLIN_PERMUTATION: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69,
    142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219,
    203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175,
    74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230,
    220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76,
    132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173,
    186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206,
    59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163,
    70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232,
    178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162,
    241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204,
    176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141,
    128, 195, 78, 66, 215, 61, 156, 180,
];

/// Permutation table for `seed`: seed 0 is Perlin's table; other seeds apply a Fisher-Yates
/// shuffle driven by xorshift64, whose state is a splitmix64 hash of the seed.
#[cfg(test)]
fn permutation(seed: i32) -> [u8; 256] {
    with_permutation(seed, |t| *t)
}

/// How many shuffled tables each thread keeps.
const CACHED_TABLES: usize = 8;

/// Runs `f` with the permutation table for `seed` (see [`shuffled`]). Shuffling costs ~255
/// divisions, so each thread keeps the tables of its last [`CACHED_TABLES`] seeds: a texture
/// typically calls noise with a few seeds in turn at every sample (granite: four), and a
/// one-table cache would reshuffle at every call.
fn with_permutation<R>(seed: i32, f: impl FnOnce(&[u8; 256]) -> R) -> R {
    use std::cell::RefCell;
    type Tables = Vec<(i32, Box<[u8; 256]>)>;
    thread_local!(static TABLES: RefCell<Tables> = const { RefCell::new(Vec::new()) });
    if seed == 0 {
        return f(&PERLIN_PERMUTATION);
    }
    TABLES.with(|tables| {
        let mut tables = tables.borrow_mut();
        let i = match tables.iter().position(|(s, _)| *s == seed) {
            Some(i) => i,
            None => {
                if tables.len() == CACHED_TABLES {
                    tables.pop();
                }
                tables.push((seed, Box::new(shuffled(seed))));
                tables.len() - 1
            }
        };
        // Keep the most recently used first, so the eviction above drops the least recent.
        if i > 0 {
            tables[..=i].rotate_right(1);
        }
        f(&tables[0].1)
    })
}

/// Perlin's table shuffled by a xorshift Fisher-Yates seeded from `seed` through splitmix64.
fn shuffled(seed: i32) -> [u8; 256] {
    let mut perm = PERLIN_PERMUTATION;
    if seed == 0 {
        return perm;
    }
    let mut z = (seed as u32 as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    let mut state = (z ^ (z >> 31)) | 1; // xorshift state must be non-zero
    for i in (1..256usize).rev() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let j = (state % (i as u64 + 1)) as usize;
        perm.swap(i, j);
    }
    perm
}

/// Perlin's quintic fade curve 6t^5 - 15t^4 + 10t^3.
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// Linear interpolation from `a` (t = 0) to `b` (t = 1).
fn lerp(t: f64, a: f64, b: f64) -> f64 {
    a + t * (b - a)
}

/// Dot product of the offset with one of Perlin's 12 gradient directions chosen by `hash`.
fn grad(hash: u8, x: f64, y: f64, z: f64) -> f64 {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

/// Splits a finite coordinate into a lattice index (mod 256) and a fractional part in [0, 1].
/// (Without library calls: `floor` and `rem_euclid` of an f64 are calls into libm on the
/// x86-64 baseline, and noise calls this three times per octave.)
#[inline]
fn split(c: f64) -> (usize, f64) {
    let f = crate::num::floor(c);
    let frac = (c - f).clamp(0.0, 1.0);
    // An integer below 2⁶³ in magnitude is exact in i64, whose low byte is its residue mod
    // 256 (two's complement: for negatives too).
    let index = if f.abs() < 9.2e18 {
        (f as i64 & 255) as usize
    } else {
        f.rem_euclid(256.0) as usize & 255
    };
    (index, frac)
}

/// Improved noise at an already scaled point with a given permutation; clamped to [-1, 1].
fn noise_raw(perm: &[u8; 256], q: [f64; 3]) -> f64 {
    if q.iter().any(|c| !c.is_finite()) {
        return 0.0;
    }
    let (xi, x) = split(q[0]);
    let (yi, y) = split(q[1]);
    let (zi, z) = split(q[2]);
    let p = |i: usize| perm[i & 255] as usize;
    let (u, v, w) = (fade(x), fade(y), fade(z));
    let a = p(xi) + yi;
    let (aa, ab) = (p(a) + zi, p(a + 1) + zi);
    let b = p(xi + 1) + yi;
    let (ba, bb) = (p(b) + zi, p(b + 1) + zi);
    let hashes = [aa, ba, ab, bb];
    let mut g = [0.0f64; 8];
    for (k, gk) in g.iter_mut().enumerate() {
        let (i, j, l) = ((k & 1) as f64, ((k >> 1) & 1) as f64, (k >> 2) as f64);
        *gk = grad(perm[(hashes[k & 3] + (k >> 2)) & 255], x - i, y - j, z - l);
    }
    let r = lerp(
        w,
        lerp(v, lerp(u, g[0], g[1]), lerp(u, g[2], g[3])),
        lerp(v, lerp(u, g[4], g[5]), lerp(u, g[6], g[7])),
    );
    if r.is_finite() {
        r.clamp(-1.0, 1.0)
    } else {
        0.0
    }
}

/// Scales `p` by `s` in f64 (cannot overflow for finite f32 inputs).
fn scaled(p: [f32; 3], s: f64) -> [f64; 3] {
    [p[0] as f64 * s, p[1] as f64 * s, p[2] as f64 * s]
}

/// Improved Perlin gradient noise (Perlin 2002: 12 gradients, quintic fade) evaluated at
/// `p * size`, using the permutation derived from `seed` (0 = Perlin's reference table, other
/// seeds = a deterministic xorshift Fisher-Yates shuffle of it). The raw value (which can reach
/// about ±1.036) is clamped to [-1, 1]; the field is 0 at integer lattice points. Non-finite
/// `p` or `size` yields 0; huge finite values are reduced in f64 and wrapped with `& 255`.
pub fn noise(p: [f32; 3], size: f32, seed: i32) -> f32 {
    if !size.is_finite() || p.iter().any(|c| !c.is_finite()) {
        return 0.0;
    }
    with_permutation(seed, |perm| noise_raw(perm, scaled(p, size as f64)) as f32)
}

/// Perlin turbulence: the sum over `i` in `0..octaves` of `|noise(p, size * 2^i, seed)| / 2^i`.
/// `octaves <= 0` gives 0 and `octaves` is capped at 32; the result lies in [0, 2).
/// Scaling is done in f64, so very large `size` cannot overflow (such octaves contribute
/// whatever the wrapped lattice gives, never Inf/NaN).
pub fn turbulence(p: [f32; 3], size: f32, octaves: i32, seed: i32) -> f32 {
    if octaves <= 0 || !size.is_finite() || p.iter().any(|c| !c.is_finite()) {
        return 0.0;
    }
    with_permutation(seed, |perm| {
        let mut sum = 0.0f64;
        let mut scale = 1.0f64;
        for _ in 0..octaves.min(32) {
            sum += noise_raw(perm, scaled(p, size as f64 * scale)).abs() as f32 as f64 / scale;
            scale *= 2.0;
        }
        sum as f32
    })
}

/// Catmull-Rom spline through `knots`, as in Ebert et al., "Texturing and Modeling".
/// `x` is clamped to [0, 1] (non-finite `x` is treated as 0) and non-finite knots count as 0.
/// With `n >= 4` knots the curve has `n - 3` spans from `knots[1]` to `knots[n - 2]`; the first
/// and last knots are end control points. Edge cases: `n == 0` gives 0, `n == 1` gives
/// `knots[0]`, `n == 2` interpolates linearly from `knots[0]` to `knots[1]`, and `n == 3` is a
/// single span from `knots[1]` to `knots[2]` with `knots[2]` repeated as the 4th control point.
/// The result is clamped to the finite f32 range.
pub fn spline(x: f32, knots: &[f32]) -> f32 {
    let k = |i: usize| {
        let v = knots[i];
        if v.is_finite() {
            v as f64
        } else {
            0.0
        }
    };
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0) as f64
    } else {
        0.0
    };
    let n = knots.len();
    let (c, t) = match n {
        0 => return 0.0,
        1 => return k(0) as f32,
        2 => return lerp(x, k(0), k(1)) as f32,
        3 => ([k(0), k(1), k(2), k(2)], x),
        _ => {
            let nspans = n - 3;
            let xs = x * nspans as f64;
            let span = (xs as usize).min(nspans - 1);
            (
                [k(span), k(span + 1), k(span + 2), k(span + 3)],
                xs - span as f64,
            )
        }
    };
    let c3 = -0.5 * c[0] + 1.5 * c[1] - 1.5 * c[2] + 0.5 * c[3];
    let c2 = c[0] - 2.5 * c[1] + 2.0 * c[2] - 0.5 * c[3];
    let c1 = -0.5 * c[0] + 0.5 * c[2];
    let c0 = c[1];
    let r = ((c3 * t + c2) * t + c1) * t + c0;
    r.clamp(-(f32::MAX as f64), f32::MAX as f64) as f32
}

/// Clamps to [0, 1], mapping NaN to 0.
fn clamp01(v: f64) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0) as f32
    }
}

/// Squared distance from `p` to the cube centre (0.5, 0.5, 0.5) over the first `dims` axes.
fn dist2(p: [f32; 3], dims: usize) -> f64 {
    p[..dims].iter().map(|&c| (c as f64 - 0.5).powi(2)).sum()
}

/// Field value of the "VL_PARAB1" paraboloid: `1 - 4 * |p - (0.5, 0.5, 0.5)|^2` clamped to
/// [0, 1] (1 at the cube centre, 0 on and outside the inscribed sphere of radius 0.5).
/// NaN input gives 0.
pub fn parab1(p: [f32; 3]) -> f32 {
    clamp01(1.0 - 4.0 * dist2(p, 3))
}

/// Spherical distance field (Figure 5 sphere of the paper): `1 - 2 * |p - (0.5, 0.5, 0.5)|`
/// clamped to [0, 1]. NaN input gives 0.
pub fn sphere(p: [f32; 3]) -> f32 {
    clamp01(1.0 - 2.0 * dist2(p, 3).sqrt())
}

/// Cylindrical distance field about the axis through (0.5, 0.5, z) parallel to z:
/// `1 - 2 * sqrt((x - 0.5)^2 + (y - 0.5)^2)` clamped to [0, 1]. `z` is ignored (an infinite
/// cylinder, clipped only by the object's boundary). NaN in `x` or `y` gives 0.
pub fn cylinder(p: [f32; 3]) -> f32 {
    clamp01(1.0 - 2.0 * dist2(p, 2).sqrt())
}

/// The dataset coordinates that the rotational sweep (`VLU_SWEEP`) reads for object point `p`:
/// with `r` the distance of `p` from the vertical axis through (0.5, ·, 0.5), the profile is
/// sampled at `(2r, p[1], 0)`: profile x runs from the axis (0) to the rim of the cube's inscribed
/// cylinder (1), profile y is the height. `None` outside that cylinder (2r > 1) and for
/// non-finite `p`.
pub fn sweep_coords(p: [f32; 3]) -> Option<[f32; 3]> {
    if p.iter().any(|c| !c.is_finite()) {
        return None;
    }
    let (dx, dz) = (p[0] as f64 - 0.5, p[2] as f64 - 0.5);
    let u = 2.0 * (dx * dx + dz * dz).sqrt();
    (u <= 1.0).then_some([u as f32, p[1], 0.0])
}

/// The rotational sweep of the 2D profile dataset `id` at the sample's object point: the
/// dataset's value at [`sweep_coords`] (with the interpolation the object captured), 0 outside
/// the inscribed cylinder (where the dataset is not read, so an unknown `id` goes unnoticed
/// there). Errors are those of `vlSample` (`VL_BADID` for an unknown dataset). The caller
/// writes the value (the C `VLU_SWEEP` writes it to every field its `vlFunction` call named).
pub fn sweep(s: &mut Sample<'_>, id: i32) -> Result<f32> {
    match sweep_coords(s.position()) {
        Some(q) => s.dataset(id, q),
        None => Ok(0.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        use crate::dataset::{Dataset, Filter, Voxels};
        use crate::program::{Datasets, SampleEnv};
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
        sets.insert(7, Arc::new(d));
        let env = SampleEnv::new(Arc::new(sets), Filter::Trilinear);
        let at = |p: [f32; 3], id: i32| {
            let mut s = Sample::with_env(p, [0.0; 3], &env);
            sweep(&mut s, id)
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
        assert_eq!(sweep(&mut bare, 7).unwrap_err().code, ErrorCode::BadId);
    }
}
