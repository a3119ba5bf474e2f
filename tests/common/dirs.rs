//! Scratch directories for the tests that write files, and what they hold.

#![allow(dead_code)] // Each test file uses what it needs.

use std::path::{Path, PathBuf};

/// A fresh empty directory `vlib-<file>-<tag>-<pid>` under the temporary directory, for one
/// test (`file` names the test file, `tag` the test).
pub fn scratch(file: &str, tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vlib-{file}-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The names in `dir`, sorted.
pub fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}
