//! `vlconvert tiff` end to end, on TIFF stacks written by tifffile (`tests/fixtures/tiff`,
//! `make.py`) with the values tifffile reads back beside each: every sample type, both byte
//! orders, each compression the `tiff` crate decodes, an ImageJ hyperstack, BigTIFF, tiles, a
//! folder of slices whose names need natural order; the spacing sidecar; the format told from
//! the file or folder; and each refusal (colour, pages of two sizes or types, hostile sizes).

mod common;

use common::{run, s, text, tmp};
use std::path::{Path, PathBuf};
use std::process::Output;
use vlib::Dataset;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/tiff")
        .join(name)
}

/// The numbers of `NAME.txt` (one a line) or `NAME.spacing.txt` (on one line).
fn numbers(name: &str) -> Vec<f64> {
    std::fs::read_to_string(fixture(name))
        .unwrap()
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect()
}

/// Each node's normalised value, clamp((voxel − a)/(b − a), 0, 1), is the writer's value
/// placed in the data's range, (w − min)/(max − min). The writer's array is [page, row,
/// column] with rows top to bottom; node (i, j, k) is page k, row ny − 1 − j (object y runs
/// upwards), column i. Within 10⁻⁶ where the type is kept exactly (the slack is f32's in a and
/// b), within half a quantum of 16 bits (plus that) where it is quantised.
fn assert_writers_values(name: &str, v: &Dataset, want: &[f64], exact: bool) {
    let [nx, ny, nz] = v.dims();
    assert_eq!(nx * ny * nz, want.len(), "{name}: nodes");
    let (lo, hi) = want
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &w| {
            (l.min(w), h.max(w))
        });
    let (a, b) = v.range();
    let (a, b) = (a as f64, b as f64);
    let tol = if exact { 1e-6 } else { 0.5 / 65535.0 + 1e-6 };
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let got = ((v.raw_node(i, j, k) - a) / (b - a)).clamp(0.0, 1.0);
                let w = want[(k * ny + (ny - 1 - j)) * nx + i];
                let expect = (w - lo) / (hi - lo);
                assert!(
                    (got - expect).abs() <= tol,
                    "{name} node ({i}, {j}, {k}): {got} vs ({w} − {lo})/({hi} − {lo}) = {expect}"
                );
            }
        }
    }
}

/// Converts `input` with `args` before it; asserts success and returns the dataset and the
/// run's output.
fn convert(input: &Path, out: &Path, args: &[&str]) -> (Dataset, Output) {
    let mut all: Vec<&str> = args.to_vec();
    all.extend([s(input), s(out)]);
    let o = run(&all);
    assert!(o.status.success(), "{input:?}: {}", text(&o.stderr));
    (Dataset::load(out).unwrap(), o)
}

