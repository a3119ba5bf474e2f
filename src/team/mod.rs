//! Rendering split over the processes of a job (a [`Team`]: the ranks of an MPI communicator,
//! docs/mpi.md). Part of the base layer: it hands out numbered items of work (tiles, slabs of
//! voxelized nodes; what an item is, the renderer and the output layer say) dynamically among
//! the ranks, and gives every rank every item's result, in item order; it agrees the ranks'
//! errors. It knows nothing of scenes, pixels or files.
//!
//! [`map`] is one collective step: every rank calls it with the same count of items; each
//! rank's threads take items from one counter the team shares (an atomic fetch-and-add, so a
//! rank that finishes its items early takes more: dynamic load balance), evaluate them, and at
//! the end every rank sends the results it made to every other (an all-gather). The results
//! are put in item order whichever rank made them, so the bytes of an image do not depend on
//! the number of ranks or on who rendered what. Each rank also sends its status (done,
//! stopped, failed with an error), so every rank comes out of a step with the same answer:
//! cancelling on one rank cancels the render on all of them at the end of the step in
//! progress, and an error on one rank, in the step or held from between steps
//! (`Progress::hold`), fails it on all of them. [`agree`] does the same for a result made
//! outside the steps; [`exchange`] agrees that every rank can hold what it is about to
//! receive. So no rank leaves a render while another still waits for it.
//!
//! The counter only grows: each step knows where it started (`base`) and, from the sum of
//! every rank's additions that the all-gather carries, where the next one starts.
//!
//! The transport is a [`Link`]: MPI (`mpi.rs`, the `mpi` feature) or, in the unit tests,
//! threads of one process.

use crate::error::{Error, ErrorCode, Result};
use rayon::prelude::*;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

#[cfg(feature = "mpi")]
mod mpi;

#[cfg(test)]
mod tests;

/// What a team's transport does: the MPI communicator's operations [`map`] and [`agree`] need.
/// Every method but `fetch_add` is collective: every rank calls it, in the same order. A
/// failure of the transport itself (an MPI error) is an `Internal` error, not an abort.
pub(crate) trait Link: Send + Sync {
    /// This process's rank, 0 … `size()` − 1.
    fn rank(&self) -> usize;
    /// The number of ranks.
    fn size(&self) -> usize;
    /// Adds `n` to the team's counter and returns its value before (atomically across ranks).
    fn fetch_add(&self, n: u64) -> Result<u64>;
    /// Every rank's `mine` (each of the same length on every rank), rank after rank.
    fn gather_u64(&self, mine: &[u64]) -> Result<Vec<u64>>;
    /// Every rank's `mine`, rank after rank, into `out` (the sum of `counts` long); `counts[r]`
    /// is the length of rank r's.
    fn gather_f32(&self, mine: &[f32], counts: &[usize], out: &mut [f32]) -> Result<()>;
    /// As [`Link::gather_f32`], for bytes.
    fn gather_u8(&self, mine: &[u8], counts: &[usize], out: &mut [u8]) -> Result<()>;
}

/// Every rank's `mine` by `gather` ([`Link::gather_f32`] or [`Link::gather_u8`]), `counts` by
/// rank, into a buffer this allocates: where any rank cannot allocate its buffer, every rank
/// fails with `NoMemory` before any data moves (collective).
fn exchange<T: Copy + Default + Send + Sync>(
    link: &dyn Link,
    mine: &[T],
    counts: &[usize],
    gather: impl FnOnce(&[T], &[usize], &mut [T]) -> Result<()>,
) -> Result<Vec<T>> {
    let total = counts
        .iter()
        .try_fold(0usize, |a, &c| a.checked_add(c))
        .unwrap_or(usize::MAX);
    let (out, own) = match crate::num::try_vec(total, T::default(), "a team's exchange") {
        Ok(v) => (Some(v), None),
        Err(e) => (None, Some(e)),
    };
    // (This rank's own error where it is one that failed.)
    let mut out =
        all_hold(link, out, total.checked_mul(size_of::<T>())).map_err(|e| own.unwrap_or(e))?;
    gather(mine, counts, &mut out)?;
    Ok(out)
}

/// `here` (this rank's memory for an exchange, `None` where it could not be had) where every
/// rank holds its own, else `NoMemory` on every rank, naming the first rank that does not and
/// the exchange's `bytes` (collective: before any data moves).
fn all_hold<T>(link: &dyn Link, here: Option<T>, bytes: Option<usize>) -> Result<T> {
    let ok = link.gather_u64(&[here.is_some() as u64])?;
    match (here, ok.iter().position(|&v| v != 1)) {
        (Some(v), None) => Ok(v),
        (_, r) => Err(crate::num::no_memory(
            &format!("a team's exchange (on rank {})", r.unwrap_or(link.rank())),
            bytes,
        )),
    }
}

