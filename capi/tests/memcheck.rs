//! Memory checking of the C interface: every C program (`examples/c/*.c`, `capi/tests/c/*.c` but
//! `nomemory.c` and `pool.c`, which set an address-space limit valgrind cannot run under)
//! runs under valgrind's memcheck with
//! `valgrind --error-exitcode=99 --leak-check=full --errors-for-leak-kinds=definite,indirect`,
//! and must finish with exit status 0, no memcheck errors, no definitely or indirectly lost
//! bytes, and little still reachable at exit: every program ends with its final `vlEnd`, which
//! frees every dataset, mapping, scene and error message vlib holds, so what remains reachable is
//! the runtime's own (the library's rayon pool, `src/pool.rs`, and its registry, whose worker
//! threads are never joined; the error queue's empty buffer), about 20 KiB whatever the program
//! loaded or rendered. [`STILL_REACHABLE_MAX`] bounds it, so a library that kept its datasets
//! after the final `vlEnd` fails here even though the memory is not "lost".
//!
//! The programs are compiled as c_examples.rs does (`cc -std=gnu89 <file> -Iinclude
//! -Ltarget/<profile> -lvlib -lm`, plus `-g`), and run in fresh directories. Every program that
//! reads an optional width from `argv[1]` renders [`WIDTH`] pixels wide (valgrind is some 50
//! times slower; `hard_cases.c`, whose `argv[1]` is its output directory, gets `.`, and takes
//! about 13 s); `text.c` and `chess.c` first get their datasets, made by the same tools as in
//! c_examples.rs. figure2.c and figure5.c have fixed sizes; figure5.c (256 × 256, twice) is the
//! slowest, about 30 s under valgrind. Two programs run at a time.
//!
//! valgrind is not installed by this test: `.ci/run` installs it. Without it the test fails
//! when `CI` is set and is skipped (with a message) otherwise.

mod common;

use common::TempDir;
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;

/// The width at which text.c and chess.c render under valgrind.
const WIDTH: usize = 32;

/// The most bytes that may remain reachable at exit (measured: 19–24 KiB).
const STILL_REACHABLE_MAX: u64 = 64 * 1024;

fn valgrind_available() -> bool {
    Command::new("valgrind")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

fn compile(source: &str, out_dir: &Path) -> PathBuf {
    common::compile_c(source, out_dir, &["-g"])
}

/// Makes the datasets `source` loads in `cwd` (as c_examples.rs does); returns its arguments.
fn prepare(source: &str, cwd: &Path) -> Vec<String> {
    common::make_inputs(source, cwd);
    // Its argument is the directory for its images, not a width.
    if source.ends_with("hard_cases.c") {
        return vec![".".to_string()];
    }
    // Every example with an optional width argument renders small.
    let text = std::fs::read_to_string(common::workspace_root().join(source)).unwrap_or_default();
    if text.contains("argv[1]") {
        vec![WIDTH.to_string()]
    } else {
        Vec::new()
    }
}

/// The number before " bytes" after `label` in a valgrind log, if the line is there.
fn bytes_after(log: &str, label: &str) -> Option<u64> {
    let line = log.lines().find(|l| l.contains(label))?;
    let rest = &line[line.find(label)? + label.len()..];
    rest.split_whitespace()
        .next()?
        .replace(',', "")
        .parse()
        .ok()
}

/// What one program did under valgrind.
struct Outcome {
    source: String,
    seconds: f64,
    still_reachable: u64,
    problems: Vec<String>,
}

fn memcheck(source: &str) -> Outcome {
    let bin = TempDir::new("memcheck-bin");
    let exe = compile(source, bin.path());
    let cwd = TempDir::new("memcheck-run");
    let args = prepare(source, cwd.path());
    let log = cwd.path().join("valgrind.log");
    let start = std::time::Instant::now();
    let out = Command::new("valgrind")
        .args([
            "--error-exitcode=99",
            "--leak-check=full",
            "--errors-for-leak-kinds=definite,indirect",
            "--show-leak-kinds=definite,indirect",
            "--num-callers=30",
        ])
        .arg(format!("--log-file={}", log.display()))
        .arg(&exe)
        .args(&args)
        .current_dir(cwd.path())
        .env("LD_LIBRARY_PATH", common::profile_dir())
        .output()
        .expect("run valgrind");
    let seconds = start.elapsed().as_secs_f64();
    let log = std::fs::read_to_string(&log).unwrap_or_default();
    let mut problems = Vec::new();
    if !out.status.success() {
        problems.push(format!(
            "exit status {} (99: memcheck errors)\n{}",
            out.status,
            String::from_utf8_lossy(&out.stdout)
        ));
    }
    if !log.contains("ERROR SUMMARY: 0 errors") {
        problems.push("memcheck reported errors".into());
    }
    let no_leaks = log.contains("All heap blocks were freed");
    for label in ["definitely lost: ", "indirectly lost: "] {
        match bytes_after(&log, label) {
            Some(0) => {}
            None if no_leaks => {}
            other => problems.push(format!("{label}{other:?} bytes")),
        }
    }
    let still_reachable = bytes_after(&log, "still reachable: ").unwrap_or(0);
    if still_reachable > STILL_REACHABLE_MAX {
        problems.push(format!(
            "{still_reachable} bytes still reachable at exit (at most {STILL_REACHABLE_MAX}): \
             does the final vlEnd free everything?"
        ));
    }
    if !problems.is_empty() {
        problems.push(format!("valgrind log:\n{log}"));
    }
    Outcome {
        source: source.to_string(),
        seconds,
        still_reachable,
        problems,
    }
}

#[test]
fn every_c_program_is_clean_under_valgrind() {
    if !valgrind_available() {
        let ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false");
        assert!(
            !ci,
            "valgrind is not installed (.ci/run installs it: apt-get install valgrind)"
        );
        eprintln!("valgrind is not installed: memory checking skipped (.ci/run installs it)");
        return;
    }
    common::ensure_libraries();
    // Not nomemory.c nor pool.c: they set an address-space limit (RLIMIT_AS), under which
    // valgrind, whose own memory counts against it and which replaces the allocator, cannot
    // run the program (and the allocation failures they provoke are the point, not leaks);
    // nomemory.rs runs them.
    let files: Vec<String> = common::c_files("examples/c")
        .into_iter()
        .chain(common::c_files("capi/tests/c"))
        .filter(|f| !f.ends_with("/nomemory.c") && !f.ends_with("/pool.c"))
        .collect();
    assert!(files.len() >= 7, "{files:?}");
    // The slowest first, so that two workers finish together.
    let mut queue = files.clone();
    queue.sort_by_key(|f| !f.ends_with("figure5.c"));
    let queue = Mutex::new(VecDeque::from(queue));
    let outcomes = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let next = queue.lock().unwrap().pop_front();
                let Some(source) = next else { break };
                let o = memcheck(&source);
                outcomes.lock().unwrap().push(o);
            });
        }
    });
    let outcomes = outcomes.into_inner().unwrap();
    assert_eq!(outcomes.len(), files.len());
    let mut failed = Vec::new();
    for o in &outcomes {
        println!(
            "{:<32} {:6.1} s under valgrind, {:6} bytes still reachable, {}",
            o.source,
            o.seconds,
            o.still_reachable,
            if o.problems.is_empty() {
                "clean"
            } else {
                "FAILED"
            }
        );
        if !o.problems.is_empty() {
            failed.push(format!("{}:\n{}", o.source, o.problems.join("\n")));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n\n"));
}
