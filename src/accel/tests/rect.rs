//! Tests of the entry map's rasterisation against the plain minimum.

use super::*;

/// `lower_rect` (in AVX-512 lanes where the processor has them: `lower_rect_wide`) is the
/// plain minimum over its rectangle and leaves every other value alone: rectangles of
/// every width from 1 to 40 (whole registers, remainders, both) at every third offset in
/// a row, values above, below and equal to the map's, ±∞ and −0.
#[test]
fn lower_rect_is_the_plain_minimum() {
    let (w, h) = (53usize, 7usize);
    let rng = crate::testing::Xorshift::new(0x10e5_7ec7_0001);
    let next = || rng.next();
    for width in 1..=40usize {
        for x0 in (0..=w - width).step_by(3) {
            let init: Vec<f64> = (0..w * h)
                .map(|i| match i % 11 {
                    0 => f64::INFINITY,
                    1 => -0.0,
                    _ => next() * 4.0 - 1.0,
                })
                .collect();
            let (y0, y1) = (x0 % h, (x0 % h + width % 4).min(h - 1));
            for v in [
                next() * 4.0 - 1.0,
                0.0,
                f64::NEG_INFINITY,
                init[y0 * w + x0],
            ] {
                let mut got = init.clone();
                lower_rect(&mut got, w, x0..=x0 + width - 1, y0..=y1, v);
                for (i, (&g, &b)) in got.iter().zip(&init).enumerate() {
                    let (x, y) = (i % w, i / w);
                    let inside = (x0..x0 + width).contains(&x) && (y0..=y1).contains(&y);
                    let want = if inside && v < b { v } else { b };
                    assert_eq!(
                        g.to_bits(),
                        want.to_bits(),
                        "width {width} x0 {x0} at ({x}, {y})"
                    );
                }
            }
        }
    }
}
