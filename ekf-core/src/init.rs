//! The initialisation window: tilt from the averaged accelerometer, yaw given, gyro bias from
//! the averaged gyro — as on the board, where the first 10 s after power-up set the initial
//! quaternion.

use crate::{
    gate::{AccelGate, PreCheck},
    mathf,
    settings::{InitSettings, Settings},
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

/// Samples before the window's stillness is judged (and at least [`MIN_CHECK_S`]).
pub const MIN_CHECK_SAMPLES: u32 = 10;
/// Time before the window's stillness is judged, s.
pub const MIN_CHECK_S: f32 = 0.2;
/// Largest gyro variance per axis of a still window, as a multiple of the configured noise
/// variance: 40 (6.3× in standard deviation). Tolerant of a noise setting 10× too low and of
/// vibration and quantisation; the motion that corrupts a window's mean is orders of magnitude
/// above it (a 15° pitch sine at 0.1 Hz: 44 (°/s)², 130× the x gyro's noise variance). Steady
/// turns have no spread: the mean test catches them.
pub const WINDOW_GYRO_VAR_FACTOR: f32 = 40.0;
/// Largest accelerometer standard deviation per axis of a still window, as a multiple of
/// `rest.accel_std_max_g` (0.01 g): 0.05 g. Vibration of a few hundredths of g (a pump, a
/// thruster at idle) averages out of the tilt and does not touch the gyro bias; a 15° pitch
/// sine spreads the accelerometer by 0.18 g.
pub const WINDOW_ACCEL_STD_FACTOR: f32 = 5.0;

/// Interval between the window's still checkpoints, s.
pub const CHECKPOINT_S: f32 = 0.25;
/// A window found moving still gives its bias and tilt when it had been still for this long
/// before (up to the checkpoint two [`CHECKPOINT_S`] before the last: motion that begins slowly
/// is seen up to half a second late), s.
pub const MIN_STILL_PREFIX_S: f32 = 0.5;

/// The window's sums up to a point.
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    elapsed: f32,
    acc_sum: Vec3,
    acc_sq: Vec3,
    acc_n: u32,
    gyro_sum: Vec3,
    gyro_sq: Vec3,
    gyro_n: u32,
}

/// Per-axis mean and variance of `n` samples from their sum and sum of squares.
fn mean_var(sum: Vec3, sq: Vec3, n: u32) -> ([f32; 3], [f32; 3]) {
    let k = 1.0 / n.max(1) as f32;
    let (m, q) = (sum * k, sq * k);
    let var = Vec3::new(q.x - m.x * m.x, q.y - m.y * m.y, q.z - m.z * m.z);
    (m.to_array(), var.to_array())
}

impl Sums {
    /// The samples after `earlier` (a checkpoint of the same window).
    fn since(&self, earlier: &Sums) -> Sums {
        Sums {
            elapsed: self.elapsed - earlier.elapsed,
            acc_sum: self.acc_sum - earlier.acc_sum,
            acc_sq: self.acc_sq - earlier.acc_sq,
            acc_n: self.acc_n - earlier.acc_n,
            gyro_sum: self.gyro_sum - earlier.gyro_sum,
            gyro_sq: self.gyro_sq - earlier.gyro_sq,
            gyro_n: self.gyro_n - earlier.gyro_n,
        }
    }

    fn gyro(&self) -> ([f32; 3], [f32; 3]) {
        mean_var(self.gyro_sum, self.gyro_sq, self.gyro_n)
    }

    fn accel(&self) -> ([f32; 3], [f32; 3]) {
        mean_var(self.acc_sum, self.acc_sq, self.acc_n)
    }
}

/// Accumulates the initialisation window.
#[derive(Clone, Copy, Debug)]
pub struct Initializer {
    settings: InitSettings,
    yaw: f32,
    /// The sums over the window so far.
    s: Sums,
    /// Largest per-sample gyro variance of a still window at the reference rate, (rad/s)².
    gyro_var_max: Vec3,
    /// Reference rate of `gyro_var_max`, Hz.
    gyro_ref_rate_hz: f32,
    /// Largest accelerometer variance per axis of a still window, g².
    accel_var_max: f32,
    moving: bool,
    /// The sums at the last still checkpoint, and at the two before it.
    checkpoint: Sums,
    previous: Sums,
    still_prefix: Sums,
    /// The accelerometer variance of the whole window when it ended (g², summed over axes).
    level: Option<f32>,
}

