//! The iNEMO V2 sensor simulator: motion scenarios of the source, ground truth and sensor
//! models, all in `f64` and independent of `ekf-core`'s maths.
//!
//! # Sensor models (thesis digest)
//! - gyro: `z_g = ω + b + e_g`, with per-axis bias `b` = (1.619, 3.440, −0.004) °/s and white
//!   noise `e_g` of variance (0.337, 0.275, 4.19e−3) (°/s)² per sample at 50 Hz;
//! - accelerometer: `z_a = a_b − Rᵀ g + ω̇ × r + ω × (ω × r) + e_a`, with `a_b` the linear
//!   acceleration of the rotation centre in body axes, `g = (0, 0, 9.80665)` m/s² in NED (so a
//!   still level board reads (0, 0, −9.81)), lever arm `r` = (297.25, −196, 80.30) mm in body
//!   FRD, and white noise of variance 2.376e−6 g² per axis and sample at 50 Hz. The tangential
//!   term `ω̇ × r` can be switched off ([`SensorModel::tangential`], on by default);
//! - the noise densities are held constant: at a sample rate `f` the per-sample variances are
//!   the 50 Hz values times `f / 50`;
//! - optional magnetometer (off by default): `Rᵀ m + e_m`, with `m` from
//!   `ekf_core::settings::MagSettings::default()` (25.6 µT, dip −65°, declination −25.5°) and
//!   0.5 µT (5 mgauss) white noise per axis;
//! - sensors are sampled instantaneously at `t_k = k / f`, `k = 0 .. round(duration · f)`
//!   (the last sample is just before `duration`).
//!
//! Noise draws come from [`crate::rng::Rng`], one stream per sensor derived from the seed, so
//! a trace depends only on (scenario, rate, duration, seed) and changing one sensor's noise
//! level leaves the other sensors' noise unchanged.
//!
//! # Truth
//! Either analytic, from an Euler-angle trajectory (angles, rates and angular accelerations of
//! each angle are analytic; `ω` and `ω̇` follow from the Z-Y-X kinematics), or integrated from
//! body rates with RK4 on `q̇ = ½ q ⊗ (0, ω)` at an internal step of at most 1 ms. Every
//! scenario starts level with yaw 0.
//!
//! # Scenarios
//! Every scenario is still for its first 10 s (the filters' initialisation window); `t' = t −
//! 10 s`. Timings are fixed; `--duration` only cuts or extends the run.
//!
//! | name | # | motion | default duration |
//! |---|---|---|---|
//! | `pitch-sine` | 1 | pitch θ = 10° · sin(2π · 0.1 Hz · t') from t = 10 s | 200 s |
//! | `coupled` | 2 | body rates p = 5° · 2π·0.1 · cos(2π·0.1·t'), q = 5° · 2π·0.15 · cos(2π·0.15·t') rad/s, r = 0, from t = 10 s (roll and pitch ≈ 5° sinusoids at 0.1 and 0.15 Hz; yaw responds through the coupling) | 200 s |
//! | `pitch-step` | 3 | pitch 0 → 20° in 0.1 s at t = 20 s (trapezoidal rate: 0.02 s edges, 250 °/s peak, 12 500 °/s² at the edges), then held | 200 s |
//! | `pitch-ramp` | 4 | pitch 0 → 30° at 1 °/s from t = 20 s to 50 s, then held | 200 s |
//! | `yaw-sine` | 5 | yaw ψ = 30° · sin(2π · 0.05 Hz · t') from t = 10 s | 200 s |
//! | `surge` | 6 | scenario 4's pitch ramp plus a constant 0.5 m/s² surge (body x) acceleration from t = 20 s to the end | 200 s |
//! | `gyro-noise` | | scenario 1 with 10× the gyro noise variance | 200 s |
//! | `accel-noise` | | scenario 1 with 10× the accelerometer noise variance | 200 s |
//! | `still-hour` | | still, level | 3600 s |
//! | `ramp-hour` | | scenario 4's pitch ramp (no roll or yaw motion) | 3600 s |
//! | `bias-off` | | still, level, with the z gyro bias 0.05 °/s larger than the default (0.046 °/s) | 3600 s |
//!
//! `bias-off` models a filter whose *configured* z bias is wrong by 0.05 °/s: the trace carries
//! the shifted bias (and says so in a comment line), and it is replayed with
//! `replay --no-init-bias`, which makes the filter use its configured bias
//! (`init.gyro_bias`, the board's mean bias) instead of estimating the bias from the still
//! initialisation window (which would measure the true bias and hide the error).

