//! `host-tests` command line: `simulate`, `replay`, `plot`. See the crate documentation and
//! `host-tests --help`.

use std::io::BufReader;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::{Arc, Mutex, PoisonError};

use clap::{Parser, Subcommand};
use ekf_core::conditioning::Conditioner;
use ekf_core::{Flags, Vec3};
use host_tests::config::ReplayConfig;
use host_tests::lenient::{SkipBadRows, Skipped};
use host_tests::output::{produce_atomically, refuse_overwriting_inputs, write_atomically};
use host_tests::progress::{CountingReader, Progress};
use host_tests::real::AttitudeScore;
use host_tests::replay::{replay_serial_with, replay_with, FilterKind, ReplayError};
use host_tests::settings::{
    device_form, parse_assignment, read_settings_file, ReplaySettings, TraceMeta,
};
use host_tests::sim::{Scenario, SimOptions};
use host_tests::trace::{EstimateRow, TraceReader, TraceRow, TraceWriter};

/// The summary goes to stderr when the output file is stdout (`--out -`).
static SUMMARY_TO_STDERR: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// `println!` that ignores a closed stdout (e.g. piped into `head`), or `eprintln!` when the
/// data itself goes to stdout.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if SUMMARY_TO_STDERR.load(std::sync::atomic::Ordering::Relaxed) {
            let _ = writeln!(std::io::stderr(), $($arg)*);
        } else {
            let _ = writeln!(std::io::stdout(), $($arg)*);
        }
    }};
}

#[derive(Parser)]
#[command(name = "host-tests", version, about = "Simulate, replay and plot ekf-core traces")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Simulate a scenario and write a trace with truth columns.
    Simulate {
        /// pitch-sine (1), coupled (2), pitch-step (3), pitch-ramp (4), yaw-sine (5), surge (6),
        /// gyro-noise, accel-noise, still-hour, ramp-hour, bias-off; robustness: tumble (all
        /// attitudes), side-mount (board at 90° roll), start-moving (no still start), pendulum
        /// (a pendulum rig, as the RepoIMU recordings).
        #[arg(value_parser = parse_scenario)]
        scenario: Scenario,
        /// Output trace CSV.
        #[arg(long)]
        out: PathBuf,
        /// Sample rate, Hz.
        #[arg(long, default_value_t = 50.0, value_parser = parse_positive)]
        rate: f64,
        /// Duration, s (default: 200 s, or 3600 s for the hour scenarios; at most 1,000,000 s,
        /// and at most 50,000,000 rows at the rate given).
        #[arg(long, value_parser = parse_non_negative)]
        duration: Option<f64>,
        /// Noise seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Also simulate the magnetometer (mx, my, mz columns).
        #[arg(long)]
        mag: bool,
        /// Add the realistic sensor errors the filter does not model (gyro bias random walk
        /// and flicker, scale factors, misalignment, residual accelerometer bias, quantisation,
        /// sample-time jitter, repeated samples, vibration: the iNEMO values of `src/sim.rs`).
        /// Without it the trace is the plain model's, unchanged.
        #[arg(long)]
        realistic: bool,
    },
    /// Run a trace through the estimator and write one estimate row per input row.
    ///
    /// With truth in the trace it prints the roll/pitch/yaw RMSE (rows after the
    /// initialisation window) and the inclination and heading RMSE of the real-data benchmarks
    /// (RepoIMU, VQF: heading with its circular mean removed; every row with truth).
    Replay {
        /// Input trace CSV.
        trace: PathBuf,
        /// Output estimate CSV.
        #[arg(long)]
        out: PathBuf,
        /// ekf, ukf, ssukf, cf or gyro.
        #[arg(long, default_value = "ekf", value_parser = parse_filter)]
        filter: FilterKind,
        /// A setting in the device's language, `NAME=VALUE` with the registry's names and
        /// units (`mag.norm_tolerance=0.1`, `lever.r=0,0,0`; docs/commands.md, docs/replay.md);
        /// repeatable, applied in order after `--settings`.
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// A settings file: one `NAME=VALUE` per line, `#` comments (`ahrs-tool settings get`
        /// writes one from a device); repeatable, applied in order.
        #[arg(long = "settings", value_name = "FILE")]
        settings: Vec<PathBuf>,
        /// Do not estimate the gyro bias in the initialisation window: use the configured
        /// `init.gyro_bias` (the same as `--set init.estimate_bias=0`).
        #[arg(long)]
        no_init_bias: bool,
        /// Another IMU's recording (e.g. RepoIMU): drop the Seahog specifics, i.e. no lever
        /// arm (`LeverArm::NONE`) and a configured gyro bias of zero (`init.gyro_bias`, the
        /// iNEMO board's); everything else default. `--settings` and `--set` apply on top.
        #[arg(long)]
        foreign: bool,
        /// Pass over malformed rows (bad cells, time not increasing) instead of stopping at
        /// the first; their number and first line numbers are reported on stderr.
        #[arg(long)]
        skip_bad_rows: bool,
    },
    /// Plot the estimate (over the truth, and the error, when the trace has truth) per axis to
    /// a PNG or an SVG, by the output's extension.
    Plot {
        /// Input trace CSV (truth columns optional).
        trace: PathBuf,
        /// Estimate CSV from `replay`.
        est: PathBuf,
        /// Output image: `.png` or `.svg`.
        #[arg(long)]
        out: PathBuf,
        /// The title's first part, e.g. the scenario and the filter (default: the two
        /// files' names); the RMSE after initialisation follows it.
        #[arg(long)]
        title: Option<String>,
        /// Image size in pixels, WIDTHxHEIGHT.
        #[arg(long, default_value = "1600x1050", value_parser = host_tests::plot::parse_size)]
        size: (u32, u32),
    },
}

