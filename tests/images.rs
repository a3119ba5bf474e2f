//! The image outputs (`docs/images.md`) read back with independent decoders (zune-png with its
//! own inflate, zune-ppm for 16-bit PPM and PFM; not the `image` crate that writes them) and
//! compared with the closed form of a scene: four bands of constant opacity and colour in a
//! slab, where a ray's transmittance is Beer–Lambert's `T = (1 − o)^(ℓ / reference)` for the
//! length ℓ it travels in the slab. RGB files hold `c·(1 − T) + T·background`, RGBA files
//! alpha `1 − T` and straight colour `c`, PFM the float values bottom row first. Also: 8-bit
//! files are the 16-bit ones rounded, an RGBA image composited over a background is the scene
//! rendered over it (scalar and packet march), the in-memory renders are the files byte for
//! byte, and the refusals of bad names, sizes and buffers.

#[path = "common/dirs.rs"]
mod dirs;
use std::path::Path;
use vlib::{Backdrop, Camera, Dataset, ErrorCode, Fields, Library, PixelFormat, Voxels};
use vlib::{DatasetId, MappingId};
use zune_core::bytestream::ZCursor;
use zune_core::result::DecodingResult;

/// The image size (an even height: zune-ppm 0.5 flips a PFM of odd height wrongly).
const W: u32 = 48;
const H: u32 = 36;
/// The eye's distance from the slab, the field of view, the slab's depth and the opacity
/// reference.
const EYE: f64 = 1000.0;
const FOV: f32 = 16.0;
const DEPTH: f64 = 10.0;
const REFERENCE: f64 = 5.0;
/// The bands' opacities and colours, left to right, each 70 units wide from x = −200.
const OPACITY: [f32; 4] = [0.6, 0.3, 0.1, 0.02];
const COLOUR: [[f32; 3]; 4] = [
    [0.9, 0.2, 0.1],
    [0.1, 0.8, 0.3],
    [0.2, 0.3, 0.9],
    [0.7, 0.7, 0.2],
];
const BAND: f64 = 70.0;
const LEFT: f64 = -200.0;
/// The background of the RGB images.
const BACKGROUND: [f32; 3] = [0.25, 0.5, 0.125];

/// The library with the band scene open (at scene scope), over `background`.
fn bands(background: [f32; 3]) -> Library {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [0.0, 0.0, -EYE as f32],
        at: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov: FOV,
    })
    .unwrap();
    let [r, g, b] = background;
    vl.background(r, g, b).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.step_size(0.7, REFERENCE as f32).unwrap();
    vl.object().unwrap();
    vl.translate(0.0, -0.5, 0.0).unwrap();
    vl.scale(4.0 * BAND as f32, 400.0, DEPTH as f32).unwrap();
    vl.translate(LEFT as f32, 0.0, 0.0).unwrap();
    vl.function(Fields::O | Fields::COLORS | Fields::KA, |s| {
        let k = ((s.position()[0] * 4.0).floor() as usize).min(3);
        s.set(Fields::O, OPACITY[k]).unwrap();
        s.set(Fields::R, COLOUR[k][0]).unwrap();
        s.set(Fields::G, COLOUR[k][1]).unwrap();
        s.set(Fields::B, COLOUR[k][2]).unwrap();
        s.set(Fields::KA, 1.0).unwrap();
    })
    .unwrap();
    vl.end().unwrap();
    vl
}

