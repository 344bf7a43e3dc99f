//! Stuck-data detection for the accelerometer: a sensor that stopped converting (frozen
//! output registers, a latched-up LSM303DLH) keeps answering on the bus with the same bytes.
//! A working one never repeats a sample for long: its noise (a few mg) moves at least one of
//! the three 1-mg steps between conversions, and every filter cycle reads a new conversion
//! (`supervision::imu` runs the accelerometer at least as fast as the filter).

/// Consecutive cycles with a bit-identical three-axis sample after which the data counts as
/// stuck (0.5 s at the default 50 Hz filter rate).
pub const STUCK_CYCLES: u16 = 25;

/// Counts repeats of the same sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StuckDetector {
    last: Option<[u32; 3]>,
    repeats: u16,
}

impl StuckDetector {
    /// Feed this cycle's sample (sensor units); true while the data is stuck, i.e. the sample
    /// equals the previous one in each of the last [`STUCK_CYCLES`] cycles.
    pub fn push(&mut self, sample: [f32; 3]) -> bool {
        let bits = sample.map(f32::to_bits);
        if self.last == Some(bits) {
            self.repeats = self.repeats.saturating_add(1);
        } else {
            self.repeats = 0;
        }
        self.last = Some(bits);
        self.repeats >= STUCK_CYCLES
    }

    /// Forget the history (after the sensor was configured again, or a missing sample).
    pub fn reset(&mut self) {
        *self = StuckDetector::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frozen_sample_is_stuck_after_the_limit_and_a_change_clears_it() {
        let mut d = StuckDetector::default();
        let s = [0.001, -0.002, 0.998];
        // The first sample and STUCK_CYCLES − 1 repeats are fine; the next repeat is stuck.
        for i in 0..STUCK_CYCLES {
            assert!(!d.push(s), "cycle {i}");
        }
        assert!(d.push(s));
        assert!(d.push(s));
        // One changed axis (one 1-mg step) clears it.
        assert!(!d.push([0.001, -0.002, 0.999]));
        assert!(!d.push(s));
    }

    #[test]
    fn a_noisy_still_sensor_is_never_stuck() {
        // A still board with 2 mg of quantised noise per axis for 10 minutes at 50 Hz.
        let mut d = StuckDetector::default();
        let mut x: u32 = 7;
        let mut noise = || {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            ((x >> 16) % 5) as f32 * 0.001 - 0.002
        };
        for i in 0..30_000 {
            let s = [noise(), noise(), 1.0 + noise()];
            assert!(!d.push(s), "cycle {i}");
        }
    }

    #[test]
    fn reset_forgets() {
        let mut d = StuckDetector::default();
        for _ in 0..=STUCK_CYCLES {
            d.push([0.0, 0.0, 1.0]);
        }
        d.reset();
        assert!(!d.push([0.0, 0.0, 1.0]));
    }
}
