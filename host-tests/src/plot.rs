//! `plot`: truth vs estimate and the error, per Euler axis, as a PNG or an SVG (plotters'
//! bitmap and SVG backends, chosen by the output's extension).
//!
//! The rows are streamed: each series keeps, per column of time, only its first, last, lowest
//! and highest sample ([`Decimator`], at least 2,048 columns across the trace, finer than the
//! pixels), so memory does not grow with the trace and every spike still shows. Angles break
//! their line where consecutive samples wrap at ±180° instead of drawing a vertical bar. The
//! truth is a wide light line under the estimate's thin dark one; the legend sits above the
//! panels, outside the data; without truth columns there are no truth lines, no error panels
//! and no "truth" legend.
//!
//! Text uses `ab_glyph` with a TrueType font read at run time: the file named by the
//! `HOST_TESTS_FONT` environment variable, else the first of a few common system paths
//! (DejaVu Sans, Liberation Sans, FreeSans). Without a font the figure is drawn without text
//! (`HOST_TESTS_FONT=none` forces that).

use std::io::BufRead;
use std::path::Path;
use std::sync::OnceLock;

use plotters::prelude::*;

use crate::replay::{truth_euler_deg, wrap_deg};
use crate::trace::{CsvReader, TraceError};

/// Font family name the figure uses.
const FAMILY: &str = "sans-serif";

const FONT_PATHS: [&str; 6] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/truetype/freefont/FreeSans.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
];

/// Register a font for [`FAMILY`] once; true when text can be drawn.
fn font_available() -> bool {
    static FONT: OnceLock<bool> = OnceLock::new();
    *FONT.get_or_init(|| {
        let candidates: Vec<String> = match std::env::var("HOST_TESTS_FONT") {
            Ok(v) if v == "none" => return false,
            Ok(v) if !v.is_empty() => vec![v],
            _ => FONT_PATHS.iter().map(|s| s.to_string()).collect(),
        };
        for p in candidates {
            if let Ok(bytes) = std::fs::read(&p) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font(FAMILY, FontStyle::Normal, bytes).is_ok() {
                    return true;
                }
            }
        }
        false
    })
}

/// Figure size, pixels (the SVG's user units).
pub const SIZE: (u32, u32) = (1600, 1050);

/// Columns a [`Decimator`] keeps at most; it ends with at least half as many across the data,
/// more than the pixel columns of any panel.
pub const COLUMNS: usize = 4096;

/// One column of a decimated series: its first, lowest, highest and last samples `(t, v)`,
/// and whether an angle wrapped (±180°) between two consecutive samples ending in it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Column {
    /// The first sample.
    pub first: (f64, f64),
    /// The lowest sample (the first of equals).
    pub min: (f64, f64),
    /// The highest sample (the first of equals).
    pub max: (f64, f64),
    /// The last sample.
    pub last: (f64, f64),
    /// An angle wrapped between two consecutive samples, the later one in this column.
    pub wrap: bool,
}

impl Column {
    fn new(p: (f64, f64), wrap: bool) -> Self {
        Column { first: p, min: p, max: p, last: p, wrap }
    }

    fn add(&mut self, p: (f64, f64), wrap: bool) {
        if p.1 < self.min.1 {
            self.min = p;
        }
        if p.1 > self.max.1 {
            self.max = p;
        }
        self.last = p;
        self.wrap |= wrap;
    }

    fn merge(a: Option<Column>, b: Option<Column>) -> Option<Column> {
        match (a, b) {
            (Some(mut a), Some(b)) => {
                if b.min.1 < a.min.1 {
                    a.min = b.min;
                }
                if b.max.1 > a.max.1 {
                    a.max = b.max;
                }
                a.last = b.last;
                a.wrap |= b.wrap;
                Some(a)
            }
            (a, None) => a,
            (None, b) => b,
        }
    }

