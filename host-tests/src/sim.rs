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
//! - sensors are sampled at `t_k = k / f`, `k = 0 .. round(duration · f)` (the last sample is
//!   just before `duration`): the accelerometer instantaneously, the gyro as the mean body
//!   rate over the period `(t_k − 1/f, t_k]`, which is what the firmware reads (it averages
//!   the ADC's frames over each filter period; digital IMUs average over their output period
//!   alike). `SimSample::omega` is the instantaneous rate.
//!
//! Noise draws come from [`crate::rng::Rng`], one stream per sensor derived from the seed, so
//! a trace depends only on (scenario, rate, duration, seed) and changing one sensor's noise
//! level leaves the other sensors' noise unchanged.
//!
//! # Realism (opt-in)
//! The model above is the filter's own. [`SensorModel::realism`] (`None` by default, so
//! traces without it are unchanged bit for bit; [`SimOptions::realistic`] /
//! [`Scenario::simulator_with`] switch on [`Realism::INEMO`]) adds the errors a real board
//! has and the filter does not model. Each random process has its own stream (4 fixed errors,
//! 5 bias random walk, 6 flicker, 7 jitter, 8 repeats, 9 vibration); the white noise draws are
//! unchanged, so [`Realism::OFF`] reproduces the plain model exactly.
//!
//! | effect | model | iNEMO value | source |
//! |---|---|---|---|
//! | gyro bias random walk | `b_rw += K √Δt · N(0,1)` per sample, from 0 | K = 0.002, 0.002, 0.0005 °/s/√s (x, y, z) | the LPR430AL/LY330ALH datasheets give no bias stability figure; 0.002 °/s/√s is a typical consumer-MEMS rate random walk (0.12 °/s after an hour), and z is bounded by the thesis's hourly z-bias spread of 0.035 °/s (K√3600 = 0.03 °/s); x/y stay well inside the thesis's 0.8/0.5 °/s (which is the per-sample noise level: the mean is stable) |
//! | gyro flicker (bias instability) | sum of 4 first-order Gauss–Markov processes, τ = 1, 10, 100, 1000 s, each of stationary σ = B / 0.76, started stationary (Allan deviation ≈ B, flat within ±5 % from 3 s to 1000 s, [`FLICKER_ADEV_PER_SIGMA`]) | B = 0.005 °/s (18 °/h) per axis | no datasheet figure; typical bias instability of consumer MEMS gyros of that generation (10–30 °/h) |
//! | gyro scale factor | `1 + u`, u ~ U(±2 %) per axis, fixed per seed | ±2 % | ST analog gyros: sensitivity tolerance of a few % before calibration (brief: ±1–2 %) |
//! | gyro cross-axis / misalignment | off-diagonal terms of the sensitivity matrix ~ U(±1 %), fixed per seed | ±1 % | typical package and board misalignment (≈ 0.6°) |
//! | accelerometer bias | U(±3 mg) per axis, fixed per seed | ±3 mg | what the six-position calibration leaves (the board runs calibrated: `ACAL` in `docs/commands.md`, thesis appendix B; the raw LSM303DLH zero-g offset of up to ±60 mg, 47 mg on z on the source's board, is what it removes): the fit's residuals are within the sensor's 1 mg resolution plus orientation error of the six positions |
//! | accelerometer scale factor | `1 + u`, u ~ U(±0.3 %) per axis, fixed per seed | ±0.3 % | residual after the same calibration (the raw sensitivity spread of a few %, 4 % on the source's board, is removed by it) |
//! | accelerometer quantisation | round to 1 mg, clamp to −2048 … 2047 mg | 1 mg/LSB, ±2 g range (±2.048 g of codes) | LSM303DLH 12-bit at ±2 g (1 mg/digit) |
//! | gyro quantisation | round to the ADC step over the sensitivity, clamp ±300 °/s | 0.806 mV / 3.33 mV/(°/s) = 0.2420 °/s (x, y), 0.806 / 3.752 = 0.2148 °/s (z) | STM32F103 12-bit ADC at 3.3 V; LPR430AL 4× output 3.33 mV/(°/s), LY330ALH 3.752 mV/(°/s), both ±300 °/s full scale |
//! | sample-time jitter | sensors sampled at `t + δ`, δ ~ N(0, σ²) clamped to ±0.4 sample periods; the row's `t` and truth stay at the nominal time | σ = 1 ms | firmware timer/ISR latency and I²C read timing |
//! | repeated samples | with probability p a row repeats the previous row's gyro, accelerometer (and magnetometer) readings | p = 2 % | loggers that re-send the last reading when a new one is late |
//! | vibration | per axis, 6 tones with frequencies ~ U(20, 40 Hz) and random phases (fixed per seed), accelerometer `a·Σ sin`, gyro `w·Σ cos` (same tones), each sum of the given RMS; sampled at 50 Hz they alias to 10–25 Hz; truth does not include the µrad attitude vibration | 0.02 g and 0.1 °/s RMS per axis | thruster/pump vibration of a small ROV, brief's 0.02 g |
//!
//! Order per axis: gyro `quantise(M (ω + ω_vib) + b + b_rw + b_flicker + e_g)`, accelerometer
//! `quantise(s ⊙ (f + f_vib) + b_a + e_a)`, with `ω`, `f` at the sampling instant. The
//! thesis's z white-noise variance (0.065 °/s)² is close to the quantisation variance
//! Δ²/12 = (0.062 °/s)² of the z step: the realistic z noise (white plus quantisation) is
//! therefore about √2 times the measured, a conservative choice.
//!
//! # Truth
//! Either analytic, from an Euler-angle trajectory (angles, rates and angular accelerations of
//! each angle are analytic; `ω` and `ω̇` follow from the Z-Y-X kinematics; optionally with a
//! fixed sensor mounting, [`Attitude::Mounted`], or as a rotation about a fixed axis,
//! [`Attitude::AboutAxis`]), or integrated from body rates with RK4 on `q̇ = ½ q ⊗ (0, ω)` at
//! an internal step of at most 1 ms. Every scenario starts with yaw 0, level except
//! `side-mount` (roll 90°) and `pendulum` (pitch 90°).
//!
//! # Scenarios
//! Every scenario except `start-moving` is still for its first 10 s (the filters'
//! initialisation window); `t' = t − 10 s`. Timings are fixed; `--duration` only cuts or
//! extends the run.
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
//! | `tumble` | | through all attitudes (each body axis points up and down, pitch ±90°, upside down) by body rates from t = 10 s: p = 55 sin(2π·0.023 t') + 30 sin(2π·0.11 t'), q = 45 sin(2π·0.017 t') + 25 sin(2π·0.07 t'), r = 35 sin(2π·0.031 t') + 20 sin(2π·0.13 t') °/s (peaks ≈ 85, 70, 55 °/s), truth by RK4 | 200 s |
//! | `side-mount` | | the IMU mounted on the vehicle at 90° roll (sensor y = vehicle down, sensor z = vehicle port: the board's z axis stays horizontal); the vehicle does scenario 1's pitch and scenario 5's yaw sinusoids from t = 10 s; the lever arm is the Seahog's in sensor axes, (0.29725, 0.0803, 0.196) m | 200 s |
//! | `start-moving` | | no still start: pitch θ = 15° · sin(2π · 0.1 Hz · t) and yaw ψ = 5 °/s · t from t = 0 | 200 s |
//! | `pendulum` | | a rigid pendulum, IMU 0.5 m below the pivot with its x axis up the rod (pitch 90°), swinging about the NED x axis (body z); hanging still for 10 s, then phases of 53 s: lifted to 35°, −30°, 40° (cycled) over 2 s, held 1 s, released into a damped swing at √(g/L)/2π = 0.705 Hz with τ = 15 s decay, caught over the last 2 s of the 40 s swing, at rest 10 s. Specific force of the point on the rod: `−Rᵀg + ω̇ × r + ω × (ω × r)`, r = (−0.5, 0, 0) m from the pivot (the rotation centre, fixed): along the rod g cos α + L α̇², across it −g sin α − L α̈ | 200 s |
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

