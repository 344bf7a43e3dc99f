//! The flash interface the settings store needs, and a simulated flash for host tests.

/// One of the two settings pages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Page {
    /// The first page.
    A,
    /// The second page.
    B,
}

impl Page {
    /// The other page.
    pub const fn other(self) -> Page {
        match self {
            Page::A => Page::B,
            Page::B => Page::A,
        }
    }

    /// `"A"` or `"B"`.
    pub const fn name(self) -> &'static str {
        match self {
            Page::A => "A",
            Page::B => "B",
        }
    }

    const fn index(self) -> usize {
        match self {
            Page::A => 0,
            Page::B => 1,
        }
    }
}

/// Why a flash operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlashError {
    /// Offset or length outside the page, or an odd offset for a half-word.
    OutOfBounds,
    /// The erase did not complete (no end of operation), or the page does not read erased.
    Erase,
    /// The program did not complete, the half-word was not erased (STM32F1 `PGERR`), or it
    /// does not read back as written.
    Program,
    /// The flash controller stayed locked after the unlock keys (STM32F1: until the next
    /// reset, after a wrong key sequence).
    Locked,
    /// The page is write-protected (STM32F1 `WRPRTERR`).
    WriteProtected,
    /// The flash controller stayed busy past the longest erase or program time.
    Timeout,
    /// Simulated power loss ([`SimFlash`] only): nothing more is written until
    /// [`SimFlash::power_on`].
    PowerLoss,
}

/// Two erasable pages of NOR flash, as on the STM32F103RE: a page erases to all-ones
/// (0xFF bytes) and is programmed one 16-bit half-word at a time (little-endian, even
/// offsets); programming can only clear bits.
///
/// On the board, the pages are the last two 2 KiB pages of the 512 KiB bank
/// (0x0807_F000 = A and 0x0807_F800 = B; the linker script must keep code out of them), and
/// the implementation is [`F103Flash`](super::f103::F103Flash), the register-level driver of
/// the flash controller.
pub trait Flash {
    /// Page size, bytes (2048 on the STM32F103RE).
    fn page_size(&self) -> usize;
    /// Read `buf.len()` bytes of `page` from `offset`.
    fn read(&self, page: Page, offset: usize, buf: &mut [u8]) -> Result<(), FlashError>;
    /// Erase `page` (every byte becomes 0xFF).
    fn erase(&mut self, page: Page) -> Result<(), FlashError>;
    /// Program the half-word at even `offset` of `page` (bytes `offset`, `offset + 1` =
    /// `value`'s low and high byte).
    fn program(&mut self, page: Page, offset: usize, value: u16) -> Result<(), FlashError>;
}

/// Page size of [`SimFlash`], bytes (the STM32F103RE's).
pub const SIM_PAGE_SIZE: usize = 2048;

/// A simulated two-page flash with a power cut: erased bytes read 0xFF, programming ANDs
/// (clears bits only) and, like the STM32F1, refuses to program a half-word that is not
/// erased unless the value is 0. After [`SimFlash::cut_power_after`]`(n)`, the first `n`
/// write steps (erases and programs) complete and every later one fails with
/// [`FlashError::PowerLoss`] and changes nothing — or, with `torn`, the interrupted step is
/// left half done (the first half of an erased page, the low byte of a half-word).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SimFlash {
    pages: [[u8; SIM_PAGE_SIZE]; 2],
    /// Write steps done (erases and programs that changed the flash).
    pub steps: usize,
    cut_after: Option<usize>,
    torn: bool,
    off: bool,
}

impl Default for SimFlash {
    fn default() -> Self {
        SimFlash::new()
    }
}

impl SimFlash {
    /// Both pages erased, power on.
    pub const fn new() -> Self {
        SimFlash {
            pages: [[0xFF; SIM_PAGE_SIZE]; 2],
            steps: 0,
            cut_after: None,
            torn: false,
            off: false,
        }
    }

    /// Cut the power after `n` more write steps; with `torn`, the step that is interrupted
    /// is left half done.
    pub fn cut_power_after(&mut self, n: usize, torn: bool) {
        self.cut_after = Some(self.steps + n);
        self.torn = torn;
    }

    /// Power back on: writes work again, without a cut.
    pub fn power_on(&mut self) {
        self.cut_after = None;
        self.off = false;
    }

    /// True after a simulated power cut (until [`SimFlash::power_on`]).
    pub fn is_off(&self) -> bool {
        self.off
    }

    /// The raw bytes of `page`.
    pub fn page(&self, page: Page) -> &[u8; SIM_PAGE_SIZE] {
        &self.pages[page.index()]
    }

    /// The raw bytes of `page`, for corrupting it in tests.
    pub fn page_mut(&mut self, page: Page) -> &mut [u8; SIM_PAGE_SIZE] {
        &mut self.pages[page.index()]
    }

    /// True if this step is cut; marks the flash as off.
    fn cut_now(&mut self) -> bool {
        if self.off {
            return true;
        }
        if self.cut_after.is_some_and(|n| self.steps >= n) {
            self.off = true;
            return true;
        }
        false
    }
}

impl Flash for SimFlash {
    fn page_size(&self) -> usize {
        SIM_PAGE_SIZE
    }

    fn read(&self, page: Page, offset: usize, buf: &mut [u8]) -> Result<(), FlashError> {
        // Checked all through (`get`, zip): the emulated firmware runs this on its cycle, and
        // the no-panic proof of `scripts/size-report` covers it.
        let src = self
            .pages
            .get(page.index())
            .and_then(|p| p.get(offset..offset.saturating_add(buf.len())))
            .ok_or(FlashError::OutOfBounds)?;
        for (d, s) in buf.iter_mut().zip(src) {
            *d = *s;
        }
        Ok(())
    }

    fn erase(&mut self, page: Page) -> Result<(), FlashError> {
        let was_off = self.off;
        if self.cut_now() {
            if self.torn && !was_off {
                if let Some(half) =
                    self.pages.get_mut(page.index()).and_then(|p| p.get_mut(..SIM_PAGE_SIZE / 2))
                {
                    half.fill(0xFF);
                }
            }
            return Err(FlashError::PowerLoss);
        }
        self.pages.get_mut(page.index()).ok_or(FlashError::OutOfBounds)?.fill(0xFF);
        self.steps += 1;
        Ok(())
    }

    fn program(&mut self, page: Page, offset: usize, value: u16) -> Result<(), FlashError> {
        if offset % 2 != 0 || offset + 2 > SIM_PAGE_SIZE {
            return Err(FlashError::OutOfBounds);
        }
        let p = self.pages.get(page.index()).ok_or(FlashError::OutOfBounds)?;
        let [lo, hi] = match p.get(offset..offset + 2) {
            Some(&[lo, hi]) => [lo, hi],
            _ => return Err(FlashError::OutOfBounds),
        };
        let old = u16::from_le_bytes([lo, hi]);
        if old != 0xFFFF && value != 0 {
            return Err(FlashError::Program);
        }
        let was_off = self.off;
        if self.cut_now() {
            if self.torn && !was_off {
                if let Some(b) = self.pages.get_mut(page.index()).and_then(|p| p.get_mut(offset)) {
                    *b &= value.to_le_bytes()[0];
                }
            }
            return Err(FlashError::PowerLoss);
        }
        let new = (old & value).to_le_bytes();
        let p = self.pages.get_mut(page.index()).ok_or(FlashError::OutOfBounds)?;
        if let Some(dst) = p.get_mut(offset..offset + 2) {
            for (d, n) in dst.iter_mut().zip(new) {
                *d = n;
            }
        }
        self.steps += 1;
        Ok(())
    }
}
