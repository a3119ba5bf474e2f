//! Which format a file is, from its first bytes (`vlconvert IN OUT.vlb`): NRRD by its magic,
//! NIfTI-1 by `n+1` at byte 344 (inside gzip too), MetaImage by its `ObjectType`/`NDims` header
//! keys, DICOM by `DICM` at byte 128, TIFF (and BigTIFF) by `II*\0`/`MM\0*` (`II+\0`/`MM\0+`),
//! PNG and PNM images (P1 to P7, PAM among them) by theirs; a folder holding TIFF files is a stack, one holding DICOM files
//! a series; a folder of neither, or of both, is refused (`vlconvert tiff` or `vlconvert dicom`
//! chooses). A headerless raw volume cannot be recognised: it needs `vlconvert raw` with its
//! dimensions and type.

use std::io::Read;
use std::path::Path;

/// The formats `vlconvert` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Nifti,
    Nrrd,
    MetaImage,
    Image,
    Dicom,
    /// A TIFF file, or a folder of them.
    Tiff,
}

/// The format of the file at `path`.
pub fn format(path: &Path) -> Result<Format, String> {
    if std::fs::metadata(path).is_ok_and(|m| m.is_dir()) {
        // A folder of TIFFs is a stack; one holding a DICOM file a series; both, neither: refused.
        let tiff = !crate::tiffstack::folder_files(path)?.is_empty();
        match (tiff, holds_dicom(path)) {
            (true, false) => return Ok(Format::Tiff),
            (false, true) => return Ok(Format::Dicom),
            (true, true) => {
                return Err(format!(
                    "{}: a folder with TIFF files (.tif, .tiff) and DICOM files: say which to \
                     read, `vlconvert tiff` or `vlconvert dicom`",
                    path.display()
                ))
            }
            (false, false) => {}
        }
        return Err(format!(
            "{}: a folder without TIFF files (.tif, .tiff) or DICOM files (DICM at byte 128): \
             neither a stack nor a series vlconvert reads",
            path.display()
        ));
    }
    // (A FIFO or a device is refused, not read: its bytes could not be read twice.)
    let head = crate::volume::read_regular(path, Some(512))?;
    if head.starts_with(&[0x1f, 0x8b]) {
        // gzip: look inside (a .nii.gz).
        let mut inner = Vec::new();
        let (f, _) = crate::volume::open_regular(path)?;
        let _ = crate::gunzip::Gunzip::new(f)
            .take(512)
            .read_to_end(&mut inner);
        if is_nifti(&inner) {
            return Ok(Format::Nifti);
        }
        return Err(format!(
            "{}: gzip-compressed, but not a NIfTI-1 file inside",
            path.display()
        ));
    }
    if is_nifti(&head) {
        return Ok(Format::Nifti);
    }
    if crate::dicom::is_dicom(&head) {
        return Ok(Format::Dicom);
    }
    if crate::nrrd::is_nrrd(&head) {
        return Ok(Format::Nrrd);
    }
    if crate::tiffstack::is_tiff(&head) {
        return Ok(Format::Tiff);
    }
    if head.starts_with(b"\x89PNG")
        || (head.len() > 2 && head[0] == b'P' && b"1234567".contains(&head[1]))
    {
        return Ok(Format::Image);
    }
    let text = String::from_utf8_lossy(&head);
    let first = text.trim_start().split(['=', ' ']).next().unwrap_or("");
    if matches!(first, "ObjectType" | "NDims" | "Comment") && text.contains("=") {
        return Ok(Format::MetaImage);
    }
    if head.starts_with(vlib::vlb::MAGIC) {
        return Err(format!("{}: already a .vlb dataset", path.display()));
    }
    Err(format!(
        "{}: not a format vlconvert recognises (NIfTI-1, NRRD, MetaImage, DICOM, TIFF, PNG, PNM); a \
         headerless raw volume converts with `vlconvert raw` and its --dims and --type",
        path.display()
    ))
}

/// Whether `head` (a file's first bytes) is a NIfTI-1 single file or header: magic `n+1` or
/// `ni1` and a NUL at byte 344.
fn is_nifti(head: &[u8]) -> bool {
    matches!(head.get(344..348), Some(b"n+1\0") | Some(b"ni1\0"))
}

/// Whether the folder `dir` holds a regular file with `DICM` at byte 128 (its first 132 bytes
/// read; unreadable entries skipped: the DICOM reader names them).
fn holds_dicom(dir: &Path) -> bool {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return false;
    };
    entries.filter_map(|e| e.ok()).any(|e| {
        let p = e.path();
        e.file_type().is_ok_and(|t| t.is_file())
            && crate::volume::read_regular(&p, Some(132))
                .is_ok_and(|head| crate::dicom::scan::is_dicom(&head))
    })
}
