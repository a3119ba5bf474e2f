//! Shading: the illumination model (ambient, diffuse and specular terms per light, with
//! attenuation), normals from field gradients (a dataset's interpolated grid gradients, or
//! central differences) and the object's normal functions, the mirror and refracted directions
//! ([`reflect`], [`refract`]), the lit colour of a DVR sample ([`Compiled::shade`]) and the
//! transmittance of shadow rays ([`Compiled::transmittance`]). [`Headlit`] is the model
//! prepared once per ray where every light is directional and nothing shadows the object: the
//! same arithmetic in the same order, so the same colour. This module decides colours, not
//! where samples are or how they combine (`cursor`, `integrate`); the same lighting for several
//! samples side by side is `lanes`'.

use super::*;

/// Central differences below this change of F count as a zero gradient.
pub(super) const ZERO_GRADIENT: f64 = 1e-7;

impl CObj {
    /// The world-space gradient of field `field` at `w` (object point `p`), and whether it
    /// vanishes: for the geometry field where it is a dataset's value, from the dataset's
    /// interpolated grid gradients; otherwise by central differences over the neighbourhood.
    /// `cache` holds the node differences of the last dataset cell read (see
    /// [`CellGradients`]): one per object and ray, or a fresh one.
    #[inline]
    pub(super) fn field_gradient(
        &self,
        w: DVec3,
        p: [f32; 3],
        field: usize,
        cache: &mut CellGradients,
    ) -> (DVec3, bool) {
        let (g, zero) = self.field_gradient_in(w, p, field, cache);
        if self.object_gradient(field) {
            return (self.grad_to_world * g, zero);
        }
        (g, zero)
    }

    /// Whether [`CObj::field_gradient_in`] gives field `field`'s gradient in object space
    /// (from the dataset's grid) rather than in world space.
    #[inline(always)]
    pub(super) fn object_gradient(&self, field: usize) -> bool {
        field == 9 && self.f_dataset.is_some()
    }

    /// [`CObj::field_gradient`] before the dataset's gradient is taken to world space (see
    /// [`CObj::object_gradient`]), so that the lighting in lanes can do that product too.
    #[inline]
    pub(super) fn field_gradient_in(
        &self,
        w: DVec3,
        p: [f32; 3],
        field: usize,
        cache: &mut CellGradients,
    ) -> (DVec3, bool) {
        if let (9, Some((data, filter, gradient))) = (field, &self.f_dataset) {
            return vanishing(data.gradient_by(p, *filter, *gradient, cache));
        }
        self.sampled_gradient(w, field)
    }

    /// [`CObj::field_gradient`] by world-space central differences of the field; for a field
    /// folded to a constant, from the box's faces ([`CObj::face_gradient`]).
    #[inline(never)]
    fn sampled_gradient(&self, w: DVec3, field: usize) -> (DVec3, bool) {
        if let Some(c) = self.constants[field] {
            return self.face_gradient(w, c as f64);
        }
        let mut diff = DVec3::ZERO;
        let mut grad = DVec3::ZERO;
        for i in 0..3 {
            let mut e = DVec3::ZERO;
            e[i] = self.delta[i];
            let d = self.field_for_gradient(w + e, field) - self.field_for_gradient(w - e, field);
            diff[i] = d;
            grad[i] = d / (2.0 * self.delta[i]);
        }
        (grad, diff.abs().max_element() <= ZERO_GRADIENT)
    }

