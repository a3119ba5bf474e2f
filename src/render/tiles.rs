//! Tile scheduling: the primary-ray generator of an image ([`view`]), the split of the image
//! into square tiles traced in parallel (rayon) and reassembled in a fixed order, so that an
//! image's bytes do not depend on the number of threads ([`per_pixel`], [`per_tile`]; nor on
//! the number of processes: with a team, `Progress::map` hands the tiles out over its ranks),
//! and the tile side of the packet march (`packet_tile`). The super-sampling driver that uses them is
//! [`super::render_image`]; what a ray shows is `integrate`'s.

use super::*;

/// Side of the square pixel tiles traced in parallel.
pub(super) const TILE: u32 = 16;

/// Side of the packet march's tiles where the image has enough of them (`packet_tile`): a
/// tile's 32 lanes stay full for longer before its last rays drain them.
pub(super) const PACKET_TILE: u32 = 32;

/// The packet march's tile side for an image of `width × height`: [`PACKET_TILE`] where that
/// gives at least 16 tiles a thread (work-stealing balances tiles of unequal cost only when
/// there are many), else [`TILE`]. Only the order of the work depends on it, not a pixel.
#[cfg(test)]
pub(super) fn packet_tile(width: u32, height: u32) -> u32 {
    packet_tile_for(width, height, rayon::current_num_threads())
}

/// `packet_tile` for a render followed by `progress`: split over a team's ranks, the
/// threads counted are those of every rank ([`crate::Team::threads`]), so that every rank cuts
/// the image alike.
pub(super) fn packet_side(width: u32, height: u32, progress: &Progress) -> u32 {
    let threads = progress
        .team()
        .map_or_else(rayon::current_num_threads, |t| t.threads());
    packet_tile_for(width, height, threads)
}

/// `packet_tile` for `threads` threads.
fn packet_tile_for(width: u32, height: u32, threads: usize) -> u32 {
    let big = width.div_ceil(PACKET_TILE) as usize * height.div_ceil(PACKET_TILE) as usize;
    if big >= 16 * threads {
        PACKET_TILE
    } else {
        TILE
    }
}

/// The primary-ray generator of a `width × height` image whose view plane has the given
/// width / height `aspect`, for the scene's camera.
pub(super) fn view(settings: &Settings, width: u32, height: u32, aspect: f32) -> Pinhole {
    let cam = &settings.camera;
    let (r, u, f) = cam.basis();
    let half = (cam.fov as f64 * 0.5).to_radians().tan();
    let aspect = aspect as f64;
    let (hw, hh) = if aspect >= 1.0 {
        (half * aspect, half)
    } else {
        (half, half / aspect)
    };
    Pinhole {
        eye: crate::model::scene::v3(cam.eye),
        right: r * hw,
        up: u * hh,
        forward: f,
        width,
        height,
    }
}

/// The top-left corners of the `side × side` tiles of rows `rows` of an image `width` wide,
/// row-major.
pub(super) fn tiles(width: u32, rows: std::ops::Range<u32>, side: u32) -> Vec<(u32, u32)> {
    let mut v = Vec::new();
    for ty in rows.step_by(side as usize) {
        for tx in (0..width).step_by(side as usize) {
            v.push((tx, ty));
        }
    }
    v
}

/// Evaluates `f` for every pixel of rows `rows`, in parallel over tiles, deterministically;
/// `VL_CANCELLED` once `progress` is cancelled (no pixel is started after that). `f` is given
/// what `context` made for the pixel's tile (x, y, width, height), made once a tile by the
/// tile's task. The buffers are `recycled`'s ([`per_tile`]).
pub(super) fn per_pixel<C, M, F>(
    width: u32,
    rows: std::ops::Range<u32>,
    progress: &Progress,
    recycled: &Recycled,
    context: M,
    f: F,
) -> Result<Vec<Pixel>>
where
    M: Fn((u32, u32, u32, u32)) -> C + Sync,
    F: Fn(&C, u32, u32) -> Pixel + Sync,
{
    per_tile(width, rows, TILE, progress, recycled, |tile, mut out| {
        let (tx, ty, tw, th) = tile;
        let here = context(tile);
        let pixels = (ty..ty + th).flat_map(|y| (tx..tx + tw).map(move |x| (x, y)));
        for (o, (x, y)) in out.iter_mut().zip(pixels) {
            // A cancelled render stops within a pixel's work (the rest is discarded).
            if !progress.cancelled() {
                *o = f(&here, x, y);
            }
        }
        out
    })
}

