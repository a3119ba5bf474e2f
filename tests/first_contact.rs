//! The scenes a new user meets first render close to their converged images with the default
//! step: the crate's front-page example (a unit-scale sphere whose every field is the sphere
//! function) and the same scene scaled by 1000, against renderings at a step far below the
//! default (`docs/compat.md`, "The default step"). A scene that sets its step keeps it.

use vlib::{Camera, Fields, Library};

/// The front page's scene at `scale` (the unit cube scaled, the camera moved with it), with
/// the step `step` if given; its pixels' channels, rendered at 48².
fn front_page(scale: f32, step: Option<f32>) -> Vec<f64> {
    let mut vl = Library::new();
    vl.scene().unwrap();
    if let Some(s) = step {
        vl.step_size(s, 1.0).unwrap();
    }
    let c = Camera::default();
    vl.camera(&Camera {
        eye: c.eye.map(|v| v * scale),
        at: c.at.map(|v| v * scale),
        ..c
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.object().unwrap();
    vl.scale(scale, scale, scale).unwrap();
    vl.function(Fields::ALL, |s| {
        let v = vlib::vlaux::sphere(s.position());
        s.set(Fields::ALL, v).ok();
    })
    .unwrap();
    vl.end().unwrap();
    let img = vl.render_preview(48, 48, 1.0).unwrap();
    img.pixels.iter().flatten().map(|&v| v as f64).collect()
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// The root mean square of the channels' differences.
fn rms(a: &[f64], b: &[f64]) -> f64 {
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
}

#[test]
fn the_front_page_example_is_close_to_its_converged_rendering() {
    // The reference: 1/16 of the default step of the unit scene (√3 / 256 ≈ 0.0068).
    let converged_image = front_page(1.0, Some(0.0004));
    let default_image = front_page(1.0, None);
    let (converged, default) = (mean(&converged_image), mean(&default_image));
    assert!(
        converged > 0.001,
        "the converged image is black: {converged}"
    );
    // 256 samples along the box's diagonal, about 150 through the sphere: the front-to-back
    // sum of a smooth integrand, whose error shrinks linearly with the step, is within 2 % of
    // the converged value.
    let err = (default / converged - 1.0).abs();
    assert!(
        err < 0.02,
        "default {default:.4} vs converged {converged:.4}"
    );
    // The legacy step of 1 world unit (one or two samples per ray) comes out about 2.5× too
    // bright: what the default step is for.
    // Pixel by pixel too: within a tenth of an 8-bit level, root mean square.
    let pixels = rms(&default_image, &converged_image);
    assert!(pixels < 0.1 / 255.0, "rms {pixels:e}");
    let legacy = mean(&front_page(1.0, Some(1.0)));
    println!("converged {converged:.5}, default {default:.5}, step 1 {legacy:.5}");
    assert!(
        (legacy / converged - 1.0).abs() > 0.3,
        "step 1: {legacy:.4} vs converged {converged:.4}"
    );
}

#[test]
fn the_default_step_does_not_depend_on_the_scenes_scale_below_256_units() {
    // At 1 and at 100 world units (a different image: opacity is per world unit), each scene
    // against its own converged rendering.
    for scale in [1.0f32, 100.0] {
        let default = mean(&front_page(scale, None));
        let converged = mean(&front_page(scale, Some(0.0004 * scale)));
        let err = (default / converged - 1.0).abs();
        assert!(
            err < 0.02,
            "scale {scale}: default {default:.4} vs converged {converged:.4}"
        );
    }
}
