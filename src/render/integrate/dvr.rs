//! Direct volume rendering: the opacity correction of a segment ([`transmit`], the segment's
//! transmittance `(1 − o)^(ℓ / reference)`), the one front-to-back composite every DVR march
//! shares ([`Integral`]: weight, accumulation and early termination), and the single-volume
//! marches: [`Compiled::march_one`] sample by sample and [`Compiled::march_batched`] for a
//! scanned volume's lean program, a run of samples at a time. The general loop of
//! [`Compiled::trace_ray`] composites through the same [`Integral`]. Lighting is `shade`'s.

use crate::render::*;

/// The transmittance `t^e` of a segment `e` references long through a medium of per-reference
/// transmittance `t`: the common exponents by [`transmit_common`], the others by `powf`.
#[inline]
pub(in crate::render) fn transmit(t: f64, e: f64) -> f64 {
    transmit_common(t, e).unwrap_or_else(|| t.powf(e))
}

/// `t^e` for the common exponents (a step of one, a half, a quarter or an eighth of the
/// reference, or twice or four times it) by square roots and products, within two units in
/// the last place (each square root and product rounds once, and a square root halves the
/// relative error it is given) and much cheaper than `powf`, which would otherwise dominate a
/// frame at fine steps; `None` for any other exponent. The
/// half first: the usual step, the MNI frame's.
#[inline(always)]
pub(in crate::render) fn transmit_common(t: f64, e: f64) -> Option<f64> {
    if e == 0.5 {
        Some(t.sqrt())
    } else if e == 1.0 {
        Some(t)
    } else if e == 0.25 {
        Some(t.sqrt().sqrt())
    } else if e == 2.0 {
        Some(t * t)
    } else if e == 0.125 {
        Some(t.sqrt().sqrt().sqrt())
    } else if e == 4.0 {
        let t2 = t * t;
        Some(t2 * t2)
    } else {
        None
    }
}

/// The transmittance of a segment `e` references long through a medium of opacity `o` not
/// above 1 (or NaN): `if o >= 1.0 { 0.0 } else { transmit(1.0 - o, e) }`, bit for bit, with
/// the opaque medium's test only before `powf`. An o of 1 makes 1 − o = +0, whose square
/// roots and square are +0 already (the common exponents' answer is the 0 of the test), and
/// any other o fails the test; only `powf` of +0 can be other than +0 (an exponent of 0, below
/// 0 or NaN). (`transmit_at_most_one_is_the_tested_transmit`.)
#[inline(always)]
pub(in crate::render) fn transmit_at_most_one(o: f64, e: f64) -> f64 {
    debug_assert!(o <= 1.0 || o.is_nan(), "{o}");
    let t = 1.0 - o;
    transmit_common(t, e).unwrap_or_else(|| if o >= 1.0 { 0.0 } else { t.powf(e) })
}

impl CObj {
    /// The transmittance of a segment `len` long of medium with opacity `o` per reference
    /// length: `(1 − o)^(len / reference)`, 0 for an opaque medium.
    #[inline]
    pub(in crate::render) fn segment_transmittance(&self, o: f64, len: f64) -> f64 {
        if o >= 1.0 {
            0.0
        } else {
            transmit(1.0 - o, len * self.inv_ref)
        }
    }

    /// [`CObj::segment_transmittance`] of an opacity not above 1 (or NaN): a table's, which
    /// the clamp keeps in [0, 1]. See [`transmit_at_most_one`].
    #[inline(always)]
    fn segment_transmittance_at_most_one(&self, o: f64, len: f64) -> f64 {
        transmit_at_most_one(o, len * self.inv_ref)
    }

    /// The opacity correction: the α of a segment `len` long of medium with opacity `o` per
    /// reference length, `1 − (1 − o)^(len / reference)`.
    #[inline(always)]
    pub(in crate::render) fn alpha(&self, o: f64, len: f64) -> f64 {
        1.0 - self.segment_transmittance(o, len)
    }

    /// [`CObj::alpha`] of an opacity not above 1 (or NaN): a table's (see
    /// [`CObj::segment_transmittance_at_most_one`]).
    #[inline(always)]
    fn alpha_at_most_one(&self, o: f64, len: f64) -> f64 {
        1.0 - self.segment_transmittance_at_most_one(o, len)
    }
}

