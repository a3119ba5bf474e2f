//! Direct surface rendering: the iso-surface hits of a DSR object along a ray, found between
//! consecutive samples and refined by bisection. On rays that show colour each hit is shaded,
//! and given its mirror ray and its refracted direction where the object asks for them (the
//! hit's `mirror` and `bend`: tracing them is the compositing's, which knows whether the hit is
//! reached and what it weighs in the pixel); shadow rays take only each hit's opacity.

use crate::render::*;

impl Compiled {
    /// The iso-surface hits of a DSR object along its ray interval, in depth order: for each
    /// surface, crossings of its threshold between consecutive samples (the field is 0 outside
    /// the boundary, so an object's faces count too), each refined by bisection to 10⁻⁶ of the
    /// step; returns (t, α, colour) per hit, α the surface's opacity there. On a ray that
    /// shows colour, an opaque hit that does not refract ends its surface's search.
    pub(in crate::render) fn surface_hits(
        &self,
        obj: &CObj,
        c: &Cursor,
        origin: DVec3,
        dir: DVec3,
        ray: Ray,
        shade: bool,
    ) -> Vec<Layer> {
        let mut hits = Vec::new();
        let starts_inside = obj.inside(obj.to_object.transform_point3(origin + c.t0 * dir));
        for &(field, threshold) in &obj.surfaces {
            let thr = threshold as f64;
            let value = |t: f64| obj.field_at(origin + t * dir, field) - thr;
            let inside = |t: f64| t > c.t0 && t < c.t1;
            // Outside the boundary the field is 0; a ray that starts inside (a camera in the
            // object, or a secondary ray) starts from the field's value there.
            let mut prev_t = c.t0;
            let mut prev_v = if starts_inside && c.t0 <= 0.0 {
                value(c.t0)
            } else {
                -thr
            };
            let mut k = 0;
            loop {
                let (t, v) = if k < c.n {
                    let mid = c.mid(k);
                    (mid, value(mid))
                } else {
                    (c.t1, -thr)
                };
                if (prev_v < 0.0) != (v < 0.0) && !(prev_v == 0.0 && v == 0.0) {
                    // Bisection on [prev_t, t]; the ends are the box faces where the field
                    // jumps from or to 0.
                    let (mut a, mut b, mut va, mut vb) = (prev_t, t, prev_v, v);
                    let tol = obj.step * 1e-6;
                    for _ in 0..60 {
                        if b - a <= tol {
                            break;
                        }
                        let m = 0.5 * (a + b);
                        let vm = if inside(m) { value(m) } else { -thr };
                        if (vm < 0.0) == (va < 0.0) {
                            a = m;
                            va = vm;
                        } else {
                            b = m;
                            vb = vm;
                        }
                    }
                    let hit = 0.5 * (a + b);
                    let w = origin + hit * dir;
                    // Shade with the fields just inside the surface (on the side above the
                    // threshold), so a surface on the box face sees the object's fields, and
                    // measurably inside: where the field at the bracket's inner end equals the
                    // threshold (closer than f32 resolves), a transfer function stepping exactly
                    // there would read the outside's row, so the point moves further in, by
                    // doubling distances up to half a step, until the field is above it.
                    let (end, end_v, inward) = if va >= 0.0 {
                        (a, va, -1.0)
                    } else {
                        (b, vb, 1.0)
                    };
                    let (lo, hi) = (c.t0 + tol * 0.5, c.t1 - tol * 0.5);
                    let clamp = |t: f64| {
                        if lo < hi {
                            t.clamp(lo, hi)
                        } else {
                            0.5 * (c.t0 + c.t1)
                        }
                    };
                    let mut side = clamp(end);
                    let mut side_v = if side == end { end_v } else { value(side) };
                    let mut d = tol;
                    while side_v <= 0.0 && d <= 0.5 * obj.step {
                        side = clamp(end + inward * d);
                        side_v = if inside(side) { value(side) } else { -thr };
                        d *= 2.0;
                    }
                    let ws = origin + side * dir;
                    let mut s = obj.sample_at(ws);
                    run(&obj.program, &mut s);
                    let o = s.value(0) as f64;
                    let bends = self.plan.refraction && obj.refract && ray.depth < obj.recursion;
                    if !shade {
                        // Shadow rays need only the opacity.
                        if o > 0.0 {
                            hits.push(Layer {
                                t: hit,
                                alpha: o.min(1.0),
                                colour: DVec3::ZERO,
                                bend: None,
                                mirror: None,
                            });
                        }
                    } else if o > 0.0 || bends {
                        let mut bend = None;
                        let mut mirror = None;
                        let secondary = (self.plan.reflections && obj.receive_reflections || bends)
                            && ray.depth < obj.recursion;
                        // Secondary rays leave along the normal the shading uses (the
                        // gradient's, then the object's normal functions): computed once.
                        let normal = secondary.then(|| obj.normal(w, -dir, &mut s, field));
                        let f = s.values();
                        let col = self.illuminate_with(obj, w, dir, &f, || {
                            normal.unwrap_or_else(|| obj.normal(w, -dir, &mut s, field))
                        });
                        if let Some(Some(n)) = normal {
                            let eps = obj.step * 1e-3;
                            if self.plan.reflections && obj.receive_reflections {
                                let ks = s.value(6) as f64;
                                if ks > 0.0 {
                                    let r = reflect(dir, if n.dot(dir) > 0.0 { -n } else { n });
                                    mirror = Some(Mirror {
                                        from: w + eps * r,
                                        dir: r,
                                        ks,
                                        background: obj.reflect_background,
                                    });
                                }
                            }
                            if bends {
                                // Entering where the field rises along the ray, leaving
                                // where it falls; the object's index is its RF field.
                                let eta = 1.0
                                    + s.value(8) as f64
                                        * (crate::types::MAX_REFRACTION as f64 - 1.0);
                                let entering = va < 0.0;
                                let (n1, n2) = if entering { (1.0, eta) } else { (eta, 1.0) };
                                let t = refract(dir, n, n1, n2);
                                bend = Some((w + eps * t, t));
                            }
                        }
                        hits.push(Layer {
                            t: hit,
                            alpha: o.min(1.0),
                            colour: col,
                            bend,
                            mirror,
                        });
                        // An opaque hit that does not refract hides the rest of the surface:
                        // every later hit is behind it, where the ray's transmittance is 0.
                        // (A shadow ray, above, does not count the hit at its own start, so
                        // it reads on.)
                        if o >= 1.0 && bend.is_none() {
                            break;
                        }
                    }
                }
                if k >= c.n {
                    break;
                }
                prev_t = t;
                prev_v = v;
                k += 1;
                // A render that is to stop ends the search (its pixels are discarded).
                if k % PROBE_EVERY == 0 && crate::control::stop_requested() {
                    break;
                }
            }
        }
        hits.sort_by(|a, b| a.t.total_cmp(&b.t));
        hits
    }
}
