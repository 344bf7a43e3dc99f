//! The LSM303DLH on I²C2: the bus, its timeouts, and the names of its errors for the log. The
//! read schedule with its retries, re-configuration and stuck-data detection is the library's
//! [`inemo_ahrs::supervision::imu::Imu`] (host-tested with injected faults).
//!
//! Every transfer is bounded by `BlockingI2c`'s DWT timeouts ([`START_TIMEOUT_US`] per START
//! try, [`START_RETRIES`] tries with a peripheral reset in between — the bus recovery —,
//! [`ADDR_TIMEOUT_US`], [`DATA_TIMEOUT_US`] per byte), so a dead or stuck bus costs about 1 ms
//! per failed read and never hangs the filter.

use inemo_ahrs::lsm303dlh::Error;
use inemo_ahrs::supervision::imu::ImuEvent;
use stm32f1xx_hal::{
    i2c::{self, BlockingI2c},
    pac,
};

/// The bus type.
pub type Bus = BlockingI2c<pac::I2C2>;
/// The sensor with its read schedule on I²C2.
pub type Imu = inemo_ahrs::supervision::imu::Imu<Bus>;
type DevError = Error<i2c::Error>;

/// Time for the START condition to appear, µs (it takes a few µs on an idle bus).
pub const START_TIMEOUT_US: u32 = 200;
/// START tries (the peripheral is reset after each failed one; must be at least 1).
pub const START_RETRIES: u8 = 3;
/// Time for the address phase, µs (25 µs at 400 kHz).
pub const ADDR_TIMEOUT_US: u32 = 200;
/// Time per data byte, µs (22.5 µs at 400 kHz).
pub const DATA_TIMEOUT_US: u32 = 200;

/// A short name of an error, for the log (no `core::fmt` on the target).
pub fn describe(e: &DevError) -> &'static str {
    match e {
        Error::I2c(i2c::Error::NoAcknowledge(_)) => "no acknowledge",
        Error::I2c(i2c::Error::Timeout) => "timeout",
        Error::I2c(i2c::Error::ArbitrationLoss) => "arbitration lost",
        Error::I2c(i2c::Error::Overrun) => "overrun",
        Error::I2c(_) => "bus error",
        Error::WrongId(_) => "wrong identification",
        Error::MagOverflow => "magnetometer overflow",
    }
}

/// Logs what a read reported.
pub fn log_event(event: &ImuEvent<i2c::Error>) {
    match event {
        ImuEvent::Reconfigured => defmt::println!("LSM303DLH configured again"),
        ImuEvent::ConfigureFailed(e) => {
            defmt::warn!("LSM303DLH configuration failed: {=str}", describe(e))
        }
        ImuEvent::NotAnswering => defmt::warn!("LSM303DLH not answering: configuring it again"),
        ImuEvent::Stuck => defmt::warn!("LSM303DLH data stuck: configuring it again"),
    }
}
