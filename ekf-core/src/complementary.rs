//! Quaternion complementary filter of Valenti, Dryanovski and Xiao (2015), accelerometer
//! part, in this crate's conventions: gyro prediction, then a delta quaternion (in NED) that
//! rotates the predicted image of the measured "down" onto NED down, interpolated toward the
//! identity by the gain (LERP below 20°, SLERP above), applied by multiplication, normalised.
//! The delta quaternion has no NED-z component, so the correction never changes heading
//! directly.

use crate::{
    filter::AttitudeFilter, gate::PreCheck, mathf, settings::Settings, Flags, GyroOnly, ImuSample,
    Quaternion, Vec3,
};

/// Complementary-filter parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ComplementaryParams {
    /// Interpolation gain per sample at `gain_rate_hz`, dimensionless in [0, 1]; scaled with
    /// the actual `dt`. Default 0.0001, the best gain the source found.
    pub gain: f32,
    /// Sample rate at which `gain` is defined, Hz. Default 50.
    pub gain_rate_hz: f32,
    /// Corrections smaller than this angle use LERP, larger ones SLERP, rad. Default 20°.
    pub lerp_below: f32,
}

impl Default for ComplementaryParams {
    fn default() -> Self {
        ComplementaryParams { gain: 1e-4, gain_rate_hz: 50.0, lerp_below: mathf::deg(20.0) }
    }
}

/// The quaternion complementary filter (gyro bias from the initialisation window, fixed).
#[derive(Clone, Debug)]
pub struct Complementary {
    /// Input checks, initialisation window and gyro prediction.
    gyro: GyroOnly,
    params: ComplementaryParams,
}

impl Complementary {
    /// A new filter, starting its initialisation window.
    pub fn new(settings: Settings, params: ComplementaryParams) -> Self {
        Complementary { gyro: GyroOnly::new(settings), params }
    }

    /// The parameters in use.
    pub fn params(&self) -> &ComplementaryParams {
        &self.params
    }

    /// The correction quaternion (NED frame) that rotates `g` (a unit vector in NED, the
    /// predicted image of the measured down direction) onto NED down `(0, 0, 1)`.
    pub fn delta_to_down(g: Vec3) -> Quaternion {
        let s = 1.0 + g.z;
        if !(s > 1e-6) {
            // Upside down: any horizontal axis; rotate about north by π.
            return Quaternion::new(0.0, 1.0, 0.0, 0.0);
        }
        let c = mathf::sqrt(0.5 * s);
        let k = 1.0 / mathf::sqrt(2.0 * s);
        Quaternion::new(c, g.y * k, -g.x * k, 0.0)
    }

    fn correct(&mut self, a_g: Vec3, norm_g: f32, dt: f32) {
        let d_body = a_g * (-1.0 / norm_g);
        let q = self.gyro.attitude();
        let g = q.rotate(d_body);
        let dq = Self::delta_to_down(g);
        let alpha = (self.params.gain * dt * self.params.gain_rate_hz).clamp(0.0, 1.0);
        // Angle of dq is 2·acos(w): LERP below the threshold, else SLERP.
        let cos_half_thr = mathf::cos(0.5 * self.params.lerp_below);
        let step = if dq.w > cos_half_thr {
            Quaternion::IDENTITY.nlerp(dq, alpha)
        } else {
            Quaternion::IDENTITY.slerp(dq, alpha)
        };
        self.gyro.set_q(step * q);
    }
}

