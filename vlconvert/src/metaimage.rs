//! MetaImage (ITK's MetaIO format): a text header of `Key = Value` lines, then the elements,
//! x fastest. In a `.mha` file the data follows the header (`ElementDataFile = LOCAL`); a `.mhd`
//! header names a data file beside it (`.raw`, `.zraw`). The header ends at its
//! `ElementDataFile` line.
//!
//! Read: `NDims` 2 or 3 (a 2D image is one slab; further dimensions only of size 1), `DimSize`,
//! `ElementType` (`MET_UCHAR` … `MET_DOUBLE`; `MET_LONG` and `MET_ULONG` are 4 bytes, as in
//! MetaIO's type table), `ElementByteOrderMSB` / `BinaryDataByteOrderMSB`, `CompressedData`
//! (zlib), `HeaderSize` (bytes to skip from the start of the data's file; −1: the data ends the
//! file) and `ElementNumberOfChannels` (only 1 converts). The placement, as ITK reads it:
//! `ElementSpacing` (mm; else `ElementSize`, as MetaIO does), `Offset` (or `Origin`,
//! `Position`: node 0's position) and `TransformMatrix` (or `Rotation`, `Orientation`: the
//! direction of each axis in turn, three numbers each) in ITK's LPS space, turned into RAS for
//! the sidecar; missing keys are ITK's defaults (spacing 1, offset 0, identity).
//! `AnatomicalOrientation` is ignored, as ITK ignores it. `ElementMin` / `ElementMax` and the
//! intensity functions are ignored too: ITK does not apply them.

use crate::progress::{Progress, Reading, Unit};
use crate::volume::{Type, Volume};
use std::io::Read;
use std::path::{Path, PathBuf};

type Res<T> = Result<T, String>;

/// Where the elements are.
enum DataFile {
    /// After the header, in the header's file.
    Local,
    /// In this file.
    Path(PathBuf),
}

/// What the header says of the elements.
struct Header {
    dims: [usize; 3],
    /// `NDims` (2 or more; dimensions beyond the third are of size 1).
    ndims: usize,
    ty: Type,
    big: bool,
    compressed: bool,
    /// `HeaderSize`: `Some(n)`, n ≥ 0, bytes to skip from the start of the data's file;
    /// `Some(-1)`, the data ends the file; `None`, the data starts after the header (a `.mha`)
    /// or at the start of the data file.
    skip: Option<i64>,
    file: DataFile,
    /// The byte after the header's last line, in the header's file.
    end: usize,
    /// The placement keys' values: `ElementSpacing` (else `ElementSize`, as MetaIO reads it),
    /// `Offset`, `TransformMatrix`.
    spacing: Option<String>,
    offset: Option<String>,
    matrix: Option<String>,
}

fn boolean(key: &str, v: &str) -> Res<bool> {
    match v.to_ascii_lowercase().as_str() {
        "true" | "t" | "1" => Ok(true),
        "false" | "f" | "0" => Ok(false),
        _ => Err(format!("{key} = {v}: True or False expected")),
    }
}

fn element_type(v: &str) -> Res<Type> {
    Ok(match v {
        "MET_UCHAR" => Type::U8,
        "MET_CHAR" => Type::I8,
        "MET_USHORT" => Type::U16,
        "MET_SHORT" => Type::I16,
        "MET_UINT" | "MET_ULONG" => Type::U32,
        "MET_INT" | "MET_LONG" => Type::I32,
        "MET_ULONG_LONG" => Type::U64,
        "MET_LONG_LONG" => Type::I64,
        "MET_FLOAT" => Type::F32,
        "MET_DOUBLE" => Type::F64,
        other => {
            return Err(format!(
                "ElementType = {other} does not convert (MET_UCHAR, MET_CHAR, MET_USHORT, \
                 MET_SHORT, MET_UINT, MET_INT, MET_ULONG, MET_LONG, MET_ULONG_LONG, \
                 MET_LONG_LONG, MET_FLOAT or MET_DOUBLE)"
            ))
        }
    })
}

