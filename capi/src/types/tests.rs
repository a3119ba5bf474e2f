//! Unit tests of the constants against the core that a constant expression cannot make.

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
