//! `ahrs-tool`: the operator's host tool for the iNEMO AHRS (see `docs/host-tool.md`).
//!
//! - `live <port>`: attitude and depth from `$PINAH` / `$PRDID`, one refreshing line;
//! - `send <port> <COMMAND...>`: one `$PINAC` command, print the `$PINAR` reply;
//! - `log <port> --out trace.csv`: raw mode into the trace CSV format, the device's settings in
//!   its header; `--restart` (`RAW,2`): the device's estimator restarted at the first row, so
//!   that a replay reproduces its estimates (`--device-estimates FILE` records them);
//! - `settings get|put <port>`: the device's settings to a `NAME=VALUE` file and back;
//! - `calibrate <port>`: interactive six-position accelerometer calibration;
//! - `emulate --pty`: the firmware library on the host behind a pseudo-terminal;
//! - `bridge <port> --udp host[:port] --tcp addr[:port]`: the sentences onto the network.

mod bridge;
mod emulate;
mod link;
mod live;
mod noise;
mod raw;
mod settings_cmd;
mod signalk;

use std::{
    fs::File,
    io::{self, BufRead, BufWriter, IsTerminal, Write},
    path::{Path, PathBuf},
    process::ExitCode,
    sync::{
        atomic::{AtomicBool, Ordering},
        Arc, LazyLock, Once,
    },
    time::{Duration, Instant},
};

use clap::{Parser, Subcommand};
use ekf_core::accel_calibration::{Position, SixPositionFit};
use ekf_core::Vec3;
use host_tests::output::refuse_overwriting_inputs;
use host_tests::settings::META_RESTARTED;
use host_tests::trace::{TraceColumns, TraceWriter};
use inemo_ahrs::command::POSITION_NAMES;
use link::{command_body, Link, Reply};

