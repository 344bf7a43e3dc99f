//! Accuracy benchmark: every filter on every scenario, all filters on the same simulated data,
//! seeds 1..=5, through the CLI's replay loop (`host_tests::accuracy`). Prints (a) the RMSE
//! table beside the source's Table 16, (b) the EKF's goals, with plain and with realistic
//! sensor errors, (c) the hour runs' yaw drift, (d) time per update on this host beside the
//! source's Table 15; then (e) every filter on the 6 RepoIMU recordings (real truth,
//! `host_tests::real`) beside VQF's published figures, (f) every filter on the 13 BROAD trials
//! (hand-held, real truth) beside VQF 2.1 online's figures, and (g) the robustness scenarios'
//! tilt RMSE, plain and realistic, every filter.
//!
//! ```sh
//! cargo bench -p host-tests --bench accuracy                       # print
//! cargo bench -p host-tests --bench accuracy -- --markdown docs/accuracy.md
//! ```
//! `--markdown PATH` also rewrites the section between `<!-- BEGIN accuracy-results -->` and
//! `<!-- END accuracy-results -->` of PATH (relative paths are taken from the workspace root),
//! and, where PATH has them, the sections `real-data` (e), `broad-data` (f) and
//! `robust-results` (g) (a missing one is only printed). The data folders are `$REPOIMU_DIR`
//! and `$BROAD_DIR`, else `shared/data/repoimu` and `shared/data/broad` beside the workspace;
//! a missing one is reported on stderr and in its section.
//! `--seeds N` changes the number of seeds (default 5); `--threads N` the worker threads
//! (default: the available parallelism). A missed EKF goal is reported (MISS), not an error:
//! `docs/accuracy.md` explains the misses, and `tests/accuracy.rs` guards against regressions.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use ekf_core::conditioning::Conditioner;
use ekf_core::{ImuSample, Vec3};
use host_tests::accuracy::{
    evaluate, replace_section, replay_config, run_with, scenario_number, simulate, source_axis,
    source_rmse, source_time_per_cycle, thread_cpu_s, RunResult, GOALS, HOUR_SCENARIOS, RATE_HZ,
    ROBUST_GOALS, ROBUST_SCENARIOS, TABLE16_SCENARIOS,
};
use host_tests::real::{score, Broad, RepoImu, ScoreRmse};
use host_tests::replay::FilterKind;
use host_tests::sim::{Scenario, SimOptions};

const SECTION: &str = "accuracy-results";
const REAL_SECTION: &str = "real-data";
const BROAD_SECTION: &str = "broad-data";
const ROBUST_SECTION: &str = "robust-results";

/// The real-data goal: mean inclination RMSE below VQF 2.1 online's, heading below 11.0°.
const REAL_GOAL_INCL: f64 = RepoImu::VQF_ONLINE.0;
const REAL_GOAL_HEADING: f64 = 11.0;
/// The BROAD goals for `ekf`: mean inclination and heading RMSE over the 13 trials at most VQF
/// 2.1 online's.
const BROAD_GOAL_INCL: f64 = Broad::VQF_ONLINE.0;
const BROAD_GOAL_HEADING: f64 = Broad::VQF_ONLINE.1;
const COMMAND: &str = "cargo bench -p host-tests --bench accuracy -- --markdown docs/accuracy.md";

struct Args {
    markdown: Option<PathBuf>,
    seeds: u64,
    threads: usize,
}

fn parse_args() -> Args {
    let mut a = Args {
        markdown: None,
        seeds: 5,
        threads: std::thread::available_parallelism().map_or(2, |n| n.get()),
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--markdown" => a.markdown = it.next().map(PathBuf::from),
            "--seeds" => a.seeds = it.next().and_then(|s| s.parse().ok()).unwrap_or(5).max(1),
            "--threads" => {
                a.threads = it.next().and_then(|s| s.parse().ok()).unwrap_or(1).max(1);
            }
            // `cargo bench` passes `--bench`; test-name filters are not supported.
            _ => {}
        }
    }
    a
}

/// Results per (scenario, filter): one per seed, in seed order.
type Results = BTreeMap<(usize, usize), Vec<RunResult>>;

fn scenario_list() -> Vec<Scenario> {
    let mut v: Vec<Scenario> = TABLE16_SCENARIOS.to_vec();
    v.push(Scenario::GyroNoise);
    v.push(Scenario::AccelNoise);
    v.extend(HOUR_SCENARIOS);
    v
}