/// The front-to-back composite along one ray, the one every scalar march uses: the colour
/// gathered and the transmittance left, each sample weighted by `t·α` and the transmittance
/// carried on as `t·(1 − α)`, the ray ending (its transmittance set to 0) once that falls below
/// the scene's termination threshold. Always inlined into the marches, its three numbers kept
/// in registers: the same arithmetic in the same order as a loop that holds them itself, so
/// the same bits. A sample's composite is no more instructions than that loop's; around it,
/// in the batched march's run loop, the compiler allocates registers slightly differently, a
/// few instructions a run, which is what writing the composite once costs.
#[derive(Clone, Copy, Debug)]
pub(in crate::render) struct Integral {
    /// The colour gathered so far.
    colour: DVec3,
    /// The transmittance left; 0 once the ray has ended.
    t: f64,
    /// The termination threshold ([`crate::model::scene::Optimise::stop_below`]).
    stop: f64,
}

impl Integral {
    /// Nothing gathered yet, for a ray of `scene`.
    #[inline(always)]
    pub(in crate::render) fn new(scene: &Compiled) -> Integral {
        Integral {
            colour: DVec3::ZERO,
            t: 1.0,
            stop: scene.settings.optimise.stop_below(),
        }
    }

    /// Takes a sample of opacity `alpha` whose colour comes later ([`Integral::add_weighted`]):
    /// its weight `t·α`, and whether the ray ends there.
    #[inline(always)]
    pub(in crate::render) fn weigh(&mut self, alpha: f64) -> (f64, bool) {
        let w = self.t * alpha;
        self.t *= 1.0 - alpha;
        if self.t < self.stop {
            self.t = 0.0;
            (w, true)
        } else {
            (w, false)
        }
    }

    /// Adds the colour of a sample weighed by [`Integral::weigh`] (weight `w`).
    #[inline(always)]
    fn add_weighted(&mut self, w: f64, colour: DVec3) {
        self.colour += w * colour;
    }

    /// Composites a sample of opacity `alpha` and colour `colour`; whether the ray ends there.
    #[inline(always)]
    pub(in crate::render) fn add(&mut self, alpha: f64, colour: DVec3) -> bool {
        let (w, ends) = self.weigh(alpha);
        self.add_weighted(w, colour);
        ends
    }

    /// The transmittance left.
    #[inline(always)]
    pub(in crate::render) fn transmittance(&self) -> f64 {
        self.t
    }

    /// The colour gathered and the transmittance left.
    #[inline(always)]
    pub(in crate::render) fn result(self) -> (DVec3, f64) {
        (self.colour, self.t)
    }
}

impl Compiled {
    /// The front-to-back composite of one DVR object's samples along a ray (the general loop of
    /// [`Compiled::trace_ray`] with a single cursor and no layers, in the same order and
    /// arithmetic); returns the colour and the remaining transmittance.
    pub(in crate::render) fn march_one(
        &self,
        c: &mut Cursor,
        origin: DVec3,
        dir: DVec3,
    ) -> (DVec3, f64) {
        let obj = &self.objects[c.object];
        if let Some(lean) = &obj.lean {
            if let Some((data, z)) = lean.value_head() {
                if let Some(pre) = &obj.preint {
                    return self.march_preintegrated(obj, pre, data, z, c, origin, dir);
                }
                if obj.normals.is_empty() {
                    return self.march_batched::<true>(obj, lean, data, z, c, origin, dir);
                }
            }
        }
        let grid = obj.skip.as_deref();
        let mut acc = Integral::new(self);
        while let Some(mid) = c.peek(grid) {
            let len = c.take();
            if len <= 0.0 {
                continue;
            }
            if let Some((alpha, colour)) =
                self.shade(obj, origin + mid * dir, c.object_point(mid), dir, len)
            {
                if acc.add(alpha, colour) {
                    break;
                }
            }
        }
        acc.result()
    }

