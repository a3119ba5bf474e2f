//! The pre-integrated packet march ([`Packets::tile_pre`]): primary rays of a pre-integrated
//! volume ([`PreMarch`], `Optimise::preintegrate`) several at a time, one ray per lane. The
//! lanes do what they are fast at: each lane's next sample whose cell can pass the zero test
//! (the runs, the cell mask and runs on trust of [`runs`], as in the midpoint march), and the
//! samples' object points, cells, nodes and trilinear values ([`Packets::values`], the
//! midpoint march's arithmetic: the same values bit for bit from node values, a relative 10⁻⁷
//! apart from 8-bit voxels). Where a lane's sample follows the last position its ray took
//! and their slab can show something, the values at the slab's middle and quarters are read
//! in lanes too, the step's slabs in batches ([`slabs`]). Each lane's slabs are then
//! composited by the scalar march's own code ([`PreMarch::slab_with`] given those values,
//! else [`PreMarch::take`]; [`PreMarch::finish`]: the tables, the halving where the data
//! bends, the composite in f64), which reads the values of passed-over samples next to a
//! taken one as the lanes read them (`integrate::preint::Bytes` from 8-bit voxels, else the
//! trilinear interpolation of the node values), and does nothing more for a sample whose
//! slabs cannot show anything (both ends at most the zero test's bound). A sample the lanes
//! pass over lies in a cell the mask clears, so its value is at most that bound: the slabs
//! composited are the scalar pre-integrated march's.
//!
//! Where the midpoint march lights its samples in lanes (a headlight, the dataset's own
//! trilinear node gradient: [`Light32::Lit`]), the slabs' pieces are lit in lanes too
//! ([`Deferred`]): a ray's transmittance, and so where it ends, does not depend on colours,
//! so each piece is weighed as it is composited and waits, with its pixel, mean colour, object
//! point and view, until [`PIECES`] of the tile's pieces are ready; sixteen at a time where
//! the march runs in sixteen lanes, else eight, then get the midpoint march's gradient and
//! lighting ([`Packets::gradient`], [`Packets::lit`], in
//! f32), and each pixel adds its pieces' weighted colours in the order of its pieces, in f64.
//! A piece's colour depends on that piece alone (not on which lanes carry it), so the pixels
//! are the same for any thread count. Elsewhere the scalar code lights each piece at once.
//!
//! Not here: which samples the lanes take ([`runs`]), the reads of nodes and voxels
//! ([`nodes`]), the batches' reads ([`slabs`]), the slabs (`integrate::preint`), the tables
//! (`render::preint`).

use super::slabs::LaneSlabs;
use super::step::Sampled;
use super::*;

/// The pieces [`Deferred`] gathers before it lights them: eight times eight lanes, four
/// times sixteen.
const PIECES: usize = 8 * W;

impl<'a> Packets<'a> {
    /// Whether the object is pre-integrated: its tiles are traced by [`Packets::tile_pre`],
    /// not [`Packets::tile`].
    pub(in crate::render) fn preintegrated(&self) -> bool {
        self.pre.is_some()
    }

    /// The pixels of the tile of `width × height` pixels at (tx, ty), row by row, as
    /// [`Packets::tile`] gives them into `out`, for a pre-integrated object (`Packets::pre`,
    /// which is set).
    pub(in crate::render) fn tile_pre(
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
        let pre = self.pre.as_ref().expect("a pre-integrated object");
        if let Light32::Lit { .. } = self.light {
            let mut light = Deferred::new(self, out.len());
            self.tile_pre_lit(pre, &tile, out, &mut light)
        } else {
            self.tile_pre_lit(pre, &tile, out, &mut CellGradients::default())
        }
    }

    /// [`Packets::tile_pre`] with its slabs' pieces lit by `light`.
    fn tile_pre_lit(
        &self,
        pre: &PreMarch<'a>,
        tile: &TileRays<'_>,
        out: Vec<Pixel>,
        light: &mut impl TileLight,
    ) -> Vec<Pixel> {
        if self.wide {
            // SAFETY: `Packets::new` set `wide` only where `detected` found every
            // feature `tile_pre_avx512` enables (and AVX2 and FMA before it).
            return unsafe { self.tile_pre_avx512(pre, tile, out, light) };
        }
        // SAFETY: `Packets::new` (the only way to make `self`) found AVX2 and FMA.
        unsafe { self.tile_pre_avx2(pre, tile, out, light) }
    }

