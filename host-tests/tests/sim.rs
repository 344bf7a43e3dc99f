//! The simulator against independent truth: hand values, analytic rotations and noise
//! statistics.
// Index loops over parallel per-axis arrays read best here.
#![allow(clippy::needless_range_loop)]

use host_tests::sim::{
    axis_angle, cross, euler_to_q, q_to_euler, qmul, rotate_inverse, Attitude, Profile, Realism,
    Scenario, SensorModel, SimConfig, SimOptions, SimSample, Simulator, Trajectory, DEG, G0,
    LEVER_ARM_M, PENDULUM_LENGTH_M,
};
use host_tests::trace::{TraceReader, TraceWriter};

/// Noise-free sensors with zero bias (the clean signals are then exact).
fn clean_sensors() -> SensorModel {
    SensorModel {
        gyro_bias: [0.0; 3],
        gyro_var: [0.0; 3],
        accel_var_g2: 0.0,
        ..SensorModel::default()
    }
}

fn config(sensors: SensorModel, rate_hz: f64, duration_s: f64) -> SimConfig {
    SimConfig { rate_hz, duration_s, seed: 7, sensors }
}

/// Mean and sample variance per axis.
fn stats(v: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let n = v.len() as f64;
    let mut mean = [0.0; 3];
    for x in v {
        for i in 0..3 {
            mean[i] += x[i] / n;
        }
    }
    let mut var = [0.0; 3];
    for x in v {
        for i in 0..3 {
            var[i] += (x[i] - mean[i]).powi(2) / (n - 1.0);
        }
    }
    (mean, var)
}

#[test]
fn still_trace_means_and_variances_match_the_model() {
    for rate in [50.0, 200.0] {
        let (sim, cfg) = Scenario::StillHour.simulator(rate, Some(200.0), 3, false);
        let samples: Vec<_> = sim.collect();
        assert_eq!(samples.len(), (200.0 * rate) as usize);
        let n = samples.len() as f64;
        let gyro: Vec<[f64; 3]> =
            samples.iter().map(|s| s.row.gyro.map(|g| g as f64 / DEG)).collect();
        let accel: Vec<[f64; 3]> = samples.iter().map(|s| s.row.accel.map(f64::from)).collect();
        let (gm, gv) = stats(&gyro);
        let (am, av) = stats(&accel);

        // Expected from the digest, independently of SensorModel: bias (°/s), variance (°/s)²
        // at 50 Hz scaled with the rate; accel variance 2.376e−6 g² at 50 Hz.
        let bias = [1.619, 3.440, -0.004];
        let var = [0.337, 0.275, 4.19e-3].map(|v| v * rate / 50.0);
        let avar = 2.376e-6 * G0 * G0 * rate / 50.0;
        for i in 0..3 {
            let se = (var[i] / n).sqrt();
            assert!((gm[i] - bias[i]).abs() < 4.0 * se, "rate {rate} gyro mean {i}: {gm:?}");
            // Sample variance: relative standard error sqrt(2/n).
            assert!((gv[i] / var[i] - 1.0).abs() < 5.0 * (2.0 / n).sqrt(), "gyro var {i}: {gv:?}");
            assert!((av[i] / avar - 1.0).abs() < 5.0 * (2.0 / n).sqrt(), "accel var {i}: {av:?}");
        }
        // Mean specific force = −g · down = (0, 0, −g0).
        let se = (avar / n).sqrt();
        assert!(am[0].abs() < 4.0 * se && am[1].abs() < 4.0 * se, "{am:?}");
        assert!((am[2] + 9.806_65).abs() < 4.0 * se, "{am:?}");
        assert_eq!(cfg.rate_hz, rate);
        // Truth is identity throughout.
        assert!(samples.iter().all(|s| s.row.truth == Some([1.0, 0.0, 0.0, 0.0])));
    }
}

#[test]
fn noise_variants_and_bias_off() {
    let n = 10_000.0;
    let var_of = |sc: Scenario| {
        let (sim, _) = sc.simulator(50.0, Some(200.0), 5, false);
        let samples: Vec<_> = sim.collect();
        // Noise = reading − clean signal − bias.
        let g: Vec<[f64; 3]> =
            samples.iter().map(|s| [0, 1, 2].map(|i| s.row.gyro[i] as f64 - s.omega[i])).collect();
        let a: Vec<[f64; 3]> = samples
            .iter()
            .map(|s| [0, 1, 2].map(|i| s.row.accel[i] as f64 - s.accel_clean[i]))
            .collect();
        (stats(&g), stats(&a))
    };
    let ((_, g1), (_, a1)) = var_of(Scenario::PitchSine);
    let ((_, g10), (_, a1b)) = var_of(Scenario::GyroNoise);
    let ((_, g1b), (_, a10)) = var_of(Scenario::AccelNoise);
    let tol = 5.0 * (2.0f64 / n).sqrt();
    for i in 0..3 {
        assert!((g10[i] / g1[i] / 10.0 - 1.0).abs() < 2.0 * tol, "gyro {i}");
        assert!((a10[i] / a1[i] / 10.0 - 1.0).abs() < 2.0 * tol, "accel {i}");
        // The other sensor's noise is unchanged (same seed, separate streams).
        assert!((g1b[i] / g1[i] - 1.0).abs() < 1e-9);
        assert!((a1b[i] / a1[i] - 1.0).abs() < 1e-9);
    }

    let (sim, cfg) = Scenario::BiasOff.simulator(50.0, Some(200.0), 5, false);
    let gz: Vec<[f64; 3]> = sim.map(|s| s.row.gyro.map(|g| g as f64 / DEG)).collect();
    let (m, _) = stats(&gz);
    let se = (4.19e-3 / n).sqrt();
    assert!((m[2] - (-0.004 + 0.05)).abs() < 4.0 * se, "{m:?}");
    assert!(Scenario::BiasOff.comments(&cfg).iter().any(|c| c.contains("--no-init-bias")));
}

