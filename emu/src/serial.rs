//! The serial firmware of `ekf-emu-serial`: what the board's application does with its USART,
//! built from the firmware library's public API only, as `ahrs-tool emulate` does on the host.
//!
//! - Every filter cycle: the next record of the embedded trace (looping), with
//!   [`DEPTH_M`] added to its depth and `dt` = 1 / filter rate, goes through
//!   `Pipeline::conditioned_sample`, `Pipeline::step` and `Device::on_cycle`; the cycle's late
//!   reply, then its `$PRDID`/`$PINAH` (or, in raw mode, `$PINAW`/`$PINAX`, and with `RAW,2`
//!   the cycle's `$PRDID`) go to [`Tx`].
//! - Every received byte goes through `LineAssembler` and `Device::handle` (with the flash);
//!   the reply goes to [`Tx`] and the action is applied (`ApplySettings` →
//!   `Pipeline::apply_settings`, `SetYaw` → `set_yaw`, `RestartEstimator` → `restart`).
//! - A cooperative operator for the six-position calibration: when a command `ACAL,<position>`
//!   passes, the board is held still in that position (gravity along the named LSM303DLH
//!   axis, a little noise, no rotation) until any other command (`ACAL,CLEAR`, the `SET`s of
//!   the fit). The trace runs on meanwhile, unseen: record `n` always feeds cycle `n` after boot (modulo its length).

use ekf_core::Vec3;
use inemo_ahrs::{
    command::{position_by_name, Action, Device, LineAssembler, LineEvent},
    nmea,
    persist::{self, Flash},
    pipeline::{Inputs, Pipeline, PipelineSettings},
};

use crate::trace;

/// Depth added to the trace's (the packed trace has none: 0 m), m.
pub const DEPTH_M: f32 = 2.5;
/// Zero-rate output voltage of the analog gyros, V (as `build.rs`).
const GYRO_ZERO_V: f32 = 1.5;
/// Gyro noise of the board held in a calibration position, °/s (standard deviation).
const POSE_GYRO_NOISE_DPS: f32 = 0.03;
/// Accelerometer noise of the board held in a calibration position, g (standard deviation).
const POSE_ACCEL_NOISE_G: f32 = 0.0015;

/// The serial transmitter.
pub trait Tx {
    /// Send `bytes` (in order; a transmitter may drop what it cannot send).
    fn send(&mut self, bytes: &[u8]);
}

/// The emulated board's firmware state.
pub struct SerialFirmware<'f, F: Flash> {
    device: Device,
    pipeline: Pipeline,
    flash: &'f mut F,
    assembler: LineAssembler,
    /// Index of the next trace record.
    next: usize,
    /// Raw accelerometer direction (g, sensor axes) while a calibration position is held.
    pose: Option<Vec3>,
    /// Noise generator state (xorshift32).
    rng: u32,
}

impl<'f, F: Flash> SerialFirmware<'f, F> {
    /// Boot: load the settings from `flash` (the newest valid record, or the defaults) and
    /// start the pipeline with them, as the application does.
    pub fn boot(flash: &'f mut F, reset_cause: &'static str) -> Self {
        let loaded = persist::load(&*flash);
        let device = Device::new(&loaded, reset_cause);
        let pipeline = Pipeline::new(*device.settings());
        SerialFirmware {
            device,
            pipeline,
            flash,
            assembler: LineAssembler::new(),
            next: 0,
            pose: None,
            rng: 0x2545_f491,
        }
    }

    /// The filter rate in use, Hz (the caller paces [`SerialFirmware::cycle`] with it).
    pub fn filter_rate_hz(&self) -> u16 {
        self.device.settings().filter_rate_hz
    }

    /// Index of the trace record the next cycle uses (cycles since boot, modulo the trace's
    /// length).
    pub fn trace_index(&self) -> usize {
        self.next
    }

