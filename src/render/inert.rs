//! What a scene switches on but cannot show, told from its description before anything is
//! traced: fields that are constants (0 where never written), and the objects no ray can see
//! anything of. The compilation (`compile`) leaves those objects out of what rays meet and
//! turns off the mirror and refracted rays of a ks or an index that cannot bend or reflect
//! (`docs/dev/render-plan.md`). It decides nothing about a pixel.

use crate::model::program::{prefix_for, Instr};
use crate::model::scene::ObjectDesc;
use crate::types::{Feature, Fields, RenderType};

/// Field number `i`'s value wherever an object's `program` runs, where it is a constant: 0 where
/// it is never written (fields start at 0), the value of a constant `vlSet` that writes it
/// last; else `None`.
fn constant_field(program: &[Instr], i: usize) -> Option<f32> {
    match prefix_for(program, Fields::from_index(i)).checked_sub(1) {
        None => Some(0.0),
        Some(k) => match program[k] {
            Instr::Set { value, .. } => Some(value),
            _ => None,
        },
    }
}

/// Whether `fields` are 0 wherever an object's `program` runs.
pub(super) fn zero_field(program: &[Instr], fields: Fields) -> bool {
    fields
        .indices()
        .all(|i| constant_field(program, i) == Some(0.0))
}

/// Whether object `o` can bend a ray: `VL_REFRACT` on, and its RF not 0 everywhere (an index
/// of 1 bends nothing).
pub(super) fn refracts(o: &ObjectDesc) -> bool {
    o.state.toggle(Feature::Refract) && !zero_field(&o.program, Fields::RF)
}

/// Whether no ray can see anything of object `o`: its opacity is 0 everywhere and it bends no
/// ray; or it is a DSR object none of whose surfaces exists (each surface's field a constant
/// below its threshold, and so is the 0 outside the boundary); or no ray looks at it (not
/// visible, and casting neither shadows nor reflections). Such an object is left out of the
/// objects rays meet, and kept for voxelization.
pub(super) fn shows_nothing(o: &ObjectDesc) -> bool {
    let r = &o.state;
    let clear = zero_field(&o.program, Fields::O) && !(refracts(o) && r.recursion > 0);
    let no_surface = r.render_type == RenderType::Dsr
        && r.surfaces.iter().all(|&(field, threshold)| {
            threshold > 0.0 && constant_field(&o.program, field).is_some_and(|c| c < threshold)
        });
    let unseen = !r.toggle(Feature::Visible)
        && !r.toggle(Feature::CastShadows)
        && !r.toggle(Feature::CastReflections);
    clear || no_surface || unseen
}
