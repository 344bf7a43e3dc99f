//! The filter loop shared by the two unscented filters: initialisation window, validation,
//! time update, accelerometer update with the gate (module documentation of [`super`]).

use nalgebra::{Cholesky, Const, SMatrix, SVector};

use super::model::{down, gamma, normalise_quaternion, process};
use super::repair::{all_finite, symmetrise};
use super::{Matrix, Real, SigmaSet, Tuning, Vector, N};
use crate::{
    gate::{AccelGate, PreCheck},
    init::{self, InitStep, Initializer},
    mathf,
    settings::Settings,
    validate::{self, Checked},
    Euler, Flags, ImuSample, Quaternion, Vec3,
};

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
    pub(super) settings: Settings,
    pub(super) tuning: Tuning,
    pub(super) set: SigmaSet<T, M>,
    pub(super) x: Vector<T>,
    pub(super) p: Matrix<T>,
    pub(super) init: Option<Initializer>,
    pub(super) gate: AccelGate,
    pub(super) last_flags: Flags,
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

    pub(super) fn set_state(&mut self, q: Quaternion, b: Vec3) {
        let v = [q.w, q.x, q.y, q.z, b.x, b.y, b.z];
        self.x = Vector::<T>::from_fn(|i, _| T::of(v[i]));
    }

    /// Initial covariance at the current attitude (see the module documentation).
    pub(super) fn initial_cov(&self) -> Matrix<T> {
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
        let var = self.settings.noise.accel_var_per_sample(dt) * self.tuning.accel_var_scale;
        let r = T::of(var.max(1e-12));
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