    /// [`Packets::tile_pre`] in [`PACKETS8`] packets of eight lanes.
    #[target_feature(enable = "avx2,fma")]
    fn tile_pre_avx2(
        &self,
        pre: &PreMarch<'a>,
        tile: &TileRays<'_>,
        out: Vec<Pixel>,
        light: &mut impl TileLight,
    ) -> Vec<Pixel> {
        let values = |st: &_, active, out: &mut _| self.values8(st, active, out);
        let slabs = |slabs: &mut _| self.slabs8(slabs);
        let taken = |c: &mut _, run: &mut _, trusted: &mut _| self.next_taken_at8(c, run, trusted);
        // SAFETY: this function has the AVX2 and FMA `march_pre` asks for.
        unsafe {
            match self.packets() {
                1 => self.march_pre::<W, 1, W, _>(pre, tile, out, light, values, slabs, taken),
                4 => self
                    .march_pre::<W, 4, { 4 * W }, _>(pre, tile, out, light, values, slabs, taken),
                _ => self.march_pre::<W, PACKETS8, { PACKETS8 * W }, _>(
                    pre, tile, out, light, values, slabs, taken,
                ),
            }
        }
    }

    /// [`Packets::tile_pre`] in [`P`] packets of sixteen lanes.
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn tile_pre_avx512(
        &self,
        pre: &PreMarch<'a>,
        tile: &TileRays<'_>,
        out: Vec<Pixel>,
        light: &mut impl TileLight,
    ) -> Vec<Pixel> {
        let values = |st: &_, active, out: &mut _| self.values16(st, active, out);
        let slabs = |slabs: &mut _| self.slabs16(slabs);
        let taken = |c: &mut _, run: &mut _, trusted: &mut _| self.next_taken_at16(c, run, trusted);
        // SAFETY: this function has AVX2 and FMA, which `march_pre` asks for.
        unsafe {
            match self.packets() {
                1 => self.march_pre::<V, 1, V, _>(pre, tile, out, light, values, slabs, taken),
                4 => self
                    .march_pre::<V, 4, { 4 * V }, _>(pre, tile, out, light, values, slabs, taken),
                _ => self
                    .march_pre::<V, P, { P * V }, _>(pre, tile, out, light, values, slabs, taken),
            }
        }
    }

