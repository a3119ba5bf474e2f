//! vlconvert's readers (NIfTI, NRRD, MetaImage, DICOM, TIFF, PNG/PNM, raw) on arbitrary files:
//! the first byte picks the reader and how the files are laid out, the rest are the files
//! (`fuzz/src/readers.rs`). No panic, no allocation far beyond the input's size (the global
//! allocator refuses it), and an accepted volume's datasets are finite, their values in [0, 1].
//!
//! With `VLCONVERT_FUZZ_STATS=DIR`, each process writes its executions per layout (and how
//! many were accepted) to `DIR/<pid>` every 10 000 executions; `VLCONVERT_FUZZ_ONLY=1,2`
//! fuzzes only those layouts (indices into `readers::LAYOUTS`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::atomic::{AtomicU64, Ordering};
use vlib_fuzz::readers;

#[global_allocator]
static ALLOC: readers::Counting = readers::Counting;

/// Executions and acceptances per layout.
static RUNS: [AtomicU64; readers::LAYOUTS.len()] = [const { AtomicU64::new(0) }; 12];
static ACCEPTED: [AtomicU64; readers::LAYOUTS.len()] = [const { AtomicU64::new(0) }; 12];
static TOTAL: AtomicU64 = AtomicU64::new(0);

/// The layouts `VLCONVERT_FUZZ_ONLY` (indices into `readers::LAYOUTS`, comma-separated)
/// restricts the inputs to: the first byte then picks among them.
fn only() -> &'static [u8] {
    static ONLY: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    ONLY.get_or_init(|| {
        std::env::var("VLCONVERT_FUZZ_ONLY")
            .map(|v| v.split(',').filter_map(|k| k.trim().parse().ok()).collect())
            .unwrap_or_default()
    })
}

fuzz_target!(|data: &[u8]| {
    let mut owned;
    let data = match (only(), data.split_first()) {
        (only @ [_, ..], Some((&pick, rest))) => {
            owned = vec![only[pick as usize % only.len()]];
            owned.extend_from_slice(rest);
            &owned[..]
        }
        _ => data,
    };
    let outcome = readers::run(data, &readers::scratch("readers"));
    if let Some(&pick) = data.first() {
        let k = pick as usize % readers::LAYOUTS.len();
        RUNS[k].fetch_add(1, Ordering::Relaxed);
        if matches!(outcome, readers::Outcome::Accepted(_)) {
            ACCEPTED[k].fetch_add(1, Ordering::Relaxed);
        }
    }
    if TOTAL.fetch_add(1, Ordering::Relaxed) % 10_000 == 9_999 {
        if let Some(dir) = std::env::var_os("VLCONVERT_FUZZ_STATS") {
            let lines: String = readers::LAYOUTS
                .iter()
                .enumerate()
                .map(|(k, l)| {
                    let (r, a) = (
                        RUNS[k].load(Ordering::Relaxed),
                        ACCEPTED[k].load(Ordering::Relaxed),
                    );
                    format!("{l:?} {r} {a}\n")
                })
                .collect();
            let _ = std::fs::write(
                std::path::Path::new(&dir).join(std::process::id().to_string()),
                lines,
            );
        }
    }
});