use crate::rng::Rng;
use crate::trace::{TraceColumns, TraceRow};

/// Degrees to radians.
pub const DEG: f64 = std::f64::consts::PI / 180.0;
/// Standard gravity used by the simulator, m/s².
pub const G0: f64 = 9.806_65;
/// Length of the still start of every scenario, s.
pub const STILL_S: f64 = 10.0;
/// Gyro bias of the board, °/s (x, y, z).
pub const GYRO_BIAS_DPS: [f64; 3] = [1.619, 3.440, -0.004];
/// Gyro noise variance of the board, (°/s)² per sample at [`NOISE_REF_RATE_HZ`].
pub const GYRO_VAR_DPS2: [f64; 3] = [0.337, 0.275, 4.19e-3];
/// Accelerometer noise variance, g² per axis and sample at [`NOISE_REF_RATE_HZ`].
pub const ACCEL_VAR_G2: f64 = 2.376e-6;
/// Rate at which the noise variances are given, Hz.
pub const NOISE_REF_RATE_HZ: f64 = 50.0;
/// IMU position from the rotation centre, m, body FRD (the Seahog).
pub const LEVER_ARM_M: [f64; 3] = [0.297_25, -0.196, 0.0803];
/// Extra z gyro bias of the `bias-off` scenario, °/s.
pub const BIAS_OFF_DPS: f64 = 0.05;

// ---------------------------------------------------------------------------------------------
// Small f64 vector / quaternion helpers (independent of ekf-core).

/// 3-vector, f64.
pub type V3 = [f64; 3];
/// Quaternion `(w, x, y, z)`, f64, Hamilton, body → NED.
pub type Q = [f64; 4];

/// Cross product.
pub fn cross(a: V3, b: V3) -> V3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Hamilton product `a ⊗ b`.
pub fn qmul(a: Q, b: Q) -> Q {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

fn qconj(q: Q) -> Q {
    [q[0], -q[1], -q[2], -q[3]]
}

/// Normalise, with the scalar part made non-negative.
pub fn qnormalize(q: Q) -> Q {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let s = if q[0] < 0.0 { -1.0 / n } else { 1.0 / n };
    [q[0] * s, q[1] * s, q[2] * s, q[3] * s]
}

/// Rotate a body vector into NED: `q ⊗ v ⊗ q*`.
pub fn rotate(q: Q, v: V3) -> V3 {
    let r = qmul(qmul(q, [0.0, v[0], v[1], v[2]]), qconj(q));
    [r[1], r[2], r[3]]
}

/// Rotate a NED vector into the body: `q* ⊗ v ⊗ q`.
pub fn rotate_inverse(q: Q, v: V3) -> V3 {
    rotate(qconj(q), v)
}

/// Rotation by `angle` (rad) about a unit `axis`.
pub fn axis_angle(axis: V3, angle: f64) -> Q {
    let (s, c) = (0.5 * angle).sin_cos();
    [c, axis[0] * s, axis[1] * s, axis[2] * s]
}

/// Z-Y-X Euler angles (rad) to the body → NED quaternion: `q_z(ψ) ⊗ q_y(θ) ⊗ q_x(φ)`.
pub fn euler_to_q(roll: f64, pitch: f64, yaw: f64) -> Q {
    let qz = axis_angle([0.0, 0.0, 1.0], yaw);
    let qy = axis_angle([0.0, 1.0, 0.0], pitch);
    let qx = axis_angle([1.0, 0.0, 0.0], roll);
    qnormalize(qmul(qmul(qz, qy), qx))
}

/// Body → NED quaternion to Z-Y-X Euler angles `(roll, pitch, yaw)`, rad.
pub fn q_to_euler(q: Q) -> V3 {
    let [w, x, y, z] = q;
    let roll = (2.0 * (y * z + w * x)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - x * z)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (x * y + w * z)).atan2(1.0 - 2.0 * (y * y + z * z));
    [roll, pitch, yaw]
}

