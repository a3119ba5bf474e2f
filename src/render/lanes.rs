//! The lighting of several samples at once: [`HeadlitLanes`] is [`Headlit`] under a single
//! directional light with an integer specular exponent, its constants spread across f64 lanes
//! once per scene and object ([`Compiled::lanes`]), each lane doing the scalar operations in
//! the same order, so giving the same bits. The batched march and the packet march use it;
//! the illumination model itself, and the normal of a single sample, are `shade`'s.

use super::*;

/// The lanes of [`HeadlitLanes`]: samples of a run side by side.
pub(super) type Lanes = wide::f64x2;

const LANES: usize = 2;

/// [`Headlit`] under a single light, its constants spread across lanes once per ray, for the
/// lighting of a run's samples side by side ([`HeadlitLanes::colours`]).
pub(super) struct HeadlitLanes {
    pub(super) ka_ambient: [Lanes; 3],
    pub(super) kd: Lanes,
    /// ks where it is above 0, else `None` (no highlight): tested once per pair rather than
    /// compared as a float.
    pub(super) ks: Option<Lanes>,
    /// The specular exponent, an integer.
    pub(super) e: u32,
    pub(super) to_light: [Lanes; 3],
    pub(super) radiance: [Lanes; 3],
    pub(super) flip: bool,
    /// Where the gradients come in object space: the matrix taking them to world space
    /// ([`CObj::grad_to_world`]); else [`ToWorld::None`] (world space).
    pub(super) to_world: ToWorld,
}

/// The matrix of [`HeadlitLanes::to_world`]. (With the tag a byte of its own: as an `Option`,
/// telling `None` from the others takes a comparison of sixteen bytes.)
#[repr(u8)]
pub(super) enum ToWorld {
    /// None: the gradients come in world space.
    None,
    /// Its columns, by column and row.
    General([[Lanes; 3]; 3]),
    /// Its diagonal, where every entry off the diagonal is zero (an object scaled or flipped
    /// along its axes, as the MNI brain is). Each world component is then the diagonal
    /// product alone, where glam's `m * g` adds the zero products to it: the two differ only
    /// where that product is −0 (which a +0 product makes +0) or where the gradient has an
    /// infinity or a NaN (which has no normal either way: its length is not finite and
    /// positive). A component's sign of zero cannot change a lit colour: it reaches the
    /// lighting's sums only as a term ±0, so they differ at most in the sign of a zero too,
    /// which no comparison with 0 sees, and every product taken where they pass has nonzero
    /// factors there (`headlit_lanes_are_headlit` compares both forms with the scalar
    /// lighting).
    Diagonal([Lanes; 3]),
}

impl HeadlitLanes {
    /// `h` for normals flipped towards the viewer if `flip`, where it has exactly one light
    /// and an integer specular exponent (`powf` is left to the scalar path); for gradients
    /// given in object space and taken to world space by `to_world` if that is given.
    pub(super) fn new(
        h: &Headlit<'_>,
        flip: bool,
        to_world: Option<glam::DMat3>,
    ) -> Option<HeadlitLanes> {
        let (&[(l, rad)], Some(e)) = (h.lights, h.e.integer) else {
            return None;
        };
        let splat = |v: DVec3| v.to_array().map(Lanes::splat);
        Some(HeadlitLanes {
            ka_ambient: splat(h.ka_ambient),
            kd: Lanes::splat(h.kd),
            ks: (h.ks > 0.0).then(|| Lanes::splat(h.ks)),
            e,
            to_light: splat(l),
            radiance: splat(rad),
            flip,
            to_world: match to_world {
                None => ToWorld::None,
                Some(m) => {
                    let off = [
                        m.x_axis.y, m.x_axis.z, m.y_axis.x, m.y_axis.z, m.z_axis.x, m.z_axis.y,
                    ];
                    if off.iter().all(|&x| x == 0.0) {
                        ToWorld::Diagonal([m.x_axis.x, m.y_axis.y, m.z_axis.z].map(Lanes::splat))
                    } else {
                        ToWorld::General([splat(m.x_axis), splat(m.y_axis), splat(m.z_axis)])
                    }
                }
            },
        })
    }

