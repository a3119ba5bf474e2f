//! Reflection and refraction at surfaces against closed forms (Snell's law itself is a unit test
//! of the renderer): the lateral offset of a parallel-sided slab, and a mirror's angle in = angle
//! out checked by where a reflected marker lands, with the mirror's normal as it is and as its
//! normal functions tilt it, and a slab's refraction under a normal its normal function tilts.
//!
//! The ray tree's bounds: two facing mirrors cost linear work in the recursion depth with the
//! closed-form pixel (depth + 1)·a, a branch ends where its weight falls below the termination
//! threshold (the pixel a·(2 − 2⁻⁹) for KS ½), and layered glass stops costing more past the
//! depth its longest traced branch reaches. The work is counted in field evaluations.

use glam::DVec3;
use vlib::{Camera, Feature, Fields, Library, RenderType};

/// The scene: an opaque wall at z ≥ 100 whose left half (x < 0) is black and right half white,
/// seen from z = −2000 through an optional glass slab (index 1.5, thickness `h`) at the origin,
/// turned by `deg` about y, whose normal function (if `normal` is given) replaces every
/// normal by `normal`. Returns the image's middle row.
fn slab_row(h: f32, deg: f32, glass: bool, width: u32) -> Vec<f32> {
    slab_row_with(h, deg, glass, width, None)
}

