//! The packet march: primary rays of a scanned volume traced several at a time, one ray per
//! SIMD lane: eight in AVX2 registers, or sixteen in AVX-512 registers where the processor has
//! them and the scene fits (the same image bit for bit). x86-64 only, the instruction set
//! detected at run time. `docs/dev/simd.md` describes the design for maintainers.
//!
//! Where it applies (see [`Packets::new`]): one visible DVR volume whose lean program is the
//! direct-shading form (a dataset read trilinearly, an opacity table, a colour table writing
//! r, g and b, constant coefficients) with no normal functions, lit as [`HeadlitLanes`] lights
//! it (one directional light, an integer specular exponent, no shadows) or not lit at all
//! (kd and ks 0: the unshaded scene), at most 2¹⁴ samples a ray ([`MAX_PACKET_SAMPLES`]); with
//! super-sampling both passes (the refined pixels' rays as pixels of the finer image,
//! `render::FineRays`). Everything else is traced by the scalar march, unchanged. Sixteen
//! lanes also need tables of at most seven rows ([`Segments`]; any tables for a
//! pre-integrated object) and the AVX-512 features of
//! [`detected`]; they read 8-bit voxels as voxels ([`Raw8`]), and node values and 16-bit
//! voxels by the eight lanes' reads on each half of their registers. On by
//! default where it applies (`Optimise::packets` switches it off, `Optimise::wide_lanes` the
//! sixteen lanes); `docs/performance.md` measures what it is worth. A pre-integrated volume
//! (`Optimise::preintegrate`, whatever its lighting) takes the same lanes for its samples and
//! their values and composites its slabs by the scalar code ([`preint`],
//! [`Packets::tile_pre`]).
//!
//! Each lane has its own ray, [`Cursor`] and state (transmittance, colour). The cursors are the
//! scalar march's (the same segments, midpoints and lengths, the same start at the [`EntryMap`]
//! bound; a tile's rays started four at a time in lanes, [`Packets::make_starts`]), but a lane
//! takes only the samples that can count: each run of sixteen segments ([`segments_from`]) is
//! tested against the cell mask together ([`Packets::to_take`]), and a sample in a cell that
//! cannot reach the zero test's bound (it would add nothing) takes no lane. The mask decides which
//! samples are taken, so that is exact wherever the walk is; the block walk is asked only after a
//! run of which nothing is taken, past the occupied blocks it last reported, and leaps over empty
//! blocks ([`Packets::next_taken`]): the scalar march asks it about every run. The samples taken
//! are the scalar march's samples that the mask passes, and those are all its samples that can
//! count; but after a run the mask passed whole, the next two are taken untested
//! ([`TRUSTED_RUNS`]: a sample it would have dropped fails the zero test, so the image is the same
//! bit for bit, and inside visible matter most runs pass). Every iteration takes each lane's next
//! sample to take and evaluates a packet's lanes together ([`Packets::step`]): the object points
//! and cells, the eight nodes (per-lane 8-byte loads and a transposition, [`Nodes::pairs2`]; for
//! 8-bit voxels whose normalisation never clamps, the voxels themselves, four to a lane by one
//! gather a row of the cell, [`Raw8`]), the trilinear value (the scalar code's f32 lerps, unfused,
//! so the same bits and the same zero test from node values; from voxels, normalised once),
//! opacity and colour (the two tables as at most eight linear pieces in registers, [`Segments`];
//! tables of more rows by their segment pairs, gathered), the opacity correction, the gradient
//! (the trilinear interpolation of the nodes' central differences, its nodes again by per-lane
//! loads or by eight more gathers of voxels, only where a lane's sample has opacity), the
//! headlight's Phong lighting and the front-to-back composite. A lane whose ray ends (it leaves
//! the volume or its transmittance falls below the termination bound) takes the tile's next ray.
//!
//! A tile's step carries two packets ([`PACKETS8`] of eight lanes, [`P`] of sixteen) through the
//! driver both widths share ([`Packets::march_tile`]): a sample's work is one long chain of
//! dependent operations (segment, point, cell, gathers, lerps, table, opacity correction,
//! transmittance), and the branch on which lanes ended waits for its end, so one packet's step
//! leaves the processor waiting; two independent chains in one step overlap. Each ray is its own
//! cursor and arithmetic, so which lane or packet carries it changes nothing in its pixel.
//!
//! **One form, two widths.** The march is written once, generic over the lane width: [`Simd`]
//! ([`lanes`]) is a token that exists only where the processor has an instruction set, whose
//! always-inlined methods are the operations the march is written in; [`Avx2`] implements it in
//! eight lanes, [`Avx512`] in sixteen. The generic code (the runs, the step, the reads of voxels,
//! the tables, the lighting) is `#[inline(always)]` and compiles inside each width's
//! `#[target_feature]` entry points ([`Packets::step8`] and [`Packets::step16`],
//! [`Packets::next_taken8`] and [`Packets::next_taken16`], [`Packets::tile`]'s two tile
//! functions), so each width gets its own instructions and no call is left: comparisons are
//! vector masks in eight lanes and mask registers in sixteen, each width's [`Simd::M`]. The
//! generic form is free (`benches/callgrind.sh` counts the eight-lane frame's instructions). What
//! stays per width, and why:
//!
//! - the two implementations of [`Simd`]: each operation's intrinsics in the width (the same
//!   shape by design);
//! - [`next_segments`] and [`next_segments16`]: each lane's lowest bit's index comes from the
//!   exponent of that power of two as f32 in AVX2, which has no per-lane leading-zero count, and
//!   from `vplzcntd` in AVX-512 (CD); and the gathers of midpoints and lengths take index
//!   registers of half the width, which the two sets split differently;
//! - the entry points: a few lines each that make the width's token under its
//!   `#[target_feature]` attribute, which a generic function cannot carry (every instantiation
//!   would get the attribute's features, not its width's);
//! - eight lanes' code, which sixteen lanes run on each half of their registers: node values
//!   by per-lane loads ([`Nodes`]; for 16-bit voxels, the voxels through the dataset's table
//!   of their node values, [`NodeValues`], the same f32 without the node values' memory);
//! - eight lanes only: tables of more than seven rows by their segment pairs
//!   ([`Packets::pairs_eval`]), a [`Simd`] hook the sixteen-lane implementation never
//!   reaches, as [`Packets::new`] gives sixteen lanes only to tables in registers (or to a
//!   pre-integrated object, whose tables the lanes do not read); and the ray starts
//!   ([`starts`]), four rays in f64 lanes for both widths.
//!
//! **Arithmetic.** From node values, the trilinear value and the gradient's sums are the scalar
//! code's f32 operations in the same order, without fused multiply-adds, so the same bits; from
//! 8-bit voxels the same operations on the voxels (the differences exact integers), then one
//! normalisation, which rounds differently from the node values' own (a relative 10⁻⁷). The tables,
//! the lighting and the composite are in f32 (the scalar march has f64 there) and use fused
//! multiply-adds where they save instructions: images differ from the scalar march's in the
//! last bits of a colour, far below an 8-bit level (`packets_are_the_scalar_march`). The two
//! widths do the same operations lane for lane, so their images are the same bit for bit.
//! Rare cases go lane by lane through the scalar code: a value whose table bucket has no
//! segment pair (`DirectShading::opacity_colour_general`), a gradient in a cell whose 4³
//! neighbourhood is not inside the grid (`Dataset::gradient_cached`). A segment whose
//! opacity-correction exponent is not the step's common one takes its power in f64 lanes,
//! which give `transmit_at_most_one`'s f32 bit for bit ([`power`](mod@power)).
//!
//! **Safety.** The lanes' `unsafe` code is here and in the entry map's rasterisation
//! (`crate::accel`; the rest of the crate's: `docs/dev/simd.md`): the gathers, the per-lane
//! loads of nodes, the loads and stores of fixed-size arrays, the calls of `#[target_feature]`
//! functions and the tokens' constructors. A [`Packets`]
//! exists only after `is_x86_feature_detected!` found AVX2 and FMA, its `wide` flag is set only
//! after [`detected`] found every AVX-512 feature, and a token is made only inside a function
//! with its features, so every intrinsic runs where the processor has it. Every node index is
//! clamped so that it and the whole span read from it lie inside the values ([`Nodes`]), every
//! table index into its table ([`gather`]), every mask-word and voxel index into its slice; the
//! gathers that do not clamp themselves ([`Simd::gather_bytes`], [`Simd::gather_words`]) are
//! `unsafe fn`s whose callers clamp, each call's `SAFETY` comment saying how. Every lane then
//! reads inside the slice whatever the ray.
//!
//! Here: the march's preparation ([`Packets::new`]), the tile functions of both widths and the
//! tile driver they share ([`Packets::march_tile`]), the lanes' state. Elsewhere: [`lanes`] (the
//! tokens, their operations, loads and stores), [`starts`] (rays started four at a time),
//! [`runs`] (which samples the lanes take), [`step`] (one sample a lane), [`preint`] (the
//! pre-integrated lanes), [`slabs`] (the pre-integrated slabs' values in lanes), [`nodes`]
//! (node values and voxels), [`tables`] (opacity and colour), [`shade`] (gradient, lighting,
//! opacity correction), [`power`](mod@power) (the opacity correction's other powers); the unit
//! tests in `tests.rs`.

