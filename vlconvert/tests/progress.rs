//! The progress line: absent when standard error is not a terminal (a pipe here), for every
//! reader; drawn under a pseudo-terminal (util-linux `script`), blanked out before the report,
//! and absent there too with `--quiet`.

mod common;

use common::{fixture, s, tmp, BIN};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A 1 MiB raw u8 volume (1024 x 1024 x 1), more than the 64 KiB a read needs for a line.
fn big_raw(d: &Path) -> PathBuf {
    let p = d.join("big.raw");
    let bytes: Vec<u8> = (0..1 << 20)
        .map(|i: u32| (i.wrapping_mul(2654435761) >> 24) as u8)
        .collect();
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Piped, every reader (raw, NIfTI, NRRD gzip, MetaImage zlib, TIFF file and folder) writes
/// no progress: standard error holds only whole `vlconvert: note:` lines, no carriage return.
#[test]
fn no_progress_when_standard_error_is_not_a_terminal() {
    let d = tmp("pipe");
    let raw = big_raw(&d);
    let out = d.join("out.vlb");
    let gz = gzipped(&fixture("nifti/int16_ct.nii"), &d);
    let cases: Vec<Vec<String>> = vec![
        vec![
            "raw".into(),
            s(&raw).into(),
            s(&out).into(),
            "--dims".into(),
            "1024".into(),
            "1024".into(),
            "1".into(),
        ],
        vec![s(&fixture("nifti/int16_ct.nii")).into(), s(&out).into()],
        // (A leading --quiet still lets the format be told from the file.)
        vec!["--quiet".into(), s(&gz).into(), s(&out).into()],
        vec![s(&fixture("nrrd/uint16_gzip.nrrd")).into(), s(&out).into()],
        vec![
            s(&fixture("metaimage/float32_zlib.mha")).into(),
            s(&out).into(),
        ],
        vec![
            s(&fixture("tiff/float32_deflate.tif")).into(),
            s(&out).into(),
        ],
        vec![s(&fixture("tiff/uint8_slices")).into(), s(&out).into()],
    ];
    for args in cases {
        let o = Command::new(BIN).args(&args).output().unwrap();
        assert!(o.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains('\r'), "{args:?}: {err:?}");
        assert!(
            err.lines().all(|l| l.starts_with("vlconvert: note: ")),
            "{args:?}: {err:?}"
        );
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// `nii` gzipped into `d`.
fn gzipped(nii: &Path, d: &Path) -> PathBuf {
    use std::io::Write;
    let gz = d.join("ct.nii.gz");
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(&std::fs::read(nii).unwrap()).unwrap();
    std::fs::write(&gz, enc.finish().unwrap()).unwrap();
    gz
}

/// A gzipped NIfTI, read through the byte-counting reader, converts to the same bytes as the
/// file it was made from.
#[test]
fn a_gzipped_nifti_reads_as_its_source() {
    let d = tmp("gz");
    let nii = fixture("nifti/int16_ct.nii");
    let gz = gzipped(&nii, &d);
    let (a, b) = (d.join("a.vlb"), d.join("b.vlb"));
    for (input, out) in [(&nii, &a), (&gz, &b)] {
        let o = Command::new(BIN)
            .args(["nifti", s(input), s(out)])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    std::fs::remove_dir_all(&d).unwrap();
}

/// `cmd` run under a pseudo-terminal by util-linux `script` (standard output and error both
/// the terminal), or `None` if `script` cannot be run here.
fn under_a_terminal(cmd: &str) -> Option<Output> {
    let o = Command::new("script")
        .args(["-qfec", cmd, "/dev/null"])
        .env("COLUMNS", "80")
        .output()
        .ok()?;
    Some(o)
}

/// The last progress line before `marker` on `screen` is blanked out ("\r", spaces, "\r")
/// and `marker` starts a line.
fn blanked_before(screen: &str, marker: &str) {
    let at = screen
        .find(marker)
        .unwrap_or_else(|| panic!("{marker:?} not in {screen:?}"));
    let before = &screen[..at];
    let last_bar = before.rfind(" [").expect("a progress line");
    let tail = &before[last_bar..];
    let blank = tail.find("\r ").expect("the line blanked out");
    assert!(
        tail[blank + 1..]
            .trim_end_matches('\r')
            .chars()
            .all(|c| c == ' '),
        "{tail:?}"
    );
    assert!(
        before.ends_with('\r'),
        "{marker:?} starts the line: {before:?}"
    );
}

/// Under a terminal the bar is drawn (the file's name, a bar, the percentage, bytes), each
/// step's line is blanked out ("\r", spaces, "\r") before anything else is written, and the
/// report follows on a clean line (an error message too); `--quiet` draws none.
#[test]
fn a_bar_on_a_terminal_blanked_out_before_the_report() {
    if under_a_terminal("true").is_none_or(|o| !o.status.success()) {
        println!("skipped: util-linux `script` (a pseudo-terminal) cannot be run here");
        return;
    }
    let d = tmp("pty");
    let raw = big_raw(&d);
    let out = d.join("out.vlb");
    let cmd = format!("'{BIN}' raw '{}' '{}' --dims 1024 1024 1", s(&raw), s(&out));
    let o = under_a_terminal(&cmd).unwrap();
    assert!(o.status.success());
    let screen = String::from_utf8_lossy(&o.stdout).into_owned();
    for step in ["reading big.raw [", "finding the range [", "converting ["] {
        assert!(screen.contains(step), "{step} not in {screen:?}");
    }
    assert!(screen.contains("MiB"), "{screen:?}");
    // Each drawing fits the 80 columns.
    for piece in screen.split('\r').filter(|p| p.contains(" [")) {
        assert!(
            piece.contains('%') && piece.chars().count() <= 80,
            "{piece:?}"
        );
    }
    blanked_before(&screen, "U8 values kept exactly");
    // --quiet: nothing but the report.
    let o = under_a_terminal(&format!("{cmd} --quiet")).unwrap();
    assert!(o.status.success());
    let screen = String::from_utf8_lossy(&o.stdout);
    assert!(!screen.contains(" ["), "{screen:?}");
    assert!(screen.starts_with("U8 values kept exactly"), "{screen:?}");
    // An error after slices were read: the line is blanked out before the message.
    let folder = d.join("stack");
    std::fs::create_dir(&folder).unwrap();
    for entry in std::fs::read_dir(fixture("tiff/uint8_slices")).unwrap() {
        let p = entry.unwrap().path();
        std::fs::copy(&p, folder.join(p.file_name().unwrap())).unwrap();
    }
    std::fs::write(folder.join("slice_12.tif"), b"II*\0 cut short").unwrap();
    let cmd = format!("'{BIN}' tiff '{}' '{}'", s(&folder), s(&out));
    let o = under_a_terminal(&cmd).unwrap();
    assert_eq!(o.status.code(), Some(1));
    let screen = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(screen.contains("stack ["), "{screen:?}");
    blanked_before(&screen, "vlconvert: ");
    std::fs::remove_dir_all(&d).unwrap();
}
