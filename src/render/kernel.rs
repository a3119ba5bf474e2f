//! The lean sampling kernel: an object program made only of constants, datasets and transfer
//! functions (`vlSet`, `vlDataset`, `vlMap`, the usual program of a scanned volume) compiled
//! into a flat list of operations on ten field registers.
//!
//! It computes exactly what [`crate::model::program::run`] computes, bit for bit (the same dataset
//! filters, the same [`Mapping`] arithmetic, the same clamping of written values), without the
//! generality a field function needs: no [`crate::model::program::Sample`] per point, no instruction
//! dispatch over function calls. These rewrites make it cheaper, all exact:
//!
//! - **The zero test.** When opacity is last written by a transfer function that is 0 on an
//!   interval [0, z] of its input ([`Mapping::zero_below`]), a sample whose input is at most z
//!   has opacity 0 and is skipped before the transfer function is evaluated.
//! - **Fused outputs.** Consecutive `vlMap`s of one source through one transfer function (the
//!   r, g, b columns of a colour table) locate the input's segment once and evaluate every
//!   output there ([`Mapping::locate`], [`Mapping::eval_at`]).
//! - **Direct form.** A scanned volume's usual program (a dataset, its opacity table, its
//!   colour table, constants) stores each value in its field directly ([`Direct`]).
//! - **Direct shading.** When that colour table writes exactly r, g and b and nothing writes
//!   ka, kd, ks or the specular exponent, a sample's shading inputs are its opacity and colour
//!   from the two tables and four constants known in advance ([`DirectShading`],
//!   [`DirectShading::opacity_colour`]): the batched march then uses no registers at all.
//!   Where an input's bucket lies inside one ramp segment of each table, both segments are
//!   found by one lookup ([`SegmentPairs`]) and evaluated without the tables' case analysis.
//!
//! It owns only this compiled form of a program and its evaluation at a sample; which
//! programs it applies to is decided when a scene is compiled (`compile`), and what the fields
//! mean, the general program and the transfer functions themselves are `model`'s.

use crate::data::{Dataset, Filter};
use crate::model::mapping::{segment_value, Mapping};
use crate::model::program::{clamp_field, clamp_fields, Instr};
use crate::types::{Fields, FIELD_COUNT};
use std::sync::Arc;

/// One operation on the field registers.
enum Op {
    /// Write a constant (already clamped) to the fields of a mask.
    Set { mask: u16, value: f32 },
    /// Write a dataset's interpolated value.
    Data {
        mask: u16,
        data: Arc<Dataset>,
        filter: Filter,
    },
    /// Write outputs of one transfer function of one source field: (mask, output column) each.
    Map {
        source: usize,
        mapping: Arc<Mapping>,
        outputs: Vec<(u16, usize)>,
    },
}

/// A compiled lean program (see the module documentation).
pub(crate) struct Lean {
    /// The operations up to the last one that may write opacity.
    opacity: Vec<Op>,
    /// The zero test before the last opacity operation: (source field, z).
    zero: Option<(usize, f32)>,
    /// The remaining operations.
    rest: Vec<Op>,
    /// The registers a sample starts from: 0, except the fields of the program's trailing
    /// constants (see [`Lean::new`]).
    start: [f32; FIELD_COUNT],
    /// The same program in direct form, when it has the usual shape (see [`Direct`]).
    direct: Option<Direct>,
    /// Its shading inputs, when they are that simple (see [`DirectShading`]).
    shading: Option<DirectShading>,
}

/// A value-head program ([`Lean::value_head`]) of the usual shape, in direct form: the dataset
/// writes its fields (the zero test's source among them), one transfer function of the source
/// writes o alone, and at most one more (the colour table) writes single fields from the same
/// source. Each table value is then stored in its field, without the operation loop, the
/// masks' bit loops or a second zero test: the same numbers as the operations.
struct Direct {
    source: usize,
    opacity: (Arc<Mapping>, usize),
    /// The colour table and its (field, output column) pairs, in order.
    colour: Option<(Arc<Mapping>, FieldOutputs)>,
}

