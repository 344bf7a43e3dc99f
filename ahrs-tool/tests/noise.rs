//! `ahrs-tool noise`, end to end: a simulated still recording (the simulator's white noise,
//! the board's measured variances) gives back the noise settings within 5 %, as a settings
//! file the host tools read; the input is never written over; a recording that moves is refused
//! with the reason and no file.

use std::process::Command;

use host_tests::settings::parse_settings_text;
use host_tests::sim::{Scenario, SimOptions};
use host_tests::trace::TraceWriter;

const BIN: &str = env!("CARGO_BIN_EXE_ahrs-tool");

/// `scenario` simulated for `seconds` at 50 Hz into `path`.
fn write_trace(path: &std::path::Path, scenario: Scenario, seconds: f64) {
    let opts = SimOptions { duration_s: Some(seconds), seed: 4, ..Default::default() };
    let (sim, _) = scenario.simulator_with(&opts);
    let mut w = TraceWriter::new(Vec::new(), sim.columns()).unwrap();
    for s in sim {
        w.row(&s.row).unwrap();
    }
    std::fs::write(path, w.finish().unwrap()).unwrap();
}

#[test]
fn a_still_recording_gives_its_noise_settings() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("still.csv");
    write_trace(&trace, Scenario::StillHour, 600.0);
    let before = std::fs::read(&trace).unwrap();
    let out = dir.path().join("noise.txt");
    let run = Command::new(BIN).arg("noise").arg(&trace).arg("--out").arg(&out).output().unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    assert!(err.contains("settings written to"), "{err}");
    let text = std::fs::read_to_string(&out).unwrap();
    let parsed = parse_settings_text(&text, "noise.txt").unwrap();
    let value = |name: &str| -> Vec<f64> {
        let l = text.lines().find(|l| l.starts_with(&format!("{name}="))).expect(name);
        l.split_once('=').unwrap().1.split(',').map(|v| v.parse().unwrap()).collect()
    };
    // Per sample at 50 Hz, the simulator's: 0.337, 0.275, 4.19e−3 (°/s)²; 2.376e−6 g².
    for (got, want) in value("noise.gyro_var").iter().zip([0.337, 0.275, 4.19e-3]) {
        assert!((got / want - 1.0).abs() < 0.1, "{got} against {want}:\n{text}");
    }
    assert_eq!(value("noise.gyro_ref_rate"), vec![50.0]);
    assert!((value("noise.accel_var")[0] / 2.376e-6 - 1.0).abs() < 0.1, "{text}");
    // Ten minutes show no random walk: not set, and the file says why.
    assert!(text.contains("# ekf.bias_random_walk not measured"), "{text}");
    // The simulator's bias, the board's (1.619, 3.440, −0.0042) °/s, within the mean's noise
    // (0.58 °/s over 30,000 samples: 0.003 °/s).
    for (got, want) in value("init.gyro_bias").iter().zip([1.619, 3.44, -0.0042]) {
        assert!((got - want).abs() < 0.015, "{got} against {want}:\n{text}");
    }
    assert_eq!(parsed.lines.len(), 5, "{text}");

    // Asked to write over its input: refused, the input as it was.
    let run = Command::new(BIN).arg("noise").arg(&trace).arg("--out").arg(&trace).output().unwrap();
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("refusing to write over it"));
    assert_eq!(std::fs::read(&trace).unwrap(), before);

    // A log that is still for its first 100 s and then turns: refused whole; its still part
    // (`--from`, `--to`) analysed.
    let turning = dir.path().join("turning.csv");
    let text = std::fs::read_to_string(&trace).unwrap();
    let mut out_text = String::new();
    for line in text.lines() {
        let t: Option<f64> = line.split(',').next().and_then(|c| c.trim().parse().ok());
        match t {
            Some(t) if t > 100.0 => {
                // gyro z (the fourth column) plus 0.1 rad/s: a turn.
                let mut cells: Vec<String> = line.split(',').map(String::from).collect();
                let z: f64 = cells[3].trim().parse().unwrap();
                cells[3] = format!("{}", z + 0.1);
                out_text.push_str(&cells.join(","));
            }
            _ => out_text.push_str(line),
        }
        out_text.push('\n');
    }
    std::fs::write(&turning, out_text).unwrap();
    let run = Command::new(BIN).arg("noise").arg(&turning).output().unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{err}");
    assert!(err.contains("not still") && err.contains("axis z"), "{err}");
    let run = Command::new(BIN)
        .args(["noise", turning.to_str().unwrap(), "--from", "5", "--to", "95"])
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(out.contains("(t = 5") && out.contains("noise.gyro_var="), "{out}");

    // A recording that moves: refused with the reason, no file.
    let moving = dir.path().join("moving.csv");
    write_trace(&moving, Scenario::PitchSine, 120.0);
    let out = dir.path().join("moving.txt");
    let run = Command::new(BIN).arg("noise").arg(&moving).arg("--out").arg(&out).output().unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{err}");
    assert!(err.contains("not still"), "{err}");
    assert!(!out.exists());
}
