//! Driver for the ST LSM303DLH accelerometer and magnetometer over I²C (`embedded-hal` 1.0).
//!
//! Written for the LSM303DLH as fitted to the iNEMO V2 board (accelerometer at 0x19,
//! magnetometer at 0x1E), not for the later LSM303DLHC, whose magnetometer orders its outputs
//! X, Z, Y and whose gains, accelerometer rates and resolution differ.
//!
//! ```no_run
//! use inemo_ahrs::lsm303dlh::{AccelConfig, Error, Lsm303dlh, MagConfig};
//!
//! # fn demo<I: embedded_hal::i2c::I2c>(i2c: I) -> Result<(), Error<I::Error>> {
//!
//! let mut imu = Lsm303dlh::new(i2c);
//! imu.check_mag_id()?;
//! imu.init_accel(AccelConfig::default())?;
//! imu.init_mag(MagConfig::default())?;
//! let accel_g = imu.read_accel_g()?;
//! let mag_ut = imu.read_mag_ut()?;
//! # let _ = (accel_g, mag_ut);
//! # Ok(())
//! # }
//! ```
//!
//! Samples are returned in the sensor's own axes; the pipeline remaps them to the body frame.

mod config;
mod driver;
mod error;
pub mod register;

#[cfg(test)]
mod tests;

pub use config::{AccelConfig, AccelRate, AccelScale, MagConfig, MagGain, MagRate};
pub use driver::Lsm303dlh;
pub use error::Error;
