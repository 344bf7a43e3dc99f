//! Rest detection for a slow ROV: blocks of samples (2 s by default) are tested for stillness
//! — bias-corrected mean rate and gyro variance per axis, accelerometer spread — and rest is
//! declared after a number of consecutive still blocks. A still block's mean rate measures the
//! gyro-bias error; the EKF uses it to re-estimate the bias and to hold yaw.
//!
//! The mean-rate threshold is `rate_threshold + 3·σᵢ/√n` per axis (σᵢ the configured per-sample
//! noise at the actual rate), so with the defaults a steady 0.5 °/s turn is motion on the
//! board's z gyro (threshold ≈ 0.22 °/s at 50 Hz) and on its noisier x/y gyros (≈ 0.36 °/s).
//!
//! The block sums are kept in fixed point (rates in units of 2⁻²⁰ rad/s, accelerations in
//! 2⁻²⁴ g, squares in `i64`): integer sums are exact, and on the Cortex-M3 the twelve float
//! additions and six multiplications per sample they replace cost ~1,200 cycles, the integer
//! form ~150. The resolution, 1e−6 rad/s and 6e−8 g, is far below every threshold and below the
//! sensors' noise (docs/performance.md).

use crate::{
    mathf,
    settings::{NoiseSettings, RestSettings},
    Vec3,
};

/// Fractional bits of the fixed-point rates: 2⁻²⁰ rad/s (≈ 1e−6 rad/s, 5.5e−5 °/s).
const RATE_FRAC_BITS: i32 = 20;
/// Fractional bits of the fixed-point accelerations: 2⁻²⁴ g (6e−8 g).
const ACCEL_FRAC_BITS: i32 = 24;
/// One rate unit, rad/s.
const RATE_LSB: f32 = 1.0 / (1u32 << RATE_FRAC_BITS) as f32;
/// One acceleration unit, g.
const ACCEL_LSB: f32 = 1.0 / (1u32 << ACCEL_FRAC_BITS) as f32;
/// Values are clamped to ±2²⁶ units (64 rad/s, 4 g of deviation) before squaring, so a square
/// is below 2⁵² and a block of up to 2¹¹ samples cannot overflow; the sums saturate anyway.
const SQUARE_CLAMP: i32 = 1 << 26;

/// `x·2^frac` rounded toward zero, saturated to `±i32::MAX` (`i32::MIN` for −∞); NaN gives 0
/// (the filters never pass one: `validate` rejects it first).
///
/// On the target from the float's bits ([`to_fixed_bits`], no soft-float call); elsewhere (an
/// FPU: the host's replay and benchmarks) as the hardware conversion of the exact product
/// `x·2^frac`, with the one case where the two differ mended: the cast saturates a finite
/// negative overflow to `i32::MIN`, the bits to `−i32::MAX`. The same result for every `f32`
/// (tested).
#[inline(always)]
fn to_fixed(x: f32, frac: i32) -> i32 {
    if cfg!(target_arch = "arm") {
        to_fixed_bits(x, frac)
    } else {
        // `2^frac` exact, so is the product (or it overflows to ±∞; subnormals truncate to 0).
        let v = (x * (1u32 << frac) as f32) as i32;
        if v == i32::MIN && x.is_finite() {
            -i32::MAX
        } else {
            v
        }
    }
}

/// [`to_fixed`] from the float's bits: no floating-point operation at all.
#[inline(always)]
fn to_fixed_bits(x: f32, frac: i32) -> i32 {
    let b = x.to_bits();
    let e = ((b >> 23) & 0xff) as i32;
    if e == 0xff {
        return if b & 0x7f_ffff != 0 {
            0
        } else if b >> 31 != 0 {
            i32::MIN
        } else {
            i32::MAX
        };
    }
    // x = m·2^(e − 150) for a normal number (subnormals are far below one unit: 0).
    let m = ((b & 0x7f_ffff) | 0x80_0000) as i64;
    let shift = e - 150 + frac;
    let v = if e == 0 || shift <= -24 {
        0
    } else if shift < 0 {
        m >> -shift
    } else if shift < 8 {
        m << shift
    } else {
        i64::MAX
    };
    let v = v.min(i32::MAX as i64) as i32;
    if b >> 31 != 0 {
        -v
    } else {
        v
    }
}

