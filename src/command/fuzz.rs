//! Fuzzing the command parser in the normal test profile, with a deterministic generator:
//! random lines, mutated valid commands (with the checksum recomputed most of the time, so
//! that the mutation reaches the parser), random byte streams through the line assembler,
//! and random filter cycles in between (NaN, infinities, rails). Checked for every input: no
//! panic; a reply, when there is one, is a valid sentence of at most 82 characters; an
//! `ERR` reply changes neither the device nor the flash and asks for no action; the settings
//! are always within the registry's ranges.

use super::tests::{cmd, fresh};
use super::*;
use crate::adc::{AdcMean, Rails};
use crate::nmea::{checksum, verify};
use crate::persist::SimFlash;
use crate::pipeline::Inputs;
use crate::registry::SETTINGS;
use ekf_core::{ImuSample, Vec3};

/// Lines executed by [`fuzz_the_command_parser`] (stated in `docs/commands.md`).
pub const FUZZ_INPUTS: usize = 150_000;

/// The fuzz test's generator: `TestRng` (xoshiro256++) with the helpers it needs.
struct Rng(crate::test_rng::TestRng);

impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0.below(n)
    }
    fn pick<'a, T>(&mut self, xs: &'a [T]) -> &'a T {
        &xs[self.below(xs.len())]
    }
    fn f32(&mut self) -> f32 {
        match self.below(8) {
            0 => f32::NAN,
            1 => f32::INFINITY,
            2 => -1e30,
            _ => (self.below(2_000_000) as f32 - 1e6) * 1e-3,
        }
    }
}

/// Interesting field values.
const TOKENS: &[&str] = &[
    "",
    "0",
    "1",
    "-1",
    "2",
    "0.5",
    "1e3",
    "1e-9",
    "1e39",
    "-1e39",
    "1e400",
    "nan",
    "inf",
    "-0",
    "+5",
    ".",
    "-",
    "e",
    "1e",
    "0x10",
    "65535",
    "65536",
    "4294967296",
    "99999999999",
    "x",
    "-y",
    "+z",
    "w",
    "--x",
    "XUP",
    "ZDOWN",
    "FIT",
    "CLEAR",
    "yes",
    "true",
    " 1",
    "1 ",
    "3.4e38",
    "-3.4e38",
    "1.17549435e-38",
    "180",
    "-180",
    "360",
    "600",
    "601",
    "50",
    "200",
    "201",
];