    /// [`Headlit::colour`] of samples `0..count` of a run, side by side in lanes, each lane
    /// doing the scalar operations in the same order, so giving the same bits: sample j's lit
    /// colour `(c[0][j], c[1][j], c[2][j])` from its colour `(rgb[0][j], rgb[1][j], rgb[2][j])`
    /// as the tables give it (f32, converted to f64 here, two to a register, as the march
    /// converted each), with the normal of its gradient `grad[·][j]` by [`normal_of_gradient`],
    /// where a gradient that vanishes is given as NaN (it has no normal either way). Gradients
    /// in object space (`to_world` given: a dataset's) are also tested here as [`vanishing`]
    /// tests them, so that the caller may pass them as they are. `view`: towards the eye
    /// (−(the ray's direction)) in lanes, the one number of [`Headlit`] that is the ray's (the
    /// rest is prepared once per scene and object: [`Compiled::lanes`]).
    #[inline]
    pub(super) fn colours(
        &self,
        count: usize,
        view: &[Lanes; 3],
        rgb: &[[f32; 8]; 3],
        c: &mut [[f64; 8]; 3],
        grad: &[[f64; 8]; 3],
    ) {
        for q in 0..8 / LANES {
            if q * LANES >= count {
                break;
            }
            self.colours_at(q * LANES, view, rgb, c, grad);
        }
    }