impl Initializer {
    /// A new window with the settings' initial yaw. A window is still when, per axis, the
    /// gyro's variance is within [`WINDOW_GYRO_VAR_FACTOR`] times the configured noise, the
    /// accelerometer's standard deviation within [`WINDOW_ACCEL_STD_FACTOR`] ×
    /// `rest.accel_std_max_g`, and the mean gyro within 3 `moving_bias_sigma` of `gyro_bias`.
    pub fn new(s: &Settings) -> Self {
        Initializer {
            settings: s.init,
            yaw: s.init.initial_yaw,
            s: Sums::default(),
            gyro_var_max: s.noise.gyro_var * WINDOW_GYRO_VAR_FACTOR,
            gyro_ref_rate_hz: s.noise.gyro_ref_rate_hz.max(1e-3),
            accel_var_max: {
                let a = s.rest.accel_std_max_g * WINDOW_ACCEL_STD_FACTOR;
                a * a
            },
            moving: false,
            checkpoint: Sums::default(),
            previous: Sums::default(),
            still_prefix: Sums::default(),
            level: None,
        }
    }

    /// True when the window was found moving: it ended early, the bias was not taken from it.
    pub fn was_moving(&self) -> bool {
        self.moving
    }

    /// The accelerometer's variance over the window so far, summed over the axes, g² (0 before
    /// two samples): the motion level the filter starts from.
    pub fn motion_level(&self) -> f32 {
        match self.level {
            Some(l) => l,
            None if self.s.acc_n < 2 => 0.0,
            None => self.s.accel().1.iter().map(|v| v.max(0.0)).sum(),
        }
    }

    /// The stillness test of [`Initializer::new`] on the samples so far.
    fn is_moving(&self) -> bool {
        if self.s.gyro_n < MIN_CHECK_SAMPLES || !(self.s.elapsed >= MIN_CHECK_S) {
            return false;
        }
        // Per-sample noise scales with the sample rate (constant noise density).
        let rate = self.s.gyro_n as f32 / self.s.elapsed;
        let var_max = (self.gyro_var_max * (rate / self.gyro_ref_rate_hz)).to_array();
        let configured = self.settings.gyro_bias.to_array();
        let off_max = 3.0 * self.settings.moving_bias_sigma;
        let (mean, var) = self.s.gyro();
        for (((m, v), vmax), c) in mean.iter().zip(var).zip(var_max).zip(configured) {
            if !(v <= vmax) || !(mathf::abs(m - c) <= off_max) {
                return true;
            }
        }
        if self.s.acc_n >= MIN_CHECK_SAMPLES
            && self.s.accel().1.iter().any(|v| !(*v <= self.accel_var_max))
        {
            return true;
        }
        // Motion that begins after a still part: the samples since the last checkpoint against
        // those before it — a spread, or a mean rate 3 standard errors away.
        let cp = self.checkpoint;
        let seg = self.s.since(&cp);
        if cp.gyro_n >= MIN_CHECK_SAMPLES && seg.gyro_n >= MIN_CHECK_SAMPLES {
            let (seg_mean, seg_var) = seg.gyro();
            let (cp_mean, _) = cp.gyro();
            let k = 1.0 / seg.gyro_n as f32 + 1.0 / cp.gyro_n as f32;
            for (((sm, sv), cm), vmax) in seg_mean.iter().zip(seg_var).zip(cp_mean).zip(var_max) {
                let d = sm - cm;
                if !(sv <= vmax) || !(d * d <= 9.0 * vmax * k) {
                    return true;
                }
            }
        }
        false
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
        self.s.elapsed
    }

