//! The device's settings language on the host: `NAME=VALUE` with the registry's names, units
//! and value syntax (`docs/commands.md`, "Settings"), checked by the firmware's own registry
//! (`inemo_ahrs::registry`), so a value the device would refuse is refused here, with the
//! reason word of the device's `ERR,SET` reply (`unknown-setting`, `args`, `type`, `range`).
//!
//! A settings file holds one `NAME=VALUE` per line (`lever.r=0,0,0`, `mag.norm_tolerance=0.1`); blank
//! lines and lines starting with `#` are comments; spaces around the name, the `=` and the
//! fields are ignored. `ahrs-tool settings get` writes such a file from a device and
//! `ahrs-tool settings put` sends one back; `host-tests replay --settings` reads it.
//!
//! A trace logged by `ahrs-tool log` carries the device's settings in its comments
//! ([`TraceMeta`]): `# setting: NAME=VALUE` lines, and a `# conditioned: ...` line naming the
//! conditioning already applied to its samples.

use std::path::Path;

use ekf_core::lever_arm::LeverArm;
use inemo_ahrs::command::Reason;
use inemo_ahrs::nmea::Sentence;
use inemo_ahrs::pipeline::PipelineSettings;
use inemo_ahrs::registry::{
    self, number, Kind, Part, Retired, Setting, Value, ValueError, SETTINGS,
};

use crate::config::ReplayConfig;

/// One `NAME=VALUE`, parsed and checked: the setting and its value (internal units).
#[derive(Clone, Copy, Debug)]
pub struct Assignment {
    /// The setting.
    pub setting: &'static Setting,
    /// Its value, internal units.
    pub value: Value,
}

/// The valid range of `s` in user units, as the device's `range` reply gives it, with the
/// unit: `0.001 to 16 g` (empty for booleans and axis maps).
fn range_text(s: &Setting) -> String {
    if !matches!(s.kind, Kind::F32 | Kind::Vec3 | Kind::U16) {
        return String::new();
    }
    let num = |v: f32| {
        let mut buf = [0u8; 24];
        let n = number::format_number(f64::from(v), &mut buf);
        String::from_utf8_lossy(&buf[..n]).into_owned()
    };
    let unit = if s.unit().is_empty() { String::new() } else { format!(" {}", s.unit()) };
    format!("{} to {}{unit}", num(s.min), num(s.max))
}

/// What a value of kind `k` looks like, for the `type` and `args` messages.
fn kind_text(k: Kind) -> &'static str {
    match k {
        Kind::F32 => "f32: one number",
        Kind::Vec3 => "f32x3: three numbers x,y,z",
        Kind::Bool => "bool: 0 or 1",
        Kind::U16 => "u16: an integer",
        Kind::Axes => "axes: three axis tokens such as x,-y,-z",
        Kind::Talker => "talker: two letters or digits such as HC",
    }
}

/// The message for a refused value: the device's reason word, then what it expects.
pub fn refusal(s: &Setting, e: ValueError) -> String {
    match e {
        ValueError::Args => format!(
            "{}: expected {} comma-separated value{} ({})",
            Reason::Args.as_str(),
            s.kind.fields(),
            if s.kind.fields() == 1 { "" } else { "s" },
            kind_text(s.kind)
        ),
        ValueError::Type => format!("{}: expected {}", Reason::Type.as_str(), kind_text(s.kind)),
        ValueError::Range => match s.kind {
            Kind::Axes => format!(
                "{}: an axis map names each of x, y, z once (a permutation)",
                Reason::Range.as_str()
            ),
            _ => format!("{}: valid {}", Reason::Range.as_str(), range_text(s)),
        },
    }
}

