//! The initialisation window: tilt from the averaged accelerometer, yaw given, gyro bias from
//! the averaged gyro — as on the board, where the first 10 s after power-up set the initial
//! quaternion.

use crate::{
    gate::{AccelGate, PreCheck},
    mathf,
    rest::{SEGMENTS, Z},
    settings::{still_bias_floor, InitSettings, Settings},
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
/// Segments before their spread is judged.
pub const MIN_SPREAD_SEGMENTS: u32 = 4;
/// A window found moving still gives its bias and tilt when it had been still for this many
/// segments before (up to the checkpoint two before the last: motion that begins slowly is seen
/// up to two segments late): 0.5 s with the default segments. A recording that starts with
/// half a second still keeps its bias (RepoIMU's pendulum: 14.97° of heading, against 45.5°
/// when the part must be as long as the spread test's [`MIN_SPREAD_SEGMENTS`]).
pub const MIN_STILL_PREFIX_SEGMENTS: u32 = 2;
/// The samples' measured variance is taken as at least this fraction of the configured noise
/// (a quantised gyro can read the same value for a while): 0.01, so that a noise setting 10×
/// too high or too low changes no decision.
pub const WINDOW_NOISE_FLOOR: f32 = 0.01;
/// Largest accelerometer standard deviation per axis of a still window, as a multiple of
/// `rest.accel_std_max_g` (0.01 g): 0.05 g. Vibration of a few hundredths of g (a pump, a
/// thruster at idle) averages out of the tilt and does not touch the gyro bias; a 15° pitch
/// sine spreads the accelerometer by 0.18 g.
pub const WINDOW_ACCEL_STD_FACTOR: f32 = 5.0;

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
    /// `ekf.bias_random_walk`, (rad/s)²/s ([`still_bias_floor`]).
    bias_random_walk: f32,
    yaw: f32,
    /// The sums over the window so far.
    s: Sums,
    /// Smallest per-sample gyro variance assumed at the reference rate, (rad/s)².
    gyro_var_floor: Vec3,
    /// Reference rate of `gyro_var_floor`, Hz.
    gyro_ref_rate_hz: f32,
    /// `ekf.initial_bias_sigma²`, (rad/s)²: the rate differences a still window tolerates.
    bias_tol_sq: f32,
    /// The segments' length, s: the rest detector's (`rest.block` over [`SEGMENTS`], 0.25 s).
    segment_s: f32,
    /// Completed segments: their number, and Σ and Σ² of their mean rates.
    segments: u32,
    seg_sum: Vec3,
    seg_sq: Vec3,
    /// Largest accelerometer variance per axis of a still window, g².
    accel_var_max: f32,
    /// Largest spread (variance) of the segment mean rates per axis, as a multiple of what the
    /// samples' own variance gives a segment mean (σ²/n): the rest detector's
    /// `rest.gyro_var_factor` (6), plus `ekf.initial_bias_sigma²` (segment means that agree
    /// within it give a bias as good as the filter assumes). The test needs no noise setting:
    /// noise and vibration, whatever their level, spread the segment means by σ²/n (χ²₃/3
    /// after four segments, beyond 6 with probability 4.4·10⁻⁴ per axis, 1.5·10⁻⁵ after six),
    /// while the slow motion that corrupts a window's mean moves them together (a 15° pitch
    /// sine at 0.1 Hz: by several °/s). Steady turns have no spread: the mean test catches
    /// them.
    spread_factor: f32,
    moving: bool,
    /// The sums at the last still checkpoint (segment end), and at the two before it.
    checkpoint: Sums,
    /// Checkpoints passed.
    checkpoints: u32,
    previous: Sums,
    still_prefix: Sums,
    /// The accelerometer variance of the whole window when it ended (g², summed over axes).
    level: Option<f32>,
}

