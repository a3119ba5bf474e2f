//! `vlconvert` end to end: raw volumes (every element type, both byte orders), NIfTI files of
//! every data type written by nibabel (`tests/fixtures/nifti`, with the writer's own values
//! beside each), grey and colour images, `info`, and the exit codes for bad input, bad command
//! lines and an output closed or full.

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
    assert_eq!(v.range(), (0.0, 23.0), "the data's range by default");

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

/// The normalised value of every node of `v`, from its voxels and a, b as the file states
/// them: clamp((voxel − a)/(b − a), 0, 1), x fastest.
fn normalised(v: &Dataset) -> Vec<f64> {
    let [nx, ny, nz] = v.dims();
    let (a, b) = v.range();
    let (a, b) = (a as f64, b as f64);
    let mut out = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                out.push(((v.raw_node(i, j, k) - a) / (b - a)).clamp(0.0, 1.0));
            }
        }
    }
    out
}

/// The writer's values of fixture `tests/fixtures/<stem>.txt`, in file order.
fn writers_values(stem: &str) -> Vec<f64> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    std::fs::read_to_string(dir.join(format!("{stem}.txt")))
        .unwrap()
        .lines()
        .map(|l| l.parse().unwrap())
        .collect()
}

/// Converts fixture `tests/fixtures/<file>` with `vlconvert <sub>` and checks the dataset: 5 ×
/// 4 × 3 nodes of `width` bytes, and each node's normalised value the writer's value placed in
/// the data's range, (v − min)/(max − min): within 10⁻⁶ where the type is kept exactly (the
/// slack is f32's in a and b), within half a quantum of 16 bits (plus that) where quantised.
fn converts_like_the_writer(sub: &str, file: &str, width: u32, exact: bool) {
    let input = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(file);
    let stem = file.rsplit_once('.').unwrap().0;
    let want = writers_values(stem);
    let (lo, hi) = want
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let d = tmp(&stem.replace('/', "-"));
    let out = d.join("out.vlb");
    let o = run(&[sub, s(&input), s(&out)]);
    assert!(
        o.status.success(),
        "{file}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let v = Dataset::load(&out).unwrap();
    assert_eq!(v.dims(), [5, 4, 3], "{file}");
    assert_eq!(v.raw().width(), width, "{file}");
    let tol = if exact { 1e-6 } else { 0.5 / 65535.0 + 1e-6 };
    for (n, (got, w)) in normalised(&v).iter().zip(&want).enumerate() {
        let expect = (w - lo) / (hi - lo);
        assert!(
            (got - expect).abs() <= tol,
            "{file} node {n}: {got} vs ({w} − {lo})/({hi} − {lo}) = {expect}"
        );
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// Every NIfTI fixture converts, and each node's normalised value is the writer's value
/// placed in the data's range, (v − min)/(max − min): within 10⁻⁶ where the type is kept
/// exactly (8- and 16-bit integers, whatever their scaling; the slack is f32's in a and b),
/// within half a quantum of 16 bits (plus that) where it is quantised. 8-bit types give
/// 8-bit voxels, wider ones 16-bit. A window in data units (a CT's −1000 … 2000) clamps.
#[test]
fn nifti_of_every_type_converts_to_the_writers_values() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/nifti");
    let d = tmp("nifti");
    let cases = [
        ("uint8", 1, true),
        ("int8", 1, true),
        ("int16_ct", 2, true),
        ("int16_scaled", 2, true),
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
        converts_like_the_writer("nifti", &format!("nifti/{name}.nii"), width, exact);
    }
    // A CT window: Hounsfield units −1000 … 2000 to 0 … 1, clamped outside.
    let want = writers_values("nifti/int16_ct");
    let out = d.join("window.vlb");
    let nii = dir.join("int16_ct.nii");
    let o = run(&["nifti", s(&nii), s(&out), "--window", "-1000", "2000"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = Dataset::load(&out).unwrap();
    for (got, w) in normalised(&v).iter().zip(&want) {
        let expect = ((w + 1000.0) / 3000.0).clamp(0.0, 1.0);
        assert!((got - expect).abs() <= 1e-6, "{got} vs {expect} for {w}");
    }
    std::fs::remove_dir_all(&d).unwrap();
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
    let o = run(&[
        "raw",
        s(&raw),
        s(&d.join("x.vlb")),
        "--dims",
        "2",
        "2",
        "2",
        "--bytes",
        "3",
    ]);
    assert_eq!(o.status.code(), Some(1));
    let o = run(&[
        "raw",
        s(&raw),
        s(&d.join("x.vlb")),
        "--dims",
        "2",
        "2",
        "2",
        "--bytes",
        "2",
        "--type",
        "i16",
    ]);
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&d).unwrap();
}

/// Every NRRD fixture (pynrrd: raw, gzip, big-endian, ascii, a detached header) converts to
/// the writer's values; a truncated file and an unknown encoding are refused (exit 1).
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
        converts_like_the_writer("nrrd", file, width, exact);
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
    std::fs::remove_dir_all(&d).unwrap();
}

/// `vlconvert IN OUT.vlb` tells the format from the file's first bytes: each fixture (NIfTI,
/// the same NIfTI gzipped, NRRD, a detached NRRD header, a PNG) converts to the same bytes as
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
