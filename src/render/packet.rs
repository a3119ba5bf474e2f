//! The packet march: primary rays of a scanned volume traced eight at a time, one ray per
//! lane of AVX2 registers (x86-64 only, detected at run time), or sixteen at a time in
//! AVX-512 registers where the processor has them and the scene fits ([`wide`]: the same
//! image bit for bit).
//!
//! Where it applies (see [`Packets::new`]): one visible DVR volume whose lean program is the
//! direct-shading form (a dataset read trilinearly, an opacity table, a colour table writing
//! r, g and b, constant coefficients) with no normal functions, lit as [`HeadlitLanes`] lights
//! it (one directional light, an integer specular exponent, no shadows) or not lit at all
//! (kd and ks 0: the unshaded scene), one ray per pixel. Everything else is traced by the
//! scalar march, unchanged.
//!
//! Each lane has its own ray, [`Cursor`] and state (transmittance, colour). The cursors are the
//! scalar march's (the same segments, midpoints and lengths, the same start at the [`EntryMap`]
//! bound; a tile's rays started four at a time in lanes, [`Packets::make_starts`]), but a lane
//! takes only the samples that can count: each run of sixteen segments (two of eight, in lanes,
//! [`segments_lanes`]) is tested against the cell mask together ([`Packets::to_take`], one gather a
//! run of eight), and a sample in a cell that cannot reach the zero test's bound (it would add
//! nothing) takes no lane. The mask decides which samples are taken, so that is exact wherever the
//! walk is; the block walk is asked only after a run of which nothing is taken, past the occupied
//! blocks it last reported, and leaps over empty blocks ([`Packets::next_taken`]): the scalar march
//! asks it about every run. The samples taken are the scalar march's samples that the mask passes,
//! and those are all its samples that can count; but after a run the mask passed whole, the next
//! two are taken untested ([`TRUSTED_RUNS`]: a sample it would have dropped fails the zero test, so
//! the image is the same bit for bit, and inside visible matter most runs pass). Every iteration
//! takes each lane's next sample to take and evaluates the eight together: the object points and
//! cells, the eight nodes (per-lane 8-byte loads and a transposition, [`Nodes::pairs2`]; for 8-bit
//! voxels whose normalisation never clamps, the voxels themselves, four to a lane by one gather a
//! row of the cell, [`Raw8`]), the trilinear value (the scalar code's f32 lerps, unfused, so the
//! same bits and the same zero test from node values; from voxels, normalised once), opacity and
//! colour (the two tables as at most eight linear pieces in registers, [`Segments`]; tables of more
//! rows by their segment pairs, gathered), the opacity correction, the gradient (the trilinear
//! interpolation of the nodes' central differences, its nodes again by per-lane loads or by eight
//! more gathers of voxels, only where a lane's sample has opacity), the headlight's Phong lighting
//! and the front-to-back composite. A lane whose ray ends (it leaves the volume or its
//! transmittance falls below the termination bound) takes the tile's next ray.
//!
//! On by default where it applies (`Optimise::packets` switches it off): about 1.1× the
//! scalar march's speed shaded and 1.25× unshaded on the measured host as first measured,
//! 1.15–1.25× shaded after the second round's cheaper loads and bookkeeping, about 1.45×
//! shaded and 1.5× unshaded since samples in masked cells take no lane; on the twelfth
//! session's host (AVX-512), about 2.1× in eight lanes and 2.6× in sixteen (`docs/performance.md`,
//! "The packet march (AVX2), measured" and the paragraphs after it).
//!
//! **Arithmetic.** From node values, the trilinear value and the gradient's sums are the scalar
//! code's f32 operations in the same order, without fused multiply-adds, so the same bits; from
//! 8-bit voxels the same operations on the voxels (the differences exact integers), then one
//! normalisation, which rounds differently from the node values' own (a relative 10⁻⁷). The tables,
//! the lighting and the composite are in f32 (the scalar march has f64 there) and use fused
//! multiply-adds where they save instructions: images differ from the scalar march's in the
//! last bits of a colour, far below an 8-bit level (`packets_are_the_scalar_march`).
//! Rare cases go lane by lane through the scalar code: a value whose table bucket has no
//! segment pair (`DirectShading::opacity_colour_general`), a gradient in a cell whose 4³
//! neighbourhood is not inside the grid (`Dataset::gradient_cached`), a segment whose
//! opacity-correction exponent is not the step's common one (`transmit_at_most_one`).
//!
//! **Safety.** The only `unsafe` code of the crate is here: the gathers, the per-lane loads of
//! nodes, the loads and stores of `[f32; 8]` / `[f64; 4]` / `[i32; 8]` arrays, and the call of
//! the `#[target_feature]` tile function, made only by a [`Packets`], which exists only after
//! `is_x86_feature_detected!` found AVX2 and FMA. Every node index is clamped so that it and
//! the whole span read from it lie inside the values ([`Nodes`]), every table index into its
//! table ([`gather`]), so every lane reads inside the slice whatever the ray.

use super::*;
use crate::data::{Filter, Voxels};
use crate::model::mapping::Mapping;
use crate::render::kernel::DirectShading;
use crate::types::MappingType;
use std::arch::x86_64::*;

pub(super) mod wide;

/// Lanes of a packet.
const W: usize = 8;

/// Packets of eight lanes a tile's step carries ([`Packets::march_tile`]).
const PACKETS8: usize = 2;

/// In unit tests, the packets a step carries in either width where not 0 (1, 2 or 4; else
/// [`PACKETS8`] and `wide::P`): `packets_carry_rays_without_changing_them` sets it. Global, so
/// a test running meanwhile may render with it too, which the claim it tests allows.
#[cfg(test)]
static TEST_PACKETS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// The unit tests' `TEST_PACKETS`, 0 outside them.
#[inline(always)]
fn test_packets() -> usize {
    #[cfg(test)]
    return TEST_PACKETS.load(std::sync::atomic::Ordering::Relaxed);
    #[cfg(not(test))]
    0
}

/// The lighting of [`Packets`]: unlit (kd and ks 0: the ambient term alone) or a headlight
/// as [`HeadlitLanes`] holds it, in f32.
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
    values: &'a [f32],
    /// The dataset's 8-bit voxels, read instead of `values` where its normalisation is
    /// linear over every byte ([`Raw8::of`]).
    raw8: Option<Raw8<'a>>,
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
    /// n − 1, max(n − 2, 0) and n − 2 per axis, as f32; the strides; 0.5·(n − 1) as f32.
    last: [f32; 3],
    top: [f32; 3],
    inner: [f32; 3],
    sy: i32,
    sz: i32,
    half_last: [f32; 3],
    /// Sixteen lanes a step ([`wide`]): the processor has AVX-512 and the scene fits it.
    wide: bool,
}

