//! The packet march in sixteen lanes (AVX-512), for the scenes whose numbers fit it: 8-bit
//! voxels read as voxels ([`Raw8`]) and tables of at most seven rows ([`Segments`]). The
//! eight-lane march's algorithm and arithmetic lane for lane, with twice the lanes a step: the
//! same cursors and runs of sixteen segments (tested in sixteen lanes here,
//! [`Packets::run16`]), the same samples, the same f32 operations on each, so the same image
//! bit for bit (`tests/packets.rs` compares the two in every case, `Optimise::wide_lanes`
//! off and on). What changes is only how many rays a step carries: on a processor with two
//! 512-bit units a step of sixteen costs about what one of eight did (the MNI frame at 0.5
//! voxel in 42 ms against 53 ms in eight lanes, `docs/performance.md`'s last run).
//!
//! A tile's step carries two such packets ([`P`]), thirty-two rays, through the driver both
//! widths share ([`Packets::march_tile`]; the eight-lane march steps two packets of eight):
//! a sample's work is one long chain of dependent operations (segment, point, cell, four
//! gathers, lerps, table, opacity correction, transmittance), and the branch on which lanes
//! ended waits for its end, so one packet's step left the processor waiting; two independent
//! chains in one step overlap (the frame about 5–10 % faster on the measured host; four
//! packets were no faster). Each ray is still its own cursor and arithmetic, so which lane or
//! packet carries it changes nothing in its pixel.
//!
//! **Safety.** As in the parent module: gathers and loads through indices clamped into the
//! slice they read, and the `#[target_feature]` tile function, called only by a [`Packets`]
//! whose `wide` flag was set after `is_x86_feature_detected!` found every feature it enables.

use super::*;

/// Lanes of a wide packet.
const V: usize = 16;

/// Packets of [`V`] lanes a tile's step carries ([`Packets::march_tile`]; at most four).
const P: usize = 2;

/// The AVX-512 features the wide march uses (with AVX2 and FMA for the runs it shares).
pub(in crate::render) fn detected() -> bool {
    is_x86_feature_detected!("avx512f")
        && is_x86_feature_detected!("avx512dq")
        && is_x86_feature_detected!("avx512bw")
        && is_x86_feature_detected!("avx512vl")
        && is_x86_feature_detected!("avx512cd")
}

/// The lanes' state, by lane (as the eight-lane `State`).
type State16 = LaneState<V>;

