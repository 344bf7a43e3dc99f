//! Averaging of ADC frames down to the filter rate.

use super::frame::{AdcFrame, Rails, SCAN_LEN};

/// Mean counts of the frames accumulated since the previous [`Averager::take`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AdcMean {
    /// Gyro X output, mean counts.
    pub gyro_x: f32,
    /// Gyro Y output, mean counts.
    pub gyro_y: f32,
    /// Gyro XY reference, mean counts.
    pub gyro_xy_ref: f32,
    /// Gyro Z output, mean counts.
    pub gyro_z: f32,
    /// Gyro Z reference, mean counts.
    pub gyro_z_ref: f32,
    /// Depth sensor, mean counts.
    pub depth: f32,
    /// VREFINT, mean counts; 0 when not measured (a trace, a test): the conversions then use
    /// the nominal VDDA (`AdcScale::for_mean`).
    pub vrefint: f32,
    /// Number of frames averaged (≥ 1).
    pub samples: u32,
    /// Frames dropped because the averager was full ([`Averager::CAPACITY`]); 0 in normal
    /// operation.
    pub dropped: u32,
    /// The channels on which at least one averaged frame was at a rail
    /// ([`super::RAIL_LOW`], [`super::RAIL_HIGH`]).
    pub rails: Rails,
}

impl AdcMean {
    /// True when any sample of any channel touched a rail.
    #[inline]
    pub const fn touched_rail(&self) -> bool {
        !self.rails.is_empty()
    }

    /// A mean of a single frame (every channel's counts as `f32`, one sample).
    pub fn from_frame(frame: &AdcFrame) -> Self {
        AdcMean {
            gyro_x: f32::from(frame.gyro_x),
            gyro_y: f32::from(frame.gyro_y),
            gyro_xy_ref: f32::from(frame.gyro_xy_ref),
            gyro_z: f32::from(frame.gyro_z),
            gyro_z_ref: f32::from(frame.gyro_z_ref),
            depth: f32::from(frame.depth),
            vrefint: f32::from(frame.vrefint),
            samples: 1,
            dropped: 0,
            rails: frame.rails(),
        }
    }
}

/// Accumulates [`AdcFrame`]s (per-channel sums in `u32`) until the filter takes their mean.
///
/// Holds up to [`Averager::CAPACITY`] frames (65 s at 1 kHz) whatever their counts; frames
/// pushed beyond that are dropped and counted in [`AdcMean::dropped`], so the sums never
/// overflow.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Averager {
    sums: [u32; SCAN_LEN],
    count: u32,
    dropped: u32,
    rails: Rails,
}

impl Averager {
    /// Frames the averager holds: 65536 × 65535 (the largest `u16`) < 2³², so no sum can
    /// overflow.
    pub const CAPACITY: u32 = 65_536;

    /// An empty averager.
    pub const fn new() -> Self {
        Averager { sums: [0; SCAN_LEN], count: 0, dropped: 0, rails: Rails::NONE }
    }

    /// Add one frame (dropped and counted if the averager already holds
    /// [`Averager::CAPACITY`] frames).
    pub fn push(&mut self, frame: &AdcFrame) {
        if self.count >= Self::CAPACITY {
            self.dropped = self.dropped.saturating_add(1);
            return;
        }
        for (sum, counts) in self.sums.iter_mut().zip(frame.to_scan()) {
            // Cannot overflow below CAPACITY frames; saturating to stay panic-free regardless.
            *sum = sum.saturating_add(u32::from(counts));
        }
        self.count += 1;
        self.rails |= frame.rails();
    }

    /// Frames accumulated since the last [`Averager::take`].
    #[inline]
    pub const fn len(&self) -> u32 {
        self.count
    }

