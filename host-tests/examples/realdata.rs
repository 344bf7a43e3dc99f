//! Score one filter's settings on every real recording: the 13 BROAD trials and the 6 RepoIMU
//! files, per file and mean (inclination and heading RMSE, `host_tests::real`), beside VQF's
//! figures: `cargo run --release -p host-tests --example realdata -- [ekf|ukf|ssukf|cf|gyro]
//! [NAME=VALUE...]`, settings in the device's language (`docs/replay.md`) on top of
//! `RepoImu::config()` (the defaults with no lever arm). `REALDATA=broad` or `=repoimu` runs
//! one set only. Data folders: `$BROAD_DIR`, `$REPOIMU_DIR`, else `../shared/data/…`.
use std::process::ExitCode;
use std::thread;

use host_tests::real::{score, Broad, RepoImu, ScoreRmse};
use host_tests::replay::FilterKind;
use host_tests::settings::with_assignments;

fn table(
    title: &str,
    files: &[(String, Vec<host_tests::trace::TraceRow>)],
    vqf: &[(f64, f64)],
    filter: FilterKind,
    cfg: &host_tests::config::ReplayConfig,
) -> Result<(f64, f64), String> {
    // Two at a time (the machine's two cores).
    let mut scores: Vec<Option<ScoreRmse>> = vec![None; files.len()];
    for (chunk, out) in files.chunks(2).zip(scores.chunks_mut(2)) {
        thread::scope(|s| {
            let hs: Vec<_> =
                chunk.iter().map(|(_, rows)| s.spawn(move || score(rows, filter, cfg))).collect();
            for (h, o) in hs.into_iter().zip(out.iter_mut()) {
                *o = h.join().expect("scoring thread");
            }
        });
    }
    println!("{title}: {:46} {:>13} {:>13}", "", "incl  head", "VQF incl head");
    let (mut si, mut sh) = (0.0, 0.0);
    for (k, ((name, _), r)) in files.iter().zip(&scores).enumerate() {
        let r = r.ok_or_else(|| format!("{name}: no rows with truth"))?;
        let v = vqf.get(k).map_or(String::new(), |v| format!("{:6.2} {:6.2}", v.0, v.1));
        println!(
            "  {:52} {:6.2} {:6.2}   {v}",
            name.trim_end_matches(".csv"),
            r.inclination_deg,
            r.heading_deg
        );
        si += r.inclination_deg;
        sh += r.heading_deg;
    }
    let n = files.len() as f64;
    println!("  {:52} {:6.2} {:6.2}", format!("mean ({})", filter.name()), si / n, sh / n);
    Ok((si / n, sh / n))
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let filter = match args.first() {
        Some(s) => FilterKind::from_name(s)
            .ok_or_else(|| format!("unknown filter {s:?} (ekf, ukf, ssukf, cf, gyro)"))?,
        None => FilterKind::Ekf,
    };
    let (cfg, notes) = with_assignments(&RepoImu::config(), args.get(1..).unwrap_or(&[]))?;
    for note in notes {
        eprintln!("{note}");
    }
    let which = std::env::var("REALDATA").unwrap_or_default();
    if which != "repoimu" {
        let files = Broad::load(&Broad::dir())?;
        let vqf: Vec<_> = Broad::TRIALS.iter().map(|t| t.1).collect();
        table("BROAD", &files, &vqf, filter, &cfg)?;
    }
    if which != "broad" {
        let files = RepoImu::load(&RepoImu::dir())?;
        table("RepoIMU", &files, &[], filter, &cfg)?;
    }
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
