//! The hand-held-like motion of [`host_tests::handheld`] (session 8, issue #13): seeds 1–3,
//! plain and realistic sensors. Prints the mean inclination and heading RMSE
//! (`host_tests::real::score`) of the EKF, gyro-only and complementary filters.
//!
//! `cargo run --release -p host-tests --example handheld -- [ACCEL_SCALE] [NAME=VALUE...]`:
//! the linear accelerations scaled by ACCEL_SCALE (default 1, up to 0.5 g; 0.3 for about
//! 0.15 g), the EKF's settings in the device's language. With `HANDHELD_TRACE=FILE` the plain
//! seed-1 trace is written there too (for `scripts/vqf-reference --trace FILE`; the realistic
//! one with `HANDHELD_TRACE_REALISTIC=1`). With
//! `HANDHELD_MOVING_START=1` the motion starts at power-on (no still start) and the simulated
//! gyro has no bias, so the configured bias the EKF starts from (the iNEMO board's, up to
//! 3.4 °/s) is wrong and only learning in motion can correct it. With `HANDHELD_RATE=HZ` the
//! trace is sampled at HZ instead of 100 Hz (the sensors' noise densities held).
use host_tests::config::ReplayConfig;
use host_tests::handheld;
use host_tests::real::score;
use host_tests::replay::FilterKind;
use host_tests::settings::with_assignments;
use host_tests::trace::{TraceColumns, TraceWriter};

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (scale, rest) = match args.first().map(|a| a.parse::<f64>()) {
        Some(Ok(k)) => (k, &args[1..]),
        _ => (1.0, &args[..]),
    };
    let moving_start = std::env::var("HANDHELD_MOVING_START").is_ok_and(|v| v == "1");
    let trace_realistic = std::env::var("HANDHELD_TRACE_REALISTIC").is_ok_and(|v| v == "1");
    let rate_hz = host_tests::sim::rate_from_env("HANDHELD_RATE", handheld::RATE_HZ)?;
    let mut base = ReplayConfig::default();
    base.conditioning.lever_arm = ekf_core::lever_arm::LeverArm::NONE;
    let (cfg, notes) = with_assignments(&base, rest)?;
    for note in notes {
        eprintln!("{note}");
    }
    let start = if moving_start {
        "moving start, simulated gyro bias 0 (configured: the iNEMO's)"
    } else {
        "10 s still start"
    };
    println!("hand-held motion, accelerations x{scale}, {start}, {rate_hz} Hz, 120 s, seeds 1-3");
    for realistic in [false, true] {
        let filters = [FilterKind::Ekf, FilterKind::Gyro, FilterKind::Cf];
        let mut sums = [(0.0, 0.0); 3];
        for seed in 1..=3u64 {
            let rows = handheld::rows(scale, seed, realistic, moving_start, rate_hz);
            if let (Ok(path), 1, true) =
                (std::env::var("HANDHELD_TRACE"), seed, realistic == trace_realistic)
            {
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