/// A sample's shading inputs in a direct-form program whose colour table writes r, g and b
/// (fields 1 to 3, each once) and which leaves ka, kd, ks and the specular exponent (fields 4
/// to 7) at the constants the registers start from: the colour is then three columns of the
/// colour table at the dataset's value, and the rest is known before any sample.
#[derive(Clone, Debug)]
pub(crate) struct DirectShading {
    /// The direct form's opacity table and column (shared with [`Direct`]; held here too so
    /// that [`DirectShading::opacity_colour`] finds its tables without unwrapping the
    /// program's options per sample).
    opacity: (Arc<Mapping>, usize),
    /// The direct form's colour table.
    colour: Arc<Mapping>,
    /// The colour table's columns of r, g and b.
    rgb: [usize; 3],
    /// Fields 4 to 7 (ka, kd, ks, the specular exponent as a field value), as f64.
    pub(crate) coefficients: [f64; 4],
    /// The two tables' segments per input bucket (see [`SegmentPairs`]).
    pairs: SegmentPairs,
}

/// The opacity and colour tables of [`DirectShading`] on one scale of input buckets
/// ([`Mapping::clamp_and_bucket`]): where the inputs of a bucket lie inside one ramp segment of
/// each table (most buckets), the two segments' numbers side by side, so that a sample locates
/// its input once for both tables and evaluates them without their case analysis. The same
/// numbers and the same arithmetic as [`Mapping::eval`], so the same bits.
#[derive(Clone, Debug)]
struct SegmentPairs {
    /// Per bucket, its pair in `pairs`, or [`SegmentPairs::NONE`].
    index: Vec<u16>,
    pairs: Vec<SegmentPair>,
}

/// One bucket's segments, as lanes of the opacity, r, g and b columns (the opacity
/// segment's numbers in the first lane, the colour segment's in the other three), so that
/// [`SegmentPairs::eval`] evaluates the four in f64 lanes. Aligned to 16 bytes, so that the
/// lanes' arithmetic reads its numbers straight from memory (SSE operands must be aligned)
/// rather than loading each pair of lanes first.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(align(16))]
struct SegmentPair {
    /// The segments' starts (a): the opacity segment's, then the colour segment's thrice.
    start: [f64; 4],
    /// The columns' values at the start (b).
    base: [f64; 4],
    /// The columns' slopes.
    slope: [f64; 4],
}

impl SegmentPair {
    /// The opacity, r, g and b at input `x`: `clamp_field((base + (x − start)·slope) as f32)`
    /// per column. The lanes do each column's scalar operations (a subtraction, a product
    /// and a sum in f64, both roundings to nearest, then the rounding to f32: the same bits),
    /// and clamp as [`clamp_fields`].
    #[inline]
    fn values(&self, x: f32) -> [f32; 4] {
        use wide::{f32x4, f64x4};
        let v = f64x4::new(self.base)
            + (f64x4::splat(x as f64) - f64x4::new(self.start)) * f64x4::new(self.slope);
        clamp_fields(f32x4::new(v.to_array().map(|v| v as f32))).to_array()
    }
}

impl SegmentPairs {
    /// A bucket without a pair: its inputs take the tables' general evaluation.
    const NONE: u16 = u16::MAX;

