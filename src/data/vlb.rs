//! The `.vlb` file format: a 28-byte little-endian header (the magic `VLB1`; nx, ny, nz and
//! the voxel width in bytes as u32; the normalisation a, b as f32) followed by the voxels, x
//! fastest, then y, then z (16-bit voxels little-endian).
//!
//! This file owns reading and writing that format: parsing and checking the header, loading a
//! file or a buffer into a [`Dataset`], and encoding a dataset back. The reader refuses a
//! malformed file before allocating anything: the header's claims are checked against each
//! other and against the file's real length, and nothing is read past its end. The checks of
//! the dataset itself (dimensions against voxels, a usable normalisation) are
//! [`Dataset::new`]'s; the atomic write is `output`'s; other formats are converted to this one
//! by the `vlconvert` tool.

use super::{voxels_of, Dataset, Voxels};
use crate::error::{Error, ErrorCode, Result};
use crate::num::{no_memory, try_vec, try_with_capacity};
use std::io::Read;
use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;

/// The magic number of a `.vlb` file.
pub const MAGIC: &[u8; 4] = b"VLB1";
/// The size of the `.vlb` header in bytes.
pub const HEADER_LEN: usize = 28;

/// A format error of `code`.
fn bad(code: ErrorCode, msg: impl Into<String>) -> Error {
    Error::new(code, msg)
}

/// `O_NONBLOCK`, for opening a dataset without waiting on a FIFO or a device.
#[cfg(any(target_os = "linux", target_os = "android"))]
const O_NONBLOCK: i32 = 0o4000;
#[cfg(not(any(target_os = "linux", target_os = "android")))]
const O_NONBLOCK: i32 = 0x0004;

/// The most bytes a placement sidecar (`.vlb.geom`) may hold: a few lines of text (64 KiB).
const MAX_SIDECAR: u64 = 64 * 1024;

/// Opens the input file `path` as [`Dataset::load`] does (and the `vlconvert` tool its
/// inputs): for reading, without waiting, so that a FIFO with no writer (or a device that
/// would wait) is refused instead of hanging (the flag changes nothing for regular files),
/// and checking that what was opened (not what the name pointed to before) is a regular file:
/// the file and its metadata. A directory or another kind of file is an error of kind `Other`
/// saying so; a missing file keeps its kind `NotFound`.
pub fn open_regular(path: &Path) -> std::io::Result<(std::fs::File, std::fs::Metadata)> {
    let f = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(O_NONBLOCK)
        .open(path)?;
    let meta = f.metadata()?;
    if meta.is_dir() {
        return Err(std::io::Error::other("is a directory"));
    }
    if !meta.is_file() {
        return Err(std::io::Error::other(
            "not a regular file (a FIFO, a device or a socket)",
        ));
    }
    Ok((f, meta))
}

impl Dataset {
    /// Parses a `.vlb` file held in memory (the voxels are copied once, into the dataset).
    pub fn from_vlb_bytes(bytes: &[u8]) -> Result<Dataset> {
        check_magic(bytes)?;
        let header = parse_header(bytes.get(..HEADER_LEN).ok_or_else(|| {
            bad(
                ErrorCode::BadSize,
                format!("truncated header: {} of {HEADER_LEN} bytes", bytes.len()),
            )
        })?)?;
        header.check_len(bytes.len() as u64)?;
        let body = &bytes[HEADER_LEN..];
        let raw = if header.bytes == 1 {
            let mut v = try_with_capacity(body.len(), "the voxels of a .vlb")?;
            v.extend_from_slice(body);
            Voxels::U8(v)
        } else {
            let mut v = try_with_capacity(body.len() / 2, "the voxels of a .vlb")?;
            extend_le(&mut v, body);
            Voxels::U16(v)
        };
        Dataset::new(header.dims, raw, header.a, header.b)
    }

