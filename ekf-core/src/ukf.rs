//! The source's unscented Kalman filter (comparison filter): the digest's seven-state additive
//! model `x = [q0 q1 q2 q3, bx by bz]` (quaternion body FRD → NED, gyro bias rad/s body FRD)
//! with `2n + 1 = 15` symmetric sigma points.
//!
//! Sigma points (scaled UT, digest values `α = 0.1`, `κ = 3`, `β = 2`, `n = 7`):
//! `λ = α²(n + κ) − n = −6.9`, `X_0 = x`, `X_{j} = x + √(n+λ)·(√P)_j`,
//! `X_{n+j} = x − √(n+λ)·(√P)_j` (`√P` the lower Cholesky factor, `(√P)_j` its column `j`).
//! Weights: `Wm_0 = λ/(n+λ) = −69`, `Wc_0 = Wm_0 + 1 + β − α² = −66.01`,
//! `Wm_i = Wc_i = 1/(2(n+λ)) = 5`.
//!
//! Process, measurement, noise, deviation-form moments, covariance repair, gate and
//! initialisation are shared with [`crate::SsUkf`]; see the `unscented` module source
//! documentation (summarised in [`Ukf`]). No yaw-split and no rest detection, as in the
//! source. The arithmetic is `f32`: the points sit `√(n+λ) ≈ 0.32` standard deviations from
//! the mean, well above `f32` resolution for the attitude itself. Not quite for the bias: a
//! bias offset moves a quaternion component by `0.32·σ_b·dt/2`, about 10⁻⁶ (tens of ulps) once
//! the bias has converged, so the bias–attitude cross terms carry rounding noise. On the
//! simulator this changes yaw RMSE by about ±0.1° against the same filter in `f64`; on a still
//! board pitched by 20° started from `set_attitude` it let yaw drift by 0.3°/min where `f64`
//! held it to 0.01°.

use nalgebra::SMatrix;

use crate::{
    mathf::deg,
    settings::Settings,
    unscented::{Core, SigmaSet, Tuning, N},
    Flags,
};

/// Number of sigma points, `2n + 1`.
const M: usize = 2 * N + 1;

/// Tuning of [`Ukf`]. Angles in rad, rates in rad/s.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct UkfParams {
    /// Spread `α` of the scaled unscented transform, dimensionless. Default 0.1 (source).
    pub alpha: f32,
    /// Secondary scaling `κ`, dimensionless. Default 3 (source).
    pub kappa: f32,
    /// Prior-distribution parameter `β` (2 is optimal for Gaussians), dimensionless.
    /// Default 2 (source).
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

impl Default for UkfParams {
    fn default() -> Self {
        UkfParams {
            alpha: 0.1,
            kappa: 3.0,
            beta: 2.0,
            accel_var_scale: 1.0,
            bias_random_walk: deg(0.002) * deg(0.002),
            initial_tilt_sigma: deg(2.0),
            initial_yaw_sigma: deg(5.0),
            initial_bias_sigma: deg(0.2),
        }
    }
}

