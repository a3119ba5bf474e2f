//! One DICOM file of a series: what its header says of its slice (series, size, pixel
//! format, scaling, placement), which slices convert and which are refused (and why), and
//! its stored pixel values.
//!
//! Files are parsed by `dicom-object` after [`super::scan`] has checked their structure
//! against their length, and decoded by `dicom-pixeldata` (the uncompressed transfer syntaxes
//! and RLE Lossless). A panic inside either crate, on a file it was not written for, is
//! caught and reported as that file's error.

use super::scan;
use crate::volume::{read_regular, Type};
use dicom_core::DicomValue;
use dicom_core::Tag;
use dicom_dictionary_std::tags;
use dicom_object::file::{OpenFileOptions, ReadPreamble};
use dicom_object::DefaultDicomObject;
use dicom_pixeldata::PixelDecoder;
use dicom_transfer_syntax_registry::{TransferSyntaxIndex, TransferSyntaxRegistry};
use std::path::{Path, PathBuf};

type Res<T> = Result<T, String>;

/// Media Storage Directory Storage: a DICOMDIR.
const DICOMDIR: &str = "1.2.840.10008.1.3.10";

/// What a file of the folder is.
pub enum Entry {
    /// Not a DICOM file (no `DICM` at byte 128): skipped.
    NotDicom,
    /// A DICOM file without an image (a DICOMDIR, a report): skipped; what it is.
    NoImage(String),
    /// An image of series `series`, with its header or what is wrong with it.
    Image {
        series: String,
        slice: Box<Res<Slice>>,
    },
}

/// A slice's header.
#[derive(Clone, Debug, PartialEq)]
pub struct Slice {
    pub path: PathBuf,
    /// Modality, series number and description, for listings.
    pub label: String,
    pub ts: String,
    pub rows: u16,
    pub cols: u16,
    pub frames: i64,
    pub samples: u16,
    pub photometric: String,
    pub bits_allocated: u16,
    pub bits_stored: u16,
    pub high_bit: u16,
    pub signed: bool,
    /// RescaleSlope and RescaleIntercept (1 and 0 where absent).
    pub slope: f64,
    pub inter: f64,
    pub modality_lut: bool,
    /// ImageOrientationPatient: the row direction, then the column direction (LPS).
    pub orientation: Option<[f64; 6]>,
    /// ImagePositionPatient: the first pixel's centre (LPS, mm).
    pub position: Option<[f64; 3]>,
    /// PixelSpacing: between rows, then between columns (mm).
    pub spacing: Option<[f64; 2]>,
    pub thickness: Option<f64>,
    pub instance: Option<i64>,
}

/// Runs `f`, turning a panic into an error (and keeping its message off standard error).
fn guarded<T>(what: &str, f: impl FnOnce() -> Res<T>) -> Res<T> {
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    std::panic::set_hook(hook);
    r.unwrap_or_else(|_| Err(format!("{what} failed on malformed data")))
}

/// An error and its causes, one after another.
fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let t = c.to_string();
        if !s.contains(&t) {
            s = format!("{s}: {t}");
        }
        cause = c.source();
    }
    s
}

/// The transfer syntax's name where the registry knows it.
fn ts_name(uid: &str) -> String {
    match TransferSyntaxRegistry.get(uid) {
        Some(ts) => format!("{} ({uid})", ts.name()),
        None => uid.to_string(),
    }
}

/// Parses the DICOM file `bytes` (its structure checked first), up to its pixel data or whole
/// (to the end of its pixel data); and the count of bytes after that, which are not parsed.
fn parse(bytes: &[u8], whole: bool) -> Res<(DefaultDicomObject, usize)> {
    let (ts, end) = scan::check(bytes)?;
    match TransferSyntaxRegistry.get(&ts) {
        Some(t) if t.can_decode_dataset() && ts != scan::DEFLATED => {}
        _ => {
            return Err(format!(
                "transfer syntax {}: a data set vlconvert cannot read (it reads Implicit and \
                 Explicit VR Little Endian, Explicit VR Big Endian and encapsulated pixel data)",
                ts_name(&ts)
            ))
        }
    }
    let mut options = OpenFileOptions::new().read_preamble(ReadPreamble::Never);
    if !whole {
        options = options.read_until(tags::PIXEL_DATA);
    }
    let obj = guarded("the DICOM parser", || {
        options.from_reader(&bytes[128..end]).map_err(|e| chain(&e))
    })?;
    Ok((obj, bytes.len() - end))
}

