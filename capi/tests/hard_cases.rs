//! Numerical hard cases as a C program (issue #7, item 4): `capi/tests/c/hard_cases.c` builds
//! some 70 scenes through the C interface (grazing, edge and corner rays; cameras inside objects,
//! on their faces and at lights; near-singular and absurd transforms; field functions returning
//! NaN, ±Inf and ±1e30; zero gradients; steps from 10⁻⁴ to 10⁶ of the object's size; opacity
//! references near 0 and huge; mapping tables with a_1 = 0 or a_n = 1; 16-bit datasets at the
//! extremes of a and b; DSR, MIP, shadows and secondary rays on hostile fields), renders each to
//! a small PPM and checks `vlError` after each. This test compiles it (warnings as errors), runs
//! it with `RAYON_NUM_THREADS=1` and `=2` into two directories, and checks that every case
//! reported what it expected, that every image is there and complete, that the two thread
//! counts wrote byte-identical files, and the values that can be predicted (below, with their
//! reasons). `tests/stability.rs` covers the same ground in Rust with proptest.

mod common;

use common::{Ppm, TempDir};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Compiles the program with warnings as errors into `out_dir`.
fn compile(out_dir: &Path) -> PathBuf {
    common::compile_c(
        "capi/tests/c/hard_cases.c",
        out_dir,
        &["-Wall", "-Wextra", "-Werror"],
    )
}

/// Runs the program into `dir` with `threads` rendering threads; returns its case lines.
fn run(exe: &Path, dir: &Path, threads: usize) -> Vec<String> {
    let out = Command::new(exe)
        .arg(dir)
        .env("LD_LIBRARY_PATH", common::profile_dir())
        .env("RAYON_NUM_THREADS", threads.to_string())
        .output()
        .expect("run hard_cases");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "hard_cases ({threads} thread(s)) exited with {}:\n{stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let cases: Vec<String> = stdout
        .lines()
        .filter(|l| l.starts_with("case "))
        .map(String::from)
        .collect();
    assert!(
        stdout.contains(&format!("{} cases, 0 failure(s)", cases.len())),
        "{stdout}"
    );
    cases
}

/// The file name of a case line `case nn ok name ...`: `nn_name`.
fn file_of(line: &str) -> String {
    let words: Vec<&str> = line.split_whitespace().collect();
    assert!(words.len() >= 4, "{line}");
    assert_eq!(words[2], "ok", "{line}");
    format!(
        "{:02}_{}",
        words[1].parse::<u32>().expect("case number"),
        words[3]
    )
}

/// What a case's image must show. Values are linear colours in [0, 1]; a pixel matches when it
/// is within one grey level of 255 · value. The renderer's own arithmetic (f64 along the ray,
/// f32 fields) is exact to far below a grey level in these scenes; the one level allows for
/// rounding a value that lies on .5 (0.5 → 127.5), whichever way float error tips it.
enum Want {
    /// The centre pixel (the ray along the camera's axis).
    Centre([f64; 3]),
    /// Every pixel.
    All([f64; 3]),
    /// The centre pixel is one of these, grey (a ray in a face plane of the box, or along an
    /// edge, is inside it or not, but never partly).
    CentreEither(f64, f64),
    /// Every row is non-increasing from left to right (transmittance never increases with
    /// depth).
    NonIncreasingRows,
}

use Want::*;

/// 1 − (1 − o)^(length / reference): a white, ambient-lit (ka = 1) slab over black.
fn slab(o: f64, length_over_reference: f64) -> f64 {
    1.0 - (1.0 - o).powf(length_over_reference)
}

