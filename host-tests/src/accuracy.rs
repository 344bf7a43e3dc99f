//! Accuracy evaluation shared by the benchmark (`cargo bench -p host-tests --bench accuracy`)
//! and the regression tests (`tests/accuracy.rs`): simulate a scenario, replay it through a
//! filter with [`crate::replay::replay_rows`] (the CLI's replay loop: conditioning, `dt`, RMSE),
//! and measure the yaw drift; the source's Table 16 and the goals for the EKF.
//!
//! Metrics (degrees):
//! - **RMSE** per axis as in [`crate::replay`]: rows with `t ≥ t₀ + init.window_s`, wrapped
//!   Z-Y-X Euler error `estimate − truth`;
//! - **yaw error** `e(t)`: the wrapped yaw error, unwrapped along the run (so a filter that
//!   drifts past 180° keeps counting);
//! - **yaw drift**, °/h: slope of the least-squares line through `e(t)` over the rows after the
//!   initialisation window;
//! - **final yaw error**: `e` at the last row;
//! - **tilt RMSE**: RMSE of the inclination error of [`crate::real::errors`] (the angle of
//!   `q_est ⊗ q_true*` about horizontal axes, whatever the heading) over the rows with
//!   `t ≥ t₀ + `[`tilt_start_s`] (30 s for `start-moving`, which has no still start; the end of
//!   the still start or the initialisation window, whichever is later, otherwise).
//!
//! The source's single number for the pitch manoeuvres (scenarios 1, 3, 4, 6) is taken as the
//! pitch RMSE and for the yaw sinusoid (5) as the yaw RMSE; scenario 2 gives all three axes.

use ekf_core::conditioning::Conditioner;

use crate::config::ReplayConfig;
use crate::real::errors;
use crate::replay::{replay_rows, truth_euler_deg, wrap_deg, FilterKind};
use crate::sim::{Scenario, SimOptions, STILL_S};
use crate::trace::TraceRow;

/// Sample rate of every evaluation, Hz (the source's).
pub const RATE_HZ: f64 = 50.0;

/// The scenarios of the source's Table 16, in its order (1–6).
pub const TABLE16_SCENARIOS: [Scenario; 6] = [
    Scenario::PitchSine,
    Scenario::Coupled,
    Scenario::PitchStep,
    Scenario::PitchRamp,
    Scenario::YawSine,
    Scenario::Surge,
];

/// The hour-long scenarios.
pub const HOUR_SCENARIOS: [Scenario; 3] =
    [Scenario::StillHour, Scenario::RampHour, Scenario::BiasOff];

/// The robustness scenarios: motions outside the source's set (all attitudes, a side-mounted
/// board, no still start, a pendulum rig), scored by their tilt RMSE ([`ROBUST_GOALS`]).
pub const ROBUST_SCENARIOS: [Scenario; 4] =
    [Scenario::Tumble, Scenario::SideMount, Scenario::StartMoving, Scenario::Pendulum];

/// Seconds after the first row from which the tilt RMSE of `scenario` is taken: 30 s for
/// `start-moving` (no still start: the filter initialises while moving), else the end of the
/// still start or of the initialisation window of `cfg`, whichever is later.
pub fn tilt_start_s(scenario: Scenario, cfg: &ReplayConfig) -> f64 {
    match scenario {
        Scenario::StartMoving => 30.0,
        _ => STILL_S.max(cfg.settings.init.window_s as f64),
    }
}

/// The source's scenario number (1–6), if any.
pub fn scenario_number(s: Scenario) -> Option<usize> {
    TABLE16_SCENARIOS.iter().position(|&x| x == s).map(|i| i + 1)
}

/// Euler axis index: roll 0, pitch 1, yaw 2.
pub const AXIS_NAMES: [&str; 3] = ["roll", "pitch", "yaw"];

/// The axis the source's single RMSE of a scenario refers to (pitch for the pitch
/// manoeuvres, yaw for the yaw sinusoid); `None` for scenario 2 (all three given) and for
/// scenarios the source has no number for.
pub fn source_axis(s: Scenario) -> Option<usize> {
    match scenario_number(s)? {
        5 => Some(2),
        2 => None,
        _ => Some(1),
    }
}

