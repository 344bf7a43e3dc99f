//! The LSM303DLH on I²C2: the bus, its timeouts, and the names of its errors for the log. The
//! read schedule with its retries, re-configuration and stuck-data detection is the library's
//! [`inemo_ahrs::supervision::imu::Imu`] (host-tested with injected faults).
//!
//! Every transfer is bounded by DWT timeouts ([`START_TIMEOUT_US`] per START try,
//! [`START_RETRIES`] tries with a peripheral reset in between, [`ADDR_TIMEOUT_US`],
//! [`DATA_TIMEOUT_US`] per byte), so a dead or stuck bus costs about 1 ms per failed read and
//! never hangs the filter. The bus is cleared at boot and after repeated failures: the
//! library's [`GuardedBus`](inemo_ahrs::supervision::i2c_bus::GuardedBus) (host-tested against
//! a model of a stuck slave); here only its hardware: [`HalBus`], [`Masked`] and [`Pins`]
//! (PB10/PB11 as open-drain GPIOs).
//!
//! **The errata windows (issue #27 point 6).** The reads (`write_read`, `read`) are no longer
//! the HAL's: they run the library's [`i2c_master`] steps on I2C2's registers ([`I2c2Regs`]),
//! whose byte-time windows of ES0340 §2.13.2 (1 byte: ADDR cleared + STOP; 2 bytes: ADDR
//! cleared + ACK off, then STOP + first read; N ≥ 3: DataN−2 read + STOP + DataN−1 read) run
//! with **every** interrupt masked ([`Primask`], `cortex_m::interrupt::free`), as ST's own
//! STM32F1 code does; before, BASEPRI left SysTick and USART2 RX able to interrupt them. The
//! image links only the N ≥ 3 window (the LSM303DLH is read in blocks of 6 and 3 bytes): in the
//! release build it is 7 instructions from `cpsid i` to `msr PRIMASK` (`Lsm303dlh::read_regs`:
//! two DR reads, CR1 read-modify-write for STOP), 4 of them I2C2 accesses; counted at no more
//! than 10 core cycles per APB1 access (an assumption, not measured), under 50 cycles: 0.7 µs
//! at 72 MHz, against the 2,160 cycles (30 µs) one byte takes at 300 kHz
//! (`i2c_master::byte_cycles`). Writes stay the HAL's (no reception window in them). The
//! whole-transfer BASEPRI mask ([`Masked`]) is kept, no longer for the errata: it keeps the ADC
//! interrupt and the tasks below from stretching a transfer, so its duration stays its bus
//! time, as the filter's cycle budget was measured with; dropping it is a change to measure on
//! a board first.

use core::sync::atomic::{compiler_fence, Ordering};

use cortex_m::peripheral::DWT;
use inemo_ahrs::lsm303dlh::Error;
use inemo_ahrs::supervision::i2c_bus::{self, BusError, BusLines, Clear, GuardedBus, Mask, RawI2c};
use inemo_ahrs::supervision::i2c_master::{self, Critical, Flag, Regs};
use inemo_ahrs::supervision::imu::ImuEvent;
use stm32f1xx_hal::{
    i2c::{self, BlockingI2c, NoAcknowledgeSource},
    pac,
};

/// The bus type.
pub type Bus = GuardedBus<HalBus, Masked>;
/// The sensor with its read schedule on I²C2.
pub type Imu = inemo_ahrs::supervision::imu::Imu<Bus>;
type DevError = Error<BusError<i2c::Error>>;

/// SCL (PB10) and SDA (PB11) in GPIOB_CRH: bits 8–11 and 12–15 (RM0008 §9.2.2).
const CRH_MASK: u32 = 0xFF00;
/// Both pins as alternate-function open-drain outputs, 50 MHz (CNF 11, MODE 11): I²C2's.
const CRH_ALTERNATE: u32 = 0xFF00;
/// Both pins as general-purpose open-drain outputs, 50 MHz (CNF 01, MODE 11): the bus clear.
const CRH_GPIO: u32 = 0x7700;
const SCL: u32 = 1 << 10;
const SDA: u32 = 1 << 11;

