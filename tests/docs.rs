//! The documentation agrees with the code: `docs/commands.md` lists the 44 commands in order,
//! each with exactly the scopes the core's table allows; and the API documentation builds
//! without a rustdoc warning.

use vlib::{Command, Scope};

#[test]
fn commands_doc_matches_the_scope_table() {
    let doc =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/commands.md")).unwrap();
    let rows: Vec<Vec<&str>> = doc
        .lines()
        .filter(|l| l.starts_with("| ") && l[2..].starts_with(|c: char| c.is_ascii_digit()))
        .map(|l| l.split(" | ").map(str::trim).collect())
        .collect();
    assert_eq!(rows.len(), 44);
    for (i, (row, cmd)) in rows.iter().zip(Command::ALL).enumerate() {
        assert_eq!(row[0].trim_start_matches("| "), (i + 1).to_string());
        let name = format!("{}(", cmd.name());
        assert!(
            row[1].contains(&format!(" {name}")) || row[1].contains(&format!("*{name}")),
            "row {}: {}",
            i + 1,
            row[1]
        );
        let letters: Vec<&str> = row[2].split_whitespace().collect();
        for (scope, letter) in Scope::ALL.iter().zip(["U", "L", "S", "O", "X"]) {
            assert_eq!(
                vlib::scope::legal(*cmd, *scope),
                letters.contains(&letter),
                "{} in {scope:?}: the doc says {:?}",
                cmd.name(),
                row[2]
            );
        }
    }
}

/// The API documentation builds without a warning (broken or ambiguous intra-doc links, bad
/// code-block attributes), private items included: `cargo doc` is not otherwise part of the
/// test command. Runs in its own target directory, since the outer `cargo test` holds the
/// lock of the workspace's.
#[test]
fn rustdoc_builds_without_warnings() {
    let root = env!("CARGO_MANIFEST_DIR");
    let out = std::process::Command::new(env!("CARGO"))
        .args([
            "doc",
            "--no-deps",
            "--workspace",
            "--document-private-items",
        ])
        .current_dir(root)
        .env("RUSTDOCFLAGS", "-D warnings")
        .env("CARGO_TARGET_DIR", format!("{root}/target/doc-check"))
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "cargo doc failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