fn run_all(scenarios: &[Scenario], seeds: u64, threads: usize) -> Results {
    // Hour runs first so the long jobs do not end up last on one thread.
    let mut jobs: Vec<(usize, u64)> = Vec::new();
    for (si, s) in scenarios.iter().enumerate() {
        if HOUR_SCENARIOS.contains(s) {
            jobs.extend((1..=seeds).map(|seed| (si, seed)));
        }
    }
    for (si, s) in scenarios.iter().enumerate() {
        if !HOUR_SCENARIOS.contains(s) {
            jobs.extend((1..=seeds).map(|seed| (si, seed)));
        }
    }
    let per_job = pool(&jobs, threads, |&(si, seed)| {
        let scenario = scenarios[si];
        let rows = simulate(scenario, None, seed);
        let cfg = replay_config(scenario);
        FilterKind::ALL.map(|f| evaluate(&rows, f, &cfg))
    });
    let mut all: Vec<(usize, u64, usize, RunResult)> = Vec::new();
    for (&(si, seed), rs) in jobs.iter().zip(per_job) {
        all.extend(rs.into_iter().enumerate().map(|(fi, r)| (si, seed, fi, r)));
    }
    all.sort_by_key(|&(si, seed, fi, _)| (si, fi, seed));
    let mut res = Results::new();
    for (si, _, fi, r) in all {
        res.entry((si, fi)).or_default().push(r);
    }
    res
}

/// `f` on every job on `threads` worker threads sharing a job counter; results in job order.
fn pool<J: Sync, R: Send>(jobs: &[J], threads: usize, f: impl Fn(&J) -> R + Sync) -> Vec<R> {
    let next = AtomicUsize::new(0);
    let out: Mutex<Vec<(usize, R)>> = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| loop {
                let j = next.fetch_add(1, Ordering::Relaxed);
                let Some(job) = jobs.get(j) else { return };
                let r = f(job);
                out.lock().unwrap().push((j, r));
            });
        }
    });
    let mut all = out.into_inner().unwrap();
    all.sort_by_key(|&(j, _)| j);
    all.into_iter().map(|(_, r)| r).collect()
}

/// Scores on the RepoIMU files: per filter (in [`FilterKind::ALL`] order) and then the EKF
/// with `real::foreign_config` (`replay --foreign`), one per file.
struct RealResults {
    files: Vec<(String, usize)>,
    per_filter: Vec<Vec<ScoreRmse>>,
    foreign: Vec<ScoreRmse>,
}

/// Every filter of [`FilterKind::ALL`], the slow ones first (the UKFs, then the EKF), so that
/// the long jobs do not end up last on one thread.
fn slow_first() -> impl Iterator<Item = FilterKind> {
    let order = [FilterKind::Ukf, FilterKind::SsUkf, FilterKind::Ekf, FilterKind::Cf];
    order.into_iter().chain(FilterKind::ALL.into_iter().filter(move |f| !order.contains(f)))
}

fn run_real(threads: usize) -> Result<RealResults, String> {
    let files = RepoImu::load(&RepoImu::dir())?;
    // (filter, foreign, file); the UKFs first (the slow ones).
    let mut jobs: Vec<(FilterKind, bool, usize)> = Vec::new();
    for f in slow_first() {
        jobs.extend((0..files.len()).map(|i| (f, false, i)));
    }
    jobs.extend((0..files.len()).map(|i| (FilterKind::Ekf, true, i)));
    let (plain, foreign) = (RepoImu::config(), host_tests::real::foreign_config());
    let scores = pool(&jobs, threads, |&(f, fo, i)| {
        score(&files[i].1, f, if fo { &foreign } else { &plain }).expect("rows with truth")
    });
    let mut per_filter = vec![Vec::new(); FilterKind::ALL.len()];
    let mut foreign_scores = Vec::new();
    for (&(f, fo, _), s) in jobs.iter().zip(scores) {
        if fo {
            foreign_scores.push(s);
        } else {
            per_filter[FilterKind::ALL.iter().position(|&x| x == f).unwrap()].push(s);
        }
    }
    Ok(RealResults {
        files: files.iter().map(|(n, r)| (n.clone(), r.len())).collect(),
        per_filter,
        foreign: foreign_scores,
    })
}

/// Scores on the BROAD trials: the trials' names and rows, and per filter (in
/// [`FilterKind::ALL`] order) one score per trial, in [`Broad::TRIALS`] order.
struct BroadResults {
    trials: Vec<(String, usize)>,
    per_filter: Vec<Vec<ScoreRmse>>,
}

