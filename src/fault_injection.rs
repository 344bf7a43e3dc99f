//! Fault injection through the whole data path ([`crate::pipeline::Pipeline`]): the sensor
//! faults the firmware must survive, each injected into a running pipeline, with the flags it
//! must raise in `$PINAH`'s status word and the attitude it must keep. The bus-level faults
//! (I²C errors, timeouts, a dead or stuck LSM303DLH) are injected into the read schedule in
//! `supervision/imu_tests.rs`; the watchdog, LED and reset-cause decisions in their modules.

use ekf_core::{mathf::deg, AttitudeFilter, Euler, Flags};

use crate::adc::AdcMean;
use crate::nmea::{verify, Status};
use crate::pipeline::{Inputs, Pipeline, PipelineSettings};

/// A flat, still board, face up: the LSM303DLH reads +1 g on its z axis.
const FLAT: [f32; 3] = [0.0, 0.0, 1.0];
const DT: f32 = 0.02;

/// ADC counts of a voltage (3.3 V reference, 12 bits).
fn counts(volts: f32) -> f32 {
    volts / 3.3 * 4095.0
}

/// The averaged scan of gyros turning at `rates_dps` (sensor outputs, °/s; references at
/// 1.5 V; sensitivities from the datasheets: 3.33 mV/(°/s) x, y; 3.752 mV/(°/s) z).
fn adc(rates_dps: [f32; 3]) -> AdcMean {
    AdcMean {
        gyro_x: counts(1.5 + rates_dps[0] * 3.33e-3),
        gyro_y: counts(1.5 + rates_dps[1] * 3.33e-3),
        gyro_xy_ref: counts(1.5),
        gyro_z: counts(1.5 + rates_dps[2] * 3.752e-3),
        gyro_z_ref: counts(1.5),
        depth: counts(1.0),
        samples: 20,
        ..AdcMean::default()
    }
}

fn cycle(accel_g: Option<[f32; 3]>, adc: AdcMean) -> Inputs {
    Inputs { dt: DT, adc: Some(adc), accel_g, ..Inputs::default() }
}

/// A pipeline past its initialisation, level and still.
fn running() -> Pipeline {
    let mut s = PipelineSettings::default();
    s.filter.init.window_s = 0.2;
    let mut p = Pipeline::new(s);
    for _ in 0..50 {
        p.step(&cycle(Some(FLAT), adc([0.0; 3])));
    }
    assert!(!p
        .step(&cycle(Some(FLAT), adc([0.0; 3])))
        .status
        .flags()
        .contains(Flags::INITIALISING));
    p
}

fn level(p: &Pipeline) -> bool {
    let e = Euler::from_quaternion(p.ekf().attitude());
    e.roll.abs() < deg(0.1) && e.pitch.abs() < deg(0.1)
}

/// The status field (9th) of the last `$PINAH` of a step, as sent.
fn sent_status(step: &crate::pipeline::Step) -> Option<u32> {
    let pinah = step.sentences.iter().find(|s| s.as_str().starts_with("$PINAH"))?;
    let body = verify(pinah.as_bytes()).ok()?;
    u32::from_str_radix(body.split(',').nth(9)?, 16).ok()
}

#[test]
fn a_gyro_at_an_adc_rail_is_flagged_saturated_and_rail() {
    let mut p = running();
    let mut rail = adc([0.0; 3]);
    rail.gyro_x = 4095.0;
    rail.rails = crate::adc::Rails::GYRO_X;
    let step = p.step(&cycle(Some(FLAT), rail));
    assert!(step.status.contains(Status::GYRO_RAIL), "{:?}", step.status);
    assert!(step.status.flags().contains(Flags::GYRO_SATURATED));
    // The output carries both bits (18 and 3).
    let mut sent = None;
    for _ in 0..5 {
        let step = p.step(&cycle(Some(FLAT), rail));
        sent = sent.or(sent_status(&step));
    }
    let sent = sent.expect("a $PINAH within 5 cycles");
    assert_ne!(sent & (1 << 18), 0);
    assert_ne!(sent & (1 << 3), 0);
}

#[test]
fn a_rate_beyond_full_scale_is_flagged_saturated() {
    let mut p = running();
    // 320 °/s about x: 2.566 V, inside the ADC's range, beyond the 300 °/s full scale
    // (`gyro.range`): the conversion (bit 18) and the estimator (bit 3) flag it.
    let step = p.step(&cycle(Some(FLAT), adc([320.0, 0.0, 0.0])));
    assert!(step.status.flags().contains(Flags::GYRO_SATURATED));
    assert!(step.status.contains(Status::GYRO_RAIL));
    // Just within range: no flag.
    let step = p.step(&cycle(Some(FLAT), adc([290.0, 0.0, 0.0])));
    assert!(!step.status.flags().contains(Flags::GYRO_SATURATED));
    assert!(!step.status.contains(Status::GYRO_RAIL));
}

#[test]
fn implausible_accelerometer_samples_are_flagged_and_do_not_move_the_attitude() {
    // Beyond `limits.accel_abs_max` (16 g), below `limits.accel_min` (0.1 g), not a number.
    for bad in [[0.0, 0.0, 20.0], [0.0, 0.0, 0.0], [0.05, 0.0, 0.05], [f32::NAN, 0.0, 1.0]] {
        let mut p = running();
        for _ in 0..50 {
            let step = p.step(&cycle(Some(bad), adc([0.0; 3])));
            assert!(step.status.flags().contains(Flags::ACCEL_INVALID), "{bad:?}");
            assert!(!step.status.flags().contains(Flags::ACCEL_USED), "{bad:?}");
        }
        assert!(level(&p), "{bad:?}");
        // A good sample is used again at once.
        let step = p.step(&cycle(Some(FLAT), adc([0.0; 3])));
        assert!(!step.status.flags().contains(Flags::ACCEL_INVALID));
    }
}

#[test]
fn an_accelerometer_lost_on_the_bus_leaves_the_gyros_in_charge() {
    let mut p = running();
    // 2 s without the accelerometer (I²C fault), still: the attitude holds on the gyros.
    for _ in 0..100 {
        let step = p.step(&Inputs { board: Status::I2C_FAULT, ..cycle(None, adc([0.0; 3])) });
        assert!(step.status.contains(Status::I2C_FAULT));
        assert!(step.status.flags().contains(Flags::ACCEL_INVALID));
        assert!(step.sentences.iter().all(|s| verify(s.as_bytes()).is_ok()));
    }
    assert!(level(&p));
}

#[test]
fn missing_adc_frames_are_flagged_and_the_filter_skips_the_gyro() {
    let mut p = running();
    let step = p.step(&Inputs { adc: None, ..cycle(Some(FLAT), adc([0.0; 3])) });
    assert!(step.status.contains(Status::ADC_FAULT));
    assert!(step.status.flags().contains(Flags::GYRO_INVALID));
    assert!(level(&p));
    // Frames dropped by the averager count as an ADC fault too.
    let step = p.step(&cycle(Some(FLAT), AdcMean { dropped: 3, ..adc([0.0; 3]) }));
    assert!(step.status.contains(Status::ADC_FAULT));
}
