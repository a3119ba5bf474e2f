//! `vlconvert` end to end: raw volumes (8 and 16 bits, both byte orders), grey and colour
//! images, `info`, and the exit codes for bad input, bad command lines and an output closed or
//! full.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use vlib::{Dataset, Voxels};

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vlconvert"))
        .args(args)
        .output()
        .unwrap()
}

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vlconvert-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn raw_volumes_convert_in_both_byte_orders() {
    let d = tmp("raw");
    let raw8 = d.join("v8.raw");
    let bytes: Vec<u8> = (0..24u8).collect();
    std::fs::write(&raw8, &bytes).unwrap();
    let out = d.join("v8.vlb");
    let o = run(&["raw", s(&raw8), s(&out), "--dims", "4", "3", "2"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = Dataset::load(&out).unwrap();
    assert_eq!(v.dims(), [4, 3, 2]);
    assert_eq!(v.raw(), &Voxels::U8(bytes.clone()));
    assert_eq!(v.range(), (0.0, 255.0));

    // 16 bits, big-endian, with a header to skip and a custom normalisation.
    let words: Vec<u16> = (0..8).map(|i| 1000 * i + 7).collect();
    let mut file = vec![0xAAu8; 5];
    file.extend(words.iter().flat_map(|w| w.to_be_bytes()));
    let raw16 = d.join("v16.raw");
    std::fs::write(&raw16, &file).unwrap();
    let out16 = d.join("v16.vlb");
    let o = run(&[
        "raw",
        s(&raw16),
        s(&out16),
        "--dims",
        "2",
        "2",
        "2",
        "--bytes",
        "2",
        "--endian",
        "big",
        "--skip",
        "5",
        "--a",
        "-10",
        "--b",
        "7000",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = Dataset::load(&out16).unwrap();
    assert_eq!(v.raw(), &Voxels::U16(words));
    assert_eq!(v.range(), (-10.0, 7000.0));

    // Too short for the dimensions: exit 1 with a message, no output.
    let out_bad = d.join("bad.vlb");
    let o = run(&["raw", s(&raw8), s(&out_bad), "--dims", "4", "4", "4"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("needed"));
    assert!(!out_bad.exists());
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn images_become_slabs_with_rows_flipped_upwards() {
    let d = tmp("img");
    // A 3×2 grey image: top row 10 20 30, bottom row 40 50 60.
    let grey = d.join("g.png");
    image::GrayImage::from_raw(3, 2, vec![10, 20, 30, 40, 50, 60])
        .unwrap()
        .save(&grey)
        .unwrap();
    let out = d.join("g.vlb");
    assert!(run(&["image", s(&grey), s(&out)]).status.success());
    let v = Dataset::load(&out).unwrap();
    assert_eq!(v.dims(), [3, 2, 1]);
    // Object y runs upwards: node row 0 is the image's bottom row.
    assert_eq!(v.raw(), &Voxels::U8(vec![40, 50, 60, 10, 20, 30]));

    // A colour PPM gives three datasets.
    let colour = d.join("c.ppm");
    image::RgbImage::from_raw(2, 1, vec![1, 2, 3, 4, 5, 6])
        .unwrap()
        .save(&colour)
        .unwrap();
    let base = d.join("c.vlb");
    assert!(run(&["image", s(&colour), s(&base)]).status.success());
    for (suffix, want) in [
        ("c_r.vlb", [1u8, 4]),
        ("c_g.vlb", [2, 5]),
        ("c_b.vlb", [3, 6]),
    ] {
        let v = Dataset::load(&d.join(suffix)).unwrap();
        assert_eq!(v.raw(), &Voxels::U8(want.to_vec()), "{suffix}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn info_describes_a_file_and_refuses_a_malformed_one() {
    let d = tmp("info");
    let v = Dataset::new(
        [5, 1, 2],
        Voxels::U16(vec![0, 1, 2, 3, 4, 500, 6, 7, 8, 9]),
        0.0,
        1000.0,
    )
    .unwrap();
    let f = d.join("v.vlb");
    v.save(&f).unwrap();
    let o = run(&["info", s(&f)]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("5 x 1 x 2"), "{text}");
    assert!(text.contains("voxel width: 2 byte"), "{text}");
    assert!(text.contains("a, b:        0 1000"), "{text}");
    assert!(text.contains("0 … 500"), "{text}");
    let bad = d.join("bad.vlb");
    std::fs::write(&bad, b"VLB2 not really").unwrap();
    let o = run(&["info", s(&bad)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("magic"));
    std::fs::remove_dir_all(&d).unwrap();
}

/// Standard output closed by its reader (`vlconvert info f | head -1`) ends the report
/// quietly with success, and a conversion still writes its file; any other failure to write
/// the report (a full device) is an error with exit code 1.
#[test]
fn a_closed_output_is_not_a_failure_but_a_full_one_is() {
    let d = tmp("pipe");
    let f = d.join("v.vlb");
    Dataset::new([2, 2, 1], Voxels::U8(vec![0, 1, 2, 3]), 0.0, 255.0)
        .unwrap()
        .save(&f)
        .unwrap();
    let raw = d.join("v.raw");
    std::fs::write(&raw, [9u8, 8, 7, 6]).unwrap();
    let out = d.join("out.vlb");
    for args in [
        vec!["info", s(&f)],
        vec!["raw", s(&raw), s(&out), "--dims", "2", "2", "1"],
    ] {
        // A pipe whose reading end is closed before the program writes a byte.
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let o = Command::new(env!("CARGO_BIN_EXE_vlconvert"))
            .args(&args)
            .stdout(writer)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{args:?}: {:?} {err}", o.status);
        assert!(err.is_empty(), "{args:?}: {err}");
    }
    assert_eq!(
        Dataset::load(&out).unwrap().raw(),
        &Voxels::U8(vec![9, 8, 7, 6])
    );
    if let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") {
        let o = Command::new(env!("CARGO_BIN_EXE_vlconvert"))
            .args(["info", s(&f)])
            .stdout(full)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(1));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("writing to standard output"), "{err}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn command_line_errors_exit_2_and_help_exits_0() {
    assert_eq!(run(&["frobnicate"]).status.code(), Some(2));
    assert_eq!(
        run(&["raw", "a", "b"]).status.code(),
        Some(2),
        "--dims is required"
    );
    let help = run(&["--help"]);
    assert_eq!(help.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&help.stdout).contains("nifti"));
}
