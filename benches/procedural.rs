//! Field-function calls per pixel in procedural scenes, against the essential count: how many
//! calls the renderer makes, and how many a renderer that evaluated only what reaches the image
//! would need. Prints a table and, with `--write`, puts it between the `procedural` markers of
//! `docs/performance.md`.
//!
//! ```text
//! cargo bench --bench procedural              # the table on standard output
//! cargo bench --bench procedural -- --write   # and into docs/performance.md
//! ```
//!
//! Scenes (256², one ray per pixel): the paper's Figure 2 as in `benches/scenes.rs`, the
//! hypertexture of `benches/scenes.rs`, the hypertexture of the accuracy study
//! (`examples/accuracy`, step 0.5, evaluated directly) and the smoke demo
//! (`examples/c/smoke.c`, ported call for call to closures: the chimney and the smoke).
//!
//! Every field function is wrapped by a recorder that counts its calls and keeps each call's
//! world point and, for the function that decides opacity, the opacity it implies. The
//! essential count is computed from those records, independently of the renderer: a call is
//! at a primary sample when its point projects to a pixel's centre (within 0.01 pixel;
//! central differences and shadow rays are off the centres, or elsewhere along the ray);
//! per pixel, the primary samples in depth order are composited with the opacity correction
//! 1 − (1 − o)^(step/reference), and a sample is essential when its opacity is above 0 and the
//! transmittance before it is at least the termination threshold (1/512). The essential calls
//! are, per essential sample, one call of each function the sample's colour needs, plus six
//! calls of the opacity function's program where the sample is lit by a diffuse or specular
//! term with a normal from central differences (the minimum for that estimate). A sample with
//! opacity 0 is never essential, though the renderer must evaluate something to find that: the
//! ratio is an upper bound on what could be cut.

mod common;
#[path = "../examples/common/figure2_scene.rs"]
mod figure2_scene;

use std::sync::{Arc, Mutex};
use vlib::{vlaux, Attenuation, Camera, Fields, Library, MappingId, MappingType, Sample};

const SIDE: u32 = 256;
const TERMINATION: f64 = 1.0 / 512.0;

/// One call of a field function.
#[derive(Clone, Copy)]
struct Call {
    /// The world point.
    world: [f32; 3],
    /// The opacity the call's sample takes, where this function decides it; else NaN.
    opacity: f32,
}

/// A field function's calls, recorded.
#[derive(Default)]
struct Recorder {
    calls: Mutex<Vec<Call>>,
}

impl Recorder {
    fn push(&self, s: &Sample, opacity: f32) {
        let world = s.world_position();
        self.calls.lock().unwrap().push(Call { world, opacity });
    }
    fn take(&self) -> Vec<Call> {
        std::mem::take(&mut *self.calls.lock().unwrap())
    }
}

