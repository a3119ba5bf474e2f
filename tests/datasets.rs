//! Datasets in scenes: `vlSample` against direct evaluation, empty-space skipping that never
//! changes a pixel, dataset-driven normals, and the MNI brain end to end.

use std::sync::{Arc, Mutex};
use vlib::Optimise;
use vlib::{Camera, Fields, Interpolation, Library, MappingType};
use vlib::{Dataset, Filter, Voxels};
use vlib::{DatasetId, MappingId};

#[path = "common/lcg.rs"]
mod lcg;
#[path = "../examples/common/mni_scene.rs"]
mod mni_scene;
use lcg::Lcg;

/// A 40×36×32 volume of a few Gaussian blobs over an empty background, 8-bit.
fn blobs() -> Dataset {
    let dims = [40usize, 36, 32];
    let centres = [
        ([0.3, 0.4, 0.5], 0.2),
        ([0.7, 0.6, 0.4], 0.15),
        ([0.5, 0.25, 0.7], 0.17),
    ];
    let mut raw = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = [i as f64 / 39.0, j as f64 / 35.0, k as f64 / 31.0];
                let v: f64 = centres
                    .iter()
                    .map(|(c, r)| {
                        let d2: f64 = (0..3).map(|a| (p[a] - c[a]).powi(2)).sum();
                        (-d2 / (r * r)).exp()
                    })
                    .sum();
                raw.push((v.min(1.0) * 255.0).round() as u8);
            }
        }
    }
    Dataset::new(dims, Voxels::U8(raw), 0.0, 255.0).unwrap()
}

fn blob_scene(
    interp: Interpolation,
    cubic: (f32, f32),
    optimise: Optimise,
    boundary: f32,
    super_sample: i32,
) -> Vec<u8> {
    let view = BlobView {
        eye: [0.0, 30.0, -80.0],
        fov: 45.0,
        scale: [39.0, 35.0, 31.0],
        rotate: [10.0, 25.0, -5.0],
        step: (0.7, 1.0),
        size: (64, 48),
    };
    blob_scene_in(
        Arc::new(blobs()),
        &view,
        (interp, cubic),
        optimise,
        boundary,
        super_sample,
    )
}

/// Where [`blob_scene_in`] puts the blobs and the camera, and the image's size.
struct BlobView {
    eye: [f32; 3],
    fov: f32,
    scale: [f32; 3],
    rotate: [f32; 3],
    /// `vlStepSize`'s step and reference.
    step: (f32, f32),
    size: (u32, u32),
}

