//! The main estimator: a quaternion EKF with gyro-bias states, accelerometer tilt correction
//! with yaw-split, rest detection (bias re-estimation and yaw hold), constant-rate yaw drift
//! compensation, the accelerometer gate, and an optional magnetometer heading update.
//!
//! State: unit quaternion `q` (body FRD → NED) and gyro bias `b` (rad/s, body) — the source's
//! seven-state model — estimated in error-state (multiplicative) form: the covariance is kept
//! over the six-dimensional error `δx = (δθ, δb)` with the attitude error in the NED frame,
//! `q_true = Exp(δθ) ⊗ q̂`. In that frame gravity is blind to `δθ_z`, the accelerometer
//! measures exactly `(δθ_x, δθ_y)` after projection, and yaw-split is a gain restriction.
//! See `docs/filter.md` for the equations and the operation count.

use crate::{
    covariance::{Cov6, ProcessNoise, TiltInnovation, YawRow},
    fcmp,
    filter::AttitudeFilter,
    gate::{AccelGate, PreCheck},
    init::{self, InitStep, Initializer},
    mathf,
    quaternion::Mat3,
    rest::{RestBlock, RestDetector},
    settings::Settings,
    validate::{self, Checked},
    Euler, Flags, ImuSample, Quaternion, Vec3,
};

/// Largest attitude-error variance before the health check resets the covariance, rad².
const MAX_ATT_VAR: f32 = 10.0;
/// Largest bias-error variance before the health check resets the covariance, (rad/s)².
const MAX_BIAS_VAR: f32 = 1.0;

/// A knock is an accelerometer jump larger than `gate.jump_g` plus this many standard
/// deviations of the current motion level.
pub const KNOCK_SIGMAS: f32 = 3.0;

/// Normalised innovation squared (2 degrees of freedom) beyond which the bias learns from the
/// accelerometer in proportion `ROBUST_NIS / NIS` (a Huber-type weight on the bias only): the
/// median of χ²₂ is 1.4, so consistent samples are untouched.
const ROBUST_NIS: f32 = 2.0;

/// At the onset of motion (a deviation of the specific force beyond [`KNOCK_SIGMAS`] standard
/// deviations of the current motion level) the motion level is averaged this many times
/// faster.
const ONSET_SPEEDUP: f32 = 10.0;

/// How far, in units in the last place of its bits, `dt` may move before what depends on the
/// sample rate (the accelerometer's per-sample variance, the motion level's weights, the
/// vibration low-pass's weight) is recomputed: 2¹⁵ of the 2²³ steps of a power of two, a
/// relative change of 0.2–0.4 %. The firmware measures `dt` from the cycle counter, so it
/// jitters by a few cycles in every sample; those quantities change by as little, and they are
/// not recomputed (a division among them) every sample.
const VAR_DT_ULPS: u32 = 1 << 15;

/// The interval over which the norm's change counts as vibration, s. Vibration is measured as
/// what the norm does within it (above about 16 Hz), motion as the rest. Up to 100 Hz that is
/// the change from one sample to the next; at a higher rate the change from a low-pass of the
/// norm with this time constant, so that a vibration which a fast sampler resolves (20–40 Hz
/// turns by only 36–72° per sample at 200 Hz) is still taken for vibration.
const VIB_STEP_S: f32 = 0.01;

/// Longest knock, s: rejections that last longer raise the motion level.
pub const KNOCK_MAX_S: f32 = 0.2;

/// Cycles between full covariance health checks (the Cauchy–Schwarz bounds of every
/// off-diagonal element: 15 products); once a second at 50 Hz.
pub const FULL_HEALTH_CHECK_EVERY: u32 = 50;

/// The quaternion EKF. See the module documentation.
#[derive(Clone, Debug)]
pub struct Ekf {
    settings: Settings,
    q: Quaternion,
    bias: Vec3,
    p: Cov6,
    init: Option<Initializer>,
    gate: AccelGate,
    rest: RestDetector,
    /// Attitude at the start of the current rest block.
    block_q: Quaternion,
    /// Yaw integrated over still blocks not yet confirmed as rest, rad.
    pending_yaw: f32,
    /// Yaw moved by the magnetometer during the current block, rad.
    external_yaw: f32,
    last_flags: Flags,
    /// Cycles since start (wrapping), for the periodic full health check.
    cycle: u32,
    /// Process noise densities, from the settings.
    noise: ProcessNoise,
    /// Variance of one tilt measurement component, rad²: `noise.accel_var · accel_var_scale`
    /// per sample at `noise.accel_ref_rate`, scaled to the sample rate (constant noise
    /// density), for the `dt` whose bits are `rate_dt`.
    accel_var: f32,
    /// The bits of the `dt` for which `accel_var`, `accel_var3`, `scatter_var`, `vib_alpha` and
    /// `motion_w` were last computed (0: not yet); they are recomputed when `dt` moves by more
    /// than [`VAR_DT_ULPS`].
    rate_dt: u32,
    /// Started in motion, and the bias is not yet as certain as a still window makes it.
    moving_start: bool,
    /// Motion level: mean squared deviation of the NED specific force from its low-pass, g².
    motion_var: f32,
    /// Low-passed horizontal specific force (north, east) in the estimate's NED frame, g: the
    /// second stage's output (the measurement).
    accel_h: [f32; 2],
    /// The low-pass's first stage, g (same frame).
    accel_h1: [f32; 2],
    /// The deviation of the specific force's norm from 1 g, g: the previous sample's, or at
    /// rates above 1/[`VIB_STEP_S`] its low-pass over `VIB_STEP_S`.
    norm_prev: f32,
    /// The weight of one sample in that low-pass, `min(dt / VIB_STEP_S, 1)` (1: the previous
    /// sample itself).
    vib_alpha: f32,
    /// Mean square of the norm's change from one sample to the next (above 1/[`VIB_STEP_S`],
    /// from `norm_prev`'s low-pass, scaled), g² (over `motion_time_constant`): for vibration
    /// and noise, whose samples are independent, twice their variance along one axis, i.e.
    /// their variance in the two horizontal axes together.
    step_var: f32,
    /// `vib_rate²`, (rad/s)², and `vib_time_constant · vib_rate²`, (rad/s)²·s.
    vib_rate2: (f32, f32),
    /// The previous sample's bias-corrected rate, rad/s (`None` when it was invalid).
    prev_rate: Option<Vec3>,
    /// `1 / motion_time_constant`, 1/s.
    inv_motion_tau: f32,
    /// `3·accel_var`: the motion level of the datasheet noise alone, g².
    accel_var3: f32,
    /// The variance of one sample per axis, as a multiple of the motion level, with which the
    /// bias learns in motion: 1/3 at `noise.accel_ref_rate`, scaled to the sample rate as
    /// `accel_var` is (motion's samples are alike from one to the next: sampled faster, they
    /// carry no more information per second).
    scatter_var: f32,
    /// The motion-average weight of one sample, `min(dt/τ, 1)`, and the onset weight
    /// `min(ONSET_SPEEDUP·dt/τ, 1)`, for the `dt` of `rate_dt`.
    motion_w: (f32, f32),
}

