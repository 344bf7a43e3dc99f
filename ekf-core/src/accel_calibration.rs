//! Accelerometer calibration: the affine model of the source (thesis appendix B) and its
//! allocation-free six-position least-squares fit.
//!
//! Model, in units of g and in the **sensor's own axes** (it is fitted on raw data, before any
//! axis remapping):
//!
//! ```text
//! [ax1 ay1 az1] = [ax ay az 1] · X,      X = [ M ]  (3×3 scale / misalignment / cross-axis)
//!                                            [ o ]  (1×3 offset row, g)
//! ```
//!
//! i.e. `calibrated = Mᵀ · raw + oᵀ`. The fit is `X = (wᵀw)⁻¹ wᵀ Y` with one row
//! `w = [ax ay az 1]` per sample and `Y` the matching reference readings (±1 g on one axis in
//! each of the six static positions).

use core::fmt;

use crate::{Vec3, GRAVITY};

/// Affine accelerometer calibration `[ax1 ay1 az1] = [ax ay az 1] · X` (units of g, sensor
/// axes).
///
/// `x` is the 4×3 matrix `X`, row-major: rows 0..=2 are the 3×3 scale/misalignment part `M`
/// (dimensionless), row 3 is the offset row `o` (g). Column `j` produces calibrated axis `j`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelCalibration {
    /// The 4×3 matrix `X`, row-major: `x[i][j]` for input `i` (x, y, z, constant 1) and output
    /// axis `j`. Rows 0..=2 dimensionless, row 3 in g.
    pub x: [[f32; 3]; 4],
}

impl Default for AccelCalibration {
    /// [`AccelCalibration::IDENTITY`].
    fn default() -> Self {
        AccelCalibration::IDENTITY
    }
}

impl AccelCalibration {
    /// No correction: unit scale, no cross-axis terms, zero offset.
    pub const IDENTITY: AccelCalibration = AccelCalibration {
        x: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]],
    };

    /// The iNEMO V2 board's `X` from the source (thesis appendix B), fitted on its six-position
    /// data; sensor axes, offset row in g.
    pub const INEMO_BOARD: AccelCalibration = AccelCalibration {
        x: [
            [0.9639, 0.0018, -0.0131],
            [0.0359, 0.9914, -0.0157],
            [0.0070, -0.0038, 0.9609],
            [-0.0035, -0.0036, -0.0474],
        ],
    };

    /// The offset row `o` of `X`, g (sensor axes).
    pub fn offset_g(&self) -> Vec3 {
        Vec3::from_array(self.x[3])
    }

    /// True when every entry of `X` is finite.
    pub fn is_finite(&self) -> bool {
        self.x.iter().flatten().all(|v| v.is_finite())
    }

    /// `Mᵀ · v` (the linear part only), same unit as `v`.
    fn linear(&self, v: Vec3) -> Vec3 {
        let [r0, r1, r2, _] = self.x;
        Vec3::new(
            v.x * r0[0] + v.y * r1[0] + v.z * r2[0],
            v.x * r0[1] + v.y * r1[1] + v.z * r2[1],
            v.x * r0[2] + v.y * r1[2] + v.z * r2[2],
        )
    }

    /// Calibrate a raw reading in g (sensor axes): `[raw 1] · X`, g out (sensor axes).
    pub fn apply_g(&self, raw_g: Vec3) -> Vec3 {
        self.linear(raw_g) + self.offset_g()
    }

    /// Calibrate a raw reading in m/s² (sensor axes), m/s² out (sensor axes). Equal to
    /// `apply_g(raw / GRAVITY) · GRAVITY`: the linear part is unit-free and the offset row is
    /// scaled by [`GRAVITY`].
    pub fn apply(&self, raw: Vec3) -> Vec3 {
        self.linear(raw) + self.offset_g() * GRAVITY
    }
}

