//! The packet march (`Optimise::packets`: primary rays eight at a time in AVX2 lanes, or sixteen
//! in AVX-512 lanes, `Optimise::wide_lanes`) against the scalar march and the two widths against
//! each other: random volumes, cameras far, grazing the box and inside it, several steps (each
//! exponent the packet march corrects opacity for by square roots and products, and one it
//! takes as a power in f64 lanes), with and
//! without skipping and termination, shaded and unshaded, and (as property tests with a fixed
//! seed) the hard cases of issue #7 for scanned volumes. Every pixel within a small
//! tolerance, none NaN or infinite, and the same bytes for one and two threads.
//!
//! The tolerance: the packet march takes exactly the scalar march's samples (its cursors) and,
//! from node values, the same trilinear values (the scalar code's f32 operations), so the zero
//! test and the cell mask decide alike; from 8-bit voxels whose normalisation never clamps it
//! interpolates the voxels and normalises once, a relative 10⁻⁷ from the node values' rounding (a
//! sample that close to the zero test's bound has an opacity that close to 0). It differs in the
//! f32 rounding of the tables (slopes rounded to f32), the opacity correction, the lighting (a
//! normal from an f32 gradient, from 8- and 16-bit voxels from their integer differences, which
//! the scalar march takes as differences of rounded node values: a relative 4·10⁻³ for 16-bit
//! neighbours one unit apart, only where the gradient is that small; `rv^e` with e ≤ 12
//! multiplying a relative error by e) and the composite (a sum of up to a few hundred terms;
//! at most 2¹⁴, past which the scalar march traces the rays, `dev/simd.md`):
//! relative errors of about 10⁻⁶ per sample, 10⁻⁴ over a ray (measured: at most 4·10⁻⁷, root
//! mean square 2·10⁻⁸). Where a ray's transmittance lands within that of the termination bound,
//! the two marches may stop one sample apart: at most the bound (1/512) times a colour. So 1/255
//! (one 8-bit level) per channel, and a root mean square far below it.

use vlib::Optimise;
use vlib::{Camera, Feature, Fields, Library, MappingType};
use vlib::{Dataset, Voxels};
use vlib::{DatasetId, MappingId};

#[path = "common/lcg.rs"]
mod lcg;
use lcg::Lcg;

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

/// A volume of hard-edged boxes of `dims` nodes: a few solid boxes (values 200 to 255) of one
/// to six nodes a side on noise below the opacity table's zero (under 60 of 255). Where the
/// blobs of [`volume`] rise over several nodes, these boxes start at a node next to empty
/// ones, so a march that skips one sample too many where empty space ends misses them.
fn hard_volume(rng: &mut Lcg, dims: [usize; 3]) -> Dataset {
    let boxes: Vec<([usize; 3], [usize; 3], u8)> = (0..4)
        .map(|_| {
            let lo: [usize; 3] = std::array::from_fn(|a| (rng.next() * dims[a] as f64) as usize);
            let hi = std::array::from_fn(|a| lo[a] + 1 + (rng.next() * 6.0) as usize);
            (lo, hi, 200 + (rng.next() * 55.0) as u8)
        })
        .collect();
    let mut raw = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let inside = boxes.iter().find(|(lo, hi, _)| {
                    [i, j, k]
                        .iter()
                        .enumerate()
                        .all(|(a, &x)| lo[a] <= x && x < hi[a])
                });
                raw.push(match inside {
                    Some((_, _, v)) => *v,
                    None => (rng.next() * 60.0) as u8,
                });
            }
        }
    }
    Dataset::new(dims, Voxels::U8(raw), 0.0, 255.0).unwrap()
}

struct Case {
    dims: [usize; 3],
    /// Hard-edged boxes ([`hard_volume`]) instead of blobs.
    hard: bool,
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
    /// Normals flipped towards the eye (`Feature::FlipNormals`).
    flip: bool,
    optimise: Optimise,
}

/// The direct-shading program both tests give their object: dataset 1 into F, table 1 into
/// opacity, table 2's three columns into r, g and b; lit with coefficients `[ka, kd, ks]`, or
/// unlit (ka 1 alone).
fn colour_program(vl: &mut Library, lit: Option<[f32; 3]>) {
    vl.dataset(Fields::F, DatasetId(1)).unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    vl.map(Fields::R, Fields::F, MappingId(2), 1).unwrap();
    vl.map(Fields::G, Fields::F, MappingId(2), 2).unwrap();
    vl.map(Fields::B, Fields::F, MappingId(2), 3).unwrap();
    match lit {
        Some([ka, kd, ks]) => {
            vl.set(Fields::KA, ka).unwrap();
            vl.set(Fields::KD, kd).unwrap();
            vl.set(Fields::KS, ks).unwrap();
        }
        None => vl.set(Fields::KA, 1.0).unwrap(),
    }
}

/// `render` run on a pool of `threads` threads.
fn on_threads<T: Send>(threads: usize, render: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(render)
}

/// Whether this processor lacks what the packet march needs (AVX2 and FMA), said on standard
/// error: a test of the packet march then has nothing to compare and returns.
#[cfg(target_arch = "x86_64")]
fn no_packet_march() -> bool {
    let none = !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"));
    if none {
        eprintln!("no AVX2 and FMA: the packet march never runs here");
    }
    none
}

