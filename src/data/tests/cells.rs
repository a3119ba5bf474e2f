//! Tests of the cell masks: their bits against the cells' nodes brute-forced, across the
//! construction's runs of words, from raw voxels of both widths and either direction of
//! normalisation; packed flags; and masked trilinear values against the plain ones.

use super::super::cells::{pack_flags, CELL_MASK_MARGIN, CELL_MASK_RUN};
use super::lanes::values8;
use super::*;

/// A mask built a run of words at a time sets exactly the bits of the cells some node of
/// which lies above z − margin, and no bit of a node that starts no cell (the last node
/// of an axis): over grids of several runs whose rows straddle the runs' ends.
#[test]
fn cell_mask_bits_are_the_cells_above_the_bound_across_runs() {
    let mut rng = Lcg(11);
    for dims in [[67, 31, 33], [300, 250, 2], [4100, 17, 1]] {
        let n: usize = dims.iter().product();
        assert!(n > 64 * CELL_MASK_RUN, "{dims:?} spans several runs");
        let raw = (0..n).map(|_| (rng.next().powi(4) * 255.0) as u8).collect();
        let d = Dataset::new(dims, Voxels::U8(raw), 0.0, 255.0).unwrap();
        let z = 100.0 / 255.0;
        let mask = d.cells_above(z);
        let [nx, ny, nz] = dims;
        let (mut set, mut clear) = (0, 0);
        for c in 0..n {
            let (i, j, k) = (c % nx, c / nx % ny, c / (nx * ny));
            let starts = |x: usize, n: usize| n == 1 || x + 1 < n;
            let want = starts(i, nx) && starts(j, ny) && starts(k, nz) && {
                let at = |x: usize, s: usize, n: usize| (x + s).min(n - 1);
                (0..8).any(|e: usize| {
                    d.node(at(i, e & 1, nx), at(j, e >> 1 & 1, ny), at(k, e >> 2, nz))
                        > z - CELL_MASK_MARGIN
                })
            };
            assert_eq!(
                mask.bits[c >> 6] >> (c & 63) & 1 != 0,
                want,
                "{dims:?} node {c}"
            );
            if want {
                set += 1;
            } else {
                clear += 1;
            }
        }
        assert!(set > 0 && clear > 0, "{dims:?}: {set} set, {clear} clear");
        assert_eq!(mask.bits.len(), n.div_ceil(64));
        // Runs of cells as words: bit b is cell c + b's, also across words and past the
        // end (where every cell may reach).
        for c in (0..n + 70).step_by(13).chain(n - 3..n + 2) {
            for len in [1, 4, 5, 37, 63, 64] {
                let run = mask.run(c, len);
                for b in 0..64 {
                    let want = b < len && mask.may_reach(c + b);
                    assert_eq!(run >> b & 1 != 0, want, "{dims:?} run {c} {len} bit {b}");
                }
            }
        }
    }
}

/// Flags packed into a word are the word of their bits, for every length up to 64
/// (whole groups of eight and a shorter last one).
#[test]
fn packed_flags_are_their_bits() {
    let mut rng = Lcg(31);
    for len in 0..=64 {
        for _ in 0..20 {
            let flags: Vec<u8> = (0..len).map(|_| u8::from(rng.next() < 0.5)).collect();
            let want = flags
                .iter()
                .enumerate()
                .fold(0u64, |w, (b, &f)| w | u64::from(f) << b);
            assert_eq!(pack_flags(&flags), want, "{flags:?}");
        }
    }
}

