//! The per-image entry map: for each pixel, a lower bound on where a primary ray through it
//! meets a block of one object that may hold opacity, by projecting boxes (the grid's shell,
//! or the passing boxes) through a [`Pinhole`] camera. Owns the refusals that depend on the
//! whole image, the runs of boxes and the filing of their marks by bins; the arithmetic of a
//! box is `project`'s, the rectangles' rasterisation `rect`'s, the boxes `grid`'s and
//! `passing`'s.

use super::grid::{Boxes, SkipGrid};
use super::project::Projection;
use super::rect::lower_rect;
use glam::{DMat4, DVec3};
use rayon::prelude::*;

/// A pinhole camera as the image's primary rays see it: the ray through image position
/// (x, y) (pixels from the top-left corner of a `width × height` image) leaves `eye` along
/// `forward + sx·right + sy·up`, with sx = 2x/width − 1 and sy = 1 − 2y/height.
pub(crate) struct Pinhole {
    pub eye: DVec3,
    pub forward: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    pub width: u32,
    pub height: u32,
}

impl Pinhole {
    /// The unit direction of the ray through image position (x, y).
    #[inline]
    pub(crate) fn ray(&self, x: f64, y: f64) -> DVec3 {
        let sx = x / self.width as f64 * 2.0 - 1.0;
        let sy = 1.0 - y / self.height as f64 * 2.0;
        (self.forward + sx * self.right + sy * self.up).normalize()
    }
}

/// Per pixel of an image, a lower bound on the parameter t (distance from the eye along a unit
/// direction) at which a primary ray through any point of the pixel meets a block of one
/// object that may hold opacity; +∞ where no such ray meets one. A ray need not walk the
/// blocks before its bound: every sample there lies in an empty block, so starting later
/// never changes a pixel, and a pixel whose bound is +∞ shows the background.
///
/// Built per image by projecting the grid's shell (see [`SkipGrid`]): each shell block, grown
/// by an eighth of a block on every side (far more than any rounding of the walk or the
/// projection), is mapped to the image through its eight corners; the pixels whose square,
/// grown by a hundredth of a pixel, meets the corners' bounding rectangle take the block's
/// smallest depth along the view direction (a unit ray's t is at least the depth of its
/// point) as a bound.
/// The projection of a box wholly in front of the eye is the convex hull of its corners'
/// projections, so every ray that meets the block passes through a marked pixel.
///
/// Why the shell suffices: a ray's samples lie in the object's box, inside the grid. The
/// first block along the ray that may hold opacity is either where the ray starts (at the
/// eye, or where it enters the box, in an edge block: shell) or entered from a neighbour the
/// ray crossed before, which is then empty (shell again). An eye inside such a block is
/// enclosed by shell blocks, some of whose corners are then not in front of it: no map.
///
/// The map is made in two parts, so that the image's bounds are never held whole:
/// [`EntryMarks`], the projection of the boxes (once per image), and its
/// [`EntryMarks::tile`], the bounds of one tile of pixels, made by the tile's task (in
/// parallel, and with a team of processes only on the rank that renders the tile).
pub(crate) struct EntryMap {
    /// Pixels per row of the map.
    pub(super) width: usize,
    /// The image row of the map's first row.
    pub(super) first_row: usize,
    /// The image column of the map's first column.
    pub(super) first_col: usize,
    pub(super) bound: Vec<f64>,
}

/// An image's projected boxes, by bins of [`ENTRY_BIN`] × [`ENTRY_BIN`] pixels: what the
/// [`EntryMap`] of any rectangle of its pixels is filled from. Made in runs of consecutive
/// boxes, each projected and filed by bins on its own, the runs in parallel (no part of the
/// map waits for the whole of another); a bin's marks are those its runs file there.
pub(crate) struct EntryMarks {
    width: usize,
    height: usize,
    /// Bins per row of bins.
    bins_x: usize,
    runs: Vec<Run>,
}

