//! Each limit of `vlib::limits` is refused with the code the module's documentation names for
//! it, one past the limit, and the refused call changes nothing; at the limit the call is
//! accepted.

use vlib::limits::*;
use vlib::{Backdrop, Camera, Dataset, ErrorCode, Fields, Library, MappingId, MappingType, Voxels};

#[path = "common/refused.rs"]
mod refused;
use refused::{refused, scene};

#[test]
fn surfaces_recursion_super_sampling_and_nesting_are_bad_values_past_their_limits() {
    let mut vl = scene();
    for i in 0..MAX_SURFACES {
        vl.surface(Fields::F, i as f32 / MAX_SURFACES as f32)
            .unwrap();
    }
    refused(&mut vl, ErrorCode::BadValue, "a 65th surface", |vl| {
        vl.surface(Fields::O, 0.5)
    });
    vl.recursion(MAX_RECURSION).unwrap();
    refused(&mut vl, ErrorCode::BadValue, "recursion 65", |vl| {
        vl.recursion(MAX_RECURSION + 1)
    });
    vl.super_sample(MAX_SUPER_SAMPLE).unwrap();
    refused(&mut vl, ErrorCode::BadValue, "super-sampling 17", |vl| {
        vl.super_sample(MAX_SUPER_SAMPLE + 1)
    });
    for _ in 0..MAX_DEPTH {
        vl.object().unwrap();
    }
    refused(&mut vl, ErrorCode::BadValue, "a 65th nested object", |vl| {
        vl.object()
    });
}

#[test]
fn image_sizes_past_their_limits_are_refused_with_the_codes_of_their_commands() {
    let mut vl = scene();
    let side = MAX_IMAGE_SIDE;
    refused(&mut vl, ErrorCode::BadValue, "vlImage side", |vl| {
        vl.image("a.png", 1.0, side + 1, 1)
    });
    // 32768 × 8193 pixels: each side within its limit, 2¹⁵ more pixels than 2²⁸.
    let (w, h) = (side, (MAX_IMAGE_PIXELS / side as u64) as i32 + 1);
    assert!(w as u64 * h as u64 > MAX_IMAGE_PIXELS);
    refused(&mut vl, ErrorCode::NoMemory, "vlImage pixels", |vl| {
        vl.image("a.png", 1.0, w, h)
    });
    vl.image("a.png", 1.0, w, h - 1).unwrap();
    let render = |vl: &mut Library, w: i32, h: i32| {
        vl.render(w as u32, h as u32, 1.0, Backdrop::Background)
            .map(|_| ())
    };
    refused(&mut vl, ErrorCode::BadValue, "render side", |vl| {
        render(vl, side + 1, 1)
    });
    refused(&mut vl, ErrorCode::BadValue, "render pixels", |vl| {
        render(vl, w, h)
    });
    let mut buffer = vec![0u8; 16];
    refused(&mut vl, ErrorCode::BadValue, "render_into pixels", |vl| {
        vl.render_into(
            w as u32,
            h as u32,
            1.0,
            vlib::PixelFormat::Rgb8,
            &mut buffer,
        )
    });
}

#[test]
fn voxelizations_datasets_and_mappings_past_their_limits_are_refused() {
    let mut vl = scene();
    // 2¹⁶ × 2¹⁶ × 2 nodes: 2³³.
    let n = [1 << 16, 1 << 16, 2];
    assert!(n.iter().map(|&n| n as u64).product::<u64>() > MAX_VOLUME_NODES);
    refused(&mut vl, ErrorCode::NoMemory, "vlVolume nodes", |vl| {
        vl.volume("v", Fields::F, [0.0; 3], [1.0; 3], n, 1)
    });
    // With a bad voxel width too: the node counts come first among the parameters, so their
    // error is the one reported (errors.md, which error when several apply).
    refused(
        &mut vl,
        ErrorCode::NoMemory,
        "vlVolume nodes and bytes",
        |vl| vl.volume("v", Fields::F, [0.0; 3], [1.0; 3], n, 3),
    );
    let dims = [1 << 16, 1 << 16, 2];
    let e = Dataset::new(dims, Voxels::U8(vec![0; 8]), 0.0, 1.0).unwrap_err();
    assert_eq!(e.code, ErrorCode::BadDimensions, "{}", e.message);
    assert!(dims.iter().map(|&n| n as u64).product::<u64>() > MAX_VOXELS);
    refused(&mut vl, ErrorCode::BadValue, "vlMapping points", |vl| {
        vl.mapping(
            MappingId(1),
            MappingType::Lookup,
            MAX_POINTS as i32 + 1,
            1,
            &[],
        )
    });
    refused(&mut vl, ErrorCode::BadValue, "vlMapping outputs", |vl| {
        vl.mapping(
            MappingId(1),
            MappingType::Lookup,
            1,
            MAX_OUTPUTS as i32 + 1,
            &[],
        )
    });
    let mut row = vec![0.5f32; MAX_OUTPUTS + 1];
    row[0] = 0.0;
    vl.mapping(
        MappingId(1),
        MappingType::Lookup,
        1,
        MAX_OUTPUTS as i32,
        &row,
    )
    .unwrap();
}

/// A 100-unit object at a step of 10⁻⁹ would take 10¹¹ samples a ray (more than 2³²): its
/// render is `BadValue` before any pixel.
#[test]
fn rays_of_more_samples_than_the_limit_are_bad_values() {
    let mut vl = scene();
    vl.camera(&Camera {
        eye: [0.0, 0.0, -300.0],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov: 30.0,
    })
    .unwrap();
    vl.step_size(1e-9, 1.0).unwrap();
    vl.object().unwrap();
    vl.scale(100.0, 100.0, 100.0).unwrap();
    vl.set(Fields::ALL, 0.5).unwrap();
    vl.end().unwrap();
    assert!(100.0 * 3f64.sqrt() / 1e-9 > MAX_SAMPLES_PER_RAY);
    let e = vl.render(4, 4, 1.0, Backdrop::Background).unwrap_err();
    assert_eq!(e.code, ErrorCode::BadValue, "{}", e.message);
}
