//! The paper's round trip (§3.2): voxelize a function-defined object with `vlVolume`, load the
//! datasets, render them, and compare with direct evaluation, at several resolutions. Prints a
//! Markdown table and, with `--write-doc`, puts it into `docs/accuracy.md`.
//!
//! ```text
//! cargo run --release --example roundtrip [-- --write-doc]
//! ```

#[path = "common/say.rs"]
mod say;
use std::time::Instant;
use vlib::{Attenuation, Camera, Fields, Image, Library, MappingType};
use vlib::{DatasetId, MappingId};

const SIZE: u32 = 256;
const WORLD: f32 = 100.0;

/// A solid-textured ball: F a paraboloid, opacity a steep ramp of F, colour smooth bands.
fn define(vl: &mut Library) -> Result<(), vlib::Error> {
    vl.function(Fields::F, |s| {
        let _ = s.set(Fields::F, vlib::vlaux::parab1(s.position()));
    })?;
    vl.map(Fields::O, Fields::F, MappingId(1), 1)?;
    vl.function(Fields::COLORS, |s| {
        let p = s.position();
        let band = 0.5 + 0.5 * (10.0 * (p[0] + 0.6 * p[1]) + 4.0 * p[2]).sin();
        let _ = s.set(Fields::R, 0.35 + 0.6 * band);
        let _ = s.set(Fields::G, 0.3 + 0.35 * band);
        let _ = s.set(Fields::B, 0.25 + 0.2 * (1.0 - band));
    })?;
    Ok(())
}

fn setup(vl: &mut Library) -> Result<(), vlib::Error> {
    vl.mapping(
        MappingId(1),
        MappingType::Ramp,
        2,
        1,
        &[0.05, 0.0, 0.15, 0.8],
    )?;
    vl.scene()?;
    vl.camera(&Camera {
        eye: [50.0, 80.0, -120.0],
        at: [50.0, 50.0, 50.0],
        up: [0.0, 1.0, 0.0],
        fov: 45.0,
    })?;
    vl.background(0.0, 0.0, 0.0)?;
    vl.ambient(1.0, 1.0, 1.0, 0.25)?;
    vl.point_light([-100.0, 200.0, -150.0], Attenuation::None, [1.0; 3], 1.0)?;
    vl.step_size(0.5, 1.0)
}

fn constants(vl: &mut Library) -> Result<(), vlib::Error> {
    vl.set(Fields::KA, 0.3)?;
    vl.set(Fields::KD, 0.7)?;
    vl.set(Fields::KS, 0.3)?;
    vl.set(Fields::N, vlib::types::specular_to_field(20.0))
}

fn direct() -> Result<(Image, f64), vlib::Error> {
    let mut vl = Library::new();
    setup(&mut vl)?;
    vl.object()?;
    vl.scale(WORLD, WORLD, WORLD)?;
    define(&mut vl)?;
    constants(&mut vl)?;
    vl.end()?;
    let t = Instant::now();
    let img = vl.render_preview(SIZE, SIZE, 1.0)?;
    Ok((img, t.elapsed().as_secs_f64()))
}

/// Voxelizes the object at n³ (16 bits) into `dir`, then renders the datasets.
fn voxelized(n: i32, dir: &std::path::Path) -> Result<(Image, f64, f64), vlib::Error> {
    let fields = Fields::O | Fields::COLORS | Fields::F;
    let prefix = dir.join(format!("ball{n}"));
    let t = Instant::now();
    let mut vl = Library::new();
    setup(&mut vl)?;
    vl.object()?;
    vl.scale(WORLD, WORLD, WORLD)?;
    define(&mut vl)?;
    vl.end()?;
    vl.volume(&prefix, fields, [0.0; 3], [WORLD; 3], [n; 3], 2)?;
    vl.end()?;
    let voxelize = t.elapsed().as_secs_f64();

    let mut vl = Library::new();
    for (id, name) in [(1, "o"), (2, "r"), (3, "g"), (4, "b"), (5, "f")] {
        let mut file = prefix.as_os_str().to_owned();
        file.push(format!("_{name}.vlb"));
        vl.load(DatasetId(id), std::path::PathBuf::from(file))?;
    }
    setup(&mut vl)?;
    vl.object()?;
    vl.scale(WORLD, WORLD, WORLD)?;
    vl.dataset(Fields::F, DatasetId(5))?;
    vl.dataset(Fields::O, DatasetId(1))?;
    vl.dataset(Fields::R, DatasetId(2))?;
    vl.dataset(Fields::G, DatasetId(3))?;
    vl.dataset(Fields::B, DatasetId(4))?;
    constants(&mut vl)?;
    vl.end()?;
    let t = Instant::now();
    let img = vl.render_preview(SIZE, SIZE, 1.0)?;
    Ok((img, t.elapsed().as_secs_f64(), voxelize))
}

/// Root-mean-square and largest difference, in 8-bit grey levels.
fn error(a: &Image, b: &Image) -> (f64, u8) {
    let (a, b) = (a.to_rgb8(), b.to_rgb8());
    let sq: f64 = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (*x as f64 - *y as f64).powi(2))
        .sum();
    let max = a
        .iter()
        .zip(&b)
        .map(|(x, y)| x.abs_diff(*y))
        .max()
        .unwrap_or(0);
    ((sq / a.len() as f64).sqrt(), max)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let write_doc = std::env::args().any(|a| a == "--write-doc");
    let dir = std::env::temp_dir().join(format!("vlib-roundtrip-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let (reference, t_direct) = direct()?;
    let mut table = String::new();
    table.push_str(&format!(
        "| resolution | voxelize (s) | render (s) | RMS error (grey levels) | max error |\n|---|---|---|---|---|\n| direct evaluation | — | {t_direct:.3} | 0 | 0 |\n"
    ));
    for n in [32, 64, 128, 256] {
        let (img, t_render, t_vox) = voxelized(n, &dir)?;
        let (rms, max) = error(&reference, &img);
        table.push_str(&format!(
            "| {n}³ | {t_vox:.2} | {t_render:.3} | {rms:.2} | {max} |\n"
        ));
        eprintln!("{n}: rms {rms:.2}, max {max}");
    }
    std::fs::remove_dir_all(&dir)?;
    say::say(format_args!("{table}"))?;
    if write_doc {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/accuracy.md");
        let doc = std::fs::read_to_string(path).unwrap_or_default();
        let (begin, end) = ("<!-- roundtrip:begin -->", "<!-- roundtrip:end -->");
        let block = format!("{begin}\n{table}{end}");
        let new = match (doc.find(begin), doc.find(end)) {
            (Some(a), Some(b)) => format!("{}{block}{}", &doc[..a], &doc[b + end.len()..]),
            _ => format!("{doc}\n{block}\n"),
        };
        vlib::write_atomic(std::path::Path::new(path), new.as_bytes())?;
        say::say(format_args!("updated {path}"))?;
    }
    Ok(())
}
