//! The `host-tests` binary end to end: simulate → replay → plot, malformed inputs, bad
//! arguments, `--settings`/`--set` and `--no-init-bias`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_host-tests");

fn run(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().expect("run host-tests")
}

fn run_env(args: &[&str], key: &str, value: &str) -> Output {
    Command::new(BIN).args(args).env(key, value).output().expect("run host-tests")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// Parse "rmse_deg roll R pitch P yaw Y" from replay's stdout.
fn rmse(out: &str) -> [f64; 3] {
    let line = out.lines().find(|l| l.starts_with("rmse_deg")).expect("rmse line");
    let w: Vec<&str> = line.split_whitespace().collect();
    [w[2].parse().unwrap(), w[4].parse().unwrap(), w[6].parse().unwrap()]
}

fn simulate(dir: &Path, scenario: &str, duration: &str) -> PathBuf {
    let trace = dir.join(format!("{scenario}.csv"));
    let o = run(&["simulate", scenario, "--out", p(&trace), "--duration", duration, "--seed", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    trace
}

#[test]
fn simulate_replay_round_trip_has_small_rmse() {
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "pitch-sine", "30");
    let text = std::fs::read_to_string(&trace).unwrap();
    assert!(text.starts_with("t,gx,gy,gz,ax,ay,az,qw,qx,qy,qz\n"));
    let data_rows = text.lines().filter(|l| !l.starts_with('#')).count() - 1;
    assert_eq!(data_rows, 1500);

    for filter in ["ekf", "ukf", "ssukf", "cf"] {
        let est = dir.path().join(format!("est-{filter}.csv"));
        let o = run(&["replay", p(&trace), "--out", p(&est), "--filter", filter]);
        assert!(o.status.success(), "{filter}: {}", stderr(&o));
        let out = stdout(&o);
        assert!(out.contains("rows/s"), "{out}");
        let r = rmse(&out);
        // 20 s of a 10° pitch sine after the 10 s window: tilt under 0.5° (1.5° for the
        // complementary filter's slow 1e-4 gain), yaw under 2°.
        let tilt = if filter == "cf" { 1.5 } else { 0.5 };
        assert!(r[0] < tilt && r[1] < tilt && r[2] < 2.0, "{filter}: {r:?}");
        assert!(out.contains("over 1000 rows"), "{out}");
        let est_text = std::fs::read_to_string(&est).unwrap();
        let mut lines = est_text.lines();
        assert_eq!(
            lines.next().unwrap(),
            "t,qw,qx,qy,qz,roll,pitch,yaw,bias_x,bias_y,bias_z,flags"
        );
        assert_eq!(lines.count(), 1500, "one estimate row per input row");
    }
    // The gyro-only baseline runs too (and is worse).
    let est = dir.path().join("est-gyro.csv");
    let o = run(&["replay", p(&trace), "--out", p(&est), "--filter", "gyro"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Replay a malformed trace: non-zero exit, one-line error naming `line` and `column`, and
/// no output file (nor a temporary one) left behind.
fn expect_trace_error(body: &str, line: usize, column: &str) {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("bad.csv");
    std::fs::write(&trace, body).unwrap();
    let est = dir.path().join("est.csv");
    let o = run(&["replay", p(&trace), "--out", p(&est)]);
    assert!(!o.status.success(), "{body}");
    let err = stderr(&o);
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.starts_with("error: "), "{err}");
    assert!(err.contains(&format!("line {line}")), "{err}");
    assert!(err.contains(&format!("column '{column}'")), "{err}");
    assert!(!est.exists(), "partial output left");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(left, vec![trace], "temporary file left");
}

#[test]
fn malformed_inputs_are_named_and_leave_no_output() {
    // Many good rows first, so that output has been written when the error is found.
    let mut good = String::from("t,gx,gy,gz,ax,ay,az\n");
    for k in 0..5000 {
        good.push_str(&format!("{},0.01,0.02,0.0,0.0,0.0,-9.81\n", k as f64 * 0.02));
    }
    // Line numbers: header is 1, row k is k + 2.
    expect_trace_error("t,gx,gy,gz,ax,az\n0,0,0,0,0,-9.8\n", 1, "ay");
    expect_trace_error(&format!("{good}100.0,0.01,abc,0,0,0,-9.81\n"), 5002, "gy");
    expect_trace_error(&format!("{good}100.0,0.01,0,0,0,NaN,-9.81\n"), 5002, "ay");
    expect_trace_error(&format!("{good}100.0,0.01,0,0,0,0,inf\n"), 5002, "az");
    expect_trace_error(&format!("{good}# comment\n99.98,0.01,0,0,0,0,-9.81\n"), 5003, "t");
    expect_trace_error(&format!("{good}100.0,0.01,0,0,0,0\n"), 5002, "az");
    expect_trace_error("t,gx,gy,gz,ax,ay,az,qw,qx,qy\n", 1, "qz");
}

#[test]
fn failed_replay_keeps_an_existing_output() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("bad.csv");
    std::fs::write(&trace, "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,x\n").unwrap();
    let est = dir.path().join("est.csv");
    std::fs::write(&est, "previous\n").unwrap();
    let o = run(&["replay", p(&trace), "--out", p(&est)]);
    assert!(!o.status.success());
    assert_eq!(std::fs::read_to_string(&est).unwrap(), "previous\n");
}

#[test]
fn bad_arguments_give_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.csv");
    let missing = dir.path().join("missing.csv");
    for args in [
        vec!["simulate", "no-such-scenario", "--out", p(&out)],
        vec!["simulate", "pitch-sine", "--out", p(&out), "--rate", "0"],
        vec!["simulate", "pitch-sine", "--out", p(&out), "--duration", "-1"],
        vec!["simulate", "pitch-sine"],
        // Issue #39: a trace that would never end or fill the disk is refused at once (the
        // limits: 1,000,000 s, 50,000,000 rows), with no file, not even a hidden one.
        vec!["simulate", "pitch-sine", "--out", p(&out), "--duration", "1e12"],
        vec!["simulate", "pitch-sine", "--out", p(&out), "--rate", "1e9"],
        vec!["replay", p(&missing), "--out", p(&out)],
        vec!["replay", p(&missing), "--out", p(&out), "--filter", "kalman"],
        vec!["frobnicate"],
    ] {
        let o = run(&args);
        assert!(!o.status.success(), "{args:?}");
        let err = stderr(&o);
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.starts_with("error: "), "{err}");
        assert!(!out.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "{args:?}: a file was left");
    }
}

#[test]
fn settings_in_the_device_language_override_and_are_refused_as_the_device_would() {
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "pitch-ramp", "30");
    let est = dir.path().join("est.csv");
    let cfg = dir.path().join("settings.txt");
    // A 5 s window: RMSE now counts rows from t = 5 s (1250 of the 1500 rows).
    std::fs::write(&cfg, "# a comment\n\ninit.window = 5\nnoise.accel_var=4.752e-5\n").unwrap();
    let o = run(&["replay", p(&trace), "--out", p(&est), "--settings", p(&cfg)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("over 1250 rows"), "{}", stdout(&o));
    // `--set` after the file: 2 s (1400 rows).
    let o = run(&[
        "replay",
        p(&trace),
        "--out",
        p(&est),
        "--settings",
        p(&cfg),
        "--set",
        "init.window=2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("over 1400 rows"), "{}", stdout(&o));

    std::fs::write(&cfg, "init.window=5\nnoise.accel_vr=4.752e-5\n").unwrap();
    let est2 = dir.path().join("est2.csv");
    for (args, want) in [
        (
            vec!["--settings", p(&cfg)],
            format!("error: {} line 2: noise.accel_vr: unknown-setting", p(&cfg)),
        ),
        (
            vec!["--set", "mag.norm_tolerance=20"],
            "error: --set mag.norm_tolerance=20: range: valid 0 to 1".into(),
        ),
        (vec!["--set", "noise.accel_var=-1"], "error: --set noise.accel_var=-1: range:".into()),
        (vec!["--set", "lever.r=1,2"], "error: --set lever.r=1,2: args: expected 3".into()),
        (vec!["--set", "init.window=1e300"], "error: --set init.window=1e300: range:".into()),
        (
            vec!["--set", "ekf.bias_random_walk=nan"],
            "error: --set ekf.bias_random_walk=nan: type:".into(),
        ),
    ] {
        let mut a = vec!["replay", p(&trace), "--out", p(&est2)];
        a.extend(&args);
        let o = run(&a);
        assert!(!o.status.success(), "{args:?}");
        let err = stderr(&o);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.starts_with(&want), "{args:?}: {err}");
        assert!(!est2.exists());
    }
    // The old TOML option is gone.
    let o = run(&["replay", p(&trace), "--out", p(&est2), "--config", p(&cfg)]);
    assert!(!o.status.success());
}

#[test]
fn settings_acting_before_the_trace_are_named_not_applied() {
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "pitch-sine", "12");
    let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
    let o = run(&["replay", p(&trace), "--out", p(&a)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o), "", "no settings, no notes");
    let o = run(&[
        "replay",
        p(&trace),
        "--out",
        p(&b),
        "--set",
        "axes.gyro=y,x,-z",
        "--set",
        "output.rate=5",
        "--set",
        "gyro.offset=1,2,3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("not applied: axes.gyro (a trace is in body axes already)"), "{err}");
    assert!(err.contains("not applied: output.rate ("), "{err}");
    assert!(err.contains("not applied: gyro.offset ("), "{err}");
    // And indeed nothing changed.
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

/// The estimate file's bias_z (°/s) on the first row after the initialisation window.
fn bias_z_after_init(est: &Path) -> f64 {
    let text = std::fs::read_to_string(est).unwrap();
    let row = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .find(|c| c[0].parse::<f64>().unwrap() >= 10.5)
        .unwrap();
    row[10].parse().unwrap()
}

#[test]
fn no_init_bias_uses_the_configured_bias() {
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "bias-off", "20");
    assert!(std::fs::read_to_string(&trace).unwrap().contains("--no-init-bias"));
    let est = dir.path().join("est.csv");
    // Estimated from the still window: the true z bias −0.004 + 0.05 °/s, within noise.
    let o = run(&["replay", p(&trace), "--out", p(&est)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let b = bias_z_after_init(&est);
    assert!((b - 0.046).abs() < 0.01, "{b}");
    // Not estimated: the configured default (−0.0042 °/s), 0.05 °/s off the truth.
    let o = run(&["replay", p(&trace), "--out", p(&est), "--no-init-bias"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let b = bias_z_after_init(&est);
    assert!((b + 0.0042).abs() < 0.002, "{b}");
}

#[test]
fn plot_writes_a_png_with_and_without_fonts() {
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "yaw-sine", "20");
    let est = dir.path().join("est.csv");
    let o = run(&["replay", p(&trace), "--out", p(&est)]);
    assert!(o.status.success(), "{}", stderr(&o));
    for (font, name) in [("", "fig.png"), ("none", "fig-notext.png")] {
        let png = dir.path().join(name);
        let o = run_env(&["plot", p(&trace), p(&est), "--out", p(&png)], "HOST_TESTS_FONT", font);
        assert!(o.status.success(), "{}", stderr(&o));
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        assert!(bytes.len() > 10_000);
    }
    // Mismatched files: an error and no image.
    let short = simulate(dir.path(), "pitch-sine", "12");
    let png = dir.path().join("bad.png");
    let o = run(&["plot", p(&short), p(&est), "--out", p(&png)]);
    assert!(!o.status.success());
    assert_eq!(stderr(&o).trim_end().lines().count(), 1);
    assert!(!png.exists());
}

/// Stroke colours of the figure's series (`src/plot.rs`): truth, estimate, error.
const TRUTH_STROKE: &str = "stroke=\"#96B9EB\"";
const ESTIMATE_STROKE: &str = "stroke=\"#961414\"";
const ERROR_STROKE: &str = "stroke=\"#14288C\"";

#[test]
fn plot_writes_svg_by_extension_and_leaves_out_error_panels_without_truth() {
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "yaw-sine", "20");
    let est = dir.path().join("est.csv");
    let o = run(&["replay", p(&trace), "--out", p(&est)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let svg = dir.path().join("fig.svg");
    let o = run(&["plot", p(&trace), p(&est), "--out", p(&svg)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg"), "{}", &text[..text.len().min(200)]);
    assert!(text.trim_end().ends_with("</svg>"));
    for stroke in [TRUTH_STROKE, ESTIMATE_STROKE, ERROR_STROKE] {
        assert!(text.contains(stroke), "{stroke}");
    }
    // The truth (wide) is drawn before, i.e. under, the estimate (thin).
    let first = |s: &str| text.find(&format!("<polyline fill=\"none\" opacity=\"1\" {s}"));
    assert!(first(TRUTH_STROKE).unwrap() < first(ESTIMATE_STROKE).unwrap());

    // Without truth columns: the estimate only, no error panels, no truth legend.
    let notruth = dir.path().join("notruth.csv");
    let kept: Vec<String> = std::fs::read_to_string(&trace)
        .unwrap()
        .lines()
        .map(|l| {
            if l.starts_with('#') {
                l.to_string()
            } else {
                l.split(',').take(7).collect::<Vec<_>>().join(",")
            }
        })
        .collect();
    std::fs::write(&notruth, kept.join("\n") + "\n").unwrap();
    let est2 = dir.path().join("est2.csv");
    let o = run(&["replay", p(&notruth), "--out", p(&est2)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let svg2 = dir.path().join("fig2.svg");
    let o = run(&["plot", p(&notruth), p(&est2), "--out", p(&svg2)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("no truth"), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg2).unwrap();
    assert!(text.starts_with("<svg"));
    assert!(text.contains(ESTIMATE_STROKE));
    assert!(!text.contains(TRUTH_STROKE) && !text.contains(ERROR_STROKE));
    assert!(!text.contains("error (deg)") && !text.contains(">truth<"));
    // An unknown extension: refused before anything is written.
    let bad = dir.path().join("fig.jpg");
    let o = run(&["plot", p(&notruth), p(&est2), "--out", p(&bad)]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains(".png or .svg"), "{}", stderr(&o));
    assert!(!bad.exists());
}

#[test]
fn simulate_is_deterministic_per_seed() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.csv");
    let b = dir.path().join("b.csv");
    let c = dir.path().join("c.csv");
    for (out, seed) in [(&a, "5"), (&b, "5"), (&c, "6")] {
        let o = run(&[
            "simulate",
            "coupled",
            "--out",
            p(out),
            "--duration",
            "12",
            "--seed",
            seed,
            "--rate",
            "100",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let (a, b, c) =
        (std::fs::read(a).unwrap(), std::fs::read(b).unwrap(), std::fs::read(c).unwrap());
    assert_eq!(a, b);
    assert_ne!(a, c);
    let rows = String::from_utf8(a).unwrap().lines().filter(|l| !l.starts_with('#')).count() - 1;
    assert_eq!(rows, 1200);
}

/// Parse "rmse_deg inclination I heading H (... over the N rows with truth ...)" from replay's
/// stdout: (I, H, N).
fn incl_heading(out: &str) -> (f64, f64, usize) {
    let line =
        out.lines().find(|l| l.starts_with("rmse_deg inclination ")).expect("inclination line");
    let w: Vec<&str> = line.split_whitespace().collect();
    assert_eq!(w[3], "heading", "{line}");
    let n = line.split("over the ").nth(1).and_then(|r| r.split(' ').next()).expect("row count");
    (w[2].parse().unwrap(), w[4].parse().unwrap(), n.parse().unwrap())
}

/// The printed value (4 decimals) is `expected` rounded.
fn assert_printed(printed: f64, expected: f64, what: &str) {
    assert!(
        (printed - expected).abs() <= 0.5e-4 + 1e-9,
        "{what}: printed {printed}, score {expected}"
    );
}

#[test]
fn replay_scores_a_recording_and_foreign_drops_the_seahog_specifics() {
    use ekf_core::lever_arm::LeverArm;
    use ekf_core::Vec3;
    use host_tests::config::ReplayConfig;
    use host_tests::real::{score, RepoImu};
    use host_tests::replay::FilterKind;

    let file = RepoImu::dir().join(RepoImu::FILES[0]);
    assert!(file.ends_with("Pendulum_Test02a_Trial1_Segment_1.csv"));
    let (_, rows) = host_tests::trace::read_trace_file(&file).expect("RepoIMU recording");
    let dir = tempfile::tempdir().unwrap();
    let est = dir.path().join("est.csv");

    let mut foreign = ReplayConfig::default();
    foreign.conditioning.lever_arm = LeverArm::NONE;
    foreign.settings.init.gyro_bias = Vec3::ZERO;
    let mut foreign_arm = foreign;
    foreign_arm.conditioning.lever_arm.r = Vec3::new(0.1, 0.0, 0.0);
    let foreign_line = "foreign: lever_arm.r [0.2973, -0.1960, 0.0803] m -> [0.0000, 0.0000, \
                        0.0000] (LeverArm::NONE), init.gyro_bias [1.6190, 3.4400, -0.0042] \
                        deg/s -> [0.0000, 0.0000, 0.0000]; the rest default";

    let mut seen = Vec::new();
    for (extra, cfg, line) in [
        (vec![], ReplayConfig::default(), None),
        (vec!["--foreign"], foreign, Some(foreign_line.to_string())),
        (
            vec!["--foreign", "--set", "lever.r=0.1,0,0"],
            foreign_arm,
            Some(format!("{foreign_line}, then the given settings on top")),
        ),
    ] {
        let mut args = vec!["replay", p(&file), "--out", p(&est)];
        args.extend(&extra);
        let o = run(&args);
        assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
        let out = stdout(&o);
        match &line {
            Some(l) => assert_eq!(out.lines().next(), Some(l.as_str()), "{out}"),
            None => assert!(!out.contains("foreign"), "{out}"),
        }
        // The Euler RMSE line is still there, and the new one follows it.
        let _ = rmse(&out);
        let (incl, heading, n) = incl_heading(&out);
        let want = score(&rows, FilterKind::Ekf, &cfg).expect("rows with truth");
        eprintln!("{extra:?}: inclination {incl} heading {heading}; score {want:?}");
        assert_eq!(n, rows.len(), "every row has truth");
        assert_eq!(n, want.rows);
        assert_printed(incl, want.inclination_deg, "inclination");
        assert_printed(heading, want.heading_deg, "heading");
        seen.push((incl, heading));
    }
    // Each configuration changes the result (the flags reach the filter).
    assert_ne!(seen[0], seen[1]);
    assert_ne!(seen[1], seen[2]);
}

#[test]
fn simulate_realistic_differs_and_the_plain_trace_is_unchanged() {
    use host_tests::sim::Scenario;
    use host_tests::trace::TraceWriter;

    let dir = tempfile::tempdir().unwrap();
    for name in ["tumble", "pitch-sine"] {
        let plain = dir.path().join(format!("{name}-plain.csv"));
        let real = dir.path().join(format!("{name}-real.csv"));
        let args = ["simulate", name, "--duration", "30", "--seed", "3"];
        let o = run(&[&args[..], &["--out", p(&plain)]].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(!stdout(&o).contains("realistic"), "{}", stdout(&o));
        let o = run(&[&args[..], &["--out", p(&real), "--realistic"]].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stdout(&o).contains("seed 3, realistic sensor errors)"), "{}", stdout(&o));

        // Without the flag: byte for byte the trace of the plain simulator (no realism).
        let scenario = Scenario::from_name(name).unwrap();
        let (sim, cfg) = scenario.simulator(50.0, Some(30.0), 3, false);
        let mut want = Vec::new();
        let mut tw = TraceWriter::new(&mut want, sim.columns()).unwrap();
        for c in scenario.comments(&cfg) {
            tw.comment(&c).unwrap();
        }
        for s in sim {
            tw.row(&s.row).unwrap();
        }
        tw.finish().unwrap();
        let plain = std::fs::read(&plain).unwrap();
        assert_eq!(plain, want, "{name}: plain trace changed");

        // With it: different sensor columns, the same rows, times and truth.
        let real = std::fs::read_to_string(&real).unwrap();
        assert_ne!(real.as_bytes(), &plain[..]);
        let data = |text: &str| -> Vec<Vec<String>> {
            text.lines()
                .filter(|l| !l.starts_with('#'))
                .map(|l| l.split(',').map(str::to_string).collect())
                .collect()
        };
        let (a, b) = (data(std::str::from_utf8(&plain).unwrap()), data(&real));
        assert_eq!(a.len(), b.len());
        assert_eq!(a[0], b[0], "header");
        let differ = a.iter().zip(&b).filter(|(x, y)| x[1..7] != y[1..7]).count();
        assert!(differ > a.len() / 2, "{name}: only {differ} rows differ");
        for (x, y) in a.iter().zip(&b) {
            assert_eq!((&x[0], &x[7..]), (&y[0], &y[7..]), "{name}: time or truth changed");
        }
    }
}

/// Issue #14: a replay never writes over its input (by any path to it), `--out -` writes the
/// estimate to stdout with the summary on stderr, and a device such as `/dev/null` is written
/// in place, not replaced.
#[test]
fn replay_outputs_never_replace_the_input_and_stdout_and_devices_work() {
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "coupled", "5");
    let before = std::fs::read(&trace).unwrap();
    let dotted = dir.path().join(".").join(".").join(trace.file_name().unwrap());
    for out in [&trace, &dotted] {
        let o = run(&["replay", p(&trace), "--out", p(out)]);
        assert!(!o.status.success());
        assert!(stderr(&o).contains("refusing to write over it"), "{}", stderr(&o));
    }
    assert_eq!(std::fs::read(&trace).unwrap(), before, "the input changed");

    let o = run(&["replay", p(&trace), "--out", "-"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = stdout(&o);
    assert!(csv.starts_with("t,qw,qx,qy,qz,roll,pitch,yaw"), "{csv}");
    assert_eq!(csv.lines().count(), 251, "header and 250 rows");
    assert!(stderr(&o).contains("replay: 250 rows"), "{}", stderr(&o));
    assert!(!dir.path().join("-").exists());

    let o = run(&["replay", p(&trace), "--out", "/dev/null"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!std::fs::metadata("/dev/null").unwrap().is_file());
}

#[test]
fn skip_bad_rows_passes_over_malformed_rows_and_reports_them() {
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "pitch-sine", "12");
    let text = std::fs::read_to_string(&trace).unwrap();
    // Damage data rows 100, 200 and 300 (file lines counted from 1) and cut the last one.
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let first_data = lines.iter().position(|l| !l.starts_with('#')).unwrap() + 1;
    let bad = [first_data + 100, first_data + 200, first_data + 300];
    for &i in &bad {
        lines[i] = lines[i].replacen(',', ",x", 1);
    }
    let last = lines.len() - 1;
    let half = lines[last].len() / 2;
    lines[last].truncate(half);
    let damaged = dir.path().join("damaged.csv");
    std::fs::write(&damaged, lines.join("\n")).unwrap();
    let est = dir.path().join("est.csv");
    // Strict: the first bad row stops the run, naming its line.
    let o = run(&["replay", p(&damaged), "--out", p(&est)]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).starts_with(&format!("error: {}: line {}", p(&damaged), bad[0] + 1)),
        "{}",
        stderr(&o)
    );
    assert!(!est.exists());
    // Lenient: every other row replayed, the four reported.
    let o = run(&["replay", p(&damaged), "--out", p(&est), "--skip-bad-rows"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let want = format!(
        "replay: skipped 4 malformed rows (lines {}, {}, {}, {}; first: line {}",
        bad[0] + 1,
        bad[1] + 1,
        bad[2] + 1,
        last + 1,
        bad[0] + 1
    );
    assert!(stderr(&o).contains(&want), "{}", stderr(&o));
    assert!(stdout(&o).contains("replay: 596 rows"), "{}", stdout(&o));
    let est_rows = std::fs::read_to_string(&est).unwrap().lines().count() - 1;
    assert_eq!(est_rows, 596);
}

#[test]
fn unfinished_and_moving_starts_are_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let est = dir.path().join("est.csv");
    // 3 s: shorter than the 10 s window.
    let short = simulate(dir.path(), "pitch-sine", "3");
    let o = run(&["replay", p(&short), "--out", p(&est)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("warning: the initialisation never completed"), "{}", stderr(&o));
    // Long enough: no warning.
    let long = simulate(dir.path(), "pitch-sine", "12");
    let o = run(&["replay", p(&long), "--out", p(&est)]);
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    // Moving from the first sample.
    let moving = simulate(dir.path(), "start-moving", "30");
    let o = run(&["replay", p(&moving), "--out", p(&est)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: the start was not still (MOVING_START)"),
        "{}",
        stderr(&o)
    );
}

/// A trace shaped as `ahrs-tool log` writes it: the CSV header, then the comments of
/// `TraceMeta::log_comments` (the conditioning its samples had, the device's settings).
/// Also the device's settings as a settings file (what `ahrs-tool settings get` writes).
fn as_logged(trace: &Path, device: &[&str], out: &Path, settings: &Path) {
    use host_tests::settings::{parse_assignment, settings_file_text, TraceMeta};
    let mut s = inemo_ahrs::pipeline::PipelineSettings::default();
    for t in device {
        let a = parse_assignment(t).unwrap();
        assert!(a.setting.set(&mut s, a.value));
    }
    std::fs::write(settings, settings_file_text(&s, &["a test device".into()])).unwrap();
    let text = std::fs::read_to_string(trace).unwrap();
    let (header, rest) = text.split_once('\n').unwrap();
    let mut log = format!("{header}\n# raw mode log from a test\n");
    for c in TraceMeta::log_comments(&s) {
        log.push_str(&format!("# {c}\n"));
    }
    log.push_str(rest);
    std::fs::write(out, log).unwrap();
}

#[test]
fn a_logged_dive_replays_with_the_device_settings_and_no_second_lever_arm() {
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "coupled", "30");
    let dive = dir.path().join("dive.csv");
    let dev = dir.path().join("device.txt");
    as_logged(&trace, &["mag.norm_tolerance=0.3", "lever.r=1,-0.5,0.2"], &dive, &dev);
    let f = |n: &str| dir.path().join(n);
    let o = run(&["replay", p(&dive), "--out", p(&f("a.csv"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        "replay: trace header: 71 device settings applied; its samples already had the lever \
         arm (none added)\n\
         replay: trace header: the device's estimator ran before the log's first row: the \
         replay's estimates are not the device's (ahrs-tool log --restart records a comparable \
         log)\n"
            .replace("71", &inemo_ahrs::registry::SETTINGS.len().to_string())
    );
    // A log whose first row is the restarted estimator's (`ahrs-tool log --restart`): the
    // replay says it reproduces the device.
    let restarted = dir.path().join("restarted.csv");
    let text = std::fs::read_to_string(&dive).unwrap();
    let (header, rest) = text.split_once('\n').unwrap();
    let meta = host_tests::settings::META_RESTARTED;
    std::fs::write(&restarted, format!("{header}\n# {meta}\n{rest}")).unwrap();
    let o = run(&["replay", p(&restarted), "--out", p(&f("r.csv"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).ends_with(
            "replay: trace header: the device's estimator restarted at the first row: the \
             replay reproduces the device's estimates\n"
        ),
        "{}",
        stderr(&o)
    );
    // The same as the bare trace with the device's settings (through the same 7-digit text)
    // and no lever arm ...
    let o = run(&[
        "replay",
        p(&trace),
        "--out",
        p(&f("b.csv")),
        "--settings",
        p(&dev),
        "--set",
        "lever.r=0,0,0",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(f("a.csv")).unwrap(), std::fs::read(f("b.csv")).unwrap());
    // ... and not as with the device's arm applied once more.
    let o = run(&["replay", p(&trace), "--out", p(&f("c.csv")), "--settings", p(&dev)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_ne!(std::fs::read(f("a.csv")).unwrap(), std::fs::read(f("c.csv")).unwrap());
    // A lever arm given for such a trace is named as not applied.
    let o = run(&["replay", p(&dive), "--out", p(&f("d.csv")), "--set", "lever.r=0.1,0,0"]);
    assert!(stderr(&o).contains("not applied: lever.r (the trace says its samples already had"));
    assert_eq!(std::fs::read(f("a.csv")).unwrap(), std::fs::read(f("d.csv")).unwrap());
}

/// `docs/tuning.md`, "Try a change on a recorded dive first", and `docs/replay.md`: the
/// commands as written there, on a dive shaped as `ahrs-tool log` writes it.
#[test]
fn the_documented_try_it_on_a_recorded_dive_commands_work() {
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "coupled", "30");
    let dive = dir.path().join("dive.csv");
    as_logged(&trace, &[], &dive, &dir.path().join("device.txt"));
    let cd = |args: &[&str]| {
        Command::new(BIN).current_dir(dir.path()).args(args).output().expect("run host-tests")
    };
    let before = cd(&["replay", "dive.csv", "--out", "before.csv"]);
    assert!(before.status.success(), "{}", stderr(&before));
    let after = cd(&[
        "replay",
        "dive.csv",
        "--out",
        "after.csv",
        "--set",
        "ekf.accel_time_constant=1.5",
        "--set",
        "noise.accel_var=4.752e-5",
    ]);
    assert!(after.status.success(), "{}", stderr(&after));
    assert!(!stderr(&after).contains("not applied:"), "{}", stderr(&after));
    let read = |n: &str| std::fs::read(dir.path().join(n)).unwrap();
    assert_ne!(read("before.csv"), read("after.csv"));
    let file = cd(&["replay", "dive.csv", "--out", "file.csv", "--settings", "device.txt"]);
    assert!(file.status.success(), "{}", stderr(&file));
    // A device's whole file: the settings a replay cannot apply are named, the rest applied.
    assert!(
        stderr(&file).contains("not applied: axes.gyro, axes.accel, axes.mag"),
        "{}",
        stderr(&file)
    );
    assert_eq!(read("before.csv"), read("file.csv"));
}

#[test]
fn replay_shows_no_progress_when_stderr_is_not_a_terminal() {
    // Long enough to pass the progress threshold (`host_tests::progress::SHOW_AFTER`) on a
    // slow machine is not needed: off a terminal nothing is ever drawn, however long.
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "still-hour", "600");
    let est = dir.path().join("est.csv");
    let o = run(&["replay", p(&trace), "--out", p(&est)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(!err.contains('\u{1b}') && !err.contains('\r'), "{err:?}");
    assert!(!err.contains("replay ["), "{err}");
}

/// On a terminal (a pseudo-terminal from util-linux `script`), a replay still reading after
/// 1 s shows progress on stderr. The trace comes through a FIFO, written in two halves 1.5 s
/// apart, so the replay is long without a large file (its size unknown: a spinner and the
/// bytes read).
#[cfg(target_os = "linux")]
#[test]
fn replay_shows_progress_on_a_terminal() {
    use std::io::Write as _;
    let have = |cmd: &str| Command::new("sh").args(["-c", &format!("command -v {cmd}")]).output();
    if !have("script").is_ok_and(|o| o.status.success())
        || !have("mkfifo").is_ok_and(|o| o.status.success())
    {
        eprintln!("SKIPPED: needs util-linux script and mkfifo");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "pitch-sine", "60");
    let text = std::fs::read(&trace).unwrap();
    let fifo = dir.path().join("trace.fifo");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let est = dir.path().join("est.csv");
    let cmd = format!("'{BIN}' replay '{}' --out '{}'", p(&fifo), p(&est));
    let child = Command::new("script")
        .args(["-qec", &cmd, "/dev/null"])
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut w = std::fs::OpenOptions::new().write(true).open(&fifo).unwrap();
    let half = text.len() / 2;
    w.write_all(&text[..half]).unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    w.write_all(&text[half..]).unwrap();
    drop(w);
    let o = child.wait_with_output().unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{out}");
    assert!(out.contains("replay: 3000 rows"), "{out}");
    // The bar's line: drawn and cleared with escape codes, with the bytes read.
    assert!(out.contains('\u{1b}') && out.contains(" KiB"), "{out:?}");
}

/// The plot's title names the run and gives the RMSE after initialisation, which the test
/// computes itself from the two files (truth quaternion to ZYX Euler angles by hand); the
/// initialisation window (rows flagged INITIALISING, bit 0) is shaded; `--size` sets the
/// image's size and a bad size is refused before anything is written (issue #30).
#[test]
fn plot_titles_the_run_with_its_rmse_and_shades_the_initialisation() {
    let dir = tempfile::tempdir().unwrap();
    let trace = simulate(dir.path(), "yaw-sine", "20");
    let est = dir.path().join("est.csv");
    assert!(run(&["replay", p(&trace), "--out", p(&est)]).status.success());
    let svg = dir.path().join("fig.svg");
    let args = ["plot", p(&trace), p(&est), "--out", p(&svg), "--title", "yaw-sine, EKF"];
    let o = run(&[&args[..], &["--size", "1000x700"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg width=\"1000\" height=\"700\""), "{}", &text[..100]);

    // The RMSE by hand: rows after the last INITIALISING row, angle errors wrapped to ±180°.
    let rows = |path: &Path| -> Vec<Vec<f64>> {
        let t = std::fs::read_to_string(path).unwrap();
        t.lines()
            .filter(|l| !l.starts_with('#'))
            .skip(1)
            .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
            .collect()
    };
    let (tr, es) = (rows(&trace), rows(&est));
    let mut sq = [0.0f64; 3];
    let (mut n, mut init_end) = (0.0, 0.0);
    for (a, e) in tr.iter().zip(&es) {
        if e[11] as u32 & 1 != 0 {
            init_end = e[0];
            continue;
        }
        let (w, x, y, z) = (a[7], a[8], a[9], a[10]);
        let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
        let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
        let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
        for (i, truth) in [roll, pitch, yaw].iter().enumerate() {
            let d = (e[5 + i] - truth.to_degrees() + 540.0).rem_euclid(360.0) - 180.0;
            sq[i] += d * d;
        }
        n += 1.0;
    }
    assert!(init_end > 5.0 && n > 100.0, "{init_end} {n}");
    let [r, pch, y] = sq.map(|s| (s / n).sqrt());
    let title = format!(
        "yaw-sine, EKF  ·  RMSE after initialisation: roll {r:.3}°, pitch {pch:.3}°, yaw {y:.3}°"
    );
    assert!(text.contains(&title), "no title {title:?} in the SVG");
    // The shade: a filled rectangle in the initialisation's grey, one per panel.
    assert_eq!(text.matches("fill=\"#E1E1E1\"").count(), 6, "one per panel");

    // A bad size: refused, nothing written.
    let bad = dir.path().join("bad.svg");
    let o = run(&["plot", p(&trace), p(&est), "--out", p(&bad), "--size", "10x10"]);
    assert!(!o.status.success() && stderr(&o).contains("10x10"), "{}", stderr(&o));
    assert!(!bad.exists());
}

/// Issue #39 point 2: a process killed while writing its output leaves nothing behind. A
/// `simulate` of 10⁶ s (the longest accepted), killed (SIGKILL: no handler runs) after it has
/// written for a second: the directory holds no file, hidden or not (before: a hidden `.tmp`
/// file of what it had written, hundreds of MB for a long run). On Linux the output is an
/// unnamed file until it is complete (`O_TMPFILE`).
#[test]
#[cfg(target_os = "linux")]
fn a_killed_run_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("long.csv");
    let mut child = Command::new(BIN)
        .args(["simulate", "pitch-sine", "--out", p(&out), "--duration", "1000000", "--seed", "1"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert!(child.try_wait().unwrap().is_none(), "simulate ended before it was killed");
    child.kill().unwrap();
    child.wait().unwrap();
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().path()).collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}