    /// The pixels of `tile`, row by row, in `P` packets of `N` lanes (`L` = P·N lanes in all,
    /// at most 64): every step gives each lane with a ray its next sample to take (its run's
    /// next bit; else its ray's next run with one, `next_taken`, which also says the run's
    /// first segment's number; else the tile's next ray), evaluates the values of every
    /// packet's samples in lanes (`values`), then hands each lane's sample to its ray's
    /// [`PreRay`] in lane order: a sample that follows its ray's last one with a slab that can
    /// show something into a batch of [`LaneSlabs`] (`P` batches hold a step's slabs), whose
    /// middles' and quarters' values `in_lanes` reads before the slabs are composited in the
    /// batch's order; any other by [`PreMarch::take`]. A ray has at most one slab in a step,
    /// so its slabs are composited in their order. A ray ends where its slabs' transmittance
    /// falls below the termination bound, or after its last sample, with the slabs to its
    /// interval's end. Each ray is its own cursor and [`PreRay`], so which lane or packet
    /// carries it changes nothing in its pixel.
    ///
    /// # Safety
    /// The caller must have AVX2 and FMA (for [`Packets::next_ray`]). Always inlined, so
    /// that the steps inline into the caller's target features.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    unsafe fn march_pre<const N: usize, const P: usize, const L: usize, T: TileLight>(
        &self,
        pre: &PreMarch<'a>,
        tile: &TileRays<'_>,
        mut out: Vec<Pixel>,
        light: &mut T,
        mut values: impl FnMut(&LaneState<N>, u32, &mut [f32; N]),
        mut in_lanes: impl FnMut(&mut LaneSlabs<N>),
        next_taken: impl Fn(&mut Cursor, &mut Run16, &mut u32) -> (u32, u64),
    ) -> Vec<Pixel> {
        const { assert!(N == 8 || N == 16) };
        const { assert!(P >= 1 && L == P * N && L <= 64) };
        let lanes_of = u64::MAX >> (64 - N);
        let background = tile.image.background;
        let (tw, th) = tile.size;
        debug_assert_eq!(out.len(), (tw * th) as usize);
        let mut starts = Starts::default();
        let mut lanes: [Option<LaneRay>; L] = std::array::from_fn(|_| None);
        let mut rays: [Option<PreRay<'a>>; L] = std::array::from_fn(|_| None);
        // Per lane: its run's segments, those still to take by bit, the run's first segment's
        // number, and the number of the sample being taken.
        let mut runs = [Run16::default(); L];
        let mut keeps = [0u32; L];
        let mut bases = [0u64; L];
        let mut index = [0u64; L];
        let mut st: [LaneState<N>; P] = std::array::from_fn(|_| LaneState::default());
        let mut vals = [[0f32; N]; P];
        let mut batches: [LaneSlabs<N>; P] = std::array::from_fn(|_| LaneSlabs::default());
        let z = pre.z();
        loop {
            let mut active = 0u64;
            for i in 0..L {
                let (h, l) = (i / N, i % N);
                loop {
                    if keeps[i] != 0 {
                        let j = keeps[i].trailing_zeros() as usize % (2 * W);
                        keeps[i] &= keeps[i] - 1;
                        st[h].mid[l] = runs[i].mids[j];
                        st[h].len[l] = runs[i].lens[j];
                        index[i] = bases[i] + j as u64;
                        active |= 1 << i;
                        break;
                    }
                    if lanes[i].is_none() {
                        // SAFETY: the caller has AVX2 and FMA.
                        let next =
                            unsafe { self.next_ray(&mut starts, &mut lanes[i], tile, &mut out) };
                        let Some((c, view)) = next else {
                            break;
                        };
                        st[h].start(l, c, view);
                        let px = lanes[i].as_ref().expect("a ray").px as u32;
                        let c = &lanes[i].as_ref().expect("a ray").cursor;
                        let mut ray = if T::SCALAR {
                            let (x, y) = (tile.origin.0 + px % tw, tile.origin.1 + px / tw);
                            // (`ray_lanes` gave the cursor this direction's object-space
                            // form.)
                            let dir = tile.view.ray(x as f64 + 0.5, y as f64 + 0.5);
                            pre.ray(c, tile.view.eye, dir)
                        } else {
                            pre.ray_in_lanes(c)
                        };
                        (ray.px, ray.view) = (px, view);
                        rays[i] = Some(ray);
                    }
                    let lane = lanes[i].as_mut().expect("a ray");
                    let (keep, base) =
                        next_taken(&mut lane.cursor, &mut runs[i], &mut lane.trusted);
                    if keep == 0 {
                        // The ray's last samples are passed over: the slabs to its end.
                        let ray = rays[i].as_mut().expect("a ray");
                        pre.finish(ray, &lane.cursor, light);
                        light.done(ray, lane.px, &mut out, background);
                        lanes[i] = None;
                        rays[i] = None;
                        continue;
                    }
                    keeps[i] = keep;
                    bases[i] = base;
                }
            }
            if active == 0 {
                break;
            }
            for (h, st) in st.iter().enumerate() {
                let a = (active >> (N * h) & lanes_of) as u32;
                if a != 0 {
                    values(st, a, &mut vals[h]);
                }
            }
            // Each lane's slabs: one that follows its ray's last position and can show
            // something into a batch of slabs (`P` batches hold a step's), the others by the
            // scalar code.
            let mut rest = active;
            while rest != 0 {
                let i = rest.trailing_zeros() as usize % L;
                rest &= rest - 1;
                let (h, l) = (i / N, i % N);
                let (Some(lane), Some(ray)) = (lanes[i].as_ref(), rays[i].as_mut()) else {
                    continue;
                };
                let (t, v) = (st[h].mid[l], vals[h][l]);
                if let Some((ta, va)) = pre.follows(ray, index[i], t, v) {
                    if va > z || v > z {
                        let batch = batches.iter_mut().find(|b| b.n < N).expect("room");
                        batch.push(i, (&st[h], l), (ta, va), (t, v));
                    }
                    continue;
                }
                if pre.take(ray, &lane.cursor, index[i], t, v, light) {
                    light.done(ray, lane.px, &mut out, background);
                    lanes[i] = None;
                    rays[i] = None;
                    keeps[i] = 0;
                }
            }
            // The batches' values in lanes, then each slab's pieces by the scalar code.
            for batch in batches.iter_mut().take_while(|b| b.n > 0) {
                in_lanes(batch);
                for k in 0..batch.n {
                    let i = batch.from[k];
                    let (Some(lane), Some(ray)) = (lanes[i].as_ref(), rays[i].as_mut()) else {
                        continue;
                    };
                    let (a, b, vm, [qa, qb]) = batch.slab(k);
                    let quarters = [Some(qa), Some(qb)];
                    if pre.slab_with(ray, &lane.cursor, a, b, vm, quarters, light) {
                        light.done(ray, lane.px, &mut out, background);
                        lanes[i] = None;
                        rays[i] = None;
                        keeps[i] = 0;
                    }
                }
                batch.n = 0;
            }
        }
        light.end(&mut out, background);
        out
    }

    /// [`Packets::next_taken_at`] in eight lanes.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn next_taken_at8(&self, c: &mut Cursor, run: &mut Run16, trusted: &mut u32) -> (u32, u64) {
        // SAFETY: this function has AVX2 and FMA.
        let s = unsafe { Avx2::new() };
        self.next_taken_at(s, c, run, trusted)
    }

    /// [`Packets::next_taken_at`] in sixteen lanes.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn next_taken_at16(&self, c: &mut Cursor, run: &mut Run16, trusted: &mut u32) -> (u32, u64) {
        // SAFETY: this function has every feature `Avx512` stands for.
        let s = unsafe { Avx512::new() };
        self.next_taken_at(s, c, run, trusted)
    }

    /// [`Packets::next_taken`], and the number of the run's first segment (bit j of the run
    /// is segment base + j): the same runs, tests and leaps.
    #[inline(always)]
    fn next_taken_at<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        c: &mut Cursor,
        run: &mut Run16,
        trusted: &mut u32,
    ) -> (u32, u64) {
        loop {
            if c.k >= c.n || c.stopping() {
                return (0, c.k);
            }
            let test = *trusted == 0;
            *trusted = trusted.saturating_sub(1);
            let base = c.k;
            let (m, candidates, keep) = self.run16(s, c, run, test);
            if test && keep != 0 && keep == candidates {
                *trusted = self.trusted_runs;
            }
            c.k += m as u64;
            if keep != 0 {
                return (keep, base);
            }
            if c.k >= c.n {
                return (0, c.k);
            }
            self.after_nothing_taken(c);
        }
    }

    /// [`Packets::values`] in eight lanes.
    #[target_feature(enable = "avx2,fma")]
    fn values8(&self, st: &LaneState<W>, active: u32, out: &mut [f32; W]) {
        // SAFETY: this function has AVX2 and FMA.
        let s = unsafe { Avx2::new() };
        self.values(s, st, &st.mid, active, out)
    }

    /// [`Packets::values`] in sixteen lanes ([`Packets::new`]).
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn values16(&self, st: &LaneState<V>, active: u32, out: &mut [f32; V]) {
        // SAFETY: this function has every feature `Avx512` stands for.
        let s = unsafe { Avx512::new() };
        self.values(s, st, &st.mid, active, out)
    }

    /// The dataset's values at ray parameters `mid` of the `active` lanes' rays (`st.mid`: their
    /// samples; or other points of them, as `slabs` reads) into `out`: [`Packets::sample`]'s,
    /// as [`Packets::step`] reads them; 0 outside the dataset (as `Dataset::trilinear` gives).
    /// Other lanes' values are 0.
    #[inline(always)]
    pub(super) fn values<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        st: &LaneState<N>,
        mid: &[f64; N],
        active: u32,
        out: &mut [f32; N],
    ) {
        *out = match self.sample(s, st, mid, active) {
            Some(Sampled { pass, v, .. }) => {
                let mut vals = [0f32; N];
                s.st(&mut vals, s.keep(s.of_bits(pass), v));
                vals
            }
            None => [0f32; N],
        };
    }
}

