//! Replay a trace through `ekf-core`: conditioning ([`Conditioner`]), then one of the filters,
//! one estimate row per input row, and the RMSE against the truth when the trace has it.
//!
//! `dt` of a row is its time minus the previous row's; the first row gets the second row's
//! spacing (the filters only use it to time the initialisation window).
//!
//! **RMSE** (per axis, degrees): over the rows with `t ≥ t₀ + window`, where `t₀` is the first
//! row's time and `window` the configured initialisation window (`init.window_s`, 10 s by
//! default), of the Z-Y-X Euler error `estimate − truth` (truth Euler angles computed in `f64`
//! from the truth quaternion; every error wrapped into [−180°, 180°)). Rows without truth are
//! skipped.

use std::io::{self, BufRead, Write};
use std::time::Instant;

use ekf_core::conditioning::Conditioner;
use ekf_core::{AttitudeFilter, Complementary, Ekf, GyroOnly, ImuSample, SsUkf, Ukf, Vec3};

use crate::config::ReplayConfig;
use crate::sim::DEG;
use crate::trace::{EstimateRow, EstimateWriter, TraceError, TraceReader, TraceRow};

/// The filters a replay can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterKind {
    /// [`Ekf`].
    Ekf,
    /// [`Ukf`].
    Ukf,
    /// [`SsUkf`].
    SsUkf,
    /// [`Complementary`].
    Cf,
    /// [`GyroOnly`].
    Gyro,
}

impl FilterKind {
    /// Every kind.
    pub const ALL: [FilterKind; 5] =
        [FilterKind::Ekf, FilterKind::Ukf, FilterKind::SsUkf, FilterKind::Cf, FilterKind::Gyro];

    /// Command-line name.
    pub fn name(self) -> &'static str {
        match self {
            FilterKind::Ekf => "ekf",
            FilterKind::Ukf => "ukf",
            FilterKind::SsUkf => "ssukf",
            FilterKind::Cf => "cf",
            FilterKind::Gyro => "gyro",
        }
    }

    /// Parse a command-line name.
    pub fn from_name(s: &str) -> Option<FilterKind> {
        FilterKind::ALL.into_iter().find(|k| k.name() == s)
    }
}

impl ReplayConfig {
    /// A new filter of `kind` with these settings.
    pub fn make_filter(&self, kind: FilterKind) -> Box<dyn AttitudeFilter> {
        let s = self.settings;
        match kind {
            FilterKind::Ekf => Box::new(Ekf::new(s)),
            FilterKind::Ukf => Box::new(Ukf::new(s, self.ukf)),
            FilterKind::SsUkf => Box::new(SsUkf::new(s, self.ssukf)),
            FilterKind::Cf => Box::new(Complementary::new(s, self.complementary)),
            FilterKind::Gyro => Box::new(GyroOnly::new(s)),
        }
    }
}

/// Why a replay failed.
#[derive(Debug)]
pub enum ReplayError {
    /// The input is malformed.
    Trace(TraceError),
    /// Writing the output failed.
    Io(io::Error),
}

impl std::fmt::Display for ReplayError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReplayError::Trace(e) => e.fmt(f),
            ReplayError::Io(e) => write!(f, "write error: {e}"),
        }
    }
}

impl std::error::Error for ReplayError {}

impl From<TraceError> for ReplayError {
    fn from(e: TraceError) -> Self {
        ReplayError::Trace(e)
    }
}

impl From<io::Error> for ReplayError {
    fn from(e: io::Error) -> Self {
        ReplayError::Io(e)
    }
}

/// Wrap an angle difference in degrees into [−180, 180) (returned as it is when already
/// there: the usual case, without the `fmod` call or the rounding of `a + 180`).
pub fn wrap_deg(a: f64) -> f64 {
    if (-180.0..180.0).contains(&a) {
        a
    } else {
        (a + 180.0).rem_euclid(360.0) - 180.0
    }
}

/// Running RMSE of Euler errors.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RmseAccumulator {
    sum_sq: [f64; 3],
    n: u64,
}

impl RmseAccumulator {
    /// Add one error sample `(roll, pitch, yaw)`, degrees (wrapped here).
    pub fn add(&mut self, err_deg: [f64; 3]) {
        for (s, e) in self.sum_sq.iter_mut().zip(err_deg) {
            let e = wrap_deg(e);
            *s += e * e;
        }
        self.n += 1;
    }

    /// Samples added.
    pub fn count(&self) -> u64 {
        self.n
    }

    /// RMSE per axis, degrees; `None` without samples.
    pub fn rmse(&self) -> Option<[f64; 3]> {
        (self.n > 0).then(|| self.sum_sq.map(|s| (s / self.n as f64).sqrt()))
    }
}

