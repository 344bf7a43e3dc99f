//! Error type of the LSM303DLH driver.

use core::fmt;

/// An error of the LSM303DLH driver, generic over the I²C bus error `E`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error<E> {
    /// The I²C transfer failed.
    I2c(E),
    /// The magnetometer's identification registers (IRA, IRB, IRC) did not read "H43"; holds
    /// what they read.
    WrongId([u8; 3]),
    /// At least one magnetometer axis read −4096 (0xF000): the field on that axis is beyond the
    /// configured range. Choose a larger `MagGain` range or move away from the source.
    MagOverflow,
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::I2c(e) => write!(f, "LSM303DLH I2C error: {e:?}"),
            Error::WrongId(id) => write!(
                f,
                "LSM303DLH magnetometer identification {:#04x} {:#04x} {:#04x}, expected \"H43\"",
                id[0], id[1], id[2]
            ),
            Error::MagOverflow => f.write_str("LSM303DLH magnetometer overflow"),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}
