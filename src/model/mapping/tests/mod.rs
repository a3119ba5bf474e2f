//! Unit tests of `mapping`.

mod paper;

use super::*;
use crate::num::clamp_field;

fn lookup(table: &[f32], points: i32, outputs: i32) -> Mapping {
    Mapping::new(MappingType::Lookup, points, outputs, table).unwrap()
}

/// `clamp_and_bucket` is `clamp_field` and the plain ⌊x·BUCKETS⌋ of its result x, bit for
/// bit: for every input of [0, 1] within 64 ulps of a bucket edge, every 61st one between,
/// and for NaNs, ±0, ±∞, negative inputs, inputs past 1 and random bit patterns.
/// `bucket_in_range` is `clamp_and_bucket`'s bucket for inputs of [0, 1] (−0 included):
/// every one within 64 ulps of a bucket edge, and every 97th between.
#[test]
fn bucket_in_range_is_the_clamped_bucket() {
    let check = |x: f32| {
        assert_eq!(
            Mapping::bucket_in_range(x),
            Mapping::clamp_and_bucket(x).1,
            "{x:e}"
        );
    };
    check(-0.0);
    for b in 0..=BUCKETS {
        let edge = (b as f32 / BUCKETS as f32).to_bits();
        for bits in edge.saturating_sub(64)..=(edge + 64).min(1.0f32.to_bits()) {
            check(f32::from_bits(bits));
        }
    }
    for bits in (0..=1.0f32.to_bits()).step_by(97) {
        check(f32::from_bits(bits));
    }
}

#[test]
fn clamp_and_bucket_is_clamp_then_bucket() {
    let check = |v: f32| {
        let (x, b) = Mapping::clamp_and_bucket(v);
        let want = clamp_field(v);
        assert_eq!(x.to_bits(), want.to_bits(), "input {v:e}");
        assert_eq!(b, (want * BUCKETS as f32) as usize, "input {v:e}");
    };
    for b in 0..=BUCKETS {
        let edge = (b as f32 / BUCKETS as f32).to_bits();
        for bits in edge.saturating_sub(64)..=(edge + 64).min(1.0f32.to_bits()) {
            check(f32::from_bits(bits));
        }
    }
    for bits in (0..=1.0f32.to_bits()).step_by(61) {
        check(f32::from_bits(bits));
    }
    let specials = [
        f32::NAN,
        -f32::NAN,
        0.0,
        -0.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
    ];
    for v in specials
        .into_iter()
        .chain([-1e-30, -0.5, 1.0 + f32::EPSILON, 2.0, 1e6])
    {
        check(v);
    }
    let mut x = 0x2545_f491u32;
    for _ in 0..100_000 {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        check(f32::from_bits(x));
    }
}

/// The bucket table gives `locate` the count of breakpoints below the input, as counting
/// them does: for breakpoints at 0 and 1, on bucket edges, a breakpoint in every bucket,
/// many in one bucket and more than a u16 can count; inputs at and one ulp around every
/// bucket edge and breakpoint, and spread between.
#[test]
fn buckets_locate_as_counting_does() {
    let edge = |b: usize| b as f32 / BUCKETS as f32;
    let mut tables: Vec<Vec<f32>> = vec![
        vec![0.0],
        vec![1.0],
        vec![0.0, 1.0],
        vec![0.1, 0.3, 0.35, 0.7],
        vec![edge(3), edge(4), edge(1000), 1.0],
        (0..=BUCKETS).map(edge).collect(),
        (0..200).map(|i| 0.5 + i as f32 * 1e-6).collect(),
        (0..70_000).map(|i| i as f32 / 70_000.0).collect(),
    ];
    let mut x = 0x2545_f491u32;
    tables.push({
        let mut v: Vec<f32> = (0..40)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                (x >> 8) as f32 / (1 << 24) as f32
            })
            .collect();
        v.sort_by(f32::total_cmp);
        v.dedup();
        v
    });
    let mut checked = 0;
    for a in tables {
        let rows: Vec<f32> = a.iter().flat_map(|&x| [x, 0.5]).collect();
        let m = Mapping::new(MappingType::Ramp, a.len() as i32, 1, &rows).unwrap();
        let mut inputs: Vec<f32> = (0..=BUCKETS).map(edge).chain(a.iter().copied()).collect();
        for v in inputs.clone() {
            inputs.extend([v.next_down(), v.next_up()]);
        }
        inputs.extend((0..=10_000).map(|i| i as f32 / 10_000.0));
        inputs.extend([-1.0, 2.0, f32::NAN, -0.0, f32::INFINITY]);
        for v in inputs {
            let clamped = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
            let want = a.partition_point(|&x| x < clamped);
            assert_eq!(
                m.locate(v),
                (clamped, want),
                "input {v}, {} points",
                a.len()
            );
            checked += 1;
        }
    }
    assert!(checked > 100_000, "{checked}");
}

