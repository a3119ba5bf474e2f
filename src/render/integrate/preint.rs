//! The pre-integrated march of one scanned volume ([`Compiled::march_preintegrated`]): the
//! ray's samples are the cursor's midpoints, as in every march, but what is composited are the
//! *slabs* between consecutive samples, each with the opacity and colour of
//! [`PreIntegrated`] for the values at its two ends, so that a value varying linearly along a
//! slab is integrated exactly, whatever the step (`docs/accuracy.md`, pre-integration). Where
//! the data bends within a slab that can have opacity (the value at its middle off the mean of
//! its ends by more than [`REFINE_TOLERANCE`]), the slab is cut in two halves at its middle,
//! each taken the same way, down to a quarter of the step: a surface is placed by the data, not
//! by a straight line through two samples a step apart.
//!
//! The slabs of a ray are composited by [`PreMarch`] and [`PreRay`], which both marches drive:
//! this scalar one, sample by sample from the cursor, and the packet march of `simd::preint`,
//! which finds each lane's samples and their values in SIMD lanes and hands them here. Each
//! piece of a slab is lit where its light comes from, through [`PieceLighting`]: at once by
//! `shade`'s model (this march, and the packet march where it cannot light in lanes), or
//! later in lanes by the packet march. The tables are `preint`'s.

use crate::model::program::clamp_field;
use crate::render::preint::{PreIntegrated, REFINE_LEVELS, REFINE_TOLERANCE};
use crate::render::*;

/// What the slabs of one object's rays share: the scene, the object, its tables, its dataset,
/// the zero test's bound z (the opacity table is 0 on [0, z]) and its lighting coefficients.
///
/// A ray's *positions* are its interval's start t0 (position 0), its samples (sample i at
/// position i + 1, the cursor's midpoint i) and its interval's end t1 (position n + 1, n
/// samples); its slabs run between consecutive positions, the first and the last being half
/// segments. The pixel is the front-to-back composite of every slab one of whose two values is
/// above z, and nothing else: a slab whose two values are at most z adds nothing. A march need
/// not read every sample: [`PreMarch::take`] is given the samples it takes in order, each with
/// its value, and where samples were passed over between two of them (a sample passed over has
/// a value at most z: an empty block of the skip grid, a cell the cell mask clears, before the
/// entry map's bound) it reads the passed-over neighbour of a taken sample whose value is above
/// z, so the slabs composited are the same whichever samples a march passes over. The start t0
/// counts as taken where the ray's first sample is not passed over before the march begins
/// ([`PreMarch::ray`]), the end t1 always ([`PreMarch::finish`]).
pub(in crate::render) struct PreMarch<'a> {
    scene: &'a Compiled,
    obj: &'a CObj,
    pre: &'a PreIntegrated,
    data: &'a Dataset,
    z: f32,
    k: [f64; 3],
    e: Specular,
    /// The dataset's 8-bit voxels where values are read from them, as the packet march
    /// reads them ([`PreMarch::with_bytes`]); else the node values' trilinear interpolation.
    bytes: Option<Bytes<'a>>,
    /// Whether the processor has AVX2 and FMA, for [`Bytes::values3`] (found once, by
    /// [`PreMarch::with_bytes`]).
    simd: bool,
}

/// A dataset's 8-bit voxels whose normalisation `raw·scale + offset` never clamps, read as
/// the packet march reads them (`simd::nodes::Raw8`): the trilinear interpolation of the
/// voxels (exact integers) in the lanes' f32 operations and order, then one fused
/// normalisation, clamped to [0, 1]; 0 outside the dataset. The same bits as a lane's value
/// (a relative 10⁻⁷ from the node values' interpolation), so that the packet march's values
/// read in lanes and those read here (passed-over neighbours, slab middles, the interval's
/// ends) are one function of the point.
#[derive(Clone, Copy)]
pub(in crate::render) struct Bytes<'a> {
    pub(in crate::render) raw: &'a [u8],
    pub(in crate::render) scale: f32,
    pub(in crate::render) offset: f32,
    /// n − 1 and n − 2 per axis, as f32; the strides of y and z.
    pub(in crate::render) last: [f32; 3],
    pub(in crate::render) top: [f32; 3],
    pub(in crate::render) sy: usize,
    pub(in crate::render) sz: usize,
}

