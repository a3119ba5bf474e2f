//! Normals where the geometry field jumps: an object whose F is a constant up to its box's
//! faces, the box turned about all three axes, rendered as a surface (DSR) and as a volume
//! (DVR). A normal function records each normal the renderer computes (before it would perturb
//! it) with the point it is for; each is compared with the analytic outward normal of the face
//! nearest to that point, computed here from the object's matrix alone. Central differences of
//! the jump see only which stencil points fall outside, so on a tilted face they point along a
//! sign pattern such as (1, 1, 0)/√2, tens of degrees off; the face's own normal is exact.

use glam::{DMat3, DVec3};
use std::sync::{Arc, Mutex};
use vlib::{Camera, Fields, Library, RenderType};

/// The box: 120 × 80 × 60 world units, turned by R = R_z(25°)·R_y(35°)·R_x(20°), centred at
/// the origin; object → world is p ↦ R·S·(p − ½).
fn rotation() -> DMat3 {
    DMat3::from_rotation_z(25f64.to_radians())
        * DMat3::from_rotation_y(35f64.to_radians())
        * DMat3::from_rotation_x(20f64.to_radians())
}
const SIZE: [f64; 3] = [120.0, 80.0, 60.0];

/// The normals a render of the box (DSR at F = 0.5, or DVR) computes: (object point, world
/// normal) per call of the normal function, the zero normal (no gradient) left out.
fn recorded_normals(render_type: RenderType) -> Vec<(DVec3, DVec3)> {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [40.0, 90.0, -300.0],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov: 45.0,
    })
    .unwrap();
    vl.directional_light([0.3, -0.5, 1.0], [1.0; 3], 1.0)
        .unwrap();
    vl.render_type(render_type).unwrap();
    vl.surface(Fields::F, 0.5).unwrap();
    vl.step_size(1.0, 1.0).unwrap();
    vl.object().unwrap();
    // Row-major R·S with the translation −R·S·½ (vlMatrix: column vectors).
    let m = rotation() * DMat3::from_diagonal(DVec3::from_array(SIZE));
    let t = -(m * DVec3::splat(0.5));
    let rows: [f32; 16] = std::array::from_fn(|k| {
        let (i, j) = (k / 4, k % 4);
        match (i, j) {
            (3, 3) => 1.0,
            (3, _) => 0.0,
            (_, 3) => t[i] as f32,
            _ => m.col(j)[i] as f32,
        }
    });
    vl.matrix(&rows).unwrap();
    vl.set(Fields::F | Fields::KD | Fields::COLORS, 1.0)
        .unwrap();
    vl.set(Fields::O, 0.02).unwrap();
    let seen: Arc<Mutex<Vec<(DVec3, DVec3)>>> = Default::default();
    let record = seen.clone();
    vl.normal(move |n, s| {
        let n = DVec3::from_array(n.map(f64::from));
        if n != DVec3::ZERO {
            let p = DVec3::from_array(s.position().map(f64::from));
            record.lock().unwrap().push((p, n));
        }
    })
    .unwrap();
    vl.end().unwrap();
    vl.render_preview(40, 40, 1.0).unwrap();
    let normals = seen.lock().unwrap().clone();
    normals
}

/// The outward unit normal in world space of the face of the unit cube nearest (in world
/// distance) to object point `p`, and the gap between that distance and the next face's.
fn nearest_face(p: DVec3) -> (DVec3, f64) {
    let r = rotation();
    let mut faces: Vec<(f64, DVec3)> = (0..3)
        .flat_map(|a| {
            // Object axis a spans SIZE[a] world units; its faces' normals are ±R·e_a.
            let axis = r.col(a);
            [(p[a] * SIZE[a], -axis), ((1.0 - p[a]) * SIZE[a], axis)]
        })
        .map(|(d, n)| (d.abs(), n))
        .collect();
    faces.sort_by(|a, b| a.0.total_cmp(&b.0));
    (faces[0].1, faces[1].0 - faces[0].0)
}

fn angle(a: DVec3, b: DVec3) -> f64 {
    a.normalize()
        .dot(b.normalize())
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// Checks every recorded normal against the analytic face normal: at most 10⁻³ degrees apart
/// (the normal reaches the function in f32, whose rounding turns it by about 10⁻⁵ degrees).
/// Points within a step of two faces (an edge: the shading point lies up to half a step from
/// the point whose normal is computed) are left out of the comparison. Returns how many were
/// compared and the largest angle.
fn check(render_type: RenderType) -> (usize, f64) {
    let normals = recorded_normals(render_type);
    let mut worst: f64 = 0.0;
    let mut compared = 0;
    for (p, n) in &normals {
        let (face, gap) = nearest_face(*p);
        if gap < 1.0 {
            continue;
        }
        compared += 1;
        worst = worst.max(angle(*n, face));
    }
    println!("{render_type:?}: {compared} normals compared, largest angle {worst:.2e}°");
    assert!(
        worst < 1e-3,
        "{render_type:?}: a normal {worst:.3}° from its face's"
    );
    (compared, worst)
}

#[test]
fn a_tilted_boxs_faces_get_their_analytic_normals_in_dsr() {
    let (compared, _) = check(RenderType::Dsr);
    // The camera sees three faces over most of a 40² image.
    assert!(compared > 300, "{compared} surface normals compared");
}

#[test]
fn a_tilted_boxs_faces_get_their_analytic_normals_in_dvr() {
    // DVR samples within the neighbourhood of a face (the stencil crosses it) get its normal;
    // deeper inside F is constant and there is no normal at all.
    let (compared, _) = check(RenderType::Dvr);
    assert!(compared > 300, "{compared} volume normals compared");
}
