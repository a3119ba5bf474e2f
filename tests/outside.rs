//! A dataset outside its grid: 0, in every path that samples it. A volume whose +x face holds a
//! bright blob, in a box enlarged to 1.5 (`vlBoundary`), turned towards the camera so that the
//! margin beyond that face shows beside the volume: every pixel whose ray misses the dataset's
//! cube is the background (under clamp-to-edge, the face's blob would stretch through the
//! margin and light many of them, which an independent march checks), with the scalar, batched
//! and packet marches, with and without empty-space skipping, and with every filter.

use glam::{DMat3, DMat4, DVec3};
use std::sync::Arc;
use vlib::{Camera, Dataset, Fields, Filter, Interpolation, Library, MappingType, Optimise};
use vlib::{DatasetId, MappingId, Voxels};

const DIMS: [usize; 3] = [33, 29, 25];
const SCALE: [f64; 3] = [40.0, 36.0, 30.0];
const ROTATE: [f64; 3] = [10.0, -20.0, -5.0];
const EYE: [f32; 3] = [0.0, 20.0, -110.0];
const FOV: f32 = 32.0;
const SIZE: (u32, u32) = (128, 96);

/// A Gaussian blob of radius 0.25 centred on the middle of the +x face (value 1 there),
/// 8-bit.
fn face_blob() -> Dataset {
    let mut raw = Vec::new();
    for k in 0..DIMS[2] {
        for j in 0..DIMS[1] {
            for i in 0..DIMS[0] {
                let p = [i, j, k].map(|c| c as f64);
                let p = [0, 1, 2].map(|a| p[a] / (DIMS[a] - 1) as f64);
                let d2 = (p[0] - 1.0).powi(2) + (p[1] - 0.5).powi(2) + (p[2] - 0.5).powi(2);
                raw.push(((-d2 / 0.0625).exp() * 255.0).round() as u8);
            }
        }
    }
    Dataset::new(DIMS, Voxels::U8(raw), 0.0, 255.0).unwrap()
}

/// Object → world: translate(−½), scale, rotate (R = R_z·R_y·R_x, degrees), as the scene
/// issues them.
fn to_world() -> DMat4 {
    let r = DMat3::from_rotation_z(ROTATE[2].to_radians())
        * DMat3::from_rotation_y(ROTATE[1].to_radians())
        * DMat3::from_rotation_x(ROTATE[0].to_radians());
    DMat4::from_mat3(r)
        * DMat4::from_scale(DVec3::from_array(SCALE))
        * DMat4::from_translation(DVec3::splat(-0.5))
}

/// The scene rendered to 8-bit RGB: the blob through an opacity ramp from 0.3, lit by one
/// directional light, with `filter` and `optimise`.
fn render(data: &Arc<Dataset>, interp: Interpolation, optimise: Optimise) -> Vec<u8> {
    let mut vl = Library::new();
    vl.add_dataset(DatasetId(1), data.clone()).unwrap();
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
    vl.camera(&Camera {
        eye: EYE,
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov: FOV,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 0.3).unwrap();
    vl.directional_light([1.0, -1.0, 1.0], [1.0; 3], 1.0)
        .unwrap();
    vl.step_size(0.5, 1.0).unwrap();
    vl.interpolation(interp).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(SCALE[0] as f32, SCALE[1] as f32, SCALE[2] as f32)
        .unwrap();
    vl.rotate(ROTATE[0] as f32, ROTATE[1] as f32, ROTATE[2] as f32)
        .unwrap();
    vl.boundary(1.5, 1.5, 1.5).unwrap();
    vl.dataset(Fields::F, DatasetId(1)).unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    vl.set(Fields::COLORS | Fields::KA | Fields::KD, 0.8)
        .unwrap();
    vl.end().unwrap();
    let (w, h) = SIZE;
    vl.render_preview(w, h, w as f32 / h as f32)
        .unwrap()
        .to_rgb8()
}

/// The object-space ray of pixel (x, y): the camera model of `tests/secondary.rs` (field of
/// view across the shorter side), through the inverse of [`to_world`].
fn pixel_ray(x: u32, y: u32) -> (DVec3, DVec3) {
    let (w, h) = (SIZE.0 as f64, SIZE.1 as f64);
    let eye = DVec3::from_array(EYE.map(f64::from));
    let f = (-eye).normalize();
    let r = DVec3::Y.cross(f).normalize();
    let u = f.cross(r);
    let half = (FOV as f64 / 2.0).to_radians().tan();
    let sx = (2.0 * (x as f64 + 0.5) / w - 1.0) * half * w / h;
    let sy = (1.0 - 2.0 * (y as f64 + 0.5) / h) * half;
    let d = (f + sx * r + sy * u).normalize();
    let to_object = to_world().inverse();
    (
        to_object.transform_point3(eye),
        to_object.transform_vector3(d),
    )
}

/// The parameter interval where `o + t·d` lies in the cube [lo, hi]³, if any.
fn cube(o: DVec3, d: DVec3, lo: f64, hi: f64) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        let (p, q) = ((lo - o[a]) / d[a], (hi - o[a]) / d[a]);
        t0 = t0.max(p.min(q));
        t1 = t1.min(p.max(q));
    }
    (t0 < t1).then_some((t0, t1))
}

