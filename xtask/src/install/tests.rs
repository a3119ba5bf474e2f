//! The unit tests of [`super`]: the cargo build's arguments, copying, and `--from-stage`
//! (refused stages install nothing, an install that fails part-way leaves the old one).

use super::*;

#[test]
fn versions_give_their_three_numbers() {
    assert_eq!(numeric_version("0.1.0"), Ok((0, 1, 0)));
    assert_eq!(numeric_version("12.3.45-rc.1+build.7"), Ok((12, 3, 45)));
    assert!(numeric_version("1.2").is_err());
    assert!(numeric_version("1.x.3").is_err());
}

#[test]
fn staging_puts_the_prefix_under_destdir() {
    let p = Path::new("/usr/local/lib");
    assert_eq!(staged(None, p), p);
    assert_eq!(
        staged(Some(Path::new("/tmp/stage")), p),
        Path::new("/tmp/stage/usr/local/lib")
    );
}

use crate::test_dir;

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn mkfifo(path: &Path) {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(path.as_os_str().as_bytes()).unwrap();
    // SAFETY: a NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0, "mkfifo");
}

/// `f()`, which must not block: a FIFO opened for reading without `O_NONBLOCK` waits for a
/// writer that never comes, so the test fails after 20 s instead of hanging.
fn promptly<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(std::time::Duration::from_secs(20))
        .expect("blocked on opening a FIFO")
}

/// Installs `from` as `to` with `mode`, alone.
fn put(from: &Path, to: &Path, mode: u32) -> Result<(), String> {
    let mut install = Install::default();
    install.copy(&open_source(None, from, false)?, to, mode, None)?;
    install.commit()
}

