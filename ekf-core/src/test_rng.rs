//! The unit tests' seeded noise: xoshiro256++ (`rand_xoshiro`, the generator of the simulator
//! in `host-tests` and of `tests/common`), one generator for every test of this crate.

use rand_xoshiro::rand_core::{Rng as _, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::Vec3;

/// A seeded generator of uniform and normal deviates.
pub struct TestRng(Xoshiro256PlusPlus);

impl TestRng {
    /// The generator for `seed` (SplitMix64 seeding).
    pub fn new(seed: u64) -> Self {
        TestRng(Xoshiro256PlusPlus::seed_from_u64(seed))
    }

    /// Uniform in [−1, 1), 53 bits.
    pub fn uniform(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (2.0 / (1u64 << 53) as f64) - 1.0
    }

    /// Standard normal deviate (Box–Muller; one of the pair).
    pub fn normal(&mut self) -> f32 {
        let u = (self.uniform() + 1.0) * 0.5; // [0, 1)
        let v = self.uniform();
        (libm::sqrt(-2.0 * libm::log(1.0 - u)) * libm::cos(core::f64::consts::PI * v)) as f32
    }

    /// A vector with components uniform in [−amp, amp).
    pub fn vec(&mut self, amp: f32) -> Vec3 {
        Vec3::new(
            self.uniform() as f32 * amp,
            self.uniform() as f32 * amp,
            self.uniform() as f32 * amp,
        )
    }
}