    /// The gradient at `w` of a field that is the constant `c` inside the box and 0 outside
    /// (a folded field): where the central differences' stencil (`w ± δ` along each world
    /// axis) has points on both sides of the box's surface, the field jumps by c across the
    /// face nearest to `w` (perpendicular world distance; the first in the order −x, +x, −y,
    /// +y, −z, +z on ties) among the faces whose planes the stencil crosses, and the gradient is
    /// −c / (2δ) times that face's outward unit normal (2δ the stencil's widest span, so the
    /// size is that of the jump over it). The direction is the face's analytic normal (the
    /// object-to-world transpose-inverse of the object axis), not the sign pattern the
    /// differences would give a tilted face. Elsewhere (the stencil wholly inside or wholly
    /// outside) the differences are all 0, and so is this: it vanishes, as it does where
    /// c ≤ [`ZERO_GRADIENT`].
    pub(super) fn face_gradient(&self, w: DVec3, c: f64) -> (DVec3, bool) {
        let p = self.to_object.transform_point3(w);
        // The stencil's offsets in object space: column i of the linear part, times δ_i.
        let offsets: [DVec3; 3] =
            std::array::from_fn(|i| self.to_object.col(i).truncate() * self.delta[i]);
        let points = offsets.iter().flat_map(|&o| [p + o, p - o]);
        let (mut inside, mut outside) = (false, false);
        for q in points {
            let i = self.inside(q);
            inside |= i;
            outside |= !i;
        }
        if !(inside && outside) || c <= ZERO_GRADIENT {
            return (DVec3::ZERO, true);
        }
        // ∇_world of object coordinate a: row a of world → object, i.e. column a of its
        // transpose (`grad_to_world`).
        let mut best: Option<(f64, DVec3)> = None;
        for a in 0..3 {
            let row = self.grad_to_world.col(a);
            let len = row.length();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            for (plane, sign) in [(self.box_min[a], -1.0), (self.box_max[a], 1.0)] {
                let gap = (p[a] - plane) * sign; // > 0: beyond the plane
                                                 // The stencil crosses the plane where some point lies beyond it.
                let crosses = gap + max_offset(&offsets, a) > 0.0;
                if !crosses {
                    continue;
                }
                let distance = gap.abs() / len;
                if best.is_none_or(|(d, _)| distance < d) {
                    best = Some((distance, row * (sign / len)));
                }
            }
        }
        match best {
            Some((_, n)) => {
                let width = 2.0 * self.delta.max_element();
                (-n * (c / width), false)
            }
            None => (DVec3::ZERO, true),
        }
    }

    /// The normal from the gradient alone: −∇F at `w` (object point `p`), flipped towards the
    /// viewer if asked; `None` where the gradient vanishes.
    #[inline(always)]
    pub(super) fn gradient_normal(
        &self,
        w: DVec3,
        view: DVec3,
        p: [f32; 3],
        field: usize,
        cache: &mut CellGradients,
    ) -> Option<DVec3> {
        let (grad, zero) = self.field_gradient(w, p, field, cache);
        normal_of_gradient(grad, zero, view, self.flip_normals)
    }

    /// The normal at `w`: −∇F by world-space central differences, then flipped towards the viewer
    /// if asked, then the normal functions in order. `None` where the gradient vanishes.
    pub(super) fn normal(
        &self,
        w: DVec3,
        view: DVec3,
        s: &mut Sample<'_>,
        field: usize,
    ) -> Option<DVec3> {
        let n = self.gradient_normal(w, view, s.position(), field, &mut CellGradients::default());
        if self.normals.is_empty() {
            return n;
        }
        let mut nv = n.unwrap_or(DVec3::ZERO).as_vec3().to_array();
        s.role = SampleRole::Normal;
        for f in &self.normals {
            f(&mut nv, s);
            // A normal function that gives a NaN or an infinity gives no normal: the next one
            // sees (0, 0, 0), as where the gradient vanishes.
            if !nv.iter().all(|x| x.is_finite()) {
                nv = [0.0; 3];
            }
        }
        s.role = SampleRole::Field;
        let v = DVec3::new(nv[0] as f64, nv[1] as f64, nv[2] as f64);
        if v.is_finite() {
            v.try_normalize()
        } else {
            None
        }
    }
}

/// The largest reach of the stencil `offsets` (±each) along object axis `axis`.
fn max_offset(offsets: &[DVec3; 3], axis: usize) -> f64 {
    offsets.iter().map(|o| o[axis].abs()).fold(0.0, f64::max)
}

