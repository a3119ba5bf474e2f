//! The README's short tour, as a new user meets it: the C block under "A short tour" is
//! compiled with the documented line and run; its image must show a coloured, lit object and
//! agree with a converged rendering of the same program (the same source with a step of 1/8 and
//! 3 × 3 super-sampling inserted after `vlScene()`).

mod common;

use common::{Ppm, TempDir};
use std::path::Path;

/// The first ```c block after the "## A short tour" heading of README.md.
fn tour_source() -> String {
    let readme = std::fs::read_to_string(common::workspace_root().join("README.md")).unwrap();
    let after = readme
        .split_once("## A short tour")
        .expect("README has a short tour")
        .1;
    let block = after.split_once("```c\n").expect("a C block").1;
    block
        .split_once("```")
        .expect("the block ends")
        .0
        .to_string()
}

/// Compiles `source` in `dir` as `name.c`, runs it there, and reads its `tour.ppm`.
fn render(source: &str, dir: &Path, name: &str) -> Ppm {
    let file = dir.join(format!("{name}.c"));
    std::fs::write(&file, source).unwrap();
    let exe = common::compile_c(file.to_str().unwrap(), dir, &[]);
    common::run(&exe, dir, &[]);
    Ppm::read(&dir.join("tour.ppm"))
}

#[test]
fn the_readme_tour_shows_a_coloured_lit_object_close_to_a_converged_rendering() {
    let source = tour_source();
    assert!(source.contains("vlImage(\"tour.ppm\""), "{source}");
    let dir = TempDir::new("tour");
    let tour = render(&source, dir.path(), "tour");
    let converged_source = source.replacen(
        "vlScene();",
        "vlScene(); vlStepSize(0.125, 1.0); vlSuperSample(3);",
        1,
    );
    assert_ne!(converged_source, source);
    let reference = render(&converged_source, dir.path(), "converged");
    assert_eq!((tour.width, tour.height), (100, 100));

    // The object: pixels that are not the white background.
    let object: Vec<[u8; 3]> = (0..tour.height)
        .flat_map(|y| (0..tour.width).map(move |x| (x, y)))
        .map(|(x, y)| tour.pixel(x, y))
        .filter(|p| p.iter().any(|&c| c < 250))
        .collect();
    assert!(
        object.len() > 1000,
        "the object covers {} pixels",
        object.len()
    );
    // Coloured: red above green above blue, as the tour's (0.9, 0.45, 0.25) under white light.
    let mean = |c: usize| object.iter().map(|p| p[c] as f64).sum::<f64>() / object.len() as f64;
    let (r, g, b) = (mean(0), mean(1), mean(2));
    assert!(
        r > g + 20.0 && g > b + 5.0,
        "mean colour {r:.1} {g:.1} {b:.1}"
    );
    // Lit: the red channel spans the diffuse falloff and the highlight, not one flat level.
    let lo = object.iter().map(|p| p[0]).min().unwrap();
    let hi = object.iter().map(|p| p[0]).max().unwrap();
    assert!(hi as i32 - lo as i32 > 60, "red spans only {lo} … {hi}");

    // Converged: the tour's default step (1 world unit on this 350-unit object) against a
    // step of 1/8 with 3 × 3 super-sampling. The two differ only at the silhouette's edge
    // pixels and by the sampling of the first few units of the surface, so the mean
    // difference stays within 2 levels per channel.
    let diff: Vec<f64> = tour
        .rgb
        .iter()
        .zip(&reference.rgb)
        .map(|(&a, &b)| (a as f64 - b as f64).abs())
        .collect();
    let mean_diff = diff.iter().sum::<f64>() / diff.len() as f64;
    assert!(
        mean_diff < 2.0,
        "mean difference {mean_diff:.2} levels against the converged rendering"
    );
}
