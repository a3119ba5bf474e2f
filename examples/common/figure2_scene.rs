//! The paper's Figure 2 scene with the safe Rust API (`examples/c/figure2.c`'s commands, in
//! its order); shared by `examples/figure2.rs`, `examples/mpi_bench.rs` and, with field
//! functions of their own, `benches/scenes.rs` and `benches/procedural.rs`.

#![allow(dead_code)]

use vlib::MappingId;
use vlib::{vlaux, Attenuation, Camera, Fields, Library, MappingType};

/// Granite, as `stone` in `examples/c/figure2.c` computes it, operation for operation in f32,
/// so the two programs write the same bytes: a base grey-brown whose lightness follows
/// turbulence, a low-frequency warm/cool tint, dark mica specks and light quartz grains.
fn stone(s: &mut vlib::Sample) {
    let p = s.position();
    let t = vlaux::turbulence(p, 5.0, 5, 1); // mostly 0.1 .. 0.9
    let warm = 0.5 + 0.5 * vlaux::noise(p, 2.5, 2); // 0 .. 1
    let grain = vlaux::noise(p, 48.0, 3); // -1 .. 1
    let speck = vlaux::noise(p, 23.0, 4); // -1 .. 1
    let shade = 0.42 + 0.35 * t.min(1.0) + 0.08 * grain;
    let (mut r, mut g, mut b) = (
        shade * (0.88 + 0.22 * warm),
        shade * (0.84 + 0.12 * warm),
        shade * (0.80 + 0.04 * warm),
    );
    if speck > 0.42 {
        // dark mica flakes
        r *= 0.35;
        g *= 0.35;
        b *= 0.38;
    } else if grain > 0.55 {
        // light quartz grains
        r = 0.5 * (r + 0.95);
        g = 0.5 * (g + 0.93);
        b = 0.5 * (b + 0.90);
    }
    let _ = s.set(Fields::R, r);
    let _ = s.set(Fields::G, g);
    let _ = s.set(Fields::B, b);
}

/// The camera of Figure 2.
pub fn camera() -> Camera {
    Camera {
        eye: [175.0, 250.0, -350.0],
        at: [175.0, 140.0, 70.0],
        up: [0.0, 1.0, 0.0],
        fov: vlib::DEFAULT_FOV,
    }
}

/// The benchmarks' stone (`benches/scenes.rs`, `benches/procedural.rs`), simpler than
/// [`stone`] and kept as measured in `docs/performance.md`: turbulent greys with a warm tint
/// and dark speckles.
pub fn bench_stone(s: &mut vlib::Sample) {
    let p = s.position();
    let t = vlaux::turbulence(p, 6.0, 5, 11);
    let speck = vlaux::noise(p, 40.0, 3);
    let base = 0.45 + 0.35 * t - if speck > 0.45 { 0.25 } else { 0.0 };
    let _ = s.set(Fields::R, base + 0.06);
    let _ = s.set(Fields::G, base);
    let _ = s.set(Fields::B, base - 0.05);
}

/// Opens the scene of Figure 2 in `vl` (at library scope), its image `out` of `size × size`
/// pixels, and builds it; the scene is left open (its `end` renders and writes the image).
pub fn build(vl: &mut Library, out: &str, size: i32) -> Result<(), Box<dyn std::error::Error>> {
    let geometry = |s: &mut vlib::Sample| {
        let _ = s.set(Fields::F, vlaux::parab1(s.position()));
    };
    build_with(vl, Some((out, size)), geometry, stone, true)
}

/// Opens the scene of Figure 2 in `vl` (at library scope) and builds it with the geometry field
/// function `geometry` (the paper's `parab1`, or one that also counts its calls) and the colour
/// function `colours`; `image`: the image requested (name and side), if any;
/// `paper_line_20`: the paper's `vlMap(VL_KS, VL_F, 1, 2)` is issued too (refused, it changes
/// nothing: kept where a program must run `figure2.c`'s commands). The scene is left open.
pub fn build_with(
    vl: &mut Library,
    image: Option<(&str, i32)>,
    geometry: impl Fn(&mut vlib::Sample) + Send + Sync + 'static,
    colours: impl Fn(&mut vlib::Sample) + Send + Sync + 'static,
    paper_line_20: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let white = [1.0, 1.0, 1.0];
    vl.scene()?;
    vl.camera(&camera())?;
    if let Some((out, size)) = image {
        vl.image(out, 1.0, size, size)?;
    }
    vl.background(1.0, 1.0, 1.0)?;
    vl.mapping(
        MappingId(1),
        MappingType::Lookup,
        2,
        1,
        &[0.001, 1.0, 1.0, 0.3],
    )?;
    vl.point_light([-200.0, 380.0, -200.0], Attenuation::None, white, 1.0)?;
    vl.ambient(1.0, 1.0, 1.0, 1.0)?;
    vl.object()?;
    vl.scale(350.0, 300.0, 300.0)?;
    vl.function(Fields::F, geometry)?;
    vl.map(Fields::O, Fields::F, MappingId(1), 1)?;
    // The paper's line 20 asks for output 2 of this one-output table: an error that changes
    // nothing (`examples/c/figure2.c` reports it through vlError). It is kept so that both
    // programs run the same commands; the error is expected and not reported here.
    if paper_line_20 && vl.map(Fields::KS, Fields::F, MappingId(1), 2).is_ok() {
        return Err("the paper's line 20 should be refused: output 2 of a one-output table".into());
    }
    vl.function(Fields::COLORS, colours)?;
    vl.set(Fields::KA, 0.3)?;
    vl.set(Fields::KD, 0.6)?;
    vl.set(Fields::N, vlib::types::specular_to_field(20.0))?;
    vl.end()?; // object
    Ok(())
}