/// Body rates `ω` and their derivative `ω̇` from Z-Y-X Euler angles `e = (φ, θ, ψ)`, their
/// rates `de` and second derivatives `dde`.
pub fn euler_rates_to_body(e: V3, de: V3, dde: V3) -> (V3, V3) {
    let (sf, cf) = e[0].sin_cos();
    let (st, ct) = e[1].sin_cos();
    let [dphi, dth, dpsi] = de;
    let [ddphi, ddth, ddpsi] = dde;
    let w = [dphi - dpsi * st, dth * cf + dpsi * sf * ct, -dth * sf + dpsi * cf * ct];
    let dw = [
        ddphi - ddpsi * st - dpsi * dth * ct,
        ddth * cf - dth * dphi * sf + ddpsi * sf * ct + dpsi * dphi * cf * ct
            - dpsi * dth * sf * st,
        -ddth * sf - dth * dphi * cf + ddpsi * cf * ct
            - dpsi * dphi * sf * ct
            - dpsi * dth * cf * st,
    ];
    (w, dw)
}

// ---------------------------------------------------------------------------------------------
// Motion.

/// A scalar function of time with analytic first and second derivatives. Zero before its
/// start unless stated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Profile {
    /// Always zero.
    Zero,
    /// A constant.
    Const(f64),
    /// `amp · sin(2π f (t − start) + phase)` from `start` on, zero before.
    Sine {
        /// Start time, s.
        start: f64,
        /// Amplitude.
        amp: f64,
        /// Frequency, Hz.
        freq_hz: f64,
        /// Phase at `start`, rad.
        phase: f64,
    },
    /// `from` until `start`, then linear to `to` at `end`, then held.
    Ramp {
        /// Start of the ramp, s.
        start: f64,
        /// End of the ramp, s.
        end: f64,
        /// Value before.
        from: f64,
        /// Value after.
        to: f64,
    },
    /// `from` → `to` over `duration` from `start`, with a trapezoidal rate: the rate rises
    /// linearly over `edge` seconds, holds, and falls over `edge` seconds.
    Step {
        /// Start, s.
        start: f64,
        /// Total duration, s (> 2 · edge).
        duration: f64,
        /// Rate rise/fall time, s.
        edge: f64,
        /// Value before.
        from: f64,
        /// Value after.
        to: f64,
    },
    /// Zero before `start`, `value` from `start` on.
    OnFrom {
        /// Switch-on time, s.
        start: f64,
        /// Value.
        value: f64,
    },
}

impl Profile {
    /// `(value, first derivative, second derivative)` at `t`.
    pub fn eval(&self, t: f64) -> (f64, f64, f64) {
        match *self {
            Profile::Zero => (0.0, 0.0, 0.0),
            Profile::Const(c) => (c, 0.0, 0.0),
            Profile::Sine { start, amp, freq_hz, phase } => {
                if t < start {
                    return (0.0, 0.0, 0.0);
                }
                let w = std::f64::consts::TAU * freq_hz;
                let (s, c) = (w * (t - start) + phase).sin_cos();
                (amp * s, amp * w * c, -amp * w * w * s)
            }
            Profile::Ramp { start, end, from, to } => {
                if t <= start {
                    (from, 0.0, 0.0)
                } else if t >= end {
                    (to, 0.0, 0.0)
                } else {
                    let rate = (to - from) / (end - start);
                    (from + rate * (t - start), rate, 0.0)
                }
            }
            Profile::Step { start, duration, edge, from, to } => {
                let (big_t, e) = (duration, edge);
                let u = t - start;
                let delta = to - from;
                let rate = delta / (big_t - e);
                if u <= 0.0 {
                    (from, 0.0, 0.0)
                } else if u >= big_t {
                    (to, 0.0, 0.0)
                } else if u < e {
                    (from + rate * u * u / (2.0 * e), rate * u / e, rate / e)
                } else if u <= big_t - e {
                    (from + rate * e / 2.0 + rate * (u - e), rate, 0.0)
                } else {
                    let v = big_t - u;
                    (to - rate * v * v / (2.0 * e), rate * v / e, -rate / e)
                }
            }
            Profile::OnFrom { start, value } => {
                if t >= start {
                    (value, 0.0, 0.0)
                } else {
                    (0.0, 0.0, 0.0)
                }
            }
        }
    }
}

/// How the attitude moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Attitude {
    /// Z-Y-X Euler angles `[roll, pitch, yaw]`, rad, each a [`Profile`]: analytic truth.
    Euler([Profile; 3]),
    /// Body rates `[p, q, r]`, rad/s, each a [`Profile`], integrated from `q0` (RK4, internal
    /// step ≤ 1 ms).
    BodyRates {
        /// Rates, rad/s, body FRD.
        rates: [Profile; 3],
        /// Initial attitude.
        q0: Q,
    },
}

