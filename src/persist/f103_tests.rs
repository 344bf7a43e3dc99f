//! [`F103Flash`] against a model of the STM32F103RE's flash controller (FPEC).

use std::cell::RefCell;

use super::*;
use crate::persist::tests::variant;
use crate::persist::{load, save, Saved, SimFlash, Source};
use crate::settings::PipelineSettings;

/// Main flash size and page size of the 512 KiB (high-density) part.
const MAIN_SIZE: usize = (MAIN_FLASH_END - MAIN_FLASH_START) as usize;
const PAGE: usize = 2048;
const PAGES: usize = MAIN_SIZE / PAGE;
/// The settings pages: the driver may touch nothing else.
const SETTINGS: core::ops::Range<u32> = 0x0807_F000..0x0808_0000;

/// One access of the driver (FLASH_SR reads and pauses are only counted).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Access {
    WriteSr(u32),
    Cr,
    WriteCr(u32),
    Keyr(u32),
    Ar(u32),
    Half(u32, u16),
    Read(u32),
}

/// An operation under way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Op {
    /// Erase the page of this index.
    Erase(usize),
    /// Program the half-word at this offset in the main flash.
    Program(usize, u16),
    /// Something the driver did not start (busy at hand-over).
    Other,
}

/// The FPEC of the STM32F103RE (RM0008 §3, PM0075 §2–3) with its 512 KiB main flash at
/// 0x0800_0000, 256 pages of 2 KiB:
/// - reset state: FLASH_CR locked (LOCK = 1); KEY1 then KEY2 into FLASH_KEYR unlock it; any
///   other key, or a key while unlocked (the manual does not say what that does: the model
///   assumes the worst), locks FLASH_CR until reset; writes to FLASH_CR while locked are
///   ignored; LOCK protects FLASH_CR only, not the flash: a PG left set keeps the flash
///   programmable by any half-word write, locked or not (as reported on ST's forum, "Illegal
///   Flash Memory writes possible?", 2011);
/// - page erase: PER, FLASH_AR = any address in the page, STRT; every byte of the page then
///   reads 0xFF; half-word program: PG, then a half-word write: refused with PGERR when the
///   half-word is not 0xFFFF, unless the value is 0x0000; programming only clears bits;
/// - a page protected in [`Fpec::protect`] (FLASH_WRPR: bit n < 31 protects pages 2n and
///   2n + 1, bit 31 pages 62–255) refuses both with WRPRTERR;
/// - an operation is BSY for [`Fpec::busy_polls`] reads of FLASH_SR, after
///   [`Fpec::start_delay`] reads during which BSY has not risen yet; then EOP is set;
///   [`Fpec::stuck`] keeps it busy forever; EOP, PGERR, WRPRTERR are cleared by writing 1;
/// - a bad cell ([`Fpec::bad_cell`]) keeps some bits at 0 through erases and others at 1
///   through programs (the operation still reports EOP);
/// - a power cut ([`Fpec::cut_power_after`]) at the start of an operation leaves it undone or
///   half done and the controller busy (dead) until [`Fpec::reset`].
///
/// Misuse that the hardware ignores, refuses with a bus error or leaves undefined is recorded
/// in `faults` (a write while busy or while locked, a flash write without PG, PG and PER
/// together, STRT without PER, an address outside the main flash, an odd half-word address).
#[derive(Clone, Debug)]
struct Fpec {
    mem: Vec<u8>,
    locked: bool,
    lockout: bool,
    key1_seen: bool,
    /// PG, PER, STRT.
    cr: u32,
    ar: u32,
    /// EOP, PGERR, WRPRTERR.
    flags: u32,
    op: Option<Op>,
    delay_left: u32,
    busy_left: u32,
    // Set-up.
    busy_polls: u32,
    start_delay: u32,
    stuck: bool,
    /// FLASH_WRPR bits that are protecting (1 = protected, the register's complement).
    protect: u32,
    bad_cell: Option<(usize, u8, u8)>,
    /// EOP set with PGERR/WRPRTERR too (the manual sets EOP "when an operation completes";
    /// whether a refused one counts is not said, so the tests try both).
    eop_on_error: bool,
    cut_at: Option<(usize, bool)>,
    off: bool,
    /// Erases and programs started.
    ops: usize,
    // Records.
    log: RefCell<Vec<Access>>,
    faults: RefCell<Vec<String>>,
    sr_reads: usize,
    pauses: usize,
}

