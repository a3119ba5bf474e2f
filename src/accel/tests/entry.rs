//! Tests of the entry map: every ray's first occupied block against its pixel's bound, the
//! refusals, and the projection against a reference with a transform per corner and NaN-aware
//! minima (`build_within_reference`).

use super::*;

/// The parameter at which the object-space ray `o + t·d` first enters an occupied block
/// (slab test against every one; ∞ if none).
fn first_occupied(g: &SkipGrid, o: DVec3, d: DVec3) -> f64 {
    (0..g.dist.len())
        .filter(|&i| g.dist[i] == 0)
        .map(|i| entry(g.block_box(i), o, d))
        .fold(f64::INFINITY, f64::min)
}

/// Every ray through every pixel (its centre, its corners and random points in it) meets
/// no occupied block before the pixel's bound, and none at all where the bound is ∞, with
/// the eye outside the grid or inside it in an empty slab; the bounds are informative
/// (background pixels exist, and a hit ray's bound is close to its hit).
#[test]
fn entry_bounds_never_pass_an_occupied_block() {
    let mut rng = Rng(0x5eed_0002);
    let mut tally = Tally::default();
    for case in 0..32 {
        let mut g = random_grid(&mut rng, [0.03, 0.1, 0.3][case % 3]);
        let to_world = random_placement(&mut rng);
        let from = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
        let camera = if case < 24 {
            camera_at(to_world, from, 90.0 + 60.0 * rng.next(), 24)
        } else {
            // The eye inside the grid, in an empty slab (the first three layers), looking
            // along +z at the rest.
            let occupied: Vec<bool> = (0..g.dist.len())
                .map(|i| i / (g.dims[0] * g.dims[1]) >= 3 && g.dist[i] == 0)
                .collect();
            g = grid_of(g.dims, &occupied);
            let eye = DVec3::new(0.3 + 0.4 * rng.next(), 0.3 + 0.4 * rng.next(), 0.1);
            let forward = to_world.transform_vector3(DVec3::Z).normalize();
            let right = forward.any_orthonormal_vector() * 0.4;
            Pinhole {
                eye: to_world.transform_point3(eye),
                forward,
                right,
                up: forward.cross(right).normalize() * 0.35,
                width: 24,
                height: 21,
            }
        };
        let Some(map) = EntryMap::build(&g, to_world, &camera) else {
            panic!("case {case}: a camera with the volume in front gets a map");
        };
        let first = |o, d| first_occupied(&g, o, d);
        tally.check(&mut rng, (&map, &camera, to_world), 4, first, case);
    }
    tally.informative();
}

/// No map where the walk's start cannot be proved: the eye in the grid, a shell corner
/// behind the eye, or more marking than the budget; and a grid with no occupied block
/// needs none.
#[test]
fn entry_map_refuses_what_it_cannot_prove() {
    let mut rng = Rng(0x5eed_0003);
    let g = random_grid(&mut rng, 0.3);
    let to_world = DMat4::from_scale(DVec3::splat(40.0));
    let outside = camera_at(to_world, DVec3::new(1.0, 0.3, 0.2), 100.0, 16);
    assert!(EntryMap::build(&g, to_world, &outside).is_some());
    // Within one block of the grid, the grid's corner included.
    for eye in [
        DVec3::splat(20.0),
        DVec3::ZERO,
        DVec3::splat(-40.0 / 6.0 + 0.1),
    ] {
        let inside = Pinhole {
            eye,
            ..camera_at(to_world, DVec3::X, 100.0, 16)
        };
        assert!(
            EntryMap::build(&g, to_world, &inside).is_none(),
            "eye at {eye}"
        );
    }
    // Outside, but looking away: the shell is behind the eye.
    let away = Pinhole {
        forward: -outside.forward,
        ..camera_at(to_world, DVec3::new(1.0, 0.3, 0.2), 100.0, 16)
    };
    assert!(EntryMap::build(&g, to_world, &away).is_none());
    // The budget: what the default marks, and one pixel less.
    let marked = |budget| EntryMap::build_within(&g.shell, to_world, &outside, budget).is_some();
    let need = (0..=16 * 13 * 64)
        .find(|&b| marked(b))
        .expect("within the default budget");
    assert!(need > 0 && !marked(need - 1));
    // More boxes than pixels: not worth projecting.
    let tiny = Pinhole {
        width: 2,
        height: 2,
        ..camera_at(to_world, DVec3::new(1.0, 0.3, 0.2), 100.0, 16)
    };
    assert!(g.shell.len() > 4);
    assert!(EntryMap::of_boxes(&g.shell, to_world, &tiny).is_none());
    let few = Boxes::of_corners((0..4).map(|i| g.shell.corners(i)).collect(), g.shell.unit);
    assert!(EntryMap::of_boxes(&few, to_world, &tiny).is_some());
    // Nothing occupied: nothing to project.
    let empty = grid_of(g.dims, &vec![false; g.dist.len()]);
    assert!(EntryMap::build(&empty, to_world, &outside).is_none());
    // Images up to MAX_MAP_SIDE pixels a side, one row tall (a mark's columns fit 16 bits).
    let few = Boxes::of_corners((0..4).map(|i| g.shell.corners(i)).collect(), g.shell.unit);
    let sides = [
        (MAX_MAP_SIDE, 1, true),
        (MAX_MAP_SIDE + 1, 1, false),
        (1, MAX_MAP_SIDE, true),
        (1, MAX_MAP_SIDE + 1, false),
    ];
    for (width, height, map) in sides {
        let wide = Pinhole {
            width: width as u32,
            height: height as u32,
            ..outside
        };
        let got = EntryMap::of_boxes(&few, to_world, &wide).is_some();
        assert_eq!(got, map, "{width} × {height}");
    }
}

