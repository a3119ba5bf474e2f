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

/// A path as a pkg-config value: UTF-8 without whitespace (pkg-config splits its output at
/// whitespace, so such a path cannot reach the compiler intact).
fn pc_path<'p>(what: &str, path: &'p Path) -> Result<&'p str, String> {
    let text = path
        .to_str()
        .ok_or_else(|| format!("{what} {}: not UTF-8", path.display()))?;
    if text.chars().any(char::is_whitespace) {
        return Err(format!(
            "{what} `{text}` holds whitespace, which pkg-config cannot pass to a compiler"
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

/// The text of `vlib.pc`.
pub fn render(pc: &PcFile) -> Result<String, String> {
    let prefix = pc_path("the prefix", pc.prefix)?;
    let prefix = if prefix.is_empty() { "/" } else { prefix };
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
        assert!(err.contains("whitespace"), "{err}");
        assert!(render(&pc("/p", "my lib", false)).is_err());
        let (p, lib, inc) = (Path::new("/p"), Path::new("lib"), Path::new("include"));
        assert!(check_paths(p, lib, inc).is_ok());
        assert!(check_paths(Path::new("/a\tb"), lib, inc).is_err());
        assert!(check_paths(p, lib, Path::new("my include")).is_err());
    }
}
