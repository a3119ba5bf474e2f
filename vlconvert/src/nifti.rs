//! NIfTI-1: a single file (`.nii`, magic `n+1`, gzipped or not as its first bytes tell) or a
//! header whose voxels are in an image file beside it (`.hdr` + `.img`, magic `ni1`; a name
//! ending in `.gz` is gzipped). This module owns reading them: every file is opened by
//! `volume::open_regular` (a FIFO, a device or a directory is refused without waiting), a gzip
//! stream is read to its end (`gunzip`: a checksum that does not match, or a stream cut short,
//! is an error; bytes after it are said in a note), the 348-byte header is parsed by the
//! `nifti` crate, and the voxels are taken at the header's `vox_offset` (a whole number of
//! bytes, at 348 or after in a single file, inside the data; bytes after the voxels are said in
//! a note). It owns what the header says of the values
//! (`dim`, `datatype`, byte order, `scl_slope` / `scl_inter`) and of their placement (the sform,
//! else the qform, else the voxel sizes; a qform quaternion that is no rotation is no
//! placement, a negative qform voxel size is taken as its absolute value), before the
//! conversion every volume shares (`volume`).

use crate::gunzip::Gunzip;
use crate::progress::{Progress, Reading, Unit};
use crate::volume::{self, Type, Volume};
use nifti::{Endianness, NiftiHeader, NiftiType};
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

type Res<T> = Result<T, String>;

/// Bytes of a NIfTI-1 header.
const HEADER_LEN: u64 = 348;

/// How far b² + c² + d² of a qform quaternion (stored as float32) may exceed 1 by rounding:
/// within it, (b, c, d) is scaled to length 1 (a = 0), as niftilib does; beyond it, the qform
/// is no rotation.
const QUATERNION_SLACK: f64 = 1e-6;

/// A failure to read a stream, in words: a gzip stream's own ([`volume::gzip_error`]), or the
/// system's.
fn read_error(gz: bool) -> impl Fn(std::io::Error) -> String {
    move |e| {
        if gz {
            volume::gzip_error(e)
        } else {
            e.to_string()
        }
    }
}

/// A file's bytes as they are read: as stored, or decompressed (gzip, member by member).
enum Stream {
    Plain(BufReader<Reading<std::fs::File>>),
    Gz(Gunzip<BufReader<Reading<std::fs::File>>>),
}

impl Read for Stream {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        match self {
            Stream::Plain(r) => r.read(out),
            Stream::Gz(r) => r.read(out),
        }
    }
}

impl Stream {
    /// Once read to its end, a note of the bytes after a gzip stream of the file `path`.
    fn note_trailing(&self, path: &Path) {
        if let Stream::Gz(g) = self {
            if g.trailing() > 0 {
                eprintln!(
                    "vlconvert: note: {} has {} after its gzip stream (ignored)",
                    path.display(),
                    crate::counted(g.trailing(), "byte")
                );
            }
        }
    }
}

/// The bytes of the regular file `path` as a stream, decompressed where it is gzipped (told by
/// its first bytes where `by_magic`, else by a name ending in `.gz`), the file's bytes counted
/// on a progress line; and whether it is gzipped.
fn stream(path: &Path, by_magic: bool) -> Res<(Stream, bool)> {
    let (f, meta) = volume::open_regular(path)?;
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let bar = Progress::new(format!("reading {name}"), meta.len(), Unit::Bytes);
    let mut r = BufReader::new(Reading::new(f, bar));
    let gz = if by_magic {
        r.fill_buf()
            .map_err(|e| format!("{}: {e}", path.display()))?
            .starts_with(&[0x1f, 0x8b])
    } else {
        name.ends_with(".gz")
    };
    Ok(if gz {
        (Stream::Gz(Gunzip::new(r)), true)
    } else {
        (Stream::Plain(r), false)
    })
}

