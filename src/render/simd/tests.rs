//! Unit tests of the packet march as a whole: runs on trust and the packets a step carries
//! change no pixel, and the lanes' opacity correction is the powers it stands for. The lane
//! routines against the scalar code they mirror are tested in `render`'s tests; the march
//! against the scalar march in `tests/packets.rs`.

use super::*;
use crate::types::{DatasetId, MappingId};

/// The test scene of slabs: slabs along x of 5 voxels (with some texture) between empty
/// ones of 3 (whole runs inside the slabs, cut runs at their faces), faint or, if
/// `opaque`, dense enough that most rays end early, before a grey-blue background, seen
/// at `step`, shaded or not, with `optimise`: the library with the scene open.
fn slabs_scene(
    step: f32,
    shaded: bool,
    opaque: bool,
    optimise: crate::model::scene::Optimise,
) -> crate::Library {
    use crate::data::{Dataset, Voxels};
    use crate::{Camera, Fields, Library, MappingType};
    let dims = [40usize, 36, 30];
    let voxels = (0..dims.iter().product::<usize>())
        .map(|i| {
            let (x, y, z) = (i % dims[0], i / dims[0] % dims[1], i / (dims[0] * dims[1]));
            if x % 8 < 5 {
                (150 + (x * 7 + y * 13 + z * 29) % 100) as u8
            } else {
                (x * 3 + y) as u8 % 60
            }
        })
        .collect();
    let data = Dataset::new(dims, Voxels::U8(voxels), 0.0, 255.0).unwrap();
    let mut vl = Library::new();
    vl.add_dataset(DatasetId(1), data).unwrap();
    let density = if opaque {
        [0.3, 0.0, 0.6, 0.6, 1.0, 0.95]
    } else {
        [0.3, 0.0, 0.6, 0.05, 1.0, 0.08]
    };
    vl.mapping(MappingId(1), MappingType::Ramp, 3, 1, &density)
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
    vl.set_optimise(optimise).unwrap();
    vl.background(0.1, 0.2, 0.3).unwrap();
    vl.camera(&Camera {
        eye: [90.0, -40.0, 70.0],
        at: [20.0, 18.0, 15.0],
        up: [0.0, 0.0, 1.0],
        fov: 40.0,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.directional_light([0.3, -1.0, 0.2], [1.0, 0.95, 0.9], 1.0)
        .unwrap();
    vl.step_size(step, 1.0).unwrap();
    vl.object().unwrap();
    vl.scale(39.0, 35.0, 29.0).unwrap();
    vl.dataset(Fields::F, DatasetId(1)).unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    vl.map(Fields::R, Fields::F, MappingId(2), 1).unwrap();
    vl.map(Fields::G, Fields::F, MappingId(2), 2).unwrap();
    vl.map(Fields::B, Fields::F, MappingId(2), 3).unwrap();
    if shaded {
        vl.set(Fields::KA, 0.2).unwrap();
        vl.set(Fields::KD, 0.7).unwrap();
        vl.set(Fields::KS, 0.3).unwrap();
    } else {
        vl.set(Fields::KA, 1.0).unwrap();
    }
    vl.end().unwrap();
    vl
}

/// The bits of the pixels of `image`.
fn bits<const C: usize>(image: &[[f32; C]]) -> Vec<u32> {
    image.iter().flatten().map(|v| v.to_bits()).collect()
}

/// The packet march's image of the scene open in `vl` (where the march applies), of
/// `(width, height)` pixels, as `render_image` makes it but in `packets` packets a step (0:
/// each width's own number, `Packets::packets`): the bits of its pixels, and the runs the
/// march took on trust.
fn march(vl: &crate::Library, (width, height): (u32, u32), packets: usize) -> (Vec<u32>, u64) {
    let scene = vl.compiled().unwrap();
    let view = view(&scene.settings, width, height, 1.2);
    let entry = scene.entry_marks(&view).map(|m| m.all_rows().unwrap());
    let image = scene.image_rays(view.eye, Backdrop::Background);
    let unbounded = scene.unbounded_colour(&image).map(|c| pixel(c, 1.0));
    let mut p = Packets::new(&scene).expect("the packet march applies");
    p.packets = packets;
    let progress = crate::control::Progress::none();
    let side = packet_tile(width, height);
    let recycled = Recycled::default();
    let pixels = per_tile(width, 0..height, side, &progress, &recycled, |tile, out| {
        p.tile(&view, entry.as_ref(), &image, unbounded, tile, out)
    })
    .unwrap();
    let untested = p.untested.load(std::sync::atomic::Ordering::Relaxed);
    (bits(&pixels), untested)
}

/// The pixels of `image` with their transmittance, as the renderer gives them.
fn with_transmittance(image: &crate::Image) -> Vec<Pixel> {
    let t = &image.transmittance;
    let p = image.pixels.iter().zip(t);
    p.map(|(&[r, g, b], &t)| [r, g, b, t]).collect()
}

/// Runs taken on trust ([`TRUSTED_RUNS`]) are taken, and change no pixel: the slabs
/// ([`slabs_scene`]) at fine and coarse steps, shaded and not, in sixteen lanes and in eight,
/// with `Optimise::trust_whole_runs` on and off.
#[test]
fn runs_on_trust_change_nothing() {
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        return;
    }
    let render = |step: f32, shaded: bool, wide_lanes: bool, trust: bool| {
        let optimise = crate::model::scene::Optimise {
            wide_lanes,
            trust_whole_runs: trust,
            ..Default::default()
        };
        march(&slabs_scene(step, shaded, false, optimise), (64, 48), 0)
    };
    for step in [0.125, 0.5, 2.0] {
        for shaded in [false, true] {
            for wide_lanes in [true, false] {
                let (tested, none) = render(step, shaded, wide_lanes, false);
                let (trusted, taken) = render(step, shaded, wide_lanes, true);
                let what = format!("step {step}, shaded {shaded}, wide {wide_lanes}");
                assert_eq!(tested, trusted, "{what}: runs on trust changed the image");
                assert_eq!(none, 0, "{what}: runs on trust with trust off");
                if step == 0.125 {
                    assert!(taken > 100, "{what}: {taken} runs on trust");
                }
            }
        }
    }
}

/// How many packets a step carries, and so which lane or packet a ray is marched in,
/// changes no pixel ([`Packets::march_tile`]): the slabs, faint and opaque (rays ending
/// early in every packet), at fine and coarse steps, shaded and not, in sixteen lanes and
/// in eight, in one, two and four packets and by default, byte for byte; in an image of
/// few tiles (16×16 pixels) and, on up to two threads, of many (32×32, `packet_tile`).
#[test]
fn packets_carry_rays_without_changing_them() {
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        return;
    }
    for size in [(64, 48), (256, 160)] {
        for opaque in [false, true] {
            for step in [0.125, 0.5, 2.0] {
                for shaded in [false, true] {
                    for wide_lanes in [true, false] {
                        let optimise = crate::model::scene::Optimise {
                            wide_lanes,
                            ..Default::default()
                        };
                        let vl = slabs_scene(step, shaded, opaque, optimise);
                        let by = |packets: usize| march(&vl, size, packets).0;
                        let (one, two, four) = (by(1), by(2), by(4));
                        let image = vl.render_preview(size.0, size.1, 1.2).unwrap();
                        let default = bits(&with_transmittance(&image));
                        let what = format!(
                            "{size:?}, opaque {opaque}, step {step}, shaded {shaded}, \
                             wide {wide_lanes}"
                        );
                        assert_eq!(one, two, "{what}: one packet and two differ");
                        assert_eq!(four, two, "{what}: four packets and two differ");
                        assert_eq!(default, two, "{what}: the default and two packets differ");
                        let background = [0.1f32, 0.2, 0.3].map(f32::to_bits);
                        let shown = default.chunks(4).filter(|p| p[..3] != background).count();
                        let least = (size.0 * size.1 / 6) as usize;
                        assert!(shown > least, "{what}: {shown} pixels show the slabs");
                    }
                }
            }
        }
    }
}