/// The source's Table 16 RMSE, degrees, of `filter` on `scenario` for `axis`, when it gives
/// one (no numbers for the gyro-only filter nor for the extra scenarios).
pub fn source_rmse(filter: FilterKind, scenario: Scenario, axis: usize) -> Option<f64> {
    // Columns: 1, 2 roll, 2 pitch, 2 yaw, 3, 4, 5, 6.
    let row: [f64; 8] = match filter {
        FilterKind::Ekf => [0.4160, 0.0897, 0.1440, 0.2602, 0.2108, 0.0494, 0.4506, 2.6165],
        FilterKind::Ukf => [0.4000, 0.0796, 0.1319, 0.2608, 0.1468, 0.0378, 0.4523, 2.6120],
        FilterKind::SsUkf => [0.4171, 0.0952, 0.1472, 1.9138, 0.2153, 0.0581, 0.6426, 2.6576],
        FilterKind::Cf => [0.9655, 2.2301, 0.4016, 0.8138, 0.4572, 0.9442, 0.4488, 2.6167],
        FilterKind::Gyro => return None,
    };
    let n = scenario_number(scenario)?;
    if n == 2 {
        return Some(row[1 + axis]);
    }
    if source_axis(scenario) != Some(axis) {
        return None;
    }
    Some(
        row[match n {
            1 => 0,
            3 => 4,
            4 => 5,
            5 => 6,
            _ => 7,
        }],
    )
}

/// The source's MATLAB time per cycle (Table 15, relative units), when it gives one.
pub fn source_time_per_cycle(filter: FilterKind) -> Option<f64> {
    match filter {
        FilterKind::Ekf => Some(62.0),
        FilterKind::Ukf => Some(283.0),
        FilterKind::SsUkf => Some(176.0),
        FilterKind::Cf => Some(24.8),
        FilterKind::Gyro => None,
    }
}

/// What a goal measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    /// RMSE of one Euler axis (0 roll, 1 pitch, 2 yaw), degrees.
    Rmse(usize),
    /// |yaw drift|, °/h (least-squares slope).
    DriftDph,
    /// |final yaw error|, degrees.
    FinalYaw,
    /// Tilt (inclination) RMSE once converged, degrees ([`RunResult::tilt_rmse_deg`]).
    TiltRmse,
}

impl Metric {
    /// Value of this metric for a run (absolute values for the drift and final error).
    pub fn of(self, r: &RunResult) -> f64 {
        match self {
            Metric::Rmse(a) => r.rmse_deg[a],
            Metric::DriftDph => r.yaw_drift_dph.abs(),
            Metric::FinalYaw => r.final_yaw_err_deg.abs(),
            Metric::TiltRmse => r.tilt_rmse_deg,
        }
    }

    /// Short description with unit.
    pub fn describe(self) -> String {
        match self {
            Metric::Rmse(a) => format!("{} RMSE (°)", AXIS_NAMES[a]),
            Metric::DriftDph => "yaw drift, absolute (°/h)".into(),
            Metric::FinalYaw => "final yaw error, absolute (°)".into(),
            Metric::TiltRmse => "tilt RMSE once converged (°)".into(),
        }
    }
}

/// A goal for [`crate::replay::FilterKind::Ekf`] with default settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Goal {
    /// Label, e.g. `"2 roll"`.
    pub label: &'static str,
    /// Scenario.
    pub scenario: Scenario,
    /// Metric.
    pub metric: Metric,
    /// Threshold: the goal is met when the measured value is ≤ this.
    pub max: f64,
}

