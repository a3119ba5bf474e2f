//! The C programs and headers with every C compiler at hand (docs/compat.md, "Legacy C code"):
//! gcc, clang-16, clang-19, and `clang` when it is yet another version. `.ci/run` installs
//! clang-16 and clang-19; without one of them these tests fail when `CI` is set and leave it out
//! with a message elsewhere. Each compiler:
//!
//! - compiles and links every `examples/c/*.c` with `-std=gnu89`: the paper's listings
//!   ([`PAPER`]: figure2.c, figure5.c, with their implicit `int`) with warnings allowed, and also
//!   with the documented C99 line `-std=c99 -Wno-error=implicit-int`; the other examples with
//!   `-Wall -Wextra -Werror`;
//! - compiles and links every `capi/tests/c/*.c` with `-std=gnu89 -Wall -Wextra -Werror`, and
//!   callbacks.c (callbacks typed as new code types them) also with
//!   `-std=c99 -pedantic -Wall -Wextra -Werror`, with and without `-DVL_NO_LEGACY_CASTS`;
//! - compiles the headers as C89 with `-pedantic-errors -Wall -Wextra -Werror`, and its C++
//!   compiler compiles them as C++11 with a lambda as field function (which a macro would split
//!   at its commas: the legacy macros are not defined in C++);
//! - compiles legacy callbacks (implicit `int`, K&R definitions, pointers to `int` functions)
//!   given to vlFunction, vlSpatial and vlNormal with `-Werror=incompatible-pointer-types`
//!   (GCC 14's default, so gcc 12 checks what GCC 14 would), and figure5.c likewise; with
//!   `-DVL_NO_LEGACY_CASTS` each of those calls is an error again; and each mistake the macros
//!   must not hide ([`MISTAKES`]) is an error with the macros on.
//!
//! The clang-19 builds of the examples and of callbacks.c then run beside gcc's builds and must
//! write the same bytes (standard output and every file), and the clang-19 builds of the other
//! test programs must pass their own checks (all but nomemory.c, which takes some 20 s and
//! exercises allocation failures inside the library, not the caller's code).

mod common;

use common::TempDir;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;
use std::sync::OnceLock;

/// The paper's listings, compiled as printed (implicit `int`): warnings allowed.
const PAPER: [&str; 2] = ["examples/c/figure2.c", "examples/c/figure5.c"];

/// Warnings that are errors in every build of code written for vlib.
const STRICT: [&str; 3] = ["-Wall", "-Wextra", "-Werror"];

/// The compiler whose builds run beside gcc's.
const RUN_WITH: &str = "clang-19";

/// The first line of `cmd --version`, if `cmd` runs.
fn version(cmd: &str) -> Option<String> {
    let out = Command::new(cmd).arg("--version").output().ok()?;
    out.status.success().then(|| {
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .next()
            .unwrap_or("")
            .to_string()
    })
}

/// The C compilers to test with: gcc, then clang-16, clang-19 and `clang` when installed and
/// not the same version as one before it.
fn compilers() -> &'static [&'static str] {
    static LIST: OnceLock<Vec<&'static str>> = OnceLock::new();
    LIST.get_or_init(|| {
        let ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false");
        let gcc = version("gcc").expect("gcc is not installed");
        let mut seen = vec![gcc];
        let mut list = vec!["gcc"];
        for (name, required) in [("clang-16", true), ("clang-19", true), ("clang", false)] {
            match version(name) {
                None => {
                    assert!(
                        !(required && ci),
                        "{name} is not installed (.ci/run installs it: apt-get install {name})"
                    );
                    eprintln!("{name} is not installed: left out (apt-get install {name})");
                }
                Some(v) if seen.contains(&v) => eprintln!("{name} is a compiler above: {v}"),
                Some(v) => {
                    seen.push(v);
                    list.push(name);
                }
            }
        }
        list
    })
}