/// What the ray through pixel (x, y) meets: `Some((band, T))` where it stays in one band
/// (with a margin) through the slab, `None` where it misses the slab, and `Err(())` for the
/// pixels near a band's edge, which the closed form does not describe.
fn ray(x: u32, y: u32) -> Result<Ray, ()> {
    let half = (FOV as f64 / 2.0).to_radians().tan();
    let (hw, hh) = (half * W as f64 / H as f64, half);
    let sx = ((x as f64 + 0.5) / W as f64 * 2.0 - 1.0) * hw;
    let sy = (1.0 - (y as f64 + 0.5) / H as f64 * 2.0) * hh;
    let norm = (sx * sx + sy * sy + 1.0).sqrt();
    let band_at = |z: f64| {
        let wx = (EYE + z) * sx;
        let u = (wx - LEFT) / BAND;
        let k = u.floor();
        let inside = (0.0..4.0).contains(&k);
        let margin = (u - k).min(k + 1.0 - u) * BAND;
        (
            inside.then_some(k as usize),
            margin > 1.0 || !(-1.0..5.0).contains(&u),
        )
    };
    match (band_at(0.0), band_at(DEPTH)) {
        ((None, true), (None, true)) => Ok(None),
        ((Some(a), true), (Some(b), true)) if a == b => {
            let length = DEPTH * norm;
            Ok(Some((
                a,
                (1.0 - OPACITY[a] as f64).powf(length / REFERENCE),
            )))
        }
        _ => Err(()),
    }
}

/// What the closed form says of a pixel's ray: its band and transmittance, or `None` where
/// it misses the slab.
type Ray = Option<(usize, f64)>;

