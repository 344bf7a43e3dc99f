//! Sigma-point machinery shared by the two unscented comparison filters, [`crate::Ukf`] and
//! [`crate::SsUkf`]: the digest's seven-state additive model, the unscented transform in
//! deviation form, the measurement update, covariance repair, and the filter loop (validation,
//! initialisation window, accelerometer gate, health checks) mirroring [`crate::Ekf`]. The two
//! filters differ only in their sigma-point set ([`SigmaSet`]) and scalar type.
//!
//! # Model
//! State `x = [q0 q1 q2 q3, bx by bz]`: the attitude quaternion (scalar first, body FRD → NED)
//! as four *additive* components, and the gyro bias (rad/s, body FRD). Covariance `P` is 7×7
//! over the same components (quaternion rows dimensionless², bias rows (rad/s)²).
//!
//! - Process (digest): `ω = gyro − b`, `q ← (I + ½ Ω(ω) dt) q`, `b ← b`, applied to every
//!   sigma point; the quaternion part of the propagated mean is then normalised (by its norm
//!   only, never sign-flipped, so that `P`'s cross terms keep their meaning). With an invalid
//!   gyro sample the state is held and only `Q` is added.
//! - Process noise `Q = blockdiag(Q_q, Q_b)`, diagonal: `Q_q = (dt²/4)·σ²_g·I₄` with
//!   `σ²_g = ψ̄/dt` the per-sample gyro variance at the actual rate (`ψ̄` the mean over the three
//!   axes of [`crate::settings::NoiseSettings::gyro_psd`], rad²/s), i.e. `Q_q = ψ̄·dt/4·I₄`
//!   (the per-step angle variance `ψ̄·dt` mapped to quaternion components by `½Ξ(q)`, with
//!   `Ξ Ξᵀ ≈ I₄`); `Q_b = bias_random_walk·dt·I₃`. `dt` here is the whole sample interval
//!   (`Checked::dt_cov`); the state moves over `Checked::dt_rate`.
//! - Measurement: the unit "down" vector in the body frame, `y = down_in_body(q)` evaluated on
//!   every (not normalised) sigma point; measured `−a/|a|` (accelerometer in g). `R = σ²_a ·
//!   accel_var_scale · I₃` with `σ²_a` = [`crate::settings::NoiseSettings::accel_var`] (g², and
//!   the unit vector is in g units).
//! - Sigma points are redrawn from `(x̄, P̄)` for the measurement update (so that `Q` is seen
//!   by the cross-covariance). `K = P_xy S⁻¹`, `x ← x̄ + K ν`, `P ← P̄ − K S Kᵀ`, then
//!   symmetrised, the quaternion part of `x` normalised, and `P` carried to the new mean
//!   (below).
//!
//! # Covariance transport
//! The quaternion block of `P` describes the uncertainty in the tangent directions of the mean
//! it was computed at: about NED x, y, z, `Γ(q̄)` (below), plus the radial direction `q̄`. The
//! time update keeps it there by itself (the process is linear in `q`: `F = I + ½Ω dt` is
//! right multiplication by `(1, ω dt/2)`, which maps `Γ(q)` to `Γ(F q)`), but the measurement
//! update moves the mean and leaves `P` behind. Yaw is unobservable, so its variance stays
//! large (5° at start) while tilt's is 0.05°: after a correction by `δ` rad the old yaw axis
//! `Γ_z(q̄_old)` lies `δ/2` off the new one, toward a tilt direction, and `P` then claims a
//! yaw–tilt correlation of about `σ_ψ² δ/2` — which the next accelerometer updates act on,
//! moving yaw by up to `(σ_ψ/σ_θ)²` times that. (Measured on the simulator: yaw RMSE 0.4–2.2°
//! from this alone, against 0.1–0.8° carried.) So after every update `P` is carried with the
//! mean: `P ← T P Tᵀ`, `T = blockdiag(M, I₃)`, `M` the right multiplication by
//! `Δ = q̄_prior* ⊗ q̄_new` (orthogonal), which maps `Γ(q̄_prior)` onto `Γ(q̄_new)` and
//! `q̄_prior` onto `q̄_new` — the same operation the time update applies. The digest does not
//! mention it; it changes nothing in the sigma-point algorithm itself, and without it the
//! additive model's covariance contradicts its own mean.
//!
//! # Deviation form
//! The central weights are large and negative (UKF −69, SS-UKF ≈ −9·10⁷), so means and
//! covariances are computed from the deviations `D_i = Y_i − Y_0` of the transformed points
//! from the transformed central point: `ȳ = Y_0 + d̄` with `d̄ = Σ Wm_i D_i`, and
//! `P_yy = Σ Wc_i (D_i − d̄)(D_i − d̄)ᵀ` (the central term is `Wc_0 d̄ d̄ᵀ`). The state-side
//! deviations of the drawn points are `√P·Z_i` exactly.
//!
//! # Repair
//! `P` is symmetrised after every step. When its Cholesky factorisation fails (non-finite, or
//! not positive definite — the second source's UKF failure), each diagonal entry `P_ii` gets
//! `10⁻⁴·|P_ii| + 10⁻⁹·max_j |P_jj|` added and the factorisation is retried once; if that still
//! fails `P` is reset to the initial covariance at the current attitude. Either way the update
//! reports [`Flags::HEALTH_RESET`]. The same happens when the innovation covariance `S` cannot
//! be factorised (then the update is skipped).
//!
//! # Gate
//! The [`AccelGate`] is used as in the EKF. The normalised innovation squared is
//! `nis = νᵀ S⁻¹ ν` of the full 3-vector innovation, compared as is with the 2-degree-of-freedom
//! threshold: the component of `ν` along "down" is second order (both vectors are unit), so the
//! statistic has effectively two degrees of freedom. On `REACQUIRE` the tilt uncertainty is
//! widened to the innovation's size (as the EKF does): `P_qq += (|ν|²/4)·(Γ_x Γ_xᵀ + Γ_y Γ_yᵀ)`
//! with `Γ` below, and the update recomputed.
//!
//! # Initial covariance
//! The attitude sigmas are angles about NED axes. With `q_true = (1, δθ/2) ⊗ q`,
//! `δq = ½ Γ(q) δθ`, `Γ(q) = [−uᵀ; w I − [u×]]` (4×3, `q = (w, u)`), so
//! `P_qq = ¼ Γ diag(σ_t², σ_t², σ_ψ²) Γᵀ + ¼ σ_t² q qᵀ` — the last term gives the (otherwise
//! singular) radial direction the tilt's variance so that `P` is positive definite.
//! `P_bb = σ_b² I₃`, no cross terms. When the initialisation window measured the bias, `P_bb`
//! starts instead at the window's standard error plus `(0.002 °/s)²` per axis
//! ([`crate::init::Initializer::bias_variance`]), exactly as the EKF: with `σ_b` = 0.2 °/s
//! the bias states take up tilt innovations and integrate them into yaw (the z bias wandered
//! to 0.3 °/s and yaw by 40° on the `coupled` scenario). `set_attitude` and covariance resets
//! use `σ_b`.

