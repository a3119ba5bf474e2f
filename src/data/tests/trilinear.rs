//! Tests of the specialised trilinear path: its gradient against the row-by-row read and the
//! plain one, its value and gradient against the generic filter, and the cell's lerps in lanes
//! against the scalar lerps.

use super::super::trilinear::trilinear_rows;
use super::*;

/// A [`CellGradients`] whose differences are in the order (x, y, z), for
/// [`gradient_row_by_row`].
struct XyzCellGradients {
    lo: usize,
    diffs: [[f32; 4]; 8],
}

/// `Dataset::trilinear_gradient_at` the plain way: each row bounds-checked on its own, the
/// differences gathered by a transpose in the order (x, y, z), and the products summed in a
/// loop from 0; the oracle of `gradient_rows_are_the_row_by_row_read`.
fn gradient_row_by_row(
    d: &Dataset,
    lo: usize,
    [fx, fy, fz]: [f32; 3],
    cache: &mut XyzCellGradients,
) -> Option<[f64; 3]> {
    if cache.lo != lo {
        let (sy, sz) = (d.strides[1], d.strides[2]);
        let v = d.values();
        let last = v.len().checked_sub(4)?;
        let row = |j: usize, k: usize| -> Option<[f32; 4]> {
            let o = lo + j * sy + k * sz;
            if o > last {
                return None;
            }
            v.get(o..o + 4)?.try_into().ok()
        };
        let (r10, r20) = (row(1, 0)?, row(2, 0)?);
        let (r01, r11, r21, r31) = (row(0, 1)?, row(1, 1)?, row(2, 1)?, row(3, 1)?);
        let (r02, r12, r22, r32) = (row(0, 2)?, row(1, 2)?, row(2, 2)?, row(3, 2)?);
        let (r13, r23) = (row(1, 3)?, row(2, 3)?);
        let corners = [
            (r11, r01, r21, r10, r12),
            (r21, r11, r31, r20, r22),
            (r12, r02, r22, r11, r13),
            (r22, r12, r32, r21, r23),
        ];
        use wide::f32x4;
        for (c, (r, ym, yp, zm, zp)) in corners.into_iter().enumerate() {
            let dx = f32x4::new([0.0, r[2], r[3], 0.0]) - f32x4::new([0.0, r[0], r[1], 0.0]);
            let dy = f32x4::new(yp) - f32x4::new(ym);
            let dz = f32x4::new(zp) - f32x4::new(zm);
            let [_, first, second, _] = f32x4::transpose([dx, dy, dz, f32x4::ZERO]);
            cache.diffs[2 * c] = first.to_array();
            cache.diffs[2 * c + 1] = second.to_array();
        }
        cache.lo = lo;
    }
    let (gx, gy, gz) = (1.0 - fx, 1.0 - fy, 1.0 - fz);
    let xy = wide::f32x4::new([gx, fx, gx, fx]) * wide::f32x4::new([gy, gy, fy, fy]);
    let near = (xy * wide::f32x4::splat(gz)).to_array();
    let far = (xy * wide::f32x4::splat(fz)).to_array();
    let weights = [
        near[0], near[1], near[2], near[3], far[0], far[1], far[2], far[3],
    ];
    let mut g = wide::f32x4::ZERO;
    for (wt, d) in weights.into_iter().zip(cache.diffs) {
        g += wide::f32x4::splat(wt) * wide::f32x4::new(d);
    }
    let g = g.to_array();
    Some([
        g[0] as f64 * d.half_last[0],
        g[1] as f64 * d.half_last[1],
        g[2] as f64 * d.half_last[2],
    ])
}

