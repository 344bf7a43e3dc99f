//! The one interface every attitude filter implements, so that the firmware, the replay tool
//! and the benchmarks drive them all the same way.

use crate::{Euler, Flags, ImuSample, Quaternion, Vec3};

/// An attitude filter fed with conditioned IMU samples.
///
/// Every implementation starts with the initialisation window of
/// [`crate::settings::InitSettings`] (tilt from the averaged accelerometer, yaw given,
/// gyro bias from the averaged gyro) unless [`AttitudeFilter::set_attitude`] starts it
/// directly.
pub trait AttitudeFilter {
    /// Short name for tables and logs (`"ekf"`, `"ukf"`, ...).
    fn name(&self) -> &'static str;

    /// Process one sample. Returns the flags describing this update. Never panics; invalid
    /// input is flagged and does not reach the state.
    fn update(&mut self, sample: &ImuSample) -> Flags;

    /// Attitude estimate: unit quaternion rotating body (FRD) vectors into NED.
    fn attitude(&self) -> Quaternion;

    /// Attitude estimate as Z-Y-X Euler angles, rad.
    fn euler(&self) -> Euler {
        Euler::from_quaternion(self.attitude())
    }

    /// Current gyro-bias estimate, rad/s, body frame (FRD). Zero for filters without one.
    fn gyro_bias(&self) -> Vec3;

    /// True once the initialisation window has completed (or the attitude was set).
    fn is_initialised(&self) -> bool;

    /// Set yaw (rad, rotation about NED z) keeping roll and pitch. During initialisation it
    /// sets the yaw that the window will start from.
    fn set_yaw(&mut self, yaw: f32);

    /// Skip (or end) initialisation and start from attitude `q` (normalised here) and gyro
    /// bias `bias` (rad/s, body FRD).
    fn set_attitude(&mut self, q: Quaternion, bias: Vec3);

    /// Restart from scratch: a new initialisation window with the configured initial yaw.
    fn reset(&mut self);
}
