//! Scoring against real truth: the inclination and heading errors of the published orientation
//! benchmarks (RepoIMU, BROAD, VQF's evaluation), the 6 RepoIMU recordings of
//! `shared/data/repoimu/` and the 13 BROAD trials of `shared/data/broad/`, with VQF's figures
//! beside them.
//!
//! For every row with truth, the error quaternion is `e = q_est ⊗ conj(q_true)` (both body →
//! NED), and
//! - the **inclination error** is `2·atan2(√(ex² + ey²), √(ew² + ez²))`: the angle of the part
//!   of `e` about a horizontal axis, whatever the heading;
//! - the **heading error** is `2·atan2(ez, ew)` wrapped to ±180°: the part of `e` about NED z,
//!   minus its circular mean over the run (an estimator without a magnetometer has no absolute
//!   heading, so a constant offset is not an error).
//!
//! Both are reported as RMSE over every row with truth, in degrees.

use std::path::{Path, PathBuf};

use ekf_core::conditioning::Conditioner;

use crate::config::ReplayConfig;
use crate::replay::{replay_rows, FilterKind};
use crate::sim::{qmul, Q};
use crate::trace::{read_trace_file, TraceError, TraceRow};

/// Inclination and heading errors of one run, accumulated row by row.
#[derive(Clone, Debug, Default)]
pub struct AttitudeScore {
    incl_sq: f64,
    /// Heading errors, rad, kept for the second pass around their circular mean.
    heading: Vec<f64>,
}

/// The RMSEs of an [`AttitudeScore`], degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScoreRmse {
    /// Inclination RMSE, degrees.
    pub inclination_deg: f64,
    /// Heading RMSE with its circular mean removed, degrees.
    pub heading_deg: f64,
    /// Rows scored.
    pub rows: usize,
}

/// Inclination and heading error (rad) of `est` against `truth` (both body → NED, any norm).
pub fn errors(est: Q, truth: Q) -> (f64, f64) {
    let t = [truth[0], -truth[1], -truth[2], -truth[3]];
    let e = qmul(est, t);
    let incl = 2.0 * f64::atan2(e[1].hypot(e[2]), e[0].hypot(e[3]));
    let mut heading = 2.0 * f64::atan2(e[3], e[0]);
    if heading > std::f64::consts::PI {
        heading -= 2.0 * std::f64::consts::PI;
    } else if heading < -std::f64::consts::PI {
        heading += 2.0 * std::f64::consts::PI;
    }
    (incl, heading)
}

impl AttitudeScore {
    /// Add one row.
    pub fn add(&mut self, est: Q, truth: Q) {
        let (i, h) = errors(est, truth);
        self.incl_sq += i * i;
        self.heading.push(h);
    }

    /// Rows added.
    pub fn count(&self) -> usize {
        self.heading.len()
    }