/// One object of a scene as the essential count sees it.
struct Object {
    /// Its field functions: (name, recorder, decides opacity, is in the program that central
    /// differences of the opacity field run).
    functions: Vec<(&'static str, Arc<Recorder>, bool, bool)>,
    /// Step and opacity reference, world units.
    step: f64,
    reference: f64,
    /// Whether its samples' normals come from central differences (kd or ks above 0, a light).
    differences: bool,
}

struct Scene {
    name: &'static str,
    camera: Camera,
    library: Library,
    objects: Vec<Object>,
}

fn rec() -> Arc<Recorder> {
    Arc::new(Recorder::default())
}

/// The lookup transfer function of Figure 2: 0.3 on (0.001, 1], else 0.
fn figure2_opacity(f: f32) -> f32 {
    if f > 0.001 && f <= 1.0 {
        0.3
    } else {
        0.0
    }
}

/// A two-point ramp (a0, 0) → (a1, b1), constant b1 above a1, 0 below a0.
fn ramp(f: f32, a0: f32, a1: f32, b1: f32) -> f32 {
    if f <= a0 {
        0.0
    } else if f >= a1 {
        b1
    } else {
        b1 * (f - a0) / (a1 - a0)
    }
}

fn figure2() -> Scene {
    let (f, stone) = (rec(), rec());
    let camera = figure2_scene::camera();
    let mut vl = Library::new();
    let r = f.clone();
    let geometry = move |s: &mut Sample| {
        let v = vlaux::parab1(s.position());
        r.push(s, figure2_opacity(v));
        let _ = s.set(Fields::F, v);
    };
    let r = stone.clone();
    let colours = move |s: &mut Sample| {
        r.push(s, f32::NAN);
        figure2_scene::bench_stone(s);
    };
    figure2_scene::build_with(&mut vl, None, geometry, colours, false).unwrap();
    Scene {
        name: "Figure 2 (`benches/scenes.rs`)",
        camera,
        library: vl,
        objects: vec![Object {
            functions: vec![("F", f, true, true), ("colours", stone, false, false)],
            // The default step: min(1, diagonal / 256) = 1 for this box; reference 1.
            step: 1.0,
            reference: 1.0,
            differences: true,
        }],
    }
}

fn hypertexture() -> Scene {
    let (f, oc) = (rec(), rec());
    let camera = common::hypertexture::camera();
    let r = f.clone();
    let geometry = move |s: &mut Sample| {
        r.push(s, f32::NAN);
        common::hypertexture::geometry(s);
    };
    let r = oc.clone();
    let opacity_colours = move |s: &mut Sample| {
        let o = common::hypertexture::opacity_colours(s);
        r.push(s, o);
    };
    let vl = common::hypertexture::build(geometry, opacity_colours);
    Scene {
        name: "hypertexture (`benches/scenes.rs`)",
        camera,
        library: vl,
        // The O|colour function decides opacity; the normal (central differences of F) runs
        // only F's prefix, the sphere function.
        objects: vec![Object {
            functions: vec![("F", f, false, true), ("O + colours", oc, true, false)],
            step: 3.0,
            reference: 6.0,
            differences: true,
        }],
    }
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn accuracy_hypertexture() -> Scene {
    let fc = rec();
    let camera = Camera {
        eye: [50.0, 80.0, -120.0],
        at: [50.0, 50.0, 50.0],
        up: [0.0, 1.0, 0.0],
        fov: 30.0,
    };
    let mut vl = Library::new();
    vl.mapping(
        MappingId(1),
        MappingType::Ramp,
        2,
        1,
        &[0.45, 0.0, 0.55, 0.9],
    )
    .unwrap();
    vl.scene().unwrap();
    vl.camera(&camera).unwrap();
    vl.background(0.0, 0.0, 0.0).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 0.25).unwrap();
    vl.point_light([-100.0, 200.0, -150.0], Attenuation::None, [1.0; 3], 1.0)
        .unwrap();
    vl.step_size(0.5, 1.0).unwrap();
    vl.object().unwrap();
    vl.scale(100.0, 100.0, 100.0).unwrap();
    let r = fc.clone();
    vl.function(Fields::F | Fields::COLORS, move |s| {
        let p = s.position();
        let base = vlaux::sphere(p);
        let w = smoothstep(0.1, 0.3, base);
        let n = if w > 0.0 {
            (0..4)
                .map(|i| vlaux::noise(p, 4.0 * (1 << i) as f32, 3) / (1 << i) as f32)
                .sum()
        } else {
            0.0
        };
        let f = base + w * 0.35 * n;
        r.push(s, ramp(f, 0.45, 0.55, 0.9));
        let _ = s.set(Fields::F, f);
        let t = 0.5 + 0.5 * n;
        let _ = s.set(Fields::R, 0.55 + 0.4 * t);
        let _ = s.set(Fields::G, 0.45 + 0.3 * t);
        let _ = s.set(Fields::B, 0.35 + 0.1 * t);
    })
    .unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    vl.set(Fields::KA, 0.3).unwrap();
    vl.set(Fields::KD, 0.7).unwrap();
    vl.set(Fields::KS, 0.3).unwrap();
    vl.set(Fields::N, vlib::types::specular_to_field(20.0))
        .unwrap();
    vl.end().unwrap();
    Scene {
        name: "hypertexture of the accuracy study (step 0.5)",
        camera,
        library: vl,
        objects: vec![Object {
            functions: vec![("F + colours", fc, true, true)],
            step: 0.5,
            reference: 1.0,
            differences: true,
        }],
    }
}

/// `examples/c/smoke.c`, closure for function.
fn smoke() -> Scene {
    const D: f32 = 160.0;
    const H: f32 = 320.0;
    const CW: f32 = 56.0;
    const CH: f32 = 90.0;
    const MARGIN: f32 = 2.0;
    let (stack, bricks, cyl, plume) = (rec(), rec(), rec(), rec());
    let camera = Camera {
        eye: [-50.0, 30.0, -420.0],
        at: [0.0, 125.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov: 46.0,
    };
    let mut vl = Library::new();
    vl.mapping(
        MappingId(1),
        MappingType::Ramp,
        2,
        1,
        &[0.35, 0.0, 0.5, 1.0],
    )
    .unwrap();
    vl.scene().unwrap();
    vl.camera(&camera).unwrap();
    vl.background(0.16, 0.20, 0.30).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.point_light(
        [-400.0, 400.0, -300.0],
        Attenuation::None,
        [1.0, 0.95, 0.85],
        1.0,
    )
    .unwrap();
    vl.step_size(0.5, 1.0).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -1.0, -0.5).unwrap();
    vl.scale(CW + 2.0 * MARGIN, CH + 2.0 * MARGIN, CW + 2.0 * MARGIN)
        .unwrap();
    vl.translate(0.0, MARGIN, 0.0).unwrap();
    let r = stack.clone();
    vl.function(Fields::F, move |s| {
        let p = s.position();
        let w = [
            (p[0] - 0.5) * (CW + 2.0 * MARGIN),
            (p[1] - 1.0) * (CH + 2.0 * MARGIN) + MARGIN,
            (p[2] - 0.5) * (CW + 2.0 * MARGIN),
        ];
        let mut d = (0.5 * CW - w[0].abs()).min(0.5 * CW - w[2].abs());
        d = d.min(-w[1]).min(CH + w[1]);
        let shaft = w[0].abs().max(w[2].abs()) - 0.3 * CW;
        let depth = -w[1] - 20.0;
        if shaft < 0.0 && depth < 0.0 {
            d = d.min(shaft.max(depth));
        }
        let f = 0.5 + 0.5 * d;
        r.push(s, ramp(f, 0.35, 0.5, 1.0));
        let _ = s.set(Fields::F, f);
    })
    .unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    let r = bricks.clone();
    vl.function(Fields::COLORS, move |s| {
        r.push(s, f32::NAN);
        let w = s.world_position();
        let row = (w[1] + 200.0) / 8.0;
        let course = row.floor();
        let fr = (row - course) * 8.0;
        let along = if w[0].abs() > w[2].abs() { w[2] } else { w[0] };
        let col = (along + 200.0 + (course as i32 % 2) as f32 * 11.0) / 22.0;
        let fc = (col - col.floor()) * 22.0;
        let mortar = fr < 1.2 || fc < 1.2;
        let t = vlaux::turbulence(w, 0.08, 4, 61);
        let cell = [col.floor() * 7.3, course * 3.1, 0.5];
        let t = 0.75 * t + 0.25 * (0.5 + 0.5 * vlaux::noise(cell, 0.37, 62));
        let (mut rr, mut g, mut b) = if mortar {
            (0.55, 0.53, 0.50)
        } else {
            (0.46 + 0.22 * t, 0.18 + 0.08 * t, 0.12 + 0.05 * t)
        };
        if w[1] > -20.5 && w[0].abs() < 0.3 * CW + 0.5 && w[2].abs() < 0.3 * CW + 0.5 {
            (rr, g, b) = (0.08, 0.07, 0.07);
        }
        let _ = s.set(Fields::R, rr.clamp(0.0, 1.0));
        let _ = s.set(Fields::G, g.clamp(0.0, 1.0));
        let _ = s.set(Fields::B, b.clamp(0.0, 1.0));
    })
    .unwrap();
    vl.set(Fields::KA, 0.35).unwrap();
    vl.set(Fields::KD, 0.75).unwrap();
    vl.end().unwrap();
    vl.step_size(1.0, 15.0).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(D, D, H).unwrap();
    vl.rotate(90.0, 0.0, 0.0).unwrap();
    vl.translate(0.0, 0.5 * H - 12.0, 0.0).unwrap();
    let r = cyl.clone();
    vl.function(Fields::F, move |s| {
        r.push(s, f32::NAN);
        let _ = s.set(Fields::F, vlaux::cylinder(s.position()));
    })
    .unwrap();
    let r = plume.clone();
    vl.function(Fields::O | Fields::COLORS, move |s| {
        let p = s.position();
        let rho = 0.5 * (1.0 - s.value(9));
        let h = 1.0 - p[2];
        let q = [p[0] + 0.25 * h, p[1], p[2] * (H / D)];
        let big = vlaux::noise(q, 1.2, 8);
        let width = 0.07 + 0.38 * h + 0.06 * big * h;
        let edge = 1.0 - rho / width;
        if edge < -1.1 * (2.0 - 0.45) {
            r.push(s, 0.0);
            let _ = s.set(Fields::O, 0.0);
            return;
        }
        let t = vlaux::turbulence(q, 2.2, 5, 7);
        let density = edge + 1.1 * (t - 0.45);
        let mut fade = 1.0 - h * h * h;
        if h < 0.03 {
            fade *= h / 0.03;
        }
        let o = 0.5 * density * fade - 0.02;
        r.push(s, o.clamp(0.0, 1.0));
        let _ = s.set(Fields::O, o);
        let _ = s.set(Fields::R, 0.55 + 0.35 * h + 0.05 * t);
        let _ = s.set(Fields::G, 0.54 + 0.34 * h + 0.05 * t);
        let _ = s.set(Fields::B, 0.54 + 0.32 * h + 0.05 * t);
    })
    .unwrap();
    vl.set(Fields::F, 0.0).unwrap();
    vl.set(Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    Scene {
        name: "smoke demo (`examples/c/smoke.c`)",
        camera,
        library: vl,
        objects: vec![
            Object {
                functions: vec![
                    ("chimney F", stack, true, true),
                    ("bricks", bricks, false, false),
                ],
                step: 0.5,
                reference: 1.0,
                differences: true,
            },
            Object {
                // F is set to 0 after the functions: no normal, ka only.
                functions: vec![
                    ("smoke F", cyl, false, false),
                    ("smoke O + colours", plume, true, false),
                ],
                step: 1.0,
                reference: 15.0,
                differences: false,
            },
        ],
    }
}

/// The pixel (column, row) whose centre `world` projects to, within 0.01 pixel, and its
/// distance from the eye; `None` off the centres. The camera model of `render::tiles::view`
/// (a square image): ray(x, y) = forward + (2x/W − 1)·right·h + (1 − 2y/H)·up·h, h = tan(fov/2).
fn pixel_of(cam: &Camera, world: [f32; 3]) -> Option<(u32, u32, f64)> {
    let v = |a: [f32; 3]| a.map(|c| c as f64);
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let norm = |a: [f64; 3]| {
        let l = dot(a, a).sqrt();
        a.map(|c| c / l)
    };
    let f = norm(sub(v(cam.at), v(cam.eye)));
    let r = norm(cross(v(cam.up), f));
    let u = cross(f, r);
    let h = (cam.fov as f64 * 0.5).to_radians().tan();
    let d = sub(v(world), v(cam.eye));
    let depth = dot(d, f);
    if depth <= 0.0 {
        return None;
    }
    let sx = dot(d, r) / depth / h;
    let sy = dot(d, u) / depth / h;
    let x = (sx + 1.0) * 0.5 * SIDE as f64;
    let y = (1.0 - sy) * 0.5 * SIDE as f64;
    let near = |c: f64| (c - c.floor() - 0.5).abs() < 0.01;
    (near(x) && near(y) && x >= 0.0 && y >= 0.0 && x < SIDE as f64 && y < SIDE as f64)
        .then(|| (x as u32, y as u32, dot(d, d).sqrt()))
}

struct Row {
    name: &'static str,
    calls: Vec<(&'static str, u64)>,
    primary: u64,
    /// Primary samples evaluated after their ray's transmittance fell below the threshold,
    /// and before it at opacity 0.
    late: u64,
    empty: u64,
    essential_samples: u64,
    essential_calls: u64,
    seconds: f64,
}

fn measure(scene: Scene) -> Row {
    let t = std::time::Instant::now();
    scene.library.render_preview(SIDE, SIDE, 1.0).unwrap();
    let seconds = t.elapsed().as_secs_f64();
    // Per pixel: (depth, opacity correction's alpha, object) of each primary sample.
    let mut rays: Vec<Vec<(f64, f64, usize)>> = vec![Vec::new(); (SIDE * SIDE) as usize];
    let mut calls = Vec::new();
    let mut primary = 0;
    for (k, obj) in scene.objects.iter().enumerate() {
        for (name, r, decides, _) in &obj.functions {
            let all = r.take();
            calls.push((*name, all.len() as u64));
            if !decides {
                continue;
            }
            for c in all {
                if let Some((x, y, depth)) = pixel_of(&scene.camera, c.world) {
                    primary += 1;
                    let o = c.opacity.clamp(0.0, 1.0) as f64;
                    let alpha = 1.0 - (1.0 - o).powf(obj.step / obj.reference);
                    rays[(x + SIDE * y) as usize].push((depth, alpha, k));
                }
            }
        }
    }
    let (mut essential_samples, mut essential_calls, mut late, mut empty) =
        (0u64, 0u64, 0u64, 0u64);
    for ray in &mut rays {
        ray.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut transmittance = 1.0;
        for (i, &(_, alpha, k)) in ray.iter().enumerate() {
            if transmittance < TERMINATION {
                late += (ray.len() - i) as u64;
                break;
            }
            if alpha == 0.0 {
                empty += 1;
            }
            if alpha > 0.0 {
                let obj = &scene.objects[k];
                essential_samples += 1;
                essential_calls += obj.functions.len() as u64;
                if obj.differences {
                    essential_calls += 6 * obj.functions.iter().filter(|f| f.3).count() as u64;
                }
            }
            transmittance *= 1.0 - alpha;
        }
    }
    Row {
        name: scene.name,
        calls,
        primary,
        late,
        empty,
        essential_samples,
        essential_calls,
        seconds,
    }
}

fn main() {
    let write = std::env::args().any(|a| a == "--write");
    let pixels = (SIDE * SIDE) as f64;
    let mut lines = vec![
        "| scene | calls per pixel, by function | all calls per pixel | primary samples evaluated per pixel: all, at opacity 0, after termination | essential samples per pixel | essential calls per pixel | calls / essential calls | frame (this run) |".to_string(),
        "|---|---|---|---|---|---|---|---|".to_string(),
    ];
    for scene in [figure2(), hypertexture(), accuracy_hypertexture(), smoke()] {
        let r = measure(scene);
        let total: u64 = r.calls.iter().map(|c| c.1).sum();
        let by: Vec<String> = r
            .calls
            .iter()
            .map(|(n, c)| format!("{n} {:.1}", *c as f64 / pixels))
            .collect();
        lines.push(format!(
            "| {} | {} | {:.1} | {:.1}, {:.1}, {:.2} | {:.2} | {:.1} | {:.1} | {:.0} ms |",
            r.name,
            by.join(", "),
            total as f64 / pixels,
            r.primary as f64 / pixels,
            r.empty as f64 / pixels,
            r.late as f64 / pixels,
            r.essential_samples as f64 / pixels,
            r.essential_calls as f64 / pixels,
            total as f64 / r.essential_calls.max(1) as f64,
            r.seconds * 1e3
        ));
    }
    let table = lines.join("\n");
    println!("{table}");
    if write {
        let doc = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/performance.md");
        let text = std::fs::read_to_string(doc).expect("docs/performance.md");
        let (begin, end) = ("<!-- procedural:begin -->", "<!-- procedural:end -->");
        let block = format!(
            "{begin}\nMeasured by `cargo bench --bench procedural -- --write` ({SIDE}², one ray per pixel, \
             RAYON_NUM_THREADS={}).\n\n{table}\n{end}",
            std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "unset".into())
        );
        let text = match (text.find(begin), text.find(end)) {
            (Some(a), Some(b)) => format!("{}{block}{}", &text[..a], &text[b + end.len()..]),
            _ => format!("{text}\n{block}\n"),
        };
        std::fs::write(doc, text).expect("write docs/performance.md");
    }
}
