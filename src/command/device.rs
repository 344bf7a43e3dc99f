//! The device state and the command executor.

use ekf_core::{mathf, Euler, ImuSample, Quaternion};

use super::calib::{self, AccelPositionCal, CalEnd, GyroBiasCal};
use super::line::LineEvent;
use super::raw;
use super::reply::{Detail, Out, Reason};
use crate::adc::DepthReading;
use crate::nmea::{self, NmeaError, Sentence};
use crate::persist::{self, Flash, Loaded, SaveError, Source};
use crate::pipeline::{HeadingRef, Inputs, PipelineSettings};
use crate::registry::number::{self, Decimal};
use crate::registry::{self, Kind, Setting, Value, ValueError, SETTINGS};
use crate::supervision::selftest::Inputs as SelfTestInputs;

/// Firmware version reported by `VER`.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// Most comma-separated fields of a command (address and verb included): `SENT` with its
/// seven flags.
const MAX_FIELDS: usize = 9;

/// The sentences `SENT` switches, in the order of its flags, with their settings.
pub const SENTENCE_SETTINGS: [(&str, &str); 7] = [
    ("PRDID", "output.prdid"),
    ("PINAH", "output.pinah"),
    ("HDT", "output.hdt"),
    ("HDG", "output.hdg"),
    ("HDM", "output.hdm"),
    ("ROT", "output.rot"),
    ("XDR", "output.xdr"),
];

/// `GBIAS` duration range, s.
pub const GBIAS_RANGE_S: (f32, f32) = (1.0, 600.0);
/// `ACAL,<position>` duration range and default, s.
pub const ACAL_RANGE_S: (f32, f32) = (0.5, 60.0);
/// Default `ACAL,<position>` duration, s.
pub const ACAL_DEFAULT_S: f32 = 2.0;
/// `YAW` range, degrees.
pub const YAW_RANGE_DEG: (f32, f32) = (-360.0, 360.0);
/// A depth reading older than this many seconds is too old for `ZERO`.
pub const DEPTH_MAX_AGE_S: f32 = 1.0;

/// `STATUS` flag: no valid settings record at the last load (boot or `LOAD`): defaults.
pub const STATUS_NO_RECORD: u16 = 1 << 0;
/// `STATUS` flag: the settings differ from the last loaded or saved ones.
pub const STATUS_UNSAVED: u16 = 1 << 1;
/// `STATUS` flag: raw streaming on.
pub const STATUS_RAW: u16 = 1 << 2;
/// `STATUS` flag: a gyro-bias calibration is running.
pub const STATUS_GBIAS: u16 = 1 << 3;
/// `STATUS` flag: an accelerometer position is being collected.
pub const STATUS_ACAL: u16 = 1 << 4;
/// `STATUS` flag: the loaded record had entries that were skipped (unknown or invalid).
pub const STATUS_SKIPPED: u16 = 1 << 5;
/// `STATUS` flag: the loaded record lacked settings (they have their defaults).
pub const STATUS_MISSING: u16 = 1 << 6;

/// Something the application must do for a command (things that need the pipeline or the
/// hardware, which the executor does not own).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Action {
    /// The settings changed: `pipeline.apply_settings(*device.settings())`. When
    /// `filter_rate_changed`, the filter task must also change its period.
    ApplySettings {
        /// `filter.rate` changed.
        filter_rate_changed: bool,
    },
    /// Set the yaw now, rad (a true heading): `pipeline.set_yaw(yaw)`.
    SetYaw(f32),
    /// Restart the estimator before the next cycle (`RAW,2`): `pipeline.restart()`. An
    /// [`Action::SetYaw`] that came before it is void (the restart starts from `init.yaw0`);
    /// one after it applies after the restart.
    RestartEstimator,
}

/// The raw streaming modes (`RAW,<mode>`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RawMode {
    /// `RAW,0`: the attitude sentences (`$PRDID`, `$PINAH`, ...) at the output rate.
    Off,
    /// `RAW,1`: every cycle `$PINAW` and `$PINAX` (the estimator's input).
    Samples,
    /// `RAW,2`: the estimator restarted when the mode was set (and `t` from 0), then every
    /// cycle `$PINAW`, `$PINAX` and the cycle's `$PRDID` (the estimate from that very
    /// sample, sent whatever its validity): a log that a replay reproduces.
    WithEstimate,
}

