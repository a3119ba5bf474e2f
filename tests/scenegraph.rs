//! Scene graphs, constructive volume geometry, spatial transfer functions and voxelization,
//! checked node by node against independent computations.

use glam::{DMat4, DVec3};
use vlib::cvg::{self, Operator};
use vlib::Dataset;
use vlib::{Fields, Library};

fn tmp(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("vlib-sg-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The spherical distance field of Figure 5, written independently: 1 − 2|q − c|, in [0, 1].
fn sphere(q: DVec3) -> f64 {
    (1.0 - 2.0 * (q - DVec3::splat(0.5)).length()).clamp(0.0, 1.0)
}

fn inside(q: DVec3, b: f64) -> bool {
    let (lo, hi) = (0.5 - b / 2.0, 0.5 + b / 2.0);
    (0..3).all(|i| q[i] >= lo && q[i] <= hi)
}

/// Voxelizes opacity over world [0, 10]³ at n³ nodes, 16 bits, and returns the values.
fn voxelize_o(vl: &mut Library, dir: &std::path::Path, n: i32) -> Dataset {
    let prefix = dir.join("v");
    vl.volume(&prefix, Fields::O, [0.0; 3], [10.0; 3], [n; 3], 2)
        .unwrap();
    vl.end().unwrap();
    let d = Dataset::load(&dir.join("v_o.vlb")).unwrap();
    assert_eq!(d.dims(), [n as usize; 3]);
    d
}

/// The two children of the CVG tests, in the parent's object space: a sphere moved left, and a
/// smaller sphere moved right and up. Returns their parent-to-child matrices.
fn add_children(vl: &mut Library) -> [DMat4; 2] {
    let field = |s: &mut vlib::Sample| {
        let v = vlib::vlaux::sphere(s.position());
        let _ = s.set(Fields::O, v);
        let _ = s.set(Fields::R, 0.25);
    };
    vl.object().unwrap();
    vl.translate(-0.2, 0.0, 0.0).unwrap();
    vl.function(Fields::O | Fields::R, field).unwrap();
    vl.end().unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(0.8, 0.8, 0.8).unwrap();
    vl.translate(0.7, 0.6, 0.5).unwrap();
    vl.function(Fields::O | Fields::R, field).unwrap();
    vl.end().unwrap();
    let m1 = DMat4::from_translation(DVec3::new(-0.2, 0.0, 0.0));
    let m2 = DMat4::from_translation(DVec3::new(0.7, 0.6, 0.5))
        * DMat4::from_scale(DVec3::splat(0.8))
        * DMat4::from_translation(DVec3::splat(-0.5));
    [m1.inverse(), m2.inverse()]
}

#[test]
fn cvg_operators_voxelize_to_their_definitions_node_by_node() {
    let dir = tmp("cvg");
    let n = 33;
    for (op, f) in [
        (Operator::Union, cvg::union as fn(&mut vlib::Sample)),
        (Operator::Intersection, cvg::intersection),
        (Operator::Difference, cvg::difference),
        (Operator::Blend, cvg::blend),
    ] {
        let mut vl = Library::new();
        vl.scene().unwrap();
        vl.object().unwrap();
        vl.scale(10.0, 10.0, 10.0).unwrap();
        let to_child = add_children(&mut vl);
        vl.function(Fields::ALL, f).unwrap();
        vl.end().unwrap();
        let d = voxelize_o(&mut vl, &dir, n);
        let mut nonzero = 0;
        for k in 0..n as usize {
            for j in 0..n as usize {
                for i in 0..n as usize {
                    let p = DVec3::new(i as f64, j as f64, k as f64) / (n - 1) as f64;
                    let o: Vec<f64> = to_child
                        .iter()
                        .map(|m| {
                            let q = m.transform_point3(p);
                            if inside(q, 1.0) {
                                sphere(q)
                            } else {
                                0.0
                            }
                        })
                        .collect();
                    let want = match op {
                        Operator::Union => o[0].max(o[1]),
                        Operator::Intersection => o[0].min(o[1]),
                        Operator::Difference => o[0].min(1.0 - o[1]),
                        Operator::Blend => 1.0 - (1.0 - o[0]) * (1.0 - o[1]),
                        other => panic!("no closed form for {other:?}"),
                    };
                    let got = d.node(i, j, k) as f64;
                    // 16-bit quantisation (7.6e-6) plus f32 evaluation.
                    assert!(
                        (got - want).abs() < 1e-3,
                        "{op:?} node ({i},{j},{k}): {got} vs {want}"
                    );
                    nonzero += usize::from(want > 0.01);
                }
            }
        }
        assert!(
            nonzero > 100,
            "{op:?}: the test must see the shapes ({nonzero} nodes)"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The paper's twist Ψ (§4.7), with atan2 for the quadrant.
fn twist(p: DVec3) -> DVec3 {
    let (dx, dz) = (p.x - 0.5, p.z - 0.5);
    let r = (dx * dx + dz * dz).sqrt();
    let theta = std::f64::consts::FRAC_PI_2 * p.y + dz.atan2(dx);
    DVec3::new(r * theta.cos() + 0.5, p.y, r * theta.sin() + 0.5)
}

#[test]
fn twist_on_an_x_ramp_voxelizes_to_the_closed_form_outside_the_unit_box_too() {
    let dir = tmp("twist");
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.object().unwrap();
    vl.boundary(1.5, 1.5, 1.5).unwrap();
    vl.spatial(|s| {
        let p = s.position();
        let q = twist(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
        s.set_position(q.as_vec3().to_array()).unwrap();
    })
    .unwrap();
    vl.function(Fields::O, |s| {
        let x = s.position()[0];
        let _ = s.set(Fields::O, x);
    })
    .unwrap();
    vl.end().unwrap();
    // World = object space here; nodes over [-0.5, 1.5]³ reach beyond the enlarged boundary.
    let n = 41usize;
    vl.volume(
        dir.join("t"),
        Fields::O,
        [-0.5; 3],
        [1.5; 3],
        [n as i32; 3],
        2,
    )
    .unwrap();
    vl.end().unwrap();
    let d = Dataset::load(&dir.join("t_o.vlb")).unwrap();
    let (mut outside_unit, mut checked) = (0, 0);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = DVec3::new(i as f64, j as f64, k as f64) / (n - 1) as f64 * 2.0
                    - DVec3::splat(0.5);
                let want = if inside(p, 1.5) {
                    twist(p).x.clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let got = d.node(i, j, k) as f64;
                assert!((got - want).abs() < 1e-3, "node {p:?}: {got} vs {want}");
                checked += 1;
                if inside(p, 1.5) && !inside(p, 1.0) && want > 0.0 {
                    outside_unit += 1;
                }
            }
        }
    }
    assert!(
        outside_unit > 1000,
        "nodes kept by the enlarged boundary: {outside_unit} of {checked}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn child_hit_is_true_exactly_inside_the_transformed_boundary() {
    let dir = tmp("hit");
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.object().unwrap();
    vl.scale(10.0, 10.0, 10.0).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(0.5, 0.3, 0.6).unwrap();
    vl.rotate(20.0, 35.0, -10.0).unwrap();
    vl.translate(0.5, 0.45, 0.55).unwrap();
    vl.boundary(0.9, 1.2, 1.0).unwrap();
    vl.end().unwrap();
    vl.function(Fields::O, |s| {
        assert_eq!(s.child_count(), 1);
        let hit = s.child_hit(1).unwrap();
        let _ = s.set(Fields::O, if hit { 1.0 } else { 0.0 });
    })
    .unwrap();
    vl.end().unwrap();
    let n = 45;
    let d = voxelize_o(&mut vl, &dir, n);
    let m = (DMat4::from_translation(DVec3::new(0.5, 0.45, 0.55))
        * DMat4::from_rotation_z((-10f64).to_radians())
        * DMat4::from_rotation_y(35f64.to_radians())
        * DMat4::from_rotation_x(20f64.to_radians())
        * DMat4::from_scale(DVec3::new(0.5, 0.3, 0.6))
        * DMat4::from_translation(DVec3::splat(-0.5)))
    .inverse();
    let (mut hits, mut misses) = (0, 0);
    for k in 0..n as usize {
        for j in 0..n as usize {
            for i in 0..n as usize {
                let p = DVec3::new(i as f64, j as f64, k as f64) / (n - 1) as f64;
                let q = m.transform_point3(p);
                let b = [0.9, 1.2, 1.0];
                // Nodes within 1e-9 of a face could go either way in f32: leave them out.
                let margin = (0..3)
                    .map(|a| {
                        ((q[a] - (0.5 - b[a] / 2.0)).abs()).min((q[a] - (0.5 + b[a] / 2.0)).abs())
                    })
                    .fold(f64::INFINITY, f64::min);
                if margin < 1e-5 {
                    continue;
                }
                let want = (0..3).all(|a| q[a] >= 0.5 - b[a] / 2.0 && q[a] <= 0.5 + b[a] / 2.0);
                assert_eq!(d.node(i, j, k) > 0.5, want, "node ({i},{j},{k}) q = {q:?}");
                if want {
                    hits += 1
                } else {
                    misses += 1
                }
            }
        }
    }
    assert!(hits > 1000 && misses > 1000, "{hits} {misses}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn only_roots_render_and_child_indices_are_checked() {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.step_size(0.01, 0.01).unwrap();
    vl.object().unwrap();
    vl.object().unwrap();
    vl.set(Fields::O | Fields::COLORS | Fields::KA, 1.0)
        .unwrap();
    vl.end().unwrap();
    let errors = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let log = errors.clone();
    // (It writes opacity: instructions after the last opacity write run only where o > 0.)
    vl.function(Fields::O, move |s| {
        let mut l = log.lock().unwrap();
        if l.is_empty() {
            l.push(s.child_hit(0).unwrap_err().code);
            l.push(s.child_field(2, Fields::O).unwrap_err().code);
            l.push(s.child_field(1, Fields::O | Fields::R).unwrap_err().code);
        }
    })
    .unwrap();
    vl.end().unwrap();
    // The parent sets no opacity: the opaque child alone shows nothing.
    let img = vl.render_preview(8, 8, 1.0).unwrap();
    assert!(img.pixels.iter().all(|p| *p == [0.0; 3]));
    let e = errors.lock().unwrap();
    use vlib::ErrorCode::*;
    assert_eq!(*e, vec![BadIndex, BadIndex, BadField]);
}

#[test]
fn voxelization_quantises_to_8_and_16_bits() {
    let dir = tmp("quant");
    for bytes in [1, 2] {
        let mut vl = Library::new();
        vl.scene().unwrap();
        vl.object().unwrap();
        vl.function(Fields::O | Fields::F, |s| {
            let p = s.position();
            let _ = s.set(Fields::O, p[0]);
            let _ = s.set(Fields::F, 0.25 + 0.5 * p[1]);
        })
        .unwrap();
        vl.end().unwrap();
        vl.volume(
            dir.join("q"),
            Fields::O | Fields::F,
            [0.0; 3],
            [1.0; 3],
            [11, 5, 2],
            bytes,
        )
        .unwrap();
        vl.end().unwrap();
        let max = if bytes == 1 { 255.0 } else { 65535.0 };
        let o = Dataset::load(&dir.join("q_o.vlb")).unwrap();
        let f = Dataset::load(&dir.join("q_f.vlb")).unwrap();
        assert!(
            !dir.join("q_r.vlb").exists(),
            "only the requested fields are written"
        );
        assert_eq!(o.range(), (0.0, max as f32));
        for k in 0..2 {
            for j in 0..5 {
                for i in 0..11 {
                    // The field values are f32: quantise what was written.
                    let want_o = ((i as f64 / 10.0) as f32 as f64 * max).round();
                    let want_f = ((0.25 + 0.5 * (j as f64 / 4.0) as f32) as f64 * max).round();
                    assert_eq!(o.raw_node(i, j, k), want_o);
                    assert_eq!(f.raw_node(i, j, k), want_f);
                }
            }
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A child read by several instructions at one point runs its program once there: nested
/// objects combined by a union of their opacity and then a blend of their colours (as
/// `docs/cvg.md` combines fields) call the innermost object's field function once a point at
/// any depth (2^(depth − 1) times were each child run per read), and voxelize to the same
/// opacity (a union of one child is that child); twelve children read twice (more than a
/// sample looks up in its short list) run once each a point too.
#[test]
fn each_child_is_evaluated_once_a_point_however_often_it_is_read() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    let d = tmp("once");
    let leaf = |calls: &Arc<AtomicUsize>| {
        let calls = calls.clone();
        move |s: &mut vlib::Sample| {
            calls.fetch_add(1, Ordering::Relaxed);
            let _ = s.set(Fields::O, vlib::vlaux::sphere(s.position()));
            let _ = s.set(Fields::R, 0.25);
        }
    };
    let nested = |depth: usize| {
        let calls = Arc::new(AtomicUsize::new(0));
        let mut vl = Library::new();
        vl.scene().unwrap();
        vl.object().unwrap();
        vl.scale(10.0, 10.0, 10.0).unwrap();
        for _ in 1..depth {
            vl.object().unwrap();
        }
        vl.function(Fields::O | Fields::R, leaf(&calls)).unwrap();
        for _ in 1..depth {
            vl.end().unwrap();
            vl.function(Fields::O, cvg::union).unwrap();
            vl.function(Fields::R | Fields::G | Fields::B, cvg::blend)
                .unwrap();
        }
        vl.end().unwrap();
        let o = voxelize_o(&mut vl, &d, 9);
        (calls.load(Ordering::Relaxed), o.values().to_vec())
    };
    let (calls, values) = nested(1);
    // Every node of the 9³ grid lies in the object's closed box [0, 10]³.
    assert_eq!(calls, 9 * 9 * 9);
    for depth in [2, 6, 12] {
        let (c, v) = nested(depth);
        assert_eq!(c, calls, "depth {depth}");
        assert!(v == values, "depth {depth}");
    }

    let calls = Arc::new(AtomicUsize::new(0));
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.object().unwrap();
    vl.scale(10.0, 10.0, 10.0).unwrap();
    for _ in 0..12 {
        vl.object().unwrap();
        vl.function(Fields::O | Fields::R, leaf(&calls)).unwrap();
        vl.end().unwrap();
    }
    vl.function(Fields::O, cvg::union).unwrap();
    vl.function(Fields::R | Fields::G | Fields::B, cvg::blend)
        .unwrap();
    vl.end().unwrap();
    voxelize_o(&mut vl, &d, 9);
    assert_eq!(calls.load(Ordering::Relaxed), 12 * 9 * 9 * 9);
    std::fs::remove_dir_all(&d).unwrap();
}
