//! The device's marine sentences read by real NMEA 0183 clients (issue #15): the emulated
//! device (`ahrs-tool emulate --pty`, the firmware library on the host, at 10× real time)
//! streams every sentence; the lines captured from its port go through pynmea2 (Python) and
//! Signal K's parser `@signalk/nmea0183-signalk` (node), as installed by `scripts/marine-clients`
//! under `target/`. Every sentence must parse in both (checksums checked), and what the clients
//! read must agree with the estimate the device sent in the same output (`$PINAH`, 2 decimals)
//! within the sentence's precision; data the device marks invalid never reaches Signal K as
//! valid.
//!
//! Without the clients the test is skipped with a message, unless `CI` or
//! `AHRS_MARINE_REQUIRED` is set (as `scripts/test-all` does): then it fails.

use std::{
    env,
    io::{BufRead, BufReader, Read},
    path::{Path, PathBuf},
    process::{Child, Command, Stdio},
    time::{Duration, Instant},
};

// `calibrate` is for the other end-to-end tests.
#[allow(dead_code)]
mod common;
use common::{stdout, BIN};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").to_path_buf()
}

fn required() -> bool {
    let set = |v: &str| env::var(v).is_ok_and(|s| !s.is_empty() && s != "0" && s != "false");
    set("CI") || set("AHRS_MARINE_REQUIRED")
}

/// The clients: (pynmea2's python, Signal K's node_modules), or why they are missing.
fn clients() -> Result<(PathBuf, PathBuf), String> {
    let root = root();
    let python = root.join("target/marine-venv/bin/python");
    let modules = root.join("target/marine-node/node_modules");
    let ok = |c: &mut Command| c.output().is_ok_and(|o| o.status.success());
    if !ok(Command::new(&python).args(["-c", "import pynmea2"])) {
        return Err(format!("no pynmea2 in {}: run scripts/marine-clients", python.display()));
    }
    if !ok(Command::new("node")
        .args(["-e", "require('@signalk/nmea0183-signalk')"])
        .env("NODE_PATH", &modules))
    {
        return Err(format!(
            "no node or no @signalk/nmea0183-signalk in {}: run scripts/marine-clients",
            modules.display()
        ));
    }
    Ok((python, modules))
}

/// The clients, or `None` (skip) when they are missing and not required.
fn clients_or_skip() -> Option<(PathBuf, PathBuf)> {
    match clients() {
        Ok(c) => Some(c),
        Err(why) if required() => panic!("marine client test cannot run: {why}"),
        Err(why) => {
            eprintln!("skipped: {why} (set AHRS_MARINE_REQUIRED=1 to fail instead)");
            None
        }
    }
}

/// A running emulator; killed on drop.
struct Emulator {
    child: Child,
    port: String,
}

impl Emulator {
    fn start(args: &[&str]) -> Emulator {
        let mut child = Command::new(BIN)
            .args(["emulate", "--pty", "--speed", "10"])
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn emulator");
        let mut line = String::new();
        let read = BufReader::new(child.stdout.take().expect("stdout")).read_line(&mut line);
        let mut emu = Emulator { child, port: line.trim().to_string() };
        if read.is_err() || emu.port.is_empty() {
            let _ = emu.child.kill();
            panic!("emulator printed no port");
        }
        emu
    }

    /// `ahrs-tool send`: the reply, which must be OK.
    fn send(&self, command: &str) -> String {
        let o = Command::new(BIN).args(["send", &self.port, command]).output().expect("send");
        let reply = stdout(&o);
        assert_eq!(o.status.code(), Some(0), "{command}: {reply}");
        reply
    }

