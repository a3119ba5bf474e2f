//! Helpers shared by the unit tests.

use std::cell::Cell;

#[path = "../tests/common/lcg.rs"]
mod lcg;
pub(crate) use lcg::Lcg;

/// The xorshift64 generator (shifts 13, 7, 17) the unit tests draw their random inputs from:
/// raw bits, or numbers in [0, 1). Its state is in a `Cell`, so several closures of a test
/// can draw from one generator.
pub(crate) struct Xorshift(Cell<u64>);

impl Xorshift {
    /// A generator starting from `seed` (not 0: xorshift stays at 0).
    pub(crate) fn new(seed: u64) -> Xorshift {
        assert_ne!(seed, 0, "xorshift needs a seed other than 0");
        Xorshift(Cell::new(seed))
    }

    /// The next 64 random bits.
    pub(crate) fn bits(&self) -> u64 {
        let mut x = self.0.get();
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.0.set(x);
        x
    }

    /// The next number in [0, 1): the top 53 bits over 2⁵³.
    pub(crate) fn next(&self) -> f64 {
        (self.bits() >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first outputs of seed 1, by the recurrence worked by hand: x ^= x << 13 gives
    /// 0x2001, x ^= x >> 7 gives 0x2041 (0x2001 >> 7 = 0x40), x ^= x << 17 gives
    /// 0x2041 ^ 0x4082_0000 = 0x4082_2041; and `next` is its top 53 bits over 2⁵³.
    #[test]
    fn xorshift_is_the_recurrence() {
        let g = Xorshift::new(1);
        assert_eq!(g.bits(), 0x4082_2041);
        let h = Xorshift::new(1);
        h.bits();
        let second = g.bits();
        assert_eq!(h.next(), (second >> 11) as f64 / (1u64 << 53) as f64);
    }
}
