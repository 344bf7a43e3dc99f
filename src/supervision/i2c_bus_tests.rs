//! The bus clear against a model of a stuck slave (the I²C specification's bit-level rules,
//! UM10204 §3.1: data changes while SCL is low; SDA rising while SCL is high is a STOP, falling
//! a START; a transmitter's byte is eight bits MSB first and the master's (N)ACK on the ninth
//! clock), and the guarded bus against mocks that check the interrupt mask.

use core::cell::Cell;
use std::rc::Rc;

use embedded_hal::i2c::{ErrorKind, I2c, NoAcknowledgeSource, Operation};

use super::*;
use crate::lsm303dlh::{register as reg, Lsm303dlh};

/// What the model slave is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Slave {
    /// Waiting for a START; SDA released.
    Idle,
    /// Sending `byte`, MSB first: `bit` 0–7 drives bit 7−`bit`; 8 is the acknowledge slot
    /// (SDA released, the master's ACK read on the rising edge).
    Transmit { byte: u8, bit: u8, acked: bool },
    /// Receiving (address or data) bit `bit` 0–7; 8: acknowledging it (SDA held low).
    Receive { bit: u8 },
}

/// Two open-drain lines with pull-ups, a master's drivers, one slave and optional shorts.
struct Model {
    master_scl: bool,
    master_sda: bool,
    slave: Slave,
    scl_short: bool,
    sda_short: bool,
    prev_scl: bool,
    prev_sda: bool,
    /// SCL falling edges (clock pulses).
    pulses: u32,
    stops: u32,
    starts: u32,
}

impl Model {
    fn new(slave: Slave) -> Self {
        let mut m = Model {
            master_scl: true,
            master_sda: true,
            slave,
            scl_short: false,
            sda_short: false,
            prev_scl: true,
            prev_sda: true,
            pulses: 0,
            stops: 0,
            starts: 0,
        };
        m.prev_scl = m.scl();
        m.prev_sda = m.sda();
        m
    }

    fn slave_sda(&self) -> bool {
        match self.slave {
            Slave::Transmit { byte, bit, .. } if bit < 8 => byte >> (7 - bit) & 1 == 1,
            Slave::Receive { bit: 8 } => false,
            _ => true,
        }
    }

    fn scl(&self) -> bool {
        self.master_scl && !self.scl_short
    }

    fn sda(&self) -> bool {
        self.master_sda && self.slave_sda() && !self.sda_short
    }

    /// The slave reacts to the lines' change.
    fn settle(&mut self) {
        let (scl, sda) = (self.scl(), self.sda());
        if scl != self.prev_scl {
            if !scl {
                self.pulses += 1;
                self.slave = match self.slave {
                    Slave::Transmit { byte, bit, acked } if bit < 8 => {
                        Slave::Transmit { byte, bit: bit + 1, acked }
                    }
                    // Acknowledged: the next byte (all zeros: the worst case).
                    Slave::Transmit { bit: 8, acked: true, .. } => {
                        Slave::Transmit { byte: 0, bit: 0, acked: false }
                    }
                    Slave::Receive { bit } if bit < 8 => Slave::Receive { bit: bit + 1 },
                    Slave::Receive { .. } => Slave::Receive { bit: 0 },
                    s => s,
                };
            } else if let Slave::Transmit { byte, bit: 8, .. } = self.slave {
                // The master's acknowledge: low = ACK (send on), high = NACK (done).
                self.slave =
                    if sda { Slave::Idle } else { Slave::Transmit { byte, bit: 8, acked: true } };
            }
        } else if scl && sda != self.prev_sda {
            if sda {
                self.stops += 1;
                self.slave = Slave::Idle;
            } else {
                self.starts += 1;
                self.slave = Slave::Receive { bit: 0 };
            }
        }
        self.prev_scl = self.scl();
        self.prev_sda = self.sda();
    }
}

impl BusLines for Model {
    fn set_scl(&mut self, high: bool) {
        self.master_scl = high;
        self.settle();
    }
    fn set_sda(&mut self, high: bool) {
        self.master_sda = high;
        self.settle();
    }
    fn scl_high(&mut self) -> bool {
        self.scl()
    }
    fn sda_high(&mut self) -> bool {
        self.sda()
    }
    fn half_period(&mut self) {}
}