#[derive(Parser)]
#[command(name = "ahrs-tool", version, about = "Operator's tool for the iNEMO AHRS")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Show attitude and depth from the board's `$PINAH` / `$PRDID` sentences.
    Live {
        /// Serial port (e.g. /dev/ttyUSB0, or the emulator's pty).
        port: String,
        /// Stop after this many seconds (default: until interrupted).
        #[arg(long, value_parser = seconds_arg)]
        seconds: Option<f64>,
    },
    /// Send one command (`VER`, `GET mag.norm_tolerance`, `SET,mag.norm_tolerance,0.08`) and print the reply;
    /// `LIST` alone lists every setting: name, value, unit and range.
    /// Exit status: 0 OK, 1 ERR reply, 2 no reply or I/O error.
    Send {
        /// Serial port.
        port: String,
        /// The command: words are joined with commas (`SET,axes.gyro,x,y,-z`, or `-- SET
        /// axes.gyro x y -z` for words starting with `-` that are not numbers).
        #[arg(required = true, num_args = 1.., allow_negative_numbers = true)]
        command: Vec<String>,
        /// How long to wait for the reply, s.
        #[arg(long, default_value_t = 2.0, value_parser = seconds_arg)]
        timeout: f64,
        /// Also wait for the late reply of `GBIAS` / `ACAL,<position>` (up to this many s).
        #[arg(long, value_parser = seconds_arg)]
        wait_late: Option<f64>,
    },
    /// Log raw mode (`$PINAW` / `$PINAX`) into a trace CSV (`host-tests replay` reads it);
    /// `--restart` makes the log replay to the device's own estimates.
    Log {
        /// Serial port.
        port: String,
        /// Output CSV.
        #[arg(long)]
        out: PathBuf,
        /// Stop after this many seconds (default: until Ctrl-C).
        #[arg(long, value_parser = seconds_arg)]
        seconds: Option<f64>,
        /// Restart the device's estimator at the first row (`RAW,2`): a replay of the log
        /// from its first row, with the settings of its header, then reproduces the device's
        /// estimates. The header says so.
        #[arg(long)]
        restart: bool,
        /// With --restart: write the device's estimate from every row's sample (its `$PRDID`)
        /// to this CSV: `t,roll,pitch,yaw`, degrees as the device printed them.
        #[arg(long, value_name = "FILE", requires = "restart")]
        device_estimates: Option<PathBuf>,
        /// Overwrite an existing `--out` (and `--device-estimates`) file; without it an
        /// existing file is refused before anything is sent.
        #[arg(long)]
        force: bool,
    },
    /// Save a device's settings to a file, or send a file's settings to a device (`NAME=VALUE`
    /// lines, the device's names and units: `host-tests replay --settings` reads them too).
    Settings {
        #[command(subcommand)]
        action: SettingsAction,
    },
    /// The noise settings measured from a still recording (a trace CSV, e.g. from `log`): the
    /// Allan variance of each gyro and accelerometer axis gives `noise.gyro_var`,
    /// `noise.accel_var` and (from an hour or more) `ekf.bias_random_walk`, as a settings file
    /// for `settings put`.
    Noise {
        /// The still recording (trace CSV).
        trace: PathBuf,
        /// Output settings file (default: standard output).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Analyse the rows from this time on, s (the trace's time column): the still part of
        /// a longer log.
        #[arg(long, value_parser = time_arg)]
        from: Option<f64>,
        /// ... up to this time, s.
        #[arg(long, value_parser = time_arg)]
        to: Option<f64>,
    },
    /// Interactive six-position accelerometer calibration (answers read from stdin).
    Calibrate {
        /// Serial port.
        port: String,
        /// Averaging time per position, s (0.5–60).
        #[arg(long, default_value_t = 2.0, value_parser = acal_seconds_arg)]
        seconds: f64,
    },
    /// Forward the device's sentences to UDP (OpenCPN, Signal K, a ROV station) and/or to the
    /// clients of a TCP server, whose lines go back to the device as commands.
    Bridge {
        /// Serial port.
        port: String,
        /// Send every sentence as a UDP datagram to `host[:port]` (port 10110 by default; a
        /// broadcast address works).
        #[arg(long)]
        udp: Option<String>,
        /// Serve TCP clients on `addr[:port]` (10110 by default): they get the sentences, and
        /// their lines go to the device (a command body such as `SENT,HDT,1`, or a sentence).
        #[arg(long)]
        tcp: Option<String>,
        /// Send attitude, true heading, rate of turn and depth as Signal K deltas (JSON) to a
        /// Signal K server's UDP input on `host[:port]` (8375 by default): what its NMEA 0183
        /// parser cannot read from `XDR` and `$PINAH`.
        #[arg(long)]
        signalk: Option<String>,
        /// Stop after this many seconds (default: until interrupted).
        #[arg(long, value_parser = seconds_arg)]
        seconds: Option<f64>,
    },
    /// Run the firmware library on the host behind a pseudo-terminal (or a given port),
    /// fed by the host-tests simulator. Prints the port path on the first line of stdout.
    Emulate {
        /// Create a pseudo-terminal and print its path.
        #[arg(long, conflicts_with = "port", required_unless_present = "port")]
        pty: bool,
        /// Use this existing serial device or pty instead.
        #[arg(long)]
        port: Option<PathBuf>,
        /// Simulator scenario: still, pitch-sine, coupled, pitch-step, pitch-ramp, yaw-sine,
        /// surge, ...
        #[arg(long, default_value = "still")]
        scenario: String,
        /// Time scale: simulated seconds per real second (above 0, at most 1000).
        #[arg(long, default_value_t = 1.0, value_parser = speed_arg)]
        speed: f64,
        /// Simulated depth, m.
        #[arg(long, default_value_t = 2.5)]
        depth: f32,
        /// Simulator seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Test helper: hold the simulated board in the position of each `ACAL,<position>`
        /// command received (back to the scenario on any other command).
        #[arg(long)]
        follow_acal: bool,
        /// Simulate the magnetometer too (the field of the default `mag.*` settings; the
        /// estimator uses it after `SET,mag.enabled,1`).
        #[arg(long)]
        mag: bool,
        /// Test helper: the emulated board's magnetometer does not answer, so `SELFTEST`
        /// says FAIL (`scripts/tests/hil.sh` checks that `scripts/hil` catches it).
        #[arg(long)]
        broken_mag: bool,
    },
}

