//! Unit tests of the panic boundary and the state lock.

use super::*;

#[test]
fn a_panic_becomes_vl_internal_and_a_poisoned_state_is_recovered() {
    // The state is global: held against the other tests that use it (one of them, run
    // at the same time, once left it initialised between the panic and the check), and
    // uninitialised here, so that what the check sees is what the panic left.
    let _serial = crate::tests::common::serial();
    *lock_state() = None;
    let v = ffi_boundary(7, || -> Result<i32> {
        let _state = lock_state();
        panic!("boom");
    });
    assert_eq!(v, 7, "the neutral value");
    assert_eq!(errors::pop(), ErrorCode::Internal);
    assert!(errors::last_error_message().is_some_and(|m| m.contains("boom")));
    assert!(STATE.is_poisoned());
    assert!(
        lock_state().is_none(),
        "the state is usable after the panic"
    );
    STATE.clear_poison();
}

/// A panic caught by the boundary prints nothing on stderr (the library never writes there);
/// a panic outside it still reaches the hook that was installed before. Checked in a child
/// process running this test alone, with the test harness's capture off, so that what the
/// panic hook prints goes to the child's real stderr.
#[test]
fn a_caught_panic_prints_nothing() {
    const CHILD: &str = "VLIB_QUIET_PANIC_CHILD";
    if std::env::var_os(CHILD).is_some() {
        ffi_boundary((), || -> Result<()> { panic!("inside-the-boundary") });
        assert_eq!(errors::pop(), ErrorCode::Internal);
        let outside = std::panic::catch_unwind(|| panic!("outside-the-boundary"));
        assert!(outside.is_err());
        return;
    }
    let out = std::process::Command::new(std::env::current_exe().expect("test binary"))
        .args([
            "--exact",
            "ffi::tests::a_caught_panic_prints_nothing",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(CHILD, "1")
        .output()
        .expect("run the child");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "child failed:\n{err}");
    assert!(!err.contains("inside-the-boundary"), "printed:\n{err}");
    assert!(
        err.contains("outside-the-boundary"),
        "the host's hook ran:\n{err}"
    );
}

/// A path `len` bytes long under a directory that does not exist, ending in `.ppm`.
fn long_path(len: usize) -> std::ffi::CString {
    let mut p = b"/vlib-no-such-directory/".to_vec();
    p.resize(len - 4, b'a');
    p.extend_from_slice(b".ppm");
    std::ffi::CString::new(p).expect("no NUL")
}

/// A path longer than `MAX_PATH_BYTES` is `VL_BADFILE` at every command that takes one and
/// changes nothing; one of exactly the bound, or a long but legal one (5000 bytes), passes the
/// check and fails later, when the file is opened.
#[test]
fn a_path_longer_than_the_bound_is_bad_file_and_a_long_one_is_not() {
    use crate::tests::common::{drain, serial};
    use crate::types::{VL_BADFILE, VL_IOERROR, VL_O};
    let _serial = serial();
    *lock_state() = None;
    drain();
    let huge = long_path(MAX_PATH_BYTES + 1);
    let bound = long_path(MAX_PATH_BYTES);
    let long = long_path(5000);
    crate::vlInit();
    // SAFETY: NUL-terminated strings that outlive the calls.
    unsafe {
        let before = state_fingerprint();
        crate::vlLoad(1, huge.as_ptr());
        assert_eq!(drain(), vec![VL_BADFILE], "vlLoad of a huge name");
        assert!(
            errors::last_error_message().is_some_and(|m| m.contains("longer than 1048576 bytes"))
        );
        assert_eq!(
            state_fingerprint(),
            before,
            "a refused vlLoad changes nothing"
        );
        for ok in [&bound, &long] {
            crate::vlLoad(1, ok.as_ptr());
            assert_eq!(drain(), vec![VL_IOERROR], "vlLoad of a long name opens it");
        }

        crate::vlScene();
        // A 2³ voxelization of the opacity with `prefix`.
        let volume = |prefix: &std::ffi::CString| {
            crate::vlVolume(
                prefix.as_ptr(),
                VL_O,
                0.0,
                0.0,
                0.0,
                1.0,
                1.0,
                1.0,
                2,
                2,
                2,
                1,
            )
        };
        let before = state_fingerprint();
        crate::vlImage(huge.as_ptr(), 1.0, 2, 2);
        assert_eq!(drain(), vec![VL_BADFILE], "vlImage of a huge name");
        volume(&huge);
        assert_eq!(drain(), vec![VL_BADFILE], "vlVolume of a huge prefix");
        assert_eq!(
            state_fingerprint(),
            before,
            "refused outputs change nothing"
        );
        crate::vlImage(long.as_ptr(), 1.0, 2, 2);
        volume(&long);
        assert_eq!(drain(), Vec::<i32>::new(), "long names are accepted");
        crate::vlEnd(); // the scene: its outputs cannot be written
        assert!(drain().iter().all(|&e| e == VL_IOERROR));
    }
    crate::vlEnd();
    drain();
    assert!(lock_state().is_none());
}