    /// The column's distinct samples in time order.
    fn points(&self) -> impl Iterator<Item = (f64, f64)> {
        let (a, b) =
            if self.min.0 <= self.max.0 { (self.min, self.max) } else { (self.max, self.min) };
        let mut pts = [Some(self.first), Some(a), Some(b), Some(self.last)];
        for i in 1..4 {
            if (0..i).any(|j| pts[j] == pts[i]) {
                pts[i] = None;
            }
        }
        pts.into_iter().flatten()
    }
}

/// Streaming min/max decimation: samples `(t, v)` in increasing time go into columns of width
/// `dt` from the first sample's time; when a sample falls past the last column, neighbouring
/// columns merge in pairs and `dt` doubles. Memory: [`COLUMNS`] columns, whatever the length.
#[derive(Clone, Debug)]
pub struct Decimator {
    t0: Option<f64>,
    dt: f64,
    cap: usize,
    cols: Vec<Option<Column>>,
    prev: Option<f64>,
    angle: bool,
}

impl Decimator {
    /// At most `cap` columns; `angle`: a series in degrees that wraps at ±180°.
    pub fn new(cap: usize, angle: bool) -> Self {
        Decimator { t0: None, dt: 1e-9, cap: cap.max(2), cols: Vec::new(), prev: None, angle }
    }

    /// Add a sample; non-finite values are left out.
    pub fn push(&mut self, t: f64, v: f64) {
        if !t.is_finite() || !v.is_finite() {
            return;
        }
        let t0 = *self.t0.get_or_insert(t);
        let mut x = ((t - t0) / self.dt).max(0.0);
        while x >= self.cap as f64 {
            self.halve();
            x = ((t - t0) / self.dt).max(0.0);
        }
        let i = x as usize;
        let wrap = self.angle && self.prev.is_some_and(|p| (v - p).abs() > 180.0);
        self.prev = Some(v);
        if i >= self.cols.len() {
            self.cols.resize(i + 1, None);
        }
        match &mut self.cols[i] {
            Some(c) => c.add((t, v), wrap),
            slot => *slot = Some(Column::new((t, v), wrap)),
        }
    }

    fn halve(&mut self) {
        let old = std::mem::take(&mut self.cols);
        self.cols =
            old.chunks(2).map(|c| Column::merge(c[0], c.get(1).copied().flatten())).collect();
        self.dt *= 2.0;
    }

    /// The columns kept, with their index (column `i` covers `[t0 + i dt, t0 + (i + 1) dt)`).
    pub fn columns(&self) -> impl Iterator<Item = (usize, &Column)> {
        self.cols.iter().enumerate().filter_map(|(i, c)| c.as_ref().map(|c| (i, c)))
    }

    /// The first sample's time and the column width.
    pub fn grid(&self) -> Option<(f64, f64)> {
        self.t0.map(|t0| (t0, self.dt))
    }

    /// Lowest and highest value.
    pub fn y_bounds(&self) -> Option<(f64, f64)> {
        self.columns().fold(None, |acc, (_, c)| match acc {
            None => Some((c.min.1, c.max.1)),
            Some((lo, hi)) => Some((c.min.1.min(lo), c.max.1.max(hi))),
        })
    }

    /// The polylines to draw: the columns' points in time order, broken where an angle wrapped
    /// (a step of more than 180° into a column where consecutive samples wrapped).
    pub fn segments(&self) -> Vec<Vec<(f64, f64)>> {
        let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
        let mut cur: Vec<(f64, f64)> = Vec::new();
        for (_, c) in self.columns() {
            for p in c.points() {
                if let Some(q) = cur.last() {
                    if c.wrap && (p.1 - q.1).abs() > 180.0 {
                        out.push(std::mem::take(&mut cur));
                    }
                }
                cur.push(p);
            }
        }
        if !cur.is_empty() {
            out.push(cur);
        }
        out
    }
}

/// What a panel shows: an axis's angles (truth and estimate) or its error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Panel {
    /// Truth and estimate of an axis (0 roll, 1 pitch, 2 yaw).
    Angle(usize),
    /// The error of an axis.
    Error(usize),
}

