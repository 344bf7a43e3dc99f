//! The sensors' noise figures from a still recording, by the Allan variance (IEEE Std 952-1997,
//! annex C): `ahrs-tool noise` turns them into the settings `noise.gyro_var`,
//! `noise.accel_var` and `ekf.bias_random_walk`, so that those are measured on the board at
//! hand rather than chosen (issue #36: a tuning setting is a number chosen by judgment; a
//! noise density measured by an Allan variance is not one).
//!
//! The overlapping Allan variance at averaging time `τ = m·dt` is computed from the integrated
//! signal `θ` (`θ_k = Σ x_i·dt`): `σ²(τ) = Σ_k (θ_{k+2m} − 2θ_{k+m} + θ_k)² / (2τ²(n + 1 − 2m))`,
//! at `m` on a grid of half octaves from 1 up to a tenth of the recording (so that every point
//! averages at least ten independent clusters). Three noise terms are fitted to it, each the
//! Allan variance of one process (IEEE Std 952, table C.2):
//!
//! | term | process | Allan variance | figure |
//! |---|---|---|---|
//! | `N²/τ` | white noise of density `N` (rate: angle random walk) | slope −1 | `N`, unit/√Hz; the per-sample variance at rate `f` is `N²·f` |
//! | `(2 ln 2/π)·B²` | bias instability (flicker) | flat | `B`, unit |
//! | `K²·τ/3` | rate random walk (the bias's random walk) | slope +1 | `K`, unit/√s; `K²` is the EKF's `ekf.bias_random_walk` |
//!
//! The fit minimises the squared *relative* residuals, each point weighted by its number of
//! clusters (its relative uncertainty falls as one over their square root), over the three
//! coefficients constrained non-negative (every subset of the terms solved, the best
//! non-negative solution kept). A term that the recording cannot resolve comes out 0: a rate
//! random walk shows only at averaging times beyond the bias instability's flat part, so it
//! needs an hour or more of still data, and it counts only when the curve shows its +½ slope
//! (at the longest averaging time the walk's term is more than the other two together).

use crate::trace::TraceRow;

/// Standard gravity, m/s² (the traces' accelerometer unit per g).
const G: f64 = 9.80665;

/// `2 ln 2 / π`: the Allan variance of bias instability `B` is this times `B²`.
pub const FLICKER_AVAR_PER_B2: f64 = 2.0 * core::f64::consts::LN_2 / core::f64::consts::PI;

/// The shortest still recording analysed, s: below it not even the white noise has ten
/// clusters of a few seconds.
pub const MIN_DURATION_S: f64 = 60.0;

/// One point of an Allan-variance curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AllanPoint {
    /// Averaging time, s.
    pub tau: f64,
    /// Allan variance, unit².
    pub avar: f64,
    /// Independent clusters the point averages (`n/m`).
    pub clusters: f64,
}

/// The overlapping Allan variance of `x` (samples `dt` s apart) at averaging times `m·dt`,
/// `m` on a half-octave grid from 1 to `n/10`.
pub fn allan_curve(x: &[f64], dt: f64) -> Vec<AllanPoint> {
    let n = x.len();
    let mut theta = Vec::with_capacity(n + 1);
    theta.push(0.0f64);
    for v in x {
        theta.push(theta[theta.len() - 1] + v * dt);
    }
    let mut out = Vec::new();
    let mut last = 0usize;
    for k in 0.. {
        let m = (2f64.powf(k as f64 / 2.0)).round() as usize;
        if m * 10 > n {
            break;
        }
        if m == last {
            continue;
        }
        last = m;
        let terms = n + 1 - 2 * m;
        let sum: f64 = (0..terms)
            .map(|i| {
                let d = theta[i + 2 * m] - 2.0 * theta[i + m] + theta[i];
                d * d
            })
            .sum();
        let tau = m as f64 * dt;
        out.push(AllanPoint {
            tau,
            avar: sum / (2.0 * tau * tau * terms as f64),
            clusters: (n / m) as f64,
        });
    }
    out
}

