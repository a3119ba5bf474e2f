//! One page of a TIFF stack: what it holds ([`Page`]), checked against its file before it is
//! decoded ([`inspect`]: grey, a bit depth and compression that convert, its strips or tiles
//! inside the file and able to hold it), and decoded ([`decode_in`]) under limits of the
//! file's size; the `tiff` crate's errors in words ([`tiff_error`]).

use super::Res;
use crate::counted;
use crate::volume::Type;
use ::tiff::decoder::{ChunkType, Decoder, DecodingResult, Limits};
use ::tiff::tags::Tag;
use ::tiff::ColorType;
use std::fs::File;
use std::io::{BufReader, Read, Seek};
use std::path::Path;

/// What a page holds, as far as the stack needs to know.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) struct Page {
    pub width: u32,
    pub height: u32,
    /// `SampleFormat` (1 unsigned, 2 signed, 3 float) and bits per sample.
    pub format: u16,
    pub bits: u8,
    /// The element type its samples convert as.
    pub ty: Type,
}

impl Page {
    /// Bytes of its samples as [`Page::ty`].
    pub fn bytes(&self) -> Res<usize> {
        (self.width as usize)
            .checked_mul(self.height as usize)
            .and_then(|n| n.checked_mul(self.ty.bytes()))
            .ok_or_else(|| format!("{} x {} pixels overflow", self.width, self.height))
    }

    pub fn describe(&self) -> String {
        let kind = match self.format {
            2 => "signed",
            3 => "float",
            _ => "unsigned",
        };
        format!(
            "{} x {} pixels of {kind} {}-bit samples",
            self.width, self.height, self.bits
        )
    }
}

/// The `tiff` crate's error, said plainly where it is the file ending early.
pub(super) fn tiff_error(e: ::tiff::TiffError) -> String {
    match e {
        ::tiff::TiffError::IoError(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
            "the file ends before its data does (cut short?)".into()
        }
        ::tiff::TiffError::LimitsExceeded => "a tag of its page directory counts more values \
            than the file holds (or over 256 MiB of them)"
            .into(),
        e => e.to_string(),
    }
}

/// The current page, checked: grey, of a bit depth and compression that convert, its data
/// inside the file (`len` bytes) and able to hold it.
pub(super) fn inspect<R: Read + Seek>(d: &mut Decoder<R>, len: u64) -> Res<Page> {
    let (width, height) = d.dimensions().map_err(tiff_error)?;
    let bits = match d.colortype().map_err(tiff_error)? {
        ColorType::Gray(b) => b,
        other => {
            return Err(format!(
                "{other:?} pixels: only grey pages of one sample a pixel convert (split colour \
                 channels into files of their own first)"
            ))
        }
    };
    let format = match d.find_tag_unsigned_vec::<u16>(Tag::SampleFormat) {
        Ok(Some(v)) => v.first().copied().unwrap_or(1),
        Ok(None) => 1,
        Err(e) => return Err(tiff_error(e)),
    };
    let ty = match (format, bits) {
        (1 | 4, 8) => Type::U8,
        (1 | 4, 16) => Type::U16,
        (1 | 4, 32) => Type::U32,
        (1 | 4, 64) => Type::U64,
        (2, 8) => Type::I8,
        (2, 16) => Type::I16,
        (2, 32) => Type::I32,
        (2, 64) => Type::I64,
        (3, 16 | 32) => Type::F32,
        (3, 64) => Type::F64,
        _ => {
            return Err(format!(
                "{bits}-bit samples of SampleFormat {format}: only 8, 16, 32 and 64-bit integers \
                 and 16, 32 and 64-bit floats convert"
            ))
        }
    };
    let page = Page {
        width,
        height,
        format,
        bits,
        ty,
    };
    // Bytes out per byte in, at most, for each compression that converts.
    let compression = d
        .find_tag_unsigned::<u16>(Tag::Compression)
        .map_err(tiff_error)?
        .unwrap_or(1);
    let ratio: u64 = match compression {
        1 => 1,
        32773 => 64,       // PackBits: 2 bytes give at most 128
        8 | 32946 => 1032, // Deflate: 258 bytes from 2 bits at best
        5 => 3641,         // LZW: 4096 bytes at most from a code of at least 9 bits
        c => {
            let name = match c {
                2..=4 => "CCITT fax",
                6 | 7 => "JPEG",
                34925 => "LZMA",
                50000 | 34926 => "Zstandard",
                50001 | 34927 => "WebP",
                _ => "unknown",
            };
            return Err(format!(
                "compression {c} ({name}) does not convert (none, LZW, Deflate and PackBits do)"
            ));
        }
    };
    let (offsets, counts) = match d.get_chunk_type() {
        ChunkType::Strip => (Tag::StripOffsets, Tag::StripByteCounts),
        ChunkType::Tile => (Tag::TileOffsets, Tag::TileByteCounts),
    };
    let mut chunks = |tag| -> Res<Vec<u64>> {
        Ok(d.find_tag_unsigned_vec::<u64>(tag)
            .map_err(tiff_error)?
            .unwrap_or_default())
    };
    let (offsets, counts) = (chunks(offsets)?, chunks(counts)?);
    let mut held: u64 = 0;
    for (&at, &n) in offsets.iter().zip(&counts) {
        if at.checked_add(n).is_none_or(|end| end > len) {
            return Err(format!(
                "data at bytes {at} … {at}+{n}, past the end of the file ({})",
                counted(len, "byte")
            ));
        }
        held = held.saturating_add(n);
    }
    // The page's bytes as stored (16-bit floats: 2 a sample).
    let need = (width as u64) * (height as u64) * (bits as u64 / 8);
    // Each tile decodes whole, padding and all: each must be able to hold its tile.
    if d.get_chunk_type() == ChunkType::Tile {
        let (tw, th) = d.chunk_dimensions();
        let tile = (tw as u64) * (th as u64) * (bits as u64 / 8);
        if let Some(&n) = counts.iter().find(|&&n| tile > n.saturating_mul(ratio)) {
            return Err(format!(
                "tiles of {tw} x {th} pixels: {}, more than a tile's {} of data can hold",
                counted(tile, "byte"),
                counted(n, "byte")
            ));
        }
    }
    if need > held.saturating_mul(ratio) {
        return Err(format!(
            "{}: {}, more than its {} of data can hold",
            page.describe(),
            counted(need, "byte"),
            counted(held, "byte")
        ));
    }
    Ok(page)
}

