//! The study's scenes: the closed-form ones (a constant medium and a colour ramp in a slab, an
//! iso-sphere) with their exact images, and those measured against a converged reference (the
//! MNI brain, a noise hypertexture, directly and voxelized).

use super::*;

/// The slab of the constant medium and of the linear ramp: z ∈ [0, SLAB], wide enough that every
/// ray of the view enters through its front face and leaves through its back face.
pub(crate) const SLAB: f64 = 20.0;
/// The camera of the slab scenes looks along +z from here.
pub(crate) const SLAB_EYE: f64 = -50.0;
pub(crate) const SLAB_FOV: f32 = 40.0;
pub(crate) const SLAB_BG: [f32; 3] = [0.1, 0.2, 0.4];
/// Opacity per unit length (the reference length is 1) of the constant medium and its colour.
pub(crate) const CONST_O: f32 = 0.05;
pub(crate) const CONST_C: [f32; 3] = [0.9, 0.6, 0.3];
/// The linear ramp: opacity per unit length, colour at the front (z = 0) and back (z = SLAB).
pub(crate) const RAMP_O: f32 = 0.1;
pub(crate) const RAMP_C0: [f32; 3] = [0.95, 0.8, 0.1];
pub(crate) const RAMP_C1: [f32; 3] = [0.05, 0.3, 0.9];

/// The direction of the primary ray through pixel (x, y), as the renderer's view builds it
/// (aspect 1, the camera looking along +z with +y up, so right = +x).
pub(crate) fn pixel_dir(x: u32, y: u32, size: u32, fov: f32) -> [f64; 3] {
    let half = (fov as f64 * 0.5).to_radians().tan();
    let sx = (x as f64 + 0.5) / size as f64 * 2.0 - 1.0;
    let sy = 1.0 - (y as f64 + 0.5) / size as f64 * 2.0;
    let d = [sx * half, sy * half, 1.0];
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    d.map(|v| v / l)
}

/// The slab scene: a constant medium, or (`linear`) constant opacity with colour linear in depth
/// through a two-point Φ_r ramp of F = 0.25 + 0.5 z. Lit by the ambient light only (ka = 1).
pub(crate) fn slab_scene(vl: &mut Library, step: f32, linear: bool) -> vlib::Result<()> {
    if linear {
        let (a, b) = (RAMP_C0, RAMP_C1);
        vl.mapping(
            MappingId(1),
            MappingType::Ramp,
            2,
            3,
            &[0.25, a[0], a[1], a[2], 0.75, b[0], b[1], b[2]],
        )?;
    }
    vl.scene()?;
    vl.camera(&Camera {
        eye: [0.0, 0.0, SLAB_EYE as f32],
        at: [0.0, 0.0, 10.0],
        up: [0.0, 1.0, 0.0],
        fov: SLAB_FOV,
    })?;
    vl.background(SLAB_BG[0], SLAB_BG[1], SLAB_BG[2])?;
    vl.ambient(1.0, 1.0, 1.0, 1.0)?;
    vl.step_size(step, 1.0)?;
    vl.object()?;
    vl.scale(400.0, 400.0, SLAB as f32)?;
    vl.translate(-200.0, -200.0, 0.0)?;
    vl.set(Fields::KA, 1.0)?;
    if linear {
        vl.set(Fields::O, RAMP_O)?;
        vl.function(Fields::F, |s| {
            let z = s.position()[2];
            let _ = s.set(Fields::F, 0.25 + 0.5 * z);
        })?;
        vl.map(Fields::R, Fields::F, MappingId(1), 1)?;
        vl.map(Fields::G, Fields::F, MappingId(1), 2)?;
        vl.map(Fields::B, Fields::F, MappingId(1), 3)?;
    } else {
        vl.set(Fields::O, CONST_O)?;
        vl.set(Fields::R, CONST_C[0])?;
        vl.set(Fields::G, CONST_C[1])?;
        vl.set(Fields::B, CONST_C[2])?;
    }
    vl.end()?;
    Ok(())
}

