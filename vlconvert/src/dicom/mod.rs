//! DICOM series: a folder of single-frame slices (`vlconvert dicom DIR OUT.vlb`, or one of
//! its files, which stands for its series) becomes one volume, x the column, y the row, z the
//! slice, with a geometry sidecar.
//!
//! Every file of the folder (not its subfolders) with `DICM` at byte 128 is read; other files
//! (a README), and DICOM files without an image (a DICOMDIR), are skipped and counted. The
//! images must be of one series (SeriesInstanceUID), or the series is chosen with `--series`
//! or by naming one of its files; they are checked ([`slice::Slice::check`]), ordered and
//! placed ([`stack`]), and read again one at a time for their pixels (not every file held
//! at once).
//!
//! Values: each slice's stored values (masked to BitsStored, sign-extended where
//! PixelRepresentation is 1) times its RescaleSlope plus its RescaleIntercept are the
//! modality values (Hounsfield units for CT). Where every slice has one slope and intercept,
//! the stored values are kept exactly in the narrowest element type that holds what
//! BitsStored allows (8-bit types, so 8-bit voxels, for BitsStored ≤ 8; 16-bit ones to 16
//! bits; 32-bit ones are quantised), and the scaling goes into the window, as for NIfTI's
//! `scl_slope`; where they differ, the modality values are computed per slice and quantised
//! to 16 bits over their range (`volume`).

pub(crate) mod scan;
mod slice;
mod stack;

use crate::volume::{Type, Volume};
use std::path::{Path, PathBuf};

type Res<T> = Result<T, String>;

pub use scan::is_dicom;

/// The files of `folder` (not its subfolders), by name.
fn files(folder: &Path) -> Res<Vec<PathBuf>> {
    let at = |e: std::io::Error| format!("{}: {e}", folder.display());
    let mut out = Vec::new();
    for entry in std::fs::read_dir(folder).map_err(at)? {
        let path = entry.map_err(at)?.path();
        if std::fs::metadata(&path).is_ok_and(|m| m.is_file()) {
            out.push(path);
        }
    }
    out.sort();
    Ok(out)
}

/// The series found in a folder: (UID, label, number of slices), in order of first file.
fn listing(images: &[(String, Res<slice::Slice>)]) -> String {
    let mut seen: Vec<(&str, String, usize)> = Vec::new();
    for (uid, s) in images {
        match seen.iter_mut().find(|(u, _, _)| u == uid) {
            Some(entry) => entry.2 += 1,
            None => seen.push((
                uid,
                s.as_ref().map(|s| s.label.clone()).unwrap_or_default(),
                1,
            )),
        }
    }
    seen.iter()
        .map(|(uid, label, n)| {
            let uid = if uid.is_empty() { "(none)" } else { uid };
            format!("\n  {uid}  {label} ({n} file(s))")
        })
        .collect()
}

/// Converts the DICOM series at `input` (a folder, or one of its files, which chooses its
/// series) to `output`; `series` chooses a series by its SeriesInstanceUID.
pub fn convert(
    input: &Path,
    output: &Path,
    window: &super::Window,
    series: Option<&str>,
) -> Res<()> {
    let (v, dir) = read(input, series)?;
    super::convert(&v, window, output).map_err(|e| format!("{dir}: {e}"))
}