/// Masks built from raw voxels are the node values' test: for 8- and 16-bit voxels,
/// normalisations that increase and decrease, clamped and not, bounds that some, none and
/// all cells pass, on a grid of several runs of words; each bit is brute-forced from the
/// node values.
#[test]
fn cell_masks_from_raw_voxels_are_the_node_values_test() {
    let mut rng = Lcg(23);
    let dims = [67, 31, 33];
    let n: usize = dims.iter().product();
    assert!(n > 64 * CELL_MASK_RUN);
    let bytes: Vec<u8> = (0..n).map(|_| (rng.next() * 256.0) as u8).collect();
    let shorts: Vec<u16> = (0..n).map(|_| (rng.next() * 65536.0) as u16).collect();
    let cases = [
        (Voxels::U8(bytes.clone()), (220.0, 10.0)),
        (Voxels::U8(bytes), (0.0, 255.0)),
        (Voxels::U16(shorts.clone()), (30000.0, 36000.0)),
        (Voxels::U16(shorts), (66000.0, -100.0)),
    ];
    for (raw, (a, b)) in cases {
        let d = Dataset::new(dims, raw, a, b).unwrap();
        let [nx, ny, nz] = dims;
        for z in [0.0, 0.3, 0.77, 0.999, 1.0, 2.0] {
            let mask = d.cells_above(z);
            let mut set = 0;
            for c in 0..n {
                let (i, j, k) = (c % nx, c / nx % ny, c / (nx * ny));
                let want = i + 1 < nx && j + 1 < ny && k + 1 < nz && {
                    (0..8).any(|e: usize| {
                        d.node(i + (e & 1), j + (e >> 1 & 1), k + (e >> 2)) > z - CELL_MASK_MARGIN
                    })
                };
                assert_eq!(mask.may_reach(c), want, "a {a} b {b} z {z} node {c}");
                set += usize::from(want);
            }
            let cells = (nx - 1) * (ny - 1) * (nz - 1);
            match z {
                0.0 => assert_eq!(set, cells, "a {a} b {b}: every cell"),
                2.0 => assert_eq!(set, 0, "a {a} b {b}: none"),
                _ => {}
            }
        }
    }
}

/// A cell mask clears exactly the cells whose nodes are all at most z − margin, and a
/// masked sample differs from the plain one only where both are at most z: over grids with
/// one node along an axis, 8- and 16-bit values crowding the bound, and random points.
#[test]
fn cell_masks_drop_only_samples_at_most_their_bound() {
    let mut rng = Lcg(7);
    for dims in [[6, 5, 7], [1, 6, 5], [5, 1, 1], [2, 2, 2], [9, 4, 1]] {
        let n = dims.iter().product::<usize>();
        let data8 = Dataset::new(
            dims,
            Voxels::U8(
                (0..n)
                    .map(|_| (30.0 + rng.next().powi(6) * 14.0) as u8)
                    .collect(),
            ),
            0.0,
            255.0,
        )
        .unwrap();
        let data16 = Dataset::new(
            dims,
            Voxels::U16((0..n).map(|_| (rng.next().powi(6) * 3.0) as u16).collect()),
            0.0,
            2.0,
        )
        .unwrap();
        for (d, z) in [(&data8, 40.0 / 255.0), (&data16, 0.5), (&data8, 0.0)] {
            let mask = d.cells_above(z);
            assert!(
                std::sync::Arc::ptr_eq(&mask, &d.cells_above(z)),
                "built once per bound"
            );
            let [nx, ny, nz] = d.dims;
            let (mut kept, mut dropped) = (0, 0);
            for k in 0..nz.saturating_sub(1).max(1) {
                for j in 0..ny.saturating_sub(1).max(1) {
                    for i in 0..nx.saturating_sub(1).max(1) {
                        let mut top = 0f32;
                        for (a, b, c) in (0..8).map(|c| (c & 1, c >> 1 & 1, c >> 2)) {
                            let at = |x: usize, s: usize, n: usize| (x + s).min(n - 1);
                            let v = d.node(at(i, a, nx), at(j, b, ny), at(k, c, nz));
                            top = top.max(v);
                        }
                        let c = i + nx * (j + ny * k);
                        assert_eq!(mask.may_reach(c), top > z - CELL_MASK_MARGIN, "{dims:?}");
                        if mask.may_reach(c) {
                            kept += 1;
                        } else {
                            dropped += 1;
                        }
                    }
                }
            }
            if z > 0.0 && n >= 30 {
                assert!(
                    kept > 0 && dropped > 0,
                    "{dims:?} z {z}: {kept} / {dropped}"
                );
            }
            for _ in 0..250 {
                let ps: [[f32; 3]; 8] = std::array::from_fn(|_| rng.point_around_box());
                let by_axis = std::array::from_fn(|axis| ps.map(|p| p[axis]));
                for count in [8, 5, 4, 3] {
                    // (`values8` starts from 1s: a rejected cell's value must be set to 0.)
                    let masked = values8(d, &by_axis, count, Some(&mask));
                    for (i, (p, masked)) in ps.into_iter().zip(masked).enumerate() {
                        let plain = d.trilinear(p);
                        if i >= count {
                            assert_eq!(masked.to_bits(), 0, "{dims:?} {p:?}");
                        } else if plain > z {
                            assert_eq!(plain.to_bits(), masked.to_bits(), "{dims:?} {p:?}");
                        } else {
                            assert!(masked == plain || masked == 0.0, "{dims:?} {p:?}");
                        }
                        // Exactly: the value where the cell may reach z, else 0.
                        let reach = mask.may_reach(d.node_index(d.cell32(p).0));
                        let want = if i < count && reach { plain } else { 0.0 };
                        assert_eq!(masked.to_bits(), want.to_bits(), "{dims:?} {p:?}");
                    }
                }
            }
        }
    }
}

