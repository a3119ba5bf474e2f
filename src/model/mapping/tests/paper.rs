//! Φ_t and Φ_r against the paper's formulas (§4.4), written out independently here case by case
//! with a linear scan, at thousands of points per table, including every edge case: values at
//! and between the a_i, v = 0 and v = 1, a_1 = 0, a_n = 1, single-row tables, several outputs.

use crate::model::mapping::Mapping;
use crate::testing::Lcg;
use crate::MappingType;

/// Φ_t of the paper: 0 if v ≤ a_1 or v > a_n; b_{i+1,j} if a_i < v ≤ a_{i+1}.
fn phi_t(a: &[f64], b: &[Vec<f64>], v: f64, j: usize) -> f64 {
    let n = a.len();
    if v <= a[0] || v > a[n - 1] {
        return 0.0;
    }
    for i in 0..n - 1 {
        if a[i] < v && v <= a[i + 1] {
            return b[i + 1][j];
        }
    }
    unreachable!()
}

/// Φ_r of the paper, with the implicit end segments: (0,0)→(a_1,b_1) on 0 < v ≤ a_1, and
/// (a_n,b_n)→(1,1) on a_n < v < 1, whose end point Φ_r(1) = 1 we include; Φ_r(0) = 0.
fn phi_r(a: &[f64], b: &[Vec<f64>], v: f64, j: usize) -> f64 {
    let n = a.len();
    if 0.0 < v && v <= a[0] {
        return v * b[0][j] / a[0];
    }
    for i in 0..n - 1 {
        if a[i] < v && v <= a[i + 1] {
            return b[i][j] + (v - a[i]) * (b[i + 1][j] - b[i][j]) / (a[i + 1] - a[i]);
        }
    }
    if a[n - 1] < v && v < 1.0 {
        return b[n - 1][j] + (v - a[n - 1]) * (1.0 - b[n - 1][j]) / (1.0 - a[n - 1]);
    }
    if v >= 1.0 && a[n - 1] < 1.0 {
        return 1.0;
    }
    0.0
}

/// A table of n rows with k outputs; a strictly increasing in [0, 1], optionally pinned to 0/1.
fn table(
    rng: &mut Lcg,
    n: usize,
    k: usize,
    first_zero: bool,
    last_one: bool,
) -> (Vec<f32>, Vec<f64>, Vec<Vec<f64>>) {
    let mut a: Vec<f32> = (0..n).map(|_| rng.next() as f32).collect();
    a.sort_by(|x, y| x.partial_cmp(y).unwrap());
    a.dedup();
    while a.len() < n {
        // Rare duplicates: spread again deterministically.
        a = (0..n).map(|i| (i as f32 + 0.5) / n as f32).collect();
    }
    if first_zero {
        a[0] = 0.0;
    }
    if last_one {
        a[n - 1] = 1.0;
    }
    let mut raw = Vec::new();
    let mut bs = Vec::new();
    for &ai in &a {
        raw.push(ai);
        let row: Vec<f32> = (0..k).map(|_| rng.next() as f32).collect();
        raw.extend_from_slice(&row);
        bs.push(row.iter().map(|&x| x as f64).collect());
    }
    (raw, a.iter().map(|&x| x as f64).collect(), bs)
}

/// The probe values: the a_i themselves, their f32 neighbours, 0, 1, and random points.
fn probes(rng: &mut Lcg, a: &[f64]) -> Vec<f32> {
    let mut v: Vec<f32> = vec![0.0, 1.0, f32::MIN_POSITIVE, 1.0 - f32::EPSILON / 2.0];
    for &ai in a {
        let x = ai as f32;
        v.extend([
            x,
            f32::from_bits(x.to_bits().saturating_add(1)).min(1.0),
            if x > 0.0 {
                f32::from_bits(x.to_bits() - 1)
            } else {
                0.0
            },
        ]);
    }
    v.extend((0..1000).map(|_| rng.next() as f32));
    v
}

#[test]
fn lookup_and_ramp_match_the_formulas() {
    let mut rng = Lcg(0x5eed);
    let mut checked = 0usize;
    for n in [1usize, 2, 3, 5, 17] {
        for k in [1usize, 3] {
            for (first_zero, last_one) in
                [(false, false), (true, false), (false, true), (true, true)]
            {
                if n == 1 && first_zero && last_one {
                    continue; // a single point cannot be both 0 and 1
                }
                let (raw, a, b) = table(&mut rng, n, k, first_zero, last_one);
                let lookup = Mapping::new(MappingType::Lookup, n as i32, k as i32, &raw).unwrap();
                let ramp = Mapping::new(MappingType::Ramp, n as i32, k as i32, &raw).unwrap();
                for v in probes(&mut rng, &a) {
                    for j in 0..k {
                        let (et, er) = (phi_t(&a, &b, v as f64, j), phi_r(&a, &b, v as f64, j));
                        let (gt, gr) = (lookup.eval(v, j) as f64, ramp.eval(v, j) as f64);
                        assert_eq!(gt, et, "Φ_t n={n} k={k} a={a:?} v={v} j={j}");
                        // f32 output of an f64 formula: half an ulp of a value in [0, 1].
                        assert!(
                            (gr - er).abs() <= 1e-7,
                            "Φ_r n={n} a={a:?} v={v} j={j}: {gr} vs {er}"
                        );
                        checked += 1;
                    }
                }
            }
        }
    }
    assert!(checked > 1000 * 30);
}

#[test]
fn empty_cases_at_the_ends() {
    // a_1 = 0: the first ramp segment (0 < v ≤ a_1) is empty; Φ_r(0) = 0, and just above 0
    // the ramp follows the segment from (0, b_1) to (a_2, b_2).
    let m = Mapping::new(MappingType::Ramp, 2, 1, &[0.0, 0.4, 0.5, 0.8]).unwrap();
    assert_eq!(m.eval(0.0, 0), 0.0);
    assert!((m.eval(0.25, 0) - 0.6).abs() < 1e-7);
    // a_n = 1: the last segment (a_n < v < 1) is empty; Φ_r(1) = b_n.
    let m = Mapping::new(MappingType::Ramp, 2, 1, &[0.5, 0.2, 1.0, 0.7]).unwrap();
    assert!((m.eval(1.0, 0) - 0.7).abs() < 1e-7);
    assert!(
        (m.eval(0.25, 0) - 0.1).abs() < 1e-7,
        "first implicit segment from (0, 0)"
    );
    // a_n < 1: the implicit segment rises to (1, 1).
    let m = Mapping::new(MappingType::Ramp, 1, 1, &[0.5, 0.2]).unwrap();
    assert!((m.eval(0.75, 0) - 0.6).abs() < 1e-7);
    assert_eq!(m.eval(1.0, 0), 1.0);
    // Φ_t at a_1 = 0: v = 0 is ≤ a_1, so 0; and v > a_n is 0.
    let t = Mapping::new(MappingType::Lookup, 2, 1, &[0.0, 0.9, 0.5, 0.3]).unwrap();
    assert_eq!(t.eval(0.0, 0), 0.0);
    assert_eq!(t.eval(0.5, 0), 0.3);
    assert_eq!(t.eval(0.50001, 0), 0.0);
    // Values outside [0, 1] and NaN are clamped as field values: NaN → 0.
    assert_eq!(t.eval(f32::NAN, 0), 0.0);
    assert_eq!(m.eval(7.0, 0), 1.0);
}
