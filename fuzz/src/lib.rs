//! Support for the fuzz targets: the command-sequence interpreter and the `.vlb` property
//! (also compiled into the root crate's `tests/fuzz_props.rs`, the bounded CI run), and a
//! per-process scratch directory.

pub mod driver;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A scratch directory of this process, removed and made anew by each run that uses it; in
/// memory (/dev/shm) where there is one, since outputs are written with fsync.
pub fn scratch_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let shm = Path::new("/dev/shm");
        let base = if shm.is_dir() {
            shm.to_path_buf()
        } else {
            std::env::temp_dir()
        };
        base.join(format!("vlib-fuzz-{}", std::process::id()))
    })
}
