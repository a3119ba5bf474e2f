//! NRRD (`.nrrd`, or a detached `.nhdr` header with its data file): the header's fields that
//! decide the values — `type`, `dimension`, `sizes`, `endian`, `encoding` (`raw`, `gzip`,
//! `ascii`), `data file`, `line skip`, `byte skip` — read as the format's specification
//! (teem.sourceforge.net/nrrd/format.html) defines them, with the spellings of every type it
//! allows. A 2D image converts as one slab. The geometry comes from `space`, `space
//! directions` (one vector an axis) and `space origin` (turned into RAS; LPS, LAS and RAS
//! spaces), or from `spacings` alone; directions of another count, or without a `space`, are
//! no placement, with a note. Other encodings (`bzip2`, `hex`), detached data lists (`LIST`, `%d`
//! patterns) and more than one value per voxel are refused by name.
//!
//! Ascii values are kept as written: an integer type takes whole numbers in its range only,
//! `float` no finite number beyond its range, and the first value that breaks this is refused by
//! value and index; `byte skip` skips bytes of the text (as teem reads it), −1 raw data only.
//! Data after the volume's (raw or gzip bytes, ascii values) is ignored with a note, and a gzip
//! stream is read to its end (`gunzip`), so that its checksums are checked; bytes after its
//! last member are a note too.

use crate::gunzip::Gunzip;
use crate::progress::{Progress, Reading, Unit};
use crate::volume::{inflate_rest, read_regular, Type, Volume};
use std::path::{Path, PathBuf};

/// The file name of `path`, for a progress line.
fn name(path: &Path) -> String {
    path.file_name()
        .unwrap_or_default()
        .to_string_lossy()
        .into_owned()
}

/// Whether `bytes` (a file's start) is a NRRD header.
pub fn is_nrrd(bytes: &[u8]) -> bool {
    bytes.starts_with(b"NRRD000")
}

/// The element type a NRRD `type` field names (all the specification's spellings).
fn type_of(name: &str) -> Option<Type> {
    let t = match name {
        "signed char" | "int8" | "int8_t" => Type::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => Type::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            Type::I16
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => Type::U16,
        "int" | "signed int" | "int32" | "int32_t" => Type::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => Type::U32,
        "longlong"
        | "long long"
        | "long long int"
        | "signed long long"
        | "signed long long int"
        | "int64"
        | "int64_t" => Type::I64,
        "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => {
            Type::U64
        }
        "float" => Type::F32,
        "double" => Type::F64,
        _ => return None,
    };
    Some(t)
}

/// The numbers of a NRRD vector `(x,y,z)`; `None` for `none` or a malformed one.
fn vector(v: &str) -> Option<Vec<f64>> {
    let inner = v.trim().strip_prefix('(')?.strip_suffix(')')?;
    inner.split(',').map(|n| n.trim().parse().ok()).collect()
}