impl RawMode {
    /// The mode's number in `RAW,<mode>`.
    pub fn number(self) -> &'static str {
        match self {
            RawMode::Off => "0",
            RawMode::Samples => "1",
            RawMode::WithEstimate => "2",
        }
    }
}

/// What a command produced.
#[derive(Clone, Debug, Default)]
pub struct Response {
    /// The reply to send; `None` for lines that are not commands for this device (other
    /// talkers, echoes of our own sentences).
    pub reply: Option<Sentence>,
    /// What the application must do, if anything.
    pub action: Option<Action>,
}

/// What a filter cycle produced.
#[derive(Clone, Debug, Default)]
pub struct CycleOutput {
    /// A late reply: a calibration finished or failed.
    pub reply: Option<Sentence>,
    /// What the application must do (a calibration changed the settings).
    pub action: Option<Action>,
    /// Raw streaming sentences of this cycle (`$PINAW`, then `$PINAX` when the magnetometer
    /// or the depth was read, then in [`RawMode::WithEstimate`] the cycle's `$PRDID`), in
    /// raw mode.
    pub raw: [Option<Sentence>; 3],
}

impl CycleOutput {
    /// The raw sentences, in sending order.
    pub fn raw_sentences(&self) -> impl Iterator<Item = &Sentence> + Clone {
        self.raw.iter().flatten()
    }
}

/// The verbs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Verb {
    Yaw,
    Yaw0,
    Zero,
    Gbias,
    Acal,
    Abort,
    Rate,
    Sent,
    Raw,
    Get,
    Set,
    List,
    Save,
    Load,
    Reset,
    Ver,
    Status,
    Selftest,
}

/// Every verb with its name, for lookup.
const VERBS: [(&str, Verb); 18] = [
    ("YAW", Verb::Yaw),
    ("YAW0", Verb::Yaw0),
    ("ZERO", Verb::Zero),
    ("GBIAS", Verb::Gbias),
    ("ACAL", Verb::Acal),
    ("ABORT", Verb::Abort),
    ("RATE", Verb::Rate),
    ("SENT", Verb::Sent),
    ("RAW", Verb::Raw),
    ("GET", Verb::Get),
    ("SET", Verb::Set),
    ("LIST", Verb::List),
    ("SAVE", Verb::Save),
    ("LOAD", Verb::Load),
    ("RESET", Verb::Reset),
    ("VER", Verb::Ver),
    ("STATUS", Verb::Status),
    ("SELFTEST", Verb::Selftest),
];

/// Names of every verb (for documentation checks).
pub fn verb_names() -> impl Iterator<Item = &'static str> {
    VERBS.iter().map(|(n, _)| *n)
}

impl Verb {
    fn name(self) -> &'static str {
        VERBS.iter().find(|(_, v)| *v == self).map(|(n, _)| *n).unwrap_or("?")
    }
}

/// A command's failure: the reason and optional detail of the `ERR` reply.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Fail(Reason, Detail);

impl From<Reason> for Fail {
    fn from(r: Reason) -> Self {
        Fail(r, Detail::None)
    }
}

type CmdResult = Result<(Out, Option<Action>), Fail>;

/// The operating state of the device: the settings in use, where they came from, the
/// calibration state machines and the raw-streaming switch. Commands go through
/// [`Device::execute`]; every filter cycle through [`Device::on_cycle`].
///
/// Every command is parsed and validated completely before anything changes: a command
/// answered with `ERR` changes nothing.
#[derive(Clone, Debug, PartialEq)]
pub struct Device {
    settings: PipelineSettings,
    source: Source,
    no_record: bool,
    load_skipped: u16,
    load_missing: u16,
    dirty: bool,
    reset_cause: &'static str,
    raw: RawMode,
    gbias: Option<GyroBiasCal>,
    acal: Option<AccelPositionCal>,
    /// The accelerometer positions collected since boot or `ACAL,CLEAR`: bit i =
    /// `Position::ALL[i]` (the means went out in the `DONE` replies; the host fits X).
    acal_seen: u8,
    /// What the board reads, for `SELFTEST` and `STATUS` ([`Device::set_board`]).
    board: SelfTestInputs,
    /// The stack's high-water mark, bytes ([`Device::set_stack_used`]).
    stack_used: Option<u32>,
    depth: Option<DepthReading>,
    depth_age_s: f32,
    clock_us: u64,
    heading_ref: HeadingRef,
}