fn slab_row_with(h: f32, deg: f32, glass: bool, width: u32, normal: Option<DVec3>) -> Vec<f32> {
    let mut vl = Library::new();
    vl.scene().unwrap();
    // The field of view spans the shorter (vertical) side: choose it so that the image is 3°
    // wide.
    let fov = 2.0
        * ((1.5f64).to_radians().tan() * 3.0 / width as f64)
            .atan()
            .to_degrees();
    vl.camera(&Camera {
        eye: [0.0, 0.0, -2000.0],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov: fov as f32,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.step_size(0.25, 0.25).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, 0.0).unwrap();
    vl.scale(600.0, 600.0, 10.0).unwrap();
    vl.translate(0.0, 0.0, 100.0).unwrap();
    vl.function(Fields::COLORS, |s| {
        let x = s.world_position()[0];
        let _ = s.set(Fields::COLORS, if x < 0.0 { 0.0 } else { 1.0 });
    })
    .unwrap();
    vl.set(Fields::O | Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    if glass {
        vl.render_type(RenderType::Dsr).unwrap();
        vl.surface(Fields::F, 0.5).unwrap();
        vl.toggle(Feature::Refract, true).unwrap();
        // F is a tent across the slab's depth, so the surfaces F = 0.5 are the planes a
        // quarter of the depth in from each face, and F is smooth (linear) around them:
        // central differences give the exact normal. (At a face where F jumps, they would not.)
        vl.object().unwrap();
        vl.translate(-0.5, -0.5, -0.5).unwrap();
        vl.scale(400.0, 400.0, 2.0 * h).unwrap();
        vl.rotate(0.0, deg, 0.0).unwrap();
        vl.function(Fields::F, |s| {
            let z = s.position()[2];
            let _ = s.set(Fields::F, 1.0 - (2.0 * z - 1.0).abs());
        })
        .unwrap();
        vl.set(Fields::RF, vlib::types::refraction_to_field(1.5))
            .unwrap();
        if let Some(n) = normal {
            let n = n.as_vec3().to_array();
            vl.normal(move |nv, _s| *nv = n).unwrap();
        }
        vl.end().unwrap();
    }
    let img = vl.render_preview(width, 3, width as f32 / 3.0).unwrap();
    (0..width).map(|x| img.pixel(x, 1)[0]).collect()
}

/// The first column whose pixel is lit: where the edge x = 0 of the wall appears.
fn edge(row: &[f32]) -> f64 {
    row.iter().position(|&v| v > 0.5).unwrap() as f64
}

/// Where, independently of the renderer, the ray through column `col` lands on the wall
/// (x coordinate), after crossing the slab: two planes n·p = ∓h/2, Snell's law by angles.
fn landing_x(col: f64, width: f64, h: f64, deg: f64) -> f64 {
    let th = deg.to_radians();
    // R_y(θ) applied to +z.
    let n = DVec3::new(th.sin(), 0.0, th.cos());
    landing_x_bent(col, width, h, n, n)
}

/// [`landing_x`] for the slab's planes of unit normal `plane` whose rays bend as Snell's law
/// says about the unit normal `optical` (a perturbed normal; both pointing along +z).
fn landing_x_bent(col: f64, width: f64, h: f64, plane: DVec3, optical: DVec3) -> f64 {
    let eye = DVec3::new(0.0, 0.0, -2000.0);
    let half_w = (1.5f64).to_radians().tan();
    let sx = (col + 0.5) / width * 2.0 - 1.0;
    let mut d = DVec3::new(sx * half_w, 0.0, 1.0).normalize();
    let mut p = eye;
    for (offset, n1, n2) in [(-h / 2.0, 1.0, 1.5), (h / 2.0, 1.5, 1.0)] {
        let t = (offset - plane.dot(p)) / plane.dot(d);
        p += t * d;
        let n = optical;
        let dn = d.dot(n) * n;
        let dt = d - dn;
        let sin_t = n1 / n2 * dt.length();
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        d = dt.normalize_or_zero() * sin_t + n * cos_t;
    }
    // The wall's first sample lies half a step behind its face.
    let t = (100.125 - p.z) / d.z;
    (p + t * d).x
}

#[test]
fn a_parallel_slab_displaces_rays_by_the_closed_form_offset() {
    let (width, h, deg) = (512u32, 40.0f64, 40.0f64);
    let without = edge(&slab_row(h as f32, deg as f32, false, width));
    let with = edge(&slab_row(h as f32, deg as f32, true, width));
    // The rays leave parallel to their entry, displaced by h·sin(θ − θt)/cos θt.
    let th = deg.to_radians();
    let tt = (th.sin() / 1.5).asin();
    let offset = h * (th - tt).sin() / tt.cos();
    // The independent trace finds the first column landing on the white half.
    let want = (0..width)
        .find(|&c| landing_x(c as f64, width as f64, h, deg) >= 0.0)
        .unwrap() as f64;
    let want_plain = (0..width)
        .find(|&c| landing_x(c as f64, width as f64, 0.0, 0.0) >= 0.0)
        .unwrap() as f64;
    assert!(
        (without - want_plain).abs() <= 1.0,
        "no slab: {without} vs {want_plain}"
    );
    assert!(
        (with - want).abs() <= 1.0,
        "slab: edge at column {with}, expected {want}"
    );
    // And the shift is the closed-form offset, in pixels of the wall.
    let px = 2.0 * 2100.125 * (1.5f64).to_radians().tan() / width as f64;
    let shift = (without - with).abs() * px;
    assert!(
        (shift - offset).abs() < 2.0 * px,
        "shift {shift:.2} vs offset {offset:.2} (pixel {px:.3})"
    );
    assert!(offset > 10.0 * px, "the test must see a real displacement");
}

/// Refracted rays leave along the normal the shading uses, the object's normal functions
/// included: a glass slab facing the camera (its planes z = ±h/2) whose normal function tilts
/// every normal by 25° about y bends each ray at both planes as Snell's law says for the
/// tilted normal, so the rays leave parallel to their entry but shifted sideways, and the
/// wall's edge appears where an independent trace with that normal puts it (within a column:
/// the edge is found to a pixel), tens of columns from where the untilted slab shows it.
#[test]
fn refracted_rays_follow_the_normal_functions() {
    let (width, h) = (512u32, 40.0f64);
    let tilt = 25f64.to_radians();
    let optical = DVec3::new(tilt.sin(), 0.0, tilt.cos());
    let flat = edge(&slab_row(h as f32, 0.0, true, width));
    let bent = edge(&slab_row_with(h as f32, 0.0, true, width, Some(optical)));
    let first = |optical: DVec3| {
        (0..width)
            .find(|&c| landing_x_bent(c as f64, width as f64, h, DVec3::Z, optical) >= 0.0)
            .unwrap() as f64
    };
    let (want_flat, want_bent) = (first(DVec3::Z), first(optical));
    assert!(
        (flat - want_flat).abs() <= 1.0,
        "flat: {flat} vs {want_flat}"
    );
    assert!(
        (bent - want_bent).abs() <= 1.0,
        "tilted normal: edge at column {bent}, expected {want_bent}"
    );
    assert!(
        (want_bent - want_flat).abs() > 10.0,
        "the tilt must move the edge: {want_bent} vs {want_flat}"
    );
}

/// Projects a world point with the renderer's camera model; returns pixel coordinates.
fn project(cam: &Camera, p: DVec3, w: f64, h: f64) -> (f64, f64) {
    let eye = DVec3::from_array(cam.eye.map(|v| v as f64));
    let f = (DVec3::from_array(cam.at.map(|v| v as f64)) - eye).normalize();
    let r = DVec3::from_array(cam.up.map(|v| v as f64))
        .cross(f)
        .normalize();
    let u = f.cross(r);
    let v = p - eye;
    let half = (cam.fov as f64 / 2.0).to_radians().tan();
    let (x, y, z) = (v.dot(r) / v.dot(f), v.dot(u) / v.dot(f), 1.0);
    let _ = z;
    (
        (x / (half * w / h) + 1.0) / 2.0 * w,
        (1.0 - y / half) / 2.0 * h,
    )
}

/// The mirror scenes' camera, marker centre and image size.
const MIRROR_CAMERA: Camera = Camera {
    eye: [-300.0, 0.0, -300.0],
    at: [0.0; 3],
    up: [0.0, 1.0, 0.0],
    fov: 40.0,
};
const MARKER: DVec3 = DVec3::new(120.0, 30.0, -90.0);
const MIRROR_SIZE: (u32, u32) = (160, 120);

/// A DSR mirror, the plane z = 0 (a thin slab behind it, all specular), whose normals a normal
/// function replaces by `normal` if given, and a red marker sphere of radius 10 at [`MARKER`]
/// in front of it, seen only in it; rendered with [`MIRROR_CAMERA`].
fn mirror_image(normal: Option<DVec3>) -> vlib::Image {
    let (w, h) = MIRROR_SIZE;
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&MIRROR_CAMERA).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.render_type(RenderType::Dsr).unwrap();
    vl.surface(Fields::F, 0.5).unwrap();
    vl.step_size(0.5, 1.0).unwrap();
    vl.toggle(Feature::ReceiveReflections, true).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, 0.0).unwrap();
    vl.scale(1000.0, 1000.0, 4.0).unwrap();
    vl.set(Fields::F | Fields::O | Fields::KS, 1.0).unwrap();
    if let Some(n) = normal {
        let n = n.as_vec3().to_array();
        vl.normal(move |nv, _s| *nv = n).unwrap();
    }
    vl.end().unwrap();
    vl.toggle(Feature::ReceiveReflections, false).unwrap();
    vl.toggle(Feature::CastReflections, true).unwrap();
    vl.toggle(Feature::Visible, false).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(40.0, 40.0, 40.0).unwrap();
    vl.translate(MARKER.x as f32, MARKER.y as f32, MARKER.z as f32)
        .unwrap();
    vl.function(Fields::F, |s| {
        let v = vlib::vlaux::sphere(s.position());
        let _ = s.set(Fields::F, v);
    })
    .unwrap();
    vl.set(Fields::O | Fields::COLORS | Fields::KA, 1.0)
        .unwrap();
    vl.end().unwrap();
    vl.render_preview(w, h, w as f32 / h as f32).unwrap()
}

