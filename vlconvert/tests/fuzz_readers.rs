//! The bounded CI run of the `vlconvert_readers` fuzz target (`fuzz/`, cargo-fuzz, nightly):
//! every fixture of `tests/fixtures` (and a few images and raw volumes made here), mutated
//! with a fixed seed — bit flips, truncations at every few offsets, fields of the first KiB
//! set to extreme integers and floats, numbers of a text header set to extreme ones — read
//! in-process by the reader the fuzz target would pick, with its checks (`fuzz/src/readers.rs`,
//! included here by path, and its allocator, which refuses a request far beyond the input's
//! size): no panic, no such request, an accepted volume finite with values in [0, 1], and each
//! case within [`SLOW`].
//!
//! The unmutated fixtures must come out as they do from the command line (accepted, or refused
//! for the reason their name says), and for every layout some mutants must still be accepted:
//! the mutations reach the readers' conversions, not only their first checks.
//!
//! `VLCONVERT_FUZZ_CASES` multiplies the random cases (a longer local run); `VLCONVERT_FUZZ_SEED`
//! picks another seed. `cargo test --release --test fuzz_readers -- --ignored write_seeds`
//! writes the unmutated inputs to `fuzz/seeds/vlconvert_readers/`.

#[path = "../../fuzz/src/readers.rs"]
mod readers;

use readers::{encode, run, Kind, Outcome};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

#[global_allocator]
static ALLOC: readers::Counting = readers::Counting;

/// How long one case may take.
const SLOW: Duration = Duration::from_secs(5);

/// A fixture as the fuzz target reads it: its name, layout and files.
struct Fixture {
    name: String,
    kind: Kind,
    files: Vec<Vec<u8>>,
}

fn fixtures_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures")
}

/// The files of `dir` with extension `ext`, by name.
fn with_ext(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && p.to_string_lossy().ends_with(ext))
        .collect();
    v.sort();
    v
}

fn stem(p: &Path) -> String {
    p.file_name().unwrap().to_string_lossy().into_owned()
}

/// `bytes` with `from` replaced by `to` (a detached header's data file, renamed as the fuzz
/// target names it).
fn renamed(bytes: &[u8], from: &str, to: &str) -> Vec<u8> {
    let text = String::from_utf8(bytes.to_vec()).unwrap();
    assert!(text.contains(from), "{from}");
    text.replace(from, to).into_bytes()
}

/// An image in `format`, made by the `image` crate (PNM: PAM, P7).
fn image(img: image::DynamicImage, format: image::ImageFormat) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, format).unwrap();
    out.into_inner()
}

/// A binary PGM (P5) or PPM (P6) of `img`.
fn pnm(img: image::DynamicImage) -> Vec<u8> {
    use image::codecs::pnm::{PnmEncoder, PnmSubtype, SampleEncoding};
    let subtype = if img.color().has_color() {
        PnmSubtype::Pixmap(SampleEncoding::Binary)
    } else {
        PnmSubtype::Graymap(SampleEncoding::Binary)
    };
    let mut out = Vec::new();
    img.write_with_encoder(PnmEncoder::new(&mut out).with_subtype(subtype))
        .unwrap();
    out
}

