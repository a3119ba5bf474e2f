//! The exported surface: the commands (the one list in `capi/src/commands.rs`, compiled in
//! here) and the vlaux functions are defined by both `libvlib.so` and `libvlib.a`;
//! `include/vlib.h` declares exactly the commands, in the order of the list, and after them,
//! under their banner, the extensions; the list is the core's `vlib_core::Command::ALL`.

#[path = "../src/commands.rs"]
mod commands;
mod common;

use commands::{COMMANDS, COMMAND_COUNT, EXTENSIONS};
use std::collections::BTreeSet;
use std::process::Command;

/// The functions of vlaux.h.
const VLAUX: [&str; 13] = [
    "vluCamera",
    "vluPlace",
    "vluNoise",
    "vluTurbulence",
    "vluSpline",
    "VL_PARAB1",
    "VLU_SPHERE",
    "VLU_CYLINDER",
    "VLU_SWEEP",
    "VLU_UNION",
    "VLU_INTERSECTION",
    "VLU_DIFFERENCE",
    "VLU_BLEND",
];

#[test]
fn the_list_is_the_cores_list() {
    let unique: BTreeSet<&str> = COMMANDS.iter().copied().collect();
    assert_eq!(unique.len(), COMMAND_COUNT, "no command is listed twice");
    let core: Vec<&str> = vlib_core::Command::ALL.iter().map(|c| c.name()).collect();
    assert_eq!(core, COMMANDS, "vlib_core::Command::ALL, in order");
}

/// The text symbols (`T`) that `nm` lists for a library.
fn defined_text_symbols(args: &[&str], lib: &std::path::Path) -> BTreeSet<String> {
    let out = Command::new("nm")
        .args(args)
        .arg(lib)
        .output()
        .unwrap_or_else(|e| panic!("run nm on {}: {e}", lib.display()));
    assert!(
        out.status.success(),
        "nm {}: {}",
        lib.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|line| {
            let mut parts = line.split_whitespace();
            let (_addr, kind, name) = (parts.next()?, parts.next()?, parts.next()?);
            (kind == "T").then(|| name.to_string())
        })
        .collect()
}

#[test]
fn libraries_export_every_command() {
    let dir = common::ensure_libraries();
    for (lib, args) in [
        ("libvlib.so", &["-D", "--defined-only"][..]),
        ("libvlib.a", &["--defined-only"][..]),
    ] {
        let symbols = defined_text_symbols(args, &dir.join(lib));
        for name in COMMANDS.iter().chain(&EXTENSIONS).chain(VLAUX.iter()) {
            assert!(symbols.contains(*name), "{lib} does not export {name}");
        }
    }
}

/// `libvlib.so` as `cargo build` leaves it carries its SONAME (`capi/build.rs`) and exports
/// vlib's names only: `nm -D --defined-only` lists nothing of Rust's or of the dependencies'.
/// (capi/tests/install.rs checks the installed, stripped copy the same way.)
#[test]
fn the_shared_library_has_its_soname_and_exports_only_vlib_names() {
    let lib = common::ensure_libraries().join("libvlib.so");
    assert_eq!(
        common::soname(&lib).as_deref(),
        Some(common::SONAME),
        "readelf -d {}",
        lib.display()
    );
    let exports = common::exports(&lib);
    let foreign: Vec<&String> = exports
        .iter()
        .filter(|n| !common::is_vlib_name(n))
        .collect();
    assert!(foreign.is_empty(), "exported beyond vl*/VL*: {foreign:?}");
    // Every export is a command, an extension or a vlaux function: nothing else of ours leaks.
    let ours: BTreeSet<&str> = COMMANDS
        .iter()
        .chain(&EXTENSIONS)
        .chain(&VLAUX)
        .copied()
        .collect();
    let unlisted: Vec<&String> = exports
        .iter()
        .filter(|n| !ours.contains(n.as_str()))
        .collect();
    assert!(
        unlisted.is_empty(),
        "exports not in the lists: {unlisted:?}"
    );
}

/// The functions `include/vlib.h` declares, in order.
#[test]
fn the_header_declares_exactly_the_commands_in_the_order_of_the_list() {
    let header = std::fs::read_to_string(common::workspace_root().join("include/vlib.h"))
        .expect("read include/vlib.h");
    let mut declared = Vec::new();
    for line in header.lines() {
        // Declarations start at column 0 with the return type: `void vlInit(void);`. Every such
        // line is taken, whatever its name, so a function that does not belong in vlib.h (a
        // vlaux one) fails the comparison too.
        let Some(open) = line.find('(') else { continue };
        if [" ", "#", "/*", "typedef"]
            .iter()
            .any(|p| line.starts_with(p))
        {
            continue;
        }
        let head = &line[..open];
        declared.push(head.rsplit([' ', '*']).next().unwrap_or("").to_string());
    }
    let want: Vec<&str> = COMMANDS.iter().chain(&EXTENSIONS).copied().collect();
    assert_eq!(
        declared, want,
        "functions declared in include/vlib.h, in order: the commands, then the extensions"
    );
    // The extensions come after the banner that sets them apart.
    let banner = header
        .find("Extensions: functions beyond the")
        .expect("the extensions' banner");
    for name in EXTENSIONS {
        assert!(header.find(&format!("{name}(")).unwrap() > banner, "{name}");
    }
    for name in COMMANDS {
        assert!(header.find(&format!("{name}(")).unwrap() < banner, "{name}");
    }
}

#[test]
fn vlaux_header_declares_the_vlaux_functions() {
    let header = std::fs::read_to_string(common::workspace_root().join("include/vlaux.h"))
        .expect("read include/vlaux.h");
    for name in VLAUX {
        assert!(header.contains(&format!("{name}(")), "vlaux.h lacks {name}");
    }
    assert!(!header.contains("//"), "vlaux.h is C89: no // comments");
}
