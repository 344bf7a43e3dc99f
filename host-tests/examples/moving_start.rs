//! A start in motion and the heading (issue #35): the largest heading gap between the EKF and
//! the gyro-only filter, both from the same configured bias, after their windows, seeds 1–5,
//! plain and realistic sensors, on `start-moving` (a 15° pitch sine and a 5 °/s turn from
//! power-on) and on the coupled roll and pitch sine from power-on (8° at 0.13 Hz,
//! 10° at 0.1 Hz, as `ekf-core/tests/robust.rs` has it). Nothing but the gyro knows the heading
//! without a magnetometer, so the gap is what the EKF's bias learning did to it.
//!
//! `cargo run --release -p host-tests --example moving_start`
use ekf_core::conditioning::Conditioner;
use ekf_core::{ekf::heading_change, mathf::wrap_pi, AttitudeFilter, ImuSample, Vec3};
use host_tests::accuracy::{replay_config, RATE_HZ};
use host_tests::replay::FilterKind;
use host_tests::sim::{Profile, Realism, Scenario, SimConfig, Simulator, Trajectory};

/// The coupled roll and pitch sine from power-on.
fn coupled_from_power_on() -> Trajectory {
    let sine = |deg: f64, f: f64| Profile::Sine {
        start: 0.0,
        amp: deg.to_radians(),
        freq_hz: f,
        phase: 0.0,
    };
    Trajectory::euler(sine(8.0, 0.13), sine(10.0, 0.1), Profile::Zero)
}

fn main() {
    let sc = Scenario::StartMoving;
    let cfg = replay_config(sc);
    let cases =
        [("start-moving", sc.trajectory()), ("coupled from power-on", coupled_from_power_on())];
    println!("largest heading gap, EKF to gyro-only (°), seeds 1–5");
    for (name, traj) in cases {
        for realistic in [false, true] {
            let mut gaps = Vec::new();
            for seed in 1..=5u64 {
                let mut sensors = sc.sensors();
                if realistic {
                    sensors.realism = Some(Realism::INEMO);
                }
                let sim = SimConfig {
                    rate_hz: RATE_HZ,
                    duration_s: sc.default_duration(),
                    seed,
                    sensors,
                };
                let rows: Vec<_> = Simulator::new(traj, sim).map(|s| s.row).collect();
                let mut filters =
                    [cfg.make_filter(FilterKind::Ekf), cfg.make_filter(FilterKind::Gyro)];
                let mut conds =
                    [Conditioner::new(cfg.conditioning), Conditioner::new(cfg.conditioning)];
                let (mut prev, mut worst) = (None, 0.0f32);
                for row in &rows {
                    let dt = prev.map_or(1.0 / RATE_HZ, |p| row.t - p) as f32;
                    prev = Some(row.t);
                    for (f, c) in filters.iter_mut().zip(conds.iter_mut()) {
                        let (g, a) = c.condition(
                            dt,
                            Vec3::from_array(row.gyro),
                            Vec3::from_array(row.accel),
                            f.gyro_bias(),
                        );
                        f.update(&ImuSample { dt, gyro: g, accel: a, mag: None });
                    }
                    let [e, g]: &[Box<dyn AttitudeFilter>; 2] = &filters;
                    if e.is_initialised() && g.is_initialised() {
                        worst =
                            worst.max(wrap_pi(heading_change(g.attitude(), e.attitude())).abs());
                    }
                }
                gaps.push(worst.to_degrees());
            }
            let w = gaps.iter().cloned().fold(0.0f32, f32::max);
            let each: Vec<String> = gaps.iter().map(|g| format!("{g:.3}")).collect();
            let kind = if realistic { "realistic" } else { "plain" };
            println!("  {name:22} {kind:9} {}  worst {w:.3}", each.join(" "));
        }
    }
}
