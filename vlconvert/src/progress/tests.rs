//! What a progress line says for a given state.

use super::{line, Unit};
use std::time::Duration;

/// The bar between `[` and `]`: (filled, empty) cells.
fn cells(text: &str) -> (usize, usize) {
    let bar = &text[text.find('[').unwrap() + 1..text.find(']').unwrap()];
    (bar.matches('#').count(), bar.matches('-').count())
}

#[test]
fn half_way_through_a_file() {
    let t = line(
        "ct.nii.gz",
        512 * 1024,
        1024 * 1024,
        Unit::Bytes,
        Duration::from_secs(2),
        80,
    );
    assert!(t.starts_with("ct.nii.gz ["), "{t}");
    // 512 KiB of 1 MiB in 2 s: 50 %, 256 KiB a second.
    assert!(
        t.ends_with("]  50%  512.0 KiB/1.0 MiB  2.0 s  256.0 KiB/s"),
        "{t}"
    );
    let (full, empty) = cells(&t);
    assert_eq!(full, (full + empty) / 2, "half filled (rounded down): {t}");
    assert!(t.chars().count() <= 79, "{t}");
}

#[test]
fn slices_and_voxels_count_in_their_units() {
    let t = line("stack", 3, 12, Unit::Slices, Duration::from_secs(2), 80);
    assert!(
        t.ends_with("]  25%  3/12 slices  2.0 s  1.5 slices/s"),
        "{t}"
    );
    let (full, empty) = cells(&t);
    assert_eq!(
        full,
        (full + empty) / 4,
        "a quarter filled (rounded down): {t}"
    );
    let t = line(
        "converting",
        2_500_000,
        10_000_000,
        Unit::Voxels,
        Duration::from_millis(500),
        80,
    );
    assert!(
        t.ends_with("]  25%  2.5 M/10.0 M voxels  0.5 s  5.0 M voxels/s"),
        "{t}"
    );
}

/// Nothing to do is done (no division by a total of 0), more than the total is the total,
/// and no rate is given before a millisecond has passed (no division by 0 time).
#[test]
fn edge_states_divide_by_nothing() {
    let t = line("x", 0, 0, Unit::Bytes, Duration::ZERO, 80);
    assert!(t.ends_with("] 100%  0 B/0 B  0.0 s"), "{t}");
    assert_eq!(cells(&t).1, 0, "{t}");
    let t = line("x", 700, 500, Unit::Bytes, Duration::from_secs(1), 80);
    assert!(t.contains("100%  500 B/500 B"), "{t}");
    assert!(!t.contains("NaN") && !t.contains("inf"), "{t}");
}

/// A long name is shortened with … so the line fits; a narrow terminal gets the line's start.
#[test]
fn the_line_fits_the_terminal() {
    let long = "a-very-long-file-name-from-a-scanner-export-0001.tif";
    let t = line(long, 1, 2, Unit::Slices, Duration::from_secs(1), 80);
    assert!(t.chars().count() <= 79, "{t}");
    assert!(t.contains('…') && t.starts_with("a-very-long"), "{t}");
    assert!(t.ends_with("50%  1/2 slices  1.0 s  1.0 slices/s"), "{t}");
    let t = line(long, 1, 2, Unit::Slices, Duration::from_secs(1), 20);
    assert_eq!(t.chars().count(), 19, "{t}");
}

#[test]
fn a_fast_rate_gives_way_to_the_whole_label() {
    // 1 M voxels in 4.8 ms: "218.2 M voxels/s" would leave "finding the range" 16 columns.
    let l = line(
        "finding the range",
        1 << 20,
        1 << 20,
        Unit::Voxels,
        Duration::from_micros(4800),
        80,
    );
    assert!(l.starts_with("finding the range ["), "{l}");
    assert!(!l.contains("voxels/s"), "{l}");
    // With room to spare the rate stays.
    let wide = line(
        "finding the range",
        1 << 20,
        1 << 20,
        Unit::Voxels,
        Duration::from_micros(4800),
        120,
    );
    assert!(wide.contains("voxels/s"), "{wide}");
}
