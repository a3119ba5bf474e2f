//! Unit tests of the output layer: image encoding and atomic writes.

use super::files::*;
use super::formats::*;
use crate::error::ErrorCode;
use crate::render::PixelFormat;
use std::fs;
use std::os::unix::fs::FileTypeExt;
use std::path::Path;

/// Every name of `docs/images.md`'s table gives its format, in any case; a word before the
/// extension that is not a modifier, or a modifier that is the whole stem, is part of the
/// name; unknown extensions and modifiers a file type cannot hold are `BadFile`.
#[test]
fn formats_by_name() {
    use Container::*;
    use PixelFormat::*;
    for (name, container, pixels) in [
        ("a.PPM", Ppm, Rgb8),
        ("x/a.png", Png, Rgb8),
        ("a.rgb.png", Png, Rgb8),
        ("a.RGB8.ppm", Ppm, Rgb8),
        ("a.rgb16.png", Png, Rgb16),
        ("a.Rgb16.PPM", Ppm, Rgb16),
        ("a.rgba.png", Png, Rgba8),
        ("a.rgba8.png", Png, Rgba8),
        ("a.rgba16.png", Png, Rgba16),
        ("a.pfm", Pfm, Rgb32F),
        ("frame.16.png", Png, Rgb8),
        ("scan.v2.png", Png, Rgb8),
        ("rgba.png", Png, Rgb8),
        (".rgba.png", Png, Rgb8),
        ("dir.rgba16/a.png", Png, Rgb8),
    ] {
        let f = ImageFormat::from_path(Path::new(name)).unwrap();
        assert_eq!((f.container, f.pixels), (container, pixels), "{name}");
    }
    for bad in [
        "a.jpg",
        "a",
        "",
        "/",
        "a.png.",
        "a.rgba.ppm",
        "a.rgba16.ppm",
        "a.rgb16.pfm",
        "a.rgba.pfm",
        "a.rgb.pfm",
        "a.ppm/",
        "a.png/.",
        "x/a.ppm/",
        "a.ppm/..",
    ] {
        let e = ImageFormat::from_path(Path::new(bad)).unwrap_err();
        assert_eq!(e.code, ErrorCode::BadFile, "{bad}");
    }
    let e = ImageFormat::from_path(Path::new("a.rgba.ppm")).unwrap_err();
    assert!(e.message.contains("no alpha"), "{}", e.message);
}

#[test]
fn ppm_layout_and_atomic_write() {
    let dir = std::env::temp_dir().join(format!("vlib-out-{}", std::process::id()));
    fs::create_dir_all(&dir).unwrap();
    let p = dir.join("t.ppm");
    let rgb = [1u8, 2, 3, 4, 5, 6];
    write_image(&p, 2, 1, &rgb).unwrap();
    let bytes = fs::read(&p).unwrap();
    assert_eq!(&bytes[..11], b"P6\n2 1\n255\n");
    assert_eq!(&bytes[11..], &rgb);
    // No temporary file is left behind.
    let left: Vec<_> = fs::read_dir(&dir).unwrap().collect();
    assert_eq!(left.len(), 1);
    // An unwritable destination is an I/O error and leaves the old file intact.
    let bad = dir.join("no-such-dir").join("t.png");
    assert_eq!(
        write_image(&bad, 2, 1, &rgb).unwrap_err().code,
        ErrorCode::IoError
    );
    fs::remove_dir_all(&dir).unwrap();
}

