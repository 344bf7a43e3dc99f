//! Sensor conditioning: raw sensor triplets (sensor axes, SI units) to body-frame samples for
//! the filters.
//!
//! Stages, in order:
//! - gyroscope (rad/s): axis map → subtract the static bias [`ConditioningSettings::gyro_offset`]
//!   (body FRD);
//! - accelerometer (m/s²): [`AccelCalibration`] in the sensor's own axes (it is fitted on raw
//!   data) → axis map → lever-arm compensation using the conditioned gyro less the estimator's
//!   current bias estimate (the true rate: the iNEMO's gyro biases of up to 3.4 °/s would
//!   otherwise add a constant centripetal term, 1.6·10⁻⁴ g or 0.01° of tilt with the Seahog's
//!   0.36 m arm);
//! - magnetometer (µT): axis map only.

use crate::accel_calibration::AccelCalibration;
use crate::axis_map::AxisMap;
use crate::lever_arm::{LeverArm, LeverArmCompensator};
use crate::Vec3;

/// Conditioning settings.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConditioningSettings {
    /// Gyroscope sensor axes → body FRD.
    pub gyro_axes: AxisMap,
    /// Accelerometer sensor axes → body FRD.
    pub accel_axes: AxisMap,
    /// Magnetometer sensor axes → body FRD.
    pub mag_axes: AxisMap,
    /// Static gyro bias, rad/s, body FRD; subtracted after remapping.
    pub gyro_offset: Vec3,
    /// Accelerometer calibration, applied in the accelerometer's own axes (before remapping),
    /// m/s² in and out.
    pub accel_calibration: AccelCalibration,
    /// Lever arm of the IMU from the rotation centre (body FRD).
    pub lever_arm: LeverArm,
}

impl Default for ConditioningSettings {
    /// Identity axis maps, zero gyro offset, identity accelerometer calibration and the Seahog
    /// lever arm ([`LeverArm::default`]: r = (0.29725, −0.196, 0.0803) m, centripetal term only).
    fn default() -> Self {
        ConditioningSettings {
            gyro_axes: AxisMap::IDENTITY,
            accel_axes: AxisMap::IDENTITY,
            mag_axes: AxisMap::IDENTITY,
            gyro_offset: Vec3::ZERO,
            accel_calibration: AccelCalibration::IDENTITY,
            lever_arm: LeverArm::default(),
        }
    }
}

/// The conditioning pipeline: [`ConditioningSettings`] plus the lever-arm compensator's state
/// (previous gyro sample, filtered angular acceleration).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conditioner {
    settings: ConditioningSettings,
    lever: LeverArmCompensator,
}

impl Default for Conditioner {
    /// A conditioner with [`ConditioningSettings::default`].
    fn default() -> Self {
        Conditioner::new(ConditioningSettings::default())
    }
}

impl Conditioner {
    /// A conditioner with `settings` and no history.
    pub fn new(settings: ConditioningSettings) -> Self {
        Conditioner { settings, lever: LeverArmCompensator::new(settings.lever_arm) }
    }

    /// The settings in use.
    pub fn settings(&self) -> &ConditioningSettings {
        &self.settings
    }

    /// Replace the settings and forget the lever-arm history.
    pub fn set_settings(&mut self, settings: ConditioningSettings) {
        *self = Conditioner::new(settings);
    }

    /// Condition one gyro/accelerometer pair.
    ///
    /// `dt`: time since the previous call, s. `gyro_raw`: rad/s, gyro sensor axes.
    /// `accel_raw`: specific force, m/s², accelerometer sensor axes.
    ///
    /// `rate_bias`: the estimator's current gyro bias estimate, rad/s, body FRD
    /// ([`AttitudeFilter::gyro_bias`](crate::AttitudeFilter::gyro_bias)); the lever-arm terms use
    /// `gyro_body − rate_bias`, the estimated true rate. It does not change `gyro_body`: the
    /// estimator subtracts its own bias. A non-finite `rate_bias` counts as zero.
    ///
    /// Returns `(gyro_body, accel_body)`: rate less the static offset, rad/s, body FRD; and
    /// specific force at the rotation centre, m/s², body FRD. Non-finite input propagates to the
    /// output of the same sensor (the lever-arm state is left untouched); an invalid `dt` skips
    /// only the lever-arm compensation.
    pub fn condition(
        &mut self,
        dt: f32,
        gyro_raw: Vec3,
        accel_raw: Vec3,
        rate_bias: Vec3,
    ) -> (Vec3, Vec3) {
        let s = &self.settings;
        let gyro = s.gyro_axes.apply(gyro_raw) - s.gyro_offset;
        let accel = s.accel_axes.apply(s.accel_calibration.apply(accel_raw));
        let bias = if rate_bias.is_finite() { rate_bias } else { Vec3::ZERO };
        let accel = self.lever.compensate(accel, gyro - bias, dt);
        (gyro, accel)
    }