/// Reads the DICOM series at `input` (a folder, or one of its files, which chooses its
/// series; `series` chooses one by its SeriesInstanceUID), saying what it found; and the
/// folder's name, for errors.
pub fn read(input: &Path, series: Option<&str>) -> Res<(Volume, String)> {
    let (folder, file) = if std::fs::metadata(input).is_ok_and(|m| m.is_dir()) {
        (input.to_path_buf(), None)
    } else {
        let head = crate::volume::read_regular(input, Some(132))?;
        if !is_dicom(&head) {
            return Err(format!(
                "{}: not a DICOM file (no DICM at byte 128)",
                input.display()
            ));
        }
        let parent = input.parent().filter(|p| !p.as_os_str().is_empty());
        (parent.unwrap_or(Path::new(".")).to_path_buf(), Some(input))
    };
    // First pass: every file's header.
    let (mut not_dicom, mut no_image) = (0usize, Vec::new());
    let mut images: Vec<(String, Res<slice::Slice>)> = Vec::new();
    let mut chosen_by_file = None;
    for path in files(&folder)? {
        match slice::read(&path)? {
            slice::Entry::NotDicom => not_dicom += 1,
            slice::Entry::NoImage(what) => {
                if file.is_some_and(|f| same_file(f, &path)) {
                    return Err(format!(
                        "{}: a DICOM file without an image ({what})",
                        path.display()
                    ));
                }
                no_image.push(what)
            }
            slice::Entry::Image { series, slice } => {
                if file.is_some_and(|f| same_file(f, &path)) {
                    chosen_by_file = Some(series.clone());
                }
                images.push((series, *slice));
            }
        }
    }
    let dir = folder.display();
    if images.is_empty() {
        let hint = if no_image.iter().any(|w| w.contains("DICOMDIR")) {
            " (its DICOMDIR lists images in other folders: convert the folder that holds them)"
        } else {
            ""
        };
        return Err(format!(
            "{dir}: no DICOM image in the folder ({not_dicom} file(s) not DICOM, {} DICOM \
             without an image){hint}",
            no_image.len()
        ));
    }
    let want = match (series, chosen_by_file) {
        (Some(uid), _) => uid.to_string(),
        (None, Some(uid)) => uid,
        (None, None) => {
            let first = &images[0].0;
            if images.iter().any(|(uid, _)| uid != first) {
                return Err(format!(
                    "{dir}: the folder holds several series; choose one with --series UID \
                     (or name one of its files):{}",
                    listing(&images)
                ));
            }
            first.clone()
        }
    };
    let total = images.len();
    let mut slices = Vec::new();
    for (_, s) in images.iter().filter(|(uid, _)| *uid == want) {
        let s = s.clone()?;
        s.check()?;
        slices.push(s);
    }
    if slices.is_empty() {
        return Err(format!(
            "{dir}: no series {want} in the folder; its series:{}",
            listing(&images)
        ));
    }
    let stack = stack::arrange(slices)?;
    for note in &stack.notes {
        eprintln!("vlconvert: note: {note}");
    }
    let n = stack.slices.len();
    let first = &stack.slices[0];
    let skipped = match (not_dicom, no_image.len(), total - n) {
        (0, 0, 0) => String::new(),
        (a, b, c) => format!(
            "; skipped {} file(s): {a} not DICOM, {b} DICOM without an image, {c} of other \
             series",
            a + b + c
        ),
    };
    super::say(format_args!(
        "series {want} ({}): {n} slice(s) of {} × {} pixels in {dir}{skipped}",
        first.label, first.cols, first.rows,
    ))?;
    super::say(format_args!("{}", stack.order))?;
    // Second pass: the pixels, slice by slice.
    let same_scale = stack
        .slices
        .iter()
        .all(|s| (s.slope, s.inter) == (first.slope, first.inter));
    let (lo, hi) = stack
        .slices
        .iter()
        .map(slice::Slice::stored_range)
        .fold((i64::MAX, i64::MIN), |(l, h), (a, b)| (l.min(a), h.max(b)));
    let exact = if same_scale { holding(lo, hi) } else { None };
    let ty = exact.unwrap_or(Type::F64);
    if exact.is_none() {
        super::say(format_args!(
            "{}: modality values computed per slice",
            if same_scale {
                "signed and unsigned 32-bit slices"
            } else {
                "RescaleSlope and RescaleIntercept differ between slices"
            }
        ))?;
    }
    let mut bytes: Vec<u8> = Vec::new();
    for s in &stack.slices {
        s.values(ty, exact.is_none(), &mut bytes)?;
    }
    let (slope, inter) = match exact {
        Some(_) => (first.slope, first.inter),
        None => (1.0, 0.0),
    };
    let volume = Volume {
        dims: [first.cols as usize, first.rows as usize, n],
        bytes,
        ty,
        big: false,
        slope,
        inter,
        geometry: stack.geometry,
    };
    Ok((volume, dir.to_string()))
}

/// The narrowest integer element type that holds every value from `lo` to `hi`.
fn holding(lo: i64, hi: i64) -> Option<Type> {
    let types = [
        (Type::U8, 0, u8::MAX as i64),
        (Type::I8, i8::MIN as i64, i8::MAX as i64),
        (Type::U16, 0, u16::MAX as i64),
        (Type::I16, i16::MIN as i64, i16::MAX as i64),
        (Type::U32, 0, u32::MAX as i64),
        (Type::I32, i32::MIN as i64, i32::MAX as i64),
    ];
    types
        .into_iter()
        .find(|&(_, min, max)| min <= lo && hi <= max)
        .map(|(t, _, _)| t)
}

/// Whether `a` and `b` name one file.
fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}
