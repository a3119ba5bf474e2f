//! The output layer: the files a scene requests, and the only place that writes them.
//!
//! [`render_outputs`] compiles a finished scene once, renders each requested image with the
//! renderer ([`crate::render`], which computes pixels and writes nothing) and voxelizes each
//! requested volume ([`voxel`]), then writes the files: images through [`write_image`] (PPM or
//! PNG by extension, `files`), datasets through [`crate::data::Dataset::save`] (defined here,
//! so that no layer below this one writes a file); every file atomically ([`write_atomic`]). It
//! does not trace rays or evaluate fields itself.

use crate::control::{Progress, RenderControl};
use crate::error::{Error, ErrorCode, Result};
use crate::model::scene::{ImageRequest, SceneDesc};
use crate::num::try_with_capacity;
use crate::render::{render_strips, Compiled, Grids};

mod files;
mod voxel;

pub(crate) use files::ImageFormat;
pub use files::{write_atomic, write_image};

#[cfg(test)]
mod tests;

impl crate::data::Dataset {
    /// Writes the dataset as a `.vlb` file, atomically (the format: [`Dataset::to_vlb_bytes`]),
    /// piece by piece: no copy of the voxels is made. Its geometry, if it has one, goes to the
    /// sidecar `path.geom` ([`crate::Geometry`]); a sidecar left there by an earlier file is
    /// removed when it has none.
    ///
    /// [`Dataset::to_vlb_bytes`]: crate::data::Dataset::to_vlb_bytes
    pub fn save(&self, path: &std::path::Path) -> Result<()> {
        let mut file = files::AtomicFile::create(path)?;
        file.write(&self.vlb_header())?;
        self.vlb_body(|bytes| file.write(bytes))?;
        // The old sidecar goes before the new file replaces the old one, and the new sidecar
        // comes after: whatever fails between, no file is described by another's geometry.
        files::write_sidecar(path, None)?;
        file.commit()?;
        match self.geometry() {
            Some(g) => files::write_sidecar(path, Some((g, self.dims()))),
            None => Ok(()),
        }
    }
}

/// Renders every image and voxelization a scene requested and writes the files. Every output
/// is attempted; the first failure is returned (its message counts the others). A cancelled
/// render (`control`) stops at once: the outputs finished before it are written, the one in
/// progress and the rest are not, and its error counts the outputs that failed before. The
/// progress function hears 1 at the end whatever failed. A panic anywhere in it, the progress
/// function's too, is an error ([`crate::error::catch`]).
pub fn render_outputs(desc: &SceneDesc, grids: &Grids, control: &RenderControl) -> Result<()> {
    if desc.images.is_empty() && desc.volumes.is_empty() {
        return Ok(());
    }
    let total = desc
        .images
        .iter()
        .map(|r| r.width as u64 * r.height as u64)
        .chain(
            desc.volumes
                .iter()
                .map(|r| r.nodes.iter().product::<usize>() as u64),
        )
        .fold(0u64, u64::saturating_add);
    let progress = Progress::new(control, total);
    let mut errors: Vec<Error> = Vec::new();
    let cancelled = crate::error::catch("rendering the scene", || {
        let compiled = Compiled::build(desc, grids)?;
        let images = desc
            .images
            .iter()
            .map(|req| image(&compiled, req, &progress));
        let volumes = desc
            .volumes
            .iter()
            .map(|req| voxel::write(&compiled, req, &progress));
        for result in images.chain(volumes) {
            match result {
                Err(e) if e.code == ErrorCode::Cancelled => return Err(e),
                Err(e) => errors.push(e),
                Ok(()) => {}
            }
        }
        Ok(())
    });
    if let Err(mut e) = cancelled {
        if !errors.is_empty() {
            e.message = format!("{} ({} output(s) failed before)", e.message, errors.len());
        }
        return Err(e);
    }
    progress.finish();
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

/// Renders one requested image and writes it. The memory it takes is the file's 8-bit pixels
/// (the output's own bytes, held whole for the encoder), a strip of the render, and for PNG
/// the compressed stream.
fn image(compiled: &Compiled, req: &ImageRequest, progress: &Progress) -> Result<()> {
    let (w, h) = (req.width, req.height);
    // A name the file cannot have, or a destination that cannot be written, is refused
    // before rendering.
    let format = files::ImageFormat::from_path(&req.path)?;
    let file = files::AtomicFile::create(&req.path)?;
    let mut rgb: Vec<u8> = try_with_capacity(w as usize * h as usize * 3, "the image's pixels")?;
    render_strips(compiled, w, h, req.aspect, progress, |_, rows| {
        rgb.extend(rows.iter().flat_map(|p| p.map(crate::render::to_u8)));
        Ok(())
    })?;
    files::encode_into(file, format, w, h, &rgb)
}