/// The centroid (x, y, in pixels) and the number of the pixels of a [`MIRROR_SIZE`] image
/// for which `hit` holds.
fn centroid(hit: impl Fn(u32, u32) -> bool) -> (f64, f64, f64) {
    let (w, h) = MIRROR_SIZE;
    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
    for y in 0..h {
        for x in 0..w {
            if hit(x, y) {
                sx += x as f64 + 0.5;
                sy += y as f64 + 0.5;
                n += 1.0;
            }
        }
    }
    (sx / n, sy / n, n)
}

#[test]
fn a_mirror_reflects_a_marker_where_angle_in_equals_angle_out() {
    let (w, h) = MIRROR_SIZE;
    let img = mirror_image(None);
    let (gx, gy, n) = centroid(|x, y| img.pixel(x, y)[0] > 0.5);
    assert!(n > 10.0, "the reflected marker is visible ({n} pixels)");
    // Angle in = angle out: the marker appears where its mirror image behind the plane would.
    let image = DVec3::new(MARKER.x, MARKER.y, -MARKER.z);
    let (ex, ey) = project(&MIRROR_CAMERA, image, w as f64, h as f64);
    assert!(
        (gx - ex).abs() < 1.0 && (gy - ey).abs() < 1.0,
        "marker at ({gx:.2}, {gy:.2}), expected ({ex:.2}, {ey:.2})"
    );
}

