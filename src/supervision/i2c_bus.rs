//! The LSM303DLH's I²C bus as the firmware uses it: every transfer with interrupts masked, and
//! the bus cleared (nine clocks and a STOP) at boot and after repeated failures (issue #16).
//!
//! - **Masked transfers.** The STM32F103's I²C peripheral needs some events of a transfer (EV6_1,
//!   EV7_1, EV7, EV8, EV3: clearing ACK, setting STOP around the last bytes) handled before the
//!   current byte ends, or it reads an extra byte, repeats one or misses one (ES0340 §2.13.2,
//!   "Some software events must be managed before the current byte is being transferred"). The
//!   workaround the errata gives is DMA or an interrupt mask around the transfer, which is what
//!   ST's own iNEMO driver does. [`GuardedBus`] runs every transfer inside [`Mask::masked`]
//!   (the firmware: BASEPRI up to the ADC's DMA interrupt, about 0.2 ms for a 6-byte read;
//!   what stays unmasked and why: `app::imu::Masked`), and the reads' byte-time windows
//!   themselves run with every interrupt masked ([`super::i2c_master`], issue #27).
//! - **Only the transfers the HAL implements.** `stm32f1xx-hal` 0.11's
//!   `BlockingI2c::transaction` is `todo!()` (a panic). The bus under a [`GuardedBus`] is a
//!   [`RawI2c`], which has no `transaction`: only `write`, `read` and `write_read`, each a
//!   complete transfer (the firmware: the HAL's `write`, and reads by
//!   [`super::i2c_master`]). [`GuardedBus`]'s own
//!   [`I2c::transaction`] maps the three shapes to them and refuses any other
//!   ([`BusError::Unsupported`]) without touching the bus: nothing can reach the `todo!()`.
//! - **Bus clear.** A reset in the middle of a read (watchdog, probe, re-flash) can leave a
//!   slave transmitting a byte: it holds SDA low until it has clocked out its bits, and every
//!   START then fails. [`clear_bus`] drives SCL as an open-drain output up to
//!   [`CLEAR_CLOCKS`] times until SDA is released, then a STOP (I²C specification UM10204
//!   §3.1.16, "Bus clear"); the firmware then resets and re-initialises the peripheral (which
//!   also clears a BUSY flag locked by a glitch, ES0340 §2.13.7). [`GuardedBus::new`] clears
//!   the bus first (boot), and [`FAILURES_BEFORE_CLEAR`] failed transfers in a row other than a
//!   missing acknowledge clear it again.

use embedded_hal::i2c::{self, ErrorKind, ErrorType, I2c, Operation};

/// SCL pulses of a bus clear at most, the STOP's own included: a slave transmitter reaches
/// the acknowledge slot of its byte within eight, where a released SDA (a NACK) ends its
/// transfer; the ninth is the STOP's.
pub const CLEAR_CLOCKS: u8 = 9;
/// Failed transfers in a row (timeouts, bus errors, arbitration lost: not a missing
/// acknowledge, which a working bus gives) after which the bus is cleared.
pub const FAILURES_BEFORE_CLEAR: u8 = 3;
/// Half periods to wait for SCL to rise (a slave stretching the clock) before giving up.
const SCL_RISE_WAITS: u8 = 10;

/// The bus lines as open-drain GPIOs, for [`clear_bus`]. "Release" lets the pull-up raise the
/// line (open drain off); "pull low" drives it low.
pub trait BusLines {
    /// SCL released (`true`) or pulled low (`false`).
    fn set_scl(&mut self, high: bool);
    /// SDA released (`true`) or pulled low (`false`).
    fn set_sda(&mut self, high: bool);
    /// The level on SCL.
    fn scl_high(&mut self) -> bool;
    /// The level on SDA.
    fn sda_high(&mut self) -> bool;
    /// Half a bus clock period (5 µs for 100 kHz).
    fn half_period(&mut self);
}

/// What a bus clear found and did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Clear {
    /// SDA was released (by `clocks` pulses, 0 if it was already high) and a STOP was seen on
    /// the bus (SDA high at the end).
    Freed {
        /// SCL pulses given, the STOPs' included.
        clocks: u8,
    },
    /// SDA still low after [`CLEAR_CLOCKS`] pulses: a slave or a short holds it (power-cycle).
    SdaStuck,
    /// SCL does not rise: held low (a short, or a slave stretching for ever).
    SclStuck,
}

