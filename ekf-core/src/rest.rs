//! Rest detection for a slow ROV: blocks of samples (2 s by default) are tested for stillness
//! — bias-corrected mean rate and gyro variance per axis, accelerometer spread — and rest is
//! declared after a number of consecutive still blocks. A still block's mean rate measures the
//! gyro-bias error; the EKF uses it to re-estimate the bias and to hold yaw.
//!
//! The mean-rate threshold is `rate_threshold + 3·σᵢ/√n` per axis (σᵢ the configured per-sample
//! noise at the actual rate), so with the defaults a steady 0.5 °/s turn is motion on the
//! board's z gyro (threshold ≈ 0.22 °/s at 50 Hz) and on its noisier x/y gyros (≈ 0.36 °/s).

use crate::{
    mathf,
    settings::{NoiseSettings, RestSettings},
    Vec3,
};

/// One finished block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestBlock {
    /// The block passed every stillness test.
    pub still: bool,
    /// Rest is declared (this block and the `min_blocks − 1` before it were still).
    pub at_rest: bool,
    /// Mean bias-corrected rate over the block, rad/s, body FRD.
    pub mean_rate: Vec3,
    /// Variance of that mean from the configured gyro noise, (rad/s)² per axis.
    pub mean_var: Vec3,
    /// Samples in the block.
    pub n: u32,
}

/// Block statistics accumulator.
#[derive(Clone, Copy, Debug)]
pub struct RestDetector {
    settings: RestSettings,
    n: u32,
    t: f32,
    g_sum: Vec3,
    g_sq: Vec3,
    a_ref: Option<Vec3>,
    a_n: u32,
    a_sum: Vec3,
    a_sq: Vec3,
    broken: bool,
    still_blocks: u8,
}

impl RestDetector {
    /// A detector with no history.
    pub fn new(settings: RestSettings) -> Self {
        RestDetector {
            settings,
            n: 0,
            t: 0.0,
            g_sum: Vec3::ZERO,
            g_sq: Vec3::ZERO,
            a_ref: None,
            a_n: 0,
            a_sum: Vec3::ZERO,
            a_sq: Vec3::ZERO,
            broken: false,
            still_blocks: 0,
        }
    }

    /// Forget the current block and the rest state.
    pub fn reset(&mut self) {
        *self = RestDetector::new(self.settings);
    }

    /// True while rest is declared.
    pub fn at_rest(&self) -> bool {
        self.still_blocks >= self.settings.min_blocks.max(1)
    }

    /// Add a sample: `dt` s, the bias-corrected gyro (rad/s) or `None` when invalid, the
    /// accelerometer (g) or `None` when invalid. Returns the block when it completes.
    pub fn push(
        &mut self,
        dt: f32,
        rate: Option<Vec3>,
        accel_g: Option<Vec3>,
        noise: &NoiseSettings,
    ) -> Option<RestBlock> {
        if !self.settings.enabled {
            return None;
        }
        self.n += 1;
        self.t += dt;
        match rate {
            Some(w) => {
                self.g_sum += w;
                self.g_sq += w.mul_elem(w);
            }
            None => self.broken = true,
        }
        match accel_g {
            Some(a) => {
                // Shift by the block's first sample so the sums of squares stay well
                // conditioned in f32.
                let r = *self.a_ref.get_or_insert(a);
                let d = a - r;
                self.a_n += 1;
                self.a_sum += d;
                self.a_sq += d.mul_elem(d);
            }
            None => self.broken = true,
        }
        if self.t < self.settings.block_s {
            return None;
        }
        let block = self.finish(noise);
        let (settings, still_blocks) = (self.settings, self.still_blocks);
        *self = RestDetector::new(settings);
        self.still_blocks = if block.still { still_blocks.saturating_add(1) } else { 0 };
        Some(RestBlock { at_rest: self.at_rest(), ..block })
    }