/// Every filter on the 13 BROAD trials with [`RepoImu::config`] (the defaults, no lever arm: the
/// RepoIMU table's configuration), run from each trial's first row and scored over its
/// `movement = 1` rows with truth.
fn run_broad(threads: usize) -> Result<BroadResults, String> {
    let trials = Broad::load(&Broad::dir())?;
    // (filter, trial); the UKFs first: 285.7 Hz, about 55k rows a trial.
    let mut jobs: Vec<(FilterKind, usize)> = Vec::new();
    for f in slow_first() {
        jobs.extend((0..trials.len()).map(|i| (f, i)));
    }
    let cfg = RepoImu::config();
    let scores = pool(&jobs, threads, |&(f, i)| {
        score(&trials[i].1, f, &cfg).ok_or_else(|| format!("{}: no scored row", trials[i].0))
    });
    let mut per_filter = vec![Vec::new(); FilterKind::ALL.len()];
    for (&(f, _), s) in jobs.iter().zip(scores) {
        per_filter[FilterKind::ALL.iter().position(|&x| x == f).unwrap()].push(s?);
    }
    Ok(BroadResults {
        trials: trials.iter().map(|(n, r)| (n.clone(), r.len())).collect(),
        per_filter,
    })
}

/// Robustness runs: per (scenario, filter, realistic) the results of seeds 1..=seeds.
type RobustResults = BTreeMap<(usize, usize, bool), Vec<RunResult>>;

fn run_robust(seeds: u64, threads: usize) -> RobustResults {
    let mut jobs = Vec::new();
    for si in 0..ROBUST_SCENARIOS.len() {
        for realistic in [false, true] {
            for seed in 1..=seeds {
                for fi in 0..FilterKind::ALL.len() {
                    jobs.push((si, fi, realistic, seed));
                }
            }
        }
    }
    let res = pool(&jobs, threads, |&(si, fi, realistic, seed)| {
        let opts = SimOptions { rate_hz: RATE_HZ, seed, realistic, ..SimOptions::default() };
        run_with(ROBUST_SCENARIOS[si], &opts, FilterKind::ALL[fi])
    });
    let mut out = RobustResults::new();
    for (&(si, fi, realistic, _), r) in jobs.iter().zip(res) {
        out.entry((si, fi, realistic)).or_default().push(r);
    }
    out
}

/// The EKF on the goals' scenarios with realistic sensor errors: per scenario, seeds in order.
fn run_goals_realistic(seeds: u64, threads: usize) -> BTreeMap<usize, Vec<RunResult>> {
    let mut scenarios: Vec<Scenario> = Vec::new();
    for g in GOALS {
        if !scenarios.contains(&g.scenario) {
            scenarios.push(g.scenario);
        }
    }
    // Hour runs first.
    scenarios.sort_by_key(|s| !HOUR_SCENARIOS.contains(s));
    let mut jobs = Vec::new();
    for &s in &scenarios {
        jobs.extend((1..=seeds).map(|seed| (s, seed)));
    }
    let res = pool(&jobs, threads, |&(s, seed)| {
        let opts = SimOptions { rate_hz: RATE_HZ, seed, realistic: true, ..SimOptions::default() };
        run_with(s, &opts, FilterKind::Ekf)
    });
    let mut out: BTreeMap<usize, Vec<RunResult>> = BTreeMap::new();
    for (&(s, _), r) in jobs.iter().zip(res) {
        out.entry(Scenario::ALL.iter().position(|&x| x == s).unwrap()).or_default().push(r);
    }
    out
}

fn met(pass: bool) -> &'static str {
    if pass {
        "met"
    } else {
        "**MISS**"
    }
}

/// Rewrite section `name` of `doc` with `content`; a missing section is reported, not an error.
fn update_optional_section(doc: &mut String, path: &Path, name: &str, content: &str) {
    match replace_section(doc, name, content) {
        Some(new) => *doc = new,
        None => eprintln!(
            "note: {}: no <!-- BEGIN {name} --> ... <!-- END {name} --> section: printed only",
            path.display()
        ),
    }
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    s / n.max(1) as f64
}

fn max(v: impl Iterator<Item = f64>) -> f64 {
    v.fold(f64::NEG_INFINITY, f64::max)
}

fn scenario_label(s: Scenario) -> String {
    match scenario_number(s) {
        Some(n) => format!("{n} {}", s.name()),
        None => s.name().to_string(),
    }
}

/// Runs of each filter in the host timing, the best taken (load bursts on a shared machine
/// last seconds).
const TIMING_REPS: usize = 7;

