//! A volume read from a file as its values of one element type (raw bytes, the type, the byte
//! order, the header's linear scaling), and how it becomes a `.vlb` dataset: which voxel width,
//! which voxels, and which a and b, so that the dataset's normalised value at a node is
//! clamp((value − A)/(B − A), 0, 1) for the window A … B (the data's full range unless given).
//!
//! - 8-bit sources (uint8, int8) keep their values exactly in 8-bit voxels, 16-bit ones (uint16,
//!   int16) in 16-bit voxels (int8 and int16 offset by 128 and 32768), whatever their scaling:
//!   the scaling is linear, so a and b absorb it.
//! - Wider integers and floats are quantised to 16 bits over their range: the voxel is the
//!   nearest of 0 … 65535 to (value − min)/(max − min)·65535, within half a quantum.
//! - Values that are not finite (NaN, ±∞ in a float file, or a finite value the scaling takes
//!   past f64's range) are counted and said in a note: +∞ takes the largest finite value, −∞
//!   and NaN the smallest. A range wider than f64 can subtract (−1e308 … 1e308) is measured in
//!   halves, so it quantises like any other.
//!
//! Files are opened by [`open_regular`], which refuses a FIFO, a device or a directory without
//! waiting. Reading a whole file ([`read_regular`]), decompressing a gzip stream to its end
//! ([`inflate_rest`]) and converting its voxels (two passes: the range, then the voxels) show
//! their progress on a terminal (`progress`).

use crate::progress::{Progress, Reading, Unit};
use clap::ValueEnum;
use std::io::Read;
use std::path::Path;

/// Elements converted between two looks at the progress line.
const BLOCK: usize = 1 << 20;

/// `f(0) … f(n − 1)`, advancing `bar` by each block of [`BLOCK`] elements.
fn collect<T>(n: usize, bar: &mut Progress, f: impl Fn(usize) -> T) -> Vec<T> {
    let mut out = Vec::with_capacity(n);
    for start in (0..n).step_by(BLOCK) {
        let end = (start + BLOCK).min(n);
        out.extend((start..end).map(&f));
        bar.advance((end - start) as u64);
    }
    out
}

/// The element types of a source volume.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Type {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    U64,
    I64,
    F32,
    F64,
}

impl Type {
    /// Bytes per element.
    pub fn bytes(self) -> usize {
        match self {
            Type::U8 | Type::I8 => 1,
            Type::U16 | Type::I16 => 2,
            Type::U32 | Type::I32 | Type::F32 => 4,
            Type::U64 | Type::I64 | Type::F64 => 8,
        }
    }

    /// The element at the start of `b` (at least [`Type::bytes`] long) as f64.
    fn read(self, b: &[u8], big: bool) -> f64 {
        macro_rules! num {
            ($t:ty, $n:expr) => {{
                let a: [u8; $n] = b[..$n].try_into().expect("element bytes");
                (if big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }) as f64
            }};
        }
        match self {
            Type::U8 => b[0] as f64,
            Type::I8 => b[0] as i8 as f64,
            Type::U16 => num!(u16, 2),
            Type::I16 => num!(i16, 2),
            Type::U32 => num!(u32, 4),
            Type::I32 => num!(i32, 4),
            Type::U64 => num!(u64, 8),
            Type::I64 => num!(i64, 8),
            Type::F32 => num!(f32, 4),
            Type::F64 => num!(f64, 8),
        }
    }

    /// Appends `v` as an element of this type, little-endian (integers saturate, as `as` does).
    pub fn push_le(self, v: f64, out: &mut Vec<u8>) {
        match self {
            Type::U8 => out.push(v as u8),
            Type::I8 => out.push(v as i8 as u8),
            Type::U16 => out.extend((v as u16).to_le_bytes()),
            Type::I16 => out.extend((v as i16).to_le_bytes()),
            Type::U32 => out.extend((v as u32).to_le_bytes()),
            Type::I32 => out.extend((v as i32).to_le_bytes()),
            Type::U64 => out.extend((v as u64).to_le_bytes()),
            Type::I64 => out.extend((v as i64).to_le_bytes()),
            Type::F32 => out.extend((v as f32).to_le_bytes()),
            Type::F64 => out.extend(v.to_le_bytes()),
        }
    }

    /// The smallest and largest value of an integer type; `None` for a float type.
    pub fn int_range(self) -> Option<(i128, i128)> {
        Some(match self {
            Type::U8 => (0, u8::MAX as i128),
            Type::I8 => (i8::MIN as i128, i8::MAX as i128),
            Type::U16 => (0, u16::MAX as i128),
            Type::I16 => (i16::MIN as i128, i16::MAX as i128),
            Type::U32 => (0, u32::MAX as i128),
            Type::I32 => (i32::MIN as i128, i32::MAX as i128),
            Type::U64 => (0, u64::MAX as i128),
            Type::I64 => (i64::MIN as i128, i64::MAX as i128),
            Type::F32 | Type::F64 => return None,
        })
    }

    /// Appends the integer `v`, which [`Type::int_range`] holds, as an element of this integer
    /// type, little-endian.
    pub fn push_int_le(self, v: i128, out: &mut Vec<u8>) {
        let bytes = v.to_le_bytes();
        out.extend_from_slice(&bytes[..self.bytes()]);
    }

    /// Where the element's values fit a voxel exactly: the voxel width and the offset added.
    fn exact(self) -> Option<(u32, f64)> {
        match self {
            Type::U8 => Some((1, 0.0)),
            Type::I8 => Some((1, 128.0)),
            Type::U16 => Some((2, 0.0)),
            Type::I16 => Some((2, 32768.0)),
            _ => None,
        }
    }
}

