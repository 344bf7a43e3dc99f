//! `host-tests` command line: `simulate`, `replay`, `plot`. See the crate documentation and
//! `host-tests --help`.

use std::io::BufReader;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use ekf_core::conditioning::Conditioner;
use host_tests::config::{parse_config, ReplayConfig};
use host_tests::output::{produce_atomically, write_atomically};
use host_tests::replay::{replay, replay_serial, FilterKind, ReplayError};
use host_tests::sim::Scenario;
use host_tests::trace::{read_estimate_file, read_trace_file, TraceReader, TraceWriter};

/// `println!` that ignores a closed stdout (e.g. piped into `head`).
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
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
        /// gyro-noise, accel-noise, still-hour, ramp-hour, bias-off.
        #[arg(value_parser = parse_scenario)]
        scenario: Scenario,
        /// Output trace CSV.
        #[arg(long)]
        out: PathBuf,
        /// Sample rate, Hz.
        #[arg(long, default_value_t = 50.0, value_parser = parse_positive)]
        rate: f64,
        /// Duration, s (default: 200 s, or 3600 s for the hour scenarios).
        #[arg(long, value_parser = parse_non_negative)]
        duration: Option<f64>,
        /// Noise seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Also simulate the magnetometer (mx, my, mz columns).
        #[arg(long)]
        mag: bool,
    },
    /// Run a trace through the estimator and write one estimate row per input row.
    Replay {
        /// Input trace CSV.
        trace: PathBuf,
        /// Output estimate CSV.
        #[arg(long)]
        out: PathBuf,
        /// ekf, ukf, ssukf, cf or gyro.
        #[arg(long, default_value = "ekf", value_parser = parse_filter)]
        filter: FilterKind,
        /// TOML file overriding settings (see the `config` module docs).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Do not estimate the gyro bias in the initialisation window: use the configured
        /// `init.gyro_bias`.
        #[arg(long)]
        no_init_bias: bool,
    },
    /// Plot truth vs estimate and the error per axis to a PNG.
    Plot {
        /// Input trace CSV (with truth).
        trace: PathBuf,
        /// Estimate CSV from `replay`.
        est: PathBuf,
        /// Output PNG.
        #[arg(long)]
        out: PathBuf,
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

fn simulate(
    scenario: Scenario,
    out: &Path,
    rate: f64,
    duration: Option<f64>,
    seed: u64,
    mag: bool,
) -> Result<(), String> {
    let (sim, cfg) = scenario.simulator(rate, duration, seed, mag);
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
        "simulate: {} ({} rows, {} Hz, {} s, seed {}) -> {}",
        scenario.name(),
        rows,
        cfg.rate_hz,
        cfg.duration_s,
        seed,
        out.display()
    );
    Ok(())
}

fn run_replay(
    trace: &Path,
    out: &Path,
    filter: FilterKind,
    config: Option<&Path>,
    no_init_bias: bool,
) -> Result<(), String> {
    let mut cfg = match config {
        Some(p) => {
            let text = std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?;
            parse_config(&text).map_err(|e| format!("{}: {e}", p.display()))?
        }
        None => ReplayConfig::default(),
    };
    if no_init_bias {
        cfg.settings.init.estimate_gyro_bias = false;
    }
    let file = std::fs::File::open(trace).map_err(|e| format!("{}: {e}", trace.display()))?;
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
    let stats = write_atomically(out, |w| {
        if cores > 1 {
            replay(reader, w, f.as_mut(), &mut cond, window)
        } else {
            replay_serial(reader, w, f.as_mut(), &mut cond, window)
        }
    })
    .map_err(|e| match e {
        ReplayError::Trace(e) => format!("{}: {e}", trace.display()),
        ReplayError::Io(e) => format!("{}: {e}", out.display()),
    })?;
    let rate = stats.rows as f64 / stats.elapsed_s.max(1e-9);
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
    }
    Ok(())
}

fn run_plot(trace: &Path, est: &Path, out: &Path) -> Result<(), String> {
    let (_, rows) = read_trace_file(trace).map_err(|e| format!("{}: {e}", trace.display()))?;
    let est_rows = read_estimate_file(est).map_err(|e| format!("{}: {e}", est.display()))?;
    produce_atomically(out, |tmp| -> Result<(), PlotErr> {
        host_tests::plot::plot(&rows, &est_rows, tmp).map_err(PlotErr::Msg)
    })
    .map_err(|e| match e {
        PlotErr::Msg(m) => m,
        PlotErr::Io(e) => format!("{}: {e}", out.display()),
    })?;
    say!("plot: {} rows -> {}", rows.len(), out.display());
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
    let result = match cli.cmd {
        Cmd::Simulate { scenario, out, rate, duration, seed, mag } => {
            simulate(scenario, &out, rate, duration, seed, mag)
        }
        Cmd::Replay { trace, out, filter, config, no_init_bias } => {
            run_replay(&trace, &out, filter, config.as_deref(), no_init_bias)
        }
        Cmd::Plot { trace, est, out } => run_plot(&trace, &est, &out),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
