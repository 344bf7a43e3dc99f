//! When the independent watchdog may be fed — at the end of a *healthy* filter cycle only — and
//! how it is programmed ([`Iwdg`]: every write waits for PVU/RVU before the reload).
//!
//! A cycle that does not reach its end (a hung task, a stalled timer) never feeds, so the
//! watchdog resets the MCU. A cycle that ends is healthy unless the estimator has reported a
//! health reset (`Flags::HEALTH_RESET`) in each of the last [`HEALTH_RESET_STORM`] cycles: a
//! lasting reset storm resets the MCU too. Sensor faults (I²C, ADC, gyro rails) do not: they
//! are reported in the status word and retried, and the filter carries on.

use ekf_core::Flags;

use crate::status::Status;

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

/// IWDG_KR keys (RM0008 §19.4.1).
pub mod key {
    /// Starts the watchdog.
    pub const START: u16 = 0xCCCC;
    /// Unlocks IWDG_PR and IWDG_RLR (any other key locks them again).
    pub const UNLOCK: u16 = 0x5555;
    /// Reloads the counter from IWDG_RLR.
    pub const RELOAD: u16 = 0xAAAA;
}
/// IWDG_SR: a prescaler update is under way (PVU, bit 0) / a reload value update (RVU, bit 1).
pub const SR_PVU: u32 = 1 << 0;
/// See [`SR_PVU`].
pub const SR_RVU: u32 = 1 << 1;
/// IWDG_PR for LSI / 64.
pub const PR_DIV64: u8 = 4;
/// Polls of IWDG_SR at most while an update crosses into the LSI domain (RM0008 §19.4.4: up
/// to five LSI periods, 170 µs at the slowest LSI of 30 kHz); the firmware pauses 10 µs per
/// poll, so 100 polls are 1 ms, six times that.
pub const UPDATE_POLLS: u32 = 100;

/// Timeout from `init` to the first feed, ms (nominal LSI).
pub const BOOT_TIMEOUT_MS: u32 = 2000;
/// Timeout between feeds once the filter runs, ms (nominal LSI: 333–667 ms over the LSI range).
pub const RUN_TIMEOUT_MS: u32 = 500;

/// Reload value for a timeout at LSI / 64 (40 kHz / 64 = 625 Hz).
pub const fn reload(ms: u32) -> u16 {
    let counts = ms * 40 / 64;
    let rl = if counts > 0 { counts - 1 } else { 0 };
    if rl > 0xFFF {
        0xFFF
    } else {
        rl as u16
    }
}

/// The IWDG's registers.
pub trait IwdgRegs {
    /// Writes IWDG_KR.
    fn key(&mut self, key: u16);
    /// Writes IWDG_PR.
    fn prescaler(&mut self, pr: u8);
    /// Writes IWDG_RLR.
    fn reload(&mut self, rlr: u16);
    /// Reads IWDG_SR.
    fn status(&mut self) -> u32;
    /// Waits a little between two polls of the status.
    fn pause(&mut self);
}

/// The IWDG's programming sequence (RM0008 §19.3, §19.4.4): a value written to IWDG_PR or
/// IWDG_RLR reaches the LSI domain up to five LSI periods later, while IWDG_SR's PVU/RVU is
/// set; a reload (KR = 0xAAAA) before that loads the counter with the *old* value, and a
/// write meanwhile is ignored. So every write is followed by a bounded wait for PVU/RVU clear
/// before the reload.
pub struct Iwdg<R> {
    regs: R,
    /// The run timeout is programmed.
    running: bool,
    /// A wait for PVU/RVU ran out (the update may not have taken effect).
    pub update_timeouts: u32,
}

impl<R: IwdgRegs> Iwdg<R> {
    /// Starts the watchdog with [`BOOT_TIMEOUT_MS`].
    pub fn start(regs: R) -> Self {
        let mut w = Iwdg { regs, running: false, update_timeouts: 0 };
        w.regs.key(key::START);
        w.program(Some(PR_DIV64), reload(BOOT_TIMEOUT_MS));
        w
    }

    /// Writes the prescaler (if given) and the reload value, waits for them to take effect,
    /// then reloads the counter.
    fn program(&mut self, pr: Option<u8>, rlr: u16) {
        self.wait_updates();
        self.regs.key(key::UNLOCK);
        if let Some(pr) = pr {
            self.regs.prescaler(pr);
        }
        self.regs.reload(rlr);
        self.wait_updates();
        self.regs.key(key::RELOAD);
    }

    /// Waits (bounded) until no update is under way; false when it is still.
    fn wait_updates(&mut self) -> bool {
        for _ in 0..UPDATE_POLLS {
            if self.regs.status() & (SR_PVU | SR_RVU) == 0 {
                return true;
            }
            self.regs.pause();
        }
        self.update_timeouts = self.update_timeouts.saturating_add(1);
        false
    }

    /// Reloads the counter. The first call switches to [`RUN_TIMEOUT_MS`].
    pub fn feed(&mut self) {
        if self.running {
            self.regs.key(key::RELOAD);
        } else {
            self.program(None, reload(RUN_TIMEOUT_MS));
            self.running = true;
        }
    }

