//! Fault injection into the LSM303DLH read schedule: a simulated sensor on a fake bus that
//! can drop off the bus, fail a number of transfers, or freeze its accelerometer output.

use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, Operation};

use super::*;
use crate::lsm303dlh::register as reg;

/// A simulated LSM303DLH. The accelerometer sample changes at every read (noise of one step)
/// unless frozen; the magnetometer reads a constant field.
#[derive(Default)]
struct FakeBus {
    /// Transfers that fail from now on (then it works again).
    fail_next: u32,
    /// Every transfer fails (sensor unplugged, bus stuck).
    down: bool,
    /// The accelerometer repeats its last sample.
    frozen: bool,
    /// Transfers tried, failed ones included.
    transfers: u32,
    /// Configuration writes received.
    config_writes: u32,
    sample: i16,
    /// Magnetometer X reads −4096 (overflow).
    mag_overflow: bool,
    /// Transfers to the magnetometer fail.
    mag_down: bool,
}

impl ErrorType for FakeBus {
    type Error = ErrorKind;
}

impl I2c for FakeBus {
    fn transaction(&mut self, addr: u8, ops: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        self.transfers += 1;
        if self.down {
            return Err(ErrorKind::NoAcknowledge(embedded_hal::i2c::NoAcknowledgeSource::Address));
        }
        if self.mag_down && addr == reg::MAG_ADDR {
            return Err(ErrorKind::Other);
        }
        if self.fail_next > 0 {
            self.fail_next -= 1;
            return Err(ErrorKind::Other);
        }
        let mut register = 0u8;
        for op in ops.iter_mut() {
            match op {
                Operation::Write(bytes) => {
                    register = bytes.first().copied().unwrap_or(0) & 0x7F;
                    if bytes.len() > 1 {
                        self.config_writes += 1;
                    }
                }
                Operation::Read(buf) => {
                    if addr == reg::ACCEL_ADDR && register == reg::OUT_X_L_A {
                        if !self.frozen {
                            self.sample = (self.sample + 1) % 3;
                        }
                        // x, y, z = noise, noise, 1 g (1000 mg at ±2 g: 1 mg per count).
                        let counts = [self.sample, -self.sample, 1000 + self.sample];
                        for (i, c) in counts.iter().enumerate() {
                            buf[2 * i..2 * i + 2].copy_from_slice(&(c << 4).to_le_bytes());
                        }
                    } else if addr == reg::MAG_ADDR && register == reg::IRA_REG_M {
                        buf.copy_from_slice(b"H43");
                    } else if addr == reg::MAG_ADDR && register == reg::OUT_X_H_M {
                        let x: i16 = if self.mag_overflow { -4096 } else { 100 };
                        for (i, c) in [x, 200, -300].iter().enumerate() {
                            buf[2 * i..2 * i + 2].copy_from_slice(&c.to_be_bytes());
                        }
                    } else {
                        buf.fill(0);
                    }
                }
            }
        }
        Ok(())
    }
}

const RATE_HZ: u16 = 50;

fn configured() -> Imu<FakeBus> {
    let mut imu = Imu::new(FakeBus::default(), RATE_HZ);
    assert_eq!(imu.configure(), Ok(None));
    imu
}

fn bus(imu: &mut Imu<FakeBus>) -> &mut FakeBus {
    imu.dev.bus_mut()
}

#[test]
fn a_healthy_sensor_gives_samples_and_the_magnetometer_at_its_rate() {
    let mut imu = configured();
    let mut mags = 0;
    for _ in 0..RATE_HZ {
        let r = imu.read();
        assert!(!r.fault && r.event.is_none());
        let a = r.accel_g.expect("sample");
        assert!((a[2] - 1.0).abs() < 0.01);
        mags += usize::from(r.mag_ut.is_some());
    }
    // 50 Hz filter, 75 Hz magnetometer (default): every cycle.
    assert_eq!(mags, usize::from(RATE_HZ));
    assert_eq!(imu.counters, ImuCounters { inits: 1, ..ImuCounters::default() });
    // 200 Hz filter: no faster than the magnetometer's 75 Hz, every 3rd cycle.
    imu.set_filter_rate(200);
    let mags = (0..200).filter(|_| imu.read().mag_ut.is_some()).count();
    assert_eq!(mags, 67);
}

#[test]
fn a_transient_error_is_retried_within_the_cycle() {
    let mut imu = configured();
    bus(&mut imu).fail_next = 1;
    let before = bus(&mut imu).transfers;
    let r = imu.read();
    assert!(!r.fault && r.accel_g.is_some(), "{r:?}");
    // The failed try, its retry and the magnetometer read.
    assert_eq!(bus(&mut imu).transfers - before, 3);
    assert_eq!(imu.counters.i2c_errors, 1);
}

#[test]
fn a_failed_read_is_bounded_flagged_and_skips_the_magnetometer() {
    let mut imu = configured();
    bus(&mut imu).fail_next = u32::from(READ_ATTEMPTS);
    let before = bus(&mut imu).transfers;
    let r = imu.read();
    assert!(r.fault && r.accel_g.is_none() && r.mag_ut.is_none());
    assert_eq!(bus(&mut imu).transfers - before, u32::from(READ_ATTEMPTS));
    assert_eq!(imu.counters.i2c_errors, u32::from(READ_ATTEMPTS));
    // The next cycle works again.
    assert!(!imu.read().fault);
}

