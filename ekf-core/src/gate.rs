//! The accelerometer gate: decides which samples may correct tilt.
//!
//! Policy (see `docs/filter.md`):
//! 1. **Magnitude**: skip when `| |a|/g − 1 |` exceeds the tolerance (the source's gate).
//! 2. **Jump**: skip when the sample moved by more than `jump_g` since the previous one — a
//!    knock that keeps `|a|` near 1 g still jolts the reading.
//! 3. **Hold-off**: after any rejection keep skipping for `holdoff_s` (knocks ring).
//! 4. **Innovation** (filters with an innovation covariance): skip when the normalised
//!    innovation squared exceeds `innovation_chi2`.
//! 5. **Long rejections**: the filter keeps propagating with the gyros; after `long_reject_s`
//!    of continuous rejection `ACCEL_REJECT_LONG` is raised. Once rejections have lasted
//!    `reacquire_s`, the innovation gate is bypassed for samples that pass 1–3, so a filter
//!    whose tilt has drifted (or was wrong) can reacquire instead of locking itself out.

use crate::{fcmp, settings::GateSettings, Flags, Vec3};

/// `innovation_chi2` at or above this turns the innovation test off (the registry's largest
/// value; the default).
pub const INNOVATION_GATE_OFF: f32 = 1e6;

/// Gate state: previous sample, hold-off and rejection timers.
#[derive(Clone, Copy, Debug)]
pub struct AccelGate {
    settings: GateSettings,
    /// `jump_g²`.
    jump_sq: f32,
    prev: Option<Vec3>,
    holdoff_left: f32,
    rejected_for: f32,
}

/// Result of the gate's first stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PreCheck {
    /// Proceed to the innovation check (or use the sample). `bypass_innovation` is true when
    /// rejections have lasted long enough to reacquire.
    Pass {
        /// Skip the innovation gate for this sample.
        bypass_innovation: bool,
    },
    /// Rejected, with the flags saying why.
    Reject(Flags),
}

impl AccelGate {
    /// A fresh gate.
    pub fn new(settings: GateSettings) -> Self {
        let jump_sq = settings.jump_g * settings.jump_g;
        AccelGate { settings, jump_sq, prev: None, holdoff_left: 0.0, rejected_for: 0.0 }
    }

    /// Forget the previous sample and timers.
    pub fn reset(&mut self) {
        *self = AccelGate::new(self.settings);
    }

    /// Seconds of continuous rejection so far.
    pub fn rejected_for(&self) -> f32 {
        self.rejected_for
    }

    /// Magnitude, jump and hold-off checks for a valid sample `a_g` (g, body) of norm `norm_g`
    /// arriving `dt` s after the previous one. A jump is a change larger than
    /// `√(jump_g² + allowance)` (`allowance` in g²: what the current motion explains).
    pub fn pre_check(&mut self, dt: f32, a_g: Vec3, norm_g: f32, allowance: f32) -> PreCheck {
        let j = self.settings.jump_g;
        let j2 = self.jump_sq + allowance;
        let jump = self
            .prev
            .map(|p| {
                let d = a_g - p;
                // |d|² > j2 ≥ j² needs some |dᵢ| > j/2 (else |d|² ≤ 3j²/4): skip the squares
                // then.
                let h = crate::mathf::half(j);
                !(fcmp::abs_le(d.x, h) && fcmp::abs_le(d.y, h) && fcmp::abs_le(d.z, h))
                    && fcmp::gt(d.norm_sq(), j2)
            })
            .unwrap_or(false);
        self.prev = Some(a_g);
        let mut why = Flags::NONE;
        if fcmp::gt(crate::mathf::abs(norm_g - 1.0), self.settings.norm_tolerance) {
            why |= Flags::ACCEL_GATED;
        }
        if jump {
            why |= Flags::ACCEL_KNOCK;
        }
        if why != Flags::NONE {
            return PreCheck::Reject(self.rejected(dt, why));
        }
        if fcmp::gt(self.holdoff_left, 0.0) {
            self.holdoff_left -= dt;
            self.rejected_for += dt;
            return PreCheck::Reject(self.long(Flags::ACCEL_KNOCK));
        }
        PreCheck::Pass { bypass_innovation: fcmp::ge(self.rejected_for, self.settings.reacquire_s) }
    }

