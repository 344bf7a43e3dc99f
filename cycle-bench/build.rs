//! Generates the embedded benchmark trace (`$OUT_DIR/trace.rs`) and, for bare-metal targets,
//! links with the firmware's memory map (the workspace's `link/memory.x`, STM32F103RE).
//!
//! The trace is deterministic (its own 64-bit LCG, `f64` arithmetic, values rounded to `f32`
//! once) so the instruction counts of every benchmark step are reproducible bit for bit:
//! - `INIT_LEN` samples (10 s at 50 Hz) of a still board, slightly tilted, for the filters'
//!   initialisation window (run by `ahrs_bench_select`, not measured);
//! - `MOTION_LEN` samples (8 s) of smooth motion that every filter's gate accepts: roll
//!   8° at 0.25 Hz, pitch 15° at 0.125 Hz, yaw 30° at 0.125 Hz, as an ROV pitching and
//!   yawing in a swell. Whole periods, so the benchmark can loop over it seamlessly;
//! - `MOVING`: the same rotations, `MOTION_LEN` samples, with a hand's horizontal shaking on
//!   top (north 0.3 g at 1 Hz, east 0.2 g at 0.75 Hz; whole periods too): the motion that
//!   makes the EKF low-pass its tilt measurement (issue #35's time constant above 0), which
//!   the gentle lap, taken raw, does not.
//!
//! Sensors: the board's gyro bias (1.619, 3.440, −0.004) °/s and white noise (0.58, 0.52,
//! 0.065) °/s per sample, the LSM303DLH's 0.0015 g accelerometer noise, no linear
//! acceleration (the accelerometer reads gravity only, so every sample takes the full update
//! path: accepted by the magnitude, jump and innovation gates).
use std::{env, f64::consts::PI, fmt::Write as _, fs, path::PathBuf};

const RATE_HZ: f64 = 50.0;
const INIT_LEN: usize = 500;
const MOTION_LEN: usize = 400;
const G: f64 = 9.806_65;

struct Lcg(u64);

impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 =
            self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Approximately standard normal (Irwin–Hall, 12 uniforms).
    fn normal(&mut self) -> f64 {
        (0..12).map(|_| self.uniform()).sum::<f64>() - 6.0
    }
}

/// Euler angles (roll, pitch, yaw) and their time derivatives at motion time `t`, rad, rad/s.
fn motion(t: f64) -> ([f64; 3], [f64; 3]) {
    let (r0, p0) = (2.0f64.to_radians(), (-1.0f64).to_radians());
    let (ar, wr) = (8.0f64.to_radians(), 2.0 * PI / 4.0);
    let (ap, wp) = (15.0f64.to_radians(), 2.0 * PI / 8.0);
    let (ay, wy) = (30.0f64.to_radians(), 2.0 * PI / 8.0);
    (
        [r0 + ar * (wr * t).sin(), p0 + ap * (wp * t).sin(), ay * (wy * t).sin()],
        [ar * wr * (wr * t).cos(), ap * wp * (wp * t).cos(), ay * wy * (wy * t).cos()],
    )
}

/// The `MOVING` lap's horizontal acceleration at motion time `t`, NED, m/s².
fn shaking(t: f64) -> [f64; 3] {
    [0.3 * G * (2.0 * PI * t).sin(), 0.2 * G * (2.0 * PI * 0.75 * t + 0.5).sin(), 0.0]
}

