//! Image files: binary PPM (P6) and PNG encoding, and the atomic write of any file.
//!
//! Every file is written to a temporary file in the destination directory and renamed over the
//! destination only when complete, so a failed write leaves no partial file and an existing file
//! is replaced only by a complete new one.
//!
//! It owns the encodings and the writing; which files a scene asks for, and their pixels, are
//! decided above it (`render_outputs`) and below it (the renderer).

use crate::error::{err, Error, ErrorCode, Result};
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The image formats `vlImage` accepts, chosen by the file extension (any case).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// Binary PPM, `P6`, 8 bits per channel.
    Ppm,
    /// PNG, 8-bit RGB.
    Png,
}

impl ImageFormat {
    /// The format for a path, from its extension.
    pub fn from_path(path: &Path) -> Result<ImageFormat> {
        if path.file_name().is_none() {
            return err(
                ErrorCode::BadFile,
                format!("{}: not a file name", path.display()),
            );
        }
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("ppm") => Ok(ImageFormat::Ppm),
            Some("png") => Ok(ImageFormat::Png),
            _ => err(
                ErrorCode::BadFile,
                format!(
                    "{}: unsupported image format (use .ppm or .png)",
                    path.display()
                ),
            ),
        }
    }
}

/// Encodes 8-bit RGB pixels (row-major, top row first) in the format of `path`.
pub fn encode(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<Vec<u8>> {
    assert_eq!(rgb.len(), width as usize * height as usize * 3);
    match ImageFormat::from_path(path)? {
        ImageFormat::Ppm => {
            let mut out = format!("P6\n{width} {height}\n255\n").into_bytes();
            out.extend_from_slice(rgb);
            Ok(out)
        }
        ImageFormat::Png => {
            use image::ImageEncoder;
            let mut out = Vec::new();
            image::codecs::png::PngEncoder::new(&mut out)
                .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
                .map_err(|e| {
                    Error::new(ErrorCode::Internal, format!("PNG encoding failed: {e}"))
                })?;
            Ok(out)
        }
    }
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, then a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().ok_or_else(|| {
        Error::new(
            ErrorCode::BadFile,
            format!("{}: not a file name", path.display()),
        )
    })?;
    let tmp = dir.join(format!(
        ".{}.{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let io = |e: std::io::Error| Error::new(ErrorCode::IoError, format!("{}: {e}", path.display()));
    let result = (|| {
        let mut f = fs::File::create(&tmp).map_err(io)?;
        f.write_all(bytes).map_err(io)?;
        f.sync_all().map_err(io)?;
        drop(f);
        fs::rename(&tmp, path).map_err(io)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// Encodes and writes an image atomically.
pub fn write_image(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    let bytes = encode(path, width, height, rgb)?;
    write_atomic(path, &bytes)
}
