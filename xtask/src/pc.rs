//! The pkg-config file `vlib.pc`: its text from the install paths, the package's version and
//! description, and the system libraries rustc reports for the archive (`Libs.private`). It
//! writes nothing; [`crate::install`] puts the text in place.

use std::path::Path;

/// What `vlib.pc` says.
pub struct PcFile<'a> {
    /// The installation prefix (absolute), as programs will see it (without any staging
    /// directory).
    pub prefix: &'a Path,
    /// The library directory: relative to the prefix, or absolute.
    pub libdir: &'a Path,
    /// The header directory: relative to the prefix, or absolute.
    pub includedir: &'a Path,
    pub description: &'a str,
    pub version: &'a str,
    /// The libraries a program linking `libvlib.a` needs besides it, as `rustc --print
    /// native-static-libs` reports them (`-lgcc_s -lutil ... -lc` on glibc Linux).
    pub native_static_libs: &'a str,
    /// Only the archive is installed: `-lvlib` can only mean `libvlib.a`, so `Libs` itself
    /// carries the system libraries (as cargo-c does) and `pkg-config --libs` is enough.
    pub archive_only: bool,
}

/// Why pkg-config cannot carry `c` of a path from `vlib.pc` to a compiler's command line
/// intact, if it cannot. Tried with pkgconf 1.8.1 (Debian 12's pkg-config) on every printable
/// ASCII character and a non-ASCII one: letters, digits and `/-._+,=:@^~()` pass as they are.
fn pc_unsafe(c: char) -> Option<&'static str> {
    if c.is_ascii_alphanumeric() || "/-._+,=:@^~()".contains(c) {
        return None;
    }
    Some(match c {
        c if c.is_whitespace() => "white space, at which pkg-config splits its output",
        '#' => "which starts a comment in a .pc file, so the path would be cut there",
        '$' => "which starts a variable reference (`${name}`) in a .pc file",
        '"' | '\'' | '\\' => "which pkg-config reads as shell quoting",
        c if c.is_ascii() => {
            "which pkg-config prints escaped with a backslash, and `$(pkg-config ...)` passes \
             the backslash on to the compiler"
        }
        _ => {
            "a non-ASCII character, whose bytes pkg-config prints escaped with backslashes, \
             and `$(pkg-config ...)` passes them on to the compiler"
        }
    })
}

/// A path as a pkg-config value: UTF-8 of the characters [`pc_unsafe`] lets through, so that
/// `vlib.pc` names it exactly (trailing slashes dropped).
fn pc_path<'p>(what: &str, path: &'p Path) -> Result<&'p str, String> {
    let text = path
        .to_str()
        .ok_or_else(|| format!("{what} {}: not UTF-8", path.display()))?;
    if let Some((c, why)) = text.chars().find_map(|c| pc_unsafe(c).map(|why| (c, why))) {
        let shown = if c.is_whitespace() || c.is_control() {
            format!("{c:?}")
        } else {
            format!("'{c}'")
        };
        return Err(format!(
            "{what} `{text}` holds {shown}, {why}: vlib.pc cannot name it (use a path of \
             letters, digits and /-._+,=:@^~() only)"
        ));
    }
    Ok(text.trim_end_matches('/'))
}

/// `${base}/dir` for a relative `dir`, `dir` itself for an absolute one.
fn under(base: &str, what: &str, dir: &Path) -> Result<String, String> {
    let text = pc_path(what, dir)?;
    Ok(if dir.is_absolute() {
        text.to_string()
    } else {
        format!("${{{base}}}/{text}")
    })
}

/// Whether `vlib.pc` can name these directories (checked before anything is built).
pub fn check_paths(prefix: &Path, libdir: &Path, includedir: &Path) -> Result<(), String> {
    pc_path("the prefix", prefix)?;
    pc_path("the libdir", libdir)?;
    pc_path("the includedir", includedir)?;
    Ok(())
}

/// The value of `prefix=` in `vlib.pc` for an absolute prefix.
pub fn prefix_value(prefix: &Path) -> Result<&str, String> {
    let text = pc_path("the prefix", prefix)?;
    Ok(if text.is_empty() { "/" } else { text })
}

