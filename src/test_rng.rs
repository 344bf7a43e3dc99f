//! The unit tests' seeded random numbers: xoshiro256++ (`rand_xoshiro`), the generator of the
//! simulator (`host-tests`) and of `ekf-core`'s tests.

use rand_xoshiro::rand_core::{Rng as _, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// A seeded generator.
pub struct TestRng(Xoshiro256PlusPlus);

impl TestRng {
    /// The generator for `seed` (SplitMix64 seeding).
    pub fn new(seed: u64) -> Self {
        TestRng(Xoshiro256PlusPlus::seed_from_u64(seed))
    }

    /// 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// Uniform in `0..n` (`0` for `n = 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }

    /// Uniform in [−a, a).
    pub fn uniform(&mut self, a: f32) -> f32 {
        let x = (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        (2.0 * x - 1.0) * a
    }
}
