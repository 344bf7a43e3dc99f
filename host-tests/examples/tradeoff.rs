//! Every figure the EKF's NED low-pass trades against each other (issue #13, sessions 9–10), in
//! one run, for settings given in the device's language: the mean inclination and heading RMSE
//! on the 6 RepoIMU recordings (`--example realdata`), the hand-held case at 0.5 g and 0.15 g
//! (`--example handheld`, seeds 1–3; 100 Hz, and 250 Hz at 0.5 g), and the robustness scenarios' tilt RMSE and the goal rows
//! of the accuracy bench (seeds 1–5), plain and realistic sensors. Lower is better everywhere:
//! a change of the estimator is done when no row gets worse.
//!
//! `cargo run --release -p host-tests --example tradeoff -- [NAME=VALUE...]`; with
//! `TRADEOFF_RATE=HZ` the robustness and goal rows are simulated at HZ instead of 50 Hz.
use host_tests::accuracy::{evaluate_from, Metric, GOALS, ROBUST_GOALS};
use host_tests::accuracy::{replay_config, simulate_with, tilt_start_s, RATE_HZ};
use host_tests::config::ReplayConfig;
use host_tests::handheld;
use host_tests::real::{score, RepoImu};
use host_tests::replay::FilterKind;
use host_tests::settings::{device_form, parse_assignment, Assignment, ReplaySettings};
use host_tests::sim::SimOptions;

fn with(base: &ReplayConfig, given: &[Assignment]) -> ReplayConfig {
    let mut rs = ReplaySettings::new(device_form(base));
    for a in given {
        rs.apply_given(a);
    }
    rs.config(base)
}

fn run() -> Result<(), String> {
    let given =
        std::env::args().skip(1).map(|t| parse_assignment(&t)).collect::<Result<Vec<_>, _>>()?;
    let ekf = FilterKind::Ekf;

    let cfg = with(&RepoImu::config(), &given);
    let files = RepoImu::load(&RepoImu::dir())?;
    let (mut si, mut sh) = (0.0, 0.0);
    for (name, rows) in &files {
        let r = score(rows, ekf, &cfg).ok_or_else(|| format!("{name}: no rows with truth"))?;
        si += r.inclination_deg / files.len() as f64;
        sh += r.heading_deg / files.len() as f64;
    }
    println!("{:34} {si:7.3} {sh:7.3}", "RepoIMU incl / heading");

    let mut base = ReplayConfig::default();
    base.conditioning.lever_arm = ekf_core::lever_arm::LeverArm::NONE;
    let cfg = with(&base, &given);
    let r0 = handheld::RATE_HZ;
    for (scale, moving, rate) in
        [(1.0, false, r0), (0.3, false, r0), (1.0, true, r0), (1.0, false, 250.0)]
    {
        let mut v = [0.0; 2];
        for (k, realistic) in [false, true].into_iter().enumerate() {
            for seed in 1..=3u64 {
                let rows = handheld::rows(scale, seed, realistic, moving, rate);
                v[k] += score(&rows, ekf, &cfg).ok_or("no truth")?.inclination_deg / 3.0;
            }
        }
        let start = if moving { ", moving start" } else { "" };
        let hz = if rate == r0 { String::new() } else { format!(", {rate} Hz") };
        println!("{:34} {:7.3} {:7.3}", format!("hand-held x{scale}{start}{hz}"), v[0], v[1]);
    }

    // The simulated rows at another rate (`TRADEOFF_RATE=HZ`; the goals are set for 50 Hz).
    let rate_hz = host_tests::sim::rate_from_env("TRADEOFF_RATE", RATE_HZ)?;
    let goals = ROBUST_GOALS.iter().chain(GOALS.iter().take(10));
    for g in goals {
        let mut v = [0.0; 2];
        for (k, realistic) in [false, true].into_iter().enumerate() {
            for seed in 1..=5u64 {
                let opts = SimOptions { rate_hz, seed, realistic, ..SimOptions::default() };
                let rows = simulate_with(g.scenario, &opts);
                let cfg = with(&replay_config(g.scenario), &given);
                let r = evaluate_from(&rows, ekf, &cfg, tilt_start_s(g.scenario, &cfg));
                v[k] += g.metric.of(&r) / 5.0;
            }
        }
        let unit = if matches!(g.metric, Metric::DriftDph) { "°/h" } else { "°" };
        println!("{:34} {:7.4} {:7.4} (goal {}{unit})", g.label, v[0], v[1], g.max);
    }
    Ok(())
}

fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tradeoff: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
