//! Compiles and runs the C programs: every `examples/c/*.c` and every `capi/tests/c/*.c`, each
//! built from the workspace root with exactly
//! `cc -std=gnu89 <file> -Iinclude -Ltarget/<profile> -lvlib -lm -o <tmpdir>/<name>`
//! (warnings allowed) and run in a fresh temporary directory with
//! `LD_LIBRARY_PATH=target/<profile>`. Then the images they write are checked.
//!
//! `text.c` and `chess.c` load datasets from their working directory: before they run, the
//! `word_png` and `profiles` examples draw them and `vlconvert` converts them there (see
//! [`prepare`]). They and the other examples that take an optional `argv[1]` width (`cvg.c`,
//! `textures.c`, `smoke.c`, `deform.c`, `metaballs.c`: `common::SMALL_WIDTHS`) render small images
//! here.

mod common;

use common::{prepare, small_width, Ppm, TempDir, SMALL};
use std::path::Path;
use std::process::Command;

/// Compiles and runs one C program in a fresh directory, after preparing its inputs there;
/// returns (directory, stdout).
fn build_and_run(source: &str) -> (TempDir, String) {
    let bin = TempDir::new("bin");
    let exe = common::compile_c(source, bin.path(), &[]);
    let cwd = TempDir::new("run");
    let args = prepare(source, cwd.path());
    let stdout = common::run(&exe, cwd.path(), &args);
    (cwd, stdout)
}

