//! The simulator against independent truth: hand values, analytic rotations and noise
//! statistics.
// Index loops over parallel per-axis arrays read best here.
#![allow(clippy::needless_range_loop)]

use host_tests::sim::{
    axis_angle, cross, q_to_euler, qmul, rotate_inverse, Attitude, Profile, Scenario, SensorModel,
    SimConfig, Simulator, Trajectory, DEG, G0, LEVER_ARM_M,
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
fn lever_arm_terms_equal_hand_values() {
    // Constant yaw rate 1 rad/s, level: ω × (ω × r) = −ω² (r_x, r_y, 0)
    //   = (−0.29725, 0.196, 0) m/s².
    let traj = Trajectory {
        attitude: Attitude::BodyRates {
            rates: [Profile::Zero, Profile::Zero, Profile::Const(1.0)],
            q0: [1.0, 0.0, 0.0, 0.0],
        },
        accel_body: [Profile::Zero; 3],
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
    // Still start: every scenario is level, yaw 0, for 10 s.
    for sc in Scenario::ALL {
        for t in [0.0, 5.0, 9.98] {
            let s = at(sc, t);
            assert!(s.omega.iter().all(|w| w.abs() < 1e-12), "{sc:?} {t}");
            assert!((s.q[0] - 1.0).abs() < 1e-12, "{sc:?} {t}");
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
