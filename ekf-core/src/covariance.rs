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

/// The two rows of the tilt measurement's `H`: `H_k = w·e_k + (0, 0, 0, j[k])` for `k` = 0, 1
/// (`δθ_x`, `δθ_y`). A low-passed measurement sees the attitude error only in the share `w` of
/// its weight that real samples carry, and the bias error through the attitude error it built
/// up over the low-pass's delay (`tilt_lowpass`); `w = 1`, `j = 0` is a plain tilt
/// measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltRows {
    /// Weight of the current attitude error, 0–1.
    pub w: f32,
    /// Sensitivity of each component to the bias error, rad per rad/s (s).
    pub j: [[f32; 3]; 2],
    /// A unit body axis along which the update does not correct the bias (the one the
    /// accelerometer cannot see: NED's vertical, for yaw-split), or zero for none.
    pub vertical: [f32; 3],
    /// The rows are exactly `[I₂, 0, 0]` (`w` = 1, `J` = 0: a raw sample, no low-pass), and the
    /// default configuration's update skips the multiplications by 1 and 0 (issue #36).
    pub raw: bool,
}

impl TiltRows {
    /// `H_k` as a full row.
    fn row(&self, k: usize) -> [f32; N] {
        let mut h = [0.0; N];
        h[k.min(1)] = self.w;
        h[3..].copy_from_slice(&self.j[k.min(1)]);
        h
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

    /// Kalman update with the tilt measurement `z` (rad) of rows `h`, measurement variance `r`
    /// (rad²) per component: two sequential scalar updates (`δθ_x`, then `δθ_y`), exactly the
    /// joint update since the two components' noises are independent. With [`YawRow::Frozen`]
    /// the yaw row gets zero gain (yaw does not move and, Joseph-consistently, its variance is
    /// unchanged); with [`YawRow::Untracked`] row and column 2 are not touched at all (`H` has
    /// no yaw column). Returns the state correction δx, or `None`, and the covariance
    /// unchanged, when an innovation variance is not positive and finite.
    pub fn update_tilt(
        &mut self,
        z: [f32; 2],
        r: [f32; 2],
        h: &TiltRows,
        yaw: YawRow,
    ) -> Option<[f32; N]> {
        let saved = *self;
        let dx = match yaw {
            YawRow::Free => self.update_tracked(z, r, h, true),
            YawRow::Frozen => self.update_tracked(z, r, h, false),
            YawRow::Untracked => self.update_untracked(z, r, h),
        };
        if dx.is_none() {
            *self = saved;
        }
        dx
    }

    /// The tilt update with the yaw row tracked (magnetometer on or yaw-split off), its gain
    /// `yaw_gain` or zero: one out-of-line, rolled copy, to keep the firmware's flash down;
    /// the default configuration's update is the inlined `Untracked` one.
    #[inline(never)]
    fn update_tracked(
        &mut self,
        z: [f32; 2],
        r: [f32; 2],
        h: &TiltRows,
        yaw_gain: bool,
    ) -> Option<[f32; N]> {
        let mut dx = [0.0f32; N];
        let n = rolled();
        let free: [bool; N] = core::array::from_fn(|i| i != 2 || yaw_gain);
        for k in 0..2 {
            let hk = h.row(k);
            let p = &mut self.m;
            // c = P hᵀ, s = h c + r, innovation after the corrections so far.
            let mut c = [0.0f32; N];
            let (mut s, mut e) = (r[k], z[k]);
            for i in 0..n {
                for l in 0..n {
                    c[i] += p[i][l] * hk[l];
                }
                s += hk[i] * c[i];
                e -= hk[i] * dx[i];
            }
            if !crate::fcmp::in_pos_range(s, f32::MAX) {
                return None;
            }
            let inv = 1.0 / s;
            // The gain restricted, K' = M·K: zero on a frozen row, and without its bias part's
            // component along `vertical` (`u`). M is a symmetric projection, so the Joseph form
            // with K' is P' = P − (c cᵀ − e eᵀ)/s with e = (I − M)·c, the part left out.
            let u = h.vertical;
            let cu = c[3] * u[0] + c[4] * u[1] + c[5] * u[2];
            let kept: [f32; N] = core::array::from_fn(|i| match (free[i], i >= 3) {
                (false, _) => 0.0,
                (true, false) => c[i],
                (true, true) => c[i] - cu * u[i - 3],
            });
            for i in 0..n {
                dx[i] += kept[i] * inv * e;
                let ei = c[i] - kept[i];
                for l in i..n {
                    let v = p[i][l] - (c[i] * c[l] - ei * (c[l] - kept[l])) * inv;
                    p[i][l] = v;
                    p[l][i] = v;
                }
            }
        }
        Some(dx)
    }

    /// [`Cov6::update_tilt`] with the yaw row untracked (the default configuration's hot path),
    /// unrolled over the tilt and bias rows: for each component `k`, `c = P hₖᵀ`,
    /// `s = hₖ c + r`, `δx += c·(zₖ − hₖ δx)/s`, `P ← P − c cᵀ/s`.
    #[inline(always)]
    fn update_untracked(&mut self, z: [f32; 2], r: [f32; 2], h: &TiltRows) -> Option<[f32; N]> {
        let mut dx = [0.0f32; N];
        unroll!(k in [0, 1] {
            let j = &h.j[k];
            let p = &mut self.m;
            let mut c = [0.0f32; N];
            // A raw sample's row is a unit vector: `c` is P's column, `s` and `e` need no
            // products (the same values: x·1 = x, x + y·0 = x but for the sign of a zero).
            unroll!(i in [0, 1, 3, 4, 5] {
                c[i] = if h.raw {
                    p[i][k]
                } else {
                    h.w * p[i][k] + p[i][3] * j[0] + p[i][4] * j[1] + p[i][5] * j[2]
                };
            });
            let s = if h.raw {
                r[k] + c[k]
            } else {
                r[k] + h.w * c[k] + j[0] * c[3] + j[1] * c[4] + j[2] * c[5]
            };
            if !crate::fcmp::in_pos_range(s, f32::MAX) {
                return None;
            }
            let inv = 1.0 / s;
            let e = if h.raw {
                z[k] - dx[k]
            } else {
                z[k] - h.w * dx[k] - j[0] * dx[3] - j[1] * dx[4] - j[2] * dx[5]
            };
            let ei = e * inv;
            // The bias gain without its component along `vertical` (see `update_tracked`).
            let u = &h.vertical;
            let cu = c[3] * u[0] + c[4] * u[1] + c[5] * u[2];
            let cui = cu * cu * inv;
            unroll!(i in [0, 1, 3, 4, 5] {
                dx[i] += if i < 3 { c[i] } else { c[i] - cu * u[i - 3] } * ei;
            });
            unroll!(i in [0, 1, 3, 4, 5] {
                let g = c[i] * inv;
                unroll!(l in [0, 1, 3, 4, 5] {
                    if l >= i {
                        let mut v = p[i][l] - g * c[l];
                        if i >= 3 {
                            v += cui * u[i - 3] * u[l - 3];
                        }
                        p[i][l] = v;
                        p[l][i] = v;
                    }
                });
            });
        });
        Some(dx)
    }

    /// The NED frame turned about its z axis by the angle whose cosine and sine are `c`, `s`
    /// (a heading change of the estimate: yaw hold, magnetometer, `set_yaw`): the attitude
    /// error's x and y components turn with it, `P ← T P Tᵀ` with `T` that rotation on rows and
    /// columns 0–1 (the bias, in body axes, does not turn).
    #[cold]
    pub fn turn_z(&mut self, c: f32, s: f32) {
        for l in 0..N {
            let (a, b) = (self.m[0][l], self.m[1][l]);
            self.m[0][l] = c * a - s * b;
            self.m[1][l] = s * a + c * b;
        }
        for i in 0..N {
            let (a, b) = (self.m[i][0], self.m[i][1]);
            self.m[i][0] = c * a - s * b;
            self.m[i][1] = s * a + c * b;
        }
        // Exactly symmetric (the two passes round the 2×2 block's corners differently).
        self.m[1][0] = self.m[0][1];
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

    /// A raw sample's rows (`w` = 1, `J` = 0) through the shortcut that skips the products by
    /// 1 and 0 (issue #36) give the general form's correction and covariance: the same values
    /// (equal as numbers: only a zero's sign may differ), with and without the vertical.
    #[test]
    fn the_raw_rows_shortcut_equals_the_general_update() {
        let p0 = sample_p();
        for u in [[0.0; 3], [0.6, 0.0, 0.8]] {
            let rows = |raw| TiltRows { w: 1.0, j: [[0.0; 3]; 2], vertical: u, raw };
            let (mut general, mut short) = (p0, p0);
            let z = [0.013, -0.021];
            let r = [1.3e-4, 0.9e-4];
            let want = general.update_tilt(z, r, &rows(false), YawRow::Untracked).unwrap();
            let got = short.update_tilt(z, r, &rows(true), YawRow::Untracked).unwrap();
            assert!(want.iter().any(|v| *v != 0.0));
            for i in 0..6 {
                assert_eq!(got[i], want[i], "dx {i}");
                for j in 0..6 {
                    assert_eq!(short.m[i][j], general.m[i][j], "{i},{j}");
                }
            }
        }
    }

    #[test]
    fn tilt_update_matches_joseph_form_and_freezes_yaw() {
        let p0 = sample_p();
        let r = 1e-4;
        let z = [0.01, -0.02];
        let vert = [0.6, 0.0, 0.8];
        // A low-passed measurement: part weight on the attitude error, and bias columns.
        let rows = |vertical| TiltRows {
            w: 0.7,
            j: [[-0.8, 0.3, 0.1], [0.2, -0.9, 0.4]],
            vertical,
            raw: false,
        };
        let hm = [rows(vert).row(0), rows(vert).row(1)];
        assert_eq!(hm[0], [0.7, 0.0, 0.0, -0.8, 0.3, 0.1]);
        assert_eq!(hm[1], [0.0, 0.7, 0.0, 0.2, -0.9, 0.4]);
        // The reference: two scalar updates in dense Joseph form, f64, with the gain's yaw row
        // zeroed when frozen and its bias part projected off `vertical` (zero: unrestricted).
        let dense = |frozen: bool, u: [f32; 3]| {
            let mut pm: [[f64; 6]; 6] = core::array::from_fn(|i| p0.m[i].map(f64::from));
            let mut dx = [0.0f64; 6];
            let u = u.map(f64::from);
            for k in 0..2 {
                let h = hm[k].map(f64::from);
                let c: [f64; 6] = core::array::from_fn(|i| (0..6).map(|l| pm[i][l] * h[l]).sum());
                let s: f64 = (0..6).map(|i| h[i] * c[i]).sum::<f64>() + f64::from(r);
                let mut g = c.map(|v| v / s);
                if frozen {
                    g[2] = 0.0;
                }
                let gu = g[3] * u[0] + g[4] * u[1] + g[5] * u[2];
                for i in 0..3 {
                    g[3 + i] -= gu * u[i];
                }
                let e = f64::from(z[k]) - (0..6).map(|i| h[i] * dx[i]).sum::<f64>();
                for i in 0..6 {
                    dx[i] += g[i] * e;
                }
                let ikh: [[f64; 6]; 6] = core::array::from_fn(|i| {
                    core::array::from_fn(|l| f64::from(u8::from(i == l)) - g[i] * h[l])
                });
                let mut out = [[0.0f64; 6]; 6];
                for i in 0..6 {
                    for l in 0..6 {
                        let mut v = 0.0;
                        for a in 0..6 {
                            for b in 0..6 {
                                v += ikh[i][a] * pm[a][b] * ikh[l][b];
                            }
                        }
                        out[i][l] = v + f64::from(r) * g[i] * g[l];
                    }
                }
                pm = out;
            }
            (dx, pm)
        };
        for (frozen_yaw, u) in [(false, [0.0; 3]), (true, [0.0; 3]), (true, vert)] {
            let mut p = p0;
            let yaw = if frozen_yaw { YawRow::Frozen } else { YawRow::Free };
            let dx = p.update_tilt(z, [r, r], &rows(u), yaw).unwrap();
            if frozen_yaw {
                // Untracked: the same tilt and bias elements and correction (to rounding: a
                // different order of sums); row/column 2 untouched, bit for bit.
                let mut p2 = p0;
                let dx2 = p2.update_tilt(z, [r, r], &rows(u), YawRow::Untracked).unwrap();
                for i in 0..6 {
                    assert!((dx[i] - dx2[i]).abs() <= 1e-6 * dx[i].abs() + 1e-12, "dx {i}");
                    for j in 0..6 {
                        if i == 2 || j == 2 {
                            assert_eq!(p2.m[i][j].to_bits(), p0.m[i][j].to_bits(), "{i},{j}");
                        } else {
                            let d = (p2.m[i][j] - p.m[i][j]).abs();
                            assert!(d <= 1e-6 * p.m[i][j].abs() + 1e-12, "{i},{j}");
                        }
                    }
                }
            }
            let (want_dx, want_p) = dense(frozen_yaw, u);
            for i in 0..6 {
                let got = f64::from(dx[i]);
                let want = want_dx[i];
                assert!((got - want).abs() < 1e-5 * want.abs() + 1e-9, "dx {i}: {got} vs {want}");
                for j in 0..6 {
                    let got = f64::from(p.m[i][j]);
                    assert!(
                        (got - want_p[i][j]).abs() < 1e-8,
                        "{frozen_yaw} {u:?} {i},{j}: {got} vs {}",
                        want_p[i][j]
                    );
                }
            }
            if frozen_yaw {
                assert_eq!(dx[2], 0.0);
                assert_eq!(p.m[2][2], p0.m[2][2]);
            } else {
                assert!(dx[2] != 0.0);
            }
            // No bias correction along the vertical; some without the restriction.
            let along = dx[3] * vert[0] + dx[4] * vert[1] + dx[5] * vert[2];
            if u == vert {
                assert!(along.abs() < 1e-9, "{along}");
            } else {
                assert!(along.abs() > 1e-6, "{along}");
            }
            assert!(p.is_healthy(&[1.0; 6]));
        }
        // Unrestricted, the two scalar updates are the joint update: K = P Hᵀ (H P Hᵀ + rI)⁻¹.
        let (dx_seq, _) = dense(false, [0.0; 3]);
        let pm = |i: usize, j: usize| f64::from(p0.m[i][j]);
        let hv = |k: usize, i: usize| f64::from(hm[k][i]);
        let pht: [[f64; 2]; 6] =
            core::array::from_fn(|i| [0, 1].map(|k| (0..6).map(|l| pm(i, l) * hv(k, l)).sum()));
        let sm: [[f64; 2]; 2] = [0, 1].map(|a| {
            [0, 1].map(|b| {
                (0..6).map(|i| hv(a, i) * pht[i][b]).sum::<f64>()
                    + if a == b { f64::from(r) } else { 0.0 }
            })
        });
        let det = sm[0][0] * sm[1][1] - sm[0][1] * sm[1][0];
        let s_inv = [[sm[1][1] / det, -sm[0][1] / det], [-sm[1][0] / det, sm[0][0] / det]];
        for i in 0..6 {
            let k: [f64; 2] = [0, 1].map(|c| (0..2).map(|m| pht[i][m] * s_inv[m][c]).sum());
            let want = k[0] * f64::from(z[0]) + k[1] * f64::from(z[1]);
            assert!((dx_seq[i] - want).abs() < 1e-9 * (1.0 + want.abs()), "joint dx {i}");
        }
        // A measurement whose innovation variance is not positive leaves P alone.
        let mut p = p0;
        assert_eq!(p.update_tilt(z, [-1.0, -1.0], &rows(vert), YawRow::Untracked), None);
        assert_eq!(p, p0);
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