/// The header at the start of the stream `r`.
fn header(r: &mut dyn Read, gz: bool) -> Res<NiftiHeader> {
    let mut buf = Vec::new();
    Read::take(&mut *r, HEADER_LEN)
        .read_to_end(&mut buf)
        .map_err(read_error(gz))?;
    if buf.len() < HEADER_LEN as usize {
        return Err(format!(
            "{}: the file ends inside the 348-byte NIfTI-1 header",
            crate::counted(buf.len(), "byte")
        ));
    }
    NiftiHeader::from_reader(buf.as_slice()).map_err(|e| match e {
        nifti::NiftiError::InvalidFormat => {
            "not a NIfTI-1 header (no n+1 or ni1 magic at byte 344)".into()
        }
        e => format!("header: {e}"),
    })
}

/// What the header says of the voxels: the dimensions, the element type and the bytes they
/// take.
fn layout(h: &NiftiHeader) -> Res<([usize; 3], Type, u64)> {
    // (dim is signed in NIfTI-1; the crate reads it unsigned.)
    let ndim = h.dim[0] as i16;
    if !(1..=7).contains(&ndim) {
        return Err(format!(
            "dim[0] = {ndim}: the number of dimensions must be 1 to 7"
        ));
    }
    let mut dim: Vec<i64> = (1..=ndim as usize)
        .map(|i| h.dim[i] as i16 as i64)
        .collect();
    if let Some(i) = dim.iter().position(|&d| d < 1) {
        return Err(format!(
            "dim[{}] = {}: every dimension must be positive",
            i + 1,
            dim[i]
        ));
    }
    // A 1- or 2-D image is a volume one node deep along the axes it lacks.
    while dim.len() < 3 {
        dim.push(1);
    }
    if dim[3..].iter().any(|&d| d != 1) {
        return Err(format!(
            "a {}-dimensional volume {dim:?}; only 3D volumes convert",
            dim.len()
        ));
    }
    let ty = match h.data_type() {
        Ok(NiftiType::Uint8) => Type::U8,
        Ok(NiftiType::Int8) => Type::I8,
        Ok(NiftiType::Uint16) => Type::U16,
        Ok(NiftiType::Int16) => Type::I16,
        Ok(NiftiType::Uint32) => Type::U32,
        Ok(NiftiType::Int32) => Type::I32,
        Ok(NiftiType::Uint64) => Type::U64,
        Ok(NiftiType::Int64) => Type::I64,
        Ok(NiftiType::Float32) => Type::F32,
        Ok(NiftiType::Float64) => Type::F64,
        Ok(other) => {
            return Err(format!(
                "data type {other:?} (complex, RGB, 128-bit) does not convert"
            ))
        }
        Err(_) => return Err(format!("datatype {}: not a NIfTI-1 data type", h.datatype)),
    };
    let dims = [dim[0] as usize, dim[1] as usize, dim[2] as usize];
    // (At most 32767³ elements of 8 bytes: no overflow.)
    let len = dims.iter().map(|&d| d as u64).product::<u64>() * ty.bytes() as u64;
    Ok((dims, ty, len))
}

/// The header's `vox_offset` as a byte offset: a whole number, not negative, and in a single
/// file (`single`) not inside the header.
fn vox_offset(h: &NiftiHeader, single: bool) -> Res<u64> {
    let v = h.vox_offset as f64;
    if !(v.is_finite() && v >= 0.0 && v.fract() == 0.0) {
        return Err(format!(
            "vox_offset {v}: not a byte offset (a whole number, not negative)"
        ));
    }
    if single && v < HEADER_LEN as f64 {
        return Err(format!(
            "vox_offset {v}: inside the 348-byte header (a single-file NIfTI-1's voxels follow \
             it, at byte 352 by the standard)"
        ));
    }
    Ok(v as u64)
}

