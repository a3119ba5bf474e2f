//! `cargo xtask install`: builds the C library (package `vlib-capi`) with cargo and installs it
//! into a prefix the way `cargo cinstall` does: the shared library under its full version with
//! the links `libvlib.so.<major>` (its SONAME, set by `capi/build.rs`) and `libvlib.so`, the
//! archive, both headers and `vlib.pc`, whose `Libs.private` is what rustc reports for the archive
//! in this build. Installed libraries are stripped (`strip --strip-unneeded` for the shared one,
//! `--strip-debug` for the archive, which keeps the symbol table a linker needs). Every file and
//! link is made beside its destination and renamed over it, so a program using an installed
//! `libvlib.so` never sees it half written. It sets no rpath and runs no `ldconfig`: how programs
//! find the library is the system's business (docs/install.md). `--features` are passed to the
//! build; `--from-stage` builds nothing and installs what an earlier `--destdir` run staged
//! (root installing what a user built). The command line is [`crate::parse_install`]'s; the
//! pkg-config text is [`crate::pc`]'s.

use crate::pc::{self, PcFile};
use crate::InstallOptions;
use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

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

    if o.types.shared {
        let full = format!("libvlib.so.{major}.{minor}.{patch}");
        let soname = format!("libvlib.so.{major}");
        put(
            &built.shared,
            &lib.join(&full),
            0o755,
            Some("--strip-unneeded"),
        )?;
        for name in [&soname, "libvlib.so"] {
            link(&full, &lib.join(name))?;
        }
    }
    if o.types.archive {
        put(
            &built.archive,
            &lib.join("libvlib.a"),
            0o644,
            Some("--strip-debug"),
        )?;
    }
    for header in HEADERS {
        put(
            &root.join("include").join(header),
            &include.join(header),
            0o644,
            None,
        )?;
    }
    write(&pkgconfig.join("vlib.pc"), pc_text.as_bytes())?;
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

/// `--from-stage`: installs what an earlier run with `--destdir stage` and the same prefix and
/// directories staged, building nothing (so root can install what a user built): the headers,
/// `vlib.pc`, the archive and the shared library found there, their links made anew. Every
/// file and link is put in place by rename as above, so it is a new inode owned by whoever runs
/// this, with the mode set here (0755 for the shared library, 0644 otherwise); directories that
/// exist are left as they are and missing ones are created. The stage's `vlib.pc` must name the
/// prefix, and only regular files are copied (a link in the stage where a file belongs is
/// refused rather than followed).
fn install_staged(o: &InstallOptions, stage: &Path) -> Result<(), String> {
    let libdir = o.prefix.join(&o.libdir);
    let includedir = o.prefix.join(&o.includedir);
    let (from_lib, from_include) = (
        staged(Some(stage), &libdir),
        staged(Some(stage), &includedir),
    );
    let from_pc = from_lib.join("pkgconfig/vlib.pc");
    let pc_text = std::fs::read_to_string(&from_pc).map_err(|e| {
        format!(
            "{}: {e} (stage with `cargo xtask install --destdir {}` and the same --prefix, \
             --libdir and --includedir first)",
            from_pc.display(),
            stage.display()
        )
    })?;
    let prefix_line = format!("prefix={}", pc::prefix_value(&o.prefix)?);
    if pc_text.lines().next() != Some(prefix_line.as_str()) {
        return Err(format!(
            "{} was staged for another prefix than {} (its first line: {:?})",
            from_pc.display(),
            o.prefix.display(),
            pc_text.lines().next().unwrap_or("")
        ));
    }
    let regular = |path: &Path| -> Result<(), String> {
        match std::fs::symlink_metadata(path) {
            Ok(m) if m.is_file() => Ok(()),
            Ok(_) => Err(format!("{} is not a regular file", path.display())),
            Err(e) => Err(format!("{}: {e}", path.display())),
        }
    };
    // The libraries and links the stage holds: files first, so that links are made to files
    // already in place.
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
            regular(&path)?;
            files.push(name);
        }
    }
    if files.is_empty() {
        return Err(format!("{} holds no libvlib", from_lib.display()));
    }
    files.sort();
    links.sort();
    for header in HEADERS {
        regular(&from_include.join(header))?;
    }
    regular(&from_pc)?;

    let pkgconfig = libdir.join("pkgconfig");
    for dir in [&libdir, &includedir, &pkgconfig] {
        std::fs::create_dir_all(dir).map_err(|e| format!("create {}: {e}", dir.display()))?;
    }
    for name in &files {
        let mode = if name == "libvlib.a" { 0o644 } else { 0o755 };
        put(&from_lib.join(name), &libdir.join(name), mode, None)?;
    }
    for (name, target) in &links {
        link(target, &libdir.join(name))?;
    }
    for header in HEADERS {
        put(
            &from_include.join(header),
            &includedir.join(header),
            0o644,
            None,
        )?;
    }
    put(&from_pc, &pkgconfig.join("vlib.pc"), 0o644, None)?;
    // The SONAME is the shortest of the names with a version, `libvlib.so.<major>`.
    let versioned = links.iter().map(|(name, _)| name).chain(&files);
    if let Some(soname) = versioned
        .filter(|n| n.starts_with("libvlib.so."))
        .min_by_key(|n| n.len())
    {
        loader_note(&libdir, soname);
    }
    Ok(())
}

