//! Image file formats: which one a file name asks for ([`ImageFormat::from_path`]) and the
//! encodings (binary PPM, PNG, PFM) of pixels laid out as a [`PixelFormat`].
//!
//! The name's extension picks the file type and a modifier just before it picks the pixels
//! (`docs/images.md`): `x.png` and `x.ppm` are 8-bit RGB, `x.rgb16.png` and `x.rgb16.ppm`
//! 16-bit RGB, `x.rgba.png` and `x.rgba16.png` RGBA against a transparent backdrop, `x.pfm`
//! 32-bit float RGB. It owns the names and the byte layouts of the files; the pixels are the
//! renderer's ([`PixelFormat::put`]), the atomic writing is `files`'.

use super::files::AtomicFile;
use crate::error::{err, Error, ErrorCode, Result};
use crate::num::{try_vec, try_with_capacity};
use crate::render::PixelFormat;
use std::io::Write;
use std::path::Path;

/// The kind of file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Container {
    /// Binary PPM, `P6`: 8 or 16 bits a channel (16-bit values big-endian).
    Ppm,
    /// PNG: RGB or RGBA, 8 or 16 bits a channel.
    Png,
    /// Portable float map, `PF`: RGB, 32-bit floats, little-endian, rows bottom to top.
    Pfm,
}

/// The format of an image file: its kind and its pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageFormat {
    /// The kind of file.
    pub container: Container,
    /// The pixels it holds (and so the backdrop it is rendered against).
    pub pixels: PixelFormat,
}

/// The modifiers a file name may carry before its extension, and the pixels each asks for.
const MODIFIERS: [(&str, PixelFormat); 6] = [
    ("rgb", PixelFormat::Rgb8),
    ("rgb8", PixelFormat::Rgb8),
    ("rgb16", PixelFormat::Rgb16),
    ("rgba", PixelFormat::Rgba8),
    ("rgba8", PixelFormat::Rgba8),
    ("rgba16", PixelFormat::Rgba16),
];

/// What an unsupported name is told.
const SUPPORTED: &str = "use .ppm, .png or .pfm, with .rgb16 before .ppm or .png for 16 bits \
                         and .rgba or .rgba16 before .png for alpha";

impl ImageFormat {
    /// The format a path asks for, from the end of its file name (any case): the extension
    /// `ppm`, `png` or `pfm`, and before it one of the modifiers `rgb`, `rgb8`, `rgb16`,
    /// `rgba`, `rgba8`, `rgba16` (another word there is part of the name). A name without a
    /// file name, an unknown extension, and a modifier its file type cannot hold (alpha in a
    /// PPM, any modifier on a PFM) are `BadFile`.
    pub fn from_path(path: &Path) -> Result<ImageFormat> {
        let Some(name) = super::files::file_name(path) else {
            return err(
                ErrorCode::BadFile,
                format!("{}: not a file name", path.display()),
            );
        };
        let name = name.to_string_lossy().to_ascii_lowercase();
        let mut parts = name.rsplit('.');
        let ext = parts.next().filter(|_| name.contains('.'));
        let modifier = parts.next().and_then(|m| {
            // In `rgba.png` or `.rgba.png` the word is the stem, not a modifier.
            let has_stem = name.len() > m.len() + ext.map_or(0, str::len) + 2;
            MODIFIERS
                .iter()
                .find(|(word, _)| *word == m && has_stem)
                .copied()
        });
        let bad = |why: String| -> Result<ImageFormat> {
            err(ErrorCode::BadFile, format!("{}: {why}", path.display()))
        };
        let container = match ext {
            Some("ppm") => Container::Ppm,
            Some("png") => Container::Png,
            Some("pfm") => Container::Pfm,
            _ => return bad(format!("unsupported image format ({SUPPORTED})")),
        };
        let pixels = match (container, modifier) {
            (Container::Pfm, None) => PixelFormat::Rgb32F,
            (Container::Pfm, Some((word, _))) => {
                return bad(format!(
                    "a PFM holds 32-bit float RGB only: .{word}.pfm is not a format \
                     ({SUPPORTED})"
                ))
            }
            (Container::Ppm, Some((word, pixels))) if pixels.has_alpha() => {
                return bad(format!(
                    "a PPM has no alpha channel: .{word}.ppm is not a format (use .{word}.png)"
                ))
            }
            (_, Some((_, pixels))) => pixels,
            (_, None) => PixelFormat::Rgb8,
        };
        Ok(ImageFormat { container, pixels })
    }

