//! Covariance repair (symmetrise, factorise with a retry, reset), transport with the mean, and
//! the health checks (module documentation of [`super`], *Repair* and *Covariance transport*).

use nalgebra::{SMatrix, SVector};

use super::filter_loop::Core;
use super::model::normalise_quaternion;
use super::{Matrix, Real, Vector, N};
use crate::{Flags, Quaternion};

/// Largest variance of a quaternion component before the health check resets `P`.
pub(super) const MAX_Q_VAR: f32 = 1.0;
/// Largest gyro-bias variance before the health check resets `P`, (rad/s)².
pub(super) const MAX_BIAS_VAR: f32 = 1.0;

/// Make `p` exactly symmetric.
pub(crate) fn symmetrise<T: Real>(p: &mut Matrix<T>) {
    for i in 0..N {
        for j in 0..i {
            let m = (p[(i, j)] + p[(j, i)]) * T::of(0.5);
            p[(i, j)] = m;
            p[(j, i)] = m;
        }
    }
}

pub(super) fn all_finite<T: Real, const R: usize, const C: usize>(m: &SMatrix<T, R, C>) -> bool {
    m.iter().all(|v| v.is_finite())
}

impl<T: Real, const M: usize> Core<T, M> {
    /// Lower Cholesky factor of `P`, repairing `P` when it fails (module documentation).
    pub(super) fn factor(&mut self) -> (Option<Matrix<T>>, Flags) {
        if all_finite(&self.p) {
            if let Some(c) = self.p.cholesky() {
                return (Some(c.l()), Flags::NONE);
            }
            let max = (0..N).map(|i| self.p[(i, i)].abs()).fold(T::zero(), |a, b| a.max(b));
            let mut pj = self.p;
            for i in 0..N {
                let d = pj[(i, i)];
                pj[(i, i)] = d + d.abs() * T::of(1e-4) + max * T::of(1e-9);
            }
            if let Some(c) = pj.cholesky() {
                self.p = pj;
                return (Some(c.l()), Flags::HEALTH_RESET);
            }
        }
        self.p = self.initial_cov();
        (self.p.cholesky().map(|c| c.l()), Flags::HEALTH_RESET)
    }

    /// Carry `P` from the prior mean quaternion `q_prior` to the current one `q`:
    /// `P ← T P Tᵀ`, `T = blockdiag(M, I₃)` with `M` the right multiplication by
    /// `Δ = q_prior* ⊗ q`, which maps `Γ(q_prior)` onto `Γ(q)` and `q_prior` onto `q`.
    pub(super) fn transport(&mut self, q_prior: &SVector<T, 4>) {
        let (w0, a0, b0, c0) = (q_prior[0], -q_prior[1], -q_prior[2], -q_prior[3]);
        let (w1, a1, b1, c1) = (self.x[0], self.x[1], self.x[2], self.x[3]);
        // Δ = q_prior* ⊗ q.
        let dw = w0 * w1 - a0 * a1 - b0 * b1 - c0 * c1;
        let dx = w0 * a1 + a0 * w1 + b0 * c1 - c0 * b1;
        let dy = w0 * b1 - a0 * c1 + b0 * w1 + c0 * a1;
        let dz = w0 * c1 + a0 * b1 - b0 * a1 + c0 * w1;
        let m = SMatrix::<T, 4, 4>::new(
            dw, -dx, -dy, -dz, dx, dw, dz, -dy, dy, -dz, dw, dx, dz, dy, -dx, dw,
        );
        let mut t = Matrix::<T>::identity();
        t.fixed_view_mut::<4, 4>(0, 0).copy_from(&m);
        self.p = t * self.p * t.transpose();
        symmetrise(&mut self.p);
    }

    /// Health checks: restore a broken state, reset a broken covariance; flag it.
    pub(super) fn health(&mut self, before: &Vector<T>) -> Flags {
        let mut flags = Flags::NONE;
        let qn = self.x.fixed_rows::<4>(0).norm_squared();
        let q_ok = (0..4).all(|k| self.x[k].is_finite()) && (qn - T::one()).abs() <= T::of(1e-3);
        if !q_ok {
            for k in 0..4 {
                self.x[k] = before[k];
            }
            normalise_quaternion(&mut self.x);
            if !(0..4).all(|k| self.x[k].is_finite()) {
                self.set_state(Quaternion::IDENTITY, self.gyro_bias());
            }
            flags |= Flags::HEALTH_RESET;
        }
        let b_ok = (4..N).all(|k| {
            self.x[k].is_finite() && self.x[k].abs() <= T::of(self.settings.limits.gyro_range)
        });
        if !b_ok {
            for k in 4..N {
                self.x[k] = if before[k].is_finite() { before[k] } else { T::zero() };
            }
            flags |= Flags::HEALTH_RESET;
        }
        let p_ok = all_finite(&self.p)
            && (0..N).all(|i| {
                let max = if i < 4 { MAX_Q_VAR } else { MAX_BIAS_VAR };
                self.p[(i, i)] > T::zero() && self.p[(i, i)] <= T::of(max)
            });
        if !p_ok {
            self.p = self.initial_cov();
            flags |= Flags::HEALTH_RESET;
        }
        flags
    }
}
