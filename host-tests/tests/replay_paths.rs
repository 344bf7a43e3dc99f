//! `replay` (three threads) and `replay_serial` (one) are two schedules of the same work: the
//! `replay` command picks one by the number of cores, so they must give the same estimate bytes
//! and the same statistics and, on a malformed trace, the same error. (What they have written
//! when they stop at an error differs, by whole blocks of rows, and is the start of the good
//! output; the command deletes it.)

use ekf_core::conditioning::Conditioner;
use host_tests::config::ReplayConfig;
use host_tests::replay::{replay, replay_serial, FilterKind, ReplayStats};
use host_tests::sim::Scenario;
use host_tests::trace::{TraceReader, TraceWriter};

/// Output bytes and the result (statistics without the wall time, or the error's message) of
/// one path on `csv`, default settings with `kind`.
fn run(csv: &[u8], kind: FilterKind, threads: bool) -> (Vec<u8>, Result<ReplayStats, String>) {
    let cfg = ReplayConfig::default();
    let mut f = cfg.make_filter(kind);
    let mut cond = Conditioner::new(cfg.conditioning);
    let window = cfg.settings.init.window_s as f64;
    let mut out = Vec::new();
    let reader = TraceReader::new(csv).expect("header");
    let r = if threads {
        replay(reader, &mut out, f.as_mut(), &mut cond, window)
    } else {
        replay_serial(reader, &mut out, f.as_mut(), &mut cond, window)
    };
    let r = r.map(|s| ReplayStats { elapsed_s: 0.0, ..s }).map_err(|e| e.to_string());
    (out, r)
}

/// 60 s of scenario 2 at 50 Hz with the magnetometer: more rows than one of `replay`'s chunks.
fn trace() -> Vec<u8> {
    let (sim, _) = Scenario::Coupled.simulator(50.0, Some(60.0), 3, true);
    let mut w = TraceWriter::new(Vec::new(), sim.columns()).unwrap();
    for s in sim {
        w.row(&s.row).unwrap();
    }
    w.finish().unwrap()
}

#[test]
fn both_paths_write_the_same_estimates() {
    let csv = trace();
    for kind in FilterKind::ALL {
        let (a, ra) = run(&csv, kind, true);
        let (b, rb) = run(&csv, kind, false);
        let stats = ra.expect("threaded replay");
        assert_eq!(stats.rows, 3000, "{kind:?}");
        assert!(stats.rmse.rmse().is_some(), "{kind:?}: truth rows after the window");
        assert_eq!(Ok(stats), rb, "{kind:?}");
        assert!(a == b, "{kind:?}: the estimate files differ");
    }
}

#[test]
fn both_paths_stop_at_the_same_error() {
    let csv = trace();
    let (good, _) = run(&csv, FilterKind::Ekf, false);
    let text = String::from_utf8(csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    // Data line 2500 (after a full chunk of `replay`'s parser) made bad in three ways.
    let k = lines.iter().position(|l| l.starts_with(|c: char| c.is_ascii_digit())).unwrap() + 2500;
    let cells: Vec<&str> = lines[k].split(',').collect();
    for bad in [
        // A non-numeric cell.
        [&["x"][..], &cells[1..]].concat().join(","),
        // NaN in the gyro.
        [&cells[..1], &["NaN"][..], &cells[2..]].concat().join(","),
        // Time going back.
        [&["1.0"][..], &cells[1..]].concat().join(","),
    ] {
        let mut broken = lines.clone();
        broken[k] = &bad;
        let broken = broken.join("\n") + "\n";
        let (a, ra) = run(broken.as_bytes(), FilterKind::Ekf, true);
        let (b, rb) = run(broken.as_bytes(), FilterKind::Ekf, false);
        let ea = ra.expect_err("threaded replay must fail");
        assert!(ea.contains(&format!("line {}", k + 1)), "{bad}: {ea}");
        assert_eq!(Err(ea), rb, "{bad}");
        assert!(good.starts_with(&a) && good.starts_with(&b), "{bad}: not the good output's start");
    }
}