/// A mark keeps its rectangle and the largest f32 at most its depth (a lower bound stays
/// one), in twelve bytes.
#[test]
fn marks_round_their_depth_down_to_an_f32() {
    assert_eq!(std::mem::size_of::<Mark>(), 12);
    let mut rng = Rng(0x5eed_0041);
    let mut rounded = 0;
    // Zeros, f32's subnormals and beyond its range on either side, then random depths.
    let special = [
        0.0, -0.0, 1e-45, -1e-45, 3e-39, -3e-39, 1e-50, -1e-50, 1e40, -1e40,
    ];
    for i in 0..10_000 + special.len() {
        let near = match (special.get(i.wrapping_sub(10_000)), i % 4) {
            (Some(&x), _) => x,
            (None, 0) => (rng.next() - 0.5) * 1e3,
            (None, 1) => rng.next() * 1e-30,
            (None, 2) => f64::from(rng.next() as f32), // exact in f32
            (None, _) => (rng.next() + 0.5) * 1e40,    // past f32's range
        };
        let (x, y) = ((i % 7, MAX_MAP_SIDE - 1), (0, i % 300));
        let m = Mark::new(x, y, near);
        assert_eq!((m.x(), m.y()), (x, y));
        let got = m.near();
        let next = (got as f32).next_up();
        assert!(got <= near && f64::from(next) > near, "{near}: {got}");
        assert!(
            got.is_finite() || near < -f64::from(f32::MAX),
            "{near}: {got}"
        );
        rounded += usize::from(got < near);
    }
    assert!(rounded > 5000, "{rounded}");
}

