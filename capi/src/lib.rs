//! # The C interface of vlib (`libvlib.a`, `libvlib.so`, header `include/vlib.h`)
//!
//! A thin layer: every exported function validates its C arguments (NULL pointers, enumerations
//! arriving as integers, string encodings), calls one method of the core's
//! [`vlib_core::Library`] and records any error for `vlError`. All meaning (scopes, validation,
//! rendering) lives in the core crate; this crate owns only the C forms and the panic boundary.
//!
//! Modules: [`types`] (the types and constants of the header), one module per API area holding
//! the commands (`session`, `scene`, `data`, `object`, `sampling`), `commands` (the list of the
//! commands, in header order), `ffi` (the panic boundary, the global state and scope dispatch,
//! pointer helpers), `extensions` (the functions after the commands: `vlProgress`, `vlCancel`,
//! `vlRenderBuffer`, `vlGradientFilter`, `vlVersion`), `errors` (the `vlError` queue), `sample`
//! (the thread-local sample scope), `callbacks` (C function pointers as core closures),
//! [`vlaux`] (vlaux, `vlaux.h`) and, with the `mpi` feature, `mpi` (`vlInit` joining the job's
//! ranks).
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

mod session;

mod scene;

mod data;

mod object;

mod sampling;

mod extensions;

/// cbindgen:ignore
mod callbacks;
/// cbindgen:ignore
#[macro_use]
mod commands;
/// cbindgen:ignore
mod errors;
/// cbindgen:ignore
mod ffi;
/// cbindgen:ignore
#[cfg(feature = "mpi")]
mod mpi;
/// cbindgen:ignore
mod sample;
/// cbindgen:ignore
pub mod vlaux;

pub use types::*;

/// Re-exports the commands of a `for_each_command!` list from their modules.
macro_rules! reexport {
    ($($module:ident::$name:ident),+ $(,)?) => {
        $(pub use $module::$name;)+
    };
}

// The commands, from the one list in `commands`.
for_each_command!(reexport);
pub use commands::{COMMANDS, COMMAND_COUNT, EXTENSIONS};

// The extensions (after the commands in `vlib.h`).
pub use extensions::{vlCancel, vlGradientFilter, vlProgress, vlRenderBuffer, vlVersion};

// vlaux (`vlaux.h`).
pub use vlaux::{
    vluCamera, vluNoise, vluPlace, vluSpline, vluTurbulence, VLU_BLEND, VLU_CYLINDER,
    VLU_DIFFERENCE, VLU_INTERSECTION, VLU_SPHERE, VLU_SWEEP, VLU_UNION, VL_PARAB1,
};

// Rust-only helpers for the unit tests (not part of the C interface).
pub use errors::{last_error_message, MAX_QUEUED};
pub use ffi::state_fingerprint;

#[cfg(test)]
mod tests;
