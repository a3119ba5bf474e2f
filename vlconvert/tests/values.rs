//! Values are converted, not altered unsaid: float values that are not finite are counted in a
//! note (+∞ the largest finite value, −∞ and NaN the smallest), a float range wider than f64
//! can subtract still quantises, NRRD ascii values an integer type cannot hold are refused by
//! value and index, and data beyond a NRRD's `sizes` (raw, gzip, ascii) is a note, with a gzip
//! stream read to its end (its checksum checked). NRRD cases that pynrrd cannot write (values
//! outside their type, data after the volume, a corrupt stream) are pynrrd's fixtures changed
//! in the test, or headers written here.

mod common;

use common::{fixture, normalised, run, s, text, tmp};
use std::io::{Read, Write};
use std::path::Path;
use vlib::{Dataset, Voxels};

/// Writes `values` as a raw f32 or f64 file and converts it as 2 x 2 x (n / 4); the output.
fn convert_floats(d: &Path, values: &[f64], f64s: bool) -> (std::process::Output, Dataset) {
    let raw = d.join("f.raw");
    let bytes: Vec<u8> = if f64s {
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    } else {
        values
            .iter()
            .flat_map(|&v| (v as f32).to_le_bytes())
            .collect()
    };
    std::fs::write(&raw, bytes).unwrap();
    let out = d.join("f.vlb");
    let _ = std::fs::remove_file(&out);
    let nz = (values.len() / 4).to_string();
    let ty = if f64s { "f64" } else { "f32" };
    let o = run(&[
        "raw",
        s(&raw),
        s(&out),
        "--dims",
        "2",
        "2",
        &nz,
        "--type",
        ty,
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v = Dataset::load(&out).unwrap();
    (o, v)
}

/// Each of `got` within half a 16-bit quantum of `want`.
fn assert_near(got: &[f64], want: &[f64]) {
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() <= 0.5 / 65535.0 + 1e-6, "{got:?} vs {want:?}");
    }
}

/// NaN and −∞ take the smallest finite value, +∞ the largest (the field is 0 and 1 there; the
/// finite values span 0 … 1), and a note counts them; with nothing finite there is nothing to
/// normalise by (exit 1).
#[test]
fn non_finite_values_are_counted_and_take_the_ends() {
    let d = tmp("nonfinite");
    let (inf, nan) = (f64::INFINITY, f64::NAN);
    let values = [nan, 1.0, 3.0, inf, 2.0, -inf, 1.5, nan];
    let (o, v) = convert_floats(&d, &values, false);
    assert_near(&normalised(&v), &[0.0, 0.0, 1.0, 1.0, 0.5, 0.0, 0.25, 0.0]);
    let err = text(&o.stderr);
    assert!(
        err.contains(
            "vlconvert: note: 2 NaN value(s) set to the smallest finite value, 1; 1 +infinite \
             value(s) set to the largest finite value, 3; 1 -infinite value(s) set to the \
             smallest finite value, 1"
        ),
        "{err}"
    );
    // Finite values only: no note.
    let (o, _) = convert_floats(&d, &[1.0, 2.0, 3.0, 4.0], false);
    assert!(text(&o.stderr).is_empty(), "{}", text(&o.stderr));
    let raw = d.join("f.raw");
    std::fs::write(&raw, [f32::NAN; 8].map(f32::to_le_bytes).concat()).unwrap();
    let args = ["raw", s(&raw), "--dims", "2", "2", "2", "--type", "f32"];
    let o = run(&[&args[..], &[s(&d.join("g.vlb"))]].concat());
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o.stderr).contains("no finite value"));
    std::fs::remove_dir_all(&d).unwrap();
}

/// float64 values from −1e308 to 1e308 (a range of 2e308, past f64's largest value) quantise
/// over it: 0 is halfway.
#[test]
fn a_float64_range_wider_than_f64_quantises() {
    let d = tmp("f64range");
    let values = [-1e308, 0.0, 1e308, 5e307];
    let (o, v) = convert_floats(&d, &values, true);
    assert_near(&normalised(&v), &[0.0, 0.5, 1.0, 0.75]);
    assert_eq!(v.range(), (0.0, 65535.0), "{}", text(&o.stdout));
    std::fs::remove_dir_all(&d).unwrap();
}