/// Evaluates `f` for every tile (x, y, width, height) of `side × side` pixels (fewer at the
/// right and bottom edges) of rows `rows`, which gives its pixels row by row into the buffer
/// of the tile's pixels it is handed (zeros, from `recycled`), in parallel over tiles,
/// deterministically; the pixels of the rows, in a buffer of `recycled`'s (the tiles' are
/// given back to it). A tile not yet started when `progress` is cancelled is skipped, and the
/// call fails with `VL_CANCELLED`.
pub(super) fn per_tile<F>(
    width: u32,
    rows: std::ops::Range<u32>,
    side: u32,
    progress: &Progress,
    recycled: &Recycled,
    f: F,
) -> Result<Vec<Pixel>>
where
    F: Fn((u32, u32, u32, u32), Vec<Pixel>) -> Vec<Pixel> + Sync,
{
    type Tile = ((u32, u32), Vec<Pixel>);
    let (top, bottom) = (rows.start, rows.end);
    let corners = tiles(width, rows, side);
    // The strip's pixels before the step: with a team, a rank that cannot hold them fails
    // the step on every rank (`Progress::hold`).
    let len = width as usize * (bottom - top) as usize;
    let mut pixels = progress.hold(recycled.take(len, "a strip of the image"))?;
    let row = width as usize;
    let per_row = width.div_ceil(side) as usize;
    // Tile `out` at column `tx` into `band`, the rows of its row of tiles.
    let place = |band: &mut [Pixel], tx: u32, out: &[Pixel]| {
        let tw = ((tx + side).min(width) - tx) as usize;
        for (y, src) in out.chunks(tw).enumerate() {
            let at = y * row + tx as usize;
            band[at..at + tw].copy_from_slice(src);
        }
    };
    // The tiles' buffers this rank took and a team's step returns: as many go back (the other
    // ranks' tiles come as buffers of their own, which are freed).
    let taken = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<Tile> = {
        // Without a team each tile goes into the strip as it ends, its row of tiles locked
        // while it is copied, and its buffer back to `recycled` at once: about one tile's
        // buffer a thread is in use. With a team every tile comes back as a result of the step
        // (every rank gets every tile), copied into place below.
        let bands: Option<Vec<std::sync::Mutex<&mut [Pixel]>>> = match &mut pixels {
            Some(p) if progress.team().is_none() => {
                Some(p.chunks_mut(row * side as usize).map(Into::into).collect())
            }
            _ => None,
        };
        progress
            .map(corners.len(), |i| {
                let (tx, ty) = corners[i];
                if progress.cancelled() {
                    return Vec::new();
                }
                let (tw, th) = ((tx + side).min(width) - tx, (ty + side).min(bottom) - ty);
                // (A tile's buffer is small: a failure is raised to the step's catch.)
                let out = recycled
                    .take((tw * th) as usize, "a tile's pixels")
                    .unwrap_or_else(|e| crate::error::raise(e));
                // (Within the tile, its rays look at whether the render is to stop.)
                let out = crate::control::working_for(progress, || f((tx, ty, tw, th), out));
                let Some(bands) = &bands else {
                    taken.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    return out;
                };
                let band = &bands[((ty - top) / side) as usize];
                place(
                    &mut band.lock().unwrap_or_else(|e| e.into_inner()),
                    tx,
                    &out,
                );
                recycled.give(out);
                progress.tile_done((tw * th) as u64);
                Vec::new()
            })?
            .into_iter()
            .zip(&corners)
            .map(|(out, &corner)| (corner, out))
            .collect()
    };
    // (Held errors fail the step: the pixels are there.)
    let Some(mut pixels) = pixels else {
        return Err(crate::error::Error::new(
            crate::error::ErrorCode::Internal,
            "a strip's pixels were not allocated",
        ));
    };
    // The tiles of a team's step come in row-major order: each band of `side` rows is a row
    // of tiles, copied into place in parallel, a tile row at a time.
    if progress.team().is_some() {
        pixels
            .par_chunks_mut(row * side as usize)
            .zip(results.par_chunks(per_row))
            .for_each(|(band, tiles)| {
                for ((tx, _), out) in tiles {
                    place(band, *tx, out);
                }
            });
        for (_, out) in results.into_iter().take(taken.into_inner()) {
            recycled.give(out);
        }
    }
    Ok(pixels)
}

/// The pixel of colour `c` and transmittance `t`: each in [0, 1], anything non-finite 0.
pub(super) fn pixel(c: DVec3, t: f64) -> Pixel {
    let [r, g, b] = to_f32(c);
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0) as f32
    } else {
        0.0
    };
    [r, g, b, t]
}

/// A colour as single-precision channels in [0, 1]; anything non-finite becomes 0.
pub(super) fn to_f32(c: DVec3) -> [f32; 3] {
    let f = |v: f64| {
        if v.is_finite() {
            v.clamp(0.0, 1.0) as f32
        } else {
            0.0
        }
    };
    [f(c.x), f(c.y), f(c.z)]
}
