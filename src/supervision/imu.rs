//! The LSM303DLH's read schedule with its fault handling, generic over the I²C bus.
//!
//! Every transfer is bounded in time by the bus driver (the application's `BlockingI2c` has
//! DWT timeouts and resets the peripheral between START tries: bus recovery), so a dead bus
//! costs about 1 ms per failed read and never hangs the filter. Here:
//! - a read is tried [`READ_ATTEMPTS`] times (bounded retries);
//! - a cycle without an accelerometer sample is a fault (`fault` of [`Reading`] → the status bit
//!   `I2C_FAULT`); the filter carries on with the gyros alone;
//! - after [`FAILED_CYCLES_BEFORE_REINIT`] such cycles in a row the sensor is configured again
//!   (it may have been power-cycled); while that fails it is retried once per second
//!   (`filter_hz` cycles) and every cycle in between is a fault without bus traffic;
//! - accelerometer data that stops changing ([`super::stuck`]) is dropped and flagged like a
//!   failed read, and the sensor is configured again;
//! - a magnetometer overflow is a reading (counted), not a bus fault.

use embedded_hal::i2c::I2c;

use super::stuck::StuckDetector;
use crate::lsm303dlh::{AccelConfig, AccelRate, Error, Lsm303dlh, MagConfig};

/// Tries of one sample read.
pub const READ_ATTEMPTS: u8 = 2;
/// Consecutive cycles without an accelerometer sample before the sensor is set up again.
pub const FAILED_CYCLES_BEFORE_REINIT: u16 = 3;

/// Running counts, for the log.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ImuCounters {
    /// Failed transfers (every attempt counts).
    pub i2c_errors: u32,
    /// Magnetometer samples with an overflowed axis.
    pub mag_overflows: u32,
    /// Configurations tried (the first included).
    pub inits: u32,
    /// Times the accelerometer data was found stuck.
    pub stuck: u32,
}

/// Something worth a log line that happened during a [`Imu::read`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImuEvent<E> {
    /// The sensor was configured again and answers.
    Reconfigured,
    /// Configuring it failed (retried in a second).
    ConfigureFailed(Error<E>),
    /// No accelerometer sample for [`FAILED_CYCLES_BEFORE_REINIT`] cycles: it will be
    /// configured again at the next cycle.
    NotAnswering,
    /// The accelerometer data is stuck: it will be configured again at the next cycle.
    Stuck,
}

/// One cycle's samples, sensor axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading<E> {
    /// Accelerometer, g; `None` after a failure or when stuck.
    pub accel_g: Option<[f32; 3]>,
    /// Magnetometer, µT; `None` when not due this cycle, overflowed or failed.
    pub mag_ut: Option<[f32; 3]>,
    /// A transfer failed, the sensor is not configured or its data is stuck:
    /// `Status::I2C_FAULT`.
    pub fault: bool,
    /// What to log, if anything.
    pub event: Option<ImuEvent<E>>,
}

impl<E> Reading<E> {
    const fn fault(event: Option<ImuEvent<E>>) -> Self {
        Reading { accel_g: None, mag_ut: None, fault: true, event }
    }
}

/// The accelerometer data rate for a filter rate: the default 100 Hz up to a 100 Hz filter,
/// above that 400 Hz, so that every cycle reads a new sample rather than a repeated one.
pub fn accel_rate(filter_hz: u16) -> AccelRate {
    match filter_hz {
        0..=100 => AccelRate::Hz100,
        101..=400 => AccelRate::Hz400,
        _ => AccelRate::Hz1000,
    }
}

/// The sensor and its read schedule.
pub struct Imu<I2C> {
    dev: Lsm303dlh<I2C>,
    accel: AccelConfig,
    mag: MagConfig,
    configured: bool,
    failed_cycles: u16,
    /// Cycles until the next configuration attempt while not configured.
    retry_in: u16,
    retry_interval: u16,
    /// The magnetometer is read every `mag_divider` cycles, so no faster than its data rate.
    mag_divider: u16,
    mag_phase: u16,
    stuck: StuckDetector,
    /// Counts, for the log.
    pub counters: ImuCounters,
}

impl<I2C: I2c> Imu<I2C> {
    /// The sensor on `bus`, to be read once per cycle at `filter_hz`. Talks to nothing yet.
    pub fn new(bus: I2C, filter_hz: u16) -> Self {
        let filter_hz = filter_hz.max(1);
        let (accel, divider) = Self::schedule(filter_hz);
        Imu {
            dev: Lsm303dlh::new(bus),
            accel,
            mag: MagConfig::new(),
            configured: false,
            failed_cycles: 0,
            retry_in: 0,
            retry_interval: filter_hz,
            mag_divider: divider,
            mag_phase: 0,
            stuck: StuckDetector::default(),
            counters: ImuCounters::default(),
        }
    }

    /// A new filter rate (a command changed it): the accelerometer rate and the magnetometer
    /// schedule follow it; the sensor is configured again at the next read if its
    /// accelerometer rate changes.
    pub fn set_filter_rate(&mut self, filter_hz: u16) {
        let old_rate = self.accel.rate;
        (self.accel, self.mag_divider) = Self::schedule(filter_hz);
        self.retry_interval = filter_hz.max(1);
        self.mag_phase = 0;
        if self.configured && old_rate != self.accel.rate {
            self.configured = false;
            self.retry_in = 0;
        }
    }