/// The 32-bit words of a mask (the packet march's view) hold bit c of the cell with first node
/// c at bit `c & 31` of word `c >> 5`, for masks of every length, whatever the machine's byte
/// order (on little-endian machines they are the 64-bit words' own bytes).
#[test]
fn a_masks_32_bit_words_hold_its_bits() {
    let mut rng = Lcg(41);
    for words in [0usize, 1, 2, 3, 17] {
        let bits: Vec<u64> = (0..words)
            .map(|_| {
                (rng.next() * 2f64.powi(32)) as u64 | ((rng.next() * 2f64.powi(32)) as u64) << 32
            })
            .collect();
        let mask = CellMask::new(bits.clone());
        let w = mask.words32();
        assert_eq!(w.len(), 2 * words);
        for c in 0..64 * words {
            let want = bits[c >> 6] >> (c & 63) & 1;
            assert_eq!(
                (w[c >> 5] >> (c & 31) & 1) as u64,
                want,
                "{words} words, cell {c}"
            );
            assert_eq!(mask.may_reach(c), want == 1);
        }
    }
}

/// A dataset keeps the cell mask asked for last and those still held elsewhere (a scene's
/// compiled objects), not one per bound ever asked for: a bound asked for again while its mask
/// is in use gets that mask; a hundred bounds asked for one after another, each mask dropped,
/// leave one in use; a mask held elsewhere stays shared.
#[test]
fn cell_masks_are_kept_while_in_use_and_the_last_one() {
    let n = 4 * 4 * 4;
    let d = Dataset::new([4, 4, 4], Voxels::U8((0..n as u8).collect()), 0.0, 63.0).unwrap();
    let in_use = || d.cell_masks.lock().unwrap().in_use();
    let held = d.cells_above(0.5);
    assert!(std::sync::Arc::ptr_eq(&held, &d.cells_above(0.5)), "shared");
    for k in 0..100 {
        drop(d.cells_above(k as f32 / 100.0 + 0.001));
    }
    // The last bound's mask (the dataset holds it) and 0.5's (held here); the entries of the
    // masks dropped are pruned once they outnumber those kept (at most 8 entries then, and the
    // one filed after the prune).
    assert_eq!(in_use(), 2);
    assert!(d.cell_masks.lock().unwrap().entries() <= 9);
    assert!(
        std::sync::Arc::ptr_eq(&held, &d.cells_above(0.5)),
        "still shared"
    );
    drop(held);
    // 0.5's mask was asked for last: the dataset holds it alone now.
    assert_eq!(in_use(), 1);
    let again = d.cells_above(0.5);
    assert_eq!(
        std::sync::Arc::strong_count(&again),
        2,
        "the dataset's and this one"
    );
    // Each answer is its bound's: the mask of 0.5 passes the cells with a node above 0.5.
    let above = (0..n).filter(|&c| again.may_reach(c)).count();
    let fresh = Dataset::new([4, 4, 4], Voxels::U8((0..n as u8).collect()), 0.0, 63.0).unwrap();
    let want = fresh.cells_above(0.5);
    assert_eq!(above, (0..n).filter(|&c| want.may_reach(c)).count());
}