/// Parse `NAME=VALUE` (spaces around the parts ignored) and check it with the registry.
/// Errors are one line: `mag.norm_tolerance=20: range: valid 0 to 1`.
pub fn parse_assignment(text: &str) -> Result<Assignment, String> {
    let text = text.trim();
    let Some((name, value)) = text.split_once('=') else {
        return Err(format!("{text:?}: expected NAME=VALUE (e.g. mag.norm_tolerance=0.1)"));
    };
    let (name, value) = (name.trim(), value.trim());
    let setting = registry::find(name).ok_or_else(|| match registry::retired(name) {
        Some(r) => format!(
            "{}: {}: {}; a log or settings file that names it replays without it",
            r.name,
            Reason::UnknownSetting.as_str(),
            r.why
        ),
        None => format!(
            "{name}: {}: no such setting (the names are listed in docs/commands.md)",
            Reason::UnknownSetting.as_str()
        ),
    })?;
    let fields: Vec<&str> = value.split(',').map(str::trim).collect();
    let value = setting
        .parse(&fields)
        .map_err(|e| format!("{}={value}: {}", setting.name, refusal(setting, e)))?;
    Ok(Assignment { setting, value })
}

/// `NAME=VALUE` of `v` (internal units) as the device prints it (`GET`).
pub fn format_assignment(s: &Setting, v: &Value) -> String {
    let mut out = Sentence::new();
    // A value always fits a sentence (the device replies with it).
    let _ = s.write_value(v, &mut out);
    format!("{}={}", s.name, out.body())
}

/// The lines of a settings file.
#[derive(Debug)]
pub struct SettingsText {
    /// `(line number, assignment)`, in order.
    pub lines: Vec<(usize, Assignment)>,
    /// The lines that name a retired setting (`registry::RETIRED`), skipped as the firmware
    /// skips them in a saved record: one warning each (`retired_warning`).
    pub retired: Vec<(usize, &'static Retired)>,
}

/// The stderr warning for a retired setting skipped at `origin`'s `line`.
pub fn retired_warning(origin: &str, line: usize, r: &Retired) -> String {
    format!("{origin} line {line}: {} skipped: {}", r.name, r.why)
}

/// The retired setting `NAME=VALUE` names, if any.
fn retired_name(text: &str) -> Option<&'static Retired> {
    text.split_once('=').and_then(|(name, _)| registry::retired(name.trim()))
}

/// The lines of a settings file: comments and blank lines skipped, a retired setting's line
/// skipped and listed. Errors name the line: `settings.txt line 3: mag.norm_tolerance=abc: type: ...`.
pub fn parse_settings_text(text: &str, origin: &str) -> Result<SettingsText, String> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut out = SettingsText { lines: Vec::new(), retired: Vec::new() };
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        if let Some(name) = retired_name(t) {
            out.retired.push((i + 1, name));
            continue;
        }
        let a = parse_assignment(t).map_err(|e| format!("{origin} line {}: {e}", i + 1))?;
        out.lines.push((i + 1, a));
    }
    Ok(out)
}

/// [`parse_settings_text`] of a file; each retired setting's line is reported on stderr.
pub fn read_settings_file(path: &Path) -> Result<Vec<(usize, Assignment)>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let origin = path.display().to_string();
    let parsed = parse_settings_text(&text, &origin)?;
    for (line, r) in &parsed.retired {
        eprintln!("{}", retired_warning(&origin, *line, r));
    }
    Ok(parsed.lines)
}

/// A whole settings file for `s`: a comment line per `header` entry, then every setting of the
/// registry in table order.
pub fn settings_file_text(s: &PipelineSettings, header: &[String]) -> String {
    let mut text = String::new();
    for h in header {
        text.push_str(&format!("# {}\n", h.replace(['\n', '\r'], " ")));
    }
    for setting in SETTINGS.iter() {
        text.push_str(&format_assignment(setting, &setting.get(s)));
        text.push('\n');
    }
    text
}

/// Where a setting acts, for a replay of a trace (body-frame SI samples).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// The estimator (`ReplayConfig::settings`): applied.
    Filter,
    /// The lever arm (`ReplayConfig::conditioning.lever_arm`): applied, unless the trace says
    /// its samples already had it.
    LeverArm,
    /// Acts before a trace's samples exist: not applied; the reason.
    Before(&'static str),
}