    fn finish(&self, noise: &NoiseSettings) -> RestBlock {
        let n = self.n.max(1) as f32;
        let mean = self.g_sum * (1.0 / n);
        // Per-sample noise variance at the actual rate (constant density).
        let rate_hz = n / self.t.max(1e-6);
        let var = noise.gyro_var * (rate_hz / noise.gyro_ref_rate_hz.max(1e-3));
        let mean_var = var * (1.0 / n);
        let mut still = !self.broken && self.n >= 4 && self.a_n == self.n;
        for i in 0..3 {
            let sample_var = (self.g_sq[i] - n * mean[i] * mean[i]) / (n - 1.0).max(1.0);
            let thr = self.settings.rate_threshold + 3.0 * mathf::sqrt(mean_var[i]);
            still &= mathf::abs(mean[i]) <= thr;
            still &= sample_var <= self.settings.gyro_var_factor * var[i];
            let am = self.a_sum[i] / n;
            let a_var = (self.a_sq[i] - n * am * am) / (n - 1.0).max(1.0);
            still &= a_var <= self.settings.accel_std_max_g * self.settings.accel_std_max_g;
        }
        RestBlock { still, at_rest: false, mean_rate: mean, mean_var, n: self.n }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mathf::deg;

    /// Deterministic zero-mean noise with unit variance (sum of uniforms).
    struct Noise(u64);
    impl Noise {
        fn next(&mut self) -> f32 {
            let mut s = 0.0;
            for _ in 0..12 {
                self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                s += (self.0 >> 40) as f32 / (1u64 << 24) as f32;
            }
            s - 6.0
        }
    }

    fn run(rate: Vec3, seconds: f32) -> (u32, u32) {
        let noise = NoiseSettings::default();
        let mut d = RestDetector::new(RestSettings::default());
        let mut rng = Noise(7);
        let sd =
            Vec3::new(noise.gyro_var.x.sqrt(), noise.gyro_var.y.sqrt(), noise.gyro_var.z.sqrt());
        let (mut blocks, mut rest) = (0, 0);
        for _ in 0..(seconds * 50.0) as usize {
            let w = rate + Vec3::new(rng.next() * sd.x, rng.next() * sd.y, rng.next() * sd.z);
            let a = Vec3::new(0.0015 * rng.next(), 0.0015 * rng.next(), -1.0 + 0.0015 * rng.next());
            if let Some(b) = d.push(0.02, Some(w), Some(a), &noise) {
                blocks += 1;
                rest += b.at_rest as u32;
            }
        }
        (blocks, rest)
    }

    #[test]
    fn still_board_is_at_rest_after_two_blocks() {
        let (blocks, rest) = run(Vec3::ZERO, 20.0);
        // 2 s blocks (f32 time sums may add a sample to a block).
        assert!(blocks == 10 || blocks == 9, "{blocks}");
        assert!(rest >= blocks - 2, "rest in {rest} of {blocks} blocks");
    }

    #[test]
    fn residual_bias_of_005_dps_is_still_rest() {
        let (blocks, rest) = run(Vec3::new(0.0, 0.0, deg(0.05)), 20.0);
        assert!(rest >= blocks - 2, "{rest}");
    }

    #[test]
    fn a_half_degree_per_second_turn_is_motion_on_every_axis() {
        for axis in 0..3 {
            let mut r = [0.0; 3];
            r[axis] = deg(0.5);
            let (_, rest) = run(Vec3::from_array(r), 120.0);
            assert_eq!(rest, 0, "axis {axis}");
        }
    }

    #[test]
    fn vibration_or_invalid_samples_are_not_rest() {
        let noise = NoiseSettings::default();
        let mut d = RestDetector::new(RestSettings::default());
        for k in 0..500 {
            // Accelerometer shaking at ±0.03 g.
            let a = Vec3::new(if k % 2 == 0 { 0.03 } else { -0.03 }, 0.0, -1.0);
            if let Some(b) = d.push(0.02, Some(Vec3::ZERO), Some(a), &noise) {
                assert!(!b.still);
            }
        }
        let mut d = RestDetector::new(RestSettings::default());
        for k in 0..500 {
            let a = if k % 10 == 0 { None } else { Some(Vec3::new(0.0, 0.0, -1.0)) };
            if let Some(b) = d.push(0.02, Some(Vec3::ZERO), a, &noise) {
                assert!(!b.still);
            }
        }
    }
}
