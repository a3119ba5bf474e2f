//! The discrete ray tracer: DVR, DSR and MIP, shadows, reflection and refraction.
//!
//! A finished [`SceneDesc`] is compiled once into an immutable [`Compiled`] scene: each object's
//! world-to-object matrix, boundary box, step and opacity exponent, normal neighbourhood, the
//! prefix of its program that determines each field, its empty-space grid, and the scene's
//! [`Plan`] of the effects it can show (see `docs/render-plan.md`). Rays are then traced over
//! image tiles in parallel (rayon); every pixel is computed independently in a fixed order, so
//! the bytes of an image do not depend on the number of threads.
//!
//! Along a ray, each object's box is clipped exactly; its interval is cut into segments of the
//! step size, the last one shorter, and each segment is represented by the sample at its midpoint
//! with opacity `α = 1 − (1 − o)^(ℓ / reference)` for its true length ℓ. For constant media the
//! product of the transmittances is therefore exactly the Beer–Lambert value `(1 − o)^(L/ref)`
//! for any step. Samples of overlapping objects are merged in order of depth, together with the
//! surface hits of DSR objects and the layers of MIP objects. Compositing is front to back with
//! early termination once the transmittance falls below `Optimise::termination` (default
//! [`T_MIN`]). Shadow rays use the same
//! segments; mirror and refracted rays start at surface hits.

use crate::dataset::{CellGradients, Cells8, Dataset, Filter};
use crate::error::{Error, ErrorCode, Result};
use crate::kernel::Lean;
use crate::program::{prefix_for, run, Instr, NormalFn, Sample, SampleEnv, SampleRole};
use crate::scene::{Light, ObjectDesc, SceneDesc, Settings};
use crate::skip::{EntryMap, Pinhole, SkipGrid, Walk};
use crate::types::{Attenuation, Feature, Fields, RenderType, FIELD_COUNT, MAX_SPECULAR};
use glam::{DMat4, DVec3};
use rayon::prelude::*;
use std::sync::Arc;

pub use crate::types::T_MIN;

/// Super-sampling refines a pixel when a colour channel differs from a 4-neighbour's by more
/// than this.
pub const SUPER_SAMPLE_CONTRAST: f32 = 4.0 / 255.0;

/// Central differences below this change of F count as a zero gradient.
const ZERO_GRADIENT: f64 = 1e-7;

/// Side of the square pixel tiles traced in parallel.
const TILE: u32 = 16;

/// Side of the packet march's tiles where the image has enough of them ([`packet_tile`]): a
/// tile's 32 lanes stay full for longer before its last rays drain them.
const PACKET_TILE: u32 = 32;

/// The packet march's tile side for an image of `width × height`: [`PACKET_TILE`] where that
/// gives at least 16 tiles a thread (work-stealing balances tiles of unequal cost only when
/// there are many), else [`TILE`]. Only the order of the work depends on it, not a pixel.
fn packet_tile(width: u32, height: u32) -> u32 {
    let big = width.div_ceil(PACKET_TILE) as usize * height.div_ceil(PACKET_TILE) as usize;
    if big >= 16 * rayon::current_num_threads() {
        PACKET_TILE
    } else {
        TILE
    }
}

#[cfg(target_arch = "x86_64")]
mod simd;

/// A rendered image: linear RGB in [0, 1], row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Pixels, `width * height` of them.
    pub pixels: Vec<[f32; 3]>,
}

impl Image {
    /// The pixel at column `x`, row `y` (row 0 at the top).
    pub fn pixel(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[(y * self.width + x) as usize]
    }

    /// 8-bit RGB, rounded; anything non-finite becomes 0.
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.pixels.iter().flat_map(|p| p.map(to_u8)).collect()
    }
}

fn to_u8(v: f32) -> u8 {
    if v.is_finite() {
        (v.clamp(0.0, 1.0) * 255.0).round() as u8
    } else {
        0
    }
}

struct CObj {
    program: Vec<Instr>,
    /// The program up to its last instruction that may write opacity: where that leaves o = 0
    /// the rest cannot change it, and is skipped.
    o_prefix: usize,
    to_object: DMat4,
    /// Its inverse, object → world (for [`EntryMap`]).
    to_world: DMat4,
    box_min: DVec3,
    box_max: DVec3,
    step: f64,
    inv_ref: f64,
    delta: DVec3,
    visible: bool,
    flip_normals: bool,
    normals: Vec<NormalFn>,
    /// Where the geometry field is a dataset's value (its last writer is `vlDataset`), normals
    /// come from that dataset's interpolated grid gradients.
    f_dataset: Option<(Arc<Dataset>, Filter)>,
    /// The linear part of object → world for gradients: ∇_world F = Aᵀ ∇_object F, A the linear
    /// part of world → object.
    grad_to_world: glam::DMat3,
    /// The program compiled for the lean kernel, where it reads only constants, datasets and
    /// transfer functions (and the kernel is not switched off).
    lean: Option<Lean>,
    env: SampleEnv,
    /// Blocks where opacity is provably 0.
    skip: Option<Arc<SkipGrid>>,
    /// For a lean program with a value head rendered by the batched march, under empty-space
    /// skipping: the cells of its dataset whose samples can pass the zero test (see
    /// [`crate::dataset::CellMask`]).
    cells: Option<Arc<crate::dataset::CellMask>>,
    /// The rendering algorithm the object captured.
    render_type: RenderType,
    /// Iso-surfaces (field index, threshold) for DSR.
    surfaces: Vec<(usize, f32)>,
    /// Per field: the program up to its last instruction that may write it.
    prefixes: [usize; FIELD_COUNT],
    /// Per field: its value where that last instruction is a constant `vlSet` (the field is
    /// then that constant inside the boundary, folded once instead of run per evaluation).
    constants: [Option<f32>; FIELD_COUNT],
    cast_shadows: bool,
    receive_shadows: bool,
    cast_reflections: bool,
    receive_reflections: bool,
    refract: bool,
    reflect_background: bool,
    recursion: i32,
}

/// One axis of [`CObj::clip`]: the interval `(t0, t1)` narrowed to where the ray's coordinate
/// `o + t·d` lies in [min, max]; `None` where `d` is 0 and `o` is outside.
#[inline(always)]
fn slab((mut t0, mut t1): (f64, f64), o: f64, d: f64, min: f64, max: f64) -> Option<(f64, f64)> {
    if d == 0.0 {
        // (A NaN `o` is not outside.)
        if o < min || o > max {
            return None;
        }
        return Some((t0, t1));
    }
    let inv = 1.0 / d;
    let (a, b) = ((min - o) * inv, (max - o) * inv);
    // `a.min(b)` and `a.max(b)`: b where a is NaN, a where b is. Neither NaN (one comparison
    // tells), a `minsd` and a `maxsd`: the same values as with the NaN terms.
    let (lo, hi) = if a.is_nan() || b.is_nan() {
        let x = if a.is_nan() { b } else { a };
        (x, x)
    } else {
        (if b < a { b } else { a }, if b > a { b } else { a })
    };
    if lo > t0 {
        t0 = lo;
    }
    if hi < t1 {
        t1 = hi;
    }
    Some((t0, t1))
}

impl CObj {
    fn new(
        o: &ObjectDesc,
        datasets: &Arc<crate::program::Datasets>,
        optimise: crate::scene::Optimise,
    ) -> CObj {
        let to_world = o.matrix();
        let b = crate::scene::v3(o.boundary);
        let box_min = DVec3::splat(0.5) - b * 0.5;
        let box_max = DVec3::splat(0.5) + b * 0.5;
        let step = o.state.step as f64;
        let delta = match o.state.neighborhood {
            Some(d) => crate::scene::v3(d),
            None => {
                let extent = (0..3)
                    .map(|i| to_world.col(i).truncate().length() * b[i])
                    .fold(f64::INFINITY, f64::min);
                DVec3::splat((step * 0.5).max(extent * 1e-3))
            }
        };
        let f_prefix = prefix_for(&o.program, Fields::F);
        // Grid gradients apply where F is a dataset's value at the sample point itself, i.e. no
        // spatial function moved the point first.
        let moved = o.program[..f_prefix]
            .iter()
            .any(|i| matches!(i, Instr::Spatial { .. }));
        let f_dataset = match f_prefix.checked_sub(1).map(|i| &o.program[i]) {
            Some(Instr::Dataset { data, filter, .. }) if !moved => Some((data.clone(), *filter)),
            _ => None,
        };
        let to_object = to_world.inverse();
        let r = &o.state;
        let o_prefix = prefix_for(&o.program, Fields::O);
        let lean = if optimise.lean_kernel {
            Lean::new(&o.program, o_prefix)
        } else {
            None
        };
        let prefixes: [usize; FIELD_COUNT] =
            std::array::from_fn(|i| prefix_for(&o.program, Fields::from_index(i)));
        let constants =
            std::array::from_fn(
                |i| match prefixes[i].checked_sub(1).map(|k| &o.program[k]) {
                    Some(Instr::Set { value, .. }) => Some(*value),
                    _ => None,
                },
            );
        CObj {
            render_type: r.render_type,
            surfaces: r.surfaces.clone(),
            prefixes,
            constants,
            cast_shadows: r.toggle(Feature::CastShadows),
            receive_shadows: r.toggle(Feature::ReceiveShadows),
            cast_reflections: r.toggle(Feature::CastReflections),
            receive_reflections: r.toggle(Feature::ReceiveReflections),
            refract: r.toggle(Feature::Refract),
            reflect_background: r.toggle(Feature::ReflectBackground),
            recursion: r.recursion,
            skip: o
                .skip
                .get_or_init(|| {
                    SkipGrid::build(&o.program[..o_prefix], box_min, box_max).map(Arc::new)
                })
                .clone(),
            o_prefix,
            f_dataset,
            grad_to_world: glam::DMat3::from_mat4(to_object).transpose(),
            // Only the batched march reads the mask: direct volume rendering of a value-head
            // program without normal functions (see `Compiled::march_one`).
            cells: lean
                .as_ref()
                .and_then(Lean::value_head)
                .filter(|_| {
                    optimise.skip_empty && r.render_type == RenderType::Dvr && o.normals.is_empty()
                })
                .map(|(data, z)| data.cells_above(z)),
            lean,
            env: SampleEnv {
                datasets: datasets.clone(),
                filter: Filter::new(r.interpolation, r.cubic),
                children: Arc::new(compile_children(o, to_object, datasets)),
            },
            program: o.program.clone(),
            to_object,
            to_world,
            box_min,
            box_max,
            step,
            inv_ref: 1.0 / o.state.reference as f64,
            delta,
            visible: o.state.toggle(Feature::Visible),
            flip_normals: o.state.toggle(Feature::FlipNormals),
            normals: o.normals.clone(),
        }
    }

    /// The world ray `origin + t·dir` in the object's coordinates, `o + t·d` (the same t).
    #[inline]
    fn object_ray(&self, origin: DVec3, dir: DVec3) -> (DVec3, DVec3) {
        (
            self.to_object.transform_point3(origin),
            self.to_object.transform_vector3(dir),
        )
    }

    /// Whether a ray of this kind sees the object (mirror rays: `cast_reflections`).
    #[inline]
    fn seen_by(&self, ray: Ray) -> bool {
        if ray.mirror {
            self.cast_reflections
        } else {
            self.visible
        }
    }

    /// The parameter interval [t0, t1] (t ≥ 0) where the object-space ray `o + t·d` lies
    /// inside the boundary box.
    ///
    /// Per axis, the slab's entry `lo` and exit `hi` are the minimum and maximum of its two
    /// face parameters with NaN ignored (either NaN: the other; both: NaN), as `f64::min` and
    /// `f64::max` give them, and t0 and t1 then take them with comparisons, which ignore a NaN
    /// too: t0 starts at +0 and only ever takes a larger value, t1 starts at +∞, so neither is
    /// NaN, and the NaN-aware `f64::max` / `f64::min` on them (7 instructions each, twice an axis
    /// a ray) give the same values. Only the sign of a zero can differ (a tie of +0 and −0, where
    /// `f64::min` and `f64::max` may answer either): t0 is never −0 in either form (it starts at
    /// +0 and moves only to a value above it), and a t1 of ±0 fails `t0 < t1` in both.
    /// (`clip_is_the_nan_aware_clip` checks them bit for bit, special values included.)
    /// Always inlined: a call left to the compiler's choice stayed out of line in
    /// [`Compiled::trace_ray`], passing the ray and the interval through memory.
    #[inline(always)]
    fn clip(&self, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
        let (min, max) = (self.box_min, self.box_max);
        // Axis by axis, written out: as a loop the compiler kept the loop and picked each
        // axis's values by index.
        let t = slab((0.0, f64::INFINITY), o.x, d.x, min.x, max.x)?;
        let t = slab(t, o.y, d.y, min.y, max.y)?;
        let (t0, t1) = slab(t, o.z, d.z, min.z, max.z)?;
        (t0 < t1 && t1.is_finite()).then_some((t0, t1))
    }

    fn inside(&self, p: DVec3) -> bool {
        p.cmpge(self.box_min).all() && p.cmple(self.box_max).all()
    }

    /// The transmittance of a segment `len` long of medium with opacity `o` per reference
    /// length: `(1 − o)^(len / reference)`, 0 for an opaque medium.
    #[inline]
    fn segment_transmittance(&self, o: f64, len: f64) -> f64 {
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

    /// The opacity at world point `w` (inside the boundary), by the lean kernel where it applies.
    #[inline]
    fn opacity_at(&self, w: DVec3) -> f64 {
        if let Some(lean) = &self.lean {
            let p = self.to_object.transform_point3(w).as_vec3().to_array();
            let mut f = [0.0f32; FIELD_COUNT];
            return lean.opacity(p, &mut f) as f64;
        }
        let mut s = self.sample_at(w);
        run(&self.program[..self.o_prefix], &mut s);
        s.value(0) as f64
    }

    fn sample_at(&self, w: DVec3) -> Sample<'_> {
        let p = self.to_object.transform_point3(w);
        Sample::with_env(p.as_vec3().to_array(), w.to_array(), &self.env)
    }

    /// Field `field` at world point `w` (0 outside the boundary: fields are bounded), running
    /// only the part of the program that can change it.
    fn field_at(&self, w: DVec3, field: usize) -> f64 {
        let p = self.to_object.transform_point3(w);
        if !self.inside(p) {
            return 0.0;
        }
        if let Some(v) = self.constants[field] {
            return v as f64;
        }
        let mut s = Sample::with_env(p.as_vec3().to_array(), w.to_array(), &self.env);
        run(&self.program[..self.prefixes[field]], &mut s);
        s.value(field) as f64
    }

