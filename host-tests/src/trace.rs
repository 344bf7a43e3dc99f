//! The trace CSV format of `shared/trace-format.md`: reading and writing input traces and
//! estimate files.
//!
//! Reading rules:
//! - the first line that is neither empty nor a comment is the header; columns are found by
//!   name (surrounding spaces ignored; a UTF-8 byte-order mark before the first name is not
//!   part of it), in any order; unknown columns are ignored; a column name may not appear
//!   twice;
//! - required columns: `t` (s, strictly increasing), `gx,gy,gz` (rad/s), `ax,ay,az` (m/s²,
//!   specific force); optional: `mx,my,mz` (µT, all three or none), `depth` (m),
//!   `qw,qx,qy,qz` (truth, all four or none; a row whose four truth cells read `nan` has no
//!   truth, as an optical system that lost the sensor writes it); `movement` (`0` or `1`:
//!   BROAD's rest and scored motion phases, [`TraceRow::scored`]);
//! - empty lines and lines whose first non-blank character is `#` are comments, anywhere
//!   (the `# ...` lines that `host-tests simulate` and `ahrs-tool log` write about the
//!   recording);
//! - every data line has exactly as many cells as the header; cells are split at every `,`
//!   (no quoting) and may be padded with spaces or tabs; `\r\n` line ends are accepted; a line
//!   must be valid UTF-8;
//! - numbers are read by the standard library (`str::parse::<f64>` for `t`, `::<f32>` for the
//!   rest: decimal, exponent, `NaN` and `inf` forms, correctly rounded); required cells must be
//!   finite — NaN, infinities and values beyond the `f32` range (`1e300`, which parses to
//!   infinity) are rejected. Optional cells may be empty (no sample on that row, e.g. a
//!   magnetometer at a lower rate) but a group (`mx,my,mz` or `qw..qz`) is all empty or all
//!   numbers.
//!
//! Every error is a [`TraceError`] naming the 1-based line number and, where one is at fault,
//! the column; after an error about a data line the reader can go on with the next line
//! (`replay --skip-bad-rows`, `crate::lenient`).
//!
//! Input traces are written with shortest round-trip formatting (the `ryu` crate: the same
//! digits as Rust's `{}`, with an exponent for very small or large values), so an `f32`
//! written and read back is bit-identical; `t` is kept as `f64`. NaN or infinite values are
//! written as `NaN`/`inf` (the reader rejects them). Estimate files keep `t` as it reads back
//! exactly and write the estimate in fixed point (quaternion 8 decimals, Euler angles 5, bias
//! 6: finer than the `f32` estimate's own precision), rounded exactly, half away from zero;
//! NaN or infinite values there are empty cells. See [`EstimateWriter`].
//!
//! The reader is plain on purpose (issue #14): one line at a time with `BufRead::read_until`,
//! split at commas, numbers by `str::parse`. An hour at 50 Hz (180 000 rows) replays in about a
//! tenth of a second; `cargo bench -p host-tests --bench replay_speed` measures each stage.

use std::fmt;
use std::io::{self, BufRead, Write};

/// One row of an input trace, units as in the file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceRow {
    /// Time, s.
    pub t: f64,
    /// Angular rate, rad/s, gyro axes (body FRD for simulated traces).
    pub gyro: [f32; 3],
    /// Specific force, m/s², accelerometer axes (body FRD for simulated traces).
    pub accel: [f32; 3],
    /// Magnetic field, µT, when the row has one.
    pub mag: Option<[f32; 3]>,
    /// Depth, m, positive down, when the row has one.
    pub depth: Option<f32>,
    /// Ground-truth attitude `(qw, qx, qy, qz)`, body FRD → NED, when the row has one (an
    /// optical system that lost the sensor writes `nan` or nothing: `None`).
    pub truth: Option<[f32; 4]>,
    /// The `movement` column when the trace has one (BROAD: `1` in the scored motion phase,
    /// `0` in the rest phases around it); `None` without the column.
    pub movement: Option<bool>,
}

impl TraceRow {
    /// True when the benchmarks score this row: it has truth, and it is in the motion phase
    /// if the trace marks one (`shared/data/broad/README.md`).
    pub fn scored(&self) -> bool {
        self.truth.is_some() && self.movement != Some(false)
    }
}

/// Why a trace or estimate file could not be read.
#[derive(Debug)]
pub enum TraceError {
    /// Reading failed.
    Io(io::Error),
    /// A line is longer than [`MAX_LINE_BYTES`] (no trace line is: a row of every column is a
    /// few hundred bytes); read no further, so memory stays bounded on any input.
    LineTooLong {
        /// 1-based line number.
        line: usize,
    },
    /// No header line (the file is empty or only has comments).
    NoHeader,
    /// A line is not valid UTF-8.
    InvalidUtf8 {
        /// 1-based line number.
        line: usize,
    },
    /// A required column (or a member of an optional group that is partly present) is missing
    /// from the header.
    MissingColumn {
        /// 1-based line number of the header.
        line: usize,
        /// The missing column.
        column: String,
    },
    /// A column name appears twice in the header.
    DuplicateColumn {
        /// 1-based line number of the header.
        line: usize,
        /// The repeated column.
        column: String,
    },
    /// A data line does not have as many cells as the header.
    CellCount {
        /// 1-based line number.
        line: usize,
        /// Cells in the header.
        expected: usize,
        /// Cells on this line.
        found: usize,
        /// First header column without a cell (too few cells), or `None` (too many).
        column: Option<String>,
    },
    /// A cell is not a number (or is empty where a number is required).
    NotANumber {
        /// 1-based line number.
        line: usize,
        /// Column of the cell.
        column: String,
        /// The cell's text.
        text: String,
    },
    /// A cell is NaN or infinite.
    NotFinite {
        /// 1-based line number.
        line: usize,
        /// Column of the cell.
        column: String,
        /// The cell's text.
        text: String,
    },
    /// An optional group (`mx,my,mz` or `qw,qx,qy,qz`) is only partly filled on a line.
    PartialGroup {
        /// 1-based line number.
        line: usize,
        /// The empty column of the group.
        column: String,
    },
    /// A `movement` cell is not `0`, `1` or empty.
    BadMovement {
        /// 1-based line number.
        line: usize,
        /// The cell's text.
        text: String,
    },
    /// `t` is not strictly greater than on the previous data line.
    TimeNotIncreasing {
        /// 1-based line number.
        line: usize,
        /// This line's time, s.
        t: f64,
        /// The previous data line's time, s.
        previous: f64,
    },
}

/// The longest line a trace, estimate or settings file may have, bytes (with its line break).
pub const MAX_LINE_BYTES: usize = 64 * 1024;