/// A sample rate from the environment variable `var` (the dev examples' `HANDHELD_RATE`,
/// `TRADEOFF_RATE`), Hz: `default` when it is not set, an error naming it when it is not a
/// finite rate of at least 1 Hz.
pub fn rate_from_env(var: &str, default: f64) -> Result<f64, String> {
    match std::env::var(var) {
        Ok(v) => v
            .parse::<f64>()
            .ok()
            .filter(|r| r.is_finite() && *r >= 1.0)
            .ok_or(format!("{var}={v}: not a sample rate in Hz (>= 1)")),
        Err(_) => Ok(default),
    }
}

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
    /// Zero before `start`, then `rate · (t − start)` without end.
    Linear {
        /// Start, s.
        start: f64,
        /// Slope, unit per second.
        rate: f64,
    },
    /// The sum of the profiles.
    Sum(&'static [Profile]),
    /// Hand-started pendulum swings, a phase every `lift + hold + swing + rest` seconds from
    /// `start` (zero before), phase `k` with amplitude `amps[k % 3]`: lifted from 0 to the
    /// amplitude `A` along a quintic smoothstep over `lift` s, held `hold` s, released from rest
    /// into the damped oscillation `A e^{−u/τ} (cos ωu + sin(ωu) / (ωτ))` (`u` from the
    /// release, `ω = 2π freq_hz`, `τ = decay_s`: zero rate at the release), caught over the
    /// last `catch` s of the `swing` s (multiplied by `1 − smoothstep`), then at rest (zero)
    /// for `rest` s. Value, rate and acceleration are continuous except the acceleration step
    /// at the release.
    Swings {
        /// Start of the first phase, s.
        start: f64,
        /// Amplitudes of successive phases (cycled).
        amps: [f64; 3],
        /// Swing frequency, Hz.
        freq_hz: f64,
        /// Amplitude decay time constant, s.
        decay_s: f64,
        /// Lift time, s.
        lift: f64,
        /// Hold time before the release, s.
        hold: f64,
        /// Swing time from the release, catch included, s.
        swing: f64,
        /// Catch time at the end of the swing, s (≤ `swing`).
        catch: f64,
        /// Rest time after the catch, s.
        rest: f64,
    },
}

/// Quintic smoothstep `S(x) = 6x⁵ − 15x⁴ + 10x³` on `[0, 1]` (clamped outside), with `S'`
/// and `S''` (zero at both ends).
fn smoothstep5(x: f64) -> (f64, f64, f64) {
    if x <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    if x >= 1.0 {
        return (1.0, 0.0, 0.0);
    }
    let x2 = x * x;
    let x3 = x2 * x;
    (
        x3 * (10.0 - 15.0 * x + 6.0 * x2),
        30.0 * x2 * (x - 1.0) * (x - 1.0),
        60.0 * x * (2.0 * x - 1.0) * (x - 1.0),
    )
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
            Profile::Linear { start, rate } => {
                if t < start {
                    (0.0, 0.0, 0.0)
                } else {
                    (rate * (t - start), rate, 0.0)
                }
            }
            Profile::Sum(ps) => ps.iter().fold((0.0, 0.0, 0.0), |acc, p| {
                let v = p.eval(t);
                (acc.0 + v.0, acc.1 + v.1, acc.2 + v.2)
            }),
            Profile::Swings { start, amps, freq_hz, decay_s, lift, hold, swing, catch, rest } => {
                if t < start {
                    return (0.0, 0.0, 0.0);
                }
                let period = lift + hold + swing + rest;
                let k = ((t - start) / period).floor();
                let a = amps[(k as u64 % 3) as usize];
                let u = t - start - k * period;
                if u < lift {
                    let (v, d, dd) = smoothstep5(u / lift);
                    return (a * v, a * d / lift, a * dd / (lift * lift));
                }
                if u < lift + hold {
                    return (a, 0.0, 0.0);
                }
                let u = u - lift - hold;
                if u >= swing {
                    return (0.0, 0.0, 0.0);
                }
                let (w, lam) = (std::f64::consts::TAU * freq_hz, 1.0 / decay_s);
                let e = (-lam * u).exp();
                let (sn, cs) = (w * u).sin_cos();
                let k2 = (w * w + lam * lam) / w;
                let s = e * (cs + lam / w * sn);
                let ds = -k2 * e * sn;
                let dds = -k2 * e * (w * cs - lam * sn);
                let (c, dc, ddc) = {
                    let (v, d, dd) = smoothstep5((u - (swing - catch)) / catch);
                    (1.0 - v, -d / catch, -dd / (catch * catch))
                };
                (a * c * s, a * (dc * s + c * ds), a * (ddc * s + 2.0 * dc * ds + c * dds))
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
    /// A sensor mounted on a vehicle at a fixed rotation: the vehicle follows the Z-Y-X Euler
    /// angles `vehicle` (rad), the sensor's attitude is `q_vehicle ⊗ mount` (`mount` rotates
    /// sensor vectors into vehicle axes); `ω` and `ω̇` are the vehicle's, in sensor axes.
    /// Analytic truth.
    Mounted {
        /// Vehicle roll, pitch, yaw, rad.
        vehicle: [Profile; 3],
        /// Sensor → vehicle rotation.
        mount: Q,
    },
    /// A rotation by `angle` (rad) about a fixed NED `axis` (unit) applied to `q0`:
    /// `q = axis_angle(axis, angle) ⊗ q0`, so `ω = R(q0)ᵀ axis · angle'` and
    /// `ω̇ = R(q0)ᵀ axis · angle''` (a pendulum swinging about its pivot). Analytic truth.
    AboutAxis {
        /// Rotation axis, NED, unit.
        axis: V3,
        /// Angle, rad.
        angle: Profile,
        /// Attitude at angle 0.
        q0: Q,
    },
}

/// A motion: attitude plus the linear acceleration of the rotation centre, given in body axes
/// (a vehicle's thrust), in NED (a motion whose position stays bounded in space: a hand, a
/// wave), or both (summed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trajectory {
    /// Attitude motion.
    pub attitude: Attitude,
    /// Linear acceleration of the rotation centre, m/s², body FRD (x surge, y sway, z heave).
    pub accel_body: [Profile; 3],
    /// Linear acceleration of the rotation centre, m/s², NED (added to `accel_body`). Sines
    /// here keep the position bounded whatever the attitude does; sines in `accel_body` on a
    /// turning body do not (the velocity wanders).
    pub accel_ned: [Profile; 3],
}

