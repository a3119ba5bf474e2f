//! The object model and plain scene data: what a scene is, not how it is rendered.
//!
//! [`scene`] holds the description the state machine builds (camera, lights, render state,
//! outputs, objects with their programs and transforms); [`program`] the ordered field program
//! and the per-sample context a field function sees; [`mapping`] the transfer functions Φ_t and
//! Φ_r; [`cvg`] the constructive volume geometry operators; [`vlaux`] the auxiliary library
//! (noise, splines, distance fields). Plain data: no render caches, nothing compiled.

pub mod cvg;
pub(crate) mod mapping;
pub(crate) mod program;
pub(crate) mod scene;
pub mod vlaux;