/// One line into `buf` (appended, line break included), reading at most [`MAX_LINE_BYTES`] +
/// 1 bytes: `Ok(None)` at the end of the input, `Ok(Some(false))` for a line over the limit
/// (the rest of it is not read), `Ok(Some(true))` otherwise.
pub fn read_line_bounded<R: BufRead>(r: &mut R, buf: &mut Vec<u8>) -> io::Result<Option<bool>> {
    let n = io::Read::take(r, MAX_LINE_BYTES as u64 + 1).read_until(b'\n', buf)?;
    Ok(match n {
        0 => None,
        n => Some(n <= MAX_LINE_BYTES),
    })
}

impl TraceError {
    /// The 1-based line the error is on, when it is about a line.
    pub fn line(&self) -> Option<usize> {
        match self {
            TraceError::Io(_) | TraceError::NoHeader => None,
            TraceError::InvalidUtf8 { line }
            | TraceError::LineTooLong { line }
            | TraceError::MissingColumn { line, .. }
            | TraceError::DuplicateColumn { line, .. }
            | TraceError::CellCount { line, .. }
            | TraceError::NotANumber { line, .. }
            | TraceError::NotFinite { line, .. }
            | TraceError::PartialGroup { line, .. }
            | TraceError::BadMovement { line, .. }
            | TraceError::TimeNotIncreasing { line, .. } => Some(*line),
        }
    }

    /// The column the error is about, when there is one.
    pub fn column(&self) -> Option<&str> {
        match self {
            TraceError::MissingColumn { column, .. }
            | TraceError::DuplicateColumn { column, .. }
            | TraceError::NotANumber { column, .. }
            | TraceError::NotFinite { column, .. }
            | TraceError::PartialGroup { column, .. } => Some(column),
            TraceError::CellCount { column, .. } => column.as_deref(),
            TraceError::TimeNotIncreasing { .. } => Some("t"),
            TraceError::BadMovement { .. } => Some("movement"),
            _ => None,
        }
    }
}

impl fmt::Display for TraceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TraceError::Io(e) => write!(f, "read error: {e}"),
            TraceError::NoHeader => write!(f, "no header line (empty file?)"),
            TraceError::InvalidUtf8 { line } => write!(f, "line {line}: not valid UTF-8"),
            TraceError::LineTooLong { line } => write!(
                f,
                "line {line}: longer than {MAX_LINE_BYTES} bytes (a trace row is a few hundred): \
                 not a trace, or its line breaks are missing"
            ),
            TraceError::MissingColumn { line, column } => {
                write!(f, "line {line}, column '{column}': missing from the header")
            }
            TraceError::DuplicateColumn { line, column } => {
                write!(f, "line {line}, column '{column}': appears twice in the header")
            }
            TraceError::CellCount { line, expected, found, column: Some(c) } => write!(
                f,
                "line {line}, column '{c}': no cell ({found} cells, the header has {expected})"
            ),
            TraceError::CellCount { line, expected, found, column: None } => write!(
                f,
                "line {line}, column {}: extra cell ({found} cells, the header has {expected})",
                expected + 1
            ),
            TraceError::NotANumber { line, column, text } => {
                write!(f, "line {line}, column '{column}': not a number: {text:?}")
            }
            TraceError::NotFinite { line, column, text } => {
                write!(f, "line {line}, column '{column}': not finite or beyond the f32 range (±3.4e38): {text:?}")
            }
            TraceError::PartialGroup { line, column } => write!(
                f,
                "line {line}, column '{column}': empty while other cells of its group are set"
            ),
            TraceError::BadMovement { line, text } => write!(
                f,
                "line {line}, column 'movement': {text:?} is not 0 (rest phase) or 1 (scored motion)"
            ),
            TraceError::TimeNotIncreasing { line, t, previous } => write!(
                f,
                "line {line}, column 't': time {t} is not after the previous row's {previous}"
            ),
        }
    }
}

impl std::error::Error for TraceError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            TraceError::Io(e) => Some(e),
            _ => None,
        }
    }
}

impl From<io::Error> for TraceError {
    fn from(e: io::Error) -> Self {
        TraceError::Io(e)
    }
}

/// Low-level reader: header by name, comment skipping and cell splitting, without allocating
/// per cell. [`TraceReader`] and [`EstimateReader`] are built on it.
pub struct CsvReader<R> {
    reader: R,
    buf: Vec<u8>,
    line: usize,
    header: Vec<String>,
    header_line: usize,
    /// `(start, end)` byte ranges of the current record's cells in `buf`, trimmed.
    cells: Vec<(usize, usize)>,
}

fn trim_range(buf: &[u8], mut s: usize, mut e: usize) -> (usize, usize) {
    while s < e && matches!(buf[s], b' ' | b'\t' | b'\r') {
        s += 1;
    }
    while e > s && matches!(buf[e - 1], b' ' | b'\t' | b'\r' | b'\n') {
        e -= 1;
    }
    (s, e)
}

impl<R: BufRead> CsvReader<R> {
    /// Read the header (skipping leading comments and empty lines).
    pub fn new(reader: R) -> Result<Self, TraceError> {
        let mut r = CsvReader {
            reader,
            buf: Vec::with_capacity(256),
            line: 0,
            header: Vec::new(),
            header_line: 0,
            cells: Vec::with_capacity(32),
        };
        if !r.next_content_line()? {
            return Err(TraceError::NoHeader);
        }
        let text = std::str::from_utf8(&r.buf)
            .map_err(|_| TraceError::InvalidUtf8 { line: r.line })?
            .to_owned();
        r.header_line = r.line;
        for (k, (s, e)) in r.cells.iter().enumerate() {
            // A UTF-8 byte-order mark before the first name (Excel's "CSV UTF-8") is not part
            // of it.
            let cell = &text[*s..*e];
            let cell = if k == 0 { cell.trim_start_matches('\u{feff}').trim_start() } else { cell };
            let name = cell.to_owned();
            if r.header.contains(&name) {
                return Err(TraceError::DuplicateColumn { line: r.line, column: name });
            }
            r.header.push(name);
        }
        Ok(r)
    }

    /// The header's column names, in file order.
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// 1-based line number of the header.
    pub fn header_line(&self) -> usize {
        self.header_line
    }

    /// Index of a column, if present.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// Index of a required column, or the `MissingColumn` error naming it.
    pub fn require(&self, name: &str) -> Result<usize, TraceError> {
        self.index_of(name).ok_or_else(|| TraceError::MissingColumn {
            line: self.header_line,
            column: name.into(),
        })
    }

    /// Indices of a group of columns that must be all present or all absent.
    pub fn group<const N: usize>(
        &self,
        names: [&str; N],
    ) -> Result<Option<[usize; N]>, TraceError> {
        let found = names.map(|n| self.index_of(n));
        if found.iter().all(Option::is_none) {
            return Ok(None);
        }
        let mut out = [0; N];
        for (i, f) in found.iter().enumerate() {
            out[i] = f.ok_or_else(|| TraceError::MissingColumn {
                line: self.header_line,
                column: names[i].into(),
            })?;
        }
        Ok(Some(out))
    }