impl Trajectory {
    /// Still and level, yaw 0.
    pub const STILL: Trajectory = Trajectory {
        attitude: Attitude::Euler([Profile::Zero; 3]),
        accel_body: [Profile::Zero; 3],
        accel_ned: [Profile::Zero; 3],
    };

    /// The linear acceleration of the rotation centre at `t`, m/s², body FRD, with the body
    /// at attitude `q`: `accel_body` plus `accel_ned` turned into the body.
    pub fn accel_at(&self, q: Q, t: f64) -> V3 {
        let (b, n) = (self.accel_body, self.accel_ned);
        let ned = [n[0].eval(t).0, n[1].eval(t).0, n[2].eval(t).0];
        add([b[0].eval(t).0, b[1].eval(t).0, b[2].eval(t).0], rotate_inverse(q, ned))
    }

    /// An Euler-angle trajectory without linear acceleration.
    pub fn euler(roll: Profile, pitch: Profile, yaw: Profile) -> Self {
        Trajectory {
            attitude: Attitude::Euler([roll, pitch, yaw]),
            accel_body: [Profile::Zero; 3],
            accel_ned: [Profile::Zero; 3],
        }
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
    /// Realistic sensor errors beyond the filter's own model (`None`, the default: off, and
    /// traces are those of the plain model bit for bit). See [`Realism`].
    pub realism: Option<Realism>,
}

/// Allan-deviation floor of the flicker model per unit of each Gauss–Markov component's
/// stationary standard deviation (four components, τ = 1, 10, 100, 1000 s: the Allan
/// deviation is within ±5 % of 0.76 σ for averaging times of 3 s to 1000 s, by numerical
/// integration of the components' spectra, `σ_A²(T) = 2 ∫ S(f) sin⁴(πfT) / (πfT)² df` with
/// the one-sided `S(f) = Σ 4σ²τ / (1 + (2πfτ)²)`; 0.64 σ at 1 s).
pub const FLICKER_ADEV_PER_SIGMA: f64 = 0.76;

/// Realistic sensor errors of the iNEMO V2 (module docs, "Realism"): slow gyro bias
/// variation, fixed per-seed scale, cross-axis and offset errors, quantisation, sample-time
/// jitter, repeated samples and vibration. [`Default`] is the iNEMO V2; [`Realism::OFF`]
/// switches every effect off (useful to switch one on at a time). Every fixed error is drawn
/// once per seed; every random process has its own [`Rng`] stream.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Realism {
    /// Gyro bias random walk (rate random walk), °/s/√s per axis.
    pub gyro_rrw_dps_rt_s: V3,
    /// Gyro bias instability (flicker) per axis: Allan-deviation floor, °/s. Modelled as the
    /// sum of first-order Gauss–Markov processes with time constants
    /// [`Realism::flicker_taus_s`], each of stationary standard deviation
    /// `B /` [`FLICKER_ADEV_PER_SIGMA`], started from their stationary distribution.
    pub gyro_flicker_dps: V3,
    /// Time constants of the flicker components, s.
    pub flicker_taus_s: [f64; 4],
    /// Gyro scale-factor error bound: each axis's factor is `1 + u`, `u` uniform in ±this.
    pub gyro_scale: f64,
    /// Gyro cross-axis sensitivity / misalignment bound: each off-diagonal term of the
    /// sensitivity matrix is uniform in ±this.
    pub gyro_cross_axis: f64,
    /// Accelerometer bias (zero-g offset) bound, g: each axis uniform in ±this.
    pub accel_bias_g: f64,
    /// Accelerometer scale-factor error bound: each axis uniform in ±this.
    pub accel_scale: f64,
    /// Gyro quantisation step per axis, °/s (0: none): the ADC step over the sensitivity.
    pub gyro_lsb_dps: V3,
    /// Gyro full scale, °/s (readings clamp to ±this; 0: no clamp).
    pub gyro_full_scale_dps: f64,
    /// Accelerometer quantisation step, g (0: none).
    pub accel_lsb_g: f64,
    /// Accelerometer range, g: readings clamp to [−FS, FS − 1 LSB] (0: no clamp). The ±2 g
    /// setting's 12 bits at 1 mg/digit span ±2.048 g.
    pub accel_full_scale_g: f64,
    /// Standard deviation of the sampling instant around the recorded (nominal) time, s
    /// (clamped to ±0.4 sample periods so samples stay in order).
    pub jitter_s: f64,
    /// Probability that a row repeats the previous row's sensor readings.
    pub repeat_fraction: f64,
    /// Accelerometer vibration, g RMS per axis.
    pub vibration_accel_g: f64,
    /// Gyro vibration, °/s RMS per axis (the same tones as the accelerometer's axis).
    pub vibration_gyro_dps: f64,
    /// Vibration band, Hz: the tones' frequencies are uniform in it.
    pub vibration_band_hz: [f64; 2],
    /// Number of vibration tones per axis.
    pub vibration_tones: usize,
}