use nalgebra::{Cholesky, Const, RealField, SMatrix, SVector};

use crate::{
    gate::{AccelGate, PreCheck},
    init::{self, InitStep, Initializer},
    mathf,
    settings::Settings,
    validate::{self, Checked},
    Euler, Flags, ImuSample, Quaternion, Vec3,
};

/// State dimension.
pub(crate) const N: usize = 7;
/// State vector `[q0 q1 q2 q3 bx by bz]`.
pub(crate) type Vector<T> = SVector<T, N>;
/// 7×7 matrix over the state.
pub(crate) type Matrix<T> = SMatrix<T, N, N>;

/// Largest variance of a quaternion component before the health check resets `P`.
const MAX_Q_VAR: f32 = 1.0;
/// Largest gyro-bias variance before the health check resets `P`, (rad/s)².
const MAX_BIAS_VAR: f32 = 1.0;

/// The scalar the sigma-point arithmetic runs in (`f32` or `f64`).
pub(crate) trait Real: RealField + Copy {
    /// From `f32`.
    fn of(x: f32) -> Self;
    /// To `f32` (rounded; saturates to ±inf).
    fn to_f32(self) -> f32;
    /// To `f64` (exact).
    #[cfg(test)]
    fn to_f64(self) -> f64;
}

impl Real for f32 {
    #[inline]
    fn of(x: f32) -> Self {
        x
    }
    #[inline]
    fn to_f32(self) -> f32 {
        self
    }
    #[cfg(test)]
    fn to_f64(self) -> f64 {
        self as f64
    }
}

impl Real for f64 {
    #[inline]
    fn of(x: f32) -> Self {
        x as f64
    }
    #[inline]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[cfg(test)]
    fn to_f64(self) -> f64 {
        self
    }
}

/// Tuning shared by both unscented filters (see their parameter structs for the meaning).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Tuning {
    pub accel_var_scale: f32,
    pub bias_random_walk: f32,
    pub initial_tilt_sigma: f32,
    pub initial_yaw_sigma: f32,
    pub initial_bias_sigma: f32,
}

impl Tuning {
    /// Replace unusable values (non-finite, non-positive; negative for the random walk) by the
    /// corresponding value of `d`.
    pub fn sanitised(self, d: Tuning) -> Tuning {
        let pos = |v: f32, d: f32| if v.is_finite() && v > 0.0 { v } else { d };
        Tuning {
            accel_var_scale: pos(self.accel_var_scale, d.accel_var_scale),
            bias_random_walk: if self.bias_random_walk.is_finite() && self.bias_random_walk >= 0.0 {
                self.bias_random_walk
            } else {
                d.bias_random_walk
            },
            initial_tilt_sigma: pos(self.initial_tilt_sigma, d.initial_tilt_sigma),
            initial_yaw_sigma: pos(self.initial_yaw_sigma, d.initial_yaw_sigma),
            initial_bias_sigma: pos(self.initial_bias_sigma, d.initial_bias_sigma),
        }
    }
}

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

/// The digest's process model: `ω = gyro − b`, `q ← (I + ½ Ω(ω) dt) q`, bias constant.
pub(crate) fn process<T: Real>(x: &Vector<T>, gyro: &[T; 3], dt: T) -> Vector<T> {
    let h = dt * T::of(0.5);
    let w = x[0];
    let u = [x[1], x[2], x[3]];
    let o = [gyro[0] - x[4], gyro[1] - x[5], gyro[2] - x[6]];
    // Ω(ω) q = (−ω·u, w ω − ω × u).
    let dot = o[0] * u[0] + o[1] * u[1] + o[2] * u[2];
    let cr = [o[1] * u[2] - o[2] * u[1], o[2] * u[0] - o[0] * u[2], o[0] * u[1] - o[1] * u[0]];
    let mut y = *x;
    y[0] = w - h * dot;
    for k in 0..3 {
        y[1 + k] = u[k] + h * (w * o[k] - cr[k]);
    }
    y
}

/// Measurement model: the NED "down" axis in the body frame, `down_in_body(q)`, evaluated on
/// the (possibly not unit) quaternion part of `x`.
pub(crate) fn down<T: Real>(x: &Vector<T>) -> SVector<T, 3> {
    let (w, a, b, c) = (x[0], x[1], x[2], x[3]);
    let two = T::of(2.0);
    SVector::<T, 3>::new(
        two * (a * c - w * b),
        two * (b * c + w * a),
        T::one() - two * (a * a + b * b),
    )
}

/// `Γ(q)` (4×3): `δq = ½ Γ(q) δθ` for a small rotation `δθ` about NED axes applied on the left.
fn gamma<T: Real>(x: &Vector<T>) -> SMatrix<T, 4, 3> {
    let (w, a, b, c) = (x[0], x[1], x[2], x[3]);
    SMatrix::<T, 4, 3>::new(-a, -b, -c, w, c, -b, -c, w, a, b, -a, w)
}

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

