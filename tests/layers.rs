//! The crate's layers import downward only (`docs/dev/architecture.md`): the state machine
//! (`api`) → output (`output`) → the renderer (`render`) → empty-space skipping (`accel`) → the
//! object model (`model`) → datasets (`data`) → the base types (`types`, `error`, `num`). This
//! reads every production source file under `src/` (unit tests excluded: they may reach any
//! layer) and fails on a path into a higher layer, whether in code or in a doc link.

use std::path::{Path, PathBuf};

/// The layers, lowest first; a layer may use its own and every lower one.
const LAYERS: [&[&str]; 7] = [
    &["types", "error", "num"],
    &["data"],
    &["model"],
    &["accel"],
    &["render"],
    &["output"],
    &["api"],
];

/// The rank of module `name` (a top-level module of the crate), if it is in a layer.
fn rank(name: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&name))
}

/// Every `.rs` file below `dir`.
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("read src") {
        let p = entry.expect("entry").path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// Whether `rel` (relative to `src/`) is test code: a `tests.rs` or a file under a `tests/`
/// directory, or the test helpers.
fn is_test(rel: &Path) -> bool {
    rel.components().any(|c| c.as_os_str() == "tests")
        || rel
            .file_name()
            .is_some_and(|n| n == "tests.rs" || n == "testing.rs")
}

/// The top-level modules a line names as `crate::<module>`.
fn crate_paths(line: &str) -> Vec<&str> {
    line.match_indices("crate::")
        .map(|(i, _)| {
            let rest = &line[i + "crate::".len()..];
            let end = rest
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(rest.len());
            &rest[..end]
        })
        .collect()
}

#[test]
fn layers_import_downward_only() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut checked = 0;
    let mut wrong = Vec::new();
    for file in &files {
        let rel = file.strip_prefix(&src).expect("below src");
        let top = rel.components().next().expect("a component");
        let top = top.as_os_str().to_string_lossy();
        let Some(own) = rank(top.trim_end_matches(".rs")) else {
            continue; // lib.rs (the public re-exports), bin/
        };
        if is_test(rel) {
            continue;
        }
        checked += 1;
        let text = std::fs::read_to_string(file).expect("read source");
        for (n, line) in text.lines().enumerate() {
            for m in crate_paths(line) {
                if rank(m).is_some_and(|r| r > own) {
                    wrong.push(format!("src/{}:{}: crate::{m}", rel.display(), n + 1));
                }
            }
        }
    }
    assert!(checked > 40, "only {checked} production files found");
    assert!(
        wrong.is_empty(),
        "paths into a higher layer:\n{}",
        wrong.join("\n")
    );
}

/// The check sees a path into a higher layer (so the test above can fail).
#[test]
fn an_upward_path_is_seen() {
    assert_eq!(
        crate_paths("use crate::render::Compiled; // crate::api"),
        ["render", "api"]
    );
    assert!(rank("render") > rank("data"));
    assert!(is_test(Path::new("render/tests.rs")) && !is_test(Path::new("render/mod.rs")));
}