/// The goals for the EKF with default settings.
pub const GOALS: [Goal; 13] = [
    Goal { label: "1 (pitch)", scenario: Scenario::PitchSine, metric: Metric::Rmse(1), max: 0.05 },
    Goal { label: "2 roll", scenario: Scenario::Coupled, metric: Metric::Rmse(0), max: 0.05 },
    Goal { label: "2 pitch", scenario: Scenario::Coupled, metric: Metric::Rmse(1), max: 0.05 },
    Goal { label: "2 yaw", scenario: Scenario::Coupled, metric: Metric::Rmse(2), max: 0.15 },
    Goal { label: "3 (pitch)", scenario: Scenario::PitchStep, metric: Metric::Rmse(1), max: 0.15 },
    Goal { label: "4 (pitch)", scenario: Scenario::PitchRamp, metric: Metric::Rmse(1), max: 0.035 },
    Goal { label: "5 yaw", scenario: Scenario::YawSine, metric: Metric::Rmse(2), max: 0.20 },
    Goal { label: "5 roll", scenario: Scenario::YawSine, metric: Metric::Rmse(0), max: 0.08 },
    Goal { label: "5 pitch", scenario: Scenario::YawSine, metric: Metric::Rmse(1), max: 0.08 },
    Goal { label: "6 (pitch)", scenario: Scenario::Surge, metric: Metric::Rmse(1), max: 2.6 },
    Goal {
        label: "still hour, bias right",
        scenario: Scenario::StillHour,
        metric: Metric::DriftDph,
        max: 0.5,
    },
    Goal {
        label: "still hour, z bias off 0.05 °/s",
        scenario: Scenario::BiasOff,
        metric: Metric::FinalYaw,
        max: 1.0,
    },
    // The "bias right" goal read as the final error too: at most the drift goal's
    // hour.
    Goal {
        label: "still hour, bias right (final)",
        scenario: Scenario::StillHour,
        metric: Metric::FinalYaw,
        max: 0.5,
    },
];

/// The robustness goals for the EKF with default settings: tilt RMSE ≤ 0.5° once converged
/// ([`tilt_start_s`]) on every [`ROBUST_SCENARIOS`] scenario.
pub const ROBUST_GOALS: [Goal; 4] = [
    Goal { label: "tumble tilt", scenario: Scenario::Tumble, metric: Metric::TiltRmse, max: 0.5 },
    Goal {
        label: "side-mount tilt",
        scenario: Scenario::SideMount,
        metric: Metric::TiltRmse,
        max: 0.5,
    },
    Goal {
        label: "start-moving tilt",
        scenario: Scenario::StartMoving,
        metric: Metric::TiltRmse,
        max: 0.5,
    },
    Goal {
        label: "pendulum tilt",
        scenario: Scenario::Pendulum,
        metric: Metric::TiltRmse,
        max: 0.5,
    },
];

/// The replay settings of a scenario: the defaults, except that
/// - `bias-off` is replayed without estimating the gyro bias in the initialisation window
///   (`replay --no-init-bias`), so the filter starts with its configured, now 0.05 °/s wrong,
///   z bias;
/// - `side-mount` gets the Seahog's lever arm in the side-mounted sensor's axes (the mounting
///   is known; the filter still sees the board's own attitude, roll ≈ 90°);
/// - `pendulum` has no lever arm (a foreign test rig: nothing configured for it, as for the
///   recorded pendulum data of [`crate::real::RepoImu::config`]);
/// - `tumble` has the lever arm's tangential term on (up to 0.04 g of ω̇ × r at 90 °/s).
pub fn replay_config(scenario: Scenario) -> ReplayConfig {
    let mut cfg = ReplayConfig::default();
    match scenario {
        Scenario::BiasOff => cfg.settings.init.estimate_gyro_bias = false,
        Scenario::SideMount => {
            let r = scenario.sensors().lever_arm;
            cfg.conditioning.lever_arm.r =
                ekf_core::Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32);
        }
        Scenario::Pendulum => cfg.conditioning.lever_arm = ekf_core::lever_arm::LeverArm::NONE,
        // Tumbling at up to 90 °/s, the Seahog's 0.36 m lever arm sees up to 0.04 g of
        // tangential acceleration ω̇ × r: a vehicle that moves like this is configured with the
        // tangential term on (`lever_arm.tangential`).
        Scenario::Tumble => cfg.conditioning.lever_arm.tangential = true,
        _ => {}
    }
    cfg
}

/// Simulate `scenario` at [`RATE_HZ`] for `duration_s` (its default when `None`) with `seed`.
pub fn simulate(scenario: Scenario, duration_s: Option<f64>, seed: u64) -> Vec<TraceRow> {
    let (sim, _) = scenario.simulator(RATE_HZ, duration_s, seed, false);
    sim.map(|s| s.row).collect()
}

/// Simulate `scenario` with `opts` (e.g. `realistic: true` for the realistic sensor errors).
pub fn simulate_with(scenario: Scenario, opts: &SimOptions) -> Vec<TraceRow> {
    let (sim, _) = scenario.simulator_with(opts);
    sim.map(|s| s.row).collect()
}

