//! The firmware's data path for one filter cycle, independent of the hardware: averaged ADC
//! counts and LSM303DLH readings in, conversion to SI units in the sensors' axes, conditioning
//! (axis maps, calibration, lever arm) into body FRD, the `Ekf`, depth, and NMEA sentences out
//! at the output rate. The RTIC app calls [`Pipeline::step`] once per filter period; the
//! emulated run (`ekf-emu`) calls the very same function.

use ekf_core::{
    conditioning::{Conditioner, ConditioningSettings},
    settings::Settings,
    AttitudeFilter, Ekf, Euler, Quaternion, Vec3, GRAVITY,
};

use crate::{
    adc::{AdcMean, AdcScale, DepthCalibration, GyroConversion},
    board,
    nmea::{self, PinahData, Sentence, Status},
    registry::{self, Part},
};

/// Which sentences go out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SentenceSet {
    /// `$PRDID` (pitch, roll, heading; RDI convention). Default on.
    pub prdid: bool,
    /// `$PINAH` (full state). Default on.
    pub pinah: bool,
}

impl Default for SentenceSet {
    fn default() -> Self {
        SentenceSet { prdid: true, pinah: true }
    }
}

/// Everything the pipeline needs; `Default` is the iNEMO V2 on the Seahog.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PipelineSettings {
    /// Estimator settings (noise, init window, gate, rest detection, ...).
    pub filter: Settings,
    /// Axis maps, calibration and lever arm. Default: the board's axis maps
    /// ([`board::ACCEL_AXES`], [`board::GYRO_AXES`], [`board::MAG_AXES`]), identity
    /// calibration, the Seahog's lever arm.
    pub conditioning: ConditioningSettings,
    /// ADC counts → volts.
    pub adc: AdcScale,
    /// Gyro volts → rad/s.
    pub gyro: GyroConversion,
    /// Depth sensor volts → pressure → depth.
    pub depth: DepthCalibration,
    /// Filter rate, Hz. Default 50 (the source's); up to 200 supported.
    pub filter_rate_hz: u16,
    /// Output rate, Hz, 1–50 (at most the filter rate). Default 10.
    pub output_rate_hz: u16,
    /// Sentences to send.
    pub sentences: SentenceSet,
}

impl Default for PipelineSettings {
    // Out of line: the firmware builds the defaults in several places (boot, `RESET`, the
    // flash loader) and one copy of this code is enough.
    #[inline(never)]
    fn default() -> Self {
        PipelineSettings {
            filter: Settings::default(),
            conditioning: ConditioningSettings {
                gyro_axes: board::GYRO_AXES,
                accel_axes: board::ACCEL_AXES,
                mag_axes: board::MAG_AXES,
                ..ConditioningSettings::default()
            },
            adc: AdcScale::default(),
            gyro: GyroConversion::default(),
            depth: DepthCalibration::default(),
            filter_rate_hz: 50,
            output_rate_hz: 10,
            sentences: SentenceSet::default(),
        }
    }
}

impl PipelineSettings {
    /// Filter cycles per output: `filter_rate / output_rate`, at least 1.
    pub fn output_divider(&self) -> u32 {
        let f = u32::from(self.filter_rate_hz.max(1));
        let o = u32::from(self.output_rate_hz.clamp(1, 50));
        (f / o).max(1)
    }
}

/// One filter cycle's input, as the hardware tasks deliver it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Inputs {
    /// Time since the previous cycle, s (the filter period; the app measures it).
    pub dt: f32,
    /// Averaged ADC scan since the previous cycle; `None` if no frame arrived.
    pub adc: Option<AdcMean>,
    /// Accelerometer, g, LSM303DLH axes; `None` after an I²C failure.
    pub accel_g: Option<[f32; 3]>,
    /// Magnetometer, µT, LSM303DLH axes; `None` when not read or failed.
    pub mag_ut: Option<[f32; 3]>,
    /// Board-level status bits of this cycle (I²C fault, ...).
    pub board: Status,
    /// Duration of the previous filter cycle, µs (DWT cycle counter), reported in `$PINAH`.
    pub last_cycle_us: u32,
}

