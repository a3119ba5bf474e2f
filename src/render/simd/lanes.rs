//! The lanes themselves: the [`Simd`] tokens of the two instruction sets ([`Avx2`], eight
//! lanes; [`Avx512`], sixteen) and the operations the generic march is written in, and the
//! unaligned loads and stores of fixed-size lane arrays. Not here: any of the march's logic,
//! which is generic code over [`Simd`] in the sibling modules.

use super::*;

/// An instruction set's lanes: a token that exists only where the processor has the set
/// ([`Avx2`]: eight lanes, [`Avx512`]: sixteen), and the operations the march's generic code
/// ([`Packets::step`] and what it calls) is written in: `F` holds `N` f32, `I` `N` i32, `M`
/// the lanes of a comparison. Every method is always inlined, so that the generic code
/// compiles to the width's own instructions inside the width's `#[target_feature]` tile
/// function (`Packets::tile_avx2`, `Packets::tile_avx512`).
///
/// # Safety
/// A value of an implementation must exist only where the processor has the features its
/// methods' intrinsics need, AVX2 and FMA among them: its methods call them unchecked, and
/// generic code calls the eight-lane functions (`#[target_feature(enable = "avx2,fma")]`)
/// given any value.
pub(super) unsafe trait Simd<const N: usize>: Copy {
    /// `N` f32.
    type F: Copy;
    /// `N` i32.
    type I: Copy;
    /// A comparison's result in `N` lanes.
    type M: Copy;
    /// Half the lanes' f64 (`N` / 2).
    type D: Copy;
    fn splat(self, x: f32) -> Self::F;
    fn zero(self) -> Self::F;
    fn add(self, a: Self::F, b: Self::F) -> Self::F;
    fn sub(self, a: Self::F, b: Self::F) -> Self::F;
    fn mul(self, a: Self::F, b: Self::F) -> Self::F;
    fn div(self, a: Self::F, b: Self::F) -> Self::F;
    fn min(self, a: Self::F, b: Self::F) -> Self::F;
    fn max(self, a: Self::F, b: Self::F) -> Self::F;
    fn sqrt(self, a: Self::F) -> Self::F;
    fn abs(self, a: Self::F) -> Self::F;
    fn xor(self, a: Self::F, b: Self::F) -> Self::F;
    /// a·b + c, fused.
    fn fmadd(self, a: Self::F, b: Self::F, c: Self::F) -> Self::F;
    /// a·b − c, fused.
    fn fmsub(self, a: Self::F, b: Self::F, c: Self::F) -> Self::F;
    fn lt(self, a: Self::F, b: Self::F) -> Self::M;
    fn le(self, a: Self::F, b: Self::F) -> Self::M;
    fn gt(self, a: Self::F, b: Self::F) -> Self::M;
    fn ge(self, a: Self::F, b: Self::F) -> Self::M;
    fn eq(self, a: Self::F, b: Self::F) -> Self::M;
    fn and_m(self, a: Self::M, b: Self::M) -> Self::M;
    /// The lanes of `b` not in `a`.
    fn andnot_m(self, a: Self::M, b: Self::M) -> Self::M;
    /// The lanes of `m` by bit.
    fn bits(self, m: Self::M) -> u32;
    /// The lanes of the bits of `bits`.
    fn of_bits(self, bits: u32) -> Self::M;
    /// `x` in the lanes of `m`, 0 in the others.
    fn keep(self, m: Self::M, x: Self::F) -> Self::F;
    /// `x` in the lanes not in `m`, 0 in the others.
    fn keep_unless(self, m: Self::M, x: Self::F) -> Self::F;
    /// `b` in the lanes of `m`, `a` in the others.
    fn blend(self, m: Self::M, a: Self::F, b: Self::F) -> Self::F;
    /// `x` in the lanes of the bits of `bits`, 0 in the others.
    fn keep_i(self, bits: u32, x: Self::I) -> Self::I;
    fn splat_i(self, x: i32) -> Self::I;
    fn zero_i(self) -> Self::I;
    fn add_i(self, a: Self::I, b: Self::I) -> Self::I;
    fn sub_i(self, a: Self::I, b: Self::I) -> Self::I;
    fn mullo_i(self, a: Self::I, b: Self::I) -> Self::I;
    fn min_i(self, a: Self::I, b: Self::I) -> Self::I;
    fn max_i(self, a: Self::I, b: Self::I) -> Self::I;
    fn eq_i(self, a: Self::I, b: Self::I) -> Self::M;
    /// Byte `K` (0 to 3) of each lane.
    fn byte<const K: i32>(self, w: Self::I) -> Self::I;
    /// Each lane as f32.
    fn to_f(self, a: Self::I) -> Self::F;
    /// Each lane truncated towards 0.
    fn trunc(self, a: Self::F) -> Self::I;
    /// `k + 1` in the lanes of `m`, `k` in the others.
    fn count(self, k: Self::I, m: Self::M) -> Self::I;
    /// `table[k]` per lane (every lane of `k` in 0..8).
    fn permute8(self, table: &[f32; 8], k: Self::I) -> Self::F;
    /// The four bytes of `raw` from `at` in each lane, as one 32-bit word (the lowest first),
    /// by a gather.
    ///
    /// # Safety
    /// Every lane of `at` must be in `[0, raw.len() − 4]` (the callers clamp to it): the
    /// gather reads four bytes from each lane's index, unchecked.
    unsafe fn gather_bytes(self, raw: &[u8], at: Self::I) -> Self::I;
    fn ld(self, a: &[f32; N]) -> Self::F;
    fn st(self, a: &mut [f32; N], v: Self::F);
    fn ld_i(self, a: &[i32; N]) -> Self::I;
    fn st_i(self, a: &mut [i32; N], v: Self::I);
    /// By bit, the lanes of `a` at most 0 (not NaN).
    fn le_zero_d(self, a: &[f64; N]) -> u32;
    /// By bit, the lanes where `a·s` is `e`.
    fn scaled_eq_d(self, a: &[f64; N], s: f64, e: f64) -> u32;
    fn splat_d(self, x: f64) -> Self::D;
    fn add_d(self, a: Self::D, b: Self::D) -> Self::D;
    fn sub_d(self, a: Self::D, b: Self::D) -> Self::D;
    fn mul_d(self, a: Self::D, b: Self::D) -> Self::D;
    fn min_d(self, a: Self::D, b: Self::D) -> Self::D;
    /// The indices of half `h` (0 or 1) of the lanes, as f64.
    fn iota_d(self, h: usize) -> Self::D;
    /// `t` in the lanes where `a ≥ b`, `x` in the others.
    fn below_or_d(self, a: Self::D, b: Self::D, x: Self::D, t: Self::D) -> Self::D;
    /// Half `h` (0 or 1) of the lanes of `a`.
    fn ld_d(self, a: &[f64; N], h: usize) -> Self::D;
    /// Stores `v` into half `h` (0 or 1) of the lanes of `a`.
    fn st_d(self, a: &mut [f64; N], h: usize, v: Self::D);
    /// The two halves `lo`, `hi` rounded to f32.
    fn narrow(self, lo: Self::D, hi: Self::D) -> Self::F;
    /// Each lane shifted right by 5 (the mask word of a cell index).
    fn shr5_i(self, a: Self::I) -> Self::I;
    /// Each lane of `a` shifted right by the lane of `b`.
    fn srlv_i(self, a: Self::I, b: Self::I) -> Self::I;
    fn and_i(self, a: Self::I, b: Self::I) -> Self::I;
    /// The lanes that are odd.
    fn odd_i(self, a: Self::I) -> Self::M;
    fn gt_i(self, a: Self::I, b: Self::I) -> Self::M;
    fn or_m(self, a: Self::M, b: Self::M) -> Self::M;
    /// `mask[at]` per lane, by a gather.
    ///
    /// # Safety
    /// Every lane of `at` must be in `[0, mask.len() − 1]` (the caller clamps to it): the
    /// gather reads each lane's index unchecked.
    unsafe fn gather_words(self, mask: &[u32], at: Self::I) -> Self::I;
    /// The eight nodes (a + 2b + 4c) of the cells whose first nodes are `base`, from the
    /// node values of `p` (or its 16-bit voxels through their table).
    fn value_nodes(self, p: &Packets<'_>, base: Self::I) -> [Self::F; 8];
    /// [`Packets::differences`]: the central differences from node values (or 16-bit voxels).
    fn value_differences(
        self,
        p: &Packets<'_>,
        base: Self::I,
        inner: u32,
        nodes: &[Self::F; 8],
    ) -> [[Self::F; 3]; 8];
    /// [`Packets::pairs_eval`]: opacity and colour by the tables' segment pairs (only in
    /// eight lanes: the sixteen-lane march has the tables in registers).
    fn pairs_eval(self, p: &Packets<'_>, v: Self::F, pass: u32) -> (Self::F, [Self::F; 3]);
}

/// The eight-lane instruction set: AVX2 and FMA.
#[derive(Clone, Copy)]
pub(super) struct Avx2(());

/// The sixteen-lane instruction set: AVX-512 (F, DQ, BW, VL, CD) with AVX2 and FMA
/// ([`detected`]).
#[derive(Clone, Copy)]
pub(super) struct Avx512(());

impl Avx2 {
    /// The token.
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA.
    #[inline(always)]
    pub(super) unsafe fn new() -> Avx2 {
        Avx2(())
    }
}

impl Avx512 {
    /// The token.
    ///
    /// # Safety
    /// The processor must have every feature [`detected`] asks for, and AVX2 and FMA.
    #[inline(always)]
    pub(super) unsafe fn new() -> Avx512 {
        Avx512(())
    }
}

/// Methods of a [`Simd`] implementation that are one expression of intrinsics each.
macro_rules! ops {
    ($($name:ident $(<$k:ident>)? ($($a:ident: $t:ty),*) -> $r:ty = $e:expr;)*) => {$(
        #[inline(always)]
        fn $name$(<const $k: i32>)?(self, $($a: $t),*) -> $r {
            // SAFETY: a value of `Self` exists only where the processor has its features
            // (`Self::new`), which are all these intrinsics need; they touch no memory.
            unsafe { $e }
        }
    )*};
}

// SAFETY: `Avx2::new`'s contract: a value exists only where the processor has AVX2 and FMA.
unsafe impl Simd<8> for Avx2 {
    type F = __m256;
    type I = __m256i;
    type M = __m256;
    type D = __m256d;
    ops! {
        splat_d(x: f64) -> __m256d = _mm256_set1_pd(x);
        add_d(a: __m256d, b: __m256d) -> __m256d = _mm256_add_pd(a, b);
        sub_d(a: __m256d, b: __m256d) -> __m256d = _mm256_sub_pd(a, b);
        mul_d(a: __m256d, b: __m256d) -> __m256d = _mm256_mul_pd(a, b);
        min_d(a: __m256d, b: __m256d) -> __m256d = _mm256_min_pd(a, b);
        iota_d(h: usize) -> __m256d = {
            let f = (4 * h) as f64;
            _mm256_setr_pd(f, f + 1.0, f + 2.0, f + 3.0)
        };
        below_or_d(a: __m256d, b: __m256d, x: __m256d, t: __m256d) -> __m256d =
            _mm256_blendv_pd(x, t, _mm256_cmp_pd::<_CMP_GE_OQ>(a, b));
        ld_d(a: &[f64; 8], h: usize) -> __m256d = ldd(a, h);
        st_d(a: &mut [f64; 8], h: usize, v: __m256d) -> () = std8d(a, h, v);
        narrow(lo: __m256d, hi: __m256d) -> __m256 =
            _mm256_set_m128(_mm256_cvtpd_ps(hi), _mm256_cvtpd_ps(lo));
        shr5_i(a: __m256i) -> __m256i = _mm256_srli_epi32::<5>(a);
        srlv_i(a: __m256i, b: __m256i) -> __m256i = _mm256_srlv_epi32(a, b);
        and_i(a: __m256i, b: __m256i) -> __m256i = _mm256_and_si256(a, b);
        odd_i(a: __m256i) -> __m256 = {
            let one = _mm256_set1_epi32(1);
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(a, one), one))
        };
        gt_i(a: __m256i, b: __m256i) -> __m256 = _mm256_castsi256_ps(_mm256_cmpgt_epi32(a, b));
        or_m(a: __m256, b: __m256) -> __m256 = _mm256_or_ps(a, b);
        splat(x: f32) -> __m256 = _mm256_set1_ps(x);
        zero() -> __m256 = _mm256_setzero_ps();
        add(a: __m256, b: __m256) -> __m256 = _mm256_add_ps(a, b);
        sub(a: __m256, b: __m256) -> __m256 = _mm256_sub_ps(a, b);
        mul(a: __m256, b: __m256) -> __m256 = _mm256_mul_ps(a, b);
        div(a: __m256, b: __m256) -> __m256 = _mm256_div_ps(a, b);
        min(a: __m256, b: __m256) -> __m256 = _mm256_min_ps(a, b);
        max(a: __m256, b: __m256) -> __m256 = _mm256_max_ps(a, b);
        sqrt(a: __m256) -> __m256 = _mm256_sqrt_ps(a);
        abs(a: __m256) -> __m256 = _mm256_andnot_ps(_mm256_set1_ps(-0.0), a);
        xor(a: __m256, b: __m256) -> __m256 = _mm256_xor_ps(a, b);
        fmadd(a: __m256, b: __m256, c: __m256) -> __m256 = _mm256_fmadd_ps(a, b, c);
        fmsub(a: __m256, b: __m256, c: __m256) -> __m256 = _mm256_fmsub_ps(a, b, c);
        lt(a: __m256, b: __m256) -> __m256 = _mm256_cmp_ps::<_CMP_LT_OQ>(a, b);
        le(a: __m256, b: __m256) -> __m256 = _mm256_cmp_ps::<_CMP_LE_OQ>(a, b);
        gt(a: __m256, b: __m256) -> __m256 = _mm256_cmp_ps::<_CMP_GT_OQ>(a, b);
        ge(a: __m256, b: __m256) -> __m256 = _mm256_cmp_ps::<_CMP_GE_OQ>(a, b);
        eq(a: __m256, b: __m256) -> __m256 = _mm256_cmp_ps::<_CMP_EQ_OQ>(a, b);
        and_m(a: __m256, b: __m256) -> __m256 = _mm256_and_ps(a, b);
        andnot_m(a: __m256, b: __m256) -> __m256 = _mm256_andnot_ps(a, b);
        bits(m: __m256) -> u32 = _mm256_movemask_ps(m) as u32;
        of_bits(bits: u32) -> __m256 = lanes_mask(bits);
        keep(m: __m256, x: __m256) -> __m256 = _mm256_and_ps(x, m);
        keep_unless(m: __m256, x: __m256) -> __m256 = _mm256_andnot_ps(m, x);
        blend(m: __m256, a: __m256, b: __m256) -> __m256 = _mm256_blendv_ps(a, b, m);
        keep_i(bits: u32, x: __m256i) -> __m256i =
            _mm256_and_si256(x, _mm256_castps_si256(lanes_mask(bits)));
        splat_i(x: i32) -> __m256i = _mm256_set1_epi32(x);
        zero_i() -> __m256i = _mm256_setzero_si256();
        add_i(a: __m256i, b: __m256i) -> __m256i = _mm256_add_epi32(a, b);
        sub_i(a: __m256i, b: __m256i) -> __m256i = _mm256_sub_epi32(a, b);
        mullo_i(a: __m256i, b: __m256i) -> __m256i = _mm256_mullo_epi32(a, b);
        min_i(a: __m256i, b: __m256i) -> __m256i = _mm256_min_epi32(a, b);
        max_i(a: __m256i, b: __m256i) -> __m256i = _mm256_max_epi32(a, b);
        eq_i(a: __m256i, b: __m256i) -> __m256 = _mm256_castsi256_ps(_mm256_cmpeq_epi32(a, b));
        byte<K>(w: __m256i) -> __m256i = match K {
            0 => _mm256_and_si256(w, _mm256_set1_epi32(0xff)),
            1 => _mm256_and_si256(_mm256_srli_epi32::<8>(w), _mm256_set1_epi32(0xff)),
            2 => _mm256_and_si256(_mm256_srli_epi32::<16>(w), _mm256_set1_epi32(0xff)),
            _ => _mm256_srli_epi32::<24>(w),
        };
        to_f(a: __m256i) -> __m256 = _mm256_cvtepi32_ps(a);
        trunc(a: __m256) -> __m256i = _mm256_cvttps_epi32(a);
        count(k: __m256i, m: __m256) -> __m256i = _mm256_sub_epi32(k, _mm256_castps_si256(m));
        permute8(table: &[f32; 8], k: __m256i) -> __m256 =
            _mm256_permutevar8x32_ps(ld8(table), k);
        ld(a: &[f32; 8]) -> __m256 = ld8(a);
        st(a: &mut [f32; 8], v: __m256) -> () = st8(a, v);
        ld_i(a: &[i32; 8]) -> __m256i = ld8i(a);
        st_i(a: &mut [i32; 8], v: __m256i) -> () = st8i(a, v);
        le_zero_d(a: &[f64; 8]) -> u32 = {
            let le = |h| _mm256_cmp_pd::<_CMP_LE_OQ>(ldd(a, h), _mm256_setzero_pd());
            _mm256_movemask_pd(le(0)) as u32 | (_mm256_movemask_pd(le(1)) as u32) << 4
        };
        scaled_eq_d(a: &[f64; 8], s: f64, e: f64) -> u32 = {
            let eq = |h| {
                let x = _mm256_mul_pd(ldd(a, h), _mm256_set1_pd(s));
                _mm256_cmp_pd::<_CMP_EQ_OQ>(x, _mm256_set1_pd(e))
            };
            _mm256_movemask_pd(eq(0)) as u32 | (_mm256_movemask_pd(eq(1)) as u32) << 4
        };
    }

