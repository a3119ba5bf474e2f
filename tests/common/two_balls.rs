//! The two overlapping balls that the pre-integration and concurrency tests render: an n³ grid
//! of 8-bit values (a = 0, b = 255) falling linearly from 255 at each ball's centre to 0 at
//! its radius, the larger value where they overlap. Centres and radii are those of the 32³
//! grid, (10, 12, 14) r 9 and (21, 19, 17) r 8, scaled by n / 32. Included by
//! `#[path = "common/two_balls.rs"] mod two_balls;`.

use vlib::{Dataset, Voxels};

/// The balls in an n³ grid.
pub fn two_balls(n: usize) -> Dataset {
    let s = n as f32 / 32.0;
    let raw: Vec<u8> = (0..n * n * n)
        .map(|i| {
            let (x, y, z) = (i % n, (i / n) % n, i / (n * n));
            let ball = |c: [f32; 3], r: f32| {
                let d = ((x as f32 - c[0] * s).powi(2)
                    + (y as f32 - c[1] * s).powi(2)
                    + (z as f32 - c[2] * s).powi(2))
                .sqrt();
                (1.0 - d / (r * s)).clamp(0.0, 1.0)
            };
            let v = ball([10.0, 12.0, 14.0], 9.0).max(ball([21.0, 19.0, 17.0], 8.0));
            (v * 255.0) as u8
        })
        .collect();
    Dataset::new([n, n, n], Voxels::U8(raw), 0.0, 255.0).unwrap()
}