#[test]
fn constant_body_rate_truth_is_the_analytic_rotation() {
    let w = [0.1, -0.2, 0.3];
    let q0 = axis_angle([0.0, 1.0, 0.0], 0.2);
    let traj = Trajectory {
        attitude: Attitude::BodyRates { rates: w.map(Profile::Const), q0 },
        accel_body: [Profile::Zero; 3],
        accel_ned: [Profile::Zero; 3],
    };
    let sim = Simulator::new(traj, config(clean_sensors(), 50.0, 30.0));
    let norm = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    let axis = w.map(|c| c / norm);
    for s in sim {
        // Body rates compose on the right: q(t) = q0 ⊗ exp(ω t).
        let expected = qmul(q0, axis_angle(axis, norm * s.row.t));
        let sign = if expected[0] < 0.0 { -1.0 } else { 1.0 };
        for i in 0..4 {
            assert!((s.q[i] - sign * expected[i]).abs() < 1e-10, "t {} {:?}", s.row.t, s.q);
        }
        // Clean gyro = ω (bias and noise off).
        for i in 0..3 {
            assert!((s.row.gyro[i] as f64 - w[i]).abs() < 1e-7);
        }
    }
}

#[test]
fn a_ned_acceleration_turns_with_the_body() {
    // Level, turning at 0.5 rad/s about NED z (yaw ψ = 0.5 t), with 1 m/s² north and
    // 2 m/s² up (NED z −2) at the rotation centre, lever arm zero: the specific force in the
    // body is Rᵀ(a − g) = (cos ψ, −sin ψ, −2 − g), and the body-axis profile adds to it.
    let traj = Trajectory {
        attitude: Attitude::BodyRates {
            rates: [Profile::Zero, Profile::Zero, Profile::Const(0.5)],
            q0: [1.0, 0.0, 0.0, 0.0],
        },
        accel_body: [Profile::Zero, Profile::Const(0.25), Profile::Zero],
        accel_ned: [Profile::Const(1.0), Profile::Zero, Profile::Const(-2.0)],
    };
    let mut sensors = clean_sensors();
    sensors.lever_arm = [0.0; 3];
    let mut n = 0;
    for s in Simulator::new(traj, config(sensors, 50.0, 10.0)) {
        let psi = 0.5 * s.row.t;
        let a = s.accel_clean;
        assert!((a[0] - psi.cos()).abs() < 1e-9, "t {} {a:?}", s.row.t);
        assert!((a[1] - (0.25 - psi.sin())).abs() < 1e-9, "t {} {a:?}", s.row.t);
        assert!((a[2] - (-2.0 - G0)).abs() < 1e-9, "t {} {a:?}", s.row.t);
        n += 1;
    }
    assert_eq!(n, 500);
}

#[test]
fn lever_arm_terms_equal_hand_values() {
    // Constant yaw rate 1 rad/s, level: ω × (ω × r) = −ω² (r_x, r_y, 0)
    //   = (−0.29725, 0.196, 0) m/s².
    let traj = Trajectory {
        attitude: Attitude::BodyRates {
            rates: [Profile::Zero, Profile::Zero, Profile::Const(1.0)],
            q0: [1.0, 0.0, 0.0, 0.0],
        },
        accel_body: [Profile::Zero; 3],
        accel_ned: [Profile::Zero; 3],
    };
    assert_eq!(LEVER_ARM_M, [0.297_25, -0.196, 0.0803]);
    for s in Simulator::new(traj, config(clean_sensors(), 50.0, 2.0)) {
        let a = s.accel_clean;
        assert!((a[0] + 0.297_25).abs() < 1e-9, "{a:?}");
        assert!((a[1] - 0.196).abs() < 1e-9, "{a:?}");
        assert!((a[2] + G0).abs() < 1e-9, "{a:?}");
    }
    // Constant yaw acceleration 2 rad/s² from rest (ω = 2t): tangential ω̇ × r =
    // (−2 r_y, 2 r_x, 0) = (0.392, 0.5945, 0), plus the centripetal −(2t)² (r_x, r_y, 0).
    let traj = Trajectory {
        attitude: Attitude::BodyRates {
            rates: [
                Profile::Zero,
                Profile::Zero,
                Profile::Ramp { start: 0.0, end: 10.0, from: 0.0, to: 20.0 },
            ],
            q0: [1.0, 0.0, 0.0, 0.0],
        },
        accel_body: [Profile::Zero; 3],
        accel_ned: [Profile::Zero; 3],
    };
    for s in Simulator::new(traj, config(clean_sensors(), 50.0, 1.0)).skip(1) {
        let w2 = (2.0 * s.row.t).powi(2);
        let a = s.accel_clean;
        assert!((a[0] - (0.392 - w2 * 0.297_25)).abs() < 1e-9, "{a:?}");
        assert!((a[1] - (0.5945 + w2 * 0.196)).abs() < 1e-9, "{a:?}");
        assert!((a[2] + G0).abs() < 1e-9);
        // Truth: a rotation about z by ∫ 2t = t².
        let yaw = q_to_euler(s.q)[2];
        assert!((yaw - s.row.t * s.row.t).abs() < 1e-9);
    }
    // Tangential term switched off: only the centripetal part remains.
    let mut sensors = clean_sensors();
    sensors.tangential = false;
    let s = Simulator::new(traj, config(sensors, 50.0, 1.0)).nth(10).unwrap();
    let w2 = (2.0 * s.row.t).powi(2);
    assert!((s.accel_clean[0] + w2 * 0.297_25).abs() < 1e-9);
}