/// One of the six static calibration positions. "Axis up" means that sensor axis points up, so
/// it reads +1 g of specific force (reference `+1 g` on that axis, 0 on the others); "down"
/// reads −1 g.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Position {
    /// Sensor +x up: reference (+1, 0, 0) g.
    XUp,
    /// Sensor +x down: reference (−1, 0, 0) g.
    XDown,
    /// Sensor +y up: reference (0, +1, 0) g.
    YUp,
    /// Sensor +y down: reference (0, −1, 0) g.
    YDown,
    /// Sensor +z up: reference (0, 0, +1) g.
    ZUp,
    /// Sensor +z down: reference (0, 0, −1) g.
    ZDown,
}

impl Position {
    /// All six positions, in [`Position::index`] order.
    pub const ALL: [Position; 6] = [
        Position::XUp,
        Position::XDown,
        Position::YUp,
        Position::YDown,
        Position::ZUp,
        Position::ZDown,
    ];

    /// Index 0..=5 of this position in [`Position::ALL`] and in
    /// [`SixPositionFit::positions_seen`].
    pub const fn index(self) -> usize {
        match self {
            Position::XUp => 0,
            Position::XDown => 1,
            Position::YUp => 2,
            Position::YDown => 3,
            Position::ZUp => 4,
            Position::ZDown => 5,
        }
    }

    /// The ideal reading in this position, g (sensor axes).
    pub const fn reference_g(self) -> Vec3 {
        match self {
            Position::XUp => Vec3::new(1.0, 0.0, 0.0),
            Position::XDown => Vec3::new(-1.0, 0.0, 0.0),
            Position::YUp => Vec3::new(0.0, 1.0, 0.0),
            Position::YDown => Vec3::new(0.0, -1.0, 0.0),
            Position::ZUp => Vec3::new(0.0, 0.0, 1.0),
            Position::ZDown => Vec3::new(0.0, 0.0, -1.0),
        }
    }

    /// The position a reference reading (g, sensor axes) belongs to: its largest-magnitude
    /// component (the first one on ties) and that component's sign, provided the magnitude is
    /// at least 0.5 g. `None` otherwise, or for a non-finite reference.
    pub fn classify(reference_g: Vec3) -> Option<Position> {
        if !reference_g.is_finite() {
            return None;
        }
        let (ax, ay, az) = (reference_g.x.abs(), reference_g.y.abs(), reference_g.z.abs());
        let (value, up, down) = if ax >= ay && ax >= az {
            (reference_g.x, Position::XUp, Position::XDown)
        } else if ay >= az {
            (reference_g.y, Position::YUp, Position::YDown)
        } else {
            (reference_g.z, Position::ZUp, Position::ZDown)
        };
        if value >= 0.5 {
            Some(up)
        } else if value <= -0.5 {
            Some(down)
        } else {
            None
        }
    }
}

/// Why [`SixPositionFit::solve`] could not produce a calibration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FitError {
    /// Fewer than [`SixPositionFit::MIN_SAMPLES`] samples were accumulated.
    TooFewSamples {
        /// Number of samples accumulated.
        count: u32,
    },
    /// Some of the six positions have no data (`seen[Position::index()]`).
    MissingPositions {
        /// Which positions have data, indexed by [`Position::index`].
        seen: [bool; 6],
    },
    /// The normal matrix `wᵀw` is singular or too ill-conditioned to solve (raw data that do
    /// not span the three axes plus the offset).
    IllConditioned,
    /// The solution is not finite (overflowing input).
    NonFinite,
}

impl fmt::Display for FitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FitError::TooFewSamples { count } => {
                write!(f, "accelerometer fit: only {count} samples")
            }
            FitError::MissingPositions { seen } => {
                write!(f, "accelerometer fit: positions missing (seen {seen:?})")
            }
            FitError::IllConditioned => {
                write!(f, "accelerometer fit: normal matrix singular or ill-conditioned")
            }
            FitError::NonFinite => write!(f, "accelerometer fit: non-finite solution"),
        }
    }
}

/// Allocation-free accumulator for the least-squares fit `X = (wᵀw)⁻¹ wᵀ Y` of an
/// [`AccelCalibration`] from static samples (raw and reference readings in g, sensor axes).
///
/// Keeps only the normal equations (`wᵀw`, 4×4, and `wᵀY`, 4×3) plus `Σ y²`, in `f64`, so its
/// size is fixed whatever the number of samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SixPositionFit {
    wtw: [[f64; 4]; 4],
    wty: [[f64; 3]; 4],
    yty: [f64; 3],
    count: u32,
    per_position: [u32; 6],
}