impl Ekf {
    /// A new filter, starting its initialisation window.
    pub fn new(settings: Settings) -> Self {
        Ekf {
            settings,
            q: Quaternion::from_yaw(settings.init.initial_yaw),
            bias: settings.init.gyro_bias,
            p: Self::initial_cov(&settings),
            init: Some(Initializer::new(&settings)),
            gate: AccelGate::new(settings.gate),
            rest: RestDetector::new(settings.rest),
            block_q: Quaternion::IDENTITY,
            pending_yaw: 0.0,
            external_yaw: 0.0,
            last_flags: Flags::INITIALISING,
            cycle: 0,
            noise: {
                let psd = settings.noise.gyro_psd();
                ProcessNoise {
                    gyro_psd_xy: 0.5 * (psd.x + psd.y),
                    gyro_psd_z: psd.z,
                    bias_random_walk: settings.ekf.bias_random_walk,
                }
            },
            accel_var: settings.noise.accel_var * settings.ekf.accel_var_scale,
            rate_dt: 0,
            moving_start: false,
            motion_var: 0.0,
            accel_h: [0.0; 2],
            accel_h1: [0.0; 2],
            norm_prev: 0.0,
            vib_alpha: 1.0,
            step_var: 0.0,
            vib_rate2: {
                let w2 = settings.ekf.vib_rate * settings.ekf.vib_rate;
                (w2, settings.ekf.vib_time_constant * w2)
            },
            prev_rate: None,
            inv_motion_tau: 1.0 / settings.ekf.motion_time_constant.max(1e-3),
            accel_var3: 3.0 * settings.noise.accel_var * settings.ekf.accel_var_scale,
            scatter_var: 1.0 / 3.0,
            motion_w: (0.0, 0.0),
        }
    }

    /// The settings in use.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Error covariance (rows 0–2 attitude error in NED, rad²; 3–5 gyro bias, (rad/s)²). With
    /// yaw-split on and no magnetometer nothing observes yaw, and row and column 2 are not
    /// propagated: they keep their initial values (`covariance::YawRow`).
    pub fn covariance(&self) -> &Cov6 {
        &self.p
    }

    /// Flags of the last update.
    pub fn last_flags(&self) -> Flags {
        self.last_flags
    }

    /// True while rest is declared.
    pub fn at_rest(&self) -> bool {
        self.rest.at_rest()
    }

    #[cold]
    #[inline(never)]
    fn initial_cov(s: &Settings) -> Cov6 {
        let t = s.ekf.initial_tilt_sigma * s.ekf.initial_tilt_sigma;
        let y = s.ekf.initial_yaw_sigma * s.ekf.initial_yaw_sigma;
        let b = s.ekf.initial_bias_sigma * s.ekf.initial_bias_sigma;
        Cov6::diagonal([t, t, y, b, b, b])
    }

    #[cold]
    #[inline(never)]
    fn start(&mut self, q: Quaternion, bias: Vec3) {
        self.q = q.normalized();
        self.bias = if bias.is_finite() { bias } else { self.settings.init.gyro_bias };
        self.p = Self::initial_cov(&self.settings);
        self.init = None;
        self.gate.reset();
        self.rest.reset();
        self.block_q = self.q;
        self.pending_yaw = 0.0;
        self.external_yaw = 0.0;
        self.accel_h = [0.0; 2];
        self.accel_h1 = [0.0; 2];
        self.norm_prev = 0.0;
        self.step_var = 0.0;
        self.motion_var = 0.0;
        self.moving_start = false;
    }

    /// How the covariance treats the yaw error: untracked when nothing observes it (yaw-split
    /// on and no magnetometer; see [`YawRow`]).
    fn yaw_row(&self) -> YawRow {
        match (self.settings.ekf.yaw_split, self.settings.mag.enabled) {
            (false, _) => YawRow::Free,
            (true, true) => YawRow::Frozen,
            (true, false) => YawRow::Untracked,
        }
    }

    /// Rotate the attitude about NED z by `angle` rad (a pure yaw change).
    #[inline(never)]
    fn rotate_yaw(&mut self, angle: f32) {
        self.q = (Quaternion::from_yaw(angle) * self.q).normalized();
    }

    /// Gyro propagation of the attitude and covariance. Returns the predicted rotation and the
    /// bias-corrected rate (rad/s, body), when the gyro sample is valid.
    fn predict(&mut self, c: &Checked) -> (Mat3, Option<Vec3>) {
        let s = &self.settings;
        let rate = c.gyro.map(|g| g - self.bias);
        if let Some(w) = rate {
            // Trapezoidal rule: the gyro is sampled at the ends of the interval, so the rotation
            // over it is that of the mean of the previous and this (bias-corrected) rate —
            // second-order accurate where holding one sample lags by half a sample. The first
            // sample, and the first after an invalid one, are held.
            let angle = match self.prev_rate {
                Some(p) => (p + w) * mathf::half(c.dt_rate),
                None => w * c.dt_rate,
            };
            // Exp is a unit quaternion, so the product keeps |q| = 1 to rounding; the one
            // normalisation of the cycle is at its end.
            self.q = self.q * Quaternion::from_rotation_vector(angle);
            if !fcmp::is_zero(s.ekf.yaw_drift_rate) {
                let half = -0.5 * s.ekf.yaw_drift_rate * c.dt_rate;
                self.q = self.q.pre_rotate_z(1.0, half);
            }
        }
        self.prev_rate = rate;
        let yaw = self.yaw_row();
        // Without a yaw row nothing reads R's bottom-left pair (A's yaw row, below, and the
        // accelerometer update take the tilt rows and the third column only).
        let r = if yaw == YawRow::Untracked {
            self.q.to_rotation_matrix_tilt()
        } else {
            self.q.to_rotation_matrix()
        };
        let dt = c.dt_cov;
        // A = R·dt; its yaw row only when the yaw error is tracked.
        let rows = if yaw == YawRow::Untracked { 2 } else { 3 };
        let mut a: Mat3 = [[0.0; 3]; 3];
        unroll!(i in [0, 1, 2] {
            if i < rows {
                unroll!(j in [0, 1, 2] {
                    a[i][j] = r[i][j] * dt;
                });
            }
        });
        let u = Vec3::new(r[0][2], r[1][2], r[2][2]);
        self.p.predict(&a, u, dt, &self.noise, yaw);
        (r, rate)
    }