impl Packets<'_> {
    /// [`Packets::tile`] in [`P`] packets of sixteen lanes: lane `i` is lane `i % 16` of
    /// packet `i / 16`, and a step steps every packet.
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    pub(super) fn tile_avx512(&self, tile: &TileRays<'_>) -> Vec<[f32; 3]> {
        let segments = |keeps: &mut _, runs: &_, st: &mut _| next_segments16(keeps, runs, st);
        let step = |st: &mut _, active, cache: &mut _| self.step16(st, active, cache);
        let taken = |c: &mut _, run: &mut _, trusted: &mut _| self.next_taken16(c, run, trusted);
        // SAFETY: this function has AVX2 and FMA, which `march_tile` asks for.
        unsafe {
            match test_packets() {
                1 => self.march_tile::<V, 1, V>(tile, segments, step, taken),
                4 => self.march_tile::<V, 4, { 4 * V }>(tile, segments, step, taken),
                _ => self.march_tile::<V, P, { P * V }>(tile, segments, step, taken),
            }
        }
    }

    /// [`Packets::next_taken`] with runs of sixteen segments ([`Packets::run16`]): the same
    /// samples taken in the same order (a run of sixteen is two runs of eight, tested
    /// together: the cell mask's latency paid once for both).
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn next_taken16(&self, c: &mut Cursor, run: &mut Run16, trusted: &mut u32) -> u32 {
        loop {
            if c.k >= c.n {
                return 0;
            }
            let (m, keep) = if *trusted != 0 {
                *trusted -= 1;
                self.run16_untested(c, run)
            } else {
                let (m, candidates, keep) = self.run16(c, run);
                if keep != 0 && keep == candidates {
                    *trusted = self.trusted_runs;
                }
                (m, keep)
            };
            c.k += m as u64;
            if keep != 0 {
                return keep;
            }
            if c.k >= c.n {
                return 0;
            }
            self.after_nothing_taken(c, V);
        }
    }

    /// Cursor `c`'s next segments, up to sixteen (there is one), into `run`
    /// ([`segments16`]), and by bit those [`Packets::to_take`] would take: their number and
    /// the bits. A cursor near 2⁵³ segments, or without a mask, takes runs of eight.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn run16(&self, c: &Cursor, run: &mut Run16) -> (usize, u32, u32) {
        let k = index_f64(c.k, c.n);
        if k >= (1u64 << 53) as f64 - 32.0 || self.mask.is_empty() {
            let mut eight = Run::default();
            let (m, keep) = self.run_at(c, &mut eight);
            run.mids[..W].copy_from_slice(&eight.mids);
            run.lens[..W].copy_from_slice(&eight.lens);
            // (Never trusted: these runs are rare, or have no test to save.)
            return (m, !keep, keep);
        }
        let m = segments16(c, run);
        let keep = candidates16(run, m);
        if keep == 0 {
            return (m, 0, 0);
        }
        let (mid0, mid1) = (ld8d(&run.mids, 0), ld8d(&run.mids, 1));
        // The object points, as `Packets::step` makes them (f64, rounded to f32).
        let p: [__m512; 3] = std::array::from_fn(|axis| {
            let o = _mm512_set1_pd(c.o[axis]);
            let d = _mm512_set1_pd(c.d[axis]);
            let f = |mid: __m512d| _mm512_cvtpd_ps(_mm512_add_pd(o, _mm512_mul_pd(mid, d)));
            _mm512_insertf32x8::<1>(_mm512_castps256_ps512(f(mid0)), f(mid1))
        });
        let (_, base, _) = self.cells16(&p);
        let word = _mm512_srli_epi32::<5>(base);
        let last = _mm512_set1_epi32(self.mask.len() as i32 - 1);
        let words = gather_words16(
            self.mask,
            _mm512_min_epi32(_mm512_max_epi32(word, _mm512_setzero_si512()), last),
        );
        let bit = _mm512_srlv_epi32(words, _mm512_and_si512(base, _mm512_set1_epi32(31)));
        // A cell past the mask's end may reach the bound.
        let reach =
            _mm512_test_epi32_mask(bit, _mm512_set1_epi32(1)) | _mm512_cmpgt_epi32_mask(word, last);
        (m, keep, keep & reach as u32)
    }

    /// [`Packets::run16`] without the cell-mask test: the run's segments of positive length
    /// (or NaN), all taken. Exact, as a taken sample the mask would have dropped adds nothing:
    /// the mask clears only cells whose every value is at most the zero test's bound (with a
    /// margin, [`crate::data::CellMask`]), so such a sample fails the zero test in
    /// [`Packets::step16`]. Taken after a run the mask passed whole ([`TRUSTED_RUNS`]).
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn run16_untested(&self, c: &Cursor, run: &mut Run16) -> (usize, u32) {
        if index_f64(c.k, c.n) >= (1u64 << 53) as f64 - 32.0 || self.mask.is_empty() {
            let (m, _, keep) = self.run16(c, run);
            return (m, keep);
        }
        count_untested();
        let m = segments16(c, run);
        (m, candidates16(run, m))
    }

    /// [`Packets::step`] in sixteen lanes (voxels, tables in registers).
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn step16(&self, st: &mut State16, active: u32, cache: &mut CellGradients) -> u32 {
        let (Some(r8), Some(tables)) = (&self.raw8, &self.segments) else {
            unreachable!("the wide march needs voxels and tables in registers")
        };
        let zero = _mm512_setzero_ps();
        let one = _mm512_set1_ps(1.0);
        let active = active as u16;
        // The lanes with a sample of positive length (a NaN length passes).
        let le = |h: usize| {
            _mm512_cmp_pd_mask::<_CMP_LE_OQ>(ld8d(&st.len, h), _mm512_setzero_pd()) as u16
        };
        let empty = le(0) | le(1) << 8;
        let live = active & !empty;
        if live == 0 {
            return 0;
        }
        // Object points (f64, then rounded to f32 as `ray_point`).
        let p: [__m512; 3] = std::array::from_fn(|axis| {
            let half = |h: usize| {
                let m = ld8d(&st.mid, h);
                let o = ld8d(&st.ro[axis], h);
                let d = ld8d(&st.rd[axis], h);
                _mm512_cvtpd_ps(_mm512_add_pd(o, _mm512_mul_pd(m, d)))
            };
            _mm512_insertf32x8::<1>(_mm512_castps256_ps512(half(0)), half(1))
        });
        let (f, base, interior) = self.cells16(&p);
        let (sy, sz) = (self.sy, self.sz);
        let base = _mm512_maskz_mov_epi32(live, base);
        let rows = r8.central_rows16(base, live, sy, sz);
        let nodes = rows.cell_nodes();
        let lerp = |a: __m512, b: __m512, t: __m512| {
            _mm512_add_ps(a, _mm512_mul_ps(_mm512_sub_ps(b, a), t))
        };
        let [fx, fy, fz] = f;
        let c00 = lerp(nodes[0], nodes[1], fx);
        let c10 = lerp(nodes[2], nodes[3], fx);
        let c01 = lerp(nodes[4], nodes[5], fx);
        let c11 = lerp(nodes[6], nodes[7], fx);
        let v = lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz);
        let v = _mm512_fmadd_ps(v, _mm512_set1_ps(r8.scale), _mm512_set1_ps(r8.offset));
        let v = _mm512_min_ps(_mm512_max_ps(v, zero), one);
        // The zero test.
        let pass = live & _mm512_cmp_ps_mask::<_CMP_GT_OQ>(v, _mm512_set1_ps(self.z));
        if pass == 0 {
            return 0;
        }
        let (o, rgb) = tables.eval16(v);
        let shown = pass & _mm512_cmp_ps_mask::<_CMP_GT_OQ>(o, zero);
        if shown == 0 {
            return 0;
        }
        // The opacity correction: 1 − (1 − o)^(len / reference).
        let eq = |h: usize| {
            let e = _mm512_mul_pd(ld8d(&st.len, h), _mm512_set1_pd(self.inv_ref));
            _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(e, _mm512_set1_pd(self.common)) as u16
        };
        let common = eq(0) | eq(1) << 8;
        let mut tr = transmit16(self.common, _mm512_sub_ps(one, o));
        let odd = shown & !common;
        if odd != 0 {
            let mut oa = [0f32; V];
            let mut ta = [0f32; V];
            st16(&mut oa, o);
            st16(&mut ta, tr);
            self.transmit_one_by_one(&oa, &st.len, odd.into(), &mut ta);
            tr = ld16(&ta);
        }
        let alpha = _mm512_maskz_mov_ps(shown, _mm512_sub_ps(one, tr));
        // The lit colour.
        let col = match &self.light {
            Light32::Unlit { ka_ambient } => finite16(std::array::from_fn(|ch| {
                _mm512_mul_ps(_mm512_set1_ps(ka_ambient[ch]), rgb[ch])
            })),
            Light32::Lit { .. } => {
                let g = self.gradient16(&p, &f, base, interior, shown, cache, r8, &rows);
                let view = [ld16(&st.view[0]), ld16(&st.view[1]), ld16(&st.view[2])];
                self.lit16(&view, g, rgb)
            }
        };
        // Front to back.
        let mut t = ld16(&st.t);
        let w = _mm512_mul_ps(t, alpha);
        for (ch, x) in col.into_iter().enumerate() {
            let acc = ld16(&st.col[ch]);
            st16(&mut st.col[ch], _mm512_fmadd_ps(w, x, acc));
        }
        t = _mm512_mul_ps(t, _mm512_sub_ps(one, alpha));
        st16(&mut st.t, t);
        (shown & _mm512_cmp_ps_mask::<_CMP_LT_OQ>(t, _mm512_set1_ps(self.stop))) as u32
    }

    /// [`Packets::cells`] in sixteen lanes: weights, first nodes, and by bit the interior
    /// cells.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn cells16(&self, p: &[__m512; 3]) -> ([__m512; 3], __m512i, u16) {
        let zero = _mm512_setzero_ps();
        let one = _mm512_set1_ps(1.0);
        let mut f = [zero; 3];
        let mut c = [_mm512_setzero_si512(); 3];
        let mut interior = 0xffffu16;
        for axis in 0..3 {
            let l = _mm512_set1_ps(self.last[axis]);
            let ua = _mm512_min_ps(_mm512_max_ps(_mm512_mul_ps(p[axis], l), zero), l);
            let cu = _mm512_min_ps(ua, _mm512_set1_ps(self.top[axis]));
            let ci = _mm512_cvttps_epi32(cu);
            f[axis] = _mm512_sub_ps(ua, _mm512_cvtepi32_ps(ci));
            c[axis] = ci;
            interior &= _mm512_cmp_ps_mask::<_CMP_GE_OQ>(cu, one)
                & _mm512_cmp_ps_mask::<_CMP_LT_OQ>(cu, _mm512_set1_ps(self.inner[axis]));
        }
        let base = _mm512_add_epi32(
            c[0],
            _mm512_add_epi32(
                _mm512_mullo_epi32(c[1], _mm512_set1_epi32(self.sy)),
                _mm512_mullo_epi32(c[2], _mm512_set1_epi32(self.sz)),
            ),
        );
        (f, base, interior)
    }

    /// [`Packets::gradient`] in sixteen lanes, from voxels.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn gradient16(
        &self,
        p: &[__m512; 3],
        f: &[__m512; 3],
        base: __m512i,
        interior: u16,
        shown: u16,
        cache: &mut CellGradients,
        r8: &Raw8<'_>,
        rows: &Rows16,
    ) -> [__m512; 3] {
        let zero = _mm512_setzero_ps();
        let one = _mm512_set1_ps(1.0);
        let inner = shown & interior;
        let mut g = [zero; 3];
        if inner != 0 {
            let d = r8.differences16(rows, base, inner, self.sy, self.sz);
            let [fx, fy, fz] = *f;
            let wx = [_mm512_sub_ps(one, fx), fx];
            let wy = [_mm512_sub_ps(one, fy), fy];
            let wz = [_mm512_sub_ps(one, fz), fz];
            for (k, d) in d.iter().enumerate() {
                let (a, b, cc) = (k & 1, k >> 1 & 1, k >> 2);
                // The weight (wx·wy)·wz, as the scalar lanes take it.
                let w = _mm512_mul_ps(_mm512_mul_ps(wx[a], wy[b]), wz[cc]);
                for axis in 0..3 {
                    let prod = _mm512_mul_ps(w, d[axis]);
                    g[axis] = if k == 0 {
                        prod
                    } else {
                        _mm512_add_ps(g[axis], prod)
                    };
                }
            }
            for (axis, ga) in g.iter_mut().enumerate() {
                *ga = _mm512_mul_ps(*ga, _mm512_set1_ps(self.half_last[axis] * r8.scale));
            }
        }
        let outer = shown & !inner;
        if outer != 0 {
            let mut pa = [[0f32; V]; 3];
            let mut ga = [[0f32; V]; 3];
            for axis in 0..3 {
                st16(&mut pa[axis], p[axis]);
                st16(&mut ga[axis], g[axis]);
            }
            self.gradients_one_by_one(&pa, outer.into(), cache, &mut ga);
            for axis in 0..3 {
                g[axis] = ld16(&ga[axis]);
            }
        }
        g
    }

    /// [`Packets::lit`] in sixteen lanes.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn lit16(&self, view: &[__m512; 3], g: [__m512; 3], rgb: [__m512; 3]) -> [__m512; 3] {
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
        let zero = _mm512_setzero_ps();
        let one = _mm512_set1_ps(1.0);
        let neg = _mm512_set1_ps(-0.0);
        let s = |x: f32| _mm512_set1_ps(x);
        // Vanishing: the largest component in magnitude at most `ZERO_GRADIENT`.
        let a = _mm512_max_ps(
            _mm512_abs_ps(g[0]),
            _mm512_max_ps(_mm512_abs_ps(g[1]), _mm512_abs_ps(g[2])),
        );
        let vanishes = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(a, s(ZERO_GRADIENT as f32));
        let g: [__m512; 3] = if *diagonal {
            std::array::from_fn(|i| _mm512_mul_ps(s(to_world[i][i]), g[i]))
        } else {
            let [x, y, z] = to_world;
            std::array::from_fn(|i| {
                _mm512_fmadd_ps(
                    s(z[i]),
                    g[2],
                    _mm512_fmadd_ps(s(y[i]), g[1], _mm512_mul_ps(s(x[i]), g[0])),
                )
            })
        };
        let dot = |a: &[__m512; 3], b: &[__m512; 3]| {
            _mm512_fmadd_ps(
                a[2],
                b[2],
                _mm512_fmadd_ps(a[1], b[1], _mm512_mul_ps(a[0], b[0])),
            )
        };
        let rcp = _mm512_div_ps(one, _mm512_sqrt_ps(dot(&g, &g)));
        let valid = !vanishes
            & _mm512_cmp_ps_mask::<_CMP_GT_OQ>(rcp, zero)
            & _mm512_cmp_ps_mask::<_CMP_LT_OQ>(rcp, s(f32::INFINITY));
        let un: [__m512; 3] = std::array::from_fn(|i| _mm512_mul_ps(g[i], rcp));
        let l = to_light.map(s);
        let ndl_u = dot(&un, &l);
        let ndl = if *flip {
            // Negated where the normal faces the eye, as `-0.0 ^` where it does not.
            let front = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(dot(&un, view), zero);
            _mm512_mask_xor_ps(ndl_u, !front, ndl_u, neg)
        } else {
            _mm512_xor_ps(ndl_u, neg)
        };
        let lit = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(ndl, zero) & valid;
        // ndl where lit, 0 where valid and not lit, 1 where not valid.
        let m = _mm512_mask_blend_ps(valid, one, _mm512_maskz_mov_ps(lit, ndl));
        let mut term: [__m512; 3] =
            std::array::from_fn(|ch| _mm512_mul_ps(_mm512_mul_ps(s(*kd), rgb[ch]), m));
        if let Some(ks) = ks {
            let two = _mm512_add_ps(ndl_u, ndl_u);
            let r: [__m512; 3] = std::array::from_fn(|i| _mm512_fmsub_ps(two, un[i], l[i]));
            let rv = dot(&r, view);
            let spec = lit & _mm512_cmp_ps_mask::<_CMP_GT_OQ>(rv, zero);
            if spec != 0 {
                // rv^e by binary exponentiation.
                let (mut x, mut k, mut pw) = (rv, *e, one);
                loop {
                    if k & 1 != 0 {
                        pw = _mm512_mul_ps(pw, x);
                    }
                    k >>= 1;
                    if k == 0 {
                        break;
                    }
                    x = _mm512_mul_ps(x, x);
                }
                let p = _mm512_maskz_mov_ps(spec, _mm512_mul_ps(s(*ks), pw));
                term = term.map(|x| _mm512_add_ps(x, p));
            }
        }
        finite16(std::array::from_fn(|ch| {
            _mm512_fmadd_ps(
                s(radiance[ch]),
                term[ch],
                _mm512_mul_ps(s(ka_ambient[ch]), rgb[ch]),
            )
        }))
    }
}

