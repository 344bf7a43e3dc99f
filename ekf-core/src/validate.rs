//! Input checks shared by every filter: NaN, ±inf, absurd values and time gaps are caught
//! here, flagged, and never reach a filter's state.

use crate::{fcmp, settings::LimitSettings, Flags, ImuSample, Vec3, GRAVITY};

/// A sample after the plausibility checks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checked {
    /// Time over which to integrate the gyro, s (`dt` capped at the gap limit).
    pub dt_rate: f32,
    /// Time over which the uncertainty grows, s (the whole `dt`, capped at one hour).
    pub dt_cov: f32,
    /// The gyro sample, rad/s, when usable.
    pub gyro: Option<Vec3>,
    /// The accelerometer sample in g and its norm in g, when usable.
    pub accel_g: Option<(Vec3, f32)>,
    /// What the checks found.
    pub flags: Flags,
}

/// Check one sample against `limits`. Returns `None` when `dt` is unusable (non-finite or
/// not positive): such a sample must be ignored entirely.
pub fn check(s: &ImuSample, limits: &LimitSettings) -> Option<Checked> {
    // (Comparisons through `fcmp`: exact, and integer instructions on the Cortex-M3.)
    if !fcmp::in_pos_range(s.dt, f32::MAX) {
        return None;
    }
    let mut flags = Flags::NONE;
    let mut dt_rate = s.dt;
    if fcmp::gt(s.dt, limits.max_gap_s) {
        flags |= Flags::TIME_GAP;
        dt_rate = limits.max_gap_s;
    }
    let dt_cov = fcmp::min(s.dt, 3600.0);

    let gyro_max = s.gyro.max_abs();
    let gyro = if s.gyro.is_finite() && fcmp::le(gyro_max, limits.gyro_abs_max) {
        if fcmp::ge(gyro_max, limits.gyro_range) {
            flags |= Flags::GYRO_SATURATED;
        }
        Some(s.gyro)
    } else {
        flags |= Flags::GYRO_INVALID;
        None
    };

    let a = s.accel * (1.0 / GRAVITY);
    let n = if a.is_finite() { a.norm() } else { f32::NAN };
    let accel_g = if n.is_finite()
        && fcmp::ge(n, limits.accel_min_g)
        && fcmp::le(n, limits.accel_abs_max_g)
    {
        Some((a, n))
    } else {
        flags |= Flags::ACCEL_INVALID;
        None
    };
    Some(Checked { dt_rate, dt_cov, gyro, accel_g, flags })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(dt: f32, g: Vec3, a: Vec3) -> ImuSample {
        ImuSample::new(dt, g, a)
    }

    #[test]
    fn rejects_what_is_not_plausible() {
        let l = LimitSettings::default();
        let level = Vec3::new(0.0, 0.0, -GRAVITY);
        assert!(check(&sample(f32::NAN, Vec3::ZERO, level), &l).is_none());
        assert!(check(&sample(0.0, Vec3::ZERO, level), &l).is_none());
        assert!(check(&sample(-0.02, Vec3::ZERO, level), &l).is_none());

        let c = check(&sample(0.02, Vec3::new(f32::NAN, 0.0, 0.0), level), &l).unwrap();
        assert!(c.gyro.is_none() && c.flags.contains(Flags::GYRO_INVALID));
        assert!(c.accel_g.is_some());
        let c = check(&sample(0.02, Vec3::new(0.0, 100.0, 0.0), level), &l).unwrap();
        assert!(c.gyro.is_none());
        let c = check(&sample(0.02, Vec3::new(0.0, 5.3, 0.0), level), &l).unwrap();
        assert!(c.gyro.is_some() && c.flags.contains(Flags::GYRO_SATURATED));

        for a in [
            Vec3::new(f32::INFINITY, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -20.0 * GRAVITY),
            Vec3::new(f32::NAN, f32::NAN, f32::NAN),
        ] {
            let c = check(&sample(0.02, Vec3::ZERO, a), &l).unwrap();
            assert!(c.accel_g.is_none() && c.flags.contains(Flags::ACCEL_INVALID), "{a:?}");
        }
        let c = check(&sample(0.02, Vec3::ZERO, level), &l).unwrap();
        let (a, n) = c.accel_g.unwrap();
        assert!((n - 1.0).abs() < 1e-6 && (a.z + 1.0).abs() < 1e-6);
        assert_eq!(c.flags, Flags::NONE);
    }

    #[test]
    fn long_gap_caps_the_integration_time_only() {
        let l = LimitSettings::default();
        let c = check(&sample(3.0, Vec3::ZERO, Vec3::new(0.0, 0.0, -GRAVITY)), &l).unwrap();
        assert!(c.flags.contains(Flags::TIME_GAP));
        assert_eq!(c.dt_rate, l.max_gap_s);
        assert_eq!(c.dt_cov, 3.0);
    }
}
