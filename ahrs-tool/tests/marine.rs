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
    process::Command,
    time::{Duration, Instant},
};

mod common;
use common::clients::{
    angle_diff, capture, check_agreement, clients_or_skip, kind, outputs, parse, sk,
};
use common::{stdout, Emulator, BIN};

impl Emulator {
    /// `ahrs-tool send`: the reply, which must be OK.
    fn send(&self, command: &str) -> String {
        let o = Command::new(BIN).args(["send", &self.port, command]).output().expect("send");
        let reply = stdout(&o);
        assert_eq!(o.status.code(), Some(0), "{command}: {reply}");
        reply
    }

    /// The complete lines the device sends during `seconds` (wall clock).
    fn capture(&self, seconds: f64) -> Vec<String> {
        capture(&self.port, seconds)
    }
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
    let n = check_agreement(&p);
    assert!(n.outputs > 200, "{n:?}");
    // Most outputs carry each sentence (the magnetometer references the heading within the
    // first seconds).
    for (name, count) in
        [("HDT", n.hdt), ("HDG", n.hdg), ("HDM", n.hdm), ("ROT", n.rot), ("XDR", n.xdr)]
    {
        assert!(count > n.outputs * 3 / 4, "{name} in {count} of {n:?}");
    }
    // The rate of turn under the magnetometer is the turn, 5 °/s = 300 °/min, not the
    // heading's change (the pull toward magnetic north printed 876 °/min here before issue
    // #38 point 5): the median within 6 °/min, eight outputs in ten within 15 °/min (the x and
    // y gyros' noise over 0.1 s through the 15° pitch, and the moving start's bias error in
    // the first seconds).
    let mut r = n.rot_mag.clone();
    r.sort_by(f64::total_cmp);
    let near = r.iter().filter(|v| (*v - 300.0).abs() <= 15.0).count();
    assert!(r.len() > n.outputs / 2, "{n:?}");
    assert!((r[r.len() / 2] - 300.0).abs() <= 6.0 && near * 10 >= r.len() * 8, "{r:?}");
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
    assert!(status.contains(",T,,*"), "{status}");
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

/// Issue #38 point 6: the guidance's Signal K row (`docs/marine.md`, its command as printed
/// there) gives Signal K one `navigation.headingTrue` per output, within 0–360°, also while the
/// magnetometer references the heading; `HDG` added to it gives a second value on the same
/// path every output (Signal K's magnetic heading plus variation, not wrapped), which is why
/// the guidance never enables both.
#[test]
fn the_signal_k_row_of_the_guidance_gives_one_true_heading_per_output() {
    let Some(clients) = clients_or_skip() else { return };
    let doc = std::fs::read_to_string(common::clients::root().join("docs/marine.md")).unwrap();
    let row = doc.lines().find(|l| l.starts_with("| Signal K server |")).expect("the row");
    let command = row.split('`').rfind(|s| s.starts_with("SENT,")).expect("its command");
    let emu = Emulator::start(&["--scenario", "start-moving", "--mag"]);
    emu.send("SET,mag.enabled,1");
    emu.send(command);
    // Per output with the magnetometer's reference (status bits 20-21 = 2): the headingTrue
    // values Signal K read from its lines.
    let true_headings = |p: &common::clients::Parsed| -> Vec<Vec<f64>> {
        outputs(p)
            .iter()
            .filter(|o| o.status & common::clients::INVALID == 0 && (o.status >> 20) & 3 == 2)
            .map(|o| {
                o.others
                    .iter()
                    .filter_map(|&i| sk(&p.signalk[i], "navigation.headingTrue"))
                    .collect()
            })
            .collect()
    };
    let row_only = true_headings(&parse(&clients, emu.capture(2.0), "signalk-row"));
    assert!(row_only.len() > 100, "{} outputs under the magnetometer", row_only.len());
    for h in &row_only {
        assert_eq!(h.len(), 1, "{command}: {h:?}");
        assert!((0.0..std::f64::consts::TAU).contains(&h[0]), "{h:?}");
    }
    emu.send("SENT,HDG,1");
    let with_hdg = true_headings(&parse(&clients, emu.capture(1.0), "signalk-hdg"));
    assert!(with_hdg.len() > 50);
    assert!(with_hdg.iter().all(|h| h.len() == 2), "{with_hdg:?}");
}

/// Issue #38 point 7: a depth beyond the sensor's range is flagged as the board flags it. The
/// emulator's ADC counts saturate at full scale, the depth channel is then at its rail (status
/// bit 19), and neither `XDR` nor `$PINAH` gives a depth; within the range both give the same.
#[test]
fn a_depth_beyond_the_sensor_is_flagged_in_both_sentences() {
    for (depth, in_range) in [("5000", false), ("25", true)] {
        let emu = Emulator::start(&["--depth", depth]);
        emu.send("SENT,XDR,1");
        let lines = emu.capture(2.0);
        let pinah: Vec<&String> = lines.iter().filter(|l| l.starts_with("$PINAH,")).collect();
        let xdr: Vec<&String> = lines.iter().filter(|l| l.contains("XDR,")).collect();
        assert!(pinah.len() > 5 && !xdr.is_empty(), "{lines:?}");
        for p in &pinah {
            let f: Vec<&str> = p.split('*').next().unwrap().split(',').collect();
            let status = u32::from_str_radix(f[9], 16).unwrap();
            assert_eq!(status & (1 << 19) != 0, !in_range, "{depth} m: {p}");
            assert_eq!(f[8].is_empty(), !in_range, "{depth} m: {p}");
            if in_range {
                assert!((f[8].parse::<f64>().unwrap() - 25.0).abs() < 0.2, "{p}");
            }
        }
        for x in &xdr {
            assert_eq!(x.contains("DEPTH"), in_range, "{depth} m: {x}");
        }
    }
}

/// `GET path` on the server's HTTP port: the JSON body, or `None`.
fn http_json(port: u16, path: &str) -> Option<serde_json::Value> {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).ok()?;
    s.set_read_timeout(Some(Duration::from_secs(2))).ok()?;
    write!(s, "GET {path} HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n").ok()?;
    let mut text = String::new();
    s.read_to_string(&mut text).ok()?;
    let (head, body) = text.split_once("\r\n\r\n")?;
    head.starts_with("HTTP/1.1 200").then(|| serde_json::from_str(body).ok())?
}