/// The panels and the grid `(rows, columns)` they fill: angles on the left and errors on the
/// right with truth; the angles alone without.
pub fn layout(has_truth: bool) -> (Vec<Panel>, (usize, usize)) {
    let mut panels = Vec::new();
    for axis in 0..3 {
        panels.push(Panel::Angle(axis));
        if has_truth {
            panels.push(Panel::Error(axis));
        }
    }
    (panels, (3, if has_truth { 2 } else { 1 }))
}

/// Decimals for tick labels on an axis spanning `span`: enough for plotters' steps (about a
/// tenth of the span, rounded to 1, 2 or 5 × 10^k).
fn decimals(span: f64) -> usize {
    if !(span.is_finite() && span > 0.0) {
        return 1;
    }
    let step = span / 10.0;
    (-step.log10().floor()).clamp(0.0, 6.0) as usize
}

/// A tick label with `decimals` decimals; never "-0", "-0.0" and so on.
pub fn tick_label(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    match s.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| c == '0' || c == '.') => rest.to_string(),
        _ => s,
    }
}

/// Output format, from the output path's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// `.png`
    Png,
    /// `.svg`
    Svg,
}

impl Format {
    /// `.png` or `.svg` (any case); anything else is an error that names the two.
    pub fn of(path: &Path) -> Result<Format, String> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(Format::Png),
            Some("svg") => Ok(Format::Svg),
            Some(e) => Err(format!(
                "{}: unknown image format \".{e}\" (the output must end in .png or .svg)",
                path.display()
            )),
            None => Err(format!(
                "{}: no image format (the output must end in .png or .svg)",
                path.display()
            )),
        }
    }
}

/// The decimated series of a figure, filled row by row.
pub struct Figure {
    truth: [Decimator; 3],
    estimate: [Decimator; 3],
    error: [Decimator; 3],
    rows: u64,
    truth_rows: u64,
    /// Sum of squared errors (deg²) per axis and the rows counted, after initialisation.
    sq_err: [f64; 3],
    scored_rows: u64,
    /// The initialisation window: from the first row to the first row without the
    /// `INITIALISING` flag (the estimate's `flags` column), s.
    init: Option<(f64, f64)>,
    initialising: bool,
    /// The title's first part (the trace, the filter); the RMSE is added to it.
    pub title: String,
}

impl Default for Figure {
    fn default() -> Self {
        let d = || Decimator::new(COLUMNS, true);
        Figure {
            truth: [d(), d(), d()],
            estimate: [d(), d(), d()],
            error: [d(), d(), d()],
            rows: 0,
            truth_rows: 0,
            sq_err: [0.0; 3],
            scored_rows: 0,
            init: None,
            initialising: false,
            title: String::new(),
        }
    }
}

impl Figure {
    /// One row: time, the estimate's Euler angles (deg), the truth's Euler angles (deg).
    pub fn add(&mut self, t: f64, est_deg: [f64; 3], truth_deg: Option<[f64; 3]>) {
        if let Some(te) = truth_deg {
            self.truth_rows += 1;
            for (d, v) in self.truth.iter_mut().zip(te) {
                d.push(t, v);
            }
        }
        self.add_estimate(t, est_deg, truth_deg);
    }

    /// [`Figure::add`] but for the truth series (filled elsewhere).
    fn add_estimate(&mut self, t: f64, est_deg: [f64; 3], truth_deg: Option<[f64; 3]>) {
        self.rows += 1;
        for (d, v) in self.estimate.iter_mut().zip(est_deg) {
            d.push(t, v);
        }
        if let Some(te) = truth_deg {
            for i in 0..3 {
                let e = wrap_deg(est_deg[i] - te[i]);
                self.error[i].push(t, e);
                if !self.initialising {
                    self.sq_err[i] += e * e;
                }
            }
            if !self.initialising {
                self.scored_rows += 1;
            }
        }
    }

