//! The trace CSV format of `shared/trace-format.md`: reading and writing input traces and
//! estimate files.
//!
//! Reading rules:
//! - the first line that is neither empty nor a comment is the header; columns are found by
//!   name (surrounding spaces ignored), in any order; unknown columns are ignored; a column
//!   name may not appear twice;
//! - required columns: `t` (s, strictly increasing), `gx,gy,gz` (rad/s), `ax,ay,az` (m/s²,
//!   specific force); optional: `mx,my,mz` (µT, all three or none), `depth` (m),
//!   `qw,qx,qy,qz` (truth, all four or none);
//! - empty lines and lines whose first non-blank character is `#` are comments, anywhere;
//! - every data line has exactly as many cells as the header; cells may be padded with spaces;
//!   `\r\n` line ends are accepted;
//! - required cells must be finite numbers. Optional cells may be empty (no sample on that row,
//!   e.g. a magnetometer at a lower rate) but a group (`mx,my,mz` or `qw..qz`) is all empty or
//!   all numbers.
//!
//! Every error is a [`TraceError`] naming the 1-based line number and, where one is at fault,
//! the column.
//!
//! Input traces are written with shortest round-trip formatting (the `ryu` crate: the same
//! digits as Rust's `{}`, with an exponent for very small or large values), so an `f32`
//! written and read back is bit-identical; `t` is kept as `f64`. NaN or infinite values are
//! written as `NaN`/`inf` (the reader rejects them). Estimate files keep `t` shortest round
//! trip and write the estimate in fixed point (quaternion 8 decimals, Euler angles 5, bias 6:
//! finer than the `f32` estimate's own precision), exactly rounded with integer arithmetic —
//! several times faster than shortest round trip; NaN or infinite values there are empty
//! cells. See [`EstimateWriter`].
//!
//! Speed: numbers are parsed with an exact fast path (see `fast_f64`; anything it does not
//! cover goes to the standard library's parser, so values and errors are those of
//! `str::parse`); the usual cell form `[-]d.ddd` is read 16 bytes at a time with SSE2 on
//! x86-64 (`sse2.rs`), 8 at a time (SWAR) elsewhere; output is assembled in 64 KiB blocks
//! (estimate lines in a stack buffer first). `cargo bench -p host-tests --bench replay_speed`
//! measures both.

use std::fmt;
use std::io::{self, BufRead, Write};

mod fixed;
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod sse2;

use fixed::{fixed_f32_into, time_fixed, u16_line_end};

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
    /// Ground-truth attitude `(qw, qx, qy, qz)`, body FRD → NED, when the row has one.
    pub truth: Option<[f32; 4]>,
}