/// The measurements of one replay.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunResult {
    /// RMSE per axis (roll, pitch, yaw), degrees.
    pub rmse_deg: [f64; 3],
    /// Least-squares slope of the (unwrapped) yaw error after the window, °/h.
    pub yaw_drift_dph: f64,
    /// Unwrapped yaw error at the last row, degrees.
    pub final_yaw_err_deg: f64,
    /// Largest |yaw error| after the window, degrees.
    pub max_yaw_err_deg: f64,
    /// Tilt (inclination) RMSE over the rows from the tilt start on, degrees (NaN with no
    /// such row).
    pub tilt_rmse_deg: f64,
    /// Rows replayed.
    pub rows: u64,
}

/// Least-squares line through `(t, e)`, accumulated.
#[derive(Clone, Copy, Debug, Default)]
struct LineFit {
    n: f64,
    st: f64,
    se: f64,
    stt: f64,
    ste: f64,
}

impl LineFit {
    fn add(&mut self, t: f64, e: f64) {
        self.n += 1.0;
        self.st += t;
        self.se += e;
        self.stt += t * t;
        self.ste += t * e;
    }

    fn slope(&self) -> f64 {
        let d = self.n * self.stt - self.st * self.st;
        if self.n < 2.0 || d <= 0.0 {
            return 0.0;
        }
        (self.n * self.ste - self.st * self.se) / d
    }
}

/// Tilt (inclination) error RMSE over the rows at or after a start time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltRmse {
    /// First time scored, s.
    pub from_t: f64,
    sum_sq: f64,
    n: u64,
}

impl TiltRmse {
    /// Score rows with `t ≥ from_t`.
    pub fn new(from_t: f64) -> Self {
        TiltRmse { from_t, sum_sq: 0.0, n: 0 }
    }

    /// Add a row: estimate and truth (body → NED, any sign and norm).
    pub fn add(&mut self, t: f64, est: [f64; 4], truth: [f64; 4]) {
        if t >= self.from_t {
            let (incl, _) = errors(est, truth);
            self.sum_sq += incl * incl;
            self.n += 1;
        }
    }

    /// Rows scored.
    pub fn count(&self) -> u64 {
        self.n
    }

    /// RMSE, degrees; NaN with no row.
    pub fn rmse_deg(&self) -> f64 {
        if self.n == 0 {
            return f64::NAN;
        }
        (self.sum_sq / self.n as f64).sqrt().to_degrees()
    }
}

/// Replay `rows` (with truth) through a new `filter` configured by `cfg`, using the CLI's
/// replay loop, and measure it; the tilt RMSE from the end of the initialisation window (use
/// [`evaluate_from`] with [`tilt_start_s`] for a scenario's own start).
pub fn evaluate(rows: &[TraceRow], filter: FilterKind, cfg: &ReplayConfig) -> RunResult {
    evaluate_from(rows, filter, cfg, cfg.settings.init.window_s as f64)
}

/// [`evaluate`] with the tilt RMSE over the rows with `t ≥ t₀ + tilt_from_s`.
pub fn evaluate_from(
    rows: &[TraceRow],
    filter: FilterKind,
    cfg: &ReplayConfig,
    tilt_from_s: f64,
) -> RunResult {
    let mut f = cfg.make_filter(filter);
    let mut cond = Conditioner::new(cfg.conditioning);
    let window = cfg.settings.init.window_s as f64;
    let t0 = rows.first().map_or(0.0, |r| r.t);
    let mut fit = LineFit::default();
    let mut unwrapped: Option<f64> = None;
    let mut max_err = 0.0f64;
    let mut tilt = TiltRmse::new(t0 + tilt_from_s);
    let stats =
        replay_rows(rows.iter().map(|r| Ok(*r)), f.as_mut(), &mut cond, window, |row, est| {
            if let Some(tq) = row.truth {
                tilt.add(row.t, est.q.map(f64::from), tq.map(f64::from));
                if row.t >= t0 + window {
                    let e = wrap_deg(est.euler_deg[2] as f64 - truth_euler_deg(tq)[2]);
                    let u = match unwrapped {
                        Some(p) => p + wrap_deg(e - p),
                        None => e,
                    };
                    unwrapped = Some(u);
                    max_err = max_err.max(u.abs());
                    fit.add(row.t - t0, u);
                }
            }
            Ok(())
        })
        .expect("in-memory replay cannot fail");
    RunResult {
        rmse_deg: stats.rmse.rmse().unwrap_or([f64::NAN; 3]),
        yaw_drift_dph: fit.slope() * 3600.0,
        final_yaw_err_deg: unwrapped.unwrap_or(f64::NAN),
        max_yaw_err_deg: max_err,
        tilt_rmse_deg: tilt.rmse_deg(),
        rows: stats.rows,
    }
}

