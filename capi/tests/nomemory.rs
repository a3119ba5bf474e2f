//! Allocation failure reports `VL_NOMEMORY` instead of aborting, and voxelization's memory does
//! not grow with its nodes (issue #24, item 3): `capi/tests/c/nomemory.c` measures the peak
//! memory of a 256³ voxelization (getrusage), then sets an address-space limit
//! (`RLIMIT_AS`, 1 GiB above what it has mapped) and checks that `vlLoad` of a sparse `.vlb` of
//! 2³¹ voxels is `VL_NOMEMORY` with the id left unloaded and the library usable, that a
//! voxelization of more than 2²⁷ nodes is written in full under the limit, and, under
//! a tighter limit, that a render whose node values do not fit and a 16384² image are
//! `VL_NOMEMORY` while a 4096² image renders, and a 4096² PNG of noise is written where a second
//! copy of its pixels would not fit. `capi/tests/c/pool.c` checks that a render whose
//! threads cannot start (item 6) is `VL_NOMEMORY` and the next one recovers, and that `vlSample`
//! of node values leaves no pool's threads running. These tests compile
//! them (warnings as errors), run them in fresh directories and require every check to pass and
//! the directory to be left empty. They are not run under valgrind (see `memcheck.rs`).

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
        "ok   a render whose node values do not fit reports VL_NOMEMORY",
        "ok   vlSample whose node values do not fit returns 0",
        "ok   and reports VL_NOMEMORY",
        "ok   a 16384^2 image reports VL_NOMEMORY",
        "ok   a 4096^2 image renders under the limit",
        "ok   a 4096^2 PNG of noise renders under the limit",
        "ok   and is written in full",
        "0 failure(s)",
    ] {
        assert!(stdout.contains(line), "missing {line:?} in:\n{stdout}");
    }
    let left: Vec<_> = std::fs::read_dir(cwd.path()).unwrap().collect();
    assert!(left.is_empty(), "files left: {left:?}");
}

#[test]
fn a_render_whose_threads_cannot_start_fails_and_the_next_recovers() {
    let bin = TempDir::new("pool-bin");
    let exe = common::compile_c(
        "capi/tests/c/pool.c",
        bin.path(),
        &["-Wall", "-Wextra", "-Werror"],
    );
    let cwd = TempDir::new("pool-run");
    let stdout = common::run(&exe, cwd.path(), &[]);
    assert!(!stdout.contains("FAIL"), "{stdout}");
    for line in [
        "ok   vlSample of node values",
        "ok   at the last node",
        "ok   leaves no thread of its own running",
        "ok   a render whose threads cannot start reports VL_NOMEMORY",
        "ok   the next render starts its threads and completes",
        "0 failure(s)",
    ] {
        assert!(stdout.contains(line), "missing {line:?} in:\n{stdout}");
    }
    let left: Vec<_> = std::fs::read_dir(cwd.path()).unwrap().collect();
    assert!(left.is_empty(), "files left: {left:?}");
}
