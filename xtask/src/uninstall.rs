//! `cargo xtask uninstall`: removes from a prefix the files `cargo xtask install` (or `cargo
//! cinstall`) puts there: `libvlib.so.X.Y.Z` of any version, the links `libvlib.so.X` and
//! `libvlib.so` that name one of them, `libvlib.a`, the two headers and `pkgconfig/vlib.pc`.
//! Everything is looked at (without following links) before anything is removed: a `vlib.pc`
//! written for another prefix, or a name that is not what an install makes (a directory, a
//! `libvlib.so` that is a file, a link to somewhere else), refuses the whole uninstall, so a
//! wrong `--prefix` or a library another package owns removes nothing. Directories are left,
//! empty or not, and the loader's cache is the system's (`ldconfig`). The command line is
//! [`crate::parse_uninstall`]'s; the names installed are [`crate::install`]'s.

use crate::UninstallOptions;
use std::path::{Path, PathBuf};

#[cfg(test)]
mod tests;

/// The headers `install` puts under the include directory.
const HEADERS: [&str; 2] = ["vlib.h", "vlaux.h"];

/// What is found at one of the names an install makes.
#[derive(Debug, PartialEq, Eq)]
enum Found {
    /// A regular file.
    File,
    /// A symbolic link to this name in the same directory.
    Link(String),
}

pub fn uninstall(o: &UninstallOptions) -> Result<(), String> {
    let staged = |dir: &Path| match &o.destdir {
        Some(d) => d.join(dir.strip_prefix("/").unwrap_or(dir)),
        None => dir.to_path_buf(),
    };
    let lib = staged(&o.prefix.join(&o.libdir));
    let include = staged(&o.prefix.join(&o.includedir));
    let pc = lib.join("pkgconfig/vlib.pc");

    let mut remove: Vec<(PathBuf, Found)> = Vec::new();
    if let Some(found) = look(&pc)? {
        check_pc(&pc, &found, &o.prefix)?;
        remove.push((pc, found));
    }
    for header in HEADERS {
        let path = include.join(header);
        if let Some(found) = look(&path)? {
            expect_file(&path, &found)?;
            remove.push((path, found));
        }
    }
    let mut names = library_names(&lib)?;
    names.sort();
    for name in names {
        let path = lib.join(&name);
        let Some(found) = look(&path)? else { continue };
        match (&found, name.as_str()) {
            // The shared library under its full version, and the archive.
            (Found::File, "libvlib.a") => {}
            (Found::File, n) if is_full_version(n) => {}
            // The links an install makes: to a versioned name beside them.
            (Found::Link(target), n) if n != "libvlib.a" && is_full_version(target) => {}
            _ => {
                return Err(format!(
                    "{} is not what cargo xtask install makes ({}); nothing was removed",
                    path.display(),
                    describe(&found)
                ))
            }
        }
        remove.push((path, found));
    }
    if remove.is_empty() {
        return Err(format!(
            "no vlib is installed under {} (looked for {}, {} and {}); check --prefix, \
             --libdir, --includedir and --destdir",
            o.prefix.display(),
            lib.join("libvlib.*").display(),
            include.join("vlib.h").display(),
            lib.join("pkgconfig/vlib.pc").display()
        ));
    }
    // Links first, so that no link is left naming a removed library.
    remove.sort_by_key(|(_, found)| matches!(found, Found::File));
    for (path, found) in &remove {
        let shown = match found {
            Found::Link(target) => format!("{} -> {target}", path.display()),
            Found::File => path.display().to_string(),
        };
        if o.dry_run {
            println!("would remove {shown}");
            continue;
        }
        match std::fs::remove_file(path) {
            Ok(()) => println!("removed {shown}"),
            // Removed by someone else meanwhile: what was asked for holds.
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(format!("remove {}: {e}", path.display())),
        }
    }
    if !o.dry_run && remove.iter().any(|(p, _)| is_shared(p)) {
        println!(
            "note: run ldconfig (as root) if {} is in the loader's path, so that its cache \
             forgets libvlib",
            lib.display()
        );
    }
    Ok(())
}

/// What is at `path`, not following a link: `None` where nothing is; a directory, a FIFO or a
/// device is refused.
fn look(path: &Path) -> Result<Option<Found>, String> {
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("{}: {e}", path.display())),
    };
    let kind = meta.file_type();
    if kind.is_symlink() {
        let target = std::fs::read_link(path).map_err(|e| format!("{}: {e}", path.display()))?;
        return Ok(Some(Found::Link(target.to_string_lossy().into_owned())));
    }
    if kind.is_file() {
        return Ok(Some(Found::File));
    }
    Err(format!(
        "{} is not a file (a directory, FIFO or device); nothing was removed",
        path.display()
    ))
}

/// `found` at `path` must be a regular file.
fn expect_file(path: &Path, found: &Found) -> Result<(), String> {
    match found {
        Found::File => Ok(()),
        Found::Link(_) => Err(format!(
            "{} is not what cargo xtask install makes ({}); nothing was removed",
            path.display(),
            describe(found)
        )),
    }
}

fn describe(found: &Found) -> String {
    match found {
        Found::File => "a file".into(),
        Found::Link(target) => format!("a link to {target}"),
    }
}

/// The installed `vlib.pc` must be a file that names `prefix` on its first line, as an install
/// into that prefix writes it.
fn check_pc(pc: &Path, found: &Found, prefix: &Path) -> Result<(), String> {
    expect_file(pc, found)?;
    use std::io::Read;
    let mut head = String::new();
    // (Its first line, at most a few KiB: a prefix line is short.)
    std::fs::File::open(pc)
        .and_then(|f| f.take(4096).read_to_string(&mut head))
        .map_err(|e| format!("read {}: {e}", pc.display()))?;
    let first = head.lines().next().unwrap_or("");
    let want = format!("prefix={}", crate::pc::prefix_value(prefix)?);
    if first != want {
        return Err(format!(
            "{} was installed for another prefix (its first line: {:?}, not {want:?}); \
             nothing was removed",
            pc.display(),
            first.chars().take(200).collect::<String>()
        ));
    }
    Ok(())
}

/// The names in `lib` an install may have made: `libvlib.a`, `libvlib.so` and
/// `libvlib.so.<anything>` (none where `lib` does not exist).
fn library_names(lib: &Path) -> Result<Vec<String>, String> {
    let entries = match std::fs::read_dir(lib) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(format!("{}: {e}", lib.display())),
    };
    let mut names = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| format!("{}: {e}", lib.display()))?;
        let Some(name) = entry.file_name().to_str().map(str::to_string) else {
            continue;
        };
        if name == "libvlib.a" || name == "libvlib.so" || name.starts_with("libvlib.so.") {
            names.push(name);
        }
    }
    Ok(names)
}

/// Whether `name` is a shared library's full name, `libvlib.so.X.Y.Z` (three numbers).
fn is_full_version(name: &str) -> bool {
    name.strip_prefix("libvlib.so.").is_some_and(|v| {
        let parts: Vec<&str> = v.split('.').collect();
        parts.len() == 3
            && parts
                .iter()
                .all(|p| !p.is_empty() && p.bytes().all(|b| b.is_ascii_digit()))
    })
}

/// Whether `path` names the shared library or one of its links.
fn is_shared(path: &Path) -> bool {
    path.file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n == "libvlib.so" || n.starts_with("libvlib.so."))
}