/// The role of `s` in a replay.
pub fn role(s: &Setting) -> Role {
    let n = s.name;
    if s.part() == Part::Filter {
        Role::Filter
    } else if n.starts_with("lever.") {
        Role::LeverArm
    } else if n.starts_with("axes.") {
        Role::Before("a trace is in body axes already")
    } else if n == "gyro.offset" || n.starts_with("accel_cal.") {
        Role::Before("sensor calibration, applied before the samples a trace holds")
    } else if n.starts_with("adc.") || n.starts_with("gyro.") || n.starts_with("depth.") {
        Role::Before("converts raw readings; a trace holds SI values")
    } else {
        Role::Before("rates and output sentences of the device; a trace has its own times")
    }
}

/// What a trace's comments say about it (`ahrs-tool log` writes them).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TraceMeta {
    /// The `# setting: NAME=VALUE` lines: the device's settings when the log started.
    pub settings: Vec<(usize, String)>,
    /// The words of the `# conditioned: ...` line: the conditioning already applied to the
    /// samples (`axes`, `gyro.offset`, `accel_cal`, `lever`).
    pub conditioned: Vec<String>,
    /// The `# estimator: restarted ...` line: the device restarted its estimator at the first
    /// row (`ahrs-tool log --restart`, the device's `RAW,2`), so that a replay from the first
    /// row with the device's settings reproduces the device's estimates.
    pub restarted: bool,
}

/// Prefix of a setting line in a trace's comments.
pub const META_SETTING: &str = "setting: ";
/// Prefix of the conditioning line in a trace's comments.
pub const META_CONDITIONED: &str = "conditioned: ";
/// The comment line (without `# `) of a log whose first row is the first sample of the
/// device's restarted estimator ([`TraceMeta::restarted`]).
pub const META_RESTARTED: &str =
    "estimator: restarted at the first row (RAW,2): a replay from the first row with these settings reproduces the device's estimates";
/// What a logged trace's samples already had applied (`$PINAW` is the estimator's input).
pub const LOG_CONDITIONED: [&str; 4] = ["axes", "gyro.offset", "accel_cal", "lever"];

impl TraceMeta {
    /// The comment lines (without `# `) that describe a log taken with device settings `s`.
    pub fn log_comments(s: &PipelineSettings) -> Vec<String> {
        let mut out = vec![format!("{META_CONDITIONED}{}", LOG_CONDITIONED.join(" "))];
        for setting in SETTINGS.iter() {
            out.push(format!("{META_SETTING}{}", format_assignment(setting, &setting.get(s))));
        }
        out
    }

    /// Read the comments of a trace up to its first data line (the header and the comments
    /// around it).
    pub fn read(path: &Path) -> std::io::Result<TraceMeta> {
        let f = std::fs::File::open(path)?;
        let mut meta = TraceMeta::default();
        let mut header_seen = false;
        let mut buf = Vec::new();
        let mut r = std::io::BufReader::new(f);
        let mut line = 0usize;
        loop {
            buf.clear();
            let Some(whole) = crate::trace::read_line_bounded(&mut r, &mut buf)? else {
                break;
            };
            line += 1;
            if !whole {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    crate::trace::TraceError::LineTooLong { line }.to_string(),
                ));
            }
            let text = String::from_utf8_lossy(&buf);
            let t = text.trim().trim_start_matches('\u{feff}');
            if t.is_empty() {
                continue;
            }
            let Some(c) = t.strip_prefix('#') else {
                if header_seen {
                    break;
                }
                header_seen = true;
                continue;
            };
            let c = c.trim();
            if let Some(s) = c.strip_prefix(META_SETTING) {
                meta.settings.push((line, s.trim().to_string()));
            } else if let Some(s) = c.strip_prefix(META_CONDITIONED) {
                meta.conditioned.extend(s.split_whitespace().map(str::to_string));
            } else if c.starts_with("estimator: restarted") {
                meta.restarted = true;
            }
        }
        Ok(meta)
    }

    /// True when the samples already had the lever arm applied.
    pub fn lever_applied(&self) -> bool {
        self.conditioned.iter().any(|w| w == "lever")
    }
}