    #[inline(always)]
    fn value_nodes(self, p: &Packets<'_>, base: __m256i) -> [__m256; 8] {
        let (sy, sz) = (p.sy, p.sz);
        // SAFETY: `self` shows the processor has AVX2 and FMA, all these functions enable.
        unsafe {
            let cell = Nodes::new(p.values, base, 1 + sy + sz);
            let [n000, n100, n010, n110] = cell.pairs2(0, sy);
            let [n001, n101, n011, n111] = cell.pairs2(sz, sy + sz);
            [n000, n100, n010, n110, n001, n101, n011, n111]
        }
    }

    #[inline(always)]
    fn value_differences(
        self,
        p: &Packets<'_>,
        base: __m256i,
        inner: u32,
        nodes: &[__m256; 8],
    ) -> [[__m256; 3]; 8] {
        // SAFETY: `self` shows the processor has AVX2 and FMA, all this function enables.
        unsafe { p.differences(base, inner, nodes) }
    }

    #[inline(always)]
    fn pairs_eval(self, p: &Packets<'_>, v: __m256, pass: u32) -> (__m256, [__m256; 3]) {
        // SAFETY: `self` shows the processor has AVX2 and FMA, all this function enables.
        unsafe { p.pairs_eval(v, pass) }
    }

    #[inline(always)]
    unsafe fn gather_words(self, mask: &[u32], at: __m256i) -> __m256i {
        // SAFETY: every lane of `at` is in [0, mask.len() − 1] (this function's contract);
        // u32 and i32 have the same size and alignment; `self` shows the processor has AVX2.
        unsafe { _mm256_i32gather_epi32::<4>(mask.as_ptr() as *const i32, at) }
    }

