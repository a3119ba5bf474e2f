//! `cargo xtask install`: builds the C library (package `vlib-capi`) with cargo and installs it
//! into a prefix the way `cargo cinstall` does: the shared library under its full version with
//! the links `libvlib.so.<major>` (its SONAME, set by `capi/build.rs`) and `libvlib.so`, the
//! archive, both headers and `vlib.pc`, whose `Libs.private` is what rustc reports for the archive
//! in this build. Installed libraries are stripped (`strip --strip-unneeded` for the shared one,
//! `--strip-debug` for the archive, which keeps the symbol table a linker needs). Every file and
//! link is first made beside its destination, and only when all of them are made are they
//! renamed over their destinations ([`Install`]), so a program using an installed `libvlib.so`
//! never sees it half written and an error while copying installs nothing. It sets no rpath and
//! runs no `ldconfig`: how programs find the library is the system's business
//! (docs/install.md). `--features` are passed to the build; `--from-stage` builds nothing and
//! installs what an earlier `--destdir` run staged (root installing what a user built), following
//! no link below the stage. The command line is [`crate::parse_install`]'s; the pkg-config text
//! is [`crate::pc`]'s.

use crate::pc::{self, PcFile};
use crate::InstallOptions;
use serde_json::Value;
use std::ffi::OsStr;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::os::unix::fs::{MetadataExt, OpenOptionsExt, PermissionsExt};
use std::path::{Component, Path, PathBuf};
use std::process::{Command, Stdio};

#[cfg(test)]
mod tests;

/// The ELF systems whose linkers take `-soname` (the list of `capi/build.rs`).
const ELF_SONAME: bool = cfg!(any(
    target_os = "linux",
    target_os = "freebsd",
    target_os = "dragonfly",
    target_os = "netbsd",
    target_os = "openbsd",
    target_os = "illumos",
    target_os = "solaris",
    target_os = "hurd",
    target_os = "haiku",
));

/// The headers a C program includes, in `include/` of the workspace.
const HEADERS: [&str; 2] = ["vlib.h", "vlaux.h"];

/// `vlib-capi` as `cargo metadata` describes it.
struct Package {
    id: String,
    version: String,
    description: String,
}

/// What the build produced.
struct Built {
    shared: PathBuf,
    archive: PathBuf,
    native_static_libs: String,
}

pub fn install(o: &InstallOptions) -> Result<(), String> {
    if !ELF_SONAME {
        return Err(
            "cargo xtask install supports ELF systems (Linux, the BSDs, illumos); \
             elsewhere use cargo cinstall (docs/install.md)"
                .into(),
        );
    }
    if let Some(stage) = &o.from_stage {
        return install_staged(o, stage);
    }
    let root = workspace_root();
    let package = metadata(&root)?;
    let (major, minor, patch) = numeric_version(&package.version)?;
    let built = build(&root, &o.profile, &o.features, &package.id)?;

    let libdir = o.prefix.join(&o.libdir);
    let includedir = o.prefix.join(&o.includedir);
    let lib = staged(o.destdir.as_deref(), &libdir);
    let include = staged(o.destdir.as_deref(), &includedir);
    let pkgconfig = lib.join("pkgconfig");
    // The pkg-config text is made before any file is written.
    let pc_text = pc::render(&PcFile {
        prefix: &o.prefix,
        libdir: &o.libdir,
        includedir: &o.includedir,
        description: &package.description,
        version: &package.version,
        native_static_libs: &built.native_static_libs,
        archive_only: o.types.archive && !o.types.shared,
    })?;
    for dir in [&lib, &include, &pkgconfig] {
        std::fs::create_dir_all(dir).map_err(|e| format!("create {}: {e}", dir.display()))?;
    }

    let mut install = Install::default();
    if o.types.shared {
        let full = format!("libvlib.so.{major}.{minor}.{patch}");
        let soname = format!("libvlib.so.{major}");
        install.copy(
            &open_source(None, &built.shared, false)?,
            &lib.join(&full),
            0o755,
            Some("--strip-unneeded"),
        )?;
        for name in [&soname, "libvlib.so"] {
            install.link(&full, &lib.join(name))?;
        }
    }
    if o.types.archive {
        install.copy(
            &open_source(None, &built.archive, false)?,
            &lib.join("libvlib.a"),
            0o644,
            Some("--strip-debug"),
        )?;
    }
    for header in HEADERS {
        install.copy(
            &open_source(None, &root.join("include").join(header), false)?,
            &include.join(header),
            0o644,
            None,
        )?;
    }
    install.write(&pkgconfig.join("vlib.pc"), pc_text.as_bytes())?;
    install.commit()?;
    if o.types.shared {
        loader_note(&libdir, &format!("libvlib.so.{major}"));
    }
    Ok(())
}