impl Bytes<'_> {
    /// The value at object point `p` of `data` (these voxels' dataset).
    #[inline(always)]
    pub(in crate::render) fn value(&self, data: &Dataset, p: [f32; 3]) -> f32 {
        if !data.covers(p) {
            return 0.0;
        }
        // `Packets::cells`: the continuous index clamped to the grid, its cell's first node
        // at most n − 2, the weight the rest.
        let mut f = [0f32; 3];
        let mut c = [0usize; 3];
        for a in 0..3 {
            let l = self.last[a];
            let ua = (p[a] * l).max(0.0).min(l);
            let ci = ua.min(self.top[a]) as i32;
            f[a] = ua - ci as f32;
            c[a] = ci.max(0) as usize;
        }
        let base = c[0] + c[1] * self.sy + c[2] * self.sz;
        let at = |o: usize| self.raw.get(base + o).map_or(0.0, |&v| v as f32);
        let (sy, sz) = (self.sy, self.sz);
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        // `trilinear_lanes`' seven lerps.
        let c00 = lerp(at(0), at(1), f[0]);
        let c10 = lerp(at(sy), at(sy + 1), f[0]);
        let c01 = lerp(at(sz), at(sz + 1), f[0]);
        let c11 = lerp(at(sy + sz), at(sy + sz + 1), f[0]);
        let v = lerp(lerp(c00, c10, f[1]), lerp(c01, c11, f[1]), f[2]);
        // (Finite: the voxels and the weights are.)
        v.mul_add(self.scale, self.offset).clamp(0.0, 1.0)
    }

    /// [`Bytes::value`] at three object points `ps` of `data`, side by side in SSE lanes: the
    /// same operations in each lane (the clamps as the lanes' max and min), so the same values
    /// (a zero's sign apart, which no comparison or lookup sees).
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    pub(in crate::render) unsafe fn values3(&self, data: &Dataset, ps: [[f32; 3]; 3]) -> [f32; 3] {
        use std::arch::x86_64::*;
        let zero = _mm_setzero_ps();
        let mut f = [zero; 3];
        let mut c = [[0i32; 4]; 3];
        for a in 0..3 {
            let p = _mm_setr_ps(ps[0][a], ps[1][a], ps[2][a], 0.0);
            let l = _mm_set1_ps(self.last[a]);
            let ua = _mm_min_ps(_mm_max_ps(_mm_mul_ps(p, l), zero), l);
            // (In [0, n − 2]: the truncation is `as i32`'s.)
            let ci = _mm_cvttps_epi32(_mm_min_ps(ua, _mm_set1_ps(self.top[a])));
            f[a] = _mm_sub_ps(ua, _mm_cvtepi32_ps(ci));
            // SAFETY: `c[a]` is four i32, an unaligned store's 16 bytes.
            unsafe { _mm_storeu_si128(c[a].as_mut_ptr().cast(), ci) };
        }
        let (sy, sz) = (self.sy, self.sz);
        let offsets = [0, sy, sz, sy + sz];
        // Per lane, its cell's first voxel; per row of the cell (y and z, `offsets`), each
        // lane's two voxels of the row as one i32, the first in its low byte (0 where one is
        // not a voxel).
        let bases: [usize; 3] = std::array::from_fn(|l| {
            c[0][l].max(0) as usize + c[1][l].max(0) as usize * sy + c[2][l].max(0) as usize * sz
        });
        let mut pairs = [[0i32; 3]; 4];
        for (l, &base) in bases.iter().enumerate() {
            if base + sy + sz + 1 < self.raw.len() {
                // Each row's two voxels, read at once: at most base + sy + sz + 1 (tested).
                for (r, off) in offsets.into_iter().enumerate() {
                    // SAFETY: base + off + 1 ≤ base + sy + sz + 1 < the voxels' length.
                    let pair = unsafe { self.raw.get_unchecked(base + off..base + off + 2) };
                    pairs[r][l] = u16::from_le_bytes([pair[0], pair[1]]) as i32;
                }
            } else {
                for (r, off) in offsets.into_iter().enumerate() {
                    let at = |x: usize| self.raw.get(base + off + x).map_or(0, |&v| v as i32);
                    pairs[r][l] = at(0) | at(1) << 8;
                }
            }
        }
        // Each row's voxels as f32 lanes (exact): the first of the pair, then the second.
        let byte = _mm_set1_epi32(0xff);
        let mut nodes = [zero; 8];
        for (r, [p0, p1, p2]) in pairs.into_iter().enumerate() {
            let row = _mm_setr_epi32(p0, p1, p2, 0);
            nodes[2 * r] = _mm_cvtepi32_ps(_mm_and_si128(row, byte));
            nodes[2 * r + 1] = _mm_cvtepi32_ps(_mm_srli_epi32::<8>(row));
        }
        let lerp = |a, b, t| _mm_add_ps(a, _mm_mul_ps(_mm_sub_ps(b, a), t));
        let [n000, n100, n010, n110, n001, n101, n011, n111] = nodes;
        let c00 = lerp(n000, n100, f[0]);
        let c10 = lerp(n010, n110, f[0]);
        let c01 = lerp(n001, n101, f[0]);
        let c11 = lerp(n011, n111, f[0]);
        let v = lerp(lerp(c00, c10, f[1]), lerp(c01, c11, f[1]), f[2]);
        let v = _mm_fmadd_ps(v, _mm_set1_ps(self.scale), _mm_set1_ps(self.offset));
        let v = _mm_min_ps(_mm_max_ps(v, zero), _mm_set1_ps(1.0));
        let mut out = [0f32; 4];
        // SAFETY: `out` is four f32, an unaligned store's 16 bytes.
        unsafe { _mm_storeu_ps(out.as_mut_ptr(), v) };
        std::array::from_fn(|l| if data.covers(ps[l]) { out[l] } else { 0.0 })
    }
}

