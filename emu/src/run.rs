//! The firmware's pipeline over the embedded record stream, shared by the host and the
//! Cortex-M3 builds: each record is one filter cycle's hardware input (averaged ADC counts,
//! LSM303DLH counts); every NMEA sentence the pipeline emits is written to `out`.

use core::fmt::Write;

use inemo_ahrs::{
    adc::AdcMean,
    lsm303dlh::AccelScale,
    pipeline::{Inputs, Pipeline, PipelineSettings},
};

static TRACE: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/trace.bin"));

/// Bytes per record: `dt` and six ADC means (f32), three accelerometer counts (i16).
const RECORD: usize = 7 * 4 + 3 * 2;

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

/// The pipeline settings of the emulated run: the firmware's defaults, with every filter
/// cycle's sentences sent (output rate = filter rate) so each cycle is compared.
pub fn settings() -> PipelineSettings {
    PipelineSettings { output_rate_hz: 50, ..PipelineSettings::default() }
}

/// Run the whole trace; returns the number of sentences written.
pub fn run(out: &mut impl Write) -> Result<u32, core::fmt::Error> {
    let mut pipeline = Pipeline::new(settings());
    let mg = AccelScale::G2.mg_per_lsb() * 1e-3;
    let mut sentences = 0;
    for rec in TRACE.chunks_exact(RECORD) {
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
        let inputs = Inputs {
            dt: f32_at(rec, 0),
            adc: Some(adc),
            accel_g: Some([f32::from(a[0]) * mg, f32::from(a[1]) * mg, f32::from(a[2]) * mg]),
            ..Inputs::default()
        };
        let step = pipeline.step(&inputs);
        for s in step.sentences.iter() {
            out.write_str(s.as_str())?;
            sentences += 1;
        }
    }
    Ok(sentences)
}
