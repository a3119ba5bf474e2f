//! Constructive volume geometry (Chen & Tucker, 2000): operators that define a parent's ten
//! fields from its children's, for use as field functions (`VLU_UNION`, `VLU_INTERSECTION`,
//! `VLU_DIFFERENCE`, `VLU_BLEND` in C; [`union`], … with `Library::function` in Rust).
//!
//! With o_i the opacity of child i (1-based, declaration order) at the point:
//!
//! - **union**: o = max_i o_i; the other nine fields come from the child of largest opacity
//!   (the first on ties);
//! - **intersection**: o = min_i o_i; the other fields from the child of smallest opacity;
//! - **difference**: child 1 minus the rest: o = min(o_1, 1 − max_{i≥2} o_i); the other fields
//!   from child 1;
//! - **blend**, a smooth union: o = 1 − Π_i (1 − o_i); the other fields are the
//!   opacity-weighted mean of the children's (0 where every child is transparent).
//!
//! Each writes only the fields its `vlFunction` call named. With no children every field is 0.
//!
//! These are field functions like any user's: they read the children through the sample's
//! `vlChild*` queries and know nothing of how children are compiled or rendered.

use crate::model::program::Sample;
use crate::types::{Fields, FIELD_COUNT};
use crate::Result;

/// The operators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Operator {
    /// max opacity.
    Union,
    /// min opacity.
    Intersection,
    /// child 1 minus the others.
    Difference,
    /// probabilistic sum of opacities, opacity-weighted fields.
    Blend,
}

/// Combines the fields of the children (each `[o, r, g, b, ka, kd, ks, n, rf, f]`).
pub fn combine(op: Operator, children: &[[f32; FIELD_COUNT]]) -> [f32; FIELD_COUNT] {
    let Some(first) = children.first() else {
        return [0.0; FIELD_COUNT];
    };
    let pick = |better: fn(f32, f32) -> bool| {
        let mut best = first;
        for c in &children[1..] {
            if better(c[0], best[0]) {
                best = c;
            }
        }
        *best
    };
    match op {
        Operator::Union => pick(|a, b| a > b),
        Operator::Intersection => pick(|a, b| a < b),
        Operator::Difference => {
            let rest = children[1..].iter().map(|c| c[0]).fold(0.0f32, f32::max);
            let mut out = *first;
            out[0] = first[0].min(1.0 - rest);
            out
        }
        Operator::Blend => {
            let transmit: f64 = children.iter().map(|c| 1.0 - c[0] as f64).product();
            let total: f64 = children.iter().map(|c| c[0] as f64).sum();
            let mut out = [0.0f32; FIELD_COUNT];
            out[0] = (1.0 - transmit) as f32;
            if total > 0.0 {
                for (i, o) in out.iter_mut().enumerate().skip(1) {
                    let s: f64 = children.iter().map(|c| c[0] as f64 * c[i] as f64).sum();
                    *o = (s / total) as f32;
                }
            }
            out
        }
    }
}

/// Runs operator `op` over all children of the object being evaluated and writes the result
/// (to the fields the running `vlFunction` named).
pub fn apply(op: Operator, s: &mut Sample<'_>) -> Result<()> {
    let n = s.child_count();
    let mut children = Vec::with_capacity(n);
    for i in 1..=n as i32 {
        children.push(s.child_fields(i)?);
    }
    let out = combine(op, &children);
    for (i, v) in out.iter().enumerate() {
        s.set(Fields::from_index(i), *v)?;
    }
    Ok(())
}

/// The union field function.
pub fn union(s: &mut Sample<'_>) {
    let _ = apply(Operator::Union, s);
}

/// The intersection field function.
pub fn intersection(s: &mut Sample<'_>) {
    let _ = apply(Operator::Intersection, s);
}

/// The difference field function (child 1 minus the others).
pub fn difference(s: &mut Sample<'_>) {
    let _ = apply(Operator::Difference, s);
}

/// The smooth-blend field function.
pub fn blend(s: &mut Sample<'_>) {
    let _ = apply(Operator::Blend, s);
}

#[cfg(test)]
mod tests;
