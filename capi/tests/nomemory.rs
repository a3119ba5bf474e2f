//! Allocation failure reports `VL_NOMEMORY` instead of aborting, and voxelization's memory does
//! not grow with its nodes (issue #24, item 3): `capi/tests/c/nomemory.c` measures the peak
//! memory of a 256³ voxelization (getrusage), then sets an address-space limit
//! (`RLIMIT_AS`, 1 GiB above what it has mapped) and checks that `vlLoad` of a sparse `.vlb` of
//! 2³¹ voxels is `VL_NOMEMORY` with the id left unloaded and the library usable, and that a
//! voxelization beyond the old bound of 2²⁷ nodes is written in full under the limit. This test
//! compiles it (warnings as errors), runs it in a fresh directory and requires every check to
//! pass and the directory to be left empty but for the program. It is not run under valgrind
//! (see `memcheck.rs`).

mod common;

use common::TempDir;

#[test]
fn allocation_failure_is_no_memory_and_voxelization_memory_is_bounded() {
    let bin = TempDir::new("nomemory-bin");
    let exe = common::compile_c(
        "capi/tests/c/nomemory.c",
        bin.path(),
        &["-Wall", "-Wextra", "-Werror"],
    );
    let cwd = TempDir::new("nomemory-run");
    let stdout = common::run(&exe, cwd.path(), &[]);
    assert!(!stdout.contains("FAIL"), "{stdout}");
    for line in [
        "ok   peak memory grew by",
        "ok   vlLoad of 2^31 voxels reports VL_NOMEMORY",
        "ok   the dataset's id stays unloaded",
        "ok   a small dataset loads after the failure",
        "ok   1024 x 1024 x 129 nodes voxelized under the limit",
        "0 failure(s)",
    ] {
        assert!(stdout.contains(line), "missing {line:?} in:\n{stdout}");
    }
    let left: Vec<_> = std::fs::read_dir(cwd.path()).unwrap().collect();
    assert!(left.is_empty(), "files left: {left:?}");
}
