//! The independent watchdog (IWDG), driven through its registers.
//!
//! It runs from the LSI RC oscillator (40 kHz nominal, 30–60 kHz over the device's range) with
//! the prescaler at /64 (1.6 ms per count). [`Watchdog::start`] arms it in `init` with
//! [`BOOT_TIMEOUT_MS`], enough for the gyro settling time before the first filter cycle; the
//! first [`Watchdog::feed`] shortens the timeout to [`RUN_TIMEOUT_MS`]. Once started the IWDG
//! cannot be stopped (except by a reset); it is halted only while a debugger halts the core.
//!
//! The application feeds it only at the end of a healthy filter cycle (see `main.rs`).

use stm32f1xx_hal::pac::{DBGMCU, IWDG};

/// Timeout from `init` to the first feed, ms (nominal LSI).
pub const BOOT_TIMEOUT_MS: u32 = 2000;
/// Timeout between feeds once the filter runs, ms (nominal LSI: 333–667 ms over the LSI range).
pub const RUN_TIMEOUT_MS: u32 = 500;

/// Reload value for a timeout at LSI / 64 (40 kHz / 64 = 625 Hz).
const fn reload(ms: u32) -> u16 {
    let counts = ms * 40 / 64;
    let rl = if counts > 0 { counts - 1 } else { 0 };
    if rl > 0xFFF {
        0xFFF
    } else {
        rl as u16
    }
}

/// The running watchdog.
pub struct Watchdog {
    iwdg: IWDG,
    /// The run timeout is programmed.
    running: bool,
}

impl Watchdog {
    /// Starts the IWDG (this also starts the LSI) with [`BOOT_TIMEOUT_MS`]; stops its counter
    /// while a debugger halts the core.
    pub fn start(iwdg: IWDG, dbg: &DBGMCU) -> Self {
        dbg.cr().modify(|_, w| w.dbg_iwdg_stop().set_bit());
        iwdg.kr().write(|w| w.key().start());
        iwdg.kr().write(|w| w.key().unlock());
        iwdg.pr().write(|w| w.pr().divide_by64());
        iwdg.rlr().write(|w| w.rl().set(reload(BOOT_TIMEOUT_MS)));
        iwdg.kr().write(|w| w.key().feed());
        Watchdog { iwdg, running: false }
    }

    /// Reloads the counter. The first call (once the boot reload value has reached the LSI
    /// domain) switches to [`RUN_TIMEOUT_MS`].
    pub fn feed(&mut self) {
        if !self.running && self.iwdg.sr().read().bits() == 0 {
            self.iwdg.kr().write(|w| w.key().unlock());
            self.iwdg.rlr().write(|w| w.rl().set(reload(RUN_TIMEOUT_MS)));
            self.running = true;
        }
        self.iwdg.kr().write(|w| w.key().feed());
    }
}