/// The marks of a run of boxes, filed by the bins they meet.
struct Run {
    marks: Vec<Mark>,
    /// Per bin (row-major), where its marks start in `in_bin`; one more, the total, last.
    start: Vec<u32>,
    /// The numbers (in `marks`) of the marks that meet each bin, bin after bin (four bytes
    /// an entry: a mark meets about one to four bins).
    in_bin: Vec<u32>,
}

/// Side in pixels of the square bins an [`EntryMarks`] files its marks by: the side of the
/// packet march's tiles, which read one bin's marks where their rows start at a multiple of
/// it (two bins' where they do not: with super-sampling, a strip's first pass starts a row
/// after the last strip's); the scalar march's tiles, half as wide, read their bin's and pass
/// over the marks outside them.
pub(super) const ENTRY_BIN: usize = 32;

/// The widest and tallest image an [`EntryMarks`] is made for, so that a [`Mark`]'s pixel
/// columns and rows fit 16 bits: above every image side the API accepts (its
/// `MAX_IMAGE_SIDE` asserts it); a larger one would get no map, its rays walking from the
/// object's box.
pub(crate) const MAX_MAP_SIDE: usize = 1 << 16;

/// A box's pixel rectangle (inclusive) and its smallest depth, in twelve bytes (an image of a
/// large dataset has a mark for each of hundreds of thousands of boxes): columns and rows in
/// 16 bits (images up to [`MAX_MAP_SIDE`]), the depth as the largest f32 at most it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Mark {
    x: [u16; 2],
    y: [u16; 2],
    near: f32,
}

impl Mark {
    /// The mark of columns `x` and rows `y` (inclusive, each below [`MAX_MAP_SIDE`]) and
    /// depth at least `near` (rounded down to an f32: a lower bound stays one).
    #[inline(always)]
    pub(super) fn new(x: (usize, usize), y: (usize, usize), near: f64) -> Mark {
        debug_assert!(x.1 < MAX_MAP_SIDE && y.1 < MAX_MAP_SIDE);
        let n = near as f32;
        Mark {
            x: [x.0 as u16, x.1 as u16],
            y: [y.0 as u16, y.1 as u16],
            near: if f64::from(n) > near {
                n.next_down()
            } else {
                n
            },
        }
    }

    /// Its first and last column.
    #[inline(always)]
    pub(super) fn x(&self) -> (usize, usize) {
        (self.x[0] as usize, self.x[1] as usize)
    }

    /// Its first and last row.
    #[inline(always)]
    pub(super) fn y(&self) -> (usize, usize) {
        (self.y[0] as usize, self.y[1] as usize)
    }

    /// Its depth: a lower bound on the parameter of any ray through its pixels that meets
    /// its box.
    #[inline(always)]
    pub(super) fn near(&self) -> f64 {
        f64::from(self.near)
    }
}

/// Calls `f` with the index of each bin (of [`ENTRY_BIN`]² pixels, `bins_x` to a row of
/// bins) that mark `m` meets, row by row.
#[inline(always)]
fn for_each_bin(m: &Mark, bins_x: usize, mut f: impl FnMut(usize)) {
    let ((x0, x1), (y0, y1)) = (m.x(), m.y());
    let (x0, x1) = (x0 / ENTRY_BIN, x1 / ENTRY_BIN);
    for by in y0 / ENTRY_BIN..=y1 / ENTRY_BIN {
        for b in by * bins_x + x0..=by * bins_x + x1 {
            f(b);
        }
    }
}

/// The fewest boxes a run of the entry map takes ([`EntryMarks`]): a task of about a tenth of a
/// millisecond.
const RUN_BOXES: usize = 1024;

/// The most runs of an entry map: each holds four bytes a bin for its starts (1/256 of a byte
/// a pixel), and as much again while it files its marks.
const MAX_RUNS: usize = 64;