/// Up to two sentences of one cycle, in sending order.
#[derive(Clone, Debug, Default)]
pub struct Sentences {
    items: [Option<Sentence>; 2],
}

impl Sentences {
    /// The sentences, in order.
    pub fn iter(&self) -> impl Iterator<Item = &Sentence> {
        self.items.iter().flatten()
    }
}

/// What one cycle produced.
#[derive(Clone, Debug)]
pub struct Step {
    /// Estimator flags and board bits.
    pub status: Status,
    /// Attitude, body FRD → NED.
    pub attitude: Quaternion,
    /// Depth, m, positive down, when the depth channel was read.
    pub depth_m: Option<f32>,
    /// Sentences to send now (empty between outputs).
    pub sentences: Sentences,
}

/// The data path. See the module documentation.
#[derive(Clone, Debug)]
pub struct Pipeline {
    settings: PipelineSettings,
    conditioner: Conditioner,
    ekf: Ekf,
    cycle: u32,
    last_depth: Option<f32>,
}

impl Pipeline {
    /// A pipeline at power-up: the estimator starts its initialisation window.
    pub fn new(settings: PipelineSettings) -> Self {
        Pipeline {
            settings,
            conditioner: Conditioner::new(settings.conditioning),
            ekf: Ekf::new(settings.filter),
            cycle: 0,
            last_depth: None,
        }
    }

    /// The settings in use.
    pub fn settings(&self) -> &PipelineSettings {
        &self.settings
    }

    /// The estimator.
    pub fn ekf(&self) -> &Ekf {
        &self.ekf
    }

    /// The estimator, for commands (`set_yaw`, ...).
    pub fn ekf_mut(&mut self) -> &mut Ekf {
        &mut self.ekf
    }

    /// Last depth, m.
    pub fn depth_m(&self) -> Option<f32> {
        self.last_depth
    }

    /// Run one filter cycle.
    pub fn step(&mut self, inputs: &Inputs) -> Step {
        let mut status = inputs.board;
        let nan = Vec3::new(f32::NAN, f32::NAN, f32::NAN);

        // Gyro (sensor axes, rad/s) and depth from the averaged ADC scan.
        let (gyro_raw, depth) = match inputs.adc {
            Some(mean) => {
                if mean.dropped > 0 {
                    status.insert(Status::ADC_FAULT);
                }
                let g = self.settings.gyro.rates(&mean);
                if g.saturated {
                    status.insert(Status::GYRO_RAIL);
                }
                let d = self.settings.depth.reading(&mean, &self.settings.adc);
                if d.at_rail {
                    status.insert(Status::DEPTH_RAIL);
                }
                let depth = (!d.at_rail && d.depth_m.is_finite()).then_some(d.depth_m);
                (g.rate_vec3(), depth)
            }
            None => {
                status.insert(Status::ADC_FAULT);
                (nan, None)
            }
        };
        if depth.is_some() {
            self.last_depth = depth;
        }

        // Accelerometer (sensor axes, g → m/s²); an I²C failure leaves the gyros alone.
        let accel_raw = inputs.accel_g.map(|a| Vec3::from_array(a) * GRAVITY).unwrap_or(nan);
        let (gyro, accel) = self.conditioner.condition(inputs.dt, gyro_raw, accel_raw);
        let mut sample = ekf_core::ImuSample::new(inputs.dt, gyro, accel);
        sample.mag = inputs.mag_ut.map(|m| self.conditioner.condition_mag(Vec3::from_array(m)));

        let flags = self.ekf.update(&sample);
        status.insert(Status::from_flags(flags));

        let attitude = self.ekf.attitude();
        let mut sentences = Sentences::default();
        if self.cycle % self.settings.output_divider() == 0 {
            let euler = Euler::from_quaternion(attitude);
            if self.settings.sentences.prdid {
                sentences.items[0] = nmea::prdid(&euler).ok();
            }
            if self.settings.sentences.pinah {
                let data = PinahData {
                    euler,
                    quaternion: attitude,
                    depth_m: self.last_depth,
                    status,
                    cycle_us: inputs.last_cycle_us,
                };
                sentences.items[1] = nmea::pinah(&data).ok();
            }
        }
        self.cycle = self.cycle.wrapping_add(1);
        Step { status, attitude, depth_m: depth, sentences }
    }