/// How [`Packets::march_pre`] lights a tile's pieces and writes the pixels of its rays.
trait TileLight: PieceLighting {
    /// Whether the pieces are lit by the scalar code, which needs each ray's world origin,
    /// direction and [`Headlit`] ([`PreMarch::ray`]); else a ray needs none of them
    /// ([`PreMarch::ray_in_lanes`]).
    const SCALAR: bool;

    /// Ray `ray`, of pixel `px` of the tile, has ended.
    fn done(&mut self, ray: &PreRay<'_>, px: usize, out: &mut [Pixel], background: DVec3);

    /// The tile's rays have all ended.
    fn end(&mut self, out: &mut [Pixel], background: DVec3);
}

/// Each piece lit at once by the scalar code: a ray's composite is its pixel as it ends
/// (`Compiled::trace`'s colour plus the transmittance times the background).
impl TileLight for CellGradients {
    const SCALAR: bool = true;

    fn done(&mut self, ray: &PreRay<'_>, px: usize, out: &mut [Pixel], background: DVec3) {
        let (col, t) = ray.result();
        out[px] = pixel(col + t * background, t);
    }

    fn end(&mut self, _: &mut [Pixel], _: DVec3) {}
}

/// The pieces of slabs waiting for their colours, piece i at index i of each array: its ray's
/// pixel in the tile, its weight (the transmittance before it times its α), and by axis (or
/// channel) its mean colour, the object point where it is lit and the view direction (towards
/// the eye). By axis, so that eight consecutive pieces load into lanes as they are.
struct Pieces {
    px: [u32; PIECES],
    w: [f64; PIECES],
    rgb: [[f32; PIECES]; 3],
    p: [[f32; PIECES]; 3],
    view: [[f32; PIECES]; 3],
}

impl Default for Pieces {
    fn default() -> Pieces {
        Pieces {
            px: [0; PIECES],
            w: [0.0; PIECES],
            rgb: [[0.0; PIECES]; 3],
            p: [[0.0; PIECES]; 3],
            view: [[0.0; PIECES]; 3],
        }
    }
}

/// The pieces of a tile's rays, weighed as they are composited and lit later in lanes (see
/// the module documentation).
struct Deferred<'p, 'a> {
    packets: &'p Packets<'a>,
    /// Per pixel of the tile: the weighted colours of its ray's pieces lit so far, added in
    /// the pieces' order, and the ray's transmittance once it has ended (`None` before, and
    /// for the pixels whose rays the march does not composite: those it writes itself).
    acc: Vec<([f64; 3], Option<f64>)>,
    pieces: Pieces,
    n: usize,
    cache: CellGradients,
}

impl<'p, 'a> Deferred<'p, 'a> {
    /// For a tile of `pixels` pixels, traced by `packets` (whose light is [`Light32::Lit`]).
    fn new(packets: &'p Packets<'a>, pixels: usize) -> Deferred<'p, 'a> {
        debug_assert!(matches!(packets.light, Light32::Lit { .. }));
        Deferred {
            packets,
            acc: vec![([0.0; 3], None); pixels],
            pieces: Pieces::default(),
            n: 0,
            cache: CellGradients::default(),
        }
    }

