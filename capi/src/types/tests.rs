//! Unit tests of the constants: against the core where a constant expression cannot compare
//! them, and the version constants against the package version of `Cargo.toml` and against
//! what `vlVersion` returns, in every state of the library.

use super::*;

#[test]
fn field_masks_match() {
    use vlib_core::Fields;
    let pairs = [
        (VL_O, Fields::O),
        (VL_R, Fields::R),
        (VL_G, Fields::G),
        (VL_B, Fields::B),
        (VL_KA, Fields::KA),
        (VL_KD, Fields::KD),
        (VL_KS, Fields::KS),
        (VL_N, Fields::N),
        (VL_RF, Fields::RF),
        (VL_F, Fields::F),
        (VL_COLORS, Fields::COLORS),
        (VL_ALLFIELDS, Fields::ALL),
    ];
    for (c, f) in pairs {
        assert_eq!(c as u32, f.bits());
    }
}

/// The version macros are the package's version, and `VLIB_VERSION` its encoding (the build
/// fails first where they are not: `checks`).
#[test]
fn version_constants_are_the_package_version() {
    let part = |s: &str| s.parse::<vlint>().expect("a version number");
    assert_eq!(VLIB_VERSION_MAJOR, part(env!("CARGO_PKG_VERSION_MAJOR")));
    assert_eq!(VLIB_VERSION_MINOR, part(env!("CARGO_PKG_VERSION_MINOR")));
    assert_eq!(VLIB_VERSION_PATCH, part(env!("CARGO_PKG_VERSION_PATCH")));
    let version: Vec<vlint> = env!("CARGO_PKG_VERSION")
        .split(['.', '-', '+'])
        .take(3)
        .map(part)
        .collect();
    assert_eq!(
        VLIB_VERSION,
        version[0] * 1_000_000 + version[1] * 1_000 + version[2]
    );
}

/// `vlVersion` returns `VLIB_VERSION` before `vlInit`, at library scope, with an error queued
/// (which it neither takes nor adds to), after the final `vlEnd` and on another thread, and
/// changes no state.
#[test]
fn vl_version_is_the_encoding_anywhere_and_records_nothing() {
    use crate::tests::common::{drain, serial};
    use crate::{state_fingerprint, vlEnd, vlError, vlInit, vlVersion};
    let _g = serial();
    for _ in 0..8 {
        if state_fingerprint() == "uninitialised" {
            break;
        }
        vlEnd();
    }
    drain();
    let uninitialised = state_fingerprint();
    assert_eq!(uninitialised, "uninitialised");
    assert_eq!(vlVersion(), VLIB_VERSION);
    assert_eq!(state_fingerprint(), uninitialised);
    vlInit();
    let library = state_fingerprint();
    assert_eq!(vlVersion(), VLIB_VERSION);
    assert_eq!(state_fingerprint(), library);
    assert_eq!(drain(), Vec::<vlint>::new(), "vlVersion records no error");
    vlInit(); // already running: VL_BADSCOPE, queued
    assert_eq!(vlVersion(), VLIB_VERSION);
    assert_eq!(
        std::thread::spawn(|| vlVersion()).join().expect("no panic"),
        VLIB_VERSION
    );
    assert_eq!(vlError(), VL_BADSCOPE, "the queued error is still there");
    assert_eq!(vlError(), VL_NOERROR, "and nothing else");
    vlEnd();
    assert_eq!(vlVersion(), VLIB_VERSION);
    assert_eq!(state_fingerprint(), uninitialised);
    assert_eq!(drain(), Vec::<vlint>::new());
}