/// Every pixel the closed form describes: (x, y, its ray); and checks that each band and the
/// outside have some.
fn described() -> Vec<(u32, u32, Ray)> {
    let all: Vec<_> = (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .filter_map(|(x, y)| ray(x, y).ok().map(|r| (x, y, r)))
        .collect();
    for band in [Some(0), Some(1), Some(2), Some(3), None] {
        let n = all.iter().filter(|p| p.2.map(|r| r.0) == band).count();
        assert!(n >= 40, "band {band:?}: {n} pixels");
    }
    all
}

/// The closed form of pixel `p` as (premultiplied colour, alpha) against a transparent
/// backdrop, and as colour over `background`.
fn exact(p: Ray, background: [f32; 3]) -> ([f64; 3], f64, [f64; 3]) {
    let (c, t) = match p {
        Some((k, t)) => (COLOUR[k].map(|v| v as f64), t),
        None => ([0.0; 3], 1.0),
    };
    let pre = c.map(|v| v * (1.0 - t));
    let over = std::array::from_fn(|i| pre[i] + t * background[i] as f64);
    (pre, 1.0 - t, over)
}

/// A decoded image: width, height, channels, samples (8-bit ones widened).
struct Decoded {
    width: usize,
    height: usize,
    channels: usize,
    bits: u32,
    samples: Vec<u32>,
}

impl Decoded {
    /// Sample `c` of pixel (x, y) in [0, 1].
    fn at(&self, x: u32, y: u32, c: usize) -> f64 {
        let i = (y as usize * self.width + x as usize) * self.channels + c;
        self.samples[i] as f64 / ((1u64 << self.bits) - 1) as f64
    }
}

/// A PNG decoded by zune-png.
fn png(path: &Path) -> Decoded {
    let bytes = std::fs::read(path).unwrap();
    let mut d = zune_png::PngDecoder::new(ZCursor::new(&bytes[..]));
    let out = d.decode().unwrap();
    let (width, height) = d.dimensions().unwrap();
    let channels = d.colorspace().unwrap().num_components();
    let (bits, samples) = integer_samples(out, path);
    Decoded {
        width,
        height,
        channels,
        bits,
        samples,
    }
}

/// The bit depth and the samples of an 8- or 16-bit decoding of `path`.
fn integer_samples(out: DecodingResult, path: &Path) -> (u32, Vec<u32>) {
    match out {
        DecodingResult::U8(v) => (8, v.into_iter().map(u32::from).collect()),
        DecodingResult::U16(v) => (16, v.into_iter().map(u32::from).collect()),
        _ => panic!("{}: neither 8 nor 16 bits", path.display()),
    }
}

/// A PPM (8 or 16 bits) or PFM decoded by zune-ppm: integer samples, or floats.
fn pnm(path: &Path) -> (usize, usize, DecodingResult) {
    let bytes = std::fs::read(path).unwrap();
    let mut d = zune_ppm::PPMDecoder::new(ZCursor::new(&bytes[..]));
    let out = d.decode().unwrap();
    let (w, h) = d.dimensions().unwrap();
    assert_eq!(d.colorspace().unwrap().num_components(), 3);
    (w, h, out)
}

/// A PPM as a [`Decoded`].
fn ppm(path: &Path) -> Decoded {
    let (width, height, out) = pnm(path);
    let (bits, samples) = integer_samples(out, path);
    Decoded {
        width,
        height,
        channels: 3,
        bits,
        samples,
    }
}

/// A PFM's floats, top row first (zune-ppm turns the file's bottom-up rows around).
fn pfm(path: &Path) -> (usize, usize, Vec<f32>) {
    let (w, h, out) = pnm(path);
    let DecodingResult::F32(v) = out else {
        panic!("{}: not floats", path.display())
    };
    (w, h, v)
}

/// Every format of the table in docs/images.md, each requested by `vlImage` of one scene and
/// read back: dimensions, channels and depth, and each described pixel against the closed
/// form within the quantisation (half a step) plus 2·10⁻⁵ (the renderer's single-precision
/// rounding; straight colour, divided by alpha, within that over alpha).
#[test]
fn every_format_reads_back_as_the_closed_form() {
    let dir = dirs::scratch("images", "formats");
    let names = [
        ("a.ppm", 3, 8),
        ("a.png", 3, 8),
        ("a.rgb16.png", 3, 16),
        ("a.RGB16.ppm", 3, 16),
        ("a.rgba.png", 4, 8),
        ("a.rgba16.png", 4, 16),
    ];
    let mut vl = bands(BACKGROUND);
    for (name, _, _) in names {
        vl.image(dir.join(name), W as f32 / H as f32, W as i32, H as i32)
            .unwrap();
    }
    vl.image(dir.join("a.pfm"), W as f32 / H as f32, W as i32, H as i32)
        .unwrap();
    vl.end().unwrap();
    let pixels = described();
    for (name, channels, bits) in names {
        let path = dir.join(name);
        let d = if name.ends_with(".png") {
            png(&path)
        } else {
            ppm(&path)
        };
        assert_eq!((d.width, d.height), (W as usize, H as usize), "{name}");
        assert_eq!((d.channels, d.bits), (channels, bits), "{name}");
        let step = 0.5 / ((1u64 << bits) - 1) as f64;
        for &(x, y, p) in &pixels {
            let (_, alpha, over) = exact(p, BACKGROUND);
            let what = format!("{name} ({x}, {y}) {p:?}");
            if channels == 3 {
                for (c, want) in over.iter().enumerate() {
                    let got = d.at(x, y, c);
                    assert!((got - want).abs() <= step + 2e-5, "{what}: {got} {want}");
                }
                continue;
            }
            let got = d.at(x, y, 3);
            assert!(
                (got - alpha).abs() <= step + 2e-5,
                "{what}: alpha {got} {alpha}"
            );
            // Straight colour: the band's colour where the slab is, 0 where nothing is.
            let straight = p.map_or([0.0; 3], |(k, _)| COLOUR[k]);
            for (c, want) in straight.iter().map(|&v| v as f64).enumerate() {
                let got = d.at(x, y, c);
                let tol = step + 2e-5 / alpha.max(1e-3);
                assert!(
                    (got - want).abs() <= tol,
                    "{what}: channel {c} {got} {want}"
                );
            }
        }
    }
    // PFM: floats, top row first once turned around, the closed form within 2·10⁻⁵.
    let (w, h, f) = pfm(&dir.join("a.pfm"));
    assert_eq!((w, h), (W as usize, H as usize));
    for &(x, y, p) in &pixels {
        let (_, _, over) = exact(p, BACKGROUND);
        for (c, want) in over.iter().enumerate() {
            let got = f[(y * W + x) as usize * 3 + c] as f64;
            assert!((got - want).abs() <= 2e-5, "pfm ({x}, {y}): {got} {want}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A PFM's header says little-endian (scale −1.0) and its rows run bottom to top: the file's
/// first row is the image's last, read here from the bytes themselves, for an odd height too.
#[test]
fn pfm_is_little_endian_bottom_up() {
    let dir = dirs::scratch("images", "pfm");
    for h in [H, 7] {
        let vl = bands(BACKGROUND);
        let image = vl.render_preview(W, h, W as f32 / h as f32).unwrap();
        image.save(dir.join("b.pfm")).unwrap();
        let bytes = std::fs::read(dir.join("b.pfm")).unwrap();
        let header = format!("PF\n{W} {h}\n-1.0\n");
        assert_eq!(&bytes[..header.len()], header.as_bytes());
        let body = &bytes[header.len()..];
        assert_eq!(body.len(), (W * h * 12) as usize);
        for (i, v) in body.chunks(4).enumerate() {
            let (row, rest) = (i / (W as usize * 3), i % (W as usize * 3));
            let (x, c) = (rest / 3, rest % 3);
            let want = image.pixel(x as u32, h - 1 - row as u32)[c];
            let got = f32::from_le_bytes([v[0], v[1], v[2], v[3]]);
            assert_eq!(got.to_bits(), want.to_bits(), "row {row} x {x} c {c}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A scene of many distinct values: a lit, half-transparent ball whose colour is its
/// position, seen at an angle, super-sampled `n`×`n`, over a grey background.
fn ball(n: i32) -> Library {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [30.0, 80.0, -120.0],
        at: [50.0, 50.0, 50.0],
        up: [0.0, 1.0, 0.0],
        fov: 40.0,
    })
    .unwrap();
    vl.background(0.3, 0.3, 0.35).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 0.4).unwrap();
    vl.directional_light([0.4, -1.0, 0.6], [1.0, 0.9, 0.8], 0.9)
        .unwrap();
    vl.super_sample(n).unwrap();
    vl.step_size(0.5, 1.0).unwrap();
    vl.object().unwrap();
    vl.scale(100.0, 100.0, 100.0).unwrap();
    vl.function(Fields::ALL, |s| {
        let p = s.position();
        let v = vlib::vlaux::sphere(p);
        s.set(Fields::F, v).unwrap();
        s.set(Fields::O, (v - 0.5).max(0.0) * 0.1).unwrap();
        s.set(Fields::R, p[0]).unwrap();
        s.set(Fields::G, p[1]).unwrap();
        s.set(Fields::B, p[2]).unwrap();
        s.set(Fields::KA, 1.0).unwrap();
        s.set(Fields::KD, 0.8).unwrap();
    })
    .unwrap();
    vl.end().unwrap();
    vl
}

/// The 8-bit files are the 16-bit ones rounded (`round(v16 / 257)`), channel for channel, RGB
/// and RGBA alike, decoded from the files; in an image of thousands of distinct values.
#[test]
fn eight_bits_are_sixteen_rounded() {
    let dir = dirs::scratch("images", "depths");
    let mut vl = ball(2);
    for name in ["c.png", "c.rgb16.png", "c.rgba.png", "c.rgba16.png"] {
        vl.image(dir.join(name), 1.0, 64, 64).unwrap();
    }
    vl.end().unwrap();
    for (eight, sixteen) in [("c.png", "c.rgb16.png"), ("c.rgba.png", "c.rgba16.png")] {
        let (a, b) = (png(&dir.join(eight)), png(&dir.join(sixteen)));
        assert_eq!((a.bits, b.bits, a.channels), (8, 16, b.channels));
        let rounded: Vec<u32> = b
            .samples
            .iter()
            .map(|&v| (v * 255 + 32767) / 65535)
            .collect();
        assert_eq!(a.samples, rounded, "{eight} against {sixteen}");
        let distinct: std::collections::HashSet<_> = b.samples.iter().collect();
        assert!(
            distinct.len() > 1000,
            "{sixteen}: {} values",
            distinct.len()
        );
        let alpha = a.channels == 4;
        let partial = (0..a.samples.len() / a.channels)
            .filter(|i| alpha && (1..255).contains(&a.samples[i * 4 + 3]))
            .count();
        assert!(
            !alpha || partial > 500,
            "{eight}: {partial} partly covered pixels"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A scanned volume (a dataset through a transfer function: the packet march where the
/// processor has it) whose opacity rises along x, so alpha takes many values.
fn scanned(background: [f32; 3], packets: bool) -> Library {
    let n = 24usize;
    let raw: Vec<u8> = (0..n * n * n)
        .map(|i| ((i % n) * 255 / (n - 1)) as u8)
        .collect();
    let mut vl = Library::new();
    vl.add_dataset(
        DatasetId(1),
        Dataset::new([n; 3], Voxels::U8(raw), 0.0, 255.0).unwrap(),
    )
    .unwrap();
    let ramp = vlib::MappingType::Ramp;
    vl.mapping(MappingId(1), ramp, 2, 1, &[0.0, 0.9, 1.0, 0.2])
        .unwrap();
    let colours = [0.0, 0.9, 0.2, 0.1, 1.0, 0.2, 0.6, 1.0];
    vl.mapping(MappingId(2), ramp, 2, 3, &colours).unwrap();
    vl.scene().unwrap();
    vl.set_optimise(vlib::Optimise {
        packets,
        ..Default::default()
    })
    .unwrap();
    let [r, g, b] = background;
    vl.background(r, g, b).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.camera(&Camera {
        eye: [12.0, 30.0, -50.0],
        at: [11.5, 11.5, 11.5],
        up: [0.0, 1.0, 0.0],
        fov: 50.0,
    })
    .unwrap();
    vl.step_size(0.5, 4.0).unwrap();
    vl.object().unwrap();
    vl.scale(23.0, 23.0, 23.0).unwrap();
    vl.dataset(Fields::F, DatasetId(1)).unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    vl.map(Fields::R, Fields::F, MappingId(2), 1).unwrap();
    vl.map(Fields::G, Fields::F, MappingId(2), 2).unwrap();
    vl.map(Fields::B, Fields::F, MappingId(2), 3).unwrap();
    vl.set(Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    vl
}

/// A glass ball (surfaces that refract, opacity 0.3) over nothing: its pixels' rays bend and
/// leave the scene, so their transmittance is followed through the refractions.
fn glass(background: [f32; 3]) -> Library {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.camera(&Camera {
        eye: [50.0, 60.0, -150.0],
        at: [50.0, 50.0, 50.0],
        up: [0.0, 1.0, 0.0],
        fov: 40.0,
    })
    .unwrap();
    let [r, g, b] = background;
    vl.background(r, g, b).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.render_type(vlib::RenderType::Dsr).unwrap();
    vl.surface(Fields::F, 0.5).unwrap();
    vl.toggle(vlib::Feature::Refract, true).unwrap();
    vl.step_size(0.5, 1.0).unwrap();
    vl.object().unwrap();
    vl.scale(100.0, 100.0, 100.0).unwrap();
    vl.function(Fields::F, |s| {
        let v = vlib::vlaux::sphere(s.position());
        s.set(Fields::F, v).unwrap();
    })
    .unwrap();
    vl.set(Fields::O, 0.3).unwrap();
    vl.set(Fields::R, 0.8).unwrap();
    vl.set(Fields::G, 0.6).unwrap();
    vl.set(Fields::B, 0.2).unwrap();
    vl.set(Fields::KA, 1.0).unwrap();
    vl.set(Fields::RF, vlib::types::refraction_to_field(1.5))
        .unwrap();
    vl.end().unwrap();
    vl
}

/// Compositing works: the 16-bit RGBA file of a scene, decoded and laid over a background B
/// (`straight·α + (1 − α)·B`), is the scene rendered over B within 1.5 steps of 16 bits
/// (the colour's and alpha's rounding), for two backgrounds, for the field-function bands,
/// the lit ball, the glass ball (transmittance through refractions) and the scanned volume
/// with and without the packet march; and the float RGBA
/// render (premultiplied: `C + (1 − α)·B`) is it within 10⁻⁵. (Without super-sampling: its
/// refinement depends on what the pixels are compared in, `docs/images.md`.)
#[test]
fn rgba_composited_over_a_background_is_the_render_over_it() {
    let dir = dirs::scratch("images", "over");
    type Scene<'a> = &'a dyn Fn([f32; 3]) -> Library;
    let scenes: [(&str, Scene); 5] = [
        ("bands", &bands),
        ("ball", &|_| ball(1)),
        ("glass", &glass),
        ("scanned", &|b| scanned(b, false)),
        ("packets", &|b| scanned(b, true)),
    ];
    for (name, scene) in scenes {
        for background in [[0.0f32, 0.0, 0.0], [0.9, 0.4, 0.7]] {
            let mut vl = scene(background);
            vl.background(background[0], background[1], background[2])
                .unwrap();
            let over = vl.render_preview(W, H, 1.2).unwrap();
            let clear = vl.render(W, H, 1.2, Backdrop::Transparent).unwrap();
            let path = dir.join(format!("{name}.rgba16.png"));
            clear.save(&path).unwrap();
            let d = png(&path);
            let floats = clear.to_rgba_f32();
            let mut covered = 0;
            for (y, x) in (0..H).flat_map(|y| (0..W).map(move |x| (y, x))) {
                let a = d.at(x, y, 3);
                covered += (a > 0.0) as usize;
                let i = (y * W + x) as usize;
                for (c, &bg) in background.iter().enumerate() {
                    let want = over.pixel(x, y)[c] as f64;
                    let got = d.at(x, y, c) * a + (1.0 - a) * bg as f64;
                    let what = format!("{name} over {background:?} ({x}, {y}) c {c}");
                    assert!((got - want).abs() <= 1.5 / 65535.0, "{what}: {got} {want}");
                    let pre =
                        floats[i * 4 + c] as f64 + (1.0 - floats[i * 4 + 3] as f64) * bg as f64;
                    assert!((pre - want).abs() <= 1e-5, "{what}: float {pre} {want}");
                }
            }
            assert!(covered > 100, "{name}: {covered} covered pixels");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The scanned scene with packets on takes the packet march where the processor has it (its
/// single-precision pixels differ from the scalar march's in rounding), so that the
/// compositing test above covers it.
#[test]
fn the_scanned_scene_takes_the_packet_march() {
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
        let bg = [0.1, 0.2, 0.3];
        let a = scanned(bg, true).render(W, H, 1.2, Backdrop::Transparent);
        let b = scanned(bg, false).render(W, H, 1.2, Backdrop::Transparent);
        let (a, b) = (a.unwrap(), b.unwrap());
        let n = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .filter(|(p, q)| p != q)
            .count();
        assert!(n > 50, "{n} pixels differ");
    }
}

/// The in-memory renders are the files byte for byte: `render_into` in each format (and
/// `Image::to_bytes` of `render`) against the decoded PNG and PPM samples and the PFM's
/// floats, of the same open scene; and the bytes past the image in a larger buffer are left
/// as they were.
#[test]
fn in_memory_renders_are_the_files() {
    let dir = dirs::scratch("images", "memory");
    let mut vl = ball(2);
    let (w, h) = (40u32, 30u32);
    let aspect = w as f32 / h as f32;
    let files = [
        ("m.ppm", PixelFormat::Rgb8),
        ("m.rgb16.ppm", PixelFormat::Rgb16),
        ("m.rgba.png", PixelFormat::Rgba8),
        ("m.rgba16.png", PixelFormat::Rgba16),
        ("m.rgb16.png", PixelFormat::Rgb16),
        ("m.pfm", PixelFormat::Rgb32F),
    ];
    let mut buffers = Vec::new();
    for (name, format) in files {
        let bytes = format.image_bytes(w, h).unwrap();
        let mut buffer = vec![0xA5u8; bytes + 7];
        vl.render_into(w, h, aspect, format, &mut buffer).unwrap();
        assert!(
            buffer[bytes..].iter().all(|&b| b == 0xA5),
            "{name}: past the image"
        );
        buffer.truncate(bytes);
        let image = vl.render(w, h, aspect, format.backdrop()).unwrap();
        assert_eq!(
            image.to_bytes(format),
            buffer,
            "{name}: render and render_into"
        );
        buffers.push(buffer);
        vl.image(dir.join(name), aspect, w as i32, h as i32)
            .unwrap();
    }
    vl.end().unwrap();
    for ((name, format), buffer) in files.iter().zip(buffers) {
        let path = dir.join(name);
        let samples: Vec<u8> = match format {
            PixelFormat::Rgb32F => {
                let (_, _, f) = pfm(&path);
                f.iter().flat_map(|v| v.to_ne_bytes()).collect()
            }
            _ => {
                let d = if name.ends_with(".png") {
                    png(&path)
                } else {
                    ppm(&path)
                };
                let wide = d.bits == 16;
                let s = d.samples.iter();
                s.flat_map(|&v| match wide {
                    true => (v as u16).to_ne_bytes().to_vec(),
                    false => vec![v as u8],
                })
                .collect()
            }
        };
        assert!(samples == buffer, "{name}: the file and the buffer differ");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Super-sampling against a transparent backdrop refines where alpha alone changes: a black
/// slab (no light, so its colour is 0 and never differs) seen almost in parallel projection;
/// with one ray a pixel its alpha is 0 or the slab's, with 3×3 its edge pixels get k/9 of
/// the slab's alpha for some k in 1 … 8 (the mean transmittance of the pixel's nine rays).
#[test]
fn supersampling_refines_alpha() {
    let alphas = |n: i32| {
        let mut vl = Library::new();
        vl.scene().unwrap();
        vl.camera(&Camera {
            eye: [0.0, 0.0, -10000.0],
            at: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov: 0.08,
        })
        .unwrap();
        vl.super_sample(n).unwrap();
        vl.object().unwrap();
        vl.translate(-0.5, -0.5, 0.0).unwrap();
        // Its edges 0.594 of a pixel into their pixels (0.58 world units wide).
        vl.scale(10.0, 10.0, 1.0).unwrap();
        vl.set(Fields::O, 0.5).unwrap();
        vl.end().unwrap();
        let image = vl.render(24, 24, 1.0, Backdrop::Transparent).unwrap();
        assert!(image.pixels.iter().all(|p| *p == [0.0; 3]));
        (0..24 * 24)
            .map(|i| image.alpha(i % 24, i / 24))
            .collect::<Vec<_>>()
    };
    let one = alphas(1);
    let whole = one.iter().copied().fold(0.0f32, f32::max);
    assert!(whole > 0.1, "{whole}");
    assert!(one.iter().all(|&a| a == 0.0 || (a - whole).abs() < 1e-5));
    let edges: Vec<f32> = alphas(3)
        .into_iter()
        .filter(|&a| a > 1e-5 && (a - whole).abs() > 1e-5)
        .collect();
    assert!(edges.len() >= 20, "{} edge pixels", edges.len());
    for a in edges {
        let k = a / whole * 9.0;
        assert!(
            (k - k.round()).abs() < 1e-3 && (1.0..=8.0).contains(&k.round()),
            "{a} is {k} ninths"
        );
    }
}

/// Bad names and sizes are refused before anything renders: unknown extensions and modifiers
/// a file type cannot hold (`BadFile`, at `vlImage`), a buffer too small (`BadValue`,
/// nothing written), sizes and aspects `vlImage` refuses, a render outside scene scope
/// (`BadScope`); `write_image` writes 8-bit RGB only.
#[test]
fn refusals() {
    let dir = dirs::scratch("images", "refusals");
    let mut vl = bands(BACKGROUND);
    for bad in ["x.jpg", "x.rgba.ppm", "x.rgb16.pfm", "x.exr", "x"] {
        let e = vl.image(dir.join(bad), 1.0, 4, 4).unwrap_err();
        assert_eq!(e.code, ErrorCode::BadFile, "{bad}");
    }
    let mut small = vec![7u8; 4 * 4 * 4 - 1];
    let e = vl
        .render_into(4, 4, 1.0, PixelFormat::Rgba8, &mut small)
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::BadValue);
    assert!(
        small.iter().all(|&b| b == 7),
        "a refused call writes nothing"
    );
    let mut buffer = vec![7u8; 1 << 16];
    for (w, h, aspect) in [
        (0, 4, 1.0),
        (4, 0, 1.0),
        (4, 4, 0.0),
        (4, 4, f32::NAN),
        (1 << 16, 1, 1.0),
    ] {
        let e = vl
            .render_into(w, h, aspect, PixelFormat::Rgb8, &mut buffer)
            .unwrap_err();
        assert_eq!(e.code, ErrorCode::BadValue, "{w}x{h} {aspect}");
        let e = vl.render(w, h, aspect, Backdrop::Transparent).unwrap_err();
        assert_eq!(e.code, ErrorCode::BadValue, "{w}x{h} {aspect}");
    }
    assert!(buffer.iter().all(|&b| b == 7));
    vl.object().unwrap();
    let e = vl.render(4, 4, 1.0, Backdrop::Background).unwrap_err();
    assert_eq!(e.code, ErrorCode::BadScope);
    vl.end().unwrap();
    vl.end().unwrap();
    let e = vl
        .render_into(4, 4, 1.0, PixelFormat::Rgb8, &mut buffer)
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::BadScope);
    let e = vlib::write_image(&dir.join("w.rgba.png"), 1, 1, &[1, 2, 3]).unwrap_err();
    assert_eq!(e.code, ErrorCode::BadFile);
    let e = vlib::write_image(&dir.join("w.png"), 2, 1, &[1, 2, 3]).unwrap_err();
    assert_eq!(e.code, ErrorCode::BadValue);
    // A PNG's header says each side in 31 bits: 2³¹ is refused before the slice's length (a
    // PPM of that size is refused for the length alone).
    for (name, width, height) in [("w.png", 1 << 31, 1), ("w.png", 1, u32::MAX)] {
        let e = vlib::write_image(&dir.join(name), width, height, &[1, 2, 3]).unwrap_err();
        assert_eq!(e.code, ErrorCode::BadValue);
        assert!(e.message.contains("at most 2147483647"), "{e}");
    }
    let e = vlib::write_image(&dir.join("w.ppm"), 1 << 31, 1, &[1, 2, 3]).unwrap_err();
    assert_eq!(e.code, ErrorCode::BadValue);
    assert!(e.message.contains("bytes for a"), "{e}");
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        0,
        "no file written"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The in-memory renders follow the render control as a scene's outputs do: a progress
/// function hears fractions rising to 1; returning `false`, or a cancel flag, stops the
/// render with `Cancelled`.
#[test]
fn in_memory_renders_follow_the_render_control() {
    use std::sync::{Arc, Mutex};
    let mut vl = bands(BACKGROUND);
    let heard = Arc::new(Mutex::new(Vec::new()));
    let h = heard.clone();
    vl.set_render_control(vlib::RenderControl {
        cancel: None,
        progress: Some(Arc::new(move |f| {
            h.lock().unwrap().push(f);
            true
        })),
    });
    let mut buffer = vec![0u8; 64 * 64 * 16];
    vl.render_into(64, 64, 1.0, PixelFormat::Rgba32F, &mut buffer)
        .unwrap();
    let fractions = heard.lock().unwrap().clone();
    assert!(fractions.windows(2).all(|p| p[0] <= p[1]) && fractions.last() == Some(&1.0));
    let flag = vlib::CancelFlag::new();
    flag.cancel();
    vl.set_render_control(vlib::RenderControl {
        cancel: Some(flag),
        progress: None,
    });
    let e = vl
        .render_into(64, 64, 1.0, PixelFormat::Rgb8, &mut buffer)
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::Cancelled);
    let e = vl.render(64, 64, 1.0, Backdrop::Transparent).unwrap_err();
    assert_eq!(e.code, ErrorCode::Cancelled);
    vl.set_render_control(vlib::RenderControl {
        cancel: None,
        progress: Some(Arc::new(|_| false)),
    });
    let e = vl.render(64, 64, 1.0, Backdrop::Background).unwrap_err();
    assert_eq!(e.code, ErrorCode::Cancelled);
}