/// Time per `update` (plus reading the attitude and Euler angles, as the replay does) of every
/// filter over `samples`; best of `reps` runs, ns, by the thread's CPU time where available.
fn time_per_update(samples: &[ImuSample], reps: usize) -> Vec<f64> {
    let cfg = replay_config(Scenario::RampHour);
    FilterKind::ALL
        .iter()
        .map(|&k| {
            let mut best = f64::INFINITY;
            for _ in 0..reps {
                let mut f = cfg.make_filter(k);
                let (start, cpu) = (Instant::now(), thread_cpu_s());
                for s in samples {
                    std::hint::black_box(f.update(std::hint::black_box(s)));
                    std::hint::black_box((f.attitude(), f.euler()));
                }
                let secs = match (cpu, thread_cpu_s()) {
                    (Some(a), Some(b)) => b - a,
                    _ => start.elapsed().as_secs_f64(),
                };
                best = best.min(secs * 1e9 / samples.len() as f64);
            }
            best
        })
        .collect()
}

fn conditioned_samples(scenario: Scenario, seed: u64) -> Vec<ImuSample> {
    let rows = simulate(scenario, None, seed);
    let cfg = replay_config(scenario);
    let mut cond = Conditioner::new(cfg.conditioning);
    let bias = cfg.settings.init.gyro_bias;
    let mut prev = None;
    rows.iter()
        .map(|r| {
            let dt = prev.map_or(1.0 / 50.0, |p| r.t - p) as f32;
            prev = Some(r.t);
            // Timing input only: the lever arm with the configured bias, which the EKF's
            // estimate starts from.
            let (gyro, accel) =
                cond.condition(dt, Vec3::from_array(r.gyro), Vec3::from_array(r.accel), bias);
            ImuSample { dt, gyro, accel, mag: None }
        })
        .collect()
}