/// The closed-form image of the slab scene. Along a ray of length L = SLAB / d_z through the
/// medium, with σ = −ln(1 − o) per unit length and E = e^(−σL), the composite is
/// `∫₀^L σ e^(−σs) C(s) ds + E·bg`: for constant C it is `C (1 − E) + E·bg` (Beer–Lambert);
/// for C(s) = c₀ + (c₁ − c₀) s / L it is `c₀ (1 − E) + (c₁ − c₀)/L · ((1 − E)/σ − L E) + E·bg`.
pub(crate) fn slab_exact(size: u32, linear: bool) -> Image {
    let o = if linear { RAMP_O } else { CONST_O } as f64;
    let sigma = -(1.0 - o).ln();
    let mut pixels = Vec::with_capacity((size * size) as usize);
    for y in 0..size {
        for x in 0..size {
            let d = pixel_dir(x, y, size, SLAB_FOV);
            let l = SLAB / d[2];
            let e = (-sigma * l).exp();
            let px: [f32; 3] = std::array::from_fn(|c| {
                let bg = SLAB_BG[c] as f64;
                let v = if linear {
                    let (c0, c1) = (RAMP_C0[c] as f64, RAMP_C1[c] as f64);
                    c0 * (1.0 - e) + (c1 - c0) / l * ((1.0 - e) / sigma - l * e) + e * bg
                } else {
                    CONST_C[c] as f64 * (1.0 - e) + e * bg
                };
                v as f32
            });
            pixels.push(px);
        }
    }
    Image::from_rgb(size, size, pixels)
}

/// The iso-sphere: F = `vlaux::sphere` on a 100-unit cube, its 0.5 iso-surface a sphere of
/// radius 25 about (50, 50, 50), rendered by DSR with opacity 1 and colour = the object-space
/// position of the hit (ambient light only), so a pixel encodes where its ray hit the surface.
pub(crate) const SPHERE_EYE: [f64; 3] = [50.0, 50.0, -100.0];
pub(crate) const SPHERE_FOV: f32 = 26.0;
pub(crate) const SPHERE_R: f64 = 25.0;

pub(crate) fn sphere_scene(vl: &mut Library, step: f32) -> vlib::Result<()> {
    vl.scene()?;
    vl.camera(&Camera {
        eye: SPHERE_EYE.map(|v| v as f32),
        at: [50.0, 50.0, 50.0],
        up: [0.0, 1.0, 0.0],
        fov: SPHERE_FOV,
    })?;
    vl.background(0.0, 0.0, 0.0)?;
    vl.ambient(1.0, 1.0, 1.0, 1.0)?;
    vl.render_type(RenderType::Dsr)?;
    vl.surface(Fields::F, 0.5)?;
    vl.step_size(step, 1.0)?;
    vl.object()?;
    vl.scale(100.0, 100.0, 100.0)?;
    vl.function(Fields::F, |s| {
        let v = vlaux::sphere(s.position());
        let _ = s.set(Fields::F, v);
    })?;
    vl.function(Fields::COLORS, |s| {
        let p = s.position();
        let _ = s.set(Fields::R, p[0]);
        let _ = s.set(Fields::G, p[1]);
        let _ = s.set(Fields::B, p[2]);
    })?;
    vl.set(Fields::O, 1.0)?;
    vl.set(Fields::KA, 1.0)?;
    vl.end()?;
    Ok(())
}

/// The closed-form image of the iso-sphere: the first intersection of each primary ray with the
/// sphere, its position / 100 as the colour; black where the ray misses.
pub(crate) fn sphere_exact(size: u32) -> Image {
    let c = [50.0, 50.0, 50.0];
    let oc = [0, 1, 2].map(|i| SPHERE_EYE[i] - c[i]);
    let mut pixels = Vec::with_capacity((size * size) as usize);
    for y in 0..size {
        for x in 0..size {
            let d = pixel_dir(x, y, size, SPHERE_FOV);
            let b = (0..3).map(|i| d[i] * oc[i]).sum::<f64>();
            let cc = (0..3).map(|i| oc[i] * oc[i]).sum::<f64>() - SPHERE_R * SPHERE_R;
            let disc = b * b - cc;
            pixels.push(if disc < 0.0 {
                [0.0; 3]
            } else {
                let t = -b - disc.sqrt();
                std::array::from_fn(|i| ((SPHERE_EYE[i] + t * d[i]) / 100.0) as f32)
            });
        }
    }
    Image::from_rgb(size, size, pixels)
}