/// The settings of a replay: the device's defaults, then the trace's own settings (a log's
/// header), then `--settings` files, then each `--set`; what was applied and what not.
#[derive(Clone, Debug)]
pub struct ReplaySettings {
    /// Everything, as the device would hold it.
    pub device: PipelineSettings,
    /// Names given by the user (files and `--set`) that a replay does not apply, with why.
    pub not_applied: Vec<(&'static str, &'static str)>,
    /// Lever-arm settings given by the user but not applied: the trace had it already.
    pub lever_already: Vec<&'static str>,
    /// Settings taken from the trace's header.
    pub from_trace: usize,
    /// The trace says its samples already had the lever arm.
    pub lever_applied: bool,
    /// Retired settings the trace's header named, skipped (`registry::RETIRED`).
    pub retired: Vec<&'static Retired>,
}

impl ReplaySettings {
    /// Start from `base` (the replay's own defaults in device form).
    pub fn new(base: PipelineSettings) -> Self {
        ReplaySettings {
            device: base,
            not_applied: Vec::new(),
            lever_already: Vec::new(),
            from_trace: 0,
            lever_applied: false,
            retired: Vec::new(),
        }
    }

    /// Apply a trace's header: its settings (`origin` names the trace in errors) and what
    /// it says was applied.
    pub fn apply_trace(&mut self, meta: &TraceMeta, origin: &str) -> Result<(), String> {
        for (line, text) in &meta.settings {
            if let Some(name) = retired_name(text) {
                // A log of older firmware: the setting no longer exists; the firmware skips
                // it in a saved record the same way.
                if !self.retired.contains(&name) {
                    self.retired.push(name);
                }
                continue;
            }
            let a = parse_assignment(text).map_err(|e| format!("{origin} line {line}: {e}"))?;
            a.setting.set(&mut self.device, a.value);
            self.from_trace += 1;
        }
        self.lever_applied |= meta.lever_applied();
        Ok(())
    }

    /// Apply one assignment given by the user.
    pub fn apply_given(&mut self, a: &Assignment) {
        // `parse` checked the value: `set` accepts it.
        a.setting.set(&mut self.device, a.value);
        let name = a.setting.name;
        match role(a.setting) {
            Role::Filter => {}
            Role::LeverArm => {
                if self.lever_applied && !self.lever_already.contains(&name) {
                    self.lever_already.push(name);
                }
            }
            Role::Before(why) => {
                if !self.not_applied.iter().any(|(n, _)| *n == name) {
                    self.not_applied.push((name, why));
                }
            }
        }
    }

    /// The replay's configuration on top of `base` (its UKF, SS-UKF and complementary tuning
    /// and conditioning other than the lever arm are kept): the estimator settings and the
    /// lever arm (none when the trace already had it).
    pub fn config(&self, base: &ReplayConfig) -> ReplayConfig {
        let mut cfg = *base;
        cfg.settings = self.device.filter;
        cfg.conditioning.lever_arm =
            if self.lever_applied { LeverArm::NONE } else { self.device.conditioning.lever_arm };
        cfg
    }

