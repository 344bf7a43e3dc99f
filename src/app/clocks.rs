//! Clock tree start-up with a fallback to the internal oscillator, and the reset cause.
//!
//! The HAL's `Rcc::freeze` waits for HSERDY without a bound ("will result in a hang if an
//! external oscillator is not connected or it fails to start"), so the crystal is started here
//! first with a bounded wait, then its frequency is measured against the HSI through the LSI
//! ([`measure_hse`]; the decision is the library's
//! [`clock_check`](inemo_ahrs::supervision::clock_check), host-tested); only if it runs at
//! 8 MHz is the HSE configuration frozen, otherwise the PLL runs from HSI/2. Before all that
//! the clock tree is put back to its reset state, whatever ran before (issue #37:
//! [`clock_reset`](inemo_ahrs::supervision::clock_reset)).

use inemo_ahrs::board;
use inemo_ahrs::supervision::clock_check::{self, HseCheck};
use inemo_ahrs::supervision::clock_reset::{self, RccRegs, ResetError};
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

/// LSI captures (each over 8 LSI periods) summed per measurement.
const CAPTURES: u32 = 4;
/// Polls of a capture flag at most: 8 LSI periods at the slowest LSI (30 kHz) are 267 µs,
/// 2,133 core cycles at 8 MHz; a poll takes a few cycles, so 20,000 polls are ample.
const CAPTURE_POLLS: u32 = 20_000;
/// Polls of SWS after a switch of SYSCLK (it takes a few cycles of both clocks).
const SWITCH_POLLS: u32 = 1_000;

/// TIM5 ticks (at SYSCLK: the prescalers are at their reset value /1) over `CAPTURES` × 8 LSI
/// periods, captured on TIM5 channel 4 (the LSI when AFIO_MAPR.TIM5CH4_IREMAP is set).
fn lsi_ticks(tim: &pac::tim2::RegisterBlock) -> Option<u32> {
    let capture = || -> Option<u16> {
        for _ in 0..CAPTURE_POLLS {
            if tim.sr().read().bits() & (1 << 4) != 0 {
                // CC4IF; reading CCR4 clears it.
                return Some(tim.ccr4().read().bits() as u16);
            }
        }
        None
    };
    let mut first = capture()?;
    let mut sum = 0u32;
    for _ in 0..CAPTURES {
        let next = capture()?;
        sum += u32::from(next.wrapping_sub(first));
        first = next;
    }
    Some(sum)
}

/// Switches SYSCLK (SW: 0 HSI, 1 HSE) and waits for SWS to follow; false if it did not.
fn switch_sysclk(rcc: &pac::RCC, hse: bool) -> bool {
    rcc.cfgr().modify(|_, w| if hse { w.sw().hse() } else { w.sw().hsi() });
    (0..SWITCH_POLLS).any(|_| rcc.cfgr().read().sws().bits() == u8::from(hse))
}

