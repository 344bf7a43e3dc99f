//! The pipeline shared by the host and the Cortex-M3 builds: every embedded sample through the
//! default `Ekf`, one estimate row per sample written to `out`.

use core::fmt::Write;

use ekf_core::{mathf::to_deg, settings::Settings, AttitudeFilter, Ekf, ImuSample, Vec3};

static TRACE: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/trace.bin"));

/// Bytes per record: seven little-endian f32.
const RECORD: usize = 28;

fn f32_at(rec: &[u8], i: usize) -> f32 {
    let mut b = [0u8; 4];
    if let Some(s) = rec.get(4 * i..4 * i + 4) {
        b.copy_from_slice(s);
    }
    f32::from_le_bytes(b)
}

/// Run the whole trace. Rows: `t,qw,qx,qy,qz,roll,pitch,yaw,flags` (t in s, Euler in degrees).
pub fn run(out: &mut impl Write) -> core::fmt::Result {
    let mut ekf = Ekf::new(Settings::default());
    let mut t = 0.0f32;
    writeln!(out, "t,qw,qx,qy,qz,roll,pitch,yaw,flags")?;
    for rec in TRACE.chunks_exact(RECORD) {
        let s = ImuSample::new(
            f32_at(rec, 0),
            Vec3::new(f32_at(rec, 1), f32_at(rec, 2), f32_at(rec, 3)),
            Vec3::new(f32_at(rec, 4), f32_at(rec, 5), f32_at(rec, 6)),
        );
        t += s.dt;
        let flags = ekf.update(&s);
        let q = ekf.attitude();
        let e = ekf.euler();
        writeln!(
            out,
            "{},{},{},{},{},{},{},{},{}",
            t,
            q.w,
            q.x,
            q.y,
            q.z,
            to_deg(e.roll),
            to_deg(e.pitch),
            to_deg(e.yaw),
            flags.bits()
        )?;
    }
    Ok(())
}
