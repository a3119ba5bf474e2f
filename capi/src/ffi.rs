//! The boundary between C and the core: the panic boundary, the global library state, the scope
//! dispatch every command goes through, and pointer and string helpers. It owns no command and
//! no validation of a command's arguments (the command modules and the core do that), only the
//! mechanics every export shares.
//!
//! ## The panic boundary
//! Every exported function, command or vlaux, has a body that is one call of [`ffi_boundary`]:
//! an `Err` from the core or from argument checks is recorded for `vlError` and a neutral value
//! returned; a panic is caught and recorded as `VL_INTERNAL` (an unwind carrying the core's
//! own error, a cache that could not be allocated, as that error), and its message is not
//! printed (the library never writes to stderr). No error ever crosses into C as anything but a
//! queued code. The helpers below return a `Result` and run inside that call;
//! none of them catches anything itself. A unit test (`tests/exports.rs`) reads the sources and
//! fails on an export whose body does not start with `ffi_boundary(`.
//!
//! ## State and scope
//! The library lives in [`STATE`] (`None` before `vlInit` and after the final `vlEnd`). Scope
//! dispatch ([`dispatch`], [`either`], [`library`]) first asks the thread-local sample context: in
//! sample scope the state is never locked (the rendering `vlEnd` holds it), and which commands are
//! legal comes from `vlib_core::scope`, the one table of legality.

use crate::errors;
use crate::sample;
use std::ffi::OsStr;
use std::os::raw::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard, Once, RwLock};
use vlib_core::scope::require;
use vlib_core::{Command, Error, ErrorCode, Library, Result, Sample, Sampler, Scope};

/// The library of the process, `None` when uninitialised.
static STATE: Mutex<Option<Library>> = Mutex::new(None);

/// Locks the state, recovering from poisoning: the core changes nothing before it has validated
/// a call, and a scene is taken out of the state before it is rendered, so a panic never leaves a
/// half-built value behind.
pub(crate) fn lock_state() -> MutexGuard<'static, Option<Library>> {
    STATE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Whether a command holds the state through a [`StateGuard`]; [`CHANGED`] is notified when it
/// lets it go and when a render starts.
static BUSY: Mutex<bool> = Mutex::new(false);

/// Wakes the commands waiting in [`lock_unless_rendering`].
static CHANGED: Condvar = Condvar::new();

/// The state, locked, for a command ([`lock_unless_rendering`]); letting it go wakes the
/// commands waiting for it.
pub(crate) struct StateGuard {
    /// `None` only while dropped.
    state: Option<MutexGuard<'static, Option<Library>>>,
}

impl std::ops::Deref for StateGuard {
    type Target = Option<Library>;
    fn deref(&self) -> &Option<Library> {
        self.state.as_ref().expect("held")
    }
}

impl std::ops::DerefMut for StateGuard {
    fn deref_mut(&mut self) -> &mut Option<Library> {
        self.state.as_mut().expect("held")
    }
}

impl Drop for StateGuard {
    fn drop(&mut self) {
        drop(self.state.take());
        *BUSY.lock().unwrap_or_else(|e| e.into_inner()) = false;
        CHANGED.notify_all();
    }
}

/// The state, locked ([`lock_state`]), unless a scene is rendering: `None` then, at once, or as
/// soon as a render starts while this waits for the state. A render holds the state until it
/// ends, and nothing waits for a render: a thread blocked on the state's mutex when a render
/// took it would wait for the whole render. So a command waits on a condition variable
/// instead, woken when the command before it lets the state go (it then takes it) and when a
/// render starts (it then returns `None`).
pub(crate) fn lock_unless_rendering() -> Option<StateGuard> {
    let mut busy = BUSY.lock().unwrap_or_else(|e| e.into_inner());
    loop {
        // (Under `BUSY`, which `Rendering::start` takes to notify after it has published the
        // render: a start between this look and the wait below still wakes the wait.)
        if rendering() {
            return None;
        }
        if !*busy {
            *busy = true;
            break;
        }
        busy = CHANGED.wait(busy).unwrap_or_else(|e| e.into_inner());
    }
    drop(busy);
    Some(StateGuard {
        state: Some(lock_state()),
    })
}

/// The state for a command legal only outside renders (an extension that takes the state
/// itself): `VL_BADSCOPE` ("`name`: not while a scene renders") in sample scope or while a
/// scene renders ([`lock_unless_rendering`]).
pub(crate) fn state_outside_render(name: &str) -> Result<StateGuard> {
    if !sample::active() {
        if let Some(state) = lock_unless_rendering() {
            return Ok(state);
        }
    }
    Err(Error::new(
        ErrorCode::BadScope,
        format!("{name}: not while a scene renders"),
    ))
}