impl<'a> Packets<'a> {
    /// The packet march of `scene`, where it applies and the processor has AVX2 and FMA;
    /// `None` otherwise (the scalar march then traces every ray).
    pub(super) fn new(scene: &'a Compiled) -> Option<Packets<'a>> {
        if !scene.settings.optimise.packets || scene.settings.super_sample > 1 {
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
        let lean = obj.lean.as_ref()?;
        let (data, z) = lean.value_head()?;
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
        // The node values only where the voxels are not read instead (made on first use).
        let raw8 = Raw8::of(data);
        let raw8_fits = raw8.is_some();
        let values = if raw8.is_some() {
            &[][..]
        } else {
            data.values()
        };
        let [ka, kd, ks, spec] = tables.coefficients;
        let light = match scene.lanes[0].as_ref() {
            Some(h) => {
                // The gradient must be this very dataset's, trilinear (as the batched march's
                // `same_cells`), in object space.
                match &obj.f_dataset {
                    Some((d, Filter::Trilinear)) if std::ptr::eq(Arc::as_ptr(d), data) => {}
                    _ => return None,
                }
                let f = |v: &Lanes| v.to_array()[0] as f32;
                let (to_world, diagonal) = match &h.to_world {
                    ToWorld::None => return None,
                    ToWorld::General(m) => (m.map(|c| c.each_ref().map(f)), false),
                    ToWorld::Diagonal(d) => {
                        let mut m = [[0f32; 3]; 3];
                        for (i, x) in d.iter().enumerate() {
                            m[i][i] = f(x);
                        }
                        (m, true)
                    }
                };
                Light32::Lit {
                    ka_ambient: h.ka_ambient.each_ref().map(f),
                    kd: f(&h.kd),
                    ks: h.ks.as_ref().map(f),
                    e: h.e,
                    to_light: h.to_light.each_ref().map(f),
                    radiance: h.radiance.each_ref().map(f),
                    flip: h.flip,
                    to_world,
                    diagonal,
                }
            }
            None => {
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
            last: dims.map(|n| (n - 1) as f32),
            top: dims.map(|n| (n - 2) as f32),
            inner: dims.map(|n| (n - 2) as f32),
            sy: strides[1] as i32,
            sz: strides[2] as i32,
            half_last: half_last.map(|x| x as f32),
            wide: scene.settings.optimise.wide_lanes
                && raw8_fits
                && segments_fit
                && wide::detected(),
        })
    }

    /// The pixels of the tile of `width × height` pixels at (tx, ty), row by row, as
    /// [`render_image`]'s per-pixel loop gives them for one ray per pixel.
    pub(super) fn tile(
        &self,
        view: &Pinhole,
        entry: Option<&EntryMap>,
        image: &ImageRays,
        unbounded: Option<[f32; 3]>,
        (tx, ty, tw, th): (u32, u32, u32, u32),
    ) -> Vec<[f32; 3]> {
        let tile = TileRays {
            view,
            entry,
            image,
            unbounded,
            origin: (tx, ty),
            size: (tw, th),
        };
        if self.wide {
            // SAFETY: `Packets::new` set `wide` only where `wide::detected` found every
            // feature `tile_avx512` enables (and AVX2 and FMA before it).
            return unsafe { self.tile_avx512(&tile) };
        }
        // SAFETY: `Packets::new` (the only way to make `self`) found AVX2 and FMA.
        unsafe { self.tile_avx2(&tile) }
    }

    /// [`Packets::tile`] in [`PACKETS8`] packets of eight lanes.
    #[target_feature(enable = "avx2,fma")]
    fn tile_avx2(&self, tile: &TileRays<'_>) -> Vec<[f32; 3]> {
        let segments = |keeps: &mut _, runs: &_, st: &mut _| next_segments(keeps, runs, st);
        let step = |st: &mut _, active, cache: &mut _| self.step(st, active, cache);
        let taken = |c: &mut _, run: &mut _, trusted: &mut _| self.next_taken(c, run, trusted);
        // SAFETY: this function has the AVX2 and FMA `march_tile` asks for.
        unsafe {
            match test_packets() {
                1 => self.march_tile::<W, 1, W>(tile, segments, step, taken),
                4 => self.march_tile::<W, 4, { 4 * W }>(tile, segments, step, taken),
                _ => self.march_tile::<W, PACKETS8, { PACKETS8 * W }>(tile, segments, step, taken),
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
        next_segments: impl Fn(&mut [u32; N], &[Run16; N], &mut LaneState<N>) -> u32,
        mut step: impl FnMut(&mut LaneState<N>, u32, &mut CellGradients) -> u32,
        next_taken: impl Fn(&mut Cursor, &mut Run16, &mut u32) -> u32,
    ) -> Vec<[f32; 3]> {
        const { assert!(N == 8 || N == 16) };
        const { assert!(P >= 1 && L == P * N && L <= 64) };
        let all = u64::MAX >> (64 - L);
        // A packet's bits (its steps give none above them; masked all the same, so that a
        // stray bit cannot name a lane of the next packet).
        let lanes_of = u64::MAX >> (64 - N);
        let background = tile.image.background;
        let (tw, th) = tile.size;
        let mut out = vec![[0f32; 3]; (tw * th) as usize];
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
        out: &mut [[f32; 3]],
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

    /// The starts of the tile's next pixels, up to four of one row, into `q` (in pixel order),
    /// and the colours of those whose ray takes no sample into `out`: [`Compiled::trace_ray`]'s
    /// one-volume path up to its march, four rays in f64 lanes, each lane the scalar code's
    /// operations in its order, so the same numbers: the direction of `Pinhole::ray`, the
    /// object-space direction of `transform_vector3`, the span of [`CObj::clip`], the count of
    /// `Cursor::unstarted` and the first segment not before the entry bound of
    /// `Cursor::start_at` (by the estimate `Cursor::pass_before` starts from, where its
    /// neighbours show it final; the cursor's own search elsewhere)
    /// (`ray_start_lanes_are_the_scalar_starts`).
    #[target_feature(enable = "avx2,fma")]
    fn make_starts(&self, q: &mut Starts, tile: &TileRays<'_>, out: &mut [[f32; 3]]) {
        let obj = self.obj;
        let (tw, _) = tile.size;
        let (row, col) = (q.next / tw, q.next % tw);
        let lanes = (tw - col).min(4) as usize;
        let first = q.next as usize;
        q.next += lanes as u32;
        q.len = 0;
        q.at = 0;
        let (x0, y) = (tile.origin.0 + col, tile.origin.1 + row);
        let bound: [f64; 4] = std::array::from_fn(|l| {
            let x = x0 + (l.min(lanes - 1)) as u32;
            tile.entry.map_or(f64::NEG_INFINITY, |e| e.bound(x, y))
        });
        // Pixels whose bound is +∞ where that is known to show a colour: no ray.
        if let Some(c) = tile.unbounded {
            if bound[..lanes].iter().all(|&b| b == f64::INFINITY) {
                out[first..first + lanes].fill(c);
                return;
            }
        }
        let (dir, d) = ray_lanes(tile.view, &obj.to_object, x0, y);
        let o = tile.image.origin_o;
        let (t0, t1, ok) = clip_lanes(o, &d, obj.box_min, obj.box_max);
        let n = count_lanes(t0, t1, obj.step);
        let from = _mm256_max_pd(ld4(&bound), t0);
        let k = first_segments(t0, t1, obj.step, n, from);
        let (dir, d, t0, t1, from) = (st4(dir), st4(d), st4d(t0), st4d(t1), st4d(from));
        let background = tile.image.background;
        let unsampled = DVec3::ZERO + 1.0 * background;
        let bits = |v: DVec3| v.to_array().map(f64::to_bits);
        for (l, &bound) in bound.iter().enumerate().take(lanes) {
            let px = first + l;
            if bound == f64::INFINITY {
                if let Some(c) = tile.unbounded {
                    out[px] = c;
                    continue;
                }
                if bits(unsampled) == bits(background) {
                    out[px] = to_f32(unsampled);
                    continue;
                }
            }
            if ok >> l & 1 == 0 {
                out[px] = to_f32(background);
                continue;
            }
            if bound >= t1[l] {
                out[px] = to_f32(unsampled);
                continue;
            }
            let n = if n[l] != 0 {
                n[l]
            } else {
                segment_count((t1[l] - t0[l]) / obj.step)
            };
            let k = match (self.grid, k[l]) {
                (None, _) => Start::At(0),
                (Some(_), Some(k)) => Start::At(k),
                (Some(_), None) => Start::Before(from[l]),
            };
            q.ready[q.len] = RayStart {
                px: px as u32,
                d: [d[0][l], d[1][l], d[2][l]],
                view: [-dir[0][l] as f32, -dir[1][l] as f32, -dir[2][l] as f32],
                t0: t0[l],
                t1: t1[l],
                n,
                k,
            };
            q.len += 1;
        }
    }

    /// One sample of each lane in `active` (at `st.mid`, `st.len`): shaded and composited
    /// into the lane's state. Returns the lanes whose rays end there (transmittance below the
    /// termination bound).
    #[target_feature(enable = "avx2,fma")]
    fn step(&self, st: &mut State, active: u32, cache: &mut CellGradients) -> u32 {
        let zero = _mm256_setzero_ps();
        let one = _mm256_set1_ps(1.0);
        // The lanes with a sample of positive length (`pass_bits`: a NaN length passes).
        let mut empty = 0u32;
        for h in 0..2 {
            let le = _mm256_cmp_pd::<_CMP_LE_OQ>(ldd(&st.len, h), _mm256_setzero_pd());
            empty |= (_mm256_movemask_pd(le) as u32) << (4 * h);
        }
        let live = active & !empty;
        if live == 0 {
            return 0;
        }
        // Object points (f64, then rounded to f32 as `ray_point`).
        let mut p = [zero; 3];
        for (axis, pa) in p.iter_mut().enumerate() {
            let half = |h: usize| {
                let m = ldd(&st.mid, h);
                let o = ldd(&st.ro[axis], h);
                let d = ldd(&st.rd[axis], h);
                _mm256_cvtpd_ps(_mm256_add_pd(o, _mm256_mul_pd(m, d)))
            };
            *pa = _mm256_set_m128(half(1), half(0));
        }
        // The cells (every sample here lies in one that may reach the bound: `to_take`).
        let (f, base, interior) = self.cells(&p);
        let sy = self.sy;
        let sz = self.sz;
        let mut pass = live;
        // The eight nodes and the trilinear value (`trilinear_rows`' lerps).
        // (Lanes without a sample read node 0 instead: no memory traffic for them.)
        let base = _mm256_and_si256(base, _mm256_castps_si256(lanes_mask(pass)));
        let (nodes, rows) = match &self.raw8 {
            Some(r8) => {
                let rows = r8.central_rows(base, pass, sy, sz);
                (rows.cell_nodes(), Some(rows))
            }
            None => {
                let cell = Nodes::new(self.values, base, 1 + sy + sz);
                let [n000, n100, n010, n110] = cell.pairs2(0, sy);
                let [n001, n101, n011, n111] = cell.pairs2(sz, sy + sz);
                ([n000, n100, n010, n110, n001, n101, n011, n111], None)
            }
        };
        let lerp = |a: __m256, b: __m256, t: __m256| {
            _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), t))
        };
        let [fx, fy, fz] = f;
        let [n000, n100, n010, n110, n001, n101, n011, n111] = nodes;
        let c00 = lerp(n000, n100, fx);
        let c10 = lerp(n010, n110, fx);
        let c01 = lerp(n001, n101, fx);
        let c11 = lerp(n011, n111, fx);
        let v = lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz);
        // (Raw voxels: the value normalised once, `raw·scale + offset`.)
        let v = match &self.raw8 {
            Some(r8) => _mm256_fmadd_ps(v, _mm256_set1_ps(r8.scale), _mm256_set1_ps(r8.offset)),
            None => v,
        };
        let v = _mm256_min_ps(_mm256_max_ps(v, zero), one);
        // The zero test.
        let above = _mm256_cmp_ps::<_CMP_GT_OQ>(v, _mm256_set1_ps(self.z));
        pass &= _mm256_movemask_ps(above) as u32;
        if pass == 0 {
            return 0;
        }
        let (o, rgb) = match &self.segments {
            Some(t) => t.eval(v),
            None => self.pairs_eval(v, pass),
        };
        // The samples with opacity.
        let shown = pass & _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(o, zero)) as u32;
        if shown == 0 {
            return 0;
        }
        // The opacity correction: 1 − (1 − o)^(len / reference).
        let mut common = 0u32;
        for h in 0..2 {
            let e = _mm256_mul_pd(ldd(&st.len, h), _mm256_set1_pd(self.inv_ref));
            let eq = _mm256_cmp_pd::<_CMP_EQ_OQ>(e, _mm256_set1_pd(self.common));
            common |= (_mm256_movemask_pd(eq) as u32) << (4 * h);
        }
        let mut tr = transmit_lanes(self.common, _mm256_sub_ps(one, o));
        let odd = shown & !common;
        if odd != 0 {
            let mut oa = [0f32; W];
            let mut ta = [0f32; W];
            st8(&mut oa, o);
            st8(&mut ta, tr);
            self.transmit_one_by_one(&oa, &st.len, odd, &mut ta);
            tr = ld8(&ta);
        }
        let shown_v = lanes_mask(shown);
        let alpha = _mm256_and_ps(_mm256_sub_ps(one, tr), shown_v);
        // The lit colour.
        let col = match &self.light {
            Light32::Unlit { ka_ambient } => finite(std::array::from_fn(|ch| {
                _mm256_mul_ps(_mm256_set1_ps(ka_ambient[ch]), rgb[ch])
            })),
            Light32::Lit { .. } => {
                let g = self.gradient(&p, &f, base, interior, shown, cache, &nodes, rows.as_ref());
                self.lit(st, g, rgb)
            }
        };
        // Front to back.
        let mut t = ld8(&st.t);
        let w = _mm256_mul_ps(t, alpha);
        for (ch, x) in col.into_iter().enumerate() {
            let acc = ld8(&st.col[ch]);
            st8(&mut st.col[ch], _mm256_fmadd_ps(w, x, acc));
        }
        t = _mm256_mul_ps(t, _mm256_sub_ps(one, alpha));
        st8(&mut st.t, t);
        let below = _mm256_cmp_ps::<_CMP_LT_OQ>(t, _mm256_set1_ps(self.stop));
        shown & _mm256_movemask_ps(below) as u32
    }