/// [`EntryMarks::build_within`] with `f64::min` / `f64::max` for the rectangles and each
/// corner transformed on its own, picked by mask (sequential: the parallel form gives the
/// same numbers).
fn build_within_reference(
    boxes: &Boxes,
    to_world: DMat4,
    camera: &Pinhole,
    budget: usize,
) -> Option<EntryMap> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    if w == 0 || h == 0 || boxes.len() == 0 {
        return None;
    }
    let margin = boxes.unit * 0.125;
    // Coefficients (depth, right, up) of an eye-relative vector: the rays' own basis.
    let basis = DMat3::from_cols(camera.forward, camera.right, camera.up);
    let det = basis.determinant().abs();
    if det.is_nan() || det <= 1e-12 {
        return None;
    }
    let to_view = basis.inverse();
    let unit_forward = camera.forward.normalize_or_zero();
    let (wf, hf) = (w as f64, h as f64);
    // Each box's pixel rectangle and depth, in parallel; `None` gives up.
    let project = |&(lo, hi): &(DVec3, DVec3)| -> Option<Option<Mark>> {
        let (lo, hi) = (lo - margin, hi + margin);
        let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut near = f64::INFINITY;
        for corner in 0..8 {
            let p = DVec3::select(
                glam::BVec3::new(corner & 1 != 0, corner & 2 != 0, corner & 4 != 0),
                hi,
                lo,
            );
            let q = to_world.transform_point3(p) - camera.eye;
            let v = to_view * q;
            // Clearly in front (a corner at or behind the eye's plane breaks the hull
            // argument); NaN fails too.
            if v.x.partial_cmp(&(1e-9 * q.length())) != Some(std::cmp::Ordering::Greater) {
                return None;
            }
            let (x, y) = ((v.y / v.x + 1.0) * 0.5 * wf, (1.0 - v.z / v.x) * 0.5 * hf);
            if !(x.is_finite() && y.is_finite()) {
                return None;
            }
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
            near = near.min(q.dot(unit_forward));
        }
        // Pixel squares [px, px + 1) meeting [x0 − ε, x1 + ε] (and likewise in y).
        const EPS: f64 = 0.01;
        let (px0, px1) = (
            (x0 - EPS).floor().max(0.0),
            (x1 + EPS).floor().min(wf - 1.0),
        );
        let (py0, py1) = (
            (y0 - EPS).floor().max(0.0),
            (y1 + EPS).floor().min(hf - 1.0),
        );
        if px0 > px1 || py0 > py1 {
            return Some(None); // off the image
        }
        Some(Some(Mark::new(
            (px0 as usize, px1 as usize),
            (py0 as usize, py1 as usize),
            // Rounding of the depth itself: a relative slack far below the margin's.
            near - 1e-9 * near.abs(),
        )))
    };
    let marks: Vec<Mark> = (0..boxes.len())
        .map(|i| boxes.corners(i))
        .filter_map(|b| match project(&b) {
            None => Some(None), // give up
            Some(None) => None, // off the image
            Some(mark) => Some(mark),
        })
        .collect::<Option<Vec<Mark>>>()?;
    let area = marks.iter().fold(0usize, |sum, m| {
        let ((x0, x1), (y0, y1)) = (m.x(), m.y());
        sum.saturating_add((x1 - x0 + 1) * (y1 - y0 + 1))
    });
    if area > budget {
        return None;
    }
    // The rectangles' minimum, mark after mark over the whole image.
    let mut bound = vec![f64::INFINITY; w * h];
    for m in &marks {
        let ((x0, x1), (y0, y1)) = (m.x(), m.y());
        for y in y0..=y1 {
            for b in &mut bound[y * w + x0..=y * w + x1] {
                *b = b.min(m.near());
            }
        }
    }
    Some(EntryMap {
        width: w,
        first_row: 0,
        first_col: 0,
        bound,
    })
}

/// The map is the one the NaN-aware minima and maxima and each corner's own transform
/// give (the reference), up to the rounding of the affine corners: the same refusals, the
/// same marked pixels, and every bound within a relative 10⁻¹² of the reference's (a
/// rectangle's edge moves with rounding only where it lies within that of a pixel's edge,
/// which these cases never do): random grids, placements and cameras, far and near
/// (corners close to or behind the eye's plane: no map), looking away, tiny images and
/// budgets.
#[test]
fn entry_map_is_the_nan_aware_projection() {
    let mut rng = Rng(0x5eed_0004);
    let (mut maps, mut refusals) = (0, 0);
    for case in 0..60 {
        let g = random_grid(&mut rng, [0.03, 0.1, 0.3][case % 3]);
        let to_world = random_placement(&mut rng);
        let from = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
        let distance = [90.0 + 60.0 * rng.next(), 40.0 * rng.next(), 1e-3][case % 3];
        let size = [24, 7, 4][case / 3 % 3];
        let mut camera = camera_at(to_world, from, distance, size);
        if case % 10 == 9 {
            camera.forward = -camera.forward;
        }
        for budget in [usize::MAX, 50] {
            let got = EntryMap::build_within(&g.shell, to_world, &camera, budget);
            let want = build_within_reference(&g.shell, to_world, &camera, budget);
            match (got, want) {
                (None, None) => refusals += 1,
                (Some(got), Some(want)) => {
                    assert_eq!(got.width, want.width);
                    assert_same_bounds(case, &got.bound, &want.bound);
                    maps += 1;
                }
                (got, want) => panic!(
                    "case {case}, budget {budget}: {} against {}",
                    got.is_some(),
                    want.is_some()
                ),
            }
        }
    }
    assert!(
        maps > 20 && refusals > 10,
        "{maps} maps, {refusals} refusals"
    );
}

