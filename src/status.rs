//! What the device reports about its state: the status word of `$PINAH` ([`Status`]) and
//! the heading reference ([`HeadingRef`]). In a module of their own so that the NMEA sentences
//! and the supervision both depend on them and not on each other.

use core::ops::{BitOr, BitOrAssign};

use ekf_core::Flags;

/// Status word sent in `$PINAH`'s status field: bits 0–15 are the estimator's
/// [`ekf_core::Flags`] of the cycle, bits 16–19 are board-level conditions (the constants
/// below). `$PINAH` adds the heading reference in bits 20–21 and transmits bits 0–21 (6 hex
/// digits); bits 22–31 are reserved and dropped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Status(pub u32);

impl Status {
    /// No bit set.
    pub const NONE: Status = Status(0);
    /// Bit 16: an I²C transfer with the LSM303DLH failed this cycle (the accelerometer or
    /// magnetometer sample is missing).
    pub const I2C_FAULT: Status = Status(1 << 16);
    /// Bit 17: the ADC delivered no frame since the previous cycle, or dropped frames (DMA
    /// overrun, or [`crate::adc::AdcMean::dropped`] > 0).
    pub const ADC_FAULT: Status = Status(1 << 17);
    /// Bit 18: the gyro conversion saturated this cycle: a gyro channel touched an ADC rail,
    /// or a rate reached the full scale `gyro.range`
    /// ([`crate::adc::GyroReading::saturated`]).
    pub const GYRO_RAIL: Status = Status(1 << 18);
    /// Bit 19: the depth channel touched an ADC rail during the cycle
    /// ([`crate::adc::DepthReading::at_rail`]): the depth is not trusted.
    pub const DEPTH_RAIL: Status = Status(1 << 19);
    /// The estimator's flags and the board bits (0–19).
    pub const BOARD_AND_FLAGS: u32 = 0x000F_FFFF;
    /// Bit 20 (`$PINAH` only): the heading is referenced to true north by the operator
    /// (`YAW`).
    pub const HEADING_TRUE: Status = Status(1 << 20);
    /// Bit 21 (`$PINAH` only): the heading is referenced to true north by the magnetometer
    /// (magnetic heading plus `mag.declination`). Neither bit 20 nor 21: relative.
    pub const HEADING_MAGNETIC: Status = Status(1 << 21);
    /// The bits `$PINAH` transmits (0–21; 6 hex digits).
    pub const TRANSMITTED: u32 = 0x003F_FFFF;

    /// Bits 20–21 for a heading reference.
    pub const fn heading_ref(r: HeadingRef) -> Status {
        match r {
            HeadingRef::Relative => Status::NONE,
            HeadingRef::True => Status::HEADING_TRUE,
            HeadingRef::Magnetic => Status::HEADING_MAGNETIC,
        }
    }

    /// The status of an estimator update: its flags in bits 0–15, no board bit.
    #[inline]
    pub const fn from_flags(flags: Flags) -> Status {
        Status(flags.bits() as u32)
    }
    /// The estimator's flags (bits 0–15).
    #[inline]
    pub const fn flags(self) -> Flags {
        Flags(self.0 as u16)
    }
    /// True when every bit of `other` is set.
    #[inline]
    pub const fn contains(self, other: Status) -> bool {
        self.0 & other.0 == other.0
    }
    /// Set the bits of `other`.
    #[inline]
    pub fn insert(&mut self, other: Status) {
        self.0 |= other.0;
    }
}

/// The name of every status bit but the heading reference's (bits 20–21), as the status table
/// of `docs/troubleshooting.md` gives it (a test holds the two together); for operators' tools.
pub const BIT_NAMES: [(Status, &str); 19] = [
    (Status::from_flags(Flags::INITIALISING), "initialising"),
    (Status::from_flags(Flags::GYRO_INVALID), "gyro invalid"),
    (Status::from_flags(Flags::TIME_GAP), "time gap"),
    (Status::from_flags(Flags::GYRO_SATURATED), "gyro saturated"),
    (Status::from_flags(Flags::ACCEL_INVALID), "accelerometer invalid"),
    (Status::from_flags(Flags::ACCEL_GATED), "acceleration gate"),
    (Status::from_flags(Flags::ACCEL_KNOCK), "knock"),
    (Status::from_flags(Flags::ACCEL_REJECT_LONG), "long rejection"),
    (Status::from_flags(Flags::ACCEL_USED), "accelerometer used"),
    (Status::from_flags(Flags::AT_REST), "at rest"),
    (Status::from_flags(Flags::MAG_USED), "magnetometer used"),
    (Status::from_flags(Flags::MAG_REJECTED), "magnetometer rejected"),
    (Status::from_flags(Flags::HEALTH_RESET), "health reset"),
    (Status::from_flags(Flags::REACQUIRE), "reacquire"),
    (Status::from_flags(Flags::MOVING_START), "moving start"),
    (Status::I2C_FAULT, "I²C fault"),
    (Status::ADC_FAULT, "ADC fault"),
    (Status::GYRO_RAIL, "gyro saturated (conversion)"),
    (Status::DEPTH_RAIL, "depth rail"),
];