/// The lanes' opacity correction is `t^e` for every exponent `Packets::new` admits, within
/// the f32 rounding of its square roots and products (a few units in the last place of
/// f32: each rounds once, and a square root halves the relative error it is given), in
/// eight lanes and, where the processor has them, sixteen.
#[test]
fn transmit_lanes_are_the_powers() {
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        return;
    }
    // SAFETY: AVX2 and FMA were detected above.
    powers(unsafe { Avx2::new() });
    if detected() {
        // SAFETY: `detected` found every feature `Avx512` stands for.
        powers(unsafe { Avx512::new() });
    }
}

/// [`transmit_lanes_are_the_powers`] in the lanes of `s`.
fn powers<S: Simd<N>, const N: usize>(s: S) {
    for e in [0.5, 1.0, 0.25, 2.0, 0.125, 4.0] {
        for i in 0..=1000 {
            let t: [f32; N] = std::array::from_fn(|k| (i * N + k) as f32 / (1000 * N) as f32);
            let mut got = [0f32; N];
            s.st(&mut got, transmit_lanes(s, e, s.ld(&t)));
            for k in 0..N {
                let want = (t[k] as f64).powf(e);
                let tol = 4.0 * f32::EPSILON as f64 * want;
                assert!(
                    (got[k] as f64 - want).abs() <= tol,
                    "{}^{e}: {} against {want}",
                    t[k],
                    got[k]
                );
            }
        }
    }
}

