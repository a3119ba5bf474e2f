//! Gives `libvlib.so` its SONAME, `libvlib.so.<major>` (the package's major version), on the ELF
//! platforms whose linkers take `-soname`, so that every build of the shared library (plain
//! `cargo build`, `cargo xtask install`, `cargo cinstall`) carries the name programs record
//! and the loader looks for. cargo-c passes the same name (`version_suffix_components = 1` in
//! `Cargo.toml`). Other platforms get no flag. The static library is not linked, so unaffected.
//! (`vlib` is the `[lib]` name in `Cargo.toml`.)

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    let elf_with_soname = [
        "linux",
        "freebsd",
        "dragonfly",
        "netbsd",
        "openbsd",
        "illumos",
        "solaris",
        "hurd",
        "haiku",
    ];
    if elf_with_soname.contains(&os.as_str()) {
        let major = std::env::var("CARGO_PKG_VERSION_MAJOR").expect("cargo sets the version");
        println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libvlib.so.{major}");
    }
}