/// Truth Euler angles (Z-Y-X) of a row's quaternion, which need not be exactly unit, degrees.
///
/// In `f64`, in the homogeneous form: roll and yaw are `atan2`s of quadratic forms that all
/// scale by `|q|²`, so only pitch's sine needs the norm, one division (instead of a square
/// root and four divisions to normalise `q` first); and `1 − 2(x² + y²)` becomes
/// `w² − x² − y² + z²`, without its cancellation near ±90° of roll. The squares of the `f32`
/// components are exact in `f64`.
pub fn truth_euler_deg(q: [f32; 4]) -> [f64; 3] {
    let [w, x, y, z] = q.map(f64::from);
    let (ww, xx, yy, zz) = (w * w, x * x, y * y, z * z);
    let roll = (2.0 * (y * z + w * x)).atan2((ww - xx) - (yy - zz));
    let pitch = (2.0 * (w * y - x * z) / ((ww + xx) + (yy + zz))).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (x * y + w * z)).atan2((ww + xx) - (yy + zz));
    [roll, pitch, yaw].map(f64::to_degrees)
}

/// What a replay did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReplayStats {
    /// Rows processed.
    pub rows: u64,
    /// RMSE accumulator (rows after the initialisation window that have truth).
    pub rmse: RmseAccumulator,
    /// Wall time, s.
    pub elapsed_s: f64,
    /// The filter's gyro-bias estimate at the end, °/s.
    pub final_bias_dps: [f32; 3],
}

/// Where a replay's rows come from: a [`TraceReader`], or one that passes over malformed rows
/// ([`crate::lenient::SkipBadRows`]).
pub trait RowSource {
    /// The next row, `Ok(None)` at the end.
    fn next_row(&mut self) -> Result<Option<TraceRow>, TraceError>;
}

impl<R: BufRead> RowSource for TraceReader<R> {
    fn next_row(&mut self) -> Result<Option<TraceRow>, TraceError> {
        TraceReader::next_row(self)
    }
}

/// Rows per chunk handed from the parsing thread to the filtering thread.
const CHUNK: usize = 2048;

/// Replay `reader` through `conditioner` and `filter`, writing estimates to `out`. RMSE is
/// taken over rows with `t ≥ t₀ + window_s`.
///
/// Three stages on three threads, a few chunks of rows apart: parsing, the filter (this
/// thread), and formatting plus writing the estimates.
pub fn replay<S: RowSource + Send, W: Write + Send>(
    reader: S,
    out: W,
    filter: &mut dyn AttitudeFilter,
    conditioner: &mut Conditioner,
    window_s: f64,
) -> Result<ReplayStats, ReplayError> {
    replay_with(reader, out, filter, conditioner, window_s, |_, _| {})
}

/// [`replay`] that also hands every input row with its estimate to `observe`, on the calling
/// thread (the filter's), in row order (the CLI scores inclination and heading with it).
pub fn replay_with<S: RowSource + Send, W: Write + Send>(
    mut reader: S,
    out: W,
    filter: &mut dyn AttitudeFilter,
    conditioner: &mut Conditioner,
    window_s: f64,
    mut observe: impl FnMut(&TraceRow, &EstimateRow),
) -> Result<ReplayStats, ReplayError> {
    let start = Instant::now();
    std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Result<Vec<TraceRow>, TraceError>>(8);
        scope.spawn(move || loop {
            let mut chunk = Vec::with_capacity(CHUNK);
            while chunk.len() < CHUNK {
                match reader.next_row() {
                    Ok(Some(row)) => chunk.push(row),
                    Ok(None) => break,
                    Err(e) => {
                        // Rows before the error first, then the error.
                        let _ = tx.send(Ok(chunk));
                        let _ = tx.send(Err(e));
                        return;
                    }
                }
            }
            let last = chunk.len() < CHUNK;
            if tx.send(Ok(chunk)).is_err() || last {
                return;
            }
        });
        let (etx, erx) = std::sync::mpsc::sync_channel::<Vec<EstimateRow>>(8);
        let writer = scope.spawn(move || -> io::Result<()> {
            let mut w = EstimateWriter::new(out)?;
            for chunk in erx {
                for e in &chunk {
                    w.row(e)?;
                }
            }
            w.finish()?;
            Ok(())
        });
        let mut rows = Chunks { rx, current: Vec::new().into_iter() };
        let mut buf: Vec<EstimateRow> = Vec::with_capacity(CHUNK);
        let result = replay_rows(&mut rows, filter, conditioner, window_s, |r, e| {
            observe(r, e);
            buf.push(*e);
            if buf.len() == CHUNK {
                let full = std::mem::replace(&mut buf, Vec::with_capacity(CHUNK));
                // A closed channel means the writer failed: its error is reported below.
                etx.send(full).map_err(|_| io::Error::other("estimate writer stopped"))?;
            }
            Ok(())
        });
        if result.is_ok() && !buf.is_empty() {
            let _ = etx.send(buf);
        }
        drop(etx);
        let written = writer.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
        let mut stats = match (result, written) {
            // A write error comes first: it is why the replay stopped.
            (_, Err(e)) => return Err(ReplayError::Io(e)),
            (Err(e), Ok(())) => return Err(e),
            (Ok(s), Ok(())) => s,
        };
        stats.elapsed_s = start.elapsed().as_secs_f64();
        Ok(stats)
    })
}

