//! The status LED (PB9, active high): what the filter reports, and the blink patterns.
//!
//! The LED task works in frames of [`SLOTS`] slots of [`SLOT_MS`] ms (1 s). At the start of
//! each frame it hands the [`Health`] the filter accumulated during the previous one to the
//! [`Led`] state, which picks a [`Mode`]. Every mode but the fault is a count of short flashes
//! (50 ms on, 150 ms apart) at the start of the second, then dark:
//! - running: one flash;
//! - initialising: two (the estimator's initialisation window, or the gyros still settling
//!   before the first cycle);
//! - running on the internal oscillator: three (the crystal failed its check at boot, so the
//!   clock is HSI at 64 MHz and there is no USB: the sentences are on USART2 only);
//! - running after a boot self-test that graded FAIL (`SELFTEST` says which item): four;
//! - fault, fast blink (5 Hz, 100 ms on / 100 ms off, the whole second): an I²C or ADC fault,
//!   an invalid gyro sample, a health reset of the estimator, or no filter cycle at all in the
//!   last second.
//!
//! **None can be taken for ST's DFU bootloader** (`iNEMO_DFU` `main.c`, V2.0.0, 09/20/2010:
//! in DFU mode its main loop toggles LED1 on PB9 after every `0x2FFFFF` turns of an empty
//! `volatile` loop): a square wave, half on, each on-time at least 3,145,727 loop turns of
//! at least five instructions at 72 MHz, over 0.2 s (about 0.4 s on a board, so about 1 Hz).
//! No pattern here lights the LED for more than 100 ms at a time. The firmware's previous
//! initialisation pattern, 500 ms on / 500 ms off, was that square wave (issue #37).

use super::selftest::Grade;
use crate::status::Status;
use ekf_core::Flags;

/// Slots per frame.
pub const SLOTS: u8 = 20;
/// Slot length, ms.
pub const SLOT_MS: u32 = 50;
/// Slots from one flash of a count to the next (200 ms).
const FLASH_PERIOD: u8 = 4;

/// What the filter reports to the LED task, accumulated over one LED frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct Health {
    /// Union of the status words of the cycles.
    pub status: Status,
    /// Number of cycles.
    pub cycles: u32,
    /// The boot self-test's overall grade, in the frame where it was evaluated (after the first
    /// cycle).
    pub selftest: Option<Grade>,
}

impl Health {
    /// Adds one cycle's status.
    pub fn record(&mut self, status: Status) {
        self.status |= status;
        self.cycles = self.cycles.saturating_add(1);
    }
}

/// The LED's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Running normally (one flash per second).
    Running,
    /// Initialisation window (two flashes).
    Init,
    /// Running on the internal oscillator, no USB (three flashes).
    InternalClock,
    /// Running after a boot self-test FAIL (four flashes).
    SelftestFail,
    /// A fault (fast blink).
    Fault,
}

impl Mode {
    /// Name, for the log.
    pub const fn name(self) -> &'static str {
        match self {
            Mode::Running => "running",
            Mode::Init => "init",
            Mode::InternalClock => "running on the internal oscillator (no USB)",
            Mode::SelftestFail => "running, boot self-test FAIL",
            Mode::Fault => "fault",
        }
    }

    /// Flashes per second, 0 for the fault's continuous blink.
    pub const fn flashes(self) -> u8 {
        match self {
            Mode::Running => 1,
            Mode::Init => 2,
            Mode::InternalClock => 3,
            Mode::SelftestFail => 4,
            Mode::Fault => 0,
        }
    }
}

/// Status bits that make the LED show a fault.
const FAULT_BITS: Status = Status(
    Status::I2C_FAULT.0
        | Status::ADC_FAULT.0
        | Flags::GYRO_INVALID.bits() as u32
        | Flags::HEALTH_RESET.bits() as u32,
);

/// The mode for one frame's health. `started`: the filter has run at least one cycle since
/// boot (before that the gyros settle and no cycle is expected); `internal_clock`: the clock is
/// the internal oscillator; `selftest_failed`: the boot self-test graded FAIL. A fault shows
/// first, then the initialisation, then the internal oscillator (which the self-test grades
/// FAIL too: the three flashes say which item), then the self-test.
pub fn mode(health: Health, started: bool, internal_clock: bool, selftest_failed: bool) -> Mode {
    if health.cycles == 0 {
        return if started { Mode::Fault } else { Mode::Init };
    }
    if health.status.0 & FAULT_BITS.0 != 0 {
        Mode::Fault
    } else if health.status.flags().contains(Flags::INITIALISING) {
        Mode::Init
    } else if internal_clock {
        Mode::InternalClock
    } else if selftest_failed {
        Mode::SelftestFail
    } else {
        Mode::Running
    }
}

