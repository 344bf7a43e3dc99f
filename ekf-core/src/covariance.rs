//! The EKF's 6×6 error covariance: attitude error δθ (rad, NED frame, left-multiplicative:
//! `q_true = Exp(δθ) ⊗ q̂`) and gyro-bias error δb (rad/s, body FRD, `b_true = b̂ + δb`).
//!
//! Stored as a full symmetric matrix whose upper triangle is computed and mirrored, so it is
//! symmetric by construction. Every operation exploits the model's structure; the flop counts
//! are in `docs/filter.md`.

use crate::{quaternion::Mat3, Vec3};

/// Number of error states.
pub const N: usize = 6;

/// `N`, hidden from the optimiser: loops up to it stay rolled instead of being unrolled 21
/// times over. For the rarely run updates, whose unrolled code would cost the 64 KiB
/// firmware kilobytes of flash for no measurable time.
#[inline(always)]
fn rolled() -> usize {
    core::hint::black_box(N).min(N)
}

/// Symmetric 6×6 covariance. Rows/columns 0–2: attitude error (rad², NED x, y, z);
/// 3–5: gyro-bias error ((rad/s)², body x, y, z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cov6 {
    /// The matrix, `m[row][col]`, always symmetric.
    pub m: [[f32; N]; N],
}

/// Process noise densities of the propagation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProcessNoise {
    /// Gyro white-noise density on body x and y (their mean), rad²/s.
    pub gyro_psd_xy: f32,
    /// Gyro white-noise density on body z, rad²/s.
    pub gyro_psd_z: f32,
    /// Gyro-bias random walk, (rad/s)²/s.
    pub bias_random_walk: f32,
}

/// How the yaw-error row (index 2) takes part in the covariance operations.
///
/// The accelerometer measures only the tilt errors `(δθ_x, δθ_y)`, and in the propagation
/// the tilt and bias elements of `P'` depend only on tilt and bias elements of `P` (`Φ`'s
/// attitude block is the identity). So when nothing corrects yaw — yaw-split on and no
/// magnetometer — row and column 2 are write-only: skipping them changes no other element, no
/// estimate and no gate decision, and saves a third of the covariance arithmetic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum YawRow {
    /// Tracked and corrected by the tilt update through its correlations (yaw-split off).
    Free,
    /// Tracked, but the tilt update gives it zero gain (yaw-split on, magnetometer on: the
    /// magnetometer's heading update needs the yaw variance and correlations).
    Frozen,
    /// Not tracked: row and column 2 keep their values (yaw-split on, no magnetometer).
    Untracked,
}

/// Innovation statistics of the two-dimensional tilt measurement, arranged for its update as
/// two sequential scalar updates (`δθ_x`, then `δθ_y`): the measurement noise is independent
/// per component, so this is exactly the joint update, in fewer operations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltInnovation {
    /// Innovation (δθ_x, δθ_y), rad.
    pub z: [f32; 2],
    /// Innovation of the second scalar update: `δθ_y` after the `δθ_x` update, rad.
    pub z2: f32,
    /// Inverse innovation variances of the two scalar updates, rad⁻².
    pub s_inv: [f32; 2],
    /// Scale of the bias rows' gain in the update, in [0, 1]: 1 is the Kalman gain; less
    /// learns the bias more slowly from this measurement (exact Joseph-form covariance for the
    /// scaled gain). [`Cov6::tilt_innovation`] sets 1.
    pub bias_gain: f32,
}

impl TiltInnovation {
    /// Normalised innovation squared `zᵀ S⁻¹ z` of the joint measurement (the sum of the two
    /// scalar ones).
    pub fn nis(&self) -> f32 {
        self.z[0] * self.z[0] * self.s_inv[0] + self.z2 * self.z2 * self.s_inv[1]
    }
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

    /// Propagate over one step of `dt` s with `Φ = [[I, −A], [0, I]]`, `A = R·dt` (R the
    /// body→NED rotation), adding process noise `q`: attitude `dt·(a·I + (c − a)·u uᵀ)` with `u`
    /// the body z axis in NED (gyro noise density `a` on body x and y, `c` on body z), and bias
    /// `dt·qb` on each axis.
    ///
    /// With `yaw` = [`YawRow::Untracked`] the yaw-error row and column (index 2) are left as
    /// they are: no other element depends on them (see [`YawRow`]), so every other element is
    /// bit-for-bit what the full propagation gives, at two thirds of the cost.
    pub fn predict(&mut self, a: &Mat3, u: Vec3, dt: f32, q: &ProcessNoise, yaw: YawRow) {
        let (psd_xy, psd_z, qb) = (q.gyro_psd_xy, q.gyro_psd_z, q.bias_random_walk);
        match yaw {
            YawRow::Untracked => self.predict_untracked(a, psd_xy, psd_z, u, dt, qb),
            YawRow::Free | YawRow::Frozen => self.predict_rows::<3>(a, psd_xy, psd_z, u, dt, qb),
        }
    }