impl Fpec {
    /// Main flash: the "firmware" (a pattern) below the settings pages, both pages erased.
    fn new() -> Self {
        let mut mem: Vec<u8> = (0..MAIN_SIZE).map(|i| (i * 7 + 3) as u8).collect();
        mem[(SETTINGS.start - MAIN_FLASH_START) as usize..].fill(0xFF);
        Fpec {
            mem,
            locked: true,
            lockout: false,
            key1_seen: false,
            cr: 0,
            ar: 0,
            flags: 0,
            op: None,
            delay_left: 0,
            busy_left: 0,
            busy_polls: 3,
            start_delay: 1,
            stuck: false,
            protect: 0,
            bad_cell: None,
            eop_on_error: false,
            cut_at: None,
            off: false,
            ops: 0,
            log: RefCell::new(Vec::new()),
            faults: RefCell::new(Vec::new()),
            sr_reads: 0,
            pauses: 0,
        }
    }

    /// A system reset: the registers to their reset values, the flash kept, power on.
    fn reset(&mut self) {
        self.locked = true;
        self.lockout = false;
        self.key1_seen = false;
        self.cr = 0;
        self.ar = 0;
        self.flags = 0;
        self.op = None;
        self.stuck = false;
        self.off = false;
        self.cut_at = None;
    }

    /// Power fails when operation `ops + n` starts (with `torn`, it is left half done).
    fn cut_power_after(&mut self, n: usize, torn: bool) {
        self.cut_at = Some((self.ops + n, torn));
    }

    /// Busy with an operation of someone else's for `polls` reads of FLASH_SR.
    fn occupy(&mut self, polls: u32) {
        self.op = Some(Op::Other);
        self.delay_left = 0;
        self.busy_left = polls;
    }

    fn fault(&self, what: String) {
        self.faults.borrow_mut().push(what);
    }

    fn busy(&self) -> bool {
        self.op.is_some()
    }

    /// Offset in the main flash of `address`, if it is in it.
    fn offset(&self, address: u32) -> Option<usize> {
        (MAIN_FLASH_START..MAIN_FLASH_END)
            .contains(&address)
            .then(|| (address - MAIN_FLASH_START) as usize)
    }

    fn protected(&self, page: usize) -> bool {
        let bit = if page < 62 { page / 2 } else { 31 };
        self.protect & (1 << bit) != 0
    }

    fn page_of(&self, offset: usize) -> usize {
        offset / PAGE
    }

    /// Starts `op` (the checks are done).
    fn start(&mut self, op: Op) {
        let n = self.ops;
        self.ops += 1;
        if let Some((at, torn)) = self.cut_at {
            if n >= at {
                if torn {
                    match op {
                        Op::Erase(p) => self.mem[p * PAGE..p * PAGE + PAGE / 2].fill(0xFF),
                        Op::Program(o, v) => self.mem[o] &= v.to_le_bytes()[0],
                        Op::Other => {}
                    }
                }
                self.off = true;
            }
        }
        self.op = Some(op);
        self.delay_left = self.start_delay;
        self.busy_left = self.busy_polls;
    }

    /// The operation under way completes.
    fn complete(&mut self) {
        match self.op.take() {
            Some(Op::Erase(p)) => {
                self.mem[p * PAGE..(p + 1) * PAGE].fill(0xFF);
                if let Some((o, zeros, _)) = self.bad_cell {
                    if self.page_of(o) == p {
                        self.mem[o] &= !zeros;
                    }
                }
            }
            Some(Op::Program(o, v)) => {
                for (i, b) in v.to_le_bytes().into_iter().enumerate() {
                    let mut b = self.mem[o + i] & b;
                    if let Some((bad, _, ones)) = self.bad_cell {
                        if bad == o + i {
                            b |= ones & self.mem[o + i];
                        }
                    }
                    self.mem[o + i] = b;
                }
            }
            Some(Op::Other) | None => {}
        }
        self.cr &= !CR_STRT;
        self.flags |= SR_EOP;
    }