/// How many calls are inside [`ffi_boundary`] now, on any thread.
static INSIDE: AtomicUsize = AtomicUsize::new(0);

/// Counts a call inside the boundary until dropped (also when it unwinds).
struct Inside;

impl Inside {
    fn enter() -> Inside {
        INSIDE.fetch_add(1, Ordering::SeqCst);
        Inside
    }
}

impl Drop for Inside {
    fn drop(&mut self) {
        INSIDE.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Installs, once, a panic hook that prints nothing while a call is inside the boundary (on the
/// calling thread or on the render's worker threads) and hands every other panic to the hook
/// that was there before. The library never writes to stderr: a panic's message reaches the
/// user as a `VL_INTERNAL` error (`vlErrorString`), and a host whose stderr is a closed pipe is
/// not killed by `SIGPIPE`.
fn quiet_panics() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if INSIDE.load(Ordering::SeqCst) == 0 {
                previous(info);
            }
        }));
    });
}

/// The panic boundary: runs `f`, turning an `Err` or a panic into a recorded error and `neutral`.
pub(crate) fn ffi_boundary<T>(neutral: T, f: impl FnOnce() -> Result<T>) -> T {
    quiet_panics();
    let _inside = Inside::enter();
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(v)) => v,
        Ok(Err(e)) => {
            errors::record(e);
            neutral
        }
        Err(payload) => {
            // The core unwinds with an `Error` where a cache cannot be allocated (a dataset's
            // node values, say): that error, `VL_NOMEMORY`, is the one recorded.
            errors::record(Error::from_unwind(payload, |msg| {
                format!("panic caught: {msg}")
            }));
            neutral
        }
    }
}

