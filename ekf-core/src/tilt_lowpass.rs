//! The EKF's tilt measurement: the specific force in the estimate's NED frame, low-passed with
//! a time constant that the motion sets (`motion`), and what that low-passed vector measures.
//!
//! The estimate's NED frame is almost inertial: it turns only by the gyro's errors. There the
//! motion's accelerations average out (their mean over τ is a change of velocity over τ)
//! while gravity stays, so the low-passed vector's horizontal part measures the tilt error.
//! The low-pass is VQF's (Laidig and Seel 2023): second-order Butterworth, natural frequency
//! `ω₀ = √2/τ`, whose delay at low frequencies is τ; a motion at angular frequency `ω ≫ ω₀`
//! passes `(ω₀/ω)² = 2/(ωτ)²` of its acceleration, half what two first-order stages of τ/2
//! (the same delay, critically damped) let through. In state-variable form, semi-implicit:
//!
//! `v ← v + ω₀²·dt·(u − x) − √2·ω₀·dt·v`, `x ← x + v·dt`
//!
//! (exact to `O(ω₀·dt)`: 1 % at 50 Hz and τ = 2.5 s, 0.2 % at 285 Hz).
//!
//! The vector is kept as the tilt error it shows, `u = (−a_E, a_N)` in g ≈ rad, since for a
//! tilt error δθ (NED, `q_true = Exp(δθ) ⊗ q̂`) the estimate's frame sees
//! `a ≈ |a|·(δθ_y, −δθ_x, −1)`. Each state `s` (the output `x`, its rate `v`) is a weighted
//! sum of past samples, modelled as
//!
//! `s = w_s·(δθ_x, δθ_y) + J_s·δb + (what the motion left)`
//!
//! - `w_s`, the sum of the state's weights on real samples: the output's starts at 0 (an
//!   empty filter says "no tilt error", which is not a measurement) and tends to 1;
//! - `J_s`, the delay: a bias error δb turns the estimate by `−R·δb·dt` per sample
//!   (`covariance`'s `Φ`), so the samples in the filter saw an attitude error that differs
//!   from today's by what δb built up since; for a steady attitude `J_x → τ·R_{xy}` (the
//!   samples, τ old on average, saw τ·R·δb more). Without it a start error, decaying through
//!   the low-pass as a ramp over τ, looks like a gyro bias and the filter learns a wrong one
//!   (VQF's bias estimator low-passes `R` for the same reason).
//!
//! The output is the measurement (`H = [w_x·I₂, 0, J_x]`, `covariance::TiltRows`). After a
//! correction `(dθ, db)` each state moves by what the correction explains, `w_s·dθ + J_s·db`,
//! so that it always holds the error of the current estimate.

use crate::{covariance::TiltRows, quaternion::Mat3, Vec3};

/// The low-pass of the tilt error and its measurement model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltLowPass {
    /// `(ω₀²·dt, √2·ω₀·dt, dt)`; `None`: no low-pass (τ = 0), the output is the sample.
    k: Option<[f32; 3]>,
    /// The states (δθ_x, δθ_y): index 0 the rate `v`, rad/s; index 1 the output `x`, rad (the
    /// measurement).
    y: [[f32; 2]; 2],
    /// Each state's sum of weights on real samples.
    w: [f32; 2],
    /// Each state's sensitivity to the bias error: `j[state][component][axis]`.
    j: [[[f32; 3]; 2]; 2],
    /// The states hold one raw sample (τ = 0): weights exactly (0, 1), `J_v` = 0.
    raw: bool,
    /// ... and no propagation since: `J` = 0 (`H = [I₂, 0, 0]`).
    fresh: bool,
}

impl TiltLowPass {
    /// An empty filter.
    pub const fn new() -> Self {
        TiltLowPass {
            k: None,
            y: [[0.0; 2]; 2],
            w: [0.0; 2],
            j: [[[0.0; 3]; 2]; 2],
            raw: false,
            fresh: false,
        }
    }

    /// Empty the filter, keeping its coefficients.
    pub fn reset(&mut self) {
        *self = TiltLowPass { k: self.k, ..Self::new() };
    }

    /// Set the coefficients for samples `dt` s apart and a time constant (delay) `tau` s; 0:
    /// no low-pass.
    pub fn set_rate(&mut self, dt: f32, tau: f32) {
        self.k = if tau > 0.0 {
            let w0 = core::f32::consts::SQRT_2 / tau;
            Some([w0 * w0 * dt, core::f32::consts::SQRT_2 * w0 * dt, dt])
        } else {
            None
        };
    }