    /// An operation refused with error flag `flag`.
    fn refuse(&mut self, flag: u32) {
        self.flags |= flag | if self.eop_on_error { SR_EOP } else { 0 };
    }

    fn write_while_busy(&self, what: &str) {
        if self.busy() {
            self.fault(format!("{what} written while busy"));
        }
    }

    /// The bytes of the settings pages.
    fn settings(&self) -> &[u8] {
        &self.mem[(SETTINGS.start - MAIN_FLASH_START) as usize..]
    }

    /// Everything the driver may not touch.
    fn outside_settings(&self) -> &[u8] {
        &self.mem[..(SETTINGS.start - MAIN_FLASH_START) as usize]
    }
}

impl FpecRegs for Fpec {
    fn sr(&mut self) -> u32 {
        self.sr_reads += 1;
        if self.busy() {
            if self.off || self.stuck {
                return self.flags | SR_BSY;
            }
            if self.delay_left > 0 {
                self.delay_left -= 1;
                return self.flags;
            }
            if self.busy_left > 0 {
                self.busy_left -= 1;
                return self.flags | SR_BSY;
            }
            self.complete();
        }
        self.flags
    }

    fn write_sr(&mut self, value: u32) {
        self.log.borrow_mut().push(Access::WriteSr(value));
        self.flags &= !(value & (SR_EOP | SR_PGERR | SR_WRPRTERR));
    }

    fn cr(&mut self) -> u32 {
        self.log.borrow_mut().push(Access::Cr);
        self.cr | if self.locked { CR_LOCK } else { 0 }
    }

    fn write_cr(&mut self, value: u32) {
        self.log.borrow_mut().push(Access::WriteCr(value));
        self.write_while_busy("FLASH_CR");
        if self.busy() {
            return;
        }
        if self.locked {
            if value & !CR_LOCK != 0 {
                self.fault(format!("FLASH_CR = {value:#x} while locked (ignored)"));
            }
            return;
        }
        if value & CR_PG != 0 && value & CR_PER != 0 {
            self.fault("PG and PER both set".into());
        }
        let strt = value & CR_STRT != 0 && self.cr & CR_STRT == 0;
        self.cr = value & (CR_PG | CR_PER | CR_STRT);
        if value & CR_LOCK != 0 {
            self.locked = true;
        }
        if strt {
            if value & CR_PER == 0 {
                self.fault("STRT without PER".into());
                return;
            }
            let Some(o) = self.offset(self.ar) else {
                self.fault(format!("erase of FLASH_AR {:#x}, outside the main flash", self.ar));
                return;
            };
            let page = self.page_of(o);
            if self.protected(page) {
                self.refuse(SR_WRPRTERR);
                self.cr &= !CR_STRT;
            } else {
                self.start(Op::Erase(page));
            }
        }
    }

    fn write_keyr(&mut self, key: u32) {
        self.log.borrow_mut().push(Access::Keyr(key));
        self.write_while_busy("FLASH_KEYR");
        if self.lockout {
            return;
        }
        let ok = self.locked && if self.key1_seen { key == KEY2 } else { key == KEY1 };
        if !ok {
            self.fault(format!("wrong key sequence ({key:#x}): locked until reset"));
            self.lockout = true;
            self.locked = true;
            self.key1_seen = false;
        } else if self.key1_seen {
            self.locked = false;
            self.key1_seen = false;
        } else {
            self.key1_seen = true;
        }
    }

    fn write_ar(&mut self, address: u32) {
        self.log.borrow_mut().push(Access::Ar(address));
        self.write_while_busy("FLASH_AR");
        if !self.busy() {
            self.ar = address;
        }
    }