use super::*;
use crate::data::{Filter, GradientFilter, Voxels, FACE_TOLERANCE};
use crate::model::mapping::Mapping;
use crate::render::kernel::DirectShading;
use crate::types::MappingType;
use std::arch::x86_64::*;

mod lanes;
mod nodes;
mod power;
mod preint;
mod runs;
mod shade;
mod slabs;
mod starts;
pub(super) mod step;
mod tables;
#[cfg(test)]
mod tests;

use lanes::*;
use nodes::*;
use power::*;
use runs::*;
use shade::*;
use starts::*;
use tables::*;

#[cfg(test)]
pub(super) use runs::{segments16, segments_lanes};
#[cfg(test)]
pub(super) use starts::{clip_lanes, count_lanes, first_segments, ray_lanes, st4d};

/// Lanes of a packet.
const W: usize = 8;

/// Packets of eight lanes a tile's step carries ([`Packets::march_tile`]).
const PACKETS8: usize = 2;

/// Lanes of a sixteen-lane packet.
const V: usize = 16;

/// Packets of [`V`] lanes a tile's step carries ([`Packets::march_tile`]; at most four).
const P: usize = 2;

/// Whether the processor has the AVX-512 features the sixteen-lane march uses ([`Avx512`];
/// with AVX2 and FMA, which [`Packets::new`] checks first).
pub(in crate::render) fn detected() -> bool {
    is_x86_feature_detected!("avx512f")
        && is_x86_feature_detected!("avx512dq")
        && is_x86_feature_detected!("avx512bw")
        && is_x86_feature_detected!("avx512vl")
        && is_x86_feature_detected!("avx512cd")
}

