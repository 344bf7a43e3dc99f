//! The command layer under libFuzzer. The input is a stream of bytes: every line (split at
//! `\n`) goes through `Device::execute` on one device with a RAM flash, the whole input also
//! through the `LineAssembler` byte by byte. The oracle, for every line:
//! - no panic;
//! - a reply is a checked sentence of at most 82 characters;
//! - a refused line (`ERR`) changes nothing: the device state and the flash compare equal to
//!   before, and it asks for no action;
//! - an accepted `SET` reads back: `GET` of the same setting replies with the value `SET`
//!   echoed;
//! - the settings always pass the registry's own checks;
//! - whether a line gets a reply, and an `ERR` reply's verb and reason, agree with an
//!   independent reading of `docs/commands.md` ([`classify`], issue #39 point 7): lines of
//!   other talkers get none; a line over 82 characters is `too-long`, a frame that is not
//!   `$…*hh` or holds a forbidden byte `format`, a wrong `hh` `checksum` (`?` as the verb for
//!   all three), a verb not in the page's table `unknown-command`; `GET` or `SET` of a name
//!   the registry does not have `unknown-setting`; any other refusal of a known verb names
//!   that verb and one of the page's reasons.
#![no_main]

use inemo_ahrs::command::{Device, LineAssembler, LineEvent};
use inemo_ahrs::nmea::{checksum, verify};
use inemo_ahrs::persist::{self, SimFlash};
use inemo_ahrs::registry::SETTINGS;
use libfuzzer_sys::fuzz_target;

/// The verbs of `docs/commands.md`'s table.
const VERBS: [&str; 18] = [
    "ABORT", "ACAL", "GBIAS", "GET", "LIST", "LOAD", "RATE", "RAW", "RESET", "SAVE", "SELFTEST",
    "SENT", "SET", "STATUS", "VER", "YAW", "YAW0", "ZERO",
];
/// The reasons of `docs/commands.md`'s table, and those that only a frame or an unknown verb
/// gets.
const REASONS: [&str; 17] = [
    "checksum",
    "format",
    "too-long",
    "unknown-command",
    "unknown-setting",
    "type",
    "range",
    "args",
    "busy",
    "no-depth",
    "not-running",
    "motion",
    "sensor",
    "position",
    "flash",
    "no-record",
    "too-large",
];
const FRAME: [&str; 4] = ["checksum", "format", "too-long", "unknown-command"];

/// What the page says a line gets.
enum Expect {
    /// No reply: another talker's line.
    Ignored,
    /// `ERR,?,<one of these>`.
    Frame(&'static [&'static str]),
    /// Parsed to a known verb (canonical name); `unknown_setting`: `GET`/`SET` of a name the
    /// registry does not have.
    Verb { name: &'static str, unknown_setting: bool },
}

/// `docs/commands.md`, *Line format*, read independently of `src/command/` and `src/nmea/`.
fn classify(line: &[u8]) -> Expect {
    let line = line
        .strip_suffix(b"\r\n")
        .or_else(|| line.strip_suffix(b"\n"))
        .or_else(|| line.strip_suffix(b"\r"))
        .unwrap_or(line);
    if !(line.starts_with(b"$PINAC") && matches!(line.get(6), Some(b',' | b'*'))) {
        return Expect::Ignored;
    }
    // 82 characters with the line end: 80 without it.
    if line.len() > 80 {
        return Expect::Frame(&["too-long"]);
    }
    let n = line.len();
    let hex = |b: u8| (b as char).to_digit(16);
    let (Some(b'*'), Some(h), Some(l)) =
        (line.get(n.wrapping_sub(3)).copied(), line.get(n - 2).copied(), line.get(n - 1).copied())
    else {
        return Expect::Frame(&["format"]);
    };
    let (Some(h), Some(l)) = (hex(h), hex(l)) else { return Expect::Frame(&["format"]) };
    let body = &line[1..n - 3];
    let forbidden = body.iter().any(|&b| b < 0x20 || b >= 0x7f || b"$*!\\^~".contains(&b));
    let sum = body.iter().fold(0u8, |x, &b| x ^ b);
    match (forbidden, u32::from(sum) == h * 16 + l) {
        (true, true) => return Expect::Frame(&["format"]),
        (true, false) => return Expect::Frame(&["format", "checksum"]),
        (false, false) => return Expect::Frame(&["checksum"]),
        (false, true) => {}
    }
    let body = std::str::from_utf8(body).expect("printable ASCII");
    let fields: Vec<&str> = body.split(',').collect();
    let verb = fields.get(1).copied().unwrap_or("");
    let Some(name) = VERBS.iter().find(|v| v.eq_ignore_ascii_case(verb)) else {
        return Expect::Frame(&["unknown-command"]);
    };
    let known = |s: &str| SETTINGS.iter().any(|x| x.name.eq_ignore_ascii_case(s));
    let unknown_setting = match (*name, fields.len()) {
        ("GET", 3) => !known(fields[2]),
        ("SET", n) if n >= 4 => !known(fields[2]),
        _ => false,
    };
    Expect::Verb { name, unknown_setting }
}