/// Every fixture, in a fixed order.
fn fixtures() -> Vec<Fixture> {
    let root = fixtures_dir();
    let read = |p: &Path| std::fs::read(p).unwrap();
    let mut out = Vec::new();
    let mut add =
        |name: String, kind: Kind, files: Vec<Vec<u8>>| out.push(Fixture { name, kind, files });
    let nifti = root.join("nifti");
    for p in [with_ext(&nifti, ".nii"), with_ext(&nifti, ".nii.gz")].concat() {
        add(stem(&p), Kind::Nifti, vec![read(&p)]);
    }
    for (hdr, img) in [
        ("uint8_pair.hdr", "uint8_pair.img"),
        ("uint8_pair_gz.hdr.gz", "uint8_pair_gz.img.gz"),
    ] {
        let files = vec![read(&nifti.join(hdr)), read(&nifti.join(img))];
        add(hdr.into(), Kind::NiftiPair, files);
    }
    let nrrd = root.join("nrrd");
    for p in with_ext(&nrrd, ".nrrd") {
        add(stem(&p), Kind::Nrrd, vec![read(&p)]);
    }
    let nhdr = renamed(
        &read(&nrrd.join("uint8_detached.nhdr")),
        "uint8_detached.raw",
        "a.raw",
    );
    let raw = read(&nrrd.join("uint8_detached.raw"));
    add(
        "uint8_detached.nhdr".into(),
        Kind::NrrdDetached,
        vec![nhdr, raw],
    );
    let meta = root.join("metaimage");
    for p in with_ext(&meta, ".mha") {
        add(stem(&p), Kind::MetaImage, vec![read(&p)]);
    }
    for (mhd, data) in [
        ("int32_zlib.mhd", "int32_zlib.zraw"),
        ("uint16.mhd", "uint16.raw"),
        ("uint8_spacing.mhd", "uint8_spacing.raw"),
    ] {
        let header = renamed(&read(&meta.join(mhd)), data, "a.raw");
        let files = vec![header, read(&meta.join(data))];
        add(mhd.into(), Kind::MetaImageDetached, files);
    }
    let dicom = root.join("dicom");
    let mut series: Vec<PathBuf> = std::fs::read_dir(&dicom)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir() && !p.ends_with("refuse"))
        .collect();
    let mut refuse: Vec<PathBuf> = std::fs::read_dir(dicom.join("refuse"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    series.sort();
    refuse.sort();
    for dir in series.iter().chain(&refuse) {
        let files: Vec<Vec<u8>> = with_ext(dir, "").iter().map(|p| read(p)).collect();
        add(format!("dicom_{}", stem(dir)), Kind::Dicom, files);
    }
    let tiff = root.join("tiff");
    for p in with_ext(&tiff, ".tif") {
        add(stem(&p), Kind::Tiff, vec![read(&p)]);
    }
    let slices = (1..=3)
        .map(|i| read(&tiff.join(format!("uint8_slices/slice_{i}.tif"))))
        .collect();
    add("uint8_slices".into(), Kind::TiffFolder, slices);
    // Images: grey and colour, 8 and 16 bits, PNG and PNM.
    let grey = image::GrayImage::from_fn(5, 3, |x, y| image::Luma([(x * 40 + y * 7) as u8]));
    let grey16 = image::ImageBuffer::<image::Luma<u16>, _>::from_fn(4, 3, |x, y| {
        image::Luma([(x * 9000 + y * 100) as u16])
    });
    let rgb = image::RgbImage::from_fn(3, 4, |x, y| image::Rgb([x as u8 * 50, y as u8 * 60, 9]));
    let mut pgm16 = b"P5\n4 3\n65535\n".to_vec();
    pgm16.extend(grey16.pixels().flat_map(|p| p.0[0].to_be_bytes()));
    use image::{DynamicImage as D, ImageFormat as F};
    for (name, bytes) in [
        ("grey.png", image(D::ImageLuma8(grey.clone()), F::Png)),
        ("grey16.png", image(D::ImageLuma16(grey16), F::Png)),
        ("rgb.png", image(D::ImageRgb8(rgb.clone()), F::Png)),
        ("grey.pam", image(D::ImageLuma8(grey.clone()), F::Pnm)),
        ("grey.pgm", pnm(D::ImageLuma8(grey))),
        ("grey16.pgm", pgm16),
        ("rgb.ppm", pnm(D::ImageRgb8(rgb))),
        ("ascii.pgm", b"P2\n3 2\n255\n0 10 20\n30 40 255\n".to_vec()),
    ] {
        add(name.into(), Kind::Image, vec![bytes]);
    }
    // Raw volumes: 4 x 3 x 2 of i16, big-endian, after 3 bytes; 2 x 2 x 1 of f64.
    let mut i16be = vec![
        3,
        2,
        1,
        readers::type_byte(vlconvert::fuzzing::Type::I16),
        1,
        3,
    ];
    i16be.extend([9, 9, 9]);
    i16be.extend((0..24i16).flat_map(|v| (v * 300 - 3000).to_be_bytes()));
    add("i16be.raw".into(), Kind::Raw, vec![i16be]);
    let mut f64le = vec![
        1,
        1,
        0,
        readers::type_byte(vlconvert::fuzzing::Type::F64),
        0,
        0,
    ];
    f64le.extend(
        [0.5f64, -2.0, 1e300, 7.0]
            .iter()
            .flat_map(|v| v.to_le_bytes()),
    );
    add("f64le.raw".into(), Kind::Raw, vec![f64le]);
    // What `vlconvert IN OUT` reads by content: one of each.
    for name in [
        "int16_ct.nii.gz",
        "int16_lps.nrrd",
        "float32_zlib.mha",
        "int16_imagej.tif",
        "rgb.png",
        "grey.pgm",
    ] {
        let f = out.iter().find(|f| f.name == name).unwrap();
        let files = f.files.clone();
        out.push(Fixture {
            name: format!("detect_{name}"),
            kind: Kind::Detect,
            files,
        });
    }
    let first_slice = read(&dicom.join("ct_rle/rle0.dcm"));
    out.push(Fixture {
        name: "detect_rle0.dcm".into(),
        kind: Kind::Detect,
        files: vec![first_slice],
    });
    out
}

/// The unmutated fixtures the readers refuse (as the command line does, for the reason the
/// name says: 4D, NIfTI-2, channels, mixed pages, colour; the DICOM `refuse` series).
const REFUSED: &[&str] = &[
    "int16_4d_2.mha",
    "int16_ct_nifti2.nii",
    "int16_ct_t2.nii",
    "int16_ct_v2.nii",
    "imagej_channels.tif",
    "imagej_frames.tif",
    "mixed_sizes.tif",
    "mixed_types.tif",
    "rgb.tif",
];

fn expect_refused(name: &str) -> bool {
    REFUSED.contains(&name)
        || (name.starts_with("dicom_")
            && std::fs::metadata(fixtures_dir().join("dicom/refuse").join(&name[6..])).is_ok())
}

/// splitmix64: the cases' random numbers.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Extreme values of a field of `width` bytes, little-endian (the caller may reverse them).
fn extremes(width: usize) -> Vec<Vec<u8>> {
    match width {
        1 => [0u8, 1, 0x7f, 0x80, 0xff]
            .iter()
            .map(|v| vec![*v])
            .collect(),
        2 => [0u16, 1, 0x7fff, 0x8000, 0xffff]
            .iter()
            .map(|v| v.to_le_bytes().to_vec())
            .collect(),
        4 => [0u32, 1, 0x7fff_ffff, 0x8000_0000, 0xffff_ffff]
            .iter()
            .map(|v| v.to_le_bytes().to_vec())
            .chain(
                [f32::NAN, f32::INFINITY, -f32::INFINITY, 3e38, -3e38, 1e-40]
                    .iter()
                    .map(|v| v.to_le_bytes().to_vec()),
            )
            .collect(),
        _ => [0u64, 1 << 40, i64::MAX as u64, 1 << 63, u64::MAX]
            .iter()
            .map(|v| v.to_le_bytes().to_vec())
            .chain(
                [f64::NAN, f64::INFINITY, 1.7e308, -1.7e308]
                    .iter()
                    .map(|v| v.to_le_bytes().to_vec()),
            )
            .collect(),
    }
}

/// Numbers a text header's field may be set to.
const WORDS: &[&str] = &[
    "0",
    "-1",
    "65536",
    "2147483648",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "99999999999999999999999",
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "-0",
];

/// The runs of ASCII digits in the first KiB of `b`: (start, end).
fn numbers(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    let end = b.len().min(1024);
    while i < end {
        if b[i].is_ascii_digit() {
            let start = i;
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
            }
            out.push((start, i));
        } else {
            i += 1;
        }
    }
    out
}