impl Segments {
    /// [`Segments::eval`] in sixteen lanes.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn eval16(&self, v: __m512) -> (__m512, [__m512; 3]) {
        let zero = _mm512_setzero_ps();
        let one = _mm512_set1_ps(1.0);
        let count = |a: &[f32]| {
            let mut k = _mm512_setzero_si512();
            for &x in a {
                let below = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(_mm512_set1_ps(x), v);
                k = _mm512_mask_add_epi32(k, below, k, _mm512_set1_epi32(1));
            }
            k
        };
        let piece = |s: &Segs, k: __m512i| {
            let at = |t: &[f32; 8]| _mm512_permutexvar_ps(k, _mm512_castps256_ps512(ld8(t)));
            let x = _mm512_fmadd_ps(_mm512_sub_ps(v, at(&s.start)), at(&s.slope), at(&s.base));
            _mm512_min_ps(_mm512_max_ps(x, zero), one)
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

/// The central rows of sixteen cells ([`Raw8::central_rows16`]).
struct Rows16 {
    r: [__m512i; 4],
}

impl Rows16 {
    /// The eight cell nodes (a + 2b + 4c: x0 + a of row (b, c), its byte 1 + a) as f32.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn cell_nodes(&self) -> [__m512; 8] {
        let r = &self.r;
        std::array::from_fn(|k| {
            let w = r[k >> 1];
            _mm512_cvtepi32_ps(if k & 1 == 0 {
                byte16::<1>(w)
            } else {
                byte16::<2>(w)
            })
        })
    }
}

impl Raw8<'_> {
    /// [`Raw8::central_rows`] in sixteen lanes.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn central_rows16(&self, base: __m512i, live: u16, sy: i32, sz: i32) -> Rows16 {
        let span = sy + sz + 3;
        let first = _mm512_sub_epi32(base, _mm512_set1_epi32(1));
        let hi = _mm512_set1_epi32(self.raw.len() as i32 - 1 - span);
        let at = _mm512_min_epi32(_mm512_max_epi32(first, _mm512_setzero_si512()), hi);
        let kept = _mm512_cmpeq_epi32_mask(at, first);
        if !kept & live != 0 {
            // The first or last cell: row by row through the eight-lane reader, per half.
            let mut f = [0i32; V];
            st16i(&mut f, first);
            let halves = [0, 1].map(|h| {
                let part: &[i32; W] = f[W * h..W * h + W].try_into().expect("eight lanes");
                self.rows_one_by_one(ld8i(part), central_offsets(sy, sz))
            });
            let r = std::array::from_fn(|k| {
                let mut lo = [0i32; W];
                let mut hi = [0i32; W];
                st8i(&mut lo, halves[0].r[k]);
                st8i(&mut hi, halves[1].r[k]);
                let mut all = [0i32; V];
                all[..W].copy_from_slice(&lo);
                all[W..].copy_from_slice(&hi);
                ld16i(&all)
            });
            return Rows16 { r };
        }
        let mut r = [at; 4];
        for (w, off) in r.iter_mut().zip(central_offsets(sy, sz)) {
            *w = gather_bytes16(self.raw, _mm512_add_epi32(at, _mm512_set1_epi32(off)));
        }
        Rows16 { r }
    }

    /// [`Raw8::differences`] in sixteen lanes.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
    fn differences16(
        &self,
        rows: &Rows16,
        base: __m512i,
        inner: u16,
        sy: i32,
        sz: i32,
    ) -> [[__m512; 3]; 8] {
        let base = _mm512_maskz_mov_epi32(inner, base);
        let hi = _mm512_set1_epi32(self.raw.len() as i32 - 4);
        let zero = _mm512_setzero_si512();
        let mut side = [zero; 8];
        for (w, off) in side.iter_mut().zip(side_offsets(sy, sz)) {
            let at = _mm512_add_epi32(base, _mm512_set1_epi32(off));
            *w = gather_bytes16(self.raw, _mm512_min_epi32(_mm512_max_epi32(at, zero), hi));
        }
        let [ym0, ym1, yp0, yp1, zm0, zm1, zp0, zp1] = side;
        let two = |w: __m512i| [byte16::<0>(w), byte16::<1>(w)];
        let (ym, yp) = ([two(ym0), two(ym1)], [two(yp0), two(yp1)]);
        let (zm, zp) = ([two(zm0), two(zm1)], [two(zp0), two(zp1)]);
        let b = |x: __m512i| {
            [
                byte16::<0>(x),
                byte16::<1>(x),
                byte16::<2>(x),
                byte16::<3>(x),
            ]
        };
        let rb = [b(rows.r[0]), b(rows.r[1]), b(rows.r[2]), b(rows.r[3])];
        let mut d = [[_mm512_setzero_ps(); 3]; 8];
        for (k, dk) in d.iter_mut().enumerate() {
            let (a, b, c) = (k & 1, k >> 1 & 1, k >> 2);
            let row = &rb[b + 2 * c];
            let dx = _mm512_sub_epi32(row[2 + a], row[a]);
            let dy = if b == 0 {
                _mm512_sub_epi32(rb[1 + 2 * c][1 + a], ym[c][a])
            } else {
                _mm512_sub_epi32(yp[c][a], rb[2 * c][1 + a])
            };
            let dz = if c == 0 {
                _mm512_sub_epi32(rb[b + 2][1 + a], zm[b][a])
            } else {
                _mm512_sub_epi32(zp[b][a], rb[b][1 + a])
            };
            *dk = [
                _mm512_cvtepi32_ps(dx),
                _mm512_cvtepi32_ps(dy),
                _mm512_cvtepi32_ps(dz),
            ];
        }
        d
    }
}

