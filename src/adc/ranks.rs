//! The boot check that the DMA buffer's ranks are the channels they should be.
//!
//! RM0008 §11.4: at the end of the calibration the calibration code is left in ADC_DR. Taken
//! by the DMA as a conversion (the calibration run with CR2.DMA set), it shifts every later
//! frame by one rank for good: each channel's counts land in its neighbour's slot. The
//! firmware calibrates with DMA requests off and reads ADC_DR out before it turns them on;
//! this check, on the first frame, says whether the ranks read like what they should be:
//! - VREFINT gives a VDDA the ADC can run at (2.4–3.6 V, [`super::scale::vdda_from_vrefint`]);
//! - each gyro reference (LPR430AL's 1.23 V, LY330ALH's 1.5 V) reads within
//!   [`REF_MIN_V`]–[`REF_MAX_V`] at that VDDA.
//!
//! The scan order ([`super::SCAN_CHANNELS`]) puts the depth channel between the two
//! references, so a shift by one rank either way moves it into a reference's slot: the check
//! sees the shift whenever the depth channel reads outside the references' window (no sensor,
//! or a sensor near the surface: 4 mA is 0.66 V across a 3.3 V-full-scale shunt). The gyro
//! outputs at rest read like their references, so that window is the only place a shift shows.

use super::frame::AdcFrame;
use super::scale::{vdda_from_vrefint, AdcScale};
use crate::board;

/// Lowest voltage a gyro reference may read, V (LPR430AL: 1.23 V typ.).
pub const REF_MIN_V: f32 = 1.0;
/// Highest voltage a gyro reference may read, V (LY330ALH: 1.5 V typ.).
pub const REF_MAX_V: f32 = 1.8;

/// What the check read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RankCheck {
    /// VDDA from the VREFINT rank, V; `None` when that rank does not read like VREFINT.
    pub vdda_v: Option<f32>,
    /// The gyro XY reference's rank, V (at the measured VDDA, else the nominal 3.3 V).
    pub xy_ref_v: f32,
    /// The gyro Z reference's rank, V.
    pub z_ref_v: f32,
    /// The depth channel's rank, V.
    pub depth_v: f32,
}

impl RankCheck {
    /// Every rank checked reads like what it should be.
    pub fn aligned(&self) -> bool {
        let window = REF_MIN_V..=REF_MAX_V;
        self.vdda_v.is_some() && window.contains(&self.xy_ref_v) && window.contains(&self.z_ref_v)
    }
}

/// Checks one frame.
pub fn check_ranks(frame: &AdcFrame) -> RankCheck {
    let full = f32::from(board::ADC_FULL_SCALE);
    // The nominal VREFINT, not the board's `adc.vrefint`: this only asks whether the rank
    // reads like VREFINT at all (a VDDA in the ADC's 2.4–3.6 V), which the part's ±5 % cannot
    // change, and it must not depend on a setting that a wrong `SET` could spoil.
    let vdda_v = vdda_from_vrefint(f32::from(frame.vrefint), full, board::VREFINT_V);
    let scale = AdcScale {
        vref_v: vdda_v.unwrap_or(board::ADC_VREF),
        full_scale_counts: full,
        vrefint_v: board::VREFINT_V,
    };
    RankCheck {
        vdda_v,
        xy_ref_v: scale.counts_to_volts(f32::from(frame.gyro_xy_ref)),
        z_ref_v: scale.counts_to_volts(f32::from(frame.gyro_z_ref)),
        depth_v: scale.counts_to_volts(f32::from(frame.depth)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::adc::SCAN_LEN;

    /// A frame at VDDA `vdda` from voltages: the gyros at rest (outputs at their references,
    /// 1.23 V LPR430AL, 1.5 V LY330ALH), VREFINT 1.20 V (DS5792 typ.), depth `depth_v`.
    fn frame(vdda: f32, depth_v: f32) -> AdcFrame {
        let c = |v: f32| (v / vdda * 4095.0).round() as u16;
        AdcFrame {
            gyro_x: c(1.23),
            gyro_y: c(1.231),
            gyro_xy_ref: c(1.23),
            gyro_z: c(1.502),
            gyro_z_ref: c(1.5),
            depth: c(depth_v),
            vrefint: c(1.20),
        }
    }

    /// The DMA buffer shifted by `by` ranks: slot i holds rank i − by.
    fn shifted(f: &AdcFrame, by: isize) -> AdcFrame {
        let scan = f.to_scan();
        let n = SCAN_LEN as isize;
        AdcFrame::from_scan(core::array::from_fn(|i| {
            scan[(i as isize - by).rem_euclid(n) as usize]
        }))
    }

    #[test]
    fn aligned_frames_pass_at_any_working_vdda() {
        for vdda in [3.0, 3.3, 3.6] {
            for depth_v in [0.0, 0.66, 1.5, 3.0] {
                let check = check_ranks(&frame(vdda, depth_v));
                assert!(check.aligned(), "VDDA {vdda} depth {depth_v}: {check:?}");
                let measured = check.vdda_v.unwrap();
                assert!((measured - vdda).abs() < 0.01, "{measured} vs {vdda}");
            }
        }
    }

    #[test]
    fn frames_shifted_by_a_rank_fail() {
        // No depth sensor (0 V), or one at the surface (4 mA: 0.66 V), or deep (3 V). One
        // rank either way is what a stray conversion (the calibration code) or a lost
        // request does; a shift by two ranks puts gyro channels into every checked slot and is
        // not seen (not a failure this check is for).
        for vdda in [3.0, 3.3] {
            for depth_v in [0.0, 0.3, 0.66, 2.5, 3.3] {
                let f = frame(vdda, depth_v);
                for by in [1, -1] {
                    let check = check_ranks(&shifted(&f, by));
                    assert!(
                        !check.aligned(),
                        "VDDA {vdda} depth {depth_v} V shifted by {by}: {check:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_calibration_code_in_the_first_slot_is_seen() {
        // The shift the calibration code causes: slot 0 holds it (a small number, RM0008
        // §11.4: the calibration factor), every rank one slot later.
        let f = frame(3.3, 0.66);
        let mut scan = shifted(&f, 1).to_scan();
        scan[0] = 0x3A;
        assert!(!check_ranks(&AdcFrame::from_scan(scan)).aligned());
    }
}
