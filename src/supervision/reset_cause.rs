//! Why the MCU last came out of reset, decoded from the reset flags of RCC_CSR (RM0008
//! §7.3.10). The flags accumulate until cleared (RMVF): the application reads them first thing
//! in `init`, clears them and reports the cause in the boot sentence `$PINAB` and `STATUS`.

/// RCC_CSR bit 26: NRST pin reset.
pub const PINRSTF: u32 = 1 << 26;
/// RCC_CSR bit 27: power-on / power-down reset.
pub const PORRSTF: u32 = 1 << 27;
/// RCC_CSR bit 28: software reset (SYSRESETREQ).
pub const SFTRSTF: u32 = 1 << 28;
/// RCC_CSR bit 29: independent watchdog reset.
pub const IWDGRSTF: u32 = 1 << 29;
/// RCC_CSR bit 30: window watchdog reset.
pub const WWDGRSTF: u32 = 1 << 30;
/// RCC_CSR bit 31: low-power management reset.
pub const LPWRRSTF: u32 = 1 << 31;

/// Why the MCU last came out of reset, most specific cause first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetCause {
    /// Low-power management reset.
    LowPower,
    /// Window watchdog.
    WindowWatchdog,
    /// Independent watchdog (the filter stopped feeding it: hang or estimator reset storm).
    IndependentWatchdog,
    /// Software reset (SYSRESETREQ, e.g. after flashing).
    Software,
    /// Power-on / power-down reset.
    PowerOn,
    /// The NRST pin (reset button, debugger).
    Pin,
    /// No flag set.
    Unknown,
}

impl ResetCause {
    /// The cause from the value of RCC_CSR. Every internal reset also pulses NRST and so sets
    /// PINRSTF (a power-on reset sets PORRSTF and PINRSTF): the pin flag counts only when no
    /// other flag is set.
    pub const fn from_csr(csr: u32) -> ResetCause {
        if csr & LPWRRSTF != 0 {
            ResetCause::LowPower
        } else if csr & WWDGRSTF != 0 {
            ResetCause::WindowWatchdog
        } else if csr & IWDGRSTF != 0 {
            ResetCause::IndependentWatchdog
        } else if csr & SFTRSTF != 0 {
            ResetCause::Software
        } else if csr & PORRSTF != 0 {
            ResetCause::PowerOn
        } else if csr & PINRSTF != 0 {
            ResetCause::Pin
        } else {
            ResetCause::Unknown
        }
    }

    /// Field of the boot sentence and of `STATUS`.
    pub const fn tag(self) -> &'static str {
        match self {
            ResetCause::LowPower => "LPWR",
            ResetCause::WindowWatchdog => "WWDG",
            ResetCause::IndependentWatchdog => "IWDG",
            ResetCause::Software => "SFT",
            ResetCause::PowerOn => "POR",
            ResetCause::Pin => "PIN",
            ResetCause::Unknown => "UNK",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_flag_combinations_the_mcu_produces_decode_to_their_cause() {
        // What each reset leaves in RCC_CSR (RM0008 §7.1.2: internal resets pulse NRST).
        let cases = [
            (PORRSTF | PINRSTF, ResetCause::PowerOn, "POR"),
            (PINRSTF, ResetCause::Pin, "PIN"),
            (IWDGRSTF | PINRSTF, ResetCause::IndependentWatchdog, "IWDG"),
            (WWDGRSTF | PINRSTF, ResetCause::WindowWatchdog, "WWDG"),
            (SFTRSTF | PINRSTF, ResetCause::Software, "SFT"),
            (LPWRRSTF | PINRSTF, ResetCause::LowPower, "LPWR"),
            (0, ResetCause::Unknown, "UNK"),
            // Not cleared since power-on, then a watchdog reset: the watchdog is the news.
            (PORRSTF | IWDGRSTF | PINRSTF, ResetCause::IndependentWatchdog, "IWDG"),
        ];
        for (csr, cause, tag) in cases {
            // The other bits of RCC_CSR (LSION, LSIRDY, RMVF) do not matter.
            for other in [0, 0b11, 1 << 24] {
                assert_eq!(ResetCause::from_csr(csr | other), cause, "{csr:#x}");
            }
            assert_eq!(cause.tag(), tag);
        }
    }

    #[test]
    fn bits_are_the_reference_manuals() {
        // RM0008 Rev 21, §7.3.10 RCC_CSR: PINRSTF 26 … LPWRRSTF 31.
        let bits = [PINRSTF, PORRSTF, SFTRSTF, IWDGRSTF, WWDGRSTF, LPWRRSTF];
        for (i, b) in bits.iter().enumerate() {
            assert_eq!(*b, 1 << (26 + i));
        }
    }
}