fn main() {
    let args = parse_args();
    let scenarios = scenario_list();
    let started = Instant::now();
    eprintln!(
        "accuracy: {} scenarios x {} seeds x {} filters on {} threads ...",
        scenarios.len(),
        args.seeds,
        FilterKind::ALL.len(),
        args.threads
    );
    let res = run_all(&scenarios, args.seeds, args.threads);
    let goals_realistic = run_goals_realistic(args.seeds, args.threads);
    let accuracy_s = started.elapsed().as_secs_f64();
    eprintln!("accuracy runs: {accuracy_s:.1} s; RepoIMU ...");
    let real_started = Instant::now();
    let real = run_real(args.threads);
    let real_s = real_started.elapsed().as_secs_f64();
    eprintln!("RepoIMU: {real_s:.1} s; BROAD ...");
    let broad_started = Instant::now();
    let broad = run_broad(args.threads);
    let broad_s = broad_started.elapsed().as_secs_f64();
    eprintln!("BROAD: {broad_s:.1} s; robustness ...");
    let robust_started = Instant::now();
    let robust = run_robust(args.seeds, args.threads);
    let robust_s = robust_started.elapsed().as_secs_f64();
    eprintln!("robustness: {robust_s:.1} s; timing ...");
    let timing_scenario = Scenario::RampHour;
    let samples = conditioned_samples(timing_scenario, 1);
    let ns = time_per_update(&samples, TIMING_REPS);
    let sidx = |s: Scenario| scenarios.iter().position(|&x| x == s).unwrap();
    let fidx = |f: FilterKind| FilterKind::ALL.iter().position(|&x| x == f).unwrap();
    let runs = |s: Scenario, f: FilterKind| &res[&(sidx(s), fidx(f))];

    let mut md = String::new();
    let seeds = args.seeds;
    let _ = writeln!(
        md,
        "Generated by `{COMMAND}` (seeds 1–{seeds}, 50 Hz, every filter with its default \
         settings on the same simulated data, through the replay loop of the `replay` command).\n"
    );

    // (a) RMSE table.
    let _ = writeln!(md, "### RMSE beside the source's Table 16\n");
    let _ = writeln!(
        md,
        "Degrees, mean over seeds 1–{seeds}, rows after the 10 s initialisation window. \
         *source* is the source's Table 16 value for the axis in brackets (pitch for the pitch \
         manoeuvres 1, 3, 4, 6; yaw for 5; all three for 2), *ratio* = source / ours (> 1: \
         ours is smaller).\n"
    );
    let _ = writeln!(md, "| scenario | filter | roll | pitch | yaw | source | ratio |");
    let _ = writeln!(md, "|---|---|---|---|---|---|---|");
    for &s in scenarios.iter().filter(|s| !HOUR_SCENARIOS.contains(s)) {
        for &f in &FilterKind::ALL {
            let r = runs(s, f);
            let m = [0, 1, 2].map(|a| mean(r.iter().map(|x| x.rmse_deg[a])));
            let (src, ratio) = if scenario_number(s) == Some(2) {
                let v: Vec<Option<f64>> = (0..3).map(|a| source_rmse(f, s, a)).collect();
                if v.iter().all(Option::is_some) {
                    let v: Vec<f64> = v.into_iter().flatten().collect();
                    (
                        format!("{:.4} / {:.4} / {:.4}", v[0], v[1], v[2]),
                        format!("{:.2} / {:.2} / {:.2}", v[0] / m[0], v[1] / m[1], v[2] / m[2]),
                    )
                } else {
                    ("—".into(), "—".into())
                }
            } else {
                match source_axis(s).and_then(|a| source_rmse(f, s, a).map(|v| (a, v))) {
                    Some((a, v)) => (
                        format!("{v:.4} ({})", ["roll", "pitch", "yaw"][a]),
                        format!("{:.2}", v / m[a]),
                    ),
                    None => ("—".into(), "—".into()),
                }
            };
            let _ = writeln!(
                md,
                "| {} | {} | {:.4} | {:.4} | {:.4} | {src} | {ratio} |",
                scenario_label(s),
                f.name(),
                m[0],
                m[1],
                m[2]
            );
        }
    }

    // (b) Goals.
    let _ = writeln!(md, "\n### Goals for `Ekf` with default settings\n");
    let _ = writeln!(
        md,
        "Measured: mean over seeds 1–{seeds} (the verdict); worst: the worst seed. Drift and \
         final yaw error are absolute values (see the definitions above). *realistic*: the \
         same runs with the realistic sensor errors the filter does not model \
         (`simulate --realistic`: bias random walk and flicker, scale factors, misalignment, \
         residual accelerometer bias, quantisation, jitter, repeated samples, vibration; \
         `src/sim.rs`), mean (worst seed) and verdict; the goals are set for the plain model.\n"
    );
    let _ = writeln!(
        md,
        "| goal | metric | measured | worst seed | goal | result | realistic | realistic result |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|");
    let mut misses = Vec::new();
    let mut misses_realistic = Vec::new();
    for g in GOALS {
        let r = runs(g.scenario, FilterKind::Ekf);
        let m = mean(r.iter().map(|x| g.metric.of(x)));
        let w = max(r.iter().map(|x| g.metric.of(x)));
        let pass = m <= g.max;
        if !pass {
            misses.push(g.label);
        }
        let rr = &goals_realistic[&Scenario::ALL.iter().position(|&x| x == g.scenario).unwrap()];
        let rm = mean(rr.iter().map(|x| g.metric.of(x)));
        let rw = max(rr.iter().map(|x| g.metric.of(x)));
        let rpass = rm <= g.max;
        if !rpass {
            misses_realistic.push(g.label);
        }
        let _ = writeln!(
            md,
            "| {} | {} | {:.4} | {:.4} | ≤ {} | {} | {:.4} ({:.4}) | {} |",
            g.label,
            g.metric.describe(),
            m,
            w,
            g.max,
            if pass { "PASS" } else { "**MISS**" },
            rm,
            rw,
            if rpass { "PASS" } else { "**MISS**" }
        );
    }

    // (c) Hour runs.
    let _ = writeln!(md, "\n### Hour runs: yaw drift\n");
    let _ = writeln!(
        md,
        "3600 s at 50 Hz. *drift*: least-squares slope of the (unwrapped) yaw error after the \
         window, °/h; *final*: the yaw error at the end of the hour, °; *max*: the largest \
         |yaw error|, °. Mean of the absolute values over seeds 1–{seeds}, worst seed in \
         brackets. `bias-off` is replayed without the initialisation window's bias estimate \
         (`replay --no-init-bias`), so every filter starts with a z bias 0.05 °/s wrong.\n"
    );
    let _ = writeln!(
        md,
        "| scenario | filter | drift (°/h) | final (°) | max (°) | roll / pitch RMSE (°) |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|");
    for &s in &HOUR_SCENARIOS {
        for &f in &FilterKind::ALL {
            let r = runs(s, f);
            let d = r.iter().map(|x| x.yaw_drift_dph.abs());
            let fe = r.iter().map(|x| x.final_yaw_err_deg.abs());
            let mx = r.iter().map(|x| x.max_yaw_err_deg);
            let _ = writeln!(
                md,
                "| {} | {} | {:.3} ({:.3}) | {:.3} ({:.3}) | {:.3} ({:.3}) | {:.4} / {:.4} |",
                s.name(),
                f.name(),
                mean(d.clone()),
                max(d),
                mean(fe.clone()),
                max(fe),
                mean(mx.clone()),
                max(mx),
                mean(r.iter().map(|x| x.rmse_deg[0])),
                mean(r.iter().map(|x| x.rmse_deg[1])),
            );
        }
    }

    // (d) Timing.
    let _ = writeln!(md, "\n### Time per update on the host\n");
    let _ = writeln!(
        md,
        "`update` plus reading the attitude and Euler angles, over the {} conditioned samples \
         of `{}` (seed 1), best of {TIMING_REPS} runs, one thread, timed by the thread's CPU time; ns per \
         update on the machine that generated this file (it varies from run to run and machine to machine: compare the \
         ratios). *source*: the source's MATLAB time per cycle (Table 15) relative to its EKF.\n",
        samples.len(),
        timing_scenario.name()
    );
    let _ = writeln!(md, "| filter | ns/update | relative to EKF | source relative |");
    let _ = writeln!(md, "|---|---|---|---|");
    let ekf_ns = ns[fidx(FilterKind::Ekf)];
    for (i, &f) in FilterKind::ALL.iter().enumerate() {
        let src = match source_time_per_cycle(f) {
            Some(v) => format!("{:.2}", v / 62.0),
            None => "—".into(),
        };
        let _ = writeln!(md, "| {} | {:.0} | {:.2} | {src} |", f.name(), ns[i], ns[i] / ekf_ns);
    }

    // (e) Real data.
    let mut real_md = String::new();
    match &real {
        Ok(real) => write_real(&mut real_md, real),
        Err(e) => {
            eprintln!("RepoIMU data not found: {e}");
            let _ = writeln!(real_md, "RepoIMU data not found: {e}");
        }
    }

    // (f) BROAD.
    let mut broad_md = String::new();
    let broad_summary = match &broad {
        Ok(broad) => write_broad(&mut broad_md, broad),
        Err(e) => {
            let msg = format!("BROAD data not found or unreadable: {e} (set BROAD_DIR)");
            eprintln!("{msg}");
            let _ = writeln!(broad_md, "{msg}");
            msg
        }
    };

    // (g) Robustness.
    let mut robust_md = String::new();
    let robust_misses = write_robust(&mut robust_md, &robust, seeds);

    println!("{md}");
    println!("{real_md}");
    println!("{broad_md}");
    println!("{robust_md}");
    if misses.is_empty() {
        println!("EKF goals: all PASS");
    } else {
        println!("EKF goals missed: {}", misses.join(", "));
    }
    if misses_realistic.is_empty() {
        println!("EKF goals with realistic sensors: all PASS");
    } else {
        println!("EKF goals missed with realistic sensors: {}", misses_realistic.join(", "));
    }
    if robust_misses.is_empty() {
        println!("EKF robustness goals: all PASS");
    } else {
        println!("EKF robustness goals missed: {}", robust_misses.join(", "));
    }
    println!("{broad_summary}");
    println!(
        "wall time: accuracy runs {accuracy_s:.1} s, RepoIMU {real_s:.1} s, BROAD {broad_s:.1} s, \
         robustness {robust_s:.1} s, total {:.1} s",
        started.elapsed().as_secs_f64()
    );

    if let Some(path) = args.markdown {
        let path = if path.is_relative() {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
        } else {
            path
        };
        let doc = match std::fs::read_to_string(&path) {
            Ok(d) => d,
            Err(e) => {
                eprintln!("error: {}: {e}", path.display());
                std::process::exit(1);
            }
        };
        let Some(mut new) = replace_section(&doc, SECTION, &md) else {
            eprintln!(
                "error: {}: no <!-- BEGIN {SECTION} --> ... <!-- END {SECTION} --> section",
                path.display()
            );
            std::process::exit(1);
        };
        update_optional_section(&mut new, &path, REAL_SECTION, &real_md);
        update_optional_section(&mut new, &path, BROAD_SECTION, &broad_md);
        update_optional_section(&mut new, &path, ROBUST_SECTION, &robust_md);
        if let Err(e) = std::fs::write(&path, new) {
            eprintln!("error: {}: {e}", path.display());
            std::process::exit(1);
        }
        eprintln!("wrote the results sections of {}", path.display());
    }
}

