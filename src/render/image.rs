//! A rendered image in memory ([`Image`]: linear colour and the transmittance of each pixel's
//! primary ray), what the rays show where they leave the scene ([`Backdrop`]), and the
//! quantisation of pixels into the integer and float layouts of [`PixelFormat`]: the one
//! definition of 8-bit, 16-bit and alpha values that the in-memory helpers, the caller's
//! buffers and the image files all use (`docs/images.md`). It computes no pixel (the renderer
//! does) and writes no file (the output layer does).

use super::{render_strips, Compiled, Progress};
use crate::error::{err, ErrorCode, Result};
use rayon::prelude::*;

/// Renders the compiled scene ([`render_strips`]) against the backdrop of `format` into
/// `buffer`, exactly the image's bytes long, a strip of rows at a time as they are finished.
pub(crate) fn render_into(
    scene: &Compiled,
    size: (u32, u32, f32),
    format: PixelFormat,
    progress: &Progress,
    buffer: &mut [u8],
) -> Result<()> {
    let backdrop = format.backdrop();
    let n = format.pixel_bytes();
    assert_eq!(Some(buffer.len()), format.image_bytes(size.0, size.1));
    let row = size.0 as usize * n;
    render_strips(scene, size, backdrop, progress, |y, rows| {
        let at = y as usize * row;
        let out = &mut buffer[at..at + rows.len() * n];
        // In parallel, a run of pixels a task.
        const RUN: usize = 4096;
        rows.par_chunks(RUN)
            .zip(out.par_chunks_mut(RUN * n))
            .for_each(|(rows, out)| {
                for (p, dst) in rows.iter().zip(out.chunks_exact_mut(n)) {
                    format.put([p[0], p[1], p[2]], p[3], backdrop, dst);
                }
            });
        Ok(())
    })
}

/// What a render shows where its rays leave the scene.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Backdrop {
    /// The scene's background colour (`vlBackground`), as in RGB images: every pixel is
    /// opaque.
    #[default]
    Background,
    /// Nothing: the background is transparent. Each pixel's colour is its light over black
    /// (premultiplied by its coverage), and its alpha is `1 − T`, `T` the transmittance of its
    /// primary ray; mirror rays that escape show black too. Compositing such an image over
    /// an image `B` (`colour + T·B`) gives the scene rendered in front of `B`.
    Transparent,
}

crate::types::int_enum!(
    /// A layout of pixels in memory: row-major, top row first, channels interleaved, values in
    /// the machine's byte order. RGB layouts show the scene over its background; RGBA layouts
    /// are rendered with a transparent backdrop ([`Backdrop::Transparent`]) and carry alpha
    /// `1 − T`. Integer RGBA colour is straight (not premultiplied), as PNG stores it; float
    /// RGBA colour is premultiplied, as OpenEXR and compositing arithmetic take it. The values
    /// are those of the C constants (`VL_RGB8` ... of `vlRenderBuffer`).
    PixelFormat, "pixel format" {
        /// 3 bytes a pixel (`VL_RGB8`).
        Rgb8 = 1,
        /// 4 bytes a pixel, straight colour (`VL_RGBA8`).
        Rgba8 = 2,
        /// 3 `u16` a pixel, 6 bytes (`VL_RGB16`).
        Rgb16 = 3,
        /// 4 `u16` a pixel, 8 bytes, straight colour (`VL_RGBA16`).
        Rgba16 = 4,
        /// 3 `f32` a pixel, 12 bytes, in [0, 1] (`VL_RGB32F`).
        Rgb32F = 5,
        /// 4 `f32` a pixel, 16 bytes, premultiplied colour, in [0, 1] (`VL_RGBA32F`).
        Rgba32F = 6,
    }
);

impl PixelFormat {
    /// The channels of a pixel: 3 or 4.
    pub fn channels(self) -> usize {
        if self.has_alpha() {
            4
        } else {
            3
        }
    }

    /// The bytes of one channel: 1, 2 or 4.
    pub fn channel_bytes(self) -> usize {
        match self {
            PixelFormat::Rgb8 | PixelFormat::Rgba8 => 1,
            PixelFormat::Rgb16 | PixelFormat::Rgba16 => 2,
            PixelFormat::Rgb32F | PixelFormat::Rgba32F => 4,
        }
    }

    /// The bytes of one pixel.
    pub fn pixel_bytes(self) -> usize {
        self.channels() * self.channel_bytes()
    }

    /// Whether it has an alpha channel.
    pub fn has_alpha(self) -> bool {
        matches!(
            self,
            PixelFormat::Rgba8 | PixelFormat::Rgba16 | PixelFormat::Rgba32F
        )
    }

