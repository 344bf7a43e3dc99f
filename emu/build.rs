//! Turns the sensor trace (CSV in the project's trace format: body-frame SI samples; path from
//! `EKF_EMU_TRACE`, default `trace.csv` beside this file) into what the board's hardware tasks
//! would deliver — averaged ADC counts of the analog gyros and the depth sensor, LSM303DLH
//! accelerometer counts at ±2 g (1 mg per LSB) — through the inverse of the firmware's own
//! conversions and axis maps, and embeds it. Record: `dt` (f32), six ADC mean counts (f32),
//! three accelerometer counts (i16), all little-endian.
//!
//! For bare-metal targets it links with the firmware's memory map (the workspace's
//! `link/memory.x`, STM32F103RE); QEMU's `netduino2` machine runs that layout.
use std::{env, fs, path::PathBuf};

use ekf_core::{Vec3, GRAVITY};
use inemo_ahrs::{board, pipeline::PipelineSettings};

/// Reference voltage of both gyros' outputs at rest, V (mid-scale of the 3.3 V ADC range is
/// near the LPR430AL's and LY330ALH's 1.5 V zero-rate level).
const GYRO_ZERO_V: f32 = 1.5;

fn main() {
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));
    let manifest = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("manifest dir"));
    println!("cargo:rerun-if-env-changed=EKF_EMU_TRACE");
    let trace =
        env::var("EKF_EMU_TRACE").map(PathBuf::from).unwrap_or_else(|_| manifest.join("trace.csv"));
    println!("cargo:rerun-if-changed={}", trace.display());
    let text = fs::read_to_string(&trace)
        .unwrap_or_else(|e| panic!("cannot read trace {}: {e}", trace.display()));
    fs::write(out.join("trace.bin"), pack(&text)).expect("write trace.bin");

    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        let root = manifest.parent().expect("workspace root");
        // `dfu` (scripts/qemu-fault-record --dfu): the firmware's DFU layout, code from
        // 0x0800_3000 behind a bootloader (tools/memory_layout.rs).
        link_memory_layout(root, env::var_os("CARGO_FEATURE_DFU").is_some());
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        link_soft_float(); // as the firmware (tools/soft_float.rs)
    }
}

include!("../tools/soft_float.rs");
include!("../tools/memory_layout.rs");

/// Columns by name (`#` and empty lines skipped); the trace comes from `host-tests simulate`
/// or `host-tests` logging, which validate it. Errors here name the line.
fn pack(text: &str) -> Vec<u8> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (_, header) = lines.next().expect("trace has no header");
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let col = |n: &str| names.iter().position(|h| *h == n);
    let need = |n: &str| col(n).unwrap_or_else(|| panic!("trace lacks column {n}"));
    let idx: Vec<usize> =
        ["t", "gx", "gy", "gz", "ax", "ay", "az"].iter().map(|n| need(n)).collect();
    let depth_col = col("depth");

    let s = PipelineSettings::default();
    let counts = |volts: f32| volts / s.adc.vref_v * s.adc.full_scale_counts;
    let gyro_inv = board::GYRO_AXES.inverse();
    let accel_inv = board::ACCEL_AXES.inverse();

    let mut bytes = Vec::new();
    let mut prev_t: Option<f64> = None;
    for (i, line) in lines {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let num = |c: usize| -> f64 {
            cells
                .get(c)
                .and_then(|s| s.parse().ok())
                .unwrap_or_else(|| panic!("trace line {}: column {} unreadable", i + 1, names[c]))
        };
        let v: Vec<f64> = idx.iter().map(|&c| num(c)).collect();
        let dt = prev_t.map(|p| v[0] - p).unwrap_or(0.02) as f32;
        prev_t = Some(v[0]);

        // Body rad/s → sensor axes → volts → mean counts.
        let g = gyro_inv.apply(Vec3::new(v[1] as f32, v[2] as f32, v[3] as f32));
        let dps = |r: f32| r.to_degrees();
        let sens = s.gyro.sensitivity_v_per_dps;
        let zero = counts(GYRO_ZERO_V);
        let adc = [
            counts(GYRO_ZERO_V + dps(g.x) * sens[0]),
            counts(GYRO_ZERO_V + dps(g.y) * sens[1]),
            zero,
            counts(GYRO_ZERO_V + dps(g.z) * sens[2]),
            zero,
            {
                let depth = depth_col.map(num).unwrap_or(0.0) as f32;
                let d = &s.depth;
                let p = d.surface_pressure_pa + d.water_density_kg_m3 * d.gravity_m_s2 * depth;
                counts((p - d.offset_pa) / d.pa_per_volt)
            },
        ];
        // Body m/s² → sensor axes → g → LSM303DLH counts at ±2 g (1 mg/LSB).
        let a = accel_inv.apply(Vec3::new(v[4] as f32, v[5] as f32, v[6] as f32)) * (1.0 / GRAVITY);
        let lsb = |x: f32| (x * 1000.0).round().clamp(-2048.0, 2047.0) as i16;

        bytes.extend_from_slice(&dt.to_le_bytes());
        for c in adc {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
        for c in [lsb(a.x), lsb(a.y), lsb(a.z)] {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    bytes
}
