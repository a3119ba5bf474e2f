//! `vlSample` outside a render (`Library::sample`, `Sampler::sample`) whose filter needs the
//! dataset's node values, made on first use, where they do not fit in memory: `NoMemory`, not
//! an unwind out of the call, and the library still samples afterwards. The case runs in a
//! child process (this test binary run again with `VLIB_SAMPLE_CHILD` set), which loads a 512³
//! 8-bit dataset (128 MiB), sets an address-space limit (`RLIMIT_AS`, 256 MiB above what it
//! has mapped: not room for the 512 MiB of its f32 node values), samples it with the nearest
//! filter (which reads the node values) and then with the trilinear one (which reads the
//! voxels), and prints one line per check; the parent requires every check, a normal exit and
//! no allocation failure on stderr.
//! Linux only (the limit is set through `setrlimit`, the mapped size read from
//! `/proc/self/status`).

#![cfg(all(target_os = "linux", target_pointer_width = "64"))]

#[path = "common/child.rs"]
mod child;
#[path = "common/rlimit.rs"]
mod rlimit;
#[path = "common/status.rs"]
mod status;
use rlimit::limit_address_space;

use vlib::{Dataset, DatasetId, ErrorCode, Interpolation, Library, Voxels};

const CHILD: &str = "VLIB_SAMPLE_CHILD";
const SIDE: usize = 512;

/// In the child.
fn run_child() {
    let check = |ok: bool, what: &str| println!("{} {what}", if ok { "ok  " } else { "FAIL" });
    let voxels = vec![51u8; SIDE * SIDE * SIDE];
    let d = Dataset::new([SIDE; 3], Voxels::U8(voxels), 0.0, 255.0).unwrap();
    let mut vl = Library::new();
    vl.add_dataset(DatasetId(1), d).unwrap();
    vl.interpolation(Interpolation::Nearest).unwrap();
    let sampler = vl.sampler();
    limit_address_space(status::status_bytes("VmSize") + (256 << 20));
    let no_memory = |r: &vlib::Result<f32>| matches!(r, Err(e) if e.code == ErrorCode::NoMemory);
    let r = vl.sample(DatasetId(1), 0.5, 0.5, 0.5);
    check(
        no_memory(&r),
        "Library::sample under the nearest filter is NoMemory",
    );
    println!("     ({r:?})");
    let r = sampler.sample(DatasetId(1), 0.5, 0.5, 0.5);
    check(no_memory(&r), "Sampler::sample is NoMemory");
    // 51 / 255 = 0.2 exactly in the voxels' normalisation, to f32's rounding.
    vl.interpolation(Interpolation::Trilinear).unwrap();
    let r = vl.sample(DatasetId(1), 0.5, 0.5, 0.5);
    check(
        matches!(r, Ok(v) if (v - 0.2).abs() < 1e-6),
        "the trilinear filter (the voxels) samples after it",
    );
    println!("     ({r:?})");
}

/// What the child runs (nothing when run as a test).
#[test]
fn child() {
    if std::env::var_os(CHILD).is_some() {
        run_child();
    }
}

#[test]
fn node_values_that_do_not_fit_are_no_memory_for_sample() {
    child::run_child(
        &[(CHILD, "1".as_ref())],
        &[
            "ok   Library::sample under the nearest filter is NoMemory",
            "ok   Sampler::sample is NoMemory",
            "ok   the trilinear filter (the voxels) samples after it",
        ],
    );
}