    /// The pairs of the opacity table's column `o_col` and the colour table's columns `rgb`.
    fn new(opacity: &Mapping, o_col: usize, colour: &Mapping, rgb: [usize; 3]) -> SegmentPairs {
        let mut pairs: Vec<SegmentPair> = Vec::new();
        let index = (0..Mapping::BUCKET_COUNT)
            .map(|b| {
                let (Some(o), Some(c)) = (opacity.bucket_segment(b), colour.bucket_segment(b))
                else {
                    return Self::NONE;
                };
                let pair = SegmentPair {
                    start: [o[0], c[0], c[0], c[0]],
                    base: [
                        o[1 + 2 * o_col],
                        c[1 + 2 * rgb[0]],
                        c[1 + 2 * rgb[1]],
                        c[1 + 2 * rgb[2]],
                    ],
                    slope: [
                        o[2 + 2 * o_col],
                        c[2 + 2 * rgb[0]],
                        c[2 + 2 * rgb[1]],
                        c[2 + 2 * rgb[2]],
                    ],
                };
                // Neighbouring buckets usually share their pair (at most one per bucket).
                if pairs.last() != Some(&pair) {
                    pairs.push(pair);
                }
                (pairs.len() - 1) as u16
            })
            .collect();
        SegmentPairs { index, pairs }
    }

    /// The opacity and colour at input `x` (a field value, in [0, 1]) of bucket `bucket` (see
    /// [`Mapping::clamp_and_bucket`]) where the bucket has a pair: [`map_value`] of the opacity
    /// table, then, if it is above 0, [`map_each`] of the colour table, bit for bit. (Bucket 0,
    /// which holds the input 0, where a ramp is 0 whatever its first segment says, never has a
    /// pair: no breakpoint lies below its inputs, so they are not between two rows.) The four columns are evaluated together
    /// in lanes ([`SegmentPair::values`]); the samples that get here have passed the zero
    /// test, so their opacity is nearly always above 0 and the colour needed.
    #[inline]
    fn eval(&self, x: f32, bucket: usize) -> Option<(f32, Option<[f32; 3]>)> {
        let i = *self.index.get(bucket)?;
        let pair = self.pairs.get(i as usize)?; // NONE is past the end
        let [o, r, g, b] = pair.values(x);
        Some((o, (o > 0.0).then_some([r, g, b])))
    }
}

/// (field, output column) pairs of a transfer function, in order.
type FieldOutputs = Vec<(usize, usize)>;

impl DirectShading {
    /// The shading inputs of `direct` (whose dataset operation heads `opacity`), when its
    /// colour table writes exactly r, g and b and nothing writes fields 4 to 7.
    fn new(direct: &Direct, opacity: &[Op], start: &[f32; FIELD_COUNT]) -> Option<DirectShading> {
        let [Op::Data { mask, .. }, ..] = opacity else {
            return None;
        };
        let (_, outputs) = direct.colour.as_ref()?;
        let mut rgb = [usize::MAX; 3];
        for &(field, column) in outputs {
            let slot = rgb.get_mut(field.checked_sub(1)?)?;
            if *slot != usize::MAX {
                return None; // a field written twice: the later column wins, keep it general
            }
            *slot = column;
        }
        if rgb.contains(&usize::MAX) || mask & 0b1111_0000 != 0 {
            return None;
        }
        let (colour, _) = direct.colour.as_ref()?;
        Some(DirectShading {
            opacity: direct.opacity.clone(),
            colour: colour.clone(),
            rgb,
            coefficients: [start[4], start[5], start[6], start[7]].map(|v| v as f64),
            pairs: SegmentPairs::new(&direct.opacity.0, direct.opacity.1, colour, rgb),
        })
    }

    /// The opacity and the colour (r, g, b) of a sample whose dataset value is `v`: the
    /// fields 0 to 3 that [`Lean::opacity_from_value`] and [`Lean::rest`] leave, bit for bit;
    /// the colour only where the opacity is above 0. (The batched march holds the program's
    /// `DirectShading` for the whole ray and calls this per sample.)
    #[inline(always)]
    pub(crate) fn opacity_colour(&self, v: f32) -> (f32, Option<[f32; 3]>) {
        // The dataset writes the clamped value into the source field, which both tables read.
        let (x, b) = Mapping::clamp_and_bucket(v);
        self.pairs
            .eval(x, b)
            .unwrap_or_else(|| self.opacity_colour_general(x))
    }

