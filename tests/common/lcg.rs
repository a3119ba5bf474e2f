//! A small deterministic generator (64-bit LCG, top bits), so the tests need no crates;
//! included by the tests that draw random inputs (`#[path = "common/lcg.rs"] mod lcg;`).

pub struct Lcg(pub u64);

impl Lcg {
    /// The next number, uniform in [0, 1) (53 bits).
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}