/// Mirror rays leave along the normal the shading uses, the object's normal functions
/// included: a flat mirror whose normal function tilts every normal by a few degrees shows the
/// marker where rays reflected about the tilted normal meet it (an independent ray-sphere
/// computation per pixel), not where the flat mirror's image is.
#[test]
fn mirror_rays_follow_the_normal_functions() {
    let (w, h) = MIRROR_SIZE;
    let radius = 10.0; // the sphere field's 0.5 level, a quarter of the object's 40
    let tilt = 6f64.to_radians();
    let n_tilted = DVec3::new(tilt.sin(), 0.0, -tilt.cos());
    let img = mirror_image(Some(n_tilted));
    // The camera's rays (the model `project` inverts) reflected at the plane z = 0 about `n`.
    let cam = MIRROR_CAMERA;
    let eye = DVec3::from_array(cam.eye.map(|v| v as f64));
    let f = (DVec3::ZERO - eye).normalize();
    let r = DVec3::Y.cross(f).normalize();
    let u = f.cross(r);
    let half = (cam.fov as f64 / 2.0).to_radians().tan();
    let meets_marker = |x: u32, y: u32, n: DVec3| {
        let sx = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0) * half * w as f64 / h as f64;
        let sy = (1.0 - 2.0 * (y as f64 + 0.5) / h as f64) * half;
        let d = (f + sx * r + sy * u).normalize();
        let p = eye + (-eye.z / d.z) * d;
        let m = d - 2.0 * d.dot(n) * n;
        let oc = p - MARKER;
        let b = oc.dot(m);
        let disc = b * b - (oc.length_squared() - radius * radius);
        disc > 0.0 && -b - disc.sqrt() > 0.0
    };
    let (gx, gy, got) = centroid(|x, y| img.pixel(x, y)[0] > 0.5);
    let (ex, ey, want) = centroid(|x, y| meets_marker(x, y, n_tilted));
    let (fx, fy, _) = centroid(|x, y| meets_marker(x, y, -DVec3::Z));
    assert!(
        want > 10.0,
        "the tilted reflection is in view ({want} pixels)"
    );
    assert!(
        (ex - fx).hypot(ey - fy) > 5.0,
        "the tilt must move the reflection: ({ex:.1}, {ey:.1}) vs flat ({fx:.1}, {fy:.1})"
    );
    assert!(
        (got - want).abs() <= 0.25 * want,
        "{got} marker pixels, {want} expected"
    );
    assert!(
        (gx - ex).abs() < 1.0 && (gy - ey).abs() < 1.0,
        "marker at ({gx:.2}, {gy:.2}), expected ({ex:.2}, {ey:.2}); flat mirror ({fx:.2}, {fy:.2})"
    );
}

/// A surface does not shadow the points it holds: a DSR sphere that casts and receives shadows,
/// lit from the eye, looks exactly as with shadows off (nothing lies between its front and the
/// light), for several steps (the bisection leaves each hit on either side of the surface).
#[test]
fn dsr_surface_does_not_shadow_itself() {
    let render = |shadows: bool, step: f32| {
        let mut vl = Library::new();
        vl.scene().unwrap();
        vl.camera(&Camera {
            eye: [0.0, 0.0, -200.0],
            at: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov: 20.0,
        })
        .unwrap();
        vl.point_light([0.0, 0.0, -200.0], vlib::Attenuation::None, [1.0; 3], 1.0)
            .unwrap();
        vl.render_type(RenderType::Dsr).unwrap();
        vl.surface(Fields::F, 0.5).unwrap();
        vl.step_size(step, 1.0).unwrap();
        vl.toggle(Feature::CastShadows, shadows).unwrap();
        vl.toggle(Feature::ReceiveShadows, shadows).unwrap();
        vl.object().unwrap();
        vl.translate(-0.5, -0.5, -0.5).unwrap();
        vl.scale(100.0, 100.0, 100.0).unwrap();
        vl.function(Fields::F, |s| {
            let v = vlib::vlaux::sphere(s.position());
            s.set(Fields::F, v).ok();
        })
        .unwrap();
        vl.set(Fields::O, 1.0).unwrap();
        vl.set(Fields::COLORS, 1.0).unwrap();
        vl.set(Fields::KD, 1.0).unwrap();
        vl.end().unwrap();
        vl.render_preview(33, 33, 1.0).unwrap().to_rgb8()
    };
    for step in [0.37, 1.0, 3.0] {
        let lit = render(false, step);
        // The centre faces the light: fully lit (kd · C · N·L = 1).
        assert_eq!(lit[3 * (16 * 33 + 16)], 255, "step {step}");
        assert_eq!(
            lit,
            render(true, step),
            "step {step}: the surface shadows itself"
        );
    }
}

