//! Behaviour of the EKF against simulated ground truth.

mod common;

use common::*;
use ekf_core::{
    mathf::{deg, to_deg},
    settings::Settings,
    AttitudeFilter, Ekf, Euler, Flags, ImuSample, Quaternion, Vec3, GRAVITY,
};

fn started(settings: Settings, q: Quaternion, bias: Vec3) -> Ekf {
    let mut f = Ekf::new(settings);
    f.set_attitude(q, bias);
    f
}

#[test]
fn initialisation_window_gives_tilt_yaw_and_bias() {
    let truth = Euler::new(deg(4.0), deg(-7.0), 0.0).to_quaternion();
    let run = simulate(truth, 12.0, 50.0, Sensors::board(), 1, still);
    let mut s = Settings::default();
    s.init.initial_yaw = deg(123.0);
    let mut f = Ekf::new(s);
    let mut done_at = None;
    for (k, smp) in run.samples.iter().enumerate() {
        let flags = f.update(smp);
        if done_at.is_none() && !flags.contains(Flags::INITIALISING) {
            done_at = Some((k, f.euler()));
        }
    }
    // 10 s window at 50 Hz; the attitude as the window ends (afterwards the board's noisy
    // x/y gyros walk it by about 0.1° in 2 s, which the low-passed accelerometer corrects
    // over its 3 s).
    let (k, e) = done_at.expect("initialised");
    assert!((499..=501).contains(&k), "{k}");
    assert!((to_deg(e.roll) - 4.0).abs() < 0.05 && (to_deg(e.pitch) + 7.0).abs() < 0.05, "{e:?}");
    assert!((to_deg(e.yaw) - 123.0).abs() < 0.05, "{e:?}");
    // Bias from the window: 500 samples of the board's gyro noise.
    let b = f.gyro_bias() - Sensors::board().gyro_bias;
    assert!(
        to_deg(b.x).abs() < 0.1 && to_deg(b.y).abs() < 0.1 && to_deg(b.z).abs() < 0.02,
        "{b:?}"
    );
}

#[test]
fn constant_rate_propagation_equals_the_exact_rotation() {
    // Noise-free: 20°/s about a skew body axis for 5 s with consistent accelerometer.
    let w = Vec3::new(deg(12.0), deg(-9.0), deg(13.0));
    let run =
        simulate(Quaternion::IDENTITY, 5.0, 100.0, Sensors::perfect(), 2, |_| (w, Vec3::ZERO));
    let mut f = started(Settings::default(), Quaternion::IDENTITY, Vec3::ZERO);
    for s in &run.samples {
        f.update(s);
    }
    let exact = Quaternion::from_rotation_vector(w * 5.0);
    let err = f.attitude().angle_to(exact);
    assert!(err < deg(0.01), "{}", to_deg(err));
}

#[test]
fn converges_from_a_30_degree_tilt_error() {
    let truth = Euler::new(deg(3.0), deg(-2.0), deg(50.0)).to_quaternion();
    let run = simulate(truth, 30.0, 50.0, Sensors::board(), 3, still);
    let wrong = Euler::new(deg(3.0 + 21.2), deg(-2.0 - 21.2), deg(50.0)).to_quaternion();
    assert!(to_deg(tilt_error(wrong, truth)) > 29.0);
    let mut f = started(Settings::default(), wrong, Sensors::board().gyro_bias);
    for s in &run.samples {
        f.update(s);
    }
    let err = to_deg(tilt_error(f.attitude(), *run.truth.last().unwrap()));
    assert!(err < 0.2, "tilt error after 30 s: {err}°");
}