    /// The attitude error moved by `−A·δb` (`A = R·dt`, rows 0–1 used): the filter's samples
    /// are now that much further from today's error.
    #[inline(always)]
    pub fn propagate(&mut self, a: &Mat3) {
        self.fresh = false;
        if self.raw {
            // One raw sample: weights (0, 1), so `J += w·A` is `J_x += A` and `J_v` stays (the
            // same values but for the sign of a zero, without 12 products and 6 sums).
            unroll!(k in [0, 1] {
                unroll!(i in [0, 1, 2] {
                    self.j[1][k][i] += a[k][i];
                });
            });
            return;
        }
        unroll!(s in [0, 1] {
            let w = self.w[s];
            unroll!(k in [0, 1] {
                unroll!(i in [0, 1, 2] {
                    self.j[s][k][i] += w * a[k][i];
                });
            });
        });
    }

    /// One sample: the specific force `an` in the estimate's NED frame (north, east), g.
    #[inline(always)]
    pub fn push(&mut self, an: [f32; 2]) {
        let u = [-an[1], an[0]];
        let Some([c1, c2, dt]) = self.k else {
            // No low-pass: the sample itself, weight 1, no delay.
            *self = TiltLowPass {
                k: None,
                y: [[0.0; 2], u],
                w: [0.0, 1.0],
                j: [[[0.0; 3]; 2]; 2],
                raw: true,
                fresh: true,
            };
            return;
        };
        self.raw = false;
        self.fresh = false;
        // A new sample has weight 1 on today's error and no delay (J = 0).
        unroll!(k in [0, 1] {
            self.y[0][k] += c1 * (u[k] - self.y[1][k]) - c2 * self.y[0][k];
            self.y[1][k] += self.y[0][k] * dt;
            unroll!(i in [0, 1, 2] {
                self.j[0][k][i] -= c1 * self.j[1][k][i] + c2 * self.j[0][k][i];
                self.j[1][k][i] += self.j[0][k][i] * dt;
            });
        });
        self.w[0] += c1 * (1.0 - self.w[1]) - c2 * self.w[0];
        self.w[1] += self.w[0] * dt;
    }

    /// The measurement (δθ_x, δθ_y), rad, and its rows of `H`, with `vertical` the body axis
    /// along which the update is not to correct the bias (zero: none).
    #[inline(always)]
    pub fn measurement(&self, vertical: [f32; 3]) -> ([f32; 2], TiltRows) {
        (self.y[1], TiltRows { w: self.w[1], j: self.j[1], vertical, raw: self.fresh })
    }

    /// [`TiltLowPass::correct`] after a raw [`TiltLowPass::push`] and no propagation since
    /// (the measurement's `raw`: weights (0, 1), `J` = 0), which it then equals: only the
    /// output moves, by `dθ`.
    #[inline(always)]
    pub fn correct_raw(&mut self, dtheta: [f32; 2]) {
        debug_assert!(self.fresh && self.w == [0.0, 1.0] && self.j == [[[0.0; 3]; 2]; 2]);
        unroll!(k in [0, 1] {
            self.y[1][k] -= dtheta[k];
        });
    }

    /// The estimate moved by `dθ` (NED x, y; rad) and its bias by `db` (rad/s): take out of
    /// each state what that correction explains.
    #[inline(always)]
    pub fn correct(&mut self, dtheta: [f32; 2], db: Vec3) {
        unroll!(s in [0, 1] {
            unroll!(k in [0, 1] {
                let j = &self.j[s][k];
                self.y[s][k] -= self.w[s] * dtheta[k] + j[0] * db.x + j[1] * db.y + j[2] * db.z;
            });
        });
    }

    /// The estimate's frame turned about NED z by the angle whose cosine and sine are `c`, `s`
    /// (a heading change: the filter's vectors turn with it).
    #[cold]
    pub fn turn(&mut self, c: f32, s: f32) {
        let rot = |v: [f32; 2]| [c * v[0] - s * v[1], s * v[0] + c * v[1]];
        for st in 0..2 {
            self.y[st] = rot(self.y[st]);
            for i in 0..3 {
                let [a, b] = rot([self.j[st][0][i], self.j[st][1][i]]);
                self.j[st][0][i] = a;
                self.j[st][1][i] = b;
            }
        }
    }

    /// The states: `[v, x]`, each (δθ_x, δθ_y).
    pub fn states(&self) -> [[f32; 2]; 2] {
        self.y
    }
}

impl Default for TiltLowPass {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quaternion::Quaternion;