    /// The RMSEs, or `None` with no row.
    pub fn rmse(&self) -> Option<ScoreRmse> {
        let n = self.heading.len();
        if n == 0 {
            return None;
        }
        let (s, c) = self.heading.iter().fold((0.0, 0.0), |(s, c), h| (s + h.sin(), c + h.cos()));
        let mean = s.atan2(c);
        let sq: f64 = self
            .heading
            .iter()
            .map(|h| {
                let d = (h - mean + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
                    - std::f64::consts::PI;
                d * d
            })
            .sum();
        Some(ScoreRmse {
            inclination_deg: (self.incl_sq / n as f64).sqrt().to_degrees(),
            heading_deg: (sq / n as f64).sqrt().to_degrees(),
            rows: n,
        })
    }
}

/// Replay `rows` through a new `filter` configured by `cfg` (the CLI's replay loop) and score
/// every row that has truth, from the first row on (the initialisation window included, as
/// the published figures are), but only the motion phase where the trace marks one
/// ([`TraceRow::scored`]: BROAD's `movement` column).
pub fn score(rows: &[TraceRow], filter: FilterKind, cfg: &ReplayConfig) -> Option<ScoreRmse> {
    let mut f = cfg.make_filter(filter);
    let mut cond = Conditioner::new(cfg.conditioning);
    let mut acc = AttitudeScore::default();
    replay_rows(rows.iter().map(|r| Ok(*r)), f.as_mut(), &mut cond, 0.0, |row, est| {
        if let (true, Some(t)) = (row.scored(), row.truth) {
            acc.add(est.q.map(f64::from), t.map(f64::from));
        }
        Ok(())
    })
    .expect("in-memory replay cannot fail");
    acc.rmse()
}

/// The 6 RepoIMU recordings of `shared/data/repoimu`, with VQF's published figures.
pub struct RepoImu;

impl RepoImu {
    /// The 6 files, in the order of the README.
    pub const FILES: [&'static str; 6] = [
        "Pendulum_Test02a_Trial1_Segment_1.csv",
        "Pendulum_Test02a_Trial1_Segment_2.csv",
        "Pendulum_Test02a_Trial1_Segment_3.csv",
        "Pendulum_Test02b_Trial1_Segment_1.csv",
        "Pendulum_Test02b_Trial1_Segment_2.csv",
        "Pendulum_Test02b_Trial1_Segment_3.csv",
    ];

    /// VQF 2.1 online, default settings, mean over the 6 files (inclination, heading), degrees
    /// (`shared/data/repoimu/README.md`).
    pub const VQF_ONLINE: (f64, f64) = (3.29, 11.02);
    /// VQF 2.1 offline, the same.
    pub const VQF_OFFLINE: (f64, f64) = (2.18, 14.19);

    /// The data folder: `$REPOIMU_DIR`, else `shared/data/repoimu` beside the workspace.
    pub fn dir() -> PathBuf {
        if let Some(d) = std::env::var_os("REPOIMU_DIR") {
            return PathBuf::from(d);
        }
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/repoimu")
    }

    /// Read every file: `(name, rows)`.
    pub fn load(dir: &Path) -> Result<Vec<(String, Vec<TraceRow>)>, String> {
        load_files(dir, Self::FILES.iter().copied())
    }