/// The control, yaw-split off, is `ekf::tests::without_yaw_split_a_correlated_yaw_moves`: with
/// a yaw error correlated to the tilt error the tilt update moves the heading.
#[test]
fn yaw_split_keeps_yaw_while_tilt_converges() {
    // Pitched 40° so that tilt corrections about NED axes would move Z-Y-X yaw.
    let truth = Euler::new(deg(10.0), deg(40.0), deg(-30.0)).to_quaternion();
    let run = simulate(truth, 10.0, 50.0, Sensors::perfect(), 4, still);
    let wrong = Euler::new(deg(20.0), deg(25.0), deg(-30.0)).to_quaternion();
    let mut s = Settings::default();
    s.rest.enabled = false;
    // Bias known and constant: yaw can then only move through the corrections.
    s.ekf.initial_bias_sigma = 1e-9;
    s.ekf.bias_random_walk = 0.0;
    let mut f = started(s, wrong, Vec3::ZERO);
    // The largest heading change of one update: with perfect, still sensors the gyro turns
    // nothing, so each update's change is its tilt correction's.
    let mut step_max = 0.0f32;
    for smp in &run.samples {
        let before = f.attitude();
        f.update(smp);
        step_max = step_max.max(ekf_core::ekf::heading_change(before, f.attitude()).abs());
    }
    assert!(to_deg(tilt_error(f.attitude(), truth)) < 0.05);
    // Each correction is a rotation about a horizontal NED axis, which has no twist about
    // NED z (to float rounding).
    assert!(to_deg(step_max) < 1e-4, "one update moved the heading {}°", to_deg(step_max));
    // Rotations about horizontal axes do not commute: along a path that is not a great circle
    // they add up to a twist of second order in the 18° corrected.
    let yaw_moved = to_deg(ekf_core::ekf::heading_change(wrong, f.attitude()));
    assert!(yaw_moved.abs() < 0.05, "heading moved {yaw_moved}° with yaw-split");
}

#[test]
fn gate_skips_extra_acceleration_and_resumes_after() {
    let truth = Euler::new(deg(2.0), deg(-3.0), 0.0).to_quaternion();
    // 0.1 g of extra acceleration (along NED down and north) from 20 s to 23 s, once the
    // still board's raw samples and rest detection have settled the bias (after 5 s it is
    // still known to only ±0.1 °/s, which would add to the walk below).
    let extra = Vec3::new(0.06, 0.0, 0.08) * GRAVITY;
    let run = simulate(truth, 30.0, 50.0, Sensors::board(), 5, |t| {
        (Vec3::ZERO, if (20.0..23.0).contains(&t) { extra } else { Vec3::ZERO })
    });
    // The source's gate (1 ± 0.05 g), a setting (off by default).
    let gated = Settings { gate: ekf_core::settings::GateSettings::SOURCE, ..Settings::default() };
    let mut f = started(gated, truth, Sensors::board().gyro_bias);
    let mut max_err: f32 = 0.0;
    let (mut used_during, mut used_after) = (0, 0);
    for (k, s) in run.samples.iter().enumerate() {
        let t = (k + 1) as f32 * 0.02;
        let flags = f.update(s);
        max_err = max_err.max(tilt_error(f.attitude(), run.truth[k]));
        if (20.01..22.99).contains(&t) && flags.contains(Flags::ACCEL_USED) {
            used_during += 1;
        }
        if t > 23.5 && flags.contains(Flags::ACCEL_USED) {
            used_after += 1;
        }
    }
    assert_eq!(used_during, 0, "accelerometer used while accelerating");
    assert!(used_after > 300, "did not resume: {used_after}");
    // 3 s on the board's noisy x/y gyros alone (0.58 °/s per sample): a random walk of
    // 0.58·0.02·√150 = 0.14° per axis, nothing more. Its largest excursion over the 3 s stays
    // below 0.7° with probability 1 − 1e−5 (reflection principle, Rayleigh tail); over seeds
    // 1–30 the largest tilt error of the run is 0.16–0.61°.
    let gated_err = to_deg(max_err);
    assert!(gated_err < 0.8, "tilt error {gated_err}°");

    // Without the gate the same acceleration tilts the estimate by degrees
    // (atan(0.06/0.92) = 3.7° if fully believed); the gate keeps it below 0.8°.
    let mut s = Settings::default();
    s.gate.norm_tolerance = 10.0;
    let mut f = started(s, truth, Sensors::board().gyro_bias);
    let mut max_err: f32 = 0.0;
    for (k, smp) in run.samples.iter().enumerate() {
        f.update(smp);
        max_err = max_err.max(tilt_error(f.attitude(), run.truth[k]));
    }
    // Low-passed over its 3 s, the 3 s push reaches the tilt as more than half of it.
    assert!(to_deg(max_err) > 2.0, "{}°", to_deg(max_err));
}