    fn write_half(&mut self, address: u32, value: u16) {
        self.log.borrow_mut().push(Access::Half(address, value));
        self.write_while_busy("the flash");
        let Some(o) = self.offset(address) else {
            self.fault(format!("write to {address:#x}, outside the main flash"));
            return;
        };
        if address % 2 != 0 {
            self.fault(format!("half-word write to odd address {address:#x} (bus error)"));
            return;
        }
        if self.busy() {
            return;
        }
        if self.cr & CR_PG == 0 {
            self.fault(format!("write to the flash at {address:#x} without PG (ignored)"));
            return;
        }
        let old = u16::from_le_bytes([self.mem[o], self.mem[o + 1]]);
        if self.protected(self.page_of(o)) {
            self.refuse(SR_WRPRTERR);
        } else if old != 0xFFFF && value != 0 {
            self.refuse(SR_PGERR);
        } else {
            self.start(Op::Program(o, value));
        }
    }

    fn read_byte(&self, address: u32) -> u8 {
        self.log.borrow_mut().push(Access::Read(address));
        if self.busy() {
            self.fault(format!("flash read at {address:#x} while busy (stalls)"));
        }
        match self.offset(address) {
            Some(o) => self.mem[o],
            None => {
                self.fault(format!("read of {address:#x}, outside the main flash"));
                0
            }
        }
    }

    fn pause(&mut self) {
        self.pauses += 1;
    }
}

type Driver = F103Flash<Fpec>;

fn driver() -> Driver {
    F103Flash::new(Fpec::new())
}

/// No misuse recorded, every address the driver used inside the settings pages, the rest of
/// the flash as it was, the controller locked and idle with no flag set.
fn assert_clean(d: &Driver) {
    let m = d.regs();
    assert_eq!(*m.faults.borrow(), Vec::<String>::new());
    for a in m.log.borrow().iter() {
        if let Access::Ar(x) | Access::Half(x, _) | Access::Read(x) = *a {
            assert!(SETTINGS.contains(&x), "{a:?} outside the settings pages");
        }
    }
    assert_eq!(m.outside_settings(), &Fpec::new().mem[..m.outside_settings().len()]);
    assert!(m.locked, "left unlocked");
    assert_eq!(m.cr, 0, "PG/PER/STRT left set");
    assert!(m.op.is_none());
    assert_eq!(m.flags, 0, "status flags left set");
}

/// The accesses since the last call: the register accesses, and the addresses of the flash
/// reads.
fn take_log(d: &Driver) -> (Vec<Access>, Vec<u32>) {
    let log = std::mem::take(&mut *d.regs().log.borrow_mut());
    let reads = log
        .iter()
        .filter_map(|a| match a {
            Access::Read(x) => Some(*x),
            _ => None,
        })
        .collect();
    (log.into_iter().filter(|a| !matches!(a, Access::Read(_))).collect(), reads)
}

const FLAGS: u32 = SR_EOP | SR_PGERR | SR_WRPRTERR;

/// The exact register sequences of a page erase and a half-word program (PM0075 §2.3): wait
/// for BSY clear, unlock, clear stale flags, PER + FLASH_AR + STRT (PG + the half-word), wait,
/// clear PER (PG), lock, clear the flags; then the erase reads the whole page back, the
/// program its half-word.
#[test]
fn erase_and_program_follow_the_manual_sequence() {
    use Access::*;
    let mut d = driver();
    d.erase(Page::B).unwrap();
    let (writes, reads) = take_log(&d);
    assert_eq!(
        writes,
        [
            Cr,
            Keyr(KEY1),
            Keyr(KEY2),
            Cr,
            WriteSr(FLAGS),
            Cr,
            WriteCr(CR_PER),
            Ar(0x0807_F800),
            WriteCr(CR_PER | CR_STRT),
            Cr,
            WriteCr(0),
            WriteCr(CR_LOCK),
            WriteSr(FLAGS),
        ]
    );
    assert_eq!(reads, (0x0807_F800..0x0808_0000).collect::<Vec<u32>>());
    d.program(Page::B, 6, 0x1234).unwrap();
    let (writes, reads) = take_log(&d);
    assert_eq!(
        writes,
        [
            Cr,
            Keyr(KEY1),
            Keyr(KEY2),
            Cr,
            WriteSr(FLAGS),
            Cr,
            WriteCr(CR_PG),
            Half(0x0807_F806, 0x1234),
            Cr,
            WriteCr(0),
            WriteCr(CR_LOCK),
            WriteSr(FLAGS),
        ]
    );
    assert_eq!(reads, [0x0807_F806, 0x0807_F807]);
    assert_eq!(&d.regs().settings()[PAGE + 6..PAGE + 8], &[0x34, 0x12]);
    assert_clean(&d);
    // Each operation waited for BSY (3 polls) after the start delay (1 poll), with pauses.
    assert!(d.regs().pauses >= 2 * 4, "{}", d.regs().pauses);
}

