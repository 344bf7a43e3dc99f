//! Shared test scenarios for [`crate::Ukf`] and [`crate::SsUkf`].

use super::*;
use nalgebra::SMatrix;

use crate::{
    filter::AttitudeFilter, mathf, mathf::deg, mathf::to_deg, Euler, Flags, ImuSample, Quaternion,
    Settings, Vec3, GRAVITY,
};

use crate::test_rng::TestRng;

/// A test mean and a full, well-conditioned covariance with standard deviations `sq`
/// (quaternion components) and `sb` (bias).
fn test_moments(sq: f64, sb: f64) -> (Vector<f64>, Matrix<f64>) {
    let x = Vector::<f64>::from_column_slice(&[0.8, 0.3, -0.4, 0.3, 0.02, -0.01, 0.005]);
    let mut rng = TestRng::new(7);
    let a = Matrix::<f64>::from_fn(|_, _| rng.uniform());
    let s =
        Matrix::<f64>::from_diagonal(&Vector::<f64>::from_fn(|i, _| if i < 4 { sq } else { sb }));
    let c = a * a.transpose() * (1.0 / N as f64) + Matrix::<f64>::identity() * 0.1;
    let d = Vector::<f64>::from_fn(|i, _| 1.0 / libm::sqrt(c[(i, i)]));
    let c = Matrix::<f64>::from_fn(|i, j| c[(i, j)] * d[i] * d[j]);
    (x, s * c * s)
}

fn errors(m: &Vector<f64>, c: &Matrix<f64>, x: &Vector<f64>, p: &Matrix<f64>) -> (f64, f64) {
    let mut me = 0.0f64;
    let mut ce = 0.0f64;
    for i in 0..N {
        me = me.max((m[i] - x[i]).abs() / libm::sqrt(p[(i, i)]));
        for j in 0..N {
            let e = (c[(i, j)] - p[(i, j)]).abs() / libm::sqrt(p[(i, i)] * p[(j, j)]);
            ce = ce.max(e);
        }
    }
    (me, ce)
}

/// Draw the points of `set` (in `T`) for a test mean and covariance, and return the errors
/// of their plain weighted mean `Σ Wm_i X_i` and covariance `Σ Wc_i (X_i − x̄)(X_i − x̄)ᵀ`
/// (accumulated in f64): mean error in standard deviations, covariance error relative to
/// `√(P_ii P_jj)`. Also checks the deviation-form moments the filters use (in `T`) at a
/// converged-size covariance and returns the larger errors.
pub fn sigma_moment_errors<T: Real, const M: usize>(set: &SigmaSet<T, M>) -> (f64, f64) {
    let (x, p) = test_moments(0.03, 0.004);
    let xt = x.map(|v| T::of(v as f32));
    let pt = p.map(|v| T::of(v as f32));
    let Some(c) = pt.cholesky() else { return (f64::INFINITY, f64::INFINITY) };
    let pts = set.points(&xt, &c.l()).map(|v| v.to_f64());
    let (wm, wc) = (set.wm.map(|v| v.to_f64()), set.wc.map(|v| v.to_f64()));
    let mut mean = Vector::<f64>::zeros();
    for (c, w) in pts.column_iter().zip(wm) {
        mean += c * w;
    }
    let mut cov = Matrix::<f64>::zeros();
    for (c, w) in pts.column_iter().zip(wc) {
        let d = c - mean;
        cov += d * d.transpose() * w;
    }
    let (me, ce) = errors(&mean, &cov, &xt.map(|v| v.to_f64()), &pt.map(|v| v.to_f64()));
    let (me2, ce2) = deviation_moment_errors(set);
    (me.max(me2), ce.max(ce2))
}

/// Errors of the deviation-form moments (in `T`, as the filters compute them) of the points
/// drawn for a converged-size covariance (σ 10⁻³ on the quaternion, 10⁻⁴ rad/s on the bias).
pub fn deviation_moment_errors<T: Real, const M: usize>(set: &SigmaSet<T, M>) -> (f64, f64) {
    let (x, p) = test_moments(1e-3, 1e-4);
    let xt = x.map(|v| T::of(v as f32));
    let pt = p.map(|v| T::of(v as f32));
    let Some(c) = pt.cholesky() else { return (f64::INFINITY, f64::INFINITY) };
    let pts = set.points(&xt, &c.l());
    let mut dev = SMatrix::<T, N, M>::zeros();
    for i in 1..M {
        dev.set_column(i, &(pts.column(i) - pts.column(0)));
    }
    let (dbar, cov) = set.moments(&dev);
    let mean = (pts.column(0) + dbar).map(|v| v.to_f64());
    let cov = cov.map(|v| v.to_f64());
    errors(&mean, &cov, &xt.map(|v| v.to_f64()), &pt.map(|v| v.to_f64()))
}

fn tilt_error_deg(q: Quaternion, truth: Quaternion) -> f32 {
    let c = q.down_in_body().dot(truth.down_in_body()).clamp(-1.0, 1.0);
    to_deg(libm::acosf(c))
}

