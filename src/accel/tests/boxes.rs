//! The box tree (`boxes`): its answers are those of a test of every box, for rays and points
//! of every kind (axis-parallel, on faces, not finite), and its ray test meets a box exactly
//! when a ray built through a point of the box, or away from it, says it must.

use super::super::boxes::{meets, BoxTree};
use super::Rng;
use glam::DVec3;

/// A random point of [−scale, scale]³, with some coordinates snapped to a small set of values
/// (so that boxes share faces and rays run along them).
fn point(rng: &mut Rng, scale: f64) -> DVec3 {
    let mut c = || {
        if rng.next() < 0.3 {
            (rng.next() * 5.0).floor() - 2.0
        } else {
            (rng.next() * 2.0 - 1.0) * scale
        }
    };
    DVec3::new(c(), c(), c())
}

/// Random boxes: most small, some flat (min = max along an axis), some points, some copies
/// of the box before, some without a box.
fn boxes(rng: &mut Rng, n: usize) -> Vec<Option<(DVec3, DVec3)>> {
    let mut out: Vec<Option<(DVec3, DVec3)>> = Vec::with_capacity(n);
    for _ in 0..n {
        let r = rng.next();
        let b = if r < 0.05 {
            None
        } else if r < 0.1 && !out.is_empty() {
            *out.last().unwrap()
        } else {
            let a = point(rng, 3.0);
            let mut size = DVec3::new(rng.next(), rng.next(), rng.next()) * 0.8;
            if rng.next() < 0.1 {
                size[(rng.next() * 3.0) as usize] = 0.0;
            }
            if rng.next() < 0.03 {
                size = DVec3::ZERO;
            }
            Some((a, a + size))
        };
        out.push(b);
    }
    out
}

/// A random direction, with zero, tiny and subnormal components among them.
fn direction(rng: &mut Rng) -> DVec3 {
    let mut c = || match (rng.next() * 10.0) as usize {
        0 => 0.0,
        1 => -0.0,
        2 => 1e-300 * (rng.next() - 0.5),
        3 => 5e-324,
        _ => rng.next() * 2.0 - 1.0,
    };
    DVec3::new(c(), c(), c())
}

/// What the tree must answer for a ray up to `reach`: every item whose box `meets` it, and
/// every item without a box, in increasing order.
fn ray_reference(
    boxes: &[Option<(DVec3, DVec3)>],
    o: DVec3,
    d: DVec3,
    slack: f64,
    reach: f64,
) -> Vec<usize> {
    let everything = !(o.is_finite() && d.is_finite());
    let reach = if reach.is_nan() { f64::INFINITY } else { reach };
    (0..boxes.len())
        .filter(|&i| match boxes[i] {
            Some((min, max)) if !everything => {
                meets(min - slack, max + slack, o, d, d.recip(), reach)
            }
            _ => true,
        })
        .collect()
}

#[test]
fn ray_queries_are_the_test_of_every_box() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut found = Vec::new();
    let mut nonempty = 0;
    for n in [0usize, 1, 2, 3, 4, 5, 7, 8, 9, 17, 64, 300] {
        for _ in 0..20 {
            let boxes = boxes(&mut rng, n);
            let tree = BoxTree::build(&boxes).unwrap();
            for k in 0..200 {
                let o = point(&mut rng, 5.0);
                let d = match k % 50 {
                    0 => DVec3::new(f64::NAN, 1.0, 0.0),
                    1 => DVec3::new(f64::INFINITY, 0.0, 0.0),
                    _ => direction(&mut rng),
                };
                let slack = if k % 3 == 0 { 0.0 } else { 1e-6 };
                // Whole rays, and rays up to a reach (a shadow ray's light), NaN bounding
                // nothing.
                let reach = match k % 4 {
                    0 => f64::INFINITY,
                    1 => f64::NAN,
                    _ => rng.next() * 8.0,
                };
                tree.ray(o, d, slack, reach, &mut found);
                let want = ray_reference(&boxes, o, d, slack, reach);
                assert_eq!(
                    found, want,
                    "{n} boxes, ray {o} + t·{d} to {reach}, slack {slack}"
                );
                nonempty += usize::from(!want.is_empty() && want.len() < n);
            }
        }
    }
    // The rays meet some boxes and miss others, often.
    assert!(nonempty > 10_000, "{nonempty}");
}

