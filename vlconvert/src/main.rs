//! `vlconvert`, the command line: converts volumes and images to vlib's `.vlb` datasets and
//! describes `.vlb` files. Everything it does is the library's (`src/lib.rs`, whose opening
//! documents the commands and exit codes), which also lets the fuzz target and the robustness
//! tests call each reader in-process (`vlconvert::fuzzing`).

fn main() -> std::process::ExitCode {
    vlconvert::run()
}