/// The three noise figures fitted to one axis's Allan variance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseFit {
    /// White-noise density `N`, unit/√Hz (unit·√s).
    pub white: f64,
    /// Bias instability `B`, unit (the flat part of the Allan deviation is `0.664·B`).
    pub instability: f64,
    /// Rate random walk `K`, unit/√s (0: not resolved by the recording).
    pub walk: f64,
    /// The longest averaging time of the curve, s.
    pub tau_max: f64,
    /// At most this much rate random walk is consistent with the curve, unit/√s: the `K`
    /// whose line `K²·τ/3` touches the curve's longest-τ point (the bound when `walk` is 0).
    pub walk_bound: f64,
}

/// The non-negative least-squares fit of `N²/τ + (2 ln 2/π)·B² + K²·τ/3` to `curve`
/// (module docs).
pub fn fit(curve: &[AllanPoint]) -> NoiseFit {
    let last = curve.last();
    let tau_max = last.map_or(0.0, |p| p.tau);
    let mut coef = fit_terms(curve, 0b111);
    // The walk is resolved only where the curve shows its +½ slope: at the longest averaging
    // time it must be more than the other two terms together. Otherwise it is the scatter of
    // the last few points (ten clusters: ±30 %), and the fit is made without it.
    if coef[2] * tau_max / 3.0 <= coef[0] / tau_max + coef[1] {
        coef = fit_terms(curve, 0b011);
    }
    NoiseFit {
        white: coef[0].sqrt(),
        instability: (coef[1] / FLICKER_AVAR_PER_B2).sqrt(),
        walk: coef[2].sqrt(),
        tau_max,
        walk_bound: last.map_or(0.0, |p| (3.0 * p.avar / p.tau).sqrt()),
    }
}

/// The best non-negative fit with the terms of `allowed` (bits: white, flicker, walk), as
/// coefficients `[N², (2 ln 2/π)·B², K²]`.
fn fit_terms(curve: &[AllanPoint], allowed: u32) -> [f64; 3] {
    let basis = |p: &AllanPoint| [1.0 / p.tau, 1.0, p.tau / 3.0];
    let mut best: Option<([f64; 3], f64)> = None;
    for mask in (1u32..8).filter(|m| m & !allowed == 0) {
        let cols: Vec<usize> = (0..3).filter(|j| mask >> j & 1 == 1).collect();
        // Normal equations of the weighted relative residuals: rows f_j(τ)/σ²(τ), target 1.
        let k = cols.len();
        let mut a = [[0.0f64; 3]; 3];
        let mut b = [0.0f64; 3];
        for p in curve {
            let f = basis(p);
            let w = p.clusters;
            for (r, &i) in cols.iter().enumerate() {
                let gi = f[i] / p.avar;
                b[r] += w * gi;
                for (c, &j) in cols.iter().enumerate() {
                    a[r][c] += w * gi * f[j] / p.avar;
                }
            }
        }
        let Some(sol) = solve(&mut a, &mut b, k) else { continue };
        if sol[..k].iter().any(|c| c.is_nan() || *c < 0.0) {
            continue;
        }
        let mut coef = [0.0f64; 3];
        for (r, &j) in cols.iter().enumerate() {
            coef[j] = sol[r];
        }
        let cost: f64 = curve
            .iter()
            .map(|p| {
                let f = basis(p);
                let model: f64 = (0..3).map(|j| coef[j] * f[j]).sum();
                p.clusters * (model / p.avar - 1.0).powi(2)
            })
            .sum();
        if best.is_none_or(|(_, c)| cost < c) {
            best = Some((coef, cost));
        }
    }
    best.map_or([0.0; 3], |(c, _)| c)
}