impl Device {
    /// The device after loading the settings at boot (`persist::load`). `reset_cause` is
    /// reported by `STATUS` (printable ASCII without `$*!\^~,`, at most 16 characters, else
    /// `?`).
    pub fn new(loaded: &Loaded, reset_cause: &'static str) -> Self {
        Device {
            settings: loaded.settings,
            source: loaded.source,
            no_record: loaded.source == Source::Defaults,
            load_skipped: loaded.skipped,
            load_missing: loaded.missing,
            dirty: false,
            reset_cause,
            raw: RawMode::Off,
            gbias: None,
            acal: None,
            acal_seen: 0,
            board: SelfTestInputs::default(),
            stack_used: None,
            depth: None,
            depth_age_s: f32::INFINITY,
            clock_us: 0,
            heading_ref: HeadingRef::Relative,
        }
    }

    /// The settings in use (the pipeline must run with these: apply them after every
    /// [`Action::ApplySettings`]).
    pub fn settings(&self) -> &PipelineSettings {
        &self.settings
    }

    /// Where the settings came from.
    pub fn source(&self) -> Source {
        self.source
    }

    /// True in raw streaming mode, either [`RawMode`] other than `Off` (the application
    /// sends [`CycleOutput::raw`] instead of the attitude sentences).
    pub fn raw_mode(&self) -> bool {
        self.raw != RawMode::Off
    }

    /// The raw streaming mode.
    pub fn raw(&self) -> RawMode {
        self.raw
    }

    /// Note what the pipeline's heading is referenced to (`Step::heading_ref`), for `STATUS`.
    pub fn set_heading_ref(&mut self, r: HeadingRef) {
        self.heading_ref = r;
    }

    /// The `STATUS` flags ([`STATUS_NO_RECORD`], ...).
    pub fn status_flags(&self) -> u16 {
        let mut f = 0;
        let mut set = |cond: bool, bit: u16| {
            if cond {
                f |= bit;
            }
        };
        set(self.no_record, STATUS_NO_RECORD);
        set(self.dirty, STATUS_UNSAVED);
        set(self.raw != RawMode::Off, STATUS_RAW);
        set(self.gbias.is_some(), STATUS_GBIAS);
        set(self.acal.is_some(), STATUS_ACAL);
        set(self.load_skipped > 0, STATUS_SKIPPED);
        set(self.load_missing > 0, STATUS_MISSING);
        f
    }

    /// What the board reads now (the application, every filter cycle): `SELFTEST` grades it,
    /// `STATUS` reports its fault record.
    pub fn set_board(&mut self, inputs: SelfTestInputs) {
        self.board = inputs;
    }

    /// The stack's high-water mark, bytes (the application measures it: painted stack).
    pub fn set_stack_used(&mut self, bytes: u32) {
        self.stack_used = Some(bytes);
    }

    /// The reply to a [`LineEvent`]: [`Device::execute`] for a line, [`Device::too_long`]
    /// for an overflow.
    pub fn handle<F: Flash>(&mut self, event: &LineEvent, flash: &mut F) -> Response {
        match event {
            LineEvent::Line(line) => self.execute(line.as_bytes(), flash),
            LineEvent::TooLong => Response { reply: Some(Self::too_long()), action: None },
        }
    }

    /// The reply to a line that was too long: `$PINAR,ERR,?,too-long`.
    pub fn too_long() -> Sentence {
        Out::err("?", Reason::TooLong, Detail::None)
    }

