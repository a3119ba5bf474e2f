//! The study's pre-integration section: the MNI brain under a steep, iso-surface-like opacity
//! ramp (0 below F = 0.35, 1 from F = 0.55; the peer scene's colour table and shading), the
//! step swept from 4 to 0.25 voxel with pre-integrated transfer functions on and off
//! (`Optimise::preintegrate`), against a 1/16-voxel reference without pre-integration.

use super::*;

/// The steep ramp's breakpoints: opacity 0 at and below the first, 1 from the second.
const RAMP: (f32, f32) = (0.35, 0.55);

/// The steps of the sweep, in voxels.
const STEPS: [f32; 5] = [4.0, 2.0, 1.0, 0.5, 0.25];

/// The reference's step, in voxels.
const REFERENCE_STEP: f32 = 1.0 / 16.0;

/// Interleaved rounds of the target's two settings (pre-integration at 2 voxels, the midpoint
/// march at 0.5 voxel), whose median ratio decides the target's time: one setting timed minutes
/// after the other sees another load of a shared host. Odd, so that the median is a round's.
const TARGET_ROUNDS: usize = 7;
const _: () = assert!(TARGET_ROUNDS % 2 == 1);

/// What the section made: the document's text and the plot's file name.
pub(crate) struct Preint {
    pub(crate) doc: String,
    /// The plot's file name.
    pub(crate) plot: String,
}

/// The steep-ramp scene of `brain` at `step` voxels, pre-integration `pre`.
fn scene(brain: &Brain, step: f32, pre: bool) -> Res<Library> {
    let mut vl = Library::new();
    vl.add_dataset(mni_scene::BRAIN, brain.data.clone())?;
    mni_scene::mappings(&mut vl)?;
    // The opacity table (mapping 1 of the peer scene) replaced by the steep ramp.
    vl.mapping(
        MappingId(1),
        MappingType::Ramp,
        2,
        1,
        &[RAMP.0, 0.0, RAMP.1, 1.0],
    )?;
    vl.scene()?;
    let dims = brain.data.dims();
    mni_scene::view(&mut vl, dims)?;
    vl.step_size(step, 1.0)?;
    vl.set_optimise(vlib::Optimise {
        preintegrate: pre,
        ..vlib::Optimise::default()
    })?;
    mni_scene::object(&mut vl, dims, true)?;
    Ok(vl)
}

/// The image side: the 256² for the full study.
fn size(p: &Params) -> u32 {
    if p.quick {
        p.size
    } else {
        256
    }
}

/// Runs the sweeps and writes the section.
pub(crate) fn study(p: &Params, brain: &Brain, start: Instant) -> Res<Preint> {
    let size = size(p);
    log(start, "steep ramp: reference");
    let reference = render(&scene(brain, REFERENCE_STEP, false)?, size)?;
    save_debug("steep_reference", &reference.img)?;
    let mut series = Vec::new();
    for pre in [false, true] {
        let mut rows = Vec::new();
        for step in STEPS {
            let r = render(&scene(brain, step, pre)?, size)?;
            let err = error(&r.img, &reference.img);
            let bad = non_finite(&r.img);
            if bad > 0 {
                eprintln!("warning: steep ramp step {step} pre {pre}: {bad} non-finite pixels");
            }
            log(
                start,
                format!(
                    "steep ramp: step {step}, pre-integration {}: {:.4} s, RMS {:.3}, max {:.1}",
                    if pre { "on" } else { "off" },
                    r.secs,
                    err.rms,
                    err.max
                ),
            );
            let label = format!("{step} voxel, {}", if pre { "on" } else { "off" });
            rows.push(Row::of(label, format!("{step}"), &r, err));
        }
        series.push(Series {
            scene: format!(
                "steep ramp, pre-integration {}",
                if pre { "on" } else { "off" }
            ),
            rows,
        });
    }
    // The Pareto front over both sweeps together: which setting a user should pick.
    let mut all: Vec<Row> = series.iter().flat_map(|s| s.rows.clone()).collect();
    mark_pareto(&mut all);
    let n0 = series[0].rows.len();
    for (i, r) in all.into_iter().enumerate() {
        let (s, j) = if i < n0 { (0, i) } else { (1, i - n0) };
        series[s].rows[j].pareto = r.pareto;
    }
    // The target's two settings again, in interleaved rounds, each first in every other round.
    let (pre2, base) = (scene(brain, 2.0, true)?, scene(brain, 0.5, false)?);
    let mut rounds = Vec::new();
    for round in 1..=TARGET_ROUNDS {
        let (a, b) = if round % 2 == 1 {
            let a = render(&pre2, size)?.secs;
            (a, render(&base, size)?.secs)
        } else {
            let b = render(&base, size)?.secs;
            (render(&pre2, size)?.secs, b)
        };
        log(
            start,
            format!("steep ramp: target round {round}: {a:.4} s against {b:.4} s"),
        );
        rounds.push((a, b));
    }
    let on = series.pop().expect("two sweeps");
    let off = series.pop().expect("two sweeps");
    let plot = plot_control(
        p,
        "preintegration",
        "Pre-integration, steep ramp: RMS error (grey levels) against render time (s)",
        &[off.clone(), on.clone()],
    )?;
    let doc = document(p, size, &reference, &off, &on, &rounds, &plot);
    Ok(Preint { doc, plot })
}

