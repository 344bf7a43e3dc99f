//! Lever-arm compensation of the accelerometer.
//!
//! The IMU sits at `r` (m, body FRD) from the vehicle's rotation centre, so on a rotating body
//! the accelerometer measures the specific force at the origin plus the tangential and
//! centripetal accelerations of its own position:
//!
//! ```text
//! f_imu = f_origin + ω̇ × r + ω × (ω × r)
//! ```
//!
//! [`LeverArmCompensator`] removes those terms (each behind a switch of [`LeverArm`]). `ω̇` is
//! not measured: it is the backward finite difference of successive gyro samples, low-pass
//! filtered, which is noisy, so the tangential term is off by default.

use crate::Vec3;

/// Lever-arm settings.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LeverArm {
    /// Position of the IMU relative to the vehicle's rotation centre, m, body FRD.
    pub r: Vec3,
    /// Remove the centripetal term `ω × (ω × r)`.
    pub centripetal: bool,
    /// Remove the tangential term `ω̇ × r` (ω̇ from differentiated gyro samples).
    pub tangential: bool,
    /// Time constant of the first-order low-pass on the differentiated `ω̇`, s. `0` (or any
    /// value that is not `> 0`) means no filtering.
    pub tangential_time_constant: f32,
}

impl LeverArm {
    /// The Seahog ROV's IMU position from the source, m, body FRD.
    pub const SEAHOG_R: Vec3 = Vec3::new(0.297_25, -0.196, 0.0803);

    /// No lever arm: `r = 0`, so compensation changes nothing whatever the switches.
    pub const NONE: LeverArm = LeverArm {
        r: Vec3::ZERO,
        centripetal: true,
        tangential: false,
        tangential_time_constant: 0.05,
    };
}

impl Default for LeverArm {
    /// The Seahog: `r =` [`LeverArm::SEAHOG_R`] (0.29725, −0.196, 0.0803) m, centripetal on,
    /// tangential off, tangential time constant 0.05 s.
    fn default() -> Self {
        LeverArm {
            r: LeverArm::SEAHOG_R,
            centripetal: true,
            tangential: false,
            tangential_time_constant: 0.05,
        }
    }
}

/// Stateful lever-arm compensator: holds the [`LeverArm`] settings, the previous gyro sample
/// and the filtered angular acceleration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeverArmCompensator {
    arm: LeverArm,
    prev_gyro: Option<Vec3>,
    omega_dot: Vec3,
}

impl Default for LeverArmCompensator {
    /// A compensator with [`LeverArm::default`] (the Seahog).
    fn default() -> Self {
        LeverArmCompensator::new(LeverArm::default())
    }
}

impl LeverArmCompensator {
    /// A compensator with settings `arm` and no history.
    pub const fn new(arm: LeverArm) -> Self {
        LeverArmCompensator { arm, prev_gyro: None, omega_dot: Vec3::ZERO }
    }

    /// The settings.
    pub fn arm(&self) -> &LeverArm {
        &self.arm
    }

    /// The current filtered angular acceleration estimate `ω̇`, rad/s², body FRD (zero until two
    /// valid samples have been seen).
    pub fn omega_dot(&self) -> Vec3 {
        self.omega_dot
    }

    /// Forget the previous gyro sample and the filtered `ω̇`.
    pub fn reset(&mut self) {
        self.prev_gyro = None;
        self.omega_dot = Vec3::ZERO;
    }