/// Valid commands: every verb, and GET/SET of every setting with its current value.
fn corpus() -> Vec<String> {
    let mut c: Vec<String> = [
        "PINAC,VER",
        "PINAC,STATUS",
        "PINAC,YAW,12.5",
        "PINAC,YAW0,-30",
        "PINAC,ZERO",
        "PINAC,GBIAS,1",
        "PINAC,ACAL,ZUP,0.5",
        "PINAC,ACAL,CLEAR",
        "PINAC,ABORT",
        "PINAC,RATE,5",
        "PINAC,SENT,1,0",
        "PINAC,SENT,1,1,0,0,0,1,1",
        "PINAC,SENT,HDM,1",
        "PINAC,RAW,1",
        "PINAC,RAW,2",
        "PINAC,RAW,0",
        "PINAC,SAVE",
        "PINAC,LOAD",
        "PINAC,RESET",
        "PINAC,LIST,3",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let d = crate::pipeline::PipelineSettings::default();
    for s in &SETTINGS {
        c.push(format!("PINAC,GET,{}", s.name));
        let mut v = crate::nmea::Sentence::new();
        s.write_value(&s.get(&d), &mut v).unwrap();
        c.push(format!("PINAC,SET,{},{}", s.name, v.body()));
    }
    c
}

fn mutate(rng: &mut Rng, base: &str) -> Vec<u8> {
    let mut body = base.as_bytes().to_vec();
    for _ in 0..1 + rng.below(3) {
        match rng.below(7) {
            0 if !body.is_empty() => {
                let i = rng.below(body.len());
                body[i] ^= 1 << rng.below(8);
            }
            1 => {
                let i = rng.below(body.len() + 1);
                body.insert(i, *rng.pick(b",.-+eE0123456789$*\r\n\x00\xffAZaz_"));
            }
            2 if !body.is_empty() => {
                let i = rng.below(body.len());
                body.remove(i);
            }
            3 => {
                // Replace one field with a token.
                let s = String::from_utf8_lossy(&body).into_owned();
                let mut fields: Vec<String> = s.split(',').map(str::to_string).collect();
                let i = rng.below(fields.len());
                fields[i] = rng.pick(TOKENS).to_string();
                body = fields.join(",").into_bytes();
            }
            4 => {
                body.push(b',');
                body.extend_from_slice(rng.pick(TOKENS).as_bytes());
            }
            5 => {
                let n = rng.below(body.len() + 1);
                body.truncate(n);
            }
            _ => {
                // Repeat a field (long lines).
                let s = String::from_utf8_lossy(&body).into_owned();
                let last = s.rsplit(',').next().unwrap_or("").to_string();
                for _ in 0..rng.below(30) {
                    body.push(b',');
                    body.extend_from_slice(last.as_bytes());
                }
            }
        }
    }
    match rng.below(10) {
        // Recompute the checksum: the parser sees the mutation.
        0..=6 => {
            let mut line = b"$".to_vec();
            line.extend_from_slice(&body);
            line.extend_from_slice(format!("*{:02X}", checksum(&body)).as_bytes());
            if rng.below(2) == 0 {
                line.extend_from_slice(b"\r\n");
            }
            line
        }
        // The original checksum (usually wrong now), or none.
        7 | 8 => {
            let mut line = cmd(base);
            let at = line.len() - 5;
            line.splice(1..at, body);
            line
        }
        _ => {
            let mut line = b"$".to_vec();
            line.extend_from_slice(&body);
            line
        }
    }
}

fn random_line(rng: &mut Rng) -> Vec<u8> {
    let mut line = if rng.below(2) == 0 { b"$PINAC,".to_vec() } else { Vec::new() };
    for _ in 0..rng.below(90) {
        line.push(match rng.below(4) {
            0 => *rng.pick(b",*$.-0123456789"),
            1 => b'A' + rng.below(26) as u8,
            _ => rng.below(256) as u8,
        });
    }
    if rng.below(2) == 0 && line.len() > 1 {
        let cs = checksum(&line[1..]);
        line.extend_from_slice(format!("*{cs:02X}").as_bytes());
    }
    line
}

fn random_inputs(rng: &mut Rng) -> Inputs {
    let mean = AdcMean {
        gyro_x: rng.f32() * 4.0,
        gyro_y: 1861.0,
        gyro_xy_ref: 1861.0,
        gyro_z: 1861.0 + rng.f32(),
        gyro_z_ref: 1861.0,
        depth: rng.f32().abs() * 4.0,
        samples: 20,
        rails: Rails(rng.below(64) as u8),
        ..AdcMean::default()
    };
    Inputs {
        dt: if rng.below(20) == 0 { rng.f32() } else { 0.02 },
        adc: (rng.below(10) > 0).then_some(mean),
        accel_g: (rng.below(10) > 0).then(|| [rng.f32() * 1e-3, rng.f32() * 1e-3, 1.0]),
        mag_ut: (rng.below(3) == 0).then(|| [rng.f32(), rng.f32(), rng.f32()]),
        ..Inputs::default()
    }
}

fn check_reply(s: &crate::nmea::Sentence) -> bool {
    assert!(s.len() <= 82, "{}", s.as_str());
    let body = verify(s.as_bytes()).expect("replies verify");
    assert!(body.starts_with("PINAR,OK,") || body.starts_with("PINAR,ERR,"), "{body}");
    body.starts_with("PINAR,ERR,")
}

fn settings_in_range(d: &Device) {
    for s in &SETTINGS {
        assert!(s.check(&s.get(d.settings())), "{} out of range", s.name);
    }
}

fn execute_checked(d: &mut Device, flash: &mut SimFlash, line: &[u8]) -> (bool, bool) {
    let before = d.clone();
    let flash_before = flash.clone();
    let r = d.execute(line, flash);
    let Some(reply) = r.reply else {
        assert_eq!(*d, before);
        assert!(r.action.is_none());
        return (false, false);
    };
    let err = check_reply(&reply);
    if err {
        assert_eq!(*d, before, "{:?} changed the device", String::from_utf8_lossy(line));
        assert_eq!(*flash, flash_before);
        assert!(r.action.is_none());
    } else if let Some(Action::ApplySettings { .. }) = r.action {
        assert_ne!(d.settings(), before.settings());
    }
    settings_in_range(d);
    (true, err)
}

#[test]
fn fuzz_the_command_parser() {
    let corpus = corpus();
    let mut rng = Rng(crate::test_rng::TestRng::new(0x5EED));
    let mut d = fresh();
    let mut flash = SimFlash::new();
    let (mut replies, mut errors, mut oks) = (0usize, 0usize, 0usize);
    for k in 0..FUZZ_INPUTS {
        let line = match k % 10 {
            0 | 1 => random_line(&mut rng),
            2 => cmd(rng.pick(&corpus).as_str()),
            _ => {
                let base = rng.pick(&corpus).clone();
                mutate(&mut rng, &base)
            }
        };
        let (replied, err) = execute_checked(&mut d, &mut flash, &line);
        replies += usize::from(replied);
        errors += usize::from(err);
        oks += usize::from(replied && !err);
        if k % 7 == 0 {
            let i = random_inputs(&mut rng);
            let sample = ImuSample::new(i.dt, Vec3::new(rng.f32(), 0.0, 0.0), Vec3::ZERO);
            let out = d.on_cycle(&i, &sample, ekf_core::Quaternion::IDENTITY);
            if let Some(r) = &out.reply {
                check_reply(r);
            }
            for s in out.raw_sentences() {
                assert!(s.len() <= 82 && verify(s.as_bytes()).is_ok());
            }
            settings_in_range(&d);
        }
        if k % 5000 == 4999 {
            // Now and then start over, so that no mode (raw, a calibration) dominates.
            d = fresh();
        }
    }
    // The generator reaches both outcomes often.
    assert!(replies > FUZZ_INPUTS / 2, "{replies}");
    assert!(errors > FUZZ_INPUTS / 3 && oks > FUZZ_INPUTS / 20, "{errors} {oks}");
}

#[test]
fn fuzz_byte_streams_through_the_line_assembler() {
    let corpus = corpus();
    let mut rng = Rng(crate::test_rng::TestRng::new(0xB17E));
    let mut d = fresh();
    let mut flash = SimFlash::new();
    let mut asm = LineAssembler::new();
    let mut lines = 0;
    for _ in 0..20_000 {
        let chunk = match rng.below(3) {
            0 => random_line(&mut rng),
            1 => cmd(rng.pick(&corpus).as_str()),
            _ => {
                let base = rng.pick(&corpus).clone();
                mutate(&mut rng, &base)
            }
        };
        for b in chunk {
            let Some(ev) = asm.push(b) else { continue };
            lines += 1;
            match ev {
                LineEvent::Line(l) => {
                    assert!(l.as_bytes().len() <= MAX_LINE);
                    execute_checked(&mut d, &mut flash, l.as_bytes());
                }
                LineEvent::TooLong => {
                    let before = d.clone();
                    let r = d.handle(&ev, &mut flash);
                    assert!(check_reply(&r.reply.unwrap()));
                    assert_eq!(d, before);
                }
            }
        }
    }
    assert!(lines > 10_000, "{lines}");
}