#[test]
fn point_queries_are_the_test_of_every_box() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    let mut found = Vec::new();
    let mut inside = 0;
    for n in [0usize, 1, 4, 5, 9, 40, 300] {
        for _ in 0..20 {
            let boxes = boxes(&mut rng, n);
            let tree = BoxTree::build(&boxes).unwrap();
            for k in 0..200 {
                // Half the points are corners of the boxes (on their faces).
                let p = match boxes.get(k % n.max(1)) {
                    Some(Some((min, max))) if k % 2 == 0 => {
                        if k % 4 == 0 {
                            *min
                        } else {
                            *max
                        }
                    }
                    _ => point(&mut rng, 3.5),
                };
                let slack = if k % 3 == 0 { 0.0 } else { 1e-3 };
                tree.point(p, slack, &mut found);
                let want: Vec<usize> = (0..n)
                    .filter(|&i| match boxes[i] {
                        Some((min, max)) => {
                            p.cmpge(min - slack).all() && p.cmple(max + slack).all()
                        }
                        None => true,
                    })
                    .collect();
                assert_eq!(found, want, "{n} boxes, point {p}, slack {slack}");
                inside += want.len();
            }
        }
    }
    assert!(inside > 5_000, "{inside}");
}

/// A hundred thousand boxes, all alike (every centre ties, which the median split breaks by
/// index) and all different: every query answers as the test of every box, and the tree is
/// shallow enough for its traversal's stack.
#[test]
fn large_trees_answer_as_the_test_of_every_box() {
    let mut rng = Rng(77);
    let same = vec![Some((DVec3::ZERO, DVec3::ONE)); 100_000];
    let tree = BoxTree::build(&same).unwrap();
    let mut found = Vec::new();
    let inf = f64::INFINITY;
    tree.ray(DVec3::new(0.5, 0.5, -1.0), DVec3::Z, 0.0, inf, &mut found);
    assert_eq!(found, (0..100_000).collect::<Vec<_>>());
    tree.ray(DVec3::new(1.5, 0.5, -1.0), DVec3::Z, 0.0, inf, &mut found);
    assert!(found.is_empty());
    tree.ray(DVec3::new(0.5, 0.5, -1.0), DVec3::Z, 0.0, 0.5, &mut found);
    assert!(found.is_empty());
    let many = boxes(&mut rng, 100_000);
    let tree = BoxTree::build(&many).unwrap();
    for _ in 0..50 {
        let (o, d) = (point(&mut rng, 5.0), direction(&mut rng));
        tree.ray(o, d, 0.0, inf, &mut found);
        assert_eq!(found, ray_reference(&many, o, d, 0.0, inf));
    }
}

/// `meets` against rays built to meet a box or to miss it: a ray from outside through a
/// point of the box (inside, on a face, at a corner) meets it at t = 1, up to the rounding of
/// `o + d`, which a slack of 10⁻⁹ of the scene covers; a ray from a point outside the box by
/// at least 10⁻³, heading away from a point of the box, misses it (the box is convex, so the
/// line meets it only on the side of that point).
#[test]
fn meets_finds_rays_through_the_box_and_not_away_from_it() {
    let mut rng = Rng(12345);
    let mut met = 0;
    for _ in 0..100_000 {
        let min = point(&mut rng, 3.0);
        let size = DVec3::new(rng.next(), rng.next(), rng.next());
        let max = min + size;
        // A point of the box, some of its coordinates on a face.
        let mut q = min + size * DVec3::new(rng.next(), rng.next(), rng.next());
        for a in 0..3 {
            match (rng.next() * 4.0) as usize {
                0 => q[a] = min[a],
                1 => q[a] = max[a],
                _ => {}
            }
        }
        let o = point(&mut rng, 6.0);
        let outside = (min - o).max(o - max).max_element();
        if outside < 1e-3 {
            continue;
        }
        let slack = 1e-9 * 10.0;
        let d = q - o;
        let inf = f64::INFINITY;
        assert!(
            meets(min - slack, max + slack, o, d, d.recip(), inf),
            "through {q}: {o} + t·{d} misses [{min}, {max}]"
        );
        // Up to its point in the box, too (a shadow ray whose light is there).
        assert!(
            meets(min - slack, max + slack, o, d, d.recip(), 1.0 + 1e-9),
            "through {q}: {o} + t·{d} up to t = 1 misses [{min}, {max}]"
        );
        let away = o - q;
        assert!(
            !meets(min, max, o, away, away.recip(), inf),
            "away from {q}: {o} + t·{away} meets [{min}, {max}]"
        );
        met += 1;
    }
    assert!(met > 50_000, "{met}");
}

