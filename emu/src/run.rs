//! The firmware's pipeline over the embedded record stream, shared by the host and the
//! Cortex-M3 builds: each record is one filter cycle's hardware input (averaged ADC counts,
//! LSM303DLH counts); every NMEA sentence the pipeline emits is written to `out`.

use core::fmt::Write;

use ekf_emu::trace;
use inemo_ahrs::pipeline::{Pipeline, PipelineSettings};

/// The pipeline settings of the emulated run: the firmware's defaults, with every filter
/// cycle's sentences sent (output rate = filter rate) so each cycle is compared.
pub fn settings() -> PipelineSettings {
    PipelineSettings { output_rate_hz: 50, ..PipelineSettings::default() }
}

/// Run the whole trace; returns the number of sentences written.
pub fn run(out: &mut impl Write) -> Result<u32, core::fmt::Error> {
    let mut pipeline = Pipeline::new(settings());
    let mut sentences = 0;
    for rec in trace::records() {
        let step = pipeline.step(&trace::inputs(rec));
        for s in step.sentences.iter() {
            out.write_str(s.as_str())?;
            sentences += 1;
        }
    }
    Ok(sentences)
}
