//! Progress of a long step (reading a file, decompressing it, decoding slices, converting
//! voxels) as one line on standard error: the step's name, a bar, the fraction done, the amount
//! (bytes, slices or voxels), the time so far and the rate, redrawn at most ten times a second.
//!
//! The line is drawn only when standard error is a terminal (`std::io::IsTerminal`) and
//! `--quiet` is not given: piped or redirected, vlconvert writes no progress at all. The line
//! is transient: when its step ends, successfully or with an error (the [`Progress`] is dropped
//! either way), it is blanked out and the cursor returned to the start of the line, so what
//! follows (the report on standard output, an error message) starts on a clean line.
//!
//! A reader drives it with [`Progress::new`], [`Progress::advance`] and [`Progress::finish`],
//! or wraps its input in [`Reading`], which advances by the bytes read. What a line says for a
//! given state is [`line()`], a pure function.

use std::io::{IsTerminal, Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

#[cfg(test)]
mod tests;

/// Set by `--quiet`: no line is drawn.
static QUIET: AtomicBool = AtomicBool::new(false);

/// The shortest time between two redraws.
const INTERVAL: Duration = Duration::from_millis(100);

/// Turns progress lines off (`--quiet`) or back on.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// What a step counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    Bytes,
    Slices,
    Voxels,
}

/// One step's progress line (see the module documentation).
pub struct Progress {
    label: String,
    total: u64,
    done: u64,
    unit: Unit,
    start: Instant,
    /// When the line was last drawn.
    drawn: Option<Instant>,
    /// Characters of the line on the screen (0: nothing drawn).
    shown: usize,
    on: bool,
}

impl Progress {
    /// A step named `label` of `total` units; it draws nothing unless standard error is a
    /// terminal and progress is not quiet.
    pub fn new(label: impl Into<String>, total: u64, unit: Unit) -> Progress {
        Progress {
            label: label.into(),
            total,
            done: 0,
            unit,
            start: Instant::now(),
            drawn: None,
            shown: 0,
            on: !QUIET.load(Ordering::Relaxed) && std::io::stderr().is_terminal(),
        }
    }

    /// `n` more units done; redraws the line if the last drawing is 0.1 s old.
    pub fn advance(&mut self, n: u64) {
        self.done = self.done.saturating_add(n);
        if !self.on {
            return;
        }
        let now = Instant::now();
        if self.drawn.is_some_and(|t| now.duration_since(t) < INTERVAL) {
            return;
        }
        self.drawn = Some(now);
        let width = std::env::var("COLUMNS")
            .ok()
            .and_then(|c| c.parse().ok())
            .unwrap_or(80);
        let text = line(
            &self.label,
            self.done,
            self.total,
            self.unit,
            now.duration_since(self.start),
            width,
        );
        let len = text.chars().count();
        // Blank out what a longer previous line left.
        let pad = " ".repeat(self.shown.saturating_sub(len));
        let mut err = std::io::stderr().lock();
        // (A terminal that cannot take the line loses nothing but the line.)
        let _ = write!(err, "\r{text}{pad}");
        let _ = err.flush();
        self.shown = len;
    }

    /// The step is done: the line is blanked out.
    pub fn finish(self) {}

    fn clear(&mut self) {
        if self.shown > 0 {
            let mut err = std::io::stderr().lock();
            let _ = write!(err, "\r{}\r", " ".repeat(self.shown));
            let _ = err.flush();
            self.shown = 0;
        }
    }
}

impl Drop for Progress {
    /// On success ([`Progress::finish`]) and on an error alike, the line is blanked out.
    fn drop(&mut self) {
        self.clear();
    }
}

/// A reader that advances a [`Progress`] of bytes by what it reads.
pub struct Reading<R> {
    inner: R,
    bar: Progress,
}

impl<R> Reading<R> {
    pub fn new(inner: R, bar: Progress) -> Reading<R> {
        Reading { inner, bar }
    }
}

impl<R: Read> Read for Reading<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.bar.advance(n as u64);
        Ok(n)
    }
}

/// `n` units for a reader: bytes in KiB, MiB, GiB; counts of voxels in k, M, G.
fn amount(n: f64, unit: Unit) -> String {
    let (base, names): (f64, [&str; 4]) = match unit {
        Unit::Bytes => (1024.0, ["B", "KiB", "MiB", "GiB"]),
        Unit::Voxels => (1000.0, ["", "k", "M", "G"]),
        Unit::Slices => return format!("{n:.0}"),
    };
    let mut v = n;
    let mut i = 0;
    while v >= base && i < 3 {
        v /= base;
        i += 1;
    }
    if i == 0 {
        format!("{v:.0} {}", names[0]).trim_end().to_string()
    } else {
        format!("{v:.1} {}", names[i])
    }
}

/// The text of a progress line: `label` (shortened with … to fit), a bar, the percentage,
/// `done`/`total` units, the seconds since the start (`elapsed`) and the rate (once a
/// millisecond has passed, unless leaving it out makes room for the whole label and a bar of
/// 10), in
/// at most `width` − 1 characters (a line that filled the last
/// column would wrap on some terminals). A `total` of 0 counts as done; `done` beyond `total`
/// as `total`.
pub fn line(
    label: &str,
    done: u64,
    total: u64,
    unit: Unit,
    elapsed: Duration,
    width: usize,
) -> String {
    let fraction = if total == 0 {
        1.0
    } else {
        (done.min(total) as f64 / total as f64).clamp(0.0, 1.0)
    };
    let noun = match unit {
        Unit::Bytes => "",
        Unit::Slices => " slices",
        Unit::Voxels => " voxels",
    };
    let secs = elapsed.as_secs_f64();
    let rate = if secs >= 1e-3 {
        let per = done.min(total) as f64 / secs;
        match unit {
            Unit::Bytes => format!("  {}/s", amount(per, unit)),
            Unit::Slices => format!("  {per:.1} slices/s"),
            Unit::Voxels => format!("  {} voxels/s", amount(per, unit)),
        }
    } else {
        String::new()
    };
    let tail_with = |rate: &str| {
        format!(
            " {:>3}%  {}/{}{noun}  {secs:.1} s{rate}",
            (fraction * 100.0).floor() as u32,
            amount(done.min(total) as f64, unit),
            amount(total as f64, unit),
        )
    };
    // What is left for the label and the bar: "label [bar]".
    let room_for = |tail: &str| width.saturating_sub(1 + tail.chars().count() + 3);
    // The rate gives way when that makes room for the whole label and a bar of 10.
    let mut tail = tail_with(&rate);
    let needed = label.chars().count() + 10;
    if room_for(&tail) < needed && room_for(&tail_with("")) >= needed {
        tail = tail_with("");
    }
    let room = room_for(&tail);
    // The label whole where it fits beside a bar of 10; the bar takes what is left, up to 30.
    let bar_len = room.saturating_sub(label.chars().count()).clamp(10, 30);
    let label_room = room.saturating_sub(bar_len).max(8);
    let label: String = if label.chars().count() > label_room {
        let keep: String = label.chars().take(label_room - 1).collect();
        format!("{keep}…")
    } else {
        label.to_string()
    };
    let filled = ((fraction * bar_len as f64).floor() as usize).min(bar_len);
    let text = format!(
        "{label} [{}{}]{tail}",
        "#".repeat(filled),
        "-".repeat(bar_len - filled)
    );
    // A terminal too narrow for it all gets the start of it.
    text.chars().take(width.saturating_sub(1).max(1)).collect()
}
