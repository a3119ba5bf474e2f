//! The pre-integrated packet march ([`Packets::tile_pre`]): primary rays of a pre-integrated
//! volume ([`PreMarch`], `Optimise::preintegrate`) several at a time, one ray per lane. The
//! lanes do what they are fast at: each lane's next sample whose cell can pass the zero test
//! (the runs, the cell mask and runs on trust of [`runs`], as in the midpoint march), and the
//! samples' object points, cells, nodes and trilinear values ([`Packets::values`], the
//! midpoint march's arithmetic: the same values bit for bit from node values, a relative 10⁻⁷
//! apart from 8-bit voxels). Each lane's slabs are then composited by the scalar march's own
//! code ([`PreMarch::take`], [`PreMarch::finish`]: the tables, the halving where the data
//! bends, the lighting, the composite in f64), which reads the values of passed-over samples
//! next to a taken one by the scalar trilinear interpolation, and does nothing more for a
//! sample whose slabs cannot show anything (both ends at most the zero test's bound). A
//! sample the lanes pass over lies in a cell the mask clears, so its value is at most that
//! bound: the slabs composited, and so the pixels, are the scalar pre-integrated march's.
//!
//! Not here: which samples the lanes take ([`runs`]), the reads of nodes and voxels
//! ([`nodes`]), the slabs (`integrate::preint`), the tables (`render::preint`).