    /// Specific force at the rotation centre, m/s², body FRD:
    /// `accel − ω × (ω × r) − ω̇ × r` (each term only when its switch is on).
    ///
    /// `accel`: measured specific force at the IMU, m/s², body FRD. `gyro`: bias-corrected
    /// angular rate `ω`, rad/s, body FRD. `dt`: time since the previous call, s.
    ///
    /// `ω̇` is updated from `(ω − ω_prev) / dt` through a first-order low-pass of time constant
    /// [`LeverArm::tangential_time_constant`]; the first call after construction or
    /// [`reset`](Self::reset) has no previous sample and leaves `ω̇` unchanged (zero).
    ///
    /// When `accel` or `gyro` has a non-finite component, or `dt` is not a finite positive
    /// number, `accel` is returned unchanged and the state is not touched. A non-finite
    /// correction (overflow) also returns `accel` unchanged.
    pub fn compensate(&mut self, accel: Vec3, gyro: Vec3, dt: f32) -> Vec3 {
        if !(accel.is_finite() && gyro.is_finite() && dt.is_finite() && dt > 0.0) {
            return accel;
        }
        if let Some(prev) = self.prev_gyro {
            let raw = (gyro - prev) / dt;
            let tau = self.arm.tangential_time_constant;
            let filtered = if tau > 0.0 {
                self.omega_dot + (raw - self.omega_dot) * (dt / (tau + dt))
            } else {
                raw
            };
            if filtered.is_finite() {
                self.omega_dot = filtered;
            }
        }
        self.prev_gyro = Some(gyro);

        let r = self.arm.r;
        let mut correction = Vec3::ZERO;
        if self.arm.centripetal {
            correction += gyro.cross(gyro.cross(r));
        }
        if self.arm.tangential {
            correction += self.omega_dot.cross(r);
        }
        let out = accel - correction;
        if out.is_finite() {
            out
        } else {
            accel
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GRAVITY;

    const F0: Vec3 = Vec3::new(0.0, 0.0, -GRAVITY);

    fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
        (a - b).max_abs() <= tol
    }

    #[test]
    fn seahog_default() {
        let d = LeverArm::default();
        assert_eq!(d.r, Vec3::new(0.29725, -0.196, 0.0803));
        assert!(d.centripetal);
        assert!(!d.tangential);
        assert_eq!(d.tangential_time_constant, 0.05);
    }

    #[test]
    fn constant_yaw_rate_centripetal_hand_values() {
        // ω = (0, 0, 1) rad/s, r = (0.3, 0, 0) m: ω × r = (0, 0.3, 0),
        // ω × (ω × r) = (−0.3, 0, 0) m/s² (towards the centre).
        let arm = LeverArm { r: Vec3::new(0.3, 0.0, 0.0), ..LeverArm::default() };
        let mut c = LeverArmCompensator::new(arm);
        let w = Vec3::new(0.0, 0.0, 1.0);
        let measured = F0 + Vec3::new(-0.3, 0.0, 0.0);
        for _ in 0..5 {
            let out = c.compensate(measured, w, 0.01);
            assert!(close(out, F0, 1e-6), "{out:?}");
        }
        // 2 rad/s about z, r = (0.3, 0.2, 0): centripetal = −ω² r_⊥ = (−1.2, −0.8, 0).
        let arm = LeverArm { r: Vec3::new(0.3, 0.2, 0.5), ..LeverArm::default() };
        let mut c = LeverArmCompensator::new(arm);
        let out = c.compensate(Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0), 0.01);
        assert!(close(out, Vec3::new(1.2, 0.8, 0.0), 1e-6), "{out:?}");
        // Switched off: unchanged.
        let mut c = LeverArmCompensator::new(LeverArm { centripetal: false, ..arm });
        assert_eq!(c.compensate(F0, Vec3::new(0.0, 0.0, 2.0), 0.01), F0);
    }

    #[test]
    fn constant_angular_acceleration_tangential_term() {
        // ω̇ = (0, 0, 2) rad/s², ω(t) = ω̇ t, r = (0.3, 0, 0):
        // ω̇ × r = (0, 0.6, 0), ω × (ω × r) = (−0.3 (2t)², 0, 0).
        let arm = LeverArm {
            r: Vec3::new(0.3, 0.0, 0.0),
            centripetal: true,
            tangential: true,
            tangential_time_constant: 0.0,
        };
        let mut c = LeverArmCompensator::new(arm);
        let dt = 0.01;
        for k in 0..50 {
            let t = k as f32 * dt;
            let w = Vec3::new(0.0, 0.0, 2.0 * t);
            let measured = F0 + Vec3::new(0.0, 0.6, 0.0) + Vec3::new(-0.3 * w.z * w.z, 0.0, 0.0);
            let out = c.compensate(measured, w, dt);
            if k == 0 {
                // No previous sample yet: ω̇ unknown (zero), tangential part left in.
                assert!(close(out, F0 + Vec3::new(0.0, 0.6, 0.0), 1e-5), "{out:?}");
            } else {
                assert!(close(c.omega_dot(), Vec3::new(0.0, 0.0, 2.0), 1e-3));
                assert!(close(out, F0, 1e-4), "k = {k}: {out:?}");
            }
        }
    }

