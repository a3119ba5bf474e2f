//! Pixel buffers kept from one frame to the next ([`Recycled`]): the strips of an image and
//! the pixels of its tiles are given back after each use and handed out again, so that a scene
//! rendered frame after frame reuses memory whose pages are mapped already, where fresh
//! buffers would be returned to the system by the allocator between frames and faulted in
//! again (a fresh page costs about 2 µs on the hosts measured: `docs/performance.md`). The
//! scene's caches hold it (`compile::Caches`), so it lives as long as the open scene. It
//! computes no pixel and decides nothing about a pixel: a buffer handed out holds zeros.

use super::Pixel;
use crate::error::Result;
use std::sync::Mutex;

/// A buffer of more than this many pixels is a strip's (a tile has at most
/// [`super::PACKET_TILE`]² pixels).
const TILE_PIXELS: usize = (super::PACKET_TILE * super::PACKET_TILE) as usize;

/// At most this many pixels' worth of tiles' buffers are kept: a strip's tiles (about 2²⁰
/// pixels, 16 MiB).
const MAX_TILE_PIXELS: usize = 1 << 20;

/// How many of the tiles' buffers kept last a tile's request looks through for one with room.
const LOOK: usize = 16;

/// The buffers kept, for the renders of one scene (see the module documentation): one strip's
/// and tiles' up to [`MAX_TILE_PIXELS`].
#[derive(Default)]
pub(crate) struct Recycled(Mutex<Kept>);

#[derive(Default)]
struct Kept {
    /// The largest strip's buffer given back.
    strip: Option<Vec<Pixel>>,
    /// Tiles' buffers, and the sum of their capacities.
    tiles: Vec<Vec<Pixel>>,
    tile_pixels: usize,
}

impl Recycled {
    /// A buffer of `len` zero pixels: a kept one where one has room for them (one of the last
    /// [`LOOK`] tiles' kept for a tile, the strip's for more), else a new one; `NoMemory`
    /// (naming `what`) where no kept buffer holds them and the memory cannot be had. A long
    /// buffer is filled in parallel, as [`crate::num::try_vec`] fills one.
    pub(crate) fn take(&self, len: usize, what: &str) -> Result<Vec<Pixel>> {
        let kept = {
            let mut k = self.lock();
            if len <= TILE_PIXELS {
                let n = k.tiles.len();
                let found = (n.saturating_sub(LOOK)..n)
                    .rev()
                    .find(|&i| k.tiles[i].capacity() >= len);
                found.map(|i| {
                    let b = k.tiles.swap_remove(i);
                    k.tile_pixels -= b.capacity();
                    b
                })
            } else {
                k.strip.take_if(|s| s.capacity() >= len)
            }
        };
        let Some(mut v) = kept else {
            return crate::num::try_vec(len, [0.0; 4], what);
        };
        v.clear();
        if len >= crate::num::PARALLEL_FILL {
            use rayon::prelude::*;
            // Into the room it has: no reallocation.
            v.par_extend(rayon::iter::repeat_n([0.0f32; 4], len));
        } else {
            v.resize(len, [0.0; 4]);
        }
        Ok(v)
    }

    /// Keeps `v` for a later [`Recycled::take`]: a strip's in place of a smaller one kept, a
    /// tile's unless that would keep more than [`MAX_TILE_PIXELS`] (it is then freed).
    pub(crate) fn give(&self, v: Vec<Pixel>) {
        let cap = v.capacity();
        let mut k = self.lock();
        if cap > TILE_PIXELS {
            if k.strip.as_ref().is_none_or(|s| s.capacity() < cap) {
                k.strip = Some(v);
            }
        } else if cap > 0 && k.tile_pixels + cap <= MAX_TILE_PIXELS {
            k.tile_pixels += cap;
            k.tiles.push(v);
        }
    }

    /// The pixels' worth of buffers kept.
    #[cfg(test)]
    pub(crate) fn kept(&self) -> usize {
        let k = self.lock();
        k.strip.as_ref().map_or(0, Vec::capacity) + k.tile_pixels
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Kept> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_buffer_given_back_is_handed_out_again_zeroed() {
        let r = Recycled::default();
        let mut strip = r.take(1 << 17, "").unwrap();
        let mut tile = r.take(1000, "").unwrap();
        assert_eq!((strip.len(), tile.len()), (1 << 17, 1000));
        assert!(strip.iter().chain(&tile).all(|p| *p == [0.0; 4]));
        strip.fill([1.0; 4]);
        tile.fill([2.0; 4]);
        let (strip_at, tile_at) = (strip.as_ptr(), tile.as_ptr());
        r.give(strip);
        r.give(tile);
        assert_eq!(r.kept(), (1 << 17) + 1000);
        // A tile's request gets a tile's buffer with room for it, a strip's the strip's; both
        // as zeros.
        let other = r.take(1001, "").unwrap();
        assert_ne!(other.as_ptr(), tile_at, "no room: a new one");
        let tile = r.take(900, "").unwrap();
        assert_eq!((tile.as_ptr(), tile.len()), (tile_at, 900));
        let strip = r.take(1 << 16, "").unwrap();
        assert_eq!((strip.as_ptr(), strip.len()), (strip_at, 1 << 16));
        assert!(strip.iter().chain(&tile).all(|p| *p == [0.0; 4]));
        assert_eq!(r.kept(), 0);
        // A strip larger than the one kept: a new buffer, and the kept one stays.
        r.give(strip);
        let larger = r.take((1 << 17) + 1, "").unwrap();
        assert_ne!(larger.as_ptr(), strip_at);
        assert_eq!(r.kept(), 1 << 17);
        // Given back, the larger replaces it.
        r.give(larger);
        assert_eq!(r.kept(), (1 << 17) + 1);
    }

    #[test]
    fn no_more_than_the_bound_is_kept() {
        let r = Recycled::default();
        let n = MAX_TILE_PIXELS / TILE_PIXELS;
        let tiles: Vec<_> = (0..n + 5)
            .map(|_| r.take(TILE_PIXELS, "").unwrap())
            .collect();
        for t in tiles {
            r.give(t);
        }
        assert_eq!(r.kept(), MAX_TILE_PIXELS);
        // With as many tiles kept, a strip is still kept.
        r.give(r.take(1 << 20, "").unwrap());
        assert_eq!(r.kept(), MAX_TILE_PIXELS + (1 << 20));
        // An empty vector holds nothing worth keeping.
        let r = Recycled::default();
        r.give(Vec::new());
        assert_eq!(r.kept(), 0);
    }

    #[test]
    fn a_buffer_that_cannot_be_had_is_no_memory() {
        let e = Recycled::default()
            .take(usize::MAX / 8, "a strip of the image")
            .unwrap_err();
        assert_eq!(e.code, crate::error::ErrorCode::NoMemory);
        assert!(e.message.contains("a strip of the image"), "{}", e.message);
    }
}
