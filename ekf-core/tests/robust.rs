//! Robustness of the EKF on motion outside the source's scenarios: long rejection streaks,
//! knocks, a start in motion, any attitude. Truth from the simulator of `common`.

mod common;

use common::*;
use ekf_core::{
    ekf::heading_change,
    mathf::{deg, to_deg},
    settings::{GateSettings, Settings},
    AttitudeFilter, Ekf, Euler, Flags, Quaternion, Vec3, GRAVITY,
};

fn started(settings: Settings, q: Quaternion, bias: Vec3) -> Ekf {
    let mut f = Ekf::new(settings);
    f.set_attitude(q, bias);
    f
}

/// The heading error in the metric of `docs/accuracy.md`: the twist about NED z of
/// `q_est ⊗ q_true*`, rad.
fn heading_error(est: Quaternion, truth: Quaternion) -> f32 {
    heading_change(truth, est)
}

/// 20 s of strong horizontal acceleration (0.3 g and 0.2 g sines), started 20° off in tilt:
/// the accelerometer is mostly wrong while it lasts. Within 15 s of the motion ending the tilt
/// has converged (the low-pass's two stages of 1.5 s forget the shaking by e^(−15/1.5)·(1 +
/// 15/1.5) = 0.05 %, and the Kalman gain, limited by the gyro's walk over the low-pass's
/// delay, corrects with a time constant of about 0.8·τ on top), with the default settings and
/// with the source's gate too, which leaves most of the shaking's samples out and keeps the
/// 20° start error through it.
#[test]
fn tilt_converges_within_15_s_after_a_long_rejection_streak() {
    let truth = Euler::new(deg(3.0), deg(-2.0), deg(40.0)).to_quaternion();
    let shake = |t: f32| {
        let a = if t < 20.0 {
            Vec3::new(
                0.3 * GRAVITY * (2.0 * core::f32::consts::PI * 0.5 * t).sin(),
                0.2 * GRAVITY * (2.0 * core::f32::consts::PI * 0.3 * t).cos(),
                0.0,
            )
        } else {
            Vec3::ZERO
        };
        (Vec3::ZERO, a)
    };
    let run = simulate(truth, 40.0, 50.0, Sensors::board(), 11, shake);
    let wrong = Euler::new(deg(3.0 + 14.0), deg(-2.0 - 14.0), deg(40.0)).to_quaternion();
    for gate in [GateSettings::default(), GateSettings::SOURCE] {
        let s = Settings { gate, ..Settings::default() };
        let mut f = started(s, wrong, Sensors::board().gyro_bias);
        let mut worst_after = 0.0f32;
        for (k, smp) in run.samples.iter().enumerate() {
            f.update(smp);
            let t = (k + 1) as f32 * 0.02;
            if t >= 35.0 {
                worst_after = worst_after.max(tilt_error(f.attitude(), run.truth[k]));
            }
        }
        assert!(
            to_deg(worst_after) < 0.5,
            "{gate:?}: tilt error {}° after 35 s",
            to_deg(worst_after)
        );
    }
}

/// A 0.16 s burst of ±0.5 g sideways (eight samples, a knock that rings) on a still board,
/// five times, hardly moves the tilt: the low-pass averages it over `ekf.accel_time_constant`.
/// By hand: the burst's mean, 0.4 g over 8 samples, is 0.064 g·s; two stages of 1.5 s pass at
/// most 0.064/1.5/e² ≈ 0.006 g... of it (0.33°) on the second stage, less where the Kalman gain
/// lags; raw, one sample of 0.5 g sideways is 27°.
#[test]
fn a_knock_burst_shorter_than_0_2_s_hardly_moves_the_tilt() {
    let truth = Euler::new(deg(2.0), deg(1.0), 0.0).to_quaternion();
    let run = simulate(truth, 20.0, 50.0, Sensors::board(), 12, still);
    let mut samples = run.samples.clone();
    for k in (200..900).step_by(150) {
        for j in 0..8 {
            let side = if j % 2 == 0 { 0.5 } else { -0.4 };
            samples[k + j].accel += Vec3::new(side * GRAVITY, 0.0, 0.0);
        }
    }
    let run_it = |samples: &[ekf_core::ImuSample]| {
        let mut f = started(Settings::default(), truth, Sensors::board().gyro_bias);
        let mut max_err = 0.0f32;
        for (k, s) in samples.iter().enumerate() {
            f.update(s);
            max_err = max_err.max(tilt_error(f.attitude(), run.truth[k]));
        }
        to_deg(max_err)
    };
    let quiet = run_it(&run.samples);
    let knocked = run_it(&samples);
    assert!(knocked < quiet + 0.4, "tilt error {knocked}° with knocks, {quiet}° without");
}