/// Simulate `scenario` with `seed` (default duration) and evaluate `filter` on it with the
/// scenario's [`replay_config`] and [`tilt_start_s`].
pub fn run(scenario: Scenario, seed: u64, filter: FilterKind) -> RunResult {
    run_with(scenario, &SimOptions { rate_hz: RATE_HZ, seed, ..SimOptions::default() }, filter)
}

/// [`run`] with the simulation options `opts` (e.g. `realistic: true`).
pub fn run_with(scenario: Scenario, opts: &SimOptions, filter: FilterKind) -> RunResult {
    let rows = simulate_with(scenario, opts);
    let cfg = replay_config(scenario);
    evaluate_from(&rows, filter, &cfg, tilt_start_s(scenario, &cfg))
}

/// CPU time of the calling thread, s (`clock_gettime(CLOCK_THREAD_CPUTIME_ID)` through the
/// `cpu-time` crate, nanoseconds),
/// so that other processes competing for the cores do not count in a timing; `None` where
/// unavailable (callers then use wall time).
///
/// Not `/proc/thread-self/schedstat`: for a thread that is running, Linux brings that figure up
/// to date only at scheduler ticks, so it lags by up to a tick (4 ms at 250 Hz) and a best-of
/// of short runs reads low. The clock adds the time since the last tick.
#[cfg(unix)]
pub fn thread_cpu_s() -> Option<f64> {
    cpu_time::ThreadTime::try_now().ok().map(|t| t.as_duration().as_secs_f64())
}

/// CPU time of the calling thread: not available here (callers use wall time).
#[cfg(not(unix))]
pub fn thread_cpu_s() -> Option<f64> {
    None
}

