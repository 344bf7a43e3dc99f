//! The status LED (PB9, active high): what the filter reports, and the blink patterns.
//!
//! The LED task works in frames of [`SLOTS`] slots of [`SLOT_MS`] ms (1 s). At the start of
//! each frame it takes the [`Health`] the filter accumulated during the previous one and picks
//! a [`Mode`]:
//! - fault, fast blink (5 Hz, 100 ms on / 100 ms off): an I²C or ADC fault, an invalid gyro
//!   sample, a health reset of the estimator, or no filter cycle at all in the last second;
//! - init, slow blink (1 Hz, 500 ms on / 500 ms off): the estimator's initialisation window
//!   (or the gyros still settling before the first cycle);
//! - running, a 50 ms flash once per second.

use crate::status::Status;
use ekf_core::Flags;

/// Slots per frame.
pub const SLOTS: u8 = 20;
/// Slot length, ms.
pub const SLOT_MS: u32 = 50;

/// What the filter reports to the LED task, accumulated over one LED frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct Health {
    /// Union of the status words of the cycles.
    pub status: Status,
    /// Number of cycles.
    pub cycles: u32,
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
    /// Initialisation window (slow blink).
    Init,
    /// Running normally (short flash per second).
    Running,
    /// A fault (fast blink).
    Fault,
}

impl Mode {
    /// Name, for the log.
    pub const fn name(self) -> &'static str {
        match self {
            Mode::Init => "init",
            Mode::Running => "running",
            Mode::Fault => "fault",
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
/// boot (before that the gyros settle and no cycle is expected).
pub fn mode(health: Health, started: bool) -> Mode {
    if health.cycles == 0 {
        return if started { Mode::Fault } else { Mode::Init };
    }
    if health.status.0 & FAULT_BITS.0 != 0 {
        Mode::Fault
    } else if health.status.flags().contains(Flags::INITIALISING) {
        Mode::Init
    } else {
        Mode::Running
    }
}

/// Whether the LED is on in `slot` (0..SLOTS) of a frame in `mode`.
pub fn lit(mode: Mode, slot: u8) -> bool {
    match mode {
        Mode::Init => slot < SLOTS / 2,
        Mode::Running => slot == 0,
        Mode::Fault => (slot / 2) % 2 == 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn health(status: Status, cycles: u32) -> Health {
        Health { status, cycles }
    }

    /// The LED's on-time per frame and the number of separate flashes.
    fn pattern(mode: Mode) -> (u32, u32) {
        let on: Vec<bool> = (0..SLOTS).map(|s| lit(mode, s)).collect();
        let ms = on.iter().filter(|l| **l).count() as u32 * SLOT_MS;
        let flashes = (0..on.len()).filter(|&i| on[i] && (i == 0 || !on[i - 1])).count() as u32;
        (ms, flashes)
    }

    #[test]
    fn patterns_are_the_documented_ones() {
        assert_eq!(SLOTS as u32 * SLOT_MS, 1000, "one frame is one second");
        // Init: 1 Hz, 500 ms on. Running: one 50 ms flash per second. Fault: 5 Hz, 100 ms on.
        assert_eq!(pattern(Mode::Init), (500, 1));
        assert_eq!(pattern(Mode::Running), (50, 1));
        assert_eq!(pattern(Mode::Fault), (500, 5));
        assert!((0..SLOTS).all(|s| lit(Mode::Fault, s) == (s % 4 < 2)));
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
            assert_eq!(mode(health(running | fault, 50), true), Mode::Fault, "{fault:?}");
            // Even during the initialisation window.
            let init = Status::from_flags(Flags::INITIALISING) | fault;
            assert_eq!(mode(health(init, 50), true), Mode::Fault, "{fault:?}");
        }
        // No cycle in a whole second once the filter ran: the filter is stuck.
        assert_eq!(mode(health(Status::NONE, 0), true), Mode::Fault);
    }

    #[test]
    fn init_and_running() {
        // Gyros settling before the first cycle.
        assert_eq!(mode(health(Status::NONE, 0), false), Mode::Init);
        let init = Status::from_flags(Flags::INITIALISING);
        assert_eq!(mode(health(init, 50), true), Mode::Init);
        // Conditions that are reported but are not faults of the device.
        for s in [
            Status::NONE,
            Status::from_flags(Flags::ACCEL_USED | Flags::AT_REST),
            Status::from_flags(Flags::ACCEL_GATED | Flags::ACCEL_KNOCK),
            Status::GYRO_RAIL | Status::from_flags(Flags::GYRO_SATURATED),
            Status::DEPTH_RAIL,
        ] {
            assert_eq!(mode(health(s, 50), true), Mode::Running, "{s:?}");
        }
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
        assert_eq!(mode(h, true), Mode::Fault);
    }
}