/// A NRRD with ascii data of `ty`, `sizes` 2 2 1, `fields` more header lines, and `data`.
fn ascii_nrrd(d: &Path, ty: &str, fields: &str, data: &str) -> std::path::PathBuf {
    let f = d.join("a.nrrd");
    let header = "NRRD0004\ndimension: 3\nsizes: 2 2 1\nencoding: ascii\n";
    std::fs::write(&f, format!("{header}type: {ty}\n{fields}\n{data}")).unwrap();
    f
}

/// NRRD ascii values: one an integer type cannot hold (out of its range, fractional, NaN) is
/// refused, named with its index; `float` refuses a finite number beyond its range. Byte skip
/// skips bytes of the text (as teem reads it; −1 is for raw data only), and values after the
/// volume's are a note.
#[test]
fn nrrd_ascii_values_are_kept_or_refused() {
    let d = tmp("nrrd-ascii");
    let out = d.join("a.vlb");
    for (ty, fields, data, says) in [
        (
            "uchar",
            "",
            "0 300 -5 3",
            "ascii value \"300\" (value 1, counting from 0): outside the range of uchar, 0 … 255",
        ),
        (
            "uchar",
            "",
            "0 3 -5 3",
            "ascii value \"-5\" (value 2, counting from 0): outside",
        ),
        (
            "short",
            "",
            "0 1 2 3.7",
            "ascii value \"3.7\" (value 3, counting from 0): not a whole number",
        ),
        (
            "short",
            "",
            "0 nan 2 3",
            "ascii value \"nan\" (value 1, counting from 0): not a whole number",
        ),
        (
            "int",
            "",
            "0 1 2 x",
            "ascii value \"x\" (value 3, counting from 0): not a number",
        ),
        (
            "float",
            "",
            "0 1e39 2 3",
            "ascii value \"1e39\" (value 1, counting from 0): beyond the range of float",
        ),
        (
            "uchar",
            "byte skip: -1\n",
            "1 2 3 4",
            "byte skip -1 with ascii encoding",
        ),
        (
            "uchar",
            "byte skip: 40\n",
            "1 2 3 4",
            "byte skip 40 is past the end of the data (7 bytes)",
        ),
    ] {
        let f = ascii_nrrd(&d, ty, fields, data);
        let o = run(&["nrrd", s(&f), s(&out)]);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{data}: {err}");
        assert!(err.contains(says), "{data}: {err}");
        assert!(!out.exists(), "{data}");
    }
    // Whole numbers in their type's range, written as integers or not, convert exactly; the
    // two values after the volume's four are a note.
    let f = ascii_nrrd(&d, "short", "", "-32768 1e3 32767.0 -0\n5 6\n");
    let o = run(&["nrrd", s(&f), s(&out)]);
    let err = text(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(&format!(
            "{} has 2 ascii values after the data (ignored)",
            f.display()
        )),
        "{err}"
    );
    let want = [-32768i32, 1000, 32767, 0].map(|v| (v + 32768) as u16);
    assert_eq!(
        Dataset::load(&out).unwrap().raw(),
        &Voxels::U16(want.to_vec())
    );
    // byte skip: 2 skips the "9 " before the values.
    let f = ascii_nrrd(&d, "uchar", "byte skip: 2\n", "9 1 2 3 4");
    let o = run(&["nrrd", s(&f), s(&out)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(
        Dataset::load(&out).unwrap().raw(),
        &Voxels::U8(vec![1, 2, 3, 4])
    );
    std::fs::remove_dir_all(&d).unwrap();
}

/// pynrrd's fixture `name` split into its header (up to and with the blank line) and its data.
fn split(name: &str) -> (Vec<u8>, Vec<u8>) {
    let bytes = std::fs::read(fixture(name)).unwrap();
    let at = bytes.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
    (bytes[..at].to_vec(), bytes[at..].to_vec())
}

/// Data after the volume's (raw: 6 bytes more; gzip: 10 more bytes compressed with it) converts
/// with a note, and so does a newline after the gzip stream; a stream of two members is read
/// whole; a gzip stream whose checksum does not match is refused (exit 1).
#[test]
fn nrrd_data_after_the_volume_is_a_note_and_gzip_is_checked() {
    let d = tmp("nrrd-after");
    let out = d.join("a.vlb");
    let (header, data) = split("nrrd/int16_raw.nrrd");
    let raw = d.join("raw.nrrd");
    std::fs::write(&raw, [&header[..], &data[..], &[7u8; 6]].concat()).unwrap();
    let (header, gz) = split("nrrd/uint16_gzip.nrrd");
    let mut volume = Vec::new();
    flate2::read::GzDecoder::new(&gz[..])
        .read_to_end(&mut volume)
        .unwrap();
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(&volume).unwrap();
    enc.write_all(&[9u8; 10]).unwrap();
    let longer = d.join("gz.nrrd");
    std::fs::write(&longer, [&header[..], &enc.finish().unwrap()[..]].concat()).unwrap();
    for (f, fixture_name, says) in [
        (
            &raw,
            "nrrd/int16_raw.nrrd",
            "has 6 bytes after the data (ignored)",
        ),
        (
            &longer,
            "nrrd/uint16_gzip.nrrd",
            "has 10 bytes after the data (ignored)",
        ),
    ] {
        let o = run(&["nrrd", s(f), s(&out)]);
        let err = text(&o.stderr);
        assert!(o.status.success(), "{err}");
        assert!(err.contains(&format!("{} {says}", f.display())), "{err}");
        // The volume is the fixture's.
        let fix = d.join("fixture.vlb");
        assert!(run(&["nrrd", s(&fixture(fixture_name)), s(&fix)])
            .status
            .success());
        assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&fix).unwrap());
    }
    // Python's gzip module's shapes of the data: pynrrd's file with a newline after its
    // stream (a note), and the volume in two members (read whole).
    let fix = d.join("fixture.vlb");
    assert!(
        run(&["nrrd", s(&fixture("nrrd/uint16_gzip.nrrd")), s(&fix)])
            .status
            .success()
    );
    for (name, note) in [
        ("nrrd/uint16_gzip_newline.nrrd", true),
        ("nrrd/uint16_gzip_members.nrrd", false),
    ] {
        let o = run(&[s(&fixture(name)), s(&out)]);
        let err = text(&o.stderr);
        assert!(o.status.success(), "{name}: {err}");
        let says = format!(
            "{} has 1 byte after its gzip stream (ignored)",
            fixture(name).display()
        );
        assert_eq!(err.contains(&says), note, "{name}: {err}");
        assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&fix).unwrap());
    }
    let mut crc = gz.clone();
    let at = crc.len() - 8; // the CRC-32 of the member's trailer
    crc[at] ^= 0xff;
    let bad = d.join("crc.nrrd");
    std::fs::write(&bad, [&header[..], &crc[..]].concat()).unwrap();
    let _ = std::fs::remove_file(&out);
    let o = run(&["nrrd", s(&bad), s(&out)]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("does not have a matching checksum"), "{err}");
    assert!(!out.exists());
    std::fs::remove_dir_all(&d).unwrap();
}

