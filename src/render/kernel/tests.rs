//! Unit tests of `kernel`.

use super::*;
use crate::data::Voxels;
use crate::model::program::{run, Sample};
use crate::testing::Xorshift;
use crate::types::MappingType;

fn ramp(table: &[f32], outputs: i32) -> Arc<Mapping> {
    let n = table.len() as i32 / (outputs + 1);
    Arc::new(Mapping::new(MappingType::Ramp, n, outputs, table).unwrap())
}

/// A small dataset with a spread of values.
fn data() -> Arc<Dataset> {
    let v: Vec<u8> = (0..4 * 5 * 6).map(|i| ((i * 37) % 256) as u8).collect();
    Arc::new(Dataset::new([4, 5, 6], Voxels::U8(v), 0.0, 255.0).unwrap())
}

fn programs() -> Vec<Vec<Instr>> {
    let d = data();
    let o = ramp(&[0.2, 0.0, 0.5, 0.4, 0.9, 0.8], 1);
    let c = ramp(&[0.1, 0.3, 0.2, 0.1, 0.6, 0.9, 0.5, 0.4], 3);
    let lookup = Arc::new(Mapping::new(MappingType::Lookup, 2, 1, &[0.3, 1.0, 0.7, 0.6]).unwrap());
    let ds = |fields| Instr::Dataset {
        fields,
        data: d.clone(),
        filter: Filter::Trilinear,
        gradient: crate::data::GradientFilter::Nodes,
    };
    let map = |targets, source, mapping: &Arc<Mapping>, output| Instr::Map {
        targets,
        source,
        mapping: mapping.clone(),
        output,
    };
    let set = |fields, value| Instr::Set { fields, value };
    vec![
        // The scanned-volume program: F from data, o and colour through tables.
        vec![
            ds(Fields::F),
            map(Fields::O, 9, &o, 0),
            map(Fields::R, 9, &c, 0),
            map(Fields::G, 9, &c, 1),
            map(Fields::B, 9, &c, 2),
            set(Fields::KA, 0.2),
        ],
        // Colour fused with opacity in one group, o in the middle of it.
        vec![
            ds(Fields::F),
            map(Fields::R, 9, &c, 0),
            map(Fields::O, 9, &c, 1),
            map(Fields::B, 9, &c, 2),
        ],
        // A map that overwrites its own source ends the group.
        vec![
            ds(Fields::F | Fields::KD),
            map(Fields::F, 9, &c, 0),
            map(Fields::O, 9, &c, 1),
            map(Fields::R | Fields::G, 5, &lookup, 0),
        ],
        // Opacity from a lookup table, with a constant overwritten later.
        vec![
            set(Fields::ALL, 0.5),
            ds(Fields::F),
            map(Fields::O, 9, &lookup, 0),
            set(Fields::R, 0.25),
        ],
        // Opacity constant: no zero test.
        vec![set(Fields::O, 0.4), ds(Fields::R)],
        // Constants set twice (the unshaded scanned volume: ka 0.2, then ka 1), one of them
        // early and for several fields.
        vec![
            set(Fields::KA | Fields::KD, 0.7),
            ds(Fields::F),
            map(Fields::O, 9, &o, 0),
            map(Fields::R, 9, &c, 0),
            set(Fields::KA, 0.2),
            set(Fields::KS, 0.5),
            set(Fields::KA, 1.0),
        ],
        // Nothing writes opacity.
        vec![ds(Fields::F)],
        // The scanned volume without a colour table (direct form, opacity alone).
        vec![ds(Fields::F), map(Fields::O, 9, &o, 0), set(Fields::R, 0.5)],
        // A map that overwrites its own source in the middle of a group (after opacity, whose
        // map the zero test splits off): the maps after it read the new value.
        vec![
            ds(Fields::F),
            map(Fields::O, 9, &o, 0),
            map(Fields::R, 9, &c, 0),
            map(Fields::F, 9, &c, 1),
            map(Fields::G, 9, &c, 2),
            map(Fields::B, 9, &c, 0),
        ],
    ]
}

#[test]
fn lean_matches_the_interpreter_bit_for_bit() {
    for (n, prog) in programs().into_iter().enumerate() {
        let o_prefix = crate::model::program::prefix_for(&prog, Fields::O);
        let lean = Lean::new(&prog, o_prefix).expect("lean program");
        let mut tested_zero = 0;
        for i in 0..=20 {
            for j in 0..=20 {
                for k in [0, 3, 10, 17, 20] {
                    let p = [i as f32 / 20.0, j as f32 / 20.0, k as f32 / 20.0];
                    let mut s = Sample::new(p, [0.0; 3]);
                    run(&prog, &mut s);
                    let want = s.values();
                    let mut f = [0.0; FIELD_COUNT];
                    let o = lean.opacity(p, &mut f);
                    assert_eq!(o.to_bits(), want[0].to_bits(), "program {n} at {p:?}");
                    if o > 0.0 {
                        lean.rest(p, &mut f);
                        assert_eq!(f, want, "program {n} at {p:?}");
                    } else {
                        tested_zero += 1;
                    }
                }
            }
        }
        assert!(tested_zero > 0 || n == 4, "program {n} never had o = 0");
    }
}

