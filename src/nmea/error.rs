//! Errors of sentence building and checking.

use core::fmt;

/// Why a sentence could not be built or did not check.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NmeaError {
    /// Longer than [`super::MAX_SENTENCE_LEN`] characters (82, from `$` to `\n` inclusive), or
    /// would become so.
    TooLong,
    /// A byte that may not appear in a sentence body: outside printable ASCII (0x20–0x7E) or
    /// one of the reserved `$ * ! \ ^ ~`.
    InvalidChar,
    /// Written to after [`super::Sentence::finish`].
    Finished,
    /// The line does not start with `$`.
    MissingStart,
    /// The line does not end with `*` and two hexadecimal digits (before the optional line
    /// end).
    MissingChecksum,
    /// The checksum does not match the body.
    BadChecksum {
        /// XOR of the body's bytes.
        computed: u8,
        /// The value after `*`.
        received: u8,
    },
}

impl fmt::Display for NmeaError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NmeaError::TooLong => f.write_str("sentence longer than 82 characters"),
            NmeaError::InvalidChar => f.write_str("character not allowed in a sentence"),
            NmeaError::Finished => f.write_str("sentence already finished"),
            NmeaError::MissingStart => f.write_str("sentence does not start with '$'"),
            NmeaError::MissingChecksum => f.write_str("sentence does not end with '*hh'"),
            NmeaError::BadChecksum { computed, received } => {
                write!(f, "checksum mismatch: computed {computed:02X}, received {received:02X}")
            }
        }
    }
}