#[test]
fn a_slave_cut_off_in_any_bit_of_any_byte_is_freed_within_nine_clocks_and_a_stop() {
    for byte in 0..=255u8 {
        for bit in 0..=8u8 {
            let mut m = Model::new(Slave::Transmit { byte, bit, acked: false });
            let found = clear_bus(&mut m);
            let Clear::Freed { clocks } = found else {
                panic!("byte {byte:#04x} bit {bit}: {found:?}");
            };
            assert!(clocks <= CLEAR_CLOCKS, "byte {byte:#04x} bit {bit}: {clocks} clocks");
            assert!(m.pulses <= u32::from(CLEAR_CLOCKS), "byte {byte:#04x} bit {bit}");
            assert_eq!(m.slave, Slave::Idle, "byte {byte:#04x} bit {bit}");
            assert!(m.stops >= 1, "byte {byte:#04x} bit {bit}: no STOP on the bus");
            assert!(m.scl() && m.sda(), "byte {byte:#04x} bit {bit}: lines left low");
        }
    }
}

#[test]
fn the_worst_case_takes_all_nine_clocks() {
    // 0x00 from its MSB: eight pulses to the acknowledge slot, the ninth is the STOP's.
    let mut m = Model::new(Slave::Transmit { byte: 0x00, bit: 0, acked: false });
    assert_eq!(clear_bus(&mut m), Clear::Freed { clocks: 9 });
    // A byte whose next bit is 0 right after a 1: the first STOP's clock moves the slave to it
    // (SDA stays low, no STOP), so the clear must clock on.
    let mut m = Model::new(Slave::Transmit { byte: 0b1000_0000, bit: 0, acked: false });
    assert_eq!(clear_bus(&mut m), Clear::Freed { clocks: 9 });
    assert_eq!(m.slave, Slave::Idle);
}

#[test]
fn a_receiver_holding_its_acknowledge_is_freed() {
    let mut m = Model::new(Slave::Receive { bit: 8 });
    assert!(!m.sda());
    assert_eq!(clear_bus(&mut m), Clear::Freed { clocks: 2 });
    assert_eq!(m.slave, Slave::Idle);
    // An idle bus: one STOP, no harm.
    let mut m = Model::new(Slave::Idle);
    assert_eq!(clear_bus(&mut m), Clear::Freed { clocks: 1 });
    assert_eq!((m.slave, m.stops, m.starts), (Slave::Idle, 1, 0));
}

#[test]
fn shorts_are_reported_after_a_bounded_number_of_clocks() {
    let mut m = Model::new(Slave::Idle);
    m.sda_short = true;
    m.prev_sda = false;
    assert_eq!(clear_bus(&mut m), Clear::SdaStuck);
    assert_eq!(m.pulses, u32::from(CLEAR_CLOCKS));
    let mut m = Model::new(Slave::Idle);
    m.scl_short = true;
    m.prev_scl = false;
    assert_eq!(clear_bus(&mut m), Clear::SclStuck);
    assert_eq!(m.pulses, 0);
}

/// The interrupt mask's state, shared by a mock mask and a mock bus.
#[derive(Clone, Default)]
struct MaskFlag(Rc<Cell<bool>>);

impl Mask for MaskFlag {
    fn masked<R>(&mut self, f: impl FnOnce() -> R) -> R {
        assert!(!self.0.get(), "masks nested");
        self.0.set(true);
        let r = f();
        self.0.set(false);
        r
    }
}

/// A bus with a model slave on it: a transfer fails (START times out: the peripheral sees the
/// bus busy) while SDA is held low; each transfer checks that interrupts are masked.
struct ModelBus {
    lines: Model,
    mask: MaskFlag,
    transfers: u32,
    unmasked: u32,
    /// Transfers that fail with a missing acknowledge.
    nack: bool,
    /// Operation kinds seen: 'w', 'r', 'x' (write-read).
    seen: Vec<char>,
}

