//! End-to-end test against the firmware on an emulated Cortex-M3: `ekf-emu-serial` (the firmware
//! library's pipeline, command layer and settings persistence behind the STM32F2 USART2) runs
//! in QEMU's `netduino2` with its serial port on a pseudo-terminal, in real time; the real
//! `ahrs-tool` binary drives it. The expected values come from outside the firmware: the trace
//! the firmware replays (`emu/trace.csv`: sensor rows and the true attitude), the documented
//! replies, and the wall clock.
//!
//! Needs `qemu-system-arm` and the thumbv7m route of `scripts/setup.sh`. Without them the test
//! is skipped with a message, unless `CI` or `AHRS_QEMU_REQUIRED` is set (as `scripts/test-all`
//! does): then it fails. `AHRS_QEMU_ELF` names a prebuilt `ekf-emu-serial`; otherwise the test
//! builds it with `scripts/cargo-thumb`.

use std::{
    env,
    fs::{File, OpenOptions},
    io::{BufRead, BufReader, Read, Write},
    os::{fd::AsRawFd, unix::fs::OpenOptionsExt},
    path::{Path, PathBuf},
    process::{Child, ChildStdin, Command, Output, Stdio},
    sync::mpsc,
    thread,
    time::{Duration, Instant},
};

use host_tests::{
    config::ReplayConfig,
    replay::{replay, truth_euler_deg, FilterKind},
    trace::{read_trace_file, TraceReader, TraceRow},
};

mod common;
use common::{clients, stdout, BIN};
use nix::sys::termios;
/// Rate of the firmware's filter (default setting) and of the trace, Hz.
const RATE: f64 = 50.0;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").to_path_buf()
}

fn required() -> bool {
    let set = |v: &str| env::var(v).is_ok_and(|s| !s.is_empty() && s != "0" && s != "false");
    set("CI") || set("AHRS_QEMU_REQUIRED")
}

