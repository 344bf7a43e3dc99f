//! The source's spherical-simplex unscented Kalman filter (comparison filter, Julier): the
//! digest's seven-state additive model `x = [q0 q1 q2 q3, bx by bz]` (quaternion body FRD →
//! NED, gyro bias rad/s body FRD) with `n + 2 = 9` sigma points.
//!
//! # Points and weights
//! Digest values `W0 = 0.1`, `α = 10⁻⁴`, `β = 2`, `n = 7`, and
//! `w1 = (1 − W0)/((n + 1)α²) = 1.125·10⁷`. `Z` is 7×9: column 0 (the central point) is zero;
//! row `j = 1..7` holds `−1/√(j(j+1)w1)` in columns `1..j`, `j/√(j(j+1)w1)` in column `j + 1`
//! and zero elsewhere. Points `X_i = x + √P·Z_i` (`√P` the lower Cholesky factor).
//!
//! These are Julier's (2003) spherical-simplex points with his scaling already applied:
//! unscaled, the simplex points have weights `W_i = (1 − W0)/(n + 1)` and offsets `Z_i/α`;
//! the scaled UT moves them to `X_0 + α(X_i − X_0)` and uses `W'_i = W_i/α²`, which is the
//! digest's `w1` (and `1/√w1 = α/√W_i` puts the `α` into `Z`). The weights used here follow:
//! - mean: `Wm_i = w1` (i = 1..8), `Wm_0 = 1 − (n + 1)w1 = W0/α² + 1 − 1/α² ≈ −9.0·10⁷`;
//! - covariance: `Wc_i = w1` (i = 1..8), `Wc_0 = Wm_0 + 1 − α² + β`.
//!
//! Then `Σ Wm_i Z_i = 0` and `Σ Wc_i Z_i Z_iᵀ = I`: the points reproduce `x` and `P` exactly.
//!
//! # Precision: `f64` internally
//! With `α = 10⁻⁴` the points sit `≈ 3·10⁻⁴ σ` from the mean: a quaternion component near 1
//! with `σ ≈ 10⁻³` moves by `≈ 3·10⁻⁷`, a few `f32` ulps (6·10⁻⁸), so in `f32` the offsets
//! are mostly rounding and the `10⁷` weights amplify it (the test
//! `f32_would_lose_the_points` shows the covariance error). All sigma-point arithmetic
//! (state, covariance, points, transforms, update) therefore runs in `f64` (soft-float on the
//! target either way); inputs and outputs are `f32`.
//!
//! Everything else — process, measurement, noise, deviation-form moments, covariance repair,
//! gate, initialisation — is shared with [`crate::Ukf`] (see [`SsUkf`]). No yaw-split and no
//! rest detection, as in the source, which found this filter worse on yaw than the UKF.

use nalgebra::SMatrix;

use crate::{
    mathf::deg,
    settings::Settings,
    unscented::{Core, SigmaSet, Tuning, N},
    Flags,
};

/// Number of sigma points, `n + 2`.
const M: usize = N + 2;

/// Tuning of [`SsUkf`]. Angles in rad, rates in rad/s.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SsUkfParams {
    /// Weight `W0` of the central point before scaling, in `[0, 1)`, dimensionless.
    /// Default 0.1 (source).
    pub w0: f32,
    /// Spread `α` of the scaled transform, dimensionless. Default 10⁻⁴ (source).
    pub alpha: f32,
    /// Prior-distribution parameter `β`, dimensionless. Default 2 (source).
    pub beta: f32,
    /// Accelerometer measurement variance as a multiple of
    /// [`crate::settings::NoiseSettings::accel_var`]. Default 1 (as the EKF).
    pub accel_var_scale: f32,
    /// Gyro-bias random walk, (rad/s)²/s per axis. Default (0.002 °/s)²/s.
    pub bias_random_walk: f32,
    /// Tilt (roll, pitch) standard deviation at start, rad, about NED x and y. Default 2°.
    pub initial_tilt_sigma: f32,
    /// Yaw standard deviation at start, rad, about NED z. Default 5°.
    pub initial_yaw_sigma: f32,
    /// Gyro-bias standard deviation at start, rad/s per body axis, when the start did not
    /// measure the bias (`set_attitude`, covariance resets, `estimate_gyro_bias` off); after
    /// a window that measured it, its standard error is used instead, as in the EKF.
    /// Default 0.2 °/s.
    pub initial_bias_sigma: f32,
}

