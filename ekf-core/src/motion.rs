//! How much the vehicle accelerates, and the tilt low-pass's time constant that follows from it
//! (issue #35; derived in `docs/filter.md`, "The time constant follows the motion").
//!
//! **The statistic** is the horizontal specific force in the estimate's NED frame, the very
//! input of the tilt low-pass (`u = (−a_E, a_N)`, g ≈ rad): horizontal acceleration is what
//! disturbs the tilt, and only it. Four first-order low-passes of it, time constants
//! `τ_max·4^−i`, and the raw sample are combined three at a time into three bands, each with
//! weights of zero sum and zero mean delay, so that neither a constant (the gravity the frame
//! holds, the estimate's tilt error) nor a ramp (the frame turning at a constant rate: a gyro
//! bias or scale error over a steady turn) reaches it: what is left is the vehicle's
//! acceleration, the accelerometer's white noise and the frame's random walk under the gyros'
//! white noise. The last two are known (the configured noise densities through the weights,
//! by hand) and subtracted; the rest, divided by the band's power gain at its centre `ω_b =
//! 1/τ` of its middle low-pass, is the motion's power per axis in that band, `m_b` (g² ≈ rad²
//! of tilt). The estimate's own drift over a band's time scale is the gyros' (walk, bias,
//! scale) and the filter's corrections, small steps next to the motion that matters: the
//! statistic does not depend on the attitude estimate itself. Acceleration the gyros predict at the
//! configured lever arm is removed before (`conditioning`). Each band's power is averaged over
//! [`ATTACK_PERIODS`] periods of its centre (at least [`ATTACK_S`]) and, once raised, falls
//! by a factor e per [`RELEASE_TAUS`]·`τ_max`: motion that has just stopped tends to resume. For
//! [`ATTACK_S`] after the first sample nothing is known of the motion and `τ_max` is used.
//!
//! **The time constant** minimises the tilt error per axis,
//!
//! `E(τ) = W·τ + S·τ² + Σ_b m_b / (1 + (ω_b·τ)⁴/4)`,
//!
//! the gyro's walk over the delay `τ` (`W = 3/4·ψ`, ψ the gyros' noise density about the
//! horizontal axes: `tilt_lowpass`'s variance) and the error its scale factor and axis
//! misalignment build up over that delay (below) against what the second-order Butterworth
//! low-pass lets through of each band (its power response `1/(1 + (ω/ω₀)⁴)`, `ω₀ = √2/τ`).
//! Raw samples (τ = 0) pass every band through the Kalman filter's own first-order averaging
//! over `t_K = √(σ²·dt/ψ)` (its correction time on raw samples):
//! `E(0) = S·t_K² + Σ m_b/(1 + (ω_b·t_K)²)`.
//!
//! **The scale error's term.** A rate error proportional to the rate, bounded by `k`
//! (`ekf.gyro_scale_error`: each scale factor uniform in ±k, each cross-axis term in ±k/2),
//! turns the frame by `K·θ` while the vehicle turns by θ; about the two horizontal axes that
//! is, per axis, `(k²/3 + k²/12)/2 = 5/24·k²` of squared error per squared angle turned. Over
//! the low-pass's delay τ (its ramp lag) the vehicle turns about NED's horizontal axes by
//! `θ_h(τ) ≈ τ·ω̄_h`, ω̄_h the rate averaged over the last `τ_max` (the first-order low-pass of
//! the rotation angle less the angle: exact for a steady turn, the swing's amplitude for a
//! fast oscillation), so `S = 5/24·k²·|ω̄_h|²`. A tumble (a steady turn of tens of °/s) takes
//! short time constants; a hand's swing of a few tenths of a radian barely notices it. Without
//! the term a tumble with the iNEMO's 2 % scale error locked itself at `τ_max`: the frame's
//! error, growing with τ, is horizontal specific force in the estimate's frame and read as
//! motion (realistic `tumble` 1.4°, now under 0.5°).
//!
//! `E` is evaluated at τ = 0 and at `τ_max·0.7^k`, k = 0…7 (down to 0.08·τ_max), and the
//! smallest wins. With no motion the samples are used raw, as the source did; a hand-held
//! motion of a few tenths of a g takes `τ_max`.