/// Where programs find the shared library, by its SONAME.
fn loader_note(libdir: &Path, soname: &str) {
    println!(
        "note: programs find {soname} in {} if that directory is in the loader's path \
         (/etc/ld.so.conf, then run ldconfig) or in LD_LIBRARY_PATH",
        libdir.display()
    );
}

/// The largest `vlib.pc` `--from-stage` reads (the real one is under 1 KiB).
const PC_MAX: u64 = 64 * 1024;

/// `--from-stage`: installs what an earlier run with `--destdir stage` and the same prefix and
/// directories staged, building nothing (so root can install what a user built): the headers,
/// `vlib.pc`, the archive and the shared library found there, their links made anew. Nothing
/// below `stage` is followed: each directory on the way to the files is opened with `O_NOFOLLOW`
/// from the one above it (a link or `..` there is refused), and each file is checked before and
/// after it is opened (`O_NOFOLLOW | O_NONBLOCK`) to be a regular file with no other hard link,
/// so neither a link nor a hard link to a file the stage's owner cannot read is copied, and no
/// FIFO or device is waited on or opened. `vlib.pc` (at most [`PC_MAX`] bytes) must name the
/// prefix. All sources are opened and checked before anything is written; then [`Install`]
/// puts them in place, each a new inode owned by whoever runs this, with the mode set here
/// (0755 for the shared library, 0644 otherwise). Directories that exist are left as they are
/// and missing ones are created.
fn install_staged(o: &InstallOptions, stage: &Path) -> Result<(), String> {
    let libdir = o.prefix.join(&o.libdir);
    let includedir = o.prefix.join(&o.includedir);
    let (from_lib, from_include) = (
        staged(Some(stage), &libdir),
        staged(Some(stage), &includedir),
    );
    let from_pc = from_lib.join("pkgconfig/vlib.pc");
    let below_stage = |dir: &Path| dir.strip_prefix("/").unwrap_or(dir).to_path_buf();
    // Where there is no vlib.pc, how to stage one.
    let missing = |e: String| match std::fs::symlink_metadata(&from_pc) {
        Ok(_) => e,
        Err(_) => format!(
            "{e} (stage with `cargo xtask install --destdir {}` and the same --prefix, \
             --libdir and --includedir first)",
            stage.display()
        ),
    };
    let root = File::options()
        .read(true)
        .custom_flags(libc::O_DIRECTORY | libc::O_NONBLOCK)
        .open(stage)
        .map_err(|e| missing(format!("{}: {e}", stage.display())))?;
    let lib = open_stage_dir(&root, stage, &below_stage(&libdir)).map_err(missing)?;
    let pkgconfig = open_stage_dir(&lib, &from_lib, Path::new("pkgconfig")).map_err(missing)?;
    let include = open_stage_dir(&root, stage, &below_stage(&includedir))?;

    let pc_source = open_source(Some(&pkgconfig), &from_pc, true).map_err(missing)?;
    if pc_source.meta.len() > PC_MAX {
        return Err(format!(
            "{} is larger than {PC_MAX} bytes",
            from_pc.display()
        ));
    }
    let mut pc_text = String::new();
    (&pc_source.file)
        .take(PC_MAX + 1)
        .read_to_string(&mut pc_text)
        .map_err(|e| format!("read {}: {e}", from_pc.display()))?;
    if pc_text.len() as u64 > PC_MAX {
        return Err(format!(
            "{} is larger than {PC_MAX} bytes",
            from_pc.display()
        ));
    }
    let prefix_line = format!("prefix={}", pc::prefix_value(&o.prefix)?);
    let first_line = pc_text.lines().next().unwrap_or("");
    if first_line != prefix_line {
        return Err(format!(
            "{} was staged for another prefix than {} (its first line: {:?})",
            from_pc.display(),
            o.prefix.display(),
            first_line.chars().take(200).collect::<String>()
        ));
    }

    // The libraries and links the stage holds. The names are listed by path; what is copied is
    // opened from `lib`, and a link's target is only a name for the link made anew.
    let mut files = Vec::new();
    let mut links = Vec::new();
    let entries =
        std::fs::read_dir(&from_lib).map_err(|e| format!("{}: {e}", from_lib.display()))?;
    for entry in entries {
        let entry = entry.map_err(|e| format!("{}: {e}", from_lib.display()))?;
        let Some(name) = entry.file_name().to_str().map(str::to_string) else {
            continue;
        };
        if name != "libvlib.a" && name != "libvlib.so" && !name.starts_with("libvlib.so.") {
            continue;
        }
        let path = entry.path();
        let meta =
            std::fs::symlink_metadata(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        if meta.file_type().is_symlink() && name != "libvlib.a" {
            let target = std::fs::read_link(&path)
                .map_err(|e| format!("{}: {e}", path.display()))?
                .to_str()
                .filter(|t| t.starts_with("libvlib.so.") && !t.contains('/'))
                .ok_or_else(|| format!("{} links outside the library's names", path.display()))?
                .to_string();
            links.push((name, target));
        } else {
            files.push((name, open_source(Some(&lib), &path, true)?));
        }
    }
    if files.is_empty() {
        return Err(format!("{} holds no libvlib", from_lib.display()));
    }
    files.sort_by(|a, b| a.0.cmp(&b.0));
    links.sort();
    let headers = HEADERS
        .iter()
        .map(|h| open_source(Some(&include), &from_include.join(h), true))
        .collect::<Result<Vec<_>, _>>()?;

    let pkgconfig = libdir.join("pkgconfig");
    for dir in [&libdir, &includedir, &pkgconfig] {
        std::fs::create_dir_all(dir).map_err(|e| format!("create {}: {e}", dir.display()))?;
    }
    let mut install = Install::default();
    for (name, source) in &files {
        let mode = if name == "libvlib.a" { 0o644 } else { 0o755 };
        install.copy(source, &libdir.join(name), mode, None)?;
    }
    for (name, target) in &links {
        install.link(target, &libdir.join(name))?;
    }
    for (header, source) in HEADERS.iter().zip(&headers) {
        install.copy(source, &includedir.join(header), 0o644, None)?;
    }
    install.write(&pkgconfig.join("vlib.pc"), pc_text.as_bytes())?;
    install.commit()?;
    // The SONAME is the shortest of the names with a version, `libvlib.so.<major>`.
    let versioned = links.iter().map(|(name, _)| name);
    if let Some(soname) = versioned
        .chain(files.iter().map(|(name, _)| name))
        .filter(|n| n.starts_with("libvlib.so."))
        .min_by_key(|n| n.len())
    {
        loader_note(&libdir, soname);
    }
    Ok(())
}

/// The flags of every open of a source: a link is not followed (the open fails) and a FIFO or
/// device does not block it (a regular file's reads ignore `O_NONBLOCK`).
const SOURCE_FLAGS: i32 = libc::O_NOFOLLOW | libc::O_NONBLOCK;

/// Opens `name` in the directory `dir`, or the path `name` itself without `dir`, read-only with
/// [`SOURCE_FLAGS`] and `flags`.
fn open_nofollow(dir: Option<&File>, name: &Path, flags: i32) -> std::io::Result<File> {
    use std::os::fd::{AsRawFd, FromRawFd};
    use std::os::unix::ffi::OsStrExt;
    let Some(dir) = dir else {
        return File::options()
            .read(true)
            .custom_flags(SOURCE_FLAGS | flags)
            .open(name);
    };
    let c_name = std::ffi::CString::new(name.as_os_str().as_bytes())
        .map_err(|_| std::io::Error::from(std::io::ErrorKind::InvalidInput))?;
    let flags = libc::O_RDONLY | libc::O_CLOEXEC | SOURCE_FLAGS | flags;
    // SAFETY: `c_name` is a NUL-terminated string and `dir` an open descriptor, both alive for
    // the call; a descriptor openat returns is new and owned by nothing else.
    let fd = unsafe { libc::openat(dir.as_raw_fd(), c_name.as_ptr(), flags) };
    if fd < 0 {
        return Err(std::io::Error::last_os_error());
    }
    // SAFETY: see above.
    Ok(unsafe { File::from_raw_fd(fd) })
}

/// Why `path` of the stage could not be opened: what stands there, or the error.
fn refusal(path: &Path, e: std::io::Error) -> String {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => format!(
            "{} is a symbolic link, which is not followed",
            path.display()
        ),
        _ => format!("{}: {e}", path.display()),
    }
}