/// Every volume fixture converts to the writer's values: 8-bit types in 8-bit voxels, 16-bit
/// ones exactly in 16-bit voxels, wider integers and floats quantised to 16 bits. A page whose
/// 0 is white is read inverted (255 − v), as the `tiff` crate reads it.
#[test]
fn every_type_converts_to_the_writers_values() {
    let d = tmp("types");
    let cases = [
        ("int16_imagej", [5, 4, 3], 2, true),
        ("float32_deflate", [5, 4, 3], 2, false),
        ("uint16_be", [5, 4, 3], 2, true),
        ("uint32_packbits", [5, 4, 3], 2, false),
        ("int8_bigtiff", [5, 4, 3], 1, true),
        ("int32_tiled", [5, 4, 3], 2, false),
        ("float64_2d", [5, 4, 1], 2, false),
        ("uint8_miniswhite", [5, 4, 3], 1, true),
        ("uint64", [5, 4, 3], 2, false),
        ("int64", [5, 4, 3], 2, false),
        ("float16", [5, 4, 3], 2, false),
    ];
    for (name, dims, width, exact) in cases {
        let out = d.join(format!("{name}.vlb"));
        let (v, _) = convert(&fixture(&format!("{name}.tif")), &out, &["tiff"]);
        assert_eq!(v.dims(), dims, "{name}");
        assert_eq!(v.raw().width(), width, "{name}");
        let mut want = numbers(&format!("{name}.txt"));
        if name == "uint8_miniswhite" {
            want.iter_mut().for_each(|w| *w = 255.0 - *w);
        }
        assert_writers_values(name, &v, &want, exact);
    }
    // The negative int16 values in a CT window: −1000 … 2000 to 0 … 1, clamped outside.
    let out = d.join("window.vlb");
    let input = fixture("int16_imagej.tif");
    let (v, _) = convert(&input, &out, &["tiff", "--window", "-1000", "2000"]);
    let want = numbers("int16_imagej.txt");
    let [nx, ny, _] = v.dims();
    let (a, b) = v.range();
    for (n, w) in want.iter().enumerate() {
        let (k, row, i) = (n / (nx * ny), n / nx % ny, n % nx);
        let got = ((v.raw_node(i, ny - 1 - row, k) - a as f64) / (b - a) as f64).clamp(0.0, 1.0);
        let expect = ((w + 1000.0) / 3000.0).clamp(0.0, 1.0);
        assert!((got - expect).abs() <= 1e-6, "{w}: {got} vs {expect}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// A folder of single-page slices is read in the natural order of the names (slice_2 before
/// slice_10, which text order puts first), says so, and ignores hidden and non-TIFF files.
#[test]
fn a_folder_is_read_in_natural_order() {
    let d = tmp("folder");
    let out = d.join("slices.vlb");
    let (v, o) = convert(&fixture("uint8_slices"), &out, &["tiff"]);
    assert_eq!(v.dims(), [5, 4, 11]);
    assert_eq!(v.raw().width(), 1);
    assert_writers_values("uint8_slices", &v, &numbers("uint8_slices.txt"), true);
    let report = text(&o.stdout);
    assert!(
        report.contains("11 slices in natural order")
            && report.contains("slice_1.tif, slice_2.tif, …, slice_11.tif"),
        "{report}"
    );
    // A copy with a hidden file, a note and a non-TIFF gives the same bytes.
    let copy = d.join("copy");
    std::fs::create_dir(&copy).unwrap();
    for entry in std::fs::read_dir(fixture("uint8_slices")).unwrap() {
        let p = entry.unwrap().path();
        std::fs::copy(&p, copy.join(p.file_name().unwrap())).unwrap();
    }
    std::fs::write(copy.join("._slice_1.tif"), b"AppleDouble").unwrap();
    std::fs::write(copy.join("notes.txt"), b"scanned 2026").unwrap();
    let out2 = d.join("copy.vlb");
    convert(&copy, &out2, &["tiff"]);
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&out2).unwrap());
    std::fs::remove_dir_all(&d).unwrap();
}

/// `vlconvert IN OUT` tells a TIFF (either byte order, BigTIFF) and a folder of TIFFs, and
/// converts them to the same bytes as `vlconvert tiff`; a folder without TIFFs is refused.
#[test]
fn tiff_files_and_folders_are_detected() {
    let d = tmp("detect");
    for name in [
        "int16_imagej.tif",
        "uint16_be.tif",
        "int8_bigtiff.tif",
        "int32_tiled.tif",
        "uint8_slices",
    ] {
        let (auto, explicit) = (d.join("auto.vlb"), d.join("explicit.vlb"));
        convert(&fixture(name), &auto, &[]);
        convert(&fixture(name), &explicit, &["tiff"]);
        assert_eq!(
            std::fs::read(&auto).unwrap(),
            std::fs::read(&explicit).unwrap(),
            "{name}"
        );
        // --quiet before the input still means `convert`.
        convert(&fixture(name), &auto, &["--quiet"]);
    }
    let empty = d.join("empty");
    std::fs::create_dir(&empty).unwrap();
    let o = run(&[s(&empty), s(&d.join("x.vlb"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o.stderr).contains("without TIFF files (.tif, .tiff) or DICOM files"),
        "{}",
        text(&o.stderr)
    );
    std::fs::remove_dir_all(&d).unwrap();
}

/// The sidecar's spacing is what tifffile reads of the file (`NAME.spacing.txt`, mm): ImageJ's
/// unit and spacing (mm; µm in the folder), inches for a single page; the axes are the stack's
/// own, said in a note. Without a slice spacing there is no sidecar, and a note gives the
/// pixel spacing (centimetres read as mm); `--spacing` gives one, and overrides the file's.
#[test]
fn the_sidecar_has_the_files_spacing() {
    let d = tmp("spacing");
    for name in ["int16_imagej", "uint8_slices", "float64_2d"] {
        let input = fixture(name);
        let input = if input.exists() {
            input
        } else {
            fixture(&format!("{name}.tif"))
        };
        let out = d.join(format!("{name}.vlb"));
        let (v, o) = convert(&input, &out, &["tiff"]);
        let want = numbers(&format!("{name}.spacing.txt"));
        let g = v.geometry().expect("a sidecar");
        for (r, (row, spacing)) in g.affine().iter().zip(&want).enumerate() {
            for (c, &got) in row.iter().enumerate() {
                let w = if r == c { *spacing } else { 0.0 };
                assert!(
                    (got - w).abs() <= 1e-12 * w.abs().max(1.0),
                    "{name} [{r}][{c}]: {got} vs {w}"
                );
            }
        }
        assert!(text(&o.stderr).contains("not RAS"), "{}", text(&o.stderr));
    }
    // uint16_be: 100 x 50 pixels per cm, no slice spacing.
    let want = numbers("uint16_be.spacing.txt");
    assert!(want[2].is_nan());
    let out = d.join("be.vlb");
    let (v, o) = convert(&fixture("uint16_be.tif"), &out, &["tiff"]);
    assert!(v.geometry().is_none());
    assert!(!vlib::Geometry::sidecar(&out).exists());
    let note = text(&o.stderr);
    let said = note
        .split("pixel spacing ")
        .nth(1)
        .and_then(|t| t.split(" mm").next())
        .expect("a note with the pixel spacing");
    let got: Vec<f64> = said.split(" x ").map(|v| v.parse().unwrap()).collect();
    assert!(
        (got[0] - want[0]).abs() < 1e-12 && (got[1] - want[1]).abs() < 1e-12,
        "{note}"
    );
    assert!(note.contains("no slice spacing"), "{note}");
    // No unit at all: a note, no sidecar.
    let (v, o) = convert(&fixture("float32_deflate.tif"), &d.join("f.vlb"), &["tiff"]);
    assert!(v.geometry().is_none());
    assert!(text(&o.stderr).contains("no pixel spacing"));
    // --spacing gives one, and overrides the file's.
    for name in ["uint16_be.tif", "int16_imagej.tif"] {
        let out = d.join("given.vlb");
        let (v, _) = convert(
            &fixture(name),
            &out,
            &["tiff", "--spacing", "0.25", "0.75", "1.5"],
        );
        assert_eq!(v.geometry().unwrap().spacing(), [0.25, 0.75, 1.5], "{name}");
    }
    // A spacing of 0 or a negative one (with an exponent too, which is no option's name) is
    // refused as such, not as a command line's error (exit 2).
    for spacing in [["1", "0", "1"], ["1", "-1e-3", "1"]] {
        let out = d.join("z.vlb");
        let o = run(&[
            &["tiff", s(&fixture("uint16_be.tif")), s(&out), "--spacing"][..],
            &spacing,
        ]
        .concat());
        assert_eq!(o.status.code(), Some(1), "{spacing:?}");
        let err = text(&o.stderr);
        assert!(
            err.contains("--spacing") && err.contains("positive numbers"),
            "{err}"
        );
        assert!(!out.exists());
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// Runs `vlconvert tiff IN` and asserts exit 1, a message with each of `says`, no output.
fn refused(input: &Path, says: &[&str]) {
    let out =
        std::env::temp_dir().join(format!("vlconvert-tiff-refused-{}.vlb", std::process::id()));
    let o = run(&["tiff", s(input), s(&out)]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{input:?}: {err}");
    for say in says {
        assert!(err.contains(say), "{input:?}: {say:?} not in {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out.exists());
}

/// Colour, pages of two sizes or two types, in a file or a folder, ImageJ hyperstacks of
/// several channels or of several frames of several slices, a multi-page file in a folder and
/// a file that is not a TIFF are refused, naming the file (and page).
#[test]
fn colour_and_mixed_pages_are_refused() {
    refused(
        &fixture("rgb.tif"),
        &["rgb.tif", "page 1", "RGB", "only grey"],
    );
    refused(
        &fixture("mixed_sizes.tif"),
        &["mixed_sizes.tif", "page 2 has 6 x 4 pixels", "page 1 5 x 4"],
    );
    refused(
        &fixture("mixed_types.tif"),
        &[
            "mixed_types.tif",
            "page 2 has 5 x 4 pixels of unsigned 16-bit",
            "8-bit",
        ],
    );
    refused(
        &fixture("imagej_channels.tif"),
        &["imagej_channels.tif", "2 channels", "one value a voxel"],
    );
    refused(
        &fixture("imagej_frames.tif"),
        &["imagej_frames.tif", "2 frames of 2 slices"],
    );
    let d = tmp("mixed-folder");
    std::fs::copy(fixture("uint8_slices/slice_1.tif"), d.join("a1.tif")).unwrap();
    std::fs::copy(fixture("uint16_be.tif"), d.join("a2.tif")).unwrap();
    refused(&d, &["a2.tif", "more than one page"]);
    std::fs::copy(fixture("float64_2d.tif"), d.join("a2.tif")).unwrap();
    refused(&d, &["a2.tif", "float 64-bit", "a1.tif", "unsigned 8-bit"]);
    std::fs::write(d.join("a2.tif"), b"not a tiff at all").unwrap();
    refused(&d, &["a2.tif"]);
    std::fs::remove_dir_all(&d).unwrap();
}

/// A little-endian TIFF of one `width` x `height` page of 16-bit samples whose one strip (or
/// tile of `tile` pixels), `data`, is said to be `count` bytes long, compressed with
/// `compression`.
fn tiff_with(
    (width, height): (u32, u32),
    tile: Option<(u32, u32)>,
    compression: u16,
    count: u32,
    data: &[u8],
) -> Vec<u8> {
    let mut entries: Vec<(u16, u16, u32)> = vec![
        (256, 4, width),  // ImageWidth, LONG
        (257, 4, height), // ImageLength
        (258, 3, 16),     // BitsPerSample, SHORT
        (259, 3, compression as u32),
        (262, 3, 1), // BlackIsZero
    ];
    match tile {
        None => entries.extend([
            (273, 4, 8),      // StripOffsets: the data after the header
            (277, 3, 1),      // SamplesPerPixel
            (278, 4, height), // RowsPerStrip
            (279, 4, count),  // StripByteCounts
        ]),
        Some((tw, th)) => entries.extend([
            (277, 3, 1),
            (322, 4, tw),    // TileWidth
            (323, 4, th),    // TileLength
            (324, 4, 8),     // TileOffsets
            (325, 4, count), // TileByteCounts
        ]),
    }
    let mut f = b"II*\0".to_vec();
    let ifd = 8 + data.len() as u32;
    f.extend(ifd.to_le_bytes());
    f.extend(data);
    f.extend((entries.len() as u16).to_le_bytes());
    for (tag, ty, v) in entries {
        f.extend(tag.to_le_bytes());
        f.extend(ty.to_le_bytes());
        f.extend(1u32.to_le_bytes());
        if ty == 3 {
            f.extend((v as u16).to_le_bytes());
            f.extend([0, 0]);
        } else {
            f.extend(v.to_le_bytes());
        }
    }
    f.extend(0u32.to_le_bytes());
    f
}

/// Sizes the file cannot hold are refused before anything is allocated for them (exit 1, no
/// panic): a 100000 x 100000 page in 10 bytes of Deflate data, a small page in tiles of
/// 2²⁰ x 2²⁰ pixels, a strip past the end of the file, a strip too short for its page, a
/// compression that does not convert, a file cut short, a page chain pointing past the end.
#[test]
fn hostile_sizes_are_refused() {
    let d = tmp("hostile");
    let zlib = [0x78, 0x9c, 3, 0, 0, 0, 0, 1, 0, 0];
    let cases: [(&str, Vec<u8>, &[&str]); 5] = [
        (
            "bomb.tif",
            tiff_with((100_000, 100_000), None, 8, 10, &zlib),
            &["page 1", "20000000000 bytes", "10 bytes of data"],
        ),
        (
            "tile.tif",
            tiff_with((4, 4), Some((1 << 20, 1 << 20)), 8, 10, &zlib),
            &["page 1", "tiles of 1048576 x 1048576", "10 bytes"],
        ),
        (
            "past.tif",
            tiff_with((4, 4), None, 1, 4000, &[0; 32]),
            &["page 1", "past the end of the file"],
        ),
        (
            "short.tif",
            tiff_with((4, 4), None, 1, 20, &[0; 20]),
            &["page 1", "32 bytes", "20 bytes of data"],
        ),
        (
            "jpeg.tif",
            tiff_with((4, 4), None, 7, 32, &[0; 32]),
            &["page 1", "compression 7 (JPEG)"],
        ),
    ];
    for (name, bytes, says) in cases {
        let p = d.join(name);
        std::fs::write(&p, bytes).unwrap();
        let mut all = vec![name];
        all.extend(says);
        refused(&p, &all);
    }
    // The fixture with its last bytes cut off, and with its first page's offset past the end.
    let good = std::fs::read(fixture("int16_imagej.tif")).unwrap();
    let cut = d.join("cut.tif");
    std::fs::write(&cut, &good[..good.len() / 2]).unwrap();
    refused(&cut, &["cut.tif"]);
    let mut far = good.clone();
    far[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    let far_path = d.join("far.tif");
    std::fs::write(&far_path, far).unwrap();
    refused(&far_path, &["far.tif"]);
    std::fs::remove_dir_all(&d).unwrap();
}

/// The offset of page `k`'s (from 1) directory entry for `tag` in the little-endian classic
/// TIFF `b`, walking the page chain.
fn entry_of(b: &[u8], k: usize, tag: u16) -> usize {
    let u32_at = |at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap()) as usize;
    let mut ifd = u32_at(4);
    for _ in 1..k {
        let n = u16::from_le_bytes([b[ifd], b[ifd + 1]]) as usize;
        ifd = u32_at(ifd + 2 + 12 * n);
    }
    let n = u16::from_le_bytes([b[ifd], b[ifd + 1]]) as usize;
    (0..n)
        .map(|e| ifd + 2 + 12 * e)
        .find(|&at| u16::from_le_bytes([b[at], b[at + 1]]) == tag)
        .unwrap()
}

/// A tag whose value count is far beyond the file (2³¹ StripByteCounts, BitsPerSamples or StripOffsets:
/// tifffile's 3-page fixture with the count patched) is refused with exit 1, naming the file
/// (and page after the first), instead of the process aborting on the allocation.
#[test]
fn a_tag_counting_more_values_than_the_file_holds_is_refused() {
    let d = tmp("tag-count");
    let good = std::fs::read(fixture("uint64.tif")).unwrap();
    for (k, tag) in [(2, 279), (3, 279), (1, 279), (2, 258), (2, 273)] {
        let mut b = good.clone();
        let at = entry_of(&b, k, tag);
        b[at + 4..at + 8].copy_from_slice(&(1u32 << 31).to_le_bytes());
        let p = d.join(format!("count{k}_{tag}.tif"));
        std::fs::write(&p, b).unwrap();
        // (The first page's directory is read as the file is opened.)
        let page = if k > 1 {
            format!("page {k}: ")
        } else {
            String::new()
        };
        refused(
            &p,
            &[&format!(
                "{page}a tag of its page directory counts more values than the file holds"
            )],
        );
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// An ImageJ stack with one page directory whose description counts its slices (as ImageJ
/// writes stacks over 4 GiB; here the tifffile fixture with its page chain cut after page 1,
/// which tifffile reads as the same 3 slices) converts to the writer's values; slices that
/// would pass the end of the file, and a description counting other pages than the file's,
/// are refused.
#[test]
fn imagej_stacks_in_one_page_directory() {
    let d = tmp("imagej-one");
    let mut one = std::fs::read(fixture("int16_imagej.tif")).unwrap();
    let entries = u16::from_le_bytes([one[8], one[9]]) as usize;
    let next = 8 + 2 + 12 * entries;
    one[next..next + 4].copy_from_slice(&0u32.to_le_bytes());
    let path = d.join("one.tif");
    std::fs::write(&path, &one).unwrap();
    let (v, _) = convert(&path, &d.join("one.vlb"), &["tiff"]);
    assert_eq!(v.dims(), [5, 4, 3]);
    assert_writers_values("one.tif", &v, &numbers("int16_imagej.txt"), true);
    let says = |bytes: &[u8], images: &[u8]| {
        let at = bytes.windows(9).position(|w| w == b"images=3\n").unwrap();
        let mut b = bytes.to_vec();
        b.splice(at..at + 9, images.iter().copied());
        b
    };
    let far = d.join("far.tif");
    // 9 slices of 40 bytes from byte 368 end at 728; the file is cut at 700 (its page
    // directory and first slices stay whole).
    std::fs::write(&far, &says(&one, b"images=9\n")[..700]).unwrap();
    refused(&far, &["far.tif", "9 slices", "pass the end of the file"]);
    let three = std::fs::read(fixture("int16_imagej.tif")).unwrap();
    let four = d.join("four.tif");
    std::fs::write(&four, says(&three, b"images=4\n")).unwrap();
    refused(&four, &["four.tif", "says 4 images, the file has 3 pages"]);
    std::fs::remove_dir_all(&d).unwrap();
}