/// A motion: attitude plus the linear acceleration of the rotation centre in body axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trajectory {
    /// Attitude motion.
    pub attitude: Attitude,
    /// Linear acceleration of the rotation centre, m/s², body FRD (x surge, y sway, z heave).
    pub accel_body: [Profile; 3],
}

impl Trajectory {
    /// Still and level, yaw 0.
    pub const STILL: Trajectory = Trajectory {
        attitude: Attitude::Euler([Profile::Zero; 3]),
        accel_body: [Profile::Zero; 3],
    };

    /// An Euler-angle trajectory without linear acceleration.
    pub fn euler(roll: Profile, pitch: Profile, yaw: Profile) -> Self {
        Trajectory { attitude: Attitude::Euler([roll, pitch, yaw]), accel_body: [Profile::Zero; 3] }
    }
}

// ---------------------------------------------------------------------------------------------
// Sensors.

/// Sensor model parameters. [`Default`] is the iNEMO V2 on the Seahog (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorModel {
    /// Gyro bias, rad/s, body FRD.
    pub gyro_bias: V3,
    /// Gyro white-noise variance per sample at `ref_rate_hz`, (rad/s)².
    pub gyro_var: V3,
    /// Accelerometer white-noise variance per axis and sample at `ref_rate_hz`, g².
    pub accel_var_g2: f64,
    /// Rate at which the variances hold, Hz (densities are constant).
    pub ref_rate_hz: f64,
    /// IMU position from the rotation centre, m, body FRD.
    pub lever_arm: V3,
    /// Include `ω × (ω × r)`.
    pub centripetal: bool,
    /// Include `ω̇ × r`.
    pub tangential: bool,
    /// Gravity, m/s².
    pub gravity: f64,
    /// Simulate the magnetometer.
    pub mag: bool,
    /// Earth field, µT, NED.
    pub mag_field_ned: V3,
    /// Magnetometer noise standard deviation per axis and sample, µT.
    pub mag_noise_ut: f64,
}

impl Default for SensorModel {
    fn default() -> Self {
        let m = ekf_core::settings::MagSettings::default();
        let (dip, dec, f) = (m.dip as f64, m.declination as f64, m.field_ut as f64);
        SensorModel {
            gyro_bias: GYRO_BIAS_DPS.map(|b| b * DEG),
            gyro_var: GYRO_VAR_DPS2.map(|v| v * DEG * DEG),
            accel_var_g2: ACCEL_VAR_G2,
            ref_rate_hz: NOISE_REF_RATE_HZ,
            lever_arm: LEVER_ARM_M,
            centripetal: true,
            tangential: true,
            gravity: G0,
            mag: false,
            mag_field_ned: [f * dip.cos() * dec.cos(), f * dip.cos() * dec.sin(), f * dip.sin()],
            mag_noise_ut: 0.5,
        }
    }
}

impl SensorModel {
    /// Per-sample gyro noise standard deviation at `rate_hz`, rad/s.
    pub fn gyro_std(&self, rate_hz: f64) -> V3 {
        self.gyro_var.map(|v| (v * rate_hz / self.ref_rate_hz).sqrt())
    }

    /// Per-sample accelerometer noise standard deviation at `rate_hz`, m/s².
    pub fn accel_std(&self, rate_hz: f64) -> f64 {
        (self.accel_var_g2 * rate_hz / self.ref_rate_hz).sqrt() * self.gravity
    }

    /// Noise-free accelerometer reading (specific force at the IMU), m/s², body FRD.
    pub fn accel_clean(&self, q: Q, omega: V3, omega_dot: V3, accel_body: V3) -> V3 {
        let g_body = rotate_inverse(q, [0.0, 0.0, self.gravity]);
        let mut f = sub(accel_body, g_body);
        if self.centripetal {
            f = add(f, cross(omega, cross(omega, self.lever_arm)));
        }
        if self.tangential {
            f = add(f, cross(omega_dot, self.lever_arm));
        }
        f
    }
}

/// Simulation settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimConfig {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Duration, s.
    pub duration_s: f64,
    /// Noise seed.
    pub seed: u64,
    /// Sensor model.
    pub sensors: SensorModel,
}

