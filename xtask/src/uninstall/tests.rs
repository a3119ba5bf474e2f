//! The unit tests of [`super`]: what an uninstall removes, what it leaves, and the layouts it
//! refuses whole.

use super::*;
use std::os::unix::fs::symlink;

/// [`crate::test_dir`] with a name of these tests (`un-…`, apart from the install tests').
fn test_dir(name: &str) -> PathBuf {
    crate::test_dir(&format!("un-{name}"))
}

/// Every path under `dir` (links not followed), relative to it, sorted; directories end in `/`.
fn tree(dir: &Path) -> Vec<String> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            let rel = path.strip_prefix(root).unwrap().display().to_string();
            if std::fs::symlink_metadata(&path).unwrap().is_dir() {
                out.push(format!("{rel}/"));
                walk(root, &path, out);
            } else {
                out.push(rel);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

fn write(path: &Path, text: &str) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

/// What `cargo xtask install --prefix <prefix>` lays out, under `root` (the prefix itself, or a
/// stage), and beside it files of other packages.
fn lay_out(root: &Path, prefix: &Path) {
    let lib = root.join("lib");
    write(&lib.join("libvlib.so.0.1.0"), "ELF");
    symlink("libvlib.so.0.1.0", lib.join("libvlib.so.0")).unwrap();
    symlink("libvlib.so.0.1.0", lib.join("libvlib.so")).unwrap();
    write(&lib.join("libvlib.a"), "!<arch>");
    write(
        &lib.join("pkgconfig/vlib.pc"),
        &format!("prefix={}\nexec_prefix=${{prefix}}\n", prefix.display()),
    );
    write(&root.join("include/vlib.h"), "/* vlib */");
    write(&root.join("include/vlaux.h"), "/* vlaux */");
    // Other packages' files.
    write(&lib.join("libvlibby.so"), "ELF");
    write(&lib.join("libother.so.1"), "ELF");
    write(&lib.join("pkgconfig/other.pc"), "prefix=/elsewhere\n");
    write(&root.join("include/other.h"), "");
}

fn options(prefix: &Path) -> UninstallOptions {
    UninstallOptions {
        prefix: prefix.to_path_buf(),
        libdir: PathBuf::from("lib"),
        includedir: PathBuf::from("include"),
        destdir: None,
        dry_run: false,
    }
}

/// The tree of a prefix laid out by [`lay_out`] once the uninstall has removed vlib.
const LEFT: [&str; 7] = [
    "include/",
    "include/other.h",
    "lib/",
    "lib/libother.so.1",
    "lib/libvlibby.so",
    "lib/pkgconfig/",
    "lib/pkgconfig/other.pc",
];

#[test]
fn an_install_is_removed_and_the_directories_and_other_files_stay() {
    let prefix = test_dir("whole");
    lay_out(&prefix, &prefix);
    // An older version's library beside it, and a link to it.
    write(&prefix.join("lib/libvlib.so.0.0.9"), "ELF");
    symlink("libvlib.so.0.0.9", prefix.join("lib/libvlib.so.00")).unwrap();
    uninstall(&options(&prefix)).unwrap();
    assert_eq!(tree(&prefix), LEFT);
    // Nothing left to remove: said so, and nothing changes.
    let err = uninstall(&options(&prefix)).unwrap_err();
    assert!(err.contains("no vlib is installed under"), "{err}");
    assert_eq!(tree(&prefix), LEFT);
    std::fs::remove_dir_all(&prefix).unwrap();
}

#[test]
fn a_dry_run_removes_nothing() {
    let prefix = test_dir("dry");
    lay_out(&prefix, &prefix);
    let before = tree(&prefix);
    uninstall(&UninstallOptions {
        dry_run: true,
        ..options(&prefix)
    })
    .unwrap();
    assert_eq!(tree(&prefix), before);
    std::fs::remove_dir_all(&prefix).unwrap();
}

#[test]
fn a_staged_install_is_removed_under_destdir() {
    let stage = test_dir("stage");
    let prefix = Path::new("/opt/vlib-test");
    let root = stage.join("opt/vlib-test");
    lay_out(&root, prefix);
    uninstall(&UninstallOptions {
        destdir: Some(stage.clone()),
        ..options(prefix)
    })
    .unwrap();
    assert_eq!(tree(&root), LEFT);
    std::fs::remove_dir_all(&stage).unwrap();
}

#[test]
fn what_an_install_does_not_make_refuses_the_whole_uninstall() {
    type Change = fn(&Path);
    let cases: [(&str, Change, &str); 6] = [
        (
            "so-file",
            |p| {
                std::fs::remove_file(p.join("lib/libvlib.so")).unwrap();
                write(&p.join("lib/libvlib.so"), "ELF");
            },
            "libvlib.so is not what cargo xtask install makes (a file)",
        ),
        (
            "so-away",
            |p| {
                std::fs::remove_file(p.join("lib/libvlib.so.0")).unwrap();
                symlink("/usr/lib/libvlib.so.0.1.0", p.join("lib/libvlib.so.0")).unwrap();
            },
            "libvlib.so.0 is not what cargo xtask install makes (a link to /usr/lib/",
        ),
        (
            "a-link",
            |p| {
                std::fs::remove_file(p.join("lib/libvlib.a")).unwrap();
                symlink("libvlib.so.0.1.0", p.join("lib/libvlib.a")).unwrap();
            },
            "libvlib.a is not what cargo xtask install makes (a link to libvlib.so.0.1.0)",
        ),
        (
            "header-link",
            |p| {
                std::fs::remove_file(p.join("include/vlib.h")).unwrap();
                symlink("/etc/passwd", p.join("include/vlib.h")).unwrap();
            },
            "vlib.h is not what cargo xtask install makes (a link to /etc/passwd)",
        ),
        (
            "pc-prefix",
            |p| write(&p.join("lib/pkgconfig/vlib.pc"), "prefix=/usr\n"),
            "was installed for another prefix (its first line: \"prefix=/usr\"",
        ),
        (
            "dir",
            |p| {
                std::fs::remove_file(p.join("lib/libvlib.a")).unwrap();
                std::fs::create_dir(p.join("lib/libvlib.a")).unwrap();
            },
            "libvlib.a is not a file (a directory, FIFO or device)",
        ),
    ];
    for (name, change, reason) in cases {
        let prefix = test_dir(name);
        lay_out(&prefix, &prefix);
        change(&prefix);
        let before = tree(&prefix);
        let err = uninstall(&options(&prefix)).unwrap_err();
        assert!(err.contains(reason), "{name}: {err}");
        assert!(err.contains("nothing was removed"), "{name}: {err}");
        assert_eq!(tree(&prefix), before, "{name}");
        std::fs::remove_dir_all(&prefix).unwrap();
    }
}

#[test]
fn full_versions_are_three_numbers() {
    assert!(is_full_version("libvlib.so.0.1.0"));
    assert!(is_full_version("libvlib.so.12.34.56"));
    for name in [
        "libvlib.so.0",
        "libvlib.so.0.1",
        "libvlib.so.0.1.0.1",
        "libvlib.so.0..1",
        "libvlib.so.0.1.x",
        "libvlib.so",
        "../libvlib.so.0.1.0",
        "libvlib.a",
    ] {
        assert!(!is_full_version(name), "{name}");
    }
}