/// Decodes the current page (`page`) and appends its elements to `out`, little-endian, rows
/// from the bottom up.
fn decode<R: Read + Seek>(d: &mut Decoder<R>, page: &Page, out: &mut Vec<u8>) -> Res<()> {
    let w = page.width as usize;
    let n = w * page.height as usize;
    macro_rules! rows {
        ($v:expr $(, $f:path)?) => {{
            let v = $v;
            if v.len() < n {
                return Err(format!("{} samples decoded, {n} expected", v.len()));
            }
            for row in v[..n].chunks_exact(w).rev() {
                for &x in row {
                    $(let x = $f(x);)?
                    out.extend_from_slice(&x.to_le_bytes());
                }
            }
        }};
    }
    let image = match d.read_image() {
        Err(::tiff::TiffError::LimitsExceeded) => {
            return Err("its data decodes to more than 3641 times the file's bytes".into())
        }
        image => image.map_err(tiff_error)?,
    };
    match image {
        DecodingResult::U8(v) => rows!(v),
        DecodingResult::U16(v) => rows!(v),
        DecodingResult::U32(v) => rows!(v),
        DecodingResult::U64(v) => rows!(v),
        DecodingResult::I8(v) => rows!(v),
        DecodingResult::I16(v) => rows!(v),
        DecodingResult::I32(v) => rows!(v),
        DecodingResult::I64(v) => rows!(v),
        DecodingResult::F16(v) => rows!(v, f32::from),
        DecodingResult::F32(v) => rows!(v),
        DecodingResult::F64(v) => rows!(v),
    }
    Ok(())
}

/// The `tiff` crate's limits while it reads page directories of a file of `len` bytes: a
/// tag's values take at most 32 bytes of memory (one value) for each byte of the file, and
/// never more than the crate's default of 256 MiB (under which it reads the first directory,
/// which [`first_directory`] has checked).
fn directory_limits(len: u64) -> Limits {
    let mut limits = Limits::default();
    let bound = usize::try_from(len.saturating_mul(32)).unwrap_or(usize::MAX);
    limits.decoding_buffer_size = limits.decoding_buffer_size.min(bound);
    limits.intermediate_buffer_size = limits.intermediate_buffer_size.min(bound);
    limits
}