/// The directory `rel` below `dir` (whose path is `shown`), each component opened with
/// `O_NOFOLLOW | O_DIRECTORY` from the one before it.
fn open_stage_dir(dir: &File, shown: &Path, rel: &Path) -> Result<File, String> {
    let mut shown = shown.to_path_buf();
    let mut dir = dir
        .try_clone()
        .map_err(|e| format!("{}: {e}", shown.display()))?;
    for component in rel.components() {
        match component {
            Component::Normal(name) => {
                shown.push(name);
                dir = open_nofollow(Some(&dir), Path::new(name), libc::O_DIRECTORY)
                    .map_err(|e| refusal(&shown, e))?;
            }
            Component::CurDir | Component::RootDir => {}
            Component::ParentDir | Component::Prefix(_) => {
                return Err(format!(
                    "{}: a staged path with `..` is refused",
                    shown.join(rel).display()
                ))
            }
        }
    }
    Ok(dir)
}

/// A file to copy, open, and what `fstat` said of it when it was opened.
struct Source {
    file: File,
    path: PathBuf,
    meta: std::fs::Metadata,
}

/// Opens the regular file `path` to copy it: by its name in `dir` where given (`path` is then
/// only shown), else by `path`, with [`SOURCE_FLAGS`]. It is checked before it is opened (so
/// a FIFO or device is not opened) and after (the file opened is the one checked); with
/// `only_name`, it must have no other hard link (a file of a stage, which `--destdir` wrote).
fn open_source(dir: Option<&File>, path: &Path, only_name: bool) -> Result<Source, String> {
    let check = |meta: &std::fs::Metadata| {
        if meta.file_type().is_symlink() {
            Err(refusal(path, std::io::ErrorKind::InvalidInput.into()))
        } else if !meta.is_file() {
            Err(format!("{} is not a regular file", path.display()))
        } else if only_name && meta.nlink() != 1 {
            Err(format!(
                "{} has {} hard links: a staged file must have no other name",
                path.display(),
                meta.nlink()
            ))
        } else {
            Ok(())
        }
    };
    let before = std::fs::symlink_metadata(path).map_err(|e| format!("{}: {e}", path.display()))?;
    check(&before)?;
    let name = match dir {
        Some(_) => Path::new(path.file_name().unwrap_or(OsStr::new(""))),
        None => path,
    };
    let file = open_nofollow(dir, name, 0).map_err(|e| refusal(path, e))?;
    let meta = file
        .metadata()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    check(&meta)?;
    if (meta.dev(), meta.ino()) != (before.dev(), before.ino()) {
        return Err(format!("{} changed while it was opened", path.display()));
    }
    Ok(Source {
        file,
        path: path.to_path_buf(),
        meta,
    })
}

