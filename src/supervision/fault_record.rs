//! The record a HardFault or a panic leaves in RAM for the next boot.
//!
//! The firmware keeps one [`FaultRecord`] in a `.uninit` section (not zeroed or initialised by
//! the start-up code, so it survives a reset that keeps the power: the watchdog's, a probe's,
//! `SYSRESETREQ`). The HardFault handler and the panic handler fill it and seal it
//! ([`FaultRecord::sealed`]: a magic word and a CRC-32 over the rest); the next boot takes it
//! ([`FaultRecord::take`]: valid only when both match, so the random contents of RAM after a
//! power-up are not taken for a record), reports it (log, the `FAULT` reply at boot, `STATUS`
//! and `SELFTEST`) and clears it.
//!
//! The registers are the Cortex-M3's fault status registers (ARM DDI 0337 / PM0056 §4.4):
//! CFSR (0xE000ED28: MMFSR bits 0–7, BFSR 8–15, UFSR 16–31), HFSR (0xE000ED2C), MMFAR
//! (0xE000ED34, valid when CFSR.MMARVALID), BFAR (0xE000ED38, valid when CFSR.BFARVALID); PC
//! and LR are the stacked ones of the faulting code (for a panic: the panic's location line in
//! `pc` is 0 and the line number is kept in `line`).

use crate::persist::Crc32;

/// "FLT1" little-endian.
pub const MAGIC: u32 = 0x3154_4C46;

/// What stopped the firmware.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultKind {
    /// The HardFault handler ran (every fault escalates to it: the configurable ones are
    /// not enabled).
    HardFault,
    /// The panic handler ran.
    Panic,
}

impl FaultKind {
    const fn code(self) -> u32 {
        match self {
            FaultKind::HardFault => 1,
            FaultKind::Panic => 2,
        }
    }

    /// Name, as reported.
    pub const fn name(self) -> &'static str {
        match self {
            FaultKind::HardFault => "HARDFAULT",
            FaultKind::Panic => "PANIC",
        }
    }
}

/// The fault registers and where the code was.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultRegs {
    /// Stacked PC (HardFault); 0 for a panic.
    pub pc: u32,
    /// Stacked LR (HardFault); the panic handler's caller for a panic.
    pub lr: u32,
    /// Configurable fault status register.
    pub cfsr: u32,
    /// HardFault status register.
    pub hfsr: u32,
    /// MemManage fault address.
    pub mmfar: u32,
    /// BusFault address.
    pub bfar: u32,
    /// The panic's source line (0 for a HardFault or when unknown).
    pub line: u32,
}

/// The record in RAM (`#[repr(C)]`: its layout is the same in every build).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FaultRecord {
    magic: u32,
    kind: u32,
    regs: [u32; 7],
    crc: u32,
}

impl FaultRecord {
    /// A sealed record of `kind` with `regs`.
    pub fn sealed(kind: FaultKind, regs: FaultRegs) -> Self {
        let mut r = FaultRecord {
            magic: MAGIC,
            kind: kind.code(),
            regs: [regs.pc, regs.lr, regs.cfsr, regs.hfsr, regs.mmfar, regs.bfar, regs.line],
            crc: 0,
        };
        r.crc = r.compute_crc();
        r
    }

    /// A record that is not one (what [`FaultRecord::take`] leaves).
    pub const fn cleared() -> Self {
        FaultRecord { magic: 0, kind: 0, regs: [0; 7], crc: 0 }
    }

    fn compute_crc(&self) -> u32 {
        let mut c = Crc32::new();
        c.update(&self.magic.to_le_bytes());
        c.update(&self.kind.to_le_bytes());
        for w in self.regs {
            c.update(&w.to_le_bytes());
        }
        c.value()
    }

    /// What the record holds, if it is one (magic, kind and CRC check).
    pub fn read(&self) -> Option<(FaultKind, FaultRegs)> {
        if self.magic != MAGIC || self.crc != self.compute_crc() {
            return None;
        }
        let kind = match self.kind {
            1 => FaultKind::HardFault,
            2 => FaultKind::Panic,
            _ => return None,
        };
        let [pc, lr, cfsr, hfsr, mmfar, bfar, line] = self.regs;
        Some((kind, FaultRegs { pc, lr, cfsr, hfsr, mmfar, bfar, line }))
    }

    /// Reads the record and clears it (so the next boot does not report it again).
    pub fn take(&mut self) -> Option<(FaultKind, FaultRegs)> {
        let found = self.read();
        *self = FaultRecord::cleared();
        found
    }
}

/// The first fault cause CFSR/HFSR name (PM0056 §4.4.10–11), for the log and the reports.
pub fn cause(regs: &FaultRegs) -> &'static str {
    const CFSR: [(u32, &str); 14] = [
        (1 << 0, "IACCVIOL"),
        (1 << 1, "DACCVIOL"),
        (1 << 3, "MUNSTKERR"),
        (1 << 4, "MSTKERR"),
        (1 << 8, "IBUSERR"),
        (1 << 9, "PRECISERR"),
        (1 << 10, "IMPRECISERR"),
        (1 << 11, "UNSTKERR"),
        (1 << 12, "STKERR"),
        (1 << 16, "UNDEFINSTR"),
        (1 << 17, "INVSTATE"),
        (1 << 18, "INVPC"),
        (1 << 24, "UNALIGNED"),
        (1 << 25, "DIVBYZERO"),
    ];
    if let Some((_, name)) = CFSR.iter().find(|(bit, _)| regs.cfsr & bit != 0) {
        return name;
    }
    if regs.hfsr & (1 << 1) != 0 {
        return "VECTTBL";
    }
    if regs.hfsr & (1 << 31) != 0 {
        return "DEBUGEVT";
    }
    ""
}

