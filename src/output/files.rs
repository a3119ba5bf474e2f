//! The atomic write of any file.
//!
//! Every file is written to a temporary file in the destination directory, created exclusively
//! under an unpredictable name, and renamed over the destination only when complete, so a failed
//! write leaves no partial file and an existing file is replaced only by a complete new one
//! ([`write_atomic`] lists the rules).
//!
//! It owns the writing; which files a scene asks for, their encodings and their pixels are
//! decided beside it (`render_outputs`, `formats`) and below it (the renderer).

use crate::error::{err, Error, ErrorCode, Result};
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// How many links [`destination`] follows before it gives up (as the kernel's `ELOOP`).
const MAX_LINKS: usize = 40;

/// The file name `path` ends with, as the system reads the path: none where it ends with `/` or
/// `/.` (or is `.`), which name a directory, not a file, though `Path::file_name` drops them
/// (`x.ppm/` would be `x.ppm`, the checks below would look at `x.ppm/`, fail with "not a
/// directory", and take that for "nothing there"); none either where it ends with `..`.
pub(crate) fn file_name(path: &Path) -> Option<&std::ffi::OsStr> {
    use std::os::unix::ffi::OsStrExt;
    let b = path.as_os_str().as_bytes();
    if b.ends_with(b"/") || b.ends_with(b"/.") || b == b"." {
        return None;
    }
    path.file_name()
}

/// The file a write to `path` replaces: `path` itself, or, where `path` is a symbolic link, the
/// file the chain of links ends at (which need not exist yet), so that the link stays a link
/// and its target is updated. A link is followed as the kernel's `protected_symlinks` rule
/// follows one, which resolving the links here would otherwise bypass: in a sticky directory
/// that anyone may write (`/tmp`), only a link owned by this process's user or by the
/// directory's owner; another user's link there is `PermissionDenied`, and nothing is written
/// through it (a link planted in `/tmp` at the name of an output would have had the library
/// replace whatever file it named).
fn destination(path: &Path) -> std::io::Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                refuse_foreign_link(&p, &m)?;
                let target = fs::read_link(&p)?;
                if file_name(&target).is_none() {
                    return Err(std::io::Error::other(format!(
                        "the link {} names a directory ({}), not a file",
                        p.display(),
                        target.display()
                    )));
                }
                p = match p.parent() {
                    Some(dir) if target.is_relative() => dir.join(target),
                    _ => target,
                };
            }
            _ => return Ok(p),
        }
    }
    Err(std::io::Error::other("too many levels of symbolic links"))
}

/// `PermissionDenied` where the link `link` (its metadata `m`) lies in a sticky directory
/// that anyone may write and is owned neither by this process's effective user nor by the
/// directory's owner (see [`destination`]).
fn refuse_foreign_link(link: &Path, m: &fs::Metadata) -> std::io::Result<()> {
    use std::os::unix::fs::MetadataExt;
    let dir = match link.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let d = fs::metadata(dir)?;
    // (Sticky, and writable by others.)
    if d.mode() & 0o1002 != 0o1002 {
        return Ok(());
    }
    // SAFETY: geteuid has no preconditions and cannot fail.
    let euid = unsafe { libc::geteuid() };
    if m.uid() == euid || m.uid() == d.uid() {
        return Ok(());
    }
    Err(std::io::Error::new(
        std::io::ErrorKind::PermissionDenied,
        format!(
            "the link {} belongs to another user in a sticky directory anyone may write, and \
             is not followed",
            link.display()
        ),
    ))
}

/// A name for a temporary file: `.vl-` and 16 hexadecimal digits that no other process or call
/// can predict (a randomly keyed hash of the process, a counter and the time), and `.tmp`.
/// Short, so that any name legal for the output leaves room for it.
pub(super) fn temporary_name() -> String {
    use std::hash::{BuildHasher, Hasher};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u32(std::process::id());
    h.write_u64(COUNTER.fetch_add(1, Ordering::Relaxed));
    if let Ok(t) = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH) {
        h.write_u128(t.as_nanos());
    }
    format!(".vl-{:016x}.tmp", h.finish())
}

/// How many names [`create_temporary`] tries before it reports the last failure.
const TEMPORARY_TRIES: usize = 16;

