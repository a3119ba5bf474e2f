//! Where a dataset's nodes lie in physical space, carried beside its `.vlb` file (whose header
//! the paper fixes) in a sidecar: `NAME.vlb.geom`, a few lines of text written by `vlconvert`
//! from the source's own geometry (NIfTI's sform or qform, NRRD's space directions and origin),
//! read by [`crate::Dataset::load`] when present: a sidecar that cannot be read, is larger
//! than 64 KiB or does not parse makes the load fail with its reason (`VL_IOERROR`,
//! `VL_BADVALUE`, `VL_BADFILE`), so keep it with its file or remove it.
//!
//! ```text
//! vlib-geometry 1
//! # node (i, j, k) lies at (x, y, z) = A · (i, j, k) + t, in millimetres, RAS
//! dims 240 240 60
//! row 0.5 0 0 -60
//! row 0 0.5 0 -60
//! row 0 0 2 -30
//! ```
//!
//! `dims` is the grid the sidecar describes: a sidecar beside a file of another grid (left
//! there by an earlier file of the name) is refused at load. Each `row` is a row of [A | t]:
//! world x, y and z as functions of the node index. The world
//! is RAS (+x the subject's right, +y anterior, +z superior), NIfTI's convention; LPS and LAS
//! sources (NRRD's `left-posterior-superior`) are turned into it. The module owns the
//! format and its checks; placing an object by it is the API's (`Library::place_dataset`).

use crate::error::{Error, ErrorCode, Result};
use std::path::{Path, PathBuf};

/// A dataset's physical placement: node (i, j, k) at `affine · (i, j, k, 1)`, millimetres, RAS.
///
/// Made only by [`Geometry::new`] and [`Geometry::axis_aligned`], which accept what a sidecar
/// may hold (finite numbers, axes that are not degenerate): every `Geometry` a dataset carries
/// is one [`crate::Dataset::save`] can write and [`crate::Dataset::load`] reads back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// The rows of [A | t].
    affine: [[f64; 4]; 3],
}

/// The first line of a geometry sidecar.
const MAGIC_LINE: &str = "vlib-geometry 1";

impl Geometry {
    /// Spacing `s` along each axis and origin `o`, axes along x, y, z: [`Geometry::new`] of
    /// that affine, so `BadValue` for a number that is not finite or a spacing of 0.
    pub fn axis_aligned(s: [f64; 3], o: [f64; 3]) -> Result<Geometry> {
        Geometry::new([
            [s[0], 0.0, 0.0, o[0]],
            [0.0, s[1], 0.0, o[1]],
            [0.0, 0.0, s[2], o[2]],
        ])
    }

    /// The rows of [A | t]: node (i, j, k) lies at A · (i, j, k) + t.
    pub fn affine(&self) -> [[f64; 4]; 3] {
        self.affine
    }

    /// A geometry whose numbers are finite and whose A is invertible, or `BadValue`: |det A|
    /// must exceed 10⁻¹² times the product of A's columns' lengths (the spacings). Spacings so
    /// far from 1 that their squares or that product leave f64's range (about 10⁻¹⁰⁰ or
    /// 10¹⁰⁰ and beyond) fail the test too, as they would fail an object transform's
    /// (`place_dataset`).
    pub fn new(affine: [[f64; 4]; 3]) -> Result<Geometry> {
        let g = Geometry { affine };
        let invalid =
            |why: &str| Error::new(ErrorCode::BadValue, format!("dataset geometry: {why}"));
        if !affine.iter().flatten().all(|v| v.is_finite()) {
            return Err(invalid("a number is not finite"));
        }
        let a = |r: usize, c: usize| affine[r][c];
        let det = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
            - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
            + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
        let scale: f64 = g.spacing().iter().product();
        if det.is_nan() || det.abs() <= 1e-12 * scale {
            return Err(invalid("its axes are degenerate (determinant 0)"));
        }
        Ok(g)
    }

    /// The distance between neighbouring nodes along each index axis (the columns' lengths).
    pub fn spacing(&self) -> [f64; 3] {
        let col = |c: usize| {
            (0..3)
                .map(|r| self.affine[r][c].powi(2))
                .sum::<f64>()
                .sqrt()
        };
        [col(0), col(1), col(2)]
    }

    /// Where node (0, 0, 0) lies.
    pub fn origin(&self) -> [f64; 3] {
        [self.affine[0][3], self.affine[1][3], self.affine[2][3]]
    }

    /// The sidecar file of the dataset file `path`: `path` with `.geom` appended.
    pub fn sidecar(path: &Path) -> PathBuf {
        let mut p = path.as_os_str().to_owned();
        p.push(".geom");
        PathBuf::from(p)
    }

    /// The sidecar's text, for a dataset of `dims` nodes.
    pub fn to_text(&self, dims: [usize; 3]) -> String {
        let mut s = format!(
            "{MAGIC_LINE}\n# node (i, j, k) lies at (x, y, z) = A · (i, j, k) + t, in millimetres, RAS\n\
             dims {} {} {}\n",
            dims[0], dims[1], dims[2]
        );
        for row in &self.affine {
            s.push_str(&format!(
                "row {} {} {} {}\n",
                row[0], row[1], row[2], row[3]
            ));
        }
        s
    }

    /// Parses the sidecar of a dataset of `dims` nodes; `BadFile` with the reason for
    /// anything else, a sidecar of another grid among them.
    pub fn parse(text: &str, dims: [usize; 3]) -> Result<Geometry> {
        let mut lines = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('#'));
        if lines.next() != Some(MAGIC_LINE) {
            return Err(bad(format!("its first line is not {MAGIC_LINE:?}")));
        }
        let grid = lines.next().unwrap_or("");
        let said: Vec<&str> = grid.split_whitespace().collect();
        let want: Vec<String> = dims.iter().map(|d| d.to_string()).collect();
        if said.first() != Some(&"dims") || said[1..] != want {
            return Err(bad(format!(
                "{grid:?} is not `dims {} {} {}`, the grid of the dataset beside it",
                dims[0], dims[1], dims[2]
            )));
        }
        let mut affine = [[0.0; 4]; 3];
        for row in &mut affine {
            let line = lines
                .next()
                .ok_or_else(|| bad("fewer than 3 rows".into()))?;
            let words: Vec<&str> = line.split_whitespace().collect();
            if words.len() != 5 || words[0] != "row" {
                return Err(bad(format!("{line:?} is not `row` and 4 numbers")));
            }
            for (v, w) in row.iter_mut().zip(&words[1..]) {
                *v = w
                    .parse()
                    .map_err(|_| bad(format!("{w:?} is not a number")))?;
            }
        }
        if let Some(extra) = lines.next() {
            return Err(bad(format!("{extra:?} after the 3 rows")));
        }
        Geometry::new(affine).map_err(|e| Error::new(ErrorCode::BadFile, e.message))
    }
}

fn bad(why: String) -> Error {
    Error::new(ErrorCode::BadFile, format!("dataset geometry: {why}"))
}
