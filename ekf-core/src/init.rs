//! The initialisation window: tilt from the averaged accelerometer, yaw given, gyro bias from
//! the averaged gyro — as on the board, where the first 10 s after power-up set the initial
//! quaternion.

use crate::{
    gate::{AccelGate, PreCheck},
    mathf,
    settings::InitSettings,
    validate::Checked,
    Euler, Quaternion, Vec3,
};

/// Roll and pitch (rad) of a body whose accelerometer reads the specific force `f` (any unit)
/// while still: `f = −g · (down in body)`.
pub fn tilt_from_accel(f: Vec3) -> (f32, f32) {
    let roll = mathf::atan2(-f.y, -f.z);
    let pitch = mathf::atan2(f.x, mathf::sqrt(f.y * f.y + f.z * f.z));
    (roll, pitch)
}

/// Attitude of a still body from its specific force `f` and a yaw (rad).
pub fn attitude_from_accel(f: Vec3, yaw: f32) -> Quaternion {
    let (roll, pitch) = tilt_from_accel(f);
    Euler::new(roll, pitch, yaw).to_quaternion()
}

/// Added to the variance of the window's bias estimate, (rad/s)² ((0.002 °/s)²): what the
/// window's average cannot know (turn-on drift, the window's own imperfect stillness).
pub const BIAS_VAR_FLOOR: f32 = 1.218e-9;

/// What the window produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InitStep {
    /// Still averaging; a provisional attitude from the samples so far (identity tilt before
    /// the first usable accelerometer sample).
    Pending(Quaternion),
    /// Done: initial attitude and gyro bias (rad/s, body FRD).
    Done(Quaternion, Vec3),
}

/// Accumulates the initialisation window.
#[derive(Clone, Copy, Debug)]
pub struct Initializer {
    settings: InitSettings,
    yaw: f32,
    elapsed: f32,
    acc_sum: Vec3,
    acc_n: u32,
    gyro_sum: Vec3,
    gyro_n: u32,
}

impl Initializer {
    /// A new window with the settings' initial yaw.
    pub fn new(settings: InitSettings) -> Self {
        Initializer {
            settings,
            yaw: settings.initial_yaw,
            elapsed: 0.0,
            acc_sum: Vec3::ZERO,
            acc_n: 0,
            gyro_sum: Vec3::ZERO,
            gyro_n: 0,
        }
    }

    /// Set the yaw (rad) the window will start from.
    pub fn set_yaw(&mut self, yaw: f32) {
        if yaw.is_finite() {
            self.yaw = mathf::wrap_pi(yaw);
        }
    }

    /// The yaw (rad) the window will start from.
    pub fn yaw(&self) -> f32 {
        self.yaw
    }

    /// Time accumulated so far, s.
    pub fn elapsed(&self) -> f32 {
        self.elapsed
    }

    /// Variance of the window's gyro-bias estimate per axis, (rad/s)²: the configured
    /// per-sample noise at the window's sample rate over the number of samples, plus
    /// [`BIAS_VAR_FLOOR`]. `None` when the bias is not estimated from the window. The filters
    /// start their bias covariance from it.
    pub fn bias_variance(&self, noise: &crate::settings::NoiseSettings) -> Option<Vec3> {
        if !self.settings.estimate_gyro_bias || self.gyro_n == 0 || !(self.elapsed > 0.0) {
            return None;
        }
        let n = self.gyro_n as f32;
        let rate_hz = n / self.elapsed;
        let floor = Vec3::new(BIAS_VAR_FLOOR, BIAS_VAR_FLOOR, BIAS_VAR_FLOOR);
        Some(noise.gyro_var * (rate_hz / noise.gyro_ref_rate_hz.max(1e-3) / n) + floor)
    }

