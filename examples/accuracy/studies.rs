//! The study's parts: the closed-form scenes ([`analytic`]), the MNI brain ([`mni_study`]) and
//! the hypertexture ([`hyper_study`]), each sweeping its controls, and the helpers that pick
//! the recommendations from a sweep.

use super::*;

/// What the closed-form part measured.
pub(crate) struct Analytic {
    pub(crate) constant: Vec<(f32, f64, Err)>,
    pub(crate) ramp: Series,
    pub(crate) sphere: Series,
}

pub(crate) fn analytic(p: &Params, cache: &mut Cache, start: Instant) -> Res<Analytic> {
    let size = p.analytic_size;
    // (a) The constant medium: exact for any step, even one segment longer than the slab.
    let exact = slab_exact(size, false);
    let mut constant = Vec::new();
    for step in [30.0f32, 7.0, 3.0, 1.3, 0.6, 0.25, 0.1] {
        let mut vl = Library::new();
        slab_scene(&mut vl, step, false)?;
        let r = render(&vl, size)?;
        let e = error(&r.img, &exact);
        log(
            start,
            format!(
                "constant medium, step {step}: RMS {:.2e}, max {:.2e}",
                e.rms, e.max
            ),
        );
        constant.push((step, r.secs, e));
    }
    // (c) The linear ramp: midpoint samples, error O(step²).
    let exact = slab_exact(size, true);
    let steps = [8.0f32, 4.0, 2.0, 1.0, 0.5, 0.25, 0.125];
    let settings = step_settings(&steps, Cfg::new(1.0, 1), "");
    let make = |cfg: Cfg| -> Res<Library> {
        let mut vl = Library::new();
        slab_scene(&mut vl, cfg.step, true)?;
        Ok(vl)
    };
    let ramp = sweep(
        cache.scene("ramp"),
        "linear colour ramp (closed form)",
        &settings,
        None,
        &make,
        &exact,
        size,
        start,
    )?;
    // (b) The iso-sphere by DSR.
    let exact = sphere_exact(size);
    let steps = [16.0f32, 8.0, 4.0, 2.0, 1.0, 0.5, 0.25];
    let settings = step_settings(&steps, Cfg::new(1.0, 1), "");
    let make = |cfg: Cfg| -> Res<Library> {
        let mut vl = Library::new();
        sphere_scene(&mut vl, cfg.step)?;
        Ok(vl)
    };
    let mut sphere = sweep(
        cache.scene("sphere"),
        "iso-sphere, DSR (closed form)",
        &settings,
        None,
        &make,
        &exact,
        size,
        start,
    )?;
    for (row, &step) in sphere.rows.iter_mut().zip(&steps) {
        let img = cache
            .scene("sphere")
            .render(&make, Cfg::new(step, 1), size)?
            .img;
        let e = sphere_error(&img, &exact);
        row.extra = vec![
            e.missed.to_string(),
            e.extra.to_string(),
            format!("{:.1e}", e.rms_pos),
            format!("{:.1e}", e.max_pos),
        ];
    }
    Ok(Analytic {
        constant,
        ramp,
        sphere,
    })
}

/// The sweeps of one converged-reference scene.
pub(crate) struct Study {
    pub(crate) reference_secs: f64,
    pub(crate) step: Series,
    pub(crate) ss: Series,
    pub(crate) filter: Option<Series>,
    /// Early termination's threshold (the brain only).
    pub(crate) termination: Option<Series>,
    pub(crate) nbhd: Option<Series>,
    pub(crate) combined: Series,
    /// Extra facts for the text.
    pub(crate) notes: Vec<String>,
}