    /// A constant bias error δb on a still filter: the estimate's true tilt error ramps as
    /// `δθ(t) = −R·δb·t`, every sample shows the error of its time, and the model
    /// `x = w_x·δθ(now) + J_x·δb` holds to rounding at every step, from an empty filter on —
    /// the delay and the filling weight together. Once full (`t ≫ τ`), `J_x → τ·R`: the
    /// low-pass shows the error of τ ago.
    #[test]
    fn the_model_matches_a_ramp_from_a_bias_error() {
        let dt = 0.02f32;
        let tau = 3.0;
        let r = Quaternion::from_rotation_vector(Vec3::new(0.3, -0.2, 1.1)).to_rotation_matrix();
        let a: Mat3 = core::array::from_fn(|i| core::array::from_fn(|j| r[i][j] * dt));
        let db = Vec3::new(0.01, -0.02, 0.005);
        let rdb = [0, 1].map(|k| r[k][0] * db.x + r[k][1] * db.y + r[k][2] * db.z);
        let mut lp = TiltLowPass::new();
        lp.set_rate(dt, tau);
        let mut err = [0.0f32; 2];
        for n in 0..2000 {
            lp.propagate(&a);
            for k in 0..2 {
                err[k] -= rdb[k] * dt;
            }
            // The stage takes the error the estimate has now: an = (δθ_y, −δθ_x).
            lp.push([err[1], -err[0]]);
            let (y, h) = lp.measurement([0.0; 3]);
            for k in 0..2 {
                let model = h.w * err[k] + h.j[k][0] * db.x + h.j[k][1] * db.y + h.j[k][2] * db.z;
                assert!(
                    (y[k] - model).abs() < 1e-4 * rdb[k].abs() * (n + 1) as f32 * dt + 1e-7,
                    "step {n}, {k}: {} vs {model}",
                    y[k]
                );
            }
        }
        let (_, h) = lp.measurement([0.0; 3]);
        assert!((h.w - 1.0).abs() < 1e-4, "{}", h.w);
        for k in 0..2 {
            for i in 0..3 {
                let want = tau * r[k][i];
                assert!((h.j[k][i] - want).abs() < 0.01 * tau, "{k},{i}: {} vs {want}", h.j[k][i]);
            }
        }
    }

    /// The raw shortcuts (issue #36: `propagate` adding `A` to `J_x` alone, the update's unit
    /// rows, `correct_raw`) hold the values the general arithmetic gives: a copy forced onto
    /// the general paths (`raw`, `fresh` cleared after each raw push) agrees at every step,
    /// over raw samples, two propagations and a bias correction without a sample, and the switch to
    /// a low-pass right after them.
    #[test]
    fn the_raw_shortcuts_hold_the_general_values() {
        let r = Quaternion::from_rotation_vector(Vec3::new(0.2, 0.5, -0.7)).to_rotation_matrix();
        let a: Mat3 = core::array::from_fn(|i| core::array::from_fn(|j| r[i][j] * 0.02));
        let (mut fast, mut slow) = (TiltLowPass::new(), TiltLowPass::new());
        fast.set_rate(0.02, 0.0);
        slow.set_rate(0.02, 0.0);
        let db = Vec3::new(0.001, -0.002, 0.0005);
        for n in 0..40 {
            if n == 30 {
                fast.set_rate(0.02, 0.6);
                slow.set_rate(0.02, 0.6);
            }
            for _ in 0..(1 + usize::from(n % 9 == 3)) {
                fast.propagate(&a);
                slow.propagate(&a);
            }
            if n % 9 == 3 {
                // A bias measured elsewhere (the rest detector) between propagation and sample.
                fast.correct([0.0; 2], db);
                slow.correct([0.0; 2], db);
            }
            let an = [0.01 * (n as f32 * 0.3).sin(), -0.02 * (n as f32 * 0.2).cos()];
            fast.push(an);
            slow.push(an);
            (slow.raw, slow.fresh) = (false, false);
            let (_, h) = fast.measurement([0.0; 3]);
            assert_eq!(h.raw, n < 30, "step {n}");
            let dth = [0.001 * n as f32, -0.0005];
            if h.raw {
                fast.correct_raw(dth);
            } else {
                fast.correct(dth, db);
            }
            slow.correct(dth, db);
            assert_eq!((fast.y, fast.w, fast.j), (slow.y, slow.w, slow.j), "step {n}");
        }
    }