impl Clear {
    /// Short name, for the log and `SELFTEST`.
    pub const fn name(self) -> &'static str {
        match self {
            Clear::Freed { .. } => "freed",
            Clear::SdaStuck => "SDA stuck low",
            Clear::SclStuck => "SCL stuck low",
        }
    }
}

/// Releases SCL and waits for it to rise; false when it stays low.
fn scl_rises(lines: &mut impl BusLines) -> bool {
    lines.set_scl(true);
    for _ in 0..SCL_RISE_WAITS {
        lines.half_period();
        if lines.scl_high() {
            return true;
        }
    }
    false
}

/// The bus clear: up to [`CLEAR_CLOCKS`] SCL pulses while SDA is low, then a STOP (SDA low to
/// high while SCL is high). A slave that drives its next bit low on the STOP's own clock
/// (the STOP failed: SDA still low) is clocked on, within the same budget.
pub fn clear_bus(lines: &mut impl BusLines) -> Clear {
    lines.set_sda(true);
    if !scl_rises(lines) {
        return Clear::SclStuck;
    }
    let mut clocks = 0u8;
    loop {
        while !lines.sda_high() {
            if clocks >= CLEAR_CLOCKS {
                return Clear::SdaStuck;
            }
            lines.set_scl(false);
            lines.half_period();
            if !scl_rises(lines) {
                return Clear::SclStuck;
            }
            clocks += 1;
        }
        if clocks >= CLEAR_CLOCKS {
            return Clear::SdaStuck;
        }
        // STOP: SCL low, SDA low, SCL high, SDA high.
        lines.set_scl(false);
        lines.half_period();
        lines.set_sda(false);
        lines.half_period();
        if !scl_rises(lines) {
            lines.set_sda(true);
            return Clear::SclStuck;
        }
        clocks += 1;
        lines.set_sda(true);
        lines.half_period();
        if lines.sda_high() {
            return Clear::Freed { clocks };
        }
    }
}

/// The I²C2 clock the peripheral runs at (RM0008 §26.6.8, I2C_CCR).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BusClock {
    /// Fast mode (F/S = 1, duty 2:1: a period is 3 · CCR PCLK1 cycles); else standard mode
    /// (a period is 2 · CCR cycles, CCR ≥ 4).
    pub fast: bool,
    /// The CCR field.
    pub ccr: u32,
    /// The SCL frequency, Hz: PCLK1 / (3 · CCR) or PCLK1 / (2 · CCR), rounded down. Given to the
    /// HAL's `Mode`, its own divider (`PCLK1 / (3 · f)`, rounded down) gives back `ccr`.
    pub hz: u32,
}

/// The bus clock for a setting of `khz` (`i2c.clock`) at APB1 `pclk1_hz`: the highest at or
/// below it that the integer divider reproduces exactly, standard mode up to 100 kHz, fast
/// mode with a 2:1 duty cycle above. (The HAL rounds its divider down, i.e. the clock up:
/// 32 MHz / (3 × 400 kHz) = 26.7 would run the bus at 410 kHz.)
pub fn bus_clock(pclk1_hz: u32, khz: u16) -> BusClock {
    let max_hz = u32::from(khz).max(1) * 1000;
    if max_hz <= 100_000 {
        let ccr = pclk1_hz.div_ceil(2 * max_hz).max(4);
        BusClock { fast: false, ccr, hz: pclk1_hz / (2 * ccr) }
    } else {
        let ccr = pclk1_hz.div_ceil(3 * max_hz).max(1);
        BusClock { fast: true, ccr, hz: pclk1_hz / (3 * ccr) }
    }
}

/// A bus that does whole transfers: the HAL's `BlockingI2c` through its inherent methods (no
/// `transaction`, which is `todo!()` there).
pub trait RawI2c {
    /// The bus's error.
    type Error: i2c::Error;
    /// START, address + W, `bytes`, STOP.
    fn write(&mut self, addr: u8, bytes: &[u8]) -> Result<(), Self::Error>;
    /// START, address + R, `buf.len()` bytes, STOP.
    fn read(&mut self, addr: u8, buf: &mut [u8]) -> Result<(), Self::Error>;
    /// START, address + W, `bytes`, repeated START, address + R, `buf.len()` bytes, STOP.
    fn write_read(&mut self, addr: u8, bytes: &[u8], buf: &mut [u8]) -> Result<(), Self::Error>;
    /// Clears the bus ([`clear_bus`] on the pins as GPIOs) and re-initialises the peripheral.
    fn clear(&mut self) -> Clear;
}