/// The predictions, by case name (see the comments in hard_cases.c for each scene).
fn predictions() -> Vec<(&'static str, Want)> {
    let grey = |v: f64| [v, v, v];
    let half = grey(0.5);
    // The DSR sphere's colour (0.2, 0.6, 1): ka C, and kd C + ks with kd = 0.5, ks = 0.25 where
    // N·L = R·V = 1 (the light at the eye, the centre pixel).
    let ka_c = [0.2, 0.6, 1.0];
    let lit = [0.35, 0.55, 0.75];
    vec![
        // The probe: o = 0.5 over its depth L with reference L, for any step (Beer–Lambert
        // is exact for constant media: docs/compat.md).
        ("baseline.ppm", Centre(half)),
        ("step_1e-4.ppm", Centre(half)),
        ("step_1e6.ppm", Centre(half)),
        ("step_0.3.ppm", Centre(half)),
        // Reference 1e-30, subnormal: (1 − o)^(huge) = 0, opaque. 1e30, FLT_MAX: nothing.
        ("reference_1e-30.ppm", All(grey(1.0))),
        ("reference_subnormal.ppm", All(grey(1.0))),
        ("reference_1e30.ppm", All(grey(0.0))),
        ("reference_flt_max.ppm", All(grey(0.0))),
        // o = 1 is opaque whatever the reference: 0^(tiny) = 0.
        ("opacity_1_reference_1e30.ppm", All(grey(1.0))),
        // The probe scaled by 10^28 and 10^-32 with step and reference: the same picture.
        ("scale_1e30.ppm", Centre(half)),
        ("scale_1e-30.ppm", Centre(half)),
        // Inside, half-way: o = 0.75 over L/2, T = 0.25^0.5 = 0.5.
        ("camera_inside.ppm", Centre(grey(slab(0.75, 0.5)))),
        ("camera_on_front_face.ppm", Centre(half)),
        // On the back face looking out: no medium ahead.
        ("camera_on_back_face.ppm", All(grey(0.0))),
        ("camera_on_corner.ppm", CentreEither(0.0, 0.5)),
        ("graze_face.ppm", CentreEither(0.0, 0.5)),
        ("along_edge.ppm", CentreEither(0.0, 0.5)),
        // Corner to corner along the body diagonal: length √3 L.
        ("through_corners.ppm", Centre(grey(slab(0.5, 3f64.sqrt())))),
        // Rays that only touch a corner or an edge: length 0.
        ("touch_corner.ppm", Centre(grey(0.0))),
        ("touch_edge.ppm", Centre(grey(0.0))),
        // A field of view of 1e-4 degrees: every ray is the axis.
        ("fov_1e-4.ppm", All(half)),
        ("fov_179.99.ppm", Centre(half)),
        // The camera's roll does not change the axis.
        ("up_near_view.ppm", Centre(half)),
        ("up_subnormal.ppm", Centre(half)),
        // The refused vlMatrix (VL_BADVALUE, checked by the program) left the probe as it was.
        ("matrix_singular.ppm", Centre(half)),
        ("mirror.ppm", Centre(half)),
        ("far_away.ppm", Centre(half)),
        // 10^-6 L thick: 1 − 0.5^(10^-6) ≈ 7e-7.
        ("paper_thin.ppm", All(grey(0.0))),
        // Field values are clamped to [0, 1], NaN to 0 (docs/compat.md): NaN, −Inf and −1e30
        // leave nothing; +Inf and 1e30 make every field 1, an opaque white slab lit beyond 1
        // (the slab fills the image).
        ("field_nan.ppm", All(grey(0.0))),
        ("field_inf.ppm", All(grey(1.0))),
        ("field_neg_inf.ppm", All(grey(0.0))),
        ("field_1e30.ppm", All(grey(1.0))),
        ("field_neg_1e30.ppm", All(grey(0.0))),
        ("field_nan_twice.ppm", All(grey(0.0))),
        // Zero gradient: isotropic, kd C N·L with N·L = 1 and no highlight, on an opaque slab.
        ("zero_gradient.ppm", All(half)),
        // A NaN normal counts as none: isotropic, (ka + kd) C = 1 on o = 0.5.
        ("normal_nan.ppm", Centre(half)),
        // Φ_r {(0, 0.2), (1, 0.8)}: Φ(0) = 0, Φ(0.5) = 0.5, Φ(1) = 0.8; Φ_t {(0, 0.9), (1, 0.6)}:
        // Φ(0) = 0 (at or below a_1), Φ(1) = 0.6 (src/model/mapping.rs, docs/compat.md).
        ("ramp_a1_0_f0.ppm", All(grey(0.0))),
        ("ramp_a1_0_f0.5.ppm", Centre(half)),
        ("ramp_an_1_f1.ppm", Centre(grey(0.8))),
        ("lookup_a1_0_f0.ppm", All(grey(0.0))),
        ("lookup_an_1_f1.ppm", Centre(grey(0.6))),
        // 16-bit datasets: (v − a) / (b − a) in double, clamped. a = −FLT_MAX, b = FLT_MAX:
        // 0.5 for every voxel; full range at 65535: 1; inverted at 0: 1; b − a = 1e-30: 1;
        // a = 1, b = 1 + ulp at v = 1: 0.
        ("u16_widest_range.ppm", Centre(half)),
        ("u16_full_range.ppm", All(grey(1.0))),
        ("u16_inverted.ppm", All(grey(1.0))),
        ("u16_tiny_range.ppm", All(grey(1.0))),
        ("u16_ulp_range.ppm", All(grey(0.0))),
        // DSR: from the sphere's centre every ray crosses it once; opaque, ambient only.
        ("dsr_camera_inside.ppm", All(ka_c)),
        ("dsr_light_at_eye.ppm", Centre(lit)),
        // Inverse-square with intensity 175², 175 from the light.
        ("dsr_light_inverse_square.ppm", Centre(lit)),
        // (dsr_light_at_eye_shadows: see dsr_surfaces_do_not_shadow_themselves below.)
        ("dsr_step_1e-4.ppm", Centre(ka_c)),
        ("dsr_step_1e6.ppm", Centre(ka_c)),
        // F = threshold everywhere counts as inside: the box's front face is the surface.
        ("dsr_on_threshold.ppm", All(grey(1.0))),
        ("dsr_nan.ppm", All(grey(0.0))),
        // MIP of a lone object: o·C + (1 − o)·background.
        ("mip.ppm", All(grey(0.4))),
        ("mip_nan.ppm", All(grey(0.0))),
        ("wedge.ppm", NonIncreasingRows),
        ("wedge_step_1e-4.ppm", NonIncreasingRows),
    ]
}