/// Measures the running crystal against the HSI (module documentation of
/// [`clock_check`](inemo_ahrs::supervision::clock_check)): TIM5 counts LSI periods with
/// SYSCLK on the HSI, then on the HSE directly (no PLL: safe for any crystal the oscillator
/// runs), then SYSCLK goes back to the HSI. Every wait is bounded; TIM5 and the remap are
/// left as they were found (reset).
fn measure_hse(rcc: &pac::RCC, started: bool) -> HseCheck {
    if !started {
        return clock_check::judge(false, None, None);
    }
    // SAFETY: TIM5, AFIO_MAPR and FLASH_ACR are not used by anything yet (this runs first in
    // `init`, interrupts masked); TIM5 is reset afterwards, the remap bit cleared.
    let (tim, afio, flash) =
        unsafe { (&*pac::TIM5::ptr(), &*pac::AFIO::ptr(), &*pac::FLASH::ptr()) };
    // Two flash wait states: SYSCLK on a crystal above 24 MHz would need them (RM0008 §3.3.3).
    flash.acr().modify(|_, w| unsafe { w.latency().bits(2) });
    rcc.apb1enr().modify(|_, w| w.tim5en().set_bit());
    rcc.apb2enr().modify(|_, w| w.afioen().set_bit());
    // The LSI is on (the watchdog started it); wait for it (bounded).
    rcc.csr().modify(|_, w| w.lsion().set_bit());
    let _ = (0..CAPTURE_POLLS).any(|_| rcc.csr().read().lsirdy().bit_is_set());
    afio.mapr().modify(|_, w| w.tim5ch4_iremap().set_bit());
    // SAFETY: raw values of TIM5's registers (RM0008 §15.4): PSC 0, ARR 0xFFFF; CCMR2 CC4S = 01
    // (IC4 on TI4), IC4PSC = 11 (a capture every 8 edges); CCER CC4E; CR1 CEN.
    unsafe {
        tim.psc().write(|w| w.bits(0));
        tim.arr().write(|w| w.bits(0xFFFF));
        tim.egr().write(|w| w.bits(1));
        tim.ccmr2_input().write(|w| w.bits(0b11 << 10 | 0b01 << 8));
        tim.ccer().write(|w| w.bits(1 << 12));
        tim.cr1().write(|w| w.bits(1));
    }
    let on_hsi = lsi_ticks(tim);
    let on_hse = if switch_sysclk(rcc, true) { lsi_ticks(tim) } else { None };
    let _ = switch_sysclk(rcc, false);
    rcc.apb1rstr().modify(|_, w| w.tim5rst().set_bit());
    rcc.apb1rstr().modify(|_, w| w.tim5rst().clear_bit());
    rcc.apb1enr().modify(|_, w| w.tim5en().clear_bit());
    afio.mapr().modify(|_, w| w.tim5ch4_iremap().clear_bit());
    clock_check::judge(true, on_hsi, on_hse)
}

/// The RCC's registers for [`clock_reset`] (raw values: the sequence works on bit masks).
struct Regs<'a>(&'a pac::RCC);

impl RccRegs for Regs<'_> {
    fn cr(&self) -> u32 {
        self.0.cr().read().bits()
    }
    fn set_cr(&mut self, v: u32) {
        // SAFETY: RCC_CR's bits are all defined (RM0008 §8.3.1); the ready bits are read-only.
        self.0.cr().write(|w| unsafe { w.bits(v) });
    }
    fn cfgr(&self) -> u32 {
        self.0.cfgr().read().bits()
    }
    fn set_cfgr(&mut self, v: u32) {
        // SAFETY: as above (§8.3.2); SWS is read-only.
        self.0.cfgr().write(|w| unsafe { w.bits(v) });
    }
    fn set_cir(&mut self, v: u32) {
        // SAFETY: as above (§8.3.3): the clear bits and the interrupt enables.
        self.0.cir().write(|w| unsafe { w.bits(v) });
    }
}

/// Configures the clock tree: 72 MHz from the crystal, or 64 MHz from HSI if it does not
/// start or is not 8 MHz. Flash wait states are set by the HAL. Returns the flash controller
/// too (for the settings pages) and what the crystal check found.
///
/// Whatever ran before (ST's DFU bootloader leaves SYSCLK on the PLL at 72 MHz), the clock
/// tree is first put back to its reset state ([`clock_reset`], host-tested): the crystal
/// check needs SYSCLK on the HSI, and the PLL cannot be configured while it runs.
pub fn freeze(rcc: pac::RCC, flash: pac::FLASH) -> (Rcc, ClockSource, flash::Parts, HseCheck) {
    match clock_reset::reset_clock_tree(&mut Regs(&rcc)) {
        Ok(()) => {}
        Err(ResetError::HsiNotReady) => defmt::warn!("clock reset: HSI not ready"),
        Err(ResetError::NotOnHsi { sws }) => {
            defmt::warn!("clock reset: SYSCLK stayed on source {}", sws)
        }
        Err(ResetError::PllRunning) => defmt::warn!("clock reset: the PLL did not stop"),
    }
    let started = start_hse(&rcc);
    let hse = measure_hse(&rcc, started);
    if started && !hse.use_hse() {
        // A crystal at the wrong frequency: off, so that nothing runs from it.
        rcc.cr().modify(|_, w| w.hseon().clear_bit());
    }
    let mut flash = flash.constrain();
    let source = if hse.use_hse() { ClockSource::Hse } else { ClockSource::Hsi };
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
    (rcc, source, flash, hse)
}
