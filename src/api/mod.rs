//! The state machine of the API: [`library::Library`], one method per command, and
//! [`scope`], the four scopes and the one table of which command is legal where.
//!
//! It owns the order of commands, their validation and the state they build (the open scene and
//! its objects, the datasets and transfer functions, and the caches of closed objects). It does
//! not render or write: a closing `vlEnd` hands the finished scene to the output layer.

pub(crate) mod library;
mod object;
mod preview;
pub mod scope;