pub(crate) fn mni_study(p: &Params, cache: &mut Cache, start: Instant) -> Res<(Study, Brain)> {
    let path = mni_dataset()?;
    let data = Dataset::load(&path)?;
    // Fill the brick-range caches once (every scene shares the dataset), not in every scene's first frame.
    data.precompute(vlib::Filter::Trilinear)?;
    data.precompute(vlib::Filter::Cubic { b: 0.0, c: 0.5 })?;
    let brain = Brain {
        data: Arc::new(data),
        path,
    };
    let size = p.size;
    let (ref_step, ref_ss) = p.mni_ref;
    let ref_cfg = Cfg::new(ref_step, ref_ss).filter(Filter::CatmullRom);
    let t = Instant::now();
    let reference = brain.scene(ref_cfg)?.render_preview(size, size, 1.0)?;
    let reference_secs = t.elapsed().as_secs_f64();
    log(start, format!("MNI reference: {reference_secs:.1} s"));
    save_debug("mni-reference", &reference)?;
    let make = |cfg: Cfg| brain.scene(cfg);
    let base = Cfg::new(0.5, 1);

    let steps = [2.0f32, 1.0, 0.5, 0.25, 0.125, 0.0625];
    let step = sweep(
        cache.scene("mni"),
        "MNI brain (trilinear, 1 sample per pixel)",
        &step_settings(&steps, base, " voxel"),
        Some(Cfg::new(0.0625, 1)),
        &make,
        &reference,
        size,
        start,
    )?;
    let rates = if p.quick {
        vec![1, 2, 4]
    } else {
        vec![1, 2, 3, 4, 6, 8]
    };
    let ss = sweep(
        cache.scene("mni"),
        "MNI brain (trilinear, step 0.5 voxel)",
        &ss_settings(&rates, base),
        Some(Cfg::new(0.5, *rates.last().expect("rates"))),
        &make,
        &reference,
        size,
        start,
    )?;
    let filters = [
        Filter::Nearest,
        Filter::Trilinear,
        Filter::CatmullRom,
        Filter::Mitchell,
        Filter::BSpline,
    ];
    let filter = sweep(
        cache.scene("mni"),
        "MNI brain (step 0.5 voxel, 1 sample per pixel)",
        &filter_settings(&filters, base),
        None,
        &make,
        &reference,
        size,
        start,
    )?;
    // Early termination's threshold, from never stopping early (0, the own reference) up.
    let thresholds: [(f64, &str); 6] = [
        (0.0, "0 (none)"),
        (1.0 / 2048.0, "1/2048"),
        (vlib::T_MIN, "1/512 (default)"),
        (mni_scene::VTK_TERMINATION, "255/32767 (VTK)"),
        (1.0 / 32.0, "1/32"),
        (1.0 / 8.0, "1/8"),
    ];
    let termination = sweep(
        cache.scene("mni"),
        "MNI brain (trilinear, step 0.5 voxel, 1 sample per pixel)",
        &thresholds
            .iter()
            .map(|&(t, label)| (label.to_string(), format!("{t:.5}"), base.termination(t)))
            .collect::<Vec<_>>(),
        Some(base.termination(0.0)),
        &make,
        &reference,
        size,
        start,
    )?;
    // The neighbourhood does not apply to a dataset's F (grid gradients): check it.
    let a = cache.scene("mni").render(&make, base.nbhd(0.1), size)?.img;
    let b = cache.scene("mni").render(&make, base.nbhd(4.0), size)?.img;
    let nb = error(&a, &b);
    let notes = vec![format!(
        "On the brain the neighbourhood has no effect: F is a dataset's value, and normals come \
         from its interpolated grid gradients; the images with offsets of 0.1 and 4 voxels differ \
         by {} grey levels RMS (max {}).",
        g(nb.rms),
        g(nb.max)
    )];
    log(
        start,
        format!("MNI neighbourhood 0.1 vs 4: RMS {}", g(nb.rms)),
    );

    let mut grid = Vec::new();
    for &s in &[1.0f32, 0.5, 0.25, 0.125] {
        for &n in &[1, 2, 4] {
            grid.push((
                format!("step {s}, {n}×{n}, trilinear"),
                format!("{s}/{n}x{n}"),
                Cfg::new(s, n),
            ));
        }
    }
    for &s in &[0.5f32, 0.25] {
        for &n in &[1, 2, 4] {
            grid.push((
                format!("step {s}, {n}×{n}, Catmull–Rom"),
                format!("{s}/{n}x{n}/CR"),
                Cfg::new(s, n).filter(Filter::CatmullRom),
            ));
        }
    }
    grid.retain(|(_, _, c)| *c != ref_cfg);
    let combined = sweep(
        cache.scene("mni"),
        "MNI brain",
        &grid,
        None,
        &make,
        &reference,
        size,
        start,
    )?;
    Ok((
        Study {
            reference_secs,
            step,
            ss,
            filter: Some(filter),
            termination: Some(termination),
            nbhd: None,
            combined,
            notes,
        },
        brain,
    ))
}

