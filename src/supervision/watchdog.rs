//! When the independent watchdog may be fed: at the end of a *healthy* filter cycle only.
//!
//! A cycle that does not reach its end (a hung task, a stalled timer) never feeds, so the
//! watchdog resets the MCU. A cycle that ends is healthy unless the estimator has reported a
//! health reset (`Flags::HEALTH_RESET`) in each of the last [`HEALTH_RESET_STORM`] cycles: a
//! lasting reset storm resets the MCU too. Sensor faults (I²C, ADC, gyro rails) do not: they
//! are reported in the status word and retried, and the filter carries on.

use ekf_core::Flags;

use crate::nmea::Status;

/// Consecutive cycles with an estimator health reset after which the cycles no longer count
/// as healthy.
pub const HEALTH_RESET_STORM: u32 = 10;

/// What the end of one cycle decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Feed the watchdog.
    Feed,
    /// Do not feed: this cycle is the first of a storm (log it once).
    StormStarted,
    /// Do not feed: the storm goes on.
    Starve,
}

impl Verdict {
    /// True for [`Verdict::Feed`].
    pub fn feed(self) -> bool {
        self == Verdict::Feed
    }
}

/// Counts the estimator's health resets in a row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FeedPolicy {
    resets_in_row: u32,
}

impl FeedPolicy {
    /// A cycle ended with `status`: feed the watchdog or not.
    pub fn cycle_end(&mut self, status: Status) -> Verdict {
        if status.flags().contains(Flags::HEALTH_RESET) {
            self.resets_in_row = self.resets_in_row.saturating_add(1);
        } else {
            self.resets_in_row = 0;
        }
        match self.resets_in_row {
            n if n < HEALTH_RESET_STORM => Verdict::Feed,
            HEALTH_RESET_STORM => Verdict::StormStarted,
            _ => Verdict::Starve,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reset() -> Status {
        Status::from_flags(Flags::HEALTH_RESET | Flags::ACCEL_USED)
    }

    #[test]
    fn sensor_faults_still_feed() {
        let mut p = FeedPolicy::default();
        for s in [
            Status::NONE,
            Status::I2C_FAULT | Status::from_flags(Flags::ACCEL_INVALID),
            Status::ADC_FAULT | Status::from_flags(Flags::GYRO_INVALID),
            Status::GYRO_RAIL | Status::from_flags(Flags::GYRO_SATURATED),
            Status::DEPTH_RAIL,
            Status(Status::TRANSMITTED & !u32::from(Flags::HEALTH_RESET.bits())),
        ] {
            for _ in 0..1000 {
                assert_eq!(p.cycle_end(s), Verdict::Feed, "{s:?}");
            }
        }
    }

    #[test]
    fn a_reset_storm_stops_feeding_until_a_clean_cycle() {
        let mut p = FeedPolicy::default();
        // Nine resets in a row still feed; the tenth starts the storm.
        for _ in 1..HEALTH_RESET_STORM {
            assert!(p.cycle_end(reset()).feed());
        }
        assert_eq!(p.cycle_end(reset()), Verdict::StormStarted);
        for _ in 0..100 {
            assert_eq!(p.cycle_end(reset()), Verdict::Starve);
        }
        // A clean cycle ends it (if the MCU has not been reset by then).
        assert!(p.cycle_end(Status::NONE).feed());
        assert!(p.cycle_end(reset()).feed());
    }

    #[test]
    fn isolated_resets_never_starve() {
        let mut p = FeedPolicy::default();
        for i in 0..10_000 {
            let s = if i % HEALTH_RESET_STORM == 0 { Status::NONE } else { reset() };
            assert!(p.cycle_end(s).feed(), "cycle {i}");
        }
    }
}