fn close(got: u8, want: f64) -> bool {
    (got as f64 - 255.0 * want).abs() <= 1.0
}

fn matches(p: [u8; 3], want: [f64; 3]) -> bool {
    (0..3).all(|c| close(p[c], want[c]))
}

fn check(name: &str, img: &Ppm, want: &Want) -> Result<(), String> {
    let centre = img.pixel(img.width / 2, img.height / 2);
    match want {
        Centre(v) => matches(centre, *v)
            .then_some(())
            .ok_or(format!("centre pixel {centre:?}, want 255 · {v:?}")),
        All(v) => {
            for y in 0..img.height {
                for x in 0..img.width {
                    let p = img.pixel(x, y);
                    if !matches(p, *v) {
                        return Err(format!("pixel ({x}, {y}) is {p:?}, want 255 · {v:?}"));
                    }
                }
            }
            Ok(())
        }
        CentreEither(a, b) => (matches(centre, [*a; 3]) || matches(centre, [*b; 3]))
            .then_some(())
            .ok_or(format!(
                "centre pixel {centre:?}, want 255 · {a} or 255 · {b}"
            )),
        NonIncreasingRows => {
            for y in 0..img.height {
                let row: Vec<u8> = (0..img.width).map(|x| img.pixel(x, y)[0]).collect();
                if row.windows(2).any(|w| w[1] > w[0]) {
                    return Err(format!("row {y} increases somewhere: {row:?}"));
                }
                // The wedge really is there: white at its thin edge, dark at its thick one
                // (T = 0.7^10 ≈ 0.03 through the whole depth).
                if row[0] < 200 || *row.last().unwrap() > 20 {
                    return Err(format!("row {y} does not span the wedge: {row:?}"));
                }
            }
            Ok(())
        }
    }
    .map_err(|e| format!("{name}: {e}"))
}