/// `ahrs-tool settings ...`.
#[derive(Subcommand)]
enum SettingsAction {
    /// Read every setting (`LIST`, `GET`) and write them as a settings file.
    Get {
        /// Serial port.
        port: String,
        /// Output settings file (`-`: standard output).
        #[arg(long)]
        out: PathBuf,
    },
    /// Check every line of a settings file, then `SET` each on the device.
    Put {
        /// Serial port.
        port: String,
        /// Settings file (`NAME=VALUE` lines, `#` comments).
        file: PathBuf,
        /// Also `SAVE` them to flash.
        #[arg(long)]
        save: bool,
    },
}

/// Set by SIGINT (Ctrl-C), SIGTERM or SIGHUP once [`catch_signals`] has run: the commands that
/// run until interrupted stop at their next check, and put the device back as they found it.
static INTERRUPTED: LazyLock<Arc<AtomicBool>> = LazyLock::new(|| Arc::new(AtomicBool::new(false)));

/// SIGINT, SIGTERM and SIGHUP set [`INTERRUPTED`] instead of killing the process (the
/// `signal-hook` crate). A signal that was ignored when the tool started stays ignored: under
/// `nohup` SIGHUP, as a background job of a non-interactive shell SIGINT — whoever started the
/// tool asked for that. SIGTERM is always caught (issue #39: a `log` stopped by it used to
/// leave a 0-byte file and the device in raw mode). Called by every command that runs until
/// interrupted, before it touches the device; the handlers are installed once per process.
fn catch_signals() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let ignored = ignored_signals();
        for sig in
            [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM, signal_hook::consts::SIGHUP]
        {
            let was_ignored = u32::try_from(sig - 1).is_ok_and(|b| b < 64 && ignored >> b & 1 == 1);
            if was_ignored && sig != signal_hook::consts::SIGTERM {
                continue;
            }
            if let Err(e) = signal_hook::flag::register(sig, Arc::clone(&INTERRUPTED)) {
                eprintln!("ahrs-tool: signal {sig} not caught: {e}");
            }
        }
    });
}

/// The signals this process ignores, as the kernel reports them (`SigIgn` of
/// `/proc/self/status`, Linux: bit n − 1 for signal n); none where that is not available.
fn ignored_signals() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("SigIgn:"))
                .and_then(|v| u64::from_str_radix(v.trim(), 16).ok())
        })
        .unwrap_or(0)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.cmd {
        Cmd::Live { port, seconds } => live::live(&port, seconds.map(|s| Instant::now() + secs(s))),
        Cmd::Send { port, command, timeout, wait_late } => {
            return send(&port, &command, timeout, wait_late);
        }
        Cmd::Log { port, out, seconds, restart, device_estimates, force } => {
            log(&port, &out, seconds, restart, device_estimates.as_deref(), force)
        }
        Cmd::Calibrate { port, seconds } => calibrate(&port, seconds),
        Cmd::Noise { trace, out, from, to } => noise::run(&trace, out.as_deref(), from, to),
        Cmd::Bridge { port, udp, tcp, signalk, seconds } => {
            catch_signals();
            let stop = || INTERRUPTED.load(Ordering::SeqCst);
            let to = bridge::Outputs {
                udp: udp.as_deref(),
                tcp: tcp.as_deref(),
                signalk: signalk.as_deref(),
            };
            bridge::run(&port, to, seconds, &stop)
        }
        Cmd::Settings { action: SettingsAction::Get { port, out } } => {
            settings_cmd::get(&port, &out)
        }
        Cmd::Settings { action: SettingsAction::Put { port, file, save } } => {
            settings_cmd::put(&port, &file, save)
        }
        Cmd::Emulate { pty, port, scenario, speed, depth, seed, follow_acal, mag, broken_mag } => {
            let opts = emulate::Options {
                scenario,
                speed,
                depth_m: depth,
                seed,
                follow_acal,
                mag,
                broken_mag,
            };
            emulator(pty, port, &opts)
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("ahrs-tool: {e}");
            ExitCode::from(2)
        }
    }
}

