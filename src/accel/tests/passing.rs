//! Tests of the passing boxes: group codes and rows of groups against the group-by-group
//! reference (`passing_in`), and every ray's first passing cell against the boxes' entry map.

use super::*;

/// Of the cells [lo, hi) (by their first nodes' indices per axis) of `data`: the lowest and
/// highest index per axis of those that `mask` lets pass, and whether all pass; `None` when
/// none does. (The oracle of [`passing_groups_row`].)
fn passing_in(
    data: &Dataset,
    mask: &CellMask,
    lo: [usize; 3],
    hi: [usize; 3],
) -> Option<([usize; 3], [usize; 3], bool)> {
    let (mut first, mut last, mut all) = ([usize::MAX; 3], [0usize; 3], true);
    // A row of the group's cells along x at a time, as bits of the mask.
    let width = hi[0] - lo[0];
    for k in lo[2]..hi[2] {
        for j in lo[1]..hi[1] {
            let row = mask.run(data.node_index([lo[0], j, k]), width);
            all &= row.count_ones() as usize == width;
            if row == 0 {
                continue;
            }
            let (a, b) = (row.trailing_zeros(), 63 - row.leading_zeros());
            first[0] = first[0].min(lo[0] + a as usize);
            last[0] = last[0].max(lo[0] + b as usize);
            for (axis, c) in [(1, j), (2, k)] {
                first[axis] = first[axis].min(c);
                last[axis] = last[axis].max(c);
            }
        }
    }
    (first[0] != usize::MAX).then_some((first, last, all))
}

impl GroupCode {
    /// The code of `passing` (cells within `BRICK` of `lo`, the group's first cell).
    fn new(lo: [usize; 3], passing: Option<([usize; 3], [usize; 3], bool)>) -> GroupCode {
        let Some((first, last, all)) = passing else {
            return GroupCode::NONE;
        };
        let offsets = |c: [usize; 3]| std::array::from_fn(|a| (c[a] - lo[a]) as u8);
        GroupCode::of_offsets(offsets(first), offsets(last), all)
    }
}

/// The first parameter at which `o + t·d` (t ≥ 0) enters the box of a cell that can pass
/// (a cell on a face of the dataset reaching as far as the object box does there, up to the
/// face tolerance 2⁻²⁰ past it: further out the dataset is 0); ∞ if none.
fn first_passing(
    data: &Dataset,
    mask: &CellMask,
    (box_min, box_max): (DVec3, DVec3),
    o: DVec3,
    d: DVec3,
) -> f64 {
    let n = data.dims();
    let cells = n.map(|k| k - 1);
    let mut first = f64::INFINITY;
    for k in 0..cells[2] {
        for j in 0..cells[1] {
            for i in 0..cells[0] {
                if !mask.may_reach(data.node_index([i, j, k])) {
                    continue;
                }
                let c = [i, j, k];
                let tol = 1.0 / 1048576.0;
                let lo = DVec3::from_array(std::array::from_fn(|a| match c[a] {
                    0 => box_min[a].max(-tol).min(0.0),
                    v => v as f64 / cells[a] as f64,
                }));
                let hi = DVec3::from_array(std::array::from_fn(|a| {
                    if c[a] + 1 == cells[a] {
                        box_max[a].min(1.0 + tol).max(1.0)
                    } else {
                        (c[a] + 1) as f64 / cells[a] as f64
                    }
                }));
                first = first.min(entry((lo, hi), o, d));
            }
        }
    }
    first
}