    /// [`Cov6::predict_rows`] for the two tilt rows, unrolled (the default configuration's hot
    /// path): the same operations in the same order.
    #[inline(always)]
    fn predict_untracked(&mut self, a: &Mat3, psd_xy: f32, psd_z: f32, u: Vec3, dt: f32, qb: f32) {
        let p = &mut self.m;
        let mut new_ab = [[0.0f32; 3]; 2];
        unroll!(i in [0, 1] {
            unroll!(j in [0, 1, 2] {
                let apbb = a[i][0] * p[3][3 + j] + a[i][1] * p[4][3 + j] + a[i][2] * p[5][3 + j];
                new_ab[i][j] = p[i][3 + j] - apbb;
            })
        });
        let qd = (psd_z - psd_xy) * dt;
        let qi = psd_xy * dt;
        let uu = [u.x, u.y, u.z];
        let qdu = [qd * uu[0], qd * uu[1]];
        unroll!(i in [0, 1] {
            let v: [f32; 3] = core::array::from_fn(|k| p[i][3 + k] + new_ab[i][k]);
            let d = p[i][i] - (v[0] * a[i][0] + v[1] * a[i][1] + v[2] * a[i][2]);
            p[i][i] = d + qdu[i] * uu[i] + qi;
            if i == 0 {
                let j = 1;
                let pab_at = p[i][3] * a[j][0] + p[i][4] * a[j][1] + p[i][5] * a[j][2];
                let a_ut = a[i][0] * new_ab[j][0] + a[i][1] * new_ab[j][1] + a[i][2] * new_ab[j][2];
                let v = p[i][j] - pab_at - a_ut + qdu[i] * uu[j];
                p[i][j] = v;
                p[j][i] = v;
            }
        });
        unroll!(i in [0, 1] {
            unroll!(j in [0, 1, 2] {
                p[i][3 + j] = new_ab[i][j];
                p[3 + j][i] = new_ab[i][j];
            })
        });
        let qbd = qb * dt;
        unroll!(i in [3, 4, 5] {
            p[i][i] += qbd;
        });
    }

    /// [`Cov6::predict`] over the attitude rows `0..NA` (and the bias block).
    #[inline(always)]
    fn predict_rows<const NA: usize>(
        &mut self,
        a: &Mat3,
        psd_xy: f32,
        psd_z: f32,
        u: Vec3,
        dt: f32,
        qb: f32,
    ) {
        let p = &mut self.m;
        // U = P_ab − A·P_bb  (the new P_ab).
        let mut new_ab = [[0.0f32; 3]; NA];
        for i in 0..NA {
            for j in 0..3 {
                let apbb = a[i][0] * p[3][3 + j] + a[i][1] * p[4][3 + j] + a[i][2] * p[5][3 + j];
                new_ab[i][j] = p[i][3 + j] - apbb;
            }
        }
        // P_aa' = P_aa − P_ab·Aᵀ − A·Uᵀ + Q_a (upper triangle).
        let qd = (psd_z - psd_xy) * dt;
        let qi = psd_xy * dt;
        let uu = [u.x, u.y, u.z];
        let qdu: [f32; NA] = core::array::from_fn(|i| qd * uu[i]);
        for i in 0..NA {
            // Diagonal: P_ab,i·a_i + a_i·U_i = (P_ab,i + U_i)·a_i, three multiplications fewer.
            let v: [f32; 3] = core::array::from_fn(|k| p[i][3 + k] + new_ab[i][k]);
            let d = p[i][i] - (v[0] * a[i][0] + v[1] * a[i][1] + v[2] * a[i][2]);
            p[i][i] = d + qdu[i] * uu[i] + qi;
            for j in i + 1..NA {
                let pab_at = p[i][3] * a[j][0] + p[i][4] * a[j][1] + p[i][5] * a[j][2];
                let a_ut = a[i][0] * new_ab[j][0] + a[i][1] * new_ab[j][1] + a[i][2] * new_ab[j][2];
                let v = p[i][j] - pab_at - a_ut + qdu[i] * uu[j];
                p[i][j] = v;
                p[j][i] = v;
            }
        }
        for (i, row) in new_ab.iter().enumerate() {
            for j in 0..3 {
                p[i][3 + j] = row[j];
                p[3 + j][i] = row[j];
            }
        }
        let qbd = qb * dt;
        for i in 3..N {
            p[i][i] += qbd;
        }
    }