impl Default for SimConfig {
    /// 50 Hz, 200 s, seed 1, the iNEMO sensors.
    fn default() -> Self {
        SimConfig { rate_hz: 50.0, duration_s: 200.0, seed: 1, sensors: SensorModel::default() }
    }
}

/// One simulated sample with its noise-free truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimSample {
    /// The trace row (sensor readings as `f32`, truth quaternion included).
    pub row: TraceRow,
    /// True attitude, body → NED.
    pub q: Q,
    /// True body rate, rad/s.
    pub omega: V3,
    /// True angular acceleration, rad/s².
    pub omega_dot: V3,
    /// Linear acceleration of the rotation centre, m/s², body.
    pub accel_body: V3,
    /// Noise-free accelerometer reading at the IMU, m/s², body.
    pub accel_clean: V3,
}

/// Iterator over the samples of a simulation.
pub struct Simulator {
    traj: Trajectory,
    cfg: SimConfig,
    k: u64,
    n: u64,
    /// Integrated attitude and its time (body-rate trajectories).
    q_int: Q,
    t_int: f64,
    gyro_rng: Rng,
    accel_rng: Rng,
    mag_rng: Rng,
    gyro_std: V3,
    accel_std: f64,
}

/// Largest internal integration step, s.
pub const MAX_INTERNAL_STEP: f64 = 1e-3;

impl Simulator {
    /// A simulation of `traj` with `cfg`.
    pub fn new(traj: Trajectory, cfg: SimConfig) -> Self {
        let n = (cfg.duration_s * cfg.rate_hz).round().max(0.0) as u64;
        let q0 = match traj.attitude {
            Attitude::BodyRates { q0, .. } => qnormalize(q0),
            Attitude::Euler(_) => [1.0, 0.0, 0.0, 0.0],
        };
        Simulator {
            traj,
            cfg,
            k: 0,
            n,
            q_int: q0,
            t_int: 0.0,
            gyro_rng: Rng::new(cfg.seed, 1),
            accel_rng: Rng::new(cfg.seed, 2),
            mag_rng: Rng::new(cfg.seed, 3),
            gyro_std: cfg.sensors.gyro_std(cfg.rate_hz),
            accel_std: cfg.sensors.accel_std(cfg.rate_hz),
        }
    }

    /// Number of samples the simulation produces.
    pub fn len(&self) -> u64 {
        self.n
    }

    /// True when the simulation produces no sample.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Columns of the trace rows produced.
    pub fn columns(&self) -> TraceColumns {
        TraceColumns { mag: self.cfg.sensors.mag, depth: false, truth: true }
    }

    fn rates(rates: &[Profile; 3], t: f64) -> V3 {
        [rates[0].eval(t).0, rates[1].eval(t).0, rates[2].eval(t).0]
    }

    /// Truth at `t`: attitude, ω, ω̇. Body-rate trajectories integrate forward from the last
    /// call (calls must come in increasing time).
    fn truth(&mut self, t: f64) -> (Q, V3, V3) {
        match self.traj.attitude {
            Attitude::Euler(p) => {
                let (a, b, c) = (p[0].eval(t), p[1].eval(t), p[2].eval(t));
                let (w, dw) =
                    euler_rates_to_body([a.0, b.0, c.0], [a.1, b.1, c.1], [a.2, b.2, c.2]);
                (euler_to_q(a.0, b.0, c.0), w, dw)
            }
            Attitude::BodyRates { rates, .. } => {
                let span = t - self.t_int;
                if span > 0.0 {
                    let steps = (span / MAX_INTERNAL_STEP).ceil().max(1.0) as u64;
                    let h = span / steps as f64;
                    let deriv = |q: Q, w: V3| -> Q {
                        let d = qmul(q, [0.0, w[0], w[1], w[2]]);
                        [0.5 * d[0], 0.5 * d[1], 0.5 * d[2], 0.5 * d[3]]
                    };
                    let axpy = |q: Q, k: Q, s: f64| -> Q {
                        [q[0] + s * k[0], q[1] + s * k[1], q[2] + s * k[2], q[3] + s * k[3]]
                    };
                    let mut q = self.q_int;
                    for i in 0..steps {
                        let t0 = self.t_int + i as f64 * h;
                        let w0 = Self::rates(&rates, t0);
                        let wm = Self::rates(&rates, t0 + 0.5 * h);
                        let w1 = Self::rates(&rates, t0 + h);
                        let k1 = deriv(q, w0);
                        let k2 = deriv(axpy(q, k1, 0.5 * h), wm);
                        let k3 = deriv(axpy(q, k2, 0.5 * h), wm);
                        let k4 = deriv(axpy(q, k3, h), w1);
                        q = [
                            q[0] + h / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
                            q[1] + h / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
                            q[2] + h / 6.0 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]),
                            q[3] + h / 6.0 * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3]),
                        ];
                        let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
                        q = q.map(|c| c / n);
                    }
                    self.q_int = q;
                    self.t_int = t;
                }
                let w = Self::rates(&rates, t);
                let dw = [rates[0].eval(t).1, rates[1].eval(t).1, rates[2].eval(t).1];
                (qnormalize(self.q_int), w, dw)
            }
        }
    }
}