#[test]
fn euler_scenarios_have_the_documented_truth() {
    let at = |sc: Scenario, t: f64| {
        let mut s = sc.sensors();
        s.gyro_var = [0.0; 3];
        s.accel_var_g2 = 0.0;
        let rate = 50.0;
        let mut sim = Simulator::new(sc.trajectory(), config(s, rate, t + 1.0));
        sim.nth((t * rate).round() as usize).unwrap()
    };
    // Still start: every scenario but start-moving is still for 10 s, level with yaw 0 except
    // side-mount (roll 90°: q = (cos 45°, sin 45°, 0, 0)) and pendulum (pitch 90°:
    // q = (cos 45°, 0, sin 45°, 0)).
    let h = std::f64::consts::FRAC_1_SQRT_2;
    for sc in Scenario::ALL.into_iter().filter(|&sc| sc != Scenario::StartMoving) {
        let q0 = match sc {
            Scenario::SideMount => [h, h, 0.0, 0.0],
            Scenario::Pendulum => [h, 0.0, h, 0.0],
            _ => [1.0, 0.0, 0.0, 0.0],
        };
        for t in [0.0, 5.0, 9.98] {
            let s = at(sc, t);
            assert!(s.omega.iter().all(|w| w.abs() < 1e-12), "{sc:?} {t}");
            assert!((0..4).all(|i| (s.q[i] - q0[i]).abs() < 1e-12), "{sc:?} {t} {:?}", s.q);
        }
    }
    // Pitch ramp: 1°/s from 20 s to 50 s: at 35 s pitch 15° about y, rate 1°/s.
    let s = at(Scenario::PitchRamp, 35.0);
    let h = 7.5 * DEG;
    let expected = [h.cos(), 0.0, h.sin(), 0.0];
    assert!(s.q.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-12), "{:?}", s.q);
    assert!((s.omega[1] - DEG).abs() < 1e-12);
    // Held at 30° afterwards: specific force (g sin30, 0, −g cos30) plus nothing else.
    let s = at(Scenario::PitchRamp, 120.0);
    assert!((s.accel_clean[0] - G0 * 0.5).abs() < 1e-9);
    assert!((s.accel_clean[2] + G0 * (30.0 * DEG).cos()).abs() < 1e-9);
    // Surge: + 0.5 m/s² along body x.
    let s = at(Scenario::Surge, 120.0);
    assert!((s.accel_clean[0] - (0.5 + G0 * 0.5)).abs() < 1e-9);
    let s = at(Scenario::Surge, 15.0);
    assert!(s.accel_clean[0].abs() < 1e-9);
    // Pitch step: 20° reached 0.1 s after t = 20 s; peak rate 250°/s in the middle.
    let s = at(Scenario::PitchStep, 20.2);
    assert!((q_to_euler(s.q)[1] - 20.0 * DEG).abs() < 1e-12);
    let s = at(Scenario::PitchStep, 20.06);
    assert!((s.omega[1] - 250.0 * DEG).abs() < 1e-9);
    // Pitch sine: 10° amplitude, 0.1 Hz: a quarter period (2.5 s) after the start, 10°.
    let s = at(Scenario::PitchSine, 12.5);
    assert!((q_to_euler(s.q)[1] - 10.0 * DEG).abs() < 1e-12);
    // Yaw sine: 30°, 0.05 Hz: 5 s after the start, 30°.
    let s = at(Scenario::YawSine, 15.0);
    assert!((q_to_euler(s.q)[2] - 30.0 * DEG).abs() < 1e-12);
}

#[test]
fn coupled_scenario_truth_is_consistent_and_yaw_responds() {
    let mut sensors = Scenario::Coupled.sensors();
    sensors.gyro_var = [0.0; 3];
    sensors.accel_var_g2 = 0.0;
    let rate = 50.0;
    let samples: Vec<_> =
        Simulator::new(Scenario::Coupled.trajectory(), config(sensors, rate, 60.0)).collect();
    let mut max_yaw: f64 = 0.0;
    let mut max_roll: f64 = 0.0;
    // (The rates start with a step at t = 10 s: no finite difference across it.)
    for w in samples.windows(3).filter(|w| w[0].row.t > 10.0) {
        // Body rate from the truth: 2 q* ⊗ q̇ (central difference) equals ω.
        let (qm, q, qp) = (w[0].q, w[1].q, w[2].q);
        let qdot = [0, 1, 2, 3].map(|i| (qp[i] - qm[i]) * rate / 2.0);
        let wq = qmul([q[0], -q[1], -q[2], -q[3]], qdot);
        for i in 0..3 {
            assert!((2.0 * wq[i + 1] - w[1].omega[i]).abs() < 2e-4, "t {}", w[1].row.t);
        }
        let e = q_to_euler(q);
        max_roll = max_roll.max(e[0].abs());
        max_yaw = max_yaw.max(e[2].abs());
        // The clean accelerometer is −g in body axes plus the lever-arm terms.
        let g_body = rotate_inverse(q, [0.0, 0.0, G0]);
        let (om, dom) = (w[1].omega, w[1].omega_dot);
        let centripetal = cross(om, cross(om, LEVER_ARM_M));
        let tangential = cross(dom, LEVER_ARM_M);
        let expected = [0, 1, 2].map(|i| -g_body[i] + centripetal[i] + tangential[i]);
        assert!((0..3).all(|i| (expected[i] - w[1].accel_clean[i]).abs() < 1e-9));
    }
    // Roll about ±5°; yaw responds (small, non-zero) though r = 0.
    assert!((max_roll / DEG - 5.0).abs() < 0.5, "{}", max_roll / DEG);
    assert!(max_yaw / DEG > 0.01 && max_yaw / DEG < 2.0, "{}", max_yaw / DEG);
    // Integration at ≤ 1 ms internal steps does not depend on the output rate.
    let s10 =
        Simulator::new(Scenario::Coupled.trajectory(), config(sensors, 10.0, 60.0)).last().unwrap();
    let s50 = samples.last().unwrap();
    assert!((s10.row.t - 59.9).abs() < 1e-9);
    let s50b = samples.iter().find(|s| (s.row.t - 59.9).abs() < 1e-9).unwrap();
    assert!(s10.q.iter().zip(s50b.q).all(|(a, b)| (a - b).abs() < 1e-9));
    assert!(s50.row.t > 59.9);
}

#[test]
fn same_seed_same_trace_written_rows_parse_back_exactly() {
    let run = |seed| {
        let (sim, _) = Scenario::PitchStep.simulator(50.0, Some(25.0), seed, true);
        let mut w = TraceWriter::new(Vec::new(), sim.columns()).unwrap();
        let rows: Vec<_> = sim.map(|s| s.row).collect();
        for r in &rows {
            w.row(r).unwrap();
        }
        (rows, w.finish().unwrap())
    };
    let (rows, bytes) = run(11);
    let (_, bytes2) = run(11);
    let (_, bytes3) = run(12);
    assert_eq!(bytes, bytes2);
    assert_ne!(bytes, bytes3);
    let back: Vec<_> =
        TraceReader::new(&bytes[..]).unwrap().collect::<Result<Vec<_>, _>>().unwrap();
    assert_eq!(back, rows);
    assert!(back.iter().all(|r| r.mag.is_some()));
}