/// By bit, the first `m` segments of `run` of positive length (or NaN).
#[inline]
#[target_feature(enable = "avx512f")]
fn candidates16(run: &Run16, m: usize) -> u32 {
    let short =
        |h: usize| _mm512_cmp_pd_mask::<_CMP_LE_OQ>(ld8d(&run.lens, h), _mm512_setzero_pd()) as u32;
    (((1u64 << m) - 1) as u32) & !(short(0) | short(1) << 8)
}

/// Cursor `c`'s next segments, up to sixteen (there is one, and its index is below 2⁵³ − 32),
/// their midpoints and lengths written into `run` (the entries past their number are
/// meaningless), their number returned: [`Cursor::segments`]' numbers bit for bit, as
/// [`segments_lanes`] makes them, eight to a register of f64
/// (`wide_segments_are_the_cursors`).
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
pub(in crate::render) fn segments16(c: &Cursor, run: &mut Run16) -> usize {
    let k = index_f64(c.k, c.n);
    debug_assert!(k < (1u64 << 53) as f64 - 32.0);
    let t0 = _mm512_set1_pd(c.t0);
    let t1 = _mm512_set1_pd(c.t1);
    let step = _mm512_set1_pd(c.step);
    let n = _mm512_set1_pd(index_f64(c.n, c.n));
    for h in 0..2 {
        let first = (8 * h) as f64;
        let j = _mm512_add_pd(
            _mm512_set1_pd(k),
            _mm512_setr_pd(
                first,
                first + 1.0,
                first + 2.0,
                first + 3.0,
                first + 4.0,
                first + 5.0,
                first + 6.0,
                first + 7.0,
            ),
        );
        let a = _mm512_add_pd(t0, _mm512_mul_pd(j, step));
        let j1 = _mm512_add_pd(j, _mm512_set1_pd(1.0));
        let next = _mm512_add_pd(t0, _mm512_mul_pd(j1, step));
        // `at_most`, then t1 for the cursor's last segment (see `segments_lanes`).
        let b = _mm512_min_pd(next, t1);
        let b = _mm512_mask_blend_pd(_mm512_cmp_pd_mask::<_CMP_GE_OQ>(j1, n), b, t1);
        st8d(
            &mut run.mids,
            h,
            _mm512_mul_pd(_mm512_set1_pd(0.5), _mm512_add_pd(a, b)),
        );
        st8d(&mut run.lens, h, _mm512_sub_pd(b, a));
    }
    (c.n - c.k).min(V as u64) as usize
}