    /// Reads a `.vlb` file: the header is checked against the file's length before the voxels
    /// are allocated (fallibly: `NoMemory` where they do not fit), and nothing is read past
    /// the end. The voxels are read straight into the dataset's buffer.
    ///
    /// Errors: `IoError` for a file that cannot be opened or read (a directory, a FIFO or a
    /// device among them); the header's codes in the order `docs/errors.md` gives them
    /// (`BadMagic`, `BadSize` for a header cut short, `BadDimensions`, `BadVoxelWidth`,
    /// `BadRange`, then `BadSize` for a file longer or shorter than its header says). Where a
    /// placement sidecar ([`Geometry::sidecar`](crate::Geometry::sidecar): the name with
    /// `.geom` appended) lies beside the file (the file a link at `path` leads to), it is read
    /// too: `IoError` where it cannot be read (or is not a regular file), `BadValue` where it
    /// is larger than 64 KiB, `BadFile` where it does not parse or describes another grid
    /// ([`Geometry::parse`](crate::Geometry::parse)).
    pub fn load(path: &Path) -> Result<Dataset> {
        let io =
            |e: std::io::Error| Error::new(ErrorCode::IoError, format!("{}: {e}", path.display()));
        let (mut f, meta) = open_regular(path).map_err(io)?;
        let len = meta.len();
        let named = |e: Error| bad(e.code, format!("{}: {}", path.display(), e.message));
        let mut head = [0u8; HEADER_LEN];
        let got = (len as usize).min(HEADER_LEN);
        f.read_exact(&mut head[..got]).map_err(io)?;
        // A file that is not a .vlb at all says so, however short it is.
        check_magic(&head[..got]).map_err(named)?;
        if len < HEADER_LEN as u64 {
            return Err(bad(
                ErrorCode::BadSize,
                format!("{}: truncated header ({len} bytes)", path.display()),
            ));
        }
        let h = parse_header(&head).map_err(named)?;
        h.check_len(len).map_err(named)?;
        let what = format!("{}: its voxels", path.display());
        // (At most 2^32 voxels: a usize on 64-bit targets.)
        let n = usize::try_from(len - HEADER_LEN as u64).map_err(|_| no_memory(&what, None))?
            / h.bytes as usize;
        let shrank = || {
            Error::new(
                ErrorCode::IoError,
                format!("{}: the file shrank while it was read", path.display()),
            )
        };
        let raw = if h.bytes == 1 {
            // Into the spare capacity (not zeroed first), and no further than the header says.
            let mut v = try_with_capacity::<u8>(n, &what)?;
            (&mut f).take(n as u64).read_to_end(&mut v).map_err(io)?;
            if v.len() != n {
                return Err(shrank());
            }
            Voxels::U8(v)
        } else {
            // Straight into the voxels' memory, its pages made first in parallel by the
            // library's threads (`try_vec`), then put in the host's byte order (nothing to do
            // on a little-endian host).
            let mut v = try_vec(n, 0u16, &what)?;
            f.read_exact(u16_bytes(&mut v)).map_err(|e| {
                if e.kind() == std::io::ErrorKind::UnexpectedEof {
                    shrank()
                } else {
                    io(e)
                }
            })?;
            if cfg!(target_endian = "big") {
                v.iter_mut().for_each(|x| *x = u16::from_le(*x));
            }
            Voxels::U16(v)
        };
        let d = Dataset::new(h.dims, raw, h.a, h.b)?;
        // The physical placement, where a sidecar gives it (`geometry`): beside the file the
        // path leads to, where a dataset saved through a link has its sidecar written
        // (`output::files`); beside the path where its links cannot be followed.
        let sidecar = super::Geometry::sidecar(
            &std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()),
        );
        let side_io = |e: std::io::Error| {
            Error::new(ErrorCode::IoError, format!("{}: {e}", sidecar.display()))
        };
        let (f, meta) = match open_regular(&sidecar) {
            Ok(opened) => opened,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(d),
            Err(e) => return Err(side_io(e)),
        };
        if meta.len() > MAX_SIDECAR {
            return Err(Error::new(
                ErrorCode::BadValue,
                format!(
                    "{}: {} bytes, more than a placement's {MAX_SIDECAR}",
                    sidecar.display(),
                    meta.len()
                ),
            ));
        }
        // (No further than the length checked: a file growing meanwhile is cut there.)
        let mut text = String::new();
        f.take(MAX_SIDECAR)
            .read_to_string(&mut text)
            .map_err(side_io)?;
        Ok(d.with_geometry(
            super::Geometry::parse(&text, h.dims)
                .map_err(|e| Error::new(e.code, format!("{}: {}", sidecar.display(), e.message)))?,
        ))
    }

    /// The `.vlb` encoding of the dataset; `NoMemory` where its bytes cannot be allocated
    /// (saving a dataset, `Dataset::save`, writes them piece by piece instead).
    pub fn to_vlb_bytes(&self) -> Result<Vec<u8>> {
        let len = self.raw.len() * self.raw.width() as usize;
        let mut out = try_with_capacity(HEADER_LEN + len, "the bytes of a .vlb")?;
        out.extend_from_slice(&self.vlb_header());
        self.vlb_body(|b| {
            out.extend_from_slice(b);
            Ok(())
        })?;
        Ok(out)
    }

    /// The dataset's `.vlb` header.
    pub(crate) fn vlb_header(&self) -> [u8; HEADER_LEN] {
        header(self.dims, self.raw.width(), self.a, self.b)
    }

    /// Gives the dataset's `.vlb` body to `out` in order, in pieces of at most 64 KiB (8-bit
    /// voxels in one piece: they are their own bytes); stops at `out`'s first error.
    pub(crate) fn vlb_body(&self, mut out: impl FnMut(&[u8]) -> Result<()>) -> Result<()> {
        match &self.raw {
            Voxels::U8(v) => out(v),
            Voxels::U16(v) => {
                let mut chunk = [0u8; 1 << 16];
                for part in v.chunks(chunk.len() / 2) {
                    for (c, x) in chunk.chunks_exact_mut(2).zip(part) {
                        c.copy_from_slice(&x.to_le_bytes());
                    }
                    out(&chunk[..2 * part.len()])?;
                }
                Ok(())
            }
        }
    }
}

