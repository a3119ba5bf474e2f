//! The entry map's projection of boxes: each box's eight corners through a pinhole camera to a
//! pixel rectangle and a smallest depth ([`Mark`]), eight boxes at a time in f64 lanes (AVX2
//! registers where the processor has them, else the SSE2 baseline's), the same numbers as one
//! box at a time. Owns the arithmetic of a box and the choice of instruction set; which boxes
//! are projected, the refusals that depend on the whole image and the filing of the marks by
//! bins are `entry`'s.

use super::entry::Mark;
use super::grid::Boxes;
use glam::{DMat3, DMat4, DVec3};

/// What the projection of a box needs of the object's transform and the camera: a box's
/// corners are lo + (a·e.x, b·e.y, c·e.z) for a, b, c in {0, 1} (e = hi − lo), and their
/// eye-relative vectors q, view coefficients v (depth, right, up: the rays' own basis) and
/// depths q·forward are affine in the object point, so each corner's numbers are the lowest
/// corner's plus the terms of its axes: a box costs the products of one corner and three
/// edges, not of eight corners. (Rounding differs from transforming each corner by a few
/// units in the last place, far inside the eighth of a unit each box is grown by.)
pub(super) struct Projection {
    /// How much each box is grown on every side.
    margin: DVec3,
    /// Of the quantities q.x, q.y, q.z, v.x, v.y, v.z and the depth: the value at the object's
    /// origin, and per object axis the coefficient of the point's coordinate.
    origin: [f64; QUANTITIES],
    coef: [[f64; 3]; QUANTITIES],
    /// The image's size in pixels.
    width: f64,
    height: f64,
}

/// The quantities a corner needs: its eye-relative vector, its view coefficients, its depth.
const QUANTITIES: usize = 7;

/// Pixel squares [px, px + 1) meeting a corners' rectangle grown by this much (pixels) are
/// marked.
const EPS: f64 = 0.01;

impl Projection {
    /// The projection through `camera` of boxes in the object space of `to_world`, each grown
    /// by `margin` on every side; `None` for a singular or non-finite camera basis.
    pub(super) fn new(to_world: DMat4, camera: &super::Pinhole, margin: DVec3) -> Option<Self> {
        let basis = DMat3::from_cols(camera.forward, camera.right, camera.up);
        let det = basis.determinant().abs();
        if det.is_nan() || det <= 1e-12 {
            return None;
        }
        let to_view = basis.inverse();
        let unit_forward = camera.forward.normalize_or_zero();
        let axes = [
            to_world.x_axis.truncate(),
            to_world.y_axis.truncate(),
            to_world.z_axis.truncate(),
        ];
        let origin_q = to_world.w_axis.truncate() - camera.eye;
        let origin_v = to_view * origin_q;
        let view_axes = axes.map(|a| to_view * a);
        let mut origin = [0.0; QUANTITIES];
        let mut coef = [[0.0; 3]; QUANTITIES];
        for c in 0..3 {
            origin[c] = origin_q[c];
            origin[3 + c] = origin_v[c];
            coef[c] = axes.map(|a| a[c]);
            coef[3 + c] = view_axes.map(|a| a[c]);
        }
        origin[6] = origin_q.dot(unit_forward);
        coef[6] = axes.map(|a| a.dot(unit_forward));
        Some(Projection {
            margin,
            origin,
            coef,
            width: camera.width as f64,
            height: camera.height as f64,
        })
    }

