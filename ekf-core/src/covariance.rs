//! The EKF's 6×6 error covariance: attitude error δθ (rad, NED frame, left-multiplicative:
//! `q_true = Exp(δθ) ⊗ q̂`) and gyro-bias error δb (rad/s, body FRD, `b_true = b̂ + δb`).
//!
//! Stored as a full symmetric matrix whose upper triangle is computed and mirrored, so it is
//! symmetric by construction. Every operation exploits the model's structure; the flop counts
//! are in `docs/filter.md`.

use crate::{quaternion::Mat3, Vec3};

/// Number of error states.
pub const N: usize = 6;

/// Symmetric 6×6 covariance. Rows/columns 0–2: attitude error (rad², NED x, y, z);
/// 3–5: gyro-bias error ((rad/s)², body x, y, z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cov6 {
    /// The matrix, `m[row][col]`, always symmetric.
    pub m: [[f32; N]; N],
}

/// Innovation statistics of the two-dimensional tilt measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltInnovation {
    /// Innovation (δθ_x, δθ_y), rad.
    pub z: [f32; 2],
    /// Inverse innovation covariance, rad⁻².
    pub s_inv: [[f32; 2]; 2],
    /// Normalised innovation squared `zᵀ S⁻¹ z`.
    pub nis: f32,
}

impl Cov6 {
    /// A diagonal covariance.
    pub fn diagonal(d: [f32; N]) -> Self {
        let mut m = [[0.0; N]; N];
        for (i, v) in d.iter().enumerate() {
            m[i][i] = *v;
        }
        Cov6 { m }
    }

    /// Propagate over one step with `Φ = [[I, −A], [0, I]]`, `A = R·dt` (R the body→NED
    /// rotation), adding process noise: attitude `dt·(a·I + (c − a)·u uᵀ)` with `u` the body
    /// z axis in NED (gyro noise density `a` rad²/s on body x and y, `c` on body z), and bias
    /// `qb` (rad/s)² on each axis.
    pub fn predict(&mut self, a: &Mat3, psd_xy: f32, psd_z: f32, u: Vec3, dt: f32, qb: f32) {
        let p = &mut self.m;
        // U = P_ab − A·P_bb  (the new P_ab).
        let mut new_ab = [[0.0f32; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                let apbb = a[i][0] * p[3][3 + j] + a[i][1] * p[4][3 + j] + a[i][2] * p[5][3 + j];
                new_ab[i][j] = p[i][3 + j] - apbb;
            }
        }
        // P_aa' = P_aa − P_ab·Aᵀ − A·Uᵀ + Q_a (upper triangle).
        let qd = (psd_z - psd_xy) * dt;
        let qi = psd_xy * dt;
        let uu = [u.x, u.y, u.z];
        for i in 0..3 {
            for j in i..3 {
                let pab_at = p[i][3] * a[j][0] + p[i][4] * a[j][1] + p[i][5] * a[j][2];
                let a_ut = a[i][0] * new_ab[j][0] + a[i][1] * new_ab[j][1] + a[i][2] * new_ab[j][2];
                let mut v = p[i][j] - pab_at - a_ut + qd * uu[i] * uu[j];
                if i == j {
                    v += qi;
                }
                p[i][j] = v;
                p[j][i] = v;
            }
        }
        for i in 0..3 {
            for j in 0..3 {
                p[i][3 + j] = new_ab[i][j];
                p[3 + j][i] = new_ab[i][j];
            }
            p[3 + i][3 + i] += qb * dt;
        }
    }

    /// Statistics of the tilt innovation `z` (rad) with measurement variance `r` (rad²) per
    /// component; the measurement matrix selects states 0 and 1.
    pub fn tilt_innovation(&self, z: [f32; 2], r: f32) -> Option<TiltInnovation> {
        let s00 = self.m[0][0] + r;
        let s01 = self.m[0][1];
        let s11 = self.m[1][1] + r;
        let det = s00 * s11 - s01 * s01;
        if !(det.is_finite() && det > 0.0) {
            return None;
        }
        let inv = 1.0 / det;
        let s_inv = [[s11 * inv, -s01 * inv], [-s01 * inv, s00 * inv]];
        let nis = z[0] * (s_inv[0][0] * z[0] + s_inv[0][1] * z[1])
            + z[1] * (s_inv[1][0] * z[0] + s_inv[1][1] * z[1]);
        Some(TiltInnovation { z, s_inv, nis })
    }

