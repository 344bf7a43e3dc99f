use nalgebra::SMatrix;

use super::model::{gamma, process};
use super::repair::all_finite;
use super::*;
use crate::{settings::Settings, Euler, Flags, ImuSample, Quaternion, Vec3};

/// A Core with a trivial symmetric point set, to exercise the shared machinery.
fn core() -> Core<f64, 15> {
    let g = 3.0_f64.sqrt();
    let mut z = SMatrix::<f64, N, 15>::zeros();
    for j in 0..N {
        z[(j, 1 + j)] = g;
        z[(j, 8 + j)] = -g;
    }
    let w = 1.0 / 6.0;
    let mut wm = [w; 15];
    wm[0] = 1.0 - 14.0 * w;
    let mut wc = wm;
    wc[0] += 2.0;
    let tuning = Tuning {
        accel_var_scale: 10.0,
        bias_random_walk: 1e-9,
        initial_tilt_sigma: 0.03,
        initial_yaw_sigma: 0.08,
        initial_bias_sigma: 0.003,
    };
    let mut c = Core::new(Settings::default(), tuning, SigmaSet { z, wm, wc });
    c.start(Euler::new(0.2, -0.1, 0.5).to_quaternion(), Vec3::ZERO);
    c
}

fn level_sample() -> ImuSample {
    ImuSample::new(0.02, Vec3::ZERO, Vec3::new(0.0, 0.0, -crate::GRAVITY))
}

#[test]
fn process_model_is_the_digest_first_order_step() {
    let x = Vector::<f64>::from_column_slice(&[1.0, 0.0, 0.0, 0.0, 0.1, 0.0, 0.0]);
    // ω = gyro − b = (0.2, 0, 0): q ← (1, ½ ω dt).
    let y = process(&x, &[0.3, 0.0, 0.0], 0.5);
    assert!((y[0] - 1.0).abs() < 1e-15 && (y[1] - 0.05).abs() < 1e-15);
    assert!(y[2] == 0.0 && y[3] == 0.0 && y[4] == 0.1);
    // Same direction as the exact rotation about body x.
    let q = Quaternion::new(1.0, 0.05, 0.0, 0.0).normalized();
    let e = Quaternion::from_rotation_vector(Vec3::new(0.1, 0.0, 0.0));
    assert!(q.angle_to(e) < 1e-3);
}

#[test]
fn initial_covariance_maps_angles_to_quaternion_components() {
    let c = core();
    let p = c.initial_cov();
    assert!(p.cholesky().is_some());
    // A pure yaw perturbation of σ_ψ: quaternion variance along ½Γ_z is σ_ψ²/4 · |Γ_z|².
    let g = gamma(&c.x);
    let gz = g.column(2).into_owned();
    let v = (gz.transpose() * p.fixed_view::<4, 4>(0, 0) * gz)[(0, 0)];
    assert!((v - 0.25 * 0.08 * 0.08).abs() < 1e-9, "{v}");
    // The tilt directions ½Γ_x, ½Γ_y and the radial direction q each get σ_t²/4 (the radial
    // one from the ¼σ_t² q qᵀ term); Γ's columns and q are orthonormal, so these are
    // uncorrelated.
    let pq = p.fixed_view::<4, 4>(0, 0).into_owned();
    let q = c.x.fixed_rows::<4>(0).into_owned();
    let dirs = [g.column(0).into_owned(), g.column(1).into_owned(), gz, q];
    let want = [0.03 * 0.03, 0.03 * 0.03, 0.08 * 0.08, 0.03 * 0.03].map(|s2| 0.25 * s2);
    for (i, a) in dirs.iter().enumerate() {
        for (j, b) in dirs.iter().enumerate() {
            let v = (a.transpose() * pq * b)[(0, 0)];
            let w = if i == j { want[i] } else { 0.0 };
            assert!((v - w).abs() < 1e-9, "{i} {j}: {v}");
        }
    }
    assert!((p[(5, 5)] - 0.003 * 0.003).abs() < 1e-12);
}

#[test]
fn indefinite_covariance_is_repaired_and_flagged() {
    let mut c = core();
    // Lose rank and go slightly indefinite in one direction: jitter repairs it.
    c.covariance_mut()[(6, 6)] = -1e-12;
    let f = c.update(&level_sample());
    assert!(f.contains(Flags::HEALTH_RESET), "{f:?}");
    assert!(c.p.cholesky().is_some());
    // Grossly indefinite: reset to the initial covariance.
    c.covariance_mut()[(0, 0)] = -1.0;
    let f = c.update(&level_sample());
    assert!(f.contains(Flags::HEALTH_RESET), "{f:?}");
    assert!(c.p.cholesky().is_some());
    assert!((0..N).all(|i| c.p[(i, i)] > 0.0));
    // Non-finite: reset too.
    c.covariance_mut()[(2, 3)] = f64::NAN;
    let f = c.update(&level_sample());
    assert!(f.contains(Flags::HEALTH_RESET));
    assert!(all_finite(&c.p));
    // A healthy covariance does not raise the flag.
    let f = c.update(&level_sample());
    assert!(!f.contains(Flags::HEALTH_RESET), "{f:?}");
}