fn io_err(e: io::Error) -> String {
    e.to_string()
}

/// The longest duration any argument takes, s: a year.
const MAX_SECONDS: f64 = 366.0 * 86_400.0;

/// A number argument within `lo..=hi` (`lo` excluded when `open_lo`), or a one-line error that
/// names the value and the range: checked before anything is opened, sent or written.
fn number_in(s: &str, what: &str, lo: f64, open_lo: bool, hi: f64) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|_| format!("'{s}' is not a number ({what})"))?;
    let above = if open_lo { v > lo } else { v >= lo };
    if v.is_finite() && above && v <= hi {
        Ok(v)
    } else {
        let from = if open_lo { format!("above {lo}") } else { format!("from {lo}") };
        Err(format!("'{s}': {what} must be finite, {from} and at most {hi}"))
    }
}

/// A duration, s: finite, above 0, at most [`MAX_SECONDS`].
fn seconds_arg(s: &str) -> Result<f64, String> {
    number_in(s, "seconds", 0.0, true, MAX_SECONDS)
}

/// A time in a trace, s: finite, from 0, at most [`MAX_SECONDS`].
fn time_arg(s: &str) -> Result<f64, String> {
    number_in(s, "time", 0.0, false, MAX_SECONDS)
}

/// `ACAL`'s averaging time, s: the device accepts 0.5–60.
fn acal_seconds_arg(s: &str) -> Result<f64, String> {
    number_in(s, "seconds per position", 0.5, false, 60.0)
}

/// The emulator's time scale.
fn speed_arg(s: &str) -> Result<f64, String> {
    number_in(s, "speed", 0.0, true, 1000.0)
}

/// A duration from a checked argument (clamped, so that sums such as `seconds + 10` stay
/// representable).
fn secs(s: f64) -> Duration {
    Duration::from_secs_f64(if s.is_finite() { s.clamp(0.0, MAX_SECONDS) } else { 0.0 })
}

fn send(port: &str, words: &[String], timeout: f64, wait_late: Option<f64>) -> ExitCode {
    let body = command_body(words);
    let mut link = match Link::open(port) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("ahrs-tool: {e}");
            return ExitCode::from(2);
        }
    };
    // `LIST` without an index: every setting (`LIST,<i>` and `GET` for each) as a table.
    if body.eq_ignore_ascii_case("LIST") {
        return match settings_cmd::print_list(&mut link) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("ahrs-tool: {e}");
                ExitCode::from(2)
            }
        };
    }
    let reply = match link.command(&body, secs(timeout)) {
        Ok(Some(r)) => r,
        Ok(None) => {
            eprintln!("ahrs-tool: no reply to {body} within {timeout} s");
            return ExitCode::from(2);
        }
        Err(e) => {
            eprintln!("ahrs-tool: {e}");
            return ExitCode::from(2);
        }
    };
    println!("{}", reply.line);
    let mut ok = reply.ok;
    if let (Some(late), true) = (wait_late, ok && reply.fields.first().is_some_and(|f| f == "RUN"))
    {
        let deadline = Instant::now() + secs(late);
        let verb = reply.verb.clone();
        match link
            .wait_reply(&verb, deadline, |r| !r.ok || r.fields.first().is_some_and(|f| f == "DONE"))
        {
            Ok(Some(r)) => {
                println!("{}", r.line);
                ok = r.ok;
            }
            Ok(None) => {
                eprintln!("ahrs-tool: no late reply within {late} s");
                return ExitCode::from(2);
            }
            Err(e) => {
                eprintln!("ahrs-tool: {e}");
                return ExitCode::from(2);
            }
        }
    }
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// Send `body` and require an OK reply (retried once: the line may be lost).
fn expect_ok(link: &mut Link, body: &str) -> Result<Reply, String> {
    for _ in 0..2 {
        match link.command(body, Duration::from_secs(2)).map_err(io_err)? {
            Some(r) if r.ok => return Ok(r),
            Some(r) => return Err(format!("{body}: {}", r.line)),
            None => continue,
        }
    }
    Err(format!("no reply to {body}"))
}

