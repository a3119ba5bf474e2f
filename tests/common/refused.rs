//! Refused calls of the Rust API: the code they give and the state they leave.

#![allow(dead_code)] // Each test file uses what it needs.

use vlib::{ErrorCode, Library};

/// `call` is refused with `code` and leaves the library as it was.
pub fn refused(
    vl: &mut Library,
    code: ErrorCode,
    what: &str,
    call: impl FnOnce(&mut Library) -> vlib::Result<()>,
) {
    let before = vl.fingerprint();
    let e = call(vl).expect_err(what);
    assert_eq!(e.code, code, "{what}: {}", e.message);
    assert_eq!(
        vl.fingerprint(),
        before,
        "{what}: a refused call changed the state"
    );
}

/// A library in scene scope.
pub fn scene() -> Library {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl
}
