//! Closed-form tests of pre-integrated transfer functions (`Optimise::preintegrate`): a dataset
//! whose value is linear in depth (trilinear interpolation reproduces a linear function
//! exactly), seen head-on through an opacity ramp and a colour ramp, against the
//! emission–absorption integral along the ray computed independently here. Each pre-integrated
//! check runs both marches: the packet march (`Optimise::packets`, where the processor has
//! AVX2 and FMA: the samples and values in SIMD lanes) and the scalar one.

#[path = "common/slab.rs"]
mod slab;
#[path = "common/two_balls.rs"]
mod two_balls;

use slab::{head_on, slab_object};
use vlib::{Camera, Dataset, Fields, Library, MappingType, Optimise, Voxels};
use vlib::{DatasetId, MappingId, RenderType};

/// Slab depth (world units) and the opacity reference length.
const DEPTH: f64 = 10.0;
const REFERENCE: f32 = 1.0;
/// The opacity ramp: 0 up to F = 0.25, then linear to 0.8 at F = 1 (per reference length).
const O_ROWS: [f32; 4] = [0.25, 0.0, 1.0, 0.8];
/// The colour ramp between the same inputs: r, g, b at F = 0.25 and at F = 1.
const C0: [f32; 3] = [0.9, 0.2, 0.1];
const C1: [f32; 3] = [0.1, 0.7, 0.95];

/// Nodes along depth; the value of node k is k/(NZ − 1) (16-bit voxels, normalised exactly).
const NZ: usize = 11;

fn opacity(v: f64) -> f64 {
    if v <= 0.25 {
        0.0
    } else {
        0.8 * (v - 0.25) / 0.75
    }
}

fn colour(v: f64) -> [f64; 3] {
    let s = ((v - 0.25) / 0.75).clamp(0.0, 1.0);
    std::array::from_fn(|i| C0[i] as f64 + (C1[i] as f64 - C0[i] as f64) * s)
}

/// The scene: the slab [−200, 200]² × [0, DEPTH] whose value rises linearly from 0 at its
/// front (z = 0) to 1 at its back, ambient light only (ka = 1), black background, seen
/// head-on from z = −100.
fn scene(step: f32, preintegrate: bool, packets: bool) -> Library {
    let per = 65535 / (NZ - 1) as u16;
    scene_of(step, preintegrate, packets, |k| k as u16 * per)
}

/// [`scene`] with node k along depth holding the voxel `voxel(k)` (normalised by the linear
/// ramp's top voxel), the packet march on or off.
fn scene_of(step: f32, preintegrate: bool, packets: bool, voxel: impl Fn(usize) -> u16) -> Library {
    scene_with(step, preintegrate, packets, voxel, &O_ROWS)
}

