//! The opacity correction `(1 − o)^e` of the packet march's samples whose exponent e (the
//! sample's length over the reference length) is not one of the step's common ones
//! ([`transmit_lanes`](super::transmit_lanes)): every sample, where the step is no
//! power-of-two fraction or multiple of the reference length, as for a scan whose voxel size
//! is not one (`--fit` in `examples/mni`, the scaling table's volumes), and the segments of
//! another length at a ray's ends. [`transmit_any`] gives each lane the f32 that the scalar
//! `transmit_at_most_one(o, e) as f32` gives, bit for bit, in about a third of the time of
//! calling `pow` lane by lane (eight AVX2 lanes): `exp(e·ln(1 − o))` in f64 arithmetic over
//! the lanes (plain loops that the compiler vectorises inside the march's target features),
//! within a relative 10⁻¹³ of the exact power (`ln` by the series of atanh, `exp` by Cody and
//! Waite's reduction and a Taylor polynomial, both by Estrin's scheme; see [`power()`]). A
//! lane's result is taken where every f64 within a relative [`GUARD`] of it (ten times that
//! bound) rounds to the same f32, so that the exact power rounds to it too, and so does
//! `pow`'s result wherever `pow` is within 9·10⁻¹³ of the exact power (glibc's is within one
//! unit in the last place, 2·10⁻¹⁶); the others (a lane in about 3·10⁴, and every lane
//! outside the domain: 1 − o outside (0, 1], e negative or not finite) go through the scalar
//! code. Not here: the common exponents' square roots, which lanes need this
//! (`Packets::step`).

use crate::render::integrate::transmit_at_most_one;

/// The relative half-width of the interval around a lane's power that must round to one f32
/// for the lane to take it (see the module documentation): ten times the bound on
/// [`power()`]'s relative error.
pub(super) const GUARD: f64 = 1e-12;

/// `ln 2` in two parts: the high one's last 21 bits are 0, so that its product with an
/// integer below 2²¹ in magnitude is exact.
const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;

/// 2⁵²: an integer below 2⁵² in its mantissa's bits is its value plus 2⁵².
const TWO52: f64 = 4_503_599_627_370_496.0;

/// `(1 − o)^e` in the lanes of `lanes` (at most N of them) of opacities `o` (f32, as the tables
/// give them) and exponents `e`, into `t`: `transmit_at_most_one(o, e) as f32`, bit for bit
/// (see the module documentation). The other lanes of `t` are left as they are. Returns the
/// lanes that went through the scalar code (for the tests).
#[inline(always)]
pub(super) fn transmit_any<const N: usize>(
    o: &[f32; N],
    e: &[f64; N],
    lanes: u32,
    t: &mut [f32; N],
) -> u32 {
    // Every lane, branch-free (what a lane outside the domain computes is not used): the
    // f32s that the lower and the upper end of the guard interval round to.
    let mut lo = [0f32; N];
    let mut hi = [0f32; N];
    for i in 0..N {
        let x = power(1.0 - o[i] as f64, e[i]);
        lo[i] = (x * (1.0 - GUARD)) as f32;
        hi[i] = (x * (1.0 + GUARD)) as f32;
    }
    let mut scalar = 0;
    for i in 0..N {
        if lanes >> i & 1 == 0 {
            continue;
        }
        let base = 1.0 - o[i] as f64;
        // (NaN fails every comparison here.)
        let domain = base > 0.0 && base <= 1.0 && e[i] >= 0.0 && e[i] <= f64::MAX;
        t[i] = if domain && lo[i] == hi[i] {
            hi[i]
        } else {
            scalar |= 1 << i;
            transmit_at_most_one(o[i] as f64, e[i]) as f32
        };
    }
    scalar
}

/// `b^e` for a normal b in (0, 1] (from an f32 opacity: b = 1 − o ≥ 2⁻²⁴) and a finite
/// e ≥ 0, within a relative 10⁻¹³ where e·ln b ≥ −105 (the rounding of `ln b` and its product
/// with e, about 7·2⁻⁵³ of y = e·ln b, carried into exp y as that much of |y|, plus exp's own
/// few units in the last place; measured: 3·10⁻¹⁴ near −105, 3·10⁻¹⁶ above −1); below −105
/// the power is 0 in f32 and this gives at most 10⁻⁴⁵. Other arguments give some number.
/// Branch-free, so that a loop of it vectorises.
#[inline(always)]
pub(super) fn power(b: f64, e: f64) -> f64 {
    // ln b = k·ln 2 + ln m, m in [√½, √2): ln m = 2·atanh(s), s = (m − 1)/(m + 1), |s| ≤
    // 0.1716, by its series to s²³ (the next term below 10⁻¹⁸ of the sum).
    // (No conversion between f64 and integers, which AVX2 has no lanes for: the biased
    // exponent put in the mantissa of 2⁵² makes 2⁵² + 1023 + k.)
    let bits = b.to_bits();
    let k = f64::from_bits((bits >> 52 & 0x7ff) | TWO52.to_bits()) - (TWO52 + 1023.0);
    let m = f64::from_bits((bits & ((1u64 << 52) - 1)) | (1023u64 << 52));
    let big = m > std::f64::consts::SQRT_2;
    let (m, k) = if big { (m * 0.5, k + 1.0) } else { (m, k) };
    // (m − 1 is exact: m is within a factor of two of 1.)
    let s = (m - 1.0) / (m + 1.0);
    let z = s * s;
    // (Estrin's scheme: a tree of products a few deep, not Horner's chain of twelve, as the
    // march waits for the result.)
    let c = |j: u32| 1.0 / (2 * j + 1) as f64;
    let z2 = z * z;
    let z4 = z2 * z2;
    let pair = |j: u32| c(j) + c(j + 1) * z;
    let quad = |j: u32| pair(j) + pair(j + 2) * z2;
    let series = quad(0) + z4 * (quad(4) + quad(8) * z4);
    let ln_m = 2.0 * s * series;
    let ln_b = k * LN2_HI + (k * LN2_LO + ln_m);
    // exp y = 2ⁿ·exp r, n = y/ln 2 rounded to even (by the 1.5·2⁵² trick), |r| ≤ ln 2 / 2:
    // exp r by its Taylor polynomial to r¹³ (the next term below 10⁻¹⁷). y at least −700,
    // so that 2ⁿ is a normal f64 (exp −700 is 0 in f32 as the true power is).
    let y = (e * ln_b).max(-700.0);
    // (y·log₂e + 1.5·2⁵² holds n + 2⁵¹ in its mantissa's bits: below, n + 1023 in its last
    // eleven.)
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let shifted = y * std::f64::consts::LOG2_E + ROUND;
    let n = shifted - ROUND;
    let r = (y - n * LN2_HI) - n * LN2_LO;
    let r2 = r * r;
    let r4 = r2 * r2;
    let a = |j: u32| 1.0 / (1..=u64::from(j)).product::<u64>() as f64;
    let pair = |j: u32| a(j) + a(j + 1) * r;
    let quad = |j: u32| pair(j) + pair(j + 2) * r2;
    let p = quad(0) + r4 * (quad(4) + r4 * (quad(8) + pair(12) * r4));
    // (n in [−1010, 0]: n + 1023 is a normal exponent, below 2¹¹; a lane outside the
    // domain may hold anything here, masked to the exponent's bits.)
    let scale = f64::from_bits((shifted.to_bits().wrapping_add(1023) & 0x7ff) << 52);
    p * scale
}