/// STM32F103 ADC step, V (3.3 V over 4096 codes).
pub const ADC_LSB_V: f64 = 3.3 / 4096.0;
/// LPR430AL sensitivity on the 4× outputs (x, y), V per °/s.
pub const LPR430AL_V_PER_DPS: f64 = 3.33e-3;
/// LY330ALH sensitivity (z), V per °/s.
pub const LY330ALH_V_PER_DPS: f64 = 3.752e-3;

impl Realism {
    /// Every effect off: with it the readings equal those of `realism: None` exactly.
    pub const OFF: Realism = Realism {
        gyro_rrw_dps_rt_s: [0.0; 3],
        gyro_flicker_dps: [0.0; 3],
        flicker_taus_s: [1.0, 10.0, 100.0, 1000.0],
        gyro_scale: 0.0,
        gyro_cross_axis: 0.0,
        accel_bias_g: 0.0,
        accel_scale: 0.0,
        gyro_lsb_dps: [0.0; 3],
        gyro_full_scale_dps: 0.0,
        accel_lsb_g: 0.0,
        accel_full_scale_g: 0.0,
        jitter_s: 0.0,
        repeat_fraction: 0.0,
        vibration_accel_g: 0.0,
        vibration_gyro_dps: 0.0,
        vibration_band_hz: [20.0, 40.0],
        vibration_tones: 6,
    };

    /// The iNEMO V2 (module docs, "Realism", for each value's source).
    pub const INEMO: Realism = Realism {
        gyro_rrw_dps_rt_s: [0.002, 0.002, 0.0005],
        gyro_flicker_dps: [0.005, 0.005, 0.005],
        flicker_taus_s: [1.0, 10.0, 100.0, 1000.0],
        gyro_scale: 0.02,
        gyro_cross_axis: 0.01,
        accel_bias_g: 0.003,
        accel_scale: 0.003,
        gyro_lsb_dps: [
            ADC_LSB_V / LPR430AL_V_PER_DPS,
            ADC_LSB_V / LPR430AL_V_PER_DPS,
            ADC_LSB_V / LY330ALH_V_PER_DPS,
        ],
        gyro_full_scale_dps: 300.0,
        accel_lsb_g: 0.001,
        accel_full_scale_g: 2.048,
        jitter_s: 1e-3,
        repeat_fraction: 0.02,
        vibration_accel_g: 0.02,
        vibration_gyro_dps: 0.1,
        vibration_band_hz: [20.0, 40.0],
        vibration_tones: 6,
    };

    /// One-line description for a trace header.
    pub fn describe(&self) -> String {
        let r = self.gyro_rrw_dps_rt_s;
        let f = self.gyro_flicker_dps;
        let q = self.gyro_lsb_dps;
        format!(
            "realism on: gyro bias random walk {} {} {} deg/s/sqrt(s), flicker (Allan floor) {} {} {} deg/s (Gauss-Markov tau {:?} s), gyro scale +-{} %, cross-axis +-{} %, accel bias +-{} mg, accel scale +-{} %, gyro step {:.4} {:.4} {:.4} deg/s, full scale +-{} deg/s, accel step {} mg, full scale +-{} g, sample jitter {} ms rms, repeated rows {} %, vibration {} g / {} deg/s rms per axis at {}-{} Hz",
            r[0],
            r[1],
            r[2],
            f[0],
            f[1],
            f[2],
            self.flicker_taus_s,
            self.gyro_scale * 100.0,
            self.gyro_cross_axis * 100.0,
            self.accel_bias_g * 1e3,
            self.accel_scale * 100.0,
            q[0],
            q[1],
            q[2],
            self.gyro_full_scale_dps,
            self.accel_lsb_g * 1e3,
            self.accel_full_scale_g,
            self.jitter_s * 1e3,
            self.repeat_fraction * 100.0,
            self.vibration_accel_g,
            self.vibration_gyro_dps,
            self.vibration_band_hz[0],
            self.vibration_band_hz[1]
        )
    }
}

impl Default for Realism {
    /// [`Realism::INEMO`].
    fn default() -> Self {
        Realism::INEMO
    }
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
            realism: None,
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
    /// The instant the sensors were sampled, s: `row.t` unless [`Realism::jitter_s`] is on.
    /// `q` is the truth at `row.t` (what the trace records); `omega`, `omega_dot`,
    /// `accel_body` and `accel_clean` are the true values at `t_sample`.
    pub t_sample: f64,
    /// The row repeats the previous row's sensor readings ([`Realism::repeat_fraction`]).
    pub repeated: bool,
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
    real: Option<Box<RealState>>,
}

/// Largest internal integration step, s.
pub const MAX_INTERNAL_STEP: f64 = 1e-3;

/// Random streams of the realistic errors (the white noise uses 1 gyro, 2 accelerometer,
/// 3 magnetometer).
const STREAM_FIXED: u64 = 4;
const STREAM_RRW: u64 = 5;
const STREAM_FLICKER: u64 = 6;
const STREAM_JITTER: u64 = 7;
const STREAM_REPEAT: u64 = 8;
const STREAM_VIBRATION: u64 = 9;

/// State of the realistic errors of one simulation.
struct RealState {
    p: Realism,
    /// Nominal sample period, s.
    dt: f64,
    /// Gyro sensitivity matrix `I + scale + cross-axis`.
    gyro_m: [[f64; 3]; 3],
    /// Accelerometer scale factors `1 + u`.
    accel_scale: V3,
    /// Accelerometer bias, m/s².
    accel_bias: V3,
    /// Gyro bias random walk, rad/s.
    rrw: V3,
    rrw_step: V3,
    rrw_rng: Rng,
    /// Flicker Gauss–Markov states, rad/s, per axis and component.
    gm: [[f64; 4]; 3],
    gm_phi: [f64; 4],
    gm_drive: [[f64; 4]; 3],
    gm_rng: Rng,
    jitter_rng: Rng,
    repeat_rng: Rng,
    /// Vibration tones per axis: (frequency Hz, phase rad).
    tones: [Vec<(f64, f64)>; 3],
    /// Previous row's readings.
    prev: Option<Readings>,
}