    /// One received byte.
    pub fn receive(&mut self, byte: u8, tx: &mut impl Tx) {
        let Some(event) = self.assembler.push(byte) else { return };
        self.follow_acal(&event);
        let r = self.device.handle(&event, &mut *self.flash);
        if let Some(reply) = r.reply {
            tx.send(reply.as_bytes());
        }
        self.act(r.action);
    }

    /// One filter cycle; `last_cycle_us` is the previous cycle's duration (reported in
    /// `$PINAH`).
    pub fn cycle(&mut self, last_cycle_us: u32, tx: &mut impl Tx) {
        let mut inputs = self.board_inputs();
        inputs.dt = 1.0 / f32::from(self.filter_rate_hz().max(1));
        inputs.last_cycle_us = last_cycle_us;
        let sample = self.pipeline.conditioned_sample(&inputs);
        let step = self.pipeline.step(&inputs);
        self.device.set_heading_ref(step.heading_ref);
        let out = self.device.on_cycle(&inputs, &sample, step.attitude);
        if let Some(reply) = &out.reply {
            tx.send(reply.as_bytes());
        }
        if self.device.raw_mode() {
            for s in out.raw_sentences() {
                tx.send(s.as_bytes());
            }
        } else {
            for s in step.sentences.iter() {
                tx.send(s.as_bytes());
            }
        }
        self.act(out.action);
    }

    fn act(&mut self, action: Option<Action>) {
        match action {
            Some(Action::ApplySettings { .. }) => {
                self.pipeline.apply_settings(*self.device.settings())
            }
            Some(Action::SetYaw(yaw)) => self.pipeline.set_yaw(yaw),
            Some(Action::RestartEstimator) => self.pipeline.restart(),
            None => {}
        }
    }

    /// The cooperative operator: hold the board in the position of an `ACAL,<position>`.
    fn follow_acal(&mut self, event: &LineEvent) {
        if let Some(pose) = operator_pose(event) {
            self.pose = pose;
        }
    }

