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
//! - **final yaw error**: `e` at the last row.
//!
//! The source's single number for the pitch manoeuvres (scenarios 1, 3, 4, 6) is taken as the
//! pitch RMSE and for the yaw sinusoid (5) as the yaw RMSE; scenario 2 gives all three axes.

use ekf_core::conditioning::Conditioner;

use crate::config::ReplayConfig;
use crate::replay::{replay_rows, truth_euler_deg, wrap_deg, FilterKind};
use crate::sim::Scenario;
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
}

impl Metric {
    /// Value of this metric for a run (absolute values for the drift and final error).
    pub fn of(self, r: &RunResult) -> f64 {
        match self {
            Metric::Rmse(a) => r.rmse_deg[a],
            Metric::DriftDph => r.yaw_drift_dph.abs(),
            Metric::FinalYaw => r.final_yaw_err_deg.abs(),
        }
    }

    /// Short description with unit.
    pub fn describe(self) -> String {
        match self {
            Metric::Rmse(a) => format!("{} RMSE (°)", AXIS_NAMES[a]),
            Metric::DriftDph => "yaw drift, absolute (°/h)".into(),
            Metric::FinalYaw => "final yaw error, absolute (°)".into(),
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

/// The replay settings of a scenario: the defaults, except that `bias-off` is replayed
/// without estimating the gyro bias in the initialisation window (`replay --no-init-bias`),
/// so the filter starts with its configured, now 0.05 °/s wrong, z bias.
pub fn replay_config(scenario: Scenario) -> ReplayConfig {
    let mut cfg = ReplayConfig::default();
    if scenario == Scenario::BiasOff {
        cfg.settings.init.estimate_gyro_bias = false;
    }
    cfg
}

/// Simulate `scenario` at [`RATE_HZ`] for `duration_s` (its default when `None`) with `seed`.
pub fn simulate(scenario: Scenario, duration_s: Option<f64>, seed: u64) -> Vec<TraceRow> {
    let (sim, _) = scenario.simulator(RATE_HZ, duration_s, seed, false);
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

/// Replay `rows` (with truth) through a new `filter` configured by `cfg`, using the CLI's
/// replay loop, and measure it.
pub fn evaluate(rows: &[TraceRow], filter: FilterKind, cfg: &ReplayConfig) -> RunResult {
    let mut f = cfg.make_filter(filter);
    let mut cond = Conditioner::new(cfg.conditioning);
    let window = cfg.settings.init.window_s as f64;
    let t0 = rows.first().map_or(0.0, |r| r.t);
    let mut fit = LineFit::default();
    let mut unwrapped: Option<f64> = None;
    let mut max_err = 0.0f64;
    let stats =
        replay_rows(rows.iter().map(|r| Ok(*r)), f.as_mut(), &mut cond, window, |row, est| {
            if let Some(tq) = row.truth {
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
        rows: stats.rows,
    }
}

/// Simulate `scenario` with `seed` (default duration) and evaluate `filter` on it with the
/// scenario's [`replay_config`].
pub fn run(scenario: Scenario, seed: u64, filter: FilterKind) -> RunResult {
    let rows = simulate(scenario, None, seed);
    evaluate(&rows, filter, &replay_config(scenario))
}

/// CPU time of the calling thread, s (`clock_gettime(CLOCK_THREAD_CPUTIME_ID)`, nanoseconds),
/// so that other processes competing for the cores do not count in a timing; `None` where
/// unavailable (callers then use wall time).
///
/// Not `/proc/thread-self/schedstat`: for a thread that is running, Linux brings that figure up
/// to date only at scheduler ticks, so it lags by up to a tick (4 ms at 250 Hz) and a best-of
/// of short runs reads low. The clock adds the time since the last tick.
#[cfg(unix)]
#[allow(unsafe_code)]
pub fn thread_cpu_s() -> Option<f64> {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `ts` is a valid, writable `timespec` for the duration of the call.
    let r = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (r == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
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
    fn section_replacement() {
        let doc = "a\n<!-- BEGIN t -->\nold\n<!-- END t -->\nb\n";
        assert_eq!(
            replace_section(doc, "t", "new\n\n").unwrap(),
            "a\n<!-- BEGIN t -->\nnew\n<!-- END t -->\nb\n"
        );
        assert_eq!(replace_section("no markers", "t", "x"), None);
    }
}
