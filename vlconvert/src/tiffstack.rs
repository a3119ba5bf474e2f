//! TIFF stacks: a multi-page TIFF (each page one z slice: ImageJ hyperstacks as ImageJ and
//! tifffile write them, plain multi-page files, BigTIFF) or a folder of single-page TIFFs taken
//! in the natural order of their names (numbers compared as numbers: slice_2 before slice_10),
//! decoded with the `tiff` crate.
//!
//! - Pages: grey, one sample a pixel, of 8, 16, 32 or 64 bits: unsigned, signed or floating
//!   point (`SampleFormat`; 16-bit floats read as f32), either byte order, uncompressed, LZW,
//!   Deflate or PackBits, in strips or tiles. WhiteIsZero pages are inverted as the `tiff` crate
//!   reads them (unsigned: max − v; floats: 1 − v), so larger is brighter. Every page must have
//!   the first page's size and type; colour, palette and multi-sample pages, other compressions
//!   and packed bit depths are refused, naming the file and page.
//! - Axes: a page's rows run top to bottom; object y runs upwards, so a page's bottom row is
//!   node row 0 (as `vlconvert image` does) and page 1 is z = 0.
//! - Spacing: X/YResolution in the unit of ImageJ's `unit=` (mm, µm, nm, cm, m, inch) or else
//!   of ResolutionUnit (inch, cm; tifffile's mm and µm), and ImageJ's `spacing=` between slices,
//!   make an axis-aligned geometry sidecar. TIFF says nothing of where the axes lie in a body:
//!   the sidecar's axes are the volume's own (origin at node 0), not RAS. A stack with no
//!   spacing, or no slice spacing, gets no sidecar and a note; `--spacing` gives one.
//! - ImageJ: a hyperstack converts when it holds one volume (slices, or frames of one slice);
//!   several channels, or frames of several slices, are refused. ImageJ's layout for stacks
//!   over 4 GiB (one page directory, `images=` slices one after another) is read too.
//! - Hostile sizes: before a page is decoded, its strips or tiles must lie inside the file and
//!   be able to hold the page, and each tile its tile (at most 1 byte a byte uncompressed, 64
//!   PackBits, 1032 Deflate, 3641 LZW): no page allocates more than its file's bytes can decode
//!   to. A page directory's tags are read under limits of the file's size (`directory_limits`;
//!   the first directory, which the `tiff` crate reads as it opens the file, is checked before:
//!   `page::first_directory`): a tag counting more values than the file holds is an error, not
//!   an allocation.

use crate::counted;
use crate::progress::{Progress, Unit};
use crate::volume::{Type, Volume};
use ::tiff::decoder::Decoder;
use ::tiff::tags::Tag;
use page::{decode_in, inspect, open, tiff_error, Page};
use std::io::{Read, Seek};
use std::path::{Path, PathBuf};

mod page;
#[cfg(test)]
mod tests;

type Res<T> = Result<T, String>;

/// `vlconvert tiff`'s arguments.
#[derive(clap::Args)]
pub struct Args {
    /// A multi-page TIFF (one z slice a page) or a folder of single-page TIFFs.
    input: PathBuf,
    output: PathBuf,
    /// Node spacing in millimetres (x, y, z), in place of what the files say.
    #[arg(long, num_args = 3, value_names = ["SX", "SY", "SZ"], allow_hyphen_values = true)]
    spacing: Vec<f64>,
    #[command(flatten)]
    window: super::Window,
}

/// Whether `head` (a file's first bytes) is a TIFF or BigTIFF, in either byte order.
pub fn is_tiff(head: &[u8]) -> bool {
    matches!(
        head.get(..4),
        Some(b"II*\0") | Some(b"MM\0*") | Some(b"II+\0") | Some(b"MM\0+")
    )
}

/// The stack read: its dimensions, element type and little-endian elements (x fastest, node
/// rows upwards), and what the files say of its spacing.
struct Stack {
    dims: [usize; 3],
    ty: Type,
    bytes: Vec<u8>,
    spacing: Spacing,
}

/// Spacing in millimetres where the files say it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Spacing {
    xy: Option<[f64; 2]>,
    z: Option<f64>,
}

