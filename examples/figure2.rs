//! The paper's Figure 2 written against the safe Rust API: the same scene as
//! `examples/c/figure2.c`, with closures as field functions and no `unsafe`. It writes the same
//! image as the C program, byte for byte (`capi/tests/golden.rs` checks it), where the C
//! compiler rounds each operation as Rust does: on x86-64, and elsewhere with
//! `-ffp-contract=off` (a fused multiply-add rounds once where Rust rounds twice).
//!
//! ```text
//! cargo run --release --example figure2 -- out/stone-rust.png
//! ```

#[path = "common/figure2_scene.rs"]
mod figure2_scene;
#[path = "common/say.rs"]
mod say;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "stone-rust.png".into());
    let mut vl = vlib::Library::new();
    figure2_scene::build(&mut vl, &out, 100)?;
    vl.end()?; // scene: renders and writes the image
    say::say(format_args!("wrote {out}"))?;
    Ok(())
}
