//! Tests of the lane-wise paths: cells found in SSE lanes against the cells axis by axis, the
//! interior test of eight cells, cell reads against the nodes read one by one, and
//! [`Dataset::trilinear8`]'s values, cells and gradients against the one-point path.

use super::*;

/// The cell in SSE lanes is the cell axis by axis, and its interior test the test on the
/// cell's indices; the values of eight points in lanes (`trilinear8`) are the values point
/// by point: inside, on and outside the box, at NaN and infinities, on grids with axes of
/// one to four nodes and the MNI grid's.
#[test]
fn cells_in_lanes_are_the_cells_axis_by_axis() {
    let mut rng = Lcg(11);
    let specials = [
        0.0,
        -0.0,
        1.0,
        0.5,
        1.0 - f32::EPSILON,
        1e-30,
        -1e-30,
        2.0,
        -3.0,
        1e30,
        -1e30,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        f32::MIN_POSITIVE,
    ];
    for (seed, dims) in [
        [9, 7, 8],
        [1, 6, 5],
        [2, 2, 2],
        [197, 233, 189],
        [1, 1, 1],
        [3, 1, 2],
    ]
    .into_iter()
    .enumerate()
    {
        let d = random_u8(dims, 20 + seed as u64);
        assert!(d.lanes.is_some(), "{dims:?} is small enough for lanes");
        trilinear8_is_trilinear(&d, &mut rng, &specials);
        let mut points: Vec<[f32; 3]> = (0..3000).map(|_| rng.point_around_box()).collect();
        for &a in &specials {
            for &b in &specials {
                points.push([a, b, 0.3]);
                points.push([0.7, a, b]);
            }
        }
        for p in points {
            let ((i, f), (j, g)) = (d.cell32(p), d.cell32_scalar(p));
            // Interior: the neighbourhood x0 − 1 … x0 + 2 (and so on) inside the grid.
            let inside = (0..3).all(|a| j[a] >= 1 && j[a] + 2 < dims[a]);
            assert_eq!(
                d.interior_cell32(p).map(|c| c.0),
                inside.then_some(j),
                "{p:?}"
            );
            assert_eq!(i, j, "{dims:?} {p:?}");
            // Equal as numbers: `maxps` makes max(−0, 0) = +0 where `f32::max` keeps −0,
            // a zero weight's sign that no lerp result depends on.
            assert_eq!(f, g, "{dims:?} {p:?}");
            assert!(f.iter().all(|w| w.is_finite() && (0.0..=1.0).contains(w)));
        }
    }
    // An axis longer than 2²⁴ nodes is not exact in f32 lanes: such a grid goes axis by
    // axis, in `trilinear8` too.
    let n = (1 << 24) + 2;
    let long = Dataset::new(
        [1, 1, n],
        Voxels::U8((0..n).map(|i| (i * 37 % 256) as u8).collect()),
        0.0,
        255.0,
    )
    .unwrap();
    assert!(long.lanes.is_none());
    trilinear8_is_trilinear(&long, &mut rng, &specials);
}