#[test]
fn files_and_links_replace_what_is_there() {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let dir = test_dir("put");
    let (src, dst) = (dir.join("src"), dir.join("dst"));
    std::fs::write(&src, b"new").unwrap();
    std::fs::write(&dst, b"old").unwrap();
    // The source's mode, set-user-ID bit included, is not copied.
    std::fs::set_permissions(&src, std::fs::Permissions::from_mode(0o4755)).unwrap();
    let old = std::fs::metadata(&dst).unwrap().ino();
    put(&src, &dst, 0o640).unwrap();
    assert_eq!(std::fs::read(&dst).unwrap(), b"new");
    let meta = std::fs::metadata(&dst).unwrap();
    assert_eq!(meta.permissions().mode() & 0o7777, 0o640);
    assert_ne!(meta.ino(), old, "rewritten in place");
    let mut install = Install::default();
    install.link("dst", &dir.join("ln")).unwrap();
    install.commit().unwrap();
    let mut install = Install::default();
    install.link("src", &dir.join("ln")).unwrap();
    install.write(&dir.join("w"), b"text").unwrap();
    install.commit().unwrap();
    assert_eq!(
        std::fs::read_link(dir.join("ln")).unwrap(),
        Path::new("src")
    );
    assert_eq!(std::fs::read(dir.join("w")).unwrap(), b"text");
    // A failed copy leaves nothing behind, not even the temporary file.
    assert!(put(&dir.join("missing"), &dir.join("x"), 0o644).is_err());
    assert_eq!(names(&dir), ["dst", "ln", "src", "w"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn sources_are_opened_without_following_links_or_waiting() {
    let dir = test_dir("sources");
    std::fs::write(dir.join("file"), b"x").unwrap();
    mkfifo(&dir.join("fifo"));
    for (name, target) in [
        ("to-file", "file"),
        ("to-fifo", "fifo"),
        ("to-zero", "/dev/zero"),
    ] {
        std::os::unix::fs::symlink(target, dir.join(name)).unwrap();
    }
    // The open itself: a link fails, a FIFO with no writer does not block.
    let fifo = dir.join("fifo");
    let opened = promptly(move || open_nofollow(None, &fifo, 0).map(|_| ()));
    assert!(opened.is_ok(), "{opened:?}");
    let dir_file = File::open(&dir).unwrap();
    assert!(open_nofollow(None, &dir.join("to-file"), 0).is_err());
    assert!(open_nofollow(Some(&dir_file), Path::new("to-file"), 0).is_err());
    assert!(open_nofollow(Some(&dir_file), Path::new("file"), 0).is_ok());
    // What is copied: a regular file, not a link, FIFO or device, by path or in a directory.
    for name in ["to-file", "to-fifo", "to-zero"] {
        let err = open_source(None, &dir.join(name), false).err().unwrap();
        assert!(err.ends_with("is a symbolic link, which is not followed"));
        let err = open_source(Some(&dir_file), &dir.join(name), true)
            .err()
            .unwrap();
        assert!(err.contains("symbolic link"), "{err}");
    }
    let fifo = dir.join("fifo");
    let err = promptly(move || open_source(None, &fifo, false).err().unwrap());
    assert!(err.ends_with("fifo is not a regular file"), "{err}");
    let err = open_source(None, Path::new("/dev/null"), false)
        .err()
        .unwrap();
    assert_eq!(err, "/dev/null is not a regular file");
    // A source that changes between its opening and its copy is not installed.
    let source = open_source(None, &dir.join("file"), false).unwrap();
    std::fs::write(dir.join("file"), b"longer").unwrap();
    let mut install = Install::default();
    let err = install
        .copy(&source, &dir.join("copy"), 0o644, None)
        .unwrap_err();
    assert!(err.ends_with("file changed while it was copied"), "{err}");
    drop(install);
    assert_eq!(
        names(&dir),
        ["fifo", "file", "to-fifo", "to-file", "to-zero"]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn features_reach_the_cargo_build() {
    let root = Path::new("/w");
    let args = |features: &[&str]| -> Vec<String> {
        let features: Vec<String> = features.iter().map(|f| f.to_string()).collect();
        build_args(root, "release", &features)
            .into_iter()
            .map(|a| a.into_string().unwrap())
            .collect()
    };
    assert_eq!(
        args(&[]).join(" "),
        "rustc --package vlib-capi --lib --profile release --message-format json \
         --manifest-path /w/Cargo.toml -- --print native-static-libs"
    );
    assert_eq!(
        args(&["mpi", "capi"]).join(" "),
        "rustc --package vlib-capi --lib --profile release --features mpi,capi \
         --message-format json --manifest-path /w/Cargo.toml -- --print native-static-libs"
    );
}

fn options(prefix: &Path, stage: &Path) -> InstallOptions {
    InstallOptions {
        prefix: prefix.to_path_buf(),
        libdir: PathBuf::from("lib"),
        includedir: PathBuf::from("include"),
        destdir: None,
        types: crate::LibraryTypes {
            shared: true,
            archive: true,
        },
        profile: "release".into(),
        features: Vec::new(),
        from_stage: Some(stage.to_path_buf()),
    }
}

/// A stage as `--destdir stage` leaves it for `prefix`, the files holding `content`; owned
/// by another user where this process may give them away (as root).
fn make_stage(stage: &Path, prefix: &Path, content: &[u8]) {
    let lib = staged(Some(stage), &prefix.join("lib"));
    let include = staged(Some(stage), &prefix.join("include"));
    std::fs::create_dir_all(lib.join("pkgconfig")).unwrap();
    std::fs::create_dir_all(&include).unwrap();
    let pc = format!("prefix={}\nexec_prefix=${{prefix}}\n", prefix.display());
    let files = [
        (lib.join("libvlib.so.0.1.0"), content),
        (lib.join("libvlib.a"), content),
        (include.join("vlib.h"), content),
        (include.join("vlaux.h"), content),
        (lib.join("pkgconfig/vlib.pc"), pc.as_bytes()),
    ];
    for (path, bytes) in files {
        std::fs::write(&path, bytes).unwrap();
        let _ = std::os::unix::fs::chown(&path, Some(65534), Some(65534));
    }
    for name in ["libvlib.so.0", "libvlib.so"] {
        std::os::unix::fs::symlink("libvlib.so.0.1.0", lib.join(name)).unwrap();
    }
}

#[test]
fn a_stage_is_installed_as_new_files_of_the_installer_in_existing_directories() {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let dir = std::env::temp_dir().join(format!("xtask-stage-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (stage, prefix) = (dir.join("stage"), dir.join("prefix"));
    let lib = prefix.join("lib");
    // An existing installation in directories of mode 0750: an old library, its links.
    std::fs::create_dir_all(&lib).unwrap();
    std::fs::set_permissions(&lib, std::fs::Permissions::from_mode(0o750)).unwrap();
    std::fs::write(lib.join("libvlib.so.0.1.0"), b"old").unwrap();
    std::os::unix::fs::symlink("libvlib.so.0.1.0", lib.join("libvlib.so.0")).unwrap();
    let old = std::fs::metadata(lib.join("libvlib.so.0.1.0")).unwrap();
    make_stage(&stage, &prefix, b"new");

    install_staged(&options(&prefix, &stage), &stage).unwrap();
    let me = std::fs::metadata(&dir).unwrap().uid();
    let installed = std::fs::metadata(lib.join("libvlib.so.0.1.0")).unwrap();
    assert_ne!(
        installed.ino(),
        old.ino(),
        "the library was rewritten in place"
    );
    assert_eq!(
        std::fs::metadata(&lib).unwrap().permissions().mode() & 0o777,
        0o750
    );
    for (path, mode) in [
        ("lib/libvlib.so.0.1.0", 0o755),
        ("lib/libvlib.a", 0o644),
        ("include/vlib.h", 0o644),
        ("include/vlaux.h", 0o644),
    ] {
        let meta = std::fs::symlink_metadata(prefix.join(path)).unwrap();
        assert!(meta.is_file(), "{path}");
        assert_eq!(meta.permissions().mode() & 0o7777, mode, "{path}");
        assert_eq!(meta.uid(), me, "{path}");
        assert_eq!(std::fs::read(prefix.join(path)).unwrap(), b"new", "{path}");
    }
    let pc = std::fs::read_to_string(lib.join("pkgconfig/vlib.pc")).unwrap();
    assert!(pc.starts_with(&format!("prefix={}\n", prefix.display())));
    for name in ["libvlib.so.0", "libvlib.so"] {
        assert_eq!(
            std::fs::read_link(lib.join(name)).unwrap(),
            Path::new("libvlib.so.0.1.0")
        );
    }
    // Nothing else: no temporary file is left.
    let mut names: Vec<String> = std::fs::read_dir(&lib)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "libvlib.a",
            "libvlib.so",
            "libvlib.so.0",
            "libvlib.so.0.1.0",
            "pkgconfig"
        ]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `install_staged`'s refusal of `stage` for `prefix` (with `libdir`), which must come
/// promptly.
fn refusal_of(prefix: &Path, stage: &Path, libdir: &str) -> String {
    let mut o = options(prefix, stage);
    o.libdir = PathBuf::from(libdir);
    let stage = stage.to_path_buf();
    promptly(move || install_staged(&o, &stage)).unwrap_err()
}

#[test]
fn a_stage_for_another_prefix_or_with_foreign_links_is_refused() {
    let dir = test_dir("badstage");
    let (stage, prefix) = (dir.join("stage"), dir.join("prefix"));
    let other = dir.join("other");
    let refused = || refusal_of(&prefix, &stage, "lib");
    let err = refused();
    assert!(
        err.contains("stage with `cargo xtask install --destdir"),
        "{err}"
    );
    // Staged for `other`, moved to where `prefix` would be staged: its vlib.pc says so.
    make_stage(&stage, &other, b"new");
    std::fs::rename(staged(Some(&stage), &other), staged(Some(&stage), &prefix)).unwrap();
    let err = refused();
    assert!(err.contains("was staged for another prefix"), "{err}");
    std::fs::remove_dir_all(&stage).unwrap();

    // A link where the archive belongs is not followed; a link out of the directory is
    // not made.
    make_stage(&stage, &prefix, b"new");
    let lib = staged(Some(&stage), &prefix.join("lib"));
    std::fs::remove_file(lib.join("libvlib.a")).unwrap();
    std::os::unix::fs::symlink("/etc/passwd", lib.join("libvlib.a")).unwrap();
    let err = refused();
    assert!(
        err.ends_with("libvlib.a is a symbolic link, which is not followed"),
        "{err}"
    );
    std::fs::remove_file(lib.join("libvlib.a")).unwrap();
    std::fs::remove_file(lib.join("libvlib.so")).unwrap();
    std::os::unix::fs::symlink("/etc/passwd", lib.join("libvlib.so")).unwrap();
    let err = refused();
    assert!(err.contains("links outside the library's names"), "{err}");
    // Nothing was installed by the refused runs.
    assert!(!prefix.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_stage_is_read_without_following_links_or_hard_links() {
    let dir = test_dir("linkstage");
    let (stage, prefix) = (dir.join("stage"), dir.join("prefix"));
    let refused = |libdir: &str| refusal_of(&prefix, &stage, libdir);
    let lib = staged(Some(&stage), &prefix.join("lib"));
    let include = staged(Some(&stage), &prefix.join("include"));
    let pc = lib.join("pkgconfig/vlib.pc");
    // A file the stage's owner could not read, and another whose first line is a secret.
    let secret = dir.join("secret");
    std::fs::write(&secret, b"secret line\n").unwrap();
    let fresh = || {
        let _ = std::fs::remove_dir_all(&stage);
        make_stage(&stage, &prefix, b"new");
    };
    let replace = |path: &Path, by: &dyn Fn(&Path)| {
        std::fs::remove_file(path).unwrap();
        by(path);
    };

    // A hard link to it, as a library, a header or vlib.pc, is refused unread.
    for path in [lib.join("libvlib.a"), include.join("vlib.h"), pc.clone()] {
        fresh();
        replace(&path, &|p| std::fs::hard_link(&secret, p).unwrap());
        let err = refused("lib");
        assert!(
            err.contains("has 2 hard links: a staged file must have no other name"),
            "{err}"
        );
    }
    // So is a link to it, or to a device or a FIFO, in vlib.pc's place: nothing is read,
    // nothing waited for.
    mkfifo(&dir.join("fifo"));
    for target in [secret.clone(), PathBuf::from("/dev/zero"), dir.join("fifo")] {
        fresh();
        replace(&pc, &|p| std::os::unix::fs::symlink(&target, p).unwrap());
        let err = refused("lib");
        assert!(err.contains("vlib.pc is a symbolic link"), "{err}");
        assert!(!err.contains("secret line"), "{err}");
    }
    // A FIFO as vlib.pc, and one larger than any vlib.pc.
    fresh();
    replace(&pc, &mkfifo);
    assert!(refused("lib").ends_with("vlib.pc is not a regular file"));
    let mut big = format!("prefix={}\n", prefix.display()).into_bytes();
    big.resize(PC_MAX as usize + 1, b'#');
    replace(&pc, &|p| std::fs::write(p, &big).unwrap());
    assert!(refused("lib").ends_with("vlib.pc is larger than 65536 bytes"));

    // A link among the stage's directories: the include directory, the directory holding
    // both, pkgconfig.
    let elsewhere = dir.join("elsewhere");
    for link in [
        include.clone(),
        lib.parent().unwrap().into(),
        lib.join("pkgconfig"),
    ] {
        fresh();
        std::fs::rename(&link, &elsewhere).unwrap();
        std::os::unix::fs::symlink(&elsewhere, &link).unwrap();
        let err = refused("lib");
        assert!(
            err.ends_with(&format!(
                "{} is a symbolic link, which is not followed",
                link.display()
            )),
            "{err}"
        );
        std::fs::remove_file(&link).unwrap();
        std::fs::remove_dir_all(&elsewhere).unwrap();
    }
    // `..` in the path below the stage.
    fresh();
    assert!(refused("include/../lib").contains("a staged path with `..` is refused"));
    assert!(!prefix.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_install_that_fails_part_way_leaves_the_one_before() {
    use std::os::unix::fs::MetadataExt;
    let dir = test_dir("partway");
    let (stage, prefix) = (dir.join("stage"), dir.join("prefix"));
    let (lib, include) = (prefix.join("lib"), prefix.join("include"));
    std::fs::create_dir_all(lib.join("pkgconfig")).unwrap();
    std::fs::create_dir_all(&include).unwrap();
    std::fs::write(lib.join("libvlib.so.0.1.0"), b"old").unwrap();
    std::os::unix::fs::symlink("libvlib.so.0.1.0", lib.join("libvlib.so.0")).unwrap();
    std::fs::write(include.join("vlib.h"), b"old").unwrap();
    let old = std::fs::metadata(lib.join("libvlib.so.0.1.0"))
        .unwrap()
        .ino();
    make_stage(&stage, &prefix, b"new");
    // The last file cannot be made (its temporary's name is taken by a directory): the
    // libraries and headers copied before it are removed, not installed.
    let blocker = beside(&lib.join("pkgconfig/vlib.pc"));
    std::fs::create_dir_all(blocker.join("x")).unwrap();
    let err = install_staged(&options(&prefix, &stage), &stage).unwrap_err();
    assert!(err.starts_with("create "), "{err}");
    assert_eq!(std::fs::read(lib.join("libvlib.so.0.1.0")).unwrap(), b"old");
    assert_eq!(
        std::fs::metadata(lib.join("libvlib.so.0.1.0"))
            .unwrap()
            .ino(),
        old
    );
    assert_eq!(std::fs::read(include.join("vlib.h")).unwrap(), b"old");
    assert_eq!(
        names(&lib),
        ["libvlib.so.0", "libvlib.so.0.1.0", "pkgconfig"]
    );
    assert_eq!(names(&include), ["vlib.h"]);
    std::fs::remove_dir_all(&blocker).unwrap();
    assert!(names(&lib.join("pkgconfig")).is_empty());

    // A rename that fails (a directory where a header goes) stops the install there and
    // leaves no temporary; the links, made last, are not replaced.
    std::fs::create_dir_all(include.join("vlaux.h/x")).unwrap();
    let err = install_staged(&options(&prefix, &stage), &stage).unwrap_err();
    assert!(err.starts_with("install "), "{err}");
    for d in [&lib, &include, &lib.join("pkgconfig")] {
        assert!(
            names(d).iter().all(|n| !n.starts_with('.')),
            "{:?}",
            names(d)
        );
    }
    assert!(!lib.join("libvlib.so").exists());
    std::fs::remove_dir_all(include.join("vlaux.h")).unwrap();
    install_staged(&options(&prefix, &stage), &stage).unwrap();
    assert_eq!(std::fs::read(include.join("vlaux.h")).unwrap(), b"new");
    assert_eq!(std::fs::read(lib.join("libvlib.so")).unwrap(), b"new");
    std::fs::remove_dir_all(&dir).unwrap();
}
