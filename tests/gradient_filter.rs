//! The gradient filter in renders (`Library::gradient_filter`, `docs/extensions.md`): a lit
//! volume with the cubic gradient renders the same pixels with the packet march allowed or not
//! (it takes the scalar path) and on any number of threads; the filter reaches the image; and
//! where a spatial function moved the point, the central differences read the dataset through
//! the gradient filter's spline.

use vlib::{
    Camera, DatasetId, Fields, GradientFilter, Library, MappingId, MappingType, Optimise, Sample,
};
use vlib::{Dataset, Voxels};

/// A ball: 8-bit voxels of a smooth radial ramp (255 at the centre, 0 at radius 0.5 of the
/// box), so its iso-surfaces are spheres cut by the grid at every angle.
fn ball(n: usize) -> Dataset {
    let mut raw = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let r = [i, j, k]
                    .map(|c| c as f64 / (n - 1) as f64 - 0.5)
                    .iter()
                    .map(|x| x * x)
                    .sum::<f64>()
                    .sqrt();
                raw.push((255.0 * (1.0 - 2.0 * r).clamp(0.0, 1.0)).round() as u8);
            }
        }
    }
    Dataset::new([n; 3], Voxels::U8(raw), 0.0, 255.0).unwrap()
}

/// The ball (24³ nodes scaled to 23 units a side) with a steep opacity ramp around 0.5, lit by
/// one directional light, under `gradient`; with `spatial`, an identity spatial function
/// (which moves nothing, but turns the normals into central differences of F).
fn render(gradient: GradientFilter, spatial: bool, packets: bool, threads: usize) -> Vec<f32> {
    let n = 24;
    let mut vl = Library::new();
    vl.add_dataset(DatasetId(1), ball(n)).unwrap();
    vl.mapping(
        MappingId(1),
        MappingType::Ramp,
        3,
        1,
        &[0.4, 0.0, 0.5, 0.6, 1.0, 0.9],
    )
    .unwrap();
    vl.mapping(
        MappingId(2),
        MappingType::Ramp,
        2,
        3,
        &[0.4, 0.9, 0.8, 0.7, 1.0, 1.0, 0.9, 0.8],
    )
    .unwrap();
    vl.scene().unwrap();
    vl.set_optimise(Optimise {
        packets,
        ..Optimise::default()
    })
    .unwrap();
    let ext = (n - 1) as f32;
    vl.camera(&Camera {
        eye: [ext * 0.5, -2.0 * ext, ext * 0.8],
        at: [ext * 0.5; 3],
        up: [0.0, 0.0, 1.0],
        fov: 35.0,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.directional_light([0.3, 1.0, -0.4], [1.0, 1.0, 1.0], 1.0)
        .unwrap();
    vl.step_size(0.25, 1.0).unwrap();
    vl.gradient_filter(gradient).unwrap();
    vl.object().unwrap();
    vl.scale(ext, ext, ext).unwrap();
    if spatial {
        vl.spatial(|_: &mut Sample| {}).unwrap();
    }
    vl.dataset(Fields::F, DatasetId(1)).unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    vl.map(Fields::R, Fields::F, MappingId(2), 1).unwrap();
    vl.map(Fields::G, Fields::F, MappingId(2), 2).unwrap();
    vl.map(Fields::B, Fields::F, MappingId(2), 3).unwrap();
    vl.set(Fields::KA, 0.2).unwrap();
    vl.set(Fields::KD, 0.8).unwrap();
    vl.end().unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let image = pool.install(|| vl.render_preview(40, 40, 1.0)).unwrap();
    (0..40)
        .flat_map(|y| (0..40).map(move |x| (x, y)))
        .flat_map(|(x, y)| image.pixel(x, y))
        .collect()
}

const BSPLINE: GradientFilter = GradientFilter::Cubic { b: 1.0, c: 0.0 };

fn rms(a: &[f32], b: &[f32]) -> f64 {
    let s: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| ((x - y) as f64 * 255.0).powi(2))
        .sum();
    (s / a.len() as f64).sqrt()
}

#[test]
fn a_cubic_gradient_renders_the_same_pixels_with_or_without_packets_on_any_threads() {
    // The scene is one the packet march takes under the paper's gradient, where the processor
    // has AVX2: its fused multiply-adds then change the last bits of some pixels.
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        let nodes = render(GradientFilter::Nodes, false, false, 1);
        assert_ne!(render(GradientFilter::Nodes, false, true, 1), nodes);
    }
    let scalar = render(BSPLINE, false, false, 1);
    assert_eq!(render(BSPLINE, false, true, 1), scalar);
    assert_eq!(render(BSPLINE, false, true, 3), scalar);
    assert_eq!(render(BSPLINE, false, false, 2), scalar);
    assert!(scalar.iter().all(|v| v.is_finite()));
}

#[test]
fn the_gradient_filter_reaches_the_image() {
    let nodes = render(GradientFilter::Nodes, false, false, 1);
    let cubic = render(BSPLINE, false, false, 1);
    let catmull = render(GradientFilter::Cubic { b: 0.0, c: 0.5 }, false, false, 1);
    // On this nearly linear ramp every filter's normals are close to the ball's (the images
    // differ by a fraction of a grey level), but not the same: the filter, and its B and C,
    // reach the lighting.
    assert_ne!(nodes, cubic);
    assert_ne!(catmull, cubic);
}

#[test]
fn moved_points_take_central_differences_of_the_gradient_filters_spline() {
    // With the identity spatial function the normals are central differences of F (offsets of
    // half the step) instead of the dataset's own gradient. Under the cubic gradient filter
    // they are differences of the B-spline, so they come close to its exact gradient; under the
    // paper's they are differences of the trilinear values, which are not.
    let exact = render(BSPLINE, false, false, 1);
    let moved_cubic = render(BSPLINE, true, false, 1);
    let moved_nodes = render(GradientFilter::Nodes, true, false, 1);
    let (near, far) = (rms(&moved_cubic, &exact), rms(&moved_nodes, &exact));
    assert!(near < far / 3.0, "cubic {near}, nodes {far}");
}