/// [`next_segments`] in sixteen lanes: the lowest bit's index as 31 − its leading zeros.
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx512cd,avx2,fma")]
fn next_segments16(keeps: &mut [u32; V], runs: &[Run16; V], st: &mut State16) -> u32 {
    // SAFETY: `keeps` is 16 u32, 64 readable and writable bytes; no alignment requirement.
    let k = unsafe { _mm512_loadu_si512(keeps.as_ptr() as *const _) };
    let active = _mm512_test_epi32_mask(k, k);
    if active == 0 {
        return 0;
    }
    let zero = _mm512_setzero_si512();
    let low = _mm512_and_si512(k, _mm512_sub_epi32(zero, k));
    let j = _mm512_and_si512(
        _mm512_sub_epi32(_mm512_set1_epi32(31), _mm512_lzcnt_epi32(low)),
        _mm512_set1_epi32(15),
    );
    let rest = _mm512_and_si512(k, _mm512_add_epi32(k, _mm512_set1_epi32(-1)));
    // SAFETY: as above.
    unsafe { _mm512_storeu_si512(keeps.as_mut_ptr() as *mut _, rest) };
    const RUN: i32 = (std::mem::size_of::<Run16>() / std::mem::size_of::<f64>()) as i32;
    let lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    let at = _mm512_add_epi32(_mm512_mullo_epi32(lane, _mm512_set1_epi32(RUN)), j);
    let base = runs.as_ptr() as *const f64;
    for h in 0..2 {
        let idx = if h == 0 {
            _mm512_castsi512_si256(at)
        } else {
            _mm512_extracti64x4_epi64::<1>(at)
        };
        // SAFETY: `Run16` is two arrays of 16 f64 (`repr(C)`), so f64 number 32·i + j and
        // 32·i + 16 + j (i, j in 0..16) lie inside the 16 runs; gathers need no alignment.
        let (mid, len) = unsafe {
            (
                _mm512_i32gather_pd::<8>(idx, base),
                _mm512_i32gather_pd::<8>(idx, base.add(V)),
            )
        };
        st8d(&mut st.mid, h, mid);
        st8d(&mut st.len, h, len);
    }
    active as u32
}

