//! What the end-to-end tests share: the tool's binary, the emulated device behind a
//! pseudo-terminal, and the six-position calibration run. (Each test file uses part of it.)
#![allow(dead_code)]

pub mod clients;

use std::{
    io::{BufRead, BufReader, Write},
    process::{Child, Command, Output, Stdio},
};

/// The `ahrs-tool` binary under test.
pub const BIN: &str = env!("CARGO_BIN_EXE_ahrs-tool");

/// A running emulator (`ahrs-tool emulate --pty --speed 10` and `extra`); killed on drop (also
/// when a test fails).
pub struct Emulator {
    child: Child,
    /// Its pseudo-terminal.
    pub port: String,
}

impl Emulator {
    /// Start it and wait for the port it prints.
    pub fn start(extra: &[&str]) -> Emulator {
        Self::start_at(10.0, extra)
    }

    /// [`Emulator::start`] at `speed` times real time.
    pub fn start_at(speed: f64, extra: &[&str]) -> Emulator {
        let mut child = Command::new(BIN)
            .args(["emulate", "--pty", "--speed", &speed.to_string()])
            .args(extra)
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

    /// Stop the emulated device (its pseudo-terminal then has nobody answering).
    pub fn stop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// `ahrs-tool <args[0]> <port> <args[1..]>`.
    pub fn tool(&self, args: &[&str]) -> Output {
        let mut a = vec![args[0], self.port.as_str()];
        a.extend_from_slice(&args[1..]);
        Command::new(BIN).args(&a).output().expect("run ahrs-tool")
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Standard output as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// `ahrs-tool calibrate` on `port`, 1 s per position, the operator pressing Enter six times
/// and confirming the save; asserts success and an rms residual of the fit below 0.005 g (the
/// emulated board's cooperative operator holds each position exactly). Returns the output.
pub fn calibrate(port: &str) -> String {
    let mut child = Command::new(BIN)
        .args(["calibrate", port, "--seconds", "1"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run calibrate");
    child.stdin.take().expect("stdin").write_all(b"\n\n\n\n\n\ny\n").expect("answers");
    let o = child.wait_with_output().expect("calibrate exits");
    let text = stdout(&o);
    assert!(o.status.success(), "{text}\n{}", String::from_utf8_lossy(&o.stderr));
    let rms: f64 = text
        .split("rms residual ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|r| r.parse().ok())
        .unwrap_or_else(|| panic!("no residual in {text}"));
    assert!(rms < 0.005, "{rms}");
    text
}