impl ModelBus {
    fn new(slave: Slave, mask: &MaskFlag) -> Self {
        ModelBus {
            lines: Model::new(slave),
            mask: mask.clone(),
            transfers: 0,
            unmasked: 0,
            nack: false,
            seen: Vec::new(),
        }
    }

    fn transfer(&mut self, kind: char) -> Result<(), ErrorKind> {
        self.transfers += 1;
        self.seen.push(kind);
        if !self.mask.0.get() {
            self.unmasked += 1;
        }
        if !self.lines.sda() || !self.lines.scl() {
            return Err(ErrorKind::Other); // the HAL's START timeout
        }
        if self.nack {
            return Err(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address));
        }
        Ok(())
    }
}

impl RawI2c for ModelBus {
    type Error = ErrorKind;
    fn write(&mut self, _: u8, _: &[u8]) -> Result<(), ErrorKind> {
        self.transfer('w')
    }
    fn read(&mut self, _: u8, buf: &mut [u8]) -> Result<(), ErrorKind> {
        buf.fill(0);
        self.transfer('r')
    }
    fn write_read(&mut self, _: u8, _: &[u8], buf: &mut [u8]) -> Result<(), ErrorKind> {
        buf.fill(0);
        self.transfer('x')
    }
    fn clear(&mut self) -> Clear {
        clear_bus(&mut self.lines)
    }
}

fn guarded(slave: Slave) -> GuardedBus<ModelBus, MaskFlag> {
    let mask = MaskFlag::default();
    GuardedBus::new(ModelBus::new(slave, &mask), mask)
}

#[test]
fn every_transfer_of_the_driver_runs_with_interrupts_masked() {
    let mut dev = Lsm303dlh::new(guarded(Slave::Idle));
    dev.check_mag_id().ok();
    dev.init_accel(crate::lsm303dlh::AccelConfig::new()).unwrap();
    dev.init_mag(crate::lsm303dlh::MagConfig::new()).unwrap();
    dev.read_accel_raw().unwrap();
    dev.read_mag_raw().unwrap();
    dev.accel_data_ready().unwrap();
    let bus = dev.destroy();
    assert!(bus.inner().transfers >= 8, "{}", bus.inner().transfers);
    assert_eq!(bus.inner().unmasked, 0, "transfers with interrupts enabled");
    // And the mask is released after each one.
    assert!(!bus.mask.0.get());
}

#[test]
fn transaction_uses_only_the_three_whole_transfers_and_refuses_the_rest() {
    let mut bus = guarded(Slave::Idle);
    let mut buf = [0u8; 2];
    bus.transaction(reg::ACCEL_ADDR, &mut [Operation::Write(&[1, 2])]).unwrap();
    bus.transaction(reg::ACCEL_ADDR, &mut [Operation::Read(&mut buf)]).unwrap();
    bus.transaction(reg::ACCEL_ADDR, &mut [Operation::Write(&[1]), Operation::Read(&mut buf)])
        .unwrap();
    assert_eq!(bus.inner().seen, ['w', 'r', 'x']);
    let (mut b1, mut b2, mut b3) = ([0u8; 1], [0u8; 1], [0u8; 2]);
    for ops in [
        &mut [Operation::Read(&mut b1), Operation::Write(&[1])][..],
        &mut [Operation::Write(&[1]), Operation::Write(&[2])][..],
        &mut [Operation::Read(&mut b2), Operation::Read(&mut b3)][..],
        &mut [][..],
    ] {
        assert_eq!(bus.transaction(reg::ACCEL_ADDR, ops), Err(BusError::Unsupported));
    }
    assert_eq!(bus.inner().transfers, 3, "a refused transaction touched the bus");
    assert_eq!(bus.counters.unsupported, 4);
}

#[test]
fn a_slave_stuck_from_before_the_reset_is_cleared_at_boot() {
    // The MCU was reset while the accelerometer sent a 0x00 byte: SDA is low.
    let mut dev = Lsm303dlh::new(guarded(Slave::Transmit { byte: 0x00, bit: 3, acked: false }));
    assert!(dev.read_accel_raw().is_ok());
    let bus = dev.destroy();
    assert_eq!(bus.counters.clears, 1);
    assert!(matches!(bus.counters.last_clear, Some(Clear::Freed { .. })));
    assert_eq!(bus.counters.errors, 0);
}

