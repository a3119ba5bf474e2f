//! The MPI transport of a [`Team`] (the `mpi` feature, on rsmpi over the system's MPI):
//! starting and ending MPI for a program that does not ([`Team::world`]), a team over a
//! communicator ([`Team::from_communicator`]), and the [`Link`] operations: the shared
//! counter is one `u64` in an MPI window on rank 0, taken with `MPI_Fetch_and_op` under a
//! passive-target epoch (no rank has to serve it), the exchanges are `MPI_Allgather(v)`. The
//! team's communicator and window have `MPI_ERRORS_RETURN`: an MPI call that fails is an
//! `Internal` error of the render, not the job's abort.
//!
//! Calls are made from one of the library's threads at a time (serialised by the caller,
//! `map`'s fetch lock and the render's single driver), so the library asks MPI for
//! `MPI_THREAD_SERIALIZED` when it starts MPI itself (docs/mpi.md).

use super::{Link, Team};
use crate::error::{Error, ErrorCode, Result};
use mpi::ffi;
use mpi::topology::{Communicator, SimpleCommunicator};
use mpi::traits::AsRaw;
use std::os::raw::{c_int, c_void};
use std::sync::Mutex;

/// The universe of an MPI the library started, finalised when the process exits.
static STARTED: Mutex<Option<mpi::environment::Universe>> = Mutex::new(None);

extern "C" {
    fn atexit(f: extern "C" fn()) -> c_int;
}

/// Finalises the MPI the library started (an `atexit` handler), unless the program did.
extern "C" fn finalize_at_exit() {
    let started = STARTED.lock().unwrap_or_else(|e| e.into_inner()).take();
    if let Some(universe) = started {
        // The universe's own drop would also finalise, but asserts on the way: a panic in an
        // exit handler would abort the process.
        std::mem::forget(universe);
        if !mpi::environment::is_finalized() {
            // SAFETY: MPI was initialised by this library and is not finalised.
            unsafe { ffi::MPI_Finalize() };
        }
    }
}

/// The environment variables by which MPI launchers (Open MPI's `mpirun`, PMI and PMIx
/// launchers: MPICH's hydra, Slurm's `srun`) tell a process it is one of a job's ranks.
const LAUNCHED: [&str; 4] = ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "PMI_RANK"];

impl Team {
    /// Whether this process is one of an MPI job's ranks: started by an MPI launcher (Open
    /// MPI's `mpirun`, or a PMI or PMIx launcher: MPICH's hydra, Slurm's `srun`), or with MPI
    /// initialised by the program.
    pub fn launched() -> bool {
        LAUNCHED.iter().any(|v| std::env::var_os(v).is_some())
            || (mpi::environment::is_initialized() && !mpi::environment::is_finalized())
    }

    /// The team of every rank of the job (`MPI_COMM_WORLD`, duplicated), starting MPI with
    /// `MPI_THREAD_SERIALIZED` if the program has not (then the library finalises it when the
    /// process exits; a program that started MPI itself finalises it itself). Collective:
    /// every rank calls it. Errors: `Internal` where MPI was finalised already or its window
    /// cannot be made.
    pub fn world() -> Result<Team> {
        if mpi::environment::is_finalized() {
            return Err(Error::new(
                ErrorCode::Internal,
                "MPI was finalised: no team can be made",
            ));
        }
        if let Some((universe, _)) =
            mpi::initialize_with_threading(mpi::environment::Threading::Serialized)
        {
            *STARTED.lock().unwrap_or_else(|e| e.into_inner()) = Some(universe);
            // SAFETY: registers a function without arguments that only finalises MPI.
            unsafe { atexit(finalize_at_exit) };
        }
        Team::from_communicator(&SimpleCommunicator::world())
    }