/// Asserts that each bound of `got` is finite where `want`'s is and equal to it within a
/// relative 10⁻¹² (the projection's rounding against the reference's), in case `case`.
fn assert_same_bounds(case: usize, got: &[f64], want: &[f64]) {
    for (a, b) in got.iter().zip(want) {
        assert_eq!(a.is_finite(), b.is_finite(), "case {case}: {a} {b}");
        if b.is_finite() {
            assert!(
                (a - b).abs() <= 1e-12 * b.abs(),
                "case {case}: {a} against {b}"
            );
        }
    }
}

/// A tile's map holds the bits the whole image's map holds at its pixels, for tiles of any
/// size and place (aligned with the bins or not, across bins, clipped at the image's edges),
/// and an empty or off-image rectangle holds nothing: each pixel is lowered by every mark
/// that covers it, once.
#[test]
fn a_tiles_map_is_the_images_map_there() {
    let mut rng = Rng(0x5eed_0011);
    let mut tiles = 0;
    for case in 0..12 {
        let g = random_grid(&mut rng, [0.1, 0.3][case % 2]);
        let to_world = random_placement(&mut rng);
        let from = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
        let size = [40, 53, 19][case % 3];
        let camera = camera_at(to_world, from, 90.0 + 60.0 * rng.next(), size);
        let Some(marks) = EntryMarks::build(&g, to_world, &camera) else {
            continue;
        };
        let whole = marks.all_rows().expect("a map of every pixel");
        let (w, h) = (camera.width as usize, camera.height as usize);
        // The whole map over several bins against the reference (all marks over the whole
        // image), as in `entry_map_is_the_nan_aware_projection`.
        let want = build_within_reference(&g.shell, to_world, &camera, usize::MAX)
            .expect("the reference maps what the map maps");
        assert_eq!(whole.bound.len(), want.bound.len());
        assert_same_bounds(case, &whole.bound, &want.bound);
        for side in [ENTRY_BIN, 2 * ENTRY_BIN, 7, 50] {
            for ty in (0..h + side).step_by(side / 2 + 1) {
                for tx in (0..w + side).step_by(side / 3 + 1) {
                    let map = marks.tile(tx..tx + side, ty..ty + side);
                    let (tw, th) = (
                        (tx + side).min(w).saturating_sub(tx),
                        (ty + side).min(h).saturating_sub(ty),
                    );
                    assert_eq!(map.bound.len(), tw * th, "case {case} tile at ({tx}, {ty})");
                    for y in ty..ty + th {
                        for x in tx..tx + tw {
                            let (a, b) = (
                                map.bound(x as u32, y as u32),
                                whole.bound(x as u32, y as u32),
                            );
                            assert_eq!(a.to_bits(), b.to_bits(), "case {case} pixel ({x}, {y})");
                        }
                    }
                    tiles += 1;
                }
            }
        }
    }
    assert!(tiles > 1000, "only {tiles} tiles checked");
}

/// `count` random boxes in the unit cube, each up to a fifth of it on a side.
fn random_boxes(rng: &mut Rng, count: usize) -> Boxes {
    let corners = (0..count)
        .map(|_| {
            let lo = DVec3::new(rng.next(), rng.next(), rng.next()) * 0.9;
            let size = DVec3::new(rng.next(), rng.next(), rng.next()) * 0.2;
            (lo, (lo + size).min(DVec3::ONE))
        })
        .collect();
    Boxes::of_corners(corners, DVec3::splat(0.05))
}