    /// [`DirectShading::opacity_colour`] of a value already in [0, 1] (−0 included: a
    /// trilinear value, which `Dataset::trilinear8` clamps), which the clamp leaves as it is:
    /// the segment pair's where the value's bucket has one, else the general evaluation. (The
    /// batched march takes the two apart, so that its loop over the pairs' samples has no
    /// call.)
    #[cfg(test)]
    fn opacity_colour_in_range(&self, x: f32) -> (f32, Option<[f32; 3]>) {
        self.pair_in_range(x)
            .unwrap_or_else(|| self.opacity_colour_general(x))
    }

    /// [`DirectShading::opacity_colour`] of a value already in [0, 1] (as
    /// `opacity_colour_in_range`) where the value's bucket has a segment pair; `None` where
    /// it has not (then [`DirectShading::opacity_colour_general`] gives it).
    #[inline(always)]
    pub(crate) fn pair_in_range(&self, x: f32) -> Option<(f32, Option<[f32; 3]>)> {
        debug_assert!((0.0..=1.0).contains(&x), "{x}");
        self.pairs.eval(x, Mapping::bucket_in_range(x))
    }

    /// The opacity table and its column, and the colour table and its columns of r, g and b
    /// (for the packet march, `render::simd`).
    pub(crate) fn tables(&self) -> ((&Mapping, usize), (&Mapping, [usize; 3])) {
        ((&self.opacity.0, self.opacity.1), (&self.colour, self.rgb))
    }

    /// The segment pairs for the packet march (`render::simd`): per input bucket (see
    /// [`Mapping::clamp_and_bucket`]) its pair's number, or −1 where it has none; per pair its
    /// numbers as f32, `[start (o), start (colour), base (o, r, g, b), slope (o, r, g, b)]`
    /// (the starts are f32 breakpoints, exact; the bases and slopes rounded to f32).
    pub(crate) fn pairs_f32(&self) -> (Vec<i32>, Vec<[f32; 10]>) {
        let p = &self.pairs;
        let index = p
            .index
            .iter()
            .map(|&i| {
                if (i as usize) < p.pairs.len() {
                    i as i32
                } else {
                    -1
                }
            })
            .collect();
        let pairs = p
            .pairs
            .iter()
            .map(|q| {
                let mut a = [0f32; 10];
                a[0] = q.start[0] as f32;
                a[1] = q.start[1] as f32;
                for j in 0..4 {
                    a[2 + j] = q.base[j] as f32;
                    a[6 + j] = q.slope[j] as f32;
                }
                a
            })
            .collect();
        (index, pairs)
    }

    /// [`DirectShading::opacity_colour`] of a value already clamped (in [0, 1]) by the
    /// tables' general evaluation, which the buckets without a segment pair take (the pairs
    /// give the same bits). Out of line and cold (a few percent of the samples), so that the
    /// march's loop around the pairs' path keeps its numbers in registers.
    #[cold]
    #[inline(never)]
    pub(crate) fn opacity_colour_general(&self, x: f32) -> (f32, Option<[f32; 3]>) {
        let o = map_value(&self.opacity.0, x, self.opacity.1);
        if o <= 0.0 {
            return (o, None);
        }
        let mut rgb = [0f32; 3];
        let outputs = [0, 1, 2].map(|i| (i, self.rgb[i]));
        map_each(&self.colour, x, &outputs, |i, v| rgb[i] = clamp_field(v));
        (o, Some(rgb))
    }
}

