//! Unit tests of `num`.

use super::*;

/// Against the library functions, bit for bit, on integers, halves, values next to
/// integers, zeros of both signs, huge and special values.
#[test]
fn floor_and_ceil_match_the_library() {
    let mut xs = vec![
        0.0,
        -0.0,
        0.5,
        -0.5,
        1.0,
        -1.0,
        2.5,
        -2.5,
        1e-300,
        -1e-300,
        INTEGRAL,
        -INTEGRAL,
        INTEGRAL - 0.5,
        -(INTEGRAL - 0.5),
        1e300,
        -1e300,
        f64::MAX,
        f64::MIN,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for i in -2000..2000 {
        let x = i as f64 * 0.37;
        xs.extend([x, x.next_up(), x.next_down()]);
    }
    for x in xs {
        assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "floor({x:e})");
        assert_eq!(ceil(x).to_bits(), x.ceil().to_bits(), "ceil({x:e})");
    }
    assert!(floor(f64::NAN).is_nan() && ceil(f64::NAN).is_nan());
}

/// An allocation larger than any address space is `NoMemory`, not an abort; one that fits is
/// the vector asked for.
#[test]
fn impossible_allocations_are_no_memory() {
    use crate::error::ErrorCode;
    let e = try_vec(usize::MAX / 2, 0u8, "a test buffer").unwrap_err();
    assert_eq!(e.code, ErrorCode::NoMemory);
    assert!(e.message.starts_with("a test buffer: "), "{}", e.message);
    let e = try_with_capacity::<[f32; 10]>(usize::MAX / 8, "fields").unwrap_err();
    assert_eq!(e.code, ErrorCode::NoMemory);
    assert_eq!(try_vec(3, 7u16, "small").unwrap(), vec![7u16; 3]);
    assert_eq!(try_with_capacity::<u8>(5, "small").unwrap().capacity(), 5);
}

/// A vector long enough to be filled in parallel holds the value everywhere, in the room
/// reserved for it (no reallocation beyond `len`).
#[test]
fn long_vectors_are_filled_whole() {
    for len in [PARALLEL_FILL - 1, PARALLEL_FILL, 3 * PARALLEL_FILL + 7] {
        let v = try_vec(len, [1.5f32, -2.0], "a test buffer").unwrap();
        assert_eq!(v.len(), len);
        assert_eq!(v.capacity(), len);
        assert!(v.iter().all(|&p| p == [1.5, -2.0]));
    }
}