/// A volume's elements: `bytes` holds `dims` elements of `ty` (x fastest), `big` for
/// big-endian; the value of an element e is `slope·e + inter`.
pub struct Source<'a> {
    pub dims: [usize; 3],
    pub bytes: &'a [u8],
    pub ty: Type,
    pub big: bool,
    pub slope: f64,
    pub inter: f64,
}

/// A volume as a reader has read it: its elements (which [`Volume::source`] lends to the
/// conversion) and, where the file says, where its nodes lie (RAS millimetres).
pub struct Volume {
    pub dims: [usize; 3],
    pub ty: Type,
    pub big: bool,
    pub bytes: Vec<u8>,
    pub slope: f64,
    pub inter: f64,
    pub geometry: Option<vlib::Geometry>,
}

impl Volume {
    /// The volume as a conversion source.
    pub fn source(&self) -> Source<'_> {
        Source {
            dims: self.dims,
            bytes: &self.bytes,
            ty: self.ty,
            big: self.big,
            slope: self.slope,
            inter: self.inter,
        }
    }
}

/// What a conversion made: the dataset, a line saying how values became voxels, and a note
/// where values were replaced (values that are not finite).
pub struct Converted {
    pub dataset: vlib::Dataset,
    pub report: String,
    pub note: Option<String>,
}

/// The values of a volume: the smallest and largest finite value, and how many are not finite.
struct Range {
    lo: f64,
    hi: f64,
    nan: u64,
    /// +∞ (or a scaled value past f64's largest).
    above: u64,
    /// −∞ (or a scaled value past f64's smallest).
    below: u64,
}

impl Range {
    /// What the values that are not finite became, for a note; `None` if every value is.
    fn note(&self) -> Option<String> {
        let mut parts = Vec::new();
        let (lo, hi) = (self.lo, self.hi);
        if self.nan > 0 {
            parts.push(format!(
                "{} NaN value(s) set to the smallest finite value, {lo}",
                self.nan
            ));
        }
        if self.above > 0 {
            parts.push(format!(
                "{} +infinite value(s) set to the largest finite value, {hi}",
                self.above
            ));
        }
        if self.below > 0 {
            parts.push(format!(
                "{} -infinite value(s) set to the smallest finite value, {lo}",
                self.below
            ));
        }
        (!parts.is_empty()).then(|| parts.join("; "))
    }

    /// The finite value that stands for `v`: `v` itself, or the end of the range a note names.
    fn finite(&self, v: f64) -> f64 {
        if v.is_finite() {
            v
        } else if v == f64::INFINITY {
            self.hi
        } else {
            self.lo
        }
    }
}