/// Number of frequency bands of the statistic.
pub const BANDS: usize = 3;
/// Number of low-passes: each band combines three consecutive ones of `[lp…, raw]`.
const LPS: usize = BANDS + 1;
/// Ratio of consecutive low-pass time constants: bands two octaves wide.
const RATIO: f32 = 4.0;
/// The time constants tried besides 0: `τ_max·GRID_STEP^k`, k = 0…GRID−1.
const GRID: usize = 8;
/// See [`GRID`].
const GRID_STEP: f32 = 0.7;
/// Averaging time of the band powers, in periods of each band's centre: a power is not known
/// from less than a couple of its periods (the gyro's walk in the lowest band, as large as the
/// motion that matters there, would otherwise look like motion now and then).
pub const ATTACK_PERIODS: f32 = 2.0;
/// The shortest averaging time, s, and the time after a start during which nothing is known of
/// the motion.
pub const ATTACK_S: f32 = 1.0;
/// Release time of the band powers, in units of `τ_max`.
pub const RELEASE_TAUS: f32 = 4.0;

/// The motion statistic and the time-constant rule. See the module documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionLevel {
    /// First-order low-passes of the horizontal specific force `(−a_E, a_N)`, g: time
    /// constants `τ_max·4^−i`.
    lp: [[f32; 2]; LPS],
    /// Each band's weights on `[lp…, raw]`: zero sum and zero mean delay.
    c: [[f32; 3]; BANDS],
    /// Each band's power less the noise's, averaged over [`ATTACK_PERIODS`] of its centre, g².
    attack: [f32; BANDS],
    /// Each band's power in use: follows `attack` up at once, falls over the release time.
    m: [f32; BANDS],
    /// Whether the low-passes hold a sample.
    started: bool,
    /// Samples left before the band powers have averaged over [`ATTACK_S`]: until then
    /// nothing is known of the motion, and the longest time constant is used.
    cold: u32,
    /// The low-passes' coefficients `dt/τ`.
    alpha: [f32; LPS],
    /// `1 − alpha[0]`: the rotation angle's low-pass keeps this much per sample.
    keep0: f32,
    /// Each band's white-noise and gyro-walk power, g² per axis.
    noise: [f32; BANDS],
    /// Each band's attack coefficient, and the release coefficient.
    k: [f32; BANDS + 1],
    /// Per axis, over the band's power gain at its centre.
    scale: [f32; BANDS],
    /// `1/(1 + (ω_b·τ_k)⁴/4)`: what the low-pass of the k-th time constant lets through of
    /// band b.
    pass: [[f32; BANDS]; GRID],
    /// The time constants tried, s.
    taus: [f32; GRID],
    /// `1/(1 + (ω_b·t_K)²)`: what raw samples let through of band b.
    raw_pass: [f32; BANDS],
    /// Each band's centre, rad/s.
    omega: [f32; BANDS],
    /// The longest time constant, s.
    tau_max: f32,
    /// The estimate's rotation about NED x and y over about the last `τ_max`, rad: the
    /// rotation angle's first-order low-pass (time constant `τ_max`) less the angle itself.
    rot: [f32; 2],
    /// The Kalman filter's correction time on raw samples, s.
    tk: f32,
    /// `5/24·k²/τ_max²`, 1/s² (k the scale error's bound).
    s_scale: f32,
}

impl MotionLevel {
    /// No motion seen yet; no coefficients (call [`MotionLevel::set_rate`]).
    pub const fn new() -> Self {
        MotionLevel {
            lp: [[0.0; 2]; LPS],
            c: [[0.0; 3]; BANDS],
            attack: [0.0; BANDS],
            m: [0.0; BANDS],
            started: false,
            cold: u32::MAX,
            alpha: [0.0; LPS],
            keep0: 0.0,
            noise: [0.0; BANDS],
            k: [0.0; BANDS + 1],
            scale: [0.0; BANDS],
            pass: [[0.0; BANDS]; GRID],
            taus: [0.0; GRID],
            raw_pass: [0.0; BANDS],
            omega: [0.0; BANDS],
            tau_max: 0.0,
            rot: [0.0; 2],
            tk: 0.0,
            s_scale: 0.0,
        }
    }

