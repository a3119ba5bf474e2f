//! The study's document: Markdown tables and plots of the sweeps, the machine it ran on, and
//! the replacement of the study's marked section of `docs/accuracy.md`.

use super::*;

pub(crate) fn ms(secs: f64) -> String {
    let ms = secs * 1e3;
    if ms >= 100.0 {
        format!("{ms:.0}")
    } else if ms >= 10.0 {
        format!("{ms:.1}")
    } else {
        format!("{ms:.2}")
    }
}

pub(crate) fn g(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if !v.is_finite() {
        "∞".into()
    } else if v >= 100.0 {
        format!("{v:.0}")
    } else if v >= 10.0 {
        format!("{v:.1}")
    } else if v >= 0.01 {
        format!("{v:.2}")
    } else {
        format!("{v:.1e}")
    }
}

/// A Markdown table of one or more sweeps of a control.
pub(crate) fn table(
    doc: &mut String,
    control: &str,
    series: &[Series],
    own_header: &str,
    extra: &[&str],
) {
    for s in series {
        let _ = writeln!(doc, "\n*{}*\n", s.scene);
        let mut header = format!("| {control} | time (ms) | RMS error | max error |");
        let mut rule = String::from("|---|---:|---:|---:|");
        if s.rows.iter().any(|r| r.own.is_some()) {
            let _ = write!(header, " {own_header} |");
            rule.push_str("---:|");
        }
        for e in extra {
            let _ = write!(header, " {e} |");
            rule.push_str("---:|");
        }
        header.push_str(" Pareto |");
        rule.push_str(":---:|");
        let _ = writeln!(doc, "{header}\n{rule}");
        for r in &s.rows {
            let mut line = format!(
                "| {} | {} | {} | {} |",
                r.label,
                ms(r.secs),
                g(r.err.rms),
                g(r.err.max)
            );
            if let Some(o) = r.own {
                let _ = write!(line, " {} |", g(o.rms));
            }
            for e in &r.extra {
                let _ = write!(line, " {e} |");
            }
            line.push_str(if r.pareto { " ★ |" } else { " |" });
            let _ = writeln!(doc, "{line}");
        }
    }
}

/// The plot of a control: one series per scene.
pub(crate) fn plot_control(p: &Params, name: &str, title: &str, series: &[Series]) -> Res<String> {
    let sweep = name != "combined";
    let file = format!("accuracy-{name}.png");
    let ps: Vec<plot::Series> = series
        .iter()
        .enumerate()
        .map(|(i, s)| plot::Series {
            name: s.scene.split(" (").next().unwrap_or_default().to_string(),
            colour: plot::PALETTE[i % plot::PALETTE.len()],
            points: s
                .rows
                .iter()
                .map(|r| plot::Point {
                    x: r.secs,
                    y: r.err.rms,
                    label: r.short.clone(),
                    pareto: r.pareto,
                })
                .collect(),
            sweep,
        })
        .collect();
    plot::draw(&p.out_dir.join(&file), title, &ps)?;
    Ok(file)
}

/// Today's date (UTC) as YYYY-MM-DD.
pub(crate) fn today() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    // Howard Hinnant's civil_from_days.
    let z = secs.div_euclid(86_400) + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

pub(crate) fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

pub(crate) fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "?".into())
}

/// Replaces the marked section of `docs/accuracy.md` (or appends it).
pub(crate) fn write_section(path: &Path, body: &str) -> Res<()> {
    let doc = std::fs::read_to_string(path).unwrap_or_default();
    let (begin, end) = ("<!-- study:begin -->", "<!-- study:end -->");
    let block = format!("{begin}\n{body}{end}");
    let new = match (doc.find(begin), doc.find(end)) {
        (Some(a), Some(b)) if a < b => format!("{}{block}{}", &doc[..a], &doc[b + end.len()..]),
        _ => format!("{}\n\n{block}\n", doc.trim_end()),
    };
    vlib::write_atomic(path, new.as_bytes())?;
    Ok(())
}
