//! Depth from the external pressure sensor.

use super::averager::AdcMean;
use super::frame::Rails;
use super::scale::AdcScale;

/// Settings of the depth conversion: a linear volts → pressure calibration, then hydrostatics.
///
/// `pressure = offset_pa + pa_per_volt · volts` and
/// `depth = (pressure − surface_pressure_pa) / (water_density_kg_m3 · gravity_m_s2)`.
///
/// The default calibration describes an absolute 0–40 bar (≈ 400 m) sensor whose output is
/// scaled into the ADC's 0–3.3 V: 4 MPa over 3.3 V, 0 Pa at 0 V. It is a PLACEHOLDER: set
/// `pa_per_volt` and `offset_pa` from the sensor's calibration certificate and the scaling
/// network (divider or 4–20 mA shunt). With a gauge (relative) sensor, which reads about 0 Pa
/// at the surface, the default surface pressure of 101325 Pa gives about −10 m until the depth
/// is zeroed at the surface ([`DepthCalibration::zero_at_surface`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthCalibration {
    /// Calibration slope, Pa per V at the ADC pin. Default 4 MPa / 3.3 V ≈ 1.212 MPa/V
    /// (placeholder, see above).
    pub pa_per_volt: f32,
    /// Calibration offset: the pressure at 0 V, Pa. Default 0 Pa (placeholder).
    pub offset_pa: f32,
    /// Water density, kg/m³. Default 1025 (seawater; fresh water is about 998).
    pub water_density_kg_m3: f32,
    /// Gravity, m/s². Default 9.80665 (standard gravity).
    pub gravity_m_s2: f32,
    /// Pressure at zero depth, Pa (absolute if the calibration is). Default 101325 Pa (one
    /// standard atmosphere); [`DepthCalibration::zero_at_surface`] sets it from a reading.
    pub surface_pressure_pa: f32,
}

impl Default for DepthCalibration {
    fn default() -> Self {
        DepthCalibration {
            pa_per_volt: 4.0e6 / 3.3,
            offset_pa: 0.0,
            water_density_kg_m3: 1025.0,
            gravity_m_s2: 9.80665,
            surface_pressure_pa: 101_325.0,
        }
    }
}

/// Depth reading of one averaged scan.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DepthReading {
    /// Sensor output at the ADC pin, V.
    pub volts: f32,
    /// Pressure, Pa (absolute if the calibration is).
    pub pressure_pa: f32,
    /// Depth below the surface, m, positive down.
    pub depth_m: f32,
    /// At least one averaged sample of the depth channel was at a rail: the sensor may be
    /// out of range or disconnected, the reading is not trusted.
    pub at_rail: bool,
}

impl DepthCalibration {
    /// Pressure for a sensor output of `volts` (V at the ADC pin), Pa.
    #[inline]
    pub fn pressure_pa(&self, volts: f32) -> f32 {
        self.offset_pa + self.pa_per_volt * volts
    }

    /// Depth for a pressure, m, positive down (negative above the zeroed surface).
    #[inline]
    pub fn depth_of_pressure_m(&self, pressure_pa: f32) -> f32 {
        (pressure_pa - self.surface_pressure_pa) / (self.water_density_kg_m3 * self.gravity_m_s2)
    }

    /// Depth for a sensor output of `volts` (V at the ADC pin), m, positive down.
    #[inline]
    pub fn depth_m(&self, volts: f32) -> f32 {
        self.depth_of_pressure_m(self.pressure_pa(volts))
    }

    /// The depth reading of an averaged scan, with the ADC's transfer function `scale`.
    pub fn reading(&self, mean: &AdcMean, scale: &AdcScale) -> DepthReading {
        // Volts with the VDDA the scan's VREFINT measured (`AdcScale::for_mean`).
        let volts = scale.for_mean(mean).counts_to_volts(mean.depth);
        let pressure_pa = self.pressure_pa(volts);
        DepthReading {
            volts,
            pressure_pa,
            depth_m: self.depth_of_pressure_m(pressure_pa),
            at_rail: mean.rails.intersects(Rails::DEPTH),
        }
    }

    /// Make `reading`'s pressure the surface (zero depth): the "zero depth" command, run with
    /// the vehicle at the surface. Refused (returns false, settings unchanged) when the
    /// reading is at a rail or its pressure is not finite.
    pub fn zero_at_surface(&mut self, reading: &DepthReading) -> bool {
        if reading.at_rail || !reading.pressure_pa.is_finite() {
            return false;
        }
        self.surface_pressure_pa = reading.pressure_pa;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::adc::{AdcFrame, Averager};

    const RHO_G: f32 = 1025.0 * 9.80665;

    #[test]
    fn defaults() {
        let d = DepthCalibration::default();
        assert_eq!(d.pressure_pa(0.0), 0.0);
        assert!((d.pressure_pa(3.3) - 4.0e6).abs() < 0.5);
        // An absolute reading of one atmosphere is zero depth.
        assert_eq!(d.depth_of_pressure_m(101_325.0), 0.0);
    }

    #[test]
    fn ten_metres_of_seawater() {
        let d = DepthCalibration::default();
        // 1025 · 9.80665 · 10 = 100 518.16 Pa above the surface.
        let p = 101_325.0 + 100_518.16;
        assert!((d.depth_of_pressure_m(p) - 10.0).abs() < 1e-5);
        let volts = p / (4.0e6 / 3.3);
        assert!((d.pressure_pa(volts) - p).abs() < 0.05);
        assert!((d.depth_m(volts) - 10.0).abs() < 1e-5);
        // Positive down: above the surface is negative.
        assert!((d.depth_of_pressure_m(101_325.0 - RHO_G) + 1.0).abs() < 1e-5);
    }

    #[test]
    fn zeroing_moves_the_offset() {
        let mut d = DepthCalibration::default();
        let scale = AdcScale::default();
        // A gauge sensor at the surface: 0.01 V ≈ 12 121 Pa, about −8.9 m before zeroing.
        let mut a = Averager::new();
        a.push(&AdcFrame::from_channels([2000, 2000, 2000, 2000, 2000, 12]));
        let surface = d.reading(&a.take().unwrap(), &scale);
        assert!(!surface.at_rail);
        assert!((surface.volts - 12.0 * 3.3 / 4095.0).abs() < 1e-7);
        assert!(surface.depth_m < -8.0);
        assert!(d.zero_at_surface(&surface));
        assert_eq!(d.surface_pressure_pa, surface.pressure_pa);
        assert_eq!(d.depth_m(surface.volts), 0.0);
        // 10 m further down: + 100 518.16 Pa = + 0.082 927 5 V.
        let volts = surface.volts + 100_518.16 / (4.0e6 / 3.3);
        assert!((d.depth_m(volts) - 10.0).abs() < 1e-4);
    }

    #[test]
    fn rail_is_flagged_and_refused_for_zeroing() {
        let mut d = DepthCalibration::default();
        let mut a = Averager::new();
        a.push(&AdcFrame::from_channels([2000, 2000, 2000, 2000, 2000, 3]));
        a.push(&AdcFrame::from_channels([2000, 2000, 2000, 2000, 2000, 300]));
        let r = d.reading(&a.take().unwrap(), &AdcScale::default());
        assert!(r.at_rail);
        assert!(!d.zero_at_surface(&r));
        assert_eq!(d.surface_pressure_pa, 101_325.0);
        let nan = DepthReading { pressure_pa: f32::NAN, ..DepthReading::default() };
        assert!(!d.zero_at_surface(&nan));
    }
}