    #[inline(always)]
    unsafe fn gather_bytes(self, raw: &[u8], at: __m256i) -> __m256i {
        // SAFETY: every lane of `at` is in [0, raw.len() − 4] (this function's contract), so
        // the four bytes each lane reads lie inside `raw`; a gather of scale 1 reads unaligned
        // words; `self` shows the processor has AVX2.
        unsafe { _mm256_i32gather_epi32::<1>(raw.as_ptr() as *const i32, at) }
    }
}

// SAFETY: `Avx512::new`'s contract: a value exists only where the processor has its
// AVX-512 features, AVX2 and FMA.
unsafe impl Simd<16> for Avx512 {
    type F = __m512;
    type I = __m512i;
    type M = __mmask16;
    type D = __m512d;
    ops! {
        splat_d(x: f64) -> __m512d = _mm512_set1_pd(x);
        add_d(a: __m512d, b: __m512d) -> __m512d = _mm512_add_pd(a, b);
        sub_d(a: __m512d, b: __m512d) -> __m512d = _mm512_sub_pd(a, b);
        mul_d(a: __m512d, b: __m512d) -> __m512d = _mm512_mul_pd(a, b);
        min_d(a: __m512d, b: __m512d) -> __m512d = _mm512_min_pd(a, b);
        iota_d(h: usize) -> __m512d = {
            let f = (8 * h) as f64;
            _mm512_setr_pd(f, f + 1.0, f + 2.0, f + 3.0, f + 4.0, f + 5.0, f + 6.0, f + 7.0)
        };
        below_or_d(a: __m512d, b: __m512d, x: __m512d, t: __m512d) -> __m512d =
            _mm512_mask_blend_pd(_mm512_cmp_pd_mask::<_CMP_GE_OQ>(a, b), x, t);
        ld_d(a: &[f64; 16], h: usize) -> __m512d = ld8d(a, h);
        st_d(a: &mut [f64; 16], h: usize, v: __m512d) -> () = st8d(a, h, v);
        narrow(lo: __m512d, hi: __m512d) -> __m512 = _mm512_insertf32x8::<1>(
            _mm512_castps256_ps512(_mm512_cvtpd_ps(lo)),
            _mm512_cvtpd_ps(hi),
        );
        shr5_i(a: __m512i) -> __m512i = _mm512_srli_epi32::<5>(a);
        srlv_i(a: __m512i, b: __m512i) -> __m512i = _mm512_srlv_epi32(a, b);
        and_i(a: __m512i, b: __m512i) -> __m512i = _mm512_and_si512(a, b);
        odd_i(a: __m512i) -> __mmask16 = _mm512_test_epi32_mask(a, _mm512_set1_epi32(1));
        gt_i(a: __m512i, b: __m512i) -> __mmask16 = _mm512_cmpgt_epi32_mask(a, b);
        splat(x: f32) -> __m512 = _mm512_set1_ps(x);
        zero() -> __m512 = _mm512_setzero_ps();
        add(a: __m512, b: __m512) -> __m512 = _mm512_add_ps(a, b);
        sub(a: __m512, b: __m512) -> __m512 = _mm512_sub_ps(a, b);
        mul(a: __m512, b: __m512) -> __m512 = _mm512_mul_ps(a, b);
        div(a: __m512, b: __m512) -> __m512 = _mm512_div_ps(a, b);
        min(a: __m512, b: __m512) -> __m512 = _mm512_min_ps(a, b);
        max(a: __m512, b: __m512) -> __m512 = _mm512_max_ps(a, b);
        sqrt(a: __m512) -> __m512 = _mm512_sqrt_ps(a);
        abs(a: __m512) -> __m512 = _mm512_abs_ps(a);
        xor(a: __m512, b: __m512) -> __m512 = _mm512_xor_ps(a, b);
        fmadd(a: __m512, b: __m512, c: __m512) -> __m512 = _mm512_fmadd_ps(a, b, c);
        fmsub(a: __m512, b: __m512, c: __m512) -> __m512 = _mm512_fmsub_ps(a, b, c);
        lt(a: __m512, b: __m512) -> __mmask16 = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(a, b);
        le(a: __m512, b: __m512) -> __mmask16 = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(a, b);
        gt(a: __m512, b: __m512) -> __mmask16 = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(a, b);
        ge(a: __m512, b: __m512) -> __mmask16 = _mm512_cmp_ps_mask::<_CMP_GE_OQ>(a, b);
        eq(a: __m512, b: __m512) -> __mmask16 = _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(a, b);
        keep(m: __mmask16, x: __m512) -> __m512 = _mm512_maskz_mov_ps(m, x);
        keep_unless(m: __mmask16, x: __m512) -> __m512 = _mm512_maskz_mov_ps(!m, x);
        blend(m: __mmask16, a: __m512, b: __m512) -> __m512 = _mm512_mask_blend_ps(m, a, b);
        keep_i(bits: u32, x: __m512i) -> __m512i = _mm512_maskz_mov_epi32(bits as u16, x);
        splat_i(x: i32) -> __m512i = _mm512_set1_epi32(x);
        zero_i() -> __m512i = _mm512_setzero_si512();
        add_i(a: __m512i, b: __m512i) -> __m512i = _mm512_add_epi32(a, b);
        sub_i(a: __m512i, b: __m512i) -> __m512i = _mm512_sub_epi32(a, b);
        mullo_i(a: __m512i, b: __m512i) -> __m512i = _mm512_mullo_epi32(a, b);
        min_i(a: __m512i, b: __m512i) -> __m512i = _mm512_min_epi32(a, b);
        max_i(a: __m512i, b: __m512i) -> __m512i = _mm512_max_epi32(a, b);
        eq_i(a: __m512i, b: __m512i) -> __mmask16 = _mm512_cmpeq_epi32_mask(a, b);
        byte<K>(w: __m512i) -> __m512i = match K {
            0 => _mm512_and_si512(w, _mm512_set1_epi32(0xff)),
            1 => _mm512_and_si512(_mm512_srli_epi32::<8>(w), _mm512_set1_epi32(0xff)),
            2 => _mm512_and_si512(_mm512_srli_epi32::<16>(w), _mm512_set1_epi32(0xff)),
            _ => _mm512_srli_epi32::<24>(w),
        };
        to_f(a: __m512i) -> __m512 = _mm512_cvtepi32_ps(a);
        trunc(a: __m512) -> __m512i = _mm512_cvttps_epi32(a);
        count(k: __m512i, m: __mmask16) -> __m512i =
            _mm512_mask_add_epi32(k, m, k, _mm512_set1_epi32(1));
        permute8(table: &[f32; 8], k: __m512i) -> __m512 =
            _mm512_permutexvar_ps(k, _mm512_castps256_ps512(ld8(table)));
        ld(a: &[f32; 16]) -> __m512 = ld16(a);
        st(a: &mut [f32; 16], v: __m512) -> () = st16(a, v);
        ld_i(a: &[i32; 16]) -> __m512i = ld16i(a);
        st_i(a: &mut [i32; 16], v: __m512i) -> () = st16i(a, v);
        le_zero_d(a: &[f64; 16]) -> u32 = {
            let le = |h| _mm512_cmp_pd_mask::<_CMP_LE_OQ>(ld8d(a, h), _mm512_setzero_pd());
            le(0) as u32 | (le(1) as u32) << 8
        };
        scaled_eq_d(a: &[f64; 16], s: f64, e: f64) -> u32 = {
            let eq = |h| {
                let x = _mm512_mul_pd(ld8d(a, h), _mm512_set1_pd(s));
                _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(x, _mm512_set1_pd(e))
            };
            eq(0) as u32 | (eq(1) as u32) << 8
        };
    }

