//! The MPI build of the C library (the `mpi` feature, docs/mpi.md): at `vlInit` a program
//! started by an MPI launcher joins the team of every rank of its job (MPI started by the
//! library if the program has not), so that each scene renders split over the ranks and rank
//! 0 writes the files; after each scene's `vlEnd`, rank 0 writes the ranks' busy times to the
//! file `VLIB_MPI_BUSY` names, if set. Without a launcher, with one rank, or with
//! `VLIB_MPI=0`, the library is the plain one.

use std::sync::OnceLock;
use vlib_core::{Library, Team};

/// The team of the job's ranks, made by the first `vlInit` (collective) and kept for the
/// sessions after it; `None` where there is none to make or it could not be made.
static WORLD: OnceLock<Option<Team>> = OnceLock::new();

/// Splits `lib`'s renders over the job's ranks, where there are several.
pub(crate) fn attach(lib: &mut Library) {
    if std::env::var_os("VLIB_MPI").is_some_and(|v| v == "0") || !Team::launched() {
        return;
    }
    let team = WORLD.get_or_init(|| match Team::world() {
        Ok(t) => Some(t),
        Err(e) => {
            crate::errors::record(e);
            None
        }
    });
    lib.set_team(team.clone().filter(|t| t.size() > 1));
}

/// On rank 0 of a team, writes the ranks' statistics (`Team::stats_text`) to the file
/// `VLIB_MPI_BUSY` names, if set, atomically; a failure is recorded for `vlError`.
pub(crate) fn report(lib: &Library) {
    let (Some(team), Some(path)) = (lib.team(), std::env::var_os("VLIB_MPI_BUSY")) else {
        return;
    };
    if team.rank() == 0 {
        if let Err(e) = vlib_core::write_atomic(path.as_ref(), team.stats_text().as_bytes()) {
            crate::errors::record(e);
        }
    }
}
