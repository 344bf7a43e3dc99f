//! Issue #29, point 1: every duration and count argument of every command is checked before
//! anything is opened, sent or written. NaN, infinity, a negative value, zero and a huge value
//! each give a one-line error naming the value, exit status 2 (clap's usage error), no panic,
//! and no file; a valid value gets past the check (to the port, which does not exist here).

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_ahrs-tool");

/// `(arguments before the flag, the flag, a value that passes)`.
fn cases(dir: &std::path::Path) -> Vec<(Vec<String>, &'static str, &'static str)> {
    let port = dir.join("no-such-port").display().to_string();
    let out = dir.join("log.csv").display().to_string();
    let v = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    vec![
        (v(&["live", &port]), "--seconds", "1"),
        (v(&["send", &port, "VER"]), "--timeout", "0.5"),
        (v(&["send", &port, "GBIAS"]), "--wait-late", "3"),
        (v(&["log", &port, "--out", &out]), "--seconds", "1"),
        (v(&["bridge", &port, "--udp", "127.0.0.1:10110"]), "--seconds", "1"),
        (v(&["calibrate", &port]), "--seconds", "2"),
        (v(&["emulate", "--port", &port]), "--speed", "10"),
    ]
}

#[test]
fn bad_durations_and_speeds_are_refused_before_anything_happens() {
    let dir = std::env::temp_dir().join(format!("ahrs-tool-args-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (args, flag, good) in cases(&dir) {
        for bad in ["NaN", "inf", "-inf", "-1", "0", "1e12", "soon"] {
            let out = Command::new(BIN).args(&args).arg(format!("{flag}={bad}")).output().unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            let what = format!("{args:?} {flag} {bad}");
            assert_eq!(out.status.code(), Some(2), "{what}: {err}");
            assert!(!err.contains("panicked"), "{what}: {err}");
            assert!(err.contains(&format!("'{bad}'")), "{what}: the error does not name it: {err}");
            assert!(
                out.stdout.is_empty(),
                "{what}: printed {:?}",
                String::from_utf8_lossy(&out.stdout)
            );
        }
        assert!(!dir.join("log.csv").exists(), "{args:?}: a file was written");
        // A valid value passes the check and fails on the missing port instead, or on the
        // emulator's missing device: not as a usage error.
        let out = Command::new(BIN).args(&args).args([flag, good]).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("must be finite"), "{args:?} {flag} {good}: {err}");
        assert!(!err.contains("panicked"), "{args:?} {flag} {good}: {err}");
    }
    // The calibration's averaging time is the device's range, 0.5–60 s.
    for (bad, ok) in [("0.4", false), ("0.5", true), ("60", true), ("61", false)] {
        let port = dir.join("no-such-port").display().to_string();
        let out = Command::new(BIN).args(["calibrate", &port, "--seconds", bad]).output().unwrap();
        let usage = out.status.code() == Some(2)
            && String::from_utf8_lossy(&out.stderr).contains("must be finite");
        assert_eq!(usage, !ok, "calibrate --seconds {bad}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue #29, point 2: `log` refuses an existing `--out` (or `--device-estimates`) file before
/// the port is opened, whatever the link: the file keeps its bytes. `--force` gets past the
/// check (to the port, missing here, so the file is still untouched).
#[test]
fn log_refuses_an_existing_file_without_force() {
    let dir = std::env::temp_dir().join(format!("ahrs-tool-logfile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let port = dir.join("no-such-port").display().to_string();
    let old = dir.join("dive.csv");
    std::fs::write(&old, b"a dive that cannot be repeated\n").unwrap();
    let link = dir.join("link.csv");
    std::os::unix::fs::symlink(dir.join("gone.csv"), &link).unwrap();
    let fresh = dir.join("fresh.csv").display().to_string();
    let cases: [&[&str]; 3] = [
        &["log", &port, "--out", old.to_str().unwrap()],
        &["log", &port, "--out", link.to_str().unwrap()],
        &["log", &port, "--out", &fresh, "--restart", "--device-estimates", old.to_str().unwrap()],
    ];
    for args in cases {
        let out = Command::new(BIN).args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("exists") && err.contains("--force"), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        let forced = Command::new(BIN).args(args).arg("--force").output().unwrap();
        let ferr = String::from_utf8_lossy(&forced.stderr);
        assert!(!ferr.contains("--force"), "{args:?} --force: {ferr}");
    }
    assert_eq!(std::fs::read(&old).unwrap(), b"a dive that cannot be repeated\n");
    assert!(!dir.join("gone.csv").exists() && !dir.join("fresh.csv").exists());
    std::fs::remove_dir_all(&dir).ok();
}
