//! The serial link to the board: opening the port, reading checked sentences, sending
//! commands and waiting for their replies.

use std::{
    io::{self, Read, Write},
    time::{Duration, Instant},
};

use inemo_ahrs::nmea;
use serialport::SerialPort;

/// Wrap a command body (`VER`, `SET,mag.norm_tolerance,0.08`) as `$PINAC,<body>*hh\r\n`.
pub fn command_line(body: &str) -> String {
    let inner = format!("PINAC,{body}");
    format!("${inner}*{:02X}\r\n", nmea::checksum(inner.as_bytes()))
}

/// Join command-line words into a command body: words are joined with `,` (so `SET mag.norm_tolerance
/// 0.08` and `SET,mag.norm_tolerance,0.08` give the same command); a leading `$PINAC,` is dropped.
pub fn command_body(words: &[String]) -> String {
    let joined = words.join(",");
    let joined = joined.strip_prefix("$PINAC,").unwrap_or(&joined);
    joined.strip_prefix("PINAC,").unwrap_or(joined).to_string()
}

/// A parsed `$PINAR` reply.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Reply {
    /// `OK` or `ERR`.
    pub ok: bool,
    /// The verb (`?` when the board could not parse that far).
    pub verb: String,
    /// The fields after the verb.
    pub fields: Vec<String>,
    /// The whole line, without the line end.
    pub line: String,
}

impl Reply {
    /// Parse a checked sentence body (`PINAR,OK,VER,...`).
    pub fn parse(body: &str, line: &str) -> Option<Reply> {
        let mut f = body.split(',');
        if f.next()? != "PINAR" {
            return None;
        }
        let ok = match f.next()? {
            "OK" => true,
            "ERR" => false,
            _ => return None,
        };
        let verb = f.next()?.to_string();
        Some(Reply { ok, verb, fields: f.map(str::to_string).collect(), line: line.to_string() })
    }
}

/// A serial port with line assembly.
pub struct Link {
    port: Box<dyn SerialPort>,
    buf: Vec<u8>,
}

impl Link {
    /// Open `path` at 115200 8N1 and discard whatever was waiting.
    pub fn open(path: &str) -> Result<Link, String> {
        let port = serialport::new(path, 115_200)
            .timeout(Duration::from_millis(20))
            .open()
            .map_err(|e| format!("cannot open {path}: {e}"))?;
        let mut link = Link { port, buf: Vec::new() };
        link.discard_input();
        Ok(link)
    }

    /// Let other programs open the port after us, then drop pending input.
    fn discard_input(&mut self) {
        #[cfg(unix)]
        {
            // Not exclusive: the emulator's pty is opened by one tool after another.
            let _ = self.port.clear(serialport::ClearBuffer::Input);
        }
        self.buf.clear();
    }

    /// A second handle on the port, for writing from another thread (the bridge).
    pub fn writer(&self) -> io::Result<Box<dyn SerialPort>> {
        self.port.try_clone().map_err(io::Error::from)
    }

    /// Write a raw string.
    pub fn write(&mut self, text: &str) -> io::Result<()> {
        self.port.write_all(text.as_bytes())?;
        self.port.flush()
    }

    /// Send a command body as a `$PINAC` line.
    pub fn send_command(&mut self, body: &str) -> io::Result<()> {
        self.write(&command_line(body))
    }

    /// The next complete line (without line end, checksum not checked), or `None` at the
    /// deadline.
    pub fn next_line(&mut self, deadline: Instant) -> io::Result<Option<String>> {
        loop {
            if let Some(end) = self.buf.iter().position(|&b| b == b'\n' || b == b'\r') {
                let line: Vec<u8> = self.buf.drain(..=end).collect();
                let text = String::from_utf8_lossy(&line[..end]).trim().to_string();
                if text.is_empty() {
                    continue;
                }
                return Ok(Some(text));
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            let mut chunk = [0u8; 512];
            match self.port.read(&mut chunk) {
                Ok(n) => self.buf.extend_from_slice(&chunk[..n]),
                Err(e) if e.kind() == io::ErrorKind::TimedOut => {}
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
            if self.buf.len() > 4096 {
                // No line end in sight: not our device's output.
                self.buf.clear();
            }
        }
    }

    /// The next line whose checksum verifies, with its body; `None` at the deadline.
    pub fn next_sentence(&mut self, deadline: Instant) -> io::Result<Option<(String, String)>> {
        while let Some(line) = self.next_line(deadline)? {
            // A `$` inside a line starts a new one (as the firmware's assembler does).
            let start = line.rfind('$').unwrap_or(0);
            let line = &line[start..];
            if let Ok(body) = nmea::verify(line.as_bytes()) {
                return Ok(Some((body.to_string(), line.to_string())));
            }
        }
        Ok(None)
    }

    /// Wait for a reply to `verb` (or a `?` reply) until the deadline.
    pub fn wait_reply(
        &mut self,
        verb: &str,
        deadline: Instant,
        accept: impl Fn(&Reply) -> bool,
    ) -> io::Result<Option<Reply>> {
        while let Some((body, line)) = self.next_sentence(deadline)? {
            if let Some(r) = Reply::parse(&body, &line) {
                if (r.verb.eq_ignore_ascii_case(verb) || r.verb == "?") && accept(&r) {
                    return Ok(Some(r));
                }
            }
        }
        Ok(None)
    }

    /// Send a command and wait `timeout` for its immediate reply.
    pub fn command(&mut self, body: &str, timeout: Duration) -> io::Result<Option<Reply>> {
        self.send_command(body)?;
        let verb = body.split(',').next().unwrap_or("").to_ascii_uppercase();
        self.wait_reply(&verb, Instant::now() + timeout, |_| true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_commands_like_the_documented_examples() {
        assert_eq!(command_line("VER"), "$PINAC,VER*38\r\n");
        assert_eq!(
            command_line("SET,gate.norm_tolerance,0.08"),
            "$PINAC,SET,gate.norm_tolerance,0.08*3C\r\n"
        );
        let words: Vec<String> = ["SET", "gate.norm_tolerance", "0.08"].map(String::from).to_vec();
        assert_eq!(command_body(&words), "SET,gate.norm_tolerance,0.08");
        assert_eq!(command_body(&["$PINAC,VER".to_string()]), "VER");
    }

    #[test]
    fn parses_replies() {
        let line = "$PINAR,ERR,SET,range,1,50*24";
        let body = nmea::verify(line.as_bytes()).unwrap();
        let r = Reply::parse(body, line).unwrap();
        assert!(!r.ok);
        assert_eq!(r.verb, "SET");
        assert_eq!(r.fields, ["range", "1", "50"]);
        assert!(Reply::parse("PINAH,1,2", "").is_none());
    }
}