/// Rectangle pixels an entry map may mark, per image pixel, before it gives up (a camera
/// close to a finely divided volume): a marked pixel costs a comparison, a ray thousands of
/// instructions.
const ENTRY_BUDGET: usize = 64;

/// Boxes an entry map may project, per image pixel: projecting a box costs about what the map
/// saves a ray, so with more boxes than pixels (a small image of a large volume) the rays
/// walk from the object's box instead.
const ENTRY_BOXES_PER_PIXEL: usize = 1;

impl EntryMap {
    /// The map of every pixel of the image ([`EntryMarks::build`], then [`EntryMarks::all_rows`]).
    #[cfg(test)]
    pub(crate) fn build(grid: &SkipGrid, to_world: DMat4, camera: &Pinhole) -> Option<EntryMap> {
        EntryMarks::build(grid, to_world, camera)?.all_rows()
    }

    /// The map of every pixel of the image ([`EntryMarks::of_boxes`], then [`EntryMarks::all_rows`]).
    #[cfg(test)]
    pub(crate) fn of_boxes(boxes: &Boxes, to_world: DMat4, camera: &Pinhole) -> Option<EntryMap> {
        EntryMarks::of_boxes(boxes, to_world, camera)?.all_rows()
    }

    /// The map of every pixel of the image ([`EntryMarks::build_within`], then [`EntryMarks::all_rows`]).
    #[cfg(test)]
    pub(super) fn build_within(
        boxes: &Boxes,
        to_world: DMat4,
        camera: &Pinhole,
        budget: usize,
    ) -> Option<EntryMap> {
        EntryMarks::build_within(boxes, to_world, camera, budget)?.all_rows()
    }

    /// The bound of pixel (x, y) (a pixel the map holds).
    #[inline]
    pub(crate) fn bound(&self, x: u32, y: u32) -> f64 {
        self.bound[(y as usize - self.first_row) * self.width + (x as usize - self.first_col)]
    }

    /// The map, in the image `n` times finer along each axis, of the `n` rows of fine pixels
    /// that pixels `xs` of row `y` (pixels this map holds) cover: each fine pixel takes the
    /// bound of the pixel it lies in, a bound for a ray through any point of that pixel. What
    /// super-sampling's n × n rays over a pixel start from in the packet march.
    #[cfg(target_arch = "x86_64")]
    pub(crate) fn finer(&self, xs: std::ops::Range<u32>, y: u32, n: u32) -> EntryMap {
        let n = n as usize;
        let (width, first_col) = (xs.len() * n, xs.start as usize * n);
        let row: Vec<f64> = xs
            .flat_map(|x| std::iter::repeat_n(self.bound(x, y), n))
            .collect();
        let mut bound = Vec::with_capacity(width * n);
        for _ in 0..n {
            bound.extend_from_slice(&row);
        }
        EntryMap {
            width,
            first_row: y as usize * n,
            first_col,
            bound,
        }
    }
}

impl EntryMarks {
    /// The projection of `grid`'s object (whose object-to-world transform is `to_world`) seen by
    /// `camera`; `None` when it cannot help or cannot be proved: a shell corner not clearly
    /// in front of the eye (an eye in or next to a block that may hold opacity, a volume
    /// around or behind the eye), a singular camera basis, or more marking than
    /// [`ENTRY_BUDGET`] allows.
    pub(crate) fn build(grid: &SkipGrid, to_world: DMat4, camera: &Pinhole) -> Option<EntryMarks> {
        Self::of_boxes(&grid.shell, to_world, camera)
    }

