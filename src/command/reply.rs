//! Reply sentences: `$PINAR,OK,<verb>,...*hh` and `$PINAR,ERR,<verb or ?>,<reason>,...*hh`.

use crate::nmea::Sentence;
use crate::registry::number::{self, Decimal};
use crate::registry::{Setting, Value};

/// Why a command was refused (the `<reason>` field of an `ERR` reply).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reason {
    /// The checksum does not match.
    Checksum,
    /// Not a sentence: no `*hh`, or a byte that may not appear in a sentence.
    Format,
    /// Longer than 82 characters.
    TooLong,
    /// Unknown verb.
    UnknownCommand,
    /// Unknown setting name.
    UnknownSetting,
    /// A field is not of the expected type.
    Type,
    /// A value is out of range.
    Range,
    /// Wrong number of fields.
    Args,
    /// That calibration is already running.
    Busy,
    /// `ZERO` without a recent, valid depth reading.
    NoDepth,
    /// `ABORT` with no calibration running.
    NotRunning,
    /// The board moved during a calibration.
    Motion,
    /// No usable sensor samples during a calibration.
    Sensor,
    /// The accelerometer did not point along the requested position.
    Position,
    /// Flash erase, program or verification failed (the previous record is intact).
    Flash,
    /// `LOAD`: no valid record in flash (settings unchanged).
    NoRecord,
    /// The record does not fit a flash page.
    TooLarge,
}

impl Reason {
    /// The reason as sent.
    pub const fn as_str(self) -> &'static str {
        match self {
            Reason::Checksum => "checksum",
            Reason::Format => "format",
            Reason::TooLong => "too-long",
            Reason::UnknownCommand => "unknown-command",
            Reason::UnknownSetting => "unknown-setting",
            Reason::Type => "type",
            Reason::Range => "range",
            Reason::Args => "args",
            Reason::Busy => "busy",
            Reason::NoDepth => "no-depth",
            Reason::NotRunning => "not-running",
            Reason::Motion => "motion",
            Reason::Sensor => "sensor",
            Reason::Position => "position",
            Reason::Flash => "flash",
            Reason::NoRecord => "no-record",
            Reason::TooLarge => "too-large",
        }
    }

    /// Every reason, for documentation checks.
    pub const ALL: [Reason; 17] = [
        Reason::Checksum,
        Reason::Format,
        Reason::TooLong,
        Reason::UnknownCommand,
        Reason::UnknownSetting,
        Reason::Type,
        Reason::Range,
        Reason::Args,
        Reason::Busy,
        Reason::NoDepth,
        Reason::NotRunning,
        Reason::Motion,
        Reason::Sensor,
        Reason::Position,
        Reason::Flash,
        Reason::NoRecord,
        Reason::TooLarge,
    ];
}

/// Extra fields of an `ERR` reply.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Detail {
    /// Nothing.
    None,
    /// The valid range: `,<min>,<max>`.
    Range(f32, f32),
    /// A count: the expected number of value fields (`args`).
    Count(u32),
    /// The expected type (`type`): `f32`, `f32x3`, `bool`, `u16`, `axes`.
    Kind(&'static str),
}

/// A reply under construction. Write errors are sticky in the sentence; [`Out::finish`]
/// falls back to the bare `$PINAR,OK,<verb>` if the reply would not fit (the tests show that
/// none does).
pub struct Out {
    s: Sentence,
    verb: &'static str,
}

impl Out {
    /// `PINAR,OK,<verb>`.
    pub fn ok(verb: &'static str) -> Out {
        let mut s = Sentence::new();
        let _ = s.push_str("PINAR,OK,");
        let _ = s.push_str(verb);
        Out { s, verb }
    }

    /// `,<text>`.
    pub fn field(&mut self, text: &str) {
        let _ = self.s.push_str(",");
        let _ = self.s.push_str(text);
    }

    /// `,<number>` (a number as typed, 7 significant digits).
    pub fn num(&mut self, v: Decimal) {
        let _ = self.s.push_str(",");
        let _ = number::push_decimal(&mut self.s, v);
    }

    /// `,<number>` (7 significant digits; empty for NaN and infinities).
    pub fn num_f32(&mut self, v: f32) {
        let _ = self.s.push_str(",");
        let _ = number::push_f32(&mut self.s, v);
    }

    /// `,<integer>`.
    pub fn uint(&mut self, v: u64) {
        let _ = self.s.push_str(",");
        let _ = self.s.push_uint(v);
    }

    /// `,<hex digits>`.
    pub fn hex(&mut self, v: u32, digits: u8) {
        let _ = self.s.push_str(",");
        let _ = self.s.push_hex(v, digits);
    }

    /// `,<value fields>` in the setting's user units.
    pub fn value(&mut self, setting: &Setting, v: &Value) {
        let _ = self.s.push_str(",");
        let _ = setting.write_value(v, &mut self.s);
    }

    /// The finished sentence.
    pub fn finish(mut self) -> Sentence {
        if self.s.finish().is_ok() {
            return self.s;
        }
        let mut s = Sentence::new();
        let _ = s.push_str("PINAR,OK,");
        let _ = s.push_str(self.verb);
        let _ = s.finish();
        s
    }

    /// `$PINAR,ERR,<verb>,<reason>[,<detail>]*hh`.
    pub fn err(verb: &str, reason: Reason, detail: Detail) -> Sentence {
        let mut s = Sentence::new();
        let _ = s.push_str("PINAR,ERR,");
        let _ = s.push_str(verb);
        let _ = s.push_str(",");
        let _ = s.push_str(reason.as_str());
        let mut with_detail = s.clone();
        let _ = match detail {
            Detail::None => Ok(()),
            Detail::Range(lo, hi) => {
                let _ = with_detail.push_str(",");
                let _ = number::push_f32(&mut with_detail, lo);
                let _ = with_detail.push_str(",");
                number::push_f32(&mut with_detail, hi)
            }
            Detail::Count(n) => {
                let _ = with_detail.push_str(",");
                with_detail.push_uint(u64::from(n))
            }
            Detail::Kind(k) => {
                let _ = with_detail.push_str(",");
                with_detail.push_str(k)
            }
        };
        if with_detail.finish().is_ok() {
            return with_detail;
        }
        let _ = s.finish();
        s
    }
}