/// With the source's gate a sustained push keeps the accelerometer out: after
/// `ekf::LONG_REJECT_S` (10 s) the filter says so (`ACCEL_REJECT_LONG`, which takes roll and
/// pitch out of the marine sentences), and not before; the first sample used clears it.
#[test]
fn a_long_rejection_is_flagged_and_clears_when_the_accelerometer_returns() {
    let truth = Euler::new(deg(2.0), deg(-3.0), 0.0).to_quaternion();
    let extra = Vec3::new(0.06, 0.0, 0.08) * GRAVITY;
    let run = simulate(truth, 40.0, 50.0, Sensors::board(), 7, |t| {
        (Vec3::ZERO, if (20.0..32.0).contains(&t) { extra } else { Vec3::ZERO })
    });
    let gated = Settings { gate: ekf_core::settings::GateSettings::SOURCE, ..Settings::default() };
    let mut f = started(gated, truth, Sensors::board().gyro_bias);
    let (mut first, mut last) = (None, None);
    for (k, s) in run.samples.iter().enumerate() {
        let t = (k + 1) as f32 * 0.02;
        if f.update(s).contains(Flags::ACCEL_REJECT_LONG) {
            first.get_or_insert(t);
            last = Some(t);
        }
    }
    let (first, last) = (first.expect("never flagged"), last.unwrap());
    // The push's samples are gated from t = 20 s (a sample's time is its interval's start);
    // flagged 10 s later.
    assert!((29.9..30.1).contains(&first), "flagged from {first} s");
    assert!((31.9..32.1).contains(&last), "flagged until {last} s");
    // Off by default: the same run, nothing gated, never flagged.
    let mut f = started(Settings::default(), truth, Sensors::board().gyro_bias);
    assert!(run.samples.iter().all(|s| !f.update(s).contains(Flags::ACCEL_REJECT_LONG)));
}

#[test]
fn knocks_that_keep_the_norm_near_1g_do_not_throw_tilt_off() {
    let truth = Euler::new(deg(1.0), deg(1.0), 0.0).to_quaternion();
    let run = simulate(truth, 20.0, 50.0, Sensors::board(), 6, still);
    let mut samples = run.samples.clone();
    // A tap every 2 s: two samples with 0.25 g sideways and the vertical reduced so that
    // |a| stays within 1 % of 1 g.
    for k in (150..1000).step_by(100) {
        for j in 0..2 {
            let s = &mut samples[k + j];
            let side = if j == 0 { 0.25 } else { -0.2 };
            s.accel = Vec3::new(side * GRAVITY, 0.0, -(1.0 - side * side).sqrt() * GRAVITY);
        }
    }
    // The largest tilt error with the knocks, and on the same noise without them.
    let largest = |samples: &[ImuSample]| {
        let mut f = started(Settings::default(), truth, Sensors::board().gyro_bias);
        let mut max_err: f32 = 0.0;
        for (k, s) in samples.iter().enumerate() {
            f.update(s);
            max_err = max_err.max(tilt_error(f.attitude(), run.truth[k]));
        }
        to_deg(max_err)
    };
    let (with, without) = (largest(&samples), largest(&run.samples));
    // A still board takes its samples raw, where one sample 14° off would move the tilt by
    // the raw Kalman gain, about 0.12: 1.8°. The motion statistic sees the knock's horizontal
    // force in its top band at once (`motion`) and the low-pass takes over with τ ≥ 0.17 s;
    // through it the two samples, +0.25 g and −0.2 g, are a net 0.001 g·s, whose peak at the
    // output is about 0.45·0.001/0.17 = 0.003 rad (0.15°) by hand, less where the Kalman gain
    // lags.
    assert!(with < without + 0.2, "tilt error {with}° with the knocks, {without}° without");
}