/// Runs a closure with interrupts masked (the firmware: BASEPRI, `app::imu::Masked`).
pub trait Mask {
    /// `f` with every interrupt held off.
    fn masked<R>(&mut self, f: impl FnOnce() -> R) -> R;
}

/// An error of a [`GuardedBus`] transfer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusError<E> {
    /// The bus reported it.
    Bus(E),
    /// A `transaction` shape the bus cannot do as one transfer (nothing was sent).
    Unsupported,
}

impl<E: i2c::Error> i2c::Error for BusError<E> {
    fn kind(&self) -> ErrorKind {
        match self {
            BusError::Bus(e) => e.kind(),
            BusError::Unsupported => ErrorKind::Other,
        }
    }
}

/// Counts of a [`GuardedBus`], for `STATUS`, `SELFTEST` and the log.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BusCounters {
    /// Failed transfers (every kind).
    pub errors: u32,
    /// Transfers not acknowledged.
    pub nacks: u32,
    /// Bus clears done (the boot's included).
    pub clears: u32,
    /// What the last clear found.
    pub last_clear: Option<Clear>,
    /// `transaction` calls refused.
    pub unsupported: u32,
}

/// The bus with masked transfers and bus clears (module documentation).
pub struct GuardedBus<B, M> {
    bus: B,
    mask: M,
    failures_in_row: u8,
    /// Counts.
    pub counters: BusCounters,
}

impl<B: RawI2c, M: Mask> GuardedBus<B, M> {
    /// The bus, cleared first (a slave may still be in the transfer a reset cut short).
    pub fn new(bus: B, mask: M) -> Self {
        let mut g = GuardedBus { bus, mask, failures_in_row: 0, counters: BusCounters::default() };
        g.clear();
        g
    }

    /// Clears the bus now.
    pub fn clear(&mut self) -> Clear {
        let found = self.bus.clear();
        self.counters.clears = self.counters.clears.saturating_add(1);
        self.counters.last_clear = Some(found);
        self.failures_in_row = 0;
        found
    }

    /// The bus underneath (tests).
    pub fn inner(&self) -> &B {
        &self.bus
    }

    /// Counts a transfer's outcome; clears the bus after [`FAILURES_BEFORE_CLEAR`] failures in
    /// a row that a working bus does not give.
    fn account<T>(&mut self, r: Result<T, B::Error>) -> Result<T, BusError<B::Error>> {
        match r {
            Ok(v) => {
                self.failures_in_row = 0;
                Ok(v)
            }
            Err(e) => {
                self.counters.errors = self.counters.errors.saturating_add(1);
                if let ErrorKind::NoAcknowledge(_) = i2c::Error::kind(&e) {
                    self.counters.nacks = self.counters.nacks.saturating_add(1);
                } else {
                    self.failures_in_row = self.failures_in_row.saturating_add(1);
                    if self.failures_in_row >= FAILURES_BEFORE_CLEAR {
                        self.clear();
                    }
                }
                Err(BusError::Bus(e))
            }
        }
    }
}

impl<B: RawI2c, M: Mask> ErrorType for GuardedBus<B, M> {
    type Error = BusError<B::Error>;
}

impl<B: RawI2c, M: Mask> I2c for GuardedBus<B, M> {
    fn read(&mut self, addr: u8, buf: &mut [u8]) -> Result<(), Self::Error> {
        let bus = &mut self.bus;
        let r = self.mask.masked(|| bus.read(addr, buf));
        self.account(r)
    }

    fn write(&mut self, addr: u8, bytes: &[u8]) -> Result<(), Self::Error> {
        let bus = &mut self.bus;
        let r = self.mask.masked(|| bus.write(addr, bytes));
        self.account(r)
    }

    fn write_read(&mut self, addr: u8, bytes: &[u8], buf: &mut [u8]) -> Result<(), Self::Error> {
        let bus = &mut self.bus;
        let r = self.mask.masked(|| bus.write_read(addr, bytes, buf));
        self.account(r)
    }

    fn transaction(&mut self, addr: u8, ops: &mut [Operation<'_>]) -> Result<(), Self::Error> {
        match ops {
            [Operation::Write(bytes)] => self.write(addr, bytes),
            [Operation::Read(buf)] => self.read(addr, buf),
            [Operation::Write(bytes), Operation::Read(buf)] => self.write_read(addr, bytes, buf),
            _ => {
                self.counters.unsupported = self.counters.unsupported.saturating_add(1);
                Err(BusError::Unsupported)
            }
        }
    }
}

#[cfg(test)]
#[path = "i2c_bus_tests.rs"]
mod tests;
