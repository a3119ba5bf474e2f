//! Voxelization (`vlVolume`): the composed scene's fields sampled on a regular world grid and
//! written as `.vlb` datasets, one file per field.
//!
//! A node takes the fields of the root object whose boundary contains it; where several do
//! (the paper defines no way to combine overlapping hierarchies), the one with the largest
//! opacity there, the first declared on ties; outside every object all fields are 0. Values in
//! [0, 1] are quantised to the nearest of 0 … 255 or 0 … 65535, and the files carry a = 0 and
//! b = 255 or 65535, so loading one gives back the values to within half a quantum.
//!
//! The fields at a node come from the compiled scene (`render::Compiled::fields_at`); this
//! module owns only the grid, the quantisation and the datasets it makes.

use crate::data::{Dataset, Voxels};
use crate::error::{Error, Result};
use crate::model::scene::VolumeRequest;
use crate::render::Compiled;
use crate::types::{FIELD_COUNT, FIELD_NAMES};
use glam::DVec3;
use rayon::prelude::*;
use std::path::PathBuf;

/// The world position of node `i` of `n` between `a` and `b`.
fn node(a: f32, b: f32, i: usize, n: usize) -> f64 {
    if n == 1 {
        a as f64
    } else {
        a as f64 + (b as f64 - a as f64) * i as f64 / (n - 1) as f64
    }
}

/// The file a field of a request is written to: `<prefix>_<field>.vlb`.
pub fn file_name(req: &VolumeRequest, field: usize) -> PathBuf {
    let mut name = req.prefix.as_os_str().to_owned();
    name.push(format!("_{}.vlb", FIELD_NAMES[field]));
    PathBuf::from(name)
}

/// Samples the scene on the request's grid: all ten fields per node, x fastest.
pub fn sample_grid(scene: &Compiled, req: &VolumeRequest) -> Vec<[f32; FIELD_COUNT]> {
    let [nx, ny, nz] = req.nodes;
    let (a, b) = (req.corner0, req.corner1);
    (0..nz)
        .into_par_iter()
        .flat_map_iter(|k| {
            let z = node(a[2], b[2], k, nz);
            (0..ny).flat_map(move |j| {
                let y = node(a[1], b[1], j, ny);
                (0..nx).map(move |i| scene.fields_at(DVec3::new(node(a[0], b[0], i, nx), y, z)))
            })
        })
        .collect()
}

/// Voxelizes and writes every requested field; all files are attempted, the first error is
/// returned.
pub fn write(scene: &Compiled, req: &VolumeRequest) -> Result<()> {
    let grid = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| sample_grid(scene, req)))
        .map_err(|_| {
        Error::new(
            crate::ErrorCode::Internal,
            "voxelization stopped by a panic (in a field function?)",
        )
    })?;
    let max = if req.bytes == 1 { 255.0 } else { 65535.0 };
    let mut first = None;
    for field in req.fields.indices() {
        let q = grid.iter().map(|f| (f[field] as f64 * max).round());
        let raw = if req.bytes == 1 {
            Voxels::U8(q.map(|v| v as u8).collect())
        } else {
            Voxels::U16(q.map(|v| v as u16).collect())
        };
        let result = Dataset::new(req.nodes, raw, 0.0, max as f32)
            .and_then(|d| d.save(&file_name(req, field)));
        if let Err(e) = result {
            first.get_or_insert(e);
        }
    }
    first.map_or(Ok(()), Err)
}
