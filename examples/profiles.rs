//! Writes the profile images of the chess example (`examples/c/chess.c`): the silhouettes that
//! `VLU_SWEEP` turns about their axis into pieces, as the paper's chess pieces were made.
//!
//! ```text
//! cargo run --release --example profiles -- out      # out/pawn.png … out/king.png
//! target/release/vlconvert image out/pawn.png out/pawn.vlb    # and so on for each
//! ```
//!
//! Each piece is described in world units (one board square is 40) as a sequence of shapes in
//! the half-plane (r ≥ 0 the distance from the axis, y the height above the board), each added to
//! or cut from the silhouette in order: smooth radius-of-height curves, balls, ellipsoids, tori.
//! The image is the right half of the upright silhouette with the axis on its left edge, as
//! `VLU_SWEEP` expects: column 0 is the axis, the last column the rim at [`RIM`] units; row 0 is
//! the top. It is 16-bit grey, white inside. Pixels are the mean of 4 × 4 sub-pixel samples,
//! then the image is blurred with a Gaussian of [`SOFT`] units (mirrored at the axis), so that F
//! rises smoothly across the surface over about two world units: the central differences that
//! give normals then see a smooth field, not a staircase.
//!
//! Every image has [`PX`] pixels per world unit and a margin of [`MARGIN`] units above and below
//! the piece (and its rim beyond the widest part), so its height in units is
//! `(ny − 1) / PX − 2 · MARGIN`; chess.c reads the sizes from the .vlb headers.
//!
//! The knight is not rotationally symmetric. It is made of two images: `knight.png`, a swept
//! base, and `knight_head.png`, a horse's head in profile (not swept: chess.c extrudes it into a
//! slab standing on the base, facing +x, and takes the maximum of the two).

#[path = "common/say.rs"]
mod say;
use std::error::Error;
use std::path::Path;

/// Pixels per world unit.
const PX: f32 = 4.0;
/// The radius at the right edge of a sweep profile (the half-width of a piece's box), units.
const RIM: f32 = 17.0;
/// Empty space below and above each piece, units.
const MARGIN: f32 = 2.0;
/// Standard deviation of the Gaussian blur, units.
const SOFT: f32 = 0.55;
/// Sub-pixel samples per axis.
const SS: usize = 4;