    /// Statistics of the tilt innovation `z` (rad) with measurement variance `r` (rad²) per
    /// component; the measurement matrix selects states 0 and 1. `None` when an innovation
    /// variance is not positive and finite.
    pub fn tilt_innovation(&self, z: [f32; 2], r: f32) -> Option<TiltInnovation> {
        let p = &self.m;
        let s1 = p[0][0] + r;
        if !crate::fcmp::in_pos_range(s1, f32::MAX) {
            return None;
        }
        let inv1 = 1.0 / s1;
        // After the δθ_x update: gain of state 1, its innovation and variance.
        let g1 = p[1][0] * inv1;
        let z2 = z[1] - g1 * z[0];
        let s2 = p[1][1] - g1 * p[0][1] + r;
        if !crate::fcmp::in_pos_range(s2, f32::MAX) {
            return None;
        }
        let inv2 = 1.0 / s2;
        Some(TiltInnovation { z, z2, s_inv: [inv1, inv2], bias_gain: 1.0 })
    }

    /// Kalman update with the tilt measurement (`H` selects states 0 and 1). With
    /// [`YawRow::Frozen`] the yaw row gets zero gain (yaw does not move and, Joseph-consistently,
    /// its variance is unchanged); with [`YawRow::Untracked`] row and column 2 are not touched
    /// at all. Returns the state correction δx.
    pub fn update_tilt(&mut self, t: &TiltInnovation, yaw: YawRow) -> [f32; N] {
        const ALL: [bool; N] = [true; N];
        const NO_YAW: [bool; N] = [true, true, false, true, true, true];
        match yaw {
            YawRow::Free => self.update_tracked(t, ALL),
            YawRow::Frozen => self.update_tracked(t, NO_YAW),
            YawRow::Untracked => self.update_untracked(t),
        }
    }

    /// The tilt update with the yaw row tracked (magnetometer on or yaw-split off): one
    /// out-of-line copy for both gain patterns, to keep the firmware's flash down; the default
    /// configuration's update is the inlined `Untracked` one.
    #[inline(never)]
    fn update_tracked(&mut self, t: &TiltInnovation, gain: [bool; N]) -> [f32; N] {
        let mut dx = [0.0f32; N];
        let n = rolled();
        // Gain scale per row: 0 frozen, 1 tilt (and yaw), `bias_gain` on the biases.
        let k: [f32; N] = core::array::from_fn(|i| match (gain[i], i >= 3) {
            (false, _) => 0.0,
            (true, false) => 1.0,
            (true, true) => t.bias_gain,
        });
        for j in 0..2 {
            let first = j == 0;
            let (z, inv) = if first { (t.z[0], t.s_inv[0]) } else { (t.z2, t.s_inv[1]) };
            let p = &mut self.m;
            let c: [f32; N] = core::array::from_fn(|i| p[i][j]);
            for i in 0..n {
                let g = c[i] * inv;
                if gain[i] {
                    dx[i] = if first { k[i] * g * z } else { dx[i] + k[i] * g * z };
                }
                for l in i..n {
                    // Joseph form with the scaled gains K_i = k_i·c_i/s.
                    let f = k[i] + k[l] - k[i] * k[l];
                    if f != 0.0 {
                        let v = p[i][l] - f * g * c[l];
                        p[i][l] = v;
                        p[l][i] = v;
                    }
                }
            }
        }
        dx
    }