    /// The map of `boxes`, each grown by an eighth of their unit on every side, that hold the
    /// first sample with opacity above 0 of any ray (the shell's blocks, or
    /// [`SkipGrid::passing_boxes`]); `None` as for [`EntryMarks::build`], and for more boxes
    /// than [`ENTRY_BOXES_PER_PIXEL`] allows.
    pub(crate) fn of_boxes(boxes: &Boxes, to_world: DMat4, camera: &Pinhole) -> Option<EntryMarks> {
        let pixels = (camera.width as usize).saturating_mul(camera.height as usize);
        if boxes.len() > EntryMarks::most_boxes(camera) {
            return None;
        }
        let budget = pixels.saturating_mul(ENTRY_BUDGET);
        Self::build_within(boxes, to_world, camera, budget)
    }

    /// The most boxes [`EntryMarks::of_boxes`] projects for `camera`'s image
    /// ([`ENTRY_BOXES_PER_PIXEL`] a pixel).
    pub(crate) fn most_boxes(camera: &Pinhole) -> usize {
        let pixels = (camera.width as usize).saturating_mul(camera.height as usize);
        pixels.saturating_mul(ENTRY_BOXES_PER_PIXEL)
    }

    /// [`EntryMarks::of_boxes`], giving up past `budget` marked rectangle pixels.
    pub(super) fn build_within(
        boxes: &Boxes,
        to_world: DMat4,
        camera: &Pinhole,
        budget: usize,
    ) -> Option<EntryMarks> {
        let (w, h) = (camera.width as usize, camera.height as usize);
        if w == 0 || h == 0 || w > MAX_MAP_SIDE || h > MAX_MAP_SIDE || boxes.len() == 0 {
            return None;
        }
        let projection = Projection::new(to_world, camera, boxes.unit * 0.125)?;
        let bins_x = w.div_ceil(ENTRY_BIN);
        let bins = bins_x.checked_mul(h.div_ceil(ENTRY_BIN))?;
        // Runs of at least `RUN_BOXES` boxes, at most `MAX_RUNS` of them.
        let per_run = RUN_BOXES.max(boxes.len().div_ceil(MAX_RUNS));
        let filed = Filing {
            bins_x,
            bins,
            budget,
            area: std::sync::atomic::AtomicUsize::new(0),
        };
        let runs = (0..boxes.len().div_ceil(per_run))
            .into_par_iter()
            .map(|r| {
                let range = r * per_run..((r + 1) * per_run).min(boxes.len());
                filed.run(&projection, boxes, range)
            })
            .collect::<Option<Vec<Run>>>()?;
        Some(EntryMarks {
            width: w,
            height: h,
            bins_x,
            runs,
        })
    }

    /// The map of the image's pixels `xs` × `ys` (clipped to the image): each bin the
    /// rectangle meets lowered by the marks filed in it, clipped to the bin, so that a pixel
    /// meets each mark once. The same numbers for any rectangle (a minimum is exact). A tile's
    /// map: it is allocated as it is, whatever its size.
    pub(crate) fn tile(&self, xs: std::ops::Range<usize>, ys: std::ops::Range<usize>) -> EntryMap {
        let (x0, x1) = (xs.start.min(self.width), xs.end.min(self.width));
        let (y0, y1) = (ys.start.min(self.height), ys.end.min(self.height));
        let tw = x1.saturating_sub(x0);
        let mut bound = vec![f64::INFINITY; tw * y1.saturating_sub(y0)];
        if x0 < x1 && y0 < y1 {
            for by in y0 / ENTRY_BIN..=(y1 - 1) / ENTRY_BIN {
                // The bin's rows within the rectangle, and likewise its columns below.
                let (r0, r1) = ((by * ENTRY_BIN).max(y0), ((by + 1) * ENTRY_BIN).min(y1) - 1);
                for bx in x0 / ENTRY_BIN..=(x1 - 1) / ENTRY_BIN {
                    let (c0, c1) = ((bx * ENTRY_BIN).max(x0), ((bx + 1) * ENTRY_BIN).min(x1) - 1);
                    let b = by * self.bins_x + bx;
                    for run in &self.runs {
                        let filed = run.start[b] as usize..run.start[b + 1] as usize;
                        for &i in &run.in_bin[filed] {
                            let m = &run.marks[i as usize];
                            let ((x_0, x_1), (y_0, y_1)) = (m.x(), m.y());
                            let (mx0, mx1) = (x_0.max(c0), x_1.min(c1));
                            let (my0, my1) = (y_0.max(r0), y_1.min(r1));
                            if mx0 <= mx1 && my0 <= my1 {
                                lower_rect(
                                    &mut bound,
                                    tw,
                                    mx0 - x0..=mx1 - x0,
                                    my0 - y0..=my1 - y0,
                                    m.near(),
                                );
                            }
                        }
                    }
                }
            }
        }
        EntryMap {
            width: tw,
            first_row: y0,
            first_col: x0,
            bound,
        }
    }

