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

/// The goals the EKF misses on seed 1, with the bound asserted instead. None since issue #35:
/// the low-pass's time constant follows the motion, and the source's scenarios, which have no
/// horizontal acceleration, take their samples raw (issue #26's fixed 2.5 s left the gyro's
/// walk over it, about 0.1° per axis, in the tilt, and missed seven of these goals).
const MISSED: [(&str, f64); 0] = [];

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
            let max = MISSED.iter().find(|m| m.0 == g.label).map_or(g.max, |m| m.1);
            eprintln!(
                "  {}: {} = {v:.4}, goal ≤ {}, asserted ≤ {max}",
                g.label,
                g.metric.describe(),
                g.max
            );
            // Also a failure when `v` is NaN.
            if v.is_nan() || v > max {
                failures.push(format!("{}: {} = {v:.4} > {max}", g.label, g.metric.describe()));
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
    // The goals (≤ 1°) would pass without the yaw hold at rest (0.19° then: issue #17); what
    // it achieves, 0.004°, is held here at 0.02°.
    for s in [Scenario::StillHour, Scenario::BiasOff] {
        let r = run(s, SEED, FilterKind::Ekf);
        let e = r.final_yaw_err_deg.abs();
        assert!(e < 0.02, "{}: final yaw error {e:.4}° (the yaw hold)", s.name());
    }
}

/// Mean (inclination, heading) RMSE of the EKF over the 6 RepoIMU recordings with `cfg`.
fn repoimu_means(cfg: &host_tests::config::ReplayConfig) -> (f64, f64) {
    let files = RepoImu::load(&RepoImu::dir()).expect("RepoIMU data");
    let (mut si, mut sh) = (0.0, 0.0);
    for (name, rows) in &files {
        let r = score(rows, FilterKind::Ekf, cfg).expect("rows with truth");
        eprintln!("{name}: inclination {:.3}°, heading {:.3}°", r.inclination_deg, r.heading_deg);
        assert!(r.inclination_deg.is_finite() && r.heading_deg.is_finite(), "{name}: {r:?}");
        si += r.inclination_deg;
        sh += r.heading_deg;
    }
    let n = files.len() as f64;
    (si / n, sh / n)
}

#[test]
fn ekf_beats_vqf_online_inclination_on_repoimu() {
    // The 6 recordings of ../shared/data/repoimu (always present), the EKF with the defaults
    // and no lever arm (`RepoImu::config`): mean inclination RMSE below VQF 2.1 online's
    // 3.29° (2.74° when this test was written).
    let start = Instant::now();
    let (mean, _) = repoimu_means(&RepoImu::config());
    let goal = RepoImu::VQF_ONLINE.0;
    eprintln!(
        "mean inclination {mean:.3}°, goal < {goal}° ({:.2} s)",
        start.elapsed().as_secs_f64()
    );
    assert!(mean < goal, "mean inclination RMSE {mean:.3}° >= VQF online {goal}°");
}

#[test]
fn ekf_heading_on_repoimu_holds() {
    // The same files, default settings and no lever arm: the windows are still for about 1.5 s
    // before the pendulum swings, and the bias comes from that still part (`init.rs`, still
    // prefix). Mean heading RMSE 15.3° when this test was written, 14.9° since session 7 (VQF 2.1
    // online: 11.0°, not met; 78° with the configured iNEMO bias). Held below 20°.
    let (_, heading) = repoimu_means(&RepoImu::config());
    assert!(heading < 20.0, "mean heading RMSE {heading:.3}° >= 20°");
}

#[test]
fn a_noise_setting_ten_times_off_changes_no_decision_on_repoimu() {
    // Issue #13, foreign sensors: the gyro and accelerometer noise settings 10× too low or too
    // high (they are the iNEMO's, not the Xsens's). The window judges stillness from the
    // samples' own scatter (`init.rs`), so the still start is found either way; with the old
    // test against 40× the configured noise, the gyro's ×0.1 called it motion and the heading
    // went to 83°. Measured: 14.8–14.9° heading, 2.7–2.9° inclination.
    for (gyro, accel) in [(0.1, 1.0), (10.0, 1.0), (1.0, 0.1), (1.0, 10.0)] {
        let mut cfg = RepoImu::config();
        cfg.settings.noise.gyro_var = cfg.settings.noise.gyro_var * gyro;
        cfg.settings.noise.accel_var *= accel;
        let (incl, heading) = repoimu_means(&cfg);
        eprintln!("gyro noise ×{gyro}, accelerometer ×{accel}: {incl:.2}° / {heading:.2}°");
        assert!(incl < 3.29 && heading < 17.0, "×{gyro} ×{accel}: {incl:.2}° / {heading:.2}°");
    }
}

