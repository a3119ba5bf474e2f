//! The crate's layers import downward only (`docs/dev/architecture.md`): the state machine (`api`)
//! → output (`output`) → the renderer (`render`) → empty-space skipping (`accel`) → the object
//! model (`model`) → datasets (`data`) → the base types (`types`, `error`, `num`, `pool`,
//! `control`, `team`). This reads every production source file under `src/` (unit tests
//! excluded: they may reach any layer) and fails on a `crate::` path into a higher layer, whether
//! in code or in a doc link, through a module or a name the crate root re-exports. Paths by
//! `super::super::…` are not followed; the code reaches other layers by `crate::` paths. Also: no
//! source file of the workspace (the core, the C layer, vlconvert, xtask) but a `tests.rs` is over
//! 800 lines.

use std::path::{Path, PathBuf};

/// The layers, lowest first; a layer may use its own and every lower one.
const LAYERS: [&[&str]; 7] = [
    &["types", "error", "num", "pool", "control", "team"],
    &["data"],
    &["model"],
    &["accel"],
    &["render"],
    &["output"],
    &["api"],
];

/// The names `src/lib.rs` re-exports at the crate root, with the layer each comes from, so that
/// `crate::Library` counts as a path into `api`.
const ROOT: [(&str, &str); 36] = [
    ("Library", "api"),
    ("Closed", "api"),
    ("Sampler", "api"),
    ("Command", "api"),
    ("Scope", "api"),
    ("scope", "api"),
    ("limits", "api"),
    ("write_atomic", "output"),
    ("write_image", "output"),
    ("Image", "render"),
    ("Backdrop", "render"),
    ("PixelFormat", "render"),
    ("Plan", "render"),
    ("Sample", "model"),
    ("SampleRole", "model"),
    ("FieldFn", "model"),
    ("NormalFn", "model"),
    ("Camera", "model"),
    ("Optimise", "model"),
    ("DEFAULT_FOV", "model"),
    ("cvg", "model"),
    ("vlaux", "model"),
    ("Dataset", "data"),
    ("Filter", "data"),
    ("Voxels", "data"),
    ("Geometry", "data"),
    ("vlb", "data"),
    ("Error", "error"),
    ("ErrorCode", "error"),
    ("Result", "error"),
    ("T_MIN", "types"),
    ("CancelFlag", "control"),
    ("ProgressFn", "control"),
    ("RenderControl", "control"),
    ("Team", "team"),
    ("RankStats", "team"),
];

/// The top-level modules that belong to no layer: the crate root and the unit tests' helpers.
const OUTSIDE: [&str; 2] = ["lib", "testing"];

/// The rank of `name` (a top-level module of the crate or a name re-exported at its root), if
/// it is in a layer.
fn rank(name: &str) -> Option<usize> {
    let module = ROOT
        .iter()
        .find(|(n, _)| *n == name)
        .map_or(name, |(_, m)| m);
    LAYERS.iter().position(|l| l.contains(&module))
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

/// The first path segments a line names after `crate::`: `crate::render::X` gives `render`,
/// `crate::{render::X, data}` gives `render` and `data`.
fn crate_paths(line: &str) -> Vec<&str> {
    let ident = |s: &str| -> usize {
        s.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .unwrap_or(s.len())
    };
    let mut out = Vec::new();
    for (i, _) in line.match_indices("crate::") {
        let rest = &line[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let group = &group[..group.find('}').unwrap_or(group.len())];
            for item in group.split(',') {
                let item = item.trim();
                out.push(&item[..ident(item)]);
            }
        } else {
            out.push(&rest[..ident(rest)]);
        }
    }
    out
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
        let top = top.trim_end_matches(".rs");
        if OUTSIDE.contains(&top) {
            continue;
        }
        let Some(own) = rank(top) else {
            panic!(
                "src/{}: module `{top}` is in no layer of LAYERS",
                rel.display()
            );
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
/// No source file of the workspace's packages is over 800 lines, but a module's `tests.rs`
/// (the files of a `tests/` directory beside the code count: they are split, not grown).
#[test]
fn source_files_but_tests_rs_are_at_most_800_lines() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut long = Vec::new();
    for dir in ["src", "capi/src", "vlconvert/src", "xtask/src"] {
        let mut files = Vec::new();
        sources(&root.join(dir), &mut files);
        for f in files {
            let rel = f.strip_prefix(root.join(dir)).unwrap();
            let lines = std::fs::read_to_string(&f).unwrap().lines().count();
            if rel.file_name().is_some_and(|n| n != "tests.rs") && lines > 800 {
                long.push(format!("{dir}/{}: {lines} lines", rel.display()));
            }
        }
    }
    assert!(long.is_empty(), "over 800 lines: {long:?}");
}

#[test]
fn an_upward_path_is_seen() {
    assert_eq!(
        crate_paths("use crate::render::Compiled; // crate::api"),
        ["render", "api"]
    );
    assert!(rank("render") > rank("data"));
    assert!(is_test(Path::new("render/tests.rs")) && !is_test(Path::new("render/mod.rs")));
}