/// A deterministic stream of numbers in [0, 1) (a 64-bit LCG's top 53 bits).
fn uniform(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

/// `power(b, e)` is within its bound of `powf` (glibc's, within one unit in the last place of
/// the exact power): a relative 10⁻¹³ where e·ln b ≥ −105, the bound `GUARD` is ten times, over
/// bases from f32's 1 − o (every f32 step near 1, near 2⁻²⁴ and between) and exponents from
/// 0 to 10⁴; below −105 both are under 10⁻⁴⁵.
#[test]
fn power_is_within_its_bounds() {
    let mut state = 7;
    for _ in 0..200_000 {
        let o = match uniform(&mut state) {
            u if u < 0.1 => 1.0 - (uniform(&mut state) * 1e-6) as f32,
            u if u < 0.2 => (uniform(&mut state) * 1e-6) as f32,
            _ => uniform(&mut state) as f32,
        };
        let e = match uniform(&mut state) {
            u if u < 0.5 => uniform(&mut state) * 3.0,
            u => (uniform(&mut state) * 9.2 - 9.2 * (1.0 - u)).exp(),
        };
        let b = 1.0 - o as f64;
        if b <= 0.0 {
            continue;
        }
        let (got, want) = (power(b, e), b.powf(e));
        let y = e * b.ln();
        let rel = (got - want).abs() / want;
        if y >= -105.0 {
            assert!(
                rel <= GUARD / 10.0,
                "{b}^{e}: {got} against {want} ({rel:e})"
            );
        } else {
            assert!(
                got <= 1e-45 && want <= 1e-45,
                "{b}^{e}: {got} against {want}"
            );
        }
    }
}

/// `transmit_any` gives every lane `transmit_at_most_one(o, e) as f32` bit for bit, over
/// opacities at every f32 scale (0, near 1, 1, below 0, NaN) and exponents from 0 through
/// 10³⁰⁰, ∞, NaN and negative ones, and over powers within 10⁻¹⁴ of the midpoint between two
/// f32s (where the guard must send the lane to the scalar code: most of them go there); lanes
/// outside `lanes` are left alone; and at most one lane in 10³ of the domain's others goes
/// through the scalar code (the fast path is taken).
#[test]
fn transmit_any_is_the_scalar_power_bit_for_bit() {
    const N: usize = 16;
    let mut state = 11;
    let fixed_e = [
        0.0,
        -0.0,
        1e-12,
        1e-3,
        0.1,
        1.0 / 3.0,
        0.45,
        0.7,
        0.999_999,
        1.000_001,
        1.5,
        2.5,
        3.7,
        7.3,
        17.0,
        99.0,
        1e3,
        1e6,
        1e300,
    ];
    let odd_e = [f64::MAX, f64::INFINITY, f64::NAN, -0.5, -f64::INFINITY];
    let fixed_o = [
        0.0f32,
        1.0,
        1.0 - f32::EPSILON / 2.0,
        f32::MIN_POSITIVE,
        1e-30,
        0.5,
    ];
    // (Outside the domain below 0: the tables give no opacity above 1, which
    // `transmit_at_most_one` asserts.)
    let odd_o = [-1.5f32, -0.25, f32::NAN, f32::NEG_INFINITY];
    let (mut lanes_in_domain, mut scalar_in_domain) = (0u64, 0u64);
    let (mut near_midpoints, mut scalar_near_midpoints) = (0u64, 0u64);
    for round in 0..44_000 {
        let mut o = [0f32; N];
        let mut e = [0f64; N];
        // The last 4000 rounds: each lane's e puts (1 − o)^e at the midpoint of an f32 and
        // the next (to within the rounding of e: a relative 10⁻¹⁴).
        let midpoints = round >= 40_000;
        for k in 0..N {
            if midpoints {
                o[k] = (0.001 + 0.998 * uniform(&mut state)) as f32;
                let f = (uniform(&mut state) * -60.0).exp() as f32;
                let m = 0.5 * (f as f64 + f32::from_bits(f.to_bits() + 1) as f64);
                e[k] = m.ln() / (1.0 - o[k] as f64).ln();
                continue;
            }
            o[k] = match uniform(&mut state) {
                u if u < 0.05 => fixed_o[(uniform(&mut state) * 6.0) as usize],
                u if u < 0.06 => odd_o[(uniform(&mut state) * 4.0) as usize],
                u if u < 0.2 => 1.0 - (uniform(&mut state) * 1e-5) as f32,
                _ => uniform(&mut state) as f32,
            };
            e[k] = match uniform(&mut state) {
                u if u < 0.1 => fixed_e[(uniform(&mut state) * 19.0) as usize],
                u if u < 0.11 => odd_e[(uniform(&mut state) * 5.0) as usize],
                _ => uniform(&mut state) * 4.0,
            };
        }
        let lanes = if round % 7 == 0 { 0x5a5a } else { 0xffff };
        let mut t = [-7f32; N];
        let scalar = transmit_any(&o, &e, lanes, &mut t);
        for k in 0..N {
            if lanes >> k & 1 == 0 {
                assert_eq!(
                    t[k].to_bits(),
                    (-7f32).to_bits(),
                    "lane {k} was not asked for"
                );
                continue;
            }
            let want = transmit_at_most_one(o[k] as f64, e[k]) as f32;
            assert_eq!(
                t[k].to_bits(),
                want.to_bits(),
                "(1 − {})^{}: {} against {want}",
                o[k],
                e[k],
                t[k]
            );
            let base = 1.0 - o[k] as f64;
            if midpoints {
                near_midpoints += 1;
                scalar_near_midpoints += u64::from(scalar >> k & 1);
            } else if base > 0.0 && base <= 1.0 && e[k] >= 0.0 && e[k].is_finite() {
                lanes_in_domain += 1;
                scalar_in_domain += u64::from(scalar >> k & 1);
            }
        }
    }
    assert!(
        scalar_in_domain * 1000 <= lanes_in_domain,
        "{scalar_in_domain} of {lanes_in_domain} lanes through the scalar code"
    );
    assert!(
        scalar_near_midpoints * 10 >= near_midpoints * 9,
        "only {scalar_near_midpoints} of {near_midpoints} lanes near a midpoint through the scalar code"
    );
}

/// The packet march in strips: an image rendered in strips of 32 rows is the one-strip image
/// bit for bit, with one ray a pixel and super-sampled (whose refinement, in packets too,
/// compares each pixel with the rows above and below across the strips' edges).
#[test]
fn packet_strips_change_no_pixel() {
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        return;
    }
    for super_sample in [1, 3] {
        let mut vl = slabs_scene(0.5, true, false, Default::default());
        vl.super_sample(super_sample).unwrap();
        let scene = vl.compiled().unwrap();
        assert!(Packets::new(&scene).is_some());
        let size = (70, 101);
        let (whole, _) = crate::render::tests::in_strips(&scene, size, 128);
        let (strips, starts) = crate::render::tests::in_strips(&scene, size, 32);
        assert_eq!(starts, [0, 32, 64, 96]);
        assert!(
            bits(&whole) == bits(&strips),
            "super-sampling {super_sample}"
        );
        assert!(
            whole.iter().any(|p| p != &whole[0]),
            "an image, not a colour"
        );
    }
}