// ---------------------------------------------------------------------------------------------
// New scenarios.

/// Rotation matrix of a body → NED quaternion, written out (independent of the simulator's
/// quaternion helpers): `R[i][j]`, NED row `i`, body column `j`.
fn matrix(q: [f64; 4]) -> [[f64; 3]; 3] {
    let [w, x, y, z] = q;
    [
        [w * w + x * x - y * y - z * z, 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), w * w - x * x + y * y - z * z, 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z],
    ]
}

/// Clean samples (no bias, no noise) of a scenario at `rate` Hz for `duration` s.
fn clean_run(sc: Scenario, rate: f64, duration: f64) -> Vec<SimSample> {
    let mut sensors = sc.sensors();
    sensors.gyro_bias = [0.0; 3];
    sensors.gyro_var = [0.0; 3];
    sensors.accel_var_g2 = 0.0;
    Simulator::new(sc.trajectory(), config(sensors, rate, duration)).collect()
}

/// The truth of a scenario is consistent: the gyro (clean) equals the body rate of the truth
/// quaternion, 2 q* ⊗ q̇; ω̇ is the derivative of ω; the accelerometer (clean) equals
/// −Rᵀ g + ω × (ω × r) + ω̇ × r with the hand-given lever arm `r` (no linear acceleration of
/// the rotation centre in these scenarios). Windows within 30 ms of `events` (steps of ω̇) are
/// skipped for the ω̇ check.
fn check_consistent(sc: Scenario, r: [f64; 3], events: &[f64]) -> Vec<SimSample> {
    let rate = 200.0;
    let samples = clean_run(sc, rate, sc.default_duration());
    assert_eq!(samples.len(), (sc.default_duration() * rate) as usize);
    for w in samples.windows(3) {
        let (a, b, c) = (&w[0], &w[1], &w[2]);
        let t = b.row.t;
        let near_event = events.iter().any(|e| (t - e).abs() < 0.03);
        // Truth rate: 2 q* ⊗ q̇ by central differences (sign-aligned).
        let sgn = |q: [f64; 4]| {
            let d: f64 = (0..4).map(|i| q[i] * b.q[i]).sum();
            if d < 0.0 {
                q.map(|c| -c)
            } else {
                q
            }
        };
        let (qm, qp) = (sgn(a.q), sgn(c.q));
        if !near_event {
            let qdot = [0, 1, 2, 3].map(|i| (qp[i] - qm[i]) * rate / 2.0);
            let wq = qmul([b.q[0], -b.q[1], -b.q[2], -b.q[3]], qdot);
            for i in 0..3 {
                assert!((2.0 * wq[i + 1] - b.omega[i]).abs() < 5e-4, "{sc:?} t {t} axis {i}");
                let dw = (c.omega[i] - a.omega[i]) * rate / 2.0;
                assert!((dw - b.omega_dot[i]).abs() < 2e-3, "{sc:?} t {t} ω̇ {i}");
            }
        }
        // The trace's gyro is the mean rate over the period ending at the sample (f32): the
        // mean of the true rates at its two ends (trapezoidal rule, to ω̈·dt²/12).
        if !events.iter().any(|e| (t - e).abs() < 0.06) {
            for i in 0..3 {
                let mean = 0.5 * (a.omega[i] + b.omega[i]);
                assert!((b.row.gyro[i] as f64 - mean).abs() < 2e-4, "{sc:?} t {t} axis {i}");
            }
        }
        // The trace's accelerometer: −Rᵀ g (the last row of R times g) plus lever-arm terms.
        let m = matrix(b.q);
        let (om, dom) = (b.omega, b.omega_dot);
        let cen = cross(om, cross(om, r));
        let tan = cross(dom, r);
        for i in 0..3 {
            let e = -G0 * m[2][i] + cen[i] + tan[i];
            assert!((b.row.accel[i] as f64 - e).abs() < 2e-5, "{sc:?} t {t} accel {i}");
        }
    }
    samples
}

#[test]
fn tumble_goes_through_all_attitudes_with_smooth_bounded_rates() {
    let samples = check_consistent(Scenario::Tumble, LEVER_ARM_M, &[10.0]);
    // Every body axis points (within 18°) both down and up at some time: the gravity
    // direction in body axes, the last row of R, visits ±x, ±y, ±z.
    let mut reach = [[f64::MIN; 2]; 3];
    let mut peak = [0.0f64; 3];
    let (mut pmax, mut pmin) = (0.0f64, 0.0f64);
    for s in &samples {
        let m = matrix(s.q);
        for i in 0..3 {
            reach[i][0] = reach[i][0].max(m[2][i]);
            reach[i][1] = reach[i][1].max(-m[2][i]);
            peak[i] = peak[i].max(s.omega[i].abs() / DEG);
        }
        let pitch = q_to_euler(s.q)[1] / DEG;
        pmax = pmax.max(pitch);
        pmin = pmin.min(pitch);
    }
    assert!(reach.iter().flatten().all(|&r| r > 0.95), "{reach:?}");
    // Upside down: body z up, the accelerometer's z reads about +g.
    assert!(samples.iter().any(|s| s.row.accel[2] as f64 > 0.95 * G0));
    assert!(pmax > 80.0 && pmin < -80.0, "pitch {pmin} … {pmax}");
    // Peak rates up to about 90 °/s, every axis moving.
    assert!(peak.iter().all(|&p| p > 40.0 && p < 95.0), "{peak:?}");
    assert!(peak.iter().any(|&p| p > 80.0), "{peak:?}");
    // Rates are continuous: no step larger than 0.5 °/s between samples at 200 Hz.
    for w in samples.windows(2) {
        for i in 0..3 {
            assert!((w[1].omega[i] - w[0].omega[i]).abs() / DEG < 0.5);
        }
    }
}

