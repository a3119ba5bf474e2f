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
//! module owns only the grid, the quantisation and the files it writes.
//!
//! The grid is sampled a slab at a time: [`SLAB_NODES`] consecutive nodes in file order (x
//! fastest, then y, then z), their ten fields in one buffer reused for every slab, quantised
//! into each requested field's file as soon as they are known. The files are written through
//! [`AtomicFile`]s, header first and then slab by slab, and committed only once every slab is
//! written, so a voxelization that fails (no memory for its buffers, a panic in a field
//! function, a cancelled render) leaves no file. Besides the files' own write buffers it holds
//! two buffers of one slab, whatever the grid's size.

use crate::control::Progress;
use crate::data::{vlb_header, MAX_VOXELS};
use crate::error::{Error, ErrorCode, Result};
use crate::model::scene::VolumeRequest;
use crate::num::try_vec;
use crate::output::files::AtomicFile;
use crate::render::Compiled;
use crate::types::{FIELD_COUNT, FIELD_NAMES};
use glam::DVec3;
use rayon::prelude::*;
use std::path::PathBuf;

/// The nodes of one slab: its fields take 40 bytes a node (2.5 MiB), enough work per slab for
/// the library's threads (a slab is shared among them) and little memory beside any output
/// worth voxelizing.
pub(crate) const SLAB_NODES: usize = 1 << 16;

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

/// The nodes of a slab taken as one item of work (by a thread, or a rank of a team).
const CHUNK_NODES: usize = 256;

/// Samples the scene at the nodes `first`, `first` + 1, … (in file order, x fastest) into
/// `out`, one node per element, in parallel ([`CHUNK_NODES`] at a time, split over the ranks
/// of the render's team if it has one); a node is skipped once the render is cancelled, and
/// the slab fails with `Cancelled` at the end (`Progress::map`).
fn sample_slab(
    scene: &Compiled,
    req: &VolumeRequest,
    first: usize,
    out: &mut [[f32; FIELD_COUNT]],
    progress: &Progress,
) -> Result<()> {
    let [nx, ny, nz] = req.nodes;
    let (a, b) = (req.corner0, req.corner1);
    let len = out.len();
    let chunks = progress.map(len.div_ceil(CHUNK_NODES), |c| {
        let nodes = c * CHUNK_NODES..((c + 1) * CHUNK_NODES).min(len);
        let mut fields = Vec::with_capacity(nodes.len());
        for t in nodes {
            if progress.cancelled() {
                break;
            }
            let o = first + t;
            let (i, j, k) = (o % nx, o / nx % ny, o / (nx * ny));
            let p = DVec3::new(
                node(a[0], b[0], i, nx),
                node(a[1], b[1], j, ny),
                node(a[2], b[2], k, nz),
            );
            fields.push(scene.fields_at(p));
        }
        fields
    })?;
    // (The step's error is every rank's; one of this rank alone is held for the next step,
    // `Progress::hold`.)
    progress.hold(crate::error::catch("voxelization", || {
        out.par_chunks_mut(CHUNK_NODES)
            .zip(chunks)
            .for_each(|(o, c)| o[..c.len()].copy_from_slice(&c));
        Ok(())
    }))?;
    Ok(())
}

/// Quantises one field of a slab's nodes into `out`: `bytes` (1 or 2) little-endian bytes per
/// node, the nearest of 0 … 255 or 0 … 65535 to the value times that maximum.
fn quantise(nodes: &[[f32; FIELD_COUNT]], field: usize, bytes: u32, out: &mut [u8]) {
    let max = if bytes == 1 { 255.0 } else { 65535.0 };
    let q = |f: &[f32; FIELD_COUNT]| (f[field] as f64 * max).round();
    if bytes == 1 {
        for (o, f) in out.iter_mut().zip(nodes) {
            *o = q(f) as u8;
        }
    } else {
        for (o, f) in out.chunks_exact_mut(2).zip(nodes) {
            o.copy_from_slice(&(q(f) as u16).to_le_bytes());
        }
    }
}

