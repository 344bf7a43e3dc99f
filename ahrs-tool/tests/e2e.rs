//! End-to-end tests: the tool against the emulated firmware (`ahrs-tool emulate --pty`: the
//! firmware library on the host behind a pseudo-terminal), at 10× real time.

use std::{
    io::{BufRead, BufReader, Write},
    net::{TcpListener, TcpStream, UdpSocket},
    process::{Child, Command, Stdio},
    time::{Duration, Instant},
};

mod common;
use common::{stdout, Emulator, BIN};

#[test]
fn send_ver_bad_command_and_setting_round_trip() {
    let emu = Emulator::start(&[]);
    let ver = emu.tool(&["send", "VER"]);
    assert_eq!(ver.status.code(), Some(0), "{ver:?}");
    assert!(stdout(&ver).starts_with("$PINAR,OK,VER,inemo-ahrs,"), "{}", stdout(&ver));

    let bad = emu.tool(&["send", "FLY"]);
    assert_eq!(bad.status.code(), Some(1));
    assert_eq!(stdout(&bad).trim(), "$PINAR,ERR,?,unknown-command*30");
    let range = emu.tool(&["send", "SET", "output.rate", "60"]);
    assert_eq!(range.status.code(), Some(1));
    assert!(stdout(&range).contains("ERR,SET,range,1,50"));

    let set = emu.tool(&["send", "SET", "gate.norm_tolerance", "0.08"]);
    assert_eq!(set.status.code(), Some(0));
    assert!(stdout(&set).contains("OK,SET,gate.norm_tolerance,0.08*"));
    let get = emu.tool(&["send", "GET,gate.norm_tolerance"]);
    assert_eq!(get.status.code(), Some(0));
    assert!(stdout(&get).contains("OK,GET,gate.norm_tolerance,0.08*"));
    let yaw = emu.tool(&["send", "YAW", "-30"]);
    assert!(stdout(&yaw).contains("OK,YAW,-30*"), "{}", stdout(&yaw));
    // GBIAS with its late reply: the simulated gyro bias, body FRD, deg/s.
    let gbias = emu.tool(&["send", "GBIAS", "2", "--wait-late", "5"]);
    assert_eq!(gbias.status.code(), Some(0), "{gbias:?}");
    let done = stdout(&gbias);
    let bx: f64 =
        done.split("DONE,").nth(1).and_then(|f| f.split(',').next()?.parse().ok()).unwrap();
    assert!((bx - 1.619).abs() < 0.1, "{done}");
    let status = emu.tool(&["send", "STATUS"]);
    assert!(stdout(&status).contains(",0003,"), "settings changed flag: {}", stdout(&status));
}