#[test]
fn side_mount_has_the_board_z_horizontal_and_the_vehicle_motion() {
    // The Seahog's lever arm (0.29725, −0.196, 0.0803) in the sensor's axes: sensor y is the
    // vehicle's z (down), sensor z the vehicle's −y (port).
    let r = [0.297_25, 0.0803, 0.196];
    assert!(Scenario::SideMount
        .sensors()
        .lever_arm
        .iter()
        .zip(r)
        .all(|(a, b)| (a - b).abs() < 1e-12));
    let samples = check_consistent(Scenario::SideMount, r, &[10.0]);
    for s in &samples {
        let m = matrix(s.q);
        let t = s.row.t;
        // The board's z axis is horizontal throughout (the vehicle does not roll).
        assert!(m[2][2].abs() < 1e-12, "t {t}");
        // The sensor's x axis is the vehicle's: its pitch is scenario 1's sine.
        let pitch = (-m[2][0]).asin();
        let want = if t < 10.0 {
            0.0
        } else {
            10.0 * DEG * (std::f64::consts::TAU * 0.1 * (t - 10.0)).sin()
        };
        assert!((pitch - want).abs() < 1e-9, "t {t}");
    }
    // Still start: gravity along sensor +y, the accelerometer reads (0, −g, 0).
    let s = &samples[100];
    assert!((s.row.accel[1] as f64 + G0).abs() < 1e-5 && s.row.accel[0].abs() < 1e-5);
    assert!(s.row.accel[2].abs() < 1e-5);
    // t = 15 s: vehicle pitch 0, yaw 30° · sin(π/2)… the sensor's Euler angles are roll 90°,
    // pitch 0, yaw 30° (yaw sine at 0.05 Hz, 5 s in).
    let s = samples.iter().find(|s| (s.row.t - 15.0).abs() < 1e-9).unwrap();
    let e = q_to_euler(s.q);
    assert!((e[0] - 90.0 * DEG).abs() < 1e-9 && e[1].abs() < 1e-9, "{e:?}");
    assert!((e[2] - 30.0 * DEG).abs() < 1e-9, "{e:?}");
}

#[test]
fn start_moving_moves_from_the_first_sample() {
    let samples = check_consistent(Scenario::StartMoving, LEVER_ARM_M, &[]);
    // At t = 0 (level, yaw 0) the body rates are the Euler rates: (0, 15° · 2π · 0.1, 5°) /s.
    let s = &samples[0];
    assert!(s.omega[0].abs() < 1e-12);
    assert!((s.omega[1] - 15.0 * DEG * std::f64::consts::TAU * 0.1).abs() < 1e-12);
    assert!((s.omega[2] - 5.0 * DEG).abs() < 1e-12);
    let at = |t: f64| samples.iter().find(|s| (s.row.t - t).abs() < 1e-9).unwrap();
    // t = 2.5 s: pitch 15°, yaw 12.5°; t = 20 s: pitch 0, yaw 100°; t = 40 s: yaw 200° → −160°.
    let e = q_to_euler(at(2.5).q);
    assert!((e[1] - 15.0 * DEG).abs() < 1e-9 && (e[2] - 12.5 * DEG).abs() < 1e-9, "{e:?}");
    let e = q_to_euler(at(20.0).q);
    assert!(e[1].abs() < 1e-9 && (e[2] - 100.0 * DEG).abs() < 1e-9, "{e:?}");
    let e = q_to_euler(at(40.0).q);
    assert!((e[2] + 160.0 * DEG).abs() < 1e-9, "{e:?}");
}

#[test]
fn pendulum_specific_force_is_that_of_a_point_on_the_rod() {
    let l = 0.5;
    assert_eq!(PENDULUM_LENGTH_M, l);
    // Phase boundaries at 10 + 53 k + (0, 2, 3, 41, 43) s: lift start and end, release (a step
    // of α̈), catch start and end (steps of the third derivative only).
    let events: Vec<f64> = (0..4)
        .flat_map(|k| [0.0, 2.0, 3.0, 41.0, 43.0].map(|d| 10.0 + 53.0 * k as f64 + d))
        .collect();
    let samples = check_consistent(Scenario::Pendulum, [-l, 0.0, 0.0], &events);
    let rate = 200.0;
    let mut crossings = 0;
    let mut prev_alpha = 0.0;
    for (k, s) in samples.iter().enumerate() {
        let m = matrix(s.q);
        let t = s.row.t;
        // The rod (body x) stays in the N-normal plane: x_ned = (0, sin α, −cos α).
        assert!(m[0][0].abs() < 1e-12, "t {t}");
        let alpha = m[1][0].atan2(-m[2][0]);
        // Rate about body z only (the swing axis).
        assert!(s.omega[0].abs() < 1e-12 && s.omega[1].abs() < 1e-12);
        let (da, dda) = (s.omega[2], s.omega_dot[2]);
        // Along the rod: g cos α + L α̇²; across: −g sin α − L α̈; none out of the plane.
        let a = s.row.accel.map(f64::from);
        assert!((a[0] - (G0 * alpha.cos() + l * da * da)).abs() < 2e-5, "t {t}: {a:?}");
        assert!((a[1] - (-G0 * alpha.sin() - l * dda)).abs() < 2e-5, "t {t}: {a:?}");
        assert!(a[2].abs() < 2e-5, "t {t}");
        // Cross-check α̈ against α by second differences.
        if k > 0 && k + 1 < samples.len() && !events.iter().any(|e| (t - e).abs() < 0.03) {
            let mm = matrix(samples[k - 1].q);
            let mp = matrix(samples[k + 1].q);
            let (am, ap) = (mm[1][0].atan2(-mm[2][0]), mp[1][0].atan2(-mp[2][0]));
            assert!(((ap - 2.0 * alpha + am) * rate * rate - dda).abs() < 5e-3, "t {t}");
        }
        if (13.0..52.0).contains(&t) && alpha * prev_alpha < 0.0 {
            crossings += 1;
        }
        prev_alpha = alpha;
        // Hanging still before the first lift: the accelerometer reads (g, 0, 0).
        if t < 10.0 {
            assert!((a[0] - G0).abs() < 1e-5 && a[1].abs() < 1e-5);
        }
    }
    let at = |t: f64| samples.iter().find(|s| (s.row.t - t).abs() < 1e-9).unwrap();
    let alpha_at = |t: f64| {
        let m = matrix(at(t).q);
        m[1][0].atan2(-m[2][0]) / DEG
    };
    // Held at the phase amplitudes 35°, −30°, 40° before each release.
    assert!((alpha_at(12.5) - 35.0).abs() < 1e-9);
    assert!((alpha_at(65.5) + 30.0).abs() < 1e-9);
    assert!((alpha_at(118.5) - 40.0).abs() < 1e-9);
    // At rest between phases.
    for t in [53.0, 58.0, 62.9] {
        assert!(alpha_at(t).abs() < 1e-12 && at(t).omega[2] == 0.0, "t {t}");
    }
    // Frequency √(g/L)/2π = 0.7049 Hz: two zero crossings per period over 39 s.
    let f = (G0 / l).sqrt() / std::f64::consts::TAU;
    assert!(((crossings as f64) - 2.0 * 39.0 * f).abs() <= 2.0, "{crossings}");
    // Damped: 30 s after the release the amplitude is about 35° e^(−2) = 4.7°.
    let peak = |a: f64, b: f64| {
        samples
            .iter()
            .filter(|s| s.row.t >= a && s.row.t < b)
            .map(|s| {
                let m = matrix(s.q);
                m[1][0].atan2(-m[2][0]).abs() / DEG
            })
            .fold(0.0, f64::max)
    };
    let late = peak(42.0, 44.0);
    assert!(late > 3.5 && late < 6.0, "{late}");
    assert!(peak(13.0, 15.0) > 30.0);
}