    #[test]
    fn tangential_low_pass_follows_first_order_response() {
        // τ = 0.05 s, dt = 0.01 s: α = dt / (τ + dt) = 1/6 per step towards the raw derivative.
        let arm = LeverArm {
            r: Vec3::new(0.0, 1.0, 0.0),
            centripetal: false,
            tangential: true,
            tangential_time_constant: 0.05,
        };
        let mut c = LeverArmCompensator::new(arm);
        let dt = 0.01;
        c.compensate(Vec3::ZERO, Vec3::ZERO, dt);
        // Step to a constant ω̇ = (1, 0, 0) rad/s²: raw derivative is 1 every step.
        let mut expected = 0.0f32;
        for k in 1..=10 {
            let w = Vec3::new(k as f32 * dt, 0.0, 0.0);
            let out = c.compensate(Vec3::ZERO, w, dt);
            expected += (1.0 - expected) / 6.0;
            assert!((c.omega_dot().x - expected).abs() < 1e-4, "k = {k}");
            // ω̇ × r = (x, 0, 0) × (0, 1, 0) = (0, 0, x), subtracted.
            assert!(close(out, Vec3::new(0.0, 0.0, -expected), 1e-4), "{out:?}");
        }
        // After one step it is exactly 1/6 of the way; after ten, 1 − (5/6)¹⁰ ≈ 0.8385.
        assert!((expected - (1.0 - libm::powf(5.0 / 6.0, 10.0))).abs() < 1e-5);
    }

    #[test]
    fn zero_motion_changes_nothing() {
        let arm = LeverArm { tangential: true, ..LeverArm::default() };
        let mut c = LeverArmCompensator::new(arm);
        for _ in 0..10 {
            assert_eq!(c.compensate(F0, Vec3::ZERO, 0.01), F0);
        }
        // Zero lever arm: nothing to compensate whatever the motion.
        let mut c = LeverArmCompensator::new(LeverArm { tangential: true, ..LeverArm::NONE });
        let a = Vec3::new(0.5, -0.25, -9.7);
        for k in 0..10 {
            let w = Vec3::new(0.3, -1.0, 2.0) * k as f32;
            assert_eq!(c.compensate(a, w, 0.01), a);
        }
    }

    #[test]
    fn bad_input_does_not_poison_state() {
        let arm = LeverArm {
            r: Vec3::new(0.3, 0.0, 0.0),
            centripetal: true,
            tangential: true,
            tangential_time_constant: 0.0,
        };
        let mut c = LeverArmCompensator::new(arm);
        let w0 = Vec3::new(0.0, 0.0, 1.0);
        c.compensate(F0, w0, 0.01);
        let before = c;
        let nan = Vec3::new(f32::NAN, 0.0, 0.0);
        assert_eq!(c.compensate(F0, nan, 0.01), F0);
        assert_eq!(c.compensate(F0, w0, 0.0), F0);
        assert_eq!(c.compensate(F0, w0, -0.01), F0);
        assert_eq!(c.compensate(F0, w0, f32::NAN), F0);
        assert_eq!(c.compensate(F0, Vec3::new(0.0, 0.0, f32::INFINITY), 0.01), F0);
        let out = c.compensate(nan, w0, 0.01);
        assert!(out.x.is_nan());
        assert_eq!(c, before);
        // Still works: same ω, so ω̇ = 0 and only the centripetal term is removed.
        let out = c.compensate(F0, w0, 0.01);
        assert!(close(out, F0 + Vec3::new(0.3, 0.0, 0.0), 1e-6));
        // Overflowing correction: accel returned unchanged, never NaN.
        let out = c.compensate(F0, Vec3::new(0.0, 0.0, 1e30), 0.01);
        assert_eq!(out, F0);
        // Tiny dt with a jump: raw derivative overflows, ω̇ keeps its last finite value.
        let mut c = LeverArmCompensator::new(arm);
        c.compensate(F0, Vec3::new(0.0, 0.0, -3e38), 1.0);
        c.compensate(F0, Vec3::new(0.0, 0.0, 3e38), 1e-30);
        assert!(c.omega_dot().is_finite());
    }

    #[test]
    fn reset_forgets_history() {
        let arm = LeverArm {
            r: Vec3::new(0.3, 0.0, 0.0),
            centripetal: false,
            tangential: true,
            tangential_time_constant: 0.0,
        };
        let mut c = LeverArmCompensator::new(arm);
        c.compensate(Vec3::ZERO, Vec3::ZERO, 0.1);
        c.compensate(Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0), 0.1);
        assert!(close(c.omega_dot(), Vec3::new(0.0, 0.0, 10.0), 1e-4));
        c.reset();
        assert_eq!(c.omega_dot(), Vec3::ZERO);
        // No previous sample after reset: a large ω gives no derivative on the first call.
        c.compensate(Vec3::ZERO, Vec3::new(0.0, 0.0, 5.0), 0.1);
        assert_eq!(c.omega_dot(), Vec3::ZERO);
    }
}
