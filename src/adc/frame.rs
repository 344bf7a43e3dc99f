//! One ADC scan and the rail test.

use crate::board;

/// Number of channels in one scan.
pub const SCAN_LEN: usize = 6;

/// ADC1 channels in scan (and DMA buffer) order: gyro X, gyro Y, gyro XY reference, gyro Z,
/// gyro Z reference, depth (channel numbers from [`crate::board`]).
pub const SCAN_CHANNELS: [u8; SCAN_LEN] = [
    board::ADC_CH_GYRO_X,
    board::ADC_CH_GYRO_Y,
    board::ADC_CH_GYRO_XY_REF,
    board::ADC_CH_GYRO_Z,
    board::ADC_CH_GYRO_Z_REF,
    board::ADC_CH_DEPTH,
];

/// A count at or below this (counts; 8 counts ≈ 6.4 mV above 0 V) is at the low rail: the
/// signal may be clipped by the ADC or by the driving amplifier's output swing, so the value
/// is not trusted.
pub const RAIL_LOW: u16 = 8;
/// A count at or above this (counts; 4087 = full scale 4095 − 8, ≈ 6.4 mV below VREF) is at
/// the high rail. Counts above 4095 (impossible for a 12-bit conversion) also count as rail.
pub const RAIL_HIGH: u16 = board::ADC_FULL_SCALE - 8;

/// True when a count is at a rail (≤ [`RAIL_LOW`] or ≥ [`RAIL_HIGH`]).
#[inline]
pub const fn at_rail(counts: u16) -> bool {
    counts <= RAIL_LOW || counts >= RAIL_HIGH
}

/// One ADC scan: the raw 12-bit count (0–4095, right-aligned) of every channel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AdcFrame {
    /// LPR430AL X rate output (4× amplified), counts.
    pub gyro_x: u16,
    /// LPR430AL Y rate output (4× amplified), counts.
    pub gyro_y: u16,
    /// LPR430AL reference voltage (the X and Y zero-rate level), counts.
    pub gyro_xy_ref: u16,
    /// LY330ALH Z rate output, counts.
    pub gyro_z: u16,
    /// LY330ALH reference voltage (the Z zero-rate level), counts.
    pub gyro_z_ref: u16,
    /// Depth (pressure) sensor output, scaled into 0–3.3 V, counts.
    pub depth: u16,
}

impl AdcFrame {
    /// A frame from a DMA buffer in scan order ([`SCAN_CHANNELS`]).
    #[inline]
    pub const fn from_scan(scan: [u16; SCAN_LEN]) -> Self {
        AdcFrame {
            gyro_x: scan[0],
            gyro_y: scan[1],
            gyro_xy_ref: scan[2],
            gyro_z: scan[3],
            gyro_z_ref: scan[4],
            depth: scan[5],
        }
    }

    /// The counts in scan order ([`SCAN_CHANNELS`]).
    #[inline]
    pub const fn to_scan(&self) -> [u16; SCAN_LEN] {
        [self.gyro_x, self.gyro_y, self.gyro_xy_ref, self.gyro_z, self.gyro_z_ref, self.depth]
    }

    /// The channels of this frame that are at a rail ([`at_rail`]).
    pub const fn rails(&self) -> Rails {
        let scan = self.to_scan();
        let mut bits = 0u8;
        let mut i = 0;
        while i < SCAN_LEN {
            if at_rail(scan[i]) {
                bits |= 1 << i;
            }
            i += 1;
        }
        Rails(bits)
    }
}

/// A set of ADC channels (bit `i` = channel `i` of the scan order), used to report which
/// channels touched a rail.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Rails(pub u8);

impl Rails {
    /// No channel.
    pub const NONE: Rails = Rails(0);
    /// Gyro X output.
    pub const GYRO_X: Rails = Rails(1 << 0);
    /// Gyro Y output.
    pub const GYRO_Y: Rails = Rails(1 << 1);
    /// Gyro XY reference.
    pub const GYRO_XY_REF: Rails = Rails(1 << 2);
    /// Gyro Z output.
    pub const GYRO_Z: Rails = Rails(1 << 3);
    /// Gyro Z reference.
    pub const GYRO_Z_REF: Rails = Rails(1 << 4);
    /// Depth sensor.
    pub const DEPTH: Rails = Rails(1 << 5);
    /// Every gyro channel (outputs and references).
    pub const GYRO: Rails = Rails(0b1_1111);

    /// True when no channel is in the set.
    #[inline]
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }
    /// True when any channel of `other` is in the set.
    #[inline]
    pub const fn intersects(self, other: Rails) -> bool {
        self.0 & other.0 != 0
    }
    /// The union of two sets.
    #[inline]
    pub const fn union(self, other: Rails) -> Rails {
        Rails(self.0 | other.0)
    }
}

impl core::ops::BitOr for Rails {
    type Output = Rails;
    fn bitor(self, o: Rails) -> Rails {
        self.union(o)
    }
}
impl core::ops::BitOrAssign for Rails {
    fn bitor_assign(&mut self, o: Rails) {
        self.0 |= o.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scan_order_matches_board() {
        assert_eq!(SCAN_CHANNELS, [10, 11, 12, 14, 15, 1]);
        let f = AdcFrame::from_scan([1, 2, 3, 4, 5, 6]);
        assert_eq!((f.gyro_x, f.gyro_xy_ref, f.gyro_z_ref, f.depth), (1, 3, 5, 6));
        assert_eq!(f.to_scan(), [1, 2, 3, 4, 5, 6]);
    }

    #[test]
    fn rail_thresholds() {
        assert_eq!(RAIL_HIGH, 4087);
        assert!(at_rail(0) && at_rail(8) && !at_rail(9));
        assert!(!at_rail(4086) && at_rail(4087) && at_rail(4095) && at_rail(u16::MAX));
        let f = AdcFrame::from_scan([2000, 8, 2000, 4090, 2000, 2000]);
        assert_eq!(f.rails(), Rails::GYRO_Y | Rails::GYRO_Z);
        assert!(f.rails().intersects(Rails::GYRO) && !f.rails().intersects(Rails::DEPTH));
        assert!(AdcFrame::from_scan([2000; 6]).rails().is_empty());
    }
}
