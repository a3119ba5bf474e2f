//! The pre-integrated march of one scanned volume ([`Compiled::march_preintegrated`]): the
//! ray's samples are the cursor's midpoints, as in every march, but what is composited are the
//! *slabs* between consecutive samples, each with the opacity and colour of
//! [`PreIntegrated`] for the values at its two ends, so that a value varying linearly along a
//! slab is integrated exactly, whatever the step (`docs/accuracy.md`, pre-integration). Where
//! the data bends within a slab that can have opacity (the value at its middle off the mean of
//! its ends by more than [`REFINE_TOLERANCE`]), the slab is cut in two halves at its middle,
//! each taken the same way, down to a quarter of the step: a surface is placed by the data, not
//! by a straight line through two samples a step apart. The tables are `preint`'s; the lighting
//! is `shade`'s, applied to each slab's mean colour where its light comes from.

use crate::model::program::clamp_field;
use crate::render::preint::{PreIntegrated, REFINE_LEVELS, REFINE_TOLERANCE};
use crate::render::*;

impl Compiled {
    /// [`Compiled::march_one`] of a direct-shading program (see [`PreIntegrated`]) with its
    /// tables `pre`: the slabs between consecutive samples front to back, plus half a segment
    /// before the first sample and after the last (from and to the interval's ends, whose
    /// values are read there too: one segment is two half slabs). A sample the skipping
    /// passes over (an empty block, before the entry map's bound) has a value at most the
    /// zero test's bound z: a slab between two of them, and any slab whose two values are at
    /// most z, adds nothing (the opacity table is 0 on [0, z]) and is not cut; a slab between a sample taken
    /// and one passed over reads the latter's value. A slab whose two values are equal is a
    /// constant medium: [`CObj::alpha`] of the tables' values, exactly the midpoint march's
    /// sample.
    #[allow(clippy::too_many_arguments)]
    pub(in crate::render) fn march_preintegrated(
        &self,
        obj: &CObj,
        pre: &PreIntegrated,
        data: &Dataset,
        z: f32,
        c: &mut Cursor,
        origin: DVec3,
        dir: DVec3,
    ) -> (DVec3, f64) {
        let grid = obj.skip.as_deref();
        let shading = &pre.shading;
        let [ka, kd, ks, spec] = shading.coefficients;
        let (k, e) = ([ka, kd, ks], Specular::of_field(spec));
        let headlit = Headlit::new(self, obj, dir, k, e);
        let mut cache = CellGradients::default();
        let mut acc = Integral::new(self);
        let (n, step) = (c.n, obj.step);
        // The object-space ray (`Cursor::object_point` without borrowing the cursor).
        let (ro, rd) = (c.o, c.d);
        let point = |t: f64| ray_point(ro, rd, t);
        let value = |t: f64| clamp_field(data.trilinear(point(t)));
        // Composites the slab from ray parameter ta (value va) to tb (value vb), of level
        // `level` (1/2^level of the step, or another length); whether the ray ends there.
        let mut piece =
            |acc: &mut Integral, level: u32, ta: f64, va: f32, tb: f64, vb: f32| -> bool {
                let len = tb - ta;
                if len.is_nan() || len <= 0.0 || (va <= z && vb <= z) {
                    return false;
                }
                // The slab's α, mean colour and the fraction of its length where it is lit.
                let (alpha, rgb, at) = if va == vb {
                    // A constant medium: the midpoint march's sample, bit for bit.
                    let (o, Some(rgb)) = shading.opacity_colour(va) else {
                        return false;
                    };
                    (obj.alpha(o as f64, len), rgb.map(|x| x as f64), 0.5)
                } else {
                    // (Midpoints one step apart differ by the step to rounding: a relative 10⁻⁹
                    // of κ changes α far below f32's resolution.)
                    let part = step / (1u32 << level) as f64;
                    let [a, r, g, b, depth] = if (len - part).abs() <= part * 1e-9 {
                        pre.lookup(level, va, vb)
                    } else {
                        pre.integrate(va, vb, len * obj.inv_ref)
                    };
                    if a.is_nan() || a <= 0.0 {
                        return false;
                    }
                    // The slab's mean colour (its premultiplied colour over its α), in [0, 1]
                    // against rounding.
                    let a = a.min(1.0);
                    (
                        a as f64,
                        [r, g, b].map(|x| (x / a).clamp(0.0, 1.0) as f64),
                        (depth / a).clamp(0.0, 1.0) as f64,
                    )
                };
                let c = DVec3::from_array(rgb);
                let tm = ta + at * len;
                let (p, w) = (point(tm), origin + tm * dir);
                let normal = || obj.gradient_normal(w, -dir, p, 9, &mut cache);
                let lit = match &headlit {
                    Some(h) => h.colour(c, normal),
                    None => self.illuminate_colour(obj, w, dir, c, k, e, normal),
                };
                acc.add(alpha, lit)
            };
        // Composites the slab from ta (value va) to tb (value vb), halved where the data is not
        // linear along it: where its value can reach the opacity table's non-zero part and the
        // value at its middle is off the mean of its ends by more than the tolerance, each half
        // is taken in turn, front first, down to REFINE_LEVELS halvings.
        let mut slab = |acc: &mut Integral, ta: f64, va: f32, tb: f64, vb: f32| -> bool {
            if va <= z && vb <= z {
                return false;
            }
            // The halves still to take, the front one last: (ta, va, tb, vb, level).
            let mut todo = [(0.0, 0.0, 0.0, 0.0, 0); REFINE_LEVELS as usize + 1];
            todo[0] = (ta, va, tb, vb, 0u32);
            let mut n = 1;
            while n > 0 {
                n -= 1;
                let (a, x, b, y, level) = todo[n];
                if level < REFINE_LEVELS && (x > z || y > z) {
                    let m = 0.5 * (a + b);
                    let vm = value(m);
                    if (vm - 0.5 * (x + y)).abs() > REFINE_TOLERANCE {
                        todo[n] = (m, vm, b, y, level + 1);
                        todo[n + 1] = (a, x, m, vm, level + 1);
                        n += 2;
                        continue;
                    }
                }
                if piece(acc, level, a, x, b, y) {
                    return true;
                }
            }
            false
        };
        // The last sample taken: its number, ray parameter and value.
        let mut last: Option<(u64, f64, f32)> = None;
        while let Some(mid) = c.peek(grid) {
            let i = c.k;
            c.take();
            let v = value(mid);
            let ends = match last {
                // The slab from the previous sample.
                Some((j, tj, vj)) if j + 1 == i => slab(&mut acc, tj, vj, mid, v),
                // Samples passed over between: the slab after the last one taken and the one
                // before this one, reading the values of the samples passed over.
                Some((j, tj, vj)) => {
                    let t1 = c.mid(j + 1);
                    let v1 = value(t1);
                    let (tp, vp) = if j + 2 == i {
                        (t1, v1)
                    } else {
                        let tp = c.mid(i - 1);
                        (tp, value(tp))
                    };
                    slab(&mut acc, tj, vj, t1, v1) || slab(&mut acc, tp, vp, mid, v)
                }
                None if i > 0 => {
                    let tp = c.mid(i - 1);
                    slab(&mut acc, tp, value(tp), mid, v)
                }
                // The first segment's front half, from the interval's start.
                None => slab(&mut acc, c.t0, value(c.t0), mid, v),
            };
            last = Some((i, mid, v));
            if ends {
                return acc.result();
            }
        }
        // After the last sample taken: the slab to the next one (passed over), or the last
        // segment's back half, to the interval's end.
        if let Some((j, tj, vj)) = last {
            let tb = if j + 1 < n { c.mid(j + 1) } else { c.t1 };
            slab(&mut acc, tj, vj, tb, value(tb));
        }
        acc.result()
    }
}
