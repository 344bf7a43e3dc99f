//! The bring-up self-test: what the board's parts read, each graded against what a working
//! iNEMO V2 reads, in one report (the `SELFTEST` reply; the same at boot).
//!
//! | item | pass | warn | fail |
//! |---|---|---|---|
//! | clock | crystal measured at 8 MHz | crystal running, not measured | no crystal, or not 8 MHz: HSI at 64 MHz |
//! | VDDA | 3.0–3.6 V (VREFINT) | another VDDA the ADC runs at | no VREFINT reading |
//! | ADC ranks | the boot frame's ranks read like their channels ([`crate::adc::check_ranks`]) | — | they do not |
//! | accelerometer | a sample of 0.9–1.1 g (at rest) | another magnitude (moving, wrong scale) | no sample |
//! | magnetometer | identifies as the LSM303DLH, 20–80 µT (the Earth's field, 25–65 µT) | other identification, no sample yet or other magnitude | does not answer |
//! | gyro references | both within 1.0–1.8 V | — | outside, or no ADC data |
//! | depth | between the rails | at a rail (no sensor, or beyond its range) | no ADC data |
//!
//! The depth item has a fourth grade, **not connected** ([`Grade::NotConnected`], 3): the
//! boot's probe found PA1 floating (it followed the pull each way,
//! [`super::depth_probe`]); it counts as a warning in the overall grade (a board without a
//! depth sensor works, its depth is meaningless).
//! | I²C | no errors since boot | errors, or bus clears after the boot's | the last bus clear could not free the bus |
//! | settings | a valid flash record | defaults (no record) | — |
//! | fault | no fault record at boot | the previous run ended in a HardFault or panic | — |

use super::clock_check::HseCheck;
use super::fault_record::FaultKind;
use super::i2c_bus::Clear;
use crate::adc::{REF_MAX_V, REF_MIN_V};

/// What the board reads (the application fills it in every filter cycle; `Default`: nothing
/// measured, as in the emulator).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Inputs {
    /// The boot's crystal check; `None` when not run (emulator).
    pub hse: Option<HseCheck>,
    /// VDDA from VREFINT, V.
    pub vdda_v: Option<f32>,
    /// The boot's ADC rank check passed.
    pub ranks_aligned: bool,
    /// The last accelerometer sample, g.
    pub accel_g: Option<[f32; 3]>,
    /// The magnetometer's identification matched (`None`: it did not answer).
    pub mag_id_ok: Option<bool>,
    /// The last magnetometer sample, µT.
    pub mag_ut: Option<[f32; 3]>,
    /// The gyro references, V.
    pub xy_ref_v: Option<f32>,
    /// See `xy_ref_v`.
    pub z_ref_v: Option<f32>,
    /// The depth channel, V, and whether it touched a rail.
    pub depth_v: Option<(f32, bool)>,
    /// The boot's probe of the depth input ([`super::depth_probe`]): `Some(false)` when it
    /// floats (nothing connected); `None` when not probed (emulator).
    pub depth_connected: Option<bool>,
    /// Failed I²C transfers since boot.
    pub i2c_errors: u32,
    /// Bus clears since boot (the boot's included).
    pub bus_clears: u32,
    /// What the last bus clear found.
    pub last_clear: Option<Clear>,
    /// The settings came from a valid flash record.
    pub settings_from_flash: bool,
    /// The fault record found at boot.
    pub fault: Option<FaultKind>,
}

/// A grade.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Grade {
    /// As a working board reads.
    Pass = 0,
    /// Works, but look at it.
    Warn = 1,
    /// Broken or missing.
    Fail = 2,
    /// The depth input floats: no sensor connected (the depth item only; a warning in the
    /// overall grade).
    NotConnected = 3,
}

impl Grade {
    /// Name, as reported.
    pub const fn name(self) -> &'static str {
        match self {
            Grade::Pass => "PASS",
            Grade::Warn => "WARN",
            Grade::Fail => "FAIL",
            Grade::NotConnected => "NC",
        }
    }

    /// How bad it is, for the overall grade: [`Grade::NotConnected`] counts as a warning.
    pub const fn severity(self) -> Grade {
        match self {
            Grade::NotConnected => Grade::Warn,
            g => g,
        }
    }
}

/// The items, in report order.
pub const ITEMS: [&str; 10] = [
    "clock",
    "VDDA",
    "ADC ranks",
    "accel",
    "mag",
    "gyro refs",
    "depth",
    "I2C",
    "settings",
    "fault",
];

/// The graded report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Report {
    /// One grade per [`ITEMS`] entry.
    pub grades: [Grade; 10],
}

impl Report {
    /// The worst grade (PASS, WARN or FAIL: "not connected" counts as WARN).
    pub fn overall(&self) -> Grade {
        self.grades.iter().map(|g| g.severity()).max().unwrap_or(Grade::Pass)
    }