    /// Execute one received line (`$PINAC,...*hh`, with or without the line end). Lines of
    /// other talkers get no reply. `flash` is used by `SAVE` and `LOAD` only.
    pub fn execute<F: Flash>(&mut self, line: &[u8], flash: &mut F) -> Response {
        // One line end at most, which `nmea::verify` takes off (until issue #39 this stripped
        // one too, so a line ending in two was accepted).
        let ours = line.starts_with(b"$PINAC") && matches!(line.get(6), Some(b',' | b'*'));
        if !ours {
            return Response::default();
        }
        let body = match nmea::verify(line) {
            Ok(body) => body,
            Err(e) => {
                let reason = match e {
                    NmeaError::BadChecksum { .. } => Reason::Checksum,
                    NmeaError::TooLong => Reason::TooLong,
                    _ => Reason::Format,
                };
                return Response { reply: Some(Out::err("?", reason, Detail::None)), action: None };
            }
        };
        let mut fields = [""; MAX_FIELDS];
        let mut n = 0;
        for f in body.split(nmea::is_comma) {
            if let Some(slot) = fields.get_mut(n) {
                *slot = f;
            }
            n += 1;
        }
        let verb_name = fields[1];
        let Some(verb) = VERBS.iter().find(|(n, _)| n.eq_ignore_ascii_case(verb_name)).map(|v| v.1)
        else {
            let reply = Out::err("?", Reason::UnknownCommand, Detail::None);
            return Response { reply: Some(reply), action: None };
        };
        let result = if n > MAX_FIELDS {
            Err(Fail(Reason::Args, Detail::None))
        } else {
            let args = fields.get(2..n).unwrap_or(&[]);
            self.refusal_changes_nothing(|d| d.run(verb, args, flash))
        };
        match result {
            Ok((out, action)) => Response { reply: Some(out.finish()), action },
            Err(Fail(reason, detail)) => {
                Response { reply: Some(Out::err(verb.name(), reason, detail)), action: None }
            }
        }
    }