/// The workspace root: this package lives in `xtask/` under it.
pub(crate) fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask has a parent")
        .to_path_buf()
}

pub(crate) fn cargo() -> Command {
    Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()))
}

/// `path` under the staging directory, if any.
fn staged(destdir: Option<&Path>, path: &Path) -> PathBuf {
    match destdir {
        Some(d) => d.join(path.strip_prefix("/").unwrap_or(path)),
        None => path.to_path_buf(),
    }
}

/// Major, minor and patch of a semver version (`0.1.0`, `1.2.3-rc.1`).
fn numeric_version(version: &str) -> Result<(u64, u64, u64), String> {
    let core = version.split(['-', '+']).next().unwrap_or("");
    let parts: Vec<u64> = core
        .split('.')
        .map(|p| p.parse::<u64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("vlib-capi's version `{version}` is not major.minor.patch"))?;
    match parts[..] {
        [major, minor, patch] => Ok((major, minor, patch)),
        _ => Err(format!(
            "vlib-capi's version `{version}` is not major.minor.patch"
        )),
    }
}

fn metadata(root: &Path) -> Result<Package, String> {
    let out = cargo()
        .args(["metadata", "--format-version", "1", "--no-deps"])
        .arg("--manifest-path")
        .arg(root.join("Cargo.toml"))
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| format!("run cargo metadata: {e}"))?;
    if !out.status.success() {
        return Err("cargo metadata failed".into());
    }
    let json: Value = serde_json::from_slice(&out.stdout)
        .map_err(|e| format!("cargo metadata printed no JSON: {e}"))?;
    let package = json["packages"]
        .as_array()
        .and_then(|ps| ps.iter().find(|p| p["name"] == "vlib-capi"))
        .ok_or("cargo metadata lists no package vlib-capi")?;
    let text = |key: &str| package[key].as_str().unwrap_or("").to_string();
    Ok(Package {
        id: text("id"),
        version: text("version"),
        description: text("description"),
    })
}

