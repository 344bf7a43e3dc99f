//! A small deterministic motion and sensor generator for the behaviour tests: truth is
//! integrated at a fine step from a body-rate profile; sensors add bias and Gaussian noise.
#![allow(dead_code)]

use ekf_core::{mathf::deg, ImuSample, Quaternion, Vec3, GRAVITY};
use rand_xoshiro::rand_core::{Rng as _, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Deterministic Gaussian noise: xoshiro256++ (`rand_xoshiro`) and Box–Muller.
pub struct Rng(Xoshiro256PlusPlus);
impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(Xoshiro256PlusPlus::seed_from_u64(seed))
    }
    /// Uniform in (0, 1).
    fn uniform(&mut self) -> f64 {
        ((self.0.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    pub fn gauss(&mut self) -> f32 {
        let (u, v) = (self.uniform(), self.uniform());
        ((-2.0 * u.ln()).sqrt() * (2.0 * core::f64::consts::PI * v).cos()) as f32
    }
    pub fn vec(&mut self, sd: Vec3) -> Vec3 {
        Vec3::new(self.gauss() * sd.x, self.gauss() * sd.y, self.gauss() * sd.z)
    }
}

/// Sensor model: the board's noise (digest) and bias by default.
#[derive(Clone, Copy)]
pub struct Sensors {
    pub gyro_bias: Vec3,
    pub gyro_sd: Vec3,
    pub accel_sd_g: f32,
}

impl Sensors {
    pub fn board() -> Self {
        Sensors {
            gyro_bias: Vec3::new(deg(1.619), deg(3.440), deg(-0.0042)),
            gyro_sd: Vec3::new(deg(0.337f32.sqrt()), deg(0.275f32.sqrt()), deg(4.19e-3f32.sqrt())),
            accel_sd_g: 2.376e-6f32.sqrt(),
        }
    }
    pub fn perfect() -> Self {
        Sensors { gyro_bias: Vec3::ZERO, gyro_sd: Vec3::ZERO, accel_sd_g: 0.0 }
    }
}

/// A simulated run: truth attitude and the samples it produced.
pub struct Run {
    pub samples: Vec<ImuSample>,
    pub truth: Vec<Quaternion>,
}

/// Simulate `seconds` at `rate_hz` starting from `q0`. `motion(t)` returns the body rate
/// (rad/s, FRD) and the linear acceleration of the sensor (m/s², NED) at time t.
pub fn simulate(
    q0: Quaternion,
    seconds: f32,
    rate_hz: f32,
    sensors: Sensors,
    seed: u64,
    motion: impl Fn(f32) -> (Vec3, Vec3),
) -> Run {
    let mut rng = Rng::new(seed);
    let n = (seconds * rate_hz).round() as usize;
    let dt = 1.0 / rate_hz;
    let sub = 20;
    let h = dt / sub as f32;
    let mut q = q0;
    let mut t = 0.0f32;
    let mut samples = Vec::with_capacity(n);
    let mut truth = Vec::with_capacity(n);
    for _ in 0..n {
        // Integrate truth over the sample interval (midpoint rule on the sub-steps); the gyro
        // reads the mean rate over the interval, as the firmware's averaged ADC frames do.
        let mut w = Vec3::ZERO;
        for k in 0..sub {
            let (wk, _) = motion(t + (k as f32 + 0.5) * h);
            q = (q * Quaternion::from_rotation_vector(wk * h)).normalized();
            w += wk * (1.0 / sub as f32);
        }
        t += dt;
        let (_, a_ned) = motion(t);
        let f_ned = a_ned - Vec3::new(0.0, 0.0, GRAVITY);
        let f_body = q.rotate_inverse(f_ned);
        samples.push(ImuSample::new(
            dt,
            w + sensors.gyro_bias + rng.vec(sensors.gyro_sd),
            f_body + rng.vec(Vec3::new(1.0, 1.0, 1.0) * (sensors.accel_sd_g * GRAVITY)),
        ));
        truth.push(q);
    }
    Run { samples, truth }
}

/// Still motion.
pub fn still(_: f32) -> (Vec3, Vec3) {
    (Vec3::ZERO, Vec3::ZERO)
}

/// Largest tilt (roll/pitch) error between estimate and truth, rad: the angle between the
/// two "down" directions in the body frame.
pub fn tilt_error(est: Quaternion, truth: Quaternion) -> f32 {
    let a = est.down_in_body();
    let b = truth.down_in_body();
    let c = a.cross(b).norm();
    c.atan2(a.dot(b))
}

/// Yaw error, rad, wrapped.
pub fn yaw_error(est: Quaternion, truth: Quaternion) -> f32 {
    ekf_core::mathf::wrap_pi(ekf_core::Euler::yaw_of(est) - ekf_core::Euler::yaw_of(truth))
}