/// Replace the text between the lines `<!-- BEGIN name -->` and `<!-- END name -->` of `doc`
/// (markers kept) by `content`. `None` when the markers are missing or out of order.
pub fn replace_section(doc: &str, name: &str, content: &str) -> Option<String> {
    let begin = format!("<!-- BEGIN {name} -->");
    let end = format!("<!-- END {name} -->");
    let b = doc.find(&begin)?;
    let after_begin = b + begin.len();
    let e = after_begin + doc[after_begin..].find(&end)?;
    let mut out = String::with_capacity(doc.len() + content.len());
    out.push_str(&doc[..after_begin]);
    out.push('\n');
    out.push_str(content.trim_end());
    out.push('\n');
    out.push_str(&doc[e..]);
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The thread CPU clock must advance in small steps, not at scheduler ticks (what
    /// `/proc/thread-self/schedstat` does for a running thread: steps of about 4 ms).
    #[cfg(unix)]
    #[test]
    fn thread_cpu_clock_is_finer_than_a_tick() {
        let a = thread_cpu_s().expect("thread CPU clock");
        let mut b = a;
        let mut spins = 0u64;
        while b == a {
            b = thread_cpu_s().expect("thread CPU clock");
            spins += 1;
            assert!(spins < 100_000_000, "thread CPU clock does not advance");
        }
        assert!(b > a);
        assert!(b - a < 5e-4, "step of {} s", b - a);
    }

    #[test]
    fn line_fit_slope() {
        let mut f = LineFit::default();
        for k in 0..100 {
            let t = k as f64 * 0.5;
            f.add(t, 3.0 - 0.25 * t);
        }
        assert!((f.slope() + 0.25).abs() < 1e-12);
        assert_eq!(LineFit::default().slope(), 0.0);
    }

    #[test]
    fn source_table() {
        assert_eq!(source_rmse(FilterKind::Ekf, Scenario::PitchSine, 1), Some(0.4160));
        assert_eq!(source_rmse(FilterKind::Ekf, Scenario::PitchSine, 0), None);
        assert_eq!(source_rmse(FilterKind::SsUkf, Scenario::Coupled, 2), Some(1.9138));
        assert_eq!(source_rmse(FilterKind::Cf, Scenario::YawSine, 2), Some(0.4488));
        assert_eq!(source_rmse(FilterKind::Ukf, Scenario::Surge, 1), Some(2.6120));
        assert_eq!(source_rmse(FilterKind::Ukf, Scenario::PitchRamp, 1), Some(0.0378));
        assert_eq!(source_rmse(FilterKind::Ekf, Scenario::PitchStep, 1), Some(0.2108));
        assert_eq!(source_rmse(FilterKind::Gyro, Scenario::PitchSine, 1), None);
        assert_eq!(source_rmse(FilterKind::Ekf, Scenario::StillHour, 2), None);
    }

    #[test]
    fn tilt_rmse_is_the_inclination_error_after_its_start() {
        use crate::sim::{axis_angle, qmul};
        let truth = axis_angle([0.2, 0.9, -0.3], 1.3);
        let mut t = TiltRmse::new(10.0);
        // Before the start: not scored, however wrong.
        t.add(9.99, axis_angle([1.0, 0.0, 0.0], 1.0), truth);
        assert_eq!(t.count(), 0);
        assert!(t.rmse_deg().is_nan());
        // A heading error alone is no tilt error; 3° and 4° about horizontal NED axes give
        // RMSE √((0 + 9 + 16) / 3) = 2.887°.
        t.add(10.0, qmul(axis_angle([0.0, 0.0, 1.0], 0.5), truth), truth);
        t.add(11.0, qmul(axis_angle([1.0, 0.0, 0.0], 3f64.to_radians()), truth), truth);
        t.add(12.0, qmul(axis_angle([0.0, 1.0, 0.0], -4f64.to_radians()), truth), truth);
        assert_eq!(t.count(), 3);
        assert!((t.rmse_deg() - (25.0f64 / 3.0).sqrt()).abs() < 1e-9, "{}", t.rmse_deg());
        let r = RunResult {
            rmse_deg: [0.0; 3],
            yaw_drift_dph: 0.0,
            final_yaw_err_deg: 0.0,
            max_yaw_err_deg: 0.0,
            tilt_rmse_deg: 0.42,
            rows: 1,
        };
        assert_eq!(Metric::TiltRmse.of(&r), 0.42);
    }

    #[test]
    fn robust_scenarios_goals_and_replay_settings() {
        let cfg = ReplayConfig::default();
        assert_eq!(tilt_start_s(Scenario::StartMoving, &cfg), 30.0);
        assert_eq!(
            tilt_start_s(Scenario::Tumble, &cfg),
            STILL_S.max(cfg.settings.init.window_s as f64)
        );
        for s in ROBUST_SCENARIOS {
            let g: Vec<_> = ROBUST_GOALS.iter().filter(|g| g.scenario == s).collect();
            assert_eq!(g.len(), 1);
            assert_eq!((g[0].metric, g[0].max), (Metric::TiltRmse, 0.5));
        }
        // Side mount: the Seahog's arm in sensor axes; pendulum: none.
        let r = replay_config(Scenario::SideMount).conditioning.lever_arm.r;
        assert!((r.x - 0.297_25).abs() < 1e-6 && (r.y - 0.0803).abs() < 1e-6);
        assert!((r.z - 0.196).abs() < 1e-6);
        let r = replay_config(Scenario::Pendulum).conditioning.lever_arm.r;
        assert_eq!(r, ekf_core::Vec3::ZERO);
        let mut tumble = ReplayConfig::default();
        tumble.conditioning.lever_arm.tangential = true;
        assert_eq!(replay_config(Scenario::Tumble), tumble);
    }

    #[test]
    fn section_replacement() {
        let doc = "a\n<!-- BEGIN t -->\nold\n<!-- END t -->\nb\n";
        assert_eq!(
            replace_section(doc, "t", "new\n\n").unwrap(),
            "a\n<!-- BEGIN t -->\nnew\n<!-- END t -->\nb\n"
        );
        assert_eq!(replace_section("no markers", "t", "x"), None);
    }
}