/// A PNG's pixels, decoded by `vlconvert image` (colour: one 8-bit .vlb per channel, rows
/// flipped, which does not matter here) in the PNG's directory.
fn read_png(path: &Path) -> Ppm {
    let dir = path.parent().expect("directory");
    let stem = path.file_stem().and_then(|n| n.to_str()).expect("name");
    let vlb = format!("{stem}-decoded.vlb");
    common::tool(
        "vlconvert",
        &["image", path.to_str().expect("utf-8 path"), &vlb],
        dir,
    );
    let planes: Vec<(usize, usize, Vec<u8>)> = ["r", "g", "b"]
        .iter()
        .map(|c| {
            let file = dir.join(format!("{stem}-decoded_{c}.vlb"));
            let data = std::fs::read(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
            let u32_at = |i: usize| u32::from_le_bytes(data[i..i + 4].try_into().unwrap());
            assert_eq!(&data[..4], b"VLB1");
            assert_eq!((u32_at(12), u32_at(16)), (1, 1), "a 2D, 8-bit plane");
            let (w, h) = (u32_at(4) as usize, u32_at(8) as usize);
            assert_eq!(data.len(), 28 + w * h);
            (w, h, data[28..].to_vec())
        })
        .collect();
    let (width, height) = (planes[0].0, planes[0].1);
    let rgb = (0..width * height)
        .flat_map(|i| [planes[0].2[i], planes[1].2[i], planes[2].2[i]])
        .collect();
    Ppm { width, height, rgb }
}

/// Every C file compiles and runs with exit status 0 (the examples' own checks are below).
#[test]
fn every_c_program_compiles_and_runs() {
    let files: Vec<String> = common::c_files("examples/c")
        .into_iter()
        .chain(common::c_files("capi/tests/c"))
        .collect();
    assert!(
        files.len() >= 11,
        "expected figure2.c, figure5.c, text.c, chess.c, cvg.c, textures.c, smoke.c, deform.c, \
         misuse.c, sweep.c and cvg.c (the test), found {files:?}"
    );
    for f in files {
        build_and_run(&f);
    }
}

/// The headers are strict C89 (and C++), and may be included twice.
#[test]
fn headers_are_strict_c89_and_cxx() {
    let dir = TempDir::new("headers");
    let src = dir.path().join("headers.c");
    std::fs::write(
        &src,
        "#include <vlib.h>\n#include <vlaux.h>\n#include <vlib.h>\n#include <vlaux.h>\n\
         int main(void) { vlvector v; VLCAMERA c; static vlfloat w[3] = {WHITE}; (void)v; (void)c; (void)w;\n\
         return (int)(VLSPECULAR(20) + VLREFRACTION(1.5)) + VL_COLORS; }\n",
    )
    .unwrap();
    let include = common::workspace_root().join("include");
    let mut compilers = vec![(
        "cc",
        vec!["-std=c89", "-pedantic-errors", "-Wall", "-Werror"],
    )];
    if Command::new("c++")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        compilers.push(("c++", vec!["-x", "c++", "-Wall", "-Werror"]));
    }
    for (cc, flags) in compilers {
        let out = Command::new(cc)
            .args(&flags)
            .arg("-fsyntax-only")
            .arg(format!("-I{}", include.display()))
            .arg(&src)
            .output()
            .expect("run the compiler");
        assert!(
            out.status.success(),
            "{cc} {flags:?}:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// Luminance in [0, 1] (Rec. 601 weights).
fn luminance(p: [u8; 3]) -> f64 {
    (0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64) / 255.0
}

/// Whether a pixel differs from `bg` by more than 8/255 in any channel.
fn differs(p: [u8; 3], bg: [u8; 3]) -> bool {
    (0..3).any(|c| (p[c] as i32 - bg[c] as i32).abs() > 8)
}

/// The object's pixels: those differing from the background, and those of them whose four
/// neighbours all differ too (the interior, free of edge pixels that mix object and background).
fn object_mask(img: &Ppm, bg: [u8; 3]) -> (Vec<bool>, Vec<bool>) {
    let (w, h) = (img.width, img.height);
    let mask: Vec<bool> = (0..w * h)
        .map(|i| differs(img.pixel(i % w, i / w), bg))
        .collect();
    let interior = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            mask[i]
                && x > 0
                && y > 0
                && x + 1 < w
                && y + 1 < h
                && mask[i - 1]
                && mask[i + 1]
                && mask[i - w]
                && mask[i + w]
        })
        .collect();
    (mask, interior)
}

fn std_dev(v: &[f64]) -> f64 {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

/// Figure 2 writes stone.ppm: 100×100, a stone covering 10–90 % of the white frame, shaded and
/// textured, and reports the VL_BADINDEX of its line 20.
#[test]
fn figure2_renders_a_shaded_stone() {
    let (dir, stdout) = build_and_run("examples/c/figure2.c");
    assert!(
        stdout.contains(&format!(
            "vlError: {}",
            vlib_core::ErrorCode::BadIndex as i32
        )),
        "figure2 should report line 20's VL_BADINDEX, printed:\n{stdout}"
    );
    let img = Ppm::read(&dir.path().join("stone.ppm"));
    assert_eq!((img.width, img.height), (100, 100));
    let (mask, interior) = object_mask(&img, [255, 255, 255]);
    let coverage = mask.iter().filter(|m| **m).count() as f64 / mask.len() as f64;
    assert!(
        (0.10..=0.90).contains(&coverage),
        "stone covers {:.1} % of the frame",
        100.0 * coverage
    );
    let lum: Vec<f64> = (0..mask.len())
        .filter(|i| interior[*i])
        .map(|i| luminance(img.pixel(i % img.width, i / img.width)))
        .collect();
    assert!(
        lum.len() > 500,
        "too few interior stone pixels: {}",
        lum.len()
    );
    // A flat (unshaded, untextured) stone is a single colour: its interior has a luminance
    // deviation of 0, or at most half a grey level (0.002) from rounding. Diffuse shading alone
    // varies cos θ across the visible half of the ellipsoid, from about 1 to 0 at the rim, which
    // with kd = 0.6 and colours around 0.5 gives tens of grey levels; the texture adds more
    // (measured: about 0.11). 0.03 (≈ 8 grey levels) separates the two with room on both sides.
    let sd = std_dev(&lum);
    assert!(sd > 0.03, "stone luminance deviation {sd:.4}: looks flat");
    let mean = lum.iter().sum::<f64>() / lum.len() as f64;
    assert!((0.1..0.8).contains(&mean), "stone mean luminance {mean:.3}");
    // Shaded, not only textured: the light is up and to the left (x = -200, y = 380, in front of
    // the stone), so the upper-left half of the stone is brighter than the lower-right half
    // (measured: 0.36 against 0.20; a texture alone gives both halves the same mean).
    let pixels: Vec<usize> = (0..mask.len()).filter(|i| mask[*i]).collect();
    let n = pixels.len() as f64;
    let cx = pixels.iter().map(|i| (i % img.width) as f64).sum::<f64>() / n;
    let cy = pixels.iter().map(|i| (i / img.width) as f64).sum::<f64>() / n;
    let (mut lit, mut dark) = (Vec::new(), Vec::new());
    for &i in &pixels {
        let (x, y) = ((i % img.width) as f64, (i / img.width) as f64);
        let l = luminance(img.pixel(i % img.width, i / img.width));
        if (x - cx) + (y - cy) < 0.0 {
            lit.push(l);
        } else {
            dark.push(l);
        }
    }
    let (lit, dark) = (
        lit.iter().sum::<f64>() / lit.len() as f64,
        dark.iter().sum::<f64>() / dark.len() as f64,
    );
    assert!(
        lit > dark + 0.05,
        "upper-left mean {lit:.3} vs lower-right {dark:.3}: not lit from the light"
    );
}

/// Figure 5 writes marble.png and marble.ppm (256×256): a lit marble ball on a dark background.
#[test]
fn figure5_renders_a_marble_ball() {
    let (dir, stdout) = build_and_run("examples/c/figure5.c");
    assert!(
        !stdout.contains("vlError"),
        "figure5 reported errors:\n{stdout}"
    );
    assert_eq!(common::png_size(&dir.path().join("marble.png")), (256, 256));
    let img = Ppm::read(&dir.path().join("marble.ppm"));
    assert_eq!((img.width, img.height), (256, 256));
    let bg = img.pixel(0, 0);
    let (mask, interior) = object_mask(&img, bg);
    let coverage = mask.iter().filter(|m| **m).count() as f64 / mask.len() as f64;
    assert!(
        (0.15..=0.60).contains(&coverage),
        "ball covers {:.1} % of the frame",
        100.0 * coverage
    );
    let lum: Vec<f64> = (0..mask.len())
        .filter(|i| interior[*i])
        .map(|i| luminance(img.pixel(i % img.width, i / img.width)))
        .collect();
    let sd = std_dev(&lum);
    assert!(sd > 0.03, "marble luminance deviation {sd:.4}: looks flat");
}

/// The misuse program checks its own expectations (exit status) and writes misuse.ppm.
#[test]
fn misuse_program_passes() {
    let (dir, stdout) = build_and_run("capi/tests/c/misuse.c");
    assert!(stdout.contains("0 failure(s)"), "{stdout}");
    let img = Ppm::read(&dir.path().join("misuse.ppm"));
    assert_eq!((img.width, img.height), (16, 16));
}

/// The sweep program checks VLU_SWEEP's values and errors itself (exit status).
#[test]
fn sweep_program_passes() {
    let (dir, stdout) = build_and_run("capi/tests/c/sweep.c");
    assert!(stdout.contains("0 failure(s)"), "{stdout}");
    let img = Ppm::read(&dir.path().join("sweep.ppm"));
    assert_eq!((img.width, img.height), (24, 24));
}

/// The CVG program checks VLU_UNION … VLU_BLEND node by node against docs/cvg.md, and their
/// scope errors, itself (exit status).
#[test]
fn cvg_program_passes() {
    let (_dir, stdout) = build_and_run("capi/tests/c/cvg.c");
    assert!(stdout.contains("0 failure(s)"), "{stdout}");
}

/// The version program checks the header's version macros against each other and
/// `vlVersion()` against `VLIB_VERSION` in every state of the library itself (exit status);
/// its first line shows both, which are the package version of `Cargo.toml` and its encoding.
#[test]
fn version_program_passes() {
    let (_dir, stdout) = build_and_run("capi/tests/c/version.c");
    assert!(stdout.contains("0 failure(s)"), "{stdout}");
    let parts = [
        env!("CARGO_PKG_VERSION_MAJOR"),
        env!("CARGO_PKG_VERSION_MINOR"),
        env!("CARGO_PKG_VERSION_PATCH"),
    ];
    let encoded = parts.iter().fold(0u64, |n, part| {
        n * 1000 + part.parse::<u64>().expect("a number")
    });
    let line = format!(
        "vlib.h {} ({encoded}), the library {encoded}\n",
        parts.join(".")
    );
    assert!(stdout.starts_with(&line), "want {line:?}:\n{stdout}");
}

/// Fraction of pixels differing from the top-left corner's colour, and the luminance of those.
fn foreground(img: &Ppm) -> (f64, Vec<f64>) {
    let bg = img.pixel(0, 0);
    let lum: Vec<f64> = (0..img.width * img.height)
        .map(|i| img.pixel(i % img.width, i / img.width))
        .filter(|&p| differs(p, bg))
        .map(luminance)
        .collect();
    (lum.len() as f64 / (img.width * img.height) as f64, lum)
}

/// text.c writes text.png (16:9): a shaded solid word on a plain background.
#[test]
fn text_renders_a_solid_word() {
    let (dir, stdout) = build_and_run("examples/c/text.c");
    assert!(
        !stdout.contains("vlError"),
        "text reported errors:\n{stdout}"
    );
    let png = dir.path().join("text.png");
    assert_eq!(
        common::png_size(&png),
        (SMALL as u32, (SMALL * 9 / 16) as u32)
    );
    let img = read_png(&png);
    let (coverage, lum) = foreground(&img);
    // Measured: 20 % at 160 × 90.
    assert!(
        (0.08..=0.50).contains(&coverage),
        "the word covers {:.1} % of the frame",
        100.0 * coverage
    );
    // Lit faces and darker sides (measured deviation 0.12); flat colour would be about 0.
    let sd = std_dev(&lum);
    assert!(
        sd > 0.04,
        "the word's luminance deviation {sd:.4}: looks flat"
    );
}

/// chess.c writes chess.png (16:10): a board covered with light and dark pieces.
#[test]
fn chess_renders_a_board_with_pieces() {
    let (dir, stdout) = build_and_run("examples/c/chess.c");
    assert!(
        !stdout.contains("vlError"),
        "chess reported errors:\n{stdout}"
    );
    let png = dir.path().join("chess.png");
    assert_eq!(
        common::png_size(&png),
        (SMALL as u32, (SMALL * 5 / 8) as u32)
    );
    let img = read_png(&png);
    // The whole board is in the frame: every pixel of the image's border is the background
    // (the corner's colour).
    let bg = img.pixel(0, 0);
    let border = (0..img.width)
        .flat_map(|x| [(x, 0), (x, img.height - 1)])
        .chain((0..img.height).flat_map(|y| [(0, y), (img.width - 1, y)]));
    let cut: Vec<_> = border
        .filter(|&(x, y)| differs(img.pixel(x, y), bg))
        .collect();
    assert!(
        cut.is_empty(),
        "the board reaches the image's edge at {cut:?}"
    );
    let (coverage, lum) = foreground(&img);
    // Measured: the board and pieces fill 35 % of the frame at 160 × 100.
    assert!(
        (0.20..=0.80).contains(&coverage),
        "board and pieces cover {:.1} % of the frame",
        100.0 * coverage
    );
    // The black pieces are the darkest things in the picture and the ivory ones the brightest
    // (the squares lie between): both must be there. Measured: 14 % of the foreground below
    // 0.12 and 5 % above 0.7; with every piece black, none is above 0.7.
    let n = lum.len() as f64;
    let dark = lum.iter().filter(|&&l| l < 0.12).count() as f64 / n;
    let bright = lum.iter().filter(|&&l| l > 0.7).count() as f64 / n;
    assert!(
        dark > 0.03 && bright > 0.02,
        "dark pixels {:.1} %, bright pixels {:.1} %: where are the pieces?",
        100.0 * dark,
        100.0 * bright
    );
}

/// Runs example `source` at its small width and returns its image `png`, after checking it
/// reported no error and has `width × height(width)` pixels.
fn run_example(source: &str, png: &str, height: fn(usize) -> usize) -> (TempDir, Ppm) {
    let (dir, stdout) = build_and_run(source);
    assert!(
        !stdout.contains("vlError"),
        "{source} reported errors:\n{stdout}"
    );
    let path = dir.path().join(png);
    let w = small_width(source);
    assert_eq!(common::png_size(&path), (w as u32, height(w) as u32));
    let img = read_png(&path);
    (dir, img)
}

/// Fraction of the pixels of columns `x0 .. x1` differing from the top-left corner's colour.
fn coverage_of_columns(img: &Ppm, x0: usize, x1: usize) -> f64 {
    let bg = img.pixel(0, 0);
    let n = (x0..x1)
        .flat_map(|x| (0..img.height).map(move |y| (x, y)))
        .filter(|&(x, y)| differs(img.pixel(x, y), bg))
        .count();
    n as f64 / ((x1 - x0) * img.height) as f64
}

/// cvg.c writes cvg.png (4:1): four panels, union, intersection, difference and blend of an
/// orange and a blue sphere. Each panel holds a shape, and the colours follow the attribute
/// rules: the union shows both children's colours, the difference only child 1's (orange).
#[test]
fn cvg_example_renders_four_combinations() {
    let (_dir, img) = run_example("examples/c/cvg.c", "cvg.png", |w| w / 4);
    let q = img.width / 4;
    let orange = |p: [u8; 3]| p[0] as i32 > p[2] as i32 + 60;
    let blue = |p: [u8; 3]| p[2] as i32 > p[0] as i32 + 60;
    let mut counts = Vec::new();
    for (i, name) in ["union", "intersection", "difference", "blend"]
        .iter()
        .enumerate()
    {
        let coverage = coverage_of_columns(&img, i * q, (i + 1) * q);
        // Measured at 200 × 50: 22 %, 7 %, 18 %, 26 %.
        assert!(
            (0.03..=0.6).contains(&coverage),
            "the {name} panel covers {:.1} % of its quarter",
            100.0 * coverage
        );
        let pixels: Vec<[u8; 3]> = (i * q..(i + 1) * q)
            .flat_map(|x| (0..img.height).map(move |y| (x, y)))
            .map(|(x, y)| img.pixel(x, y))
            .collect();
        let o = pixels.iter().filter(|p| orange(**p)).count();
        let b = pixels.iter().filter(|p| blue(**p)).count();
        counts.push((o, b));
    }
    let [union, _, difference, _] = counts[..] else {
        unreachable!()
    };
    // Measured: 184 orange and 252 blue pixels in the union, 383 and 0 in the difference.
    assert!(
        union.0 > 20 && union.1 > 20,
        "the union shows both colours (orange, blue pixels: {union:?})"
    );
    assert!(
        difference.0 > 50 && difference.1 == 0,
        "the difference takes child 1's orange everywhere (orange, blue pixels: {difference:?})"
    );
}

/// textures.c writes textures.png (16:10): six textured objects on a floor.
#[test]
fn textures_example_renders_textured_objects() {
    let (_dir, img) = run_example("examples/c/textures.c", "textures.png", |w| w * 5 / 8);
    let (coverage, lum) = foreground(&img);
    // Measured: 54 % at 160 × 100 (the floor fills much of the lower half).
    assert!(
        (0.3..=0.95).contains(&coverage),
        "the objects and floor cover {:.1} % of the frame",
        100.0 * coverage
    );
    // White marble, dark slate, wood and granite: a wide range (measured deviation 0.14).
    let sd = std_dev(&lum);
    assert!(sd > 0.08, "luminance deviation {sd:.4}: looks flat");
}

/// smoke.c writes smoke.png (3:4): a chimney and, above it, a plume of grey smoke.
#[test]
fn smoke_example_renders_a_plume() {
    let (_dir, img) = run_example("examples/c/smoke.c", "smoke.png", |w| w * 4 / 3);
    let (coverage, _) = foreground(&img);
    // Measured: 15 % at 120 × 160.
    assert!(
        (0.05..=0.6).contains(&coverage),
        "chimney and smoke cover {:.1} % of the frame",
        100.0 * coverage
    );
    // The smoke: pixels in the upper half lighter than the dark blue background, and grey
    // (their red about their blue, unlike the background and the bricks).
    let bg = img.pixel(0, 0);
    let smoke = (0..img.width * img.height / 2)
        .map(|i| img.pixel(i % img.width, i / img.width))
        .filter(|p| luminance(*p) > luminance(bg) + 0.1 && (p[0] as i32 - p[2] as i32).abs() < 40)
        .count() as f64
        / (img.width * img.height / 2) as f64;
    // Measured: 11 %.
    assert!(
        smoke > 0.05,
        "smoke covers {:.1} % of the upper half",
        100.0 * smoke
    );
}

/// deform.c writes deform.png (2:1): four deformed objects across the frame.
#[test]
fn deform_example_renders_four_objects() {
    let (_dir, img) = run_example("examples/c/deform.c", "deform.png", |w| w / 2);
    let (coverage, lum) = foreground(&img);
    // Measured: 28 % at 160 × 80, 19 to 39 % in each quarter.
    assert!(
        (0.1..=0.6).contains(&coverage),
        "the objects cover {:.1} % of the frame",
        100.0 * coverage
    );
    let q = img.width / 4;
    for i in 0..4 {
        let c = coverage_of_columns(&img, i * q, (i + 1) * q);
        assert!(
            c > 0.05,
            "quarter {i} of the frame is nearly empty ({:.1} %)",
            100.0 * c
        );
    }
    // Measured: 0.165.
    let sd = std_dev(&lum);
    assert!(
        sd > 0.05,
        "luminance deviation {sd:.4}: the stripes are missing"
    );
}