impl Direct {
    /// The direct form of a value-head program's operations, if they have its shape.
    fn new(opacity: &[Op], zero: Option<(usize, f32)>, rest: &[Op]) -> Option<Direct> {
        let (source, _) = zero?;
        let [Op::Data {
            mask: data_mask, ..
        }, Op::Map {
            source: s,
            mapping,
            outputs,
        }] = opacity
        else {
            return None;
        };
        // o alone, from the source, which is not o (so the colour table reads it unchanged).
        let [(o_mask, o_col)] = outputs.as_slice() else {
            return None;
        };
        if *s != source || source == 0 || *o_mask != 1 || data_mask & (1 << source) == 0 {
            return None;
        }
        let single = |m: u16| (m.count_ones() == 1).then(|| m.trailing_zeros() as usize);
        let colour = match rest {
            [] => None,
            [Op::Map {
                source: s,
                mapping,
                outputs,
            }] if *s == source => Some((
                mapping.clone(),
                outputs
                    .iter()
                    .map(|&(m, j)| Some((single(m)?, j)))
                    .collect::<Option<Vec<_>>>()?,
            )),
            _ => return None,
        };
        Some(Direct {
            source,
            opacity: (mapping.clone(), *o_col),
            colour,
        })
    }
}

/// Output `j` of `mapping` at `x`, clamped as a field value: [`map_outputs`] for one output.
#[inline(always)]
fn map_value(mapping: &Mapping, x: f32, j: usize) -> f32 {
    let mut out = 0.0;
    map_each(mapping, x, &[((), j)], |(), v| out = v);
    clamp_field(out)
}

/// The outputs of `mapping` at input `x`, each an (anything, output column) pair: the input's
/// segment located once, then `put` called with each pair's first member and its value, in
/// order (unclamped).
#[inline(always)]
fn map_each<T: Copy>(
    mapping: &Mapping,
    x: f32,
    outputs: &[(T, usize)],
    mut put: impl FnMut(T, f32),
) {
    let (v, k) = mapping.locate(x);
    if let Some(seg) = mapping.ramp_segment(v, k) {
        // The usual case, a ramp inside its rows: `eval_at`'s formula without its case
        // analysis.
        // (j < outputs: `vlMap` refuses any other output column.)
        let dv = v as f64 - seg[0];
        for &(t, j) in outputs {
            put(t, segment_value(seg, dv, j));
        }
        return;
    }
    for &(t, j) in outputs {
        put(t, mapping.eval_at(v, k, j));
    }
}

#[inline]
fn write(fields: &mut [f32; FIELD_COUNT], mask: u16, v: f32) {
    let v = clamp_field(v);
    let mut bits = mask;
    while bits != 0 {
        fields[bits.trailing_zeros() as usize] = v;
        bits &= bits - 1;
    }
}

fn mask(f: Fields) -> u16 {
    (f.bits() & Fields::ALL.bits()) as u16
}

/// Compiles `program` into operations, fusing consecutive maps of one source through one
/// transfer function as long as none of them overwrites that source. `None` if the program
/// holds anything but `vlSet`, `vlDataset` and `vlMap`.
fn compile(program: &[Instr]) -> Option<Vec<Op>> {
    let mut ops: Vec<Op> = Vec::with_capacity(program.len());
    for ins in program {
        match ins {
            Instr::Set { fields, value } => ops.push(Op::Set {
                mask: mask(*fields),
                value: *value,
            }),
            Instr::Dataset {
                fields,
                data,
                filter,
                ..
            } => ops.push(Op::Data {
                mask: mask(*fields),
                data: data.clone(),
                filter: *filter,
            }),
            Instr::Map {
                targets,
                source,
                mapping,
                output,
            } => {
                let m = mask(*targets);
                if let Some(Op::Map {
                    source: s,
                    mapping: mp,
                    outputs,
                }) = ops.last_mut()
                {
                    // Whether no output of the group writes its source: each output was
                    // checked against it when the next one joined, so the last one tells.
                    let source_intact = outputs.last().is_none_or(|&(t, _)| t & (1 << *s) == 0);
                    if *s == *source && Arc::ptr_eq(mp, mapping) && source_intact {
                        outputs.push((m, *output));
                        continue;
                    }
                }
                ops.push(Op::Map {
                    source: *source,
                    mapping: mapping.clone(),
                    outputs: vec![(m, *output)],
                });
            }
            Instr::Function { .. } | Instr::Spatial { .. } => return None,
        }
    }
    Some(ops)
}