    /// Add one sample: `dt` s, the gyro (rad/s) when valid, the accelerometer (any unit, body
    /// FRD) when it passed the magnitude gate.
    pub fn push(&mut self, dt: f32, gyro: Option<Vec3>, accel: Option<Vec3>) -> InitStep {
        self.elapsed += dt;
        if let Some(g) = gyro {
            self.gyro_sum += g;
            self.gyro_n += 1;
        }
        if let Some(a) = accel {
            self.acc_sum += a;
            self.acc_n += 1;
        }
        let q = if self.acc_n > 0 {
            attitude_from_accel(self.acc_sum, self.yaw)
        } else {
            Quaternion::from_yaw(self.yaw)
        };
        // Half a sample of tolerance: f32 sums of dt fall just short of the window (500 × 0.02
        // s = 9.9999 s), and the window must end on the sample nearest its length, not on the
        // next one, which may already be moving.
        if self.elapsed >= self.settings.window_s - 0.5 * dt && self.acc_n > 0 {
            let bias = if self.settings.estimate_gyro_bias && self.gyro_n > 0 {
                self.gyro_sum * (1.0 / self.gyro_n as f32)
            } else {
                self.settings.gyro_bias
            };
            InitStep::Done(q, bias)
        } else {
            InitStep::Pending(q)
        }
    }
}

/// Feed one checked sample to the window; only accelerometer samples that pass the gate's
/// magnitude, jump and hold-off checks enter the tilt average.
#[inline(never)] // the first seconds only: out of the update's hot code
pub fn feed(init: &mut Initializer, gate: &mut AccelGate, c: &Checked) -> InitStep {
    let a = c.accel_g.and_then(|(a, n)| match gate.pre_check(c.dt_rate, a, n) {
        PreCheck::Pass { .. } => Some(a),
        PreCheck::Reject(_) => None,
    });
    init.push(c.dt_rate, c.gyro, a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mathf::deg;

    #[test]
    fn tilt_from_a_known_attitude() {
        let truth = Euler::new(deg(-20.0), deg(35.0), deg(70.0)).to_quaternion();
        // Specific force of a still body: −g · down_in_body.
        let f = truth.down_in_body() * -9.81;
        let q = attitude_from_accel(f, deg(70.0));
        assert!(q.angle_to(truth) < 1e-5, "{}", q.angle_to(truth));
    }

    #[test]
    fn window_averages_then_finishes() {
        let s = InitSettings { window_s: 1.0, ..Default::default() };
        let mut init = Initializer::new(s);
        init.set_yaw(deg(30.0));
        let truth = Euler::new(deg(5.0), deg(-3.0), deg(30.0)).to_quaternion();
        let f = truth.down_in_body() * -1.0;
        let bias = Vec3::new(0.01, -0.02, 0.003);
        let mut done = None;
        for k in 0..60 {
            // Alternating noise that averages out exactly over pairs.
            let n = if k % 2 == 0 { 0.01 } else { -0.01 };
            match init.push(0.02, Some(bias + Vec3::new(n, n, n)), Some(f + Vec3::new(n, -n, n))) {
                InitStep::Pending(_) => assert!(k < 50, "still pending at {k}"),
                InitStep::Done(q, b) => {
                    // 1 s of 0.02 s steps: done at the 50th sample, not the 51st, although the f32 sum
                    // of dt is 0.99999994 (even count: the noise cancels).
                    assert_eq!(k, 49);
                    done = Some((q, b));
                    break;
                }
            }
        }
        let (q, b) = done.unwrap();
        assert!(q.angle_to(truth) < 1e-4);
        assert!((b - bias).max_abs() < 1e-6);
    }

    #[test]
    fn waits_for_an_accelerometer_sample_and_uses_configured_bias_without_gyro() {
        let s = InitSettings { window_s: 0.1, ..Default::default() };
        let mut init = Initializer::new(s);
        for _ in 0..10 {
            assert!(matches!(init.push(0.02, None, None), InitStep::Pending(_)));
        }
        match init.push(0.02, None, Some(Vec3::new(0.0, 0.0, -1.0))) {
            InitStep::Done(q, b) => {
                assert!(q.angle_to(Quaternion::IDENTITY) < 1e-6);
                assert_eq!(b, s.gyro_bias);
            }
            other => panic!("{other:?}"),
        }
    }
}