    /// The complete lines the device sends during `seconds` (wall clock).
    fn capture(&self, seconds: f64) -> Vec<String> {
        let mut port = std::fs::OpenOptions::new()
            .read(true)
            .custom_flags_nonblock()
            .open(&self.port)
            .expect("open pty");
        let end = Instant::now() + Duration::from_secs_f64(seconds);
        let mut bytes = Vec::new();
        let mut buf = [0u8; 4096];
        while Instant::now() < end {
            match port.read(&mut buf) {
                Ok(n) if n > 0 => bytes.extend_from_slice(&buf[..n]),
                _ => std::thread::sleep(Duration::from_millis(5)),
            }
        }
        let text = String::from_utf8_lossy(&bytes).into_owned();
        // Drop the partial first and last lines.
        let mut lines: Vec<String> = text.split("\r\n").map(str::to_string).collect();
        lines.pop();
        if !lines.is_empty() {
            lines.remove(0);
        }
        lines.retain(|l| l.starts_with('$') && !l.starts_with("$PINAR"));
        lines
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

trait NonBlock {
    fn custom_flags_nonblock(&mut self) -> &mut Self;
}
impl NonBlock for std::fs::OpenOptions {
    fn custom_flags_nonblock(&mut self) -> &mut Self {
        use std::os::unix::fs::OpenOptionsExt;
        self.custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY)
    }
}

/// What both clients read from each line: pynmea2's fields and Signal K's `path=value`s.
struct Parsed {
    lines: Vec<String>,
    pynmea2: Vec<Vec<String>>,
    signalk: Vec<Vec<String>>,
}

/// Run both clients over `lines` (written to a file under target/).
fn parse(clients: &(PathBuf, PathBuf), lines: Vec<String>, name: &str) -> Parsed {
    let root = root();
    let dir = root.join("target/marine-test");
    std::fs::create_dir_all(&dir).expect("target/marine-test");
    let file = dir.join(format!("{name}-{}.nmea", std::process::id()));
    let text: String = lines.iter().map(|l| format!("{l}\r\n")).collect();
    std::fs::write(&file, text).expect("write capture");
    let run = |c: &mut Command| {
        let o = c.output().expect("run client");
        assert!(o.status.success(), "{c:?}: {}", String::from_utf8_lossy(&o.stderr));
        let out = stdout(&o);
        let rows: Vec<Vec<String>> =
            out.lines().map(|l| l.split('\t').skip(1).map(str::to_string).collect()).collect();
        assert_eq!(rows.len(), lines.len(), "{c:?} answered every line");
        rows
    };
    let pynmea2 =
        run(Command::new(&clients.0).arg(root.join("tools/marine/parse_pynmea2.py")).arg(&file));
    let signalk = run(Command::new("node")
        .arg(root.join("tools/marine/parse_signalk.js"))
        .arg(&file)
        .env("NODE_PATH", &clients.1));
    std::fs::remove_file(&file).ok();
    Parsed { lines, pynmea2, signalk }
}

/// Signal K's value of `path` in the values of one line.
fn sk(values: &[String], path: &str) -> Option<f64> {
    values.iter().find_map(|v| v.strip_prefix(path)?.strip_prefix('=')?.parse().ok())
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

/// One output of the device: its `$PINAH` (the estimate) and the standard sentences after it.
#[derive(Default)]
struct Output {
    roll: f64,
    pitch: f64,
    yaw: f64,
    depth: Option<f64>,
    status: u32,
    /// Indices of the output's other lines in [`Parsed`].
    others: Vec<usize>,
    /// The `$PRDID` before it, if any.
    prdid: Option<usize>,
}

/// `$PINAH` status bits that make the attitude untrustworthy: initialising (0), gyro invalid
/// (1), time gap (2), gyro saturated (3), health reset (12), ADC fault (17), gyro rail (18).
const INVALID: u32 = 1 | 2 | 4 | 8 | 1 << 12 | 1 << 17 | 1 << 18;

/// The outputs of a capture, from pynmea2's reading of `$PINAH` (proprietary data fields).
fn outputs(p: &Parsed) -> Vec<Output> {
    let mut out: Vec<Output> = Vec::new();
    let mut prdid = None;
    for (i, f) in p.pynmea2.iter().enumerate() {
        assert_ne!(f[0], "ERROR", "pynmea2 refused {}: {f:?}", p.lines[i]);
        match f[0].as_str() {
            "PINAH" => {
                let num = |k: usize| f[k].parse::<f64>().unwrap_or(f64::NAN);
                out.push(Output {
                    roll: num(1),
                    pitch: num(2),
                    yaw: num(3),
                    depth: f[8].parse().ok(),
                    status: u32::from_str_radix(&f[9], 16).expect("status word"),
                    others: Vec::new(),
                    prdid: prdid.take(),
                });
            }
            "PRDID" => prdid = Some(i),
            _ => {
                if let Some(o) = out.last_mut() {
                    o.others.push(i);
                }
            }
        }
    }
    out
}

fn kind<'a>(p: &'a Parsed, o: &Output, name: &str) -> Option<(usize, &'a [String])> {
    o.others.iter().find(|&&i| p.pynmea2[i][0] == name).map(|&i| (i, &p.pynmea2[i][1..]))
}

#[test]
fn every_sentence_parses_in_pynmea2_and_signal_k_and_agrees_with_the_estimate() {
    let Some(clients) = clients_or_skip() else { return };
    // A 5 °/s turn with a 15° pitch sine from the start, and the magnetometer.
    let emu = Emulator::start(&["--scenario", "start-moving", "--mag"]);
    emu.send("SENT,1,1,1,1,1,1,1");
    emu.send("SET,mag.enabled,1");
    // 3 s: 30 s of the scenario, 300 outputs at 10 Hz.
    let p = parse(&clients, emu.capture(3.0), "moving");
    for (i, s) in p.signalk.iter().enumerate() {
        assert!(s.first().is_none_or(|x| x != "ERROR"), "Signal K refused {}: {s:?}", p.lines[i]);
    }
    let outs = outputs(&p);
    assert!(outs.len() > 200, "{} outputs", outs.len());
    // No handler for the proprietary sentences either.
    for (i, f) in p.pynmea2.iter().enumerate() {
        if f[0] == "PINAH" || f[0] == "PRDID" {
            assert_eq!(p.signalk[i], ["null"], "{}", p.lines[i]);
        }
    }
    let deg = f64::to_degrees;
    let (mut hdt, mut hdg, mut hdm, mut rot, mut xdr) = (0, 0, 0, 0, 0);
    for (k, o) in outs.iter().enumerate() {
        // Validity is judged over the cycles since the previous output; `$PINAH` shows the
        // output's cycle. A sentence without status goes out only when valid; one withheld
        // while this and the previous output look valid would be a fault in between, which
        // the emulated board does not have.
        let valid = o.status & INVALID == 0;
        let settled = valid && k > 0 && outs[k - 1].status & INVALID == 0;
        let reference = (o.status >> 20) & 3;
        let yaw360 = o.yaw.rem_euclid(360.0);
        // PRDID only while valid; its values are the estimate's.
        match o.prdid {
            Some(i) => {
                assert!(valid, "{}", p.lines[i]);
                let f = &p.pynmea2[i];
                let v = |j: usize| f[j].parse::<f64>().unwrap();
                assert!((v(1) - o.pitch).abs() < 0.011 && (v(2) - o.roll).abs() < 0.011);
                assert!(angle_diff(v(3), yaw360).abs() < 0.011);
            }
            None => assert!(!settled, "no $PRDID though valid: {:x}", o.status),
        }
        // HDT: true heading on navigation.headingTrue (rad), within 0.05° + the estimate's
        // 0.005°.
        if let Some((i, f)) = kind(&p, o, "HDT") {
            assert!(valid && reference != 0, "{}", p.lines[i]);
            let h = sk(&p.signalk[i], "navigation.headingTrue").expect("headingTrue");
            assert!(angle_diff(deg(h), yaw360).abs() <= 0.0551, "{} vs {yaw360}", p.lines[i]);
            assert!(angle_diff(f[0].parse().unwrap(), yaw360).abs() <= 0.0551);
            hdt += 1;
        }
        // HDG: magnetic = true − declination (−25.5°: W); Signal K adds the variation back.
        let magnetic = yaw360 + 25.5;
        if let Some((i, f)) = kind(&p, o, "HDG") {
            assert!(valid && reference == 2, "{} status {:x}", p.lines[i], o.status);
            let s = &p.signalk[i];
            let m = sk(s, "navigation.headingMagnetic").expect("headingMagnetic");
            let t = sk(s, "navigation.headingTrue").expect("headingTrue");
            let var = sk(s, "navigation.magneticVariation").expect("magneticVariation");
            assert!(angle_diff(deg(m), magnetic).abs() <= 0.0551, "{}", p.lines[i]);
            assert!(angle_diff(deg(t), yaw360).abs() <= 0.0551 + 0.05, "{}", p.lines[i]);
            assert!((deg(var) + 25.5).abs() < 1e-6, "{} {var}", p.lines[i]);
            assert_eq!((f[1].as_str(), f[2].as_str()), ("25.5", "W"));
            hdg += 1;
        }
        if let Some((i, _)) = kind(&p, o, "HDM") {
            assert!(valid && reference == 2, "{} status {:x}", p.lines[i], o.status);
            let m = sk(&p.signalk[i], "navigation.headingMagnetic").expect("headingMagnetic");
            assert!(angle_diff(deg(m), magnetic).abs() <= 0.0551, "{}", p.lines[i]);
            hdm += 1;
        }
        // ROT: the heading's change since the previous output over its 0.1 s (of the
        // scenario's time), °/min; the estimate's 0.005° rounding at both ends is 6 °/min.
        let (i, f) = kind(&p, o, "ROT").expect("ROT in every output");
        let rate = sk(&p.signalk[i], "navigation.rateOfTurn");
        if f[1] == "A" {
            let prev = k.checked_sub(1).map(|j| &outs[j]);
            let expect = prev.map(|q| angle_diff(o.yaw, q.yaw) / 0.1 * 60.0);
            let got = deg(rate.expect("rateOfTurn")) * 60.0;
            assert!(valid, "{}", p.lines[i]);
            if let Some(e) = expect {
                assert!((got - e).abs() <= 6.06, "{} vs {e} °/min", p.lines[i]);
                assert!((f[0].parse::<f64>().unwrap() - got).abs() < 1e-6);
                rot += 1;
            }
        } else {
            assert_eq!(rate, None, "ROT with V reached Signal K: {}", p.lines[i]);
        }
        // XDR via pynmea2: pitch, roll (degrees, 1 decimal) and depth (m, 1 decimal).
        if let Some((i, f)) = kind(&p, o, "XDR") {
            let t = |name: &str| {
                f.iter().find(|x| x.ends_with(name)).map(|x| {
                    let q: Vec<&str> = x.split(':').collect();
                    (q[0].to_string(), q[1].parse::<f64>().unwrap(), q[2].to_string())
                })
            };
            match (t(":PTCH"), t(":ROLL")) {
                (Some((ta, pitch, ua)), Some((tb, roll, ub))) => {
                    assert!(valid, "{}", p.lines[i]);
                    assert_eq!(
                        (ta.as_str(), ua.as_str(), tb.as_str(), ub.as_str()),
                        ("A", "D", "A", "D")
                    );
                    assert!((pitch - o.pitch).abs() <= 0.0551, "{} vs {}", p.lines[i], o.pitch);
                    assert!((roll - o.roll).abs() <= 0.0551, "{} vs {}", p.lines[i], o.roll);
                    xdr += 1;
                }
                // Tilt withheld: invalid, or the accelerometer rejected for long (bit 7).
                (None, None) => assert!(!settled || o.status & 0x80 != 0, "{}", p.lines[i]),
                _ => panic!("pitch without roll: {}", p.lines[i]),
            }
            // Signal K's parser has no XDR handler (docs/marine.md says so).
            assert_eq!(p.signalk[i], ["null"], "{}", p.lines[i]);
            let (td, depth, ud) = t(":DEPTH").expect("depth");
            assert_eq!((td.as_str(), ud.as_str()), ("D", "M"));
            assert!((depth - o.depth.expect("depth in $PINAH")).abs() < 1e-9);
            assert!((depth - 2.5).abs() < 0.051, "the emulated depth: {}", p.lines[i]);
        }
    }
    // Most outputs carry each sentence (the magnetometer references the heading within the
    // first seconds).
    let n = outs.len();
    for (name, count) in [("HDT", hdt), ("HDG", hdg), ("HDM", hdm), ("ROT", rot), ("XDR", xdr)] {
        assert!(count > n * 3 / 4, "{name} in {count} of {n} outputs");
    }
}

#[test]
fn nothing_invalid_or_relative_reaches_signal_k_as_valid_and_yaw_makes_the_heading_true() {
    let Some(clients) = clients_or_skip() else { return };
    // Still for 10 s (the initialisation window), then a ±30° yaw sine; no magnetometer.
    let emu = Emulator::start(&["--scenario", "yaw-sine"]);
    emu.send("SENT,1,1,1,1,1,1,1");
    // During the window: 0.6 s of the first 10 s.
    let init = parse(&clients, emu.capture(0.6), "init");
    let outs = outputs(&init);
    assert!(outs.len() > 30, "{} outputs", outs.len());
    for (k, o) in outs.iter().enumerate() {
        assert!(o.status & 1 != 0, "initialising");
        assert_eq!(o.prdid, None);
        for &i in &o.others {
            let (line, values) = (&init.lines[i], &init.signalk[i]);
            match init.pynmea2[i][0].as_str() {
                // The status field says V; Signal K drops it.
                "ROT" => assert!(line.ends_with(",V*") || line.contains(",V*"), "{line}"),
                // Depth only: the attitude's quadruplets are left out.
                "XDR" => assert_eq!(init.pynmea2[i][1..], ["D:2.5:M:DEPTH"], "{line}"),
                _ => panic!("output {k} sent {line} while initialising"),
            }
            assert!(
                values.iter().all(|v| v == "null" || v.is_empty()),
                "Signal K read {values:?} from {line}"
            );
        }
    }
    // Initialised (after 10 s of the scenario), heading relative: no HDT, nothing on
    // navigation.headingTrue; the rate of turn is valid.
    let until = Instant::now() + Duration::from_secs(5);
    loop {
        let lines = emu.capture(0.2);
        let last = lines.iter().rev().find(|l| l.starts_with("$PINAH"));
        let status = last.and_then(|l| u32::from_str_radix(l.split(',').nth(9)?, 16).ok());
        if status.is_some_and(|s| s & 1 == 0) {
            break;
        }
        assert!(Instant::now() < until, "still initialising: {last:?}");
    }
    let relative = parse(&clients, emu.capture(0.5), "relative");
    let outs = outputs(&relative);
    let st: Vec<String> = outs.iter().map(|o| format!("{:x}", o.status)).collect();
    assert!(outs.iter().all(|o| o.status & 1 == 0 && (o.status >> 20) & 3 == 0), "{st:?}");
    let mut rates = 0;
    for i in outs.iter().flat_map(|o| o.others.iter().copied()) {
        let values = &relative.signalk[i];
        assert!(sk(values, "navigation.headingTrue").is_none(), "{}", relative.lines[i]);
        assert_ne!(relative.pynmea2[i][0], "HDT");
        rates += usize::from(sk(values, "navigation.rateOfTurn").is_some());
    }
    assert!(rates + 1 >= outs.len(), "{rates} valid rates in {} outputs", outs.len());
    // The operator makes the heading true: 123.4° now.
    emu.send("YAW,123.4");
    let status = emu.send("STATUS");
    assert!(status.contains(",T*"), "{status}");
    let true_ = parse(&clients, emu.capture(0.3), "true");
    let outs = outputs(&true_);
    let first = outs.first().expect("outputs");
    assert_eq!((first.status >> 20) & 3, 1, "heading true by the operator");
    let mut headings = Vec::new();
    for o in &outs {
        let (i, _) = kind(&true_, o, "HDT").expect("HDT in every output");
        let h = sk(&true_.signalk[i], "navigation.headingTrue").expect("headingTrue");
        assert!(angle_diff(h.to_degrees(), o.yaw.rem_euclid(360.0)).abs() <= 0.0551);
        headings.push(h.to_degrees());
    }
    // Within a few tenths of a second of the scenario's turn (at most 9.4 °/s) of 123.4°.
    assert!(angle_diff(headings[0], 123.4).abs() < 5.0, "{headings:?}");
}
