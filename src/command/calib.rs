//! The calibration state machines: static gyro bias (`GBIAS`) and one accelerometer position
//! (`ACAL,<position>`). Both collect samples for a set time and check that the board was
//! still: a sample far from the running mean fails at once ("motion"), and at the end the
//! spread must be within the rest-detection thresholds of the settings.

use ekf_core::accel_calibration::Position;
use ekf_core::mathf;

use crate::settings::PipelineSettings;

/// Running mean and variance of three channels (Welford, `f32`: no `f64` soft-float on the
/// target; a mean over 10^5 samples keeps about 6 digits, far below the noise).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stats3 {
    n: u32,
    mean: [f32; 3],
    m2: [f32; 3],
}

impl Stats3 {
    /// Add one sample.
    pub fn push(&mut self, v: [f32; 3]) {
        self.n = self.n.saturating_add(1);
        let n = self.n as f32;
        for ((m, s), &x) in self.mean.iter_mut().zip(self.m2.iter_mut()).zip(v.iter()) {
            let d = x - *m;
            *m += d / n;
            *s += d * (x - *m);
        }
    }

    /// Number of samples.
    pub fn count(&self) -> u32 {
        self.n
    }

    /// Mean per channel.
    pub fn mean(&self) -> [f32; 3] {
        self.mean
    }

    /// Sample variance per channel (0 with fewer than two samples).
    pub fn variance(&self) -> [f32; 3] {
        let d = self.n.saturating_sub(1).max(1) as f32;
        self.m2.map(|s| if self.n > 1 { s / d } else { 0.0 })
    }

    /// True when `v` is more than `k` times `sigma[i]` from the mean on some channel (after
    /// at least 10 samples).
    fn outlier(&self, v: [f32; 3], sigma: [f32; 3], k: f32) -> bool {
        self.n >= 10
            && v.iter().zip(self.mean.iter()).zip(sigma.iter()).any(|((&x, &m), &s)| {
                let d = x - m;
                !(d.abs() <= k * s)
            })
    }

    /// True when every channel's standard deviation is within `sigma`.
    fn within(&self, sigma: [f32; 3]) -> bool {
        self.variance().iter().zip(sigma.iter()).all(|(&v, &s)| v <= s * s)
    }
}

/// How a calibration ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CalEnd {
    /// Still collecting.
    Running,
    /// Done: the mean (gyro: rad/s, body FRD; accelerometer: g, sensor axes).
    Done([f32; 3]),
    /// The board moved.
    Motion,
    /// No usable sample (sensor missing or saturated throughout).
    Sensor,
    /// The accelerometer mean does not point along the requested position.
    WrongPosition,
}

/// A sample further than this many allowed standard deviations from the mean is motion.
const OUTLIER_SIGMAS: f32 = 8.0;
/// Smallest allowed gyro standard deviation, rad/s (0.01 °/s), whatever the noise settings.
const GYRO_SIGMA_FLOOR: f32 = 0.01 * core::f32::consts::PI / 180.0;
/// Smallest allowed accelerometer standard deviation, g.
const ACCEL_SIGMA_FLOOR: f32 = 0.002;

/// Allowed gyro standard deviation per body axis, rad/s: `sqrt(rest.gyro_var_factor ·
/// noise.gyro_var · filter_rate / noise.gyro_ref_rate)`, at least 0.01 °/s.
pub fn gyro_sigma(s: &PipelineSettings) -> [f32; 3] {
    let n = &s.filter.noise;
    let rate_ratio = f32::from(s.filter_rate_hz.max(1)) / n.gyro_ref_rate_hz.max(1e-3);
    let factor = s.filter.rest.gyro_var_factor;
    n.gyro_var.to_array().map(|v| mathf::sqrt(factor * v * rate_ratio).max(GYRO_SIGMA_FLOOR))
}

/// Allowed accelerometer standard deviation per axis, g: `rest.accel_std_max`, at least
/// 0.002 g.
pub fn accel_sigma(s: &PipelineSettings) -> [f32; 3] {
    [s.filter.rest.accel_std_max_g.max(ACCEL_SIGMA_FLOOR); 3]
}

/// Static gyro-bias calibration: the mean body-frame gyro (axis map applied, offset not
/// subtracted) over `duration_s`, the board still.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroBiasCal {
    /// Collection time, s.
    pub duration_s: f32,
    elapsed_s: f32,
    gyro: Stats3,
    accel: Stats3,
}

impl GyroBiasCal {
    /// Start collecting for `duration_s`.
    pub fn new(duration_s: f32) -> Self {
        GyroBiasCal {
            duration_s,
            elapsed_s: 0.0,
            gyro: Stats3::default(),
            accel: Stats3::default(),
        }
    }

