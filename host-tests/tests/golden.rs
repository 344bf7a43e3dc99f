//! Golden replay: the committed short trace `tests/data/golden-trace.csv` (30 s of scenario 2,
//! `coupled`, at 50 Hz, seed 42) replayed with the default EKF through the `replay` command's
//! code path must reproduce the committed `tests/data/golden-estimate.csv`, so any functional
//! change of the estimator (or of conditioning, replay or the file formats) shows up in review
//! as a change of the golden estimate.
//!
//! Tolerance, per row: quaternion components within 1e-5 (after aligning the sign), Euler
//! angles within 2e-3° (yaw wrapped), bias within 1e-4 °/s, time and flags exactly, the same
//! number of rows. On one host the replay is deterministic and the files match bit for bit (the
//! test says so when they do); the tolerance only absorbs rounding differences from a compiler
//! or platform change, far below any functional change.
//!
//! Regenerate both files after an intended change:
//! `UPDATE_GOLDEN=1 cargo test -p host-tests --test golden`.

use std::io::BufReader;
use std::path::{Path, PathBuf};

use ekf_core::conditioning::Conditioner;
use host_tests::config::ReplayConfig;
use host_tests::replay::{replay, wrap_deg, FilterKind};
use host_tests::sim::Scenario;
use host_tests::trace::{EstimateReader, EstimateRow, TraceReader, TraceWriter};

const SECONDS: f64 = 30.0;
const SEED: u64 = 42;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

/// Replay a trace file with the default EKF, as `host-tests replay TRACE --out -` would.
fn replay_file(trace: &Path) -> Vec<u8> {
    let file = std::fs::File::open(trace).expect("golden trace");
    let reader = TraceReader::new(BufReader::new(file)).expect("trace header");
    let cfg = ReplayConfig::default();
    let mut f = cfg.make_filter(FilterKind::Ekf);
    let mut cond = Conditioner::new(cfg.conditioning);
    let mut out = Vec::new();
    replay(reader, &mut out, f.as_mut(), &mut cond, cfg.settings.init.window_s as f64)
        .expect("replay");
    out
}

fn parse(bytes: &[u8]) -> Vec<EstimateRow> {
    let mut r = EstimateReader::new(bytes).expect("estimate header");
    let mut rows = Vec::new();
    while let Some(row) = r.next_row().expect("estimate row") {
        rows.push(row);
    }
    rows
}

fn regenerate() {
    let (sim, cfg) = Scenario::Coupled.simulator(50.0, Some(SECONDS), SEED, false);
    let mut w = TraceWriter::new(Vec::new(), sim.columns()).unwrap();
    for c in Scenario::Coupled.comments(&cfg) {
        w.comment(&c).unwrap();
    }
    w.comment("golden trace of host-tests/tests/golden.rs: UPDATE_GOLDEN=1 cargo test -p host-tests --test golden").unwrap();
    for s in sim {
        w.row(&s.row).unwrap();
    }
    std::fs::write(data("golden-trace.csv"), w.finish().unwrap()).unwrap();
    let est = replay_file(&data("golden-trace.csv"));
    std::fs::write(data("golden-estimate.csv"), est).unwrap();
    eprintln!(
        "regenerated {} and {}",
        data("golden-trace.csv").display(),
        data("golden-estimate.csv").display()
    );
}

#[test]
fn replay_matches_the_golden_estimate() {
    if std::env::var_os("UPDATE_GOLDEN").is_some_and(|v| v == "1") {
        regenerate();
    }
    let golden_bytes = std::fs::read(data("golden-estimate.csv")).expect("golden estimate");
    let out = replay_file(&data("golden-trace.csv"));
    if out == golden_bytes {
        eprintln!("golden: bit-identical");
        return;
    }
    let (got, want) = (parse(&out), parse(&golden_bytes));
    assert_eq!(got.len(), want.len(), "row count");
    assert_eq!(want.len(), (SECONDS * 50.0) as usize);
    let mut worst = [0.0f64; 3];
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        let line = k + 2;
        assert_eq!(g.t, w.t, "line {line}: t");
        assert_eq!(g.flags, w.flags, "line {line} (t = {}): flags", w.t);
        let dot: f32 = (0..4).map(|i| g.q[i] * w.q[i]).sum();
        let s = if dot < 0.0 { -1.0 } else { 1.0 };
        for i in 0..4 {
            let d = (s * g.q[i] - w.q[i]).abs() as f64;
            worst[0] = worst[0].max(d);
            assert!(d <= 1e-5, "line {line} (t = {}): q[{i}] {} vs golden {}", w.t, g.q[i], w.q[i]);
        }
        for i in 0..3 {
            let d = wrap_deg(g.euler_deg[i] as f64 - w.euler_deg[i] as f64).abs();
            worst[1] = worst[1].max(d);
            assert!(
                d <= 2e-3,
                "line {line} (t = {}): euler[{i}] {} vs golden {}",
                w.t,
                g.euler_deg[i],
                w.euler_deg[i]
            );
            let d = (g.bias_dps[i] - w.bias_dps[i]).abs() as f64;
            worst[2] = worst[2].max(d);
            assert!(
                d <= 1e-4,
                "line {line} (t = {}): bias[{i}] {} vs golden {}",
                w.t,
                g.bias_dps[i],
                w.bias_dps[i]
            );
        }
    }
    eprintln!("golden: within tolerance, not bit-identical (largest differences: q {:.2e}, euler {:.2e}°, bias {:.2e} °/s)", worst[0], worst[1], worst[2]);
}