#[test]
fn zero_test_is_placed_on_the_opacity_map() {
    let progs = programs();
    let lean = Lean::new(&progs[0], 2).unwrap();
    // Φ_r of the opacity table is 0 on [0, 0.2].
    assert_eq!(lean.zero, Some((9, 0.2)));
    // The o column of `c` is 0.2·v/0.1 > 0 for any v > 0: only v = 0 is tested.
    let lean = Lean::new(&progs[1], 3).unwrap();
    assert_eq!(lean.zero, Some((9, 0.0)));
    // Constant opacity: no map, no test.
    let lean = Lean::new(&progs[4], 1).unwrap();
    assert_eq!(lean.zero, None);
    // Lookup: 0 up to a_1 = 0.3.
    let lean = Lean::new(&progs[3], 3).unwrap();
    assert_eq!(lean.zero, Some((9, 0.3)));
}

#[test]
fn constants_overwritten_later_are_folded() {
    let progs = programs();
    let lean = Lean::new(&progs[5], 3).unwrap();
    // ka = 1 and ks = 0.5 start the registers; the early set keeps only kd, the ka = 0.2
    // between is gone, and the rest is the colour map alone.
    assert_eq!(lean.start[4], 1.0);
    assert_eq!(lean.start[6], 0.5);
    assert_eq!(lean.start[5], 0.0);
    assert!(matches!(lean.opacity[0], Op::Set { mask, value } if mask == 1 << 5 && value == 0.7));
    assert_eq!(lean.rest.len(), 1);
    assert!(matches!(lean.rest[0], Op::Map { .. }));
}

/// The direct form is taken by the usual shape only (the interpreter comparison above then
/// checks its numbers): program 0 (o and colour tables of F) and its opacity part alone,
/// not those where o shares its table's group, a map overwrites its source, or a constant
/// precedes the dataset; nor when a colour output writes two fields at once.
#[test]
fn direct_form_applies_to_the_usual_shape_only() {
    let progs = programs();
    let direct = |prog: &[Instr]| {
        let lean = Lean::new(prog, crate::model::program::prefix_for(prog, Fields::O)).unwrap();
        lean.direct
            .map(|d| d.colour.map_or(0, |(_, outputs)| outputs.len()))
    };
    assert_eq!(direct(&progs[0]), Some(3));
    assert_eq!(direct(&progs[0][..2]), Some(0));
    for n in [1, 2, 3, 4, 5, 6] {
        assert_eq!(direct(&progs[n]), None, "program {n}");
    }
    let mut two_fields = progs[0].clone();
    two_fields[2] = Instr::Map {
        targets: Fields::R | Fields::G,
        source: 9,
        mapping: ramp(&[0.1, 0.3, 0.2, 0.1, 0.6, 0.9, 0.5, 0.4], 3),
        output: 0,
    };
    assert_eq!(direct(&two_fields), None);
}

