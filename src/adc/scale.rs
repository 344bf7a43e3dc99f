//! ADC counts to volts, with VDDA measured through VREFINT.
//!
//! The ADC's reference is VDDA (VREF+ is bonded to it on the 64-pin package), so a count is a
//! fraction of VDDA; the gyros' and the depth sensor's outputs are voltages that do not follow
//! VDDA, so a VDDA 5 % below the nominal 3.3 V reads every rate and every pressure 5 % high.
//! Every scan converts the internal reference VREFINT (channel 17) too; its mean gives
//! VDDA = VREFINT · 4095 / counts ([`vdda_from_vrefint`]), and [`AdcScale::for_mean`] uses it
//! instead of the nominal value.
//!
//! VREFINT itself is 1.20 V typical but 1.16–1.26 V from part to part (DS5792, "Embedded
//! internal reference voltage"), −3.3 … +5.0 % of the nominal. Taken as 1.20 V, VDDA, and so
//! every gyro rate and every depth voltage, reads 1.20 / VREFINT of the truth: +3.4 % on a
//! 1.16 V part, −4.8 % on a 1.26 V one (a 90° bench turn reads 93.1° … 85.7°). The
//! setting `adc.vrefint` ([`AdcScale::vrefint_v`]) holds the part's value, measured once per
//! board against a multimeter (`docs/bring-up.md`, "VREFINT").

use super::averager::AdcMean;
use crate::board;

/// VDDA, V, from a VREFINT reading (mean counts) and the part's VREFINT `vrefint_v` (V; the
/// nominal [`board::VREFINT_V`] or the board's measured `adc.vrefint`), or `None` when the
/// reading gives a VDDA outside the range in which the ADC works
/// ([`board::VDDA_MIN_V`]–[`board::VDDA_MAX_V`]): not a VREFINT reading (not measured: 0; or a
/// rank out of place).
pub fn vdda_from_vrefint(counts: f32, full_scale_counts: f32, vrefint_v: f32) -> Option<f32> {
    if !(counts > 0.0) {
        return None;
    }
    let vdda = vrefint_v * full_scale_counts / counts;
    (board::VDDA_MIN_V..=board::VDDA_MAX_V).contains(&vdda).then_some(vdda)
}

/// The ADC's transfer function: volts = counts · `vref_v` / `full_scale_counts`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdcScale {
    /// Reference voltage (VREF+ = VDDA), V. Default [`board::ADC_VREF`] = 3.3 V.
    pub vref_v: f32,
    /// Count at VREF, counts. Default [`board::ADC_FULL_SCALE`] = 4095.
    pub full_scale_counts: f32,
    /// The part's internal reference VREFINT, V, from which [`AdcScale::for_mean`] measures
    /// VDDA (setting `adc.vrefint`). Default [`board::VREFINT_V`] = 1.20 V (DS5792 typ.;
    /// 1.16–1.26 V from part to part).
    pub vrefint_v: f32,
}

impl Default for AdcScale {
    fn default() -> Self {
        AdcScale {
            vref_v: board::ADC_VREF,
            full_scale_counts: board::ADC_FULL_SCALE as f32,
            vrefint_v: board::VREFINT_V,
        }
    }
}

impl AdcScale {
    /// Volts at the ADC pin for `counts` (a mean or a difference of counts may be fractional
    /// or negative).
    #[inline]
    pub fn counts_to_volts(&self, counts: f32) -> f32 {
        counts * self.vref_v / self.full_scale_counts
    }

    /// VDDA, V, that `mean`'s VREFINT measured, with this scale's `vrefint_v`
    /// ([`vdda_from_vrefint`]).
    #[inline]
    pub fn vdda(&self, mean: &AdcMean) -> Option<f32> {
        vdda_from_vrefint(mean.vrefint, self.full_scale_counts, self.vrefint_v)
    }

