//! The hypertexture of `benches/scenes.rs` and `benches/procedural.rs`: a sphere of diameter
//! 200 whose density falls off towards its rim and is broken up by turbulence,
//! semi-transparent (opacity exact over 6 world units, sampled every 3), with a fiery colour
//! ramp. The geometry F is the smooth sphere field, so the normals (central differences of F,
//! for the diffuse term) do not re-evaluate the turbulence.

use vlib::{vlaux, Attenuation, Camera, Fields, Library, Sample};

/// The camera.
pub fn camera() -> Camera {
    Camera {
        eye: [0.0, 80.0, -380.0],
        at: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov: 40.0,
    }
}

/// The geometry: F of the sphere.
pub fn geometry(s: &mut Sample) {
    let _ = s.set(Fields::F, vlaux::sphere(s.position()));
}

/// Opacity and colour at a sample; returns the opacity it set.
pub fn opacity_colours(s: &mut Sample) -> f32 {
    // F: 1 at the centre, 0 on the inscribed sphere, negative outside. The density is
    // F - 0.25 pushed out by up to 0.3 · (2 - 0.5) by turbulence (which lies in [0, 2)):
    // nothing below F = -0.2 can become dense, and the turbulence is skipped there.
    let d = s.value(9);
    if d < -0.2 {
        let _ = s.set(Fields::O, 0.0);
        return 0.0;
    }
    let t = vlaux::turbulence(s.position(), 6.0, 3, 3);
    let density = (3.0 * (d - 0.25 + 0.3 * (t - 0.5))).clamp(0.0, 1.0);
    let _ = s.set(Fields::O, 0.6 * density);
    let _ = s.set(Fields::R, 1.0);
    let _ = s.set(Fields::G, 0.3 + 0.6 * density);
    let _ = s.set(Fields::B, 0.1 + 0.6 * density * density);
    0.6 * density
}

/// The scene, open, with `geometry` as F's function and `opacity_colours` as the function of
/// O and the colours (those above, or ones that also count their calls).
pub fn build(
    geometry: impl Fn(&mut Sample) + Send + Sync + 'static,
    opacity_colours: impl Fn(&mut Sample) + Send + Sync + 'static,
) -> Library {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&camera()).unwrap();
    vl.background(0.02, 0.02, 0.05).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.point_light([-300.0, 300.0, -300.0], Attenuation::None, [1.0; 3], 0.8)
        .unwrap();
    vl.step_size(3.0, 6.0).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(200.0, 200.0, 200.0).unwrap();
    vl.function(Fields::F, geometry).unwrap();
    vl.function(Fields::O | Fields::COLORS, opacity_colours)
        .unwrap();
    vl.set(Fields::KA, 0.6).unwrap();
    vl.set(Fields::KD, 0.5).unwrap();
    vl.end().unwrap();
    vl
}