fn check_sane<F: AttitudeFilter>(f: &F, cov: &impl Fn(&F) -> SMatrix<f32, 7, 7>) {
    let q = f.attitude();
    assert!(q.is_finite() && (q.norm_sq() - 1.0).abs() < 1e-5, "{q:?}");
    assert!(f.gyro_bias().is_finite());
    let p = cov(f);
    for i in 0..N {
        assert!(p[(i, i)] > 0.0, "P[{i},{i}] = {}", p[(i, i)]);
        for j in 0..N {
            assert!(p[(i, j)].is_finite(), "{p}");
            assert_eq!(p[(i, j)], p[(j, i)]);
        }
    }
}

/// Start 30° off in roll and 30° off in pitch from the truth, feed 20 s of still samples
/// with small deterministic noise and a small true gyro bias; returns the tilt error, °.
pub fn tilt_convergence<F: AttitudeFilter>(f: &mut F) -> f32 {
    let truth = Euler::new(deg(10.0), deg(-5.0), deg(30.0)).to_quaternion();
    f.set_attitude(Euler::new(deg(40.0), deg(25.0), deg(30.0)).to_quaternion(), Vec3::ZERO);
    assert!(tilt_error_deg(f.attitude(), truth) > 35.0);
    let bias = Vec3::new(deg(0.1), deg(-0.1), deg(0.05));
    let f_true = truth.down_in_body() * -GRAVITY;
    let mut rng = TestRng::new(42);
    let mut used = false;
    for _ in 0..1000 {
        let s = ImuSample::new(0.02, bias + rng.vec(deg(0.5)), f_true + rng.vec(0.02));
        used |= f.update(&s).contains(Flags::ACCEL_USED);
    }
    assert!(used);
    tilt_error_deg(f.attitude(), truth)
}

/// Level body turning at 10 °/s about body z for 10 s with exact gyro and accelerometer;
/// returns the yaw error, °.
pub fn yaw_tracking<F: AttitudeFilter>(f: &mut F) -> f32 {
    let rate = deg(10.0);
    f.set_attitude(Quaternion::IDENTITY, Vec3::ZERO);
    let s = ImuSample::new(0.02, Vec3::new(0.0, 0.0, rate), Vec3::new(0.0, 0.0, -GRAVITY));
    for _ in 0..500 {
        f.update(&s);
    }
    let truth = Quaternion::from_yaw(rate * 10.0);
    let e = f.euler();
    assert!(to_deg(e.roll.abs()).max(to_deg(e.pitch.abs())) < 0.01, "{e:?}");
    assert!(to_deg(f.attitude().angle_to(truth)) < 0.1);
    to_deg(mathf::wrap_pi(e.yaw - rate * 10.0).abs())
}

/// A run with NaN, ±inf, absurd and extreme samples mixed in: after every update the
/// quaternion is unit and finite, and `P` finite, symmetric, with a positive diagonal.
/// Clean samples afterwards bring the tilt back.
pub fn garbage_run<F: AttitudeFilter>(f: &mut F, cov: impl Fn(&F) -> SMatrix<f32, 7, 7>) {
    let truth = Euler::new(deg(8.0), deg(-4.0), deg(20.0)).to_quaternion();
    f.set_attitude(truth, Vec3::ZERO);
    let acc = truth.down_in_body() * -GRAVITY;
    let (nan, inf) = (f32::NAN, f32::INFINITY);
    let g0 = Vec3::ZERO;
    let big = deg(1999.0);
    let bad = [
        ImuSample::new(nan, g0, acc),
        ImuSample::new(-0.02, g0, acc),
        ImuSample::new(0.0, g0, acc),
        ImuSample::new(inf, g0, acc),
        ImuSample::new(1e9, g0, acc),
        ImuSample::new(1e-30, g0, acc),
        ImuSample::new(3.0, Vec3::new(0.1, -0.2, 0.3), acc),
        ImuSample::new(0.02, Vec3::new(nan, 0.0, 0.0), acc),
        ImuSample::new(0.02, Vec3::new(0.0, -inf, 0.0), acc),
        ImuSample::new(0.02, Vec3::new(1e9, 0.0, f32::MAX), acc),
        ImuSample::new(0.02, Vec3::new(big, -big, big), acc),
        ImuSample::new(0.5, Vec3::new(big, big, -big), acc),
        ImuSample::new(0.02, g0, Vec3::new(nan, 0.0, 0.0)),
        ImuSample::new(0.02, g0, Vec3::new(0.0, inf, -inf)),
        ImuSample::new(0.02, g0, Vec3::ZERO),
        ImuSample::new(0.02, g0, Vec3::new(0.0, 0.0, -1e-30)),
        ImuSample::new(0.02, g0, Vec3::new(1e9, 0.0, 0.0)),
        ImuSample::new(0.02, g0, Vec3::new(0.0, 0.0, -15.0 * GRAVITY)),
        ImuSample::new(0.02, g0, Vec3::new(3.0 * GRAVITY, 0.0, 0.0)),
        ImuSample::new(nan, Vec3::new(nan, nan, nan), Vec3::new(inf, nan, -inf)),
    ];
    let mut rng = TestRng::new(3);
    for k in 0..1200 {
        let s = if k % 3 == 0 {
            bad[(k / 3) % bad.len()]
        } else {
            ImuSample::new(0.02, rng.vec(deg(0.5)), acc + rng.vec(0.02))
        };
        f.update(&s);
        check_sane(f, &cov);
    }
    for _ in 0..1500 {
        f.update(&ImuSample::new(0.02, rng.vec(deg(0.5)), acc + rng.vec(0.02)));
        check_sane(f, &cov);
    }
    let e = tilt_error_deg(f.attitude(), truth);
    assert!(e < 1.0, "tilt error {e}° 30 s after the garbage");
}