/// A hand's or a wave's back-and-forth: 0.3 g of north–south acceleration at 1 Hz on a level
/// board that does not turn. The tilt follows the NED low-pass of the specific force, two
/// first-order stages of half its time constant each
/// (`ekf.accel_time_constant`, 3 s). Each stage of 1.5 s passes 1/√(1 + (2π·1.5)²) of the
/// sine, both together 1/(1 + 88.8) = 0.011: a tilt swing of 0.3 × 0.011 rad = 0.19° by hand
/// (0.43° measured: the gyro noise and the Kalman gain's own lag add to it). One stage of the
/// same delay would pass 0.053 (0.9°), the raw samples all of it (17°).
#[test]
fn a_back_and_forth_acceleration_is_averaged_out_by_the_second_order_low_pass() {
    let truth = Quaternion::IDENTITY;
    let sway = |t: f32| {
        let a = 0.3 * GRAVITY * (2.0 * core::f32::consts::PI * t).sin();
        (Vec3::ZERO, Vec3::new(a, 0.0, 0.0))
    };
    let run = simulate(truth, 40.0, 50.0, Sensors::board(), 13, sway);
    let mut f = started(Settings::default(), truth, Sensors::board().gyro_bias);
    let mut worst = 0.0f32;
    for (k, smp) in run.samples.iter().enumerate() {
        f.update(smp);
        if k as f32 * 0.02 >= 20.0 {
            worst = worst.max(tilt_error(f.attitude(), run.truth[k]));
        }
    }
    let worst = to_deg(worst);
    assert!((0.15..0.6).contains(&worst), "tilt swing {worst}°, by hand 0.19°");
}

/// The start in motion: from power-on a 15° pitch sine at 0.1 Hz plus a 5 °/s turn.
/// The window sees the motion, starts at once from the configured bias (flagged), and the tilt
/// is within 1° of the truth 10 s later and stays so; the bias is not corrupted.
#[test]
fn a_start_in_motion_is_flagged_and_converges_within_10_s() {
    let w = core::f32::consts::TAU * 0.1;
    let motion =
        move |t: f32| (Vec3::new(0.0, deg(15.0) * w * (w * t).cos(), deg(5.0)), Vec3::ZERO);
    let run = simulate(Quaternion::IDENTITY, 120.0, 50.0, Sensors::board(), 13, motion);
    let mut f = Ekf::new(Settings::default());
    let mut moving_flag_at = None;
    let mut worst_after_10 = 0.0f32;
    for (k, smp) in run.samples.iter().enumerate() {
        let flags = f.update(smp);
        let t = (k + 1) as f32 * 0.02;
        if moving_flag_at.is_none() && flags.contains(Flags::MOVING_START) {
            moving_flag_at = Some(t);
        }
        if t >= 10.0 {
            worst_after_10 = worst_after_10.max(tilt_error(f.attitude(), run.truth[k]));
        }
    }
    let at = moving_flag_at.expect("MOVING_START raised");
    assert!(at < 0.5, "moving start flagged at {at} s");
    assert!(to_deg(worst_after_10) < 1.0, "tilt error {}° after 10 s", to_deg(worst_after_10));
    let db = f.gyro_bias() - Sensors::board().gyro_bias;
    assert!(to_deg(db.max_abs()) < 0.3, "bias off by {:?} °/s", db.to_array().map(to_deg));
}