    /// `BadValue` where a side of a `width × height` image is more than the format can
    /// say: a PNG's header holds each side in 31 bits (at most 2³¹ − 1); PPM and PFM write
    /// them as decimal text, without a limit.
    fn check_sides(self, path: &Path, width: u32, height: u32) -> Result<()> {
        if self.container == Container::Png && width.max(height) > PNG_MAX_SIDE {
            return err(
                ErrorCode::BadValue,
                format!(
                    "{}: size {width}x{height} (a PNG's sides are at most {PNG_MAX_SIDE})",
                    path.display()
                ),
            );
        }
        Ok(())
    }
}

/// The longest side a PNG file can have (its header's 31-bit width and height).
const PNG_MAX_SIDE: u32 = i32::MAX as u32;

/// A writer that keeps the first error its inner writer gave (and gives it back as well), for
/// an encoder that may drop it.
pub(super) struct Kept<W: Write> {
    pub(super) inner: W,
    pub(super) error: Option<std::io::Error>,
}

impl<W: Write> Kept<W> {
    /// `r`, its error kept (as its kind and message) if it is the first (an interrupted call,
    /// which a caller tries again, is not an error to keep).
    fn keep<T>(&mut self, r: std::io::Result<T>) -> std::io::Result<T> {
        if let Err(e) = &r {
            if self.error.is_none() && e.kind() != std::io::ErrorKind::Interrupted {
                self.error = Some(std::io::Error::new(e.kind(), e.to_string()));
            }
        }
        r
    }
}

impl<W: Write> Write for Kept<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let r = self.inner.write(buf);
        self.keep(r)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        let r = self.inner.flush();
        self.keep(r)
    }
}

/// The most bytes of compressed image a PNG's IDAT chunk holds: the PNG encoder's output buffer.
const PNG_CHUNK: usize = 1 << 20;

/// Encodes `pixels` (a `width × height` image laid out as `format.pixels`, in the machine's
/// byte order) into the file `f` and commits it. Where the file wants another byte order or
/// row order, a row at a time is reordered: no copy of the image is made, and a PNG is
/// compressed as its rows are written (its encoder holds a few rows and a chunk of
/// [`PNG_CHUNK`] bytes of compressed stream).
pub(crate) fn encode_into(
    mut f: AtomicFile,
    format: ImageFormat,
    width: u32,
    height: u32,
    pixels: &[u8],
) -> Result<()> {
    let row = width as usize * format.pixels.pixel_bytes();
    assert_eq!(Some(pixels.len()), format.pixels.image_bytes(width, height));
    let rows = pixels.chunks_exact(row.max(1));
    match format.container {
        Container::Ppm if format.pixels.channel_bytes() == 1 => {
            f.write(format!("P6\n{width} {height}\n255\n").as_bytes())?;
            f.write(pixels)?;
        }
        Container::Ppm => {
            // 16-bit values are big-endian.
            f.write(format!("P6\n{width} {height}\n65535\n").as_bytes())?;
            let mut line = Vec::with_capacity(row);
            for r in rows {
                line.clear();
                line.extend(
                    r.chunks_exact(2)
                        .flat_map(|v| u16::from_ne_bytes([v[0], v[1]]).to_be_bytes()),
                );
                f.write(&line)?;
            }
        }
        Container::Png => {
            let (colour, depth) = match format.pixels {
                PixelFormat::Rgb8 => (png::ColorType::Rgb, png::BitDepth::Eight),
                PixelFormat::Rgba8 => (png::ColorType::Rgba, png::BitDepth::Eight),
                PixelFormat::Rgb16 => (png::ColorType::Rgb, png::BitDepth::Sixteen),
                PixelFormat::Rgba16 => (png::ColorType::Rgba, png::BitDepth::Sixteen),
                other => unreachable!("no PNG of {other:?}"),
            };
            let path = f.path().to_path_buf();
            let failed = |e: png::EncodingError| match e {
                png::EncodingError::IoError(e) => {
                    Error::new(ErrorCode::IoError, format!("{}: {e}", path.display()))
                }
                e => Error::new(ErrorCode::Internal, format!("PNG encoding failed: {e}")),
            };
            let sixteen = format.pixels.channel_bytes() == 2;
            // 16-bit samples go big-endian, a row at a time.
            let mut line = if sixteen {
                try_with_capacity(row, "a PNG row")?
            } else {
                Vec::new()
            };
            // (Every write goes through `Kept`: the encoder drops some of its errors, in the
            // flush of its last chunk.)
            let mut kept = Kept {
                inner: f.writer(),
                error: None,
            };
            let mut encoder = png::Encoder::new(&mut kept, width, height);
            encoder.set_color(colour);
            encoder.set_depth(depth);
            encoder.set_compression(png::Compression::Fast);
            encoder.set_filter(png::Filter::Adaptive);
            // Streamed: each row is filtered and compressed as it comes, and the compressed
            // stream leaves in IDAT chunks of at most `PNG_CHUNK` bytes, so the encoder's
            // memory is a few rows and a chunk, whatever the image's size.
            let mut writer = encoder.write_header().map_err(failed)?;
            let mut stream = writer.stream_writer_with_size(PNG_CHUNK).map_err(failed)?;
            for r in rows {
                let bytes = if sixteen {
                    line.clear();
                    line.extend(
                        r.chunks_exact(2)
                            .flat_map(|v| u16::from_ne_bytes([v[0], v[1]]).to_be_bytes()),
                    );
                    &line[..]
                } else {
                    r
                };
                stream
                    .write_all(bytes)
                    .map_err(|e| failed(png::EncodingError::IoError(e)))?;
            }
            stream.finish().map_err(failed)?;
            // (The image's end, IEND.)
            writer.finish().map_err(failed)?;
            if let Some(e) = kept.error.take() {
                return Err(failed(png::EncodingError::IoError(e)));
            }
        }
        Container::Pfm => {
            // A negative scale: little-endian floats. Rows bottom to top.
            f.write(format!("PF\n{width} {height}\n-1.0\n").as_bytes())?;
            let mut line = Vec::with_capacity(row);
            for r in rows.rev() {
                line.clear();
                line.extend(
                    r.chunks_exact(4)
                        .flat_map(|v| f32::from_ne_bytes([v[0], v[1], v[2], v[3]]).to_le_bytes()),
                );
                f.write(&line)?;
            }
        }
    }
    f.commit()
}

