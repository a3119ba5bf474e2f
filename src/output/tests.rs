//! Unit tests of the output layer: image encoding and atomic writes.

use super::files::*;
use crate::error::ErrorCode;
use std::fs;
use std::path::Path;

#[test]
fn formats_by_extension() {
    assert_eq!(
        ImageFormat::from_path(Path::new("a.PPM")).unwrap(),
        ImageFormat::Ppm
    );
    assert_eq!(
        ImageFormat::from_path(Path::new("x/a.png")).unwrap(),
        ImageFormat::Png
    );
    for bad in ["a.jpg", "a", "", "/"] {
        assert_eq!(
            ImageFormat::from_path(Path::new(bad)).unwrap_err().code,
            ErrorCode::BadFile,
            "{bad}"
        );
    }
}

#[test]
fn ppm_layout_and_atomic_write() {
    let dir = std::env::temp_dir().join(format!("vlib-out-{}", std::process::id()));
    fs::create_dir_all(&dir).unwrap();
    let p = dir.join("t.ppm");
    let rgb = [1u8, 2, 3, 4, 5, 6];
    write_image(&p, 2, 1, &rgb).unwrap();
    let bytes = fs::read(&p).unwrap();
    assert_eq!(&bytes[..11], b"P6\n2 1\n255\n");
    assert_eq!(&bytes[11..], &rgb);
    // No temporary file is left behind.
    let left: Vec<_> = fs::read_dir(&dir).unwrap().collect();
    assert_eq!(left.len(), 1);
    // An unwritable destination is an I/O error and leaves the old file intact.
    let bad = dir.join("no-such-dir").join("t.png");
    assert_eq!(
        write_image(&bad, 2, 1, &rgb).unwrap_err().code,
        ErrorCode::IoError
    );
    fs::remove_dir_all(&dir).unwrap();
}
