//! Score one filter's settings on the 6 RepoIMU recordings, per file and mean (inclination and
//! heading RMSE, `host_tests::real`): `cargo run --release -p host-tests --example repoimu --
//! [ekf|ukf|ssukf|cf|gyro] [NAME=VALUE...]`, settings in the device's language (`gate.jump=0.1`,
//! `ekf.accel_var_scale=20`; docs/replay.md). They apply on top of `RepoImu::config()` (the
//! defaults with no lever arm), as `replay --set` does on top of the defaults. The data
//! folder is `$REPOIMU_DIR`, else `../shared/data/repoimu`.
use std::process::ExitCode;

use host_tests::real::{score, RepoImu};
use host_tests::replay::FilterKind;
use host_tests::settings::{device_form, parse_assignment, ReplaySettings};

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let filter = match args.first() {
        Some(s) => FilterKind::from_name(s)
            .ok_or_else(|| format!("unknown filter {s:?} (ekf, ukf, ssukf, cf, gyro)"))?,
        None => FilterKind::Ekf,
    };
    let base = RepoImu::config();
    let mut rs = ReplaySettings::new(device_form(&base));
    for text in args.iter().skip(1) {
        rs.apply_given(&parse_assignment(text)?);
    }
    for note in rs.notes() {
        eprintln!("{note}");
    }
    let cfg = rs.config(&base);
    let files = RepoImu::load(&RepoImu::dir())?;
    let (mut si, mut sh) = (0.0, 0.0);
    for (name, rows) in &files {
        let r = score(rows, filter, &cfg).ok_or_else(|| format!("{name}: no rows with truth"))?;
        println!("{name:40} incl {:6.2} heading {:6.2}", r.inclination_deg, r.heading_deg);
        si += r.inclination_deg;
        sh += r.heading_deg;
    }
    let n = files.len() as f64;
    println!("mean {:34} incl {:6.2} heading {:6.2}", filter.name(), si / n, sh / n);
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