    /// Accelerometer tilt correction: motion statistics, gate, the low-pass in the estimate's
    /// NED frame, then the Kalman update with yaw-split. `r` is the predicted rotation.
    /// `rate2` is the squared rotation rate, (rad/s)².
    fn accel_update(&mut self, dt: f32, a_g: Vec3, norm_g: f32, r: &Mat3, rate2: f32) -> Flags {
        let e = &self.settings.ekf;
        // The horizontal specific force in the estimate's NED frame and its deviation from the
        // low-pass's first stage; with the deviation of the norm from 1 g for the vertical, the
        // motion level `m` (g²) is their mean square over `motion_time_constant`.
        let an = [
            r[0][0] * a_g.x + r[0][1] * a_g.y + r[0][2] * a_g.z,
            r[1][0] * a_g.x + r[1][1] * a_g.y + r[1][2] * a_g.z,
        ];
        let dev = [an[0] - self.accel_h1[0], an[1] - self.accel_h1[1]];
        let dn = norm_g - 1.0;
        let dev2 = dev[0] * dev[0] + dev[1] * dev[1] + dn * dn;
        // The norm's change since the previous sample (at rates above 1/VIB_STEP_S, from its
        // low-pass over VIB_STEP_S): the vibration's share (below). For white noise of
        // variance σ² the change from the low-pass has the variance 2σ²/(2 − α): scaled by
        // 2 − α it is 2σ² at any rate, as the step from one sample to the next is.
        let step = dn - self.norm_prev;
        let step2 = if fcmp::lt(self.vib_alpha, 1.0) {
            self.norm_prev += self.vib_alpha * step;
            (2.0 - self.vib_alpha) * (step * step)
        } else {
            self.norm_prev = dn;
            step * step
        };
        let m = self.motion_var;
        let bits = dt.to_bits();
        if bits.abs_diff(self.rate_dt) > VAR_DT_ULPS {
            // Once per sample rate (a measured `dt` that jitters by less than [`VAR_DT_ULPS`]
            // keeps them: one division, not one per sample): the white noise's variance per sample
            // grows with the sample rate, so that the tilt's correction time, in seconds, does
            // not depend on the rate; so does the variance the bias learns with in motion
            // (below); the weight of the norm's low-pass for the vibration share; and the
            // motion level's weights.
            let n = &self.settings.noise;
            let ratio = n.accel_rate_ratio(dt);
            let var = n.accel_var * ratio * self.settings.ekf.accel_var_scale;
            self.accel_var = var;
            self.accel_var3 = 3.0 * var;
            self.scatter_var = ratio * (1.0 / 3.0);
            self.rate_dt = bits;
            self.vib_alpha = fcmp::min(dt * (1.0 / VIB_STEP_S), 1.0);
            // The weight of one sample in the motion level's average, and at the onset of
            // motion.
            let w = dt * self.inv_motion_tau;
            self.motion_w = (fcmp::min(w, 1.0), fcmp::min(ONSET_SPEEDUP * w, 1.0));
        }
        // A knock is a jump far beyond the current motion level (KNOCK_SIGMAS standard
        // deviations), so swinging or bobbing is not mistaken for one.
        let allowance = KNOCK_SIGMAS * KNOCK_SIGMAS * m;
        // Motion sets in at once: a deviation beyond the same KNOCK_SIGMAS standard deviations
        // (for noise alone χ²₃/3 > 9, six samples in a million) is averaged in ONSET_SPEEDUP
        // times faster, so that the low-pass lengthens within a tenth of the
        // motion average's time constant, before the motion's first swing has pulled the tilt.
        let k = if fcmp::gt(dev2, allowance) { self.motion_w.1 } else { self.motion_w.0 };
        let m_next = m + k * (dev2 - m);
        let bypass = match self.gate.pre_check(dt, a_g, norm_g, allowance) {
            PreCheck::Reject(f) => {
                // A knock is short: rejected samples raise the motion level only once the
                // rejections have outlasted one, so that motion that began with a jump is
                // soon accepted as motion (no lock-out).
                if fcmp::gt(self.gate.rejected_for(), KNOCK_MAX_S) {
                    self.motion_var = m_next;
                }
                return f;
            }
            PreCheck::Pass { bypass_innovation } => bypass_innovation,
        };
        self.motion_var = m_next;
        let m = m_next; // this sample counts in its own weight
        self.step_var += self.motion_w.0 * (step2 - self.step_var);
        // Motion weight w = m / (m + motion_scale) in [0, 1): 0 still, → 1 in strong motion.
        // The low-pass delays by w times a time constant: still, each sample is used as it is;
        // in motion, accelerations average out in the (almost inertial) NED frame while gravity
        // stays. Two first-order stages of half the delay each (critically damped, second
        // order): the same delay as one stage, so the same gyro error accumulates over it, but
        // a motion at angular frequency ω ≫ 1/τ passes 4/(ωτ)² instead of 1/(ωτ) — 0.033
        // instead of 0.091 at 1 Hz and τ = 1.75 s — and no overshoot when w changes (a
        // Butterworth stage's momentum overshot at the start of motion).
        //
        // The time constant depends on what moves. Vibration and noise change from one sample
        // to the next, motion does not: for independent samples the norm's mean square step is
        // twice their variance along the vertical, i.e. their variance in the two horizontal
        // axes together if it is the same on every axis. That share of m, v = min(step_var,
        // m), averages out over `vib_time_constant`, and the shorter the faster the board
        // turns (`vib_rate`, with |ω| the largest axis rate: the gyro's scale-factor and
        // misalignment errors grow over the delay in a turn). The rest, m − v, is motion, which
        // needs `accel_time_constant`. Vibration that does not reach the norm (along the
        // horizontal only) counts as motion, as it did before the split:
        //   delay = (τ·(m − v) + τ_v·v·ω₀²/(ω₀² + |ω|²)) / (m + motion_scale),
        // α = dt / (delay/2 + dt), written with one division.
        let v = fcmp::min(self.step_var, m);
        let (w02, tw02) = self.vib_rate2;
        let g = w02 + rate2;
        let dmm = dt * (m + e.motion_scale) * g;
        let num = (e.accel_time_constant * (m - v)) * g + tw02 * v;
        let alpha = dmm / (mathf::half(num) + dmm);
        self.accel_h1[0] += dev[0] * alpha;
        self.accel_h1[1] += dev[1] * alpha;
        self.accel_h[0] += (self.accel_h1[0] - self.accel_h[0]) * alpha;
        self.accel_h[1] += (self.accel_h1[1] - self.accel_h[1]) * alpha;
        // The filtered horizontal specific force in the estimate's NED frame, in g: for a tilt
        // error δθ, ā = Exp(−δθ)·(0, 0, −|ā|) ≈ |ā|·(δθ_y, −δθ_x, −1), a measurement of
        // (δθ_x, δθ_y) scaled by |ā|/g — 1 for a calibrated accelerometer at rest, a few per
        // cent more under the mean centripetal force of a swing; no division, no square root.
        let z = [-self.accel_h[1], self.accel_h[0]];
        let var = self.accel_var;
        let Some(mut t) = self.p.tilt_innovation(z, var) else {
            return Flags::HEALTH_RESET;
        };
        // The bias learns from this measurement as if its variance were that of the raw
        // samples' scatter, m/3 per axis (at `noise.accel_ref_rate`; scaled to the sample rate
        // as the noise's variance is, `scatter_var`), when that is the larger: the low-pass makes
        // consecutive measurements alike, not independent, so it adds no information about the
        // bias, and vibration or motion would otherwise drive the bias through the tilt–bias
        // correlation. And robustly: an innovation beyond ROBUST_NIS of what S expects moves
        // the bias in proportion (Huber). One division: β = (S₀/S_eff)·(c / max(NIS, c)).
        let nis = t.nis();
        // Most still samples are neither (β stays 1 and the update skips its scaling).
        let scatter = fcmp::gt(m, self.accel_var3);
        let outlier = fcmp::gt(nis, ROBUST_NIS);
        if scatter || outlier {
            let p0 = self.p.m[0][0];
            let (num, den) =
                if scatter { (p0 + var, p0 + m * self.scatter_var) } else { (1.0, 1.0) };
            let (c, den_n) = if outlier { (ROBUST_NIS, nis) } else { (1.0, 1.0) };
            t.bias_gain = (num * c) / (den * den_n);
        }
        let mut flags = match self.gate.innovation(dt, nis, bypass) {
            Ok(f) => f,
            Err(f) => return f,
        };
        if flags.contains(Flags::REACQUIRE) {
            // Trust the accelerometer again: widen tilt uncertainty to the innovation's size.
            let e = z[0] * z[0] + z[1] * z[1];
            self.p.inflate(0, e);
            self.p.inflate(1, e);
            match self.p.tilt_innovation(z, var) {
                // The bias learns from the reacquired sample as from any other.
                Some(t2) => t = TiltInnovation { bias_gain: t.bias_gain, ..t2 },
                None => return Flags::HEALTH_RESET,
            }
        }
        let dx = self.p.update_tilt(&t, self.yaw_row());
        // (1, δθ/2) ⊗ q, not normalised: only the direction matters until the cycle's end.
        // With yaw-split the gain row of δθ_z is zero, so the correction is a rotation about a
        // horizontal NED axis: it has no component about NED z, and leaves the heading (the
        // twist about NED z) alone at every attitude, pitch ±90° and upside down included.
        self.q = if fcmp::is_zero(dx[2]) {
            self.q.pre_rotate_small_xy(dx[0], dx[1]) // always so with yaw-split
        } else {
            self.q.pre_rotate_small(Vec3::new(dx[0], dx[1], dx[2]))
        };
        self.bias += Vec3::new(dx[3], dx[4], dx[5]);
        // The filtered vectors live in the estimate's frame: turn both stages with the
        // correction, ā ← Exp(δθ) ā ≈ ā + δθ × ā with ā ≈ (·, ·, −1) g: (−δθ_y, δθ_x) on the
        // horizontal part (to first order in the small tilt error).
        self.accel_h[0] -= dx[1];
        self.accel_h[1] += dx[0];
        self.accel_h1[0] -= dx[1];
        self.accel_h1[1] += dx[0];
        flags |= Flags::ACCEL_USED;
        flags
    }

