//! Instruction counts per replay stage, for callgrind (the stable figure on a busy machine):
//!
//! ```text
//! cargo build --release -p host-tests --example replay_profile
//! valgrind --tool=callgrind --collect-atstart=no --toggle-collect='*stage_STAGE*' \
//!     target/release/examples/replay_profile STAGE [ROWS]
//! ```
//!
//! `STAGE` is `parse`, `filter`, `format` or `serial` (all on one thread, memory to memory,
//! the trace's bytes read in place), or `file` (`replay_serial` from a trace file to an
//! estimate file, as the `replay` command writes it);
//! the trace is the `still-hour` scenario (seed 1) cut to `ROWS` rows (default 20 000). The
//! collected count divided by `ROWS` is the instructions per row of that stage.
//!
//! For a sampling profile of the whole single-thread replay, `serial` takes a repeat count:
//!
//! ```text
//! perf record -e cpu-clock -g target/release/examples/replay_profile serial 180000 20
//! ```
//!
//! With a repeat count above 1 it also prints the best and the median thread CPU time per row
//! of the repeats (a quick A/B figure; the benchmark `replay_speed` is the reported one);
//! `file ROWS REPS` prints the best wall time and the best thread CPU time (user and system).

use std::io::BufReader;

use ekf_core::conditioning::Conditioner;
use host_tests::accuracy::{replay_config, simulate, thread_cpu_s, RATE_HZ};
use host_tests::config::ReplayConfig;
use host_tests::output::write_atomically;
use host_tests::replay::{replay_rows, replay_serial, FilterKind};
use host_tests::sim::Scenario;
use host_tests::trace::TraceWriter;
use host_tests::trace::{EstimateRow, EstimateWriter, TraceColumns, TraceReader, TraceRow};

#[inline(never)]
fn stage_parse(csv: &[u8]) -> usize {
    let mut r = TraceReader::new(csv).unwrap();
    let mut k = 0;
    while let Some(row) = r.next_row().unwrap() {
        std::hint::black_box(row);
        k += 1;
    }
    k
}

#[inline(never)]
fn stage_filter(cfg: &ReplayConfig, rows: &[TraceRow], est: &mut Vec<EstimateRow>) {
    let mut f = cfg.make_filter(FilterKind::Ekf);
    let mut cond = Conditioner::new(cfg.conditioning);
    let window = cfg.settings.init.window_s as f64;
    replay_rows(rows.iter().map(|r| Ok(*r)), f.as_mut(), &mut cond, window, |_, e| {
        est.push(*e);
        Ok(())
    })
    .unwrap();
}

#[inline(never)]
fn stage_format(est: &[EstimateRow], out: &mut Vec<u8>) {
    let mut w = EstimateWriter::new(out).unwrap();
    for e in est {
        w.row(e).unwrap();
    }
    w.finish().unwrap();
}

#[inline(never)]
fn stage_serial(cfg: &ReplayConfig, csv: &[u8], out: &mut Vec<u8>) {
    let reader = TraceReader::new(csv).unwrap();
    let mut f = cfg.make_filter(FilterKind::Ekf);
    let mut cond = Conditioner::new(cfg.conditioning);
    let window = cfg.settings.init.window_s as f64;
    replay_serial(reader, out, f.as_mut(), &mut cond, window).unwrap();
}

#[inline(never)]
fn stage_file(cfg: &ReplayConfig, trace: &std::path::Path, est: &std::path::Path) {
    let file = std::fs::File::open(trace).expect("open the trace");
    let reader = TraceReader::new(BufReader::with_capacity(1 << 16, file)).unwrap();
    let mut f = cfg.make_filter(FilterKind::Ekf);
    let mut cond = Conditioner::new(cfg.conditioning);
    let window = cfg.settings.init.window_s as f64;
    write_atomically(est, |w| replay_serial(reader, w, f.as_mut(), &mut cond, window)).unwrap();
}

fn main() {
    let mut args = std::env::args().skip(1);
    let stage = args.next().unwrap_or_else(|| "serial".into());
    let n: usize = args.next().map_or(20_000, |s| s.parse().expect("ROWS"));
    let scenario = Scenario::StillHour;
    let rows = simulate(scenario, Some(n as f64 / RATE_HZ), 1);
    let rows = &rows[..n.min(rows.len())];
    let mut w =
        TraceWriter::new(Vec::new(), TraceColumns { truth: true, ..Default::default() }).unwrap();
    for r in rows {
        w.row(r).unwrap();
    }
    let csv = w.finish().unwrap();
    let cfg = replay_config(scenario);
    let mut est = Vec::with_capacity(rows.len());
    let mut out = Vec::with_capacity(rows.len() * 128);
    match stage.as_str() {
        "parse" => assert_eq!(stage_parse(&csv), rows.len()),
        "filter" => stage_filter(&cfg, rows, &mut est),
        "format" => {
            stage_filter(&cfg, rows, &mut est);
            stage_format(&est, &mut out);
        }
        "serial" => {
            // Repeated (third argument) so that a sampling profiler sees mostly the replay,
            // not the simulation that made its input.
            let reps: usize = args.next().map_or(1, |s| s.parse().expect("REPS"));
            let mut times = Vec::with_capacity(reps);
            for _ in 0..reps {
                out.clear();
                let c0 = thread_cpu_s().unwrap_or(0.0);
                stage_serial(&cfg, &csv, &mut out);
                times.push((thread_cpu_s().unwrap_or(0.0) - c0) * 1e9 / rows.len() as f64);
            }
            times.sort_by(f64::total_cmp);
            if reps > 1 {
                // Thread CPU time per row: best, and the median of the runs.
                eprintln!("serial: best {:.1} ns/row, median {:.1}", times[0], times[reps / 2]);
            }
        }
        "file" => {
            // `replay_serial` file to file, as the `replay` command writes its output (through
            // `write_atomically`), repeated: the best wall time and the best thread CPU time
            // (user and system) per row.
            let reps: usize = args.next().map_or(1, |s| s.parse().expect("REPS"));
            let dir = tempfile::tempdir().expect("temporary directory");
            let (trace, est) = (dir.path().join("trace.csv"), dir.path().join("est.csv"));
            std::fs::write(&trace, &csv).expect("write the trace");
            let (mut wall, mut cpu) = (f64::INFINITY, f64::INFINITY);
            for _ in 0..reps {
                let (t0, c0) = (std::time::Instant::now(), thread_cpu_s().unwrap_or(0.0));
                stage_file(&cfg, &trace, &est);
                let c = thread_cpu_s().unwrap_or(0.0) - c0;
                wall = wall.min(t0.elapsed().as_secs_f64());
                cpu = cpu.min(c);
            }
            let per_row = |s: f64| s * 1e9 / rows.len() as f64;
            eprintln!("file: best wall {:.1} ns/row, CPU {:.1}", per_row(wall), per_row(cpu));
        }
        _ => panic!("stage: parse, filter, format, serial or file"),
    }
    eprintln!("{stage}: {} rows, {} bytes in, {} bytes out", rows.len(), csv.len(), out.len());
}