/// The lighting of [`Packets`]: unlit (kd and ks 0: the ambient term alone) or a headlight
/// as [`HeadlitLanes`] holds it, in f32. For a pre-integrated object, `Lit` lights its slabs'
/// pieces in lanes ([`Packets::tile_pre`]); `Unlit` is not read there, the scalar code lighting
/// them.
enum Light32 {
    Unlit {
        ka_ambient: [f32; 3],
    },
    Lit {
        ka_ambient: [f32; 3],
        kd: f32,
        ks: Option<f32>,
        e: u32,
        to_light: [f32; 3],
        radiance: [f32; 3],
        flip: bool,
        /// Object-space gradients to world space: the matrix's columns (by column and row).
        to_world: [[f32; 3]; 3],
        diagonal: bool,
    },
}

/// The packet march of a scene, prepared once per image where it applies.
pub(super) struct Packets<'a> {
    obj: &'a CObj,
    data: &'a Dataset,
    tables: &'a DirectShading,
    /// The object's skip grid where empty-space skipping is on.
    grid: Option<&'a SkipGrid>,
    /// The node values, or 16-bit voxels and their table (empty where `raw8` is read).
    values: NodeValues<'a>,
    /// The dataset's 8-bit voxels, read instead of `values` where its normalisation is
    /// linear over every byte ([`Raw8::of`]).
    raw8: Option<Raw8<'a>>,
    /// The dataset's 16-bit voxels, whose gradients' differences (and, where the lanes'
    /// normalisation gives the node values' bits, cell nodes) are read from them where its
    /// normalisation clamps none of them ([`Raw16::of`]).
    raw16: Option<Raw16<'a>>,
    /// The cell mask's bits as 32-bit words (empty: no mask).
    mask: &'a [u32],
    /// The runs taken untested after one the mask passed whole ([`TRUSTED_RUNS`], or 0 where
    /// `Optimise::trust_whole_runs` is off).
    trusted_runs: u32,
    z: f32,
    /// The two tables as segments in registers, where each has at most seven rows.
    segments: Option<Segments>,
    /// Per table bucket, its segment pair's number or −1.
    bucket_pair: Vec<i32>,
    /// Per pair, by number: [start (o), start (colour), base (o, r, g, b), slope (o, r, g, b)].
    pairs: [Vec<f32>; 10],
    light: Light32,
    inv_ref: f64,
    /// The exponent of a whole step (step / reference) where it is one the vector path
    /// handles (0.5, 1, 0.25, 2, 0.125, 4), else NaN (every sample then takes the scalar
    /// correction).
    common: f64,
    stop: f32,
    /// Whether the object's box reaches outside the dataset's cube [0, 1]³ (by more than
    /// `FACE_TOLERANCE`), so that a sample must be tested for it ([`Packets::step`]).
    clip: bool,
    /// n − 1, max(n − 2, 0) and n − 2 per axis, as f32; the strides; 0.5·(n − 1) as f32.
    last: [f32; 3],
    top: [f32; 3],
    inner: [f32; 3],
    sy: i32,
    sz: i32,
    half_last: [f32; 3],
    /// Sixteen lanes a step ([`Avx512`]): the processor has AVX-512 and the scene fits it.
    wide: bool,
    /// The slabs of a pre-integrated object ([`Packets::tile_pre`] traces its tiles).
    pre: Option<PreMarch<'a>>,
    /// In the unit tests, the packets a step carries in either width where not 0 (1, 2 or
    /// 4; else [`PACKETS8`] and [`P`]): `packets_carry_rays_without_changing_them` sets it.
    #[cfg(test)]
    packets: usize,
    /// In the unit tests, the runs this march took on trust ([`TRUSTED_RUNS`]; in eight lanes,
    /// each of a run's halves): `runs_on_trust_change_nothing` reads it.
    #[cfg(test)]
    untested: std::sync::atomic::AtomicU64,
}