#[test]
fn rest_detection_converges_the_bias_and_stops_yaw_drift() {
    let sensors = Sensors::board();
    let truth = Euler::new(deg(2.0), deg(-1.0), deg(10.0)).to_quaternion();
    let run = simulate(truth, 600.0, 50.0, sensors, 7, still);
    // Configured z bias wrong by 0.05 °/s, no initialisation window.
    let wrong = sensors.gyro_bias + Vec3::new(0.0, 0.0, deg(0.05));
    for rest_on in [true, false] {
        let mut s = Settings::default();
        s.rest.enabled = rest_on;
        let mut f = started(s, truth, wrong);
        let mut rest_seen = 0;
        for smp in &run.samples {
            rest_seen += f.update(smp).contains(Flags::AT_REST) as u32;
        }
        let yaw_err = to_deg(yaw_error(f.attitude(), *run.truth.last().unwrap()));
        let bias_err = to_deg(f.gyro_bias().z - sensors.gyro_bias.z);
        if rest_on {
            assert!(rest_seen > 25_000, "{rest_seen}");
            assert!(bias_err.abs() < 0.005, "bias error {bias_err} °/s");
            assert!(yaw_err.abs() < 0.3, "yaw error {yaw_err}° after 10 min");
        } else {
            // 0.05 °/s for 600 s: 30° of yaw drift.
            assert!(yaw_err.abs() > 25.0, "{yaw_err}");
        }
    }
}

#[test]
fn rest_detection_does_not_fire_during_a_half_degree_per_second_turn() {
    let sensors = Sensors::board();
    let w = Vec3::new(0.0, 0.0, deg(0.5));
    let run = simulate(Quaternion::IDENTITY, 300.0, 50.0, sensors, 8, |_| (w, Vec3::ZERO));
    let mut f = started(Settings::default(), Quaternion::IDENTITY, sensors.gyro_bias);
    for s in &run.samples {
        assert!(!f.update(s).contains(Flags::AT_REST));
    }
    // The turn is not absorbed into the bias and yaw follows it: 150° after 300 s.
    assert!(to_deg(f.gyro_bias().z - sensors.gyro_bias.z).abs() < 0.02);
    let yaw_err = to_deg(yaw_error(f.attitude(), *run.truth.last().unwrap()));
    assert!(yaw_err.abs() < 1.0, "{yaw_err}");
}

#[test]
fn constant_yaw_drift_compensation_subtracts_the_configured_rate() {
    let mut s = Settings::default();
    s.rest.enabled = false;
    s.ekf.yaw_drift_rate = deg(16.2) / 3600.0;
    let run = simulate(Quaternion::IDENTITY, 100.0, 50.0, Sensors::perfect(), 9, still);
    let mut f = started(s, Quaternion::IDENTITY, Vec3::ZERO);
    for smp in &run.samples {
        f.update(smp);
    }
    // 16.2 °/h for 100 s = −0.45°.
    assert!((to_deg(f.euler().yaw) + 0.45).abs() < 1e-3, "{}", to_deg(f.euler().yaw));
}

/// The Earth's field in NED, µT, for the configured strength, dip and declination.
fn field_ned(s: &Settings) -> Vec3 {
    let (f0, dip, dec) = (s.mag.field_ut, s.mag.dip, s.mag.declination);
    Vec3::new(dip.cos() * dec.cos(), dip.cos() * dec.sin(), dip.sin()) * f0
}

