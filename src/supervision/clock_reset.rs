//! The clock tree back to its reset state, from whatever ran before (issue #37).
//!
//! ST's DFU bootloader of the iNEMO V2 (`main.c`, V2.0.0) runs `SystemInit()` and jumps to the
//! application with SYSCLK on the PLL at 72 MHz from the crystal, APB1 at /2; a debugger's
//! reset or our own watchdog reset leave the reset state. `clocks::freeze` assumes the reset
//! state: its crystal check runs the timer on "the HSI" and then on the HSE, and the HAL
//! writes PLLMUL/PLLSRC, which RM0008 (§8.3.2) allows only with the PLL off. So the clock
//! tree is first put back as ST's own `SystemInit()` does (CMSIS `system_stm32f10x.c`,
//! V3.5.0, 11-March-2011: HSION; CFGR &= 0xF8FF0000; CR &= 0xFEF6FFFF; CR &= 0xFFFBFFFF;
//! CFGR &= 0xFF80FFFF; CIR = 0x009F0000), with three differences: it switches SYSCLK to the
//! HSI before it resets the prescalers (APB1 at /1 on a 72 MHz SYSCLK would exceed 36 MHz);
//! it waits, bounded, for the switch to the HSI (SWS) before turning the PLL off (RM0008 §8.3.1: PLLON "cannot be
//! cleared if the PLL clock is used as system clock", and HSEON likewise while the HSE feeds
//! it), and for PLLRDY to clear; and it clears the whole CFGR (its bits are all zero at
//! reset, SWS follows SW). Register bits from RM0008 Rev 21, §8.3.1 (RCC_CR) and §8.3.2
//! (RCC_CFGR).
//!
//! The sequence runs against [`RccRegs`]: the RCC on the target (`src/app/clocks.rs`), and a
//! model of its documented behaviour in the tests below.

/// RCC_CR: HSI on.
pub const CR_HSION: u32 = 1 << 0;
/// RCC_CR: HSI ready.
pub const CR_HSIRDY: u32 = 1 << 1;
/// RCC_CR: HSE on.
pub const CR_HSEON: u32 = 1 << 16;
/// RCC_CR: HSE ready.
pub const CR_HSERDY: u32 = 1 << 17;
/// RCC_CR: HSE bypass (external clock instead of a crystal).
pub const CR_HSEBYP: u32 = 1 << 18;
/// RCC_CR: clock security system on.
pub const CR_CSSON: u32 = 1 << 19;
/// RCC_CR: PLL on.
pub const CR_PLLON: u32 = 1 << 24;
/// RCC_CR: PLL locked.
pub const CR_PLLRDY: u32 = 1 << 25;
/// RCC_CFGR: SW, the system clock switch (00 HSI, 01 HSE, 10 PLL).
pub const CFGR_SW: u32 = 0b11;
/// RCC_CFGR: SWS, the system clock in use (read-only, same coding, bits 3:2).
pub const CFGR_SWS: u32 = 0b11 << 2;
/// What ST's first write of RCC_CFGR keeps: the PLL's source, predivider and multiplier and
/// the USB prescaler (bits 23:16).
pub const CFGR_KEEP_PLL: u32 = 0xF8FF_0000;
/// RCC_CIR at reset as ST writes it: every ready interrupt off, every flag cleared (LSIRDYC,
/// LSERDYC, HSIRDYC, HSERDYC, PLLRDYC and CSSC).
pub const CIR_CLEAR: u32 = 0x009F_0000;

/// Reads of a status bit at most per wait: each wait takes a few cycles of the slower clock
/// (SWS), or the PLL's stop (PLLRDY, microseconds); at 72 MHz 10,000 reads are over 500 µs.
pub const POLLS: u32 = 10_000;

/// The RCC registers the reset touches.
pub trait RccRegs {
    /// RCC_CR.
    fn cr(&self) -> u32;
    /// Write RCC_CR.
    fn set_cr(&mut self, v: u32);
    /// RCC_CFGR.
    fn cfgr(&self) -> u32;
    /// Write RCC_CFGR.
    fn set_cfgr(&mut self, v: u32);
    /// Write RCC_CIR.
    fn set_cir(&mut self, v: u32);
}

/// What did not follow within [`POLLS`] reads. The sequence goes on regardless (whatever is
/// left, the HAL's `freeze` and the crystal check meet it); the boot log names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetError {
    /// The HSI did not become ready.
    HsiNotReady,
    /// SYSCLK did not switch to the HSI (SWS stayed at `sws`).
    NotOnHsi {
        /// The SWS field read last (0 HSI, 1 HSE, 2 PLL).
        sws: u8,
    },
    /// The PLL did not stop (PLLRDY stayed set).
    PllRunning,
}