fn log(
    port: &str,
    out: &Path,
    seconds: Option<f64>,
    restart: bool,
    estimates_path: Option<&Path>,
    force: bool,
) -> Result<(), String> {
    // A log records a dive that cannot be recorded again: an existing file (or link, dangling
    // or not) is refused before the port is opened, unless `--force`.
    if !force {
        for p in std::iter::once(out).chain(estimates_path) {
            if p.symlink_metadata().is_ok() {
                return Err(format!(
                    "{} exists: a log is not overwritten without --force (choose another name)",
                    p.display()
                ));
            }
        }
    }
    // Before the device is touched: a signal during the settings walk (seconds) ends the
    // command before the log starts, with nothing written and the device as it was.
    catch_signals();
    let mut link = Link::open(port)?;
    // What the samples already had applied and the device's settings (`host-tests replay`
    // applies them, and no conditioning twice); read before the file is created.
    let header = settings_cmd::log_comments(&mut link)?;
    if INTERRUPTED.load(Ordering::SeqCst) {
        return Err("interrupted before the log started: nothing written".into());
    }
    let existed = out.exists();
    // Not truncated yet: a refusal below leaves an existing file as it was.
    let file = File::options()
        .write(true)
        .create(true)
        .truncate(false)
        .open(out)
        .map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    if let Some(p) = estimates_path {
        // Two outputs, never the same file (through any path or link: `out` exists now).
        if refuse_overwriting_inputs(p, &[out]).is_err() {
            if !existed {
                let _ = std::fs::remove_file(out);
            }
            return Err(format!(
                "--device-estimates {} is the --out file {}: refusing to write both into one",
                p.display(),
                out.display()
            ));
        }
    }
    file.set_len(0).map_err(|e| format!("cannot write {}: {e}", out.display()))?;
    let mut estimates = match estimates_path {
        Some(p) => {
            let f = File::create(p).map_err(|e| format!("cannot create {}: {e}", p.display()))?;
            let mut w = BufWriter::new(f);
            writeln!(w, "t,roll,pitch,yaw").map_err(io_err)?;
            Some(w)
        }
        None => None,
    };
    let cols = TraceColumns { mag: true, depth: true, truth: false };
    let mut writer = TraceWriter::new(BufWriter::new(file), cols).map_err(io_err)?;
    writer.comment(&format!("raw mode log from {port} by ahrs-tool")).map_err(io_err)?;
    for c in header {
        writer.comment(&c).map_err(io_err)?;
    }
    if restart {
        writer.comment(META_RESTARTED).map_err(io_err)?;
    }
    writer.flush().map_err(io_err)?;
    // `RAW,2` restarts the estimator and the time; the rows after its reply are the new
    // estimator's, from its first sample (`t` one period).
    expect_ok(&mut link, if restart { "RAW,2" } else { "RAW,1" })?;
    let end = seconds.map(|s| Instant::now() + secs(s));
    let mut joiner = raw::RawJoiner::default();
    let mut gaps = GapCount::default();
    let mut rows = 0u64;
    let mut result = Ok(());
    // Each row reaches the file as it comes (a kill loses at most the row being written).
    let mut write = |logged: raw::Logged| -> Result<(), String> {
        writer.row(&logged.row).map_err(io_err)?;
        writer.flush().map_err(io_err)?;
        gaps.push(logged.row.t);
        if let (Some(w), Some(d)) = (estimates.as_mut(), &logged.device) {
            writeln!(w, "{:.4},{},{},{}", logged.row.t, d.roll, d.pitch, d.yaw).map_err(io_err)?;
            w.flush().map_err(io_err)?;
        }
        rows += 1;
        Ok(())
    };
    while !INTERRUPTED.load(Ordering::SeqCst) && end.is_none_or(|e| Instant::now() < e) {
        let deadline = Instant::now() + Duration::from_millis(200);
        match link.next_sentence(deadline) {
            Ok(Some((body, _))) => {
                if let Some(logged) = joiner.push(&body) {
                    if let Err(e) = write(logged) {
                        result = Err(e);
                        break;
                    }
                }
            }
            Ok(None) => {}
            Err(e) => {
                result = Err(io_err(e));
                break;
            }
        }
    }
    if result.is_ok() {
        if let Some(logged) = joiner.finish() {
            result = write(logged);
        }
    }
    // Whatever ended the log (its time, a signal, a full disk, the port), the device goes back
    // to its normal output and the file is closed with what it has.
    let off = expect_ok(&mut link, "RAW,0");
    let closed = writer.finish().map(|_| ()).map_err(io_err);
    let closed = closed.and(estimates.map_or(Ok(()), |mut w| w.flush().map_err(io_err)));
    let result = result.and(closed);
    eprintln!("{rows} rows written to {} ({} raw cycles skipped)", out.display(), joiner.skipped);
    if restart && gaps.missing > 0 {
        eprintln!(
            "warning: {} cycles missing (first after t = {:.4} s): a replay reproduces the \
             device's estimates only up to there",
            gaps.missing,
            gaps.first_after.unwrap_or(0.0)
        );
    }
    result.and(off.map(|_| ()))
}

