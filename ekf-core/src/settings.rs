//! Settings of the estimators. Every `Default` is the iNEMO V2 / Seahog value from the source
//! (thesis digest) where the source gives one, otherwise the tuned value documented in
//! `docs/settings.md`. Angles in rad, rates in rad/s, time in s, accelerations in g where the
//! name says so.

use crate::{mathf::deg, Vec3};

/// (°/s)² → (rad/s)².
const DEG2: f32 = (core::f32::consts::PI / 180.0) * (core::f32::consts::PI / 180.0);

/// Sensor noise model (facts about the sensors, shared by every filter).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NoiseSettings {
    /// Gyro white-noise variance of one sample at `gyro_ref_rate_hz`, per body axis,
    /// (rad/s)². Default: the board's measured 0.337, 0.275, 4.19e−3 (°/s)² at 50 Hz.
    /// The noise density is taken as constant, so at another sample rate the per-sample
    /// variance scales with the rate.
    pub gyro_var: Vec3,
    /// Sample rate at which `gyro_var` was measured, Hz. Default 50.
    pub gyro_ref_rate_hz: f32,
    /// Accelerometer white-noise variance per axis and sample at `accel_ref_rate_hz`, g².
    /// Default 2.376e−6 (LSM303DLH datasheet, as in the source: 218 µg/√Hz over 50 Hz). As
    /// for the gyro, the noise density is taken as constant: at another sample rate the
    /// per-sample variance scales with the rate ([`NoiseSettings::accel_var_per_sample`]).
    pub accel_var: f32,
    /// Sample rate at which `accel_var` holds, Hz. Default 50 (the board's rate, at which the
    /// source used the datasheet figure).
    pub accel_ref_rate_hz: f32,
}

impl Default for NoiseSettings {
    fn default() -> Self {
        NoiseSettings {
            gyro_var: Vec3::new(0.337 * DEG2, 0.275 * DEG2, 4.19e-3 * DEG2),
            gyro_ref_rate_hz: 50.0,
            accel_var: 2.376e-6,
            accel_ref_rate_hz: 50.0,
        }
    }
}

impl NoiseSettings {
    /// Gyro noise power spectral density per axis, (rad/s)²/Hz = rad²/s.
    pub fn gyro_psd(&self) -> Vec3 {
        self.gyro_var * (1.0 / self.gyro_ref_rate_hz.max(1e-3))
    }

    /// Accelerometer white-noise variance of one sample `dt` seconds long, per axis, g²:
    /// `accel_var · (1/dt) / accel_ref_rate_hz` (constant noise density). Exactly `accel_var`
    /// at the reference rate.
    pub fn accel_var_per_sample(&self, dt: f32) -> f32 {
        self.accel_var * self.accel_rate_ratio(dt)
    }

    /// The sample rate `1/dt` over `accel_ref_rate_hz`: how much more (or less) variance one
    /// sample has than one at the reference rate. Exactly 1 at the reference rate.
    pub fn accel_rate_ratio(&self, dt: f32) -> f32 {
        1.0 / (dt * self.accel_ref_rate_hz).max(1e-6)
    }
}

/// Start-up: the initialisation window.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InitSettings {
    /// Length of the initialisation window, s: tilt is taken from the accelerometer averaged
    /// over it (and the gyro bias from the averaged gyro). Default 10 s, as on the board.
    /// Zero starts on the first valid sample.
    pub window_s: f32,
    /// Initial yaw, rad (e.g. from a gyrocompass), rotation about NED z. Default 0.
    pub initial_yaw: f32,
    /// Take the initial gyro bias from the gyro averaged over the window (the vehicle must be
    /// still). Default true. When false, or when the window had no usable sample, `gyro_bias`
    /// is used.
    pub estimate_gyro_bias: bool,
    /// Gyro bias used when it is not estimated, rad/s, body FRD. Default: the board's mean
    /// bias (1.619, 3.440, −0.004) °/s.
    pub gyro_bias: Vec3,
    /// Standard deviation of `gyro_bias` when the window was not still and the filter starts
    /// from it, rad/s. Default 2 °/s: several times the board's measured bias change between
    /// sessions (0.3 °/s on x), room for temperature and for another sensor.
    pub moving_bias_sigma: f32,
}

