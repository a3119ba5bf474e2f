//! Helpers shared by the integration tests of the C interface.
//!
//! The C interface has process-global state (the library and the error queue), so every test
//! that touches it takes [`serial`] first. The built libraries are found from the test binary's
//! own path: it lives in `target/<profile>/deps/`.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The workspace root (`capi/..`).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("capi has a parent")
        .to_path_buf()
}

/// `target/<profile>`: the directory above the `deps/` that holds this test binary.
pub fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("current_exe");
    let deps = exe.parent().expect("test binary directory");
    assert_eq!(
        deps.file_name().and_then(|n| n.to_str()),
        Some("deps"),
        "test binary not in deps/"
    );
    deps.parent().expect("profile directory").to_path_buf()
}

/// `profile_dir()` relative to the workspace root when it lies inside it (as `target/release`).
pub fn profile_dir_arg() -> PathBuf {
    let dir = profile_dir();
    match dir.strip_prefix(workspace_root()) {
        Ok(rel) => rel.to_path_buf(),
        Err(_) => dir,
    }
}

/// The shared library's SONAME, `libvlib.so.<major>` (set by `capi/build.rs`): the name a
/// program linked against `libvlib.so` asks the loader for.
pub const SONAME: &str = concat!("libvlib.so.", env!("CARGO_PKG_VERSION_MAJOR"));

/// Makes sure `libvlib.so` and `libvlib.a` in `target/<profile>/` are fresh, with the link
/// `libvlib.so.<major>` -> `libvlib.so` beside them (as README's "Building a C program" makes it).
///
/// `cargo test` builds the library (all three crate types) into `target/<profile>/deps/` but
/// does not copy ("uplift") the `.so` and `.a` to `target/<profile>/`, where C programs link
/// against them; so this runs `cargo build -p vlib-capi` with the same profile and target
/// directory once per test binary. Cargo releases its build lock before running tests, so the
/// nested build does not deadlock. Programs linked against `libvlib.so` record its SONAME, and
/// the loader looks for that name in `LD_LIBRARY_PATH=target/<profile>`: hence the link.
pub fn ensure_libraries() -> &'static Path {
    static BUILT: OnceLock<PathBuf> = OnceLock::new();
    BUILT.get_or_init(|| {
        let dir = cargo_build(&["-p", "vlib-capi", "--lib"]);
        for lib in ["libvlib.so", "libvlib.a"] {
            assert!(
                dir.join(lib).is_file(),
                "{} was not built",
                dir.join(lib).display()
            );
        }
        let link = dir.join(SONAME);
        if std::fs::read_link(&link).ok().as_deref() != Some(Path::new("libvlib.so")) {
            let tmp = dir.join(format!(".{SONAME}.{}", std::process::id()));
            let _ = std::fs::remove_file(&tmp);
            std::os::unix::fs::symlink("libvlib.so", &tmp)
                .and_then(|()| std::fs::rename(&tmp, &link))
                .unwrap_or_else(|e| panic!("link {} -> libvlib.so: {e}", link.display()));
        }
        dir
    })
}

/// Makes sure the tools that prepare the C examples' datasets are fresh in `target/<profile>/`:
/// `vlconvert` (package `vlconvert`) and the `word_png` and `profiles` examples (in `examples/`).
/// `cargo test` builds them only when it tests their packages; this works for
/// `cargo test -p vlib-capi` too.
pub fn ensure_tools() -> &'static Path {
    static BUILT: OnceLock<PathBuf> = OnceLock::new();
    BUILT.get_or_init(|| {
        cargo_build(&["-p", "vlconvert"]);
        let dir = cargo_build(&[
            "-p",
            "vlib-volume",
            "--example",
            "word_png",
            "--example",
            "profiles",
        ]);
        for tool in ["vlconvert", "examples/word_png", "examples/profiles"] {
            assert!(
                dir.join(tool).is_file(),
                "{} was not built",
                dir.join(tool).display()
            );
        }
        dir
    })
}

/// The cargo profile this test binary was built with (`dev` for `target/debug`).
pub fn profile_name() -> String {
    let dir = profile_dir();
    match dir.file_name().and_then(|n| n.to_str()) {
        Some("debug") => "dev".to_string(),
        Some(name) => name.to_string(),
        None => panic!("cannot tell the profile from {}", dir.display()),
    }
}