    /// True when no frame has been accumulated since the last [`Averager::take`].
    #[inline]
    pub const fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The mean of the accumulated frames (`None` if there were none), and reset.
    ///
    /// Each mean is `quotient + remainder / count` of the integer division of the sum, so it is
    /// exact whenever it is representable in `f32` (any mean with a power-of-two count, or an
    /// integer or half-integer mean) and within one rounding of the exact value otherwise.
    pub fn take(&mut self) -> Option<AdcMean> {
        let count = self.count;
        if count == 0 {
            return None;
        }
        let mut mean = [0.0f32; SCAN_LEN];
        for (m, &sum) in mean.iter_mut().zip(self.sums.iter()) {
            let quotient = sum / count;
            let remainder = sum % count;
            // Both are below 2^24 (quotient ≤ 65535, remainder < count ≤ 65536): exact in f32.
            *m = quotient as f32 + remainder as f32 / count as f32;
        }
        // Scan order (SCAN_CHANNELS), as `AdcFrame::to_scan` summed it.
        let out = AdcMean {
            gyro_xy_ref: mean[0],
            depth: mean[1],
            gyro_z_ref: mean[2],
            gyro_x: mean[3],
            gyro_y: mean[4],
            gyro_z: mean[5],
            vrefint: mean[6],
            samples: count,
            dropped: self.dropped,
            rails: self.rails,
        };
        *self = Averager::new();
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(v: u16) -> AdcFrame {
        AdcFrame::from_scan([v; SCAN_LEN])
    }

    /// A frame by channel: gyro X, Y, XY reference, Z, Z reference, depth; VREFINT 1489.
    fn named(c: [u16; 6]) -> AdcFrame {
        AdcFrame {
            gyro_x: c[0],
            gyro_y: c[1],
            gyro_xy_ref: c[2],
            gyro_z: c[3],
            gyro_z_ref: c[4],
            depth: c[5],
            vrefint: 1489,
        }
    }

    #[test]
    fn empty_gives_none() {
        let mut a = Averager::new();
        assert!(a.is_empty());
        assert_eq!(a.take(), None);
    }

    #[test]
    fn small_mean_and_reset() {
        let mut a = Averager::new();
        a.push(&named([100, 200, 300, 400, 500, 600]));
        a.push(&named([101, 200, 301, 400, 500, 601]));
        a.push(&named([102, 200, 302, 400, 500, 605]));
        assert_eq!(a.len(), 3);
        let m = a.take().unwrap();
        assert_eq!(m.samples, 3);
        assert_eq!((m.gyro_x, m.gyro_y, m.gyro_xy_ref), (101.0, 200.0, 301.0));
        assert_eq!((m.gyro_z, m.gyro_z_ref), (400.0, 500.0));
        assert_eq!((m.depth, m.vrefint), (602.0, 1489.0));
        assert!(!m.touched_rail());
        assert!(a.is_empty() && a.take().is_none());
    }

    #[test]
    fn thirds_are_within_one_rounding() {
        let mut a = Averager::new();
        for v in [1000, 1000, 1001] {
            a.push(&frame(v));
        }
        let m = a.take().unwrap();
        assert_eq!(m.gyro_x, (3001.0f64 / 3.0) as f32);
    }

    #[test]
    fn full_capacity_at_largest_counts_is_exact() {
        // 65536 frames of the largest possible u16: the sum is 2^32 − 65536, no overflow.
        let mut a = Averager::new();
        for _ in 0..Averager::CAPACITY {
            a.push(&frame(u16::MAX));
        }
        let m = a.take().unwrap();
        assert_eq!(m.samples, 65_536);
        assert_eq!(m.gyro_x, 65535.0);
        assert_eq!(m.depth, 65535.0);
        assert_eq!(m.dropped, 0);
        assert_eq!(m.rails, Rails(0b111_1111));
    }

    #[test]
    fn large_count_fractional_mean_is_exact() {
        // Alternating 4000 and 4001 over 65536 frames: mean 4000.5 exactly; a ramp over 65536
        // frames (0..4096 repeated 16 times): mean 2047.5 exactly.
        let mut a = Averager::new();
        for i in 0..65_536u32 {
            let ramp = (i % 4096) as u16;
            a.push(&named([4000 + (i % 2) as u16, ramp, 2000, 2000, 2000, 17]));
        }
        let m = a.take().unwrap();
        assert_eq!(m.gyro_x, 4000.5);
        assert_eq!(m.gyro_y, 2047.5);
        assert_eq!(m.gyro_xy_ref, 2000.0);
        assert_eq!(m.depth, 17.0);
        // The ramp passes both rails, gyro X's 4001 does not reach 4087.
        assert_eq!(m.rails, Rails::GYRO_Y);
        // 1000 frames of 1234 and 24 of 1235 (1024 frames): mean 1234 + 24/1024, exact.
        for i in 0..1024 {
            a.push(&frame(if i < 24 { 1235 } else { 1234 }));
        }
        assert_eq!(a.take().unwrap().gyro_z, 1234.0 + 24.0 / 1024.0);
    }

    #[test]
    fn frames_beyond_capacity_are_dropped_and_counted() {
        let mut a = Averager::new();
        for _ in 0..Averager::CAPACITY {
            a.push(&frame(3000));
        }
        a.push(&frame(u16::MAX));
        a.push(&frame(0));
        let m = a.take().unwrap();
        assert_eq!((m.samples, m.dropped, m.gyro_x), (65_536, 2, 3000.0));
        assert!(!m.touched_rail());
    }

    #[test]
    fn rail_touched_by_a_single_frame() {
        let mut a = Averager::new();
        for _ in 0..99 {
            a.push(&frame(2000));
        }
        a.push(&named([2000, 2000, 2000, 2000, 2000, 4095]));
        let m = a.take().unwrap();
        assert!(m.touched_rail());
        assert_eq!(m.rails, Rails::DEPTH);
    }
}