fn command(body: &str) -> Vec<u8> {
    format!("${body}*{:02X}\r\n", checksum(body.as_bytes())).into_bytes()
}

fn check_reply(d: &Device, reply: &inemo_ahrs::nmea::Sentence) -> String {
    assert!(reply.len() <= 82, "{}", reply.as_str());
    let body = verify(reply.as_bytes()).expect("a reply verifies").to_string();
    for s in SETTINGS {
        assert!(s.check(&s.get(d.settings())), "{} out of range: {body}", s.name);
    }
    body
}

fuzz_target!(|data: &[u8]| {
    let mut flash = SimFlash::new();
    let mut d = Device::new(&persist::load(&flash), "POR");
    for line in data.split(|&b| b == b'\n') {
        let (before, flash_before) = (d.clone(), flash.clone());
        let r = d.execute(line, &mut flash);
        let expect = classify(line);
        let shown = String::from_utf8_lossy(line);
        let Some(reply) = r.reply else {
            assert!(matches!(expect, Expect::Ignored), "no reply to {shown:?}");
            assert_eq!(d, before, "a line with no reply changed the device");
            continue;
        };
        let body = check_reply(&d, &reply);
        let err: Vec<&str> =
            body.strip_prefix("PINAR,ERR,").map_or(vec![], |e| e.split(',').collect());
        match expect {
            Expect::Ignored => panic!("{shown:?} is another talker's line, and got {body}"),
            Expect::Frame(reasons) => assert!(
                err.len() >= 2 && err[0] == "?" && reasons.contains(&err[1]),
                "{shown:?}: {body}, the page says ERR,?,{reasons:?}"
            ),
            Expect::Verb { name, unknown_setting } => {
                if let [verb, reason, ..] = err[..] {
                    assert!(
                        verb == name && REASONS.contains(&reason) && !FRAME.contains(&reason),
                        "{shown:?}: {body}, a refusal of {name} with one of the page's reasons"
                    );
                }
                // (`SET` with more fields than any setting takes may be refused as `args`
                // first: the page gives no order between the two.)
                if unknown_setting {
                    let ok = match err.get(1) {
                        Some(&"unknown-setting") => true,
                        Some(&"args") => name == "SET" && err.len() >= 2,
                        _ => false,
                    };
                    assert!(ok, "{shown:?}: {body}, the page says unknown-setting");
                }
            }
        }
        if body.starts_with("PINAR,ERR,") {
            assert_eq!(d, before, "refused {:?} changed the device", String::from_utf8_lossy(line));
            assert!(flash == flash_before, "refused line changed the flash");
            assert!(r.action.is_none());
        } else if let Some(rest) = body.strip_prefix("PINAR,OK,SET,") {
            // `OK,SET,<name>,<value...>`: GET must give the same value back.
            let name = rest.split(',').next().unwrap_or("");
            let got = d.execute(&command(&format!("PINAC,GET,{name}")), &mut flash);
            let got = check_reply(&d, &got.reply.expect("GET replies"));
            assert_eq!(got.strip_prefix("PINAR,OK,GET,"), Some(rest), "SET then GET of {name}");
        }
    }
    // The same bytes as a serial stream: lines of at most the longest command, no panic.
    let mut asm = LineAssembler::new();
    for &b in data {
        if let Some(LineEvent::Line(l)) = asm.push(b) {
            assert!(l.as_bytes().len() <= inemo_ahrs::command::MAX_LINE);
        }
    }
});
