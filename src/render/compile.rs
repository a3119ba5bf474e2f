//! Compiling a scene: a finished [`SceneDesc`] becomes the immutable [`Compiled`] scene that
//! every worker thread shares, and each object a [`CObj`] holding what tracing needs of it
//! (its matrices, box, step, opacity exponent, program prefixes, empty-space grid and cell
//! mask, toggles), with the object-level queries on it that do not shade: the ray's interval in
//! its box ([`CObj::clip`]) and its fields and opacity at a point. It also decides the scene's
//! [`Plan`], puts the world boxes of a scene of many objects in a [`BoxTree`] (which objects
//! a ray or a point may meet: [`Compiled::met_by_ray`], [`Compiled::holding`]), and it holds
//! what later compilations of a scene share ([`Caches`]: each root object's empty-space grid,
//! built by `accel` the first time a compilation needs it, and its pre-integration tables,
//! built by `preint`). It does not trace, shade or composite (`integrate`, `shade`).

use super::*;
use crate::render::inert::{refracts, shows_nothing, zero_field};
use crate::render::preint::PreIntegrated;

/// One object of a scene compiled for tracing: immutable, read by every ray that meets it.
pub(super) struct CObj {
    pub(super) program: Vec<Instr>,
    /// The program up to its last instruction that may write opacity: where that leaves o = 0
    /// the rest cannot change it, and is skipped.
    pub(super) o_prefix: usize,
    pub(super) to_object: DMat4,
    /// Its inverse, object → world (for [`EntryMap`]).
    pub(super) to_world: DMat4,
    pub(super) box_min: DVec3,
    pub(super) box_max: DVec3,
    pub(super) step: f64,
    pub(super) inv_ref: f64,
    pub(super) delta: DVec3,
    pub(super) visible: bool,
    pub(super) flip_normals: bool,
    pub(super) normals: Vec<NormalFn>,
    /// Where the geometry field is a dataset's value (its last writer is `vlDataset`), normals
    /// come from that dataset's interpolated grid gradients.
    pub(super) f_dataset: Option<(Arc<Dataset>, Filter, GradientFilter)>,
    /// The linear part of object → world for gradients: ∇_world F = Aᵀ ∇_object F, A the linear
    /// part of world → object.
    pub(super) grad_to_world: glam::DMat3,
    /// The program compiled for the lean kernel, where it reads only constants, datasets and
    /// transfer functions (and the kernel is not switched off).
    pub(super) lean: Option<Lean>,
    /// Where the lean program has direct shading and a value head, the object is rendered by
    /// DVR without normal functions and `Optimise::preintegrate` is on: its pre-integration
    /// table for slabs of its step (`preint`).
    pub(super) preint: Option<Arc<PreIntegrated>>,
    pub(super) env: SampleEnv,
    /// Blocks where opacity is provably 0.
    pub(super) skip: Option<Arc<SkipGrid>>,
    /// For a lean program with a value head rendered by the batched march, under empty-space
    /// skipping: the cells of its dataset whose samples can pass the zero test (see
    /// [`crate::data::CellMask`]).
    pub(super) cells: Option<Arc<crate::data::CellMask>>,
    /// The rendering algorithm the object captured.
    pub(super) render_type: RenderType,
    /// Iso-surfaces (field index, threshold) for DSR.
    pub(super) surfaces: Vec<(usize, f32)>,
    /// Per field: the program up to its last instruction that may write it.
    pub(super) prefixes: [usize; FIELD_COUNT],
    /// Per field: its value where that last instruction is a constant `vlSet` (the field is
    /// then that constant inside the boundary, folded once instead of run per evaluation).
    pub(super) constants: [Option<f32>; FIELD_COUNT],
    pub(super) cast_shadows: bool,
    pub(super) receive_shadows: bool,
    pub(super) cast_reflections: bool,
    pub(super) receive_reflections: bool,
    pub(super) refract: bool,
    pub(super) reflect_background: bool,
    pub(super) recursion: i32,
}