/// Encodes 8-bit RGB pixels (row-major, top row first) in the format of `path` (by its name:
/// `.ppm`, `.png`, `.rgb.png` ...; a name that asks for other pixels is `BadFile`: those are
/// written by [`crate::Image::save`]) and writes them atomically, straight into the file: no
/// copy of the pixels is made (nor of the PNG's compressed stream).
/// A side of 0 (an image of no pixels, which no format is asked to hold, as no render makes
/// one), a PNG side over 2³¹ − 1 (more than its header can say) and a slice that is not
/// `3 · width · height` bytes long are `BadValue`, in that order; nothing is written then.
pub fn write_image(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    let format = ImageFormat::from_path(path)?;
    if format.pixels != PixelFormat::Rgb8 {
        return err(
            ErrorCode::BadFile,
            format!(
                "{}: write_image writes 8-bit RGB (.ppm, .png); {:?} pixels are written by \
                 Image::save",
                path.display(),
                format.pixels
            ),
        );
    }
    if width == 0 || height == 0 {
        return err(
            ErrorCode::BadValue,
            format!(
                "{}: size {width}x{height} (each side at least 1)",
                path.display()
            ),
        );
    }
    format.check_sides(path, width, height)?;
    if Some(rgb.len()) != PixelFormat::Rgb8.image_bytes(width, height) {
        return err(
            ErrorCode::BadValue,
            format!(
                "{}: {} bytes for a {width}x{height} RGB image",
                path.display(),
                rgb.len()
            ),
        );
    }
    encode_into(AtomicFile::create(path)?, format, width, height, rgb)
}

impl crate::render::Image {
    /// Writes the image atomically in the format its file name asks for (`docs/images.md`):
    /// RGB formats hold its colour (for an image rendered against a transparent backdrop,
    /// its light over black); RGBA formats its colour straight and alpha (1 for an image
    /// rendered against the background: opaque). A name of no format is `BadFile`; an image
    /// [`Image::check`] refuses (a side of 0, a `pixels` or `transmittance` of another length
    /// than `width × height`) is `BadValue`. The file's bytes (3 to 12 a pixel) are made
    /// first, before anything is written: where they cannot be allocated it is `NoMemory`.
    /// A file that cannot be written is `IoError` (under [`crate::write_atomic`]'s rules).
    /// Whatever fails, no file, temporary or partial, is left, and an existing file is kept.
    ///
    /// [`Image::check`]: crate::Image::check
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let format = ImageFormat::from_path(path)?;
        self.check()
            .map_err(|e| Error::new(e.code, format!("{}: {}", path.display(), e.message)))?;
        let len = format.pixels.image_bytes(self.width, self.height);
        let mut bytes = try_vec(len.unwrap_or(usize::MAX), 0u8, "the image's pixels")?;
        self.put_bytes(format.pixels, &mut bytes);
        encode_into(
            AtomicFile::create(path)?,
            format,
            self.width,
            self.height,
            &bytes,
        )
    }
}