    /// Innovation check after a `Pass`: `nis` is the normalised innovation squared. Returns
    /// `Ok(flags)` when the sample may be used (`REACQUIRE` set when the gate was bypassed),
    /// `Err(flags)` when rejected.
    pub fn innovation(&mut self, dt: f32, nis: f32, bypass: bool) -> Result<Flags, Flags> {
        if bypass {
            self.accepted();
            return Ok(Flags::REACQUIRE);
        }
        let off = fcmp::ge(self.settings.innovation_chi2, INNOVATION_GATE_OFF);
        if off || (nis.is_finite() && fcmp::le(nis, self.settings.innovation_chi2)) {
            self.accepted();
            Ok(Flags::NONE)
        } else {
            Err(self.rejected(dt, Flags::ACCEL_KNOCK))
        }
    }

    /// Record that the sample was used.
    pub fn accepted(&mut self) {
        self.rejected_for = 0.0;
    }

    fn rejected(&mut self, dt: f32, why: Flags) -> Flags {
        self.holdoff_left = self.settings.holdoff_s;
        self.rejected_for += dt;
        self.long(why)
    }

    fn long(&self, why: Flags) -> Flags {
        if self.rejected_for > self.settings.long_reject_s {
            why | Flags::ACCEL_REJECT_LONG
        } else {
            why
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f32 = 0.02;
    fn level() -> Vec3 {
        Vec3::new(0.0, 0.0, -1.0)
    }

    #[test]
    fn the_innovation_test_is_off_by_default() {
        let mut g = AccelGate::new(GateSettings::default());
        assert_eq!(g.innovation(DT, 1e9, false), Ok(Flags::NONE));
        let mut g = AccelGate::new(GateSettings::SOURCE);
        assert!(g.innovation(DT, 17.0, false).is_err());
        assert_eq!(g.innovation(DT, 15.0, false), Ok(Flags::NONE));
    }

    #[test]
    fn magnitude_gate_at_five_percent() {
        let mut g = AccelGate::new(GateSettings { jump_g: 1.0, ..GateSettings::SOURCE });
        assert!(matches!(g.pre_check(DT, level(), 1.0, 0.0), PreCheck::Pass { .. }));
        assert!(matches!(g.pre_check(DT, level() * 1.04, 1.04, 0.0), PreCheck::Pass { .. }));
        match g.pre_check(DT, level() * 1.06, 1.06, 0.0) {
            PreCheck::Reject(f) => assert!(f.contains(Flags::ACCEL_GATED)),
            p => panic!("{p:?}"),
        }
        match g.pre_check(DT, level() * 0.94, 0.94, 0.0) {
            PreCheck::Reject(f) => assert!(f.contains(Flags::ACCEL_GATED)),
            p => panic!("{p:?}"),
        }
    }

    #[test]
    fn a_jump_that_keeps_the_norm_is_a_knock_and_holds_off() {
        let mut g = AccelGate::new(GateSettings::default());
        assert!(matches!(g.pre_check(DT, level(), 1.0, 0.0), PreCheck::Pass { .. }));
        // Lateral tap: the norm stays within 1 %, the direction jumps by ~6°.
        let tap = Vec3::new(0.1, 0.0, -0.995);
        match g.pre_check(DT, tap, tap.norm(), 0.0) {
            PreCheck::Reject(f) => assert!(f.contains(Flags::ACCEL_KNOCK)),
            p => panic!("{p:?}"),
        }
        // Back to level: that is a jump too, then the hold-off runs for 0.1 s.
        assert!(matches!(g.pre_check(DT, level(), 1.0, 0.0), PreCheck::Reject(_)));
        let mut passed_at = None;
        for k in 0..20 {
            if let PreCheck::Pass { .. } = g.pre_check(DT, level(), 1.0, 0.0) {
                passed_at = Some(k);
                break;
            }
        }
        // 0.1 s of hold-off at 50 Hz: five samples rejected, the sixth passes.
        assert_eq!(passed_at, Some(5));
    }

    #[test]
    fn innovation_lockout_is_bypassed_after_reacquire_time_and_long_flag_is_raised() {
        let s = GateSettings { holdoff_s: 0.0, ..GateSettings::SOURCE };
        let mut g = AccelGate::new(s);
        let mut t = 0.0;
        let mut saw_long = false;
        loop {
            t += DT;
            match g.pre_check(DT, level(), 1.0, 0.0) {
                PreCheck::Pass { bypass_innovation } => {
                    match g.innovation(DT, 100.0, bypass_innovation) {
                        Ok(f) => {
                            assert!(f.contains(Flags::REACQUIRE));
                            assert!(t >= s.reacquire_s && t < s.reacquire_s + 0.05);
                            break;
                        }
                        Err(f) => saw_long |= f.contains(Flags::ACCEL_REJECT_LONG),
                    }
                }
                PreCheck::Reject(_) => panic!("only the innovation should reject"),
            }
            assert!(t < 5.0);
        }
        assert!(!saw_long);
        assert_eq!(g.rejected_for(), 0.0);
        // A long magnitude rejection raises the long flag after long_reject_s.
        let mut flags = Flags::NONE;
        for _ in 0..(s.long_reject_s / DT) as usize + 2 {
            if let PreCheck::Reject(f) = g.pre_check(DT, level() * 1.2, 1.2, 0.0) {
                flags = f;
            }
        }
        assert!(flags.contains(Flags::ACCEL_REJECT_LONG | Flags::ACCEL_GATED));
    }

    /// A jump along any single axis is a knock (the skip of the squares, when every axis moved
    /// less than half the limit, must not hide one axis's jump behind the others' stillness).
    #[test]
    fn a_jump_along_any_one_axis_is_a_knock() {
        for axis in 0..3 {
            let mut g = AccelGate::new(GateSettings::default());
            let base = Vec3::new(0.0, 0.0, -1.0);
            assert!(matches!(g.pre_check(DT, base, 1.0, 0.0), PreCheck::Pass { .. }));
            let mut d = [0.0; 3];
            d[axis] = 0.2; // four times the 0.05 g jump limit
            let a = base + Vec3::from_array(d);
            match g.pre_check(DT, a, 1.0, 0.0) {
                PreCheck::Reject(f) => assert!(f.contains(Flags::ACCEL_KNOCK), "axis {axis}"),
                p => panic!("axis {axis}: {p:?}"),
            }
        }
    }

    /// The motion allowance widens the jump limit to `√(jump_g² + allowance)`: a 0.1 g change
    /// is a knock still, and passes with an allowance of 0.01 g² (limit 0.112 g) — the EKF's
    /// swinging pendulum is motion, not knocks.
    #[test]
    fn the_motion_allowance_widens_the_jump_limit() {
        let change = Vec3::new(0.1, 0.0, -1.0);
        for (allowance, knock) in [(0.0, true), (0.01, false), (0.005, true)] {
            let mut g = AccelGate::new(GateSettings::default());
            assert!(matches!(
                g.pre_check(DT, Vec3::new(0.0, 0.0, -1.0), 1.0, 0.0),
                PreCheck::Pass { .. }
            ));
            let r = g.pre_check(DT, change, 1.0, allowance);
            assert_eq!(matches!(r, PreCheck::Reject(_)), knock, "allowance {allowance}: {r:?}");
        }
    }

    /// `rejected_for` counts the seconds of continuous rejection (the EKF raises its motion
    /// level from rejected samples only after `KNOCK_MAX_S` of them) and an accepted sample
    /// ends it; `reset` forgets the previous sample, so the first sample after it is no jump.
    #[test]
    fn rejection_time_and_reset() {
        let mut g = AccelGate::new(GateSettings::default());
        assert!(matches!(
            g.pre_check(DT, Vec3::new(0.0, 0.0, -1.0), 1.0, 0.0),
            PreCheck::Pass { .. }
        ));
        for k in 1..=5 {
            // Alternating 0.3 g taps: every one a knock.
            let a = Vec3::new(if k % 2 == 1 { 0.3 } else { -0.3 }, 0.0, -0.95);
            assert!(matches!(g.pre_check(DT, a, 1.0, 0.0), PreCheck::Reject(_)));
            assert!((g.rejected_for() - k as f32 * DT).abs() < 1e-6, "{}", g.rejected_for());
        }
        g.accepted();
        assert_eq!(g.rejected_for(), 0.0);
        // After a reset a sample far from the last one is not a jump.
        g.reset();
        assert!(matches!(
            g.pre_check(DT, Vec3::new(0.5, 0.0, -0.866), 1.0, 0.0),
            PreCheck::Pass { .. }
        ));
    }
}
