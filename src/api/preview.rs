//! What the Rust API adds to the commands, at library or scene scope: rendering the open scene
//! to memory ([`Library::render`], [`Library::render_into`] a caller's buffer, which the C
//! extension `vlRenderBuffer` uses), its render plan ([`Library::render_plan`]), the
//! pixel-preserving speed-ups ([`Library::set_optimise`]), progress and cancellation
//! ([`Library::set_render_control`]), the ranks renders are split over ([`Library::set_team`])
//! and a snapshot of the state for tests
//! ([`Library::fingerprint`]). None of these is a command of the C API; only `set_optimise`
//! and `set_render_control` change state, and a render fills the open scene's caches, nothing
//! else.

use super::library::{positive, Library, MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE};
use crate::api::scope::Scope;
use crate::error::{err, Error, ErrorCode, Result};
use crate::model::scene::SceneDesc;
use crate::render::{Backdrop, Image, PixelFormat};

impl Library {
    /// Renders the open scene (at scene scope) to an image in memory, without closing it or
    /// writing its outputs: `width × height` pixels (each side 1 … [`MAX_IMAGE_SIDE`], at most
    /// [`MAX_IMAGE_PIXELS`] in all, else `BadValue`) whose view plane has the width / height
    /// `aspect` (positive, else `BadValue`), as `vlImage` would render it; against `backdrop`
    /// ([`Backdrop::Background`] for what an RGB file shows, [`Backdrop::Transparent`] for
    /// colour over black and alpha `1 − T`, what an RGBA file holds: `docs/images.md`). It
    /// follows [`Library::set_render_control`] like a scene's `end`. Not a command of the C
    /// API (its extension `vlRenderBuffer` renders into a buffer: [`Library::render_into`]).
    pub fn render(
        &self,
        width: u32,
        height: u32,
        aspect: f32,
        backdrop: Backdrop,
    ) -> Result<Image> {
        // (With a team, a rank whose arguments or scope are refused takes part in the first
        // agreement with its error, so every rank fails instead of the others waiting.)
        let desc = self
            .open_scene("render")
            .and_then(|desc| check_size("render", width, height, aspect).map(|()| desc));
        if let (Err(e), None) = (&desc, &self.team) {
            return Err(e.clone());
        }
        crate::pool::install(|| {
            let progress =
                crate::control::Progress::new(&self.control, width as u64 * height as u64)
                    .with_team(self.team.as_ref());
            // (With a team, a rank that cannot compile the scene fails every rank.)
            let compiled = desc.and_then(|desc| {
                crate::error::catch("compiling the scene", || self.compile(&desc))
            });
            let scene = crate::team::agree(progress.team(), compiled)?;
            crate::render::render_image(&scene, (width, height, aspect), backdrop, &progress)
        })
    }

    /// [`Library::render`] against the background: the image an RGB file of the scene shows.
    pub fn render_preview(&self, width: u32, height: u32, aspect: f32) -> Result<Image> {
        self.render(width, height, aspect, Backdrop::Background)
    }

    /// Renders the open scene (at scene scope) as [`Library::render`] does, against the
    /// backdrop of `format` ([`PixelFormat::backdrop`]), into `buffer`: its first
    /// [`PixelFormat::image_bytes`] bytes get the pixels in `format` (row-major, top row first,
    /// the machine's byte order: [`Image::to_bytes`], byte for byte), the rest is left as it
    /// is. A buffer shorter than that is refused with `BadValue`, and so are the sizes
    /// `render` refuses; a refused call writes nothing. Rows are written a strip at a time
    /// as they are finished: where the render fails after it started (`Cancelled`,
    /// `NoMemory`, `Internal`), the rows finished before it are written and the others left
    /// as they were. No memory beyond a strip of the render is taken (about 2²⁰ pixels).
    pub fn render_into(
        &self,
        width: u32,
        height: u32,
        aspect: f32,
        format: PixelFormat,
        buffer: &mut [u8],
    ) -> Result<()> {
        let needed = format.image_bytes(width, height);
        // (With a team, checked with the compile below: a rank whose scope, sizes or buffer
        // are refused fails every rank, instead of the others waiting for it.)
        let fits = self.open_scene("render_into").and_then(|desc| {
            check_size("render_into", width, height, aspect)?;
            let bytes = needed.filter(|&n| n <= buffer.len()).ok_or_else(|| {
                crate::error::Error::new(
                    ErrorCode::BadValue,
                    format!(
                        "render_into: a {width}x{height} image of {format:?} takes {} bytes, \
                         the buffer has {}",
                        needed.map_or("more than usize::MAX".into(), |n| n.to_string()),
                        buffer.len()
                    ),
                )
            })?;
            Ok((desc, bytes))
        });
        if let (Err(e), None) = (&fits, &self.team) {
            return Err(e.clone());
        }
        crate::pool::install(|| {
            let progress =
                crate::control::Progress::new(&self.control, width as u64 * height as u64)
                    .with_team(self.team.as_ref());
            // (With a team, a rank that cannot compile the scene fails every rank.)
            let compiled = fits.and_then(|(desc, bytes)| {
                let scene = crate::error::catch("compiling the scene", || self.compile(&desc))?;
                Ok((bytes, scene))
            });
            let (bytes, scene) = crate::team::agree(progress.team(), compiled)?;
            let buffer = &mut buffer[..bytes];
            crate::render::render_into(&scene, (width, height, aspect), format, &progress, buffer)
        })
    }