    /// The cells of object points `p`, as `Dataset::trilinear8` finds them: the weights
    /// within the cell, the cell's first node's index and, per lane, whether the cell's 4³
    /// neighbourhood lies inside the grid (`Dataset::interior8`).
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn cells(&self, p: &[__m256; 3]) -> ([__m256; 3], __m256i, __m256i) {
        let zero = _mm256_setzero_ps();
        let one = _mm256_set1_ps(1.0);
        let mut f = [zero; 3];
        let mut c = [_mm256_setzero_si256(); 3];
        let mut interior = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_EQ_OQ>(zero, zero));
        for axis in 0..3 {
            let l = _mm256_set1_ps(self.last[axis]);
            let ua = _mm256_min_ps(_mm256_max_ps(_mm256_mul_ps(p[axis], l), zero), l);
            let cu = _mm256_min_ps(ua, _mm256_set1_ps(self.top[axis]));
            let ci = _mm256_cvttps_epi32(cu);
            f[axis] = _mm256_sub_ps(ua, _mm256_cvtepi32_ps(ci));
            c[axis] = ci;
            let inside = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(cu, one),
                _mm256_cmp_ps::<_CMP_LT_OQ>(cu, _mm256_set1_ps(self.inner[axis])),
            );
            interior = _mm256_and_si256(interior, _mm256_castps_si256(inside));
        }
        let base = _mm256_add_epi32(
            c[0],
            _mm256_add_epi32(
                _mm256_mullo_epi32(c[1], _mm256_set1_epi32(self.sy)),
                _mm256_mullo_epi32(c[2], _mm256_set1_epi32(self.sz)),
            ),
        );
        (f, base, interior)
    }

    /// The next run of cursor `c`'s ray with a segment to take, as [`Packets::to_take`]'s
    /// bits (0: the ray has no sample left), its segments in `run`. The runs of segments are
    /// tested against the cell mask, which decides what is taken (exact, as the block walk
    /// is), but for the `trusted` runs after one it passed whole ([`TRUSTED_RUNS`]: all
    /// their segments of positive length taken); the walk is asked only after a run of which
    /// nothing is taken, and only where the ray is past the occupied blocks it last reported,
    /// to leap over empty blocks.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn next_taken(&self, c: &mut Cursor, run: &mut Run16, trusted: &mut u32) -> u32 {
        loop {
            if c.k >= c.n {
                return 0;
            }
            let test = *trusted == 0;
            *trusted = trusted.saturating_sub(1);
            let (m, candidates, keep) = self.run16_avx2(c, run, test);
            if test && keep != 0 && keep == candidates {
                *trusted = self.trusted_runs;
            }
            c.k += m as u64;
            if keep != 0 {
                return keep;
            }
            if c.k >= c.n {
                return 0;
            }
            self.after_nothing_taken(c, 2 * W);
        }
    }

    /// Cursor `c`'s next segments, up to sixteen (there is one), into `run` as two runs of
    /// eight ([`segments_lanes`]' numbers from the cursor's next segment and the eighth after
    /// it), and those [`Packets::to_take`] takes of each, by bit (the second's from bit 8):
    /// their number, the bits of the segments of positive length (or NaN) and the bits taken,
    /// those of the former the mask passes (all of them, untested, where `test` is false). A
    /// cursor near 2⁵³ segments, or without a mask, takes runs of eight (tested, and as
    /// candidates the complement of those taken: never passed whole).
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn run16_avx2(&self, c: &Cursor, run: &mut Run16, test: bool) -> (usize, u32, u32) {
        let (m0, m1) = run.mids.split_at_mut(W);
        let (l0, l1) = run.lens.split_at_mut(W);
        fn eight(x: &mut [f64]) -> &mut [f64; W] {
            x.try_into().expect("eight")
        }
        let (m0, m1, l0, l1) = (eight(m0), eight(m1), eight(l0), eight(l1));
        if index_f64(c.k, c.n) >= (1u64 << 53) as f64 - 32.0 || self.mask.is_empty() {
            let m = segments_lanes(c, m0, l0);
            let keep = self.to_take(c, m0, l0, m);
            return (m, !keep, keep);
        }
        // (The mask is not empty past the return above, as `mask_bits` needs.)
        let take = |mids: &[f64; W], lens: &[f64; W], m: usize| {
            let candidates = candidates(lens, m);
            let keep = if test && candidates != 0 {
                candidates & self.mask_bits(&object_points(c, mids))
            } else {
                if !test {
                    count_untested();
                }
                candidates
            };
            (candidates, keep)
        };
        let n0 = segments_from(c, c.k, m0, l0);
        let (cand0, keep0) = take(m0, l0, n0);
        if c.n - c.k <= W as u64 {
            return (n0, cand0, keep0);
        }
        let n1 = segments_from(c, c.k + W as u64, m1, l1);
        let (cand1, keep1) = take(m1, l1, n1);
        (n0 + n1, cand0 | cand1 << W, keep0 | keep1 << W)
    }

    /// After a run of cursor `c` of which nothing was taken (and with a segment left): where
    /// its next sample is past the occupied blocks the walk last reported, asks the walk (made
    /// here on first use) about it and the next run's length of samples after it, and passes
    /// over the empty blocks it reports.
    #[inline]
    fn after_nothing_taken(&self, c: &mut Cursor, run: usize) {
        let next = c.mid(c.k);
        if next >= c.occupied_until {
            if let Some(grid) = self.grid {
                let walk = match c.walk.as_mut() {
                    Some(w) => w,
                    None => grid.walk_into(&mut c.walk, c.o, c.d, next),
                };
                let horizon = next + run as f64 * c.step;
                match walk.skip_until(grid, next, horizon) {
                    Ok(exit) => c.pass_before(exit),
                    Err(until) => c.occupied_until = until,
                }
            }
        }
    }

    /// Cursor `c`'s next segments, up to eight (there is one), written into `run`
    /// ([`segments_lanes`]), and those [`Packets::to_take`] takes: their number and the bits.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn run_at(&self, c: &Cursor, run: &mut Run) -> (usize, u32) {
        let m = segments_lanes(c, &mut run.mids, &mut run.lens);
        (m, self.to_take(c, &run.mids, &run.lens, m))
    }

    /// The segments of a run (`m` of them, 1 to 8, at midpoints `mids` with lengths `lens`
    /// on the ray of cursor `c`) that [`Packets::step`] must take, by bit: those of positive
    /// length (or NaN) whose sample lies in a cell the cell mask says may reach the bound.
    /// Every other segment adds nothing to its ray (the scalar march drops it too), so it
    /// needs no lane: in the measured frame about half of the segments the block walk gives.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn to_take(&self, c: &Cursor, mids: &[f64; 8], lens: &[f64; 8], m: usize) -> u32 {
        let keep = candidates(lens, m);
        if self.mask.is_empty() || keep == 0 {
            return keep;
        }
        keep & self.mask_bits(&object_points(c, mids))
    }

    /// By bit, the object points `p` whose cell the cell mask says may reach the bound (a
    /// cell past the mask's end may); the mask is not empty.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn mask_bits(&self, p: &[__m256; 3]) -> u32 {
        let (_, base, _) = self.cells(p);
        let word = _mm256_srli_epi32::<5>(base);
        let words = gather_u32(self.mask, word);
        let bit = _mm256_and_si256(
            _mm256_srlv_epi32(words, _mm256_and_si256(base, _mm256_set1_epi32(31))),
            _mm256_set1_epi32(1),
        );
        let past = _mm256_cmpgt_epi32(word, _mm256_set1_epi32(self.mask.len() as i32 - 1));
        let reach = _mm256_or_si256(_mm256_cmpeq_epi32(bit, _mm256_set1_epi32(1)), past);
        _mm256_movemask_ps(_mm256_castsi256_ps(reach)) as u32
    }

    /// Opacity and colour of values `v` from the tables' segment pairs (gathers), the lanes
    /// of `pass` whose bucket has none by the tables' general evaluation.
    #[target_feature(enable = "avx2,fma")]
    fn pairs_eval(&self, v: __m256, pass: u32) -> (__m256, [__m256; 3]) {
        let zero = _mm256_setzero_ps();
        let one = _mm256_set1_ps(1.0);
        let bucket = _mm256_cvttps_epi32(_mm256_mul_ps(v, _mm256_set1_ps(1024.0)));
        let pair = gather_i32(&self.bucket_pair, bucket);
        let general = pass
            & _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(
                _mm256_setzero_si256(),
                pair,
            ))) as u32;
        let q = |k: usize| gather(&self.pairs[k], pair);
        let clamp = |x: __m256| _mm256_min_ps(_mm256_max_ps(x, zero), one);
        let dxo = _mm256_sub_ps(v, q(0));
        let dxc = _mm256_sub_ps(v, q(1));
        let mut o = clamp(_mm256_fmadd_ps(dxo, q(6), q(2)));
        let mut rgb = [
            clamp(_mm256_fmadd_ps(dxc, q(7), q(3))),
            clamp(_mm256_fmadd_ps(dxc, q(8), q(4))),
            clamp(_mm256_fmadd_ps(dxc, q(9), q(5))),
        ];
        if general != 0 {
            let mut vs = [0f32; W];
            st8(&mut vs, v);
            let mut oa = [0f32; W];
            let mut ca = [[0f32; W]; 3];
            st8(&mut oa, o);
            for ch in 0..3 {
                st8(&mut ca[ch], rgb[ch]);
            }
            for i in 0..W {
                if general >> i & 1 != 0 {
                    let (oi, ci) = self.tables.opacity_colour_general(vs[i]);
                    oa[i] = oi;
                    let ci = ci.unwrap_or([0.0; 3]);
                    for ch in 0..3 {
                        ca[ch][i] = ci[ch];
                    }
                }
            }
            o = ld8(&oa);
            for ch in 0..3 {
                rgb[ch] = ld8(&ca[ch]);
            }
        }
        (o, rgb)
    }

    /// The object-space gradients of the lanes in `shown` (at points `p`, cells `base` with
    /// weights `f`, `interior` as `Dataset::interior8`, cell nodes `nodes`): in interior
    /// cells by per-lane loads (`Nodes`), with `Dataset::trilinear_gradient_at`'s f32 operations in its order;
    /// in the others by `Dataset::gradient_cached`. The scale 0.5·(n − 1) applied; where a
    /// gradient vanishes, NaN.
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx2,fma")]
    fn gradient(
        &self,
        p: &[__m256; 3],
        f: &[__m256; 3],
        base: __m256i,
        interior: __m256i,
        shown: u32,
        cache: &mut CellGradients,
        nodes: &[__m256; 8],
        rows: Option<&Rows>,
    ) -> [__m256; 3] {
        let zero = _mm256_setzero_ps();
        let one = _mm256_set1_ps(1.0);
        let inner = shown & _mm256_movemask_ps(_mm256_castsi256_ps(interior)) as u32;
        let mut g = [zero; 3];
        if inner != 0 {
            let (d, scale) = match (&self.raw8, rows) {
                (Some(r8), Some(rows)) => (
                    r8.differences(rows, base, inner, self.sy, self.sz),
                    r8.scale,
                ),
                _ => (self.differences(base, inner, nodes), 1.0),
            };
            let [fx, fy, fz] = *f;
            let (gx, gy, gz) = (
                _mm256_sub_ps(one, fx),
                _mm256_sub_ps(one, fy),
                _mm256_sub_ps(one, fz),
            );
            let wx = [gx, fx];
            let wy = [gy, fy];
            let wz = [gz, fz];
            for (k, d) in d.iter().enumerate() {
                let (a, b, cc) = (k & 1, k >> 1 & 1, k >> 2);
                // The weight (wx·wy)·wz, as the scalar lanes take it.
                let w = _mm256_mul_ps(_mm256_mul_ps(wx[a], wy[b]), wz[cc]);
                for axis in 0..3 {
                    let prod = _mm256_mul_ps(w, d[axis]);
                    g[axis] = if k == 0 {
                        prod
                    } else {
                        _mm256_add_ps(g[axis], prod)
                    };
                }
            }
            for (axis, ga) in g.iter_mut().enumerate() {
                // (Raw differences: times the normalisation's scale too, in one product.)
                let s = if scale == 1.0 {
                    self.half_last[axis]
                } else {
                    self.half_last[axis] * scale
                };
                *ga = _mm256_mul_ps(*ga, _mm256_set1_ps(s));
            }
        }
        let outer = shown & !inner;
        if outer != 0 {
            let mut pa = [[0f32; W]; 3];
            let mut ga = [[0f32; W]; 3];
            for axis in 0..3 {
                st8(&mut pa[axis], p[axis]);
                st8(&mut ga[axis], g[axis]);
            }
            self.gradients_one_by_one(&pa, outer, cache, &mut ga);
            for axis in 0..3 {
                g[axis] = ld8(&ga[axis]);
            }
        }
        g
    }

    /// The central differences along x, y and z at the eight corners (a + 2b + 4c) of the
    /// cells whose first nodes are `base`, for the lanes of `inner` (whose 4³ neighbourhoods
    /// lie inside the grid), from the node values (cell nodes `nodes`, the others by per-lane
    /// loads): the node on the far side minus the node on the near side, one of them a cell
    /// node.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn differences(&self, base: __m256i, inner: u32, nodes: &[__m256; 8]) -> [[__m256; 3]; 8] {
        let (sy, sz) = (self.sy, self.sz);
        // The neighbourhood's first node: the cell's less (1, 1, 1).
        let lo = _mm256_sub_epi32(base, _mm256_set1_epi32(1 + sy + sz));
        let lo = _mm256_and_si256(lo, _mm256_castps_si256(lanes_mask(inner)));
        let hood = Nodes::new(self.values, lo, 3 + 3 * sy + 3 * sz);
        let o = |j: i32, k: i32| 1 + j * sy + k * sz;
        // The nodes beside the cell: along y and z as x-pairs (the cell's two x nodes),
        // along x the first and last of the cell's rows of four.
        let two = |j0: i32, k0: i32, j1: i32, k1: i32| {
            let [a, b, c, d] = hood.pairs2(o(j0, k0), o(j1, k1));
            [(a, b), (c, d)]
        };
        let (ym, yp) = (two(0, 1, 0, 2), two(3, 1, 3, 2));
        let (zm, zp) = (two(1, 0, 2, 0), two(1, 3, 2, 3));
        let r = |b: i32, c: i32| hood.row4(o(1 + b, 1 + c) - 1);
        let rows = [r(0, 0), r(1, 0), r(0, 1), r(1, 1)];
        let (xm, xp) = (rows.map(|r| r[0]), rows.map(|r| r[3]));
        let pick = |p: (__m256, __m256), a: usize| if a == 0 { p.0 } else { p.1 };
        // (A loop, not a `from_fn` closure, which the compiler left out of line.)
        let mut d = [[_mm256_setzero_ps(); 3]; 8];
        for (k, dk) in d.iter_mut().enumerate() {
            let (a, b, cc) = (k & 1, k >> 1 & 1, k >> 2);
            let node = |a: usize, b: usize, cc: usize| nodes[a + 2 * b + 4 * cc];
            let row = b + 2 * cc;
            let dx = if a == 0 {
                _mm256_sub_ps(node(1, b, cc), xm[row])
            } else {
                _mm256_sub_ps(xp[row], node(0, b, cc))
            };
            let dy = if b == 0 {
                _mm256_sub_ps(node(a, 1, cc), pick(ym[cc], a))
            } else {
                _mm256_sub_ps(pick(yp[cc], a), node(a, 0, cc))
            };
            let dz = if cc == 0 {
                _mm256_sub_ps(node(a, b, 1), pick(zm[b], a))
            } else {
                _mm256_sub_ps(pick(zp[b], a), node(a, b, 0))
            };
            *dk = [dx, dy, dz];
        }
        d
    }

    /// The lit colours of samples of colours `rgb` and object-space gradients `g`:
    /// [`HeadlitLanes::colours_at`]'s operations in f32.
    #[target_feature(enable = "avx2,fma")]
    fn lit(&self, st: &State, g: [__m256; 3], rgb: [__m256; 3]) -> [__m256; 3] {
        let Light32::Lit {
            ka_ambient,
            kd,
            ks,
            e,
            to_light,
            radiance,
            flip,
            to_world,
            diagonal,
        } = &self.light
        else {
            unreachable!("lit lanes")
        };
        let zero = _mm256_setzero_ps();
        let one = _mm256_set1_ps(1.0);
        let neg = _mm256_set1_ps(-0.0);
        let s = |x: f32| _mm256_set1_ps(x);
        // Vanishing: the largest component in magnitude at most `ZERO_GRADIENT`.
        let abs = |x: __m256| _mm256_andnot_ps(neg, x);
        let a = _mm256_max_ps(abs(g[0]), _mm256_max_ps(abs(g[1]), abs(g[2])));
        let vanishes = _mm256_cmp_ps::<_CMP_LE_OQ>(a, s(ZERO_GRADIENT as f32));
        let g: [__m256; 3] = if *diagonal {
            std::array::from_fn(|i| _mm256_mul_ps(s(to_world[i][i]), g[i]))
        } else {
            let [x, y, z] = to_world;
            std::array::from_fn(|i| {
                _mm256_fmadd_ps(
                    s(z[i]),
                    g[2],
                    _mm256_fmadd_ps(s(y[i]), g[1], _mm256_mul_ps(s(x[i]), g[0])),
                )
            })
        };
        let dot = |a: &[__m256; 3], b: &[__m256; 3]| {
            _mm256_fmadd_ps(
                a[2],
                b[2],
                _mm256_fmadd_ps(a[1], b[1], _mm256_mul_ps(a[0], b[0])),
            )
        };
        let rcp = _mm256_div_ps(one, _mm256_sqrt_ps(dot(&g, &g)));
        let valid = _mm256_andnot_ps(
            vanishes,
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(rcp, zero),
                _mm256_cmp_ps::<_CMP_LT_OQ>(rcp, s(f32::INFINITY)),
            ),
        );
        let un: [__m256; 3] = std::array::from_fn(|i| _mm256_mul_ps(g[i], rcp));
        let l = to_light.map(s);
        let view = [ld8(&st.view[0]), ld8(&st.view[1]), ld8(&st.view[2])];
        let ndl_u = dot(&un, &l);
        let sign = if *flip {
            let front = _mm256_cmp_ps::<_CMP_GT_OQ>(dot(&un, &view), zero);
            _mm256_andnot_ps(front, neg)
        } else {
            neg
        };
        let ndl = _mm256_xor_ps(ndl_u, sign);
        let lit = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(ndl, zero), valid);
        let m = _mm256_or_ps(_mm256_and_ps(ndl, lit), _mm256_andnot_ps(valid, one));
        let mut term: [__m256; 3] =
            std::array::from_fn(|ch| _mm256_mul_ps(_mm256_mul_ps(s(*kd), rgb[ch]), m));
        if let Some(ks) = ks {
            let two = _mm256_add_ps(ndl_u, ndl_u);
            let r: [__m256; 3] = std::array::from_fn(|i| _mm256_fmsub_ps(two, un[i], l[i]));
            let rv = dot(&r, &view);
            let spec = _mm256_and_ps(lit, _mm256_cmp_ps::<_CMP_GT_OQ>(rv, zero));
            if _mm256_movemask_ps(spec) != 0 {
                // rv^e by binary exponentiation.
                let (mut x, mut k, mut pw) = (rv, *e, one);
                loop {
                    if k & 1 != 0 {
                        pw = _mm256_mul_ps(pw, x);
                    }
                    k >>= 1;
                    if k == 0 {
                        break;
                    }
                    x = _mm256_mul_ps(x, x);
                }
                let p = _mm256_and_ps(_mm256_mul_ps(s(*ks), pw), spec);
                term = term.map(|x| _mm256_add_ps(x, p));
            }
        }
        finite(std::array::from_fn(|ch| {
            _mm256_fmadd_ps(
                s(radiance[ch]),
                term[ch],
                _mm256_mul_ps(s(ka_ambient[ch]), rgb[ch]),
            )
        }))
    }
}

