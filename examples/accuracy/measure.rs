//! The study's measurements: the settings it sweeps ([`Cfg`], [`Filter`]), timed renders
//! ([`render`], [`Cache`]), errors against a reference ([`error`], [`Row`], [`Series`]), the
//! Pareto marks, and the sweeps of one control ([`sweep`] and its settings).

use super::*;

/// The interpolation filters swept for datasets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Filter {
    Nearest,
    Trilinear,
    CatmullRom,
    Mitchell,
    BSpline,
}

impl Filter {
    pub(crate) fn apply(self, vl: &mut Library) -> vlib::Result<()> {
        let cubic = |vl: &mut Library, b: f32, c: f32| {
            vl.interpolation(Interpolation::Tricubic)?;
            vl.cubic_filter(b, c)
        };
        match self {
            Filter::Nearest => vl.interpolation(Interpolation::Nearest),
            Filter::Trilinear => vl.interpolation(Interpolation::Trilinear),
            Filter::CatmullRom => cubic(vl, 0.0, 0.5),
            Filter::Mitchell => cubic(vl, 1.0 / 3.0, 1.0 / 3.0),
            Filter::BSpline => cubic(vl, 1.0, 0.0),
        }
    }

    pub(crate) fn name(self) -> &'static str {
        match self {
            Filter::Nearest => "nearest",
            Filter::Trilinear => "trilinear",
            Filter::CatmullRom => "Catmull–Rom (B=0, C=½)",
            Filter::Mitchell => "Mitchell (B=C=⅓)",
            Filter::BSpline => "cubic B-spline (B=1, C=0)",
        }
    }

    /// A label short enough for a plot (ASCII).
    pub(crate) fn short(self) -> &'static str {
        match self {
            Filter::Nearest => "nearest",
            Filter::Trilinear => "linear",
            Filter::CatmullRom => "CR",
            Filter::Mitchell => "Mitchell",
            Filter::BSpline => "B-spline",
        }
    }
}

/// One combination of the controls.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cfg {
    pub(crate) step: f32,
    pub(crate) ss: i32,
    pub(crate) filter: Filter,
    /// Central-difference offsets in world units; `None` = automatic (half the step).
    pub(crate) nbhd: Option<f32>,
    /// Early termination's threshold (`Optimise::termination`).
    pub(crate) termination: f64,
}

impl Cfg {
    pub(crate) fn new(step: f32, ss: i32) -> Cfg {
        Cfg {
            step,
            ss,
            filter: Filter::Trilinear,
            nbhd: None,
            termination: vlib::T_MIN,
        }
    }

    pub(crate) fn termination(self, termination: f64) -> Cfg {
        Cfg {
            termination,
            ..self
        }
    }

    pub(crate) fn filter(self, filter: Filter) -> Cfg {
        Cfg { filter, ..self }
    }

    pub(crate) fn nbhd(self, d: f32) -> Cfg {
        Cfg {
            nbhd: Some(d),
            ..self
        }
    }

    /// Applies the settings at scene scope; `reference` is the opacity reference length.
    pub(crate) fn apply(&self, vl: &mut Library, reference: f32) -> vlib::Result<()> {
        vl.step_size(self.step, reference)?;
        vl.super_sample(self.ss)?;
        self.filter.apply(vl)?;
        if let Some(d) = self.nbhd {
            vl.neighborhood(d, d, d)?;
        }
        vl.set_optimise(vlib::Optimise {
            termination: self.termination,
            ..vlib::Optimise::default()
        })
    }
}

/// A rendered image and the best wall-clock time of `render_preview`.
#[derive(Clone)]
pub(crate) struct Timed {
    pub(crate) img: Image,
    pub(crate) secs: f64,
    pub(crate) runs: u32,
    /// The warm-up frame's time: mostly what a scene's first frame builds (empty-space grid).
    pub(crate) warm: f64,
}

