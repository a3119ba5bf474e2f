//! A transfer function of the documented maximum sizes (2²⁰ rows, 64 outputs: about 1.3 GiB of
//! rows and ramp segments) that does not fit in memory is `NoMemory`, not an abort, and leaves
//! the library as it was. The case runs in a child process (this test binary run again with
//! `VLIB_MAPPING_CHILD` set), which builds the table, sets an address-space limit
//! (`RLIMIT_AS`, 512 MiB above what it has mapped: room for the rows' outputs, 256 MiB, and
//! not for the segments, 1 GiB), declares the mapping and prints one line per check; the
//! parent requires every check, a normal exit and nothing on stderr. Linux only (the limit is
//! set through `setrlimit` and the mapped size read from `/proc/self/status`).

#![cfg(all(target_os = "linux", target_pointer_width = "64"))]

#[path = "common/child.rs"]
mod child;
#[path = "common/rlimit.rs"]
mod rlimit;
#[path = "common/status.rs"]
mod status;
use rlimit::limit_address_space;

use vlib::{ErrorCode, Library, MappingId, MappingType};

const CHILD: &str = "VLIB_MAPPING_CHILD";
const POINTS: usize = vlib::limits::MAX_POINTS;
const OUTPUTS: usize = vlib::limits::MAX_OUTPUTS;

/// The address space this process has mapped (`VmSize`), in bytes.
fn mapped() -> u64 {
    status::status_bytes("VmSize")
}

/// In the child: a library holding a small mapping, the largest mapping declared under the
/// limit, and what the library holds afterwards.
fn run_child() {
    // Rows (i / 2²⁰, ½, …, ½): strictly increasing inputs in [0, 1).
    let mut table = vec![0.5f32; POINTS * (OUTPUTS + 1)];
    for (i, row) in table.chunks_exact_mut(OUTPUTS + 1).enumerate() {
        row[0] = i as f32 / POINTS as f32;
    }
    let mut vl = Library::new();
    vl.mapping(MappingId(1), MappingType::Ramp, 2, 1, &[0.3, 0.0, 0.5, 1.0])
        .unwrap();
    let before = vl.fingerprint();
    limit_address_space(mapped() + (512 << 20));
    let e = vl
        .mapping(
            MappingId(1),
            MappingType::Ramp,
            POINTS as i32,
            OUTPUTS as i32,
            &table,
        )
        .unwrap_err();
    let check = |ok: bool, what: &str| println!("{} {what}", if ok { "ok  " } else { "FAIL" });
    check(
        e.code == ErrorCode::NoMemory,
        "the largest ramp is NoMemory",
    );
    println!("     ({e})");
    check(vl.fingerprint() == before, "the library is unchanged");
    let small = vl.mapping(
        MappingId(2),
        MappingType::Lookup,
        2,
        1,
        &[0.3, 1.0, 0.5, 0.5],
    );
    check(
        small.is_ok(),
        "a small mapping is declared after the failure",
    );
}

/// What the child runs (nothing when run as a test).
#[test]
fn child() {
    if std::env::var_os(CHILD).is_some() {
        run_child();
    }
}

#[test]
fn the_largest_mapping_that_does_not_fit_is_no_memory() {
    child::run_child(
        &[(CHILD, "1".as_ref())],
        &[
            "ok   the largest ramp is NoMemory",
            "ok   the library is unchanged",
            "ok   a small mapping is declared after the failure",
        ],
    );
}