/// Whether the LED is on in `slot` (0..SLOTS) of a frame in `mode`.
pub fn lit(mode: Mode, slot: u8) -> bool {
    match mode {
        Mode::Fault => (slot / 2) % 2 == 0,
        m => slot % FLASH_PERIOD == 0 && slot / FLASH_PERIOD < m.flashes(),
    }
}

/// The LED task's state across frames.
#[derive(Clone, Copy, Debug)]
pub struct Led {
    /// The clock is the internal oscillator (fixed at boot).
    internal_clock: bool,
    /// The filter has run a cycle.
    started: bool,
    /// The boot self-test graded FAIL.
    selftest_failed: bool,
    /// The current mode.
    mode: Mode,
}

impl Led {
    /// At boot: initialising; `internal_clock` as the clock set-up found it.
    pub const fn new(internal_clock: bool) -> Self {
        Led { internal_clock, started: false, selftest_failed: false, mode: Mode::Init }
    }

    /// A frame begins with the health of the last one: the mode for it, and whether it changed.
    pub fn frame(&mut self, health: Health) -> (Mode, bool) {
        if let Some(g) = health.selftest {
            self.selftest_failed = g == Grade::Fail;
        }
        let new = mode(health, self.started, self.internal_clock, self.selftest_failed);
        self.started |= health.cycles > 0;
        let changed = new != self.mode;
        self.mode = new;
        (new, changed)
    }

    /// The current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODES: [Mode; 5] =
        [Mode::Running, Mode::Init, Mode::InternalClock, Mode::SelftestFail, Mode::Fault];

    fn health(status: Status, cycles: u32) -> Health {
        Health { status, cycles, selftest: None }
    }

    /// The LED's on-time per frame, the number of separate flashes and the longest flash, ms.
    fn pattern(mode: Mode) -> (u32, u32, u32) {
        let on: Vec<bool> = (0..SLOTS).map(|s| lit(mode, s)).collect();
        let ms = on.iter().filter(|l| **l).count() as u32 * SLOT_MS;
        let flashes = (0..on.len()).filter(|&i| on[i] && (i == 0 || !on[i - 1])).count() as u32;
        let mut longest = 0;
        let mut run = 0;
        for l in &on {
            run = if *l { run + SLOT_MS } else { 0 };
            longest = longest.max(run);
        }
        (ms, flashes, longest)
    }

    #[test]
    fn patterns_are_the_documented_ones() {
        assert_eq!(SLOTS as u32 * SLOT_MS, 1000, "one frame is one second");
        // Counts of 50 ms flashes, 200 ms apart; the fault 5 Hz, 100 ms on.
        assert_eq!(pattern(Mode::Running), (50, 1, 50));
        assert_eq!(pattern(Mode::Init), (100, 2, 50));
        assert_eq!(pattern(Mode::InternalClock), (150, 3, 50));
        assert_eq!(pattern(Mode::SelftestFail), (200, 4, 50));
        assert_eq!(pattern(Mode::Fault), (500, 5, 100));
        assert!((0..SLOTS).all(|s| lit(Mode::Fault, s) == (s % 4 < 2)));
        assert!((0..SLOTS).all(|s| lit(Mode::SelftestFail, s) == (s % 4 == 0 && s < 16)));
        // Each count ends with at least 350 ms dark, so the counts stay apart; the fault's
        // blink has no such gap.
        for m in MODES {
            let last = (0..SLOTS).filter(|&s| lit(m, s)).max().unwrap();
            let dark = (u32::from(SLOTS) - 1 - u32::from(last)) * SLOT_MS;
            if m == Mode::Fault {
                assert_eq!(dark, 100);
            } else {
                assert!(dark >= 350, "{m:?}: {dark} ms dark");
            }
        }
    }

    /// No pattern can be taken for ST's DFU bootloader's blink: a square wave whose on-time is
    /// `0x2FFFFF` turns of a `volatile` loop (iNEMO_DFU `main.c` V2.0.0), each at least five
    /// instructions (load, add, store, compare, branch) at no more than 72 MHz: over 200 ms
    /// (about 0.4 s on a board). Every pattern here lights the LED for 100 ms at most.
    #[test]
    fn no_pattern_looks_like_the_bootloaders_blink() {
        let bootloader_on_ms = 0x2F_FFFF as f64 * 5.0 / 72e6 * 1e3;
        assert!(bootloader_on_ms > 200.0, "{bootloader_on_ms}");
        for m in MODES {
            let (_, _, longest) = pattern(m);
            assert!(f64::from(longest) * 2.0 <= bootloader_on_ms, "{m:?}: {longest} ms");
        }
        // And the modes tell themselves apart: distinct flash counts.
        let mut counts: Vec<u32> = MODES.iter().map(|m| pattern(*m).1).collect();
        counts.sort();
        counts.dedup();
        assert_eq!(counts.len(), MODES.len());
    }

