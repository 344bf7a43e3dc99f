//! Clock tree start-up with a fallback to the internal oscillator, and the reset cause.
//!
//! The HAL's `Rcc::freeze` waits for HSERDY without a bound ("will result in a hang if an
//! external oscillator is not connected or it fails to start"), so the crystal is started here
//! first with a bounded wait; only if it runs is the HSE configuration frozen, otherwise the
//! PLL runs from HSI/2.

use inemo_ahrs::board;
pub use inemo_ahrs::supervision::reset_cause::ResetCause;
use stm32f1xx_hal::{
    flash::{self, FlashExt},
    pac,
    rcc::{Config, Rcc, RccExt},
    time::Hertz,
};

/// SYSCLK from HSI/2 × 16: the fastest the PLL reaches from the internal oscillator.
pub const HSI_SYSCLK_HZ: u32 = 64_000_000;
/// APB1 (I²C2, USART2, TIM3's bus) at most 36 MHz; 32 MHz when running from HSI.
const HSE_PCLK1_HZ: u32 = 36_000_000;
const HSI_PCLK1_HZ: u32 = 32_000_000;
/// Requested ADC clock (at most 14 MHz): PCLK2/6 = 12 MHz from HSE, 10.67 MHz from HSI.
const ADCCLK_HZ: u32 = 12_000_000;

/// Polls of HSERDY, one per [`HSE_POLL_CYCLES`] core cycles: at the 8 MHz HSI the core runs
/// on out of reset, 500 × 100 µs = 50 ms, 25 times the crystal's typical 2 ms start-up.
const HSE_POLLS: u32 = 500;
const HSE_POLL_CYCLES: u32 = 800;

/// Which oscillator drives the PLL.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum ClockSource {
    /// 8 MHz crystal × 9 = 72 MHz.
    Hse,
    /// Internal 8 MHz RC / 2 × 16 = 64 MHz (the crystal did not start).
    Hsi,
}

impl ClockSource {
    /// Field of the boot sentence.
    pub const fn tag(self) -> &'static str {
        match self {
            ClockSource::Hse => "HSE72",
            ClockSource::Hsi => "HSI64",
        }
    }
}

/// Reads the reset flags and clears them (RMVF), so the next reset reports only its own cause.
/// The decoding is [`ResetCause::from_csr`] (host-tested).
pub fn take_reset_cause(rcc: &pac::RCC) -> ResetCause {
    let cause = ResetCause::from_csr(rcc.csr().read().bits());
    rcc.csr().modify(|_, w| w.rmvf().set_bit());
    cause
}

/// Starts the crystal and waits for HSERDY at most 50 ms; switches it off again if it did not
/// come up (a half-started oscillator must not be left to the PLL).
fn start_hse(rcc: &pac::RCC) -> bool {
    rcc.cr().modify(|_, w| w.hseon().set_bit());
    for _ in 0..HSE_POLLS {
        if rcc.cr().read().hserdy().bit_is_set() {
            return true;
        }
        cortex_m::asm::delay(HSE_POLL_CYCLES);
    }
    rcc.cr().modify(|_, w| w.hseon().clear_bit());
    false
}

/// Configures the clock tree: 72 MHz from the crystal, or 64 MHz from HSI if it does not
/// start. Flash wait states are set by the HAL. Returns the flash controller too (for the
/// settings pages).
pub fn freeze(rcc: pac::RCC, flash: pac::FLASH) -> (Rcc, ClockSource, flash::Parts) {
    let mut flash = flash.constrain();
    let source = if start_hse(&rcc) { ClockSource::Hse } else { ClockSource::Hsi };
    let config = match source {
        ClockSource::Hse => Config::hse(Hertz::from_raw(board::HSE_HZ))
            .sysclk(Hertz::from_raw(board::SYSCLK_HZ))
            .pclk1(Hertz::from_raw(HSE_PCLK1_HZ)),
        ClockSource::Hsi => Config::hsi()
            .sysclk(Hertz::from_raw(HSI_SYSCLK_HZ))
            .pclk1(Hertz::from_raw(HSI_PCLK1_HZ)),
    }
    .adcclk(Hertz::from_raw(ADCCLK_HZ));
    // The HSE branch re-enables HSEON and waits for HSERDY, which is already set.
    let rcc = rcc.freeze(config, &mut flash.acr);
    (rcc, source, flash)
}
