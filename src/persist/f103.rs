//! [`Flash`] on the STM32F103RE's own flash controller (the FPEC), driven through its
//! registers: the two settings pages [`board::SETTINGS_PAGE_A`] and
//! [`board::SETTINGS_PAGE_B`], 2 KiB page erase and 16-bit half-word programming, following
//! the programming sequences of RM0008 §3.3.3 and PM0075 (the STM32F10xxx flash programming
//! manual) §2.3–2.4, every step bounded and checked:
//!
//! - **Unlock** (before every erase or program, when FLASH_CR.LOCK is set): KEY1 then KEY2
//!   into FLASH_KEYR; LOCK must read clear afterwards. A wrong sequence locks FLASH_CR until
//!   the next reset, so the keys are written only while LOCK is set, never twice.
//! - **Page erase**: wait for BSY clear; clear stale EOP/PGERR/WRPRTERR (write 1); set PER;
//!   FLASH_AR = the page's address; set STRT; wait until BSY is clear *and* EOP or an error
//!   flag is set (BSY rises one cycle after STRT, errata ES0340 §2.2.8 for the F105/F107, so a
//!   clear BSY alone does not mean done); clear PER; LOCK; then every byte of the page must
//!   read 0xFF.
//! - **Half-word program**: the same, with PG set and a half-word write to the address
//!   instead of PER/AR/STRT; afterwards the half-word must read back as written. The FPEC
//!   refuses (PGERR) a half-word that is not erased unless the value is 0x0000.
//! - **Clear PG/PER and lock again** after every operation, whatever its outcome: a stray
//!   write to the flash between two operations then programs nothing (LOCK alone would not
//!   do: it protects FLASH_CR, and a PG left set keeps the flash programmable), and a stray
//!   write to FLASH_CR changes nothing.
//!
//! Every address is computed from [`Page`] and an offset checked against the page size
//! *before* any register access: the driver never touches anything outside
//! `0x0807_F000..0x0808_0000` (the tests' model of the controller records every access and
//! checks that). Waits are bounded ([`ERASE_POLLS`], [`PROGRAM_POLLS`] polls of FLASH_SR with
//! [`FpecRegs::pause`] between them): a BSY that never clears is [`FlashError::Timeout`], not
//! a hang.
//!
//! The firmware (`src/app/settings_flash.rs`) gives this driver the real registers; the host
//! tests give it a model of the FPEC (`f103_tests.rs`).

use super::{Flash, FlashError, Page};
use crate::board;

/// Start of the main flash.
pub const MAIN_FLASH_START: u32 = 0x0800_0000;
/// End (exclusive) of the STM32F103RE's 512 KiB main flash.
pub const MAIN_FLASH_END: u32 = 0x0808_0000;
/// FLASH_KEYR unlock keys, in this order (RM0008 §3.3.3, PM0075 §2.3.1).
pub const KEY1: u32 = 0x4567_0123;
/// See [`KEY1`].
pub const KEY2: u32 = 0xCDEF_89AB;
/// FLASH_SR: busy.
pub const SR_BSY: u32 = 1 << 0;
/// FLASH_SR: programming error (the half-word was not erased), write 1 to clear.
pub const SR_PGERR: u32 = 1 << 2;
/// FLASH_SR: write-protection error, write 1 to clear.
pub const SR_WRPRTERR: u32 = 1 << 4;
/// FLASH_SR: end of operation (set after every successful erase or program), write 1 to clear.
pub const SR_EOP: u32 = 1 << 5;
/// FLASH_CR: programming.
pub const CR_PG: u32 = 1 << 0;
/// FLASH_CR: page erase.
pub const CR_PER: u32 = 1 << 1;
/// FLASH_CR: start the erase.
pub const CR_STRT: u32 = 1 << 6;
/// FLASH_CR: locked (write 1 to lock; only the key sequence clears it).
pub const CR_LOCK: u32 = 1 << 7;
/// Polls of FLASH_SR at most for an erase (and for a busy controller before one), with
/// [`FpecRegs::pause`] (1 µs) between two: 100 ms, 2.5 times the datasheet's longest page
/// erase (t_ERASE ≤ 40 ms, DS5792 table "Flash memory characteristics").
pub const ERASE_POLLS: u32 = 100_000;
/// Polls of FLASH_SR at most for a half-word program: 1 ms, 14 times the longest
/// (t_PROG ≤ 70 µs).
pub const PROGRAM_POLLS: u32 = 1_000;

/// The FPEC's registers and the flash memory, as the driver uses them.
pub trait FpecRegs {
    /// Reads FLASH_SR.
    fn sr(&mut self) -> u32;
    /// Writes FLASH_SR (1 clears EOP, PGERR, WRPRTERR; 0 leaves them).
    fn write_sr(&mut self, value: u32);
    /// Reads FLASH_CR.
    fn cr(&mut self) -> u32;
    /// Writes FLASH_CR.
    fn write_cr(&mut self, value: u32);
    /// Writes FLASH_KEYR.
    fn write_keyr(&mut self, key: u32);
    /// Writes FLASH_AR.
    fn write_ar(&mut self, address: u32);
    /// Writes the half-word at flash address `address` (even).
    fn write_half(&mut self, address: u32, value: u16);
    /// Reads the byte at flash address `address`.
    fn read_byte(&self, address: u32) -> u8;
    /// Waits about 1 µs between two polls of FLASH_SR.
    fn pause(&mut self);
}

/// The settings pages on the STM32F103RE's flash controller. See the module documentation.
pub struct F103Flash<R> {
    regs: R,
}