    /// [`Compiled::march_one`] for a lean program with a value head (a scanned volume) and no
    /// normal functions: the samples of a run the cursor knows to be in occupied blocks (or
    /// all of them, without skipping; see [`Cursor::next_run`]) are read in batches (positions
    /// and dataset values first, in lanes across the samples), then shaded and composited in
    /// order, exactly as the sample-by-sample loop does (for the usual program under a single
    /// directional light, the lighting of the samples up to where the ray ends in lanes:
    /// [`HeadlitLanes`]).
    /// `IN_LANES`: that lighting in lanes (only tests turn it off, to compare).
    #[allow(clippy::too_many_arguments)]
    pub(in crate::render) fn march_batched<const IN_LANES: bool>(
        &self,
        obj: &CObj,
        lean: &Lean,
        data: &Dataset,
        z: f32,
        c: &mut Cursor,
        origin: DVec3,
        dir: DVec3,
    ) -> (DVec3, f64) {
        let grid = obj.skip.as_deref();
        let cells = obj.cells.as_deref();
        let mut acc = Integral::new(self);
        let mut f = [0.0f32; FIELD_COUNT];
        // The object-space ray in registers: `Cursor::object_point` without the loads.
        let (ro, rd) = (c.o.to_array(), c.d.to_array());
        // Consecutive shaded samples often share a cell: its node differences are read once.
        let mut cache = CellGradients::default();
        // A run's midpoints and lengths (see `Cursor::next_run`), and its samples' values.
        let (mut mids, mut lens, mut vs) = ([0.0f64; 8], [0.0f64; 8], [0.0f32; 8]);
        // And their cells: where the normal's gradient is that of this very dataset, trilinear,
        // a shaded sample's gradient is taken in the cell its value was read from.
        let mut cells8 = Cells8::default();
        let same_cells = matches!(
            &obj.f_dataset,
            Some((d, Filter::Trilinear, GradientFilter::Nodes)) if std::ptr::eq(Arc::as_ptr(d), data)
        );
        // The usual program's shaded samples of a run, in order: their compositing weights,
        // colours (then lit colours) and gradients, by axis.
        let (mut weights, mut colours, mut grads) = ([0.0f64; 8], [[0.0f64; 8]; 3], [[0.0; 8]; 3]);
        // Under the lighting lanes, those samples' colours as the tables give them.
        let mut rgb32 = [[0.0f32; 8]; 3];
        // Under a single light, the lighting in lanes across a run's samples (prepared for
        // the object once: the ray's view apart).
        let lanes = self.lanes[c.object].as_ref().filter(|_| IN_LANES);
        let view = (-dir).to_array().map(Lanes::splat);
        // The usual program's coefficients and exponent, examined once per ray, and, without
        // the lanes, its lighting prepared where every light is directional and nothing
        // shadows the object. (The direct shading itself is held here for the whole ray: its
        // tables per sample without the program's options unwrapped each time.)
        let shading = lean.direct_shading().map(|s| {
            let [ka, kd, ks, spec] = s.coefficients;
            let k = [ka, kd, ks];
            let e = Specular::of_field(spec);
            let headlit = match lanes {
                Some(_) => None,
                None => Headlit::new(self, obj, dir, k, e),
            };
            (s, k, e, headlit)
        });
        loop {
            // The run: the next sample to take and those after it in occupied blocks.
            let m = c.next_run(grid, &mut mids, &mut lens);
            if m == 0 {
                break;
            }
            // Their object points by axis, and their values (the cells in lanes across them).
            // (A short run needs only the first four.)
            let point = |axis: usize, t: f64| (ro[axis] + t * rd[axis]) as f32;
            let ps: [[f32; 8]; 3] = if m <= 4 {
                std::array::from_fn(|axis| {
                    std::array::from_fn(|i| if i < 4 { point(axis, mids[i]) } else { 0.0 })
                })
            } else {
                std::array::from_fn(|axis| mids.map(|t| point(axis, t)))
            };
            // In [0, 1], as field values; 0 (at most z) where the cell cannot pass the zero test.
            data.trilinear8(&ps, m, cells, &mut vs, &mut cells8);
            // The samples that pass the zero test (and have a length), as bits in order: the
            // loop below visits only those, without a branch per sample.
            let mut pass = pass_bits(&lens, &vs, z) & ((1u32 << m) - 1);
            if let Some((tables, k, e, headlit)) = &shading {
                // The usual program: opacity and colour straight from the tables, the other
                // coefficients known (the same numbers as the registers'). In phases over the
                // run: opacities, transmittance (without the lanes, the lit colours too) in
                // order up to where the ray ends (no sample after that is shaded); under a
                // single light, then those samples' gradients and their lighting in lanes
                // across them; then the composite.
                let (mut count, mut run_ends) = (0, false);
                if let Some(h) = &lanes {
                    // Under a single light: the opacities, colours and weights first, in
                    // order up to where the ray ends, noting each shaded sample's place in
                    // the run; then their gradients, in the same order (through the same
                    // cache, which nothing else reads); then the lighting in lanes.
                    let mut at = [0u8; 8];
                    // A shaded sample (number i, opacity o, colour rgb) noted, its weight
                    // taken and the transmittance carried on; whether the ray ends there.
                    macro_rules! shade {
                        ($i:expr, $o:expr, $rgb:expr) => {{
                            let (i, o, rgb): (usize, f32, [f32; 3]) = ($i, $o, $rgb);
                            let (w, ends) = acc.weigh(obj.alpha_at_most_one(o as f64, lens[i]));
                            for (a, x) in rgb32.iter_mut().zip(rgb) {
                                a[count] = x;
                            }
                            at[count] = i as u8;
                            weights[count] = w;
                            count += 1;
                            ends
                        }};
                    }
                    // The samples whose buckets have a segment pair in an inner loop
                    // without a call; the others (a few percent) by the tables' general
                    // evaluation, out of line, outside it, so that the inner loop keeps its
                    // numbers in registers.
                    'samples: loop {
                        while pass != 0 {
                            let i = pass.trailing_zeros() as usize;
                            let Some(oc) = tables.pair_in_range(vs[i]) else {
                                break;
                            };
                            pass &= pass - 1;
                            let (o, Some(rgb)) = oc else {
                                continue;
                            };
                            if shade!(i, o, rgb) {
                                run_ends = true;
                                break 'samples;
                            }
                        }
                        if pass == 0 {
                            break;
                        }
                        let i = pass.trailing_zeros() as usize;
                        pass &= pass - 1;
                        let (o, Some(rgb)) = tables.opacity_colour_general(vs[i]) else {
                            continue;
                        };
                        if shade!(i, o, rgb) {
                            run_ends = true;
                            break;
                        }
                    }
                    // The normals' gradients (in object space where they are the dataset's:
                    // the lanes take them to world space, and test the dataset's own for
                    // vanishing).
                    // (Which of the run's cells are interior: taken only for runs with a
                    // sample to shade.)
                    let interior = if same_cells && count != 0 {
                        data.interior8(&cells8)
                    } else {
                        0
                    };
                    for (j, &i) in at[..count].iter().enumerate() {
                        let i = i as usize;
                        let g = if interior >> i & 1 != 0 {
                            data.trilinear_gradient_in(&ps, &cells8, i, &mut cache)
                        } else {
                            let (p, w) = ([ps[0][i], ps[1][i], ps[2][i]], origin + mids[i] * dir);
                            match obj.field_gradient_in(w, p, 9, &mut cache) {
                                (_, true) => [f64::NAN; 3],
                                (g, false) => g.to_array(),
                            }
                        };
                        for (a, x) in grads.iter_mut().zip(g) {
                            a[j] = x;
                        }
                    }
                    h.colours(count, &view, &rgb32, &mut colours, &grads);
                } else {
                    while pass != 0 {
                        let i = pass.trailing_zeros() as usize;
                        pass &= pass - 1;
                        let (o, Some(rgb)) = tables.opacity_colour(vs[i]) else {
                            continue;
                        };
                        let (weight, ends) = acc.weigh(obj.alpha_at_most_one(o as f64, lens[i]));
                        let c = DVec3::from_array(rgb.map(|x| x as f64));
                        let (p, w) = ([ps[0][i], ps[1][i], ps[2][i]], origin + mids[i] * dir);
                        let normal = || obj.gradient_normal(w, -dir, p, 9, &mut cache);
                        let c = match headlit {
                            Some(h) => h.colour(c, normal),
                            None => self.illuminate_colour(obj, w, dir, c, *k, *e, normal),
                        };
                        for (a, x) in colours.iter_mut().zip(c.to_array()) {
                            a[count] = x;
                        }
                        weights[count] = weight;
                        count += 1;
                        if ends {
                            run_ends = true;
                            break;
                        }
                    }
                }
                for (j, &w) in weights[..count].iter().enumerate() {
                    acc.add_weighted(w, DVec3::new(colours[0][j], colours[1][j], colours[2][j]));
                }
                if run_ends {
                    return acc.result();
                }
                continue;
            }
            while pass != 0 {
                let i = pass.trailing_zeros() as usize;
                pass &= pass - 1;
                let len = lens[i];
                let (p, w) = ([ps[0][i], ps[1][i], ps[2][i]], origin + mids[i] * dir);
                let o = lean.opacity_from_value(vs[i], p, &mut f) as f64;
                if o <= 0.0 {
                    continue;
                }
                let (alpha, colour) =
                    self.finish_lean(obj, lean, o, p, w, dir, len, &mut f, &mut cache);
                if acc.add(alpha, colour) {
                    return acc.result();
                }
            }
        }
        acc.result()
    }
}