/// Page A is the 2 KiB at 0x0807_F000, page B the 2 KiB at 0x0807_F800 (the last two of the
/// 512 KiB): an erase clears exactly its page, a program writes exactly its half-word, a read
/// reads exactly its bytes.
#[test]
fn the_settings_pages_are_the_last_two_of_the_512_kib() {
    assert_eq!(page_address(Page::A), 0x0807_F000);
    assert_eq!(page_address(Page::B), 0x0807_F800);
    assert_eq!(page_address(Page::B) + PAGE as u32, MAIN_FLASH_END);
    assert_eq!(PAGES, 256);
    let mut d = driver();
    for (page, at) in [(Page::A, 0usize), (Page::B, PAGE)] {
        d.program(page, 0, 0x0102).unwrap();
        d.program(page, PAGE - 2, 0x0304).unwrap();
        let s = d.regs().settings();
        assert_eq!((s[at], s[at + 1]), (0x02, 0x01));
        assert_eq!((s[at + PAGE - 2], s[at + PAGE - 1]), (0x04, 0x03));
        let mut buf = [0u8; 2];
        d.read(page, PAGE - 2, &mut buf).unwrap();
        assert_eq!(buf, [0x04, 0x03]);
    }
    let before = d.regs().settings().to_vec();
    d.erase(Page::A).unwrap();
    let after = d.regs().settings();
    assert!(after[..PAGE].iter().all(|&b| b == 0xFF));
    assert_eq!(after[PAGE..], before[PAGE..]);
    d.program(Page::A, 0, 0x0506).unwrap();
    d.erase(Page::B).unwrap();
    let after = d.regs().settings();
    assert!(after[PAGE..].iter().all(|&b| b == 0xFF));
    assert_eq!(&after[..2], &[0x06, 0x05]);
    assert_clean(&d);
}

/// Offsets outside the page and odd half-word offsets are refused before any access.
#[test]
fn out_of_bounds_accesses_are_refused_without_touching_the_controller() {
    let mut d = driver();
    let mut buf = [0u8; 4];
    for page in [Page::A, Page::B] {
        assert_eq!(d.program(page, PAGE, 0), Err(FlashError::OutOfBounds));
        assert_eq!(d.program(page, PAGE - 1, 0), Err(FlashError::OutOfBounds));
        assert_eq!(d.program(page, 1, 0), Err(FlashError::OutOfBounds));
        assert_eq!(d.program(page, usize::MAX - 1, 0), Err(FlashError::OutOfBounds));
        assert_eq!(d.read(page, PAGE - 3, &mut buf), Err(FlashError::OutOfBounds));
        assert_eq!(d.read(page, usize::MAX - 1, &mut buf), Err(FlashError::OutOfBounds));
        assert_eq!(d.read(page, PAGE + 1, &mut []), Err(FlashError::OutOfBounds));
    }
    assert_eq!(take_log(&d), (vec![], vec![]));
    assert_eq!(d.regs().sr_reads, 0);
    // The last bytes of a page are readable, an empty read at its end too.
    d.read(Page::B, PAGE - 4, &mut buf).unwrap();
    d.read(Page::B, PAGE, &mut []).unwrap();
    assert_eq!(take_log(&d).1, [0x0807_FFFC, 0x0807_FFFD, 0x0807_FFFE, 0x0807_FFFF]);
    assert_clean(&d);
}