/// Nodes read from 16-bit voxels through their table (`Dataset::table16`) are the node values
/// bit for bit: `Nodes::row4` and `Nodes::pairs2` of every lane, at random indices (negative
/// and past the end ones among them, which both clamp alike), from voxels over the whole
/// 16-bit range and a normalisation that clamps some of them to 0 and 1.
#[test]
fn nodes_of_16_bit_voxels_are_the_node_values() {
    if !is_x86_feature_detected!("avx2") {
        return;
    }
    use crate::data::{Dataset, Voxels};
    let rng = crate::testing::Xorshift::new(5);
    let dims = [9usize, 7, 6];
    let n = dims.iter().product::<usize>();
    let raw: Vec<u16> = (0..n).map(|_| rng.bits() as u16).collect();
    let data = Dataset::new(dims, Voxels::U16(raw.clone()), 1000.0, 60000.0).unwrap();
    let table = data.table16().expect("16-bit voxels have a table");
    let values = data.values();
    let (from_raw, from_values) = (NodeValues::U16(&raw, table), NodeValues::F32(values));
    let span = 1 + 9 + 63;
    let same = |a: [__m256; 4], b: [__m256; 4]| {
        let bits = |r: [__m256; 4]| {
            r.map(|x| {
                let mut out = [0f32; 8];
                // SAFETY: `out` holds eight f32; the store has no alignment requirement.
                unsafe { _mm256_storeu_ps(out.as_mut_ptr(), x) };
                out.map(f32::to_bits)
            })
        };
        bits(a) == bits(b)
    };
    for _ in 0..200 {
        let at: [i32; 8] = std::array::from_fn(|_| (rng.bits() % (n as u64 + 40)) as i32 - 20);
        // SAFETY: the processor has AVX2 (checked above), all these functions need.
        unsafe {
            let at = _mm256_loadu_si256(at.as_ptr() as *const __m256i);
            let (a, b) = (
                Nodes::new(from_raw, at, span),
                Nodes::new(from_values, at, span),
            );
            for off in [0, 5, span - 3] {
                assert!(same(a.row4(off), b.row4(off)), "row4 at offset {off}");
            }
            for (p, q) in [(0, 9), (63, 72), (1, span - 1)] {
                assert!(same(a.pairs2(p, q), b.pairs2(p, q)), "pairs2 {p}, {q}");
            }
        }
    }
    // The normalisation clamps: some voxels are below a = 1000 and above b = 60000.
    assert!(raw.iter().any(|&v| v < 1000) && raw.iter().any(|&v| v > 60000));
    assert!(data.table16().is_some());
    let bytes = Dataset::new(dims, Voxels::U8(vec![0; n]), 0.0, 255.0).unwrap();
    assert!(bytes.table16().is_none(), "8-bit voxels have no table");
}