#[test]
fn hard_cases_render_as_predicted_on_any_thread_count() {
    let bin = TempDir::new("hard-bin");
    let exe = compile(bin.path());
    let work = TempDir::new("hard-run");
    let (one, two) = (work.path().join("threads1"), work.path().join("threads2"));
    let lines = run(&exe, &one, 1);
    assert_eq!(lines, run(&exe, &two, 2), "the case lines differ");
    assert!(lines.len() >= 60, "only {} cases", lines.len());

    // Every image: there, complete, and the same bytes for both thread counts.
    let mut images = Vec::new();
    for line in &lines {
        let file = file_of(line);
        let (a, b) = (one.join(&file), two.join(&file));
        let img = Ppm::read(&a);
        assert!(img.width > 0 && img.height > 0, "{file}");
        assert_eq!(
            std::fs::read(&a).unwrap(),
            std::fs::read(&b).unwrap_or_else(|e| panic!("{}: {e}", b.display())),
            "{file} differs between 1 and 2 threads"
        );
        let name = file.split_once('_').unwrap().1.to_string();
        images.push((name, img));
    }
    // The PNG twin of the NaN scene.
    let png = lines
        .iter()
        .map(|l| file_of(l))
        .find(|f| f.ends_with("field_nan_twice.ppm"))
        .expect("the field_nan_twice case")
        .replace(".ppm", ".png");
    assert_eq!(common::png_size(&one.join(&png)), (9, 9));
    assert_eq!(
        std::fs::read(one.join(&png)).unwrap(),
        std::fs::read(two.join(&png)).unwrap(),
        "{png} differs between 1 and 2 threads"
    );
    // No temporaries left behind.
    for dir in [&one, &two] {
        for entry in std::fs::read_dir(dir).unwrap() {
            let name = entry.unwrap().file_name().to_string_lossy().into_owned();
            assert!(!name.ends_with(".tmp"), "temporary {name} left in {dir:?}");
        }
    }

    // The predicted values.
    let mut failed = Vec::new();
    let predictions = predictions();
    for (name, want) in &predictions {
        let img = images
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, img)| img)
            .unwrap_or_else(|| panic!("no case {name}"));
        if let Err(e) = check(name, img, want) {
            failed.push(e);
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
    assert!(predictions.len() >= 50, "{} predictions", predictions.len());
}

/// A DSR object that casts and receives shadows must not shadow its own lit surface: the
/// sphere lit from the eye, shadows on, looks exactly as with shadows off (nothing lies between
/// its front and the light). The hit point is the bisection's midpoint, within 10⁻⁶ of a step
/// of the surface on either side of it; before the fix, a shadow ray starting on the inner side
/// counted the surface it started on, and the surface came out speckled black.
#[test]
fn dsr_surfaces_do_not_shadow_themselves() {
    let bin = TempDir::new("hard-bin");
    let exe = compile(bin.path());
    let work = TempDir::new("hard-run");
    let lines = run(&exe, work.path(), 1);
    let image = |suffix: &str| {
        let file = lines
            .iter()
            .map(|l| file_of(l))
            .find(|f| f.ends_with(suffix))
            .unwrap_or_else(|| panic!("no case {suffix}"));
        Ppm::read(&work.path().join(file))
    };
    let (plain, shadowed) = (
        image("_dsr_light_at_eye.ppm"),
        image("_dsr_light_at_eye_shadows.ppm"),
    );
    assert_eq!(
        plain.rgb,
        shadowed.rgb,
        "shadows darken a convex surface lit from the eye: centre {:?} instead of {:?}",
        shadowed.pixel(4, 4),
        plain.pixel(4, 4)
    );
}
