//! `vlconvert dicom`: DICOM series written by pydicom (`tests/fixtures/dicom`, `make.py`)
//! convert node by node to the modality values pydicom reads back (`NAME.txt`), with the
//! placement numpy computes from the same headers (`NAME.affine.txt`); a folder and a single
//! file are told apart from other formats; every series that does not convert (several series,
//! slices of mixed sizes or orientations, two at one position, a missing slice, several
//! frames, colour, compressed pixel data, hostile lengths) exits 1 with a message naming the
//! file, and writes nothing.

mod common;

use common::{normalised, run, s, text, tmp};
use std::path::{Path, PathBuf};
use std::process::Output;
use vlib::Dataset;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/dicom")
        .join(name)
}

/// The writer's numbers beside a series (`NAME.txt`: one a line; `NAME.affine.txt`: rows).
fn numbers(file: &str) -> Vec<Vec<f64>> {
    std::fs::read_to_string(fixture(file))
        .unwrap()
        .lines()
        .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
        .collect()
}

fn writers_values(series: &str) -> Vec<f64> {
    numbers(&format!("{series}.txt")).concat()
}

/// Runs `args`, which write `out`, and loads it.
fn convert(args: &[&str], out: &Path) -> (Dataset, Output) {
    let o = run(args);
    assert!(o.status.success(), "{args:?}: {}", text(&o.stderr));
    (Dataset::load(out).unwrap(), o)
}

/// Each node's normalised value is the writer's value w placed in the window a … b,
/// clamp((w − a)/(b − a), 0, 1): within 10⁻⁶ where the stored values are kept exactly (the
/// slack is f32's, in the file's a and b), within half a quantum of 16 bits (plus that)
/// where the values are quantised.
fn assert_values(name: &str, v: &Dataset, want: &[f64], (a, b): (f64, f64), exact: bool) {
    let got = normalised(v);
    assert_eq!(got.len(), want.len(), "{name}: nodes");
    let tol = if exact { 1e-6 } else { 0.5 / 65535.0 + 1e-6 };
    for (n, (g, w)) in got.iter().zip(want).enumerate() {
        let expect = ((w - a) / (b - a)).clamp(0.0, 1.0);
        assert!(
            (g - expect).abs() <= tol,
            "{name} node {n}: {g} vs ({w} − {a})/({b} − {a}) = {expect}"
        );
    }
}

fn range(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
            (l.min(x), h.max(x))
        })
}

/// Every series converts to pydicom's modality values, node by node, in the data's range:
/// negative Hounsfield units (int16, intercept −1024), a slope and intercept per slice (float
/// values, quantised), 12 bits of 16 sign-extended in big endian, 8-bit implicit VR (8-bit
/// voxels), 32-bit values (quantised), RLE, a gantry tilt, and slices ordered by
/// InstanceNumber. The slices are found in the order of
/// their positions, whatever their file names and instance numbers say.
#[test]
fn every_series_converts_to_the_writers_values() {
    for (series, width, exact) in [
        ("ct_oblique", 2, true),
        ("mr_slopes", 2, false),
        ("be_signed12", 2, true),
        ("us8_implicit", 1, true),
        ("u32_scaled", 2, false),
        ("ct_rle", 2, true),
        ("ct_tilt", 2, true),
        ("by_instance", 2, true),
    ] {
        let d = tmp(series);
        let out = d.join("out.vlb");
        let (v, _) = convert(&["dicom", s(&fixture(series)), s(&out)], &out);
        assert_eq!(v.dims(), [6, 5, 4], "{series}");
        assert_eq!(v.raw().width(), width, "{series}");
        let want = writers_values(series);
        assert_values(series, &v, &want, range(&want), exact);
        std::fs::remove_dir_all(&d).unwrap();
    }
    // The CT's values are Hounsfield units, some below −1000: a CT window clamps them.
    let want = writers_values("ct_oblique");
    assert!(range(&want).0 < -1000.0);
    let d = tmp("window");
    let out = d.join("w.vlb");
    let (v, _) = convert(
        &[
            "dicom",
            s(&fixture("ct_oblique")),
            s(&out),
            "--window",
            "-1000",
            "2000",
        ],
        &out,
    );
    assert_values("window", &v, &want, (-1000.0, 2000.0), true);
    std::fs::remove_dir_all(&d).unwrap();
}

