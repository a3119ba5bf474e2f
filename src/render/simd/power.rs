//! The opacity correction `(1 − o)^e` of the packet march's samples whose exponent e (the
//! sample's length over the reference length) is not one of the step's common ones
//! ([`transmit_lanes`]): every sample, where the step is no power-of-two fraction or multiple
//! of the reference length, as for a scan whose voxel size is not one (`--fit` in
//! `examples/mni`, the scaling table's volumes), and the segments of another length at a
//! ray's ends. [`transmit_any`] gives each lane the f32 that the scalar
//! `transmit_at_most_one(o, e) as f32` gives, bit for bit, about ten times faster than calling
//! `pow` lane by lane: `exp(e·ln(1 − o))` in f64 arithmetic over the lanes (plain loops that
//! the compiler vectorises inside the march's target features), within a relative 10⁻¹³ of
//! the exact power (`ln` by the series of atanh, `exp` by Cody and Waite's reduction and a
//! Taylor polynomial). A lane's result is taken where every f64 within a relative [`GUARD`] of
//! it (ten times that error, and libm's `pow` is within one unit in the last place) rounds to
//! the same f32, so that the exact power and `pow`'s round to it too; the others (a lane in
//! about 3·10⁴, and every lane outside the domain: 1 − o outside (0, 1], e negative or not
//! finite) go through the scalar code. Not here: the common exponents' square roots
//! ([`transmit_lanes`]), which lanes need this (`Packets::step`).

use crate::render::integrate::transmit_at_most_one;

/// The relative half-width of the interval around a lane's power that must round to one f32
/// for the lane to take it (see the module documentation): at least ten times the powers'
/// own relative error (7·10⁻¹⁴ for the largest exponents whose power is not 0 in f32, see
/// [`power`]) plus `pow`'s (2.2·10⁻¹⁶).
pub(super) const GUARD: f64 = 1e-12;

/// `ln 2` in two parts: the high one's last 21 bits are 0, so that its product with an
/// integer below 2²¹ in magnitude is exact.
const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;

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

/// `b^e` for b in (0, 1] and a finite e ≥ 0, within a relative 7·10⁻¹⁴ where the power is at
/// least 10⁻⁴⁶ (an exponent of e·ln b ≥ −105; below, the power is 0 in f32, and this gives at
/// most 10⁻⁴⁵), within 10⁻¹⁵ where e·ln b ≥ −1; other arguments give some number. Branch-free,
/// so that a loop of it vectorises.
#[inline(always)]
pub(super) fn power(b: f64, e: f64) -> f64 {
    // ln b = k·ln 2 + ln m, m in [√½, √2): ln m = 2·atanh(s), s = (m − 1)/(m + 1), |s| ≤
    // 0.1716, by its series to s²³ (the next term below 10⁻¹⁸ of the sum).
    let bits = b.to_bits();
    let k = ((bits >> 52) & 0x7ff) as i64 - 1023;
    let m = f64::from_bits((bits & ((1u64 << 52) - 1)) | (1023u64 << 52));
    let big = m > std::f64::consts::SQRT_2;
    let (m, k) = if big { (m * 0.5, k + 1) } else { (m, k) };
    // (m − 1 is exact: m is within a factor of two of 1.)
    let s = (m - 1.0) / (m + 1.0);
    let z = s * s;
    const ODD: [f64; 12] = [
        1.0 / 23.0,
        1.0 / 21.0,
        1.0 / 19.0,
        1.0 / 17.0,
        1.0 / 15.0,
        1.0 / 13.0,
        1.0 / 11.0,
        1.0 / 9.0,
        1.0 / 7.0,
        1.0 / 5.0,
        1.0 / 3.0,
        1.0,
    ];
    let mut series = ODD[0];
    for c in &ODD[1..] {
        series = series * z + c;
    }
    let ln_m = 2.0 * s * series;
    let kf = k as f64;
    let ln_b = kf * LN2_HI + (kf * LN2_LO + ln_m);
    // exp y = 2ⁿ·exp r, n = y/ln 2 rounded to even (by the 1.5·2⁵² trick), |r| ≤ ln 2 / 2:
    // exp r by its Taylor polynomial to r¹³ (the next term below 10⁻¹⁷). y at least −700,
    // so that 2ⁿ is a normal f64 (exp −700 is 0 in f32 as the true power is).
    let y = (e * ln_b).max(-700.0);
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let n = (y * std::f64::consts::LOG2_E + ROUND) - ROUND;
    let r = (y - n * LN2_HI) - n * LN2_LO;
    const TAYLOR: [f64; 14] = [
        1.0 / 6_227_020_800.0,
        1.0 / 479_001_600.0,
        1.0 / 39_916_800.0,
        1.0 / 3_628_800.0,
        1.0 / 362_880.0,
        1.0 / 40_320.0,
        1.0 / 5_040.0,
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        0.5,
        1.0,
        1.0,
    ];
    let mut p = TAYLOR[0];
    for c in &TAYLOR[1..] {
        p = p * r + c;
    }
    // (n in [−1010, 0]: n + 1023 is a normal exponent; a lane outside the domain may hold
    // anything here, masked to the exponent's bits.)
    let scale = f64::from_bits((((n as i64 + 1023) as u64) & 0x7ff) << 52);
    p * scale
}