/// A fresh empty directory for one test.
fn scratch(tag: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("vlib-out-{tag}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A link planted at any name the temporary file could take is never written through: names a
/// planter could predict from the file's name and the process (`.<name>.<pid>.<n>.tmp`) are not
/// used, and a link at the chosen name makes the exclusive creation try another.
#[test]
fn planted_links_are_never_followed() {
    use std::os::unix::fs::symlink;
    let dir = scratch("planted");
    let victim = dir.join("victim");
    fs::write(&victim, b"precious").unwrap();
    for n in 0..64 {
        let planted = dir.join(format!(".out.ppm.{}.{n}.tmp", std::process::id()));
        symlink(&victim, planted).unwrap();
    }
    write_atomic(&dir.join("out.ppm"), b"new").unwrap();
    assert_eq!(fs::read(&victim).unwrap(), b"precious");
    assert_eq!(fs::read(dir.join("out.ppm")).unwrap(), b"new");
    // The exclusive creation itself: a link at the first name it takes is left alone.
    let first = std::cell::Cell::new(true);
    let name = || {
        if first.replace(false) {
            ".taken".to_string()
        } else {
            ".free".to_string()
        }
    };
    symlink(&victim, dir.join(".taken")).unwrap();
    let (tmp, _) = create_temporary(&dir, name).unwrap();
    assert_eq!(tmp, dir.join(".free"));
    assert_eq!(fs::read(&victim).unwrap(), b"precious");
    // Every name taken: the last failure is reported, nothing written.
    let e = create_temporary(&dir, || ".taken".to_string()).unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::AlreadyExists);
    fs::remove_dir_all(&dir).unwrap();
}

/// Temporary names differ from call to call and leave room for any legal output name.
#[test]
fn temporary_names_are_short_and_distinct() {
    let names: std::collections::HashSet<String> = (0..1000).map(|_| temporary_name()).collect();
    assert_eq!(names.len(), 1000);
    assert!(names
        .iter()
        .all(|n| n.len() == 24 && n.starts_with(".vl-") && n.ends_with(".tmp")));
}

/// An output that is a symbolic link (to a file, through a chain of links, or dangling) keeps
/// the link and gets its target written.
#[test]
fn an_output_link_updates_its_target() {
    use std::os::unix::fs::symlink;
    let dir = scratch("link");
    fs::create_dir(dir.join("real")).unwrap();
    fs::write(dir.join("real/a.ppm"), b"old").unwrap();
    symlink("real/a.ppm", dir.join("a.ppm")).unwrap();
    symlink("a.ppm", dir.join("b.ppm")).unwrap();
    write_atomic(&dir.join("b.ppm"), b"new").unwrap();
    assert_eq!(fs::read(dir.join("real/a.ppm")).unwrap(), b"new");
    for l in ["a.ppm", "b.ppm"] {
        assert!(fs::symlink_metadata(dir.join(l))
            .unwrap()
            .file_type()
            .is_symlink());
    }
    symlink("real/c.ppm", dir.join("c.ppm")).unwrap();
    write_atomic(&dir.join("c.ppm"), b"made").unwrap();
    assert_eq!(fs::read(dir.join("real/c.ppm")).unwrap(), b"made");
    symlink("loop2", dir.join("loop1")).unwrap();
    symlink("loop1", dir.join("loop2")).unwrap();
    assert_eq!(
        write_atomic(&dir.join("loop1"), b"x").unwrap_err().code,
        ErrorCode::IoError
    );
    assert_eq!(
        names(&dir),
        ["a.ppm", "b.ppm", "c.ppm", "loop1", "loop2", "real"]
    );
    assert_eq!(names(&dir.join("real")), ["a.ppm", "c.ppm"]);
    fs::remove_dir_all(&dir).unwrap();
}

/// `Image::save` of an image `Image::check` refuses (lengths that disagree with the size, a
/// side of 0) is `BadValue` in every format, and nothing is written: no file, no temporary, an
/// existing file kept. (A 4 × 4 image of 3 pixels panicked in the encoder; one of 2 pixels
/// without transmittance was saved as a black transparent `.rgba.png`; a 0 × 0 image was
/// `Internal` as a PNG and a 0 × 0 PPM.)
#[test]
fn images_that_disagree_with_themselves_are_not_saved() {
    use crate::render::Image;
    let dir = scratch("disagree");
    fs::write(dir.join("kept.png"), b"old").unwrap();
    let image = Image::with_lengths;
    for (bad, why) in [
        (
            image(4, 4, 3, 3),
            "3 pixels and 3 transmittance values for a 4x4 image",
        ),
        (
            image(2, 1, 2, 0),
            "2 pixels and 0 transmittance values for a 2x1 image",
        ),
        (image(0, 0, 0, 0), "size 0x0"),
        (image(0, 3, 0, 0), "size 0x3"),
        (image(5, 0, 0, 0), "size 5x0"),
    ] {
        for name in [
            "x.ppm",
            "x.rgb16.ppm",
            "x.png",
            "x.rgb16.png",
            "x.rgba.png",
            "x.rgba16.png",
            "x.pfm",
            "kept.png",
        ] {
            let p = dir.join(name);
            let e = bad.save(&p).unwrap_err();
            assert_eq!(e.code, ErrorCode::BadValue, "{name}: {}", e.message);
            let head = format!("{}: Image: {why}", p.display());
            assert!(e.message.starts_with(&head), "{name}: {}", e.message);
        }
    }
    assert_eq!(names(&dir), ["kept.png"]);
    assert_eq!(fs::read(dir.join("kept.png")).unwrap(), b"old");
    fs::remove_dir_all(&dir).unwrap();
}

/// `write_image` of an image with a side of 0 is `BadValue` in every format it writes, and
/// nothing is written: no file, no temporary, an existing file kept. (A 0 × 0 PNG was
/// `Internal`, "PNG encoding failed: Zero width not allowed", and a 0 × 0 PPM was written.)
#[test]
fn empty_images_are_not_written() {
    let dir = scratch("empty");
    fs::write(dir.join("kept.ppm"), b"old").unwrap();
    for (w, h) in [(0, 0), (0, 3), (4, 0)] {
        for name in ["x.ppm", "x.rgb8.ppm", "x.png", "x.rgb.png", "kept.ppm"] {
            let p = dir.join(name);
            let e = write_image(&p, w, h, &[]).unwrap_err();
            assert_eq!(e.code, ErrorCode::BadValue, "{name}: {}", e.message);
            assert_eq!(
                e.message,
                format!("{}: size {w}x{h} (each side at least 1)", p.display())
            );
        }
    }
    assert_eq!(names(&dir), ["kept.ppm"]);
    assert_eq!(fs::read(dir.join("kept.ppm")).unwrap(), b"old");
    fs::remove_dir_all(&dir).unwrap();
}

/// An existing output without write permission, or one that is not a regular file, is kept
/// and the write reported as an I/O error; a replaced file keeps its permissions.
#[test]
fn protected_outputs_are_kept() {
    use std::os::unix::fs::PermissionsExt;
    let dir = scratch("protected");
    let p = dir.join("ro.ppm");
    fs::write(&p, b"keep").unwrap();
    fs::set_permissions(&p, fs::Permissions::from_mode(0o444)).unwrap();
    assert_eq!(
        write_atomic(&p, b"new").unwrap_err().code,
        ErrorCode::IoError
    );
    assert_eq!(fs::read(&p).unwrap(), b"keep");
    let q = dir.join("mode.ppm");
    fs::write(&q, b"old").unwrap();
    fs::set_permissions(&q, fs::Permissions::from_mode(0o640)).unwrap();
    write_atomic(&q, b"new").unwrap();
    assert_eq!(fs::read(&q).unwrap(), b"new");
    assert_eq!(
        fs::metadata(&q).unwrap().permissions().mode() & 0o777,
        0o640
    );
    let fifo = dir.join("fifo.ppm");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if made.is_ok_and(|s| s.success()) {
        assert_eq!(
            write_atomic(&fifo, b"x").unwrap_err().code,
            ErrorCode::IoError
        );
        assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    }
    assert_eq!(
        names(&dir).iter().filter(|n| n.ends_with(".tmp")).count(),
        0
    );
    fs::remove_dir_all(&dir).unwrap();
}

/// A name that ends with `/` or `/.` names a directory, as the system reads it: `BadFile`, and
/// the file (or link) that the name without its slash is stays as it was (a read-only file is
/// not replaced, a link is not turned into a file). A link whose target ends with `/` is an
/// I/O error, and nothing is made.
#[test]
fn names_ending_in_a_slash_are_not_files() {
    use std::os::unix::fs::{symlink, PermissionsExt};
    let dir = scratch("slash");
    let ro = dir.join("ro.ppm");
    fs::write(&ro, b"keep").unwrap();
    fs::set_permissions(&ro, fs::Permissions::from_mode(0o444)).unwrap();
    symlink("real.ppm", dir.join("link.ppm")).unwrap();
    for name in ["ro.ppm/", "ro.ppm/.", "link.ppm/", "link.ppm/."] {
        let mut p = dir.as_os_str().to_owned();
        p.push("/");
        p.push(name);
        let e = write_atomic(Path::new(&p), b"new").unwrap_err();
        assert_eq!(e.code, ErrorCode::BadFile, "{name}: {}", e.message);
    }
    assert_eq!(fs::read(&ro).unwrap(), b"keep");
    assert_eq!(
        fs::metadata(&ro).unwrap().permissions().mode() & 0o777,
        0o444
    );
    assert!(fs::symlink_metadata(dir.join("link.ppm"))
        .unwrap()
        .file_type()
        .is_symlink());
    symlink("made.ppm/", dir.join("to_dir.ppm")).unwrap();
    let e = write_atomic(&dir.join("to_dir.ppm"), b"x").unwrap_err();
    assert_eq!(e.code, ErrorCode::IoError, "{}", e.message);
    assert_eq!(names(&dir), ["link.ppm", "ro.ppm", "to_dir.ppm"]);
    fs::remove_dir_all(&dir).unwrap();
}

/// Any name legal for the output works: a file name of 255 bytes, and a path of 4 090 bytes
/// (the temporary's name does not make it longer than the system allows).
#[test]
fn long_names_and_paths_work() {
    let dir = scratch("long");
    let long = dir.join(format!("{}.ppm", "n".repeat(251)));
    write_atomic(&long, b"long name").unwrap();
    assert_eq!(fs::read(&long).unwrap(), b"long name");
    let mut deep = dir.clone();
    while deep.as_os_str().len() < 4090 - 260 {
        deep.push("d".repeat(200));
    }
    fs::create_dir_all(&deep).unwrap();
    let pad = 4090 - deep.as_os_str().len() - 1;
    let file = deep.join(format!("{}.ppm", "p".repeat(pad - 4)));
    assert_eq!(file.as_os_str().len(), 4090);
    write_atomic(&file, b"deep").unwrap();
    assert_eq!(fs::read(&file).unwrap(), b"deep");
    assert_eq!(names(&deep).len(), 1, "no temporary left");
    fs::remove_dir_all(&dir).unwrap();
}

/// The PNG encoder's writer keeps the first error its file gave, which the encoder may drop,
/// and gives every result back as it was; an interrupted call is not kept.
#[test]
fn the_png_writer_keeps_the_first_error() {
    use std::io::{Error, ErrorKind, Write};
    /// Fails each write with the next error of `errors`, then takes everything.
    struct Failing(Vec<ErrorKind>);
    impl Write for Failing {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            match self.0.pop() {
                Some(k) => Err(Error::new(k, format!("{k:?}"))),
                None => Ok(buf.len()),
            }
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let mut kept = Kept {
        inner: Failing(vec![
            ErrorKind::WriteZero,
            ErrorKind::StorageFull,
            ErrorKind::Interrupted,
        ]),
        error: None,
    };
    assert_eq!(
        kept.write(b"ab").unwrap_err().kind(),
        ErrorKind::Interrupted
    );
    assert!(kept.error.is_none(), "an interrupted call is tried again");
    // The encoder drops this one; it is kept.
    let _ = kept.write(b"ab");
    assert_eq!(kept.write(b"ab").unwrap_err().kind(), ErrorKind::WriteZero);
    assert_eq!(kept.write(b"abc").unwrap(), 3);
    let e = kept.error.take().expect("kept");
    assert_eq!(e.kind(), ErrorKind::StorageFull, "the first one");
    assert_eq!(e.to_string(), "StorageFull");
}

/// A dataset file whose name is within 5 bytes of the file system's 255 has no sidecar to
/// remove (the sidecar's name, 5 bytes longer, cannot exist): writing a dataset without
/// geometry there succeeds, as with a shorter name (it was `VL_IOERROR`, from the removal's
/// ENAMETOOLONG).
#[test]
fn a_dataset_name_near_the_limit_has_no_sidecar_to_remove() {
    let dir = std::env::temp_dir().join(format!("vlib-sidecar-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for len in [250usize, 255] {
        let name = format!("{}.vlb", "a".repeat(len - 4));
        let path = dir.join(&name);
        std::fs::write(&path, b"x").unwrap();
        assert!(
            super::files::write_sidecar(&path, None).is_ok(),
            "a {len}-byte name"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// In a sticky directory anyone may write (as `/tmp`), a link owned by another user is not
/// followed (the kernel's `protected_symlinks` rule, which resolving links in the library
/// would otherwise bypass): the write is `VL_IOERROR` and the file the link names is left as
/// it was; a link of this process's user there is followed (its target written), and another
/// user's link in a directory that is not sticky is followed too. Giving a link to another
/// user needs root: elsewhere that part is skipped.
#[test]
fn another_users_link_in_a_sticky_directory_is_not_followed() {
    use std::os::unix::fs::{lchown, symlink, PermissionsExt};
    let root = std::env::temp_dir().join(format!("vlib-sticky-{}", std::process::id()));
    let _ = fs::remove_dir_all(&root);
    let (sticky, plain, victims) = (root.join("sticky"), root.join("plain"), root.join("v"));
    for d in [&sticky, &plain, &victims] {
        fs::create_dir_all(d).unwrap();
    }
    fs::set_permissions(&sticky, fs::Permissions::from_mode(0o1777)).unwrap();
    let victim = victims.join("victim.txt");
    fs::write(&victim, b"keep").unwrap();
    // Our own link in the sticky directory: followed.
    symlink(&victim, sticky.join("own.ppm")).unwrap();
    write_atomic(&sticky.join("own.ppm"), b"new").unwrap();
    assert_eq!(fs::read(&victim).unwrap(), b"new");
    fs::write(&victim, b"keep").unwrap();
    // Another user's (nobody's) link there: refused, the victim kept.
    let foreign = sticky.join("foreign.ppm");
    symlink(&victim, &foreign).unwrap();
    if lchown(&foreign, Some(65534), Some(65534)).is_err() {
        eprintln!("not root: another user's link cannot be made here");
        fs::remove_dir_all(&root).unwrap();
        return;
    }
    let e = write_atomic(&foreign, b"planted").unwrap_err();
    assert_eq!(e.code, ErrorCode::IoError, "{e}");
    assert_eq!(fs::read(&victim).unwrap(), b"keep");
    assert!(fs::symlink_metadata(&foreign)
        .unwrap()
        .file_type()
        .is_symlink());
    // The same link in a directory that is not sticky: followed.
    let elsewhere = plain.join("foreign.ppm");
    symlink(&victim, &elsewhere).unwrap();
    lchown(&elsewhere, Some(65534), Some(65534)).unwrap();
    write_atomic(&elsewhere, b"fine").unwrap();
    assert_eq!(fs::read(&victim).unwrap(), b"fine");
    fs::remove_dir_all(&root).unwrap();
}
