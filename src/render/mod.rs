//! The discrete ray tracer: DVR, DSR and MIP, shadows, reflection and refraction.
//!
//! The renderer owns turning a finished [`SceneDesc`] into pixels: it compiles the scene once
//! into an immutable [`Compiled`] scene (`compile`: each object's world-to-object matrix,
//! boundary box, step and opacity exponent, normal neighbourhood, the prefix of its program
//! that determines each field, its empty-space grid, and the scene's [`Plan`] of the effects it
//! can show, see `docs/dev/render-plan.md`), then traces rays over image tiles in parallel
//! (rayon, `tiles`); every pixel is computed independently in a fixed order, so the bytes of
//! an image do not depend on the number of threads. [`render_image`] is the entry point and
//! returns an [`Image`]; each pixel carries its colour and the transmittance of its primary
//! ray, and a render against a transparent [`Backdrop`] shows nothing where rays leave the
//! scene (RGBA images; their quantisation and layouts are `image`'s). It does not write files
//! (the output layer above it does), nor does it build the scene description (`model`) or the
//! empty-space structures (`accel`); it uses them.
//! It owns the evaluation of programs during a render: the general interpreter is `model`'s
//! (`program::run`), the lean kernel for programs of constants, datasets and transfer functions
//! is the renderer's own (`kernel`).
//!
//! Along a ray, each object's box is clipped exactly; its interval is cut into segments of the
//! step size, the last one shorter (`cursor`), and each segment is represented by the sample
//! at its midpoint with opacity `α = 1 − (1 − o)^(ℓ / reference)` for its true length ℓ. For
//! constant media the product of the transmittances is therefore exactly the Beer–Lambert value
//! `(1 − o)^(L/ref)` for any step. A scanned volume whose opacity and colour are its value
//! through transfer functions is instead composited by slabs between samples with
//! pre-integrated transfer functions where `Optimise::preintegrate` is on (`preint`,
//! `integrate::preint`). Samples of overlapping objects are merged in order of depth,
//! together with the surface hits of DSR objects and the layers of MIP objects (`integrate`).
//! Compositing is front to back with early termination once the transmittance falls below
//! `Optimise::termination` (default [`crate::T_MIN`]). Shadow rays use the same segments; mirror and
//! refracted rays start at surface hits. Lighting, normals and shadow transmittance are
//! `shade`'s (`lanes`: the same lighting for several samples at once).
//!
//! Where it applies, primary rays of a scanned volume are traced in SIMD packets (`simd`,
//! x86-64; its arithmetic against the scalar march's: `docs/dev/simd.md`); everything else
//! takes the scalar path here.

// What the renderer's modules share of the crate: each of them (the packet march too) takes
// the render module's names with `use super::*` (or `use crate::render::*`).
use crate::accel::{BoxTree, EntryMap, EntryMarks, Pinhole, SkipGrid, Walk};
use crate::control::Progress;
use crate::data::{CellGradients, Cells8, Dataset, Filter, GradientFilter};
use crate::error::{Error, ErrorCode, Result};
use crate::model::program::{prefix_for, run, Instr, NormalFn, Sample, SampleEnv, SampleRole};
use crate::model::scene::{Light, ObjectDesc, SceneDesc, Settings};
use crate::render::kernel::Lean;
use crate::types::{Attenuation, Feature, Fields, RenderType, FIELD_COUNT, MAX_SPECULAR};
use glam::{DMat4, DVec3};
use rayon::prelude::*;
use std::sync::Arc;

mod compile;
mod cursor;
mod image;
mod inert;
mod integrate;
mod kernel;
mod lanes;
mod preint;
mod recycle;
mod shade;
mod tiles;

pub(crate) use compile::Caches;
pub use compile::{Compiled, Plan};
pub(crate) use image::render_into;
pub use image::{Backdrop, Image, PixelFormat};
pub(crate) use shade::{reflect, refract};

// The renderer's own items, reachable as `super::NAME` from its submodules (the packet march
// and the tests among them).
use compile::*;
use cursor::*;
use integrate::*;
use lanes::*;
use recycle::Recycled;
use shade::*;
use tiles::*;

/// Super-sampling refines a pixel when a colour channel differs from a 4-neighbour's by more
/// than this.
pub const SUPER_SAMPLE_CONTRAST: f32 = 4.0 / 255.0;