/// Its limits while it decodes a page `inspect` has checked: the page, at most the file's bytes
/// at the largest expansion of a compression that converts (LZW's 3641), in chunks of at most
/// the file's bytes. No directory is read under them.
fn page_limits(len: u64) -> Limits {
    let mut limits = Limits::default();
    let size = |n: u64| usize::try_from(n).unwrap_or(usize::MAX);
    limits.decoding_buffer_size = size(len.saturating_mul(3641));
    limits.intermediate_buffer_size = size(len);
    limits
}

/// Decodes the current page of a file of `len` bytes under [`page_limits`], then puts back
/// [`directory_limits`] for the next page's directory.
pub(super) fn decode_in<R: Read + Seek>(
    d: Decoder<R>,
    page: &Page,
    out: &mut Vec<u8>,
    len: u64,
) -> (Decoder<R>, Res<()>) {
    let mut d = d.with_limits(page_limits(len));
    let done = decode(&mut d, page, out);
    (d.with_limits(directory_limits(len)), done)
}

/// A decoder for the regular file `path`, and its length. The `tiff` crate reads the first
/// page directory as it opens the file, under its default limits (a tag's values may take
/// 256 MiB), before [`directory_limits`] can be set: [`first_directory`] checks that
/// directory first.
pub(super) fn open(path: &Path) -> Res<(Decoder<BufReader<File>>, u64)> {
    let at = |e: String| format!("{}: {e}", path.display());
    let (f, meta) = crate::volume::open_regular(path)?;
    let mut r = BufReader::new(f);
    first_directory(&mut r, meta.len()).map_err(at)?;
    r.rewind().map_err(|e| at(e.to_string()))?;
    let d = Decoder::new(r)
        .map_err(|e| at(tiff_error(e)))?
        .with_limits(directory_limits(meta.len()));
    Ok((d, meta.len()))
}

/// Checks the first page directory of the TIFF `r` (`len` bytes): no tag may count more
/// values than the file's bytes hold. Anything else wrong with it (no TIFF header, a
/// directory past the end) is left to the decoder to say.
fn first_directory<R: Read + Seek>(r: &mut R, len: u64) -> Res<()> {
    use std::io::SeekFrom;
    let mut head = [0u8; 16];
    if r.read_exact(&mut head).is_err() {
        return Ok(());
    }
    let big = match &head[..2] {
        b"MM" => true,
        b"II" => false,
        _ => return Ok(()),
    };
    let num = |b: &[u8]| -> u64 {
        let mut v = [0u8; 8];
        if big {
            v[8 - b.len()..].copy_from_slice(b);
            u64::from_be_bytes(v)
        } else {
            v[..b.len()].copy_from_slice(b);
            u64::from_le_bytes(v)
        }
    };
    // BigTIFF (43): 8-byte entry counts, value counts and offsets; else 2, 4 and 4.
    let bigtiff = num(&head[2..4]) == 43;
    let (at, wide) = if bigtiff {
        (num(&head[8..16]), 8)
    } else {
        (num(&head[4..8]), 4)
    };
    let mut field = [0u8; 8];
    let mut next =
        |r: &mut R, n: usize| r.read_exact(&mut field[..n]).ok().map(|_| num(&field[..n]));
    if r.seek(SeekFrom::Start(at)).is_err() {
        return Ok(());
    }
    let Some(entries) = next(r, if bigtiff { 8 } else { 2 }) else {
        return Ok(());
    };
    for _ in 0..entries {
        let (Some(tag), Some(ty)) = (next(r, 2), next(r, 2)) else {
            return Ok(());
        };
        let size: u64 = match ty {
            1 | 2 | 6 | 7 => 1,
            3 | 8 => 2,
            4 | 9 | 11 | 13 => 4,
            5 | 10 | 12 | 16..=18 => 8,
            _ => {
                // A type the decoder skips, as it skips it: 8 more bytes, even in a BigTIFF
                // (whose entries are 20 bytes: the decoder reads the next ones from there).
                if next(r, 8).is_none() {
                    return Ok(());
                }
                continue;
            }
        };
        let (Some(count), Some(_)) = (next(r, wide), next(r, wide)) else {
            return Ok(());
        };
        if count.checked_mul(size).is_none_or(|n| n > len) {
            return Err(format!(
                "a tag of its page directory counts more values than the file holds (tag \
                 {tag}: {count} values of {}, in a file of {})",
                counted(size, "byte"),
                counted(len, "byte")
            ));
        }
    }
    Ok(())
}