/// An attribute's text, trimmed; `None` where absent or empty.
fn text(obj: &DefaultDicomObject, tag: Tag) -> Option<String> {
    let s = obj.get(tag)?.to_str().ok()?;
    let s = s.trim_matches(['\0', ' ']);
    (!s.is_empty()).then(|| s.to_string())
}

/// An attribute of `n` finite numbers; `None` where absent or empty.
fn numbers(obj: &DefaultDicomObject, tag: Tag, name: &str, n: usize) -> Res<Option<Vec<f64>>> {
    let Some(shown) = text(obj, tag) else {
        return Ok(None);
    };
    let bad = || format!("{name} {shown:?}: {n} number(s) expected");
    let e = obj.get(tag).ok_or_else(bad)?;
    let v = e.to_multi_float64().map_err(|_| bad())?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        return Err(bad());
    }
    Ok(Some(v))
}

fn number(obj: &DefaultDicomObject, tag: Tag, name: &str) -> Res<Option<f64>> {
    Ok(numbers(obj, tag, name, 1)?.map(|v| v[0]))
}

fn integer(obj: &DefaultDicomObject, tag: Tag, name: &str) -> Res<Option<i64>> {
    match number(obj, tag, name)? {
        Some(v) if v.fract() == 0.0 && v.abs() < 9.0e15 => Ok(Some(v as i64)),
        Some(v) => Err(format!("{name} {v}: a whole number expected")),
        None => Ok(None),
    }
}

fn required_u16(obj: &DefaultDicomObject, tag: Tag, name: &str) -> Res<u16> {
    match integer(obj, tag, name)? {
        Some(v) => u16::try_from(v).map_err(|_| format!("{name} {v}: 0 … 65535 expected")),
        None => Err(format!("no {name}")),
    }
}

/// `N` numbers (as [`numbers`] checks) as an array.
fn fixed<const N: usize>(v: Option<Vec<f64>>) -> Option<[f64; N]> {
    v.map(|v| std::array::from_fn(|i| v[i]))
}

impl Slice {
    fn from(path: &Path, obj: &DefaultDicomObject) -> Res<Slice> {
        let label = [
            text(obj, tags::MODALITY),
            text(obj, tags::SERIES_NUMBER).map(|n| format!("#{n}")),
            text(obj, tags::SERIES_DESCRIPTION).map(|d| format!("{d:?}")),
        ]
        .into_iter()
        .flatten()
        .collect::<Vec<_>>()
        .join(" ");
        Ok(Slice {
            path: path.to_path_buf(),
            label,
            ts: obj
                .meta()
                .transfer_syntax()
                .trim_end_matches('\0')
                .to_string(),
            rows: required_u16(obj, tags::ROWS, "Rows")?,
            cols: required_u16(obj, tags::COLUMNS, "Columns")?,
            frames: integer(obj, tags::NUMBER_OF_FRAMES, "NumberOfFrames")?.unwrap_or(1),
            samples: required_u16(obj, tags::SAMPLES_PER_PIXEL, "SamplesPerPixel")?,
            photometric: text(obj, tags::PHOTOMETRIC_INTERPRETATION)
                .ok_or("no PhotometricInterpretation")?,
            bits_allocated: required_u16(obj, tags::BITS_ALLOCATED, "BitsAllocated")?,
            bits_stored: required_u16(obj, tags::BITS_STORED, "BitsStored")?,
            high_bit: required_u16(obj, tags::HIGH_BIT, "HighBit")?,
            signed: match required_u16(obj, tags::PIXEL_REPRESENTATION, "PixelRepresentation")? {
                0 => false,
                1 => true,
                v => return Err(format!("PixelRepresentation {v}: 0 or 1 expected")),
            },
            slope: number(obj, tags::RESCALE_SLOPE, "RescaleSlope")?.unwrap_or(1.0),
            inter: number(obj, tags::RESCALE_INTERCEPT, "RescaleIntercept")?.unwrap_or(0.0),
            modality_lut: obj.get(tags::MODALITY_LUT_SEQUENCE).is_some(),
            orientation: fixed(numbers(
                obj,
                tags::IMAGE_ORIENTATION_PATIENT,
                "ImageOrientationPatient",
                6,
            )?),
            position: fixed(numbers(
                obj,
                tags::IMAGE_POSITION_PATIENT,
                "ImagePositionPatient",
                3,
            )?),
            spacing: fixed(numbers(obj, tags::PIXEL_SPACING, "PixelSpacing", 2)?),
            thickness: number(obj, tags::SLICE_THICKNESS, "SliceThickness")?,
            instance: integer(obj, tags::INSTANCE_NUMBER, "InstanceNumber")?,
        })
    }

