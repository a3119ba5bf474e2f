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