    /// Read the next non-comment line into `buf` and split it into `cells`. False at the end.
    fn next_content_line(&mut self) -> Result<bool, TraceError> {
        loop {
            self.buf.clear();
            let Some(whole) = read_line_bounded(&mut self.reader, &mut self.buf)? else {
                return Ok(false);
            };
            self.line += 1;
            if !whole {
                return Err(TraceError::LineTooLong { line: self.line });
            }
            let (s, e) = trim_range(&self.buf, 0, self.buf.len());
            if s == e || self.buf[s] == b'#' {
                continue;
            }
            self.cells.clear();
            let end = e;
            let mut start = 0;
            let buf = &self.buf[..end];
            while let Some(p) = buf[start..].iter().position(|&b| b == b',') {
                self.cells.push(trim_range(buf, start, start + p));
                start += p + 1;
            }
            self.cells.push(trim_range(buf, start, end));
            return Ok(true);
        }
    }

    /// Advance to the next data record. `Ok(None)` at the end of the input.
    pub fn next_record(&mut self) -> Result<Option<Record<'_>>, TraceError> {
        if !self.next_content_line()? {
            return Ok(None);
        }
        let n = self.header.len();
        if self.cells.len() != n {
            let column = if self.cells.len() < n {
                Some(self.header[self.cells.len()].clone())
            } else {
                None
            };
            return Err(TraceError::CellCount {
                line: self.line,
                expected: n,
                found: self.cells.len(),
                column,
            });
        }
        let text = std::str::from_utf8(&self.buf)
            .map_err(|_| TraceError::InvalidUtf8 { line: self.line })?;
        Ok(Some(Record { text, cells: &self.cells, header: &self.header, line: self.line }))
    }
}

/// One data line of a [`CsvReader`].
pub struct Record<'a> {
    text: &'a str,
    cells: &'a [(usize, usize)],
    header: &'a [String],
    line: usize,
}

impl Record<'_> {
    /// 1-based line number.
    pub fn line(&self) -> usize {
        self.line
    }

    /// Text of cell `i`, trimmed.
    pub fn text(&self, i: usize) -> &str {
        let (s, e) = self.cells[i];
        &self.text[s..e]
    }

    /// Cell `i` by `str::parse`: a finite number, else `NotFinite` (NaN, infinities, values
    /// beyond the type's range, which parse to infinities) or `NotANumber`.
    fn parse<T: std::str::FromStr + Copy + Into<f64>>(&self, i: usize) -> Result<T, TraceError> {
        let text = self.text(i);
        let (line, column) = (self.line, || self.header[i].clone());
        match text.parse::<T>() {
            Ok(v) if v.into().is_finite() => Ok(v),
            Ok(_) => Err(TraceError::NotFinite { line, column: column(), text: text.into() }),
            Err(_) => Err(TraceError::NotANumber { line, column: column(), text: text.into() }),
        }
    }

    /// Cell `i` as a finite `f32`.
    pub fn f32(&self, i: usize) -> Result<f32, TraceError> {
        self.parse::<f32>(i)
    }

    /// Cell `i` as a finite `f64`.
    pub fn f64(&self, i: usize) -> Result<f64, TraceError> {
        self.parse::<f64>(i)
    }

    /// True if cell `i` is empty.
    pub fn is_empty(&self, i: usize) -> bool {
        let (s, e) = self.cells[i];
        s == e
    }

    /// True if cell `i` reads `nan` (any case, as `str::parse` takes it): a value the
    /// recording did not have.
    pub fn is_nan(&self, i: usize) -> bool {
        self.text(i).eq_ignore_ascii_case("nan")
    }

    /// An optional group of cells: all empty → `None`, all finite numbers → `Some`.
    pub fn group<const N: usize>(&self, idx: &[usize; N]) -> Result<Option<[f32; N]>, TraceError> {
        let empty = idx.iter().filter(|&&i| self.is_empty(i)).count();
        if empty == N {
            return Ok(None);
        }
        if empty > 0 {
            let i = *idx.iter().find(|&&i| self.is_empty(i)).unwrap_or(&idx[0]);
            return Err(TraceError::PartialGroup {
                line: self.line,
                column: self.header[i].clone(),
            });
        }
        let mut out = [0.0; N];
        for (o, &i) in out.iter_mut().zip(idx) {
            *o = self.f32(i)?;
        }
        Ok(Some(out))
    }
}

/// Which optional columns a trace has.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraceColumns {
    /// `mx,my,mz` present.
    pub mag: bool,
    /// `depth` present.
    pub depth: bool,
    /// `qw,qx,qy,qz` present.
    pub truth: bool,
}

/// Streaming reader of input traces.
pub struct TraceReader<R> {
    csv: CsvReader<R>,
    t: usize,
    gyro: [usize; 3],
    accel: [usize; 3],
    mag: Option<[usize; 3]>,
    depth: Option<usize>,
    truth: Option<[usize; 4]>,
    movement: Option<usize>,
    prev_t: Option<f64>,
}

impl<R: BufRead> TraceReader<R> {
    /// Read and check the header.
    pub fn new(reader: R) -> Result<Self, TraceError> {
        let csv = CsvReader::new(reader)?;
        let t = csv.require("t")?;
        let gyro = [csv.require("gx")?, csv.require("gy")?, csv.require("gz")?];
        let accel = [csv.require("ax")?, csv.require("ay")?, csv.require("az")?];
        let mag = csv.group(["mx", "my", "mz"])?;
        let depth = csv.index_of("depth");
        let truth = csv.group(["qw", "qx", "qy", "qz"])?;
        let movement = csv.index_of("movement");
        Ok(TraceReader { csv, t, gyro, accel, mag, depth, truth, movement, prev_t: None })
    }

    /// The optional columns present in the header.
    pub fn columns(&self) -> TraceColumns {
        TraceColumns {
            mag: self.mag.is_some(),
            depth: self.depth.is_some(),
            truth: self.truth.is_some(),
        }
    }

    /// The next row, `Ok(None)` at the end.
    pub fn next_row(&mut self) -> Result<Option<TraceRow>, TraceError> {
        let Some(rec) = self.csv.next_record()? else {
            return Ok(None);
        };
        let t = rec.f64(self.t)?;
        if let Some(prev) = self.prev_t {
            if t <= prev {
                return Err(TraceError::TimeNotIncreasing { line: rec.line(), t, previous: prev });
            }
        }
        let gyro = [rec.f32(self.gyro[0])?, rec.f32(self.gyro[1])?, rec.f32(self.gyro[2])?];
        let accel = [rec.f32(self.accel[0])?, rec.f32(self.accel[1])?, rec.f32(self.accel[2])?];
        let mag = match &self.mag {
            Some(idx) => rec.group(idx)?,
            None => None,
        };
        let depth = match self.depth {
            Some(i) if !rec.is_empty(i) => Some(rec.f32(i)?),
            _ => None,
        };
        let truth = match &self.truth {
            // Truth lost (every cell `nan`): the row has none, as if its cells were empty.
            Some(idx) if idx.iter().all(|&i| rec.is_nan(i)) => None,
            Some(idx) => rec.group(idx)?,
            None => None,
        };
        let movement = match self.movement {
            Some(i) => match rec.text(i) {
                "0" => Some(false),
                "1" => Some(true),
                "" => None,
                text => {
                    return Err(TraceError::BadMovement { line: rec.line(), text: text.into() })
                }
            },
            None => None,
        };
        self.prev_t = Some(t);
        Ok(Some(TraceRow { t, gyro, accel, mag, depth, truth, movement }))
    }
}

