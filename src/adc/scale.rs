//! ADC counts to volts, with VDDA measured through VREFINT.
//!
//! The ADC's reference is VDDA (VREF+ is bonded to it on the 64-pin package), so a count is a
//! fraction of VDDA; the gyros' and the depth sensor's outputs are voltages that do not follow
//! VDDA, so a VDDA 5 % below the nominal 3.3 V reads every rate and every pressure 5 % high.
//! Every scan converts the internal reference VREFINT (1.20 V, channel 17) too; its mean gives
//! VDDA = 1.20 V · 4095 / counts ([`vdda_from_vrefint`]), and [`AdcScale::for_mean`] uses it
//! instead of the nominal value.

use super::averager::AdcMean;
use crate::board;

/// VDDA, V, from a VREFINT reading (mean counts), or `None` when the reading gives a VDDA
/// outside the range in which the ADC works ([`board::VDDA_MIN_V`]–[`board::VDDA_MAX_V`]):
/// not a VREFINT reading (not measured: 0; or a rank out of place).
pub fn vdda_from_vrefint(counts: f32, full_scale_counts: f32) -> Option<f32> {
    if !(counts > 0.0) {
        return None;
    }
    let vdda = board::VREFINT_V * full_scale_counts / counts;
    (board::VDDA_MIN_V..=board::VDDA_MAX_V).contains(&vdda).then_some(vdda)
}

/// The ADC's transfer function: volts = counts · `vref_v` / `full_scale_counts`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdcScale {
    /// Reference voltage (VREF+ = VDDA), V. Default [`board::ADC_VREF`] = 3.3 V.
    pub vref_v: f32,
    /// Count at VREF, counts. Default [`board::ADC_FULL_SCALE`] = 4095.
    pub full_scale_counts: f32,
}

impl Default for AdcScale {
    fn default() -> Self {
        AdcScale { vref_v: board::ADC_VREF, full_scale_counts: board::ADC_FULL_SCALE as f32 }
    }
}

impl AdcScale {
    /// Volts at the ADC pin for `counts` (a mean or a difference of counts may be fractional
    /// or negative).
    #[inline]
    pub fn counts_to_volts(&self, counts: f32) -> f32 {
        counts * self.vref_v / self.full_scale_counts
    }

    /// This transfer function with the VDDA that `mean`'s VREFINT measured, when it did
    /// ([`vdda_from_vrefint`]); else unchanged (the nominal or configured `vref_v`).
    #[inline]
    pub fn for_mean(&self, mean: &AdcMean) -> AdcScale {
        match vdda_from_vrefint(mean.vrefint, self.full_scale_counts) {
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
        let vdda = vdda_from_vrefint(1489.091, 4095.0).unwrap();
        assert!((vdda - 3.3).abs() < 1e-4, "{vdda}");
        // At 3.0 V: 1638 counts.
        assert!((vdda_from_vrefint(1638.0, 4095.0).unwrap() - 3.0).abs() < 1e-4);
        // Not measured (0), or counts that give a VDDA the ADC cannot run at (2.4–3.6 V):
        // 1.2 · 4095 / 2100 = 2.34 V, 1.2 · 4095 / 1300 = 3.78 V.
        for counts in [0.0, -1.0, f32::NAN, 2100.0, 1300.0, 4095.0] {
            assert_eq!(vdda_from_vrefint(counts, 4095.0), None, "{counts}");
        }
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
