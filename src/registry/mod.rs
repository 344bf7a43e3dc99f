//! The settings registry: one table ([`SETTINGS`]) of every setting of
//! [`PipelineSettings`] the operator may read, change and save — its name, stable id, type,
//! unit, valid range and accessors.
//!
//! Everything else derives from this table: the `GET`/`SET`/`LIST` commands
//! ([`crate::command`]), the flash record ([`crate::persist`], entries keyed by
//! [`Setting::id`]) and the table in `docs/commands.md` (a test checks that every row of the
//! documentation matches [`Setting::doc_row`]).
//!
//! Units. The wire uses the operator's units — degrees, °/s, °/h, g, mV/(°/s) — written in
//! ASCII ([`Setting::unit`]: `deg`, `deg/s`, `deg/h`, ...). `PipelineSettings` stores SI/rad
//! values; [`Setting::scale`] converts (`user = internal · scale`, computed in `f64`). Ranges
//! ([`Setting::min`], [`Setting::max`]) are in user units, inclusive, and apply to every
//! component of a vector. Values are printed with 7 significant digits
//! ([`number::push_number`]); flash keeps the internal `f32` bits, so a save and a load are
//! exact.

pub mod number;
mod slot;
mod table;

pub use table::SETTINGS;

use ekf_core::axis_map::AxisMap;
use ekf_core::mathf;

use crate::nmea::{NmeaError, Sentence};
use crate::settings::PipelineSettings;
pub use crate::settings::{talker_code, talker_valid};

/// Type of a setting's value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// One number (`f32` internally), scaled to user units.
    F32,
    /// `0` or `1`.
    Bool,
    /// Unsigned integer (`u16` or smaller internally).
    U16,
    /// Three numbers (x, y, z), scaled to user units.
    Vec3,
    /// Signed axis permutation, three tokens such as `x,-y,-z`: body axis i (x forward,
    /// y starboard, z down) is the sensor axis named by token i, negated with `-`.
    Axes,
    /// An NMEA talker identifier: two characters, each `A`–`Z` or `0`–`9` (lowercase letters
    /// are taken as uppercase). Stored as [`Value::U16`], the two ASCII bytes big-endian
    /// ([`talker_code`]).
    Talker,
}

impl Kind {
    /// Number of comma-separated fields of a value of this kind.
    pub const fn fields(self) -> usize {
        match self {
            Kind::F32 | Kind::Bool | Kind::U16 | Kind::Talker => 1,
            Kind::Vec3 | Kind::Axes => 3,
        }
    }

    /// Name used in `LIST` replies and the documentation.
    pub const fn name(self) -> &'static str {
        match self {
            Kind::F32 => "f32",
            Kind::Bool => "bool",
            Kind::U16 => "u16",
            Kind::Vec3 => "f32x3",
            Kind::Axes => "axes",
            Kind::Talker => "talker",
        }
    }
}

/// A setting's value in INTERNAL units (as stored in [`PipelineSettings`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// [`Kind::F32`].
    F32(f32),
    /// [`Kind::Bool`].
    Bool(bool),
    /// [`Kind::U16`].
    U16(u16),
    /// [`Kind::Vec3`].
    Vec3([f32; 3]),
    /// [`Kind::Axes`].
    Axes(AxisMap),
}

impl Value {
    /// The kind of this value.
    pub const fn kind(&self) -> Kind {
        match self {
            Value::F32(_) => Kind::F32,
            Value::Bool(_) => Kind::Bool,
            Value::U16(_) => Kind::U16,
            Value::Vec3(_) => Kind::Vec3,
            Value::Axes(_) => Kind::Axes,
        }
    }
}

/// Why a value given as text was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ValueError {
    /// Wrong number of fields (the expected number is [`Kind::fields`]).
    Args,
    /// A field is not of the setting's type (not a number, not `0`/`1`, not an integer, not
    /// an axis token).
    Type,
    /// A field is out of [`Setting::min`]..=[`Setting::max`], or an axis map is not a
    /// permutation.
    Range,
}

