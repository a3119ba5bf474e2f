//! A series' slices put in order, checked to form one regular grid, and placed.
//!
//! The order is by ImagePositionPatient projected on the slice normal (the cross product of
//! ImageOrientationPatient's row and column directions), ascending, so that node k + 1 lies
//! further along the normal than node k; InstanceNumber orders the slices only where a
//! position or the orientation is missing (and then there is no placement). Refused: slices
//! of different sizes, orientations or pixel spacings, two slices at one position, gaps
//! between slices that differ by more than [`gap_tolerance`] (a missing slice: the error names
//! the two slices of the gap furthest from the median gap), and positions off the line through
//! the first and last.
//!
//! The placement, in DICOM's LPS patient coordinates, maps node (i, j, k) (column, row,
//! slice) to P₀ + i·Δc·r + j·Δr·c + k·s: P₀ the first slice's position, r and c the row and
//! column directions, Δr and Δc the PixelSpacing (between rows, between columns), and s the
//! step from one slice's position to the next ((P_last − P₀)/(n − 1), so a gantry tilt gives
//! a sheared grid whose nodes lie where the files put them; for a single slice the normal
//! times its SliceThickness, or 1 mm). It is turned into RAS by negating x and y.

use super::slice::Slice;
use crate::vector::{cross, dot};

type Res<T> = Result<T, String>;

/// The slices in node order, and where they lie.
pub struct Stack {
    pub slices: Vec<Slice>,
    pub geometry: Option<vlib::Geometry>,
    /// What could not be placed, and why.
    pub notes: Vec<String>,
    /// How the slices were ordered and how far apart they lie.
    pub order: String,
}

/// Positions closer than this along the normal (mm) are one position.
const SAME: f64 = 1e-3;

/// Direction cosines that differ by more than this are different orientations.
const TURN: f64 = 1e-3;

/// How far (mm) a gap between neighbouring slices may differ from the mean gap `step`, and a
/// position from its place on the grid: 1 % of the step or 0.01 mm (two decimals, as
/// positions are often written), whichever is larger.
pub fn gap_tolerance(step: f64) -> f64 {
    (0.01 * step).max(0.01)
}

fn name(s: &Slice) -> String {
    s.path.display().to_string()
}

/// Orders `slices` (at least one, all of one series) and places them.
pub fn arrange(mut slices: Vec<Slice>) -> Res<Stack> {
    let first = slices.first().ok_or("no slices")?.clone();
    for s in &slices[1..] {
        if (s.rows, s.cols) != (first.rows, first.cols) {
            return Err(format!(
                "{}: {} × {} pixels (Columns × Rows), but {} has {} × {}: the slices of a \
                 series must be of one size",
                name(s),
                s.cols,
                s.rows,
                name(&first),
                first.cols,
                first.rows
            ));
        }
        if let (Some(a), Some(b)) = (s.spacing, first.spacing) {
            if (0..2).any(|i| (a[i] - b[i]).abs() > 1e-6 * b[i].abs()) {
                return Err(format!(
                    "{}: PixelSpacing {a:?}, but {}'s is {b:?}: the slices of a series must \
                     share one pixel spacing",
                    name(s),
                    name(&first)
                ));
            }
        }
        if let (Some(o), Some(o0)) = (s.orientation, first.orientation) {
            if (0..6).any(|i| (o[i] - o0[i]).abs() > TURN) {
                return Err(format!(
                    "{}: ImageOrientationPatient {o:?}, but {}'s is {o0:?}: the slices of a \
                     series must share one orientation",
                    name(s),
                    name(&first)
                ));
            }
        }
    }
    let mut notes = Vec::new();
    let unplaced = slices
        .iter()
        .find(|s| s.orientation.is_none() || s.position.is_none());
    let normal = match (unplaced, first.orientation) {
        (Some(s), _) => {
            notes.push(format!(
                "{}: no ImagePositionPatient or ImageOrientationPatient: the slices are \
                 ordered by InstanceNumber, and the volume converts without a placement",
                name(s)
            ));
            None
        }
        (None, Some(o)) => {
            let n = cross([o[0], o[1], o[2]], [o[3], o[4], o[5]]);
            let len = dot(n, n).sqrt();
            if len < 0.5 {
                notes.push(format!(
                    "ImageOrientationPatient {o:?} gives no slice normal (its directions are \
                     parallel or not unit vectors): the slices are ordered by InstanceNumber, \
                     and the volume converts without a placement"
                ));
                None
            } else {
                Some(n.map(|v| v / len))
            }
        }
        (None, None) => None,
    };
    let Some(n) = normal else {
        return by_instance(slices, notes);
    };
    let d = |s: &Slice| dot(n, s.position.expect("every slice has a position"));
    slices.sort_by(|a, b| {
        d(a).total_cmp(&d(b))
            .then(a.instance.cmp(&b.instance))
            .then(a.path.cmp(&b.path))
    });
    for w in slices.windows(2) {
        if d(&w[1]) - d(&w[0]) < SAME {
            return Err(format!(
                "{} and {} lie at one position ({:.4} mm along the slice normal): a series of one \
                 slice per position converts (two acquisitions in one series? put each in a \
                 folder of its own)",
                name(&w[0]),
                name(&w[1]),
                d(&w[0])
            ));
        }
    }
    let count = slices.len();
    let p0 = slices[0].position.expect("a position");
    let last = slices[count - 1].position.expect("a position");
    let (step, s) = if count > 1 {
        let k = (count - 1) as f64;
        (
            (d(&slices[count - 1]) - d(&slices[0])) / k,
            [0, 1, 2].map(|i| (last[i] - p0[i]) / k),
        )
    } else {
        let t = first.thickness.filter(|t| *t > 0.0).unwrap_or(1.0);
        (t, n.map(|v| v * t))
    };
    let tol = gap_tolerance(step);
    let gaps: Vec<f64> = slices.windows(2).map(|w| d(&w[1]) - d(&w[0])).collect();
    if gaps.iter().any(|gap| (gap - step).abs() > tol) {
        // The gap furthest from the median gap (of an even count, the lower middle one: a
        // missing slice widens a gap) is the one to name.
        let mut sorted = gaps.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[(sorted.len() - 1) / 2];
        let far = |k: usize| (gaps[k] - median).abs();
        let k = (0..gaps.len())
            .max_by(|&i, &j| far(i).total_cmp(&far(j)).then(j.cmp(&i)))
            .expect("a gap");
        return Err(format!(
            "the slices are not evenly spaced: from {} to {} is {:.4} mm along the slice \
             normal, but the median gap is {median:.4} mm (a slice missing? the gaps may \
             differ from their mean, {step:.4} mm, by {tol:.4} mm)",
            name(&slices[k]),
            name(&slices[k + 1]),
            gaps[k]
        ));
    }
    for (k, sl) in slices.iter().enumerate() {
        let p = sl.position.expect("a position");
        let off = [0, 1, 2].map(|i| p[i] - p0[i] - k as f64 * s[i]);
        let off = dot(off, off).sqrt();
        if off > tol {
            return Err(format!(
                "{}: ImagePositionPatient {p:?} lies {off:.4} mm off the line through the first \
                 and last slices' positions: the slices do not form a regular grid",
                name(sl)
            ));
        }
    }
    let order = format!(
        "slices ordered by ImagePositionPatient along the slice normal ({:.4}, {:.4}, {:.4}) \
         (LPS), {step:.4} mm apart",
        n[0], n[1], n[2]
    );
    let geometry = match placement(&slices, s) {
        Ok(g) => Some(g),
        Err(e) => {
            notes.push(format!("{e}: the volume converts without a placement"));
            None
        }
    };
    Ok(Stack {
        slices,
        geometry,
        notes,
        order,
    })
}