    /// The coefficients for samples `dt` s apart, the longest time constant `tau_max` s, the
    /// accelerometer's white-noise variance per sample `var` (g², per axis), the gyros'
    /// noise density about the horizontal axes `psd` (rad²/s) and their scale error's bound
    /// `scale_error` (`ekf.gyro_scale_error`). Once per sample rate (it has
    /// divisions).
    #[cold]
    #[inline(never)]
    pub fn set_rate(&mut self, dt: f32, tau_max: f32, var: f32, psd: f32, scale_error: f32) {
        // The Kalman filter's correction time on raw samples, √(σ²·dt/ψ), and what its
        // first-order averaging lets through of each band.
        let tk = if psd > 0.0 { crate::mathf::sqrt(var * dt / psd) } else { 0.0 };
        self.tk = tk;
        let a = |t: f32| if t > dt { dt / t } else { 1.0 };
        // Time constants and coefficients of `[lp…, raw]`.
        let mut t = [0.0f32; LPS + 1];
        let mut al = [1.0f32; LPS + 1];
        let mut ti = tau_max;
        for i in 0..LPS {
            t[i] = ti;
            al[i] = a(ti);
            self.alpha[i] = al[i];
            ti /= RATIO;
        }
        self.keep0 = 1.0 - self.alpha[0];
        // The mean delay of each, s (a first-order low-pass's ramp lag, discrete).
        let lag: [f32; LPS + 1] = core::array::from_fn(|i| dt * (1.0 - al[i]) / al[i]);
        // White noise of variance σ² through two first-order low-passes: covariance
        // σ²·αᵢαⱼ/(αᵢ + αⱼ − αᵢαⱼ). A random walk of density ψ (the estimate's frame under
        // the gyro's noise) through a zero-sum, zero-delay combination Σcᵢ·LPᵢ:
        // −ψ/2·Σᵢⱼ cᵢcⱼ·(τᵢ² + τⱼ²)/(τᵢ + τⱼ) (by hand, partial fractions of |Σ cᵢ/(1 + jωτᵢ)|²/ω²).
        let g = |ai: f32, aj: f32| ai * aj / (ai + aj - ai * aj);
        let h =
            |ti: f32, tj: f32| if ti + tj > 0.0 { (ti * ti + tj * tj) / (ti + tj) } else { 0.0 };
        let mut omega = [0.0f32; BANDS];
        for b in 0..BANDS {
            // Weights on lp b, b+1, b+2 (the last may be the raw sample): c₂ = 1, and
            // c₀ + c₁ = −1, c₀·lag₀ + c₁·lag₁ = −lag₂, so that a constant and a ramp (a
            // gravity vector the frame holds, and one it turns at a constant rate: a gyro
            // bias or scale error) give nothing.
            let span = lag[b] - lag[b + 1];
            // At a sample rate too low for the band (its low-passes no longer differ), none.
            let c = if span > 0.0 {
                let c0 = (lag[b + 1] - lag[b + 2]) / span;
                [c0, -1.0 - c0, 1.0]
            } else {
                [0.0; 3]
            };
            self.c[b] = c;
            let (mut n, mut w) = (0.0f32, 0.0f32);
            for i in 0..3 {
                for j in 0..3 {
                    n += c[i] * c[j] * g(al[b + i], al[b + j]);
                    w -= 0.5 * c[i] * c[j] * h(t[b + i], t[b + j]);
                }
            }
            omega[b] = 1.0 / t[b + 1];
            // The combination's power gain at the band's centre, |Σ cᵢ/(1 + jωτᵢ)|²: the band
            // power is divided by it, so that a motion at the centre reads its own power.
            let (mut re, mut im) = (0.0f32, 0.0f32);
            for i in 0..3 {
                let x = omega[b] * t[b + i];
                let d = 1.0 + x * x;
                re += c[i] / d;
                im -= c[i] * x / d;
            }
            let gain = re * re + im * im;
            (self.scale[b], self.noise[b]) =
                if gain > 0.0 { (0.5 / gain, (var * n + psd * w) / gain) } else { (0.0, 0.0) };
        }
        for b in 0..BANDS {
            let x = omega[b] * tk;
            self.raw_pass[b] = 1.0 / (1.0 + x * x);
        }
        let mut tau = tau_max;
        for k in 0..GRID {
            self.taus[k] = tau;
            for b in 0..BANDS {
                let x = omega[b] * tau;
                let x2 = x * x;
                self.pass[k][b] = 1.0 / (1.0 + 0.25 * x2 * x2);
            }
            tau *= GRID_STEP;
        }
        for b in 0..BANDS {
            let t = ATTACK_PERIODS * core::f32::consts::TAU / omega[b];
            self.k[b] = a(if t > ATTACK_S { t } else { ATTACK_S });
        }
        self.k[BANDS] = a(RELEASE_TAUS * tau_max);
        if self.cold == u32::MAX {
            self.cold = (ATTACK_S / dt) as u32;
        }
        self.tau_max = tau_max;
        self.omega = omega;
        self.s_scale = if tau_max > 0.0 {
            (5.0 / 24.0) * scale_error * scale_error / (tau_max * tau_max)
        } else {
            0.0
        };
    }

