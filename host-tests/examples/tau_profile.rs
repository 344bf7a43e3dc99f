//! Where the EKF's time constant sits on the real recordings (issue #35): for each BROAD trial
//! and RepoIMU file, the share of the scored rows at each time constant the rule can choose
//! (raw samples, then `2.5 s·0.7^k`), how often it changes per minute, and the inclination
//! RMSE. With `WINDOWS=<trial prefix>` it prints that trial second by second instead: the
//! error and the time constants in use, to see what a change of the time constant does.
//!
//! `cargo run --release -p host-tests --example tau_profile` (defaults as `realdata`:
//! `RepoImu::config()`, the defaults with no lever arm; `NAME=VALUE` settings on top).
use std::{cell::RefCell, collections::BTreeMap, process::ExitCode, rc::Rc};

use ekf_core::{
    conditioning::Conditioner, ekf::Ekf, filter::AttitudeFilter, flags::Flags,
    quaternion::Quaternion, sample::ImuSample, vec3::Vec3,
};
use host_tests::real::{errors, Broad, RepoImu};
use host_tests::replay::replay_rows;
use host_tests::settings::with_assignments;
use host_tests::trace::TraceRow;

/// The EKF, noting its time constant after every update.
struct Noting {
    ekf: Ekf,
    taus: Rc<RefCell<Vec<f32>>>,
}

impl AttitudeFilter for Noting {
    fn name(&self) -> &'static str {
        self.ekf.name()
    }
    fn update(&mut self, sample: &ImuSample) -> Flags {
        let f = self.ekf.update(sample);
        self.taus.borrow_mut().push(self.ekf.time_constant());
        f
    }
    fn attitude(&self) -> Quaternion {
        self.ekf.attitude()
    }
    fn gyro_bias(&self) -> Vec3 {
        self.ekf.gyro_bias()
    }
    fn is_initialised(&self) -> bool {
        self.ekf.is_initialised()
    }
    fn set_yaw(&mut self, yaw: f32) {
        self.ekf.set_yaw(yaw)
    }
    fn set_attitude(&mut self, q: Quaternion, bias: Vec3) {
        self.ekf.set_attitude(q, bias)
    }
    fn reset(&mut self) {
        self.ekf.reset()
    }
}

/// One row with truth: time, inclination error (degrees), scored, time constant (s).
struct Row {
    t: f64,
    err: f64,
    scored: bool,
    tau: f32,
}

fn replay(rows: &[TraceRow], cfg: &host_tests::config::ReplayConfig) -> Vec<Row> {
    let taus = Rc::new(RefCell::new(Vec::new()));
    let mut f = Noting { ekf: Ekf::new(cfg.settings), taus: Rc::clone(&taus) };
    let mut cond = Conditioner::new(cfg.conditioning);
    let mut out = Vec::new();
    replay_rows(rows.iter().map(|r| Ok(*r)), &mut f, &mut cond, 0.0, |row, est| {
        let tau = taus.borrow().last().copied().unwrap_or(f32::NAN);
        if let Some(t) = row.truth {
            let (i, _) = errors(est.q.map(f64::from), t.map(f64::from));
            out.push(Row { t: row.t, err: i.to_degrees(), scored: row.scored(), tau });
        }
        Ok(())
    })
    .expect("in-memory replay cannot fail");
    out
}

/// The time constant's label: `raw` or its value.
fn label(tau: f32) -> String {
    if tau == 0.0 {
        "raw".into()
    } else {
        format!("{tau:.2}")
    }
}

fn profile(name: &str, rows: &[Row]) {
    let scored: Vec<&Row> = rows.iter().filter(|r| r.scored).collect();
    if scored.is_empty() {
        return;
    }
    let mut shares: BTreeMap<u32, usize> = BTreeMap::new();
    for r in &scored {
        *shares.entry(r.tau.to_bits()).or_default() += 1;
    }
    let changes = scored.windows(2).filter(|w| w[0].tau != w[1].tau).count();
    let minutes = (scored.last().unwrap().t - scored[0].t) / 60.0;
    let rmse = (scored.iter().map(|r| r.err * r.err).sum::<f64>() / scored.len() as f64).sqrt();
    let mut by_tau: Vec<(f32, usize)> =
        shares.into_iter().map(|(b, n)| (f32::from_bits(b), n)).collect();
    by_tau.sort_by(|a, b| b.0.total_cmp(&a.0));
    let shares: Vec<String> = by_tau
        .iter()
        .map(|(t, n)| format!("{} {:.0}%", label(*t), 100.0 * *n as f64 / scored.len() as f64))
        .collect();
    println!(
        "{:44} {rmse:5.2}°  {:6.0} changes/min  {}",
        name.trim_end_matches(".csv"),
        changes as f64 / minutes.max(1e-9),
        shares.join(", ")
    );
}

fn windows(rows: &[Row]) {
    println!(
        "{:>6} {:>7} {:>6}  time constants in use (share of the second)",
        "t (s)", "scored", "incl"
    );
    let mut start = 0;
    while start < rows.len() {
        let t0 = rows[start].t;
        let end =
            rows[start..].iter().position(|r| r.t - t0 >= 1.0).map_or(rows.len(), |k| start + k);
        let w = &rows[start..end];
        let rms = (w.iter().map(|r| r.err * r.err).sum::<f64>() / w.len() as f64).sqrt();
        let mut taus: BTreeMap<u32, usize> = BTreeMap::new();
        for r in w {
            *taus.entry(r.tau.to_bits()).or_default() += 1;
        }
        let taus: Vec<String> = taus
            .iter()
            .rev()
            .map(|(b, n)| {
                format!("{} {:.0}%", label(f32::from_bits(*b)), 100.0 * *n as f64 / w.len() as f64)
            })
            .collect();
        let scored = w.iter().filter(|r| r.scored).count();
        println!("{t0:6.0} {scored:7} {rms:6.2}  {}", taus.join(", "));
        start = end;
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (cfg, notes) = with_assignments(&RepoImu::config(), &args)?;
    for note in notes {
        eprintln!("{note}");
    }
    let mut files = Broad::load(&Broad::dir())?;
    files.extend(RepoImu::load(&RepoImu::dir())?);
    if let Ok(prefix) = std::env::var("WINDOWS") {
        let (name, rows) = files
            .iter()
            .find(|(n, _)| n.starts_with(&prefix))
            .ok_or_else(|| format!("no recording starts with {prefix:?}"))?;
        println!("{name}");
        windows(&replay(rows, &cfg));
        return Ok(());
    }
    println!(
        "{:44} {:>6}  {:>18}  share of the scored rows at each time constant (s)",
        "", "incl", ""
    );
    for (name, rows) in &files {
        profile(name, &replay(rows, &cfg));
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
