//! Progress on long work: a bar on standard error (`indicatif`) while a replay reads its
//! input, shown only when standard error is a terminal and the work has already taken
//! [`SHOW_AFTER`]; nothing at all (no thread, no escape codes) otherwise, so piped and logged
//! runs stay quiet.

use std::io::{IsTerminal, Read};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A run shorter than this shows no progress.
pub const SHOW_AFTER: Duration = Duration::from_secs(1);

/// How often the bar is updated.
const TICK: Duration = Duration::from_millis(100);

/// Whether to show progress now: standard error is a terminal, the work has run for
/// [`SHOW_AFTER`] and is not finished (`done < total`, when the total is known).
pub fn should_show(
    stderr_is_terminal: bool,
    elapsed: Duration,
    done: u64,
    total: Option<u64>,
) -> bool {
    stderr_is_terminal && elapsed >= SHOW_AFTER && total.is_none_or(|t| done < t)
}

/// A reader that counts the bytes read through it into a shared counter.
pub struct CountingReader<R> {
    inner: R,
    count: Arc<AtomicU64>,
}

impl<R> CountingReader<R> {
    /// Wrap `inner`; [`CountingReader::counter`] follows it.
    pub fn new(inner: R) -> Self {
        CountingReader { inner, count: Arc::new(AtomicU64::new(0)) }
    }

    /// The bytes read so far, shared.
    pub fn counter(&self) -> Arc<AtomicU64> {
        Arc::clone(&self.count)
    }
}

impl<R: Read> Read for CountingReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.count.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }
}

/// Progress of reading `total` bytes (`None`: unknown, e.g. a pipe), by a counter; ends (and
/// clears its line) on [`Progress::finish`] or drop.
pub struct Progress {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Progress {
    /// Start watching `count` for `label`; does nothing unless standard error is a terminal.
    pub fn start(label: &str, total: Option<u64>, count: Arc<AtomicU64>) -> Progress {
        let stop = Arc::new(AtomicBool::new(false));
        if !std::io::stderr().is_terminal() {
            return Progress { stop, thread: None };
        }
        let label = label.to_string();
        let flag = Arc::clone(&stop);
        let thread = std::thread::spawn(move || {
            let start = Instant::now();
            let mut bar: Option<ProgressBar> = None;
            while !flag.load(Ordering::Relaxed) {
                std::thread::park_timeout(TICK);
                let done = count.load(Ordering::Relaxed);
                if bar.is_none() && should_show(true, start.elapsed(), done, total) {
                    let b = match total {
                        Some(t) => ProgressBar::with_draw_target(
                            Some(t),
                            ProgressDrawTarget::stderr(),
                        )
                        .with_style(
                            ProgressStyle::with_template(
                                "{msg} [{bar:30}] {bytes}/{total_bytes} ({percent}%), {elapsed}",
                            )
                            .unwrap_or_else(|_| ProgressStyle::default_bar())
                            .progress_chars("=> "),
                        ),
                        None => ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr())
                            .with_style(
                                ProgressStyle::with_template("{msg} {spinner} {bytes} {elapsed}")
                                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
                            ),
                    };
                    let b = b.with_position(done).with_elapsed(start.elapsed());
                    b.set_message(label.clone());
                    bar = Some(b);
                }
                if let Some(b) = &bar {
                    b.set_position(done);
                }
            }
            if let Some(b) = bar {
                b.finish_and_clear();
            }
        });
        Progress { stop, thread: Some(thread) }
    }

    /// Stop and clear the bar (before the command's own messages).
    pub fn finish(mut self) {
        self.end();
    }

    fn end(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            t.thread().unpark();
            let _ = t.join();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.end();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shown_only_on_a_terminal_for_long_unfinished_work() {
        let long = SHOW_AFTER + Duration::from_millis(1);
        let short = SHOW_AFTER - Duration::from_millis(1);
        assert!(should_show(true, long, 10, Some(100)));
        assert!(should_show(true, long, 10, None));
        assert!(!should_show(false, long, 10, Some(100)), "not a terminal");
        assert!(!should_show(true, short, 10, Some(100)), "too short so far");
        assert!(!should_show(true, long, 100, Some(100)), "finished");
    }

    #[test]
    fn the_counter_follows_the_reads() {
        let mut r = CountingReader::new(&b"hello, world"[..]);
        let c = r.counter();
        let mut buf = [0u8; 5];
        r.read_exact(&mut buf).unwrap();
        assert_eq!(c.load(Ordering::Relaxed), 5);
        let mut rest = Vec::new();
        r.read_to_end(&mut rest).unwrap();
        assert_eq!(c.load(Ordering::Relaxed), 12);
        // Not a terminal under the test harness: no thread, and finishing is immediate.
        let p = Progress::start("x", Some(12), c);
        assert!(p.thread.is_none() || std::io::stderr().is_terminal());
        p.finish();
    }
}