    /// This transfer function with the VDDA that `mean`'s VREFINT measured, when it did
    /// ([`AdcScale::vdda`]); else unchanged (the nominal or configured `vref_v`).
    #[inline]
    pub fn for_mean(&self, mean: &AdcMean) -> AdcScale {
        match self.vdda(mean) {
            Some(vdda) => AdcScale { vref_v: vdda, ..*self },
            None => *self,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_to_volts_by_hand() {
        let s = AdcScale::default();
        assert_eq!(s.counts_to_volts(0.0), 0.0);
        assert_eq!(s.counts_to_volts(4095.0), 3.3);
        // 1241 counts: 1241 · 3.3 / 4095 = 1.000073… V.
        assert!((s.counts_to_volts(1241.0) - 1.000_073_3).abs() < 1e-6);
        assert!((s.counts_to_volts(-100.0) + 0.080_586_08).abs() < 1e-7);
    }

    #[test]
    fn vdda_from_vrefint_by_hand() {
        // DS5792: VREFINT 1.20 V typ. At VDDA 3.3 V it reads 1.2 / 3.3 · 4095 = 1489.09.
        let vdda = vdda_from_vrefint(1489.091, 4095.0, 1.20).unwrap();
        assert!((vdda - 3.3).abs() < 1e-4, "{vdda}");
        // At 3.0 V: 1638 counts.
        assert!((vdda_from_vrefint(1638.0, 4095.0, 1.20).unwrap() - 3.0).abs() < 1e-4);
        // Not measured (0), or counts that give a VDDA the ADC cannot run at (2.4–3.6 V):
        // 1.2 · 4095 / 2100 = 2.34 V, 1.2 · 4095 / 1300 = 3.78 V.
        for counts in [0.0, -1.0, f32::NAN, 2100.0, 1300.0, 4095.0] {
            assert_eq!(vdda_from_vrefint(counts, 4095.0, 1.20), None, "{counts}");
        }
    }

    #[test]
    fn vdda_from_a_configured_vrefint_by_hand() {
        // A part whose VREFINT is 1.23 V, at VDDA 3.300 V, reads 1.23 / 3.3 · 4095 = 1526.32
        // counts. With its own VREFINT the VDDA is right: 1.23 · 4095 / 1526 = 3.3007 V …
        let vdda = vdda_from_vrefint(1526.0, 4095.0, 1.23).unwrap();
        assert!((vdda - 3.3007).abs() < 1e-3, "{vdda}");
        // … with the nominal 1.20 V it is 1.20 · 4095 / 1526 = 3.2202 V, 2.4 % low.
        let nominal = vdda_from_vrefint(1526.0, 4095.0, 1.20).unwrap();
        assert!((nominal - 3.2202).abs() < 1e-3, "{nominal}");
        // The datasheet's extremes at a true 3.3 V: 1.16 V reads 1439.45 counts, 1.26 V
        // 1563.55; with the nominal 1.20 V they give 3.414 V (+3.4 %) and 3.143 V (−4.8 %).
        for (vrefint, counts, nominal_vdda) in [(1.16, 1439.45, 3.4138), (1.26, 1563.55, 3.1429)] {
            let right = vdda_from_vrefint(counts, 4095.0, vrefint).unwrap();
            assert!((right - 3.3).abs() < 1e-3, "{vrefint}: {right}");
            let wrong = vdda_from_vrefint(counts, 4095.0, 1.20).unwrap();
            assert!((wrong - nominal_vdda).abs() < 1e-3, "{vrefint}: {wrong}");
        }
    }

    #[test]
    fn for_mean_uses_the_configured_vrefint() {
        // VREFINT 1.23 V, VDDA 3.3 V: VREFINT reads 1526.3 counts, a 1.000 V depth signal
        // 1.0 / 3.3 · 4095 = 1240.9 counts. The configured scale reads 1.000 V; the nominal one
        // 1.0 · 1.20 / 1.23 = 0.9756 V.
        let mean = AdcMean { depth: 1240.909, vrefint: 1526.318, ..AdcMean::default() };
        let configured = AdcScale { vrefint_v: 1.23, ..AdcScale::default() };
        let v = configured.for_mean(&mean).counts_to_volts(mean.depth);
        assert!((v - 1.0).abs() < 1e-4, "{v}");
        assert!((configured.vdda(&mean).unwrap() - 3.3).abs() < 1e-4);
        let v0 = AdcScale::default().for_mean(&mean).counts_to_volts(mean.depth);
        assert!((v0 - 0.975_61).abs() < 1e-4, "{v0}");
    }

    #[test]
    fn a_low_vdda_is_measured_and_corrected() {
        // The board's VDDA at 3.0 V: a 1.0 V signal reads 1.0 / 3.0 · 4095 = 1365 counts; with
        // the nominal 3.3 V it would be taken for 1.1 V.
        let mean = AdcMean { depth: 1365.0, vrefint: 1638.0, ..AdcMean::default() };
        let s = AdcScale::default().for_mean(&mean);
        assert!((s.counts_to_volts(mean.depth) - 1.0).abs() < 1e-4, "{s:?}");
        // Without a VREFINT reading: the nominal scale.
        let m0 = AdcMean { vrefint: 0.0, ..mean };
        assert_eq!(AdcScale::default().for_mean(&m0), AdcScale::default());
    }
}