    /// The estimate's flags of the row about to be added: rows with `INITIALISING` (bit 0) at
    /// the start make the initialisation window, shaded and left out of the RMSE.
    pub fn flags(&mut self, t: f64, flags: u32) {
        let init = flags & u32::from(ekf_core::Flags::INITIALISING.bits()) != 0;
        if self.rows == 0 {
            self.initialising = init;
            if init {
                self.init = Some((t, t));
            }
        } else if self.initialising {
            if let Some(w) = &mut self.init {
                w.1 = t;
            }
            self.initialising = init;
        }
    }

    /// RMSE per axis (roll, pitch, yaw; deg) over the rows with truth after initialisation.
    pub fn rmse_deg(&self) -> Option<[f64; 3]> {
        (self.scored_rows > 0).then(|| self.sq_err.map(|s| (s / self.scored_rows as f64).sqrt()))
    }

    /// The initialisation window `(start, end)`, s, when the estimate has flags that say so.
    pub fn init_window(&self) -> Option<(f64, f64)> {
        self.init
    }

    /// The title line: [`Figure::title`] and the RMSE.
    pub fn title_line(&self) -> String {
        let mut t = self.title.clone();
        match self.rmse_deg() {
            Some([r, p, y]) => {
                if !t.is_empty() {
                    t.push_str("  ·  ");
                }
                let after = if self.init.is_some() { " after initialisation" } else { "" };
                t.push_str(&format!("RMSE{after}: roll {r:.3}°, pitch {p:.3}°, yaw {y:.3}°"));
            }
            None if t.is_empty() => t.push_str("attitude estimate (the trace has no truth)"),
            None => t.push_str("  ·  no truth in the trace"),
        }
        t
    }

    /// Rows added.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Whether any row had truth.
    pub fn has_truth(&self) -> bool {
        self.truth_rows > 0
    }

    fn x_range(&self) -> std::ops::Range<f64> {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (_, c) in self.estimate[0].columns() {
            lo = lo.min(c.first.0);
            hi = hi.max(c.last.0);
        }
        if !lo.is_finite() {
            return 0.0..1.0;
        }
        lo..hi.max(lo + 1e-3)
    }
}

/// Rows handed from a reading thread to the figure, in chunks.
const CHUNK: usize = 4096;

type Chunks<T> = std::sync::mpsc::Receiver<Result<Vec<T>, String>>;
/// A trace row for the figure: time, truth Euler angles (deg).
type TraceItem = (f64, Option<[f64; 3]>);
/// An estimate row for the figure: time, Euler angles (deg).
type EstItem = (f64, [f64; 3], u32);

/// The next item of a chunked stream: `Ok(None)` at its end (the sender gone).
fn pull<T>(rx: &Chunks<T>, cur: &mut std::vec::IntoIter<T>) -> Result<Option<T>, String> {
    loop {
        if let Some(x) = cur.next() {
            return Ok(Some(x));
        }
        match rx.recv() {
            Ok(Ok(v)) => *cur = v.into_iter(),
            Ok(Err(e)) => return Err(e),
            Err(_) => return Ok(None),
        }
    }
}

/// A trace row's time, s, and truth quaternion when the trace has one.
type TimeTruth = (f64, Option<[f32; 4]>);