    fn run<F: Flash>(&mut self, verb: Verb, args: &[&str], flash: &mut F) -> CmdResult {
        let name = verb.name();
        let nargs = |n: usize| if args.len() == n { Ok(()) } else { Err(Fail::from(Reason::Args)) };
        let arg = |i: usize| args.get(i).copied().unwrap_or("");
        match verb {
            Verb::Yaw => {
                nargs(1)?;
                let deg = parse_in(arg(0), YAW_RANGE_DEG)?;
                let yaw = mathf::wrap_pi(mathf::deg(deg.value() as f32));
                let mut out = Out::ok(name);
                out.num(deg);
                Ok((out, Some(Action::SetYaw(yaw))))
            }
            Verb::Yaw0 => {
                nargs(1)?;
                self.set_values(name, None, &[("init.yaw0", args)])
            }
            Verb::Rate => {
                nargs(1)?;
                self.set_values(name, None, &[("output.rate", args)])
            }
            Verb::Sent => {
                // `SENT,<name>,<0|1>`: one sentence by name.
                let first = arg(0);
                if args.len() == 2 && !matches!(first, "0" | "1") {
                    let (label, setting) = SENTENCE_SETTINGS
                        .iter()
                        .find(|(n, _)| n.eq_ignore_ascii_case(first))
                        .ok_or(Reason::Type)?;
                    let value = args.get(1..2).unwrap_or(&[]);
                    return self.set_values(name, Some(label), &[(setting, value)]);
                }
                // `SENT,<prdid>,<pinah>[,<hdt>,<hdg>,<hdm>,<rot>,<xdr>]`: flags in order.
                if args.len() != 2 && args.len() != SENTENCE_SETTINGS.len() {
                    return Err(Reason::Args.into());
                }
                let mut items: [(&str, &[&str]); SENTENCE_SETTINGS.len()] =
                    [("", &[]); SENTENCE_SETTINGS.len()];
                for (i, (item, (_, setting))) in
                    items.iter_mut().zip(SENTENCE_SETTINGS.iter()).enumerate()
                {
                    *item = (setting, args.get(i..i + 1).unwrap_or(&[]));
                }
                self.set_values(name, None, items.get(..args.len()).unwrap_or(&[]))
            }
            Verb::Set => {
                let (Some(&setting_name), Some(value)) = (args.first(), args.get(1..)) else {
                    return Err(Reason::Args.into());
                };
                if value.is_empty() {
                    return Err(Reason::Args.into());
                }
                let setting = registry::find(setting_name).ok_or(Reason::UnknownSetting)?;
                self.set_values(name, Some(setting.name), &[(setting.name, value)])
            }
            Verb::Get => {
                nargs(1)?;
                let setting = registry::find(arg(0)).ok_or(Reason::UnknownSetting)?;
                let mut out = Out::ok(name);
                out.field(setting.name);
                out.value(setting, &setting.get(&self.settings));
                Ok((out, None))
            }
            Verb::List => {
                nargs(1)?;
                let i = number::parse_uint(arg(0)).ok_or(Reason::Type)?;
                let max = SETTINGS.len() - 1;
                let setting = SETTINGS
                    .get(i as usize)
                    .ok_or(Fail(Reason::Range, Detail::Range(0.0, max as f32)))?;
                let mut out = Out::ok(name);
                out.uint(u64::from(i));
                out.uint(SETTINGS.len() as u64);
                out.field(setting.name);
                out.field(setting.kind.name());
                out.field(setting.unit());
                // The accepted range in the unit above (`docs/commands.md`'s table); empty
                // for kinds that are not numbers (bool, axes, talker).
                if matches!(setting.kind, Kind::F32 | Kind::Vec3 | Kind::U16) {
                    let (min, max) = setting.range();
                    out.num_f32(min);
                    out.num_f32(max);
                } else {
                    out.field("");
                    out.field("");
                }
                Ok((out, None))
            }
            Verb::Raw => {
                nargs(1)?;
                let mode = match arg(0) {
                    "0" => RawMode::Off,
                    "1" => RawMode::Samples,
                    "2" => RawMode::WithEstimate,
                    _ => return Err(Reason::Type.into()),
                };
                self.raw = mode;
                let mut out = Out::ok(name);
                out.field(mode.number());
                if mode == RawMode::WithEstimate {
                    // The log's time starts with the restarted estimator: its first row is
                    // one cycle after the restart.
                    self.clock_us = 0;
                    return Ok((out, Some(Action::RestartEstimator)));
                }
                Ok((out, None))
            }
            Verb::Zero => {
                nargs(0)?;
                let reading = match self.depth {
                    Some(r) if self.depth_age_s <= DEPTH_MAX_AGE_S => r,
                    _ => return Err(Reason::NoDepth.into()),
                };
                let mut new = self.settings;
                if !new.depth.zero_at_surface(&reading) {
                    return Err(Reason::NoDepth.into());
                }
                let setting = registry::find("depth.surface_pressure").ok_or(Reason::Range)?;
                if !setting.check(&setting.get(&new)) {
                    return Err(Fail(
                        Reason::Range,
                        Detail::Range(setting.range().0, setting.range().1),
                    ));
                }
                let action = self.commit(new);
                let mut out = Out::ok(name);
                out.num_f32(new.depth.surface_pressure_pa);
                Ok((out, action))
            }
            Verb::Gbias => {
                nargs(1)?;
                let s = parse_in(arg(0), GBIAS_RANGE_S)?;
                if self.gbias.is_some() {
                    return Err(Reason::Busy.into());
                }
                self.gbias = Some(GyroBiasCal::new(s.value() as f32));
                let mut out = Out::ok(name);
                out.field("RUN");
                out.num(s);
                Ok((out, None))
            }
            Verb::Acal => self.acal_command(args),
            Verb::Abort => {
                nargs(0)?;
                if self.gbias.is_none() && self.acal.is_none() {
                    return Err(Reason::NotRunning.into());
                }
                self.gbias = None;
                self.acal = None;
                Ok((Out::ok(name), None))
            }
            Verb::Save => {
                nargs(0)?;
                let saved = persist::save(flash, &self.settings).map_err(|e| match e {
                    SaveError::TooLarge => Fail::from(Reason::TooLarge),
                    SaveError::Flash(_) | SaveError::Verify => Fail::from(Reason::Flash),
                })?;
                self.source = Source::Flash { page: saved.page, seq: saved.seq };
                self.dirty = false;
                let mut out = Out::ok(name);
                out.field(saved.page.name());
                out.uint(u64::from(saved.seq));
                Ok((out, None))
            }
            Verb::Load => {
                nargs(0)?;
                let loaded = persist::load(flash);
                let Source::Flash { page, seq } = loaded.source else {
                    return Err(Reason::NoRecord.into());
                };
                let action = self.commit(loaded.settings);
                self.source = loaded.source;
                self.no_record = false;
                self.load_skipped = loaded.skipped;
                self.load_missing = loaded.missing;
                self.dirty = false;
                let mut out = Out::ok(name);
                out.field(page.name());
                out.uint(u64::from(seq));
                out.uint(u64::from(loaded.skipped));
                out.uint(u64::from(loaded.missing));
                Ok((out, action))
            }
            Verb::Reset => {
                nargs(0)?;
                let action = self.commit(PipelineSettings::default());
                self.source = Source::Defaults;
                Ok((Out::ok(name), action))
            }
            Verb::Ver => {
                nargs(0)?;
                let mut out = Out::ok(name);
                out.field("inemo-ahrs");
                out.field(VERSION);
                out.uint(u64::from(persist::FORMAT_VERSION));
                out.uint(SETTINGS.len() as u64);
                Ok((out, None))
            }
            Verb::Status => {
                nargs(0)?;
                let mut out = Out::ok(name);
                match self.source {
                    Source::Defaults => {
                        out.field("DEFAULTS");
                        out.field("");
                    }
                    Source::Flash { page, seq } => {
                        out.field(page.name());
                        out.uint(u64::from(seq));
                    }
                }
                let cause = self.reset_cause;
                let printable =
                    cause.len() <= 16 && cause.bytes().all(|b| nmea::is_body_byte(b) && b != b',');
                out.field(if printable { cause } else { "?" });
                out.hex(u32::from(self.status_flags()), 4);
                out.hex(u32::from(self.acal_seen), 2);
                out.field(self.heading_ref.letter());
                // The board: the fault record found at boot, the stack's high-water mark.
                out.field(self.board.fault.map_or("", |k| k.name()));
                match self.stack_used {
                    Some(bytes) => out.uint(u64::from(bytes)),
                    None => out.field(""),
                }
                Ok((out, None))
            }
            Verb::Selftest => {
                nargs(0)?;
                Ok((super::board::selftest_reply(name, &self.board), None))
            }
        }
    }