/// [`transmit_lanes`] in sixteen lanes.
#[inline]
#[target_feature(enable = "avx512f")]
fn transmit16(e: f64, t: __m512) -> __m512 {
    if e == 0.5 {
        _mm512_sqrt_ps(t)
    } else if e == 1.0 {
        t
    } else if e == 0.25 {
        _mm512_sqrt_ps(_mm512_sqrt_ps(t))
    } else if e == 2.0 {
        _mm512_mul_ps(t, t)
    } else if e == 0.125 {
        _mm512_sqrt_ps(_mm512_sqrt_ps(_mm512_sqrt_ps(t)))
    } else {
        let t2 = _mm512_mul_ps(t, t);
        _mm512_mul_ps(t2, t2)
    }
}

/// [`finite`] in sixteen lanes.
#[inline]
#[target_feature(enable = "avx512f")]
fn finite16(col: [__m512; 3]) -> [__m512; 3] {
    let zero = _mm512_setzero_ps();
    let m = _mm512_mul_ps(
        _mm512_add_ps(
            _mm512_mul_ps(_mm512_add_ps(_mm512_mul_ps(col[0], zero), col[1]), zero),
            col[2],
        ),
        zero,
    );
    let ok = _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(m, zero);
    col.map(|x| _mm512_maskz_mov_ps(ok, x))
}

