//! Rest detection for a slow ROV: blocks of samples (2 s by default) are tested for stillness
//! — bias-corrected mean rate per axis, and the spread of the block's eight segment means
//! (0.25 s each) of the rate and of the accelerometer — and rest is declared after a number of
//! consecutive still blocks. A still block's mean rate measures the gyro-bias error; the EKF
//! uses it to re-estimate the bias and to hold yaw.
//!
//! The mean-rate threshold is `rate_threshold + 3·σᵢ/√n` per axis (σᵢ the configured per-sample
//! noise at the actual rate), so with the defaults a steady 0.5 °/s turn is motion on the
//! board's z gyro (threshold ≈ 0.22 °/s at 50 Hz) and on its noisier x/y gyros (≈ 0.36 °/s).
//!
//! Stillness is judged on the segment means, not on the samples: motion — rocking, bobbing,
//! a turn begun and reversed within the block — moves the quarter-second means, while sensor
//! noise and vibration (thrusters and pumps: tens of hertz, a few hundredths of g) average out
//! of them. A zero-mean oscillation slower than about 2 Hz is motion; vibration of 0.02 g and
//! 0.1 °/s rms, which the samples' own spread would call motion, is still (tested).
//!
//! The block sums are kept in fixed point (rates in units of 2⁻²⁰ rad/s, accelerations in
//! 2⁻²⁴ g): integer sums are exact, and on the Cortex-M3 the float additions per sample they
//! replace cost far more. The resolution, 1e−6 rad/s and 6e−8 g, is far below every threshold
//! and below the sensors' noise (docs/performance.md). Each segment's mean is formed in float
//! once, when the segment ends (every 12–13 samples at 50 Hz).

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
/// Segments per block: the segment means' spread is the stillness test.
pub const SEGMENTS: u32 = 8;
/// The significance of every mean test of the stillness detection, here and in the start
/// window (`init.rs`): a mean this many of its standard deviations from what stillness
/// predicts is motion (two-sided 0.27 % for a normally distributed mean). One number, so that
/// the detector and the start window judge alike.
pub const Z: f32 = 3.0;

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

/// Sums of one quantity's segment means (3 axes): Σ mean and Σ mean².
#[derive(Clone, Copy, Debug, Default)]
struct SegmentSpread {
    sum: [f32; 3],
    sq: [f32; 3],
}

impl SegmentSpread {
    /// Add the segment whose fixed-point sums are `now − start`, with `scale` = LSB / samples.
    #[inline(never)] // once per segment: kept out of the per-sample path
    fn add(&mut self, now: &[i64; 3], start: &[i64; 3], scale: f32) {
        for ((s, q), (n, b)) in
            self.sum.iter_mut().zip(self.sq.iter_mut()).zip(now.iter().zip(start))
        {
            // Clamped to i32 (i32 → f32 is the cheaper conversion on the target): beyond it a
            // segment's mean is over 150 rad/s or 9 g, motion either way.
            let d = n.saturating_sub(*b).clamp(i32::MIN as i64, i32::MAX as i64) as i32;
            let m = d as f32 * scale;
            *s += m;
            *q += m * m;
        }
    }

    /// Sample variance of the `k` segment means per axis (0 with fewer than two).
    fn variance(&self, k: u32) -> [f32; 3] {
        if k < 2 {
            return [0.0; 3];
        }
        let kf = k as f32;
        let mut v = [0.0; 3];
        for (v, (s, q)) in v.iter_mut().zip(self.sum.iter().zip(self.sq.iter())) {
            *v = ((q - s * s / kf) / (kf - 1.0)).max(0.0);
        }
        v
    }
}