    /// The stderr notes: what was not applied and why (one line per reason).
    pub fn notes(&self) -> Vec<String> {
        let mut out = Vec::new();
        // One line per reason, naming the settings it retired.
        let mut whys: Vec<&str> = Vec::new();
        for r in &self.retired {
            if !whys.contains(&r.why) {
                whys.push(r.why);
            }
        }
        for why in whys {
            let names: Vec<&str> =
                self.retired.iter().filter(|r| r.why == why).map(|r| r.name).collect();
            out.push(format!("trace header: {} skipped: {why}", names.join(", ")));
        }
        if !self.lever_already.is_empty() {
            out.push(format!(
                "not applied: {} (the trace says its samples already had the lever arm)",
                self.lever_already.join(", ")
            ));
        }
        let mut reasons: Vec<&str> = Vec::new();
        for (_, why) in &self.not_applied {
            if !reasons.contains(why) {
                reasons.push(why);
            }
        }
        for why in reasons {
            let names: Vec<&str> =
                self.not_applied.iter().filter(|(_, w)| *w == why).map(|(n, _)| *n).collect();
            out.push(format!("not applied: {} ({why})", names.join(", ")));
        }
        out
    }
}

/// The replay's defaults in the device's form: `PipelineSettings::default()` with the
/// estimator settings and lever arm of `base` (so that no settings give `base` exactly).
pub fn device_form(base: &ReplayConfig) -> PipelineSettings {
    let mut ps = PipelineSettings { filter: base.settings, ..PipelineSettings::default() };
    ps.conditioning.lever_arm = base.conditioning.lever_arm;
    ps
}