    #[test]
    fn each_fault_shows_the_fault_pattern() {
        let running = Status::from_flags(Flags::ACCEL_USED);
        for fault in [
            Status::I2C_FAULT,
            Status::ADC_FAULT,
            Status::from_flags(Flags::GYRO_INVALID),
            Status::from_flags(Flags::HEALTH_RESET),
        ] {
            for (clock, selftest) in [(false, false), (true, true), (false, true)] {
                let h = health(running | fault, 50);
                assert_eq!(mode(h, true, clock, selftest), Mode::Fault, "{fault:?}");
                // Even during the initialisation window.
                let init = Status::from_flags(Flags::INITIALISING) | fault;
                assert_eq!(mode(health(init, 50), true, clock, selftest), Mode::Fault);
            }
        }
        // No cycle in a whole second once the filter ran: the filter is stuck.
        assert_eq!(mode(health(Status::NONE, 0), true, false, false), Mode::Fault);
    }

    #[test]
    fn init_running_internal_clock_and_selftest() {
        // Gyros settling before the first cycle.
        assert_eq!(mode(health(Status::NONE, 0), false, true, false), Mode::Init);
        let init = Status::from_flags(Flags::INITIALISING);
        assert_eq!(mode(health(init, 50), true, true, true), Mode::Init);
        // Conditions that are reported but are not faults of the device.
        for s in [
            Status::NONE,
            Status::from_flags(Flags::ACCEL_USED | Flags::AT_REST),
            Status::from_flags(Flags::ACCEL_GATED | Flags::ACCEL_KNOCK),
            Status::GYRO_RAIL | Status::from_flags(Flags::GYRO_SATURATED),
            Status::DEPTH_RAIL,
        ] {
            assert_eq!(mode(health(s, 50), true, false, false), Mode::Running, "{s:?}");
            assert_eq!(mode(health(s, 50), true, true, false), Mode::InternalClock, "{s:?}");
            // The internal oscillator is a self-test FAIL too; its own count says which.
            assert_eq!(mode(health(s, 50), true, true, true), Mode::InternalClock, "{s:?}");
            assert_eq!(mode(health(s, 50), true, false, true), Mode::SelftestFail, "{s:?}");
        }
    }

    /// The names the boot log prints when the pattern changes (`status LED: …`).
    #[test]
    fn each_mode_has_its_name() {
        let names = MODES.map(Mode::name);
        assert_eq!(
            names,
            [
                "running",
                "init",
                "running on the internal oscillator (no USB)",
                "running, boot self-test FAIL",
                "fault"
            ]
        );
    }

    #[test]
    fn health_is_the_union_of_the_cycles() {
        let mut h = Health::default();
        h.record(Status::from_flags(Flags::ACCEL_USED));
        h.record(Status::I2C_FAULT);
        h.record(Status::NONE);
        assert_eq!(h.cycles, 3);
        assert!(h.status.contains(Status::I2C_FAULT | Status::from_flags(Flags::ACCEL_USED)));
        // One faulty cycle in the second makes the frame a fault frame.
        assert_eq!(mode(h, true, false, false), Mode::Fault);
    }

    /// The task's state over a boot: settling, the window, the self-test's verdict kept from
    /// the frame it came in (a FAIL stays; a WARN, as a board without a depth sensor gives, is
    /// running), a stuck filter.
    #[test]
    fn the_led_follows_a_boot() {
        let running = Status::from_flags(Flags::ACCEL_USED);
        let init = Status::from_flags(Flags::INITIALISING);
        for (grade, clock, after) in [
            (Grade::Pass, false, Mode::Running),
            (Grade::Warn, false, Mode::Running),
            (Grade::Fail, false, Mode::SelftestFail),
            (Grade::Fail, true, Mode::InternalClock),
        ] {
            let mut led = Led::new(clock);
            assert_eq!(led.mode(), Mode::Init);
            // The gyros settling: seconds without a cycle before the first are not a fault.
            assert_eq!(led.frame(health(Status::NONE, 0)), (Mode::Init, false));
            assert_eq!(led.frame(health(Status::NONE, 0)), (Mode::Init, false));
            let first = Health { selftest: Some(grade), ..health(init, 40) };
            assert_eq!(led.frame(first), (Mode::Init, false));
            assert_eq!(led.frame(health(init, 50)).0, Mode::Init);
            assert_eq!(led.frame(health(running, 50)), (after, after != Mode::Init));
            assert_eq!(led.frame(health(running, 50)), (after, false));
            assert_eq!(led.frame(health(Status::NONE, 0)), (Mode::Fault, true));
            assert_eq!(led.frame(health(running, 50)).0, after, "{grade:?}");
        }
    }
}