    #[inline(always)]
    fn or_m(self, a: __mmask16, b: __mmask16) -> __mmask16 {
        a | b
    }

    #[inline(always)]
    fn and_m(self, a: __mmask16, b: __mmask16) -> __mmask16 {
        a & b
    }

    #[inline(always)]
    fn andnot_m(self, a: __mmask16, b: __mmask16) -> __mmask16 {
        !a & b
    }

    #[inline(always)]
    fn bits(self, m: __mmask16) -> u32 {
        m as u32
    }

    #[inline(always)]
    fn of_bits(self, bits: u32) -> __mmask16 {
        bits as u16
    }

    /// Eight lanes at a time: each half by [`Avx2`]'s reads, joined.
    #[inline(always)]
    fn value_nodes(self, p: &Packets<'_>, base: __m512i) -> [__m512; 8] {
        // SAFETY: `self` exists only where the processor has every feature `Avx512::new`'s
        // contract names, AVX2 and FMA among them: `Avx2::new`'s contract, and every feature
        // `halves_i` and `join` enable (AVX-512 F and DQ, AVX2).
        unsafe {
            let a = Avx2::new();
            let (lo, hi) = halves_i(base);
            let (lo, hi) = (a.value_nodes(p, lo), a.value_nodes(p, hi));
            std::array::from_fn(|k| join(lo[k], hi[k]))
        }
    }

