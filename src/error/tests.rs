//! Unit tests of `error`.

use super::*;

#[test]
fn codes_are_fixed_and_round_trip() {
    for (i, c) in ErrorCode::ALL.iter().enumerate() {
        assert_eq!(*c as i32, i as i32);
        assert_eq!(ErrorCode::from_raw(i as i32), Some(*c));
        assert!(c.description_nul().ends_with('\0'));
        assert!(!c.description().contains('\0'));
    }
    assert_eq!(ErrorCode::from_raw(-1), None);
    assert_eq!(ErrorCode::from_raw(ErrorCode::ALL.len() as i32), None);
}

/// The render's panic boundary: a raised error comes back as it is, another panic as
/// `Internal` with what stopped and the panic's message, and a result passes through.
#[test]
fn catch_returns_raised_errors_as_they_are() {
    let raised = Error::new(
        ErrorCode::NoMemory,
        "a cache: 8 bytes could not be allocated",
    );
    let r: Result<()> = catch("a render", || raise(raised.clone()));
    assert_eq!(r, Err(raised));
    let r: Result<()> = catch("a render", || panic!("a field function failed"));
    let e = r.unwrap_err();
    assert_eq!(e.code, ErrorCode::Internal);
    assert!(e.message.contains("a render") && e.message.contains("a field function failed"));
    assert_eq!(catch("a render", || Ok(3)), Ok(3));
    let passed: Result<()> = catch("a render", || err(ErrorCode::BadValue, "as it is"));
    assert_eq!(passed.unwrap_err().code, ErrorCode::BadValue);
}