/// Byte `K` of each 32-bit lane of `w`.
#[inline]
#[target_feature(enable = "avx512f")]
fn byte16<const K: i32>(w: __m512i) -> __m512i {
    let shifted = match K {
        0 => w,
        1 => _mm512_srli_epi32::<8>(w),
        2 => _mm512_srli_epi32::<16>(w),
        _ => return _mm512_srli_epi32::<24>(w),
    };
    _mm512_and_si512(shifted, _mm512_set1_epi32(0xff))
}

/// `mask[at]` per lane (every lane of `at` in `[0, mask.len() − 1]`: the caller clamps).
#[inline]
#[target_feature(enable = "avx512f")]
fn gather_words16(mask: &[u32], at: __m512i) -> __m512i {
    // SAFETY: every lane of `at` is in [0, mask.len() − 1] (the caller clamps to it).
    unsafe { _mm512_i32gather_epi32::<4>(at, mask.as_ptr() as *const i32) }
}

/// [`gather_bytes`] in sixteen lanes; every lane of `at` must be in `[0, raw.len() − 4]`.
#[inline]
#[target_feature(enable = "avx512f")]
fn gather_bytes16(raw: &[u8], at: __m512i) -> __m512i {
    // SAFETY: every lane of `at` is in [0, raw.len() − 4] (the callers clamp to it), so the
    // four bytes each lane reads lie inside `raw`; a gather of scale 1 reads unaligned words.
    unsafe { _mm512_i32gather_epi32::<1>(at, raw.as_ptr() as *const i32) }
}