    /// Refuses a slice that does not convert: saying why, and what does.
    pub fn check(&self) -> Res<()> {
        let at = |e: String| format!("{}: {e}", self.path.display());
        let Some(ts) = TransferSyntaxRegistry.get(&self.ts) else {
            return Err(at(format!("transfer syntax {}: unknown", self.ts)));
        };
        if !ts.can_decode_all() {
            return Err(at(format!(
                "transfer syntax {}: compressed pixel data vlconvert cannot decode (it reads \
                 the uncompressed transfer syntaxes and RLE Lossless; decompress the series \
                 first, e.g. with `gdcmconv --raw` or `dcmdjpeg`)",
                ts_name(&self.ts)
            )));
        }
        if self.rows == 0 || self.cols == 0 {
            return Err(at(format!(
                "Rows {} and Columns {}: an empty image",
                self.rows, self.cols
            )));
        }
        if self.frames != 1 {
            return Err(at(format!(
                "NumberOfFrames {}: a multi-frame image; vlconvert reads series of \
                 single-frame slices (one file per slice)",
                self.frames
            )));
        }
        if self.samples != 1 {
            return Err(at(format!(
                "SamplesPerPixel {} ({}): colour images do not convert, only images of one \
                 value per pixel",
                self.samples, self.photometric
            )));
        }
        if !self.photometric.starts_with("MONOCHROME") {
            return Err(at(format!(
                "PhotometricInterpretation {}: only MONOCHROME1 and MONOCHROME2 images hold \
                 values that convert",
                self.photometric
            )));
        }
        if ![8, 16, 32].contains(&self.bits_allocated) {
            return Err(at(format!(
                "BitsAllocated {}: 8, 16 or 32 convert",
                self.bits_allocated
            )));
        }
        let (ba, bs, hb) = (self.bits_allocated, self.bits_stored, self.high_bit);
        if bs == 0 || bs > ba || hb >= ba || hb + 1 < bs {
            return Err(at(format!(
                "BitsStored {bs} and HighBit {hb} do not fit BitsAllocated {ba}"
            )));
        }
        if self.modality_lut {
            return Err(at(
                "a Modality LUT Sequence (a table, not RescaleSlope and RescaleIntercept, \
                 gives its values): does not convert"
                    .into(),
            ));
        }
        if self.slope == 0.0 {
            return Err(at("RescaleSlope 0: every value would be the same".into()));
        }
        Ok(())
    }

    /// The smallest and largest value its stored bits can hold.
    pub fn stored_range(&self) -> (i64, i64) {
        let b = self.bits_stored as u32;
        if self.signed {
            (-(1i64 << (b - 1)), (1i64 << (b - 1)) - 1)
        } else {
            (0, (1i64 << b) - 1)
        }
    }