    /// The team of the ranks of `comm` (an intra-communicator of a program that started MPI),
    /// which it duplicates: the team's messages never meet the program's. Collective over
    /// `comm`. The duplicate and the team's window live until MPI is finalised.
    pub fn from_communicator(comm: &SimpleCommunicator) -> Result<Team> {
        // The team's MPI calls are made from the library's rendering threads, one at a time:
        // MPI must have been started with MPI_THREAD_SERIALIZED or more.
        use mpi::environment::Threading;
        let level = mpi::environment::threading_support();
        if !matches!(level, Threading::Serialized | Threading::Multiple) {
            return Err(Error::new(
                ErrorCode::BadValue,
                format!(
                    "MPI was started with thread level {level:?}: a team needs \
                     MPI_THREAD_SERIALIZED or MPI_THREAD_MULTIPLE (MPI_Init_thread)"
                ),
            ));
        }
        let dup = std::mem::ManuallyDrop::new(comm.duplicate());
        let raw = dup.as_raw();
        // The team's MPI calls return their errors (each becomes the library's `Internal`)
        // instead of aborting the job, MPI's default.
        // SAFETY: the duplicate just made, and MPI's predefined handler.
        check(
            unsafe { ffi::MPI_Comm_set_errhandler(raw, ffi::RSMPI_ERRORS_RETURN) },
            "MPI_Comm_set_errhandler",
        )?;
        let (rank, size) = (dup.rank() as usize, dup.size() as usize);
        let mut base: *mut c_void = std::ptr::null_mut();
        let mut win: ffi::MPI_Win = unsafe { std::mem::zeroed() };
        let bytes = if rank == 0 { 8 } else { 0 };
        // SAFETY: a window of 8 bytes on rank 0 and none elsewhere, over a live communicator;
        // `base` and `win` are written by MPI.
        let rc = unsafe {
            ffi::MPI_Win_allocate(
                bytes,
                8,
                ffi::RSMPI_INFO_NULL,
                raw,
                (&mut base as *mut *mut c_void).cast(),
                &mut win,
            )
        };
        check(rc, "MPI_Win_allocate")?;
        // SAFETY: the window just made, and MPI's predefined handler.
        check(
            unsafe { ffi::MPI_Win_set_errhandler(win, ffi::RSMPI_ERRORS_RETURN) },
            "MPI_Win_set_errhandler",
        )?;
        if rank == 0 {
            // SAFETY: rank 0's 8 bytes of the window, before any rank opens its epoch.
            unsafe { base.cast::<u64>().write(0) };
        }
        // SAFETY: the window just made; the barrier orders rank 0's zero before every fetch.
        check(unsafe { ffi::MPI_Barrier(raw) }, "MPI_Barrier")?;
        check(unsafe { ffi::MPI_Win_lock_all(0, win) }, "MPI_Win_lock_all")?;
        Team::from_link(Box::new(MpiLink {
            comm: raw,
            win,
            rank,
            size,
        }))
    }
}

/// A team over an MPI communicator.
struct MpiLink {
    comm: ffi::MPI_Comm,
    win: ffi::MPI_Win,
    rank: usize,
    size: usize,
}

// SAFETY: the handles are process-wide MPI objects; every call through them is serialised by
// the team's users (one fetch at a time, one collective at a time) and MPI is initialised with
// MPI_THREAD_SERIALIZED.
unsafe impl Send for MpiLink {}
unsafe impl Sync for MpiLink {}

/// `Ok` where MPI's return code `rc` of `what` is `MPI_SUCCESS` (0), else `Internal`: the
/// team's communicator and window return errors instead of aborting the job
/// (`MPI_ERRORS_RETURN`).
fn check(rc: c_int, what: &str) -> Result<()> {
    if rc == 0 {
        Ok(())
    } else {
        Err(Error::new(
            ErrorCode::Internal,
            format!("{what} failed (MPI error {rc})"),
        ))
    }
}

