//! The independent watchdog (IWDG), driven through its registers.
//!
//! It runs from the LSI RC oscillator (40 kHz nominal, 30–60 kHz over the device's range) with
//! the prescaler at /64 (1.6 ms per count). [`start`] arms it in `init` with
//! [`BOOT_TIMEOUT_MS`](inemo_ahrs::supervision::watchdog::BOOT_TIMEOUT_MS), enough for the gyro
//! settling time before the first filter cycle; the first feed shortens the timeout to
//! [`RUN_TIMEOUT_MS`](inemo_ahrs::supervision::watchdog::RUN_TIMEOUT_MS). The sequence (every
//! write waits for PVU/RVU before the reload) is the library's
//! [`Iwdg`](inemo_ahrs::supervision::watchdog::Iwdg), host-tested against a model with the LSI
//! domain's update latency. Once started the IWDG cannot be stopped (except by a reset); it is
//! halted only while a debugger halts the core.
//!
//! The application feeds it only at the end of a healthy filter cycle (see `main.rs`).

use inemo_ahrs::supervision::watchdog::{Iwdg, IwdgRegs};
use stm32f1xx_hal::pac::{DBGMCU, IWDG};

/// The running watchdog.
pub type Watchdog = Iwdg<Regs>;

/// IWDG's registers.
pub struct Regs(IWDG);

// SAFETY (the `bits` writes): every 16-bit key, 3-bit prescaler and 12-bit reload value is a
// valid write (RM0008 §19.4); the PAC's fields mask them to their width.
impl IwdgRegs for Regs {
    fn key(&mut self, key: u16) {
        self.0.kr().write(|w| unsafe { w.key().bits(key) });
    }
    fn prescaler(&mut self, pr: u8) {
        self.0.pr().write(|w| unsafe { w.pr().bits(pr) });
    }
    fn reload(&mut self, rlr: u16) {
        self.0.rlr().write(|w| unsafe { w.rl().bits(rlr) });
    }
    fn status(&mut self) -> u32 {
        u32::from(self.0.sr().read().bits())
    }
    fn pause(&mut self) {
        // 10 µs at 72 MHz (and longer at the 8 MHz the core may still run at in `init`).
        cortex_m::asm::delay(720);
    }
}

/// Starts the IWDG (this also starts the LSI); its counter stops while a debugger halts the
/// core. Also DBGMCU_CR.DBG_SLEEP (RM0008 §31.16.3): the core's clock keeps running in `wfi`,
/// so a debugger (RTT, defmt) can read memory while the firmware idles.
pub fn start(iwdg: IWDG, dbg: &DBGMCU) -> Watchdog {
    dbg.cr().modify(|_, w| w.dbg_iwdg_stop().set_bit().dbg_sleep().set_bit());
    Iwdg::start(Regs(iwdg))
}
