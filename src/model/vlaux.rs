//! The auxiliary library ("vlaux"): procedural helpers that build volume objects and
//! textures. It owns Perlin's improved gradient noise and turbulence (with deterministic,
//! seedable permutation tables), the Catmull-Rom `spline` of Ebert et al., and the analytic
//! distance fields (`parab1`, `sphere`, `cylinder`) defined on the unit cube, and the rotational
//! sweep of a 2D profile dataset (`sweep`, `sweep_coords`). Every function but `sweep` is pure,
//! deterministic and total: any input, including NaN, infinities and huge values, yields a
//! finite result; `sweep` reads a dataset through the sample it is given.
//!
//! It owns nothing of the state machine or the renderer: these are functions a field
//! function may call, and the C layer exports them as `vlaux.h`.

use crate::error::Result;
use crate::model::program::Sample;
use crate::types::DatasetId;

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
pub fn sweep(s: &mut Sample<'_>, id: DatasetId) -> Result<f32> {
    match sweep_coords(s.position()) {
        Some(q) => s.dataset(id, q),
        None => Ok(0.0),
    }
}

#[cfg(test)]
mod tests;
