//! What the benchmarks share: the MNI brain's dataset and scene (used by `mni.rs` and by the
//! thread-scaling group of `scenes.rs`), the hypertexture (`scenes.rs`, `procedural.rs`), and a
//! timer for in-process ratios.
//!
//! A directory module, so that cargo does not take it for a benchmark target of its own.

#![allow(dead_code)]

#[path = "../../examples/common/mni_scene.rs"]
pub mod mni_scene;

pub mod hypertexture;

use std::path::{Path, PathBuf};
use std::time::Instant;
use vlib::Library;
use vlib::Optimise;

/// The converted MNI template: `$VLIB_MNI_VLB`, or `target/bench-data/mni.vlb`, made on first
/// use with `vlconvert` from `../shared/data/…nii.gz`. An error when neither the file nor the
/// NIfTI source is there, or when the conversion fails.
pub fn try_mni_dataset() -> Result<PathBuf, String> {
    mni_scene::converted_dataset()
}

/// [`try_mni_dataset`], panicking when it fails.
pub fn mni_dataset() -> PathBuf {
    try_mni_dataset().unwrap_or_else(|e| panic!("MNI dataset: {e}"))
}

/// A library with the brain loaded and the scene open, ready to render: the VTK peer scene
/// with sample distance `step` voxels, shaded or not.
pub fn mni_scene(vlb: &Path, step: f32, shaded: bool, optimise: Optimise) -> Library {
    let mut vl = Library::new();
    vl.load(mni_scene::BRAIN, vlb).unwrap();
    let dims = vl.dataset_of(mni_scene::BRAIN).unwrap().dims();
    mni_scene::mappings(&mut vl).unwrap();
    vl.scene().unwrap();
    vl.set_optimise(optimise).unwrap();
    mni_scene::build(&mut vl, dims, step, shaded).unwrap();
    vl
}

/// The time `f` takes, in seconds.
pub fn seconds(f: impl FnOnce()) -> f64 {
    let start = Instant::now();
    f();
    start.elapsed().as_secs_f64()
}

/// The median of some timings (the mean of the middle two for an even count).
pub fn median(mut t: Vec<f64>) -> f64 {
    assert!(!t.is_empty(), "median of no timings");
    t.sort_by(f64::total_cmp);
    let n = t.len();
    if n % 2 == 1 {
        t[n / 2]
    } else {
        0.5 * (t[n / 2 - 1] + t[n / 2])
    }
}