/// A dataset's gradient `g`, and whether it vanishes (no component above [`ZERO_GRADIENT`]
/// in magnitude).
#[inline(always)]
pub(super) fn vanishing(g: [f64; 3]) -> (DVec3, bool) {
    let g = DVec3::from_array(g);
    (g, g.abs().max_element() <= ZERO_GRADIENT)
}

/// The normal of gradient `grad` (`zero`: it vanishes): −`grad` normalised, flipped towards
/// `view` if `flip`; `None` where the gradient vanishes or cannot be normalised.
#[inline]
pub(super) fn normal_of_gradient(
    grad: DVec3,
    zero: bool,
    view: DVec3,
    flip: bool,
) -> Option<DVec3> {
    let n = if zero { None } else { try_normalize(-grad) };
    match n {
        Some(v) if flip && v.dot(view) < 0.0 => Some(-v),
        n => n,
    }
}

/// `v.try_normalize()`: the same arithmetic (`v · (1 / |v|)`), and its test that the reciprocal
/// is finite and above 0 as one unsigned comparison of its bits (those of the positive finite
/// numbers are 1 to `f64::MAX`'s; 0, the negative numbers, the infinities and NaN are not)
/// instead of the class test the compiler makes of `is_finite() && > 0`.
#[inline(always)]
pub(super) fn try_normalize(v: DVec3) -> Option<DVec3> {
    let rcp = v.length_recip();
    (rcp.to_bits().wrapping_sub(1) < f64::MAX.to_bits()).then(|| v * rcp)
}

/// [`Compiled::illuminate_colour`] prepared for one ray and one object's constant coefficients
/// where every light is directional and no shadow falls on the object (the peer benchmark's
/// headlight): no per-light case analysis, attenuation or shadow test per sample, and the
/// ambient term's product of constants taken once. The same arithmetic in the same order, so
/// the same colour, bit for bit.
pub(super) struct Headlit<'a> {
    /// ka × the ambient radiance (the left product of `ka · I_amb · C`).
    pub(super) ka_ambient: DVec3,
    pub(super) kd: f64,
    pub(super) ks: f64,
    pub(super) e: Specular,
    /// Towards the eye: −(the ray's direction).
    pub(super) view: DVec3,
    /// Towards each light, and its radiance; empty where neither kd nor ks is above 0.
    pub(super) lights: &'a [(DVec3, DVec3)],
}

impl<'a> Headlit<'a> {
    /// The preparation for object `obj` seen along `dir` with coefficients ka, kd, ks and
    /// exponent `e`, or `None` where a light is not directional or a shadow may fall on it.
    pub(super) fn new(
        scene: &'a Compiled,
        obj: &CObj,
        dir: DVec3,
        [ka, kd, ks]: [f64; 3],
        e: Specular,
    ) -> Option<Headlit<'a>> {
        if scene.plan.shadows && obj.receive_shadows {
            return None;
        }
        let lights = scene.directional.as_deref()?;
        Some(Headlit {
            ka_ambient: ka * scene.ambient,
            kd,
            ks,
            e,
            view: -dir,
            lights: if kd > 0.0 || ks > 0.0 { lights } else { &[] },
        })
    }

    /// The colour of a sample of colour `c`; `normal` computes the normal, only if a light
    /// needs it.
    #[inline]
    pub(super) fn colour(&self, c: DVec3, normal: impl FnOnce() -> Option<DVec3>) -> DVec3 {
        let mut col = self.ka_ambient * c;
        if !self.lights.is_empty() {
            let (kd, ks, view) = (self.kd, self.ks, self.view);
            let n = normal();
            // (A directional light's attenuation is 1: `radiance · 1` is the radiance.)
            for &(l, rad) in self.lights {
                col += rad * lit(n, l, view, c, [kd, ks], self.e);
            }
        }
        if col.is_finite() {
            col
        } else {
            DVec3::ZERO
        }
    }
}