/// The gradient's central differences read from 16-bit voxels ([`Raw16::differences`]) are the
/// voxels' integer differences exactly (an independent count: each corner node's neighbours
/// read by index, subtracted as i64), in every lane of random interior cells of voxels over
/// the whole 16-bit range; scaled by the normalisation's slope they are within two f32
/// roundings of the exact differences of normalised values, where node values' differences err
/// over a thousand times more; a normalisation that would clamp some voxel reads the node
/// values instead, and a decreasing one scales by its negative slope.
#[test]
fn differences_of_16_bit_voxels_are_exact() {
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        return;
    }
    use crate::data::{Dataset, Filter, Voxels};
    let rng = crate::testing::Xorshift::new(11);
    let dims = [9usize, 7, 6];
    let (sy, sz) = (dims[0], dims[0] * dims[1]);
    let n = dims.iter().product::<usize>();
    let raw: Vec<u16> = (0..n).map(|_| rng.bits() as u16).collect();
    let extremes = |d: &Dataset| d.bricks(Filter::Trilinear).raw_extremes();
    let lo = *raw.iter().min().unwrap() as f64;
    let hi = *raw.iter().max().unwrap() as f64;
    let data = Dataset::new(dims, Voxels::U16(raw.clone()), 0.0, 65535.0).unwrap();
    assert_eq!(
        extremes(&data),
        (lo, hi),
        "the brick ranges' extremes are the voxels'"
    );
    let r16 = Raw16::of(&data, extremes(&data)).expect("no voxel clamps");
    assert_eq!(r16.scale, (1.0 / 65535.0f64) as f32);
    let at = |x: usize, y: usize, z: usize| raw[x + sy * y + sz * z] as i64;
    for _ in 0..200 {
        // Interior cells: first node in [1, n − 3] per axis.
        let cells: [[usize; 3]; 8] =
            std::array::from_fn(|_| dims.map(|d| 1 + (rng.bits() as usize) % (d - 3)));
        let base: [i32; 8] = cells.map(|[x, y, z]| (x + sy * y + sz * z) as i32);
        let live = 0b1011_1111u32;
        // SAFETY: the processor has AVX2 and FMA (checked above: the packet march asks both).
        let d = unsafe {
            let s = Avx2::new();
            r16.differences(s, s.ld_i(&base), live, sy as i32, sz as i32)
        };
        for (k, dk) in d.iter().enumerate() {
            let (a, b, c) = (k & 1, k >> 1 & 1, k >> 2);
            for (axis, da) in dk.iter().enumerate() {
                let mut out = [0f32; 8];
                // SAFETY: `out` holds eight f32; the store has no alignment requirement.
                unsafe { _mm256_storeu_ps(out.as_mut_ptr(), *da) };
                for (l, &[x, y, z]) in cells.iter().enumerate() {
                    if live >> l & 1 == 0 {
                        continue;
                    }
                    let [x, y, z] = [x + a, y + b, z + c];
                    let e = [(1, 0, 0), (0, 1, 0), (0, 0, 1)][axis];
                    let want = at(x + e.0, y + e.1, z + e.2) - at(x - e.0, y - e.1, z - e.2);
                    assert_eq!(out[l], want as f32, "corner {k}, axis {axis}, lane {l}");
                }
            }
        }
    }
    // Scaled by the slope, an integer difference is within two f32 roundings of the exact
    // difference of normalised values (the slope's and the product's), where the difference
    // of two node values rounded to f32 errs by up to an ulp of the values: over pairs of
    // neighbours one to sixteen units apart, the node values' worst relative error is over a
    // thousand times the scaled integers'.
    let table = data.table16().expect("16-bit voxels have a table");
    let (mut worst_raw, mut worst_table) = (0f64, 0f64);
    for _ in 0..10_000 {
        let v0 = 32768 + (rng.bits() % 30000) as i64;
        let v1 = v0 + 1 + (rng.bits() % 16) as i64;
        let exact = (v1 - v0) as f64 / 65535.0;
        let raw = ((v1 - v0) as f32 * r16.scale) as f64;
        let nodes = (table[v1 as usize] - table[v0 as usize]) as f64;
        worst_raw = worst_raw.max((raw - exact).abs() / exact);
        worst_table = worst_table.max((nodes - exact).abs() / exact);
    }
    // (Two roundings of at most 2⁻²⁴ each: f32::EPSILON = 2⁻²³.)
    assert!(worst_raw <= f32::EPSILON as f64, "{worst_raw}");
    assert!(
        worst_table > 1000.0 * worst_raw,
        "{worst_table} against {worst_raw}"
    );
    // A normalisation from 1000 to 60000 clamps the voxels outside: none read raw.
    assert!(lo < 1000.0 && hi > 60000.0);
    let clamps = Dataset::new(dims, Voxels::U16(raw.clone()), 1000.0, 60000.0).unwrap();
    assert!(Raw16::of(&clamps, extremes(&clamps)).is_none());
    // Decreasing (b < a) over every voxel: the slope −1/65535.
    let down = Dataset::new(dims, Voxels::U16(raw), 65535.0, 0.0).unwrap();
    let r16 = Raw16::of(&down, extremes(&down)).expect("no voxel clamps");
    assert_eq!(r16.scale, (-1.0 / 65535.0f64) as f32);
    let bytes = Dataset::new(dims, Voxels::U8(vec![0; n]), 0.0, 255.0).unwrap();
    assert!(
        Raw16::of(&bytes, (0.0, 0.0)).is_none(),
        "8-bit voxels are not 16-bit ones"
    );
}