/// The heading gap between the EKF and the gyro-only filter with the same configured bias, the
/// worst over a 200 s run from power-on, degrees, and the EKF's worst z bias error, °/s.
fn moving_start_gap(motion: impl Fn(f32) -> (Vec3, Vec3) + Copy, seed: u64) -> (f32, f32) {
    let truth0 = Euler::new(0.0, 0.0, deg(30.0)).to_quaternion();
    let run = simulate(truth0, 200.0, 50.0, Sensors::board(), seed, motion);
    let mut s = Settings::default();
    s.init.initial_yaw = deg(30.0);
    let mut ekf = Ekf::new(s);
    let mut gyro = ekf_core::GyroOnly::new(s);
    let (mut worst, mut worst_bz) = (0.0f32, 0.0f32);
    let mut moving = false;
    for smp in &run.samples {
        moving |= ekf.update(smp).contains(Flags::MOVING_START);
        gyro.update(smp);
        if ekf.is_initialised() && gyro.is_initialised() {
            worst = worst.max(heading_change(gyro.attitude(), ekf.attitude()).abs());
            let bz = ekf.gyro_bias().z - Sensors::board().gyro_bias.z;
            worst_bz = worst_bz.max(bz.abs());
        }
    }
    assert!(moving, "seed {seed}: not flagged as a moving start");
    (to_deg(worst), to_deg(worst_bz))
}

/// A start in motion and the heading of the gyro alone, given the same configured bias (issue
/// #35, point 2): from power-on, with no still window, a pitch-only sine (10° at 0.1 Hz,
/// scenario 1's motion) and a coupled roll and pitch sine (8° at 0.13 Hz and 10° at 0.1 Hz),
/// 5 seeds each. Nothing but the gyro knows the heading, so the EKF's differs from the
/// gyro-only filter's only through the bias it learns. The accelerometer cannot see a bias
/// about the vertical, and under a pitch swing the *current* vertical wobbles, so a gain
/// removed along it still leaks x-bias corrections into z by sin θ·cos θ (issue #35, cause 2);
/// here it is removed along the *mean* vertical (normalised, averaged over
/// `ekf::MEAN_VERTICAL_S`). In the first seconds that mean is one over part of a swing, a few
/// degrees off, and the large corrections of a bias known to 2 °/s leaked into z through it
/// (2.34° at worst, issue #26's design 5.56°); what the accelerometer taught along the mean
/// vertical as it is known now is taken back while the mean is young. Measured worst of the
/// ten: 0.10° (the z bias off by 0.011 °/s at most, early, and then taken back).
#[test]
fn a_start_in_motion_keeps_the_heading_near_the_gyro_alone() {
    let w = core::f32::consts::TAU * 0.1;
    let pitch = move |t: f32| (Vec3::new(0.0, deg(10.0) * w * (w * t).cos(), 0.0), Vec3::ZERO);
    let wr = core::f32::consts::TAU * 0.13;
    let coupled = move |t: f32| {
        (Vec3::new(deg(8.0) * wr * (wr * t).cos(), deg(10.0) * w * (w * t).cos(), 0.0), Vec3::ZERO)
    };
    let mut worst = (0.0f32, 0.0f32);
    for seed in 1..=5 {
        for (name, (gap, bz)) in
            [("pitch", moving_start_gap(pitch, seed)), ("coupled", moving_start_gap(coupled, seed))]
        {
            eprintln!("seed {seed} {name}: heading gap {gap:.3}°, z bias error {bz:.4} °/s");
            worst = (worst.0.max(gap), worst.1.max(bz));
        }
    }
    assert!(worst.1 < 0.015, "z bias off by up to {} °/s", worst.1);
    assert!(worst.0 < 0.3, "heading up to {}° from the gyro-only filter's", worst.0);
}

