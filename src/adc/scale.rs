//! ADC counts to volts.

use crate::board;

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
}