#[cfg(target_arch = "x86_64")]
mod simd;
#[cfg(all(vlib_counters, target_arch = "x86_64"))]
pub use simd::step::counters::sample_counts;

/// A pixel as the renderer computes it: linear RGB in [0, 1], then the transmittance `T` of
/// its primary ray in [0, 1] (the weight of the backdrop in the colour).
pub(crate) type Pixel = [f32; 4];

/// Pixels a strip of an image holds at most (more where one row of tiles is more): an image
/// is rendered a strip of rows at a time, so the memory a render needs beyond its output is
/// bounded, whatever the image's size (`docs/dev/robustness.md`).
const STRIP_PIXELS: u64 = 1 << 20;

/// Rows of a strip of a `width × height` image: whole rows of packet tiles, about
/// [`STRIP_PIXELS`] pixels.
fn strip_rows(width: u32, height: u32) -> u32 {
    let rows = (STRIP_PIXELS / width.max(1) as u64).max(1) as u32;
    rows.next_multiple_of(PACKET_TILE).min(height.max(1))
}

/// The most samples one ray may take through one object (2³², as many as a `.vlb` dataset has
/// voxels): a scene whose step is finer than this fraction of an object's world diagonal is
/// refused with `VL_BADVALUE` before it renders. The diagonal bounds every ray, a
/// grazing one too, so a thin, wide object at a fine step is measured by its width.
pub const MAX_SAMPLES_PER_RAY: f64 = (1u64 << 32) as f64;

/// The largest image side in pixels.
pub const MAX_IMAGE_SIDE: i32 = 1 << 15;
// (Every image the API accepts gets an entry map: its marks hold pixel columns and rows in 16
// bits.)
const _: () = assert!(MAX_IMAGE_SIDE as usize <= crate::accel::MAX_MAP_SIDE);
/// The largest number of pixels of one image.
pub const MAX_IMAGE_PIXELS: u64 = 1 << 28;

/// Renders the compiled scene to an image of `width × height` pixels whose view plane has the
/// given width / height `aspect`, against `backdrop` ([`render_strips`]), into memory.
pub fn render_image(
    scene: &Compiled,
    (width, height, aspect): (u32, u32, f32),
    backdrop: Backdrop,
    progress: &Progress,
) -> Result<Image> {
    let n = width as usize * height as usize;
    // (With a team, a rank that cannot hold the image fails every rank.)
    let buffers = (|| {
        Ok((
            crate::num::try_with_capacity(n, "the image")?,
            crate::num::try_with_capacity(n, "the image's transmittance")?,
        ))
    })();
    let (mut pixels, mut transmittance) = crate::team::agree(progress.team(), buffers)?;
    render_strips(
        scene,
        (width, height, aspect),
        backdrop,
        progress,
        |_, rows| {
            // (In parallel into the room reserved above: a large image's fresh pages cost
            // more than the copy.)
            pixels.par_extend(rows.par_iter().map(|p| [p[0], p[1], p[2]]));
            transmittance.par_extend(rows.par_iter().map(|p| p[3]));
            Ok(())
        },
    )?;
    Ok(Image {
        width,
        height,
        pixels,
        transmittance,
        backdrop,
    })
}

/// Renders the compiled scene to an image of `width × height` pixels whose view plane has the
/// given width / height `aspect`, against `backdrop`, a strip of rows at a time: `sink(y,
/// rows)` takes each strip, top first (`y` its first row), and `progress` counts its pixels.
/// Adaptive super-sampling: one ray through each pixel centre, then pixels that differ from a
/// neighbour by more than [`SUPER_SAMPLE_CONTRAST`] in a colour channel (or, against a
/// transparent backdrop, in transmittance) are replaced by the mean of an n×n grid of rays
/// (colour and transmittance), traced in packets where the first pass is (`FineRays`). Every
/// pixel is computed on its own, so strips change no pixel.
///
/// Errors: the scene's work bound ([`Compiled::check_work`]), `VL_NOMEMORY`, `VL_CANCELLED`
/// (within a tile of work of the flag), the sink's, and a panic (`VL_INTERNAL`).
pub(crate) fn render_strips(
    scene: &Compiled,
    size: (u32, u32, f32),
    backdrop: Backdrop,
    progress: &Progress,
    sink: impl FnMut(u32, &[Pixel]) -> Result<()>,
) -> Result<()> {
    let step = strip_rows(size.0, size.1);
    render_in_strips(scene, size, backdrop, step, progress, sink)
}