use super::step::Sampled;
use super::*;

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
        if self.wide {
            // SAFETY: `Packets::new` set `wide` only where `detected` found every
            // feature `tile_pre_avx512` enables (and AVX2 and FMA before it).
            return unsafe { self.tile_pre_avx512(pre, &tile, out) };
        }
        // SAFETY: `Packets::new` (the only way to make `self`) found AVX2 and FMA.
        unsafe { self.tile_pre_avx2(pre, &tile, out) }
    }

    /// [`Packets::tile_pre`] in [`PACKETS8`] packets of eight lanes.
    #[target_feature(enable = "avx2,fma")]
    fn tile_pre_avx2(
        &self,
        pre: &PreMarch<'a>,
        tile: &TileRays<'_>,
        out: Vec<Pixel>,
    ) -> Vec<Pixel> {
        let values = |st: &_, active, out: &mut _| self.values8(st, active, out);
        let taken = |c: &mut _, run: &mut _, trusted: &mut _| self.next_taken_at8(c, run, trusted);
        // SAFETY: this function has the AVX2 and FMA `march_pre` asks for.
        unsafe {
            match self.packets() {
                1 => self.march_pre::<W, 1, W>(pre, tile, out, values, taken),
                4 => self.march_pre::<W, 4, { 4 * W }>(pre, tile, out, values, taken),
                _ => self.march_pre::<W, PACKETS8, { PACKETS8 * W }>(pre, tile, out, values, taken),
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
    ) -> Vec<Pixel> {
        let values = |st: &_, active, out: &mut _| self.values16(st, active, out);
        let taken = |c: &mut _, run: &mut _, trusted: &mut _| self.next_taken_at16(c, run, trusted);
        // SAFETY: this function has AVX2 and FMA, which `march_pre` asks for.
        unsafe {
            match self.packets() {
                1 => self.march_pre::<V, 1, V>(pre, tile, out, values, taken),
                4 => self.march_pre::<V, 4, { 4 * V }>(pre, tile, out, values, taken),
                _ => self.march_pre::<V, P, { P * V }>(pre, tile, out, values, taken),
            }
        }
    }

    /// The pixels of `tile`, row by row, in `P` packets of `N` lanes (`L` = P·N lanes in all,
    /// at most 64): every step gives each lane with a ray its next sample to take (its run's
    /// next bit; else its ray's next run with one, `next_taken`, which also says the run's
    /// first segment's number; else the tile's next ray), evaluates the values of every
    /// packet's samples in lanes (`values`), then hands each lane's sample to its ray's
    /// [`PreRay`] in lane order. A ray ends where its slabs' transmittance falls below the
    /// termination bound, or after its last sample, with the slabs to its interval's end.
    /// Each ray is its own cursor and [`PreRay`], so which lane or packet carries it changes
    /// nothing in its pixel.
    ///
    /// # Safety
    /// The caller must have AVX2 and FMA (for [`Packets::next_ray`]). Always inlined, so
    /// that the steps inline into the caller's target features.
    #[inline(always)]
    unsafe fn march_pre<const N: usize, const P: usize, const L: usize>(
        &self,
        pre: &PreMarch<'a>,
        tile: &TileRays<'_>,
        mut out: Vec<Pixel>,
        mut values: impl FnMut(&LaneState<N>, u32, &mut [f32; N]),
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
        let mut cache = CellGradients::default();
        // The composite of a ray that ends, into its pixel (`Compiled::trace`'s colour plus
        // the transmittance times the background).
        let done = |ray: &PreRay<'_>, out: &mut [Pixel], px: usize| {
            let (col, t) = ray.result();
            out[px] = pixel(col + t * background, t);
        };
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
                        let (x, y) = (tile.origin.0 + px % tw, tile.origin.1 + px / tw);
                        // (`ray_lanes` gave the cursor this direction's object-space form.)
                        let dir = tile.view.ray(x as f64 + 0.5, y as f64 + 0.5);
                        let c = &lanes[i].as_ref().expect("a ray").cursor;
                        rays[i] = Some(pre.ray(c, tile.view.eye, dir));
                    }
                    let lane = lanes[i].as_mut().expect("a ray");
                    let (keep, base) =
                        next_taken(&mut lane.cursor, &mut runs[i], &mut lane.trusted);
                    if keep == 0 {
                        // The ray's last samples are passed over: the slabs to its end.
                        let ray = rays[i].as_mut().expect("a ray");
                        pre.finish(ray, &lane.cursor, &mut cache);
                        done(ray, &mut out, lane.px);
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
            // Each lane's slabs, by the scalar code.
            while active != 0 {
                let i = active.trailing_zeros() as usize % L;
                active &= active - 1;
                let (h, l) = (i / N, i % N);
                let (Some(lane), Some(ray)) = (lanes[i].as_ref(), rays[i].as_mut()) else {
                    continue;
                };
                let ends = pre.take(
                    ray,
                    &lane.cursor,
                    index[i],
                    st[h].mid[l],
                    vals[h][l],
                    &mut cache,
                );
                if ends {
                    done(ray, &mut out, lane.px);
                    lanes[i] = None;
                    rays[i] = None;
                    keeps[i] = 0;
                }
            }
        }
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
            if c.k >= c.n {
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
            self.after_nothing_taken(c, 2 * W);
        }
    }

    /// [`Packets::values`] in eight lanes.
    #[target_feature(enable = "avx2,fma")]
    fn values8(&self, st: &LaneState<W>, active: u32, out: &mut [f32; W]) {
        // SAFETY: this function has AVX2 and FMA.
        let s = unsafe { Avx2::new() };
        self.values(s, st, active, out)
    }

    /// [`Packets::values`] in sixteen lanes ([`Packets::new`]).
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn values16(&self, st: &LaneState<V>, active: u32, out: &mut [f32; V]) {
        // SAFETY: this function has every feature `Avx512` stands for.
        let s = unsafe { Avx512::new() };
        self.values(s, st, active, out)
    }

    /// The dataset's values at the samples of the `active` lanes (at `st.mid`) into `out`:
    /// [`Packets::sample`]'s, as [`Packets::step`] reads them; 0 outside the dataset (as
    /// `Dataset::trilinear` gives). Other lanes' values are 0.
    #[inline(always)]
    fn values<S: Simd<N>, const N: usize>(
        &self,
        s: S,
        st: &LaneState<N>,
        active: u32,
        out: &mut [f32; N],
    ) {
        *out = match self.sample(s, st, active) {
            Some(Sampled { pass, v, .. }) => {
                let mut vals = [0f32; N];
                s.st(&mut vals, s.keep(s.of_bits(pass), v));
                vals
            }
            None => [0f32; N],
        };
    }
}
