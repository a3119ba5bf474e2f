//! The parent's half of a test that runs in a child process (this test binary run again,
//! running only its test `child`, with an environment variable telling that test to act): for
//! the tests that set a process-wide limit (`RLIMIT_AS`) a child must bear alone.

use std::ffi::OsStr;
use std::process::Command;

/// Runs this test binary's test `child` with `envs` set, one thread, output captured, and
/// requires a normal exit, no line marked `FAIL`, each of `lines` printed and no allocation
/// failure reported on stderr (the library's refusals are errors, not aborts). Its stdout.
pub fn run_child(envs: &[(&str, &OsStr)], lines: &[&str]) -> String {
    let out = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "child", "--nocapture", "--test-threads=1"])
        .envs(envs.iter().copied())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}\n{stdout}\n{stderr}", out.status);
    assert!(!stdout.contains("FAIL"), "{stdout}");
    for line in lines {
        assert!(stdout.contains(line), "missing {line:?} in:\n{stdout}");
    }
    assert!(!stderr.contains("memory allocation"), "{stderr}");
    stdout
}
