//! What the end-to-end tests share: the tool's binary and its six-position calibration run.

pub mod clients;

use std::{
    io::Write,
    process::{Command, Output, Stdio},
};

/// The `ahrs-tool` binary under test.
pub const BIN: &str = env!("CARGO_BIN_EXE_ahrs-tool");

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
