//! Exact empty-space skipping.
//!
//! For an object whose opacity is computed from datasets (through any chain of `vlDataset`,
//! `vlMap` and `vlSet` instructions), the part of its program that determines opacity is
//! evaluated over *intervals*, once per block of the object: each dataset contributes the range
//! of node values its filter can read anywhere in the block
//! ([`crate::data::Dataset::bricks`]), each mapping the exact range of Φ over its input
//! interval ([`crate::model::mapping::Mapping::range`]), each constant itself, and each field
//! function the whole [0, 1] (nothing is known of it). A block whose opacity interval is
//! [0, 0] is *empty*: every sample in it has o = 0 and contributes nothing. Rays walk the block
//! grid (a 3D DDA) and skip the segments whose sample points lie in empty blocks; the remaining
//! samples are exactly the ones that would have been taken, so skipping never changes a pixel.
//!
//! The module owns these acceleration structures, not their use: the renderer asks a [`Walk`]
//! whether a sample lies in an empty block and where to resume, an [`EntryMap`] where each
//! primary ray may start, and a [`BoxTree`] which of a scene's many objects a ray or a point
//! may meet at all; nothing here depends on the renderer. Nothing here caches either:
//! the renderer's `Caches`, which the state machine keeps per open scene, holds each object's
//! grid.
//!
//! - `grid`: [`SkipGrid`], the blocks of one object, their opacity intervals, the chessboard
//!   distance map the walk leaps by and the shell the entry map projects.
//! - `passing`: the boxes of a dataset's cells that can pass a zero test, by groups of 4³
//!   cells (what the batched march's entry map projects instead of the shell).
//! - `walk`: [`Walk`], the block walk (a 3D DDA with leaps) along one ray.
//! - `entry`: [`Pinhole`] and [`EntryMap`], the per-image lower bound on where each primary ray
//!   meets a block that may hold opacity.
//! - `project`: the entry map's projection of boxes, eight boxes to the f64 lanes.
//! - `rect`: the entry map's rasterisation (lowering a rectangle of the map).
//! - `boxes`: [`BoxTree`], a bounding volume hierarchy over a scene's objects: which of them
//!   a ray or a point may meet.
//! - `tests`: every unit test of the module and the brute-force references they check against.

mod boxes;
mod entry;
mod grid;
mod passing;
mod project;
mod rect;
#[cfg(test)]
mod tests;
mod walk;

pub(crate) use boxes::BoxTree;
pub(crate) use entry::{EntryMap, EntryMarks, Pinhole, MAX_MAP_SIDE};
pub(crate) use grid::SkipGrid;
pub(crate) use walk::Walk;