    /// Accelerometer configuration and magnetometer divider for a filter rate.
    fn schedule(filter_hz: u16) -> (AccelConfig, u16) {
        let filter_hz = filter_hz.max(1);
        let accel = AccelConfig::new().with_rate(accel_rate(filter_hz));
        // ceil(filter / mag rate) in quarter hertz (the slowest mag rate is 0.75 Hz).
        let mag_qhz = ((MagConfig::new().rate.hz() * 4.0) as u32).max(1);
        let divider = (u32::from(filter_hz) * 4).div_ceil(mag_qhz).clamp(1, u32::from(u16::MAX));
        (accel, divider as u16)
    }

    /// The bus (its counters).
    pub fn bus(&self) -> &I2C {
        self.dev.bus()
    }

    /// Whether the last configuration succeeded.
    pub fn configured(&self) -> bool {
        self.configured
    }

    /// The accelerometer configuration written.
    pub fn accel_config(&self) -> AccelConfig {
        self.accel
    }

    /// Checks the magnetometer's identification, then configures the accelerometer and the
    /// magnetometer. A wrong identification does not stop it (the DLHC reads the same): it is
    /// returned as `Ok(Some(id))` for the log.
    pub fn configure(&mut self) -> Result<Option<[u8; 3]>, Error<I2C::Error>> {
        self.counters.inits = self.counters.inits.saturating_add(1);
        self.configured = false;
        let wrong_id = match self.dev.check_mag_id() {
            Ok(()) => None,
            Err(Error::WrongId(id)) => Some(id),
            Err(e) => return Err(e),
        };
        self.dev.init_accel(self.accel)?;
        self.dev.init_mag(self.mag)?;
        self.configured = true;
        self.failed_cycles = 0;
        self.mag_phase = 0;
        self.stuck.reset();
        Ok(wrong_id)
    }

    /// This cycle's samples. Bounded in time (at most [`READ_ATTEMPTS`] transfers per sensor,
    /// or one configuration); never panics.
    pub fn read(&mut self) -> Reading<I2C::Error> {
        let mut event = None;
        if !self.configured {
            if self.retry_in > 0 {
                self.retry_in -= 1;
                return Reading::fault(None);
            }
            self.retry_in = self.retry_interval;
            match self.configure() {
                Ok(_) => event = Some(ImuEvent::Reconfigured),
                Err(e) => {
                    self.counters.i2c_errors = self.counters.i2c_errors.saturating_add(1);
                    return Reading::fault(Some(ImuEvent::ConfigureFailed(e)));
                }
            }
        }
        let accel_g = match self.attempt(|d| d.read_accel_g()) {
            Ok(a) => a,
            Err(_) => {
                self.stuck.reset();
                self.failed_cycles = self.failed_cycles.saturating_add(1);
                if self.failed_cycles >= FAILED_CYCLES_BEFORE_REINIT {
                    self.configured = false;
                    self.retry_in = 0;
                    event = Some(ImuEvent::NotAnswering);
                }
                // The bus is likely down: skip the magnetometer this cycle.
                return Reading::fault(event);
            }
        };
        if self.stuck.push(accel_g) {
            self.counters.stuck = self.counters.stuck.saturating_add(1);
            self.configured = false;
            self.retry_in = 0;
            return Reading::fault(Some(ImuEvent::Stuck));
        }
        self.failed_cycles = 0;
        let mut reading = Reading { accel_g: Some(accel_g), mag_ut: None, fault: false, event };
        if self.mag_phase == 0 {
            match self.attempt(|d| d.read_mag_ut()) {
                Ok(m) => reading.mag_ut = Some(m),
                Err(Error::MagOverflow) => {
                    self.counters.mag_overflows = self.counters.mag_overflows.saturating_add(1)
                }
                Err(_) => reading.fault = true,
            }
        }
        self.mag_phase = (self.mag_phase + 1) % self.mag_divider.max(1);
        reading
    }

    /// `f` up to [`READ_ATTEMPTS`] times while it fails on the bus; a magnetometer overflow
    /// is a reading, not a bus error, and is returned at once.
    fn attempt<T>(
        &mut self,
        mut f: impl FnMut(&mut Lsm303dlh<I2C>) -> Result<T, Error<I2C::Error>>,
    ) -> Result<T, Error<I2C::Error>> {
        let mut result = f(&mut self.dev);
        for _ in 1..READ_ATTEMPTS {
            match result {
                Err(Error::I2c(_)) => {
                    self.counters.i2c_errors = self.counters.i2c_errors.saturating_add(1);
                    result = f(&mut self.dev);
                }
                _ => break,
            }
        }
        if let Err(Error::I2c(_)) = result {
            self.counters.i2c_errors = self.counters.i2c_errors.saturating_add(1);
        }
        result
    }
}

#[cfg(test)]
#[path = "imu_tests.rs"]
mod tests;