impl<R: BufRead> Iterator for TraceReader<R> {
    type Item = Result<TraceRow, TraceError>;
    fn next(&mut self) -> Option<Self::Item> {
        self.next_row().transpose()
    }
}

/// Read a whole trace from a file.
pub fn read_trace_file(
    path: &std::path::Path,
) -> Result<(TraceColumns, Vec<TraceRow>), TraceError> {
    let f = std::fs::File::open(path)?;
    let mut r = TraceReader::new(io::BufReader::with_capacity(1 << 16, f))?;
    let cols = r.columns();
    let mut rows = Vec::new();
    while let Some(row) = r.next_row()? {
        rows.push(row);
    }
    Ok((cols, rows))
}

/// Output is assembled in the writer's own buffer and handed to the inner writer in blocks of
/// about this many bytes (a block at least as large as a `BufWriter`'s 64 KiB buffer bypasses
/// it, so bytes are copied once).
const OUT_BLOCK: usize = 64 * 1024;

/// One output line being appended to a writer's buffer: shortest round-trip float formatting
/// (`ryu`: `0.02`, `1.0`, `-9.80665`, `1.6284444e-12`).
struct Line<'a> {
    buf: &'a mut Vec<u8>,
    fb: ryu::Buffer,
    first: bool,
}

impl<'a> Line<'a> {
    fn new(buf: &'a mut Vec<u8>) -> Self {
        Line { buf, fb: ryu::Buffer::new(), first: true }
    }

    fn sep(&mut self) {
        if !self.first {
            self.buf.push(b',');
        }
        self.first = false;
    }

    fn f64(&mut self, v: f64) {
        self.sep();
        let s = if v.is_finite() { self.fb.format_finite(v) } else { self.fb.format(v) };
        self.buf.extend_from_slice(s.as_bytes());
    }

    fn f32s(&mut self, vs: &[f32]) {
        for &v in vs {
            self.sep();
            let s = if v.is_finite() { self.fb.format_finite(v) } else { self.fb.format(v) };
            self.buf.extend_from_slice(s.as_bytes());
        }
    }

    fn empty(&mut self, n: usize) {
        for _ in 0..n {
            self.sep();
        }
    }

    /// End the line; hand the buffer to `w` once it holds a block.
    fn finish<W: Write>(self, w: &mut W) -> io::Result<()> {
        self.buf.push(b'\n');
        if self.buf.len() >= OUT_BLOCK {
            w.write_all(self.buf)?;
            self.buf.clear();
        }
        Ok(())
    }
}

/// Writer of input traces. Output is buffered in blocks: end with [`TraceWriter::finish`].
pub struct TraceWriter<W: Write> {
    w: W,
    cols: TraceColumns,
    buf: Vec<u8>,
}

impl<W: Write> TraceWriter<W> {
    /// Write the header: `t,gx,gy,gz,ax,ay,az`, then `mx,my,mz`, `depth`, `qw,qx,qy,qz` as
    /// selected.
    pub fn new(mut w: W, cols: TraceColumns) -> io::Result<Self> {
        w.write_all(b"t,gx,gy,gz,ax,ay,az")?;
        if cols.mag {
            w.write_all(b",mx,my,mz")?;
        }
        if cols.depth {
            w.write_all(b",depth")?;
        }
        if cols.truth {
            w.write_all(b",qw,qx,qy,qz")?;
        }
        w.write_all(b"\n")?;
        Ok(TraceWriter { w, cols, buf: Vec::with_capacity(OUT_BLOCK + 512) })
    }

    /// A `# ` comment line (newlines in `text` are replaced by spaces).
    pub fn comment(&mut self, text: &str) -> io::Result<()> {
        self.buf.extend_from_slice(b"# ");
        self.buf.extend_from_slice(text.replace(['\n', '\r'], " ").as_bytes());
        self.buf.push(b'\n');
        Ok(())
    }

    /// One row. Optional columns missing from `row` are written as empty cells.
    pub fn row(&mut self, row: &TraceRow) -> io::Result<()> {
        let mut line = Line::new(&mut self.buf);
        line.f64(row.t);
        line.f32s(&row.gyro);
        line.f32s(&row.accel);
        if self.cols.mag {
            match &row.mag {
                Some(m) => line.f32s(m),
                None => line.empty(3),
            }
        }
        if self.cols.depth {
            match row.depth {
                Some(d) => line.f32s(&[d]),
                None => line.empty(1),
            }
        }
        if self.cols.truth {
            match &row.truth {
                Some(q) => line.f32s(q),
                None => line.empty(4),
            }
        }
        line.finish(&mut self.w)
    }

    /// Write what is buffered and flush the inner writer (a log's rows reach the disk as they
    /// come).
    pub fn flush(&mut self) -> io::Result<()> {
        self.w.write_all(&self.buf)?;
        self.buf.clear();
        self.w.flush()
    }

    /// Write what is buffered, flush and return the inner writer. Rows are buffered: without
    /// this call the last rows are lost.
    pub fn finish(mut self) -> io::Result<W> {
        self.w.write_all(&self.buf)?;
        self.buf.clear();
        self.w.flush()?;
        Ok(self.w)
    }
}

/// One row of an estimate file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimateRow {
    /// Time, s (the input row's).
    pub t: f64,
    /// Attitude `(qw, qx, qy, qz)`, body FRD → NED.
    pub q: [f32; 4],
    /// Z-Y-X Euler angles `(roll, pitch, yaw)`, degrees.
    pub euler_deg: [f32; 3],
    /// Estimated gyro bias, °/s, body FRD (`NaN` when the file has no bias columns).
    pub bias_dps: [f32; 3],
    /// The filter's flags (`ekf_core::Flags` bits; 0 when the file has none).
    pub flags: u16,
}

/// Header of the estimate files this crate writes.
pub const ESTIMATE_HEADER: &str = "t,qw,qx,qy,qz,roll,pitch,yaw,bias_x,bias_y,bias_z,flags";

/// Decimals of the quaternion components in estimate files (1e-8: below an `f32`'s spacing
/// near 1, 6e-8).
pub const Q_DECIMALS: usize = 8;
/// Decimals of the Euler angles (degrees) in estimate files (1e-5°: an `f32`'s spacing near
/// 180° is 1.5e-5°).
pub const EULER_DECIMALS: usize = 5;
/// Decimals of the gyro bias (°/s) in estimate files.
pub const BIAS_DECIMALS: usize = 6;

