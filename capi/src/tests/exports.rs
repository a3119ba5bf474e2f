//! The exported functions, read from the sources: every `#[no_mangle]` function's body is one
//! call of the panic boundary (`ffi::ffi_boundary`), and the command modules export exactly the
//! commands of the list (`crate::COMMANDS`) and the extensions module the extensions
//! (`crate::EXTENSIONS`). The C side of the same surface (symbols, headers) is
//! checked by `capi/tests/symbols.rs`.

use std::path::{Path, PathBuf};

/// One exported function: the file, its name, and the first line of its body.
struct Export {
    file: String,
    name: String,
    first_line: String,
}

/// The crate's production sources (`src/**/*.rs` less the unit tests).
fn sources() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).expect("read a source directory") {
            let path = entry.expect("a directory entry").path();
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if path.is_dir() {
                if name != "tests" {
                    walk(&path, out);
                }
            } else if name.ends_with(".rs") && name != "tests.rs" {
                out.push(path);
            }
        }
    }
    let mut out = Vec::new();
    walk(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"), &mut out);
    out.sort();
    out
}

/// The `#[no_mangle]` functions of one source file.
fn exports_of(file: &Path) -> Vec<Export> {
    let text = std::fs::read_to_string(file).expect("read a source file");
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        if !(line.starts_with("#[") && line.contains("no_mangle")) {
            continue;
        }
        let sig = (i + 1..lines.len())
            .find(|&j| lines[j].contains(" fn "))
            .unwrap_or_else(|| panic!("{}:{}: no function after no_mangle", file.display(), i));
        let name = lines[sig].split(" fn ").nth(1).unwrap_or("");
        let name = name.split('(').next().unwrap_or("").to_string();
        // The signature ends at the first line at column 0 that opens the body.
        let open = (sig..lines.len())
            .find(|&j| !lines[j].starts_with(' ') && lines[j].ends_with('{'))
            .unwrap_or_else(|| panic!("{}: no body for {name}", file.display()));
        let first_line = lines[open + 1..]
            .iter()
            .map(|l| l.trim())
            .find(|l| !l.is_empty() && !l.starts_with("//"))
            .unwrap_or("")
            .to_string();
        out.push(Export {
            file: file.display().to_string(),
            name,
            first_line,
        });
    }
    out
}

fn all_exports() -> Vec<Export> {
    sources().iter().flat_map(|f| exports_of(f)).collect()
}

#[test]
fn every_export_runs_inside_the_panic_boundary() {
    let exports = all_exports();
    assert!(
        exports.len() > crate::COMMAND_COUNT,
        "the commands and vlaux"
    );
    let outside: Vec<String> = exports
        .iter()
        .filter(|e| !e.first_line.starts_with("ffi_boundary("))
        .map(|e| format!("{} in {}: `{}`", e.name, e.file, e.first_line))
        .collect();
    assert!(
        outside.is_empty(),
        "exports whose body is not one ffi_boundary call:\n{}",
        outside.join("\n")
    );
}

#[test]
fn the_command_modules_export_exactly_the_listed_commands() {
    let of = |keep: &dyn Fn(&str) -> bool| {
        let mut names: Vec<String> = all_exports()
            .into_iter()
            .filter(|e| keep(&e.file))
            .map(|e| e.name)
            .collect();
        names.sort();
        names
    };
    let commands = of(&|f| !f.ends_with("vlaux.rs") && !f.ends_with("extensions.rs"));
    let mut listed: Vec<String> = crate::COMMANDS.iter().map(|s| s.to_string()).collect();
    listed.sort();
    assert_eq!(commands, listed);
    let extensions = of(&|f| f.ends_with("extensions.rs"));
    let mut listed: Vec<String> = crate::EXTENSIONS.iter().map(|s| s.to_string()).collect();
    listed.sort();
    assert_eq!(extensions, listed);
}