    /// [`Cov6::update_tilt`] with the yaw row untracked (the default configuration's hot path),
    /// unrolled: two scalar updates, `H = e₀` with innovation `z₀`, then `H = e₁` with `z2`, on
    /// the tilt and bias rows. The bias rows' gain is scaled by `bias_gain` = β; the Joseph form
    /// with that gain changes only the bias block, by the factor `2β − β²`.
    #[inline(always)]
    fn update_untracked(&mut self, t: &TiltInnovation) -> [f32; N] {
        let mut dx = [0.0f32; N];
        // The bias rows: the state's gain ×β, the covariance's ×(2β − β²); nothing to scale
        // when β = 1 (most still samples).
        let b = t.bias_gain;
        let scaled = b.to_bits() != 1.0f32.to_bits();
        let bb = if scaled { b * (2.0 - b) } else { 1.0 };
        unroll!(j in [0, 1] {
            let first = j == 0;
            let (z, inv) = if first { (t.z[0], t.s_inv[0]) } else { (t.z2, t.s_inv[1]) };
            let p = &mut self.m;
            // c = P e_j, g = c / s; P' = P − g cᵀ (yaw row and column untouched).
            let mut c = [0.0f32; N];
            let mut g = [0.0f32; N];
            // The gain for the state (g·β on the bias rows) and for the covariance (g·(2β − β²)
            // on the bias block, g elsewhere).
            let mut gp = [0.0f32; N];
            unroll!(i in [0, 1, 3, 4, 5] {
                c[i] = p[i][j];
                g[i] = c[i] * inv;
                gp[i] = g[i];
                if i >= 3 && scaled {
                    gp[i] = bb * g[i];
                    g[i] *= b;
                }
            });
            unroll!(i in [0, 1, 3, 4, 5] {
                dx[i] = if first { g[i] * z } else { dx[i] + g[i] * z };
            });
            unroll!(i in [0, 1, 3, 4, 5] {
                unroll!(l in [0, 1, 3, 4, 5] {
                    if l >= i {
                        // Rows 0–1 (tilt, and tilt–bias): c_i c_l / s; bias block: ×(2β − β²).
                        let v = p[i][l] - gp[i] * c[l];
                        p[i][l] = v;
                        p[l][i] = v;
                    }
                });
            });
        });
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
        let mut ok = true;
        unroll!(i in [0, 1, 2, 3, 4, 5] {
            ok &= crate::fcmp::in_pos_range(self.m[i][i], max_diag[i]);
        });
        ok
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
        let noise = ProcessNoise { gyro_psd_xy: psd_xy, gyro_psd_z: psd_z, bias_random_walk: qb };
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
        let p0 = p;
        p.predict(&a, u, dt, &noise, YawRow::Free);
        // Untracked yaw: every other element bit for bit the same, row/column 2 untouched.
        let mut p2 = p0;
        p2.predict(&a, u, dt, &noise, YawRow::Untracked);
        for i in 0..6 {
            for j in 0..6 {
                let want = if i == 2 || j == 2 { p0.m[i][j] } else { p.m[i][j] };
                assert_eq!(p2.m[i][j].to_bits(), want.to_bits(), "{i},{j}");
            }
        }
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
            let dx = p.update_tilt(&t, if frozen_yaw { YawRow::Frozen } else { YawRow::Free });
            if frozen_yaw {
                // Untracked: the same tilt and bias elements and correction, bit for bit;
                // row/column 2 untouched.
                let mut p2 = p0;
                let dx2 = p2.update_tilt(&t, YawRow::Untracked);
                assert_eq!(dx, dx2);
                for i in 0..6 {
                    for j in 0..6 {
                        let want = if i == 2 || j == 2 { p0.m[i][j] } else { p.m[i][j] };
                        assert_eq!(p2.m[i][j].to_bits(), want.to_bits(), "{i},{j}");
                    }
                }
            }
            // Dense Joseph form with the restricted gain.
            let (s00, s01, s11) = (p0.m[0][0] + r, p0.m[0][1], p0.m[1][1] + r);
            let det = s00 * s11 - s01 * s01;
            let s_inv = [[s11 / det, -s01 / det], [-s01 / det, s00 / det]];
            let nis = z[0] * (s_inv[0][0] * z[0] + s_inv[0][1] * z[1])
                + z[1] * (s_inv[1][0] * z[0] + s_inv[1][1] * z[1]);
            assert!((t.nis() - nis).abs() < 1e-4 * nis, "{} vs {nis}", t.nis());
            let mut k = [[0.0f32; 2]; 6];
            for i in 0..6 {
                if !frozen[i] {
                    for c in 0..2 {
                        k[i][c] = (0..2).map(|m| p0.m[i][m] * s_inv[m][c]).sum();
                    }
                }
            }
            let dx_joseph: [f32; 6] = core::array::from_fn(|i| k[i][0] * z[0] + k[i][1] * z[1]);
            for i in 0..6 {
                assert!((dx[i] - dx_joseph[i]).abs() < 1e-5 * dx_joseph[i].abs() + 1e-9, "dx {i}");
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
