//! DSR, MIP and shadows against closed forms: the silhouette of an iso-sphere, semi-transparent
//! surfaces compositing, the maximum-intensity sample, and a shadow through a constant slab.

use vlib::MappingId;
use vlib::{Attenuation, Camera, Feature, Fields, Library, RenderType};

fn radial(s: &mut vlib::Sample) {
    let v = vlib::vlaux::sphere(s.position());
    let _ = s.set(Fields::F, v);
}

/// A sphere of world radius 25 (F = 0.5 of the radial field of a 100-unit cube at the origin),
/// seen from 200 units: the number of covered pixels of a `size`² image with field of view
/// `fov`, DSR with `step`.
fn iso_sphere_pixels(step: f32, size: u32, fov: f32) -> usize {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [0.0, 0.0, -200.0],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.step_size(step, 1.0).unwrap();
    vl.render_type(RenderType::Dsr).unwrap();
    vl.surface(Fields::F, 0.5).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(100.0, 100.0, 100.0).unwrap();
    vl.function(Fields::F, radial).unwrap();
    vl.set(Fields::O | Fields::COLORS | Fields::KA, 1.0)
        .unwrap();
    vl.end().unwrap();
    let img = vl.render_preview(size, size, 1.0).unwrap();
    img.pixels.iter().filter(|p| p[0] > 0.5).count()
}

#[test]
fn iso_sphere_silhouette_matches_the_perspective_projection() {
    let (size, fov, r, d) = (256u32, 20.0f64, 25.0f64, 200.0f64);
    // The silhouette of a sphere on the optical axis is a disc of angular radius asin(r/d);
    // on the image plane at distance 1 its radius is tan(asin(r/d)).
    let rho = (r / d).asin().tan();
    let px = rho / (fov / 2.0).to_radians().tan() * size as f64 / 2.0;
    let want = std::f64::consts::PI * px * px;
    for step in [0.5f32, 1.0, 2.0, 3.5, 5.0] {
        let got = iso_sphere_pixels(step, size, fov as f32) as f64;
        let err = (got - want).abs() / want;
        assert!(
            err < 0.01,
            "step {step}: {got} pixels vs {want:.0} ({:.2} %)",
            err * 100.0
        );
    }
}

#[test]
fn semi_transparent_surfaces_composite_in_depth_order() {
    // Three nested spheres F = 0.2, 0.35, 0.5 of the radial field; the central ray crosses each
    // twice: six layers of opacity o and colour c over a background b.
    let (o, c, b) = (0.3f64, 0.8f64, 0.25f64);
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [0.0, 0.0, -200.0],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov: 20.0,
    })
    .unwrap();
    vl.background(b as f32, b as f32, b as f32).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.render_type(RenderType::Dsr).unwrap();
    for t in [0.2, 0.35, 0.5] {
        vl.surface(Fields::F, t).unwrap();
    }
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(100.0, 100.0, 100.0).unwrap();
    vl.function(Fields::F, radial).unwrap();
    vl.set(Fields::O, o as f32).unwrap();
    vl.set(Fields::COLORS | Fields::KA, c as f32).unwrap();
    vl.end().unwrap();
    let img = vl.render_preview(5, 5, 1.0).unwrap();
    let t6 = (1.0 - o).powi(6);
    let want = c * c * (1.0 - t6) + b * t6; // colour c, ka c, ambient 1
    let got = img.pixel(2, 2)[0] as f64;
    assert!((got - want).abs() < 1e-4, "{got} vs {want}");
}

#[test]
fn mip_shows_the_most_opaque_sample() {
    // Opacity rises linearly with depth z inside the cube, up to 0.8 at the back face;
    // MIP shows o·(r, g, b) + (1 − o)·background with o the largest sample on the ray.
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [0.0, 0.0, -200.0],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov: 10.0,
    })
    .unwrap();
    vl.background(0.0, 0.0, 1.0).unwrap();
    vl.render_type(RenderType::Mip).unwrap();
    vl.step_size(0.25, 1.0).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(100.0, 100.0, 100.0).unwrap();
    vl.function(Fields::O, |s| {
        let z = s.position()[2];
        let _ = s.set(Fields::O, 0.8 * z);
    })
    .unwrap();
    vl.set(Fields::R, 1.0).unwrap();
    vl.end().unwrap();
    let p = vl.render_preview(5, 5, 1.0).unwrap().pixel(2, 2);
    // The last sample's midpoint is 0.125 units before the back face: o = 0.8·(1 − 0.125/100).
    let o = 0.8 * (1.0 - 0.125 / 100.0);
    assert!((p[0] as f64 - o).abs() < 1e-5, "{p:?}");
    assert!((p[2] as f64 - (1.0 - o)).abs() < 1e-5, "{p:?}");
}

