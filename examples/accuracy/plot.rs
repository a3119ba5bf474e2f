//! The accuracy study's plots: drawn with the `image` crate and a built-in 5×7 bitmap font
//! (`font`: no system fonts needed).

use image::{Rgb, RgbImage};
use std::path::Path;

pub const PALETTE: [[u8; 3]; 6] = [
    [31, 119, 180],
    [214, 39, 40],
    [44, 160, 44],
    [148, 103, 189],
    [255, 127, 14],
    [23, 190, 207],
];

pub struct Point {
    pub x: f64,
    pub y: f64,
    pub label: String,
    pub pareto: bool,
}

pub struct Series {
    pub name: String,
    pub colour: [u8; 3],
    pub points: Vec<Point>,
    /// Join the points in sweep order (a one-control sweep) and label them all; otherwise
    /// (a grid) only the Pareto front is joined and labelled.
    pub sweep: bool,
}

const W: u32 = 640;
const H: u32 = 420;
const LEFT: i32 = 58;
const RIGHT: i32 = 628;
const TOP: i32 = 26;
const BOTTOM: i32 = 344;
/// Errors below this are drawn at it.
const FLOOR: f64 = 1e-3;

struct Canvas(RgbImage);

impl Canvas {
    fn put(&mut self, x: i32, y: i32, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as u32) < W && (y as u32) < H {
            self.0.put_pixel(x as u32, y as u32, Rgb(c));
        }
    }

    fn line(&mut self, (x0, y0): (i32, i32), (x1, y1): (i32, i32), c: [u8; 3], dash: bool) {
        let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
        let (sx, sy) = (if x0 < x1 { 1 } else { -1 }, if y0 < y1 { 1 } else { -1 });
        let (mut x, mut y, mut err, mut i) = (x0, y0, dx + dy, 0u32);
        loop {
            if !dash || (i / 3) % 2 == 0 {
                self.put(x, y, c);
            }
            i += 1;
            if x == x1 && y == y1 {
                break;
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
        }
    }

    fn thick(&mut self, a: (i32, i32), b: (i32, i32), c: [u8; 3]) {
        for (ox, oy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            self.line((a.0 + ox, a.1 + oy), (b.0 + ox, b.1 + oy), c, false);
        }
    }

    fn disc(&mut self, (cx, cy): (i32, i32), r: i32, c: [u8; 3], ring: Option<[u8; 3]>) {
        for y in -r - 1..=r + 1 {
            for x in -r - 1..=r + 1 {
                let d2 = x * x + y * y;
                if d2 <= r * r {
                    self.put(cx + x, cy + y, c);
                } else if d2 <= (r + 1) * (r + 1) {
                    if let Some(k) = ring {
                        self.put(cx + x, cy + y, k);
                    }
                }
            }
        }
    }

    /// Text in the 5×7 font, `scale` pixels per font pixel, top-left at (x, y).
    fn text(&mut self, x: i32, y: i32, s: &str, c: [u8; 3], scale: i32) {
        for (i, ch) in s.chars().enumerate() {
            let rows = super::font::glyph(ch);
            for (gy, row) in rows.iter().enumerate() {
                for gx in 0..5 {
                    if row & (0x10 >> gx) != 0 {
                        for sy in 0..scale {
                            for sx in 0..scale {
                                self.put(
                                    x + (i as i32 * 6 + gx) * scale + sx,
                                    y + gy as i32 * scale + sy,
                                    c,
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    /// Text turned 90° anticlockwise (reading upwards), its baseline start at (x, y).
    fn text_up(&mut self, x: i32, y: i32, s: &str, c: [u8; 3]) {
        for (i, ch) in s.chars().enumerate() {
            let rows = super::font::glyph(ch);
            for (gy, row) in rows.iter().enumerate() {
                for gx in 0..5 {
                    if row & (0x10 >> gx) != 0 {
                        self.put(x + gy as i32, y - (i as i32 * 6 + gx), c);
                    }
                }
            }
        }
    }
}

fn text_width(s: &str, scale: i32) -> i32 {
    s.chars().count() as i32 * 6 * scale
}

/// A log axis over [lo, hi] (log10 values) and its tick values.
struct Axis {
    lo: f64,
    hi: f64,
}

impl Axis {
    /// `right` adds room after the largest value (for point labels).
    fn new(min: f64, max: f64, right: f64) -> Axis {
        let (mut lo, mut hi) = (min.log10(), max.log10());
        let pad = ((hi - lo) * 0.06).max(0.08);
        lo -= pad;
        hi += pad + right * (hi - lo);
        if hi - lo < 0.8 {
            let mid = 0.5 * (lo + hi);
            lo = mid - 0.4;
            hi = mid + 0.4;
        }
        Axis { lo, hi }
    }

    fn frac(&self, v: f64) -> f64 {
        (v.log10() - self.lo) / (self.hi - self.lo)
    }

    /// Labelled ticks (every m × 10^k over short ranges, 1, 2, 5 × 10^k over medium ones,
    /// only 10^k over wide ones) and minor ticks.
    fn ticks(&self) -> (Vec<f64>, Vec<f64>) {
        let span = self.hi - self.lo;
        let (mut major, mut minor) = (Vec::new(), Vec::new());
        for k in (self.lo.floor() as i32)..=(self.hi.ceil() as i32) {
            for m in 1..10 {
                let v = m as f64 * 10f64.powi(k);
                let l = v.log10();
                if l < self.lo || l > self.hi {
                    continue;
                }
                if m == 1 || (span <= 2.5 && (m == 2 || m == 5)) || span < 1.2 {
                    major.push(v);
                } else {
                    minor.push(v);
                }
            }
        }
        (major, minor)
    }
}

fn tick_label(v: f64) -> String {
    if v >= 1.0 {
        format!("{v:.0}")
    } else if v >= 1e-3 {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').to_string()
    } else {
        let e = v.log10().floor() as i32;
        let m = v / 10f64.powi(e);
        if (m - 1.0).abs() < 1e-9 {
            format!("1e{e}")
        } else {
            format!("{m:.0}e{e}")
        }
    }
}

pub fn draw(path: &Path, title: &str, series: &[Series]) -> image::ImageResult<()> {
    let mut c = Canvas(RgbImage::from_pixel(W, H, Rgb([255, 255, 255])));
    let pts = || series.iter().flat_map(|s| s.points.iter());
    let ys = |p: &Point| p.y.max(FLOOR);
    let xa = Axis::new(
        pts().map(|p| p.x).fold(f64::INFINITY, f64::min),
        pts().map(|p| p.x).fold(0.0, f64::max),
        0.08,
    );
    let ya = Axis::new(
        pts().map(ys).fold(f64::INFINITY, f64::min),
        pts().map(ys).fold(0.0, f64::max),
        0.0,
    );
    let px = |x: f64| LEFT + (xa.frac(x) * (RIGHT - LEFT) as f64).round() as i32;
    let py = |y: f64| BOTTOM - (ya.frac(y.max(FLOOR)) * (BOTTOM - TOP) as f64).round() as i32;
    let (grey, light, dark) = ([150, 150, 150], [225, 225, 225], [40, 40, 40]);

    // Grid and ticks.
    let (xmaj, xmin) = xa.ticks();
    let (ymaj, ymin) = ya.ticks();
    for &v in &xmaj {
        let x = px(v);
        c.line((x, TOP), (x, BOTTOM), light, false);
        c.line((x, BOTTOM), (x, BOTTOM + 5), dark, false);
        let l = tick_label(v);
        c.text(x - text_width(&l, 1) / 2, BOTTOM + 8, &l, dark, 1);
    }
    for &v in &xmin {
        let x = px(v);
        c.line((x, BOTTOM), (x, BOTTOM + 2), grey, false);
    }
    for &v in &ymaj {
        let y = py(v);
        c.line((LEFT, y), (RIGHT, y), light, false);
        c.line((LEFT - 5, y), (LEFT, y), dark, false);
        let l = tick_label(v);
        c.text(LEFT - 8 - text_width(&l, 1), y - 3, &l, dark, 1);
    }
    for &v in &ymin {
        let y = py(v);
        c.line((LEFT - 2, y), (LEFT, y), grey, false);
    }
    // Frame.
    c.line((LEFT, TOP), (RIGHT, TOP), dark, false);
    c.line((LEFT, BOTTOM), (RIGHT, BOTTOM), dark, false);
    c.line((LEFT, TOP), (LEFT, BOTTOM), dark, false);
    c.line((RIGHT, TOP), (RIGHT, BOTTOM), dark, false);

    // Titles.
    c.text(LEFT, 9, title, dark, 1);
    let xl = "render time (s), log scale";
    c.text(
        (LEFT + RIGHT) / 2 - text_width(xl, 1) / 2,
        BOTTOM + 22,
        xl,
        dark,
        1,
    );
    c.text_up(6, BOTTOM - 40, "RMS error (grey levels), log scale", dark);

    // Series: all points joined in sweep order (dashed), the Pareto front solid.
    for s in series {
        let xy: Vec<(i32, i32)> = s.points.iter().map(|p| (px(p.x), py(p.y))).collect();
        if s.sweep {
            for w in xy.windows(2) {
                c.line(w[0], w[1], s.colour, true);
            }
        }
        let mut front: Vec<&Point> = s.points.iter().filter(|p| p.pareto).collect();
        front.sort_by(|a, b| a.x.total_cmp(&b.x));
        for w in front.windows(2) {
            c.thick((px(w[0].x), py(w[0].y)), (px(w[1].x), py(w[1].y)), s.colour);
        }
    }
    for s in series {
        for p in &s.points {
            let at = (px(p.x), py(p.y));
            if p.pareto {
                c.disc(at, 3, s.colour, Some([0, 0, 0]));
            } else {
                c.disc(at, 3, s.colour, None);
                c.disc(at, 1, [255, 255, 255], None);
            }
            if s.sweep || p.pareto {
                c.text(at.0 + 5, at.1 - 9, &p.label, s.colour, 1);
            }
        }
    }

    // Legend, below the axis label: entries left to right, wrapping.
    let (mut x, mut y) = (LEFT, BOTTOM + 40);
    let entries = series
        .iter()
        .map(|s| (s.name.as_str(), Some(s.colour)))
        .chain([("filled dot: Pareto-optimal", None)]);
    for (name, colour) in entries {
        let w = 24 + text_width(name, 1) + 18;
        if x + w > RIGHT {
            x = LEFT;
            y += 14;
        }
        match colour {
            Some(k) => {
                c.thick((x, y + 3), (x + 16, y + 3), k);
                c.disc((x + 8, y + 3), 3, k, Some([0, 0, 0]));
            }
            None => c.disc((x + 8, y + 3), 3, [120, 120, 120], Some([0, 0, 0])),
        }
        c.text(x + 24, y, name, dark, 1);
        x += w;
    }
    c.0.save(path)
}