/// From the stream `r`, now at its byte `at`, the `len` bytes from byte `start` (at or after
/// `at`) on, of the voxels `what` names; and the count of bytes after them, read to the
/// stream's end (so that a gzip stream is checked whole).
fn voxels(
    r: &mut dyn Read,
    gz: bool,
    (at, start, len): (u64, u64, u64),
    what: &str,
) -> Res<(Vec<u8>, u64)> {
    let sink = &mut std::io::sink();
    let skipped =
        std::io::copy(&mut Read::take(&mut *r, start - at), sink).map_err(read_error(gz))?;
    if at + skipped < start {
        return Err(format!(
            "vox_offset {start} is past the end of the data ({})",
            crate::counted(at + skipped, "byte")
        ));
    }
    let mut data = Vec::new();
    Read::take(&mut *r, len)
        .read_to_end(&mut data)
        .map_err(read_error(gz))?;
    if (data.len() as u64) < len {
        return Err(format!(
            "{} of voxels from vox_offset {start}, {len} needed for {what}",
            crate::counted(data.len(), "byte")
        ));
    }
    let extra = std::io::copy(r, sink).map_err(read_error(gz))?;
    Ok((data, extra))
}

/// The image file of the header `hdr` (`name.hdr` or `name.hdr.gz`): `name.img.gz` where it
/// exists, else `name.img`.
fn image_file(hdr: &Path) -> Res<PathBuf> {
    let name = hdr.file_name().unwrap_or_default().to_string_lossy();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    let stem = Path::new(name)
        .file_stem()
        .unwrap_or_default()
        .to_string_lossy();
    let plain = hdr.with_file_name(format!("{stem}.img"));
    let gz = hdr.with_file_name(format!("{stem}.img.gz"));
    if std::fs::metadata(&gz).is_ok() {
        Ok(gz)
    } else if std::fs::metadata(&plain).is_ok() {
        Ok(plain)
    } else {
        Err(format!(
            "a NIfTI-1 header (magic ni1) without its image file: neither {} nor {} is there",
            plain.display(),
            gz.display()
        ))
    }
}

/// A NIfTI-1 header's placement of its voxels, in RAS millimetres: the sform where its code
/// is set, else the qform (quaternion, pixdim, qfac), else the voxel sizes alone (NIfTI's
/// "method 1"); units other than millimetres (xyzt_units) are converted. A quaternion whose
/// b² + c² + d² exceeds 1 by more than rounding ([`QUATERNION_SLACK`]) is refused: it is no
/// rotation (nibabel refuses it too). A negative qform voxel size (pixdim[1 … 3]) is taken as
/// its absolute value, as nibabel takes it (qfac alone mirrors an axis), and said to `note`.
fn geometry(h: &NiftiHeader, note: impl Fn(String)) -> Res<vlib::Geometry> {
    let unit = match h.xyzt_units & 7 {
        1 => 1000.0, // metres
        3 => 0.001,  // micrometres
        _ => 1.0,    // millimetres, or unknown
    };
    let p = |i: usize| h.pixdim[i] as f64;
    let affine = if h.sform_code > 0 {
        [h.srow_x, h.srow_y, h.srow_z].map(|r| r.map(|v| v as f64 * unit))
    } else if h.qform_code > 0 {
        let (b, c, d) = (h.quatern_b as f64, h.quatern_c as f64, h.quatern_d as f64);
        let norm2 = b * b + c * c + d * d;
        if norm2 > 1.0 + QUATERNION_SLACK {
            return Err(format!(
                "qform quaternion b, c, d = {b}, {c}, {d}: b² + c² + d² = {norm2} is more than \
                 1, so it is no rotation"
            ));
        }
        // Within rounding of 1: a 180° rotation, (b, c, d) of length 1.
        let (a, b, c, d) = if norm2 > 1.0 {
            let n = norm2.sqrt();
            (0.0, b / n, c / n, d / n)
        } else {
            ((1.0 - norm2).sqrt(), b, c, d)
        };
        let r = [
            [
                a * a + b * b - c * c - d * d,
                2.0 * (b * c - a * d),
                2.0 * (b * d + a * c),
            ],
            [
                2.0 * (b * c + a * d),
                a * a + c * c - b * b - d * d,
                2.0 * (c * d - a * b),
            ],
            [
                2.0 * (b * d - a * c),
                2.0 * (c * d + a * b),
                a * a + d * d - c * c - b * b,
            ],
        ];
        let qfac = if p(0) < 0.0 { -1.0 } else { 1.0 };
        for i in (1..=3).filter(|&i| p(i) < 0.0) {
            note(format!(
                "qform pixdim[{i}] = {}: a voxel size is not negative, so its absolute value \
                 {} is used, as nibabel uses it (only qfac, pixdim[0], mirrors an axis)",
                p(i),
                p(i).abs()
            ));
        }
        let s = [p(1).abs(), p(2).abs(), qfac * p(3).abs()];
        // (The crate names qoffset_x … z quatern_x … z.)
        let off = [h.quatern_x as f64, h.quatern_y as f64, h.quatern_z as f64];
        let row = |i: usize| {
            [
                r[i][0] * s[0] * unit,
                r[i][1] * s[1] * unit,
                r[i][2] * s[2] * unit,
                off[i] * unit,
            ]
        };
        [row(0), row(1), row(2)]
    } else {
        [
            [p(1) * unit, 0.0, 0.0, 0.0],
            [0.0, p(2) * unit, 0.0, 0.0],
            [0.0, 0.0, p(3) * unit, 0.0],
        ]
    };
    vlib::Geometry::new(affine).map_err(|e| e.message)
}

