//! The settings pages in the STM32F103RE's own flash: the library's register-level driver
//! [`F103Flash`] (page A at `board::SETTINGS_PAGE_A` = 0x0807_F000, page B at
//! `board::SETTINGS_PAGE_B` = 0x0807_F800; 2 KiB page erase, 16-bit half-word programming,
//! every wait bounded, every erase and program read back), host-tested against a model of the
//! flash controller (`src/persist/f103_tests.rs`), over the real registers given here.
//!
//! `memory.x` keeps code out of both pages. Erasing or programming stalls the CPU
//! (instruction fetches wait for the flash): a page erase takes about 20–40 ms, during which
//! no interrupt is served (ADC frames are lost and counted; received bytes may be lost).
//! The HSI oscillator, which the flash interface needs for writing, is never switched off.

use core::ptr;

use inemo_ahrs::persist::f103::{F103Flash, FpecRegs};
use stm32f1xx_hal::{flash, pac};

/// The flash controller, for the two settings pages only.
pub type SettingsFlash = F103Flash<Regs>;

/// The FPEC's registers and the flash memory. Holds the HAL's flash parts (their `acr` has set
/// the wait states): owning them is owning the FPEC, which nothing else uses.
pub struct Regs {
    _parts: flash::Parts,
}

/// Takes the flash controller.
pub fn take(parts: flash::Parts) -> SettingsFlash {
    F103Flash::new(Regs { _parts: parts })
}

fn fpec() -> &'static pac::flash::RegisterBlock {
    // SAFETY: the FPEC's register block, always mapped; `Regs` owns the controller (see there).
    unsafe { &*pac::FLASH::ptr() }
}

// SAFETY (the `bits` writes): the driver writes FLASH_SR with the write-1-to-clear flags only,
// FLASH_CR with FLASH_CR's own value and PG, PER, STRT, LOCK, FLASH_KEYR with the two keys and
// FLASH_AR with a settings page's address (RM0008 §3.3.3, PM0075 §3).
impl FpecRegs for Regs {
    fn sr(&mut self) -> u32 {
        fpec().sr().read().bits()
    }
    fn write_sr(&mut self, value: u32) {
        fpec().sr().write(|w| unsafe { w.bits(value) });
    }
    fn cr(&mut self) -> u32 {
        fpec().cr().read().bits()
    }
    fn write_cr(&mut self, value: u32) {
        fpec().cr().write(|w| unsafe { w.bits(value) });
    }
    fn write_keyr(&mut self, key: u32) {
        fpec().keyr().write(|w| unsafe { w.bits(key) });
    }
    fn write_ar(&mut self, address: u32) {
        fpec().ar().write(|w| unsafe { w.bits(address) });
    }
    fn write_half(&mut self, address: u32, value: u16) {
        // SAFETY: the driver writes only half-words inside the settings pages (checked
        // before), flash that no Rust object occupies; with PG set this programs it.
        unsafe { ptr::write_volatile(address as usize as *mut u16, value) }
    }
    fn read_byte(&self, address: u32) -> u8 {
        // SAFETY: the driver reads only inside the settings pages (checked before), readable
        // flash that no Rust object occupies.
        unsafe { ptr::read_volatile(address as usize as *const u8) }
    }
    fn pause(&mut self) {
        // 1 µs at 72 MHz (1.1 µs at 64 MHz on the HSI).
        cortex_m::asm::delay(72);
    }
}