impl Default for SsUkfParams {
    fn default() -> Self {
        SsUkfParams {
            w0: 0.1,
            alpha: 1e-4,
            beta: 2.0,
            accel_var_scale: 1.0,
            bias_random_walk: deg(0.002) * deg(0.002),
            initial_tilt_sigma: deg(2.0),
            initial_yaw_sigma: deg(5.0),
            initial_bias_sigma: deg(0.2),
        }
    }
}

impl SsUkfParams {
    /// The parameters with unusable values replaced by the defaults: `W0`, `α`, `β` together
    /// when any is non-finite, `W0 ∉ [0, 1)` or `α ≤ 0`; each other field when non-finite or
    /// not positive (the random walk may be zero).
    pub fn sanitised(self) -> Self {
        let d = SsUkfParams::default();
        let ok = self.w0.is_finite()
            && (0.0..1.0).contains(&self.w0)
            && self.alpha.is_finite()
            && self.alpha > 0.0
            && self.beta.is_finite();
        let (w0, alpha, beta) =
            if ok { (self.w0, self.alpha, self.beta) } else { (d.w0, d.alpha, d.beta) };
        let t = self.tuning().sanitised(d.tuning());
        SsUkfParams {
            w0,
            alpha,
            beta,
            accel_var_scale: t.accel_var_scale,
            bias_random_walk: t.bias_random_walk,
            initial_tilt_sigma: t.initial_tilt_sigma,
            initial_yaw_sigma: t.initial_yaw_sigma,
            initial_bias_sigma: t.initial_bias_sigma,
        }
    }

    fn tuning(&self) -> Tuning {
        Tuning {
            accel_var_scale: self.accel_var_scale,
            bias_random_walk: self.bias_random_walk,
            initial_tilt_sigma: self.initial_tilt_sigma,
            initial_yaw_sigma: self.initial_yaw_sigma,
            initial_bias_sigma: self.initial_bias_sigma,
        }
    }

    /// The digest's `w1` and `Z`, and the scaled weights (module documentation), in `f64`.
    fn sigma_set(&self) -> SigmaSet<f64, M> {
        let (w0, alpha, beta) = (self.w0 as f64, self.alpha as f64, self.beta as f64);
        let a2 = alpha * alpha;
        let w1 = (1.0 - w0) / ((N as f64 + 1.0) * a2);
        let mut z = SMatrix::<f64, N, M>::zeros();
        for j in 1..=N {
            let jf = j as f64;
            let s = libm::sqrt(jf * (jf + 1.0) * w1);
            for col in 1..=j {
                z[(j - 1, col)] = -1.0 / s;
            }
            z[(j - 1, j + 1)] = jf / s;
        }
        let mut wm = [w1; M];
        let mut wc = [w1; M];
        wm[0] = 1.0 - (N as f64 + 1.0) * w1;
        wc[0] = wm[0] + 1.0 - a2 + beta;
        SigmaSet { z, wm, wc }
    }
}