    /// What a render in this format shows where rays leave the scene.
    pub fn backdrop(self) -> Backdrop {
        if self.has_alpha() {
            Backdrop::Transparent
        } else {
            Backdrop::Background
        }
    }

    /// The bytes of a `width × height` image, if that fits in `usize`.
    pub fn image_bytes(self, width: u32, height: u32) -> Option<usize> {
        (width as usize)
            .checked_mul(height as usize)?
            .checked_mul(self.pixel_bytes())
    }

    /// Writes the pixel of colour `rgb` and transmittance `t`, of an image rendered against
    /// `backdrop`, into `out` (exactly [`PixelFormat::pixel_bytes`] long) in the machine's
    /// byte order.
    pub(crate) fn put(self, rgb: [f32; 3], t: f32, backdrop: Backdrop, out: &mut [u8]) {
        let alpha = alpha(t, backdrop);
        match self {
            PixelFormat::Rgb8 => out.copy_from_slice(&rgb.map(to_u8)),
            PixelFormat::Rgba8 => {
                let [r, g, b] = rgb.map(|c| to_u8(straight(c, alpha)));
                out.copy_from_slice(&[r, g, b, to_u8(alpha)]);
            }
            PixelFormat::Rgb16 => put_all(out, rgb.map(|c| to_u16(c).to_ne_bytes())),
            PixelFormat::Rgba16 => {
                let [r, g, b] = rgb.map(|c| to_u16(straight(c, alpha)));
                put_all(out, [r, g, b, to_u16(alpha)].map(u16::to_ne_bytes));
            }
            PixelFormat::Rgb32F => put_all(out, rgb.map(|c| clean(c).to_ne_bytes())),
            PixelFormat::Rgba32F => {
                let [r, g, b] = rgb.map(clean);
                put_all(out, [r, g, b, alpha].map(f32::to_ne_bytes));
            }
        }
    }
}

/// Writes the channels' bytes one after the other into `out`.
fn put_all<const C: usize, const B: usize>(out: &mut [u8], channels: [[u8; B]; C]) {
    for (dst, src) in out.chunks_exact_mut(B).zip(channels) {
        dst.copy_from_slice(&src);
    }
}

/// A rendered image: linear RGB in [0, 1] and the transmittance of each pixel's primary
/// ray, row-major, top row first (`docs/images.md`).
///
/// Its fields are public, so an image built or changed by hand can disagree with itself (a
/// `pixels` or `transmittance` of another length than `width × height`): [`Image::check`]
/// tells it, [`Image::save`] refuses such an image with `BadValue`, and the conversions
/// (`to_bytes`, `to_rgb8` …) panic on it rather than return the pixels of another image.
/// The accessors (`pixel`, `alpha`) check only their own pixel: they panic where it lies
/// outside `width × height` or past the end of the vector they read, and otherwise return
/// the value stored at its index `y · width + x`.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Colour, `width * height` pixels: with [`Backdrop::Background`] what the pixel shows,
    /// the background included; with [`Backdrop::Transparent`] the light of the scene over
    /// black (colour premultiplied by alpha).
    pub pixels: Vec<[f32; 3]>,
    /// The transmittance `T` of each pixel's primary ray, in [0, 1]: the weight of what lies
    /// behind the scene (the background) in the pixel, 0 where the ray ends in opaque matter
    /// or early termination; with super-sampling the mean over the pixel's rays.
    /// `width * height` values, one a pixel.
    pub transmittance: Vec<f32>,
    /// What the rays show where they leave the scene.
    pub backdrop: Backdrop,
}

impl Image {
    /// An image of `pixels` colours (0.5 grey) and `transmittance` values (0), whether or not
    /// they agree with `width × height`, against the background: the image a caller who
    /// builds one by hand may get wrong, for the tests of `check`, `save` and the conversions.
    #[cfg(test)]
    pub(crate) fn with_lengths(
        width: u32,
        height: u32,
        pixels: usize,
        transmittance: usize,
    ) -> Image {
        Image {
            width,
            height,
            pixels: vec![[0.5; 3]; pixels],
            transmittance: vec![0.0; transmittance],
            backdrop: Backdrop::Background,
        }
    }

    /// An image of the colours `pixels` (`width * height` of them, row-major, top row first),
    /// opaque: against the background, transmittance 0 (for images made by other means than
    /// a render, such as a closed form to compare a render with).
    ///
    /// # Panics
    ///
    /// Where `pixels` does not hold `width * height` colours.
    pub fn from_rgb(width: u32, height: u32, pixels: Vec<[f32; 3]>) -> Image {
        assert!(
            pixels.len() as u64 == width as u64 * height as u64,
            "Image::from_rgb: {} pixels for a {width}x{height} image",
            pixels.len()
        );
        Image {
            width,
            height,
            transmittance: vec![0.0; pixels.len()],
            pixels,
            backdrop: Backdrop::Background,
        }
    }