/// Converts the NIfTI-1 file `input` (a single file, or a header with its image file).
pub fn convert(input: &Path, output: &Path, window: &super::Window) -> Res<()> {
    let v = read(input)?;
    super::convert(&v, window, output).map_err(|e| format!("{}: {e}", input.display()))
}

/// Reads the NIfTI-1 file `input` (a single file, or a header with its image file).
pub fn read(input: &Path) -> Res<Volume> {
    let at = |e: String| format!("{}: {e}", input.display());
    let (mut r, gz) = stream(input, true)?;
    let h = header(&mut r, gz).map_err(at)?;
    let single = &h.magic == b"n+1\0";
    let (dims, ty, len) = layout(&h).map_err(at)?;
    let start = vox_offset(&h, single).map_err(at)?;
    if h.bitpix as i64 != 8 * ty.bytes() as i64 {
        eprintln!(
            "vlconvert: note: {}: bitpix {} does not match datatype {ty:?} ({} bits): the \
             datatype is read",
            input.display(),
            h.bitpix,
            8 * ty.bytes()
        );
    }
    let what = format!("{dims:?} of {ty:?}");
    let (file, data, extra) = if single {
        let (data, extra) = voxels(&mut r, gz, (HEADER_LEN, start, len), &what).map_err(at)?;
        r.note_trailing(input);
        (input.to_path_buf(), data, extra)
    } else {
        // The rest of the header's file (its extensions), to its end: a gzip stream is checked.
        std::io::copy(&mut r, &mut std::io::sink()).map_err(|e| at(read_error(gz)(e)))?;
        r.note_trailing(input);
        drop(r);
        let img = image_file(input).map_err(at)?;
        let (mut r, gz) = stream(&img, false)?;
        let (data, extra) = voxels(&mut r, gz, (0, start, len), &what)
            .map_err(|e| format!("{}: {e}", img.display()))?;
        r.note_trailing(&img);
        (img, data, extra)
    };
    if extra > 0 {
        eprintln!(
            "vlconvert: note: {} has {} after the voxels (ignored)",
            file.display(),
            crate::counted(extra, "byte")
        );
    }
    // NIfTI-1: a slope of 0 means the values are unscaled.
    let (slope, inter) = if h.scl_slope == 0.0 || !h.scl_slope.is_finite() {
        (1.0, 0.0)
    } else {
        (h.scl_slope as f64, h.scl_inter as f64)
    };
    // A placement that cannot be made (voxel sizes of 0, say) is said, and the volume
    // converts without one.
    let note = |e: String| eprintln!("vlconvert: note: {}: {e}", input.display());
    let placement = match geometry(&h, note) {
        Ok(g) => Some(g),
        Err(e) => {
            eprintln!("vlconvert: note: {}: no placement: {e}", input.display());
            None
        }
    };
    Ok(Volume {
        dims,
        bytes: data,
        ty,
        big: h.endianness == Endianness::Big,
        slope,
        inter,
        geometry: placement,
    })
}
