//! # The C interface of vlib (`libvlib.a`, `libvlib.so`, header `include/vlib.h`)
//!
//! A thin layer: every exported function validates its C arguments (NULL pointers, enumerations
//! arriving as integers, string encodings), calls one method of the core's
//! [`vlib_core::Library`] and records any error for `vlError`. All meaning (scopes, validation,
//! rendering) lives in the core crate; this crate owns only the C forms and the panic boundary.
//!
//! Modules: [`types`] (the types and constants of the header), `ffi` (the panic boundary, the
//! global state and scope dispatch, pointer helpers), `errors` (the `vlError` queue), `sample`
//! (the thread-local sample scope), `callbacks` (C function pointers as core closures), one
//! module per API area holding the commands, and [`vlaux`] (vlaux, `vlaux.h`).
//!
//! Every command is listed below, once, in the order of the API (`docs` and `api.md`), so the
//! exported surface can be audited at a glance.
//!
//! ## Safety
//! The exports that take pointers are `unsafe`: pointer arguments must be NULL or point to as
//! many valid elements as the command reads or writes; strings must be NUL-terminated. NULL is
//! always detected and reported as `VL_NULLPOINTER`. The other exports are safe functions. C
//! field, normal and spatial functions must be thread-safe: the renderer calls them concurrently
//! from worker threads.

#![allow(non_snake_case)]
#![deny(unsafe_op_in_unsafe_fn)]

// cbindgen reads the modules in the order they are declared, and that is the order of the header:
// the types and constants, then the commands by API area. Keep the blank lines: they stop rustfmt
// from sorting the declarations. Every other module is marked `cbindgen:ignore` (the one way
// items are kept out of `vlib.h`): it holds no item of the header.
pub mod types;

mod session; // commands 1–4

mod scene; // commands 5–21

mod data; // commands 22–25

mod object; // commands 26–38

mod sampling; // commands 39–44

/// cbindgen:ignore
mod callbacks;
/// cbindgen:ignore
mod errors;
/// cbindgen:ignore
mod ffi;
/// cbindgen:ignore
mod sample;
/// cbindgen:ignore
pub mod vlaux;

pub use types::*;

// The 44 commands, in the order of the API.
pub use data::vlLoad; // 22
pub use data::vlMapping; // 25
pub use data::vlSample; // 24
pub use data::vlUnload; // 23
pub use object::vlBoundary; // 32
pub use object::vlDataset; // 36
pub use object::vlFlip; // 30
pub use object::vlFunction; // 35
pub use object::vlMap; // 37
pub use object::vlMatrix; // 31
pub use object::vlNormal; // 38
pub use object::vlObject; // 26
pub use object::vlRotate; // 29
pub use object::vlScale; // 27
pub use object::vlSet; // 34
pub use object::vlSpatial; // 33
pub use object::vlTranslate; // 28
pub use sampling::vlChildCount; // 41
pub use sampling::vlChildField; // 43
pub use sampling::vlChildHit; // 42
pub use sampling::vlChildNormal;
pub use sampling::vlField; // 39
pub use sampling::vlPosition; // 40
pub use scene::vlAmbient; // 11
pub use scene::vlBackground; // 9
pub use scene::vlCamera; // 8
pub use scene::vlCubicFilter; // 20
pub use scene::vlDirectionalLight; // 13
pub use scene::vlImage; // 6
pub use scene::vlInterpolationType; // 19
pub use scene::vlNeighborhood; // 21
pub use scene::vlPointLight; // 12
pub use scene::vlRecursion; // 18
pub use scene::vlRenderType; // 14
pub use scene::vlScene; // 5
pub use scene::vlStepSize; // 15
pub use scene::vlSuperSample; // 10
pub use scene::vlSurface; // 16
pub use scene::vlToggle; // 17
pub use scene::vlVolume; // 7
pub use session::vlEnd; // 2
pub use session::vlError; // 3
pub use session::vlErrorString; // 4
pub use session::vlInit; // 1 // 44

// vlaux (`vlaux.h`).
pub use vlaux::{
    vluCamera, vluNoise, vluSpline, vluTurbulence, VLU_CYLINDER, VLU_SPHERE, VL_PARAB1,
};

// Rust-only helpers for tests and Rust hosts (not part of the C interface).
pub use errors::{last_error_message, MAX_QUEUED};
pub use ffi::state_fingerprint;

#[cfg(test)]
mod tests;