/// The mutants of `f`'s files: (what was done, files).
fn mutants(f: &Fixture, rng: &mut Rng, scale: usize) -> Vec<(String, Vec<Vec<u8>>)> {
    let mut out = Vec::new();
    let n = f.files.len();
    // Truncations of each file at every few offsets.
    for (i, file) in f.files.iter().enumerate().take(3) {
        let step = (file.len() / 24).max(1);
        for cut in (0..file.len()).step_by(step) {
            let mut files = f.files.clone();
            files[i].truncate(cut);
            out.push((format!("file {i} cut at {cut}"), files));
        }
    }
    for _ in 0..48 * scale {
        // Bit flips, 1 to 8, in one file (the first, half the time).
        let i = if rng.below(2) == 0 { 0 } else { rng.below(n) };
        let mut files = f.files.clone();
        if files[i].is_empty() {
            continue;
        }
        let flips = 1 + rng.below(8);
        let mut said = Vec::new();
        for _ in 0..flips {
            let at = rng.below(files[i].len());
            let bit = rng.below(8);
            files[i][at] ^= 1 << bit;
            said.push(format!("{at}.{bit}"));
        }
        out.push((format!("file {i} bits {}", said.join(" ")), files));
    }
    for _ in 0..64 * scale {
        // A field of the first KiB set to an extreme value, either byte order.
        let i = if rng.below(2) == 0 { 0 } else { rng.below(n) };
        let mut files = f.files.clone();
        let width = [1, 2, 4, 8][rng.below(4)];
        let room = files[i].len().min(1024);
        if room < width {
            continue;
        }
        let values = extremes(width);
        let mut v = values[rng.below(values.len())].clone();
        if rng.below(2) == 1 {
            v.reverse();
        }
        let at = rng.below(room - width + 1);
        files[i][at..at + width].copy_from_slice(&v);
        out.push((format!("file {i} bytes {at}.. = {v:02x?}"), files));
    }
    for _ in 0..16 * scale {
        // A number of a text header set to an extreme one.
        let i = if rng.below(2) == 0 { 0 } else { rng.below(n) };
        let spots = numbers(&f.files[i]);
        if spots.is_empty() {
            break;
        }
        let (a, b) = spots[rng.below(spots.len())];
        let word = WORDS[rng.below(WORDS.len())];
        let mut files = f.files.clone();
        files[i].splice(a..b, word.bytes());
        out.push((format!("file {i} number at {a} = {word}"), files));
    }
    out
}

