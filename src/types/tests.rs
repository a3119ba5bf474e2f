//! Unit tests of `types`.

use super::*;

#[test]
fn field_masks_validate() {
    assert_eq!(Fields::from_raw(0).unwrap_err().code, ErrorCode::BadField);
    assert_eq!(
        Fields::from_raw(1 << 10).unwrap_err().code,
        ErrorCode::BadField
    );
    assert_eq!(Fields::from_raw(-1).unwrap_err().code, ErrorCode::BadField);
    assert_eq!(Fields::from_raw(0x3ff).unwrap(), Fields::ALL);
    assert_eq!(Fields::single_from_raw(1 << 9).unwrap(), 9);
    assert_eq!(
        Fields::single_from_raw(3).unwrap_err().code,
        ErrorCode::BadField
    );
    assert_eq!(Fields::COLORS, Fields::R | Fields::G | Fields::B);
    assert_eq!(Fields::ALL.indices().count(), FIELD_COUNT);
}

#[test]
fn enums_validate() {
    for (i, t) in RenderType::ALL.iter().enumerate() {
        assert_eq!(RenderType::from_raw(i as i32).unwrap(), *t);
    }
    assert_eq!(
        RenderType::from_raw(3).unwrap_err().code,
        ErrorCode::BadEnum
    );
    assert_eq!(Feature::from_raw(-1).unwrap_err().code, ErrorCode::BadEnum);
    assert_eq!(Feature::ALL.len(), 8);
    assert_eq!(
        Attenuation::from_raw(2).unwrap(),
        Attenuation::InverseSquare
    );
}

#[test]
fn encodings_map_ranges_to_unit_interval() {
    assert_eq!(specular_to_field(MAX_SPECULAR), 1.0);
    assert_eq!(specular_to_field(0.0), 0.0);
    assert_eq!(refraction_to_field(1.0), 0.0);
    assert_eq!(refraction_to_field(MAX_REFRACTION), 1.0);
}