/// One entry of the registry.
#[derive(Clone, Copy)]
pub struct Setting {
    /// Stable identifier used in flash records. Never reused for another meaning: a removed
    /// setting's id stays retired.
    pub id: u16,
    /// Dotted name used by `GET`/`SET` (lowercase; matched case-insensitively).
    pub name: &'static str,
    /// Value type.
    pub kind: Kind,
    /// Unit as shown to the operator ([`Setting::unit`]): its index in [`UNITS`] (one byte
    /// instead of a string reference: the table's size in flash).
    unit: u8,
    /// `user = internal · scale` for [`Kind::F32`] and [`Kind::Vec3`]; [`Scale::One`]
    /// otherwise.
    pub scale: Scale,
    /// Smallest valid value per component, user units ([`Kind::F32`], [`Kind::Vec3`],
    /// [`Kind::U16`]). `f32` (the table's size in flash); a parsed value is compared after
    /// its rounding to `f32`, so a limit such as 0.1 is the `f32` nearest to it.
    pub min: f32,
    /// Largest valid value per component, user units.
    pub max: f32,
}

impl core::fmt::Debug for Setting {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Setting").field("id", &self.id).field("name", &self.name).finish()
    }
}

/// `(°/s)` per `rad/s`, and friends.
const DEG: f64 = 180.0 / core::f64::consts::PI;

/// The unit conversions of the table: `user = internal · factor`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// 1.
    One,
    /// rad → ° (and rad/s → °/s).
    Deg,
    /// (rad/s)² → (°/s)².
    Deg2,
    /// rad/s → °/h.
    DegH,
    /// V → mV.
    Milli,
}

impl Scale {
    /// Every scale.
    pub const ALL: [Scale; 5] = [Scale::One, Scale::Deg, Scale::Deg2, Scale::DegH, Scale::Milli];

    /// The factor (a constant: for the documentation and the host).
    pub const fn factor(self) -> f64 {
        const DEG2: f64 = DEG * DEG;
        const DEG_H: f64 = DEG * 3600.0;
        match self {
            Scale::One => 1.0,
            Scale::Deg => DEG,
            Scale::Deg2 => DEG2,
            Scale::DegH => DEG_H,
            Scale::Milli => 1000.0,
        }
    }

    /// The scale whose factor is `f` (for the table, at compile time: another factor fails
    /// the build).
    const fn of(f: f64) -> Scale {
        let mut i = 0;
        while i < Scale::ALL.len() {
            if Scale::ALL[i].factor() == f {
                return Scale::ALL[i];
            }
            i += 1;
        }
        panic!("scale missing from Scale")
    }
}

/// The units of the table ([`Setting::unit`]).
pub const UNITS: [&str; 19] = [
    "",
    "(deg/s)2",
    "(deg/s)2/s",
    "Hz",
    "g2",
    "s",
    "deg",
    "deg/s",
    "deg/h",
    "g",
    "uT",
    "m",
    "V",
    "mV/(deg/s)",
    "Pa/V",
    "Pa",
    "kg/m3",
    "m/s2",
    "kHz",
];

/// The index of `unit` in [`UNITS`] (for the table, at compile time: a unit missing from
/// [`UNITS`] fails the build).
const fn unit_index(unit: &str) -> u8 {
    let (u, mut i) = (unit.as_bytes(), 0);
    while i < UNITS.len() {
        let c = UNITS[i].as_bytes();
        if c.len() == u.len() {
            let mut k = 0;
            while k < u.len() && c[k] == u[k] {
                k += 1;
            }
            if k == u.len() {
                return i as u8;
            }
        }
        i += 1;
    }
    panic!("unit missing from UNITS")
}

impl Setting {
    /// [`Setting::min`] and [`Setting::max`].
    pub fn range(&self) -> (f32, f32) {
        (self.min, self.max)
    }

    /// [`Setting::scale`]'s factor.
    pub fn scale_factor(&self) -> f64 {
        self.scale.factor()
    }

