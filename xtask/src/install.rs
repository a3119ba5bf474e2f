//! `cargo xtask install`: builds the C library (package `vlib-capi`) with cargo and installs it
//! into a prefix the way `cargo cinstall` does: the shared library under its full version with
//! the links `libvlib.so.<major>` (its SONAME, set by `capi/build.rs`) and `libvlib.so`, the
//! archive, both headers and `vlib.pc`, whose `Libs.private` is what rustc reports for the archive
//! in this build. Installed libraries are stripped (`strip --strip-unneeded` for the shared one,
//! `--strip-debug` for the archive, which keeps the symbol table a linker needs). Every file and
//! link is made beside its destination and renamed over it, so a program using an installed
//! `libvlib.so` never sees it half written. It sets no rpath and runs no `ldconfig`: how programs
//! find the library is the system's business (docs/install.md). `--features` are passed to the
//! build. The command line is [`crate::parse_install`]'s; the pkg-config text is
//! [`crate::pc`]'s.

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
        println!(
            "note: programs find libvlib.so.{major} in {} if that directory is in the loader's \
             path (/etc/ld.so.conf, then run ldconfig) or in LD_LIBRARY_PATH",
            libdir.display()
        );
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

/// Copies `from` to `to` with permissions `mode`, stripped with `strip <flag>` when asked.
fn put(from: &Path, to: &Path, mode: u32, strip: Option<&str>) -> Result<(), String> {
    use std::os::unix::fs::PermissionsExt;
    let tmp = beside(to);
    let result = (|| {
        let _ = std::fs::remove_file(&tmp);
        std::fs::copy(from, &tmp).map_err(|e| format!("copy {}: {e}", from.display()))?;
        std::fs::set_permissions(&tmp, std::fs::Permissions::from_mode(mode))
            .map_err(|e| format!("set the mode of {}: {e}", tmp.display()))?;
        if let Some(flag) = strip {
            run_strip(flag, &tmp)?;
        }
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
        put(&src, &dst, 0o640, None).unwrap();
        assert_eq!(std::fs::read(&dst).unwrap(), b"new");
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&dst).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o640);
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
}