#[test]
fn new_scenarios_have_names_and_comments() {
    for (sc, name) in [
        (Scenario::Tumble, "tumble"),
        (Scenario::SideMount, "side-mount"),
        (Scenario::StartMoving, "start-moving"),
        (Scenario::Pendulum, "pendulum"),
    ] {
        assert_eq!(Scenario::from_name(name), Some(sc));
        assert_eq!(sc.default_duration(), 200.0);
        let (_, cfg) = sc.simulator(50.0, None, 1, false);
        assert!(sc.comments(&cfg).iter().any(|c| c.starts_with(name)), "{name}");
        assert!(!sc.comments(&cfg).iter().any(|c| c.contains("realism")));
    }
}

// ---------------------------------------------------------------------------------------------
// Realism.

/// Clean sensors (no bias, no white noise) with `realism`.
fn clean_with(realism: Realism) -> SensorModel {
    SensorModel { realism: Some(realism), ..clean_sensors() }
}

#[test]
fn realism_is_off_by_default_and_off_values_change_nothing() {
    assert_eq!(SensorModel::default().realism, None);
    assert_eq!(Realism::default(), Realism::INEMO);
    // Realism::OFF reproduces the plain model bit for bit (body-rate truth, magnetometer).
    let rows = |realism: Option<Realism>| {
        let mut s = Scenario::Coupled.sensors();
        s.mag = true;
        s.realism = realism;
        let sim = Simulator::new(Scenario::Coupled.trajectory(), config(s, 50.0, 40.0));
        sim.map(|s| s.row).collect::<Vec<_>>()
    };
    assert_eq!(rows(None), rows(Some(Realism::OFF)));
    assert_ne!(rows(None), rows(Some(Realism::INEMO)));
    // The options: `realistic` switches on the iNEMO values and says so in the header.
    let opts = SimOptions { realistic: true, duration_s: Some(5.0), ..SimOptions::default() };
    let (sim, cfg) = Scenario::PitchSine.simulator_with(&opts);
    assert_eq!(cfg.sensors.realism, Some(Realism::INEMO));
    assert_eq!(sim.len(), 250);
    assert!(Scenario::PitchSine.comments(&cfg).iter().any(|c| c.starts_with("realism on")));
    let (_, plain) = Scenario::PitchSine.simulator(50.0, Some(5.0), 1, false);
    assert_eq!(plain.sensors.realism, None);
    assert_eq!(
        SimOptions::default(),
        SimOptions { rate_hz: 50.0, duration_s: None, seed: 1, mag: false, realistic: false }
    );
}

#[test]
fn realism_quantisation_is_the_datasheet_figures() {
    let r = Realism::INEMO;
    // 3.3 V / 4096 = 0.80566 mV per ADC step; / 3.33 mV/(°/s) = 0.24194 °/s; / 3.752 mV/(°/s)
    // = 0.21473 °/s.
    assert!((r.gyro_lsb_dps[0] - 0.241_94).abs() < 1e-5 && r.gyro_lsb_dps[1] == r.gyro_lsb_dps[0]);
    assert!((r.gyro_lsb_dps[2] - 0.214_73).abs() < 1e-5);
    // LSM303DLH at ±2 g: 12 bits at 1 mg/digit, −2048 … 2047 mg.
    assert_eq!((r.accel_lsb_g, r.accel_full_scale_g, r.gyro_full_scale_dps), (0.001, 2.048, 300.0));
}