/// The blobs (dataset `data`) through an opacity ramp, lit, seen as `view` says with the
/// filter `interp` (and its B, C), rendered to 8-bit RGB.
fn blob_scene_in(
    data: Arc<Dataset>,
    view: &BlobView,
    (interp, cubic): (Interpolation, (f32, f32)),
    optimise: Optimise,
    boundary: f32,
    super_sample: i32,
) -> Vec<u8> {
    let mut vl = Library::new();
    vl.add_dataset(DatasetId(7), data).unwrap();
    vl.mapping(
        MappingId(1),
        MappingType::Ramp,
        3,
        1,
        &[0.3, 0.0, 0.6, 0.5, 0.9, 0.9],
    )
    .unwrap();
    vl.scene().unwrap();
    vl.set_optimise(optimise).unwrap();
    vl.super_sample(super_sample).unwrap();
    vl.camera(&Camera {
        eye: view.eye,
        at: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov: view.fov,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 0.3).unwrap();
    vl.directional_light([1.0, -1.0, 1.0], [1.0, 1.0, 1.0], 1.0)
        .unwrap();
    vl.step_size(view.step.0, view.step.1).unwrap();
    vl.interpolation(interp).unwrap();
    vl.cubic_filter(cubic.0, cubic.1).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(view.scale[0], view.scale[1], view.scale[2])
        .unwrap();
    vl.rotate(view.rotate[0], view.rotate[1], view.rotate[2])
        .unwrap();
    vl.boundary(boundary, boundary, boundary).unwrap();
    vl.dataset(Fields::F, DatasetId(7)).unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    vl.set(Fields::COLORS | Fields::KA | Fields::KD, 0.8)
        .unwrap();
    vl.end().unwrap();
    let (w, h) = view.size;
    vl.render_preview(w, h, w as f32 / h as f32)
        .unwrap()
        .to_rgb8()
}

#[test]
fn empty_space_skipping_never_changes_a_pixel() {
    let off = Optimise {
        skip_empty: false,
        early_termination: true,
        ..Optimise::default()
    };
    for (interp, cubic) in [
        (Interpolation::Nearest, (0.0, 0.5)),
        (Interpolation::Trilinear, (0.0, 0.5)),
        (Interpolation::Tricubic, (0.0, 0.5)),
        (Interpolation::Tricubic, (1.0, 0.0)),
    ] {
        // (Super-sampled rays start their walks at their pixel's entry bound too.)
        for (boundary, ss) in [(1.0, 1), (1.3, 1), (1.0, 3)] {
            let with = blob_scene(interp, cubic, Optimise::default(), boundary, ss);
            let without = blob_scene(interp, cubic, off, boundary, ss);
            assert!(
                with == without,
                "{interp:?} {cubic:?} boundary {boundary} super-sampling {ss}: skipping changed \
                 pixels"
            );
            let lit = with.iter().filter(|&&v| v > 10).count();
            assert!(
                lit > 500,
                "{interp:?}: the blobs are visible ({lit} channels lit)"
            );
        }
    }
}

#[test]
fn early_termination_changes_pixels_by_less_than_its_threshold() {
    let on = blob_scene(
        Interpolation::Trilinear,
        (0.0, 0.5),
        Optimise::default(),
        1.0,
        1,
    );
    let off = blob_scene(
        Interpolation::Trilinear,
        (0.0, 0.5),
        Optimise {
            skip_empty: true,
            early_termination: false,
            ..Optimise::default()
        },
        1.0,
        1,
    );
    // T_MIN = 1/512 bounds the light left out; after rounding, at most one grey level.
    for (a, b) in on.iter().zip(&off) {
        assert!(a.abs_diff(*b) <= 1);
    }
    // A threshold set by `Optimise::termination` bounds it the same way: at 1/32 what a ray
    // leaves out is below 255/32 ≈ 8 levels (plus one of rounding), and more than the default
    // threshold allows does change;
    // at 0 no ray stops early and the image is the one without early termination.
    let at = |termination: f64| {
        blob_scene(
            Interpolation::Trilinear,
            (0.0, 0.5),
            Optimise {
                termination,
                ..Optimise::default()
            },
            1.0,
            1,
        )
    };
    let coarse = at(1.0 / 32.0);
    let worst = coarse
        .iter()
        .zip(&off)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap();
    assert!((2..=9).contains(&worst), "largest change {worst}");
    assert!(at(0.0) == off, "termination 0 stopped a ray early");
    assert!(at(vlib::T_MIN) == on, "the default is T_MIN");
}

#[test]
fn termination_thresholds_outside_zero_to_one_are_refused() {
    let mut vl = Library::new();
    for t in [-0.1, 1.0, 2.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let before = vl.fingerprint();
        let e = vl
            .set_optimise(Optimise {
                termination: t,
                ..Optimise::default()
            })
            .unwrap_err();
        assert_eq!(e.code, vlib::ErrorCode::BadValue, "{t}");
        assert_eq!(
            vl.fingerprint(),
            before,
            "{t}: a refused call changed the state"
        );
    }
    for t in [0.0, 1e-9, 0.5, 1.0 - f64::EPSILON] {
        vl.set_optimise(Optimise {
            termination: t,
            ..Optimise::default()
        })
        .unwrap();
    }
}

#[test]
fn vl_sample_matches_direct_evaluation() {
    let d = blobs();
    let mut vl = Library::new();
    vl.add_dataset(DatasetId(3), d.clone()).unwrap();
    let mut rng = Lcg(11);
    for (interp, filter) in [
        (Interpolation::Nearest, Filter::Nearest),
        (Interpolation::Trilinear, Filter::Trilinear),
        (Interpolation::Tricubic, Filter::Cubic { b: 0.0, c: 0.5 }),
    ] {
        vl.interpolation(interp).unwrap();
        for _ in 0..500 {
            let p = [rng.next() as f32, rng.next() as f32, rng.next() as f32];
            assert_eq!(
                vl.sample(DatasetId(3), p[0], p[1], p[2]).unwrap(),
                d.sample(p, filter)
            );
        }
    }
    assert_eq!(
        vl.sample(DatasetId(4), 0.5, 0.5, 0.5).unwrap_err().code,
        vlib::ErrorCode::BadId
    );
    assert_eq!(
        vl.sample(DatasetId(3), f32::NAN, 0.5, 0.5)
            .unwrap_err()
            .code,
        vlib::ErrorCode::BadValue
    );
    // Both wrong: the id, the first parameter, is reported (errors.md, which error when
    // several apply).
    assert_eq!(
        vl.sample(DatasetId(4), f32::NAN, 0.5, 0.5)
            .unwrap_err()
            .code,
        vlib::ErrorCode::BadId
    );
}

#[test]
fn vl_sample_inside_a_field_function_uses_the_objects_interpolation() {
    let d = blobs();
    type Log = Arc<Mutex<Vec<([f32; 3], f32)>>>;
    let seen: Log = Arc::default();
    let mut vl = Library::new();
    vl.add_dataset(DatasetId(3), d.clone()).unwrap();
    vl.scene().unwrap();
    vl.interpolation(Interpolation::Nearest).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.object().unwrap();
    let log = seen.clone();
    vl.function(Fields::O, move |s| {
        let p = s.position();
        let v = s.dataset(DatasetId(3), p).unwrap();
        let mut l = log.lock().unwrap();
        if l.len() < 200 {
            l.push((p, v));
        }
        let _ = s.set(Fields::O, v);
    })
    .unwrap();
    vl.end().unwrap();
    vl.render_preview(8, 8, 1.0).unwrap();
    let seen = seen.lock().unwrap();
    assert!(!seen.is_empty());
    for (p, v) in seen.iter() {
        assert_eq!(*v, d.sample(*p, Filter::Nearest));
    }
}

#[test]
fn dataset_commands_validate() {
    use vlib::ErrorCode;
    let mut vl = Library::new();
    assert_eq!(vl.unload(DatasetId(1)).unwrap_err().code, ErrorCode::BadId);
    assert_eq!(
        vl.load(DatasetId(1), "/no/such/file.vlb").unwrap_err().code,
        ErrorCode::IoError
    );
    vl.add_dataset(DatasetId(1), blobs()).unwrap();
    vl.scene().unwrap();
    vl.object().unwrap();
    assert_eq!(
        vl.dataset(Fields::O, DatasetId(2)).unwrap_err().code,
        ErrorCode::BadId
    );
    assert_eq!(
        vl.dataset(Fields::NONE, DatasetId(1)).unwrap_err().code,
        ErrorCode::BadField
    );
    let before = vl.fingerprint();
    assert_eq!(
        vl.load(DatasetId(2), "x.vlb").unwrap_err().code,
        ErrorCode::BadScope
    );
    assert_eq!(vl.fingerprint(), before);
    vl.dataset(Fields::O, DatasetId(1)).unwrap();
    vl.end().unwrap();
    // Unloading keeps objects that already cast the dataset working.
    vl.unload(DatasetId(1)).unwrap();
    assert!(vl.render_preview(4, 4, 1.0).is_ok());
}

/// The MNI brain: convert, render small with and without skipping, and check the cortex shows.
#[test]
fn mni_brain_renders_identically_with_and_without_skipping() {
    let nii = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz"
    );
    if !std::path::Path::new(nii).exists() {
        eprintln!("skipped: {nii} not found");
        return;
    }
    let dir = std::env::temp_dir().join(format!("vlib-mni-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let vlb = dir.join("mni.vlb");
    mni_scene::vlconvert(&["nifti".as_ref(), nii.as_ref(), vlb.as_os_str()]).unwrap();
    let d = Dataset::load(&vlb).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    let dims = d.dims();
    assert_eq!(dims, [197, 233, 189]);
    let render = |skip: bool, lean_kernel: bool| {
        let mut vl = Library::new();
        vl.add_dataset(DatasetId(1), d.clone()).unwrap();
        let op: Vec<f32> = [
            (40.0, 0.0),
            (80.0, 0.1),
            (120.0, 0.35),
            (180.0, 0.6),
            (255.0, 0.85),
        ]
        .iter()
        .flat_map(|&(s, a): &(f32, f32)| [s / 255.0, a])
        .collect();
        vl.mapping(MappingId(1), MappingType::Ramp, 5, 1, &op)
            .unwrap();
        vl.scene().unwrap();
        vl.set_optimise(Optimise {
            skip_empty: skip,
            early_termination: true,
            lean_kernel,
            // (The scalar march both ways: the general interpreter has no packet march.)
            packets: false,
            ..Optimise::default()
        })
        .unwrap();
        let c = [98.0, 116.0, 94.0];
        vl.camera(&Camera {
            eye: [c[0], c[1] + 360.0, c[2]],
            at: c,
            up: [0.0, 0.0, 1.0],
            fov: 30.0,
        })
        .unwrap();
        vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
        vl.directional_light([0.0, -1.0, 0.0], [1.0; 3], 1.0)
            .unwrap();
        vl.step_size(0.5, 1.0).unwrap();
        vl.object().unwrap();
        vl.scale(
            (dims[0] - 1) as f32,
            (dims[1] - 1) as f32,
            (dims[2] - 1) as f32,
        )
        .unwrap();
        vl.dataset(Fields::F, DatasetId(1)).unwrap();
        vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
        vl.set(Fields::COLORS, 0.9).unwrap();
        vl.set(Fields::KA, 0.2).unwrap();
        vl.set(Fields::KD, 0.7).unwrap();
        vl.end().unwrap();
        vl.render_preview(96, 96, 1.0).unwrap().to_rgb8()
    };
    let (a, b) = (render(true, true), render(false, true));
    assert!(a == b, "skipping changed the MNI image");
    assert!(
        a == render(true, false),
        "the lean kernel changed the MNI image"
    );
    // The brain covers a good part of the frame (the VTK image: about 47 % of rays hit it).
    let hit = a.chunks(3).filter(|p| p[0] > 20).count() as f64 / (96.0 * 96.0);
    assert!((0.3..0.7).contains(&hit), "coverage {hit}");
}

#[test]
fn mip_with_skipping_is_identical_to_mip_without() {
    let render = |skip_empty: bool| {
        let mut vl = Library::new();
        vl.add_dataset(DatasetId(7), blobs()).unwrap();
        vl.mapping(MappingId(1), MappingType::Ramp, 2, 1, &[0.3, 0.0, 0.9, 0.9])
            .unwrap();
        vl.scene().unwrap();
        vl.set_optimise(Optimise {
            skip_empty,
            early_termination: true,
            ..Optimise::default()
        })
        .unwrap();
        vl.camera(&Camera {
            eye: [0.0, 30.0, -80.0],
            at: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov: 45.0,
        })
        .unwrap();
        vl.render_type(vlib::RenderType::Mip).unwrap();
        vl.step_size(0.7, 1.0).unwrap();
        vl.object().unwrap();
        vl.translate(-0.5, -0.5, -0.5).unwrap();
        vl.scale(39.0, 35.0, 31.0).unwrap();
        vl.dataset(Fields::F, DatasetId(7)).unwrap();
        vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
        vl.set(Fields::COLORS, 1.0).unwrap();
        vl.end().unwrap();
        vl.render_preview(48, 36, 48.0 / 36.0).unwrap().to_rgb8()
    };
    let (a, b) = (render(true), render(false));
    assert!(a == b);
    let lit = a.iter().filter(|&&v| v > 20).count();
    assert!(lit > 100, "the blobs show ({lit} channels)");
}

#[test]
fn sizes_whose_product_overflows_are_refused_before_allocating() {
    use vlib::ErrorCode;
    // A header of 2^22 × 2^22 × 2^22 voxels: the count overflows 64 bits.
    let mut v = b"VLB1".to_vec();
    for _ in 0..3 {
        v.extend_from_slice(&(1u32 << 22).to_le_bytes());
    }
    v.extend_from_slice(&1u32.to_le_bytes());
    v.extend_from_slice(&0f32.to_le_bytes());
    v.extend_from_slice(&1f32.to_le_bytes());
    assert_eq!(
        Dataset::from_vlb_bytes(&v).unwrap_err().code,
        ErrorCode::BadDimensions
    );
    // The same for a voxelization request, and a directory is not a dataset.
    let mut vl = Library::new();
    assert_eq!(
        vl.load(DatasetId(1), std::env::temp_dir())
            .unwrap_err()
            .code,
        ErrorCode::IoError
    );
    vl.scene().unwrap();
    let n = 1 << 22;
    let e = vl
        .volume("/tmp/x", Fields::O, [0.0; 3], [1.0; 3], [n, n, n], 1)
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::NoMemory);
    let e = vl
        .volume(
            "/tmp/x",
            Fields::O,
            [0.0; 3],
            [1.0; 3],
            [1 << 16, 1 << 16, 2],
            1,
        )
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::NoMemory, "2^32 nodes at most");
    assert_eq!(vlib::limits::MAX_VOLUME_NODES, vlib::limits::MAX_VOXELS);
    // The largest grid a .vlb holds is accepted (it is voxelized slab by slab when the scene
    // closes; this one is not closed).
    vl.volume(
        "/tmp/x",
        Fields::O,
        [0.0; 3],
        [1.0; 3],
        [1 << 16, 1 << 15, 2],
        1,
    )
    .unwrap();
}

