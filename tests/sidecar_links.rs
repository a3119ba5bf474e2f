//! A dataset saved through a symbolic link has its geometry sidecar (`<name>.geom`) written or
//! removed beside the file the link leads to, where the `.vlb` itself is written, not beside
//! the link: a geometry saved through a link is the target's, and a stale sidecar beside the
//! target (which would describe another grid, and fail its load) is removed. The same for the
//! files of a voxelization (`vlVolume`) whose prefix names links. A dataset loaded through a
//! link reads the sidecar beside the file the link leads to.

#[path = "common/dirs.rs"]
mod dirs;
use dirs::names;
use std::fs;
use std::os::unix::fs::symlink;
use std::path::Path;
use vlib::{Dataset, Fields, Geometry, Library, Voxels};

/// Whether `p` is a symbolic link.
fn is_link(p: &Path) -> bool {
    fs::symlink_metadata(p).unwrap().file_type().is_symlink()
}

/// An `n³` dataset of 8-bit voxels 0, 1, 2, …, with `geometry` if given.
fn cube(n: usize, geometry: Option<Geometry>) -> Dataset {
    let voxels = (0..n * n * n).map(|i| i as u8).collect();
    let d = Dataset::new([n; 3], Voxels::U8(voxels), 0.0, 255.0).unwrap();
    match geometry {
        Some(g) => d.with_geometry(g),
        None => d,
    }
}

/// The brief's case, through a relative link in another directory (`links/ct.vlb` →
/// `../real/ct.vlb`): a 4³ dataset with a geometry saved at the target, then a 2³ one without
/// geometry through the link, removes the target's sidecar (it described the 4³ grid, and the
/// target failed to load: `"dims 4 4 4" is not "dims 2 2 2"`); then a 2³ one with a geometry
/// through the link writes its sidecar beside the target (it went beside the link, and the
/// target loaded without it). Nothing is made beside the link, which stays a link.
#[test]
fn a_sidecar_goes_beside_the_file_a_link_leads_to() {
    let dir = dirs::scratch("sidecar-links", "relative");
    fs::create_dir(dir.join("real")).unwrap();
    fs::create_dir(dir.join("links")).unwrap();
    symlink("../real/ct.vlb", dir.join("links/ct.vlb")).unwrap();
    let (real, link) = (dir.join("real/ct.vlb"), dir.join("links/ct.vlb"));
    let g4 = Geometry::axis_aligned([0.5, 0.5, 2.0], [-10.0, 20.0, 3.0]).unwrap();
    cube(4, Some(g4)).save(&real).unwrap();
    assert_eq!(names(&dir.join("real")), ["ct.vlb", "ct.vlb.geom"]);
    assert_eq!(Dataset::load(&real).unwrap(), cube(4, Some(g4)));

    // Without geometry, through the link: the target's stale sidecar is removed.
    cube(2, None).save(&link).unwrap();
    assert_eq!(names(&dir.join("real")), ["ct.vlb"]);
    assert_eq!(names(&dir.join("links")), ["ct.vlb"]);
    assert!(is_link(&link));
    for path in [&real, &link] {
        let loaded = Dataset::load(path).unwrap();
        assert_eq!(loaded, cube(2, None));
        assert_eq!(loaded.geometry(), None);
    }

    // With geometry, through the link: its sidecar is the target's.
    let g2 = Geometry::axis_aligned([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]).unwrap();
    cube(2, Some(g2)).save(&link).unwrap();
    assert_eq!(names(&dir.join("real")), ["ct.vlb", "ct.vlb.geom"]);
    assert_eq!(names(&dir.join("links")), ["ct.vlb"]);
    assert!(is_link(&link));
    assert_eq!(
        fs::read_to_string(dir.join("real/ct.vlb.geom")).unwrap(),
        g2.to_text([2; 3])
    );
    assert_eq!(Dataset::load(&real).unwrap().geometry(), Some(&g2));
    // Loaded through the link, the dataset has the sidecar beside the file it leads to.
    assert_eq!(Dataset::load(&link).unwrap(), cube(2, Some(g2)));
    fs::remove_dir_all(&dir).unwrap();
}

