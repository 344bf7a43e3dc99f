//! Which of the realistic sensor errors costs a scenario its tilt: the EKF's tilt RMSE
//! (default settings, seeds 1–5, the bench's replay configuration) with every error of
//! `Realism::INEMO` on, with one group off at a time, with only the gyro's scale and cross-axis
//! errors, and with none. Issue #35: the realistic `tumble`'s tilt is the gyro's scale and
//! cross-axis error (1.37° of 1.41° before `motion`'s scale-error term).
//!
//! `cargo run --release -p host-tests --example realism_breakdown -- [SCENARIO]` (default
//! `tumble`); `TAU=S` and `KS=K` set `ekf.accel_time_constant` and `ekf.gyro_scale_error`.
use host_tests::accuracy::{evaluate_from, replay_config, tilt_start_s, RATE_HZ};
use host_tests::replay::FilterKind;
use host_tests::sim::{Realism, Scenario, SimConfig, Simulator};

type Edit = fn(&mut Realism);

fn main() -> Result<(), String> {
    let name = std::env::args().nth(1).unwrap_or_else(|| "tumble".into());
    let sc = *Scenario::ALL
        .iter()
        .find(|s| s.name() == name)
        .ok_or_else(|| format!("no scenario '{name}'"))?;
    let variants: [(&str, Edit); 8] = [
        ("every error", |_| {}),
        ("no gyro scale", |r| r.gyro_scale = 0.0),
        ("no gyro cross-axis", |r| r.gyro_cross_axis = 0.0),
        ("no gyro scale, cross-axis", |r| {
            r.gyro_scale = 0.0;
            r.gyro_cross_axis = 0.0;
        }),
        ("no accel bias, scale", |r| {
            r.accel_bias_g = 0.0;
            r.accel_scale = 0.0;
        }),
        ("no vibration", |r| {
            r.vibration_accel_g = 0.0;
            r.vibration_gyro_dps = 0.0;
        }),
        ("only gyro scale, cross-axis", |r| {
            *r = Realism {
                gyro_scale: r.gyro_scale,
                gyro_cross_axis: r.gyro_cross_axis,
                ..Realism::OFF
            };
        }),
        ("none", |r| *r = Realism::OFF),
    ];
    let mut cfg = replay_config(sc);
    let env =
        |k: &str| std::env::var(k).ok().map(|v| v.parse::<f32>().map_err(|e| format!("{k}: {e}")));
    if let Some(v) = env("TAU") {
        cfg.settings.ekf.accel_time_constant = v?;
    }
    if let Some(v) = env("KS") {
        cfg.settings.ekf.gyro_scale_error = v?;
    }
    println!("{name}: EKF tilt RMSE, mean of seeds 1–5 (°)");
    for (label, edit) in variants {
        let mut sum = 0.0;
        for seed in 1..=5u64 {
            let mut sensors = sc.sensors();
            let mut r = Realism::INEMO;
            edit(&mut r);
            sensors.realism = Some(r);
            let duration_s = sc.default_duration();
            let sim = SimConfig { rate_hz: RATE_HZ, duration_s, seed, sensors };
            let rows: Vec<_> = Simulator::new(sc.trajectory(), sim).map(|s| s.row).collect();
            sum +=
                evaluate_from(&rows, FilterKind::Ekf, &cfg, tilt_start_s(sc, &cfg)).tilt_rmse_deg;
        }
        println!("  {label:28} {:.3}", sum / 5.0);
    }
    Ok(())
}