/// One ray's state in a [`PreMarch`]: the composite so far, its lighting, the last position
/// taken (number, ray parameter, value) and the ray (the eye and the world direction, which
/// only the scalar lighting reads: zero, and no lighting, for a ray whose pieces are lit in
/// lanes, [`PreMarch::ray_in_lanes`]); where its pieces are lit later ([`PieceLighting`]), its
/// pixel and its view direction as f32.
pub(in crate::render) struct PreRay<'a> {
    acc: Integral,
    headlit: Option<Headlit<'a>>,
    origin: DVec3,
    dir: DVec3,
    last: Option<(u64, f64, f32)>,
    pub(in crate::render) px: u32,
    pub(in crate::render) view: [f32; 3],
}

/// Where the pieces of a ray's slabs are lit. [`CellGradients`] (a cache of the last cell's
/// node differences) lights each piece at once by the scalar model in f64 and composites it;
/// the packet march's buffer (`simd::preint`) takes each piece's weight at once (the ray's
/// transmittance and so its end do not depend on colours) and lights the pieces later, several
/// side by side in lanes.
pub(in crate::render) trait PieceLighting {
    /// Composites a piece of opacity `alpha` and mean colour `col` into `ray` (of cursor `c`),
    /// lit at ray parameter `tm`; whether the ray ends there.
    #[allow(clippy::too_many_arguments)]
    fn composite(
        &mut self,
        march: &PreMarch<'_>,
        ray: &mut PreRay<'_>,
        c: &Cursor,
        alpha: f64,
        col: DVec3,
        tm: f64,
    ) -> bool;
}

impl PieceLighting for CellGradients {
    #[inline]
    fn composite(
        &mut self,
        march: &PreMarch<'_>,
        ray: &mut PreRay<'_>,
        c: &Cursor,
        alpha: f64,
        col: DVec3,
        tm: f64,
    ) -> bool {
        let (origin, dir) = (ray.origin, ray.dir);
        debug_assert!(dir != DVec3::ZERO, "a ray started for the lanes' lighting");
        let (p, w) = (ray_point(c.o, c.d, tm), origin + tm * dir);
        let normal = || march.obj.gradient_normal(w, -dir, p, 9, self);
        let lit = match &ray.headlit {
            Some(h) => h.colour(col, normal),
            None => march
                .scene
                .illuminate_colour(march.obj, w, dir, col, march.k, march.e, normal),
        };
        ray.acc.add(alpha, lit)
    }
}