/// Voxelizes and writes every requested field, a slab at a time, reporting each slab's nodes
/// to `progress`. A field whose file cannot be written is an error of its own and the other
/// fields are still written (the first error is returned); a failure of the voxelization
/// itself (`NoMemory` for its buffers, `Internal` for a panic, `Cancelled`) writes no file.
/// With a team (`Progress::team`), the nodes are sampled by every rank, rank 0 alone opens
/// and writes the files, and every rank follows what rank 0's files allow and returns its
/// errors.
pub fn write(scene: &Compiled, req: &VolumeRequest, progress: &Progress) -> Result<()> {
    let team = progress.team();
    let result = write_files(scene, req, progress);
    crate::team::agree(team, result)
}

/// [`write()`] before the ranks agree on its result.
fn write_files(scene: &Compiled, req: &VolumeRequest, progress: &Progress) -> Result<()> {
    let team = progress.team();
    let writes = crate::team::writes(team);
    let total = req
        .nodes
        .iter()
        .try_fold(1u64, |acc, &n| acc.checked_mul(n as u64))
        .filter(|&n| n <= MAX_VOXELS)
        .ok_or_else(|| {
            Error::new(
                ErrorCode::NoMemory,
                format!("vlVolume: {:?} nodes exceed {MAX_VOXELS}", req.nodes),
            )
        })? as usize;
    let max = if req.bytes == 1 { 255.0 } else { 65535.0 };
    let header = vlb_header(req.nodes, req.bytes, 0.0, max as f32);
    let mut first_error: Option<Error> = None;
    // Each requested field's file: rank 0's (every process's without a team); the other ranks
    // keep the fields whose files rank 0 has open, without a file.
    let mut files: Vec<(usize, Option<AtomicFile>)> = Vec::new();
    for field in req.fields.indices() {
        if !writes {
            files.push((field, None));
            continue;
        }
        let opened = AtomicFile::create(&file_name(req, field)).and_then(|mut f| {
            f.write(&header)?;
            Ok(f)
        });
        match opened {
            Ok(f) => files.push((field, Some(f))),
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    follow_root(team, &mut files)?;
    let slab = SLAB_NODES.min(total);
    // (With a team, a rank that cannot hold the slab fails every rank.)
    let buffers = (|| {
        Ok((
            try_vec(slab, [0f32; FIELD_COUNT], "a voxelization's slab")?,
            try_vec(slab * req.bytes as usize, 0u8, "a voxelization's slab")?,
        ))
    })();
    let (mut nodes, mut bytes) = crate::team::agree(team, buffers)?;
    progress.check()?;
    let mut done = 0;
    while done < total && !files.is_empty() {
        let n = slab.min(total - done);
        let nodes = &mut nodes[..n];
        crate::error::catch("voxelization", || {
            sample_slab(scene, req, done, nodes, progress)
        })?;
        progress.check()?;
        let bytes = &mut bytes[..n * req.bytes as usize];
        if !progress.holds() {
            files.retain_mut(|(field, file)| {
                let Some(file) = file else { return true };
                quantise(nodes, *field, req.bytes, bytes);
                file.write(bytes)
                    .map_err(|e| first_error.get_or_insert(e))
                    .is_ok()
            });
        }
        follow_root(team, &mut files)?;
        done += n;
        progress.hold(crate::error::catch("the progress function", || {
            progress.advance(n as u64)
        }))?;
    }
    // (With a team, an error held after the last step fails every rank here, before any
    // file is committed.)
    progress.settle()?;
    for (_, file) in files {
        let Some(file) = file else { continue };
        // (A voxelization's nodes lie in the scene's world, not in millimetres: no geometry,
        // and a sidecar an earlier file left is removed, beside the file written: a link's
        // target, not the link.)
        let path = file.named().to_path_buf();
        if let Err(e) =
            crate::output::files::write_sidecar(&path, None).and_then(|()| file.commit())
        {
            first_error.get_or_insert(e);
        }
    }
    first_error.map_or(Ok(()), Err)
}

/// With a team, keeps on every rank the fields whose files rank 0 still has (collective).
fn follow_root(
    team: Option<&crate::team::Team>,
    files: &mut Vec<(usize, Option<AtomicFile>)>,
) -> Result<()> {
    if team.is_none() {
        return Ok(());
    }
    let mask = files.iter().fold(0u64, |m, (field, _)| m | 1 << field);
    let root = crate::team::from_root(team, mask)?;
    files.retain(|(field, _)| root & 1 << field != 0);
    Ok(())
}

#[cfg(test)]
mod tests;