/// Normalise the quaternion part of `x` by its norm (no sign change). Leaves `x` alone when
/// the norm is zero or not finite (the health check handles that).
fn normalise_quaternion<T: Real>(x: &mut Vector<T>) {
    let n2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3];
    let n = n2.sqrt();
    if n.is_finite() && n > T::of(1e-15) {
        for k in 0..4 {
            x[k] /= n;
        }
    }
}

fn all_finite<T: Real, const R: usize, const C: usize>(m: &SMatrix<T, R, C>) -> bool {
    m.iter().all(|v| v.is_finite())
}

/// The innovation of one accelerometer update.
struct Innovation<T: Real> {
    nu: SVector<T, 3>,
    pxy: SMatrix<T, N, 3>,
    s: SMatrix<T, 3, 3>,
    chol: Cholesky<T, Const<3>>,
    nis: T,
}

/// One unscented filter on the digest's seven-state model with sigma-point set `set`, in
/// scalar type `T`: everything but the point set is shared by [`crate::Ukf`] and
/// [`crate::SsUkf`].
#[derive(Clone, Debug)]
pub(crate) struct Core<T: Real, const M: usize> {
    settings: Settings,
    tuning: Tuning,
    set: SigmaSet<T, M>,
    x: Vector<T>,
    p: Matrix<T>,
    init: Option<Initializer>,
    gate: AccelGate,
    last_flags: Flags,
}

impl<T: Real, const M: usize> Core<T, M> {
    /// A new filter, starting its initialisation window.
    pub fn new(settings: Settings, tuning: Tuning, set: SigmaSet<T, M>) -> Self {
        let mut c = Core {
            settings,
            tuning,
            set,
            x: Vector::<T>::zeros(),
            p: Matrix::<T>::identity(),
            init: Some(Initializer::new(&settings)),
            gate: AccelGate::new(settings.gate),
            last_flags: Flags::INITIALISING,
        };
        c.set_state(Quaternion::from_yaw(settings.init.initial_yaw), settings.init.gyro_bias);
        c.p = c.initial_cov();
        c
    }

    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    pub fn last_flags(&self) -> Flags {
        self.last_flags
    }

    /// The covariance rounded to `f32`.
    pub fn covariance(&self) -> SMatrix<f32, N, N> {
        self.p.map(|v| v.to_f32())
    }

    #[cfg(test)]
    pub fn sigma_set(&self) -> &SigmaSet<T, M> {
        &self.set
    }

    #[cfg(test)]
    pub fn covariance_mut(&mut self) -> &mut Matrix<T> {
        &mut self.p
    }

    pub fn attitude(&self) -> Quaternion {
        Quaternion::new(
            self.x[0].to_f32(),
            self.x[1].to_f32(),
            self.x[2].to_f32(),
            self.x[3].to_f32(),
        )
        .normalized()
    }

    pub fn gyro_bias(&self) -> Vec3 {
        Vec3::new(self.x[4].to_f32(), self.x[5].to_f32(), self.x[6].to_f32())
    }

    pub fn is_initialised(&self) -> bool {
        self.init.is_none()
    }

    fn set_state(&mut self, q: Quaternion, b: Vec3) {
        let v = [q.w, q.x, q.y, q.z, b.x, b.y, b.z];
        self.x = Vector::<T>::from_fn(|i, _| T::of(v[i]));
    }

    /// Initial covariance at the current attitude (see the module documentation).
    fn initial_cov(&self) -> Matrix<T> {
        let t = T::of(self.tuning.initial_tilt_sigma * self.tuning.initial_tilt_sigma);
        let y = T::of(self.tuning.initial_yaw_sigma * self.tuning.initial_yaw_sigma);
        let b = T::of(self.tuning.initial_bias_sigma * self.tuning.initial_bias_sigma);
        let q = self.x.fixed_rows::<4>(0).into_owned();
        let g = gamma(&self.x);
        let d = SMatrix::<T, 3, 3>::from_diagonal(&SVector::<T, 3>::new(t, t, y));
        let quarter = T::of(0.25);
        let pq = (g * d * g.transpose() + q * q.transpose() * t) * quarter;
        let mut p = Matrix::<T>::zeros();
        p.fixed_view_mut::<4, 4>(0, 0).copy_from(&pq);
        for k in 4..N {
            p[(k, k)] = b;
        }
        symmetrise(&mut p);
        p
    }

    /// Start from attitude `q` and bias `bias` with the initial covariance.
    pub fn start(&mut self, q: Quaternion, bias: Vec3) {
        let bias = if bias.is_finite() { bias } else { self.settings.init.gyro_bias };
        self.set_state(q.normalized(), bias);
        self.p = self.initial_cov();
        self.init = None;
        self.gate.reset();
    }

