//! Accuracy regression tests: the EKF with default settings on fixed seeds against the goals of
//! `docs/accuracy.md` (`host_tests::accuracy::GOALS`). This is the fast subset: seed 1, the EKF
//! only, scenarios 1–6 at 200 s and the one-hour `still-hour` and `bias-off` runs (about a
//! second in the test profile). The full set (seeds 1–5, every
//! filter, every scenario) is `cargo bench -p host-tests --bench accuracy`.
//!
//! Also guarded: the EKF on the 6 RepoIMU recordings (`host_tests::real`, real truth) against
//! VQF's published online figure, and the robustness scenarios (`ROBUST_GOALS`) on seed 1.

use std::time::Instant;

use host_tests::accuracy::{run, GOALS, ROBUST_GOALS, ROBUST_SCENARIOS, TABLE16_SCENARIOS};
use host_tests::real::{score, RepoImu};
use host_tests::replay::FilterKind;
use host_tests::sim::Scenario;

const SEED: u64 = 1;

// Every goal is asserted at its threshold: on seed 1 the EKF meets all of them. (Averaged over
// seeds 1–5 it misses "2 yaw" and "5 yaw": see "Misses" in docs/accuracy.md. Should a retune
// make a seed-1 value miss, assert the measured value plus a small margin here, with a comment
// pointing to docs/accuracy.md, rather than loosening the goal.)

fn check(scenarios: &[Scenario]) {
    let mut failures = Vec::new();
    for &s in scenarios {
        let start = Instant::now();
        let r = run(s, SEED, FilterKind::Ekf);
        eprintln!(
            "{}: rmse {:.4} / {:.4} / {:.4}, drift {:.4} °/h, final yaw {:.4}° ({:.2} s)",
            s.name(),
            r.rmse_deg[0],
            r.rmse_deg[1],
            r.rmse_deg[2],
            r.yaw_drift_dph,
            r.final_yaw_err_deg,
            start.elapsed().as_secs_f64()
        );
        for g in GOALS.iter().filter(|g| g.scenario == s) {
            let v = g.metric.of(&r);
            eprintln!("  {}: {} = {v:.4}, goal ≤ {}", g.label, g.metric.describe(), g.max);
            // Also a failure when `v` is NaN.
            if v.is_nan() || v > g.max {
                failures.push(format!("{}: {} = {v:.4} > {}", g.label, g.metric.describe(), g.max));
            }
        }
    }
    assert!(failures.is_empty(), "accuracy regressions:\n{}", failures.join("\n"));
}

#[test]
fn ekf_meets_the_goals_on_scenarios_1_to_6() {
    check(&TABLE16_SCENARIOS);
}

#[test]
fn ekf_holds_yaw_for_an_hour() {
    // One hour still with the bias right, and with the configured z bias 0.05 °/s off.
    check(&[Scenario::StillHour, Scenario::BiasOff]);
}

#[test]
fn ekf_beats_vqf_online_inclination_on_repoimu() {
    // The 6 recordings of ../shared/data/repoimu (always present), the EKF with the defaults
    // and no lever arm (`RepoImu::config`): mean inclination RMSE below VQF 2.1 online's
    // 3.29° (2.71° when this test was written). Heading is not guarded (no magnetometer: the
    // EKF's heading drifts on this rig; see docs/accuracy.md).
    let start = Instant::now();
    let files = RepoImu::load(&RepoImu::dir()).expect("RepoIMU data");
    let cfg = RepoImu::config();
    let mut sum = 0.0;
    for (name, rows) in &files {
        let r = score(rows, FilterKind::Ekf, &cfg).expect("rows with truth");
        eprintln!("{name}: inclination {:.3}°, heading {:.3}°", r.inclination_deg, r.heading_deg);
        assert!(r.inclination_deg.is_finite(), "{name}: {r:?}");
        sum += r.inclination_deg;
    }
    let mean = sum / files.len() as f64;
    let goal = RepoImu::VQF_ONLINE.0;
    eprintln!(
        "mean inclination {mean:.3}°, goal < {goal}° ({:.2} s)",
        start.elapsed().as_secs_f64()
    );
    assert!(mean < goal, "mean inclination RMSE {mean:.3}° >= VQF online {goal}°");
}

#[test]
fn ekf_keeps_the_robustness_goals() {
    // Seed 1, plain sensors. Every robust scenario that meets its goal (tilt RMSE ≤ 0.5°) keeps
    // it: tumble ≈ 0.18°, side-mount ≈ 0.09°, start-moving ≈ 0.07° when this was written.
    // `pendulum` (≈ 0.55°) does not meet it yet: it is held below 1.0° instead.
    let mut failures = Vec::new();
    for s in ROBUST_SCENARIOS {
        let start = Instant::now();
        let r = run(s, SEED, FilterKind::Ekf);
        let g = ROBUST_GOALS.iter().find(|g| g.scenario == s).expect("a goal per scenario");
        let limit = if s == Scenario::Pendulum { 1.0 } else { g.max };
        let v = g.metric.of(&r);
        eprintln!(
            "{}: {} = {v:.4}, held ≤ {limit} (goal ≤ {}) ({:.2} s)",
            s.name(),
            g.metric.describe(),
            g.max,
            start.elapsed().as_secs_f64()
        );
        if v.is_nan() || v > limit {
            failures.push(format!("{}: {} = {v:.4} > {limit}", g.label, g.metric.describe()));
        }
    }
    assert!(failures.is_empty(), "robustness regressions:\n{}", failures.join("\n"));
}