/// The firmware image, or why there is none.
fn firmware() -> Result<PathBuf, String> {
    if let Ok(p) = env::var("AHRS_QEMU_ELF") {
        let p = PathBuf::from(p);
        assert!(p.is_file(), "AHRS_QEMU_ELF={}: no such file", p.display());
        return Ok(p);
    }
    let root = root();
    if !root.join("target/thumb-route.env").is_file() {
        return Err("no thumbv7m route: run scripts/setup.sh".into());
    }
    // Its own target directory: the `cargo test` that runs this test holds the lock of its own.
    let dir = root.join("target/qemu-e2e");
    let out = Command::new(root.join("scripts/cargo-thumb"))
        .args(["build", "-p", "ekf-emu", "--bin", "ekf-emu-serial", "--release", "--locked", "-q"])
        .env("CARGO_TARGET_DIR", &dir)
        // The image must embed emu/trace.csv, the truth this test reads.
        .env_remove("EKF_EMU_TRACE")
        .current_dir(&root)
        .output()
        .map_err(|e| format!("scripts/cargo-thumb: {e}"))?;
    // A failed build is a failure, never a skip.
    assert!(
        out.status.success(),
        "building ekf-emu-serial failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    Ok(dir.join("thumbv7m-none-eabi/release/ekf-emu-serial"))
}

/// QEMU running the firmware; killed on drop (also when the test fails).
struct Qemu {
    child: Child,
    monitor: ChildStdin,
    port: String,
    booted: Instant,
}

impl Qemu {
    fn start(elf: &Path) -> Qemu {
        let booted = Instant::now();
        let mut child = Command::new("qemu-system-arm")
            .args(["-M", "netduino2", "-nographic", "-monitor", "stdio"])
            // The first -serial is USART1, the second USART2 (the board's output port).
            .args(["-serial", "null", "-serial", "pty", "-kernel"])
            .arg(elf)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn qemu-system-arm");
        let monitor = child.stdin.take().expect("monitor");
        let stdout = child.stdout.take().expect("stdout");
        // "char device redirected to /dev/pts/N (label serial1)"; then keep draining stdout.
        let (tx, rx) = mpsc::channel();
        thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if let Some(p) = line.split("redirected to ").nth(1) {
                    let _ = tx.send(p.split_whitespace().next().unwrap_or("").to_string());
                }
            }
        });
        let port = rx.recv_timeout(Duration::from_secs(10));
        let mut q = Qemu { child, monitor, port: String::new(), booted };
        q.port = port.unwrap_or_else(|_| panic!("QEMU named no pty"));
        q
    }

    /// `system_reset` from the monitor: the firmware boots again (like the reset button).
    fn reset(&mut self) {
        self.monitor.write_all(b"system_reset\n").expect("monitor");
        self.monitor.flush().expect("monitor");
        self.booted = Instant::now();
        self.wait_stream();
    }

    fn tool(&self, sub: &str, args: &[&str]) -> Output {
        Command::new(BIN).arg(sub).arg(&self.port).args(args).output().expect("run ahrs-tool")
    }

    /// `ahrs-tool send`: exit code and the reply line(s).
    fn send(&self, args: &[&str]) -> (Option<i32>, String) {
        let o = self.tool("send", args);
        (o.status.code(), stdout(&o).trim().to_string())
    }

    /// The port, opened as the tool opens it (raw mode, no controlling terminal).
    fn open_port(&self) -> File {
        let port = OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(libc::O_NOCTTY | libc::O_NONBLOCK)
            .open(&self.port)
            .expect("open pty");
        let mut t = termios::tcgetattr(port.as_raw_fd()).expect("tcgetattr");
        termios::cfmakeraw(&mut t);
        termios::tcsetattr(port.as_raw_fd(), termios::SetArg::TCSANOW, &t).expect("tcsetattr");
        port
    }

    /// The first complete line starting with `start` read from `port` within 3 s.
    fn read_line(port: &mut File, start: &str) -> String {
        let deadline = Instant::now() + Duration::from_secs(3);
        let mut text = String::new();
        let mut buf = [0u8; 512];
        while Instant::now() < deadline {
            match port.read(&mut buf) {
                Ok(n) => text.push_str(&String::from_utf8_lossy(&buf[..n])),
                Err(_) => thread::sleep(Duration::from_millis(10)),
            }
            if let Some(rest) = text.split(start).nth(1) {
                if let Some((line, _)) = rest.split_once('\n') {
                    return format!("{start}{}", line.trim_end());
                }
            }
        }
        panic!("no {start} line: {text:?}");
    }

    /// Wait until the firmware streams (it drops what it receives before its USART is on).
    fn wait_stream(&self) {
        Qemu::read_line(&mut self.open_port(), "$PINAH");
    }

    /// Write one raw line to the port and return the first `$PINAR` line that comes back.
    fn raw_line(&self, line: &str) -> String {
        let mut port = self.open_port();
        port.write_all(line.as_bytes()).expect("write pty");
        Qemu::read_line(&mut port, "$PINAR")
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn wait_until(t: Instant) {
    let now = Instant::now();
    if t > now {
        thread::sleep(t - now);
    }
}

/// The STATUS reply's fields after the verb: source, sequence, reset cause, flags, positions,
/// heading reference, fault, stack.
fn status(q: &Qemu) -> Vec<String> {
    let (code, s) = q.send(&["STATUS"]);
    assert_eq!(code, Some(0), "{s}");
    let body = s.split('*').next().unwrap_or("");
    body.split(',').skip(3).map(str::to_string).collect()
}

/// Roll, pitch, yaw (°), depth (m) and status word of one `live` line.
fn live_values(line: &str) -> Option<[f64; 5]> {
    let w: Vec<&str> = line.split_whitespace().collect();
    let at =
        |name: &str| w.iter().position(|x| *x == name).and_then(|i| w.get(i + 1)?.parse().ok());
    let status = w.iter().position(|x| *x == "status").and_then(|i| w.get(i + 1))?;
    let status = f64::from(u32::from_str_radix(status, 16).ok()?);
    Some([at("roll")?, at("pitch")?, at("yaw")?, at("depth")?, status])
}

/// Difference of two angles, degrees, in (−180, 180].
fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

#[test]
fn tool_against_the_firmware_on_qemu() {
    let qemu_ok =
        Command::new("qemu-system-arm").arg("--version").output().is_ok_and(|o| o.status.success());
    let elf = if qemu_ok { firmware() } else { Err("qemu-system-arm not found".into()) };
    let elf = match elf {
        Ok(e) => e,
        Err(why) if required() => panic!("QEMU end-to-end test cannot run: {why}"),
        Err(why) => {
            eprintln!(
                "SKIPPED tool_against_the_firmware_on_qemu: {why} (set CI=1 to make this fail)"
            );
            return;
        }
    };
    let (_, truth) = read_trace_file(&root().join("emu/trace.csv")).expect("emu/trace.csv");
    let n = truth.len();
    let mut q = Qemu::start(&elf);
    q.wait_stream();

    // Boot: defaults (no record), power-on reset.
    let (code, ver) = q.send(&["VER"]);
    assert_eq!(code, Some(0), "{ver}");
    assert!(ver.starts_with("$PINAR,OK,VER,inemo-ahrs,"), "{ver}");
    let boot = status(&q);
    assert_eq!(&boot[..3], ["DEFAULTS", "", "POR"], "{boot:?}");

    // Refused commands reply an error and change nothing.
    let bad = q.raw_line("$PINAC,SET,output.rate,5*00\r\n");
    assert!(bad.starts_with("$PINAR,ERR,?,checksum*"), "{bad}");
    let (code, r) = q.send(&["GET", "no.such"]);
    assert_eq!((code, r.contains("ERR,GET,unknown-setting")), (Some(1), true), "{r}");
    let (code, r) = q.send(&["SET", "output.rate", "60"]);
    assert_eq!((code, r.contains("ERR,SET,range,1,50*")), (Some(1), true), "{r}");
    let (code, r) = q.send(&["FLY"]);
    assert_eq!((code, r.as_str()), (Some(1), "$PINAR,ERR,?,unknown-command*30"));
    assert_eq!(status(&q), boot, "a refused command changed the state");
    let (_, r) = q.send(&["GET", "output.rate"]);
    assert!(r.contains("OK,GET,output.rate,10*"), "{r}");

    // Raw log, once the trace moves (10 s of stillness, the initialisation window): every row
    // is the trace's next row, in real time.
    wait_until(q.booted + Duration::from_secs_f64(10.5));
    let dir = env::temp_dir().join(format!("ahrs-tool-qemu-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("trace.csv");
    let log_start = Instant::now();
    let o = q.tool("log", &["--out", csv.to_str().unwrap(), "--seconds", "3"]);
    let log_end = Instant::now();
    assert!(o.status.success(), "{o:?}");
    let (cols, rows) = read_trace_file(&csv).expect("the log parses as a trace");
    assert!(cols.depth && !cols.truth);
    let span = rows.last().unwrap().t - rows[0].t;
    // 3 s of raw mode (`t` sums f32 cycle times: a rounding above 3 s is still 3 s).
    assert!(
        rows.len() >= 100 && (2.0..=3.001).contains(&span),
        "{} rows over {span} s",
        rows.len()
    );
    // `t` is the sum of the cycle times since boot: cycle k uses trace row k (mod n). Raw mode
    // starts once `log` has read the device's settings for the header (`LIST`, `GET` of each:
    // seconds at the emulated baud rate), between the command's start and its end.
    let first = (rows[0].t * RATE).round() as usize - 1;
    let since_boot = (log_start - q.booted).as_secs_f64();
    let until = (log_end - q.booted).as_secs_f64() - span;
    assert!(
        rows[0].t > since_boot - 1.0 && rows[0].t < until + 1.0,
        "firmware at {} s, wall {since_boot}-{until} s",
        rows[0].t
    );
    // The lever-arm compensation of the conditioning (centripetal term, the Seahog's arm) moves
    // the accelerometer by at most |ω − b̂|²·|r|, with b̂ the estimator's gyro bias: at most
    // (|ω| + 0.1 rad/s)²·|r| (the iNEMO's bias is 0.066 rad/s, the estimate starts there).
    const BIAS_BOUND: f32 = 0.1;
    let arm = ekf_core::lever_arm::LeverArm::default().r;
    let arm = (arm.x * arm.x + arm.y * arm.y + arm.z * arm.z).sqrt();
    for (k, r) in rows.iter().enumerate() {
        let want: &TraceRow = &truth[(first + k) % n];
        let dg = (0..3).map(|i| (r.gyro[i] - want.gyro[i]).abs()).fold(0.0, f32::max);
        let da = (0..3).map(|i| (r.accel[i] - want.accel[i]).abs()).fold(0.0, f32::max);
        let w = want.gyro.iter().map(|w| w * w).sum::<f32>().sqrt() + BIAS_BOUND;
        // Gyro: 5 decimals; accelerometer: 1 mg counts (half a step 0.0049 m/s²), 4 decimals,
        // the lever arm.
        assert!(
            dg < 2e-5 && da < 0.005 + w * w * arm,
            "row {k} (t {}): {r:?} vs trace {want:?}",
            r.t
        );
        // Depth in every cycle's $PINAX (the last one may be cut off by the end of the log).
        assert!(r.depth == Some(2.5) || k + 1 == rows.len(), "row {k}: {r:?}");
    }
    let flags = u16::from_str_radix(&status(&q)[3], 16).expect("flags");
    assert_eq!(flags & 0x4, 0, "raw mode still on after the log");
    // `host-tests replay` accepts the log.
    let reader = TraceReader::new(BufReader::new(File::open(&csv).unwrap())).unwrap();
    let cfg = ReplayConfig::default();
    let mut filter = cfg.make_filter(FilterKind::Ekf);
    let mut cond = ekf_core::conditioning::Conditioner::new(cfg.conditioning);
    let stats = replay(reader, Vec::new(), filter.as_mut(), &mut cond, 0.0).expect("replay");
    assert_eq!(stats.rows, rows.len() as u64);
    std::fs::remove_dir_all(&dir).ok();

    // Live view: the firmware's attitude against the trace's truth, aligned by the log's last
    // row (its trace time at the end of the log), and the depth.
    let t_end = rows.last().unwrap().t;
    let trace_time = |at: Instant| t_end + at.saturating_duration_since(log_end).as_secs_f64();
    let live = |q: &Qemu, seconds: f64| {
        let o = q.tool("live", &["--seconds", &seconds.to_string()]);
        let end = Instant::now();
        assert!(o.status.success(), "{o:?}");
        let lines: Vec<[f64; 5]> = stdout(&o).lines().filter_map(live_values).collect();
        let m = lines.len() as f64;
        // 10 Hz output in real time: one line per update, its $PRDID and $PINAH together (the
        // first fraction of a second may be lost while the tool starts and QEMU sees the pty
        // open).
        let (lo, hi) = ((10.0 * (seconds - 1.0)).max(3.0), 10.0 * seconds + 2.0);
        assert!((lo..=hi).contains(&m), "{m} lines in {seconds} s");
        // Lines come every 0.1 s until the tool stops (its start-up may take a while).
        let times: Vec<f64> =
            (0..lines.len()).map(|i| trace_time(end) - 0.1 * (m - i as f64)).collect();
        (lines, times)
    };
    let truth_near = |t: f64, slack: f64| -> Vec<[f64; 3]> {
        let (lo, hi) = (((t - slack) * RATE) as usize, ((t + slack) * RATE) as usize);
        (lo..=hi).map(|k| truth_euler_deg(truth[(k + n - 1) % n].truth.unwrap())).collect()
    };
    let (lines, times) = live(&q, 3.0);
    for (v, &t) in lines.iter().zip(&times) {
        assert_eq!(v[3], 2.5, "depth");
        // Status bit 0 (ekf_core::Flags::INITIALISING): the window is over.
        assert_eq!(v[4] as u32 & 1, 0, "still initialising at trace time {t:.2}");
        let near = truth_near(t, 0.75);
        for axis in 0..3 {
            let err =
                near.iter().map(|e| angle_diff(v[axis], e[axis]).abs()).fold(f64::MAX, f64::min);
            assert!(
                err < 1.0,
                "axis {axis} at trace time {t:.2}: {v:?}, truth {:?}",
                near[near.len() / 2]
            );
        }
    }

    // YAW: the heading jumps to −30° (then follows the trace's yaw changes).
    let yaw_at = trace_time(Instant::now());
    let (code, r) = q.send(&["YAW", "-30"]);
    assert_eq!((code, r.contains("OK,YAW,-30*")), (Some(0), true), "{r}");
    let (lines, times) = live(&q, 1.0);
    let yaw0 = truth_near(yaw_at, 0.0)[0][2];
    for (v, &t) in lines.iter().zip(&times) {
        let want = -30.0 + truth_near(t, 0.0)[0][2] - yaw0;
        assert!(angle_diff(v[2], want).abs() < 1.0, "yaw {} at {t:.2}, want {want}", v[2]);
    }

    // The marine sentences through the real clients (`docs/marine.md`): every sentence on, 2 s
    // of the stream; the heading is true since `YAW`, no magnetometer in the trace.
    let (code, r) = q.send(&["SENT,1,1,1,1,1,1,1"]);
    assert_eq!(code, Some(0), "{r}");
    assert!(status(&q).get(5).is_some_and(|r| r == "T"), "heading true after YAW");
    if let Some(c) = clients::clients_or_skip() {
        let p = clients::parse(&c, clients::capture(&q.port, 2.0), "qemu");
        let n = clients::check_agreement(&p);
        // 10 Hz in real time; ROT's first rate needs the output before it.
        assert!(n.outputs >= 12, "{n:?}");
        assert!(n.hdt == n.outputs && n.xdr == n.outputs && n.rot + 1 >= n.outputs, "{n:?}");
        assert_eq!((n.hdg, n.hdm), (0, 0), "no magnetometer: {n:?}");
    }
    let (code, r) = q.send(&["SENT,1,1,0,0,0,0,0"]);
    assert_eq!(code, Some(0), "{r}");

    // A setting round trip (after the attitude checks: an estimator setting changed during
    // the initialisation window restarts the window).
    let (code, r) = q.send(&["SET", "gate.norm_tolerance", "0.08"]);
    assert_eq!((code, r.contains("OK,SET,gate.norm_tolerance,0.08*")), (Some(0), true), "{r}");
    let (_, r) = q.send(&["GET,gate.norm_tolerance"]);
    assert!(r.contains("OK,GET,gate.norm_tolerance,0.08*"), "{r}");

    // SAVE survives a reset; an unsaved change does not.
    let (code, r) = q.send(&["SAVE"]);
    assert_eq!((code, r.as_str()), (Some(0), "$PINAR,OK,SAVE,A,1*31"));
    let (code, _) = q.send(&["SET", "gate.norm_tolerance", "0.09"]);
    assert_eq!(code, Some(0));
    q.reset();
    assert_eq!(&status(&q)[..3], ["A", "1", "PIN"]);
    let (_, r) = q.send(&["GET", "gate.norm_tolerance"]);
    assert!(r.contains("OK,GET,gate.norm_tolerance,0.08*"), "{r}");

    // Six-position calibration with the board put in each position by the firmware's
    // cooperative operator, saved, kept over a reset.
    let text = common::calibrate(&q.port);
    assert!(text.contains("Saved: $PINAR,OK,SAVE,B,2"), "{text}");
    assert_eq!(status(&q)[4], "3F", "all six positions collected");
    let (_, cal) = q.send(&["GET", "accel_cal.x"]);
    assert!(cal.contains("OK,GET,accel_cal.x,"), "{cal}");
    q.reset();
    let after = status(&q);
    assert_eq!(&after[..3], ["B", "2", "PIN"], "{after:?}");
    assert_eq!(q.send(&["GET", "accel_cal.x"]).1, cal);
}