    /// The map of every pixel.
    #[cfg(test)]
    pub(crate) fn all_rows(&self) -> Option<EntryMap> {
        Some(self.tile(0..self.width, 0..self.height))
    }

    /// How many runs the marks were made in.
    #[cfg(test)]
    pub(super) fn runs(&self) -> usize {
        self.runs.len()
    }

    /// The pixels all marks cover (counted with multiplicity), and the most one run's cover.
    #[cfg(test)]
    pub(super) fn areas(&self) -> (usize, usize) {
        let areas = self.runs.iter().map(|r| area(&r.marks));
        (areas.clone().sum(), areas.max().unwrap_or(0))
    }
}

/// What filing a run's marks needs: the image's bins, the budget of marked pixels and what
/// the runs filed so far have marked.
struct Filing {
    bins_x: usize,
    bins: usize,
    budget: usize,
    area: std::sync::atomic::AtomicUsize,
}

impl Filing {
    /// The run of boxes `range`, projected and filed by bins; `None` to give up (a box that
    /// cannot be projected, the runs' marked pixels together past the budget, memory that
    /// cannot be had: the rays then walk from the object's box).
    fn run(
        &self,
        projection: &Projection,
        boxes: &Boxes,
        range: std::ops::Range<usize>,
    ) -> Option<Run> {
        let mut marks = Vec::new();
        marks.try_reserve_exact(range.len()).ok()?;
        if !projection.marks(boxes, range, &mut marks) {
            return None;
        }
        // The runs' areas together within the budget (checked before filing, whose work grows
        // with the area, so that all runs together file no more than the budget allows).
        let area = area(&marks);
        let relaxed = std::sync::atomic::Ordering::Relaxed;
        let add = |sum: usize| Some(sum.saturating_add(area));
        let before = self
            .area
            .fetch_update(relaxed, relaxed, add)
            .unwrap_or(usize::MAX);
        if before.saturating_add(area) > self.budget {
            return None;
        }
        // Counted, then placed.
        let mut start = crate::num::try_vec(self.bins + 1, 0u32, "").ok()?;
        for m in &marks {
            for_each_bin(m, self.bins_x, |b| start[b + 1] += 1);
        }
        let mut total = 0u32;
        for s in &mut start[1..] {
            total = total.checked_add(*s)?;
            *s = total;
        }
        let mut next = crate::num::try_vec(self.bins, 0u32, "").ok()?;
        next.copy_from_slice(&start[..self.bins]);
        let mut in_bin = crate::num::try_vec(total as usize, 0u32, "").ok()?;
        for (i, m) in marks.iter().enumerate() {
            for_each_bin(m, self.bins_x, |b| {
                in_bin[next[b] as usize] = i as u32;
                next[b] += 1;
            });
        }
        Some(Run {
            marks,
            start,
            in_bin,
        })
    }
}

/// The pixels `marks` cover, counted with multiplicity (saturating).
fn area(marks: &[Mark]) -> usize {
    marks.iter().fold(0usize, |sum, m| {
        let ((x0, x1), (y0, y1)) = (m.x(), m.y());
        sum.saturating_add((x1 - x0 + 1) * (y1 - y0 + 1))
    })
}
