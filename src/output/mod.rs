//! The output layer: the files a scene requests, and the only place that writes them.
//!
//! [`render_outputs`] compiles a finished scene once, renders each requested image with the
//! renderer ([`crate::render`], which computes pixels and writes nothing) and voxelizes each
//! requested volume ([`voxel`]), then writes the files: images through [`write_image`] (PPM or
//! PNG by extension, `files`), datasets through [`crate::data::Dataset::save`] (defined here,
//! so that no layer below this one writes a file); every file atomically ([`write_atomic`]). It
//! does not trace rays or evaluate fields itself.

use crate::control::Progress;
use crate::error::{Error, Result};
use crate::model::scene::SceneDesc;
use crate::render::{render_image, Compiled, Grids};

mod files;
mod voxel;

pub(crate) use files::ImageFormat;
pub use files::{write_atomic, write_image};

#[cfg(test)]
mod tests;

impl crate::data::Dataset {
    /// Writes the dataset as a `.vlb` file, atomically (the format: [`Dataset::to_vlb_bytes`]),
    /// piece by piece: no copy of the voxels is made.
    ///
    /// [`Dataset::to_vlb_bytes`]: crate::data::Dataset::to_vlb_bytes
    pub fn save(&self, path: &std::path::Path) -> Result<()> {
        let mut file = files::AtomicFile::create(path)?;
        file.write(&self.vlb_header())?;
        self.vlb_body(|bytes| file.write(bytes))?;
        file.commit()
    }
}

/// Renders every image and voxelization a scene requested and writes the files. Every output
/// is attempted; the first failure is returned (its message counts the others).
///
/// Voxelizations report their nodes to `progress` and stop where it says the render is
/// cancelled (writing none of their files).
pub fn render_outputs(desc: &SceneDesc, grids: &Grids, progress: &Progress) -> Result<()> {
    if desc.images.is_empty() && desc.volumes.is_empty() {
        return Ok(());
    }
    let compiled = Compiled::new(desc, grids);
    let mut errors: Vec<Error> = Vec::new();
    for req in &desc.images {
        let result = render_image(&compiled, req.width, req.height, req.aspect)
            .and_then(|img| write_image(&req.path, img.width, img.height, &img.to_rgb8()));
        if let Err(e) = result {
            errors.push(e);
        }
    }
    for req in &desc.volumes {
        if let Err(e) = voxel::write(&compiled, req, progress) {
            errors.push(e);
        }
    }
    match errors.len() {
        0 => Ok(()),
        1 => Err(errors.remove(0)),
        n => {
            let mut e = errors.remove(0);
            e.message = format!("{} (and {} more output(s) failed)", e.message, n - 1);
            Err(e)
        }
    }
}