/// Silhouette and depth errors of a rendered iso-sphere against the closed form: pixels the
/// renderer missed, pixels it hit that the sphere does not cover, and the RMS and largest
/// distance (world units) between rendered and exact hit points where both hit.
pub(crate) struct SphereErr {
    pub(crate) missed: usize,
    pub(crate) extra: usize,
    pub(crate) rms_pos: f64,
    pub(crate) max_pos: f64,
}

pub(crate) fn sphere_error(img: &Image, exact: &Image) -> SphereErr {
    let hit = |p: &[f32; 3]| p.iter().any(|&v| v > 0.05);
    let (mut missed, mut extra, mut sq, mut max, mut n) = (0, 0, 0.0f64, 0.0f64, 0usize);
    for (p, q) in img.pixels.iter().zip(&exact.pixels) {
        match (hit(p), hit(q)) {
            (false, true) => missed += 1,
            (true, false) => extra += 1,
            (true, true) => {
                let d2: f64 = (0..3)
                    .map(|i| ((p[i] as f64 - q[i] as f64) * 100.0).powi(2))
                    .sum();
                sq += d2;
                max = max.max(d2.sqrt());
                n += 1;
            }
            _ => {}
        }
    }
    SphereErr {
        missed,
        extra,
        rms_pos: (sq / n.max(1) as f64).sqrt(),
        max_pos: max,
    }
}

/// The MNI scene of `examples/common/mni_scene.rs` (camera, light, transfer functions, shading)
/// with every control of `cfg` in force.
pub(crate) fn mni_scene(vl: &mut Library, dims: [usize; 3], cfg: Cfg) -> vlib::Result<()> {
    mni_scene::mappings(vl)?;
    vl.scene()?;
    mni_scene::view(vl, dims)?;
    cfg.apply(vl, 1.0)?;
    mni_scene::object(vl, dims, true)
}

/// The brain, loaded once and shared by every scene.
pub(crate) struct Brain {
    pub(crate) data: Arc<Dataset>,
    pub(crate) path: PathBuf,
}

impl Brain {
    pub(crate) fn scene(&self, cfg: Cfg) -> Res<Library> {
        let mut vl = Library::new();
        vl.add_dataset(mni_scene::BRAIN, self.data.clone())?;
        mni_scene(&mut vl, self.data.dims(), cfg)?;
        Ok(vl)
    }
}

/// The MNI dataset: `$VLIB_MNI_VLB`, or `target/bench-data/mni.vlb`, converted from the NIfTI
/// file in `../shared/data` with `vlconvert` (built first if needed) when missing.
pub(crate) fn mni_dataset() -> Res<PathBuf> {
    Ok(mni_scene::converted_dataset()?)
}

/// The hypertexture: a ball whose geometry field is a sphere's distance field displaced by
/// four octaves of signed Perlin noise (fractal sum of `vlaux::noise`, smooth, unlike
/// `vlaux::turbulence`, whose |noise| has creases where central differences converge slowly),
/// opacity a steep ramp of F, colour from the noise, one point light with diffuse and specular
/// terms. Its normals come from central differences of F, so the neighbourhood matters. The
/// noise is faded out (and skipped) near the box, where it could not raise F to the opacity
/// threshold.
pub(crate) const HYPER: f32 = 100.0;

pub(crate) fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Four octaves of signed noise, 4 cycles per unit at the first: roughly −1 … 1.
pub(crate) fn fbm(p: [f32; 3]) -> f32 {
    (0..4)
        .map(|i| vlaux::noise(p, 4.0 * (1 << i) as f32, 3) / (1 << i) as f32)
        .sum()
}

pub(crate) fn hyper_fields(s: &mut vlib::Sample) {
    let p = s.position();
    let base = vlaux::sphere(p);
    let w = smoothstep(0.1, 0.3, base);
    let n = if w > 0.0 { fbm(p) } else { 0.0 };
    let _ = s.set(Fields::F, base + w * 0.35 * n);
    let t = 0.5 + 0.5 * n;
    let _ = s.set(Fields::R, 0.55 + 0.4 * t);
    let _ = s.set(Fields::G, 0.45 + 0.3 * t);
    let _ = s.set(Fields::B, 0.35 + 0.1 * t);
}