fn parse_scenario(s: &str) -> Result<Scenario, String> {
    Scenario::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = Scenario::ALL.iter().map(|s| s.name()).collect();
        format!("unknown scenario (one of {}, or 1-6)", names.join(", "))
    })
}

fn parse_filter(s: &str) -> Result<FilterKind, String> {
    FilterKind::from_name(s).ok_or_else(|| "unknown filter (ekf, ukf, ssukf, cf, gyro)".into())
}

fn parse_positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err("expected a positive number".into()),
    }
}

fn parse_non_negative(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err("expected a non-negative number".into()),
    }
}

/// The longest `simulate --duration`, s (11.6 days; 140,000 s is a documented run).
const MAX_SIM_DURATION_S: f64 = 1e6;
/// The most rows `simulate` writes (about 5 GB of CSV at ~100 bytes a row).
const MAX_SIM_ROWS: f64 = 5e7;

fn simulate(
    scenario: Scenario,
    out: &Path,
    rate: f64,
    duration: Option<f64>,
    seed: u64,
    mag: bool,
    realistic: bool,
) -> Result<(), String> {
    // Refused before anything is written: a run that would never end, or fill the disk.
    let seconds = duration.unwrap_or(scenario.default_duration());
    if seconds > MAX_SIM_DURATION_S {
        return Err(format!(
            "--duration {seconds}: at most {MAX_SIM_DURATION_S} s (11.6 days) per trace"
        ));
    }
    if seconds * rate > MAX_SIM_ROWS {
        return Err(format!(
            "{seconds} s at {rate} Hz is {:.0} rows: at most {MAX_SIM_ROWS:.0} per trace \
             (about 5 GB); shorten --duration or lower --rate",
            seconds * rate
        ));
    }
    let opts = SimOptions { rate_hz: rate, duration_s: duration, seed, mag, realistic };
    let (sim, cfg) = scenario.simulator_with(&opts);
    let rows = sim.len();
    write_atomically(out, |w| -> std::io::Result<()> {
        let mut tw = TraceWriter::new(w, sim.columns())?;
        for c in scenario.comments(&cfg) {
            tw.comment(&c)?;
        }
        for s in sim {
            tw.row(&s.row)?;
        }
        tw.finish()?;
        Ok(())
    })
    .map_err(|e| format!("{}: {e}", out.display()))?;
    say!(
        "simulate: {} ({} rows, {} Hz, {} s, seed {}{}) -> {}",
        scenario.name(),
        rows,
        cfg.rate_hz,
        cfg.duration_s,
        seed,
        if realistic { ", realistic sensor errors" } else { "" },
        out.display()
    );
    Ok(())
}