/// The ranks of a job that render together: every scene a `Library` with a team
/// renders is split among them (`Library::set_team`), rank 0 writes the files, and every rank
/// gets every image's pixels. Cloning it shares it.
#[derive(Clone)]
pub struct Team(Arc<Inner>);

struct Inner {
    link: Box<dyn Link>,
    /// The threads of every rank, summed.
    threads: usize,
    /// The counter's value where the next step starts, and the ranks' statistics.
    state: Mutex<State>,
}

#[derive(Default)]
struct State {
    base: u64,
    stats: Vec<RankStats>,
    /// The buffers of the steps' exchanges, kept from one step to the next ([`Buffers`]).
    buffers: Buffers,
}

/// What a rank sends in a step's exchange (its items' values) and what it receives (every
/// rank's), kept from one step to the next so that a render's steps, frame after frame, reuse
/// memory whose pages are already there (fresh pages cost more than the copy). Each holds the
/// largest exchange of the team's steps so far: at most a strip of the image (about 2²⁰
/// pixels of four f32, 16 MiB; a rank may send all of it) or a slab of voxelized nodes,
/// released with the team.
#[derive(Default)]
struct Buffers {
    send: Vec<f32>,
    recv: Vec<f32>,
}

/// `v` with `len` elements (its first `len`; zeros where it grows), without failing where its
/// memory cannot be had: `None` then, and `v` is dropped.
fn sized(mut v: Vec<f32>, len: usize) -> Option<Vec<f32>> {
    if len > v.len() && v.try_reserve_exact(len - v.len()).is_err() {
        return None;
    }
    v.resize(len, 0.0);
    Some(v)
}

/// The buffers of a step's values made from those the team kept (`kept`): `send` `floats`
/// long (this rank's values), `recv` the sum of `counts` (every rank's, by rank). Where any
/// rank cannot hold its two, every rank fails with `NoMemory` before any data moves, and the
/// memory kept is released (collective).
fn buffers_for(link: &dyn Link, kept: Buffers, floats: usize, counts: &[usize]) -> Result<Buffers> {
    let total = counts.iter().try_fold(0usize, |a, &c| a.checked_add(c));
    let send = sized(kept.send, floats);
    let recv = total.and_then(|t| sized(kept.recv, t));
    let bytes = total.and_then(|t| t.checked_mul(size_of::<f32>()));
    let (send, recv) = all_hold(link, send.zip(recv), bytes)?;
    Ok(Buffers { send, recv })
}

/// What one rank of a [`Team`] has done since the team was made: the sum over its threads of
/// the time spent on items of work (tiles, slabs of voxelized nodes), and their number.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RankStats {
    /// Time in items of work, summed over the rank's threads.
    pub busy: Duration,
    /// Items of work done.
    pub items: u64,
}

impl std::fmt::Debug for Team {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Team")
            .field("rank", &self.rank())
            .field("size", &self.size())
            .finish()
    }
}

impl Team {
    /// The team over `link`; collective (the ranks tell each other their threads). Without the
    /// `mpi` feature only the tests make teams.
    #[cfg_attr(not(any(test, feature = "mpi")), allow(dead_code))]
    pub(crate) fn from_link(link: Box<dyn Link>) -> Result<Team> {
        let stats = vec![RankStats::default(); link.size()];
        let threads = link
            .gather_u64(&[crate::pool::threads() as u64])?
            .iter()
            .sum::<u64>() as usize;
        Ok(Team(Arc::new(Inner {
            link,
            threads,
            state: Mutex::new(State {
                base: 0,
                stats,
                buffers: Buffers::default(),
            }),
        })))
    }

    /// This process's rank: 0 writes the files.
    pub fn rank(&self) -> usize {
        self.0.link.rank()
    }

    /// The number of ranks.
    pub fn size(&self) -> usize {
        self.0.link.size()
    }

    /// The threads of the library's pools of every rank, summed (what the tile sizes are
    /// chosen for).
    pub fn threads(&self) -> usize {
        self.0.threads
    }