/// Counts and displacements for MPI (which takes `int`s) of `counts` elements; `BadValue`
/// where an exchange passes 2³¹ − 1 elements (the same on every rank: every rank knows every
/// count).
fn partition(counts: &[usize]) -> Result<(Vec<c_int>, Vec<c_int>)> {
    let too_many = || {
        Error::new(
            ErrorCode::BadValue,
            "an exchange between the ranks of more than 2^31 - 1 elements (a smaller image or \
             volume, or more ranks)",
        )
    };
    let mut displs = Vec::with_capacity(counts.len());
    let mut at = 0usize;
    for &c in counts {
        displs.push(c_int::try_from(at).map_err(|_| too_many())?);
        at += c;
    }
    c_int::try_from(at).map_err(|_| too_many())?;
    let counts = counts
        .iter()
        .map(|&c| c_int::try_from(c).map_err(|_| too_many()))
        .collect::<Result<_>>()?;
    Ok((counts, displs))
}

impl MpiLink {
    /// `MPI_Allgatherv` of `mine` (`T` of MPI type `ty`), `counts` by rank, into `out`.
    fn gather_var<T: Copy>(
        &self,
        mine: &[T],
        counts: &[usize],
        out: &mut [T],
        ty: ffi::MPI_Datatype,
    ) -> Result<()> {
        let total: usize = counts.iter().sum();
        if total == 0 {
            // Every rank knows every count: none of them sends (and two empty buffers would be
            // the same dangling address, which MPI refuses as aliasing).
            return Ok(());
        }
        let (c, d) = partition(counts)?;
        if out.len() != total || mine.len() != counts[self.rank] {
            return Err(Error::new(
                ErrorCode::Internal,
                "an exchange's buffers do not match its counts",
            ));
        }
        // SAFETY: `out` holds the sum of `counts` elements; each rank sends `counts[rank]`,
        // the length of its `mine`.
        let rc = unsafe {
            ffi::MPI_Allgatherv(
                mine.as_ptr().cast(),
                c[self.rank],
                ty,
                out.as_mut_ptr().cast(),
                c.as_ptr(),
                d.as_ptr(),
                ty,
                self.comm,
            )
        };
        check(rc, "MPI_Allgatherv")
    }
}

impl Link for MpiLink {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn fetch_add(&self, n: u64) -> Result<u64> {
        let mut before = 0u64;
        // SAFETY: an atomic add on rank 0's u64 of the window, inside the epoch opened by
        // MPI_Win_lock_all; the flush completes it before `before` is read.
        let rc = unsafe {
            ffi::MPI_Fetch_and_op(
                (&n as *const u64).cast(),
                (&mut before as *mut u64).cast(),
                ffi::RSMPI_UINT64_T,
                0,
                0,
                ffi::RSMPI_SUM,
                self.win,
            )
        };
        check(rc, "MPI_Fetch_and_op")?;
        // SAFETY: as above.
        check(unsafe { ffi::MPI_Win_flush(0, self.win) }, "MPI_Win_flush")?;
        Ok(before)
    }

    fn gather_u64(&self, mine: &[u64]) -> Result<Vec<u64>> {
        // (A header of a few words from each rank: small, whatever the render.)
        let mut out = vec![0u64; mine.len() * self.size];
        let n = c_int::try_from(mine.len())
            .map_err(|_| Error::new(ErrorCode::Internal, "a header of more than 2^31 - 1 words"))?;
        // SAFETY: `out` holds `size` times `mine`.
        let rc = unsafe {
            ffi::MPI_Allgather(
                mine.as_ptr().cast(),
                n,
                ffi::RSMPI_UINT64_T,
                out.as_mut_ptr().cast(),
                n,
                ffi::RSMPI_UINT64_T,
                self.comm,
            )
        };
        check(rc, "MPI_Allgather")?;
        Ok(out)
    }

    fn gather_f32(&self, mine: &[f32], counts: &[usize], out: &mut [f32]) -> Result<()> {
        self.gather_var(mine, counts, out, unsafe { ffi::RSMPI_FLOAT })
    }

    fn gather_u8(&self, mine: &[u8], counts: &[usize], out: &mut [u8]) -> Result<()> {
        self.gather_var(mine, counts, out, unsafe { ffi::RSMPI_UINT8_T })
    }
}