/// The text of `vlib.pc`.
pub fn render(pc: &PcFile) -> Result<String, String> {
    let prefix = prefix_value(pc.prefix)?;
    let libdir = under("exec_prefix", "the libdir", pc.libdir)?;
    let includedir = under("prefix", "the includedir", pc.includedir)?;
    let private = pc
        .native_static_libs
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    let description = pc.description.split_whitespace().collect::<Vec<_>>();
    let mut libs = String::from("-L${libdir} -lvlib");
    if pc.archive_only && !private.is_empty() {
        libs = format!("{libs} {private}");
    }
    Ok(format!(
        "prefix={prefix}\n\
         exec_prefix=${{prefix}}\n\
         libdir={libdir}\n\
         includedir={includedir}\n\
         \n\
         Name: vlib\n\
         Description: {}\n\
         Version: {}\n\
         Libs: {libs}\n\
         Libs.private: {private}\n\
         Cflags: -I${{includedir}}\n",
        description.join(" "),
        pc.version
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    const GLIBC: &str = "-lgcc_s -lutil -lrt -lpthread -lm -ldl -lc";

    fn pc<'a>(prefix: &'a str, libdir: &'a str, archive_only: bool) -> PcFile<'a> {
        PcFile {
            prefix: Path::new(prefix),
            libdir: Path::new(libdir),
            includedir: Path::new("include"),
            description: "The C ABI of vlib:\n libvlib.a and libvlib.so",
            version: "0.1.0",
            native_static_libs: GLIBC,
            archive_only,
        }
    }

    #[test]
    fn relative_directories_follow_the_prefix() {
        let text = render(&pc("/opt/vlib/", "lib", false)).unwrap();
        assert_eq!(
            text,
            "prefix=/opt/vlib\nexec_prefix=${prefix}\nlibdir=${exec_prefix}/lib\n\
             includedir=${prefix}/include\n\nName: vlib\n\
             Description: The C ABI of vlib: libvlib.a and libvlib.so\nVersion: 0.1.0\n\
             Libs: -L${libdir} -lvlib\nLibs.private: -lgcc_s -lutil -lrt -lpthread -lm -ldl -lc\n\
             Cflags: -I${includedir}\n"
        );
    }

    #[test]
    fn absolute_directories_stay_absolute() {
        let text = render(&pc("/usr", "/usr/lib/x86_64-linux-gnu", false)).unwrap();
        assert!(
            text.contains("\nlibdir=/usr/lib/x86_64-linux-gnu\n"),
            "{text}"
        );
        assert!(render(&pc("/", "lib", false))
            .unwrap()
            .starts_with("prefix=/\n"));
    }

    #[test]
    fn an_archive_alone_carries_its_system_libraries_in_libs() {
        let text = render(&pc("/p", "lib", true)).unwrap();
        assert!(text.contains(&format!("\nLibs: -L${{libdir}} -lvlib {GLIBC}\n")));
        assert!(text.contains(&format!("\nLibs.private: {GLIBC}\n")));
    }

    #[test]
    fn paths_pkg_config_cannot_pass_are_refused() {
        let err = render(&pc("/my prefix", "lib", false)).unwrap_err();
        assert!(err.contains("white space"), "{err}");
        assert!(render(&pc("/p", "my lib", false)).is_err());
        let (p, lib, inc) = (Path::new("/p"), Path::new("lib"), Path::new("include"));
        assert!(check_paths(p, lib, inc).is_ok());
        assert!(check_paths(Path::new("/a\tb"), lib, inc).is_err());
        assert!(check_paths(p, lib, Path::new("my include")).is_err());
    }

    #[test]
    fn characters_pkg_config_reads_or_prints_specially_are_refused() {
        let refused = |prefix: &str| {
            check_paths(Path::new(prefix), Path::new("lib"), Path::new("include")).unwrap_err()
        };
        // pkg-config prints `-I/tmp/a/include` for a prefix of `/tmp/a#b`.
        let err = refused("/tmp/a#b");
        assert!(
            err.starts_with("the prefix `/tmp/a#b` holds '#', which starts a comment"),
            "{err}"
        );
        assert!(refused("/tmp/a${x}b").contains("variable reference"));
        assert!(refused("/tmp/a$b").contains("variable reference"));
        for quoting in ["/tmp/a\"b", "/tmp/a'b", "/tmp/a\\b"] {
            assert!(refused(quoting).contains("shell quoting"), "{quoting}");
        }
        // pkgconf prints these with a backslash before them.
        for c in "!%&*;<>?[]`{}|".chars() {
            assert!(
                refused(&format!("/tmp/a{c}b")).contains("escaped with a backslash"),
                "{c}"
            );
        }
        assert!(refused("/home/jos\u{e9}").contains("holds '\u{e9}', a non-ASCII character"));
        assert!(refused("/tmp/a\\b").contains("holds '\\', which"));
        assert!(refused("/tmp/a\tb").contains("holds '\\t', white space"));
        // Every printable ASCII character is either passed or refused with a reason; the
        // passed ones are those pkgconf prints as they are.
        let passed: String = (' '..='~').filter(|&c| pc_unsafe(c).is_none()).collect();
        assert_eq!(
            passed,
            "()+,-./0123456789:=@ABCDEFGHIJKLMNOPQRSTUVWXYZ^_abcdefghijklmnopqrstuvwxyz~"
        );
        let (p, inc) = (
            Path::new("/opt/v-1.2_x+y,z=w:u@v^t~(s)"),
            Path::new("include"),
        );
        assert!(check_paths(p, Path::new("lib"), inc).is_ok());
        assert!(check_paths(p, Path::new("lib#64"), inc)
            .unwrap_err()
            .starts_with("the libdir `lib#64`"));
        assert!(check_paths(p, Path::new("lib"), Path::new("inc&"))
            .unwrap_err()
            .starts_with("the includedir `inc&`"));
    }
}