#[test]
fn fixed_errors_are_bounded_constant_and_per_seed() {
    let fixed = Realism {
        gyro_scale: 0.02,
        gyro_cross_axis: 0.01,
        accel_bias_g: 0.02,
        accel_scale: 0.01,
        ..Realism::OFF
    };
    // Sensitivity matrix column j from a constant 1 rad/s rate about body axis j.
    let matrix_of = |seed: u64| {
        let mut m = [[0.0; 3]; 3];
        for j in 0..3 {
            let mut w = [Profile::Zero; 3];
            w[j] = Profile::Const(1.0);
            let traj = Trajectory {
                attitude: Attitude::BodyRates { rates: w, q0: [1.0, 0.0, 0.0, 0.0] },
                accel_body: [Profile::Zero; 3],
                accel_ned: [Profile::Zero; 3],
            };
            let cfg = SimConfig { seed, ..config(clean_with(fixed), 50.0, 1.0) };
            let rows: Vec<_> = Simulator::new(traj, cfg).map(|s| s.row.gyro).collect();
            assert!(rows.iter().all(|g| *g == rows[0]), "constant over time");
            for i in 0..3 {
                m[i][j] = rows[0][i] as f64;
            }
        }
        m
    };
    let m = matrix_of(3);
    for i in 0..3 {
        for j in 0..3 {
            let e = if i == j { m[i][j] - 1.0 } else { m[i][j] };
            let bound = if i == j { 0.02 } else { 0.01 };
            assert!(e.abs() <= bound + 1e-7 && e.abs() > 1e-6, "{i} {j}: {m:?}");
        }
    }
    assert_ne!(m, matrix_of(4));
    // Accelerometer: level (reads −g(1+s) + b on z) and upside down (+g(1+s) + b).
    let z = |roll: f64| {
        let traj = Trajectory::euler(Profile::Const(roll), Profile::Zero, Profile::Zero);
        let s = Simulator::new(traj, config(clean_with(fixed), 50.0, 1.0)).nth(10).unwrap();
        s.row.accel.map(f64::from)
    };
    let (up, down) = (z(0.0), z(std::f64::consts::PI));
    let b = (up[2] + down[2]) / 2.0 / G0;
    let s = (down[2] - up[2]) / (2.0 * G0) - 1.0;
    assert!(b.abs() <= 0.02 && b.abs() > 1e-5, "bias {b} g");
    assert!(s.abs() <= 0.01 && s.abs() > 1e-6, "scale {s}");
    for i in 0..2 {
        assert!(up[i].abs() / G0 <= 0.02 + 1e-6 && up[i] != 0.0, "{up:?}");
        assert!((up[i] - down[i]).abs() < 1e-5, "bias, not gravity: {up:?} {down:?}");
    }
}

#[test]
fn quantisation_and_full_scale() {
    let q = Realism {
        gyro_lsb_dps: Realism::INEMO.gyro_lsb_dps,
        gyro_full_scale_dps: 300.0,
        accel_lsb_g: 0.001,
        accel_full_scale_g: 2.048,
        ..Realism::OFF
    };
    let sensors = SensorModel { realism: Some(q), ..Scenario::PitchSine.sensors() };
    let steps = [0, 1, 2].map(|i| 3.3 / 4096.0 / [3.33e-3, 3.33e-3, 3.752e-3][i] * DEG);
    let mg = 1e-3 * G0;
    let mut distinct = std::collections::BTreeSet::new();
    for s in Simulator::new(Scenario::PitchSine.trajectory(), config(sensors, 50.0, 30.0)) {
        for i in 0..3 {
            let k = s.row.gyro[i] as f64 / steps[i];
            assert!((k - k.round()).abs() < 1e-4, "gyro {i}: {k}");
            let k = s.row.accel[i] as f64 / mg;
            assert!((k - k.round()).abs() < 1e-3, "accel {i}: {k}");
        }
        distinct.insert((s.row.gyro[0] as f64 / steps[0]).round() as i64);
    }
    // The noise (0.58 °/s) spans several steps.
    assert!(distinct.len() > 5);
    // Beyond full scale: ±3 g of surge clamps to 2047 / −2048 mg; 400 °/s clamps to 300 °/s.
    for (a, want) in [(3.0, 2047.0), (-3.0, -2048.0)] {
        let traj = Trajectory {
            attitude: Attitude::BodyRates {
                rates: [Profile::Zero, Profile::Zero, Profile::Const(400.0 * DEG)],
                q0: [1.0, 0.0, 0.0, 0.0],
            },
            accel_body: [Profile::Const(a * G0), Profile::Zero, Profile::Zero],
            accel_ned: [Profile::Zero; 3],
        };
        let mut sensors = clean_with(q);
        sensors.lever_arm = [0.0; 3];
        let s = Simulator::new(traj, config(sensors, 50.0, 1.0)).nth(3).unwrap();
        assert!((s.row.accel[0] as f64 / mg - want).abs() < 1e-3, "{:?}", s.row.accel);
        assert!((s.row.gyro[2] as f64 / DEG - 300.0).abs() < 1e-4, "{:?}", s.row.gyro);
    }
}

#[test]
fn jitter_samples_the_sensors_off_the_recorded_time() {
    let j = Realism { jitter_s: 1e-3, ..Realism::OFF };
    let samples: Vec<_> =
        Simulator::new(Scenario::PitchSine.trajectory(), config(clean_with(j), 50.0, 200.0))
            .collect();
    // Pitch sine: θ = 10° sin(w (t − 10)), ω_y = θ̇ = 10° w cos(·). The gyro reads the mean
    // rate over the period ending at the sampling instant, (θ(t) − θ(t − 1/f))·f; moved by
    // the jitter δ it changes by δ·(ω(t) − ω(t − 1/f))·f.
    let w = std::f64::consts::TAU * 0.1;
    let a = 10.0 * DEG;
    let dt = 1.0 / 50.0;
    let theta = |t: f64| a * (w * (t - 10.0)).sin();
    let omega = |t: f64| a * w * (w * (t - 10.0)).cos();
    let mut d = Vec::new();
    for s in samples.iter().filter(|s| s.row.t > 10.5) {
        let t = s.row.t;
        // Truth column at the nominal time.
        let want = euler_to_q(0.0, theta(t), 0.0);
        assert!((0..4).all(|i| (s.q[i] - want[i]).abs() < 1e-12), "t {t}");
        let slope = (omega(t) - omega(t - dt)) / dt;
        if slope.abs() > 0.7 * a * w * w {
            // Reading offset over the mean rate's slope: the sampling offset.
            let mean = (theta(t) - theta(t - dt)) / dt;
            d.push((s.row.gyro[1] as f64 - mean) / slope);
        }
    }
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    assert!(n > 3000.0);
    assert!(mean.abs() < 1e-4, "{mean}");
    assert!((sd / 1e-3 - 1.0).abs() < 0.1, "jitter sd {sd}");
    assert!(d.iter().all(|x| x.abs() <= 0.4 / 50.0 + 1e-6));
}