impl<'a> PreMarch<'a> {
    pub(in crate::render) fn new(
        scene: &'a Compiled,
        obj: &'a CObj,
        pre: &'a PreIntegrated,
        data: &'a Dataset,
        z: f32,
    ) -> PreMarch<'a> {
        let [ka, kd, ks, spec] = pre.shading.coefficients;
        PreMarch {
            scene,
            obj,
            pre,
            data,
            z,
            k: [ka, kd, ks],
            e: Specular::of_field(spec),
            bytes: None,
            simd: false,
        }
    }

    /// This march with its values read from the dataset's 8-bit voxels `bytes`, as the
    /// packet march reads them.
    pub(in crate::render) fn with_bytes(self, bytes: Bytes<'a>) -> PreMarch<'a> {
        #[cfg(target_arch = "x86_64")]
        let simd = is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma");
        #[cfg(not(target_arch = "x86_64"))]
        let simd = false;
        PreMarch {
            bytes: Some(bytes),
            simd,
            ..self
        }
    }

    /// A ray of cursor `c` (before its first sample is taken) from `origin` along the world
    /// direction `dir`: its start t0 taken where the cursor is at its first sample.
    pub(in crate::render) fn ray(&self, c: &Cursor, origin: DVec3, dir: DVec3) -> PreRay<'a> {
        let headlit = Headlit::new(self.scene, self.obj, dir, self.k, self.e);
        self.start(c, headlit, origin, dir)
    }

    /// [`PreMarch::ray`] for pieces lit elsewhere (the packet march's lanes): no world origin,
    /// direction or [`Headlit`], which only the scalar lighting reads.
    pub(in crate::render) fn ray_in_lanes(&self, c: &Cursor) -> PreRay<'a> {
        self.start(c, None, DVec3::ZERO, DVec3::ZERO)
    }

    /// A ray of cursor `c` (before its first sample is taken) with these lighting, origin and
    /// direction: nothing composited yet, its start t0 taken where the cursor is at its first
    /// sample.
    #[inline]
    fn start(
        &self,
        c: &Cursor,
        headlit: Option<Headlit<'a>>,
        origin: DVec3,
        dir: DVec3,
    ) -> PreRay<'a> {
        PreRay {
            acc: Integral::new(self.scene),
            headlit,
            origin,
            dir,
            last: (c.k == 0).then(|| (0, c.t0, self.end_value(c, c.t0))),
            px: 0,
            view: [0.0; 3],
        }
    }

    /// The dataset's value at ray parameter `t` of cursor `c`'s ray.
    #[inline]
    pub(in crate::render) fn value(&self, c: &Cursor, t: f64) -> f32 {
        self.value_at(ray_point(c.o, c.d, t))
    }

    /// The dataset's value at object point `p`.
    #[inline]
    fn value_at(&self, p: [f32; 3]) -> f32 {
        match &self.bytes {
            Some(b) => b.value(self.data, p),
            None => clamp_field(self.data.trilinear(p)),
        }
    }

    /// The dataset's value at an end of cursor `c`'s interval (`t` its t0 or t1): a point on
    /// the box's surface, where the value may jump (a dataset is 0 outside [0, 1]³). Computed
    /// as `o + t·d` it can land outside the box by far more than the 2⁻²⁰ a dataset forgives
    /// (an object-space ray of huge `o` and `d`, under a near-singular transform or seen from
    /// afar, cancels to the face with an absolute error of |o|·2⁻⁵³), so it is brought back
    /// into the box first, where it lies exactly.
    #[inline]
    fn end_value(&self, c: &Cursor, t: f64) -> f32 {
        let p = (c.o + t * c.d).clamp(self.obj.box_min, self.obj.box_max);
        self.value_at(p.as_vec3().to_array())
    }

    /// The ray parameter of position `p` of cursor `c`'s ray (see [`PreMarch`]).
    #[inline]
    fn at(c: &Cursor, p: u64) -> f64 {
        if p == 0 {
            c.t0
        } else if p > c.n {
            c.t1
        } else {
            c.mid(p - 1)
        }
    }

    /// Takes sample `i` of cursor `c`'s ray (ray parameter `t`, value `v`), after those
    /// taken before it: composites the slabs from the last position taken to it (see
    /// [`PreMarch`]); whether the ray ends there (its transmittance below the termination
    /// bound).
    #[inline]
    pub(in crate::render) fn take(
        &self,
        ray: &mut PreRay<'a>,
        c: &Cursor,
        i: u64,
        t: f64,
        v: f32,
        light: &mut impl PieceLighting,
    ) -> bool {
        self.take_position(ray, c, i + 1, t, v, light)
    }

    /// Where sample `i` of a ray (ray parameter `t`, value `v`) follows the last position
    /// `ray` took (sample i − 1, or the start t0 for sample 0), takes it without compositing:
    /// the slab from that position, returned as its ray parameter and value, is the caller's
    /// to composite ([`PreMarch::slab_with`], where one of its values is above z). Else
    /// `None`, and nothing changes: [`PreMarch::take`] takes the sample.
    #[inline]
    pub(in crate::render) fn follows(
        &self,
        ray: &mut PreRay<'a>,
        i: u64,
        t: f64,
        v: f32,
    ) -> Option<(f64, f32)> {
        match ray.last {
            Some((q, tq, vq)) if q == i => {
                ray.last = Some((i + 1, t, v));
                Some((tq, vq))
            }
            _ => None,
        }
    }

    /// The zero test's bound: a slab whose two values are at most it adds nothing.
    #[inline]
    pub(in crate::render) fn z(&self) -> f32 {
        self.z
    }

    /// The end of the ray (its samples all taken or passed over, the ray not ended): the slabs
    /// to its end t1; its colour and transmittance.
    pub(in crate::render) fn finish(
        &self,
        ray: &mut PreRay<'a>,
        c: &Cursor,
        light: &mut impl PieceLighting,
    ) -> (DVec3, f64) {
        let v = self.end_value(c, c.t1);
        self.take_position(ray, c, c.n + 1, c.t1, v, light);
        ray.acc.result()
    }

    /// [`PreMarch::take`] of position `p`.
    #[inline]
    fn take_position(
        &self,
        ray: &mut PreRay<'a>,
        c: &Cursor,
        p: u64,
        t: f64,
        v: f32,
        light: &mut impl PieceLighting,
    ) -> bool {
        let z = self.z;
        let ends = match ray.last {
            // The slab from the position before.
            Some((q, tq, vq)) if q + 1 == p => self.slab(ray, c, tq, vq, t, v, light),
            // Positions passed over between (values at most z): the slab after the last one
            // taken where its value is above z, and the one before this one where this value
            // is, each reading the value of the position passed over.
            Some((q, tq, vq)) => {
                // (One position passed over is both neighbours: its value is read once.)
                let mut after = None;
                (vq > z && {
                    let t1 = Self::at(c, q + 1);
                    let v1 = *after.insert(self.value(c, t1));
                    self.slab(ray, c, tq, vq, t1, v1, light)
                }) || (v > z && {
                    let tp = Self::at(c, p - 1);
                    let vp = match after {
                        Some(v1) if q + 2 == p => v1,
                        _ => self.value(c, tp),
                    };
                    self.slab(ray, c, tp, vp, t, v, light)
                })
            }
            None => {
                v > z && {
                    let tp = Self::at(c, p - 1);
                    self.slab(ray, c, tp, self.value(c, tp), t, v, light)
                }
            }
        };
        ray.last = Some((p, t, v));
        ends
    }

    /// Composites the slab from ray parameter ta (value va) to tb (value vb), halved where the
    /// data is not linear along it: where its value can reach the opacity table's non-zero
    /// part and the value at its middle is off the mean of its ends by more than the
    /// tolerance, each half is taken in turn, front first, and each half the same way once
    /// more ([`REFINE_LEVELS`] = 2 halvings, down to a quarter). From 8-bit voxels in SIMD
    /// lanes ([`Bytes::values3`]) the values at the middle and at the quarters are read
    /// together, before the first test, so that the quarters' reads do not wait for it (and go
    /// unused where the slab stays whole); otherwise each is read where a test needs it.
    /// Whether the ray ends there.
    #[allow(clippy::too_many_arguments)]
    fn slab(
        &self,
        ray: &mut PreRay<'a>,
        c: &Cursor,
        ta: f64,
        va: f32,
        tb: f64,
        vb: f32,
        light: &mut impl PieceLighting,
    ) -> bool {
        const { assert!(REFINE_LEVELS == 2) };
        let z = self.z;
        if va <= z && vb <= z {
            return false;
        }
        let m = 0.5 * (ta + tb);
        let (qa, qb) = (0.5 * (ta + m), 0.5 * (m + tb));
        let (vm, quarters) = match self.values3(c, [m, qa, qb]) {
            Some([vm, vqa, vqb]) => (vm, [Some(vqa), Some(vqb)]),
            None => (self.value(c, m), [None, None]),
        };
        self.slab_with(ray, c, (ta, va), (tb, vb), vm, quarters, light)
    }

    /// [`PreMarch::slab`] from ray parameter ta (value va) to tb (value vb), one of whose
    /// values is above z, given the value `vm` at its middle and those at its quarters
    /// (`None`: read where a test needs it), as a march that has read them in lanes gives
    /// them (`simd::slabs`). Whether the ray ends there.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(in crate::render) fn slab_with(
        &self,
        ray: &mut PreRay<'a>,
        c: &Cursor,
        a: (f64, f32),
        b: (f64, f32),
        vm: f32,
        quarters: [Option<f32>; 2],
        light: &mut impl PieceLighting,
    ) -> bool {
        let mut piece = |level, a, b| self.piece(ray, c, level, a, b, light);
        self.pieces(c, a, b, vm, quarters, &mut piece)
    }

    /// The pieces of the slab from ray parameter ta (value va) to tb (value vb) of cursor
    /// `c`'s ray, one of whose values is above z, front first, each given to `piece` as its
    /// level (1/2^level of the step) and its ends (ray parameter, value), until `piece` says
    /// the ray ends there: [`PreMarch::slab`]'s halving, given the value `vm` at its middle
    /// and those at its quarters (`None`: read where a test needs it). Whether the ray ends.
    #[inline]
    fn pieces(
        &self,
        c: &Cursor,
        (ta, va): (f64, f32),
        (tb, vb): (f64, f32),
        vm: f32,
        quarters: [Option<f32>; 2],
        piece: &mut impl FnMut(u32, (f64, f32), (f64, f32)) -> bool,
    ) -> bool {
        let z = self.z;
        let m = 0.5 * (ta + tb);
        let (qa, qb) = (0.5 * (ta + m), 0.5 * (m + tb));
        if !bends(va, vm, vb) {
            return piece(0, (ta, va), (tb, vb));
        }
        // Each half: whole where its values are at most z or it is linear, else its quarters.
        let mut half =
            |(ta, va): (f64, f32), (tq, vq): (f64, Option<f32>), (tb, vb): (f64, f32)| {
                if va > z || vb > z {
                    let vq = vq.unwrap_or_else(|| self.value(c, tq));
                    if bends(va, vq, vb) {
                        return piece(2, (ta, va), (tq, vq)) || piece(2, (tq, vq), (tb, vb));
                    }
                }
                piece(1, (ta, va), (tb, vb))
            };
        half((ta, va), (qa, quarters[0]), (m, vm)) || half((m, vm), (qb, quarters[1]), (tb, vb))
    }

    /// The dataset's values at ray parameters `ts` of cursor `c`'s ray ([`PreMarch::value`]),
    /// read side by side in SSE lanes where they come from 8-bit voxels and the processor has
    /// AVX2 and FMA; else `None`.
    #[inline]
    fn values3(&self, c: &Cursor, ts: [f64; 3]) -> Option<[f32; 3]> {
        match &self.bytes {
            #[cfg(target_arch = "x86_64")]
            Some(b) if self.simd => {
                let ps = ts.map(|t| ray_point(c.o, c.d, t));
                // SAFETY: the processor has AVX2 and FMA (`PreMarch::simd`).
                Some(unsafe { b.values3(self.data, ps) })
            }
            _ => None,
        }
    }

    /// Composites the slab from ray parameter ta (value va) to tb (value vb), of level
    /// `level` (1/2^level of the step, or another length); whether the ray ends there.
    fn piece(
        &self,
        ray: &mut PreRay<'a>,
        c: &Cursor,
        level: u32,
        (ta, va): (f64, f32),
        (tb, vb): (f64, f32),
        light: &mut impl PieceLighting,
    ) -> bool {
        let (obj, pre, z) = (self.obj, self.pre, self.z);
        let shading = &pre.shading;
        let len = tb - ta;
        if len.is_nan() || len <= 0.0 || (va <= z && vb <= z) {
            return false;
        }
        // The slab's α, mean colour and the fraction of its length where it is lit.
        let (alpha, rgb, at) = if (vb - va).abs() <= NEARLY_CONSTANT {
            // A constant medium (the midpoint march's sample, bit for bit), or one whose two
            // values are as good as equal: the sample at their mean.
            let v = if va == vb { va } else { 0.5 * (va + vb) };
            let (o, Some(rgb)) = shading.opacity_colour(v) else {
                return false;
            };
            (obj.alpha(o as f64, len), rgb.map(|x| x as f64), 0.5)
        } else {
            // (Midpoints one step apart differ by the step to rounding: a relative 10⁻⁹ of κ
            // changes α far below f32's resolution. 1/2^level is exact: the product is the
            // quotient by 2^level.)
            let part = obj.step * (1.0 / (1u32 << level) as f64);
            let [a, r, g, b, depth] = if (len - part).abs() <= part * 1e-9 {
                pre.lookup(level, va, vb)
            } else {
                pre.integrate(va, vb, len * obj.inv_ref)
            };
            if a.is_nan() || a <= 0.0 {
                return false;
            }
            // The slab's mean colour (its premultiplied colour over its α), in [0, 1] against
            // rounding.
            let a = a.min(1.0);
            (
                a as f64,
                [r, g, b].map(|x| (x / a).clamp(0.0, 1.0) as f64),
                (depth / a).clamp(0.0, 1.0) as f64,
            )
        };
        light.composite(self, ray, c, alpha, DVec3::from_array(rgb), ta + at * len)
    }
}

