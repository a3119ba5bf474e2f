//! Support for the fuzz targets: the command-sequence interpreter and the `.vlb` property
//! (also compiled into the root crate's `tests/fuzz_props.rs`, the bounded CI run), the
//! vlconvert readers' input format and checks (also compiled into
//! `vlconvert/tests/fuzz_readers.rs`), and a per-process scratch directory.

pub mod driver;
pub mod readers;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A scratch directory of this process, removed and made anew by each run that uses it; in
/// memory (/dev/shm) where there is one, since outputs are written with fsync.
pub fn scratch_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| readers::scratch_base().join(format!("vlib-fuzz-{}", std::process::id())))
}