#[test]
fn rays_that_miss_the_datasets_cube_show_the_background() {
    let data = Arc::new(face_blob());
    let (w, h) = SIZE;
    // The pixels whose rays miss the cube (grown by 2 % for the pixel's footprint), and of
    // those, the ones where clamping to the faces would have shown opacity: the clamped
    // value above the ramp's 0.3 somewhere along the ray in the enlarged box.
    let mut missing = Vec::new();
    let mut clamp_would_show = 0;
    for y in 0..h {
        for x in 0..w {
            let (o, d) = pixel_ray(x, y);
            if cube(o, d, -0.02, 1.02).is_some() {
                continue;
            }
            missing.push((x, y));
            if let Some((t0, t1)) = cube(o, d, -0.25, 1.25) {
                let n = 400;
                let lit = (0..n).any(|i| {
                    let p = o + (t0 + (t1 - t0) * (i as f64 + 0.5) / n as f64) * d;
                    let q = p.clamp(DVec3::ZERO, DVec3::ONE).as_vec3().to_array();
                    data.sample(q, Filter::Trilinear) > 0.35
                });
                clamp_would_show += usize::from(lit);
            }
        }
    }
    assert!(
        clamp_would_show > 30,
        "the scene must show the margin beyond the blob's face ({clamp_would_show} pixels)"
    );
    let plain = Optimise {
        skip_empty: false,
        packets: false,
        lean_kernel: false,
        ..Optimise::default()
    };
    for interp in [
        Interpolation::Nearest,
        Interpolation::Trilinear,
        Interpolation::Tricubic,
    ] {
        let reference = render(&data, interp, plain);
        let lit = reference.iter().filter(|&&v| v > 20).count();
        assert!(lit > 300, "{interp:?}: the blob shows ({lit} channels)");
        let fast = render(&data, interp, Optimise::default());
        let unskipped = render(
            &data,
            interp,
            Optimise {
                skip_empty: false,
                ..Optimise::default()
            },
        );
        for image in [&reference, &fast, &unskipped] {
            for &(x, y) in &missing {
                let at = 3 * (y * w + x) as usize;
                assert_eq!(
                    image[at..at + 3],
                    [0, 0, 0],
                    "{interp:?}: pixel ({x}, {y}) misses the dataset's cube"
                );
            }
        }
        // Skipping (with its entry map and cell masks) changes no byte; the lean kernel and
        // the batched and packet marches, whose lighting rounds in f32, at most a level.
        assert!(fast == unskipped, "{interp:?}: skipping changed pixels");
        let worst = fast
            .iter()
            .zip(&reference)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap();
        assert!(
            worst <= 1,
            "{interp:?}: the fast paths differ by {worst} levels"
        );
    }
}