/// Pitched 5° and still, started 3° off about NED x and y (a pure tilt error, yaw right)
/// with the default 5° yaw uncertainty, exact gyro and an accelerometer with about the
/// configured noise, for 60 s. Every tilt correction moves the mean; the covariance must
/// move with it or the yaw variance leaks into the tilt directions and the corrections into
/// yaw (0.2° here without [`Core::transport`]). Returns the yaw error, °.
pub fn yaw_kept_through_tilt_corrections<F: AttitudeFilter>(f: &mut F) -> f32 {
    let truth = Euler::new(0.0, deg(5.0), deg(30.0)).to_quaternion();
    let start = Quaternion::from_rotation_vector(Vec3::new(deg(3.0), deg(-3.0), 0.0)) * truth;
    f.set_attitude(start, Vec3::ZERO);
    let f_true = truth.down_in_body() * -GRAVITY;
    let mut rng = TestRng::new(11);
    for _ in 0..3000 {
        // Uniform ±0.0027 g: σ 0.0016 g, the configured accelerometer noise.
        f.update(&ImuSample::new(0.02, Vec3::ZERO, f_true + rng.vec(0.0027 * GRAVITY)));
    }
    let te = tilt_error_deg(f.attitude(), truth);
    assert!(te < 0.1, "tilt error {te}°");
    to_deg(mathf::wrap_pi(Euler::yaw_of(f.attitude()) - Euler::yaw_of(truth)).abs())
}

/// After the initialisation window the bias covariance is the window's standard error plus
/// the floor, as the EKF's (to 10⁻⁴: the EKF's window ends with its last sample's tilt update,
/// which the window's own tilt variance makes move the bias covariance by a few 10⁻⁵).
pub fn bias_covariance_from_the_window<F: AttitudeFilter>(
    f: &mut F,
    cov: impl Fn(&F) -> SMatrix<f32, 7, 7>,
) {
    let mut ekf = crate::Ekf::new(Settings::default());
    let s = ImuSample::new(0.02, Vec3::new(0.01, -0.02, 0.003), Vec3::new(0.0, 0.0, -GRAVITY));
    while !f.is_initialised() {
        f.update(&s);
        ekf.update(&s);
    }
    assert!(ekf.is_initialised());
    let p = cov(f);
    let pe = ekf.covariance();
    for i in 0..3 {
        let (v, ve) = (p[(4 + i, 4 + i)], pe.m[3 + i][3 + i]);
        assert!((v / ve - 1.0).abs() < 1e-4, "axis {i}: {v} vs EKF {ve}");
        // Far below the configured 0.2 °/s.
        assert!(v < 0.05 * deg(0.2) * deg(0.2), "axis {i}: {v}");
    }
}

/// The initialisation window (default 10 s) with a yaw set during it, `set_yaw` after it,
/// and `reset`.
pub fn init_window_and_reset<F: AttitudeFilter>(f: &mut F) {
    let truth = Euler::new(deg(3.0), deg(-6.0), deg(45.0)).to_quaternion();
    let bias = Vec3::new(0.01, -0.02, 0.003);
    let s = ImuSample::new(0.02, bias, truth.down_in_body() * -GRAVITY);
    assert!(!f.is_initialised());
    f.set_yaw(deg(45.0));
    for _ in 0..450 {
        assert!(f.update(&s).contains(Flags::INITIALISING));
    }
    assert!(!f.is_initialised());
    for _ in 0..60 {
        f.update(&s);
    }
    assert!(f.is_initialised());
    assert!(to_deg(f.attitude().angle_to(truth)) < 0.05);
    assert!((f.gyro_bias() - bias).max_abs() < 1e-4);
    f.set_yaw(deg(-90.0));
    let e = f.euler();
    assert!((to_deg(e.yaw) + 90.0).abs() < 1e-3, "{e:?}");
    assert!((to_deg(e.roll) - 3.0).abs() < 0.05 && (to_deg(e.pitch) + 6.0).abs() < 0.05);
    f.reset();
    assert!(!f.is_initialised());
    assert!(to_deg(Euler::yaw_of(f.attitude())).abs() < 1e-3);
}