impl Status {
    /// The names of the bits set, lowest bit first ([`BIT_NAMES`]; the heading reference's
    /// bits and reserved bits are not named).
    pub fn names(self) -> impl Iterator<Item = &'static str> {
        BIT_NAMES.iter().filter(move |(bit, _)| self.contains(*bit)).map(|(_, name)| *name)
    }
}

impl From<Flags> for Status {
    fn from(flags: Flags) -> Status {
        Status::from_flags(flags)
    }
}
impl BitOr for Status {
    type Output = Status;
    fn bitor(self, o: Status) -> Status {
        Status(self.0 | o.0)
    }
}
impl BitOrAssign for Status {
    fn bitor_assign(&mut self, o: Status) {
        self.0 |= o.0;
    }
}

/// What the heading is referenced to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HeadingRef {
    /// Relative: integrated from the gyros since the start (from `init.yaw0`), not tied to
    /// north.
    #[default]
    Relative,
    /// True north, set by the operator (`YAW`, a true heading); the gyros carry it since.
    True,
    /// True north from the magnetometer (magnetic heading plus `mag.declination`).
    Magnetic,
}

impl HeadingRef {
    /// The letter sent in `$PINAH` and `STATUS`: `R`, `T` or `M`.
    pub const fn letter(self) -> &'static str {
        match self {
            HeadingRef::Relative => "R",
            HeadingRef::True => "T",
            HeadingRef::Magnetic => "M",
        }
    }

    /// True when the heading is referenced to true north (`HDT` may go out).
    pub const fn is_true(self) -> bool {
        !matches!(self, HeadingRef::Relative)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The names are the table's of `docs/troubleshooting.md`, bit by bit, and decode its
    /// examples as it reads them.
    #[test]
    fn bit_names_are_the_troubleshooting_table() {
        let doc = include_str!("../docs/troubleshooting.md");
        let mut rows = 0;
        for line in doc.lines().filter(|l| l.starts_with("| ")) {
            let cells: Vec<&str> = line.split(" | ").collect();
            let (Ok(bit), Ok(hex)) = (
                cells[0].trim_start_matches("| ").parse::<u32>(),
                u32::from_str_radix(cells.get(1).copied().unwrap_or(""), 16),
            ) else {
                continue;
            };
            assert_eq!(hex, 1 << bit, "{line}");
            if bit >= 20 {
                continue;
            }
            let named: Vec<&str> = Status(hex).names().collect();
            assert_eq!(named, [cells[2]], "bit {bit}");
            rows += 1;
        }
        assert_eq!(rows, BIT_NAMES.len());
        // "`000300` = accelerometer used + at rest"; "`110010` = heading set by `YAW`, I²C
        // fault + accelerometer invalid".
        assert_eq!(Status(0x000300).names().collect::<Vec<_>>(), ["accelerometer used", "at rest"]);
        assert_eq!(
            Status(0x110010).names().collect::<Vec<_>>(),
            ["accelerometer invalid", "I²C fault"]
        );
        assert_eq!(Status(0x300000 | 1 << 15).names().count(), 0);
    }

    #[test]
    fn board_bits_above_the_estimators() {
        let mut s = Status::from(Flags::AT_REST | Flags::ACCEL_USED);
        s |= Status::I2C_FAULT | Status::DEPTH_RAIL;
        assert_eq!(s.0, 0x0009_0300);
        assert_eq!(s.flags(), Flags::AT_REST | Flags::ACCEL_USED);
        assert!(s.contains(Status::I2C_FAULT) && !s.contains(Status::ADC_FAULT));
        let board = Status::I2C_FAULT | Status::ADC_FAULT | Status::GYRO_RAIL | Status::DEPTH_RAIL;
        assert_eq!(board.0 & 0xFFFF, 0);
        assert_eq!(board.0 & !Status::TRANSMITTED, 0);
        assert_eq!(board.0.count_ones(), 4);
    }
}
