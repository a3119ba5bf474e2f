//! Saving an image whose file bytes do not fit in memory is `NoMemory`, not an abort, and
//! leaves no file and no temporary. The case runs in a child process (this test binary run
//! again with `VLIB_IMAGE_CHILD` set), which makes an 8192 × 8192 image (its colour and
//! transmittance, 1 GiB of address space), sets an address-space limit (`RLIMIT_AS`, 256 MiB
//! above what it has mapped: not room for the 512 MiB of a 16-bit RGBA file's pixels), saves
//! it as `.rgba16.png` and prints one line per check; the parent requires every check, a
//! normal exit and nothing on stderr. Linux only (the limit is set through `setrlimit` and the
//! mapped size read from `/proc/self/status`).

#![cfg(all(target_os = "linux", target_pointer_width = "64"))]

#[path = "common/child.rs"]
mod child;
#[path = "common/dirs.rs"]
mod dirs;
#[path = "common/rlimit.rs"]
mod rlimit;
#[path = "common/status.rs"]
mod status;
use dirs::names;
use rlimit::limit_address_space;

use std::path::{Path, PathBuf};
use vlib::{ErrorCode, Image};

const CHILD: &str = "VLIB_IMAGE_CHILD";
/// The directory the child writes in, from the parent.
const DIR: &str = "VLIB_IMAGE_DIR";
const SIDE: u32 = 8192;

/// In the child: a small save (which starts the library's threads, as the large one would),
/// the large save under the limit, and a small save after it.
fn run_child(dir: &Path) {
    let check = |ok: bool, what: &str| println!("{} {what}", if ok { "ok  " } else { "FAIL" });
    // 512² pixels: a buffer the library fills on its threads, started here, before the limit.
    let warm = Image::from_rgb(512, 512, vec![[0.25; 3]; 512 * 512]);
    check(
        warm.save(dir.join("warm.rgba16.png")).is_ok(),
        "a 512 x 512 image is saved before the limit",
    );
    // Zeroed memory: mapped, not touched.
    let n = SIDE as usize * SIDE as usize;
    let big = Image::from_rgb(SIDE, SIDE, vec![[0.0; 3]; n]);
    limit_address_space(status::status_bytes("VmSize") + (256 << 20));
    let saved = big.save(dir.join("big.rgba16.png"));
    check(
        matches!(&saved, Err(e) if e.code == ErrorCode::NoMemory),
        "the 8192 x 8192 .rgba16.png is NoMemory",
    );
    println!("     ({saved:?})");
    check(
        names(dir) == ["warm.rgba16.png"],
        "no file and no temporary is left",
    );
    println!("     ({:?})", names(dir));
    // Red, and (0, 0.5, 1): 0.5 · 255 = 127.5 rounds to 128.
    let small = Image::from_rgb(2, 1, vec![[1.0, 0.0, 0.0], [0.0, 0.5, 1.0]]);
    let saved = small.save(dir.join("small.ppm"));
    check(
        saved.is_ok()
            && std::fs::read(dir.join("small.ppm")).ok().as_deref()
                == Some(&b"P6\n2 1\n255\n\xff\x00\x00\x00\x80\xff"[..]),
        "a 2 x 1 image is saved after the failure",
    );
}

/// What the child runs (nothing when run as a test).
#[test]
fn child() {
    if std::env::var_os(CHILD).is_some() {
        run_child(Path::new(&std::env::var_os(DIR).expect("the directory")));
    }
}

#[test]
fn an_image_whose_bytes_do_not_fit_is_no_memory_and_leaves_no_file() {
    let dir: PathBuf =
        std::env::temp_dir().join(format!("vlib-image-nomemory-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    child::run_child(
        &[(CHILD, "1".as_ref()), (DIR, dir.as_os_str())],
        &[
            "ok   a 512 x 512 image is saved before the limit",
            "ok   the 8192 x 8192 .rgba16.png is NoMemory",
            "ok   no file and no temporary is left",
            "ok   a 2 x 1 image is saved after the failure",
        ],
    );
    let left = names(&dir);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(left, ["small.ppm", "warm.rgba16.png"]);
}
