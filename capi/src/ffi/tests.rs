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