#[inline]
fn apply(ops: &[Op], p: [f32; 3], fields: &mut [f32; FIELD_COUNT]) {
    for op in ops {
        match op {
            Op::Set { mask, value } => write(fields, *mask, *value),
            Op::Data { mask, data, filter } => write(fields, *mask, data.sample(p, *filter)),
            Op::Map {
                source,
                mapping,
                outputs,
            } => map_outputs(fields, *source, mapping, outputs),
        }
    }
}

/// A group of outputs of one transfer function of field `source`: the input's segment located
/// once, the outputs written in order (a later one may overwrite an earlier one's field).
#[inline(always)]
fn map_outputs(
    fields: &mut [f32; FIELD_COUNT],
    source: usize,
    mapping: &Mapping,
    outputs: &[(u16, usize)],
) {
    let x = fields[source];
    map_each(mapping, x, outputs, |mask, v| write(fields, mask, v));
}

impl Lean {
    /// The lean form of `program`, whose first `o_prefix` instructions decide opacity; `None`
    /// if the program is not lean.
    pub(crate) fn new(program: &[Instr], o_prefix: usize) -> Option<Lean> {
        let mut opacity = compile(&program[..o_prefix])?;
        let mut rest = compile(&program[o_prefix..])?;
        // The opacity prefix ends with the last writer of o; if that is a map group whose
        // transfer function is 0 near 0 for the o column, test its input first. The group is
        // split so the test sits right before the map that writes o.
        let mut zero = None;
        if let Some(Op::Map {
            source,
            mapping,
            outputs,
        }) = opacity.last_mut()
        {
            let o_bit = mask(Fields::O);
            if let Some(last_o) = outputs.iter().rposition(|&(m, _)| m & o_bit != 0) {
                let (source, mapping) = (*source, mapping.clone());
                // Outputs before the one writing o stay in a group of their own.
                let tail = outputs.split_off(last_o);
                let head_empty = outputs.is_empty();
                if head_empty {
                    opacity.pop();
                }
                if let Some(z) = mapping.zero_below(tail[0].1) {
                    zero = Some((source, z));
                }
                // The o map and anything fused after it (which cannot write o again, or it
                // would be the last writer) follow the test.
                let mut after = tail;
                let first = after.remove(0);
                opacity.push(Op::Map {
                    source,
                    mapping: mapping.clone(),
                    outputs: vec![first],
                });
                if !after.is_empty() {
                    rest.insert(
                        0,
                        Op::Map {
                            source,
                            mapping,
                            outputs: after,
                        },
                    );
                }
            }
        }
        // Trailing constants (`vlSet` after everything else, as for ka, kd, ks and the specular
        // exponent of a scanned volume) are written at the start instead, when no dataset or
        // map reads or writes their fields: the result is the same, at no cost per sample.
        // Earlier constants for those fields are overwritten by them, so they are dropped.
        let mut start = [0.0f32; FIELD_COUNT];
        while let Some(Op::Set { mask, value }) = rest.last() {
            let (mask, value) = (*mask, *value);
            let touched = opacity
                .iter()
                .chain(&rest[..rest.len() - 1])
                .any(|op| match op {
                    Op::Set { .. } => false,
                    Op::Data { mask: m, .. } => m & mask != 0,
                    Op::Map {
                        source, outputs, ..
                    } => mask & (1 << *source) != 0 || outputs.iter().any(|&(m, _)| m & mask != 0),
                });
            if touched {
                break;
            }
            write(&mut start, mask, value);
            rest.pop();
            for ops in [&mut opacity, &mut rest] {
                for op in ops.iter_mut() {
                    if let Op::Set { mask: m, .. } = op {
                        *m &= !mask;
                    }
                }
                ops.retain(|op| !matches!(op, Op::Set { mask: 0, .. }));
            }
        }
        let direct = Direct::new(&opacity, zero, &rest);
        let shading = direct
            .as_ref()
            .and_then(|d| DirectShading::new(d, &opacity, &start));
        Some(Lean {
            opacity,
            zero,
            rest,
            start,
            direct,
            shading,
        })
    }

