//! Property tests: whatever the input — extremes, NaN, ±inf, saturation, absurd time steps —
//! every filter keeps a finite unit quaternion and a finite bias, and the EKF, the UKF and the
//! SS-UKF keep their covariance finite and symmetric with a positive diagonal.

#![allow(clippy::needless_range_loop)]

use ekf_core::{
    complementary::ComplementaryParams, settings::Settings, ssukf::SsUkfParams, ukf::UkfParams,
    AttitudeFilter, Complementary, Ekf, GyroOnly, ImuSample, SsUkf, Ukf, Vec3,
};
use proptest::prelude::*;

fn scalar(range: f32) -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => -range..range,
        1 => Just(0.0f32),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(f32::MAX),
        1 => Just(-1e30f32),
        1 => Just(5.236f32), // 300 °/s: gyro saturation
    ]
}

fn vec3(range: f32) -> impl Strategy<Value = Vec3> {
    (scalar(range), scalar(range), scalar(range)).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn dt() -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => Just(0.02f32),
        2 => 1e-6f32..2.0,
        1 => Just(0.0f32),
        1 => Just(-0.02f32),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(1e7f32),
    ]
}

fn sample() -> impl Strategy<Value = ImuSample> {
    // Mostly plausible samples near 1 g, so the corrections actually run.
    let plausible =
        (-2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0, -3.0f32..3.0, -3.0f32..3.0, -10.5f32..-9.0)
            .prop_map(|(gx, gy, gz, ax, ay, az)| {
                ImuSample::new(0.02, Vec3::new(gx, gy, gz), Vec3::new(ax, ay, az))
            });
    let wild = (dt(), vec3(10.0), vec3(200.0), proptest::option::of(vec3(100.0)))
        .prop_map(|(dt, g, a, m)| ImuSample { dt, gyro: g, accel: a, mag: m });
    prop_oneof![3 => plausible, 2 => wild]
}

fn settings(window: bool, mag: bool) -> Settings {
    let mut s = Settings::default();
    if !window {
        s.init.window_s = 0.0;
    }
    s.mag.enabled = mag;
    s
}

/// A 7×7 covariance (the unscented filters'): finite, exactly symmetric, positive diagonal.
fn check_cov7(p: &nalgebra::SMatrix<f32, 7, 7>) -> Result<(), TestCaseError> {
    for i in 0..7 {
        prop_assert!(p[(i, i)].is_finite() && p[(i, i)] > 0.0, "P[{i}][{i}] = {}", p[(i, i)]);
        for j in 0..7 {
            prop_assert!(p[(i, j)].is_finite());
            prop_assert_eq!(p[(i, j)], p[(j, i)]);
        }
    }
    Ok(())
}

fn check_filter(f: &dyn AttitudeFilter) -> Result<(), TestCaseError> {
    let q = f.attitude();
    prop_assert!(q.is_finite(), "{:?}", q);
    prop_assert!((q.norm_sq() - 1.0).abs() < 1e-4, "|q|² = {}", q.norm_sq());
    prop_assert!(f.gyro_bias().is_finite());
    let e = f.euler();
    prop_assert!(e.roll.is_finite() && e.pitch.is_finite() && e.yaw.is_finite());
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn ekf_state_stays_valid(samples in proptest::collection::vec(sample(), 1..300),
                             window in any::<bool>(), mag in any::<bool>(),
                             split in any::<bool>()) {
        let mut s = settings(window, mag);
        s.ekf.yaw_split = split;
        let mut f = Ekf::new(s);
        for smp in &samples {
            f.update(smp);
            check_filter(&f)?;
            let p = &f.covariance().m;
            for i in 0..6 {
                prop_assert!(p[i][i].is_finite() && p[i][i] > 0.0, "P[{i}][{i}] = {}", p[i][i]);
                for j in 0..6 {
                    prop_assert!(p[i][j].is_finite());
                    prop_assert_eq!(p[i][j], p[j][i]);
                }
            }
        }
    }

    #[test]
    fn complementary_and_gyro_only_stay_valid(
        samples in proptest::collection::vec(sample(), 1..300), window in any::<bool>()) {
        let mut cf = Complementary::new(settings(window, false),
            ComplementaryParams { gain: 0.05, ..Default::default() });
        let mut g = GyroOnly::new(settings(window, false));
        for smp in &samples {
            cf.update(smp);
            g.update(smp);
            check_filter(&cf)?;
            check_filter(&g)?;
        }
    }

    #[test]
    fn unscented_filters_stay_valid(
        samples in proptest::collection::vec(sample(), 1..200), window in any::<bool>()) {
        let mut ukf = Ukf::new(settings(window, false), UkfParams::default());
        let mut ss = SsUkf::new(settings(window, false), SsUkfParams::default());
        for smp in &samples {
            ukf.update(smp);
            ss.update(smp);
            check_filter(&ukf)?;
            check_filter(&ss)?;
            check_cov7(&ukf.covariance())?;
            check_cov7(&ss.covariance())?;
        }
    }
}