/// [`replay`] on the calling thread alone: each row parsed, filtered, formatted and written
/// in turn (the output in 64 KiB blocks), no allocation per row. The same output and errors as
/// [`replay`] (tests/replay_paths.rs; after an error, the two have written different numbers of
/// whole rows, the start of the output either way); faster than it on one core, or when the
/// other cores are busy.
pub fn replay_serial<S: RowSource, W: Write>(
    reader: S,
    out: W,
    filter: &mut dyn AttitudeFilter,
    conditioner: &mut Conditioner,
    window_s: f64,
) -> Result<ReplayStats, ReplayError> {
    replay_serial_with(reader, out, filter, conditioner, window_s, |_, _| {})
}

/// [`replay_serial`] that also hands every input row with its estimate to `observe`, in row
/// order (as [`replay_with`]).
pub fn replay_serial_with<S: RowSource, W: Write>(
    mut reader: S,
    out: W,
    filter: &mut dyn AttitudeFilter,
    conditioner: &mut Conditioner,
    window_s: f64,
    mut observe: impl FnMut(&TraceRow, &EstimateRow),
) -> Result<ReplayStats, ReplayError> {
    let start = Instant::now();
    let mut w = EstimateWriter::new(out)?;
    let rows = std::iter::from_fn(|| reader.next_row().transpose());
    let mut stats = replay_rows(rows, filter, conditioner, window_s, |r, e| {
        observe(r, e);
        w.row(e)
    })?;
    w.finish()?;
    stats.elapsed_s = start.elapsed().as_secs_f64();
    Ok(stats)
}

/// Rows from the parsing thread, chunk by chunk.
struct Chunks {
    rx: std::sync::mpsc::Receiver<Result<Vec<TraceRow>, TraceError>>,
    current: std::vec::IntoIter<TraceRow>,
}

impl Iterator for Chunks {
    type Item = Result<TraceRow, TraceError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(row) = self.current.next() {
                return Some(Ok(row));
            }
            match self.rx.recv().ok()? {
                Ok(chunk) => self.current = chunk.into_iter(),
                Err(e) => return Some(Err(e)),
            }
        }
    }
}