/// The C++ compiler that comes with C compiler `cc`.
fn cxx_of(cc: &str) -> String {
    match cc {
        "gcc" => "g++".to_string(),
        _ => cc.replacen("clang", "clang++", 1),
    }
}

/// The file name of `source` without `.c`.
fn stem(source: &str) -> String {
    Path::new(source)
        .file_stem()
        .expect("file name")
        .to_string_lossy()
        .into_owned()
}

/// Compiles and links each of `sources` with every compiler (one thread each) for each flag set
/// of `flag_sets(source)`, into `dir`; returns the failures, each with the compiler's messages.
fn compile_everywhere(
    sources: &[String],
    dir: &Path,
    flag_sets: impl Fn(&str) -> Vec<Vec<&'static str>> + Sync,
) -> Vec<String> {
    let failures = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for &cc in compilers() {
            let (failures, flag_sets) = (&failures, &flag_sets);
            s.spawn(move || {
                for source in sources {
                    for (i, flags) in flag_sets(source).iter().enumerate() {
                        let exe = dir.join(format!("{}-{cc}-{i}", stem(source)));
                        if let Err(m) = common::compile_with(cc, source, &exe, flags) {
                            let line = flags.join(" ");
                            failures
                                .lock()
                                .unwrap()
                                .push(format!("{cc} {line} {source}:\n{m}"));
                        }
                    }
                }
            });
        }
    });
    failures.into_inner().unwrap()
}

