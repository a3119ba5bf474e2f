//! The MPI build of the C library (the `mpi` feature, docs/mpi.md): at `vlInit` a program
//! started by an MPI launcher joins the team of every rank of its job (MPI started by the
//! library if the program has not), so that each scene renders split over the ranks and rank
//! 0 writes the files; after each scene's `vlEnd`, rank 0 writes the ranks' busy times to the
//! file `VLIB_MPI_BUSY` names, if set. Without a launcher, with one rank, or with
//! `VLIB_MPI=0`, the library is the plain one. The errors that field functions record while
//! a scene renders are recorded on the rank that ran them; [`share_errors`] gives every rank
//! every rank's.

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

/// After a render of `lib`'s team: the codes recorded since `mark` on each rank (by field,
/// normal and spatial functions, on the rank that rendered their samples) are queued on every
/// rank, rank 0's first (collective; nothing without a team).
pub(crate) fn share_errors(lib: &Library, mark: u64) {
    let Some(team) = lib.team() else { return };
    let mine: Vec<u8> = crate::errors::take_since(mark)
        .iter()
        .flat_map(|c| (*c as i32).to_le_bytes())
        .collect();
    let all = match team.gather(&mine) {
        Ok(all) => all,
        Err(e) => {
            crate::errors::record(e);
            return;
        }
    };
    for (rank, codes) in all.iter().enumerate() {
        for code in codes.chunks_exact(4) {
            let raw = i32::from_le_bytes(code.try_into().expect("4 bytes"));
            let code =
                vlib_core::ErrorCode::from_raw(raw).unwrap_or(vlib_core::ErrorCode::Internal);
            crate::errors::record(vlib_core::Error::new(
                code,
                format!("recorded on rank {rank} while rendering"),
            ));
        }
    }
}