/// Cycles missing from a log: gaps in `t` longer than 1.5 times the spacing of its first two
/// rows (the filter period).
#[derive(Default)]
struct GapCount {
    first: Option<f64>,
    period: Option<f64>,
    last: Option<f64>,
    missing: u64,
    first_after: Option<f64>,
}

impl GapCount {
    fn push(&mut self, t: f64) {
        match (self.first, self.period, self.last) {
            (None, _, _) => self.first = Some(t),
            (Some(first), None, _) => {
                self.period = Some(t - first);
                // `RAW,2` restarts `t`: the first row is one period after the restart.
                if t - first < first - 1e-6 {
                    self.missing += ((first / (t - first)).round() as u64).saturating_sub(1);
                    self.first_after.get_or_insert(0.0);
                }
            }
            (Some(_), Some(p), Some(last)) if p > 0.0 && t - last > 1.5 * p => {
                self.missing += ((t - last) / p).round() as u64 - 1;
                self.first_after.get_or_insert(last);
            }
            _ => {}
        }
        self.last = Some(t);
    }
}

/// Human description of a calibration position.
fn describe(pos: &str) -> String {
    let (axis, dir) = pos.split_at(1);
    format!("{axis} axis of the LSM303DLH pointing {}", dir.to_ascii_lowercase())
}

/// Prompt and read one answer line from stdin; `None` at end of input.
fn ask(stdin: &mut impl BufRead, prompt: &str) -> Option<String> {
    print!("{prompt}");
    io::stdout().flush().ok();
    let mut line = String::new();
    match stdin.read_line(&mut line) {
        Ok(0) | Err(_) => None,
        Ok(_) => {
            if !io::stdin().is_terminal() {
                println!();
            }
            Some(line.trim().to_string())
        }
    }
}

