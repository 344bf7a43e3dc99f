//! The LSM303DLH on I²C2: the bus, its timeouts, and the names of its errors for the log. The
//! read schedule with its retries, re-configuration and stuck-data detection is the library's
//! [`inemo_ahrs::supervision::imu::Imu`] (host-tested with injected faults).
//!
//! Every transfer is bounded by `BlockingI2c`'s DWT timeouts ([`START_TIMEOUT_US`] per START
//! try, [`START_RETRIES`] tries with a peripheral reset in between,
//! [`ADDR_TIMEOUT_US`], [`DATA_TIMEOUT_US`] per byte), so a dead or stuck bus costs about 1 ms
//! per failed read and never hangs the filter. Every transfer runs with interrupts masked and
//! the bus is cleared at boot and after repeated failures: the library's
//! [`GuardedBus`](inemo_ahrs::supervision::i2c_bus::GuardedBus) (host-tested against a model of
//! a stuck slave); here only its hardware: [`HalBus`] (the HAL's whole transfers, never its
//! `todo!()` `transaction`), [`Masked`] and [`Pins`] (PB10/PB11 as open-drain GPIOs).

use core::sync::atomic::{compiler_fence, Ordering};

use inemo_ahrs::lsm303dlh::Error;
use inemo_ahrs::supervision::i2c_bus::{self, BusError, BusLines, Clear, GuardedBus, Mask, RawI2c};
use inemo_ahrs::supervision::imu::ImuEvent;
use stm32f1xx_hal::{
    i2c::{self, BlockingI2c},
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

/// The HAL's blocking I²C2 through its inherent whole-transfer methods, and the bus clear on
/// its pins.
pub struct HalBus {
    i2c: BlockingI2c<pac::I2C2>,
    /// Core cycles in half a 100 kHz clock period (5 µs): the clear runs at standard mode.
    half_period_cycles: u32,
}

impl HalBus {
    /// The bus; `sysclk_hz` times the bus clear.
    pub fn new(i2c: BlockingI2c<pac::I2C2>, sysclk_hz: u32) -> Self {
        HalBus { i2c, half_period_cycles: (sysclk_hz / 200_000).max(1) }
    }
}

impl RawI2c for HalBus {
    type Error = i2c::Error;
    fn write(&mut self, addr: u8, bytes: &[u8]) -> Result<(), i2c::Error> {
        self.i2c.write(addr, bytes)
    }
    fn read(&mut self, addr: u8, buf: &mut [u8]) -> Result<(), i2c::Error> {
        self.i2c.read(addr, buf)
    }
    fn write_read(&mut self, addr: u8, bytes: &[u8], buf: &mut [u8]) -> Result<(), i2c::Error> {
        self.i2c.write_read(addr, bytes, buf)
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

/// The logical priority up to which interrupts are held off during a transfer: the ADC's DMA
/// interrupt (3) and every task below it. Above it run only the USART2 RX interrupt (4) and
/// SysTick (hardware priority 0, the monotonic's): each takes a few µs, well inside the
/// 22.5 µs of a byte at 400 kHz in which ES0340 §2.13.2's events must be handled. Masking them
/// too (PRIMASK, as ST's own driver does) would cost more than it protects: the SysTick
/// monotonic counts its 10 kHz ticks by interrupt, so a 0.2 ms mask loses two (the filter's
/// period would stretch by 1 %), and the USART, which holds one received byte, would overrun.
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