/// A transfer function's output column as linear pieces, by the number k of breakpoints
/// below the input (the segment [`Mapping::locate`] finds): `Φ(v) = base[k] + (v −
/// start[k])·slope[k]` for v in (0, 1] (the pieces of [`Mapping::eval_at`], in f32; an
/// input of 0 never gets here: it fails the zero test), then clamped as a field value.
struct Segs {
    a: Vec<f32>,
    start: [f32; 8],
    base: [f32; 8],
    slope: [f32; 8],
}

impl Segs {
    /// The pieces of column `j` of `m`, where it has at most seven rows.
    fn new(m: &Mapping, j: usize) -> Option<Segs> {
        let a = m.breakpoints();
        let n = a.len();
        if n > 7 {
            return None;
        }
        let (mut start, mut base, mut slope) = ([0f32; 8], [0f32; 8], [0f32; 8]);
        let b = |i: usize| m.b(i, j) as f64;
        for k in 0..=n {
            let (s0, b0, sl) = match m.kind() {
                MappingType::Lookup => (0.0, if k == 0 || k == n { 0.0 } else { b(k) }, 0.0),
                MappingType::Ramp if k == 0 => {
                    // 0 < v ≤ a_1: v·b_1/a_1 (a_1 > 0 there).
                    let a1 = a[0] as f64;
                    (0.0, 0.0, if a1 > 0.0 { b(0) / a1 } else { 0.0 })
                }
                MappingType::Ramp if k == n => {
                    // a_n < v ≤ 1: towards (1, 1).
                    let an = a[n - 1] as f64;
                    let s = if an < 1.0 {
                        (1.0 - b(n - 1)) / (1.0 - an)
                    } else {
                        0.0
                    };
                    (an, b(n - 1), s)
                }
                MappingType::Ramp => {
                    // Between rows k − 1 and k: the mapping's own segment (a, b, slope).
                    let seg = m.segment(k - 1);
                    (seg[0], seg[1 + 2 * j], seg[2 + 2 * j])
                }
            };
            start[k] = s0 as f32;
            base[k] = b0 as f32;
            slope[k] = sl as f32;
        }
        Some(Segs {
            a: a.to_vec(),
            start,
            base,
            slope,
        })
    }
}

/// The opacity and colour tables as [`Segs`].
struct Segments {
    o: Segs,
    rgb: [Segs; 3],
}

impl Segments {
    /// Opacity and colour of values `v` (in [0, 1]), each clamped to [0, 1].
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn eval(&self, v: __m256) -> (__m256, [__m256; 3]) {
        let zero = _mm256_setzero_ps();
        let one = _mm256_set1_ps(1.0);
        let count = |a: &[f32]| {
            let mut k = _mm256_setzero_si256();
            for &x in a {
                let below = _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_set1_ps(x), v);
                k = _mm256_sub_epi32(k, _mm256_castps_si256(below));
            }
            k
        };
        let piece = |s: &Segs, k: __m256i| {
            let at = |t: &[f32; 8]| _mm256_permutevar8x32_ps(ld8(t), k);
            let x = _mm256_fmadd_ps(_mm256_sub_ps(v, at(&s.start)), at(&s.slope), at(&s.base));
            _mm256_min_ps(_mm256_max_ps(x, zero), one)
        };
        let ko = count(&self.o.a);
        let kc = count(&self.rgb[0].a);
        (
            piece(&self.o, ko),
            [
                piece(&self.rgb[0], kc),
                piece(&self.rgb[1], kc),
                piece(&self.rgb[2], kc),
            ],
        )
    }
}

/// [`Cursor::segments`] in lanes: the cursor's next segments (there is one), up to eight,
/// their midpoints and lengths written into `mids` and `lens`, the same numbers bit for bit
/// (`lanes_segments_are_the_cursors`); their number returned. Boundary j of the run is
/// `t0 + (k + j)·step` (k + j exact in f64: k below 2⁵³ − 16, else the cursor's own loop), a
/// segment ends at the next boundary where that is below t1 and at t1 otherwise, and the
/// cursor's last segment at t1.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn segments_lanes(c: &Cursor, mids: &mut [f64; W], lens: &mut [f64; W]) -> usize {
    if index_f64(c.k, c.n) >= (1u64 << 53) as f64 - 16.0 {
        return c.segments(mids, lens);
    }
    segments_from(c, c.k, mids, lens)
}

/// [`segments_lanes`] from segment `from` (below the count and 2⁵³ − 16) instead of the
/// cursor's next.
#[inline]
#[target_feature(enable = "avx2")]
fn segments_from(c: &Cursor, from: u64, mids: &mut [f64; W], lens: &mut [f64; W]) -> usize {
    let k = index_f64(from, c.n);
    let t0 = _mm256_set1_pd(c.t0);
    let t1 = _mm256_set1_pd(c.t1);
    let step = _mm256_set1_pd(c.step);
    // The count as f64: exact up to 2⁵³; above, every k + j + 1 here is below it.
    let n = _mm256_set1_pd(index_f64(c.n, c.n));
    let one = _mm256_set1_pd(1.0);
    for h in 0..2 {
        let first = (4 * h) as f64;
        let j = _mm256_add_pd(
            _mm256_set1_pd(k),
            _mm256_setr_pd(first, first + 1.0, first + 2.0, first + 3.0),
        );
        let a = _mm256_add_pd(t0, _mm256_mul_pd(j, step));
        let j1 = _mm256_add_pd(j, one);
        let next = _mm256_add_pd(t0, _mm256_mul_pd(j1, step));
        // `at_most` (minpd gives its second operand unless the first is below it), then t1
        // for the cursor's last segment (and the meaningless lanes past it).
        let b = _mm256_min_pd(next, t1);
        let b = _mm256_blendv_pd(b, t1, _mm256_cmp_pd::<_CMP_GE_OQ>(j1, n));
        std8d(
            mids,
            h,
            _mm256_mul_pd(_mm256_set1_pd(0.5), _mm256_add_pd(a, b)),
        );
        std8d(lens, h, _mm256_sub_pd(b, a));
    }
    (c.n - from).min(W as u64) as usize
}

