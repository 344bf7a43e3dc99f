//! The fixed-capacity sentence buffer and the checksum.

use core::fmt;

use super::error::NmeaError;

/// Longest sentence NMEA 0183 allows, characters, from `$` to the final `\n` inclusive.
pub const MAX_SENTENCE_LEN: usize = 82;
/// Bytes after the body: `*`, two hex digits, `\r`, `\n`.
const TRAILER_LEN: usize = 5;
/// Longest body (between `$` and `*`), characters: 82 − 1 − 5 = 76.
pub const MAX_BODY_LEN: usize = MAX_SENTENCE_LEN - 1 - TRAILER_LEN;

/// XOR of all bytes of `body` (the bytes between `$` and `*`): the NMEA checksum.
pub const fn checksum(body: &[u8]) -> u8 {
    let mut x = 0u8;
    let mut i = 0;
    while i < body.len() {
        x ^= body[i];
        i += 1;
    }
    x
}

/// True for a byte allowed in a sentence body: printable ASCII except the reserved
/// `$ * ! \ ^ ~` (the field separator `,` is allowed).
pub const fn is_body_byte(b: u8) -> bool {
    matches!(b, 0x20..=0x7E) && !matches!(b, b'$' | b'*' | b'!' | b'\\' | b'^' | b'~')
}

/// Uppercase hexadecimal digit of the low nibble of `n`.
pub(super) const fn hex_digit(n: u8) -> u8 {
    let n = n & 0x0F;
    if n < 10 {
        b'0' + n
    } else {
        b'A' + n - 10
    }
}

/// One NMEA 0183 sentence in a fixed buffer of [`MAX_SENTENCE_LEN`] bytes (no allocation).
///
/// It starts as `$`; the body (address and fields) is appended with [`Sentence::push_str`],
/// `core::fmt::Write` or the number writers ([`Sentence::push_fixed`] and friends), and
/// [`Sentence::finish`] appends `*hh\r\n`. Room for the trailer is always kept, so a finished
/// sentence is never longer than 82 characters.
///
/// Errors are sticky: a write that would overflow or that holds a forbidden byte writes
/// nothing and returns an error, and every later write and [`Sentence::finish`] return the
/// same error, so a chain of writes may be checked once, at `finish`.
#[derive(Clone)]
pub struct Sentence {
    buf: [u8; MAX_SENTENCE_LEN],
    len: usize,
    finished: bool,
    error: Option<NmeaError>,
}

impl Default for Sentence {
    fn default() -> Self {
        Sentence::new()
    }
}

impl fmt::Debug for Sentence {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Sentence")
            .field("text", &self.as_str())
            .field("finished", &self.finished)
            .field("error", &self.error)
            .finish()
    }
}

impl Sentence {
    /// An empty sentence: just `$`.
    pub const fn new() -> Self {
        let mut buf = [0u8; MAX_SENTENCE_LEN];
        buf[0] = b'$';
        Sentence { buf, len: 1, finished: false, error: None }
    }

    /// Back to the empty sentence (`$`), clearing any error.
    pub fn clear(&mut self) {
        *self = Sentence::new();
    }

    /// Append body text. Fails, writing nothing, if the body would exceed [`MAX_BODY_LEN`]
    /// ([`NmeaError::TooLong`]), if `s` holds a byte not allowed in a body
    /// ([`NmeaError::InvalidChar`]), after [`Sentence::finish`] ([`NmeaError::Finished`]), or
    /// after an earlier error (that error).
    pub fn push_str(&mut self, s: &str) -> Result<(), NmeaError> {
        self.push_bytes(s.as_bytes())
    }