/// `[x, y, z]` with 4 decimals.
fn vec3(v: Vec3, scale: f32) -> String {
    format!("[{:.4}, {:.4}, {:.4}]", v.x * scale, v.y * scale, v.z * scale)
}

/// The `--foreign` configuration: the defaults without the Seahog specifics (lever arm, the
/// iNEMO's gyro bias), and the line that says what changed.
fn foreign_config(then_config: bool) -> (ReplayConfig, String) {
    let d = ReplayConfig::default();
    let (arm, bias) = (d.conditioning.lever_arm.r, d.settings.init.gyro_bias);
    let cfg = host_tests::real::foreign_config();
    let line = format!(
        "foreign: lever_arm.r {} m -> {} (LeverArm::NONE), init.gyro_bias {} deg/s -> {}; \
         the rest default{}",
        vec3(arm, 1.0),
        vec3(cfg.conditioning.lever_arm.r, 1.0),
        vec3(bias, 1f32.to_degrees()),
        vec3(cfg.settings.init.gyro_bias, 1f32.to_degrees()),
        if then_config { ", then the given settings on top" } else { "" },
    );
    (cfg, line)
}

/// `replay`'s options besides the paths and the filter.
struct ReplayOptions {
    set: Vec<String>,
    settings: Vec<PathBuf>,
    no_init_bias: bool,
    foreign: bool,
    skip_bad_rows: bool,
}

/// The replay's configuration: the defaults (or `--foreign`'s), the trace's own header (a log's
/// device settings and conditioning), the settings files, each `--set`. Notes for stderr.
fn replay_config(
    trace: &Path,
    o: &ReplayOptions,
) -> Result<(ReplayConfig, String, Vec<String>), String> {
    let given = !o.set.is_empty() || !o.settings.is_empty();
    let (base, foreign_line) =
        if o.foreign { foreign_config(given) } else { (ReplayConfig::default(), String::new()) };
    let mut rs = ReplaySettings::new(device_form(&base));
    let mut restart_note = None;
    // A regular file only: reading a pipe's header here would take it from the replay.
    if std::fs::metadata(trace).is_ok_and(|m| m.is_file()) {
        let meta = TraceMeta::read(trace).map_err(|e| format!("{}: {e}", trace.display()))?;
        rs.apply_trace(&meta, &trace.display().to_string())?;
        restart_note = restart_note_for(&meta);
    }
    for path in &o.settings {
        for (_, a) in read_settings_file(path)? {
            rs.apply_given(&a);
        }
    }
    for text in &o.set {
        rs.apply_given(&parse_assignment(text).map_err(|e| format!("--set {e}"))?);
    }
    let mut cfg = rs.config(&base);
    if o.no_init_bias {
        cfg.settings.init.estimate_gyro_bias = false;
    }
    let mut notes = Vec::new();
    if rs.from_trace > 0 || rs.lever_applied {
        notes.push(format!(
            "trace header: {} device settings applied{}",
            rs.from_trace,
            if rs.lever_applied {
                "; its samples already had the lever arm (none added)"
            } else {
                ""
            }
        ));
    }
    notes.extend(rs.notes());
    notes.extend(restart_note);
    Ok((cfg, foreign_line, notes))
}

/// For a device's log (its header has the device's settings): whether the replay can be
/// compared with the device's own estimates.
fn restart_note_for(meta: &TraceMeta) -> Option<String> {
    if meta.restarted {
        Some(
            "trace header: the device's estimator restarted at the first row: the replay \
             reproduces the device's estimates"
                .into(),
        )
    } else if !meta.settings.is_empty() {
        Some(
            "trace header: the device's estimator ran before the log's first row: the \
             replay's estimates are not the device's (ahrs-tool log --restart records a \
             comparable log)"
                .into(),
        )
    } else {
        None
    }
}