    /// Lights the pieces gathered, sixteen at a time where the march runs in sixteen lanes
    /// (else eight), and adds each one's weighted colour to its
    /// pixel, in their order.
    fn flush(&mut self) {
        if self.packets.wide {
            for first in (0..self.n).step_by(V) {
                let len = (self.n - first).min(V);
                // SAFETY: `Packets::new` set `wide` only where `detected` found every feature
                // `light_pieces16` enables.
                let col = unsafe {
                    self.packets
                        .light_pieces16(&self.pieces, first, len, &mut self.cache)
                };
                self.add(first, len, &col);
            }
        } else {
            for first in (0..self.n).step_by(W) {
                let len = (self.n - first).min(W);
                // SAFETY: `Packets::tile_pre` makes a `Deferred` of its own `Packets`, which
                // `Packets::new` made only where it found AVX2 and FMA.
                let col = unsafe {
                    self.packets
                        .light_pieces8(&self.pieces, first, len, &mut self.cache)
                };
                self.add(first, len, &col);
            }
        }
        self.n = 0;
    }

    /// Adds the lit colours `col` (by channel, then lane) of the `len` pieces from `first`,
    /// each times its weight, to its pixel, in their order.
    #[inline]
    fn add<const N: usize>(&mut self, first: usize, len: usize, col: &[[f32; N]; 3]) {
        for l in 0..len {
            let (px, w) = (self.pieces.px[first + l], self.pieces.w[first + l]);
            let acc = &mut self.acc[px as usize].0;
            for (ch, c) in col.iter().enumerate() {
                acc[ch] += w * c[l] as f64;
            }
        }
    }
}

impl PieceLighting for Deferred<'_, '_> {
    #[inline]
    fn composite(
        &mut self,
        _: &PreMarch<'_>,
        ray: &mut PreRay<'_>,
        c: &Cursor,
        alpha: f64,
        col: DVec3,
        tm: f64,
    ) -> bool {
        let (w, ends) = ray.weigh(alpha);
        // (A piece of weight 0 adds nothing: its colour is finite.)
        if w > 0.0 {
            let (q, i) = (&mut self.pieces, self.n);
            (q.px[i], q.w[i]) = (ray.px, w);
            // (The mean colour is an f32's: exact.)
            let (rgb, p) = (col.to_array(), ray_point(c.o, c.d, tm));
            for a in 0..3 {
                q.rgb[a][i] = rgb[a] as f32;
                q.p[a][i] = p[a];
                q.view[a][i] = ray.view[a];
            }
            self.n += 1;
            if self.n == PIECES {
                self.flush();
            }
        }
        ends
    }
}

impl TileLight for Deferred<'_, '_> {
    const SCALAR: bool = false;