#[test]
fn repeated_rows_repeat_the_previous_readings() {
    let r = Realism { repeat_fraction: 0.02, ..Realism::OFF };
    let sensors = SensorModel { realism: Some(r), mag: true, ..Scenario::PitchSine.sensors() };
    let samples: Vec<_> =
        Simulator::new(Scenario::PitchSine.trajectory(), config(sensors, 50.0, 200.0)).collect();
    let mut repeats = 0;
    for w in samples.windows(2) {
        let same = w[1].row.gyro == w[0].row.gyro
            && w[1].row.accel == w[0].row.accel
            && w[1].row.mag == w[0].row.mag;
        assert_eq!(same, w[1].repeated);
        if same {
            repeats += 1;
            // The truth moves on.
            assert!(w[1].row.t > w[0].row.t);
        }
    }
    // 2 % of 9999 rows: 200 ± 14 (binomial), 5 σ.
    assert!((repeats as f64 - 200.0).abs() < 70.0, "{repeats}");
}

#[test]
fn vibration_has_the_rms_and_band() {
    let v = Realism { vibration_accel_g: 0.02, vibration_gyro_dps: 0.1, ..Realism::OFF };
    let run = |rate: f64, secs: f64| {
        let samples: Vec<_> =
            Simulator::new(Trajectory::STILL, config(clean_with(v), rate, secs)).collect();
        let a: Vec<[f64; 3]> = samples
            .iter()
            .map(|s| [0, 1, 2].map(|i| s.row.accel[i] as f64 - s.accel_clean[i]))
            .collect();
        let g: Vec<[f64; 3]> = samples.iter().map(|s| s.row.gyro.map(|x| x as f64 / DEG)).collect();
        (a, g)
    };
    let (a, g) = run(50.0, 200.0);
    let (am, av) = stats(&a);
    let (gm, gv) = stats(&g);
    for i in 0..3 {
        assert!((av[i].sqrt() / (0.02 * G0) - 1.0).abs() < 0.1, "accel rms {i}: {av:?}");
        assert!((gv[i].sqrt() / 0.1 - 1.0).abs() < 0.1, "gyro rms {i}: {gv:?}");
        assert!(am[i].abs() < 0.1 * 0.02 * G0 && gm[i].abs() < 0.01);
    }
    // At 1 kHz the 20–40 Hz tones are resolved: lag-1 autocorrelation between cos(2π·40/1000)
    // = 0.969 and cos(2π·20/1000) = 0.992 (white noise would give 0).
    let (a, _) = run(1000.0, 20.0);
    for i in 0..3 {
        let x: Vec<f64> = a.iter().map(|v| v[i]).collect();
        let c0: f64 = x.iter().map(|v| v * v).sum();
        let c1: f64 = x.windows(2).map(|w| w[0] * w[1]).sum();
        let rho = c1 / c0;
        assert!(rho > 0.96 && rho < 0.995, "axis {i}: {rho}");
    }
}

/// Non-overlapping Allan variance of `x` (sampled at `rate`) for clusters of `m` samples.
fn allan_var(x: &[f64], m: usize) -> f64 {
    let means: Vec<f64> = x.chunks_exact(m).map(|c| c.iter().sum::<f64>() / m as f64).collect();
    let d: Vec<f64> = means.windows(2).map(|w| (w[1] - w[0]).powi(2)).collect();
    d.iter().sum::<f64>() / (2.0 * d.len() as f64)
}

#[test]
fn gyro_bias_random_walk_grows_as_the_root_of_time() {
    let r = Realism { gyro_rrw_dps_rt_s: [0.002, 0.002, 0.0005], ..Realism::OFF };
    let rate = 50.0;
    let g: Vec<[f64; 3]> = Simulator::new(Trajectory::STILL, config(clean_with(r), rate, 3600.0))
        .map(|s| s.row.gyro.map(|x| x as f64 / DEG))
        .collect();
    // Starts at zero.
    assert!(g[0].iter().all(|&b| b == 0.0));
    // Increments over 10 s: variance K² · 10 s (360 windows: 7.5 % standard error).
    for (i, k) in [0.002, 0.002, 0.0005].into_iter().enumerate() {
        let lag = (10.0 * rate) as usize;
        let inc: Vec<f64> = g
            .iter()
            .step_by(lag)
            .map(|v| v[i])
            .collect::<Vec<_>>()
            .windows(2)
            .map(|w| w[1] - w[0])
            .collect();
        let var = inc.iter().map(|d| d * d).sum::<f64>() / inc.len() as f64;
        assert!((var / (k * k * 10.0) - 1.0).abs() < 0.3, "axis {i}: {var}");
    }
}

#[test]
fn gyro_flicker_has_a_flat_allan_deviation() {
    let b = 0.005;
    let r = Realism { gyro_flicker_dps: [b; 3], ..Realism::OFF };
    let rate = 10.0;
    let (mut a10, mut a100, mut a1) = (0.0, 0.0, 0.0);
    let mut n = 0.0;
    for seed in 1..=3 {
        let cfg = SimConfig { seed, ..config(clean_with(r), rate, 3600.0) };
        let g: Vec<[f64; 3]> = Simulator::new(Trajectory::STILL, cfg)
            .map(|s| s.row.gyro.map(|x| x as f64 / DEG))
            .collect();
        for i in 0..3 {
            let x: Vec<f64> = g.iter().map(|v| v[i]).collect();
            a1 += allan_var(&x, 10);
            a10 += allan_var(&x, 100);
            a100 += allan_var(&x, 1000);
            n += 1.0;
        }
    }
    let (d1, d10, d100) = ((a1 / n).sqrt(), (a10 / n).sqrt(), (a100 / n).sqrt());
    // Flat near B from 10 s to 100 s (white noise would fall by √10 = 3.16 per decade; a
    // random walk would rise by the same), a little lower at 1 s (0.84 B).
    assert!((d10 / b - 1.0).abs() < 0.2, "{d10}");
    assert!((d100 / b - 1.0).abs() < 0.25, "{d100}");
    assert!((d100 / d10) > 0.75 && (d100 / d10) < 1.33, "{d10} {d100}");
    assert!((d1 / b - 0.84).abs() < 0.15, "{d1}");
}