/// Block statistics accumulator.
#[derive(Clone, Copy, Debug)]
pub struct RestDetector {
    settings: RestSettings,
    n: u32,
    t: f32,
    /// Σ rate in `RATE_LSB` units.
    g_sum: [i64; 3],
    /// The block's first acceleration; Σ of the deviations from it, `ACCEL_LSB` units.
    a_ref: Option<[i32; 3]>,
    a_n: u32,
    a_sum: [i64; 3],
    /// The current segment: where it ends (s into the block), its first sample's index, and
    /// the sums before it.
    seg_end: f32,
    seg_n0: u32,
    g_seg0: [i64; 3],
    a_seg0: [i64; 3],
    /// Closed segments and their means' sums.
    segments: u32,
    g_means: SegmentSpread,
    a_means: SegmentSpread,
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
            a_ref: None,
            a_n: 0,
            a_sum: [0; 3],
            seg_end: settings.block_s * (1.0 / SEGMENTS as f32),
            seg_n0: 0,
            g_seg0: [0; 3],
            a_seg0: [0; 3],
            segments: 0,
            g_means: SegmentSpread::default(),
            a_means: SegmentSpread::default(),
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
                // Deviations from the block's first sample: small, so their means are exact
                // in f32 far beyond every threshold.
                let r = *self.a_ref.get_or_insert(a);
                self.a_n += 1;
                unroll!(i in [0, 1, 2] {
                    let d = a[i].saturating_sub(r[i]);
                    self.a_sum[i] = self.a_sum[i].saturating_add(d as i64);
                });
            }
            None => self.broken = true,
        }
        if crate::fcmp::lt(self.t, self.seg_end) {
            return None;
        }
        self.close_segment();
        if crate::fcmp::lt(self.t, self.settings.block_s) {
            return None;
        }
        let block = self.finish(noise);
        let (settings, still_blocks) = (self.settings, self.still_blocks);
        *self = RestDetector::new(settings);
        self.still_blocks = if block.still { still_blocks.saturating_add(1) } else { 0 };
        Some(RestBlock { at_rest: self.at_rest(), ..block })
    }

    /// End the current segment: add its mean rate and acceleration to the spread sums.
    #[inline(never)] // once per segment
    fn close_segment(&mut self) {
        let n = self.n - self.seg_n0;
        if n > 0 {
            let inv = 1.0 / n as f32;
            self.g_means.add(&self.g_sum, &self.g_seg0, RATE_LSB * inv);
            self.a_means.add(&self.a_sum, &self.a_seg0, ACCEL_LSB * inv);
            self.segments += 1;
        }
        self.seg_n0 = self.n;
        self.g_seg0 = self.g_sum;
        self.a_seg0 = self.a_sum;
        self.seg_end += self.settings.block_s * (1.0 / SEGMENTS as f32);
    }

    fn finish(&self, noise: &NoiseSettings) -> RestBlock {
        let n = self.n.max(1) as f32;
        let mean = Vec3::from_array(self.g_sum.map(|s| s as f32 * (RATE_LSB / n)));
        // Per-sample noise variance at the actual rate (constant density).
        let rate_hz = n / self.t.max(1e-6);
        let var = noise.gyro_var * (rate_hz / noise.gyro_ref_rate_hz.max(1e-3));
        let mean_var = var * (1.0 / n);
        let k = self.segments;
        let mut still = !self.broken && self.n >= 4 && self.a_n == self.n && k >= 2;
        // A segment mean of n/k samples has variance k·σ²/n from the noise.
        let seg_var = mean_var * k as f32;
        let g_spread = self.g_means.variance(k);
        let a_spread = self.a_means.variance(k);
        let a_max = self.settings.accel_std_max_g * self.settings.accel_std_max_g;
        let limits = seg_var.to_array().map(|v| self.settings.gyro_var_factor * v);
        for i in 0..3 {
            let thr = self.settings.rate_threshold + Z * mathf::sqrt(mean_var[i]);
            still &= mathf::abs(mean[i]) <= thr;
            still &= g_spread[i] <= limits[i];
            still &= a_spread[i] <= a_max;
        }
        RestBlock { still, at_rest: false, mean_rate: mean, mean_var, n: self.n }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mathf::deg;
    use crate::test_rng::TestRng;

    fn run(rate: Vec3, seconds: f32) -> (u32, u32) {
        let noise = NoiseSettings::default();
        let mut d = RestDetector::new(RestSettings::default());
        let mut rng = TestRng::new(7);
        let sd =
            Vec3::new(noise.gyro_var.x.sqrt(), noise.gyro_var.y.sqrt(), noise.gyro_var.z.sqrt());
        let (mut blocks, mut rest) = (0, 0);
        for _ in 0..(seconds * 50.0) as usize {
            let w = rate + Vec3::new(rng.normal() * sd.x, rng.normal() * sd.y, rng.normal() * sd.z);
            let a = Vec3::new(
                0.0015 * rng.normal(),
                0.0015 * rng.normal(),
                -1.0 + 0.0015 * rng.normal(),
            );
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

    /// Vibration at sample `k` (50 Hz): three tones between 20 and 40 Hz per axis, `rms` in
    /// all per axis.
    fn tones(k: usize, rms: f32) -> Vec3 {
        let t = k as f32 * 0.02;
        let axis = |f: [f32; 3], p: f32| {
            f.iter().map(|f| mathf::sin(2.0 * core::f32::consts::PI * f * t + p)).sum::<f32>()
                * (rms * core::f32::consts::SQRT_2 / mathf::sqrt(3.0))
        };
        Vec3::new(
            axis([21.3, 29.9, 38.2], 0.3),
            axis([23.7, 33.1, 36.4], 1.1),
            axis([20.6, 27.2, 39.5], 2.0),
        )
    }

    /// Thrusters idling: the accelerometer vibrates by 0.02 g rms and the gyro by 0.15 °/s rms
    /// (tones at 20–40 Hz) on top of their noise. The samples' own spread is beyond
    /// `accel_std_max_g` and `gyro_var_factor` (checked here), yet the board is still: the
    /// quarter-second means do not move, and rest is declared.
    #[test]
    fn vibration_is_rest() {
        let noise = NoiseSettings::default();
        let set = RestSettings::default();
        let mut d = RestDetector::new(set);
        let mut rng = TestRng::new(11);
        let sd = noise.gyro_var.to_array().map(mathf::sqrt);
        let (mut blocks, mut rest, mut a_sq, mut g_sq) = (0, 0, 0.0f32, 0.0f32);
        let n = 1_000;
        for k in 0..n {
            let va = tones(k, 0.02);
            let a = Vec3::new(
                va.x + 0.0015 * rng.normal(),
                va.y + 0.0015 * rng.normal(),
                -1.0 + va.z + 0.0015 * rng.normal(),
            );
            let vg = tones(k + 7, deg(0.15));
            let w = Vec3::new(
                vg.x + sd[0] * rng.normal(),
                vg.y + sd[1] * rng.normal(),
                vg.z + sd[2] * rng.normal(),
            );
            a_sq += (a.x * a.x + a.y * a.y) * 0.5;
            g_sq += w.z * w.z;
            if let Some(b) = d.push(0.02, Some(w), Some(a), &noise) {
                blocks += 1;
                rest += b.at_rest as u32;
            }
        }
        // The samples alone would not pass.
        assert!(mathf::sqrt(a_sq / n as f32) > 1.5 * set.accel_std_max_g, "{a_sq}");
        assert!(g_sq / n as f32 > set.gyro_var_factor * noise.gyro_var.z, "{g_sq}");
        assert!(blocks >= 9 && rest >= blocks - 2, "rest in {rest} of {blocks} blocks");
    }

    /// Rocking at 1 Hz, ±0.03 g on the accelerometer (the gyro still): the block's mean is
    /// that of a still board, its segment means are not.
    #[test]
    fn rocking_or_invalid_samples_are_not_rest() {
        let noise = NoiseSettings::default();
        let mut d = RestDetector::new(RestSettings::default());
        let mut blocks = 0;
        for k in 0..500 {
            let s = mathf::sin(2.0 * core::f32::consts::PI * k as f32 * 0.02);
            let a = Vec3::new(0.03 * s, 0.0, -1.0);
            if let Some(b) = d.push(0.02, Some(Vec3::ZERO), Some(a), &noise) {
                assert!(!b.still);
                blocks += 1;
            }
        }
        assert!(blocks >= 4, "{blocks}");
        let mut d = RestDetector::new(RestSettings::default());
        for k in 0..500 {
            let a = if k % 10 == 0 { None } else { Some(Vec3::new(0.0, 0.0, -1.0)) };
            if let Some(b) = d.push(0.02, Some(Vec3::ZERO), a, &noise) {
                assert!(!b.still);
            }
        }
    }

    /// A gyro that rocks with zero mean over each block (a 1 Hz sine of ±1.5 °/s on x: whole
    /// periods per 2 s block) while the accelerometer is still: only the segment-spread test of
    /// the rate can call that motion. The same blocks with the noise alone are rest.
    #[test]
    fn a_zero_mean_gyro_rocking_is_not_rest() {
        let noise = NoiseSettings::default();
        let still = Vec3::new(0.0, 0.0, -1.0);
        let mut d = RestDetector::new(RestSettings::default());
        let mut blocks = 0;
        for k in 0..500 {
            let s = mathf::sin(2.0 * core::f32::consts::PI * k as f32 * 0.02);
            let w = Vec3::new(deg(1.5) * s, 0.0, 0.0);
            if let Some(b) = d.push(0.02, Some(w), Some(still), &noise) {
                // The block mean is (nearly) zero, far inside the mean-rate test's 0.2 °/s.
                assert!(b.mean_rate.max_abs() < deg(0.05), "{:?}", b.mean_rate);
                assert!(!b.still);
                blocks += 1;
            }
        }
        assert!(blocks >= 4, "{blocks}");
        let (blocks, rest) = run(Vec3::ZERO, 10.0);
        assert!(blocks >= 4 && rest >= 3, "{blocks} {rest}");
    }

    /// A still block at `hz` samples per second (the exact noise-free board): the block.
    fn one_block(
        d: &mut RestDetector,
        hz: f32,
        noise: &NoiseSettings,
        gyro_gap: bool,
    ) -> RestBlock {
        let dt = 1.0 / hz;
        for k in 0.. {
            let w = if gyro_gap && k == 3 { None } else { Some(Vec3::ZERO) };
            if let Some(b) = d.push(dt, w, Some(Vec3::new(0.0, 0.0, -1.0)), noise) {
                return b;
            }
        }
        unreachable!()
    }

    /// The variance of a block's mean from the configured noise follows the sample rate
    /// (constant density): at `r` Hz against the noise's reference rate `r₀`, a sample's
    /// variance is `σ²·r/r₀`, and the mean of `n` samples has `σ²·r/(r₀·n)` — by hand for a
    /// 2 s block at 200 Hz (n = 400, four times the reference's per-sample variance): σ²/100.
    #[test]
    fn the_mean_variance_follows_the_sample_rate() {
        let noise = NoiseSettings::default();
        let mut d = RestDetector::new(RestSettings::default());
        let b = one_block(&mut d, 200.0, &noise, false);
        assert!(b.n == 400 || b.n == 401, "{}", b.n);
        let rate = b.n as f32 / (b.n as f32 / 200.0);
        let want = noise.gyro_var * (rate / noise.gyro_ref_rate_hz) * (1.0 / b.n as f32);
        for (got, want) in b.mean_var.to_array().iter().zip(want.to_array()) {
            assert!((got - want).abs() <= 1e-6 * want, "{got} vs {want}");
        }
        assert!((b.mean_var.x - noise.gyro_var.x / 100.0).abs() < 0.01 * noise.gyro_var.x / 100.0);
    }

    /// One invalid gyro sample in an otherwise perfectly still block breaks it: not still, and
    /// the rest count starts again; a reset forgets the count and the block under way.
    #[test]
    fn an_invalid_sample_breaks_the_block_and_a_reset_forgets_rest() {
        let noise = NoiseSettings::default();
        let mut d = RestDetector::new(RestSettings::default());
        assert!(one_block(&mut d, 50.0, &noise, false).still);
        let b = one_block(&mut d, 50.0, &noise, false);
        assert!(b.still && b.at_rest && d.at_rest());
        let broken = one_block(&mut d, 50.0, &noise, true);
        assert!(!broken.still && !broken.at_rest && !d.at_rest());
        // Rest again after two still blocks; then a reset in the middle of a block.
        one_block(&mut d, 50.0, &noise, false);
        assert!(one_block(&mut d, 50.0, &noise, false).at_rest);
        for _ in 0..30 {
            d.push(0.02, Some(Vec3::ZERO), Some(Vec3::new(0.0, 0.0, -1.0)), &noise);
        }
        d.reset();
        assert!(!d.at_rest());
        // The next block is a whole one (100 samples, not the 70 left) and the first still one.
        let b = one_block(&mut d, 50.0, &noise, false);
        assert!(b.n >= 100 && b.still && !b.at_rest, "{} {} {}", b.n, b.still, b.at_rest);
    }

    /// Motion ends rest at once: after rest is declared, one moving block (a 2 °/s turn) clears
    /// it, and rest needs two still blocks again.
    #[test]
    fn a_moving_block_ends_rest() {
        let noise = NoiseSettings::default();
        let mut d = RestDetector::new(RestSettings::default());
        one_block(&mut d, 50.0, &noise, false);
        assert!(one_block(&mut d, 50.0, &noise, false).at_rest);
        let mut moved = None;
        while moved.is_none() {
            moved = d.push(
                0.02,
                Some(Vec3::new(0.0, 0.0, deg(2.0))),
                Some(Vec3::new(0.0, 0.0, -1.0)),
                &noise,
            );
        }
        let moved = moved.unwrap();
        assert!(!moved.still && !moved.at_rest && !d.at_rest());
        assert!(!one_block(&mut d, 50.0, &noise, false).at_rest);
        assert!(one_block(&mut d, 50.0, &noise, false).at_rest);
    }

    /// At 2.5 Hz a sample is 0.4 s after the last, longer than a segment (0.25 s): each
    /// sample closes one segment (the segment ends fall behind, never a segment without a
    /// sample: `close_segment`'s `n > 0` always holds), and a still board is at rest.
    #[test]
    fn a_rate_slower_than_the_segments_still_finds_rest() {
        let noise = NoiseSettings::default();
        let mut d = RestDetector::new(RestSettings::default());
        let (mut blocks, mut last) = (0, None);
        for _ in 0..40 {
            if let Some(b) = d.push(0.4, Some(Vec3::ZERO), Some(Vec3::new(0.0, 0.0, -1.0)), &noise)
            {
                assert!(b.still, "{b:?}");
                blocks += 1;
                last = Some(b);
            }
        }
        assert!(blocks >= 5, "{blocks}");
        assert!(last.is_some_and(|b| b.at_rest));
    }

    /// The segment spread's sample variance, by hand: means 1, 2, 3, 4 give Σ = 10, Σ² = 30,
    /// (30 − 10²/4)/3 = 5/3; fewer than two segments give 0; a spread is never negative.
    #[test]
    fn the_segment_variance_is_the_sample_variance() {
        let mut s = SegmentSpread::default();
        for (k, m) in [1.0f32, 2.0, 3.0, 4.0].iter().enumerate() {
            let now = [(m * 1024.0) as i64, (-m * 1024.0) as i64, 0];
            s.add(&now, &[0, 0, 0], 1.0 / 1024.0);
            let v = s.variance(k as u32 + 1);
            if k == 0 {
                assert_eq!(v, [0.0; 3]);
            }
            if k == 1 {
                // Two means, 1 and 2: (5 − 9/2)/1 = 1/2.
                assert!((v[0] - 0.5).abs() < 1e-6, "{v:?}");
            }
        }
        let v = s.variance(4);
        assert!((v[0] - 5.0 / 3.0).abs() < 1e-6 && (v[1] - 5.0 / 3.0).abs() < 1e-6, "{v:?}");
        assert_eq!(v[2], 0.0);
    }
}
