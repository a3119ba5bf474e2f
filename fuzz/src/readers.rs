//! The input format and the checks of the `vlconvert_readers` fuzz target, shared with its
//! bounded CI run (`vlconvert/tests/fuzz_readers.rs`, which includes this file by path, so it
//! may use only `std`, `vlib` and `vlconvert`).
//!
//! An input is one byte that picks a reader and a layout ([`LAYOUTS`]), then the bytes of one
//! or more files, separated by [`SEP`]: a header and its data file (NIfTI `.hdr` + `.img`,
//! NRRD `.nhdr` + `a.raw`, MetaImage `.mhd` + `a.raw`), the slices of a DICOM series or of a
//! TIFF folder, or one file. [`run`] writes them to a fresh scratch directory, calls the
//! reader in-process (`vlconvert::fuzzing::read`) and checks:
//!
//! - nothing panics (a panic is a crash for the fuzzer and a failure for the CI run);
//! - no allocation asks for more than [`budget`] of the input's size (1 MiB, plus 2100 bytes
//!   a byte: gzip and zlib data inflate at most 1032-fold, and a vector that grows doubles;
//!   more for an image, whose pixels may be bits); a larger request is refused by [`Counting`], the global allocator of both binaries, so a
//!   reader that asks for it infallibly aborts, and one that asks with `try_reserve` gets an
//!   error, both reported (a header claiming 2⁴⁰ voxels must be refused before any
//!   allocation);
//! - an accepted volume's datasets have dimensions, finite and different ends a ≠ b, node
//!   values that are finite and in [0, 1], and a placement of finite numbers.
//!
//! Time is bounded by the fuzzer's `-timeout` and by the CI run's per-case bound.

#![allow(dead_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use vlconvert::fuzzing::{read, types, Format, Type};

/// The separator of an input's files.
pub const SEP: &[u8] = b"--8<--";

/// What the first byte picks (modulo their count): the reader, and the names of the files.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// `vlconvert IN OUT` on one file named `input` (no extension: the content decides).
    Detect,
    /// A single-file NIfTI-1 (`a.nii`, gzipped or not as its bytes say).
    Nifti,
    /// A NIfTI-1 pair: `a.hdr` and `a.img` (`a.img.gz` where its bytes are gzip).
    NiftiPair,
    /// `a.nrrd`.
    Nrrd,
    /// `a.nhdr` and `a.raw` (which its `data file` field must name).
    NrrdDetached,
    /// `a.mha`.
    MetaImage,
    /// `a.mhd` and `a.raw` (which its `ElementDataFile` must name).
    MetaImageDetached,
    /// The files `s0`, `s1`, … of a folder, read as a DICOM series.
    Dicom,
    /// A multi-page `a.tif`.
    Tiff,
    /// The files `s1.tif`, `s2.tif`, … of a folder, read as a stack.
    TiffFolder,
    /// An image named `input` (PNG or PNM as its bytes say).
    Image,
    /// A raw volume: the 7 bytes after the first give its dimensions (1 + a byte each), type,
    /// byte order and skip (a byte each); the rest is the file.
    Raw,
}

/// Every layout, in the order the first byte picks them.
pub const LAYOUTS: [Kind; 12] = [
    Kind::Detect,
    Kind::Nifti,
    Kind::NiftiPair,
    Kind::Nrrd,
    Kind::NrrdDetached,
    Kind::MetaImage,
    Kind::MetaImageDetached,
    Kind::Dicom,
    Kind::Tiff,
    Kind::TiffFolder,
    Kind::Image,
    Kind::Raw,
];

/// The input that gives `kind` and `files` (the inverse of [`run`]'s reading; for
/// [`Kind::Raw`], the first file's first 7 bytes are the parameters).
pub fn encode(kind: Kind, files: &[&[u8]]) -> Vec<u8> {
    let at = LAYOUTS.iter().position(|&k| k == kind).expect("a layout");
    let mut out = vec![at as u8];
    for (i, f) in files.iter().enumerate() {
        if i > 0 {
            out.extend_from_slice(SEP);
        }
        out.extend_from_slice(f);
    }
    out
}