/// Parses the header at the start of `text` (the header file's bytes); `dir` is the header's
/// directory, which a data file name is relative to.
fn parse(text: &[u8], dir: &Path) -> Res<Header> {
    let (mut ndims, mut dimsize, mut ty, mut file) = (None, None, None, None);
    let (mut big, mut compressed, mut skip) = (false, false, None);
    let (mut spacing, mut offset, mut matrix) = (None, None, None);
    let mut size = None;
    let mut start = 0;
    let mut number = 0;
    while file.is_none() {
        if start >= text.len() {
            return Err(if number == 0 {
                "empty: not a MetaImage header".into()
            } else {
                "no ElementDataFile line (the line that ends a MetaImage header)".into()
            });
        }
        number += 1;
        let nl = text[start..].iter().position(|&b| b == b'\n');
        let stop = nl.map_or(text.len(), |p| start + p);
        let raw = &text[start..stop];
        start = nl.map_or(text.len(), |_| stop + 1);
        let line = std::str::from_utf8(raw)
            .map_err(|_| format!("line {number} is not text: not a MetaImage header"))?
            .trim();
        if line.is_empty() {
            continue;
        }
        let (key, value) = line
            .split_once('=')
            .map(|(k, v)| (k.trim(), v.trim()))
            .ok_or_else(|| format!("line {number} is not `Key = Value`: not a MetaImage header"))?;
        let at = |e: String| format!("line {number}: {e}");
        match key {
            "ObjectType" if value != "Image" => {
                return Err(at(format!("ObjectType = {value}: only an Image converts")))
            }
            "NDims" => {
                ndims = Some(
                    value
                        .parse::<usize>()
                        .ok()
                        .filter(|&n| n >= 2)
                        .ok_or_else(|| at(format!("NDims = {value}: 2 or more expected")))?,
                )
            }
            "DimSize" => {
                let sizes: Option<Vec<usize>> = value
                    .split_whitespace()
                    .map(|w| w.parse().ok().filter(|&d| d > 0))
                    .collect();
                dimsize = Some(sizes.ok_or_else(|| {
                    at(format!(
                        "DimSize = {value}: positive whole numbers expected"
                    ))
                })?);
            }
            "ElementType" => ty = Some(element_type(value).map_err(at)?),
            "ElementNumberOfChannels" if value.parse::<u64>().ok() != Some(1) => {
                return Err(at(format!(
                    "ElementNumberOfChannels = {value}: only images of one channel convert"
                )))
            }
            "BinaryData" if !boolean(key, value).map_err(at)? => {
                return Err(at(
                    "BinaryData = False (elements as text) does not convert".into()
                ))
            }
            "ElementByteOrderMSB" | "BinaryDataByteOrderMSB" => {
                big = boolean(key, value).map_err(at)?
            }
            "CompressedData" => compressed = boolean(key, value).map_err(at)?,
            "ElementSpacing" => spacing = Some(value.to_string()),
            "ElementSize" => size = Some(value.to_string()),
            "Offset" | "Origin" | "Position" => offset = Some(value.to_string()),
            "TransformMatrix" | "Rotation" | "Orientation" => matrix = Some(value.to_string()),
            "HeaderSize" => {
                skip = Some(
                    value
                        .parse::<i64>()
                        .ok()
                        .filter(|&n| n >= -1)
                        .ok_or_else(|| {
                            at(format!(
                                "HeaderSize = {value}: a size in bytes or -1 expected"
                            ))
                        })?,
                )
            }
            "ElementDataFile" => {
                file = Some(if value.eq_ignore_ascii_case("LOCAL") {
                    DataFile::Local
                } else if value.starts_with("LIST") || value.contains('%') {
                    return Err(at(format!(
                        "ElementDataFile = {value}: data in a list or series of files does \
                         not convert (only LOCAL or one file)"
                    )));
                } else if value.is_empty() {
                    return Err(at("ElementDataFile is empty".into()));
                } else {
                    DataFile::Path(dir.join(value))
                })
            }
            _ => {}
        }
    }
    let ndims = ndims.ok_or("no NDims")?;
    let dimsize = dimsize.ok_or("no DimSize")?;
    if dimsize.len() != ndims {
        return Err(format!(
            "DimSize has {} sizes, NDims = {ndims}",
            dimsize.len()
        ));
    }
    if dimsize[3.min(ndims)..].iter().any(|&d| d != 1) {
        return Err(format!(
            "a {ndims}-dimensional image {dimsize:?}: only 2D and 3D images convert"
        ));
    }
    let dims = [dimsize[0], dimsize[1], *dimsize.get(2).unwrap_or(&1)];
    Ok(Header {
        dims,
        ndims,
        ty: ty.ok_or("no ElementType")?,
        big,
        compressed,
        skip,
        file: file.expect("the loop ends at ElementDataFile"),
        end: start,
        spacing: spacing.or(size),
        offset,
        matrix,
    })
}