/// The arguments of cargo that build vlib-capi's library (both crate types) in `profile` with
/// `features`, cargo printing JSON messages and rustc reporting the archive's system libraries.
fn build_args(root: &Path, profile: &str, features: &[String]) -> Vec<std::ffi::OsString> {
    let mut args: Vec<std::ffi::OsString> = [
        "rustc",
        "--package",
        "vlib-capi",
        "--lib",
        "--profile",
        profile,
    ]
    .map(Into::into)
    .into();
    if !features.is_empty() {
        args.extend(["--features".into(), features.join(",").into()]);
    }
    args.extend(["--message-format", "json", "--manifest-path"].map(Into::into));
    args.push(root.join("Cargo.toml").into());
    args.extend(["--", "--print", "native-static-libs"].map(Into::into));
    args
}

/// Builds vlib-capi's library (both crate types) with rustc reporting the archive's system
/// libraries; cargo's own messages go to stderr, the compiler's warnings are shown there too.
/// When the crate is fresh, cargo replays the report it stored with the build.
fn build(root: &Path, profile: &str, features: &[String], id: &str) -> Result<Built, String> {
    let mut child = cargo()
        .args(build_args(root, profile, features))
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("run cargo: {e}"))?;
    let stdout = child.stdout.take().expect("piped stdout");
    let (mut shared, mut archive, mut native) = (None, None, None);
    for line in BufReader::new(stdout).lines() {
        let line = line.map_err(|e| format!("read cargo's output: {e}"))?;
        let Ok(msg) = serde_json::from_str::<Value>(&line) else {
            continue;
        };
        match msg["reason"].as_str() {
            Some("compiler-message") => {
                let text = msg["message"]["message"].as_str().unwrap_or("");
                if let Some(libs) = text.strip_prefix("native-static-libs:") {
                    if msg["package_id"] == id {
                        native = Some(libs.trim().to_string());
                    }
                } else if !text.starts_with("link against the following native artifacts") {
                    if let Some(rendered) = msg["message"]["rendered"].as_str() {
                        eprint!("{rendered}");
                    }
                }
            }
            Some("compiler-artifact") if msg["package_id"] == id => {
                for file in msg["filenames"].as_array().into_iter().flatten() {
                    let Some(file) = file.as_str() else { continue };
                    if file.ends_with(".so") {
                        shared = Some(PathBuf::from(file));
                    } else if file.ends_with(".a") {
                        archive = Some(PathBuf::from(file));
                    }
                }
            }
            _ => {}
        }
    }
    let status = child.wait().map_err(|e| format!("wait for cargo: {e}"))?;
    if !status.success() {
        return Err(format!("building vlib-capi failed ({status})"));
    }
    Ok(Built {
        shared: shared.ok_or("cargo built no libvlib.so")?,
        archive: archive.ok_or("cargo built no libvlib.a")?,
        native_static_libs: native
            .ok_or("rustc did not report the archive's system libraries (native-static-libs)")?,
    })
}

/// A temporary name beside `to`, for a file or link renamed over it when complete.
fn beside(to: &Path) -> PathBuf {
    let name = to.file_name().and_then(|n| n.to_str()).unwrap_or("file");
    to.with_file_name(format!(".{name}.xtask-{}", std::process::id()))
}

/// An install in two steps: [`copy`](Install::copy), [`write`](Install::write) and
/// [`link`](Install::link) make each file or link beside its destination, and
/// [`commit`](Install::commit) renames them over their destinations, files first, links last.
/// An install dropped uncommitted (an error on the way) removes its temporaries, leaving the
/// destinations as they were; an error while renaming (rare: each rename stays in one
/// directory) stops there and removes the temporaries not yet renamed.
#[derive(Default)]
struct Install {
    /// The temporaries that exist, to remove if the install stops.
    made: Vec<PathBuf>,
    /// Temporary, destination, and what is said when it is in place.
    files: Vec<(PathBuf, PathBuf, String)>,
    links: Vec<(PathBuf, PathBuf, String)>,
}