/// The same through an absolute link, through a chain of two links (the sidecar goes beside
/// the file the chain ends at), and through a dangling link (the file and its sidecar are made
/// at its target).
#[test]
fn a_sidecar_follows_absolute_chained_and_dangling_links() {
    let dir = dirs::scratch("sidecar-links", "chains");
    fs::create_dir(dir.join("real")).unwrap();
    fs::create_dir(dir.join("links")).unwrap();
    let real = dir.join("real/ct.vlb");
    symlink(&real, dir.join("links/abs.vlb")).unwrap();
    symlink("links/abs.vlb", dir.join("chain.vlb")).unwrap();
    symlink("../real/new.vlb", dir.join("links/new.vlb")).unwrap();
    let g = Geometry::axis_aligned([0.25, 0.5, 0.75], [1.0, -2.0, 3.0]).unwrap();

    // A stale sidecar of a 3³ grid beside the target, removed through the absolute link.
    cube(3, Some(g)).save(&real).unwrap();
    cube(2, None).save(&dir.join("links/abs.vlb")).unwrap();
    assert_eq!(names(&dir.join("real")), ["ct.vlb"]);
    assert_eq!(Dataset::load(&real).unwrap(), cube(2, None));

    // A geometry through the chain.
    cube(2, Some(g)).save(&dir.join("chain.vlb")).unwrap();
    assert_eq!(names(&dir.join("real")), ["ct.vlb", "ct.vlb.geom"]);
    assert_eq!(Dataset::load(&real).unwrap(), cube(2, Some(g)));

    // A stale sidecar removed through the chain.
    cube(3, None).save(&dir.join("chain.vlb")).unwrap();
    assert_eq!(names(&dir.join("real")), ["ct.vlb"]);
    assert_eq!(Dataset::load(&real).unwrap(), cube(3, None));

    // A dangling link: the file and its sidecar are made at the target.
    cube(2, Some(g)).save(&dir.join("links/new.vlb")).unwrap();
    assert_eq!(
        names(&dir.join("real")),
        ["ct.vlb", "new.vlb", "new.vlb.geom"]
    );
    assert_eq!(
        Dataset::load(&dir.join("real/new.vlb")).unwrap(),
        cube(2, Some(g))
    );
    assert_eq!(names(&dir), ["chain.vlb", "links", "real"]);
    assert_eq!(names(&dir.join("links")), ["abs.vlb", "new.vlb"]);
    for l in ["chain.vlb", "links/abs.vlb", "links/new.vlb"] {
        assert!(is_link(&dir.join(l)), "{l}");
    }
    fs::remove_dir_all(&dir).unwrap();
}

/// A voxelization whose files are links (`links/v_o.vlb` → `../real/v_o.vlb`) removes the
/// stale sidecar beside the target (one of a 9³ grid, which made the target's load fail), and
/// makes nothing beside the link.
#[test]
fn a_voxelization_through_a_link_removes_the_targets_stale_sidecar() {
    let dir = dirs::scratch("sidecar-links", "volume");
    fs::create_dir(dir.join("real")).unwrap();
    fs::create_dir(dir.join("links")).unwrap();
    symlink("../real/v_o.vlb", dir.join("links/v_o.vlb")).unwrap();
    let g = Geometry::axis_aligned([1.0; 3], [0.0; 3]).unwrap();
    cube(9, Some(g)).save(&dir.join("real/v_o.vlb")).unwrap();
    assert_eq!(names(&dir.join("real")), ["v_o.vlb", "v_o.vlb.geom"]);

    // Opacity 0.5 everywhere in the unit cube, sampled at 3³ nodes of it: 128 at every node
    // (0.5 · 255 = 127.5, rounded half away from zero).
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.object().unwrap();
    vl.function(Fields::O, |s| {
        let _ = s.set(Fields::O, 0.5);
    })
    .unwrap();
    vl.end().unwrap();
    vl.volume(
        dir.join("links/v"),
        Fields::O,
        [0.1; 3],
        [0.9; 3],
        [3, 3, 3],
        1,
    )
    .unwrap();
    vl.end().unwrap();

    assert_eq!(names(&dir.join("real")), ["v_o.vlb"]);
    assert_eq!(names(&dir.join("links")), ["v_o.vlb"]);
    assert!(is_link(&dir.join("links/v_o.vlb")));
    let loaded = Dataset::load(&dir.join("real/v_o.vlb")).unwrap();
    let want = Dataset::new([3; 3], Voxels::U8(vec![128; 27]), 0.0, 255.0).unwrap();
    assert_eq!(loaded, want);
    assert_eq!(loaded.geometry(), None);
    fs::remove_dir_all(&dir).unwrap();
}
