//! Draws a word into a grey PNG for the "text" example (the paper's Figure 3(b) idea: a word
//! converted to a dataset and rendered as a solid object).
//!
//! ```text
//! cargo run --release --example word_png -- out/word.png [word]
//! target/release/vlconvert image out/word.png out/word.vlb
//! ```
//!
//! The letters come from a tiny built-in stroke font: each glyph of the table below is a few
//! line segments, rings and dots on a 5 × 7 grid (baseline y = 0, x-height 4, ascender 7),
//! stroked with round ends. Pixels are white (255) inside the strokes and black outside. Each
//! pixel is the box-filtered mean of 4 × 4 sub-pixel samples, so edges are anti-aliased; then a
//! Gaussian of [`SOFT`] pixels widens the transition a little. The converted dataset thus rises
//! smoothly across each edge, over about three pixels: with only the one-pixel anti-aliased
//! ramp, the iso-surface of the trilinear field is faceted pixel by pixel, and the extruded
//! sides of the letters show those facets as stripes. Only the letters in the table are known
//! (`vlib` by default).

#[path = "common/say.rs"]
mod say;
use std::error::Error;

/// One stroke of a glyph, in glyph units.
#[derive(Clone, Copy)]
enum Stroke {
    /// A segment from one point to another.
    Line([f32; 2], [f32; 2]),
    /// A circle: centre and radius.
    Ring([f32; 2], f32),
    /// A round dot (a stroke of zero length).
    Dot([f32; 2]),
}

use Stroke::{Dot, Line, Ring};

/// The glyph table: the strokes and the advance width of each letter (glyph units).
fn glyph(c: char) -> Option<(&'static [Stroke], f32)> {
    const V: &[Stroke] = &[Line([0.0, 4.0], [2.0, 0.0]), Line([2.0, 0.0], [4.0, 4.0])];
    const L: &[Stroke] = &[Line([0.0, 0.0], [0.0, 7.0])];
    const I: &[Stroke] = &[Line([0.0, 0.0], [0.0, 4.0]), Dot([0.0, 5.8])];
    const B: &[Stroke] = &[Line([0.0, 0.0], [0.0, 7.0]), Ring([2.0, 2.0], 2.0)];
    const O: &[Stroke] = &[Ring([2.0, 2.0], 2.0)];
    const D: &[Stroke] = &[Line([4.0, 0.0], [4.0, 7.0]), Ring([2.0, 2.0], 2.0)];
    const X: &[Stroke] = &[Line([0.0, 0.0], [4.0, 4.0]), Line([0.0, 4.0], [4.0, 0.0])];
    Some(match c {
        'v' => (V, 4.0),
        'l' => (L, 0.0),
        'i' => (I, 0.0),
        'b' => (B, 4.0),
        'o' => (O, 4.0),
        'd' => (D, 4.0),
        'x' => (X, 4.0),
        _ => return None,
    })
}

/// Pixels per glyph unit.
const UNIT: f32 = 22.0;
/// Stroke width, in glyph units.
const STROKE: f32 = 1.25;
/// Space between letters (between stroke edges), in glyph units.
const GAP: f32 = 1.3;
/// Margin around the word, in glyph units.
const MARGIN: f32 = 1.0;
/// Sub-pixel samples per axis.
const SS: u32 = 4;
/// Standard deviation of the final blur, pixels.
const SOFT: f32 = 1.0;

/// Distance from `p` to a stroke's centre line.
fn distance(s: Stroke, p: [f32; 2]) -> f32 {
    let len = |x: f32, y: f32| (x * x + y * y).sqrt();
    match s {
        Dot(c) => len(p[0] - c[0], p[1] - c[1]),
        Ring(c, r) => (len(p[0] - c[0], p[1] - c[1]) - r).abs(),
        Line(a, b) => {
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let t =
                (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
            len(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)
        }
    }
}

/// Separable Gaussian blur of [`SOFT`] pixels; outside the image is 0.
fn blur(img: &[f32], w: usize, h: usize) -> Vec<f32> {
    let rad = (3.0 * SOFT).ceil() as isize;
    let kernel: Vec<f32> = (-rad..=rad)
        .map(|d| (-(d * d) as f32 / (2.0 * SOFT * SOFT)).exp())
        .collect();
    let sum: f32 = kernel.iter().sum();
    let pass = |src: &[f32], stride: usize, len: usize, at: &dyn Fn(usize) -> usize| {
        let mut out = vec![0.0f32; src.len()];
        for (i, o) in out.iter_mut().enumerate() {
            let pos = at(i) as isize;
            *o = kernel
                .iter()
                .enumerate()
                .filter_map(|(t, k)| {
                    let q = pos + t as isize - rad;
                    (0..len as isize)
                        .contains(&q)
                        .then(|| k * src[(i as isize + (q - pos) * stride as isize) as usize])
                })
                .sum::<f32>()
                / sum;
        }
        out
    };
    let rows = pass(img, 1, w, &|i| i % w);
    pass(&rows, w, h, &|i| i / w)
}

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = args.first().map(String::as_str).unwrap_or("word.png");
    let word = args.get(1).map(String::as_str).unwrap_or("vlib");
    // Lay the word out: each glyph's strokes, offset by its pen position.
    let mut strokes: Vec<Stroke> = Vec::new();
    let mut pen = 0.0f32;
    for c in word.chars() {
        let (g, advance) =
            glyph(c).ok_or_else(|| format!("no glyph for {c:?} (known: vlibodx)"))?;
        let shift = |q: [f32; 2]| [q[0] + pen, q[1]];
        strokes.extend(g.iter().map(|&s| match s {
            Line(a, b) => Line(shift(a), shift(b)),
            Ring(c, r) => Ring(shift(c), r),
            Dot(c) => Dot(shift(c)),
        }));
        pen += advance + STROKE + GAP;
    }
    if strokes.is_empty() {
        return Err("empty word".into());
    }
    let pad = MARGIN + STROKE / 2.0;
    let (w_units, h_units) = (pen - STROKE - GAP + 2.0 * pad, 7.0 + 2.0 * pad);
    let (w, h) = (
        (w_units * UNIT).ceil() as u32,
        (h_units * UNIT).ceil() as u32,
    );
    let mut cover = vec![0.0f32; (w * h) as usize];
    for (i, c) in cover.iter_mut().enumerate() {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let mut hits = 0u32;
        for sy in 0..SS {
            for sx in 0..SS {
                // Glyph units; image row 0 at the top is the top of the letters.
                let gx = (x as f32 + (sx as f32 + 0.5) / SS as f32) / UNIT - pad;
                let gy = 7.0 + pad - (y as f32 + (sy as f32 + 0.5) / SS as f32) / UNIT;
                if strokes
                    .iter()
                    .any(|&s| distance(s, [gx, gy]) <= STROKE / 2.0)
                {
                    hits += 1;
                }
            }
        }
        *c = hits as f32 / (SS * SS) as f32;
    }
    let soft = blur(&cover, w as usize, h as usize);
    let px = soft
        .iter()
        .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect();
    let img = image::GrayImage::from_raw(w, h, px).ok_or("image size")?;
    img.save(out)?;
    say::say(format_args!("wrote {out} ({w}x{h}, \"{word}\")"))?;
    Ok(())
}