#[cfg(test)]
mod tests {
    use super::*;

    fn regs() -> FaultRegs {
        FaultRegs {
            pc: 0x0800_1234,
            lr: 0xFFFF_FFF9,
            cfsr: 1 << 17,
            hfsr: 1 << 30,
            mmfar: 0xE000_EDF8,
            bfar: 0xE000_EDF8,
            line: 0,
        }
    }

    #[test]
    fn a_sealed_record_reads_back_once() {
        let mut r = FaultRecord::sealed(FaultKind::HardFault, regs());
        assert_eq!(r.read(), Some((FaultKind::HardFault, regs())));
        assert_eq!(r.take(), Some((FaultKind::HardFault, regs())));
        assert_eq!(r.take(), None, "reported twice");
        let p = FaultRegs { line: 321, ..FaultRegs::default() };
        assert_eq!(FaultRecord::sealed(FaultKind::Panic, p).read(), Some((FaultKind::Panic, p)));
    }

    #[test]
    fn a_damaged_record_or_power_up_ram_is_not_a_record() {
        let good = FaultRecord::sealed(FaultKind::HardFault, regs());
        // Every single bit flipped anywhere in the record.
        let words = |r: &FaultRecord| {
            let mut w = vec![r.magic, r.kind];
            w.extend(r.regs);
            w.push(r.crc);
            w
        };
        let n = words(&good).len();
        for i in 0..n {
            for bit in 0..32 {
                let mut w = words(&good);
                w[i] ^= 1 << bit;
                let r = FaultRecord {
                    magic: w[0],
                    kind: w[1],
                    regs: core::array::from_fn(|k| w[2 + k]),
                    crc: w[n - 1],
                };
                assert_eq!(r.read(), None, "word {i} bit {bit}");
            }
        }
        // SRAM after power-up: patterns and pseudo-random words, with and without the magic.
        let mut x = 0x1234_5678u32;
        for k in 0..1000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let r = FaultRecord {
                magic: if k % 2 == 0 { MAGIC } else { x },
                kind: 1 + k % 2,
                regs: [x, !x, x.rotate_left(3), 0, 0xFFFF_FFFF, x ^ 0x5555, k],
                crc: x.wrapping_mul(31),
            };
            assert_eq!(r.read(), None);
        }
        assert_eq!(FaultRecord::cleared().read(), None);
    }

    #[test]
    fn causes_from_the_fault_status_bits() {
        // PM0056 §4.4.10: UFSR INVSTATE is CFSR bit 17; BFSR PRECISERR bit 9; HFSR FORCED bit 30
        // (escalated) names no cause of its own.
        assert_eq!(cause(&regs()), "INVSTATE");
        assert_eq!(cause(&FaultRegs { cfsr: 1 << 9 | 1 << 15, ..regs() }), "PRECISERR");
        assert_eq!(cause(&FaultRegs { cfsr: 1 << 25, ..regs() }), "DIVBYZERO");
        assert_eq!(cause(&FaultRegs { cfsr: 0, hfsr: 1 << 1, ..regs() }), "VECTTBL");
        assert_eq!(cause(&FaultRegs { cfsr: 0, hfsr: 1 << 30, ..regs() }), "");
    }

    /// Every fault status bit of PM0056 §4.4.10 (CFSR: MMFSR bits 0–7, BFSR 8–15, UFSR 16–31)
    /// alone names its cause; the status bits without a cause (MMARVALID 7, BFARVALID 15) and
    /// the reserved bits name none; with several bits the lowest named one wins.
    #[test]
    fn each_fault_status_bit_alone_names_its_cause() {
        let named = [
            (0, "IACCVIOL"),
            (1, "DACCVIOL"),
            (3, "MUNSTKERR"),
            (4, "MSTKERR"),
            (8, "IBUSERR"),
            (9, "PRECISERR"),
            (10, "IMPRECISERR"),
            (11, "UNSTKERR"),
            (12, "STKERR"),
            (16, "UNDEFINSTR"),
            (17, "INVSTATE"),
            (18, "INVPC"),
            (24, "UNALIGNED"),
            (25, "DIVBYZERO"),
        ];
        for bit in 0..32u32 {
            let want = named.iter().find(|(b, _)| *b == bit).map_or("", |(_, n)| *n);
            let r = FaultRegs { cfsr: 1 << bit, hfsr: 0, ..regs() };
            assert_eq!(cause(&r), want, "CFSR bit {bit}");
        }
        for (i, (lo, name)) in named.iter().enumerate() {
            for (hi, _) in &named[i + 1..] {
                let r = FaultRegs { cfsr: 1 << lo | 1 << hi, hfsr: 1 << 1, ..regs() };
                assert_eq!(cause(&r), *name, "CFSR bits {lo} and {hi}");
            }
        }
        // HFSR DEBUGEVT (bit 31) when nothing else is named.
        assert_eq!(cause(&FaultRegs { cfsr: 0, hfsr: 1 << 31, ..regs() }), "DEBUGEVT");
    }
}