/// Table (e): every filter on the RepoIMU recordings beside VQF, then the EKF per file.
fn write_real(md: &mut String, real: &RealResults) {
    let n = real.files.len();
    let rows: usize = real.files.iter().map(|f| f.1).sum();
    let _ = writeln!(md, "### Real data: the RepoIMU pendulum recordings\n");
    let _ = writeln!(
        md,
        "Generated by `{COMMAND}`. The {n} recordings of `shared/data/repoimu` ({rows} rows, \
         Xsens MTi on a pendulum, optical truth; `shared/data/repoimu/README.md`), every filter \
         with its default settings and no lever arm (`RepoImu::config`; *--foreign*: also the \
         configured gyro bias zero, as `replay --foreign`), scored by `host_tests::real` over \
         every row, the initialisation window included: inclination RMSE, and heading RMSE \
         with its circular mean removed, degrees, mean over the {n} files. VQF 2.1: its \
         published figures on the same files. Goal: mean inclination < {REAL_GOAL_INCL}° \
         (VQF online), heading < {REAL_GOAL_HEADING}°.\n"
    );
    let _ = writeln!(
        md,
        "| filter | config | inclination (°) | heading (°) | inclination < {REAL_GOAL_INCL}° | \
         heading < {REAL_GOAL_HEADING}° |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|");
    let row = |md: &mut String, name: &str, config: &str, s: &[ScoreRmse]| {
        let i = mean(s.iter().map(|x| x.inclination_deg));
        let h = mean(s.iter().map(|x| x.heading_deg));
        let _ = writeln!(
            md,
            "| {name} | {config} | {i:.2} | {h:.2} | {} | {} |",
            met(i < REAL_GOAL_INCL),
            met(h < REAL_GOAL_HEADING)
        );
    };
    for (fi, f) in FilterKind::ALL.iter().enumerate() {
        row(md, f.name(), "no lever arm", &real.per_filter[fi]);
        if *f == FilterKind::Ekf {
            row(md, f.name(), "--foreign", &real.foreign);
        }
    }
    for (name, (i, h)) in
        [("VQF 2.1 online", RepoImu::VQF_ONLINE), ("VQF 2.1 offline", RepoImu::VQF_OFFLINE)]
    {
        let _ = writeln!(md, "| {name} | published | {i:.2} | {h:.2} | — | — |");
    }
    let ekf = &real.per_filter[FilterKind::ALL.iter().position(|&x| x == FilterKind::Ekf).unwrap()];
    let _ = writeln!(md, "\nPer file, `ekf`:\n");
    let _ = writeln!(
        md,
        "| file | rows | inclination (°) | heading (°) | --foreign inclination (°) | \
         --foreign heading (°) |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|");
    for (k, (name, rows)) in real.files.iter().enumerate() {
        let _ = writeln!(
            md,
            "| {} | {rows} | {:.2} | {:.2} | {:.2} | {:.2} |",
            name.trim_end_matches(".csv"),
            ekf[k].inclination_deg,
            ekf[k].heading_deg,
            real.foreign[k].inclination_deg,
            real.foreign[k].heading_deg
        );
    }
}