/// One shape of a silhouette, in world units.
enum Shape {
    /// The region r ≤ R(y) for y in the knots' range, R a smooth (cubic Hermite) curve through
    /// the (y, r) knots, y increasing.
    Curve(&'static [(f32, f32)]),
    /// An ellipsoid on the axis: centre height, radial and vertical semi-axes.
    Ellipse(f32, f32, f32),
    /// A torus: centre height, radius of its centre circle, radius of its tube.
    Torus(f32, f32, f32),
    /// A cylinder on the axis: from height, to height, radius.
    Cylinder(f32, f32, f32),
}

use Shape::{Curve, Cylinder, Ellipse, Torus};

/// Whether (r, y) lies in `s`.
fn inside(s: &Shape, r: f32, y: f32) -> bool {
    match *s {
        Curve(k) => curve(k, y).is_some_and(|rad| r <= rad),
        Ellipse(c, a, b) => (r / a).powi(2) + ((y - c) / b).powi(2) <= 1.0,
        Torus(c, rc, a) => (r - rc).powi(2) + (y - c).powi(2) <= a * a,
        Cylinder(y0, y1, rad) => (y0..=y1).contains(&y) && r <= rad,
    }
}

/// The radius of a knot curve at height `y` (`None` outside its range): cubic Hermite with
/// finite-difference tangents (a Catmull-Rom spline for uneven knots).
fn curve(k: &[(f32, f32)], y: f32) -> Option<f32> {
    let n = k.len();
    if n < 2 || y < k[0].0 || y > k[n - 1].0 {
        return None;
    }
    let i = (0..n - 1).find(|&i| y <= k[i + 1].0).unwrap_or(n - 2);
    let ((y0, r0), (y1, r1)) = (k[i], k[i + 1]);
    let h = y1 - y0;
    if h <= 0.0 {
        return Some(r0.max(r1));
    }
    let slope = |a: usize, b: usize| (k[b].1 - k[a].1) / (k[b].0 - k[a].0);
    let m0 = if i == 0 {
        slope(0, 1)
    } else {
        slope(i - 1, i + 1)
    } * h;
    let m1 = if i + 2 >= n {
        slope(n - 2, n - 1)
    } else {
        slope(i, i + 2)
    } * h;
    let t = (y - y0) / h;
    let (t2, t3) = (t * t, t * t * t);
    let r = (2.0 * t3 - 3.0 * t2 + 1.0) * r0
        + (t3 - 2.0 * t2 + t) * m0
        + (-2.0 * t3 + 3.0 * t2) * r1
        + (t3 - t2) * m1;
    Some(r.max(0.0))
}

/// A piece: its name, its height in units, and its shapes, each added (`true`) or cut.
type Piece = (&'static str, f32, &'static [(bool, Shape)]);

/// The pieces. Each stands on a broad turned foot from y = 0. The knight's entry is only its
/// swept base, as tall as its head's image so that both fill the same box.
const PIECES: &[Piece] = &[
    (
        "pawn",
        35.0,
        &[
            (
                true,
                Curve(&[
                    (0.0, 13.6),
                    (1.2, 14.0),
                    (2.6, 13.6),
                    (3.8, 11.8),
                    (5.0, 11.0),
                    (6.2, 10.8),
                    (7.4, 9.0),
                    (9.5, 7.0),
                    (14.0, 5.4),
                    (18.5, 4.6),
                    (20.5, 4.5),
                ]),
            ),
            (true, Ellipse(20.8, 8.2, 1.5)),
            (true, Ball::at(27.7, 7.3)),
        ],
    ),
    (
        "rook",
        42.0,
        &[
            (
                true,
                Curve(&[
                    (0.0, 14.6),
                    (1.2, 15.0),
                    (2.8, 14.6),
                    (4.2, 12.6),
                    (5.6, 12.0),
                    (7.0, 11.8),
                    (8.2, 10.0),
                    (10.5, 9.2),
                    (22.0, 8.4),
                    (28.0, 8.8),
                    (30.5, 10.6),
                    (31.5, 12.0),
                    (32.2, 12.3),
                    (42.0, 12.3),
                ]),
            ),
            // A band between the body and the turret, a groove round the turret, and its hollow
            // top (the crenellations of a real rook are not rotationally symmetric).
            (true, Torus(29.6, 10.2, 1.2)),
            (false, Torus(36.6, 12.9, 1.2)),
            (false, Cylinder(38.5, 43.0, 8.6)),
        ],
    ),
    (
        "knight",
        HEAD_HEIGHT,
        &[
            (
                true,
                Curve(&[
                    (0.0, 14.6),
                    (1.2, 15.0),
                    (2.8, 14.6),
                    (4.2, 12.6),
                    (5.6, 12.0),
                    (7.0, 11.8),
                    (8.4, 10.6),
                    (10.0, 10.4),
                    (12.5, 11.0),
                    (13.6, 11.2),
                    (15.0, 11.0),
                ]),
            ),
            (true, Torus(13.0, 10.2, 1.4)),
        ],
    ),
    (
        "bishop",
        55.0,
        &[
            (
                true,
                Curve(&[
                    (0.0, 14.2),
                    (1.2, 14.6),
                    (2.7, 14.2),
                    (4.0, 12.4),
                    (5.3, 11.5),
                    (6.6, 11.3),
                    (8.0, 9.4),
                    (10.5, 7.4),
                    (18.0, 5.6),
                    (26.0, 4.6),
                    (29.0, 4.5),
                ]),
            ),
            (true, Ellipse(29.3, 8.8, 1.5)),
            (true, Ellipse(31.6, 6.6, 1.0)),
            (true, Ellipse(40.6, 6.9, 9.6)),
            // The mitre's cut, turned: a groove round its upper part.
            (false, Torus(44.0, 6.9, 1.3)),
            (true, Ellipse(51.0, 1.6, 1.6)),
            (true, Ball::at(52.8, 2.4)),
        ],
    ),
    (
        "queen",
        64.0,
        &[
            (
                true,
                Curve(&[
                    (0.0, 15.0),
                    (1.3, 15.5),
                    (2.9, 15.0),
                    (4.3, 13.2),
                    (5.7, 12.3),
                    (7.1, 12.0),
                    (8.4, 10.2),
                    (11.0, 8.2),
                    (22.0, 6.0),
                    (33.0, 5.0),
                    (38.0, 5.2),
                ]),
            ),
            (true, Ellipse(38.3, 10.0, 1.6)),
            (true, Ellipse(40.8, 7.6, 1.1)),
            (
                true,
                Curve(&[
                    (40.5, 5.4),
                    (45.0, 6.6),
                    (49.5, 8.8),
                    (53.0, 10.8),
                    (54.6, 11.4),
                ]),
            ),
            // The crown: a beaded rim round a dished top, and an orb.
            (true, Torus(54.4, 10.9, 1.5)),
            (false, Ellipse(59.5, 9.6, 5.6)),
            (true, Ellipse(56.0, 6.0, 2.4)),
            (true, Ball::at(59.2, 3.6)),
            (true, Ball::at(63.1, 1.6)),
        ],
    ),
    (
        "king",
        74.0,
        &[
            (
                true,
                Curve(&[
                    (0.0, 15.2),
                    (1.3, 15.7),
                    (2.9, 15.2),
                    (4.3, 13.4),
                    (5.7, 12.5),
                    (7.1, 12.2),
                    (8.4, 10.4),
                    (11.0, 8.4),
                    (24.0, 6.3),
                    (37.0, 5.3),
                    (41.0, 5.5),
                ]),
            ),
            (true, Ellipse(41.3, 10.4, 1.6)),
            (true, Ellipse(43.8, 8.0, 1.1)),
            (
                true,
                Curve(&[
                    (43.5, 5.8),
                    (49.0, 7.4),
                    (54.0, 9.4),
                    (57.0, 10.4),
                    (58.5, 10.5),
                ]),
            ),
            (true, Ellipse(58.5, 10.5, 3.4)),
            // The cross is not rotationally symmetric: turned, it is a finial (a post with a
            // collar and a knob).
            (true, Ellipse(62.4, 3.4, 1.6)),
            (true, Cylinder(62.0, 72.0, 1.8)),
            (true, Ellipse(68.0, 4.6, 1.3)),
            (true, Ball::at(72.0, 2.0)),
        ],
    ),
];

/// Balls on the axis (an ellipse with equal semi-axes), for readable tables.
struct Ball;

impl Ball {
    const fn at(y: f32, r: f32) -> Shape {
        Ellipse(y, r, r)
    }
}

/// The knight's head in profile, facing +x, as a polygon in units over its box: x from 0 to
/// 2 · RIM (the box's width), y the height above the board.
const HEAD: &[(f32, f32)] = &[
    // The back of the neck, rising from the base to the mane.
    (8.5, 11.0),
    (6.8, 17.0),
    (6.0, 23.5),
    (6.4, 30.0),
    (7.8, 35.8),
    (10.2, 40.6),
    (13.4, 44.2),
    // The ear.
    (16.4, 46.0),
    (18.6, 49.0),
    (20.2, 45.6),
    // The forehead and the bridge of the nose, down to the muzzle.
    (23.2, 43.8),
    (27.2, 40.4),
    (30.6, 36.6),
    (32.2, 34.0),
    (32.0, 31.6),
    // The mouth, the chin and the jaw.
    (28.4, 30.8),
    (30.6, 29.2),
    (29.6, 27.6),
    (26.6, 27.0),
    (23.0, 27.8),
    (20.4, 27.0),
    // The throat and the chest.
    (18.8, 24.0),
    (18.8, 20.4),
    (20.6, 16.4),
    (23.8, 13.2),
    (25.8, 11.0),
];

/// The height of the knight's head box, units: the tip of the ear.
const HEAD_HEIGHT: f32 = 49.0;

/// Whether (x, y) lies inside the polygon (even-odd rule).
fn in_polygon(poly: &[(f32, f32)], x: f32, y: f32) -> bool {
    let mut odd = false;
    let mut j = poly.len() - 1;
    for i in 0..poly.len() {
        let ((xi, yi), (xj, yj)) = (poly[i], poly[j]);
        if (yi > y) != (yj > y) && x < xi + (y - yi) / (yj - yi) * (xj - xi) {
            odd = !odd;
        }
        j = i;
    }
    odd
}

/// A grey image of `w` × `h` pixels in [0, 1]: `test(x, y)` on 4 × 4 sub-pixels, where pixel
/// (i, j) is centred on (x0 + i / PX, y1 − j / PX) (row 0 at the top).
fn raster(w: usize, h: usize, x0: f32, y1: f32, test: impl Fn(f32, f32) -> bool) -> Vec<f32> {
    let mut img = vec![0.0f32; w * h];
    for j in 0..h {
        for i in 0..w {
            let mut hits = 0;
            for sj in 0..SS {
                for si in 0..SS {
                    let dx = ((si as f32 + 0.5) / SS as f32 - 0.5) / PX;
                    let dy = ((sj as f32 + 0.5) / SS as f32 - 0.5) / PX;
                    if test(x0 + i as f32 / PX + dx, y1 - j as f32 / PX - dy) {
                        hits += 1;
                    }
                }
            }
            img[j * w + i] = hits as f32 / (SS * SS) as f32;
        }
    }
    img
}

/// Separable Gaussian blur of [`SOFT`] units; columns left of 0 mirror the image when `mirror`
/// (the axis of a sweep), else they are 0, as everything beyond the other edges.
fn blur(img: &[f32], w: usize, h: usize, mirror: bool) -> Vec<f32> {
    let sigma = SOFT * PX;
    let rad = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f32> = (-rad..=rad)
        .map(|d| (-(d * d) as f32 / (2.0 * sigma * sigma)).exp())
        .collect();
    let sum: f32 = kernel.iter().sum();
    let kernel: Vec<f32> = kernel.iter().map(|k| k / sum).collect();
    let mut tmp = vec![0.0f32; w * h];
    for j in 0..h {
        for i in 0..w {
            let mut acc = 0.0;
            for (t, k) in kernel.iter().enumerate() {
                let mut x = i as isize + t as isize - rad;
                if x < 0 && mirror {
                    x = -x;
                }
                if (0..w as isize).contains(&x) {
                    acc += k * img[j * w + x as usize];
                }
            }
            tmp[j * w + i] = acc;
        }
    }
    let mut out = vec![0.0f32; w * h];
    for j in 0..h {
        for i in 0..w {
            let mut acc = 0.0;
            for (t, k) in kernel.iter().enumerate() {
                let y = j as isize + t as isize - rad;
                if (0..h as isize).contains(&y) {
                    acc += k * tmp[y as usize * w + i];
                }
            }
            out[j * w + i] = acc;
        }
    }
    out
}

/// Writes a 16-bit grey PNG.
fn save(path: &Path, img: &[f32], w: usize, h: usize) -> Result<(), Box<dyn Error>> {
    let px: Vec<u16> = img
        .iter()
        .map(|v| (v.clamp(0.0, 1.0) * 65535.0).round() as u16)
        .collect();
    let buf = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w as u32, h as u32, px)
        .ok_or("image size")?;
    buf.save(path)?;
    say::say(format_args!("wrote {} ({w}x{h})", path.display()))?;
    Ok(())
}