/// [`render_strips`] in strips of `step` rows.
fn render_in_strips(
    scene: &Compiled,
    (width, height, aspect): (u32, u32, f32),
    backdrop: Backdrop,
    step: u32,
    progress: &Progress,
    mut sink: impl FnMut(u32, &[Pixel]) -> Result<()>,
) -> Result<()> {
    scene.check_work()?;
    progress.check()?;
    let team = progress.team();
    let run = || -> Result<()> {
        // What every strip needs, made on each rank (its caches may fail to allocate): with a
        // team, a failure on one rank fails every rank here.
        let prologue = crate::error::catch("rendering", || {
            let view = view(&scene.settings, width, height, aspect);
            let marks = scene.entry_marks(&view);
            let image = scene.image_rays(view.eye, backdrop);
            // What a pixel whose bound is +∞ shows, where that is known without its ray.
            let unbounded = scene.unbounded_colour(&image).map(|c| pixel(c, 1.0));
            #[cfg(target_arch = "x86_64")]
            let here = simd::Packets::new(scene);
            #[cfg(not(target_arch = "x86_64"))]
            let here: Option<()> = None;
            Ok((view, marks, image, unbounded, here))
        });
        let (view, marks, image, unbounded, here) = crate::team::agree(team, prologue)?;
        // Rays in packets of SIMD lanes, where that applies, on every rank of a team: ranks of
        // other processors take the same march and cut the image alike.
        let everywhere = crate::team::all(team, here.is_some())?;
        #[cfg(target_arch = "x86_64")]
        let packets = here.filter(|_| everywhere);
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (here, everywhere);
        #[cfg(target_arch = "x86_64")]
        let packet_side = packet_side(width, height, progress);
        let n = scene.settings.super_sample.max(1) as u32;
        // With super-sampling, the image n times finer along each axis (at most 2¹⁹ pixels a
        // side): its pixel (n·x + i, n·y + j) is centred on ray (i, j) of pixel (x, y).
        #[cfg(target_arch = "x86_64")]
        let fine = tiles::view(&scene.settings, width * n, height * n, aspect);
        // The entry map of a tile, made by the tile's task.
        let entry_of = |(tx, ty, tw, th): (u32, u32, u32, u32)| -> Option<EntryMap> {
            let (tx, ty) = (tx as usize, ty as usize);
            let m = marks.as_ref()?;
            Some(m.tile(tx..tx + tw as usize, ty..ty + th as usize))
        };
        // The first pass of rows `rows`.
        let recycled = &*scene.recycled;
        let first_pass = |rows: std::ops::Range<u32>| {
            #[cfg(target_arch = "x86_64")]
            if let Some(p) = &packets {
                if p.preintegrated() {
                    return per_tile(width, rows, packet_side, progress, recycled, |tile, out| {
                        p.tile_pre(&view, entry_of(tile).as_ref(), &image, unbounded, tile, out)
                    });
                }
                return per_tile(width, rows, packet_side, progress, recycled, |tile, out| {
                    p.tile(&view, entry_of(tile).as_ref(), &image, unbounded, tile, out)
                });
            }
            per_pixel(width, rows, progress, recycled, entry_of, |entry, x, y| {
                let bound = entry.as_ref().map_or(f64::NEG_INFINITY, |m| m.bound(x, y));
                if let (Some(c), true) = (unbounded, bound == f64::INFINITY) {
                    return c;
                }
                let dir = view.ray(x as f64 + 0.5, y as f64 + 0.5);
                let (c, t) = scene.trace(view.eye, &image, dir, bound);
                pixel(c, t)
            })
        };
        // The first pass of rows [lo, hi): a strip's rows and, with super-sampling, the row on
        // either side (the next strip keeps those it has).
        let mut first: Vec<Pixel> = Vec::new();
        let (mut lo, mut hi) = (0u32, 0u32);
        let row = width as usize;
        for y0 in (0..height).step_by(step as usize) {
            let y1 = (y0 + step).min(height);
            let (need_lo, need_hi) = if n > 1 {
                (y0.saturating_sub(1), (y1 + 1).min(height))
            } else {
                (y0, y1)
            };
            // (Here and below, an error of this rank alone is held for the next step with a
            // team, `Progress::hold`, and the rank takes no work in it.)
            // Keep the rows of the last strip's pass this one needs, then trace the rest.
            let keep = need_lo.clamp(lo, hi);
            first.drain(..(keep - lo) as usize * row);
            lo = keep;
            if lo == hi {
                lo = need_lo;
                hi = need_lo;
            }
            // The strip's pixels, and the work of its passes: the rows traced afresh, and
            // with super-sampling the strip's pixels again.
            let units = (y1 - y0) as u64 * width as u64;
            let traced = (need_hi - hi) as u64 * width as u64;
            progress.begin(units, traced + if n > 1 { units } else { 0 });
            let fresh = first_pass(hi..need_hi)?;
            if n == 1 {
                // One ray a pixel: the first pass is the strip, handed on as it is.
                if !progress.holds() {
                    progress.hold(crate::error::catch("rendering", || sink(y0, &fresh)))?;
                }
                recycled.give(fresh);
            } else {
                progress.hold(first.try_reserve(fresh.len()).map_err(|_| {
                    crate::num::no_memory("a strip of the image", Some(fresh.len() * 16))
                }))?;
                if !progress.holds() {
                    first.extend_from_slice(&fresh);
                }
                recycled.give(fresh);
                hi = need_hi;
                let at = |x: u32, y: u32| first[(y - lo) as usize * row + x as usize];
                // The channels compared: colour, and against a transparent backdrop the
                // transmittance (alpha) too.
                let channels = match backdrop {
                    Backdrop::Background => 3,
                    Backdrop::Transparent => 4,
                };
                let differs = |x: u32, y: u32| {
                    let p = at(x, y);
                    let neighbours = [
                        (x.wrapping_sub(1), y),
                        (x + 1, y),
                        (x, y.wrapping_sub(1)),
                        (x, y + 1),
                    ];
                    neighbours.iter().any(|&(nx, ny)| {
                        nx < width && ny < height && {
                            let q = at(nx, ny);
                            (0..channels).any(|c| (p[c] - q[c]).abs() > SUPER_SAMPLE_CONTRAST)
                        }
                    })
                };
                // The pixels' n × n rays in packets where the first pass took them: each run of
                // pixels to refine along a row of a tile is a tile of the n times finer image,
                // whose pixel centres are those rays' image positions.
                #[cfg(target_arch = "x86_64")]
                let refined = packets.as_ref().map(|p| {
                    let rays = FineRays {
                        packets: p,
                        fine: &fine,
                        image: &image,
                        unbounded,
                        recycled,
                        n,
                    };
                    per_tile(width, y0..y1, TILE, progress, recycled, |tile, out| {
                        rays.refine_tile(tile, out, &at, &differs, &entry_of)
                    })
                });
                #[cfg(not(target_arch = "x86_64"))]
                let refined = None;
                // The tile's entry map, made at its first pixel to refine.
                let lazy = |tile| (tile, std::cell::OnceCell::new());
                let refined = refined.unwrap_or_else(|| {
                    per_pixel(
                        width,
                        y0..y1,
                        progress,
                        recycled,
                        lazy,
                        |(tile, entry), x, y| {
                            if !differs(x, y) {
                                return at(x, y);
                            }
                            let bound = entry
                                .get_or_init(|| entry_of(*tile))
                                .as_ref()
                                .map_or(f64::NEG_INFINITY, |m| m.bound(x, y));
                            let (mut sum, mut t_sum) = (DVec3::ZERO, 0.0);
                            for j in 0..n {
                                for i in 0..n {
                                    let sx = x as f64 + (i as f64 + 0.5) / n as f64;
                                    let sy = y as f64 + (j as f64 + 0.5) / n as f64;
                                    let (c, t) =
                                        scene.trace(view.eye, &image, view.ray(sx, sy), bound);
                                    let p = pixel(c, t);
                                    sum += crate::model::scene::v3([p[0], p[1], p[2]]);
                                    t_sum += p[3] as f64;
                                }
                            }
                            let samples = (n * n) as f64;
                            pixel(sum / samples, t_sum / samples)
                        },
                    )
                })?;
                if !progress.holds() {
                    progress.hold(crate::error::catch("rendering", || sink(y0, &refined)))?;
                }
                recycled.give(refined);
            }
            progress.hold(crate::error::catch("the progress function", || {
                progress.advance(units)
            }))?;
        }
        // (With a team, an error held after the last step fails every rank here.)
        progress.settle()
    };
    crate::error::catch("rendering", run)
}