/// A slab whose two values differ by at most this (1/64 of a table cell's width of value,
/// some 12 units of a 16-bit voxel over the full range) is the constant medium of their mean.
/// The tables are exact on their diagonal (a constant value) but interpolate between the
/// nodes around it: where the transfer functions change within that cell (a rise narrower
/// than a cell), a slab of nearly equal values would take a blend of the two sides, though
/// its values lie on one.
const NEARLY_CONSTANT: f32 = 1.0 / (64 * (crate::render::preint::TABLE_NODES - 1)) as f32;

/// Whether the data bends along a slab of values `va` at its front, `vm` at its middle and
/// `vb` at its back: the middle off the mean of the ends by more than [`REFINE_TOLERANCE`].
#[inline]
fn bends(va: f32, vm: f32, vb: f32) -> bool {
    (vm - 0.5 * (va + vb)).abs() > REFINE_TOLERANCE
}

impl PreRay<'_> {
    /// Takes a piece of opacity `alpha` whose colour is composited elsewhere: its weight (the
    /// transmittance before it times α), and whether the ray ends there.
    #[inline]
    pub(in crate::render) fn weigh(&mut self, alpha: f64) -> (f64, bool) {
        self.acc.weigh(alpha)
    }

    /// The colour gathered and the transmittance left.
    pub(in crate::render) fn result(&self) -> (DVec3, f64) {
        self.acc.result()
    }
}