/// Runs command `cmd`: in sample scope `in_sample` gets the current sample (if `cmd` is legal
/// there, else `VL_BADSCOPE` without locking the state); otherwise `outside` gets the locked
/// state.
pub(crate) fn dispatch<T>(
    cmd: Command,
    in_sample: impl FnOnce(&mut Sample<'_>) -> Result<T>,
    outside: impl FnOnce(&mut Option<Library>) -> Result<T>,
) -> Result<T> {
    let sampled = sample::with_current(|s| {
        require(cmd, Scope::Sample)?;
        in_sample(s)
    });
    if let Some(r) = sampled {
        return r;
    }
    match lock_unless_rendering() {
        Some(mut state) => outside(&mut state),
        None => Err(Error::new(
            ErrorCode::BadScope,
            format!(
                "{} while a scene renders: only its field functions' sample-scope commands, \
                 vlSample, vlError and vlErrorString are legal then",
                cmd.name()
            ),
        )),
    }
}

/// While a scene renders (its `vlEnd` holds the state), what `vlSample` reads; `None` otherwise.
/// A thread outside the render's sample scope, such as a helper thread a field function starts,
/// reads this instead of waiting for the state, which the render holds until it ends.
static RENDERING: RwLock<Option<Sampler>> = RwLock::new(None);

/// Whether a scene is being rendered.
pub(crate) fn rendering() -> bool {
    RENDERING
        .read()
        .unwrap_or_else(|e| e.into_inner())
        .is_some()
}

/// The sampler of the scene being rendered, if one is.
pub(crate) fn render_sampler() -> Option<Sampler> {
    RENDERING.read().unwrap_or_else(|e| e.into_inner()).clone()
}

/// Marks a render as running until dropped (also when the render panics).
pub(crate) struct Rendering(());

impl Rendering {
    /// Publishes `sampler` for the threads outside the render, and clears the cancel flag
    /// (`vlCancel` stops only the render in progress).
    pub(crate) fn start(sampler: Sampler) -> Rendering {
        crate::extensions::cancel_flag().reset();
        *RENDERING.write().unwrap_or_else(|e| e.into_inner()) = Some(sampler);
        // The commands waiting for the state return at once (`lock_unless_rendering`).
        let _busy = BUSY.lock().unwrap_or_else(|e| e.into_inner());
        CHANGED.notify_all();
        Rendering(())
    }
}

impl Drop for Rendering {
    fn drop(&mut self) {
        *RENDERING.write().unwrap_or_else(|e| e.into_inner()) = None;
        crate::extensions::cancel_flag().reset();
    }
}

/// The scope of the locked state.
pub(crate) fn scope_of(state: &Option<Library>) -> Scope {
    state.as_ref().map_or(Scope::Uninitialised, Library::scope)
}

/// Runs command `cmd`: in sample scope `in_sample` gets the current sample; otherwise the scope of
/// the state is checked (before any argument is converted, so an illegal call always reports
/// `VL_BADSCOPE`) and `outside` gets the library.
pub(crate) fn either<T>(
    cmd: Command,
    in_sample: impl FnOnce(&mut Sample<'_>) -> Result<T>,
    outside: impl FnOnce(&mut Library) -> Result<T>,
) -> Result<T> {
    dispatch(cmd, in_sample, |state| {
        require(cmd, scope_of(state))?;
        match state {
            Some(lib) => outside(lib),
            None => never(cmd),
        }
    })
}

/// Runs a command that is legal only outside sample scope, in an initialised library.
pub(crate) fn library<T>(cmd: Command, f: impl FnOnce(&mut Library) -> Result<T>) -> Result<T> {
    either(cmd, |_| never(cmd), f)
}

/// The result for a scope that the scope table allows but a command's C form does not handle;
/// unreachable while the table and the command agree.
pub(crate) fn never<T>(cmd: Command) -> Result<T> {
    Err(Error::new(
        ErrorCode::Internal,
        format!("{} has no implementation for this scope", cmd.name()),
    ))
}

/// The error for a NULL argument.
pub(crate) fn null(name: &str, arg: &str) -> Error {
    Error::new(ErrorCode::NullPointer, format!("{name}: {arg} is NULL"))
}

/// Reads `N` floats from a C array.
///
/// # Safety
/// `p` must be NULL or point to `N` readable floats.
pub(crate) unsafe fn read_floats<const N: usize>(
    name: &str,
    arg: &str,
    p: *const f32,
) -> Result<[f32; N]> {
    if p.is_null() {
        return Err(null(name, arg));
    }
    let mut out = [0.0; N];
    // SAFETY: non-NULL, aligned (a C `float *`) and, by the caller's contract, N floats long;
    // `out` is a distinct local array of N floats.
    unsafe { std::ptr::copy_nonoverlapping(p, out.as_mut_ptr(), N) };
    Ok(out)
}

/// The longest path a command accepts, in bytes (1 MiB): far beyond any system's `PATH_MAX`,
/// so no name a file system takes is refused, while the copies a command makes of a name (its
/// extension in lower case, error messages) stay small.
pub(crate) const MAX_PATH_BYTES: usize = 1 << 20;

/// A C string as a path; any bytes are accepted (paths need not be UTF-8). A string longer than
/// [`MAX_PATH_BYTES`] is `BadFile`, found by reading at most one byte past the bound.
///
/// # Safety
/// `s` must be NULL or a NUL-terminated string that outlives the returned reference.
pub(crate) unsafe fn c_path<'a>(name: &str, arg: &str, s: *const c_char) -> Result<&'a Path> {
    if s.is_null() {
        return Err(null(name, arg));
    }
    let mut len = 0;
    // SAFETY: non-NULL and NUL-terminated by the caller's contract: every byte up to the NUL
    // is readable, and the scan stops there.
    while unsafe { *s.add(len) } != 0 {
        if len == MAX_PATH_BYTES {
            return Err(Error::new(
                ErrorCode::BadFile,
                format!("{name}: {arg} is longer than {MAX_PATH_BYTES} bytes"),
            ));
        }
        len += 1;
    }
    // SAFETY: the `len` bytes before the NUL, readable as above; the caller's contract bounds
    // the lifetime `'a`.
    let bytes = unsafe { std::slice::from_raw_parts(s.cast::<u8>(), len) };
    os_str(name, bytes).map(Path::new)
}

#[cfg(unix)]
fn os_str<'a>(_: &str, bytes: &'a [u8]) -> Result<&'a OsStr> {
    use std::os::unix::ffi::OsStrExt;
    Ok(OsStr::from_bytes(bytes))
}

#[cfg(not(unix))]
fn os_str<'a>(name: &str, bytes: &'a [u8]) -> Result<&'a OsStr> {
    // Elsewhere a path must be UTF-8.
    std::str::from_utf8(bytes)
        .map(OsStr::new)
        .map_err(|_| Error::new(ErrorCode::BadFile, format!("{name}: path is not UTF-8")))
}

/// A textual snapshot of the library state ("uninitialised" before `vlInit`), for tests that
/// check a refused call changed nothing. Not callable from a field function (the state is locked
/// by the renderer then): in sample scope it returns "sample scope".
pub fn state_fingerprint() -> String {
    if sample::active() {
        return "sample scope".into();
    }
    match &*lock_state() {
        Some(lib) => lib.fingerprint(),
        None => "uninitialised".into(),
    }
}

#[cfg(test)]
mod tests;
