//! Tests of the skip grid's construction: the distance map against brute force, the shell.

use super::*;

/// The distance map is, for every block, the chessboard (L∞) distance to the nearest
/// occupied block capped at `MAX_LEAP` (0 for an occupied block, `MAX_LEAP` where none is
/// nearer or there is none), checked by brute force over all pairs of blocks: grids with
/// axes of one block, long thin ones (lines longer than the cap and than rayon's minimum
/// share), empty, full and sparse ones; and the same map on one thread as on two.
#[test]
fn distance_map_is_the_capped_chessboard_distance() {
    let mut rng = Rng(0x5eed_c4e5);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut checked = 0usize;
    for case in 0..120 {
        let mut dims = [
            1 + (rng.next() * 12.0) as usize,
            1 + (rng.next() * 12.0) as usize,
            1 + (rng.next() * 12.0) as usize,
        ];
        if case % 5 == 0 {
            dims[case / 5 % 3] = 40 + (rng.next() * 30.0) as usize;
        }
        let fill = [0.0, 0.002, 0.02, 0.2, 0.9, 1.0][case % 6];
        let n: usize = dims.iter().product();
        let occupied: Vec<bool> = (0..n).map(|_| rng.next() < fill).collect();
        let start: Vec<u8> = occupied
            .iter()
            .map(|&o| if o { 0 } else { MAX_LEAP })
            .collect();
        let mut dist = start.clone();
        chessboard(&mut dist, dims);
        let mut alone = start;
        one.install(|| chessboard(&mut alone, dims));
        assert_eq!(dist, alone, "{dims:?}");
        let coords = |i: usize| [i % dims[0], i / dims[0] % dims[1], i / dims[0] / dims[1]];
        for (i, &d) in dist.iter().enumerate() {
            let a = coords(i);
            let want = (0..n)
                .filter(|&j| occupied[j])
                .map(|j| {
                    let b = coords(j);
                    (0..3).map(|k| a[k].abs_diff(b[k])).max().unwrap()
                })
                .min()
                .map_or(MAX_LEAP, |m| m.min(MAX_LEAP as usize) as u8);
            assert_eq!(d, want, "{dims:?} block {a:?}");
            checked += 1;
        }
    }
    assert!(checked > 50_000, "{checked}");
}

/// The shell is exactly the occupied blocks with an empty block or the outside among their
/// 26 neighbours (checked against signed neighbour coordinates).
#[test]
fn shell_is_the_occupied_blocks_with_an_open_neighbour() {
    let mut rng = Rng(0x5eed_0001);
    for fill in [0.0, 0.2, 0.6, 0.95, 1.0] {
        for _ in 0..20 {
            let g = random_grid(&mut rng, fill);
            let [nx, ny, nz] = g.dims.map(|n| n as i64);
            let occupied = |i: i64, j: i64, k: i64| {
                (0..nx).contains(&i)
                    && (0..ny).contains(&j)
                    && (0..nz).contains(&k)
                    && g.distance([i, j, k]) == 0
            };
            let mut want = Vec::new();
            for k in 0..nz {
                for j in 0..ny {
                    for i in 0..nx {
                        let open = (-1..=1).any(|c| {
                            (-1..=1).any(|b| (-1..=1).any(|a| !occupied(i + a, j + b, k + c)))
                        });
                        if occupied(i, j, k) && open {
                            want.push((i + nx * (j + ny * k)) as usize);
                        }
                    }
                }
            }
            let want: Vec<_> = want.into_iter().map(|i| g.block_box(i)).collect();
            let shell: Vec<_> = (0..g.shell.len()).map(|i| g.shell.corners(i)).collect();
            assert_eq!(shell, want, "fill {fill}");
        }
    }
}