    /// `BadValue` unless the image is one the library renders and writes: each side 1 …
    /// [`MAX_IMAGE_SIDE`], at most [`MAX_IMAGE_PIXELS`] pixels, and `pixels` and
    /// `transmittance` each `width × height` long. [`Image::save`] checks it before it
    /// writes anything.
    ///
    /// [`MAX_IMAGE_SIDE`]: super::MAX_IMAGE_SIDE
    /// [`MAX_IMAGE_PIXELS`]: super::MAX_IMAGE_PIXELS
    pub fn check(&self) -> Result<()> {
        use super::{MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE};
        if let Some(why) = self.lengths_disagree() {
            return err(ErrorCode::BadValue, format!("Image: {why}"));
        }
        let (w, h) = (self.width, self.height);
        let side = 1..=MAX_IMAGE_SIDE as u32;
        if !side.contains(&w) || !side.contains(&h) || w as u64 * h as u64 > MAX_IMAGE_PIXELS {
            return err(
                ErrorCode::BadValue,
                format!(
                    "Image: size {w}x{h} (each side 1 … {MAX_IMAGE_SIDE}, at most \
                     {MAX_IMAGE_PIXELS} pixels)"
                ),
            );
        }
        Ok(())
    }

    /// What is wrong with the lengths of `pixels` and `transmittance`, if either is not
    /// `width × height`.
    fn lengths_disagree(&self) -> Option<String> {
        let n = self.width as u64 * self.height as u64;
        let (p, t) = (self.pixels.len(), self.transmittance.len());
        (p as u64 != n || t as u64 != n).then(|| {
            format!(
                "{p} pixels and {t} transmittance values for a {}x{} image ({n} of each)",
                self.width, self.height
            )
        })
    }

    /// Panics, naming the conversion `what`, where the lengths of `pixels` and
    /// `transmittance` are not `width × height`.
    fn assert_lengths(&self, what: &str) {
        if let Some(why) = self.lengths_disagree() {
            panic!("Image::{what}: {why}");
        }
    }

    /// The colour at column `x`, row `y` (row 0 at the top).
    ///
    /// # Panics
    ///
    /// Where `x` or `y` lies outside the image (`x ≥ width` or `y ≥ height`), or the pixel's
    /// index `y · width + x` lies past the end of `pixels`.
    pub fn pixel(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[self.index(x, y, "pixel")]
    }

    /// The index of the pixel at column `x`, row `y`; panics, naming the accessor `what`,
    /// where it lies outside the image.
    fn index(&self, x: u32, y: u32, what: &str) -> usize {
        assert!(
            x < self.width && y < self.height,
            "Image::{what}: ({x}, {y}) is outside the {}x{} image",
            self.width,
            self.height
        );
        y as usize * self.width as usize + x as usize
    }

    /// The alpha at column `x`, row `y`: `1 − T` for a transparent backdrop, 1 (opaque) for
    /// the background.
    ///
    /// # Panics
    ///
    /// Where `x` or `y` lies outside the image (`x ≥ width` or `y ≥ height`), or the pixel's
    /// index `y · width + x` lies past the end of `transmittance` (for either backdrop).
    pub fn alpha(&self, x: u32, y: u32) -> f32 {
        alpha(self.transmittance[self.index(x, y, "alpha")], self.backdrop)
    }

    /// The pixels in `format` ([`PixelFormat`]: what a render into a buffer of that format
    /// gives, and what the image files hold), in the machine's byte order.
    ///
    /// # Panics
    ///
    /// Where `pixels` or `transmittance` is not `width × height` long ([`Image::check`]
    /// tells it without panicking). The same holds for every `to_*` conversion.
    pub fn to_bytes(&self, format: PixelFormat) -> Vec<u8> {
        self.assert_lengths("to_bytes");
        let mut out = vec![0u8; self.pixels.len() * format.pixel_bytes()];
        self.put_bytes(format, &mut out);
        out
    }

    /// Writes the pixels in `format` into `out`, one pixel after the other (`out` holds
    /// [`PixelFormat::pixel_bytes`] bytes for each): the bytes of [`Image::to_bytes`], into a
    /// buffer the caller allocated (`Image::save`'s, allocated fallibly). For an image whose
    /// lengths agree ([`Image::check`]).
    pub(crate) fn put_bytes(&self, format: PixelFormat, out: &mut [u8]) {
        let n = format.pixel_bytes();
        debug_assert!(self.lengths_disagree().is_none());
        debug_assert_eq!(out.len(), self.pixels.len() * n);
        for ((p, &t), dst) in self
            .pixels
            .iter()
            .zip(&self.transmittance)
            .zip(out.chunks_exact_mut(n))
        {
            format.put(*p, t, self.backdrop, dst);
        }
    }