impl Compiled {
    /// [`Compiled::march_one`] of a direct-shading program (see [`PreIntegrated`]) with its
    /// tables `pre`: the slabs between consecutive samples front to back, plus half a segment
    /// before the first sample and after the last (from and to the interval's ends, whose
    /// values are read there too: one segment is two half slabs), as [`PreMarch`] composites
    /// them from the samples the cursor does not pass over. A slab whose two values are equal
    /// is a constant medium: [`CObj::alpha`] of the tables' values, exactly the midpoint
    /// march's sample.
    #[allow(clippy::too_many_arguments)]
    pub(in crate::render) fn march_preintegrated(
        &self,
        obj: &CObj,
        pre: &PreIntegrated,
        data: &Dataset,
        z: f32,
        c: &mut Cursor,
        origin: DVec3,
        dir: DVec3,
    ) -> (DVec3, f64) {
        let grid = obj.skip.as_deref();
        let march = PreMarch::new(self, obj, pre, data, z);
        let mut ray = march.ray(c, origin, dir);
        let mut cache = CellGradients::default();
        while let Some(mid) = c.peek(grid) {
            let i = c.k;
            c.take();
            let v = march.value(c, mid);
            if march.take(&mut ray, c, i, mid, v, &mut cache) {
                return ray.result();
            }
        }
        march.finish(&mut ray, c, &mut cache)
    }
}