/// The settings store over the driver and the model: saves alternate pages, the newest
/// loads exactly, and the pages hold the same bytes as the RAM flash after the same saves.
#[test]
fn saves_and_loads_over_the_controller_as_over_the_ram_flash() {
    let mut d = driver();
    let mut sim = SimFlash::new();
    assert_eq!(load(&d).source, Source::Defaults);
    let mut expect_page = Page::A;
    for k in 1..=5u32 {
        let s = variant(k);
        let saved = save(&mut d, &s).unwrap();
        assert_eq!(saved, Saved { page: expect_page, seq: k });
        assert_eq!(save(&mut sim, &s).unwrap(), saved);
        expect_page = expect_page.other();
        let l = load(&d);
        assert_eq!(l.settings, s);
        assert_eq!(l.source, Source::Flash { page: saved.page, seq: k });
        let m = d.regs().settings();
        assert_eq!(&m[..PAGE], &sim.page(Page::A)[..]);
        assert_eq!(&m[PAGE..], &sim.page(Page::B)[..]);
        assert_clean(&d);
    }
}

/// A power cut at the start of every erase and program of a save, the interrupted step
/// undone or half done, then a reset: the old or (only when complete) the new settings, and
/// the store keeps working.
#[test]
fn a_power_cut_at_any_step_of_a_save_keeps_the_old_or_the_new_settings() {
    let mut cases = 0;
    for history in 0..2u32 {
        let mut base = driver();
        let mut old = PipelineSettings::default();
        for k in 0..history {
            old = variant(10 + k);
            save(&mut base, &old).unwrap();
        }
        let new = variant(99);
        let mut probe = F103Flash::new(base.regs().clone());
        let before = probe.regs().ops;
        save(&mut probe, &new).unwrap();
        let total = probe.regs().ops - before;
        // One erase and the record's half-words (`record_size_of_the_current_registry`).
        assert_eq!(total, 1 + 510 / 2);
        for torn in [false, true] {
            for n in 0..=total {
                let mut d = F103Flash::new(base.regs().clone());
                d.regs_mut().cut_power_after(n, torn);
                d.regs_mut().log.borrow_mut().clear();
                let r = save(&mut d, &new);
                assert_eq!(r.is_ok(), n == total, "n {n} of {total}: {r:?}");
                if n < total {
                    assert_eq!(r, Err(crate::persist::SaveError::Flash(FlashError::Timeout)));
                }
                d.regs_mut().reset();
                d.regs_mut().faults.borrow_mut().clear();
                let l = load(&d);
                if n == total {
                    assert_eq!(l.settings, new);
                } else {
                    assert!(l.settings == old, "history {history}, torn {torn}, cut at {n}");
                }
                let newer = variant(123);
                save(&mut d, &newer).unwrap();
                assert_eq!(load(&d).settings, newer);
                assert_eq!(d.regs().outside_settings(), Fpec::new().outside_settings());
                cases += 1;
            }
        }
    }
    assert_eq!(cases, 2 * 2 * 257);
}

/// PGERR: a half-word that is not erased is not programmed (except with 0x0000), with EOP
/// or without.
#[test]
fn programming_a_programmed_half_word_is_a_program_error() {
    for eop in [false, true] {
        let mut d = driver();
        d.regs_mut().eop_on_error = eop;
        d.program(Page::A, 10, 0x1234).unwrap();
        assert_eq!(d.program(Page::A, 10, 0x0FFF), Err(FlashError::Program));
        assert_eq!(&d.regs().settings()[10..12], &[0x34, 0x12]);
        assert_clean(&d);
        // Refused even with the same value (it reads back right, but PGERR says it was not
        // programmed: the contract of `Flash::program`, as the RAM flash has it).
        assert_eq!(d.program(Page::A, 10, 0x1234), Err(FlashError::Program));
        assert_clean(&d);
        d.program(Page::A, 10, 0).unwrap();
        assert_eq!(&d.regs().settings()[10..12], &[0, 0]);
        assert_clean(&d);
    }
}