    /// Kalman update with the tilt measurement; rows with `frozen[i]` get zero gain (their
    /// state does not move and, Joseph-consistently, their mutual covariance is unchanged).
    /// Returns the state correction δx.
    pub fn update_tilt(&mut self, t: &TiltInnovation, frozen: [bool; N]) -> [f32; N] {
        let p = &mut self.m;
        // C = P Hᵀ (columns 0, 1); K = C S⁻¹.
        let mut k = [[0.0f32; 2]; N];
        let mut c = [[0.0f32; 2]; N];
        let mut dx = [0.0f32; N];
        for i in 0..N {
            c[i] = [p[i][0], p[i][1]];
            k[i] = [
                c[i][0] * t.s_inv[0][0] + c[i][1] * t.s_inv[1][0],
                c[i][0] * t.s_inv[0][1] + c[i][1] * t.s_inv[1][1],
            ];
            if !frozen[i] {
                dx[i] = k[i][0] * t.z[0] + k[i][1] * t.z[1];
            }
        }
        // Joseph form with a gain restricted to the free rows reduces to
        // P'_il = P_il − (K Cᵀ)_il unless both i and l are frozen.
        for i in 0..N {
            for l in i..N {
                if frozen[i] && frozen[l] {
                    continue;
                }
                let v = p[i][l] - (k[i][0] * c[l][0] + k[i][1] * c[l][1]);
                p[i][l] = v;
                p[l][i] = v;
            }
        }
        dx
    }

    /// Scalar Kalman update of state `j` (`H = e_j`) with innovation `z` and measurement
    /// variance `r`; only rows with `free[i]` move (Joseph-consistent, as in `update_tilt`).
    /// Returns the correction and the normalised innovation squared, or `None` when the
    /// innovation variance is not positive.
    pub fn update_scalar(
        &mut self,
        j: usize,
        z: f32,
        r: f32,
        free: [bool; N],
    ) -> Option<([f32; N], f32)> {
        let j = j.min(N - 1);
        let s = self.m[j][j] + r;
        if !(s.is_finite() && s > 0.0) {
            return None;
        }
        let inv = 1.0 / s;
        let c: [f32; N] = core::array::from_fn(|i| self.m[i][j]);
        let mut dx = [0.0f32; N];
        for i in 0..N {
            if free[i] {
                dx[i] = c[i] * inv * z;
            }
        }
        let p = &mut self.m;
        for i in 0..N {
            for l in i..N {
                if !(free[i] || free[l]) {
                    continue;
                }
                let v = p[i][l] - c[i] * c[l] * inv;
                p[i][l] = v;
                p[l][i] = v;
            }
        }
        Some((dx, z * z * inv))
    }

    /// Add `v` to diagonal element `i`.
    pub fn inflate(&mut self, i: usize, v: f32) {
        let i = i.min(N - 1);
        self.m[i][i] += v;
    }

    /// Cheap health check, run every cycle: every diagonal element finite and in
    /// `(0, max_diag[i]]`. (Symmetry holds by construction: every write is mirrored.)
    pub fn diagonal_is_healthy(&self, max_diag: &[f32; N]) -> bool {
        (0..N).all(|i| {
            let d = self.m[i][i];
            d.is_finite() && d > 0.0 && d <= max_diag[i]
        })
    }

