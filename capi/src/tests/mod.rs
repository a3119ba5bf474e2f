//! Unit tests of the C interface, compiled into the library's test harness (the library is
//! built only as `staticlib` and `cdylib`, so integration tests cannot link it as Rust).

pub(crate) mod common;
mod error_order;
mod exports;
mod scopes;