/// [`scene_of`] through the opacity table of `rows` (input, opacity pairs).
fn scene_with(
    step: f32,
    preintegrate: bool,
    packets: bool,
    voxel: impl Fn(usize) -> u16,
    rows: &[f32],
) -> Library {
    let mut vl = Library::new();
    let per = 65535 / (NZ - 1) as u16;
    let raw: Vec<u16> = (0..4 * 4 * NZ).map(|i| voxel(i / 16)).collect();
    let top = per as f32 * (NZ - 1) as f32;
    let data = Dataset::new([4, 4, NZ], Voxels::U16(raw), 0.0, top).unwrap();
    vl.add_dataset(DatasetId(1), data).unwrap();
    vl.mapping(
        MappingId(1),
        MappingType::Ramp,
        rows.len() as i32 / 2,
        1,
        rows,
    )
    .unwrap();
    colour_ramp(&mut vl, 0.25, 1.0);
    vl.scene().unwrap();
    vl.set_optimise(Optimise {
        preintegrate,
        packets,
        ..Optimise::default()
    })
    .unwrap();
    head_on(&mut vl);
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.background(0.0, 0.0, 0.0).unwrap();
    vl.step_size(step, REFERENCE).unwrap();
    slab_object(&mut vl, DEPTH as f32);
    direct_shading(&mut vl);
    vl.set(Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    vl
}

/// Colour table 2: a ramp from `C0` at F = `lo` to `C1` at F = `hi`.
fn colour_ramp(vl: &mut Library, lo: f32, hi: f32) {
    let mut c = vec![lo];
    c.extend(C0);
    c.push(hi);
    c.extend(C1);
    vl.mapping(MappingId(2), MappingType::Ramp, 2, 3, &c)
        .unwrap();
}

/// The open object's direct-shading program: F from dataset 1, O through table 1, R, G and B
/// through table 2 (the form pre-integration applies to).
fn direct_shading(vl: &mut Library) {
    vl.dataset(Fields::F, DatasetId(1)).unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    vl.map(Fields::R, Fields::F, MappingId(2), 1).unwrap();
    vl.map(Fields::G, Fields::F, MappingId(2), 2).unwrap();
    vl.map(Fields::B, Fields::F, MappingId(2), 3).unwrap();
}

/// The emission–absorption integral along a ray through the slab of path length `len` (the
/// value rising linearly from 0 to 1 along it): colour ∫ c σ e^(−∫σ) ds with σ = −ln(1 − o)
/// per reference length, by the composite midpoint rule in f64 over a million steps (its
/// error, of order (len/10⁶)²·σ'', is far below f32's resolution).
fn exact(len: f64) -> [f64; 3] {
    exact_along(len, |s| s / len)
}

/// The emission–absorption integral along a ray of path length `len` whose value at distance
/// s from its front is `value(s)`, as [`exact`].
fn exact_along(len: f64, value: impl Fn(f64) -> f64) -> [f64; 3] {
    let n = 1_000_000;
    let ds = len / n as f64;
    let mut tau = 0.0f64;
    let mut col = [0.0f64; 3];
    for i in 0..n {
        let v = value((i as f64 + 0.5) * ds);
        let sigma = -(1.0 - opacity(v)).ln() / REFERENCE as f64;
        // The step's own attenuation at its middle: e^(−τ − σ ds/2).
        let w = sigma * ds * (-(tau + 0.5 * sigma * ds)).exp();
        let c = colour(v);
        for k in 0..3 {
            col[k] += w * c[k];
        }
        tau += sigma * ds;
    }
    col
}

/// The largest difference between the centre pixel (a ray straight along z, path length
/// DEPTH) and the closed form.
fn centre_error(step: f32, preintegrate: bool, packets: bool, expected: &[f64; 3]) -> f64 {
    let img = scene(step, preintegrate, packets)
        .render_preview(3, 3, 1.0)
        .unwrap();
    let p = img.pixel(1, 1);
    (0..3)
        .map(|k| (p[k] as f64 - expected[k]).abs())
        .fold(0.0, f64::max)
}

#[test]
fn preintegration_is_exact_on_a_linear_ramp_at_any_step() {
    let expected = exact(DEPTH);
    // Steps that divide the depth and steps that do not (a shorter last segment, integrated
    // on the spot), up to one segment longer than the slab (two half slabs). The table is
    // the same integral at value spacing 1/127 read bilinearly: the midpoint rule's error in
    // each sub-slab and the interpolation's, both of order (1/127)² times second derivatives
    // of α and the colour (below 1 here), so at most a few 10⁻⁵; 2·10⁻⁴ (a twentieth of an
    // 8-bit level) leaves room for the f32 arithmetic of the composite.
    for step in [0.37f32, 1.0, 2.5, 2.9, 7.0, 15.0] {
        for packets in [true, false] {
            let err = centre_error(step, true, packets, &expected);
            assert!(
                err < 2e-4,
                "step {step}, packets {packets}: error {err:e}, expected {expected:?}"
            );
        }
    }
    // Without pre-integration the midpoint rule's error at coarse steps is far larger (the
    // test can tell the two apart).
    let coarse = centre_error(7.0, false, true, &expected);
    assert!(coarse > 1e-2, "midpoint rule at step 7: {coarse:e}");
}

#[test]
fn slabs_are_halved_where_the_data_bends() {
    // Node k along depth (at z = k) holds a value that zigzags, so the value is linear within
    // each cell and bends at every node. At step 2 the samples lie at odd z and every slab
    // between them spans two cells with a bend at its middle: the midpoint's value is off the
    // mean of the ends, so the slab is halved there, and each half lies within one cell, where
    // the value is linear and its table integral exact (the same bound as on the linear ramp).
    // The half slabs to and from the faces lie within one cell too.
    const ZIGZAG: [f64; NZ] = [0.3, 0.9, 0.4, 0.8, 0.5, 0.95, 0.35, 0.7, 0.6, 1.0, 0.45];
    let top = (65535 / (NZ - 1) as u16) as f64 * (NZ - 1) as f64;
    let voxel = |k: usize| (ZIGZAG[k] * top).round() as u16;
    let node = |k: usize| voxel(k) as f64 / top;
    let expected = exact_along(DEPTH, |z| {
        let k = (z.floor() as usize).min(NZ - 2);
        node(k) + (node(k + 1) - node(k)) * (z - k as f64)
    });
    let err = |pre: bool, packets: bool| {
        let img = scene_of(2.0, pre, packets, voxel)
            .render_preview(3, 3, 1.0)
            .unwrap();
        let p = img.pixel(1, 1);
        (0..3)
            .map(|k| (p[k] as f64 - expected[k]).abs())
            .fold(0.0, f64::max)
    };
    for packets in [true, false] {
        let on = err(true, packets);
        assert!(
            on < 2e-4,
            "pre-integrated, packets {packets}: error {on:e}, expected {expected:?}"
        );
    }
    // The midpoint rule at the same step is far off (the test tells the two apart).
    let off = err(false, true);
    assert!(off > 1e-2, "midpoint rule: {off:e}");
}

#[test]
fn a_constant_value_keeps_the_exact_opacity_of_a_constant_medium() {
    // Every node 0.6 of the ramp's top: value 0.6 (to f32 rounding of the normalisation),
    // opacity o and colour c constant, so the pixel is c·(1 − (1 − o)^DEPTH) for any step,
    // each slab being the midpoint march's own sample (`CObj::alpha`). The tolerance is the
    // f32 rounding of the value, the tables and the composite (a few units of 10⁻⁷ each).
    let per = 65535 / (NZ - 1) as u16;
    let voxel = (0.6 * (per as f64 * (NZ - 1) as f64)) as u16;
    let v = voxel as f64 / (per as f64 * (NZ - 1) as f64);
    let o = opacity(v);
    let alpha = 1.0 - (1.0 - o).powf(DEPTH / REFERENCE as f64);
    let c = colour(v);
    for step in [0.37f32, 1.0, 2.9, 15.0] {
        for (pre, packets) in [(true, true), (true, false), (false, true)] {
            let img = scene_of(step, pre, packets, |_| voxel)
                .render_preview(3, 3, 1.0)
                .unwrap();
            let p = img.pixel(1, 1);
            for k in 0..3 {
                let want = c[k] * alpha;
                assert!(
                    (p[k] as f64 - want).abs() < 2e-6,
                    "step {step}, pre-integration {pre}, packets {packets}: {p:?} vs {want}"
                );
            }
        }
    }
}

#[test]
fn a_nearly_constant_value_keeps_the_opacity_of_a_constant_medium() {
    // An opacity that rises from 0 to 0.2 between F = 0.506 and 0.5065 (narrower than a
    // table cell, 1/127) and stays 0.2; every node at F ≈ 0.508, just above the rise, one
    // voxel in two a unit higher (a 16-bit scan's noise). Every slab's values lie above the
    // rise, so the pixel is the constant medium's c·(1 − 0.8^DEPTH); the tables' nodes
    // around 0.508 (0.5039 and 0.5118) straddle the rise, and their interpolation gave a
    // slab of two values a unit apart about half the opacity. The tolerance: the colour
    // ramp's change over the noise (its slope 1.1 times 2·10⁻⁵) and f32 roundings.
    let rows = [0.0, 0.0, 0.506, 0.0, 0.5065, 0.2, 1.0, 0.2];
    let per = 65535 / (NZ - 1) as u16;
    let top = per as f64 * (NZ - 1) as f64;
    let voxel = (0.508 * top) as u16;
    let v = voxel as f64 / top;
    let alpha = 1.0 - 0.8f64.powf(DEPTH / REFERENCE as f64);
    let c = colour(v);
    for step in [0.37f32, 1.0, 2.9] {
        for packets in [true, false] {
            let noisy = |k: usize| voxel + (k % 2) as u16;
            let img = scene_with(step, true, packets, noisy, &rows)
                .render_preview(3, 3, 1.0)
                .unwrap();
            let p = img.pixel(1, 1);
            for k in 0..3 {
                let want = c[k] * alpha;
                assert!(
                    (p[k] as f64 - want).abs() < 1e-4,
                    "step {step}, packets {packets}: {p:?} vs {want}"
                );
            }
        }
    }
}

/// A 32³ dataset of two soft balls (8-bit), through a steep opacity ramp and a colour ramp,
/// lit by a directional light, rendered with pre-integration and `skip_empty` as given.
fn balls(skip_empty: bool, step: f32, packets: bool) -> Vec<u8> {
    balls_on(skip_empty, step, 0, packets)
}

/// [`balls`] on a pool of `threads` threads (0: rayon's default).
fn balls_on(skip_empty: bool, step: f32, threads: usize, packets: bool) -> Vec<u8> {
    balls_and(skip_empty, step, threads, packets, (true, None))
}

/// A second object over the left half of the balls.
#[derive(Clone, Copy)]
enum Second {
    /// A box of this opacity, faint or clear.
    Box(f32),
    /// An opaque DSR box whose surface (F = 0.5) does not exist: its F is the constant 0.3.
    NoSurface,
}

/// [`balls_on`], pre-integrated as `preintegrate` says, with `second` where given.
fn balls_and(
    skip_empty: bool,
    step: f32,
    threads: usize,
    packets: bool,
    (preintegrate, second): (bool, Option<Second>),
) -> Vec<u8> {
    let mut vl = Library::new();
    let data = two_balls::two_balls(32);
    vl.add_dataset(DatasetId(1), data).unwrap();
    vl.mapping(
        MappingId(1),
        MappingType::Ramp,
        2,
        1,
        &[0.3, 0.0, 0.45, 1.0],
    )
    .unwrap();
    colour_ramp(&mut vl, 0.3, 0.8);
    vl.scene().unwrap();
    vl.set_optimise(Optimise {
        preintegrate,
        skip_empty,
        packets,
        ..Optimise::default()
    })
    .unwrap();
    vl.camera(&Camera {
        eye: [0.3, 0.2, -2.5],
        at: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov: 30.0,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 0.3).unwrap();
    vl.directional_light([1.0, -1.0, 1.0], [1.0, 1.0, 1.0], 1.0)
        .unwrap();
    vl.step_size(step, 0.05).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    direct_shading(&mut vl);
    vl.set(Fields::KA, 0.3).unwrap();
    vl.set(Fields::KD, 0.7).unwrap();
    vl.end().unwrap();
    if let Some(second) = second {
        let o = match second {
            Second::Box(o) => o,
            Second::NoSurface => {
                vl.render_type(RenderType::Dsr).unwrap();
                vl.surface(Fields::F, 0.5).unwrap();
                1.0
            }
        };
        vl.object().unwrap();
        vl.translate(-0.6, -0.6, -0.6).unwrap();
        vl.scale(0.6, 1.2, 1.2).unwrap();
        vl.set(Fields::O, o).unwrap();
        if let Second::NoSurface = second {
            vl.set(Fields::F, 0.3).unwrap();
        }
        vl.end().unwrap();
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| vl.render_preview(40, 40, 1.0))
        .unwrap()
        .to_rgb8()
}

#[test]
fn empty_space_skipping_changes_no_pre_integrated_pixel() {
    // A sample the skipping passes over has a value the opacity table maps to 0; the slabs
    // next to it read its value, so the same slabs are composited with and without skipping.
    // The packet march passes over the samples its cell mask clears, the scalar march those
    // in empty blocks: the same slabs either way.
    for step in [0.013f32, 0.05, 0.11] {
        for packets in [true, false] {
            let (on, off) = (balls(true, step, packets), balls(false, step, packets));
            assert!(
                on.iter().any(|&b| b > 40),
                "step {step}: the balls are visible"
            );
            assert!(
                on == off,
                "step {step}, packets {packets}: skipping changed a pixel"
            );
        }
    }
}

#[test]
fn pre_integrated_bytes_do_not_depend_on_the_thread_count() {
    // The tables' rows are built in parallel and the tiles traced in parallel; each entry and
    // each pixel is computed on its own, so the bytes are the same on any number of threads.
    for packets in [true, false] {
        let one = balls_on(true, 0.05, 1, packets);
        assert!(one.iter().any(|&b| b > 40), "the balls are visible");
        for threads in [2, 3, 8] {
            assert!(
                balls_on(true, 0.05, threads, packets) == one,
                "packets {packets}: {threads} threads differ from one"
            );
        }
    }
}

/// [`band`]'s image: a volume whose value steps between 0.1 and 0.9 after node `edge` of 64
/// along depth (from 0.1 to 0.9 front to back, or the other way where `falling`), seen
/// head-on through an opacity band (0 up to 0.2 and from 0.6, 1 at 0.4), pre-integrated at
/// step `step` with empty-space skipping as given; the pixels' bits and the centre's
/// transmittance.
fn band(falling: bool, edge: usize, step: f32, skip_empty: bool, packets: bool) -> (Vec<u32>, f32) {
    let nz = 64usize;
    let (low, high) = (6554u16, 58982u16);
    let voxels: Vec<u16> = (0..8 * 8 * nz)
        .map(|i| {
            if (i / 64 <= edge) != falling {
                low
            } else {
                high
            }
        })
        .collect();
    let mut vl = Library::new();
    let data = Dataset::new([8, 8, nz], Voxels::U16(voxels), 0.0, 65535.0).unwrap();
    vl.add_dataset(DatasetId(1), data).unwrap();
    let rows = [0.0, 0.0, 0.2, 0.0, 0.4, 1.0, 0.6, 0.0, 1.0, 0.0];
    vl.mapping(MappingId(1), MappingType::Ramp, 5, 1, &rows)
        .unwrap();
    let white = [0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
    vl.mapping(MappingId(2), MappingType::Ramp, 2, 3, &white)
        .unwrap();
    vl.scene().unwrap();
    vl.set_optimise(Optimise {
        preintegrate: true,
        skip_empty,
        packets,
        ..Optimise::default()
    })
    .unwrap();
    head_on(&mut vl);
    vl.background(0.0, 0.0, 0.0).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.step_size(step, 1.0).unwrap();
    slab_object(&mut vl, (nz - 1) as f32);
    direct_shading(&mut vl);
    vl.set(Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    let image = vl.render_preview(3, 3, 1.0).unwrap();
    let bits = image.pixels.iter().flatten().map(|x| x.to_bits()).collect();
    (bits, image.transmittance[4])
}

#[test]
fn skipping_keeps_the_slabs_that_cross_an_opacity_band() {
    // Both sides of the step have opacity 0 (0.1 below the band, 0.9 above it), so a grid of
    // opacity would call the high side empty and pass over its samples; but the slab from the
    // last sample on one side to the first on the other crosses the band, whose opacity it
    // integrates. Skipping may pass over a sample only where its value is at most the zero
    // test's bound (0.2): the same image with and without it, in both marches, and the band
    // seen (the slab across the step is more than a sample's 0.8 of value long in 2 voxels:
    // it takes the band's opacity over part of its length).
    for falling in [false, true] {
        for step in [2.0f32, 4.0] {
            for edge in [27usize, 29, 31] {
                for packets in [true, false] {
                    let what =
                        format!("falling {falling}, step {step}, edge {edge}, packets {packets}");
                    let (on, t_on) = band(falling, edge, step, true, packets);
                    let (off, t_off) = band(falling, edge, step, false, packets);
                    assert!(t_off < 0.99, "{what}: the band is seen ({t_off})");
                    assert!(
                        on == off,
                        "{what}: skipping changed a pixel ({t_on} against {t_off})"
                    );
                }
            }
        }
    }
}

#[test]
fn a_scene_of_two_objects_takes_midpoint_samples() {
    // Pre-integration is for a volume rendered alone: where a second object (here a faint box
    // over half of the balls) is in the scene, every ray is composited by midpoint samples,
    // with or without the switch (were the rays that meet one object alone pre-integrated,
    // the box's edge would show as a seam), in both marches.
    for packets in [true, false] {
        let faint = Some(Second::Box(0.002));
        let midpoint = balls_and(true, 0.05, 0, packets, (false, faint));
        assert!(midpoint.iter().any(|&b| b > 40), "the balls are visible");
        assert!(
            balls_and(true, 0.05, 0, packets, (true, faint)) == midpoint,
            "packets {packets}: pre-integrated with a second object"
        );
        // Alone, the switch changes the image.
        let alone = balls_and(true, 0.05, 0, packets, (true, None));
        assert!(
            alone != balls_and(true, 0.05, 0, packets, (false, None)),
            "packets {packets}: pre-integration alone changed nothing"
        );
        // A clear box (opacity 0), or a box whose surface does not exist, is no object rays
        // meet: the balls are pre-integrated alone.
        for second in [Second::Box(0.0), Second::NoSurface] {
            assert!(
                balls_and(true, 0.05, 0, packets, (true, Some(second))) == alone,
                "packets {packets}: a box that shows nothing changed the image"
            );
        }
    }
}

/// A constant medium stays exact under a transform that makes the object-space ray huge: a
/// box sheared flat to a determinant of 10⁻¹⁰ (which `vlMatrix` accepts), seen from 30 and 300
/// units away. Its ray's origin and direction in object space are about 10¹¹, so `o + t·d` at
/// the box's faces cancels with an absolute error far above the 2⁻²⁰ a dataset forgives
/// outside its grid: a face value read there was 0 (outside), and the half slab from it to
/// the medium's 1 took the opacity step at 0.4 on the way (a quarter of the pixels off by up
/// to 0.6). The faces' values are read at the point brought back into the box, so the
/// pre-integrated image is the midpoint march's, bit for bit, in both marches.
#[test]
fn a_constant_medium_stays_exact_where_the_object_space_ray_is_huge() {
    let image = |preintegrate: bool, packets: bool, eye: f32| {
        let mut vl = Library::new();
        let data = Dataset::new([4, 4, 4], Voxels::U16(vec![65535; 64]), 0.0, 65535.0).unwrap();
        vl.add_dataset(DatasetId(1), data).unwrap();
        // Opacity 0 up to 0.4, a step to 1 just above it; a colour ramp.
        let rows = [0.0, 0.0, 0.4, 0.0, 0.40001, 1.0, 1.0, 1.0];
        vl.mapping(MappingId(1), MappingType::Ramp, 4, 1, &rows)
            .unwrap();
        let colours = [0.25, 0.7, 0.3, 0.2, 0.5, 0.9, 0.7, 0.5];
        vl.mapping(MappingId(2), MappingType::Ramp, 2, 3, &colours)
            .unwrap();
        vl.scene().unwrap();
        vl.set_optimise(Optimise {
            preintegrate,
            packets,
            ..Optimise::default()
        })
        .unwrap();
        vl.camera(&Camera {
            eye: [0.3, eye, 0.2],
            at: [0.0; 3],
            up: [0.0, 0.0, 1.0],
            fov: 6.0,
        })
        .unwrap();
        vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
        vl.object().unwrap();
        vl.translate(-0.5, -0.5, -0.5).unwrap();
        #[rustfmt::skip]
        let shear = [
            1.0, 1.0, 0.0, 0.0,
            0.0, 1e-10, 0.0, 0.0,
            0.0, 0.0, 1.0, 0.0,
            0.0, 0.0, 0.0, 1.0,
        ];
        vl.matrix(&shear).unwrap();
        vl.scale(10.0, 10.0, 10.0).unwrap();
        direct_shading(&mut vl);
        vl.set(Fields::KA, 1.0).unwrap();
        vl.end().unwrap();
        let img = vl.render_preview(32, 32, 1.0).unwrap();
        let covered = img.transmittance.iter().filter(|&&t| t < 1.0).count();
        let bits: Vec<u32> = img.pixels.iter().flatten().map(|v| v.to_bits()).collect();
        (bits, covered)
    };
    for eye in [30.0, 300.0] {
        for packets in [false, true] {
            let (midpoint, covered) = image(false, packets, eye);
            // The medium shows.
            assert!(covered > 50, "eye {eye}: {covered} pixels covered");
            let (pre, _) = image(true, packets, eye);
            let apart = midpoint.iter().zip(&pre).filter(|(a, b)| a != b).count();
            assert_eq!(
                apart, 0,
                "eye {eye}, packets {packets}: {apart} channels apart"
            );
        }
    }
}