/// The same bits, or both NaN (a NaN's payload is not promised).
fn same_f64(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// The trilinear gradient's rows read under the test of the neighbourhood's last row, and
/// its differences gathered in the order (y, z, x), give a gradient exactly for the
/// neighbourhood starts whose last row lies inside the values (every interior cell's:
/// `specialised_trilinear_paths_agree_with_the_generic_filter`), and there the bits of the
/// row-by-row read ([`gradient_row_by_row`]), through a cache that hits and misses, on values
/// of every kind (random bits: NaNs, infinities, subnormals, ±0, huge) and awkward weights.
#[test]
fn gradient_rows_are_the_row_by_row_read() {
    let rng = crate::testing::Xorshift::new(0x5eed_6a0d);
    let weight = |rng: &crate::testing::Xorshift| -> f32 {
        match rng.bits() % 8 {
            0 => 0.0,
            1 => -0.0,
            2 => 1.0,
            3 => f32::from_bits(rng.bits() as u32),
            4 => f32::from_bits(1),
            _ => rng.next() as f32,
        }
    };
    for (dims, bits) in [
        ([4, 4, 4], false),
        ([5, 4, 6], false),
        ([7, 5, 4], true),
        ([4, 9, 5], true),
        ([6, 6, 6], true),
    ] {
        let mut d = random_u8(dims, 21);
        if bits {
            // Any f32 at all, to check the lanes' operations, not only the dataset's
            // values in [0, 1].
            let n = d.raw.len();
            d.values = std::sync::OnceLock::from(
                (0..n)
                    .map(|i| match i % 13 {
                        0 => -0.0,
                        1 => f32::NAN,
                        2 => f32::INFINITY,
                        3 => f32::NEG_INFINITY,
                        4 => f32::from_bits(rng.bits() as u32 & 0x807f_ffff),
                        5 => f32::MAX,
                        _ => f32::from_bits(rng.bits() as u32),
                    })
                    .collect::<Vec<f32>>(),
            );
        }
        let (mut cache, mut xyz_cache) = (
            CellGradients::default(),
            XyzCellGradients {
                lo: usize::MAX,
                diffs: [[0.0; 4]; 8],
            },
        );
        for lo in 0..d.raw.len() + 3 {
            for _ in 0..3 {
                let f = [weight(&rng), weight(&rng), weight(&rng)];
                let got = d.trilinear_gradient_at::<true>(lo, f, &mut cache);
                let (sy, sz) = (d.strides[1], d.strides[2]);
                let inside = lo + 3 * sy + 3 * sz + 4 <= d.raw.len();
                assert_eq!(got.is_some(), inside, "{dims:?} lo {lo}");
                // (The plain read where the gradient reads, the same cache traffic.)
                let want = if inside {
                    gradient_row_by_row(&d, lo, f, &mut xyz_cache)
                } else {
                    None
                };
                assert_eq!(got.is_some(), want.is_some(), "{dims:?} lo {lo}");
                if let (Some(g), Some(w)) = (got, want) {
                    assert!(
                        g.iter().zip(w).all(|(&g, w)| same_f64(g, w)),
                        "{dims:?} lo {lo} {f:?}: {g:?} vs {w:?}"
                    );
                }
                // A fresh cache: the miss's path at every start, not only the first.
                let fresh = d.trilinear_gradient_at::<true>(lo, f, &mut CellGradients::default());
                // Without the signed zeros: the same but for the sign of a zero.
                let unsigned =
                    d.trilinear_gradient_at::<false>(lo, f, &mut CellGradients::default());
                assert_eq!(
                    unsigned.map(|g| g.map(|x| (x + 0.0).to_bits())),
                    fresh.map(|g| g.map(|x| (x + 0.0).to_bits())),
                    "{dims:?} lo {lo}"
                );
                assert_eq!(
                    fresh.map(|g| g.map(f64::to_bits)),
                    got.map(|g| g.map(f64::to_bits)),
                    "{dims:?} lo {lo}"
                );
            }
        }
    }
}

/// A trilinear value read before the node values are made reads the cell's voxels through the
/// table of their normalisation and does not make the node values; it is the value read from
/// the node values, bit for bit, one point at a time and eight in lanes (`trilinear8`): at
/// points inside, on and outside grids of 8- and 16-bit voxels (one of them a single node
/// across x, whose x-stride is 0), under normalisations that increase, decrease and clamp.
#[test]
fn values_read_from_the_voxels_are_those_of_the_node_values() {
    let rng = crate::testing::Xorshift::new(0x7a1e_5eed);
    for (dims, wide, (a, b)) in [
        ([4, 4, 4], false, (10.0, 240.0)),
        ([5, 7, 6], false, (255.0, 0.0)),
        ([1, 5, 4], false, (-3.5, 100.25)),
        ([4, 6, 5], true, (0.0, 65535.0)),
        ([7, 4, 5], true, (40000.0, 1000.0)),
        ([1, 4, 6], true, (-100.0, 30000.0)),
    ] {
        let n: usize = dims.iter().product();
        let voxels = if wide {
            Voxels::U16((0..n).map(|_| rng.bits() as u16).collect())
        } else {
            Voxels::U8((0..n).map(|_| rng.bits() as u8).collect())
        };
        let raw = Dataset::new(dims, voxels, a, b).unwrap();
        let made = raw.clone();
        made.values();
        let point = |k: usize| -> [f32; 3] {
            std::array::from_fn(|_| match k % 7 {
                0 => (rng.bits() % 5) as f32 / 4.0,
                _ => rng.next() as f32 * 1.2 - 0.1,
            })
        };
        for k in 0..2000 {
            let p = point(k);
            let (got, want) = (raw.trilinear(p), made.trilinear(p));
            assert_eq!(got.to_bits(), want.to_bits(), "{dims:?} {p:?}");
        }
        let mut cells = crate::data::Cells8::default();
        for k in 0..250 {
            let ps: [[f32; 3]; 8] = std::array::from_fn(|i| point(8 * k + i));
            let by_axis: [[f32; 8]; 3] = std::array::from_fn(|a| ps.map(|p| p[a]));
            let (mut got, mut want) = ([0f32; 8], [0f32; 8]);
            raw.trilinear8(&by_axis, 8, None, &mut got, &mut cells);
            made.trilinear8(&by_axis, 8, None, &mut want, &mut cells);
            assert_eq!(
                got.map(f32::to_bits),
                want.map(f32::to_bits),
                "{dims:?} {ps:?}"
            );
        }
        assert!(
            !raw.values_made(),
            "{dims:?}: the values made the node values"
        );
    }
}

/// A gradient read before the node values are made reads the voxels through the table of
/// their normalisation and does not make the node values; it is the gradient read from the
/// node values, bit for bit: at every neighbourhood start of grids of 8- and 16-bit voxels
/// (both ends of the 16-bit range among them), under normalisations that increase, decrease
/// and clamp, through a cache that hits and misses.
#[test]
fn gradients_read_from_the_voxels_are_those_of_the_node_values() {
    let rng = crate::testing::Xorshift::new(0x6a0d_b17e);
    for (dims, wide, (a, b)) in [
        ([4, 4, 4], false, (10.0, 240.0)),
        ([5, 7, 6], false, (255.0, 0.0)),
        ([6, 5, 4], false, (-3.5, 100.25)),
        ([4, 6, 5], true, (0.0, 65535.0)),
        ([7, 4, 5], true, (40000.0, 1000.0)),
        ([5, 5, 9], true, (-100.0, 30000.0)),
    ] {
        let n: usize = dims.iter().product();
        let voxels = if wide {
            // Every 16-bit value's neighbourhood is not possible in so few voxels: both ends,
            // and the rest at random.
            Voxels::U16(
                (0..n)
                    .map(|i| match i % 11 {
                        0 => 0,
                        1 => u16::MAX,
                        _ => rng.bits() as u16,
                    })
                    .collect(),
            )
        } else {
            Voxels::U8(
                (0..n)
                    .map(|i| (i * 7 + rng.bits() as usize % 5) as u8)
                    .collect(),
            )
        };
        let raw = Dataset::new(dims, voxels, a, b).unwrap();
        let made = raw.clone();
        made.values();
        let (mut cache, mut made_cache) = (CellGradients::default(), CellGradients::default());
        for lo in 0..n + 3 {
            for _ in 0..3 {
                let f = [rng.next() as f32, rng.next() as f32, rng.next() as f32];
                let got = raw.trilinear_gradient_at::<true>(lo, f, &mut cache);
                let want = made.trilinear_gradient_at::<true>(lo, f, &mut made_cache);
                assert_eq!(
                    got.map(|g| g.map(f64::to_bits)),
                    want.map(|g| g.map(f64::to_bits)),
                    "{dims:?} lo {lo} {f:?}"
                );
            }
        }
        assert!(
            !raw.values_made(),
            "{dims:?}: the gradients made the node values"
        );
    }
}

/// The interior trilinear gradient the plain way, for bit-for-bit comparisons: the cell
/// axis by axis, each corner's central differences read node by node, the weights as
/// products, each axis summed corner by corner in f32, then 0.5·g·(n − 1) in f64.
fn plain_interior_gradient(d: &Dataset, p: [f32; 3]) -> [f64; 3] {
    let ([x0, y0, z0], [fx, fy, fz]) = d.cell32_scalar(p);
    let (gx, gy, gz) = (1.0 - fx, 1.0 - fy, 1.0 - fz);
    let mut g = [0f32; 3];
    for corner in 0..8 {
        let [i, j, k] = [
            x0 + (corner & 1),
            y0 + (corner >> 1 & 1),
            z0 + (corner >> 2),
        ];
        let w = [gx, fx][corner & 1] * [gy, fy][corner >> 1 & 1] * [gz, fz][corner >> 2];
        let diffs = [
            d.node(i + 1, j, k) - d.node(i - 1, j, k),
            d.node(i, j + 1, k) - d.node(i, j - 1, k),
            d.node(i, j, k + 1) - d.node(i, j, k - 1),
        ];
        for (g, diff) in g.iter_mut().zip(diffs) {
            *g += w * diff;
        }
    }
    std::array::from_fn(|axis| 0.5 * g[axis] as f64 * d.last[axis])
}

#[test]
fn specialised_trilinear_paths_agree_with_the_generic_filter() {
    let d = random_u8([9, 7, 8], 8);
    let mut rng = Lcg(9);
    let (mut cache, mut hits) = (CellGradients::default(), 0);
    for _ in 0..5000 {
        let p = rng.point_around_box();
        let u = [d.index(p[0], 0), d.index(p[1], 1), d.index(p[2], 2)];
        let generic = d.filter(u, Filter::Trilinear, |i, j, k| d.node(i, j, k) as f64);
        // (Outside the cube the dataset is 0: `a_dataset_is_zero_outside_its_cube`.)
        let generic = if d.covers(p) { generic } else { 0.0 };
        // f32 index arithmetic: the weights are off by at most an ulp of the index (n < 16
        // here: 1e-6), times node differences of at most 1.
        assert!(
            (d.trilinear(p) as f64 - generic.clamp(0.0, 1.0)).abs() < 4e-6,
            "{p:?}"
        );
        // The cached path gives the same bits as a fresh read, whether the cache holds the
        // point's cell (a second point close by mostly shares it) or another one.
        for q in [p, [p[0] + 1e-3, p[1] - 1e-3, p[2] + 1e-3]] {
            let fresh = d.trilinear_gradient_interior(q, &mut CellGradients::default());
            let lo = d.interior_cell32(q).map(|(c, _)| d.neighbourhood_lo(c));
            // Every interior cell takes the specialised path (its rows are all inside).
            assert_eq!(fresh.is_some(), lo.is_some(), "{q:?}");
            hits += usize::from(fresh.is_some() && Some(cache.lo) == lo);
            assert_eq!(d.trilinear_gradient_interior(q, &mut cache), fresh, "{q:?}");
        }
        if let Some(g) = d.trilinear_gradient_interior(p, &mut CellGradients::default()) {
            let want = plain_interior_gradient(&d, p);
            assert_eq!(g.map(f64::to_bits), want.map(f64::to_bits), "{p:?}");
            for (axis, g) in g.into_iter().enumerate() {
                let n = d.dims()[axis];
                let want = d.filter(u, Filter::Trilinear, |i, j, k| {
                    d.node_derivative(i, j, k, axis)
                }) * (n - 1) as f64;
                assert!(
                    (g - want).abs() < 1e-5 * (n as f64),
                    "{p:?} axis {axis}: {g} vs {want}"
                );
            }
        }
    }
    assert!(hits > 500, "only {hits} cache hits tested");
    // Degenerate axes take the generic route where needed and stay constant.
    let slab = random_u8([5, 4, 1], 10);
    let a = slab.sample([0.3, 0.6, 0.0], Filter::Trilinear);
    assert_eq!(a, slab.sample([0.3, 0.6, 0.9], Filter::Trilinear));
}

/// [`trilinear_rows`] in lanes against the scalar lerps, bit for bit, on nodes and weights
/// drawn from awkward values (NaN, ±0, ±∞, subnormals, huge, the unit interval's ends) and from
/// random bits, and on the usual nodes in [0, 1] with weights in [0, 1). Where both give NaN only that is required: Rust leaves a NaN's
/// payload unspecified, and the compiler may swap a sum's or product's operands.
#[test]
fn trilinear_rows_is_the_scalar_lerps() {
    let scalar = |[r00, r10, r01, r11]: [[f32; 2]; 4], [fx, fy, fz]: [f32; 3]| {
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let (c00, c10, c01, c11) = (
            lerp(r00[0], r00[1], fx),
            lerp(r10[0], r10[1], fx),
            lerp(r01[0], r01[1], fx),
            lerp(r11[0], r11[1], fx),
        );
        lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz).clamp(0.0, 1.0)
    };
    let rng = crate::testing::Xorshift::new(0x9e37_79b9_7f4a_7c15u64);
    let specials = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.5,
        1.0 - f32::EPSILON / 2.0,
        f32::MIN_POSITIVE,
        f32::MIN_POSITIVE / 8.0,
        -f32::MIN_POSITIVE / 8.0,
        f32::from_bits(1),
        1e30,
        -1e30,
        f32::MAX,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        -f32::NAN,
    ];
    let special = || specials[(rng.bits() % specials.len() as u64) as usize];
    let awkward = || match rng.bits() % 4 {
        0 => f32::from_bits(rng.bits() as u32),
        1 => rng.next() as f32,
        _ => special(),
    };
    let unit = || rng.next() as f32;
    for round in 0..400_000 {
        let draw = || if round % 2 == 0 { awkward() } else { unit() };
        let rows: [[f32; 2]; 4] = std::array::from_fn(|_| [draw(), draw()]);
        let f: [f32; 3] = std::array::from_fn(|_| draw());
        let [r00, r10, r01, r11] = rows;
        let z0 = [r00[0], r00[1], r01[0], r01[1]];
        let new = trilinear_rows(z0, [r10[0], r10[1], r11[0], r11[1]], f);
        let want = scalar(rows, f);
        assert!(
            new.to_bits() == want.to_bits() || (new.is_nan() && want.is_nan()),
            "{rows:?} {f:?}: {new:?} against {want:?}"
        );
    }
}
