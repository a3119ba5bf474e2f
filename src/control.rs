//! Progress and cancellation of a render: the options a caller gives ([`RenderControl`]: a
//! [`CancelFlag`] and a progress function) and, per render, the counter of work done that
//! reports to them ([`Progress`]). Part of the base layer: it counts units of work (pixels,
//! voxelized nodes) and knows nothing of scenes; the renderer and the output layer say what a
//! unit is and check for cancellation between and within their pieces of work.
//!
//! A render split over a [`Team`]'s ranks decides to stop only where the ranks exchange their
//! work ([`Progress::map`]), so that every rank stops at the same step: a rank's own flag or
//! progress function stops its work at once ([`Progress::cancelled`]), and the render fails
//! on every rank at the end of that step ([`Progress::check`]).

use crate::error::{Error, ErrorCode, Result};
use crate::team::Team;
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

/// A flag that stops renders: cloned to any thread, [`CancelFlag::cancel`] makes the render in
/// progress (and every later one, until [`CancelFlag::reset`]) stop within a few thousand
/// samples of each ray and fail with [`ErrorCode::Cancelled`], writing no file of the output
/// it was making: a scene's outputs finished before it are written, the rest are not.
#[derive(Clone, Debug, Default)]
pub struct CancelFlag(Arc<AtomicBool>);

impl CancelFlag {
    /// A flag not set.
    pub fn new() -> CancelFlag {
        CancelFlag::default()
    }

    /// Sets the flag.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Clears the flag.
    pub fn reset(&self) {
        self.0.store(false, Ordering::Relaxed);
    }

    /// Whether the flag is set.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// A progress function: called with the fraction of a scene's outputs done, in [0, 1],
/// never decreasing, as an image's tiles end (at most every 0.1 s), between pieces of work (a
/// strip of image rows, a slab of voxelized nodes) and with 1 at the end (also where an output
/// failed), while other rendering threads may be calling field functions; returning `false`
/// cancels the
/// render. It is called on one of the library's rendering threads (the one that called the
/// scene's `end`, `render`, `render_preview` or `render_into` waits meanwhile), one call at a
/// time.
pub type ProgressFn = Arc<dyn Fn(f32) -> bool + Send + Sync>;

/// How a caller follows and stops renders (`Library::set_render_control`).
#[derive(Clone, Default)]
pub struct RenderControl {
    /// Renders stop when it is set.
    pub cancel: Option<CancelFlag>,
    /// Told the progress of each render.
    pub progress: Option<ProgressFn>,
}

impl std::fmt::Debug for RenderControl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RenderControl")
            .field("cancel", &self.cancel)
            .field("progress", &self.progress.as_ref().map(|_| "fn"))
            .finish()
    }
}

/// One render's progress: the units of work it has, those done, and whether it was
/// cancelled. Shared by the threads of the render (checks are atomic loads).
pub(crate) struct Progress {
    control: RenderControl,
    total: u64,
    done: AtomicU64,
    stopped: AtomicBool,
    /// The ranks the render is split over, if any.
    team: Option<Team>,
    /// With a team: every rank has agreed to stop (at a step of [`Progress::map`]).
    agreed_stop: AtomicBool,
    /// With a team: an error this rank met between steps, for the next step (or
    /// [`Progress::settle`]) to fail every rank with ([`Progress::hold`]).
    held: std::sync::Mutex<Option<Error>>,
    /// The units of the piece of work in progress (a strip of an image, [`Progress::begin`]),
    /// the work its tiles do (pixels traced, over every pass) and the work they have reported
    /// done ([`Progress::tile_done`]).
    piece: AtomicU64,
    piece_work: AtomicU64,
    piece_done: AtomicU64,
    /// The last call of the progress function: held while it is called, so that calls come
    /// one at a time.
    told: std::sync::Mutex<Told>,
}

/// When the progress function was last called, and the fraction it heard.
#[derive(Default)]
struct Told {
    at: Option<std::time::Instant>,
    fraction: f32,
}

/// How often at most the progress function hears of tiles done within a strip.
const TELL_EVERY: std::time::Duration = std::time::Duration::from_millis(100);

impl Progress {
    /// A render of `total` units of work followed by `control`.
    pub(crate) fn new(control: &RenderControl, total: u64) -> Progress {
        Progress {
            control: control.clone(),
            total,
            done: AtomicU64::new(0),
            stopped: AtomicBool::new(false),
            team: None,
            agreed_stop: AtomicBool::new(false),
            held: std::sync::Mutex::new(None),
            piece: AtomicU64::new(0),
            piece_work: AtomicU64::new(0),
            piece_done: AtomicU64::new(0),
            told: std::sync::Mutex::new(Told::default()),
        }
    }