    /// Every rank's `mine`, by rank (collective: every rank of the team calls it, in the same
    /// order as every other collective call of the team). Errors, the same on every rank:
    /// `NoMemory` where a rank cannot hold them all, `Internal` where MPI fails.
    pub fn gather(&self, mine: &[u8]) -> Result<Vec<Vec<u8>>> {
        let link = &*self.0.link;
        let counts: Vec<usize> = link
            .gather_u64(&[mine.len() as u64])?
            .iter()
            .map(|&c| c as usize)
            .collect();
        let all = exchange(link, mine, &counts, |m, c, o| link.gather_u8(m, c, o))?;
        let mut at = 0;
        Ok(counts
            .iter()
            .map(|&c| {
                at += c;
                all[at - c..at].to_vec()
            })
            .collect())
    }

    /// Every rank's statistics, by rank, as of the last step of work (the same on every rank).
    pub fn stats(&self) -> Vec<RankStats> {
        self.state().stats.clone()
    }

    /// The statistics as text, a line per rank (`rank busy_seconds items`), after a header
    /// line: what `VLIB_MPI_BUSY` writes (docs/mpi.md).
    pub fn stats_text(&self) -> String {
        let mut s = String::from("# rank busy_seconds items\n");
        for (r, st) in self.stats().iter().enumerate() {
            s += &format!("{r} {:.6} {}\n", st.busy.as_secs_f64(), st.items);
        }
        s
    }

    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        self.0.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// A value an item of work gives: a fixed number of `f32`s (a pixel, a voxelized node's
/// fields), the form in which results travel between ranks.
pub(crate) trait Floats: Copy + Send + Sync {
    /// Its `f32`s.
    const N: usize;
    /// Writes its `f32`s to `out`, [`Floats::N`] long.
    fn put(&self, out: &mut [f32]);
    fn get(from: &[f32]) -> Self;
}

impl<const K: usize> Floats for [f32; K] {
    const N: usize = K;
    fn put(&self, out: &mut [f32]) {
        out.copy_from_slice(self);
    }
    fn get(from: &[f32]) -> Self {
        let mut v = [0.0; K];
        v.copy_from_slice(&from[..K]);
        v
    }
}

/// How a step ended on a rank, as the all-gather carries it.
const DONE: u64 = 0;
const STOPPED: u64 = 1;
const FAILED: u64 = 2;

/// Evaluates `f(i)` for every item `i` in 0 … `n`, in parallel: on the library's threads
/// without a team (or a team of one), else split dynamically over the team's ranks ([the
/// module](self)). Every rank gets every item's result, in item order. `stop()` says that this
/// rank is to stop (it takes no more items); then, with a team, every rank fails with
/// `Cancelled` at the end of the step. Without a team, the caller checks for cancellation: an
/// item `f` skipped is whatever `f` returned.
///
/// With a team, a failure on one rank fails the step on every rank, with that rank's error
/// (the first failing rank's, by rank, "on rank r"): `held`, an error the rank met since its
/// last step (it then takes no item), an error or panic in `f` (a panic is `Internal`; an
/// error raised by [`crate::error::raise`], such as `NoMemory` for a cache, keeps its code),
/// or the memory for the results. Without a team, `held` is returned as it is and a panic in
/// `f` unwinds to the caller's `catch`.
pub(crate) fn map<T, F>(
    team: Option<&Team>,
    n: usize,
    stop: &(dyn Fn() -> bool + Sync),
    held: Option<Error>,
    f: F,
) -> Result<Vec<Vec<T>>>
where
    T: Floats,
    F: Fn(usize) -> Vec<T> + Sync + Send,
{
    let Some(team) = team.filter(|t| t.size() > 1) else {
        if let Some(e) = held {
            return Err(e);
        }
        return Ok((0..n).into_par_iter().with_max_len(1).map(f).collect());
    };
    let link = &*team.0.link;
    let base = team.state().base;
    // The results' slots, before any work: a rank that cannot hold them fails the step.
    let mut out: Vec<Option<Vec<T>>> = Vec::new();
    let failure: Mutex<Option<Error>> = Mutex::new(held);
    if out.try_reserve_exact(n).is_err() {
        fail(
            &failure,
            crate::num::no_memory("the results of a step of work", None),
        );
    }
    // This rank's part: items as they are taken, whatever thread took them.
    let mine: Mutex<Vec<(usize, Vec<T>)>> = Mutex::new(Vec::new());
    let added = std::sync::atomic::AtomicU64::new(0);
    let busy = std::sync::atomic::AtomicU64::new(0);
    let failed = std::sync::atomic::AtomicBool::new(lock(&failure).is_some());
    let fetch_lock = Mutex::new(());
    // One fetch at a time on a rank (the MPI library is asked for serialised calls only).
    let fetch = |k: u64| -> Result<u64> {
        let _one = lock(&fetch_lock);
        added.fetch_add(k, std::sync::atomic::Ordering::Relaxed);
        link.fetch_add(k)
    };
    let worker = || loop {
        if stop() || failed.load(std::sync::atomic::Ordering::Relaxed) {
            // Every rank's next fetch passes the end: the team stops within an item.
            if let Err(e) = fetch(n as u64) {
                fail(&failure, e);
            }
            return;
        }
        let i = match fetch(1) {
            Ok(v) => v - base,
            Err(e) => {
                fail(&failure, e);
                failed.store(true, std::sync::atomic::Ordering::Relaxed);
                return;
            }
        };
        if i >= n as u64 {
            return;
        }
        let start = Instant::now();
        let result = crate::error::catch("rendering", || Ok(f(i as usize)));
        busy.fetch_add(
            start.elapsed().as_nanos() as u64,
            std::sync::atomic::Ordering::Relaxed,
        );
        match result {
            Ok(v) => lock(&mine).push((i as usize, v)),
            Err(e) => {
                fail(&failure, e);
                failed.store(true, std::sync::atomic::Ordering::Relaxed);
            }
        }
    };
    rayon::broadcast(|_| worker());
    let mine = mine.into_inner().unwrap_or_else(|e| e.into_inner());
    let failure = failure.into_inner().unwrap_or_else(|e| e.into_inner());
    let (status, code, message) = match &failure {
        Some(e) => (FAILED, e.code as i32 as u64, e.message.as_bytes()),
        None if stop() => (STOPPED, 0, &[][..]),
        None => (DONE, 0, &[][..]),
    };
    // The step's exchange: each rank's status, additions to the counter, busy time, items,
    // values and error; then, where a rank failed, the errors' messages, else the items'
    // numbers and lengths, then their values.
    let floats: usize = mine.iter().map(|(_, v)| v.len() * T::N).sum();
    let heads = link.gather_u64(&[
        status,
        added.into_inner(),
        busy.into_inner(),
        mine.len() as u64,
        floats as u64,
        code,
        message.len() as u64,
    ])?;
    let heads: Vec<&[u64]> = heads.chunks(7).collect();
    let buffers = {
        let mut state = team.state();
        state.base = base + heads.iter().map(|h| h[1]).sum::<u64>();
        for (s, h) in state.stats.iter_mut().zip(&heads) {
            s.busy += Duration::from_nanos(h[2]);
            s.items += h[3];
        }
        std::mem::take(&mut state.buffers)
    };
    if let Some(r) = heads.iter().position(|h| h[0] == FAILED) {
        let counts: Vec<usize> = heads.iter().map(|h| h[6] as usize).collect();
        let messages = exchange(link, message, &counts, |m, c, o| link.gather_u8(m, c, o))?;
        return Err(rank_error(
            team,
            r,
            heads[r][5],
            &messages,
            &counts,
            failure,
        ));
    }
    if heads.iter().any(|h| h[0] == STOPPED) {
        return Err(crate::control::cancelled());
    }
    let index_counts: Vec<usize> = heads.iter().map(|h| h[3] as usize * 2).collect();
    let value_counts: Vec<usize> = heads.iter().map(|h| h[4] as usize).collect();
    let index: Vec<u64> = mine
        .iter()
        .flat_map(|(i, v)| [*i as u64, v.len() as u64])
        .collect();
    let all_index = gather_index(link, &index, &index_counts)?;
    // The values, through the buffers the team keeps: this rank's items' in `send`, every
    // rank's into `recv`.
    let Buffers { mut send, mut recv } = buffers_for(link, buffers, floats, &value_counts)?;
    let mut at = 0;
    for (_, v) in &mine {
        for x in v {
            x.put(&mut send[at..at + T::N]);
            at += T::N;
        }
    }
    link.gather_f32(&send, &value_counts, &mut recv)?;
    // Every item once, in order, whichever rank made it: this rank's as they were made, the
    // others' from what came.
    let me = team.rank();
    let mut mine = mine.into_iter();
    out.resize_with(n, || None);
    let (mut pairs, mut at) = (all_index.chunks_exact(2), 0);
    for (r, &count) in index_counts.iter().enumerate() {
        for pair in pairs.by_ref().take(count / 2) {
            let (i, len) = (pair[0] as usize, pair[1] as usize);
            let floats = len * T::N;
            let v = if r == me {
                mine.next().map(|(_, v)| v).unwrap_or_default()
            } else {
                recv[at..at + floats]
                    .chunks_exact(T::N)
                    .map(T::get)
                    .collect()
            };
            at += floats;
            if let Some(slot) = out.get_mut(i) {
                *slot = Some(v);
            }
        }
    }
    // (Their contents are spent: only their memory is kept.)
    team.state().buffers = Buffers { send, recv };
    out.into_iter()
        .enumerate()
        .map(|(i, v)| {
            v.ok_or_else(|| {
                Error::new(
                    ErrorCode::Internal,
                    format!("item {i} of a step of work came back from no rank"),
                )
            })
        })
        .collect()
}

/// Records `e` as the step's failure on this rank, unless one is recorded already.
fn fail(failure: &Mutex<Option<Error>>, e: Error) {
    lock(failure).get_or_insert(e);
}

/// The mutex's value, whether or not a thread panicked holding it.
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The error of rank `r` (code `code`, its message in `messages` at the place `counts` give)
/// as every rank reports it: the rank's own error as it is on that rank, and with "(on rank
/// r)" on the others (where its message does not name a rank already: an error agreed in a
/// step and agreed again at the output's end keeps the rank it first came from).
fn rank_error(
    team: &Team,
    r: usize,
    code: u64,
    messages: &[u8],
    counts: &[usize],
    own: Option<Error>,
) -> Error {
    if r == team.rank() {
        if let Some(e) = own {
            return e;
        }
    }
    let at: usize = counts[..r].iter().sum();
    let text = String::from_utf8_lossy(&messages[at..at + counts[r]]);
    // (Sent as `code as i32 as u64`: the truncation gives the i32 back.)
    let code = ErrorCode::from_raw(code as i32).unwrap_or(ErrorCode::Internal);
    // (An error agreed before, passed on to another agreement, names its rank already.)
    if text.contains(" (on rank ") {
        return Error::new(code, text.into_owned());
    }
    Error::new(code, format!("{text} (on rank {r})"))
}

/// The items' numbers and lengths of every rank (the all-gather of `u64`s, through bytes).
fn gather_index(link: &dyn Link, mine: &[u64], counts: &[usize]) -> Result<Vec<u64>> {
    let bytes: Vec<u8> = mine.iter().flat_map(|v| v.to_le_bytes()).collect();
    let counts: Vec<usize> = counts.iter().map(|c| c * 8).collect();
    Ok(
        exchange(link, &bytes, &counts, |m, c, o| link.gather_u8(m, c, o))?
            .chunks_exact(8)
            .map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")))
            .collect(),
    )
}

/// The outcome every rank of the team agrees on: `mine` where every rank succeeded, else the
/// error of the first rank (by rank) that failed, on every rank. Without a team, `mine`.
/// Collective.
pub(crate) fn agree<T>(team: Option<&Team>, mine: Result<T>) -> Result<T> {
    let Some(team) = team.filter(|t| t.size() > 1) else {
        return mine;
    };
    let link = &*team.0.link;
    let (code, message) = match &mine {
        Ok(_) => (0u64, &[][..]),
        Err(e) => (e.code as i32 as u64, e.message.as_bytes()),
    };
    let heads = link.gather_u64(&[code, message.len() as u64])?;
    let Some(r) = heads.chunks(2).position(|h| h[0] != 0) else {
        return mine;
    };
    let counts: Vec<usize> = heads.chunks(2).map(|h| h[1] as usize).collect();
    let messages = exchange(link, message, &counts, |m, c, o| link.gather_u8(m, c, o))?;
    Err(rank_error(
        team,
        r,
        heads[2 * r],
        &messages,
        &counts,
        mine.err(),
    ))
}

/// The value `v` of rank 0, on every rank (collective); `v` without a team.
pub(crate) fn from_root(team: Option<&Team>, v: u64) -> Result<u64> {
    match team.filter(|t| t.size() > 1) {
        Some(t) => Ok(t.0.link.gather_u64(&[v])?[0]),
        None => Ok(v),
    }
}

/// Whether `here` holds on every rank (collective); `here` without a team.
pub(crate) fn all(team: Option<&Team>, here: bool) -> Result<bool> {
    match team.filter(|t| t.size() > 1) {
        Some(t) => Ok(t.0.link.gather_u64(&[here as u64])?.iter().all(|&v| v == 1)),
        None => Ok(here),
    }
}

/// Whether this process writes the files: rank 0 of a team, or a process without one.
pub(crate) fn writes(team: Option<&Team>) -> bool {
    team.is_none_or(|t| t.rank() == 0)
}