/// A group's passing cells, read a row of mask bits at a time, are those its cells' own
/// bits give: over random masks, groups at the grid's faces and runs crossing words.
#[test]
fn passing_cells_of_a_group_are_those_of_their_bits() {
    let mut rng = Rng(0x5eed_0017);
    for case in 0..12 {
        let dims = [70 + case, 9 + case % 4, 7];
        let data = spheres(&mut rng, dims, 1 + case % 3);
        let mask = data.cells_above(0.3 + 0.05 * (case % 5) as f32);
        let cells = dims.map(|n| n - 1);
        for gk in 0..cells[2].div_ceil(BRICK) {
            for gj in 0..cells[1].div_ceil(BRICK) {
                for gi in 0..cells[0].div_ceil(BRICK) {
                    let lo = [gi, gj, gk].map(|g| g * BRICK);
                    let hi = std::array::from_fn(|a| (lo[a] + BRICK).min(cells[a]));
                    let (mut first, mut last, mut all) = ([usize::MAX; 3], [0; 3], true);
                    for k in lo[2]..hi[2] {
                        for j in lo[1]..hi[1] {
                            for i in lo[0]..hi[0] {
                                if mask.may_reach(data.node_index([i, j, k])) {
                                    for (a, c) in [i, j, k].into_iter().enumerate() {
                                        first[a] = first[a].min(c);
                                        last[a] = last[a].max(c);
                                    }
                                } else {
                                    all = false;
                                }
                            }
                        }
                    }
                    let want = (first[0] != usize::MAX).then_some((first, last, all));
                    assert_eq!(passing_in(&data, &mask, lo, hi), want, "{dims:?} {lo:?}");
                }
            }
        }
    }
}

/// A row of groups' codes, read from the mask a word at a time, are their groups' passing
/// cells found group by group (`passing_in`): rows of cells shorter and longer than a
/// word, multiples of the group and of the word and neither, sparse and dense masks.
#[test]
fn rows_of_groups_are_their_groups() {
    let mut rng = Rng(0x5eed_0031);
    let mut seen = [0usize; 3]; // none, some, all of a group's cells pass
    for (case, nx) in [2, 5, 17, 61, 64, 65, 66, 129, 130, 200]
        .into_iter()
        .enumerate()
    {
        let dims = [nx, 6 + case % 3, 5 + case % 4];
        let data = spheres(&mut rng, dims, 1 + case % 3);
        for z in [0.0, 0.05, 0.3, 0.6] {
            let mask = data.cells_above(z);
            let cells = dims.map(|n| n - 1);
            let groups = cells.map(|c| c.div_ceil(BRICK));
            for gk in 0..groups[2] {
                for gj in 0..groups[1] {
                    let mut row = vec![GroupCode(0); groups[0]];
                    passing_groups_row(&data, &mask, cells, (gj, gk), &mut row);
                    for (gi, &code) in row.iter().enumerate() {
                        let lo = [gi, gj, gk].map(|g| g * BRICK);
                        let hi = std::array::from_fn(|a| (lo[a] + BRICK).min(cells[a]));
                        let want = passing_in(&data, &mask, lo, hi);
                        assert_eq!(code, GroupCode::new(lo, want), "{dims:?} z {z} {lo:?}");
                        seen[match want {
                            None => 0,
                            Some((_, _, false)) => 1,
                            Some((_, _, true)) => 2,
                        }] += 1;
                    }
                }
            }
        }
    }
    assert!(
        seen.iter().all(|&n| n > 20),
        "every kind of group: {seen:?}"
    );
}