/// For every lane whose run has a segment left to take (a bit of its `keeps` word): that
/// segment's midpoint and length into `st` (the lowest bit's segment of its run), and the bit
/// cleared. Returns those lanes. In lanes: the lowest bit of each word by `x & −x`, its index
/// from the exponent of that power of two as f32, the segments by gathers from the runs.
#[inline]
#[target_feature(enable = "avx2")]
fn next_segments(keeps: &mut [u32; W], runs: &[Run16; W], st: &mut State) -> u32 {
    // SAFETY: `keeps` is 8 u32, 32 readable and writable bytes; no alignment requirement.
    let k = unsafe { _mm256_loadu_si256(keeps.as_ptr() as *const __m256i) };
    let zero = _mm256_setzero_si256();
    let has = _mm256_cmpeq_epi32(k, zero);
    let active = !(_mm256_movemask_ps(_mm256_castsi256_ps(has)) as u32) & 0xff;
    if active == 0 {
        return 0;
    }
    // Every bit is below 16 (runs of at most sixteen segments), so the lowest as f32 is
    // exact and its exponent field is 127 + its index; a word of 0 gives index
    // 15 & (0 − 127): in range, and its lane is not active.
    let low = _mm256_and_si256(k, _mm256_sub_epi32(zero, k));
    let e = _mm256_srli_epi32::<23>(_mm256_castps_si256(_mm256_cvtepi32_ps(low)));
    let j = _mm256_and_si256(
        _mm256_sub_epi32(e, _mm256_set1_epi32(127)),
        _mm256_set1_epi32(15),
    );
    let rest = _mm256_and_si256(k, _mm256_add_epi32(k, _mm256_set1_epi32(-1)));
    // SAFETY: as above.
    unsafe { _mm256_storeu_si256(keeps.as_mut_ptr() as *mut __m256i, rest) };
    // Lane i's segment j: f64 number 32·i + j of the runs (its midpoints), + 16 (its lengths).
    const RUN: i32 = (std::mem::size_of::<Run16>() / std::mem::size_of::<f64>()) as i32;
    let at = _mm256_add_epi32(
        _mm256_mullo_epi32(
            _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
            _mm256_set1_epi32(RUN),
        ),
        j,
    );
    let base = runs.as_ptr() as *const f64;
    for h in 0..2 {
        let idx = if h == 0 {
            _mm256_castsi256_si128(at)
        } else {
            _mm256_extracti128_si256::<1>(at)
        };
        // SAFETY: `Run16` is two arrays of 16 f64 (`repr(C)`), so f64 number 32·i + j and
        // 32·i + 16 + j (i in 0..8, j in 0..16) lie inside the 8 runs; gathers need no
        // alignment.
        let (mid, len) = unsafe {
            (
                _mm256_i32gather_pd::<8>(base, idx),
                _mm256_i32gather_pd::<8>(base.add(2 * W), idx),
            )
        };
        std8d(&mut st.mid, h, mid);
        std8d(&mut st.len, h, len);
    }
    active
}

/// A dataset's 8-bit voxels, where its normalisation `(v − a)/(b − a)` maps every byte into
/// [0, 1] (so it never clamps, and is linear): the packet march reads the voxels themselves,
/// four to a 32-bit lane by gathers, a quarter of the node values' memory, and normalises a
/// sample's interpolated value once (`raw·scale + offset`) and its gradient by `scale`
/// (the differences of bytes are exact integers). The node values are the voxels'
/// normalisations in f64 rounded to f32, so a sample's value differs from the value
/// interpolated from those by f32 rounding: relative errors of a few 10⁻⁷ (the packet march's
/// tolerance against the scalar march, `tests/packets.rs`).
struct Raw8<'a> {
    raw: &'a [u8],
    scale: f32,
    offset: f32,
}

impl<'a> Raw8<'a> {
    /// The voxels of `data`, where they are 8-bit and its normalisation maps 0 and 255 into
    /// [0, 1] (every byte between, then: the normalisation is monotone).
    fn of(data: &'a Dataset) -> Option<Raw8<'a>> {
        let Voxels::U8(raw) = data.raw() else {
            return None;
        };
        let (a, b) = data.range();
        let (a, b) = (a as f64, b as f64);
        let norm = |v: f64| (v - a) / (b - a);
        let inside = |x: f64| (0.0..=1.0).contains(&x);
        if !(inside(norm(0.0)) && inside(norm(255.0))) || raw.len() >= i32::MAX as usize / 2 {
            return None;
        }
        Some(Raw8 {
            raw,
            scale: (1.0 / (b - a)) as f32,
            offset: (-a / (b - a)) as f32,
        })
    }

    /// The central rows of the cells whose first nodes are `base`, for the lanes of `live`:
    /// for (b, c) in (0, 0), (1, 0), (0, 1), (1, 1), the four voxels x0 − 1 … x0 + 2 of row
    /// y0 + b, z0 + c, one per byte (the lowest first). A lane whose row reaches past either
    /// end of the voxels (the very first cell, or the last) is read voxel by voxel, with 0
    /// past the end (only interior cells, whose rows lie inside, read the outer two).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn central_rows(&self, base: __m256i, live: u32, sy: i32, sz: i32) -> Rows {
        let span = sy + sz + 3;
        let first = _mm256_sub_epi32(base, _mm256_set1_epi32(1));
        let hi = _mm256_set1_epi32(self.raw.len() as i32 - 1 - span);
        let at = _mm256_min_epi32(_mm256_max_epi32(first, _mm256_setzero_si256()), hi);
        let kept = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(at, first)));
        if !(kept as u32) & live != 0 {
            return self.rows_one_by_one(first, central_offsets(sy, sz));
        }
        let mut r = [at; 4];
        for (w, off) in r.iter_mut().zip(central_offsets(sy, sz)) {
            *w = gather_bytes(self.raw, _mm256_add_epi32(at, _mm256_set1_epi32(off)));
        }
        Rows { r }
    }

    /// [`Raw8::central_rows`] voxel by voxel: the four voxels from `first + off` per lane
    /// and offset, 0 where one lies outside.
    #[cold]
    #[inline(never)]
    #[target_feature(enable = "avx2")]
    fn rows_one_by_one(&self, first: __m256i, offs: [i32; 4]) -> Rows {
        let mut at = [0i32; W];
        st8i(&mut at, first);
        let byte = |i: i64| -> u32 {
            usize::try_from(i)
                .ok()
                .and_then(|i| self.raw.get(i))
                .map_or(0, |&v| v as u32)
        };
        Rows {
            r: offs.map(|off| {
                let words: [i32; W] = std::array::from_fn(|lane| {
                    let i = at[lane] as i64 + off as i64;
                    (0..4).fold(0u32, |w, k| w | byte(i + k) << (8 * k)) as i32
                });
                ld8i(&words)
            }),
        }
    }

    /// The central differences along x, y and z at the eight corners (a + 2b + 4c) of the
    /// cells whose first nodes are `base` and central rows `rows`, for the lanes of `inner`
    /// (whose 4³ neighbourhoods lie inside the grid), in raw voxels: exact integers, as f32.
    /// The rows beside the cell along y and z by eight more gathers (two voxels of each).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn differences(
        &self,
        rows: &Rows,
        base: __m256i,
        inner: u32,
        sy: i32,
        sz: i32,
    ) -> [[__m256; 3]; 8] {
        let base = _mm256_and_si256(base, _mm256_castps_si256(lanes_mask(inner)));
        let hi = _mm256_set1_epi32(self.raw.len() as i32 - 4);
        let zero = _mm256_setzero_si256();
        let mut side = [zero; 8];
        // Rows y0 − 1 and y0 + 2 at z0 + c, rows z0 − 1 and z0 + 2 at y0 + b (from x0): the
        // index clamped (a no-op for an interior cell's lane).
        for (w, off) in side.iter_mut().zip(side_offsets(sy, sz)) {
            let at = _mm256_add_epi32(base, _mm256_set1_epi32(off));
            *w = gather_bytes(self.raw, _mm256_min_epi32(_mm256_max_epi32(at, zero), hi));
        }
        let [ym0, ym1, yp0, yp1, zm0, zm1, zp0, zp1] = side;
        let (ym, yp, zm, zp) = ([ym0, ym1], [yp0, yp1], [zm0, zm1], [zp0, zp1]);
        let r = &rows.r;
        // Byte k of a row as i32: node x0 + a is byte 1 + a of a central row, byte a of a
        // side row.
        let b = |w: &[__m256i; 4], i: usize| -> [__m256i; 4] {
            let x = w[i];
            [byte::<0>(x), byte::<1>(x), byte::<2>(x), byte::<3>(x)]
        };
        let rb = [b(r, 0), b(r, 1), b(r, 2), b(r, 3)];
        let two = |w: __m256i| [byte::<0>(w), byte::<1>(w)];
        let (ym, yp, zm, zp) = (ym.map(two), yp.map(two), zm.map(two), zp.map(two));
        let mut d = [[_mm256_setzero_ps(); 3]; 8];
        for (k, dk) in d.iter_mut().enumerate() {
            let (a, b, c) = (k & 1, k >> 1 & 1, k >> 2);
            let row = &rb[b + 2 * c];
            let dx = _mm256_sub_epi32(row[2 + a], row[a]);
            let dy = if b == 0 {
                _mm256_sub_epi32(rb[1 + 2 * c][1 + a], ym[c][a])
            } else {
                _mm256_sub_epi32(yp[c][a], rb[2 * c][1 + a])
            };
            let dz = if c == 0 {
                _mm256_sub_epi32(rb[b + 2][1 + a], zm[b][a])
            } else {
                _mm256_sub_epi32(zp[b][a], rb[b][1 + a])
            };
            *dk = [
                _mm256_cvtepi32_ps(dx),
                _mm256_cvtepi32_ps(dy),
                _mm256_cvtepi32_ps(dz),
            ];
        }
        d
    }
}

/// The central rows of eight cells ([`Raw8::central_rows`]): four voxels a lane, in its bytes.
struct Rows {
    r: [__m256i; 4],
}

impl Rows {
    /// The eight cell nodes (a + 2b + 4c: x0 + a of row (b, c), its byte 1 + a) as f32.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn cell_nodes(&self) -> [__m256; 8] {
        let r = &self.r;
        std::array::from_fn(|k| {
            let w = r[k >> 1];
            _mm256_cvtepi32_ps(if k & 1 == 0 {
                byte::<1>(w)
            } else {
                byte::<2>(w)
            })
        })
    }
}

/// Byte `K` of each 32-bit lane of `w`.
#[inline]
#[target_feature(enable = "avx2")]
fn byte<const K: i32>(w: __m256i) -> __m256i {
    let shifted = match K {
        0 => w,
        1 => _mm256_srli_epi32::<8>(w),
        2 => _mm256_srli_epi32::<16>(w),
        _ => return _mm256_srli_epi32::<24>(w),
    };
    _mm256_and_si256(shifted, _mm256_set1_epi32(0xff))
}

/// The four bytes of `raw` from `at` in each lane, as one 32-bit word (the lowest first), by
/// a gather; every lane of `at` must be in `[0, raw.len() − 4]` (asserted per call for the
/// bounds, not per lane: the callers clamp).
#[inline]
#[target_feature(enable = "avx2")]
fn gather_bytes(raw: &[u8], at: __m256i) -> __m256i {
    // SAFETY: every lane of `at` is in [0, raw.len() − 4] (the callers clamp to it), so the
    // four bytes each lane reads lie inside `raw`; a gather of scale 1 reads unaligned words.
    unsafe { _mm256_i32gather_epi32::<1>(raw.as_ptr() as *const i32, at) }
}

/// The eight i32 of `a` as a register.
#[inline]
#[target_feature(enable = "avx")]
fn ld8i(a: &[i32; W]) -> __m256i {
    // SAFETY: `a` is 8 i32, 32 readable bytes; the load has no alignment requirement.
    unsafe { _mm256_loadu_si256(a.as_ptr() as *const __m256i) }
}

/// Stores the register `v` into the eight i32 of `a`.
#[inline]
#[target_feature(enable = "avx")]
fn st8i(a: &mut [i32; W], v: __m256i) {
    // SAFETY: `a` is 8 i32, 32 writable bytes; the store has no alignment requirement.
    unsafe { _mm256_storeu_si256(a.as_mut_ptr() as *mut __m256i, v) }
}

/// What a tile's rays share: the camera, the entry map, the image's rays, the colour of an
/// unbounded pixel, the tile's corner and size.
struct TileRays<'a> {
    view: &'a Pinhole,
    entry: Option<&'a EntryMap>,
    image: &'a ImageRays,
    unbounded: Option<[f32; 3]>,
    origin: (u32, u32),
    size: (u32, u32),
}

/// Where a started ray's cursor begins: at segment k, or at the first segment whose midpoint
/// is not before t (`Cursor::start_at`).
#[derive(Clone, Copy, Debug)]
enum Start {
    At(u64),
    Before(f64),
}