impl AttitudeFilter for Complementary {
    fn name(&self) -> &'static str {
        "cf"
    }

    fn update(&mut self, sample: &ImuSample) -> Flags {
        let c = match self.gyro.propagate(sample) {
            Ok(c) => c,
            Err(flags) => return flags,
        };
        let mut flags = c.flags;
        if let Some((a, n)) = c.accel_g {
            let gate = self.gyro.gate_mut();
            match gate.pre_check(c.dt_rate, a, n, 0.0) {
                PreCheck::Reject(f) => flags |= f,
                PreCheck::Pass { .. } => {
                    gate.accepted();
                    self.correct(a, n, c.dt_rate);
                    flags |= Flags::ACCEL_USED;
                }
            }
        }
        flags
    }

    fn attitude(&self) -> Quaternion {
        self.gyro.attitude()
    }

    fn gyro_bias(&self) -> Vec3 {
        self.gyro.gyro_bias()
    }

    fn is_initialised(&self) -> bool {
        self.gyro.is_initialised()
    }

    fn set_yaw(&mut self, yaw: f32) {
        self.gyro.set_yaw(yaw);
    }

    fn set_attitude(&mut self, q: Quaternion, bias: Vec3) {
        self.gyro.set_attitude(q, bias);
    }

    fn reset(&mut self) {
        self.gyro.reset();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{mathf::deg, Euler};

    #[test]
    fn delta_rotates_the_predicted_down_onto_ned_down() {
        for g in [Vec3::new(0.3, -0.2, 0.9), Vec3::new(-0.7, 0.1, 0.2), Vec3::new(0.0, 0.0, 1.0)] {
            let g = g * (1.0 / g.norm());
            let d = Complementary::delta_to_down(g);
            assert!((d.rotate(g) - Vec3::new(0.0, 0.0, 1.0)).max_abs() < 1e-6, "{g:?}");
            assert_eq!(d.z, 0.0);
        }
    }

    /// One correction of a level, still board believed rolled by `roll0` (yaw 0, no rate): the
    /// roll left after one sample of `dt` s.
    fn roll_after_one_sample(p: ComplementaryParams, roll0: f32, dt: f32) -> f32 {
        let mut f = Complementary::new(Settings::default(), p);
        f.set_attitude(Euler::new(roll0, 0.0, 0.0).to_quaternion(), Vec3::ZERO);
        let flags = f.update(&ImuSample::new(dt, Vec3::ZERO, Vec3::new(0.0, 0.0, -9.81)));
        assert!(flags.contains(Flags::ACCEL_USED));
        let e = f.euler();
        assert!(e.pitch.abs() < 1e-6 && e.yaw.abs() < 1e-6, "{e:?}");
        e.roll
    }

    /// The correction is about north, by a fraction α = gain · dt · gain_rate_hz of the tilt
    /// error: SLERP turns by exactly α·θ; LERP (normalised) by φ with
    /// tan(φ/2) = α sin(θ/2) / (1 − α + α cos(θ/2)), a little less.
    #[test]
    fn the_gain_scales_with_dt_and_large_corrections_use_slerp() {
        let p = ComplementaryParams { gain: 0.5, ..Default::default() };
        // 30° (beyond the default 20°: SLERP), α = 0.5 · 0.01 · 50 = 0.25: 30° − 7.5°.
        let r = roll_after_one_sample(p, deg(30.0), 0.01);
        assert!((r - deg(22.5)).abs() < 2e-5, "{}", mathf::to_deg(r));
        // At 0.02 s, α = 0.5: 15° left.
        let r = roll_after_one_sample(p, deg(30.0), 0.02);
        assert!((r - deg(15.0)).abs() < 2e-5, "{}", mathf::to_deg(r));
        // The same 30° with LERP up to 90°: tan(φ/2) = 0.25·sin 15° / (0.75 + 0.25·cos 15°)
        // = 0.0652607, φ = 7.4677°: 22.5323° left (SLERP would leave 22.5°).
        let lerp = ComplementaryParams { lerp_below: deg(90.0), ..p };
        let r = roll_after_one_sample(lerp, deg(30.0), 0.01);
        assert!((r - deg(22.5323)).abs() < 2e-5, "{}", mathf::to_deg(r));
        // 60° with LERP up to 90°: tan(φ/2) = 0.25·sin 30° / (0.75 + 0.25·cos 30°) = 0.1293318,
        // φ = 14.7385°: 45.2615° left (SLERP: 45°).
        let r = roll_after_one_sample(lerp, deg(60.0), 0.01);
        assert!((r - deg(45.2615)).abs() < 2e-5, "{}", mathf::to_deg(r));
        // Beyond 90° SLERP again: 100° − 25°.
        let r = roll_after_one_sample(lerp, deg(100.0), 0.01);
        assert!((r - deg(75.0)).abs() < 2e-5, "{}", mathf::to_deg(r));
    }

    /// The trait's other methods reach the gyro part: the window, the bias it measures,
    /// `set_yaw`, `reset`, the name.
    #[test]
    fn window_bias_yaw_and_reset() {
        let mut f = Complementary::new(Settings::default(), ComplementaryParams::default());
        assert_eq!(f.name(), "cf");
        assert!(!f.is_initialised());
        let b = Vec3::new(0.002, -0.001, 0.0005);
        let level = Vec3::new(0.0, 0.0, -crate::GRAVITY);
        let mut n = 0;
        while !f.is_initialised() && n < 5000 {
            f.update(&ImuSample::new(0.02, b, level));
            n += 1;
        }
        // The default window is 10 s: 500 samples of 0.02 s.
        assert!(f.is_initialised() && (499..=501).contains(&n), "{n}");
        assert!((f.gyro_bias() - b).norm() < 1e-6, "{:?}", f.gyro_bias());
        f.set_attitude(Euler::new(deg(10.0), deg(-20.0), deg(30.0)).to_quaternion(), b);
        f.set_yaw(deg(-45.0));
        let e = f.euler();
        assert!((e.yaw - deg(-45.0)).abs() < 1e-5, "{e:?}");
        assert!((e.roll - deg(10.0)).abs() < 1e-5 && (e.pitch - deg(-20.0)).abs() < 1e-5);
        f.reset();
        assert!(!f.is_initialised());
        assert_eq!(f.gyro_bias(), Settings::default().init.gyro_bias);
    }

    #[test]
    fn gain_one_snaps_tilt_and_keeps_heading_direction() {
        let p = ComplementaryParams { gain: 1.0, ..Default::default() };
        let mut f = Complementary::new(Settings::default(), p);
        // Start 30° off in roll and pitch; the board is truly level with yaw 40°.
        f.set_attitude(Euler::new(deg(30.0), deg(-30.0), deg(40.0)).to_quaternion(), Vec3::ZERO);
        f.update(&ImuSample::new(0.02, Vec3::ZERO, Vec3::new(0.0, 0.0, -9.81)));
        let e = f.euler();
        assert!(e.roll.abs() < 1e-5 && e.pitch.abs() < 1e-5, "{e:?}");
    }
}