    /// The open scene (at scene scope) compiled as it would render now (for tests of the
    /// renderer's internals).
    #[cfg(test)]
    pub(crate) fn compiled(&self) -> Result<crate::render::Compiled> {
        self.compile(&self.open_scene("compiled")?)
    }

    /// `desc`, the open scene, compiled with the scene's caches (empty-space grids,
    /// pre-integration tables).
    fn compile(&self, desc: &SceneDesc) -> Result<crate::render::Compiled> {
        let caches = &self.scene.as_ref().expect("scene scope").caches;
        crate::render::Compiled::build(desc, caches)
    }

    /// The open scene (at scene scope) as it would render now, without its outputs.
    pub(crate) fn open_scene(&self, what: &str) -> Result<SceneDesc> {
        if self.scope() != Scope::Scene {
            return err(
                ErrorCode::BadScope,
                format!("{what} needs an open scene outside objects"),
            );
        }
        let s = self.scene.as_ref().expect("scene scope");
        Ok(SceneDesc {
            settings: s.settings.clone(),
            lights: s.lights.clone(),
            images: Vec::new(),
            volumes: Vec::new(),
            objects: s.objects.clone(),
            datasets: self.datasets.clone(),
        })
    }

    /// The render plan the open scene compiles to (which effects it calls for); at scene scope.
    /// Not a command of the C API.
    pub fn render_plan(&self) -> Result<crate::render::Plan> {
        let desc = self.open_scene("render_plan")?;
        crate::pool::install(|| Ok(self.compile(&desc)?.plan()))
    }

    /// Switches the pixel-preserving speed-ups (empty-space skipping, early ray termination)
    /// on or off, for benchmarks, and sets early termination's threshold; at library or scene
    /// scope like the other settings. A threshold outside [0, 1) (NaN included) is refused
    /// with `BadValue` and nothing changes. Not a command of the C API.
    pub fn set_optimise(&mut self, optimise: crate::model::scene::Optimise) -> Result<()> {
        if !matches!(self.scope(), Scope::Library | Scope::Scene) {
            return err(
                ErrorCode::BadScope,
                "set_optimise: library or scene scope only",
            );
        }
        let t = optimise.termination;
        if !(0.0..1.0).contains(&t) {
            return err(
                ErrorCode::BadValue,
                format!("set_optimise: termination {t} (a transmittance in [0, 1))"),
            );
        }
        self.settings_mut().optimise = optimise;
        Ok(())
    }

    /// Sets how renders are followed and stopped, at any scope: a [`crate::CancelFlag`] that
    /// stops a render from any thread, and a progress function called with the fraction done
    /// on one of the library's rendering threads (returning `false` cancels; see
    /// [`crate::ProgressFn`]). They apply to the scene's outputs at
    /// its `end` and to [`Library::render`] and [`Library::render_into`]; a cancelled render fails with
    /// [`ErrorCode::Cancelled`] and writes no file of the output it was making (outputs
    /// finished before it are written). Not a command of the C API (its extensions
    /// `vlProgress` and `vlCancel` use it).
    pub fn set_render_control(&mut self, control: crate::control::RenderControl) {
        self.control = control;
    }

    /// Splits the renders of this library over the ranks of `team` (`None`: this process
    /// renders alone), at any scope: each scene's outputs at its `end`, and [`Library::render`]
    /// and [`Library::render_into`], whose pixels every rank gets. Rank 0 alone writes files;
    /// every rank must make the same calls (the renders are collective), and every rank's
    /// render ends with the same result (docs/mpi.md). A team of one renders as no team does.
    /// Not a command of the C API (the MPI build of the C library sets it at `vlInit`).
    pub fn set_team(&mut self, team: Option<crate::team::Team>) {
        self.team = team;
    }

    /// The team renders are split over ([`Library::set_team`]).
    pub fn team(&self) -> Option<&crate::team::Team> {
        self.team.as_ref()
    }

    /// Where this library renders with a team, a render call this rank refused before it
    /// reached [`Library::render`] or [`Library::render_into`] (a C layer's checks of its
    /// arguments) takes part in the render's first agreement with its error `error`, as those
    /// functions do with their own refusals, so that every rank's call fails with the error of
    /// the first rank that refused instead of the others waiting; the error this rank's call
    /// reports. Without a team, `error`. For the C interface's `vlRenderBuffer`.
    #[doc(hidden)]
    pub fn refuse_render(&self, error: Error) -> Error {
        crate::team::agree(self.team.as_ref(), Err::<(), _>(error.clone()))
            .err()
            .unwrap_or(error)
    }

    /// A textual snapshot of the whole state, for tests that check a refused call changed
    /// nothing.
    #[doc(hidden)]
    pub fn fingerprint(&self) -> String {
        format!("{self:?}")
    }
}

/// Accepts the size and aspect of an image rendered to memory: each side 1 …
/// [`MAX_IMAGE_SIDE`], at most [`MAX_IMAGE_PIXELS`] pixels, a positive finite aspect; else
/// `BadValue`.
fn check_size(what: &str, width: u32, height: u32, aspect: f32) -> Result<()> {
    positive(what, &[aspect])?;
    let side = 1..=MAX_IMAGE_SIDE as u32;
    if !side.contains(&width)
        || !side.contains(&height)
        || width as u64 * height as u64 > MAX_IMAGE_PIXELS
    {
        return err(
            ErrorCode::BadValue,
            format!(
                "{what}: size {width}x{height} (each side 1 … {MAX_IMAGE_SIDE}, at most \
                 {MAX_IMAGE_PIXELS} pixels)"
            ),
        );
    }
    Ok(())
}