/// One axis of [`CObj::clip`]: the interval `(t0, t1)` narrowed to where the ray's coordinate
/// `o + t·d` lies in [min, max]; `None` where `d` is 0 and `o` is outside.
#[inline(always)]
pub(super) fn slab(
    (mut t0, mut t1): (f64, f64),
    o: f64,
    d: f64,
    min: f64,
    max: f64,
) -> Option<(f64, f64)> {
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
    pub(super) fn new(
        o: &ObjectDesc,
        datasets: &Arc<crate::model::program::Datasets>,
        optimise: crate::model::scene::Optimise,
        alone: bool,
        cache: &ObjectCache,
    ) -> CObj {
        let to_world = o.matrix();
        let b = crate::model::scene::v3(o.boundary);
        let box_min = DVec3::splat(0.5) - b * 0.5;
        let box_max = DVec3::splat(0.5) + b * 0.5;
        let diagonal = (0..3)
            .map(|i| (to_world.col(i).truncate().length() * b[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        let step = o.state.step_for(diagonal);
        let delta = match o.state.neighborhood {
            Some(d) => crate::model::scene::v3(d),
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
            Some(Instr::Dataset {
                data,
                filter,
                gradient,
                ..
            }) if !moved => Some((data.clone(), *filter, *gradient)),
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
        let inv_ref = 1.0 / o.state.reference as f64;
        let kappa = step * inv_ref;
        let preint = lean
            .as_ref()
            .filter(|l| l.value_head().is_some())
            .and_then(Lean::direct_shading)
            .filter(|_| {
                optimise.preintegrate
                    && alone
                    && r.render_type == RenderType::Dvr
                    && o.normals.is_empty()
                    && kappa.is_finite()
                    && kappa > 0.0
            })
            .map(|s| cache.preintegrated(kappa, || PreIntegrated::new(s, kappa)));
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
            // A mirror of ks 0 everywhere reflects nothing, and an index of 1 everywhere (RF 0)
            // bends nothing: neither asks for secondary rays.
            receive_reflections: r.toggle(Feature::ReceiveReflections)
                && !zero_field(&o.program, Fields::KS),
            refract: refracts(o),
            reflect_background: r.toggle(Feature::ReflectBackground),
            recursion: r.recursion,
            skip: match (&preint, lean.as_ref().and_then(Lean::value_head)) {
                // Pre-integrated: a block is empty only where its values are at most the
                // zero test's bound, which every sample the march passes over must be.
                (Some(_), Some((_, z))) => crate::pool::once(&cache.value_grid, || {
                    SkipGrid::build(&o.program[..o_prefix], box_min, box_max, Some(z)).map(Arc::new)
                }),
                _ => crate::pool::once(&cache.grid, || {
                    SkipGrid::build(&o.program[..o_prefix], box_min, box_max, None).map(Arc::new)
                }),
            }
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
                .map(|(data, z)| crate::pool::once(&cache.cells, || data.cells_above(z)).clone()),
            lean,
            preint,
            env: SampleEnv {
                datasets: datasets.clone(),
                filter: Filter::of_settings(r.interpolation, r.cubic),
                children: Arc::new(compile_children(o, to_object, datasets)),
            },
            program: o.program.clone(),
            to_object,
            to_world,
            box_min,
            box_max,
            step,
            inv_ref,
            delta,
            visible: o.state.toggle(Feature::Visible),
            flip_normals: o.state.toggle(Feature::FlipNormals),
            normals: o.normals.clone(),
        }
    }

    /// The longest chord of the object's box in world space, which bounds every ray through
    /// it: the longest of the parallelepiped's four body diagonals (+∞ where one is NaN).
    pub(super) fn world_diagonal(&self) -> f64 {
        let corner = |k: usize| self.world_corner(k);
        (0..4)
            .map(|k| corner(k).distance(corner(7 - k)))
            .fold(
                0.0f64,
                |a, b| if b.is_nan() { f64::INFINITY } else { a.max(b) },
            )
    }

    /// Corner `k` (0 … 7) of the object's box in world space: bit 0 of `k` picks the box's
    /// low or high x, bit 1 y, bit 2 z (so corners k and 7 − k are opposite).
    fn world_corner(&self, k: usize) -> DVec3 {
        let pick = |bit: usize, lo: f64, hi: f64| if k >> bit & 1 == 0 { lo } else { hi };
        let (lo, hi) = (self.box_min, self.box_max);
        self.to_world.transform_point3(DVec3::new(
            pick(0, lo.x, hi.x),
            pick(1, lo.y, hi.y),
            pick(2, lo.z, hi.z),
        ))
    }

    /// The world ray `origin + t·dir` in the object's coordinates, `o + t·d` (the same t).
    #[inline]
    pub(super) fn object_ray(&self, origin: DVec3, dir: DVec3) -> (DVec3, DVec3) {
        (
            self.to_object.transform_point3(origin),
            self.to_object.transform_vector3(dir),
        )
    }

    /// Whether a ray of this kind sees the object (mirror rays: `cast_reflections`).
    #[inline]
    pub(super) fn seen_by(&self, ray: Ray) -> bool {
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
    /// Always inlined: a call left to the compiler's choice is kept out of line in
    /// [`Compiled::trace_ray`], passing the ray and the interval through memory.
    #[inline(always)]
    pub(super) fn clip(&self, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
        let (min, max) = (self.box_min, self.box_max);
        // Axis by axis, written out: as a loop the compiler keeps the loop and picks each
        // axis's values by index.
        let t = slab((0.0, f64::INFINITY), o.x, d.x, min.x, max.x)?;
        let t = slab(t, o.y, d.y, min.y, max.y)?;
        let (t0, t1) = slab(t, o.z, d.z, min.z, max.z)?;
        (t0 < t1 && t1.is_finite()).then_some((t0, t1))
    }

    pub(super) fn inside(&self, p: DVec3) -> bool {
        p.cmpge(self.box_min).all() && p.cmple(self.box_max).all()
    }

    /// The opacity at world point `w` (inside the boundary), by the lean kernel where it applies.
    #[inline]
    pub(super) fn opacity_at(&self, w: DVec3) -> f64 {
        if let Some(lean) = &self.lean {
            let p = self.to_object.transform_point3(w).as_vec3().to_array();
            let mut f = [0.0f32; FIELD_COUNT];
            return lean.opacity(p, &mut f) as f64;
        }
        let mut s = self.sample_at(w);
        run(&self.program[..self.o_prefix], &mut s);
        s.value(0) as f64
    }

    pub(super) fn sample_at(&self, w: DVec3) -> Sample<'_> {
        let p = self.to_object.transform_point3(w);
        Sample::with_env(p.as_vec3().to_array(), w.to_array(), &self.env)
    }

    /// Field `field` at world point `w` (0 outside the boundary: fields are bounded), running
    /// only the part of the program that can change it.
    pub(super) fn field_at(&self, w: DVec3, field: usize) -> f64 {
        self.field_read(w, field, false)
    }

    /// [`CObj::field_at`] for a normal's central differences: each dataset read through the
    /// BC-spline of its gradient filter where that is [`GradientFilter::Cubic`], so that the
    /// differences are those of the spline whose gradient that filter takes, also where a
    /// spatial function moved the point and the dataset's own gradient does not apply.
    pub(super) fn field_for_gradient(&self, w: DVec3, field: usize) -> f64 {
        self.field_read(w, field, true)
    }

    fn field_read(&self, w: DVec3, field: usize, for_gradient: bool) -> f64 {
        let p = self.to_object.transform_point3(w);
        if !self.inside(p) {
            return 0.0;
        }
        if let Some(v) = self.constants[field] {
            return v as f64;
        }
        let mut s = Sample::with_env(p.as_vec3().to_array(), w.to_array(), &self.env);
        s.for_gradient = for_gradient;
        run(&self.program[..self.prefixes[field]], &mut s);
        s.value(field) as f64
    }
}

/// The children of `o` as its functions see them; `world_to_o` maps the world to `o`'s space.
fn compile_children(
    o: &ObjectDesc,
    world_to_o: DMat4,
    datasets: &Arc<crate::model::program::Datasets>,
) -> Vec<crate::model::program::Child> {
    o.children
        .iter()
        .map(|c| {
            let to_child = c.matrix().inverse();
            let world_to_child = to_child * world_to_o;
            let b = crate::model::scene::v3(c.boundary);
            let r = &c.state;
            crate::model::program::Child {
                program: c.program.clone(),
                to_child,
                world_to_child,
                box_min: DVec3::splat(0.5) - b * 0.5,
                box_max: DVec3::splat(0.5) + b * 0.5,
                env: SampleEnv {
                    datasets: datasets.clone(),
                    filter: Filter::of_settings(r.interpolation, r.cubic),
                    children: Arc::new(compile_children(c, world_to_child, datasets)),
                },
            }
        })
        .collect()
}

/// What later compilations of a scene share of one root object: its empty-space grid, built
/// once (`None`: the object has no grid), its dataset's cell mask for its zero test's bound
/// (which the dataset keeps only while it is in use), and its pre-integration tables with
/// the κ (slab length in reference lengths, as bits) they were built for. A closed root object
/// does not change, so its tables depend on κ alone: they are rebuilt only where κ changes.
#[derive(Default)]
pub(super) struct ObjectCache {
    grid: std::sync::OnceLock<Option<Arc<SkipGrid>>>,
    /// The grid by the values' bound, for the object pre-integrated (`SkipGrid::build`).
    value_grid: std::sync::OnceLock<Option<Arc<SkipGrid>>>,
    /// The cell mask of the object's value head (`Dataset::cells_above`).
    cells: std::sync::OnceLock<Arc<crate::data::CellMask>>,
    preint: std::sync::Mutex<Option<(u64, Arc<PreIntegrated>)>>,
}

impl ObjectCache {
    /// The tables for slabs `kappa` reference lengths long: those kept where they were built for
    /// `kappa`, else `build`'s, kept in their place. (Built outside the lock, which a
    /// compilation on another thread may want meanwhile: two may then build the same tables,
    /// and either is kept.)
    fn preintegrated(
        &self,
        kappa: f64,
        build: impl FnOnce() -> PreIntegrated,
    ) -> Arc<PreIntegrated> {
        let slot = || self.preint.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((k, t)) = &*slot() {
            if *k == kappa.to_bits() {
                return t.clone();
            }
        }
        let tables = Arc::new(build());
        *slot() = Some((kappa.to_bits(), tables.clone()));
        tables
    }
}

/// The [`ObjectCache`]s of a scene's root objects, by their index in the scene, each filled by
/// the first compilation that needs it and shared by later ones, and the pixel buffers its
/// renders give back for the next ([`Recycled`]). The state machine keeps one for each open
/// scene (a closed root object does not change, and objects are only appended), so scene data
/// holds no cache; a fresh `Caches` builds everything anew.
#[derive(Default)]
pub(crate) struct Caches {
    objects: std::sync::Mutex<Vec<Arc<ObjectCache>>>,
    pixels: Arc<Recycled>,
}

impl Caches {
    /// The cache of root object `i`.
    fn cell(&self, i: usize) -> Arc<ObjectCache> {
        let mut cells = self.objects.lock().unwrap_or_else(|e| e.into_inner());
        if cells.len() <= i {
            cells.resize_with(i + 1, Default::default);
        }
        cells[i].clone()
    }
}

/// A cache is not part of the state a refused call must leave unchanged (`Library::fingerprint`
/// prints the state with `Debug`), so it prints nothing of its contents.
impl std::fmt::Debug for Caches {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Caches")
    }
}

/// What a scene calls for: effects its objects, toggles and lights can actually show. An
/// effect that nothing in the scene can exhibit costs nothing (see `docs/dev/render-plan.md`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Plan {
    /// Shadow rays: some object casts, some object receives, and a light of some radiance
    /// exists.
    pub shadows: bool,
    /// Mirror rays: some object receives reflections (with recursion above 0) and its ks is not
    /// 0 everywhere.
    pub reflections: bool,
    /// Refracted rays: some object refracts (with recursion above 0) and its RF is not 0
    /// everywhere (an index of 1).
    pub refraction: bool,
}

/// A scene compiled for tracing: immutable, shared by all worker threads.
pub struct Compiled {
    /// The objects rays may see something of, in the scene's order.
    pub(super) objects: Vec<CObj>,
    /// Each of those objects' number in the scene.
    shown_index: Vec<usize>,
    /// The objects no ray sees anything of (see `shows_nothing`), with their numbers: only
    /// voxelization reads them.
    hidden: Vec<(usize, CObj)>,
    /// The lights, each with its radiance in f64.
    pub(super) lights: Vec<(Light, DVec3)>,
    /// The ambient light's radiance in f64.
    pub(super) ambient: DVec3,
    /// Where every light is directional: each light's direction towards it and radiance (see
    /// [`Headlit`]).
    pub(super) directional: Option<Vec<(DVec3, DVec3)>>,
    /// Per object, the lighting lanes of its direct shading (`DirectShading`) where every
    /// light is directional and there is one ([`HeadlitLanes`]): what [`Headlit::new`] and
    /// [`HeadlitLanes::new`] would give every ray, but for its view, prepared once.
    pub(super) lanes: Vec<Option<HeadlitLanes>>,
    pub(super) settings: Settings,
    pub(super) plan: Plan,
    /// The pixel buffers of the scene's renders, kept between frames (the caches').
    pub(super) recycled: Arc<Recycled>,
    /// Under empty-space skipping, for a scene of more than [`SCANNED_OBJECTS`] objects: their
    /// world boxes in a tree, which finds the objects a ray or a point may meet
    /// ([`Compiled::met_by_ray`], [`Compiled::holding`]).
    pub(super) tree: Option<BoxTree>,
}

/// Up to this many objects, a ray or a point is tested against every one; beyond, the scene's
/// [`BoxTree`] finds those it may meet.
pub(super) const SCANNED_OBJECTS: usize = 8;

/// A box tree's boxes are the objects' world boxes widened by this fraction of their largest
/// coordinate and extent, and a ray's query by this fraction of its origin's largest
/// coordinate: more than rounding moves the clip in an object's space by. That clip reads the
/// ray through `to_object`, an inverse computed with a relative error of about the
/// transform's condition number κ times ε, which the object's own matrix then magnifies by
/// up to κ again: in world units about κ²·ε times the sizes of the origin and the point. For
/// κ at most [`TREE_CONDITION`] that is 2·10⁻⁸ of them, 450 times less than this slack, so
/// the tree leaves out no object whose clip would find the ray.
const TREE_SLACK: f64 = 1e-5;

/// An object whose transform's condition number (the Frobenius norms of its linear part and
/// its inverse's, multiplied: at least the 2-norm one) is above this, or not finite, is
/// tested by every ray (a needle 7·10⁵ long, κ near 10⁶, 10⁸ from the origin: rounding
/// moves its clip's answer by up to 10⁴ world units along it, `tests/many_objects.rs`).
const TREE_CONDITION: f64 = 1e4;

/// The objects a ray or a point may meet: every one, or those a [`BoxTree`] found, in
/// increasing order.
pub(super) enum Met {
    All(std::ops::Range<usize>),
    Found(std::vec::IntoIter<usize>),
}

impl Iterator for Met {
    type Item = usize;
    #[inline]
    fn next(&mut self) -> Option<usize> {
        match self {
            Met::All(r) => r.next(),
            Met::Found(f) => f.next(),
        }
    }
}

/// `obj`'s box in world space (the box of its eight corners) widened by [`TREE_SLACK`], or
/// `None` where that is not finite or its transform's condition is above [`TREE_CONDITION`].
fn world_box(obj: &CObj) -> Option<(DVec3, DVec3)> {
    let (mut min, mut max) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for k in 0..8 {
        let c = obj.world_corner(k);
        min = min.min(c);
        max = max.max(c);
    }
    let norm = |m: glam::DMat3| {
        (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared()).sqrt()
    };
    let condition =
        norm(glam::DMat3::from_mat4(obj.to_world)) * norm(glam::DMat3::from_mat4(obj.to_object));
    let size = min.abs().max(max.abs()).max_element() + (max - min).max_element();
    let pad = TREE_SLACK * size;
    (min.is_finite() && max.is_finite() && pad.is_finite() && condition <= TREE_CONDITION)
        .then(|| (min - pad, max + pad))
}

impl Compiled {
    /// [`Compiled::new`], with an error where the compilation cannot complete: `NoMemory` for
    /// a dataset cache or an empty-space grid that cannot be allocated, `Internal` for a panic
    /// (in a field function a grid evaluates, say).
    pub fn build(desc: &SceneDesc, caches: &Caches) -> Result<Compiled> {
        crate::error::catch("compiling the scene", || Ok(Compiled::new(desc, caches)))
    }

    /// Compiles a scene description; its root objects' empty-space grids and pre-integration
    /// tables come from `caches`
    /// (built there by the first compilation that needs them). Unwinds where a cache cannot be
    /// allocated ([`Compiled::build`] returns that as an error).
    pub fn new(desc: &SceneDesc, caches: &Caches) -> Compiled {
        // The objects rays meet, and those no ray can see anything of (voxelization's alone).
        let shown: Vec<bool> = desc.objects.iter().map(|o| !shows_nothing(o)).collect();
        // Pre-integration is for an object rendered alone: with others, a ray that meets
        // several is composited by midpoint samples, which would leave seams.
        let alone = shown.iter().filter(|&&s| s).count() == 1;
        let (mut objects, mut shown_index, mut hidden) = (Vec::new(), Vec::new(), Vec::new());
        for (i, o) in desc.objects.iter().enumerate() {
            let alone = alone && shown[i];
            let obj = CObj::new(
                o,
                &desc.datasets,
                desc.settings.optimise,
                alone,
                &caches.cell(i),
            );
            if shown[i] {
                objects.push(obj);
                shown_index.push(i);
            } else {
                hidden.push((i, obj));
            }
        }
        // A light of no radiance (colour or intensity 0) adds nothing anywhere: the scene is
        // compiled without it, so it costs nothing (no shadow rays, and the paths of one light
        // or none stay open).
        let lights: Vec<(Light, DVec3)> = desc
            .lights
            .iter()
            .map(|&light| {
                let (Light::Point { radiance, .. } | Light::Directional { radiance, .. }) = light;
                (light, crate::model::scene::v3(radiance))
            })
            .filter(|&(_, radiance)| radiance != DVec3::ZERO)
            .collect();
        let plan = Plan {
            shadows: !lights.is_empty()
                && objects.iter().any(|o| o.cast_shadows)
                && objects.iter().any(|o| o.receive_shadows),
            reflections: objects
                .iter()
                .any(|o| o.receive_reflections && o.recursion > 0),
            refraction: objects.iter().any(|o| o.refract && o.recursion > 0),
        };
        let directional = lights
            .iter()
            .map(|&(light, radiance)| match light {
                Light::Directional { to_light, .. } => Some((to_light, radiance)),
                Light::Point { .. } => None,
            })
            .collect();
        let mut scene = Compiled {
            objects,
            shown_index,
            hidden,
            lights,
            directional,
            lanes: Vec::new(),
            ambient: crate::model::scene::v3(desc.settings.ambient),
            settings: desc.settings.clone(),
            plan,
            recycled: caches.pixels.clone(),
            tree: None,
        };
        if desc.settings.optimise.skip_empty && scene.objects.len() > SCANNED_OBJECTS {
            let boxes: Vec<_> = scene.objects.iter().map(world_box).collect();
            scene.tree = Some(crate::data::or_unwind(BoxTree::build(&boxes)));
        }
        scene.lanes = scene
            .objects
            .iter()
            .map(|o| scene.headlit_lanes(o))
            .collect();
        scene
    }

    /// Whether the scene's rays stay within the work bound: a ray takes at most
    /// [`MAX_SAMPLES_PER_RAY`] samples through each object (its world diagonal over its step),
    /// else the render is refused with `VL_BADVALUE` before any pixel (`vlStepSize(1e-9, 1)`
    /// through a 100-unit object would take 10¹¹ a ray). With it, a render's work grows at
    /// most linearly with its pixels, super-sampling, lights and recursion, and with the
    /// square of a ray's samples where shadow rays leave each sample; every ray can be
    /// cancelled within [`PROBE_EVERY`] samples (`Cursor::stopping`).
    pub(crate) fn check_work(&self) -> Result<()> {
        for (i, obj) in self.every_object() {
            let diagonal = obj.world_diagonal();
            let samples = diagonal / obj.step;
            if samples.is_nan() || samples > MAX_SAMPLES_PER_RAY {
                return Err(Error::new(
                    ErrorCode::BadValue,
                    format!(
                        "object {i}: a ray through it would take up to {samples:.3e} samples \
                         (world diagonal {diagonal:.3e} over step {:.3e}); at most \
                         {MAX_SAMPLES_PER_RAY} (a coarser vlStepSize, or a smaller object)",
                        obj.step
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The objects whose boxes the world ray `origin + t·dir` may meet at 0 ≤ t ≤ `reach`
    /// (infinite, or a shadow ray's distance to its light along a unit `dir`), in increasing
    /// order: every one, or, with a tree, a superset of those whose [`CObj::clip`] finds it
    /// entering before `reach`. (The clip's entry, like its point, moves by less than the
    /// slack: the reach is widened by the same fraction of it and the origin.)
    #[inline]
    pub(super) fn met_by_ray(&self, origin: DVec3, dir: DVec3, reach: f64) -> Met {
        match &self.tree {
            None => Met::All(0..self.objects.len()),
            Some(tree) => {
                let mut found = Vec::new();
                let size = origin.abs().max_element();
                let slack = TREE_SLACK * size;
                let reach = reach + TREE_SLACK * (size + reach);
                tree.ray(origin, dir, slack, reach, &mut found);
                Met::Found(found.into_iter())
            }
        }
    }

    /// The objects whose boxes may hold world point `w`, in increasing order: every one, or,
    /// with a tree, a superset of those whose [`CObj::inside`] holds it.
    pub(super) fn holding(&self, w: DVec3) -> Met {
        match &self.tree {
            None => Met::All(0..self.objects.len()),
            Some(tree) => {
                let mut found = Vec::new();
                tree.point(w, 0.0, &mut found);
                Met::Found(found.into_iter())
            }
        }
    }

    /// Every object of the scene with its number, in the scene's order.
    fn every_object(&self) -> impl Iterator<Item = (usize, &CObj)> {
        self.with_hidden(0..self.objects.len())
    }

    /// The objects `shown` (indices into [`Compiled::objects`], increasing) and the hidden
    /// ones, each with its number in the scene, in the scene's order.
    fn with_hidden(
        &self,
        shown: impl Iterator<Item = usize>,
    ) -> impl Iterator<Item = (usize, &CObj)> {
        let mut all: Vec<(usize, &CObj)> = shown
            .map(|i| (self.shown_index[i], &self.objects[i]))
            .chain(self.hidden.iter().map(|(i, o)| (*i, o)))
            .collect();
        all.sort_unstable_by_key(|&(i, _)| i);
        all.into_iter()
    }

    /// The render plan: which effects this scene calls for.
    pub fn plan(&self) -> Plan {
        self.plan
    }

    /// All fields of the scene at world point `w`: those of the root object containing it with
    /// the largest opacity (the first on ties), or all 0 (voxelization samples the scene with it).
    pub fn fields_at(&self, w: DVec3) -> [f32; crate::types::FIELD_COUNT] {
        let mut best: Option<[f32; crate::types::FIELD_COUNT]> = None;
        let mut consider = |obj: &CObj| {
            let p = obj.to_object.transform_point3(w);
            if !obj.inside(p) {
                return;
            }
            let mut s = Sample::with_env(p.as_vec3().to_array(), w.to_array(), &obj.env);
            run(&obj.program, &mut s);
            let f = s.values();
            if best.is_none_or(|b| f[0] > b[0]) {
                best = Some(f);
            }
        };
        if self.hidden.is_empty() {
            self.holding(w).for_each(|i| consider(&self.objects[i]));
        } else {
            // (The hidden objects among the others, in the scene's order: the first wins ties.)
            self.with_hidden(self.holding(w))
                .for_each(|(_, o)| consider(o));
        }
        best.unwrap_or([0.0; crate::types::FIELD_COUNT])
    }
}