/// Runs `cargo build <args>` with this test binary's profile and target directory; returns
/// `target/<profile>`.
pub fn cargo_build(args: &[&str]) -> PathBuf {
    let dir = profile_dir();
    let profile = profile_name();
    let target_dir = dir.parent().expect("target directory");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let out = Command::new(cargo)
        .arg("build")
        .args(args)
        .args(["--profile", &profile, "--target-dir"])
        .arg(target_dir)
        .current_dir(workspace_root())
        .output()
        .expect("run cargo build");
    assert!(
        out.status.success(),
        "cargo build {} --profile {profile} failed:\n{}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    dir
}

/// A fresh, empty temporary directory (removed by [`TempDir`]'s drop).
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(tag: &str) -> TempDir {
        use std::sync::atomic::{AtomicUsize, Ordering};
        static N: AtomicUsize = AtomicUsize::new(0);
        let p = std::env::temp_dir().join(format!(
            "vlib-capi-{tag}-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).expect("create temp dir");
        TempDir(p)
    }

    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// A decoded binary PPM (P6, maxval 255).
pub struct Ppm {
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<u8>,
}

impl Ppm {
    pub fn read(path: &Path) -> Ppm {
        let data = std::fs::read(path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()));
        let mut fields = Vec::new();
        let mut i = 0;
        while fields.len() < 4 {
            while i < data.len() && data[i].is_ascii_whitespace() {
                i += 1;
            }
            let start = i;
            while i < data.len() && !data[i].is_ascii_whitespace() {
                i += 1;
            }
            assert!(start < i, "{}: truncated PPM header", path.display());
            fields.push(String::from_utf8_lossy(&data[start..i]).into_owned());
        }
        assert_eq!(fields[0], "P6", "{}: not a binary PPM", path.display());
        assert_eq!(fields[3], "255", "{}: maxval", path.display());
        let width: usize = fields[1].parse().expect("width");
        let height: usize = fields[2].parse().expect("height");
        let rgb = data[i + 1..].to_vec();
        assert_eq!(
            rgb.len(),
            width * height * 3,
            "{}: pixel data size",
            path.display()
        );
        Ppm { width, height, rgb }
    }

    pub fn pixel(&self, x: usize, y: usize) -> [u8; 3] {
        let i = 3 * (y * self.width + x);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }
}

/// Width and height from a PNG's IHDR chunk.
pub fn png_size(path: &Path) -> (u32, u32) {
    let data = std::fs::read(path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()));
    assert!(
        data.len() > 24 && data.starts_with(b"\x89PNG\r\n\x1a\n"),
        "{}: not a PNG",
        path.display()
    );
    assert_eq!(&data[12..16], b"IHDR");
    let w = u32::from_be_bytes(data[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(data[20..24].try_into().unwrap());
    (w, h)
}

/// The C files of `dir` (relative to the workspace root), as `dir/name.c`, sorted.
pub fn c_files(dir: &str) -> Vec<String> {
    let mut files: Vec<String> = std::fs::read_dir(workspace_root().join(dir))
        .unwrap_or_else(|e| panic!("read {dir}: {e}"))
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".c"))
        .map(|n| format!("{dir}/{n}"))
        .collect();
    files.sort();
    files
}

/// Compiles `source` (relative to the workspace root) into `out_dir` with the documented line,
/// `cc -std=gnu89 <flags> source -Iinclude -Ltarget/<profile> -lvlib -lm`, and returns the
/// executable; fails the test with cc's messages if it does not compile.
pub fn compile_c(source: &str, out_dir: &Path, flags: &[&str]) -> PathBuf {
    let mut all = vec!["-std=gnu89"];
    all.extend_from_slice(flags);
    let name = Path::new(source)
        .file_stem()
        .expect("file name")
        .to_string_lossy()
        .into_owned();
    let exe = out_dir.join(name);
    if let Err(messages) = compile_with("cc", source, &exe, &all) {
        panic!("cc {source} failed:\n{messages}");
    }
    exe
}

/// Compiles and links `source` (relative to the workspace root) into `exe` with compiler `cc`:
/// `cc <flags> source -Iinclude -Ltarget/<profile> -lvlib -lm -o exe`, run from the workspace
/// root. Returns the compiler's messages as the error when it fails.
pub fn compile_with(cc: &str, source: &str, exe: &Path, flags: &[&str]) -> Result<(), String> {
    ensure_libraries();
    let out = Command::new(cc)
        .args(flags)
        .args([source, "-Iinclude"])
        .arg(format!("-L{}", profile_dir_arg().display()))
        .args(["-lvlib", "-lm", "-o"])
        .arg(exe)
        .current_dir(workspace_root())
        .output()
        .unwrap_or_else(|e| panic!("run {cc}: {e}"));
    if out.status.success() {
        Ok(())
    } else {
        Err(String::from_utf8_lossy(&out.stderr).into_owned())
    }
}

/// Runs a tool from `target/<profile>/` (`vlconvert`, `examples/word_png`, …) in `cwd`; fails
/// the test with its output if it fails.
pub fn tool(name: &str, args: &[&str], cwd: &Path) {
    let exe = ensure_tools().join(name);
    let out = Command::new(&exe)
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap_or_else(|e| panic!("run {}: {e}", exe.display()));
    assert!(
        out.status.success(),
        "{name} {args:?} failed:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Makes in `cwd` the datasets the C program `source` loads, as examples/gallery.sh does:
/// the word for text.c, the piece profiles for chess.c. Returns whether `source` needed any.
pub fn make_inputs(source: &str, cwd: &Path) -> bool {
    match Path::new(source).file_stem().and_then(|n| n.to_str()) {
        Some("text") => {
            tool("examples/word_png", &["word.png"], cwd);
            tool("vlconvert", &["image", "word.png", "word.vlb"], cwd);
            true
        }
        Some("chess") => {
            tool("examples/profiles", &["."], cwd);
            for piece in [
                "pawn",
                "rook",
                "knight",
                "knight_head",
                "bishop",
                "queen",
                "king",
            ] {
                let (png, vlb) = (format!("{piece}.png"), format!("{piece}.vlb"));
                tool("vlconvert", &["image", &png, &vlb], cwd);
            }
            true
        }
        _ => false,
    }
}

/// The width at which the tests render text.c and chess.c.
pub const SMALL: usize = 160;

/// The widths at which the tests render the examples without datasets that take a width.
pub const SMALL_WIDTHS: [(&str, usize); 5] = [
    ("examples/c/cvg.c", 200),
    ("examples/c/textures.c", SMALL),
    ("examples/c/smoke.c", 120),
    ("examples/c/deform.c", SMALL),
    ("examples/c/metaballs.c", SMALL),
];

/// The width at which the tests render example `source`.
pub fn small_width(source: &str) -> usize {
    SMALL_WIDTHS
        .iter()
        .find(|(s, _)| *s == source)
        .map(|(_, w)| *w)
        .unwrap_or_else(|| panic!("{source} is not in SMALL_WIDTHS"))
}

/// Makes the datasets the C program `source` loads, in `cwd`, as examples/gallery.sh does;
/// returns the arguments to run it with.
pub fn prepare(source: &str, cwd: &Path) -> Vec<String> {
    if SMALL_WIDTHS.iter().any(|(s, _)| *s == source) {
        return vec![small_width(source).to_string()];
    }
    if make_inputs(source, cwd) {
        vec![SMALL.to_string()]
    } else {
        Vec::new()
    }
}

/// Makes sure the Rust examples `names` are fresh in `target/<profile>/examples/`; returns
/// `target/<profile>`.
pub fn ensure_examples(names: &[&str]) -> PathBuf {
    let mut args = vec!["-p", "vlib-volume"];
    for n in names {
        args.extend(["--example", n]);
    }
    cargo_build(&args)
}

/// Runs `exe` (a program linked against the library) with `cwd` as working directory;
/// returns its standard output, and panics with both outputs when it fails.
pub fn run(exe: &Path, cwd: &Path, args: &[String]) -> String {
    let out = Command::new(exe)
        .args(args)
        .current_dir(cwd)
        .env("LD_LIBRARY_PATH", profile_dir())
        .output()
        .unwrap_or_else(|e| panic!("run {}: {e}", exe.display()));
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{} exited with {}:\n{stdout}\n{}",
        exe.display(),
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Runs a binutils tool (`readelf`, `nm`) on `file`; its standard output.
pub fn binutils(tool: &str, args: &[&str], file: &Path) -> String {
    let out = Command::new(tool)
        .args(args)
        .arg(file)
        .output()
        .unwrap_or_else(|e| panic!("run {tool} (binutils) on {}: {e}", file.display()));
    assert!(
        out.status.success(),
        "{tool} {args:?} {}: {}",
        file.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The SONAME an ELF shared library carries (`readelf -d`), if any.
pub fn soname(lib: &Path) -> Option<String> {
    binutils("readelf", &["-d"], lib).lines().find_map(|line| {
        let rest = line.split_once("Library soname: [")?.1;
        Some(rest.trim_end().trim_end_matches(']').to_string())
    })
}

/// The libraries an ELF file needs (`NEEDED` in `readelf -d`).
pub fn needed(file: &Path) -> Vec<String> {
    binutils("readelf", &["-d"], file)
        .lines()
        .filter_map(|line| {
            let rest = line.split_once("Shared library: [")?.1;
            Some(rest.trim_end().trim_end_matches(']').to_string())
        })
        .collect()
}

/// Every symbol a shared library defines for other objects (`nm -D --defined-only`), of any kind.
pub fn exports(lib: &Path) -> Vec<String> {
    binutils("nm", &["-D", "--defined-only"], lib)
        .lines()
        .filter_map(|line| line.split_whitespace().nth(2).map(str::to_string))
        .collect()
}

/// Whether an exported name is vlib's: the commands and extensions (`vl…`), vlaux (`vlu…`,
/// `VL_…`, `VLU_…`).
pub fn is_vlib_name(name: &str) -> bool {
    name.starts_with("vl") || name.starts_with("VL")
}