    /// One filter cycle: `gyro` in rad/s, body FRD, before the offset (`None` when missing
    /// or saturated), `accel_g` the accelerometer in g (any axes).
    pub fn push(
        &mut self,
        dt: f32,
        gyro: Option<[f32; 3]>,
        accel_g: Option<[f32; 3]>,
        s: &PipelineSettings,
    ) -> CalEnd {
        let (gs, as_) = (gyro_sigma(s), accel_sigma(s));
        let finite = |v: &[f32; 3]| v.iter().all(|x| x.is_finite());
        if let Some(g) = gyro.filter(finite) {
            if self.gyro.outlier(g, gs, OUTLIER_SIGMAS) {
                return CalEnd::Motion;
            }
            self.gyro.push(g);
        }
        if let Some(a) = accel_g.filter(finite) {
            if self.accel.outlier(a, as_, OUTLIER_SIGMAS) {
                return CalEnd::Motion;
            }
            self.accel.push(a);
        }
        let dt = if dt.is_finite() && dt > 0.0 { dt } else { 0.0 };
        self.elapsed_s += dt;
        // Done at the sample nearest to the duration (of two equally near, the earlier).
        if self.elapsed_s + 0.5 * dt < self.duration_s {
            return CalEnd::Running;
        }
        if self.gyro.count() < 10 {
            return CalEnd::Sensor;
        }
        if !self.gyro.within(gs) || !self.accel.within(as_) {
            return CalEnd::Motion;
        }
        CalEnd::Done(self.gyro.mean())
    }
}

/// One position of the six-position accelerometer calibration: the mean raw accelerometer
/// (g, sensor axes) over `duration_s`, the board still.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccelPositionCal {
    /// The position being measured.
    pub position: Position,
    /// Collection time, s.
    pub duration_s: f32,
    elapsed_s: f32,
    accel: Stats3,
}

impl AccelPositionCal {
    /// Start collecting `position` for `duration_s`.
    pub fn new(position: Position, duration_s: f32) -> Self {
        AccelPositionCal { position, duration_s, elapsed_s: 0.0, accel: Stats3::default() }
    }

    /// One filter cycle: `accel_g` the raw accelerometer, g, sensor axes.
    pub fn push(&mut self, dt: f32, accel_g: Option<[f32; 3]>, s: &PipelineSettings) -> CalEnd {
        let sigma = accel_sigma(s);
        if let Some(a) = accel_g.filter(|a| a.iter().all(|v| v.is_finite())) {
            if self.accel.outlier(a, sigma, OUTLIER_SIGMAS) {
                return CalEnd::Motion;
            }
            self.accel.push(a);
        }
        let dt = if dt.is_finite() && dt > 0.0 { dt } else { 0.0 };
        self.elapsed_s += dt;
        // Done at the sample nearest to the duration (of two equally near, the earlier).
        if self.elapsed_s + 0.5 * dt < self.duration_s {
            return CalEnd::Running;
        }
        if self.accel.count() < 10 {
            return CalEnd::Sensor;
        }
        if !self.accel.within(sigma) {
            return CalEnd::Motion;
        }
        let mean = self.accel.mean();
        if Position::classify(ekf_core::Vec3::from_array(mean)) != Some(self.position) {
            return CalEnd::WrongPosition;
        }
        CalEnd::Done(mean)
    }
}

/// Position names on the command line, in [`Position::ALL`] order.
pub const POSITION_NAMES: [&str; 6] = ["XUP", "XDOWN", "YUP", "YDOWN", "ZUP", "ZDOWN"];

/// The position called `name` (case-insensitive).
pub fn position_by_name(name: &str) -> Option<Position> {
    POSITION_NAMES
        .iter()
        .zip(Position::ALL.iter())
        .find(|(n, _)| n.eq_ignore_ascii_case(name))
        .map(|(_, p)| *p)
}