#[test]
fn rejects_bad_tables() {
    let bad = |p, o, t: &[f32]| Mapping::new(MappingType::Ramp, p, o, t).unwrap_err().code;
    assert_eq!(bad(0, 1, &[]), ErrorCode::BadValue);
    assert_eq!(bad(1, 0, &[0.5]), ErrorCode::BadValue);
    assert_eq!(bad(2, 1, &[0.1, 0.2, 0.3]), ErrorCode::BadValue);
    assert_eq!(bad(2, 1, &[0.5, 0.2, 0.5, 0.3]), ErrorCode::BadValue);
    assert_eq!(bad(2, 1, &[0.6, 0.2, 0.5, 0.3]), ErrorCode::BadValue);
    assert_eq!(bad(1, 1, &[f32::NAN, 0.2]), ErrorCode::BadValue);
    assert_eq!(bad(1, 1, &[0.5, 1.5]), ErrorCode::BadValue);
}

#[test]
fn figure2_table() {
    // {0.001, 1.0, 1.0, 0.3}: 2 points, 1 output.
    let m = lookup(&[0.001, 1.0, 1.0, 0.3], 2, 1);
    assert_eq!(m.eval(0.0, 0), 0.0);
    assert_eq!(m.eval(0.001, 0), 0.0);
    assert_eq!(m.eval(0.0011, 0), 0.3);
    assert_eq!(m.eval(1.0, 0), 0.3);
    assert_eq!(m.outputs(), 1);
}

/// Inside its rows a ramp is the segment's line, computed in f64 (an independent
/// evaluation from the table itself), and `ramp_segment` offers exactly those inputs, with
/// the numbers the kernel's fast path combines into the same value.
#[test]
fn ramp_segments_are_the_lines_between_rows() {
    let table = [
        0.1, 0.0, 1.0, 0.5, //
        0.4, 0.8, 0.2, 0.5, //
        0.5, 0.3, 0.9, 0.1, //
        0.9, 1.0, 0.0, 0.7,
    ];
    let m = Mapping::new(MappingType::Ramp, 4, 3, &table).unwrap();
    let row = |i: usize| &table[4 * i..4 * i + 4];
    for s in 0..=1000 {
        let v = s as f32 / 1000.0;
        let (v, k) = m.locate(v);
        let seg = m.ramp_segment(v, k);
        assert_eq!(seg.is_some(), k > 0 && k < 4 && v > 0.0, "v = {v}");
        let Some(seg) = seg else { continue };
        let (r0, r1) = (row(k - 1), row(k));
        for j in 0..3 {
            let t = (v as f64 - r0[0] as f64) / (r1[0] as f64 - r0[0] as f64);
            let line = r0[j + 1] as f64 + t * (r1[j + 1] as f64 - r0[j + 1] as f64);
            let y = m.eval(v, j);
            // The f64 line and the table's slope form differ by a few f64 ulps before the
            // f32 rounding: at most one f32 ulp apart.
            assert!(
                (y as f64 - line).abs() <= 1.2e-7,
                "v = {v}, j = {j}: {y} vs {line}"
            );
            let fast = segment_value(seg, v as f64 - seg[0], j);
            assert_eq!(fast.to_bits(), y.to_bits(), "v = {v}, j = {j}");
        }
    }
    let lookup = lookup(&[0.2, 0.5, 0.6, 0.9], 2, 1);
    assert!(lookup.ramp_segment(0.5, 1).is_none());
}

