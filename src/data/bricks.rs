//! Brick ranges: the range of node values any point of each 4×4×4 brick of nodes can read under
//! a filter, the unit of empty-space skipping.
//!
//! This file owns [`Bricks`] and their computation from a dataset's raw voxels (per dataset and
//! filter reach, once, in parallel). Not here: the skipping structures and decisions built from
//! the ranges (`accel`), and the finer per-cell test of one bound (the `cells` module's
//! [`CellMask`](super::CellMask)).

use super::{normaliser, Dataset, Filter, Voxels};

/// Nodes per side of a brick, the unit of empty-space skipping.
pub const BRICK: usize = 4;

/// The range of node values that any point of each brick can read under a filter: brick
/// (i, j, k) covers object coordinates of node indices [4i, 4i + 4] × …, and its range is taken
/// over every node the filter can reach from there, including from points a rounding error
/// outside it. Kept as the raw voxels' extremes (two bytes a brick for 8-bit voxels, four for
/// 16-bit) and normalised when read: the normalisation is monotone, so the normalised raw
/// extremes are the node values' extremes, the same f32 numbers.
#[derive(Clone, Debug)]
pub struct Bricks {
    /// Brick counts per axis.
    pub dims: [usize; 3],
    /// Smallest and largest raw voxel per brick, x fastest.
    raw: RawRanges,
    /// The smallest and largest raw voxel of the whole grid (every node lies in some brick's
    /// span).
    extremes: (f64, f64),
    /// The dataset's normalisation `(v − a)/(b − a)`, clamped to [0, 1].
    a: f32,
    b: f32,
}

/// The raw extremes of [`Bricks`], in the voxels' own type; 8-bit ones with the normalisation
/// of every byte (1 KiB).
#[derive(Clone, Debug)]
enum RawRanges {
    U8(Vec<u8>, Vec<u8>, Box<[f32; 256]>),
    U16(Vec<u16>, Vec<u16>),
}

impl Bricks {
    /// The smallest and largest raw voxel of the dataset, before its normalisation.
    pub(crate) fn raw_extremes(&self) -> (f64, f64) {
        self.extremes
    }

    /// The (min, max) of brick (i, j, k); indices are clamped to the grid.
    #[inline]
    pub fn get(&self, i: usize, j: usize, k: usize) -> (f32, f32) {
        let d = self.dims;
        let idx = i.min(d[0] - 1) + d[0] * (j.min(d[1] - 1) + d[1] * k.min(d[2] - 1));
        let (lo, hi) = match &self.raw {
            RawRanges::U8(lo, hi, norm) => (norm[lo[idx] as usize], norm[hi[idx] as usize]),
            RawRanges::U16(lo, hi) => {
                let norm = normaliser(self.a, self.b);
                (norm(lo[idx] as f64), norm(hi[idx] as f64))
            }
        };
        // (A decreasing normalisation, b < a, swaps the ends.)
        if self.b > self.a {
            (lo, hi)
        } else {
            (hi, lo)
        }
    }
}

/// Lowers each of `min` to the matching value of `lo` where that is smaller, and raises each of
/// `max` to the matching value of `hi` where that is larger (raw voxels: no NaN among them).
fn widen<T: Copy + PartialOrd>(min: &mut [T], max: &mut [T], lo: &[T], hi: &[T]) {
    // (As selects rather than conditional stores, so that they compile to lanes of minima and
    // maxima.)
    for (m, &x) in min.iter_mut().zip(lo) {
        *m = if x < *m { x } else { *m };
    }
    for (m, &x) in max.iter_mut().zip(hi) {
        *m = if x > *m { x } else { *m };
    }
}

impl Dataset {
    /// Computes now what a render with `filter` would compute on first use and keep (the brick
    /// ranges its empty-space grids are built from), so that a first frame does not pay for it;
    /// on the library's threads. It fails only with `NoMemory`: where those threads cannot be
    /// started, or the ranges (or their scratch rows) cannot be allocated; nothing is kept
    /// then, and a later call or render tries again.
    pub fn precompute(&self, filter: Filter) -> crate::error::Result<()> {
        crate::pool::install(|| {
            self.try_bricks(filter)?;
            Ok(())
        })
    }

    /// The brick ranges for `filter` (computed on first use, in parallel and holding no lock,
    /// [`crate::pool::try_once`]; then kept per dataset and reach, and shared).
    /// Where they cannot be allocated this unwinds ([`super::or_unwind`]);
    /// [`Dataset::try_bricks`] reports it instead.
    pub(crate) fn bricks(&self, filter: Filter) -> &Bricks {
        super::or_unwind(self.try_bricks(filter))
    }

    /// [`Dataset::bricks`], or `NoMemory` where they cannot be allocated (nothing is kept).
    pub(crate) fn try_bricks(&self, filter: Filter) -> crate::error::Result<&Bricks> {
        let reach = match filter {
            Filter::Nearest | Filter::Trilinear => 1,
            Filter::Cubic { .. } => 2,
        };
        crate::pool::try_once(&self.bricks[reach - 1], || self.compute_bricks(reach))
    }