/// Creates a new temporary file in `dir`, exclusively: `O_CREAT | O_EXCL`, so an existing file
/// or link at the name (even a dangling one) is never opened or followed; such a name is
/// passed over for the next one.
pub(super) fn create_temporary(
    dir: &Path,
    name: impl Fn() -> String,
) -> std::io::Result<(PathBuf, fs::File)> {
    let mut last = None;
    for _ in 0..TEMPORARY_TRIES {
        let tmp = dir.join(name());
        match fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
        {
            Ok(f) => return Ok((tmp, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last.unwrap_or_else(|| std::io::Error::other("no temporary name")))
}

/// The directory `dest` is in, as a path to create a temporary in that stays valid when the
/// working directory changes (a progress function, or another thread, calling chdir): its
/// absolute path, or, where that is long (or cannot be had), the directory opened now and
/// reached through `/proc/self/fd` (so that a path near `PATH_MAX` leaves room for the
/// temporary's name); the open directory is returned with it to keep that path valid.
fn directory_of(dest: &Path) -> (PathBuf, Option<fs::File>) {
    let dir = match dest.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    // Room for "/" and the longest file name, within Linux's PATH_MAX of 4096 with its NUL.
    let fits = |p: &Path| p.as_os_str().len() + 1 + 255 < 4095;
    if let Ok(abs) = std::path::absolute(&dir) {
        if fits(&abs) {
            return (abs, None);
        }
    }
    match fs::File::open(&dir) {
        Ok(f) => {
            use std::os::fd::AsRawFd;
            let via = PathBuf::from(format!("/proc/self/fd/{}", f.as_raw_fd()));
            if via.is_dir() {
                (via, Some(f))
            } else {
                (dir, None)
            }
        }
        Err(_) => (dir, None),
    }
}

/// A file being written atomically ([`write_atomic`] lists the rules): the bytes go to a
/// temporary in the destination's directory, and [`AtomicFile::commit`] renames it over the
/// destination once complete. Dropped without a commit (a failed or cancelled write), it
/// removes the temporary: nothing of it is left. Writes are buffered.
pub(crate) struct AtomicFile {
    /// The path the caller named (for messages).
    path: PathBuf,
    /// The file the write replaces (the path, or where it is a link the file the links lead
    /// to, [`destination`]), made absolute when the write began (where that fits in
    /// `PATH_MAX`): for the files that go beside it ([`AtomicFile::named`]).
    named: PathBuf,
    /// The temporary and its directory, the destination's file name, the permissions of the
    /// file it replaces.
    tmp: PathBuf,
    dir: PathBuf,
    name: std::ffi::OsString,
    existing: Option<fs::Permissions>,
    /// `None` once committed.
    file: Option<std::io::BufWriter<fs::File>>,
    /// Keeps `dir` valid where it is a `/proc/self/fd` path.
    _open_dir: Option<fs::File>,
}

impl AtomicFile {
    /// Starts writing `path`: checks the destination and creates the temporary.
    pub(crate) fn create(path: &Path) -> Result<AtomicFile> {
        if file_name(path).is_none() {
            return err(
                ErrorCode::BadFile,
                format!("{}: not a file name", path.display()),
            );
        }
        let io =
            |e: std::io::Error| Error::new(ErrorCode::IoError, format!("{}: {e}", path.display()));
        let dest = destination(path).map_err(io)?;
        let name = dest.file_name().ok_or_else(|| {
            Error::new(
                ErrorCode::BadFile,
                format!("{}: not a file name", path.display()),
            )
        })?;
        let existing = match fs::metadata(&dest) {
            Ok(m) if m.is_dir() => {
                return err(
                    ErrorCode::IoError,
                    format!("{}: is a directory", path.display()),
                )
            }
            Ok(m) if !m.is_file() => {
                return err(
                    ErrorCode::IoError,
                    format!("{}: not a regular file", path.display()),
                )
            }
            Ok(m) => {
                let denied = m.permissions().readonly()
                    || fs::OpenOptions::new().write(true).open(&dest).is_err();
                if denied {
                    return err(
                        ErrorCode::IoError,
                        format!("{}: the existing file may not be written", path.display()),
                    );
                }
                Some(m.permissions())
            }
            Err(_) => None,
        };
        let (dir, open_dir) = directory_of(&dest);
        let (tmp, f) = create_temporary(&dir, temporary_name).map_err(io)?;
        let named = match std::path::absolute(&dest) {
            Ok(abs) if abs.as_os_str().len() < 4095 => abs,
            _ => dest.clone(),
        };
        Ok(AtomicFile {
            path: path.to_path_buf(),
            named,
            tmp,
            dir,
            name: name.to_owned(),
            existing,
            file: Some(std::io::BufWriter::with_capacity(1 << 16, f)),
            _open_dir: open_dir,
        })
    }

    /// The path the caller named.
    pub(crate) fn path(&self) -> &Path {
        &self.path
    }

    /// The file this write replaces, as the path the caller named was resolved when the write
    /// began: where that path is a symbolic link, the file the chain of links ends at (followed
    /// under the rules of [`destination`]), and absolute where that fits in `PATH_MAX`. For a
    /// file that goes beside this one (a `.vlb`'s sidecar, [`write_sidecar`]): beside the file
    /// written, not beside a link to it, and where a working directory changed since does not
    /// move it.
    pub(crate) fn named(&self) -> &Path {
        &self.named
    }

    /// The error of a failed write, with the caller's path.
    fn io(&self, e: std::io::Error) -> Error {
        Error::new(ErrorCode::IoError, format!("{}: {e}", self.path.display()))
    }

    /// Appends `bytes`; `VL_IOERROR` if they cannot be written.
    pub(crate) fn write(&mut self, bytes: &[u8]) -> Result<()> {
        let f = self.file.as_mut().expect("not committed");
        f.write_all(bytes)
            .map_err(|e| Error::new(ErrorCode::IoError, format!("{}: {e}", self.path.display())))
    }

    /// The buffered file, for encoders that write through [`std::io::Write`].
    pub(crate) fn writer(&mut self) -> &mut impl Write {
        self.file.as_mut().expect("not committed")
    }

    /// Completes the file: flushes it to disk, gives it the replaced file's permissions and
    /// renames it over the destination.
    pub(crate) fn commit(mut self) -> Result<()> {
        let f = self.file.take().expect("not committed");
        let result = (|| {
            let f = f.into_inner().map_err(|e| e.into_error())?;
            if let Some(p) = &self.existing {
                f.set_permissions(p.clone())?;
            }
            f.sync_all()?;
            drop(f);
            fs::rename(&self.tmp, self.dir.join(&self.name))
        })();
        // Committed or not, the temporary is gone after this (renamed, or removed here), so
        // `Drop` has nothing left to remove.
        let tmp = std::mem::take(&mut self.tmp);
        result.map_err(|e| {
            let _ = fs::remove_file(&tmp);
            self.io(e)
        })
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.tmp.as_os_str().is_empty() {
            self.file = None;
            let _ = fs::remove_file(&self.tmp);
        }
    }
}

/// Writes `bytes` to `path` atomically, the one way every file of the library is written
/// (through an `AtomicFile`):
///
/// - the bytes go to a new temporary file in the destination's directory, created exclusively
///   under a name nobody can predict (never through a link planted at it), flushed to disk, and
///   renamed over the destination only when complete: a failed write leaves no partial file and
///   no temporary, and an existing file is replaced only by a complete new one;
/// - where `path` is a symbolic link, the file it leads to is replaced and the link kept;
/// - an existing destination that may not be written (no write permission bit, or one this
///   process cannot open for writing) is kept, and the write fails with `VL_IOERROR`; so is one
///   that is not a regular file (a directory, a device, a FIFO); a replaced file's permissions
///   pass to the new one;
/// - any path legal for the output works (a file name of 255 bytes, a path near `PATH_MAX`).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write(bytes)?;
    f.commit()
}

/// Writes the geometry sidecar of the dataset file `path` (atomically), or, for a dataset
/// without geometry, removes one an earlier file left, so that the sidecar always describes
/// the file beside it. `path` is the dataset file as written ([`AtomicFile::named`]: a link's
/// target, not the link), so the sidecar lies beside the file it describes; it is itself
/// written as every file is ([`write_atomic`]: a link at its name is followed under the same
/// rules), and a link at its name is removed, not followed. A sidecar whose name is too long
/// for the file system (a dataset file's name within 5 bytes of the limit) cannot exist: there
/// is none to remove.
pub(crate) fn write_sidecar(
    path: &Path,
    geometry: Option<(&crate::data::Geometry, [usize; 3])>,
) -> Result<()> {
    let sidecar = crate::data::Geometry::sidecar(path);
    let absent = |e: &std::io::Error| {
        matches!(
            e.kind(),
            std::io::ErrorKind::NotFound | std::io::ErrorKind::InvalidFilename
        )
    };
    match geometry {
        Some((g, dims)) => write_atomic(&sidecar, g.to_text(dims).as_bytes()),
        None => match fs::remove_file(&sidecar) {
            Err(e) if !absent(&e) => Err(Error::new(
                ErrorCode::IoError,
                format!("{}: {e}", sidecar.display()),
            )),
            _ => Ok(()),
        },
    }
}
