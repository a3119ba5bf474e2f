//! Unit tests of `program`.

use super::*;
use crate::testing::Xorshift;
use crate::types::MappingType;

/// [`clamp_fields`] is [`clamp_field`] lane by lane, bit for bit: on NaNs, ±0, ±∞, the
/// subnormals, values around 0 and 1, and 100 000 random bit patterns, in every lane.
#[test]
fn clamp_fields_is_clamp_field() {
    let mut values = vec![
        f32::NAN,
        -f32::NAN,
        f32::from_bits(0x7f80_0001),
        0.0,
        -0.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        f32::from_bits(1),
        f32::from_bits(0x8000_0001),
        0.5,
        1.0,
        -1.0,
        f32::MAX,
        f32::MIN,
    ];
    values.extend(
        [1.0f32, -0.0, 0.0]
            .iter()
            .flat_map(|x| [x.next_up(), x.next_down()]),
    );
    let rng = Xorshift::new(0x9e37_79b9_7f4a_7c15u64);
    values.extend((0..100_000).map(|_| f32::from_bits((rng.bits() >> 32) as u32)));
    for (k, w) in values.windows(4).enumerate() {
        let mut lanes = [w[0], w[1], w[2], w[3]];
        lanes.rotate_left(k % 4);
        let got = clamp_fields(wide::f32x4::new(lanes)).to_array();
        assert_eq!(
            got.map(f32::to_bits),
            lanes.map(|v| clamp_field(v).to_bits()),
            "{lanes:?}"
        );
    }
}

#[test]
fn set_is_masked_and_clamped() {
    let prog = vec![
        Instr::Set {
            fields: Fields::KA,
            value: 0.3,
        },
        Instr::Function {
            fields: Fields::F,
            f: Arc::new(|s: &mut Sample| {
                s.set(Fields::ALL, 2.0).unwrap();
            }),
        },
        Instr::Function {
            fields: Fields::O | Fields::R,
            f: Arc::new(|s: &mut Sample| {
                let f = s.field(Fields::F).unwrap();
                s.set(Fields::O, f - 0.25).unwrap();
                s.set(Fields::R, f32::NAN).unwrap();
                s.set(Fields::G, 0.5).unwrap();
            }),
        },
    ];
    let mut s = Sample::new([0.5; 3], [0.0; 3]);
    run(&prog, &mut s);
    let v = s.values();
    assert_eq!(v[4], 0.3);
    assert_eq!(v[9], 1.0, "2.0 clamps to 1");
    assert_eq!(v[0], 0.75);
    assert_eq!(v[1], 0.0, "NaN becomes 0");
    assert_eq!(v[2], 0.0, "G was not in the function's mask");
    assert_eq!(prefix_for(&prog, Fields::F), 2);
    assert_eq!(prefix_for(&prog, Fields::KS), 0);
}

#[test]
fn map_reads_source_field() {
    let m = Arc::new(Mapping::new(MappingType::Lookup, 2, 1, &[0.001, 1.0, 1.0, 0.3]).unwrap());
    let prog = vec![
        Instr::Set {
            fields: Fields::F,
            value: 0.5,
        },
        Instr::Map {
            targets: Fields::O | Fields::KS,
            source: 9,
            mapping: m,
            output: 0,
        },
    ];
    let mut s = Sample::new([0.5; 3], [0.0; 3]);
    run(&prog, &mut s);
    assert_eq!(s.value(0), 0.3);
    assert_eq!(s.value(6), 0.3);
}

/// A mask with a bit that names no field is `BadField` for `vlField` and `vlSet` inside a
/// field function, as for `Library::set` and the C layer: the read does not index past the ten
/// fields and the write changes nothing, even where the mask also names fields.
#[test]
fn masks_with_bits_that_name_no_field_are_bad_fields() {
    let mut s = Sample::new([0.5; 3], [0.0; 3]);
    s.mask = Fields::ALL;
    s.fields = [0.25; FIELD_COUNT];
    for bit in [10, 20, 31] {
        let f = Fields::from_bits_unchecked(1 << bit);
        assert_eq!(s.field(f).unwrap_err().code, ErrorCode::BadField, "{bit}");
        assert_eq!(
            s.set(f, 1.0).unwrap_err().code,
            ErrorCode::BadField,
            "{bit}"
        );
        let both = f | Fields::O;
        assert_eq!(s.set(both, 1.0).unwrap_err().code, ErrorCode::BadField);
        assert_eq!(
            s.values(),
            [0.25; FIELD_COUNT],
            "bit {bit}: a refused vlSet wrote"
        );
    }
    assert_eq!(s.field(Fields::KS).unwrap(), 0.25);
    s.set(Fields::O | Fields::F, 2.0).unwrap();
    let mut want = [0.25; FIELD_COUNT];
    (want[0], want[9]) = (1.0, 1.0);
    assert_eq!(s.values(), want);
}

/// A sample made by `Sample::new` is a field function's that named every field: `set` writes
/// what it names (clamped), as inside a render.
#[test]
fn a_new_sample_takes_every_field_it_is_given() {
    let mut s = Sample::new([0.5; 3], [0.0; 3]);
    s.set(Fields::ALL, 0.7).unwrap();
    assert_eq!(s.values(), [0.7; FIELD_COUNT]);
    s.set(Fields::O | Fields::F, 2.0).unwrap();
    assert_eq!(s.field(Fields::O).unwrap(), 1.0);
    assert_eq!(s.field(Fields::F).unwrap(), 1.0);
    assert_eq!(s.field(Fields::R).unwrap(), 0.7);
}

#[test]
fn normal_role_cannot_write() {
    let mut s = Sample::new([0.5; 3], [0.0; 3]);
    s.role = SampleRole::Normal;
    assert_eq!(s.set(Fields::O, 1.0).unwrap_err().code, ErrorCode::BadScope);
    assert_eq!(
        s.field(Fields::O | Fields::R).unwrap_err().code,
        ErrorCode::BadField
    );
}

/// `vlPosition` is finite however far the point: a world coordinate beyond f32's range is
/// ±`f32::MAX`, one within it the f32 nearest (as `as f32` rounds), a NaN 0.
#[test]
fn world_positions_are_finite_f32() {
    let far = Sample::new([0.5; 3], [1e39, -1e300, 2.5e38]);
    assert_eq!(far.world_position(), [f32::MAX, -f32::MAX, 2.5e38]);
    let near = Sample::new([0.5; 3], [0.1, -3.0, f32::MAX as f64]);
    assert_eq!(near.world_position(), [0.1f64 as f32, -3.0, f32::MAX]);
    let nan = Sample::new([0.5; 3], [f64::NAN, f64::INFINITY, f64::NEG_INFINITY]);
    assert_eq!(nan.world_position(), [0.0, f32::MAX, -f32::MAX]);
}