/// Pixels spanning `units` world units, nodes at both ends.
fn pixels(units: f32) -> usize {
    (units * PX).round() as usize + 1
}

fn main() -> Result<(), Box<dyn Error>> {
    let dir = std::env::args().nth(1).unwrap_or_else(|| ".".into());
    let dir = Path::new(&dir);
    std::fs::create_dir_all(dir)?;
    for (name, height, shapes) in PIECES {
        let (w, h) = (pixels(RIM), pixels(height + 2.0 * MARGIN));
        let img = raster(w, h, 0.0, height + MARGIN, |r, y| {
            shapes.iter().fold(
                false,
                |acc, (add, s)| {
                    if inside(s, r, y) {
                        *add
                    } else {
                        acc
                    }
                },
            )
        });
        save(
            &dir.join(format!("{name}.png")),
            &blur(&img, w, h, true),
            w,
            h,
        )?;
    }
    let (w, h) = (pixels(2.0 * RIM), pixels(HEAD_HEIGHT + 2.0 * MARGIN));
    let img = raster(w, h, 0.0, HEAD_HEIGHT + MARGIN, |x, y| {
        in_polygon(HEAD, x, y)
    });
    save(&dir.join("knight_head.png"), &blur(&img, w, h, false), w, h)?;
    Ok(())
}