/// Millimetres per unit of an ImageJ `unit=` name.
fn imagej_unit(name: &str) -> Option<f64> {
    Some(match name.trim() {
        "mm" | "millimeter" | "millimetre" | "millimeters" | "millimetres" => 1.0,
        "um" | "µm" | "μm" | "\\u00B5m" | "micron" | "microns" | "micrometer" | "micrometre" => {
            1e-3
        }
        "nm" | "nanometer" | "nanometre" => 1e-6,
        "cm" | "centimeter" | "centimetre" => 10.0,
        "m" | "meter" | "metre" => 1000.0,
        "inch" | "in" | "inches" => 25.4,
        _ => return None,
    })
}

/// ImageJ's `key=value` lines of a description that starts `ImageJ=`.
fn imagej_fields(description: &str) -> Option<Vec<(String, String)>> {
    if !description.starts_with("ImageJ=") {
        return None;
    }
    Some(
        description
            .lines()
            .filter_map(|l| l.split_once('='))
            .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
            .collect(),
    )
}

/// A positive finite number, or `None`.
fn positive(v: f64) -> Option<f64> {
    (v.is_finite() && v > 0.0).then_some(v)
}

/// A resolution tag's pixels per unit.
fn resolution<R: Read + Seek>(d: &mut Decoder<R>, tag: Tag) -> Option<f64> {
    use ::tiff::decoder::ifd::Value;
    let v = match d.find_tag(tag).ok()?? {
        Value::Rational(n, m) if m != 0 => n as f64 / m as f64,
        Value::Float(v) => v as f64,
        Value::Double(v) => v,
        Value::Short(v) => v as f64,
        Value::Unsigned(v) => v as f64,
        _ => return None,
    };
    positive(v)
}

/// The spacing the current page's tags give, with ImageJ's description fields (`ij`).
fn spacing_of<R: Read + Seek>(d: &mut Decoder<R>, ij: &[(String, String)]) -> Spacing {
    let field = |k: &str| ij.iter().find(|(n, _)| n == k).map(|(_, v)| v.as_str());
    let unit = match field("unit") {
        Some(u) => imagej_unit(u),
        None => match d
            .find_tag_unsigned::<u16>(Tag::ResolutionUnit)
            .ok()
            .flatten()
        {
            Some(2) => Some(25.4),
            Some(3) => Some(10.0),
            // tifffile's names beyond the standard's: millimetre, micrometre.
            Some(4) => Some(1.0),
            Some(5) => Some(1e-3),
            _ => None,
        },
    };
    let Some(mm) = unit else {
        return Spacing::default();
    };
    let xy = match (
        resolution(d, Tag::XResolution),
        resolution(d, Tag::YResolution),
    ) {
        (Some(x), Some(y)) => Some([mm / x, mm / y]),
        _ => None,
    };
    let z = field("spacing")
        .and_then(|s| s.parse::<f64>().ok())
        .and_then(positive)
        .map(|s| s * mm);
    Spacing { xy, z }
}

/// The description's ImageJ fields, if it is ImageJ's.
fn imagej<R: Read + Seek>(d: &mut Decoder<R>) -> Vec<(String, String)> {
    d.find_tag(Tag::ImageDescription)
        .ok()
        .flatten()
        .and_then(|v| v.into_string().ok())
        .and_then(|s| imagej_fields(&s))
        .unwrap_or_default()
}

/// Checks page `k` (from 1) against the first; `Err` names both.
fn same(first: &Page, page: &Page, k: usize) -> Res<()> {
    if page != first {
        return Err(format!(
            "page {k} has {}, page 1 {}: every slice must have the first one's size and type",
            page.describe(),
            first.describe()
        ));
    }
    Ok(())
}

/// Room for `n` bytes, or an error saying how many.
fn room(n: usize) -> Res<Vec<u8>> {
    let mut v = Vec::new();
    let memory = |_| format!("{} for the volume: not enough memory", counted(n, "byte"));
    v.try_reserve_exact(n).map_err(memory)?;
    Ok(v)
}

