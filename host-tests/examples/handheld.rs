//! A hand-held-like motion that the project's scenarios do not cover (session 8, issue #13):
//! three sines per body axis at 0.2–2.7 Hz (rates up to about 250 °/s) and, at the rotation
//! centre, linear accelerations of up to 0.5 g at 0.6–2.4 Hz, sines in NED (so that the position
//! stays bounded, as a hand's does; session 9), after a 10 s still start; 100 Hz,
//! 120 s, no lever arm, seeds 1–3, plain and realistic sensors (`simulate --realistic`'s errors,
//! full scales widened to ±2000 °/s and ±8 g). Prints the mean inclination and heading RMSE
//! (`host_tests::real::score`) of the EKF, gyro-only and complementary filters.
//!
//! `cargo run --release -p host-tests --example handheld -- [ACCEL_SCALE] [NAME=VALUE...]`:
//! the linear accelerations scaled by ACCEL_SCALE (default 1; 0.3 for about 0.15 g), the EKF's
//! settings in the device's language. With `HANDHELD_TRACE=FILE` the plain seed-1 trace is
//! written there too (for `scripts/vqf-reference --trace FILE`). With `HANDHELD_MOVING_START=1`
//! the motion starts at power-on (no still start) and the simulated gyro has no bias, so the
//! configured bias the EKF starts from (the iNEMO board's, up to 3.4 °/s) is wrong and only
//! learning in motion can correct it.
use host_tests::config::ReplayConfig;
use host_tests::real::score;
use host_tests::replay::FilterKind;
use host_tests::settings::{device_form, parse_assignment, ReplaySettings};
use host_tests::sim::{Attitude, Profile, Realism, SensorModel, SimConfig, Simulator, Trajectory};
use host_tests::trace::{TraceColumns, TraceWriter};

const D: f64 = std::f64::consts::PI / 180.0;

fn moving_start() -> bool {
    std::env::var("HANDHELD_MOVING_START").is_ok_and(|v| v == "1")
}

fn sine(amp: f64, freq_hz: f64, phase: f64) -> Profile {
    Profile::Sine { start: if moving_start() { 0.0 } else { 10.0 }, amp, freq_hz, phase }
}

fn sum(v: Vec<Profile>) -> Profile {
    Profile::Sum(Box::leak(v.into_boxed_slice()))
}

fn trajectory(k: f64) -> Trajectory {
    let rate =
        |a: [(f64, f64, f64); 3]| sum(a.iter().map(|&(amp, f, ph)| sine(amp * D, f, ph)).collect());
    let acc =
        |a: [(f64, f64, f64); 2]| sum(a.iter().map(|&(amp, f, ph)| sine(amp * k, f, ph)).collect());
    Trajectory {
        attitude: Attitude::BodyRates {
            rates: [
                rate([(90.0, 0.37, 0.0), (60.0, 1.1, 1.0), (30.0, 2.3, 2.0)]),
                rate([(80.0, 0.29, 0.5), (70.0, 0.93, 1.5), (25.0, 1.9, 2.5)]),
                rate([(100.0, 0.21, 0.2), (50.0, 0.77, 1.2), (20.0, 2.7, 2.2)]),
            ],
            q0: [1.0, 0.0, 0.0, 0.0],
        },
        accel_body: [Profile::Zero; 3],
        accel_ned: [
            acc([(3.0, 0.8, 0.0), (2.0, 2.1, 1.0)]),
            acc([(2.5, 0.6, 0.3), (2.0, 1.7, 1.3)]),
            acc([(2.0, 0.9, 0.6), (1.5, 2.4, 1.6)]),
        ],
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (scale, rest) = match args.first().map(|a| a.parse::<f64>()) {
        Some(Ok(k)) => (k, &args[1..]),
        _ => (1.0, &args[..]),
    };
    let mut base = ReplayConfig::default();
    base.conditioning.lever_arm = ekf_core::lever_arm::LeverArm::NONE;
    let mut rs = ReplaySettings::new(device_form(&base));
    for text in rest {
        rs.apply_given(&parse_assignment(text)?);
    }
    let cfg = rs.config(&base);
    let traj = trajectory(scale);
    let start = if moving_start() {
        "moving start, simulated gyro bias 0 (configured: the iNEMO's)"
    } else {
        "10 s still start"
    };
    println!("hand-held motion, accelerations x{scale}, {start}, 100 Hz, 120 s, seeds 1-3");
    for realistic in [false, true] {
        let filters = [FilterKind::Ekf, FilterKind::Gyro, FilterKind::Cf];
        let mut sums = [(0.0, 0.0); 3];
        for seed in 1..=3u64 {
            let mut sensors = SensorModel { lever_arm: [0.0; 3], ..SensorModel::default() };
            if moving_start() {
                sensors.gyro_bias = [0.0; 3];
            }
            if realistic {
                sensors.realism = Some(Realism {
                    gyro_full_scale_dps: 2000.0,
                    accel_full_scale_g: 8.0,
                    ..Realism::INEMO
                });
            }
            let sim = SimConfig { rate_hz: 100.0, duration_s: 120.0, seed, sensors };
            let rows: Vec<_> = Simulator::new(traj, sim).map(|s| s.row).collect();
            if let (Ok(path), 1, false) = (std::env::var("HANDHELD_TRACE"), seed, realistic) {
                let file = std::fs::File::create(&path).map_err(|e| format!("{path}: {e}"))?;
                let cols = TraceColumns { mag: false, depth: false, truth: true };
                let mut w = TraceWriter::new(std::io::BufWriter::new(file), cols)
                    .map_err(|e| e.to_string())?;
                for r in &rows {
                    w.row(r).map_err(|e| e.to_string())?;
                }
                w.finish().map_err(|e| e.to_string())?;
            }
            for (f, s) in filters.iter().zip(sums.iter_mut()) {
                let r = score(&rows, *f, &cfg).ok_or("no truth")?;
                s.0 += r.inclination_deg / 3.0;
                s.1 += r.heading_deg / 3.0;
            }
        }
        let label = if realistic { "realistic" } else { "plain" };
        for (f, s) in filters.iter().zip(sums) {
            println!("{label:9} {:5} inclination {:6.2} heading {:6.2}", f.name(), s.0, s.1);
        }
    }
    Ok(())
}

fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("handheld: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
