//! The lean sampling kernel: an object program made only of constants, datasets and transfer
//! functions (`vlSet`, `vlDataset`, `vlMap`, the usual program of a scanned volume) compiled
//! into a flat list of operations on ten field registers.
//!
//! It computes exactly what [`crate::program::run`] computes, bit for bit (the same dataset
//! filters, the same [`Mapping`] arithmetic, the same clamping of written values), without the
//! generality a field function needs: no [`crate::program::Sample`] per point, no instruction
//! dispatch over function calls. These rewrites make it cheaper, all exact:
//!
//! - **The zero test.** When opacity is last written by a transfer function that is 0 on an
//!   interval [0, z] of its input ([`Mapping::zero_below`]), a sample whose input is at most z
//!   has opacity 0 and is dropped before the transfer function is evaluated.
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

use crate::dataset::{Dataset, Filter};
use crate::mapping::{segment_value, Mapping};
use crate::program::{clamp_field, clamp_fields, Instr};
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
    /// (for the packet march, `render::packet`).
    pub(crate) fn tables(&self) -> ((&Mapping, usize), (&Mapping, [usize; 3])) {
        ((&self.opacity.0, self.opacity.1), (&self.colour, self.rgb))
    }

    /// The segment pairs for the packet march (`render::packet`): per input bucket (see
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
                    let source_intact = outputs.iter().all(|&(t, _)| t & (1 << *s) == 0);
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
mod tests {
    use super::*;
    use crate::dataset::Voxels;
    use crate::program::{run, Sample};
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
        let lookup =
            Arc::new(Mapping::new(MappingType::Lookup, 2, 1, &[0.3, 1.0, 0.7, 0.6]).unwrap());
        let ds = |fields| Instr::Dataset {
            fields,
            data: d.clone(),
            filter: Filter::Trilinear,
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
        ]
    }

    #[test]
    fn lean_matches_the_interpreter_bit_for_bit() {
        for (n, prog) in programs().into_iter().enumerate() {
            let o_prefix = crate::program::prefix_for(&prog, Fields::O);
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
        assert!(
            matches!(lean.opacity[0], Op::Set { mask, value } if mask == 1 << 5 && value == 0.7)
        );
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
            let lean = Lean::new(prog, crate::program::prefix_for(prog, Fields::O)).unwrap();
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
        let lean =
            |prog: &[Instr]| Lean::new(prog, crate::program::prefix_for(prog, Fields::O)).unwrap();
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
            let o_prefix = crate::program::prefix_for(prog, Fields::O);
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
}
