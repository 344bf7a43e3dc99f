//! The settings pages in the STM32F103RE's own flash: [`persist::Flash`] over the HAL's
//! `FlashWriter` (2 KiB page erase, 16-bit half-word programming, both verified by the HAL).
//!
//! Page A is at `board::SETTINGS_PAGE_A` (0x0807_F000), page B at `board::SETTINGS_PAGE_B`
//! (0x0807_F800); `memory.x` keeps code out of both. Erasing or programming stalls the CPU
//! (instruction fetches wait for the flash): a page erase takes about 20–40 ms, during which
//! no interrupt is served (ADC frames are lost and counted; received bytes may be lost).
//! The HSI oscillator, which the flash interface needs for writing, is never switched off.

use inemo_ahrs::board;
use inemo_ahrs::persist::{Flash, FlashError, Page};
use stm32f1xx_hal::flash::{self, FlashSize, SectorSize, FLASH_START};

/// The flash controller, for the two settings pages only.
pub struct SettingsFlash {
    parts: flash::Parts,
}

impl SettingsFlash {
    /// Takes the flash controller (its `acr` has already set the wait states).
    pub fn new(parts: flash::Parts) -> Self {
        SettingsFlash { parts }
    }

    fn writer(&mut self) -> flash::FlashWriter<'_> {
        self.parts.writer(SectorSize::Sz2K, FlashSize::Sz512K)
    }
}

/// Absolute address of `page`.
const fn base(page: Page) -> u32 {
    match page {
        Page::A => board::SETTINGS_PAGE_A,
        Page::B => board::SETTINGS_PAGE_B,
    }
}

/// `offset` .. `offset + len` within a page.
fn check(offset: usize, len: usize) -> Result<u32, FlashError> {
    match offset.checked_add(len) {
        Some(end) if end <= board::FLASH_PAGE_SIZE => Ok(offset as u32),
        _ => Err(FlashError::OutOfBounds),
    }
}

impl Flash for SettingsFlash {
    fn page_size(&self) -> usize {
        board::FLASH_PAGE_SIZE
    }

    fn read(&self, page: Page, offset: usize, buf: &mut [u8]) -> Result<(), FlashError> {
        let addr = base(page) + check(offset, buf.len())?;
        for (i, b) in buf.iter_mut().enumerate() {
            // SAFETY: inside one of the two settings pages (checked above), which are
            // readable flash that no Rust object occupies.
            *b = unsafe { core::ptr::read_volatile((addr as usize + i) as *const u8) };
        }
        Ok(())
    }

    fn erase(&mut self, page: Page) -> Result<(), FlashError> {
        let offset = base(page) - FLASH_START;
        self.writer().page_erase(offset).map_err(|_| FlashError::Erase)
    }

    fn program(&mut self, page: Page, offset: usize, value: u16) -> Result<(), FlashError> {
        if offset % 2 != 0 {
            return Err(FlashError::OutOfBounds);
        }
        let offset = base(page) - FLASH_START + check(offset, 2)?;
        self.writer().write(offset, &value.to_le_bytes()).map_err(|_| FlashError::Program)
    }
}