/// The cell nodes read from 16-bit voxels by [`Raw16::cell_nodes`] (the voxels normalised in f32
/// lanes) are the node values bit for bit, in every lane of random cells (the grid's first and
/// last among them), where the check of every voxel finds the lanes' normalisation exact: from 0
/// to 65535, from 1000 to 60000 over voxels inside it, decreasing. From 0.1 to 65535.3, where
/// some quotients round to another f32 than the node values, the table is read instead.
#[test]
fn cell_nodes_of_16_bit_voxels_are_the_node_values() {
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        return;
    }
    use crate::data::{Dataset, Filter, Voxels};
    let rng = crate::testing::Xorshift::new(17);
    let dims = [9usize, 7, 6];
    let (sy, sz) = (dims[0], dims[0] * dims[1]);
    let n = dims.iter().product::<usize>();
    let extremes = |d: &Dataset| d.bricks(Filter::Trilinear).raw_extremes();
    for (lo, span, a, b) in [
        (0u64, 65536u64, 0.0f32, 65535.0f32),
        (1000, 59001, 1000.0, 60000.0),
        (0, 65536, 65535.0, 0.0),
    ] {
        let raw: Vec<u16> = (0..n).map(|_| (lo + rng.bits() % span) as u16).collect();
        let data = Dataset::new(dims, Voxels::U16(raw), a, b).unwrap();
        let r16 = Raw16::of(&data, extremes(&data)).expect("no voxel clamps");
        assert!(r16.exact(), "{a} to {b}: the lanes' normalisation is exact");
        let values = data.values();
        for round in 0..100 {
            let cells: [[usize; 3]; 8] = std::array::from_fn(|l| match (round, l) {
                (0, 0) => [0; 3],
                (0, 1) => dims.map(|d| d - 2),
                _ => dims.map(|d| (rng.bits() as usize) % (d - 1)),
            });
            let base: [i32; 8] = cells.map(|[x, y, z]| (x + sy * y + sz * z) as i32);
            // SAFETY: the processor has AVX2 and FMA (checked above).
            let nodes = unsafe {
                let s = Avx2::new();
                r16.cell_nodes(s, s.ld_i(&base), sy as i32, sz as i32)
            };
            for (k, node) in nodes.iter().enumerate() {
                let mut out = [0f32; 8];
                // SAFETY: `out` holds eight f32; the store has no alignment requirement.
                unsafe { _mm256_storeu_ps(out.as_mut_ptr(), *node) };
                for (l, &[x, y, z]) in cells.iter().enumerate() {
                    let at = (x + (k & 1)) + sy * (y + (k >> 1 & 1)) + sz * (z + (k >> 2));
                    assert_eq!(out[l].to_bits(), values[at].to_bits(), "node {k}, lane {l}");
                }
            }
        }
    }
    // (Voxels from 1: the normalisation clamps none.)
    let raw: Vec<u16> = (0..n).map(|_| (1 + rng.bits() % 65535) as u16).collect();
    let data = Dataset::new(dims, Voxels::U16(raw), 0.1, 65535.3).unwrap();
    let r16 = Raw16::of(&data, extremes(&data)).expect("no voxel clamps");
    assert!(
        !r16.exact(),
        "some quotient rounds to another f32 than its node value"
    );
}