    /// Eight lanes at a time, as [`Avx512::value_nodes`].
    #[inline(always)]
    fn value_differences(
        self,
        p: &Packets<'_>,
        base: __m512i,
        inner: u32,
        nodes: &[__m512; 8],
    ) -> [[__m512; 3]; 8] {
        // SAFETY: as in `value_nodes` (`halves` enables AVX-512 F and DQ, AVX2).
        unsafe {
            let a = Avx2::new();
            let (lo, hi) = halves_i(base);
            let split = nodes.map(|n| halves(n));
            let lo = a.value_differences(p, lo, inner & 0xff, &split.map(|h| h.0));
            let hi = a.value_differences(p, hi, inner >> 8 & 0xff, &split.map(|h| h.1));
            std::array::from_fn(|k| std::array::from_fn(|axis| join(lo[k][axis], hi[k][axis])))
        }
    }

    fn pairs_eval(self, _: &Packets<'_>, _: __m512, _: u32) -> (__m512, [__m512; 3]) {
        unreachable!("the sixteen-lane march has its tables in registers (`Packets::new`)")
    }

    #[inline(always)]
    unsafe fn gather_words(self, mask: &[u32], at: __m512i) -> __m512i {
        // SAFETY: every lane of `at` is in [0, mask.len() − 1] (this function's contract);
        // u32 and i32 have the same size and alignment; `self` shows the processor has
        // AVX-512F.
        unsafe { _mm512_i32gather_epi32::<4>(at, mask.as_ptr() as *const i32) }
    }