/// The source's spherical-simplex UKF on the seven-state additive quaternion + bias model
/// (module docs), arithmetic in `f64`.
///
/// - Process `q ← (I + ½Ω(gyro − b)dt) q` on every sigma point, mean quaternion normalised;
///   `Q = blockdiag(ψ̄·dt/4·I₄, bias_random_walk·dt·I₃)` with `ψ̄` the mean gyro noise density
///   (rad²/s) and `dt` the sample interval, s.
/// - Measurement: unit "down" in the body frame, `down_in_body(q)` per sigma point, against
///   `−a/|a|`; `R = accel_var·accel_var_scale·I₃` (g², `accel_var` per sample at
///   `noise.accel_ref_rate`, scaled to the sample rate).
/// - Means and covariances in deviation form around the central point; `P` symmetrised after
///   every step; a failing Cholesky factorisation is repaired (diagonal jitter, else reset to
///   the initial covariance) and reported as [`Flags::HEALTH_RESET`].
/// - After each update `P` is carried with the mean (right multiplication by
///   `q̄_prior* ⊗ q̄_new`) so that its yaw variance stays on the yaw axis.
/// - Initialisation window (bias covariance from the window as in the EKF), input validation
///   and accelerometer gate as [`crate::Ekf`]; the gate tests `νᵀS⁻¹ν` of the 3-vector
///   innovation against the 2-dof threshold as is.
#[derive(Clone, Debug)]
pub struct SsUkf {
    core: Core<f64, M>,
    params: SsUkfParams,
}

impl SsUkf {
    /// A new filter, starting its initialisation window. Unusable parameters are replaced by
    /// the defaults ([`SsUkfParams::sanitised`]).
    pub fn new(settings: Settings, params: SsUkfParams) -> Self {
        let params = params.sanitised();
        SsUkf { core: Core::new(settings, params.tuning(), params.sigma_set()), params }
    }

    /// A new filter with the default settings and parameters.
    pub fn with_defaults() -> Self {
        SsUkf::new(Settings::default(), SsUkfParams::default())
    }

    /// The settings in use.
    pub fn settings(&self) -> &Settings {
        self.core.settings()
    }

    /// The parameters in use (after sanitising).
    pub fn params(&self) -> &SsUkfParams {
        &self.params
    }

    /// State covariance rounded to `f32`: rows/columns 0–3 the quaternion components
    /// `q0..q3` (dimensionless²), 4–6 the gyro bias, (rad/s)², body FRD.
    pub fn covariance(&self) -> SMatrix<f32, 7, 7> {
        self.core.covariance()
    }

    /// Flags of the last update.
    pub fn last_flags(&self) -> Flags {
        self.core.last_flags()
    }
}

impl Default for SsUkf {
    /// Same as [`SsUkf::with_defaults`].
    fn default() -> Self {
        SsUkf::with_defaults()
    }
}