    /// The world-space gradient of field `field` at `w` (object point `p`), and whether it
    /// vanishes: for the geometry field where it is a dataset's value, from the dataset's
    /// interpolated grid gradients; otherwise by central differences over the neighbourhood.
    /// `cache` holds the node differences of the last dataset cell read (see
    /// [`CellGradients`]): one per object and ray, or a fresh one.
    #[inline]
    fn field_gradient(
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
    fn object_gradient(&self, field: usize) -> bool {
        field == 9 && self.f_dataset.is_some()
    }

    /// [`CObj::field_gradient`] before the dataset's gradient is taken to world space (see
    /// [`CObj::object_gradient`]), so that the lighting in lanes can do that product too.
    #[inline]
    fn field_gradient_in(
        &self,
        w: DVec3,
        p: [f32; 3],
        field: usize,
        cache: &mut CellGradients,
    ) -> (DVec3, bool) {
        if let (9, Some((data, filter))) = (field, &self.f_dataset) {
            return vanishing(data.gradient_cached(p, *filter, cache));
        }
        self.sampled_gradient(w, field)
    }

    /// [`CObj::field_gradient`] by world-space central differences of the field.
    #[inline(never)]
    fn sampled_gradient(&self, w: DVec3, field: usize) -> (DVec3, bool) {
        let mut diff = DVec3::ZERO;
        let mut grad = DVec3::ZERO;
        for i in 0..3 {
            let mut e = DVec3::ZERO;
            e[i] = self.delta[i];
            let d = self.field_at(w + e, field) - self.field_at(w - e, field);
            diff[i] = d;
            grad[i] = d / (2.0 * self.delta[i]);
        }
        (grad, diff.abs().max_element() <= ZERO_GRADIENT)
    }

    /// The normal from the gradient alone: −∇F at `w` (object point `p`), flipped towards the
    /// viewer if asked; `None` where the gradient vanishes.
    #[inline(always)]
    fn gradient_normal(
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
    fn normal(&self, w: DVec3, view: DVec3, s: &mut Sample<'_>, field: usize) -> Option<DVec3> {
        let n = self.gradient_normal(w, view, s.position(), field, &mut CellGradients::default());
        if self.normals.is_empty() {
            return n;
        }
        let mut nv = n.unwrap_or(DVec3::ZERO).as_vec3().to_array();
        s.role = SampleRole::Normal;
        for f in &self.normals {
            f(&mut nv, s);
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

/// A dataset's gradient `g`, and whether it vanishes (no component above [`ZERO_GRADIENT`]
/// in magnitude).
#[inline(always)]
fn vanishing(g: [f64; 3]) -> (DVec3, bool) {
    let g = DVec3::from_array(g);
    (g, g.abs().max_element() <= ZERO_GRADIENT)
}

/// The normal of gradient `grad` (`zero`: it vanishes): −`grad` normalised, flipped towards
/// `view` if `flip`; `None` where the gradient vanishes or cannot be normalised.
#[inline]
fn normal_of_gradient(grad: DVec3, zero: bool, view: DVec3, flip: bool) -> Option<DVec3> {
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
fn try_normalize(v: DVec3) -> Option<DVec3> {
    let rcp = v.length_recip();
    (rcp.to_bits().wrapping_sub(1) < f64::MAX.to_bits()).then(|| v * rcp)
}

/// The children of `o` as its functions see them; `world_to_o` maps the world to `o`'s space.
pub(crate) fn compile_children(
    o: &ObjectDesc,
    world_to_o: DMat4,
    datasets: &Arc<crate::program::Datasets>,
) -> Vec<crate::program::Child> {
    o.children
        .iter()
        .map(|c| {
            let to_child = c.matrix().inverse();
            let world_to_child = to_child * world_to_o;
            let b = crate::scene::v3(c.boundary);
            let r = &c.state;
            crate::program::Child {
                program: c.program.clone(),
                to_child,
                world_to_child,
                box_min: DVec3::splat(0.5) - b * 0.5,
                box_max: DVec3::splat(0.5) + b * 0.5,
                env: SampleEnv {
                    datasets: datasets.clone(),
                    filter: Filter::new(r.interpolation, r.cubic),
                    children: Arc::new(compile_children(c, world_to_child, datasets)),
                },
            }
        })
        .collect()
}

/// What kind of ray is being traced: how many bounces it has made, whether it is a mirror ray
/// (it then sees only objects that cast reflections) and what it shows where it escapes.
#[derive(Clone, Copy, Debug)]
struct Ray {
    depth: i32,
    mirror: bool,
    background: bool,
}

impl Ray {
    const PRIMARY: Ray = Ray {
        depth: 0,
        mirror: false,
        background: true,
    };
}

/// A contribution at one depth along a ray: a surface hit or a MIP layer; `bend` is the new
/// direction of a refracting surface (the ray continues that way behind it).
#[derive(Clone, Copy, Debug)]
struct Layer {
    t: f64,
    alpha: f64,
    colour: DVec3,
    bend: Option<(DVec3, DVec3)>,
}

/// The transmittance `t^e` of a segment `e` references long through a medium of per-reference
/// transmittance `t`: the common exponents by [`transmit_common`], the others by `powf`.
#[inline]
fn transmit(t: f64, e: f64) -> f64 {
    transmit_common(t, e).unwrap_or_else(|| t.powf(e))
}

/// `t^e` for the common exponents (a step of one, a half, a quarter or an eighth of the
/// reference, or twice or four times it) by square roots and products, within two units in
/// the last place (each square root and product rounds once, and a square root halves the
/// relative error it is given) and much cheaper than `powf` (at an eighth, the sweep's finest
/// step, `powf` was a third of the frame's instructions); `None` for any other exponent. The
/// half first: the usual step, the MNI frame's.
#[inline(always)]
fn transmit_common(t: f64, e: f64) -> Option<f64> {
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
fn transmit_at_most_one(o: f64, e: f64) -> f64 {
    debug_assert!(o <= 1.0 || o.is_nan(), "{o}");
    let t = 1.0 - o;
    transmit_common(t, e).unwrap_or_else(|| if o >= 1.0 { 0.0 } else { t.powf(e) })
}

/// [`Compiled::illuminate_colour`] prepared for one ray and one object's constant coefficients
/// where every light is directional and no shadow falls on the object (the peer benchmark's
/// headlight): no per-light case analysis, attenuation or shadow test per sample, and the
/// ambient term's product of constants taken once. The same arithmetic in the same order, so
/// the same colour, bit for bit.
struct Headlit<'a> {
    /// ka × the ambient radiance (the left product of `ka · I_amb · C`).
    ka_ambient: DVec3,
    kd: f64,
    ks: f64,
    e: Specular,
    /// Towards the eye: −(the ray's direction).
    view: DVec3,
    /// Towards each light, and its radiance; empty where neither kd nor ks is above 0.
    lights: &'a [(DVec3, DVec3)],
}

impl<'a> Headlit<'a> {
    /// The preparation for object `obj` seen along `dir` with coefficients ka, kd, ks and
    /// exponent `e`, or `None` where a light is not directional or a shadow may fall on it.
    fn new(
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
    fn colour(&self, c: DVec3, normal: impl FnOnce() -> Option<DVec3>) -> DVec3 {
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
fn lit(
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

/// The lanes of [`HeadlitLanes`]: samples of a run side by side.
type Lanes = wide::f64x2;
const LANES: usize = 2;

/// [`Headlit`] under a single light, its constants spread across lanes once per ray, for the
/// lighting of a run's samples side by side ([`HeadlitLanes::colours`]).
struct HeadlitLanes {
    ka_ambient: [Lanes; 3],
    kd: Lanes,
    /// ks where it is above 0, else `None` (no highlight): tested once per pair rather than
    /// compared as a float.
    ks: Option<Lanes>,
    /// The specular exponent, an integer.
    e: u32,
    to_light: [Lanes; 3],
    radiance: [Lanes; 3],
    flip: bool,
    /// Where the gradients come in object space: the matrix taking them to world space
    /// ([`CObj::grad_to_world`]); else [`ToWorld::None`] (world space).
    to_world: ToWorld,
}

/// The matrix of [`HeadlitLanes::to_world`]. (With the tag a byte of its own: as an `Option`,
/// telling `None` from the others took a comparison of sixteen bytes.)
#[repr(u8)]
enum ToWorld {
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
    fn new(h: &Headlit<'_>, flip: bool, to_world: Option<glam::DMat3>) -> Option<HeadlitLanes> {
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
    fn colours(
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
    fn colours_at(
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

/// A specular exponent e, examined once (per ray for direct shading, per sample otherwise)
/// for the specular term's `x^e`: integer exponents (the usual case: `VLSPECULAR(20)`) by
/// repeated squaring, which is exact to rounding and much cheaper than `powf`.
#[derive(Clone, Copy, Debug)]
struct Specular {
    e: f64,
    integer: Option<u32>,
}

impl Specular {
    /// The exponent of a specular-exponent field value.
    #[inline]
    fn of_field(value: f64) -> Specular {
        Specular::new(value * MAX_SPECULAR as f64)
    }

    #[inline]
    fn new(e: f64) -> Specular {
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
    fn pow(self, x: f64) -> f64 {
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
fn powi(x: f64, k: u32) -> f64 {
    powi_in(x, 1.0, k)
}

/// [`powi`]'s products for any number type with a multiplication (f64, or f64 lanes, each
/// lane then the scalar products in the same order); `one` is its 1.
#[inline]
fn powi_in<T: Copy + std::ops::MulAssign>(mut x: T, one: T, mut k: u32) -> T {
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

/// What a scene calls for: effects its objects, toggles and lights can actually show. An
/// effect that nothing in the scene can exhibit costs nothing (see `docs/render-plan.md`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Plan {
    /// Shadow rays: some object casts, some object receives, and a light exists.
    pub shadows: bool,
    /// Mirror rays: some object receives reflections (with recursion above 0).
    pub reflections: bool,
    /// Refracted rays: some object refracts (with recursion above 0).
    pub refraction: bool,
}

/// A scene compiled for tracing: immutable, shared by all worker threads.
pub struct Compiled {
    objects: Vec<CObj>,
    /// The lights, each with its radiance in f64.
    lights: Vec<(Light, DVec3)>,
    /// The ambient light's radiance in f64.
    ambient: DVec3,
    /// Where every light is directional: each light's direction towards it and radiance (see
    /// [`Headlit`]).
    directional: Option<Vec<(DVec3, DVec3)>>,
    /// Per object, the lighting lanes of its direct shading (`DirectShading`) where every
    /// light is directional and there is one ([`HeadlitLanes`]): what [`Headlit::new`] and
    /// [`HeadlitLanes::new`] would give every ray, but for its view, prepared once.
    lanes: Vec<Option<HeadlitLanes>>,
    settings: Settings,
    plan: Plan,
}

impl Compiled {
    /// Compiles a scene description.
    pub fn new(desc: &SceneDesc) -> Compiled {
        let objects: Vec<CObj> = desc
            .objects
            .iter()
            .map(|o| CObj::new(o, &desc.datasets, desc.settings.optimise))
            .collect();
        let plan = Plan {
            shadows: !desc.lights.is_empty()
                && objects.iter().any(|o| o.cast_shadows)
                && objects.iter().any(|o| o.receive_shadows),
            reflections: objects
                .iter()
                .any(|o| o.receive_reflections && o.recursion > 0),
            refraction: objects.iter().any(|o| o.refract && o.recursion > 0),
        };
        let lights: Vec<(Light, DVec3)> = desc
            .lights
            .iter()
            .map(|&light| {
                let (Light::Point { radiance, .. } | Light::Directional { radiance, .. }) = light;
                (light, crate::scene::v3(radiance))
            })
            .collect();
        let directional = lights
            .iter()
            .map(|&(light, radiance)| match light {
                Light::Directional { to_light, .. } => Some((to_light, radiance)),
                Light::Point { .. } => None,
            })
            .collect();
        let mut scene = Compiled {
            objects,
            lights,
            directional,
            lanes: Vec::new(),
            ambient: crate::scene::v3(desc.settings.ambient),
            settings: desc.settings.clone(),
            plan,
        };
        scene.lanes = scene
            .objects
            .iter()
            .map(|o| scene.headlit_lanes(o))
            .collect();
        scene
    }

    /// [`Compiled::lanes`] of `obj`: as the batched march made them for every ray (the view,
    /// which they do not hold, apart).
    fn headlit_lanes(&self, obj: &CObj) -> Option<HeadlitLanes> {
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

    /// The render plan: which effects this scene calls for.
    pub fn plan(&self) -> Plan {
        self.plan
    }

    /// All fields of the scene at world point `w`: those of the root object containing it with
    /// the largest opacity (the first on ties), or all 0 (see [`crate::voxel`]).
    pub fn fields_at(&self, w: DVec3) -> [f32; crate::types::FIELD_COUNT] {
        let mut best: Option<[f32; crate::types::FIELD_COUNT]> = None;
        for obj in &self.objects {
            let p = obj.to_object.transform_point3(w);
            if !obj.inside(p) {
                continue;
            }
            let mut s = Sample::with_env(p.as_vec3().to_array(), w.to_array(), &obj.env);
            run(&obj.program, &mut s);
            let f = s.values();
            if best.is_none_or(|b| f[0] > b[0]) {
                best = Some(f);
            }
        }
        best.unwrap_or([0.0; crate::types::FIELD_COUNT])
    }

    /// Shades one DVR sample: returns (α, colour) or `None` where the opacity is 0.
    fn shade(
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
        let alpha = 1.0 - obj.segment_transmittance(o, len);
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
    fn finish_lean(
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
        let alpha = 1.0 - obj.segment_transmittance(o, len);
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
    fn illuminate_with(
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
    fn illuminate_colour(
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
    fn transmittance(&self, w: DVec3, l: DVec3, dist: f64) -> f64 {
        let mut t_total = 1.0f64;
        for obj in self.objects.iter().filter(|o| o.cast_shadows) {
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

    /// The iso-surface hits of a DSR object along its ray interval, in depth order: for each
    /// surface, crossings of its threshold between consecutive samples (the field is 0 outside
    /// the boundary, so an object's faces count too), each refined by bisection to 10⁻⁶ of the
    /// step; returns (t, α, colour) per hit, α the surface's opacity there.
    fn surface_hits(
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
                    let (mut a, mut b, mut va) = (prev_t, t, prev_v);
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
                        }
                    }
                    let hit = 0.5 * (a + b);
                    let w = origin + hit * dir;
                    // Shade with the fields just inside the surface (on the side above the
                    // threshold), so a surface on the box face sees the object's fields.
                    let side = if va >= 0.0 { a } else { b };
                    let (lo, hi) = (c.t0 + tol * 0.5, c.t1 - tol * 0.5);
                    let side = if lo < hi {
                        side.clamp(lo, hi)
                    } else {
                        0.5 * (c.t0 + c.t1)
                    };
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
                            });
                        }
                    } else if o > 0.0 || bends {
                        let mut bend = None;
                        let secondary = (self.plan.reflections && obj.receive_reflections || bends)
                            && ray.depth < obj.recursion;
                        // Secondary rays leave along the normal the shading uses (the
                        // gradient's, then the object's normal functions): computed once.
                        let normal = secondary.then(|| obj.normal(w, -dir, &mut s, field));
                        let f = s.values();
                        let mut col = self.illuminate_with(obj, w, dir, &f, || {
                            normal.unwrap_or_else(|| obj.normal(w, -dir, &mut s, field))
                        });
                        if let Some(Some(n)) = normal {
                            let eps = obj.step * 1e-3;
                            if self.plan.reflections && obj.receive_reflections {
                                let ks = s.value(6) as f64;
                                if ks > 0.0 {
                                    let r = reflect(dir, if n.dot(dir) > 0.0 { -n } else { n });
                                    let mirror = Ray {
                                        depth: ray.depth + 1,
                                        mirror: true,
                                        background: obj.reflect_background,
                                    };
                                    col += ks
                                        * self.trace_ray(
                                            w + eps * r,
                                            None,
                                            r,
                                            mirror,
                                            f64::NEG_INFINITY,
                                        );
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
                        });
                    }
                }
                if k >= c.n {
                    break;
                }
                prev_t = t;
                prev_v = v;
                k += 1;
            }
        }
        hits.sort_by(|a, b| a.t.total_cmp(&b.t));
        hits
    }

    /// The maximum-intensity layer of a MIP object: the sample of greatest opacity along the
    /// interval (the first on ties), shown as `o·(r, g, b)`; returns (t, o, colour).
    fn mip_layer(&self, obj: &CObj, c: &mut Cursor, origin: DVec3, dir: DVec3) -> Option<Layer> {
        let mut best: Option<(f64, f64)> = None;
        // Empty blocks hold no sample above 0: the walk passes over them exactly as for DVR.
        let grid = obj.skip.as_deref();
        while let Some(mid) = c.peek(grid) {
            c.k += 1;
            let o = obj.opacity_at(origin + mid * dir);
            if o > 0.0 && best.is_none_or(|(_, b)| o > b) {
                best = Some((mid, o));
                if o >= 1.0 {
                    break;
                }
            }
        }
        let (t, o) = best?;
        let mut s = obj.sample_at(origin + t * dir);
        run(&obj.program, &mut s);
        let f = s.values();
        Some(Layer {
            t: c.t1,
            alpha: o,
            colour: DVec3::new(f[1] as f64, f[2] as f64, f[3] as f64),
            bend: None,
        })
    }

    /// The [`EntryMap`] of an image: for a scene of one DVR volume with a skip grid (the
    /// only case [`Compiled::trace_ray`] uses it), when the map can be built.
    fn entry_map(&self, camera: &Pinhole) -> Option<EntryMap> {
        let [obj] = self.objects.as_slice() else {
            return None;
        };
        if !(self.settings.optimise.skip_empty
            && obj.seen_by(Ray::PRIMARY)
            && obj.render_type == RenderType::Dvr)
        {
            return None;
        }
        let grid = obj.skip.as_deref()?;
        // Where the batched march consults a cell mask, the boxes of the cells that can pass
        // its zero test bound where rays meet opacity more tightly than the shell's blocks.
        let passing = match (&obj.cells, obj.lean.as_ref().and_then(Lean::value_head)) {
            (Some(mask), Some((data, _))) => {
                grid.passing_boxes(data, mask, obj.box_min, obj.box_max)
            }
            _ => None,
        };
        // (Too many of them for the image: the shell's blocks, which may be fewer.)
        passing
            .and_then(|boxes| EntryMap::of_boxes(&boxes, obj.to_world, camera))
            .or_else(|| EntryMap::build(grid, obj.to_world, camera))
    }

    /// The colour [`Compiled::trace`] gives every primary ray whose bound is +∞, whatever its
    /// origin and direction, where [`Compiled::trace_ray`]'s one-volume path answers it
    /// without looking at the ray (`None` where it does look): the per-pixel loop then
    /// neither makes the ray nor calls the trace for such a pixel.
    fn unbounded_colour(&self) -> Option<DVec3> {
        let ray = Ray::PRIMARY;
        let background = if ray.background {
            crate::scene::v3(self.settings.background)
        } else {
            DVec3::ZERO
        };
        let [obj] = self.objects.as_slice() else {
            return None;
        };
        if !(obj.seen_by(ray) && obj.render_type == RenderType::Dvr) {
            return None;
        }
        // `trace_ray`'s test, the same numbers.
        let bits = |v: DVec3| v.to_array().map(f64::to_bits);
        let shown = DVec3::ZERO + 1.0 * background;
        (bits(shown) == bits(background)).then_some(shown)
    }

    /// Traces one primary ray whose pixel has the [`EntryMap`] bound `bound` (−∞ without a
    /// map); returns the pixel colour.
    ///
    /// `image`: [`Compiled::image_rays`] of `origin` (the same for every ray of an image).
    fn trace(&self, origin: DVec3, image: &ImageRays, dir: DVec3, bound: f64) -> DVec3 {
        self.trace_ray(origin, Some(image), dir, Ray::PRIMARY, bound)
    }

    /// What [`Compiled::trace_ray`] makes of the scene and the ray origin `origin` on every
    /// primary ray from it, made once per image.
    fn image_rays(&self, origin: DVec3) -> ImageRays {
        ImageRays {
            origin_o: match self.objects.as_slice() {
                [obj] => obj.object_ray(origin, DVec3::ZERO).0,
                _ => DVec3::ZERO,
            },
            background: crate::scene::v3(self.settings.background),
        }
    }

    /// Traces a ray. DVR objects contribute their samples, DSR objects their surface hits and
    /// MIP objects their maximum-intensity layer, all composited front to back in depth order.
    /// At a refracting surface the rest of the ray continues along the refracted direction.
    ///
    /// `bound`: no block of the scene's one object that may hold opacity meets the ray before
    /// this parameter (its [`EntryMap`] bound; −∞ when nothing is known): the walk starts
    /// there, and a ray whose bound is +∞ shows the background. Only a primary ray of a scene
    /// of one DVR volume is given a bound.
    ///
    /// `image`: what is made of `origin` and the scene once per image where known
    /// ([`Compiled::image_rays`]; `None`: made here).
    fn trace_ray(
        &self,
        origin: DVec3,
        image: Option<&ImageRays>,
        dir: DVec3,
        ray: Ray,
        bound: f64,
    ) -> DVec3 {
        let background = if ray.background {
            match image {
                Some(i) => i.background,
                None => crate::scene::v3(self.settings.background),
            }
        } else {
            DVec3::ZERO
        };
        if let [obj] = self.objects.as_slice() {
            // A scene of one volume (the usual scanned-data case): what the general path below
            // does for it, without building its lists.
            if obj.seen_by(ray) && obj.render_type == RenderType::Dvr {
                // What the march gives when it takes no sample.
                let unsampled = || DVec3::ZERO + 1.0 * background;
                if bound == f64::INFINITY {
                    // Without the clip: a ray that misses the box shows `background`, one that
                    // meets it takes no sample (its bound is past t1, which is finite) and shows
                    // `unsampled`. The two differ only in a component that is −0 (0 + −0 is
                    // +0); where none is, either is the answer.
                    let bits = |v: DVec3| v.to_array().map(f64::to_bits);
                    let shown = unsampled();
                    if bits(shown) == bits(background) {
                        return shown;
                    }
                }
                let (o, d) = match image {
                    Some(i) => (i.origin_o, obj.to_object.transform_vector3(dir)),
                    None => obj.object_ray(origin, dir),
                };
                let Some((t0, t1)) = obj.clip(o, d) else {
                    return background;
                };
                if bound >= t1 {
                    return unsampled();
                }
                // In place (see `Cursor::unstarted`).
                let mut c = Cursor::unstarted(obj, 0, (o, d), (t0, t1));
                c.start(self, obj, bound);
                let (col, t) = self.march_one(&mut c, origin, dir);
                return col + t * background;
            }
        }
        let mut cursors: Vec<Cursor> = Vec::new();
        let mut layers: Vec<Layer> = Vec::new();
        for (i, obj) in self.objects.iter().enumerate() {
            if !obj.seen_by(ray) {
                continue;
            }
            let (o, d) = obj.object_ray(origin, dir);
            if let Some((t0, t1)) = obj.clip(o, d) {
                let mut c = Cursor::new(self, obj, i, (o, d), (t0, t1), f64::NEG_INFINITY);
                match obj.render_type {
                    RenderType::Dvr => cursors.push(c),
                    RenderType::Dsr => {
                        layers.extend(self.surface_hits(obj, &c, origin, dir, ray, true))
                    }
                    RenderType::Mip => layers.extend(self.mip_layer(obj, &mut c, origin, dir)),
                }
            }
        }
        if layers.is_empty() && cursors.len() == 1 {
            // One volume along the ray and nothing else: its own tight loop.
            let mut c = cursors.pop().expect("one cursor");
            let (col, t) = self.march_one(&mut c, origin, dir);
            return col + t * background;
        }
        layers.sort_by(|a, b| a.t.total_cmp(&b.t));
        let mut layers = layers.into_iter().peekable();
        let stop = self.settings.optimise.stop_below();
        let mut col = DVec3::ZERO;
        let mut t = 1.0f64;
        let composite = |alpha: f64, colour: DVec3, col: &mut DVec3, t: &mut f64| {
            *col += *t * alpha * colour;
            *t *= 1.0 - alpha;
            *t < stop
        };
        'march: loop {
            // The next segment in depth order (ties: object order).
            let mut best: Option<(usize, f64)> = None;
            for (ci, c) in cursors.iter_mut().enumerate() {
                let grid = self.objects[c.object].skip.as_deref();
                if let Some(mid) = c.peek(grid) {
                    if best.is_none_or(|(_, m)| mid < m) {
                        best = Some((ci, mid));
                    }
                }
            }
            // Layers in front of that sample come first.
            while let Some(&layer) = layers.peek() {
                if best.is_some_and(|(_, m)| layer.t > m) {
                    break;
                }
                layers.next();
                if composite(layer.alpha, layer.colour, &mut col, &mut t) {
                    t = 0.0;
                    break 'march;
                }
                if let Some((from, to)) = layer.bend {
                    // Everything behind a refracting surface is seen along the bent ray.
                    let behind = self.trace_ray(
                        from,
                        None,
                        to,
                        Ray {
                            depth: ray.depth + 1,
                            ..ray
                        },
                        f64::NEG_INFINITY,
                    );
                    return col + t * behind;
                }
            }
            let Some((ci, mid)) = best else { break };
            let c = &mut cursors[ci];
            let len = c.take();
            if len <= 0.0 {
                continue;
            }
            let obj = &self.objects[c.object];
            if let Some((alpha, colour)) =
                self.shade(obj, origin + mid * dir, c.object_point(mid), dir, len)
            {
                if composite(alpha, colour, &mut col, &mut t) {
                    t = 0.0;
                    break;
                }
            }
        }
        col + t * background
    }

    /// The front-to-back composite of one DVR object's samples along a ray (the general loop of
    /// [`Compiled::trace_ray`] with a single cursor and no layers, in the same order and
    /// arithmetic); returns the colour and the remaining transmittance.
    fn march_one(&self, c: &mut Cursor, origin: DVec3, dir: DVec3) -> (DVec3, f64) {
        let obj = &self.objects[c.object];
        if let Some(lean) = &obj.lean {
            if let Some((data, z)) = lean.value_head() {
                if obj.normals.is_empty() {
                    return self.march_batched::<true>(obj, lean, data, z, c, origin, dir);
                }
            }
        }
        let grid = obj.skip.as_deref();
        let stop = self.settings.optimise.stop_below();
        let mut col = DVec3::ZERO;
        let mut t = 1.0f64;
        while let Some(mid) = c.peek(grid) {
            let len = c.take();
            if len <= 0.0 {
                continue;
            }
            if let Some((alpha, colour)) =
                self.shade(obj, origin + mid * dir, c.object_point(mid), dir, len)
            {
                col += t * alpha * colour;
                t *= 1.0 - alpha;
                if t < stop {
                    t = 0.0;
                    break;
                }
            }
        }
        (col, t)
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
    fn march_batched<const IN_LANES: bool>(
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
        let stop = self.settings.optimise.stop_below();
        let cells = obj.cells.as_deref();
        let mut col = DVec3::ZERO;
        let mut t = 1.0f64;
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
            Some((d, Filter::Trilinear)) if std::ptr::eq(Arc::as_ptr(d), data)
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
                let (mut count, mut ends) = (0, false);
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
                            let alpha =
                                1.0 - obj.segment_transmittance_at_most_one(o as f64, lens[i]);
                            for (a, x) in rgb32.iter_mut().zip(rgb) {
                                a[count] = x;
                            }
                            at[count] = i as u8;
                            weights[count] = t * alpha;
                            count += 1;
                            t *= 1.0 - alpha;
                            t < stop
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
                                ends = true;
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
                            ends = true;
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
                        let alpha = 1.0 - obj.segment_transmittance_at_most_one(o as f64, lens[i]);
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
                        weights[count] = t * alpha;
                        count += 1;
                        t *= 1.0 - alpha;
                        if t < stop {
                            ends = true;
                            break;
                        }
                    }
                }
                for (j, &w) in weights[..count].iter().enumerate() {
                    col += w * DVec3::new(colours[0][j], colours[1][j], colours[2][j]);
                }
                if ends {
                    return (col, 0.0);
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
                col += t * alpha * colour;
                t *= 1.0 - alpha;
                if t < stop {
                    return (col, 0.0);
                }
            }
        }
        (col, t)
    }
}

/// The number of segments of `x` steps (the span over the step): ⌈x⌉, at least 1, saturating
/// at `u64::MAX` (NaN: 1). For 0 < x < 2⁵², the usual case, by truncation: ⌈x⌉ is the
/// truncation where that is x and one more where it is below, both exact there; elsewhere by
/// the rounding function (`segment_count_is_the_rounded_up_span` checks the two agree).
#[inline]
fn segment_count(x: f64) -> u64 {
    if x > 0.0 && x < 4_503_599_627_370_496.0 {
        let t = x as i64;
        return (t + ((t as f64) < x) as i64) as u64;
    }
    let n = crate::num::ceil(x).max(1.0);
    if n.is_finite() && n < u64::MAX as f64 {
        n as u64
    } else {
        u64::MAX
    }
}

/// Segment number `k` of a cursor of `n` segments (k ≤ n) as f64, the same value as
/// `k as f64`: where n < 2⁶³ (every count a cursor meets in practice) by the signed
/// conversion, one `cvtsi2sd`, where `k as f64` is six instructions on the SSE2 baseline
/// (which has no unsigned conversion); the same integer, rounded the same way. The test is on
/// n, not k: the compiler turns a signed conversion under `k ≤ i64::MAX` back into the
/// unsigned one. Taken for every midpoint a cursor looks at
/// (`index_f64_is_the_unsigned_conversion`).
#[inline(always)]
fn index_f64(k: u64, n: u64) -> f64 {
    debug_assert!(k <= n);
    if n <= i64::MAX as u64 {
        k as i64 as f64
    } else {
        k as f64
    }
}

/// One object's segments along a ray: segment k spans [t0 + k·step, t0 + (k + 1)·step], the last
/// one ending at t1; its sample is at its midpoint.
struct Cursor {
    object: usize,
    t0: f64,
    t1: f64,
    step: f64,
    k: u64,
    n: u64,
    walk: Option<Walk>,
    /// The ray in the object's coordinates: the object point of ray parameter t is
    /// `o + t·d`.
    o: DVec3,
    d: DVec3,
    /// Samples before this ray parameter lie in the occupied block the walk last reported:
    /// they are taken without consulting the walk.
    occupied_until: f64,
}

impl Cursor {
    /// The segments of object `obj` (number `index`) over [t0, t1] of a ray, given in the
    /// object's coordinates ([`CObj::object_ray`]), with a block walk when empty-space skipping
    /// is on. `from` (< t1): every sample before it lies in an empty block (an [`EntryMap`]
    /// bound, or −∞): with a walk, those are passed over at once and the walk starts there.
    fn new(
        scene: &Compiled,
        obj: &CObj,
        index: usize,
        ray: (DVec3, DVec3),
        span: (f64, f64),
        from: f64,
    ) -> Cursor {
        let mut c = Cursor::unstarted(obj, index, ray, span);
        c.start(scene, obj, from);
        c
    }

    /// [`Cursor::new`] before its walk is started ([`Cursor::start`]). Apart, so that a caller
    /// that starts it in place builds the cursor where it keeps it: a cursor whose address was
    /// taken (by the walk's start) before it was returned was built on the callee's stack and
    /// copied (a `memcpy` of the whole cursor a ray).
    #[inline]
    fn unstarted(obj: &CObj, index: usize, (o, d): (DVec3, DVec3), (t0, t1): (f64, f64)) -> Cursor {
        let n = segment_count((t1 - t0) / obj.step);
        Cursor {
            object: index,
            t0,
            t1,
            step: obj.step,
            k: 0,
            n,
            walk: None,
            o,
            d,
            occupied_until: f64::NEG_INFINITY,
        }
    }

    /// Starts an [`Cursor::unstarted`] cursor's walk when empty-space skipping is on, at `from`
    /// as [`Cursor::new`] takes it.
    #[inline]
    fn start(&mut self, scene: &Compiled, obj: &CObj, from: f64) {
        if let (Some(grid), true) = (&obj.skip, scene.settings.optimise.skip_empty) {
            self.start_walk(grid, from.max(self.t0));
        }
    }

    /// Starts the block walk through `grid` at `start` (the cursor's first segment's start, or
    /// later: an [`EntryMap`] bound) and passes over the segments whose midpoints are before
    /// it. The walk is built in the cursor's field (see [`SkipGrid::walk_into`]).
    #[inline(never)]
    fn start_walk(&mut self, grid: &SkipGrid, start: f64) {
        grid.walk_into(&mut self.walk, self.o, self.d, start);
        self.start_at(start);
    }

    /// Passes over the segments whose midpoints are before `t` (none if the next one's is
    /// not; there is a next one).
    fn start_at(&mut self, t: f64) {
        if self.mid(self.k) < t {
            self.pass_before(t);
        }
    }

    /// Passes over the next segment, whose midpoint is before `t`, and every later one whose
    /// midpoint is before `t`.
    #[inline]
    fn pass_before(&mut self, t: f64) {
        // Where the first midpoint not before t should be: ⌈g⌉ for g not an integer, g + 1 for
        // one (the truncation, plus 1: no rounding call, and a saturating conversion of a
        // value known to be in range). Any start above `k` settles on the same segment below
        // (midpoints do not decrease), at most one step further here than from ⌈g⌉.
        let g = (t - self.t0) / self.step - 0.5;
        let mut k = if g > index_f64(self.k, self.n) {
            if g < 9.0e18 {
                (g as i64 as u64 + 1).min(self.n)
            } else {
                self.n
            }
        } else {
            self.k + 1
        };
        while k > self.k + 1 && self.mid(k - 1) >= t {
            k -= 1;
        }
        while k < self.n && self.mid(k) < t {
            k += 1;
        }
        self.k = k;
    }

    /// The object point of ray parameter `t`.
    #[inline]
    fn object_point(&self, t: f64) -> [f32; 3] {
        ray_point(self.o, self.d, t)
    }

    /// Segment boundary number `k` (a count, exact in f64 below 2⁵³): `t0 + k·step`.
    #[inline]
    fn boundary(&self, k: f64) -> f64 {
        self.t0 + k * self.step
    }

    /// The end of a segment whose next boundary is `next`: t1 for the last segment, else the
    /// boundary (never past t1).
    #[inline]
    fn end(&self, next: f64, last: bool) -> f64 {
        if last {
            self.t1
        } else {
            at_most(next, self.t1)
        }
    }

    #[inline]
    fn segment(&self, k: u64) -> (f64, f64) {
        let a = self.boundary(index_f64(k, self.n));
        (
            a,
            self.end(self.boundary(index_f64(k + 1, self.n)), k + 1 >= self.n),
        )
    }

    /// The length of the next segment, which is then passed.
    #[inline]
    fn take(&mut self) -> f64 {
        let (a, b) = self.segment(self.k);
        self.k += 1;
        b - a
    }

    #[inline]
    fn mid(&self, k: u64) -> f64 {
        let (a, b) = self.segment(k);
        0.5 * (a + b)
    }

    /// The next segments (there is one: `k < n`), up to eight: writes their midpoints and
    /// lengths into `mids` and `lens` and returns their number (the entries past the number
    /// are meaningless, possibly left from an earlier run). Each segment's end is the next
    /// one's start: one boundary per sample, the same numbers as [`Cursor::segment`]. In lanes
    /// across the segments while their boundary numbers are exact in f64 (below 2⁵³), so that
    /// k + j + 1 is one rounding-free addition.
    #[inline]
    fn segments(&self, mids: &mut [f64; 8], lens: &mut [f64; 8]) -> usize {
        let left = (self.n - self.k).min(8) as usize; // k < n
        let last = self.k + left as u64 == self.n; // the run may reach the last segment
        let k = index_f64(self.k, self.n);
        if k < (1u64 << 53) as f64 - 16.0 {
            let next: [f64; 8] = std::array::from_fn(|j| self.boundary(k + (j + 1) as f64));
            let a: [f64; 8] = std::array::from_fn(|j| {
                if j == 0 {
                    self.boundary(k)
                } else {
                    next[j - 1]
                }
            });
            // `Cursor::end` lane by lane (calling it per lane costs 0.3 % of the frame).
            let b = next.map(|x| at_most(x, self.t1));
            *mids = std::array::from_fn(|j| 0.5 * (a[j] + b[j]));
            *lens = std::array::from_fn(|j| b[j] - a[j]);
            if last {
                // The last segment ends at t1: its sample made again from its start, a[i]
                // (k + i is k + (i − 1 + 1), and k + 0 is k), so that `b` stays in registers
                // (its lane set in memory cost four stores a run).
                let i = left - 1;
                let a = self.boundary(k + i as f64);
                mids[i] = 0.5 * (a + self.t1);
                lens[i] = self.t1 - a;
            }
        } else {
            let mut a = self.boundary(k);
            let mut kf = k;
            for j in 0..left {
                kf += 1.0;
                let next = self.boundary(kf);
                let b = self.end(next, last && j + 1 == left);
                mids[j] = 0.5 * (a + b);
                lens[j] = b - a;
                a = next;
            }
        }
        left
    }

    /// The batched march's next run: the next sample to take ([`Cursor::peek`]) and those after
    /// it, up to eight, that lie in occupied blocks. It used to end where the walk's block did,
    /// the next peek asking the walk about the sample past it; it now asks the walk there itself
    /// and carries on while the answer is an occupied block. Writes the run's midpoints and
    /// lengths as [`Cursor::segments`] does, passes its segments and returns their number (0: no
    /// sample left). The same samples as the peek-then-run loop (`joined_runs_are_peek_and_run`);
    /// fewer questions to the walk: asked about a sample in an occupied block, the walk also
    /// steps through the occupied blocks after it that the run's last sample reaches
    /// ([`Walk::skip_until`]'s horizon), so a run inside occupied blocks asks once.
    #[inline(never)]
    fn next_run(
        &mut self,
        grid: Option<&SkipGrid>,
        mids: &mut [f64; 8],
        lens: &mut [f64; 8],
    ) -> usize {
        if self.k >= self.n {
            return 0;
        }
        let left = self.segments(mids, lens);
        let (Some(walk), Some(grid)) = (self.walk.as_mut(), grid) else {
            self.k += left as u64;
            return left;
        };
        // Samples before j are taken; sample j is taken if it lies before `until` or the
        // walk finds it in an occupied block.
        let (mut j, mut until) = (0, self.occupied_until);
        let exit = loop {
            while j < left && mids[j] < until {
                j += 1;
            }
            if j == left {
                break None;
            }
            match walk.skip_until(grid, mids[j], mids[left - 1]) {
                Err(u) => {
                    until = u;
                    j += 1;
                    // The midpoints do not decrease and none is NaN (the cursor's ends are
                    // finite, its step finite and positive): when the run's last lies before
                    // the block's end, every one from j on does (one comparison, where the
                    // loop above takes five a sample).
                    if mids[left - 1] < until {
                        j = left;
                        break None;
                    }
                }
                Ok(exit) => break Some(exit),
            }
        };
        self.occupied_until = until;
        self.k += j as u64;
        let Some(exit) = exit else {
            return j;
        };
        // Sample j lies in an empty block: pass it and those after it up to the exit.
        self.pass_before(exit);
        if j > 0 {
            return j;
        }
        // The run starts after the empty blocks (apart: as a loop here, the compiler kept
        // the run's constants in registers across every call).
        self.next_run_after_gap(Some(grid), mids, lens)
    }

    /// [`Cursor::next_run`] again, where its first sample lay in an empty block.
    #[cold]
    #[inline(never)]
    fn next_run_after_gap(
        &mut self,
        grid: Option<&SkipGrid>,
        mids: &mut [f64; 8],
        lens: &mut [f64; 8],
    ) -> usize {
        self.next_run(grid, mids, lens)
    }

    /// The midpoint of the next segment that must be sampled, passing over segments whose
    /// samples lie in empty blocks.
    fn peek(&mut self, grid: Option<&SkipGrid>) -> Option<f64> {
        loop {
            if self.k >= self.n {
                return None;
            }
            let mid = self.mid(self.k);
            if mid < self.occupied_until {
                return Some(mid);
            }
            let (Some(walk), Some(grid)) = (self.walk.as_mut(), grid) else {
                return Some(mid);
            };
            let exit = match walk.skip_until(grid, mid, mid) {
                Err(until) => {
                    self.occupied_until = until;
                    return Some(mid);
                }
                Ok(exit) => exit,
            };
            self.pass_before(exit);
        }
    }
}

/// `x.min(t1)` for a `t1` that is not NaN (a cursor's end: [`CObj::clip`] gives finite
/// ends), as one comparison: t1 where x is NaN or not below it (`f64::min`'s NaN handling
/// costs a vector select per pair of lanes).
#[inline(always)]
fn at_most(x: f64, t1: f64) -> f64 {
    if x < t1 {
        x
    } else {
        t1
    }
}

/// Bit i set where sample i of a run has a length and passes the zero test:
/// `!(lens[i] <= 0 || vs[i] <= z)` (a NaN fails neither comparison), in lanes.
#[inline]
fn pass_bits(lens: &[f64; 8], vs: &[f32; 8], z: f32) -> u32 {
    use wide::{f32x4, f64x2};
    // By pairs and quadruples, each comparison's bits taken by one `movmskpd`/`movmskps`
    // (the compiler packed wider lanes' masks into bytes first: a dozen more instructions).
    let short = |j: usize| {
        f64x2::new([lens[j], lens[j + 1]])
            .simd_le(f64x2::ZERO)
            .to_bitmask()
            << j
    };
    let low = |j: usize| {
        f32x4::new([vs[j], vs[j + 1], vs[j + 2], vs[j + 3]])
            .simd_le(f32x4::splat(z))
            .to_bitmask()
            << j
    };
    let fail = short(0) | short(2) | short(4) | short(6) | low(0) | low(4);
    !fail & 0xff
}

/// The object point (f32, as samples see it) of parameter `t` on the object-space ray
/// `o + t·d`.
#[inline]
fn ray_point(o: DVec3, d: DVec3, t: f64) -> [f32; 3] {
    (o + t * d).as_vec3().to_array()
}

/// The primary-ray generator of a `width × height` image whose view plane has the given
/// width / height `aspect`, for the scene's camera.
fn view(settings: &Settings, width: u32, height: u32, aspect: f32) -> Pinhole {
    let cam = &settings.camera;
    let (r, u, f) = cam.basis();
    let half = (cam.fov as f64 * 0.5).to_radians().tan();
    let aspect = aspect as f64;
    let (hw, hh) = if aspect >= 1.0 {
        (half * aspect, half)
    } else {
        (half, half / aspect)
    };
    Pinhole {
        eye: crate::scene::v3(cam.eye),
        right: r * hw,
        up: u * hh,
        forward: f,
        width,
        height,
    }
}

fn tiles(width: u32, height: u32, side: u32) -> Vec<(u32, u32)> {
    let mut v = Vec::new();
    for ty in (0..height).step_by(side as usize) {
        for tx in (0..width).step_by(side as usize) {
            v.push((tx, ty));
        }
    }
    v
}

/// Evaluates `f` for every pixel, in parallel over tiles, deterministically.
fn per_pixel<F>(width: u32, height: u32, f: F) -> Vec<[f32; 3]>
where
    F: Fn(u32, u32) -> [f32; 3] + Sync,
{
    per_tile(width, height, TILE, |(tx, ty, tw, th)| {
        let mut out = Vec::with_capacity((tw * th) as usize);
        for y in ty..ty + th {
            for x in tx..tx + tw {
                out.push(f(x, y));
            }
        }
        out
    })
}

/// Evaluates `f` for every tile (x, y, width, height) of `side × side` pixels (fewer at the
/// right and bottom edges), which gives its pixels row by row, in parallel over tiles,
/// deterministically.
fn per_tile<F>(width: u32, height: u32, side: u32, f: F) -> Vec<[f32; 3]>
where
    F: Fn((u32, u32, u32, u32)) -> Vec<[f32; 3]> + Sync,
{
    type Tile = ((u32, u32), Vec<[f32; 3]>);
    let results: Vec<Tile> = tiles(width, height, side)
        .into_par_iter()
        .map(|(tx, ty)| {
            let (tw, th) = ((tx + side).min(width) - tx, (ty + side).min(height) - ty);
            ((tx, ty), f((tx, ty, tw, th)))
        })
        .collect();
    // The tiles come in row-major order: each band of `side` rows is a row of tiles, copied
    // into place in parallel, a tile row at a time.
    let per_row = width.div_ceil(side) as usize;
    let mut pixels = vec![[0.0f32; 3]; (width * height) as usize];
    pixels
        .par_chunks_mut((width * side) as usize)
        .zip(results.par_chunks(per_row))
        .for_each(|(band, row)| {
            for ((tx, _), out) in row {
                let tw = ((tx + side).min(width) - tx) as usize;
                for (y, src) in out.chunks(tw).enumerate() {
                    let at = y * width as usize + *tx as usize;
                    band[at..at + tw].copy_from_slice(src);
                }
            }
        });
    pixels
}

fn to_f32(c: DVec3) -> [f32; 3] {
    let f = |v: f64| {
        if v.is_finite() {
            v.clamp(0.0, 1.0) as f32
        } else {
            0.0
        }
    };
    [f(c.x), f(c.y), f(c.z)]
}

/// What [`Compiled::trace_ray`] makes of the scene and the origin of an image's primary rays
/// (the eye) on each of them ([`Compiled::image_rays`]), made once per image: the same numbers.
struct ImageRays {
    /// The origin in the coordinates of the scene's object where it has one only
    /// ([`CObj::object_ray`]; zero, not read, otherwise).
    origin_o: DVec3,
    /// The background colour.
    background: DVec3,
}

/// Renders the compiled scene to an image of `width × height` pixels whose view plane has the
/// given width / height `aspect`. Adaptive super-sampling: one ray through each pixel centre,
/// then pixels that differ from a neighbour by more than [`SUPER_SAMPLE_CONTRAST`] are replaced
/// by the mean of an n×n grid of rays.
pub fn render_image(scene: &Compiled, width: u32, height: u32, aspect: f32) -> Result<Image> {
    let run = || {
        let view = view(&scene.settings, width, height, aspect);
        let entry = scene.entry_map(&view);
        let from = |x: u32, y: u32| entry.as_ref().map_or(f64::NEG_INFINITY, |m| m.bound(x, y));
        // What a pixel whose bound is +∞ shows, where that is known without its ray.
        let unbounded = scene.unbounded_colour().map(to_f32);
        let image = scene.image_rays(view.eye);
        // Rays in packets of SIMD lanes, where that applies (one ray per pixel).
        #[cfg(target_arch = "x86_64")]
        if let Some(p) = simd::Packets::new(scene) {
            return per_tile(width, height, packet_tile(width, height), |tile| {
                p.tile(&view, entry.as_ref(), &image, unbounded, tile)
            });
        }
        let first = per_pixel(width, height, |x, y| {
            let bound = from(x, y);
            if let (Some(c), true) = (unbounded, bound == f64::INFINITY) {
                return c;
            }
            let dir = view.ray(x as f64 + 0.5, y as f64 + 0.5);
            to_f32(scene.trace(view.eye, &image, dir, bound))
        });
        let n = scene.settings.super_sample.max(1) as u32;
        if n == 1 {
            return first;
        }
        let differs = |x: u32, y: u32| {
            let p = first[(y * width + x) as usize];
            let neighbours = [
                (x.wrapping_sub(1), y),
                (x + 1, y),
                (x, y.wrapping_sub(1)),
                (x, y + 1),
            ];
            neighbours.iter().any(|&(nx, ny)| {
                nx < width && ny < height && {
                    let q = first[(ny * width + nx) as usize];
                    (0..3).any(|c| (p[c] - q[c]).abs() > SUPER_SAMPLE_CONTRAST)
                }
            })
        };
        per_pixel(width, height, |x, y| {
            if !differs(x, y) {
                return first[(y * width + x) as usize];
            }
            let mut sum = DVec3::ZERO;
            for j in 0..n {
                for i in 0..n {
                    let sx = x as f64 + (i as f64 + 0.5) / n as f64;
                    let sy = y as f64 + (j as f64 + 0.5) / n as f64;
                    let c = scene.trace(view.eye, &image, view.ray(sx, sy), from(x, y));
                    sum += crate::scene::v3(to_f32(c));
                }
            }
            to_f32(sum / (n * n) as f64)
        })
    };
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(run)) {
        Ok(pixels) => Ok(Image {
            width,
            height,
            pixels,
        }),
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(Error::new(
                ErrorCode::Internal,
                format!("rendering stopped by a panic (in a field function?): {msg}"),
            ))
        }
    }
}

/// Renders every image and voxelization a scene requested and writes the files. All images are attempted; the
/// first failure is returned (its message counts the others).
pub fn render_outputs(desc: &SceneDesc) -> Result<()> {
    if desc.images.is_empty() && desc.volumes.is_empty() {
        return Ok(());
    }
    let compiled = Compiled::new(desc);
    let mut errors: Vec<Error> = Vec::new();
    for req in &desc.images {
        let result = render_image(&compiled, req.width, req.height, req.aspect).and_then(|img| {
            crate::output::write_image(&req.path, img.width, img.height, &img.to_rgb8())
        });
        if let Err(e) = result {
            errors.push(e);
        }
    }
    for req in &desc.volumes {
        if let Err(e) = crate::voxel::write(&compiled, req) {
            errors.push(e);
        }
    }
    match errors.len() {
        0 => Ok(()),
        1 => Err(errors.remove(0)),
        n => {
            let mut e = errors.remove(0);
            e.message = format!("{} (and {} more output(s) failed)", e.message, n - 1);
            Err(e)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::Xorshift;

    /// The packet march's tiles are 32×32 where the image has at least 16 of them a thread,
    /// else 16×16; and `tiles` with either side covers the image once, row-major.
    #[test]
    fn packet_tiles_are_large_only_where_there_are_many() {
        let threads = rayon::current_num_threads();
        assert_eq!(packet_tile(64, 48), TILE, "4 tiles of 32");
        // Exactly 16 a thread: a row of 16·threads tiles of 32, the last one partial.
        let w = 32 * 16 * threads as u32 - 5;
        assert_eq!(packet_tile(w, 32), PACKET_TILE);
        assert_eq!(packet_tile(w - 32, 32), TILE);
        for side in [TILE, PACKET_TILE] {
            let (w, h) = (101u32, 67u32);
            let t = tiles(w, h, side);
            assert_eq!(t.len(), (w.div_ceil(side) * h.div_ceil(side)) as usize);
            let mut covered = vec![0u8; (w * h) as usize];
            for &(tx, ty) in &t {
                for y in ty..(ty + side).min(h) {
                    for x in tx..(tx + side).min(w) {
                        covered[(y * w + x) as usize] += 1;
                    }
                }
            }
            assert!(covered.iter().all(|&c| c == 1), "side {side}");
            assert!(t.windows(2).all(|p| (p[0].1, p[0].0) < (p[1].1, p[1].0)));
        }
    }

    /// `try_normalize` is glam's `DVec3::try_normalize`, bit for bit and in when it declines:
    /// zero, tiny (a square that underflows), huge (one that overflows), infinite and NaN
    /// components, and ordinary vectors of every sign.
    #[test]
    fn try_normalize_is_glams() {
        let special = [
            0.0,
            -0.0,
            1e-320,
            -1e-200,
            1e-150,
            3.0,
            -0.25,
            1e150,
            -1e200,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let mut checked = 0;
        for &x in &special {
            for &y in &special {
                for &z in &special {
                    let v = DVec3::new(x, y, z);
                    let bits = |n: Option<DVec3>| n.map(|n| n.to_array().map(f64::to_bits));
                    assert_eq!(bits(try_normalize(v)), bits(v.try_normalize()), "{v:?}");
                    checked += usize::from(v.try_normalize().is_some());
                }
            }
        }
        assert!(checked > 100, "only {checked} normalisable vectors");
    }

    #[test]
    fn fast_powers_agree_with_powf() {
        for i in 0..=1000 {
            let t = i as f64 / 1000.0;
            for e in [1.0, 0.5, 0.25, 2.0, 0.125, 4.0, 0.37, 7.0] {
                assert!((transmit(t, e) - t.powf(e)).abs() < 1e-15, "{t}^{e}");
            }
            for e in [0.0, 1.0, 10.0, 20.5, 128.0] {
                let want = t.powf(e);
                assert!(
                    (Specular::new(e).pow(t) - want).abs() <= 1e-12 * want.max(1e-300) + 1e-300,
                    "{t}^{e}"
                );
            }
        }
    }

    /// The inlined binary exponentiation gives `f64::powi`'s bits (the library routine it
    /// replaces), for every exponent the specular term can take and a spread of bases; the
    /// exponent test takes exactly the integers in range and sends the rest to `powf`.
    #[test]
    fn powi_is_the_library_powi() {
        let mut x = 1e-3f64;
        while x < 1.0 {
            for k in 0..=MAX_SPECULAR as u32 {
                let (ours, lib) = (powi(x, k), x.powi(std::hint::black_box(k as i32)));
                assert_eq!(ours.to_bits(), lib.to_bits(), "{x}^{k}");
                assert_eq!(
                    Specular::new(k as f64).pow(x).to_bits(),
                    lib.to_bits(),
                    "{x}^{k}"
                );
            }
            x = x * 1.37 + 1e-4;
        }
        for e in [
            -1.0,
            0.5,
            10.25,
            MAX_SPECULAR as f64 + 1.0,
            1e30,
            f64::INFINITY,
        ] {
            assert_eq!(
                Specular::new(e).pow(0.7).to_bits(),
                0.7f64.powf(e).to_bits(),
                "0.7^{e}"
            );
        }
        assert_eq!(
            Specular::new(f64::NAN).pow(0.7).to_bits(),
            0.7f64.powf(f64::NAN).to_bits()
        );
    }

    /// A scene of one object (receiving and casting shadows if `shadows`) under `lights`,
    /// compiled.
    fn lit_scene(lights: Vec<Light>, shadows: bool) -> Compiled {
        let mut state = crate::scene::RenderState::default();
        state.toggles[Feature::CastShadows as usize] = shadows;
        state.toggles[Feature::ReceiveShadows as usize] = shadows;
        Compiled::new(&SceneDesc {
            settings: Settings {
                ambient: [0.3, 0.5, 1.0],
                ..Settings::default()
            },
            lights,
            images: Vec::new(),
            volumes: Vec::new(),
            objects: vec![ObjectDesc::new(state)],
            datasets: Default::default(),
        })
    }

    /// [`Headlit`] gives [`Compiled::illuminate_colour`]'s colour bit for bit, and asks for the
    /// normal exactly when it does: for one and several directional lights and none, normals
    /// and none (a vanishing gradient), coefficients at and above 0, integer and other
    /// exponents, colours from 0 to above 1, any view direction. It is refused for a point
    /// light and where a shadow may fall on the object.
    #[test]
    fn headlit_is_the_illumination_model() {
        let rng = Xorshift::new(0x9e37_79b9_7f4a_7c15u64);
        let (next, unit) = (|| rng.next(), || unit_dir(&|| rng.next()));
        let light = |to_light: DVec3, radiance: [f32; 3]| Light::Directional { to_light, radiance };
        let configurations = [
            vec![light(DVec3::new(0.0, -1.0, 0.0), [1.0; 3])],
            vec![
                light(unit(), [0.9, 0.2, 0.4]),
                light(unit(), [2.0, 1.0, 0.5]),
                light(unit(), [0.0, 0.1, 0.0]),
            ],
            vec![],
        ];
        let mut compared = 0;
        let mut lit = 0;
        for lights in configurations {
            let scene = lit_scene(lights, false);
            let obj = &scene.objects[0];
            for k in [
                [0.2, 0.7, 0.3],
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.5],
                [0.1, 0.9, 0.0],
            ] {
                for e in [10.0, 0.0, 20.5, 128.0].map(Specular::new) {
                    for _ in 0..200 {
                        let dir = unit();
                        let c =
                            DVec3::new(next(), next() * 2.0, if next() < 0.2 { 0.0 } else { 1.0 });
                        let n = (next() < 0.9).then(unit);
                        let h = Headlit::new(&scene, obj, dir, k, e).expect("directional");
                        let (calls, want_calls) =
                            (std::cell::Cell::new(0), std::cell::Cell::new(0));
                        let got = h.colour(c, || {
                            calls.set(calls.get() + 1);
                            n
                        });
                        let want = scene.illuminate_colour(obj, DVec3::ZERO, dir, c, k, e, || {
                            want_calls.set(want_calls.get() + 1);
                            n
                        });
                        assert_eq!(
                            got.to_array().map(f64::to_bits),
                            want.to_array().map(f64::to_bits)
                        );
                        assert_eq!(calls.get(), want_calls.get());
                        compared += 1;
                        lit += calls.get();
                    }
                }
            }
        }
        assert_eq!(compared, 3 * 4 * 4 * 200);
        assert!(lit > 1000, "{lit}");
        let point = Light::Point {
            position: DVec3::ZERO,
            attenuation: Attenuation::None,
            radiance: [1.0; 3],
        };
        let k = [0.2, 0.7, 0.3];
        let e = Specular::new(10.0);
        let scene = lit_scene(vec![light(DVec3::Y, [1.0; 3]), point], false);
        assert!(Headlit::new(&scene, &scene.objects[0], DVec3::X, k, e).is_none());
        let scene = lit_scene(vec![light(DVec3::Y, [1.0; 3])], true);
        assert!(scene.plan.shadows);
        assert!(Headlit::new(&scene, &scene.objects[0], DVec3::X, k, e).is_none());
    }

    /// The lighting lanes' diagonal form of a matrix whose entries off the diagonal are ±0
    /// (`ToWorld::Diagonal`) lights every sample as the general product with that matrix
    /// (`ToWorld::General`, glam's `m * g`), bit for bit: gradients with components of every
    /// kind (±0, subnormal, tiny, huge, infinite, NaN, random bits), diagonals with negative,
    /// zero and huge entries, lights and views along the axes and not, flipped or not. And
    /// the sign of a zero component of a gradient changes no colour, in either form or in
    /// world space.
    #[test]
    fn diagonal_to_world_is_the_matrix_product() {
        let rng = Xorshift::new(0x9e37_79b9_7f4a_7c15);
        let (next, unit) = (|| rng.next(), || unit_dir(&|| rng.next()));
        let comp = || match (next() * 10.0) as usize {
            0 => 0.0,
            1 => -0.0,
            2 => 1e-310,
            3 => -1e-8,
            4 => 1e300,
            5 => f64::INFINITY,
            6 => f64::NAN,
            7 => f64::from_bits(rng.bits()),
            _ => next() - 0.5,
        };
        let axis = |v: f64| {
            let mut d = DVec3::ZERO;
            d[(next() * 3.0) as usize] = v;
            d
        };
        let mut compared = 0;
        for round in 0..400 {
            let to_light = if round % 2 == 0 { axis(1.0) } else { unit() };
            let scene = lit_scene(
                vec![Light::Directional {
                    to_light,
                    radiance: [1.0, 0.7, 0.3],
                }],
                false,
            );
            let dir = if round % 3 == 0 { -axis(1.0) } else { unit() };
            let e = Specular::new([10.0, 1.0, 0.0][round % 3]);
            let h = Headlit::new(&scene, &scene.objects[0], dir, [0.2, 0.7, 0.3], e).unwrap();
            let z = || if next() < 0.5 { 0.0 } else { -0.0 };
            let d = || match (next() * 4.0) as usize {
                0 => -1.0,
                1 => 0.0,
                2 => 1e300,
                _ => (next() - 0.5) * 300.0,
            };
            let m = glam::DMat3::from_cols(
                DVec3::new(d(), z(), z()),
                DVec3::new(z(), d(), z()),
                DVec3::new(z(), z(), d()),
            );
            for flip in [false, true] {
                let diagonal = HeadlitLanes::new(&h, flip, Some(m)).unwrap();
                assert!(matches!(diagonal.to_world, ToWorld::Diagonal(_)));
                let mut general = HeadlitLanes::new(&h, flip, Some(m)).unwrap();
                let splat = |v: DVec3| v.to_array().map(Lanes::splat);
                general.to_world =
                    ToWorld::General([splat(m.x_axis), splat(m.y_axis), splat(m.z_axis)]);
                let mut cs = [[0.0f32; 8]; 3];
                let mut grads = [[0.0; 8]; 3];
                for j in 0..8 {
                    for a in 0..3 {
                        cs[a][j] = next() as f32;
                        grads[a][j] = if next() < 0.3 { z() } else { comp() };
                    }
                }
                let view = h.view.to_array().map(Lanes::splat);
                let (mut a, mut b) = ([[0.0; 8]; 3], [[0.0; 8]; 3]);
                diagonal.colours(8, &view, &cs, &mut a, &grads);
                general.colours(8, &view, &cs, &mut b, &grads);
                assert_eq!(
                    a.map(|c| c.map(f64::to_bits)),
                    b.map(|c| c.map(f64::to_bits)),
                    "{m:?} {grads:?}"
                );
                // Nor does the sign of a zero component of the gradient change a colour
                // (`Dataset::trilinear_gradient_in` may give either), in object space or in
                // world space.
                let flipped = grads.map(|a| a.map(|x| if x == 0.0 { -x } else { x }));
                let mut world = HeadlitLanes::new(&h, flip, None).unwrap();
                for lanes in [&diagonal, &general, &mut world] {
                    let (mut a, mut b) = ([[0.0; 8]; 3], [[0.0; 8]; 3]);
                    lanes.colours(8, &view, &cs, &mut a, &grads);
                    lanes.colours(8, &view, &cs, &mut b, &flipped);
                    assert_eq!(
                        a.map(|c| c.map(f64::to_bits)),
                        b.map(|c| c.map(f64::to_bits)),
                        "{grads:?}"
                    );
                }
                compared += 8;
            }
        }
        assert!(compared > 6000);
    }

    /// [`HeadlitLanes`] gives [`Headlit::colour`]'s colour bit for bit, the normal made by
    /// [`normal_of_gradient`] as [`CObj::gradient_normal`] makes it: for runs of 1 to 8
    /// samples, random lights, views and gradients (N·L and R·V of either sign, exactly ±0,
    /// vanishing, NaN and subnormal gradients), kd or ks 0 or negative, integer exponents,
    /// normals flipped or not, colours from 0 to overflowing. It is refused for several lights,
    /// none (kd and ks 0) and other exponents, which the scalar path keeps.
    #[test]
    fn headlit_lanes_are_headlit() {
        let rng = Xorshift::new(0x2545_f491_4f6c_dd1du64);
        let (next, unit) = (|| rng.next(), || unit_dir(&|| rng.next()));
        let light = |to_light: DVec3, radiance: [f32; 3]| Light::Directional { to_light, radiance };
        // What the scalar colours exercised: lit with a specular term, lit without, facing
        // away, no normal, and not finite.
        let mut seen = [0usize; 5];
        let mut compared = 0;
        for round in 0..12 {
            let to_light = match round % 3 {
                0 => DVec3::new(0.0, -1.0, 0.0),
                _ => unit(),
            };
            let radiance = [1.0, 0.5 + next() as f32, 2.0 * next() as f32];
            let scene = lit_scene(vec![light(to_light, radiance)], false);
            let obj = &scene.objects[0];
            for k in [
                [0.2, 0.7, 0.3],
                [1.0, 0.0, 0.5],
                [0.1, 0.9, 0.0],
                [0.3, -0.5, 0.4],
            ] {
                for e in [10.0, 0.0, 1.0, 7.0, 128.0].map(Specular::new) {
                    for flip in [false, true] {
                        for _ in 0..60 {
                            let dir = match round % 3 {
                                0 => DVec3::new(0.0, 1.0, 0.0),
                                _ => unit(),
                            };
                            let h = Headlit::new(&scene, obj, dir, k, e).expect("directional");
                            // Gradients in world space, or in object space for the lanes to
                            // transform (a random matrix, as `CObj::field_gradient` would, or
                            // a diagonal one, a flip or scale along the axes, with +0 and −0
                            // off the diagonal).
                            let to_world = match (next() * 4.0) as usize {
                                0 | 1 => None,
                                2 => {
                                    Some(glam::DMat3::from_cols(unit() * 3.0, unit(), unit() * 0.1))
                                }
                                _ => {
                                    let z = || if next() < 0.5 { 0.0 } else { -0.0 };
                                    let d = || match (next() * 5.0) as usize {
                                        0 => -1.0,
                                        1 => 0.0,
                                        2 => 196.0,
                                        _ => (next() - 0.5) * 300.0,
                                    };
                                    Some(glam::DMat3::from_cols(
                                        DVec3::new(d(), z(), z()),
                                        DVec3::new(z(), d(), z()),
                                        DVec3::new(z(), z(), d()),
                                    ))
                                }
                            };
                            let lanes = HeadlitLanes::new(&h, flip, to_world).expect("one light");
                            let count = 1 + (next() * 8.0) as usize;
                            let (mut cs, mut grads) = ([[0.0f32; 8]; 3], [[0.0; 8]; 3]);
                            let mut want = Vec::new();
                            for j in 0..count {
                                // Colours in f32, as the tables give them (the largest, and
                                // an infinite one, included).
                                let v = next();
                                let c32 = if v < 0.03 {
                                    [f32::MAX, next() as f32, 0.0]
                                } else if v < 0.05 {
                                    [next() as f32, f32::INFINITY, 0.0]
                                } else {
                                    let b = (next() < 0.8) as u8 as f32;
                                    [next() as f32, next() as f32 * 2.0, b]
                                };
                                let c = DVec3::from_array(c32.map(f64::from));
                                let u = next();
                                let (g, zero) = if u < 0.05 {
                                    (DVec3::ZERO, true)
                                } else if u < 0.1 {
                                    (unit(), true)
                                } else if u < 0.13 {
                                    (DVec3::new(f64::NAN, 1.0, 0.0), false)
                                } else if u < 0.16 {
                                    (DVec3::new(1e-320, 0.0, 0.0), false)
                                } else if u < 0.22 {
                                    // About the threshold of a vanishing gradient.
                                    let t = ZERO_GRADIENT;
                                    let tiny = [0.0, -0.0, t, -t, t.next_up(), -t.next_up()];
                                    let pick = || match (next() * 9.0) as usize {
                                        k @ 0..6 => tiny[k],
                                        6 => 1e-320,
                                        7 => t * next(),
                                        _ => -t * next(),
                                    };
                                    let g = DVec3::new(pick(), pick(), pick());
                                    (g, vanishing(g.to_array()).1)
                                } else if u < 0.25 {
                                    // Along an axis: N·L exactly ±0 or ±1 for the axis light
                                    // (the other components +0 or −0).
                                    let z = || if next() < 0.5 { 0.0 } else { -0.0 };
                                    let mut g = DVec3::new(z(), z(), z());
                                    g[(next() * 3.0) as usize] = next() - 0.5;
                                    (g, false)
                                } else {
                                    (unit() * (0.001 + 100.0 * next()), false)
                                };
                                // An object-space gradient is a dataset's: it vanishes as
                                // `vanishing` finds, and the lanes test that themselves
                                // (given as it is, or as NaN where it vanishes, as the march
                                // passes a gradient from `CObj::field_gradient_in`).
                                let (g, zero, as_it_is) = match to_world {
                                    Some(_) => (g, vanishing(g.to_array()).1, next() < 0.5),
                                    None => (g, zero, false),
                                };
                                let view = -dir;
                                let world = to_world.map_or(g, |m| m * g);
                                let n = normal_of_gradient(world, zero, view, flip);
                                let col = h.colour(c, || n);
                                want.push(col);
                                let case = match n {
                                    _ if col == DVec3::ZERO && c != DVec3::ZERO => 4,
                                    None => 3,
                                    Some(n) if n.dot(to_light) <= 0.0 => 2,
                                    Some(n)
                                        if (2.0 * n.dot(to_light) * n - to_light).dot(view)
                                            > 0.0 =>
                                    {
                                        0
                                    }
                                    Some(_) => 1,
                                };
                                seen[case] += 1;
                                let g = if zero && !as_it_is {
                                    [f64::NAN; 3]
                                } else {
                                    g.to_array()
                                };
                                for a in 0..3 {
                                    cs[a][j] = c32[a];
                                    grads[a][j] = g[a];
                                }
                            }
                            let view = h.view.to_array().map(Lanes::splat);
                            let mut out = [[0.0; 8]; 3];
                            lanes.colours(count, &view, &cs, &mut out, &grads);
                            for (j, want) in want.iter().enumerate() {
                                let got = [out[0][j], out[1][j], out[2][j]];
                                assert_eq!(
                                    got.map(f64::to_bits),
                                    want.to_array().map(f64::to_bits),
                                    "{got:?} {want:?}"
                                );
                                compared += 1;
                            }
                        }
                    }
                }
            }
        }
        assert!(compared > 40_000, "{compared}");
        assert!(seen.iter().all(|&n| n > 500), "{seen:?}");
        // Refused: several lights, none (kd and ks 0), an exponent that is not an integer.
        let one = lit_scene(vec![light(DVec3::Y, [1.0; 3])], false);
        let two = lit_scene(
            vec![light(DVec3::Y, [1.0; 3]), light(DVec3::X, [1.0; 3])],
            false,
        );
        let (k, e) = ([0.2, 0.7, 0.3], Specular::new(10.0));
        let headlit = |scene, k, e| Headlit::new(scene, &scene.objects[0], DVec3::X, k, e);
        assert!(HeadlitLanes::new(&headlit(&one, k, e).unwrap(), false, None).is_some());
        assert!(HeadlitLanes::new(&headlit(&two, k, e).unwrap(), false, None).is_none());
        let dark = headlit(&one, [0.2, 0.0, 0.0], e).unwrap();
        assert!(HeadlitLanes::new(&dark, false, None).is_none());
        let e = Specular::new(20.5);
        assert!(HeadlitLanes::new(&headlit(&one, k, e).unwrap(), false, None).is_none());
    }

    /// The march in lanes is the march without them and the sample-by-sample loop, bit for
    /// bit, ray for ray, through a lit random volume opaque enough that most rays end inside
    /// a run (the transmittance falls below the threshold at a sample with others after it):
    /// no sample after the end is lit, and the gradient cache is read in the same order.
    #[test]
    fn lanes_march_is_the_march() {
        use crate::types::MappingType;
        let rng = Xorshift::new(0x9e37_79b9_7f4a_7c15u64);
        let next = || rng.next();
        let n = 24usize;
        // Smooth blobs, with flat (zero-gradient) patches at 0 and 255.
        let centres: Vec<[f64; 4]> = (0..6)
            .map(|_| {
                [
                    next() * 24.0,
                    next() * 24.0,
                    next() * 24.0,
                    3.0 + next() * 5.0,
                ]
            })
            .collect();
        let voxels: Vec<u8> = (0..n * n * n)
            .map(|i| {
                let p = [(i % n) as f64, (i / n % n) as f64, (i / n / n) as f64];
                let v: f64 = centres
                    .iter()
                    .map(|c| {
                        let d2 = (0..3).map(|a| (p[a] - c[a]).powi(2)).sum::<f64>();
                        300.0 * (-d2 / (c[3] * c[3])).exp()
                    })
                    .sum();
                v.min(255.0) as u8
            })
            .collect();
        let data = Dataset::new([n; 3], crate::dataset::Voxels::U8(voxels), 0.0, 1.0).unwrap();
        let mut terminated = 0;
        for (ks, exponent) in [(0.3, 10.0), (0.0, 10.0), (0.6, 3.0), (0.3, 20.5)] {
            let mut vl = crate::Library::new();
            vl.add_dataset(1, data.clone()).unwrap();
            vl.mapping(
                2,
                MappingType::Ramp,
                3,
                1,
                &[0.15, 0.0, 0.5, 0.6, 1.0, 0.95],
            )
            .unwrap();
            let colour = [0.2, 0.55, 0.35, 0.3, 0.6, 0.9, 0.7, 0.5, 1.0, 1.0, 1.0, 1.0];
            vl.mapping(3, MappingType::Ramp, 3, 3, &colour).unwrap();
            vl.scene().unwrap();
            vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
            vl.directional_light([0.3, -1.0, 0.2], [1.0, 0.9, 0.8], 1.0)
                .unwrap();
            vl.step_size(0.5, 1.0).unwrap();
            vl.object().unwrap();
            vl.scale(23.0, 23.0, 23.0).unwrap();
            vl.dataset(Fields::F, 1).unwrap();
            vl.map(Fields::O, Fields::F, 2, 1).unwrap();
            vl.map(Fields::R, Fields::F, 3, 1).unwrap();
            vl.map(Fields::G, Fields::F, 3, 2).unwrap();
            vl.map(Fields::B, Fields::F, 3, 3).unwrap();
            vl.set(Fields::KA, 0.2).unwrap();
            vl.set(Fields::KD, 0.7).unwrap();
            vl.set(Fields::KS, ks).unwrap();
            vl.set(Fields::N, crate::types::specular_to_field(exponent))
                .unwrap();
            vl.end().unwrap();
            let scene = vl.compiled().unwrap();
            let obj = &scene.objects[0];
            let lean = obj.lean.as_ref().expect("lean");
            let (data, z) = lean.value_head().expect("a value head");
            assert!(lean.direct_shading().is_some());
            let stop = scene.settings.optimise.stop_below();
            for _ in 0..400 {
                let at = DVec3::new(next(), next(), next()) * 23.0;
                let dir = unit_dir(&next);
                let origin = at - 60.0 * dir;
                let (o, d) = obj.object_ray(origin, dir);
                let Some((t0, t1)) = obj.clip(o, d) else {
                    continue;
                };
                let cursor = || Cursor::new(&scene, obj, 0, (o, d), (t0, t1), f64::NEG_INFINITY);
                let (mut a, mut b, mut c) = (cursor(), cursor(), cursor());
                let lanes = scene.march_batched::<true>(obj, lean, data, z, &mut a, origin, dir);
                let plain = scene.march_batched::<false>(obj, lean, data, z, &mut b, origin, dir);
                // The sample-by-sample loop (`march_one`'s general one).
                let (mut col, mut t) = (DVec3::ZERO, 1.0f64);
                while let Some(mid) = c.peek(obj.skip.as_deref()) {
                    let len = c.take();
                    if len <= 0.0 {
                        continue;
                    }
                    let (w, p) = (origin + mid * dir, c.object_point(mid));
                    if let Some((alpha, colour)) = scene.shade(obj, w, p, dir, len) {
                        col += t * alpha * colour;
                        t *= 1.0 - alpha;
                        if t < stop {
                            t = 0.0;
                            break;
                        }
                    }
                }
                let bits = |(c, t): (DVec3, f64)| (c.to_array().map(f64::to_bits), t.to_bits());
                assert_eq!(bits(lanes), bits(plain));
                assert_eq!(bits(lanes), bits((col, t)));
                terminated += (lanes.1 == 0.0) as usize;
            }
        }
        assert!(terminated > 300, "{terminated}");
    }

    /// A scene of one DVR volume with a skip grid: random spheres in a 20³ dataset, scaled
    /// to a box 19 wide.
    fn sphere_scene() -> Compiled {
        use crate::types::MappingType;
        let n = 20usize;
        let centres = [
            [5.0, 6.0, 7.0, 3.0],
            [14.0, 12.0, 9.0, 4.0],
            [8.0, 15.0, 15.0, 2.5],
        ];
        let voxels: Vec<u8> = (0..n * n * n)
            .map(|i| {
                let p = [(i % n) as f64, (i / n % n) as f64, (i / n / n) as f64];
                let inside = centres
                    .iter()
                    .any(|c| (0..3).map(|a| (p[a] - c[a]).powi(2)).sum::<f64>() < c[3] * c[3]);
                if inside {
                    200
                } else {
                    0
                }
            })
            .collect();
        let data = Dataset::new([n; 3], crate::dataset::Voxels::U8(voxels), 0.0, 1.0).unwrap();
        let mut vl = crate::Library::new();
        vl.add_dataset(1, data).unwrap();
        vl.mapping(2, MappingType::Ramp, 3, 1, &[0.3, 0.0, 0.5, 0.6, 1.0, 0.95])
            .unwrap();
        vl.scene().unwrap();
        vl.step_size(0.5, 1.0).unwrap();
        vl.object().unwrap();
        vl.scale(19.0, 19.0, 19.0).unwrap();
        vl.dataset(Fields::F, 1).unwrap();
        vl.map(Fields::O, Fields::F, 2, 1).unwrap();
        vl.set(Fields::R, 1.0).unwrap();
        vl.end().unwrap();
        let scene = vl.compiled().unwrap();
        assert!(scene.objects[0].skip.is_some(), "a skip grid");
        scene
    }

    /// Ray parts that make trouble: zeros of both signs, magnitudes below 10⁻³⁰⁸ (whose
    /// reciprocals overflow), huge values, infinities and NaN, and ordinary ones.
    const AWKWARD: [f64; 14] = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.37,
        -2.5,
        1e-310,
        -1e-310,
        1e300,
        -1e300,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        19.0,
    ];

    /// [`CObj::clip`] as it was, with `f64::min` / `f64::max`.
    fn clip_reference(min: DVec3, max: DVec3, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for i in 0..3 {
            if d[i] == 0.0 {
                if o[i] < min[i] || o[i] > max[i] {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / d[i];
            let (a, b) = ((min[i] - o[i]) * inv, (max[i] - o[i]) * inv);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        (t0 < t1 && t1.is_finite()).then_some((t0, t1))
    }

    /// The clip is the NaN-aware one, bit for bit: rays from outside, inside, on faces and
    /// edges, parallel to faces, with zero, tiny, huge, infinite and NaN parts, through
    /// ordinary, flat (one axis of zero width) and signed-zero boxes.
    #[test]
    fn clip_is_the_nan_aware_clip() {
        let mut scene = sphere_scene();
        let rng = Xorshift::new(0x2545_f491_4f6c_dd1du64);
        let next = || rng.next();
        let boxes = [
            (DVec3::ZERO, DVec3::ONE),
            (DVec3::new(-0.0, 0.0, -0.0), DVec3::new(2.0, 0.0, 1.0)),
            (DVec3::new(-3.0, 1e-310, -1.0), DVec3::new(-1.0, 1.0, 1e300)),
        ];
        let (mut some, mut none) = (0, 0);
        for (min, max) in boxes {
            scene.objects[0].box_min = min;
            scene.objects[0].box_max = max;
            let obj = &scene.objects[0];
            let mut check = |o: DVec3, d: DVec3| {
                let bits = |r: Option<(f64, f64)>| r.map(|(a, b)| (a.to_bits(), b.to_bits()));
                let got = obj.clip(o, d);
                assert_eq!(bits(got), bits(clip_reference(min, max, o, d)), "{o} {d}");
                // The packet march's clip in lanes, the same numbers.
                #[cfg(target_arch = "x86_64")]
                if is_x86_feature_detected!("avx2") {
                    // SAFETY: AVX2 was detected.
                    let lanes = unsafe {
                        use std::arch::x86_64::_mm256_set1_pd as splat;
                        let (t0, t1, ok) =
                            simd::clip_lanes(o, &[splat(d.x), splat(d.y), splat(d.z)], min, max);
                        (ok & 1 != 0).then(|| (simd::st4d(t0)[0], simd::st4d(t1)[0]))
                    };
                    assert_eq!(bits(lanes), bits(got), "lanes: {o} {d}");
                }
                if got.is_some() {
                    some += 1;
                } else {
                    none += 1;
                }
            };
            let mut parts: Vec<f64> = AWKWARD.to_vec();
            parts.extend([min.x, max.y, min.z, max.x]);
            let inside = (min + max) * 0.5;
            for &a in &parts {
                for &b in &parts {
                    for &c in &parts {
                        let v = DVec3::new(a, b, c);
                        check(inside, v);
                        check(v, DVec3::new(0.3, -0.5, 0.8));
                        check(v, DVec3::new(b, c, a));
                        check(DVec3::new(-5.0, c, b), v);
                    }
                }
            }
            for _ in 0..20_000 {
                let o = DVec3::new(next() * 8.0 - 4.0, next() * 8.0 - 4.0, next() * 8.0 - 4.0);
                let mut d = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                // Some parallel to a face.
                let axis = (next() * 6.0) as usize;
                if axis < 3 {
                    d[axis] = 0.0;
                }
                check(o, d);
            }
        }
        assert!(some > 10_000 && none > 10_000, "{some} / {none}");
    }

    /// The packet march's ray starts in lanes are the scalar ones, bit for bit: the directions
    /// of `Pinhole::ray` and their object-space directions (random cameras and placements,
    /// every pixel of small images), segment counts of `segment_count` (where the lanes give
    /// one), and first segments of `Cursor::start_at` (where the lanes give one: at bounds
    /// before, on and between midpoints, past the end, at awkward values).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn ray_start_lanes_are_the_scalar_starts() {
        use std::arch::x86_64::*;
        if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
            return;
        }
        let rng = Xorshift::new(0x5a77_1e5f_0ca5_7e11);
        let next = || rng.next();
        // Directions.
        for case in 0..200 {
            let (w, h) = (5 + (next() * 40.0) as u32, 3 + (next() * 30.0) as u32);
            let view = Pinhole {
                eye: DVec3::ZERO,
                forward: unit_dir(&next) * (0.5 + next() * 3.0),
                right: unit_dir(&next) * (0.1 + next()),
                up: unit_dir(&next) * (0.1 + next()),
                width: w,
                height: h,
            };
            let to_object = glam::DMat4::from_cols_array(&std::array::from_fn(|i| {
                if i % 5 == 0 || case % 3 != 0 {
                    next() * 4.0 - 2.0
                } else {
                    0.0
                }
            }));
            for y in 0..h {
                for x0 in (0..w).step_by(4) {
                    // SAFETY: AVX2 was detected above.
                    let (dir, d) = unsafe { simd::ray_lanes(&view, &to_object, x0, y) };
                    let (dir, d) =
                        unsafe { (dir.map(|v| simd::st4d(v)), d.map(|v| simd::st4d(v))) };
                    for l in 0..4 {
                        let want = view.ray((x0 + l as u32) as f64 + 0.5, y as f64 + 0.5);
                        let want_d = to_object.transform_vector3(want);
                        for c in 0..3 {
                            assert_eq!(
                                dir[c][l].to_bits(),
                                want[c].to_bits(),
                                "{case} {x0}+{l} {y}"
                            );
                            assert_eq!(
                                d[c][l].to_bits(),
                                want_d[c].to_bits(),
                                "{case} {x0}+{l} {y}"
                            );
                        }
                    }
                }
            }
        }
        // Counts and first segments.
        let mut values: Vec<f64> = AWKWARD.to_vec();
        values.extend([0.25, 0.5, 1.0 / 3.0, 7.5, 1e-3, 1e-12, 3e15]);
        let (mut counted, mut found, mut searched) = (0, 0, 0);
        for case in 0..20_000 {
            let pick = || values[(next() * values.len() as f64) as usize % values.len()];
            // A cursor's span and step are finite and positive (`CObj::clip`, the state's
            // checks); here its segments below 2⁴⁰ and its step resolvable at its ends (a
            // step below their spacing of numbers has no midpoints to search among, and
            // the cursor's own search walks them one by one).
            let (t0, len, step) = if case % 4 == 0 {
                let (t0, len, step) = (pick().abs(), pick().abs(), pick().abs());
                if !(t0.is_finite() && len > 0.0 && step > 0.0 && (t0 + len).is_finite())
                    || len / step >= (1u64 << 40) as f64
                    || step < (t0 + len) * 1e-9
                {
                    continue;
                }
                (t0, len, step)
            } else {
                let step = [0.5, 1.0 / 3.0, 0.01, 2.0, 1e-9][case % 5] * (0.5 + next());
                (next() * 50.0, next() * [1.0, 100.0, 1e-6][case % 3], step)
            };
            let t1 = t0 + len;
            let lanes = |x: [f64; 4]| unsafe { _mm256_loadu_pd(x.as_ptr()) };
            let n_scalar = segment_count((t1 - t0) / step);
            // SAFETY: AVX2 was detected above.
            let n = unsafe { simd::count_lanes(lanes([t0; 4]), lanes([t1; 4]), step) };
            if n[0] != 0 {
                assert_eq!(n[0], n_scalar, "{t0} {t1} {step}");
                counted += 1;
            }
            let c = cursor(t0, t1, step, n_scalar, 0, f64::NEG_INFINITY);
            let mid = |k: u64| c.mid(k.min(n_scalar - 1));
            let k = (next() * n_scalar.min(1 << 20) as f64) as u64;
            let ts = [
                t0 - 1.0,
                mid(k),
                mid(k) + step * 0.25,
                mid(k + 1) - step * 1e-9,
                t1 + step,
                pick(),
                f64::NEG_INFINITY,
                t0 + (next() - 0.2) * len * 1.3,
            ];
            for chunk in ts.chunks(4) {
                let t: [f64; 4] = chunk.try_into().unwrap();
                // SAFETY: AVX2 was detected above.
                let got = unsafe {
                    simd::first_segments(lanes([t0; 4]), lanes([t1; 4]), step, [n[0]; 4], lanes(t))
                };
                for (l, &t) in t.iter().enumerate() {
                    let mut want = cursor(t0, t1, step, n_scalar, 0, f64::NEG_INFINITY);
                    want.start_at(t);
                    match got[l] {
                        Some(k) => {
                            assert_eq!(k, want.k, "{t0} {t1} {step} n {n_scalar} t {t}");
                            found += 1;
                        }
                        None => searched += 1,
                    }
                }
            }
        }
        assert!(
            counted > 15_000 && found > 80_000,
            "{counted} {found} {searched}"
        );
    }

    /// A ray whose entry bound is +∞ shows the background as the clip and march would give
    /// it, bit for bit (`background` where it misses the box, `0 + 1·background` where it
    /// meets it): through a background with −0 parts too (where the two differ), infinite
    /// and NaN parts, and rays with zero, tiny, infinite and NaN parts.
    #[test]
    fn unbounded_rays_show_the_background() {
        let mut scene = sphere_scene();
        let (mut checked, mut known) = (0, 0);
        for background in [
            [0.2f32, 0.5, 0.9],
            [-0.0, 0.5, 0.0],
            [f32::NAN, f32::INFINITY, -0.0],
        ] {
            scene.settings.background = background;
            let bg = crate::scene::v3(background);
            let obj = &scene.objects[0];
            for &a in &AWKWARD {
                for &b in &AWKWARD {
                    for (origin, dir) in [
                        (DVec3::new(-30.0, a, 9.0), DVec3::new(1.0, b, 0.01)),
                        (DVec3::new(a, b, 5.0), DVec3::new(0.2, 0.3, 0.9)),
                        (DVec3::new(9.0, 9.0, 9.0), DVec3::new(a, b, 1.0)),
                        (DVec3::new(9.0, 40.0, a), DVec3::new(0.0, -1.0, b)),
                    ] {
                        let (o, d) = obj.object_ray(origin, dir);
                        let want = match obj.clip(o, d) {
                            None => bg,
                            Some(_) => DVec3::ZERO + 1.0 * bg,
                        };
                        let got = scene.trace_ray(origin, None, dir, Ray::PRIMARY, f64::INFINITY);
                        let bits = |v: DVec3| v.to_array().map(f64::to_bits);
                        assert_eq!(bits(got), bits(want), "{origin} {dir} {background:?}");
                        let image = scene.image_rays(origin);
                        let per_image = scene.trace(origin, &image, dir, f64::INFINITY);
                        assert_eq!(bits(per_image), bits(want), "{origin} {dir} {background:?}");
                        // The per-pixel loop's answer without the ray, where it has one.
                        if let Some(c) = scene.unbounded_colour() {
                            assert_eq!(bits(c), bits(got), "{origin} {dir} {background:?}");
                            known += 1;
                        }
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 2000 && known > 700, "{checked} {known}");
    }

    /// The one-volume path, whose cursor is built in place ([`Cursor::unstarted`] and
    /// [`Cursor::start`]), is [`Cursor::new`] and [`Compiled::march_one`], bit for bit, for
    /// entry bounds of −∞, NaN, the clip's t0, and points inside the box's span.
    #[test]
    fn cursor_started_in_place_is_the_new_cursor() {
        let mut scene = sphere_scene();
        scene.settings.background = [0.1, 0.2, 0.3];
        let bg = crate::scene::v3(scene.settings.background);
        let obj = &scene.objects[0];
        let rng = Xorshift::new(0x9e37_79b9_7f4a_7c15u64);
        let next = || rng.next();
        let (mut hits, mut checked) = (0, 0);
        for i in 0..3000 {
            let at = DVec3::new(next(), next(), next()) * 19.0;
            let mut dir = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            if i % 7 == 0 {
                dir[i % 3] = 0.0;
            }
            let origin = at - 50.0 * dir;
            let (o, d) = obj.object_ray(origin, dir);
            let Some((t0, t1)) = obj.clip(o, d) else {
                continue;
            };
            for bound in [f64::NEG_INFINITY, f64::NAN, t0, t0 + (t1 - t0) * next()] {
                let mut c = Cursor::new(&scene, obj, 0, (o, d), (t0, t1), bound);
                let (col, t) = scene.march_one(&mut c, origin, dir);
                let want = col + t * bg;
                let got = scene.trace_ray(origin, None, dir, Ray::PRIMARY, bound);
                let bits = |v: DVec3| v.to_array().map(f64::to_bits);
                assert_eq!(bits(got), bits(want), "{origin} {dir} {bound}");
                // And with the origin and background made once per image (`Compiled::trace`).
                let image = scene.image_rays(origin);
                let per_image = scene.trace_ray(origin, Some(&image), dir, Ray::PRIMARY, bound);
                assert_eq!(bits(per_image), bits(want), "{origin} {dir} {bound}");
                hits += (t < 1.0) as usize;
                checked += 1;
            }
        }
        assert!(checked > 2000 && hits > 500, "{checked} / {hits}");
    }

    /// `index_f64` is `k as f64` bit for bit, for counts n ≥ k below and above 2⁶³: small
    /// numbers, around 2⁵³ (where the conversion starts rounding), 2⁶³ and 2⁶⁴, and random bit
    /// patterns of every width.
    #[test]
    fn index_f64_is_the_unsigned_conversion() {
        let mut ks = vec![0u64, 1, 2, 3, 1000, u64::MAX, u64::MAX - 1];
        for e in [52u32, 53, 54, 62, 63] {
            let b = 1u64 << e;
            ks.extend([b - 2, b - 1, b, b + 1, b + 2, b + 3]);
        }
        let rng = Xorshift::new(0x2545_f491_4f6c_dd1du64);
        for i in 0..4000 {
            ks.push(rng.bits() >> (i % 64));
        }
        for &k in &ks {
            for n in [
                k,
                k.saturating_add(1),
                k | (1 << 62),
                i64::MAX as u64,
                u64::MAX,
            ] {
                let (k, n) = std::hint::black_box((k, n.max(k)));
                assert_eq!(
                    index_f64(k, n).to_bits(),
                    (k as f64).to_bits(),
                    "{k} of {n}"
                );
            }
        }
    }

    /// `transmit_at_most_one` is the opaque medium's test, then `transmit`, bit for bit on
    /// opacities of [0, 1] (±0, subnormal, near 1, 1), below 0, −∞ and NaN, each against the
    /// common exponents, their neighbours, 0, ±subnormal, negative, huge, ±∞, NaN and random
    /// exponents; and random opacity bits with the sign of a number not above 1.
    #[test]
    fn transmit_at_most_one_is_the_tested_transmit() {
        // (The opaque medium's test first, then `transmit`.)
        let old = |o: f64, e: f64| if o >= 1.0 { 0.0 } else { transmit(1.0 - o, e) };
        let rng = Xorshift::new(0x2545_f491_4f6c_dd1d);
        let mut os = vec![
            0.0,
            -0.0,
            1.0,
            1.0 - f64::EPSILON / 2.0,
            1.0 - f64::EPSILON,
            0.5,
            0.25,
            1e-310,
            f64::MIN_POSITIVE,
            -1e-310,
            -1.0,
            -1e300,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
            f32::MIN_POSITIVE as f64,
            (1.0f32 - f32::EPSILON / 2.0) as f64,
        ];
        os.extend((0..2000).map(|_| rng.next()));
        os.extend((0..2000).map(|_| rng.next() as f32 as f64));
        os.extend((0..2000).map(|_| {
            let o = f64::from_bits(rng.bits());
            if o > 1.0 {
                -o
            } else {
                o
            }
        }));
        let mut es = vec![
            0.0,
            -0.0,
            1.0,
            0.5,
            0.25,
            2.0,
            -0.5,
            -1.0,
            -2.0,
            1e-310,
            -1e-310,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            3.0,
            0.125,
            4.0,
            8.0,
            0.0625,
        ];
        for e in [1.0f64, 0.5, 0.25, 2.0, 0.125, 4.0] {
            es.extend([e.next_up(), e.next_down()]);
        }
        es.extend((0..40).map(|_| rng.next() * 4.0));
        es.extend((0..40).map(|_| f64::from_bits(rng.bits())));
        for &o in &os {
            for &e in &es {
                let (a, b) = (transmit_at_most_one(o, e), old(o, e));
                assert!(
                    a.to_bits() == b.to_bits(),
                    "o {o:e} e {e:e}: {a:e} against {b:e}"
                );
            }
        }
    }

    /// The segment count is ⌈x⌉ clamped as it was, at integers and next to them, in (0, 1),
    /// around 2⁵² and 2⁶⁴, at zeros, negatives, infinities and NaN.
    #[test]
    fn segment_count_is_the_rounded_up_span() {
        let reference = |x: f64| {
            let n = crate::num::ceil(x).max(1.0);
            if n.is_finite() && n < u64::MAX as f64 {
                n as u64
            } else {
                u64::MAX
            }
        };
        let mut xs = vec![
            0.0,
            -0.0,
            -1.0,
            1e-310,
            0.5,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            1e300,
            u64::MAX as f64,
            (1u64 << 63) as f64,
        ];
        for base in [
            1.0f64,
            2.0,
            3.0,
            17.0,
            1e6,
            4_503_599_627_370_496.0,
            9e15,
            1.8e19,
        ] {
            let mut x = base;
            for _ in 0..4 {
                x = x.next_down();
            }
            for _ in 0..9 {
                xs.extend([x, -x, x + 0.5]);
                x = x.next_up();
            }
        }
        let rng = Xorshift::new(0x1234_5678_9abc_def1u64);
        for _ in 0..100_000 {
            let bits = rng.bits();
            xs.push(f64::from_bits(bits));
            xs.push((bits >> 11) as f64 / (1u64 << 40) as f64);
        }
        for x in xs {
            assert_eq!(segment_count(x), reference(x), "{x:e}");
        }
    }

    /// A random unit direction from `next` (uniform in [0, 1)).
    fn unit_dir(next: &impl Fn() -> f64) -> DVec3 {
        DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5)
            .try_normalize()
            .unwrap_or(DVec3::Y)
    }

    /// A cursor over [t0, t1] in steps of `step`, with no walk.
    fn cursor(t0: f64, t1: f64, step: f64, n: u64, k: u64, occupied_until: f64) -> Cursor {
        Cursor {
            object: 0,
            t0,
            t1,
            step,
            k,
            n,
            walk: None,
            o: DVec3::ZERO,
            d: DVec3::X,
            occupied_until,
        }
    }

    /// The batched march's run before `Cursor::next_run` (the oracle of
    /// `joined_runs_are_peek_and_run`): from the sample `Cursor::peek` chose, the samples
    /// after it in the occupied block the walk last reported (all unless `unbounded`), up to
    /// eight; their number, their midpoints and lengths written into `mids` and `lens`.
    fn run(c: &Cursor, unbounded: bool, mids: &mut [f64; 8], lens: &mut [f64; 8]) -> usize {
        let left = c.segments(mids, lens);
        // The first sample is in the block (peek chose it); the run ends at the first other
        // one that is not.
        if unbounded {
            left
        } else {
            (1..left)
                .find(|&j| mids[j].partial_cmp(&c.occupied_until) != Some(std::cmp::Ordering::Less))
                .unwrap_or(left)
        }
    }

    /// `Cursor::segments` as it was before its last lane was made apart (the oracle of
    /// `segments_last_lane_apart_is_the_old_run`), verbatim.
    fn segments_old(c: &Cursor, mids: &mut [f64; 8], lens: &mut [f64; 8]) -> usize {
        let left = (c.n - c.k).min(8) as usize; // k < n
        let last = c.k + left as u64 == c.n; // the run may reach the last segment
        let k = index_f64(c.k, c.n);
        if k < (1u64 << 53) as f64 - 16.0 {
            let next: [f64; 8] = std::array::from_fn(|j| c.boundary(k + (j + 1) as f64));
            let a: [f64; 8] =
                std::array::from_fn(|j| if j == 0 { c.boundary(k) } else { next[j - 1] });
            let mut b = next.map(|x| at_most(x, c.t1));
            if last {
                b[left - 1] = c.t1;
            }
            *mids = std::array::from_fn(|j| 0.5 * (a[j] + b[j]));
            *lens = std::array::from_fn(|j| b[j] - a[j]);
        } else {
            let mut a = c.boundary(k);
            let mut kf = k;
            for j in 0..left {
                kf += 1.0;
                let next = c.boundary(kf);
                let b = c.end(next, last && j + 1 == left);
                mids[j] = 0.5 * (a + b);
                lens[j] = b - a;
                a = next;
            }
        }
        left
    }

    /// The bits of `x`, every NaN as one: which operand's NaN an addition passes on depends on
    /// the order the compiler gives its operands (it may swap them), and a march's ends and
    /// step are never NaN.
    fn nan_any(x: f64) -> u64 {
        if x.is_nan() {
            u64::MAX
        } else {
            x.to_bits()
        }
    }

    /// A cursor's span and step for the segment tests' case `case`: ordinary (even cases) or
    /// awkward (±0, subnormal, huge, infinite, NaN, random bits: every third case's parts are
    /// random bits).
    fn segment_span(rng: &Xorshift, case: usize) -> (f64, f64, f64) {
        let mut values: Vec<f64> = AWKWARD.to_vec();
        values.extend([0.25, 0.5, 1.0 / 3.0, 7.5, 1e-3]);
        let pick = || {
            if case.is_multiple_of(3) {
                f64::from_bits(rng.bits())
            } else {
                values[(rng.next() * values.len() as f64) as usize % values.len()]
            }
        };
        if case.is_multiple_of(2) {
            let t0 = rng.next() * 10.0;
            (t0, t0 + rng.next() * 20.0, 0.01 + rng.next())
        } else {
            (pick(), pick(), pick())
        }
    }

    /// The run's segments with the last lane made apart are the old ones bit for bit: every
    /// run length, near the start, the end and 2⁵³, for ordinary and awkward ends and steps
    /// (±0, subnormal, huge, infinite, NaN, random bits). A NaN is any NaN ([`nan_any`]).
    #[test]
    fn segments_last_lane_apart_is_the_old_run() {
        let rng = Xorshift::new(0x0dd5_e9e5_1a57_1a9e);
        let mut checked = 0;
        for case in 0..4000 {
            let (t0, t1, step) = segment_span(&rng, case);
            let n = [1u64, 2, 7, 8, 9, 17, 1 << 20, (1 << 53) + 5, u64::MAX][case % 9];
            for k in [
                0,
                n / 2,
                n.saturating_sub(9),
                n.saturating_sub(8),
                n - 1,
                n.saturating_sub(3),
            ] {
                if k >= n {
                    continue;
                }
                let c = cursor(t0, t1, step, n, k, f64::NEG_INFINITY);
                let (mut m0, mut l0) = ([0.5; 8], [0.5; 8]);
                let (mut m1, mut l1) = ([0.5; 8], [0.5; 8]);
                let a = segments_old(&c, &mut m0, &mut l0);
                let b = c.segments(&mut m1, &mut l1);
                assert_eq!(a, b);
                assert_eq!(m0.map(nan_any), m1.map(nan_any), "{t0} {t1} {step} {k}/{n}");
                assert_eq!(l0.map(nan_any), l1.map(nan_any), "{t0} {t1} {step} {k}/{n}");
                checked += 1;
            }
        }
        assert!(checked > 15_000, "{checked}");
    }

    /// The packet march's segments in lanes are the cursor's, bit for bit, on the cases of
    /// `segments_last_lane_apart_is_the_old_run` (every run length, near the start, the end
    /// and 2⁵³, ordinary and awkward ends and steps). A NaN is any NaN ([`nan_any`]).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn lanes_segments_are_the_cursors() {
        if !is_x86_feature_detected!("avx2") {
            return;
        }
        let rng = Xorshift::new(0x5e9_3e47_1a9e_5eed);
        let mut checked = 0;
        for case in 0..4000 {
            let (t0, t1, step) = segment_span(&rng, case);
            let n = [1u64, 2, 7, 8, 9, 17, 1 << 20, (1 << 53) + 5, u64::MAX][case % 9];
            for k in [
                0,
                n / 2,
                n.saturating_sub(17),
                n.saturating_sub(9),
                n.saturating_sub(8),
                n - 1,
                n.saturating_sub(3),
                ((1u64 << 53) - 17).min(n - 1),
            ] {
                let c = cursor(t0, t1, step, n, k, f64::NEG_INFINITY);
                let (mut m0, mut l0) = ([0.5; 8], [0.5; 8]);
                let (mut m1, mut l1) = ([0.5; 8], [0.5; 8]);
                let a = c.segments(&mut m0, &mut l0);
                // SAFETY: AVX2 was detected above.
                let b = unsafe { simd::segments_lanes(&c, &mut m1, &mut l1) };
                assert_eq!(a, b);
                let bits = |x: &[f64; 8]| x[..a].iter().map(|&v| nan_any(v)).collect::<Vec<_>>();
                assert_eq!(bits(&m0), bits(&m1), "{t0} {t1} {step} {k}/{n}");
                assert_eq!(bits(&l0), bits(&l1), "{t0} {t1} {step} {k}/{n}");
                checked += 1;
            }
        }
        assert!(checked > 30_000, "{checked}");
    }

    /// The sixteen-lane march's runs of sixteen segments are the cursor's, bit for bit: two
    /// runs of eight from k and k + 8, on `lanes_segments_are_the_cursors`' cases (a NaN is
    /// any NaN, as there), every starting segment below 2⁵³ − 32.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn wide_segments_are_the_cursors() {
        if !simd::detected() {
            return;
        }
        let rng = Xorshift::new(0x51de_5e9e_a11e_0016);
        let mut checked = 0;
        for case in 0..4000 {
            let (t0, t1, step) = segment_span(&rng, case);
            let n = [
                1u64,
                2,
                7,
                8,
                9,
                16,
                17,
                33,
                1 << 20,
                (1 << 53) + 5,
                u64::MAX,
            ][case % 11];
            for k in [
                0,
                n / 2,
                n.saturating_sub(17),
                n.saturating_sub(16),
                n.saturating_sub(9),
                n - 1,
                ((1u64 << 53) - 33).min(n - 1),
            ] {
                if k as f64 >= (1u64 << 53) as f64 - 32.0 {
                    continue;
                }
                let c = cursor(t0, t1, step, n, k, f64::NEG_INFINITY);
                let mut run = simd::Run16::default();
                // SAFETY: every feature the function enables was detected above.
                let m = unsafe { simd::segments16(&c, &mut run) };
                assert_eq!(m, (n - k).min(16) as usize);
                for (h, from) in [(0, k), (8, k + 8)] {
                    if from >= n {
                        continue;
                    }
                    let c = cursor(t0, t1, step, n, from, f64::NEG_INFINITY);
                    let (mut mids, mut lens) = ([0.5; 8], [0.5; 8]);
                    let a = c.segments(&mut mids, &mut lens);
                    for j in 0..a {
                        assert_eq!(
                            nan_any(run.mids[h + j]),
                            nan_any(mids[j]),
                            "{t0} {t1} {step} {k}+{h}+{j}/{n}"
                        );
                        assert_eq!(
                            nan_any(run.lens[h + j]),
                            nan_any(lens[j]),
                            "{t0} {t1} {step} {k}+{h}+{j}/{n}"
                        );
                    }
                }
                checked += 1;
            }
        }
        assert!(checked > 20_000, "{checked}");
    }

    /// A run in lanes has the segments of the sample-by-sample cursor, bit for bit, ends
    /// at the first sample past the occupied block, and never passes the last segment: near the
    /// start, the end and 2⁵³ (where the boundary numbers stop being exact and the run goes
    /// sample by sample), for uneven steps and ends.
    #[test]
    fn runs_are_the_cursors_segments() {
        let big = (1u64 << 53) as f64;
        let cases = [
            (0.25, 9.9, 0.5, None),
            (-3.0, 4.0, 0.1, None),
            (1e-3, 1.0, 1.0 / 3.0, None),
            (0.0, 2.0, 0.7, None),
            (0.0, big * 0.5, 0.5, Some(1u64 << 53)),
            (5.0, 5.0 + 1e-9, 1e-15, Some(1u64 << 53)),
        ];
        let mut checked = 0;
        for (t0, t1, step, n_cap) in cases {
            let n = n_cap.unwrap_or(((t1 - t0) / step).ceil() as u64).max(1);
            let starts: Vec<u64> = (0..n.min(12))
                .chain(n.saturating_sub(12)..n)
                .chain(
                    [(1 << 53) - 20, (1 << 53) - 17, (1 << 53) - 9]
                        .into_iter()
                        .filter(|&k| k < n),
                )
                .collect();
            for k in starts {
                for occupied in [
                    f64::NEG_INFINITY,
                    f64::INFINITY,
                    t0 + (k as f64 + 3.2) * step,
                ] {
                    for unbounded in [false, true] {
                        let c = cursor(t0, t1, step, n, k, occupied);
                        let (mut mids, mut lens) = ([0.0; 8], [0.0; 8]);
                        let m = run(&c, unbounded, &mut mids, &mut lens);
                        let left = (n - k).min(8) as usize;
                        assert!(m >= 1 && m <= left, "{k} of {n}: {m}");
                        for j in 0..m {
                            let (a, b) = c.segment(k + j as u64);
                            assert_eq!(mids[j].to_bits(), c.mid(k + j as u64).to_bits());
                            assert_eq!(lens[j].to_bits(), (b - a).to_bits(), "{k}+{j} of {n}");
                            assert!(j == 0 || unbounded || mids[j] < occupied);
                        }
                        // The run stops only at the block's end or its eight samples.
                        if m < left {
                            let mid = c.mid(k + m as u64);
                            assert!(
                                !unbounded
                                    && mid.partial_cmp(&occupied) != Some(std::cmp::Ordering::Less)
                            );
                        }
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 300, "{checked}");
    }

    /// The batched march's runs (`Cursor::next_run`, joined across occupied blocks) take
    /// exactly the samples of `Cursor::peek` and the run (`run`, the march before them, kept
    /// here as the oracle), in the same order, bit for bit: on random grids of every fill,
    /// for rays from outside and inside the grid, along axes and diagonals (zero direction
    /// parts), with entry bounds before, inside and past the span, small and large steps, and
    /// without a walk or a grid.
    #[test]
    fn joined_runs_are_peek_and_run() {
        let rng = Xorshift::new(0x1234_5678_9abc_def1);
        let next = || rng.next();
        let mut runs = [0usize; 2];
        let mut taken = 0usize;
        for case in 0..3000 {
            let dims = [
                1 + (next() * 9.0) as usize,
                1 + (next() * 9.0) as usize,
                1 + (next() * 9.0) as usize,
            ];
            let fill = [0.0, 0.1, 0.5, 0.9, 1.0][case % 5];
            let occupied: Vec<bool> = (0..dims.iter().product::<usize>())
                .map(|_| next() < fill)
                .collect();
            let cell = DVec3::new(0.5 + next(), 0.5 + next(), 0.5 + next()) * 0.25;
            let origin = DVec3::new(next(), next(), next()) - 0.5;
            let grid = SkipGrid::of_occupied(dims, origin, cell, &occupied);
            let size = DVec3::from_array(dims.map(|n| n as f64)) * cell;
            let mut d = unit_dir(&next);
            // Some rays along an axis or in a coordinate plane.
            match case % 7 {
                0 => {
                    d = DVec3::new(d.x, 0.0, 0.0)
                        .try_normalize()
                        .unwrap_or(DVec3::X)
                }
                1 => {
                    d = DVec3::new(d.x, d.y, 0.0)
                        .try_normalize()
                        .unwrap_or(DVec3::Y)
                }
                2 => {
                    d = DVec3::new(0.0, -0.0, d.z)
                        .try_normalize()
                        .unwrap_or(DVec3::Z)
                }
                _ => {}
            }
            // From inside the grid, or outside it.
            let inside = origin + size * DVec3::new(next(), next(), next());
            let o = if case % 3 == 0 {
                inside
            } else {
                inside - d * (size.length() * (0.5 + next()))
            };
            let t0 = next() * 0.3;
            let t1 = t0 + size.length() * (0.2 + 2.0 * next());
            let step = [0.5, 0.25, 0.125, 0.7, 2.0, 0.03][case % 6] * cell.x * (0.9 + 0.2 * next());
            let n = segment_count((t1 - t0) / step);
            let from = match case % 4 {
                0 => f64::NEG_INFINITY,
                1 => t0 + (t1 - t0) * next(),
                2 => t0 - 1.0,
                _ => t0 + (t1 - t0) * next() * 0.2,
            };
            let start = || {
                let mut c = cursor(t0, t1, step, n, 0, f64::NEG_INFINITY);
                c.o = o;
                c.d = d;
                if case % 11 != 10 {
                    c.start_walk(&grid, from.max(t0));
                }
                c
            };
            let have_grid = case % 13 != 12;
            let g = have_grid.then_some(&grid);
            // The march before: peek, then the run in the walk's block.
            let (mut want, mut got) = (Vec::new(), Vec::new());
            let mut c = start();
            let unbounded = c.walk.is_none() || !have_grid;
            while c.peek(g).is_some() {
                let (mut mids, mut lens) = ([0.0; 8], [0.0; 8]);
                let m = run(&c, unbounded, &mut mids, &mut lens);
                for j in 0..m {
                    want.push((mids[j].to_bits(), lens[j].to_bits()));
                }
                c.k += m as u64;
                runs[0] += 1;
            }
            let mut c = start();
            loop {
                let (mut mids, mut lens) = ([f64::NAN; 8], [f64::NAN; 8]);
                let m = c.next_run(g, &mut mids, &mut lens);
                if m == 0 {
                    break;
                }
                assert!(m <= 8 && c.k <= c.n);
                for j in 0..m {
                    got.push((mids[j].to_bits(), lens[j].to_bits()));
                }
                runs[1] += 1;
            }
            // (A segment's midpoint and length name it: midpoints increase.)
            assert_eq!(got, want, "case {case}");
            assert_eq!(c.k, c.n, "case {case}");
            taken += want.len();
        }
        // Joined runs are fewer; every kind of case came up.
        assert!(runs[1] < runs[0] && taken > 100_000, "{runs:?} {taken}");
    }

    /// `at_most` is `f64::min` wherever the bound is not NaN (a cursor's end never is): for
    /// NaN, infinite, tiny, equal and neighbouring values (bit for bit, except that of two
    /// equal zeros `f64::min` may return either).
    #[test]
    fn at_most_is_the_minimum_below_a_bound_that_is_not_nan() {
        let values = [
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.0,
            -0.0,
            1.0,
            1.0 + f64::EPSILON,
            1.0 - f64::EPSILON / 2.0,
            -1.0,
            1e300,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            5e-324,
            f64::MAX,
        ];
        for t1 in values.into_iter().filter(|t| !t.is_nan()) {
            for x in values {
                let (got, want) = (at_most(x, t1), x.min(t1));
                if x == 0.0 && t1 == 0.0 {
                    assert_eq!(got, want);
                } else {
                    assert_eq!(got.to_bits(), want.to_bits(), "{x} {t1}");
                }
            }
        }
    }

    /// The pass bits in lanes are the comparisons sample by sample, NaN included.
    /// Starting at a parameter passes over the segments before it and stops at the first
    /// whose midpoint is not before it (or at the end), from any start, for targets before,
    /// on, between and beyond the midpoints.
    #[test]
    fn starting_stops_at_the_first_midpoint_not_before() {
        let mut checked = 0;
        for (t0, t1, step) in [
            (0.25f64, 9.9, 0.5),
            (-3.0, 4.0, 0.1),
            (1e-3, 1.0, 1.0 / 3.0),
        ] {
            let n = ((t1 - t0) / step).ceil() as u64;
            for k in 0..n {
                let probe = cursor(t0, t1, step, n, k, f64::NEG_INFINITY);
                let mut targets: Vec<f64> = (0..n).map(|j| probe.mid(j)).collect();
                targets.extend(targets.clone().iter().map(|m| m + step * 0.5));
                targets.extend([t0 - 1.0, t0, t1, t1 + 1.0, 1e300, f64::INFINITY]);
                for t in targets {
                    let mut c = cursor(t0, t1, step, n, k, f64::NEG_INFINITY);
                    c.start_at(t);
                    let want = (k..n).find(|&j| c.mid(j) >= t).unwrap_or(n);
                    assert_eq!(c.k, want, "from {k} of {n} to {t}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 1000, "{checked}");
    }

    #[test]
    fn pass_bits_are_the_comparisons() {
        let lens = [0.5, 0.0, -1.0, f64::NAN, 1e-300, f64::INFINITY, 2.0, -0.0];
        let values = [
            0.0,
            0.3,
            f32::from_bits(0.3f32.to_bits() + 1),
            f32::NAN,
            1.0,
            -0.0,
            f32::from_bits(0.3f32.to_bits() - 1),
            f32::INFINITY,
        ];
        for z in [0.0, 0.3, -1.0, 1.0, f32::NAN] {
            for rot in 0..8 {
                let mut vs = values;
                vs.rotate_left(rot);
                let want = (0..8).fold(0u32, |bits, i| {
                    bits | u32::from(!(lens[i] <= 0.0 || vs[i] <= z)) << i
                });
                assert_eq!(pass_bits(&lens, &vs, z), want, "z {z} rotation {rot}");
            }
        }
    }
}