/// Renders the open scene of `vl`: a small warm-up frame first (dataset brick ranges and
/// empty-space grids are built once per dataset and object, and are not what is measured), then
/// up to three timed frames while they add up to less than a second; the best time counts.
pub(crate) fn render(vl: &Library, size: u32) -> Res<Timed> {
    let tw = Instant::now();
    vl.render_preview(16, 16, 1.0)?;
    let warm = tw.elapsed().as_secs_f64();
    let (mut best, mut total, mut runs) = (f64::INFINITY, 0.0, 0);
    let mut img = None;
    // Fast renders are noisier: up to ten runs while they add up to half a second.
    while runs < 10 && ((runs < 3 && total < 2.0) || total < 0.5) {
        let t = Instant::now();
        let i = vl.render_preview(size, size, 1.0)?;
        let s = t.elapsed().as_secs_f64();
        best = best.min(s);
        total += s;
        runs += 1;
        img.get_or_insert(i);
    }
    Ok(Timed {
        img: img.expect("one run"),
        secs: best,
        runs,
        warm,
    })
}

/// Renders already made, by scene and settings: the sweeps share their baselines.
pub(crate) struct Cache {
    pub(crate) scene: String,
    pub(crate) done: std::collections::HashMap<String, Timed>,
}

impl Cache {
    pub(crate) fn new() -> Cache {
        Cache {
            scene: String::new(),
            done: Default::default(),
        }
    }

    /// Switches to another scene (renders of different scenes never match).
    pub(crate) fn scene(&mut self, name: &str) -> &mut Cache {
        self.scene = name.into();
        self
    }

    pub(crate) fn render(
        &mut self,
        make: &dyn Fn(Cfg) -> Res<Library>,
        cfg: Cfg,
        size: u32,
    ) -> Res<Timed> {
        let key = format!("{}/{cfg:?}/{size}", self.scene);
        if let Some(t) = self.done.get(&key) {
            return Ok(t.clone());
        }
        let t = render(&make(cfg)?, size)?;
        self.done.insert(key, t.clone());
        Ok(t)
    }
}

/// RMS and largest difference over all channels of all pixels, in 8-bit grey levels, computed
/// on the linear RGB values × 255 (no rounding); a non-finite value counts as an infinite error.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Err {
    pub(crate) rms: f64,
    pub(crate) max: f64,
}

pub(crate) fn error(a: &Image, b: &Image) -> Err {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let (mut sq, mut max, mut n) = (0.0f64, 0.0f64, 0usize);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            let d = (p[c] as f64 - q[c] as f64) * 255.0;
            let d = if d.is_finite() {
                d.abs()
            } else {
                f64::INFINITY
            };
            sq += d * d;
            max = max.max(d);
            n += 1;
        }
    }
    Err {
        rms: (sq / n as f64).sqrt(),
        max,
    }
}

pub(crate) fn non_finite(img: &Image) -> usize {
    img.pixels
        .iter()
        .filter(|p| p.iter().any(|v| !v.is_finite()))
        .count()
}

/// One measured setting of a sweep.
#[derive(Clone, Debug)]
pub(crate) struct Row {
    /// How the setting is written in tables.
    pub(crate) label: String,
    /// How it is written next to its point in a plot (ASCII).
    pub(crate) short: String,
    pub(crate) secs: f64,
    /// The warm-up frame's time (see [`Timed::warm`]).
    pub(crate) warm: f64,
    pub(crate) err: Err,
    /// Error against the finest value of the swept control alone (others unchanged).
    pub(crate) own: Option<Err>,
    /// Extra cells (sweep-specific).
    pub(crate) extra: Vec<String>,
    pub(crate) pareto: bool,
}

impl Row {
    /// The row of a render `r` with error `err`: no error against the control's own finest
    /// value, no extra cells, not (yet) on the Pareto front.
    pub(crate) fn of(label: String, short: String, r: &Timed, err: Err) -> Row {
        Row {
            label,
            short,
            secs: r.secs,
            warm: r.warm,
            err,
            own: None,
            extra: Vec::new(),
            pareto: false,
        }
    }
}

/// A sweep of one control on one scene.
#[derive(Clone, Debug)]
pub(crate) struct Series {
    pub(crate) scene: String,
    pub(crate) rows: Vec<Row>,
}

/// Timing noise: render times within this fraction of each other count as equal.
pub(crate) const TIME_TOL: f64 = 0.1;