/// Two facing mirrors, opaque DSR slabs (z ∈ [100, 104] and [−104, −100], 1000 wide) whose
/// colour is `a` everywhere, KA 1 and KS `ks`, under ambient light 1 and no other light, seen
/// from between them (the eye at z = −50, looking along +z, a field of view of 1°, so
/// that every ray stays between the mirrors for hundreds of bounces) at 16², with secondary rays up to
/// `depth` bounces. Returns the image and the number of field evaluations it took (a measure of
/// the work that does not depend on the machine).
fn facing_mirrors(depth: i32, ks: f32, a: f32, terminate: bool) -> (vlib::Image, usize) {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    let calls = Arc::new(AtomicUsize::new(0));
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [0.0, 0.0, -50.0],
        at: [0.0, 0.0, 100.0],
        up: [0.0, 1.0, 0.0],
        fov: 1.0,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.render_type(RenderType::Dsr).unwrap();
    vl.surface(Fields::F, 0.5).unwrap();
    vl.step_size(1.0, 1.0).unwrap();
    vl.recursion(depth).unwrap();
    vl.toggle(Feature::ReceiveReflections, true).unwrap();
    vl.toggle(Feature::CastReflections, true).unwrap();
    for z in [100.0, -104.0] {
        vl.object().unwrap();
        vl.translate(-0.5, -0.5, 0.0).unwrap();
        vl.scale(1000.0, 1000.0, 4.0).unwrap();
        vl.translate(0.0, 0.0, z).unwrap();
        let calls = calls.clone();
        vl.function(Fields::F, move |s| {
            calls.fetch_add(1, Ordering::Relaxed);
            let _ = s.set(Fields::F, 1.0);
        })
        .unwrap();
        vl.set(Fields::O | Fields::KA, 1.0).unwrap();
        vl.set(Fields::KS, ks).unwrap();
        vl.set(Fields::COLORS, a).unwrap();
        vl.end().unwrap();
    }
    vl.set_optimise(vlib::Optimise {
        early_termination: terminate,
        ..Default::default()
    })
    .unwrap();
    let img = vl.render_preview(16, 16, 1.0).unwrap();
    let n = calls.load(Ordering::Relaxed);
    (img, n)
}

/// Perfect mirrors (KS 1) never weaken a branch: each bounce adds `a`, so the pixel is
/// (depth + 1)·a, and each bounce traces one ray (the surface behind an opaque front face is
/// not reached, so it spawns none): the work grows linearly with the depth.
#[test]
fn facing_mirrors_cost_linear_in_the_depth() {
    let a = 0.004f32;
    let cost: Vec<usize> = [8, 16, 24]
        .iter()
        .map(|&d| facing_mirrors(d, 1.0, a, true).1)
        .collect();
    let (first, second) = ((cost[1] - cost[0]) as f64, (cost[2] - cost[1]) as f64);
    assert!(first > 0.0, "deeper recursion takes more rays: {cost:?}");
    assert!(
        (second / first - 1.0).abs() < 0.05,
        "eight more bounces cost the same each time: {cost:?}"
    );
    for depth in [32, 64] {
        let (img, n) = facing_mirrors(depth, 1.0, a, true);
        // Linear: the cost at depth d extrapolated from 8 and 16, within 5 %.
        let linear = cost[0] as f64 + (depth - 8) as f64 / 8.0 * first;
        assert!(
            (n as f64 / linear - 1.0).abs() < 0.05,
            "depth {depth}: {n} evaluations, linear {linear}"
        );
        let want = (depth + 1) as f32 * a;
        for y in 0..16 {
            for x in 0..16 {
                let p = img.pixel(x, y);
                assert!(
                    (p[0] - want).abs() < 1e-5 * want.max(1.0),
                    "pixel ({x}, {y}) at depth {depth}: {} vs (depth + 1)·a = {want}",
                    p[0]
                );
            }
        }
    }
}

/// Mirrors of KS ½ weaken each bounce's branch by half: the branch of bounce i weighs 2⁻ⁱ in
/// the pixel, and a branch ends where its weight falls below the termination threshold 1/512:
/// bounces 0 … 9 are traced, the pixel is a·Σ 2⁻ⁱ = a·(2 − 2⁻⁹), and recursion 32 and 64 do
/// the same work. With early termination off nothing is cut: a·(2 − 2⁻ᵈ).
#[test]
fn a_branch_ends_where_its_weight_falls_below_the_threshold() {
    let a = 0.25f32;
    let (img32, n32) = facing_mirrors(32, 0.5, a, true);
    let (img64, n64) = facing_mirrors(64, 0.5, a, true);
    assert_eq!(n32, n64, "the branches past bounce 9 are cut at any depth");
    let want = a as f64 * (2.0 - 2f64.powi(-9));
    for img in [&img32, &img64] {
        let p = img.pixel(8, 8)[0] as f64;
        assert!((p - want).abs() < 1e-6, "{p} vs a·(2 − 2⁻⁹) = {want}");
    }
    let (full, n_full) = facing_mirrors(20, 0.5, a, false);
    assert!(n_full > n32, "without termination the tree goes deeper");
    let want = a as f64 * (2.0 - 2f64.powi(-20));
    let p = full.pixel(8, 8)[0] as f64;
    assert!((p - want).abs() < 1e-6, "{p} vs a·(2 − 2⁻²⁰) = {want}");
}

