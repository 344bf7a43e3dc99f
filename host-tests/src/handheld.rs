//! A hand-held-like motion that the project's scenarios do not cover (session 8, issue #13;
//! `examples/handheld.rs` prints its figures): three sines per body axis at 0.2–2.7 Hz (rates up
//! to about 250 °/s) and, at the rotation centre, linear accelerations of up to 0.5 g at
//! 0.6–2.4 Hz, sines in NED (so that the position stays bounded, as a hand's does; session 9),
//! after a 10 s still start, or from power-on; 100 Hz (or another rate), 120 s, no lever arm.
use crate::sim::{Attitude, Profile, Realism, SensorModel, SimConfig, Simulator, Trajectory};
use crate::trace::TraceRow;

const D: f64 = std::f64::consts::PI / 180.0;

/// The hand-held trajectory: linear accelerations scaled by `accel_scale` (1: up to 0.5 g;
/// 0.3: about 0.15 g), the motion from `start_s` (10 s after a still start, or 0).
pub fn trajectory(accel_scale: f64, start_s: f64) -> Trajectory {
    fn sum(v: Vec<Profile>) -> Profile {
        Profile::Sum(Box::leak(v.into_boxed_slice()))
    }
    let sine =
        |amp: f64, freq_hz: f64, phase: f64| Profile::Sine { start: start_s, amp, freq_hz, phase };
    let rate =
        |a: [(f64, f64, f64); 3]| sum(a.iter().map(|&(amp, f, ph)| sine(amp * D, f, ph)).collect());
    let acc = |a: [(f64, f64, f64); 2]| {
        sum(a.iter().map(|&(amp, f, ph)| sine(amp * accel_scale, f, ph)).collect())
    };
    Trajectory {
        attitude: Attitude::BodyRates {
            rates: [
                rate([(90.0, 0.37, 0.0), (60.0, 1.1, 1.0), (30.0, 2.3, 2.0)]),
                rate([(80.0, 0.29, 0.5), (70.0, 0.93, 1.5), (25.0, 1.9, 2.5)]),
                rate([(100.0, 0.21, 0.2), (50.0, 0.77, 1.2), (20.0, 2.7, 2.2)]),
            ],
            q0: [1.0, 0.0, 0.0, 0.0],
        },
        accel_body: [Profile::Zero; 3],
        accel_ned: [
            acc([(3.0, 0.8, 0.0), (2.0, 2.1, 1.0)]),
            acc([(2.5, 0.6, 0.3), (2.0, 1.7, 1.3)]),
            acc([(2.0, 0.9, 0.6), (1.5, 2.4, 1.6)]),
        ],
    }
}

/// The usual sample rate of the case, Hz.
pub const RATE_HZ: f64 = 100.0;

/// The simulated trace at `rate_hz` (the noise densities held, as everywhere in the simulator),
/// 120 s, no lever arm: plain sensors, or `realistic` ones
/// (`simulate --realistic`'s errors, full scales widened to ±2000 °/s and ±8 g). With
/// `moving_start` the motion starts at power-on and the simulated gyro has no bias, so the
/// configured bias a filter starts from (the iNEMO board's, up to 3.4 °/s) is wrong.
pub fn rows(
    accel_scale: f64,
    seed: u64,
    realistic: bool,
    moving_start: bool,
    rate_hz: f64,
) -> Vec<TraceRow> {
    let mut sensors = SensorModel { lever_arm: [0.0; 3], ..SensorModel::default() };
    if moving_start {
        sensors.gyro_bias = [0.0; 3];
    }
    if realistic {
        sensors.realism = Some(Realism {
            gyro_full_scale_dps: 2000.0,
            accel_full_scale_g: 8.0,
            ..Realism::INEMO
        });
    }
    let sim = SimConfig { rate_hz, duration_s: 120.0, seed, sensors };
    let traj = trajectory(accel_scale, if moving_start { 0.0 } else { 10.0 });
    Simulator::new(traj, sim).map(|s| s.row).collect()
}