/// `n` numbers from the value of `key`, or `default` when the key is missing.
fn numbers(key: &str, value: Option<&str>, n: usize, default: &[f64]) -> Res<Vec<f64>> {
    let Some(v) = value else {
        return Ok(default.to_vec());
    };
    let got: Option<Vec<f64>> = v
        .split_whitespace()
        .map(|w| w.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect();
    match got {
        Some(g) if g.len() >= n => Ok(g[..n].to_vec()),
        _ => Err(format!("{key} = {v}: {n} finite numbers expected")),
    }
}

/// The RAS placement of the header's image: node (i, j, k) at offset + Σ spacing·index·direction
/// in LPS (ITK's reading), with x and y negated for RAS. A 2D image's third axis is its plane's
/// normal, 1 mm long.
fn geometry(h: &Header) -> Res<vlib::Geometry> {
    let n = h.ndims;
    if n > 3 {
        return Err(format!(
            "the placement of a {n}-dimensional header is not read"
        ));
    }
    let spacing = numbers("ElementSpacing", h.spacing.as_deref(), n, &[1.0; 3][..n])?;
    let offset = numbers("Offset", h.offset.as_deref(), n, &[0.0; 3][..n])?;
    let identity: Vec<f64> = (0..n * n)
        .map(|i| if i / n == i % n { 1.0 } else { 0.0 })
        .collect();
    let m = numbers("TransformMatrix", h.matrix.as_deref(), n * n, &identity)?;
    // axis a's direction: m[a·n .. a·n + n] (ITK's MetaImageIO), padded to 3D.
    let mut dir = [[0.0f64; 3]; 3];
    for (a, d) in dir.iter_mut().enumerate().take(n) {
        d[..n].copy_from_slice(&m[a * n..a * n + n]);
    }
    let mut origin = [0.0f64; 3];
    origin[..n].copy_from_slice(&offset);
    let mut step = [1.0f64; 3];
    step[..n].copy_from_slice(&spacing);
    if n == 2 {
        dir[2] = crate::vector::unit_normal(dir[0], dir[1])
            .ok_or("TransformMatrix: the image's two axes are parallel")?;
    }
    let ras = [-1.0, -1.0, 1.0];
    let row = |r: usize| {
        [
            dir[0][r] * step[0] * ras[r],
            dir[1][r] * step[1] * ras[r],
            dir[2][r] * step[2] * ras[r],
            origin[r] * ras[r],
        ]
        .map(|v| v + 0.0) // no "-0" in the sidecar
    };
    vlib::Geometry::new([row(0), row(1), row(2)]).map_err(|e| e.message)
}

/// The header's elements, `need` bytes of them, from `bytes` (the data's file, `name`), where
/// they start at `from` unless `HeaderSize` says otherwise.
fn elements(h: &Header, bytes: &[u8], from: usize, need: usize, name: &Path) -> Res<Vec<u8>> {
    let len = bytes.len();
    let label = format!(
        "decompressing {}",
        name.file_name().unwrap_or_default().to_string_lossy()
    );
    let name = name.display();
    let from = match h.skip {
        Some(-1) if h.compressed => {
            return Err(
                "HeaderSize = -1 with compressed data: where the data starts is \
                        unknown"
                    .into(),
            )
        }
        Some(-1) => len.checked_sub(need).ok_or_else(|| {
            format!(
                "{name}: {}, but {need} are needed for the data that ends it",
                crate::counted(len, "byte")
            )
        })?,
        Some(n) if n > 0 => usize::try_from(n).unwrap_or(usize::MAX),
        _ => from,
    };
    let data = bytes.get(from..).ok_or_else(|| {
        format!(
            "{name}: {}, but the data starts at byte {from}",
            crate::counted(len, "byte")
        )
    })?;
    let what = format!("{:?} x {:?}", h.dims, h.ty);
    let out = if h.compressed {
        let mut out = Vec::new();
        let bar = Progress::new(label, need as u64, Unit::Bytes);
        Reading::new(
            flate2::read::ZlibDecoder::new(data).take(need as u64 + 1),
            bar,
        )
        .read_to_end(&mut out)
        .map_err(|e| format!("{name}: compressed data from byte {from}: {e}"))?;
        if out.len() < need {
            return Err(format!(
                "{name}: the data decompresses to {}, but {need} are needed for {what}",
                crate::counted(out.len(), "byte")
            ));
        }
        if out.len() > need {
            eprintln!("vlconvert: note: {name}: more data decompressed than {what} (ignored)");
        }
        out.truncate(need);
        out
    } else {
        if data.len() < need {
            return Err(format!(
                "{name}: {} of data from byte {from}, but {need} are needed for {what}",
                crate::counted(data.len(), "byte")
            ));
        }
        if data.len() > need {
            eprintln!(
                "vlconvert: note: {name} has {} after the data (ignored)",
                crate::counted(data.len() - need, "byte")
            );
        }
        data[..need].to_vec()
    };
    Ok(out)
}

/// Converts the MetaImage `input` (`.mha`, or `.mhd` with its data file) to `output`.
pub fn convert(input: &Path, output: &Path, window: &super::Window) -> Res<()> {
    let v = read(input)?;
    super::convert(&v, window, output).map_err(|e| format!("{}: {e}", input.display()))
}

/// Reads the MetaImage `input` (`.mha`, or `.mhd` with its data file).
pub fn read(input: &Path) -> Res<Volume> {
    let at = |e: String| format!("{}: {e}", input.display());
    let text = crate::volume::read_regular(input, None).map_err(at)?;
    let dir = input.parent().unwrap_or(Path::new(""));
    let h = parse(&text, dir).map_err(at)?;
    let need = h
        .dims
        .iter()
        .try_fold(h.ty.bytes() as u64, |a, &d| a.checked_mul(d as u64))
        .and_then(|n| usize::try_from(n).ok())
        .ok_or_else(|| at(format!("DimSize {:?}: too large", h.dims)))?;
    let data = match &h.file {
        DataFile::Local => elements(&h, &text, h.end, need, input)?,
        DataFile::Path(p) => {
            let bytes = crate::volume::read_regular(p, None)?;
            elements(&h, &bytes, 0, need, p)?
        }
    };
    let placement = match geometry(&h) {
        Ok(g) => Some(g),
        Err(e) => {
            eprintln!("vlconvert: note: {}: no placement: {e}", input.display());
            None
        }
    };
    Ok(Volume {
        dims: h.dims,
        bytes: data,
        ty: h.ty,
        big: h.big,
        slope: 1.0,
        inter: 0.0,
        geometry: placement,
    })
}