/// The lean kernel (programs of constants, datasets and transfer functions evaluated without the
/// general interpreter) computes the same fields bit for bit, so every image is identical with
/// it and without it: DVR with colour tables and shadows through two overlapping objects (the
/// general compositing loop), one object alone (the single-volume loop), and MIP.
#[test]
fn lean_kernel_changes_no_pixel() {
    let render = |lean_kernel: bool, two: bool, mip: bool| {
        let mut vl = Library::new();
        vl.add_dataset(DatasetId(7), blobs()).unwrap();
        vl.mapping(MappingId(1), MappingType::Ramp, 2, 1, &[0.3, 0.0, 0.9, 0.9])
            .unwrap();
        vl.mapping(
            MappingId(2),
            MappingType::Ramp,
            3,
            3,
            &[0.1, 0.9, 0.2, 0.1, 0.5, 0.3, 0.8, 0.2, 0.9, 0.6, 0.6, 1.0],
        )
        .unwrap();
        vl.scene().unwrap();
        vl.set_optimise(Optimise {
            lean_kernel,
            // (The scalar march both ways: the general interpreter has no packet march.)
            packets: false,
            ..Optimise::default()
        })
        .unwrap();
        vl.camera(&Camera {
            eye: [10.0, 30.0, -80.0],
            at: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov: 45.0,
        })
        .unwrap();
        vl.ambient(1.0, 1.0, 1.0, 0.3).unwrap();
        vl.point_light(
            [-40.0, 60.0, -40.0],
            vlib::Attenuation::None,
            [1.0, 0.9, 0.8],
            1.0,
        )
        .unwrap();
        if mip {
            vl.render_type(vlib::RenderType::Mip).unwrap();
        } else {
            vl.toggle(vlib::Feature::CastShadows, true).unwrap();
            vl.toggle(vlib::Feature::ReceiveShadows, true).unwrap();
        }
        vl.step_size(0.7, 1.0).unwrap();
        let count = if two { 2 } else { 1 };
        for i in 0..count {
            vl.object().unwrap();
            vl.translate(-0.5 + 0.3 * i as f32, -0.5, -0.5).unwrap();
            vl.scale(39.0, 35.0, 31.0).unwrap();
            vl.dataset(Fields::F, DatasetId(7)).unwrap();
            vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
            vl.map(Fields::R, Fields::F, MappingId(2), 1).unwrap();
            vl.map(Fields::G, Fields::F, MappingId(2), 2).unwrap();
            vl.map(Fields::B, Fields::F, MappingId(2), 3).unwrap();
            vl.set(Fields::KA, 0.3).unwrap();
            vl.set(Fields::KD, 0.6).unwrap();
            vl.set(Fields::KS, 0.4).unwrap();
            vl.set(Fields::N, vlib::types::specular_to_field(12.0))
                .unwrap();
            vl.end().unwrap();
        }
        vl.render_preview(64, 64, 1.0).unwrap().to_rgb8()
    };
    for (two, mip) in [(false, false), (true, false), (false, true)] {
        let a = render(true, two, mip);
        if !mip {
            let plan = {
                let mut vl = Library::new();
                vl.scene().unwrap();
                vl.toggle(vlib::Feature::CastShadows, true).unwrap();
                vl.toggle(vlib::Feature::ReceiveShadows, true).unwrap();
                vl.point_light([0.0; 3], vlib::Attenuation::None, [1.0; 3], 1.0)
                    .unwrap();
                vl.object().unwrap();
                vl.set(Fields::O, 0.5).unwrap();
                vl.end().unwrap();
                vl.render_plan().unwrap()
            };
            assert!(plan.shadows, "the toggles switch shadows on");
        }
        assert!(
            a.iter().any(|&v| v > 30),
            "the scene (two: {two}, mip: {mip}) shows something"
        );
        assert!(
            a == render(false, two, mip),
            "the lean kernel changed the image (two: {two}, mip: {mip})"
        );
    }
}