    /// Unit as shown to the operator, ASCII (empty: dimensionless or not a number).
    pub fn unit(&self) -> &'static str {
        UNITS.get(usize::from(self.unit)).copied().unwrap_or("")
    }

    /// The current value (internal units).
    pub fn get(&self, s: &PipelineSettings) -> Value {
        // The accessor hands out a mutable slot: read it from a copy.
        let mut copy = *s;
        slot::slot(&mut copy, self.id).map_or(Value::Bool(false), |slot| slot.read())
    }

    /// One-line description for the documentation (kept out of the firmware's flash: only
    /// the documentation and the host use it).
    pub fn help(&self) -> &'static str {
        table::HELP.iter().find(|(id, _)| *id == self.id).map_or("", |(_, h)| *h)
    }

    /// Store `v` (internal units). Values of another kind, or failing [`Setting::check`], are
    /// ignored and false is returned.
    pub fn set(&self, s: &mut PipelineSettings, v: Value) -> bool {
        if !self.check(&v) {
            return false;
        }
        match slot::slot(s, self.id) {
            Some(slot) => {
                slot.write(v);
                table::after_write(s, self.id);
                true
            }
            None => false,
        }
    }

    /// True when `v` (internal units) has this setting's kind and is in range. Scaled values
    /// get a relative slack of 1e−6 so that a stored internal value at a limit passes.
    pub fn check(&self, v: &Value) -> bool {
        let (min, max) = self.range();
        let slack = 1e-6 * mathf::abs(min).max(mathf::abs(max)).max(1.0);
        let in_range = |x: f32| {
            x.is_finite() && {
                let u = (f64::from(x) * self.scale_factor()) as f32;
                u >= min - slack && u <= max + slack
            }
        };
        match (*v, self.kind) {
            (Value::F32(x), Kind::F32) => in_range(x),
            (Value::Vec3(x), Kind::Vec3) => x.iter().all(|&c| in_range(c)),
            (Value::U16(x), Kind::U16) => f32::from(x) >= min && f32::from(x) <= max,
            (Value::U16(x), Kind::Talker) => talker_valid(x),
            (Value::Bool(_), Kind::Bool) | (Value::Axes(_), Kind::Axes) => true,
            _ => false,
        }
    }

    /// Parse a value from its comma-separated fields (user units) and validate it; the result
    /// is in internal units. Nothing is changed.
    pub fn parse(&self, fields: &[&str]) -> Result<Value, ValueError> {
        if fields.len() != self.kind.fields() {
            return Err(ValueError::Args);
        }
        let f = |i: usize| fields.get(i).copied().unwrap_or("");
        match self.kind {
            Kind::F32 => Ok(Value::F32(self.parse_scaled(f(0))?)),
            Kind::Vec3 => {
                // Every field is checked for its type before any for its range.
                for i in 0..3 {
                    number::parse_number(f(i)).ok_or(ValueError::Type)?;
                }
                Ok(Value::Vec3([
                    self.parse_scaled(f(0))?,
                    self.parse_scaled(f(1))?,
                    self.parse_scaled(f(2))?,
                ]))
            }
            Kind::Bool => match f(0) {
                "0" => Ok(Value::Bool(false)),
                "1" => Ok(Value::Bool(true)),
                _ => Err(ValueError::Type),
            },
            Kind::U16 => {
                let n = number::parse_uint(f(0)).ok_or(ValueError::Type)?;
                let (min, max) = self.range();
                // n < 10^9; the limits are integers below 2^24, exact in `f32`.
                if (n as f32) < min || (n as f32) > max {
                    return Err(ValueError::Range);
                }
                u16::try_from(n).map(Value::U16).map_err(|_| ValueError::Range)
            }
            Kind::Axes => parse_axes([f(0), f(1), f(2)]).map(Value::Axes),
            Kind::Talker => match f(0).as_bytes() {
                &[a, b] => {
                    let code = talker_code([a.to_ascii_uppercase(), b.to_ascii_uppercase()]);
                    if talker_valid(code) {
                        Ok(Value::U16(code))
                    } else {
                        Err(ValueError::Type)
                    }
                }
                _ => Err(ValueError::Type),
            },
        }
    }

    fn parse_scaled(&self, text: &str) -> Result<f32, ValueError> {
        let u = number::parse_number(text).ok_or(ValueError::Type)?;
        // In `f32`: the limits are `f32` (a value typed as the limit passes).
        let user = u as f32;
        if !(user.is_finite() && user >= self.min && user <= self.max) {
            return Err(ValueError::Range);
        }
        let internal = (u / self.scale_factor()) as f32;
        if !internal.is_finite() {
            return Err(ValueError::Range);
        }
        Ok(internal)
    }

    /// Append `v` (internal units) as comma-separated fields in user units.
    pub fn write_value(&self, v: &Value, out: &mut Sentence) -> Result<(), NmeaError> {
        match *v {
            Value::F32(x) => number::push_scaled(out, x, self.scale_factor()),
            Value::Vec3(x) => {
                for (i, c) in x.iter().enumerate() {
                    if i > 0 {
                        out.push_str(",")?;
                    }
                    number::push_scaled(out, *c, self.scale_factor())?;
                }
                Ok(())
            }
            Value::Bool(b) => out.push_str(if b { "1" } else { "0" }),
            Value::U16(n) if self.kind == Kind::Talker => out.push_bytes(&n.to_be_bytes()),
            Value::U16(n) => out.push_uint(u64::from(n)),
            Value::Axes(m) => {
                for i in 0..3 {
                    if i > 0 {
                        out.push_str(",")?;
                    }
                    let (src, sign) = (m.source()[i], m.sign()[i]);
                    if sign < 0 {
                        out.push_str("-")?;
                    }
                    out.push_str(match src {
                        0 => "x",
                        1 => "y",
                        _ => "z",
                    })?;
                }
                Ok(())
            }
        }
    }

    /// Serialise `v` (internal units) for flash: little-endian `f32` bits, `u16` (a talker's
    /// code too), one byte per
    /// bool, or one byte per axis (source index, bit 7 set for a negative sign). Returns the
    /// number of bytes written (0 if `out` is too short or the kind does not match).
    pub fn encode(&self, v: &Value, out: &mut [u8]) -> usize {
        let mut tmp = [0u8; 12];
        let n = match (*v, self.kind) {
            (Value::F32(x), Kind::F32) => {
                for (t, b) in tmp.iter_mut().zip(x.to_le_bytes()) {
                    *t = b;
                }
                4
            }
            (Value::Vec3(x), Kind::Vec3) => {
                for (chunk, c) in tmp.chunks_exact_mut(4).zip(x.iter()) {
                    for (t, b) in chunk.iter_mut().zip(c.to_le_bytes()) {
                        *t = b;
                    }
                }
                12
            }
            (Value::Bool(b), Kind::Bool) => {
                tmp[0] = u8::from(b);
                1
            }
            (Value::U16(x), Kind::U16 | Kind::Talker) => {
                for (t, b) in tmp.iter_mut().zip(x.to_le_bytes()) {
                    *t = b;
                }
                2
            }
            (Value::Axes(m), Kind::Axes) => {
                for ((slot, src), sign) in tmp.iter_mut().zip(m.source()).zip(m.sign()) {
                    *slot = src | if sign < 0 { 0x80 } else { 0 };
                }
                3
            }
            _ => return 0,
        };
        match (out.get_mut(..n), tmp.get(..n)) {
            (Some(dst), Some(src)) => {
                // Zips, not `copy_from_slice`: no length check left to panic (no-panic proof).
                for (d, s) in dst.iter_mut().zip(src) {
                    *d = *s;
                }
                n
            }
            _ => 0,
        }
    }

    /// Decode a value written by [`Setting::encode`]; `None` if the length or content does not
    /// fit this setting's kind, or the value fails [`Setting::check`].
    pub fn decode(&self, bytes: &[u8]) -> Option<Value> {
        let f = |i: usize| -> Option<f32> {
            let b = bytes.get(4 * i..4 * i + 4)?;
            Some(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        };
        let v = match (self.kind, bytes.len()) {
            (Kind::F32, 4) => Value::F32(f(0)?),
            (Kind::Vec3, 12) => Value::Vec3([f(0)?, f(1)?, f(2)?]),
            (Kind::Bool, 1) => match bytes.first()? {
                0 => Value::Bool(false),
                1 => Value::Bool(true),
                _ => return None,
            },
            (Kind::U16 | Kind::Talker, 2) => {
                Value::U16(u16::from_le_bytes([*bytes.first()?, *bytes.get(1)?]))
            }
            (Kind::Axes, 3) => {
                let mut source = [0u8; 3];
                let mut sign = [1i8; 3];
                for i in 0..3 {
                    let b = *bytes.get(i)?;
                    if b & 0x7C != 0 {
                        return None;
                    }
                    source[i] = b & 0x03;
                    sign[i] = if b & 0x80 != 0 { -1 } else { 1 };
                }
                Value::Axes(AxisMap::new(source, sign).ok()?)
            }
            _ => return None,
        };
        self.check(&v).then_some(v)
    }

    /// The documentation row of this setting in `docs/commands.md`:
    /// `| name | type | unit | min | max | default | description |`, a `|` of the description
    /// escaped (`\|`) so that it does not split the cell.
    pub fn doc_row(&self, out: &mut impl core::fmt::Write) -> core::fmt::Result {
        let mut default = Sentence::new();
        let _ = self.write_value(&self.get(&PipelineSettings::default()), &mut default);
        let range = matches!(self.kind, Kind::F32 | Kind::Vec3 | Kind::U16);
        let mut lo = [0u8; 24];
        let mut hi = [0u8; 24];
        let (nl, nh) = if range {
            let (min, max) = self.range();
            (
                number::format_number(f64::from(min), &mut lo),
                number::format_number(f64::from(max), &mut hi),
            )
        } else {
            (0, 0)
        };
        write!(
            out,
            "| `{}` | {} | {} | {} | {} | `{}` | ",
            self.name,
            self.kind.name(),
            self.unit(),
            ascii(&lo, nl),
            ascii(&hi, nh),
            default.body(),
        )?;
        for (i, part) in self.help().split('|').enumerate() {
            if i > 0 {
                out.write_str("\\|")?;
            }
            out.write_str(part)?;
        }
        out.write_str(" |")
    }
}

