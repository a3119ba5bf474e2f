//! The library's own thread pool: every parallel part of a render (compiling a scene, the skip
//! grids, the tiles, voxelization) runs on it rather than on rayon's global pool.
//!
//! It is built on first use with `RAYON_NUM_THREADS` threads, else one a core (what rayon's
//! global pool would have), but at most [`THREADS_PER_CORE`] a core: rayon's idle threads
//! look for work by spinning, so threads far beyond the cores only take the cores from the
//! threads that work. Stacks of 8 MiB ([`STACK`]); the pool is kept for later renders. A
//! process that forked after the pool was made has none of its threads, so a pool made by
//! another process is left alone and a new one built. A failure to start the threads is an
//! error of the render that needed them (`VL_NOMEMORY`), and the next render tries again. Work
//! that a pool thread must be able to wait for without running other pool tasks is split over
//! threads of its own ([`fill`]), which only help: where none can start, the caller does it
//! all. Part of the base layer: it knows nothing of scenes.

use crate::error::{Error, ErrorCode, Result};
use std::sync::{Arc, Mutex};

/// The stack of each of the pool's threads, which run the user's field and progress
/// functions: a C program's main thread usually has 8 MiB (Linux's default `ulimit -s`),
/// against the 2 MiB of a thread Rust starts, and a function that runs on the one should run
/// on the other. Address space only: pages are used as the stack grows into them.
const STACK: usize = 8 << 20;

/// The most threads the library's pool has for each core the process may use
/// (`available_parallelism`), whatever `RAYON_NUM_THREADS` asks: a render's work is the
/// processor's, so more threads than cores cannot shorten it, and rayon's idle threads spin
/// looking for work, each look visiting every thread. On two cores, three 64² frames of the
/// MNI brain took 5.7 s on 1000 threads, 24 s on 2000 and more than five minutes on 8000,
/// against 0.13 s on two.
const THREADS_PER_CORE: usize = 4;

/// The pool and the process that built it.
static POOL: Mutex<Option<(u32, Arc<rayon::ThreadPool>)>> = Mutex::new(None);

/// Pools inherited from a parent process, kept (not dropped) and never used.
static STALE: Mutex<Vec<Arc<rayon::ThreadPool>>> = Mutex::new(Vec::new());