/// The row of `s` at `step`.
fn at(s: &Series, step: f32) -> &Row {
    let i = STEPS.iter().position(|&x| x == step).expect("a swept step");
    &s.rows[i]
}

/// The section's text; `rounds` are the target's interleaved rounds (pre-integrated time,
/// midpoint time).
fn document(
    p: &Params,
    size: u32,
    reference: &Timed,
    off: &Series,
    on: &Series,
    rounds: &[(f64, f64)],
    plot: &str,
) -> String {
    let mut d = String::new();
    let _ = writeln!(
        d,
        "\n### Pre-integrated transfer functions\n\n\
         ![error against time, pre-integration]({plot})\n\n\
         The MNI brain of the peer scene (trilinear, shaded, one headlight, its colour table) \
         under a steep, iso-surface-like opacity ramp: 0 at and below F = {}, rising linearly \
         to 1 at F = {} and 1 above, at {size}×{size} pixels, 1 sample per pixel. The \
         reference is step {} voxel without pre-integration ({} s). With pre-integration \
         (`Optimise::preintegrate`, off by default) each slab between two samples takes the \
         opacity and colour of the value varying linearly from one sample to the next, cut \
         in halves down to a quarter of the step where the data bends along it (128 × 128 \
         tables per object for the step, its half and its quarter, built by a scene's \
         first frame, the untimed warm-up, and kept for the frames timed below); without \
         it, each segment is its midpoint sample. Both are traced by the packet march \
         where the processor has AVX2 (for pre-integrated images, the samples, their \
         values, the values at the slabs' middles and quarters and the lighting in lanes, \
         the halving, the tables and the composite by scalar code). A ★ marks the Pareto \
         front of both sweeps together.\n",
        RAMP.0,
        RAMP.1,
        REFERENCE_STEP,
        g(reference.secs),
    );
    let _ = writeln!(
        d,
        "| step | time off (ms) | RMS off | max off | time on (ms) | RMS on | max on |\n\
         |---|---:|---:|---:|---:|---:|---:|"
    );
    for &step in &STEPS {
        let (a, b) = (at(off, step), at(on, step));
        let star = |r: &Row| if r.pareto { " ★" } else { "" };
        let _ = writeln!(
            d,
            "| {step} voxel | {}{} | {} | {} | {}{} | {} | {} |",
            ms(a.secs),
            star(a),
            g(a.err.rms),
            g(a.err.max),
            ms(b.secs),
            star(b),
            g(b.err.rms),
            g(b.err.max),
        );
    }
    // The target: at 2 voxels, at most the error and the time of 0.5 voxel without;
    // the time by the median ratio of the interleaved rounds.
    let (base, pre2) = (at(off, 0.5), at(on, 2.0));
    let error_met = pre2.err.rms <= base.err.rms;
    let mut ratios: Vec<f64> = rounds.iter().map(|(a, b)| a / b).collect();
    ratios.sort_by(f64::total_cmp);
    let median = ratios.get(ratios.len() / 2).copied().unwrap_or(f64::NAN);
    let time_met = median <= 1.0;
    let each: Vec<String> = rounds
        .iter()
        .map(|(a, b)| format!("{} against {}", ms(*a), ms(*b)))
        .collect();
    let _ = writeln!(
        d,
        "\nThe target (pre-integration at 2 voxels: at most the error and the time of 0.5 voxel \
         without it): {} RMS against {} ({}); the time, in {} interleaved rounds of the two \
         (ms, each round's best frame as in the table; the two in turn first): {}; the median \
         ratio {:.3} ({}, its range {:.2}–{:.2}).{}",
        g(pre2.err.rms),
        g(base.err.rms),
        if error_met { "met" } else { "not met" },
        rounds.len(),
        each.join("; "),
        median,
        if time_met { "met" } else { "not met" },
        ratios.first().copied().unwrap_or(f64::NAN),
        ratios.last().copied().unwrap_or(f64::NAN),
        if p.quick {
            " (A quick run: small images, times not representative.)"
        } else {
            ""
        }
    );
    // Recommendation: the cheapest setting under each limit, over both sweeps.
    let rows: Vec<&Row> = off.rows.iter().chain(&on.rows).collect();
    let cheapest = |limit: f64| {
        rows.iter()
            .filter(|r| r.err.rms < limit)
            .min_by(|a, b| a.secs.total_cmp(&b.secs))
            .map_or("none of the settings measured".to_string(), |r| {
                format!(
                    "step {} ({} grey levels RMS, {} ms)",
                    r.label,
                    g(r.err.rms),
                    ms(r.secs)
                )
            })
    };
    // What pre-integration costs at a given step: the range of its time over the time
    // without it, over the steps swept.
    let ratios: Vec<f64> = STEPS
        .iter()
        .map(|&step| at(on, step).secs / at(off, step).secs)
        .filter(|r| r.is_finite())
        .collect();
    let lo = ratios.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = ratios.iter().copied().fold(0.0, f64::max);
    let _ = writeln!(
        d,
        "\n**Recommendation for steep transfer functions.** The cheapest setting under 2 grey \
         levels RMS is {}, under 1 {}, under 0.5 {}. At a given step pre-integration lowers \
         the error (the terracing of a steep ramp) and costs {:.1}–{:.1} times the packet \
         march's time, which is why it is off by default (`compat.md`): switch it on with a \
         coarse step.",
        cheapest(2.0),
        cheapest(1.0),
        cheapest(0.5),
        lo,
        hi,
    );
    d
}