    /// Variance of the window's gyro-bias estimate per axis, (rad/s)²: the configured
    /// per-sample noise at the window's sample rate over the number of samples, plus
    /// [`BIAS_VAR_FLOOR`]. `None` when the bias is not estimated from the window. The filters
    /// start their bias covariance from it.
    pub fn bias_variance(&self, noise: &crate::settings::NoiseSettings) -> Option<Vec3> {
        if !self.settings.estimate_gyro_bias
            || self.moving
            || self.s.gyro_n == 0
            || !(self.s.elapsed > 0.0)
        {
            return None;
        }
        let n = self.s.gyro_n as f32;
        let rate_hz = n / self.s.elapsed;
        let floor = Vec3::new(BIAS_VAR_FLOOR, BIAS_VAR_FLOOR, BIAS_VAR_FLOOR);
        Some(noise.gyro_var * (rate_hz / noise.gyro_ref_rate_hz.max(1e-3) / n) + floor)
    }

    /// Add one sample: `dt` s, the gyro (rad/s) when valid, the accelerometer (any unit, body
    /// FRD) when it passed the magnitude gate.
    pub fn push(&mut self, dt: f32, gyro: Option<Vec3>, accel: Option<Vec3>) -> InitStep {
        self.s.elapsed += dt;
        if let Some(g) = gyro {
            self.s.gyro_sum += g;
            self.s.gyro_sq += Vec3::new(g.x * g.x, g.y * g.y, g.z * g.z);
            self.s.gyro_n += 1;
        }
        if let Some(a) = accel {
            self.s.acc_sum += a;
            self.s.acc_sq += Vec3::new(a.x * a.x, a.y * a.y, a.z * a.z);
            self.s.acc_n += 1;
        }
        let q = if self.s.acc_n > 0 {
            attitude_from_accel(self.s.acc_sum, self.yaw)
        } else {
            Quaternion::from_yaw(self.yaw)
        };
        // Half a sample of tolerance: f32 sums of dt fall just short of the window (500 × 0.02
        // s = 9.9999 s), and the window must end on the sample nearest its length, not on the
        // next one, which may already be moving.
        if self.s.acc_n > 0 && self.is_moving() {
            self.level = Some(self.motion_level());
            let p = self.still_prefix;
            if p.elapsed >= MIN_STILL_PREFIX_S && p.acc_n > 0 && p.gyro_n > 0 {
                // Still before the motion began: the window ends there, a shorter still window
                // (its sums up to the checkpoint two before the last).
                self.s = p;
                return self.finish();
            }
            // Not still: start now, from the configured bias (the filter widens its covariance).
            self.moving = true;
            return InitStep::Done(q, self.settings.gyro_bias);
        }
        if self.s.elapsed - self.checkpoint.elapsed >= CHECKPOINT_S {
            self.still_prefix = self.previous;
            self.previous = self.checkpoint;
            self.checkpoint = self.s;
        }
        if self.s.elapsed >= self.settings.window_s - 0.5 * dt && self.s.acc_n > 0 {
            self.finish()
        } else {
            InitStep::Pending(q)
        }
    }

    /// The end of a still window: tilt from the mean accelerometer, bias from the mean gyro.
    fn finish(&self) -> InitStep {
        let q = attitude_from_accel(self.s.acc_sum, self.yaw);
        let bias = if self.settings.estimate_gyro_bias && self.s.gyro_n > 0 {
            self.s.gyro_sum * (1.0 / self.s.gyro_n as f32)
        } else {
            self.settings.gyro_bias
        };
        InitStep::Done(q, bias)
    }
}