impl Default for InitSettings {
    fn default() -> Self {
        InitSettings {
            window_s: 10.0,
            initial_yaw: 0.0,
            estimate_gyro_bias: true,
            gyro_bias: Vec3::new(deg(1.619), deg(3.440), deg(-0.0042)),
            moving_bias_sigma: deg(2.0),
        }
    }
}

/// Accelerometer gating: which samples may correct tilt. The EKF (the firmware's filter) reads
/// `norm_tolerance` in its update, and `norm_tolerance`, `jump_g` and `holdoff_s` in its start
/// window (`init::feed`); the rest are the comparison filters' (UKF, SS-UKF, complementary,
/// gyro-only: `gate.rs`). Only `norm_tolerance` is in the registry: the firmware keeps the
/// others at their defaults (issue #36 retired them).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GateSettings {
    /// Magnitude gate: skip the update when `| |a|/g − 1 |` exceeds this, dimensionless.
    /// Default 1 (off in practice:
    /// only beyond 2 g). 0.05 is the source's 1 ± 0.05 g gate; on real motion it rejects most
    /// samples, and the EKF's low-pass in motion replaces it (`docs/filter.md`).
    pub norm_tolerance: f32,
    /// Knock detection by jump: skip when the accelerometer moved by more than this between
    /// two consecutive samples, g. Default 0.05 g.
    pub jump_g: f32,
    /// Knock detection by innovation (filters with an innovation covariance): skip when the
    /// normalised innovation squared exceeds this (χ², 2 degrees of freedom). Default 10⁶
    /// (off): on real motion the test rejected exactly the samples that would correct a tilt
    /// error grown in motion. 16 (p ≈ 3·10⁻⁴ for a consistent filter) was the old default.
    pub innovation_chi2: f32,
    /// After any rejection, keep skipping for this long, s (knocks ring). Default 0.1 s.
    pub holdoff_s: f32,
    /// When only the innovation gate has rejected for this long, s, bypass it so the filter
    /// can reacquire a tilt it has lost. Default 2 s.
    pub reacquire_s: f32,
    /// Continuous rejection longer than this, s, raises `ACCEL_REJECT_LONG`. Default 10 s.
    pub long_reject_s: f32,
}

impl GateSettings {
    /// The source's gate: 1 ± 0.05 g, 0.05 g jump, χ² 16 innovation test.
    pub const SOURCE: GateSettings = GateSettings {
        norm_tolerance: 0.05,
        jump_g: 0.05,
        innovation_chi2: 16.0,
        holdoff_s: 0.1,
        reacquire_s: 2.0,
        long_reject_s: 10.0,
    };
}

impl Default for GateSettings {
    fn default() -> Self {
        GateSettings {
            norm_tolerance: 1.0,
            jump_g: 0.05,
            innovation_chi2: 1e6,
            holdoff_s: 0.1,
            reacquire_s: 2.0,
            long_reject_s: 10.0,
        }
    }
}

/// Plausibility limits of the input.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LimitSettings {
    /// Gyro full scale, rad/s: a sample at or beyond it is flagged saturated (still used).
    /// Default 300 °/s (LPR430AL, LY330ALH).
    pub gyro_range: f32,
    /// A gyro sample beyond this, rad/s, is absurd and rejected. Default 2000 °/s.
    pub gyro_abs_max: f32,
    /// An accelerometer sample beyond this norm, g, is absurd and rejected. Default 16 g.
    pub accel_abs_max_g: f32,
    /// An accelerometer sample below this norm, g, has no usable direction. Default 0.1 g.
    pub accel_min_g: f32,
    /// Longest `dt` integrated with the sample's rate, s; a longer gap propagates the
    /// attitude over this much only and the uncertainty over the whole gap. Default 0.5 s.
    pub max_gap_s: f32,
}

impl Default for LimitSettings {
    fn default() -> Self {
        LimitSettings {
            gyro_range: deg(300.0),
            gyro_abs_max: deg(2000.0),
            accel_abs_max_g: 16.0,
            accel_min_g: 0.1,
            max_gap_s: 0.5,
        }
    }
}