/// The HAL's blocking I²C2 (its initialisation, reset and writes) with the reads done here
/// step by step ([`i2c_master`], the errata windows under PRIMASK), and the bus clear on its
/// pins.
pub struct HalBus {
    i2c: BlockingI2c<pac::I2C2>,
    /// Core cycles in half a 100 kHz clock period (5 µs): the clear runs at standard mode.
    half_period_cycles: u32,
    /// The waits' bounds, core cycles ([`START_TIMEOUT_US`], [`ADDR_TIMEOUT_US`],
    /// [`DATA_TIMEOUT_US`]), as the HAL's own.
    start_cycles: u32,
    addr_cycles: u32,
    data_cycles: u32,
}

impl HalBus {
    /// The bus; `sysclk_hz` times the bus clear and the waits.
    pub fn new(i2c: BlockingI2c<pac::I2C2>, sysclk_hz: u32) -> Self {
        let cycles = |us: u32| us.saturating_mul(sysclk_hz / 1_000_000);
        HalBus {
            i2c,
            half_period_cycles: (sysclk_hz / 200_000).max(1),
            start_cycles: cycles(START_TIMEOUT_US),
            addr_cycles: cycles(ADDR_TIMEOUT_US),
            data_cycles: cycles(DATA_TIMEOUT_US),
        }
    }
}

impl RawI2c for HalBus {
    type Error = i2c::Error;
    fn write(&mut self, addr: u8, bytes: &[u8]) -> Result<(), i2c::Error> {
        self.i2c.write(addr, bytes)
    }
    fn read(&mut self, addr: u8, buf: &mut [u8]) -> Result<(), i2c::Error> {
        i2c_master::read(&mut I2c2Regs(self), &mut Primask, addr, buf, START_RETRIES)
    }
    fn write_read(&mut self, addr: u8, bytes: &[u8], buf: &mut [u8]) -> Result<(), i2c::Error> {
        if bytes.is_empty() {
            return self.read(addr, buf);
        }
        let mut regs = I2c2Regs(self);
        i2c_master::write_no_stop(&mut regs, addr, bytes, START_RETRIES)?;
        if buf.is_empty() {
            regs.stop();
            return regs.wait_stop();
        }
        i2c_master::read(&mut regs, &mut Primask, addr, buf, START_RETRIES)
    }
    fn clear(&mut self) -> Clear {
        // SAFETY: GPIOB's CRH bits of PB10/PB11 and their ODR/IDR bits, which belong to the
        // I²C2 pins this bus owns; the other pins' bits are written back unchanged (CRH is
        // read-modify-written by `filter` only, at priority 2, and by `init`).
        let gpiob = unsafe { &*pac::GPIOB::ptr() };
        let mut pins = Pins { gpiob, half_period_cycles: self.half_period_cycles };
        // Released first (ODR high), then the pins to the GPIO: no glitch low.
        gpiob.bsrr().write(|w| unsafe { w.bits(SCL | SDA) });
        set_crh(gpiob, CRH_GPIO);
        let found = i2c_bus::clear_bus(&mut pins);
        set_crh(gpiob, CRH_ALTERNATE);
        // SWRST and the HAL's initialisation again (also clears a BUSY flag a glitch locked,
        // ES0340 §2.13.7).
        self.i2c.reset();
        found
    }
}

/// Every interrupt masked (PRIMASK) for the errata windows of [`i2c_master`]: a few register
/// accesses each (their length: `docs/firmware.md`).
pub struct Primask;

impl Critical for Primask {
    #[inline(always)]
    fn free<R>(&mut self, f: impl FnOnce() -> R) -> R {
        cortex_m::interrupt::free(|_| f())
    }
}

/// I²C2's registers for [`i2c_master`]: the peripheral the [`HalBus`] owns (its `BlockingI2c`
/// is borrowed for the whole transfer); the waits as the HAL's (`wait_for_flag!`: BERR, ARLO,
/// AF, OVR checked and cleared first), bounded by the DWT cycle counter.
struct I2c2Regs<'a>(&'a mut HalBus);