impl UkfParams {
    /// The parameters with unusable values replaced by the defaults: `α`, `κ`, `β` together
    /// when any is non-finite, `α ≤ 0` or `n + κ ≤ 0`; each other field when non-finite or not
    /// positive (the random walk may be zero).
    pub fn sanitised(self) -> Self {
        let d = UkfParams::default();
        let ok = self.alpha.is_finite()
            && self.alpha > 0.0
            && self.kappa.is_finite()
            && N as f32 + self.kappa > 0.0
            && self.beta.is_finite();
        let (alpha, kappa, beta) =
            if ok { (self.alpha, self.kappa, self.beta) } else { (d.alpha, d.kappa, d.beta) };
        let t = self.tuning().sanitised(d.tuning());
        UkfParams {
            alpha,
            kappa,
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

    /// The symmetric point set and its weights (module documentation).
    fn sigma_set(&self) -> SigmaSet<f32, M> {
        let n = N as f32;
        // n + λ = α²(n + κ), computed directly (n + (α²(n + κ) − n) would cancel).
        let nl = self.alpha * self.alpha * (n + self.kappa);
        let gamma = crate::mathf::sqrt(nl);
        let mut z = SMatrix::<f32, N, M>::zeros();
        for j in 0..N {
            z[(j, 1 + j)] = gamma;
            z[(j, 1 + N + j)] = -gamma;
        }
        let wi = 1.0 / (2.0 * nl);
        let mut wm = [wi; M];
        let mut wc = [wi; M];
        // λ/(n + λ) = 1 − n/(n + λ).
        wm[0] = 1.0 - n / nl;
        wc[0] = wm[0] + 1.0 + self.beta - self.alpha * self.alpha;
        SigmaSet { z, wm, wc }
    }
}

/// The source's UKF on the seven-state additive quaternion + bias model (module docs).
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
pub struct Ukf {
    core: Core<f32, M>,
    params: UkfParams,
}

impl Ukf {
    /// A new filter, starting its initialisation window. Unusable parameters are replaced by
    /// the defaults ([`UkfParams::sanitised`]).
    pub fn new(settings: Settings, params: UkfParams) -> Self {
        let params = params.sanitised();
        Ukf { core: Core::new(settings, params.tuning(), params.sigma_set()), params }
    }

    /// A new filter with the default settings and parameters.
    pub fn with_defaults() -> Self {
        Ukf::new(Settings::default(), UkfParams::default())
    }

    /// The settings in use.
    pub fn settings(&self) -> &Settings {
        self.core.settings()
    }

    /// The parameters in use (after sanitising).
    pub fn params(&self) -> &UkfParams {
        &self.params
    }

    /// State covariance: rows/columns 0–3 the quaternion components `q0..q3` (dimensionless²),
    /// 4–6 the gyro bias, (rad/s)², body FRD.
    pub fn covariance(&self) -> SMatrix<f32, 7, 7> {
        self.core.covariance()
    }

    /// Flags of the last update.
    pub fn last_flags(&self) -> Flags {
        self.core.last_flags()
    }
}

impl Default for Ukf {
    /// Same as [`Ukf::with_defaults`].
    fn default() -> Self {
        Ukf::with_defaults()
    }
}

crate::unscented::impl_attitude_filter_for_core!(Ukf, "ukf");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::AttitudeFilter;
    use crate::unscented::testkit;

    #[test]
    fn weights_are_the_digest_values() {
        let s = UkfParams::default().sigma_set();
        assert!((s.wm[0] + 69.0).abs() < 1e-3, "{}", s.wm[0]);
        assert!((s.wc[0] + 66.01).abs() < 1e-3, "{}", s.wc[0]);
        assert!((s.wm[1] - 5.0).abs() < 1e-4 && s.wm[1] == s.wc[M - 1]);
        assert!((s.z[(3, 4)] - 0.1f32.sqrt()).abs() < 1e-6);
    }

    #[test]
    fn sigma_points_reproduce_mean_and_covariance() {
        let f = Ukf::with_defaults();
        let (mean_err, cov_err) = testkit::sigma_moment_errors(f.core.sigma_set());
        // f32: the offsets of a converged-size covariance are ~5000 ulps, hence ~1e-4.
        assert!(mean_err < 1e-4, "mean error {mean_err} σ");
        assert!(cov_err < 1e-3, "covariance error {cov_err} (relative)");
    }

    #[test]
    fn converges_from_a_30_degree_tilt_error() {
        let mut f = Ukf::with_defaults();
        let err = testkit::tilt_convergence(&mut f);
        assert!(err < 0.5, "tilt error {err}° after 20 s");
    }

    #[test]
    fn tracks_a_constant_rate_yaw_rotation() {
        let mut f = Ukf::with_defaults();
        let err = testkit::yaw_tracking(&mut f);
        assert!(err < 0.1, "yaw error {err}° after 10 s");
    }

    #[test]
    fn tilt_corrections_do_not_leak_into_yaw() {
        // Bias uncertainty of the size the initialisation window leaves.
        let p = UkfParams { initial_bias_sigma: deg(0.02), ..Default::default() };
        let mut f = Ukf::new(Settings::default(), p);
        let err = testkit::yaw_kept_through_tilt_corrections(&mut f);
        // Without the covariance transport: 0.22°. (f32 rounding of the bias cross terms leaves a few hundredths.)
        assert!(err < 0.1, "yaw moved {err}° while the tilt converged");
    }

    #[test]
    fn bias_covariance_starts_from_the_window_as_in_the_ekf() {
        let mut f = Ukf::with_defaults();
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
        let mut f = Ukf::new(s, UkfParams::default());
        testkit::garbage_run(&mut f, |f| f.covariance());
    }

    #[test]
    fn initialises_then_sets_yaw_and_resets() {
        let mut f = Ukf::with_defaults();
        testkit::init_window_and_reset(&mut f);
        assert_eq!(f.name(), "ukf");
    }

    #[test]
    fn bad_parameters_fall_back_to_defaults() {
        let p = UkfParams {
            alpha: f32::NAN,
            kappa: -10.0,
            initial_tilt_sigma: -1.0,
            ..Default::default()
        };
        let f = Ukf::new(Settings::default(), p);
        assert_eq!(*f.params(), UkfParams::default());
    }

    /// Each unusable parameter alone falls back (α, κ, β together); usable ones at the edge
    /// of their domain are kept: any finite β, `n + κ` just above 0, a zero random walk.
    #[test]
    fn each_bad_parameter_alone_falls_back() {
        let d = UkfParams::default();
        let (a, k, b) = (0.5, -6.5, -1.0);
        let good = UkfParams { alpha: a, kappa: k, beta: b, ..d };
        assert_eq!(good.sanitised(), good);
        for (alpha, kappa, beta) in [
            (f32::NAN, k, b),
            (0.0, k, b),
            (-0.5, k, b),
            (f32::INFINITY, k, b),
            (a, -7.0, b),
            (a, -8.0, b),
            (a, f32::INFINITY, b),
            (a, f32::NAN, b),
            (a, k, f32::NAN),
            (a, k, f32::NEG_INFINITY),
        ] {
            let p = UkfParams { alpha, kappa, beta, ..d }.sanitised();
            assert_eq!(
                (p.alpha, p.kappa, p.beta),
                (d.alpha, d.kappa, d.beta),
                "{alpha} {kappa} {beta}"
            );
        }
        let kept = UkfParams {
            accel_var_scale: 3.0,
            bias_random_walk: 0.0,
            initial_tilt_sigma: 0.1,
            initial_yaw_sigma: 0.2,
            initial_bias_sigma: 0.3,
            ..d
        };
        assert_eq!(kept.sanitised(), kept);
        for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            let p = UkfParams {
                accel_var_scale: bad,
                initial_tilt_sigma: bad,
                initial_yaw_sigma: bad,
                initial_bias_sigma: bad,
                ..kept
            }
            .sanitised();
            assert_eq!(p.accel_var_scale, d.accel_var_scale, "{bad}");
            assert_eq!(p.initial_tilt_sigma, d.initial_tilt_sigma, "{bad}");
            assert_eq!(p.initial_yaw_sigma, d.initial_yaw_sigma, "{bad}");
            assert_eq!(p.initial_bias_sigma, d.initial_bias_sigma, "{bad}");
            assert_eq!(p.bias_random_walk, 0.0);
        }
        for bad in [-1e-12, f32::NAN, f32::INFINITY] {
            let p = UkfParams { bias_random_walk: bad, ..kept }.sanitised();
            assert_eq!(p, UkfParams { bias_random_walk: d.bias_random_walk, ..kept }, "{bad}");
        }
    }
}
