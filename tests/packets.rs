//! The packet march (`Optimise::packets`: eight primary rays in AVX2 lanes) against the scalar
//! march: random volumes, cameras far, grazing the box and inside it, several steps, with and
//! without skipping and termination, shaded and unshaded. Every pixel within a small
//! tolerance, none NaN or infinite, and the same bytes for one and two threads.
//!
//! The tolerance: the packet march takes exactly the scalar march's samples (its cursors) and
//! the same trilinear values (the scalar code's f32 operations), so the zero test and the cell
//! mask decide alike; it differs in the f32 rounding of the tables (slopes rounded to f32), the
//! opacity correction, the lighting (a normal from an f32 gradient, `rv^e` with e ≤ 12
//! multiplying a relative error by e) and the composite (a sum of up to a few hundred terms):
//! relative errors of about 10⁻⁶ per sample, 10⁻⁴ over a ray (measured: at most 4·10⁻⁷, root mean square 2·10⁻⁸). Where a ray's transmittance
//! lands within that of the termination bound, the two marches may stop one sample apart:
//! at most the bound (1/512) times a colour. So 1/255 (one 8-bit level) per channel, and a
//! root mean square far below it.

use vlib::dataset::{Dataset, Voxels};
use vlib::scene::Optimise;
use vlib::{Camera, Fields, Library, MappingType};

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A random volume of `dims` nodes: a few blobs and noise, 8-bit.
fn volume(rng: &mut Lcg, dims: [usize; 3]) -> Dataset {
    let blobs: Vec<([f64; 3], f64)> = (0..3)
        .map(|_| {
            (
                [rng.next(), rng.next(), rng.next()],
                0.15 + 0.3 * rng.next(),
            )
        })
        .collect();
    let mut raw = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = [
                    i as f64 / (dims[0] - 1) as f64,
                    j as f64 / (dims[1] - 1) as f64,
                    k as f64 / (dims[2] - 1) as f64,
                ];
                let v: f64 = blobs
                    .iter()
                    .map(|(c, r)| {
                        let d2: f64 = (0..3).map(|a| (p[a] - c[a]).powi(2)).sum();
                        (-d2 / (r * r)).exp()
                    })
                    .sum::<f64>()
                    + 0.15 * rng.next();
                raw.push((v.min(1.0) * 255.0).round() as u8);
            }
        }
    }
    Dataset::new(dims, Voxels::U8(raw), 0.0, 255.0).unwrap()
}

struct Case {
    dims: [usize; 3],
    seed: u64,
    eye: [f32; 3],
    at: [f32; 3],
    step: f32,
    shaded: bool,
    /// An opacity table of ten rows (more than the packet march holds in registers: its
    /// segment pairs are gathered per lane) instead of four.
    many_rows: bool,
    /// The volume turned about its centre (gradients to world space by a general matrix, not
    /// a diagonal one).
    turned: bool,
    optimise: Optimise,
}

/// The image of `case` (packets on or off) as f32 pixels, rendered on `threads` threads.
fn render(case: &Case, packets: bool, threads: usize) -> Vec<[f32; 3]> {
    let mut rng = Lcg(case.seed);
    let data = volume(&mut rng, case.dims);
    let mut vl = Library::new();
    vl.add_dataset(1, data).unwrap();
    // An opacity ramp that is 0 up to 0.3 (the zero test), a colour ramp.
    let opacity: &[f32] = if case.many_rows {
        &[
            0.3, 0.0, 0.38, 0.1, 0.45, 0.05, 0.52, 0.3, 0.6, 0.25, 0.67, 0.5, 0.74, 0.45, 0.8, 0.7,
            0.88, 0.65, 0.95, 0.9,
        ]
    } else {
        &[0.3, 0.0, 0.5, 0.2, 0.7, 0.6, 0.95, 0.9]
    };
    vl.mapping(1, MappingType::Ramp, opacity.len() as i32 / 2, 1, opacity)
        .unwrap();
    vl.mapping(
        2,
        MappingType::Ramp,
        3,
        3,
        &[0.25, 0.7, 0.3, 0.2, 0.5, 0.9, 0.7, 0.5, 0.8, 1.0, 0.95, 0.9],
    )
    .unwrap();
    vl.scene().unwrap();
    vl.set_optimise(Optimise {
        packets,
        ..case.optimise
    })
    .unwrap();
    vl.camera(&Camera {
        eye: case.eye,
        at: case.at,
        up: [0.0, 0.0, 1.0],
        fov: 40.0,
    })
    .unwrap();
    vl.background(0.1, 0.2, 0.3).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.directional_light([0.3, -1.0, 0.2], [1.0, 0.95, 0.9], 1.0)
        .unwrap();
    vl.step_size(case.step, 1.0).unwrap();
    vl.object().unwrap();
    let ext = case.dims.map(|n| (n - 1) as f32);
    if case.turned {
        vl.translate(ext[0] / 2.0, ext[1] / 2.0, ext[2] / 2.0)
            .unwrap();
        vl.rotate(20.0, -35.0, 10.0).unwrap();
        vl.translate(-ext[0] / 2.0, -ext[1] / 2.0, -ext[2] / 2.0)
            .unwrap();
    }
    vl.scale(ext[0], ext[1], ext[2]).unwrap();
    vl.dataset(Fields::F, 1).unwrap();
    vl.map(Fields::O, Fields::F, 1, 1).unwrap();
    vl.map(Fields::R, Fields::F, 2, 1).unwrap();
    vl.map(Fields::G, Fields::F, 2, 2).unwrap();
    vl.map(Fields::B, Fields::F, 2, 3).unwrap();
    if case.shaded {
        vl.set(Fields::KA, 0.2).unwrap();
        vl.set(Fields::KD, 0.7).unwrap();
        vl.set(Fields::KS, 0.3).unwrap();
        vl.set(Fields::N, vlib::types::specular_to_field(12.0))
            .unwrap();
    } else {
        vl.set(Fields::KA, 1.0).unwrap();
    }
    vl.end().unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let image = pool.install(|| vl.render_preview(48, 40, 1.2)).unwrap();
    (0..40)
        .flat_map(|y| (0..48).map(move |x| (x, y)))
        .map(|(x, y)| image.pixel(x, y))
        .collect()
}