#[test]
fn ekf_keeps_the_robustness_goals() {
    // Seed 1, plain sensors. Every robust scenario that meets its goal (tilt RMSE ≤ 0.5°) keeps
    // it: tumble ≈ 0.18°, side-mount ≈ 0.09°, start-moving ≈ 0.07° when this was written.
    // `pendulum` (≈ 0.56°) does not meet it: it is held below 1.0° instead.
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

/// `still-hour` with the realistic sensor errors for `seconds`, replayed through the EKF with
/// `cfg`; `each` sees every row from 20 s on with its estimate.
fn realistic_still(
    seconds: f64,
    cfg: &host_tests::config::ReplayConfig,
    mut each: impl FnMut(&host_tests::trace::TraceRow, &host_tests::trace::EstimateRow),
) {
    use host_tests::accuracy::simulate_with;
    use host_tests::sim::SimOptions;
    let opts = SimOptions {
        seed: SEED,
        duration_s: Some(seconds),
        realistic: true,
        ..SimOptions::default()
    };
    let rows = simulate_with(Scenario::StillHour, &opts);
    let mut f = cfg.make_filter(FilterKind::Ekf);
    let mut cond = ekf_core::conditioning::Conditioner::new(cfg.conditioning);
    host_tests::replay::replay_rows(
        rows.iter().map(|r| Ok(*r)),
        f.as_mut(),
        &mut cond,
        10.0,
        |r, e| {
            if r.t >= 20.0 {
                each(r, e);
            }
            Ok(())
        },
    )
    .unwrap();
}

#[test]
fn a_still_board_with_realistic_sensors_keeps_its_bias() {
    // `still-hour` for 120 s with the realistic sensor errors (vibration 0.02 g, quantisation,
    // jitter, repeated samples, bias instability: host-tests/src/sim.rs), replayed twice: with
    // the defaults (the window is still: vibration and quantisation are within its limits) and
    // started at once with the 2 °/s bias uncertainty and 30° tilt uncertainty of a start in
    // motion. The bias must stay put in both. (Session 6: a window that took the vibration for
    // motion ran its z bias to 4 °/s with the first bias-gain design. Since session 13 the
    // window's limits, the low-pass's delay model and the bias not learned about the vertical
    // keep it: docs/filter.md.)
    use host_tests::accuracy::replay_config;
    use host_tests::sim::GYRO_BIAS_DPS;
    for moving_start in [false, true] {
        let mut cfg = replay_config(Scenario::StillHour);
        if moving_start {
            cfg.settings.init.window_s = 0.0;
            cfg.settings.ekf.initial_bias_sigma = 2f32.to_radians();
            cfg.settings.ekf.initial_tilt_sigma = 30f32.to_radians();
        }
        let mut worst_bias = 0.0f64;
        let mut yaw = (0.0f64, 0.0f64);
        realistic_still(120.0, &cfg, |r, e| {
            for (b, t) in e.bias_dps.iter().zip(GYRO_BIAS_DPS) {
                worst_bias = worst_bias.max((*b as f64 - t).abs());
            }
            if r.t < 20.02 {
                yaw.0 = e.euler_deg[2] as f64;
            }
            yaw.1 = e.euler_deg[2] as f64;
        });
        let turned = host_tests::replay::wrap_deg(yaw.1 - yaw.0);
        eprintln!("moving start {moving_start}: worst bias error after 20 s {worst_bias:.3} °/s, yaw turned {turned:.2}° in 100 s");
        // The simulated bias wanders too (random walk and flicker); a moving start learns the
        // x/y bias of the board's noisy gyros from the accelerometer within a few tenths of a
        // degree per second.
        assert!(worst_bias < 0.5, "moving start {moving_start}: bias off by {worst_bias:.3} °/s");
        assert!(turned.abs() < 20.0, "moving start {moving_start}: yaw turned {turned:.2}°");
    }
}

#[test]
fn a_vibrating_still_board_is_at_rest_and_holds_its_heading() {
    // `still-hour` for 600 s with the realistic sensor errors: 0.02 g and 0.1 °/s rms of
    // vibration at 20–40 Hz, quantisation, a wandering bias. The rest detector judges the
    // block's 0.25 s segment means, which the vibration does not move, so the board is at rest
    // most of the time and the yaw is held. (With the samples' own spread as the test, as until
    // session 7, it was never at rest and the yaw drifted by tens of degrees per hour.)
    let cfg = host_tests::accuracy::replay_config(Scenario::StillHour);
    let (mut n, mut at_rest) = (0u32, 0u32);
    let mut yaw = (0.0f64, 0.0f64);
    realistic_still(600.0, &cfg, |_, e| {
        n += 1;
        at_rest += (e.flags & ekf_core::Flags::AT_REST.bits() != 0) as u32;
        if n == 1 {
            yaw.0 = e.euler_deg[2] as f64;
        }
        yaw.1 = e.euler_deg[2] as f64;
    });
    let turned = host_tests::replay::wrap_deg(yaw.1 - yaw.0);
    let rest = at_rest as f64 / n as f64;
    eprintln!(
        "at rest {:.0} % of the rows after 20 s; yaw turned {turned:.3}° in 580 s",
        rest * 100.0
    );
    assert!(rest > 0.85, "at rest in {:.0} % of the rows", rest * 100.0);
    assert!(turned.abs() < 0.3, "yaw turned {turned:.3}°");
}