/// A tile's ray that takes samples ([`Packets::make_starts`]): its pixel (in the tile), its
/// object-space direction, its view direction (towards the eye, as the lighting takes it),
/// its span [t0, t1] in the object's box, its segment count and its first segment.
#[derive(Clone, Copy, Debug)]
struct RayStart {
    px: u32,
    d: [f64; 3],
    view: [f32; 3],
    t0: f64,
    t1: f64,
    n: u64,
    k: Start,
}

/// The started rays of a tile's last four pixels not yet given a lane, and the next pixel.
struct Starts {
    ready: [RayStart; 4],
    len: usize,
    at: usize,
    next: u32,
}

impl Default for Starts {
    fn default() -> Starts {
        let none = RayStart {
            px: 0,
            d: [0.0; 3],
            view: [0.0; 3],
            t0: 0.0,
            t1: 0.0,
            n: 0,
            k: Start::At(0),
        };
        Starts {
            ready: [none; 4],
            len: 0,
            at: 0,
            next: 0,
        }
    }
}

/// The unit directions of `Pinhole::ray` through the centres of pixels (x0 + l, y) for l in
/// 0..4, and their object-space directions by `to_object.transform_vector3`, in f64 lanes by
/// axis: each lane those functions' operations in their order, so the same numbers
/// (`ray_lanes_are_the_rays`).
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn ray_lanes(
    view: &Pinhole,
    to_object: &DMat4,
    x0: u32,
    y: u32,
) -> ([__m256d; 3], [__m256d; 3]) {
    let splat = _mm256_set1_pd;
    let x: [f64; 4] = std::array::from_fn(|l| (x0 + l as u32) as f64 + 0.5);
    let sy = 1.0 - (y as f64 + 0.5) / view.height as f64 * 2.0;
    let sx = _mm256_sub_pd(
        _mm256_mul_pd(_mm256_div_pd(ld4(&x), splat(view.width as f64)), splat(2.0)),
        splat(1.0),
    );
    // (forward + sx·right) + sy·up, then times 1/√(v·v). (Loops, not `from_fn` closures,
    // which the compiler left out of line.)
    let mut v = [sx; 3];
    for (c, v) in v.iter_mut().enumerate() {
        *v = _mm256_add_pd(
            _mm256_add_pd(
                splat(view.forward[c]),
                _mm256_mul_pd(sx, splat(view.right[c])),
            ),
            splat(sy * view.up[c]),
        );
    }
    let dot = _mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(v[0], v[0]), _mm256_mul_pd(v[1], v[1])),
        _mm256_mul_pd(v[2], v[2]),
    );
    let recip = _mm256_div_pd(splat(1.0), _mm256_sqrt_pd(dot));
    let dir = [
        _mm256_mul_pd(v[0], recip),
        _mm256_mul_pd(v[1], recip),
        _mm256_mul_pd(v[2], recip),
    ];
    // z·dz + (y·dy + x·dx).
    let m = to_object;
    let mut d = dir;
    for (c, d) in d.iter_mut().enumerate() {
        *d = _mm256_add_pd(
            _mm256_mul_pd(splat(m.z_axis[c]), dir[2]),
            _mm256_add_pd(
                _mm256_mul_pd(splat(m.y_axis[c]), dir[1]),
                _mm256_mul_pd(splat(m.x_axis[c]), dir[0]),
            ),
        );
    }
    (dir, d)
}

/// [`CObj::clip`] of four rays from `o` along the directions `d` (by axis) in lanes: their
/// spans [t0, t1] and, by bit, those that meet the box [min, max]. Each axis is [`slab`]'s
/// operations in its order (a zero direction part by its test of `o`, NaN face parameters by
/// its choice of the other), so the same numbers.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn clip_lanes(
    o: DVec3,
    d: &[__m256d; 3],
    min: DVec3,
    max: DVec3,
) -> (__m256d, __m256d, u32) {
    let mut t0 = _mm256_setzero_pd();
    let mut t1 = _mm256_set1_pd(f64::INFINITY);
    let mut fail = _mm256_setzero_pd();
    for axis in 0..3 {
        let da = d[axis];
        let zero = _mm256_cmp_pd::<_CMP_EQ_OQ>(da, _mm256_setzero_pd());
        // (A NaN `o` is not outside.)
        if o[axis] < min[axis] || o[axis] > max[axis] {
            fail = _mm256_or_pd(fail, zero);
        }
        let inv = _mm256_div_pd(_mm256_set1_pd(1.0), da);
        let a = _mm256_mul_pd(_mm256_set1_pd(min[axis] - o[axis]), inv);
        let b = _mm256_mul_pd(_mm256_set1_pd(max[axis] - o[axis]), inv);
        let a_nan = _mm256_cmp_pd::<_CMP_UNORD_Q>(a, a);
        let b_nan = _mm256_cmp_pd::<_CMP_UNORD_Q>(b, b);
        let x = _mm256_blendv_pd(a, b, a_nan);
        let lo = _mm256_blendv_pd(a, b, _mm256_cmp_pd::<_CMP_LT_OQ>(b, a));
        let hi = _mm256_blendv_pd(a, b, _mm256_cmp_pd::<_CMP_GT_OQ>(b, a));
        let either = _mm256_or_pd(a_nan, b_nan);
        let (lo, hi) = (
            _mm256_blendv_pd(lo, x, either),
            _mm256_blendv_pd(hi, x, either),
        );
        let t0_new = _mm256_blendv_pd(t0, lo, _mm256_cmp_pd::<_CMP_GT_OQ>(lo, t0));
        let t1_new = _mm256_blendv_pd(t1, hi, _mm256_cmp_pd::<_CMP_LT_OQ>(hi, t1));
        t0 = _mm256_blendv_pd(t0_new, t0, zero);
        t1 = _mm256_blendv_pd(t1_new, t1, zero);
    }
    // t0 < t1 and t1 finite (t1 is never NaN: it only takes values below it).
    let ok = _mm256_andnot_pd(
        fail,
        _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_LT_OQ>(t0, t1),
            _mm256_cmp_pd::<_CMP_LT_OQ>(t1, _mm256_set1_pd(f64::INFINITY)),
        ),
    );
    (t0, t1, _mm256_movemask_pd(ok) as u32)
}

/// `segment_count((t1 − t0)/step)` in lanes where the span over the step is in (0, 2⁵²)
/// (`segment_count`'s own fast path: ⌈x⌉ as its truncation, plus one where that is below x),
/// else 0 (the caller then takes `segment_count`).
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn count_lanes(t0: __m256d, t1: __m256d, step: f64) -> [u64; 4] {
    let x = _mm256_div_pd(_mm256_sub_pd(t1, t0), _mm256_set1_pd(step));
    let t = _mm256_round_pd::<{ _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC }>(x);
    let up = _mm256_and_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(t, x), _mm256_set1_pd(1.0));
    let n = st4d(_mm256_add_pd(t, up));
    let fast = _mm256_movemask_pd(_mm256_and_pd(
        _mm256_cmp_pd::<_CMP_GT_OQ>(x, _mm256_setzero_pd()),
        _mm256_cmp_pd::<_CMP_LT_OQ>(x, _mm256_set1_pd(4_503_599_627_370_496.0)),
    )) as u32;
    std::array::from_fn(|l| if fast >> l & 1 != 0 { n[l] as u64 } else { 0 })
}

/// `Cursor::start_at(t)` of four new cursors (k = 0) over [t0, t1] in steps of `step` with
/// `n` segments (0: unknown), in lanes: per lane the first segment whose midpoint is not before
/// t, where it can be told without the cursor's search: 0 where segment 0's midpoint is not
/// before t; else `Cursor::pass_before`'s estimate (⌊(t − t0)/step − 0.5⌋ + 1, at least 1, at
/// most n) where the midpoints beside it show it final (the one before it below t, it at or
/// past t or the last); `None` otherwise (and for counts of 2⁵² or more), where the cursor
/// then searches. The midpoints are `Cursor::mid`'s operations (boundaries t0 + k·step, an end
/// at the next boundary where below t1, at t1 for the last segment).
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn first_segments(
    t0: __m256d,
    t1: __m256d,
    step: f64,
    n: [u64; 4],
    t: __m256d,
) -> [Option<u64>; 4] {
    let step_v = _mm256_set1_pd(step);
    let nf = _mm256_setr_pd(n[0] as f64, n[1] as f64, n[2] as f64, n[3] as f64);
    /// `Cursor::mid` of segments `k` in lanes.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn mid_lanes(k: __m256d, t0: __m256d, t1: __m256d, step: __m256d, n: __m256d) -> __m256d {
        let a = _mm256_add_pd(t0, _mm256_mul_pd(k, step));
        let k1 = _mm256_add_pd(k, _mm256_set1_pd(1.0));
        let next = _mm256_add_pd(t0, _mm256_mul_pd(k1, step));
        let b = _mm256_blendv_pd(
            _mm256_min_pd(next, t1),
            t1,
            _mm256_cmp_pd::<_CMP_GE_OQ>(k1, n),
        );
        _mm256_mul_pd(_mm256_set1_pd(0.5), _mm256_add_pd(a, b))
    }
    let zero = _mm256_setzero_pd();
    let one = _mm256_set1_pd(1.0);
    // Segment 0 needs no search where its midpoint is not before t.
    let stays = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_NLT_UQ>(
        mid_lanes(zero, t0, t1, step_v, nf),
        t,
    )) as u32;
    let g = _mm256_sub_pd(
        _mm256_div_pd(_mm256_sub_pd(t, t0), step_v),
        _mm256_set1_pd(0.5),
    );
    let est = _mm256_min_pd(
        _mm256_add_pd(
            _mm256_round_pd::<{ _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC }>(g),
            one,
        ),
        nf,
    );
    // g > 0 (and below 2⁵², where its truncation is exact): the estimate; else 1.
    let positive = _mm256_and_pd(
        _mm256_cmp_pd::<_CMP_GT_OQ>(g, zero),
        _mm256_cmp_pd::<_CMP_LT_OQ>(g, _mm256_set1_pd(4_503_599_627_370_496.0)),
    );
    let big = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_NLT_UQ>(
        g,
        _mm256_set1_pd(4_503_599_627_370_496.0),
    )) as u32;
    let k = _mm256_blendv_pd(one, est, positive);
    let before = _mm256_sub_pd(k, one);
    // Final: k = 1 or mid(k − 1) < t; and k = n or mid(k) ≥ t.
    let low = _mm256_or_pd(
        _mm256_cmp_pd::<_CMP_LE_OQ>(k, one),
        _mm256_cmp_pd::<_CMP_LT_OQ>(mid_lanes(before, t0, t1, step_v, nf), t),
    );
    let high = _mm256_or_pd(
        _mm256_cmp_pd::<_CMP_GE_OQ>(k, nf),
        _mm256_cmp_pd::<_CMP_GE_OQ>(mid_lanes(k, t0, t1, step_v, nf), t),
    );
    let fin = _mm256_movemask_pd(_mm256_and_pd(low, high)) as u32;
    let k = st4d(k);
    let mut out = [None; 4];
    for (l, o) in out.iter_mut().enumerate() {
        *o = if n[l] == 0 || n[l] >= 1 << 52 || big >> l & 1 != 0 {
            None
        } else if stays >> l & 1 != 0 {
            Some(0)
        } else if fin >> l & 1 != 0 {
            Some(k[l] as u64)
        } else {
            None
        };
    }
    out
}

/// By bit, the first `m` (at most eight) segments of lengths `lens` that are positive (or NaN).
#[inline]
#[target_feature(enable = "avx2")]
fn candidates(lens: &[f64; 8], m: usize) -> u32 {
    let mut keep = (1u32 << m) - 1;
    for h in 0..2 {
        let le = _mm256_cmp_pd::<_CMP_LE_OQ>(ldd(lens, h), _mm256_setzero_pd());
        keep &= !((_mm256_movemask_pd(le) as u32) << (4 * h));
    }
    keep
}