/// Rest detection: while the vehicle is still, re-estimate the gyro bias and hold yaw.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RestSettings {
    /// Enable rest detection. Default true.
    pub enabled: bool,
    /// Length of one detection block, s. Default 2 s.
    pub block_s: f32,
    /// Consecutive still blocks before rest is declared. Default 2.
    pub min_blocks: u8,
    /// Largest bias-corrected mean rate per axis in a still block, rad/s, on top of three
    /// standard errors of the block mean. Default 0.2 °/s: a steady 0.5 °/s turn is motion.
    pub rate_threshold: f32,
    /// Largest variance of a still block's segment mean rates (eight segments, 0.25 s each by
    /// default) per axis, as a multiple of what the configured noise gives a segment mean
    /// (σ²·segments/n). Default 6: with 8 segments the statistic is χ²₇/7 for noise alone,
    /// beyond 6 with probability 5·10⁻⁷ per axis (beyond 4, 2·10⁻⁴: a still board would lose
    /// rest about once an hour). Vibration averages out of the segment means; rocking does not.
    /// The start window's stillness test takes the same limit on its segment means, against
    /// the samples' own scatter there (`init.rs`).
    pub gyro_var_factor: f32,
    /// Largest standard deviation of a still block's segment mean accelerations per axis, g
    /// (0.25 s segments by default: vibration averages out). Default 0.01 g.
    pub accel_std_max_g: f32,
    /// Hold yaw while at rest: undo the yaw integrated over each still block. Default true.
    pub yaw_hold: bool,
}

impl Default for RestSettings {
    fn default() -> Self {
        RestSettings {
            enabled: true,
            block_s: 2.0,
            min_blocks: 2,
            rate_threshold: deg(0.2),
            gyro_var_factor: 6.0,
            accel_std_max_g: 0.01,
            yaw_hold: true,
        }
    }
}

/// Optional magnetometer heading correction (off by default: the Seahog's thrusters and
/// cables distort the field).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagSettings {
    /// Use the magnetometer. Default false.
    pub enabled: bool,
    /// Expected field strength, µT. Default 25.6 µT (Cape Town, approximate; take your site's
    /// value from a geomagnetic model).
    pub field_ut: f32,
    /// Expected dip (inclination) below the horizontal, rad, positive down. Default −65°
    /// (Cape Town, approximate).
    pub dip: f32,
    /// Declination (magnetic north east of true north), rad. Default −25.5° (Cape Town,
    /// approximate).
    pub declination: f32,
    /// Reject samples whose field norm differs from `field_ut` by more than this fraction.
    /// Default 0.15.
    pub norm_tolerance: f32,
    /// Reject samples whose dip differs from `dip` by more than this, rad. Default 5°.
    pub dip_tolerance: f32,
    /// Heading measurement standard deviation, rad. Default 3°.
    pub heading_sigma: f32,
}

impl Default for MagSettings {
    fn default() -> Self {
        MagSettings {
            enabled: false,
            field_ut: 25.6,
            dip: deg(-65.0),
            declination: deg(-25.5),
            norm_tolerance: 0.15,
            dip_tolerance: deg(5.0),
            heading_sigma: deg(3.0),
        }
    }
}

/// EKF tuning beyond the sensor facts.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EkfSettings {
    /// Yaw-split: accelerometer corrections never change yaw. Default true (the source's
    /// board implementation); false reproduces its first implementation.
    pub yaw_split: bool,
    /// Gyro-bias random walk, (rad/s)²/s per axis. Default (0.002 °/s)²/s.
    pub bias_random_walk: f32,
    /// Constant yaw drift subtracted from the yaw integral, rad/s (the source's
    /// compensation, 16.2 °/h on its board). Default 0: rest detection replaces it.
    pub yaw_drift_rate: f32,
    /// Tilt (roll, pitch) standard deviation after initialisation, rad. Default 2°.
    pub initial_tilt_sigma: f32,
    /// Gyro-bias standard deviation after initialisation, rad/s. Default 0.2 °/s. Also the rate
    /// agreement a still initialisation window tolerates (`init.rs`).
    pub initial_bias_sigma: f32,
    /// The longest time constant (delay) of the accelerometer's low-pass in the estimate's NED
    /// frame, s: a second-order Butterworth filter of natural frequency √2/τ (VQF's). Motion
    /// accelerations average out in that almost-inertial frame (their mean is a change of
    /// velocity over this time) while gravity stays (VQF's idea, Laidig and Seel 2023). The
    /// time constant in use follows the motion (`motion`, issue #35): 0 (raw samples) on a still
    /// board or in gentle rotation, this much in hand-held motion, whatever balances the gyro's
    /// walk over the delay against the measured horizontal acceleration in between. Default
    /// 2.5 s (VQF's `tauAcc` is 3 s; chosen on the BROAD development set and RepoIMU 02a,
    /// `docs/filter.md`). 0: always raw samples.
    pub accel_time_constant: f32,
    /// The gyro's rate error proportional to the rate (scale factor and axis misalignment),
    /// dimensionless: the bound k of each scale factor's error (each cross-axis term's: k/2).
    /// It adds `(k·|ω|)²·τ` rad²/s to the attitude's process noise, τ the low-pass's longest
    /// time constant, so that what a fast turn builds up over the low-pass's delay is taken for
    /// attitude error, not for gyro bias; and the time-constant rule counts the error it builds
    /// up over the delay, `5/24·k²·(ω̄_h·τ)²` (`motion`), so that a sustained turn takes a short
    /// time constant. Default 0.02 (the iNEMO's gyros: 2 % sensitivity tolerance, 1 %
    /// cross-axis).
    pub gyro_scale_error: f32,
}