/// Why a trace or estimate file could not be read.
#[derive(Debug)]
pub enum TraceError {
    /// Reading failed.
    Io(io::Error),
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

impl TraceError {
    /// The 1-based line the error is on, when it is about a line.
    pub fn line(&self) -> Option<usize> {
        match self {
            TraceError::Io(_) | TraceError::NoHeader => None,
            TraceError::InvalidUtf8 { line }
            | TraceError::MissingColumn { line, .. }
            | TraceError::DuplicateColumn { line, .. }
            | TraceError::CellCount { line, .. }
            | TraceError::NotANumber { line, .. }
            | TraceError::NotFinite { line, .. }
            | TraceError::PartialGroup { line, .. }
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
            if self.reader.read_until(b'\n', &mut self.buf)? == 0 {
                return Ok(false);
            }
            self.line += 1;
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

    /// The fast path of the readers built on this one: offer the unread part of the input
    /// buffer to `parse`, which either recognises one complete, well-formed data line at its
    /// start (returning its value and the line's length including the `\n`) or declines
    /// (`None`: a comment, anything unusual or malformed, a line crossing the end of the
    /// buffer). A recognised line is consumed and counted; after `Ok(None)` nothing is
    /// consumed and the caller reads the line with [`CsvReader::next_record`], which handles
    /// every case and reports the errors. No copy, no allocation.
    pub fn next_fast<T>(
        &mut self,
        parse: impl FnOnce(&[u8]) -> Option<(T, usize)>,
    ) -> Result<Option<T>, TraceError> {
        let buf = self.reader.fill_buf()?;
        match parse(buf) {
            Some((value, len)) => {
                self.reader.consume(len);
                self.line += 1;
                Ok(Some(value))
            }
            None => Ok(None),
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

/// Powers of ten exactly representable in `f64`.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// A decimal number `±m · 10^e` as written, before conversion.
#[derive(Clone, Copy, Debug)]
struct Decimal {
    neg: bool,
    m: u64,
    e: i32,
}

/// The run of ASCII digits at the start of `b`, at most 8 of them: `(value, length)`
/// ([`digit_word`], or byte by byte near the end of `b`).
#[inline(always)]
fn digit_run8(b: &[u8]) -> (u64, usize) {
    if let Some(r) = digit_word(b, 0) {
        r
    } else {
        let mut m = 0;
        let mut k = 0;
        while k < b.len() && b[k].is_ascii_digit() {
            m = m * 10 + u64::from(b[k] - b'0');
            k += 1;
        }
        (m, k)
    }
}

/// Digits at the start of `b` appended to `m`: the new `m`, the digits read, or `None` past 19
/// digits in all (`nd` already read), so that `m` cannot overflow.
#[inline(always)]
fn digits(b: &[u8], mut m: u64, nd: usize) -> Option<(u64, usize)> {
    let mut i = 0;
    loop {
        let (v, k) = digit_run8(&b[i..]);
        if nd + i + k > 19 {
            return None;
        }
        m = m * POW10_U64[k] + v;
        i += k;
        if k < 8 {
            return Some((m, i));
        }
    }
}

/// Scan `[+-]digits[.digits][(e|E)[+-]digits]` (at least one digit, at most 19 in all, an
/// exponent below 10000) at the start of `b`: the number and the bytes it spans. `None` if
/// there is no such number; what follows it is the caller's business.
#[inline(always)]
fn scan_decimal(b: &[u8]) -> Option<(Decimal, usize)> {
    let (neg, mut i) = match b.first()? {
        b'-' => (true, 1),
        b'+' => (false, 1),
        _ => (false, 0),
    };
    let (mut m, int_digits) = digits(&b[i..], 0, 0)?;
    i += int_digits;
    let mut nd = int_digits;
    let mut e: i32 = 0;
    if b.get(i) == Some(&b'.') {
        i += 1;
        let (m2, frac_digits) = digits(&b[i..], m, nd)?;
        m = m2;
        i += frac_digits;
        nd += frac_digits;
        e = -(frac_digits as i32);
    }
    if nd == 0 {
        return None;
    }
    if let Some(b'e' | b'E') = b.get(i) {
        i += 1;
        let eneg = match b.get(i) {
            Some(b'-') => {
                i += 1;
                true
            }
            Some(b'+') => {
                i += 1;
                false
            }
            _ => false,
        };
        let start = i;
        let mut x: i32 = 0;
        while let Some(&c) = b.get(i) {
            if !c.is_ascii_digit() || i - start == 4 {
                break;
            }
            x = x * 10 + i32::from(c - b'0');
            i += 1;
        }
        if i == start || b.get(i).is_some_and(u8::is_ascii_digit) {
            return None;
        }
        e += if eneg { -x } else { x };
    }
    Some((Decimal { neg, m, e }, i))
}

/// Exact fast path of decimal → `f64` (Clinger): a mantissa `m ≤ 2⁵³` and a decimal exponent
/// `|e| ≤ 22`, so that `m` and `10^|e|` are exact in `f64` and one correctly rounded
/// multiplication or division gives the correctly rounded result. `None` for anything else.
#[inline(always)]
fn decimal_f64(d: Decimal) -> Option<f64> {
    if d.m > 1 << 53 {
        return None;
    }
    let v = if d.m == 0 {
        0.0
    } else if (0..=22).contains(&d.e) {
        d.m as f64 * POW10[d.e as usize]
    } else if (-22..0).contains(&d.e) {
        d.m as f64 / POW10[(-d.e) as usize]
    } else {
        return None;
    };
    Some(with_sign(v, d.neg))
}

/// `−v` if `neg`, else `v`, for `v ≥ +0`: the sign bit set without a branch (the signs of
/// sensor noise are random, and a mispredicted branch costs more than the whole operation).
#[inline(always)]
fn with_sign(v: f64, neg: bool) -> f64 {
    f64::from_bits(v.to_bits() | u64::from(neg) << 63)
}

/// Negative powers of ten rounded to `f64` (not exact).
const NEG_POW10: [f64; 23] = [
    1e0, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14,
    1e-15, 1e-16, 1e-17, 1e-18, 1e-19, 1e-20, 1e-21, 1e-22,
];

/// Correctly rounded `f32` of `d`, or `None` (as [`decimal_f64`]; also for results outside the
/// normal `f32` range).
///
/// First without a division: `x = m · fl(10^e)` (`m ≤ 2⁵³` exact) has two roundings, so
/// `|x − v| ≤ 2.01·u·|v|` (`u = 2⁻⁵³`) for the exact value `v`: within 2.01 units in the last
/// place of `x`, at most 5 `f64` steps (bit patterns) even where `v` is in the binade below
/// (half the spacing). The `f32` rounding boundaries (midpoints between
/// neighbouring `f32`s) in the normal range are the `f64`s whose 29 bits below the `f32`
/// significand are `1000…0`; positive `f64` bit patterns are ordered like the values. So if
/// those 29 bits of `x` are more than 8 away from `1000…0`, no boundary lies between `x` and
/// `v`, and `x as f32` is `v` correctly rounded. Otherwise the exact path: the correctly
/// rounded `f64` ([`decimal_f64`]) rounded to `f32` is correct unless it landed exactly on a
/// midpoint (`f32` midpoints are `f64`s, so otherwise it is on the same side of every midpoint
/// as `v`); that case gives `None`.
#[inline(always)]
fn decimal_f32(d: Decimal) -> Option<f32> {
    const LOW: u64 = (1 << 29) - 1;
    const MID: u64 = 1 << 28;
    let x = if d.m > 1 << 53 {
        return None;
    } else if (-22..=0).contains(&d.e) {
        // `m ≤ 2⁵³`: the signed conversion is the same, and shorter.
        with_sign(d.m as i64 as f64 * NEG_POW10[(-d.e) as usize], d.neg)
    } else {
        decimal_f64(d)?
    };
    let a = x.abs();
    if a == 0.0 {
        return Some(x as f32);
    }
    if !(a >= f32::MIN_POSITIVE as f64 && a <= f32::MAX as f64) {
        return None;
    }
    if (x.to_bits() & LOW).abs_diff(MID) > 8 {
        return Some(x as f32);
    }
    let x = decimal_f64(d)?;
    if x.to_bits() & LOW == MID {
        return None;
    }
    Some(x as f32)
}

/// The exact fast path on a whole cell ([`scan_decimal`], [`decimal_f64`]). `None` for
/// anything else (the caller then uses the standard library's parser, which also produces the
/// errors): the result, when there is one, is always the one `str::parse::<f64>` gives.
fn fast_f64(b: &[u8]) -> Option<f64> {
    match scan_decimal(b)? {
        (d, n) if n == b.len() => decimal_f64(d),
        _ => None,
    }
}

/// [`fast_f64`] for `f32` ([`decimal_f32`]): always `str::parse::<f32>`'s result, when any.
fn fast_f32(b: &[u8]) -> Option<f32> {
    match scan_decimal(b)? {
        (d, n) if n == b.len() => decimal_f32(d),
        _ => None,
    }
}

/// Numbers the reader parses: the exact fast path, else `FromStr`.
trait FastParse: std::str::FromStr + Copy + Into<f64> {
    fn fast_parse(b: &[u8]) -> Option<Self>;
}

impl FastParse for f32 {
    fn fast_parse(b: &[u8]) -> Option<f32> {
        fast_f32(b)
    }
}

impl FastParse for f64 {
    fn fast_parse(b: &[u8]) -> Option<f64> {
        fast_f64(b)
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

    fn parse<T: FastParse>(&self, i: usize) -> Result<T, TraceError> {
        let text = self.text(i);
        if let Some(v) = T::fast_parse(text.as_bytes()) {
            return Ok(v);
        }
        match text.parse::<T>() {
            Ok(v) if v.into().is_finite() => Ok(v),
            Ok(_) => Err(TraceError::NotFinite {
                line: self.line,
                column: self.header[i].clone(),
                text: text.into(),
            }),
            Err(_) => Err(TraceError::NotANumber {
                line: self.line,
                column: self.header[i].clone(),
                text: text.into(),
            }),
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
    prev_t: Option<f64>,
    /// Per header column, the slot of [`fast_row`] it fills ([`SKIP`] for other columns).
    slots: Vec<u8>,
    /// Try [`fast_row`] first (false only in tests comparing the two paths).
    fast: bool,
}

/// Slots of [`fast_row`]: `t`, then `gx..az`, `mx..mz`, `depth`, `qw..qz`.
const SLOT_GYRO: u8 = 1;
const SLOT_ACCEL: u8 = 4;
const SLOT_MAG: u8 = 7;
const SLOT_DEPTH: u8 = 10;
const SLOT_TRUTH: u8 = 11;
/// A column [`fast_row`] skips.
const SKIP: u8 = u8::MAX;
const MASK_REQUIRED: u32 = (1 << SLOT_MAG) - 1;
const MASK_MAG: u32 = 0b111 << SLOT_MAG;
const MASK_TRUTH: u32 = 0b1111 << SLOT_TRUTH;

/// The 8 digit values in the bytes of `v`, byte 0 the most significant: their number, by
/// pairwise combination (8 → 4 → 2 → 1 lanes).
#[inline(always)]
fn swar8(v: u64) -> u64 {
    let v = v.wrapping_mul(10).wrapping_add(v >> 8);
    (((v & 0x0000_00ff_0000_00ff).wrapping_mul(100 + (1_000_000 << 32))
        + ((v >> 16) & 0x0000_00ff_0000_00ff).wrapping_mul(1 + (10_000 << 32)))
        >> 32)
        & 0xffff_ffff
}

/// The run of ASCII digits at `buf[i..]`, at most 8 of them, `(value, length)`, without
/// branches on the data; `None` if `buf` has fewer than 8 bytes from `i`.
///
/// SWAR on one little-endian `u64`: a byte is a digit iff neither `c - 0x30` nor `c + 0x46`
/// has its top bit set. A borrow or carry only crosses from a non-digit byte into later bytes,
/// so the first flagged byte is exactly the first non-digit. The digit values are shifted to
/// the top of the word (zero bytes in front, i.e. leading zeros) and combined ([`swar8`]).
#[inline(always)]
fn digit_word(buf: &[u8], i: usize) -> Option<(u64, usize)> {
    let c = u64::from_le_bytes(*buf.get(i..)?.first_chunk::<8>()?);
    let v = c.wrapping_sub(0x3030_3030_3030_3030);
    let non_digit = (c.wrapping_add(0x4646_4646_4646_4646) | v) & 0x8080_8080_8080_8080;
    let k = (non_digit.trailing_zeros() / 8) as usize; // 8 when all are digits
    Some((swar8(v.checked_shl(8 * (8 - k) as u32).unwrap_or(0)), k))
}

/// Bytes [`window_decimal`] reads from the start of a cell: the longest form it takes and the
/// byte after it (`-` + 7 + `.` + 15 + 1 < 32).
const WINDOW: usize = 32;

/// The digits at the start of the 8 bytes `c` (little endian, i.e. text order): their value
/// bytes `c - '0'` and their count `k ≤ 8` (SWAR, see [`digit_word`]).
#[inline(always)]
fn digit_lanes(c: u64) -> (u64, usize) {
    let v = c.wrapping_sub(0x3030_3030_3030_3030);
    let non_digit = (c.wrapping_add(0x4646_4646_4646_4646) | v) & 0x8080_8080_8080_8080;
    (v, (non_digit.trailing_zeros() / 8) as usize)
}

/// The value of the first `k ≤ 8` digit lanes of `v` ([`digit_lanes`]).
#[inline(always)]
fn lanes_value(v: u64, k: usize) -> u64 {
    swar8(v.checked_shl(8 * (8 - k) as u32).unwrap_or(0))
}

/// The common number form at the start of `w`: `[-]digits.digits` with at most 7 integer and
/// 15 fraction digits, 19 in all; the number and where it ends (the caller checks what
/// follows, always inside `w`). One fixed window, so no bounds checks: the integer part and
/// the `.` from one word, the fraction from one word, or two when it has 8 digits or more;
/// `None` for anything else, left to [`scan_decimal`].
#[inline(always)]
fn window_decimal(w: &[u8; WINDOW]) -> Option<(Decimal, usize)> {
    let neg = w[0] == b'-';
    let p = usize::from(neg);
    let word = |i: usize| u64::from_le_bytes(*w[i..].first_chunk::<8>().unwrap());
    let c = word(p);
    let (v, k1) = digit_lanes(c);
    if k1 == 8 || (c >> (8 * k1)) as u8 != b'.' {
        return None;
    }
    // Usually one integer digit (`0.`, `-9.`, `1.`).
    let m1 = if k1 == 1 { v & 0xff } else { lanes_value(v, k1) };
    let f = p + k1 + 1;
    let (va, ka) = digit_lanes(word(f));
    let (m, k) = if ka < 8 {
        if k1 + ka == 0 {
            return None;
        }
        (m1 * POW10_U64[ka] + lanes_value(va, ka), ka)
    } else {
        let (vb, kb) = digit_lanes(word(f + 8));
        if kb == 8 || k1 + 8 + kb > 19 {
            return None;
        }
        ((m1 * 100_000_000 + swar8(va)) * POW10_U64[kb] + lanes_value(vb, kb), 8 + kb)
    };
    Some((Decimal { neg, m, e: -(k as i32) }, f + k))
}

/// The common number form at the start of `w` as [`window_decimal`] reads it, at most 16
/// digits, by the SSE2 parser where there is one (x86-64); `None` for anything else, left to
/// [`window_decimal`].
#[inline(always)]
fn window_decimal_fast(w: &[u8; WINDOW]) -> Option<(Decimal, usize)> {
    #[cfg(target_arch = "x86_64")]
    return sse2::window_decimal(w);
    #[cfg(not(target_arch = "x86_64"))]
    return None;
}

/// [`window_decimal`] at `buf[s..]`, `None` where fewer than [`WINDOW`] bytes are left.
#[cfg(test)]
#[inline(always)]
fn plain_decimal(buf: &[u8], s: usize) -> Option<(Decimal, usize)> {
    let w = buf.get(s..)?.first_chunk::<WINDOW>()?;
    window_decimal(w).map(|(d, n)| (d, s + n))
}

/// The fast path of [`TraceReader`]: one data line at the start of `buf`, parsed in place in a
/// single pass: cells split as they are parsed, numbers by [`window_decimal_fast`], else
/// [`window_decimal`], else [`scan_decimal`] (the exact fast path), skipped cells only checked
/// to be ASCII (so the line is valid UTF-8). Returns the row and the line's length, or `None`
/// for anything that is not a plain, complete data line: a comment or empty line, padding, a
/// number outside the exact fast path, a missing or extra cell, a partial group, no `\n` in
/// `buf`. The slow path then reads the line and gives the same row, or the error. (Near the end
/// of `buf`, where a [`WINDOW`]-byte window does not fit, cells are read by [`scan_decimal`]
/// alone.)
/// `t` is not checked against the previous row here.
#[inline]
fn fast_row(slots: &[u8], buf: &[u8]) -> Option<(TraceRow, usize)> {
    if let b'#' | b' ' | b'\t' | b'\r' | b'\n' = buf.first()? {
        return None;
    }
    let mut t = 0.0;
    let mut v = [0.0f32; 15];
    let mut present = 0u32;
    let mut i = 0;
    let last = slots.len() - 1;
    for (col, &slot) in slots.iter().enumerate() {
        if slot == SKIP {
            loop {
                match *buf.get(i)? {
                    b',' | b'\n' => break,
                    c if c >= 0x80 => return None,
                    _ => i += 1,
                }
            }
        } else if !matches!(buf.get(i)?, b',' | b'\n' | b'\r') {
            let plain = match buf[i..].first_chunk::<WINDOW>() {
                Some(w) => window_decimal_fast(w)
                    .or_else(|| window_decimal(w))
                    .filter(|&(_, n)| matches!(w[n], b',' | b'\n' | b'\r')),
                None => None,
            };
            let (d, n) = match plain {
                Some(r) => r,
                None => scan_decimal(&buf[i..])?,
            };
            i += n;
            if slot == 0 {
                t = decimal_f64(d)?;
            } else {
                v[slot as usize] = decimal_f32(d)?;
            }
            present |= 1 << slot;
        }
        let c = *buf.get(i)?;
        i += 1;
        if col < last {
            if c != b',' {
                return None;
            }
        } else if c == b'\r' {
            if *buf.get(i)? != b'\n' {
                return None;
            }
            i += 1;
        } else if c != b'\n' {
            return None;
        }
    }
    let group = |mask: u32| match present & mask {
        0 => Some(false),
        p if p == mask => Some(true),
        _ => None,
    };
    if present & MASK_REQUIRED != MASK_REQUIRED {
        return None;
    }
    let mag = group(MASK_MAG)?.then(|| [v[7], v[8], v[9]]);
    let truth = group(MASK_TRUTH)?.then(|| [v[11], v[12], v[13], v[14]]);
    let depth = (present & 1 << SLOT_DEPTH != 0).then_some(v[10]);
    let row =
        TraceRow { t, gyro: [v[1], v[2], v[3]], accel: [v[4], v[5], v[6]], mag, depth, truth };
    Some((row, i))
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
        let mut slots = vec![SKIP; csv.header().len()];
        slots[t] = 0;
        for k in 0..3 {
            slots[gyro[k]] = SLOT_GYRO + k as u8;
            slots[accel[k]] = SLOT_ACCEL + k as u8;
        }
        for (k, &c) in mag.iter().flatten().enumerate() {
            slots[c] = SLOT_MAG + k as u8;
        }
        if let Some(c) = depth {
            slots[c] = SLOT_DEPTH;
        }
        for (k, &c) in truth.iter().flatten().enumerate() {
            slots[c] = SLOT_TRUTH + k as u8;
        }
        Ok(TraceReader { csv, t, gyro, accel, mag, depth, truth, prev_t: None, slots, fast: true })
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
        if self.fast {
            let slots = &self.slots;
            if let Some(row) = self.csv.next_fast(|buf| fast_row(slots, buf))? {
                if let Some(prev) = self.prev_t {
                    if row.t <= prev {
                        let line = self.csv.line;
                        return Err(TraceError::TimeNotIncreasing {
                            line,
                            t: row.t,
                            previous: prev,
                        });
                    }
                }
                self.prev_t = Some(row.t);
                return Ok(Some(row));
            }
        }
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
            Some(idx) => rec.group(idx)?,
            None => None,
        };
        self.prev_t = Some(t);
        Ok(Some(TraceRow { t, gyro, accel, mag, depth, truth }))
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

const POW10_U64: [u64; 10] =
    [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000, 10_000_000, 100_000_000, 1_000_000_000];

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
/// `t` is written shortest round trip (the input's value back); the other numbers in fixed
/// point, [`Q_DECIMALS`], [`EULER_DECIMALS`] and [`BIAS_DECIMALS`] decimals at most, rounded
/// exactly (half away from zero), trailing zeros dropped; NaN or infinite values are written
/// as empty cells.
/// Output is buffered in blocks: end with [`EstimateWriter::finish`].
pub struct EstimateWriter<W: Write> {
    w: W,
    /// The block being assembled: `buf[..len]`; rows are written into it in place.
    buf: Box<[u8]>,
    len: usize,
    fb: ryu::Buffer,
}

/// Room after [`OUT_BLOCK`] for one more estimate line: at most 24 + 10 · 25 + 6 bytes.
const LINE_MAX: usize = 512;

impl<W: Write> EstimateWriter<W> {
    /// Write the header.
    pub fn new(mut w: W) -> io::Result<Self> {
        writeln!(w, "{ESTIMATE_HEADER}")?;
        Ok(EstimateWriter {
            w,
            buf: vec![0; OUT_BLOCK + LINE_MAX].into_boxed_slice(),
            len: 0,
            fb: ryu::Buffer::new(),
        })
    }

    /// One row.
    pub fn row(&mut self, r: &EstimateRow) -> io::Result<()> {
        // Written in place into the block (fixed-size writes into 24-byte slots, no copies).
        let start = self.len;
        let b: &mut [u8; LINE_MAX] = (&mut self.buf[start..start + LINE_MAX]).try_into().unwrap();
        let mut n = 0;
        let slot: &mut [u8; 24] = (&mut b[..24]).try_into().unwrap();
        if let Some(k) = time_fixed(r.t, slot) {
            n = k;
        } else if r.t.is_finite() {
            let s = self.fb.format_finite(r.t).as_bytes();
            b[..s.len()].copy_from_slice(s);
            n = s.len();
        }
        n = fixed_f32s::<Q_DECIMALS, _>(&mut self.fb, &r.q, b, n);
        n = fixed_f32s::<EULER_DECIMALS, _>(&mut self.fb, &r.euler_deg, b, n);
        n = fixed_f32s::<BIAS_DECIMALS, _>(&mut self.fb, &r.bias_dps, b, n);
        b[n] = b',';
        n += 1;
        n += u16_line_end(r.flags, (&mut b[n..n + 8]).try_into().unwrap());
        self.len = start + n;
        if self.len >= OUT_BLOCK {
            self.w.write_all(&self.buf[..self.len])?;
            self.len = 0;
        }
        Ok(())
    }

    /// Write what is buffered, flush and return the inner writer. Rows are buffered: without
    /// this call the last rows are lost.
    pub fn finish(mut self) -> io::Result<W> {
        self.w.write_all(&self.buf[..self.len])?;
        self.len = 0;
        self.w.flush()?;
        Ok(self.w)
    }
}

/// `,` and each of `vs` with `D` decimals at most (see [`fixed_f32_into`]) into `b` from `n`; the
/// new end.
#[inline(always)]
fn fixed_f32s<const D: usize, const N: usize>(
    fb: &mut ryu::Buffer,
    vs: &[f32; N],
    b: &mut [u8; LINE_MAX],
    mut n: usize,
) -> usize {
    for &v in vs {
        // One bounds check for the separator and the number.
        let cell: &mut [u8; 25] = (&mut b[n..n + 25]).try_into().unwrap();
        cell[0] = b',';
        let slot: &mut [u8; 24] = (&mut cell[1..]).try_into().unwrap();
        n += 1 + match fixed_f32_into::<D>(v, slot) {
            Some(k) => k,
            None => {
                // Outside the fixed formatter's range (|v| ≥ 1e9): shortest round trip.
                let s = fb.format_finite(v).as_bytes();
                slot[..s.len()].copy_from_slice(s);
                s.len()
            }
        };
    }
    n
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
    fn fast_parse_agrees_with_the_standard_parser() {
        let fixed = [
            "0",
            "-0",
            "+0",
            "0.0",
            "1",
            "-1",
            "1.0",
            "0.02",
            "-9.80665",
            "9.805495",
            "1e5",
            "1E5",
            "1e+5",
            "1e-5",
            "-1.6284444e-12",
            "0.0006753999",
            "6.4238854e-8",
            "3.4028235e38",
            "3.4028236e38",
            "1.1754944e-38",
            "1e-45",
            "1e-30",
            "123456789012345678901",
            ".5",
            "5.",
            ".",
            "-",
            "+",
            "",
            "e5",
            "1e",
            "1e+",
            "1.2.3",
            "1,2",
            "NaN",
            "inf",
            "-inf",
            "0x10",
            " 1",
            "1 ",
            "16777217",
            "16777217.0",
            "33554435",
            "0.1",
            "0.3",
            "9007199254740993",
            "9007199254740992",
            "1e22",
            "1e23",
            "1e-22",
            "1e-23",
            "00000000000000000000000001.5",
            "1.00000000000000000000000",
        ];
        let check = |t: &str| {
            let b = t.as_bytes();
            if let Some(v) = fast_f64(b) {
                assert_eq!(t.parse::<f64>().map(f64::to_bits), Ok(v.to_bits()), "f64 {t:?}");
            }
            if let Some(v) = fast_f32(b) {
                assert_eq!(t.parse::<f32>().map(f32::to_bits), Ok(v.to_bits()), "f32 {t:?}");
            }
        };
        for t in fixed {
            check(t);
        }
        // Shortest round-trip output of many f32 and f64 values (what the writers produce),
        // and decimal strings near f32 midpoints.
        let mut rng = crate::rng::Rng::new(99, 0);
        let mut fast = 0;
        for k in 0..200_000u32 {
            let bits = rng.next_u64();
            let x32 = f32::from_bits(bits as u32);
            let x64 = f64::from_bits(bits);
            let scaled = (rng.normal() * 10f64.powi((k % 40) as i32 - 20)) as f32;
            for t in [
                ryu::Buffer::new().format(x32).to_string(),
                ryu::Buffer::new().format(scaled).to_string(),
                ryu::Buffer::new().format(x64).to_string(),
                format!("{:.9e}", scaled as f64 * (1.0 + 2f64.powi(-25))),
                format!("{}", (bits >> 11) as f64 / 1e10),
            ] {
                check(&t);
                if fast_f32(t.as_bytes()).is_some() {
                    fast += 1;
                }
            }
        }
        assert!(fast > 200_000, "the fast path is taken for most inputs ({fast})");
    }

    /// The number `text` gives on the reader's fast line path ([`plain_decimal`], else
    /// [`scan_decimal`], as in [`fast_row`]), the cell followed by `,` and padding.
    fn fast_cell(text: &str) -> Option<Decimal> {
        let buf = format!("{text},{:0<WINDOW$}", "");
        let buf = buf.as_bytes();
        match plain_decimal(buf, 0) {
            Some((d, end)) if buf[end] == b',' => (end == text.len()).then_some(d),
            _ => scan_decimal(buf).filter(|&(_, n)| n == text.len()).map(|(d, _)| d),
        }
    }

    /// Every way the readers parse `text` agrees with `str::parse` where it gives a value.
    fn check_parsers(text: &str) {
        let b = text.as_bytes();
        let want32 = text.parse::<f32>().map(f32::to_bits);
        let want64 = text.parse::<f64>().map(f64::to_bits);
        if let Some(v) = fast_f64(b) {
            assert_eq!(want64, Ok(v.to_bits()), "fast_f64 {text:?}");
        }
        if let Some(v) = fast_f32(b) {
            assert_eq!(want32, Ok(v.to_bits()), "fast_f32 {text:?}");
        }
        if let Some(d) = fast_cell(text) {
            if let Some(v) = decimal_f64(d) {
                assert_eq!(want64, Ok(v.to_bits()), "line path f64 {text:?}");
            }
            if let Some(v) = decimal_f32(d) {
                assert_eq!(want32, Ok(v.to_bits()), "line path f32 {text:?}");
            }
        }
    }

    #[test]
    fn line_path_numbers_agree_with_the_standard_parser() {
        let mut rng = crate::rng::Rng::new(5, 0);
        let mut plain = 0;
        for k in 0..300_000u32 {
            let bits = rng.next_u64();
            let x32 = f32::from_bits(bits as u32);
            let scaled = (rng.normal() * 10f64.powi((k % 30) as i32 - 15)) as f32;
            // An f32 midpoint (exact in f64) and its f64 neighbours, printed with enough digits
            // to land next to, on and around it: the slow branch of `decimal_f32`.
            let mid = (f64::from(scaled) + f64::from(f32::from_bits(scaled.to_bits() + 1))) / 2.0;
            let near =
                f64::from_bits(mid.to_bits().wrapping_add(rng.next_u64() % 17).wrapping_sub(8));
            for t in [
                ryu::Buffer::new().format(x32).to_string(),
                ryu::Buffer::new().format(scaled).to_string(),
                ryu::Buffer::new().format(f64::from_bits(bits)).to_string(),
                format!("{:.12}", near),
                format!("{:.17}", mid),
                format!("{}", near),
                format!("{:.1$}", scaled, (k % 16) as usize),
                format!("-{:.1$}", rng.uniform() * 1e3, (k % 19) as usize),
                format!("{}.{}", k % 1000, bits % 10u64.pow(1 + k % 15)),
            ] {
                check_parsers(&t);
                if plain_decimal(format!("{t},{:0<WINDOW$}", "").as_bytes(), 0).is_some() {
                    plain += 1;
                }
            }
        }
        assert!(plain > 1_000_000, "the plain form is taken for most inputs ({plain})");
        for t in [
            "0.0",
            "-0.0",
            "1.0",
            "5.",
            ".5",
            "-.5",
            ".",
            "-.",
            "-",
            "",
            "00000001.5",
            "1.2.3",
            "0.00000000000000000001",
            "12345678.1",
            "1234567.123456789012",
            "9.999999999999999999",
            "3.4028235e38",
            "3.4028236e38",
            "340282350000000000000000000000000000000.0",
            "0.000000000000000000000000000000000000011754944",
            "0.000000000000000000000000000000000000011754942",
            "1e-45",
            "16777217.0",
            "9007199254740993.0",
            "0.1",
            "-9.80665",
            "1.0e",
            "1.0e+",
            "1.0e-5",
            "1,0",
            "0x1.0",
        ] {
            check_parsers(t);
        }
    }

    /// Rows (as `Debug` text, so `-0.0` differs from `0.0`) or the error message of each
    /// `next_row` until the end or the first error.
    fn read_all(text: &[u8], fast: bool, capacity: usize) -> Vec<String> {
        let mut out = Vec::new();
        let mut r = match TraceReader::new(io::BufReader::with_capacity(capacity, text)) {
            Ok(r) => r,
            Err(e) => return vec![e.to_string()],
        };
        r.fast = fast;
        loop {
            match r.next_row() {
                Ok(Some(row)) => out.push(format!("{row:?}")),
                Ok(None) => return out,
                Err(e) => {
                    out.push(format!("{e} {:?} {:?}", e.line(), e.column()));
                    return out;
                }
            }
        }
    }

    /// A random trace text: a random header (required, optional and unknown columns in random
    /// order) and rows of plausible and damaged cells, comments, blank lines, `\r\n`.
    fn random_trace(rng: &mut crate::rng::Rng) -> Vec<u8> {
        let pick = |rng: &mut crate::rng::Rng, n: usize| (rng.next_u64() % n as u64) as usize;
        let mut cols: Vec<&str> = vec!["t", "gx", "gy", "gz", "ax", "ay", "az"];
        for group in [&["mx", "my", "mz"][..], &["depth"], &["qw", "qx", "qy", "qz"], &["x"]] {
            if pick(rng, 2) == 0 {
                cols.extend_from_slice(group);
            }
        }
        if pick(rng, 20) == 0 {
            cols.remove(pick(rng, cols.len())); // a missing column
        }
        for i in (1..cols.len()).rev() {
            cols.swap(i, pick(rng, i + 1));
        }
        let mut text = cols.join(",").into_bytes();
        text.push(b'\n');
        let mut t = 0.0f64;
        for _ in 0..pick(rng, 40) {
            match pick(rng, 30) {
                0 => text.extend_from_slice(b"# comment, 1.0\n"),
                1 => text.extend_from_slice(b"\n"),
                2 => text.extend_from_slice(b"  \t\r\n"),
                _ => {}
            }
            t += [0.02, 0.001, 1e-7, 0.0, -0.01, 1234.5][pick(rng, 6)];
            let mut cells: Vec<String> = cols
                .iter()
                .map(|&c| {
                    let v = (rng.normal() * 10f64.powi(pick(rng, 12) as i32 - 8)) as f32;
                    let empty_ok = !matches!(c, "t" | "gx" | "gy" | "gz" | "ax" | "ay" | "az");
                    match pick(rng, 40) {
                        0 => String::new(),
                        1 => "NaN".into(),
                        2 => "-inf".into(),
                        3 => format!(" {v}"),
                        4 => format!("{v}\r"),
                        5 => "1e5".into(),
                        6 => "x".into(),
                        7 => "é".into(),
                        8 => format!("{v:e}"),
                        9 => format!("+{}", v.abs()),
                        10 => format!("{:.20}", v),
                        11 => "1.5.5".into(),
                        12 => "-".into(),
                        _ if c == "t" => ryu::Buffer::new().format(t).to_string(),
                        _ if empty_ok && pick(rng, 3) == 0 => String::new(),
                        _ => ryu::Buffer::new().format(v).to_string(),
                    }
                })
                .collect();
            match pick(rng, 50) {
                0 => {
                    cells.pop();
                }
                1 => cells.push("1".into()),
                _ => {}
            }
            text.extend_from_slice(cells.join(",").as_bytes());
            text.extend_from_slice(if pick(rng, 10) == 0 { b"\r\n" } else { b"\n" });
        }
        if pick(rng, 4) == 0 {
            text.pop(); // no final newline
        }
        text
    }

    #[test]
    fn line_fast_path_gives_the_slow_paths_rows_and_errors() {
        let mut rng = crate::rng::Rng::new(17, 0);
        for case in 0..20_000 {
            let text = random_trace(&mut rng);
            // Small buffers put lines across buffer ends.
            let cap = [16, 37, 100, 256, 1 << 16][case % 5];
            let slow = read_all(&text, false, 1 << 16);
            assert_eq!(
                read_all(&text, true, cap),
                slow,
                "case {case}, capacity {cap}:\n{}",
                String::from_utf8_lossy(&text)
            );
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(5000))]

        /// Any `f32`, written shortest round trip (as the trace writer does), with a fixed
        /// number of decimals, or with an exponent.
        #[test]
        fn prop_f32_texts_parse_exactly(bits in proptest::num::u32::ANY, decimals in 0usize..20) {
            let x = f32::from_bits(bits);
            check_parsers(ryu::Buffer::new().format(x));
            check_parsers(&format!("{x:.decimals$}"));
            check_parsers(&format!("{x:e}"));
        }

        /// Any `f64`, likewise (the `t` column).
        #[test]
        fn prop_f64_texts_parse_exactly(bits in proptest::num::u64::ANY, decimals in 0usize..20) {
            let x = f64::from_bits(bits);
            check_parsers(ryu::Buffer::new().format(x));
            check_parsers(&format!("{x:.decimals$}"));
        }

        /// Decimal numbers of every shape the fast paths take and just beyond (more digits,
        /// exponents).
        #[test]
        fn prop_decimal_texts_parse_exactly(
            sign in "[-+]?",
            int in "[0-9]{0,10}",
            frac in proptest::option::of("[0-9]{0,20}"),
            exp in proptest::option::of(-45i32..45),
        ) {
            let frac = frac.map(|f| format!(".{f}")).unwrap_or_default();
            let exp = exp.map(|e| format!("e{e}")).unwrap_or_default();
            check_parsers(&format!("{sign}{int}{frac}{exp}"));
        }

        /// Arbitrary strings of number characters.
        #[test]
        fn prop_number_like_texts(text in "[0-9.eE+-]{0,24}") {
            check_parsers(&text);
        }

        /// Whole traces: the fast line path reads the slow path's rows and errors.
        #[test]
        fn prop_fast_and_slow_line_paths_agree(seed in proptest::num::u64::ANY, cap in 8usize..300) {
            let text = random_trace(&mut crate::rng::Rng::new(seed, 0));
            proptest::prop_assert_eq!(read_all(&text, true, cap), read_all(&text, false, 1 << 16));
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