    /// Runs the opacity part at object point `p` on fresh registers; returns the opacity, or 0
    /// as soon as the zero test proves it (the registers are then incomplete or untouched).
    #[inline]
    pub(crate) fn opacity(&self, p: [f32; 3], fields: &mut [f32; FIELD_COUNT]) -> f32 {
        if let Some((data, z)) = self.value_head() {
            let v = clamp_field(data.trilinear(p));
            if v <= z {
                return 0.0;
            }
            return self.opacity_from_value(v, p, fields);
        }
        let Some((last, head)) = self.opacity.split_last() else {
            *fields = self.start;
            return 0.0;
        };
        *fields = self.start;
        apply(head, p, fields);
        self.finish_opacity(last, p, fields)
    }

    /// The usual head of a scanned volume's program: the opacity part starts with one
    /// trilinear read of a dataset whose value the zero test examines. Then the dataset and the
    /// test's bound z: a sample whose value (clamped, as written) is at most z has opacity 0,
    /// and [`Lean::opacity_from_value`] finishes the others.
    #[inline]
    pub(crate) fn value_head(&self) -> Option<(&Dataset, f32)> {
        match (self.opacity.as_slice(), self.zero) {
            (
                [Op::Data {
                    mask,
                    data,
                    filter: Filter::Trilinear,
                }, _],
                Some((source, z)),
            ) if mask & (1 << source) != 0 => Some((data, z)),
            _ => None,
        }
    }

    /// [`Lean::opacity`] for a program with a [`Lean::value_head`], given the clamped value
    /// `v` of its dataset at `p` (above the zero test's bound).
    #[inline]
    pub(crate) fn opacity_from_value(
        &self,
        v: f32,
        p: [f32; 3],
        fields: &mut [f32; FIELD_COUNT],
    ) -> f32 {
        let [Op::Data { mask, .. }, last] = self.opacity.as_slice() else {
            unreachable!("opacity_from_value needs a value head")
        };
        *fields = self.start;
        write(fields, *mask, v);
        if let Some(d) = &self.direct {
            let o = map_value(&d.opacity.0, fields[d.source], d.opacity.1);
            fields[0] = o;
            return o;
        }
        self.finish_opacity(last, p, fields)
    }

    /// The zero test on the registers, then the last opacity operation.
    #[inline]
    fn finish_opacity(&self, last: &Op, p: [f32; 3], fields: &mut [f32; FIELD_COUNT]) -> f32 {
        if let Some((source, z)) = self.zero {
            if fields[source] <= z {
                return 0.0;
            }
        }
        match last {
            // The usual last operation, the opacity table: without the operation loop.
            Op::Map {
                source,
                mapping,
                outputs,
            } => map_outputs(fields, *source, mapping, outputs),
            _ => apply(std::slice::from_ref(last), p, fields),
        }
        fields[0]
    }

    /// The program's shading inputs when they are [`DirectShading`]'s.
    #[inline]
    pub(crate) fn direct_shading(&self) -> Option<&DirectShading> {
        self.shading.as_ref()
    }

    /// Runs the rest of the program after [`Lean::opacity`] returned a positive opacity.
    #[inline]
    pub(crate) fn rest(&self, p: [f32; 3], fields: &mut [f32; FIELD_COUNT]) {
        if let Some(d) = &self.direct {
            if let Some((mapping, outputs)) = &d.colour {
                let x = fields[d.source];
                map_each(mapping, x, outputs, |field, v| {
                    fields[field] = clamp_field(v)
                });
            }
            return;
        }
        match self.rest.as_slice() {
            // The usual rest, one colour table: without the operation loop.
            [Op::Map {
                source,
                mapping,
                outputs,
            }] => map_outputs(fields, *source, mapping, outputs),
            rest => apply(rest, p, fields),
        }
    }
}

#[cfg(test)]
mod tests;