/// Feed one checked sample to the window; only accelerometer samples that pass the gate's
/// magnitude, jump and hold-off checks enter the tilt average.
#[inline(never)] // the first seconds only: out of the update's hot code
pub fn feed(init: &mut Initializer, gate: &mut AccelGate, c: &Checked) -> InitStep {
    let a = c.accel_g.and_then(|(a, n)| match gate.pre_check(c.dt_rate, a, n, 0.0) {
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
        let s = settings(1.0);
        let mut init = Initializer::new(&s);
        init.set_yaw(deg(30.0));
        let truth = Euler::new(deg(5.0), deg(-3.0), deg(30.0)).to_quaternion();
        let f = truth.down_in_body() * -1.0;
        let bias = Vec3::new(0.01, -0.02, 0.003);
        let mut done = None;
        for k in 0..60 {
            // Alternating noise that averages out exactly over pairs.
            let n = if k % 2 == 0 { 0.01 } else { -0.01 };
            match init.push(
                0.02,
                Some(bias + Vec3::new(n, n, 0.05 * n)),
                Some(f + Vec3::new(n, -n, n) * 0.5),
            ) {
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
        assert!(!init.was_moving());
    }

    fn settings(window_s: f32) -> Settings {
        let mut s = Settings::default();
        s.init.window_s = window_s;
        s
    }

    /// Feed `rate(t)` (rad/s) and a level accelerometer at 50 Hz; the step that finished.
    fn run_window(init: &mut Initializer, rate: impl Fn(f32) -> Vec3) -> (usize, Vec3) {
        for k in 0..1000 {
            let t = k as f32 * 0.02;
            if let InitStep::Done(_, b) =
                init.push(0.02, Some(rate(t)), Some(Vec3::new(0.0, 0.0, -1.0)))
            {
                return (k, b);
            }
        }
        panic!("window never finished");
    }

    #[test]
    fn a_moving_window_ends_at_once_with_the_configured_bias() {
        let s = settings(10.0);
        let configured = s.init.gyro_bias;
        // A 15° pitch sine at 0.1 Hz: rate amplitude 9.4 °/s, far beyond the noise.
        let mut init = Initializer::new(&s);
        let (k, b) = run_window(&mut init, |t| {
            configured + Vec3::new(0.0, deg(9.42) * mathf::cos(0.628 * t), 0.0)
        });
        assert!(init.was_moving());
        assert_eq!(b, configured);
        // Judged after MIN_CHECK_SAMPLES, long before the 10 s window.
        assert!(k < 20, "{k}");
        assert!(init.bias_variance(&s.noise).is_none());
        // A steady 10 °/s turn has no spread, but no gyro is that far off its configured bias.
        let mut init = Initializer::new(&s);
        let (_, b) = run_window(&mut init, |_| configured + Vec3::new(0.0, 0.0, deg(10.0)));
        assert!(init.was_moving());
        assert_eq!(b, configured);
        // Still for 2 s, then the pitch sine: the window ends at the still part's last
        // checkpoint before the motion, a shorter still window, and its bias is measured.
        let mut init = Initializer::new(&s);
        let off = configured + Vec3::new(deg(0.5), deg(-0.3), deg(0.2));
        let (k, b) = run_window(&mut init, |t| {
            let pitch = if t < 2.0 { 0.0 } else { deg(9.42) * mathf::sin(0.628 * (t - 2.0)) };
            off + Vec3::new(0.0, pitch, 0.0)
        });
        assert!(!init.was_moving());
        // Seen at 2.8 s (the rate reaches the window's 3-standard-error test about 0.6 s in);
        // the window ends at 2.25 s or before, with at most the sine's first 0.25 s in it.
        assert!((120..160).contains(&k), "{k}");
        assert!(init.elapsed() <= 2.3, "{}", init.elapsed());
        assert!((b - off).max_abs() < deg(0.05), "{b:?}");
        assert!(init.bias_variance(&s.noise).is_some());
        // The same window still, with a bias 1 °/s off the configured one: averaged for 10 s.
        let mut init = Initializer::new(&s);
        let off = configured + Vec3::new(deg(1.0), 0.0, 0.0);
        let (k, b) = run_window(&mut init, |_| off);
        assert!(!init.was_moving());
        assert_eq!(k, 499);
        assert!((b - off).max_abs() < 1e-6);
    }

    #[test]
    fn waits_for_an_accelerometer_sample_and_uses_configured_bias_without_gyro() {
        let s = settings(0.1);
        let mut init = Initializer::new(&s);
        for _ in 0..10 {
            assert!(matches!(init.push(0.02, None, None), InitStep::Pending(_)));
        }
        match init.push(0.02, None, Some(Vec3::new(0.0, 0.0, -1.0))) {
            InitStep::Done(q, b) => {
                assert!(q.angle_to(Quaternion::IDENTITY) < 1e-6);
                assert_eq!(b, s.init.gyro_bias);
            }
            other => panic!("{other:?}"),
        }
    }
}