/// `v²` of `v` clamped to ±`SQUARE_CLAMP`.
#[inline(always)]
fn square(v: i32) -> i64 {
    let v = v.clamp(-SQUARE_CLAMP, SQUARE_CLAMP) as i64;
    v * v
}

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
    /// Σ rate, Σ rate², in `RATE_LSB` units.
    g_sum: [i64; 3],
    g_sq: [i64; 3],
    /// The block's first acceleration; Σ and Σ² of the deviations from it, `ACCEL_LSB` units.
    a_ref: Option<[i32; 3]>,
    a_n: u32,
    a_sum: [i64; 3],
    a_sq: [i64; 3],
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
            g_sum: [0; 3],
            g_sq: [0; 3],
            a_ref: None,
            a_n: 0,
            a_sum: [0; 3],
            a_sq: [0; 3],
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
                let w = w.to_array();
                unroll!(i in [0, 1, 2] {
                    let v = to_fixed(w[i], RATE_FRAC_BITS);
                    self.g_sum[i] = self.g_sum[i].saturating_add(v as i64);
                    self.g_sq[i] = self.g_sq[i].saturating_add(square(v));
                });
            }
            None => self.broken = true,
        }
        match accel_g {
            Some(a) => {
                let a = [a.x, a.y, a.z];
                let a = [
                    to_fixed(a[0], ACCEL_FRAC_BITS),
                    to_fixed(a[1], ACCEL_FRAC_BITS),
                    to_fixed(a[2], ACCEL_FRAC_BITS),
                ];
                // Deviations from the block's first sample: small, so their squares are too.
                let r = *self.a_ref.get_or_insert(a);
                self.a_n += 1;
                unroll!(i in [0, 1, 2] {
                    let d = a[i].saturating_sub(r[i]);
                    self.a_sum[i] = self.a_sum[i].saturating_add(d as i64);
                    self.a_sq[i] = self.a_sq[i].saturating_add(square(d));
                });
            }
            None => self.broken = true,
        }
        if crate::fcmp::lt(self.t, self.settings.block_s) {
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
        let (g_lsb, a_lsb) = (RATE_LSB / n, ACCEL_LSB / n);
        let mean = Vec3::from_array(self.g_sum.map(|s| s as f32 * g_lsb));
        // Per-sample noise variance at the actual rate (constant density).
        let rate_hz = n / self.t.max(1e-6);
        let var = noise.gyro_var * (rate_hz / noise.gyro_ref_rate_hz.max(1e-3));
        let mean_var = var * (1.0 / n);
        let mut still = !self.broken && self.n >= 4 && self.a_n == self.n;
        for i in 0..3 {
            let g_sq = self.g_sq[i] as f32 * (RATE_LSB * RATE_LSB);
            let sample_var = (g_sq - n * mean[i] * mean[i]) / (n - 1.0).max(1.0);
            let thr = self.settings.rate_threshold + 3.0 * mathf::sqrt(mean_var[i]);
            still &= mathf::abs(mean[i]) <= thr;
            still &= sample_var <= self.settings.gyro_var_factor * var[i];
            let am = self.a_sum[i] as f32 * a_lsb;
            let a_sq = self.a_sq[i] as f32 * (ACCEL_LSB * ACCEL_LSB);
            let a_var = (a_sq - n * am * am) / (n - 1.0).max(1.0);
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
    fn fixed_point_conversion_truncates_exactly() {
        for (x, frac, want) in [
            (1.0f32, 20, 1 << 20),
            (-1.0, 20, -(1 << 20)),
            (0.0, 20, 0),
            (-0.0, 24, 0),
            (1.5e-7, 20, 0),                    // below one unit
            (3.0 / (1u32 << 20) as f32, 20, 3), // exact
            (2.9 / (1u32 << 20) as f32, 20, 2), // toward zero
            (-2.9 / (1u32 << 20) as f32, 20, -2),
            (1.0e9, 20, i32::MAX),
            (-1.0e9, 20, -i32::MAX),
            (f32::INFINITY, 20, i32::MAX),
            (f32::NAN, 20, 0),
            (1.0e-40, 24, 0), // subnormal
        ] {
            assert_eq!(to_fixed(x, frac), want, "{x} at {frac} bits");
        }
        // The two implementations agree on every sign and exponent, for the mantissas at both
        // ends of each binade and 4,000 between (every place where they could differ: the
        // shifts, the saturation, zeros, subnormals, infinities, NaN).
        let mut s = 987u32;
        for frac in [RATE_FRAC_BITS, ACCEL_FRAC_BITS] {
            for top in 0..512u32 {
                for k in 0..6_000u32 {
                    let mant = match k {
                        0..1_000 => k,
                        1_000..2_000 => 0x7f_ffff - (k - 1_000),
                        _ => {
                            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                            s >> 9
                        }
                    };
                    let x = f32::from_bits(top << 23 | mant);
                    assert_eq!(to_fixed(x, frac), to_fixed_bits(x, frac), "{x:e} at {frac}");
                }
            }
        }
        // Against the f64 product on many values.
        let mut s = 12345u32;
        for _ in 0..100_000 {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let x = f32::from_bits(s & 0x83ff_ffff | 0x3000_0000); // ±[2⁻³¹, 2⁸)
            let want = (x as f64 * (1u64 << 20) as f64).trunc() as i32;
            assert_eq!(to_fixed(x, 20), want, "{x}");
        }
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

    /// A gyro that oscillates with zero mean (±1.5 °/s on x, 2.6× the board's per-sample noise;
    /// a rocking the accelerometer does not see) while the accelerometer is still: only the
    /// gyro-variance test can call that motion. The same block with the noise alone is rest.
    #[test]
    fn a_zero_mean_gyro_oscillation_is_not_rest() {
        let noise = NoiseSettings::default();
        let still = Vec3::new(0.0, 0.0, -1.0);
        let mut d = RestDetector::new(RestSettings::default());
        let mut blocks = 0;
        for k in 0..500 {
            let w = Vec3::new(if k % 2 == 0 { deg(1.5) } else { deg(-1.5) }, 0.0, 0.0);
            if let Some(b) = d.push(0.02, Some(w), Some(still), &noise) {
                // The block mean is (nearly: an odd sample count) zero, far inside the mean-rate
                // test's 0.2 °/s.
                assert!(b.mean_rate.max_abs() < deg(0.05), "{:?}", b.mean_rate);
                assert!(!b.still);
                blocks += 1;
            }
        }
        assert!(blocks >= 4, "{blocks}");
        let (blocks, rest) = run(Vec3::ZERO, 10.0);
        assert!(blocks >= 4 && rest >= 3, "{blocks} {rest}");
    }
}