/// Read a trace and its estimate file together, row by row, into a [`Figure`]. Each file is
/// parsed on a thread of its own (the trace's also draws up the truth series); this one fills
/// the estimate and error series. Rows are matched by index and must have the same times.
/// Messages name `trace_name` and `est_name`.
pub fn read_figure<A, B>(
    trace: A,
    est: B,
    trace_name: &str,
    est_name: &str,
) -> Result<Figure, String>
where
    A: BufRead + Send,
    B: BufRead + Send,
{
    let terr = |e: TraceError| format!("{trace_name}: {e}");
    let eerr = |e: TraceError| format!("{est_name}: {e}");
    // The trace's time and truth only: the plot draws nothing else, and `replay`, which made
    // the estimate, has read and checked every cell of the sensors (this halves the reading).
    let mut trace = CsvReader::new(trace).map_err(terr)?;
    let t_idx = trace.require("t").map_err(terr)?;
    let q_idx = trace.group(["qw", "qx", "qy", "qz"]).map_err(terr)?;
    let mut next_trace = move || -> Result<Option<TimeTruth>, TraceError> {
        let Some(rec) = trace.next_record()? else {
            return Ok(None);
        };
        let t = rec.f64(t_idx)?;
        let q = match &q_idx {
            Some(idx) => rec.group(idx)?,
            None => None,
        };
        Ok(Some((t, q)))
    };
    // The estimate's time and Euler angles only (the columns `EstimateReader` requires, checked
    // the same way, but without parsing the quaternion, bias and flags the plot does not draw).
    let mut est = CsvReader::new(est).map_err(eerr)?;
    let mut idx = [0; 8];
    for (i, name) in ["t", "qw", "qx", "qy", "qz", "roll", "pitch", "yaw"].iter().enumerate() {
        idx[i] = est.require(name).map_err(eerr)?;
    }
    let [ti, _, _, _, _, ri, pi, yi] = idx;
    // The flags, when the file has them: the initialisation window.
    let fi = est.index_of("flags");
    let mut next_est = move || -> Result<Option<EstItem>, TraceError> {
        let Some(rec) = est.next_record()? else {
            return Ok(None);
        };
        let t = rec.f64(ti)?;
        let flags = match fi {
            Some(i) => rec.f64(i)? as u32,
            None => 0,
        };
        Ok(Some((t, [rec.f32(ri)?, rec.f32(pi)?, rec.f32(yi)?].map(f64::from), flags)))
    };
    let (tx, rx) = std::sync::mpsc::sync_channel(4);
    let (etx, erx) = std::sync::mpsc::sync_channel(4);
    let mut fig = Figure::default();
    std::thread::scope(|s| -> Result<(), String> {
        // Owned here: an early return drops them, which ends the reading threads (their sends
        // fail) before the scope waits for them.
        let rx: Chunks<TraceItem> = rx;
        let erx: Chunks<EstItem> = erx;
        let truth_thread = s.spawn(move || {
            let d = || Decimator::new(COLUMNS, true);
            let mut truth = [d(), d(), d()];
            let mut truth_rows = 0u64;
            let mut chunk = Vec::with_capacity(CHUNK);
            loop {
                match next_trace() {
                    Ok(Some((t, q))) => {
                        let te = q.map(truth_euler_deg);
                        if let Some(te) = te {
                            truth_rows += 1;
                            for (d, v) in truth.iter_mut().zip(te) {
                                d.push(t, v);
                            }
                        }
                        chunk.push((t, te));
                    }
                    Ok(None) => {
                        let _ = tx.send(Ok(chunk));
                        return (truth, truth_rows);
                    }
                    Err(e) => {
                        let _ = tx.send(Err(terr(e)));
                        return (truth, truth_rows);
                    }
                }
                if chunk.len() == CHUNK
                    && tx
                        .send(Ok(std::mem::replace(&mut chunk, Vec::with_capacity(CHUNK))))
                        .is_err()
                {
                    return (truth, truth_rows);
                }
            }
        });
        s.spawn(move || {
            let mut chunk = Vec::with_capacity(CHUNK);
            loop {
                match next_est() {
                    Ok(Some(r)) => chunk.push(r),
                    Ok(None) => {
                        let _ = etx.send(Ok(chunk));
                        return;
                    }
                    Err(e) => {
                        let _ = etx.send(Err(eerr(e)));
                        return;
                    }
                }
                if chunk.len() == CHUNK
                    && etx
                        .send(Ok(std::mem::replace(&mut chunk, Vec::with_capacity(CHUNK))))
                        .is_err()
                {
                    return;
                }
            }
        });
        let (mut tcur, mut ecur) = (Vec::new().into_iter(), Vec::new().into_iter());
        let (mut trace_rows, mut est_rows) = (0u64, 0u64);
        loop {
            match (pull(&rx, &mut tcur)?, pull(&erx, &mut ecur)?) {
                (Some((t, truth)), Some((et, euler, flags))) => {
                    trace_rows += 1;
                    est_rows += 1;
                    if (t - et).abs() > 1e-6 * (1.0 + t.abs()) {
                        return Err(format!(
                            "row {trace_rows}: the estimate's time {et} differs from the \
                             trace's {t} (one estimate row per trace row, from `replay`)"
                        ));
                    }
                    fig.flags(t, flags);
                    fig.add_estimate(t, euler, truth);
                }
                (Some(_), None) => {
                    trace_rows += 1;
                    while pull(&rx, &mut tcur)?.is_some() {
                        trace_rows += 1;
                    }
                    break;
                }
                (None, Some(_)) => {
                    est_rows += 1;
                    while pull(&erx, &mut ecur)?.is_some() {
                        est_rows += 1;
                    }
                    break;
                }
                (None, None) => break,
            }
        }
        if est_rows != trace_rows {
            return Err(format!(
                "the estimate has {est_rows} rows but the trace has {trace_rows} (one estimate \
                 row per trace row, from `replay`)"
            ));
        }
        let (truth, truth_rows) =
            truth_thread.join().map_err(|_| "the trace's reading thread failed".to_string())?;
        fig.truth = truth;
        fig.truth_rows = truth_rows;
        Ok(())
    })?;
    if fig.rows == 0 {
        return Err("no rows to plot".into());
    }
    Ok(fig)
}