/// WRPRTERR: FLASH_WRPR bit 31 protects pages 62–255 of the 512 KiB part, the settings pages
/// among them; the other bits do not.
#[test]
fn a_write_protected_page_is_refused() {
    for eop in [false, true] {
        let mut d = driver();
        d.regs_mut().eop_on_error = eop;
        d.program(Page::B, 0, 0x00AA).unwrap();
        d.regs_mut().protect = 0x7FFF_FFFF;
        d.erase(Page::A).unwrap();
        d.program(Page::A, 0, 0x1234).unwrap();
        d.regs_mut().protect = 1 << 31;
        let before = d.regs().settings().to_vec();
        assert_eq!(d.erase(Page::B), Err(FlashError::WriteProtected));
        assert_eq!(d.program(Page::A, 2, 0x5678), Err(FlashError::WriteProtected));
        assert_eq!(d.regs().settings(), &before[..]);
        assert_clean(&d);
        d.regs_mut().protect = 0;
        d.erase(Page::B).unwrap();
        assert_clean(&d);
    }
}

/// The bounds of the waits, with the 1 µs pause between two polls: at least 2.5 times the
/// datasheet's longest page erase (40 ms) and 10 times its longest half-word program (70 µs),
/// and short enough that a dead controller is reported well within the watchdog's run
/// timeout (500 ms; the filter task, of higher priority, keeps feeding it meanwhile).
#[test]
fn the_wait_bounds_cover_the_datasheet_times() {
    let erase_us = u64::from(ERASE_POLLS);
    let program_us = u64::from(PROGRAM_POLLS);
    assert!((100_000..=200_000).contains(&erase_us), "{erase_us}");
    assert!((700..=2_000).contains(&program_us), "{program_us}");
    assert!(erase_us * 2 < u64::from(crate::supervision::watchdog::RUN_TIMEOUT_MS) * 1000);
}

/// A controller that never clears BSY: the erase and the program give up after their bounded
/// number of polls, with a pause between two (what the controller then does with the writes
/// that end the operation does not matter: a reset recovers it).
#[test]
fn a_busy_flag_that_never_clears_is_a_timeout() {
    let mut d = driver();
    d.regs_mut().stuck = true;
    assert_eq!(d.erase(Page::A), Err(FlashError::Timeout));
    let m = d.regs();
    assert_eq!(m.sr_reads, ERASE_POLLS as usize + 1);
    assert_eq!(m.pauses, ERASE_POLLS as usize);
    // Busy before the start: nothing is written at all.
    let mut d = driver();
    d.regs_mut().occupy(0);
    d.regs_mut().stuck = true;
    assert_eq!(d.program(Page::A, 0, 0), Err(FlashError::Timeout));
    assert_eq!(d.regs().sr_reads, ERASE_POLLS as usize);
    assert_eq!(take_log(&d), (vec![], vec![]));
    // The program's own wait is the shorter one.
    let mut d = driver();
    d.regs_mut().busy_polls = u32::MAX;
    assert_eq!(d.program(Page::A, 0, 0), Err(FlashError::Timeout));
    assert_eq!(d.regs().sr_reads, 1 + PROGRAM_POLLS as usize);
    // After a reset the controller works again.
    d.regs_mut().reset();
    d.regs_mut().busy_polls = 3;
    d.regs_mut().faults.borrow_mut().clear();
    d.regs_mut().log.borrow_mut().clear();
    d.erase(Page::A).unwrap();
    d.program(Page::A, 0, 0x4321).unwrap();
    assert_clean(&d);
}

/// An operation of someone else's still under way is waited for; stale status flags are
/// cleared before the start, so a stale EOP does not end the wait before BSY rises.
#[test]
fn a_busy_controller_and_stale_flags_are_handled_before_the_start() {
    let mut d = driver();
    d.regs_mut().occupy(20);
    d.erase(Page::A).unwrap();
    assert_clean(&d);
    let mut d = driver();
    d.regs_mut().flags = SR_EOP | SR_PGERR | SR_WRPRTERR;
    d.regs_mut().start_delay = 2;
    d.erase(Page::B).unwrap();
    d.regs_mut().flags = SR_EOP;
    d.program(Page::B, 4, 0xBEEF).unwrap();
    assert_eq!(&d.regs().settings()[PAGE + 4..PAGE + 6], &[0xEF, 0xBE]);
    assert_clean(&d);
}

