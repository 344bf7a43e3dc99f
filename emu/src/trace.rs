//! The embedded record stream: each record is one filter cycle's hardware input (averaged ADC
//! counts, LSM303DLH counts), packed by `build.rs` from the sensor trace.

use inemo_ahrs::{adc::AdcMean, lsm303dlh::AccelScale, pipeline::Inputs};

/// The packed trace.
pub static TRACE: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/trace.bin"));

/// Bytes per record: `dt` and six ADC means (f32), three accelerometer counts (i16).
pub const RECORD: usize = 7 * 4 + 3 * 2;

fn f32_at(rec: &[u8], off: usize) -> f32 {
    let mut b = [0u8; 4];
    if let Some(s) = rec.get(off..off + 4) {
        b.copy_from_slice(s);
    }
    f32::from_le_bytes(b)
}

fn i16_at(rec: &[u8], off: usize) -> i16 {
    let mut b = [0u8; 2];
    if let Some(s) = rec.get(off..off + 2) {
        b.copy_from_slice(s);
    }
    i16::from_le_bytes(b)
}

/// The records, in order.
pub fn records() -> core::slice::ChunksExact<'static, u8> {
    TRACE.chunks_exact(RECORD)
}

/// Number of records.
pub fn len() -> usize {
    TRACE.len() / RECORD
}

/// The pipeline inputs of one record: its `dt`, the six ADC means (20 samples each), the
/// accelerometer counts at ±2 g in g.
pub fn inputs(rec: &[u8]) -> Inputs {
    let mg = AccelScale::G2.mg_per_lsb() * 1e-3;
    let adc = AdcMean {
        gyro_x: f32_at(rec, 4),
        gyro_y: f32_at(rec, 8),
        gyro_xy_ref: f32_at(rec, 12),
        gyro_z: f32_at(rec, 16),
        gyro_z_ref: f32_at(rec, 20),
        depth: f32_at(rec, 24),
        samples: 20,
        ..AdcMean::default()
    };
    let a = [i16_at(rec, 28), i16_at(rec, 30), i16_at(rec, 32)];
    Inputs {
        dt: f32_at(rec, 0),
        adc: Some(adc),
        accel_g: Some([f32::from(a[0]) * mg, f32::from(a[1]) * mg, f32::from(a[2]) * mg]),
        ..Inputs::default()
    }
}