impl Install {
    /// A new file of mode 0600 beside `to`, to be removed unless renamed.
    fn create(&mut self, to: &Path) -> Result<(PathBuf, File), String> {
        let tmp = beside(to);
        let _ = std::fs::remove_file(&tmp);
        let file = File::options()
            .write(true)
            .create_new(true)
            .mode(0o600)
            .open(&tmp)
            .map_err(|e| format!("create {}: {e}", tmp.display()))?;
        self.made.push(tmp.clone());
        Ok((tmp, file))
    }

    /// Copies `from` beside `to`, strips the copy with `strip <flag>` when asked and gives it
    /// `mode` (never the source's mode, which could hold set-id bits). The copy must have the
    /// size `from` had when opened, and `from` must still have that size and modification time.
    fn copy(
        &mut self,
        from: &Source,
        to: &Path,
        mode: u32,
        strip: Option<&str>,
    ) -> Result<(), String> {
        let (tmp, mut copy) = self.create(to)?;
        let copy_err = |e: std::io::Error| format!("copy {}: {e}", from.path.display());
        let copied = std::io::copy(&mut &from.file, &mut copy).map_err(copy_err)?;
        let after = from.file.metadata().map_err(copy_err)?;
        let stamp = |m: &std::fs::Metadata| (m.len(), m.mtime(), m.mtime_nsec());
        if copied != from.meta.len() || stamp(&after) != stamp(&from.meta) {
            return Err(format!(
                "{} changed while it was copied",
                from.path.display()
            ));
        }
        copy.sync_all()
            .map_err(|e| format!("write {}: {e}", tmp.display()))?;
        drop(copy);
        if let Some(flag) = strip {
            run_strip(flag, &tmp)?;
        }
        set_mode(&tmp, mode)?;
        self.files
            .push((tmp, to.to_path_buf(), to.display().to_string()));
        Ok(())
    }

    /// Writes `bytes` beside `to`, mode 0644.
    fn write(&mut self, to: &Path, bytes: &[u8]) -> Result<(), String> {
        use std::io::Write;
        let (tmp, mut file) = self.create(to)?;
        file.write_all(bytes)
            .and_then(|()| file.sync_all())
            .map_err(|e| format!("write {}: {e}", tmp.display()))?;
        set_mode(&tmp, 0o644)?;
        self.files
            .push((tmp, to.to_path_buf(), to.display().to_string()));
        Ok(())
    }

    /// A symbolic link to `target` (a name in the same directory) beside `at`.
    fn link(&mut self, target: &str, at: &Path) -> Result<(), String> {
        let tmp = beside(at);
        let _ = std::fs::remove_file(&tmp);
        std::os::unix::fs::symlink(target, &tmp)
            .map_err(|e| format!("link {} -> {target}: {e}", tmp.display()))?;
        self.made.push(tmp.clone());
        let shown = format!("{} -> {target}", at.display());
        self.links.push((tmp, at.to_path_buf(), shown));
        Ok(())
    }

    /// Renames everything made over its destination, files first.
    fn commit(mut self) -> Result<(), String> {
        let renames: Vec<_> = self.files.drain(..).chain(self.links.drain(..)).collect();
        for (tmp, to, shown) in renames {
            std::fs::rename(&tmp, &to).map_err(|e| format!("install {}: {e}", to.display()))?;
            self.made.retain(|t| *t != tmp);
            println!("installed {shown}");
        }
        Ok(())
    }
}

impl Drop for Install {
    fn drop(&mut self) {
        for tmp in &self.made {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

fn set_mode(path: &Path, mode: u32) -> Result<(), String> {
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
        .map_err(|e| format!("set the mode of {}: {e}", path.display()))
}

fn run_strip(flag: &str, file: &Path) -> Result<(), String> {
    let strip = std::env::var_os("STRIP").unwrap_or_else(|| "strip".into());
    let out = Command::new(&strip)
        .arg(flag)
        .arg(file)
        .output()
        .map_err(|e| {
            format!(
                "run {} (binutils; set STRIP to use another): {e}",
                strip.to_string_lossy()
            )
        })?;
    if !out.status.success() {
        return Err(format!(
            "{} {flag} {} failed: {}",
            strip.to_string_lossy(),
            file.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    Ok(())
}