/// Reads the multi-page TIFF `path`, one z slice a page.
fn read_file(path: &Path) -> Res<Stack> {
    let at = |e: String| format!("{}: {e}", path.display());
    let (mut d, len) = open(path)?;
    let ij = imagej(&mut d);
    let spacing = spacing_of(&mut d, &ij);
    // Every page is checked before any is decoded.
    let mut pages: Vec<Page> = Vec::new();
    loop {
        let k = pages.len() + 1;
        let page = inspect(&mut d, len).map_err(|e| at(format!("page {k}: {e}")))?;
        if let Some(first) = pages.first() {
            same(first, &page, k).map_err(at)?;
        }
        pages.push(page);
        if !d.more_images() {
            break;
        }
        d.next_image()
            .map_err(|e| at(format!("page {}: {}", k + 1, tiff_error(e))))?;
    }
    let field = |k: &str| -> Option<usize> {
        ij.iter()
            .find(|(n, _)| n == k)
            .and_then(|(_, v)| v.parse().ok())
    };
    if let Some(c) = field("channels").filter(|&c| c > 1) {
        return Err(at(format!(
            "an ImageJ hyperstack of {c} channels: only one value a voxel converts (save each \
             channel on its own)"
        )));
    }
    if let (Some(z), Some(t)) = (field("slices"), field("frames")) {
        if z > 1 && t > 1 {
            return Err(at(format!(
                "an ImageJ hyperstack of {t} frames of {z} slices: only one volume converts \
                 (save each frame on its own)"
            )));
        }
    }
    if let Some(images) = field("images").filter(|&n| n != pages.len()) {
        if pages.len() == 1 && images > 1 {
            let (dims, ty, bytes) = contiguous(path, &mut d, &pages[0], images, len)?;
            return Ok(Stack {
                dims,
                ty,
                bytes,
                spacing,
            });
        }
        return Err(at(format!(
            "ImageJ's description says {images} images, the file has {} pages",
            pages.len()
        )));
    }
    let first = pages[0];
    let nz = pages.len();
    let total = first
        .bytes()?
        .checked_mul(nz)
        .ok_or_else(|| at("the volume's size overflows".into()))?;
    let mut bytes = room(total).map_err(at)?;
    let mut bar = Progress::new(file_name(path), nz as u64, Unit::Slices);
    d.seek_to_image(0).map_err(|e| at(tiff_error(e)))?;
    for (k, page) in pages.iter().enumerate() {
        if k > 0 {
            d.next_image()
                .map_err(|e| at(format!("page {}: {}", k + 1, tiff_error(e))))?;
        }
        let done;
        (d, done) = decode_in(d, page, &mut bytes, len);
        done.map_err(|e| at(format!("page {}: {e}", k + 1)))?;
        bar.advance(1);
    }
    bar.finish();
    Ok(Stack {
        dims: [first.width as usize, first.height as usize, nz],
        ty: first.ty,
        bytes,
        spacing,
    })
}

/// An ImageJ stack whose description counts `images` slices but whose file has one page
/// directory (`page`, the decoder's current one), as ImageJ writes stacks of more than 4 GiB:
/// the slices lie one after the other from the page's first strip, uncompressed. They must lie
/// inside the file (`len` bytes). Returns the dimensions, type and little-endian elements.
fn contiguous<R: Read + Seek>(
    path: &Path,
    d: &mut Decoder<R>,
    page: &Page,
    images: usize,
    len: u64,
) -> Res<([usize; 3], Type, Vec<u8>)> {
    use std::io::SeekFrom;
    let at = |e: String| format!("{}: {e}", path.display());
    let says = format!("ImageJ's description says {images} images in one page directory");
    let compression = d.find_tag_unsigned::<u16>(Tag::Compression).ok().flatten();
    if compression.unwrap_or(1) != 1 || page.format == 3 && page.bits == 16 {
        return Err(at(format!(
            "{says}, but its data is compressed or of 16-bit floats: not ImageJ's layout"
        )));
    }
    let list = |d: &mut Decoder<R>, tag| d.find_tag_unsigned_vec::<u64>(tag).ok().flatten();
    let (offsets, counts) = (
        list(d, Tag::StripOffsets).unwrap_or_default(),
        list(d, Tag::StripByteCounts).unwrap_or_default(),
    );
    let joined = offsets
        .windows(2)
        .zip(&counts)
        .all(|(o, &n)| o[0].checked_add(n) == Some(o[1]));
    let Some(&start) = offsets.first().filter(|_| joined) else {
        return Err(at(format!(
            "{says}, but its strips do not lie one after another"
        )));
    };
    let size = page.width as usize;
    let rows = page.height as usize;
    let bytes = page.ty.bytes();
    let slice = size * rows * bytes;
    let end = (slice as u64)
        .checked_mul(images as u64)
        .and_then(|n| n.checked_add(start))
        .filter(|&end| end <= len)
        .ok_or_else(|| {
            at(format!(
                "{says}: {images} slices of {} from byte {start} pass the end of the file ({})",
                counted(slice, "byte"),
                counted(len, "byte")
            ))
        })?;
    let total = (end - start) as usize;
    let mut out = room(total).map_err(at)?;
    let big = d.byte_order() == ::tiff::tags::ByteOrder::BigEndian;
    let file = d.inner();
    file.seek(SeekFrom::Start(start))
        .map_err(|e| at(e.to_string()))?;
    let mut bar = Progress::new(file_name(path), images as u64, Unit::Slices);
    let mut stored = vec![0u8; slice];
    for k in 0..images {
        file.read_exact(&mut stored)
            .map_err(|e| at(format!("slice {}: {e}", k + 1)))?;
        for row in stored.chunks_exact(size * bytes).rev() {
            for e in row.chunks_exact(bytes) {
                if big {
                    out.extend(e.iter().rev());
                } else {
                    out.extend_from_slice(e);
                }
            }
        }
        bar.advance(1);
    }
    bar.finish();
    Ok(([size, rows, images], page.ty, out))
}

