//! Assembling command lines from the bytes the UART receives.

/// Longest line kept, bytes, from `$` to the checksum digits, without the line end: 80, so
/// that with `\r\n` a line is at most the 82 characters NMEA 0183 allows.
pub const MAX_LINE: usize = 80;

/// One received line, `$` to the checksum, without the line end.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Line {
    buf: [u8; MAX_LINE],
    len: u8,
}

impl Line {
    /// A line holding `bytes` (truncated to [`MAX_LINE`]); for tests and tools.
    pub fn from_bytes(bytes: &[u8]) -> Line {
        let mut line = Line { buf: [0; MAX_LINE], len: 0 };
        let n = bytes.len().min(MAX_LINE);
        if let (Some(dst), Some(src)) = (line.buf.get_mut(..n), bytes.get(..n)) {
            dst.copy_from_slice(src);
        }
        line.len = n as u8;
        line
    }

    /// The line's bytes.
    pub fn as_bytes(&self) -> &[u8] {
        self.buf.get(..usize::from(self.len)).unwrap_or(&[])
    }
}

impl core::fmt::Debug for Line {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_tuple("Line").field(&core::str::from_utf8(self.as_bytes())).finish()
    }
}

/// What a received byte completed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineEvent {
    /// A line, for [`super::Device::execute`].
    Line(Line),
    /// A `$PINAC` line grew beyond [`MAX_LINE`]: it is discarded up to the next `$` or line
    /// end; answer with [`super::Device::too_long`].
    TooLong,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    /// Waiting for `$` (bytes outside a line are ignored).
    Idle,
    /// Inside a line.
    Collecting,
    /// After an overflow: ignoring bytes until `$` or a line end.
    Discarding,
}

/// Turns the received byte stream into lines, in a fixed buffer: feed every byte to
/// [`LineAssembler::push`] (e.g. from the USART RX interrupt).
///
/// A line starts at `$` and ends at `\r` or `\n` (so `\r\n`, `\n` and `\r` all work; the
/// empty line between `\r` and `\n` is ignored). A `$` inside a line starts a new one (the
/// partial line is dropped silently). Bytes between lines are ignored. A line longer than
/// [`MAX_LINE`] gives one [`LineEvent::TooLong`] — only for lines starting with `$PINAC`, so
/// that other equipment's long sentences (or an echo) cause no reply — and the rest of it is
/// discarded. Never panics, never allocates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineAssembler {
    buf: [u8; MAX_LINE],
    len: usize,
    state: State,
}

impl Default for LineAssembler {
    fn default() -> Self {
        LineAssembler::new()
    }
}

impl LineAssembler {
    /// An empty assembler, waiting for `$`.
    pub const fn new() -> Self {
        LineAssembler { buf: [0; MAX_LINE], len: 0, state: State::Idle }
    }

    /// Feed one received byte.
    pub fn push(&mut self, byte: u8) -> Option<LineEvent> {
        match (byte, self.state) {
            (b'$', _) => {
                self.buf[0] = b'$';
                self.len = 1;
                self.state = State::Collecting;
                None
            }
            (b'\r' | b'\n', State::Collecting) => {
                self.state = State::Idle;
                let line = Line::from_bytes(self.buf.get(..self.len).unwrap_or(&[]));
                self.len = 0;
                Some(LineEvent::Line(line))
            }
            (b'\r' | b'\n', _) => {
                self.state = State::Idle;
                None
            }
            (_, State::Collecting) => match self.buf.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                    None
                }
                None => {
                    self.state = State::Discarding;
                    let ours = self.buf.starts_with(b"$PINAC");
                    self.len = 0;
                    ours.then_some(LineEvent::TooLong)
                }
            },
            (_, State::Idle | State::Discarding) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feed(a: &mut LineAssembler, bytes: &[u8]) -> Vec<LineEvent> {
        bytes.iter().filter_map(|&b| a.push(b)).collect()
    }

    fn line(s: &str) -> LineEvent {
        LineEvent::Line(Line::from_bytes(s.as_bytes()))
    }

    /// A test's failure message shows the line as text (the `Debug` the assertions print).
    #[test]
    fn a_line_debugs_as_its_text() {
        assert_eq!(format!("{:?}", Line::from_bytes(b"$PINAC,VER")), r#"Line(Ok("$PINAC,VER"))"#);
    }

    #[test]
    fn line_ends_and_noise() {
        let mut a = LineAssembler::new();
        assert_eq!(feed(&mut a, b"$PINAC,VER*21\r\n"), [line("$PINAC,VER*21")]);
        assert_eq!(feed(&mut a, b"$A*41\n$B*42\r"), [line("$A*41"), line("$B*42")]);
        // Garbage between lines, and a line cut by a new `$`.
        assert_eq!(feed(&mut a, b"xyz\r\n\n$PIN$C*43\r\n"), [line("$C*43")]);
        // Bytes are kept as they are (the executor rejects what is not a sentence).
        assert_eq!(feed(&mut a, b"$\x00\xff\n"), [LineEvent::Line(Line::from_bytes(b"$\x00\xff"))]);
        assert_eq!(feed(&mut a, b"$\r"), [line("$")]);
    }

    #[test]
    fn eighty_characters_fit_eighty_one_do_not() {
        let mut a = LineAssembler::new();
        let mut ok = b"$PINAC,".to_vec();
        ok.resize(MAX_LINE, b'A');
        let mut bytes = ok.clone();
        bytes.extend_from_slice(b"\r\n");
        assert_eq!(feed(&mut a, &bytes), [LineEvent::Line(Line::from_bytes(&ok))]);
        let mut long = ok.clone();
        long.extend_from_slice(b"BCDEFGH\r\n$PINAC,VER*21\r\n");
        assert_eq!(feed(&mut a, &long), [LineEvent::TooLong, line("$PINAC,VER*21")]);
        // The rest of a long line up to `$` is discarded, then a new line starts.
        let mut long = ok.clone();
        long.extend_from_slice(b"B*00$PINAC,VER*21\n");
        assert_eq!(feed(&mut a, &long), [LineEvent::TooLong, line("$PINAC,VER*21")]);
        // Long lines of other talkers are dropped silently.
        let mut other = b"$GPGSV,".to_vec();
        other.resize(200, b'1');
        other.push(b'\n');
        assert!(feed(&mut a, &other).is_empty());
    }

    #[test]
    fn a_megabyte_of_noise_never_panics_and_lines_stay_bounded() {
        let mut a = LineAssembler::new();
        let mut x: u32 = 1;
        for _ in 0..1_000_000 {
            x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            let b = match x >> 28 {
                0 => b'$',
                1 => b'\n',
                2 => b'\r',
                _ => (x >> 16) as u8,
            };
            if let Some(LineEvent::Line(l)) = a.push(b) {
                assert!(l.as_bytes().len() <= MAX_LINE && l.as_bytes()[0] == b'$');
            }
        }
    }
}
