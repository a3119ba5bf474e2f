//! The readers called in-process, for the fuzz target (`fuzz/fuzz_targets/vlconvert_readers.rs`)
//! and its bounded CI run (`vlconvert/tests/fuzz_readers.rs`): each format's reader, from a
//! path to the datasets the command line would write with the data's own window, writing no
//! file and saying nothing on standard output (notes still go to standard error). Not an API:
//! hidden from the documentation, and free to change with the fuzz target.

use crate::{detect, dicom, metaimage, nifti, nrrd, tiffstack, Norm, Res};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use vlib::Dataset;

pub use crate::volume::Type;

/// Every element type, in the order the enum declares them, for a raw volume's parameters.
pub fn types() -> &'static [Type] {
    <Type as clap::ValueEnum>::value_variants()
}

/// Set by [`read`]: the command line's report lines (`say`) are not written.
pub(crate) static SILENT: AtomicBool = AtomicBool::new(false);

/// A reader, as a subcommand of the command line chooses it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Format {
    /// `vlconvert IN OUT`: the format from the file's first bytes, or a folder's files.
    Detect,
    Nifti,
    Nrrd,
    MetaImage,
    /// A folder of slices, or one of its files.
    Dicom,
    /// A multi-page file, or a folder of single-page files.
    Tiff,
    Image,
    /// `vlconvert raw --dims … --type … --endian … --skip …`.
    Raw {
        dims: [u32; 3],
        ty: Type,
        big: bool,
        skip: u64,
    },
}

/// The datasets `vlconvert` would write for `input` read as `format` (three for a colour
/// image, else one), or its error.
pub fn read(format: Format, input: &Path) -> Res<Vec<Dataset>> {
    SILENT.store(true, Ordering::Relaxed);
    crate::progress::set_quiet(true);
    let volume = match format {
        Format::Detect => {
            let format = match detect::format(input)? {
                detect::Format::Nifti => Format::Nifti,
                detect::Format::Nrrd => Format::Nrrd,
                detect::Format::MetaImage => Format::MetaImage,
                detect::Format::Dicom => Format::Dicom,
                detect::Format::Tiff => Format::Tiff,
                detect::Format::Image => Format::Image,
            };
            return read(format, input);
        }
        Format::Nifti => nifti::read(input)?,
        Format::Nrrd => nrrd::read(input)?,
        Format::MetaImage => metaimage::read(input)?,
        Format::Dicom => dicom::read(input, None)?.0,
        Format::Tiff => tiffstack::read(input, &[])?,
        Format::Image => {
            let images = crate::image_datasets(input, Norm { a: None, b: None })?;
            return Ok(images.into_iter().map(|(_, d)| d).collect());
        }
        Format::Raw {
            dims,
            ty,
            big,
            skip,
        } => {
            let endian = if big {
                crate::Endian::Big
            } else {
                crate::Endian::Little
            };
            crate::raw_volume(input, &dims, ty, endian, skip)?
        }
    };
    let converted = volume.source().convert((None, None))?;
    Ok(vec![match volume.geometry {
        Some(g) => converted.dataset.with_geometry(g),
        None => converted.dataset,
    }])
}