/// The geometry a header's fields give (`field` looks one up) to an array of `axes` axes (2 or
/// 3), in RAS millimetres: `space directions` (one vector an axis) in a named `space`, or
/// `spacings`.
fn geometry(
    field: &dyn Fn(&[&str]) -> Option<String>,
    axes: usize,
) -> Result<Option<vlib::Geometry>, String> {
    // RAS from the space's own axes: flip the ones that point left or posterior.
    let flip = match field(&["space"]).as_deref() {
        Some("right-anterior-superior" | "RAS") => Some([1.0, 1.0, 1.0]),
        Some("left-anterior-superior" | "LAS") => Some([-1.0, 1.0, 1.0]),
        Some("left-posterior-superior" | "LPS") => Some([-1.0, -1.0, 1.0]),
        Some(other) => return Err(format!("space {other:?}: only RAS, LAS and LPS convert")),
        None => None,
    };
    if let (None, Some(_)) = (flip, field(&["space directions"])) {
        let said = field(&["space dimension"]).map_or(String::new(), |n| {
            format!(" (space dimension {n} names no orientation in the body)")
        });
        return Err(format!(
            "space directions without a space field{said}: only RAS, LAS and LPS spaces convert"
        ));
    }
    if let (Some(flip), Some(dirs)) = (flip, field(&["space directions"])) {
        let cols: Vec<Vec<f64>> = dirs
            .split_whitespace()
            .map(|d| vector(d).filter(|v| v.len() == 3))
            .collect::<Option<_>>()
            .ok_or_else(|| format!("space directions {dirs:?}"))?;
        let origin = match field(&["space origin"]) {
            Some(o) => vector(&o)
                .filter(|v| v.len() == 3)
                .ok_or_else(|| format!("space origin {o:?}"))?,
            None => vec![0.0; 3],
        };
        if cols.len() != axes {
            return Err(format!(
                "space directions {dirs:?}: {} vectors for {axes} axes (one an axis)",
                cols.len()
            ));
        }
        // A 2D image's third axis: the unit normal of its plane.
        // (Parallel directions give a zero axis, which the placement refuses as degenerate.)
        let normal = if cols.len() == 2 {
            let v = |c: &[f64]| [c[0], c[1], c[2]];
            crate::vector::unit_normal(v(&cols[0]), v(&cols[1])).unwrap_or([0.0; 3])
        } else {
            [0.0; 3]
        };
        let col = |c: usize, r: usize| cols.get(c).map_or(normal[r], |v| v[r]);
        let row = |r: usize| [col(0, r), col(1, r), col(2, r), origin[r]].map(|v| v * flip[r]);
        return vlib::Geometry::new([row(0), row(1), row(2)])
            .map(Some)
            .map_err(|e| e.message);
    }
    if let Some(sp) = field(&["spacings"]) {
        let s: Vec<f64> = sp
            .split_whitespace()
            .map(|v| if v == "nan" { Ok(1.0) } else { v.parse() })
            .collect::<Result<_, _>>()
            .map_err(|_| format!("spacings {sp:?}"))?;
        let s = [s.first(), s.get(1), s.get(2)].map(|v| v.copied().unwrap_or(1.0));
        return vlib::Geometry::axis_aligned(s, [0.0; 3])
            .map(Some)
            .map_err(|e| e.message);
    }
    Ok(None)
}