/// A receiver (opaque, lit from straight ahead) behind a constant slab of opacity `o` and
/// depth `depth` that casts shadows; the light is behind the camera. Returns the centre pixel
/// with and without the slab casting.
fn shadowed(o: f32, depth: f32, cast: bool) -> f64 {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [0.0, 0.0, -200.0],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov: 10.0,
    })
    .unwrap();
    vl.directional_light([0.0, 0.0, 1.0], [1.0; 3], 1.0)
        .unwrap();
    vl.step_size(0.7, 1.0).unwrap();
    // The slab: casts, invisible to primary rays, so the pixel shows the receiver alone.
    vl.toggle(Feature::CastShadows, cast).unwrap();
    vl.toggle(Feature::Visible, false).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, 0.0).unwrap();
    vl.scale(400.0, 400.0, depth).unwrap();
    vl.translate(0.0, 0.0, -50.0).unwrap();
    vl.set(Fields::O, o).unwrap();
    vl.end().unwrap();
    // The receiver: receives, visible, does not cast.
    vl.toggle(Feature::CastShadows, false).unwrap();
    vl.toggle(Feature::Visible, true).unwrap();
    vl.toggle(Feature::ReceiveShadows, true).unwrap();
    vl.neighborhood(1.0, 1.0, 1.0).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, 0.0).unwrap();
    vl.scale(400.0, 400.0, 10.0).unwrap();
    vl.set(Fields::O | Fields::F | Fields::COLORS | Fields::KD, 1.0)
        .unwrap();
    vl.end().unwrap();
    vl.render_preview(5, 5, 1.0).unwrap().pixel(2, 2)[0] as f64
}

#[test]
fn a_slab_darkens_what_it_shadows_by_its_beer_lambert_transmittance() {
    let lit = shadowed(0.2, 6.0, false);
    assert!((lit - 1.0).abs() < 1e-6, "unshadowed receiver {lit}");
    for (o, depth) in [(0.2f32, 6.0f32), (0.05, 13.3), (0.5, 2.2)] {
        let got = shadowed(o, depth, true);
        let want = (1.0 - o as f64).powf(depth as f64);
        assert!(
            (got - want).abs() < 1.0 / 255.0,
            "o {o} depth {depth}: {got} vs {want}"
        );
        assert!(
            (got - want).abs() < 1e-5,
            "exact for any step: {got} vs {want}"
        );
    }
}

#[test]
fn shadows_cost_nothing_without_a_receiver() {
    let build = |receive: bool| {
        let mut vl = Library::new();
        vl.scene().unwrap();
        vl.point_light([0.0, 0.0, -10.0], Attenuation::None, [1.0; 3], 1.0)
            .unwrap();
        vl.toggle(Feature::CastShadows, true).unwrap();
        vl.toggle(Feature::ReceiveShadows, receive).unwrap();
        vl.object().unwrap();
        vl.set(Fields::O | Fields::KD, 0.5).unwrap();
        vl.end().unwrap();
        vl
    };
    for (receive, want) in [(false, false), (true, true)] {
        let vl = build(receive);
        assert_eq!(vl.render_plan().unwrap().shadows, want);
    }
}