/// Body rates (FRD) from Z-Y-X Euler angles and rates, and the accelerometer's specific force
/// (gravity, and the acceleration `acc` in NED, m/s²) in the body frame, m/s².
fn body(e: [f64; 3], de: [f64; 3], acc: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let ([phi, theta, psi], [dphi, dtheta, dpsi]) = (e, de);
    let w = [
        dphi - dpsi * theta.sin(),
        dtheta * phi.cos() + dpsi * theta.cos() * phi.sin(),
        -dtheta * phi.sin() + dpsi * theta.cos() * phi.cos(),
    ];
    let (sf, cf, st, ct, sp, cp) =
        (phi.sin(), phi.cos(), theta.sin(), theta.cos(), psi.sin(), psi.cos());
    // Body → NED, Z-Y-X; the specific force is Rᵀ·(acc − g), g = (0, 0, G).
    let r = [
        [cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf],
        [sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf],
        [-st, ct * sf, ct * cf],
    ];
    let a = [0, 1, 2].map(|i| (0..3).map(|k| r[k][i] * acc[k]).sum::<f64>() - G * r[2][i]);
    (w, a)
}

fn main() {
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));
    let manifest = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("manifest dir"));

    let dt = 1.0 / RATE_HZ;
    let bias = [1.619f64.to_radians(), 3.440f64.to_radians(), (-0.0042f64).to_radians()];
    let gyro_sigma = [0.337f64.sqrt(), 0.275f64.sqrt(), 4.19e-3f64.sqrt()].map(f64::to_radians);
    let accel_sigma = 2.376e-6f64.sqrt() * G;
    let mut rng = Lcg(0x5EA_0C0D_E5EE_D5EE);

    let mut src = String::new();
    writeln!(src, "/// Samples of the still initialisation window.").unwrap();
    writeln!(src, "pub const INIT_LEN: usize = {INIT_LEN};").unwrap();
    writeln!(src, "/// Samples of the motion part (whole periods: it loops seamlessly).").unwrap();
    writeln!(src, "pub const MOTION_LEN: usize = {MOTION_LEN};").unwrap();
    writeln!(src, "/// `[dt, gx, gy, gz, ax, ay, az]`: s, rad/s (body FRD), m/s² (body FRD).")
        .unwrap();
    let mut row = |e: [f64; 3], de: [f64; 3], acc: [f64; 3], src: &mut String| {
        let (w, a) = body(e, de, acc);
        let mut row = [dt as f32; 7];
        for i in 0..3 {
            row[1 + i] = (w[i] + bias[i] + gyro_sigma[i] * rng.normal()) as f32;
        }
        for i in 0..3 {
            row[4 + i] = (a[i] + accel_sigma * rng.normal()) as f32;
        }
        let cells: Vec<String> = row.iter().map(|v| format!("{v:?}")).collect();
        writeln!(src, "    [{}],", cells.join(", ")).unwrap();
    };
    writeln!(src, "pub static TRACE: [[f32; 7]; {}] = [", INIT_LEN + MOTION_LEN).unwrap();
    for k in 0..INIT_LEN + MOTION_LEN {
        let (e, de) = if k < INIT_LEN {
            let (e, _) = motion(0.0);
            (e, [0.0; 3])
        } else {
            motion((k - INIT_LEN) as f64 * dt)
        };
        row(e, de, [0.0; 3], &mut src);
    }
    writeln!(src, "];").unwrap();
    writeln!(src, "/// The motion part with a hand's horizontal shaking on top (same format).")
        .unwrap();
    writeln!(src, "pub static MOVING: [[f32; 7]; {MOTION_LEN}] = [").unwrap();
    for k in 0..MOTION_LEN {
        let t = k as f64 * dt;
        let (e, de) = motion(t);
        row(e, de, shaking(t), &mut src);
    }
    writeln!(src, "];").unwrap();
    fs::write(out.join("trace.rs"), src).expect("write trace.rs");
    println!("cargo:rerun-if-changed=build.rs");

    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        let link = manifest.parent().expect("workspace root").join("link");
        println!("cargo:rustc-link-search={}", link.display());
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        println!("cargo:rerun-if-changed={}", link.join("memory.x").display());
        link_soft_float();
    } else {
        println!("cargo:rustc-env=AHRS_SOFTFLOAT_USED=host");
    }
}

include!("../tools/soft_float.rs");