/// Empty-space skipping (with each image's entry map, which starts primary rays' walks where
/// they can first meet opacity) changes no pixel from any camera: outside the volume, inside
/// it, grazing it, with wide and narrow views, any rotation and scale, boundaries 1 and 1.3,
/// and super-sampling. Property-based with a fixed seed.
#[test]
fn skipping_is_exact_from_any_camera() {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    let config = Config {
        cases: 400,
        failure_persistence: None,
        ..Config::default()
    };
    let mut runner =
        TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &[11; 32]));
    let data = Arc::new(blobs());
    let lit = std::sync::atomic::AtomicUsize::new(0);
    let strategy = (
        [-1.5f32..1.5, -1.5f32..1.5, -1.5f32..1.5],
        [-180f32..180.0, -180f32..180.0, -180f32..180.0],
        [5f32..60.0, 5f32..60.0, 5f32..60.0],
        (any::<bool>(), 1i32..3, 15f32..100.0),
    );
    runner
        .run(&strategy, |(eye, rotate, scale, (wide, ss, fov))| {
            let size = scale.iter().fold(0.0f32, |m, v| m.max(*v));
            let view = BlobView {
                eye: eye.map(|e| e * size),
                fov,
                scale,
                rotate,
                step: (0.02 * size, 0.05 * size),
                size: (20, 15),
            };
            let filter = (Interpolation::Trilinear, (0.0, 0.5));
            let b = if wide { 1.3 } else { 1.0 };
            let render = |skip_empty: bool| {
                let optimise = Optimise {
                    skip_empty,
                    ..Optimise::default()
                };
                blob_scene_in(data.clone(), &view, filter, optimise, b, ss)
            };
            let with = render(true);
            prop_assert_eq!(&with, &render(false));
            if with.iter().filter(|&&v| v > 10).count() > 30 {
                lit.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            }
            Ok(())
        })
        .unwrap();
    // Most cameras see the blobs (the test compares pictures, not empty frames).
    let lit = lit.into_inner();
    assert!(lit > 200, "{lit} of 400 cases show the blobs");
}