#[test]
fn send_times_out_without_a_device() {
    // A pty nobody answers on: the emulator's, with the emulator stopped.
    let mut emu = Emulator::start(&[]);
    emu.stop();
    let o = emu.tool(&["send", "VER", "--timeout", "0.3"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn live_shows_attitude_and_depth() {
    let emu = Emulator::start(&[]);
    let o = emu.tool(&["live", "--seconds", "1"]);
    assert!(o.status.success());
    let text = stdout(&o);
    let last = text.lines().last().unwrap_or("");
    assert!(last.contains("roll") && last.contains("depth    2.5 m"), "{text}");
}

#[test]
fn log_still_board_into_a_replayable_trace() {
    let emu = Emulator::start(&[]);
    let dir = std::env::temp_dir().join(format!("ahrs-tool-log-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("trace.csv");
    let o = emu.tool(&["log", "--out", csv.to_str().unwrap(), "--seconds", "2"]);
    assert!(o.status.success(), "{o:?}");
    let (cols, rows) = host_tests::trace::read_trace_file(&csv).expect("trace parses");
    std::fs::remove_dir_all(&dir).ok();
    assert!(cols.depth && cols.mag && !cols.truth);
    // 2 s at 10× and 50 Hz: about 1000 cycles.
    assert!(rows.len() > 500, "{} rows", rows.len());
    for w in rows.windows(2) {
        assert!((w[1].t - w[0].t - 0.02).abs() < 1e-3, "gap at t = {}", w[0].t);
    }
    let n = rows.len() as f32;
    let mean =
        |f: &dyn Fn(&host_tests::trace::TraceRow) -> f32| rows.iter().map(f).sum::<f32>() / n;
    let a = [mean(&|r| r.accel[0]), mean(&|r| r.accel[1]), mean(&|r| r.accel[2])];
    assert!(a[0].abs() < 0.1 && a[1].abs() < 0.1 && (a[2] + 9.81).abs() < 0.1, "{a:?}");
    // Gyro: the simulated bias (about 1.6, 3.4, 0 °/s), body FRD, rad/s.
    let g = [mean(&|r| r.gyro[0]), mean(&|r| r.gyro[1]), mean(&|r| r.gyro[2])];
    assert!((g[0] - 1.619f32.to_radians()).abs() < 0.005, "{g:?}");
    assert!((g[1] - 3.44f32.to_radians()).abs() < 0.005, "{g:?}");
    // Depth in every cycle's $PINAX (the last row's may be cut off by the end of the log).
    let with_depth = rows.iter().filter(|r| r.depth.is_some()).count();
    assert!(with_depth + 1 >= rows.len(), "{with_depth} of {}", rows.len());
    assert!(rows.iter().all(|r| r.depth.is_none_or(|d| (d - 2.5).abs() < 0.01) && r.mag.is_none()));
    // Raw mode was turned off again: the board answers and streams $PINAH.
    let status = emu.tool(&["send", "STATUS"]);
    let s = stdout(&status);
    let flags = s.split(',').nth(6).unwrap_or("");
    assert_eq!(u16::from_str_radix(flags, 16).unwrap() & 0x4, 0, "raw mode still on: {s}");
}

#[test]
fn calibrate_six_positions_from_stdin_and_save() {
    let emu = Emulator::start(&["--follow-acal"]);
    let text = common::calibrate(&emu.port);
    assert!(text.contains("Saved: $PINAR,OK,SAVE,A,1"), "{text}");
    let status = stdout(&emu.tool(&["send", "STATUS"]));
    assert!(status.starts_with("$PINAR,OK,STATUS,A,1,") && status.contains(",3F,R,,*"), "{status}");
    let cal = stdout(&emu.tool(&["send", "GET", "accel_cal.x"]));
    assert!(cal.contains("OK,GET,accel_cal.x,"), "{cal}");
}

#[test]
fn calibrate_quits_on_q_without_changes() {
    let emu = Emulator::start(&["--follow-acal"]);
    let mut child = Command::new(BIN)
        .args(["calibrate", &emu.port])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run calibrate");
    child.stdin.take().unwrap().write_all(b"q\n").unwrap();
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let status = stdout(&emu.tool(&["send", "STATUS"]));
    assert!(status.contains(",00,R,,*"), "{status}");
}

/// A child process killed on drop.
/// A TCP connection to the bridge at `addr`, once it listens (2.5 s at most).
fn connect_to_bridge(addr: &str) -> TcpStream {
    (0..50)
        .find_map(|_| {
            TcpStream::connect(addr).ok().or_else(|| {
                std::thread::sleep(Duration::from_millis(50));
                None
            })
        })
        .expect("the bridge listens")
}

struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The datagrams received on `udp` within `seconds`, each checked as one NMEA sentence.
fn datagrams(udp: &UdpSocket, seconds: f64) -> Vec<String> {
    let end = Instant::now() + Duration::from_secs_f64(seconds);
    let mut out = Vec::new();
    let mut buf = [0u8; 2048];
    while Instant::now() < end {
        if let Ok(n) = udp.recv(&mut buf) {
            let text = std::str::from_utf8(&buf[..n]).expect("ASCII datagram").to_string();
            assert!(text.ends_with("\r\n") && text.matches('$').count() == 1, "{text:?}");
            inemo_ahrs::nmea::verify(text.as_bytes()).expect("checksum");
            out.push(text.trim_end().to_string());
        }
    }
    out
}

#[test]
fn bridge_forwards_sentences_to_udp_and_tcp_and_tcp_commands_to_the_device() {
    let emu = Emulator::start(&[]);
    let udp = UdpSocket::bind("127.0.0.1:0").expect("UDP listener");
    udp.set_read_timeout(Some(Duration::from_millis(100))).unwrap();
    let udp_to = format!("127.0.0.1:{}", udp.local_addr().unwrap().port());
    let tcp_at = {
        let free = TcpListener::bind("127.0.0.1:0").expect("a free port");
        format!("127.0.0.1:{}", free.local_addr().unwrap().port())
    };
    let _bridge = Killed(
        Command::new(BIN)
            .args(["bridge", &emu.port, "--udp", &udp_to, "--tcp", &tcp_at, "--seconds", "30"])
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn bridge"),
    );
    // Emulated device → bridge → UDP: the default sentences, each a checked datagram.
    let first = datagrams(&udp, 1.0);
    assert!(first.iter().filter(|l| l.starts_with("$PINAH,")).count() > 20, "{first:?}");
    assert!(!first.iter().any(|l| l.starts_with("$HC")), "standard sentences are off by default");
    // A TCP client: it reads the stream, and its lines are commands to the device.
    let stream = connect_to_bridge(&tcp_at);
    stream.set_read_timeout(Some(Duration::from_secs(3))).unwrap();
    let mut writer = stream.try_clone().unwrap();
    let mut reader = BufReader::new(stream);
    let mut reply_to = |typed: &str, expect: &str| {
        writer.write_all(typed.as_bytes()).unwrap();
        let end = Instant::now() + Duration::from_secs(3);
        let mut line = String::new();
        while Instant::now() < end {
            line.clear();
            if reader.read_line(&mut line).is_err() {
                break;
            }
            if line.starts_with("$PINAR") {
                assert!(line.starts_with(expect), "{typed:?}: {line}");
                return;
            }
            assert!(line.starts_with('$') && line.ends_with("\r\n"), "{line:?}");
        }
        panic!("no reply to {typed:?}");
    };
    // Typed as an operator would: a bad command is refused, then the marine sentences go on.
    reply_to("FLY\n", "$PINAR,ERR,?,unknown-command*");
    reply_to("$PINAC,SENT,1,1,0,0,0,1,1\r\n", "$PINAR,OK,SENT,1,1,0,0,0,1,1*");
    // ... which the UDP listener now receives.
    let after = datagrams(&udp, 1.0);
    for s in ["$HCROT,", "$HCXDR,", "$PINAH,", "$PINAR,OK,SENT"] {
        assert!(after.iter().any(|l| l.starts_with(s)), "no {s} in {after:?}");
    }
}

/// Issue #38 point 4: the bridge outlives the device. Under a running bridge (the port a
/// symlink to the emulator's pseudo-terminal, as a udev name would be), the emulator is killed:
/// the bridge names the port and the reason, keeps its TCP client connected, and when a new
/// emulator answers at the same path it forwards its sentences to the same client; its
/// summary counts the reconnection. (Before: `ahrs-tool: Broken pipe`, exit 2, every client
/// cut.)
#[test]
fn the_bridge_outlives_the_device_and_keeps_its_clients() {
    let dir = std::env::temp_dir().join(format!("ahrs-bridge-outlives-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("ttyROV");
    let mut emu = Emulator::start(&[]);
    std::os::unix::fs::symlink(&emu.port, &path).unwrap();
    let tcp_at = {
        let free = TcpListener::bind("127.0.0.1:0").expect("a free port");
        format!("127.0.0.1:{}", free.local_addr().unwrap().port())
    };
    let log = dir.join("bridge.log");
    let mut bridge = Killed(
        Command::new(BIN)
            .args(["bridge", path.to_str().unwrap(), "--tcp", &tcp_at, "--seconds", "14"])
            .stderr(Stdio::from(std::fs::File::create(&log).unwrap()))
            .spawn()
            .expect("spawn bridge"),
    );
    let stream = connect_to_bridge(&tcp_at);
    stream.set_read_timeout(Some(Duration::from_millis(500))).unwrap();
    let mut reader = BufReader::new(stream);
    // PINAH lines read within `seconds`; `Err` at the end of the stream.
    let mut pinah = |seconds: f64| -> Result<usize, String> {
        let end = Instant::now() + Duration::from_secs_f64(seconds);
        let mut n = 0;
        while Instant::now() < end {
            let mut line = String::new();
            match reader.read_line(&mut line) {
                Ok(0) => return Err(format!("the bridge closed the client after {n} lines")),
                Ok(_) => n += usize::from(line.starts_with("$PINAH,")),
                Err(_) => {}
            }
        }
        Ok(n)
    };
    assert!(pinah(1.0).unwrap() > 5);
    emu.stop();
    // The device is gone: nothing comes, and the client is still connected.
    assert!(pinah(1.5).unwrap() <= 2);
    let emu2 = Emulator::start(&[]);
    std::fs::remove_file(&path).unwrap();
    std::os::unix::fs::symlink(&emu2.port, &path).unwrap();
    // Back within the retries' longest wait (5 s), on the same connection.
    assert!(pinah(7.0).unwrap() > 5);
    let status = bridge.0.wait().unwrap();
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(status.success(), "{text}");
    let name = path.display().to_string();
    assert!(
        text.contains(&format!("bridge: {name}: ")) && text.contains("the device is gone"),
        "{text}"
    );
    assert!(text.contains(&format!("bridge: {name} is back")), "{text}");
    assert!(text.contains("1 TCP clients served") && text.contains("1 reconnections"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `send LIST` without an index lists every setting: name, value, unit and range (issue #30;
/// the device alone answers `ERR,LIST,args`). The expected rows are `docs/commands.md`'s.
#[test]
fn send_list_without_an_index_lists_every_setting() {
    let emu = Emulator::start(&[]);
    emu.tool(&["send", "SET", "gate.norm_tolerance", "0.08"]);
    let o = emu.tool(&["send", "LIST"]);
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let text = stdout(&o);
    let lines: Vec<Vec<&str>> = text.lines().map(|l| l.split_whitespace().collect()).collect();
    assert_eq!(lines[0], ["name", "value", "unit", "range"]);
    assert_eq!(lines.len(), 1 + inemo_ahrs::registry::SETTINGS.len(), "{text}");
    let row = |name: &str| lines.iter().find(|l| l[0] == name).unwrap_or_else(|| panic!("{name}"));
    // | `noise.gyro_var` | f32x3 | (deg/s)2 | 1e-6 | 100 | `0.337,0.275,0.00419` |
    assert_eq!(row("noise.gyro_var")[1..], ["0.337,0.275,0.00419", "(deg/s)2", "1e-6", "…", "100"]);
    // The value now, not the default: | `gate.norm_tolerance` | f32 |  | 0.001 | 1 | `1` |
    assert_eq!(row("gate.norm_tolerance")[1..], ["0.08", "0.001", "…", "1"]);
    // | `output.prdid` | bool |  |  |  | `1` |: no unit, no range.
    assert_eq!(row("output.prdid")[1..], ["1"]);
}

/// Ctrl-C (SIGINT) ends `live` at once and cleanly: exit status 0, no error (the signal
/// handler sets the flag its loop reads; without it the process dies of the signal).
#[test]
fn ctrl_c_ends_live_cleanly() {
    let emu = Emulator::start(&[]);
    let mut child = Command::new(BIN)
        .args(["live", &emu.port])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run live");
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    assert!(line.starts_with("roll"), "{line}");
    let kill = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(kill.success());
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(start.elapsed() < Duration::from_secs(5), "live still running after Ctrl-C");
        std::thread::sleep(Duration::from_millis(20));
    };
    let _ = std::io::Read::read_to_string(&mut out, &mut String::new());
    assert!(status.success(), "{status:?}");
}

/// `log` in the background, its output file, and a way to wait for its end.
struct Logging {
    child: Child,
    csv: std::path::PathBuf,
    _dir: tempfile::TempDir,
}

impl Logging {
    /// `log --out DIR/trace.csv` on `emu`, started through `sh -c` with `ignore` (e.g.
    /// `trap "" INT HUP`: how a background job or `nohup` starts it) before the `exec`.
    fn start(emu: &Emulator, ignore: &str) -> Logging {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("trace.csv");
        let script = format!("{ignore}\nexec \"$0\" log \"$1\" --out \"$2\"");
        let child = Command::new("sh")
            .args(["-c", &script, BIN, &emu.port, csv.to_str().unwrap()])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run log");
        Logging { child, csv, _dir: dir }
    }

    /// Wait until the file holds at least `rows` data rows (lines not starting with `#`, less
    /// the header), at most 20 s; how many it holds then.
    fn wait_rows(&self, rows: usize) -> usize {
        let start = Instant::now();
        loop {
            let text = std::fs::read_to_string(&self.csv).unwrap_or_default();
            let n = text.lines().filter(|l| !l.starts_with('#')).count().saturating_sub(1);
            if n >= rows {
                return n;
            }
            assert!(start.elapsed() < Duration::from_secs(20), "{n} rows after 20 s");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    fn signal(&self, sig: &str) {
        let ok = Command::new("kill").args([sig, &self.child.id().to_string()]).status().unwrap();
        assert!(ok.success());
    }

    /// The exit status and stderr, within `seconds`; `None` if still running then.
    fn wait(&mut self, seconds: f64) -> Option<(std::process::ExitStatus, String)> {
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs_f64(seconds) {
            if let Some(s) = self.child.try_wait().unwrap() {
                let mut err = String::new();
                std::io::Read::read_to_string(self.child.stderr.as_mut().unwrap(), &mut err).ok();
                return Some((s, err));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        None
    }
}

impl Drop for Logging {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The device's raw-mode bit (STATUS flags bit 2).
fn raw_mode_on(emu: &Emulator) -> bool {
    let s = stdout(&emu.tool(&["send", "STATUS"]));
    let flags = s.split(',').nth(6).unwrap_or("");
    u16::from_str_radix(flags, 16).expect("STATUS flags") & 0x4 != 0
}

/// Issue #39, point 1: SIGTERM (and SIGHUP, SIGINT) ends `log` the way its time does: exit 0,
/// every row on disk, the device out of raw mode. Before, SIGTERM killed it with a 0-byte file
/// (the rows were buffered) and the device left in raw mode.
#[test]
fn sigterm_or_sighup_ends_log_with_its_rows_and_the_device_as_it_was() {
    let emu = Emulator::start(&[]);
    for sig in ["-TERM", "-HUP", "-INT"] {
        let mut log = Logging::start(&emu, "");
        log.wait_rows(100);
        log.signal(sig);
        let (status, err) = log.wait(5.0).unwrap_or_else(|| panic!("{sig}: log still running"));
        assert!(status.success(), "{sig}: {status:?} {err}");
        let (_, rows) = host_tests::trace::read_trace_file(&log.csv).expect("the log parses");
        assert!(rows.len() >= 100, "{sig}: {} rows", rows.len());
        assert!(err.contains(&format!("{} rows written", rows.len())), "{sig}: {err}");
        assert!(!raw_mode_on(&emu), "{sig}: raw mode left on");
    }
}

/// Started as a background job or under `nohup` (SIGINT and SIGHUP ignored when it starts),
/// `log` leaves those ignored, as it was asked, and still ends cleanly on SIGTERM. Before, the
/// signal library refused to install anything when a signal was not at its default, and
/// SIGTERM left the device in raw mode.
#[test]
fn as_a_background_job_log_keeps_ignoring_int_and_hup_and_ends_on_term() {
    let emu = Emulator::start(&[]);
    let mut log = Logging::start(&emu, "trap '' INT HUP");
    log.wait_rows(50);
    log.signal("-INT");
    log.signal("-HUP");
    assert!(log.wait(1.0).is_none(), "an ignored signal ended the log");
    log.signal("-TERM");
    let (status, err) = log.wait(5.0).expect("log still running after SIGTERM");
    assert!(status.success(), "{status:?} {err}");
    assert!(!raw_mode_on(&emu), "raw mode left on");
}

/// A kill that cannot be caught (SIGKILL) loses at most the row being written: the rows
/// before it are on disk, each flushed as it comes (they appear one by one: the first time the
/// file shows any, it shows a few, where 64 KiB blocks showed about 1,100 at once).
#[test]
fn after_a_sigkill_the_rows_so_far_are_on_disk() {
    let emu = Emulator::start(&[]);
    let mut log = Logging::start(&emu, "");
    let first = log.wait_rows(1);
    assert!(first < 50, "the first rows appeared {first} at once");
    log.wait_rows(100);
    log.signal("-KILL");
    log.wait(5.0).expect("killed");
    let text = std::fs::read_to_string(&log.csv).unwrap();
    // t, gyro, accel, mag, depth: 11 cells.
    let complete = text.lines().filter(|l| !l.starts_with('#') && l.split(',').count() == 11);
    assert!(complete.count() >= 100, "{text:.300}");
    // The device stays in raw mode (nothing could switch it back); the next tool does.
    assert!(emu.tool(&["send", "RAW,0"]).status.success());
}

/// A signal during the settings walk, before the log starts: nothing written, no file, the
/// device never switched to raw mode. Before, SIGINT in the walk's first seconds killed the
/// tool (no handler yet).
#[test]
fn a_signal_before_the_log_starts_leaves_no_file() {
    // In real time the walk takes seconds (a `GET` per setting, each answered in a cycle).
    let emu = Emulator::start_at(1.0, &[]);
    let mut log = Logging::start(&emu, "");
    // The tool opens the port after installing its handlers: once it holds the port, the
    // signal lands in the walk, however loaded the machine.
    let fds = format!("/proc/{}/fd", log.child.id());
    let start = Instant::now();
    while !std::fs::read_dir(&fds)
        .into_iter()
        .flatten()
        .flatten()
        .any(|e| std::fs::read_link(e.path()).is_ok_and(|l| l == std::path::Path::new(&emu.port)))
    {
        assert!(start.elapsed() < Duration::from_secs(20), "log never opened {}", emu.port);
        std::thread::sleep(Duration::from_millis(10));
    }
    log.signal("-INT");
    let (status, err) = log.wait(20.0).expect("log still running");
    assert!(!status.success(), "{status:?} {err}");
    assert!(err.contains("interrupted before the log started"), "{err}");
    assert!(!log.csv.exists(), "a file was written");
    assert!(!raw_mode_on(&emu));
}

/// Issue #37, point 5: the emulator's `SELFTEST` reads as a healthy board with a depth sensor
/// (the emulator simulates one) reads: the 8 MHz crystal, VDDA 3.3 V, the accelerometer at
/// 1 g, the gyro references at their zero-rate 1.5 V, the depth channel, no I²C errors; the
/// one warning is the settings' (defaults, no saved record at boot), and without `--mag` the
/// magnetometer's (no sample). It used to answer `FAIL,12AAA` with every field empty.
#[test]
fn the_emulators_self_test_reads_as_a_healthy_board() {
    for (extra, grades) in [(&[][..], "10100"), (&["--mag"][..], "10000")] {
        let emu = Emulator::start(extra);
        let s = stdout(&emu.tool(&["send", "SELFTEST"]));
        let f: Vec<&str> = s.trim().split('*').next().unwrap().split(',').collect();
        assert_eq!(f[..5], ["$PINAR", "OK", "SELFTEST", "WARN", grades], "{s}");
        assert_eq!((f[5], f[6]), ("8000", "3300"), "{s}");
        let accel_mg: f32 = f[7].parse().unwrap();
        assert!((accel_mg - 1000.0).abs() < 10.0, "{s}");
        assert_eq!(f[8].is_empty(), extra.is_empty(), "{s}");
        assert_eq!((f[9], f[10]), ("1500", "1500"), "{s}");
        assert!(f[11].parse::<f32>().unwrap() > 0.0, "{s}");
        assert_eq!((f[12], f[13]), ("0", "0"), "{s}");
    }
}