/// The most samples a ray of the packet march may take through its object (see [`Packets::new`]).
const MAX_PACKET_SAMPLES: f64 = (1u32 << 14) as f64;

impl<'a> Packets<'a> {
    /// The packet march of `scene`, where it applies and the processor has AVX2 and FMA;
    /// `None` otherwise (the scalar march then traces every ray).
    pub(super) fn new(scene: &'a Compiled) -> Option<Packets<'a>> {
        if !scene.settings.optimise.packets {
            return None;
        }
        if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
            return None;
        }
        let [obj] = scene.objects.as_slice() else {
            return None;
        };
        if !(obj.seen_by(Ray::PRIMARY) && obj.render_type == RenderType::Dvr) {
            return None;
        }
        // The lanes composite in f32 (each sample's transmittance rounded to f32, colour and
        // transmittance summed and multiplied in f32): the error grows with the samples of a
        // ray, about 2⁻²⁴ each, so beyond 2¹⁴ samples (a quarter of an 8-bit level) the
        // scalar march, in f64, traces every ray.
        let samples = obj.world_diagonal() / obj.step;
        if samples.is_nan() || samples > MAX_PACKET_SAMPLES {
            return None;
        }
        let lean = obj.lean.as_ref()?;
        let (data, z) = lean.value_head()?;
        // (Normal functions are the scalar code's, for a pre-integrated object too.)
        if !obj.normals.is_empty() {
            return None;
        }
        let tables = lean.direct_shading()?;
        let (strides, half_last) = data.packet_parts();
        let dims = data.dims();
        // Every axis at least 4 nodes (so interior cells exist and the clamps below have room),
        // every index an i32.
        if dims.iter().any(|&n| n < 4) || dims.iter().product::<usize>() >= i32::MAX as usize / 2 {
            return None;
        }
        // The node values only where the voxels are not read instead (made on first use):
        // 8-bit voxels straight ([`Raw8`]), 16-bit voxels straight where the lanes' normalisation
        // gives the node values' bits ([`Raw16`]), else through their table of node values.
        let raw8 = Raw8::of(data);
        // A pre-integrated object's slabs are composited by the scalar code (`Packets::tile_pre`),
        // its values read as the lanes read them.
        let pre = obj.preint.as_ref().map(|pre| {
            let march = PreMarch::new(scene, obj, pre, data, z);
            match &raw8 {
                Some(r8) => march.with_bytes(Bytes {
                    raw: r8.raw,
                    scale: r8.scale,
                    offset: r8.offset,
                    last: dims.map(|n| (n - 1) as f32),
                    top: dims.map(|n| (n - 2) as f32),
                    sy: strides[1],
                    sz: strides[2],
                }),
                None => march,
            }
        });
        let values = match (&raw8, data.raw()) {
            (Some(_), _) => NodeValues::F32(&[]),
            (None, Voxels::U16(raw)) => NodeValues::U16(raw, data.table16()?),
            (None, _) => NodeValues::F32(data.values()),
        };
        let [ka, kd, ks, spec] = tables.coefficients;
        // The lanes' lighting where the scene's headlight has lanes (`Compiled::lanes`) and the
        // gradient is this very dataset's, trilinear (as the batched march's `same_cells`), in
        // object space; a pre-integrated object without it has its slabs lit by the scalar code
        // (`Light32::Unlit` then unread), any other object no packet march.
        let lit = scene.lanes[0].as_ref().and_then(|h| {
            match &obj.f_dataset {
                Some((d, Filter::Trilinear, GradientFilter::Nodes))
                    if std::ptr::eq(Arc::as_ptr(d), data) => {}
                _ => return None,
            }
            let f64_of = |v: &Lanes| v.to_array()[0];
            let f = |v: &Lanes| f64_of(v) as f32;
            // The lanes' colours in f32: a lit sample's colour is at most the brightest
            // channel's radiance times kd + ks, plus the brightest ambient term (colours,
            // cosines and powers at most 1). Past `MAX_LIT` (or NaN) the scalar march's f64
            // lights the samples, which no sum of up to 2³² colours in f32 could.
            let brightest = |v: &[Lanes; 3]| v.iter().map(|x| f64_of(x).abs()).fold(0.0, f64::max);
            let ks = h.ks.as_ref().map_or(0.0, |k| f64_of(k).abs());
            let bound =
                brightest(&h.radiance) * (f64_of(&h.kd).abs() + ks) + brightest(&h.ka_ambient);
            if bound.is_nan() || bound > MAX_LIT {
                return None;
            }
            // The normal's matrix scaled by a power of two that brings its largest entry into
            // [1, 2): the same direction, and the same bits wherever the unscaled matrix
            // neither overflows nor underflows in f32, which for objects of world size below
            // 10⁻¹⁹ or above 10²² it would (the gradient's square).
            let (to_world, diagonal) = match &h.to_world {
                ToWorld::None => return None,
                ToWorld::General(m) => (m.map(|c| c.each_ref().map(f64_of)), false),
                ToWorld::Diagonal(d) => {
                    let mut m = [[0f64; 3]; 3];
                    for (i, x) in d.iter().enumerate() {
                        m[i][i] = f64_of(x);
                    }
                    (m, true)
                }
            };
            let largest = to_world
                .iter()
                .flatten()
                .fold(0.0f64, |m, x| m.max(x.abs()));
            let to_world = to_world.map(|c| c.map(|x| (x * unit_scale(largest)) as f32));
            Some(Light32::Lit {
                ka_ambient: h.ka_ambient.each_ref().map(f),
                kd: f(&h.kd),
                ks: h.ks.as_ref().map(f),
                e: h.e,
                to_light: h.to_light.each_ref().map(f),
                radiance: h.radiance.each_ref().map(f),
                flip: h.flip,
                to_world,
                diagonal,
            })
        });
        let light = match (lit, scene.lanes[0].as_ref()) {
            (Some(lit), _) => lit,
            (None, _) if pre.is_some() => Light32::Unlit {
                ka_ambient: [0.0; 3],
            },
            (None, Some(_)) => return None,
            (None, None) => {
                let h = Headlit::new(
                    scene,
                    obj,
                    DVec3::ZERO,
                    [ka, kd, ks],
                    Specular::of_field(spec),
                )?;
                if !h.lights.is_empty() {
                    return None;
                }
                Light32::Unlit {
                    ka_ambient: h.ka_ambient.to_array().map(|x| x as f32),
                }
            }
        };
        // (The dataset's extremes from its brick ranges, made once per dataset, where skipping
        // is on for the skip grid; where they cannot be made, the table's nodes and differences.)
        let raw16 = match data.raw() {
            Voxels::U16(_) => data
                .try_bricks(Filter::Trilinear)
                .ok()
                .and_then(|b| Raw16::of(data, b.raw_extremes())),
            Voxels::U8(_) => None,
        };
        let mask = obj.cells.as_deref().map_or(&[][..], |m| m.words32());
        if mask.len() >= i32::MAX as usize {
            return None;
        }
        let (bucket_pair, pair_list) = tables.pairs_f32();
        if pair_list.is_empty() || pair_list.len() >= i32::MAX as usize {
            return None;
        }
        let pairs = std::array::from_fn(|k| pair_list.iter().map(|p| p[k]).collect());
        let ((om, oj), (cm, cj)) = tables.tables();
        let segments = match (
            Segs::new(om, oj),
            Segs::new(cm, cj[0]),
            Segs::new(cm, cj[1]),
            Segs::new(cm, cj[2]),
        ) {
            (Some(o), Some(r), Some(g), Some(b)) => Some(Segments { o, rgb: [r, g, b] }),
            _ => None,
        };
        let segments_fit = segments.is_some();
        let common = obj.step * obj.inv_ref;
        let common = if [0.5, 1.0, 0.25, 2.0, 0.125, 4.0].contains(&common) {
            common
        } else {
            f64::NAN
        };
        Some(Packets {
            obj,
            data,
            tables,
            grid: obj
                .skip
                .as_deref()
                .filter(|_| scene.settings.optimise.skip_empty),
            values,
            raw8,
            raw16,
            mask,
            trusted_runs: if scene.settings.optimise.trust_whole_runs {
                TRUSTED_RUNS
            } else {
                0
            },
            z,
            segments,
            bucket_pair,
            pairs,
            light,
            inv_ref: obj.inv_ref,
            common,
            stop: scene.settings.optimise.stop_below() as f32,
            clip: !crate::data::box_covered(obj.box_min, obj.box_max),
            last: dims.map(|n| (n - 1) as f32),
            top: dims.map(|n| (n - 2) as f32),
            inner: dims.map(|n| (n - 2) as f32),
            sy: strides[1] as i32,
            sz: strides[2] as i32,
            half_last: half_last.map(|x| x as f32),
            wide: scene.settings.optimise.wide_lanes
                && (segments_fit || pre.is_some())
                && detected(),
            pre,
            #[cfg(test)]
            packets: 0,
            #[cfg(test)]
            untested: Default::default(),
        })
    }

