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

/// At most this many pixels' worth of buffers are kept (64 MiB): a strip of the image
/// (about 2²⁰ pixels) and its tiles' pixels, twice over.
const MAX_PIXELS: usize = 1 << 22;

/// At most this many buffers are kept.
const MAX_BUFFERS: usize = 4096;

/// The buffers kept, for the renders of one scene (see the module documentation).
#[derive(Default)]
pub(crate) struct Recycled(Mutex<Kept>);

#[derive(Default)]
struct Kept {
    buffers: Vec<Vec<Pixel>>,
    /// The sum of their capacities.
    pixels: usize,
}

impl Recycled {
    /// A buffer of `len` zero pixels: the kept buffer with the least room that holds them,
    /// else a new one; `NoMemory` (naming `what`) where no kept buffer holds them and the
    /// memory cannot be had. A long buffer is filled in parallel, as [`crate::num::try_vec`]
    /// fills one.
    pub(crate) fn take(&self, len: usize, what: &str) -> Result<Vec<Pixel>> {
        let kept = {
            let mut k = self.lock();
            let best = k
                .buffers
                .iter()
                .enumerate()
                .filter(|(_, b)| b.capacity() >= len)
                .min_by_key(|(_, b)| b.capacity())
                .map(|(i, _)| i);
            best.map(|i| {
                let b = k.buffers.swap_remove(i);
                k.pixels -= b.capacity();
                b
            })
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

    /// Keeps `v` for a later [`Recycled::take`], unless that would keep more than
    /// [`MAX_PIXELS`] pixels or [`MAX_BUFFERS`] buffers (it is then freed).
    pub(crate) fn give(&self, v: Vec<Pixel>) {
        let cap = v.capacity();
        if cap == 0 {
            return;
        }
        let mut k = self.lock();
        if k.buffers.len() < MAX_BUFFERS && k.pixels.saturating_add(cap) <= MAX_PIXELS {
            k.pixels += cap;
            k.buffers.push(v);
        }
    }

    /// The pixels' worth of buffers kept.
    #[cfg(test)]
    pub(crate) fn kept(&self) -> usize {
        self.lock().pixels
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Kept> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_buffer_given_back_is_handed_out_again_zeroed_and_the_least_that_fits() {
        let r = Recycled::default();
        let mut strip = r.take(1 << 17, "").unwrap();
        let mut tile = r.take(1024, "").unwrap();
        assert!(strip.iter().chain(&tile).all(|p| *p == [0.0; 4]));
        strip.fill([1.0; 4]);
        tile.fill([2.0; 4]);
        let (strip_at, tile_at) = (strip.as_ptr(), tile.as_ptr());
        r.give(strip);
        r.give(tile);
        assert!(r.kept() >= (1 << 17) + 1024);
        // A tile's request gets the tile's buffer, not the strip's; both come back as zeros.
        let tile = r.take(1000, "").unwrap();
        assert_eq!((tile.as_ptr(), tile.len()), (tile_at, 1000));
        let strip = r.take(1 << 17, "").unwrap();
        assert_eq!(strip.as_ptr(), strip_at);
        assert!(strip.iter().chain(&tile).all(|p| *p == [0.0; 4]));
        assert_eq!(r.kept(), 0);
        // Nothing kept that fits: a new buffer.
        r.give(tile);
        let big = r.take(2048, "").unwrap();
        assert_eq!(big.len(), 2048);
        assert_ne!(big.as_ptr(), tile_at);
    }

    #[test]
    fn no_more_than_the_bound_is_kept() {
        let r = Recycled::default();
        r.give(Vec::with_capacity(MAX_PIXELS));
        assert_eq!(r.kept(), MAX_PIXELS);
        // Over the bound: freed, not kept.
        r.give(Vec::with_capacity(16));
        assert_eq!(r.kept(), MAX_PIXELS);
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