    /// At least the motion power `m` (g², per axis) in every band (tests: a filter in motion).
    #[cfg(test)]
    pub fn at_least(&mut self, m: f32) {
        for b in 0..BANDS {
            if self.m[b] < m {
                self.m[b] = m;
            }
        }
    }

    /// One sample: the horizontal specific force in the estimate's NED frame, kept as the
    /// tilt error it shows, `u = (−a_E, a_N)`, g, and the estimate's rotation over the sample
    /// about NED x and y, `dth`, rad.
    #[inline(always)]
    pub fn push(&mut self, u: [f32; 2], dth: [f32; 2]) {
        if !self.started {
            self.lp = [u; LPS];
            self.started = true;
        }
        self.cold = self.cold.saturating_sub(1);
        unroll!(i in [0, 1, 2, 3] {
            unroll!(k in [0, 1] {
                self.lp[i][k] += self.alpha[i] * (u[k] - self.lp[i][k]);
            });
        });
        unroll!(k in [0, 1] {
            self.rot[k] = self.keep0 * (self.rot[k] - dth[k]);
        });
        let ar = self.k[BANDS];
        unroll!(b in [0, 1, 2] {
            let c = self.c[b];
            let mut p = 0.0;
            unroll!(k in [0, 1] {
                let top = if b + 2 < LPS { self.lp[(b + 2) % LPS][k] } else { u[k] };
                // `c[2]` is 1 (or the band is off: `c` all 0, and then `scale` and `noise`
                // are 0 too, so `p` is not read): `top` itself, no multiplication.
                let d = c[0] * self.lp[b][k] + c[1] * self.lp[b + 1][k] + top;
                p += d * d;
            });
            // Per axis, at the band's centre.
            self.attack[b] += self.k[b] * (self.scale[b] * p - self.noise[b] - self.attack[b]);
            self.m[b] -= ar * self.m[b];
            if self.attack[b] > self.m[b] {
                self.m[b] = self.attack[b];
            }
        });
    }