    /// The conditioned sample (rad/s, m/s², µT, body FRD — what the estimator is fed) that
    /// the next [`Pipeline::step`] with the same `inputs` computes. Works on a copy of the
    /// conditioner, so nothing changes; call it before `step`. For the raw streaming mode
    /// (`crate::command`).
    pub fn conditioned_sample(&self, inputs: &Inputs) -> ekf_core::ImuSample {
        let nan = Vec3::new(f32::NAN, f32::NAN, f32::NAN);
        let gyro_raw =
            inputs.adc.map(|mean| self.settings.gyro.rates(&mean).rate_vec3()).unwrap_or(nan);
        let accel_raw = inputs.accel_g.map(|a| Vec3::from_array(a) * GRAVITY).unwrap_or(nan);
        let mut conditioner = self.conditioner;
        let (gyro, accel) = conditioner.condition(inputs.dt, gyro_raw, accel_raw);
        let mut sample = ekf_core::ImuSample::new(inputs.dt, gyro, accel);
        sample.mag = inputs.mag_ut.map(|m| conditioner.condition_mag(Vec3::from_array(m)));
        sample
    }

    /// Replace the settings at run time (commands), keeping the attitude.
    ///
    /// The conditioner is rebuilt when the conditioning settings change (the lever-arm
    /// history restarts). The estimator is rebuilt when its settings or the static gyro
    /// offset change: once initialised it restarts from the current attitude and gyro bias
    /// (the bias shifted by the change of the offset, so the corrected rate is unchanged; the
    /// covariance restarts from the initial sigmas); during the initialisation window the
    /// window restarts. Output settings (rate, sentences) take effect at the next cycle. The
    /// filter rate is only recorded here: the caller changes the cycle period. Changes are
    /// found through the registry ([`registry::same`]): only fields it reaches count.
    pub fn apply_settings(&mut self, settings: PipelineSettings) {
        let old = self.settings;
        // Compared through the registry (the derived comparisons cost ≈ 0.9 KB of flash).
        if !registry::same(&settings, &old, Some(Part::Conditioning)) {
            self.conditioner = Conditioner::new(settings.conditioning);
        }
        let shift = settings.conditioning.gyro_offset - old.conditioning.gyro_offset;
        if !registry::same(&settings, &old, Some(Part::Filter)) || shift != Vec3::ZERO {
            let mut ekf = Ekf::new(settings.filter);
            if self.ekf.is_initialised() {
                ekf.set_attitude(self.ekf.attitude(), self.ekf.gyro_bias() - shift);
            }
            self.ekf = ekf;
        }
        self.settings = settings;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nmea::verify;
    use ekf_core::{mathf::deg, Flags};

    /// A flat, still board, face up: the LSM303DLH reads +1 g on its z axis.
    const FLAT: [f32; 3] = [0.0, 0.0, 1.0];

    /// ADC counts for a rate (°/s) on a gyro with reference at 1.5 V.
    fn counts(volts: f32) -> f32 {
        volts / 3.3 * 4095.0
    }

    fn still_adc(rates_dps: [f32; 3]) -> AdcMean {
        let r = 1.5;
        AdcMean {
            gyro_x: counts(r + rates_dps[0] * 3.33e-3),
            gyro_y: counts(r + rates_dps[1] * 3.33e-3),
            gyro_xy_ref: counts(r),
            gyro_z: counts(r + rates_dps[2] * 3.752e-3),
            gyro_z_ref: counts(r),
            depth: counts(1.0),
            samples: 20,
            ..AdcMean::default()
        }
    }

    #[test]
    fn a_tilted_still_board_reads_its_tilt_in_prdid_after_the_window() {
        let mut s = PipelineSettings::default();
        s.filter.init.window_s = 1.0;
        let mut p = Pipeline::new(s);
        // Body pitched 10° bow up and rolled 5° starboard down: the specific force in body
        // axes, mapped back into the LSM303DLH's axes through the inverse axis map.
        let truth = Euler::new(deg(5.0), deg(10.0), 0.0).to_quaternion();
        let f_body = truth.down_in_body() * -1.0; // g
        let f_sensor = board::ACCEL_AXES.inverse().apply(f_body);
        let mut last = None;
        for _ in 0..100 {
            let step = p.step(&Inputs {
                dt: 0.02,
                adc: Some(still_adc([0.0; 3])),
                accel_g: Some(f_sensor.to_array()),
                ..Inputs::default()
            });
            let first = step.sentences.iter().next().cloned();
            if first.is_some() {
                last = first;
            }
        }
        let e = Euler::from_quaternion(p.ekf().attitude());
        assert!((e.pitch - deg(10.0)).abs() < deg(0.05) && (e.roll - deg(5.0)).abs() < deg(0.05));
        let line = last.expect("sentences");
        assert_eq!(verify(line.as_bytes()).unwrap(), "PRDID,+10.00,+5.00,0.00");
    }

    #[test]
    fn output_rate_divides_the_filter_rate_and_both_sentences_verify() {
        let s = PipelineSettings { output_rate_hz: 5, ..PipelineSettings::default() };
        let mut p = Pipeline::new(s);
        let mut outputs = 0;
        for _ in 0..100 {
            let step = p.step(&Inputs {
                dt: 0.02,
                adc: Some(still_adc([0.0; 3])),
                accel_g: Some(FLAT),
                ..Inputs::default()
            });
            let lines: Vec<Sentence> = step.sentences.iter().cloned().collect();
            if !lines.is_empty() {
                outputs += 1;
                assert_eq!(lines.len(), 2);
                assert!(verify(lines[0].as_bytes()).unwrap().starts_with("PRDID,"));
                assert!(verify(lines[1].as_bytes()).unwrap().starts_with("PINAH,"));
            }
        }
        // 2 s at 50 Hz, output at 5 Hz.
        assert_eq!(outputs, 10);
    }

    #[test]
    fn an_i2c_failure_keeps_the_gyros_running_and_is_flagged() {
        let mut s = PipelineSettings::default();
        s.filter.init.window_s = 0.0;
        let mut p = Pipeline::new(s);
        p.step(&Inputs {
            dt: 0.02,
            adc: Some(still_adc([0.0; 3])),
            accel_g: Some(FLAT),
            ..Inputs::default()
        });
        // 1 s of a 10 °/s turn about the body's z (down: the yaw gyro's output falls, with the
        // default map) without the accelerometer.
        let mut status = Status::NONE;
        for _ in 0..50 {
            let step = p.step(&Inputs {
                dt: 0.02,
                adc: Some(still_adc([0.0, 0.0, -10.0])),
                accel_g: None,
                board: Status::I2C_FAULT,
                ..Inputs::default()
            });
            status = step.status;
        }
        assert!(status.contains(Status::I2C_FAULT));
        assert!(status.flags().contains(Flags::ACCEL_INVALID));
        let yaw = Euler::from_quaternion(p.ekf().attitude()).yaw;
        // With a zero-length window the bias is the first (still) sample's rate. The gyro is
        // integrated by the trapezoidal rule, so the first 0.02 s step counts the mean of the
        // still rate and the turn's: the yaw is 10 °/s for 0.99 s, minus the bias for 1 s.
        let bias_z = p.ekf().gyro_bias().z;
        let expect = deg(10.0) * 0.99 - bias_z;
        assert!((yaw - expect).abs() < deg(0.05), "{}", ekf_core::mathf::to_deg(yaw));
    }

    #[test]
    fn depth_comes_from_the_depth_channel_and_a_missing_adc_is_flagged() {
        let mut p = Pipeline::new(PipelineSettings::default());
        let step =
            p.step(&Inputs { dt: 0.02, adc: Some(still_adc([0.0; 3])), ..Inputs::default() });
        let d = PipelineSettings::default().depth;
        let expect = d.depth_m(counts(1.0) / 4095.0 * 3.3);
        assert!((step.depth_m.unwrap() - expect).abs() < 1e-3);
        let step = p.step(&Inputs { dt: 0.02, adc: None, ..Inputs::default() });
        assert!(step.status.contains(Status::ADC_FAULT));
        assert_eq!(step.depth_m, None);
        // The last good depth is kept for the output.
        assert!((p.depth_m().unwrap() - expect).abs() < 1e-3);
    }
}