/// The object points of the segments with midpoints `mids` on cursor `c`'s ray, as
/// [`Packets::step`] makes them (f64, rounded to f32).
#[inline]
#[target_feature(enable = "avx2")]
fn object_points(c: &Cursor, mids: &[f64; 8]) -> [__m256; 3] {
    std::array::from_fn(|axis| {
        let o = _mm256_set1_pd(c.o[axis]);
        let d = _mm256_set1_pd(c.d[axis]);
        let half = |h: usize| _mm256_cvtpd_ps(_mm256_add_pd(o, _mm256_mul_pd(ldd(mids, h), d)));
        _mm256_set_m128(half(1), half(0))
    })
}

/// The four f64 of `a` as a register.
#[inline]
#[target_feature(enable = "avx")]
pub(super) fn ld4(a: &[f64; 4]) -> __m256d {
    // SAFETY: `a` is 4 f64, 32 readable bytes; the load has no alignment requirement.
    unsafe { _mm256_loadu_pd(a.as_ptr()) }
}

/// The four lanes of `v`.
#[inline]
#[target_feature(enable = "avx")]
pub(super) fn st4d(v: __m256d) -> [f64; 4] {
    let mut a = [0f64; 4];
    // SAFETY: `a` is 4 f64, 32 writable bytes; the store has no alignment requirement.
    unsafe { _mm256_storeu_pd(a.as_mut_ptr(), v) };
    a
}

/// The lanes of three registers.
#[inline]
#[target_feature(enable = "avx")]
fn st4(v: [__m256d; 3]) -> [[f64; 4]; 3] {
    [st4d(v[0]), st4d(v[1]), st4d(v[2])]
}

/// Lane `i`'s pixel (of lanes with colours `col` by channel and transmittances `t`, in eight
/// or sixteen lanes): its colour plus its transmittance times the background.
fn finish<const N: usize>(
    col: &[[f32; N]; 3],
    t: &[f32; N],
    i: usize,
    background: DVec3,
) -> [f32; 3] {
    let c = DVec3::new(col[0][i] as f64, col[1][i] as f64, col[2][i] as f64);
    to_f32(c + t[i] as f64 * background)
}

/// The offsets of a cell's four central rows (y0 + b, z0 + c for b + 2c = 0 … 3) from its
/// first node's row, for node strides `sy`, `sz` ([`Raw8::central_rows`]).
fn central_offsets(sy: i32, sz: i32) -> [i32; 4] {
    [0, sy, sz, sy + sz]
}

/// The offsets of the rows beside a cell that its gradient's differences read, from its
/// first node: rows y0 − 1 and y0 + 2 at z0 + c (c = 0, 1), then rows z0 − 1 and z0 + 2 at
/// y0 + b (b = 0, 1) ([`Raw8::differences`]).
fn side_offsets(sy: i32, sz: i32) -> [i32; 8] {
    [
        -sy,
        -sy + sz,
        2 * sy,
        2 * sy + sz,
        -sz,
        sy - sz,
        2 * sz,
        sy + 2 * sz,
    ]
}

impl Packets<'_> {
    /// The opacity correction lane by lane where a sample's exponent is not the step's common
    /// one (the lanes of `odd`, eight or sixteen of them): `1 − t` of opacities `o` over
    /// lengths `len`, by the scalar `transmit_at_most_one`, into `t`.
    fn transmit_one_by_one<const N: usize>(
        &self,
        o: &[f32; N],
        len: &[f64; N],
        odd: u32,
        t: &mut [f32; N],
    ) {
        for i in 0..N {
            if odd >> i & 1 != 0 {
                t[i] = transmit_at_most_one(o[i] as f64, len[i] * self.inv_ref) as f32;
            }
        }
    }

    /// The gradients lane by lane where a cell's 4³ neighbourhood is not inside the grid (the
    /// lanes of `outer`, eight or sixteen of them), at object points `p` (by axis), by the
    /// scalar `Dataset::gradient_cached`, into `g` (by axis).
    fn gradients_one_by_one<const N: usize>(
        &self,
        p: &[[f32; N]; 3],
        outer: u32,
        cache: &mut CellGradients,
        g: &mut [[f32; N]; 3],
    ) {
        for i in 0..N {
            if outer >> i & 1 != 0 {
                let gi = self.data.gradient_cached(
                    [p[0][i], p[1][i], p[2][i]],
                    Filter::Trilinear,
                    cache,
                );
                for axis in 0..3 {
                    g[axis][i] = gi[axis] as f32;
                }
            }
        }
    }
}

/// A lane's ray: its cursor, its pixel (in the tile), and how many of its next runs are taken
/// without the cell-mask test ([`TRUSTED_RUNS`]).
struct LaneRay {
    cursor: Cursor,
    px: usize,
    trusted: u32,
}

/// The runs of a ray taken without the cell-mask test after a run the mask passed whole
/// (`Packets::run16_untested`, and in eight lanes [`Packets::next_taken`]). Exact, as a taken
/// sample the mask would have dropped adds nothing: the mask clears only cells whose every
/// value is at most the zero test's bound, with a margin over the rounding of any sample in
/// them ([`crate::data::CellMask`]), so such a sample fails the zero test of
/// [`Packets::step`]. Inside visible matter the mask passes most runs whole, and at fine
/// steps its test cost about a third of a sample's work (at 0.125 voxel half the runs of the
/// MNI frame were passed whole, 37 % not at all); where a run it would have cut comes
/// untested, the samples it would have dropped take lanes for nothing. Two: the fastest of
/// 1, 2, 4, 8 and unbounded on the measured host (`docs/performance.md`).
pub(in crate::render) const TRUSTED_RUNS: u32 = 2;

/// The runs taken on trust, counted in the unit tests (`runs_on_trust_change_nothing`).
#[cfg(test)]
pub(in crate::render) static UNTESTED_RUNS: std::sync::atomic::AtomicU64 =
    std::sync::atomic::AtomicU64::new(0);

/// Counts a run taken on trust (in the unit tests only; in eight lanes, each of its halves).
#[inline]
pub(in crate::render) fn count_untested() {
    #[cfg(test)]
    UNTESTED_RUNS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
}

/// The run of segments a lane is taking: up to sixteen midpoints and lengths (two runs of
/// eight, tested against the cell mask together: its gather's latency paid once for both).
#[derive(Clone, Copy, Default)]
#[repr(C)]
pub(in crate::render) struct Run16 {
    pub(in crate::render) mids: [f64; 2 * W],
    pub(in crate::render) lens: [f64; 2 * W],
}

/// A run of eight segments: midpoints and lengths ([`Cursor::next_run`]).
#[derive(Clone, Copy, Default)]
#[repr(C)]
struct Run {
    mids: [f64; 8],
    lens: [f64; 8],
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

/// The eight-lane march's state.
type State = LaneState<W>;

/// `t^e` in each lane for a common exponent `e` (0.5, 1, 0.25, 2, 0.125 or 4: any other
/// gives t⁴), by square roots and products in f32: `transmit_common`'s operations.
#[inline]
#[target_feature(enable = "avx2")]
fn transmit_lanes(e: f64, t: __m256) -> __m256 {
    if e == 0.5 {
        _mm256_sqrt_ps(t)
    } else if e == 1.0 {
        t
    } else if e == 0.25 {
        _mm256_sqrt_ps(_mm256_sqrt_ps(t))
    } else if e == 2.0 {
        _mm256_mul_ps(t, t)
    } else if e == 0.125 {
        _mm256_sqrt_ps(_mm256_sqrt_ps(_mm256_sqrt_ps(t)))
    } else {
        let t2 = _mm256_mul_ps(t, t);
        _mm256_mul_ps(t2, t2)
    }
}

/// Lane `i` of the result all ones where bit `i` of `bits` is set, else zero.
#[inline]
#[target_feature(enable = "avx2")]
fn lanes_mask(bits: u32) -> __m256 {
    let b = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    let m = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(bits as i32), b), b);
    _mm256_castsi256_ps(m)
}

/// The colour, each lane zero where one of its channels is not finite (`Headlit::colour`):
/// `((x·0 + y)·0 + z)·0` is ±0 where all three are finite, else NaN.
#[inline]
#[target_feature(enable = "avx2")]
fn finite(col: [__m256; 3]) -> [__m256; 3] {
    let zero = _mm256_setzero_ps();
    let m = _mm256_mul_ps(
        _mm256_add_ps(
            _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(col[0], zero), col[1]), zero),
            col[2],
        ),
        zero,
    );
    let ok = _mm256_cmp_ps::<_CMP_EQ_OQ>(m, zero);
    col.map(|x| _mm256_and_ps(x, ok))
}

/// Eight node indices into `values`, each clamped so that it and every index up to `span`
/// past it lie inside the slice: [`Nodes::row4`] and [`Nodes::pairs2`] of offsets within
/// `0..=span` then read inside it in every lane.
struct Nodes<'a> {
    values: &'a [f32],
    at: __m256i,
    span: i32,
}

impl<'a> Nodes<'a> {
    /// `at` clamped to `[0, values.len() − 1 − span]` (`values.len() > span`, which
    /// [`Packets::new`] ensures: every axis has at least 4 nodes; asserted all the same).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn new(values: &'a [f32], at: __m256i, span: i32) -> Nodes<'a> {
        assert!(span >= 0 && (span as usize) < values.len() && values.len() <= i32::MAX as usize);
        let hi = _mm256_set1_epi32((values.len() - 1) as i32 - span);
        let at = _mm256_min_epi32(_mm256_max_epi32(at, _mm256_setzero_si256()), hi);
        Nodes { values, at, span }
    }
}

impl Nodes<'_> {
    /// `values[at + off + k]` for k in 0..4, per lane, as four registers (register k holds
    /// the k-th of each lane's four): a 16-byte load per lane, then a transposition.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn row4(&self, off: i32) -> [__m256; 4] {
        assert!(off >= 0 && off + 3 <= self.span);
        let at = self.indices();
        let p = self.values.as_ptr();
        let lane = |i: usize| {
            // SAFETY: `at[i]` is in [0, len − 1 − span] (`Nodes::new`) and
            // 0 ≤ off ≤ span − 3, so the four f32 at `at[i] + off` lie inside `values`.
            unsafe { _mm_loadu_ps(p.add(at[i] + off as usize)) }
        };
        transpose(std::array::from_fn(|i| {
            _mm256_set_m128(lane(i + 4), lane(i))
        }))
    }

    /// `values[at + a]`, `values[at + a + 1]`, `values[at + b]`, `values[at + b + 1]` per
    /// lane, as four registers: two 8-byte loads per lane, then a transposition.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn pairs2(&self, a: i32, b: i32) -> [__m256; 4] {
        assert!(a >= 0 && b >= 0 && a < self.span && b < self.span);
        let at = self.indices();
        let p = self.values.as_ptr();
        let lane = |i: usize| {
            // SAFETY: `at[i]` is in [0, len − 1 − span] and 0 ≤ a, b < span, so the two
            // f32 at `at[i] + a` and the two at `at[i] + b` lie inside `values`; the loads
            // have no alignment requirement.
            unsafe {
                let lo = _mm_castpd_ps(_mm_load_sd(p.add(at[i] + a as usize) as *const f64));
                _mm_castpd_ps(_mm_loadh_pd(
                    _mm_castps_pd(lo),
                    p.add(at[i] + b as usize) as *const f64,
                ))
            }
        };
        transpose(std::array::from_fn(|i| {
            _mm256_set_m128(lane(i + 4), lane(i))
        }))
    }

    /// The lanes of `at` as an array of indices (each in [0, len − 1 − span], `Nodes::new`;
    /// as usize, so that an offset is added without a sign extension per load).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn indices(&self) -> [usize; W] {
        let mut a = [0i32; W];
        // SAFETY: `a` is 8 i32, 32 writable bytes; the store has no alignment requirement.
        unsafe { _mm256_storeu_si256(a.as_mut_ptr() as *mut __m256i, self.at) };
        a.map(|x| x as u32 as usize)
    }
}