/// A `.vlb` header: the magic, the dimensions and the voxel width as u32, the normalisation a,
/// b as f32, all little-endian. The one encoding of it, for saved datasets and for
/// voxelizations written piece by piece (`output::voxel`).
pub(crate) fn header(dims: [usize; 3], width: u32, a: f32, b: f32) -> [u8; HEADER_LEN] {
    let mut h = [0u8; HEADER_LEN];
    h[..4].copy_from_slice(MAGIC);
    for (k, d) in dims.iter().enumerate() {
        h[4 + 4 * k..8 + 4 * k].copy_from_slice(&(*d as u32).to_le_bytes());
    }
    h[16..20].copy_from_slice(&width.to_le_bytes());
    h[20..24].copy_from_slice(&a.to_le_bytes());
    h[24..28].copy_from_slice(&b.to_le_bytes());
    h
}

/// The bytes of `v`, in memory order.
fn u16_bytes(v: &mut [u16]) -> &mut [u8] {
    // SAFETY: the bytes of initialised u16 are initialised u8, of alignment 1, and span
    // exactly `v`'s memory, borrowed as long as `v`; every pattern of two bytes is a u16, so
    // whatever is written through the view leaves valid u16.
    unsafe { std::slice::from_raw_parts_mut(v.as_mut_ptr().cast::<u8>(), 2 * v.len()) }
}

/// Appends the little-endian 16-bit voxels of `bytes` (of even length) to `v`.
fn extend_le(v: &mut Vec<u16>, bytes: &[u8]) {
    v.extend(
        bytes
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]])),
    );
}

/// What a `.vlb` header claims: dimensions, bytes per voxel, and the normalisation a, b.
struct Header {
    dims: [usize; 3],
    bytes: u32,
    a: f32,
    b: f32,
}

impl Header {
    /// Checks that the file length is exactly header + voxels.
    fn check_len(&self, len: u64) -> Result<()> {
        let voxels = voxel_count(self.dims).unwrap_or(u64::MAX);
        let need = voxels
            .checked_mul(self.bytes as u64)
            .and_then(|v| v.checked_add(HEADER_LEN as u64));
        match need {
            Some(n) if n == len => Ok(()),
            Some(n) if n > len => Err(bad(
                ErrorCode::BadSize,
                format!("file holds {len} bytes but its header claims {n} (truncated)"),
            )),
            Some(n) => Err(bad(
                ErrorCode::BadSize,
                format!("file holds {len} bytes but its header claims {n} (trailing data)"),
            )),
            None => Err(bad(
                ErrorCode::BadDimensions,
                "header claims an impossibly large volume",
            )),
        }
    }
}

/// nx·ny·nz, or `None` when the product overflows.
fn voxel_count(dims: [usize; 3]) -> Option<u64> {
    dims.iter()
        .try_fold(1u64, |acc, &d| acc.checked_mul(d as u64))
}

/// Checks the magic number as far as `bytes` reach (a file shorter than the magic is judged on
/// what it has; the length check reports it).
fn check_magic(bytes: &[u8]) -> Result<()> {
    let n = bytes.len().min(MAGIC.len());
    if bytes[..n] != MAGIC[..n] {
        return Err(bad(
            ErrorCode::BadMagic,
            format!("bad magic {:?} (expected \"VLB1\")", &bytes[..n]),
        ));
    }
    Ok(())
}

fn parse_header(h: &[u8]) -> Result<Header> {
    if &h[0..4] != MAGIC {
        return Err(bad(
            ErrorCode::BadMagic,
            format!("bad magic {:?} (expected \"VLB1\")", &h[0..4]),
        ));
    }
    let u = |o: usize| u32::from_le_bytes([h[o], h[o + 1], h[o + 2], h[o + 3]]);
    let f = |o: usize| f32::from_le_bytes([h[o], h[o + 1], h[o + 2], h[o + 3]]);
    let dims = [u(4) as usize, u(8) as usize, u(12) as usize];
    voxels_of(dims, "dimensions")?;
    let bytes = u(16);
    if bytes != 1 && bytes != 2 {
        return Err(bad(
            ErrorCode::BadVoxelWidth,
            format!("voxel width {bytes} (must be 1 or 2 bytes)"),
        ));
    }
    let (a, b) = (f(20), f(24));
    if !a.is_finite() || !b.is_finite() || a == b {
        return Err(bad(
            ErrorCode::BadRange,
            format!("normalisation a = {a}, b = {b} (must be finite and different)"),
        ));
    }
    Ok(Header { dims, bytes, a, b })
}