/// The command-line name of `p`.
pub fn position_name(p: Position) -> &'static str {
    POSITION_NAMES.get(p.index()).copied().unwrap_or("?")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `sqrt(rest.gyro_var_factor · noise.gyro_var · filter_rate / gyro_ref_rate)` by hand for
    /// the defaults (factor 6; 0.337, 0.275, 0.00419 (°/s)² at 50 Hz, filter at 50 Hz): 1.4220,
    /// 1.2845, 0.15856 °/s; at 100 Hz √2 times that; a tiny noise setting gives the 0.01 °/s
    /// floor.
    #[test]
    fn allowed_gyro_spread_by_hand() {
        let deg = core::f32::consts::PI / 180.0;
        let mut s = PipelineSettings::default();
        let close = |got: [f32; 3], want: [f32; 3]| {
            got.iter().zip(want).all(|(g, w)| (g / deg - w).abs() < 1e-4 * w.max(1.0))
        };
        assert!(close(gyro_sigma(&s), [1.4220, 1.2845, 0.15856]), "{:?}", gyro_sigma(&s));
        s.filter_rate_hz = 100;
        let r2 = core::f32::consts::SQRT_2;
        assert!(close(gyro_sigma(&s), [1.4220 * r2, 1.2845 * r2, 0.15856 * r2]));
        s.filter.noise.gyro_var = ekf_core::Vec3::new(1e-14, 1e-14, 1e-14);
        assert!(close(gyro_sigma(&s), [0.01; 3]), "{:?}", gyro_sigma(&s));
    }

    /// A collection ends at the sample nearest to its duration, and ten samples are enough:
    /// 0.5 s at 20 Hz is done at the tenth cycle, not before and not a sensor failure.
    #[test]
    fn ten_samples_are_enough_and_the_end_is_the_nearest_sample() {
        let s = PipelineSettings { filter_rate_hz: 20, ..PipelineSettings::default() };
        let mut cal = AccelPositionCal::new(Position::ZUp, 0.5);
        for k in 1..10 {
            assert_eq!(cal.push(0.05, Some([0.0, 0.0, 1.0]), &s), CalEnd::Running, "cycle {k}");
        }
        assert_eq!(cal.push(0.05, Some([0.0, 0.0, 1.0]), &s), CalEnd::Done([0.0, 0.0, 1.0]));
        let mut gyro = GyroBiasCal::new(1.0);
        let rate = Some([0.01, -0.02, 0.003]);
        for k in 1..20 {
            assert_eq!(gyro.push(0.05, rate, Some([0.0, 0.0, 1.0]), &s), CalEnd::Running, "{k}");
        }
        assert!(matches!(gyro.push(0.05, rate, Some([0.0, 0.0, 1.0]), &s), CalEnd::Done(_)));
    }

    /// The tie between two samples equally near the duration goes to the earlier one, and ten
    /// gyro samples are enough: with 1/64 s cycles (exact in binary) and 10.5/64 s, both
    /// collections end at the tenth cycle, the gyro's with its mean.
    #[test]
    fn a_tie_ends_at_the_earlier_sample_and_ten_gyro_samples_are_enough() {
        let s = PipelineSettings { filter_rate_hz: 64, ..PipelineSettings::default() };
        let (dt, up, rate) = (1.0 / 64.0, Some([0.0, 0.0, 1.0]), [0.01, -0.02, 0.003]);
        let mut cal = AccelPositionCal::new(Position::ZUp, 10.5 / 64.0);
        let mut gyro = GyroBiasCal::new(10.5 / 64.0);
        for k in 1..10 {
            assert_eq!(cal.push(dt, up, &s), CalEnd::Running, "cycle {k}");
            assert_eq!(gyro.push(dt, Some(rate), up, &s), CalEnd::Running, "cycle {k}");
        }
        assert_eq!(cal.push(dt, up, &s), CalEnd::Done([0.0, 0.0, 1.0]));
        assert_eq!(gyro.push(dt, Some(rate), up, &s), CalEnd::Done(rate));
    }

    /// A cycle time that is not a positive number adds no time: with one before every valid
    /// cycle, 0.5 s at 20 Hz still ends at the tenth valid cycle.
    #[test]
    fn a_bad_cycle_time_adds_no_time() {
        let s = PipelineSettings { filter_rate_hz: 20, ..PipelineSettings::default() };
        let up = Some([0.0, 0.0, 1.0]);
        for bad in [-0.05, f32::NAN, f32::INFINITY, -f32::INFINITY] {
            let mut cal = AccelPositionCal::new(Position::ZUp, 0.5);
            let mut gyro = GyroBiasCal::new(1.0);
            for k in 1..=20 {
                assert_eq!(gyro.push(bad, Some([0.0; 3]), up, &s), CalEnd::Running, "{bad}");
                if k <= 10 {
                    assert_eq!(cal.push(bad, up, &s), CalEnd::Running, "{bad} before {k}");
                    let end = cal.push(0.05, up, &s);
                    let want = if k < 10 { CalEnd::Running } else { CalEnd::Done([0.0, 0.0, 1.0]) };
                    assert_eq!(end, want, "{bad}: cycle {k}");
                }
                let end = gyro.push(0.05, Some([0.0; 3]), up, &s);
                assert_eq!(end == CalEnd::Running, k < 20, "{bad}: gyro cycle {k}: {end:?}");
            }
        }
    }
}