/// A window whose ends are one value, or not finite, once in the 32-bit floats a `.vlb` holds
/// (1000 … 1000.00001, −1e39 … 1e39) is refused (exit 1, nothing written) naming the window
/// as given and what it became; a window 32-bit floats tell apart converts.
#[test]
fn windows_a_vlb_cannot_hold_are_refused_naming_the_window() {
    let d = tmp("window-f32");
    let raw = d.join("v.raw");
    std::fs::write(&raw, [0u8, 1, 2, 3]).unwrap();
    let out = d.join("v.vlb");
    let convert = |a: &str, b: &str| {
        let dims = ["--dims", "2", "2", "1", "--window", a, b];
        run(&[&["raw", s(&raw), s(&out)][..], &dims].concat())
    };
    for (a, b, says) in [
        (
            "1000",
            "1000.00001",
            "window 1000 … 1000.00001: a .vlb holds its ends as 32-bit floats in voxel units, \
             where they are 1000 … 1000",
        ),
        (
            "-1e39",
            "1e39",
            "where they are -inf … inf; they must be finite and different",
        ),
    ] {
        let o = convert(a, b);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{a} {b}: {err}");
        assert!(err.contains(says), "{a} {b}: {err}");
        assert!(!out.exists(), "{a} {b}");
    }
    let o = convert("1000", "1000.5");
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(Dataset::load(&out).unwrap().range(), (1000.0, 1000.5));
    std::fs::remove_dir_all(&d).unwrap();
}
