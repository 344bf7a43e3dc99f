//! The device emulator: the firmware library (`Pipeline`, `command::Device`, `LineAssembler`,
//! the NMEA writers) run on the host behind a pseudo-terminal, fed by the `host-tests`
//! simulator. QEMU cannot emulate the STM32F103's ADC, I²C and USART as the board wires them,
//! so this is the emulation: the same library code the firmware runs, with the simulated
//! sensor readings turned back into what the hardware tasks deliver (averaged ADC counts,
//! LSM303DLH readings in g), as `ekf-emu` does.

use std::{
    fs::File,
    io::{self, Read, Write},
    os::fd::AsRawFd,
    path::{Path, PathBuf},
    thread,
    time::{Duration, Instant},
};

use ekf_core::{Vec3, GRAVITY};
use host_tests::sim::{Scenario, SimSample, Simulator};
use nix::fcntl::{fcntl, FcntlArg, OFlag};
use serialport::{SerialPort, TTYPort};

use inemo_ahrs::{
    adc::{at_rail, AdcMean, Rails},
    board,
    command::{Action, Device, LineAssembler, LineEvent},
    persist::{self, SimFlash, Source},
    pipeline::{Inputs, Pipeline, PipelineSettings},
    supervision::{clock_check::HseCheck, selftest},
};

/// Zero-rate output voltage of the analog gyros, V (as `ekf-emu`).
const GYRO_ZERO_V: f32 = 1.5;

/// Emulator options.
#[derive(Clone, Debug)]
pub struct Options {
    /// Simulator scenario (`host-tests` names, plus `still`).
    pub scenario: String,
    /// Time scale: simulated seconds per real second.
    pub speed: f64,
    /// Constant simulated depth, m.
    pub depth_m: f32,
    /// Simulator seed.
    pub seed: u64,
    /// Put the simulated board into the position named by every `ACAL,<pos>` command seen
    /// (a cooperative operator), back to the scenario on any other command (`ACAL,CLEAR`,
    /// the `SET`s of the fit).
    pub follow_acal: bool,
    /// Simulate the magnetometer (the default `mag.*` settings' field).
    pub mag: bool,
    /// The magnetometer does not answer (`SELFTEST`: FAIL), a test helper.
    pub broken_mag: bool,
}

/// A pseudo-terminal: the master side (ours) and the slave's path (the tool's).
pub struct Pty {
    /// Master side, non-blocking, with a zero timeout.
    pub master: TTYPort,
    /// Kept open so that the master never sees a hang-up between clients.
    _slave: TTYPort,
    /// Path of the slave side.
    pub path: PathBuf,
}

/// Open a pseudo-terminal (`serialport`'s `TTYPort::pair`: the slave in raw mode, no echo, no
/// line-end translation). The master is made non-blocking, so that a write nobody reads is
/// lost rather than waited on, as on a UART.
pub fn open_pty() -> io::Result<Pty> {
    let (mut master, slave) = TTYPort::pair()?;
    master.set_timeout(Duration::ZERO)?;
    let fd = master.as_raw_fd();
    let flags = OFlag::from_bits_truncate(fcntl(fd, FcntlArg::F_GETFL)?);
    fcntl(fd, FcntlArg::F_SETFL(flags | OFlag::O_NONBLOCK))?;
    let path = slave.name().ok_or_else(|| io::Error::other("the pty's slave has no name"))?;
    Ok(Pty { master, _slave: slave, path: PathBuf::from(path) })
}

/// Open an existing device or pty path for the emulator, non-blocking.
pub fn open_path(path: &Path) -> io::Result<File> {
    use std::os::unix::fs::OpenOptionsExt;
    std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY)
        .open(path)
}

/// The simulated board: the simulator and the hardware model.
struct Board {
    scenario: Scenario,
    seed: u64,
    rate_hz: f64,
    sim: Simulator,
    mag: bool,
    depth_m: f32,
    /// Forced raw accelerometer direction (g, sensor axes) while a calibration position is held.
    pose: Option<Vec3>,
}

fn scenario_by_name(name: &str) -> Option<Scenario> {
    match name {
        "still" => Some(Scenario::StillHour),
        other => Scenario::from_name(other),
    }
}

impl Board {
    fn new(scenario: Scenario, seed: u64, rate_hz: f64, depth_m: f32, mag: bool) -> Self {
        let sim = Self::sim(scenario, seed, rate_hz, mag);
        Board { scenario, seed, rate_hz, sim, mag, depth_m, pose: None }
    }

    fn sim(scenario: Scenario, seed: u64, rate_hz: f64, mag: bool) -> Simulator {
        scenario.simulator(rate_hz, Some(1e7), seed, mag).0
    }

    fn set_rate(&mut self, rate_hz: f64) {
        self.rate_hz = rate_hz;
        self.sim = Self::sim(self.scenario, self.seed, rate_hz, self.mag);
    }

    fn next_sample(&mut self) -> SimSample {
        match self.sim.next() {
            Some(s) => s,
            None => {
                self.sim = Self::sim(self.scenario, self.seed, self.rate_hz, self.mag);
                self.sim.next().expect("simulator produces samples")
            }
        }
    }

