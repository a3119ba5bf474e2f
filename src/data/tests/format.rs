//! Tests of the `.vlb` format: round trips, and malformed files refused with the right error.

use super::*;
use crate::error::ErrorCode;

#[test]
fn vlb_round_trip_is_bit_exact() {
    let d8 = random_u8([7, 3, 5], 6);
    let back = Dataset::from_vlb_bytes(&d8.to_vlb_bytes().unwrap()).unwrap();
    assert_eq!(back, d8);
    assert_eq!(back.to_vlb_bytes().unwrap(), d8.to_vlb_bytes().unwrap());
    let (d16, _) = linear([4, 3, 2]);
    let bytes = d16.to_vlb_bytes().unwrap();
    assert_eq!(bytes.len(), HEADER_LEN + 4 * 3 * 2 * 2);
    assert_eq!(&bytes[..4], b"VLB1");
    assert_eq!(Dataset::from_vlb_bytes(&bytes).unwrap(), d16);
    // Files too.
    let path = std::env::temp_dir().join(format!("vlib-rt-{}.vlb", std::process::id()));
    d16.save(&path).unwrap();
    assert_eq!(Dataset::load(&path).unwrap(), d16);
    std::fs::remove_file(&path).unwrap();
}

/// A 16-bit file composed byte by byte from the format's description (not by our writer),
/// large enough for the voxels' memory to be made in parallel (`num::PARALLEL_FILL`): the
/// voxels' two bytes differ (a swapped pair gives another value) and so do neighbours (a
/// shifted, repeated or skipped voxel too); and a file one byte short of its voxels is refused.
#[test]
fn sixteen_bit_files_load_their_little_endian_voxels() {
    let dims = [64u32, 32, 32];
    let n = (dims[0] * dims[1] * dims[2]) as usize;
    assert!(n >= crate::num::PARALLEL_FILL);
    // Low byte i mod 251, the high one 1 to 254 above it (mod 256).
    let voxels: Vec<u16> = (0..n)
        .map(|i| {
            let lo = (i % 251) as u8;
            let hi = lo.wrapping_add(1 + (i / 251 % 254) as u8);
            u16::from_le_bytes([lo, hi])
        })
        .collect();
    assert!(voxels.iter().all(|v| v >> 8 != v & 0xff) && voxels.windows(2).all(|w| w[0] != w[1]));
    let mut bytes = b"VLB1".to_vec();
    for d in dims.iter().chain(&[2u32]) {
        bytes.extend_from_slice(&d.to_le_bytes());
    }
    bytes.extend_from_slice(&0f32.to_le_bytes());
    bytes.extend_from_slice(&65535f32.to_le_bytes());
    for v in &voxels {
        bytes.extend_from_slice(&[(v & 0xff) as u8, (v >> 8) as u8]);
    }
    let path = std::env::temp_dir().join(format!("vlib-le16-{}.vlb", std::process::id()));
    std::fs::write(&path, &bytes).unwrap();
    let d = Dataset::load(&path).unwrap();
    let last = voxels[n - 1] as f64;
    assert_eq!(d.raw(), &Voxels::U16(voxels));
    assert_eq!(d.raw_node(63, 31, 31), last);
    std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
    assert_eq!(Dataset::load(&path).unwrap_err().code, ErrorCode::BadSize);
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn malformed_files_are_refused_with_the_right_error() {
    let good = random_u8([3, 2, 2], 7).to_vlb_bytes().unwrap();
    let patch = |at: usize, bytes: &[u8]| {
        let mut v = good.clone();
        v[at..at + bytes.len()].copy_from_slice(bytes);
        v
    };
    let cases: Vec<(&str, Vec<u8>, ErrorCode)> = vec![
        ("empty", vec![], ErrorCode::BadSize),
        ("short header", good[..20].to_vec(), ErrorCode::BadSize),
        ("short non-vlb file", b"P6\n".to_vec(), ErrorCode::BadMagic),
        ("bad magic", patch(0, b"VLB2"), ErrorCode::BadMagic),
        (
            "zero dimension",
            patch(8, &0u32.to_le_bytes()),
            ErrorCode::BadDimensions,
        ),
        (
            "10^15 voxels",
            {
                let mut v = patch(4, &100_000u32.to_le_bytes());
                v[8..12].copy_from_slice(&100_000u32.to_le_bytes());
                v[12..16].copy_from_slice(&100_000u32.to_le_bytes());
                v
            },
            ErrorCode::BadDimensions,
        ),
        (
            "voxel width 3",
            patch(16, &3u32.to_le_bytes()),
            ErrorCode::BadVoxelWidth,
        ),
        (
            "voxel width 0",
            patch(16, &0u32.to_le_bytes()),
            ErrorCode::BadVoxelWidth,
        ),
        (
            "a = b",
            patch(24, &10.0f32.to_le_bytes()),
            ErrorCode::BadRange,
        ),
        (
            "a NaN",
            patch(20, &f32::NAN.to_le_bytes()),
            ErrorCode::BadRange,
        ),
        (
            "b infinite",
            patch(24, &f32::INFINITY.to_le_bytes()),
            ErrorCode::BadRange,
        ),
        (
            "truncated voxels",
            good[..good.len() - 1].to_vec(),
            ErrorCode::BadSize,
        ),
        (
            "trailing data",
            [good.clone(), vec![0]].concat(),
            ErrorCode::BadSize,
        ),
        (
            "16-bit claim on 8-bit data",
            patch(16, &2u32.to_le_bytes()),
            ErrorCode::BadSize,
        ),
    ];
    let dir = std::env::temp_dir().join(format!("vlib-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, bytes, code) in cases {
        assert_eq!(
            Dataset::from_vlb_bytes(&bytes).unwrap_err().code,
            code,
            "{name} (memory)"
        );
        let path = dir.join("bad.vlb");
        std::fs::write(&path, &bytes).unwrap();
        assert_eq!(
            Dataset::load(&path).unwrap_err().code,
            code,
            "{name} (file)"
        );
    }
    assert_eq!(
        Dataset::load(&dir.join("missing.vlb")).unwrap_err().code,
        ErrorCode::IoError
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Files that are not regular files are refused with `VL_IOERROR` without waiting: a FIFO with
/// no writer (whose plain open would block forever), a character device, a directory.
#[test]
fn non_regular_files_are_refused_without_blocking() {
    let dir = std::env::temp_dir().join(format!("vlib-fifo-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let fifo = dir.join("pipe.vlb");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo");
    let mut paths = vec![fifo, dir.clone()];
    if std::path::Path::new("/dev/null").exists() {
        paths.push("/dev/null".into());
    }
    for p in paths {
        let (tx, rx) = std::sync::mpsc::channel();
        let q = p.clone();
        std::thread::spawn(move || {
            let _ = tx.send(Dataset::load(&q).map(|_| ()).map_err(|e| e.code));
        });
        let got = rx
            .recv_timeout(std::time::Duration::from_secs(10))
            .unwrap_or_else(|_| panic!("{}: vlLoad blocked", p.display()));
        assert_eq!(got, Err(ErrorCode::IoError), "{}", p.display());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A placement sidecar that is not a regular file is refused with `VL_IOERROR` without
/// waiting or reading without end: a FIFO with no writer, a link to an endless device, a
/// directory. One longer than a placement can be is refused with `VL_BADVALUE` before it is
/// read. Where no sidecar is, the dataset loads without a placement.
#[test]
fn sidecars_that_are_not_regular_files_are_refused_without_blocking() {
    let dir = std::env::temp_dir().join(format!("vlib-sidecar-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let vlb = dir.join("d.vlb");
    std::fs::write(&vlb, random_u8([3, 2, 2], 7).to_vlb_bytes().unwrap()).unwrap();
    let side = super::super::Geometry::sidecar(&vlb);
    let load = |want: Option<ErrorCode>, what: &str| {
        let (tx, rx) = std::sync::mpsc::channel();
        let q = vlb.clone();
        std::thread::spawn(move || {
            let _ = tx.send(Dataset::load(&q).map(|d| d.geometry().is_some()));
        });
        let got = rx
            .recv_timeout(std::time::Duration::from_secs(10))
            .unwrap_or_else(|_| panic!("{what}: vlLoad blocked"));
        match want {
            Some(code) => assert_eq!(got.map_err(|e| e.code), Err(code), "{what}"),
            None => assert_eq!(got.map_err(|e| e.code), Ok(false), "{what}"),
        }
    };
    load(None, "no sidecar");
    let made = std::process::Command::new("mkfifo").arg(&side).status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo");
    load(Some(ErrorCode::IoError), "a FIFO");
    std::fs::remove_file(&side).unwrap();
    if std::path::Path::new("/dev/zero").exists() {
        std::os::unix::fs::symlink("/dev/zero", &side).unwrap();
        load(Some(ErrorCode::IoError), "a link to /dev/zero");
        std::fs::remove_file(&side).unwrap();
    }
    std::fs::create_dir(&side).unwrap();
    load(Some(ErrorCode::IoError), "a directory");
    std::fs::remove_dir(&side).unwrap();
    // One byte more than the most a sidecar may hold, in comment lines.
    let long = "#".repeat(63) + "\n";
    std::fs::write(&side, long.repeat(1024) + "#").unwrap();
    load(Some(ErrorCode::BadValue), "a sidecar of 64 KiB + 1");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A cache whose computation fails is left empty and the error returned (a later call
/// computes it again), and the infallible form unwinds with the error instead of aborting.
#[test]
fn failed_caches_stay_empty_and_report_their_error() {
    use crate::error::{Error, ErrorCode};
    let cell = std::sync::OnceLock::new();
    let fail = || {
        Err(Error::new(
            ErrorCode::NoMemory,
            "a cache: 8 bytes could not be allocated",
        ))
    };
    let e = super::super::get_or_try_init(&cell, fail).unwrap_err();
    assert_eq!(e.code, ErrorCode::NoMemory);
    assert!(cell.get().is_none());
    assert_eq!(
        *super::super::get_or_try_init(&cell, || Ok(7u64)).unwrap(),
        7
    );
    assert_eq!(
        *super::super::get_or_try_init(&cell, fail).unwrap(),
        7,
        "kept"
    );
    // The infallible accessor unwinds with the error, which the render's boundary returns.
    let unwound = std::panic::catch_unwind(|| super::super::or_unwind(fail()));
    let payload = unwound.unwrap_err();
    assert_eq!(payload.downcast_ref::<Error>(), Some(&fail().unwrap_err()));
    let caught = crate::error::catch("a test", || Ok(super::super::or_unwind(fail())));
    assert_eq!(caught, fail());
}
