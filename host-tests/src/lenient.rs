//! `replay --skip-bad-rows`: pass over malformed rows instead of stopping at the first one,
//! counting them and keeping the first few line numbers for the report.

use std::sync::{Arc, Mutex, PoisonError};

use crate::replay::RowSource;
use crate::trace::{TraceError, TraceRow};

/// Line numbers kept for the report.
pub const FIRST_LINES: usize = 5;

/// The malformed rows passed over.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Skipped {
    /// How many.
    pub count: u64,
    /// The first [`FIRST_LINES`] line numbers (1-based).
    pub first_lines: Vec<usize>,
    /// The first one's error, as the strict replay would have reported it.
    pub first_error: Option<String>,
}

impl Skipped {
    /// The report line, `None` when nothing was skipped: `skipped 3 malformed rows (lines 5,
    /// 9, 12; first: line 5: column "gx": ...)`.
    pub fn report(&self) -> Option<String> {
        if self.count == 0 {
            return None;
        }
        let lines: Vec<String> = self.first_lines.iter().map(usize::to_string).collect();
        let more = if self.count as usize > self.first_lines.len() { ", ..." } else { "" };
        Some(format!(
            "skipped {} malformed row{} (line{} {}{more}; first: {})",
            self.count,
            if self.count == 1 { "" } else { "s" },
            if self.first_lines.len() == 1 { "" } else { "s" },
            lines.join(", "),
            self.first_error.as_deref().unwrap_or("")
        ))
    }
}

/// A [`RowSource`] that skips rows with an error about their line (cells, numbers, time
/// order); errors of the input itself (reading, the header) still stop it. The record is
/// shared ([`SkipBadRows::skipped`]), so it can be read after the source moved into a replay.
pub struct SkipBadRows<S> {
    inner: S,
    skipped: Arc<Mutex<Skipped>>,
}

impl<S: RowSource> SkipBadRows<S> {
    /// Wrap `inner`.
    pub fn new(inner: S) -> Self {
        SkipBadRows { inner, skipped: Arc::default() }
    }

    /// The record of skipped rows (shared with this source).
    pub fn skipped(&self) -> Arc<Mutex<Skipped>> {
        Arc::clone(&self.skipped)
    }
}

impl<S: RowSource> RowSource for SkipBadRows<S> {
    fn next_row(&mut self) -> Result<Option<TraceRow>, TraceError> {
        let mut last_line = None;
        loop {
            match self.inner.next_row() {
                Err(e) => {
                    let Some(line) = e.line() else { return Err(e) };
                    // The reader moves past a bad line; the same line twice would mean it
                    // did not, so stop rather than loop.
                    if last_line == Some(line) {
                        return Err(e);
                    }
                    last_line = Some(line);
                    let mut s = self.skipped.lock().unwrap_or_else(PoisonError::into_inner);
                    s.count += 1;
                    if s.first_lines.len() < FIRST_LINES {
                        s.first_lines.push(line);
                    }
                    if s.first_error.is_none() {
                        s.first_error = Some(e.to_string());
                    }
                }
                ok => return ok,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::TraceReader;

    #[test]
    fn bad_rows_are_counted_and_the_good_ones_kept() {
        let text =
            "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,-9.8\n0.1,0,x,0,0,0,-9.8\n0.2,0,0,0,0,0,-9.8\n\
                    0.2,0,0,0,0,0,-9.8\n0.3,0,0,0\n0.4,0,0,0,0,0,-9.8\n0.5,0,0,0,0,0";
        let mut s = SkipBadRows::new(TraceReader::new(text.as_bytes()).unwrap());
        let mut t = Vec::new();
        while let Some(r) = s.next_row().unwrap() {
            t.push(r.t);
        }
        assert_eq!(t, [0.0, 0.2, 0.4]);
        let k = s.skipped().lock().unwrap().clone();
        assert_eq!(k.count, 4);
        assert_eq!(k.first_lines, [3, 5, 6, 8]);
        let r = k.report().unwrap();
        assert!(r.starts_with("skipped 4 malformed rows (lines 3, 5, 6, 8; first: line 3"), "{r}");
        // The strict reader stops at the first.
        let mut strict = TraceReader::new(text.as_bytes()).unwrap();
        assert!(strict.next_row().is_ok());
        assert_eq!(strict.next_row().unwrap_err().line(), Some(3));
    }
}