/// Past [`MAX_PACKET_SAMPLES`] samples a ray (the object's world diagonal over its step) the
/// scalar march traces every ray: the lanes' f32 composite drifts by about 2⁻²⁴ a sample.
#[test]
fn rays_of_more_samples_than_the_bound_take_the_scalar_march() {
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        return;
    }
    let vl = slabs_scene(1.0, true, false, Default::default());
    let scene = vl.compiled().unwrap();
    let diagonal = scene.objects[0].world_diagonal();
    assert!(Packets::new(&scene).is_some());
    for (samples, packets) in [(0.99, true), (1.01, false)] {
        let step = (diagonal / (samples * MAX_PACKET_SAMPLES)) as f32;
        let vl = slabs_scene(step, true, false, Default::default());
        let scene = vl.compiled().unwrap();
        assert_eq!(Packets::new(&scene).is_some(), packets, "step {step}");
    }
}

/// Once a render is to stop, super-sampling's packet refinement starts no run of rays (a run
/// is up to 16·n² rays too short to look at the flag themselves: a cancelled 32² render at
/// n = 16 went on for up to half a second): every pixel of a tile is refined while the flag
/// is clear, and none once it is set.
#[test]
fn a_cancel_stops_super_sampling_runs_in_packets() {
    use crate::control::{working_for, CancelFlag, Progress, RenderControl};
    use crate::render::{tiles::view, Backdrop, FineRays, Recycled};
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        return;
    }
    let mut vl = slabs_scene(0.5, true, false, Default::default());
    vl.super_sample(4).unwrap();
    let scene = vl.compiled().unwrap();
    let packets = Packets::new(&scene).unwrap();
    let (side, n) = (16u32, 4u32);
    let fine = view(&scene.settings, side * n, side * n, 1.0);
    let image = scene.image_rays(fine.eye, Backdrop::Background);
    let recycled = Recycled::default();
    let rays = FineRays {
        packets: &packets,
        fine: &fine,
        image: &image,
        unbounded: None,
        recycled: &recycled,
        n,
    };
    let flag = CancelFlag::new();
    let control = RenderControl {
        cancel: Some(flag.clone()),
        progress: None,
    };
    let progress = Progress::new(&control, (side * side) as u64);
    let refine = || {
        let zeros = vec![[0.0f32; 4]; (side * side) as usize];
        let (first, every, none) = (|_, _| [0.0; 4], |_, _| true, |_| None);
        working_for(&progress, || {
            rays.refine_tile((0, 0, side, side), zeros, &first, &every, &none)
        })
    };
    // Every pixel refined: each is its rays' mean, whose transmittance is above 0 here or
    // whose colour is (a ray that misses shows the background, 0.1, 0.2, 0.3).
    assert!(refine().iter().all(|p| p != &[0.0; 4]));
    flag.cancel();
    assert!(refine().iter().all(|p| p == &[0.0; 4]));
}
