//! One IMU sample as every filter takes it: conditioned, in the body frame, SI units.

use crate::Vec3;

/// A conditioned IMU sample (after axis map, calibration and lever-arm compensation, see
/// [`crate::conditioning`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImuSample {
    /// Time since the previous sample, s. The first sample's `dt` is only used to time the
    /// initialisation window. Non-positive or non-finite values are rejected.
    pub dt: f32,
    /// Angular rate of the body relative to NED, in the body frame (FRD), rad/s, including
    /// the sensor's bias (the filters estimate it).
    pub gyro: Vec3,
    /// Specific force (acceleration minus gravity) in the body frame (FRD), m/s². A level,
    /// still board reads about `(0, 0, −9.81)`.
    pub accel: Vec3,
    /// Magnetic field in the body frame (FRD), µT, when a magnetometer sample is available.
    pub mag: Option<Vec3>,
}

impl ImuSample {
    /// A sample without magnetometer data.
    pub const fn new(dt: f32, gyro: Vec3, accel: Vec3) -> Self {
        ImuSample { dt, gyro, accel, mag: None }
    }
}