impl Iterator for Simulator {
    type Item = SimSample;

    fn next(&mut self) -> Option<SimSample> {
        if self.k >= self.n {
            return None;
        }
        let t = self.k as f64 / self.cfg.rate_hz;
        self.k += 1;
        let s = self.cfg.sensors;
        let (q, omega, omega_dot) = self.truth(t);
        let ab = self.traj.accel_body;
        let accel_body = [ab[0].eval(t).0, ab[1].eval(t).0, ab[2].eval(t).0];
        let accel_clean = s.accel_clean(q, omega, omega_dot, accel_body);

        let mut gyro = [0f32; 3];
        for i in 0..3 {
            let v = omega[i] + s.gyro_bias[i] + self.gyro_std[i] * self.gyro_rng.normal();
            gyro[i] = v as f32;
        }
        let mut accel = [0f32; 3];
        for i in 0..3 {
            accel[i] = (accel_clean[i] + self.accel_std * self.accel_rng.normal()) as f32;
        }
        let mag = if s.mag {
            let m = rotate_inverse(q, s.mag_field_ned);
            let mut out = [0f32; 3];
            for i in 0..3 {
                out[i] = (m[i] + s.mag_noise_ut * self.mag_rng.normal()) as f32;
            }
            Some(out)
        } else {
            None
        };
        let row = TraceRow { t, gyro, accel, mag, depth: None, truth: Some(q.map(|c| c as f32)) };
        Some(SimSample { row, q, omega, omega_dot, accel_body, accel_clean })
    }
}

// ---------------------------------------------------------------------------------------------
// Scenarios.

/// The named scenarios (see the module docs for their definitions).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scenario {
    /// 1: pitch sinusoid.
    PitchSine,
    /// 2: small coupled roll + pitch sinusoids through body rates.
    Coupled,
    /// 3: near-instantaneous pitch step.
    PitchStep,
    /// 4: gradual pitch step at constant rate.
    PitchRamp,
    /// 5: yaw sinusoid.
    YawSine,
    /// 6: surge acceleration during a gradual pitch step.
    Surge,
    /// Scenario 1 with 10× gyro noise variance.
    GyroNoise,
    /// Scenario 1 with 10× accelerometer noise variance.
    AccelNoise,
    /// One hour still.
    StillHour,
    /// One hour with a gradual pitch step, no yaw motion.
    RampHour,
    /// One hour still with the z gyro bias 0.05 °/s off the default.
    BiasOff,
}