/// The same start with the old behaviour's input — a window that takes the motion as bias —
/// is what the moving-start check prevents: with the check defeated (a huge `moving_bias_sigma`
/// for the mean test, rate tolerance `initial_bias_sigma` for the segments' spread and the
/// checkpoints, and accelerometer limit), the bias from the window is wrong by degrees per
/// second.
#[test]
fn without_the_stillness_check_the_window_takes_motion_as_bias() {
    let w = core::f32::consts::TAU * 0.1;
    let motion =
        move |t: f32| (Vec3::new(0.0, deg(15.0) * w * (w * t).cos(), deg(5.0)), Vec3::ZERO);
    let run = simulate(Quaternion::IDENTITY, 10.5, 50.0, Sensors::board(), 13, motion);
    let mut s = Settings::default();
    s.init.moving_bias_sigma = deg(1000.0);
    s.ekf.initial_bias_sigma = deg(1000.0);
    s.rest.accel_std_max_g = 10.0;
    let mut f = Ekf::new(s);
    for smp in &run.samples {
        f.update(smp);
    }
    let db = f.gyro_bias() - Sensors::board().gyro_bias;
    assert!(to_deg(db.z).abs() > 4.0, "z bias off by only {}°/s", to_deg(db.z));
}

/// Standing on end (x up, pitch 90° — the RepoIMU pendulum's attitude) and rocking ±5° about
/// the vertical x axis, or upside down and still: the heading (twist about NED z) does not move
/// under the tilt corrections, where the Z-Y-X yaw is undefined or flips; tilt stays right.
#[test]
fn pitch_90_and_upside_down_keep_heading_and_tilt() {
    let w = core::f32::consts::TAU * 0.2;
    let rock = move |t: f32| (Vec3::new(deg(5.0) * w * (w * t).cos(), 0.0, 0.0), Vec3::ZERO);
    type Motion<'a> = &'a dyn Fn(f32) -> (Vec3, Vec3);
    let cases: [(Quaternion, Motion); 4] = [
        (Euler::new(0.0, deg(90.0), deg(30.0)).to_quaternion(), &rock),
        (Euler::new(deg(25.0), deg(89.0), deg(-60.0)).to_quaternion(), &rock),
        (Euler::new(deg(180.0), deg(10.0), deg(100.0)).to_quaternion(), &still),
        (Euler::new(deg(170.0), deg(-90.0), deg(0.0)).to_quaternion(), &still),
    ];
    for (start, motion) in cases {
        let run = simulate(start, 60.0, 50.0, Sensors::board(), 14, motion);
        let mut f = started(Settings::default(), start, Sensors::board().gyro_bias);
        let (mut worst_tilt, mut worst_heading) = (0.0f32, 0.0f32);
        for (k, smp) in run.samples.iter().enumerate() {
            f.update(smp);
            worst_tilt = worst_tilt.max(tilt_error(f.attitude(), run.truth[k]));
            worst_heading = worst_heading.max(heading_error(f.attitude(), run.truth[k]).abs());
        }
        // The board's x/y gyro noise walks the attitude over the low-pass's delay: 5/8·τ·psd
        // = 0.11° rms per axis (`ekf::accel_update`), the largest of 60 s below 0.4°.
        assert!(to_deg(worst_tilt) < 0.4, "{start:?}: tilt {}°", to_deg(worst_tilt));
        // 60 s of the gyro noise of whichever body axis is vertical (0.58 °/s per sample on x,
        // 0.065 on z): a random walk of at most about 0.6°; nothing from the corrections.
        assert!(to_deg(worst_heading) < 1.5, "{start:?}: heading {}°", to_deg(worst_heading));
    }
}