impl Initializer {
    /// A new window with the settings' initial yaw. A window is still when, per axis, its
    /// segment mean rates spread by no more than `rest.gyro_var_factor` times what the samples'
    /// own variance gives them (plus `ekf.initial_bias_sigma²`), the accelerometer's standard
    /// deviation is within [`WINDOW_ACCEL_STD_FACTOR`] × `rest.accel_std_max_g`, the mean gyro
    /// within [`Z`] (3) `moving_bias_sigma` of `gyro_bias`, and the samples since the last
    /// checkpoint agree with those before it (within [`Z`] standard errors plus
    /// `ekf.initial_bias_sigma`: the rest detector's significance). No test depends on the
    /// configured gyro noise (beyond a floor).
    pub fn new(s: &Settings) -> Self {
        Initializer {
            settings: s.init,
            bias_random_walk: s.ekf.bias_random_walk,
            yaw: s.init.initial_yaw,
            s: Sums::default(),
            gyro_var_floor: s.noise.gyro_var * WINDOW_NOISE_FLOOR,
            gyro_ref_rate_hz: s.noise.gyro_ref_rate_hz.max(1e-3),
            accel_var_max: {
                let a = s.rest.accel_std_max_g * WINDOW_ACCEL_STD_FACTOR;
                a * a
            },
            bias_tol_sq: s.ekf.initial_bias_sigma * s.ekf.initial_bias_sigma,
            segment_s: s.rest.block_s * (1.0 / SEGMENTS as f32),
            segments: 0,
            spread_factor: s.rest.gyro_var_factor,
            seg_sum: Vec3::ZERO,
            seg_sq: Vec3::ZERO,
            moving: false,
            checkpoint: Sums::default(),
            checkpoints: 0,
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
        let floor = (self.gyro_var_floor * (rate / self.gyro_ref_rate_hz)).to_array();
        let configured = self.settings.gyro_bias.to_array();
        let off_max = Z * self.settings.moving_bias_sigma;
        let (mean, _) = self.s.gyro();
        for (m, c) in mean.iter().zip(configured) {
            if !(mathf::abs(m - c) <= off_max) {
                return true;
            }
        }
        if self.s.acc_n >= MIN_CHECK_SAMPLES
            && self.s.accel().1.iter().any(|v| !(*v <= self.accel_var_max))
        {
            return true;
        }
        // The segment means against the samples' own scatter (the samples up to the last
        // checkpoint, which the segments cover).
        let cp = self.checkpoint;
        let (_, cp_var) = cp.gyro();
        if self.segments >= MIN_SPREAD_SEGMENTS {
            let k = self.segments as f32;
            let n_seg = cp.gyro_n as f32 / k;
            let (sum, sq) = (self.seg_sum.to_array(), self.seg_sq.to_array());
            for (((s1, s2), v), f) in sum.iter().zip(sq).zip(cp_var).zip(floor) {
                let spread = (s2 - s1 * s1 / k) / (k - 1.0);
                if !(spread <= self.spread_factor * v.max(f) / n_seg + self.bias_tol_sq) {
                    return true;
                }
            }
        }
        // Motion that begins after a still part: the samples since the last checkpoint against
        // those before it — a mean rate Z (3) standard errors away, and far enough to move the
        // window's mean by more than the tolerance (`d·n_seg/n` beyond `initial_bias_sigma`).
        let seg = self.s.since(&cp);
        if cp.gyro_n >= MIN_CHECK_SAMPLES && seg.gyro_n >= MIN_CHECK_SAMPLES {
            let (seg_mean, _) = seg.gyro();
            let (cp_mean, _) = cp.gyro();
            let k = 1.0 / seg.gyro_n as f32 + 1.0 / cp.gyro_n as f32;
            let share = self.s.gyro_n as f32 / seg.gyro_n as f32;
            let tol_sq = self.bias_tol_sq * share * share;
            for (((sm, cm), v), f) in seg_mean.iter().zip(cp_mean).zip(cp_var).zip(floor) {
                let d = sm - cm;
                if !(d * d <= Z * Z * v.max(f) * k + tol_sq) {
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
    /// what the average measures besides the bias, Earth's rate and the bias's walk over the
    /// window ([`still_bias_floor`]). `None` when the bias is not estimated from the
    /// window. The filters start their bias covariance from it.
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
        let f = still_bias_floor(self.bias_random_walk, self.s.elapsed);
        let floor = Vec3::new(f, f, f);
        Some(noise.gyro_var * (rate_hz / noise.gyro_ref_rate_hz.max(1e-3) / n) + floor)
    }

    /// The variance of the window's tilt (rad², per axis) when it was still: the
    /// accelerometer's per-sample variance (g² ≈ rad² of direction) over the number of samples
    /// averaged; `None` after a start in motion or with no accelerometer sample.
    pub fn tilt_variance(&self, noise: &crate::settings::NoiseSettings) -> Option<f32> {
        if self.moving || self.s.acc_n == 0 || !(self.s.elapsed > 0.0) {
            return None;
        }
        let n = self.s.acc_n as f32;
        Some(noise.accel_var_per_sample(self.s.elapsed / n) / n)
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
            if self.checkpoints >= MIN_STILL_PREFIX_SEGMENTS + 2 && p.acc_n > 0 && p.gyro_n > 0 {
                // Still before the motion began: the window ends there, a shorter still window
                // (its sums up to the checkpoint two before the last).
                self.s = p;
                return self.finish();
            }
            // Not still: start now, from the configured bias (the filter widens its covariance).
            self.moving = true;
            return InitStep::Done(q, self.settings.gyro_bias);
        }
        if self.s.elapsed - self.checkpoint.elapsed >= self.segment_s {
            let seg = self.s.since(&self.checkpoint);
            if seg.gyro_n > 0 {
                let m = Vec3::from_array(seg.gyro().0);
                self.seg_sum += m;
                self.seg_sq += Vec3::new(m.x * m.x, m.y * m.y, m.z * m.z);
                self.segments += 1;
            }
            self.still_prefix = self.previous;
            self.previous = self.checkpoint;
            self.checkpoint = self.s;
            self.checkpoints += 1;
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
        // Seen about 0.35 s in, when the sine's segment mean would move the window's mean by
        // `initial_bias_sigma` (noise-free, the samples have no scatter). The window ends at
        // 2.25 s or before, with at most the sine's first 0.25 s in it.
        assert!((110..125).contains(&k), "{k}");
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

    /// The window's segment means may spread by `rest.gyro_var_factor` times what the samples'
    /// own scatter gives them, as the rest detector's: a still window with white gyro noise
    /// (σ = 0.05 rad/s, segment means scattering by σ²/12.5) takes its whole 10 s under the
    /// default limit (6), for 5 seeds; under a limit of 0.5 the spread that the noise alone
    /// gives the segment means exceeds it, and the window ends within its first seconds.
    #[test]
    fn the_window_spread_limit_is_the_rest_detectors() {
        let run = |factor: f32, seed: u64| {
            let mut s = settings(10.0);
            s.rest.gyro_var_factor = factor;
            let c = s.init.gyro_bias;
            let mut init = Initializer::new(&s);
            let mut rng = crate::test_rng::TestRng::new(seed);
            for k in 0..1000 {
                let w = c + Vec3::new(rng.normal(), rng.normal(), rng.normal()) * 0.05;
                if let InitStep::Done(..) =
                    init.push(0.02, Some(w), Some(Vec3::new(0.0, 0.0, -1.0)))
                {
                    return k;
                }
            }
            panic!("never finished");
        };
        for seed in 1..=5 {
            assert_eq!(run(6.0, seed), 499, "seed {seed}");
            assert!(run(0.5, seed) < 200, "seed {seed}: {}", run(0.5, seed));
        }
    }

    /// The window's bias variance: the noise's over the samples plus Earth's rate and the
    /// bias's walk between the window's mean and its end. Hand-derived with the defaults
    /// (walk (0.002 °/s)²/s = 1.2185e−9 rad²/s³): Ω² = (7.292115e−5)² = 5.3175e−9 and
    /// 1.2185e−9·10/3 = 4.0617e−9, 9.3792e−9 (rad/s)² (0.00555 °/s) after 10 s; with a noise-free
    /// gyro that is all of it. With the noise the board's: 0.337 (°/s)² at 50 Hz over 500
    /// samples more on x.
    #[test]
    fn the_window_bias_variance_has_earth_rate_and_the_walk_as_its_floor() {
        let mut s = settings(10.0);
        s.noise.gyro_var = Vec3::ZERO;
        let mut init = Initializer::new(&s);
        let still = s.init.gyro_bias + Vec3::new(deg(0.1), 0.0, 0.0);
        let (k, _) = run_window(&mut init, |_| still);
        assert_eq!(k, 499);
        let v = init.bias_variance(&s.noise).unwrap();
        for v in v.to_array() {
            assert!((v / 9.3792e-9 - 1.0).abs() < 1e-3, "{v}");
        }
        let noise = Settings::default().noise;
        let x = init.bias_variance(&noise).unwrap().x;
        assert!((x - 9.3792e-9 - 0.337 * deg(1.0) * deg(1.0) / 500.0).abs() < 1e-9, "{x}");
        // A rest block of 2 s: 5.3175e−9 + 0.8123e−9.
        assert!((still_bias_floor(s.ekf.bias_random_walk, 2.0) / 6.1298e-9 - 1.0).abs() < 1e-3);
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