fn run_replay(
    trace: &Path,
    out: &Path,
    filter: FilterKind,
    o: &ReplayOptions,
) -> Result<(), String> {
    let (cfg, foreign_line, notes) = replay_config(trace, o)?;
    let foreign = o.foreign;
    refuse_overwriting_inputs(out, &[trace]).map_err(|e| e.to_string())?;
    let file = std::fs::File::open(trace).map_err(|e| format!("{}: {e}", trace.display()))?;
    // Progress by the bytes read, on a terminal only (`host_tests::progress`).
    let total = file.metadata().ok().filter(|m| m.is_file()).map(|m| m.len());
    let file = CountingReader::new(file);
    let progress = Progress::start("replay", total, file.counter());
    let reader = TraceReader::new(BufReader::with_capacity(1 << 16, file))
        .map_err(|e| format!("{}: {e}", trace.display()))?;
    let has_truth = reader.columns().truth;
    let mut f = cfg.make_filter(filter);
    let mut cond = Conditioner::new(cfg.conditioning);
    let window = cfg.settings.init.window_s as f64;
    // Three threads: faster than `replay_serial` file to file when a second core is free (see
    // the replay-speed table of docs/accuracy.md); with one core, the threads would only take
    // turns on it, so the single-thread replay does the same work without their hand-overs.
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // Inclination and heading errors (`host_tests::real`) of every row with truth, in the
    // motion phase where the trace marks one (BROAD's `movement`).
    let mut score = AttitudeScore::default();
    let mut score_row = |row: &TraceRow, est: &EstimateRow| {
        if let (true, Some(t)) = (row.scored(), row.truth) {
            score.add(est.q.map(f64::from), t.map(f64::from));
        }
    };
    let mut flags = FlagSummary::default();
    let observe = |row: &TraceRow, est: &EstimateRow| {
        flags.add(est.flags);
        score_row(row, est)
    };
    let skipped = Arc::new(Mutex::new(Skipped::default()));
    let stats = write_atomically(out, |w| {
        if o.skip_bad_rows {
            let reader = SkipBadRows::new(reader);
            let record = reader.skipped();
            let r = if cores > 1 {
                replay_with(reader, w, f.as_mut(), &mut cond, window, observe)
            } else {
                replay_serial_with(reader, w, f.as_mut(), &mut cond, window, observe)
            };
            *skipped.lock().unwrap_or_else(PoisonError::into_inner) =
                record.lock().unwrap_or_else(PoisonError::into_inner).clone();
            r
        } else if cores > 1 {
            replay_with(reader, w, f.as_mut(), &mut cond, window, observe)
        } else {
            replay_serial_with(reader, w, f.as_mut(), &mut cond, window, observe)
        }
    })
    .map_err(|e| match e {
        ReplayError::Trace(e) => format!("{}: {e}", trace.display()),
        ReplayError::Io(e) => format!("{}: {e}", out.display()),
    })?;
    progress.finish();
    for n in &notes {
        eprintln!("replay: {n}");
    }
    if let Some(r) = skipped.lock().unwrap_or_else(PoisonError::into_inner).report() {
        eprintln!("replay: {r}");
    }
    for w in flags.warnings(stats.rows) {
        eprintln!("warning: {w}");
    }
    let rate = stats.rows as f64 / stats.elapsed_s.max(1e-9);
    if foreign {
        say!("{foreign_line}");
    }
    say!(
        "replay: {} rows through {} in {:.3} s ({:.0} rows/s) -> {}",
        stats.rows,
        filter.name(),
        stats.elapsed_s,
        rate,
        out.display()
    );
    let b = stats.final_bias_dps;
    say!("final gyro bias (deg/s): {:.4} {:.4} {:.4}", b[0], b[1], b[2]);
    if has_truth {
        match stats.rmse.rmse() {
            Some(r) => say!(
                "rmse_deg roll {:.4} pitch {:.4} yaw {:.4} (over {} rows with t >= t0 + {} s)",
                r[0],
                r[1],
                r[2],
                stats.rmse.count(),
                window
            ),
            None => say!("rmse_deg: no truth rows after the {window} s window"),
        }
        if let Some(s) = score.rmse() {
            say!(
                "rmse_deg inclination {:.4} heading {:.4} (heading less its circular mean; over \
                 the {} rows with truth, the window included; only movement = 1 where the trace \
                 has that column)",
                s.inclination_deg,
                s.heading_deg,
                s.rows
            );
        }
    }
    Ok(())
}

/// What the estimator's flags said over a replay, for the warnings.
#[derive(Default)]
struct FlagSummary {
    last: u16,
    moving_start: bool,
}

impl FlagSummary {
    fn add(&mut self, bits: u16) {
        self.last = bits;
        self.moving_start |= bits & Flags::MOVING_START.bits() != 0;
    }

