//! The robustness acceptance test of the C interface (issue 6): `capi/tests/c/misuse_full.c`,
//! at least 40 numbered misuse and malformed-input cases, each checking the exact code
//! `vlError` reports, then a scene with a known answer. Built from the workspace root with
//! `cc -std=gnu89 -Wall -Wextra -Werror capi/tests/c/misuse_full.c -Iinclude -Ltarget/<profile>
//! -lvlib -lm` and run in a fresh directory; this test checks what the program printed and the
//! files it left.

mod common;

use common::{Ppm, TempDir};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Compiles `source` (relative to the workspace root) with warnings as errors into `out_dir`.
fn compile(source: &str, out_dir: &Path) -> PathBuf {
    common::compile_c(source, out_dir, &["-Wall", "-Wextra", "-Werror"])
}

#[test]
fn misuse_full_reports_every_case_and_still_renders_correctly() {
    let bin = TempDir::new("misuse-bin");
    let exe = compile("capi/tests/c/misuse_full.c", bin.path());
    let cwd = TempDir::new("misuse-run");
    let out = Command::new(&exe)
        .current_dir(cwd.path())
        .env("LD_LIBRARY_PATH", common::profile_dir())
        .output()
        .expect("run misuse_full");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "misuse_full exited with {}:\n{stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );

    // One numbered line per case, all "ok", numbered 1, 2, 3 … without gaps.
    let cases: Vec<&str> = stdout.lines().filter(|l| l.starts_with("case ")).collect();
    assert!(cases.len() >= 40, "only {} cases:\n{stdout}", cases.len());
    for (i, line) in cases.iter().enumerate() {
        let mut words = line.split_whitespace().skip(1);
        assert_eq!(words.next(), Some((i + 1).to_string().as_str()), "{line}");
        assert_eq!(words.next(), Some("ok"), "{line}");
    }
    assert!(
        stdout.contains(&format!("{} cases, 0 failure(s)", cases.len())),
        "{stdout}"
    );
    // The coverage the issue asks for, by the case descriptions.
    for topic in [
        "bad magic",
        "zero dimension",
        "10^15 voxels",
        "voxel width 3",
        "a = b",
        "a is NaN",
        "truncated voxels",
        "trailing bytes",
        "a missing file",
        "a directory",
        "an empty file",
        "before vlInit",
        "after the final vlEnd",
        "inside an object",
        "vlImage(NULL)",
        "vlVolume(NULL prefix)",
        "vlCamera(NULL)",
        "vlLoad(NULL)",
        "vlMapping(NULL table)",
        "vlMatrix(NULL)",
        "vlSpatial(NULL)",
        "vlFunction(NULL)",
        "vlNormal(NULL)",
        "vlPosition(NULL)",
        "vlChildNormal(1, NULL)",
        "vlStepSize step NaN",
        "above 2^28 pixels",
        "vlSuperSample(17)",
        "fov 0",
        "vlScale x 0",
        "vlMatrix singular",
        "inputs not increasing",
        "an output of 1.5",
        "2^20 + 1 points",
        "2048^3 nodes",
        "2^66 nodes",
        "2^66 voxels",
        "unknown field bit",
        "vlRenderType(99)",
        "unknown mapping",
        "unknown id",
        "output 2 of a 1-output mapping",
        "missing directory",
        "keep.ppm is unchanged",
        "in a field function",
        "in a normal function",
        "oldest 1024 are kept",
    ] {
        assert!(
            cases.iter().any(|l| l.contains(topic)),
            "no case about {topic:?}"
        );
    }

    // The files: the known-answer image, the kept file, and no temporaries or refused outputs.
    let img = Ppm::read(&cwd.path().join("final.ppm"));
    assert_eq!((img.width, img.height), (9, 9));
    let centre = img.pixel(4, 4);
    for (c, want) in centre.iter().zip([191.25, 95.625, 63.75]) {
        assert!(
            (*c as f64 - want).abs() <= 1.0,
            "centre pixel {centre:?}, want (191.25, 95.6, 63.75)"
        );
    }
    assert_eq!(Ppm::read(&cwd.path().join("keep.ppm")).width, 4);
    for entry in std::fs::read_dir(cwd.path()).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".tmp"), "temporary file {name} left behind");
        assert!(
            !name.starts_with("never"),
            "refused output {name} was written"
        );
    }
    assert!(!cwd.path().join("no-such-dir").exists());
}