    /// Appends the slice's values to `out` as elements of `ty` (little endian), row by row,
    /// each row from its first column: the stored values (masked to BitsStored,
    /// sign-extended where signed), or with `rescale` their modality values (stored value ×
    /// RescaleSlope + RescaleIntercept). The file is read again and must still say what it
    /// said (`self`); `out` grows only once the pixel data is known to hold the slice.
    pub fn values(&self, ty: Type, rescale: bool, out: &mut Vec<u8>) -> Res<()> {
        let at = |e: String| format!("{}: {e}", self.path.display());
        let bytes = read_regular(&self.path, None)?;
        let (obj, trailing) = parse(&bytes, true).map_err(at)?;
        if trailing > 0 {
            eprintln!(
                "vlconvert: note: {} has {} after its last element (ignored)",
                self.path.display(),
                crate::counted(trailing, "byte")
            );
        }
        if Slice::from(&self.path, &obj).as_ref() != Ok(self) {
            return Err(at("the file changed while it was read".into()));
        }
        rle_headers(&self.ts, &obj).map_err(at)?;
        let px = guarded("the pixel data decoder", || {
            obj.decode_pixel_data().map_err(|e| chain(&e))
        })
        .map_err(|e| at(format!("pixel data: {e}")))?;
        let width = self.bits_allocated as usize / 8;
        let n = self.rows as usize * self.cols as usize;
        let need = n * width;
        let data = px.data();
        if data.len() < need {
            return Err(at(format!(
                "{} of pixel data, but Rows × Columns = {} × {} of {} bits need {need}",
                crate::counted(data.len(), "byte"),
                self.rows,
                self.cols,
                self.bits_allocated
            )));
        }
        // dicom-pixeldata gives native samples in the machine's byte order, decoded RLE
        // in little endian.
        let le = TransferSyntaxRegistry
            .get(&self.ts)
            .is_some_and(|t| t.is_encapsulated_pixel_data());
        let word = |b: &[u8]| -> u32 {
            match (b.len(), le) {
                (1, _) => b[0] as u32,
                (2, true) => u16::from_le_bytes([b[0], b[1]]) as u32,
                (2, false) => u16::from_ne_bytes([b[0], b[1]]) as u32,
                (_, true) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                (_, false) => u32::from_ne_bytes([b[0], b[1], b[2], b[3]]),
            }
        };
        out.try_reserve(n * ty.bytes()).map_err(|_| {
            at(format!(
                "not enough memory for {} more bytes",
                n * ty.bytes()
            ))
        })?;
        let bs = self.bits_stored as u32;
        let shift = self.high_bit as u32 + 1 - bs;
        let mask = (1u64 << bs) - 1;
        for sample in data[..need].chunks_exact(width) {
            let v = ((word(sample) >> shift) as u64 & mask) as i64;
            let v = if self.signed && v >> (bs - 1) == 1 {
                v - (1i64 << bs)
            } else {
                v
            } as f64;
            ty.push_le(
                if rescale {
                    self.slope * v + self.inter
                } else {
                    v
                },
                out,
            );
        }
        Ok(())
    }
}

/// RLE Lossless.
const RLE: &str = "1.2.840.10008.1.2.5";

/// Checks the header of each RLE fragment of `obj` (transfer syntax `ts`) before
/// `dicom-pixeldata` decodes it: it allocates as many segment offsets as the header's first
/// word says before it reads them (up to 16 GiB from 4 bytes), where RLE Lossless allows at
/// most 15, in a 64-byte header.
fn rle_headers(ts: &str, obj: &DefaultDicomObject) -> Res<()> {
    let Some(DicomValue::PixelSequence(seq)) = obj.get(tags::PIXEL_DATA).map(|e| e.value()) else {
        return Ok(());
    };
    if ts != RLE {
        return Ok(());
    }
    for (k, f) in seq.fragments().iter().enumerate() {
        let segments = f
            .get(..4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]));
        if f.len() < 64 || segments.is_none_or(|n| n > 15) {
            return Err(format!(
                "pixel data fragment {k}: {}, {}: not an RLE Lossless header (64 bytes, at \
                 most 15 segments)",
                crate::counted(f.len(), "byte"),
                segments.map_or("no segment count".into(), |n| crate::counted(n, "segment"))
            ));
        }
    }
    Ok(())
}

/// Reads the header of the file at `path`: what it is, and for an image, its slice.
pub fn read(path: &Path) -> Res<Entry> {
    let at = |e: String| format!("{}: {e}", path.display());
    let head = read_regular(path, Some(132))?;
    if !scan::is_dicom(&head) {
        return Ok(Entry::NotDicom);
    }
    let bytes = read_regular(path, None)?;
    let (obj, _) = parse(&bytes, false).map_err(at)?;
    if obj.get(tags::ROWS).is_none() && obj.get(tags::COLUMNS).is_none() {
        let class = obj
            .meta()
            .media_storage_sop_class_uid()
            .trim_end_matches('\0');
        return Ok(Entry::NoImage(if class == DICOMDIR {
            "a DICOMDIR".into()
        } else {
            format!("SOP class {class}")
        }));
    }
    Ok(Entry::Image {
        series: text(&obj, tags::SERIES_INSTANCE_UID).unwrap_or_default(),
        slice: Box::new(Slice::from(path, &obj).map_err(at)),
    })
}