/// A free local port of `kind` ("tcp" or "udp").
fn free_port(udp: bool) -> u16 {
    if udp {
        std::net::UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
    } else {
        std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
    }
}

/// Issue #38 points 1 and 2: `ahrs-tool bridge --signalk` into a real Signal K server
/// (signalk-server 2.23.0, `scripts/marine-clients`), whose REST API then gives the attitude,
/// the true heading and the depth the device sent, within the output's rounding (`$PINAH`:
/// 0.01°, 0.1 m) and the still board's noise. Skipped with a message, and listed in
/// `target/skipped-tests.txt` for `scripts/test-all`'s summary, when npm could not install the
/// server.
#[test]
fn a_signal_k_server_receives_attitude_heading_and_depth() {
    let root = common::clients::root();
    let server = root.join("target/signalk-server/node_modules/.bin/signalk-server");
    if !server.exists() {
        let why = "signalk-server is not installed (scripts/marine-clients: npm unreachable?)";
        eprintln!("SKIPPED a_signal_k_server_receives_attitude_heading_and_depth: {why}");
        let list = root.join("target/skipped-tests.txt");
        let mut f = std::fs::OpenOptions::new().create(true).append(true).open(list).unwrap();
        use std::io::Write;
        writeln!(f, "ahrs-tool marine: the Signal K server test: {why}").unwrap();
        return;
    }
    let dir = std::env::temp_dir().join(format!("ahrs-signalk-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (http, udp) = (free_port(false), free_port(true));
    let settings = serde_json::json!({
        "interfaces": { "nmea-tcp": false, "tcp": false, "mdns": false },
        "pipedProviders": [{
            "id": "ahrs",
            "enabled": true,
            "pipeElements": [{
                "type": "providers/simple",
                "options": { "logging": false, "type": "SignalK",
                             "subOptions": { "type": "udp", "port": udp.to_string() } }
            }]
        }]
    });
    std::fs::write(dir.join("settings.json"), settings.to_string()).unwrap();
    struct Killed(std::process::Child);
    impl Drop for Killed {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
    let _server = Killed(
        Command::new(&server)
            .arg("-c")
            .arg(&dir)
            .env("PORT", http.to_string())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("start signalk-server"),
    );
    let up = Instant::now() + Duration::from_secs(60);
    while http_json(http, "/signalk").is_none() {
        assert!(Instant::now() < up, "signalk-server did not answer on port {http}");
        std::thread::sleep(Duration::from_millis(200));
    }
    let emu = Emulator::start_at(1.0, &["--depth", "25"]);
    // A true heading (the operator's YAW), and the rate of turn on.
    let _ = emu.send("YAW,123.4");
    let _ = emu.send("SENT,ROT,1");
    let tcp = free_port(false);
    let _bridge = Killed(
        Command::new(BIN)
            .args(["bridge", &emu.port, "--signalk", &format!("127.0.0.1:{udp}")])
            .args(["--tcp", &format!("127.0.0.1:{tcp}"), "--seconds", "40"])
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("spawn bridge"),
    );
    let api = "/signalk/v1/api/vessels/self";
    let value = |path: &str| http_json(http, &format!("{api}/{path}")).map(|v| v["value"].clone());
    let until = Instant::now() + Duration::from_secs(30);
    let (att, heading, depth) = loop {
        if let (Some(a), Some(h), Some(d)) = (
            value("navigation/attitude"),
            value("navigation/headingTrue"),
            value("environment/depth/belowSurface"),
        ) {
            if a.get("yaw").is_some() {
                break (a, h, d);
            }
        }
        assert!(Instant::now() < until, "no attitude, heading and depth in Signal K");
        std::thread::sleep(Duration::from_millis(300));
    };
    // What the device sends now, through the bridge's TCP stream (the bridge holds its port; a
    // still board: its estimate moves by hundredths of a degree).
    let last = {
        use std::io::BufRead;
        let stream = std::net::TcpStream::connect(("127.0.0.1", tcp)).expect("the bridge's TCP");
        stream.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
        let mut r = std::io::BufReader::new(stream);
        let (mut last, end) = (None, Instant::now() + Duration::from_secs(1));
        while Instant::now() < end {
            let mut line = String::new();
            if r.read_line(&mut line).unwrap_or(0) == 0 {
                break;
            }
            if line.starts_with("$PINAH,") {
                last = Some(line);
            }
        }
        last.expect("PINAH from the bridge")
    };
    let f: Vec<&str> = last.split('*').next().unwrap().split(',').collect();
    let deg = |v: &serde_json::Value| v.as_f64().unwrap().to_degrees();
    let close = |a: f64, b: f64| angle_diff(a, b).abs() < 0.1;
    let (roll, pitch, yaw): (f64, f64, f64) =
        (f[1].parse().unwrap(), f[2].parse().unwrap(), f[3].parse().unwrap());
    assert!(close(deg(&att["roll"]), roll) && close(deg(&att["pitch"]), pitch), "{att} vs {f:?}");
    assert!(close(deg(&att["yaw"]), yaw) && close(deg(&heading), yaw), "{heading} vs {f:?}");
    assert!((deg(&heading) - 123.4).abs() < 1.0, "{heading}");
    let d: f64 = f[8].parse().unwrap();
    assert!((depth.as_f64().unwrap() - d).abs() <= 0.05 && (d - 25.0).abs() < 0.2, "{depth} {d}");
    // The units the meta delta gave.
    let meta = http_json(http, &format!("{api}/environment/depth/belowSurface")).unwrap();
    assert_eq!(meta["meta"]["units"], "m");
    std::fs::remove_dir_all(&dir).ok();
}