/// Lanes `8h .. 8h + 8` of `a` (h is 0 or 1) as a register.
#[inline]
#[target_feature(enable = "avx512f")]
fn ld8d(a: &[f64; V], h: usize) -> __m512d {
    let q: &[f64; 8] = a[8 * h..8 * h + 8].try_into().expect("eight lanes");
    // SAFETY: `q` is 8 f64, 64 readable bytes; the load has no alignment requirement.
    unsafe { _mm512_loadu_pd(q.as_ptr()) }
}

/// Stores `v` into lanes `8h .. 8h + 8` of `a` (h is 0 or 1).
#[inline]
#[target_feature(enable = "avx512f")]
fn st8d(a: &mut [f64; V], h: usize, v: __m512d) {
    let q: &mut [f64; 8] = (&mut a[8 * h..8 * h + 8]).try_into().expect("eight lanes");
    // SAFETY: `q` is 8 f64, 64 writable bytes; the store has no alignment requirement.
    unsafe { _mm512_storeu_pd(q.as_mut_ptr(), v) }
}

/// The sixteen f32 of `a` as a register.
#[inline]
#[target_feature(enable = "avx512f")]
fn ld16(a: &[f32; V]) -> __m512 {
    // SAFETY: `a` is 16 f32, 64 readable bytes; the load has no alignment requirement.
    unsafe { _mm512_loadu_ps(a.as_ptr()) }
}

/// Stores `v` into the sixteen f32 of `a`.
#[inline]
#[target_feature(enable = "avx512f")]
fn st16(a: &mut [f32; V], v: __m512) {
    // SAFETY: `a` is 16 f32, 64 writable bytes; the store has no alignment requirement.
    unsafe { _mm512_storeu_ps(a.as_mut_ptr(), v) }
}

/// The sixteen i32 of `a` as a register.
#[inline]
#[target_feature(enable = "avx512f")]
fn ld16i(a: &[i32; V]) -> __m512i {
    // SAFETY: `a` is 16 i32, 64 readable bytes; the load has no alignment requirement.
    unsafe { _mm512_loadu_si512(a.as_ptr() as *const _) }
}

/// Stores `v` into the sixteen i32 of `a`.
#[inline]
#[target_feature(enable = "avx512f")]
fn st16i(a: &mut [i32; V], v: __m512i) {
    // SAFETY: `a` is 16 i32, 64 writable bytes; the store has no alignment requirement.
    unsafe { _mm512_storeu_si512(a.as_mut_ptr() as *mut _, v) }
}
