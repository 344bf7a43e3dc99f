//! Replay throughput: `cargo bench -p host-tests --bench replay_speed`.
//!
//! The one-hour `still-hour` trace (180 000 rows, seed 1) is simulated and written to memory
//! once; then 15 rounds, each running every measurement below once, and the best of each kept
//! (bursts of load on a shared machine last seconds, and the rounds spread every figure over
//! the same stretch of time). On one thread, timed by the thread's CPU time
//! (`clock_gettime(CLOCK_THREAD_CPUTIME_ID)`; wall time where there is none) so that other
//! processes sharing the cores do not inflate it:
//! - **parse**: `TraceReader` over the CSV bytes (the byte slice itself as the `BufRead`: in
//!   memory there is nothing to read, so no copy through a buffer);
//! - **filter**: the replay loop (`replay_rows`: conditioning, `dt`, the EKF, RMSE) on parsed
//!   rows, estimates kept in memory;
//! - **format**: `EstimateWriter` of the estimate rows into memory;
//!
//! and end to end, from the CSV bytes in memory to an estimate CSV in memory:
//! - `replay_serial` (everything on one thread: the single-core figure), thread CPU time;
//! - `replay` (parsing and formatting on their own threads), wall time;
//!
//! and file to file as the `replay` command does it (trace file in the page cache, output
//! through `write_atomically` to a temporary directory), wall time, with each of the two, and
//! the thread CPU time of `replay_serial` (user and system: the kernel's copies and page-cache
//! work count, on the one core). `--markdown docs/accuracy.md` also writes the table into
//! docs/accuracy.md.

use std::fmt::Write as _;
use std::io::BufReader;
use std::path::{Path, PathBuf};
use std::time::Instant;

use ekf_core::conditioning::Conditioner;
use host_tests::accuracy::{replace_section, replay_config, simulate, thread_cpu_s};
use host_tests::output::write_atomically;
use host_tests::replay::{replay, replay_rows, replay_serial, FilterKind};
use host_tests::sim::Scenario;
use host_tests::trace::{EstimateRow, EstimateWriter, TraceReader, TraceRow, TraceWriter};

const REPS: usize = 15;
const SECTION: &str = "replay-speed";
const COMMAND: &str =
    "cargo bench -p host-tests --bench replay_speed -- --markdown docs/accuracy.md";

/// CPU time of the calling thread for `f` where available, else its wall time, s.
fn cpu<F: FnOnce()>(f: F) -> f64 {
    let (t, c) = (Instant::now(), thread_cpu_s());
    f();
    match (c, thread_cpu_s()) {
        (Some(a), Some(b)) => b - a,
        _ => t.elapsed().as_secs_f64(),
    }
}

/// Wall time of `f`, s.
fn wall<F: FnOnce()>(f: F) -> f64 {
    let t = Instant::now();
    f();
    t.elapsed().as_secs_f64()
}

/// Wall time and thread CPU time of one run of `f` (the CPU time is the wall time where there
/// is no thread clock), s.
fn wall_and_cpu<F: FnOnce()>(f: F) -> (f64, f64) {
    let mut c = 0.0;
    let w = wall(|| c = cpu(f));
    (w, c)
}