#[test]
fn a_surface_shadows_by_the_opacity_of_each_crossing() {
    // A DSR sphere of surface opacity o between the light and a receiver: the shadow ray
    // through its centre crosses the surface twice, so the receiver gets (1 − o)².
    for o in [0.3f32, 0.75] {
        let mut vl = Library::new();
        vl.scene().unwrap();
        vl.camera(&Camera {
            eye: [0.0, 0.0, -200.0],
            at: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov: 10.0,
        })
        .unwrap();
        vl.directional_light([0.0, 0.0, 1.0], [1.0; 3], 1.0)
            .unwrap();
        vl.toggle(Feature::CastShadows, true).unwrap();
        vl.toggle(Feature::Visible, false).unwrap();
        vl.render_type(RenderType::Dsr).unwrap();
        vl.surface(Fields::F, 0.5).unwrap();
        vl.object().unwrap();
        vl.translate(-0.5, -0.5, -0.5).unwrap();
        vl.scale(100.0, 100.0, 100.0).unwrap();
        vl.translate(0.0, 0.0, -80.0).unwrap();
        vl.function(Fields::F, radial).unwrap();
        vl.set(Fields::O, o).unwrap();
        vl.end().unwrap();
        vl.render_type(RenderType::Dvr).unwrap();
        vl.toggle(Feature::CastShadows, false).unwrap();
        vl.toggle(Feature::Visible, true).unwrap();
        vl.toggle(Feature::ReceiveShadows, true).unwrap();
        vl.neighborhood(1.0, 1.0, 1.0).unwrap();
        vl.object().unwrap();
        vl.translate(-0.5, -0.5, 0.0).unwrap();
        vl.scale(400.0, 400.0, 10.0).unwrap();
        vl.set(Fields::O | Fields::F | Fields::COLORS | Fields::KD, 1.0)
            .unwrap();
        vl.end().unwrap();
        let got = vl.render_preview(5, 5, 1.0).unwrap().pixel(2, 2)[0] as f64;
        let want = (1.0 - o as f64).powi(2);
        assert!((got - want).abs() < 1e-5, "o {o}: {got} vs {want}");
    }
}

/// Nested iso-surfaces whose colours come from a lookup table stepping exactly at their
/// thresholds (the paper's Figure 8b with breaks at 0.2, 0.35 and 0.5): a hit is shaded with the
/// fields measurably inside its surface, so the outer, opaque shell (blue, the row of
/// 0.2 < F ≤ 0.35) covers the sphere's whole disc without a speckle of the inner shells or of
/// the background. `MappingType::Lookup`: Φ_t(F) is 0 for F ≤ 0.2, so a shading point whose F
/// rounds to the threshold would make the hit transparent.
#[test]
fn surfaces_are_shaded_inside_where_a_table_steps_at_their_threshold() {
    let size = 96u32;
    let mut vl = Library::new();
    #[rustfmt::skip]
    let table = [
        0.2, 1.0, 0.0, 0.0, 0.0,
        0.35, 1.0, 0.0, 0.0, 1.0,
        0.5, 1.0, 1.0, 1.0, 0.0,
        1.0, 1.0, 1.0, 0.0, 0.0,
    ];
    vl.mapping(MappingId(1), vlib::MappingType::Lookup, 4, 4, &table)
        .unwrap();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [0.0, 0.0, -200.0],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov: 40.0,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.render_type(RenderType::Dsr).unwrap();
    for thr in [0.2, 0.35, 0.5] {
        vl.surface(Fields::F, thr).unwrap();
    }
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(100.0, 100.0, 100.0).unwrap();
    vl.function(Fields::F, radial).unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    vl.map(Fields::R, Fields::F, MappingId(1), 2).unwrap();
    vl.map(Fields::G, Fields::F, MappingId(1), 3).unwrap();
    vl.map(Fields::B, Fields::F, MappingId(1), 4).unwrap();
    vl.set(Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    let img = vl.render_preview(size, size, 1.0).unwrap();
    // The outer shell: radius 40 world units (F = 1 − 2r = 0.2 at r = 0.4 of the cube), seen
    // from 200: pixels well inside its projected disc must be pure blue.
    let half = (40.0f64 / (200.0f64.powi(2) - 40.0f64.powi(2)).sqrt()) / (20f64.to_radians().tan());
    let (mut disc, mut wrong) = (0, Vec::new());
    for y in 0..size {
        for x in 0..size {
            let nx = (x as f64 + 0.5) / size as f64 * 2.0 - 1.0;
            let ny = (y as f64 + 0.5) / size as f64 * 2.0 - 1.0;
            if (nx * nx + ny * ny).sqrt() > 0.9 * half {
                continue;
            }
            disc += 1;
            let p = img.pixel(x, y);
            if !(p[0] < 0.01 && p[1] < 0.01 && p[2] > 0.99) {
                wrong.push((x, y, p));
            }
        }
    }
    assert!(disc > 1000, "{disc} pixels in the disc");
    assert!(
        wrong.is_empty(),
        "{} of {disc} pixels not the outer shell's blue, e.g. {:?}",
        wrong.len(),
        &wrong[..wrong.len().min(5)]
    );
}