    /// Lower Cholesky factor of `P`, repairing `P` when it fails (module documentation).
    fn factor(&mut self) -> (Option<Matrix<T>>, Flags) {
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

    fn add_process_noise(&mut self, dt: f32) {
        let psd = self.settings.noise.gyro_psd();
        let psd_mean = (psd.x + psd.y + psd.z) * (1.0 / 3.0);
        let qq = T::of(psd_mean * dt * 0.25);
        let qb = T::of(self.tuning.bias_random_walk * dt);
        for k in 0..4 {
            self.p[(k, k)] += qq;
        }
        for k in 4..N {
            self.p[(k, k)] += qb;
        }
    }

    /// Time update: unscented transform through the process model (valid gyro only), then `Q`.
    fn predict(&mut self, c: &Checked) -> Flags {
        let mut flags = Flags::NONE;
        if let Some(g) = c.gyro {
            let (l, f) = self.factor();
            flags |= f;
            if let Some(l) = l {
                let pts = self.set.points(&self.x, &l);
                let gyro = [T::of(g.x), T::of(g.y), T::of(g.z)];
                let dt = T::of(c.dt_rate);
                let y0 = process(&pts.column(0).into_owned(), &gyro, dt);
                let mut dev = SMatrix::<T, N, M>::zeros();
                for i in 1..M {
                    let yi = process(&pts.column(i).into_owned(), &gyro, dt);
                    dev.set_column(i, &(yi - y0));
                }
                let (dbar, cov) = self.set.moments(&dev);
                self.x = y0 + dbar;
                self.p = cov;
                normalise_quaternion(&mut self.x);
            }
        }
        self.add_process_noise(c.dt_cov);
        symmetrise(&mut self.p);
        flags
    }

    /// Unscented prediction of the measurement from `(x, P)` and the innovation of `meas`.
    fn innovation(&mut self, meas: &SVector<T, 3>, r: T) -> (Option<Innovation<T>>, Flags) {
        let (l, mut flags) = self.factor();
        let Some(mut l) = l else { return (None, flags) };
        for attempt in 0..2 {
            let pts = self.set.points(&self.x, &l);
            let dx = l * self.set.z;
            let y0 = down(&pts.column(0).into_owned());
            let mut dy = SMatrix::<T, 3, M>::zeros();
            for i in 1..M {
                dy.set_column(i, &(down(&pts.column(i).into_owned()) - y0));
            }
            let (ybar, pyy) = self.set.moments(&dy);
            let (xbar, _) = self.set.moments(&dx);
            let pxy = self.set.cross(&dx, &xbar, &dy, &ybar);
            let s = pyy + SMatrix::<T, 3, 3>::identity() * r;
            let nu = meas - (y0 + ybar);
            if all_finite(&s) && all_finite(&pxy) && all_finite(&nu) {
                if let Some(chol) = s.cholesky() {
                    let nis = nu.dot(&chol.solve(&nu));
                    return (Some(Innovation { nu, pxy, s, chol, nis }), flags);
                }
            }
            // S not positive definite: the covariance is unusable for this measurement.
            flags |= Flags::HEALTH_RESET;
            if attempt == 0 {
                self.p = self.initial_cov();
                match self.p.cholesky() {
                    Some(c) => l = c.l(),
                    None => break,
                }
            }
        }
        (None, flags)
    }

    /// Accelerometer update with the gate.
    fn accel_update(&mut self, dt: f32, a_g: Vec3, norm_g: f32) -> Flags {
        let bypass = match self.gate.pre_check(dt, a_g, norm_g, 0.0) {
            PreCheck::Reject(f) => return f,
            PreCheck::Pass { bypass_innovation } => bypass_innovation,
        };
        let d = a_g * (-1.0 / norm_g);
        let meas = SVector::<T, 3>::new(T::of(d.x), T::of(d.y), T::of(d.z));
        // Floored (also against NaN) so that S stays invertible with a zero noise setting.
        let r = T::of((self.settings.noise.accel_var * self.tuning.accel_var_scale).max(1e-12));
        let (inn, mut flags) = self.innovation(&meas, r);
        let Some(mut inn) = inn else { return flags };
        match self.gate.innovation(dt, inn.nis.to_f32(), bypass) {
            Ok(f) => flags |= f,
            Err(f) => return flags | f,
        }
        if flags.contains(Flags::REACQUIRE) {
            // Trust the accelerometer again: widen the tilt uncertainty to the innovation's size.
            let e = inn.nu.norm_squared() * T::of(0.25);
            let g = gamma(&self.x);
            let gx = g.column(0).into_owned();
            let gy = g.column(1).into_owned();
            let add = (gx * gx.transpose() + gy * gy.transpose()) * e;
            let mut pq = self.p.fixed_view_mut::<4, 4>(0, 0);
            pq += add;
            let (i2, f2) = self.innovation(&meas, r);
            flags |= f2;
            match i2 {
                Some(i2) => inn = i2,
                None => return flags,
            }
        }
        let k = inn.chol.solve(&inn.pxy.transpose()).transpose();
        let q_prior = self.x.fixed_rows::<4>(0).into_owned();
        self.x += k * inn.nu;
        self.p -= k * inn.s * k.transpose();
        symmetrise(&mut self.p);
        normalise_quaternion(&mut self.x);
        self.transport(&q_prior);
        flags | Flags::ACCEL_USED
    }

    /// Carry `P` from the prior mean quaternion `q_prior` to the current one `q`:
    /// `P ← T P Tᵀ`, `T = blockdiag(M, I₃)` with `M` the right multiplication by
    /// `Δ = q_prior* ⊗ q`, which maps `Γ(q_prior)` onto `Γ(q)` and `q_prior` onto `q`.
    fn transport(&mut self, q_prior: &SVector<T, 4>) {
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
    fn health(&mut self, before: &Vector<T>) -> Flags {
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

    /// One sample (see [`crate::AttitudeFilter::update`]).
    pub fn update(&mut self, sample: &ImuSample) -> Flags {
        let Some(c) = validate::check(sample, &self.settings.limits) else {
            self.last_flags = Flags::TIME_GAP;
            return self.last_flags;
        };
        let mut flags = c.flags;
        let accel = c.accel_g;

        if let Some(init) = self.init.as_mut() {
            // Only samples that pass the magnitude and jump checks enter the tilt average.
            match init::feed(init, &mut self.gate, &c) {
                InitStep::Pending(q) => {
                    let b = self.gyro_bias();
                    self.set_state(q, b);
                    self.last_flags = flags | Flags::INITIALISING;
                    return self.last_flags;
                }
                InitStep::Done(q, b) => {
                    let var = init.bias_variance(&self.settings.noise);
                    self.start(q, b);
                    if let Some(v) = var {
                        // The window measured the bias: start with its actual uncertainty,
                        // as the EKF does.
                        for i in 0..3 {
                            self.p[(4 + i, 4 + i)] = T::of(v[i]);
                        }
                    }
                    // The window's last sample still moves the state (below), as in the EKF.
                }
            }
        }

        let before = self.x;
        flags |= self.predict(&c);
        if let Some((a, n)) = accel {
            flags |= self.accel_update(c.dt_rate, a, n);
        }
        flags |= self.health(&before);
        self.last_flags = flags;
        flags
    }

    /// Set yaw (rad) keeping roll and pitch; rotates `P` with the state.
    pub fn set_yaw(&mut self, yaw: f32) {
        if !yaw.is_finite() {
            return;
        }
        if let Some(init) = self.init.as_mut() {
            init.set_yaw(yaw);
            return;
        }
        let delta = mathf::wrap_pi(yaw - Euler::yaw_of(self.attitude()));
        let (c, s) = (T::of(mathf::cos(0.5 * delta)), T::of(mathf::sin(0.5 * delta)));
        let z = T::zero();
        // Left multiplication by (c, 0, 0, s), as a 7×7 map (bias unchanged).
        let mut l = Matrix::<T>::identity();
        let l4 = SMatrix::<T, 4, 4>::new(c, z, z, -s, z, c, -s, z, z, s, c, z, s, z, z, c);
        l.fixed_view_mut::<4, 4>(0, 0).copy_from(&l4);
        self.x = l * self.x;
        normalise_quaternion(&mut self.x);
        self.p = l * self.p * l.transpose();
        symmetrise(&mut self.p);
    }

    /// Restart with a new initialisation window.
    pub fn reset(&mut self) {
        *self = Core::new(self.settings, self.tuning, self.set.clone());
    }
}

/// Shared test scenarios for [`crate::Ukf`] and [`crate::SsUkf`].
#[cfg(test)]
pub(crate) mod testkit {
    use super::*;
    use crate::{filter::AttitudeFilter, mathf::deg, mathf::to_deg, GRAVITY};

    /// Deterministic uniform noise in [−1, 1).
    pub struct Lcg(u64);

    impl Lcg {
        pub fn new(seed: u64) -> Self {
            Lcg(seed)
        }
        pub fn next(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((self.0 >> 40) as f32) / ((1u64 << 24) as f32) * 2.0 - 1.0
        }
        pub fn vec(&mut self, amp: f32) -> Vec3 {
            Vec3::new(self.next() * amp, self.next() * amp, self.next() * amp)
        }
    }

    /// A test mean and a full, well-conditioned covariance with standard deviations `sq`
    /// (quaternion components) and `sb` (bias).
    fn test_moments(sq: f64, sb: f64) -> (Vector<f64>, Matrix<f64>) {
        let x = Vector::<f64>::from_column_slice(&[0.8, 0.3, -0.4, 0.3, 0.02, -0.01, 0.005]);
        let mut rng = Lcg::new(7);
        let a = Matrix::<f64>::from_fn(|_, _| rng.next() as f64);
        let s = Matrix::<f64>::from_diagonal(&Vector::<f64>::from_fn(
            |i, _| {
                if i < 4 {
                    sq
                } else {
                    sb
                }
            },
        ));
        let c = a * a.transpose() * (1.0 / N as f64) + Matrix::<f64>::identity() * 0.1;
        let d = Vector::<f64>::from_fn(|i, _| 1.0 / libm::sqrt(c[(i, i)]));
        let c = Matrix::<f64>::from_fn(|i, j| c[(i, j)] * d[i] * d[j]);
        (x, s * c * s)
    }

    fn errors(m: &Vector<f64>, c: &Matrix<f64>, x: &Vector<f64>, p: &Matrix<f64>) -> (f64, f64) {
        let mut me = 0.0f64;
        let mut ce = 0.0f64;
        for i in 0..N {
            me = me.max((m[i] - x[i]).abs() / libm::sqrt(p[(i, i)]));
            for j in 0..N {
                let e = (c[(i, j)] - p[(i, j)]).abs() / libm::sqrt(p[(i, i)] * p[(j, j)]);
                ce = ce.max(e);
            }
        }
        (me, ce)
    }

    /// Draw the points of `set` (in `T`) for a test mean and covariance, and return the errors
    /// of their plain weighted mean `Σ Wm_i X_i` and covariance `Σ Wc_i (X_i − x̄)(X_i − x̄)ᵀ`
    /// (accumulated in f64): mean error in standard deviations, covariance error relative to
    /// `√(P_ii P_jj)`. Also checks the deviation-form moments the filters use (in `T`) at a
    /// converged-size covariance and returns the larger errors.
    pub fn sigma_moment_errors<T: Real, const M: usize>(set: &SigmaSet<T, M>) -> (f64, f64) {
        let (x, p) = test_moments(0.03, 0.004);
        let xt = x.map(|v| T::of(v as f32));
        let pt = p.map(|v| T::of(v as f32));
        let Some(c) = pt.cholesky() else { return (f64::INFINITY, f64::INFINITY) };
        let pts = set.points(&xt, &c.l()).map(|v| v.to_f64());
        let (wm, wc) = (set.wm.map(|v| v.to_f64()), set.wc.map(|v| v.to_f64()));
        let mut mean = Vector::<f64>::zeros();
        for (c, w) in pts.column_iter().zip(wm) {
            mean += c * w;
        }
        let mut cov = Matrix::<f64>::zeros();
        for (c, w) in pts.column_iter().zip(wc) {
            let d = c - mean;
            cov += d * d.transpose() * w;
        }
        let (me, ce) = errors(&mean, &cov, &xt.map(|v| v.to_f64()), &pt.map(|v| v.to_f64()));
        let (me2, ce2) = deviation_moment_errors(set);
        (me.max(me2), ce.max(ce2))
    }

    /// Errors of the deviation-form moments (in `T`, as the filters compute them) of the points
    /// drawn for a converged-size covariance (σ 10⁻³ on the quaternion, 10⁻⁴ rad/s on the bias).
    pub fn deviation_moment_errors<T: Real, const M: usize>(set: &SigmaSet<T, M>) -> (f64, f64) {
        let (x, p) = test_moments(1e-3, 1e-4);
        let xt = x.map(|v| T::of(v as f32));
        let pt = p.map(|v| T::of(v as f32));
        let Some(c) = pt.cholesky() else { return (f64::INFINITY, f64::INFINITY) };
        let pts = set.points(&xt, &c.l());
        let mut dev = SMatrix::<T, N, M>::zeros();
        for i in 1..M {
            dev.set_column(i, &(pts.column(i) - pts.column(0)));
        }
        let (dbar, cov) = set.moments(&dev);
        let mean = (pts.column(0) + dbar).map(|v| v.to_f64());
        let cov = cov.map(|v| v.to_f64());
        errors(&mean, &cov, &xt.map(|v| v.to_f64()), &pt.map(|v| v.to_f64()))
    }

    fn tilt_error_deg(q: Quaternion, truth: Quaternion) -> f32 {
        let c = q.down_in_body().dot(truth.down_in_body()).clamp(-1.0, 1.0);
        to_deg(libm::acosf(c))
    }

    fn check_sane<F: AttitudeFilter>(f: &F, cov: &impl Fn(&F) -> SMatrix<f32, 7, 7>) {
        let q = f.attitude();
        assert!(q.is_finite() && (q.norm_sq() - 1.0).abs() < 1e-5, "{q:?}");
        assert!(f.gyro_bias().is_finite());
        let p = cov(f);
        for i in 0..N {
            assert!(p[(i, i)] > 0.0, "P[{i},{i}] = {}", p[(i, i)]);
            for j in 0..N {
                assert!(p[(i, j)].is_finite(), "{p}");
                assert_eq!(p[(i, j)], p[(j, i)]);
            }
        }
    }

    /// Start 30° off in roll and 30° off in pitch from the truth, feed 20 s of still samples
    /// with small deterministic noise and a small true gyro bias; returns the tilt error, °.
    pub fn tilt_convergence<F: AttitudeFilter>(f: &mut F) -> f32 {
        let truth = Euler::new(deg(10.0), deg(-5.0), deg(30.0)).to_quaternion();
        f.set_attitude(Euler::new(deg(40.0), deg(25.0), deg(30.0)).to_quaternion(), Vec3::ZERO);
        assert!(tilt_error_deg(f.attitude(), truth) > 35.0);
        let bias = Vec3::new(deg(0.1), deg(-0.1), deg(0.05));
        let f_true = truth.down_in_body() * -GRAVITY;
        let mut rng = Lcg::new(42);
        let mut used = false;
        for _ in 0..1000 {
            let s = ImuSample::new(0.02, bias + rng.vec(deg(0.5)), f_true + rng.vec(0.02));
            used |= f.update(&s).contains(Flags::ACCEL_USED);
        }
        assert!(used);
        tilt_error_deg(f.attitude(), truth)
    }

    /// Level body turning at 10 °/s about body z for 10 s with exact gyro and accelerometer;
    /// returns the yaw error, °.
    pub fn yaw_tracking<F: AttitudeFilter>(f: &mut F) -> f32 {
        let rate = deg(10.0);
        f.set_attitude(Quaternion::IDENTITY, Vec3::ZERO);
        let s = ImuSample::new(0.02, Vec3::new(0.0, 0.0, rate), Vec3::new(0.0, 0.0, -GRAVITY));
        for _ in 0..500 {
            f.update(&s);
        }
        let truth = Quaternion::from_yaw(rate * 10.0);
        let e = f.euler();
        assert!(to_deg(e.roll.abs()).max(to_deg(e.pitch.abs())) < 0.01, "{e:?}");
        assert!(to_deg(f.attitude().angle_to(truth)) < 0.1);
        to_deg(mathf::wrap_pi(e.yaw - rate * 10.0).abs())
    }

    /// A run with NaN, ±inf, absurd and extreme samples mixed in: after every update the
    /// quaternion is unit and finite, and `P` finite, symmetric, with a positive diagonal.
    /// Clean samples afterwards bring the tilt back.
    pub fn garbage_run<F: AttitudeFilter>(f: &mut F, cov: impl Fn(&F) -> SMatrix<f32, 7, 7>) {
        let truth = Euler::new(deg(8.0), deg(-4.0), deg(20.0)).to_quaternion();
        f.set_attitude(truth, Vec3::ZERO);
        let acc = truth.down_in_body() * -GRAVITY;
        let (nan, inf) = (f32::NAN, f32::INFINITY);
        let g0 = Vec3::ZERO;
        let big = deg(1999.0);
        let bad = [
            ImuSample::new(nan, g0, acc),
            ImuSample::new(-0.02, g0, acc),
            ImuSample::new(0.0, g0, acc),
            ImuSample::new(inf, g0, acc),
            ImuSample::new(1e9, g0, acc),
            ImuSample::new(1e-30, g0, acc),
            ImuSample::new(3.0, Vec3::new(0.1, -0.2, 0.3), acc),
            ImuSample::new(0.02, Vec3::new(nan, 0.0, 0.0), acc),
            ImuSample::new(0.02, Vec3::new(0.0, -inf, 0.0), acc),
            ImuSample::new(0.02, Vec3::new(1e9, 0.0, f32::MAX), acc),
            ImuSample::new(0.02, Vec3::new(big, -big, big), acc),
            ImuSample::new(0.5, Vec3::new(big, big, -big), acc),
            ImuSample::new(0.02, g0, Vec3::new(nan, 0.0, 0.0)),
            ImuSample::new(0.02, g0, Vec3::new(0.0, inf, -inf)),
            ImuSample::new(0.02, g0, Vec3::ZERO),
            ImuSample::new(0.02, g0, Vec3::new(0.0, 0.0, -1e-30)),
            ImuSample::new(0.02, g0, Vec3::new(1e9, 0.0, 0.0)),
            ImuSample::new(0.02, g0, Vec3::new(0.0, 0.0, -15.0 * GRAVITY)),
            ImuSample::new(0.02, g0, Vec3::new(3.0 * GRAVITY, 0.0, 0.0)),
            ImuSample::new(nan, Vec3::new(nan, nan, nan), Vec3::new(inf, nan, -inf)),
        ];
        let mut rng = Lcg::new(3);
        for k in 0..1200 {
            let s = if k % 3 == 0 {
                bad[(k / 3) % bad.len()]
            } else {
                ImuSample::new(0.02, rng.vec(deg(0.5)), acc + rng.vec(0.02))
            };
            f.update(&s);
            check_sane(f, &cov);
        }
        for _ in 0..1500 {
            f.update(&ImuSample::new(0.02, rng.vec(deg(0.5)), acc + rng.vec(0.02)));
            check_sane(f, &cov);
        }
        let e = tilt_error_deg(f.attitude(), truth);
        assert!(e < 1.0, "tilt error {e}° 30 s after the garbage");
    }

    /// Pitched 5° and still, started 3° off about NED x and y (a pure tilt error, yaw right)
    /// with the default 5° yaw uncertainty, exact gyro and an accelerometer with about the
    /// configured noise, for 60 s. Every tilt correction moves the mean; the covariance must
    /// move with it or the yaw variance leaks into the tilt directions and the corrections into
    /// yaw (0.2° here without [`Core::transport`]). Returns the yaw error, °.
    pub fn yaw_kept_through_tilt_corrections<F: AttitudeFilter>(f: &mut F) -> f32 {
        let truth = Euler::new(0.0, deg(5.0), deg(30.0)).to_quaternion();
        let start = Quaternion::from_rotation_vector(Vec3::new(deg(3.0), deg(-3.0), 0.0)) * truth;
        f.set_attitude(start, Vec3::ZERO);
        let f_true = truth.down_in_body() * -GRAVITY;
        let mut rng = Lcg::new(11);
        for _ in 0..3000 {
            // Uniform ±0.0027 g: σ 0.0016 g, the configured accelerometer noise.
            f.update(&ImuSample::new(0.02, Vec3::ZERO, f_true + rng.vec(0.0027 * GRAVITY)));
        }
        let te = tilt_error_deg(f.attitude(), truth);
        assert!(te < 0.1, "tilt error {te}°");
        to_deg(mathf::wrap_pi(Euler::yaw_of(f.attitude()) - Euler::yaw_of(truth)).abs())
    }

    /// After the initialisation window the bias covariance is the window's standard error plus
    /// the floor, exactly as the EKF's.
    pub fn bias_covariance_from_the_window<F: AttitudeFilter>(
        f: &mut F,
        cov: impl Fn(&F) -> SMatrix<f32, 7, 7>,
    ) {
        let mut ekf = crate::Ekf::new(Settings::default());
        let s = ImuSample::new(0.02, Vec3::new(0.01, -0.02, 0.003), Vec3::new(0.0, 0.0, -GRAVITY));
        while !f.is_initialised() {
            f.update(&s);
            ekf.update(&s);
        }
        assert!(ekf.is_initialised());
        let p = cov(f);
        let pe = ekf.covariance();
        for i in 0..3 {
            let (v, ve) = (p[(4 + i, 4 + i)], pe.m[3 + i][3 + i]);
            assert!((v / ve - 1.0).abs() < 1e-5, "axis {i}: {v} vs EKF {ve}");
            // Far below the configured 0.2 °/s.
            assert!(v < 0.05 * deg(0.2) * deg(0.2), "axis {i}: {v}");
        }
    }

    /// The initialisation window (default 10 s) with a yaw set during it, `set_yaw` after it,
    /// and `reset`.
    pub fn init_window_and_reset<F: AttitudeFilter>(f: &mut F) {
        let truth = Euler::new(deg(3.0), deg(-6.0), deg(45.0)).to_quaternion();
        let bias = Vec3::new(0.01, -0.02, 0.003);
        let s = ImuSample::new(0.02, bias, truth.down_in_body() * -GRAVITY);
        assert!(!f.is_initialised());
        f.set_yaw(deg(45.0));
        for _ in 0..450 {
            assert!(f.update(&s).contains(Flags::INITIALISING));
        }
        assert!(!f.is_initialised());
        for _ in 0..60 {
            f.update(&s);
        }
        assert!(f.is_initialised());
        assert!(to_deg(f.attitude().angle_to(truth)) < 0.05);
        assert!((f.gyro_bias() - bias).max_abs() < 1e-4);
        f.set_yaw(deg(-90.0));
        let e = f.euler();
        assert!((to_deg(e.yaw) + 90.0).abs() < 1e-3, "{e:?}");
        assert!((to_deg(e.roll) - 3.0).abs() < 0.05 && (to_deg(e.pitch) + 6.0).abs() < 0.05);
        f.reset();
        assert!(!f.is_initialised());
        assert!(to_deg(Euler::yaw_of(f.attitude())).abs() < 1e-3);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Core with a trivial symmetric point set, to exercise the shared machinery.
    fn core() -> Core<f64, 15> {
        let g = 3.0_f64.sqrt();
        let mut z = SMatrix::<f64, N, 15>::zeros();
        for j in 0..N {
            z[(j, 1 + j)] = g;
            z[(j, 8 + j)] = -g;
        }
        let w = 1.0 / 6.0;
        let mut wm = [w; 15];
        wm[0] = 1.0 - 14.0 * w;
        let mut wc = wm;
        wc[0] += 2.0;
        let tuning = Tuning {
            accel_var_scale: 10.0,
            bias_random_walk: 1e-9,
            initial_tilt_sigma: 0.03,
            initial_yaw_sigma: 0.08,
            initial_bias_sigma: 0.003,
        };
        let mut c = Core::new(Settings::default(), tuning, SigmaSet { z, wm, wc });
        c.start(Euler::new(0.2, -0.1, 0.5).to_quaternion(), Vec3::ZERO);
        c
    }

    fn level_sample() -> ImuSample {
        ImuSample::new(0.02, Vec3::ZERO, Vec3::new(0.0, 0.0, -crate::GRAVITY))
    }

    #[test]
    fn process_model_is_the_digest_first_order_step() {
        let x = Vector::<f64>::from_column_slice(&[1.0, 0.0, 0.0, 0.0, 0.1, 0.0, 0.0]);
        // ω = gyro − b = (0.2, 0, 0): q ← (1, ½ ω dt).
        let y = process(&x, &[0.3, 0.0, 0.0], 0.5);
        assert!((y[0] - 1.0).abs() < 1e-15 && (y[1] - 0.05).abs() < 1e-15);
        assert!(y[2] == 0.0 && y[3] == 0.0 && y[4] == 0.1);
        // Same direction as the exact rotation about body x.
        let q = Quaternion::new(1.0, 0.05, 0.0, 0.0).normalized();
        let e = Quaternion::from_rotation_vector(Vec3::new(0.1, 0.0, 0.0));
        assert!(q.angle_to(e) < 1e-3);
    }

    #[test]
    fn initial_covariance_maps_angles_to_quaternion_components() {
        let c = core();
        let p = c.initial_cov();
        assert!(p.cholesky().is_some());
        // A pure yaw perturbation of σ_ψ: quaternion variance along ½Γ_z is σ_ψ²/4 · |Γ_z|².
        let g = gamma(&c.x);
        let gz = g.column(2).into_owned();
        let v = (gz.transpose() * p.fixed_view::<4, 4>(0, 0) * gz)[(0, 0)];
        assert!((v - 0.25 * 0.08 * 0.08).abs() < 1e-9, "{v}");
        assert!((p[(5, 5)] - 0.003 * 0.003).abs() < 1e-12);
    }

    #[test]
    fn indefinite_covariance_is_repaired_and_flagged() {
        let mut c = core();
        // Lose rank and go slightly indefinite in one direction: jitter repairs it.
        c.covariance_mut()[(6, 6)] = -1e-12;
        let f = c.update(&level_sample());
        assert!(f.contains(Flags::HEALTH_RESET), "{f:?}");
        assert!(c.p.cholesky().is_some());
        // Grossly indefinite: reset to the initial covariance.
        c.covariance_mut()[(0, 0)] = -1.0;
        let f = c.update(&level_sample());
        assert!(f.contains(Flags::HEALTH_RESET), "{f:?}");
        assert!(c.p.cholesky().is_some());
        assert!((0..N).all(|i| c.p[(i, i)] > 0.0));
        // Non-finite: reset too.
        c.covariance_mut()[(2, 3)] = f64::NAN;
        let f = c.update(&level_sample());
        assert!(f.contains(Flags::HEALTH_RESET));
        assert!(all_finite(&c.p));
        // A healthy covariance does not raise the flag.
        let f = c.update(&level_sample());
        assert!(!f.contains(Flags::HEALTH_RESET), "{f:?}");
    }

    #[test]
    fn transport_carries_the_covariance_with_the_mean() {
        // P built at q, the mean then rotated (about NED axes, as a correction does): carried
        // along, P is again the initial covariance, now at the new mean.
        let mut c = core();
        let q_prior = c.x.fixed_rows::<4>(0).into_owned();
        let q = Quaternion::new(
            q_prior[0] as f32,
            q_prior[1] as f32,
            q_prior[2] as f32,
            q_prior[3] as f32,
        );
        let q2 = Quaternion::from_rotation_vector(Vec3::new(0.02, -0.03, 0.01)) * q;
        c.set_state(q2, Vec3::ZERO);
        c.transport(&q_prior);
        let p0 = c.initial_cov();
        assert!((c.p - p0).abs().max() < 1e-8, "{}", (c.p - p0).abs().max());
        // Without it the yaw variance would appear in the tilt directions of the new mean.
        let mut d = core();
        let p_old = d.p;
        d.set_state(q2, Vec3::ZERO);
        assert!((p_old - d.initial_cov()).abs().max() > 1e-6);
    }

    #[test]
    fn set_yaw_rotates_state_and_covariance() {
        let mut c = core();
        let before = Euler::from_quaternion(c.attitude());
        let p_before = c.p;
        c.set_yaw(-2.0);
        let after = Euler::from_quaternion(c.attitude());
        assert!((after.yaw + 2.0).abs() < 1e-5);
        assert!((after.roll - before.roll).abs() < 1e-5);
        assert!((after.pitch - before.pitch).abs() < 1e-5);
        // Rotated with the state, P is again the initial covariance at the new attitude.
        let p0 = c.initial_cov();
        assert!((c.p - p0).abs().max() < 1e-9, "{}", (c.p - p0).abs().max());
        assert!((c.p - p_before).abs().max() > 1e-6);
    }
}

/// `AttitudeFilter` for a wrapper around [`Core`] (its field `core`), named `$name`.
macro_rules! impl_attitude_filter_for_core {
    ($ty:ty, $name:literal) => {
        impl $crate::filter::AttitudeFilter for $ty {
            fn name(&self) -> &'static str {
                $name
            }

            fn update(&mut self, sample: &$crate::ImuSample) -> $crate::Flags {
                self.core.update(sample)
            }

            fn attitude(&self) -> $crate::Quaternion {
                self.core.attitude()
            }

            fn gyro_bias(&self) -> $crate::Vec3 {
                self.core.gyro_bias()
            }

            fn is_initialised(&self) -> bool {
                self.core.is_initialised()
            }

            fn set_yaw(&mut self, yaw: f32) {
                self.core.set_yaw(yaw);
            }

            fn set_attitude(&mut self, q: $crate::Quaternion, bias: $crate::Vec3) {
                self.core.start(q, bias);
            }

            fn reset(&mut self) {
                self.core.reset();
            }
        }
    };
}
pub(crate) use impl_attitude_filter_for_core;