/// One row's sensor readings: gyro, accelerometer, magnetometer.
type Readings = ([f32; 3], [f32; 3], Option<[f32; 3]>);

impl RealState {
    fn new(p: Realism, cfg: &SimConfig) -> Self {
        let dt = 1.0 / cfg.rate_hz;
        let mut fixed = Rng::new(cfg.seed, STREAM_FIXED);
        let mut sym = |bound: f64| bound * (2.0 * fixed.uniform() - 1.0);
        let mut gyro_m = [[0.0; 3]; 3];
        for (i, row) in gyro_m.iter_mut().enumerate() {
            row[i] = 1.0 + sym(p.gyro_scale);
        }
        for (i, j) in [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)] {
            gyro_m[i][j] = sym(p.gyro_cross_axis);
        }
        let g = cfg.sensors.gravity;
        let accel_bias = [0; 3].map(|_| sym(p.accel_bias_g) * g);
        let accel_scale = [0; 3].map(|_| 1.0 + sym(p.accel_scale));
        let gm_phi = p.flicker_taus_s.map(|tau| (-dt / tau).exp());
        let sigma = p.gyro_flicker_dps.map(|b| b * DEG / FLICKER_ADEV_PER_SIGMA);
        let mut gm_rng = Rng::new(cfg.seed, STREAM_FLICKER);
        let mut gm = [[0.0; 4]; 3];
        let mut gm_drive = [[0.0; 4]; 3];
        for i in 0..3 {
            for c in 0..4 {
                gm[i][c] = sigma[i] * gm_rng.normal();
                gm_drive[i][c] = sigma[i] * (1.0 - gm_phi[c] * gm_phi[c]).sqrt();
            }
        }
        let mut vib = Rng::new(cfg.seed, STREAM_VIBRATION);
        let [lo, hi] = p.vibration_band_hz;
        let tones = [0; 3].map(|_| {
            (0..p.vibration_tones)
                .map(|_| {
                    let f = lo + (hi - lo) * vib.uniform();
                    (f, std::f64::consts::TAU * vib.uniform())
                })
                .collect()
        });
        RealState {
            p,
            dt,
            gyro_m,
            accel_scale,
            accel_bias,
            rrw: [0.0; 3],
            rrw_step: p.gyro_rrw_dps_rt_s.map(|k| k * DEG * dt.sqrt()),
            rrw_rng: Rng::new(cfg.seed, STREAM_RRW),
            gm,
            gm_phi,
            gm_drive,
            gm_rng,
            jitter_rng: Rng::new(cfg.seed, STREAM_JITTER),
            repeat_rng: Rng::new(cfg.seed, STREAM_REPEAT),
            tones,
            prev: None,
        }
    }

    /// Sampling-time offset of the next row, s.
    fn jitter(&mut self) -> f64 {
        let lim = 0.4 * self.dt;
        (self.p.jitter_s * self.jitter_rng.normal()).clamp(-lim, lim)
    }

    /// Vibration at `t`: (specific force, m/s²; rate, rad/s), body.
    fn vibration(&self, t: f64, gravity: f64) -> (V3, V3) {
        let n = self.p.vibration_tones.max(1) as f64;
        let aa = self.p.vibration_accel_g * gravity * (2.0 / n).sqrt();
        let ag = self.p.vibration_gyro_dps * DEG * (2.0 / n).sqrt();
        let mut a = [0.0; 3];
        let mut w = [0.0; 3];
        for i in 0..3 {
            for &(f, ph) in &self.tones[i] {
                let (sn, cs) = (std::f64::consts::TAU * f * t + ph).sin_cos();
                a[i] += aa * sn;
                w[i] += ag * cs;
            }
        }
        (a, w)
    }

    /// Slow gyro bias (random walk plus flicker) of the current row, rad/s.
    fn slow_bias(&self, i: usize) -> f64 {
        self.rrw[i] + self.gm[i].iter().sum::<f64>()
    }

    /// Advance the slow bias processes by one sample.
    fn advance(&mut self) {
        for i in 0..3 {
            self.rrw[i] += self.rrw_step[i] * self.rrw_rng.normal();
        }
        for i in 0..3 {
            for c in 0..4 {
                self.gm[i][c] =
                    self.gm_phi[c] * self.gm[i][c] + self.gm_drive[i][c] * self.gm_rng.normal();
            }
        }
    }
}

/// Round `v` to a multiple of `step` (none when `step` is 0), then clamp to `[lo, hi]` (none
/// when `hi` is 0).
fn quantise(v: f64, step: f64, lo: f64, hi: f64) -> f64 {
    let q = if step > 0.0 { (v / step).round() * step } else { v };
    if hi > 0.0 {
        q.clamp(lo, hi)
    } else {
        q
    }
}

