//! Rate-gyro conversion: mean counts to angular rate.

use ekf_core::{mathf, Vec3};

use super::averager::AdcMean;
use super::frame::Rails;
use super::scale::AdcScale;
use crate::board;

/// Settings of the gyro conversion. The defaults are the board's ([`crate::board`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroConversion {
    /// ADC transfer function. Default: 3.3 V at 4095 counts.
    pub scale: AdcScale,
    /// Sensitivity of the x, y, z outputs, V per °/s. Default: 3.33 mV/dps on x and y
    /// (LPR430AL, 4× amplified outputs), 3.752 mV/dps on z (LY330ALH).
    pub sensitivity_v_per_dps: [f32; 3],
    /// Full scale of the gyros, °/s: a rate whose magnitude reaches it is flagged saturated.
    /// Default ±300 °/s.
    pub range_dps: f32,
}

impl Default for GyroConversion {
    fn default() -> Self {
        GyroConversion {
            scale: AdcScale::default(),
            sensitivity_v_per_dps: [
                board::LPR430AL_SENSITIVITY_V_PER_DPS,
                board::LPR430AL_SENSITIVITY_V_PER_DPS,
                board::LY330ALH_SENSITIVITY_V_PER_DPS,
            ],
            range_dps: board::GYRO_RANGE_DPS,
        }
    }
}

/// Angular rate from the analog gyros, in the SENSORS' axes: x = LPR430AL X output,
/// y = LPR430AL Y output, z = LY330ALH Z output, each positive in its datasheet's sense. The
/// map to the body frame (FRD) is `ekf-core`'s conditioning (axis map), applied later.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GyroReading {
    /// Angular rate per sensor axis, rad/s: (output − reference) / sensitivity.
    pub rate: [f32; 3],
    /// Per axis: a channel of the axis (its output or its reference) touched a rail, or the
    /// rate's magnitude is at or beyond the range (or not finite).
    pub axis_saturated: [bool; 3],
    /// Any axis saturated.
    pub saturated: bool,
}

impl GyroReading {
    /// The rate as an `ekf_core` vector (sensor axes, rad/s).
    #[inline]
    pub fn rate_vec3(&self) -> Vec3 {
        Vec3::new(self.rate[0], self.rate[1], self.rate[2])
    }
}

impl GyroConversion {
    /// Volts at the ADC pin for `counts` (see [`AdcScale::counts_to_volts`]).
    #[inline]
    pub fn counts_to_volts(&self, counts: f32) -> f32 {
        self.scale.counts_to_volts(counts)
    }

    /// Rate of one axis, °/s, from the output and reference mean counts.
    #[inline]
    fn rate_dps(scale: &AdcScale, sens: f32, output: f32, reference: f32) -> f32 {
        // The difference is taken in counts first: exact for any realistic mean.
        scale.counts_to_volts(output - reference) / sens
    }