/// Truth: a wide light line, underneath.
const TRUTH: RGBColor = RGBColor(150, 185, 235);
/// Estimate: a thin dark line, on top.
const ESTIMATE: RGBColor = RGBColor(150, 20, 20);
/// Error.
const ERROR: RGBColor = RGBColor(20, 40, 140);
/// The initialisation window's shade.
const INIT: RGBColor = RGBColor(225, 225, 225);

fn y_range(series: &[&Decimator]) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for d in series {
        if let Some((a, b)) = d.y_bounds() {
            lo = lo.min(a);
            hi = hi.max(b);
        }
    }
    if !lo.is_finite() || !hi.is_finite() {
        return -1.0..1.0;
    }
    let pad = ((hi - lo) * 0.05).max(1e-3);
    (lo - pad)..(hi + pad)
}

type DrawResult = Result<(), Box<dyn std::error::Error>>;

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    fig: &Figure,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let text = font_available();
    let names = ["roll", "pitch", "yaw"];
    let has_truth = fig.has_truth();
    root.fill(&WHITE)?;
    let body = if text {
        let (head, body) = root.split_vertically(70);
        head.draw(&Text::new(fig.title_line(), (20, 8), (FAMILY, 22).into_font()))?;
        // The legend, above the panels: outside the data.
        let mut entries = vec![];
        if has_truth {
            entries.push(("truth", TRUTH.stroke_width(6)));
        }
        entries.push(("estimate", ESTIMATE.stroke_width(1)));
        if has_truth {
            entries.push(("error (estimate - truth)", ERROR.stroke_width(1)));
        }
        if fig.init.is_some() {
            entries.push(("initialisation", INIT.stroke_width(10)));
        }
        let mut x = 20;
        for (label, style) in entries {
            head.draw(&PathElement::new(vec![(x, 52), (x + 40, 52)], style))?;
            head.draw(&Text::new(label, (x + 48, 44), (FAMILY, 16).into_font()))?;
            x += 70 + 9 * label.len() as i32;
        }
        body
    } else {
        root.clone()
    };
    let (panels, grid) = layout(has_truth);
    let areas = body.split_evenly(grid);
    let x_range = fig.x_range();
    let x_dec = decimals(x_range.end - x_range.start);
    for (panel, area) in panels.iter().zip(&areas) {
        let (series, caption): (Vec<(&Decimator, ShapeStyle)>, String) = match *panel {
            Panel::Angle(i) => {
                let mut v = Vec::new();
                if has_truth {
                    v.push((&fig.truth[i], TRUTH.stroke_width(5)));
                }
                v.push((&fig.estimate[i], ESTIMATE.stroke_width(1)));
                (v, format!("{} (deg)", names[i]))
            }
            Panel::Error(i) => {
                (vec![(&fig.error[i], ERROR.stroke_width(1))], format!("{} error (deg)", names[i]))
            }
        };
        let refs: Vec<&Decimator> = series.iter().map(|s| s.0).collect();
        let y = y_range(&refs);
        let y_dec = decimals(y.end - y.start);
        let mut builder = ChartBuilder::on(area);
        builder.margin(8);
        if text {
            builder.caption(caption, (FAMILY, 18)).x_label_area_size(40).y_label_area_size(60);
        }
        let mut chart = builder.build_cartesian_2d(x_range.clone(), y)?;
        let mut mesh = chart.configure_mesh();
        let xf = move |v: &f64| tick_label(*v, x_dec);
        let yf = move |v: &f64| tick_label(*v, y_dec);
        if text {
            mesh.x_desc("t (s)")
                .label_style((FAMILY, 14))
                .x_label_formatter(&xf)
                .y_label_formatter(&yf);
        } else {
            mesh.x_labels(0).y_labels(0);
        }
        mesh.draw()?;
        // The initialisation window, shaded under the series.
        if let Some((t0, t1)) = fig.init {
            let (y0, y1) = (chart.y_range().start, chart.y_range().end);
            chart.draw_series(std::iter::once(Rectangle::new(
                [(t0, y0), (t1.max(t0), y1)],
                INIT.filled(),
            )))?;
        }
        // In order: the truth first, under the estimate.
        for (d, style) in series {
            for seg in d.segments() {
                chart.draw_series(LineSeries::new(seg, style))?;
            }
        }
    }
    root.present()?;
    Ok(())
}

