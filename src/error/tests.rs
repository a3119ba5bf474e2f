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