/// Absolute address of `page`.
pub const fn page_address(page: Page) -> u32 {
    match page {
        Page::A => board::SETTINGS_PAGE_A,
        Page::B => board::SETTINGS_PAGE_B,
    }
}

/// Absolute address of `len` bytes at `offset` in `page`, if they lie inside it.
fn address(page: Page, offset: usize, len: usize) -> Result<u32, FlashError> {
    match offset.checked_add(len) {
        Some(end) if end <= board::FLASH_PAGE_SIZE => Ok(page_address(page) + offset as u32),
        _ => Err(FlashError::OutOfBounds),
    }
}

impl<R: FpecRegs> F103Flash<R> {
    /// The driver over `regs` (the controller may be locked or not, busy or not).
    pub const fn new(regs: R) -> Self {
        F103Flash { regs }
    }

    /// The registers (tests).
    pub fn regs(&self) -> &R {
        &self.regs
    }

    /// The registers, mutably (tests).
    pub fn regs_mut(&mut self) -> &mut R {
        &mut self.regs
    }

    /// Waits (bounded) until BSY is clear; with `done`, also until EOP or an error flag is
    /// set. Returns FLASH_SR, or [`FlashError::Timeout`].
    fn wait(&mut self, polls: u32, done: bool) -> Result<u32, FlashError> {
        for _ in 0..polls {
            let sr = self.regs.sr();
            if sr & SR_BSY == 0 && (!done || sr & (SR_EOP | SR_PGERR | SR_WRPRTERR) != 0) {
                return Ok(sr);
            }
            self.regs.pause();
        }
        Err(FlashError::Timeout)
    }

    /// Waits until the controller is idle; unlocks FLASH_CR if it is locked; clears stale
    /// status flags.
    fn begin(&mut self) -> Result<(), FlashError> {
        self.wait(ERASE_POLLS, false)?;
        if self.regs.cr() & CR_LOCK != 0 {
            self.regs.write_keyr(KEY1);
            self.regs.write_keyr(KEY2);
            if self.regs.cr() & CR_LOCK != 0 {
                return Err(FlashError::Locked);
            }
        }
        self.regs.write_sr(SR_EOP | SR_PGERR | SR_WRPRTERR);
        Ok(())
    }

    /// FLASH_CR without PG, PER, STRT: an operation bit left set by other code (a known pitfall
    /// with ST's HAL: its `FLASH_PageErase` called on its own leaves PER set) would make the
    /// next operation PG and PER at once.
    fn idle_cr(&mut self) -> u32 {
        self.regs.cr() & !(CR_PG | CR_PER | CR_STRT)
    }

    /// Clears the operation bit `op`, locks FLASH_CR, clears the status flags; maps the
    /// outcome of the wait (`waited`) to the error `failed` stands for.
    fn end(
        &mut self,
        op: u32,
        waited: Result<u32, FlashError>,
        failed: FlashError,
    ) -> Result<(), FlashError> {
        let cr = self.regs.cr();
        self.regs.write_cr(cr & !(op | CR_STRT));
        self.regs.write_cr((cr & !(op | CR_STRT)) | CR_LOCK);
        let sr = waited?;
        self.regs.write_sr(SR_EOP | SR_PGERR | SR_WRPRTERR);
        if sr & SR_WRPRTERR != 0 {
            Err(FlashError::WriteProtected)
        } else if sr & SR_PGERR != 0 || sr & SR_EOP == 0 {
            Err(failed)
        } else {
            Ok(())
        }
    }
}

impl<R: FpecRegs> Flash for F103Flash<R> {
    fn page_size(&self) -> usize {
        board::FLASH_PAGE_SIZE
    }

    fn read(&self, page: Page, offset: usize, buf: &mut [u8]) -> Result<(), FlashError> {
        let start = address(page, offset, buf.len())?;
        for (at, b) in (start..).zip(buf.iter_mut()) {
            *b = self.regs.read_byte(at);
        }
        Ok(())
    }

    fn erase(&mut self, page: Page) -> Result<(), FlashError> {
        let start = page_address(page);
        self.begin()?;
        let cr = self.idle_cr();
        self.regs.write_cr(cr | CR_PER);
        self.regs.write_ar(start);
        self.regs.write_cr(cr | CR_PER | CR_STRT);
        let waited = self.wait(ERASE_POLLS, true);
        self.end(CR_PER, waited, FlashError::Erase)?;
        let mut at = start;
        while at < start + board::FLASH_PAGE_SIZE as u32 {
            if self.regs.read_byte(at) != 0xFF {
                return Err(FlashError::Erase);
            }
            at += 1;
        }
        Ok(())
    }

    fn program(&mut self, page: Page, offset: usize, value: u16) -> Result<(), FlashError> {
        if offset % 2 != 0 {
            return Err(FlashError::OutOfBounds);
        }
        let at = address(page, offset, 2)?;
        self.begin()?;
        let cr = self.idle_cr();
        self.regs.write_cr(cr | CR_PG);
        self.regs.write_half(at, value);
        let waited = self.wait(PROGRAM_POLLS, true);
        self.end(CR_PG, waited, FlashError::Program)?;
        let [lo, hi] = value.to_le_bytes();
        if self.regs.read_byte(at) != lo || self.regs.read_byte(at + 1) != hi {
            return Err(FlashError::Program);
        }
        Ok(())
    }
}

#[cfg(test)]
#[path = "f103_tests.rs"]
mod tests;