crate::unscented::impl_attitude_filter_for_core!(SsUkf, "ssukf");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::AttitudeFilter;
    use crate::unscented::testkit;

    #[test]
    fn z_matrix_and_weights_are_the_digest_values() {
        let s = SsUkfParams::default().sigma_set();
        let w1 = 0.9 / (8.0 * 1e-8);
        assert!((s.wm[1] / w1 - 1.0).abs() < 1e-6);
        let w1 = s.wm[1];
        assert!((s.z[(0, 1)] + 1.0 / libm::sqrt(2.0 * w1)).abs() < 1e-12);
        assert!((s.z[(0, 2)] - 1.0 / libm::sqrt(2.0 * w1)).abs() < 1e-12);
        assert_eq!(s.z[(0, 3)], 0.0);
        assert!((s.z[(6, 8)] - 7.0 / libm::sqrt(56.0 * w1)).abs() < 1e-12);
        assert!((s.z[(6, 3)] + 1.0 / libm::sqrt(56.0 * w1)).abs() < 1e-12);
        assert!((0..N).all(|j| s.z[(j, 0)] == 0.0));
        let sum: f64 = s.wm.iter().sum();
        assert!((sum - 1.0).abs() < 1e-6, "{sum}");
        assert!((s.wc[0] - s.wm[0] - (3.0 - 1e-8)).abs() < 1e-6);
    }

    #[test]
    fn sigma_points_reproduce_mean_and_covariance() {
        let f = SsUkf::with_defaults();
        let (mean_err, cov_err) = testkit::sigma_moment_errors(f.core.sigma_set());
        assert!(mean_err < 1e-5, "mean error {mean_err} σ");
        assert!(cov_err < 1e-7, "covariance error {cov_err} (relative)");
    }

    #[test]
    fn f32_would_lose_the_points() {
        // The same point set in f32: the covariance is no longer reproduced.
        let s = SsUkfParams::default().sigma_set();
        let s32 = SigmaSet::<f32, M> {
            z: s.z.map(|v| v as f32),
            wm: s.wm.map(|v| v as f32),
            wc: s.wc.map(|v| v as f32),
        };
        let (_, cov_err) = testkit::sigma_moment_errors(&s32);
        assert!(cov_err > 1.0, "f32 covariance error only {cov_err}");
    }

    #[test]
    fn converges_from_a_30_degree_tilt_error() {
        let mut f = SsUkf::with_defaults();
        let err = testkit::tilt_convergence(&mut f);
        assert!(err < 0.5, "tilt error {err}° after 20 s");
    }

    #[test]
    fn tracks_a_constant_rate_yaw_rotation() {
        let mut f = SsUkf::with_defaults();
        let err = testkit::yaw_tracking(&mut f);
        assert!(err < 0.1, "yaw error {err}° after 10 s");
    }

    #[test]
    fn tilt_corrections_do_not_leak_into_yaw() {
        // Bias uncertainty of the size the initialisation window leaves.
        let p = SsUkfParams { initial_bias_sigma: deg(0.02), ..Default::default() };
        let mut f = SsUkf::new(Settings::default(), p);
        let err = testkit::yaw_kept_through_tilt_corrections(&mut f);
        // Without the covariance transport: 0.22°.
        assert!(err < 0.02, "yaw moved {err}° while the tilt converged");
    }

    #[test]
    fn bias_covariance_starts_from_the_window_as_in_the_ekf() {
        let mut f = SsUkf::with_defaults();
        testkit::bias_covariance_from_the_window(&mut f, |f| f.covariance());
    }

    #[test]
    fn garbage_input_keeps_the_state_sane() {
        // With the source's gate (1 ± 0.05 g, χ² 16): the unscented filters take the raw
        // accelerometer with the datasheet noise and follow whatever passes the gate.
        let s = crate::Settings {
            gate: crate::settings::GateSettings::SOURCE,
            ..crate::Settings::default()
        };
        let mut f = SsUkf::new(s, SsUkfParams::default());
        testkit::garbage_run(&mut f, |f| f.covariance());
    }

    #[test]
    fn initialises_then_sets_yaw_and_resets() {
        let mut f = SsUkf::with_defaults();
        testkit::init_window_and_reset(&mut f);
        assert_eq!(f.name(), "ssukf");
    }

    #[test]
    fn bad_parameters_fall_back_to_defaults() {
        let p =
            SsUkfParams { w0: 1.5, alpha: 0.0, initial_bias_sigma: f32::NAN, ..Default::default() };
        let f = SsUkf::new(Settings::default(), p);
        assert_eq!(*f.params(), SsUkfParams::default());
    }

    /// Each unusable parameter alone falls back (`W0`, α, β together); usable ones at the
    /// edge of their domain are kept: `W0` = 0, any finite β.
    #[test]
    fn each_bad_parameter_alone_falls_back() {
        let d = SsUkfParams::default();
        let (w, a, b) = (0.0, 0.5, -1.0);
        let good = SsUkfParams { w0: w, alpha: a, beta: b, ..d };
        assert_eq!(good.sanitised(), good);
        let almost_one = SsUkfParams { w0: 0.999, ..good };
        assert_eq!(almost_one.sanitised(), almost_one);
        for (w0, alpha, beta) in [
            (f32::NAN, a, b),
            (1.0, a, b),
            (-0.1, a, b),
            (w, 0.0, b),
            (w, -0.5, b),
            (w, f32::NAN, b),
            (w, f32::INFINITY, b),
            (w, a, f32::NAN),
            (w, a, f32::INFINITY),
        ] {
            let p = SsUkfParams { w0, alpha, beta, ..d }.sanitised();
            assert_eq!((p.w0, p.alpha, p.beta), (d.w0, d.alpha, d.beta), "{w0} {alpha} {beta}");
        }
    }
}