    /// `ACAL,<position>[,<s>]`, `ACAL,CLEAR`. (The fit of X from the six means is the host's:
    /// `ahrs-tool calibrate` sets `accel_cal.*` with `SET`.)
    fn acal_command(&mut self, args: &[&str]) -> CmdResult {
        let name = Verb::Acal.name();
        let first = args.first().copied().ok_or(Reason::Args)?;
        if first.eq_ignore_ascii_case("CLEAR") {
            if args.len() != 1 {
                return Err(Reason::Args.into());
            }
            self.acal_seen = 0;
            self.acal = None;
            let mut out = Out::ok(name);
            out.field("CLEAR");
            return Ok((out, None));
        }
        let position = calib::position_by_name(first).ok_or(Reason::Type)?;
        let duration = match args.len() {
            1 => ACAL_DEFAULT_S,
            2 => parse_in(args.get(1).copied().unwrap_or(""), ACAL_RANGE_S)?.value() as f32,
            _ => return Err(Reason::Args.into()),
        };
        if self.acal.is_some() {
            return Err(Reason::Busy.into());
        }
        self.acal = Some(AccelPositionCal::new(position, duration));
        let mut out = Out::ok(name);
        out.field("RUN");
        out.field(calib::position_name(position));
        out.num_f32(duration);
        Ok((out, None))
    }

    /// Parse and validate values for named settings, all before changing anything, then
    /// commit them together. The reply is `OK,<verb>,<values...>`.
    fn set_values(
        &mut self,
        verb: &'static str,
        label: Option<&str>,
        items: &[(&str, &[&str])],
    ) -> CmdResult {
        let mut new = self.settings;
        let mut out = Out::ok(verb);
        if let Some(label) = label {
            out.field(label);
        }
        for (name, fields) in items {
            let setting = registry::find(name).ok_or(Reason::UnknownSetting)?;
            let value = setting.parse(fields).map_err(|e| value_fail(setting, e))?;
            if !setting.set(&mut new, value) {
                return Err(Fail(Reason::Range, range_detail(setting)));
            }
            out.value(setting, &setting.get(&new));
        }
        let action = self.commit(new);
        Ok((out, action))
    }