pub(crate) struct Voxel {
    pub(crate) series: Series,
    pub(crate) filter: Series,
}

pub(crate) fn hyper_study(p: &Params, cache: &mut Cache, start: Instant) -> Res<(Study, Voxel)> {
    let size = p.size;
    let (ref_step, ref_nb, ref_ss) = p.hyper_ref;
    let ref_cfg = Cfg::new(ref_step, ref_ss).nbhd(ref_nb);
    let t = Instant::now();
    let reference = hyper_direct(ref_cfg)?.render_preview(size, size, 1.0)?;
    let reference_secs = t.elapsed().as_secs_f64();
    log(
        start,
        format!("hypertexture reference: {reference_secs:.1} s"),
    );
    save_debug("hyper-reference", &reference)?;
    let base = Cfg::new(0.5, 1);
    let make = |cfg: Cfg| hyper_direct(cfg);

    let steps = [4.0f32, 2.0, 1.0, 0.5, 0.25, 0.125, 0.0625];
    let step = sweep(
        cache.scene("hyper"),
        "hypertexture (1 sample per pixel, automatic neighbourhood = ½ step)",
        &step_settings(&steps, base, ""),
        Some(Cfg::new(0.0625, 1)),
        &make,
        &reference,
        size,
        start,
    )?;
    let rates = if p.quick {
        vec![1, 2, 4]
    } else {
        vec![1, 2, 3, 4, 8]
    };
    let ss = sweep(
        cache.scene("hyper"),
        "hypertexture (step 0.5)",
        &ss_settings(&rates, base),
        Some(Cfg::new(0.5, *rates.last().expect("rates"))),
        &make,
        &reference,
        size,
        start,
    )?;
    // The neighbourhood on a 2×2 super-sampled baseline, so that its effect stands out of the
    // one-sample-per-pixel floor; the automatic choice is ½ step = 0.25 here.
    let nb_base = Cfg::new(0.5, 2);
    let nbs: Vec<(String, String, Cfg)> = [8.0f32, 4.0, 2.0, 1.0, 0.5, 0.25, 0.1, 0.05, 0.02]
        .iter()
        .map(|&d| {
            if d == 0.25 {
                ("0.25 (automatic)".into(), "auto".into(), nb_base)
            } else {
                (format!("{d}"), format!("{d}"), nb_base.nbhd(d))
            }
        })
        .collect();
    let mut nbhd = sweep(
        cache.scene("hyper"),
        "hypertexture (step 0.5, 2×2 super-sampling)",
        &nbs,
        Some(nb_base.nbhd(0.02)),
        &make,
        &reference,
        size,
        start,
    )?;
    // The offset does not change the work (six evaluations of F per shaded sample whatever it
    // is), so the rows differ in time mostly by noise: rank them by error alone.
    mark_pareto_equal_cost(&mut nbhd.rows);

    let mut grid = Vec::new();
    for &(s, rates) in &[
        (1.0f32, &[1, 2, 4][..]),
        (0.5, &[1, 2, 4]),
        (0.25, &[1, 2, 4]),
        (0.125, &[1, 2]),
    ] {
        for &n in rates {
            grid.push((
                format!("step {s}, {n}×{n}"),
                format!("{s}/{n}x{n}"),
                Cfg::new(s, n),
            ));
        }
    }
    let combined = sweep(
        cache.scene("hyper"),
        "hypertexture",
        &grid,
        None,
        &make,
        &reference,
        size,
        start,
    )?;

    // Direct evaluation against voxelized fields, and the filters on a coarse voxelization
    // (whose exact answer, unlike the brain's, is known: the function itself).
    let dir = std::env::temp_dir().join(format!("vlib-accuracy-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let direct = cache.scene("hyper").render(&make, base, size)?;
    let mut rows = vec![Row {
        extra: vec!["—".into()],
        ..Row::of(
            "direct evaluation".into(),
            "direct".into(),
            &direct,
            error(&direct.img, &reference),
        )
    }];
    let mut filter = None;
    let filter_n = 64;
    for &n in &p.voxel_sizes {
        let (data, vox_secs) = hyper_voxelize(n, &dir)?;
        let r = render(&hyper_voxel(&data, base)?, size)?;
        let err = error(&r.img, &reference);
        log(
            start,
            format!(
                "hypertexture voxelized {n}³: voxelize {vox_secs:.2} s, render {:.3} s, RMS {:.3}",
                r.secs, err.rms
            ),
        );
        rows.push(Row {
            extra: vec![format!("{vox_secs:.2}")],
            ..Row::of(format!("voxelized {n}³"), format!("{n}³"), &r, err)
        });
        if n == filter_n {
            let filters = [
                Filter::Nearest,
                Filter::Trilinear,
                Filter::CatmullRom,
                Filter::Mitchell,
                Filter::BSpline,
            ];
            let make_vox = |cfg: Cfg| hyper_voxel(&data, cfg);
            filter = Some(sweep(
                cache.scene(&format!("vox{n}")),
                &format!("hypertexture voxelized at {n}³ (step 0.5, 1 sample per pixel)"),
                &filter_settings(&filters, base),
                None,
                &make_vox,
                &reference,
                size,
                start,
            )?);
        }
    }
    std::fs::remove_dir_all(&dir)?;
    mark_pareto(&mut rows);
    let voxel = Voxel {
        series: Series {
            scene: "hypertexture (step 0.5, 1 sample per pixel, 16-bit fields, trilinear)".into(),
            rows,
        },
        filter: filter.ok_or("no voxelization at the filter sweep's resolution")?,
    };
    Ok((
        Study {
            reference_secs,
            step,
            ss,
            filter: None,
            termination: None,
            nbhd: Some(nbhd),
            combined,
            notes: Vec::new(),
        },
        voxel,
    ))
}

/// The own error (against the sweep's finest value) of the row labelled `short`, formatted.
pub(crate) fn own_of(s: &Series, short: &str) -> String {
    s.rows
        .iter()
        .find(|r| r.short == short)
        .and_then(|r| r.own)
        .map_or("—".into(), |e| g(e.rms))
}

/// The plot label of a sweep's last row and of the one before it.
pub(crate) fn last(s: &Series) -> String {
    s.rows.last().map_or(String::new(), |r| r.short.clone())
}

pub(crate) fn second_last(s: &Series) -> String {
    s.rows
        .iter()
        .rev()
        .nth(1)
        .map_or(String::new(), |r| r.short.clone())
}

/// The cheapest row of a sweep whose RMS error is below `limit`.
pub(crate) fn cheapest(s: &Series, limit: f64) -> Option<&Row> {
    s.rows
        .iter()
        .filter(|r| r.err.rms < limit)
        .min_by(|a, b| a.secs.total_cmp(&b.secs))
}

pub(crate) fn choice(s: &Series, limit: f64) -> String {
    match cheapest(s, limit) {
        Some(r) => format!(
            "{} ({} grey levels RMS, {} ms)",
            r.label,
            g(r.err.rms),
            ms(r.secs)
        ),
        None => "none of the grid".into(),
    }
}

pub(crate) fn convergence_order(rows: &[Row], steps: &[f32]) -> Option<f64> {
    // Least-squares slope of log(error) against log(step) over the rows above the noise floor.
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .zip(steps)
        .filter(|(r, _)| r.err.rms > 1e-3)
        .map(|(r, &s)| ((s as f64).ln(), r.err.rms.ln()))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (sx, sy) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), &(x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let num: f64 = pts.iter().map(|&(x, y)| (x - mx) * (y - my)).sum();
    let den: f64 = pts.iter().map(|&(x, _)| (x - mx).powi(2)).sum();
    Some(num / den)
}