    /// The registers (tests).
    pub fn regs(&self) -> &R {
        &self.regs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The IWDG with its LSI-domain latency (RM0008 §19.4.4): writes to PR/RLR reach the
    /// counter's domain `LATENCY` LSI ticks later (PVU/RVU set meanwhile; writes then are
    /// ignored, as are writes while locked); a reload takes the values that have arrived. Time
    /// passes one tick per pause.
    struct Model {
        now: u32,
        unlocked: bool,
        started: bool,
        pr: u8,
        rlr: u16,
        pr_pending: Option<(u8, u32)>,
        rlr_pending: Option<(u16, u32)>,
        /// (prescaler, reload) of every counter reload.
        reloads: Vec<(u8, u16)>,
    }

    const LATENCY: u32 = 5;

    impl Model {
        fn new() -> Self {
            // Reset values: PR = 0 (/4), RLR = 0xFFF.
            Model {
                now: 0,
                unlocked: false,
                started: false,
                pr: 0,
                rlr: 0xFFF,
                pr_pending: None,
                rlr_pending: None,
                reloads: Vec::new(),
            }
        }
        fn settle(&mut self) {
            if let Some((v, due)) = self.pr_pending {
                if self.now >= due {
                    self.pr = v;
                    self.pr_pending = None;
                }
            }
            if let Some((v, due)) = self.rlr_pending {
                if self.now >= due {
                    self.rlr = v;
                    self.rlr_pending = None;
                }
            }
        }
    }

    impl IwdgRegs for Model {
        fn key(&mut self, key: u16) {
            self.settle();
            self.unlocked = key == key::UNLOCK;
            match key {
                key::START => {
                    self.started = true;
                    self.reloads.push((self.pr, self.rlr));
                }
                key::RELOAD => self.reloads.push((self.pr, self.rlr)),
                _ => {}
            }
        }
        fn prescaler(&mut self, pr: u8) {
            self.settle();
            if self.unlocked && self.pr_pending.is_none() {
                self.pr_pending = Some((pr, self.now + LATENCY));
            }
        }
        fn reload(&mut self, rlr: u16) {
            self.settle();
            if self.unlocked && self.rlr_pending.is_none() {
                self.rlr_pending = Some((rlr, self.now + LATENCY));
            }
        }
        fn status(&mut self) -> u32 {
            self.settle();
            let mut sr = 0;
            if self.pr_pending.is_some() {
                sr |= SR_PVU;
            }
            if self.rlr_pending.is_some() {
                sr |= SR_RVU;
            }
            sr
        }
        fn pause(&mut self) {
            self.now += 1;
        }
    }

    #[test]
    fn reload_values_by_hand() {
        // LSI 40 kHz / 64 = 625 Hz: 2 s = 1250 counts, RLR 1249; 0.5 s = 312.5 → 312, RLR 311.
        assert_eq!(reload(BOOT_TIMEOUT_MS), 1249);
        assert_eq!(reload(RUN_TIMEOUT_MS), 311);
        assert_eq!(reload(100_000), 0xFFF);
        // Below one count (1.6 ms): the shortest timeout, RLR 0, not an underflow.
        assert_eq!(reload(0), 0);
        assert_eq!(reload(1), 0);
        assert_eq!(reload(2), 0);
    }

    #[test]
    fn only_feed_feeds() {
        assert!(Verdict::Feed.feed());
        assert!(!Verdict::StormStarted.feed());
        assert!(!Verdict::Starve.feed());
    }

    #[test]
    fn the_boot_timeout_is_in_force_after_start() {
        let w = Iwdg::start(Model::new());
        let m = w.regs();
        assert!(m.started);
        // The last reload used the values written, not the reset ones (PR /4, RLR 0xFFF:
        // 410 ms, shorter than the gyros' settling time).
        assert_eq!(m.reloads.last(), Some(&(PR_DIV64, reload(BOOT_TIMEOUT_MS))));
        assert_eq!(w.update_timeouts, 0);
    }

    #[test]
    fn the_run_timeout_is_in_force_from_the_first_feed() {
        let mut w = Iwdg::start(Model::new());
        w.feed();
        assert_eq!(w.regs().reloads.last(), Some(&(PR_DIV64, reload(RUN_TIMEOUT_MS))));
        for _ in 0..3 {
            w.feed();
            assert_eq!(w.regs().reloads.last(), Some(&(PR_DIV64, reload(RUN_TIMEOUT_MS))));
        }
        // Every write was accepted (none during an update), every wait ended in time.
        assert_eq!(w.update_timeouts, 0);
        assert!(!w.regs().unlocked, "left unlocked");
    }

    #[test]
    fn an_update_that_never_ends_is_counted_not_waited_for_forever() {
        struct Stuck(u32);
        impl IwdgRegs for Stuck {
            fn key(&mut self, _: u16) {}
            fn prescaler(&mut self, _: u8) {}
            fn reload(&mut self, _: u16) {}
            fn status(&mut self) -> u32 {
                self.0 += 1;
                SR_RVU
            }
            fn pause(&mut self) {}
        }
        let mut w = Iwdg::start(Stuck(0));
        w.feed();
        assert_eq!(w.update_timeouts, 4);
        assert_eq!(w.regs().0, 4 * UPDATE_POLLS);
    }

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