impl I2c2Regs<'_> {
    #[inline(always)]
    fn regs(&self) -> &pac::i2c1::RegisterBlock {
        // SAFETY: I2C2's registers; the `BlockingI2c` that owns them is borrowed mutably for
        // as long as this lives, so nothing else touches them.
        unsafe { &*pac::I2C2::ptr() }
    }
}

impl Regs for I2c2Regs<'_> {
    type Error = i2c::Error;
    #[inline(always)]
    fn start(&mut self) {
        // Writing 0 clears SR1's error flags (rc_w0) and leaves its read-only bits.
        self.regs().sr1().write(|w| unsafe { w.bits(0) });
        self.regs().cr1().modify(|_, w| w.start().set_bit());
    }
    #[inline(always)]
    fn stop(&mut self) {
        self.regs().cr1().modify(|_, w| w.stop().set_bit());
    }
    #[inline(always)]
    fn set_ack(&mut self, on: bool) {
        self.regs().cr1().modify(|_, w| w.ack().bit(on));
    }
    #[inline(always)]
    fn set_pos(&mut self, on: bool) {
        self.regs().cr1().modify(|_, w| w.pos().bit(on));
    }
    #[inline(always)]
    fn write_dr(&mut self, byte: u8) {
        self.regs().dr().write(|w| w.dr().set(byte));
    }
    #[inline(always)]
    fn read_dr(&mut self) -> u8 {
        self.regs().dr().read().dr().bits()
    }
    #[inline(always)]
    fn clear_addr(&mut self) {
        self.regs().sr1().read();
        self.regs().sr2().read();
    }
    fn wait(&mut self, flag: Flag) -> Result<(), i2c::Error> {
        let (cycles, nack) = match flag {
            Flag::Sb => (self.0.start_cycles, NoAcknowledgeSource::Unknown),
            Flag::Addr => (self.0.addr_cycles, NoAcknowledgeSource::Address),
            Flag::Txe | Flag::Btf | Flag::Rxne => (self.0.data_cycles, NoAcknowledgeSource::Data),
        };
        let started = DWT::cycle_count();
        loop {
            let sr1 = self.regs().sr1().read();
            if sr1.berr().bit_is_set() {
                self.regs().sr1().write(|w| w.berr().clear_bit());
                return Err(i2c::Error::Bus);
            } else if sr1.arlo().bit_is_set() {
                self.regs().sr1().write(|w| w.arlo().clear_bit());
                return Err(i2c::Error::ArbitrationLoss);
            } else if sr1.af().bit_is_set() {
                self.regs().sr1().write(|w| w.af().clear_bit());
                return Err(i2c::Error::NoAcknowledge(nack));
            } else if sr1.ovr().bit_is_set() {
                self.regs().sr1().write(|w| w.ovr().clear_bit());
                return Err(i2c::Error::Overrun);
            }
            let set = match flag {
                Flag::Sb => sr1.sb().bit_is_set(),
                Flag::Addr => sr1.addr().bit_is_set(),
                Flag::Txe => sr1.tx_e().bit_is_set(),
                Flag::Btf => sr1.btf().bit_is_set(),
                Flag::Rxne => sr1.rx_ne().bit_is_set(),
            };
            if set {
                return Ok(());
            }
            if DWT::cycle_count().wrapping_sub(started) >= cycles {
                return Err(i2c::Error::Timeout);
            }
        }
    }
    fn wait_stop(&mut self) -> Result<(), i2c::Error> {
        let started = DWT::cycle_count();
        while self.regs().cr1().read().stop().bit_is_set() {
            if DWT::cycle_count().wrapping_sub(started) >= self.0.data_cycles {
                return Err(i2c::Error::Timeout);
            }
        }
        Ok(())
    }
    fn is_nack(e: &i2c::Error) -> bool {
        matches!(e, i2c::Error::NoAcknowledge(_))
    }
    fn reset(&mut self) {
        self.0.i2c.reset();
    }
}

fn set_crh(gpiob: &pac::gpiob::RegisterBlock, bits: u32) {
    gpiob.crh().modify(|r, w| unsafe { w.bits((r.bits() & !CRH_MASK) | bits) });
}

