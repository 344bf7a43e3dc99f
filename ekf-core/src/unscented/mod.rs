//! Sigma-point machinery shared by the two unscented comparison filters, [`crate::Ukf`] and
//! [`crate::SsUkf`]: the digest's seven-state additive model, the unscented transform in
//! deviation form, the measurement update, covariance repair, and the filter loop (validation,
//! initialisation window, accelerometer gate, health checks) mirroring [`crate::Ekf`]. The two
//! filters differ only in their sigma-point set ([`SigmaSet`]) and scalar type.
//!
//! # Model
//! State `x = [q0 q1 q2 q3, bx by bz]`: the attitude quaternion (scalar first, body FRD → NED)
//! as four *additive* components, and the gyro bias (rad/s, body FRD). Covariance `P` is 7×7
//! over the same components (quaternion rows dimensionless², bias rows (rad/s)²).
//!
//! - Process (digest): `ω = gyro − b`, `q ← (I + ½ Ω(ω) dt) q`, `b ← b`, applied to every
//!   sigma point; the quaternion part of the propagated mean is then normalised (by its norm
//!   only, never sign-flipped, so that `P`'s cross terms keep their meaning). With an invalid
//!   gyro sample the state is held and only `Q` is added.
//! - Process noise `Q = blockdiag(Q_q, Q_b)`, diagonal: `Q_q = (dt²/4)·σ²_g·I₄` with
//!   `σ²_g = ψ̄/dt` the per-sample gyro variance at the actual rate (`ψ̄` the mean over the three
//!   axes of [`crate::settings::NoiseSettings::gyro_psd`], rad²/s), i.e. `Q_q = ψ̄·dt/4·I₄`
//!   (the per-step angle variance `ψ̄·dt` mapped to quaternion components by `½Ξ(q)`, with
//!   `Ξ Ξᵀ ≈ I₄`); `Q_b = bias_random_walk·dt·I₃`. `dt` here is the whole sample interval
//!   (`Checked::dt_cov`); the state moves over `Checked::dt_rate`.
//! - Measurement: the unit "down" vector in the body frame, `y = down_in_body(q)` evaluated on
//!   every (not normalised) sigma point; measured `−a/|a|` (accelerometer in g). `R = σ²_a ·
//!   accel_var_scale · I₃` with `σ²_a` = [`crate::settings::NoiseSettings::accel_var_per_sample`]
//!   (g², and the unit vector is in g units: `noise.accel_var` scaled to the sample rate).
//! - Sigma points are redrawn from `(x̄, P̄)` for the measurement update (so that `Q` is seen
//!   by the cross-covariance). `K = P_xy S⁻¹`, `x ← x̄ + K ν`, `P ← P̄ − K S Kᵀ`, then
//!   symmetrised, the quaternion part of `x` normalised, and `P` carried to the new mean
//!   (below).
//!
//! # Covariance transport
//! The quaternion block of `P` describes the uncertainty in the tangent directions of the mean
//! it was computed at: about NED x, y, z, `Γ(q̄)` (below), plus the radial direction `q̄`. The
//! time update keeps it there by itself (the process is linear in `q`: `F = I + ½Ω dt` is
//! right multiplication by `(1, ω dt/2)`, which maps `Γ(q)` to `Γ(F q)`), but the measurement
//! update moves the mean and leaves `P` behind. Yaw is unobservable, so its variance stays
//! large (5° at start) while tilt's is 0.05°: after a correction by `δ` rad the old yaw axis
//! `Γ_z(q̄_old)` lies `δ/2` off the new one, toward a tilt direction, and `P` then claims a
//! yaw–tilt correlation of about `σ_ψ² δ/2` — which the next accelerometer updates act on,
//! moving yaw by up to `(σ_ψ/σ_θ)²` times that. (Measured on the simulator: yaw RMSE 0.4–2.2°
//! from this alone, against 0.1–0.8° carried.) So after every update `P` is carried with the
//! mean: `P ← T P Tᵀ`, `T = blockdiag(M, I₃)`, `M` the right multiplication by
//! `Δ = q̄_prior* ⊗ q̄_new` (orthogonal), which maps `Γ(q̄_prior)` onto `Γ(q̄_new)` and
//! `q̄_prior` onto `q̄_new` — the same operation the time update applies. The digest does not
//! mention it; it changes nothing in the sigma-point algorithm itself, and without it the
//! additive model's covariance contradicts its own mean.
//!
//! # Deviation form
//! The central weights are large and negative (UKF −69, SS-UKF ≈ −9·10⁷), so means and
//! covariances are computed from the deviations `D_i = Y_i − Y_0` of the transformed points
//! from the transformed central point: `ȳ = Y_0 + d̄` with `d̄ = Σ Wm_i D_i`, and
//! `P_yy = Σ Wc_i (D_i − d̄)(D_i − d̄)ᵀ` (the central term is `Wc_0 d̄ d̄ᵀ`). The state-side
//! deviations of the drawn points are `√P·Z_i` exactly.
//!
//! # Repair
//! `P` is symmetrised after every step. When its Cholesky factorisation fails (non-finite, or
//! not positive definite — the second source's UKF failure), each diagonal entry `P_ii` gets
//! `10⁻⁴·|P_ii| + 10⁻⁹·max_j |P_jj|` added and the factorisation is retried once; if that still
//! fails `P` is reset to the initial covariance at the current attitude. Either way the update
//! reports [`Flags::HEALTH_RESET`]. The same happens when the innovation covariance `S` cannot
//! be factorised (then the update is skipped).
//!
//! # Gate
//! The [`AccelGate`] is used as in the EKF. The normalised innovation squared is
//! `nis = νᵀ S⁻¹ ν` of the full 3-vector innovation, compared as is with the 2-degree-of-freedom
//! threshold: the component of `ν` along "down" is second order (both vectors are unit), so the
//! statistic has effectively two degrees of freedom. On `REACQUIRE` the tilt uncertainty is
//! widened to the innovation's size (as the EKF does): `P_qq += (|ν|²/4)·(Γ_x Γ_xᵀ + Γ_y Γ_yᵀ)`
//! with `Γ` below, and the update recomputed.
//!
//! # Initial covariance
//! The attitude sigmas are angles about NED axes. With `q_true = (1, δθ/2) ⊗ q`,
//! `δq = ½ Γ(q) δθ`, `Γ(q) = [−uᵀ; w I − [u×]]` (4×3, `q = (w, u)`), so
//! `P_qq = ¼ Γ diag(σ_t², σ_t², σ_ψ²) Γᵀ + ¼ σ_t² q qᵀ` — the last term gives the (otherwise
//! singular) radial direction the tilt's variance so that `P` is positive definite.
//! `P_bb = σ_b² I₃`, no cross terms. When the initialisation window measured the bias, `P_bb`
//! starts instead at the window's standard error plus `(0.002 °/s)²` per axis
//! ([`crate::init::Initializer::bias_variance`]), exactly as the EKF: with `σ_b` = 0.2 °/s
//! the bias states take up tilt innovations and integrate them into yaw (the z bias wandered
//! to 0.3 °/s and yaw by 40° on the `coupled` scenario). `set_attitude` and covariance resets
//! use `σ_b`.