/// Table (f): every filter on the BROAD trials beside VQF 2.1 online, the EKF's goals marked,
/// then `ekf` and `gyro` per trial. Returns a one-line summary of the EKF's goals.
fn write_broad(md: &mut String, broad: &BroadResults) -> String {
    let n = broad.trials.len();
    let rows: usize = broad.trials.iter().map(|t| t.1).sum();
    let fidx = |f: FilterKind| FilterKind::ALL.iter().position(|&x| x == f).unwrap();
    let (ekf, gyro) =
        (&broad.per_filter[fidx(FilterKind::Ekf)], &broad.per_filter[fidx(FilterKind::Gyro)]);
    let scored: usize = ekf.iter().map(|s| s.rows).sum();
    let (gi, gh) = (BROAD_GOAL_INCL, BROAD_GOAL_HEADING);
    let _ = writeln!(md, "### Real data: the BROAD hand-held trials (development set)\n");
    let _ = writeln!(
        md,
        "Generated by `{COMMAND}`. The {n} trials of `shared/data/broad` ({rows} rows at \
         285.7 Hz, myon aktos-t IMU moved by hand, OptiTrack optical truth; \
         `shared/data/broad/README.md`), every filter with its default settings and no lever \
         arm (`RepoImu::config`, as the RepoIMU table), run over every row from the first, \
         scored by `host_tests::real` as the benchmark scores: only the motion phase \
         (`movement = 1`) and only rows with truth (the rows where the optical system lost the \
         sensor, `nan`, are run through and skipped), {scored} rows in all: inclination RMSE, \
         and heading RMSE with its circular mean removed, degrees, mean over the {n} trials. \
         VQF 2.1 online: its figures on the same files in that README. Goal for `ekf`: mean \
         inclination ≤ {gi:.2}° and mean heading ≤ {gh:.2}° (VQF online). These {n} trials are \
         the benchmark's development set (its other 17 are not shared), not its score.\n"
    );
    let _ = writeln!(
        md,
        "| filter | inclination (°) | heading (°) | inclination ≤ {gi:.2}° | heading ≤ {gh:.2}° |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|");
    let means = |s: &[ScoreRmse]| {
        (mean(s.iter().map(|x| x.inclination_deg)), mean(s.iter().map(|x| x.heading_deg)))
    };
    for (fi, f) in FilterKind::ALL.iter().enumerate() {
        let (i, h) = means(&broad.per_filter[fi]);
        let (vi, vh) =
            if *f == FilterKind::Ekf { (met(i <= gi), met(h <= gh)) } else { ("—", "—") };
        let _ = writeln!(md, "| {} | {i:.2} | {h:.2} | {vi} | {vh} |", f.name());
    }
    let (oi, oh) = Broad::VQF_ONLINE;
    let _ = writeln!(md, "| VQF 2.1 online (published) | {oi:.2} | {oh:.2} | — | — |");

    let _ = writeln!(
        md,
        "\nPer trial, `ekf` and `gyro` (the gyro-only filter) beside VQF 2.1 online; *rows*: the \
         rows scored; *ekf < gyro*: the ekf's inclination RMSE below the gyro-only filter's on \
         that trial (goal: every trial).\n"
    );
    let _ = writeln!(
        md,
        "| trial | rows | ekf inclination (°) | ekf heading (°) | gyro inclination (°) | \
         gyro heading (°) | VQF online inclination (°) | VQF online heading (°) | ekf < gyro |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|");
    let mut beats = 0;
    for (k, (name, _)) in broad.trials.iter().enumerate() {
        let (e, g) = (ekf[k], gyro[k]);
        let (vi, vh) = Broad::TRIALS[k].1;
        let better = e.inclination_deg < g.inclination_deg;
        beats += usize::from(better);
        let _ = writeln!(
            md,
            "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {vi:.2} | {vh:.2} | {} |",
            name.trim_end_matches(".csv"),
            e.rows,
            e.inclination_deg,
            e.heading_deg,
            g.inclination_deg,
            g.heading_deg,
            if better { "yes" } else { "**no**" }
        );
    }
    let ((ei, eh), (gyi, gyh)) = (means(ekf), means(gyro));
    let _ = writeln!(
        md,
        "| **mean of the {n}** | {scored} | {ei:.2} | {eh:.2} | {gyi:.2} | {gyh:.2} | {oi:.2} | \
         {oh:.2} | {beats} of {n} |"
    );
    format!(
        "EKF on BROAD: inclination {ei:.2}° (≤ {gi:.2}°: {}), heading {eh:.2}° (≤ {gh:.2}°: {}); \
         inclination below the gyro-only filter's on {beats} of {n} trials",
        if ei <= gi { "PASS" } else { "MISS" },
        if eh <= gh { "PASS" } else { "MISS" }
    )
}

