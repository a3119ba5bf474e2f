//! Tests of the datasets module: here the grid itself (node values, normalisation) and the
//! helpers every test file shares (a seeded generator, a linear field, random 8-bit grids); the
//! file format, the placement (geometry), the filters, the trilinear paths, the lanes, the
//! brick ranges and the cell masks in the files of those names. The plain versions the
//! specialised paths must agree with bit for bit (oracles) live in these files, not in the
//! module.

mod bricks;
mod cells;
mod filter;
mod format;
mod geometry;
mod gradient;
mod lanes;
mod trilinear;

use super::*;

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A point of [−0.2, 1.2]³: the unit box and a margin around it, where reads clamp.
    fn point_around_box(&mut self) -> [f32; 3] {
        std::array::from_fn(|_| (self.next() * 1.4 - 0.2) as f32)
    }
}

/// A 16-bit dataset whose raw values are the integer linear function 1000 + 7i + 300j + 20k
/// (no clamping: all within [0, 65535]), normalised by a = 0, b = 65535.
fn linear(dims: [usize; 3]) -> (Dataset, impl Fn([f64; 3]) -> f64) {
    let mut raw = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                raw.push((1000 + 7 * i + 300 * j + 20 * k) as u16);
            }
        }
    }
    let d = Dataset::new(dims, Voxels::U16(raw), 0.0, 65535.0).unwrap();
    let n = dims.map(|n| (n.max(2) - 1) as f64);
    let f = move |p: [f64; 3]| {
        let c = |x: f64, axis: usize| {
            if dims[axis] == 1 {
                0.0
            } else {
                x.clamp(0.0, 1.0) * n[axis]
            }
        };
        (1000.0 + 7.0 * c(p[0], 0) + 300.0 * c(p[1], 1) + 20.0 * c(p[2], 2)) / 65535.0
    };
    (d, f)
}

fn random_u8(dims: [usize; 3], seed: u64) -> Dataset {
    let mut rng = Lcg(seed);
    let n = dims.iter().product();
    let raw: Vec<u8> = (0..n).map(|_| (rng.next() * 256.0) as u8).collect();
    Dataset::new(dims, Voxels::U8(raw), 10.0, 240.0).unwrap()
}

/// `Dataset::new` refuses what `vlLoad` refuses in a header with the same codes (a dimension
/// of 0, one of more than 2³¹ − 1 nodes or more than 2³² voxels `BadDimensions`, before the
/// voxels are counted; a normalisation that is not finite or has
/// a = b `BadRange`), and voxels that disagree with the dimensions with `BadValue`.
#[test]
fn new_datasets_are_refused_with_the_codes_of_their_fault() {
    let u8s = |n: usize| Voxels::U8(vec![7; n]);
    let refused = |dims: [usize; 3], raw: Voxels, a: f32, b: f32| {
        Dataset::new(dims, raw, a, b).map(|_| ()).unwrap_err().code
    };
    for dims in [[0, 2, 2], [2, 0, 2], [2, 2, 0], [0, 0, 0]] {
        assert_eq!(
            refused(dims, u8s(0), 0.0, 1.0),
            ErrorCode::BadDimensions,
            "{dims:?}"
        );
    }
    let big = 1 << 16;
    for dims in [[big, big, 2], [usize::MAX, 2, 1], [big + 1, big, 1]] {
        assert_eq!(
            refused(dims, u8s(1), 0.0, 1.0),
            ErrorCode::BadDimensions,
            "{dims:?}"
        );
    }
    // An axis beyond an i32 (2³² along x is within MAX_VOXELS, and `save` could not write it
    // in a u32); 2³¹ − 1 passes the dimension check and meets the voxels' count.
    for dims in [[1 << 31, 1, 1], [1, 1 << 32, 1], [1, 1, (1 << 31) + 5]] {
        assert_eq!(
            refused(dims, u8s(1), 0.0, 1.0),
            ErrorCode::BadDimensions,
            "{dims:?}"
        );
    }
    assert_eq!(
        refused([i32::MAX as usize, 1, 1], u8s(1), 0.0, 1.0),
        ErrorCode::BadValue
    );
    for (a, b) in [
        (1.0, 1.0),
        (f32::NAN, 1.0),
        (0.0, f32::INFINITY),
        (f32::NEG_INFINITY, 0.0),
    ] {
        assert_eq!(
            refused([2, 2, 1], u8s(4), a, b),
            ErrorCode::BadRange,
            "{a} {b}"
        );
    }
    for n in [3, 5] {
        assert_eq!(
            refused([2, 2, 1], u8s(n), 0.0, 1.0),
            ErrorCode::BadValue,
            "{n}"
        );
    }
    let fits = Dataset::new([2, 2, 1], u8s(4), 255.0, 0.0).unwrap();
    assert_eq!((fits.dims(), fits.range()), ([2, 2, 1], (255.0, 0.0)));
}