    #[inline(always)]
    unsafe fn gather_bytes(self, raw: &[u8], at: __m512i) -> __m512i {
        // SAFETY: every lane of `at` is in [0, raw.len() − 4] (this function's contract), so
        // the four bytes each lane reads lie inside `raw`; a gather of scale 1 reads unaligned
        // words; `self` shows the processor has AVX-512F.
        unsafe { _mm512_i32gather_epi32::<1>(at, raw.as_ptr() as *const i32) }
    }
}

/// The eight f32 of `a` as a register.
#[inline]
#[target_feature(enable = "avx")]
pub(super) fn ld8(a: &[f32; W]) -> __m256 {
    // SAFETY: `a` is 8 f32, 32 readable bytes; the load has no alignment requirement.
    unsafe { _mm256_loadu_ps(a.as_ptr()) }
}

/// Stores the register `v` into the eight f32 of `a`.
#[inline]
#[target_feature(enable = "avx")]
pub(super) fn st8(a: &mut [f32; W], v: __m256) {
    // SAFETY: `a` is 8 f32, 32 writable bytes; the store has no alignment requirement.
    unsafe { _mm256_storeu_ps(a.as_mut_ptr(), v) }
}

/// Stores the register `v` into lanes `4h .. 4h + 4` of `a` (h is 0 or 1).
#[inline]
#[target_feature(enable = "avx")]
pub(super) fn std8d(a: &mut [f64; W], h: usize, v: __m256d) {
    let q: &mut [f64; 4] = (&mut a[4 * h..4 * h + 4]).try_into().expect("four lanes");
    // SAFETY: `q` is 4 f64, 32 writable bytes; the store has no alignment requirement.
    unsafe { _mm256_storeu_pd(q.as_mut_ptr(), v) }
}