    /// 8-bit RGB, each channel `round(255·v)`. Panics as [`Image::to_bytes`] does.
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.assert_lengths("to_rgb8");
        self.pixels.iter().flat_map(|p| p.map(to_u8)).collect()
    }

    /// 16-bit RGB: `round(65535·v)`, the 16-bit value whose rounding to 8 bits
    /// (`round(v16 / 257)`) is the 8-bit value (`docs/images.md`). Panics as
    /// [`Image::to_bytes`] does.
    pub fn to_rgb16(&self) -> Vec<u16> {
        self.assert_lengths("to_rgb16");
        self.pixels.iter().flat_map(|p| p.map(to_u16)).collect()
    }

    /// 8-bit RGBA, straight colour (colour / alpha) and alpha, as a PNG holds it. Panics as
    /// [`Image::to_bytes`] does.
    pub fn to_rgba8(&self) -> Vec<u8> {
        self.assert_lengths("to_rgba8");
        self.to_bytes(PixelFormat::Rgba8)
    }

    /// 16-bit RGBA, straight colour (colour / alpha) and alpha, as a PNG holds it. Panics as
    /// [`Image::to_bytes`] does.
    pub fn to_rgba16(&self) -> Vec<u16> {
        self.assert_lengths("to_rgba16");
        self.rgba(to_u16, |c, a| to_u16(straight(c, a)))
    }

    /// Float RGBA: premultiplied colour and alpha. Panics as [`Image::to_bytes`] does.
    pub fn to_rgba_f32(&self) -> Vec<f32> {
        self.assert_lengths("to_rgba_f32");
        self.rgba(clean, |c, _| clean(c))
    }

    /// Every pixel as four channels: `colour(c, alpha)` of each colour channel, then
    /// `alpha_of(alpha)`.
    fn rgba<T>(&self, alpha_of: impl Fn(f32) -> T, colour: impl Fn(f32, f32) -> T) -> Vec<T> {
        self.pixels
            .iter()
            .zip(&self.transmittance)
            .flat_map(|(p, &t)| {
                let a = alpha(t, self.backdrop);
                let [r, g, b] = p.map(|c| colour(c, a));
                [r, g, b, alpha_of(a)]
            })
            .collect()
    }
}

/// The alpha of a pixel whose primary ray has transmittance `t`: `1 − t` against a
/// transparent backdrop, 1 against the background; in [0, 1], never NaN.
pub(crate) fn alpha(t: f32, backdrop: Backdrop) -> f32 {
    match backdrop {
        Backdrop::Background => 1.0,
        Backdrop::Transparent => 1.0 - clean(t),
    }
}

/// `v` in [0, 1]; anything non-finite becomes 0.
pub(crate) fn clean(v: f32) -> f32 {
    if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The straight colour of the premultiplied channel `c` at alpha `a`: `c / a`, at most 1
/// (light a mirror adds beyond the coverage cannot be stored straight); 0 where `a` is 0 (a
/// pixel nothing covers has no colour).
pub(crate) fn straight(c: f32, a: f32) -> f32 {
    if a > 0.0 {
        (clean(c) / a).min(1.0)
    } else {
        0.0
    }
}

/// A channel in 8 bits: `round(255·v)` of `v` in [0, 1]; anything non-finite becomes 0.
pub(crate) fn to_u8(v: f32) -> u8 {
    if v.is_finite() {
        (v.clamp(0.0, 1.0) * 255.0).round() as u8
    } else {
        0
    }
}

/// A channel in 16 bits: `round(65535·v)` of `v` in [0, 1] (computed exactly, in double
/// precision); anything non-finite becomes 0. Rounded to 8 bits (`round(v16 / 257)`), it is
/// [`to_u8`]`(v)`: in exact arithmetic `65535·v = 257·(255·v)` and 257 is odd, so the half
/// steps of 8 bits fall on half steps of 16 bits and both roundings agree. [`to_u8`] rounds
/// `255·v` in single precision, which can move a product within 2⁻¹⁷ of a half step across
/// it; the 16-bit value is then kept within the 8-bit value's interval (one unit of 16 bits),
/// so that the relation always holds.
pub(crate) fn to_u16(v: f32) -> u16 {
    if !v.is_finite() {
        return 0;
    }
    let q8 = to_u8(v) as i32;
    let q = (v.clamp(0.0, 1.0) as f64 * 65535.0).round() as i32;
    q.clamp(257 * q8 - 128, 257 * q8 + 128).clamp(0, 65535) as u16
}

#[cfg(test)]
mod tests;
