//! Issue #39 point 1: a tool that changed the device puts it back when a later change fails.
//! `settings put` against a scripted device on a pseudo-terminal (the test plays the device:
//! it answers `GET` with the old values, accepts the first `SET`s and refuses one), so the
//! refusal comes from the device, after the tool's own check of the file passed.

use std::io::{Read, Write};
use std::process::Command;
use std::sync::mpsc;
use std::time::Duration;

use serialport::{SerialPort, TTYPort};

const BIN: &str = env!("CARGO_BIN_EXE_ahrs-tool");

fn sentence(body: &str) -> String {
    let sum = body.bytes().fold(0u8, |x, b| x ^ b);
    format!("${body}*{sum:02X}\r\n")
}

/// The device: answers every command line on `master` until it closes, and reports each
/// command's body. `GET` gets `old`'s value, `SET` of `refuse` a range error, any other `SET`
/// an echo.
fn device(
    mut master: TTYPort,
    old: Vec<(&'static str, &'static str)>,
    refuse: &'static str,
) -> mpsc::Receiver<String> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut line = Vec::new();
        let mut byte = [0u8; 1];
        while let Ok(1) = master.read(&mut byte) {
            if byte[0] != b'\n' {
                line.push(byte[0]);
                continue;
            }
            let text = String::from_utf8_lossy(&line).trim().to_string();
            line.clear();
            let Some(body) = text.strip_prefix("$PINAC,").and_then(|t| t.split('*').next()) else {
                continue;
            };
            let f: Vec<&str> = body.split(',').collect();
            let reply = match f[..] {
                ["GET", name] => {
                    let v = old.iter().find(|o| o.0 == name).map_or("0", |o| o.1);
                    format!("PINAR,OK,GET,{name},{v}")
                }
                ["SET", name, ..] if name == refuse => "PINAR,ERR,SET,range,0,1".to_string(),
                ["SET", ..] => format!("PINAR,OK,{body}"),
                _ => format!("PINAR,ERR,{},unknown-command", f[0]),
            };
            tx.send(body.to_string()).ok();
            if master.write_all(sentence(&reply).as_bytes()).is_err() {
                break;
            }
        }
    });
    rx
}

#[test]
fn a_refused_setting_puts_back_the_ones_set_before_it() {
    let (mut master, slave_port) = TTYPort::pair().expect("a pseudo-terminal pair");
    master.set_timeout(Duration::from_secs(20)).unwrap();
    let slave = slave_port.name().expect("the slave's path");
    let old = vec![("mag.norm_tolerance", "0.15"), ("rest.block", "2"), ("mag.declination", "0")];
    let bodies = device(master, old, "mag.declination");
    let dir = std::env::temp_dir().join(format!("ahrs-tool-restore-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("board.txt");
    std::fs::write(&file, "mag.norm_tolerance=0.1\nrest.block=3\nmag.declination=5\n").unwrap();
    let out = Command::new(BIN)
        .args(["settings", "put"])
        .arg(&slave)
        .arg(&file)
        .output()
        .expect("run ahrs-tool");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("line 3") && err.contains("put back"), "{err}");
    let seen: Vec<String> = bodies.try_iter().collect();
    assert_eq!(
        seen,
        [
            "GET,mag.norm_tolerance",
            "GET,rest.block",
            "GET,mag.declination",
            "SET,mag.norm_tolerance,0.1",
            "SET,rest.block,3",
            "SET,mag.declination,5",
            // Put back, latest first.
            "SET,rest.block,2",
            "SET,mag.norm_tolerance,0.15",
        ]
    );
    drop(slave_port);
    std::fs::remove_dir_all(&dir).ok();
}