/// PB10/PB11 as open-drain GPIOs.
pub struct Pins<'a> {
    gpiob: &'a pac::gpiob::RegisterBlock,
    half_period_cycles: u32,
}

impl BusLines for Pins<'_> {
    fn set_scl(&mut self, high: bool) {
        let bit = if high { SCL } else { SCL << 16 };
        self.gpiob.bsrr().write(|w| unsafe { w.bits(bit) });
    }
    fn set_sda(&mut self, high: bool) {
        let bit = if high { SDA } else { SDA << 16 };
        self.gpiob.bsrr().write(|w| unsafe { w.bits(bit) });
    }
    fn scl_high(&mut self) -> bool {
        self.gpiob.idr().read().bits() & SCL != 0
    }
    fn sda_high(&mut self) -> bool {
        self.gpiob.idr().read().bits() & SDA != 0
    }
    fn half_period(&mut self) {
        cortex_m::asm::delay(self.half_period_cycles);
    }
}

/// The logical priority up to which interrupts are held off during a whole transfer: the ADC's
/// DMA interrupt (3) and every task below it. Above it run the USART2 RX interrupt (4) and
/// SysTick (hardware priority 0, the monotonic's), except inside the errata windows, which
/// [`Primask`] masks completely for under a µs (module docs). PRIMASK for the whole transfer
/// (about 0.2 ms) would cost more than it protects: the SysTick monotonic counts its 10 kHz
/// ticks by interrupt, so it would lose two (the filter's period would stretch by 1 %), and the
/// USART, which holds one received byte, would overrun.
pub const MASKED_PRIORITY: u8 = 3;
/// BASEPRI for [`MASKED_PRIORITY`]: RTIC's logical priority p is hardware priority
/// (2^NVIC_PRIO_BITS − p) << (8 − NVIC_PRIO_BITS) (4 priority bits on the STM32F1).
const MASK_BASEPRI: u8 = {
    let bits = pac::NVIC_PRIO_BITS;
    ((1 << bits) - MASKED_PRIORITY) << (8 - bits)
};

/// Interrupts up to [`MASKED_PRIORITY`] held off with BASEPRI (as an RTIC lock of that ceiling
/// does: raised with `basepri_max`, the previous value restored).
pub struct Masked;

impl Mask for Masked {
    fn masked<R>(&mut self, f: impl FnOnce() -> R) -> R {
        let previous = cortex_m::register::basepri::read();
        // Raising BASEPRI only masks more; the previous value is restored below, as RTIC's own
        // locks do.
        cortex_m::register::basepri_max::write(MASK_BASEPRI);
        compiler_fence(Ordering::SeqCst);
        let r = f();
        compiler_fence(Ordering::SeqCst);
        // SAFETY: the value read on entry.
        unsafe { cortex_m::register::basepri::write(previous) };
        r
    }
}

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
        Error::I2c(BusError::Bus(i2c::Error::NoAcknowledge(_))) => "no acknowledge",
        Error::I2c(BusError::Bus(i2c::Error::Timeout)) => "timeout",
        Error::I2c(BusError::Bus(i2c::Error::ArbitrationLoss)) => "arbitration lost",
        Error::I2c(BusError::Bus(i2c::Error::Overrun)) => "overrun",
        Error::I2c(BusError::Unsupported) => "unsupported transfer",
        Error::I2c(_) => "bus error",
        Error::WrongId(_) => "wrong identification",
        Error::MagOverflow => "magnetometer overflow",
    }
}

/// Logs what a read reported.
pub fn log_event(event: &ImuEvent<BusError<i2c::Error>>) {
    match event {
        ImuEvent::Reconfigured => defmt::println!("LSM303DLH configured again"),
        ImuEvent::ConfigureFailed(e) => {
            defmt::warn!("LSM303DLH configuration failed: {=str}", describe(e))
        }
        ImuEvent::NotAnswering => defmt::warn!("LSM303DLH not answering: configuring it again"),
        ImuEvent::Stuck => defmt::warn!("LSM303DLH data stuck: configuring it again"),
    }
}