/// A tumble through every attitude (roll, pitch and yaw sines of 30–60 °/s about an axis that
/// keeps changing) with gyros whose scale factors are 2 % off and whose axes cross-couple by
/// 1 % (the iNEMO's bounds, `ekf.gyro_scale_error`), on an otherwise quiet board with no
/// acceleration. The rate error, up to 1.2 °/s, is no bias: it follows the rotation. Modelled
/// (the default 0.02), it is process noise on the attitude and, in the time-constant rule, the
/// error it builds up over the low-pass's delay (`motion`: (k·ω·τ)²), so the tilt follows the
/// accelerometer closely; unmodelled (0), the filter takes the error's effect on the
/// low-passed gravity for motion, lengthens the low-pass, and lags (the realistic `tumble`'s
/// 1.4° before issue #35's session 16).
#[test]
fn a_tumble_with_the_gyros_scale_error_keeps_the_tilt() {
    let w = |f: f32, t: f32| (core::f32::consts::TAU * f * t).sin();
    let motion = move |t: f32| {
        let rate = if t < 5.0 {
            Vec3::ZERO
        } else {
            Vec3::new(deg(60.0) * w(0.05, t), deg(45.0) * w(0.037, t + 3.0), deg(30.0) * w(0.07, t))
        };
        (rate, Vec3::ZERO)
    };
    let sensors = Sensors::board();
    let mut run = simulate(Quaternion::IDENTITY, 120.0, 50.0, sensors, 21, motion);
    // The gyros' sensitivity matrix: scale factors 1.02, 0.98, 1.015; cross-axis ±0.01.
    let k = [[1.02, 0.01, -0.01], [-0.01, 0.98, 0.01], [0.01, 0.01, 1.015]];
    for smp in &mut run.samples {
        let g = smp.gyro - sensors.gyro_bias;
        let m = |r: [f32; 3]| r[0] * g.x + r[1] * g.y + r[2] * g.z;
        smp.gyro = Vec3::new(m(k[0]), m(k[1]), m(k[2])) + sensors.gyro_bias;
    }
    let rms = |settings: Settings| {
        let mut f = started(settings, Quaternion::IDENTITY, sensors.gyro_bias);
        let (mut sum, mut n, mut tau) = (0.0f32, 0, 0.0f32);
        for (i, smp) in run.samples.iter().enumerate() {
            f.update(smp);
            if i >= 1000 {
                sum += tilt_error(f.attitude(), run.truth[i]).powi(2);
                tau += f.time_constant();
                n += 1;
            }
        }
        (to_deg((sum / n as f32).sqrt()), tau / n as f32)
    };
    let (modelled, tau_m) = rms(Settings::default());
    let mut unmodelled = Settings::default();
    unmodelled.ekf.gyro_scale_error = 0.0;
    let (unmodelled, tau_u) = rms(unmodelled);
    // Measured: 0.11° on raw samples (mean τ 0) against 2.6° at τ = 2.5 s; 1.9° modelled
    // without the rule's term, 0.26° without the process noise.
    assert!(
        modelled < 0.2 && tau_m < 0.5 && modelled < 0.5 * unmodelled,
        "tilt RMSE {modelled}° with the scale error modelled (mean τ {tau_m} s), \
         {unmodelled}° without (mean τ {tau_u} s)"
    );
}

/// A start in motion that turns the board every way (roll, pitch and yaw sines of 40–60 °/s,
/// 60 s from power-on), with the configured bias 2 °/s wrong on x and y (the board was
/// recalibrated since): the accelerometer must teach the bias, about the mean vertical too,
/// since the vertical spreads over every attitude. The correction that takes back what it
/// teaches along the mean vertical while the mean is young (`ekf::accel_update`) is for a
/// swing about one mean; here the mean is short (|m|² well below 0.9) and the bias is learnt.
#[test]
fn a_start_in_motion_over_every_attitude_learns_the_bias() {
    let w = |f: f32, t: f32| (core::f32::consts::TAU * f * t).cos();
    let motion = move |t: f32| {
        let rate =
            Vec3::new(deg(60.0) * w(0.21, t), deg(50.0) * w(0.17, t + 1.0), deg(40.0) * w(0.13, t));
        (rate, Vec3::ZERO)
    };
    let run = simulate(Quaternion::IDENTITY, 60.0, 50.0, Sensors::board(), 31, motion);
    let mut s = Settings::default();
    s.init.gyro_bias = Sensors::board().gyro_bias + Vec3::new(deg(2.0), deg(-2.0), 0.0);
    let mut f = Ekf::new(s);
    let mut worst = 0.0f32;
    for (k, smp) in run.samples.iter().enumerate() {
        f.update(smp);
        if k >= 1500 {
            let db = f.gyro_bias() - Sensors::board().gyro_bias;
            worst = worst.max(to_deg(db.norm()));
        }
    }
    // Measured: 0.14 °/s at worst after 30 s; 1.9 °/s when the correction applies at every
    // spread of the vertical (it then takes back what the rotations taught).
    assert!(worst < 0.3, "bias off by up to {worst} °/s after 30 s");
}
