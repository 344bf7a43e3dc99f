//! Is a depth sensor connected to PA1? The boot reads the depth channel twice with the pin's
//! internal pull-down, then its pull-up, switched on (issue #27 point 4); this module decides
//! from the two readings.
//!
//! Why it is needed: with nothing on PA1 the pin floats. In analog mode (no pull) a floating
//! pin reads whatever charge the ADC's sample-and-hold capacitor kept from the previous
//! channel of the scan — the gyro XY reference, about 1.23 V (issue #27 reports about 1.2 V) —
//! which lies between the rails and would pass as a sensor's output.
//!
//! The model. A sensor is a source `V_s` behind its output impedance `R_s`; the pull is
//! `R_p` to a rail (0 V or VDDA). The pin reads
//! `V = V_s + (V_rail − V_s) · R_s / (R_s + R_p)`, so with both pulls (equal `R_p`)
//! `up − down = VDDA · R_s / (R_s + R_p)`:
//! - a floating pin (`R_s` → ∞) follows the pull: `up − down` → VDDA;
//! - a sensor's output barely moves: a 165 Ω 4–20 mA shunt moves by VDDA · 165 / 30,165 =
//!   0.55 % of full scale at the strongest pull; a divider with 10 kΩ‖20 kΩ = 6.67 kΩ by
//!   18 %.
//!
//! The decision: **not connected when `up − down` ≥ half the full scale**, i.e. when
//! `R_s ≥ R_p`. The numbers it rests on:
//! - `R_p` = 30–50 kΩ (DS5792, STM32F103xC/D/E datasheet, I/O static characteristics, R_PU
//!   and R_PD: min 30, typ 40, max 50 kΩ): every source below 30 kΩ is graded connected; the
//!   ADC is specified for sources up to R_AIN = 50 kΩ only (DS5792, ADC characteristics).
//! - How closely a floating pin follows its pull. The pull is on 1 ms before the scan and
//!   stays on while the depth rank samples (t_S = 239.5 ADC cycles = 19.95 µs at 12 MHz;
//!   `src/app/adc_scan.rs`). When the sample-and-hold capacitor (C_ADC ≤ 8 pF, DS5792) is
//!   connected it shares its charge (the previous rank's voltage, at worst the other rail)
//!   with the pin's node C (the pin's ~5 pF and the board's), then recharges through
//!   `R_p + R_ADC` ≤ 51 kΩ (R_ADC ≤ 1 kΩ, DS5792). The error left at the end of sampling is
//!   `VDDA · (8 pF / C) · exp(−19.95 µs / (51 kΩ · C))`, largest for C = 19.95 µs / 51 kΩ =
//!   391 pF: 8 / 391 · e⁻¹ = 0.75 % of VDDA, whatever the node's capacitance. The input
//!   leakage (≤ 1 µA, DS5792) through 50 kΩ adds at most 50 mV. A floating pin thus reads
//!   within 0.75 % + 50 mV of each rail: `up − down` ≥ 3.3 V · 0.985 − 0.1 V = 3.15 V, 95 %
//!   of full scale at VDDA 3.3 V — far above the threshold of 50 %.
//!
//! The readings are in ADC counts of the same VDDA, so the decision needs no volts. Not
//! verified on a board: that the STM32F103's ADC converts a pin configured as a pulled input
//! (RM0008's I/O structure, §9.1, shows the analog path to the ADC taken from the pad ahead of
//! the input's Schmitt trigger), and what a board without a sensor reads.

use crate::board;

/// `up − down`, counts, at or above which the pin is taken as floating: half the full scale
/// (2048, above half of 4095; module documentation).
pub const FLOATING_SPREAD_COUNTS: u16 = board::ADC_FULL_SCALE / 2 + 1;

/// The depth channel read with each pull on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthProbe {
    /// Counts with the pull-down on.
    pub pulled_down: u16,
    /// Counts with the pull-up on.
    pub pulled_up: u16,
}

impl DepthProbe {
    /// Whether something drives the pin: the two readings are less than half the full scale
    /// apart (a floating pin follows each pull to its rail).
    pub fn connected(&self) -> bool {
        self.pulled_up.saturating_sub(self.pulled_down) < FLOATING_SPREAD_COUNTS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Counts of `v` volts at VDDA 3.3 V, as the ADC codes them (4095 at full scale).
    fn c(v: f64) -> u16 {
        (v / 3.3 * 4095.0).round() as u16
    }

    /// What the pin reads with a source `vs` behind `rs` ohms and the pull `rp` to `rail`.
    fn pin(vs: f64, rs: f64, rp: f64, rail: f64) -> f64 {
        vs + (rail - vs) * rs / (rs + rp)
    }

    #[test]
    fn the_threshold_is_half_the_full_scale() {
        assert_eq!(FLOATING_SPREAD_COUNTS, 2048);
    }

    /// A floating pin at its worst (module documentation): 0.75 % of VDDA (25 mV at 3.3 V)
    /// and 50 mV of leakage away from each rail: 75 mV and 3.225 V, 93 and 4002 counts.
    #[test]
    fn a_floating_pin_is_not_connected() {
        let worst = DepthProbe { pulled_down: c(0.075), pulled_up: c(3.225) };
        assert_eq!(worst, DepthProbe { pulled_down: 93, pulled_up: 4002 });
        assert!(!worst.connected());
        // At the rails exactly.
        assert!(!DepthProbe { pulled_down: 0, pulled_up: 4095 }.connected());
    }

    /// Sensors with a low output impedance, at the weakest and the strongest pull (50 and
    /// 30 kΩ), at several outputs: connected.
    #[test]
    fn a_driven_pin_is_connected() {
        // 4–20 mA across 165 Ω (3.3 V at 20 mA), 4 mA: 0.66 V; a divider's 6.67 kΩ at 1.65 V;
        // an amplifier's output (100 Ω) at either rail.
        for (vs, rs) in [(0.66, 165.0), (3.3, 165.0), (1.65, 6_667.0), (0.0, 100.0), (3.3, 100.0)] {
            for rp in [30e3, 50e3] {
                let p = DepthProbe {
                    pulled_down: c(pin(vs, rs, rp, 0.0)),
                    pulled_up: c(pin(vs, rs, rp, 3.3)),
                };
                assert!(p.connected(), "{vs} V behind {rs} Ω, pull {rp} Ω: {p:?}");
            }
        }
        // The divider at the strongest pull by hand: 1.65 · 30 / 36.667 = 1.350 V (1675
        // counts) and 1.65 + 1.65 · 6.667 / 36.667 = 1.950 V (2420): 745 counts apart.
        let divider = DepthProbe { pulled_down: 1675, pulled_up: 2420 };
        assert_eq!(c(pin(1.65, 6_667.0, 30e3, 0.0)), divider.pulled_down);
        assert_eq!(c(pin(1.65, 6_667.0, 30e3, 3.3)), divider.pulled_up);
        assert!(divider.connected());
    }

    /// The boundary: a source as strong as the pull (R_s = R_p) moves by half the full
    /// scale; one count less is connected.
    #[test]
    fn the_boundary_is_a_source_as_strong_as_the_pull() {
        assert!(!DepthProbe { pulled_down: 1000, pulled_up: 3048 }.connected());
        assert!(DepthProbe { pulled_down: 1000, pulled_up: 3047 }.connected());
        // Noise the wrong way round (up below down) is a driven pin.
        assert!(DepthProbe { pulled_down: 2000, pulled_up: 1990 }.connected());
    }
}