/// Table (g): tilt RMSE of every filter on the robustness scenarios, plain and realistic, the
/// EKF's goals marked. Returns the EKF's misses (plain sensors).
fn write_robust(md: &mut String, robust: &RobustResults, seeds: u64) -> Vec<&'static str> {
    let _ = writeln!(md, "### Robustness: tilt RMSE beyond the source's scenarios\n");
    let _ = writeln!(
        md,
        "Generated by `{COMMAND}`. Tilt (inclination) RMSE once converged (from 30 s for \
         `start-moving`, else from the end of the still start), degrees, mean over seeds \
         1–{seeds} with the worst seed in brackets, 50 Hz, 200 s, each scenario's replay \
         settings (`accuracy::replay_config`). *realistic*: the same with the realistic sensor \
         errors (`simulate --realistic`). Goal for `ekf` (`ROBUST_GOALS`): ≤ 0.5° with plain \
         sensors; the result column gives plain / realistic against it.\n"
    );
    let _ = writeln!(md, "| scenario | filter | plain | realistic | goal | result |");
    let _ = writeln!(md, "|---|---|---|---|---|---|");
    let mut misses = Vec::new();
    for (si, s) in ROBUST_SCENARIOS.iter().enumerate() {
        let g = ROBUST_GOALS.iter().find(|g| g.scenario == *s).expect("a goal per scenario");
        for (fi, f) in FilterKind::ALL.iter().enumerate() {
            let stat = |realistic: bool| {
                let r = &robust[&(si, fi, realistic)];
                let v = r.iter().map(|x| g.metric.of(x));
                (mean(v.clone()), max(v))
            };
            let (pm, pw) = stat(false);
            let (rm, rw) = stat(true);
            let (goal, result) = if *f == FilterKind::Ekf {
                if pm.is_nan() || pm > g.max {
                    misses.push(g.label);
                }
                let v = |m: f64| if m <= g.max { "PASS" } else { "**MISS**" };
                (format!("≤ {}", g.max), format!("{} / {}", v(pm), v(rm)))
            } else {
                ("—".into(), "—".into())
            };
            let _ = writeln!(
                md,
                "| {} | {} | {pm:.3} ({pw:.3}) | {rm:.3} ({rw:.3}) | {goal} | {result} |",
                s.name(),
                f.name()
            );
        }
    }
    misses
}