    /// The pixels of the tile of `width × height` pixels at (tx, ty), row by row, as
    /// [`render_image`]'s per-pixel loop gives them for one ray per pixel, written into `out`
    /// (the tile's `width × height` pixels, zeros).
    pub(super) fn tile(
        &self,
        view: &Pinhole,
        entry: Option<&EntryMap>,
        image: &ImageRays,
        unbounded: Option<Pixel>,
        (tx, ty, tw, th): (u32, u32, u32, u32),
        out: Vec<Pixel>,
    ) -> Vec<Pixel> {
        let tile = TileRays {
            view,
            entry,
            image,
            unbounded,
            origin: (tx, ty),
            size: (tw, th),
        };
        if self.wide {
            // SAFETY: `Packets::new` set `wide` only where `detected` found every
            // feature `tile_avx512` enables (and AVX2 and FMA before it).
            return unsafe { self.tile_avx512(&tile, out) };
        }
        // SAFETY: `Packets::new` (the only way to make `self`) found AVX2 and FMA.
        unsafe { self.tile_avx2(&tile, out) }
    }

    /// The packets a step carries where the unit tests set it (`Packets::packets`), else 0:
    /// each width's own number.
    #[inline(always)]
    fn packets(&self) -> usize {
        #[cfg(test)]
        return self.packets;
        #[cfg(not(test))]
        0
    }