impl Simulator {
    /// A simulation of `traj` with `cfg`.
    pub fn new(traj: Trajectory, cfg: SimConfig) -> Self {
        let n = (cfg.duration_s * cfg.rate_hz).round().max(0.0) as u64;
        let q0 = match traj.attitude {
            Attitude::BodyRates { q0, .. } => qnormalize(q0),
            // (Unused: the other attitudes are analytic.)
            Attitude::Euler(_) | Attitude::Mounted { .. } | Attitude::AboutAxis { .. } => {
                [1.0, 0.0, 0.0, 0.0]
            }
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
            real: cfg.sensors.realism.map(|p| Box::new(RealState::new(p, &cfg))),
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

    /// True body rate at `t`, rad/s, without moving the body-rate integrator.
    fn rate_at(&self, t: f64) -> V3 {
        let euler = |p: &[Profile; 3]| {
            let (a, b, c) = (p[0].eval(t), p[1].eval(t), p[2].eval(t));
            euler_rates_to_body([a.0, b.0, c.0], [a.1, b.1, c.1], [a.2, b.2, c.2]).0
        };
        match self.traj.attitude {
            Attitude::Euler(p) => euler(&p),
            Attitude::Mounted { vehicle: p, mount } => rotate_inverse(mount, euler(&p)),
            Attitude::AboutAxis { axis, angle, q0 } => {
                rotate_inverse(q0, axis).map(|c| c * angle.eval(t).1)
            }
            Attitude::BodyRates { rates, .. } => Self::rates(&rates, t),
        }
    }

    /// The gyro's reading of the trajectory: the mean body rate over the sample period that
    /// ends at `t`, rad/s, as the firmware averages the ADC's frames over each filter period
    /// (Simpson's rule on 4 panels; the period's start is clamped at 0).
    fn mean_rate(&self, t: f64) -> V3 {
        let t0 = (t - 1.0 / self.cfg.rate_hz).max(0.0);
        if t <= t0 {
            return self.rate_at(t);
        }
        let h = (t - t0) / 4.0;
        let mut sum = [0.0; 3];
        for (i, w) in [1.0, 4.0, 2.0, 4.0, 1.0].into_iter().enumerate() {
            let r = self.rate_at(t0 + i as f64 * h);
            for c in 0..3 {
                sum[c] += w * r[c] / 12.0;
            }
        }
        sum
    }

    /// Truth at `t`: attitude, ω, ω̇. Body-rate trajectories integrate forward from the last
    /// call (calls must come in increasing time).
    /// The magnetometer's reading at attitude `q` (the field in body axes plus its noise), when
    /// it is simulated.
    fn mag_sample(&mut self, q: Q) -> Option<[f32; 3]> {
        let s = self.cfg.sensors;
        if !s.mag {
            return None;
        }
        let m = rotate_inverse(q, s.mag_field_ned);
        Some([0, 1, 2].map(|i| (m[i] + s.mag_noise_ut * self.mag_rng.normal()) as f32))
    }

    fn truth(&mut self, t: f64) -> (Q, V3, V3) {
        match self.traj.attitude {
            Attitude::Euler(p) => {
                let (a, b, c) = (p[0].eval(t), p[1].eval(t), p[2].eval(t));
                let (w, dw) =
                    euler_rates_to_body([a.0, b.0, c.0], [a.1, b.1, c.1], [a.2, b.2, c.2]);
                (euler_to_q(a.0, b.0, c.0), w, dw)
            }
            Attitude::Mounted { vehicle: p, mount } => {
                let (a, b, c) = (p[0].eval(t), p[1].eval(t), p[2].eval(t));
                let (w, dw) =
                    euler_rates_to_body([a.0, b.0, c.0], [a.1, b.1, c.1], [a.2, b.2, c.2]);
                let q = qnormalize(qmul(euler_to_q(a.0, b.0, c.0), mount));
                (q, rotate_inverse(mount, w), rotate_inverse(mount, dw))
            }
            Attitude::AboutAxis { axis, angle, q0 } => {
                let (a, da, dda) = angle.eval(t);
                let q = qnormalize(qmul(axis_angle(axis, a), q0));
                let ax = rotate_inverse(q0, axis);
                (q, ax.map(|c| c * da), ax.map(|c| c * dda))
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
        if self.real.is_some() {
            return Some(self.next_realistic(t));
        }
        let s = self.cfg.sensors;
        let (q, omega, omega_dot) = self.truth(t);
        let accel_body = self.traj.accel_at(q, t);
        let accel_clean = s.accel_clean(q, omega, omega_dot, accel_body);

        let mean = self.mean_rate(t);
        let mut gyro = [0f32; 3];
        for i in 0..3 {
            let v = mean[i] + s.gyro_bias[i] + self.gyro_std[i] * self.gyro_rng.normal();
            gyro[i] = v as f32;
        }
        let mut accel = [0f32; 3];
        for i in 0..3 {
            accel[i] = (accel_clean[i] + self.accel_std * self.accel_rng.normal()) as f32;
        }
        let mag = self.mag_sample(q);
        let row = sim_row(t, gyro, accel, mag, q);
        Some(SimSample {
            row,
            q,
            omega,
            omega_dot,
            accel_body,
            accel_clean,
            t_sample: t,
            repeated: false,
        })
    }
}

impl Simulator {
    /// The sample at nominal time `t` with [`SensorModel::realism`] on. The white noise is
    /// drawn exactly as without realism (so [`Realism::OFF`] gives the same readings).
    fn next_realistic(&mut self, t: f64) -> SimSample {
        let s = self.cfg.sensors;
        let mut r = self.real.take().expect("realism state");
        // Sampling instant; truth at both instants, in increasing time (the body-rate
        // integrator only moves forward).
        let t_s = (t + r.jitter()).max(0.0);
        let (q, (q_s, omega, omega_dot)) = if t_s < t {
            let at_s = self.truth(t_s);
            (self.truth(t).0, at_s)
        } else if t_s > t {
            let q = self.truth(t).0;
            (q, self.truth(t_s))
        } else {
            let at = self.truth(t);
            (at.0, at)
        };
        let accel_body = self.traj.accel_at(q_s, t_s);
        let accel_clean = s.accel_clean(q_s, omega, omega_dot, accel_body);
        let p = r.p;
        let (vib_a, vib_w) = r.vibration(t_s, s.gravity);

        let w_in = add(self.mean_rate(t_s), vib_w);
        let mut gyro = [0f32; 3];
        let fs_w = p.gyro_full_scale_dps * DEG;
        for (i, m) in r.gyro_m.iter().enumerate() {
            let w_s = m[0] * w_in[0] + m[1] * w_in[1] + m[2] * w_in[2];
            let v =
                w_s + s.gyro_bias[i] + r.slow_bias(i) + self.gyro_std[i] * self.gyro_rng.normal();
            gyro[i] = quantise(v, p.gyro_lsb_dps[i] * DEG, -fs_w, fs_w) as f32;
        }
        let f_in = add(accel_clean, vib_a);
        let mut accel = [0f32; 3];
        let step = p.accel_lsb_g * s.gravity;
        let fs_a = p.accel_full_scale_g * s.gravity;
        for i in 0..3 {
            let v = r.accel_scale[i] * f_in[i]
                + r.accel_bias[i]
                + self.accel_std * self.accel_rng.normal();
            accel[i] = quantise(v, step, -fs_a, fs_a - step) as f32;
        }
        let mag = self.mag_sample(q_s);
        r.advance();
        let repeat_draw = r.repeat_rng.uniform();
        let (gyro, accel, mag, repeated) = match r.prev {
            Some((g, a, m)) if repeat_draw <= p.repeat_fraction && p.repeat_fraction > 0.0 => {
                (g, a, m, true)
            }
            _ => (gyro, accel, mag, false),
        };
        r.prev = Some((gyro, accel, mag));
        self.real = Some(r);
        let row = sim_row(t, gyro, accel, mag, q);
        SimSample { row, q, omega, omega_dot, accel_body, accel_clean, t_sample: t_s, repeated }
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
    /// Rotation through all attitudes (pitch ±90°, upside down) by smooth body rates.
    Tumble,
    /// The IMU mounted on its side (90° roll on the vehicle) through scenario 1's pitch and
    /// scenario 5's yaw sinusoids.
    SideMount,
    /// Moving from the first sample: pitch sinusoid plus a constant turn, no still start.
    StartMoving,
    /// The IMU on a swinging rigid pendulum, x axis up along the rod.
    Pendulum,
}

/// Pendulum length: pivot to IMU, m (`pendulum`).
pub const PENDULUM_LENGTH_M: f64 = 0.5;

/// Tumble body rates (`tumble`), rad/s: sums of sinusoids from the end of the still start
/// (phase 0, so each rate starts from zero). Amplitudes °/s, frequencies Hz.
const TUMBLE_P: [Profile; 2] = [
    Profile::Sine { start: STILL_S, amp: 55.0 * DEG, freq_hz: 0.023, phase: 0.0 },
    Profile::Sine { start: STILL_S, amp: 30.0 * DEG, freq_hz: 0.11, phase: 0.0 },
];
const TUMBLE_Q: [Profile; 2] = [
    Profile::Sine { start: STILL_S, amp: 45.0 * DEG, freq_hz: 0.017, phase: 0.0 },
    Profile::Sine { start: STILL_S, amp: 25.0 * DEG, freq_hz: 0.07, phase: 0.0 },
];
const TUMBLE_R: [Profile; 2] = [
    Profile::Sine { start: STILL_S, amp: 35.0 * DEG, freq_hz: 0.031, phase: 0.0 },
    Profile::Sine { start: STILL_S, amp: 20.0 * DEG, freq_hz: 0.13, phase: 0.0 },
];

impl Scenario {
    /// Every scenario, in order.
    pub const ALL: [Scenario; 15] = [
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
        Scenario::Tumble,
        Scenario::SideMount,
        Scenario::StartMoving,
        Scenario::Pendulum,
    ];

    /// The sensor → vehicle rotation of `side-mount`: 90° about the vehicle's x axis (the
    /// board's y axis points down, its z axis to port).
    pub fn side_mount() -> Q {
        axis_angle([1.0, 0.0, 0.0], 90.0 * DEG)
    }

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
            Scenario::Tumble => "tumble",
            Scenario::SideMount => "side-mount",
            Scenario::StartMoving => "start-moving",
            Scenario::Pendulum => "pendulum",
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
                    accel_ned: [Profile::Zero; 3],
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
            Scenario::Tumble => Trajectory {
                attitude: Attitude::BodyRates {
                    rates: [
                        Profile::Sum(&TUMBLE_P),
                        Profile::Sum(&TUMBLE_Q),
                        Profile::Sum(&TUMBLE_R),
                    ],
                    q0: [1.0, 0.0, 0.0, 0.0],
                },
                accel_body: [Profile::Zero; 3],
                accel_ned: [Profile::Zero; 3],
            },
            Scenario::SideMount => Trajectory {
                attitude: Attitude::Mounted {
                    vehicle: [
                        Profile::Zero,
                        Profile::Sine { start: STILL_S, amp: 10.0 * DEG, freq_hz: 0.1, phase: 0.0 },
                        Profile::Sine {
                            start: STILL_S,
                            amp: 30.0 * DEG,
                            freq_hz: 0.05,
                            phase: 0.0,
                        },
                    ],
                    mount: Scenario::side_mount(),
                },
                accel_body: [Profile::Zero; 3],
                accel_ned: [Profile::Zero; 3],
            },
            Scenario::StartMoving => Trajectory::euler(
                Profile::Zero,
                Profile::Sine { start: 0.0, amp: 15.0 * DEG, freq_hz: 0.1, phase: 0.0 },
                Profile::Linear { start: 0.0, rate: 5.0 * DEG },
            ),
            Scenario::Pendulum => Trajectory {
                // Swinging about the NED x axis through the pivot; at rest the rod hangs
                // down with the IMU's x axis pointing up along it (pitch 90°).
                attitude: Attitude::AboutAxis {
                    axis: [1.0, 0.0, 0.0],
                    angle: Profile::Swings {
                        start: STILL_S,
                        amps: [35.0 * DEG, -30.0 * DEG, 40.0 * DEG],
                        freq_hz: (G0 / PENDULUM_LENGTH_M).sqrt() / std::f64::consts::TAU,
                        decay_s: 15.0,
                        lift: 2.0,
                        hold: 1.0,
                        swing: 40.0,
                        catch: 2.0,
                        rest: 10.0,
                    },
                    q0: euler_to_q(0.0, 90.0 * DEG, 0.0),
                },
                // The pivot is the rotation centre and does not move.
                accel_body: [Profile::Zero; 3],
                accel_ned: [Profile::Zero; 3],
            },
        }
    }

    /// The sensor model (the default, with this scenario's changes).
    pub fn sensors(self) -> SensorModel {
        let mut s = SensorModel::default();
        match self {
            Scenario::GyroNoise => s.gyro_var = s.gyro_var.map(|v| v * 10.0),
            Scenario::AccelNoise => s.accel_var_g2 *= 10.0,
            Scenario::BiasOff => s.gyro_bias[2] += BIAS_OFF_DPS * DEG,
            // The Seahog's lever arm in the side-mounted sensor's axes.
            Scenario::SideMount => {
                s.lever_arm = rotate_inverse(Scenario::side_mount(), s.lever_arm)
            }
            // The pivot is `L` up the rod, along the IMU's +x: the IMU is at −L x from it.
            Scenario::Pendulum => s.lever_arm = [-PENDULUM_LENGTH_M, 0.0, 0.0],
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
            Scenario::Tumble => c.push(
                "tumble: body rates are sums of sinusoids from t = 10 s (through pitch +-90 deg \
                 and upside down)"
                    .into(),
            ),
            Scenario::SideMount => {
                let r = cfg.sensors.lever_arm;
                c.push(format!(
                    "side-mount: IMU mounted at 90 deg roll on the vehicle (board z horizontal); \
                     lever arm in sensor axes (m): {} {} {}",
                    r[0], r[1], r[2]
                ))
            }
            Scenario::StartMoving => c.push(
                "start-moving: no still start (pitch 15 deg sine at 0.1 Hz and a 5 deg/s turn \
                 from t = 0)"
                    .into(),
            ),
            Scenario::Pendulum => c.push(format!(
                "pendulum: IMU {PENDULUM_LENGTH_M} m below the pivot, x axis up the rod; \
                 lever arm from the pivot (m): {} 0 0",
                -PENDULUM_LENGTH_M
            )),
            _ => {}
        }
        if let Some(r) = cfg.sensors.realism {
            c.push(r.describe());
        }
        c
    }

    /// The simulator for this scenario with `rate_hz`, `duration_s` (default when `None`) and
    /// `seed`, without the realistic errors (see [`Scenario::simulator_with`]).
    pub fn simulator(
        self,
        rate_hz: f64,
        duration_s: Option<f64>,
        seed: u64,
        mag: bool,
    ) -> (Simulator, SimConfig) {
        self.simulator_with(&SimOptions { rate_hz, duration_s, seed, mag, realistic: false })
    }

    /// The simulator for this scenario with `opts`; `opts.realistic` switches on the
    /// realistic sensor errors with the iNEMO values ([`Realism::INEMO`]).
    pub fn simulator_with(self, opts: &SimOptions) -> (Simulator, SimConfig) {
        let mut sensors = self.sensors();
        sensors.mag = opts.mag;
        if opts.realistic {
            sensors.realism = Some(Realism::INEMO);
        }
        let cfg = SimConfig {
            rate_hz: opts.rate_hz,
            duration_s: opts.duration_s.unwrap_or(self.default_duration()),
            seed: opts.seed,
            sensors,
        };
        (Simulator::new(self.trajectory(), cfg), cfg)
    }
}

/// Options of [`Scenario::simulator_with`] (the `simulate` command's flags).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimOptions {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Duration, s (`None`: the scenario's default).
    pub duration_s: Option<f64>,
    /// Noise seed.
    pub seed: u64,
    /// Simulate the magnetometer.
    pub mag: bool,
    /// Add the realistic sensor errors ([`Realism::INEMO`]).
    pub realistic: bool,
}

impl Default for SimOptions {
    /// 50 Hz, the scenario's duration, seed 1, no magnetometer, no realistic errors.
    fn default() -> Self {
        SimOptions { rate_hz: 50.0, duration_s: None, seed: 1, mag: false, realistic: false }
    }
}

/// A simulated trace row: the samples and the truth, nothing else.
fn sim_row(t: f64, gyro: [f32; 3], accel: [f32; 3], mag: Option<[f32; 3]>, q: Q) -> TraceRow {
    TraceRow { t, gyro, accel, mag, depth: None, truth: Some(q.map(|c| c as f32)), movement: None }
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
    fn new_profiles_match_hand_values_and_finite_differences() {
        let lin = Profile::Linear { start: 2.0, rate: 0.5 };
        assert_eq!(lin.eval(1.0), (0.0, 0.0, 0.0));
        assert_eq!(lin.eval(2.0), (0.0, 0.5, 0.0));
        assert_eq!(lin.eval(6.0), (2.0, 0.5, 0.0));
        static TERMS: [Profile; 2] =
            [Profile::Const(1.5), Profile::Linear { start: 0.0, rate: 2.0 }];
        assert_eq!(Profile::Sum(&TERMS).eval(3.0), (7.5, 2.0, 0.0));
        let sw = Profile::Swings {
            start: 1.0,
            amps: [0.6, -0.5, 0.7],
            freq_hz: 0.7,
            decay_s: 15.0,
            lift: 2.0,
            hold: 1.0,
            swing: 40.0,
            catch: 2.0,
            rest: 10.0,
        };
        // Before, lifted, held, released from rest, caught, at rest, next phase's amplitude.
        assert_eq!(sw.eval(0.5), (0.0, 0.0, 0.0));
        assert!((sw.eval(2.0).0 - 0.3).abs() < 1e-12);
        assert_eq!(sw.eval(3.5), (0.6, 0.0, 0.0));
        let r = sw.eval(4.0);
        assert!((r.0 - 0.6).abs() < 1e-12 && r.1.abs() < 1e-12);
        let w = std::f64::consts::TAU * 0.7;
        assert!((r.2 + 0.6 * (w * w + 1.0 / 225.0)).abs() < 1e-9, "{r:?}");
        assert_eq!(sw.eval(44.0), (0.0, 0.0, 0.0));
        assert_eq!(sw.eval(56.5), (-0.5, 0.0, 0.0));
        // Amplitude decays by e^(−u/τ): whole periods after the release, u = 10/0.7 s.
        let u = 10.0 / 0.7;
        assert!((sw.eval(4.0 + u).0 - 0.6 * (-u / 15.0).exp()).abs() < 1e-9);
        // Derivatives by finite differences everywhere but at the release (t = 4, 57).
        let h = 1e-6;
        for p in [sw, lin] {
            for k in 0..4000 {
                let t = 0.013 + k as f64 * 0.027;
                if (t - 4.0).abs() < 1e-3 || (t - 57.0).abs() < 1e-3 {
                    continue;
                }
                let (_, d0, dd0) = p.eval(t);
                let (vp, dp, _) = p.eval(t + h);
                let (vm, dm, _) = p.eval(t - h);
                assert!(((vp - vm) / (2.0 * h) - d0).abs() < 1e-5 * (1.0 + d0.abs()), "{t}");
                assert!(((dp - dm) / (2.0 * h) - dd0).abs() < 1e-4 * (1.0 + dd0.abs()), "{t}");
            }
        }
        // Continuous value and rate at the phase boundaries.
        for t in [1.0, 3.0, 4.0, 42.0, 44.0, 54.0] {
            let (a, b) = (sw.eval(t - 1e-9), sw.eval(t + 1e-9));
            assert!((a.0 - b.0).abs() < 1e-8 && (a.1 - b.1).abs() < 1e-7, "{t}");
        }
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