/// One light's term of the illumination model before its radiance: `kd·C·max(N·L, 0) +
/// ks·(R·V)^e` for unit normal `n` and unit `l` towards the light, the highlight only where
/// N·L and R·V are above 0 and ks is; where the gradient vanishes (`n` is `None`) there is no
/// preferred direction and the medium is lit isotropically: diffuse at full strength, no
/// highlight. Shared by [`Compiled::illuminate_colour`] and [`Headlit::colour`], so the two
/// compute it alike.
#[inline(always)]
pub(super) fn lit(
    n: Option<DVec3>,
    l: DVec3,
    view: DVec3,
    c: DVec3,
    [kd, ks]: [f64; 2],
    e: Specular,
) -> DVec3 {
    match n {
        Some(n) => {
            let ndl = n.dot(l);
            let mut term = kd * c * ndl.max(0.0);
            if ks > 0.0 && ndl > 0.0 {
                let r = 2.0 * ndl * n - l;
                let rv = r.dot(view);
                if rv > 0.0 {
                    term += DVec3::splat(ks * e.pow(rv));
                }
            }
            term
        }
        None => kd * c,
    }
}

/// A specular exponent e, examined once (per ray for direct shading, per sample otherwise)
/// for the specular term's `x^e`: integer exponents (the usual case: `VLSPECULAR(20)`) by
/// repeated squaring, which is exact to rounding and much cheaper than `powf`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Specular {
    pub(super) e: f64,
    pub(super) integer: Option<u32>,
}

impl Specular {
    /// The exponent of a specular-exponent field value.
    #[inline]
    pub(super) fn of_field(value: f64) -> Specular {
        Specular::new(value * MAX_SPECULAR as f64)
    }

    #[inline]
    pub(super) fn new(e: f64) -> Specular {
        // `e as u32` saturates (NaN to 0), so the round trip holds exactly for integers in
        // range; no libm call (`fract` is one) on this per-sample path.
        let k = e as u32;
        Specular {
            e,
            integer: (k as f64 == e && k <= MAX_SPECULAR as u32).then_some(k),
        }
    }

    /// `x^e`.
    #[inline]
    pub(super) fn pow(self, x: f64) -> f64 {
        match self.integer {
            Some(k) => powi(x, k),
            None => x.powf(self.e),
        }
    }
}

/// `x^k` by binary exponentiation: the products of compiler-rt's and libgcc's `__powidf2`
/// (what `f64::powi` calls for an exponent unknown at compile time), in the same order, so the
/// same bits, without the call.
#[inline]
pub(super) fn powi(x: f64, k: u32) -> f64 {
    powi_in(x, 1.0, k)
}

/// [`powi`]'s products for any number type with a multiplication (f64, or f64 lanes, each
/// lane then the scalar products in the same order); `one` is its 1.
#[inline]
pub(super) fn powi_in<T: Copy + std::ops::MulAssign>(mut x: T, one: T, mut k: u32) -> T {
    let mut r = one;
    loop {
        if k & 1 != 0 {
            r *= x;
        }
        k >>= 1;
        if k == 0 {
            return r;
        }
        x *= x;
    }
}

/// The mirror direction of `d` about the unit normal `n`.
pub fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    d - 2.0 * d.dot(n) * n
}

/// Snell's law: the direction of unit ray `d` after crossing from index `n1` into `n2` at a
/// surface of unit normal `n` (either orientation); the mirror direction when the angle is
/// beyond the critical one (total internal reflection).
pub fn refract(d: DVec3, n: DVec3, n1: f64, n2: f64) -> DVec3 {
    let n = if d.dot(n) > 0.0 { -n } else { n };
    let eta = n1 / n2;
    let cos_i = -d.dot(n);
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    if k < 0.0 {
        reflect(d, n)
    } else {
        (eta * d + (eta * cos_i - k.sqrt()) * n).normalize()
    }
}