/// Direct shading is taken where the colour table writes exactly r, g and b and nothing
/// writes ka, kd, ks or the exponent; its opacity and colour are then the registers'
/// fields 0 to 3, bit for bit, and its coefficients the constants of fields 4 to 7.
#[test]
fn direct_shading_is_the_registers() {
    let progs = programs();
    let lean = |prog: &[Instr]| {
        Lean::new(prog, crate::model::program::prefix_for(prog, Fields::O)).unwrap()
    };
    let usual = lean(&progs[0]);
    let shading = usual.direct_shading().expect("the usual program");
    assert_eq!(shading.coefficients, [0.2f32 as f64, 0.0, 0.0, 0.0]);
    let mut values: Vec<f32> = (0..=400).map(|i| i as f32 / 400.0).collect();
    values.extend([-1.0, 2.0, -0.0, f32::NAN, f32::INFINITY, 0.1, 0.2, 0.5, 0.6]);
    let mut coloured = 0;
    for v in values {
        let mut f = [0.0; FIELD_COUNT];
        let o = usual.opacity_from_value(v, [0.5; 3], &mut f);
        let (o2, rgb) = shading.opacity_colour(v);
        assert_eq!(o.to_bits(), o2.to_bits(), "{v}");
        assert_eq!(rgb.is_some(), o > 0.0, "{v}");
        if let Some(rgb) = rgb {
            usual.rest([0.5; 3], &mut f);
            assert_eq!(rgb.map(f32::to_bits), [f[1], f[2], f[3]].map(f32::to_bits));
            assert_eq!(
                shading.coefficients,
                [f[4], f[5], f[6], f[7]].map(|v| v as f64)
            );
            coloured += 1;
        }
    }
    assert!(coloured > 200, "{coloured}");
    // Of a value in [0, 1] (−0 included), without the clamp: the same bits, at and within
    // 3 ulps of every bucket edge and of the tables' breakpoints, and at random values.
    let rng = Xorshift::new(0x0c1a_4b5e);
    let mut inputs = vec![-0.0f32, 0.0, 1.0, 1.0f32.next_down()];
    for edge in (0..=Mapping::BUCKET_COUNT)
        .map(|b| b as f32 / 1024.0)
        .chain([0.1, 0.2, 0.3, 0.5, 0.6, 0.7, 0.9])
    {
        let mut x = edge;
        for _ in 0..3 {
            x = x.next_down();
        }
        for _ in 0..7 {
            inputs.push(x);
            x = x.next_up();
        }
    }
    inputs.extend((0..10_000).map(|_| rng.next() as f32));
    inputs.extend((0..200).map(|_| f32::from_bits(rng.bits() as u32 % 0x3f80_0001)));
    for x in inputs.into_iter().filter(|x| (0.0..=1.0).contains(x)) {
        let (o, rgb) = shading.opacity_colour(x);
        // In range; and by the general evaluation alone, whatever the bucket.
        for (o2, rgb2) in [
            shading.opacity_colour_in_range(x),
            shading.opacity_colour_general(x),
        ] {
            assert_eq!(o.to_bits(), o2.to_bits(), "{x:e}");
            assert_eq!(
                rgb.map(|c| c.map(f32::to_bits)),
                rgb2.map(|c| c.map(f32::to_bits))
            );
        }
    }
    // Not taken: no colour table; ka, kd, ks or the exponent written by the dataset or
    // the colour table; a colour field missing or written twice; the general shapes.
    let c = ramp(&[0.1, 0.3, 0.2, 0.1, 0.6, 0.9, 0.5, 0.4], 3);
    let map = |targets, output| Instr::Map {
        targets,
        source: 9,
        mapping: c.clone(),
        output,
    };
    let mut data_kd = progs[0].clone();
    let Instr::Dataset { fields, .. } = &mut data_kd[0] else {
        unreachable!()
    };
    *fields = Fields::F | Fields::KD;
    let mut colour_kd = progs[0].clone();
    colour_kd[4] = map(Fields::KD, 2);
    let mut no_blue = progs[0].clone();
    no_blue.remove(4);
    let mut red_twice = progs[0].clone();
    red_twice[3] = map(Fields::R, 1);
    for (name, prog) in [
        ("opacity alone", progs[0][..2].to_vec()),
        ("data writes kd", data_kd),
        ("colour writes kd", colour_kd),
        ("no blue", no_blue),
        ("red twice", red_twice),
    ] {
        assert!(lean(&prog).direct_shading().is_none(), "{name}");
    }
    for (n, prog) in progs.iter().enumerate().skip(1) {
        let o_prefix = crate::model::program::prefix_for(prog, Fields::O);
        if let Some(l) = Lean::new(prog, o_prefix) {
            assert!(l.direct_shading().is_none(), "program {n}");
        }
    }
}

/// [`SegmentPair::values`] is `clamp_field((base + (x − start)·slope) as f32)` column by
/// column, bit for bit, for random segments with starts, bases and slopes of every
/// magnitude (results below 0, inside [0, 1], past 1 and past f32's range) at inputs of
/// [0, 1].
#[test]
fn segment_pair_values_are_the_scalar_ones() {
    let rng = Xorshift::new(0x2545_f491_4f6c_dd1du64);
    let next = || rng.next();
    for n in 0..20_000 {
        let scale = [1.0, 1e-3, 10.0, 1e6, 1e40][n % 5];
        let signed = |s: f64| (next() * 2.0 - 1.0) * s;
        let pair = SegmentPair {
            start: std::array::from_fn(|_| signed(1.0)),
            base: std::array::from_fn(|_| signed(1.5)),
            slope: std::array::from_fn(|_| signed(scale)),
        };
        let x = next() as f32;
        let want = std::array::from_fn(|j| {
            let v = pair.base[j] + (x as f64 - pair.start[j]) * pair.slope[j];
            clamp_field(v as f32).to_bits()
        });
        assert_eq!(pair.values(x).map(f32::to_bits), want, "{pair:?} at {x}");
    }
}