fn cases() -> Vec<Case> {
    let mut rng = Lcg(7);
    let mut cases = Vec::new();
    for n in 0..24 {
        let dims = [
            4 + (rng.next() * 20.0) as usize,
            4 + (rng.next() * 20.0) as usize,
            4 + (rng.next() * 20.0) as usize,
        ];
        let centre = dims.map(|d| (d - 1) as f32 / 2.0);
        let size = dims.iter().map(|&d| d as f32).fold(0.0, f32::max);
        // Far, near (grazing the box: aimed at a corner), inside.
        let dir = [
            rng.next() as f32 - 0.5,
            rng.next() as f32 - 0.5,
            rng.next() as f32 - 0.5,
        ];
        let len = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2])
            .sqrt()
            .max(1e-3);
        let (eye, at) = match n % 3 {
            0 => (
                std::array::from_fn(|a| centre[a] + dir[a] / len * size * 2.0),
                centre,
            ),
            1 => (
                std::array::from_fn(|a| centre[a] + dir[a] / len * size * 1.2),
                [0.0, 0.0, (dims[2] - 1) as f32],
            ),
            _ => (
                std::array::from_fn(|a| centre[a] + dir[a] * 0.3 * dims[a] as f32),
                [centre[0] + 1.0, centre[1] - 2.0, centre[2] + 0.5],
            ),
        };
        let step = [0.5, 0.7, 1.0, 0.25, 2.0][n % 5];
        let optimise = Optimise {
            skip_empty: n % 4 != 1,
            early_termination: n % 4 != 2,
            ..Optimise::default()
        };
        cases.push(Case {
            dims,
            seed: 100 + n as u64,
            eye,
            at,
            step,
            shaded: n % 2 == 0,
            many_rows: n % 3 == 0,
            turned: n % 5 >= 3,
            optimise,
        });
    }
    cases
}

#[test]
#[cfg(target_arch = "x86_64")]
fn packets_are_the_scalar_march() {
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        eprintln!("no AVX2 and FMA: the packet march never runs here");
        return;
    }
    let (mut worst, mut sum, mut count, mut differ) = (0.0f32, 0.0f64, 0usize, 0usize);
    for (n, case) in cases().iter().enumerate() {
        let scalar = render(case, false, 1);
        let packets = render(case, true, 1);
        let two = render(case, true, 2);
        let bits = |v: &[[f32; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&packets),
            bits(&two),
            "case {n}: 1 and 2 threads differ"
        );
        if bits(&packets) != bits(&scalar) {
            differ += 1;
        }
        let shown = scalar
            .iter()
            .filter(|p| (p[0] - 0.1).abs() + (p[1] - 0.2).abs() + (p[2] - 0.3).abs() > 0.01)
            .count();
        eprintln!(
            "case {n}: {shown} of {} pixels show the volume",
            scalar.len()
        );
        for (p, s) in packets.iter().zip(&scalar) {
            for c in 0..3 {
                assert!(p[c].is_finite(), "case {n}: {p:?}");
                let d = (p[c] - s[c]).abs();
                assert!(d <= 1.0 / 255.0, "case {n}: {p:?} against {s:?}");
                worst = worst.max(d);
                sum += (d as f64).powi(2);
                count += 1;
            }
        }
    }
    let rms = (sum / count as f64).sqrt();
    eprintln!("packets against scalar: largest difference {worst}, rms {rms:e}");
    assert!(rms < 1e-5, "rms {rms}");
    // The packet march did run (its f32 arithmetic leaves some last bits apart).
    assert!(
        differ > 0,
        "no image differed: the packet march did not run"
    );
}

/// The packet march is on by default (where it applies and the processor has AVX2).
#[test]
fn packets_are_on_by_default() {
    assert!(Optimise::default().packets);
}