    /// Angular rates of an averaged scan, rad/s in the sensors' axes, with saturation flags.
    pub fn rates(&self, mean: &AdcMean) -> GyroReading {
        // Volts with the VDDA the scan's VREFINT measured (`AdcScale::for_mean`).
        let scale = self.scale.for_mean(mean);
        let sens = self.sensitivity_v_per_dps;
        let dps = [
            Self::rate_dps(&scale, sens[0], mean.gyro_x, mean.gyro_xy_ref),
            Self::rate_dps(&scale, sens[1], mean.gyro_y, mean.gyro_xy_ref),
            Self::rate_dps(&scale, sens[2], mean.gyro_z, mean.gyro_z_ref),
        ];
        let channels = [
            Rails::GYRO_X | Rails::GYRO_XY_REF,
            Rails::GYRO_Y | Rails::GYRO_XY_REF,
            Rails::GYRO_Z | Rails::GYRO_Z_REF,
        ];
        let mut reading = GyroReading::default();
        for i in 0..3 {
            reading.rate[i] = mathf::deg(dps[i]);
            // `!(a < b)` is also true for NaN.
            reading.axis_saturated[i] =
                mean.rails.intersects(channels[i]) || !(mathf::abs(dps[i]) < self.range_dps);
            reading.saturated |= reading.axis_saturated[i];
        }
        reading
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::adc::{AdcFrame, Averager};

    const DEG: f32 = core::f32::consts::PI / 180.0;

    /// A mean with the given volts on each channel (as fractional counts).
    fn mean_volts(x: f32, y: f32, xy_ref: f32, z: f32, z_ref: f32) -> AdcMean {
        let c = |v: f32| v * 4095.0 / 3.3;
        AdcMean {
            gyro_x: c(x),
            gyro_y: c(y),
            gyro_xy_ref: c(xy_ref),
            gyro_z: c(z),
            gyro_z_ref: c(z_ref),
            depth: 1000.0,
            samples: 1,
            ..AdcMean::default()
        }
    }

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn defaults_from_board() {
        let g = GyroConversion::default();
        assert_eq!(g.sensitivity_v_per_dps, [3.33e-3, 3.33e-3, 3.752e-3]);
        assert_eq!(g.range_dps, 300.0);
        assert_eq!(g.scale, AdcScale { vref_v: 3.3, full_scale_counts: 4095.0, vrefint_v: 1.20 });
        assert_eq!(g.counts_to_volts(4095.0), 3.3);
    }

    #[test]
    fn x_plus_0_333_v_is_100_dps() {
        let g = GyroConversion::default();
        let r = g.rates(&mean_volts(1.23 + 0.333, 1.23, 1.23, 1.5, 1.5));
        assert!(close(r.rate[0], 100.0 * DEG, 2e-6), "{}", r.rate[0] / DEG);
        assert!(close(r.rate[1], 0.0, 1e-9) && close(r.rate[2], 0.0, 1e-9));
        assert!(!r.saturated);
    }

    #[test]
    fn rates_are_corrected_for_the_measured_vdda() {
        // VDDA at 3.0 V (a regulator 10 % low): X turning at 100 °/s is 0.333 V above its
        // 1.23 V reference whatever VDDA is; in counts (of 3.0 V) that is 454.6 counts,
        // which the nominal 3.3 V would read as 110 °/s. VREFINT (1.20 V) reads 1638 counts.
        let c = |v: f32| v / 3.0 * 4095.0;
        let mean = AdcMean {
            gyro_x: c(1.23 + 0.333),
            gyro_y: c(1.23),
            gyro_xy_ref: c(1.23),
            gyro_z: c(1.5 - 0.3752),
            gyro_z_ref: c(1.5),
            vrefint: c(1.20),
            samples: 1,
            ..AdcMean::default()
        };
        let r = GyroConversion::default().rates(&mean);
        assert!(close(r.rate[0], 100.0 * DEG, 1e-4), "{}", r.rate[0] / DEG);
        assert!(close(r.rate[2], -100.0 * DEG, 1e-4), "{}", r.rate[2] / DEG);
    }

    #[test]
    fn z_uses_3_752_mv_per_dps_and_negative_rates() {
        let g = GyroConversion::default();
        // z: −0.3752 V → −100 °/s; y: −0.0333 V → −10 °/s.
        let r = g.rates(&mean_volts(1.23, 1.23 - 0.0333, 1.23, 1.5 - 0.3752, 1.5));
        assert!(close(r.rate[2], -100.0 * DEG, 2e-6), "{}", r.rate[2] / DEG);
        assert!(close(r.rate[1], -10.0 * DEG, 2e-6), "{}", r.rate[1] / DEG);
        assert!(!r.saturated);
    }

    #[test]
    fn integer_counts_by_hand() {
        // Out − ref = +100 counts = 100 · 3.3 / 4095 V = 80.586 mV:
        // x: 80.586 / 3.33 = 24.2002 °/s; z: 80.586 / 3.752 = 21.4782 °/s.
        let mut a = Averager::new();
        a.push(&AdcFrame::from_channels([1626, 1526, 1526, 1962, 1862, 500]));
        let r = GyroConversion::default().rates(&a.take().unwrap());
        assert!(close(r.rate[0], 24.200_02 * DEG, 1e-6));
        assert!(close(r.rate[1], 0.0, 0.0));
        assert!(close(r.rate[2], 21.478_2 * DEG, 1e-6));
    }

    #[test]
    fn saturation_at_range() {
        let g = GyroConversion::default();
        let v = |dps: f32| dps * 3.33e-3;
        let r = g.rates(&mean_volts(1.23 + v(299.5), 1.23 - v(299.5), 1.23, 1.5, 1.5));
        assert!(!r.saturated);
        let r = g.rates(&mean_volts(1.23 + v(300.5), 1.23, 1.23, 1.5, 1.5));
        assert_eq!(r.axis_saturated, [true, false, false]);
        assert!(r.saturated);
        let r = g.rates(&mean_volts(1.23, 1.23, 1.23, 1.5 - 300.5 * 3.752e-3, 1.5));
        assert_eq!(r.axis_saturated, [false, false, true]);
        assert!(r.rate[2] < -300.0 * DEG);
        // NaN counts (never from the averager) are saturated, not silently passed.
        let mut m = mean_volts(1.23, 1.23, 1.23, 1.5, 1.5);
        m.gyro_y = f32::NAN;
        assert_eq!(g.rates(&m).axis_saturated, [false, true, false]);
    }

    #[test]
    fn saturation_at_rails() {
        let g = GyroConversion::default();
        let mut a = Averager::new();
        for _ in 0..9 {
            a.push(&AdcFrame::from_channels([1526, 1526, 1526, 1862, 1862, 2000]));
        }
        // One frame with the XY reference at the low rail: x and y are saturated.
        a.push(&AdcFrame::from_channels([1526, 1526, 5, 1862, 1862, 2000]));
        let r = g.rates(&a.take().unwrap());
        assert_eq!(r.axis_saturated, [true, true, false]);
        assert!(r.saturated);
        // The depth channel at a rail does not saturate the gyros.
        a.push(&AdcFrame::from_channels([1526, 1526, 1526, 1862, 4095, 4095]));
        assert_eq!(g.rates(&a.take().unwrap()).axis_saturated, [false, false, true]);
        a.push(&AdcFrame::from_channels([1526, 1526, 1526, 1862, 1862, 4095]));
        assert!(!g.rates(&a.take().unwrap()).saturated);
    }
}