/// Draw `fig` into a PNG file at `path` (written directly; the caller makes it all or
/// nothing, e.g. with [`crate::output::produce_atomically`]).
pub fn render_png(fig: &Figure, path: &Path, size: (u32, u32)) -> Result<(), String> {
    draw(BitMapBackend::new(path, size).into_drawing_area(), fig)
        .map_err(|e| format!("drawing failed: {e}"))
}

/// Draw `fig` as SVG text.
pub fn render_svg(fig: &Figure, size: (u32, u32)) -> Result<String, String> {
    let mut s = String::new();
    draw(SVGBackend::with_string(&mut s, size).into_drawing_area(), fig)
        .map_err(|e| format!("drawing failed: {e}"))?;
    Ok(s)
}

/// A `--size WIDTHxHEIGHT` in pixels, each 400…8000.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("'{s}': the size is WIDTHxHEIGHT in pixels, each 400 to 8000 (1600x1050)");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h): (u32, u32) = (w.parse().map_err(|_| bad())?, h.parse().map_err(|_| bad())?);
    if !(400..=8000).contains(&w) || !(400..=8000).contains(&h) {
        return Err(bad());
    }
    Ok((w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic pseudo-random sequence in [-1, 1).
    fn noise(k: u64) -> f64 {
        let x = k.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(17) ^ 0x5555;
        (x.wrapping_mul(0xBF58_476D_1CE4_E5B9) >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    #[test]
    fn decimation_keeps_each_columns_min_and_max_exactly() {
        let n = 100_000u64;
        let samples: Vec<(f64, f64)> =
            (0..n).map(|k| (10.0 + k as f64 * 0.02, 50.0 * noise(k))).collect();
        let mut d = Decimator::new(256, false);
        for &(t, v) in &samples {
            d.push(t, v);
        }
        let (t0, dt) = d.grid().unwrap();
        let cols: Vec<(usize, Column)> = d.columns().map(|(i, c)| (i, *c)).collect();
        assert!(cols.len() <= 256 && cols.len() >= 128, "{}", cols.len());
        for (i, c) in &cols {
            let inside: Vec<(f64, f64)> =
                samples.iter().copied().filter(|p| (((p.0 - t0) / dt) as usize) == *i).collect();
            let min = inside.iter().copied().fold(inside[0], |a, p| if p.1 < a.1 { p } else { a });
            let max = inside.iter().copied().fold(inside[0], |a, p| if p.1 > a.1 { p } else { a });
            assert_eq!(c.min, min, "column {i}");
            assert_eq!(c.max, max, "column {i}");
            assert_eq!(c.first, inside[0]);
            assert_eq!(c.last, *inside.last().unwrap());
        }
        // Every sample is in some column; a single spike survives.
        let total: usize = samples
            .iter()
            .filter(|p| cols.iter().any(|(i, _)| (((p.0 - t0) / dt) as usize) == *i))
            .count();
        assert_eq!(total, n as usize);
        let mut s = Decimator::new(100, false);
        for k in 0..1_000_000u64 {
            s.push(k as f64, if k == 512_345 { 99.0 } else { 0.0 });
        }
        assert!(s.columns().any(|(_, c)| c.max.1 == 99.0));
        assert!(s.columns().count() <= 100);
        // The polyline runs in time order.
        let seg = s.segments();
        assert_eq!(seg.len(), 1);
        assert!(seg[0].windows(2).all(|w| w[0].0 < w[1].0));
    }

    #[test]
    fn wraps_break_the_line_and_fast_turns_do_not() {
        // Yaw turning through +180 -> -180 twice: three pieces, none with a step over 180°.
        let mut d = Decimator::new(64, true);
        let mut yaw = 170.0;
        for k in 0..2000 {
            d.push(k as f64 * 0.01, wrap_deg(yaw));
            yaw += if k < 1000 { 0.03 } else { -0.03 };
        }
        let seg = d.segments();
        assert_eq!(seg.len(), 3, "{}", seg.len());
        for s in &seg {
            assert!(s.windows(2).all(|w| (w[1].1 - w[0].1).abs() < 180.0), "{s:?}");
        }
        // Without the wrap, the same jump would have been one piece with a vertical bar.
        let mut d = Decimator::new(64, false);
        let mut yaw = 170.0;
        for k in 0..2000 {
            d.push(k as f64 * 0.01, wrap_deg(yaw));
            yaw += if k < 1000 { 0.03 } else { -0.03 };
        }
        assert_eq!(d.segments().len(), 1);
        // For an angle, any step over 180° between consecutive samples is a wrap.
        let mut d = Decimator::new(64, true);
        for (k, v) in [0.0, 150.0, -150.0, 150.0].into_iter().enumerate() {
            d.push(k as f64, v);
        }
        assert_eq!(d.segments().len(), 3);
    }

    #[test]
    fn tick_labels_never_read_minus_zero() {
        for v in [-0.0, -1e-9, -0.00004, 0.0, 1e-12] {
            for dec in 0..4 {
                let s = tick_label(v, dec);
                assert!(!s.starts_with('-'), "{v} {dec}: {s}");
            }
        }
        assert_eq!(tick_label(-0.04, 1), "0.0");
        assert_eq!(tick_label(-0.05001, 1), "-0.1");
        assert_eq!(tick_label(-2.0, 0), "-2");
        assert_eq!(tick_label(12.5, 1), "12.5");
        assert_eq!(decimals(20.0), 0);
        assert_eq!(decimals(3.0), 1);
        assert_eq!(decimals(0.05), 3);
    }

    #[test]
    fn without_truth_there_are_no_error_panels() {
        let (p, grid) = layout(false);
        assert_eq!(grid, (3, 1));
        assert_eq!(p, vec![Panel::Angle(0), Panel::Angle(1), Panel::Angle(2)]);
        let (p, grid) = layout(true);
        assert_eq!(grid, (3, 2));
        assert_eq!(p.iter().filter(|p| matches!(p, Panel::Error(_))).count(), 3);
    }

    #[test]
    fn format_by_extension() {
        assert_eq!(Format::of(Path::new("a.png")), Ok(Format::Png));
        assert_eq!(Format::of(Path::new("a.SVG")), Ok(Format::Svg));
        let e = Format::of(Path::new("a.jpg")).unwrap_err();
        assert!(e.contains(".png or .svg"), "{e}");
        assert!(Format::of(Path::new("-")).is_err());
    }
}