/// Made in several runs of boxes (each filed by bins on its own), the map is still the
/// reference's, every tile's map is the whole map's there, and the budget holds for the
/// runs together: a map of exactly the budget is made, one pixel less refuses it even though
/// every run alone is within it.
#[test]
fn a_map_made_in_runs_is_the_reference() {
    let mut rng = Rng(0x5eed_0012);
    for case in 0..4 {
        let boxes = random_boxes(&mut rng, [5000, 3001, 2049, 7777][case]);
        let to_world = random_placement(&mut rng);
        let from = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
        let camera = camera_at(
            to_world,
            from,
            90.0 + 60.0 * rng.next(),
            [96, 70, 41, 130][case],
        );
        let marks = EntryMarks::build_within(&boxes, to_world, &camera, usize::MAX)
            .expect("a camera with the boxes in front gets a map");
        assert!(marks.runs() > 1, "case {case}: one run");
        let whole = marks.all_rows().expect("a map of every pixel");
        let want = build_within_reference(&boxes, to_world, &camera, usize::MAX)
            .expect("the reference maps what the map maps");
        assert_same_bounds(case, &whole.bound, &want.bound);
        let (w, h) = (camera.width as usize, camera.height as usize);
        for (tx, ty) in [(0, 0), (ENTRY_BIN, 0), (17, 20), (w - 5, h - 9)] {
            let map = marks.tile(tx..tx + ENTRY_BIN, ty..ty + ENTRY_BIN);
            for y in ty..(ty + ENTRY_BIN).min(h) {
                for x in tx..(tx + ENTRY_BIN).min(w) {
                    let (a, b) = (
                        map.bound(x as u32, y as u32),
                        whole.bound(x as u32, y as u32),
                    );
                    assert_eq!(a.to_bits(), b.to_bits(), "case {case} pixel ({x}, {y})");
                }
            }
        }
        let (area, largest) = marks.areas();
        assert!(
            largest < area - 1,
            "case {case}: a run of {largest} of {area}"
        );
        assert!(EntryMarks::build_within(&boxes, to_world, &camera, area).is_some());
        assert!(EntryMarks::build_within(&boxes, to_world, &camera, area - 1).is_none());
    }
}

/// The projection's lanes (eight boxes at a time, in AVX2 registers where the processor has
/// them, and in the baseline's) give the marks of one box at a time bit for bit, and give up
/// where one box at a time does: runs of every length from 0 to 40 (full and partial
/// lanes), boxes in front of the eye, across its plane and behind it, off the image, and
/// degenerate (flat, a point, NaN corners).
#[test]
fn projection_lanes_are_one_box_at_a_time() {
    let mut rng = Rng(0x5eed_0013);
    let (mut made, mut refused) = (0, 0);
    for case in 0..120 {
        let to_world = random_placement(&mut rng);
        let from = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
        let distance = [150.0 * rng.next() + 20.0, 30.0 * rng.next(), 1e4][case % 3];
        let camera = camera_at(to_world, from, distance, 20 + (rng.next() * 60.0) as u32);
        let margin = DVec3::splat([0.0, 0.01, 0.3][case % 3]);
        let Some(projection) = Projection::new(to_world, &camera, margin) else {
            panic!("case {case}: a regular camera");
        };
        let count = case % 41;
        let mut corners: Vec<(DVec3, DVec3)> = (0..count)
            .map(|_| {
                let lo = DVec3::new(rng.next(), rng.next(), rng.next()) * 2.0 - 0.5;
                (
                    lo,
                    lo + DVec3::new(rng.next(), rng.next(), rng.next()) * 0.3,
                )
            })
            .collect();
        // Degenerate boxes now and then: flat, a point, a NaN corner.
        if count > 3 && case % 4 == 0 {
            corners[1].1.z = corners[1].0.z;
            corners[2].1 = corners[2].0;
        }
        if count > 5 && case % 10 == 5 {
            corners[count - 2].0.y = f64::NAN;
        }
        let boxes = Boxes::of_corners(corners.clone(), DVec3::splat(0.05));
        let mut want = Vec::new();
        let mut gives_up = false;
        for &(lo, hi) in &corners {
            match projection.mark(lo, hi) {
                None => gives_up = true,
                Some(None) => {}
                Some(Some(m)) => want.push(m),
            }
        }
        let bits = |m: &Mark| (m.x(), m.y(), m.near().to_bits());
        for (name, f) in [
            (
                "dispatched",
                Projection::marks as fn(&_, &_, _, &mut _) -> bool,
            ),
            ("baseline", Projection::marks_generic),
        ] {
            let mut got = Vec::new();
            let ok = f(&projection, &boxes, 0..count, &mut got);
            assert_eq!(ok, !gives_up, "case {case} {name}");
            if ok {
                let (got, want): (Vec<_>, Vec<_>) = (
                    got.iter().map(bits).collect(),
                    want.iter().map(bits).collect(),
                );
                assert_eq!(got, want, "case {case} {name}");
            }
        }
        if gives_up {
            refused += 1;
        } else if !want.is_empty() {
            made += 1;
        }
    }
    assert!(
        made > 40 && refused > 20,
        "{made} runs marked, {refused} refused"
    );
}