/// Writer of estimate files: `t,qw,qx,qy,qz,roll,pitch,yaw` (Euler in degrees), then
/// `bias_x,bias_y,bias_z` (°/s) and `flags` (the `ekf_core::Flags` bits as an integer).
///
/// `t` is written so that it reads back as the same `f64` (the input's value back): with at
/// most 9 decimals when that text reads back exactly (`0.02`, `1`), else shortest round trip
/// (`0.0`, `1e-10`). The other numbers in fixed point, [`Q_DECIMALS`], [`EULER_DECIMALS`] and
/// [`BIAS_DECIMALS`] decimals at most, rounded exactly (half away from zero), trailing zeros
/// dropped (`1`, `0.5`, `-0.00012`), a value that rounds to zero as `0`, `|v| ≥ 1e9` shortest
/// round trip; NaN or infinite values are written as empty cells.
/// Output is buffered in blocks: end with [`EstimateWriter::finish`].
pub struct EstimateWriter<W: Write> {
    w: W,
    buf: Vec<u8>,
    fb: ryu::Buffer,
}

impl<W: Write> EstimateWriter<W> {
    /// Write the header.
    pub fn new(mut w: W) -> io::Result<Self> {
        writeln!(w, "{ESTIMATE_HEADER}")?;
        Ok(EstimateWriter { w, buf: Vec::with_capacity(OUT_BLOCK + 512), fb: ryu::Buffer::new() })
    }

    /// One row.
    pub fn row(&mut self, r: &EstimateRow) -> io::Result<()> {
        let (buf, fb) = (&mut self.buf, &mut self.fb);
        push_time(buf, fb, r.t);
        for (values, decimals) in [
            (&r.q[..], Q_DECIMALS),
            (&r.euler_deg[..], EULER_DECIMALS),
            (&r.bias_dps[..], BIAS_DECIMALS),
        ] {
            for &v in values {
                buf.push(b',');
                push_fixed(buf, fb, v, decimals);
            }
        }
        buf.push(b',');
        push_uint(buf, r.flags.into(), 1);
        buf.push(b'\n');
        if buf.len() >= OUT_BLOCK {
            self.w.write_all(buf)?;
            buf.clear();
        }
        Ok(())
    }

    /// Write what is buffered, flush and return the inner writer. Rows are buffered: without
    /// this call the last rows are lost.
    pub fn finish(mut self) -> io::Result<W> {
        self.w.write_all(&self.buf)?;
        self.buf.clear();
        self.w.flush()?;
        Ok(self.w)
    }
}

/// `n` in decimal, with leading zeros up to `width` digits.
fn push_uint(buf: &mut Vec<u8>, mut n: u64, width: usize) {
    let mut digits = [b'0'; 20];
    let mut i = digits.len();
    while n > 0 || digits.len() - i < width {
        i -= 1;
        digits[i] = b'0' + (n % 10) as u8;
        n /= 10;
    }
    buf.extend_from_slice(&digits[i..]);
}

/// `±n·10^-decimals` (`n > 0`): the integer part, then the fraction without its trailing zeros
/// (none, and no `.`, when it is zero).
fn push_decimal(buf: &mut Vec<u8>, neg: bool, n: u64, decimals: usize) {
    let unit = 10u64.pow(decimals as u32);
    let (int, mut frac, mut width) = (n / unit, n % unit, decimals);
    if neg {
        buf.push(b'-');
    }
    push_uint(buf, int, 1);
    if frac != 0 {
        while frac % 10 == 0 {
            frac /= 10;
            width -= 1;
        }
        buf.push(b'.');
        push_uint(buf, frac, width);
    }
}

/// `v` with at most `decimals ≤ 8` decimals, rounded exactly, half away from zero, trailing
/// zeros dropped (`1`, `0.5`, `-0.00012`); a value that rounds to zero is `0`, NaN or infinite
/// values are nothing (an empty cell), `|v| ≥ 1e9` is written shortest round trip (`ryu`).
///
/// The rounding is exact because `|v|·10^decimals` is computed exactly: `|v| = m·2^e` with an
/// integer `m < 2^24` and `10^d = 5^d·2^d` with `5^8 < 2^19`, so the product `m·5^d·2^(e+d)`
/// has a significand below 2^43 and is an `f64`; `f64::round` then rounds it half away from
/// zero.
fn push_fixed(buf: &mut Vec<u8>, fb: &mut ryu::Buffer, v: f32, decimals: usize) {
    debug_assert!(decimals <= 8);
    if !v.is_finite() {
        return;
    }
    if v.abs() >= 1e9 {
        buf.extend_from_slice(fb.format_finite(v).as_bytes());
        return;
    }
    let n = (f64::from(v.abs()) * 10u32.pow(decimals as u32) as f64).round() as u64;
    if n == 0 {
        buf.push(b'0');
    } else {
        push_decimal(buf, v < 0.0, n, decimals);
    }
}

/// `t` (s) with at most 9 decimals, trailing zeros dropped, when that text reads back as
/// exactly `t` (for `|t| < 4·10⁶` s these are the digits of the shortest round trip, without
/// `ryu`'s `.0` or exponent); otherwise, and for `t = 0` or `|t| ≥ 4·10⁹` s, shortest round
/// trip (`ryu`: `0.0`, `1e-10`); nothing for NaN or infinities.
fn push_time(buf: &mut Vec<u8>, fb: &mut ryu::Buffer, t: f64) {
    let n = (t.abs() * 1e9).round();
    if n > 0.0 && t.abs() < 4e9 {
        let start = buf.len();
        push_decimal(buf, t < 0.0, n as u64, 9);
        let text = std::str::from_utf8(&buf[start..]).unwrap_or_default();
        if text.parse() == Ok(t) {
            return;
        }
        buf.truncate(start);
    }
    if t.is_finite() {
        buf.extend_from_slice(fb.format_finite(t).as_bytes());
    }
}

/// Streaming reader of estimate files (required `t,qw,qx,qy,qz,roll,pitch,yaw`; optional
/// `bias_x,bias_y,bias_z` and `flags`; other columns ignored).
pub struct EstimateReader<R> {
    csv: CsvReader<R>,
    idx: [usize; 8],
    bias: Option<[usize; 3]>,
    flags: Option<usize>,
}

impl<R: BufRead> EstimateReader<R> {
    /// Read and check the header.
    pub fn new(reader: R) -> Result<Self, TraceError> {
        let csv = CsvReader::new(reader)?;
        let mut idx = [0; 8];
        for (i, name) in ["t", "qw", "qx", "qy", "qz", "roll", "pitch", "yaw"].iter().enumerate() {
            idx[i] = csv.require(name)?;
        }
        let bias = csv.group(["bias_x", "bias_y", "bias_z"])?;
        let flags = csv.index_of("flags");
        Ok(EstimateReader { csv, idx, bias, flags })
    }