/// The key of natural order: `name`'s runs of digits and of other characters, digits
/// compared as numbers (by the length of their digits after leading zeros, then the digits:
/// `slice_2` before `slice_10`, at any length); names equal so are ordered by their leading
/// zeros, fewer first.
type NaturalKey = (Vec<(bool, usize, String)>, Vec<usize>);

fn natural_key(name: &str) -> NaturalKey {
    let (mut runs, mut zeros) = (Vec::new(), Vec::new());
    let mut rest = name;
    while let Some(c) = rest.chars().next() {
        let digit = c.is_ascii_digit();
        let end = rest
            .find(|ch: char| ch.is_ascii_digit() != digit)
            .unwrap_or(rest.len());
        let (run, tail) = rest.split_at(end);
        if digit {
            let number = run.trim_start_matches('0');
            runs.push((true, number.len(), number.to_string()));
            zeros.push(run.len() - number.len());
        } else {
            runs.push((false, 0, run.to_string()));
        }
        rest = tail;
    }
    (runs, zeros)
}

/// The TIFF files of folder `dir` (`.tif`, `.tiff`, any case; not hidden), in natural order of
/// their names.
pub fn folder_files(dir: &Path) -> Res<Vec<PathBuf>> {
    let at = |e: std::io::Error| format!("{}: {e}", dir.display());
    let mut names: Vec<String> = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(at)? {
        let name = entry
            .map_err(at)?
            .file_name()
            .to_string_lossy()
            .into_owned();
        let lower = name.to_ascii_lowercase();
        if !name.starts_with('.') && (lower.ends_with(".tif") || lower.ends_with(".tiff")) {
            names.push(name);
        }
    }
    names.sort_by_cached_key(|n| natural_key(n));
    Ok(names.iter().map(|n| dir.join(n)).collect())
}

/// Reads the folder `dir` of single-page TIFFs, one z slice a file, in natural order.
fn read_folder(dir: &Path) -> Res<(Stack, Vec<PathBuf>)> {
    let files = folder_files(dir)?;
    if files.is_empty() {
        return Err(format!(
            "{}: no TIFF files (.tif, .tiff) in the folder",
            dir.display()
        ));
    }
    let mut bar = Progress::new(file_name(dir), files.len() as u64, Unit::Slices);
    let (mut first, mut spacing, mut bytes) = (None, Spacing::default(), Vec::new());
    for path in &files {
        let at = |e: String| format!("{}: {e}", path.display());
        let (mut d, len) = open(path)?;
        let page = inspect(&mut d, len).map_err(at)?;
        if d.more_images() {
            return Err(at(
                "more than one page: a folder's TIFFs must be single slices".into(),
            ));
        }
        match first {
            None => {
                let ij = imagej(&mut d);
                spacing = spacing_of(&mut d, &ij);
                let n = page.bytes()?.checked_mul(files.len());
                bytes = room(n.ok_or("the volume's size overflows")?).map_err(at)?;
                first = Some(page);
            }
            Some(f) if f != page => {
                return Err(at(format!(
                    "{}, {} {}: every slice must have the first one's size and type",
                    page.describe(),
                    file_name(&files[0]),
                    f.describe()
                )))
            }
            Some(_) => {}
        }
        decode_in(d, &page, &mut bytes, len).1.map_err(at)?;
        bar.advance(1);
    }
    bar.finish();
    let first = first.expect("at least one file");
    let stack = Stack {
        dims: [first.width as usize, first.height as usize, files.len()],
        ty: first.ty,
        bytes,
        spacing,
    };
    Ok((stack, files))
}

fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(
        || p.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// The geometry for `stack`: `--spacing` if given, else the files' spacing; `None`, with a
/// note, where they do not say it all.
fn geometry(stack: &Stack, given: &[f64], input: &Path) -> Res<Option<vlib::Geometry>> {
    let note = |what: String| eprintln!("vlconvert: note: {}: {what}", input.display());
    let s = match (given, stack.spacing) {
        ([x, y, z], _) => [*x, *y, *z],
        (
            _,
            Spacing {
                xy: Some([x, y]),
                z: Some(z),
            },
        ) => [x, y, z],
        // One page: the z spacing does not matter; 1 mm, as a 2D NRRD's unit normal.
        (
            _,
            Spacing {
                xy: Some([x, y]),
                z: None,
            },
        ) if stack.dims[2] == 1 => [x, y, 1.0],
        (
            _,
            Spacing {
                xy: Some([x, y]),
                z: None,
            },
        ) => {
            note(format!(
                "pixel spacing {x} x {y} mm, but no slice spacing (ImageJ's spacing=): no \
                 geometry sidecar (--spacing SX SY SZ gives one)"
            ));
            return Ok(None);
        }
        (_, Spacing { xy: None, .. }) => {
            note(
                "no pixel spacing in a known unit (X/YResolution with ResolutionUnit or \
                 ImageJ's unit=): no geometry sidecar (--spacing SX SY SZ gives one)"
                    .into(),
            );
            return Ok(None);
        }
    };
    let g = vlib::Geometry::axis_aligned(s, [0.0; 3])
        .map_err(|e| format!("spacing {s:?}: {}", e.message))?;
    note(
        "TIFF does not say how its axes lie in the body: the sidecar's axes are the stack's \
         own (x along the rows, y up the page, z from the first slice), not RAS"
            .into(),
    );
    Ok(Some(g))
}

/// `vlconvert tiff IN OUT`: converts the stack (file or folder) `args.input`.
pub fn convert(args: &Args) -> Res<()> {
    let v = read(&args.input, &args.spacing)?;
    super::convert(&v, &args.window, &args.output)
        .map_err(|e| format!("{}: {e}", args.input.display()))
}

/// Reads the stack (file or folder) `input`, placed by `spacing` (`--spacing`: none, or three
/// positive numbers) or else by what its files say; a folder's files are said in their order.
pub fn read(input: &Path, spacing: &[f64]) -> Res<Volume> {
    let (stack, files) = if input.is_dir() {
        let (s, f) = read_folder(input)?;
        (s, Some(f))
    } else {
        (read_file(input)?, None)
    };
    if let Some(files) = files {
        let names: Vec<String> = files.iter().map(|p| file_name(p)).collect();
        let shown = if names.len() <= 4 {
            names.join(", ")
        } else {
            format!("{}, {}, …, {}", names[0], names[1], names[names.len() - 1])
        };
        super::say(format_args!(
            "{} slices in natural order of their names (numbers as numbers): {shown}",
            names.len()
        ))?;
    }
    if !spacing.is_empty() && !spacing.iter().all(|&v| positive(v).is_some()) {
        return Err(format!("--spacing {spacing:?}: positive numbers"));
    }
    let geometry = geometry(&stack, spacing, input)?;
    Ok(Volume {
        dims: stack.dims,
        ty: stack.ty,
        bytes: stack.bytes,
        big: false,
        slope: 1.0,
        inter: 0.0,
        geometry,
    })
}

/// `vlconvert IN OUT` with a TIFF file or folder `input`.
pub fn convert_auto(input: &Path, output: &Path, window: &super::Window) -> Res<()> {
    convert(&Args {
        input: input.to_path_buf(),
        output: output.to_path_buf(),
        spacing: Vec::new(),
        window: window.clone(),
    })
}