    /// Magnetometer heading update: only yaw (and the gyro biases) move.
    #[inline(never)] // off by default; kept out of the hot path's code
    fn mag_update(&mut self, m: Vec3) -> Flags {
        let ms = self.settings.mag;
        let n = m.norm();
        if !(m.is_finite() && n > 0.0) || mathf::abs(n / ms.field_ut - 1.0) > ms.norm_tolerance {
            return Flags::MAG_REJECTED;
        }
        self.q = self.q.normalized(); // the correction left it unnormalised
        let mn = self.q.rotate(m);
        let h = mathf::sqrt(mn.x * mn.x + mn.y * mn.y);
        let dip = mathf::atan2(mn.z, h);
        if mathf::abs(dip - ms.dip) > ms.dip_tolerance || !(h > 0.0) {
            return Flags::MAG_REJECTED;
        }
        let z = mathf::wrap_pi(ms.declination - mathf::atan2(mn.y, mn.x));
        let free = [false, false, true, true, true, true];
        let saved = self.p;
        match self.p.update_scalar(2, z, ms.heading_sigma * ms.heading_sigma, free) {
            Some((dx, nis)) if nis <= self.settings.gate.innovation_chi2 => {
                self.rotate_yaw(dx[2]);
                self.external_yaw += dx[2];
                self.bias += Vec3::new(dx[3], dx[4], dx[5]);
                Flags::MAG_USED
            }
            _ => {
                self.p = saved;
                Flags::MAG_REJECTED
            }
        }
    }

    /// End of a rest block: re-estimate the bias and hold yaw while at rest.
    #[inline(never)] // once per rest-detection block
    fn rest_block(&mut self, b: &RestBlock) -> Flags {
        // The rotation about NED z since the block began: the twist of q ⊗ q_block*, defined
        // at every attitude (no Euler angle).
        let moved = mathf::wrap_pi(heading_change(self.block_q, self.q) - self.external_yaw);
        self.external_yaw = 0.0;
        if b.still {
            self.pending_yaw += moved;
        } else {
            self.pending_yaw = 0.0;
        }
        let mut flags = Flags::NONE;
        if b.at_rest {
            flags |= Flags::AT_REST;
            if self.settings.rest.yaw_hold {
                self.rotate_yaw(-self.pending_yaw);
            }
            self.pending_yaw = 0.0;
            // Zero-rate measurement of the bias error, axis by axis; only the bias moves.
            let free = [false, false, false, true, true, true];
            let floor = self.settings.rest.bias_meas_floor;
            let mut moved_bias = Vec3::ZERO;
            for i in 0..3 {
                let z = b.mean_rate[i] - moved_bias[i];
                let r = b.mean_var[i] + floor * floor;
                if let Some((dx, _)) = self.p.update_scalar(3 + i, z, r, free) {
                    let d = Vec3::new(dx[3], dx[4], dx[5]);
                    self.bias += d;
                    moved_bias += d;
                }
            }
        }
        self.block_q = self.q;
        flags
    }

    /// `MOVING_START` until the bias is as certain as a still start (every bias variance
    /// within `initial_bias_sigma²`) or rest has measured it.
    #[cold]
    fn moving_start_flag(&mut self) -> Flags {
        let lim = self.settings.ekf.initial_bias_sigma * self.settings.ekf.initial_bias_sigma;
        let p = &self.p.m;
        if self.rest.at_rest() || (p[3][3] <= lim && p[4][4] <= lim && p[5][5] <= lim) {
            self.moving_start = false;
            Flags::NONE
        } else {
            Flags::MOVING_START
        }
    }