#[test]
fn every_example_compiles_with_every_compiler() {
    let dir = TempDir::new("compilers-examples");
    let examples = common::c_files("examples/c");
    for paper in PAPER {
        assert!(examples.iter().any(|e| e == paper), "{paper} is missing");
    }
    let failures = compile_everywhere(&examples, dir.path(), |source| {
        if PAPER.contains(&source) {
            vec![
                vec!["-std=gnu89"],
                vec!["-std=c99", "-Wno-error=implicit-int"],
            ]
        } else {
            vec![[&["-std=gnu89"][..], &STRICT].concat()]
        }
    });
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_test_program_compiles_clean_with_every_compiler() {
    let dir = TempDir::new("compilers-tests");
    let programs = common::c_files("capi/tests/c");
    assert!(programs.iter().any(|p| p.ends_with("/callbacks.c")));
    let failures = compile_everywhere(&programs, dir.path(), |source| {
        let mut sets = vec![[&["-std=gnu89"][..], &STRICT].concat()];
        if source.ends_with("/callbacks.c") {
            let c99 = [&["-std=c99", "-pedantic"][..], &STRICT].concat();
            sets.push(c99.clone());
            sets.push([&c99[..], &["-DVL_NO_LEGACY_CASTS"]].concat());
        }
        sets
    });
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Runs `cc <flags> -fsyntax-only -I include file`; returns whether it succeeded and its
/// messages.
fn syntax_check(cc: &str, flags: &[&str], file: &Path) -> (bool, String) {
    let out = Command::new(cc)
        .args(flags)
        .arg("-fsyntax-only")
        .arg(format!(
            "-I{}",
            common::workspace_root().join("include").display()
        ))
        .arg(file)
        .current_dir(common::workspace_root())
        .output()
        .unwrap_or_else(|e| panic!("run {cc}: {e}"));
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn headers_are_strict_c89_and_cxx_with_every_compiler() {
    let dir = TempDir::new("compilers-headers");
    let c = dir.path().join("headers.c");
    std::fs::write(
        &c,
        "#include <vlib.h>\n#include <vlaux.h>\n#include <vlib.h>\n#include <vlaux.h>\n\
         static void field(vlfloat *p, void *misc) { (void)misc; vlSet(VL_F, p[0]); }\n\
         int main(void) { vlvector v; VLCAMERA c; static vlfloat w[3] = {WHITE}; (void)v;\n\
         (void)c; (void)w; vlFunction(VL_F, field, 0); vlFunction(VL_F, VLU_SPHERE, 0);\n\
         return (int)(VLSPECULAR(20) + VLREFRACTION(1.5)) + VL_COLORS; }\n",
    )
    .unwrap();
    let cpp = dir.path().join("headers.cpp");
    std::fs::write(
        &cpp,
        "#include <vlib.h>\n#include <vlaux.h>\n\
         int main() {\n\
         vlFunction(VL_F, [](vlfloat *p, void *misc) { vlfloat a = p[0], b = p[1]; (void)misc;\n\
                                                       vlSet(VL_F, a + b); }, 0);\n\
         vlFunction(VL_F, VLU_SPHERE, 0);\n\
         return 0; }\n",
    )
    .unwrap();
    let mut failures = Vec::new();
    for &cc in compilers() {
        let flags = [&["-std=c89", "-pedantic-errors"][..], &STRICT].concat();
        let (ok, messages) = syntax_check(cc, &flags, &c);
        if !ok {
            failures.push(format!("{cc} {flags:?}:\n{messages}"));
        }
        let cxx = cxx_of(cc);
        if version(&cxx).is_none() {
            eprintln!("{cxx} is not installed: the headers are not compiled as C++ with it");
            continue;
        }
        let flags = [&["-std=c++11", "-pedantic"][..], &STRICT].concat();
        let (ok, messages) = syntax_check(&cxx, &flags, &cpp);
        if !ok {
            failures.push(format!("{cxx} {flags:?}:\n{messages}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Legacy callbacks as the paper's code writes them, one call per line marked `CALL`.
const LEGACY: &str = "#include <vlib.h>
int knr();
field(vlvector p, void *misc) { vlSet(VL_F, p[0]); }
warp(p, misc) vlfloat *p; void *misc; { p[0] = 1.0f - p[0]; }
bump(vlfloat *n, vlfloat *p, void *misc) { n[0] = p[0]; }
main()
{
    int (*pointer)(vlfloat *, void *) = field;
    int (*unprototyped)() = knr;
    vlSpatial(warp, 0); /* CALL */
    vlFunction(VL_F, field, 0); /* CALL */
    vlFunction(VL_F, &field, 0); /* CALL */
    vlFunction(VL_F, pointer, 0); /* CALL */
    vlFunction(VL_F, unprototyped, 0); /* CALL */
    vlFunction(VL_F, knr, 0); /* CALL */
    vlNormal(bump, 0); /* CALL */
    return 0;
}
int knr(p, misc) vlfloat *p; void *misc; { return p != misc; }
";

/// What a program sets up for [`MISTAKES`].
const MISTAKE_PRELUDE: &str = "#include <vlib.h>
static void normal(vlfloat *n, vlfloat *p, void *misc) { (void)n; (void)p; (void)misc; }
static int wide(double *p, void *misc) { (void)p; (void)misc; return 0; }
static int field(vlfloat *p, void *misc) { (void)p; (void)misc; return 0; }
int main(void)
{
    int number = 1;
    static vlfloat data[3];
    (void)normal; (void)wide; (void)field; (void)number; (void)data;
";

/// Calls the legacy macros must leave to the compiler's checks: a normal function given to
/// vlFunction, parameters of another type, a field function given to vlNormal, an integer, a
/// data pointer.
const MISTAKES: [&str; 5] = [
    "vlFunction(VL_F, normal, 0);",
    "vlFunction(VL_F, wide, 0);",
    "vlNormal(field, 0);",
    "vlSpatial(number, 0);",
    "vlFunction(VL_F, data, 0);",
];

/// The flags under which a wrong pointer type is an error for every compiler (GCC 14's and
/// clang 16's defaults for function pointers; gcc 12 only warns by default).
const POINTER_ERRORS: [&str; 3] = [
    "-std=gnu89",
    "-Werror=incompatible-pointer-types",
    "-Werror=int-conversion",
];

/// The 1-based numbers of the lines of `text` that contain every one of `needles`.
fn lines_with(text: &str, needles: &[&str]) -> Vec<usize> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| needles.iter().all(|n| l.contains(n)))
        .map(|(i, _)| i + 1)
        .collect()
}

/// Checks that `cc` accepts `file` under `flags`, rejects it with `-DVL_NO_LEGACY_CASTS` added,
/// and then names each line of `lines` in its messages.
fn opt_out_restores_the_diagnostics(cc: &str, file: &Path, lines: &[usize]) -> Vec<String> {
    let mut failures = Vec::new();
    let name = file.file_name().unwrap().to_string_lossy();
    let (ok, messages) = syntax_check(cc, &POINTER_ERRORS, file);
    if !ok {
        failures.push(format!(
            "{cc} rejects {name} with the legacy macros:\n{messages}"
        ));
    }
    let flags = [&POINTER_ERRORS[..], &["-DVL_NO_LEGACY_CASTS"]].concat();
    let (ok, messages) = syntax_check(cc, &flags, file);
    let missing: Vec<usize> = lines
        .iter()
        .copied()
        .filter(|l| !messages.contains(&format!("{name}:{l}:")))
        .collect();
    if ok || !messages.contains("incompatible") || !missing.is_empty() {
        failures.push(format!(
            "{cc} -DVL_NO_LEGACY_CASTS should reject the calls on lines {lines:?} of {name} \
             (lines not named: {missing:?}):\n{messages}"
        ));
    }
    failures
}

#[test]
fn legacy_macros_pass_legacy_callbacks_and_nothing_else() {
    let dir = TempDir::new("compilers-legacy");
    let legacy = dir.path().join("legacy.c");
    std::fs::write(&legacy, LEGACY).unwrap();
    let calls = lines_with(LEGACY, &["CALL"]);
    assert_eq!(calls.len(), 7);
    let figure5 = common::workspace_root().join("examples/c/figure5.c");
    let text = std::fs::read_to_string(&figure5).unwrap();
    let figure5_calls: Vec<usize> = [
        lines_with(&text, &["vlFunction(", "sphere"]),
        lines_with(&text, &["vlFunction(", "marble"]),
    ]
    .concat();
    assert_eq!(figure5_calls.len(), 2, "figure5.c's two vlFunction calls");
    // One program per mistake, and one with none (which must compile: the mistake is the
    // reason each other one fails).
    let programs: Vec<(String, std::path::PathBuf)> = std::iter::once("")
        .chain(MISTAKES)
        .enumerate()
        .map(|(i, call)| {
            let path = dir.path().join(format!("mistake{i}.c"));
            std::fs::write(
                &path,
                format!("{MISTAKE_PRELUDE}    {call}\n    return 0;\n}}\n"),
            )
            .unwrap();
            (call.to_string(), path)
        })
        .collect();
    let mut failures = Vec::new();
    for &cc in compilers() {
        failures.extend(opt_out_restores_the_diagnostics(cc, &legacy, &calls));
        failures.extend(opt_out_restores_the_diagnostics(
            cc,
            &figure5,
            &figure5_calls,
        ));
        for (call, path) in &programs {
            let (ok, messages) = syntax_check(cc, &POINTER_ERRORS, path);
            if call.is_empty() && !ok {
                failures.push(format!("{cc}: the program without a mistake:\n{messages}"));
            }
            if !call.is_empty() && (ok || !messages.contains("error")) {
                failures.push(format!("{cc} lets `{call}` through:\n{messages}"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The width at which the examples that take one render here (as small as the comparison
/// allows: every pixel of every image is compared).
const WIDTH: usize = 64;

/// Runs `exe` in a fresh directory holding the datasets `source` loads, at width [`WIDTH`] if
/// it takes one; returns its standard output and the files it wrote (name and bytes), and
/// fails the test if it exits with an error.
fn run_and_collect(source: &str, exe: &Path) -> (String, BTreeMap<String, Vec<u8>>) {
    let cwd = TempDir::new("compilers-run");
    common::make_inputs(source, cwd.path());
    let text = std::fs::read_to_string(common::workspace_root().join(source)).unwrap();
    let args = if text.contains("argv[1]") {
        vec![WIDTH.to_string()]
    } else {
        Vec::new()
    };
    let inputs: Vec<String> = std::fs::read_dir(cwd.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let stdout = common::run(exe, cwd.path(), &args);
    let files = std::fs::read_dir(cwd.path())
        .unwrap()
        .map(|e| e.unwrap())
        .map(|e| (e.file_name().to_string_lossy().into_owned(), e.path()))
        .filter(|(name, _)| !inputs.contains(name))
        .map(|(name, path)| (name, std::fs::read(path).unwrap()))
        .collect();
    (stdout, files)
}

/// Whether the compiler whose builds run beside gcc's is installed (see [`compilers`]).
fn run_with_available() -> bool {
    let there = compilers().contains(&RUN_WITH);
    if !there {
        eprintln!("{RUN_WITH} is not installed: its builds are not run");
    }
    there
}

#[test]
fn clang_builds_of_the_examples_write_the_bytes_of_gcc_builds() {
    if !run_with_available() {
        return;
    }
    let bin = TempDir::new("compilers-bin");
    let sources: Vec<String> = common::c_files("examples/c")
        .into_iter()
        .chain(["capi/tests/c/callbacks.c".to_string()])
        .collect();
    let mut failures = Vec::new();
    for source in &sources {
        let mut outputs = Vec::new();
        for cc in ["gcc", RUN_WITH] {
            let exe = bin.path().join(format!("{}-{cc}", stem(source)));
            if let Err(m) = common::compile_with(cc, source, &exe, &["-std=gnu89"]) {
                panic!("{cc} -std=gnu89 {source}:\n{m}");
            }
            outputs.push(run_and_collect(source, &exe));
        }
        let ((out_gcc, files_gcc), (out_clang, files_clang)) = (&outputs[0], &outputs[1]);
        assert!(!files_gcc.is_empty() || source.ends_with("callbacks.c"));
        if out_gcc != out_clang {
            failures.push(format!(
                "{source}: standard output differs\ngcc:\n{out_gcc}\n{RUN_WITH}:\n{out_clang}"
            ));
        }
        let names = |f: &BTreeMap<String, Vec<u8>>| f.keys().cloned().collect::<Vec<_>>();
        if names(files_gcc) != names(files_clang) {
            failures.push(format!(
                "{source}: gcc's build wrote {:?}, {RUN_WITH}'s {:?}",
                names(files_gcc),
                names(files_clang)
            ));
        }
        for (name, bytes) in files_gcc {
            if files_clang.get(name).is_some_and(|b| b != bytes) {
                failures.push(format!("{source}: {name} differs between the builds"));
            }
        }
        println!(
            "{source}: {} file(s) and standard output compared (gcc, {RUN_WITH})",
            files_gcc.len()
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn clang_builds_of_the_test_programs_pass() {
    if !run_with_available() {
        return;
    }
    let bin = TempDir::new("compilers-bin");
    let programs: Vec<String> = common::c_files("capi/tests/c")
        .into_iter()
        .filter(|p| !p.ends_with("/nomemory.c") && !p.ends_with("/callbacks.c"))
        .collect();
    assert!(programs.len() >= 9, "{programs:?}");
    for source in &programs {
        let exe = bin.path().join(stem(source));
        if let Err(m) = common::compile_with(RUN_WITH, source, &exe, &["-std=gnu89"]) {
            panic!("{RUN_WITH} -std=gnu89 {source}:\n{m}");
        }
        let cwd = TempDir::new("compilers-run");
        let args = common::prepare(source, cwd.path());
        let stdout = common::run(&exe, cwd.path(), &args);
        assert!(
            stdout.contains("0 failure(s)"),
            "{source} built by {RUN_WITH}:\n{stdout}"
        );
    }
}