/// The placement of `slices` (in order, with positions, one orientation and one pixel spacing
/// where they have one) whose positions step by `s`, in RAS.
fn placement(slices: &[Slice], s: [f64; 3]) -> Res<vlib::Geometry> {
    let first = &slices[0];
    if let Some(sl) = slices.iter().find(|sl| sl.spacing.is_none()) {
        return Err(format!("{}: no PixelSpacing", name(sl)));
    }
    let [dr, dc] = first.spacing.expect("a pixel spacing");
    if !(dr > 0.0 && dc > 0.0) {
        return Err(format!("PixelSpacing [{dr}, {dc}]: both must be positive"));
    }
    let o = first.orientation.expect("an orientation");
    let p = first.position.expect("a position");
    let columns = [
        [o[0] * dc, o[1] * dc, o[2] * dc],
        [o[3] * dr, o[4] * dr, o[5] * dr],
        s,
        p,
    ];
    // LPS to RAS: x and y change sign.
    let flip = [-1.0, -1.0, 1.0];
    let row = |r: usize| columns.map(|c| c[r] * flip[r]);
    vlib::Geometry::new([row(0), row(1), row(2)]).map_err(|e| e.message)
}

/// Orders `slices` by InstanceNumber (no placement).
fn by_instance(mut slices: Vec<Slice>, notes: Vec<String>) -> Res<Stack> {
    if slices.len() > 1 {
        if let Some(s) = slices.iter().find(|s| s.instance.is_none()) {
            return Err(format!(
                "{}: neither ImagePositionPatient and ImageOrientationPatient nor \
                 InstanceNumber: the slices cannot be ordered",
                name(s)
            ));
        }
    }
    slices.sort_by(|a, b| a.instance.cmp(&b.instance).then(a.path.cmp(&b.path)));
    for w in slices.windows(2) {
        if w[0].instance == w[1].instance {
            return Err(format!(
                "{} and {} have one InstanceNumber ({}) and no position: the slices cannot be \
                 ordered",
                name(&w[0]),
                name(&w[1]),
                w[0].instance.unwrap_or_default()
            ));
        }
    }
    Ok(Stack {
        slices,
        geometry: None,
        notes,
        order: "slices ordered by InstanceNumber".into(),
    })
}
