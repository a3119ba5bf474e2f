//! Which error a command reports when several of its arguments are wrong at once
//! (`docs/errors.md`, "Which error, when several apply"): its scope first, then its field
//! masks (and, in C, its pointers and enumerations, which the Rust API takes as typed values),
//! then its values in the order of its parameters. Each case gets two arguments wrong and
//! expects the code of the one the rule puts first, as the C interface reports it; the refused
//! call changes nothing. (The C layer's own conversions are tested in `capi/src/tests/`.)

use vlib::{DatasetId, ErrorCode, Fields, MappingId, Sample};

#[path = "common/refused.rs"]
mod refused;
use refused::{refused, scene};

#[test]
fn vl_volume_reports_its_field_mask_before_its_prefix_and_values() {
    let mut vl = scene();
    // An empty prefix (BadFile) with an empty mask (BadField): the mask, which the C layer
    // converts before the core looks at the prefix.
    refused(
        &mut vl,
        ErrorCode::BadField,
        "empty prefix, no fields",
        |vl| vl.volume("", Fields::NONE, [0.0; 3], [1.0; 3], [2; 3], 1),
    );
    // An empty prefix with a NaN corner: the prefix, the first parameter.
    refused(
        &mut vl,
        ErrorCode::BadFile,
        "empty prefix, NaN corner",
        |vl| vl.volume("", Fields::F, [f32::NAN; 3], [1.0; 3], [2; 3], 1),
    );
    // A box of no size along z (x1 ≤ x0 with 2 nodes) with too many nodes (NoMemory): the
    // corners come before the node counts.
    refused(&mut vl, ErrorCode::BadValue, "flat box, 2^60 nodes", |vl| {
        vl.volume(
            "v",
            Fields::F,
            [0.0; 3],
            [1.0, 1.0, 0.0],
            [1 << 30, 1 << 30, 2],
            1,
        )
    });
}

#[test]
fn vl_image_reports_its_name_then_its_aspect_then_its_size() {
    let mut vl = scene();
    refused(&mut vl, ErrorCode::BadFile, "a .bmp name, aspect 0", |vl| {
        vl.image("a.bmp", 0.0, 2, 2)
    });
    refused(
        &mut vl,
        ErrorCode::BadFile,
        "a .bmp name, 2^30 pixels",
        |vl| vl.image("a.bmp", 1.0, 1 << 15, 1 << 15),
    );
    // Aspect 0 (BadValue) before 2^30 pixels (NoMemory).
    refused(
        &mut vl,
        ErrorCode::BadValue,
        "aspect 0, 2^30 pixels",
        |vl| vl.image("a.ppm", 0.0, 1 << 15, 1 << 15),
    );
}

#[test]
fn object_instructions_report_their_field_masks_before_their_ids_and_indices() {
    let mut vl = scene();
    vl.object().unwrap();
    refused(
        &mut vl,
        ErrorCode::BadField,
        "vlDataset: no fields, no dataset",
        |vl| vl.dataset(Fields::NONE, DatasetId(9)),
    );
    refused(
        &mut vl,
        ErrorCode::BadField,
        "vlMap: no targets, no mapping",
        |vl| vl.map(Fields::NONE, Fields::F, MappingId(9), 0),
    );
    refused(
        &mut vl,
        ErrorCode::BadField,
        "vlMap: two sources, no mapping",
        |vl| vl.map(Fields::O, Fields::O | Fields::F, MappingId(9), 0),
    );
    refused(
        &mut vl,
        ErrorCode::BadId,
        "vlMap: no mapping, output 0",
        |vl| vl.map(Fields::O, Fields::F, MappingId(9), 0),
    );
}

#[test]
fn vl_surface_reports_its_field_before_its_threshold() {
    let mut vl = scene();
    refused(
        &mut vl,
        ErrorCode::BadField,
        "two fields, threshold 2",
        |vl| vl.surface(Fields::O | Fields::F, 2.0),
    );
    refused(
        &mut vl,
        ErrorCode::BadField,
        "no field, NaN threshold",
        |vl| vl.surface(Fields::NONE, f32::NAN),
    );
}

#[test]
fn sample_scope_commands_report_their_field_masks_before_their_indices_and_ids() {
    let s = Sample::new([0.5; 3], [0.5; 3]);
    // vlChildField(99, two fields): no child 99 (BadIndex) and two fields (BadField).
    let e = s.child_field(99, Fields::O | Fields::F).unwrap_err();
    assert_eq!(e.code, ErrorCode::BadField, "{}", e.message);
    // vlSample(unknown id, NaN point): the id, the first parameter.
    let e = s.dataset(DatasetId(9), [f32::NAN; 3]).unwrap_err();
    assert_eq!(e.code, ErrorCode::BadId, "{}", e.message);
}

#[test]
fn vl_directional_light_reports_its_direction_before_its_colour() {
    let mut vl = scene();
    // A zero direction with a colour of 2: both BadValue; the message names the direction.
    let before = vl.fingerprint();
    let e = vl
        .directional_light([0.0; 3], [2.0, 0.5, 0.5], 1.0)
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::BadValue);
    assert!(e.message.contains("zero direction"), "{}", e.message);
    assert_eq!(vl.fingerprint(), before);
}