/// `node` and `raw_node` read the node they name, and for a node outside the grid (one
/// coordinate past its axis, where i + nx·(j + ny·k) would name another node, or all of them)
/// panic with a message naming the call, the node and the grid, never reading another node.
#[test]
fn nodes_outside_the_grid_panic_instead_of_reading_another() {
    let dims = [2, 3, 2];
    let d = Dataset::new(
        dims,
        Voxels::U8((0..12).map(|v| 10 * v).collect()),
        0.0,
        255.0,
    )
    .unwrap();
    for k in 0..2 {
        for j in 0..3 {
            for i in 0..2 {
                let raw = 10 * (i + 2 * (j + 3 * k));
                assert_eq!(d.raw_node(i, j, k), raw as f64);
                assert_eq!(d.node(i, j, k), (raw as f64 / 255.0) as f32);
            }
        }
    }
    let outside = [
        [2, 0, 0],
        [0, 3, 0],
        [1, 0, 2],
        [usize::MAX, 0, 0],
        [0, 0, usize::MAX],
        [2, 3, 2],
    ];
    for [i, j, k] in outside {
        let reads: [(&str, &dyn Fn() -> f64); 2] = [
            ("node", &|| d.node(i, j, k) as f64),
            ("raw_node", &|| d.raw_node(i, j, k)),
        ];
        for (what, read) in reads {
            let panic = std::panic::catch_unwind(std::panic::AssertUnwindSafe(read))
                .expect_err(&format!("{what}({i}, {j}, {k}) read a node"));
            let message = panic.downcast_ref::<String>().map_or("", |s| s.as_str());
            assert_eq!(
                message,
                format!("Dataset::{what}: node ({i}, {j}, {k}) lies outside the 2×3×2 grid")
            );
        }
    }
}

/// Node values are made on first use, by any number of threads the same, and a node read
/// before then (from its voxel) is the node value made after: for 8- and 16-bit voxels,
/// normalisations that increase, decrease and clamp, sizes below and above a thread's
/// share (65 536 voxels).
#[test]
fn node_values_are_made_on_first_use_the_same_on_any_threads() {
    let mut rng = Lcg(99);
    for (case, dims) in [[7, 5, 3], [61, 47, 29], [2, 1, 1]].into_iter().enumerate() {
        let n: usize = dims.iter().product();
        for (a, b) in [(0.0, 255.0), (240.0, 10.0), (1000.0, 60000.0), (-5.0, 3.0)] {
            let raw = if case % 2 == 0 {
                Voxels::U8((0..n).map(|_| (rng.next() * 256.0) as u8).collect())
            } else {
                Voxels::U16((0..n).map(|_| (rng.next() * 65536.0) as u16).collect())
            };
            let d = Dataset::new(dims, raw, a, b).unwrap();
            assert!(!d.values_made());
            let norm = normaliser(a, b);
            let before: Vec<u32> = (0..n)
                .map(|at| {
                    let [i, j, k] = [
                        at % dims[0],
                        at / dims[0] % dims[1],
                        at / (dims[0] * dims[1]),
                    ];
                    d.node(i, j, k).to_bits()
                })
                .collect();
            assert!(!d.values_made(), "reading a node made the values");
            let want: Vec<u32> = (0..n).map(|at| norm(d.raw.get(at)).to_bits()).collect();
            assert_eq!(before, want);
            let made = |threads: usize| {
                let e = d.clone();
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| e.values().iter().map(|v| v.to_bits()).collect::<Vec<_>>())
            };
            assert_eq!(made(1), want);
            assert_eq!(made(3), want);
            // Where no thread of their own can start, the caller makes them all (two parts
            // for the largest case).
            let alone = d.clone();
            let made_alone = rayon::ThreadPoolBuilder::new()
                .num_threads(3)
                .build()
                .unwrap()
                .install(|| {
                    crate::pool::FAIL_SPAWNS.with(|f| f.set(true));
                    let v = alone
                        .values()
                        .iter()
                        .map(|v| v.to_bits())
                        .collect::<Vec<_>>();
                    crate::pool::FAIL_SPAWNS.with(|f| f.set(false));
                    v
                });
            assert_eq!(made_alone, want);
            assert_eq!(d.values().len(), n);
            assert!(d.values_made());
        }
    }
}