use nalgebra::{RealField, SMatrix, SVector};

mod filter_loop;
mod model;
mod repair;
mod transform;

#[cfg(test)]
pub(crate) mod testkit;
#[cfg(test)]
mod tests;

pub(crate) use filter_loop::Core;
pub(crate) use transform::SigmaSet;

/// State dimension.
pub(crate) const N: usize = 7;
/// State vector `[q0 q1 q2 q3 bx by bz]`.
pub(crate) type Vector<T> = SVector<T, N>;
/// 7×7 matrix over the state.
pub(crate) type Matrix<T> = SMatrix<T, N, N>;

/// The scalar the sigma-point arithmetic runs in (`f32` or `f64`).
pub(crate) trait Real: RealField + Copy {
    /// From `f32`.
    fn of(x: f32) -> Self;
    /// To `f32` (rounded; saturates to ±inf).
    fn to_f32(self) -> f32;
    /// To `f64` (exact).
    #[cfg(test)]
    fn to_f64(self) -> f64;
}

impl Real for f32 {
    #[inline]
    fn of(x: f32) -> Self {
        x
    }
    #[inline]
    fn to_f32(self) -> f32 {
        self
    }
    #[cfg(test)]
    fn to_f64(self) -> f64 {
        self as f64
    }
}

impl Real for f64 {
    #[inline]
    fn of(x: f32) -> Self {
        x as f64
    }
    #[inline]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[cfg(test)]
    fn to_f64(self) -> f64 {
        self
    }
}

/// Tuning shared by both unscented filters (see their parameter structs for the meaning).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Tuning {
    pub accel_var_scale: f32,
    pub bias_random_walk: f32,
    pub initial_tilt_sigma: f32,
    pub initial_yaw_sigma: f32,
    pub initial_bias_sigma: f32,
}

impl Tuning {
    /// Replace unusable values (non-finite, non-positive; negative for the random walk) by the
    /// corresponding value of `d`.
    pub fn sanitised(self, d: Tuning) -> Tuning {
        let pos = |v: f32, d: f32| if v.is_finite() && v > 0.0 { v } else { d };
        Tuning {
            accel_var_scale: pos(self.accel_var_scale, d.accel_var_scale),
            bias_random_walk: if self.bias_random_walk.is_finite() && self.bias_random_walk >= 0.0 {
                self.bias_random_walk
            } else {
                d.bias_random_walk
            },
            initial_tilt_sigma: pos(self.initial_tilt_sigma, d.initial_tilt_sigma),
            initial_yaw_sigma: pos(self.initial_yaw_sigma, d.initial_yaw_sigma),
            initial_bias_sigma: pos(self.initial_bias_sigma, d.initial_bias_sigma),
        }
    }
}

/// `AttitudeFilter` for a wrapper around [`Core`] (its field `core`), named `$name`.
macro_rules! impl_attitude_filter_for_core {
    ($ty:ty, $name:literal) => {
        impl $crate::filter::AttitudeFilter for $ty {
            fn name(&self) -> &'static str {
                $name
            }

            fn update(&mut self, sample: &$crate::ImuSample) -> $crate::Flags {
                self.core.update(sample)
            }

            fn attitude(&self) -> $crate::Quaternion {
                self.core.attitude()
            }

            fn gyro_bias(&self) -> $crate::Vec3 {
                self.core.gyro_bias()
            }

            fn is_initialised(&self) -> bool {
                self.core.is_initialised()
            }

            fn set_yaw(&mut self, yaw: f32) {
                self.core.set_yaw(yaw);
            }

            fn set_attitude(&mut self, q: $crate::Quaternion, bias: $crate::Vec3) {
                self.core.start(q, bias);
            }

            fn reset(&mut self) {
                self.core.reset();
            }
        }
    };
}
pub(crate) use impl_attitude_filter_for_core;