/// Reads the NRRD file `path`: its volume, unscaled, placed where the header says.
pub fn read(path: &Path) -> Result<Volume, String> {
    let file = read_regular(path, None)?;
    if !is_nrrd(&file) {
        return Err(format!(
            "{}: not a NRRD file (no NRRD000x magic)",
            path.display()
        ));
    }
    // The header: lines up to the first empty one (or the end, for a detached header).
    let mut fields: Vec<(String, String)> = Vec::new();
    let mut at = 0;
    let mut first = true;
    let header_end = loop {
        let Some(nl) = file[at..].iter().position(|&b| b == b'\n') else {
            break file.len();
        };
        let line = String::from_utf8_lossy(&file[at..at + nl]);
        let line = line.trim_end_matches('\r');
        at += nl + 1;
        if first {
            first = false;
            continue; // the magic
        }
        if line.is_empty() {
            break at;
        }
        if line.starts_with('#') || line.contains(":=") {
            continue; // comments and key/value pairs
        }
        let (key, value) = line
            .split_once(": ")
            .ok_or_else(|| format!("{}: malformed header line {line:?}", path.display()))?;
        fields.push((key.trim().to_ascii_lowercase(), value.trim().to_string()));
    };
    let field = |names: &[&str]| {
        fields
            .iter()
            .find(|(k, _)| names.contains(&k.as_str()))
            .map(|(_, v)| v.as_str())
    };
    let bad = |what: String| format!("{}: {what}", path.display());
    let ty_name = field(&["type"]).ok_or_else(|| bad("no type field".into()))?;
    let ty = type_of(ty_name).ok_or_else(|| bad(format!("type {ty_name:?} does not convert")))?;
    let dimension: usize = field(&["dimension"])
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| bad("no or a malformed dimension field".into()))?;
    let sizes: Vec<usize> = field(&["sizes"])
        .ok_or_else(|| bad("no sizes field".into()))?
        .split_whitespace()
        .map(|v| v.parse().map_err(|_| bad(format!("size {v:?}"))))
        .collect::<Result<_, _>>()?;
    if sizes.len() != dimension {
        return Err(bad(format!(
            "dimension {dimension} but {} sizes",
            sizes.len()
        )));
    }
    // One value per voxel: every axis a domain (space or time) axis.
    if let Some(kinds) = field(&["kinds"]) {
        let ok = ["domain", "space", "time", "none", "???"];
        if let Some(k) = kinds.split_whitespace().find(|k| !ok.contains(k)) {
            return Err(bad(format!(
                "kinds {kinds:?}: an axis of kind {k} (more than one value per voxel) does not \
                 convert"
            )));
        }
    }
    let dims = match sizes.as_slice() {
        [x, y, z] => [*x, *y, *z],
        [x, y] => [*x, *y, 1],
        _ => {
            return Err(bad(format!(
                "a {dimension}-dimensional array {sizes:?}: only 2D and 3D volumes of one \
                 value per voxel convert"
            )))
        }
    };
    if dims.contains(&0) {
        return Err(bad(format!("sizes {sizes:?}: every size must be positive")));
    }
    // A placement that cannot be made is said, and the volume converts without one.
    let axes = sizes.len();
    let geometry = geometry(&|names: &[&str]| field(names).map(str::to_string), axes)
        .unwrap_or_else(|e| {
            eprintln!("vlconvert: note: {}: no placement: {e}", path.display());
            None
        });
    let big = match field(&["endian"]) {
        Some("big") => true,
        Some("little") | None => false,
        Some(e) => return Err(bad(format!("endian {e:?}"))),
    };
    let encoding = field(&["encoding"]).ok_or_else(|| bad("no encoding field".into()))?;
    let number = |names: &[&str]| -> Result<i64, String> {
        field(names)
            .map(|v| v.parse().map_err(|_| bad(format!("{} {v:?}", names[0]))))
            .unwrap_or(Ok(0))
    };
    let line_skip = number(&["line skip", "lineskip"])?;
    let byte_skip = number(&["byte skip", "byteskip"])?;
    // The data: after the header, or in the detached data file (relative to the header).
    let (data, data_path): (Vec<u8>, PathBuf) = match field(&["data file", "datafile"]) {
        Some(name) if name.starts_with("LIST") || name.contains('%') => {
            return Err(bad(format!(
                "data file {name:?}: lists of files do not convert"
            )))
        }
        Some(name) => {
            let p = Path::new(name);
            let p: PathBuf = if p.is_relative() {
                path.parent().unwrap_or(Path::new(".")).join(p)
            } else {
                p.to_path_buf()
            };
            (read_regular(&p, None)?, p)
        }
        None => (file[header_end..].to_vec(), path.to_path_buf()),
    };
    // Line skip, then byte skip (−1: the data is the file's last bytes, raw only).
    let mut data = data.as_slice();
    for _ in 0..line_skip.max(0) {
        match data.iter().position(|&b| b == b'\n') {
            Some(nl) => data = &data[nl + 1..],
            None => return Err(bad("line skip past the end of the data".into())),
        }
    }
    let n = dims
        .iter()
        .try_fold(1usize, |a, &d| a.checked_mul(d))
        .ok_or_else(|| bad(format!("sizes {sizes:?} overflow")))?;
    let need = n
        .checked_mul(ty.bytes())
        .ok_or_else(|| bad("sizes overflow".into()))?;
    if byte_skip < -1 {
        return Err(bad(format!("byte skip {byte_skip}: at least -1")));
    }
    if byte_skip == -1 && encoding != "raw" {
        return Err(bad(format!(
            "byte skip -1 with {encoding} encoding: the data ending the file is for raw \
             encoding only"
        )));
    }
    let skip = byte_skip.max(0) as u64;
    // The volume's bytes from `data` (after the byte skip), and how many follow them.
    let raw = |data: &[u8]| -> Result<(Vec<u8>, u64), String> {
        let data = if byte_skip == -1 {
            data.get(data.len().saturating_sub(need)..).unwrap_or(data)
        } else {
            data.get(skip as usize..).unwrap_or(&[])
        };
        if data.len() < need {
            return Err(bad(format!(
                "{} of data, {need} needed for {dims:?} of {ty_name}",
                crate::counted(data.len(), "byte")
            )));
        }
        Ok((data[..need].to_vec(), (data.len() - need) as u64))
    };
    // The volume's bytes, their byte order, and what follows them (a count and its noun, in
    // the singular).
    let (bytes, big, extra) = match encoding {
        "raw" => {
            let (bytes, extra) = raw(data)?;
            (bytes, big, (extra, "byte"))
        }
        "gzip" | "gz" => {
            let mut out = Vec::new();
            // Byte skip counts bytes of the decompressed data. The stream is read to its end
            // (its checksums checked), what follows the volume counted, not kept.
            let keep = need as u64 + skip;
            let bar = Progress::new(format!("decompressing {}", name(path)), keep, Unit::Bytes);
            let mut gz = Gunzip::new(data);
            let after = inflate_rest(&mut Reading::new(&mut gz, bar), &mut out, keep);
            let after = after.map_err(bad)?;
            if gz.trailing() > 0 {
                eprintln!(
                    "vlconvert: note: {} has {} after its gzip stream (ignored)",
                    data_path.display(),
                    crate::counted(gz.trailing(), "byte")
                );
            }
            let (bytes, _) = raw(&out)?;
            (bytes, big, (after, "byte"))
        }
        "ascii" | "text" | "txt" => {
            // Byte skip counts bytes of the text, as teem reads it.
            let text = data.get(skip as usize..).ok_or_else(|| {
                bad(format!(
                    "byte skip {skip} is past the end of the data ({})",
                    crate::counted(data.len(), "byte")
                ))
            })?;
            let (bytes, extra) =
                ascii(&String::from_utf8_lossy(text), ty, ty_name, n).map_err(bad)?;
            (bytes, false, (extra as u64, "ascii value"))
        }
        e => {
            return Err(bad(format!(
                "encoding {e:?} does not convert (raw, gzip, ascii do)"
            )))
        }
    };
    if let (count @ 1.., what) = extra {
        eprintln!(
            "vlconvert: note: {} has {} after the data (ignored)",
            data_path.display(),
            crate::counted(count, what)
        );
    }
    Ok(Volume {
        dims,
        ty,
        big,
        bytes,
        slope: 1.0,
        inter: 0.0,
        geometry,
    })
}