/// A layered glass block: F = ½ + ½·sin(2π·8z) across its depth (eight layers, sixteen
/// surfaces F = ½ along a ray through it), opacity `alpha`, KS ½, index 1.5, reflections and
/// refraction on, in front of a white wall, at 32² with `depth` bounces. Returns the image and
/// the number of field evaluations.
fn layered_glass(depth: i32, alpha: f32) -> (vlib::Image, usize) {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    let calls = Arc::new(AtomicUsize::new(0));
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [30.0, 40.0, -300.0],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov: 30.0,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.directional_light([0.3, 0.5, -1.0], [1.0; 3], 1.0)
        .unwrap();
    vl.recursion(depth).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, 0.0).unwrap();
    vl.scale(400.0, 400.0, 10.0).unwrap();
    vl.translate(0.0, 0.0, 100.0).unwrap();
    vl.set(Fields::O | Fields::KA | Fields::COLORS, 1.0)
        .unwrap();
    vl.end().unwrap();
    vl.render_type(RenderType::Dsr).unwrap();
    vl.surface(Fields::F, 0.5).unwrap();
    vl.toggle(Feature::Refract, true).unwrap();
    vl.toggle(Feature::ReceiveReflections, true).unwrap();
    vl.toggle(Feature::CastReflections, true).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(120.0, 120.0, 60.0).unwrap();
    vl.rotate(20.0, 30.0, 0.0).unwrap();
    let counter = calls.clone();
    vl.function(Fields::F, move |s| {
        counter.fetch_add(1, Ordering::Relaxed);
        let z = s.position()[2];
        let _ = s.set(
            Fields::F,
            0.5 + 0.5 * (2.0 * std::f32::consts::PI * 8.0 * z).sin(),
        );
    })
    .unwrap();
    vl.set(Fields::O, alpha).unwrap();
    vl.set(Fields::KS | Fields::KD, 0.5).unwrap();
    vl.set(Fields::COLORS, 0.6).unwrap();
    vl.set(Fields::RF, vlib::types::refraction_to_field(1.5))
        .unwrap();
    vl.end().unwrap();
    let img = vl.render_preview(32, 32, 1.0).unwrap();
    let n = calls.load(Ordering::Relaxed);
    (img, n)
}

/// In layered glass every surface both reflects and refracts, so the ray tree may branch at
/// each of the sixteen surfaces of each ray: only the branches that weigh at least the
/// termination threshold in the pixel are traced, so the work stops growing once the depth
/// passes the longest such branch. With opacity 0.3 a branch loses at least 30 % at each
/// surface it passes or reflects at (KS ½ · 0.3 < 0.7), so none is longer than
/// log(1/512)/log(0.7) < 18 bounces: depth 32 and 64 trace the same tree and give the same
/// image. With opacity 0.1 branches reach 59 bounces, but few rays stay in the glass so long.
#[test]
fn layered_glass_work_stops_growing_with_the_depth() {
    let (img32, n32) = layered_glass(32, 0.3);
    let (img64, n64) = layered_glass(64, 0.3);
    assert_eq!(n32, n64, "the same tree at depth 32 and 64");
    for y in 0..32 {
        for x in 0..32 {
            assert_eq!(img32.pixel(x, y), img64.pixel(x, y), "({x}, {y})");
        }
    }
    let (_, n32) = layered_glass(32, 0.1);
    let (img64, n64) = layered_glass(64, 0.1);
    assert!(
        n64 as f64 <= 1.01 * n32 as f64,
        "{n32} evaluations at depth 32, {n64} at 64"
    );
    // The glass shows: the image is not the wall's colour everywhere.
    let wall = img64.pixel(0, 0);
    assert!((0..32).any(|y| (0..32).any(|x| img64.pixel(x, y) != wall)));
}