#[test]
fn normalisation_clamps() {
    let d = Dataset::new([3, 1, 1], Voxels::U8(vec![0, 100, 255]), 50.0, 150.0).unwrap();
    assert_eq!(d.values(), &[0.0, 0.5, 1.0]);
    // b < a inverts.
    let d = Dataset::new([2, 1, 1], Voxels::U8(vec![0, 255]), 255.0, 0.0).unwrap();
    assert_eq!(d.values(), &[1.0, 0.0]);
    // A dimension of 1 is constant along its axis.
    assert_eq!(d.sample([1.0, 0.3, 0.9], Filter::Trilinear), 0.0);
}

/// The caches a render asks a dataset for (brick ranges, cell masks, node values) are built
/// with parallel work; a thread of the pool waiting for its parts may meanwhile run another
/// task of the pool that asks for the same cache (another render sharing the dataset). That
/// must not wait for the build it sits inside: many tasks on one pool ask for every cache of
/// fresh datasets at once, and all of them finish, with the caches every thread count gives.
#[test]
fn caches_asked_for_while_being_built_on_the_same_pool_are_built() {
    // Every brick's range, as bits.
    fn ranges(b: &Bricks, dims: [usize; 3]) -> Vec<(u32, u32)> {
        let [nx, ny, nz] = dims.map(|n| (n - 1).div_ceil(BRICK));
        let at = |i| b.get(i % nx, i / nx % ny, i / (nx * ny));
        (0..nx * ny * nz)
            .map(|i| (at(i).0.to_bits(), at(i).1.to_bits()))
            .collect()
    }
    let (done, finished) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let mut rng = Lcg(7);
        for round in 0..40 {
            let dims = [40, 36, 150 + round];
            let n: usize = dims.iter().product();
            let raw = Voxels::U8((0..n).map(|_| (rng.next() * 256.0) as u8).collect());
            let d = Dataset::new(dims, raw, 0.0, 255.0).unwrap();
            let z = 0.3 + 0.01 * (round % 5) as f32;
            // Each from a thread of its own, as sessions render: each `install` is a task
            // that any thread of the pool may take, one waiting inside a build among them.
            let all: Vec<_> = std::thread::scope(|s| {
                let asks: Vec<_> = (0..8)
                    .map(|_| {
                        s.spawn(|| {
                            pool.install(|| {
                                let bricks = ranges(d.try_bricks(Filter::Trilinear).unwrap(), dims);
                                let mask = d.try_cells_above(z).unwrap().bits.clone();
                                (bricks, mask, d.values().len())
                            })
                        })
                    })
                    .collect();
                asks.into_iter().map(|a| a.join().unwrap()).collect()
            });
            // The same caches as one thread builds on a fresh copy.
            let e = Dataset::new(dims, d.raw.clone(), 0.0, 255.0).unwrap();
            let one = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap();
            let want = one.install(|| {
                let bricks = ranges(e.try_bricks(Filter::Trilinear).unwrap(), dims);
                (bricks, e.try_cells_above(z).unwrap().bits.clone(), n)
            });
            assert!(all.iter().all(|got| *got == want), "round {round}");
        }
        done.send(()).unwrap();
    });
    finished
        .recv_timeout(std::time::Duration::from_secs(60))
        .expect("every task asking for the caches finished");
}