/// `data` split at each [`SEP`].
fn split(data: &[u8]) -> Vec<&[u8]> {
    let mut parts = Vec::new();
    let mut rest = data;
    while let Some(at) = rest.windows(SEP.len()).position(|w| w == SEP) {
        parts.push(&rest[..at]);
        rest = &rest[at + SEP.len()..];
    }
    parts.push(rest);
    parts
}

/// The largest request an input of `len` bytes may make, read as `kind`: 1 MiB plus 2100
/// bytes a byte (zlib and gzip data inflate at most 1032-fold, and a vector that grows
/// doubles); an image (or a file whose format is told by its content) 50 000 bytes a byte:
/// a PNG's pixels are at most 8 a byte of its 1032-fold zlib stream, and a palette pixel
/// becomes 6 bytes of 16-bit RGB.
pub fn budget(kind: Kind, len: usize) -> usize {
    let per_byte = match kind {
        Kind::Image | Kind::Detect => 50_000,
        _ => 2100,
    };
    (1 << 20) + per_byte * len
}

/// The global allocator of the fuzz target and its CI run: the system's, refusing (null) any
/// request over [`LIMIT`] and remembering the largest one refused in [`OVER`].
pub struct Counting;

/// The largest request allowed (usize::MAX: any).
pub static LIMIT: AtomicUsize = AtomicUsize::new(usize::MAX);
/// The largest request refused since [`run`] began (0: none).
pub static OVER: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > LIMIT.load(Ordering::Relaxed) {
            OVER.fetch_max(layout.size(), Ordering::Relaxed);
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's layout, passed on unchanged.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() > LIMIT.load(Ordering::Relaxed) {
            OVER.fetch_max(layout.size(), Ordering::Relaxed);
            return std::ptr::null_mut();
        }
        // SAFETY: as in `alloc`.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System` with this layout (`alloc`, `realloc`).
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > LIMIT.load(Ordering::Relaxed) {
            OVER.fetch_max(new_size, Ordering::Relaxed);
            return std::ptr::null_mut();
        }
        // SAFETY: as in `dealloc`; the caller's new size.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// The outcome of one input: refused (the reader's message) or the datasets' dimensions.
#[derive(Debug)]
pub enum Outcome {
    /// The input picked nothing (it is empty).
    Nothing,
    Refused(String),
    Accepted(Vec<[usize; 3]>),
}

/// Writes `files` into `dir` (emptied first) under `kind`'s names; the path to read and the
/// reader.
fn lay_out(kind: Kind, files: &[&[u8]], dir: &Path) -> std::io::Result<(PathBuf, Format)> {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir)?;
    let put = |name: &str, bytes: &[u8]| -> std::io::Result<PathBuf> {
        let p = dir.join(name);
        std::fs::write(&p, bytes)?;
        Ok(p)
    };
    let first = files.first().copied().unwrap_or_default();
    let second = files.get(1).copied().unwrap_or_default();
    Ok(match kind {
        Kind::Detect => (put("input", first)?, Format::Detect),
        Kind::Nifti => (put("a.nii", first)?, Format::Nifti),
        Kind::NiftiPair => {
            let img = if second.starts_with(&[0x1f, 0x8b]) {
                "a.img.gz"
            } else {
                "a.img"
            };
            put(img, second)?;
            (put("a.hdr", first)?, Format::Nifti)
        }
        Kind::Nrrd => (put("a.nrrd", first)?, Format::Nrrd),
        Kind::NrrdDetached => {
            put("a.raw", second)?;
            (put("a.nhdr", first)?, Format::Nrrd)
        }
        Kind::MetaImage => (put("a.mha", first)?, Format::MetaImage),
        Kind::MetaImageDetached => {
            put("a.raw", second)?;
            (put("a.mhd", first)?, Format::MetaImage)
        }
        Kind::Dicom | Kind::TiffFolder => {
            let sub = dir.join("series");
            std::fs::create_dir_all(&sub)?;
            for (i, f) in files.iter().enumerate().take(8) {
                let name = if kind == Kind::Dicom {
                    format!("s{i}")
                } else {
                    format!("s{}.tif", i + 1)
                };
                std::fs::write(sub.join(name), f)?;
            }
            let format = if kind == Kind::Dicom {
                Format::Dicom
            } else {
                Format::Tiff
            };
            (sub, format)
        }
        Kind::Tiff => (put("a.tif", first)?, Format::Tiff),
        Kind::Image => (put("input", first)?, Format::Image),
        Kind::Raw => {
            let p = |i: usize| first.get(i).copied().unwrap_or(0);
            let format = Format::Raw {
                dims: [1 + p(0) as u32, 1 + p(1) as u32, 1 + p(2) as u32],
                ty: types()[p(3) as usize % types().len()],
                big: p(4) & 1 == 1,
                skip: p(5) as u64,
            };
            (put("a.raw", first.get(6..).unwrap_or_default())?, format)
        }
    })
}

