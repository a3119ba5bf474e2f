//! `vlconvert` end to end: raw volumes (every element type, both byte orders), NIfTI files of
//! every data type written by nibabel (`tests/fixtures/nifti`) and MetaImage files written by
//! SimpleITK (`tests/fixtures/metaimage`), each with the writer's own values beside it, grey and
//! colour images, `info`, and the exit codes for bad input, bad command
//! lines and an output closed or full.

mod common;

use common::{
    assert_writers_values, converts_like_the_writer, fixture, normalised, run, s, text, tmp,
    writers_values,
};
use std::path::Path;
use std::process::Command;
use vlib::{Dataset, Voxels};

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
    assert_eq!(v.range(), (0.0, 23.0), "the data's range by default");

    // 16 bits, big-endian, with a header to skip and a custom normalisation.
    let words: Vec<u16> = (0..8).map(|i| 1000 * i + 7).collect();
    let mut file = vec![0xAAu8; 5];
    file.extend(words.iter().flat_map(|w| w.to_be_bytes()));
    let raw16 = d.join("v16.raw");
    std::fs::write(&raw16, &file).unwrap();
    let out16 = d.join("v16.vlb");
    // The file's layout, for every conversion of it below.
    let raw16_args = [
        "raw",
        s(&raw16),
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
    ];
    let o = run(&[&raw16_args[..], &[s(&out16), "--a", "-10", "--b", "7000"]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = Dataset::load(&out16).unwrap();
    assert_eq!(v.raw(), &Voxels::U16(words));
    assert_eq!(v.range(), (-10.0, 7000.0));

    // --b alone at or below the data's smallest value (7) would invert the window, --a alone at
    // or above its largest (7007) would make every voxel 0: both refused; both ends given, an
    // inverted window is what was asked for.
    let inverted = d.join("inverted.vlb");
    let o = run(&[&raw16_args[..], &[s(&inverted), "--b", "5"]].concat());
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--b 5 is at or below the data's smallest value 7:"),
        "{err}"
    );
    assert!(!inverted.exists());
    let o = run(&[&raw16_args[..], &[s(&inverted), "--a", "7007"]].concat());
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--a 7007 is at or above the data's largest value 7007:"),
        "{err}"
    );
    assert!(!inverted.exists());
    let o = run(&[&raw16_args[..], &[s(&inverted), "--window", "7000", "-10"]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(Dataset::load(&inverted).unwrap().range(), (7000.0, -10.0));

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

    // A PAM (P7) written by the image crate, named .pam and without a suffix: detected by
    // `vlconvert IN OUT` as an image, with the rows flipped as `vlconvert image` flips them.
    let mut pam = Vec::new();
    image::DynamicImage::ImageLuma8(
        image::GrayImage::from_raw(3, 2, vec![10, 20, 30, 40, 50, 60]).unwrap(),
    )
    .write_to(&mut std::io::Cursor::new(&mut pam), image::ImageFormat::Pnm)
    .unwrap();
    assert!(pam.starts_with(b"P7"), "{:?}", &pam[..8]);
    for name in ["p.pam", "p"] {
        let input = d.join(name);
        std::fs::write(&input, &pam).unwrap();
        let out = d.join(format!("{name}.vlb"));
        let o = run(&[s(&input), s(&out)]);
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let v = Dataset::load(&out).unwrap();
        assert_eq!(v.raw(), &Voxels::U8(vec![40, 50, 60, 10, 20, 30]), "{name}");
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

/// A `.vlb` whose 16-bit voxels are signed values written as they are (as numpy's int16 bytes
/// would be: the format's voxels are unsigned) is described with a note that says so and how
/// to convert it; the conversion it names gives the values their window meant. A file of
/// unsigned voxels over the same window gets no note.
#[test]
fn info_notes_signed_voxels_in_a_16_bit_file() {
    let d = tmp("signed");
    let hu: [i16; 4] = [-1024, -1000, 0, 3071];
    let write = |name: &str, voxels: &[u8]| {
        let mut bytes = b"VLB1".to_vec();
        for v in [4u32, 1, 1, 2] {
            bytes.extend(v.to_le_bytes());
        }
        for v in [-1024f32, 3071.0] {
            bytes.extend(v.to_le_bytes());
        }
        bytes.extend(voxels);
        let f = d.join(name);
        std::fs::write(&f, bytes).unwrap();
        f
    };
    let signed: Vec<u8> = hu.iter().flat_map(|v| v.to_le_bytes()).collect();
    let f = write("signed.vlb", &signed);
    let o = run(&["info", s(&f)]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("64512"), "{text}");
    assert!(
        text.contains("note:") && text.contains("--type i16"),
        "{text}"
    );
    // The conversion the note names.
    let out = d.join("fixed.vlb");
    let args = [
        "raw",
        s(&f),
        s(&out),
        "--skip",
        "28",
        "--type",
        "i16",
        "--dims",
        "4",
        "1",
        "1",
        "--window",
        "-1024",
        "3071",
    ];
    assert!(run(&args).status.success());
    let v = Dataset::load(&out).unwrap();
    for (i, h) in hu.iter().enumerate() {
        let want = (*h as f64 + 1024.0) / 4095.0;
        let got = v.node(i, 0, 0) as f64;
        assert!((got - want).abs() < 1e-4, "{h}: {got} against {want}");
    }
    // Unsigned voxels 0 … 4095 over that window: no note.
    let unsigned: Vec<u8> = [0u16, 24, 1024, 4095]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let o = run(&["info", s(&write("unsigned.vlb", &unsigned))]);
    assert!(!String::from_utf8_lossy(&o.stdout).contains("note:"));
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

/// Negative option values in exponent form (`-1e-3`, `-2.5e-3`) are values, not flags: `raw`
/// takes them in `--window` and `--a`, `image` in `--a`, and the windows are those values.
#[test]
fn negative_values_with_exponents_are_values() {
    let d = tmp("negative-exponents");
    let raw = d.join("v.raw");
    std::fs::write(&raw, [0u8, 1, 2, 3]).unwrap();
    let out = d.join("v.vlb");
    let dims = ["--dims", "2", "2", "1"];
    for (args, (a, b)) in [
        (&["--window", "-1e-3", "2.5"][..], (-1e-3, 2.5)),
        (&["--a", "-2.5e-3"][..], (-2.5e-3, 3.0)),
        (&["--b", "2.5E+0", "--a=-1E-3"][..], (-1e-3, 2.5)),
    ] {
        let o = run(&[&["raw", s(&raw), s(&out)][..], &dims, args].concat());
        assert!(o.status.success(), "{args:?}: {}", text(&o.stderr));
        assert_windowed(&Dataset::load(&out).unwrap(), &[0.0, 1.0, 2.0, 3.0], a, b);
    }
    let grey = d.join("g.png");
    image::GrayImage::from_raw(2, 1, vec![0, 200])
        .unwrap()
        .save(&grey)
        .unwrap();
    let o = run(&["image", s(&grey), s(&out), "--a", "-2.5e-3", "--b", "1e2"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(Dataset::load(&out).unwrap().range(), (-2.5e-3, 100.0));
    // Ends an f32 cannot hold (1e39 reads as infinite), or equal ends, are refused by name,
    // and the file written before is kept.
    for args in [
        &["--a", "1e39"][..],
        &["--a", "-2.5e-3", "--b", "-1e39"],
        &["--a", "255"],
    ] {
        let o = run(&[&["image", s(&grey), s(&out)][..], args].concat());
        assert_eq!(o.status.code(), Some(1), "{args:?}");
        let err = text(&o.stderr);
        assert!(
            err.contains("--a") && err.contains("must be finite"),
            "{args:?}: {err}"
        );
        assert_eq!(Dataset::load(&out).unwrap().range(), (-2.5e-3, 100.0));
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// Converts the CT fixture `tests/fixtures/<file>` (whose values are in `<stem>.txt`) with
/// `vlconvert <sub> --window -1000 2000`: Hounsfield units −1000 … 2000 to 0 … 1, clamped
/// outside ([`assert_windowed`]).
fn converts_in_a_ct_window(sub: &str, file: &str) {
    let want = writers_values(&fixture(&format!(
        "{}.txt",
        file.rsplit_once('.').unwrap().0
    )));
    let d = tmp(&format!("window-{}", file.replace(['/', '.'], "-")));
    let out = d.join("window.vlb");
    let o = run(&[sub, s(&fixture(file)), s(&out), "--window", "-1000", "2000"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_windowed(&Dataset::load(&out).unwrap(), &want, -1000.0, 2000.0);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Each node's normalised value in `v` is the writer's value in the window `a` … `b`,
/// clamp((w − a)/(b − a), 0, 1), within 10⁻⁶.
fn assert_windowed(v: &Dataset, want: &[f64], a: f64, b: f64) {
    let got = normalised(v);
    assert_eq!(got.len(), want.len(), "nodes");
    for (got, w) in got.iter().zip(want) {
        let expect = ((w - a) / (b - a)).clamp(0.0, 1.0);
        assert!((got - expect).abs() <= 1e-6, "{got} vs {expect} for {w}");
    }
}

/// Every NIfTI fixture converts, and each node's normalised value is the writer's value
/// placed in the data's range, (v − min)/(max − min): within 10⁻⁶ where the type is kept
/// exactly (8- and 16-bit integers, whatever their scaling; the slack is f32's in a and b),
/// within half a quantum of 16 bits (plus that) where it is quantised. 8-bit types give
/// 8-bit voxels, wider ones 16-bit. A window in data units (a CT's −1000 … 2000) clamps.
#[test]
fn nifti_of_every_type_converts_to_the_writers_values() {
    let cases = [
        ("uint8", 1, true),
        ("int8", 1, true),
        ("int16_ct", 2, true),
        ("int16_scaled", 2, true),
        ("int16_negslope", 2, true),
        ("int16_big", 2, true),
        ("uint16", 2, true),
        ("int32", 2, false),
        ("uint32", 2, false),
        ("int64", 2, false),
        ("float32", 2, false),
        ("float32_scaled", 2, false),
        ("float64", 2, false),
    ];
    for (name, width, exact) in cases {
        let file = format!("nifti/{name}.nii");
        converts_like_the_writer("nifti", &file, [5, 4, 3], width, exact);
    }
    converts_in_a_ct_window("nifti", "nifti/int16_ct.nii");
}

/// Raw volumes of signed and float types in either byte order: an int16 −1 is −1 (not 65535),
/// floats are quantised over their range, and a window maps data values.
#[test]
fn raw_volumes_of_every_type_keep_their_values() {
    let d = tmp("rawtypes");
    let values = [-1.0f64, 0.0, 250.5, -32768.0, 32767.0, 7.25, -0.5, 1000.0];
    // The bytes of `v` as type `ty` in either byte order (as the type holds it: integers
    // truncate, i8 saturates, u64 takes 0 for negatives).
    fn encode(ty: &str, v: f64, big: bool) -> Vec<u8> {
        macro_rules! bytes {
            ($x:expr) => {
                if big {
                    $x.to_be_bytes().to_vec()
                } else {
                    $x.to_le_bytes().to_vec()
                }
            };
        }
        match ty {
            "i16" => bytes!(v as i16),
            "i32" => bytes!(v as i32),
            "f32" => bytes!(v as f32),
            "f64" => bytes!(v),
            "i8" => bytes!(v as i8),
            "u64" => bytes!(v as u64),
            _ => unreachable!(),
        }
    }
    let cases = [
        ("i16", true),
        ("i32", false),
        ("f32", false),
        ("f64", false),
        ("i8", true),
        ("u64", false),
    ];
    for (ty, exact) in cases {
        for big in [false, true] {
            // What the type holds of each value (integers truncate, i8 saturates, u64 ≥ 0).
            let held: Vec<f64> = values
                .iter()
                .map(|&v| match ty {
                    "i16" | "i32" => v.trunc(),
                    "i8" => v.clamp(-128.0, 127.0).trunc(),
                    "u64" => v.max(0.0).trunc(),
                    _ => v,
                })
                .collect();
            let file: Vec<u8> = values.iter().flat_map(|&v| encode(ty, v, big)).collect();
            let raw = d.join(format!("{ty}{big}.raw"));
            std::fs::write(&raw, &file).unwrap();
            let out = d.join(format!("{ty}{big}.vlb"));
            let endian = if big { "big" } else { "little" };
            let args = [
                "raw",
                s(&raw),
                s(&out),
                "--dims",
                "2",
                "2",
                "2",
                "--type",
                ty,
                "--endian",
                endian,
            ];
            let o = run(&args);
            assert!(
                o.status.success(),
                "{ty}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            let v = Dataset::load(&out).unwrap();
            let (lo, hi) = held
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                    (l.min(v), h.max(v))
                });
            let tol = if exact { 1e-6 } else { 0.5 / 65535.0 + 1e-6 };
            for (got, w) in normalised(&v).iter().zip(&held) {
                let expect = (w - lo) / (hi - lo);
                assert!(
                    (got - expect).abs() <= tol,
                    "{ty} big {big}: {got} vs {expect} for {w}"
                );
            }
        }
    }
    // --bytes 3 is refused (exit 1); --type and --bytes together are a command-line error.
    let raw = d.join("i16false.raw");
    let out = d.join("x.vlb");
    let base = ["raw", s(&raw), s(&out), "--dims", "2", "2", "2"];
    let o = run(&[&base[..], &["--bytes", "3"]].concat());
    assert_eq!(o.status.code(), Some(1));
    let o = run(&[&base[..], &["--bytes", "2", "--type", "i16"]].concat());
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&d).unwrap();
}

/// Every NRRD fixture (pynrrd: raw, gzip, big-endian, ascii, a detached header) converts to
/// the writer's values; a truncated file, an unknown encoding and a fourth axis are refused
/// (exit 1).
#[test]
fn nrrd_of_every_encoding_converts_to_the_writers_values() {
    for (file, width, exact) in [
        ("nrrd/int16_raw.nrrd", 2, true),
        ("nrrd/uint16_gzip.nrrd", 2, true),
        ("nrrd/float32_big.nrrd", 2, false),
        ("nrrd/float64_ascii.nrrd", 2, false),
        ("nrrd/int8_raw.nrrd", 1, true),
        ("nrrd/uint8_detached.nhdr", 1, true),
    ] {
        converts_like_the_writer("nrrd", file, [5, 4, 3], width, exact);
    }
    let d = tmp("nrrd-bad");
    let good = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/nrrd/int16_raw.nrrd");
    let bytes = std::fs::read(&good).unwrap();
    let short = d.join("short.nrrd");
    std::fs::write(&short, &bytes[..bytes.len() - 10]).unwrap();
    let o = run(&["nrrd", s(&short), s(&d.join("a.vlb"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("needed"));
    let text = String::from_utf8_lossy(&bytes).replace("encoding: raw", "encoding: bzip2");
    let bz = d.join("bz.nrrd");
    std::fs::write(&bz, text.as_bytes()).unwrap();
    let o = run(&["nrrd", s(&bz), s(&d.join("b.vlb"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("bzip2"));
    assert!(!d.join("a.vlb").exists() && !d.join("b.vlb").exists());
    // pynrrd's volume with a fourth axis of size 1: refused in one sentence.
    let text = String::from_utf8_lossy(&bytes)
        .replace("dimension: 3", "dimension: 4")
        .replace("sizes: 5 4 3", "sizes: 5 4 3 1");
    let four = d.join("four.nrrd");
    std::fs::write(&four, text.as_bytes()).unwrap();
    let o = run(&["nrrd", s(&four), s(&d.join("b.vlb"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&o.stderr).ends_with(
            "a 4-dimensional array [5, 4, 3, 1]: only 2D and 3D volumes of one value per voxel \
             convert\n"
        ),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // Hostile headers exit 1 with a message, without a panic, an abort or a hang: sizes whose
    // product overflows, an ascii volume far larger than its file, a negative byte skip, an
    // axis of several values per voxel, a FIFO.
    let header = "NRRD0004\ntype: int16\ndimension: 3\nencoding: raw\n";
    for (name, fields, says) in [
        ("overflow", "sizes: 9223372036854775809 2 1\n", "overflow"),
        (
            "ascii",
            "sizes: 1000000 1000000 100000\nencoding: ascii\n",
            "needed",
        ),
        ("skip", "sizes: 2 2 2\nbyte skip: -7\n", "byte skip"),
        (
            "kinds",
            "sizes: 3 2 2\nkinds: RGB-color domain domain\n",
            "kinds",
        ),
    ] {
        let f = d.join(format!("{name}.nrrd"));
        let text = format!("{header}{fields}\n")
            .replace("encoding: raw\nsizes: 1000000", "sizes: 1000000");
        std::fs::write(&f, text.as_bytes()).unwrap();
        let o = run(&["nrrd", s(&f), s(&d.join("c.vlb"))]);
        assert_eq!(o.status.code(), Some(1), "{name}");
        assert!(
            String::from_utf8_lossy(&o.stderr).contains(says),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let fifo = d.join("fifo");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let o = run(&[s(&fifo), s(&d.join("c.vlb"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not a regular file"));
    // A placement that cannot be made is a note; the volume converts without one.
    let f = d.join("space.nrrd");
    let mut bytes = b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspace: scanner-xyz\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n\n".to_vec();
    bytes.extend([1u8, 2, 3, 4, 5, 6, 7, 8]);
    std::fs::write(&f, &bytes).unwrap();
    let o = run(&["nrrd", s(&f), s(&d.join("e.vlb"))]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no placement"));
    assert!(Dataset::load(&d.join("e.vlb"))
        .unwrap()
        .geometry()
        .is_none());
    std::fs::remove_dir_all(&d).unwrap();
}

/// `vlconvert IN OUT.vlb` tells the format from the file's first bytes: each fixture (NIfTI,
/// the same NIfTI gzipped, NRRD, a detached NRRD header, MetaImage `.mha` and `.mhd`, a PNG) converts to the same bytes as
/// its own subcommand gives; a headerless file and a `.vlb` are refused with a message that
/// says what to do (exit 1).
#[test]
fn the_format_is_told_from_the_file() {
    use std::io::Write;
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    let d = tmp("auto");
    let nii = fixtures.join("nifti/int16_ct.nii");
    let gz = d.join("ct.nii.gz");
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(&std::fs::read(&nii).unwrap()).unwrap();
    std::fs::write(&gz, enc.finish().unwrap()).unwrap();
    let png = d.join("grey.png");
    image::GrayImage::from_fn(6, 5, |x, y| image::Luma([(x * 40 + y) as u8]))
        .save(&png)
        .unwrap();
    for (sub, input) in [
        ("nifti", nii.clone()),
        ("nifti", gz),
        ("nrrd", fixtures.join("nrrd/uint16_gzip.nrrd")),
        ("nrrd", fixtures.join("nrrd/uint8_detached.nhdr")),
        ("metaimage", fixtures.join("metaimage/int16_ct.mha")),
        ("metaimage", fixtures.join("metaimage/uint16.mhd")),
        ("image", png),
    ] {
        let (auto, explicit) = (d.join("auto.vlb"), d.join("explicit.vlb"));
        let o = run(&[s(&input), s(&auto)]);
        assert!(
            o.status.success(),
            "{}: {}",
            input.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        let o = run(&[sub, s(&input), s(&explicit)]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(
            std::fs::read(&auto).unwrap(),
            std::fs::read(&explicit).unwrap(),
            "{}",
            input.display()
        );
    }
    let raw = d.join("volume.raw");
    std::fs::write(&raw, [7u8; 64]).unwrap();
    let o = run(&[s(&raw), s(&d.join("x.vlb"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("vlconvert raw"));
    let o = run(&[s(&d.join("auto.vlb")), s(&d.join("y.vlb"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("already a .vlb"));
    assert!(!d.join("x.vlb").exists() && !d.join("y.vlb").exists());
    std::fs::remove_dir_all(&d).unwrap();
}

/// Every MetaImage fixture (`.mha`, `.mhd` with `.raw` or `.zraw`, zlib-compressed or not)
/// converts, and each node's normalised value is SimpleITK's value placed in the data's range, as
/// for NIfTI; a 2D image is one slab. A CT window (−1000 … 2000) clamps.
#[test]
fn metaimage_of_every_type_converts_to_the_writers_values() {
    let cases = [
        ("int16_ct.mha", [5, 4, 3], 2, true),
        ("uint16.mhd", [5, 4, 3], 2, true),
        ("float32_zlib.mha", [5, 4, 3], 2, false),
        ("int32_zlib.mhd", [5, 4, 3], 2, false),
        ("int8.mha", [5, 4, 3], 1, true),
        ("float64.mha", [5, 4, 3], 2, false),
        ("uint8.mha", [5, 4, 3], 1, true),
        ("uint8_2d.mha", [5, 4, 1], 1, true),
        ("int16_oblique.mha", [5, 4, 3], 2, true),
        ("uint8_spacing.mhd", [5, 4, 3], 1, true),
    ];
    for (file, dims, width, exact) in cases {
        let file = format!("metaimage/{file}");
        converts_like_the_writer("metaimage", &file, dims, width, exact);
    }
    converts_in_a_ct_window("metaimage", "metaimage/int16_ct.mha");
}

/// SimpleITK's 4-D images (`NDims = 4`): 5 x 4 x 3 x 1 converts to the writer's values
/// without a placement (a note says so); 5 x 4 x 3 x 2 is refused by its dimensions.
#[test]
fn metaimage_of_four_dimensions_converts_when_one_volume() {
    converts_like_the_writer("metaimage", "metaimage/int16_4d_1.mha", [5, 4, 3], 2, true);
    let d = tmp("metaimage-4d");
    let out = d.join("v.vlb");
    let o = run(&[s(&fixture("metaimage/int16_4d_1.mha")), s(&out)]);
    let err = text(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("no placement"), "{err}");
    assert!(Dataset::load(&out).unwrap().geometry().is_none());
    std::fs::remove_file(&out).unwrap();
    let o = run(&[s(&fixture("metaimage/int16_4d_2.mha")), s(&out)]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("a 4-dimensional image [5, 4, 3, 2]: only 2D and 3D images convert"),
        "{err}"
    );
    assert!(!out.exists());
    std::fs::remove_dir_all(&d).unwrap();
}

/// Big-endian elements (`ElementByteOrderMSB = True`) at the end of their data file
/// (`HeaderSize = -1`, after bytes that are not data) keep their values.
#[test]
fn metaimage_big_endian_data_at_the_end_of_its_file() {
    let d = tmp("metaimage-msb");
    let values: [i16; 4] = [-300, 0, 1200, 7];
    let mut raw = vec![0xAAu8; 9];
    raw.extend(values.iter().flat_map(|v| v.to_be_bytes()));
    std::fs::write(d.join("v.raw"), &raw).unwrap();
    let mhd = d.join("v.mhd");
    std::fs::write(
        &mhd,
        "ObjectType = Image\nNDims = 3\nDimSize = 2 2 1\nElementByteOrderMSB = True\n\
         HeaderSize = -1\nElementType = MET_SHORT\nElementDataFile = v.raw\n",
    )
    .unwrap();
    let out = d.join("v.vlb");
    let o = run(&["metaimage", s(&mhd), s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let want = values.map(f64::from);
    assert_writers_values("v.mhd", &Dataset::load(&out).unwrap(), &want, true);
    std::fs::remove_dir_all(&d).unwrap();
}

/// A placement that cannot be made (a malformed `ElementSpacing`, parallel axes in
/// `TransformMatrix`) is a note: the volume converts without a sidecar. Without placement keys
/// the sidecar is ITK's default: 1 mm spacing (or `ElementSize`'s, as MetaIO reads it without
/// `ElementSpacing`), node 0 at the origin, LPS axes turned into RAS.
#[test]
fn metaimage_placements_that_cannot_be_made_are_notes() {
    let d = tmp("metaimage-placement");
    std::fs::write(d.join("v.raw"), [1u8, 2, 3, 4]).unwrap();
    let cases = [
        ("ElementSpacing = 1 abc 1\n", Some("ElementSpacing")),
        ("TransformMatrix = 1 0 0 1 0 0 0 0 1\n", Some("degenerate")),
        ("", None),
        ("ElementSize = 0.5 0.5 2\n", None),
    ];
    for (key, note) in cases {
        let mhd = d.join("v.mhd");
        std::fs::write(
            &mhd,
            format!(
                "ObjectType = Image\nNDims = 3\nDimSize = 2 2 1\n{key}\
                 ElementType = MET_UCHAR\nElementDataFile = v.raw\n"
            ),
        )
        .unwrap();
        let out = d.join("v.vlb");
        let o = run(&["metaimage", s(&mhd), s(&out)]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{err}");
        let g = Dataset::load(&out).unwrap().geometry().cloned();
        match note {
            Some(what) => {
                assert!(
                    err.contains("no placement") && err.contains(what),
                    "{key}: {err}"
                );
                assert!(g.is_none(), "{key}");
            }
            None => {
                let g = g.expect("ITK's default placement");
                // ElementSize stands for a missing ElementSpacing, as MetaIO reads it.
                let d = if key.is_empty() {
                    [1.0, 1.0, 1.0]
                } else {
                    [0.5, 0.5, 2.0]
                };
                let want = [
                    [-d[0], 0.0, 0.0, 0.0],
                    [0.0, -d[1], 0.0, 0.0],
                    [0.0, 0.0, d[2], 0.0],
                ];
                assert_eq!(g.affine(), want);
            }
        }
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// A data file shorter than the dimensions need (`.mhd` + `.raw`, `.mha`, compressed `.mha`),
/// several channels and a list of data files each exit 1 with a message and write nothing.
#[test]
fn metaimage_errors_exit_1_without_output() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/metaimage");
    let d = tmp("metaimage-bad");
    let header = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap();
    let bytes = |name: &str| std::fs::read(dir.join(name)).unwrap();
    // uint16.mhd with 100 of its 120 bytes of data.
    std::fs::write(d.join("uint16.mhd"), header("uint16.mhd")).unwrap();
    std::fs::write(d.join("uint16.raw"), &bytes("uint16.raw")[..100]).unwrap();
    // A .mha and a compressed .mha cut 20 bytes short.
    for name in ["int16_ct.mha", "float32_zlib.mha"] {
        let b = bytes(name);
        std::fs::write(d.join(name), &b[..b.len() - 20]).unwrap();
    }
    // Three channels (an RGB image), and a list of slice files.
    let mut rgb = bytes("uint8.mha");
    let at = rgb.windows(11).position(|w| w == b"ElementType").unwrap();
    rgb.splice(at..at, *b"ElementNumberOfChannels = 3\n");
    std::fs::write(d.join("rgb.mha"), rgb).unwrap();
    let list =
        header("uint16.mhd").replace("ElementDataFile = uint16.raw", "ElementDataFile = LIST");
    std::fs::write(d.join("list.mhd"), format!("{list}uint16.raw\n")).unwrap();
    for (name, says) in [
        ("uint16.mhd", "needed"),
        ("int16_ct.mha", "needed"),
        ("float32_zlib.mha", "compressed data"),
        ("rgb.mha", "ElementNumberOfChannels = 3"),
        ("list.mhd", "LIST"),
    ] {
        let out = d.join(format!("{name}.vlb"));
        let o = run(&["metaimage", s(&d.join(name)), s(&out)]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{name}: {err}");
        assert!(err.contains(says), "{name}: {err}");
        assert!(!out.exists(), "{name}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}
