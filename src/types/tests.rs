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

/// `single_index` names a field only for a set of exactly one of the ten: a single bit above
/// them (1 << 10, 1 << 20, 1 << 31) is no field, so `validate_single` and `Sample::field` refuse
/// it instead of reading past the fields. `from_index` panics with its own message past them.
#[test]
fn a_single_bit_that_names_no_field_has_no_index() {
    for bit in [10, 20, 31] {
        let f = Fields::from_bits_unchecked(1 << bit);
        assert_eq!(f.single_index(), None, "bit {bit}");
        assert_eq!(f.validate_single().unwrap_err().code, ErrorCode::BadField);
    }
    for i in 0..FIELD_COUNT {
        assert_eq!(Fields::from_bits_unchecked(1 << i).single_index(), Some(i));
        assert_eq!(Fields::from_index(i).bits(), 1 << i);
    }
    assert_eq!(Fields::NONE.single_index(), None);
    assert_eq!((Fields::O | Fields::F).single_index(), None);
    let past = std::panic::catch_unwind(|| Fields::from_index(FIELD_COUNT)).unwrap_err();
    let message = past.downcast_ref::<String>().map_or("", |s| s.as_str());
    assert_eq!(message, "Fields::from_index: 10 is no field index (0 … 9)");
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