/// Super-sampling's rays in packets: the n × n rays of pixel (x, y) are the pixels
/// (n·x + i, n·y + j) of `fine`, the image n times finer along each axis, traced by `packets`.
#[cfg(target_arch = "x86_64")]
struct FineRays<'a> {
    packets: &'a simd::Packets<'a>,
    fine: &'a Pinhole,
    image: &'a ImageRays,
    unbounded: Option<Pixel>,
    recycled: &'a Recycled,
    n: u32,
}

#[cfg(target_arch = "x86_64")]
impl FineRays<'_> {
    /// The pixels of tile (x, y, width, height) of a super-sampled strip, into `out` (the
    /// tile's buffer): `at(x, y)`, the first pass, where `differs(x, y)` is false, and else the
    /// mean of its rays, each run of such pixels along a row at once ([`FineRays::refine`]),
    /// from the tile's entry map (`entry_of`, made for the first run). Once the render is to
    /// stop (`control::stop_requested`) no run starts: the rest of `out` is left as it is (a
    /// cancelled render's pixels are discarded), as the scalar refinement starts no pixel.
    fn refine_tile(
        &self,
        (tx, ty, tw, th): (u32, u32, u32, u32),
        mut out: Vec<Pixel>,
        at: &impl Fn(u32, u32) -> Pixel,
        differs: &impl Fn(u32, u32) -> bool,
        entry_of: &impl Fn((u32, u32, u32, u32)) -> Option<EntryMap>,
    ) -> Vec<Pixel> {
        let entry = std::cell::OnceCell::new();
        for y in ty..ty + th {
            let row = &mut out[((y - ty) * tw) as usize..][..tw as usize];
            let mut x = tx;
            while x < tx + tw {
                let x0 = x;
                if !differs(x, y) {
                    row[(x - tx) as usize] = at(x, y);
                    x += 1;
                    continue;
                }
                x += 1;
                while x < tx + tw && differs(x, y) {
                    x += 1;
                }
                // (A ray of the packet march looks at the flag only every `PROBE_EVERY`
                // samples: a run of up to 16·n² short rays would not.)
                if crate::control::stop_requested() {
                    return out;
                }
                let map = entry.get_or_init(|| entry_of((tx, ty, tw, th)));
                let place = &mut row[(x0 - tx) as usize..(x - tx) as usize];
                self.refine(x0..x, y, map.as_ref(), place);
            }
        }
        out
    }

    /// Pixels `xs` of row `y` into `out`, each the mean of its n × n rays: one tile of the
    /// finer image, `n·len × n` pixels, started from the pixels' bounds in `entry` (made
    /// finer, [`EntryMap::finer`]); per pixel its rays' colours and transmittances summed in
    /// f64 row by row, as the scalar refinement sums them.
    fn refine(
        &self,
        xs: std::ops::Range<u32>,
        y: u32,
        entry: Option<&EntryMap>,
        out: &mut [Pixel],
    ) {
        let (p, n) = (self.packets, self.n);
        let map = entry.map(|m| m.finer(xs.clone(), y, n));
        let tile = (xs.start * n, y * n, xs.len() as u32 * n, n);
        // (A run's buffer is small, at most a tile's width times n²: a failure is raised to
        // the step's catch, as a tile's own.)
        let rays = self
            .recycled
            .take((tile.2 * n) as usize, "a run's rays")
            .unwrap_or_else(|e| crate::error::raise(e));
        let (fine, image, unbounded) = (self.fine, self.image, self.unbounded);
        let rays = if p.preintegrated() {
            p.tile_pre(fine, map.as_ref(), image, unbounded, tile, rays)
        } else {
            p.tile(fine, map.as_ref(), image, unbounded, tile, rays)
        };
        let (side, n) = (tile.2 as usize, n as usize);
        for (k, o) in out.iter_mut().enumerate() {
            let (mut sum, mut t_sum) = (DVec3::ZERO, 0.0);
            for j in 0..n {
                for q in &rays[j * side + k * n..][..n] {
                    sum += crate::model::scene::v3([q[0], q[1], q[2]]);
                    t_sum += q[3] as f64;
                }
            }
            let samples = (n * n) as f64;
            *o = pixel(sum / samples, t_sum / samples);
        }
        self.recycled.give(rays);
    }
}

#[cfg(test)]
mod tests;