/// The segment pairs give [`Mapping::eval`]'s opacity and colour, clamped, bit for bit, at
/// 0, at every bucket edge and breakpoint and one ulp around them, for tables with
/// breakpoints inside buckets, first and last stretches, end rows at 0 and 1 (where the
/// first segment's base at 0 is not the ramp's value there), many rows, and colour
/// columns in any order; and they serve most inputs of the peer benchmark's tables.
#[test]
fn segment_pairs_are_the_tables() {
    let table = |points: &[(f32, &[f32])]| {
        let flat: Vec<f32> = points
            .iter()
            .flat_map(|&(a, b)| std::iter::once(a).chain(b.iter().copied()))
            .collect();
        let outputs = points[0].1.len() as i32;
        Mapping::new(MappingType::Ramp, points.len() as i32, outputs, &flat).unwrap()
    };
    let s = 1.0 / 255.0;
    let mni_o = table(&[
        (40.0 * s, &[0.0]),
        (80.0 * s, &[0.10]),
        (120.0 * s, &[0.35]),
        (180.0 * s, &[0.60]),
        (255.0 * s, &[0.85]),
    ]);
    let mni_c = table(&[
        (60.0 * s, &[0.55, 0.35, 0.30]),
        (110.0 * s, &[0.88, 0.66, 0.56]),
        (180.0 * s, &[0.96, 0.92, 0.86]),
        (255.0 * s, &[1.0, 1.0, 1.0]),
    ]);
    // Two opacity columns; the ends at 0 and 1; many rows (buckets with breakpoints).
    let ends = table(&[(0.0, &[0.0, 0.3]), (0.5, &[0.9, 0.1]), (1.0, &[0.2, 1.0])]);
    let from_zero = table(&[(0.0, &[0.1, 0.2, 0.3]), (1.0, &[0.9, 0.8, 0.7])]);
    let rng = Xorshift::new(0x2545_f491_4f6c_dd1du64);
    let next = || (rng.bits() >> 40) as f32 / (1u64 << 24) as f32;
    let mut rows: Vec<(f32, Vec<f32>)> = (0..900)
        .map(|i| {
            (
                i as f32 / 900.0 + next() / 1800.0,
                vec![next(), next(), next()],
            )
        })
        .collect();
    rows[0].0 = 0.001;
    let many = {
        let points: Vec<(f32, &[f32])> = rows.iter().map(|(a, b)| (*a, b.as_slice())).collect();
        table(&points)
    };
    let cases = [
        (&mni_o, 0, &mni_c, [0, 1, 2], true),
        (&mni_o, 0, &mni_c, [2, 0, 1], true),
        (&ends, 1, &mni_c, [1, 1, 0], true),
        (&ends, 1, &from_zero, [0, 1, 2], true),
        (&ends, 0, &many, [0, 1, 2], false),
        (&mni_o, 0, &many, [2, 1, 0], false),
    ];
    for (n, (o, o_col, c, rgb, mostly)) in cases.into_iter().enumerate() {
        let pairs = SegmentPairs::new(o, o_col, c, rgb);
        assert_eq!(pairs.index[0], SegmentPairs::NONE, "case {n}");
        let mut inputs: Vec<f32> = (0..Mapping::BUCKET_COUNT)
            .map(|b| b as f32 / (Mapping::BUCKET_COUNT - 1) as f32)
            .chain(o.breakpoints().iter().copied())
            .chain(c.breakpoints().iter().copied())
            .collect();
        inputs.extend(
            inputs
                .clone()
                .iter()
                .flat_map(|x| [x.next_up(), x.next_down()]),
        );
        inputs.extend((0..2000).map(|_| next()));
        inputs.retain(|x| *x >= 0.0 && *x <= 1.0);
        let mut served = 0;
        for &x in &inputs {
            let Some((po, prgb)) = pairs.eval(x, Mapping::clamp_and_bucket(x).1) else {
                continue;
            };
            served += 1;
            let want_o = clamp_field(o.eval(x, o_col));
            assert_eq!(po.to_bits(), want_o.to_bits(), "case {n} at {x}");
            assert_eq!(prgb.is_some(), want_o > 0.0, "case {n} at {x}");
            if let Some(prgb) = prgb {
                let want = rgb.map(|j| clamp_field(c.eval(x, j)).to_bits());
                assert_eq!(prgb.map(f32::to_bits), want, "case {n} at {x}");
            }
        }
        // Pairs serve the inputs from the colour table's first breakpoint (60/255 for the
        // MNI tables) to 1 except in buckets a breakpoint splits: most of 900 rows' buckets.
        let share = served as f64 / inputs.len() as f64;
        if mostly {
            assert!(share > 0.6, "case {n}: {share}");
        } else {
            assert!(served > 0 && share < 0.6, "case {n}: {share}");
        }
    }
}

#[test]
fn functions_are_not_lean() {
    let prog = vec![Instr::Function {
        fields: Fields::O,
        f: Arc::new(|_s: &mut Sample| {}),
    }];
    assert!(Lean::new(&prog, 1).is_none());
}