/// The workspace root: this package lives in `xtask/` under it.
fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask has a parent")
        .to_path_buf()
}

fn cargo() -> Command {
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

/// Copies the regular file `from` to `to` with permissions `mode`, stripped with `strip <flag>`
/// when asked. The copy is a new file, made with mode 0600 and given `mode` once written (it
/// never has the source's mode, which could hold set-id bits), then renamed over `to`. `from`
/// must be a regular file: a symbolic link there is refused, not followed.
fn put(from: &Path, to: &Path, mode: u32, strip: Option<&str>) -> Result<(), String> {
    use std::os::unix::fs::{MetadataExt, OpenOptionsExt, PermissionsExt};
    let tmp = beside(to);
    let result = (|| {
        let _ = std::fs::remove_file(&tmp);
        let copy_err = |e: std::io::Error| format!("copy {}: {e}", from.display());
        let mut source = std::fs::File::open(from).map_err(copy_err)?;
        let opened = source.metadata().map_err(copy_err)?;
        let entry = std::fs::symlink_metadata(from).map_err(copy_err)?;
        if !entry.is_file() || (entry.dev(), entry.ino()) != (opened.dev(), opened.ino()) {
            return Err(format!("{} is not a regular file", from.display()));
        }
        let mut copy = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(0o600)
            .open(&tmp)
            .map_err(|e| format!("create {}: {e}", tmp.display()))?;
        std::io::copy(&mut source, &mut copy).map_err(copy_err)?;
        drop(copy);
        if let Some(flag) = strip {
            run_strip(flag, &tmp)?;
        }
        std::fs::set_permissions(&tmp, std::fs::Permissions::from_mode(mode))
            .map_err(|e| format!("set the mode of {}: {e}", tmp.display()))?;
        std::fs::rename(&tmp, to).map_err(|e| format!("install {}: {e}", to.display()))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    } else {
        println!("installed {}", to.display());
    }
    result
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

/// Writes `bytes` to `to` (mode 0644).
fn write(to: &Path, bytes: &[u8]) -> Result<(), String> {
    use std::os::unix::fs::PermissionsExt;
    let tmp = beside(to);
    let result = (|| {
        let _ = std::fs::remove_file(&tmp);
        std::fs::write(&tmp, bytes).map_err(|e| format!("write {}: {e}", tmp.display()))?;
        std::fs::set_permissions(&tmp, std::fs::Permissions::from_mode(0o644))
            .map_err(|e| format!("set the mode of {}: {e}", tmp.display()))?;
        std::fs::rename(&tmp, to).map_err(|e| format!("install {}: {e}", to.display()))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    } else {
        println!("installed {}", to.display());
    }
    result
}

/// Makes `at` a symbolic link to `target` (a name in the same directory), replacing what is there.
fn link(target: &str, at: &Path) -> Result<(), String> {
    let tmp = beside(at);
    let _ = std::fs::remove_file(&tmp);
    std::os::unix::fs::symlink(target, &tmp)
        .and_then(|()| std::fs::rename(&tmp, at))
        .map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            format!("link {} -> {target}: {e}", at.display())
        })?;
    println!("installed {} -> {target}", at.display());
    Ok(())
}

#[cfg(test)]
mod tests {
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

    #[test]
    fn files_and_links_replace_what_is_there() {
        let dir = std::env::temp_dir().join(format!("xtask-put-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let (src, dst) = (dir.join("src"), dir.join("dst"));
        std::fs::write(&src, b"new").unwrap();
        std::fs::write(&dst, b"old").unwrap();
        use std::os::unix::fs::{MetadataExt, PermissionsExt};
        // The source's mode, set-user-ID bit included, is not copied.
        std::fs::set_permissions(&src, std::fs::Permissions::from_mode(0o4755)).unwrap();
        let old = std::fs::metadata(&dst).unwrap().ino();
        put(&src, &dst, 0o640, None).unwrap();
        assert_eq!(std::fs::read(&dst).unwrap(), b"new");
        let meta = std::fs::metadata(&dst).unwrap();
        assert_eq!(meta.permissions().mode() & 0o7777, 0o640);
        assert_ne!(meta.ino(), old, "rewritten in place");
        // A symbolic link as the source is refused, not followed.
        std::os::unix::fs::symlink("src", dir.join("to-src")).unwrap();
        let err = put(&dir.join("to-src"), &dir.join("x"), 0o644, None).unwrap_err();
        assert!(err.ends_with("to-src is not a regular file"), "{err}");
        std::fs::remove_file(dir.join("to-src")).unwrap();
        link("dst", &dir.join("ln")).unwrap();
        link("src", &dir.join("ln")).unwrap();
        assert_eq!(
            std::fs::read_link(dir.join("ln")).unwrap(),
            Path::new("src")
        );
        write(&dir.join("w"), b"text").unwrap();
        assert_eq!(std::fs::read(dir.join("w")).unwrap(), b"text");
        // A failed copy leaves nothing behind, not even the temporary file.
        assert!(put(&dir.join("missing"), &dir.join("x"), 0o644, None).is_err());
        let mut names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["dst", "ln", "src", "w"]);
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

    #[test]
    fn a_stage_for_another_prefix_or_with_foreign_links_is_refused() {
        let dir = std::env::temp_dir().join(format!("xtask-badstage-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let (stage, prefix) = (dir.join("stage"), dir.join("prefix"));
        let other = dir.join("other");
        let err = install_staged(&options(&prefix, &stage), &stage).unwrap_err();
        assert!(
            err.contains("stage with `cargo xtask install --destdir"),
            "{err}"
        );
        // Staged for `other`, moved to where `prefix` would be staged: its vlib.pc says so.
        make_stage(&stage, &other, b"new");
        std::fs::rename(staged(Some(&stage), &other), staged(Some(&stage), &prefix)).unwrap();
        let err = install_staged(&options(&prefix, &stage), &stage).unwrap_err();
        assert!(err.contains("was staged for another prefix"), "{err}");
        std::fs::remove_dir_all(&stage).unwrap();

        // A link where the archive belongs is not followed; a link out of the directory is
        // not made.
        make_stage(&stage, &prefix, b"new");
        let lib = staged(Some(&stage), &prefix.join("lib"));
        std::fs::remove_file(lib.join("libvlib.a")).unwrap();
        std::os::unix::fs::symlink("/etc/passwd", lib.join("libvlib.a")).unwrap();
        let err = install_staged(&options(&prefix, &stage), &stage).unwrap_err();
        assert!(err.contains("libvlib.a is not a regular file"), "{err}");
        std::fs::remove_file(lib.join("libvlib.a")).unwrap();
        std::fs::remove_file(lib.join("libvlib.so")).unwrap();
        std::os::unix::fs::symlink("/etc/passwd", lib.join("libvlib.so")).unwrap();
        let err = install_staged(&options(&prefix, &stage), &stage).unwrap_err();
        assert!(err.contains("links outside the library's names"), "{err}");
        // Nothing was installed by the refused runs.
        assert!(!prefix.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