/// The replay loop behind [`replay`], on rows already parsed: conditioning, `dt`, the filter,
/// the RMSE; `sink` gets every input row with its estimate (the CLI writes the estimate; the
/// accuracy benchmark keeps the yaw error). An error from `input` or `sink` stops the replay.
/// `elapsed_s` of the result is 0 (the caller times what it wants).
pub fn replay_rows<I, F>(
    input: I,
    filter: &mut dyn AttitudeFilter,
    conditioner: &mut Conditioner,
    window_s: f64,
    mut sink: F,
) -> Result<ReplayStats, ReplayError>
where
    I: IntoIterator<Item = Result<TraceRow, TraceError>>,
    F: FnMut(&TraceRow, &EstimateRow) -> io::Result<()>,
{
    let mut input = input.into_iter();
    let mut rmse = RmseAccumulator::default();
    let mut rows = 0u64;

    let mut pending: Option<TraceRow> = input.next().transpose()?;
    let mut next: Option<TraceRow> =
        if pending.is_some() { input.next().transpose()? } else { None };
    let t0 = pending.map_or(0.0, |r| r.t);
    let mut prev_t: Option<f64> = None;
    let to_deg = 1.0 / DEG as f32;

    while let Some(row) = pending {
        let dt = match (prev_t, next) {
            (Some(p), _) => row.t - p,
            (None, Some(n)) => n.t - row.t,
            (None, None) => 0.0,
        } as f32;
        let (gyro, accel) = conditioner.condition(
            dt,
            Vec3::from_array(row.gyro),
            Vec3::from_array(row.accel),
            filter.gyro_bias(),
        );
        let mag = row.mag.map(|m| conditioner.condition_mag(Vec3::from_array(m)));
        let flags = filter.update(&ImuSample { dt, gyro, accel, mag });
        let q = filter.attitude();
        let e = filter.euler();
        let b = filter.gyro_bias();
        let est = EstimateRow {
            t: row.t,
            q: [q.w, q.x, q.y, q.z],
            euler_deg: [e.roll * to_deg, e.pitch * to_deg, e.yaw * to_deg],
            bias_dps: [b.x * to_deg, b.y * to_deg, b.z * to_deg],
            flags: flags.bits(),
        };
        sink(&row, &est)?;
        if let Some(tq) = row.truth {
            if row.t >= t0 + window_s {
                let tr = truth_euler_deg(tq);
                rmse.add([0, 1, 2].map(|i| est.euler_deg[i] as f64 - tr[i]));
            }
        }
        rows += 1;
        prev_t = Some(row.t);
        pending = next;
        next = if pending.is_some() { input.next().transpose()? } else { None };
    }
    let b = filter.gyro_bias();
    Ok(ReplayStats {
        rows,
        rmse,
        elapsed_s: 0.0,
        final_bias_dps: [b.x * to_deg, b.y * to_deg, b.z * to_deg],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap() {
        assert_eq!(wrap_deg(190.0), -170.0);
        assert_eq!(wrap_deg(-190.0), 170.0);
        assert_eq!(wrap_deg(180.0), -180.0);
        assert_eq!(wrap_deg(0.5), 0.5);
        assert_eq!(wrap_deg(359.0), -1.0);
        assert_eq!(wrap_deg(-180.0), -180.0);
        assert_eq!(wrap_deg(179.999), 179.999);
        assert_eq!(wrap_deg(1e-20), 1e-20);
    }

    #[test]
    fn rmse_accumulator() {
        let mut a = RmseAccumulator::default();
        assert_eq!(a.rmse(), None);
        a.add([3.0, 0.0, 359.0]);
        a.add([-4.0, 0.0, 1.0]);
        let r = a.rmse().unwrap();
        assert!((r[0] - 12.5f64.sqrt()).abs() < 1e-12);
        assert_eq!(r[1], 0.0);
        assert!((r[2] - 1.0).abs() < 1e-9);
    }

    /// Z-Y-X angles in, `q = q_z(ψ)·q_y(θ)·q_x(φ)` built from axis rotations, scaled off unit
    /// and rounded to `f32` as a trace stores it: the same angles out, to the `f32` rounding of
    /// `q` (about 1e−7 rad, 6e−6°; pitch near ±90° loses more, so it stays within ±85° here).
    #[test]
    fn truth_euler_inverts_the_zyx_rotation() {
        use crate::sim::{axis_angle, qmul};
        let mut rng = crate::rng::Rng::new(7, 0);
        let mut uniform = |lo: f64, hi: f64| lo + (hi - lo) * rng.uniform();
        for k in 0..20_000 {
            let e = [uniform(-179.0, 179.0), uniform(-85.0, 85.0), uniform(-179.0, 179.0)];
            let q = qmul(
                axis_angle([0.0, 0.0, 1.0], e[2] * DEG),
                qmul(
                    axis_angle([0.0, 1.0, 0.0], e[1] * DEG),
                    axis_angle([1.0, 0.0, 0.0], e[0] * DEG),
                ),
            );
            let scale = if k % 2 == 0 { 1.0 } else { uniform(0.99, 1.01) };
            let got = truth_euler_deg(q.map(|c| (c * scale) as f32));
            for i in 0..3 {
                let err = wrap_deg(got[i] - e[i]).abs();
                assert!(err < 2e-4, "{e:?} scale {scale}: {got:?}");
            }
        }
        // Exact cases: identity, and a half turn about each axis.
        assert_eq!(truth_euler_deg([1.0, 0.0, 0.0, 0.0]), [0.0, 0.0, 0.0]);
        assert_eq!(truth_euler_deg([0.0, 1.0, 0.0, 0.0]), [180.0, 0.0, 0.0]);
        assert_eq!(truth_euler_deg([0.0, 0.0, 0.0, 2.0]), [0.0, 0.0, 180.0]);
        assert_eq!(truth_euler_deg([0.5f32.sqrt(), 0.0, 0.5f32.sqrt(), 0.0])[1], 90.0);
    }

    #[test]
    fn every_filter_kind_constructs_and_runs() {
        let cfg = ReplayConfig::default();
        for k in FilterKind::ALL {
            assert_eq!(FilterKind::from_name(k.name()), Some(k));
            let mut f = cfg.make_filter(k);
            for _ in 0..10 {
                f.update(&ImuSample::new(0.02, Vec3::ZERO, Vec3::new(0.0, 0.0, -9.80665)));
            }
            assert!(f.attitude().is_finite());
        }
    }
}