/// The sidecar holds the placement numpy computes from pydicom's reading of the headers
/// (LPS turned into RAS), to 10⁻⁹ mm, a tilted series' sheared grid too; `info` shows it. A
/// series without positions has none, and says so.
#[test]
fn the_sidecar_is_the_writers_placement() {
    for series in [
        "ct_oblique",
        "mr_slopes",
        "be_signed12",
        "us8_implicit",
        "u32_scaled",
        "ct_rle",
        "ct_tilt",
    ] {
        let d = tmp(&format!("{series}-geom"));
        let out = d.join("out.vlb");
        let (v, _) = convert(&["dicom", s(&fixture(series)), s(&out)], &out);
        let g = v.geometry().expect("a placement");
        let want = numbers(&format!("{series}.affine.txt"));
        for (r, (got_row, want_row)) in g.affine().iter().zip(&want).enumerate() {
            for (c, (got, w)) in got_row.iter().zip(want_row).enumerate() {
                assert!((got - w).abs() <= 1e-9, "{series} [{r}][{c}]: {got} vs {w}");
            }
        }
        if series == "ct_oblique" {
            let o = run(&["info", s(&out)]);
            assert!(o.status.success());
            let info = text(&o.stdout);
            assert!(info.contains("spacing:     0.6"), "{info}");
            assert!(
                info.contains(&format!("affine row:  {:?}", g.affine()[1])),
                "{info}"
            );
        }
        std::fs::remove_dir_all(&d).unwrap();
    }
    let d = tmp("unplaced");
    let out = d.join("out.vlb");
    let (v, o) = convert(&["dicom", s(&fixture("by_instance")), s(&out)], &out);
    assert!(v.geometry().is_none());
    let err = text(&o.stderr);
    assert!(
        err.contains("no ImagePositionPatient") && err.contains("without a placement"),
        "{err}"
    );
    let info = text(&run(&["info", s(&out)]).stdout);
    assert!(info.contains("geometry:    none"), "{info}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// `vlconvert DIR OUT` and `vlconvert FILE OUT` (a slice: its series, from its folder) give
/// the bytes and the sidecar `vlconvert dicom DIR OUT` gives; the README and the DICOMDIR
/// beside the slices are skipped and counted.
#[test]
fn a_folder_and_a_single_file_are_told_apart() {
    let d = tmp("auto");
    let dir = fixture("ct_oblique");
    let explicit = d.join("explicit.vlb");
    let (_, o) = convert(&["dicom", s(&dir), s(&explicit)], &explicit);
    let said = text(&o.stdout);
    assert!(
        said.contains("4 slice(s) of 6 × 5 pixels")
            && said.contains("skipped 2 file(s): 1 not DICOM, 1 DICOM without an image"),
        "{said}"
    );
    for (name, input) in [("folder", dir.clone()), ("file", dir.join("zz"))] {
        let out = d.join(format!("{name}.vlb"));
        convert(&[s(&input), s(&out)], &out);
        assert_eq!(
            std::fs::read(&out).unwrap(),
            std::fs::read(&explicit).unwrap(),
            "{name}"
        );
        let sidecar = |p: &Path| std::fs::read(vlib::Geometry::sidecar(p)).unwrap();
        assert_eq!(sidecar(&out), sidecar(&explicit), "{name}");
    }
    // The README is not DICOM, the DICOMDIR holds no image: neither is a slice.
    for name in ["README", "DICOMDIR"] {
        let o = run(&["dicom", s(&dir.join(name)), s(&d.join("x.vlb"))]);
        assert_eq!(o.status.code(), Some(1), "{name}");
        let err = text(&o.stderr);
        assert!(
            err.contains("not a DICOM file") || err.contains("without an image"),
            "{err}"
        );
    }
    // A folder of no DICOM image.
    let empty = d.join("empty");
    std::fs::create_dir(&empty).unwrap();
    std::fs::copy(dir.join("README"), empty.join("README")).unwrap();
    let o = run(&["dicom", s(&empty), s(&d.join("y.vlb"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o.stderr).contains("no DICOM image"),
        "{}",
        text(&o.stderr)
    );
    // Detected, it is neither a TIFF stack nor a DICOM series.
    let o = run(&[s(&empty), s(&d.join("y.vlb"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o.stderr).contains("neither a stack nor a series"),
        "{}",
        text(&o.stderr)
    );
    // A folder of DICOM files and a stray TIFF: neither reader is chosen for the user.
    let mixed = d.join("mixed");
    std::fs::create_dir(&mixed).unwrap();
    let slice = std::fs::read_dir(&dir).unwrap().find_map(|e| {
        let p = e.unwrap().path();
        p.extension().is_some_and(|x| x == "dcm").then_some(p)
    });
    let slice = slice.expect("a .dcm slice in the fixture");
    std::fs::copy(&slice, mixed.join("a.dcm")).unwrap();
    std::fs::copy(
        common::fixture("tiff/uint16_be.tif"),
        mixed.join("screenshot.tif"),
    )
    .unwrap();
    let o = run(&[s(&mixed), s(&d.join("z.vlb"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o.stderr).contains("TIFF files (.tif, .tiff) and DICOM files"),
        "{}",
        text(&o.stderr)
    );
    assert!(!d.join("x.vlb").exists() && !d.join("y.vlb").exists() && !d.join("z.vlb").exists());
    std::fs::remove_dir_all(&d).unwrap();
}

/// The series UID a conversion reports (`series UID (...)`).
fn reported_uid(o: &Output) -> String {
    let said = text(&o.stdout);
    said.strip_prefix("series ")
        .and_then(|r| r.split_whitespace().next())
        .unwrap_or_else(|| panic!("{said}"))
        .to_string()
}

/// A folder of two series is refused with both UIDs listed; `--series` or one of its files
/// chooses one, which converts to its writer's values; an unknown UID is refused, and so is
/// `--series` for a format that has none.
#[test]
fn several_series_are_listed_and_one_is_chosen() {
    let d = tmp("two");
    let mixed = d.join("mixed");
    std::fs::create_dir(&mixed).unwrap();
    let mut uids = Vec::new();
    for series in ["ct_oblique", "mr_slopes"] {
        for e in std::fs::read_dir(fixture(series)).unwrap() {
            let p = e.unwrap().path();
            std::fs::copy(&p, mixed.join(p.file_name().unwrap())).unwrap();
        }
        let one = d.join("one.vlb");
        let (_, o) = convert(&["dicom", s(&fixture(series)), s(&one)], &one);
        uids.push(reported_uid(&o));
    }
    let out = d.join("out.vlb");
    let o = run(&["dicom", s(&mixed), s(&out)]);
    assert_eq!(o.status.code(), Some(1));
    let err = text(&o.stderr);
    assert!(
        err.contains("several series") && err.contains("--series"),
        "{err}"
    );
    for uid in &uids {
        assert!(err.contains(uid.as_str()), "{err}");
    }
    assert!(!out.exists());
    let (v, _) = convert(&[s(&mixed), s(&out), "--series", &uids[1]], &out);
    let want = writers_values("mr_slopes");
    assert_values("--series", &v, &want, range(&want), false);
    let (v, o) = convert(&[s(&mixed.join("IM_0003")), s(&out)], &out);
    assert_eq!(reported_uid(&o), uids[0]);
    assert!(text(&o.stdout).contains("4 of other series"));
    let want = writers_values("ct_oblique");
    assert_values("a file", &v, &want, range(&want), true);
    std::fs::remove_file(&out).unwrap();
    let o = run(&["dicom", s(&mixed), s(&out), "--series", "1.2.3.4"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o.stderr).contains("no series 1.2.3.4"));
    let nrrd = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/nrrd/int8_raw.nrrd");
    let o = run(&[s(&nrrd), s(&out), "--series", "1.2.3.4"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o.stderr).contains("--series"));
    assert!(!out.exists());
    std::fs::remove_dir_all(&d).unwrap();
}

/// Runs `vlconvert dicom input` and checks that it exits 1, says `says` (and names `names`),
/// and writes nothing.
fn refused(input: &Path, says: &str, names: &str) {
    let d = tmp("refused");
    let out = d.join("out.vlb");
    let o = run(&["dicom", s(input), s(&out)]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{}: {err}", input.display());
    assert!(err.contains(says), "{}: {err}", input.display());
    assert!(err.contains(names), "{}: {err}", input.display());
    assert!(!out.exists());
    std::fs::remove_dir_all(&d).unwrap();
}

/// Series that do not convert, each refused with its reason and the file: slices of two
/// sizes, orientations or pixel spacings, a slice off the line of the others, several frames
/// in a file, colour, a palette, a Modality LUT Sequence, JPEG-compressed pixel data and a
/// deflated data set (the transfer syntax named), two slices at one position, a slice missing
/// from the middle.
#[test]
fn series_that_do_not_convert_are_refused_by_name() {
    let refuse = |case: &str| fixture(&format!("refuse/{case}"));
    refused(
        &refuse("mixed_size"),
        "must be of one size",
        "mixed_size2.dcm",
    );
    refused(
        &refuse("mixed_orientation"),
        "must share one orientation",
        "mixed_orientation1.dcm",
    );
    refused(
        &refuse("mixed_spacing"),
        "must share one pixel spacing",
        "mixed_spacing1.dcm",
    );
    refused(
        &refuse("off_line"),
        "lies 1.0000 mm off the line",
        "off_line1.dcm",
    );
    refused(&refuse("multiframe"), "NumberOfFrames 2", "multiframe0.dcm");
    refused(&refuse("colour"), "SamplesPerPixel 3", "colour0.dcm");
    refused(&refuse("palette"), "PALETTE COLOR", "palette0.dcm");
    refused(
        &refuse("modality_lut"),
        "Modality LUT Sequence",
        "modality_lut0.dcm",
    );
    refused(&refuse("jpeg"), "JPEG Baseline", "jpeg0.dcm");
    refused(&refuse("deflated"), "Deflated Explicit VR", "deflated0.dcm");
    // Two copies of one slice; the series with its second slice (zz) gone.
    let d = tmp("gaps");
    let (twice, gap) = (d.join("twice"), d.join("gap"));
    for (dir, skip) in [(&twice, ""), (&gap, "zz")] {
        std::fs::create_dir(dir).unwrap();
        for e in std::fs::read_dir(fixture("ct_oblique")).unwrap() {
            let p = e.unwrap().path();
            if p.file_name().unwrap() != skip {
                std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
            }
        }
    }
    std::fs::copy(twice.join("zz"), twice.join("zz-copy")).unwrap();
    refused(&twice, "lie at one position", "zz-copy");
    refused(&gap, "not evenly spaced", "IM_0003");
    std::fs::remove_dir_all(&d).unwrap();
}

/// A slice missing from a series is named by the gap it leaves, the one furthest from the
/// median gap: ct_tilt's slices lie 2.5 mm apart along the normal; without its third (t2), or
/// its second (t1), the 5 mm gap is reported with the median 2.5 mm, not the first gap.
#[test]
fn a_missing_slice_is_named_by_its_gap() {
    let d = tmp("missing");
    for (gone, from, to) in [
        ("t2.dcm", "t1.dcm", "t3.dcm"),
        ("t1.dcm", "t0.dcm", "t2.dcm"),
    ] {
        let dir = d.join(gone);
        std::fs::create_dir(&dir).unwrap();
        for e in std::fs::read_dir(fixture("ct_tilt")).unwrap() {
            let p = e.unwrap().path();
            if p.file_name().unwrap() != gone {
                std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
            }
        }
        let says = format!(
            "from {} to {} is 5.0000 mm along the slice normal, but the median gap is 2.5000 mm",
            dir.join(from).display(),
            dir.join(to).display()
        );
        refused(&dir, &says, to);
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// `vlconvert dicom input` run with its address space limited to 1 GiB, far less than the
/// sizes a hostile header declares: it must exit 1 with `says`, not abort on an allocation.
fn refused_in_little_memory(input: &Path, says: &str) {
    common::refused_within(1 << 20, &["dicom"], input, &[says]);
}

/// A DICOM file: preamble, `DICM`, a file meta group naming transfer syntax `ts`, then
/// `dataset`.
fn part10(ts: &str, dataset: &[u8]) -> Vec<u8> {
    let mut uid = ts.as_bytes().to_vec();
    if uid.len() % 2 == 1 {
        uid.push(0);
    }
    let mut b = vec![0u8; 128];
    b.extend(b"DICM");
    b.extend([0x02, 0x00, 0x10, 0x00, b'U', b'I']);
    b.extend((uid.len() as u16).to_le_bytes());
    b.extend(uid);
    b.extend(dataset);
    b
}

/// Hostile files exit 1 naming the file, without allocating what they declare: Rows and
/// Columns of 65535 over 60 bytes of pixels (8.6 GB declared), a pixel data element that
/// declares 4 GiB in a file of a few hundred bytes, a file cut short, and sequences nested
/// 100 deep.
#[test]
fn hostile_files_exit_1_without_allocating_what_they_declare() {
    let d = tmp("hostile");
    let huge = d.join("huge");
    std::fs::create_dir(&huge).unwrap();
    for e in std::fs::read_dir(fixture("refuse/huge")).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, huge.join(p.file_name().unwrap())).unwrap();
    }
    refused_in_little_memory(&huge.join("huge0.dcm"), "need 8589672450");
    // The pixel data element of a slice, its length declared 0xFFFFFFF0.
    let slice = std::fs::read(fixture("ct_oblique/zz")).unwrap();
    let at = slice
        .windows(6)
        .position(|w| w == [0xE0, 0x7F, 0x10, 0x00, b'O', b'W'])
        .expect("the pixel data element");
    let mut big = slice[..at + 8].to_vec();
    big.extend(0xFFFF_FFF0u32.to_le_bytes());
    big.extend([1, 2]);
    let declared = d.join("declared");
    std::fs::create_dir(&declared).unwrap();
    std::fs::write(declared.join("f.dcm"), &big).unwrap();
    refused_in_little_memory(
        &declared.join("f.dcm"),
        "declares 4294967280 bytes, but 2 remain",
    );
    let short = d.join("short");
    std::fs::create_dir(&short).unwrap();
    std::fs::write(short.join("f.dcm"), &slice[..slice.len() - 10]).unwrap();
    refused(
        &short.join("f.dcm"),
        "declares 60 bytes, but 50 remain",
        "f.dcm",
    );
    // (0008,1140) sequences of undefined length, each in an item of undefined length.
    let mut nested = Vec::new();
    for _ in 0..100 {
        nested.extend([
            0x08, 0x00, 0x40, 0x11, b'S', b'Q', 0, 0, 0xFF, 0xFF, 0xFF, 0xFF,
        ]);
        nested.extend([0xFE, 0xFF, 0x00, 0xE0, 0xFF, 0xFF, 0xFF, 0xFF]);
    }
    let deep = d.join("deep");
    std::fs::create_dir(&deep).unwrap();
    std::fs::write(deep.join("f.dcm"), part10("1.2.840.10008.1.2.1", &nested)).unwrap();
    refused(&deep.join("f.dcm"), "nested more than 32 deep", "f.dcm");
    std::fs::remove_dir_all(&d).unwrap();
}

/// Bytes after a slice's last element that are no element in order (16 zero bytes, a line of
/// text, in explicit and in implicit VR) are trailing data, as pydicom reads them: the series
/// converts to the bytes of the unchanged one, with a note naming the file and the count.
#[test]
fn bytes_after_the_last_element_are_a_note() {
    let d = tmp("trailing");
    for (series, slice) in [("ct_oblique", "zz"), ("us8_implicit", "c1.dcm")] {
        let want = d.join("want.vlb");
        let (_, o) = convert(&["dicom", s(&fixture(series)), s(&want)], &want);
        assert!(!text(&o.stderr).contains("after its last element"));
        for tail in [&[0u8; 16][..], b"trailing text\n"] {
            let copy = d.join(series);
            let _ = std::fs::remove_dir_all(&copy);
            std::fs::create_dir(&copy).unwrap();
            for entry in std::fs::read_dir(fixture(series)).unwrap() {
                let from = entry.unwrap().path();
                std::fs::copy(&from, copy.join(from.file_name().unwrap())).unwrap();
            }
            let f = copy.join(slice);
            let bytes = std::fs::read(&f).unwrap();
            std::fs::write(&f, [&bytes[..], tail].concat()).unwrap();
            let got = d.join("got.vlb");
            let (_, o) = convert(&["dicom", s(&copy), s(&got)], &got);
            let err = text(&o.stderr);
            let says = format!(
                "{} has {} bytes after its last element (ignored)",
                f.display(),
                tail.len()
            );
            assert!(err.contains(&says), "{series} {tail:?}: {err}");
            assert_eq!(
                std::fs::read(&got).unwrap(),
                std::fs::read(&want).unwrap(),
                "{series}"
            );
        }
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// Slices with bytes changed at random places (a fixed sequence) convert or exit 1 with a
/// message: never a panic, an abort or another exit code. One RLE slice with a byte of its
/// run data changed (found so) makes the RLE decoder of dicom-transfer-syntax-registry 0.10
/// panic: it is reported as the file's error.
#[test]
fn damaged_slices_never_panic() {
    let d = tmp("damaged");
    let mut rle = std::fs::read(fixture("ct_rle/rle0.dcm")).unwrap();
    rle[931] = 0x80;
    let f = d.join("rle.dcm");
    std::fs::write(&f, &rle).unwrap();
    let o = run(&["dicom", s(&f), s(&d.join("out.vlb"))]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.starts_with(&format!("vlconvert: {}: pixel data: ", f.display()))
            && err.contains("decoder failed on malformed data")
            && !err.contains("panicked"),
        "{err}"
    );
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for name in [
        "ct_oblique/zz",
        "ct_rle/rle1.dcm",
        "be_signed12/s2",
        "us8_implicit/c1.dcm",
    ] {
        let good = std::fs::read(fixture(name)).unwrap();
        for trial in 0..40 {
            let mut bad = good.clone();
            for _ in 0..1 + next() % 3 {
                let at = 132 + (next() as usize) % (bad.len() - 132);
                bad[at] = next() as u8;
            }
            let f = d.join("slice.dcm");
            std::fs::write(&f, &bad).unwrap();
            let o = run(&["dicom", s(&f), s(&d.join("out.vlb"))]);
            let err = text(&o.stderr);
            assert!(
                matches!(o.status.code(), Some(0 | 1)) && !err.contains("panicked"),
                "{name} trial {trial}: {:?} {err}",
                o.status
            );
            if o.status.code() == Some(1) {
                assert!(err.starts_with("vlconvert: "), "{err}");
            }
        }
    }
    std::fs::remove_dir_all(&d).unwrap();
}