/// Simd `4h .. 4h + 4` of `a` (h is 0 or 1) as a register.
#[inline]
#[target_feature(enable = "avx")]
pub(super) fn ldd(a: &[f64; W], h: usize) -> __m256d {
    let q: &[f64; 4] = a[4 * h..4 * h + 4].try_into().expect("four lanes");
    // SAFETY: `q` is 4 f64, 32 readable bytes; the load has no alignment requirement.
    unsafe { _mm256_loadu_pd(q.as_ptr()) }
}

/// The eight i32 of `a` as a register.
#[inline]
#[target_feature(enable = "avx")]
pub(super) fn ld8i(a: &[i32; W]) -> __m256i {
    // SAFETY: `a` is 8 i32, 32 readable bytes; the load has no alignment requirement.
    unsafe { _mm256_loadu_si256(a.as_ptr() as *const __m256i) }
}

/// Stores the register `v` into the eight i32 of `a`.
#[inline]
#[target_feature(enable = "avx")]
pub(super) fn st8i(a: &mut [i32; W], v: __m256i) {
    // SAFETY: `a` is 8 i32, 32 writable bytes; the store has no alignment requirement.
    unsafe { _mm256_storeu_si256(a.as_mut_ptr() as *mut __m256i, v) }
}

/// Simd `8h .. 8h + 8` of `a` (h is 0 or 1) as a register.
#[inline]
#[target_feature(enable = "avx512f")]
pub(super) fn ld8d(a: &[f64; V], h: usize) -> __m512d {
    let q: &[f64; 8] = a[8 * h..8 * h + 8].try_into().expect("eight lanes");
    // SAFETY: `q` is 8 f64, 64 readable bytes; the load has no alignment requirement.
    unsafe { _mm512_loadu_pd(q.as_ptr()) }
}