fn ascii(b: &[u8], n: usize) -> &str {
    core::str::from_utf8(b.get(..n).unwrap_or(&[])).unwrap_or("")
}

/// Parse three axis tokens (`x`, `-y`, `+z`, case-insensitive) into a map.
fn parse_axes(tokens: [&str; 3]) -> Result<AxisMap, ValueError> {
    let mut source = [0u8; 3];
    let mut sign = [1i8; 3];
    for (i, t) in tokens.iter().enumerate() {
        let (sg, rest) = match t.as_bytes() {
            [b'-', rest @ ..] => (-1, rest),
            [b'+', rest @ ..] => (1, rest),
            rest => (1, rest),
        };
        source[i] = match rest {
            [b'x' | b'X'] => 0,
            [b'y' | b'Y'] => 1,
            [b'z' | b'Z'] => 2,
            _ => return Err(ValueError::Type),
        };
        sign[i] = sg;
    }
    AxisMap::new(source, sign).map_err(|_| ValueError::Range)
}

/// A part of [`PipelineSettings`], by setting id (ids go by tens per section).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// `filter` (the estimator's settings): ids below 70.
    Filter,
    /// `conditioning`: ids 70 to 89.
    Conditioning,
    /// Everything else.
    Other,
}

impl Setting {
    /// The part of [`PipelineSettings`] this setting lives in.
    pub fn part(&self) -> Part {
        match self.id {
            0..70 => Part::Filter,
            70..90 => Part::Conditioning,
            _ => Part::Other,
        }
    }
}

