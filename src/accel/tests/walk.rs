//! Tests of the walk: its arithmetic (the block index, the exit, the relocation and the bounds
//! test, each against the plain form it stands for, bit for bit) and its answers along a ray.

use super::*;

impl Walk {
    /// A copy of the walk (the walk itself is not `Clone`).
    fn clone_walk(&self) -> Walk {
        Walk { ..*self }
    }
}

/// The block index is the clamped floor, at block boundaries, just inside and outside the
/// grid, far away, at infinities and NaN.
#[test]
fn block_index_is_the_clamped_floor() {
    for last in [0.0, 1.0, 49.0] {
        let mut rels = vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -0.0,
            1e300,
            -1e300,
            last,
            last + 0.5,
            last + 1.0,
        ];
        for i in -300..=300 {
            let r = i as f64 / 4.0;
            rels.extend([r, r - 1e-12, r + 1e-12]);
        }
        for rel in rels {
            let want = if rel.is_nan() {
                0
            } else {
                rel.floor().clamp(0.0, last) as i64
            };
            assert_eq!(block_index(rel, last), want, "{rel} in [0, {last}]");
        }
    }
}

/// `Walk::exit` by comparisons equals the `f64::min` chain, bit for bit, on
/// every triple of awkward exits (±0, ±∞, NaN, subnormals, extremes) and random bits.
#[test]
fn exit_is_the_nan_aware_minimum() {
    let walk = |t_max: [f64; 3]| Walk {
        o: DVec3::ZERO,
        d: DVec3::X,
        inv_d: DVec3::X,
        cell: [0; 3],
        step: [0; 3],
        t_max,
        t_delta: [f64::INFINITY; 3],
        done: false,
        entry: 0.0,
    };
    let reference = |t: [f64; 3]| {
        std::hint::black_box(t[0])
            .min(std::hint::black_box(t[1]))
            .min(std::hint::black_box(t[2]))
    };
    let mut vals = vec![
        0.0,
        -0.0,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        -f64::NAN,
        f64::from_bits(1),
        -f64::from_bits(1),
        f64::MIN_POSITIVE,
        f64::MAX,
        f64::MIN,
        1.0,
        -1.0,
        2.5,
    ];
    let rng = crate::testing::Xorshift::new(0x9e37_79b9_7f4a_7c15u64);
    vals.extend((0..20).map(|_| f64::from_bits(rng.bits())));
    for &a in &vals {
        for &b in &vals {
            for &c in &vals {
                let t = [a, b, c];
                let got = std::hint::black_box(walk(t)).exit();
                assert_eq!(got.to_bits(), reference(t).to_bits(), "{t:?}");
            }
        }
    }
}

/// `Walk::relocate` without the bounds test on unforced axes (`block_index` clamps into
/// the grid) leaves the walk as the bounds-checked form does, bit for bit, at awkward
/// parameters and points (outside the grid, ±0, ±∞, NaN, subnormal and zero direction parts)
/// and with forced indices in and out of the grid (NaN exits as NaN, whatever their bits).
#[test]
fn relocate_is_the_bounds_checked_relocate() {
    fn reference(w: &mut Walk, grid: &SkipGrid, t0: f64, forced: [Option<i64>; 3]) {
        let p = w.o + t0 * w.d;
        for axis in 0..3 {
            let c = match forced[axis] {
                Some(c) => c,
                None => {
                    let rel = (p[axis] - grid.origin[axis]) * grid.inv_cell[axis];
                    block_index(rel, grid.last[axis])
                }
            };
            if c < 0 || c >= grid.dims[axis] as i64 {
                w.done = true;
                return;
            }
            w.cell[axis] = c;
            let size = grid.cell[axis];
            let (d, inv) = (w.d[axis], w.inv_d[axis]);
            if d > 0.0 {
                let boundary = grid.origin[axis] + (c + 1) as f64 * size;
                w.t_max[axis] = t0 + (boundary - p[axis]) * inv;
            } else if d < 0.0 {
                let boundary = grid.origin[axis] + c as f64 * size;
                w.t_max[axis] = t0 + (boundary - p[axis]) * inv;
            }
        }
    }
    // A NaN's sign and payload follow the operand order the compiler picks for the
    // arithmetic (x86 keeps the first NaN operand's), not the code: NaNs compare as one.
    let bits = |t: f64| {
        if t.is_nan() {
            f64::NAN.to_bits()
        } else {
            t.to_bits()
        }
    };
    let state = |w: &Walk| (w.cell, w.t_max.map(bits), w.done, w.entry.to_bits());
    let grid = grid_of([5, 4, 3], &[false; 60]);
    let parts = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.3,
        -0.7,
        f64::from_bits(1),
        -f64::from_bits(1),
        1e300,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
    ];
    let ts = [0.0, -0.0, 0.25, 1.0, -3.0, 1e300, f64::INFINITY, f64::NAN];
    let forceds = [
        [None, None, None],
        [Some(4), None, None],
        [None, Some(-1), None],
        [None, None, Some(3)],
        [Some(5), Some(0), None],
    ];
    let mut n = 0;
    for &ox in &parts {
        for &dx in &parts {
            for &dy in &parts {
                let o = DVec3::new(ox, 0.4, -0.2);
                let d = DVec3::new(dx, dy, 0.5);
                let mut slot = None;
                let start = grid.walk_into(&mut slot, o, d, 0.0);
                for &t0 in &ts {
                    for forced in forceds {
                        let (mut a, mut b) = (start.clone_walk(), start.clone_walk());
                        a.relocate(&grid, t0, forced);
                        reference(&mut b, &grid, t0, forced);
                        assert_eq!(state(&a), state(&b), "{o} {d} {t0} {forced:?}");
                        n += 1;
                    }
                }
            }
        }
    }
    assert!(n > 0);
}