/// Wait for `done` over at most [`POLLS`] reads.
fn wait<R: RccRegs>(r: &R, done: impl Fn(&R) -> bool) -> bool {
    (0..POLLS).any(|_| done(r))
}

/// The clock tree as at reset: SYSCLK on the HSI (8 MHz), the PLL and the HSE off, every
/// prescaler /1, the clock interrupts off and their flags cleared. Every wait bounded; the
/// first failure is returned, after every step has been tried.
pub fn reset_clock_tree<R: RccRegs>(r: &mut R) -> Result<(), ResetError> {
    let mut first = None;
    let mut fail = |e: ResetError| {
        if first.is_none() {
            first = Some(e);
        }
    };
    r.set_cr(r.cr() | CR_HSION);
    if !wait(r, |r| r.cr() & CR_HSIRDY != 0) {
        fail(ResetError::HsiNotReady);
    }
    // SYSCLK to the HSI first, the prescalers kept until it has switched (ST's single write
    // sets APB1 to /1 while SYSCLK may still be the PLL's 72 MHz, twice APB1's 36 MHz limit,
    // for the switch's few cycles); then the prescalers and MCO to reset (ST's mask: bits
    // 15:0 and 26:24). The PLL's configuration cannot be written while it runs, so it is
    // cleared after the PLL is off.
    r.set_cfgr(r.cfgr() & !CFGR_SW);
    if !wait(r, |r| r.cfgr() & CFGR_SWS == 0) {
        fail(ResetError::NotOnHsi { sws: ((r.cfgr() & CFGR_SWS) >> 2) as u8 });
    }
    r.set_cfgr(r.cfgr() & CFGR_KEEP_PLL);
    // PLL, clock security and HSE off (in that order of dependence), then the bypass.
    r.set_cr(r.cr() & !(CR_PLLON | CR_CSSON));
    if !wait(r, |r| r.cr() & CR_PLLRDY == 0) {
        fail(ResetError::PllRunning);
    }
    r.set_cr(r.cr() & !CR_HSEON);
    r.set_cr(r.cr() & !CR_HSEBYP);
    r.set_cfgr(0);
    r.set_cir(CIR_CLEAR);
    match first {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::cell::Cell;

    /// The RCC as RM0008 §8.3.1–§8.3.2 describes it, for what the sequence touches: SWS
    /// follows SW after `switch_delay` reads of CFGR; PLLRDY follows PLLON, HSERDY HSEON and
    /// HSIRDY HSION after `ready_delay` reads of CR; PLLON cannot be cleared while the PLL is
    /// the system clock, HSEON not while the HSE is the system clock or feeds a running PLL,
    /// HSEBYP not while HSEON; PLLSRC, PLLXTPRE and PLLMUL cannot be written while the PLL is
    /// on ("when the PLL is disabled": read strictly, until PLLRDY has cleared). Reads are
    /// counted, to bound the waits.
    struct Model {
        cr: Cell<u32>,
        cfgr: Cell<u32>,
        cir: u32,
        switch_delay: u32,
        ready_delay: u32,
        /// Reads since the last write of CR / CFGR.
        cr_reads: Cell<u32>,
        cfgr_reads: Cell<u32>,
        reads: Cell<u32>,
        /// SWS stuck (a broken switch): it never follows.
        sws_stuck: bool,
        /// Every value written to CFGR, as written.
        cfgr_writes: Vec<u32>,
    }

    const PLL_CFG: u32 = 0x003F_0000; // PLLSRC, PLLXTPRE, PLLMUL

    impl Model {
        fn new(cr: u32, cfgr: u32) -> Self {
            Model {
                cr: Cell::new(cr),
                cfgr: Cell::new(cfgr),
                cir: 0x1F, // ready flags pending
                switch_delay: 3,
                ready_delay: 5,
                cr_reads: Cell::new(0),
                cfgr_reads: Cell::new(0),
                reads: Cell::new(0),
                sws_stuck: false,
                cfgr_writes: Vec::new(),
            }
        }

        /// At reset: HSI on and ready, everything else zero.
        fn at_reset() -> Self {
            Model::new(CR_HSION | CR_HSIRDY, 0)
        }

        /// As ST's DFU bootloader leaves it: SYSCLK on the PLL, 72 MHz = 8 MHz HSE × 9,
        /// APB1 /2 (PPRE1 = 100), flash wait states aside.
        fn after_st_bootloader() -> Self {
            let cr = CR_HSION | CR_HSIRDY | CR_HSEON | CR_HSERDY | CR_PLLON | CR_PLLRDY;
            let cfgr = 0b10 | 0b10 << 2 | 0b100 << 8 | 1 << 16 | 0b0111 << 18;
            Model::new(cr, cfgr)
        }

        fn sws(&self) -> u32 {
            (self.cfgr.get() & CFGR_SWS) >> 2
        }
    }

    impl RccRegs for Model {
        fn cr(&self) -> u32 {
            self.reads.set(self.reads.get() + 1);
            let n = self.cr_reads.get() + 1;
            self.cr_reads.set(n);
            let mut cr = self.cr.get();
            if n >= self.ready_delay {
                for (on, rdy) in
                    [(CR_HSION, CR_HSIRDY), (CR_HSEON, CR_HSERDY), (CR_PLLON, CR_PLLRDY)]
                {
                    cr = if cr & on != 0 { cr | rdy } else { cr & !rdy };
                }
                self.cr.set(cr);
            }
            cr
        }

        fn set_cr(&mut self, v: u32) {
            let old = self.cr.get();
            let sws = self.sws();
            let mut v = (v & !(CR_HSIRDY | CR_HSERDY | CR_PLLRDY))
                | (old & (CR_HSIRDY | CR_HSERDY | CR_PLLRDY));
            if sws == 0b10 && old & CR_PLLON != 0 {
                v |= CR_PLLON; // the PLL is the system clock: PLLON stays
            }
            let pll_on = v & CR_PLLON != 0;
            let pll_from_hse = self.cfgr.get() & (1 << 16) != 0;
            if old & CR_HSEON != 0 && (sws == 0b01 || (pll_on && pll_from_hse)) {
                v |= CR_HSEON; // the HSE clocks the system: HSEON stays
            }
            if old & CR_HSEON != 0 || v & CR_HSEON != 0 {
                v = (v & !CR_HSEBYP) | (old & CR_HSEBYP); // HSEBYP only with the HSE off
            }
            self.cr.set(v);
            self.cr_reads.set(0);
        }

        fn cfgr(&self) -> u32 {
            self.reads.set(self.reads.get() + 1);
            let n = self.cfgr_reads.get() + 1;
            self.cfgr_reads.set(n);
            let c = self.cfgr.get();
            if n >= self.switch_delay && !self.sws_stuck {
                self.cfgr.set((c & !CFGR_SWS) | (c & CFGR_SW) << 2);
            }
            self.cfgr.get()
        }

        fn set_cfgr(&mut self, v: u32) {
            self.cfgr_writes.push(v);
            let old = self.cfgr.get();
            let mut v = (v & !CFGR_SWS) | (old & CFGR_SWS); // SWS is read-only
            if self.cr.get() & (CR_PLLON | CR_PLLRDY) != 0 {
                v = (v & !PLL_CFG) | (old & PLL_CFG); // locked until the PLL has stopped
            }
            self.cfgr.set(v);
            self.cfgr_reads.set(0);
        }

        fn set_cir(&mut self, v: u32) {
            // The clear bits (23:16) clear the flags (bits 4:0 and 7), and read back as 0.
            self.cir = (self.cir & !(v >> 16 & 0x9F)) & !0x00FF_0000 | (v & 0x0000_FF00);
        }
    }

    #[test]
    fn from_st_s_bootloader_the_tree_is_as_at_reset() {
        let mut m = Model::after_st_bootloader();
        assert_eq!(reset_clock_tree(&mut m), Ok(()));
        // Reading settles the ready bits.
        for _ in 0..10 {
            let _ = (m.cr(), m.cfgr());
        }
        let reset = Model::at_reset();
        assert_eq!(m.cr.get(), reset.cr.get(), "CR {:#010x}", m.cr.get());
        assert_eq!(m.cfgr.get(), 0, "CFGR {:#010x}", m.cfgr.get());
        assert_eq!(m.cir & 0x9F, 0, "CIR flags {:#x}", m.cir);
    }

    /// The bits and ST's masks as RM0008 Rev 21 (§8.3.1 RCC_CR, §8.3.2 RCC_CFGR) and
    /// `system_stm32f10x.c` V3.5.0 write them, in hex, not from the constants above (the model
    /// uses those: a wrong bit would move both).
    #[test]
    fn the_register_bits_are_rm0008_s() {
        let cr =
            [CR_HSION, CR_HSIRDY, CR_HSEON, CR_HSERDY, CR_HSEBYP, CR_CSSON, CR_PLLON, CR_PLLRDY];
        assert_eq!(
            cr,
            [
                0x1,
                0x2,
                0x0001_0000,
                0x0002_0000,
                0x0004_0000,
                0x0008_0000,
                0x0100_0000,
                0x0200_0000
            ]
        );
        assert_eq!((CFGR_SW, CFGR_SWS), (0x3, 0xC));
        // SystemInit: RCC->CR &= 0xFEF6FFFF (HSEON, CSSON, PLLON off), &= 0xFFFBFFFF (HSEBYP).
        assert_eq!(!(CR_HSEON | CR_CSSON | CR_PLLON), 0xFEF6_FFFF);
        assert_eq!(!CR_HSEBYP, 0xFFFB_FFFF);
        assert_eq!((CFGR_KEEP_PLL, CIR_CLEAR), (0xF8FF_0000, 0x009F_0000));
    }

    /// From the bootloader's CFGR (0x001D040A: SW = SWS = PLL, PPRE1 /2, PLLSRC HSE, PLLMUL
    /// ×9), the writes by hand: SW to the HSI (0x001D0408), then, switched, the prescalers and
    /// MCO to reset with the PLL's configuration kept (0x001D0000), then, the PLL stopped, 0.
    #[test]
    fn the_cfgr_writes_are_the_safe_order_s() {
        let mut m = Model::after_st_bootloader();
        assert_eq!(m.cfgr.get(), 0x001D_040A);
        assert_eq!(reset_clock_tree(&mut m), Ok(()));
        assert_eq!(m.cfgr_writes, [0x001D_0408, 0x001D_0000, 0]);
    }

    /// A clock left on the HSE alone, the HSI off (a bootloader may stop it): the HSI comes
    /// back, the system clock goes to it, and the HSE stops.
    #[test]
    fn from_the_hse_alone_the_hsi_comes_back() {
        let mut m = Model::new(CR_HSEON | CR_HSERDY, 0b01 | 0b01 << 2);
        assert_eq!(reset_clock_tree(&mut m), Ok(()));
        for _ in 0..10 {
            let _ = (m.cr(), m.cfgr());
        }
        assert_eq!((m.cr.get(), m.cfgr.get()), (CR_HSION | CR_HSIRDY, 0));
    }

    #[test]
    fn from_reset_it_changes_nothing() {
        let mut m = Model::at_reset();
        assert_eq!(reset_clock_tree(&mut m), Ok(()));
        assert_eq!((m.cr.get(), m.cfgr.get()), (CR_HSION | CR_HSIRDY, 0));
    }

    /// ST's own order without the wait for SWS: the PLL is still the system clock when PLLON
    /// is cleared, so it stays on, and the PLL's configuration stays locked. The wait is what
    /// makes the sequence work on this model (a switch takes a few cycles of both clocks).
    #[test]
    fn without_the_wait_for_the_switch_the_pll_stays_on() {
        let mut m = Model::after_st_bootloader();
        m.set_cr(m.cr() | CR_HSION);
        m.set_cfgr(m.cfgr.get() & !CFGR_SW);
        m.set_cr(m.cr.get() & !(CR_PLLON | CR_CSSON | CR_HSEON));
        m.set_cfgr(0);
        assert_ne!(m.cr.get() & CR_PLLON, 0, "PLLON cleared while the PLL was the system clock");
        assert_ne!(m.cfgr.get() & PLL_CFG, 0, "PLL configuration written while it ran");
    }

    /// A switch that never completes (SWS stuck on the PLL): the sequence returns, after at
    /// most a few times [`POLLS`] reads, and says where it stuck.
    #[test]
    fn every_wait_is_bounded() {
        let mut m = Model::after_st_bootloader();
        m.sws_stuck = true;
        let r = reset_clock_tree(&mut m);
        assert_eq!(r, Err(ResetError::NotOnHsi { sws: 2 }));
        assert!(m.reads.get() <= 4 * POLLS, "{} reads", m.reads.get());
        // An HSI that never becomes ready.
        let mut m = Model::new(0, 0);
        m.ready_delay = u32::MAX;
        assert_eq!(reset_clock_tree(&mut m), Err(ResetError::HsiNotReady));
        assert!(m.reads.get() <= 4 * POLLS, "{} reads", m.reads.get());
    }
}