/// The passing boxes are the groups with passing cells (their codes as `passing_in` finds
/// them, in group order) less those enclosed: the group and its 26 neighbours all pass,
/// every one inside the grid. Volumes with many full groups (large spheres, a full cube
/// with a hollow, shapes of 2 and 3 groups along an axis), at several bounds.
#[test]
fn passing_boxes_are_the_groups_not_enclosed() {
    let mut rng = Rng(0x5eed_0032);
    let mut volumes: Vec<Dataset> = [[30, 27, 33], [41, 20, 26], [13, 30, 30], [6, 30, 30]]
        .into_iter()
        .map(|dims| spheres(&mut rng, dims, 6))
        .collect();
    // A full cube with a hollow in one group, a full slab two groups thick, and a rod of
    // more layers of groups than the boxes are counted in runs of (4096).
    let shapes = [
        ([29, 29, 29], Some([14, 14, 14])),
        ([25, 25, 9], None),
        ([9, 9, 16_401], None),
    ];
    for (dims, hollow) in shapes {
        let mut raw = vec![255u8; dims.iter().product()];
        // (Zero nodes 3 a side: the two cells within them pass no bound.)
        if let Some([i, j, k]) = hollow {
            for n in 0..27 {
                let (a, b, c) = (i + n % 3, j + n / 3 % 3, k + n / 9);
                raw[a + dims[0] * (b + dims[1] * c)] = 0;
            }
        }
        volumes.push(Dataset::new(dims, crate::data::Voxels::U8(raw), 0.0, 255.0).unwrap());
    }
    let (mut kept, mut enclosed) = (0, 0);
    for data in &volumes {
        for z in [0.05, 0.5] {
            let mask = data.cells_above(z);
            let cells = data.dims().map(|n| n - 1);
            let groups = cells.map(|c| c.div_ceil(BRICK));
            let code = |g: [usize; 3]| {
                let lo = g.map(|g| g * BRICK);
                let hi = std::array::from_fn(|a| (lo[a] + BRICK).min(cells[a]));
                GroupCode::new(lo, passing_in(data, &mask, lo, hi))
            };
            let mut want = Vec::new();
            for gk in 0..groups[2] {
                for gj in 0..groups[1] {
                    for gi in 0..groups[0] {
                        let c = code([gi, gj, gk]);
                        if c == GroupCode::NONE {
                            continue;
                        }
                        let g = [gi, gj, gk].map(|g| g as i64);
                        let full_around = (0..27).all(|n| {
                            let at: [i64; 3] =
                                std::array::from_fn(|a| g[a] + (n / 3i64.pow(a as u32)) % 3 - 1);
                            let inside = (0..3).all(|a| at[a] >= 0 && at[a] < groups[a] as i64);
                            inside && code(at.map(|c| c as usize)).all()
                        });
                        if full_around {
                            enclosed += 1;
                        } else {
                            want.push(((gi + groups[0] * (gj + groups[1] * gk)) as u32, c));
                        }
                    }
                }
            }
            kept += want.len();
            let boxes = passing_boxes(data, &mask, DVec3::ZERO, DVec3::ONE, usize::MAX);
            let boxes = boxes.expect("3D").expect("at most usize::MAX");
            assert_eq!(boxes.groups(), Some(&want[..]), "{:?} z {z}", data.dims());
        }
    }
    assert!(
        kept > 100 && enclosed > 10,
        "kept {kept}, enclosed {enclosed}"
    );
}

/// A group's code gives back every passing-cells triple a group can have (each axis's
/// lowest and highest passing cell within `BRICK` of its first cell, all or not), and
/// none where none passes; codes of different triples differ.
#[test]
fn group_codes_give_back_their_groups() {
    let pairs: Vec<(usize, usize)> = (0..BRICK)
        .flat_map(|f| (f..BRICK).map(move |l| (f, l)))
        .collect();
    let mut seen = std::collections::HashSet::new();
    for (n, lo) in [
        [0, 0, 0],
        [4, 8, 12],
        [196, 232, 188],
        [1 << 30, 4, 1 << 40],
    ]
    .into_iter()
    .enumerate()
    {
        assert_eq!(GroupCode::new(lo, None).get(lo), None);
        assert!(!GroupCode::NONE.all());
        for &x in &pairs {
            for &y in &pairs {
                for &z in &pairs {
                    for all in [false, true] {
                        let g = (
                            [lo[0] + x.0, lo[1] + y.0, lo[2] + z.0],
                            [lo[0] + x.1, lo[1] + y.1, lo[2] + z.1],
                            all,
                        );
                        let code = GroupCode::new(lo, Some(g));
                        assert_ne!(code, GroupCode::NONE);
                        assert_eq!(code.get(lo), Some(g), "{lo:?}");
                        assert_eq!(code.all(), all);
                        if n == 0 {
                            assert!(seen.insert(code.0), "{g:?}");
                        }
                    }
                }
            }
        }
    }
    assert_eq!(seen.len(), 2 * pairs.len().pow(3));
}