#[test]
fn range_bounds_every_value_in_the_interval() {
    let tables: [(MappingType, i32, &[f32]); 3] = [
        (MappingType::Lookup, 3, &[0.2, 0.5, 0.4, 0.9, 0.7, 0.1]),
        (MappingType::Ramp, 3, &[0.2, 0.5, 0.4, 0.0, 0.7, 0.9]),
        (MappingType::Ramp, 2, &[0.0, 0.3, 1.0, 0.6]),
    ];
    for (kind, n, t) in tables {
        let m = Mapping::new(kind, n, 1, t).unwrap();
        for i in 0..=40 {
            for k in i..=40 {
                let (lo, hi) = (i as f32 / 40.0, k as f32 / 40.0);
                let (rmin, rmax) = m.range(lo, hi, 0);
                let mut seen = (f32::INFINITY, f32::NEG_INFINITY);
                for s in 0..=400 {
                    let v = (lo + (hi - lo) * s as f32 / 400.0).min(hi);
                    let y = m.eval(v, 0);
                    assert!(
                        y >= rmin - 1e-6 && y <= rmax + 1e-6,
                        "{kind:?} [{lo},{hi}] v={v}: {y} outside [{rmin},{rmax}]"
                    );
                    seen = (seen.0.min(y), seen.1.max(y));
                }
                // And the bound is tight where the scan visits the extremes.
                assert!(
                    rmax - seen.1 < 0.05 + 1e-6 || kind == MappingType::Lookup,
                    "{kind:?} [{lo},{hi}] loose: {rmax} vs {}",
                    seen.1
                );
            }
        }
    }
}

/// A linear congruential generator from `seed`: 32 bits a call.
fn lcg(mut state: u64) -> impl FnMut() -> u32 {
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as u32
    }
}

/// `zero_below`'s one pass finds what its definition asks: the last of 0, a_1, …, a_n (in
/// order, stopping at the first that fails) over which `range(0, c, j)` has a largest value of
/// at most 0, for lookup tables and ramps of 1 to 40 rows and three outputs, whose first rows
/// are zero in some outputs and not others, with and without a first row at input 0, and
/// whose z is 0 or lies further.
#[test]
fn zero_below_is_the_last_breakpoint_range_proves_transparent() {
    let by_definition = |m: &Mapping, j: usize| {
        let mut z = None;
        for c in std::iter::once(0.0).chain(m.breakpoints().iter().copied()) {
            if m.range(0.0, c, j).1 > 0.0 {
                break;
            }
            z = Some(c);
        }
        z
    };
    let mut next = lcg(0x2545_f491_4f6c_dd1d);
    // (Φ(0) is 0 for both kinds, so z is at least 0: count how far the cases reach.)
    let (mut past_zero, mut at_zero_only) = (0, 0);
    for case in 0..3000 {
        let n = 1 + next() as usize % 40;
        let zeros = next() as usize % (n + 2);
        let at_zero = next().is_multiple_of(3);
        let mut table = Vec::new();
        for i in 0..n {
            // Strictly increasing inputs in [0, 1], the first at 0 in a third of the cases.
            let a = if at_zero {
                i as f32 / n as f32
            } else {
                (i + 1) as f32 / (n + 1) as f32
            };
            table.push(a);
            for j in 0..3 {
                let zero = i < zeros + j;
                table.push(if zero { 0.0 } else { (next() % 5) as f32 / 4.0 });
            }
        }
        for kind in [MappingType::Lookup, MappingType::Ramp] {
            let m = Mapping::new(kind, n as i32, 3, &table).unwrap();
            for j in 0..3 {
                let z = m.zero_below(j);
                assert_eq!(z, by_definition(&m, j), "case {case} {kind:?} n={n} j={j}");
                if z.is_some_and(|z| z > 0.0) {
                    past_zero += 1
                } else {
                    at_zero_only += 1
                }
            }
        }
    }
    assert!(
        past_zero > 400 && at_zero_only > 400,
        "{past_zero} past 0, {at_zero_only} at 0 only"
    );
}