#[test]
fn transport_carries_the_covariance_with_the_mean() {
    // P built at q, the mean then rotated (about NED axes, as a correction does): carried
    // along, P is again the initial covariance, now at the new mean.
    let mut c = core();
    let q_prior = c.x.fixed_rows::<4>(0).into_owned();
    let q =
        Quaternion::new(q_prior[0] as f32, q_prior[1] as f32, q_prior[2] as f32, q_prior[3] as f32);
    let q2 = Quaternion::from_rotation_vector(Vec3::new(0.02, -0.03, 0.01)) * q;
    c.set_state(q2, Vec3::ZERO);
    c.transport(&q_prior);
    let p0 = c.initial_cov();
    assert!((c.p - p0).abs().max() < 1e-8, "{}", (c.p - p0).abs().max());
    // Without it the yaw variance would appear in the tilt directions of the new mean.
    let mut d = core();
    let p_old = d.p;
    d.set_state(q2, Vec3::ZERO);
    assert!((p_old - d.initial_cov()).abs().max() > 1e-6);
}

#[test]
fn set_yaw_rotates_state_and_covariance() {
    let mut c = core();
    let before = Euler::from_quaternion(c.attitude());
    let p_before = c.p;
    c.set_yaw(-2.0);
    let after = Euler::from_quaternion(c.attitude());
    assert!((after.yaw + 2.0).abs() < 1e-5);
    assert!((after.roll - before.roll).abs() < 1e-5);
    assert!((after.pitch - before.pitch).abs() < 1e-5);
    // Rotated with the state, P is again the initial covariance at the new attitude.
    let p0 = c.initial_cov();
    assert!((c.p - p0).abs().max() < 1e-9, "{}", (c.p - p0).abs().max());
    assert!((c.p - p_before).abs().max() > 1e-6);
}

/// Both unscented filters correct a tilt error in the same time, in seconds, at any sample
/// rate: the accelerometer's variance per sample grows with the rate
/// (`NoiseSettings::accel_var_per_sample`), as the gyro's process noise does. A still, level
/// board for 30 s, then the accelerometer tilted by 2° about x (the estimate 2° off, its
/// covariance settled): the time until the estimate is within 1° of the new tilt. With the
/// variance held per sample, the time at 250 Hz would be about 1/√5 of that at 50 Hz.
#[test]
fn a_tilt_error_decays_in_the_same_time_at_any_sample_rate() {
    use crate::filter::AttitudeFilter;
    let tilted = Quaternion::from_rotation_vector(Vec3::new(2f32.to_radians(), 0.0, 0.0));
    let down = tilted.rotate_inverse(Vec3::new(0.0, 0.0, -crate::GRAVITY));
    fn half_time(f: &mut dyn AttitudeFilter, rate: f32, down: Vec3, tilted: Quaternion) -> f32 {
        let dt = 1.0 / rate;
        let level = ImuSample::new(dt, Vec3::ZERO, Vec3::new(0.0, 0.0, -crate::GRAVITY));
        for _ in 0..(30.0 * rate) as usize {
            f.update(&level);
        }
        assert!(f.attitude().angle_to(Quaternion::IDENTITY) < 0.001f32.to_radians());
        let mut t = 0.0;
        for _ in 0..(10.0 * rate) as usize {
            f.update(&ImuSample::new(dt, Vec3::ZERO, down));
            t += dt;
            if f.attitude().angle_to(tilted) < 1f32.to_radians() {
                return t;
            }
        }
        panic!("{}: the tilt error did not halve in 10 s at {rate} Hz", f.name());
    }
    let s = Settings::default();
    let t = |rate: f32, ss: bool, scale: f32| {
        if ss {
            let p = crate::ssukf::SsUkfParams { accel_var_scale: scale, ..Default::default() };
            half_time(&mut crate::ssukf::SsUkf::new(s, p), rate, down, tilted)
        } else {
            let p = crate::ukf::UkfParams { accel_var_scale: scale, ..Default::default() };
            half_time(&mut crate::ukf::Ukf::new(s, p), rate, down, tilted)
        }
    };
    for ss in [false, true] {
        let (t50, t250) = (t(50.0, ss, 1.0), t(250.0, ss, 1.0));
        assert!(
            (t250 / t50 - 1.0).abs() < 0.1,
            "ss {ss}: halving time {t50} s at 50 Hz, {t250} s at 250 Hz"
        );
        // `accel_var_scale` multiplies the per-sample variance: 16 times the variance, about
        // 4 times the correction time (the gain goes as 1/√r).
        let t16 = t(50.0, ss, 16.0);
        assert!(t16 > 2.5 * t50, "ss {ss}: {t16} s with accel_var_scale 16, {t50} s with 1");
    }
}