/// Marks the rows no other row clearly beats: one that is no slower (within [`TIME_TOL`]) and
/// no less accurate (within 5 % or 0.01 grey levels), and clearly better in one of the two.
pub(crate) fn mark_pareto(rows: &mut [Row]) {
    let pts: Vec<(f64, f64)> = rows.iter().map(|r| (r.secs, r.err.rms)).collect();
    let eps = |e: f64| (0.05 * e).max(0.01);
    for (i, r) in rows.iter_mut().enumerate() {
        let (t, e) = pts[i];
        r.pareto = !pts.iter().enumerate().any(|(j, &(tj, ej))| {
            let no_worse = tj <= t * (1.0 + TIME_TOL) && ej <= e + eps(e);
            let better = tj < t * (1.0 - TIME_TOL) || ej < e - eps(e);
            j != i && no_worse && better
        });
    }
}

/// Marks the rows of a sweep whose settings all cost the same: the most accurate (within the
/// error tolerance of [`mark_pareto`]), whatever the measured times.
pub(crate) fn mark_pareto_equal_cost(rows: &mut [Row]) {
    let best = rows.iter().map(|r| r.err.rms).fold(f64::INFINITY, f64::min);
    for r in rows.iter_mut() {
        r.pareto = r.err.rms <= best + (0.05 * best).max(0.01);
    }
}

/// Saves an image as PNG into `$VLIB_ACCURACY_IMAGES`, when set (to look at the references).
pub(crate) fn save_debug(name: &str, img: &Image) -> Res<()> {
    if let Some(dir) = std::env::var_os("VLIB_ACCURACY_IMAGES") {
        let path = Path::new(&dir).join(format!("{name}.png"));
        vlib::write_image(&path, img.width, img.height, &img.to_rgb8())?;
    }
    Ok(())
}

/// Prints progress with the time since the start.
pub(crate) fn log(start: Instant, msg: impl AsRef<str>) {
    eprintln!("[{:6.1} s] {}", start.elapsed().as_secs_f64(), msg.as_ref());
}

/// Renders each setting, measures its error against `reference` and against the image of the
/// `own` setting (the finest value of the swept control, others unchanged), and marks the
/// Pareto front.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sweep(
    cache: &mut Cache,
    scene: &str,
    settings: &[(String, String, Cfg)],
    own: Option<Cfg>,
    make: &dyn Fn(Cfg) -> Res<Library>,
    reference: &Image,
    size: u32,
    start: Instant,
) -> Res<Series> {
    let mut rows = Vec::new();
    let mut images = Vec::new();
    for (label, short, cfg) in settings {
        let r = cache.render(make, *cfg, size)?;
        let bad = non_finite(&r.img);
        if bad > 0 {
            eprintln!("warning: {scene} {label}: {bad} non-finite pixels");
        }
        let err = error(&r.img, reference);
        log(
            start,
            format!(
                "{scene}: {label}: {:.3} s ({} runs), RMS {:.3}, max {:.1}",
                r.secs, r.runs, err.rms, err.max
            ),
        );
        rows.push(Row::of(label.clone(), short.clone(), &r, err));
        images.push(r.img);
    }
    if let Some(own) = own {
        let own_img = cache.render(make, own, size)?.img;
        for (row, img) in rows.iter_mut().zip(&images) {
            row.own = Some(error(img, &own_img));
        }
    }
    mark_pareto(&mut rows);
    Ok(Series {
        scene: scene.into(),
        rows,
    })
}

pub(crate) fn step_settings(steps: &[f32], base: Cfg, unit: &str) -> Vec<(String, String, Cfg)> {
    steps
        .iter()
        .map(|&s| {
            (
                format!("{s}{unit}"),
                format!("{s}"),
                Cfg { step: s, ..base },
            )
        })
        .collect()
}

pub(crate) fn ss_settings(rates: &[i32], base: Cfg) -> Vec<(String, String, Cfg)> {
    rates
        .iter()
        .map(|&n| {
            (
                if n == 1 {
                    "1 (off)".to_string()
                } else {
                    format!("{n}×{n}")
                },
                format!("{n}x{n}"),
                Cfg { ss: n, ..base },
            )
        })
        .collect()
}

pub(crate) fn filter_settings(filters: &[Filter], base: Cfg) -> Vec<(String, String, Cfg)> {
    filters
        .iter()
        .map(|&f| (f.name().to_string(), f.short().to_string(), base.filter(f)))
        .collect()
}