    /// The warnings: the initialisation never completed; the start was not still.
    fn warnings(&self, rows: u64) -> Vec<String> {
        let mut out = Vec::new();
        if rows > 0 && self.last & Flags::INITIALISING.bits() != 0 {
            out.push(format!(
                "the initialisation never completed: every one of the {rows} rows is \
                 \"initialising\" (the trace is shorter than init.window, or its start is \
                 invalid); the estimates use the configured gyro bias"
            ));
        }
        if self.moving_start {
            out.push(
                "the start was not still (MOVING_START): the filter started from the configured \
                 gyro bias, init.gyro_bias, with a wide uncertainty"
                    .to_string(),
            );
        }
        out
    }
}

fn run_plot(
    trace: &Path,
    est: &Path,
    out: &Path,
    title: Option<String>,
    size: (u32, u32),
) -> Result<(), String> {
    use host_tests::plot::{read_figure, render_png, render_svg, Format};
    let format = Format::of(out)?;
    refuse_overwriting_inputs(out, &[trace, est]).map_err(|e| e.to_string())?;
    let open = |p: &Path| {
        std::fs::File::open(p)
            .map(|f| BufReader::with_capacity(1 << 16, f))
            .map_err(|e| format!("{}: {e}", p.display()))
    };
    let mut fig = read_figure(
        open(trace)?,
        open(est)?,
        &trace.display().to_string(),
        &est.display().to_string(),
    )?;
    let name = |p: &Path| {
        p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
    };
    fig.title = title.unwrap_or_else(|| format!("{} · {}", name(trace), name(est)));
    match format {
        Format::Png => produce_atomically(out, |tmp| -> Result<(), PlotErr> {
            render_png(&fig, tmp, size).map_err(PlotErr::Msg)
        }),
        Format::Svg => {
            let svg = render_svg(&fig, size)?;
            write_atomically(out, |w| -> Result<(), PlotErr> {
                use std::io::Write as _;
                w.write_all(svg.as_bytes())?;
                Ok(())
            })
        }
    }
    .map_err(|e| match e {
        PlotErr::Msg(m) => m,
        PlotErr::Io(e) => format!("{}: {e}", out.display()),
    })?;
    if !fig.has_truth() {
        eprintln!("plot: the trace has no truth columns: the estimate alone, without error panels");
    }
    say!("plot: {} rows -> {} ({})", fig.rows(), out.display(), fig.title_line());
    Ok(())
}

enum PlotErr {
    Msg(String),
    Io(std::io::Error),
}

impl From<std::io::Error> for PlotErr {
    fn from(e: std::io::Error) -> Self {
        PlotErr::Io(e)
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion)
                || matches!(e.kind(), ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand)
            {
                // Help and version: clap's own output and exit code.
                e.exit();
            }
            // clap's message spans several lines (details, usage, help hint): keep one.
            let msg = e.to_string();
            let parts: Vec<&str> = msg
                .lines()
                .take_while(|l| !l.starts_with("Usage:"))
                .map(str::trim)
                .filter(|l| !l.is_empty() && !l.starts_with("For more information"))
                .collect();
            let line = parts.join(" ");
            let line = line.strip_prefix("error: ").unwrap_or(&line);
            eprintln!("error: {line}");
            return ExitCode::from(2);
        }
    };
    let (Cmd::Simulate { out, .. } | Cmd::Replay { out, .. } | Cmd::Plot { out, .. }) = &cli.cmd;
    if out.as_os_str() == "-" {
        SUMMARY_TO_STDERR.store(true, std::sync::atomic::Ordering::Relaxed);
    }
    let result = match cli.cmd {
        Cmd::Simulate { scenario, out, rate, duration, seed, mag, realistic } => {
            simulate(scenario, &out, rate, duration, seed, mag, realistic)
        }
        Cmd::Replay { trace, out, filter, set, settings, no_init_bias, foreign, skip_bad_rows } => {
            let opts = ReplayOptions { set, settings, no_init_bias, foreign, skip_bad_rows };
            run_replay(&trace, &out, filter, &opts)
        }
        Cmd::Plot { trace, est, out, title, size } => run_plot(&trace, &est, &out, title, size),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