    /// [`HeadlitLanes::colours`] of samples `at..at + LANES` (`at + LANES <= 8`). Apart, so
    /// that the constants are read where they are used rather than held (and spilled) across
    /// the run.
    #[inline(never)]
    pub(super) fn colours_at(
        &self,
        at: usize,
        view: &[Lanes; 3],
        rgb: &[[f32; 8]; 3],
        c: &mut [[f64; 8]; 3],
        grad: &[[f64; 8]; 3],
    ) {
        let zero = Lanes::ZERO;
        let (ka, kd, l, rad) = (&self.ka_ambient, self.kd, &self.to_light, &self.radiance);
        let lanes = |a: &[f64; 8]| Lanes::new(std::array::from_fn(|k| a[at + k]));
        let mut g = [lanes(&grad[0]), lanes(&grad[1]), lanes(&grad[2])];
        let mut vanishes = None;
        if !matches!(self.to_world, ToWorld::None) {
            // A dataset's gradient vanishes where its largest component in magnitude is at
            // most `ZERO_GRADIENT` ([`vanishing`]); which of equal components is the largest
            // does not matter, nor how a NaN is ordered: a gradient with a NaN (or an
            // infinity) has no normal anyway (its reciprocal length is NaN, or 0).
            let a = g.map(Lanes::abs);
            vanishes = Some(
                a[0].fast_max(a[1].fast_max(a[2]))
                    .simd_le(Lanes::splat(ZERO_GRADIENT)),
            );
            g = match &self.to_world {
                ToWorld::None => g,
                // `m * g` as glam computes it: column x times g.x, plus column y times g.y,
                // plus column z times g.z (a NaN gradient stays NaN in every axis).
                ToWorld::General([x, y, z]) => {
                    std::array::from_fn(|i| x[i] * g[0] + y[i] * g[1] + z[i] * g[2])
                }
                // (The same lighting: see `ToWorld::Diagonal`.)
                ToWorld::Diagonal(d) => std::array::from_fn(|i| d[i] * g[i]),
            };
        }
        // `(-g).try_normalize()`: (−g)·(−g) is g·g, and (−g)·rcp is g·(−rcp), bit for bit
        // (a NaN's sign aside, and a NaN gradient has no normal).
        let rcp = Lanes::ONE / (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        // `rcp.is_finite() && rcp > 0.0`: 0 < rcp < ∞ (a NaN fails both); and no normal where
        // the gradient vanishes. (Everything below depends on the gradient only through
        // `valid` where it is false, so such a lane is lit as one given as NaN.)
        let valid = rcp.simd_gt(zero) & rcp.simd_lt(Lanes::splat(f64::INFINITY));
        let valid = match vanishes {
            Some(v) => valid & !v,
            None => valid,
        };
        // The normal is ±u, its sign left to N·L alone: rounding to nearest is symmetric, so
        // negating a factor of products and sums negates them exactly, and (−u)·x is −(u·x)
        // bit for bit. The normal −u is flipped where −(u·V) < 0, that is where u·V > 0 (a
        // NaN, or ±0, neither); there N·L is u·L, else −(u·L). The mirror direction
        // `2(N·L)N − L` is the same for both signs, (2(−a))(−b) being (2a)b.
        let u = g.map(|x| x * rcp);
        let ndl_u = u[0] * l[0] + u[1] * l[1] + u[2] * l[2];
        let neg = Lanes::splat(-0.0);
        let sign = if self.flip {
            let front = (u[0] * view[0] + u[1] * view[1] + u[2] * view[2]).simd_gt(zero);
            !front & neg
        } else {
            neg
        };
        let ndl = ndl_u ^ sign;
        // The samples' colours as the tables give them, in f32, converted here.
        let cl: [Lanes; 3] =
            std::array::from_fn(|ch| Lanes::new(std::array::from_fn(|k| rgb[ch][at + k] as f64)));
        let kdc = cl.map(|x| kd * x);
        let lit = ndl.simd_gt(zero) & valid;
        // `ndl.max(0.0)` (ndl where above 0, else +0: a NaN and −0 included), and 1 where
        // there is no normal, so that `term` is then `kd · C` itself (x·1 is x).
        let m = (ndl & lit) | (Lanes::ONE & !valid);
        let mut term = kdc.map(|x| x * m);
        if let Some(ks) = self.ks {
            let s = Lanes::splat(2.0) * ndl_u;
            let r = [s * u[0] - l[0], s * u[1] - l[1], s * u[2] - l[2]];
            let rv = r[0] * view[0] + r[1] * view[1] + r[2] * view[2];
            let spec = lit & rv.simd_gt(zero);
            if spec.any() {
                // Lanes without a highlight add −0, x + (−0) being x bit for bit (+0 and NaN
                // included): one selection rather than one per channel.
                let p = spec.bitselect(ks * powi_in(rv, Lanes::ONE, self.e), neg);
                term = term.map(|x| x + p);
            }
        }
        // The ambient term only now, its constants read here rather than held (and spilled)
        // across the highlight.
        let col = [
            ka[0] * cl[0] + rad[0] * term[0],
            ka[1] * cl[1] + rad[1] * term[1],
            ka[2] * cl[2] + rad[2] * term[2],
        ];
        // `is_finite` of all three: x · 0 is ±0 for finite x, NaN for the others, and ±0 + y is
        // as finite as y, NaN + y NaN; so `((x·0 + y)·0 + z)·0` is ±0 where all three are
        // finite, else NaN (one product fewer than summing the three products).
        let finite = (((col[0] * zero + col[1]) * zero + col[2]) * zero).simd_eq(zero);
        for (o, x) in c.iter_mut().zip(col) {
            o[at..at + LANES].copy_from_slice(&(x & finite).to_array());
        }
    }
}

impl Compiled {
    /// [`Compiled::lanes`] of `obj`: what the batched march would make for every ray (the view,
    /// which they do not hold, apart).
    pub(super) fn headlit_lanes(&self, obj: &CObj) -> Option<HeadlitLanes> {
        let s = obj.lean.as_ref()?.direct_shading()?;
        let [ka, kd, ks, spec] = s.coefficients;
        let h = Headlit::new(
            self,
            obj,
            DVec3::ZERO,
            [ka, kd, ks],
            Specular::of_field(spec),
        )?;
        let to_world = obj.object_gradient(9).then_some(obj.grad_to_world);
        HeadlitLanes::new(&h, obj.flip_normals, to_world)
    }
}