/// True when every setting (of `part`; all for `None`) has the same value in `a` and `b`,
/// values compared as the derived `PartialEq` does (`f32` as numbers: −0 = 0, NaN ≠ NaN).
/// The registry reaches every field that commands and the flash record change, and the other
/// fields are constant or follow from those (`adc.vref`, `adc.vrefint`), so for settings the device derives
/// from the defaults this is the structs' equality (tested) at a fraction of its code.
pub fn same(a: &PipelineSettings, b: &PipelineSettings, part: Option<Part>) -> bool {
    let (mut a, mut b) = (*a, *b);
    SETTINGS.iter().filter(|s| part.is_none_or(|p| s.part() == p)).all(|s| {
        let read = |x: &mut PipelineSettings| slot::slot(x, s.id).map(|slot| slot.read());
        read(&mut a) == read(&mut b)
    })
}

/// The setting called `name` (ASCII case-insensitive).
pub fn find(name: &str) -> Option<&'static Setting> {
    SETTINGS.iter().find(|s| s.name.eq_ignore_ascii_case(name))
}

/// A setting that older firmware had and this one has retired.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Retired {
    /// Its flash id, never reused.
    pub id: u16,
    /// Its name as the registry spelled it.
    pub name: &'static str,
    /// Why it is gone, for the host tools' messages.
    pub why: &'static str,
}