    /// Counts a run taken on trust (in the unit tests only, `Packets::untested`).
    #[inline(always)]
    fn count_untested(&self) {
        #[cfg(test)]
        self.untested
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }

    /// [`Packets::tile`] in [`PACKETS8`] packets of eight lanes.
    #[target_feature(enable = "avx2,fma")]
    fn tile_avx2(&self, tile: &TileRays<'_>, out: Vec<Pixel>) -> Vec<Pixel> {
        let segments = |keeps: &mut _, runs: &_, st: &mut _| next_segments(keeps, runs, st);
        let step = |st: &mut _, active, cache: &mut _| self.step8(st, active, cache);
        let taken = |c: &mut _, run: &mut _, trusted: &mut _| self.next_taken8(c, run, trusted);
        // SAFETY: this function has the AVX2 and FMA `march_tile` asks for.
        unsafe {
            match self.packets() {
                1 => self.march_tile::<W, 1, W>(tile, out, segments, step, taken),
                4 => self.march_tile::<W, 4, { 4 * W }>(tile, out, segments, step, taken),
                _ => self
                    .march_tile::<W, PACKETS8, { PACKETS8 * W }>(tile, out, segments, step, taken),
            }
        }
    }

    /// [`Packets::tile`] in [`P`] packets of sixteen lanes: lane `i` is lane `i % 16` of
    /// packet `i / 16`, and a step steps every packet.
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn tile_avx512(&self, tile: &TileRays<'_>, out: Vec<Pixel>) -> Vec<Pixel> {
        let segments = |keeps: &mut _, runs: &_, st: &mut _| next_segments16(keeps, runs, st);
        let step = |st: &mut _, active, cache: &mut _| self.step16(st, active, cache);
        let taken = |c: &mut _, run: &mut _, trusted: &mut _| self.next_taken16(c, run, trusted);
        // SAFETY: this function has AVX2 and FMA, which `march_tile` asks for.
        unsafe {
            match self.packets() {
                1 => self.march_tile::<V, 1, V>(tile, out, segments, step, taken),
                4 => self.march_tile::<V, 4, { 4 * V }>(tile, out, segments, step, taken),
                _ => self.march_tile::<V, P, { P * V }>(tile, out, segments, step, taken),
            }
        }
    }