impl Default for SixPositionFit {
    fn default() -> Self {
        SixPositionFit::new()
    }
}

impl SixPositionFit {
    /// Minimum number of samples [`SixPositionFit::solve`] accepts (one per position).
    pub const MIN_SAMPLES: u32 = 6;

    /// Smallest accepted `L[k][k]² / A[k][k]` in the Cholesky factorisation of `A = wᵀw`: the
    /// fraction of column `k`'s energy not explained by the previous columns (sin² of its angle
    /// to their span). Below it the system is rejected as ill-conditioned.
    pub const MIN_PIVOT_RATIO: f64 = 1e-6;

    /// An empty accumulator.
    pub const fn new() -> Self {
        SixPositionFit {
            wtw: [[0.0; 4]; 4],
            wty: [[0.0; 3]; 4],
            yty: [0.0; 3],
            count: 0,
            per_position: [0; 6],
        }
    }

    /// Accumulate one sample: raw reading `raw_g` and the reading `reference_g` it should
    /// calibrate to, both in g (sensor axes). The sample counts toward the position given by
    /// [`Position::classify`] of the reference. Samples with a non-finite component are
    /// ignored.
    pub fn add(&mut self, raw_g: Vec3, reference_g: Vec3) {
        if !raw_g.is_finite() || !reference_g.is_finite() {
            return;
        }
        let w = [f64::from(raw_g.x), f64::from(raw_g.y), f64::from(raw_g.z), 1.0];
        let y = [f64::from(reference_g.x), f64::from(reference_g.y), f64::from(reference_g.z)];
        for ((a_row, b_row), &wi) in self.wtw.iter_mut().zip(self.wty.iter_mut()).zip(w.iter()) {
            for (a, &wj) in a_row.iter_mut().zip(w.iter()) {
                *a += wi * wj;
            }
            for (b, &yj) in b_row.iter_mut().zip(y.iter()) {
                *b += wi * yj;
            }
        }
        for (s, &yj) in self.yty.iter_mut().zip(y.iter()) {
            *s += yj * yj;
        }
        self.count = self.count.saturating_add(1);
        if let Some(p) = Position::classify(reference_g) {
            if let Some(n) = self.per_position.get_mut(p.index()) {
                *n = n.saturating_add(1);
            }
        }
    }

    /// Accumulate one raw reading `raw_g` (g, sensor axes) taken in static position `pos`
    /// (reference [`Position::reference_g`]).
    pub fn add_position(&mut self, pos: Position, raw_g: Vec3) {
        self.add(raw_g, pos.reference_g());
    }

    /// Number of samples accumulated.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Number of samples accumulated in position `pos`.
    pub fn count_at(&self, pos: Position) -> u32 {
        self.per_position.get(pos.index()).copied().unwrap_or(0)
    }

    /// Which of the six positions have at least one sample, indexed by [`Position::index`].
    pub fn positions_seen(&self) -> [bool; 6] {
        self.per_position.map(|n| n > 0)
    }

    /// Forget every sample.
    pub fn reset(&mut self) {
        *self = SixPositionFit::new();
    }

    /// Solve the normal equations `(wᵀw) X = wᵀY` by Cholesky factorisation (in `f64`).
    ///
    /// Errors: fewer than [`Self::MIN_SAMPLES`] samples, a position without data, a singular
    /// or ill-conditioned `wᵀw` (see [`Self::MIN_PIVOT_RATIO`]), or a non-finite solution.
    pub fn solve(&self) -> Result<AccelCalibration, FitError> {
        if self.count < Self::MIN_SAMPLES {
            return Err(FitError::TooFewSamples { count: self.count });
        }
        let seen = self.positions_seen();
        if seen.iter().any(|s| !s) {
            return Err(FitError::MissingPositions { seen });
        }
        let l = cholesky4(&self.wtw).ok_or(FitError::IllConditioned)?;
        let mut x = [[0.0f32; 3]; 4];
        for j in 0..3 {
            let b = [self.wty[0][j], self.wty[1][j], self.wty[2][j], self.wty[3][j]];
            let sol = cholesky4_solve(&l, b);
            for (row, &v) in x.iter_mut().zip(sol.iter()) {
                row[j] = v as f32;
            }
        }
        let cal = AccelCalibration { x };
        if cal.is_finite() {
            Ok(cal)
        } else {
            Err(FitError::NonFinite)
        }
    }