/// Axis-parallel rays along a face meet the box (its faces belong to it), and those beside it
/// do not, whatever the sign of the zero components.
#[test]
fn axis_parallel_rays_on_faces_meet_the_box() {
    let (min, max) = (DVec3::ZERO, DVec3::ONE);
    for z in [0.0, -0.0] {
        for (o, d, want) in [
            (DVec3::new(0.0, 0.5, -1.0), DVec3::new(z, z, 1.0), true),
            (DVec3::new(1.0, 1.0, -1.0), DVec3::new(z, z, 1.0), true),
            (
                DVec3::new(1.0 + 1e-12, 0.5, -1.0),
                DVec3::new(z, z, 1.0),
                false,
            ),
            (DVec3::new(0.5, 0.5, 2.0), DVec3::new(z, z, 1.0), false),
            (DVec3::new(0.5, 0.5, 1.0), DVec3::new(z, z, 1.0), true),
            (DVec3::new(0.5, -1.0, 0.0), DVec3::new(z, 1.0, z), true),
            (DVec3::new(0.0, 0.0, 0.0), DVec3::new(z, z, z), true),
        ] {
            assert_eq!(
                meets(min, max, o, d, d.recip(), f64::INFINITY),
                want,
                "{o} + t·{d}"
            );
        }
    }
}

/// A ray's reach: the unit box, entered at t = 1 and left at t = 2 by a ray along z (at
/// t = 0.5 and 1 with twice the direction), is met up to a reach from its entry on (the face
/// included), and not up to a reach before it; a ray from inside meets it at any reach.
#[test]
fn a_reach_before_the_box_misses_it() {
    let (min, max) = (DVec3::ZERO, DVec3::ONE);
    let o = DVec3::new(0.5, 0.5, -1.0);
    for (d, entry) in [(DVec3::Z, 1.0), (2.0 * DVec3::Z, 0.5)] {
        for (reach, want) in [
            (0.0, false),
            (entry * (1.0 - 1e-12), false),
            (entry, true),
            (entry * 1.5, true),
            (f64::INFINITY, true),
        ] {
            assert_eq!(
                meets(min, max, o, d, d.recip(), reach),
                want,
                "{d}, reach {reach}"
            );
        }
    }
    // From inside, and from a corner along a diagonal.
    let inside = DVec3::splat(0.5);
    assert!(meets(min, max, inside, DVec3::X, DVec3::X.recip(), 0.0));
    let d = DVec3::ONE;
    assert!(meets(min, max, -DVec3::ONE, d, d.recip(), 1.0));
    assert!(!meets(min, max, -DVec3::ONE, d, d.recip(), 0.999_999));
    // A tree answers the same.
    let tree = BoxTree::build(&[Some((min, max)), Some((min + 3.0, max + 3.0))]).unwrap();
    let mut found = Vec::new();
    tree.ray(o, DVec3::Z, 0.0, 1.5, &mut found);
    assert_eq!(found, [0]);
    tree.ray(-DVec3::ONE, d, 0.0, 3.5, &mut found);
    assert_eq!(found, [0]);
    tree.ray(-DVec3::ONE, d, 0.0, 4.0, &mut found);
    assert_eq!(found, [0, 1]);
}