    /// Health checks, and the cycle's one normalisation of `q`: reset a broken quaternion,
    /// bias or covariance to its last good or initial value and flag it. The covariance's
    /// diagonal is checked every cycle, its off-diagonal bounds every
    /// [`FULL_HEALTH_CHECK_EVERY`] cycles and whenever the diagonal fails.
    fn health(&mut self, q_before: Quaternion, bias_before: Vec3) -> Flags {
        let mut flags = Flags::NONE;
        // The cycle's steps scale q freely (yaw restore by up to ~2); only a non-finite or
        // vanishing q is broken.
        match self.q.try_normalized() {
            Some(q) => self.q = q,
            None => {
                self.q = q_before.normalized();
                flags |= Flags::HEALTH_RESET;
            }
        }
        if !self.bias.is_finite() || fcmp::gt(self.bias.max_abs(), self.settings.limits.gyro_range)
        {
            self.bias = if bias_before.is_finite() { bias_before } else { Vec3::ZERO };
            flags |= Flags::HEALTH_RESET;
        }
        let max = [MAX_ATT_VAR, MAX_ATT_VAR, MAX_ATT_VAR, MAX_BIAS_VAR, MAX_BIAS_VAR, MAX_BIAS_VAR];
        self.cycle = self.cycle.wrapping_add(1);
        let full = self.cycle % FULL_HEALTH_CHECK_EVERY == 0;
        let healthy = self.p.diagonal_is_healthy(&max) && (!full || self.p.is_healthy(&max));
        if !healthy {
            self.p = Self::initial_cov(&self.settings);
            flags |= Flags::HEALTH_RESET;
        }
        flags
    }
}

/// Angle (rad, in (−π, π]) of the rotation about NED z that takes attitude `from` to `to`: the
/// twist about z of `to ⊗ from*` (the heading change in the sense of the inclination/heading
/// split of `docs/accuracy.md`). Defined at every attitude; any norm.
pub fn heading_change(from: Quaternion, to: Quaternion) -> f32 {
    let d = to * from.conjugate();
    mathf::twice(mathf::atan2(d.z, d.w))
}

