//! The firmware's data path for one filter cycle, independent of the hardware: averaged ADC
//! counts and LSM303DLH readings in, conversion to SI units in the sensors' axes, conditioning
//! (axis maps, calibration, lever arm) into body FRD, the `Ekf`, depth, and NMEA sentences out
//! at the output rate. The RTIC app calls [`Pipeline::step`] once per filter period; the
//! emulated run (`ekf-emu`) calls the very same function.

use ekf_core::{
    conditioning::Conditioner, mathf, AttitudeFilter, Ekf, Flags, Quaternion, Vec3, GRAVITY,
};

pub use crate::settings::{PipelineSettings, SentenceSet};
pub use crate::status::HeadingRef;
use crate::{
    adc::AdcMean,
    nmea::{self, PinahData, Sentence, Status},
    registry::{self, Part},
};

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

/// Most sentences of one cycle: `$PRDID`, `$PINAH`, `HDT`, `HDG`, `HDM`, `ROT`, `XDR`.
pub const MAX_SENTENCES: usize = 7;

/// The sentences of one cycle, in sending order.
#[derive(Clone, Debug, Default)]
pub struct Sentences {
    items: [Option<Sentence>; MAX_SENTENCES],
}

impl Sentences {
    /// The sentences, in order.
    pub fn iter(&self) -> impl Iterator<Item = &Sentence> + Clone {
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
    /// What the heading is referenced to.
    pub heading_ref: HeadingRef,
}

/// Estimator flags that make the attitude untrustworthy for the cycle: initialising, a bad or
/// saturated gyro sample, a time gap, a state reset.
const ATTITUDE_BAD_FLAGS: u32 = (Flags::INITIALISING.0
    | Flags::GYRO_INVALID.0
    | Flags::TIME_GAP.0
    | Flags::GYRO_SATURATED.0
    | Flags::HEALTH_RESET.0) as u32;
/// Board bits that make the attitude untrustworthy: no or dropped ADC frames (the gyros),
/// the gyro conversion at a rail.
const ATTITUDE_BAD_BOARD: u32 = Status::ADC_FAULT.0 | Status::GYRO_RAIL.0;

/// True when nothing in `status` (the flags and board bits of every cycle since the last
/// output, OR-ed) makes the attitude untrustworthy: the standard sentences without a status
/// field are sent, `ROT` says `A`.
pub const fn attitude_valid(status: Status) -> bool {
    status.0 & (ATTITUDE_BAD_FLAGS | ATTITUDE_BAD_BOARD) == 0
}

/// True when the tilt (pitch, roll) is trustworthy: [`attitude_valid`], and the accelerometer
/// has not been rejected for longer than the long-rejection time.
pub const fn tilt_valid(status: Status) -> bool {
    attitude_valid(status) && status.0 & Flags::ACCEL_REJECT_LONG.0 as u32 == 0
}

/// The data path. See the module documentation.
#[derive(Clone, Debug)]
pub struct Pipeline {
    settings: PipelineSettings,
    conditioner: Conditioner,
    ekf: Ekf,
    cycle: u32,
    last_depth: Option<f32>,
    heading_ref: HeadingRef,
    /// Status bits of every cycle since the last output.
    interval_status: Status,
    /// Yaw at the last output (rad; `None`: the rate of turn starts again at the next output)
    /// and the time since, s: the rate of turn.
    rot_yaw: Option<f32>,
    rot_time_s: f32,
    /// The heading moved by the estimator's corrections since the last output, rad: not a turn.
    rot_jumps: f32,
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
            heading_ref: HeadingRef::Relative,
            interval_status: Status::NONE,
            rot_yaw: None,
            rot_time_s: 0.0,
            rot_jumps: 0.0,
        }
    }

    /// What the heading is referenced to.
    pub fn heading_ref(&self) -> HeadingRef {
        self.heading_ref
    }

    /// Reference the heading to `r`. A change of reference moves the heading without a turn
    /// (the magnetometer taking over pulls it to magnetic north), so the rate of turn starts
    /// again: the next output's `ROT` is empty and invalid.
    fn reference_heading(&mut self, r: HeadingRef) {
        if r != self.heading_ref {
            self.heading_ref = r;
            self.rot_yaw = None;
        }
    }

    /// The operator's true heading (`YAW`), rad: the estimator's yaw becomes `yaw` and the
    /// heading is referenced to true north (unless the magnetometer references it). A
    /// non-finite value changes nothing.
    pub fn set_yaw(&mut self, yaw: f32) {
        if !yaw.is_finite() {
            return;
        }
        self.ekf.set_yaw(yaw);
        if self.heading_ref != HeadingRef::Magnetic {
            self.heading_ref = HeadingRef::True;
        }
        // The jump is not a turn.
        self.rot_yaw = None;
    }

    /// Restart the estimator as at power-up (`RAW,2`): a fresh `Ekf` with the current
    /// settings, whose initialisation window starts with the next [`Pipeline::step`]; the
    /// conditioner's history cleared (the lever arm's previous rate); the heading referenced
    /// to `init.yaw0` again (relative) and no rate of turn until the next output after it.
    ///
    /// Kept: the settings, the last depth and the output schedule (the cycle count that
    /// decimates the sentences to the output rate).
    pub fn restart(&mut self) {
        self.conditioner = Conditioner::new(self.settings.conditioning);
        self.ekf = Ekf::new(self.settings.filter);
        self.heading_ref = HeadingRef::Relative;
        self.interval_status = Status::NONE;
        self.rot_yaw = None;
        self.rot_time_s = 0.0;
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
        let (gyro, accel) =
            self.conditioner.condition(inputs.dt, gyro_raw, accel_raw, self.ekf.gyro_bias());
        let mut sample = ekf_core::ImuSample::new(inputs.dt, gyro, accel);
        sample.mag = inputs.mag_ut.map(|m| self.conditioner.condition_mag(Vec3::from_array(m)));

        let flags = self.ekf.update(&sample);
        status.insert(Status::from_flags(flags));
        let mag_on = self.settings.filter.mag.enabled;
        if mag_on && flags.contains(Flags::MAG_USED) {
            self.reference_heading(HeadingRef::Magnetic);
        } else if !mag_on && self.heading_ref == HeadingRef::Magnetic {
            // The gyros carry the referenced heading on, as after `YAW`.
            self.reference_heading(HeadingRef::True);
        }
        self.interval_status |= status;
        if inputs.dt.is_finite() && inputs.dt > 0.0 {
            self.rot_time_s += inputs.dt;
        }
        self.rot_jumps += self.ekf.take_heading_jumps();

        let attitude = self.ekf.attitude();
        let mut sentences = Sentences::default();
        if self.cycle % self.settings.output_divider() == 0 {
            let euler = self.ekf.euler();
            let set = self.settings.sentences;
            let valid = attitude_valid(self.interval_status);
            let tilt_ok = tilt_valid(self.interval_status);
            // The rate of turn: the gyros' share of the heading's change since the last output
            // (what the magnetometer's pull and the yaw hold moved it is no turn; issue #38
            // point 5) over the time.
            let rate = match self.rot_yaw {
                Some(prev) if self.rot_time_s > 0.0 => {
                    Some(mathf::wrap_pi(euler.yaw - prev - self.rot_jumps) / self.rot_time_s)
                }
                _ => None,
            };
            self.rot_yaw = Some(euler.yaw);
            self.rot_time_s = 0.0;
            self.rot_jumps = 0.0;
            if set.prdid && valid {
                sentences.items[0] = nmea::prdid(&euler).ok();
            }
            if self.settings.sentences.pinah {
                let data = PinahData {
                    euler,
                    quaternion: attitude,
                    depth_m: self.last_depth,
                    status,
                    cycle_us: inputs.last_cycle_us,
                    heading_ref: self.heading_ref,
                };
                sentences.items[1] = nmea::pinah(&data).ok();
            }
            let talker = set.talker;
            if set.hdt && valid && self.heading_ref.is_true() {
                sentences.items[2] = nmea::hdt(talker, euler.yaw).ok();
            }
            // Magnetic heading = true heading − declination (magnetic north east of true).
            let declination = self.settings.filter.mag.declination;
            let magnetic = valid && self.heading_ref == HeadingRef::Magnetic;
            if set.hdg && magnetic {
                sentences.items[3] = nmea::hdg(talker, euler.yaw - declination, declination).ok();
            }
            if set.hdm && magnetic {
                sentences.items[4] = nmea::hdm(talker, euler.yaw - declination).ok();
            }
            if set.rot {
                sentences.items[5] = nmea::rot(talker, rate, valid && rate.is_some()).ok();
            }
            if set.xdr {
                let tilt = tilt_ok.then_some((euler.pitch, euler.roll));
                let depth_ok = !self.interval_status.contains(Status::DEPTH_RAIL)
                    && !self.interval_status.contains(Status::ADC_FAULT);
                let depth = self.last_depth.filter(|_| depth_ok);
                sentences.items[6] = nmea::xdr(talker, tilt, depth).and_then(Result::ok);
            }
            self.interval_status = Status::NONE;
        }
        self.cycle = self.cycle.wrapping_add(1);
        Step { status, attitude, depth_m: depth, sentences, heading_ref: self.heading_ref }
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
        let (gyro, accel) =
            conditioner.condition(inputs.dt, gyro_raw, accel_raw, self.ekf.gyro_bias());
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
            } else {
                // The window starts again from `init.yaw0`.
                self.reference_heading(HeadingRef::Relative);
            }
            self.ekf = ekf;
        }
        self.settings = settings;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::board;
    use crate::nmea::verify;
    use ekf_core::mathf::deg;
    use ekf_core::Euler;

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
        // 1 s of window and 7 s after it: the low-pass takes a few seconds to bring the
        // window's 0.008° off (its first samples) to the measured tilt.
        for _ in 0..400 {
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

    /// The lever-arm compensation (the Seahog's 0.36 m arm, on by default) works on the rate
    /// less the estimated gyro bias: a still, tilted board whose gyros read only their bias
    /// (2, 3, −1 °/s) settles on its true tilt. On the raw rate it would remove a centripetal
    /// `b × (b × r)` of 1.5·10⁻³ m/s² from gravity: 0.009° of tilt.
    #[test]
    fn gyro_bias_adds_no_centripetal_tilt() {
        let mut s = PipelineSettings::default();
        s.filter.init.window_s = 1.0;
        assert!(s.conditioning.lever_arm.centripetal && s.conditioning.lever_arm.r.norm() > 0.3);
        let mut p = Pipeline::new(s);
        let truth = Euler::new(deg(5.0), deg(10.0), 0.0).to_quaternion();
        let f_sensor = board::ACCEL_AXES.inverse().apply(truth.down_in_body() * -1.0);
        for _ in 0..1500 {
            p.step(&Inputs {
                dt: 0.02,
                adc: Some(still_adc([2.0, 3.0, -1.0])),
                accel_g: Some(f_sensor.to_array()),
                ..Inputs::default()
            });
        }
        let bias = p.ekf().gyro_bias().norm();
        assert!((bias - deg(3.742)).abs() < deg(0.01), "bias {bias} rad/s");
        let e = Euler::from_quaternion(p.ekf().attitude());
        let (roll, pitch) = ((e.roll - deg(5.0)).abs(), (e.pitch - deg(10.0)).abs());
        assert!(roll.max(pitch) < deg(0.002), "roll error {roll}, pitch error {pitch} rad");
    }

    #[test]
    fn output_rate_divides_the_filter_rate_and_both_sentences_verify() {
        let mut s = PipelineSettings { output_rate_hz: 5, ..PipelineSettings::default() };
        s.filter.init.window_s = 0.0;
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
        // With a zero-length window the bias is the first (still) sample's rate. Each sample
        // is the mean rate over the period that ends with it (the averaged ADC frames), so
        // the yaw is 10 °/s for 1 s, minus the bias for 1 s.
        let bias_z = p.ekf().gyro_bias().z;
        let expect = deg(10.0) - bias_z;
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

    /// Every sentence on, a 1 s window.
    fn all_on() -> PipelineSettings {
        let mut s = PipelineSettings::default();
        s.filter.init.window_s = 1.0;
        s.sentences =
            SentenceSet { hdt: true, hdg: true, hdm: true, rot: true, xdr: true, ..s.sentences };
        s
    }

    /// The bodies of a step's sentences.
    fn bodies(step: &Step) -> Vec<String> {
        step.sentences.iter().map(|s| verify(s.as_bytes()).unwrap().to_string()).collect()
    }

    /// Bits 20–21 of `$PINAH`'s status word: the heading reference.
    fn pinah_ref(body: &str) -> u32 {
        let status = body.split(',').nth(9).unwrap();
        assert_eq!(status.len(), 6);
        (u32::from_str_radix(status, 16).unwrap() >> 20) & 3
    }

    fn with_prefix<'a>(b: &'a [String], prefix: &str) -> Option<&'a str> {
        b.iter().find(|x| x.starts_with(prefix)).map(String::as_str)
    }

    fn still(adc_rates: [f32; 3]) -> Inputs {
        Inputs {
            dt: 0.02,
            adc: Some(still_adc(adc_rates)),
            accel_g: Some(FLAT),
            ..Inputs::default()
        }
    }

    #[test]
    fn standard_sentences_wait_for_a_valid_attitude_and_a_true_heading() {
        let mut p = Pipeline::new(all_on());
        // The first output, initialising: PINAH (its status says so), ROT with V, and XDR
        // with the depth only.
        let b = bodies(&p.step(&still([0.0; 3])));
        assert_eq!(b.len(), 3, "{b:?}");
        assert!(b[0].starts_with("PINAH,") && pinah_ref(&b[0]) == 0, "{b:?}");
        assert_eq!(b[1], "HCROT,,V");
        assert!(b[2].starts_with("HCXDR,D,") && b[2].ends_with(",M,DEPTH"), "{b:?}");
        let mut last = Vec::new();
        for _ in 0..99 {
            let b = bodies(&p.step(&still([0.0; 3])));
            if !b.is_empty() {
                last = b;
            }
        }
        // Initialised, heading relative: no HDT; no HDG/HDM without the magnetometer.
        assert!(!p.ekf().last_flags().contains(Flags::INITIALISING));
        assert_eq!(p.heading_ref(), HeadingRef::Relative);
        assert!(with_prefix(&last, "PRDID,").is_some(), "{last:?}");
        assert_eq!(with_prefix(&last, "HCROT,"), Some("HCROT,0.0,A"));
        assert_eq!(
            with_prefix(&last, "HCXDR,").map(|x| x
                .split(',')
                .take(10)
                .collect::<Vec<_>>()
                .join(",")),
            Some("HCXDR,A,0.0,D,PTCH,A,0.0,D,ROLL,D".into())
        );
        assert!(with_prefix(&last, "HCHDT").is_none() && with_prefix(&last, "HCHD").is_none());
        // The operator's true heading: HDT goes out, PINAH says T.
        p.set_yaw(deg(-30.0));
        assert_eq!(p.heading_ref(), HeadingRef::True);
        let mut b = Vec::new();
        while b.is_empty() {
            b = bodies(&p.step(&still([0.0; 3])));
        }
        assert_eq!(with_prefix(&b, "HCHDT,"), Some("HCHDT,330.0,T"));
        assert_eq!(pinah_ref(with_prefix(&b, "PINAH,").unwrap()), 1);
        // The jump of `YAW` is not a turn: the first rate after it is unknown.
        assert_eq!(with_prefix(&b, "HCROT,"), Some("HCROT,,V"));
        assert!(with_prefix(&b, "HCHDG").is_none() && with_prefix(&b, "HCHDM").is_none());
        // The talker follows the setting.
        let mut s = *p.settings();
        s.sentences.talker = registry::talker_code(*b"II");
        p.apply_settings(s);
        let mut b = Vec::new();
        while b.is_empty() {
            b = bodies(&p.step(&still([0.0; 3])));
        }
        assert_eq!(with_prefix(&b, "IIHDT,"), Some("IIHDT,330.0,T"));
        assert!(with_prefix(&b, "IIROT,").is_some() && with_prefix(&b, "IIXDR,").is_some());
        // A filter setting changed during the window restarts it from `init.yaw0`: relative.
        let mut q = Pipeline::new(all_on());
        q.set_yaw(deg(10.0));
        assert_eq!(q.heading_ref(), HeadingRef::True);
        let mut s = *q.settings();
        s.filter.gate.norm_tolerance = 0.2;
        q.apply_settings(s);
        assert_eq!(q.heading_ref(), HeadingRef::Relative);
    }

    #[test]
    fn a_fault_in_the_interval_withholds_the_sentences_without_status() {
        let mut s = all_on();
        s.filter.init.window_s = 0.0;
        let mut p = Pipeline::new(s);
        p.set_yaw(0.0);
        // Outputs every 5 cycles (10 Hz of 50), the first at the first cycle.
        for _ in 0..6 {
            p.step(&still([0.0; 3]));
        }
        // One ADC frame missing in the interval (not at the output's cycle).
        let mut b = Vec::new();
        for k in 0..5 {
            let inputs =
                if k == 1 { Inputs { adc: None, ..still([0.0; 3]) } } else { still([0.0; 3]) };
            b.extend(bodies(&p.step(&inputs)));
        }
        assert_eq!(b.len(), 2, "{b:?}");
        assert!(b[0].starts_with("PINAH,"));
        assert!(b[1].starts_with("HCROT,") && b[1].ends_with(",V"), "{b:?}");
        // The next interval is clean again.
        let mut b = Vec::new();
        for _ in 0..5 {
            b.extend(bodies(&p.step(&still([0.0; 3]))));
        }
        assert_eq!(b.len(), 5, "{b:?}");
        // The gyro at a rail (saturated): withheld too.
        let mut b = Vec::new();
        for _ in 0..5 {
            b.extend(bodies(&p.step(&Inputs { board: Status::GYRO_RAIL, ..still([0.0; 3]) })));
        }
        assert_eq!(b.len(), 3, "{b:?}");
        assert!(b[1].ends_with(",V") && b[2].starts_with("HCXDR,D,"), "{b:?}");
        // The depth at its rail: XDR keeps pitch and roll, drops the depth.
        let mut b = Vec::new();
        for _ in 0..5 {
            b.extend(bodies(&p.step(&Inputs { board: Status::DEPTH_RAIL, ..still([0.0; 3]) })));
        }
        let x = with_prefix(&b, "HCXDR,").unwrap();
        assert!(x.ends_with(",D,ROLL"), "{x}");
    }

    #[test]
    fn rate_of_turn_is_the_heading_rate_in_degrees_per_minute() {
        let mut s = all_on();
        s.filter.init.window_s = 0.0;
        s.filter.rest.enabled = false;
        let mut p = Pipeline::new(s);
        p.step(&still([0.0; 3]));
        // 10 °/s about body z (down): the yaw gyro's output falls with the default map.
        let mut rates = Vec::new();
        for _ in 0..100 {
            let b = bodies(&p.step(&still([0.0, 0.0, -10.0])));
            if let Some(r) = with_prefix(&b, "HCROT,") {
                rates.push(r.to_string());
            }
        }
        // After the first interval (trapezoidal start), 600 °/min, bow to starboard.
        for r in &rates[2..] {
            let v: f32 = r.split(',').nth(1).unwrap().parse().unwrap();
            assert!((v - 600.0).abs() < 1.0, "{r}");
            assert!(r.ends_with(",A"));
        }
        // The other way: negative.
        let mut last = String::new();
        for _ in 0..20 {
            let b = bodies(&p.step(&still([0.0, 0.0, 5.0])));
            if let Some(r) = with_prefix(&b, "HCROT,") {
                last = r.to_string();
            }
        }
        let v: f32 = last.split(',').nth(1).unwrap().parse().unwrap();
        assert!((v + 300.0).abs() < 1.0, "{last}");
    }

    #[test]
    fn the_magnetometer_references_the_heading_hdg_hdm_and_hdt_agree() {
        let mut s = all_on();
        s.filter.init.window_s = 0.0;
        s.filter.mag.enabled = true;
        let mut p = Pipeline::new(s);
        // Level, bow to magnetic north: the field in NED is (F cos dip, 0, F sin dip).
        let m = &s.filter.mag;
        let ned = Vec3::new(m.field_ut * m.dip.cos(), 0.0, m.field_ut * m.dip.sin());
        let sensor = board::MAG_AXES.inverse().apply(ned);
        let mut b = Vec::new();
        for _ in 0..500 {
            let step = p.step(&Inputs { mag_ut: Some(sensor.to_array()), ..still([0.0; 3]) });
            if step.sentences.iter().next().is_some() {
                b = bodies(&step);
            }
        }
        assert_eq!(p.heading_ref(), HeadingRef::Magnetic);
        // Magnetic heading 0, declination −25.5° (west): true heading 334.5°.
        assert_eq!(with_prefix(&b, "HCHDM,"), Some("HCHDM,0.0,M"), "{b:?}");
        assert_eq!(with_prefix(&b, "HCHDG,"), Some("HCHDG,0.0,,,25.5,W"));
        assert_eq!(with_prefix(&b, "HCHDT,"), Some("HCHDT,334.5,T"));
        assert_eq!(pinah_ref(with_prefix(&b, "PINAH,").unwrap()), 2);
        // The magnetometer switched off: the gyros carry the true heading on.
        let mut s2 = *p.settings();
        s2.filter.mag.enabled = false;
        p.apply_settings(s2);
        let mut b = Vec::new();
        for _ in 0..5 {
            b.extend(bodies(&p.step(&still([0.0; 3]))));
        }
        assert_eq!(p.heading_ref(), HeadingRef::True);
        assert!(with_prefix(&b, "HCHDT,").is_some() && with_prefix(&b, "HCHDM").is_none());
    }

    /// The rate of turn starts again at every change of the heading's reference (issue #28):
    /// the magnetometer taking over moves a relative heading of 0° to 334.5° true, and letting
    /// go, `YAW` and a restart (`RAW,2`) move it too, none of them a turn. The first output
    /// after each has an empty, invalid `ROT`; before, the take-over printed
    /// `$HCROT,-11252.8,A` here. The magnetometer's pull over the next outputs is no turn
    /// either (issue #38 point 5: it printed −3,185 and −381 °/min on the next two): the rate
    /// is the gyros' share of the heading's change, under 1 °/min for this still board (what
    /// is left is the bias the magnetometer corrects, propagated).
    #[test]
    fn the_rate_of_turn_restarts_when_the_heading_reference_changes() {
        let mut s = all_on();
        s.filter.init.window_s = 0.0;
        let mut p = Pipeline::new(s);
        let m = s.filter.mag;
        let ned = Vec3::new(m.field_ut * m.dip.cos(), 0.0, m.field_ut * m.dip.sin());
        let field = Some(board::MAG_AXES.inverse().apply(ned).to_array());
        // The ROT bodies of `n` steps, and whether each step changed the reference.
        let run = |p: &mut Pipeline, n: usize, mag: bool| {
            let mut rots = Vec::new();
            for _ in 0..n {
                let before = p.heading_ref();
                let inputs = Inputs { mag_ut: field.filter(|_| mag), ..still([0.0; 3]) };
                let step = p.step(&inputs);
                let changed = p.heading_ref() != before;
                if let Some(r) = with_prefix(&bodies(&step), "HCROT,") {
                    rots.push((r.to_string(), changed));
                }
            }
            rots
        };
        let steady = run(&mut p, 50, false);
        assert!(steady.iter().skip(1).all(|(r, _)| r.ends_with(",A")), "{steady:?}");
        // The magnetometer takes over.
        let mut on = *p.settings();
        on.filter.mag.enabled = true;
        p.apply_settings(on);
        let rots = run(&mut p, 50, true);
        assert_eq!(p.heading_ref(), HeadingRef::Magnetic);
        assert_eq!(rots.first().map(|r| r.0.as_str()), Some("HCROT,,V"), "{rots:?}");
        let rate = |r: &str| r.split(',').nth(1).and_then(|v| v.parse::<f32>().ok());
        assert!(
            rots.iter().skip(1).all(|(r, _)| rate(r).is_some_and(|v| v.abs() < 2.0)),
            "the magnetometer's pull read as a turn: {rots:?}"
        );
        // It lets go: the gyros carry the true heading on.
        let mut off = *p.settings();
        off.filter.mag.enabled = false;
        p.apply_settings(off);
        let rots = run(&mut p, 50, false);
        assert_eq!(p.heading_ref(), HeadingRef::True);
        assert_eq!(rots.first().map(|r| r.0.as_str()), Some("HCROT,,V"), "{rots:?}");
        assert!(rots.iter().skip(1).all(|(r, _)| r.ends_with(",A")), "{rots:?}");
        // `YAW` and a restart.
        p.set_yaw(deg(120.0));
        let rots = run(&mut p, 50, false);
        assert_eq!(rots.first().map(|r| r.0.as_str()), Some("HCROT,,V"), "{rots:?}");
        p.restart();
        let rots = run(&mut p, 50, false);
        assert_eq!(rots.first().map(|r| r.0.as_str()), Some("HCROT,,V"), "{rots:?}");
    }

    /// The longest output (every sentence at its widest) and the highest output rate at which
    /// 115200 baud (11,520 bytes/s, 8N1) carries it: the figures of `docs/marine.md`.
    #[test]
    fn longest_output_and_the_rate_the_serial_line_carries() {
        let t = registry::talker_code(*b"HC");
        let worst = Euler::new(deg(-179.99), deg(-89.99), deg(-179.99));
        let pinah = nmea::pinah(&PinahData {
            euler: worst,
            quaternion: Quaternion::new(0.1234, -0.9876, -0.5432, -1.0),
            depth_m: Some(-9.9),
            status: Status(u32::MAX),
            cycle_us: u32::MAX,
            heading_ref: HeadingRef::Magnetic,
        })
        .unwrap();
        let lens = [
            nmea::prdid(&worst).unwrap().len(),
            pinah.len(),
            nmea::hdt(t, deg(359.9)).unwrap().len(),
            nmea::hdg(t, deg(359.9), deg(-179.9)).unwrap().len(),
            nmea::hdm(t, deg(359.9)).unwrap().len(),
            nmea::rot(t, Some(deg(-1666.0)), true).unwrap().len(),
            nmea::xdr(t, Some((deg(-89.9), deg(-179.9))), Some(999.9)).unwrap().unwrap().len(),
        ];
        assert_eq!(lens, [33, 82, 19, 27, 19, 22, 58]);
        let total: usize = lens.iter().sum();
        assert_eq!(total, 260);
        // Bytes per second at 115200 baud, 10 bits a byte.
        let line = board::USART_BAUD as usize / 10;
        assert_eq!(line / total, 44);
        // The default output (PRDID and PINAH) at the highest rate, 50 Hz.
        assert!((lens[0] + lens[1]) * 50 <= line);
    }
}
