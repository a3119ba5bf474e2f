//! The placement a dataset carries: every [`Geometry`] that can be made is one its sidecar
//! holds and a load reads back; what a sidecar cannot hold is refused when it is made.

use super::*;

/// A fresh directory for one test's files.
fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("vlib-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A spacing or origin that is not finite, or a spacing of 0, is refused with `BadValue`
/// by `axis_aligned` (as by `new`): no dataset can carry it, so none is saved with a sidecar
/// that its load would refuse (`row 0 0 NaN 0`).
#[test]
fn axis_aligned_refuses_what_a_sidecar_cannot_hold() {
    let bad: [([f64; 3], [f64; 3]); 6] = [
        ([0.0, 1.0, f64::NAN], [0.0; 3]),
        ([1.0, f64::INFINITY, 1.0], [0.0; 3]),
        ([1.0, 1.0, 1.0], [f64::NEG_INFINITY, 0.0, 0.0]),
        ([1.0, 1.0, 1.0], [0.0, f64::NAN, 0.0]),
        ([1.0, 0.0, 1.0], [0.0; 3]),
        ([0.0; 3], [0.0; 3]),
    ];
    for (s, o) in bad {
        let e = Geometry::axis_aligned(s, o).unwrap_err();
        assert_eq!(e.code, ErrorCode::BadValue, "spacing {s:?}, origin {o:?}");
    }
    let g = Geometry::axis_aligned([0.5, 2.0, -3.0], [-60.0, 1.25, 7.0]).unwrap();
    assert_eq!(g.spacing(), [0.5, 2.0, 3.0]);
    assert_eq!(g.origin(), [-60.0, 1.25, 7.0]);
    assert_eq!(
        g.affine(),
        [
            [0.5, 0.0, 0.0, -60.0],
            [0.0, 2.0, 0.0, 1.25],
            [0.0, 0.0, -3.0, 7.0]
        ]
    );
}

/// Spacings whose squares or whose product leave f64's range are refused with `BadValue` (as
/// `Geometry::new` says), though A is invertible: the test of |det A| against the product of
/// the spacings cannot be made there.
#[test]
fn spacings_beyond_f64s_range_are_refused() {
    for s in [1e-200, 1e-110, 1e110, 1e200] {
        let e = Geometry::axis_aligned([s; 3], [0.0; 3]).unwrap_err();
        assert_eq!(e.code, ErrorCode::BadValue, "spacing {s}");
        assert!(e.message.contains("degenerate"), "{}", e.message);
    }
}

/// Geometries at the edges of what `new` accepts (tiny and huge spacings, a rotation,
/// mirrored axes, far origins) are saved beside their dataset and load back equal.
#[test]
fn every_geometry_a_dataset_carries_loads_back() {
    let dir = scratch("geometry-round-trip");
    let (c, s) = (0.6f64, 0.8f64);
    let affines = [
        [
            [1e-90, 0.0, 0.0, 0.0],
            [0.0, 1e-90, 0.0, 0.0],
            [0.0, 0.0, 1e-90, 0.0],
        ],
        [
            [1e90, 0.0, 0.0, -1e300],
            [0.0, 1e90, 0.0, 1e300],
            [0.0, 0.0, 1e90, f64::MAX],
        ],
        [
            [c, -s, 0.0, 0.1],
            [s, c, 0.0, 0.2],
            [0.0, 0.0, -1.0 / 3.0, 0.3],
        ],
        [
            [-0.9375, 0.0, 0.0, 119.53125],
            [0.0, 0.0, 1.2, -80.0],
            [0.0, -0.9375, 0.0, f64::MIN_POSITIVE],
        ],
    ];
    for (n, affine) in affines.into_iter().enumerate() {
        let g = Geometry::new(affine).unwrap();
        let d = random_u8([3, 2, 2], n as u64).with_geometry(g);
        let path = dir.join(format!("d{n}.vlb"));
        d.save(&path).unwrap();
        let back = Dataset::load(&path).unwrap();
        assert_eq!(back.geometry(), Some(&g), "{affine:?}");
        assert_eq!(back.geometry().unwrap().affine(), affine);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
