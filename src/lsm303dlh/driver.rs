//! The LSM303DLH driver: configuration writes, data-ready polls, sample reads and conversions.

use embedded_hal::i2c::I2c;

use super::config::{AccelConfig, AccelScale, MagConfig, MagGain};
use super::error::Error;
use super::register as reg;

/// Microtesla per gauss.
const UT_PER_GAUSS: f32 = 100.0;

/// LSM303DLH accelerometer and magnetometer on one I²C bus.
///
/// The driver remembers the accelerometer scale and the magnetometer gain it last wrote so that
/// the converting reads use them; until `init_accel` / `init_mag` succeed it assumes the reset
/// values (±2 g, ±1.3 gauss).
#[derive(Debug)]
pub struct Lsm303dlh<I2C> {
    i2c: I2C,
    accel_scale: AccelScale,
    mag_gain: MagGain,
}

impl<I2C: I2c> Lsm303dlh<I2C> {
    /// A driver on `i2c`. Talks to nothing until one of its methods is called.
    pub fn new(i2c: I2C) -> Self {
        Lsm303dlh { i2c, accel_scale: AccelScale::G2, mag_gain: MagGain::Gauss1_3 }
    }

    /// Gives the bus back.
    pub fn destroy(self) -> I2C {
        self.i2c
    }

    /// The bus (its counters, for the log and the self-test).
    pub fn bus(&self) -> &I2C {
        &self.i2c
    }

    /// The bus, for tests that inject faults into it.
    #[cfg(test)]
    pub(crate) fn bus_mut(&mut self) -> &mut I2C {
        &mut self.i2c
    }

    /// The accelerometer scale the conversions use.
    pub fn accel_scale(&self) -> AccelScale {
        self.accel_scale
    }

    /// The magnetometer gain the conversions use.
    pub fn mag_gain(&self) -> MagGain {
        self.mag_gain
    }

    /// Configures the accelerometer: normal power mode at `config.rate` with X, Y and Z enabled
    /// (`CTRL_REG1_A`), then block data update, little-endian output and `config.scale`
    /// (`CTRL_REG4_A`).
    pub fn init_accel(&mut self, config: AccelConfig) -> Result<(), Error<I2C::Error>> {
        let ctrl1 =
            reg::CTRL1_PM_NORMAL | (config.rate.bits() << reg::CTRL1_DR_SHIFT) | reg::CTRL1_XYZ_EN;
        self.write_reg(reg::ACCEL_ADDR, reg::CTRL_REG1_A, ctrl1)?;
        let ctrl4 = reg::CTRL4_BDU | (config.scale.bits() << reg::CTRL4_FS_SHIFT);
        self.write_reg(reg::ACCEL_ADDR, reg::CTRL_REG4_A, ctrl4)?;
        self.accel_scale = config.scale;
        Ok(())
    }

    /// Configures the magnetometer: `config.rate` with normal measurement (`CRA_REG_M`),
    /// `config.gain` (`CRB_REG_M`), then continuous conversion (`MR_REG_M`).
    pub fn init_mag(&mut self, config: MagConfig) -> Result<(), Error<I2C::Error>> {
        let cra = (config.rate.bits() << reg::CRA_DO_SHIFT) | reg::CRA_MS_NORMAL;
        self.write_reg(reg::MAG_ADDR, reg::CRA_REG_M, cra)?;
        self.write_reg(reg::MAG_ADDR, reg::CRB_REG_M, config.gain.bits() << reg::CRB_GN_SHIFT)?;
        self.mag_gain = config.gain;
        self.write_reg(reg::MAG_ADDR, reg::MR_REG_M, reg::MR_CONTINUOUS)
    }

    /// Whether a new accelerometer sample (all three axes) is available (`STATUS_REG_A`
    /// ZYXDA).
    pub fn accel_data_ready(&mut self) -> Result<bool, Error<I2C::Error>> {
        let mut status = [0];
        self.read_regs(reg::ACCEL_ADDR, reg::STATUS_REG_A, &mut status)?;
        Ok(status[0] & reg::STATUS_A_ZYXDA != 0)
    }