#[test]
fn a_dead_sensor_is_configured_again_once_per_second_and_recovers() {
    let mut imu = configured();
    bus(&mut imu).down = true;
    // Cycles without a sample, then the re-configuration is scheduled.
    for i in 1..=FAILED_CYCLES_BEFORE_REINIT {
        let r = imu.read();
        assert!(r.fault);
        let expect = (i == FAILED_CYCLES_BEFORE_REINIT).then_some(ImuEvent::NotAnswering);
        assert_eq!(r.event, expect, "cycle {i}");
    }
    // Ten seconds down: one configuration try per second, no bus traffic in between, and
    // every cycle bounded to at most READ_ATTEMPTS transfers.
    let mut tries = 0;
    for _ in 0..10 * RATE_HZ {
        let before = bus(&mut imu).transfers;
        let r = imu.read();
        assert!(r.fault && r.accel_g.is_none());
        let transfers = bus(&mut imu).transfers - before;
        assert!(transfers <= u32::from(READ_ATTEMPTS));
        if let Some(ImuEvent::ConfigureFailed(e)) = r.event {
            assert!(matches!(e, Error::I2c(ErrorKind::NoAcknowledge(_))));
            assert_eq!(transfers, 1);
            tries += 1;
        } else {
            assert_eq!((r.event, transfers), (None, 0));
        }
    }
    assert_eq!(tries, 10);
    assert!(!imu.configured());
    // Back on the bus: configured again within a second, then samples flow.
    bus(&mut imu).down = false;
    let writes = bus(&mut imu).config_writes;
    let mut back = None;
    for i in 0..=RATE_HZ {
        let r = imu.read();
        if !r.fault {
            back = Some(i);
            assert_eq!(r.event, Some(ImuEvent::Reconfigured));
            break;
        }
    }
    assert!(back.is_some(), "not back within a second");
    assert!(imu.configured());
    // CTRL_REG1_A, CTRL_REG4_A, CRA_REG_M, CRB_REG_M, MR_REG_M written again.
    assert_eq!(bus(&mut imu).config_writes - writes, 5);
    assert!(imu.read().accel_g.is_some());
}

#[test]
fn stuck_accelerometer_data_is_dropped_flagged_and_the_sensor_configured_again() {
    let mut imu = configured();
    for _ in 0..10 {
        assert!(!imu.read().fault);
    }
    bus(&mut imu).frozen = true;
    // The repeats pass until the limit...
    let mut cycles = 0;
    let stuck_at = loop {
        cycles += 1;
        let r = imu.read();
        if r.fault {
            break r;
        }
        assert!(cycles <= STUCK, "never flagged");
    };
    assert_eq!(cycles, STUCK);
    assert_eq!(stuck_at.event, Some(ImuEvent::Stuck));
    assert!(stuck_at.accel_g.is_none() && stuck_at.mag_ut.is_none());
    assert_eq!(imu.counters.stuck, 1);
    // ...then it is configured again at once; still frozen, it is flagged again after the
    // limit, never delivering a stuck sample for longer than that.
    let writes = bus(&mut imu).config_writes;
    assert_eq!(imu.read().event, Some(ImuEvent::Reconfigured));
    assert_eq!(bus(&mut imu).config_writes - writes, 5);
    // A sensor that converts again after the re-configuration is used again.
    bus(&mut imu).frozen = false;
    for _ in 0..100 {
        let r = imu.read();
        assert!(!r.fault && r.accel_g.is_some());
    }
    assert_eq!(imu.counters.stuck, 1);
}

/// Cycles from the start of the freeze to the flag: the first frozen read may still differ
/// from the one before it, then [`super::super::stuck::STUCK_CYCLES`] repeats.
const STUCK: u16 = super::super::stuck::STUCK_CYCLES;

#[test]
fn a_magnetometer_overflow_is_counted_not_a_fault() {
    let mut imu = configured();
    bus(&mut imu).mag_overflow = true;
    let r = imu.read();
    assert!(!r.fault && r.accel_g.is_some() && r.mag_ut.is_none());
    assert_eq!(imu.counters.mag_overflows, 1);
    assert_eq!(imu.counters.i2c_errors, 0);
}

#[test]
fn a_failed_magnetometer_read_is_a_fault_but_keeps_the_accelerometer() {
    let mut imu = configured();
    bus(&mut imu).mag_down = true;
    let before = bus(&mut imu).transfers;
    let r = imu.read();
    assert!(r.fault && r.accel_g.is_some() && r.mag_ut.is_none());
    // One accelerometer read, READ_ATTEMPTS magnetometer tries.
    assert_eq!(bus(&mut imu).transfers - before, 1 + u32::from(READ_ATTEMPTS));
    // Not a reason to configure the sensor again: the accelerometer answers.
    for _ in 0..10 {
        assert!(imu.read().accel_g.is_some());
    }
    assert!(imu.configured());
}

#[test]
fn a_faster_filter_rate_raises_the_accelerometer_rate_and_reconfigures() {
    let mut imu = configured();
    assert_eq!(imu.accel_config().rate, AccelRate::Hz100);
    imu.set_filter_rate(200);
    assert_eq!(imu.accel_config().rate, AccelRate::Hz400);
    assert!(!imu.configured());
    assert_eq!(imu.read().event, Some(ImuEvent::Reconfigured));
    // Same accelerometer rate: no re-configuration.
    imu.set_filter_rate(150);
    assert!(imu.configured());
    assert_eq!(accel_rate(100), AccelRate::Hz100);
    assert_eq!(accel_rate(101), AccelRate::Hz400);
}
