//! The LSM303DLH on I²C2: configuration, reads with bounded retries, and recovery.
//!
//! Every transfer is bounded by `BlockingI2c`'s DWT timeouts ([`START_TIMEOUT_US`] per START
//! try, [`START_RETRIES`] tries with a peripheral reset in between, [`ADDR_TIMEOUT_US`],
//! [`DATA_TIMEOUT_US`] per byte), so a dead or stuck bus costs about 1 ms per failed read and
//! never hangs the filter. A read is tried [`READ_ATTEMPTS`] times; after
//! [`FAILED_CYCLES_BEFORE_REINIT`] cycles without an accelerometer sample the sensor is
//! configured again (it may have been power-cycled), at most once per second.

use inemo_ahrs::lsm303dlh::{AccelConfig, AccelRate, Error, Lsm303dlh, MagConfig};
use stm32f1xx_hal::{
    i2c::{self, BlockingI2c},
    pac,
};

/// The bus type.
pub type Bus = BlockingI2c<pac::I2C2>;
type DevError = Error<i2c::Error>;

/// Time for the START condition to appear, µs (it takes a few µs on an idle bus).
pub const START_TIMEOUT_US: u32 = 200;
/// START tries (the peripheral is reset after each failed one; must be at least 1).
pub const START_RETRIES: u8 = 3;
/// Time for the address phase, µs (25 µs at 400 kHz).
pub const ADDR_TIMEOUT_US: u32 = 200;
/// Time per data byte, µs (22.5 µs at 400 kHz).
pub const DATA_TIMEOUT_US: u32 = 200;
/// Tries of one sample read.
const READ_ATTEMPTS: u8 = 2;
/// Consecutive cycles without an accelerometer sample before the sensor is set up again.
const FAILED_CYCLES_BEFORE_REINIT: u16 = 3;

/// Running counts, for the log.
#[derive(Clone, Copy, Debug, Default)]
pub struct ImuCounters {
    /// Failed transfers (every attempt counts).
    pub i2c_errors: u32,
    /// Magnetometer samples with an overflowed axis.
    pub mag_overflows: u32,
    /// Configurations written (the first included).
    pub inits: u32,
}

/// One cycle's samples, sensor axes.
#[derive(Clone, Copy, Debug, Default)]
pub struct Reading {
    /// Accelerometer, g; `None` after a failure.
    pub accel_g: Option<[f32; 3]>,
    /// Magnetometer, µT; `None` when not due this cycle, overflowed or failed.
    pub mag_ut: Option<[f32; 3]>,
    /// An I²C transfer failed (or the sensor is not configured): `Status::I2C_FAULT`.
    pub fault: bool,
}

/// The sensor and its read schedule.
pub struct Imu {
    dev: Lsm303dlh<Bus>,
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
    /// Counts, for the log.
    pub counters: ImuCounters,
}

/// The accelerometer data rate for a filter rate: the default 100 Hz up to a 100 Hz filter,
/// above that 400 Hz, so that every cycle reads a new sample rather than a repeated one.
fn accel_rate(filter_hz: u16) -> AccelRate {
    match filter_hz {
        0..=100 => AccelRate::Hz100,
        101..=400 => AccelRate::Hz400,
        _ => AccelRate::Hz1000,
    }
}

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

impl Imu {
    /// The sensor on `bus`, to be read once per cycle at `filter_hz`. Talks to nothing yet.
    pub fn new(bus: Bus, filter_hz: u16) -> Self {
        let filter_hz = filter_hz.max(1);
        let (accel, divider) = Imu::new_schedule(filter_hz);
        let mag = MagConfig::new();
        Imu {
            dev: Lsm303dlh::new(bus),
            accel,
            mag,
            configured: false,
            failed_cycles: 0,
            retry_in: 0,
            retry_interval: filter_hz,
            mag_divider: divider,
            mag_phase: 0,
            counters: ImuCounters::default(),
        }
    }

    /// A new filter rate (a command changed it): the accelerometer rate and the magnetometer
    /// schedule follow it; the sensor is configured again at the next read if its
    /// accelerometer rate changes.
    #[cfg(feature = "serial-commands")]
    pub fn set_filter_rate(&mut self, filter_hz: u16) {
        let old_rate = self.accel.rate;
        (self.accel, self.mag_divider) = Imu::new_schedule(filter_hz);
        self.retry_interval = filter_hz.max(1);
        self.mag_phase = 0;
        if self.configured && old_rate != self.accel.rate {
            self.configured = false;
            self.retry_in = 0;
        }
    }

    /// Accelerometer configuration and magnetometer divider for a filter rate.
    fn new_schedule(filter_hz: u16) -> (AccelConfig, u16) {
        let filter_hz = filter_hz.max(1);
        let accel = AccelConfig::new().with_rate(accel_rate(filter_hz));
        // ceil(filter / mag rate) in quarter hertz (the slowest mag rate is 0.75 Hz).
        let mag_qhz = ((MagConfig::new().rate.hz() * 4.0) as u32).max(1);
        let divider = (u32::from(filter_hz) * 4).div_ceil(mag_qhz).clamp(1, u32::from(u16::MAX));
        (accel, divider as u16)
    }

    /// Whether the last configuration succeeded.
    pub fn configured(&self) -> bool {
        self.configured
    }

    /// The accelerometer configuration written.
    pub fn accel_config(&self) -> AccelConfig {
        self.accel
    }

    /// Checks the magnetometer's identification (a mismatch is only logged: the DLHC reads
    /// the same), then configures the accelerometer and the magnetometer.
    pub fn configure(&mut self) -> Result<(), DevError> {
        self.counters.inits = self.counters.inits.saturating_add(1);
        self.configured = false;
        match self.dev.check_mag_id() {
            Ok(()) => {}
            Err(Error::WrongId(id)) => {
                defmt::warn!("LSM303DLH: magnetometer identifies as {=[u8]:a}", &id[..])
            }
            Err(e) => return Err(e),
        }
        self.dev.init_accel(self.accel)?;
        self.dev.init_mag(self.mag)?;
        self.configured = true;
        self.failed_cycles = 0;
        self.mag_phase = 0;
        Ok(())
    }

    /// This cycle's samples. Bounded in time; never panics.
    pub fn read(&mut self) -> Reading {
        const FAULT: Reading = Reading { accel_g: None, mag_ut: None, fault: true };
        if !self.configured {
            if self.retry_in > 0 {
                self.retry_in -= 1;
                return FAULT;
            }
            self.retry_in = self.retry_interval;
            match self.configure() {
                Ok(()) => defmt::println!("LSM303DLH configured again"),
                Err(e) => {
                    self.counters.i2c_errors = self.counters.i2c_errors.saturating_add(1);
                    defmt::warn!("LSM303DLH configuration failed: {=str}", describe(&e));
                    return FAULT;
                }
            }
        }

        let accel_g = match self.attempt(|d| d.read_accel_g()) {
            Ok(a) => a,
            Err(_) => {
                self.failed_cycles = self.failed_cycles.saturating_add(1);
                if self.failed_cycles >= FAILED_CYCLES_BEFORE_REINIT {
                    defmt::warn!("LSM303DLH not answering: configuring it again");
                    self.configured = false;
                    self.retry_in = 0;
                }
                // The bus is likely down: skip the magnetometer this cycle.
                return FAULT;
            }
        };
        self.failed_cycles = 0;

        let mut reading = Reading { accel_g: Some(accel_g), mag_ut: None, fault: false };
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
        mut f: impl FnMut(&mut Lsm303dlh<Bus>) -> Result<T, DevError>,
    ) -> Result<T, DevError> {
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
