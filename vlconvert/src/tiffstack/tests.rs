//! The pure parts of the TIFF reader: natural order, TIFF magic, ImageJ's description.

use super::{imagej_fields, imagej_unit, is_tiff, natural_key};

fn sorted(names: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = names.iter().map(|n| n.to_string()).collect();
    v.sort_by_cached_key(|n| natural_key(n));
    v
}

#[test]
fn natural_order_compares_numbers_as_numbers() {
    assert_eq!(
        sorted(&["slice_10.tif", "slice_2.tif", "slice_1.tif", "slice_11.tif"]),
        ["slice_1.tif", "slice_2.tif", "slice_10.tif", "slice_11.tif"]
    );
    // Several numbers: the first that differs decides; leading zeros do not count, except
    // to order equal numbers (fewer zeros first).
    assert_eq!(
        sorted(&[
            "s2_z10.tif",
            "s2_z9.tif",
            "s10_z1.tif",
            "s02_z9.tif",
            "s1_z100.tif"
        ]),
        [
            "s1_z100.tif",
            "s2_z9.tif",
            "s02_z9.tif",
            "s2_z10.tif",
            "s10_z1.tif"
        ]
    );
    // Numbers beyond any integer type still compare by value.
    let big = "x123456789012345678901234567890123456789012345.tif";
    let bigger = "x923456789012345678901234567890123456789012345.tif";
    let biggest = "x1000000000000000000000000000000000000000000000.tif";
    assert_eq!(sorted(&[biggest, bigger, big]), [big, bigger, biggest]);
}

#[test]
fn tiff_magic_in_both_byte_orders_and_bigtiff() {
    for head in [&b"II*\0rest"[..], b"MM\0*rest", b"II+\0rest", b"MM\0+rest"] {
        assert!(is_tiff(head), "{head:?}");
    }
    for head in [&b"II*"[..], b"MM*\0", b"II\0*", b"\x89PNG"] {
        assert!(!is_tiff(head), "{head:?}");
    }
}

#[test]
fn imagej_descriptions_give_units_and_spacing() {
    let f = imagej_fields("ImageJ=1.54f\nimages=3\nslices=3\nunit=micron\nspacing=2.5\n").unwrap();
    let get = |k: &str| f.iter().find(|(n, _)| n == k).map(|(_, v)| v.as_str());
    assert_eq!(get("slices"), Some("3"));
    assert_eq!(get("spacing"), Some("2.5"));
    assert_eq!(imagej_unit(get("unit").unwrap()), Some(1e-3));
    assert!(imagej_fields("{\"shape\": [3, 4, 5]}").is_none());
    for (name, mm) in [
        ("mm", 1.0),
        ("\\u00B5m", 1e-3),
        ("µm", 1e-3),
        ("um", 1e-3),
        ("nm", 1e-6),
        ("cm", 10.0),
        ("inch", 25.4),
    ] {
        assert_eq!(imagej_unit(name), Some(mm), "{name}");
    }
    assert_eq!(imagej_unit("pixel"), None);
}
