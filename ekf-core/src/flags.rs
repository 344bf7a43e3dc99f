//! Status flags reported by every filter for each update.

use core::ops::{BitOr, BitOrAssign};

/// A set of status flags (bit set). Each update returns the flags that describe what it did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Flags(pub u16);

impl Flags {
    /// No flag.
    pub const NONE: Flags = Flags(0);
    /// The initialisation window is still running; the attitude is provisional.
    pub const INITIALISING: Flags = Flags(1 << 0);
    /// The gyro sample was NaN, infinite or absurd: it did not reach the state (the attitude
    /// was held and only the uncertainty grew).
    pub const GYRO_INVALID: Flags = Flags(1 << 1);
    /// `dt` was non-positive or non-finite (sample ignored), or longer than the gap limit
    /// (attitude propagated over the limit only, uncertainty over the whole gap).
    pub const TIME_GAP: Flags = Flags(1 << 2);
    /// A gyro axis is at or beyond the sensor's range (±300 °/s by default).
    pub const GYRO_SATURATED: Flags = Flags(1 << 3);
    /// The accelerometer sample was NaN, infinite, absurd or near zero: not used.
    pub const ACCEL_INVALID: Flags = Flags(1 << 4);
    /// Acceleration-magnitude gate: `| |a|/g − 1 |` above the tolerance, update skipped.
    pub const ACCEL_GATED: Flags = Flags(1 << 5);
    /// Knock detection: a jump between samples, an innovation outside the gate, or the
    /// hold-off after either; update skipped.
    pub const ACCEL_KNOCK: Flags = Flags(1 << 6);
    /// The accelerometer has been rejected continuously for longer than the long-rejection
    /// time: tilt rests on the gyros alone.
    pub const ACCEL_REJECT_LONG: Flags = Flags(1 << 7);
    /// The accelerometer corrected tilt in this update.
    pub const ACCEL_USED: Flags = Flags(1 << 8);
    /// Rest detected: the vehicle is still; gyro bias re-estimated and yaw held.
    pub const AT_REST: Flags = Flags(1 << 9);
    /// The magnetometer corrected heading in this update.
    pub const MAG_USED: Flags = Flags(1 << 10);
    /// The magnetometer sample was rejected (field norm, dip angle, innovation or invalid).
    pub const MAG_REJECTED: Flags = Flags(1 << 11);
    /// A health check found a broken state (quaternion or covariance) and reset it.
    pub const HEALTH_RESET: Flags = Flags(1 << 12);
    /// The innovation gate was bypassed to reacquire tilt after a long innovation rejection.
    pub const REACQUIRE: Flags = Flags(1 << 13);
    /// The initialisation window was not still: the filter started at once from the
    /// configured gyro bias with a wide covariance, and the bias is still less certain than a
    /// still window would have made it.
    pub const MOVING_START: Flags = Flags(1 << 14);

    /// True when every flag of `other` is set in `self`.
    #[inline]
    pub const fn contains(self, other: Flags) -> bool {
        self.0 & other.0 == other.0
    }
    /// True when any flag of `other` is set in `self`.
    #[inline]
    pub const fn intersects(self, other: Flags) -> bool {
        self.0 & other.0 != 0
    }
    /// Set the flags of `other`.
    #[inline]
    pub fn insert(&mut self, other: Flags) {
        self.0 |= other.0;
    }
    /// Clear the flags of `other`.
    #[inline]
    pub fn remove(&mut self, other: Flags) {
        self.0 &= !other.0;
    }
    /// The raw bits.
    #[inline]
    pub const fn bits(self) -> u16 {
        self.0
    }
}

impl BitOr for Flags {
    type Output = Flags;
    fn bitor(self, o: Flags) -> Flags {
        Flags(self.0 | o.0)
    }
}
impl BitOrAssign for Flags {
    fn bitor_assign(&mut self, o: Flags) {
        self.0 |= o.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_are_distinct_bits() {
        let all = [
            Flags::INITIALISING,
            Flags::GYRO_INVALID,
            Flags::TIME_GAP,
            Flags::GYRO_SATURATED,
            Flags::ACCEL_INVALID,
            Flags::ACCEL_GATED,
            Flags::ACCEL_KNOCK,
            Flags::ACCEL_REJECT_LONG,
            Flags::ACCEL_USED,
            Flags::AT_REST,
            Flags::MAG_USED,
            Flags::MAG_REJECTED,
            Flags::HEALTH_RESET,
            Flags::REACQUIRE,
            Flags::MOVING_START,
        ];
        let mut acc = Flags::NONE;
        for f in all {
            assert_eq!(f.0.count_ones(), 1);
            assert!(!acc.intersects(f));
            acc |= f;
        }
        assert!(acc.contains(Flags::AT_REST | Flags::ACCEL_USED));
        acc.remove(Flags::AT_REST);
        assert!(!acc.contains(Flags::AT_REST));
    }

    /// Setting a flag that is already set leaves it set (`|` on the bits, not a toggle), and
    /// `bits` is the raw word the firmware and the replay log report.
    #[test]
    fn setting_a_set_flag_keeps_it_and_bits_are_the_word() {
        let both = Flags::AT_REST | Flags::ACCEL_USED;
        assert_eq!(both | Flags::AT_REST, both);
        let mut f = both;
        f |= Flags::AT_REST;
        f.insert(Flags::ACCEL_USED);
        assert_eq!(f, both);
        f.insert(Flags::TIME_GAP);
        assert_eq!(f.bits(), 0x0304);
        assert_eq!(Flags::NONE.bits(), 0);
        assert_eq!(Flags::MOVING_START.bits(), 0x4000);
    }
}