fn main() {
    // `--markdown PATH` (relative to the workspace root) also rewrites the section between
    // `<!-- BEGIN replay-speed -->` and `<!-- END replay-speed -->` of PATH. `cargo bench`
    // passes `--bench`, ignored.
    let mut markdown: Option<PathBuf> = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        if a == "--markdown" {
            markdown = args.next().map(PathBuf::from);
        }
    }
    let scenario = Scenario::StillHour;
    let rows: Vec<TraceRow> = simulate(scenario, None, 1);
    let n = rows.len() as f64;
    let mut w = TraceWriter::new(
        Vec::new(),
        host_tests::trace::TraceColumns { truth: true, ..Default::default() },
    )
    .unwrap();
    for r in &rows {
        w.row(r).unwrap();
    }
    let csv = w.finish().unwrap();
    let cfg = replay_config(scenario);
    let window = cfg.settings.init.window_s as f64;

    // One estimate buffer and one output buffer for all runs, so that their pages are mapped
    // once (first-touch page faults would otherwise be a large part of the format stage).
    let mut est: Vec<EstimateRow> = Vec::with_capacity(rows.len());
    let mut out: Vec<u8> = Vec::with_capacity(32 << 20);
    let mut out_len = None;
    // File to file, as `host-tests replay` does it.
    let dir = tempfile::tempdir().unwrap();
    let trace_path = dir.path().join("trace.csv");
    let est_path = dir.path().join("est.csv");
    std::fs::write(&trace_path, &csv).unwrap();
    let file_to_file = |threads: bool| {
        let file = std::fs::File::open(&trace_path).unwrap();
        let reader = TraceReader::new(BufReader::with_capacity(1 << 16, file)).unwrap();
        let mut f = cfg.make_filter(FilterKind::Ekf);
        let mut cond = Conditioner::new(cfg.conditioning);
        let s = write_atomically(&est_path, |w| {
            if threads {
                replay(reader, w, f.as_mut(), &mut cond, window)
            } else {
                replay_serial(reader, w, f.as_mut(), &mut cond, window)
            }
        })
        .unwrap();
        assert_eq!(s.rows as usize, rows.len());
    };

    // Round by round, every measurement once per round, the best of each kept: the rounds
    // spread every figure over the same stretch of time, so that a quiet or a busy spell of a
    // shared machine does not favour one of them.
    let mut b = [f64::INFINITY; 8];
    for _ in 0..REPS {
        let (file_wall, file_cpu) = wall_and_cpu(|| file_to_file(false));
        let times = [
            cpu(|| {
                let mut r = TraceReader::new(&csv[..]).unwrap();
                let mut k = 0usize;
                while let Some(row) = r.next_row().unwrap() {
                    std::hint::black_box(row);
                    k += 1;
                }
                assert_eq!(k, rows.len());
            }),
            cpu(|| {
                est.clear();
                let mut f = cfg.make_filter(FilterKind::Ekf);
                let mut cond = Conditioner::new(cfg.conditioning);
                replay_rows(rows.iter().map(|r| Ok(*r)), f.as_mut(), &mut cond, window, |_, e| {
                    est.push(*e);
                    Ok(())
                })
                .unwrap();
            }),
            cpu(|| {
                out.clear();
                let mut w = EstimateWriter::new(&mut out).unwrap();
                for e in &est {
                    w.row(e).unwrap();
                }
                w.finish().unwrap();
            }),
            cpu(|| {
                let reader = TraceReader::new(&csv[..]).unwrap();
                let mut f = cfg.make_filter(FilterKind::Ekf);
                let mut cond = Conditioner::new(cfg.conditioning);
                let formatted = out.len();
                out.clear();
                let s = replay_serial(reader, &mut out, f.as_mut(), &mut cond, window).unwrap();
                assert_eq!(s.rows as usize, rows.len());
                assert_eq!(out.len(), formatted, "the format stage's bytes");
            }),
            wall(|| {
                let reader = TraceReader::new(&csv[..]).unwrap();
                let mut f = cfg.make_filter(FilterKind::Ekf);
                let mut cond = Conditioner::new(cfg.conditioning);
                out.clear();
                let s = replay(reader, &mut out, f.as_mut(), &mut cond, window).unwrap();
                assert_eq!(s.rows as usize, rows.len());
                out_len = Some(out.len());
            }),
            file_wall,
            wall(|| file_to_file(true)),
            file_cpu,
        ];
        for (b, t) in b.iter_mut().zip(times) {
            *b = b.min(t);
        }
    }
    let [parse, filter, format, serial, end_to_end, file_serial, file_threads, file_serial_cpu] = b;
    let out_len = out_len.unwrap_or(0);

    let ns = |s: f64| s * 1e9 / n;
    let total = ns(parse) + ns(filter) + ns(format);
    let clock = if thread_cpu_s().is_some() { "thread CPU time" } else { "wall time" };
    let mut md = String::new();
    let _ = writeln!(
        md,
        "Generated by `{COMMAND}`: {} rows of `{}` (seed 1), {} bytes of trace CSV in, {} bytes \
         of estimate CSV out, default EKF, best of {REPS} rounds of all the measurements \
         ({clock} where marked CPU, wall time where marked wall). Machine-dependent: the \
         figures vary from run to run, and with the load of the machine.\n",
        rows.len(),
        scenario.name(),
        csv.len(),
        out_len
    );
    let _ = writeln!(md, "| stage | ns/row | M rows/s |");
    let _ = writeln!(md, "|---|---|---|");
    for (name, v) in [
        ("parse (`TraceReader`, CPU)", ns(parse)),
        ("filter (`replay_rows`: conditioning, EKF, RMSE; CPU)", ns(filter)),
        ("format (`EstimateWriter`, CPU)", ns(format)),
        ("sum of the three", total),
        ("`replay_serial` end to end, memory to memory, 1 thread (CPU)", ns(serial)),
        ("`replay` end to end, memory to memory, 3 threads (wall)", ns(end_to_end)),
        ("file to file, 1 thread (`replay_serial`, wall)", ns(file_serial)),
        ("file to file, 1 thread (`replay_serial`, CPU: user + system)", ns(file_serial_cpu)),
        ("file to file, 3 threads (`replay`, wall)", ns(file_threads)),
    ] {
        let _ = writeln!(md, "| {name} | {v:.0} | {:.2} |", 1e3 / v);
    }
    println!("{md}");
    if let Some(path) = markdown {
        let path = if path.is_relative() {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
        } else {
            path
        };
        let doc =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let new = replace_section(&doc, SECTION, &md).unwrap_or_else(|| {
            panic!("{}: no <!-- BEGIN {SECTION} --> ... <!-- END {SECTION} -->", path.display())
        });
        std::fs::write(&path, new).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        eprintln!("wrote the replay-speed section of {}", path.display());
    }
}