    /// Appends to `out` the marks of boxes `range` of `boxes` that meet the image, in order;
    /// false (giving up: no map) at a box with a corner not clearly in front of the eye or a
    /// corner whose image position is not finite, `out` then holding any part.
    pub(super) fn marks(
        &self,
        boxes: &Boxes,
        range: std::ops::Range<usize>,
        out: &mut Vec<Mark>,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            /// The boxes in AVX2 registers, four lanes of f64 each. (AVX-512's eight lanes
            /// were slower on the machine measured: their divisions are the bound.)
            #[target_feature(enable = "avx2")]
            fn avx2(
                p: &Projection,
                b: &Boxes,
                r: std::ops::Range<usize>,
                o: &mut Vec<Mark>,
            ) -> bool {
                p.marks_generic(b, r, o)
            }
            if is_x86_feature_detected!("avx2") {
                // SAFETY: AVX2 was detected.
                return unsafe { avx2(self, boxes, range, out) };
            }
        }
        self.marks_generic(boxes, range, out)
    }

    /// [`Projection::marks`], compiled with its caller's instruction set: eight boxes at a
    /// time, one to a lane of plain arrays that the compiler vectorises, each box by the
    /// operations of `Projection::mark` (one box at a time, the tests' reference) in its
    /// order (no operation fused or reordered), so every instruction set gives the same
    /// numbers as `mark` (but for the sign of a zero depth, which `f64::min` leaves open and
    /// which compares equal).
    #[inline(always)]
    pub(super) fn marks_generic(
        &self,
        boxes: &Boxes,
        range: std::ops::Range<usize>,
        out: &mut Vec<Mark>,
    ) -> bool {
        let (start, end) = (range.start, range.end);
        let mut at = start;
        while at < end {
            // Eight boxes (the last ones repeated past the end, their marks not kept).
            let mut lanes = [(DVec3::ZERO, DVec3::ZERO); LANES];
            for (l, b) in lanes.iter_mut().enumerate() {
                *b = boxes.corners((at + l).min(end - 1));
            }
            let Some(marks) = self.lanes(&lanes) else {
                return false;
            };
            let kept = (end - at).min(LANES);
            out.extend(marks.into_iter().take(kept).flatten());
            at += LANES;
        }
        true
    }

    /// `Projection::mark` of eight boxes, one to a lane: `None` where any of them gives up.
    /// (Plain loops over the lanes, no closures or `array::map`: the compiler calls those
    /// instead of inlining them into the caller's target features, its arrays spilled around
    /// each call.)
    #[inline(always)]
    fn lanes(&self, boxes: &[(DVec3, DVec3); LANES]) -> Option<[Option<Mark>; LANES]> {
        // Each box's lowest corner and edges, grown by the margin.
        let mut lo = [[0.0; LANES]; 3];
        let mut e = [[0.0; LANES]; 3];
        for (l, (b_lo, b_hi)) in boxes.iter().enumerate() {
            for a in 0..3 {
                lo[a][l] = b_lo[a] - self.margin[a];
                e[a][l] = (b_hi[a] + self.margin[a]) - lo[a][l];
            }
        }
        let (origin, coef) = (&self.origin, &self.coef);
        // At the lowest corner, and along each edge.
        let mut base = [[0.0; LANES]; QUANTITIES];
        let mut edge = [[[0.0; LANES]; 3]; QUANTITIES];
        for j in 0..QUANTITIES {
            for l in 0..LANES {
                base[j][l] = origin[j]
                    + coef[j][0] * lo[0][l]
                    + coef[j][1] * lo[1][l]
                    + coef[j][2] * lo[2][l];
                for a in 0..3 {
                    edge[j][a][l] = coef[j][a] * e[a][l];
                }
            }
        }
        let (mut x0, mut x1) = ([f64::INFINITY; LANES], [f64::NEG_INFINITY; LANES]);
        let (mut y0, mut y1) = ([f64::INFINITY; LANES], [f64::NEG_INFINITY; LANES]);
        let mut near = [f64::INFINITY; LANES];
        // All ones in a lane while its box's corners are all in front and finite: a mask of
        // the lanes' own width, which the compiler keeps in vector registers.
        let mut ok = [u64::MAX; LANES];
        for k in 0..8 {
            // Corner k: the edges of the bits of k added in axis order.
            let mut c = base;
            for (c, edge) in c.iter_mut().zip(&edge) {
                for (a, edge) in edge.iter().enumerate() {
                    if k >> a & 1 != 0 {
                        for (c, d) in c.iter_mut().zip(edge) {
                            *c += d;
                        }
                    }
                }
            }
            for l in 0..LANES {
                let (qx, qy, qz) = (c[0][l], c[1][l], c[2][l]);
                let (vx, vy, vz, n) = (c[3][l], c[4][l], c[5][l], c[6][l]);
                let q2 = qx * qx + qy * qy + qz * qz;
                let x = (vy / vx + 1.0) * 0.5 * self.width;
                let y = (1.0 - vz / vx) * 0.5 * self.height;
                // Clearly in front, and finite (`Projection::mark`).
                let good = (vx > 0.0)
                    & (vx * vx > 1e-18 * q2)
                    & (x.abs() < f64::INFINITY)
                    & (y.abs() < f64::INFINITY);
                ok[l] &= if good { u64::MAX } else { 0 };
                // `x0.min(x)` and the like, by comparisons: where the box is kept neither side
                // is NaN (x and y are finite; the bounds start at ±∞ and only take them), and
                // the two agree on ties, as neither x nor y can be −0: `r + 1` and `1 − r`
                // round to +0, never −0, and when not 0 are at least 2⁻⁵³ in magnitude, which
                // halving and the image size (≥ 1) cannot take to 0. The depth's ignores NaN,
                // as `f64::min` does.
                x0[l] = if x < x0[l] { x } else { x0[l] };
                x1[l] = if x > x1[l] { x } else { x1[l] };
                y0[l] = if y < y0[l] { y } else { y0[l] };
                y1[l] = if y > y1[l] { y } else { y1[l] };
                near[l] = if n < near[l] { n } else { near[l] };
            }
        }
        let mut all = u64::MAX;
        for ok in ok {
            all &= ok;
        }
        if all == 0 {
            return None;
        }
        let mut marks = [const { None }; LANES];
        for (l, m) in marks.iter_mut().enumerate() {
            *m = self.rectangle((x0[l], x1[l]), (y0[l], y1[l]), near[l]);
        }
        Some(marks)
    }

    /// The mark of the box [lo, hi] grown by the margin: `Some(None)` off the image, `None` to
    /// give up (a corner not clearly in front of the eye, whose projection is then not the
    /// hull of the corners', or an image position that is not finite). One box at a time: the
    /// reference the lanes of [`Projection::marks`] are tested against.
    #[cfg(test)]
    pub(super) fn mark(&self, lo: DVec3, hi: DVec3) -> Option<Option<Mark>> {
        let (lo, hi) = (lo - self.margin, hi + self.margin);
        let e = hi - lo;
        let vector = |j: usize| DVec3::new(self.origin[j], self.origin[j + 1], self.origin[j + 2]);
        let axis = |j: usize, a: usize| {
            DVec3::new(self.coef[j][a], self.coef[j + 1][a], self.coef[j + 2][a])
        };
        let axes = [0, 1, 2].map(|a| axis(0, a));
        let view_axes = [0, 1, 2].map(|a| axis(3, a));
        let depth_axes = self.coef[6];
        let q0 = vector(0) + axes[0] * lo.x + axes[1] * lo.y + axes[2] * lo.z;
        let v0 = vector(3) + view_axes[0] * lo.x + view_axes[1] * lo.y + view_axes[2] * lo.z;
        let n0 =
            self.origin[6] + depth_axes[0] * lo.x + depth_axes[1] * lo.y + depth_axes[2] * lo.z;
        let dq = [axes[0] * e.x, axes[1] * e.y, axes[2] * e.z];
        let dv = [view_axes[0] * e.x, view_axes[1] * e.y, view_axes[2] * e.z];
        let dn = [
            depth_axes[0] * e.x,
            depth_axes[1] * e.y,
            depth_axes[2] * e.z,
        ];
        let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut near = f64::INFINITY;
        for k in 0..8 {
            let (mut q, mut v, mut n) = (q0, v0, n0);
            for (a, ((dq, dv), dn)) in dq.iter().zip(&dv).zip(&dn).enumerate() {
                if k >> a & 1 != 0 {
                    q += *dq;
                    v += *dv;
                    n += dn;
                }
            }
            // Clearly in front (a corner at or behind the eye's plane breaks the hull
            // argument): v.x > 10⁻⁹·|q|, squared (v.x positive first); NaN fails too.
            if !(v.x > 0.0 && v.x * v.x > 1e-18 * q.length_squared()) {
                return None;
            }
            let (x, y) = (
                (v.y / v.x + 1.0) * 0.5 * self.width,
                (1.0 - v.z / v.x) * 0.5 * self.height,
            );
            if !(x.is_finite() && y.is_finite()) {
                return None;
            }
            (x0, x1) = (x0.min(x), x1.max(x));
            (y0, y1) = (y0.min(y), y1.max(y));
            near = near.min(n);
        }
        Some(self.rectangle((x0, x1), (y0, y1), near))
    }

    /// The mark of corners whose image positions span `x` and `y` (finite) and whose least
    /// depth is `near`: the pixel squares [px, px + 1) meeting [x0 − ε, x1 + ε] (and likewise
    /// in y); `None` off the image.
    #[inline(always)]
    fn rectangle(&self, x: (f64, f64), y: (f64, f64), near: f64) -> Option<Mark> {
        // (The floor inline, bit for bit the library's, which is a call on the SSE2 baseline.)
        let floor = crate::num::floor;
        let (wf, hf) = (self.width, self.height);
        let (px0, px1) = (floor(x.0 - EPS).max(0.0), floor(x.1 + EPS).min(wf - 1.0));
        let (py0, py1) = (floor(y.0 - EPS).max(0.0), floor(y.1 + EPS).min(hf - 1.0));
        if px0 > px1 || py0 > py1 {
            return None;
        }
        Some(Mark::new(
            (px0 as usize, px1 as usize),
            (py0 as usize, py1 as usize),
            // Rounding of the depth itself: a relative slack far below the margin's.
            near - 1e-9 * near.abs(),
        ))
    }
}

/// Boxes projected at a time, one to a lane.
const LANES: usize = 8;