    /// The time constant, s, that minimises the tilt error `E(τ)` for the gyro walk `w`
    /// (rad²/s: `3/4·ψ`); 0: raw samples.
    #[inline(always)]
    pub fn time_constant(&self, w: f32) -> f32 {
        if self.cold > 0 {
            return self.tau_max;
        }
        // The band powers are never negative: each starts at 0 and takes the attack's value
        // only when that is larger.
        // The gyro's scale error over the delay: S·τ², S = 5/24·k²·|ω̄_h|² (module docs),
        // ω̄_h = rot/τ_max.
        let r2 = self.rot[0] * self.rot[0] + self.rot[1] * self.rot[1];
        let s = r2 * self.s_scale;
        let mut best = s * self.tk * self.tk;
        unroll!(b in [0, 1, 2] {
            best += self.m[b] * self.raw_pass[b];
        });
        // From the shortest time constant up: the walk's and the scale error's terms alone,
        // `W·τ + S·τ²`, grow with τ and bound `E` from below (the bands' terms are never
        // negative), so once they reach the best so far no longer τ can win and the rest of
        // the grid is skipped (with no motion, all of it). Ties go to the longer time
        // constant, raw samples keep theirs: the minimum is the same as over the whole grid.
        let mut tau_best = 0.0;
        let mut grid = false;
        let better = |e: f32, best: f32, grid: bool| {
            if grid {
                crate::fcmp::le(e, best)
            } else {
                crate::fcmp::lt(e, best)
            }
        };
        for k in (0..GRID).rev() {
            let t = self.taus[k];
            let mut e = w * t + s * t * t;
            if !better(e, best, grid) {
                break;
            }
            unroll!(b in [0, 1, 2] {
                e += self.m[b] * self.pass[k][b];
            });
            if better(e, best, grid) {
                best = e;
                tau_best = t;
                grid = true;
            }
        }
        tau_best
    }

    /// The motion's power per band, g² (rad² of tilt) per axis, lowest band first.
    pub fn power(&self) -> [f32; BANDS] {
        self.m
    }
}

impl Default for MotionLevel {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::TestRng;

    /// `E(τ)` over every candidate, longest first, strictly smaller wins: the rule as
    /// written in the module documentation, without the early stop.
    fn exhaustive(m: &MotionLevel, w: f32) -> f32 {
        if m.cold > 0 {
            return m.tau_max;
        }
        let s = (m.rot[0] * m.rot[0] + m.rot[1] * m.rot[1]) * m.s_scale;
        let mut best = s * m.tk * m.tk;
        for b in 0..BANDS {
            best += m.m[b] * m.raw_pass[b];
        }
        let mut tau_best = 0.0;
        for k in 0..GRID {
            let mut e = w * m.taus[k] + s * m.taus[k] * m.taus[k];
            for b in 0..BANDS {
                e += m.m[b] * m.pass[k][b];
            }
            if e < best {
                best = e;
                tau_best = m.taus[k];
            }
        }
        tau_best
    }

    /// The early stop of [`MotionLevel::time_constant`] (issue #36) changes no choice: over
    /// band powers from none to a hand's, rotations from none to a tumble's, and walks from
    /// none to ten times the board's, including exact ties (equal powers, zero walk), it picks
    /// the time constant the exhaustive evaluation picks.
    #[test]
    fn the_early_stop_picks_what_the_whole_grid_picks() {
        let mut rng = TestRng::new(36);
        let mut level = MotionLevel::new();
        // 50 Hz, τ_max 2.5 s, the LSM303DLH's and the LPR430AL's noise, k = 0.02.
        level.set_rate(0.02, 2.5, 3.0e-6, 1.5e-6, 0.02);
        level.cold = 0;
        let mut chosen = [0usize; GRID + 1];
        for n in 0..200_000 {
            let mag = |rng: &mut TestRng| {
                let e = rng.uniform() as f32 * 6.0 - 8.0; // 1e-14 … 1e-2
                if n % 7 == 0 {
                    0.0
                } else {
                    10f32.powf(e)
                }
            };
            level.m = [mag(&mut rng), mag(&mut rng), mag(&mut rng)];
            if n % 11 == 0 {
                level.m = [level.m[0]; 3];
            }
            let r = if n % 3 == 0 { 0.0 } else { rng.uniform() as f32 * 2.0 };
            level.rot = [r, rng.uniform() as f32 * r];
            let w =
                if n % 5 == 0 { 0.0 } else { 1.1e-6 * (1.0 + 9.0 * rng.uniform() as f32).abs() };
            let (fast, all) = (level.time_constant(w), exhaustive(&level, w));
            assert_eq!(fast.to_bits(), all.to_bits(), "case {n}: {level:?}, w {w}");
            chosen[level.taus.iter().position(|&t| t == all).map_or(0, |k| k + 1)] += 1;
        }
        // The cases reach raw samples and every time constant of the grid.
        assert!(chosen.iter().all(|&c| c > 100), "{chosen:?}");
    }
}