/// The tests' image size.
const W: u32 = 48;
const H: u32 = 40;

/// The image of `case` (packets on or off) as f32 pixels, rendered on `threads` threads.
fn render(case: &Case, packets: bool, threads: usize) -> Vec<[f32; 3]> {
    render_made(case, packets, threads).0
}

/// [`render`], and whether the render made the dataset's node values.
fn render_made(case: &Case, packets: bool, threads: usize) -> (Vec<[f32; 3]>, bool) {
    render_made_as(case, packets, threads, false)
}

/// [`render_made`], of the case's volume as 16-bit voxels (v · 257, normalised from 0 to
/// 65535: the same values to within f32 rounding) where `sixteen`.
fn render_made_as(
    case: &Case,
    packets: bool,
    threads: usize,
    sixteen: bool,
) -> (Vec<[f32; 3]>, bool) {
    let vl = library(case, packets, sixteen);
    let image = on_threads(threads, || vl.render_preview(W, H, 1.2)).unwrap();
    let pixels = (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|(x, y)| image.pixel(x, y))
        .collect();
    (pixels, vl.dataset_of(DatasetId(1)).unwrap().values_made())
}

/// The scene of `case` (packets on or off; 16-bit voxels where `sixteen`, as
/// [`render_made_as`] renders it).
fn library(case: &Case, packets: bool, sixteen: bool) -> Library {
    let mut rng = Lcg(case.seed);
    let data = if case.hard {
        hard_volume(&mut rng, case.dims)
    } else {
        volume(&mut rng, case.dims)
    };
    let data = match data.raw() {
        Voxels::U8(v) if sixteen => Dataset::new(
            data.dims(),
            Voxels::U16(v.iter().map(|&x| x as u16 * 257).collect()),
            0.0,
            65535.0,
        )
        .unwrap(),
        _ => data,
    };
    let mut vl = Library::new();
    vl.add_dataset(DatasetId(1), data).unwrap();
    // An opacity ramp that is 0 up to 0.3 (the zero test), a colour ramp.
    let opacity: &[f32] = if case.many_rows {
        &[
            0.3, 0.0, 0.38, 0.1, 0.45, 0.05, 0.52, 0.3, 0.6, 0.25, 0.67, 0.5, 0.74, 0.45, 0.8, 0.7,
            0.88, 0.65, 0.95, 0.9,
        ]
    } else {
        &[0.3, 0.0, 0.5, 0.2, 0.7, 0.6, 0.95, 0.9]
    };
    vl.mapping(
        MappingId(1),
        MappingType::Ramp,
        opacity.len() as i32 / 2,
        1,
        opacity,
    )
    .unwrap();
    vl.mapping(
        MappingId(2),
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
    vl.toggle(Feature::FlipNormals, case.flip).unwrap();
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
    colour_program(&mut vl, case.shaded.then_some([0.2, 0.7, 0.3]));
    if case.shaded {
        vl.set(Fields::N, vlib::types::specular_to_field(12.0))
            .unwrap();
    }
    vl.end().unwrap();
    vl
}

/// Whether pixel `p` shows the volume: it differs from the backdrop (0.1, 0.2, 0.3) of
/// [`render_made_as`]'s scenes.
fn shows_volume(p: &[f32; 3]) -> bool {
    (p[0] - 0.1).abs() + (p[1] - 0.2).abs() + (p[2] - 0.3).abs() > 0.01
}

fn cases() -> Vec<Case> {
    let mut rng = Lcg(7);
    let mut cases = Vec::new();
    for n in 0..36 {
        // The last twelve: hard-edged boxes in larger volumes (more blocks to leap over).
        let hard = n >= 24;
        let (least, spread) = if hard { (12.0, 28.0) } else { (4.0, 20.0) };
        let dims = [
            (least + rng.next() * spread) as usize,
            (least + rng.next() * spread) as usize,
            (least + rng.next() * spread) as usize,
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
        let step = [0.5, 0.7, 1.0, 0.25, 2.0, 0.125, 4.0][n % 7];
        let optimise = Optimise {
            skip_empty: n % 4 != 1,
            early_termination: n % 4 != 2,
            ..Optimise::default()
        };
        cases.push(Case {
            dims,
            hard,
            seed: 100 + n as u64,
            eye,
            at,
            step,
            shaded: n % 2 == 0,
            many_rows: n % 3 == 0,
            turned: n % 5 >= 3,
            flip: n % 4 == 0,
            optimise,
        });
    }
    cases
}

#[test]
#[cfg(target_arch = "x86_64")]
fn packets_are_the_scalar_march() {
    if no_packet_march() {
        return;
    }
    if !is_x86_feature_detected!("avx512f") {
        eprintln!("no AVX-512: sixteen lanes never run here, the wide and narrow images are one");
    }
    let (mut worst, mut sum, mut count, mut differ) = (0.0f32, 0.0f64, 0usize, 0usize);
    for (n, case) in cases().iter().enumerate() {
        let scalar = render(case, false, 1);
        let packets = render(case, true, 1);
        let two = render(case, true, 2);
        let narrow = render(
            &Case {
                optimise: Optimise {
                    wide_lanes: false,
                    ..case.optimise
                },
                ..*case
            },
            true,
            1,
        );
        // Every run tested against the cell mask, none taken on trust.
        let tested = render(
            &Case {
                optimise: Optimise {
                    trust_whole_runs: false,
                    ..case.optimise
                },
                ..*case
            },
            true,
            1,
        );
        let bits = |v: &[[f32; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&packets),
            bits(&two),
            "case {n}: 1 and 2 threads differ"
        );
        assert_eq!(
            bits(&packets),
            bits(&tested),
            "case {n}: runs taken on trust change the image"
        );
        assert_eq!(
            bits(&packets),
            bits(&narrow),
            "case {n}: sixteen and eight lanes differ"
        );
        if bits(&packets) != bits(&scalar) {
            differ += 1;
        }
        let shown = scalar.iter().filter(|p| shows_volume(p)).count();
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

/// The packet march of 8-bit voxels normalised from 0 to 255 reads the voxels, and leaves
/// the node values unmade (a scan's first image does not pay for them), in every case of
/// `packets_are_the_scalar_march` with skipping on, many of which show the volume; so does
/// the scalar march, which reads a cell's voxels through the table of their normalisation
/// (its values and gradients, the node values' bits) while the node values are not made.
#[test]
#[cfg(target_arch = "x86_64")]
fn packets_of_bytes_leave_the_node_values_unmade() {
    if no_packet_march() {
        return;
    }
    let mut shown = 0;
    for case in cases().iter().filter(|c| c.optimise.skip_empty) {
        let (pixels, made) = render_made(case, true, 2);
        assert!(!made, "{:?}", case.dims);
        assert!(!render_made(case, false, 2).1, "{:?}", case.dims);
        shown += pixels.iter().any(shows_volume) as usize;
    }
    assert!(shown >= 10, "{shown}");
}

/// The pre-integrated packet march of 8-bit voxels reads them for its values (the lanes' and
/// the slabs' own reads) and for its normals (the trilinear gradient through the table of the
/// voxels' normalisation), and leaves the node values unmade, in every case of
/// `packets_are_the_scalar_march` with skipping on.
#[test]
#[cfg(target_arch = "x86_64")]
fn preintegrated_packets_of_bytes_leave_the_node_values_unmade() {
    if no_packet_march() {
        return;
    }
    let mut shown = 0;
    for case in cases().iter().filter(|c| c.optimise.skip_empty) {
        let case = Case {
            optimise: Optimise {
                preintegrate: true,
                ..case.optimise
            },
            ..*case
        };
        let (pixels, made) = render_made(&case, true, 2);
        assert!(!made, "{:?}", case.dims);
        shown += pixels.iter().any(shows_volume) as usize;
    }
    assert!(shown >= 10, "{shown}");
}

/// The packet march of 16-bit voxels reads them (normalised in lanes where that gives the node
/// values' bits, else through their table of node values) and leaves the node values unmade,
/// in every case of `packets_are_the_scalar_march` with skipping on
/// (its volumes as 16-bit voxels), within one 8-bit level of the scalar march (the tolerance
/// of `packets_are_the_scalar_march`), which leaves them unmade too; in sixteen
/// lanes (where the processor has AVX-512) the image of eight, bit for bit.
#[test]
#[cfg(target_arch = "x86_64")]
fn packets_of_16_bit_voxels_leave_the_node_values_unmade() {
    if no_packet_march() {
        return;
    }
    let mut shown = 0;
    for case in cases().iter().filter(|c| c.optimise.skip_empty) {
        let (pixels, made) = render_made_as(case, true, 2, true);
        assert!(!made, "{:?}", case.dims);
        let eight = Case {
            optimise: Optimise {
                wide_lanes: false,
                ..case.optimise
            },
            ..*case
        };
        let (narrow, _) = render_made_as(&eight, true, 2, true);
        let bits = |v: &[[f32; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&pixels), bits(&narrow), "{:?}", case.dims);
        let (scalar, scalar_made) = render_made_as(case, false, 2, true);
        for (p, s) in pixels.iter().zip(&scalar) {
            for c in 0..3 {
                assert!((p[c] - s[c]).abs() <= 1.0 / 255.0, "{p:?} against {s:?}");
            }
        }
        assert!(!scalar_made, "{:?}", case.dims);
        shown += scalar.iter().any(shows_volume) as usize;
    }
    assert!(shown >= 10, "{shown}");
}

/// The packet march is on by default (where it applies and the processor has AVX2).
#[test]
fn packets_are_on_by_default() {
    assert!(Optimise::default().packets);
}

/// Hard cases for the packet march (the stability suite's `tests/stability.rs` scenes are field
/// functions, which the packet march never traces): scanned volumes of 8- and 16-bit voxels with
/// normalisations at the extremes, absurd and near-singular transforms, steps from 10⁻⁴ to 10⁶
/// of the volume's size with extreme opacity references, cameras inside the volume, opacity
/// tables with a_1 = 0 or a_n = 1, shaded and unshaded. Every pixel is finite and in [0, 1],
/// the same bytes on one and two threads, and within one 8-bit level of the scalar march's
/// (the argument of the module's tolerance holds for any ray: f32 rounding of at most about
/// 10⁻⁴ over thousands of samples, a termination one sample apart).
#[test]
#[cfg(target_arch = "x86_64")]
fn hostile_scanned_scenes_stay_finite_and_near_the_scalar_march() {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    if no_packet_march() {
        return;
    }
    let scale = prop_oneof![4 => 0.1f32..100.0, 1 => 1e-4f32..1e-2, 1 => 1e3f32..1e5];
    let strategy = (
        (
            [4usize..9, 4usize..9, 4usize..9],
            any::<u64>(),
            0u8..6,
            [scale.clone(), scale.clone(), scale],
            [-360f32..360.0, -360f32..360.0, -360f32..360.0],
        ),
        (
            -4.0f32..6.0,
            -6.0f32..6.0,
            [-3f32..3.0, -3f32..3.0, -3f32..3.0],
            (any::<bool>(), any::<bool>()),
            any::<bool>(),
            [-1f32..1.0, -1f32..1.0, -1f32..1.0],
        ),
    );
    let config = Config {
        cases: 1500,
        failure_persistence: None,
        ..Config::default()
    };
    let mut runner =
        TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &[23; 32]));
    let ran = std::sync::atomic::AtomicUsize::new(0);
    runner
        .run(
            &strategy,
            |(
                (dims, seed, voxels, scale, rotate),
                (step_rel, ref_rel, eye, ends, shaded, light),
            )| {
                let n: usize = dims.iter().product();
                let mut rng = Lcg(seed);
                // 8- or 16-bit voxels, with normalisations at the extremes of a and b.
                let data = match voxels {
                    0 => Dataset::new(
                        dims,
                        Voxels::U8((0..n).map(|_| (rng.next() * 256.0) as u8).collect()),
                        0.0,
                        255.0,
                    ),
                    1 => Dataset::new(
                        dims,
                        Voxels::U16((0..n).map(|_| (rng.next() * 65536.0) as u16).collect()),
                        0.0,
                        65535.0,
                    ),
                    2 => Dataset::new(
                        dims,
                        Voxels::U16((0..n).map(|_| (rng.next() * 65536.0) as u16).collect()),
                        -1e30,
                        1e30,
                    ),
                    // Decreasing over every voxel: the gradient's integer differences scaled
                    // by a negative slope.
                    3 => Dataset::new(
                        dims,
                        Voxels::U16((0..n).map(|_| (rng.next() * 65536.0) as u16).collect()),
                        65535.0,
                        0.0,
                    ),
                    // Clamping none, but not exact in f32 lanes: the table's nodes with the
                    // voxels' differences.
                    4 => Dataset::new(
                        dims,
                        Voxels::U16((0..n).map(|_| 1 + (rng.next() * 65535.0) as u16).collect()),
                        0.1,
                        65535.3,
                    ),
                    _ => Dataset::new(
                        dims,
                        Voxels::U8((0..n).map(|_| (rng.next() * 256.0) as u8).collect()),
                        255.0,
                        254.0,
                    ),
                }
                .unwrap();
                let size = scale.iter().fold(0.0f32, |m, v| m.max(*v));
                let render = |packets: bool, threads: usize, wide_lanes: bool, trust: bool| {
                    let mut vl = Library::new();
                    vl.add_dataset(DatasetId(1), data.clone()).unwrap();
                    let (a1, an) = (
                        if ends.0 { 0.0 } else { 0.1 },
                        if ends.1 { 1.0 } else { 0.9 },
                    );
                    vl.mapping(
                        MappingId(1),
                        MappingType::Ramp,
                        3,
                        1,
                        &[a1, 0.0, 0.5, 0.4, an, 0.95],
                    )
                    .unwrap();
                    vl.mapping(
                        MappingId(2),
                        MappingType::Ramp,
                        2,
                        3,
                        &[0.0, 0.2, 0.4, 0.6, 1.0, 1.0, 0.9, 0.5],
                    )
                    .unwrap();
                    vl.scene().unwrap();
                    vl.set_optimise(Optimise {
                        packets,
                        wide_lanes,
                        trust_whole_runs: trust,
                        ..Optimise::default()
                    })
                    .unwrap();
                    // The eye at a multiple of the size from the centre: inside for small ones.
                    let _ = vl.camera(&Camera {
                        eye: eye.map(|e| e * size),
                        at: [0.0; 3],
                        up: [0.0, 1.0, 0.0],
                        fov: 50.0,
                    });
                    let _ = vl.step_size(size * 10f32.powf(step_rel), size * 10f32.powf(ref_rel));
                    vl.ambient(1.0, 1.0, 1.0, 0.4).unwrap();
                    let _ = vl.directional_light(light, [1.0, 0.9, 0.8], 1.0);
                    vl.object().unwrap();
                    let _ = vl.rotate(rotate[0], rotate[1], rotate[2]);
                    let _ = vl.scale(scale[0], scale[1], scale[2]);
                    let _ = vl.translate(-0.5, -0.5, -0.5);
                    colour_program(&mut vl, shaded.then_some([0.3, 0.6, 0.4]));
                    vl.end().unwrap();
                    on_threads(threads, || vl.render_preview(6, 5, 1.2)).unwrap()
                };
                let (packets, two, scalar) = (
                    render(true, 1, true, true),
                    render(true, 2, true, true),
                    render(false, 1, true, true),
                );
                // Sixteen lanes a step (where the processor has AVX-512) or eight: the same
                // image bit for bit.
                let narrow = render(true, 1, false, true);
                // Every run tested against the cell mask: the same image bit for bit.
                let tested = render(true, 1, true, false);
                let flat =
                    |i: &vlib::Image| -> Vec<f32> { i.pixels.iter().flatten().copied().collect() };
                let (p, s) = (flat(&packets), flat(&scalar));
                prop_assert!(
                    p.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)),
                    "{p:?}"
                );
                let bits = |v: &[f32]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                prop_assert_eq!(bits(&p), bits(&flat(&two)));
                prop_assert_eq!(bits(&p), bits(&flat(&tested)));
                prop_assert_eq!(bits(&p), bits(&flat(&narrow)));
                for (a, b) in p.iter().zip(&s) {
                    prop_assert!((a - b).abs() <= 1.0 / 255.0, "{a} against {b}");
                }
                if p.iter().zip(&s).any(|(a, b)| a.to_bits() != b.to_bits()) {
                    ran.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                }
                Ok(())
            },
        )
        .unwrap();
    // The packet march did run in a good part of the cases (its last bits differ).
    let ran = ran.into_inner();
    eprintln!("the packet march changed a pixel in {ran} of 1500 cases");
    assert!(
        ran > 150,
        "the packet march changed a pixel in only {ran} of 1500 cases"
    );
}