impl AttitudeFilter for Ekf {
    fn name(&self) -> &'static str {
        "ekf"
    }

    fn update(&mut self, sample: &ImuSample) -> Flags {
        let Some(c) = validate::check(sample, &self.settings.limits) else {
            self.last_flags = Flags::TIME_GAP;
            return self.last_flags;
        };
        let mut flags = c.flags;
        let accel = c.accel_g;

        if let Some(init) = self.init.as_mut() {
            match init::feed(init, &mut self.gate, &c) {
                InitStep::Pending(q) => {
                    self.q = q;
                    self.last_flags = flags | Flags::INITIALISING;
                    return self.last_flags;
                }
                InitStep::Done(q, b) => {
                    let var = init.bias_variance(&self.settings.noise);
                    let moving = init.was_moving();
                    let level = init.motion_level();
                    self.start(q, b);
                    // The motion level starts from the window's, not from rest: vibration or
                    // motion in the window weights the first samples at once.
                    self.motion_var = level;
                    if moving {
                        // A start in motion: tilt from a moving accelerometer, bias configured.
                        // Tilt as uncertain as the accelerometer's spread in the window (g² ≈
                        // rad² of direction), at least the still start's.
                        let t0 = self.settings.ekf.initial_tilt_sigma;
                        let t = if fcmp::gt(level, t0 * t0) { level } else { t0 * t0 };
                        let b = self.settings.init.moving_bias_sigma;
                        self.p = Cov6::diagonal([t, t, t, b * b, b * b, b * b]);
                        self.moving_start = true;
                    }
                    if let Some(v) = var {
                        // The window measured the bias: start with its actual uncertainty.
                        for i in 0..3 {
                            self.p.m[3 + i][3 + i] = v[i];
                        }
                    }
                    // The window's last sample still moves the state (below), so a window
                    // that ends as motion starts loses nothing.
                }
            }
        }

        let (q_before, bias_before) = (self.q, self.bias);
        let (r, rate) = self.predict(&c);

        let rest_block =
            self.rest.push(c.dt_rate, rate, accel.map(|(a, _)| a), &self.settings.noise);
        let mut r = r;
        if let Some(block) = rest_block {
            flags |= self.rest_block(&block);
            r = self.q.to_rotation_matrix(); // the yaw hold may have rotated q
        } else if self.rest.at_rest() {
            flags |= Flags::AT_REST;
        }

        if let Some((a, n)) = accel {
            // The largest axis rate, squared: the scale of what the gyro's errors can build up.
            let rate2 = rate.map_or(0.0, |w| {
                let r = fcmp::max_abs3(w.x, w.y, w.z);
                r * r
            });
            flags |= self.accel_update(c.dt_rate, a, n, &r, rate2);
        }
        if self.settings.mag.enabled {
            if let Some(m) = sample.mag {
                flags |= self.mag_update(m);
            }
        }
        flags |= self.health(q_before, bias_before);
        if self.moving_start {
            flags |= self.moving_start_flag();
        }
        self.last_flags = flags;
        flags
    }

    fn attitude(&self) -> Quaternion {
        self.q
    }

    fn euler(&self) -> Euler {
        Euler::from_unit_quaternion(self.q)
    }

    fn gyro_bias(&self) -> Vec3 {
        self.bias
    }

    fn is_initialised(&self) -> bool {
        self.init.is_none()
    }

    fn set_yaw(&mut self, yaw: f32) {
        if !yaw.is_finite() {
            return;
        }
        if let Some(init) = self.init.as_mut() {
            init.set_yaw(yaw);
            return;
        }
        self.q = self.q.with_yaw(yaw);
        self.block_q = self.q;
        self.pending_yaw = 0.0;
        self.external_yaw = 0.0;
    }

    fn set_attitude(&mut self, q: Quaternion, bias: Vec3) {
        self.start(q, bias);
    }

    fn reset(&mut self) {
        *self = Ekf::new(self.settings);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mathf::deg;
    use crate::settings::GateSettings;
    use proptest::prelude::*;

    proptest! {
        /// With yaw-split on, an accelerometer update never changes the heading (the twist of
        /// the correction about NED z is zero), whatever the attitude — pitch ±90° and upside
        /// down included — the covariance history and the measurement.
        #[test]
        fn accel_update_never_changes_heading(
            qw in -1.0f32..1.0, qx in -1.0f32..1.0, qy in -1.0f32..1.0, qz in -1.0f32..1.0,
            ax in -1.0f32..1.0, ay in -1.0f32..1.0, az in -1.0f32..1.0,
            wx in -0.5f32..0.5, wy in -0.5f32..0.5, wz in -0.5f32..0.5,
            steps in 1usize..50,
        ) {
            let q0 = Quaternion::new(qw, qx, qy, qz);
            prop_assume!(q0.norm_sq() > 0.01);
            let mut s = Settings::default();
            s.rest.enabled = false;
            s.gate.jump_g = 10.0;
            // The build-up samples reach 2.06 g: none may be gated (its hold-off would then
            // reject the sample under test).
            s.gate.norm_tolerance = 2.0;
            let mut f = Ekf::new(s);
            f.set_attitude(q0.normalized(), Vec3::ZERO);
            // Build up some correlated covariance first.
            for _ in 0..steps {
                f.update(&ImuSample::new(0.02, Vec3::new(wx, wy, wz), Vec3::new(ax, ay, az - 0.5) * 9.8));
            }
            let a = Vec3::new(ax, ay, az);
            prop_assume!(a.norm() > 0.2);
            let a = a * (1.0 / a.norm());
            let r = f.q.to_rotation_matrix();
            let before = f.q;
            let flags = f.accel_update(0.02, a, 1.0, &r, 0.0);
            prop_assert!(flags.contains(Flags::ACCEL_USED), "{:?}", flags);
            let moved = heading_change(before, f.q);
            prop_assert!(moved.abs() < 1e-6, "heading moved {} rad", moved);
            // ... and the tilt did move toward the measurement (the update did something).
            prop_assert!(f.q.normalized().angle_to(before) > 0.0);
        }
    }

    /// The tilt's correction time, in seconds, does not depend on the sample rate. The
    /// accelerometer's white noise has a constant density, so its variance per sample grows
    /// with the rate, as the gyro's does. With a fixed variance per sample the steady-state
    /// gain per sample would go as √(q·dt/r), q ∝ dt the gyro's noise per sample, and the
    /// correction time as √dt: at 250 Hz √5 = 2.2 times shorter than at 50 Hz (measured:
    /// 0.120 s and 0.112 s; with the variance held per sample, 0.120 s and 0.052 s). A still,
    /// level board, the filter settled for 30 s, then its attitude turned 2° about north: the
    /// time until the error is down to 1°. The low-pass is kept out of it (a huge
    /// `motion_scale`: no delay whatever the motion level), because the turn is a step of the
    /// specific force in NED, which the motion level sees for one sample whatever the sample's
    /// length.
    #[test]
    fn a_tilt_error_decays_in_the_same_time_at_any_sample_rate() {
        let mut s = Settings::default();
        s.ekf.motion_scale = 1e6;
        let half_time = |rate: f32| {
            let dt = 1.0 / rate;
            let mut f = Ekf::new(s);
            let still = ImuSample::new(dt, Vec3::ZERO, Vec3::new(0.0, 0.0, -crate::GRAVITY));
            for _ in 0..(30.0 * rate) as usize {
                f.update(&still);
            }
            assert!(f.q.normalized().angle_to(Quaternion::IDENTITY) < deg(0.001));
            f.q = f.q.pre_rotate_small_xy(deg(2.0), 0.0).normalized();
            let mut t = 0.0;
            for _ in 0..(10.0 * rate) as usize {
                f.update(&still);
                t += dt;
                if f.q.normalized().angle_to(Quaternion::IDENTITY) < deg(1.0) {
                    return t;
                }
            }
            panic!("the tilt error did not halve in 10 s at {rate} Hz");
        };
        let (t50, t250) = (half_time(50.0), half_time(250.0));
        assert!(
            (t250 / t50 - 1.0).abs() < 0.1,
            "halving time {t50} s at 50 Hz, {t250} s at 250 Hz"
        );
    }

    /// The measurement variance follows `dt`, times `accel_var_scale`, but only once `dt` has
    /// moved by more than [`VAR_DT_ULPS`] (the firmware's measured `dt` jitters by a few
    /// cycles): exactly 2¹⁵ units in the last place keep it, one more recomputes it.
    #[test]
    fn the_measurement_variance_follows_the_sample_rate_past_the_jitter_allowance() {
        let mut s = Settings::default();
        s.ekf.accel_var_scale = 4.0;
        let mut f = quiet_filter(s);
        let level = Vec3::new(0.0, 0.0, -1.0);
        let at = |f: &mut Ekf, dt: f32| {
            f.accel_update(dt, level, 1.0, &IDENTITY, 0.0);
            f.accel_var
        };
        let v = at(&mut f, 0.02);
        assert!((v / (4.0 * 2.376e-6) - 1.0).abs() < 1e-6, "{v}");
        let jitter = f32::from_bits(0.02f32.to_bits() + (1 << 15));
        assert_eq!(at(&mut f, jitter).to_bits(), v.to_bits(), "recomputed within the allowance");
        let moved = f32::from_bits(0.02f32.to_bits() + (1 << 15) + 1);
        let want = 4.0 * 2.376e-6 * (0.02 / moved);
        assert!((at(&mut f, moved) / want - 1.0).abs() < 1e-6, "not recomputed past it");
        assert!((at(&mut f, 0.01) / (8.0 * 2.376e-6) - 1.0).abs() < 1e-6);
        assert!((f.accel_var3 / (24.0 * 2.376e-6) - 1.0).abs() < 1e-6);
    }

    /// A started filter at the identity with a covariance so small that the Kalman correction
    /// (which also turns the low-pass's stages) is negligible: the stages then show the
    /// low-pass's own weight α.
    fn quiet_filter(settings: Settings) -> Ekf {
        let mut f = Ekf::new(settings);
        f.set_attitude(Quaternion::IDENTITY, Vec3::ZERO);
        f.p = Cov6::diagonal([1e-14; 6]);
        f
    }

    const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

    /// The low-pass's weight against the documented formula, computed here in `f64` with its
    /// division (the filter multiplies it out): α = dt / (D/2 + dt),
    /// D = (τ·(m − v) + τ_v·v·ω₀²/(ω₀² + |ω|²)) / (m + m₀), for motion and vibration mixed,
    /// vibration alone, a fast turn and no turn. The sample is chosen so that this sample's
    /// deviation and step equal the current level and step mean square (m and `step_var` stay
    /// as set), north so that the first stage moves by α times the deviation.
    #[test]
    fn the_low_pass_delay_follows_its_formula() {
        let s = Settings::default();
        let (tau, tau_v, w0, m0) = (
            f64::from(s.ekf.accel_time_constant),
            f64::from(s.ekf.vib_time_constant),
            f64::from(s.ekf.vib_rate),
            f64::from(s.ekf.motion_scale),
        );
        assert_eq!((tau, tau_v, m0 as f32), (1.75, 1.5, 1e-3));
        let dt = 0.02f32;
        for (m, step2, rate) in [
            (4e-3f32, 1e-3f32, 0.0f32),
            (4e-3, 1e-3, deg(30.0)),
            (2e-3, 5e-3, deg(5.0)),
            (0.05, 0.0, deg(200.0)),
        ] {
            let mut f = quiet_filter(s);
            f.motion_var = m;
            f.step_var = step2;
            f.norm_prev = -step2.sqrt(); // this sample's norm is 1 g: its step is √step_var
            let north = m.sqrt(); // this sample's deviation from the first stage (at 0)
            let a = Vec3::new(north, 0.0, -(1.0 - m).sqrt());
            let flags = f.accel_update(dt, a, 1.0, &IDENTITY, rate * rate);
            assert!(flags.contains(Flags::ACCEL_USED), "{flags:?}");
            let alpha = f64::from(f.accel_h1[0]) / f64::from(north);
            let (m, v, w2) = (f64::from(m), f64::from(step2.min(m)), f64::from(rate).powi(2));
            let delay = (tau * (m - v) + tau_v * v * w0 * w0 / (w0 * w0 + w2)) / (m + m0);
            let want = 0.02 / (delay / 2.0 + 0.02);
            assert!((alpha / want - 1.0).abs() < 1e-4, "m {m} v {v}: α {alpha}, by hand {want}");
        }
    }

    /// The vibration share is the norm's sample-to-sample scatter: for independent samples of
    /// standard deviation σ the mean square step is 2σ² (here σ = 0.02 g on the norm: 8·10⁻⁴
    /// g²); for a slow vertical bob (0.2 g at 0.5 Hz, 50 Hz samples) it is (0.2·2π·0.5·0.02)²/2
    /// = 7.9·10⁻⁵ g², while its motion level is about 0.2²/2 = 0.02 g².
    #[test]
    fn the_vibration_share_is_the_norms_sample_to_sample_scatter() {
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut gauss = || {
            // Irwin–Hall: the sum of 12 uniforms minus 6, unit variance.
            let mut sum = 0.0f32;
            for _ in 0..12 {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                sum += (rng >> 40) as f32 / (1u64 << 24) as f32;
            }
            sum - 6.0
        };
        let mut f = quiet_filter(Settings::default());
        for _ in 0..1500 {
            let n = 1.0 + 0.02 * gauss();
            f.accel_update(0.02, Vec3::new(0.0, 0.0, -n), n, &IDENTITY, 0.0);
        }
        assert!((f.step_var / 8e-4 - 1.0).abs() < 0.25, "noise: {}", f.step_var);

        let mut f = quiet_filter(Settings::default());
        for k in 0..1500 {
            let t = k as f32 * 0.02;
            let n = 1.0 + 0.2 * (core::f32::consts::TAU * 0.5 * t).sin();
            f.accel_update(0.02, Vec3::new(0.0, 0.0, -n), n, &IDENTITY, 0.0);
        }
        assert!((f.step_var / 7.9e-5 - 1.0).abs() < 0.1, "bob: {}", f.step_var);
        assert!((f.motion_var / 0.02 - 1.0).abs() < 0.1, "bob's level: {}", f.motion_var);
    }

    /// Above 100 Hz the vibration share is the norm's change from its low-pass over
    /// `VIB_STEP_S` (weight α = dt/0.01 s = 0.5 at 200 Hz), scaled by 2 − α. The change from
    /// the low-pass is (1 − z⁻¹)/(1 − (1 − α) z⁻¹) of the norm: for white noise its variance
    /// is 2σ²/(2 − α), so the scaled share is 2σ², as the step between independent samples
    /// at 50 Hz. A 25 Hz vibration of amplitude 0.02 g (σ² = 2·10⁻⁴ g²) turns by 45° per
    /// sample: |1 − e^(−iπ/4)|² / |1 − 0.5 e^(−iπ/4)|² = 0.586/0.543 of σ², times 1.5:
    /// 3.24·10⁻⁴ g² by hand, most of 2σ²; the step from the previous sample would give
    /// 2σ²(1 − cos 45°) = 1.17·10⁻⁴ g², and the rest would lengthen the delay as motion.
    #[test]
    fn above_100_hz_the_vibration_share_is_the_change_within_ten_milliseconds() {
        let dt = 0.005f32;
        let mut f = quiet_filter(Settings::default());
        for k in 0..6000 {
            let t = k as f32 * dt;
            let n = 1.0 + 0.02 * (core::f32::consts::TAU * 25.0 * t).sin();
            f.accel_update(dt, Vec3::new(0.0, 0.0, -n), n, &IDENTITY, 0.0);
        }
        assert_eq!(f.vib_alpha, 0.5);
        assert!((f.step_var / 3.24e-4 - 1.0).abs() < 0.05, "25 Hz vibration: {}", f.step_var);

        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut f = quiet_filter(Settings::default());
        for _ in 0..6000 {
            let mut sum = 0.0f32; // Irwin–Hall: the sum of 12 uniforms minus 6
            for _ in 0..12 {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                sum += (rng >> 40) as f32 / (1u64 << 24) as f32;
            }
            let n = 1.0 + 0.02 * (sum - 6.0);
            f.accel_update(dt, Vec3::new(0.0, 0.0, -n), n, &IDENTITY, 0.0);
        }
        assert!((f.step_var / 8e-4 - 1.0).abs() < 0.25, "noise: {}", f.step_var);
    }

    /// The motion level averages over `motion_time_constant` with weight β = dt/τ per sample,
    /// and ten times that (`ONSET_SPEEDUP`) for a deviation beyond 3 standard deviations of
    /// the level: the filter's level after a step of the norm to 1.1 g (a deviation of 0.01
    /// g², nothing horizontal) against that recurrence, at τ = 0.25 s (β = 0.08).
    #[test]
    fn the_motion_level_averages_over_its_time_constant_faster_at_onset() {
        let mut s = Settings::default();
        s.ekf.motion_time_constant = 0.25;
        let mut f = quiet_filter(s);
        let mut m = 0.0f64;
        for k in 0..40 {
            f.accel_update(0.02, Vec3::new(0.0, 0.0, -1.1), 1.1, &IDENTITY, 0.0);
            let dev2 = 0.1f64 * 0.1;
            let beta = if dev2 > 9.0 * m { 0.8 } else { 0.08 };
            m += beta * (dev2 - m);
            let got = f64::from(f.motion_var);
            assert!((got / m - 1.0).abs() < 1e-4, "sample {k}: level {got}, by hand {m}");
        }
    }

    /// In motion the bias learns as if the measurement's variance were the samples' scatter:
    /// its gain is scaled by β = (P₀₀ + σ²)/(P₀₀ + m/3) (docs/filter.md, step 4). With the
    /// low-pass off (α = 1: the measurement is this sample's horizontal specific force) and the
    /// tilt x error correlated with the x bias only (P₀₃ = c), one sample east e (a tilt x
    /// measurement of −e) moves the x bias by −β·c·e/(P₀₀ + σ²) = −c·e/(P₀₀ + m/3) (the first
    /// scalar update; the second, in y, does not reach it), against −c·e/(P₀₀ + σ²) still. At
    /// 200 Hz both variances are 4 times those at 50 Hz (`noise.accel_ref_rate`): −c·e/(P₀₀ +
    /// 4m/3) in motion, so that the bias learns as much per second at any rate.
    #[test]
    fn in_motion_the_bias_learns_with_the_samples_scatter_as_variance() {
        let mut s = Settings::default();
        s.ekf.accel_time_constant = 0.0;
        s.ekf.vib_time_constant = 0.0;
        let (p0, c) = (1e-2f32, 1e-4f32);
        for (m, dt) in [(1e-3f32, 0.02f32), (0.0, 0.02), (1e-3, 0.005), (0.0, 0.005)] {
            let ratio = 0.02 / dt;
            let var = s.noise.accel_var * s.ekf.accel_var_scale * ratio;
            let mut f = Ekf::new(s);
            f.set_attitude(Quaternion::IDENTITY, Vec3::ZERO);
            let mut p = Cov6::diagonal([p0, p0, 1e-2, 1e-4, 1e-4, 1e-4]);
            p.m[0][3] = c;
            p.m[3][0] = c;
            f.p = p;
            f.motion_var = m;
            // This sample's deviation equals the level, so the level stays m.
            let e = if m > 0.0 { m.sqrt() } else { 1e-3 };
            let a = Vec3::new(0.0, e, -(1.0 - e * e).sqrt());
            let flags = f.accel_update(dt, a, 1.0, &IDENTITY, 0.0);
            assert!(flags.contains(Flags::ACCEL_USED), "{flags:?}");
            let den = if m > 3.0 * var { p0 + m / 3.0 * ratio } else { p0 + var };
            let want = -c * e / den;
            let got = f.bias.x;
            assert!(
                (got / want - 1.0).abs() < 1e-3,
                "m {m}, dt {dt}: bias moved {got}, by hand {want}"
            );
        }
    }

    /// Robust bias learning and the reacquisition after a lock-out, by hand. The source's gate
    /// (χ² 16; no hold-off here) rejects a sample 0.1 g north and 0.05 g east of a level
    /// estimate while its tilt variance is 10⁻⁶ rad² (NIS ≈ 3,700) — for 2 s, then takes it
    /// (`REACQUIRE`): the tilt variances are widened by |z|² = 0.0125 rad², and the bias learns
    /// from that sample as from any other, with β = (P₀₀ + σ²)/(P₀₀ + m/3) for the motion
    /// level's scatter times c/NIS (c = 2) for the outlier, taken before the widening. With the
    /// low-pass off the measurement is the sample itself, z = (−0.05, 0.1), and the motion level
    /// (started at 0.01 g²) decays by 1 − dt/τ per sample once the first stage holds the sample.
    #[test]
    fn a_reacquired_sample_widens_the_tilt_variance_and_teaches_the_bias_robustly() {
        let mut s = Settings::default();
        s.ekf.accel_time_constant = 0.0;
        s.ekf.vib_time_constant = 0.0;
        s.gate = GateSettings { holdoff_s: 0.0, ..GateSettings::SOURCE };
        let var = f64::from(s.noise.accel_var * s.ekf.accel_var_scale);
        let mut f = Ekf::new(s);
        f.set_attitude(Quaternion::IDENTITY, Vec3::ZERO);
        let (p0, c) = (1e-6f32, 5e-6f32);
        let mut p = Cov6::diagonal([p0, p0, 1e-2, 1e-4, 1e-4, 1e-4]);
        p.m[0][3] = c;
        p.m[3][0] = c;
        f.p = p;
        f.motion_var = 0.01;
        let (north, east) = (0.1f32, 0.05f32);
        let a = Vec3::new(north, east, -(1.0 - north * north - east * east).sqrt());
        let mut m = 0.01f64;
        let mut dev2 = f64::from(north * north + east * east); // the first stage starts at 0
        for k in 0..200 {
            let flags = f.accel_update(0.02, a, 1.0, &IDENTITY, 0.0);
            m += 0.02 * (dev2 - m);
            dev2 = 0.0;
            if !flags.contains(Flags::REACQUIRE) {
                assert!(flags.contains(Flags::ACCEL_KNOCK), "sample {k}: {flags:?}");
                assert_eq!(f.p.m[0][0], p0, "a rejected sample changes nothing");
                continue;
            }
            assert!((100..=102).contains(&k), "reacquired at sample {k}");
            let (p0, c) = (f64::from(p0), f64::from(c));
            let (z0, z1) = (-f64::from(east), f64::from(north));
            let e = z0 * z0 + z1 * z1;
            let nis = (z0 * z0 + z1 * z1) / (p0 + var);
            let beta = (p0 + var) / (p0 + m / 3.0) * (2.0 / nis);
            let widened = p0 + e;
            let want_p = widened * var / (widened + var);
            let want_b = beta * c * z0 / (widened + var);
            let (got_p, got_b) = (f64::from(f.p.m[0][0]), f64::from(f.bias.x));
            // (P₀₀ after the update is a difference of two numbers near 0.0125: f32 leaves it
            // good to about 10⁻⁴.)
            assert!((got_p / want_p - 1.0).abs() < 1e-3, "P₀₀ {got_p}, by hand {want_p}");
            assert!((got_b / want_b - 1.0).abs() < 1e-3, "bias {got_b}, by hand {want_b}");
            // What is left of the measurement after the correction (the stages turn with it):
            // z·σ²/(P + |z|² + σ²) on each axis, 1.9·10⁻⁴ of it.
            let left = var / (widened + var);
            let got = [f64::from(f.accel_h1[0]), f64::from(f.accel_h1[1])];
            let want = [f64::from(north) * left, f64::from(east) * left];
            for (g, w) in got.iter().zip(want) {
                assert!((g / w - 1.0).abs() < 1e-2, "left {got:?}, by hand {want:?}");
            }
            return;
        }
        panic!("never reacquired");
    }

    #[test]
    fn heading_change_is_the_rotation_about_down() {
        let q = crate::Euler::new(deg(30.0), deg(89.9), deg(-40.0)).to_quaternion();
        let turned = Quaternion::from_yaw(deg(25.0)) * q;
        assert!((heading_change(q, turned) - deg(25.0)).abs() < 1e-5);
        // A rotation about a horizontal NED axis is no heading change.
        let tilted = Quaternion::from_rotation_vector(Vec3::new(0.1, -0.2, 0.0)) * q;
        assert!(heading_change(q, tilted).abs() < 1e-6);
    }
}