/// Reads `data` (an input as the module's opening describes) with files in `dir` and checks
/// the properties; panics, naming the property, where one fails.
pub fn run(data: &[u8], dir: &Path) -> Outcome {
    let Some((&pick, rest)) = data.split_first() else {
        return Outcome::Nothing;
    };
    let kind = LAYOUTS[pick as usize % LAYOUTS.len()];
    let files = split(rest);
    let (path, format) = lay_out(kind, &files, dir).expect("the scratch directory is writable");
    OVER.store(0, Ordering::Relaxed);
    LIMIT.store(budget(kind, data.len()), Ordering::Relaxed);
    let result = read(format, &path);
    LIMIT.store(usize::MAX, Ordering::Relaxed);
    let over = OVER.swap(0, Ordering::Relaxed);
    assert!(
        over == 0,
        "{kind:?}: a request of {over} bytes for an input of {} bytes (at most {} allowed): \
         {result:?}",
        data.len(),
        budget(kind, data.len()),
        result = result.as_ref().map(|d| d.len())
    );
    match result {
        Err(e) => {
            assert!(!e.is_empty(), "{kind:?}: an empty error");
            Outcome::Refused(e)
        }
        Ok(datasets) => {
            assert!(!datasets.is_empty(), "{kind:?}: accepted, but no dataset");
            for d in &datasets {
                check(d, kind);
            }
            Outcome::Accepted(datasets.iter().map(|d| d.dims()).collect())
        }
    }
}

/// The properties of an accepted dataset.
fn check(d: &vlib::Dataset, kind: Kind) {
    let [nx, ny, nz] = d.dims();
    assert!(nx * ny * nz > 0, "{kind:?}: dimensions {:?}", d.dims());
    let (a, b) = d.range();
    assert!(
        a.is_finite() && b.is_finite() && a != b,
        "{kind:?}: ends {a} {b}"
    );
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let v = d.node(i, j, k);
                assert!(
                    (0.0..=1.0).contains(&v),
                    "{kind:?}: node ({i}, {j}, {k}) of {:?} is {v}",
                    d.dims()
                );
            }
        }
    }
    if let Some(g) = d.geometry() {
        let finite = g.affine().iter().flatten().all(|v| v.is_finite());
        assert!(finite, "{kind:?}: placement {:?}", g.affine());
        let s = g.spacing();
        assert!(
            s.iter().all(|v| v.is_finite() && *v > 0.0),
            "{kind:?}: spacing {s:?}"
        );
    }
}

/// Where scratch directories go: in memory (/dev/shm) where there is one, else the system's
/// temporary directory.
pub fn scratch_base() -> PathBuf {
    let shm = Path::new("/dev/shm");
    if shm.is_dir() {
        shm.to_path_buf()
    } else {
        std::env::temp_dir()
    }
}

/// A scratch directory of this process, under [`scratch_base`].
pub fn scratch(tag: &str) -> PathBuf {
    scratch_base().join(format!("vlconvert-fuzz-{tag}-{}", std::process::id()))
}

/// The type a raw input's fourth parameter byte picks (for seeds).
pub fn type_byte(ty: Type) -> u8 {
    types().iter().position(|&t| t == ty).expect("a type") as u8
}