/// The pre-integrated packet march (`Optimise::preintegrate` with `Optimise::packets`) against
/// the scalar pre-integrated march, in every case of `packets_are_the_scalar_march`. The two
/// composite the same slabs by the same scalar code (tables, halving, composite in f64): the
/// lanes find the samples to take and their values, and in the shaded cases (one directional
/// light, the node gradient) light the slabs' pieces by the midpoint march's f32 lighting (a
/// relative 10⁻⁶ or so from the scalar f64 model). From node values the values are the scalar code's bits; these volumes are 8-bit
/// voxels, which the lanes interpolate and normalise once (a relative 10⁻⁷ from the node
/// values, as in the midpoint march), so a slab's ends, its table lookup and its halving test
/// may differ by that much:
/// a table's bilinear interpolation moves by at most its slope times 10⁻⁷, far below an 8-bit
/// level, and a halving decided the other way at the tolerance's edge changes the slab by
/// the table's resolution (about 10⁻⁴). A termination one slab apart adds at most the bound
/// (1/512) times a colour. So the packet tolerance, 1/255 per channel. The packet march's
/// images are the same bits for one and two threads, eight and sixteen lanes (of the volume
/// as 8- and as 16-bit voxels), runs on trust or tested, and with skipping on and off (the slabs composited do not depend on which
/// samples are passed over).
#[test]
#[cfg(target_arch = "x86_64")]
fn preintegrated_packets_are_the_scalar_march() {
    if no_packet_march() {
        return;
    }
    let (mut worst, mut differ, mut shown_cases) = (0.0f32, 0usize, 0usize);
    let bits = |v: &[[f32; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    // The same bits, or how many channels differ and by how much at most.
    let same = |a: &[[f32; 3]], b: &[[f32; 3]], what: &str| {
        let (a, b) = (a.iter().flatten(), b.iter().flatten());
        let apart: Vec<f32> = a
            .zip(b)
            .filter(|(x, y)| x.to_bits() != y.to_bits())
            .map(|(x, y)| (x - y).abs())
            .collect();
        let most = apart.iter().fold(0.0f32, |m, &d| m.max(d));
        assert!(
            apart.is_empty(),
            "{what}: {} channels apart, at most {most}",
            apart.len()
        );
    };
    for (n, case) in cases().iter().enumerate() {
        let case = Case {
            optimise: Optimise {
                preintegrate: true,
                ..case.optimise
            },
            ..*case
        };
        let with = |f: &dyn Fn(&mut Optimise)| {
            let mut optimise = case.optimise;
            f(&mut optimise);
            Case { optimise, ..case }
        };
        let scalar = render(&case, false, 1);
        let packets = render(&case, true, 1);
        same(
            &packets,
            &render(&case, true, 2),
            &format!("case {n}: threads"),
        );
        let narrow = with(&|o| o.wide_lanes = false);
        same(
            &packets,
            &render(&narrow, true, 1),
            &format!("case {n}: lanes"),
        );
        same(
            &render_made_as(&case, true, 1, true).0,
            &render_made_as(&narrow, true, 1, true).0,
            &format!("case {n}: lanes, 16-bit voxels"),
        );
        let tested = with(&|o| o.trust_whole_runs = false);
        same(
            &packets,
            &render(&tested, true, 1),
            &format!("case {n}: trust"),
        );
        let skipping = with(&|o| o.skip_empty = !o.skip_empty);
        same(
            &scalar,
            &render(&skipping, false, 1),
            &format!("case {n}: skipping, scalar"),
        );
        same(
            &packets,
            &render(&skipping, true, 1),
            &format!("case {n}: skipping"),
        );
        if bits(&packets) != bits(&scalar) {
            differ += 1;
        }
        if scalar.iter().any(shows_volume) {
            shown_cases += 1;
        }
        for (p, s) in packets.iter().zip(&scalar) {
            for c in 0..3 {
                assert!(p[c].is_finite(), "case {n}: {p:?}");
                let d = (p[c] - s[c]).abs();
                assert!(d <= 1.0 / 255.0, "case {n}: {p:?} against {s:?}");
                worst = worst.max(d);
            }
        }
    }
    eprintln!(
        "pre-integrated packets against scalar: largest difference {worst}, {differ} of 36 \
         images not bit for bit, {shown_cases} show the volume"
    );
    assert!(shown_cases >= 20, "{shown_cases}");
    // The packet march did run (8-bit voxels interpolated in lanes leave some last bits apart).
    assert!(
        differ > 0,
        "no image differed: the packet march did not run"
    );
}

/// Where the pre-integrated packet march reads what the scalar march reads (16-bit voxels,
/// whose values both take from the node values' interpolation, not 8-bit voxels
/// interpolated in lanes) and lights nothing in lanes (the unshaded cases), its images are
/// the scalar march's bit for bit: the lanes find the samples and read the values at them and
/// at the middles and quarters of the slabs that follow a ray's last sample (in batches of a
/// step's slabs, `simd::slabs`), and the scalar code composites the same slabs from the same
/// values. A value read at the wrong point, or given to the wrong ray, changes pixels. That
/// the packet march ran shows in the same cases from 8-bit voxels, which it interpolates
/// itself (a relative 10⁻⁷ apart).
#[test]
#[cfg(target_arch = "x86_64")]
fn unlit_preintegrated_packets_of_node_values_are_the_scalar_march_bit_for_bit() {
    if no_packet_march() {
        return;
    }
    let (mut shown, mut bytes_apart) = (0, 0);
    for (n, case) in cases().iter().enumerate().filter(|(_, c)| !c.shaded) {
        let case = Case {
            optimise: Optimise {
                preintegrate: true,
                ..case.optimise
            },
            ..*case
        };
        let narrow = Case {
            optimise: Optimise {
                wide_lanes: false,
                ..case.optimise
            },
            ..case
        };
        let scalar = render_made_as(&case, false, 1, true).0;
        for (what, packets) in [
            ("wide", render_made_as(&case, true, 1, true).0),
            ("narrow", render_made_as(&narrow, true, 1, true).0),
        ] {
            let apart = packets
                .iter()
                .zip(&scalar)
                .filter(|(p, s)| p.map(f32::to_bits) != s.map(f32::to_bits))
                .count();
            assert_eq!(apart, 0, "case {n}, {what}: {apart} pixels differ");
        }
        if scalar.iter().any(shows_volume) {
            shown += 1;
        }
        // The same case from 8-bit voxels, which the lanes interpolate themselves: some last
        // bits apart from the scalar march where the packet march runs.
        let bits = |v: &[[f32; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        if bits(&render(&case, true, 1)) != bits(&render(&case, false, 1)) {
            bytes_apart += 1;
        }
    }
    assert!(shown >= 10, "{shown}");
    // The packet march ran in these cases (its voxels' type does not decide where it runs).
    assert!(bytes_apart > 0, "the packet march did not run");
}

/// The lit packet march (and the pre-integrated one, whose pieces the lanes light) at the
/// extremes of legal scenes: objects of world size 10⁻³⁰ to 10³⁰, whose normal matrix (the
/// inverse of the object's scale) squared would overflow or vanish in f32, and lights up to
/// `FLT_MAX`, whose lit colours would. Each image within the packet tolerance of the scalar
/// march, which lights in f64 (an object's lighting is the same at every scale: its pixels are
/// compared with those at scale 1 too). At the extreme scales the lanes still light (the
/// images differ from the scalar march's in their last bits); under the brightest lights the
/// scalar march lights the samples (the same bits).
#[test]
#[cfg(target_arch = "x86_64")]
fn lit_packets_hold_at_extreme_scales_and_lights() {
    if no_packet_march() {
        return;
    }
    // A ball whose value falls from 1 at its centre to 0 at its surface.
    let n = 24usize;
    let c = (n - 1) as f32 / 2.0;
    let voxels = (0..n * n * n)
        .map(|k| {
            let (x, y, z) = ((k % n) as f32, ((k / n) % n) as f32, (k / (n * n)) as f32);
            let r = ((x - c).powi(2) + (y - c).powi(2) + (z - c).powi(2)).sqrt() / c;
            ((1.0 - r).max(0.0) * 255.0) as u8
        })
        .collect();
    let data = Dataset::new([n; 3], Voxels::U8(voxels), 0.0, 255.0).unwrap();
    let render = |scale: f32, light: f32, packets: bool, preintegrate: bool| {
        let mut vl = Library::new();
        vl.add_dataset(DatasetId(1), data.clone()).unwrap();
        // Opaque from half the radius in: no ray reaches the centre, where the gradient
        // vanishes and a normal's direction is rounding's.
        vl.mapping(MappingId(1), MappingType::Ramp, 2, 1, &[0.2, 0.0, 0.5, 1.0])
            .unwrap();
        vl.mapping(
            MappingId(2),
            MappingType::Ramp,
            2,
            3,
            &[0.2, 1.0, 0.5, 0.2, 0.9, 0.3, 0.8, 0.4],
        )
        .unwrap();
        vl.scene().unwrap();
        vl.set_optimise(Optimise {
            packets,
            preintegrate,
            ..Optimise::default()
        })
        .unwrap();
        vl.camera(&Camera {
            eye: [0.0, 0.0, -2.0 * scale],
            at: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov: 40.0,
        })
        .unwrap();
        vl.step_size(scale / 50.0, scale).unwrap();
        vl.ambient(1.0, 1.0, 1.0, 0.1).unwrap();
        vl.directional_light([1.0, -1.0, 1.0], [1.0; 3], light)
            .unwrap();
        vl.object().unwrap();
        vl.translate(-0.5, -0.5, -0.5).unwrap();
        vl.scale(scale, scale, scale).unwrap();
        colour_program(&mut vl, Some([0.5, 1.0, 0.5]));
        vl.set(Fields::N, 20.0 / 128.0).unwrap();
        vl.end().unwrap();
        let image = vl.render_preview(25, 25, 1.0).unwrap();
        image.pixels.iter().flatten().copied().collect::<Vec<f32>>()
    };
    let near = |a: &[f32], b: &[f32], what: &str| {
        for (k, (x, y)) in a.iter().zip(b).enumerate() {
            assert!(
                x.is_finite() && (x - y).abs() <= 1.0 / 255.0,
                "{what}: channel {k}, {x} against {y}"
            );
        }
    };
    for preintegrate in [false, true] {
        let at_one = render(1.0, 1.0, false, preintegrate);
        // The ball is lit: its pixels differ from the background's.
        assert!(at_one.iter().any(|&v| v > 0.05), "{at_one:?}");
        for scale in [1e-30f32, 1e-20, 1e-19, 1.0, 1e20, 1e24, 1e30] {
            let what = format!("scale {scale:e}, pre-integrated {preintegrate}");
            let (packets, scalar) = (
                render(scale, 1.0, true, preintegrate),
                render(scale, 1.0, false, preintegrate),
            );
            near(
                &packets,
                &scalar,
                &format!("{what}: packets against scalar"),
            );
            near(&scalar, &at_one, &format!("{what}: scalar against scale 1"));
            assert_ne!(packets, scalar, "{what}: the lanes did not light");
        }
        for light in [1e19f32, 1e30, 3e38, f32::MAX] {
            let what = format!("light {light:e}, pre-integrated {preintegrate}");
            let (packets, scalar) = (
                render(1.0, light, true, preintegrate),
                render(1.0, light, false, preintegrate),
            );
            near(&packets, &scalar, &what);
            // Lit that brightly, the ball is white where it is lit.
            assert!(scalar.contains(&1.0), "{what}");
        }
    }
}

/// Super-sampling with the packet march (`compat.md`), against a transparent backdrop (so
/// that the transmittance is compared and averaged too) in an image whose width leaves a
/// partial tile: a pixel the rule leaves alone is the first pass, the image of one ray a
/// pixel, bit for bit; a pixel it refines is the mean of its n × n rays, which are the pixels
/// of the image n times finer along each axis (the same view: its pixel (n·x + i, n·y + j) is
/// centred on ray (i, j) of pixel (x, y)), colour and transmittance summed in f64 row by row,
/// bit for bit: the first pass and the finer image each a render of one ray a pixel in
/// packets. The rule is computed here from the first pass: a colour channel or the
/// transmittance more than 4/255 from a 4-neighbour's. And the same bytes on one and three
/// threads, and within one 8-bit level of the scalar march's super-sampled image wherever
/// both refine a pixel or neither does.
#[test]
#[cfg(target_arch = "x86_64")]
fn super_sampled_packets_are_the_mean_of_the_finer_image() {
    if no_packet_march() {
        return;
    }
    // The rule's contrast (`compat.md`: more than 4/255 in a channel).
    const CONTRAST: f32 = 4.0 / 255.0;
    // 51 = three tiles of 16 and three columns.
    let (w, h) = (W + 3, H);
    let bits = |v: &[[f32; 4]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    // Colour and transmittance of every pixel, row by row.
    let image = |vl: &mut Library, ss: i32, (w, h): (u32, u32), threads: usize| {
        vl.super_sample(ss).unwrap();
        let image = on_threads(threads, || {
            vl.render(w, h, 1.2, vlib::Backdrop::Transparent)
        })
        .unwrap();
        (0..(w * h) as usize)
            .map(|i| {
                let [r, g, b] = image.pixels[i];
                [r, g, b, image.transmittance[i]]
            })
            .collect::<Vec<_>>()
    };
    // Whether the rule refines pixel (x, y) of first pass `first` (w × h pixels).
    let refines = |first: &[[f32; 4]], x: u32, y: u32| {
        let p = first[(y * w + x) as usize];
        let near = [
            (x.wrapping_sub(1), y),
            (x + 1, y),
            (x, y.wrapping_sub(1)),
            (x, y + 1),
        ];
        near.iter().any(|&(nx, ny)| {
            nx < w && ny < h && {
                let q = first[(ny * w + nx) as usize];
                (0..4).any(|c| (p[c] - q[c]).abs() > CONTRAST)
            }
        })
    };
    let (mut refined, mut kept, mut compared) = (0usize, 0usize, 0usize);
    for (k, case) in cases().iter().enumerate().filter(|(k, _)| k % 3 == 0) {
        let (n, preintegrate) = [(2, false), (3, true), (4, false)][k / 3 % 3];
        let case = Case {
            optimise: Optimise {
                preintegrate,
                ..case.optimise
            },
            ..*case
        };
        let mut vl = library(&case, true, false);
        let first = image(&mut vl, 1, (w, h), 1);
        let fine = image(&mut vl, 1, (n * w, n * h), 1);
        let got = image(&mut vl, n as i32, (w, h), 1);
        let threads = image(&mut vl, n as i32, (w, h), 3);
        assert_eq!(bits(&got), bits(&threads), "case {k}: threads");
        let mut scalar_vl = library(&case, false, false);
        let scalar = image(&mut scalar_vl, n as i32, (w, h), 1);
        let scalar_first = image(&mut scalar_vl, 1, (w, h), 1);
        for y in 0..h {
            for x in 0..w {
                let want = if refines(&first, x, y) {
                    refined += 1;
                    let mut sum = [0.0f64; 4];
                    for j in 0..n {
                        for i in 0..n {
                            let q = fine[((n * y + j) * n * w + n * x + i) as usize];
                            for c in 0..4 {
                                sum[c] += q[c] as f64;
                            }
                        }
                    }
                    sum.map(|s| (s / (n * n) as f64).clamp(0.0, 1.0) as f32)
                } else {
                    kept += 1;
                    first[(y * w + x) as usize]
                };
                let i = (y * w + x) as usize;
                assert_eq!(
                    got[i].map(f32::to_bits),
                    want.map(f32::to_bits),
                    "case {k}, n {n}, pixel ({x}, {y}): {:?} against {want:?}",
                    got[i]
                );
                // The scalar march's refinement decides from its own first pass.
                if refines(&scalar_first, x, y) == refines(&first, x, y) {
                    compared += 1;
                    for c in 0..4 {
                        assert!(
                            (got[i][c] - scalar[i][c]).abs() <= 1.0 / 255.0,
                            "case {k}, n {n}, pixel ({x}, {y}): {:?} against the scalar {:?}",
                            got[i],
                            scalar[i]
                        );
                    }
                }
            }
        }
    }
    // Both kinds of pixel were there, and most pixels compared with the scalar march.
    assert!(
        refined > 500 && kept > 500,
        "{refined} refined, {kept} kept"
    );
    assert!(
        compared * 100 >= (refined + kept) * 95,
        "{compared} of {}",
        refined + kept
    );
}

/// A step so fine that a ray takes over a million samples (1.7·10⁶ through a unit cube of
/// constant 8-bit value 0.9, step 10⁻⁶ against a reference of 10, early termination off): the
/// lanes composite in f32, an error of about 2⁻²⁴ a sample, which here came to three 8-bit
/// levels against the scalar march's f64. Past 2¹⁴ samples a ray (`dev/simd.md`) the scalar
/// march traces every ray, so the two switches give the same image.
#[test]
fn a_million_samples_a_ray_stay_within_a_level_of_the_scalar_march() {
    let image = |packets: bool, step: f32| {
        let mut vl = Library::new();
        let data = Dataset::new([8; 3], Voxels::U8(vec![230; 512]), 0.0, 255.0).unwrap();
        vl.add_dataset(DatasetId(1), data).unwrap();
        let opacity = [0.3, 0.0, 0.5, 0.2, 0.7, 0.6, 0.95, 0.9];
        vl.mapping(MappingId(1), MappingType::Ramp, 4, 1, &opacity)
            .unwrap();
        let colours = [0.25, 0.9, 0.2, 0.1, 0.75, 0.1, 0.7, 0.95];
        vl.mapping(MappingId(2), MappingType::Ramp, 2, 3, &colours)
            .unwrap();
        vl.scene().unwrap();
        vl.set_optimise(Optimise {
            packets,
            early_termination: false,
            ..Optimise::default()
        })
        .unwrap();
        vl.camera(&Camera {
            eye: [0.3, 0.2, -3.0],
            at: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov: 40.0,
        })
        .unwrap();
        vl.background(1.0, 1.0, 1.0).unwrap();
        vl.step_size(step, 10.0).unwrap();
        vl.object().unwrap();
        vl.translate(-0.5, -0.5, -0.5).unwrap();
        colour_program(&mut vl, None);
        vl.end().unwrap();
        let img = vl.render_preview(4, 4, 1.0).unwrap();
        (0..4)
            .flat_map(|y| (0..4).map(move |x| (x, y)))
            .map(|(x, y)| img.pixel(x, y))
            .collect::<Vec<_>>()
    };
    for step in [1e-6, 1e-2] {
        let (lanes, scalar) = (image(true, step), image(false, step));
        let worst = lanes
            .iter()
            .flatten()
            .zip(scalar.iter().flatten())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(worst <= 1.0 / 255.0, "step {step}: {worst}");
        // The cube absorbs: the comparison means something.
        assert!(scalar.iter().any(|p| p[0] < 0.9), "step {step}: {scalar:?}");
    }
}
