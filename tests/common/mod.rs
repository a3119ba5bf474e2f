//! Helpers shared by the integration tests.

use std::path::PathBuf;

/// The path of example `name`, which `cargo test` builds alongside the tests:
/// target/<profile>/deps/<test>-<hash> → target/<profile>/examples/<name>.
pub fn example(name: &str) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    exe.parent()
        .unwrap()
        .parent()
        .unwrap()
        .join("examples")
        .join(name)
}
