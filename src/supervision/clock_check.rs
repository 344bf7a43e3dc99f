//! Is the crystal the 8 MHz one the clock tree assumes? Decided at boot, before the PLL
//! multiplies it by 9 (with a 12 MHz crystal that would be 108 MHz, and nothing would run).
//!
//! The measurement uses the LSI as a transfer oscillator: TIM5 channel 4 captures the LSI
//! (RM0008 §8.3.9/§15: AFIO_MAPR.TIM5CH4_IREMAP connects it, meant for calibrating the LSI),
//! once with the timer clocked by the HSI (8 MHz, trimmed to ±1 % at 25 °C; about ±2.5 % over
//! temperature, DS5792) and once by the HSE. The LSI's own frequency (30–60 kHz) cancels out:
//! HSE = 8 MHz × (ticks per LSI period on HSE) / (ticks per LSI period on HSI).
//! The LSI alone could not tell 8 MHz from 12: it is only known within a factor of two.
//!
//! A crystal more than [`HSE_TOLERANCE_PERMILLE`] off 8 MHz is not used: the firmware falls
//! back to HSI/2 × 16 = 64 MHz and reports it (boot sentence, log, `SELFTEST`).

/// The HSI's nominal frequency, Hz.
pub const HSI_HZ: u32 = 8_000_000;
/// The crystal the board carries, Hz.
pub const EXPECTED_HSE_HZ: u32 = crate::board::HSE_HZ;
/// How far off the measured HSE may be, ‰: the HSI's ±2.5 % over temperature plus the LSI's
/// drift between the two measurements and the capture's quantisation (1 tick in ≥ 1000),
/// with margin. Crystals one might fit instead (4, 6, 10, 12, 16 MHz) are 25 % off or more.
pub const HSE_TOLERANCE_PERMILLE: u32 = 50;

/// What the boot check found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HseCheck {
    /// The crystal runs at 8 MHz (measured, Hz): the PLL runs from it (72 MHz).
    Ok(u32),
    /// The crystal runs, at another frequency (measured, Hz): HSI instead.
    WrongFrequency(u32),
    /// The crystal runs but the LSI captures did not come: it is used unmeasured.
    Unmeasured,
    /// The crystal did not start (HSERDY): HSI instead.
    NotStarted,
}

impl HseCheck {
    /// Whether the PLL may run from the crystal.
    pub const fn use_hse(self) -> bool {
        matches!(self, HseCheck::Ok(_) | HseCheck::Unmeasured)
    }

    /// The measured frequency, Hz, if any.
    pub const fn measured_hz(self) -> Option<u32> {
        match self {
            HseCheck::Ok(hz) | HseCheck::WrongFrequency(hz) => Some(hz),
            _ => None,
        }
    }

    /// Short name, for the log and `SELFTEST`.
    pub const fn name(self) -> &'static str {
        match self {
            HseCheck::Ok(_) => "HSE 8 MHz",
            HseCheck::WrongFrequency(_) => "HSE wrong frequency",
            HseCheck::Unmeasured => "HSE unmeasured",
            HseCheck::NotStarted => "HSE not started",
        }
    }
}

/// The HSE's frequency, Hz, from the timer ticks counted over the same number of LSI periods
/// with the timer on the HSI (`hsi_ticks`) and on the HSE (`hse_ticks`).
pub fn hse_hz(hsi_ticks: u32, hse_ticks: u32) -> Option<u32> {
    if hsi_ticks == 0 {
        return None;
    }
    let hz = u64::from(HSI_HZ) * u64::from(hse_ticks) / u64::from(hsi_ticks);
    u32::try_from(hz).ok()
}

/// The decision: `started` is HSERDY; the tick counts are `None` when the captures did not
/// come (bounded waits ran out).
pub fn judge(started: bool, hsi_ticks: Option<u32>, hse_ticks: Option<u32>) -> HseCheck {
    if !started {
        return HseCheck::NotStarted;
    }
    let Some(hz) = hsi_ticks.zip(hse_ticks).and_then(|(a, b)| hse_hz(a, b)) else {
        return HseCheck::Unmeasured;
    };
    let tolerance = EXPECTED_HSE_HZ / 1000 * HSE_TOLERANCE_PERMILLE;
    if hz.abs_diff(EXPECTED_HSE_HZ) <= tolerance {
        HseCheck::Ok(hz)
    } else {
        HseCheck::WrongFrequency(hz)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The names the boot log prints for each verdict (the self-test report's clock item is
    /// its kHz and grade; these are the words an operator reads in the log).
    #[test]
    fn each_verdict_has_its_name() {
        assert_eq!(HseCheck::Ok(8_000_000).name(), "HSE 8 MHz");
        assert_eq!(HseCheck::WrongFrequency(12_000_000).name(), "HSE wrong frequency");
        assert_eq!(HseCheck::Unmeasured.name(), "HSE unmeasured");
        assert_eq!(HseCheck::NotStarted.name(), "HSE not started");
    }

    /// Timer ticks over `periods` LSI periods with the timer at `timer_hz` (truncated: the
    /// captured counter difference), summed over four measurements as the firmware does.
    fn ticks(timer_hz: f64, lsi_hz: f64, periods: u32) -> u32 {
        4 * (timer_hz * f64::from(periods) / lsi_hz) as u32
    }

    /// The check for a crystal at `hse` Hz, with the HSI and the LSI anywhere in their
    /// ranges (HSI 8 MHz ±2.5 %, LSI 30–60 kHz, DS5792) and the LSI drifting by 0.5 %
    /// between the two measurements.
    fn check(hse: f64, hsi: f64, lsi: f64) -> HseCheck {
        judge(true, Some(ticks(hsi, lsi, 8)), Some(ticks(hse, lsi * 1.005, 8)))
    }

    #[test]
    fn an_8_mhz_crystal_passes_over_the_oscillators_ranges() {
        for hsi in [7.8e6, 8.0e6, 8.2e6] {
            for lsi in [30e3, 40e3, 60e3] {
                let c = check(8e6, hsi, lsi);
                assert!(matches!(c, HseCheck::Ok(_)), "HSI {hsi} LSI {lsi}: {c:?}");
                assert!(c.use_hse());
            }
        }
        // Measured as 8 MHz within the HSI's error.
        let hz = check(8e6, 8.0e6, 40e3).measured_hz().unwrap();
        assert!(hz.abs_diff(8_000_000) < 60_000, "{hz}");
    }

    #[test]
    fn other_crystals_are_refused() {
        for hse in [4e6, 6e6, 10e6, 12e6, 16e6, 25e6] {
            for hsi in [7.8e6, 8.2e6] {
                for lsi in [30e3, 60e3] {
                    let c = check(hse, hsi, lsi);
                    assert!(matches!(c, HseCheck::WrongFrequency(_)), "{hse} {hsi} {lsi}: {c:?}");
                    assert!(!c.use_hse());
                    let hz = f64::from(c.measured_hz().unwrap());
                    assert!((hz / hse - 1.0).abs() < 0.04, "{hse}: measured {hz}");
                }
            }
        }
    }

    #[test]
    fn no_crystal_or_no_measurement() {
        assert_eq!(judge(false, Some(1000), Some(1000)), HseCheck::NotStarted);
        assert!(!HseCheck::NotStarted.use_hse());
        assert_eq!(judge(true, None, Some(1000)), HseCheck::Unmeasured);
        assert_eq!(judge(true, Some(0), Some(1000)), HseCheck::Unmeasured);
        assert!(HseCheck::Unmeasured.use_hse());
    }
}