    /// Root-mean-square residual, g, of calibration `cal` over the accumulated samples:
    /// `sqrt(Σ‖[raw 1]·X − reference‖² / count)`, computed from the normal equations (the samples
    /// themselves are not stored). `None` with no samples or a non-finite result.
    pub fn rms_residual_g(&self, cal: &AccelCalibration) -> Option<f32> {
        if self.count == 0 {
            return None;
        }
        // Σ_samples (w·x_j − y_j)² = x_jᵀ A x_j − 2 x_jᵀ b_j + Σ y_j².
        let mut sum = 0.0f64;
        for j in 0..3 {
            let xj = cal.x.map(|row| f64::from(row[j]));
            let mut quad = 0.0;
            let mut lin = 0.0;
            for ((a_row, b_row), &xi) in self.wtw.iter().zip(self.wty.iter()).zip(xj.iter()) {
                let ax: f64 = a_row.iter().zip(xj.iter()).map(|(a, x)| a * x).sum();
                quad += xi * ax;
                lin += xi * b_row[j];
            }
            sum += quad - 2.0 * lin + self.yty[j];
        }
        // Rounding can leave a tiny negative value for a perfect fit.
        let ms = (sum / f64::from(self.count)).max(0.0);
        let rms = libm::sqrt(ms) as f32;
        rms.is_finite().then_some(rms)
    }
}

/// Lower-triangular Cholesky factor `L` of a symmetric positive-definite 4×4 `a = L Lᵀ`, or
/// `None` when a pivot falls below [`SixPositionFit::MIN_PIVOT_RATIO`] of its diagonal entry
/// (singular, ill-conditioned or non-finite input).
fn cholesky4(a: &[[f64; 4]; 4]) -> Option<[[f64; 4]; 4]> {
    let mut l = [[0.0f64; 4]; 4];
    for k in 0..4 {
        let akk = a[k][k];
        if !(akk.is_finite() && akk > 0.0) {
            return None;
        }
        let row_k = l[k];
        let d = akk - dot_prefix(&row_k, &row_k, k);
        // Written so that a NaN pivot is rejected too.
        let well_conditioned = d > SixPositionFit::MIN_PIVOT_RATIO * akk;
        if !well_conditioned {
            return None;
        }
        let lkk = libm::sqrt(d);
        l[k][k] = lkk;
        for i in (k + 1)..4 {
            let row_i = l[i];
            l[i][k] = (a[i][k] - dot_prefix(&row_i, &row_k, k)) / lkk;
        }
    }
    Some(l)
}

/// `Σ_{p<n} a[p]·b[p]`.
fn dot_prefix(a: &[f64; 4], b: &[f64; 4], n: usize) -> f64 {
    a.iter().zip(b.iter()).take(n).map(|(x, y)| x * y).sum()
}