/// Runs one case; its outcome, failing the test (naming the case) on a panic or a slow case.
fn case(name: &str, kind: Kind, files: &[Vec<u8>], dir: &Path) -> Outcome {
    let refs: Vec<&[u8]> = files.iter().map(|f| f.as_slice()).collect();
    let input = encode(kind, &refs);
    let start = Instant::now();
    let outcome = std::panic::catch_unwind(|| run(&input, dir))
        .unwrap_or_else(|_| panic!("{name}: the case above failed"));
    let took = start.elapsed();
    assert!(took < SLOW, "{name}: took {took:?}");
    outcome
}

#[test]
fn mutated_fixtures_keep_the_readers_properties() {
    let scale: usize = std::env::var("VLCONVERT_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let seed: u64 = std::env::var("VLCONVERT_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0x5eed);
    let dir = readers::scratch("props");
    let mut rng = Rng(seed);
    // Per layout: (cases, accepted mutants).
    let mut tally: Vec<(Kind, usize, usize)> = Vec::new();
    for f in fixtures() {
        let pristine = case(&f.name, f.kind, &f.files, &dir);
        match (&pristine, expect_refused(&f.name)) {
            (Outcome::Accepted(_), false) | (Outcome::Refused(_), true) => {}
            (o, _) => panic!("{}: unmutated, {o:?}", f.name),
        }
        for (what, files) in mutants(&f, &mut rng, scale) {
            let outcome = case(&format!("{} ({what})", f.name), f.kind, &files, &dir);
            let entry = match tally.iter_mut().find(|t| t.0 == f.kind) {
                Some(e) => e,
                None => {
                    tally.push((f.kind, 0, 0));
                    tally.last_mut().unwrap()
                }
            };
            entry.1 += 1;
            if matches!(outcome, Outcome::Accepted(_)) {
                entry.2 += 1;
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!("(layout, cases, accepted): {tally:?}");
    assert_eq!(tally.len(), readers::LAYOUTS.len(), "{tally:?}");
    for (kind, cases, accepted) in &tally {
        assert!(*accepted > 0, "{kind:?}: no mutant of {cases} accepted");
    }
}

/// Writes the unmutated fixtures as the fuzz target's inputs, its seed corpus.
#[test]
#[ignore]
fn write_seeds() {
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds/vlconvert_readers");
    std::fs::create_dir_all(&out).unwrap();
    for f in fixtures() {
        let refs: Vec<&[u8]> = f.files.iter().map(|f| f.as_slice()).collect();
        std::fs::write(out.join(&f.name), encode(f.kind, &refs)).unwrap();
    }
}