    /// Approximately normal noise, zero mean, standard deviation `sigma` (sum of four
    /// uniforms).
    fn noise(&mut self, sigma: f32) -> f32 {
        let mut sum = 0.0;
        for _ in 0..4 {
            let mut x = self.rng;
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            self.rng = x;
            sum += (x >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
        }
        // Four uniforms on (−0.5, 0.5): variance 1/3.
        sum * 1.732_050_8 * sigma
    }

    /// What the hardware tasks deliver this cycle: the next trace record, or the board held
    /// still in a calibration position. Conversions use the board's physical constants (the
    /// default settings), whatever the settings in use.
    fn board_inputs(&mut self) -> Inputs {
        let s = PipelineSettings::default();
        let counts = |volts: f32| volts / s.adc.vref_v * s.adc.full_scale_counts;
        let d = &s.depth;
        let depth_counts = counts(d.water_density_kg_m3 * d.gravity_m_s2 * DEPTH_M / d.pa_per_volt);
        let rec = trace::records().nth(self.next).unwrap_or_default();
        self.next = (self.next + 1) % trace::len().max(1);
        let Some(pose) = self.pose else {
            let mut inputs = trace::inputs(rec);
            if let Some(adc) = inputs.adc.as_mut() {
                adc.depth += depth_counts;
            }
            return inputs;
        };
        let mut inputs = trace::inputs(&[]);
        let sens = s.gyro.sensitivity_v_per_dps;
        let zero = counts(GYRO_ZERO_V);
        let p = d.surface_pressure_pa + d.water_density_kg_m3 * d.gravity_m_s2 * DEPTH_M;
        if let Some(adc) = inputs.adc.as_mut() {
            adc.gyro_x = counts(GYRO_ZERO_V + self.noise(POSE_GYRO_NOISE_DPS) * sens[0]);
            adc.gyro_y = counts(GYRO_ZERO_V + self.noise(POSE_GYRO_NOISE_DPS) * sens[1]);
            adc.gyro_xy_ref = zero;
            adc.gyro_z = counts(GYRO_ZERO_V + self.noise(POSE_GYRO_NOISE_DPS) * sens[2]);
            adc.gyro_z_ref = zero;
            adc.depth = counts((p - d.offset_pa) / d.pa_per_volt);
        }
        // LSM303DLH at ±2 g, 1 mg per LSB.
        let mut lsb = |x: f32| {
            let n = x + self.noise(POSE_ACCEL_NOISE_G);
            let counts = n * 1000.0 + if n < 0.0 { -0.5 } else { 0.5 };
            (counts as i32).clamp(-2048, 2047) as f32 * 1e-3
        };
        inputs.accel_g = Some([lsb(pose.x), lsb(pose.y), lsb(pose.z)]);
        inputs
    }
}

/// The cooperative operator of the six-position calibration, shared by the emulators
/// (`ekf-emu-serial` on QEMU, `ahrs-tool emulate`): for a command line with a valid checksum,
/// the board's pose it asks for — `Some(Some(g))`: hold still with gravity `g` (g, body) as in
/// the position named by `ACAL,<position>`; `Some(None)`: any other command (`ACAL,CLEAR`, the
/// `SET`s of the fitted calibration) puts the board back to its scenario; `None`: not a
/// command line, nothing changes.
pub fn operator_pose(event: &LineEvent) -> Option<Option<Vec3>> {
    let LineEvent::Line(line) = event else { return None };
    let body = nmea::verify(line.as_bytes()).ok()?;
    let mut f = body.split(nmea::is_comma);
    if !f.next().is_some_and(|a| a.eq_ignore_ascii_case("PINAC")) {
        return None;
    }
    let acal = f.next().is_some_and(|v| v.eq_ignore_ascii_case("ACAL"));
    Some(f.next().filter(|_| acal).and_then(position_by_name).map(|p| p.reference_g()))
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::{string::String, vec::Vec};

    use ekf_core::AttitudeFilter;
    use inemo_ahrs::persist::SimFlash;

    use super::*;

    #[derive(Default)]
    struct Capture(Vec<u8>);

    impl Tx for Capture {
        fn send(&mut self, bytes: &[u8]) {
            self.0.extend_from_slice(bytes);
        }
    }

    fn command(fw: &mut SerialFirmware<'_, SimFlash>, body: &str) -> String {
        let mut tx = Capture::default();
        let body = std::format!("PINAC,{body}");
        let mut sum = 0u8;
        for b in body.bytes() {
            sum ^= b;
        }
        for b in std::format!("${body}*{sum:02X}\r\n").bytes() {
            fw.receive(b, &mut tx);
        }
        String::from_utf8(tx.0).unwrap()
    }

    #[test]
    fn streams_replies_and_persists() {
        let mut flash = SimFlash::new();
        {
            let mut fw = SerialFirmware::boot(&mut flash, "POR");
            let mut tx = Capture::default();
            for _ in 0..50 {
                fw.cycle(0, &mut tx);
            }
            let text = String::from_utf8(tx.0).unwrap();
            // 1 s at the default 10 Hz output rate: 10 $PINAH, depth 2.5 m; no $PRDID during
            // the start-up window (it has no status field: withheld while not valid).
            assert_eq!(text.matches("$PINAH,").count(), 10, "{text}");
            assert_eq!(text.matches("$PRDID,").count(), 0, "{text}");
            let depth = text.lines().find(|l| l.starts_with("$PINAH")).unwrap();
            assert_eq!(depth.split(',').nth(8), Some("2.5"), "{depth}");
            assert_eq!(fw.trace_index(), 50);
            let set = command(&mut fw, "SET,mag.norm_tolerance,0.07");
            assert!(set.contains("OK,SET,mag.norm_tolerance,0.07*"), "{set}");
            assert!(command(&mut fw, "SAVE").starts_with("$PINAR,OK,SAVE,A,1*"));
            assert!(command(&mut fw, "FLY").contains("ERR,?,unknown-command"));
        }
        let mut fw = SerialFirmware::boot(&mut flash, "PIN");
        assert!(
            command(&mut fw, "GET,mag.norm_tolerance").contains("OK,GET,mag.norm_tolerance,0.07*")
        );
        assert!(command(&mut fw, "STATUS").starts_with("$PINAR,OK,STATUS,A,1,PIN,"));
    }

    #[test]
    fn raw_mode_2_restarts_the_estimator_and_sends_each_cycles_prdid() {
        let mut flash = SimFlash::new();
        let mut fw = SerialFirmware::boot(&mut flash, "POR");
        let mut tx = Capture::default();
        for _ in 0..600 {
            fw.cycle(0, &mut tx);
        }
        assert!(fw.pipeline.ekf().is_initialised());
        assert!(command(&mut fw, "RAW,2").starts_with("$PINAR,OK,RAW,2*"));
        assert!(!fw.pipeline.ekf().is_initialised(), "a new initialisation window");
        let mut tx = Capture::default();
        for _ in 0..3 {
            fw.cycle(0, &mut tx);
        }
        let text = String::from_utf8(tx.0).unwrap();
        let kinds: Vec<&str> = text.lines().map(|l| l.get(..6).unwrap_or(l)).collect();
        assert_eq!(kinds, ["$PINAW", "$PINAX", "$PRDID"].repeat(3), "{text}");
        assert!(text.starts_with("$PINAW,0.0200,"), "t restarts with the estimator: {text}");
        let status = command(&mut fw, "STATUS");
        assert!(status.contains(",0005,"), "STATUS flags: no record, raw mode: {status}");
    }

    #[test]
    fn holds_the_calibration_position() {
        let mut flash = SimFlash::new();
        let mut fw = SerialFirmware::boot(&mut flash, "POR");
        let run = command(&mut fw, "ACAL,YDOWN,0.5");
        assert!(run.contains("OK,ACAL,RUN,YDOWN"), "{run}");
        let mut tx = Capture::default();
        for _ in 0..40 {
            fw.cycle(0, &mut tx);
        }
        assert_eq!(fw.trace_index(), 40, "the trace runs on while a position is held");
        let text = String::from_utf8(tx.0).unwrap();
        let done = text.lines().find(|l| l.contains("ACAL,DONE,YDOWN,"));
        let done = done.unwrap_or_else(|| panic!("{text}"));
        let f: Vec<f64> = done.split(',').skip(5).take(3).map(|v| v.parse().unwrap()).collect();
        let y = position_by_name("YDOWN").unwrap().reference_g().y;
        assert!(f[0].abs() < 0.002 && (f[1] - f64::from(y)).abs() < 0.002, "{done}");
        assert!(f[2].abs() < 0.002, "{done}");
        assert!(command(&mut fw, "ACAL,CLEAR").contains("OK,ACAL,CLEAR"));
    }

    #[test]
    fn the_operator_holds_the_named_position_until_another_command() {
        let event = |text: &str| {
            let mut asm = LineAssembler::new();
            text.bytes().find_map(|b| asm.push(b)).expect("a complete line")
        };
        let line = |body: &str| {
            let sum = body.bytes().fold(0u8, |s, b| s ^ b);
            std::format!("${body}*{sum:02X}\r\n")
        };
        let xup = operator_pose(&event(&line("PINAC,ACAL,XUP")));
        assert_eq!(xup, Some(Some(Vec3::new(1.0, 0.0, 0.0))));
        let zdown = operator_pose(&event(&line("PINAC,ACAL,zdown")));
        assert_eq!(zdown, Some(Some(Vec3::new(0.0, 0.0, -1.0))));
        assert_eq!(operator_pose(&event(&line("PINAC,SET,accel_cal.o,0,0,0"))), Some(None));
        assert_eq!(operator_pose(&event(&line("PINAC,ACAL,CLEAR"))), Some(None));
        // Not commands: a bad checksum, another talker.
        assert_eq!(operator_pose(&event("$PINAC,ACAL,XUP*00\r\n")), None);
        assert_eq!(operator_pose(&event(&line("GPGGA,ACAL,XUP"))), None);
    }
}