    /// Run `handler`; when it refuses, put the state back as it was before it. So a refused
    /// command changes nothing by construction, whatever the handler did before it refused
    /// (the handlers also validate every field before they change anything; this makes a
    /// forgotten case harmless). Flash changes only through `SAVE`, whose refusals come before
    /// it writes. Costs a copy of the device state (≈ 0.6 KB of the command task's stack).
    fn refusal_changes_nothing(
        &mut self,
        handler: impl FnOnce(&mut Self) -> CmdResult,
    ) -> CmdResult {
        let before = self.clone();
        let result = handler(self);
        if result.is_err() {
            *self = before;
        }
        result
    }

    /// Make `new` the settings; an action when they changed.
    fn commit(&mut self, new: PipelineSettings) -> Option<Action> {
        // Through the registry: the derived comparison costs ≈ 0.9 KB of flash.
        if registry::same(&new, &self.settings, None) {
            return None;
        }
        let filter_rate_changed = new.filter_rate_hz != self.settings.filter_rate_hz;
        self.settings = new;
        self.dirty = true;
        Some(Action::ApplySettings { filter_rate_changed })
    }

    /// Feed one filter cycle: `inputs` as given to `Pipeline::step`, `sample` from
    /// `Pipeline::conditioned_sample(inputs)` (used only in raw mode; pass any sample
    /// otherwise), `attitude` the estimate that step produced (`Step::attitude`; used only in
    /// [`RawMode::WithEstimate`]). Runs the calibrations, keeps the latest depth reading for
    /// `ZERO` and builds the raw sentences.
    pub fn on_cycle(
        &mut self,
        inputs: &Inputs,
        sample: &ImuSample,
        attitude: Quaternion,
    ) -> CycleOutput {
        let mut out = CycleOutput::default();
        let dt = inputs.dt;
        if dt.is_finite() && dt > 0.0 {
            // In `f32` (exact to the µs for any cycle under 16 s); through `u32`: no 64-bit
            // float-to-integer routine in the firmware.
            self.clock_us = self.clock_us.wrapping_add(u64::from((dt * 1e6 + 0.5) as u32));
            self.depth_age_s += dt;
        }
        let s = self.settings;
        let mut depth_m = None;
        let mut gyro_body = None;
        if let Some(mean) = inputs.adc {
            let r = s.depth.reading(&mean, &s.adc);
            if !r.at_rail && r.pressure_pa.is_finite() && r.depth_m.is_finite() {
                self.depth = Some(r);
                self.depth_age_s = 0.0;
                depth_m = Some(r.depth_m);
            }
            let g = s.gyro.rates(&mean);
            let body = s.conditioning.gyro_axes.apply(g.rate_vec3());
            if !g.saturated && body.is_finite() {
                gyro_body = Some(body.to_array());
            }
        }

        if let Some(mut cal) = self.gbias {
            let end = cal.push(dt, gyro_body, inputs.accel_g, &s);
            self.gbias = if end == CalEnd::Running { Some(cal) } else { None };
            match end {
                CalEnd::Running => {}
                CalEnd::Done(bias) => {
                    let setting = registry::find("gyro.offset");
                    let mut new = s;
                    match setting {
                        Some(st) if st.set(&mut new, Value::Vec3(bias)) => {
                            let mut o = Out::ok(Verb::Gbias.name());
                            o.field("DONE");
                            o.value(st, &st.get(&new));
                            out.reply = Some(o.finish());
                            out.action = self.commit(new);
                        }
                        _ => {
                            let d = setting.map(range_detail).unwrap_or(Detail::None);
                            out.reply = Some(Out::err(Verb::Gbias.name(), Reason::Range, d));
                        }
                    }
                }
                other => {
                    out.reply = Some(Out::err(Verb::Gbias.name(), end_reason(other), Detail::None))
                }
            }
        }

        if let Some(mut cal) = self.acal {
            let end = cal.push(dt, inputs.accel_g, &s);
            self.acal = if end == CalEnd::Running { Some(cal) } else { None };
            let reply = match end {
                CalEnd::Running => None,
                CalEnd::Done(mean) => {
                    self.acal_seen |= 1 << cal.position.index();
                    let mut o = Out::ok(Verb::Acal.name());
                    o.field("DONE");
                    o.field(calib::position_name(cal.position));
                    for m in mean {
                        o.num_f32(m);
                    }
                    o.uint(u64::from(self.acal_seen.count_ones()));
                    Some(o.finish())
                }
                other => Some(Out::err(Verb::Acal.name(), end_reason(other), Detail::None)),
            };
            // Two calibrations ending in the same cycle: the accelerometer's reply waits for
            // none; the gyro's is sent first and this one replaces nothing.
            if out.reply.is_none() {
                out.reply = reply;
            }
        }

        if self.raw != RawMode::Off {
            out.raw[0] = raw::pinaw(self.clock_us, sample).ok();
            if sample.mag.is_some() || depth_m.is_some() {
                out.raw[1] =
                    raw::pinax(self.clock_us, sample.mag.map(|m| m.to_array()), depth_m).ok();
            }
        }
        if self.raw == RawMode::WithEstimate {
            out.raw[2] = nmea::prdid(&Euler::from_quaternion(attitude)).ok();
        }
        out
    }
}

