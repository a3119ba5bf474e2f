//! A dataset's physical placement (`vlib::Geometry`, the sidecar `vlconvert` writes): the
//! sidecar carries the writer's own affine (nibabel's for NIfTI, sform and qform; pynrrd's LPS
//! space directions turned into RAS; SimpleITK's spacing, origin and direction for MetaImage,
//! LPS turned into RAS), and `Library::place_dataset` shows a converted volume at
//! its physical size and orientation: the anisotropic NIfTI fixture (spacing 0.5 × 0.5 × 2 mm,
//! x flipped) keeps its aspect and its subject's right on the +x side.

use std::path::{Path, PathBuf};
use std::process::Command;
use vlib::DatasetId;
use vlib::{Camera, Dataset, Fields, Geometry, Library};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// Converts fixture `name` into a scratch directory; returns the `.vlb`'s path.
fn convert(name: &str) -> PathBuf {
    // A directory of its own per call: the tests run at once and remove theirs.
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let d = std::env::temp_dir().join(format!(
        "vlib-geometry-{}-{}-{call}",
        name.replace(['/', '.'], "-"),
        std::process::id()
    ));
    std::fs::create_dir_all(&d).unwrap();
    let out = d.join("out.vlb");
    let o = Command::new(env!("CARGO_BIN_EXE_vlconvert"))
        .arg(fixture(name))
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

/// The writer's 3 × 4 affine beside a fixture (`NAME.affine.txt`).
fn writers_affine(stem: &str) -> [[f64; 4]; 3] {
    let text = std::fs::read_to_string(fixture(&format!("{stem}.affine.txt"))).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
        .collect();
    [0, 1, 2].map(|r| [0, 1, 2, 3].map(|c| rows[r][c]))
}

/// The sidecar holds the writer's placement, to f32's precision (NIfTI stores f32).
#[test]
fn the_sidecar_is_the_writers_affine() {
    for (file, stem) in [
        ("nifti/int16_aniso.nii", "nifti/int16_aniso"),
        ("nifti/uint8_qform.nii", "nifti/uint8_qform"),
        ("nifti/uint8_pair.hdr", "nifti/uint8_pair"),
        ("nrrd/int16_lps.nrrd", "nrrd/int16_lps"),
        ("nrrd/uint8_oblique.nrrd", "nrrd/uint8_oblique"),
        ("metaimage/int16_oblique.mha", "metaimage/int16_oblique"),
        ("metaimage/uint8_spacing.mhd", "metaimage/uint8_spacing"),
    ] {
        let out = convert(file);
        let d = Dataset::load(&out).unwrap();
        let g = d.geometry().expect("a geometry");
        let want = writers_affine(stem);
        for (r, (got_row, want_row)) in g.affine().iter().zip(&want).enumerate() {
            for (c, (got, w)) in got_row.iter().zip(want_row).enumerate() {
                assert!(
                    (got - w).abs() <= 1e-5 * w.abs().max(1.0),
                    "{file} [{r}][{c}]: {got} vs {w}"
                );
            }
        }
        std::fs::remove_dir_all(out.parent().unwrap()).unwrap();
    }
}

/// pynrrd's `int16_lps.nrrd` with its placement fields changed: two space directions for its
/// three axes, or `space dimension: 3` in place of its `space` (so no orientation in the body),
/// convert without a placement and with a note saying why, instead of a third axis made up or
/// a placement dropped unsaid.
#[test]
fn nrrd_placements_short_of_an_axis_or_a_space_are_notes() {
    let good = std::fs::read(fixture("nrrd/int16_lps.nrrd")).unwrap();
    let at = good.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
    let header = String::from_utf8(good[..at].to_vec()).unwrap();
    let d = std::env::temp_dir().join(format!("vlib-geometry-nrrd-notes-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    for (from, to, says) in [
        (
            "space directions: (0.5,0,0) (0,0.75,0) (0,0,2.5)",
            "space directions: (0.5,0,0) (0,0.75,0)",
            "no placement: space directions \"(0.5,0,0) (0,0.75,0)\": 2 vectors for 3 axes",
        ),
        (
            "space: left-posterior-superior",
            "space dimension: 3",
            "no placement: space directions without a space field (space dimension 3 names no \
             orientation in the body)",
        ),
    ] {
        assert!(header.contains(from));
        let f = d.join("v.nrrd");
        std::fs::write(
            &f,
            [header.replace(from, to).as_bytes(), &good[at..]].concat(),
        )
        .unwrap();
        let out = d.join("v.vlb");
        let o = Command::new(env!("CARGO_BIN_EXE_vlconvert"))
            .arg(&f)
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{to}: {err}");
        assert!(err.contains(says), "{to}: {err}");
        assert!(Dataset::load(&out).unwrap().geometry().is_none(), "{to}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// The sidecar's text: round trip, and each malformed form refused with `BadFile`.
#[test]
fn sidecars_round_trip_and_refuse_malformed_text() {
    let g = Geometry::new([
        [0.5, 0.0, 0.0, -3.0],
        [0.0, 0.25, 0.1, 2.0],
        [0.0, 0.0, 2.0, 1e-3],
    ])
    .unwrap();
    assert_eq!(
        Geometry::parse(&g.to_text([4, 3, 2]), [4, 3, 2]).unwrap(),
        g
    );
    // Beside a file of another grid (a stale sidecar), refused.
    let e = Geometry::parse(&g.to_text([4, 3, 2]), [4, 3, 3]).unwrap_err();
    assert_eq!(e.code, vlib::ErrorCode::BadFile);
    assert!(e.message.contains("dims 4 3 3"), "{}", e.message);
    let spacing = g.spacing();
    assert!((spacing[2] - (0.1f64 * 0.1 + 4.0).sqrt()).abs() < 1e-12);
    for bad in [
        "",
        "vlib-geometry 2\nrow 1 0 0 0\nrow 0 1 0 0\nrow 0 0 1 0\n",
        "vlib-geometry 1\nrow 1 0 0 0\nrow 0 1 0 0\n",
        "vlib-geometry 1\nrow 1 0 0 0\nrow 0 1 0 0\nrow 0 0 x 0\n",
        "vlib-geometry 1\nrow 1 0 0 0\nrow 0 1 0 0\nrow 0 0 1 0\nrow 0 0 0 1\n",
        "vlib-geometry 1\nrow 1 0 0 0\nrow 2 0 0 0\nrow 0 0 1 0\n",
        "vlib-geometry 1\nrow 1 0 0 0\nrow 0 1 0 0\nrow 0 0 NaN 0\n",
    ] {
        let bad = bad.replacen("\nrow", "\ndims 2 2 2\nrow", 1);
        let e = Geometry::parse(&bad, [2, 2, 2]).unwrap_err();
        assert_eq!(e.code, vlib::ErrorCode::BadFile, "{bad:?}");
    }
}

/// A library with the converted anisotropic fixture loaded as dataset 1 and a scene seen from
/// anterior (+y, far away, up +z) at 200², whose one object is placed by the dataset and
/// shows where `opaque` holds of the object point.
fn anterior_view(opaque: fn([f32; 3]) -> bool) -> vlib::Image {
    let out = convert("nifti/int16_aniso.nii");
    let mut vl = Library::new();
    vl.load(DatasetId(1), &out).unwrap();
    std::fs::remove_dir_all(out.parent().unwrap()).unwrap();
    vl.scene().unwrap();
    // The box spans x 28 … 30, y −20 … −18.5, z −10 … −6 (nodes 0 … n − 1, spacing
    // 0.5 × 0.5 × 2, x flipped): its centre is (29, −19.25, −8).
    vl.camera(&Camera {
        eye: [29.0, 1980.75, -8.0],
        at: [29.0, -19.25, -8.0],
        up: [0.0, 0.0, 1.0],
        fov: 0.2,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.step_size(0.05, 1.0).unwrap();
    vl.object().unwrap();
    vl.place_dataset(DatasetId(1)).unwrap();
    vl.dataset(Fields::F, DatasetId(1)).unwrap();
    vl.function(Fields::O, move |s| {
        let _ = s.set(Fields::O, if opaque(s.position()) { 1.0 } else { 0.0 });
    })
    .unwrap();
    vl.set(Fields::COLORS | Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    vl.render_preview(200, 200, 1.0).unwrap()
}

/// The columns and rows of `img` that hold a lit pixel: (first, last) of each.
fn lit_extent(img: &vlib::Image) -> ((u32, u32), (u32, u32)) {
    let lit = |x: u32, y: u32| img.pixel(x, y)[0] > 0.5;
    let cols: Vec<u32> = (0..img.width)
        .filter(|&x| (0..img.height).any(|y| lit(x, y)))
        .collect();
    let rows: Vec<u32> = (0..img.height)
        .filter(|&y| (0..img.width).any(|x| lit(x, y)))
        .collect();
    assert!(!cols.is_empty(), "something is lit");
    (
        (cols[0], *cols.last().unwrap()),
        (rows[0], *rows.last().unwrap()),
    )
}

/// At its physical size: the box is 2 mm wide (x) and 4 mm tall (z) seen from anterior, so
/// its silhouette's width is half its height (within two pixels of the 120 it spans), where the
/// unit cube would give 1.
#[test]
fn a_placed_anisotropic_volume_keeps_its_aspect() {
    let img = anterior_view(|_| true);
    let ((x0, x1), (y0, y1)) = lit_extent(&img);
    let (w, h) = ((x1 - x0 + 1) as f64, (y1 - y0 + 1) as f64);
    // The view spans 2 · 2000 · tan(0.1°) ≈ 6.98 mm over 200 pixels.
    let px = 2.0 * 2000.0 * (0.1f64).to_radians().tan() / 200.0;
    assert!(
        (h * px - 4.0).abs() < 2.0 * px,
        "height {h} px = {} mm, 4 mm",
        h * px
    );
    assert!(
        (w * px - 2.0).abs() < 2.0 * px,
        "width {w} px = {} mm, 2 mm",
        w * px
    );
}

/// Not mirrored: the fixture's x axis is flipped (node i = 0 at x = 30, the subject's right),
/// so the quarter of the object nearest node 0 lies at the largest x; the camera model puts +x
/// to the image's right (right = up × forward = (1, 0, 0) here), so it shows in the right half.
#[test]
fn a_placed_volume_keeps_its_right_on_the_right() {
    let img = anterior_view(|p| p[0] < 0.25);
    let ((x0, x1), _) = lit_extent(&img);
    assert!(
        x0 > 100,
        "the marker spans columns {x0} … {x1}: the right half"
    );
    let whole = anterior_view(|_| true);
    let ((w0, w1), _) = lit_extent(&whole);
    assert!(
        x1 <= w1 + 1 && x0 > (w0 + w1) / 2,
        "within the box's right half"
    );
}

/// Without geometry, place_dataset is refused and changes nothing; an unknown id is BadId.
#[test]
fn placing_needs_a_dataset_with_geometry() {
    let mut vl = Library::new();
    vl.add_dataset(
        DatasetId(2),
        Dataset::new([2, 2, 2], vlib::Voxels::U8(vec![0; 8]), 0.0, 255.0).unwrap(),
    )
    .unwrap();
    vl.scene().unwrap();
    vl.object().unwrap();
    let before = vl.fingerprint();
    assert_eq!(
        vl.place_dataset(DatasetId(2)).unwrap_err().code,
        vlib::ErrorCode::BadValue
    );
    assert_eq!(
        vl.place_dataset(DatasetId(9)).unwrap_err().code,
        vlib::ErrorCode::BadId
    );
    assert_eq!(vl.fingerprint(), before);
}

/// An oblique placement (the NRRD fixture turned 30° about z, spacing 1 × 2 × 3): the part of
/// the object near node (4, 0, ·) shows where the writer's affine puts those nodes. Seen from
/// far above (+z, up +y), the marker's centroid lies within two pixels of the projection of
/// A·(3.5, 0.375, 1) + t (the centre of its region, object x 0.75 … 1, y 0 … 0.25), by the
/// camera model: right = up × forward, up = forward × right. A transposed or mirrored A puts it
/// elsewhere.
#[test]
fn an_oblique_placement_puts_each_node_where_the_writer_does() {
    let out = convert("nrrd/uint8_oblique.nrrd");
    let a = writers_affine("nrrd/uint8_oblique");
    let world =
        |p: [f64; 3]| [0, 1, 2].map(|r| a[r][0] * p[0] + a[r][1] * p[1] + a[r][2] * p[2] + a[r][3]);
    // The box's centre, nodes (2, 1.5, 1).
    let c = world([2.0, 1.5, 1.0]);
    let cam = Camera {
        eye: [c[0] as f32, c[1] as f32, c[2] as f32 + 2000.0],
        at: [c[0] as f32, c[1] as f32, c[2] as f32],
        up: [0.0, 1.0, 0.0],
        fov: 0.4,
    };
    let mut vl = Library::new();
    vl.load(DatasetId(1), &out).unwrap();
    std::fs::remove_dir_all(out.parent().unwrap()).unwrap();
    vl.scene().unwrap();
    vl.camera(&cam).unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.step_size(0.05, 1.0).unwrap();
    vl.object().unwrap();
    vl.place_dataset(DatasetId(1)).unwrap();
    vl.dataset(Fields::F, DatasetId(1)).unwrap();
    vl.function(Fields::O, |s| {
        let p = s.position();
        let _ = s.set(
            Fields::O,
            if p[0] > 0.75 && p[1] < 0.25 { 1.0 } else { 0.0 },
        );
    })
    .unwrap();
    vl.set(Fields::COLORS | Fields::KA, 1.0).unwrap();
    vl.end().unwrap();
    let (w, h) = (200u32, 200u32);
    let img = vl.render_preview(w, h, 1.0).unwrap();
    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
    for y in 0..h {
        for x in 0..w {
            if img.pixel(x, y)[0] > 0.5 {
                sx += x as f64 + 0.5;
                sy += y as f64 + 0.5;
                n += 1.0;
            }
        }
    }
    assert!(n > 10.0, "the marker shows ({n} pixels)");
    // The camera model: f the view direction, r = up × f, u = f × r; a point at v from the
    // eye lands at ((1 + (v·r)/(v·f)/t)·w/2, (1 − (v·u)/(v·f)/t)·h/2), t = tan(fov / 2).
    let (f, up) = ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0]);
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let r = cross(up, f);
    let u = cross(f, r);
    let p = world([3.5, 0.375, 1.0]);
    let v = [0, 1, 2].map(|i| p[i] - cam.eye[i] as f64);
    let t = (0.2f64).to_radians().tan();
    let ex = (1.0 + dot(v, r) / dot(v, f) / t) * w as f64 / 2.0;
    let ey = (1.0 - dot(v, u) / dot(v, f) / t) * h as f64 / 2.0;
    let (gx, gy) = (sx / n, sy / n);
    assert!(
        (gx - ex).abs() < 2.0 && (gy - ey).abs() < 2.0,
        "marker at ({gx:.1}, {gy:.1}), the writer's nodes at ({ex:.1}, {ey:.1})"
    );
}

/// A sidecar beside a file of another grid (copied, or left by an earlier file of the name) is
/// refused at load with `BadFile`, naming the grid; saving a dataset without geometry removes
/// the sidecar an earlier file left, and one with geometry writes its own.
#[test]
fn a_sidecar_of_another_grid_is_refused_and_saving_keeps_them_paired() {
    let out = convert("nifti/int16_aniso.nii");
    let dir = out.parent().unwrap().to_path_buf();
    let other = dir.join("other.vlb");
    Dataset::new([2, 2, 2], vlib::Voxels::U8(vec![1; 8]), 0.0, 255.0)
        .unwrap()
        .save(&other)
        .unwrap();
    assert!(Dataset::load(&other).unwrap().geometry().is_none());
    std::fs::copy(Geometry::sidecar(&out), Geometry::sidecar(&other)).unwrap();
    let e = Dataset::load(&other).unwrap_err();
    assert_eq!(e.code, vlib::ErrorCode::BadFile);
    assert!(e.message.contains("dims 2 2 2"), "{}", e.message);
    // Saved again without geometry: the stale sidecar goes.
    Dataset::new([2, 2, 2], vlib::Voxels::U8(vec![1; 8]), 0.0, 255.0)
        .unwrap()
        .save(&other)
        .unwrap();
    assert!(!Geometry::sidecar(&other).exists());
    // Saved with the converted dataset's geometry: loaded back the same.
    let placed = Dataset::load(&out).unwrap();
    let copy = dir.join("copy.vlb");
    placed.save(&copy).unwrap();
    assert_eq!(Dataset::load(&copy).unwrap(), placed);
    std::fs::remove_dir_all(&dir).unwrap();
}