    fn done(&mut self, ray: &PreRay<'_>, px: usize, _: &mut [Pixel], _: DVec3) {
        self.acc[px].1 = Some(ray.result().1);
    }

    fn end(&mut self, out: &mut [Pixel], background: DVec3) {
        self.flush();
        for (px, &(col, t)) in self.acc.iter().enumerate() {
            if let Some(t) = t {
                out[px] = pixel(DVec3::from_array(col) + t * background, t);
            }
        }
    }
}

impl Packets<'_> {
    /// The lit colours (by channel, then lane) of the `len` pieces from `first` of `pieces`
    /// (`first` a multiple of eight, `len` at most eight), side by side: the midpoint march's
    /// gradient and lighting at each piece's object point, for its view and mean colour.
    /// Lanes past `len` hold what their arrays hold there and come out unread.
    #[target_feature(enable = "avx2,fma")]
    fn light_pieces8(
        &self,
        pieces: &Pieces,
        first: usize,
        len: usize,
        cache: &mut CellGradients,
    ) -> [[f32; W]; 3] {
        // SAFETY: this function has AVX2 and FMA.
        let s = unsafe { Avx2::new() };
        self.light_pieces(s, pieces, first, len, cache)
    }

    /// [`Packets::light_pieces8`] in sixteen lanes.
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn light_pieces16(
        &self,
        pieces: &Pieces,
        first: usize,
        len: usize,
        cache: &mut CellGradients,
    ) -> [[f32; V]; 3] {
        // SAFETY: this function has every feature `Avx512` stands for.
        let s = unsafe { Avx512::new() };
        self.light_pieces(s, pieces, first, len, cache)
    }

    /// [`Packets::light_pieces8`] in the `N` lanes of `s` (`first` a multiple of `N`, `len` at
    /// most `N`).
    #[inline(always)]
    fn light_pieces<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        pieces: &Pieces,
        first: usize,
        len: usize,
        cache: &mut CellGradients,
    ) -> [[f32; N]; 3] {
        debug_assert!(len > 0 && len <= N && first.is_multiple_of(N) && first + N <= PIECES);
        let live = u32::MAX >> (32 - len);
        // (Loops, not closures: a closure would not have this function's target features.)
        let mut v = [[s.zero(); 3]; 3];
        for (k, by_axis) in [&pieces.p, &pieces.view, &pieces.rgb]
            .into_iter()
            .enumerate()
        {
            for (a, values) in by_axis.iter().enumerate() {
                let lanes: &[f32; N] = values[first..first + N].try_into().expect("N");
                v[k][a] = s.ld(lanes);
            }
        }
        let [p, view, rgb] = v;
        let (f, base, interior) = self.cells(s, &p);
        let (base, nodes, rows) = self.cell_nodes(s, base, live);
        let g = self.gradient(
            s,
            &p,
            &f,
            base,
            interior,
            live,
            cache,
            &nodes,
            rows.as_ref(),
        );
        let col = self.lit(s, &view, g, rgb);
        let mut out = [[0f32; N]; 3];
        for (o, c) in out.iter_mut().zip(col) {
            s.st(o, c);
        }
        out
    }
}