/// [`Dataset::interior8`] against the test axis by axis, on clamped coordinates drawn from
/// awkward numbers (±0, ±∞, subnormals, huge, 1 and the interior bound and their neighbours)
/// and random bits, at every count: every number but NaN, which `trilinear8` never writes
/// (checked here from NaN points).
#[test]
fn interior8_is_the_tests_axis_by_axis() {
    use wide::f32x8;
    let rng = crate::testing::Xorshift::new(0x2545_f491_4f6c_dd1du64);
    for dims in [[9, 7, 8], [4, 5, 4], [1, 6, 5], [3, 3, 3], [197, 233, 189]] {
        let d = random_u8(dims, 7);
        let Some([_, _, inner]) = d.lanes else {
            panic!("{dims:?} is small enough for lanes");
        };
        let axis_by_axis = |cells: &Cells8| {
            let inside = |axis: usize| {
                let cu = f32x8::new(cells.cu[axis]);
                cu.simd_ge(f32x8::ONE) & cu.simd_lt(f32x8::splat(inner[axis]))
            };
            let count = cells.count.min(8);
            (inside(0) & inside(1) & inside(2)).to_bitmask() & ((1 << count) - 1)
        };
        let mut specials = vec![
            0.0f32,
            -0.0,
            1.0,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            -f32::from_bits(1),
            1e30,
            -1e30,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for x in [1.0f32, inner[0], inner[1], inner[2]] {
            specials.extend([x, x.next_up(), x.next_down(), -x]);
        }
        let draw = || match rng.bits() % 4 {
            0 => loop {
                let x = f32::from_bits(rng.bits() as u32);
                if !x.is_nan() {
                    break x;
                }
            },
            1 => (rng.next() * 4.0 - 1.0) as f32 * inner[(rng.bits() % 3) as usize],
            _ => specials[(rng.bits() % specials.len() as u64) as usize],
        };
        for round in 0..20_000 {
            let cells = Cells8 {
                cu: std::array::from_fn(|_| std::array::from_fn(|_| draw())),
                count: round % 10,
                ..Cells8::default()
            };
            assert_eq!(
                d.interior8(&cells),
                axis_by_axis(&cells),
                "{dims:?} {cells:?}"
            );
        }
        // NaN and infinite points give clamped coordinates that are numbers.
        let mut cells = Cells8::default();
        for a in [f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.5] {
            let p = [[a; 8], [0.5; 8], [a; 8]];
            for count in [3, 8] {
                d.trilinear8(&p, count, None, &mut [0.0; 8], &mut cells);
                let cu = cells.cu.as_flattened();
                assert!(cu.iter().all(|x| !x.is_nan()), "{dims:?} {a}");
            }
        }
    }
}

/// A cell's value as the eight nodes read one by one (the second node along an axis of one
/// node is the first) and interpolated in the order of [`Dataset::trilinear_cell`]; 0 where
/// a coordinate lies outside [−2⁻²⁰, 1 + 2⁻²⁰] (the dataset is 0 there) or is NaN.
fn trilinear_by_nodes(d: &Dataset, p: [f32; 3]) -> f32 {
    let tol = 1.0 / 1048576.0;
    if !p.iter().all(|&x| x >= -tol && x <= 1.0 + tol) {
        return 0.0;
    }
    let ([i, j, k], [fx, fy, fz]) = d.cell32_scalar(p);
    let [nx, ny, nz] = d.dims;
    let n = |a: usize, b: usize, c: usize| {
        d.node(
            (i + a).min(nx - 1),
            (j + b).min(ny - 1),
            (k + c).min(nz - 1),
        )
    };
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let row = |b: usize, c: usize| lerp(n(0, b, c), n(1, b, c), fx);
    lerp(
        lerp(row(0, 0), row(1, 0), fy),
        lerp(row(0, 1), row(1, 1), fy),
        fz,
    )
    .clamp(0.0, 1.0)
}

/// The cells' nodes read from one span (and, in `trilinear8`, the cells' first nodes found
/// in f32 lanes) give the values of the eight nodes read one by one, bit for bit: on grids
/// with axes of one and two nodes, on the largest grid whose node indices are exact in f32
/// (2²⁴ nodes, points near its last cells) and on one node more (indices computed
/// axis by axis), with and without the lanes.
#[test]
fn cell_reads_are_the_nodes() {
    let mut rng = Lcg(13);
    let check = |d: &Dataset, points: &[[f32; 3]]| {
        let mut plain = d.clone();
        plain.index_lanes = None;
        for chunk in points.chunks(8) {
            let mut ps = [[0.5f32; 3]; 8];
            ps[..chunk.len()].copy_from_slice(chunk);
            let by_axis = std::array::from_fn(|axis| ps.map(|p| p[axis]));
            for count in [chunk.len(), chunk.len().min(4)] {
                let (got, fallback) = (
                    values8(d, &by_axis, count, None),
                    values8(&plain, &by_axis, count, None),
                );
                for (i, p) in ps.iter().enumerate().take(count) {
                    let want = trilinear_by_nodes(d, *p).to_bits();
                    assert_eq!(d.trilinear(*p).to_bits(), want, "{:?} {p:?}", d.dims);
                    assert_eq!(got[i].to_bits(), want, "{:?} {p:?} lane {i}", d.dims);
                    assert_eq!(fallback[i].to_bits(), want, "{:?} {p:?}", d.dims);
                }
            }
        }
    };
    for (seed, dims) in [
        [9, 7, 8],
        [1, 6, 5],
        [5, 1, 4],
        [4, 5, 1],
        [2, 2, 2],
        [1, 1, 1],
        [2, 1, 1],
        [197, 233, 189],
    ]
    .into_iter()
    .enumerate()
    {
        let d = random_u8(dims, 40 + seed as u64);
        assert!(d.index_lanes.is_some());
        let points: Vec<[f32; 3]> = (0..2000).map(|_| rng.point_around_box()).collect();
        check(&d, &points);
    }
    for (dims, exact) in [([2048, 2048, 4], true), ([2049, 2048, 4], false)] {
        let d = random_u8(dims, 50);
        assert!(d.lanes.is_some());
        assert_eq!(d.index_lanes.is_some(), exact, "{dims:?}");
        let mut points: Vec<[f32; 3]> = (0..2000)
            .map(|_| std::array::from_fn(|_| 1.0 - (rng.next() * 0.01) as f32))
            .collect();
        points.extend((0..200).map(|_| rng.point_around_box()));
        check(&d, &points);
    }
}

/// [`Dataset::trilinear8`]'s values, returned.
pub(super) fn values8(
    d: &Dataset,
    p: &[[f32; 8]; 3],
    count: usize,
    mask: Option<&CellMask>,
) -> [f32; 8] {
    let mut out = [1.0f32; 8]; // not 0: `trilinear8` sets every value
    d.trilinear8(p, count, mask, &mut out, &mut Cells8::default());
    out
}

/// [`Dataset::trilinear8`] at the first `count` points, for every count, against
/// [`Dataset::trilinear`] point by point: the same bits, and 0 past the count.
fn trilinear8_is_trilinear(d: &Dataset, rng: &mut Lcg, specials: &[f32]) {
    let mut points: Vec<[f32; 3]> = (0..400).map(|_| rng.point_around_box()).collect();
    for &a in specials {
        points.push([a, 0.4, 0.3]);
        points.push([0.7, a, 0.2]);
        points.push([0.1, 0.6, a]);
    }
    for (batch, chunk) in points.chunks(8).enumerate() {
        let mut ps = [[0.5f32; 3]; 8];
        ps[..chunk.len()].copy_from_slice(chunk);
        let by_axis = std::array::from_fn(|axis| ps.map(|p| p[axis]));
        let count = batch % 9;
        let got = values8(d, &by_axis, count, None);
        // A mask of no bits lets every cell through, as no mask does.
        let empty = CellMask::new(Vec::new());
        let unmasked = values8(d, &by_axis, count, Some(&empty));
        for (i, (p, got)) in ps.iter().zip(got).enumerate() {
            let want = if i < count { d.trilinear(*p) } else { 0.0 };
            assert_eq!(got.to_bits(), want.to_bits(), "{:?} {p:?} lane {i}", d.dims);
            assert_eq!(unmasked[i].to_bits(), want.to_bits(), "{:?} {p:?}", d.dims);
        }
    }
    trilinear8_cells(d, rng, specials);
}

/// [`Dataset::trilinear8`]'s cells against [`Dataset::interior_cell32`] point by point (an
/// interior bit exactly where that finds an interior cell, and then the same cell and
/// weights), and [`Dataset::trilinear_gradient_in`] in them against [`Dataset::gradient`],
/// bit for bit (one cache across the points, as in a ray): at random points, points in
/// the cells next to the faces and just either side of their nodes, and `specials`.
fn trilinear8_cells(d: &Dataset, rng: &mut Lcg, specials: &[f32]) {
    let mut points: Vec<[f32; 3]> = (0..400).map(|_| rng.point_around_box()).collect();
    for axis in 0..3 {
        let n = d.dims[axis];
        let last = n.saturating_sub(1).max(1) as f32;
        for node in [0, 1, 2, 3, n.saturating_sub(3), n.saturating_sub(2), n - 1] {
            let at = node as f32 / last;
            for a in [at, at.next_down(), at.next_up(), at + 0.3 / last] {
                let mut p = rng.point_around_box();
                p[axis] = a;
                points.push(p);
            }
        }
    }
    for &a in specials {
        points.push([a, 0.4, 0.3]);
        points.push([0.5, a, 0.6]);
    }
    let mut cache = CellGradients::default();
    let mut interior = 0;
    for (batch, chunk) in points.chunks(8).enumerate() {
        let mut ps = [[0.5f32; 3]; 8];
        ps[..chunk.len()].copy_from_slice(chunk);
        let by_axis = std::array::from_fn(|axis| ps.map(|p| p[axis]));
        let count = (batch + 5) % 9;
        // Not the defaults: `trilinear8` sets the count and the coordinates (the ones of
        // the eight lanes, interior in grids of more than 3 nodes a side, must go).
        let mut cells = Cells8 {
            count: 8,
            cu: [[1.0; 8]; 3],
            ..Cells8::default()
        };
        d.trilinear8(&by_axis, count, None, &mut [0.0; 8], &mut cells);
        let bits = d.interior8(&cells);
        assert_eq!(bits >> count, 0, "{:?}", d.dims);
        for (i, p) in ps.iter().enumerate().take(count) {
            let found = d.interior_cell32(*p);
            if bits >> i & 1 == 0 {
                // Only where the cells were not found in lanes may an interior cell have
                // no bit.
                assert!(found.is_none() || d.index_lanes.is_none(), "{p:?}");
                continue;
            }
            interior += 1;
            let (cell, f) = found.expect("an interior cell");
            assert_eq!(cells.at[i] as usize, d.node_index(cell), "{p:?}");
            let got = [cells.f[0][i], cells.f[1][i], cells.f[2][i]];
            assert_eq!(got.map(f32::to_bits), f.map(f32::to_bits), "{p:?}");
            let g = d.trilinear_gradient_in(&by_axis, &cells, i, &mut cache);
            let want = d.gradient(*p, Filter::Trilinear);
            // (But for the sign of a zero, which `trilinear_gradient_in` leaves.)
            let bits = |g: [f64; 3]| g.map(|x| (x + 0.0).to_bits());
            assert_eq!(bits(g), bits(want), "{p:?}");
        }
    }
    // A grid with interior cells had points in them.
    if d.dims.iter().all(|&n| n >= 4) && d.index_lanes.is_some() {
        assert!(interior > 10, "{:?}: {interior}", d.dims);
    }
}