    /// The render split over `team`'s ranks (a team of one, or none, is a render of one
    /// process).
    pub(crate) fn with_team(mut self, team: Option<&Team>) -> Progress {
        self.team = team.filter(|t| t.size() > 1).cloned();
        self
    }

    /// The ranks the render is split over, if more than one.
    pub(crate) fn team(&self) -> Option<&Team> {
        self.team.as_ref()
    }

    /// Evaluates `f(i)` for each item `i` in 0 … `n` in parallel, split over the team's ranks
    /// where there is a team ([`crate::team::map`]), and gives every item's result in order;
    /// `Err(Cancelled)` where the render is to stop ([`Progress::check`] after the step).
    /// `f` should return at once (anything) when [`Progress::cancelled`].
    pub(crate) fn map<T, F>(&self, n: usize, f: F) -> Result<Vec<Vec<T>>>
    where
        T: crate::team::Floats,
        F: Fn(usize) -> Vec<T> + Sync + Send,
    {
        let out = crate::team::map(self.team(), n, &|| self.cancelled(), self.take_held(), f);
        match out {
            Err(e) if e.code == ErrorCode::Cancelled => {
                self.agreed_stop.store(true, Ordering::Relaxed);
                Err(e)
            }
            Err(e) => Err(e),
            Ok(v) => {
                self.check()?;
                Ok(v)
            }
        }
    }

    /// An error this rank met outside a step of [`Progress::map`] (a buffer it could not
    /// allocate, a panic in the caller's sink or progress function). Without a team,
    /// `Err(e)`: the render fails at once. With a team, `Ok`: the error is held, the rank
    /// carries on to the next step as the others do, taking no work, and that step fails on
    /// every rank with it ([`crate::team::map`]), or [`Progress::settle`] where no step
    /// follows: the ranks leave the render together instead of one waiting for another that
    /// has gone.
    pub(crate) fn hold<T>(&self, r: Result<T>) -> Result<Option<T>> {
        match r {
            Ok(v) => Ok(Some(v)),
            Err(e) if self.team.is_some() => {
                self.held
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .get_or_insert(e);
                Ok(None)
            }
            Err(e) => Err(e),
        }
    }

    /// Whether this rank holds an error ([`Progress::hold`]): it is to take no more work.
    pub(crate) fn holds(&self) -> bool {
        self.held
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .is_some()
    }

    /// The end of a piece of work with no step after it (collective with a team): the error a
    /// rank holds, on every rank ([`crate::team::agree`]); `Ok` without a team.
    pub(crate) fn settle(&self) -> Result<()> {
        let held = self.take_held();
        crate::team::agree(self.team(), held.map_or(Ok(()), Err))
    }

    /// The error held, taken.
    fn take_held(&self) -> Option<Error> {
        self.held.lock().unwrap_or_else(|p| p.into_inner()).take()
    }

    /// A render nobody follows (tests, internal renders).
    #[cfg(test)]
    pub(crate) fn none() -> Progress {
        Progress::new(&RenderControl::default(), 0)
    }

    /// Whether the render is to stop (its flag set, or its progress function said so).
    #[inline]
    pub(crate) fn cancelled(&self) -> bool {
        self.stopped.load(Ordering::Relaxed)
            || self
                .control
                .cancel
                .as_ref()
                .is_some_and(|c| c.is_cancelled())
    }

    /// `Err(Cancelled)` where the render is to stop: with a team, where the ranks agreed to
    /// at the last step of [`Progress::map`] (so that every rank gives the same answer).
    pub(crate) fn check(&self) -> Result<()> {
        let stop = match &self.team {
            Some(_) => self.agreed_stop.load(Ordering::Relaxed),
            None => self.cancelled(),
        };
        if stop {
            Err(cancelled())
        } else {
            Ok(())
        }
    }

    /// A piece of work of `units` begins (a strip of an image), whose tiles do `work` (the
    /// pixels they trace, over every pass) and report it as they end ([`Progress::tile_done`]);
    /// it ends with [`Progress::advance`] by `units`.
    pub(crate) fn begin(&self, units: u64, work: u64) {
        self.piece_done.store(0, Ordering::Relaxed);
        self.piece_work.store(work, Ordering::Relaxed);
        self.piece.store(units, Ordering::Relaxed);
    }

