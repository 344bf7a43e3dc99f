//! The command layer under libFuzzer. The input is a stream of bytes: every line (split at
//! `\n`) goes through `Device::execute` on one device with a RAM flash, the whole input also
//! through the `LineAssembler` byte by byte. The oracle, for every line:
//! - no panic;
//! - a reply is a checked sentence of at most 82 characters;
//! - a refused line (`ERR`) changes nothing: the device state and the flash compare equal to
//!   before, and it asks for no action;
//! - an accepted `SET` reads back: `GET` of the same setting replies with the value `SET`
//!   echoed;
//! - the settings always pass the registry's own checks.
#![no_main]

use inemo_ahrs::command::{Device, LineAssembler, LineEvent};
use inemo_ahrs::nmea::{checksum, verify};
use inemo_ahrs::persist::{self, SimFlash};
use inemo_ahrs::registry::SETTINGS;
use libfuzzer_sys::fuzz_target;

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
        let Some(reply) = r.reply else {
            assert_eq!(d, before, "a line with no reply changed the device");
            continue;
        };
        let body = check_reply(&d, &reply);
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