/// Camera, lights and opacity mapping of the hypertexture; opens the scene.
pub(crate) fn hyper_setup(vl: &mut Library, cfg: Cfg) -> vlib::Result<()> {
    vl.mapping(
        MappingId(1),
        MappingType::Ramp,
        2,
        1,
        &[0.45, 0.0, 0.55, 0.9],
    )?;
    vl.scene()?;
    vl.camera(&Camera {
        eye: [50.0, 80.0, -120.0],
        at: [50.0, 50.0, 50.0],
        up: [0.0, 1.0, 0.0],
        fov: 30.0,
    })?;
    vl.background(0.0, 0.0, 0.0)?;
    vl.ambient(1.0, 1.0, 1.0, 0.25)?;
    vl.point_light([-100.0, 200.0, -150.0], Attenuation::None, [1.0; 3], 1.0)?;
    cfg.apply(vl, 1.0)
}

pub(crate) fn hyper_constants(vl: &mut Library) -> vlib::Result<()> {
    vl.set(Fields::KA, 0.3)?;
    vl.set(Fields::KD, 0.7)?;
    vl.set(Fields::KS, 0.3)?;
    vl.set(Fields::N, vlib::types::specular_to_field(20.0))
}

/// The hypertexture evaluated directly.
pub(crate) fn hyper_direct(cfg: Cfg) -> Res<Library> {
    let mut vl = Library::new();
    hyper_setup(&mut vl, cfg)?;
    vl.object()?;
    vl.scale(HYPER, HYPER, HYPER)?;
    vl.function(Fields::F | Fields::COLORS, hyper_fields)?;
    vl.map(Fields::O, Fields::F, MappingId(1), 1)?;
    hyper_constants(&mut vl)?;
    vl.end()?;
    Ok(vl)
}

/// Voxelizes F and the colours of the hypertexture at n³ nodes (16 bits) with `vlVolume`;
/// returns the four datasets (F, R, G, B) and the time it took.
pub(crate) fn hyper_voxelize(n: i32, dir: &Path) -> Res<([Arc<Dataset>; 4], f64)> {
    let prefix = dir.join(format!("hyper{n}"));
    let t = Instant::now();
    let mut vl = Library::new();
    hyper_setup(&mut vl, Cfg::new(1.0, 1))?;
    vl.object()?;
    vl.scale(HYPER, HYPER, HYPER)?;
    vl.function(Fields::F | Fields::COLORS, hyper_fields)?;
    vl.end()?;
    vl.volume(
        &prefix,
        Fields::F | Fields::COLORS,
        [0.0; 3],
        [HYPER; 3],
        [n; 3],
        2,
    )?;
    vl.end()?;
    let secs = t.elapsed().as_secs_f64();
    let load = |name: &str| -> Res<Arc<Dataset>> {
        let mut file = prefix.as_os_str().to_owned();
        file.push(format!("_{name}.vlb"));
        let path = PathBuf::from(file);
        let d = Dataset::load(&path)?;
        std::fs::remove_file(&path)?;
        Ok(Arc::new(d))
    };
    Ok(([load("f")?, load("r")?, load("g")?, load("b")?], secs))
}

/// The hypertexture from its voxelized fields: F and the colours from the datasets (grid
/// gradients for the normals), opacity the same ramp of F.
pub(crate) fn hyper_voxel(data: &[Arc<Dataset>; 4], cfg: Cfg) -> Res<Library> {
    let mut vl = Library::new();
    for (i, d) in data.iter().enumerate() {
        vl.add_dataset(DatasetId(10 + i as i32), d.clone())?;
    }
    hyper_setup(&mut vl, cfg)?;
    vl.object()?;
    vl.scale(HYPER, HYPER, HYPER)?;
    vl.dataset(Fields::F, DatasetId(10))?;
    vl.map(Fields::O, Fields::F, MappingId(1), 1)?;
    vl.dataset(Fields::R, DatasetId(11))?;
    vl.dataset(Fields::G, DatasetId(12))?;
    vl.dataset(Fields::B, DatasetId(13))?;
    hyper_constants(&mut vl)?;
    vl.end()?;
    Ok(vl)
}