    /// One filter cycle's hardware input: the inverse of the firmware's conversions with the
    /// board's physical constants (default settings) and axis maps.
    fn inputs(&mut self) -> Inputs {
        let s = PipelineSettings::default();
        let sample = self.next_sample();
        let row = sample.row;
        // A 12-bit conversion: the volts as counts, saturated at 0 and full scale as the ADC
        // saturates (issue #38 point 7: `--depth 5000` gave counts past full scale, read as a
        // valid depth), and whether the count is at a rail (`adc::at_rail`, as the averager
        // flags it on the board).
        let fs = s.adc.full_scale_counts;
        let mut rails = Rails::NONE;
        let mut counts_on = |volts: f32, channel: Rails| {
            let c = (volts / s.adc.vref_v * fs).clamp(0.0, fs);
            if at_rail(c.round() as u16) {
                rails = rails.union(channel);
            }
            c
        };
        let mut gyro = Vec3::from_array(row.gyro);
        let accel_g = match self.pose {
            Some(p) => {
                // Held still in a position: no rotation, gravity along the sensor axis.
                gyro -= Vec3::new(
                    sample.omega[0] as f32,
                    sample.omega[1] as f32,
                    sample.omega[2] as f32,
                );
                let noise = Vec3::new(
                    (f64::from(row.accel[0]) - sample.accel_clean[0]) as f32,
                    (f64::from(row.accel[1]) - sample.accel_clean[1]) as f32,
                    (f64::from(row.accel[2]) - sample.accel_clean[2]) as f32,
                ) * (1.0 / GRAVITY);
                p + noise
            }
            None => {
                board::ACCEL_AXES.inverse().apply(Vec3::from_array(row.accel)) * (1.0 / GRAVITY)
            }
        };
        let g = board::GYRO_AXES.inverse().apply(gyro);
        let sens = s.gyro.sensitivity_v_per_dps;
        let d = &s.depth;
        let p = d.surface_pressure_pa + d.water_density_kg_m3 * d.gravity_m_s2 * self.depth_m;
        let mut adc = AdcMean {
            gyro_x: counts_on(GYRO_ZERO_V + g.x.to_degrees() * sens[0], Rails::GYRO_X),
            gyro_y: counts_on(GYRO_ZERO_V + g.y.to_degrees() * sens[1], Rails::GYRO_Y),
            gyro_xy_ref: counts_on(GYRO_ZERO_V, Rails::GYRO_XY_REF),
            gyro_z: counts_on(GYRO_ZERO_V + g.z.to_degrees() * sens[2], Rails::GYRO_Z),
            gyro_z_ref: counts_on(GYRO_ZERO_V, Rails::GYRO_Z_REF),
            depth: counts_on((p - d.offset_pa) / d.pa_per_volt, Rails::DEPTH),
            samples: 20,
            ..AdcMean::default()
        };
        adc.rails = rails;
        // LSM303DLH at ±2 g, 1 mg per LSB.
        let lsb = |x: f32| (x * 1000.0).round().clamp(-2048.0, 2047.0) * 1e-3;
        Inputs {
            dt: (1.0 / self.rate_hz) as f32,
            adc: Some(adc),
            accel_g: Some([lsb(accel_g.x), lsb(accel_g.y), lsb(accel_g.z)]),
            // The magnetometer shares the accelerometer's axes (`board::MAG_AXES`).
            mag_ut: row
                .mag
                .map(|m| board::MAG_AXES.inverse().apply(Vec3::from_array(m)).to_array()),
            last_cycle_us: 1200,
            ..Inputs::default()
        }
    }
}

/// Write what fits; like a UART with nobody listening, the rest is lost.
fn send(port: &mut impl Write, bytes: &[u8]) {
    let mut rest = bytes;
    while !rest.is_empty() {
        match port.write(rest) {
            Ok(0) | Err(_) => return,
            Ok(n) => rest = &rest[n..],
        }
    }
}

/// What the emulated board's self-test reads (`SELFTEST`): a healthy board's boot findings —
/// the 8 MHz crystal, VDDA at the ADC's reference, the ranks aligned, the magnetometer
/// answering, the gyro references at their zero-rate voltage, a depth sensor connected (the
/// emulator simulates one: `--depth`) — and, every cycle, the live readings.
fn healthy_board(settings_from_flash: bool) -> selftest::Inputs {
    let s = PipelineSettings::default();
    selftest::Inputs {
        hse: Some(HseCheck::Ok(board::HSE_HZ)),
        vdda_v: Some(s.adc.vref_v),
        ranks_aligned: true,
        mag_id_ok: Some(true),
        xy_ref_v: Some(GYRO_ZERO_V),
        z_ref_v: Some(GYRO_ZERO_V),
        depth_connected: Some(true),
        settings_from_flash,
        ..selftest::Inputs::default()
    }
}

/// The emulated firmware: device state, pipeline, flash, the simulated board.
struct Firmware {
    /// What the self-test reads ([`healthy_board`], the live readings kept current).
    selftest: selftest::Inputs,
    device: Device,
    pipeline: Pipeline,
    flash: SimFlash,
    assembler: LineAssembler,
    board: Board,
    follow_acal: bool,
}