#[test]
fn repeated_failures_clear_the_bus_but_missing_acknowledges_do_not() {
    let mut bus = guarded(Slave::Idle);
    assert_eq!(bus.counters.clears, 1);
    // A slave gets stuck during operation (a glitch on SCL mid-read).
    bus.bus.lines.slave = Slave::Transmit { byte: 0x00, bit: 1, acked: false };
    bus.bus.lines.prev_sda = bus.bus.lines.sda();
    let mut buf = [0u8; 6];
    for i in 1..FAILURES_BEFORE_CLEAR {
        assert!(bus.read(reg::ACCEL_ADDR, &mut buf).is_err(), "read {i}");
        assert_eq!(bus.counters.clears, 1, "cleared after {i} failures");
    }
    assert!(bus.read(reg::ACCEL_ADDR, &mut buf).is_err());
    assert_eq!(bus.counters.clears, 2);
    assert!(bus.read(reg::ACCEL_ADDR, &mut buf).is_ok(), "still stuck after the clear");
    // A device that does not answer (no acknowledge) is not a stuck bus.
    bus.bus.nack = true;
    for _ in 0..10 {
        assert!(bus.read(reg::ACCEL_ADDR, &mut buf).is_err());
    }
    assert_eq!((bus.counters.clears, bus.counters.nacks), (2, 10));
    assert_eq!(bus.counters.errors, u32::from(FAILURES_BEFORE_CLEAR) + 10);
}

/// The bus clock by hand (RM0008 §26.6.8: fast mode T = 3 · CCR / PCLK1 at duty 2:1, standard
/// mode T = 2 · CCR / PCLK1). PCLK1 is 36 MHz from the crystal (72 MHz / 2), 32 MHz from HSI
/// (64 MHz / 2).
#[test]
fn the_bus_clock_is_the_highest_exact_one_at_or_below_the_setting() {
    // 36 MHz: 300 kHz is CCR 40 exactly, 400 kHz CCR 30, 100 kHz standard CCR 180.
    assert_eq!(bus_clock(36_000_000, 300), BusClock { fast: true, ccr: 40, hz: 300_000 });
    assert_eq!(bus_clock(36_000_000, 400), BusClock { fast: true, ccr: 30, hz: 400_000 });
    assert_eq!(bus_clock(36_000_000, 100), BusClock { fast: false, ccr: 180, hz: 100_000 });
    // 32 MHz: 400 kHz would need CCR 26.7; 27 gives 395,061 Hz (26 would be 410 kHz). 300 kHz
    // needs 35.6: 36 gives 296,296 Hz.
    assert_eq!(bus_clock(32_000_000, 400), BusClock { fast: true, ccr: 27, hz: 395_061 });
    assert_eq!(bus_clock(32_000_000, 300), BusClock { fast: true, ccr: 36, hz: 296_296 });
    // 36 MHz, 350 kHz: CCR 34.3 → 35, 342,857 Hz.
    assert_eq!(bus_clock(36_000_000, 350), BusClock { fast: true, ccr: 35, hz: 342_857 });
    // The HAL's divider (PCLK1 / (3 · f), rounded down) gives the same CCR back.
    for pclk1 in [32_000_000, 36_000_000] {
        for khz in [101, 150, 200, 250, 300, 333, 350, 399, 400] {
            let c = bus_clock(pclk1, khz);
            assert!(c.fast && c.hz <= u32::from(khz) * 1000, "{pclk1} {khz}: {c:?}");
            assert_eq!(pclk1 / (3 * c.hz), c.ccr, "{pclk1} {khz}");
        }
    }
}

/// The names the boot log prints for a bus clear's outcome.
#[test]
fn each_clear_outcome_has_its_name() {
    assert_eq!(Clear::Freed { clocks: 3 }.name(), "freed");
    assert_eq!(Clear::SdaStuck.name(), "SDA stuck low");
    assert_eq!(Clear::SclStuck.name(), "SCL stuck low");
}