    /// A tile of the piece of work in progress has done `work` (pixels traced): where
    /// [`TELL_EVERY`] has passed since the progress function was last called and no call is
    /// under way, it hears the fraction done, the piece counted in proportion to its work
    /// done and short of its end by one unit (which [`Progress::advance`] reports). Not with
    /// a team, whose ranks hear of whole steps, nor once the render is to stop. A panic in the
    /// function unwinds as the render's error.
    pub(crate) fn tile_done(&self, work: u64) {
        if self.control.progress.is_none() || self.team.is_some() || self.cancelled() {
            return;
        }
        self.piece_done.fetch_add(work, Ordering::Relaxed);
        let mut told = match self.told.try_lock() {
            Ok(t) => t,
            Err(std::sync::TryLockError::Poisoned(p)) => p.into_inner(),
            Err(std::sync::TryLockError::WouldBlock) => return,
        };
        if told.at.is_some_and(|t| t.elapsed() < TELL_EVERY) {
            return;
        }
        let (units, all) = (
            self.piece.load(Ordering::Relaxed),
            self.piece_work.load(Ordering::Relaxed),
        );
        if units == 0 || all == 0 {
            return;
        }
        let piece = self.piece_done.load(Ordering::Relaxed).min(all);
        let within = (piece as u128 * units as u128 / all as u128) as u64;
        let done = self.done.load(Ordering::Relaxed) + within.min(units - 1);
        let told_now = crate::error::catch("the progress function", || {
            self.tell_at(&mut told, done);
            Ok(())
        });
        if let Err(e) = told_now {
            drop(told);
            crate::error::raise(e);
        }
    }

    /// Counts `units` more done and tells the progress function (called between pieces of
    /// work, never concurrently with itself); `Err(Cancelled)` where the render is to stop.
    pub(crate) fn advance(&self, units: u64) -> Result<()> {
        let done = self.done.fetch_add(units, Ordering::Relaxed) + units;
        self.begin(0, 0);
        self.tell(done);
        self.check()
    }

    /// The render has ended (every output done or failed, none cancelled): where the work
    /// counted falls short of the total (an output failed), the progress function hears 1.
    /// Its answer is not asked for: nothing is left to stop. A panic in it is the error
    /// returned (`Internal`).
    pub(crate) fn finish(&self) -> Result<()> {
        let done = self.done.swap(self.total, Ordering::Relaxed);
        if done < self.total {
            crate::error::catch("the progress function", || {
                self.tell(self.total);
                Ok(())
            })?;
        }
        Ok(())
    }

    /// Tells the progress function the fraction `done` of the total; records a `false`.
    fn tell(&self, done: u64) {
        let mut told = self.told.lock().unwrap_or_else(|p| p.into_inner());
        self.tell_at(&mut told, done);
    }

    /// [`Progress::tell`] with the last call held (`told`): the fraction never below the
    /// last one told (an output that failed leaves its part of the total uncounted, which its
    /// tiles may have told), the call's time now.
    fn tell_at(&self, told: &mut Told, done: u64) {
        told.at = Some(std::time::Instant::now());
        if let Some(f) = &self.control.progress {
            let fraction = if self.total == 0 {
                1.0
            } else {
                (done.min(self.total) as f64 / self.total as f64) as f32
            };
            let fraction = fraction.max(told.fraction);
            told.fraction = fraction;
            // A panic in the function is the render's (caught where the render's are). Its
            // answer to 1 is not asked for: every output is done, nothing is left to stop.
            if !f(fraction) && fraction < 1.0 {
                self.stopped.store(true, Ordering::Relaxed);
            }
        }
    }
}

/// The error of a cancelled render.
pub(crate) fn cancelled() -> Error {
    Error::new(ErrorCode::Cancelled, "the render was cancelled")
}

thread_local! {
    /// The render whose work this thread is doing ([`working_for`]); null outside one.
    static WORKING_FOR: Cell<*const Progress> = const { Cell::new(std::ptr::null()) };
}

/// Runs `f` as work of the render that `progress` follows: while it runs, on this thread,
/// [`stop_requested`] says whether that render is to stop, so that work within a pixel (a
/// ray's march, each of its samples' shadow rays) can end early. Nested calls (a tile stolen
/// by a thread waiting inside another tile) answer for the innermost one, and the outer one
/// is restored when `f` returns or unwinds.
pub(crate) fn working_for<R>(progress: &Progress, f: impl FnOnce() -> R) -> R {
    /// Puts back the render the thread worked for before.
    struct Restore(*const Progress);
    impl Drop for Restore {
        fn drop(&mut self) {
            WORKING_FOR.with(|w| w.set(self.0));
        }
    }
    let _restore = Restore(WORKING_FOR.with(|w| w.replace(progress)));
    f()
}

/// Whether the render this thread is working for ([`working_for`]) is to stop
/// ([`Progress::cancelled`]); `false` outside a render's work.
pub(crate) fn stop_requested() -> bool {
    WORKING_FOR.with(|w| {
        let p = w.get();
        // SAFETY: a non-null pointer was set by `working_for` on this thread from a borrowed
        // `Progress`, which outlives the call of `f` that the pointer is set for; the pointer
        // is restored to the one before (null, or an outer call's, still borrowed) when that
        // call returns or unwinds.
        !p.is_null() && unsafe { &*p }.cancelled()
    })
}