    /// The replay configuration for a foreign IMU: the project's defaults with no lever arm
    /// (the Seahog's mounting is not this IMU's), nothing tuned per file.
    pub fn config() -> ReplayConfig {
        let mut cfg = ReplayConfig::default();
        cfg.conditioning.lever_arm = ekf_core::lever_arm::LeverArm::NONE;
        cfg
    }
}

/// The 13 BROAD trials of `shared/data/broad` (the development set: the benchmark's other 17
/// trials are not shared), with VQF's figures from its README.
pub struct Broad;

impl Broad {
    /// Each trial's file and VQF 2.1 online's (inclination, heading) RMSE on it, degrees
    /// (`shared/data/broad/README.md`).
    pub const TRIALS: [(&'static str, (f64, f64)); 13] = [
        ("01_undisturbed_slow_rotation_A.csv", (0.60, 4.55)),
        ("04_undisturbed_slow_rotation_with_breaks_A.csv", (0.79, 3.84)),
        ("06_undisturbed_fast_rotation_A.csv", (0.80, 0.35)),
        ("08_undisturbed_fast_rotation_with_breaks_A.csv", (1.76, 7.72)),
        ("10_undisturbed_slow_translation_A.csv", (0.30, 1.02)),
        ("15_undisturbed_fast_translation_A.csv", (0.47, 1.43)),
        ("24_disturbed_tapping_A.csv", (0.61, 0.58)),
        ("26_disturbed_phone_vibration_A.csv", (0.56, 0.90)),
        ("28_disturbed_stationary_magnet_A.csv", (1.21, 3.46)),
        ("30_disturbed_stationary_magnet_C.csv", (1.25, 5.06)),
        ("32_disturbed_attached_magnet_1cm.csv", (0.56, 2.01)),
        ("34_disturbed_attached_magnet_3cm.csv", (0.65, 3.50)),
        ("36_disturbed_attached_magnet_5cm.csv", (0.88, 4.36)),
    ];

    /// VQF 2.1 online, mean over the 13 trials (inclination, heading), degrees.
    pub const VQF_ONLINE: (f64, f64) = (0.80, 2.98);

    /// The data folder: `$BROAD_DIR`, else `shared/data/broad` beside the workspace.
    pub fn dir() -> PathBuf {
        if let Some(d) = std::env::var_os("BROAD_DIR") {
            return PathBuf::from(d);
        }
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/broad")
    }

    /// Read every trial: `(name, rows)`.
    pub fn load(dir: &Path) -> Result<Vec<(String, Vec<TraceRow>)>, String> {
        load_files(dir, Self::TRIALS.iter().map(|t| t.0))
    }
}

/// Read `names` from `dir`: `(name, rows)`, or the first error naming its file.
fn load_files<'a>(
    dir: &Path,
    names: impl Iterator<Item = &'a str>,
) -> Result<Vec<(String, Vec<TraceRow>)>, String> {
    names
        .map(|name| {
            let p = dir.join(name);
            read_trace_file(&p)
                .map(|(_, rows)| (name.to_string(), rows))
                .map_err(|e: TraceError| format!("{}: {e}", p.display()))
        })
        .collect()
}

/// `replay --foreign`: [`RepoImu::config`] and also the configured gyro bias zero (the
/// default, `init.gyro_bias`, is the iNEMO board's own).
pub fn foreign_config() -> ReplayConfig {
    let mut cfg = RepoImu::config();
    cfg.settings.init.gyro_bias = ekf_core::Vec3::ZERO;
    cfg
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::axis_angle;

    #[test]
    fn errors_split_tilt_from_heading() {
        let t = axis_angle([0.3, -0.5, 0.8], 1.1);
        // A pure rotation about NED z of 20°: heading error 20°, no inclination error.
        let est = qmul(axis_angle([0.0, 0.0, 1.0], 20f64.to_radians()), t);
        let (i, h) = errors(est, t);
        assert!(i.abs() < 1e-12 && (h.to_degrees() - 20.0).abs() < 1e-9, "{i} {h}");
        // A rotation about a horizontal NED axis of 7°: inclination 7°, heading 0.
        let est = qmul(axis_angle([0.6, 0.8, 0.0], 7f64.to_radians()), t);
        let (i, h) = errors(est, t);
        assert!((i.to_degrees() - 7.0).abs() < 1e-9 && h.abs() < 1e-12, "{i} {h}");
        // Sign of q does not matter.
        let neg = est.map(|c| -c);
        let (i2, h2) = errors(neg, t);
        assert!((i2 - i).abs() < 1e-12 && h2.abs() < 1e-12);
    }

    #[test]
    fn heading_mean_is_removed_circularly() {
        let t = [1.0, 0.0, 0.0, 0.0];
        let mut s = AttitudeScore::default();
        // Errors of 179° and −179° (2° apart across the wrap) and a 3° inclination error on
        // one row: heading RMSE 1°, inclination RMSE 3/√2.
        s.add(axis_angle([0.0, 0.0, 1.0], 179f64.to_radians()), t);
        s.add(
            qmul(
                axis_angle([1.0, 0.0, 0.0], 3f64.to_radians()),
                axis_angle([0.0, 0.0, 1.0], -179f64.to_radians()),
            ),
            t,
        );
        let r = s.rmse().unwrap();
        assert!((r.heading_deg - 1.0).abs() < 1e-6, "{r:?}");
        assert!((r.inclination_deg - 3.0 / 2f64.sqrt()).abs() < 1e-6, "{r:?}");
        assert_eq!(AttitudeScore::default().rmse(), None);
    }
}