    /// The pixels of `tile`, row by row, marched in `P` packets of `N` lanes (`L` = P·N lanes
    /// in all, at most 64, lane `i` being lane `i % N` of packet `i / N`); the march of
    /// either width ([`Packets::tile_avx2`], `tile_avx512`) through its own three steps:
    ///
    /// - `next_segments(keeps, runs, st)`: the packet's lanes whose run has a next segment
    ///   to take (their bit in `keeps` taken, its segment written into `st`), by bit;
    /// - `step(st, active, cache)`: one sample in each `active` lane of the packet, composited
    ///   front to back; the lanes whose ray it ended (early termination), by bit;
    /// - `next_taken(cursor, run, trusted)`: a ray's next run with a segment to take, by bit
    ///   (0 at the ray's end).
    ///
    /// A step steps every packet: their chains of dependent operations overlap. Each ray is
    /// its own cursor and arithmetic, so which lane or packet carries it changes nothing in
    /// its pixel.
    ///
    /// # Safety
    /// The caller must have AVX2 and FMA (for [`Packets::next_ray`]). Always inlined, so
    /// that the steps inline into the caller's target features.
    #[inline(always)]
    unsafe fn march_tile<const N: usize, const P: usize, const L: usize>(
        &self,
        tile: &TileRays<'_>,
        mut out: Vec<Pixel>,
        next_segments: impl Fn(&mut [u32; N], &[Run16; N], &mut LaneState<N>) -> u32,
        mut step: impl FnMut(&mut LaneState<N>, u32, &mut CellGradients) -> u32,
        next_taken: impl Fn(&mut Cursor, &mut Run16, &mut u32) -> u32,
    ) -> Vec<Pixel> {
        const { assert!(N == 8 || N == 16) };
        const { assert!(P >= 1 && L == P * N && L <= 64) };
        let all = u64::MAX >> (64 - L);
        // A packet's bits (its steps give none above them; masked all the same, so that a
        // stray bit cannot name a lane of the next packet).
        let lanes_of = u64::MAX >> (64 - N);
        let background = tile.image.background;
        let (tw, th) = tile.size;
        debug_assert_eq!(out.len(), (tw * th) as usize);
        let mut starts = Starts::default();
        let mut lanes: [Option<LaneRay>; L] = std::array::from_fn(|_| None);
        // Per lane: its run's segments, and those still to take by bit (`to_take`; 0 for a
        // lane without a ray). Apart from the rays, so that the common case below reads a
        // word, two numbers and nothing else of the lane.
        let mut runs = [Run16::default(); L];
        let mut keeps = [0u32; L];
        let mut st: [LaneState<N>; P] = std::array::from_fn(|_| LaneState::default());
        let mut cache = CellGradients::default();
        loop {
            // The common case: a lane's run has a next segment to take (all lanes at once).
            let mut active = 0u64;
            for (h, st) in st.iter_mut().enumerate() {
                let k = (&mut keeps[N * h..N * h + N]).try_into().expect("N lanes");
                let r = runs[N * h..N * h + N].try_into().expect("N lanes");
                active |= (next_segments(k, r, st) as u64 & lanes_of) << (N * h);
            }
            // The other lanes: the next run of their ray with a segment to take, or a new ray
            // where their ray has ended.
            let mut idle = !active & all;
            while idle != 0 {
                let i = idle.trailing_zeros() as usize % L;
                idle &= idle - 1;
                let (h, l) = (i / N, i % N);
                let st = &mut st[h];
                loop {
                    if lanes[i].is_none() {
                        // SAFETY: the caller has AVX2 and FMA.
                        let next =
                            unsafe { self.next_ray(&mut starts, &mut lanes[i], tile, &mut out) };
                        let Some((c, view)) = next else {
                            break;
                        };
                        st.start(l, c, view);
                    }
                    let lane = lanes[i].as_mut().expect("a ray");
                    // The next run with a segment to take (runs of none are passed over).
                    let (run, keep) = (&mut runs[i], &mut keeps[i]);
                    *keep = next_taken(&mut lane.cursor, run, &mut lane.trusted);
                    if *keep == 0 {
                        let px = lane.px;
                        lanes[i] = None;
                        out[px] = finish(&st.col, &st.t, l, background);
                        continue;
                    }
                    let j = keep.trailing_zeros() as usize % (2 * W);
                    *keep &= *keep - 1;
                    st.mid[l] = run.mids[j];
                    st.len[l] = run.lens[j];
                    active |= 1 << i;
                    break;
                }
            }
            if active == 0 {
                break;
            }
            let mut ended = 0u64;
            for (h, st) in st.iter_mut().enumerate() {
                let a = (active >> (N * h) & lanes_of) as u32;
                ended |= (step(st, a, &mut cache) as u64 & lanes_of) << (N * h);
            }
            while ended != 0 {
                let i = ended.trailing_zeros() as usize % L;
                ended &= ended - 1;
                let (h, l) = (i / N, i % N);
                let px = lanes[i].take().expect("a ray").px;
                keeps[i] = 0;
                st[h].t[l] = 0.0;
                out[px] = finish(&st[h].col, &st[h].t, l, background);
            }
        }
        out
    }