    /// Remap a magnetometer reading, µT, magnetometer sensor axes → µT, body FRD.
    pub fn condition_mag(&self, raw: Vec3) -> Vec3 {
        self.settings.mag_axes.apply(raw)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GRAVITY;

    fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
        (a - b).max_abs() <= tol
    }

    /// Settings where every stage changes the result and the order matters.
    fn example_settings() -> ConditioningSettings {
        // body = [raw.y, raw.x, −raw.z]
        let swap_flip = AxisMap::new([1, 0, 2], [1, 1, -1]).unwrap();
        ConditioningSettings {
            gyro_axes: swap_flip,
            accel_axes: swap_flip,
            // body = [raw.x, −raw.z, raw.y]
            mag_axes: AxisMap::new([0, 2, 1], [1, -1, 1]).unwrap(),
            gyro_offset: Vec3::new(0.1, -0.2, 0.5),
            // Sensor x scaled by 1.1, y by 0.9; offsets +0.1 g on x, −0.05 g on z.
            accel_calibration: AccelCalibration {
                x: [[1.1, 0.0, 0.0], [0.0, 0.9, 0.0], [0.0, 0.0, 1.0], [0.1, 0.0, -0.05]],
            },
            lever_arm: LeverArm {
                r: Vec3::new(0.3, 0.0, 0.0),
                centripetal: true,
                tangential: false,
                tangential_time_constant: 0.05,
            },
        }
    }

    #[test]
    fn every_stage_in_order_hand_computed() {
        let mut c = Conditioner::new(example_settings());
        // Gyro: raw (−0.2, 0.1, −1.5) → remap [y, x, −z] = (0.1, −0.2, 1.5)
        //       → minus offset (0.1, −0.2, 0.5) = (0, 0, 1) rad/s.
        let gyro_raw = Vec3::new(-0.2, 0.1, -1.5);
        // Accel: raw (0.5, 1.0, 9.0) m/s² → calibration in sensor axes
        //        (1.1·0.5 + 0.1 g, 0.9·1.0, 9.0 − 0.05 g) = (1.530665, 0.9, 8.5096675)
        //        → remap [y, x, −z] = (0.9, 1.530665, −8.5096675)
        //        → lever arm: ω × (ω × r) = (−0.3, 0, 0) removed: (1.2, 1.530665, −8.5096675).
        let accel_raw = Vec3::new(0.5, 1.0, 9.0);
        for _ in 0..3 {
            let (g, a) = c.condition(0.01, gyro_raw, accel_raw, Vec3::ZERO);
            assert!(close(g, Vec3::new(0.0, 0.0, 1.0), 1e-6), "{g:?}");
            assert!(close(a, Vec3::new(1.2, 1.530_665, -8.509_668), 1e-5), "{a:?}");
        }
        // Cross-check the calibration constants used above.
        assert!((0.55 + 0.1 * GRAVITY - 1.530_665).abs() < 1e-6);
        assert!((9.0 - 0.05 * GRAVITY - 8.509_668).abs() < 1e-6);
        // Mag: raw (20, −5, 40) µT → [x, −z, y] = (20, −40, −5) µT.
        assert_eq!(c.condition_mag(Vec3::new(20.0, -5.0, 40.0)), Vec3::new(20.0, -40.0, -5.0));
    }

    #[test]
    fn stage_order_matters() {
        // Calibration after remapping, or lever arm on the uncorrected gyro, would give other
        // numbers: check the pipeline against a manual composition in the documented order and
        // against the wrong orders.
        let s = example_settings();
        let gyro_raw = Vec3::new(0.3, -0.4, 0.2);
        let accel_raw = Vec3::new(-1.0, 2.0, -9.5);
        let mut c = Conditioner::new(s);
        let (g, a) = c.condition(0.01, gyro_raw, accel_raw, Vec3::ZERO);

        let g_ref = s.gyro_axes.apply(gyro_raw) - s.gyro_offset;
        let r = s.lever_arm.r;
        let right = s.accel_axes.apply(s.accel_calibration.apply(accel_raw));
        let a_ref = right - g_ref.cross(g_ref.cross(r));
        assert_eq!(g, g_ref);
        assert!(close(a, a_ref, 1e-5));

        let wrong_cal_order = s.accel_calibration.apply(s.accel_axes.apply(accel_raw));
        let wrong = wrong_cal_order - g_ref.cross(g_ref.cross(r));
        assert!(!close(a, wrong, 1e-2));
        let g_raw_mapped = s.gyro_axes.apply(gyro_raw);
        let wrong = right - g_raw_mapped.cross(g_raw_mapped.cross(r));
        assert!(!close(a, wrong, 1e-2));
    }

