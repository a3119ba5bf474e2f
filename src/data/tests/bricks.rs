//! Tests of the brick ranges: the extremes of each brick's padded span, by brute force.

use super::*;

#[test]
fn brick_ranges_are_the_extremes_of_their_padded_spans() {
    // 8- and 16-bit voxels, normalisations that increase and decrease, unclamped (so
    // that the extremes differ between spans) and clamped (plateaus at 0 and 1): the
    // ranges come from the raw extremes, and must still be the node values' extremes.
    let cases = [
        ([13, 9, 11], 5, false, (0.0, 255.0)),
        ([2, 17, 6], 6, false, (0.0, 255.0)),
        ([9, 1, 5], 7, false, (0.0, 255.0)),
        ([13, 9, 11], 8, false, (200.0, 40.0)),
        ([11, 10, 9], 9, false, (90.0, 130.0)),
        ([13, 9, 11], 10, true, (-5000.0, 70000.0)),
        ([10, 12, 7], 11, true, (66000.0, -100.0)),
        ([10, 12, 7], 12, true, (30000.0, 36000.0)),
    ];
    for (dims, seed, wide, (na, nb)) in cases {
        let mut rng = Lcg(seed);
        let n: usize = dims.iter().product();
        let raw = if wide {
            Voxels::U16((0..n).map(|_| (rng.next() * 65536.0) as u16).collect())
        } else {
            Voxels::U8((0..n).map(|_| (rng.next() * 256.0) as u8).collect())
        };
        let d = Dataset::new(dims, raw, na, nb).unwrap();
        for (filter, pad) in [
            (Filter::Trilinear, 1),
            (Filter::Cubic { b: 0.0, c: 0.5 }, 2),
        ] {
            let b = d.bricks(filter);
            for (bk, bj, bi) in (0..b.dims[2]).flat_map(|k| {
                (0..b.dims[1]).flat_map(move |j| (0..b.dims[0]).map(move |i| (k, j, i)))
            }) {
                // By brute force: every node within `pad` of the brick's node span.
                let span = |b: usize, n: usize| {
                    (
                        (b * BRICK).saturating_sub(pad),
                        (b * BRICK + BRICK + pad).min(n - 1),
                    )
                };
                let ((x0, x1), (y0, y1), (z0, z1)) =
                    (span(bi, dims[0]), span(bj, dims[1]), span(bk, dims[2]));
                let (mut mn, mut mx) = (f32::INFINITY, f32::NEG_INFINITY);
                for z in z0..=z1 {
                    for y in y0..=y1 {
                        for x in x0..=x1 {
                            mn = mn.min(d.node(x, y, z));
                            mx = mx.max(d.node(x, y, z));
                        }
                    }
                }
                let at = format!("{dims:?} a {na} b {nb} brick {bi} {bj} {bk}");
                assert_eq!(b.get(bi, bj, bk), (mn, mx), "{at}");
            }
        }
    }
}