    /// The tile's next ray that takes a sample ([`Packets::make_starts`], four pixels at a
    /// time), in `slot` (built there: a cursor is a few hundred bytes); the pixels before it
    /// whose ray takes none get their colour in `out`. `None` at the tile's end.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn next_ray<'s>(
        &self,
        q: &mut Starts,
        slot: &'s mut Option<LaneRay>,
        tile: &TileRays<'_>,
        out: &mut [Pixel],
    ) -> Option<(&'s Cursor, [f32; 3])> {
        while q.at == q.len {
            if q.next >= tile.size.0 * tile.size.1 {
                return None;
            }
            self.make_starts(q, tile, out);
        }
        let r = q.ready[q.at];
        q.at += 1;
        let lane = slot.insert(LaneRay {
            cursor: Cursor {
                object: 0,
                t0: r.t0,
                t1: r.t1,
                step: self.obj.step,
                k: 0,
                n: r.n,
                walk: None,
                o: tile.image.origin_o,
                d: DVec3::from_array(r.d),
                occupied_until: f64::NEG_INFINITY,
                probe_at: crate::render::cursor::PROBE_EVERY,
            },
            px: r.px as usize,
            trusted: 0,
        });
        match r.k {
            Start::At(k) => lane.cursor.k = k,
            Start::Before(t) => lane.cursor.start_at(t),
        }
        Some((&lane.cursor, r.view))
    }
}

/// Lane `i`'s pixel (of lanes with colours `col` by channel and transmittances `t`, in eight
/// or sixteen lanes): its colour plus its transmittance times the background, and its
/// transmittance.
fn finish<const N: usize>(col: &[[f32; N]; 3], t: &[f32; N], i: usize, background: DVec3) -> Pixel {
    let c = DVec3::new(col[0][i] as f64, col[1][i] as f64, col[2][i] as f64);
    pixel(c + t[i] as f64 * background, t[i] as f64)
}

/// A lane's ray: its cursor, its pixel (in the tile), and how many of its next runs are taken
/// without the cell-mask test ([`TRUSTED_RUNS`]).
struct LaneRay {
    cursor: Cursor,
    px: usize,
    trusted: u32,
}

/// The runs of a ray taken without the cell-mask test after a run the mask passed whole
/// ([`Packets::next_taken`]). Exact, as a taken sample the mask would have dropped adds
/// nothing: the mask clears only cells whose every value is at most the zero test's bound,
/// with a margin over the rounding of any sample in them ([`crate::data::CellMask`]), so
/// such a sample fails the zero test of [`Packets::step`]. Inside visible matter the mask
/// passes most runs whole, and at fine steps its test is about a third of a sample's work;
/// but where a run it would have cut comes untested, the samples it would have dropped take
/// lanes for nothing. More runs on trust save more tests and waste more lanes at the edges of
/// matter; `docs/performance.md` measures the choice of two.
pub(in crate::render) const TRUSTED_RUNS: u32 = 2;

/// The run of segments a lane is taking: up to sixteen midpoints and lengths, tested against
/// the cell mask together ([`Packets::run16`]).
#[derive(Clone, Copy, Default)]
#[repr(C)]
pub(in crate::render) struct Run16 {
    pub(in crate::render) mids: [f64; 2 * W],
    pub(in crate::render) lens: [f64; 2 * W],
}

/// A packet's state, by lane, for `N` lanes: the ray in object coordinates (`o + t·d`), the
/// view direction (towards the eye), the sample being taken (its segment's midpoint and
/// length), the transmittance and the colour so far.
#[repr(C, align(64))]
struct LaneState<const N: usize> {
    ro: [[f64; N]; 3],
    rd: [[f64; N]; 3],
    mid: [f64; N],
    len: [f64; N],
    view: [[f32; N]; 3],
    t: [f32; N],
    col: [[f32; N]; 3],
}

impl<const N: usize> Default for LaneState<N> {
    fn default() -> Self {
        Self {
            ro: [[0.0; N]; 3],
            rd: [[0.0; N]; 3],
            mid: [0.0; N],
            len: [0.0; N],
            view: [[0.0; N]; 3],
            t: [0.0; N],
            col: [[0.0; N]; 3],
        }
    }
}

impl<const N: usize> LaneState<N> {
    /// Lane `l` starts ray `c` (transmittance 1, no colour yet), seen along `view`.
    #[inline(always)]
    fn start(&mut self, l: usize, c: &Cursor, view: [f32; 3]) {
        self.t[l] = 1.0;
        for (ch, &v) in view.iter().enumerate() {
            self.col[ch][l] = 0.0;
            self.view[ch][l] = v;
            self.ro[ch][l] = c.o[ch];
            self.rd[ch][l] = c.d[ch];
        }
    }
}