/// `base` with `NAME=VALUE` settings in the device's language on top (the examples'
/// arguments), and the notes to print about them (retired or overridden names).
pub fn with_assignments<S: AsRef<str>>(
    base: &ReplayConfig,
    texts: &[S],
) -> Result<(ReplayConfig, Vec<String>), String> {
    let mut rs = ReplaySettings::new(device_form(base));
    for text in texts {
        rs.apply_given(&parse_assignment(text.as_ref())?);
    }
    Ok((rs.config(base), rs.notes()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ekf_core::Vec3;

    /// The examples' arguments: each setting applied on top of the base, a bad one refused.
    #[test]
    fn assignments_apply_on_top_of_the_base() {
        let base = ReplayConfig::default();
        let (cfg, _) = with_assignments(&base, &["init.window=5"]).unwrap();
        assert_eq!(cfg.settings.init.window_s, 5.0);
        assert_eq!(with_assignments(&base, &[] as &[&str]).unwrap().0.settings, base.settings);
        assert!(with_assignments(&base, &["init.window=x"]).is_err());
    }

    #[test]
    fn the_device_defaults_are_the_replay_defaults() {
        // No settings: the replay's configuration is unchanged.
        let base = ReplayConfig::default();
        let rs = ReplaySettings::new(device_form(&base));
        assert_eq!(rs.config(&base), base);
        assert_eq!(PipelineSettings::default().filter, base.settings);
        assert_eq!(PipelineSettings::default().conditioning.lever_arm, base.conditioning.lever_arm);
    }

    #[test]
    fn values_in_user_units_reach_the_configuration() {
        let base = ReplayConfig::default();
        let mut rs = ReplaySettings::new(device_form(&base));
        for t in [
            "mag.norm_tolerance = 0.1",
            "lever.r=0,0,0",
            "init.gyro_bias=1,2,-3",
            "rest.min_blocks=3",
        ] {
            rs.apply_given(&parse_assignment(t).unwrap());
        }
        let c = rs.config(&base);
        assert_eq!(c.settings.mag.norm_tolerance, 0.1);
        assert_eq!(c.conditioning.lever_arm.r, Vec3::ZERO);
        // Degrees per second on the wire, rad/s inside.
        let b = c.settings.init.gyro_bias;
        assert!((b.x - 1f32.to_radians()).abs() < 1e-7 && (b.z + 3f32.to_radians()).abs() < 1e-7);
        assert_eq!(c.settings.rest.min_blocks, 3);
        assert!(rs.notes().is_empty());
    }

    #[test]
    fn refusals_use_the_device_words() {
        let e = |t: &str| parse_assignment(t).unwrap_err();
        assert_eq!(e("mag.norm_tolerance=20"), "mag.norm_tolerance=20: range: valid 0 to 1");
        assert_eq!(
            e("mag.norm_tolerance=abc"),
            "mag.norm_tolerance=abc: type: expected f32: one number"
        );
        assert_eq!(
            e("lever.r=1,2"),
            "lever.r=1,2: args: expected 3 comma-separated values (f32x3: three numbers x,y,z)"
        );
        assert!(e("gate.jmp=1").starts_with("gate.jmp: unknown-setting"), "{}", e("gate.jmp=1"));
        assert!(e("axes.gyro=x,x,z").starts_with("axes.gyro=x,x,z: range:"));
        assert!(e("mag.norm_tolerance").contains("expected NAME=VALUE"));
        // The examples: negative variance, NaN, infinity, 1e300.
        for t in ["noise.accel_var=-1", "ekf.bias_random_walk=nan", "gate.norm_tolerance=inf"] {
            assert!(parse_assignment(t).is_err(), "{t}");
        }
        assert!(e("init.window=1e300").contains("range"), "{}", e("init.window=1e300"));
    }

    #[test]
    fn a_file_round_trips_and_errors_name_the_line() {
        let mut s = PipelineSettings::default();
        registry::find("mag.norm_tolerance").unwrap().set(&mut s, Value::F32(0.25));
        let text = settings_file_text(&s, &["from a test".into()]);
        assert!(text.starts_with("# from a test\nnoise.gyro_var=0.337,0.275,0.00419\n"), "{text}");
        let mut back = PipelineSettings::default();
        for (_, a) in parse_settings_text(&text, "f").unwrap().lines {
            assert!(a.setting.set(&mut back, a.value));
        }
        // The same file again (values travel as the device prints them: 7 digits).
        assert_eq!(settings_file_text(&back, &["from a test".into()]), text);
        assert_eq!(back.filter.mag.norm_tolerance, 0.25);
        let e =
            parse_settings_text("# c\n\nmag.norm_tolerance=0.1\nmag.norm_tolerance=x\n", "s.txt")
                .unwrap_err();
        assert_eq!(e, "s.txt line 4: mag.norm_tolerance=x: type: expected f32: one number");
    }

    /// Issue #39, point 8: the settings sessions 13 and 19 retired (`registry::RETIRED`), named
    /// in an old log's header or a settings file, are skipped with a warning that names them
    /// and says why, as the firmware skips their ids in a saved record; `--set` with one says
    /// it was retired.
    #[test]
    fn retired_settings_are_skipped_with_a_warning_and_refused_by_name() {
        // `--set` (and any single assignment): refused, and the reason says retired.
        let e = parse_assignment("ekf.motion_scale=0.001").unwrap_err();
        assert!(e.starts_with("ekf.motion_scale: unknown-setting: retired"), "{e}");
        let e = parse_assignment("EKF.VIB_RATE=15").unwrap_err();
        assert!(e.starts_with("ekf.vib_rate: unknown-setting: retired"), "{e}");
        // A name that never existed is still just unknown.
        let e = parse_assignment("ekf.motion_scales=1").unwrap_err();
        assert!(e.contains("no such setting"), "{e}");
        // A settings file: the retired lines skipped and listed, the rest applied.
        let text =
            "mag.norm_tolerance=0.2\nekf.vib_time_constant=1.5\n# c\nekf.motion_time_constant=1\n";
        let parsed = parse_settings_text(text, "old.txt").unwrap();
        assert_eq!(parsed.lines.len(), 1);
        assert_eq!(parsed.lines[0].1.setting.name, "mag.norm_tolerance");
        let names: Vec<(usize, &str)> = parsed.retired.iter().map(|(l, r)| (*l, r.name)).collect();
        assert_eq!(names, vec![(2, "ekf.vib_time_constant"), (4, "ekf.motion_time_constant")]);
        let w = retired_warning("old.txt", 2, parsed.retired[0].1);
        assert!(w.starts_with("old.txt line 2: ekf.vib_time_constant skipped: retired"), "{w}");
        // An old log's header: the retired settings skipped and named in the notes, the others
        // applied.
        let meta = TraceMeta {
            settings: vec![
                (2, "mag.norm_tolerance=0.3".into()),
                (3, "ekf.motion_scale=0.001".into()),
                (4, "gate.jump=0.05".into()),
                (5, "ekf.vib_rate=15".into()),
                (6, "ekf.accel_var_scale=1".into()),
                (7, "gate.holdoff=0.1".into()),
            ],
            ..TraceMeta::default()
        };
        let base = ReplayConfig::default();
        let mut rs = ReplaySettings::new(device_form(&base));
        rs.apply_trace(&meta, "old.csv").unwrap();
        assert_eq!(rs.from_trace, 1);
        assert_eq!(rs.config(&base).settings.mag.norm_tolerance, 0.3);
        let notes = rs.notes().join("\n");
        assert!(
            notes.contains("trace header: ekf.motion_scale, ekf.vib_rate skipped: retired"),
            "{notes}"
        );
        // Session 19's (issue #36), one line per reason.
        assert!(
            notes.contains("trace header: gate.jump, gate.holdoff skipped: retired by issue #36"),
            "{notes}"
        );
        assert!(
            notes.contains("trace header: ekf.accel_var_scale skipped: retired by issue #36"),
            "{notes}"
        );
        let e = parse_assignment("gate.innovation_chi2=16").unwrap_err();
        assert!(
            e.starts_with("gate.innovation_chi2: unknown-setting: retired by issue #36"),
            "{e}"
        );
    }

    #[test]
    fn settings_acting_before_the_trace_are_reported_not_applied() {
        let base = ReplayConfig::default();
        let mut rs = ReplaySettings::new(device_form(&base));
        for t in ["axes.gyro=y,x,-z", "gyro.offset=1,1,1", "output.rate=5", "axes.mag=x,y,z"] {
            rs.apply_given(&parse_assignment(t).unwrap());
        }
        assert_eq!(rs.config(&base), base);
        let notes = rs.notes().join("\n");
        assert!(notes.contains("axes.gyro, axes.mag (a trace is in body axes already)"), "{notes}");
        assert!(notes.contains("gyro.offset (sensor calibration"), "{notes}");
        assert!(notes.contains("output.rate ("), "{notes}");
    }

    #[test]
    fn a_log_header_sets_the_device_settings_and_no_second_lever_arm() {
        let mut dev = PipelineSettings::default();
        registry::find("mag.norm_tolerance").unwrap().set(&mut dev, Value::F32(0.3));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.csv");
        let mut text = String::from("t,gx,gy,gz,ax,ay,az\n");
        for c in TraceMeta::log_comments(&dev) {
            text.push_str(&format!("# {c}\n"));
        }
        text.push_str("0,0,0,0,0,0,-9.81\n# setting: mag.norm_tolerance=0.9\n");
        std::fs::write(&path, text).unwrap();
        let meta = TraceMeta::read(&path).unwrap();
        assert!(meta.lever_applied());
        assert!(!meta.restarted, "no `# estimator: restarted` line");
        let base = ReplayConfig::default();
        let mut rs = ReplaySettings::new(device_form(&base));
        rs.apply_trace(&meta, "log.csv").unwrap();
        rs.apply_given(&parse_assignment("lever.r=1,0,0").unwrap());
        let c = rs.config(&base);
        // The device's value, not the comment after the first data line.
        assert_eq!(c.settings.mag.norm_tolerance, 0.3);
        assert_eq!(c.conditioning.lever_arm, LeverArm::NONE);
        assert_eq!(
            rs.notes(),
            ["not applied: lever.r (the trace says its samples already had the lever arm)"]
        );
        // `ahrs-tool log --restart`'s line.
        let text = std::fs::read_to_string(&path).unwrap();
        let (head, rest) = text.split_once('\n').unwrap();
        std::fs::write(&path, format!("{head}\n# {META_RESTARTED}\n{rest}")).unwrap();
        assert!(TraceMeta::read(&path).unwrap().restarted);
    }
}