/// Stores `v` into lanes `8h .. 8h + 8` of `a` (h is 0 or 1).
#[inline]
#[target_feature(enable = "avx512f")]
pub(super) fn st8d(a: &mut [f64; V], h: usize, v: __m512d) {
    let q: &mut [f64; 8] = (&mut a[8 * h..8 * h + 8]).try_into().expect("eight lanes");
    // SAFETY: `q` is 8 f64, 64 writable bytes; the store has no alignment requirement.
    unsafe { _mm512_storeu_pd(q.as_mut_ptr(), v) }
}

/// The sixteen f32 of `a` as a register.
#[inline]
#[target_feature(enable = "avx512f")]
pub(super) fn ld16(a: &[f32; V]) -> __m512 {
    // SAFETY: `a` is 16 f32, 64 readable bytes; the load has no alignment requirement.
    unsafe { _mm512_loadu_ps(a.as_ptr()) }
}

/// Stores `v` into the sixteen f32 of `a`.
#[inline]
#[target_feature(enable = "avx512f")]
pub(super) fn st16(a: &mut [f32; V], v: __m512) {
    // SAFETY: `a` is 16 f32, 64 writable bytes; the store has no alignment requirement.
    unsafe { _mm512_storeu_ps(a.as_mut_ptr(), v) }
}

/// The sixteen i32 of `a` as a register.
#[inline]
#[target_feature(enable = "avx512f")]
pub(super) fn ld16i(a: &[i32; V]) -> __m512i {
    // SAFETY: `a` is 16 i32, 64 readable bytes; the load has no alignment requirement.
    unsafe { _mm512_loadu_si512(a.as_ptr() as *const _) }
}

/// Stores `v` into the sixteen i32 of `a`.
#[inline]
#[target_feature(enable = "avx512f")]
pub(super) fn st16i(a: &mut [i32; V], v: __m512i) {
    // SAFETY: `a` is 16 i32, 64 writable bytes; the store has no alignment requirement.
    unsafe { _mm512_storeu_si512(a.as_mut_ptr() as *mut _, v) }
}

/// Lanes 0–7 and 8–15 of `a`.
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx2")]
fn halves(a: __m512) -> (__m256, __m256) {
    (_mm512_castps512_ps256(a), _mm512_extractf32x8_ps::<1>(a))
}

/// Lanes 0–7 and 8–15 of `a`.
#[inline]
#[target_feature(enable = "avx512f,avx2")]
fn halves_i(a: __m512i) -> (__m256i, __m256i) {
    (_mm512_castsi512_si256(a), _mm512_extracti64x4_epi64::<1>(a))
}

/// The sixteen lanes of `lo` (0–7) and `hi` (8–15).
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx2")]
fn join(lo: __m256, hi: __m256) -> __m512 {
    _mm512_insertf32x8::<1>(_mm512_castps256_ps512(lo), hi)
}
