//! The Rust examples' standard output: a reader that has gone is not an error, any other
//! failure to write is reported with exit status 1 (`examples/common/say.rs`); `println!`
//! panicked in both cases (exit status 101).

use std::process::Command;

mod common;
use common::example;

#[test]
fn examples_end_quietly_when_their_reader_has_gone_and_report_other_write_errors() {
    let bin = example("figure2");
    assert!(bin.exists(), "{} not built", bin.display());
    let dir = std::env::temp_dir().join(format!("vlib-examples-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("stone.ppm");
    // A pipe whose reading end is closed before the example writes a byte.
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let o = Command::new(&bin)
        .arg(&out)
        .stdout(writer)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{:?} {err}", o.status);
    assert!(!err.contains("panicked"), "{err}");
    assert!(std::fs::metadata(&out).unwrap().len() > 0, "image written");
    if let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") {
        std::fs::remove_file(&out).unwrap();
        let o = Command::new(&bin).arg(&out).stdout(full).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains("writing to standard output"), "{err}");
        assert!(!err.contains("panicked"), "{err}");
        // The image was written before the report line failed.
        assert!(std::fs::metadata(&out).unwrap().len() > 0, "image written");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