fn calibrate(port: &str, seconds: f64) -> Result<(), String> {
    let mut link = Link::open(port)?;
    let stdin = io::stdin();
    let mut input = stdin.lock();
    println!("Six-position accelerometer calibration on {port}.");
    expect_ok(&mut link, "ACAL,CLEAR")?;
    // The device measures the six means; the least-squares fit of X is done here.
    let mut fit = SixPositionFit::new();
    for (pos, position) in POSITION_NAMES.into_iter().zip(Position::ALL) {
        loop {
            let prompt = format!(
                "Position {pos}: {}. Hold it still and press Enter (q to quit): ",
                describe(pos)
            );
            let answer = ask(&mut input, &prompt).ok_or("input ended")?;
            if answer.eq_ignore_ascii_case("q") {
                let _ = link.command("ACAL,CLEAR", Duration::from_secs(2));
                return Err("calibration abandoned (nothing changed)".into());
            }
            let run = expect_ok(&mut link, &format!("ACAL,{pos},{seconds}"))?;
            if run.fields.first().map(String::as_str) != Some("RUN") {
                return Err(format!("unexpected reply {}", run.line));
            }
            let deadline = Instant::now() + secs(seconds + 10.0);
            let done = link
                .wait_reply("ACAL", deadline, |r| {
                    !r.ok || r.fields.first().is_some_and(|f| f == "DONE")
                })
                .map_err(io_err)?
                .ok_or_else(|| format!("no result for {pos}"))?;
            if done.ok {
                // OK,ACAL,DONE,<pos>,<ax>,<ay>,<az>,<positions collected>
                let f = &done.fields;
                let g = |i: usize| f.get(i).map(String::as_str).unwrap_or("?");
                println!("  {pos}: mean ({}, {}, {}) g", g(2), g(3), g(4));
                let mean: Vec<f32> = (2..5).filter_map(|i| g(i).parse().ok()).collect();
                let [x, y, z] = mean[..] else {
                    return Err(format!("unexpected reply {}", done.line));
                };
                fit.add_position(position, Vec3::new(x, y, z));
                break;
            }
            println!("  {pos} failed: {} — try again", done.fields.first().map_or("?", |s| s));
        }
    }
    let cal = fit.solve().map_err(|e| format!("fit failed: {e}"))?;
    let rms = fit.rms_residual_g(&cal).unwrap_or(f32::NAN);
    // X row by row (`accel_cal.x`, `.y`, `.z`: dimensionless; `.o`: the offset, g), all four
    // or none: a refused or lost `SET` puts back those already set.
    let rows: Vec<(String, String)> = cal
        .x
        .iter()
        .zip(["x", "y", "z", "o"])
        .map(|(row, name)| {
            (format!("accel_cal.{name}"), format!("{:e},{:e},{:e}", row[0], row[1], row[2]))
        })
        .collect();
    settings_cmd::set_all(&mut link, &rows).map_err(|(_, e)| e)?;
    println!("Fit done: rms residual {rms} g (accel_cal.* set, not saved).");
    let answer = ask(&mut input, "Save to flash? [y/N] ").unwrap_or_default();
    if answer.eq_ignore_ascii_case("y") || answer.eq_ignore_ascii_case("yes") {
        let saved = expect_ok(&mut link, "SAVE")?;
        println!("Saved: {}", saved.line);
    } else {
        println!("Not saved: the calibration is in use until reset; SAVE keeps it.");
    }
    Ok(())
}

fn emulator(pty: bool, port: Option<PathBuf>, opts: &emulate::Options) -> Result<(), String> {
    let banner = || {
        io::stdout().flush().ok();
        eprintln!(
            "emulating the iNEMO AHRS firmware (scenario {}, speed {}x); Ctrl-C to stop",
            opts.scenario, opts.speed
        );
    };
    if pty {
        let mut p = emulate::open_pty().map_err(|e| format!("openpty: {e}"))?;
        println!("{}", p.path.display());
        banner();
        emulate::run(&mut p.master, opts).map_err(io_err)
    } else {
        let path = port.ok_or("give --pty or --port")?;
        let f = emulate::open_path(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        println!("{}", path.display());
        banner();
        emulate::run(f, opts).map_err(io_err)
    }
}

#[cfg(test)]
mod tests {
    use crate::live::live_line;

    fn fields(line: &str) -> Vec<String> {
        line.split(',').map(str::to_string).collect()
    }

    #[test]
    fn live_shows_the_heading_reference_from_the_status_word() {
        let p = |status: &str| {
            fields(&format!("PINAH,1.00,2.00,3.00,1.0000,0.0000,0.0000,0.0000,2.5,{status},400"))
        };
        let line = live_line(None, Some(&p("000300")));
        assert!(
            line.contains("status 000300 (accelerometer used, at rest)  heading relative"),
            "{line}"
        );
        assert!(live_line(None, Some(&p("100300"))).ends_with("heading true (YAW)"));
        assert!(live_line(None, Some(&p("200300"))).ends_with("heading true (magnetometer)"));
        assert!(live_line(None, Some(&p(""))).ends_with("heading -"));
        let prdid = fields("PRDID,+2.00,+1.00,3.00");
        let words: Vec<String> =
            live_line(Some(&prdid), None).split_whitespace().map(str::to_string).collect();
        assert_eq!(words, ["roll", "+1.00", "pitch", "+2.00", "heading", "3.00"]);
    }
}