/// With the boxes of the cells that can pass the zero test, no ray through any pixel
/// meets such a cell before its pixel's bound, none at all where the bound is ∞, for
/// object boxes of 1 and 1.3 (samples outside the dataset take its edge cells' values),
/// cameras outside and inside the volume; the enclosed groups left out are really
/// enclosed (a full volume has boxes only at its faces); the bounds are informative.
#[test]
fn passing_boxes_bound_every_ray() {
    let mut rng = Rng(0x5eed_0004);
    let mut tally = Tally::default();
    for case in 0..24 {
        let dims = [13 + case % 5, 11 + case % 3, 12];
        let data = spheres(&mut rng, dims, 1 + case % 4);
        let mask = data.cells_above(0.5);
        let half = if case % 2 == 0 { 0.5 } else { 0.65 };
        let (box_min, box_max) = (DVec3::splat(0.5 - half), DVec3::splat(0.5 + half));
        let boxes = passing_boxes(&data, &mask, box_min, box_max, usize::MAX);
        let boxes = boxes.expect("3D").expect("at most usize::MAX");
        let to_world = random_placement(&mut rng);
        let from = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
        let camera = if case % 6 != 5 {
            camera_at(to_world, from, 90.0 + 60.0 * rng.next(), 24)
        } else {
            // Inside the volume: a map only if no box is around or behind the eye.
            Pinhole {
                eye: to_world.transform_point3(DVec3::new(rng.next(), rng.next(), 0.02)),
                ..camera_at(to_world, from, 90.0, 24)
            }
        };
        let Some(map) = EntryMap::of_boxes(&boxes, to_world, &camera) else {
            assert!(case % 6 == 5, "case {case}: an outside camera gets a map");
            continue;
        };
        let first = |o, d| first_passing(&data, &mask, (box_min, box_max), o, d);
        tally.check(&mut rng, (&map, &camera, to_world), 1, first, case);
    }
    tally.informative();
    // A volume whose every cell passes: only the groups at its faces have boxes.
    let raw = vec![255u8; 17 * 17 * 17];
    let full = Dataset::new([17; 3], crate::data::Voxels::U8(raw), 0.0, 255.0).unwrap();
    let mask = full.cells_above(0.5);
    let boxes = passing_boxes(&full, &mask, DVec3::ZERO, DVec3::ONE, usize::MAX);
    assert_eq!(
        boxes.expect("3D").expect("all").len(),
        4 * 4 * 4 - 2 * 2 * 2
    );
}

/// A grid keeps its passing boxes where the image that asked can project them, else only
/// their number: an image that cannot gets none without their being found again, one that can
/// gets them made (once, then shared), and a smaller one after it none.
#[test]
fn a_grid_keeps_only_the_boxes_an_image_can_use() {
    let mut rng = Rng(0x5eed_0033);
    let data = spheres(&mut rng, [30, 27, 33], 6);
    let mask = data.cells_above(0.5);
    let cube = (DVec3::ZERO, DVec3::ONE);
    let all = passing_boxes(&data, &mask, cube.0, cube.1, usize::MAX);
    let n = all.expect("3D").expect("all").len();
    assert!(n > 10, "{n} boxes");
    assert!(matches!(
        passing_boxes(&data, &mask, cube.0, cube.1, n - 1),
        Some(Err(m)) if m == n
    ));
    let grid = grid_of([2, 2, 2], &[true; 8]);
    let kept = |grid: &SkipGrid| match &*grid.passing.lock().unwrap() {
        Passing::Unknown => "unknown".to_string(),
        Passing::Unavailable => "unavailable".to_string(),
        Passing::Many(m) => format!("many {m}"),
        Passing::Made(b) => format!("made {}", b.len()),
    };
    assert!(grid.passing_boxes(&data, &mask, cube, n - 1).is_none());
    assert_eq!(kept(&grid), format!("many {n}"));
    // (Known too many: answered from the number, with a mask that would give other boxes.)
    let other = data.cells_above(0.05);
    assert!(grid.passing_boxes(&data, &other, cube, n - 1).is_none());
    let made = grid.passing_boxes(&data, &mask, cube, n).expect("n fit");
    assert_eq!((made.len(), kept(&grid)), (n, format!("made {n}")));
    assert!(grid.passing_boxes(&data, &mask, cube, n - 1).is_none());
    let again = grid
        .passing_boxes(&data, &mask, cube, usize::MAX)
        .expect("made");
    assert!(std::sync::Arc::ptr_eq(&made, &again));
    // A dataset with an axis of one node has none, whatever the image.
    let flat = Dataset::new(
        [5, 5, 1],
        crate::data::Voxels::U8(vec![255; 25]),
        0.0,
        255.0,
    )
    .unwrap();
    let flat_grid = grid_of([2, 2, 2], &[true; 8]);
    let flat_mask = flat.cells_above(0.5);
    assert!(flat_grid
        .passing_boxes(&flat, &flat_mask, cube, usize::MAX)
        .is_none());
    assert_eq!(kept(&flat_grid), "unavailable");
}