/// `range` by bisection (and by blocks of rows, in tables of more than 256) gives what a scan
/// of every row gives (the definition: Φ at both ends, for Φ_r Φ at every breakpoint strictly
/// inside, for Φ_t the 0 outside (a_1, a_n] where the interval reaches it and the output of
/// every step it meets), for random tables of 1 to 40 rows and intervals with ends on
/// breakpoints, between them and outside [0, 1], and for tables of 257 to 1000 rows and
/// random intervals, some wider than many blocks, ends on breakpoints or not.
#[test]
fn range_by_bisection_is_the_scan_of_every_row() {
    let scan = |m: &Mapping, lo: f32, hi: f32, j: usize| {
        let clamp = |v: f32| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        let (lo, hi) = (clamp(lo), clamp(hi.max(lo)));
        let (a, n) = (m.breakpoints(), m.breakpoints().len());
        let mut values = vec![m.eval(lo, j), m.eval(hi, j)];
        match m.kind {
            MappingType::Lookup => {
                if lo <= a[0] || hi > a[n - 1] {
                    values.push(0.0);
                }
                for i in 0..n - 1 {
                    if hi > a[i] && lo <= a[i + 1] {
                        values.push(m.b(i + 1, j));
                    }
                }
            }
            MappingType::Ramp => values.extend(
                a.iter()
                    .filter(|&&x| x > lo && x < hi)
                    .map(|&x| m.eval(x, j)),
            ),
        }
        let min = values.iter().copied().fold(f32::INFINITY, f32::min);
        let max = values.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        (min, max)
    };
    let mut next = lcg(0x9e37_79b9_7f4a_7c15);
    for case in 0..500 {
        let n = 1 + next() as usize % 40;
        let mut table = Vec::new();
        for i in 0..n {
            table.push((i + (case % 2)) as f32 / (n + 1) as f32);
            table.extend((0..2).map(|_| (next() % 5) as f32 / 4.0));
        }
        let ends: Vec<f32> = (0..=2 * n + 2)
            .map(|k| k as f32 / (2 * n + 2) as f32)
            .chain([-0.5, 1.5, f32::NAN])
            .collect();
        for kind in [MappingType::Lookup, MappingType::Ramp] {
            let m = Mapping::new(kind, n as i32, 2, &table).unwrap();
            for &lo in &ends {
                for &hi in &ends {
                    for j in 0..2 {
                        assert_eq!(
                            m.range(lo, hi, j),
                            scan(&m, lo, hi, j),
                            "case {case} {kind:?} n={n} [{lo}, {hi}] j={j}"
                        );
                    }
                }
            }
        }
    }
    for case in 0..20 {
        let n = 257 + next() as usize % 744;
        let mut table = Vec::new();
        for i in 0..n {
            table.push((i + 1) as f32 / (n + 1) as f32);
            // Mostly 0 (blocks of zeros, as a transfer function's clear stretch has), else
            // one of five levels.
            let level = |x: u32| {
                if x.is_multiple_of(3) {
                    (x % 5) as f32 / 4.0
                } else {
                    0.0
                }
            };
            table.extend((0..2).map(|_| level(next())));
        }
        let a: Vec<f32> = table.iter().step_by(3).copied().collect();
        let end = |x: u32| match x % 3 {
            0 => a[x as usize / 3 % n],
            1 => (x % 10007) as f32 / 10006.0,
            _ => a[x as usize / 3 % n] + 0.3 / (n + 1) as f32,
        };
        for kind in [MappingType::Lookup, MappingType::Ramp] {
            let m = Mapping::new(kind, n as i32, 2, &table).unwrap();
            assert!(!m.blocks.is_empty());
            for _ in 0..3000 {
                let (x, y) = (end(next()), end(next()));
                let (lo, hi) = (x.min(y), x.max(y));
                for j in 0..2 {
                    assert_eq!(
                        m.range(lo, hi, j),
                        scan(&m, lo, hi, j),
                        "case {case} {kind:?} n={n} [{lo}, {hi}] j={j}"
                    );
                }
            }
        }
    }
}