    /// Full health check: every element finite, diagonal in `(0, max_diag[i]]`, each off-diagonal
    /// within the Cauchy–Schwarz bound `P_il² ≤ P_ii·P_ll` (a necessary condition for
    /// positive semi-definiteness), and symmetric. Returns false when broken.
    pub fn is_healthy(&self, max_diag: &[f32; N]) -> bool {
        let p = &self.m;
        for i in 0..N {
            let d = p[i][i];
            if !(d.is_finite() && d > 0.0 && d <= max_diag[i]) {
                return false;
            }
        }
        for i in 0..N {
            for l in i + 1..N {
                let v = p[i][l];
                if !v.is_finite() || v != p[l][i] || v * v > p[i][i] * p[l][l] * 1.0001 {
                    return false;
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dense reference: Φ P Φᵀ + Q with plain matrix products.
    fn dense_predict(p: &[[f32; 6]; 6], a: &Mat3, q: &[[f32; 6]; 6]) -> [[f32; 6]; 6] {
        let mut phi = [[0.0f32; 6]; 6];
        for i in 0..6 {
            phi[i][i] = 1.0;
        }
        for i in 0..3 {
            for j in 0..3 {
                phi[i][3 + j] = -a[i][j];
            }
        }
        let mut tmp = [[0.0f32; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                tmp[i][j] = (0..6).map(|k| phi[i][k] * p[k][j]).sum();
            }
        }
        let mut out = [[0.0f32; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                out[i][j] = (0..6).map(|k| tmp[i][k] * phi[j][k]).sum::<f32>() + q[i][j];
            }
        }
        out
    }

    fn sample_p() -> Cov6 {
        // A random-looking SPD matrix: L Lᵀ.
        let mut l = [[0.0f32; 6]; 6];
        let mut s = 1u32;
        for i in 0..6 {
            for j in 0..=i {
                s = s.wrapping_mul(1103515245).wrapping_add(12345);
                l[i][j] = ((s >> 16) % 1000) as f32 / 1000.0 - 0.5 + if i == j { 1.0 } else { 0.0 };
            }
        }
        let mut m = [[0.0f32; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                m[i][j] = (0..6).map(|k| l[i][k] * l[j][k]).sum::<f32>() * 1e-3;
            }
        }
        Cov6 { m }
    }

    #[test]
    fn structured_predict_equals_dense_product() {
        let mut p = sample_p();
        let q = crate::Quaternion::from_rotation_vector(Vec3::new(0.3, -0.5, 1.2));
        let r = q.to_rotation_matrix();
        let dt = 0.02;
        let a: Mat3 = core::array::from_fn(|i| core::array::from_fn(|j| r[i][j] * dt));
        let (psd_xy, psd_z, qb) = (1e-4, 2e-6, 1e-9);
        let u = Vec3::new(r[0][2], r[1][2], r[2][2]);
        // Dense Q: R diag(a, a, c) Rᵀ dt.
        let mut qm = [[0.0f32; 6]; 6];
        let d = [psd_xy, psd_xy, psd_z];
        for i in 0..3 {
            for j in 0..3 {
                qm[i][j] = (0..3).map(|k| r[i][k] * d[k] * r[j][k]).sum::<f32>() * dt;
            }
            qm[3 + i][3 + i] = qb * dt;
        }
        let expect = dense_predict(&p.m, &a, &qm);
        p.predict(&a, psd_xy, psd_z, u, dt, qb);
        for i in 0..6 {
            for j in 0..6 {
                assert!((p.m[i][j] - expect[i][j]).abs() < 1e-8, "{i},{j}");
            }
        }
    }

    #[test]
    fn tilt_update_matches_joseph_form_and_freezes_yaw() {
        let p0 = sample_p();
        let r = 1e-4;
        let z = [0.01, -0.02];
        for frozen_yaw in [false, true] {
            let mut p = p0;
            let t = p.tilt_innovation(z, r).unwrap();
            let mut frozen = [false; 6];
            frozen[2] = frozen_yaw;
            let dx = p.update_tilt(&t, frozen);
            // Dense Joseph form with the restricted gain.
            let mut k = [[0.0f32; 2]; 6];
            for i in 0..6 {
                if !frozen[i] {
                    for c in 0..2 {
                        k[i][c] = (0..2).map(|m| p0.m[i][m] * t.s_inv[m][c]).sum();
                    }
                }
            }
            let mut ikh = [[0.0f32; 6]; 6];
            for i in 0..6 {
                ikh[i][i] = 1.0;
                ikh[i][0] -= k[i][0];
                ikh[i][1] -= k[i][1];
            }
            for i in 0..6 {
                for j in 0..6 {
                    let mut v = 0.0;
                    for a in 0..6 {
                        for b in 0..6 {
                            v += ikh[i][a] * p0.m[a][b] * ikh[j][b];
                        }
                    }
                    v += r * (k[i][0] * k[j][0] + k[i][1] * k[j][1]);
                    assert!((p.m[i][j] - v).abs() < 1e-8, "{i},{j}: {} vs {v}", p.m[i][j]);
                }
            }
            if frozen_yaw {
                assert_eq!(dx[2], 0.0);
                assert_eq!(p.m[2][2], p0.m[2][2]);
            } else {
                assert!(dx[2] != 0.0);
            }
            assert!(p.is_healthy(&[1.0; 6]));
        }
    }

    #[test]
    fn health_check_catches_broken_matrices() {
        let good = sample_p();
        assert!(good.is_healthy(&[1.0; 6]));
        let mut bad = good;
        bad.m[3][3] = -1e-6;
        assert!(!bad.is_healthy(&[1.0; 6]));
        let mut bad = good;
        bad.m[1][4] = f32::NAN;
        bad.m[4][1] = f32::NAN;
        assert!(!bad.is_healthy(&[1.0; 6]));
        let mut bad = good;
        bad.m[0][2] = 1.0;
        bad.m[2][0] = 1.0;
        assert!(!bad.is_healthy(&[1.0; 6]));
        let mut bad = good;
        bad.m[0][1] += 1e-6;
        assert!(!bad.is_healthy(&[1.0; 6]));
        assert!(!good.is_healthy(&[1e-9; 6]));
    }
}