impl Compiled {
    /// Shades one DVR sample: returns (α, colour) or `None` where the opacity is 0.
    pub(super) fn shade(
        &self,
        obj: &CObj,
        w: DVec3,
        p: [f32; 3],
        dir: DVec3,
        len: f64,
    ) -> Option<(f64, DVec3)> {
        if let Some(lean) = &obj.lean {
            return self.shade_lean(obj, lean, w, p, dir, len);
        }
        let mut s = Sample::with_env(p, w.to_array(), &obj.env);
        run(&obj.program[..obj.o_prefix], &mut s);
        let o = s.value(0) as f64;
        if o <= 0.0 {
            return None;
        }
        run(&obj.program[obj.o_prefix..], &mut s);
        let alpha = obj.alpha(o, len);
        Some((alpha, self.illuminate(obj, w, dir, &mut s, 9)))
    }

    /// [`Compiled::shade`] by the lean kernel: the same fields, bit for bit, so the same colour.
    #[inline]
    fn shade_lean(
        &self,
        obj: &CObj,
        lean: &Lean,
        w: DVec3,
        p: [f32; 3],
        dir: DVec3,
        len: f64,
    ) -> Option<(f64, DVec3)> {
        let mut f = [0.0f32; FIELD_COUNT];
        let o = lean.opacity(p, &mut f) as f64;
        if o <= 0.0 {
            return None;
        }
        let mut cache = CellGradients::default();
        Some(self.finish_lean(obj, lean, o, p, w, dir, len, &mut f, &mut cache))
    }

