//! Accuracy regression tests: the EKF with default settings on fixed seeds against the goals of
//! `docs/accuracy.md` (`host_tests::accuracy::GOALS`). This is the fast subset: seed 1, the EKF
//! only, scenarios 1–6 at 200 s and the one-hour `still-hour` and `bias-off` runs (about a
//! second in the test profile). The full set (seeds 1–5, every
//! filter, every scenario) is `cargo bench -p host-tests --bench accuracy`.

use std::time::Instant;

use host_tests::accuracy::{run, GOALS, TABLE16_SCENARIOS};
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
