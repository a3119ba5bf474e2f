//! The output layer: the files a scene requests, and the only place that writes them.
//!
//! [`render_outputs`] compiles a finished scene once, renders each requested image with the
//! renderer ([`crate::render`], which computes pixels and writes nothing) and voxelizes each
//! requested volume ([`voxel`]), then writes the files: images in the format their names ask
//! for (`formats`: PPM, PNG and PFM, RGB or RGBA, 8, 16 or 32 bits; also [`write_image`] and
//! [`crate::Image::save`]), datasets through [`crate::data::Dataset::save`] (defined here, so
//! that no layer below this one writes a file); every file atomically ([`write_atomic`],
//! `files`). It does not trace rays or evaluate fields itself.
//!
//! Split over a [`Team`]'s ranks, every rank renders its share of each output and rank 0
//! alone writes the files; every output's result is agreed among the ranks
//! ([`crate::team::agree`]), so every rank goes through the same outputs and ends with the same
//! error (docs/mpi.md).

use crate::control::{Progress, RenderControl};
use crate::error::{Error, ErrorCode, Result};
use crate::model::scene::{ImageRequest, SceneDesc};
use crate::render::{render_into, Caches, Compiled};
use crate::team::Team;

mod files;
mod formats;
mod voxel;

pub use files::write_atomic;
pub use formats::write_image;
pub(crate) use formats::ImageFormat;

#[cfg(test)]
mod tests;

impl crate::data::Dataset {
    /// Writes the dataset as a `.vlb` file, atomically (the format: [`Dataset::to_vlb_bytes`]),
    /// piece by piece: no copy of the voxels is made. Its geometry, if it has one, goes to the
    /// sidecar `path.geom` ([`crate::Geometry`]); a sidecar left there by an earlier file is
    /// removed when it has none. Where `path` is a symbolic link, the file it leads to is
    /// written ([`crate::write_atomic`]) and the sidecar is written or removed beside that
    /// file, not beside the link.
    ///
    /// [`Dataset::to_vlb_bytes`]: crate::data::Dataset::to_vlb_bytes
    pub fn save(&self, path: &std::path::Path) -> Result<()> {
        let mut file = files::AtomicFile::create(path)?;
        file.write(&self.vlb_header())?;
        self.vlb_body(|bytes| file.write(bytes))?;
        // The old sidecar goes before the new file replaces the old one, and the new sidecar
        // comes after: whatever fails between, no file is described by another's geometry.
        // (Both beside the file written, as its path was resolved when the write began: a
        // link's target, not the link.)
        let named = file.named().to_path_buf();
        files::write_sidecar(&named, None)?;
        file.commit()?;
        match self.geometry() {
            Some(g) => files::write_sidecar(&named, Some((g, self.dims()))),
            None => Ok(()),
        }
    }
}

/// Renders every image and voxelization a scene requested and writes the files. Every output
/// is attempted; the first failure is returned (its message counts the others). A cancelled
/// render (`control`) stops at once: the outputs finished before it are written, the one in
/// progress and the rest are not, and its error counts the outputs that failed before. The
/// progress function hears 1 at the end whatever failed. A panic anywhere in it, the progress
/// function's too, is an error ([`crate::error::catch`]). With a `team` the work is split over
/// its ranks (collective: every rank calls it with the same scene).
pub fn render_outputs(
    desc: &SceneDesc,
    caches: &Caches,
    control: &RenderControl,
    team: Option<&Team>,
) -> Result<()> {
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
    let progress = Progress::new(control, total).with_team(team);
    let mut errors: Vec<Error> = Vec::new();
    let cancelled = crate::error::catch("rendering the scene", || {
        // (With a team, a rank that cannot compile the scene fails every rank.)
        let compiled = crate::team::agree(
            team,
            crate::error::catch("compiling the scene", || Compiled::build(desc, caches)),
        )?;
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
    let finished = progress.finish();
    match errors.len() {
        0 => finished,
        1 => Err(errors.remove(0)),
        n => {
            let mut e = errors.remove(0);
            e.message = format!("{} (and {} more output(s) failed)", e.message, n - 1);
            Err(e)
        }
    }
}

/// Renders one requested image, against the backdrop its pixels call for (transparent for
/// RGBA), and writes it. The memory it takes is the file's pixels (the output's own bytes,
/// 3 to 12 a pixel, held whole for the encoder), a strip of the render, and for PNG the
/// encoder's few rows and output chunk (`formats::encode_into`).
/// With a team, rank 0 alone opens and writes the file, and every rank returns its result.
fn image(compiled: &Compiled, req: &ImageRequest, progress: &Progress) -> Result<()> {
    let (w, h) = (req.width, req.height);
    let team = progress.team();
    // A name the file cannot have, or a destination that cannot be written, is refused
    // before rendering.
    let prepared = (|| {
        let format = formats::ImageFormat::from_path(&req.path)?;
        let file = match crate::team::writes(team) {
            true => Some(files::AtomicFile::create(&req.path)?),
            false => None,
        };
        let bytes = format.pixels.image_bytes(w, h);
        let pixels = crate::num::try_vec(bytes.unwrap_or(usize::MAX), 0u8, "the image's pixels")?;
        Ok((format, file, pixels))
    })();
    let (format, file, mut pixels) = crate::team::agree(team, prepared)?;
    render_into(
        compiled,
        (w, h, req.aspect),
        format.pixels,
        progress,
        &mut pixels,
    )?;
    let written = match file {
        // (Caught: with a team, rank 0 alone encodes, and every rank agrees below.)
        Some(file) => crate::error::catch("encoding the image", || {
            formats::encode_into(file, format, w, h, &pixels)
        }),
        None => Ok(()),
    };
    crate::team::agree(team, written)
}