    fn compute_bricks(&self, reach: usize) -> crate::error::Result<Bricks> {
        // Over the raw voxels (a quarter or half of the node values' memory, compared a byte
        // or two at a time), normalised when read ([`Bricks::get`]).
        // (Raw voxels are integers: no NaN among the extremes.)
        fn whole<T: Copy + Into<f64>>(lo: &[T], hi: &[T]) -> (f64, f64) {
            let lo = lo.iter().fold(f64::INFINITY, |m, &v| m.min(v.into()));
            let hi = hi.iter().fold(f64::NEG_INFINITY, |m, &v| m.max(v.into()));
            (lo, hi)
        }
        let (raw, extremes) = match &self.raw {
            Voxels::U8(v) => {
                let (lo, hi) = self.raw_brick_extremes(v, reach)?;
                let norm = normaliser(self.a, self.b);
                let extremes = whole(&lo, &hi);
                let table = Box::new(std::array::from_fn(|v| norm(v as f64)));
                (RawRanges::U8(lo, hi, table), extremes)
            }
            Voxels::U16(v) => {
                let (lo, hi) = self.raw_brick_extremes(v, reach)?;
                let extremes = whole(&lo, &hi);
                (RawRanges::U16(lo, hi), extremes)
            }
        };
        Ok(Bricks {
            dims: self.brick_counts(),
            raw,
            extremes,
            a: self.a,
            b: self.b,
        })
    }

    /// Bricks per axis.
    fn brick_counts(&self) -> [usize; 3] {
        self.dims
            .map(|n| (n.saturating_sub(1)).div_ceil(BRICK).max(1))
    }

    /// The smallest and largest raw voxel of each brick's padded span of nodes (see
    /// [`Bricks`]), x fastest, from the raw voxels `v`.
    fn raw_brick_extremes<T>(&self, v: &[T], reach: usize) -> crate::error::Result<(Vec<T>, Vec<T>)>
    where
        T: Copy + PartialOrd + Default + Send + Sync,
    {
        let d = self.dims;
        let counts = self.brick_counts();
        // Along each axis, a point of brick b has its continuous index u in [4b, 4b + 4], or a
        // rounding error outside. Trilinear (reach 1) reads nodes floor(u) and floor(u) + 1, so
        // [4b − 1, 4b + 5] covers u from just below 4b to just above 4b + 4; nearest reads
        // round(u), inside that; the cubic filter (reach 2) reads floor(u) − 1 … floor(u) + 2,
        // so [4b − 2, 4b + 6].
        let pad = reach;
        let span = |b: usize, n: usize| {
            let lo = (b * BRICK).saturating_sub(pad);
            let hi = (b * BRICK + BRICK + pad).min(n - 1);
            (lo, hi)
        };
        // Per plane of bricks (in parallel), separably: the extremes over the plane's slab of
        // nodes per (x, y) column, then over each brick row's span of y, then along x. Only
        // small scratch rows: a first image pays a page fault per 4 KiB of fresh memory, which
        // whole intermediate grids would pay over and over.
        use rayon::prelude::*;
        let [nx, ny, _] = d;
        let plane = counts[0] * counts[1];
        let zero = T::default();
        let what = "a dataset's brick ranges";
        let mut min = crate::num::try_vec(plane * counts[2], zero, what)?;
        let mut max = crate::num::try_vec(plane * counts[2], zero, what)?;
        let layer = |z: usize| &v[z * nx * ny..(z + 1) * nx * ny];
        min.par_chunks_mut(plane)
            .zip(max.par_chunks_mut(plane))
            .enumerate()
            .try_for_each_init(
                || {
                    let row = |n: usize| crate::num::try_vec(n, zero, "brick ranges' scratch rows");
                    Ok::<_, crate::error::Error>((row(nx * ny)?, row(nx * ny)?, row(nx)?, row(nx)?))
                },
                |scratch, (k, (min, max))| {
                    let (zmin, zmax, ymin, ymax) = scratch.as_mut().map_err(|e| e.clone())?;
                    let (z0, z1) = span(k, d[2]);
                    zmin.copy_from_slice(layer(z0));
                    zmax.copy_from_slice(layer(z0));
                    for z in z0 + 1..=z1 {
                        widen(zmin, zmax, layer(z), layer(z));
                    }
                    for bj in 0..counts[1] {
                        let (y0, y1) = span(bj, ny);
                        ymin.copy_from_slice(&zmin[y0 * nx..(y0 + 1) * nx]);
                        ymax.copy_from_slice(&zmax[y0 * nx..(y0 + 1) * nx]);
                        for y in y0 + 1..=y1 {
                            let r = y * nx..(y + 1) * nx;
                            widen(ymin, ymax, &zmin[r.clone()], &zmax[r]);
                        }
                        for bi in 0..counts[0] {
                            let (x0, x1) = span(bi, nx);
                            let (mut mn, mut mx) = (ymin[x0], ymax[x0]);
                            for (&lo, &hi) in ymin[x0..=x1].iter().zip(&ymax[x0..=x1]) {
                                if lo < mn {
                                    mn = lo;
                                }
                                if hi > mx {
                                    mx = hi;
                                }
                            }
                            min[bi + counts[0] * bj] = mn;
                            max[bi + counts[0] * bj] = mx;
                        }
                    }
                    Ok(())
                },
            )?;
        Ok((min, max))
    }
}
