//! The unit tests of empty-space skipping, by module (`boxes`, `grid`, `passing`, `walk`, `entry`,
//! `rect`), and what they share: a deterministic generator, random grids, placements,
//! cameras and datasets, the slab test, and the tally of rays checked against an entry map.
//! Brute-force references live beside the tests that use them. Test code only.

mod boxes;
mod entry;
mod grid;
mod passing;
mod rect;
mod walk;

use super::entry::{EntryMap, EntryMarks, Mark, Pinhole, ENTRY_BIN, MAX_MAP_SIDE};
use super::grid::{chessboard, Boxes, SkipGrid, MAX_LEAP};
use super::passing::{passing_boxes, passing_groups_row, GroupCode, Passing};
use super::project::Projection;
use super::rect::lower_rect;
use super::walk::{block_index, outside, Walk};
use crate::data::{CellMask, Dataset, BRICK};
use glam::{DMat3, DMat4, DVec3};

/// A small deterministic generator (xorshift64*), uniform in [0, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A grid over the unit cube with the given occupied blocks (distance map as `build`
/// makes it).
fn grid_of(dims: [usize; 3], occupied: &[bool]) -> SkipGrid {
    let cell = DVec3::ONE / DVec3::from_array(dims.map(|n| n as f64));
    SkipGrid::of_occupied(dims, DVec3::ZERO, cell, occupied)
}

fn random_grid(rng: &mut Rng, fill: f64) -> SkipGrid {
    let dims = [
        5 + (rng.next() * 6.0) as usize,
        4 + (rng.next() * 6.0) as usize,
        6,
    ];
    let occupied: Vec<bool> = (0..dims.iter().product())
        .map(|_| rng.next() < fill)
        .collect();
    grid_of(dims, &occupied)
}

/// The parameter t ≥ 0 at which `o + t·d` enters the box (lo, hi) (slab test); ∞ if it
/// misses.
fn entry((lo, hi): (DVec3, DVec3), o: DVec3, d: DVec3) -> f64 {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        let (u, v) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
        t0 = t0.max(u.min(v));
        t1 = t1.min(u.max(v));
    }
    if t0 <= t1 {
        t0
    } else {
        f64::INFINITY
    }
}

/// A random object-to-world transform: scales of 20 to 40, any rotation, translations
/// up to 50.
fn random_placement(rng: &mut Rng) -> DMat4 {
    let angles = (rng.next() * 6.0, rng.next() * 6.0, rng.next() * 6.0);
    DMat4::from_scale_rotation_translation(
        DVec3::new(30.0, 20.0 + 20.0 * rng.next(), 25.0),
        glam::DQuat::from_euler(glam::EulerRot::XYZ, angles.0, angles.1, angles.2),
        DVec3::new(rng.next() * 100.0 - 50.0, 7.0, -3.0),
    )
}

/// Hits and bounds of rays checked against an entry map.
#[derive(Default)]
struct Tally {
    hits: usize,
    misses: usize,
    ratio: f64,
}

impl Tally {
    /// Checks `map` for the rays of `camera` through every pixel's centre, two corners and
    /// `random` random points: none meets what `first` finds (the parameter at which the
    /// object-space ray `o + t·d` first meets something that may hold opacity) before its
    /// pixel's bound, and none meets it at all where the bound is ∞.
    fn check(
        &mut self,
        rng: &mut Rng,
        (map, camera, to_world): (&EntryMap, &Pinhole, DMat4),
        random: usize,
        first: impl Fn(DVec3, DVec3) -> f64,
        case: usize,
    ) {
        let to_object = to_world.inverse();
        for py in 0..camera.height {
            for px in 0..camera.width {
                let bound = map.bound(px, py);
                let mut offsets = vec![(0.5, 0.5), (0.0, 0.0), (0.999_999, 0.999_999)];
                offsets.extend((0..random).map(|_| (rng.next(), rng.next())));
                for (dx, dy) in offsets {
                    let (x, y) = (px as f64 + dx, py as f64 + dy);
                    let dir = camera.ray(x, y);
                    let o = to_object.transform_point3(camera.eye);
                    let hit = first(o, to_object.transform_vector3(dir));
                    assert!(
                        bound <= hit,
                        "case {case} pixel ({px}, {py}) at ({x}, {y}): bound {bound} \
                         past the first hit at {hit}"
                    );
                    if hit.is_finite() {
                        self.hits += 1;
                        self.ratio += bound / hit;
                    } else if bound.is_infinite() {
                        self.misses += 1;
                    }
                }
            }
        }
    }

    /// The bounds were informative: background pixels exist, and a hit ray's bound is
    /// close to its hit (a pixel's bound is the nearest depth of any box whose rectangle
    /// meets it: 0.86 of the hit on average in these tests; a map that knew nothing would
    /// give 0).
    fn informative(&self) {
        assert!(
            self.hits > 1000 && self.misses > 1000,
            "{} hits, {} bare misses",
            self.hits,
            self.misses
        );
        let mean = self.ratio / self.hits as f64;
        assert!(mean > 0.75, "mean bound / hit {mean}");
    }
}

/// A camera `distance` from the centre of the object `to_world` places, looking at it
/// from direction `from`.
fn camera_at(to_world: DMat4, from: DVec3, distance: f64, size: u32) -> Pinhole {
    let centre = to_world.transform_point3(DVec3::splat(0.5));
    let eye = centre + from.normalize() * distance;
    let forward = (centre - eye).normalize();
    let right = DVec3::Z.cross(forward).normalize() * 0.4;
    let up = forward.cross(right).normalize() * 0.35;
    Pinhole {
        eye,
        forward,
        right,
        up,
        width: size,
        height: size - 3,
    }
}

/// A dataset of `dims` nodes, 8-bit, with a few random spheres of 255 in 0 (each node
/// 255 or 0).
fn spheres(rng: &mut Rng, dims: [usize; 3], count: usize) -> Dataset {
    let centres: Vec<(DVec3, f64)> = (0..count)
        .map(|_| {
            let c = DVec3::new(rng.next(), rng.next(), rng.next());
            (c, 0.05 + 0.2 * rng.next())
        })
        .collect();
    let mut raw = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = DVec3::new(i as f64, j as f64, k as f64)
                    / DVec3::from_array(dims.map(|n| (n - 1) as f64));
                let inside = centres.iter().any(|(c, r)| p.distance(*c) < *r);
                raw.push(if inside { 255u8 } else { 0 });
            }
        }
    }
    Dataset::new(dims, crate::data::Voxels::U8(raw), 0.0, 255.0).unwrap()
}

#[cfg(test)]
impl SkipGrid {
    /// A grid of `dims` blocks of size `cell` from `origin` whose blocks that may hold opacity
    /// are `occupied` (x fastest), with the distance map `build` makes.
    pub(crate) fn of_occupied(
        dims: [usize; 3],
        origin: DVec3,
        cell: DVec3,
        occupied: &[bool],
    ) -> SkipGrid {
        let mut dist: Vec<u8> = occupied
            .iter()
            .map(|&o| if o { 0 } else { MAX_LEAP })
            .collect();
        chessboard(&mut dist, dims);
        SkipGrid::new(dims, origin, cell, dist)
    }
}