/// `outside` is the two-sided bounds test, at and around 0, the grid's size
/// and the ends of i64.
#[test]
fn outside_is_the_two_sided_bounds_test() {
    for dims in [1usize, 2, 5, 255, 1 << 20] {
        let d = dims as i64;
        for c in [
            i64::MIN,
            i64::MIN + 1,
            -d - 1,
            -d,
            -2,
            -1,
            0,
            1,
            d - 1,
            d,
            d + 1,
        ]
        .into_iter()
        .chain([2 * d, i64::MAX - 1, i64::MAX])
        {
            assert_eq!(outside(c, dims), c < 0 || c >= d, "{c} in 0..{dims}");
        }
    }
}

/// `skip_until`'s answers hold along the ray, whether the questions come sample by sample or
/// far apart, as the packet march asks after runs it passed over itself (where the walk moves
/// to the question's block at once), each past the blocks the last answer covered, as the
/// callers ask, with and without a horizon: `Ok(exit)` where the blocks
/// from the question to `exit` are all empty, `Err(until)` where those up to `until` are all
/// occupied. Checked at points of the ray between, in random grids and directions, by the
/// block each point lies in (points within 10⁻⁹ of a block face, where rounding may place
/// them either side, and points outside the grid, which a walk that has left it calls
/// occupied, are not checked).
#[test]
fn skip_until_answers_hold_along_the_ray() {
    let mut rng = Rng(0x5eed_0fb1_0c0f);
    let mut checked = [0usize; 2];
    for case in 0..400 {
        let grid = random_grid(&mut rng, [0.05, 0.2, 0.5][case % 3]);
        let o = DVec3::new(rng.next(), rng.next(), rng.next()) * 1.4 - 0.2;
        let d = (DVec3::new(rng.next(), rng.next(), rng.next()) * 2.0 - 1.0).normalize_or_zero();
        if d == DVec3::ZERO {
            continue;
        }
        // The block a point lies in, `None` near a face or outside the grid.
        let block = |t: f64| -> Option<[i64; 3]> {
            let p = o + t * d;
            let mut c = [0i64; 3];
            for a in 0..3 {
                let rel = (p[a] - grid.origin[a]) * grid.inv_cell[a];
                if !(rel >= 0.0 && rel < grid.dims[a] as f64) || (rel - rel.round()).abs() < 1e-9 {
                    return None;
                }
                c[a] = rel as i64;
            }
            Some(c)
        };
        let check = |from: f64, to: f64, empty: bool, checked: &mut [usize; 2]| {
            let to = to.min(from + 4.0);
            for i in 0..64 {
                let t = from + (to - from) * (i as f64 + 0.5) / 64.0;
                if let Some(c) = block(t) {
                    assert_eq!(
                        grid.distance(c) != 0,
                        empty,
                        "case {case}: {o} + t·{d}, t = {t} in block {c:?}, asked from {from} to {to}"
                    );
                    checked[empty as usize] += 1;
                }
            }
        };
        let mut slot = None;
        let walk = grid.walk_into(&mut slot, o, d, 0.0);
        let mut t = 0.0;
        while t < 3.0 {
            // Some questions a sample apart, some many blocks apart.
            t += if rng.next() < 0.5 {
                0.02
            } else {
                0.3 * rng.next()
            };
            let horizon = if rng.next() < 0.5 {
                t
            } else {
                t + 0.2 * rng.next()
            };
            match walk.skip_until(&grid, t, horizon) {
                Ok(exit) => {
                    assert!(exit >= t, "case {case}: exit {exit} before {t}");
                    check(t, exit, true, &mut checked);
                    t = exit;
                }
                Err(until) => {
                    assert!(
                        until >= t,
                        "case {case}: occupied until {until}, before {t}"
                    );
                    check(t, until, false, &mut checked);
                    // (As the callers do, the next question is past the occupied blocks.)
                    t = until;
                }
            }
        }
    }
    assert!(checked[0] > 10_000 && checked[1] > 10_000, "{checked:?}");
}