/// (x − c0)/c1, where x − c0 could overflow f64: then taken of halves, (x/2 − c0/2)/(c1/2).
fn voxel_units(x: f64, c0: f64, c1: f64) -> f64 {
    let d = x - c0;
    if d.is_finite() {
        d / c1
    } else {
        (x * 0.5 - c0 * 0.5) / (c1 * 0.5)
    }
}

impl Source<'_> {
    /// The number of elements (saturating: a product that overflows is refused by
    /// [`Source::convert`]'s length check).
    fn len(&self) -> usize {
        self.dims.iter().fold(1usize, |a, &d| a.saturating_mul(d))
    }

    /// Element `i`'s raw value (before scaling).
    fn element(&self, i: usize) -> f64 {
        let n = self.ty.bytes();
        self.ty.read(&self.bytes[i * n..], self.big)
    }

    /// The values' range (scaled); `None` if none is finite.
    fn range(&self, bar: &mut Progress) -> Option<Range> {
        let mut r = Range {
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
            nan: 0,
            above: 0,
            below: 0,
        };
        let n = self.len();
        for start in (0..n).step_by(BLOCK) {
            let end = (start + BLOCK).min(n);
            for i in start..end {
                let v = self.slope * self.element(i) + self.inter;
                if v.is_finite() {
                    r.lo = r.lo.min(v);
                    r.hi = r.hi.max(v);
                } else if v.is_nan() {
                    r.nan += 1;
                } else if v > 0.0 {
                    r.above += 1;
                } else {
                    r.below += 1;
                }
            }
            bar.advance((end - start) as u64);
        }
        (r.lo <= r.hi).then_some(r)
    }

    /// The dataset whose normalised values are clamp((value − A)/(B − A), 0, 1) for the window
    /// (A, B) = `window`, each end the data's own where `None` (its smallest and largest
    /// value; a constant volume v gets (v, v + 1), so it normalises to 0).
    pub fn convert(&self, window: (Option<f64>, Option<f64>)) -> Result<Converted, String> {
        let need = self.len().saturating_mul(self.ty.bytes());
        if self.bytes.len() < need {
            return Err(format!(
                "{} of voxels, {need} needed for {:?} of {:?}",
                crate::counted(self.bytes.len(), "byte"),
                self.dims,
                self.ty
            ));
        }
        if !(self.slope.is_finite() && self.inter.is_finite() && self.slope != 0.0) {
            return Err(format!(
                "scaling slope {} and intercept {} must be finite, the slope not 0",
                self.slope, self.inter
            ));
        }
        // Two passes over the elements: the range, then the voxels.
        let n = self.len();
        let mut bar = Progress::new("finding the range", n as u64, Unit::Voxels);
        let range = self.range(&mut bar);
        bar.finish();
        let range = range.ok_or("no finite value: nothing to normalise by")?;
        let (lo, hi) = (range.lo, range.hi);
        match window {
            (None, Some(b)) if b <= lo => {
                return Err(format!(
                    "--b {b} is at or below the data's smallest value {lo}: the window would be \
                     inverted; give --a too (--window A B) if that is what you want"
                ))
            }
            (Some(a), None) if a >= hi => {
                return Err(format!(
                    "--a {a} is at or above the data's largest value {hi}: every voxel would be \
                     0; give --b too (--window A B) if that is what you want"
                ))
            }
            _ => {}
        }
        let a = window.0.unwrap_or(lo);
        // (A constant volume, lo = hi, and no --b: b one above, so every voxel is 0.)
        let b = window.1.unwrap_or(if hi > a { hi } else { a + 1.0 });
        if !(a.is_finite() && b.is_finite() && a != b) {
            return Err(format!("window {a} … {b}: both ends finite and different"));
        }
        // A voxel v stands for the value c0 + c1·v.
        let mut bar = Progress::new("converting", n as u64, Unit::Voxels);
        let (raw, c0, c1, how) = if let Some((width, offset)) = self.ty.exact() {
            let vox = |i: usize| (self.element(i) + offset) as u32;
            let raw = if width == 1 {
                vlib::Voxels::U8(collect(n, &mut bar, |i| vox(i) as u8))
            } else {
                vlib::Voxels::U16(collect(n, &mut bar, |i| vox(i) as u16))
            };
            let how = format!("{:?} values kept exactly in {width}-byte voxels", self.ty);
            (raw, self.inter - self.slope * offset, self.slope, how)
        } else {
            // h = 1/2 where hi − lo overflows f64: the span and each value's distance from lo
            // are then taken of halved values, which cannot overflow.
            let h = if (hi - lo).is_finite() { 1.0 } else { 0.5 };
            let span = if hi > lo { hi * h - lo * h } else { 1.0 };
            let q = |i: usize| {
                let v = range.finite(self.slope * self.element(i) + self.inter);
                ((v * h - lo * h) / span * 65535.0)
                    .round()
                    .clamp(0.0, 65535.0) as u16
            };
            let how = format!("{:?} values {lo} … {hi} quantised to 0 … 65535", self.ty);
            (
                vlib::Voxels::U16(collect(n, &mut bar, q)),
                lo,
                span / 65535.0 / h,
                how,
            )
        };
        bar.finish();
        let (va, vb) = (voxel_units(a, c0, c1), voxel_units(b, c0, c1));
        // The file holds a and b as f32: the window must survive the cast.
        let (fa, fb) = (va as f32, vb as f32);
        if !(fa.is_finite() && fb.is_finite() && fa != fb) {
            return Err(format!(
                "window {a} … {b}: a .vlb holds its ends as 32-bit floats in voxel units, where \
                 they are {fa} … {fb}; they must be finite and different (the window is too \
                 narrow or too wide for them)"
            ));
        }
        let dataset = vlib::Dataset::new(self.dims, raw, fa, fb).map_err(|e| e.to_string())?;
        Ok(Converted {
            dataset,
            report: format!("{how}; window {a} … {b} (a, b = {va} {vb} in voxel units)"),
            note: range.note(),
        })
    }
}