/// Issue #26's fixed low-pass (session 13) replaced the motion level and vibration share.
const WHY_26: &str = "retired with the estimator's redesign (issue #26: the fixed low-pass replaced the motion level and vibration share)";
/// Issue #36 (session 19): the EKF never read these after its start window, which keeps the
/// defaults of two of them; the host's comparison filters use them.
const WHY_36_GATE: &str = "retired by issue #36: the EKF's only gate setting is gate.norm_tolerance (its start window's knock test keeps the defaults; the innovation gate is the comparison filters')";
/// Issue #36 (session 19): it only repeated `noise.accel_var`.
const WHY_36_VAR: &str = "retired by issue #36: the accelerometer's variance is noise.accel_var alone (this factor repeated it)";

/// Issue #36 (session 20): a floor derived from Earth's rate and the bias's random walk.
const WHY_36_FLOOR: &str = "retired by issue #36: the floor of a still block's bias measurement is derived (Earth's rate and ekf.bias_random_walk over the block)";

/// Issue #36 (session 20): the start's heading variance is that of an unknown angle.
const WHY_36_YAW: &str = "retired by issue #36: the heading is unknown at the start (variance pi^2/3): a heading source's first measurement sets it";

/// Settings that older firmware had and this one has retired. The ids are never reused; a
/// saved record that holds one loads without it (`persist`), and the host tools skip one
/// named in a log's header or a settings file, with a warning that says why (issue #39).
pub const RETIRED: [Retired; 12] = [
    Retired { id: 58, name: "ekf.vib_time_constant", why: WHY_26 },
    Retired { id: 59, name: "ekf.vib_rate", why: WHY_26 },
    Retired { id: 68, name: "ekf.motion_scale", why: WHY_26 },
    Retired { id: 69, name: "ekf.motion_time_constant", why: WHY_26 },
    Retired { id: 21, name: "gate.jump", why: WHY_36_GATE },
    Retired { id: 22, name: "gate.innovation_chi2", why: WHY_36_GATE },
    Retired { id: 23, name: "gate.holdoff", why: WHY_36_GATE },
    Retired { id: 24, name: "gate.reacquire", why: WHY_36_GATE },
    Retired { id: 25, name: "gate.long_reject", why: WHY_36_GATE },
    Retired { id: 61, name: "ekf.accel_var_scale", why: WHY_36_VAR },
    Retired { id: 46, name: "rest.bias_meas_floor", why: WHY_36_FLOOR },
    Retired { id: 65, name: "ekf.initial_yaw_sigma", why: WHY_36_YAW },
];

/// The retired setting called `name` (matched case-insensitively).
pub fn retired(name: &str) -> Option<&'static Retired> {
    RETIRED.iter().find(|r| r.name.eq_ignore_ascii_case(name))
}

/// The setting with flash id `id`.
pub fn by_id(id: u16) -> Option<&'static Setting> {
    SETTINGS.iter().find(|s| s.id == id)
}

#[cfg(test)]
mod tests;
