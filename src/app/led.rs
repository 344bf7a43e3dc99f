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

use ekf_core::Flags;
use inemo_ahrs::nmea::Status;

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
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum Mode {
    /// Initialisation window (slow blink).
    Init,
    /// Running normally (short flash per second).
    Running,
    /// A fault (fast blink).
    Fault,
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