#[test]
fn magnetometer_moves_only_yaw_and_rejects_disturbed_samples() {
    let mut s = Settings::default();
    s.mag.enabled = true;
    s.rest.enabled = false;
    let truth = Euler::new(deg(5.0), deg(-4.0), deg(60.0)).to_quaternion();
    let run = simulate(truth, 60.0, 50.0, Sensors::perfect(), 10, still);
    let field_ned = field_ned(&s);
    // Magnetic yaw: truth yaw is measured from true north; the filter starts 20° off.
    let start = Euler::new(deg(5.0), deg(-4.0), deg(40.0)).to_quaternion();
    let mut f = started(s, start, Vec3::ZERO);
    let (mut used, mut rejected) = (0, 0);
    for (k, smp) in run.samples.iter().enumerate() {
        let mut smp = *smp;
        let mut m = run.truth[k].rotate_inverse(field_ned);
        if k % 10 == 5 {
            m = m * 1.5; // a thruster-disturbed sample: norm off by 50 %
        }
        smp.mag = Some(m);
        let flags = f.update(&smp);
        used += flags.contains(Flags::MAG_USED) as u32;
        rejected += flags.contains(Flags::MAG_REJECTED) as u32;
        assert!(to_deg(tilt_error(f.attitude(), truth)) < 0.01);
    }
    assert!(rejected >= 300 && used > 2000, "used {used} rejected {rejected}");
    let yaw_err = to_deg(yaw_error(f.attitude(), truth));
    assert!(yaw_err.abs() < 0.5, "{yaw_err}");
}

/// Nothing the filter starts from measures the heading, so its start variance is that of an
/// unknown angle (π²/3) and the magnetometer's first sample sets it: a board heading 120° (on
/// the magnetometer's north), started from the default yaw 0 after a still window, is within
/// 0.5° of it after the first magnetometer update (with the former 5° start σ that update
/// moved it by three quarters of the 120°).
#[test]
fn the_first_magnetometer_sample_sets_the_unknown_start_heading() {
    let mut s = Settings::default();
    s.mag.enabled = true;
    s.init.window_s = 2.0;
    let truth = Euler::new(deg(3.0), deg(-2.0), deg(120.0)).to_quaternion();
    let run = simulate(truth, 4.0, 50.0, Sensors::perfect(), 10, still);
    let field_ned = field_ned(&s);
    let mut f = Ekf::new(s);
    for (k, smp) in run.samples.iter().enumerate() {
        let mut smp = *smp;
        smp.mag = Some(run.truth[k].rotate_inverse(field_ned));
        if f.update(&smp).contains(Flags::MAG_USED) {
            let err = to_deg(yaw_error(f.attitude(), truth));
            assert!(err.abs() < 0.5, "after the first magnetometer update: {err}°");
            return;
        }
    }
    panic!("no magnetometer update");
}

#[test]
fn set_yaw_keeps_tilt() {
    let q = Euler::new(deg(7.0), deg(-12.0), deg(33.0)).to_quaternion();
    let mut f = started(Settings::default(), q, Vec3::ZERO);
    f.set_yaw(deg(-150.0));
    let e = f.euler();
    assert!((to_deg(e.yaw) + 150.0).abs() < 1e-3);
    assert!((to_deg(e.roll) - 7.0).abs() < 1e-3 && (to_deg(e.pitch) + 12.0).abs() < 1e-3);
}

#[test]
fn invalid_samples_never_reach_the_state() {
    let q = Euler::new(deg(7.0), deg(-12.0), deg(33.0)).to_quaternion();
    let mut f = started(Settings::default(), q, Vec3::ZERO);
    let level = Vec3::new(0.0, 0.0, -GRAVITY);
    let bad = [
        ImuSample::new(f32::NAN, Vec3::ZERO, level),
        ImuSample::new(-1.0, Vec3::ZERO, level),
        ImuSample::new(0.02, Vec3::new(f32::NAN, 0.0, 0.0), Vec3::new(f32::NAN, 0.0, 0.0)),
        ImuSample::new(0.02, Vec3::new(f32::INFINITY, 0.0, 0.0), Vec3::new(1e30, 0.0, 0.0)),
        ImuSample::new(0.02, Vec3::new(1e6, -1e6, 0.0), Vec3::ZERO),
    ];
    for s in &bad {
        let flags = f.update(s);
        assert!(flags.intersects(Flags::TIME_GAP | Flags::GYRO_INVALID | Flags::ACCEL_INVALID));
        assert!(f.attitude().angle_to(q) < 1e-6, "{flags:?}");
        assert_eq!(f.gyro_bias(), Vec3::ZERO);
    }
}