/// The regular file `path`, opened for reading, and its metadata: a FIFO, a device or a
/// directory is refused without waiting, as `vlLoad` refuses it ([`vlib::vlb::open_regular`]).
pub fn open_regular(path: &Path) -> Result<(std::fs::File, std::fs::Metadata), String> {
    vlib::vlb::open_regular(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// The bytes of the regular file `path`, at most `limit` of them (`None`: all), opened by
/// [`open_regular`]. Reads of more than 64 KiB (not a format's first bytes) show their
/// progress.
pub fn read_regular(path: &Path, limit: Option<u64>) -> Result<Vec<u8>, String> {
    let at = |e: std::io::Error| format!("{}: {e}", path.display());
    let (f, meta) = open_regular(path)?;
    let total = limit.map_or(meta.len(), |l| l.min(meta.len()));
    let mut out = Vec::new();
    let mut f = f.take(limit.unwrap_or(u64::MAX));
    if total > 64 * 1024 {
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        let bar = Progress::new(format!("reading {name}"), total, Unit::Bytes);
        Reading::new(f, bar).read_to_end(&mut out).map_err(at)?;
    } else {
        f.read_to_end(&mut out).map_err(at)?;
    }
    Ok(out)
}

/// What a failure to read a gzip stream means: one cut short says so; a corrupt one (a
/// checksum or length that does not match, a malformed block or header) gives the decoder's
/// reason.
pub fn gzip_error(e: std::io::Error) -> String {
    if e.kind() == std::io::ErrorKind::UnexpectedEof {
        "the file ends inside the gzip stream (it is cut short)".into()
    } else if e.to_string().contains("gzip") {
        e.to_string()
    } else {
        format!("gzip stream: {e}")
    }
}

/// Reads the gzip stream `r` (`gunzip`'s decoder of one or more members) to its end: into
/// `out` until `out` holds `keep` bytes, then the bytes after those, counted and dropped, so
/// that every member's checksum and length are checked. Returns that count.
pub fn inflate_rest(r: &mut impl Read, out: &mut Vec<u8>, keep: u64) -> Result<u64, String> {
    let room = keep.saturating_sub(out.len() as u64);
    r.by_ref().take(room).read_to_end(out).map_err(gzip_error)?;
    std::io::copy(r, &mut std::io::sink()).map_err(gzip_error)
}
