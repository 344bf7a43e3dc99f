//! One ADC scan and the rail test.

use crate::board;

/// Number of channels in one scan.
pub const SCAN_LEN: usize = 7;

/// ADC1 channels in scan (and DMA buffer) order: gyro XY reference, depth, gyro Z reference,
/// gyro X, gyro Y, gyro Z, VREFINT (channel numbers from [`crate::board`]).
///
/// The order makes a DMA buffer shifted by one rank (the ADC's calibration code taken for the
/// first conversion, RM0008 §11.4) visible to [`super::check_ranks`]: either way the depth
/// channel lands in a gyro reference's slot. The gyro outputs at rest read like their
/// references, so among the gyro ranks alone a shift could not be seen.
pub const SCAN_CHANNELS: [u8; SCAN_LEN] = [
    board::ADC_CH_GYRO_XY_REF,
    board::ADC_CH_DEPTH,
    board::ADC_CH_GYRO_Z_REF,
    board::ADC_CH_GYRO_X,
    board::ADC_CH_GYRO_Y,
    board::ADC_CH_GYRO_Z,
    board::ADC_CH_VREFINT,
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
    /// The internal reference VREFINT (1.20 V typ.), counts: measures VDDA.
    pub vrefint: u16,
}

impl AdcFrame {
    /// A frame from a DMA buffer in scan order ([`SCAN_CHANNELS`]).
    #[inline]
    pub const fn from_scan(scan: [u16; SCAN_LEN]) -> Self {
        AdcFrame {
            gyro_xy_ref: scan[0],
            depth: scan[1],
            gyro_z_ref: scan[2],
            gyro_x: scan[3],
            gyro_y: scan[4],
            gyro_z: scan[5],
            vrefint: scan[6],
        }
    }

    /// A frame by channel, for tests: gyro X, Y, XY reference, Z, Z reference, depth (VREFINT
    /// not measured: 0).
    #[cfg(test)]
    pub(crate) const fn from_channels(c: [u16; 6]) -> Self {
        AdcFrame {
            gyro_x: c[0],
            gyro_y: c[1],
            gyro_xy_ref: c[2],
            gyro_z: c[3],
            gyro_z_ref: c[4],
            depth: c[5],
            vrefint: 0,
        }
    }

    /// The counts in scan order ([`SCAN_CHANNELS`]).
    #[inline]
    pub const fn to_scan(&self) -> [u16; SCAN_LEN] {
        [
            self.gyro_xy_ref,
            self.depth,
            self.gyro_z_ref,
            self.gyro_x,
            self.gyro_y,
            self.gyro_z,
            self.vrefint,
        ]
    }

    /// The channels of this frame that are at a rail ([`at_rail`]).
    pub const fn rails(&self) -> Rails {
        let named = [
            (self.gyro_x, Rails::GYRO_X),
            (self.gyro_y, Rails::GYRO_Y),
            (self.gyro_xy_ref, Rails::GYRO_XY_REF),
            (self.gyro_z, Rails::GYRO_Z),
            (self.gyro_z_ref, Rails::GYRO_Z_REF),
            (self.depth, Rails::DEPTH),
            (self.vrefint, Rails::VREFINT),
        ];
        let mut bits = 0u8;
        let mut i = 0;
        while i < named.len() {
            if at_rail(named[i].0) {
                bits |= named[i].1 .0;
            }
            i += 1;
        }
        Rails(bits)
    }
}

/// A set of ADC channels (one bit per named channel, not the scan order), used to report which
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
    /// The internal reference VREFINT.
    pub const VREFINT: Rails = Rails(1 << 6);
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
        // RM0008 §11.12: VREFINT is ADC1's channel 17.
        assert_eq!(SCAN_CHANNELS, [12, 1, 15, 10, 11, 14, 17]);
        let f = AdcFrame::from_scan([1, 2, 3, 4, 5, 6, 7]);
        assert_eq!((f.gyro_xy_ref, f.depth, f.gyro_z_ref), (1, 2, 3));
        assert_eq!((f.gyro_x, f.gyro_y, f.gyro_z, f.vrefint), (4, 5, 6, 7));
        assert_eq!(f.to_scan(), [1, 2, 3, 4, 5, 6, 7]);
    }

    #[test]
    fn rail_thresholds() {
        assert_eq!(RAIL_HIGH, 4087);
        assert!(at_rail(0) && at_rail(8) && !at_rail(9));
        assert!(!at_rail(4086) && at_rail(4087) && at_rail(4095) && at_rail(u16::MAX));
        let f = AdcFrame { gyro_y: 8, gyro_z: 4090, ..AdcFrame::from_scan([2000; SCAN_LEN]) };
        assert_eq!(f.rails(), Rails::GYRO_Y | Rails::GYRO_Z);
        assert!(f.rails().intersects(Rails::GYRO) && !f.rails().intersects(Rails::DEPTH));
        assert!(AdcFrame::from_scan([2000; SCAN_LEN]).rails().is_empty());
        let f = AdcFrame { depth: 0, vrefint: 4095, ..AdcFrame::from_scan([2000; SCAN_LEN]) };
        assert_eq!(f.rails(), Rails::DEPTH | Rails::VREFINT);
    }
}