    #[test]
    fn identity_settings_and_zero_lever_arm_pass_through() {
        let s = ConditioningSettings {
            lever_arm: LeverArm { tangential: true, ..LeverArm::NONE },
            ..ConditioningSettings::default()
        };
        let mut c = Conditioner::new(s);
        for k in 0..20 {
            let t = k as f32;
            let gyro = Vec3::new(0.1 * t, -0.3, 1.0 - 0.05 * t);
            let accel = Vec3::new(0.2, -0.1 * t, -GRAVITY);
            let (g, a) = c.condition(0.01, gyro, accel, Vec3::ZERO);
            assert_eq!(g, gyro);
            assert_eq!(a, accel);
        }
        let m = Vec3::new(21.0, -3.5, 42.0);
        assert_eq!(c.condition_mag(m), m);
    }

    #[test]
    fn default_is_identity_with_seahog_lever_arm() {
        let d = ConditioningSettings::default();
        assert_eq!(d.gyro_axes, AxisMap::IDENTITY);
        assert_eq!(d.accel_axes, AxisMap::IDENTITY);
        assert_eq!(d.mag_axes, AxisMap::IDENTITY);
        assert_eq!(d.gyro_offset, Vec3::ZERO);
        assert_eq!(d.accel_calibration, AccelCalibration::IDENTITY);
        assert_eq!(d.lever_arm, LeverArm::default());
        assert_eq!(d.lever_arm.r, Vec3::new(0.297_25, -0.196, 0.0803));
        // Still board: no rotation, so nothing changes even with the lever arm.
        let mut c = Conditioner::default();
        let still = Vec3::new(0.0, 0.0, -GRAVITY);
        assert_eq!(c.condition(0.01, Vec3::ZERO, still, Vec3::ZERO), (Vec3::ZERO, still));
    }

    /// The lever-arm terms use the estimated true rate: a still board whose gyros read only
    /// their bias (the iNEMO's 1.6, 3.4, −0.4 °/s) sees no centripetal acceleration once the
    /// estimator's bias is given; without it, `ω_b × (ω_b × r)` = 4.6·10⁻³ m/s² would be removed
    /// from gravity. A non-finite bias counts as zero.
    #[test]
    fn the_lever_arm_uses_the_rate_less_the_estimated_bias() {
        let deg = core::f32::consts::PI / 180.0;
        let bias = Vec3::new(1.619 * deg, 3.44 * deg, -0.4 * deg);
        let still = Vec3::new(0.0, 0.0, -GRAVITY);
        let mut c = Conditioner::default();
        for _ in 0..3 {
            assert_eq!(c.condition(0.02, bias, still, bias), (bias, still));
        }
        let r = ConditioningSettings::default().lever_arm.r;
        let wrong = still - bias.cross(bias.cross(r));
        assert!((wrong - still).norm() > 1e-3, "{wrong:?}");
        let mut c = Conditioner::default();
        let (_, a) = c.condition(0.02, bias, still, Vec3::ZERO);
        assert!(close(a, wrong, 1e-7), "{a:?}");
        let nan = Vec3::new(f32::NAN, 0.0, 0.0);
        let mut c = Conditioner::default();
        let (_, a) = c.condition(0.02, bias, still, nan);
        assert!(close(a, wrong, 1e-7), "{a:?}");
    }

    #[test]
    fn bad_input_stays_contained() {
        let mut c = Conditioner::new(example_settings());
        let gyro_raw = Vec3::new(-0.2, 0.1, -1.5);
        let accel_raw = Vec3::new(0.5, 1.0, 9.0);
        let nan = Vec3::new(f32::NAN, 0.0, 0.0);
        let (g, a) = c.condition(0.01, nan, accel_raw, Vec3::ZERO);
        assert!(!g.is_finite());
        assert!(a.is_finite(), "finite accel must stay finite: {a:?}");
        let (g, a) = c.condition(-1.0, gyro_raw, accel_raw, Vec3::ZERO);
        assert!(g.is_finite() && a.is_finite());
        // After bad samples the pipeline still gives the hand values.
        let (_, a) = c.condition(0.01, gyro_raw, accel_raw, Vec3::ZERO);
        assert!(close(a, Vec3::new(1.2, 1.530_665, -8.509_668), 1e-5), "{a:?}");
        // set_settings replaces everything.
        c.set_settings(ConditioningSettings::default());
        assert_eq!(c.settings(), &ConditioningSettings::default());
    }
}