/// Solve `L Lᵀ x = b` given the Cholesky factor from [`cholesky4`] (non-zero diagonal).
fn cholesky4_solve(l: &[[f64; 4]; 4], b: [f64; 4]) -> [f64; 4] {
    // Forward: L z = b.
    let mut z = [0.0f64; 4];
    for i in 0..4 {
        let mut s = b[i];
        for p in 0..i {
            s -= l[i][p] * z[p];
        }
        z[i] = s / l[i][i];
    }
    // Backward: Lᵀ x = z.
    let mut x = [0.0f64; 4];
    for i in (0..4).rev() {
        let mut s = z[i];
        for p in (i + 1)..4 {
            s -= l[p][i] * x[p];
        }
        x[i] = s / l[i][i];
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The source's six raw position means, g, with their positions.
    const SOURCE_MEANS: [(Position, [f32; 3]); 6] = [
        (Position::XDown, [-1.035, 0.004, 0.030]),
        (Position::XUp, [1.040, 0.001, 0.058]),
        (Position::YDown, [0.039, -1.003, 0.040]),
        (Position::YUp, [-0.036, 1.015, 0.072]),
        (Position::ZDown, [0.013, -0.001, -0.993]),
        (Position::ZUp, [-0.003, 0.007, 1.088]),
    ];

    /// `[raw 1] · X` in f64, written out independently of `apply_g`.
    fn model_f64(x: &[[f64; 3]; 4], raw: [f64; 3]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (j, o) in out.iter_mut().enumerate() {
            *o = raw[0] * x[0][j] + raw[1] * x[1][j] + raw[2] * x[2][j] + x[3][j];
        }
        out
    }

    /// Inverse of the model: the raw reading (g) that calibrates to `reference`.
    fn inverse_model(x: &[[f64; 3]; 4], reference: [f64; 3]) -> [f64; 3] {
        // reference − o = Mᵀ raw  →  raw = (Mᵀ)⁻¹ (reference − o), by Cramer's rule.
        let m = |r: usize, c: usize| x[c][r]; // Mᵀ[r][c]
        let rhs = [reference[0] - x[3][0], reference[1] - x[3][1], reference[2] - x[3][2]];
        let det3 = |a: [[f64; 3]; 3]| {
            a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
                - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
                + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
        };
        let mt =
            [[m(0, 0), m(0, 1), m(0, 2)], [m(1, 0), m(1, 1), m(1, 2)], [m(2, 0), m(2, 1), m(2, 2)]];
        let d = det3(mt);
        let mut raw = [0.0; 3];
        for (c, r) in raw.iter_mut().enumerate() {
            let mut a = mt;
            for (row, &v) in a.iter_mut().zip(rhs.iter()) {
                row[c] = v;
            }
            *r = det3(a) / d;
        }
        raw
    }

    /// A non-trivial known X: scale errors, cross-axis terms and offsets of a few percent.
    const KNOWN_X: [[f64; 3]; 4] =
        [[1.02, 0.015, -0.03], [-0.02, 0.97, 0.025], [0.04, -0.01, 1.05], [0.03, -0.05, 0.02]];

    fn synthetic_fit(samples: usize, noise_g: f64) -> SixPositionFit {
        let mut rng = crate::test_rng::TestRng::new(12345);
        let mut fit = SixPositionFit::new();
        for pos in Position::ALL {
            let r = pos.reference_g();
            let raw = inverse_model(&KNOWN_X, [r.x.into(), r.y.into(), r.z.into()]);
            for _ in 0..samples {
                let v = Vec3::new(
                    (raw[0] + noise_g * rng.uniform()) as f32,
                    (raw[1] + noise_g * rng.uniform()) as f32,
                    (raw[2] + noise_g * rng.uniform()) as f32,
                );
                fit.add_position(pos, v);
            }
        }
        fit
    }

    #[test]
    fn inemo_board_calibrates_source_means_to_references() {
        for (pos, raw) in SOURCE_MEANS {
            let out = AccelCalibration::INEMO_BOARD.apply_g(Vec3::from_array(raw));
            let reference = pos.reference_g();
            let xf = AccelCalibration::INEMO_BOARD.x.map(|r| r.map(f64::from));
            let indep = model_f64(&xf, raw.map(f64::from));
            for j in 0..3 {
                // The published X brings every mean to within 6.4 mg of its reference (by hand:
                // the largest is YUp's z, 0.0063 g).
                assert!((out[j] - reference[j]).abs() < 0.01, "{pos:?} axis {j}: {out:?}");
                assert!((f64::from(out[j]) - indep[j]).abs() < 1e-6);
            }
        }
        // One hand-computed value: +x up, x axis:
        // 1.040·0.9639 + 0.001·0.0359 + 0.058·0.0070 − 0.0035 = 0.9993979.
        let out = AccelCalibration::INEMO_BOARD.apply_g(Vec3::new(1.040, 0.001, 0.058));
        assert!((out.x - 0.999_397_9).abs() < 1e-6, "{out:?}");
        // And its z: 1.040·(−0.0131) + 0.001·(−0.0157) + 0.058·0.9609 − 0.0474 = −0.0053075.
        assert!((out.z - (-0.005_307_5)).abs() < 1e-6, "{out:?}");
        // +z up, every axis (each negative entry of the published X is in one of these five
        // values):
        // x: −0.003·0.9639 + 0.007·0.0359 + 1.088·0.0070 − 0.0035 = 0.0014756;
        // y: −0.003·0.0018 + 0.007·0.9914 + 1.088·(−0.0038) − 0.0036 = −0.0008000;
        // z: −0.003·(−0.0131) + 0.007·(−0.0157) + 1.088·0.9609 − 0.0474 = 0.9979886.
        let out = AccelCalibration::INEMO_BOARD.apply_g(Vec3::new(-0.003, 0.007, 1.088));
        let want = Vec3::new(0.001_475_6, -0.000_800_0, 0.997_988_6);
        assert!((out - want).max_abs() < 1e-6, "{out:?}");
    }

    #[test]
    fn identity_changes_nothing() {
        let v = Vec3::new(0.3, -9.7, 1.25);
        assert_eq!(AccelCalibration::IDENTITY.apply(v), v);
        assert_eq!(AccelCalibration::IDENTITY.apply_g(v), v);
        assert_eq!(AccelCalibration::default(), AccelCalibration::IDENTITY);
    }

    #[test]
    fn apply_in_si_equals_apply_g_scaled() {
        let cals = [
            AccelCalibration::INEMO_BOARD,
            AccelCalibration { x: KNOWN_X.map(|r| r.map(|v| v as f32)) },
        ];
        let raws =
            [Vec3::new(0.1, -0.2, -9.8), Vec3::new(9.81, 0.0, 0.4), Vec3::new(-3.0, 5.0, 7.0)];
        for cal in cals {
            for raw in raws {
                let si = cal.apply(raw);
                let via_g = cal.apply_g(raw / GRAVITY) * GRAVITY;
                assert!((si - via_g).max_abs() < 1e-5, "{si:?} vs {via_g:?}");
            }
            // The offset row is scaled by g: a zero reading gives o · g.
            assert_eq!(cal.apply(Vec3::ZERO), cal.offset_g() * GRAVITY);
        }
        // Hand value: INEMO_BOARD at rest (0, 0, −g): z = −0.9609·g − 0.0474·g = −1.0083·g.
        let z = AccelCalibration::INEMO_BOARD.apply(Vec3::new(0.0, 0.0, -GRAVITY)).z;
        assert!((z - (-1.0083 * GRAVITY)).abs() < 1e-5, "{z}");
    }

    #[test]
    fn noiseless_synthetic_data_fit_back_exactly() {
        let fit = synthetic_fit(3, 0.0);
        assert_eq!(fit.count(), 18);
        let cal = fit.solve().unwrap();
        // Only f32 rounding of the raw samples (~1e-7 g) and of X itself.
        for (row, known) in cal.x.iter().zip(KNOWN_X.iter()) {
            for (&v, &k) in row.iter().zip(known.iter()) {
                assert!((f64::from(v) - k).abs() < 2e-6, "{:?}", cal.x);
            }
        }
        assert!(fit.rms_residual_g(&cal).unwrap() < 1e-5);
    }

    #[test]
    fn noisy_synthetic_data_fit_back_within_noise_bound() {
        // Uniform noise of half-width a = 1 mg on each raw axis, N = 64 samples per position:
        // each position's mean error has σ = a/√3/√N ≈ 7.2e-5 g. With six ±1 g positions, each
        // entry of X is a combination of at most a few position means with coefficients of
        // order ‖M‖ ≈ 1, so its error is ≈ 1e-4 g; 5e-4 is a ≥ 5σ bound that a transposed or
        // mis-indexed fit (cross terms 0.01–0.05) badly violates.
        let fit = synthetic_fit(64, 1e-3);
        let cal = fit.solve().unwrap();
        for (row, known) in cal.x.iter().zip(KNOWN_X.iter()) {
            for (&v, &k) in row.iter().zip(known.iter()) {
                assert!((f64::from(v) - k).abs() < 5e-4, "{:?}", cal.x);
            }
        }
        // Residuals are the noise mapped through M: RMS ≈ √3 · a/√3 = 1 mg.
        let rms = fit.rms_residual_g(&cal).unwrap();
        assert!(rms > 0.5e-3 && rms < 1.5e-3, "{rms}");
    }

    #[test]
    fn fit_of_source_means_is_least_squares_optimal() {
        let mut fit = SixPositionFit::new();
        for (pos, raw) in SOURCE_MEANS {
            fit.add_position(pos, Vec3::from_array(raw));
        }
        assert_eq!(fit.positions_seen(), [true; 6]);
        let cal = fit.solve().unwrap();
        // Least squares: no other X does better on the same data, in particular not the
        // board's published X or small perturbations of the solution.
        let best = fit.rms_residual_g(&cal).unwrap();
        assert!(best <= fit.rms_residual_g(&AccelCalibration::INEMO_BOARD).unwrap());
        for i in 0..4 {
            for j in 0..3 {
                for d in [-1e-3f32, 1e-3] {
                    let mut p = cal;
                    p.x[i][j] += d;
                    assert!(fit.rms_residual_g(&p).unwrap() > best, "({i},{j})");
                }
            }
        }
        // And it lands close to the published X (within a few hundredths).
        for (row, pub_row) in cal.x.iter().zip(AccelCalibration::INEMO_BOARD.x.iter()) {
            for (&v, &k) in row.iter().zip(pub_row.iter()) {
                assert!((v - k).abs() < 0.05, "{:?}", cal.x);
            }
        }
    }

    #[test]
    fn rms_residual_matches_direct_computation() {
        let mut fit = SixPositionFit::new();
        let mut direct = 0.0f64;
        let cal = AccelCalibration::INEMO_BOARD;
        for (pos, raw) in SOURCE_MEANS {
            fit.add_position(pos, Vec3::from_array(raw));
            let e = cal.apply_g(Vec3::from_array(raw)) - pos.reference_g();
            direct += f64::from(e.norm_sq());
        }
        let rms = fit.rms_residual_g(&cal).unwrap();
        assert!((f64::from(rms) - libm::sqrt(direct / 6.0)).abs() < 1e-5);
        assert_eq!(SixPositionFit::new().rms_residual_g(&cal), None);
    }

    #[test]
    fn too_few_positions_or_samples_are_errors() {
        let empty = SixPositionFit::new();
        assert_eq!(empty.solve(), Err(FitError::TooFewSamples { count: 0 }));

        // Five of six positions, many samples: missing position reported.
        let mut fit = SixPositionFit::new();
        for (pos, raw) in SOURCE_MEANS.iter().take(5) {
            for _ in 0..4 {
                fit.add_position(*pos, Vec3::from_array(*raw));
            }
        }
        assert_eq!(fit.count(), 20);
        let seen = fit.positions_seen();
        assert_eq!(seen.iter().filter(|s| **s).count(), 5);
        assert!(!seen[Position::ZUp.index()]);
        assert_eq!(fit.solve(), Err(FitError::MissingPositions { seen }));
        fit.reset();
        assert_eq!(fit.count(), 0);
    }

    #[test]
    fn degenerate_data_are_errors_not_panics() {
        // Six positions but the sensor reads the same thing every time: rank 1.
        let mut fit = SixPositionFit::new();
        for pos in Position::ALL {
            fit.add_position(pos, Vec3::new(0.0, 0.0, 1.0));
        }
        assert_eq!(fit.solve(), Err(FitError::IllConditioned));

        // Raw z always zero: a zero column.
        let mut fit = SixPositionFit::new();
        for pos in Position::ALL {
            let r = pos.reference_g();
            fit.add_position(pos, Vec3::new(r.x, r.y, 0.0));
        }
        assert_eq!(fit.solve(), Err(FitError::IllConditioned));

        // A z axis stuck at 0.02 g with ±10 µg of noise: nearly a copy of the constant
        // column. The constant column's part not explained by z is var(z)/mean(z²) ≈
        // 6.7e−11/4e−4 ≈ 1.7e−7 of it, under MIN_PIVOT_RATIO (1e−6): refused, not solved into
        // an X of thousands.
        let mut fit = SixPositionFit::new();
        for pos in Position::ALL {
            let r = pos.reference_g();
            for i in 0..10 {
                let z = 0.02 + 1e-5 * (i % 3) as f32 - 1e-5;
                fit.add_position(pos, Vec3::new(r.x, r.y, z));
            }
        }
        assert_eq!(fit.solve(), Err(FitError::IllConditioned));
        // At ±1 mg the ratio is 1.7e−3 and the fit goes through.
        let mut fit = SixPositionFit::new();
        for pos in Position::ALL {
            let r = pos.reference_g();
            for i in 0..10 {
                let z = 0.02 + 1e-3 * (i % 3) as f32 - 1e-3;
                fit.add_position(pos, Vec3::new(r.x, r.y, z));
            }
        }
        assert!(fit.solve().is_ok());

        // Non-finite samples are ignored.
        let mut fit = SixPositionFit::new();
        fit.add_position(Position::XUp, Vec3::new(f32::NAN, 0.0, 0.0));
        fit.add(Vec3::new(1.0, 0.0, 0.0), Vec3::new(f32::INFINITY, 0.0, 0.0));
        assert_eq!(fit.count(), 0);
        assert_eq!(fit.positions_seen(), [false; 6]);

        // Huge but finite samples: no panic, and any Ok result is finite.
        let mut fit = SixPositionFit::new();
        for pos in Position::ALL {
            fit.add_position(pos, pos.reference_g() * 3e38);
        }
        if let Ok(cal) = fit.solve() {
            assert!(cal.is_finite());
        }
    }

    #[test]
    fn a_solution_beyond_f32_is_refused_as_non_finite() {
        // Raw readings of 1e−39 g (f32 subnormals) for ±1 g references: the scale part of X is
        // 1e39, finite in the f64 solve and beyond f32::MAX (3.4e38) once stored.
        let mut fit = SixPositionFit::new();
        for pos in Position::ALL {
            fit.add_position(pos, pos.reference_g() * 1e-39);
        }
        assert_eq!(fit.solve(), Err(FitError::NonFinite));
        let mut cal = AccelCalibration::IDENTITY;
        assert!(cal.is_finite());
        cal.x[3][2] = f32::NAN;
        assert!(!cal.is_finite());
        cal.x[3][2] = 0.0;
        cal.x[1][0] = f32::NEG_INFINITY;
        assert!(!cal.is_finite());
    }

    #[test]
    fn fit_errors_say_what_went_wrong() {
        // `ahrs-tool calibrate` prints these after "fit failed: ".
        let says = crate::test_text::assert_displays::<FitError>;
        says(FitError::TooFewSamples { count: 5 }, "accelerometer fit: only 5 samples");
        let mut seen = [true; 6];
        seen[Position::ZUp.index()] = false;
        says(
            FitError::MissingPositions { seen },
            "accelerometer fit: positions missing (seen [true, true, true, true, false, true])",
        );
        says(
            FitError::IllConditioned,
            "accelerometer fit: normal matrix singular or ill-conditioned",
        );
        says(FitError::NonFinite, "accelerometer fit: non-finite solution");
    }

    #[test]
    fn positions_are_classified_from_references() {
        for pos in Position::ALL {
            assert_eq!(Position::classify(pos.reference_g()), Some(pos));
            assert_eq!(Position::ALL[pos.index()], pos);
        }
        assert_eq!(Position::classify(Vec3::new(0.1, -0.9, 0.3)), Some(Position::YDown));
        assert_eq!(Position::classify(Vec3::new(0.3, 0.2, 0.1)), None);
        assert_eq!(Position::classify(Vec3::new(f32::NAN, 1.0, 0.0)), None);
        let mut fit = SixPositionFit::new();
        fit.add(Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.0, 0.0, -1.0));
        fit.add(Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.0, 0.1, -0.99));
        assert_eq!(fit.count_at(Position::ZDown), 2);
        assert_eq!(fit.positions_seen(), [false, false, false, false, false, true]);
    }
}
