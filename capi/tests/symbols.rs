//! The exported surface: the 44 commands of `api.md` (and the vlaux functions) are defined by
//! both `libvlib.so` and `libvlib.a`, and `include/vlib.h` declares exactly the 44 commands.

mod common;

use std::collections::BTreeSet;
use std::process::Command;

/// The 44 commands, in the order of api.md.
const COMMANDS: [&str; 44] = [
    "vlInit",
    "vlEnd",
    "vlError",
    "vlErrorString",
    "vlScene",
    "vlImage",
    "vlVolume",
    "vlCamera",
    "vlBackground",
    "vlSuperSample",
    "vlAmbient",
    "vlPointLight",
    "vlDirectionalLight",
    "vlRenderType",
    "vlStepSize",
    "vlSurface",
    "vlToggle",
    "vlRecursion",
    "vlInterpolationType",
    "vlCubicFilter",
    "vlNeighborhood",
    "vlLoad",
    "vlUnload",
    "vlSample",
    "vlMapping",
    "vlObject",
    "vlScale",
    "vlTranslate",
    "vlRotate",
    "vlFlip",
    "vlMatrix",
    "vlBoundary",
    "vlSpatial",
    "vlSet",
    "vlFunction",
    "vlDataset",
    "vlMap",
    "vlNormal",
    "vlField",
    "vlPosition",
    "vlChildCount",
    "vlChildHit",
    "vlChildField",
    "vlChildNormal",
];

/// The functions of vlaux.h.
const VLAUX: [&str; 12] = [
    "vluCamera",
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
    assert_eq!(unique.len(), 44, "44 distinct commands");
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
        for name in COMMANDS.iter().chain(VLAUX.iter()) {
            assert!(symbols.contains(*name), "{lib} does not export {name}");
        }
    }
}

#[test]
fn the_header_declares_exactly_the_commands() {
    let header = std::fs::read_to_string(common::workspace_root().join("include/vlib.h"))
        .expect("read include/vlib.h");
    let mut declared = Vec::new();
    for line in header.lines() {
        // Declarations start at column 0 with the return type: `void vlInit(void);`.
        let Some(open) = line.find('(') else { continue };
        if line.starts_with(' ') || line.starts_with('#') || line.starts_with("typedef") {
            continue;
        }
        let head = &line[..open];
        let name = head.rsplit([' ', '*']).next().unwrap_or("");
        if name.starts_with("vl") {
            declared.push(name.to_string());
        }
    }
    assert_eq!(
        declared, COMMANDS,
        "functions declared in include/vlib.h, in order"
    );
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