    /// The rest of a lean sample whose opacity `o` is above 0 (registers `f` filled by the
    /// opacity part): its other fields, α for a segment `len` long, and its colour.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(super) fn finish_lean(
        &self,
        obj: &CObj,
        lean: &Lean,
        o: f64,
        p: [f32; 3],
        w: DVec3,
        dir: DVec3,
        len: f64,
        f: &mut [f32; FIELD_COUNT],
        cache: &mut CellGradients,
    ) -> (f64, DVec3) {
        lean.rest(p, f);
        let alpha = obj.alpha(o, len);
        let colour = if obj.normals.is_empty() {
            self.illuminate_with(obj, w, dir, f, || obj.gradient_normal(w, -dir, p, 9, cache))
        } else {
            let mut s = Sample::with_env(p, w.to_array(), &obj.env);
            s.fields = *f;
            self.illuminate(obj, w, dir, &mut s, 9)
        };
        (alpha, colour)
    }

    /// The illumination model at a sample whose fields are computed, with normals from the
    /// gradient of field `normal_field`:
    /// `ka·I_amb·C + Σ att·I·L·T·(kd·C·max(N·L, 0) + ks·(R·V)^e)`, T the transmittance towards
    /// the light where shadows are simulated.
    fn illuminate(
        &self,
        obj: &CObj,
        w: DVec3,
        dir: DVec3,
        s: &mut Sample<'_>,
        normal_field: usize,
    ) -> DVec3 {
        let f = s.values();
        self.illuminate_with(obj, w, dir, &f, || obj.normal(w, -dir, s, normal_field))
    }

    /// The illumination model for fields `f`; `normal` computes the normal, only if a light
    /// needs it.
    #[inline]
    pub(super) fn illuminate_with(
        &self,
        obj: &CObj,
        w: DVec3,
        dir: DVec3,
        f: &[f32; FIELD_COUNT],
        normal: impl FnOnce() -> Option<DVec3>,
    ) -> DVec3 {
        let c = DVec3::new(f[1] as f64, f[2] as f64, f[3] as f64);
        let k = [f[4], f[5], f[6]].map(|v| v as f64);
        let e = Specular::of_field(f[7] as f64);
        self.illuminate_colour(obj, w, dir, c, k, e, normal)
    }

    /// The illumination model for colour `c`, coefficients ka, kd and ks and specular
    /// exponent `e`; `normal` computes the normal, only if a light needs it.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(super) fn illuminate_colour(
        &self,
        obj: &CObj,
        w: DVec3,
        dir: DVec3,
        c: DVec3,
        [ka, kd, ks]: [f64; 3],
        e: Specular,
        normal: impl FnOnce() -> Option<DVec3>,
    ) -> DVec3 {
        let mut col = ka * self.ambient * c;
        if !self.lights.is_empty() && (kd > 0.0 || ks > 0.0) {
            let view = -dir;
            let n = normal();
            let shadowed = self.plan.shadows && obj.receive_shadows;
            for &(light, radiance) in &self.lights {
                let (l, att, dist) = match light {
                    Light::Point {
                        position,
                        attenuation,
                        ..
                    } => {
                        let to = position - w;
                        let d = to.length();
                        let att = match attenuation {
                            Attenuation::None => 1.0,
                            Attenuation::Inverse => 1.0 / d.max(1e-6),
                            Attenuation::InverseSquare => 1.0 / (d * d).max(1e-12),
                        };
                        (to.try_normalize().unwrap_or(view), att, d)
                    }
                    Light::Directional { to_light, .. } => (to_light, 1.0, f64::INFINITY),
                };
                let mut rad = radiance * att;
                if shadowed {
                    rad *= self.transmittance(w, l, dist);
                    if rad == DVec3::ZERO {
                        continue;
                    }
                }
                col += rad * lit(n, l, view, c, [kd, ks], e);
            }
        }
        if col.is_finite() {
            col
        } else {
            DVec3::ZERO
        }
    }

    /// The transmittance from `w` along unit direction `l` up to distance `dist` through the
    /// objects that cast shadows (each sampled on its own step grid, exactly like primary rays,
    /// empty-space skipping included). A medium does not shadow its own sample: the shadow
    /// ray's first segment ends its own step away; a surface does not shadow the point it
    /// holds: crossings within 10⁻³ of a step of the point are not counted.
    pub(super) fn transmittance(&self, w: DVec3, l: DVec3, dist: f64) -> f64 {
        // A render that is to stop sends no more shadow rays (each sample of a ray has one per
        // light, so one look a shadow ray is a small part of its cost; the cursors below look
        // again every `PROBE_EVERY` segments).
        if crate::control::stop_requested() {
            return 0.0;
        }
        let mut t_total = 1.0f64;
        for obj in self.met_by_ray(w, l, dist).map(|i| &self.objects[i]) {
            if !obj.cast_shadows {
                continue;
            }
            let (o, d) = obj.object_ray(w, l);
            let Some((t0, t1)) = obj.clip(o, d) else {
                continue;
            };
            let t1 = t1.min(dist);
            if t1 <= t0 {
                continue;
            }
            let mut c = Cursor::new(self, obj, 0, (o, d), (t0, t1), f64::NEG_INFINITY);
            if obj.render_type == RenderType::Dsr {
                // A surface object shadows by the opacity of the surfaces the ray crosses. A
                // point on a surface lies within 10⁻⁶ of a step of it, on either side: crossings
                // that close to the start are the surface the point is on, which must not
                // shadow itself (secondary rays start the same distance off their surface).
                let eps = obj.step * 1e-3;
                for hit in self.surface_hits(obj, &c, w, l, Ray::PRIMARY, false) {
                    if hit.t > eps {
                        t_total *= 1.0 - hit.alpha;
                    }
                }
                if t_total < self.settings.optimise.termination {
                    return 0.0;
                }
                continue;
            }
            let grid = obj.skip.as_deref();
            while let Some(mid) = c.peek(grid) {
                let len = c.take();
                if len <= 0.0 {
                    continue;
                }
                let o = obj.opacity_at(w + mid * l);
                if o > 0.0 {
                    t_total *= obj.segment_transmittance(o, len);
                    if t_total < self.settings.optimise.termination {
                        return 0.0;
                    }
                }
            }
        }
        t_total
    }
}
