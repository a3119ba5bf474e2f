//! The bounded CI run of the two fuzz targets (`fuzz/`, cargo-fuzz, nightly), as proptest
//! properties with a fixed seed so that CI needs only stable Rust and every run is the same:
//!
//! - `vlb_reader`: arbitrary bytes, and `.vlb` headers built field by field with one defect at a
//!   time, through `Dataset::from_vlb_bytes` and `Dataset::load`; structured headers are also
//!   checked against an independent oracle for the exact error code.
//! - `command_sequence`: random byte strings read as API call sequences on `vlib::Library` by the
//!   interpreter the fuzz target uses (`fuzz/src/driver.rs`, included here by path), including
//!   field functions that panic (caught, reported as `Internal`).
//!
//! `VLIB_FUZZ_CASES` multiplies the case counts (a longer local run); the seed is fixed unless
//! `VLIB_FUZZ_SEED` gives another. See docs/dev/robustness.md.

#[path = "../fuzz/src/driver.rs"]
mod driver;

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use std::path::PathBuf;
use vlib::limits::MAX_VOXELS;
use vlib::vlb::HEADER_LEN;
use vlib::Dataset;
use vlib::ErrorCode;

/// A runner with a fixed seed, `cases` cases (times `VLIB_FUZZ_CASES`), no regression files.
fn runner(cases: u32, salt: u8) -> TestRunner {
    let scale: u32 = std::env::var("VLIB_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let seed: u8 = std::env::var("VLIB_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0x5e);
    let config = Config {
        cases: cases * scale,
        failure_persistence: None,
        max_shrink_iters: 2048,
        ..Config::default()
    };
    let mut key = [seed; 32];
    key[0] = salt;
    TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &key))
}

/// A scratch directory, in memory (/dev/shm) where there is one: outputs are written with
/// fsync, which costs milliseconds on a disk.
fn scratch(tag: &str) -> PathBuf {
    let shm = std::path::Path::new("/dev/shm");
    let base = if shm.is_dir() {
        shm.to_path_buf()
    } else {
        std::env::temp_dir()
    };
    base.join(format!("vlib-fuzz-props-{tag}-{}", std::process::id()))
}

/// Any bytes, biased towards starting with the magic number.
fn any_bytes() -> impl Strategy<Value = Vec<u8>> {
    (any::<bool>(), prop::collection::vec(any::<u8>(), 0..96)).prop_map(|(magic, mut v)| {
        if magic {
            let mut m = b"VLB1".to_vec();
            m.append(&mut v);
            m
        } else {
            v
        }
    })
}

#[test]
fn vlb_reader_arbitrary_bytes() {
    let dir = scratch("vlb");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("input.vlb");
    runner(4000, 1)
        .run(&any_bytes(), |bytes| {
            driver::check_vlb(&bytes, Some(&file));
            Ok(())
        })
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// A `.vlb` file described field by field.
#[derive(Clone, Debug)]
struct Vlb {
    magic: [u8; 4],
    dims: [u32; 3],
    width: u32,
    a: f32,
    b: f32,
    /// Body length relative to what the header claims (when that is small).
    delta: i8,
    /// Total length cut to this many bytes (when below the full length).
    cut: usize,
}

impl Vlb {
    fn bytes(&self) -> Vec<u8> {
        let mut v = self.magic.to_vec();
        for d in self.dims {
            v.extend_from_slice(&d.to_le_bytes());
        }
        v.extend_from_slice(&self.width.to_le_bytes());
        v.extend_from_slice(&self.a.to_le_bytes());
        v.extend_from_slice(&self.b.to_le_bytes());
        let body = self.claimed_body().filter(|&n| n <= 4096).unwrap_or(0);
        let body = (body as i64 + self.delta as i64).max(0) as usize;
        v.extend((0..body).map(|i| (i * 37 % 251) as u8));
        v.truncate(self.cut);
        v
    }

    /// The body length the header claims, if it is representable.
    fn claimed_body(&self) -> Option<u64> {
        self.dims
            .iter()
            .try_fold(1u64, |acc, &d| acc.checked_mul(d as u64))
            .and_then(|n| n.checked_mul(self.width as u64))
    }

    /// The code the reader must give, by the documented checks in their documented order
    /// (docs/dev/robustness.md): magic, header length, dimensions, voxel width, range, file length.
    fn expected(&self) -> ErrorCode {
        let bytes = self.bytes();
        let n = bytes.len().min(4);
        if bytes[..n] != b"VLB1"[..n] {
            return ErrorCode::BadMagic;
        }
        if bytes.len() < HEADER_LEN {
            return ErrorCode::BadSize;
        }
        let voxels = self
            .dims
            .iter()
            .try_fold(1u64, |acc, &d| acc.checked_mul(d as u64));
        if self.dims.contains(&0)
            || self.dims.iter().any(|&d| d > i32::MAX as u32)
            || voxels.is_none_or(|v| v > MAX_VOXELS)
        {
            return ErrorCode::BadDimensions;
        }
        if self.width != 1 && self.width != 2 {
            return ErrorCode::BadVoxelWidth;
        }
        if !self.a.is_finite() || !self.b.is_finite() || self.a == self.b {
            return ErrorCode::BadRange;
        }
        let need = HEADER_LEN as u64 + self.claimed_body().expect("at most 2^33 bytes");
        if bytes.len() as u64 != need {
            return ErrorCode::BadSize;
        }
        ErrorCode::NoError
    }
}

fn special_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => (0u8..=255).prop_map(|v| v as f32),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(0.0f32),
        1 => Just(-0.0f32),
        1 => any::<f32>(),
    ]
}