    /// Append body bytes (see [`Sentence::push_str`]).
    pub fn push_bytes(&mut self, bytes: &[u8]) -> Result<(), NmeaError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        if self.finished {
            return Err(NmeaError::Finished);
        }
        let end = self.len + bytes.len();
        let result = if end > 1 + MAX_BODY_LEN {
            Err(NmeaError::TooLong)
        } else if !bytes.iter().all(|&b| is_body_byte(b)) {
            Err(NmeaError::InvalidChar)
        } else {
            match self.buf.get_mut(self.len..end) {
                Some(dst) => {
                    // Equal lengths, but `copy_from_slice`'s check would stay in the code (a
                    // panic path for the no-panic proof): a zip copies them.
                    for (d, b) in dst.iter_mut().zip(bytes) {
                        *d = *b;
                    }
                    self.len = end;
                    Ok(())
                }
                None => Err(NmeaError::TooLong),
            }
        };
        if let Err(e) = result {
            self.error = Some(e);
        }
        result
    }

    /// Append `*`, the checksum as two uppercase hex digits, and `\r\n`. Returns the sticky
    /// error if any write failed; finishing twice is harmless.
    pub fn finish(&mut self) -> Result<(), NmeaError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        if self.finished {
            return Ok(());
        }
        let cs = checksum(self.body().as_bytes());
        let trailer = [b'*', hex_digit(cs >> 4), hex_digit(cs), b'\r', b'\n'];
        // Room for the trailer is reserved by `push_bytes`.
        match self.buf.get_mut(self.len..self.len + TRAILER_LEN) {
            Some(dst) => dst.copy_from_slice(&trailer),
            None => return Err(NmeaError::TooLong),
        }
        self.len += TRAILER_LEN;
        self.finished = true;
        Ok(())
    }

    /// True after a successful [`Sentence::finish`].
    #[inline]
    pub const fn is_finished(&self) -> bool {
        self.finished
    }

    /// The first error of a write, if any.
    #[inline]
    pub const fn error(&self) -> Option<NmeaError> {
        self.error
    }

    /// The sentence so far (complete with `*hh\r\n` once finished).
    #[inline]
    pub fn as_bytes(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }

    /// The sentence so far as text (always ASCII).
    pub fn as_str(&self) -> &str {
        core::str::from_utf8(self.as_bytes()).unwrap_or("")
    }

    /// The body: the text between `$` and `*` (or the end, before `finish`).
    pub fn body(&self) -> &str {
        let end = if self.finished { self.len.saturating_sub(TRAILER_LEN) } else { self.len };
        self.buf.get(1..end).and_then(|b| core::str::from_utf8(b).ok()).unwrap_or("")
    }

    /// Length so far, bytes (including `$`, and the trailer once finished).
    #[inline]
    pub const fn len(&self) -> usize {
        self.len
    }

    /// True when the body is empty (the sentence is just `$`).
    #[inline]
    pub const fn is_empty(&self) -> bool {
        self.len <= 1
    }
}

impl fmt::Write for Sentence {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.push_str(s).map_err(|_| fmt::Error)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::fmt::Write;

    #[test]
    fn classic_gga_checksum() {
        let body = "GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,";
        assert_eq!(checksum(body.as_bytes()), 0x47);
        let mut s = Sentence::new();
        write!(s, "{body}").unwrap();
        s.finish().unwrap();
        assert_eq!(
            s.as_str(),
            "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\r\n"
        );
        assert_eq!(s.body(), body);
        assert!(s.is_finished());
    }

    #[test]
    fn uppercase_hex_and_small_sentences() {
        let mut s = Sentence::new();
        assert!(s.is_empty());
        s.push_str("A").unwrap();
        s.finish().unwrap();
        assert_eq!(s.as_bytes(), b"$A*41\r\n");
        // 'J' ^ 'P' = 0x1A: letters, not lowercase.
        let mut s = Sentence::new();
        s.push_str("JP").unwrap();
        s.finish().unwrap();
        s.finish().unwrap();
        assert_eq!(s.as_str(), "$JP*1A\r\n");
        assert_eq!(s.push_str(","), Err(NmeaError::Finished));
    }

    #[test]
    fn overflow_is_an_error_and_sticky() {
        let mut s = Sentence::new();
        let long = "ABCDEFGHIJKLMNOPQRSTUVWXYZABCDEFGHIJKLMNOPQRSTUVWXYZABCDEFGHIJKLMNOPQRSTUVWX";
        assert_eq!(long.len(), MAX_BODY_LEN);
        s.push_str(long).unwrap();
        assert_eq!(s.push_str("Y"), Err(NmeaError::TooLong));
        assert_eq!(s.len(), 1 + MAX_BODY_LEN);
        assert_eq!(s.finish(), Err(NmeaError::TooLong));
        // Through core::fmt as well: an error, not a panic.
        let mut s = Sentence::new();
        assert!(write!(s, "{long}{}", 1).is_err());
        assert_eq!(s.error(), Some(NmeaError::TooLong));
        // A full body still finishes at exactly 82 characters.
        let mut s = Sentence::new();
        s.push_str(long).unwrap();
        s.finish().unwrap();
        assert_eq!(s.len(), MAX_SENTENCE_LEN);
        s.clear();
        assert_eq!(s.as_str(), "$");
        assert_eq!(s.error(), None);
    }

    #[test]
    fn reserved_characters_are_refused() {
        for bad in ["*", "$", "!", "\\", "^", "~", "\r", "\n", "é", "\t"] {
            let mut s = Sentence::new();
            assert_eq!(s.push_str(bad), Err(NmeaError::InvalidChar), "{bad:?}");
            assert_eq!(s.as_str(), "$");
        }
    }
}
