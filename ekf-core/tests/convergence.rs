//! Every filter that corrects tilt converges from a 30° tilt error on a still board with the
//! board's sensor noise; the gyro-only baseline cannot and does not.

mod common;

use common::*;
use ekf_core::{
    complementary::ComplementaryParams, mathf::deg, mathf::to_deg, settings::Settings,
    ssukf::SsUkfParams, ukf::UkfParams, AttitudeFilter, Complementary, Ekf, Euler, GyroOnly,
    Quaternion, SsUkf, Ukf, Vec3,
};

fn tilt_after(f: &mut dyn AttitudeFilter, seconds: f32) -> f32 {
    let truth = Euler::new(deg(-4.0), deg(6.0), deg(-100.0)).to_quaternion();
    let sensors = Sensors::board();
    // 30° off about a horizontal NED axis: a pure tilt error.
    let axis = Vec3::new(1.0, 1.0, 0.0) * (deg(30.0) / 2f32.sqrt());
    let start = Quaternion::from_rotation_vector(axis) * truth;
    assert!((to_deg(tilt_error(start, truth)) - 30.0).abs() < 1e-3);
    f.set_attitude(start, sensors.gyro_bias);
    let run = simulate(truth, seconds, 50.0, sensors, 11, still);
    for s in &run.samples {
        f.update(s);
    }
    to_deg(tilt_error(f.attitude(), truth))
}

#[test]
fn every_correcting_filter_converges_from_30_degrees() {
    let s = Settings::default();
    let cases: Vec<(Box<dyn AttitudeFilter>, f32, f32)> = vec![
        (Box::new(Ekf::new(s)), 30.0, 0.2),
        (Box::new(Ukf::new(s, UkfParams::default())), 30.0, 0.2),
        (Box::new(SsUkf::new(s, SsUkfParams::default())), 30.0, 0.2),
        // The source's gain 0.0001 per 50 Hz sample: a 200 s time constant, and a noise floor
        // of σ/√(2K) ≈ 0.8° per axis from the board's 0.58 °/s x/y gyro noise.
        (Box::new(Complementary::new(s, ComplementaryParams::default())), 1500.0, 3.0),
    ];
    for (mut f, seconds, tol) in cases {
        let err = tilt_after(f.as_mut(), seconds);
        assert!(err < tol, "{}: tilt error {err}° after {seconds} s", f.name());
    }
}

#[test]
fn gyro_only_keeps_its_initial_error() {
    let mut f = GyroOnly::new(Settings::default());
    let err = tilt_after(&mut f, 30.0);
    assert!(err > 29.0, "{err}");
}
