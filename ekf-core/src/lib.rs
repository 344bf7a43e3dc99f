//! `ekf-core`: attitude estimation for the iNEMO V2 sensor pod of a slow, tethered ROV.
//!
//! `#![no_std]`, allocation-free, `f32` throughout. Conventions (shared by every tool of the
//! project, see `docs/conventions.md`):
//! - body frame **FRD** (x forward, y starboard, z down), reference frame **NED**;
//! - attitude: scalar-first Hamilton quaternion rotating body vectors into NED,
//!   `v_ned = q ⊗ v_frd ⊗ q*`;
//! - Euler angles: intrinsic Z-Y-X (yaw ψ, pitch θ, roll φ), radians in code;
//! - gyroscope in rad/s, accelerometer specific force in m/s² (a level, still board reads
//!   about `(0, 0, −9.81)`), magnetometer in µT, time in s.
//!
//! The main estimator is [`Ekf`]; [`Ukf`], [`SsUkf`], [`Complementary`] and [`GyroOnly`] are the
//! filters it was chosen against. All implement [`AttitudeFilter`] and take the same
//! [`ImuSample`]s. Sensor conditioning (axis map, calibration, lever arm) lives in
//! [`conditioning`] and runs before any filter.
#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]
// `!(x > 0.0)` is deliberate throughout: unlike `x <= 0.0` it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Small fixed-size matrix code reads best with explicit indices.
#![allow(clippy::needless_range_loop)]

/// The block once per listed index, as straight-line code with constant indices: the hot
/// loops are unrolled whatever the optimisation level (the firmware's `ekf-core` is built for
/// size, where the optimiser would keep them rolled; `docs/performance.md`).
macro_rules! unroll {
    ($i:ident in [$($v:literal),*] $body:block) => {{
        $({
            let $i: usize = $v;
            $body
        })*
    }};
}

pub mod accel_calibration;
pub mod axis_map;
pub mod complementary;
pub mod conditioning;
pub mod covariance;
pub mod ekf;
pub mod euler;
pub mod fcmp;
pub mod filter;
pub mod flags;
pub mod gate;
pub mod gyro_only;
pub mod init;
pub mod lever_arm;
pub mod mathf;
pub mod motion;
pub mod quaternion;
pub mod rest;
pub mod sample;
pub mod settings;
pub mod ssukf;
#[cfg(test)]
mod test_rng;
#[cfg(test)]
mod test_text;
pub mod tilt_lowpass;
pub mod ukf;
mod unscented;
pub mod validate;
pub mod vec3;

pub use complementary::Complementary;
pub use ekf::Ekf;
pub use euler::Euler;
pub use filter::AttitudeFilter;
pub use flags::Flags;
pub use gyro_only::GyroOnly;
pub use quaternion::Quaternion;
pub use sample::ImuSample;
pub use settings::Settings;
pub use ssukf::SsUkf;
pub use ukf::Ukf;
pub use vec3::Vec3;

/// Standard gravity, m/s². The accelerometer gate and the calibration model work in units of it.
pub const GRAVITY: f32 = 9.806_65;