/// The first `n` whitespace-separated values of `text` as elements of `ty` (the NRRD type
/// `ty_name`), little-endian, and how many values follow them. Nothing is altered: an integer
/// type takes whole numbers in its range only, `float` no finite number beyond its range;
/// the first value that breaks this is an error naming it and its index.
fn ascii(text: &str, ty: Type, ty_name: &str, n: usize) -> Result<(Vec<u8>, usize), String> {
    let mut out = Vec::with_capacity(n.min(text.len() / 2 + 1) * ty.bytes());
    let mut words = text.split_whitespace();
    for (i, word) in words.by_ref().take(n).enumerate() {
        let offence =
            |why: String| format!("ascii value {word:?} (value {i}, counting from 0): {why}");
        let number = || {
            word.parse::<f64>()
                .map_err(|_| offence("not a number".into()))
        };
        match ty.int_range() {
            Some((min, max)) => {
                let v = match word.parse::<i128>() {
                    Ok(v) => v,
                    Err(_) => {
                        let f = number()?;
                        if !f.is_finite() || f.fract() != 0.0 {
                            return Err(offence(format!(
                                "not a whole number, and {ty_name} holds whole numbers only"
                            )));
                        }
                        f as i128
                    }
                };
                if v < min || v > max {
                    return Err(offence(format!(
                        "outside the range of {ty_name}, {min} … {max}"
                    )));
                }
                ty.push_int_le(v, &mut out);
            }
            None if ty == Type::F32 => {
                let f = number()?;
                if f.is_finite() && !(f as f32).is_finite() {
                    return Err(offence(format!("beyond the range of {ty_name}")));
                }
                out.extend((f as f32).to_le_bytes());
            }
            None => out.extend(number()?.to_le_bytes()),
        }
    }
    if out.len() < n * ty.bytes() {
        return Err(format!(
            "{} ascii values, {n} needed",
            out.len() / ty.bytes()
        ));
    }
    Ok((out, words.count()))
}
