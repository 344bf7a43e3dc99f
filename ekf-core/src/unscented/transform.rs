//! The unscented transform over a sigma-point set, in deviation form (module documentation of
//! [`super`]).

use nalgebra::{SMatrix, SVector};

use super::{Matrix, Real, Vector, N};

/// A sigma-point set: point `i` is `x + √P · z_i` (`√P` the lower Cholesky factor), with mean
/// weight `wm[i]` and covariance weight `wc[i]`. Column 0 is the central point (`z_0 = 0`).
/// The weighted mean of the `z_i` is zero and their weighted second moment the identity.
#[derive(Clone, Debug)]
pub(crate) struct SigmaSet<T: Real, const M: usize> {
    pub z: SMatrix<T, N, M>,
    pub wm: [T; M],
    pub wc: [T; M],
}

impl<T: Real, const M: usize> SigmaSet<T, M> {
    /// The points `x + L z_i` as columns.
    pub fn points(&self, x: &Vector<T>, l: &Matrix<T>) -> SMatrix<T, N, M> {
        let mut pts = l * self.z;
        for mut c in pts.column_iter_mut() {
            c += x;
        }
        pts
    }

    /// Weighted mean `d̄ = Σ Wm_i D_i` and covariance `Σ Wc_i (D_i − d̄)(D_i − d̄)ᵀ` of the
    /// deviations `D_i` (columns of `dev`).
    pub fn moments<const R: usize>(
        &self,
        dev: &SMatrix<T, R, M>,
    ) -> (SVector<T, R>, SMatrix<T, R, R>) {
        let mut mean = SVector::<T, R>::zeros();
        for i in 0..M {
            mean += dev.column(i) * self.wm[i];
        }
        let mut cov = SMatrix::<T, R, R>::zeros();
        for i in 0..M {
            let d = dev.column(i) - mean;
            cov += (d * d.transpose()) * self.wc[i];
        }
        (mean, cov)
    }

    /// Weighted cross-covariance `Σ Wc_i (Dx_i − mx)(Dy_i − my)ᵀ`.
    pub fn cross<const R: usize>(
        &self,
        dx: &SMatrix<T, N, M>,
        mx: &Vector<T>,
        dy: &SMatrix<T, R, M>,
        my: &SVector<T, R>,
    ) -> SMatrix<T, N, R> {
        let mut c = SMatrix::<T, N, R>::zeros();
        for i in 0..M {
            let a = dx.column(i) - mx;
            let b = dy.column(i) - my;
            c += (a * b.transpose()) * self.wc[i];
        }
        c
    }
}