/// Gaussian elimination with partial pivoting on the leading `k`×`k` block; `None` when
/// singular.
fn solve(a: &mut [[f64; 3]; 3], b: &mut [f64; 3], k: usize) -> Option<[f64; 3]> {
    for c in 0..k {
        let p = (c..k).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        let pivot = a[p][c];
        if pivot.is_nan() || pivot.abs() <= 1e-300 {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..k {
            let f = a[r][c] / a[c][c];
            let top = a[c];
            for (x, t) in a[r][c..k].iter_mut().zip(&top[c..k]) {
                *x -= f * t;
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = [0.0f64; 3];
    for r in (0..k).rev() {
        let s: f64 = (r + 1..k).map(|j| a[r][j] * x[j]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    Some(x)
}

/// The noise of a still recording: each sensor axis's fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecordingNoise {
    /// Sample rate, Hz (rows over the recording's length).
    pub rate_hz: f64,
    /// Length, s.
    pub duration_s: f64,
    /// The gyro's mean rate per axis, rad/s: its bias at rest (with Earth's rate's projection).
    pub gyro_mean: [f64; 3],
    /// Gyro x, y, z: rad/s units (`white` in rad/s/√Hz, `walk` in rad/s/√s).
    pub gyro: [NoiseFit; 3],
    /// Accelerometer x, y, z: g units.
    pub accel: [NoiseFit; 3],
}

/// Largest departure of a still recording's 1 s accelerometer mean from the recording's mean,
/// g: more is a board tilted or moved during the recording.
pub const STILL_ACCEL_G: f64 = 0.05;
/// Largest departure of its 1 s gyro mean, rad/s (1 °/s: a turn).
pub const STILL_RATE: f64 = 0.017_453_3;

/// Analyse the rows of a still recording (a trace: gyro rad/s, accelerometer m/s²). Errors
/// name the row by its time and say what is wrong: a value that is not a finite number, a
/// time that does not increase or a gap (the Allan variance needs evenly spaced samples), a
/// recording shorter than [`MIN_DURATION_S`], or one that is not still.
pub fn analyse(rows: &[TraceRow]) -> Result<RecordingNoise, String> {
    if rows.len() < 2 {
        return Err(format!(
            "{} rows: a still recording of at least {MIN_DURATION_S} s is needed",
            rows.len()
        ));
    }
    for (i, r) in rows.iter().enumerate() {
        if !r.t.is_finite() {
            return Err(match i {
                0 => "the first row's time is not a number".to_string(),
                _ => format!("the row after t = {} s: its time is not a number", rows[i - 1].t),
            });
        }
        if !r.gyro.iter().chain(&r.accel).all(|v| v.is_finite()) {
            return Err(format!(
                "t = {} s: the gyro and the accelerometer must be finite numbers",
                r.t
            ));
        }
    }
    let duration = rows[rows.len() - 1].t - rows[0].t;
    let dt = duration / (rows.len() - 1) as f64;
    if duration.is_nan() || duration < MIN_DURATION_S {
        return Err(format!(
            "the recording is {duration:.1} s long: the Allan variance needs at least {MIN_DURATION_S} s still (an hour or more to resolve the bias's random walk)"
        ));
    }
    for w in rows.windows(2) {
        let step = w[1].t - w[0].t;
        if !(step > 0.5 * dt && step < 1.5 * dt) {
            return Err(format!(
                "t = {} s: {step} s after the row before, the samples being {dt:.6} s apart on average; the Allan variance needs an unbroken, evenly sampled recording",
                w[1].t
            ));
        }
    }
    let series = |f: &dyn Fn(&TraceRow) -> f64| -> Vec<f64> { rows.iter().map(f).collect() };
    let gyro: [Vec<f64>; 3] = core::array::from_fn(|a| series(&|r| r.gyro[a] as f64));
    let accel: [Vec<f64>; 3] = core::array::from_fn(|a| series(&|r| r.accel[a] as f64 / G));
    // Stillness: every 1 s mean near the recording's mean.
    let per_s = ((1.0 / dt).round() as usize).max(1);
    for (what, axes, limit, unit) in [
        ("gyro", &gyro, STILL_RATE, 180.0 / core::f64::consts::PI),
        ("accelerometer", &accel, STILL_ACCEL_G, 1.0),
    ] {
        for (a, x) in axes.iter().enumerate() {
            let mean = x.iter().sum::<f64>() / x.len() as f64;
            for (c, chunk) in x.chunks_exact(per_s).enumerate() {
                let m = chunk.iter().sum::<f64>() / chunk.len() as f64;
                if (m - mean).abs() > limit {
                    return Err(format!(
                        "the recording is not still: at t = {:.0} s the {what}'s 1 s mean on axis {} is {:.3} {} from the recording's mean (at most {:.2} allowed); record with the board at rest",
                        rows[c * per_s].t,
                        ["x", "y", "z"][a],
                        (m - mean).abs() * unit,
                        if what == "gyro" { "°/s" } else { "g" },
                        limit * unit,
                    ));
                }
            }
        }
    }
    let fits = |axes: &[Vec<f64>; 3]| -> [NoiseFit; 3] {
        core::array::from_fn(|a| fit(&allan_curve(&axes[a], dt)))
    };
    let gyro_mean = core::array::from_fn(|a| gyro[a].iter().sum::<f64>() / gyro[a].len() as f64);
    Ok(RecordingNoise {
        rate_hz: 1.0 / dt,
        duration_s: duration,
        gyro_mean,
        gyro: fits(&gyro),
        accel: fits(&accel),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Realism, Scenario, SimOptions, Simulator};

    /// A still recording of `seconds` at `rate` Hz with the plain iNEMO noise and `realism`.
    fn still(seconds: f64, rate: f64, realism: Option<Realism>, seed: u64) -> Vec<TraceRow> {
        let opts =
            SimOptions { rate_hz: rate, duration_s: Some(seconds), seed, ..Default::default() };
        let (_, mut cfg) = Scenario::StillHour.simulator_with(&opts);
        cfg.sensors.realism = realism;
        Simulator::new(Scenario::StillHour.trajectory(), cfg).map(|s| s.row).collect()
    }

    fn deg(x: f64) -> f64 {
        x.to_radians()
    }

    /// White noise alone: `N = σ/√f` recovered per axis (the simulator's per-sample variances
    /// at 50 Hz: the board's 0.337, 0.275, 4.19e−3 (°/s)², and the LSM303DLH's 2.376e−6 g²),
    /// within 5 %; no random walk.
    #[test]
    fn white_noise_is_measured_as_its_density() {
        let rows = still(600.0, 50.0, None, 3);
        let r = analyse(&rows).unwrap();
        assert!((r.rate_hz - 50.0).abs() < 1e-6);
        let var: [f64; 3] = [0.337, 0.275, 4.19e-3];
        for (a, v) in var.iter().enumerate() {
            let want = deg(v.sqrt()) / 50f64.sqrt();
            let got = r.gyro[a].white;
            assert!((got / want - 1.0).abs() < 0.05, "gyro {a}: N {got} against {want}");
            assert_eq!(r.gyro[a].walk, 0.0, "gyro {a}: {:?}", r.gyro[a]);
        }
        for a in 0..3 {
            let want = (2.376e-6f64 / 50.0).sqrt();
            assert!((r.accel[a].white / want - 1.0).abs() < 0.05, "accel {a}: {:?}", r.accel[a]);
        }
    }

    /// A rate random walk (the simulator's `b += K·√dt·N(0, 1)`, K = 0.002 °/s/√s on x and y,
    /// 0.0005 on z) over two hours at 20 Hz: K recovered within 30 % on x and y; and the
    /// white noise still within 5 %.
    #[test]
    fn a_rate_random_walk_is_measured_over_hours() {
        let real = Realism { gyro_rrw_dps_rt_s: [0.002, 0.002, 0.0005], ..Realism::OFF };
        let rows = still(7200.0, 20.0, Some(real), 5);
        let r = analyse(&rows).unwrap();
        for a in 0..2 {
            let k = r.gyro[a].walk;
            assert!((k / deg(0.002) - 1.0).abs() < 0.3, "gyro {a}: K {} °/s/√s", k.to_degrees());
        }
        // The density is the simulator's at any rate: σ at 50 Hz over √50.
        let want = deg(0.337f64.sqrt()) / 50f64.sqrt();
        assert!((r.gyro[0].white / want - 1.0).abs() < 0.05, "{:?}", r.gyro[0]);
    }

    /// Bias instability alone (the simulator's flicker, an Allan deviation flat at 0.005 °/s
    /// from 3 s to 1000 s) over an hour at 20 Hz: on z, whose white noise is low enough for
    /// the flat part to show from a few seconds on, the fitted floor `0.664·B` within 15 % of
    /// 0.005 °/s; on no axis is it mistaken for a random walk.
    #[test]
    fn bias_instability_is_not_taken_for_a_random_walk() {
        let real = Realism { gyro_flicker_dps: [0.005; 3], ..Realism::OFF };
        let rows = still(3600.0, 20.0, Some(real), 7);
        let r = analyse(&rows).unwrap();
        let floor = FLICKER_AVAR_PER_B2.sqrt() * r.gyro[2].instability.to_degrees();
        assert!((floor / 0.005 - 1.0).abs() < 0.15, "z: floor {floor} °/s ({:?})", r.gyro[2]);
        for a in 0..3 {
            assert_eq!(r.gyro[a].walk, 0.0, "gyro {a}: {:?}", r.gyro[a]);
        }
    }

    /// Bad recordings: each error names the row by its time, or says what is wrong.
    #[test]
    fn bad_recordings_are_refused_with_the_reason() {
        let rows = still(100.0, 50.0, None, 1);
        let e = analyse(&rows[..1000]).unwrap_err();
        assert!(e.contains("20.0 s long"), "{e}");
        let mut gap = rows.clone();
        gap.remove(2000);
        let e = analyse(&gap).unwrap_err();
        assert!(e.starts_with("t = 40.02 s: 0.04"), "{e}");
        let mut nan = rows.clone();
        nan[17].gyro[1] = f32::NAN;
        assert!(analyse(&nan).unwrap_err().starts_with("t = 0.34 s:"));
        nan[17].gyro[1] = 0.0;
        nan[30].t = f64::NAN;
        assert!(analyse(&nan).unwrap_err().starts_with("the row after t = 0.58 s: its time"));
        let mut tilted = rows.clone();
        for r in &mut tilted[3000..] {
            r.accel[0] += 0.1 * 9.80665_f32;
        }
        let e = analyse(&tilted).unwrap_err();
        assert!(
            e.contains("not still") && e.contains("accelerometer") && e.contains("axis x"),
            "{e}"
        );
        let mut turned = rows;
        for r in &mut turned[..500] {
            r.gyro[2] += 0.1;
        }
        let e = analyse(&turned).unwrap_err();
        assert!(e.contains("not still") && e.contains("gyro") && e.contains("axis z"), "{e}");
    }

    /// The fit on exact curves: each term alone and all three together come back to 1e−6.
    #[test]
    fn the_fit_recovers_exact_terms() {
        let (n, b, k) = (0.01f64, 0.002f64, 0.0003f64);
        let curve: Vec<AllanPoint> = (0..30)
            .map(|i| {
                let tau = 0.02 * 2f64.powf(i as f64 / 2.0);
                let avar = n * n / tau + FLICKER_AVAR_PER_B2 * b * b + k * k * tau / 3.0;
                AllanPoint { tau, avar, clusters: 1e6 / tau }
            })
            .collect();
        let f = fit(&curve);
        assert!((f.white / n - 1.0).abs() < 1e-6, "{f:?}");
        assert!((f.instability / b - 1.0).abs() < 1e-6, "{f:?}");
        assert!((f.walk / k - 1.0).abs() < 1e-6, "{f:?}");
        let white_only: Vec<AllanPoint> =
            curve.iter().map(|p| AllanPoint { avar: n * n / p.tau, ..*p }).collect();
        let f = fit(&white_only);
        assert!((f.white / n - 1.0).abs() < 1e-9 && f.instability == 0.0 && f.walk == 0.0, "{f:?}");
    }
}