    /// The accelerometer sample X, Y, Z in LSB of the 12-bit output (the left-justified 16-bit
    /// registers shifted right by four), read in one auto-incrementing transfer.
    pub fn read_accel_raw(&mut self) -> Result<[i16; 3], Error<I2C::Error>> {
        let mut buf = [0; 6];
        self.read_regs(reg::ACCEL_ADDR, reg::OUT_X_L_A | reg::AUTO_INCREMENT, &mut buf)?;
        Ok([
            i16::from_le_bytes([buf[0], buf[1]]) >> 4,
            i16::from_le_bytes([buf[2], buf[3]]) >> 4,
            i16::from_le_bytes([buf[4], buf[5]]) >> 4,
        ])
    }

    /// The accelerometer sample X, Y, Z in g, in the sensor's axes (a chip lying face up reads
    /// about +1 g on Z).
    pub fn read_accel_g(&mut self) -> Result<[f32; 3], Error<I2C::Error>> {
        let raw = self.read_accel_raw()?;
        let mg_per_lsb = self.accel_scale.mg_per_lsb();
        Ok(raw.map(|v| f32::from(v) * mg_per_lsb / 1000.0))
    }

    /// Whether a new magnetometer sample is available (`SR_REG_M` DRDY).
    pub fn mag_data_ready(&mut self) -> Result<bool, Error<I2C::Error>> {
        let mut status = [0];
        self.read_regs(reg::MAG_ADDR, reg::SR_REG_M, &mut status)?;
        Ok(status[0] & reg::SR_M_DRDY != 0)
    }

    /// The magnetometer sample X, Y, Z in LSB, as the registers hold it (big-endian, in X, Y, Z
    /// order on the DLH). An overflowed axis reads −4096; it is passed through.
    pub fn read_mag_raw(&mut self) -> Result<[i16; 3], Error<I2C::Error>> {
        let mut buf = [0; 6];
        self.read_regs(reg::MAG_ADDR, reg::OUT_X_H_M, &mut buf)?;
        Ok([
            i16::from_be_bytes([buf[0], buf[1]]),
            i16::from_be_bytes([buf[2], buf[3]]),
            i16::from_be_bytes([buf[4], buf[5]]),
        ])
    }

    /// The magnetometer sample X, Y, Z in µT, in the sensor's axes, with the gain's separate X/Y
    /// and Z sensitivities. Returns `Error::MagOverflow` if any axis overflowed.
    pub fn read_mag_ut(&mut self) -> Result<[f32; 3], Error<I2C::Error>> {
        let [x, y, z] = self.read_mag_raw()?;
        if [x, y, z].contains(&reg::MAG_OVERFLOW) {
            return Err(Error::MagOverflow);
        }
        let xy = f32::from(self.mag_gain.lsb_per_gauss_xy());
        let zz = f32::from(self.mag_gain.lsb_per_gauss_z());
        Ok([
            f32::from(x) * UT_PER_GAUSS / xy,
            f32::from(y) * UT_PER_GAUSS / xy,
            f32::from(z) * UT_PER_GAUSS / zz,
        ])
    }

    /// The magnetometer's identification registers IRA, IRB, IRC.
    pub fn mag_id(&mut self) -> Result<[u8; 3], Error<I2C::Error>> {
        let mut id = [0; 3];
        self.read_regs(reg::MAG_ADDR, reg::IRA_REG_M, &mut id)?;
        Ok(id)
    }

    /// Checks that the magnetometer identifies as "H43"; `Error::WrongId` with what it read
    /// otherwise. The LSM303DLHC reads "H43" too, so this proves an LSM303-family magnetometer
    /// answers at 0x1E, not that it is a DLH.
    pub fn check_mag_id(&mut self) -> Result<(), Error<I2C::Error>> {
        let id = self.mag_id()?;
        if id == reg::MAG_ID {
            Ok(())
        } else {
            Err(Error::WrongId(id))
        }
    }

    fn write_reg(&mut self, addr: u8, register: u8, value: u8) -> Result<(), Error<I2C::Error>> {
        self.i2c.write(addr, &[register, value]).map_err(Error::I2c)
    }

    fn read_regs(
        &mut self,
        addr: u8,
        register: u8,
        buf: &mut [u8],
    ) -> Result<(), Error<I2C::Error>> {
        self.i2c.write_read(addr, &[register], buf).map_err(Error::I2c)
    }
}