/// Unlocks with KEY1, KEY2 only while locked; locks again after every operation, also a
/// failed one; a controller locked out by a wrong key (until reset) is reported as locked with
/// nothing written.
#[test]
fn unlocks_only_while_locked_and_locks_after_every_operation() {
    let mut d = driver();
    d.regs_mut().locked = false;
    d.erase(Page::A).unwrap();
    let (writes, _) = take_log(&d);
    assert!(!writes.iter().any(|a| matches!(a, Access::Keyr(_))), "{writes:?}");
    assert_clean(&d);
    d.program(Page::A, 0, 0x1111).unwrap();
    assert_clean(&d);
    assert_eq!(d.program(Page::A, 0, 0x2222), Err(FlashError::Program));
    assert_clean(&d);
    take_log(&d);
    d.regs_mut().lockout = true;
    let before = d.regs().settings().to_vec();
    assert_eq!(d.erase(Page::A), Err(FlashError::Locked));
    assert_eq!(d.program(Page::B, 0, 0), Err(FlashError::Locked));
    let (writes, _) = take_log(&d);
    assert!(writes.iter().all(|a| matches!(a, Access::Cr | Access::Keyr(_))), "{writes:?}");
    assert_eq!(d.regs().settings(), &before[..]);
    d.regs_mut().reset();
    d.erase(Page::A).unwrap();
    assert_clean(&d);
}

/// A cell that does not erase (a bit stuck at 0) fails the erase's read-back, a cell that
/// does not program (a bit stuck at 1) the program's, though the controller reports EOP.
#[test]
fn the_read_back_catches_cells_that_do_not_erase_or_program() {
    let page_b = (SETTINGS.start - MAIN_FLASH_START) as usize + PAGE;
    // Anywhere in the page: its first byte, its last.
    for at in [0, PAGE - 1] {
        let mut d = driver();
        d.regs_mut().bad_cell = Some((page_b + at, 0x01, 0));
        d.program(Page::B, at & !1, 0).unwrap();
        assert_eq!(d.erase(Page::B), Err(FlashError::Erase));
        assert_clean(&d);
        d.erase(Page::A).unwrap();
    }
    let cell = page_b + 100;
    let mut d = driver();
    d.regs_mut().bad_cell = Some((cell + 1, 0, 0x80));
    assert_eq!(d.program(Page::B, 100, 0x0000), Err(FlashError::Program));
    assert_clean(&d);
    d.program(Page::B, 102, 0x0000).unwrap();
}

/// After an operation, locked or not, a stray half-word write (a wild pointer) programs
/// nothing: PG is cleared, which LOCK alone would not do.
#[test]
fn a_stray_write_after_an_operation_programs_nothing() {
    let mut d = driver();
    d.program(Page::A, 0, 0x1234).unwrap();
    d.regs_mut().write_half(0x0807_F010, 0x0000);
    d.erase(Page::B).unwrap();
    d.regs_mut().write_half(0x0807_F810, 0x0000);
    assert_eq!(d.program(Page::A, 0, 0x1111), Err(FlashError::Program));
    d.regs_mut().write_half(0x0807_F020, 0x0000);
    assert!(d.regs().settings()[2..].iter().all(|&b| b == 0xFF));
    assert_eq!(d.regs().faults.borrow().len(), 3);
}

/// PG or PER left set by other code (unlocked, idle): the next operation starts without it.
#[test]
fn an_operation_bit_left_set_by_other_code_is_cleared() {
    for left in [CR_PG, CR_PER] {
        let mut d = driver();
        d.regs_mut().locked = false;
        d.regs_mut().cr = left;
        d.program(Page::A, 8, 0xA5A5).unwrap();
        assert_clean(&d);
        d.regs_mut().locked = false;
        d.regs_mut().cr = left;
        d.erase(Page::A).unwrap();
        assert_clean(&d);
    }
}