/// Four registers of lanes (i, i + 4) in their halves, four numbers each, transposed: register
/// k holds number k of lanes 0 to 7.
#[inline]
#[target_feature(enable = "avx2")]
fn transpose(y: [__m256; 4]) -> [__m256; 4] {
    let t0 = _mm256_unpacklo_ps(y[0], y[1]);
    let t1 = _mm256_unpackhi_ps(y[0], y[1]);
    let t2 = _mm256_unpacklo_ps(y[2], y[3]);
    let t3 = _mm256_unpackhi_ps(y[2], y[3]);
    [
        _mm256_shuffle_ps::<0x44>(t0, t2),
        _mm256_shuffle_ps::<0xEE>(t0, t2),
        _mm256_shuffle_ps::<0x44>(t1, t3),
        _mm256_shuffle_ps::<0xEE>(t1, t3),
    ]
}

/// `idx` with each lane clamped to `[0, len − 1]` (`len` not 0, at most `i32::MAX`): the
/// indices every gather below reads through.
#[inline]
#[target_feature(enable = "avx2")]
fn clamped(len: usize, idx: __m256i) -> __m256i {
    assert!(len != 0 && len <= i32::MAX as usize);
    let hi = _mm256_set1_epi32((len - 1) as i32);
    _mm256_min_epi32(_mm256_max_epi32(idx, _mm256_setzero_si256()), hi)
}

/// `data[idx]` per lane, each index first clamped to `[0, data.len() − 1]` (`data` not
/// empty, at most `i32::MAX` long).
#[inline]
#[target_feature(enable = "avx2")]
fn gather(data: &[f32], idx: __m256i) -> __m256 {
    let idx = clamped(data.len(), idx);
    // SAFETY: every index is in [0, data.len() − 1] (`clamped`), so every lane reads an
    // element of `data`.
    unsafe { _mm256_i32gather_ps::<4>(data.as_ptr(), idx) }
}

/// [`gather`] of i32 numbers.
#[inline]
#[target_feature(enable = "avx2")]
fn gather_i32(data: &[i32], idx: __m256i) -> __m256i {
    let idx = clamped(data.len(), idx);
    // SAFETY: as in `gather`: every index is in [0, data.len() − 1].
    unsafe { _mm256_i32gather_epi32::<4>(data.as_ptr(), idx) }
}

/// [`gather`] of u32 words (as i32 lanes).
#[inline]
#[target_feature(enable = "avx2")]
fn gather_u32(data: &[u32], idx: __m256i) -> __m256i {
    let idx = clamped(data.len(), idx);
    // SAFETY: as in `gather`: every index is in [0, data.len() − 1]; u32 and i32 have the
    // same size and alignment.
    unsafe { _mm256_i32gather_epi32::<4>(data.as_ptr() as *const i32, idx) }
}

/// The eight f32 of `a` as a register.
#[inline]
#[target_feature(enable = "avx")]
fn ld8(a: &[f32; W]) -> __m256 {
    // SAFETY: `a` is 8 f32, 32 readable bytes; the load has no alignment requirement.
    unsafe { _mm256_loadu_ps(a.as_ptr()) }
}

/// Stores the register `v` into the eight f32 of `a`.
#[inline]
#[target_feature(enable = "avx")]
fn st8(a: &mut [f32; W], v: __m256) {
    // SAFETY: `a` is 8 f32, 32 writable bytes; the store has no alignment requirement.
    unsafe { _mm256_storeu_ps(a.as_mut_ptr(), v) }
}

/// Stores the register `v` into lanes `4h .. 4h + 4` of `a` (h is 0 or 1).
#[inline]
#[target_feature(enable = "avx")]
fn std8d(a: &mut [f64; W], h: usize, v: __m256d) {
    let q: &mut [f64; 4] = (&mut a[4 * h..4 * h + 4]).try_into().expect("four lanes");
    // SAFETY: `q` is 4 f64, 32 writable bytes; the store has no alignment requirement.
    unsafe { _mm256_storeu_pd(q.as_mut_ptr(), v) }
}

/// Lanes `4h .. 4h + 4` of `a` (h is 0 or 1) as a register.
#[inline]
#[target_feature(enable = "avx")]
fn ldd(a: &[f64; W], h: usize) -> __m256d {
    let q: &[f64; 4] = a[4 * h..4 * h + 4].try_into().expect("four lanes");
    // SAFETY: `q` is 4 f64, 32 readable bytes; the load has no alignment requirement.
    unsafe { _mm256_loadu_pd(q.as_ptr()) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The test scene of slabs: slabs along x of 5 voxels (with some texture) between empty
    /// ones of 3 (whole runs inside the slabs, cut runs at their faces), faint or, if
    /// `opaque`, dense enough that most rays end early, before a grey-blue background, seen
    /// at `step`, shaded or not, with `optimise`; its image of `(width, height)` pixels as
    /// the bits of its pixels.
    fn slabs(
        step: f32,
        shaded: bool,
        opaque: bool,
        optimise: crate::model::scene::Optimise,
        (width, height): (u32, u32),
    ) -> Vec<u32> {
        use crate::data::{Dataset, Voxels};
        use crate::{Camera, Fields, Library, MappingType};
        let dims = [40usize, 36, 30];
        let voxels = (0..dims.iter().product::<usize>())
            .map(|i| {
                let (x, y, z) = (i % dims[0], i / dims[0] % dims[1], i / (dims[0] * dims[1]));
                if x % 8 < 5 {
                    (150 + (x * 7 + y * 13 + z * 29) % 100) as u8
                } else {
                    (x * 3 + y) as u8 % 60
                }
            })
            .collect();
        let data = Dataset::new(dims, Voxels::U8(voxels), 0.0, 255.0).unwrap();
        let mut vl = Library::new();
        vl.add_dataset(1, data).unwrap();
        let density = if opaque {
            [0.3, 0.0, 0.6, 0.6, 1.0, 0.95]
        } else {
            [0.3, 0.0, 0.6, 0.05, 1.0, 0.08]
        };
        vl.mapping(1, MappingType::Ramp, 3, 1, &density).unwrap();
        vl.mapping(
            2,
            MappingType::Ramp,
            2,
            3,
            &[0.0, 0.2, 0.4, 0.6, 1.0, 1.0, 0.9, 0.5],
        )
        .unwrap();
        vl.scene().unwrap();
        vl.set_optimise(optimise).unwrap();
        vl.background(0.1, 0.2, 0.3).unwrap();
        vl.camera(&Camera {
            eye: [90.0, -40.0, 70.0],
            at: [20.0, 18.0, 15.0],
            up: [0.0, 0.0, 1.0],
            fov: 40.0,
        })
        .unwrap();
        vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
        vl.directional_light([0.3, -1.0, 0.2], [1.0, 0.95, 0.9], 1.0)
            .unwrap();
        vl.step_size(step, 1.0).unwrap();
        vl.object().unwrap();
        vl.scale(39.0, 35.0, 29.0).unwrap();
        vl.dataset(Fields::F, 1).unwrap();
        vl.map(Fields::O, Fields::F, 1, 1).unwrap();
        vl.map(Fields::R, Fields::F, 2, 1).unwrap();
        vl.map(Fields::G, Fields::F, 2, 2).unwrap();
        vl.map(Fields::B, Fields::F, 2, 3).unwrap();
        if shaded {
            vl.set(Fields::KA, 0.2).unwrap();
            vl.set(Fields::KD, 0.7).unwrap();
            vl.set(Fields::KS, 0.3).unwrap();
        } else {
            vl.set(Fields::KA, 1.0).unwrap();
        }
        vl.end().unwrap();
        let image = vl.render_preview(width, height, 1.2).unwrap();
        image
            .pixels
            .iter()
            .flatten()
            .map(|v| v.to_bits())
            .collect::<Vec<_>>()
    }

    /// Runs taken on trust ([`TRUSTED_RUNS`]) are taken, and change no pixel: the slabs
    /// ([`slabs`]) at fine and coarse steps, shaded and not, in sixteen lanes and in eight,
    /// with `Optimise::trust_whole_runs` on and off.
    #[test]
    fn runs_on_trust_change_nothing() {
        if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
            return;
        }
        let render = |step: f32, shaded: bool, wide_lanes: bool, trust: bool| {
            let optimise = crate::model::scene::Optimise {
                wide_lanes,
                trust_whole_runs: trust,
                ..Default::default()
            };
            slabs(step, shaded, false, optimise, (64, 48))
        };
        let runs = || UNTESTED_RUNS.load(std::sync::atomic::Ordering::Relaxed);
        for step in [0.125, 0.5, 2.0] {
            for shaded in [false, true] {
                for wide_lanes in [true, false] {
                    let tested = render(step, shaded, wide_lanes, false);
                    let before = runs();
                    let trusted = render(step, shaded, wide_lanes, true);
                    let taken = runs() - before;
                    let what = format!("step {step}, shaded {shaded}, wide {wide_lanes}");
                    assert_eq!(tested, trusted, "{what}: runs on trust changed the image");
                    if step == 0.125 {
                        // (Other tests may count runs meanwhile: this bounds from below.)
                        assert!(taken > 100, "{what}: {taken} runs on trust");
                    }
                }
            }
        }
    }

    /// How many packets a step carries, and so which lane or packet a ray is marched in,
    /// changes no pixel ([`Packets::march_tile`]): the slabs, faint and opaque (rays ending
    /// early in every packet), at fine and coarse steps, shaded and not, in sixteen lanes and
    /// in eight, in one, two and four packets and by default, byte for byte; in an image of
    /// few tiles (16×16 pixels) and, on up to two threads, of many (32×32, `packet_tile`).
    #[test]
    fn packets_carry_rays_without_changing_them() {
        use std::sync::atomic::Ordering::Relaxed;
        if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
            return;
        }
        for size in [(64, 48), (256, 160)] {
            for opaque in [false, true] {
                for step in [0.125, 0.5, 2.0] {
                    for shaded in [false, true] {
                        for wide_lanes in [true, false] {
                            let optimise = crate::model::scene::Optimise {
                                wide_lanes,
                                ..Default::default()
                            };
                            let by = |packets: usize| {
                                TEST_PACKETS.store(packets, Relaxed);
                                slabs(step, shaded, opaque, optimise, size)
                            };
                            let (default, one, two, four) = (by(0), by(1), by(2), by(4));
                            TEST_PACKETS.store(0, Relaxed);
                            let what = format!(
                                "{size:?}, opaque {opaque}, step {step}, shaded {shaded}, \
                                 wide {wide_lanes}"
                            );
                            assert_eq!(one, two, "{what}: one packet and two differ");
                            assert_eq!(four, two, "{what}: four packets and two differ");
                            assert_eq!(default, two, "{what}: the default and two packets differ");
                            let background = [0.1f32, 0.2, 0.3].map(f32::to_bits);
                            let shown = default.chunks(3).filter(|p| *p != background).count();
                            let least = (size.0 * size.1 / 6) as usize;
                            assert!(shown > least, "{what}: {shown} pixels show the slabs");
                        }
                    }
                }
            }
        }
    }

    /// The lanes' opacity correction is `t^e` for every exponent `Packets::new` admits, within
    /// the f32 rounding of its square roots and products (a few units in the last place of
    /// f32: each rounds once, and a square root halves the relative error it is given).
    #[test]
    fn transmit_lanes_are_the_powers() {
        if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
            return;
        }
        for e in [0.5, 1.0, 0.25, 2.0, 0.125, 4.0] {
            for i in 0..=1000 {
                let t: [f32; W] = std::array::from_fn(|k| (i * W + k) as f32 / (1000 * W) as f32);
                let mut got = [0f32; W];
                // SAFETY: AVX2 was detected above.
                unsafe { st8(&mut got, transmit_lanes(e, ld8(&t))) };
                for k in 0..W {
                    let want = (t[k] as f64).powf(e);
                    let tol = 4.0 * f32::EPSILON as f64 * want;
                    assert!(
                        (got[k] as f64 - want).abs() <= tol,
                        "{}^{e}: {} against {want}",
                        t[k],
                        got[k]
                    );
                }
            }
        }
    }
}