    /// The next row, `Ok(None)` at the end.
    pub fn next_row(&mut self) -> Result<Option<EstimateRow>, TraceError> {
        let Some(rec) = self.csv.next_record()? else {
            return Ok(None);
        };
        let i = &self.idx;
        let t = rec.f64(i[0])?;
        let q = [rec.f32(i[1])?, rec.f32(i[2])?, rec.f32(i[3])?, rec.f32(i[4])?];
        let euler_deg = [rec.f32(i[5])?, rec.f32(i[6])?, rec.f32(i[7])?];
        let bias_dps = match &self.bias {
            Some(b) => rec.group(b)?.unwrap_or([f32::NAN; 3]),
            None => [f32::NAN; 3],
        };
        let flags = match self.flags {
            Some(fi) if !rec.is_empty(fi) => {
                let text = rec.text(fi);
                text.parse::<u16>().map_err(|_| TraceError::NotANumber {
                    line: rec.line(),
                    column: "flags".into(),
                    text: text.into(),
                })?
            }
            _ => 0,
        };
        Ok(Some(EstimateRow { t, q, euler_deg, bias_dps, flags }))
    }
}

/// Read a whole estimate file.
pub fn read_estimate_file(path: &std::path::Path) -> Result<Vec<EstimateRow>, TraceError> {
    let f = std::fs::File::open(path)?;
    let mut r = EstimateReader::new(io::BufReader::with_capacity(1 << 16, f))?;
    let mut rows = Vec::new();
    while let Some(row) = r.next_row()? {
        rows.push(row);
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An endless line with no line break (a multi-gigabyte one as far as any reader can
    /// tell), counting the bytes it serves.
    struct Endless<'a> {
        served: &'a std::cell::Cell<u64>,
    }

    impl io::Read for Endless<'_> {
        fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
            out.fill(b'1');
            self.served.set(self.served.get() + out.len() as u64);
            Ok(out.len())
        }
    }

    /// Issue #39, point 3: a line with no end is refused with its line number after
    /// [`MAX_LINE_BYTES`], having read no more than that and one buffer: memory stays bounded
    /// (a 200 MB line took 1.2 GB before, and failed with "column '1.0' appears twice").
    #[test]
    fn an_endless_line_is_refused_after_the_limit() {
        let served = std::cell::Cell::new(0u64);
        let r = io::BufReader::new(Endless { served: &served });
        let e = TraceReader::new(r).err().expect("refused");
        assert!(matches!(e, TraceError::LineTooLong { line: 1 }), "{e}");
        assert!(e.to_string().starts_with("line 1: longer than 65536 bytes"), "{e}");
        assert!(served.get() <= (MAX_LINE_BYTES + 2 * 8192) as u64, "{} bytes read", served.get());
        // After a header, on the data line.
        let served = std::cell::Cell::new(0u64);
        let head = io::Read::chain(
            &b"t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,-9.8\n"[..],
            Endless { served: &served },
        );
        let mut r = TraceReader::new(io::BufReader::new(head)).unwrap();
        assert!(r.next_row().unwrap().is_some());
        let e = r.next_row().expect_err("refused");
        assert!(matches!(e, TraceError::LineTooLong { line: 3 }), "{e}");
        assert!(served.get() <= (MAX_LINE_BYTES + 2 * 8192) as u64, "{} bytes read", served.get());
    }

    /// A line of exactly the limit, its line break included, is read; one byte more is not.
    #[test]
    fn the_line_limit_is_exact() {
        let mut buf = Vec::new();
        let mut line = vec![b'1'; MAX_LINE_BYTES - 1];
        line.push(b'\n');
        assert_eq!(read_line_bounded(&mut &line[..], &mut buf).unwrap(), Some(true));
        assert_eq!(buf.len(), MAX_LINE_BYTES);
        let mut longer = vec![b'1'; MAX_LINE_BYTES];
        longer.push(b'\n');
        buf.clear();
        assert_eq!(read_line_bounded(&mut &longer[..], &mut buf).unwrap(), Some(false));
        // The last line of a file needs no line break.
        buf.clear();
        assert_eq!(read_line_bounded(&mut &b"1,2"[..], &mut buf).unwrap(), Some(true));
        buf.clear();
        assert_eq!(read_line_bounded(&mut &b""[..], &mut buf).unwrap(), None);
    }

    fn read(text: &str) -> Result<Vec<TraceRow>, TraceError> {
        TraceReader::new(text.as_bytes())?.collect()
    }

    #[test]
    fn columns_in_any_order_unknown_ignored_comments_skipped() {
        let text = "# leading comment\n\n az , ay,ax,gz,gy,gx,extra,t\n\
                    -9.8,0.5,0.25,3,2,1,zzz,0\n# mid\n\n-9.7,0,0,0,0,0,,0.02\r\n";
        let rows = read(text).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[0].gyro, [1.0, 2.0, 3.0]);
        assert_eq!(rows[0].accel, [0.25, 0.5, -9.8]);
        assert_eq!(rows[1].t, 0.02);
        assert_eq!(rows[1].mag, None);
        assert_eq!(rows[1].truth, None);
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = read("t,gx,gy,gz,ax,ay\n0,0,0,0,0,0\n").unwrap_err();
        assert!(matches!(&e, TraceError::MissingColumn { line: 1, column } if column == "az"));
        assert!(e.to_string().contains("line 1") && e.to_string().contains("'az'"));

        let e = read("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,0\n0.1,0,x,0,0,0,0\n").unwrap_err();
        assert!(matches!(&e, TraceError::NotANumber { line: 3, column, .. } if column == "gy"));

        let e = read("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,NaN\n").unwrap_err();
        assert!(matches!(&e, TraceError::NotFinite { line: 2, column, .. } if column == "az"));
        let e = read("t,gx,gy,gz,ax,ay,az\n0,inf,0,0,0,0,0\n").unwrap_err();
        assert!(matches!(&e, TraceError::NotFinite { line: 2, column, .. } if column == "gx"));

        let e = read("t,gx,gy,gz,ax,ay,az\n#c\n1,0,0,0,0,0,0\n1,0,0,0,0,0,0\n").unwrap_err();
        assert!(matches!(e, TraceError::TimeNotIncreasing { line: 4, .. }));
        assert_eq!(e.column(), Some("t"));

        let e = read("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0\n").unwrap_err();
        assert!(matches!(&e, TraceError::CellCount { line: 2, expected: 7, found: 6, .. }));
        assert_eq!(e.column(), Some("az"));
        let e = read("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,0,0\n").unwrap_err();
        assert!(matches!(e, TraceError::CellCount { line: 2, found: 8, column: None, .. }));

        let e = read("t,gx,gy,gz,ax,ay,az\n0,0,,0,0,0,0\n").unwrap_err();
        assert!(matches!(&e, TraceError::NotANumber { line: 2, column, .. } if column == "gy"));

        let e = read("t,gx,gy,gz,ax,ay,az,t\n").unwrap_err();
        assert!(matches!(e, TraceError::DuplicateColumn { line: 1, .. }));
        assert!(matches!(read("# only\n\n").unwrap_err(), TraceError::NoHeader));
        let e = read("t,gx,gy,gz,ax,ay,az,mx,mz\n").unwrap_err();
        assert!(matches!(&e, TraceError::MissingColumn { column, .. } if column == "my"));
    }

    #[test]
    fn optional_groups() {
        let h = "t,gx,gy,gz,ax,ay,az,mx,my,mz,depth,qw,qx,qy,qz\n";
        let rows =
            read(&format!("{h}0,0,0,0,0,0,-9.8,1,2,3,4.5,1,0,0,0\n0.1,0,0,0,0,0,-9.8,,,,,,,,\n"))
                .unwrap();
        assert_eq!(rows[0].mag, Some([1.0, 2.0, 3.0]));
        assert_eq!(rows[0].depth, Some(4.5));
        assert_eq!(rows[0].truth, Some([1.0, 0.0, 0.0, 0.0]));
        assert_eq!((rows[1].mag, rows[1].depth, rows[1].truth), (None, None, None));
        let e = read(&format!("{h}0,0,0,0,0,0,-9.8,1,,3,,,,,\n")).unwrap_err();
        assert!(matches!(&e, TraceError::PartialGroup { line: 2, column } if column == "my"));
    }

    /// A recording whose optical system lost the sensor (BROAD: `nan` in all four truth
    /// cells) has rows without truth, which are read and not scored; `movement` marks the
    /// scored phase. A truth partly `nan`, or a `movement` other than 0 or 1, is an error
    /// naming the line and the column.
    #[test]
    fn lost_truth_and_the_movement_column() {
        let h = "t,gx,gy,gz,ax,ay,az,qw,qx,qy,qz,movement\n";
        let rows = read(&format!(
            "{h}0,0,0,0,0,0,-9.8,1,0,0,0,0\n0.1,0,0,0,0,0,-9.8,nan,nan,NaN,nan,1\n\
             0.2,0,0,0,0,0,-9.8,1,0,0,0,1\n"
        ))
        .unwrap();
        assert_eq!(rows[1].truth, None);
        assert_eq!(
            rows.iter().map(|r| r.movement).collect::<Vec<_>>(),
            [Some(false), Some(true), Some(true)]
        );
        assert_eq!(rows.iter().map(TraceRow::scored).collect::<Vec<_>>(), [false, false, true]);
        // An empty cell says nothing of the phase: the row is scored like one without the
        // column (not read as 0, the rest phase, which would drop it from the score).
        let rows = read(&format!("{h}0,0,0,0,0,0,-9.8,1,0,0,0,\n")).unwrap();
        assert_eq!((rows[0].movement, rows[0].scored()), (None, true));
        // Without the column every row with truth is scored.
        let rows = read("t,gx,gy,gz,ax,ay,az,qw,qx,qy,qz\n0,0,0,0,0,0,-9.8,1,0,0,0\n").unwrap();
        assert!(rows[0].scored() && rows[0].movement.is_none());
        let e = read(&format!("{h}0,0,0,0,0,0,-9.8,nan,0,0,0,1\n")).unwrap_err();
        assert!(matches!(&e, TraceError::NotFinite { line: 2, column, .. } if column == "qw"));
        let e = read(&format!("{h}0,0,0,0,0,0,-9.8,1,0,0,0,2\n")).unwrap_err();
        assert!(matches!(&e, TraceError::BadMovement { line: 2, .. }), "{e}");
        assert_eq!(e.column(), Some("movement"));
        // A lost gyro or accelerometer is still an error: the filter needs every sample.
        let e = read(&format!("{h}0,0,nan,0,0,0,-9.8,1,0,0,0,1\n")).unwrap_err();
        assert!(matches!(&e, TraceError::NotFinite { line: 2, column, .. } if column == "gy"));
    }

    #[test]
    fn write_read_round_trip_is_exact() {
        let cols = TraceColumns { mag: true, depth: true, truth: true };
        let mut w = TraceWriter::new(Vec::new(), cols).unwrap();
        let mut rows = Vec::new();
        let mut x = 0.123_456_79_f32;
        for k in 0..100 {
            x = (x * 3.7 + 0.1).fract() - 0.5;
            let row = TraceRow {
                t: k as f64 / 50.0,
                gyro: [x, -x * 1e-7, x * 1e5],
                accel: [f32::MIN_POSITIVE, -9.806_65, x / 3.0],
                mag: if k % 3 == 0 { None } else { Some([x, 2.0 * x, 1e-30]) },
                depth: if k % 2 == 0 { Some(x.abs()) } else { None },
                truth: Some([1.0 - x * x, x, -x, 0.0]),
                movement: None,
            };
            w.row(&row).unwrap();
            if k == 10 {
                w.comment("a comment\nwith a newline").unwrap();
            }
            rows.push(row);
        }
        let bytes = w.finish().unwrap();
        let back = read(std::str::from_utf8(&bytes).unwrap()).unwrap();
        assert_eq!(back, rows);
    }

    #[test]
    fn padding_blank_lines_and_the_byte_order_mark() {
        let text = "\u{feff} t ,gx,gy,gz,ax,ay,az\n  \t\r\n   # indented comment, 1, 2\n\
                    \t0.5 ,\t1e-3, -2E2 ,+3,0,0,-9.8\r\n";
        let rows = read(text).unwrap();
        assert_eq!(rows.len(), 1);
        assert_eq!((rows[0].t, rows[0].gyro), (0.5, [1e-3, -200.0, 3.0]));
        // A line with something after a `\r` is not a data line with a `\r\n` end.
        let e = read("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,1\r2\n").unwrap_err();
        assert!(matches!(&e, TraceError::NotANumber { line: 2, column, .. } if column == "az"));
        let e = read("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,\u{e9}\n").unwrap_err();
        assert!(matches!(&e, TraceError::NotANumber { line: 2, .. }));
        let e = TraceReader::new(&b"t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,\xff\n"[..])
            .unwrap()
            .next_row()
            .unwrap_err();
        assert!(matches!(e, TraceError::InvalidUtf8 { line: 2 }));
    }

    #[test]
    fn out_of_range_and_non_finite_cells() {
        for (cell, column) in [("1e300", "az"), ("-1e39", "az"), ("NaN", "az"), ("-inf", "az")] {
            let e = read(&format!("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,{cell}\n")).unwrap_err();
            assert!(matches!(&e, TraceError::NotFinite { line: 2, column: c, .. } if c == column));
            assert!(e.to_string().contains("f32 range"), "{e}");
        }
        // `t` is an `f64`: 1e300 is a time, an f64 overflow is not.
        assert_eq!(read("t,gx,gy,gz,ax,ay,az\n1e300,0,0,0,0,0,0\n").unwrap()[0].t, 1e300);
        let e = read("t,gx,gy,gz,ax,ay,az\n1e309,0,0,0,0,0,0\n").unwrap_err();
        assert!(matches!(&e, TraceError::NotFinite { column, .. } if column == "t"));
        // Subnormal and rounded values are the standard parser's.
        let rows = read("t,gx,gy,gz,ax,ay,az\n0,1e-45,0.1,16777217,0,0,0\n").unwrap();
        assert_eq!(rows[0].gyro, [1e-45, 0.1, 16_777_216.0]);
    }

    /// `v` rounded to `d` decimals half away from zero, as a signed count of 10^-d, from the
    /// exact decimal expansion of `v` (the standard library's formatting).
    fn reference_fixed(v: f32, d: usize) -> i128 {
        let s = format!("{:.200}", f64::from(v).abs());
        let (ip, fp) = s.split_once('.').unwrap();
        let mut n: i128 = format!("{ip}{}", &fp[..d]).parse().unwrap();
        if fp.as_bytes()[d] >= b'5' {
            n += 1;
        }
        if v < 0.0 {
            -n
        } else {
            n
        }
    }

    /// A fixed-point cell as a signed count of 10^-d, checking its form: no trailing zero, at
    /// most `d` decimals, no `-0`.
    fn written_fixed(s: &str, d: usize) -> i128 {
        let (neg, s) = match s.strip_prefix('-') {
            Some(r) => (true, r),
            None => (false, s),
        };
        let (ip, fp) = s.split_once('.').unwrap_or((s, ""));
        assert!(!fp.ends_with('0') && fp.len() <= d && !s.ends_with('.'), "{s:?}");
        let n: i128 = format!("{ip}{fp:0<d$}").parse().unwrap();
        assert!(!(neg && n == 0), "negative zero written: {s:?}");
        if neg {
            -n
        } else {
            n
        }
    }

    fn fixed(v: f32, d: usize) -> String {
        let mut buf = Vec::new();
        push_fixed(&mut buf, &mut ryu::Buffer::new(), v, d);
        String::from_utf8(buf).unwrap()
    }

    #[test]
    fn fixed_point_rounds_exactly_half_away_from_zero() {
        let check = |v: f32| {
            for d in [0, 5, 6, 8] {
                assert_eq!(written_fixed(&fixed(v, d), d), reference_fixed(v, d), "{v:e}, {d}");
            }
        };
        for v in [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            0.001_953_125, // 2^-9: a tie at 8 decimals
            -0.001_953_125,
            0.015_625, // 2^-6: a tie at 5 decimals
            -0.007_812_5,
            1e-9,
            5e-9,
            179.9,
            -180.0,
            f32::MIN_POSITIVE,
            1e-45,
            999_999_940.0,
            0.999_999_94,
        ] {
            check(v);
        }
        let mut rng = crate::rng::Rng::new(7, 0);
        for k in 0..100_000u32 {
            let v = (rng.normal() * 10f64.powi((k % 21) as i32 - 12)) as f32;
            let r = f32::from_bits(rng.next_u64() as u32);
            for v in [v, r] {
                if v.is_finite() && v.abs() < 1e9 {
                    check(v);
                }
            }
        }
        assert_eq!(fixed(0.707_106_77, 8), "0.70710677");
        assert_eq!(fixed(-0.000_000_004, 8), "0");
        assert_eq!(
            (fixed(f32::NAN, 8), fixed(f32::NEG_INFINITY, 8)),
            (String::new(), String::new())
        );
        assert_eq!(
            (fixed(1e9, 8), fixed(-2.5e10, 5)),
            ("1000000000.0".into(), "-25000000000.0".into())
        );
    }

    #[test]
    fn times_read_back_exactly() {
        let time = |t: f64| {
            let mut buf = Vec::new();
            push_time(&mut buf, &mut ryu::Buffer::new(), t);
            String::from_utf8(buf).unwrap()
        };
        for (t, text) in [
            (0.0, "0.0"),
            (1.0, "1"),
            (0.02, "0.02"),
            (-3.5, "-3.5"),
            (0.1 + 0.2, "0.30000000000000004"),
            (1e-10, "1e-10"),
            (123_456.000_000_001, "123456.000000001"),
            (5e9, "5000000000.0"),
            (f64::NAN, ""),
        ] {
            assert_eq!(time(t), text);
        }
        let mut rng = crate::rng::Rng::new(3, 0);
        for k in 0..100_000 {
            let t = [k as f64 * 0.02, rng.uniform() * 1e6, rng.uniform() * 1e-3][k % 3];
            assert_eq!(time(t).parse::<f64>(), Ok(t));
        }
    }

    #[test]
    fn estimate_round_trip() {
        let mut w = EstimateWriter::new(Vec::new()).unwrap();
        let r = EstimateRow {
            t: 0.02,
            q: [1.0, 0.0, 1e-3, -2e-4],
            euler_deg: [0.1, -0.2, 179.9],
            bias_dps: [1.619, 3.44, -0.004],
            flags: 0x0101,
        };
        w.row(&r).unwrap();
        let bytes = w.finish().unwrap();
        let mut rd = EstimateReader::new(&bytes[..]).unwrap();
        assert_eq!(rd.next_row().unwrap(), Some(r));
        assert_eq!(rd.next_row().unwrap(), None);

        // Fixed point: the estimate within half a unit of the last decimal; NaN → empty cell.
        let r = EstimateRow {
            t: 1234.56,
            q: [0.707_106_77, -0.000_123_456_79, 0.5, -0.707_106_77],
            euler_deg: [-179.999_99, 45.123_456, 0.0], // -179.99998474…
            bias_dps: [f32::NAN; 3],
            flags: 3,
        };
        let mut w = EstimateWriter::new(Vec::new()).unwrap();
        w.row(&r).unwrap();
        let bytes = w.finish().unwrap();
        let text = std::str::from_utf8(&bytes).unwrap();
        assert_eq!(
            text.lines().nth(1),
            Some("1234.56,0.70710677,-0.00012346,0.5,-0.70710677,-179.99998,45.12346,0,,,,3")
        );
        let back = EstimateReader::new(&bytes[..]).unwrap().next_row().unwrap().unwrap();
        assert_eq!((back.t, back.flags), (r.t, r.flags));
        assert!(back.bias_dps.iter().all(|b| b.is_nan()));
        for (a, b) in back.q.iter().zip(&r.q) {
            assert!((a - b).abs() <= 0.5e-8 + 6e-8, "{a} {b}");
        }
        for (a, b) in back.euler_deg.iter().zip(&r.euler_deg) {
            assert!((a - b).abs() <= 0.5e-5 + 1.6e-5, "{a} {b}");
        }
    }
}