impl Firmware {
    fn act(&mut self, action: Option<Action>) {
        match action {
            Some(Action::ApplySettings { filter_rate_changed }) => {
                self.pipeline.apply_settings(*self.device.settings());
                if filter_rate_changed {
                    self.board.set_rate(f64::from(self.device.settings().filter_rate_hz));
                }
            }
            Some(Action::SetYaw(yaw)) => self.pipeline.set_yaw(yaw),
            Some(Action::RestartEstimator) => self.pipeline.restart(),
            None => {}
        }
    }

    /// The test helper `--follow-acal`: move the simulated board as the operator would.
    fn follow(&mut self, event: &LineEvent) {
        if let Some(pose) = ekf_emu::serial::operator_pose(event) {
            self.board.pose = pose;
        }
    }

    fn receive(&mut self, port: &mut (impl Read + Write)) -> io::Result<()> {
        let mut buf = [0u8; 256];
        loop {
            let n = match port.read(&mut buf) {
                Ok(0) => return Ok(()),
                Ok(n) => n,
                // Nothing to read (a `TTYPort` with a zero timeout reports `TimedOut`).
                Err(e)
                    if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) =>
                {
                    return Ok(())
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                // EIO: no slave side open (only with `--port`).
                Err(e) if e.raw_os_error() == Some(libc::EIO) => return Ok(()),
                Err(e) => return Err(e),
            };
            for &b in &buf[..n] {
                if let Some(event) = self.assembler.push(b) {
                    if self.follow_acal {
                        self.follow(&event);
                    }
                    let r = self.device.handle(&event, &mut self.flash);
                    if let Some(reply) = r.reply {
                        send(port, reply.as_bytes());
                    }
                    self.act(r.action);
                }
            }
        }
    }

    fn cycle(&mut self, port: &mut impl Write) {
        let inputs = self.board.inputs();
        // The live readings, as the firmware's `app::update_board` keeps them.
        self.selftest.accel_g = inputs.accel_g;
        if inputs.mag_ut.is_some() {
            self.selftest.mag_ut = inputs.mag_ut;
        }
        if let Some(m) = &inputs.adc {
            let a = &self.device.settings().adc;
            let volts = |c: f32| c * a.vref_v / a.full_scale_counts;
            self.selftest.depth_v = Some((volts(m.depth), false));
        }
        self.device.set_board(self.selftest);
        let sample = self.pipeline.conditioned_sample(&inputs);
        let step = self.pipeline.step(&inputs);
        self.device.set_heading_ref(step.heading_ref);
        let out = self.device.on_cycle(&inputs, &sample, step.attitude);
        let mut bytes = Vec::with_capacity(256);
        if let Some(reply) = &out.reply {
            bytes.extend_from_slice(reply.as_bytes());
        }
        if self.device.raw_mode() {
            for s in out.raw_sentences() {
                bytes.extend_from_slice(s.as_bytes());
            }
        } else {
            for s in step.sentences.iter() {
                bytes.extend_from_slice(s.as_bytes());
            }
        }
        send(port, &bytes);
        self.act(out.action);
    }
}

/// Run the emulator on `port` (non-blocking: [`Pty::master`] or [`open_path`]'s file) until an
/// I/O error (forever in practice).
pub fn run(mut port: impl Read + Write, opts: &Options) -> io::Result<()> {
    let scenario = scenario_by_name(&opts.scenario).ok_or_else(|| {
        io::Error::new(io::ErrorKind::InvalidInput, format!("unknown scenario {}", opts.scenario))
    })?;
    if !(opts.speed > 0.0 && opts.speed.is_finite()) {
        return Err(io::Error::new(io::ErrorKind::InvalidInput, "speed must be positive"));
    }
    let flash = SimFlash::new();
    let loaded = persist::load(&flash);
    let device = Device::new(&loaded, "POR");
    let pipeline = Pipeline::new(*device.settings());
    let rate = f64::from(device.settings().filter_rate_hz);
    let mut fw = Firmware {
        selftest: selftest::Inputs {
            mag_id_ok: if opts.broken_mag { None } else { Some(true) },
            ..healthy_board(matches!(loaded.source, Source::Flash { .. }))
        },
        device,
        pipeline,
        flash,
        assembler: LineAssembler::new(),
        board: Board::new(scenario, opts.seed, rate, opts.depth_m, opts.mag),
        follow_acal: opts.follow_acal,
    };
    let mut start = Instant::now();
    let mut k: u64 = 0;
    let mut rate_hz = fw.board.rate_hz;
    loop {
        let due = start + Duration::from_secs_f64(k as f64 / rate_hz / opts.speed);
        let now = Instant::now();
        if due > now {
            thread::sleep(due - now);
        }
        fw.receive(&mut port)?;
        fw.cycle(&mut port);
        k += 1;
        if fw.board.rate_hz != rate_hz {
            rate_hz = fw.board.rate_hz;
            start = Instant::now();
            k = 0;
        }
    }
}