impl Scenario {
    /// Every scenario, in order.
    pub const ALL: [Scenario; 11] = [
        Scenario::PitchSine,
        Scenario::Coupled,
        Scenario::PitchStep,
        Scenario::PitchRamp,
        Scenario::YawSine,
        Scenario::Surge,
        Scenario::GyroNoise,
        Scenario::AccelNoise,
        Scenario::StillHour,
        Scenario::RampHour,
        Scenario::BiasOff,
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Scenario::PitchSine => "pitch-sine",
            Scenario::Coupled => "coupled",
            Scenario::PitchStep => "pitch-step",
            Scenario::PitchRamp => "pitch-ramp",
            Scenario::YawSine => "yaw-sine",
            Scenario::Surge => "surge",
            Scenario::GyroNoise => "gyro-noise",
            Scenario::AccelNoise => "accel-noise",
            Scenario::StillHour => "still-hour",
            Scenario::RampHour => "ramp-hour",
            Scenario::BiasOff => "bias-off",
        }
    }

    /// Parse a name, or the source's scenario number `1`–`6`.
    pub fn from_name(s: &str) -> Option<Scenario> {
        let n = match s {
            "1" => "pitch-sine",
            "2" => "coupled",
            "3" => "pitch-step",
            "4" => "pitch-ramp",
            "5" => "yaw-sine",
            "6" => "surge",
            other => other,
        };
        Scenario::ALL.into_iter().find(|sc| sc.name() == n)
    }

    /// Default duration, s.
    pub fn default_duration(self) -> f64 {
        match self {
            Scenario::StillHour | Scenario::RampHour | Scenario::BiasOff => 3600.0,
            _ => 200.0,
        }
    }

    /// The motion.
    pub fn trajectory(self) -> Trajectory {
        let pitch_ramp = Profile::Ramp { start: 20.0, end: 50.0, from: 0.0, to: 30.0 * DEG };
        match self {
            Scenario::PitchSine | Scenario::GyroNoise | Scenario::AccelNoise => Trajectory::euler(
                Profile::Zero,
                Profile::Sine { start: STILL_S, amp: 10.0 * DEG, freq_hz: 0.1, phase: 0.0 },
                Profile::Zero,
            ),
            Scenario::Coupled => {
                let rate = |amp_deg: f64, f: f64| Profile::Sine {
                    start: STILL_S,
                    amp: amp_deg * DEG * std::f64::consts::TAU * f,
                    freq_hz: f,
                    phase: std::f64::consts::FRAC_PI_2,
                };
                Trajectory {
                    attitude: Attitude::BodyRates {
                        rates: [rate(5.0, 0.1), rate(5.0, 0.15), Profile::Zero],
                        q0: [1.0, 0.0, 0.0, 0.0],
                    },
                    accel_body: [Profile::Zero; 3],
                }
            }
            Scenario::PitchStep => Trajectory::euler(
                Profile::Zero,
                Profile::Step { start: 20.0, duration: 0.1, edge: 0.02, from: 0.0, to: 20.0 * DEG },
                Profile::Zero,
            ),
            Scenario::PitchRamp | Scenario::RampHour => {
                Trajectory::euler(Profile::Zero, pitch_ramp, Profile::Zero)
            }
            Scenario::YawSine => Trajectory::euler(
                Profile::Zero,
                Profile::Zero,
                Profile::Sine { start: STILL_S, amp: 30.0 * DEG, freq_hz: 0.05, phase: 0.0 },
            ),
            Scenario::Surge => Trajectory {
                accel_body: [
                    Profile::OnFrom { start: 20.0, value: 0.5 },
                    Profile::Zero,
                    Profile::Zero,
                ],
                ..Trajectory::euler(Profile::Zero, pitch_ramp, Profile::Zero)
            },
            Scenario::StillHour | Scenario::BiasOff => Trajectory::STILL,
        }
    }

    /// The sensor model (the default, with this scenario's changes).
    pub fn sensors(self) -> SensorModel {
        let mut s = SensorModel::default();
        match self {
            Scenario::GyroNoise => s.gyro_var = s.gyro_var.map(|v| v * 10.0),
            Scenario::AccelNoise => s.accel_var_g2 *= 10.0,
            Scenario::BiasOff => s.gyro_bias[2] += BIAS_OFF_DPS * DEG,
            _ => {}
        }
        s
    }

    /// Comment lines for the trace header.
    pub fn comments(self, cfg: &SimConfig) -> Vec<String> {
        let mut c = vec![format!(
            "host-tests simulate {}: rate {} Hz, duration {} s, seed {}",
            self.name(),
            cfg.rate_hz,
            cfg.duration_s,
            cfg.seed
        )];
        let b = cfg.sensors.gyro_bias.map(|v| v / DEG);
        c.push(format!("gyro bias (deg/s): {} {} {}", b[0], b[1], b[2]));
        match self {
            Scenario::BiasOff => c.push(format!(
                "bias-off: z gyro bias is {BIAS_OFF_DPS} deg/s larger than the default; replay \
                 with --no-init-bias so the filter uses its configured (now wrong) bias"
            )),
            Scenario::GyroNoise => c.push("gyro-noise: 10x gyro noise variance".into()),
            Scenario::AccelNoise => c.push("accel-noise: 10x accelerometer noise variance".into()),
            _ => {}
        }
        c
    }

    /// The simulator for this scenario with `rate_hz`, `duration_s` (default when `None`) and
    /// `seed`.
    pub fn simulator(
        self,
        rate_hz: f64,
        duration_s: Option<f64>,
        seed: u64,
        mag: bool,
    ) -> (Simulator, SimConfig) {
        let mut sensors = self.sensors();
        sensors.mag = mag;
        let cfg = SimConfig {
            rate_hz,
            duration_s: duration_s.unwrap_or(self.default_duration()),
            seed,
            sensors,
        };
        (Simulator::new(self.trajectory(), cfg), cfg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profiles_derivatives_match_finite_differences() {
        let ps = [
            Profile::Sine { start: 1.0, amp: 0.3, freq_hz: 0.7, phase: 0.4 },
            Profile::Ramp { start: 1.0, end: 3.0, from: 0.1, to: -0.5 },
            Profile::Step { start: 1.0, duration: 0.1, edge: 0.02, from: 0.0, to: 0.35 },
        ];
        let h = 1e-6;
        for p in ps {
            for k in 0..400 {
                let t = 0.9 + k as f64 * 0.000_77 + 0.000_1;
                let (v0, d0, dd0) = p.eval(t);
                let (vp, dp, _) = p.eval(t + h);
                let (vm, dm, _) = p.eval(t - h);
                assert!(((vp - vm) / (2.0 * h) - d0).abs() < 1e-4 * (1.0 + d0.abs()), "{p:?} {t}");
                assert!(((dp - dm) / (2.0 * h) - dd0).abs() < 1e-3 * (1.0 + dd0.abs()), "{p:?}");
                assert!(v0.is_finite());
            }
        }
        // The step reaches its end value and its rate peaks at Δ / (T − edge).
        let p = Profile::Step { start: 0.0, duration: 0.1, edge: 0.02, from: 0.0, to: 20.0 };
        assert!((p.eval(0.1).0 - 20.0).abs() < 1e-12);
        assert!((p.eval(0.05).1 - 250.0).abs() < 1e-9);
        assert!((p.eval(0.0999999).0 - 20.0).abs() < 1e-6);
    }

    #[test]
    fn euler_kinematics_match_numerical_differentiation() {
        // Arbitrary smooth Euler trajectory: ω from the formula equals the rate of change of
        // the quaternion, 2 q* ⊗ q̇; ω̇ equals the finite difference of ω.
        let e = |t: f64| [0.3 * (1.1 * t).sin(), 0.2 * (0.7 * t).cos(), 0.5 * t];
        let de = |t: f64| [0.33 * (1.1 * t).cos(), -0.14 * (0.7 * t).sin(), 0.5];
        let dde = |t: f64| [-0.363 * (1.1 * t).sin(), -0.098 * (0.7 * t).cos(), 0.0];
        let h = 1e-6;
        for k in 0..20 {
            let t = 0.37 * k as f64;
            let (w, dw) = euler_rates_to_body(e(t), de(t), dde(t));
            let q = |t: f64| {
                let a = e(t);
                euler_to_q(a[0], a[1], a[2])
            };
            let (qp, qm) = (q(t + h), q(t - h));
            let qdot = [0, 1, 2, 3].map(|i| (qp[i] - qm[i]) / (2.0 * h));
            let wq = qmul(qconj(q(t)), qdot);
            for i in 0..3 {
                assert!((2.0 * wq[i + 1] - w[i]).abs() < 1e-6, "{t} {i}");
            }
            let (wp, _) = euler_rates_to_body(e(t + h), de(t + h), dde(t + h));
            let (wm, _) = euler_rates_to_body(e(t - h), de(t - h), dde(t - h));
            for i in 0..3 {
                assert!(((wp[i] - wm[i]) / (2.0 * h) - dw[i]).abs() < 1e-6, "{t} {i}");
            }
        }
    }

    #[test]
    fn euler_round_trip() {
        let q = euler_to_q(0.3, -0.4, 2.5);
        let e = q_to_euler(q);
        assert!((e[0] - 0.3).abs() < 1e-12 && (e[1] + 0.4).abs() < 1e-12);
        assert!((e[2] - 2.5).abs() < 1e-12);
    }

    #[test]
    fn scenario_names_round_trip() {
        for s in Scenario::ALL {
            assert_eq!(Scenario::from_name(s.name()), Some(s));
        }
        assert_eq!(Scenario::from_name("6"), Some(Scenario::Surge));
        assert_eq!(Scenario::from_name("nope"), None);
    }
}
