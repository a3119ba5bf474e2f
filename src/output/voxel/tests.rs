//! Unit tests of the voxelization: slabs against the whole grid, cancellation, panics.

use super::*;
use crate::control::{CancelFlag, RenderControl};
use crate::model::scene::VolumeRequest;
use crate::types::Fields;
use crate::Library;
use std::fs;
use std::path::Path;
use std::sync::{Arc, Mutex};

/// A fresh empty directory for one test.
fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vlib-voxel-{tag}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Two overlapping objects whose fields vary everywhere (so that every node, and which object
/// wins it, matters), compiled; the second object's field function panics at points whose
/// object z is above `panic_above` (its object space is the world's moved by (0.4, 0.3, 0.2)).
fn scene(panic_above: f32) -> Compiled {
    let mut vl = Library::new();
    vl.scene().unwrap();
    vl.object().unwrap();
    vl.function(Fields::O | Fields::R | Fields::KS, |s| {
        let [x, y, z] = s.position();
        let _ = s.set(Fields::O, (x * 3.1 + y * y).fract());
        let _ = s.set(Fields::R, (x * y * 7.3 + z).fract());
        let _ = s.set(Fields::KS, 0.5 + 0.5 * (z * 11.0).sin());
    })
    .unwrap();
    vl.end().unwrap();
    vl.object().unwrap();
    vl.translate(0.4, 0.3, 0.2).unwrap();
    vl.function(Fields::O | Fields::R, move |s| {
        let [x, y, z] = s.position();
        assert!(z <= panic_above, "a field function's panic");
        let _ = s.set(Fields::O, (y * 5.7 + z * 0.3).fract());
        let _ = s.set(Fields::R, (x + y + z) / 3.0);
    })
    .unwrap();
    vl.end().unwrap();
    vl.compiled().unwrap()
}

/// The whole-grid reference: the whole grid at once (`z` planes in parallel,
/// collected), each field quantised, and the `.vlb` bytes laid out by hand.
fn whole_grid_files(scene: &Compiled, req: &VolumeRequest) -> Vec<(usize, Vec<u8>)> {
    let [nx, ny, nz] = req.nodes;
    let (a, b) = (req.corner0, req.corner1);
    let grid: Vec<[f32; FIELD_COUNT]> = (0..nz)
        .into_par_iter()
        .flat_map_iter(|k| {
            let z = node(a[2], b[2], k, nz);
            (0..ny).flat_map(move |j| {
                let y = node(a[1], b[1], j, ny);
                (0..nx).map(move |i| scene.fields_at(DVec3::new(node(a[0], b[0], i, nx), y, z)))
            })
        })
        .collect();
    let max = if req.bytes == 1 { 255.0 } else { 65535.0 };
    req.fields
        .indices()
        .map(|field| {
            let mut out = b"VLB1".to_vec();
            for n in req.nodes {
                out.extend_from_slice(&(n as u32).to_le_bytes());
            }
            out.extend_from_slice(&req.bytes.to_le_bytes());
            out.extend_from_slice(&0f32.to_le_bytes());
            out.extend_from_slice(&(max as f32).to_le_bytes());
            for f in &grid {
                let q = (f[field] as f64 * max).round();
                if req.bytes == 1 {
                    out.push(q as u8);
                } else {
                    out.extend_from_slice(&(q as u16).to_le_bytes());
                }
            }
            (field, out)
        })
        .collect()
}

fn request(dir: &Path, nodes: [usize; 3], bytes: u32, fields: Fields) -> VolumeRequest {
    VolumeRequest {
        prefix: dir.join("v"),
        fields,
        corner0: [-0.2, -0.1, 0.0],
        corner1: [1.3, 1.2, 1.25],
        nodes,
        bytes,
    }
}

/// Grids of several slabs, the last one partial, whose slabs start in the middle of x-rows
/// and z-planes (and a grid smaller than one slab, and one of a single node): every file is
/// byte for byte the whole-grid computation's, for 8- and 16-bit voxels, and the progress
/// function hears of every slab, the last report being 1.
#[test]
fn slabs_write_the_whole_grids_bytes() {
    let scene = scene(f32::INFINITY);
    let dir = scratch("slabs");
    for (nodes, bytes) in [
        ([37, 29, 150], 1),
        ([53, 1, 2600], 2),
        ([256, 256, 3], 1),
        ([5, 4, 3], 2),
        ([1, 1, 1], 1),
    ] {
        let total: usize = nodes.iter().product();
        let req = request(&dir, nodes, bytes, Fields::O | Fields::R | Fields::KS);
        let reports = Arc::new(Mutex::new(Vec::new()));
        let seen = reports.clone();
        let control = RenderControl {
            cancel: None,
            progress: Some(Arc::new(move |f| {
                seen.lock().unwrap().push(f);
                true
            })),
        };
        write(&scene, &req, &Progress::new(&control, total as u64)).unwrap();
        for (field, expected) in whole_grid_files(&scene, &req) {
            let got = fs::read(file_name(&req, field)).unwrap();
            assert!(got == expected, "{nodes:?} × {bytes} bytes, field {field}");
        }
        let reports = reports.lock().unwrap();
        assert_eq!(reports.len(), total.div_ceil(SLAB_NODES), "{nodes:?}");
        assert!(reports.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(*reports.last().unwrap(), 1.0);
        assert_eq!(names(&dir), ["v_ks.vlb", "v_o.vlb", "v_r.vlb"]);
    }
    fs::remove_dir_all(&dir).unwrap();
}

/// A cancelled voxelization (its flag set before it starts, or its progress function saying
/// stop after the first slab) is `Cancelled` and leaves no file and no temporary, not even an
/// older file's replacement: a file already there is kept as it was.
#[test]
fn a_cancelled_voxelization_writes_no_file() {
    let scene = scene(f32::INFINITY);
    let dir = scratch("cancel");
    let req = request(&dir, [40, 40, 100], 1, Fields::O | Fields::R);
    fs::write(dir.join("v_o.vlb"), b"older").unwrap();
    let flag = CancelFlag::new();
    flag.cancel();
    let by_flag = RenderControl {
        cancel: Some(flag),
        progress: None,
    };
    let calls = Arc::new(Mutex::new(0));
    let counted = calls.clone();
    let by_function = RenderControl {
        cancel: None,
        progress: Some(Arc::new(move |_| {
            *counted.lock().unwrap() += 1;
            false
        })),
    };
    for control in [by_flag, by_function] {
        let e = write(&scene, &req, &Progress::new(&control, 160_000)).unwrap_err();
        assert_eq!(e.code, ErrorCode::Cancelled);
        assert_eq!(names(&dir), ["v_o.vlb"]);
        assert_eq!(fs::read(dir.join("v_o.vlb")).unwrap(), b"older");
    }
    assert_eq!(*calls.lock().unwrap(), 1, "stopped after the first slab");
    fs::remove_dir_all(&dir).unwrap();
}

/// A field function that panics in the last slab stops the voxelization with `Internal`, and
/// none of its files is written (the slabs before were).
#[test]
fn a_panic_in_a_late_slab_writes_no_file() {
    // World z above 1.05 only in the last 250 of 3000 planes: in the third slab of three.
    let scene = scene(0.85);
    let dir = scratch("panic");
    let mut req = request(&dir, [8, 8, 3000], 1, Fields::O);
    req.corner0 = [0.5, 0.5, 0.0];
    req.corner1 = [1.0, 1.0, 1.05];
    write(&scene, &req, &Progress::none()).unwrap();
    fs::remove_file(file_name(&req, 0)).unwrap();
    req.corner1 = [1.0, 1.0, 1.2];
    let e = write(&scene, &req, &Progress::none()).unwrap_err();
    assert_eq!(e.code, ErrorCode::Internal);
    assert!(names(&dir).is_empty(), "{:?}", names(&dir));
    fs::remove_dir_all(&dir).unwrap();
}