    /// The grades packed two bits per item, item 0 in the lowest bits (0 pass, 1 warn,
    /// 2 fail, 3 not connected — the depth item only): 20 bits, five hex digits in the reply.
    pub fn code(&self) -> u32 {
        self.grades.iter().enumerate().fold(0, |c, (i, g)| c | (*g as u32) << (2 * i))
    }
}

fn norm(v: [f32; 3]) -> f32 {
    ekf_core::mathf::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
}

fn within(v: f32, lo: f32, hi: f32) -> bool {
    (lo..=hi).contains(&v)
}

/// Grades what the board reads (the table in the module documentation).
pub fn evaluate(i: &Inputs) -> Report {
    use Grade::*;
    let clock = match i.hse {
        Some(HseCheck::Ok(_)) => Pass,
        Some(HseCheck::Unmeasured) => Warn,
        Some(HseCheck::WrongFrequency(_) | HseCheck::NotStarted) | None => Fail,
    };
    let vdda = match i.vdda_v {
        Some(v) if within(v, 3.0, 3.6) => Pass,
        Some(_) => Warn,
        None => Fail,
    };
    let ranks = if i.ranks_aligned { Pass } else { Fail };
    let accel = match i.accel_g {
        Some(a) if within(norm(a), 0.9, 1.1) => Pass,
        Some(_) => Warn,
        None => Fail,
    };
    let mag = match (i.mag_id_ok, i.mag_ut) {
        (None, _) => Fail,
        (Some(true), Some(m)) if within(norm(m), 20.0, 80.0) => Pass,
        (Some(_), _) => Warn,
    };
    let refs = match (i.xy_ref_v, i.z_ref_v) {
        (Some(a), Some(b))
            if within(a, REF_MIN_V, REF_MAX_V) && within(b, REF_MIN_V, REF_MAX_V) =>
        {
            Pass
        }
        _ => Fail,
    };
    let depth = match i.depth_v {
        Some(_) if i.depth_connected == Some(false) => NotConnected,
        Some((_, false)) => Pass,
        Some((_, true)) => Warn,
        None => Fail,
    };
    let i2c = match i.last_clear {
        Some(Clear::SdaStuck | Clear::SclStuck) => Fail,
        _ if i.i2c_errors > 0 || i.bus_clears > 1 => Warn,
        _ => Pass,
    };
    let settings = if i.settings_from_flash { Pass } else { Warn };
    let fault = if i.fault.is_some() { Warn } else { Pass };
    Report { grades: [clock, vdda, ranks, accel, mag, refs, depth, i2c, settings, fault] }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A working board at rest on the bench.
    fn good() -> Inputs {
        Inputs {
            hse: Some(HseCheck::Ok(8_001_000)),
            vdda_v: Some(3.29),
            ranks_aligned: true,
            accel_g: Some([0.01, -0.02, 1.0]),
            mag_id_ok: Some(true),
            mag_ut: Some([20.0, 0.0, -40.0]),
            xy_ref_v: Some(1.23),
            z_ref_v: Some(1.5),
            depth_v: Some((0.66, false)),
            depth_connected: Some(true),
            i2c_errors: 0,
            bus_clears: 1,
            last_clear: Some(Clear::Freed { clocks: 1 }),
            settings_from_flash: true,
            fault: None,
        }
    }

    fn grade(i: &Inputs, item: &str) -> Grade {
        let k = ITEMS.iter().position(|n| *n == item).unwrap();
        evaluate(i).grades[k]
    }

    /// The I²C item warns after any transfer error or a second bus clear (the first, at boot,
    /// is routine) and fails on a stuck line.
    #[test]
    fn i2c_warns_on_errors_or_repeated_clears() {
        assert_eq!(grade(&good(), "I2C"), Grade::Pass);
        assert_eq!(grade(&Inputs { i2c_errors: 1, ..good() }, "I2C"), Grade::Warn);
        assert_eq!(grade(&Inputs { bus_clears: 2, ..good() }, "I2C"), Grade::Warn);
        assert_eq!(grade(&Inputs { bus_clears: 0, ..good() }, "I2C"), Grade::Pass);
        let stuck = Inputs { last_clear: Some(Clear::SdaStuck), ..good() };
        assert_eq!(grade(&stuck, "I2C"), Grade::Fail);
    }

    /// The accelerometer item checks the magnitude of the reading, whatever the board's tilt.
    #[test]
    fn a_tilted_board_reads_one_g() {
        for a in [[0.6, 0.0, 0.8], [0.0, -0.6, 0.8], [0.8, 0.0, -0.6], [0.577, 0.577, 0.577]] {
            assert_eq!(
                grade(&Inputs { accel_g: Some(a), ..good() }, "accel"),
                Grade::Pass,
                "{a:?}"
            );
        }
        let low = Inputs { accel_g: Some([0.5, 0.0, 0.7]), ..good() };
        assert_eq!(grade(&low, "accel"), Grade::Warn);
    }

    #[test]
    fn a_working_board_passes_everything() {
        let r = evaluate(&good());
        assert_eq!(r.overall(), Grade::Pass, "{r:?}");
        assert_eq!(r.code(), 0);
    }

    #[test]
    fn each_failure_is_graded_on_its_own_item() {
        let cases: [(&str, Inputs, Grade); 17] = [
            (
                "clock",
                Inputs { hse: Some(HseCheck::WrongFrequency(12_000_000)), ..good() },
                Grade::Fail,
            ),
            ("clock", Inputs { hse: Some(HseCheck::NotStarted), ..good() }, Grade::Fail),
            ("clock", Inputs { hse: Some(HseCheck::Unmeasured), ..good() }, Grade::Warn),
            ("VDDA", Inputs { vdda_v: Some(2.8), ..good() }, Grade::Warn),
            ("VDDA", Inputs { vdda_v: None, ..good() }, Grade::Fail),
            ("ADC ranks", Inputs { ranks_aligned: false, ..good() }, Grade::Fail),
            ("accel", Inputs { accel_g: None, ..good() }, Grade::Fail),
            ("accel", Inputs { accel_g: Some([0.0, 0.0, 2.0]), ..good() }, Grade::Warn),
            ("mag", Inputs { mag_id_ok: None, ..good() }, Grade::Fail),
            ("mag", Inputs { mag_id_ok: Some(false), ..good() }, Grade::Warn),
            ("mag", Inputs { mag_ut: Some([0.0, 0.0, 300.0]), ..good() }, Grade::Warn),
            ("gyro refs", Inputs { z_ref_v: Some(0.2), ..good() }, Grade::Fail),
            ("depth", Inputs { depth_v: Some((0.0, true)), ..good() }, Grade::Warn),
            ("depth", Inputs { depth_v: None, ..good() }, Grade::Fail),
            ("I2C", Inputs { last_clear: Some(Clear::SdaStuck), ..good() }, Grade::Fail),
            ("I2C", Inputs { i2c_errors: 3, bus_clears: 2, ..good() }, Grade::Warn),
            ("settings", Inputs { settings_from_flash: false, ..good() }, Grade::Warn),
        ];
        for (item, inputs, expected) in cases {
            assert_eq!(grade(&inputs, item), expected, "{item}: {inputs:?}");
            // Nothing else changed grade.
            let r = evaluate(&inputs);
            let k = ITEMS.iter().position(|n| *n == item).unwrap();
            for (j, g) in r.grades.iter().enumerate() {
                if j != k {
                    assert_eq!(*g, Grade::Pass, "{item} moved {}", ITEMS[j]);
                }
            }
            assert_eq!(r.overall(), expected);
        }
        let f = Inputs { fault: Some(FaultKind::HardFault), ..good() };
        assert_eq!(grade(&f, "fault"), Grade::Warn);
    }

    /// A floating depth input (the boot's probe: `depth_connected == Some(false)`) is graded
    /// "not connected", 3 in bits 12–13, whatever it reads — a mid-range 1.2 V included (issue
    /// #27 point 4) — and counts as a warning overall. Not probed (`None`): graded on the
    /// reading alone, as before. No ADC data still fails.
    #[test]
    fn a_floating_depth_input_is_not_connected() {
        let floating =
            Inputs { depth_v: Some((1.2, false)), depth_connected: Some(false), ..good() };
        let r = evaluate(&floating);
        assert_eq!(grade(&floating, "depth"), Grade::NotConnected);
        assert_eq!(r.code(), 0x3000);
        assert_eq!(r.overall(), Grade::Warn);
        assert_eq!(r.overall().name(), "WARN");
        let at_rail = Inputs { depth_v: Some((3.3, true)), ..floating };
        assert_eq!(grade(&at_rail, "depth"), Grade::NotConnected);
        let unprobed = Inputs { depth_connected: None, ..floating };
        assert_eq!(grade(&unprobed, "depth"), Grade::Pass);
        let no_data = Inputs { depth_v: None, ..floating };
        assert_eq!(grade(&no_data, "depth"), Grade::Fail);
        // A failure elsewhere still makes the whole report FAIL.
        let r = evaluate(&Inputs { ranks_aligned: false, ..floating });
        assert_eq!(r.overall(), Grade::Fail);
        assert_eq!(r.code(), 0x3000 | 0b10 << 4);
    }

    #[test]
    fn the_code_packs_two_bits_per_item() {
        let r = evaluate(&Inputs {
            hse: Some(HseCheck::NotStarted),
            fault: Some(FaultKind::Panic),
            ..good()
        });
        assert_eq!(r.code(), 0b01 << 18 | 0b10);
        // Nothing measured (the emulator): failures.
        assert_eq!(evaluate(&Inputs::default()).overall(), Grade::Fail);
    }
}