/// Dimensions: small, zero, large, and ones whose product overflows u64.
fn dim() -> impl Strategy<Value = u32> {
    prop_oneof![
        6 => 1u32..6,
        1 => Just(0u32),
        1 => Just(1u32 << 16),
        1 => Just(100_000u32),
        1 => Just(1u32 << 22),
        1 => Just(i32::MAX as u32),
        1 => Just(1u32 << 31),
        1 => Just(u32::MAX),
    ]
}

fn vlb() -> impl Strategy<Value = Vlb> {
    (
        prop_oneof![8 => Just(*b"VLB1"), 1 => any::<[u8; 4]>(), 1 => Just(*b"VLB2")],
        [dim(), dim(), dim()],
        prop_oneof![8 => 1u32..=2, 1 => Just(0u32), 1 => Just(3u32), 1 => any::<u32>()],
        special_f32(),
        special_f32(),
        prop_oneof![8 => Just(0i8), 1 => -3i8..0, 1 => 1i8..4],
        prop_oneof![8 => Just(usize::MAX), 1 => 0usize..40],
    )
        .prop_map(|(magic, dims, width, a, b, delta, cut)| Vlb {
            magic,
            dims,
            width,
            a,
            b,
            delta,
            cut,
        })
}

#[test]
fn vlb_reader_structured_headers_give_the_documented_code() {
    let dir = scratch("vlb-structured");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("input.vlb");
    let seen = std::cell::RefCell::new(std::collections::BTreeSet::new());
    runner(4000, 2)
        .run(&vlb(), |v| {
            let bytes = v.bytes();
            driver::check_vlb(&bytes, Some(&file));
            let got = match Dataset::from_vlb_bytes(&bytes) {
                Ok(_) => ErrorCode::NoError,
                Err(e) => e.code,
            };
            prop_assert_eq!(got, v.expected(), "{:?}", v);
            seen.borrow_mut().insert(got as i32);
            Ok(())
        })
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    // Every outcome was reached: accepted, and each of the reader's five refusals.
    assert_eq!(
        seen.into_inner().into_iter().collect::<Vec<_>>(),
        vec![0, 13, 14, 15, 16, 17],
        "outcomes reached"
    );
}

/// A well-formed 8-bit header of dimensions `dims` (a = 0, b = 1), with the voxels it claims
/// where they are few.
fn header(dims: [u32; 3]) -> Vlb {
    Vlb {
        magic: *b"VLB1",
        dims,
        width: 1,
        a: 0.0,
        b: 1.0,
        delta: 0,
        cut: usize::MAX,
    }
}

/// An axis of more than 2³¹ − 1 nodes is refused whatever the product (a sample's cell index
/// is an i32; 2³² along x with the others 1 is within `MAX_VOXELS`); one of 2³¹ − 1 passes the
/// dimension check and meets the length check.
#[test]
fn vlb_header_axis_beyond_i32_is_refused() {
    let big = 1u32 << 31;
    for dims in [[big, 1, 1], [1, big, 1], [1, 1, u32::MAX], [u32::MAX, 1, 1]] {
        let e = Dataset::from_vlb_bytes(&header(dims).bytes()).unwrap_err();
        assert_eq!(e.code, ErrorCode::BadDimensions, "{dims:?}: {e}");
        assert!(e.message.contains("along an axis"), "{dims:?}: {e}");
    }
    let e = Dataset::from_vlb_bytes(&header([i32::MAX as u32, 1, 1]).bytes()).unwrap_err();
    assert_eq!(e.code, ErrorCode::BadSize, "{e}");
}

/// Dimensions whose product overflows u64 (2^22 × 2^22 × 2^22 wraps to 0) are refused as too
/// large, never wrapped: once a gap, found by the fuzzer (docs/dev/robustness.md).
#[test]
fn vlb_header_dims_product_overflow() {
    for dims in [[1u32 << 22; 3], [u32::MAX; 3], [1 << 21, 1 << 21, 1 << 22]] {
        let v = header(dims);
        let r = std::panic::catch_unwind(|| Dataset::from_vlb_bytes(&v.bytes()).map(|_| ()));
        match r {
            Ok(Err(e)) => assert_eq!(e.code, ErrorCode::BadDimensions, "{dims:?}: {e}"),
            Ok(Ok(())) => panic!("{dims:?} accepted"),
            Err(_) => panic!("{dims:?}: the reader panicked"),
        }
    }
}

/// Byte strings for the interpreter: mostly short, some long.
fn program() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        3 => prop::collection::vec(any::<u8>(), 0..128),
        1 => prop::collection::vec(any::<u8>(), 128..600),
    ]
}

fn sequences(cases: u32, salt: u8, allow_panics: bool) {
    let dir = scratch(&format!("seq-{salt}"));
    let cfg = driver::Config {
        allow_panics,
        ..driver::Config::default()
    };
    let total = std::cell::Cell::new(driver::Stats::default());
    let start = std::time::Instant::now();
    runner(cases, salt)
        .run(&program(), |bytes| {
            let mut t = total.get();
            t += driver::run(&bytes, &dir, cfg);
            total.set(t);
            Ok(())
        })
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let total = total.get();
    println!(
        "command sequences (panicking callbacks {allow_panics}): {total:?} in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    assert!(
        total.scenes > 0 && total.images > 0 && total.volumes > 0,
        "{total:?}"
    );
    assert!(total.failed_outputs > 0, "{total:?}");
    assert_eq!(allow_panics, total.caught_panics > 0, "{total:?}");
}

#[test]
fn command_sequences() {
    sequences(5000, 3, false);
}

#[test]
fn command_sequences_with_panicking_callbacks() {
    // The panics are caught by the renderer; silence the default hook's messages for them.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .copied()
            .unwrap_or_default();
        if !msg.contains("(fuzz)") {
            hook(info);
        }
    }));
    sequences(1000, 4, true);
}