impl Default for EkfSettings {
    fn default() -> Self {
        EkfSettings {
            yaw_split: true,
            bias_random_walk: deg(0.002) * deg(0.002),
            yaw_drift_rate: 0.0,
            initial_tilt_sigma: deg(2.0),
            initial_bias_sigma: deg(0.2),
            accel_time_constant: 2.5,
            gyro_scale_error: 0.02,
        }
    }
}

/// Earth's rotation rate, rad/s (WGS 84's ω_ie).
pub const EARTH_RATE: f32 = 7.292_115e-5;

/// What a still average of the gyro over `t` s measures besides the bias the filter
/// estimates, as a variance, (rad/s)² per axis: Earth's rate, up to [`EARTH_RATE`] on an
/// axis (the filter has no Earth-rate model: its bias takes in the projection at the
/// attitude where it was measured, which a turn changes), and the bias's own walk between
/// the average and its end (a random walk of density `bias_random_walk` differs from its
/// mean over the last `t` s by a variance `bias_random_walk·t/3`). Added to the variance of
/// the start window's bias (`init.rs`) and of a rest block's (`ekf.rs`): with the
/// defaults, 0.0055 °/s after the 10 s window and 0.0045 °/s after a 2 s block.
pub fn still_bias_floor(bias_random_walk: f32, t: f32) -> f32 {
    EARTH_RATE * EARTH_RATE + bias_random_walk * t * (1.0 / 3.0)
}

/// Everything the estimator needs; `Default` is the iNEMO V2 / Seahog configuration.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Settings {
    /// Sensor noise model.
    pub noise: NoiseSettings,
    /// Initialisation window.
    pub init: InitSettings,
    /// Accelerometer gating.
    pub gate: GateSettings,
    /// Input plausibility limits.
    pub limits: LimitSettings,
    /// Rest detection.
    pub rest: RestSettings,
    /// Magnetometer heading update.
    pub mag: MagSettings,
    /// EKF tuning.
    pub ekf: EkfSettings,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Constant noise density: the variance of one sample is `accel_var` at the reference
    /// rate exactly (so 50 Hz behaves as before the reference rate existed), twice that at
    /// twice the rate, a fifth at a fifth of it.
    #[test]
    fn the_accelerometer_variance_per_sample_scales_with_the_rate() {
        let n = NoiseSettings::default();
        assert_eq!((n.accel_var, n.accel_ref_rate_hz), (2.376e-6, 50.0));
        assert_eq!(n.accel_var_per_sample(0.02), 2.376e-6);
        for (dt, want) in [(0.01f32, 4.752e-6f32), (0.004, 1.188e-5), (0.1, 4.752e-7)] {
            let got = n.accel_var_per_sample(dt);
            assert!((got / want - 1.0).abs() < 1e-6, "dt {dt}: {got}, by hand {want}");
        }
        let m = NoiseSettings { accel_ref_rate_hz: 100.0, ..n };
        assert!((m.accel_var_per_sample(0.02) / 1.188e-6 - 1.0).abs() < 1e-6);
    }
}