    /// The weight on real samples fills as the Butterworth's step response: ζ = 1/√2,
    /// ω₀ = √2/τ, by hand 1 − e^{−ζω₀t}·(cos ω_d t + sin ω_d t) with ω_d = ω₀/√2: 0.4917 at
    /// t = τ, and its 4.3 % overshoot at t = π/ω_d.
    #[test]
    fn the_weight_fills_as_the_step_response() {
        let dt = 0.0005f32;
        let tau = 3.0f32;
        let mut lp = TiltLowPass::new();
        lp.set_rate(dt, tau);
        let mut peak = 0.0f32;
        for n in 1..=20_000 {
            lp.push([0.0, 0.0]);
            peak = peak.max(lp.w[1]);
            if n == 6000 {
                let want = 1.0 - (-1.0f32).exp() * (1.0f32.cos() + 1.0f32.sin());
                assert!((lp.w[1] - want).abs() < 2e-3, "{} vs {want}", lp.w[1]);
            }
        }
        let overshoot = (-core::f32::consts::PI).exp();
        assert!((peak - 1.0 - overshoot).abs() < 2e-3, "peak {peak}, by hand {}", 1.0 + overshoot);
    }

    /// A correction takes out what it explains: a state that holds `w·δθ + J·δb` holds zero
    /// after the correction `(δθ, δb)`; a heading change turns the vectors with the frame.
    #[test]
    fn a_correction_and_a_turn_move_the_stages() {
        let mut lp = TiltLowPass::new();
        lp.set_rate(0.02, 3.0);
        let a: Mat3 = [[0.02, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 0.02]];
        let (dth, db) = ([0.01f32, -0.03f32], Vec3::new(0.002, 0.001, -0.004));
        for _ in 0..100 {
            lp.propagate(&a);
            lp.push([0.0, 0.0]);
        }
        for s in 0..2 {
            for k in 0..2 {
                let j = lp.j[s][k];
                lp.y[s][k] = lp.w[s] * dth[k] + j[0] * db.x + j[1] * db.y + j[2] * db.z;
            }
        }
        assert!(lp.y[1][0].abs() > 1e-3);
        lp.correct(dth, db);
        for s in 0..2 {
            for k in 0..2 {
                assert!(lp.y[s][k].abs() < 1e-8, "{s},{k}: {}", lp.y[s][k]);
            }
        }
        lp.y = [[0.01, 0.0], [0.0, 0.02]];
        let j = lp.j;
        let q = core::f32::consts::FRAC_PI_2;
        lp.turn(q.cos(), q.sin());
        let y = lp.states();
        assert!((y[0][1] - 0.01).abs() < 1e-7 && y[0][0].abs() < 1e-7, "{y:?}");
        assert!((y[1][0] + 0.02).abs() < 1e-7 && y[1][1].abs() < 1e-7, "{y:?}");
        // The bias sensitivities are NED vectors too: they turn with the frame (x ← −y, y ← x).
        assert!(j[1][0].iter().any(|v| v.abs() > 1e-3), "{j:?}");
        for st in 0..2 {
            for i in 0..3 {
                assert!((lp.j[st][0][i] + j[st][1][i]).abs() < 1e-7, "{st},{i}: {:?}", lp.j);
                assert!((lp.j[st][1][i] - j[st][0][i]).abs() < 1e-7, "{st},{i}: {:?}", lp.j);
            }
        }
    }

    /// A reset empties the states (a restart of the estimator: no sample, no weight, no
    /// delay) and keeps the coefficients: the next sample fills it as the first one did.
    #[test]
    fn a_reset_empties_the_filter_and_keeps_its_time_constant() {
        let a: Mat3 = [[0.02, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 0.02]];
        let mut lp = TiltLowPass::new();
        lp.set_rate(0.02, 1.0);
        let mut fresh = lp;
        for _ in 0..100 {
            lp.propagate(&a);
            lp.push([0.01, -0.02]);
        }
        assert!(lp.w[1] > 0.5 && lp.y[1][0] != 0.0 && lp.j[1][0][0] != 0.0);
        lp.reset();
        assert_eq!(lp, fresh);
        lp.push([0.01, -0.02]);
        fresh.push([0.01, -0.02]);
        assert_eq!(lp, fresh);
    }

    /// τ = 0 (`ekf.accel_time_constant = 0`, and the rule's raw samples): no low-pass, the
    /// measurement is the sample itself with weight 1 and no delay, whatever came before.
    #[test]
    fn without_a_time_constant_the_sample_is_the_measurement() {
        let mut lp = TiltLowPass::new();
        lp.set_rate(0.02, 1.0);
        for _ in 0..50 {
            lp.propagate(&[[0.02, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 0.02]]);
            lp.push([0.003, 0.001]);
        }
        lp.set_rate(0.02, 0.0);
        lp.push([0.002, -0.004]);
        let (z, h) = lp.measurement([0.0; 3]);
        assert_eq!(z, [0.004, 0.002]);
        assert_eq!((h.w, h.j, h.raw), (1.0, [[0.0; 3]; 2], true));
    }
}