/// The pool of this process, built now if there is none.
fn pool() -> Result<Arc<rayon::ThreadPool>> {
    let mut slot = POOL.lock().unwrap_or_else(|e| e.into_inner());
    let pid = std::process::id();
    if let Some((p, pool)) = slot.as_ref() {
        if *p == pid {
            return Ok(pool.clone());
        }
    }
    // Built by the parent of a fork: its threads are not in this process, and dropping it
    // would signal them, so it is kept aside, never used again.
    if let Some((_, inherited)) = slot.take() {
        STALE
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(inherited);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(default_threads())
        .thread_name(|i| format!("vlib-{i}"))
        .stack_size(STACK)
        .build()
        .map_err(|e| {
            Error::new(
                ErrorCode::NoMemory,
                format!("could not start the render's threads: {e}"),
            )
        })?;
    let pool = Arc::new(pool);
    *slot = Some((pid, pool.clone()));
    Ok(pool)
}

/// Runs `f` on the library's pool (on the caller's pool when the caller is a pool's thread
/// already, so that a render inside `ThreadPool::install` uses that pool).
pub(crate) fn install<T: Send>(f: impl FnOnce() -> Result<T> + Send) -> Result<T> {
    if rayon::current_thread_index().is_some() {
        return f();
    }
    pool()?.install(f)
}

/// The threads of the library's pool (of the pool that would be built: [`default_threads`]).
/// Used by teams, which the plain build makes only in tests.
#[cfg_attr(not(any(test, feature = "mpi")), allow(dead_code))]
pub(crate) fn threads() -> usize {
    match pool() {
        Ok(p) => p.current_num_threads(),
        Err(_) => default_threads(),
    }
}

/// The number of threads to split work over, starting none: the caller's pool's where the
/// caller is a pool's thread, else the library pool's, built or not. (Not
/// `rayon::current_num_threads`, which from outside a pool builds rayon's global pool, once
/// for the process: a failure to start its threads then lasts.)
pub(crate) fn width() -> usize {
    if rayon::current_thread_index().is_some() {
        return rayon::current_num_threads();
    }
    let slot = POOL.lock().unwrap_or_else(|e| e.into_inner());
    match slot.as_ref() {
        Some((pid, pool)) if *pid == std::process::id() => pool.current_num_threads(),
        _ => default_threads(),
    }
}

/// The threads of the library's pool: `RAYON_NUM_THREADS` where it is a positive number (spaces
/// around it allowed), else one a core (at least one), and at most [`THREADS_PER_CORE`] a core.
fn default_threads() -> usize {
    threads_for(
        std::env::var("RAYON_NUM_THREADS").ok().as_deref(),
        std::thread::available_parallelism().map_or(1, |n| n.get()),
    )
}

/// [`default_threads`] for the variable's value `asked` on `cores` cores.
fn threads_for(asked: Option<&str>, cores: usize) -> usize {
    let cores = cores.max(1);
    asked
        .and_then(|s| s.trim().parse::<usize>().ok())
        .filter(|&n| n > 0)
        .map_or(cores, |n| n.min(cores.saturating_mul(THREADS_PER_CORE)))
}

/// `cell`'s value, made by `make` where it has none yet: for a cache whose making runs parallel
/// work on a pool. `make` runs holding no lock. A pool thread waiting for the parts of its work
/// runs other tasks of the pool meanwhile, and one of them may ask for the same cache (another
/// render sharing the dataset or the scene): waiting for the making it sits inside would never
/// end (`OnceLock::get_or_init` and `Mutex::lock` are not re-entrant). Here that task makes the
/// value itself. So threads asking at once may each make it; the first stored is kept and
/// returned to all, and the others' are dropped. An error is returned and nothing kept (a later
/// call tries again).
pub(crate) fn try_once<T, E>(
    cell: &std::sync::OnceLock<T>,
    make: impl FnOnce() -> std::result::Result<T, E>,
) -> std::result::Result<&T, E> {
    if let Some(v) = cell.get() {
        return Ok(v);
    }
    let made = make()?;
    // (Where another thread stored its value first, `set` hands ours back, dropped here.)
    let _ = cell.set(made);
    Ok(cell.get().expect("a value was stored"))
}

/// [`try_once`] for a `make` that cannot fail.
pub(crate) fn once<T>(cell: &std::sync::OnceLock<T>, make: impl FnOnce() -> T) -> &T {
    match try_once(cell, || Ok::<T, std::convert::Infallible>(make())) {
        Ok(v) => v,
        Err(never) => match never {},
    }
}

/// Writes every element of `out` by `write(part, from)` over parts of `chunk` elements (part
/// k from element k·chunk), on up to `threads` threads of their own (not the pool's, so that
/// the caller may wait for them inside a pool task): the calling thread and the others take
/// parts in turn until none is left. A thread that cannot start leaves its parts to the
/// threads that did, the caller's at least, so every element is written even where no other
/// thread starts. Which thread writes a part changes nothing of what it writes.
pub(crate) fn fill<T: Send>(
    out: &mut [std::mem::MaybeUninit<T>],
    chunk: usize,
    threads: usize,
    write: impl Fn(&mut [std::mem::MaybeUninit<T>], usize) + Sync,
) {
    use std::sync::atomic::{AtomicUsize, Ordering};
    /// The start of `out`, shared by the threads: each writes only the parts it takes.
    struct Start<T>(*mut std::mem::MaybeUninit<T>);
    // SAFETY: the threads reach the memory only through the disjoint parts `work` takes.
    unsafe impl<T: Send> Sync for Start<T> {}
    impl<T> Start<T> {
        fn at(&self, from: usize) -> *mut std::mem::MaybeUninit<T> {
            // SAFETY: `from` is a part's start, inside `out` (`work`).
            unsafe { self.0.add(from) }
        }
    }
    let (len, chunk) = (out.len(), chunk.max(1));
    let parts = len.div_ceil(chunk);
    let next = AtomicUsize::new(0);
    let start = Start(out.as_mut_ptr());
    let work = || loop {
        let k = next.fetch_add(1, Ordering::Relaxed);
        if k >= parts {
            break;
        }
        let from = k * chunk;
        let n = chunk.min(len - from);
        // SAFETY: part k, elements from … from + n − 1 of `out` (from < len), is taken by
        // this thread alone (`fetch_add` gives each k once), and `out` is borrowed mutably
        // for the whole scope.
        let part = unsafe { std::slice::from_raw_parts_mut(start.at(from), n) };
        write(part, from);
    };
    std::thread::scope(|scope| {
        for _ in 1..threads.min(parts) {
            if spawn_scoped(scope, work).is_err() {
                break;
            }
        }
        work();
    });
}

/// `Builder::spawn_scoped` of `f` in `scope` (in tests, failing where `FAIL_SPAWNS` says
/// so).
fn spawn_scoped<'scope, 'env>(
    scope: &'scope std::thread::Scope<'scope, 'env>,
    f: impl FnOnce() + Send + 'scope,
) -> std::io::Result<()> {
    #[cfg(test)]
    if FAIL_SPAWNS.with(|f| f.get()) {
        return Err(std::io::Error::other("no thread (a test)"));
    }
    std::thread::Builder::new()
        .spawn_scoped(scope, f)
        .map(|_| ())
}

#[cfg(test)]
thread_local! {
    /// In tests: whether [`spawn_scoped`] fails on this thread, as where no thread can start.
    pub(crate) static FAIL_SPAWNS: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

#[cfg(test)]
mod tests;