fn end_reason(end: CalEnd) -> Reason {
    match end {
        CalEnd::Motion => Reason::Motion,
        CalEnd::WrongPosition => Reason::Position,
        _ => Reason::Sensor,
    }
}

/// Parse a number in `[lo, hi]` (compared in `f64`, before the rounding to `f32`).
fn parse_in(text: &str, (lo, hi): (f32, f32)) -> Result<Decimal, Fail> {
    let v = Decimal::parse(text).ok_or(Reason::Type)?;
    if (f64::from(lo)..=f64::from(hi)).contains(&v.value()) {
        Ok(v)
    } else {
        Err(Fail(Reason::Range, Detail::Range(lo, hi)))
    }
}

fn range_detail(s: &Setting) -> Detail {
    match s.kind {
        Kind::F32 | Kind::Vec3 | Kind::U16 => Detail::Range(s.range().0, s.range().1),
        Kind::Bool | Kind::Axes | Kind::Talker => Detail::None,
    }
}

fn value_fail(s: &Setting, e: ValueError) -> Fail {
    match e {
        ValueError::Args => Fail(Reason::Args, Detail::Count(s.kind.fields() as u32)),
        ValueError::Type => Fail(Reason::Type, Detail::Kind(s.kind.name())),
        ValueError::Range => Fail(Reason::Range, range_detail(s)),
    }
}

#[cfg(test)]
mod refusal {
    use super::*;

    /// A refused command changes nothing by construction (issue #17): a handler that changes the
    /// device and then refuses — the `SENT,0,x` mutation that once set `output.prdid` before
    /// replying `ERR`, with every test green — leaves no trace, because `execute` puts the state
    /// back on every refusal.
    #[test]
    fn a_handler_that_changes_the_state_and_then_refuses_leaves_no_trace() {
        let mut d = super::super::tests::fresh();
        let before = d.clone();
        let r = d.refusal_changes_nothing(|d| {
            d.settings.sentences.prdid = !d.settings.sentences.prdid;
            d.dirty = true;
            d.raw = RawMode::Samples;
            Err(Reason::Type.into())
        });
        assert!(r.is_err());
        assert_eq!(d, before);
        // An accepted command keeps its changes.
        let r = d.refusal_changes_nothing(|d| {
            d.raw = RawMode::Samples;
            Ok((Out::ok("RAW"), None))
        });
        assert!(r.is_ok() && d.raw_mode());
        // And the real `SENT,0,x`: refused, nothing changed.
        let before = d.clone();
        let mut f = crate::persist::SimFlash::new();
        let r = d.execute(&super::super::tests::cmd("PINAC,SENT,0,x"), &mut f);
        assert_eq!(r.reply.expect("a reply").as_str(), "$PINAR,ERR,SENT,type,bool*1B\r\n");
        assert_eq!(d, before);
    }
}
