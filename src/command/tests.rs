//! Tests of the command protocol: every verb, every error reason, the calibrations, raw mode,
//! and the pipeline following the device's settings.

use super::*;
use crate::adc::AdcMean;
use crate::nmea::{checksum, verify, Sentence};
use crate::persist::{self, Flash, FlashError, Page, SimFlash, Source};
use crate::pipeline::{Inputs, Pipeline, PipelineSettings};
use crate::registry::{self, SETTINGS};
use ekf_core::{mathf, AttitudeFilter, Euler, ImuSample, Quaternion, Vec3};

/// `$<body>*hh`.
pub(super) fn cmd(body: &str) -> Vec<u8> {
    format!("${body}*{:02X}\r\n", checksum(body.as_bytes())).into_bytes()
}

pub(super) fn fresh() -> Device {
    Device::new(&persist::load(&SimFlash::new()), "POR")
}

/// Run a command; check the reply is a valid sentence of at most 82 characters and return
/// its body.
fn run(d: &mut Device, f: &mut SimFlash, body: &str) -> (String, Option<Action>) {
    let r = d.execute(&cmd(body), f);
    let reply = r.reply.expect("a reply");
    (check(&reply), r.action)
}

fn check(s: &Sentence) -> String {
    assert!(s.len() <= 82, "{}", s.as_str());
    assert!(s.as_str().ends_with("\r\n"));
    verify(s.as_bytes()).expect("reply verifies").to_string()
}

/// Run a command that must fail, and check that it changed nothing.
fn refused(d: &mut Device, f: &mut SimFlash, line: &[u8]) -> String {
    let before = d.clone();
    let flash_before = f.clone();
    let r = d.execute(line, f);
    assert_eq!(*d, before, "{:?}", String::from_utf8_lossy(line));
    assert_eq!(*f, flash_before);
    assert!(r.action.is_none());
    let body = check(&r.reply.expect("a reply"));
    assert!(body.starts_with("PINAR,ERR,"), "{body}");
    body
}

fn counts(volts: f32) -> f32 {
    volts / 3.3 * 4095.0
}

/// An ADC mean with the gyros at `dps` (sensor axes) and the depth channel at `depth_v`.
fn adc(dps: [f32; 3], depth_v: f32) -> AdcMean {
    AdcMean {
        gyro_x: counts(1.5 + dps[0] * 3.33e-3),
        gyro_y: counts(1.5 + dps[1] * 3.33e-3),
        gyro_xy_ref: counts(1.5),
        gyro_z: counts(1.5 + dps[2] * 3.752e-3),
        gyro_z_ref: counts(1.5),
        depth: counts(depth_v),
        samples: 20,
        ..AdcMean::default()
    }
}

use crate::test_rng::TestRng as Noise;

fn inputs(dps: [f32; 3], accel_g: [f32; 3], n: &mut Noise) -> Inputs {
    Inputs {
        dt: 0.02,
        adc: Some(adc(
            [dps[0] + n.uniform(0.1), dps[1] + n.uniform(0.1), dps[2] + n.uniform(0.03)],
            0.5,
        )),
        accel_g: Some(accel_g.map(|a| a + n.uniform(0.001))),
        ..Inputs::default()
    }
}

fn cycle(d: &mut Device, i: &Inputs) -> CycleOutput {
    let sample = ImuSample::new(i.dt, Vec3::ZERO, Vec3::ZERO);
    d.on_cycle(i, &sample, Quaternion::IDENTITY)
}

#[test]
fn version_status_and_list() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    let (r, a) = run(&mut d, &mut f, "PINAC,VER");
    assert_eq!(r, format!("PINAR,OK,VER,inemo-ahrs,{},1,{}", VERSION, SETTINGS.len()));
    assert!(a.is_none());
    // Both pages invalid at boot: defaults, flagged.
    assert_eq!(run(&mut d, &mut f, "PINAC,STATUS").0, "PINAR,OK,STATUS,DEFAULTS,,POR,0001,00,R,,");
    assert_eq!(
        run(&mut d, &mut f, "PINAC,LIST,0").0,
        "PINAR,OK,LIST,0,68,noise.gyro_var,f32x3,(deg/s)2,1e-6,100"
    );
    assert_eq!(run(&mut d, &mut f, "PINAC,LIST,59").0, "PINAR,OK,LIST,59,68,output.prdid,bool,,,");
    for i in 0..SETTINGS.len() {
        assert!(run(&mut d, &mut f, &format!("PINAC,LIST,{i}")).0.starts_with("PINAR,OK,LIST,"));
    }
    assert_eq!(refused(&mut d, &mut f, &cmd("PINAC,LIST,68")), "PINAR,ERR,LIST,range,0,67");
    // Verbs are case-insensitive.
    assert!(run(&mut d, &mut f, "PINAC,ver").0.starts_with("PINAR,OK,VER,"));
    // A reset cause that cannot be sent is shown as `?`.
    let mut d = Device::new(&persist::load(&SimFlash::new()), "a,b");
    assert!(run(&mut d, &mut f, "PINAC,STATUS").0.contains(",?,"));
}

#[test]
fn status_and_selftest_report_the_board() {
    use crate::supervision::{fault_record::FaultKind, selftest};
    let mut d = Device::new(&persist::load(&SimFlash::new()), "IWDG");
    let mut f = SimFlash::new();
    // Nothing measured yet (the emulator): every measured field empty, the grade FAIL.
    let (r, a) = run(&mut d, &mut f, "PINAC,SELFTEST");
    assert!(r.starts_with("PINAR,OK,SELFTEST,FAIL,"), "{r}");
    assert!(a.is_none());
    assert_eq!(refused(&mut d, &mut f, &cmd("PINAC,SELFTEST,1")), "PINAR,ERR,SELFTEST,args");
    // The board reported a fault record at boot and a stack high-water mark.
    d.set_board(selftest::Inputs { fault: Some(FaultKind::HardFault), ..Default::default() });
    d.set_stack_used(2412);
    assert_eq!(
        run(&mut d, &mut f, "PINAC,STATUS").0,
        "PINAR,OK,STATUS,DEFAULTS,,IWDG,0001,00,R,HARDFAULT,2412"
    );
}

#[test]
fn get_and_set_every_setting() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    for s in &SETTINGS {
        let (r, _) = run(&mut d, &mut f, &format!("PINAC,GET,{}", s.name));
        let prefix = format!("PINAR,OK,GET,{},", s.name);
        assert!(r.starts_with(&prefix), "{r}");
        let value = &r[prefix.len()..];
        // Setting the value read changes nothing.
        let (r2, a) = run(&mut d, &mut f, &format!("PINAC,SET,{},{}", s.name, value));
        assert_eq!(r2, format!("PINAR,OK,SET,{},{}", s.name, value));
        assert!(
            a.is_none()
                || !matches!(
                    s.kind,
                    registry::Kind::Bool
                        | registry::Kind::U16
                        | registry::Kind::Axes
                        | registry::Kind::Talker
                ),
            "{}",
            s.name
        );
    }
    let (r, a) = run(&mut d, &mut f, "PINAC,SET,gate.norm_tolerance,0.1");
    assert_eq!(r, "PINAR,OK,SET,gate.norm_tolerance,0.1");
    assert_eq!(a, Some(Action::ApplySettings { filter_rate_changed: false }));
    assert_eq!(d.settings().filter.gate.norm_tolerance, 0.1);
    let (r, a) = run(&mut d, &mut f, "PINAC,SET,FILTER.RATE,100");
    assert_eq!(r, "PINAR,OK,SET,filter.rate,100");
    assert_eq!(a, Some(Action::ApplySettings { filter_rate_changed: true }));
    let (r, _) = run(&mut d, &mut f, "PINAC,SET,axes.gyro,y,-x,z");
    assert_eq!(r, "PINAR,OK,SET,axes.gyro,y,-x,z");
    let (r, _) = run(&mut d, &mut f, "PINAC,SET,ekf.yaw_drift_rate,16.2");
    assert_eq!(r, "PINAR,OK,SET,ekf.yaw_drift_rate,16.2");
    assert!((d.settings().filter.ekf.yaw_drift_rate - mathf::deg(16.2) / 3600.0).abs() < 1e-10);
    let (r, _) = run(&mut d, &mut f, "PINAC,SET,accel_cal.o,0.01,-0.02,1e-3");
    assert_eq!(r, "PINAR,OK,SET,accel_cal.o,0.01,-0.02,0.001");
    assert_eq!(run(&mut d, &mut f, "PINAC,STATUS").0, "PINAR,OK,STATUS,DEFAULTS,,POR,0003,00,R,,");
}

#[test]
fn every_error_names_the_problem_and_changes_nothing() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    let mut bad_sum = cmd("PINAC,SET,output.rate,5");
    let n = bad_sum.len();
    bad_sum[n - 3] = if bad_sum[n - 3] == b'0' { b'1' } else { b'0' };
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (bad_sum, "PINAR,ERR,?,checksum"),
        (b"$PINAC,SET,output.rate,5\r\n".to_vec(), "PINAR,ERR,?,format"),
        (b"$PINAC,SET,output.rate,5*G0".to_vec(), "PINAR,ERR,?,format"),
        // One line end only: a second is a byte after `*hh` (the fuzz target's page oracle).
        ([cmd("PINAC,VER"), b"\r".to_vec()].concat(), "PINAR,ERR,?,format"),
        (b"$PINAC,SET,output\x01rate,5*00".to_vec(), "PINAR,ERR,?,format"),
        (cmd(&format!("PINAC,SET,lever.r,{}", "1".repeat(70))), "PINAR,ERR,?,too-long"),
        (cmd("PINAC,FLY,1"), "PINAR,ERR,?,unknown-command"),
        (cmd("PINAC"), "PINAR,ERR,?,unknown-command"),
        (cmd("PINAC,"), "PINAR,ERR,?,unknown-command"),
        (cmd("PINAC,GET,no.such"), "PINAR,ERR,GET,unknown-setting"),
        (cmd("PINAC,SET,no.such,1"), "PINAR,ERR,SET,unknown-setting"),
        (cmd("PINAC,SET,output.rate,fast"), "PINAR,ERR,SET,type,u16"),
        (cmd("PINAC,SET,output.rate,5.5"), "PINAR,ERR,SET,type,u16"),
        (cmd("PINAC,SET,rest.enabled,yes"), "PINAR,ERR,SET,type,bool"),
        (cmd("PINAC,SET,mag.norm_tolerance,1e"), "PINAR,ERR,SET,type,f32"),
        (cmd("PINAC,SET,axes.mag,x,y,w"), "PINAR,ERR,SET,type,axes"),
        (cmd("PINAC,SET,output.rate,51"), "PINAR,ERR,SET,range,1,50"),
        (cmd("PINAC,SET,gate.norm_tolerance,-1"), "PINAR,ERR,SET,range,0.001,1"),
        (cmd("PINAC,SET,lever.r,0,0,11"), "PINAR,ERR,SET,range,-10,10"),
        (cmd("PINAC,SET,axes.mag,x,y,y"), "PINAR,ERR,SET,range"),
        (cmd("PINAC,SET,lever.r,1,2"), "PINAR,ERR,SET,args,3"),
        (cmd("PINAC,SET,output.rate"), "PINAR,ERR,SET,args"),
        (cmd("PINAC,SET"), "PINAR,ERR,SET,args"),
        (cmd("PINAC,GET"), "PINAR,ERR,GET,args"),
        (cmd("PINAC,GET,a,b"), "PINAR,ERR,GET,args"),
        (cmd("PINAC,SET,a,1,2,3,4,5,6,7"), "PINAR,ERR,SET,args"),
        (cmd("PINAC,VER,1"), "PINAR,ERR,VER,args"),
        (cmd("PINAC,YAW,400"), "PINAR,ERR,YAW,range,-360,360"),
        (cmd("PINAC,YAW,north"), "PINAR,ERR,YAW,type"),
        (cmd("PINAC,YAW0,181"), "PINAR,ERR,YAW0,range,-180,180"),
        (cmd("PINAC,RATE,0"), "PINAR,ERR,RATE,range,1,50"),
        (cmd("PINAC,SENT,1,2"), "PINAR,ERR,SENT,type,bool"),
        (cmd("PINAC,SENT,1"), "PINAR,ERR,SENT,args"),
        (cmd("PINAC,SENT,1,1,1"), "PINAR,ERR,SENT,args"),
        (cmd("PINAC,SENT,1,1,1,1,1,1,1,1"), "PINAR,ERR,SENT,args"),
        (cmd("PINAC,SENT,1,1,1,1,1,1,x"), "PINAR,ERR,SENT,type,bool"),
        (cmd("PINAC,SENT,GGA,1"), "PINAR,ERR,SENT,type"),
        (cmd("PINAC,SENT,HDT,2"), "PINAR,ERR,SENT,type,bool"),
        (cmd("PINAC,SENT,HDT"), "PINAR,ERR,SENT,args"),
        (cmd("PINAC,SENT,HDT,1,1"), "PINAR,ERR,SENT,args"),
        (cmd("PINAC,SET,output.talker,H"), "PINAR,ERR,SET,type,talker"),
        (cmd("PINAC,SET,output.talker,H1X"), "PINAR,ERR,SET,type,talker"),
        (cmd("PINAC,SET,output.talker,H-"), "PINAR,ERR,SET,type,talker"),
        (cmd("PINAC,RAW,3"), "PINAR,ERR,RAW,type"),
        (cmd("PINAC,RAW,-1"), "PINAR,ERR,RAW,type"),
        (cmd("PINAC,RAW,02"), "PINAR,ERR,RAW,type"),
        (cmd("PINAC,RAW"), "PINAR,ERR,RAW,args"),
        (cmd("PINAC,RAW,2,1"), "PINAR,ERR,RAW,args"),
        (cmd("PINAC,ZERO"), "PINAR,ERR,ZERO,no-depth"),
        (cmd("PINAC,GBIAS,0.5"), "PINAR,ERR,GBIAS,range,1,600"),
        (cmd("PINAC,GBIAS"), "PINAR,ERR,GBIAS,args"),
        (cmd("PINAC,ACAL,UP"), "PINAR,ERR,ACAL,type"),
        (cmd("PINAC,ACAL,XUP,100"), "PINAR,ERR,ACAL,range,0.5,60"),
        (cmd("PINAC,ACAL,CLEAR,1"), "PINAR,ERR,ACAL,args"),
        (cmd("PINAC,ACAL"), "PINAR,ERR,ACAL,args"),
        // The fit of X is the host's (`ahrs-tool calibrate`), not a device command.
        (cmd("PINAC,ACAL,FIT"), "PINAR,ERR,ACAL,type"),
        (cmd("PINAC,ABORT"), "PINAR,ERR,ABORT,not-running"),
        (cmd("PINAC,LOAD"), "PINAR,ERR,LOAD,no-record"),
        (cmd("PINAC,LIST,x"), "PINAR,ERR,LIST,type"),
    ];
    for (line, expect) in &cases {
        assert_eq!(refused(&mut d, &mut f, line), *expect, "{:?}", String::from_utf8_lossy(line));
    }
    // Busy: a second GBIAS / ACAL while one runs.
    run(&mut d, &mut f, "PINAC,GBIAS,5");
    assert_eq!(refused(&mut d, &mut f, &cmd("PINAC,GBIAS,5")), "PINAR,ERR,GBIAS,busy");
    run(&mut d, &mut f, "PINAC,ACAL,ZUP");
    assert_eq!(refused(&mut d, &mut f, &cmd("PINAC,ACAL,XUP")), "PINAR,ERR,ACAL,busy");
    assert_eq!(run(&mut d, &mut f, "PINAC,ABORT").0, "PINAR,OK,ABORT");
    // A failing flash: SAVE answers `flash` and the device state is unchanged.
    let mut broken = BrokenFlash;
    let before = d.clone();
    let r = d.execute(&cmd("PINAC,SAVE"), &mut broken);
    assert_eq!(check(&r.reply.unwrap()), "PINAR,ERR,SAVE,flash");
    assert_eq!(d, before);
    // Other talkers and our own replies are ignored without a reply.
    for line in [&b"$GPGGA,1*00"[..], b"$PINAR,OK,VER*00", b"$PINACX,VER*00", b"PINAC,VER", b""] {
        let r = d.execute(line, &mut f);
        assert!(r.reply.is_none() && r.action.is_none());
    }
    assert_eq!(
        d.handle(&LineEvent::TooLong, &mut f).reply.map(|s| check(&s)).unwrap(),
        "PINAR,ERR,?,too-long"
    );
}

/// A flash whose every write fails.
struct BrokenFlash;

impl Flash for BrokenFlash {
    fn page_size(&self) -> usize {
        2048
    }
    fn read(&self, _: Page, _: usize, buf: &mut [u8]) -> Result<(), FlashError> {
        buf.fill(0xFF);
        Ok(())
    }
    fn erase(&mut self, _: Page) -> Result<(), FlashError> {
        Err(FlashError::Erase)
    }
    fn program(&mut self, _: Page, _: usize, _: u16) -> Result<(), FlashError> {
        Err(FlashError::Program)
    }
}

#[test]
fn yaw_rate_sentences_and_raw_mode() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    let (r, a) = run(&mut d, &mut f, "PINAC,YAW,270");
    assert_eq!(r, "PINAR,OK,YAW,270");
    match a {
        Some(Action::SetYaw(y)) => assert!((y - mathf::deg(-90.0)).abs() < 1e-6),
        other => panic!("{other:?}"),
    }
    assert_eq!(*d.settings(), PipelineSettings::default());
    let (r, a) = run(&mut d, &mut f, "PINAC,YAW0,-45.5");
    assert_eq!(r, "PINAR,OK,YAW0,-45.5");
    assert!(a.is_some());
    assert!((d.settings().filter.init.initial_yaw - mathf::deg(-45.5)).abs() < 1e-6);
    assert_eq!(run(&mut d, &mut f, "PINAC,RATE,25").0, "PINAR,OK,RATE,25");
    assert_eq!(d.settings().output_rate_hz, 25);
    assert_eq!(run(&mut d, &mut f, "PINAC,SENT,0,1").0, "PINAR,OK,SENT,0,1");
    assert!(!d.settings().sentences.prdid && d.settings().sentences.pinah);
    // Seven flags in the order PRDID, PINAH, HDT, HDG, HDM, ROT, XDR; one by name.
    let (r, a) = run(&mut d, &mut f, "PINAC,SENT,1,0,1,0,1,0,1");
    assert_eq!(r, "PINAR,OK,SENT,1,0,1,0,1,0,1");
    assert!(a.is_some());
    let s = d.settings().sentences;
    assert_eq!(
        [s.prdid, s.pinah, s.hdt, s.hdg, s.hdm, s.rot, s.xdr],
        [true, false, true, false, true, false, true]
    );
    assert_eq!(run(&mut d, &mut f, "PINAC,SENT,rot,1").0, "PINAR,OK,SENT,ROT,1");
    assert!(d.settings().sentences.rot);
    assert_eq!(run(&mut d, &mut f, "PINAC,SENT,XDR,0").0, "PINAR,OK,SENT,XDR,0");
    assert!(!d.settings().sentences.xdr);
    let (r, a) = run(&mut d, &mut f, "PINAC,SENT,XDR,0");
    assert_eq!((r.as_str(), a), ("PINAR,OK,SENT,XDR,0", None));
    assert_eq!(
        run(&mut d, &mut f, "PINAC,SET,output.talker,ii").0,
        "PINAR,OK,SET,output.talker,II"
    );
    assert_eq!(d.settings().sentences.talker, crate::registry::talker_code(*b"II"));
    // The heading reference the application notes is in `STATUS`.
    d.set_heading_ref(crate::pipeline::HeadingRef::True);
    assert!(run(&mut d, &mut f, "PINAC,STATUS").0.ends_with(",T,,"));
    d.set_heading_ref(crate::pipeline::HeadingRef::Magnetic);
    assert!(run(&mut d, &mut f, "PINAC,STATUS").0.ends_with(",M,,"));
    // Raw mode: $PINAW every cycle, $PINAX when the depth (or magnetometer) was read.
    let mut n = Noise::new(1);
    let i = inputs([0.0; 3], [0.0, 0.0, 1.0], &mut n);
    assert!(cycle(&mut d, &i).raw_sentences().next().is_none());
    assert_eq!(run(&mut d, &mut f, "PINAC,RAW,1").0, "PINAR,OK,RAW,1");
    assert!(d.raw_mode());
    let p = Pipeline::new(*d.settings());
    let sample = p.conditioned_sample(&i);
    let out = d.on_cycle(&i, &sample, Quaternion::IDENTITY);
    let lines: Vec<String> = out.raw_sentences().map(check).collect();
    assert_eq!(lines.len(), 2);
    assert!(lines[0].starts_with("PINAW,0.0400,"), "{}", lines[0]);
    assert!(lines[1].starts_with("PINAX,0.0400,,,,"), "{}", lines[1]);
    // Without the ADC, no gyro or depth: empty gyro fields, no $PINAX.
    let i2 = Inputs { adc: None, ..i };
    let out = d.on_cycle(&i2, &p.conditioned_sample(&i2), Quaternion::IDENTITY);
    let lines: Vec<String> = out.raw_sentences().map(check).collect();
    assert_eq!(lines.len(), 1);
    assert!(lines[0].starts_with("PINAW,0.0600,,,,"), "{}", lines[0]);
    assert_eq!(run(&mut d, &mut f, "PINAC,RAW,0").0, "PINAR,OK,RAW,0");
}

/// Numbers on the command line: limits compared before any rounding, the forms the parser
/// takes and refuses, the 7-digit echo (issue #18 replaced the number code: these pin it).
#[test]
fn numbers_at_the_command_line() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    for (arg, echo) in [
        ("-360", "-360"),
        ("360.0", "360"),
        ("+.5", "0.5"),
        ("5.", "5"),
        ("1E2", "100"),
        ("12.3456789", "12.34568"),
        ("-0.000012345675", "-0.00001234568"),
        ("1e-7", "1e-7"),
        ("-0", "0"),
    ] {
        assert_eq!(
            run(&mut d, &mut f, &format!("PINAC,YAW,{arg}")).0,
            format!("PINAR,OK,YAW,{echo}")
        );
    }
    for arg in ["360.00001", "-360.0000001", "1e3"] {
        assert_eq!(
            refused(&mut d, &mut f, &cmd(&format!("PINAC,YAW,{arg}"))),
            "PINAR,ERR,YAW,range,-360,360"
        );
    }
    for arg in ["1.2.3", ".", "1e", "inf", "nan", "0x10", "1,5"] {
        let want = if arg == "1,5" { "PINAR,ERR,YAW,args" } else { "PINAR,ERR,YAW,type" };
        assert_eq!(refused(&mut d, &mut f, &cmd(&format!("PINAC,YAW,{arg}"))), want, "{arg}");
    }
    // A setting in other units than its internal ones: typed in degrees, kept in radians,
    // printed back in degrees.
    let (r, _) = run(&mut d, &mut f, "PINAC,SET,init.gyro_bias,0.1,-2.5e-3,12.345678");
    assert_eq!(r, "PINAR,OK,SET,init.gyro_bias,0.1,-0.0025,12.34568");
    let (r, _) = run(&mut d, &mut f, "PINAC,GET,init.gyro_bias");
    assert_eq!(r, "PINAR,OK,GET,init.gyro_bias,0.1,-0.0025,12.34568");
}

/// `RAW,2` (issue #14): the estimator restarts (an action for the application), the time
/// restarts, and every cycle sends `$PINAW`, `$PINAX`, then the `$PRDID` of the estimate from
/// that very sample, whatever its validity; so that a replay of the log from its first row runs
/// the device's estimator.
#[test]
fn raw_mode_2_restarts_the_estimator_and_sends_each_cycles_estimate() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    let mut n = Noise::new(7);
    let mut p = Pipeline::new(*d.settings());
    // Some time in raw mode 1 first: the clock runs, no $PRDID.
    assert_eq!(run(&mut d, &mut f, "PINAC,RAW,1").0, "PINAR,OK,RAW,1");
    for _ in 0..30 {
        let i = inputs([3.0, -2.0, 5.0], [0.1, 0.0, 0.99], &mut n);
        let sample = p.conditioned_sample(&i);
        let step = p.step(&i);
        let out = d.on_cycle(&i, &sample, step.attitude);
        assert!(out.raw_sentences().all(|s| !s.as_str().starts_with("$PRDID")));
    }
    assert_eq!(d.raw(), RawMode::Samples);

    // Refused forms change nothing (and request nothing).
    for bad in ["PINAC,RAW,3", "PINAC,RAW,2,0", "PINAC,RAW,two", "PINAC,RAW,"] {
        refused(&mut d, &mut f, &cmd(bad));
    }
    assert_eq!(d.raw(), RawMode::Samples);

    let (r, a) = run(&mut d, &mut f, "PINAC,RAW,2");
    assert_eq!(r, "PINAR,OK,RAW,2");
    assert_eq!(a, Some(Action::RestartEstimator));
    assert_eq!(d.raw(), RawMode::WithEstimate);
    assert!(d.raw_mode());
    assert_ne!(d.status_flags() & STATUS_RAW, 0, "STATUS bit 2: raw mode");
    // The application restarts the pipeline: from here it runs as a fresh one.
    p.restart();
    let mut fresh_pipeline = Pipeline::new(*d.settings());
    for k in 1..=600u32 {
        let i = inputs([3.0, -2.0, 5.0], [0.1, 0.0, 0.99], &mut n);
        let sample = p.conditioned_sample(&i);
        let step = p.step(&i);
        let twin = fresh_pipeline.step(&i);
        assert_eq!(step.attitude, twin.attitude, "cycle {k}: the restart is not a power-up");
        let out = d.on_cycle(&i, &sample, step.attitude);
        let lines: Vec<String> = out.raw_sentences().map(check).collect();
        assert_eq!(lines.len(), 3, "{lines:?}");
        // The time restarted with the estimator: the first row is one cycle after it.
        let t = format!("{}.{:04}", k / 50, (k % 50) * 200);
        assert!(lines[0].starts_with(&format!("PINAW,{t},")), "{k}: {}", lines[0]);
        assert!(lines[1].starts_with(&format!("PINAX,{t},")), "{k}: {}", lines[1]);
        let prdid = crate::nmea::prdid(&Euler::from_quaternion(step.attitude)).unwrap();
        assert_eq!(lines[2], check(&prdid), "cycle {k}");
        // During the initialisation window too (the estimate is sent whatever its validity).
        if k == 1 {
            assert!(!p.ekf().is_initialised());
        }
    }
    assert!(p.ekf().is_initialised(), "the window ended");
    // RAW,1: no more $PRDID; RAW,0: nothing raw.
    assert_eq!(run(&mut d, &mut f, "PINAC,RAW,1"), ("PINAR,OK,RAW,1".into(), None));
    let i = inputs([0.0; 3], [0.0, 0.0, 1.0], &mut n);
    assert_eq!(
        d.on_cycle(&i, &p.conditioned_sample(&i), Quaternion::IDENTITY).raw_sentences().count(),
        2
    );
    assert_eq!(run(&mut d, &mut f, "PINAC,RAW,0").0, "PINAR,OK,RAW,0");
    assert_eq!(d.status_flags() & STATUS_RAW, 0);
    assert_eq!(cycle(&mut d, &i).raw_sentences().count(), 0);
}

#[test]
fn zero_depth_uses_the_latest_reading() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    let mut i = Inputs { dt: 0.02, adc: Some(adc([0.0; 3], 0.01)), ..Inputs::default() };
    cycle(&mut d, &i);
    let expect = d.settings().depth.pressure_pa(counts(0.01) * 3.3 / 4095.0);
    let (r, a) = run(&mut d, &mut f, "PINAC,ZERO");
    assert!(r.starts_with("PINAR,OK,ZERO,"), "{r}");
    assert!(a.is_some());
    assert!((d.settings().depth.surface_pressure_pa - expect).abs() < 1.0);
    // The pipeline now reads zero depth at that pressure.
    let mut p = Pipeline::new(PipelineSettings::default());
    p.apply_settings(*d.settings());
    assert!(p.step(&i).depth_m.unwrap().abs() < 1e-3);
    // A reading older than a second is not used.
    i.adc = None;
    for _ in 0..51 {
        cycle(&mut d, &i);
    }
    assert_eq!(refused(&mut d, &mut f, &cmd("PINAC,ZERO")), "PINAR,ERR,ZERO,no-depth");
    // A reading at a rail is not kept.
    let mut railed = adc([0.0; 3], 0.0);
    railed.rails = crate::adc::Rails::DEPTH;
    cycle(&mut d, &Inputs { dt: 0.02, adc: Some(railed), ..Inputs::default() });
    assert_eq!(refused(&mut d, &mut f, &cmd("PINAC,ZERO")), "PINAR,ERR,ZERO,no-depth");
    // Nor does it replace the latest good one: a valid reading, then one at the rail (whose
    // depth is a finite number all the same), and ZERO takes the valid one.
    let good = adc([0.0; 3], 0.02);
    cycle(&mut d, &Inputs { dt: 0.02, adc: Some(good), ..Inputs::default() });
    cycle(&mut d, &Inputs { dt: 0.02, adc: Some(railed), ..Inputs::default() });
    let (r, _) = run(&mut d, &mut f, "PINAC,ZERO");
    assert!(r.starts_with("PINAR,OK,ZERO,"), "{r}");
    let expect = d.settings().depth.pressure_pa(counts(0.02) * 3.3 / 4095.0);
    assert!((d.settings().depth.surface_pressure_pa - expect).abs() < 1.0);
}

#[test]
fn gyro_bias_calibration_sets_the_offset_or_detects_motion() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    let mut n = Noise::new(7);
    assert_eq!(run(&mut d, &mut f, "PINAC,GBIAS,2").0, "PINAR,OK,GBIAS,RUN,2");
    assert_eq!(d.status_flags() & STATUS_GBIAS, STATUS_GBIAS);
    let bias = [1.0, -2.0, 0.5];
    let mut done = None;
    for k in 0..200 {
        let out = cycle(&mut d, &inputs(bias, [0.0, 0.0, 1.0], &mut n));
        if let Some(r) = out.reply {
            done = Some((k, check(&r), out.action));
            break;
        }
    }
    let (k, r, a) = done.expect("GBIAS finished");
    assert_eq!(k, 99, "2 s at 50 Hz");
    assert!(r.starts_with("PINAR,OK,GBIAS,DONE,"), "{r}");
    assert_eq!(a, Some(Action::ApplySettings { filter_rate_changed: false }));
    // Body = (x, y, −z) of the sensor axes with the board's gyro map.
    let off = d.settings().conditioning.gyro_offset;
    let want = Vec3::new(mathf::deg(1.0), mathf::deg(-2.0), mathf::deg(-0.5));
    assert!((off - want).max_abs() < mathf::deg(0.03), "{off:?}");
    assert_eq!(d.status_flags() & STATUS_GBIAS, 0);

    // Motion during the calibration: a turn starts after 1 s.
    assert!(run(&mut d, &mut f, "PINAC,GBIAS,3").0.starts_with("PINAR,OK,GBIAS,RUN"));
    let before = *d.settings();
    let mut reply = None;
    for k in 0..200 {
        let rate = if k < 50 { bias } else { [1.0, -2.0, 10.0] };
        if let Some(r) = cycle(&mut d, &inputs(rate, [0.0, 0.0, 1.0], &mut n)).reply {
            reply = Some((k, check(&r)));
            break;
        }
    }
    assert_eq!(reply, Some((50, "PINAR,ERR,GBIAS,motion".to_string())));
    assert_eq!(*d.settings(), before);

    // A slowly shaking accelerometer fails the final check.
    run(&mut d, &mut f, "PINAC,GBIAS,1");
    let mut reply = None;
    for k in 0..100 {
        let tilt = 0.06 * ((k % 10) as f32 / 10.0);
        if let Some(r) = cycle(&mut d, &inputs(bias, [tilt, 0.0, 1.0], &mut n)).reply {
            reply = Some(check(&r));
            break;
        }
    }
    assert_eq!(reply.as_deref(), Some("PINAR,ERR,GBIAS,motion"));

    // No gyro at all: `sensor`.
    run(&mut d, &mut f, "PINAC,GBIAS,1");
    let mut reply = None;
    for _ in 0..100 {
        let i = Inputs { dt: 0.02, adc: None, accel_g: Some([0.0, 0.0, 1.0]), ..Inputs::default() };
        if let Some(r) = cycle(&mut d, &i).reply {
            reply = Some(check(&r));
            break;
        }
    }
    assert_eq!(reply.as_deref(), Some("PINAR,ERR,GBIAS,sensor"));
}

#[test]
fn six_position_accelerometer_calibration() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    let mut n = Noise::new(3);
    let mut fit = ekf_core::accel_calibration::SixPositionFit::new();
    // The sensor reads 2 % high with an offset.
    let offset = [0.01, -0.02, 0.03];
    let raw_of = |r: [f32; 3]| [0, 1, 2].map(|i| r[i] * 1.02 + offset[i]);
    for (k, name) in POSITION_NAMES.iter().enumerate() {
        let pos = position_by_name(name).unwrap();
        let (r, _) = run(&mut d, &mut f, &format!("PINAC,ACAL,{name}"));
        assert_eq!(r, format!("PINAR,OK,ACAL,RUN,{name},2"));
        let mut reply = None;
        for _ in 0..150 {
            let i = inputs([0.0; 3], raw_of(pos.reference_g().to_array()), &mut n);
            if let Some(r) = cycle(&mut d, &i).reply {
                reply = Some(check(&r));
                break;
            }
        }
        let reply = reply.expect("position done");
        assert!(reply.starts_with(&format!("PINAR,OK,ACAL,DONE,{name},")), "{reply}");
        assert!(reply.ends_with(&format!(",{}", k + 1)), "{reply}");
        // OK,ACAL,DONE,<pos>,<ax>,<ay>,<az>,<count>: the mean the sensor read there.
        let mean: Vec<f32> = reply.split(',').skip(5).take(3).map(|v| v.parse().unwrap()).collect();
        let truth = raw_of(pos.reference_g().to_array());
        for (m, t) in mean.iter().zip(truth) {
            assert!((m - t).abs() < 2e-3, "{name}: {mean:?} vs {truth:?}");
        }
        fit.add_position(pos, Vec3::new(mean[0], mean[1], mean[2]));
    }
    assert_eq!(run(&mut d, &mut f, "PINAC,STATUS").0, "PINAR,OK,STATUS,DEFAULTS,,POR,0001,3F,R,,");
    // A position measured again is still one of six.
    run(&mut d, &mut f, "PINAC,ACAL,ZUP");
    let reply = (0..150)
        .find_map(|_| cycle(&mut d, &inputs([0.0; 3], raw_of([0.0, 0.0, 1.0]), &mut n)).reply)
        .map(|r| check(&r));
    assert!(reply.as_deref().is_some_and(|r| r.ends_with(",6")), "{reply:?}");
    assert_eq!(run(&mut d, &mut f, "PINAC,STATUS").0, "PINAR,OK,STATUS,DEFAULTS,,POR,0001,3F,R,,");
    // The host fits X from the six means and sets it row by row.
    let cal = fit.solve().unwrap();
    for (row, name) in cal.x.iter().zip(["x", "y", "z", "o"]) {
        let line = format!("PINAC,SET,accel_cal.{name},{:e},{:e},{:e}", row[0], row[1], row[2]);
        assert!(run(&mut d, &mut f, &line).0.starts_with("PINAR,OK,SET,"));
    }
    let cal = d.settings().conditioning.accel_calibration;
    for pos in ekf_core::accel_calibration::Position::ALL {
        let raw = Vec3::from_array(raw_of(pos.reference_g().to_array()));
        assert!((cal.apply_g(raw) - pos.reference_g()).max_abs() < 2e-3);
    }
    // Wrong orientation: asked for XUP, lying Z up.
    run(&mut d, &mut f, "PINAC,ACAL,XUP,1");
    let mut reply = None;
    for _ in 0..100 {
        if let Some(r) = cycle(&mut d, &inputs([0.0; 3], [0.0, 0.0, 1.0], &mut n)).reply {
            reply = Some(check(&r));
            break;
        }
    }
    assert_eq!(reply.as_deref(), Some("PINAR,ERR,ACAL,position"));
    assert_eq!(run(&mut d, &mut f, "PINAC,ACAL,CLEAR").0, "PINAR,OK,ACAL,CLEAR");
    assert_eq!(run(&mut d, &mut f, "PINAC,STATUS").0, "PINAR,OK,STATUS,DEFAULTS,,POR,0003,00,R,,");
}

#[test]
fn save_load_reset_and_status() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    run(&mut d, &mut f, "PINAC,SET,depth.density,998");
    assert_eq!(run(&mut d, &mut f, "PINAC,SAVE").0, "PINAR,OK,SAVE,A,1");
    assert_eq!(run(&mut d, &mut f, "PINAC,STATUS").0, "PINAR,OK,STATUS,A,1,POR,0001,00,R,,");
    run(&mut d, &mut f, "PINAC,SET,depth.density,1000");
    assert_eq!(run(&mut d, &mut f, "PINAC,SAVE").0, "PINAR,OK,SAVE,B,2");
    let (r, a) = run(&mut d, &mut f, "PINAC,RESET");
    assert_eq!(r, "PINAR,OK,RESET");
    assert!(a.is_some());
    assert_eq!(*d.settings(), PipelineSettings::default());
    assert_eq!(run(&mut d, &mut f, "PINAC,STATUS").0, "PINAR,OK,STATUS,DEFAULTS,,POR,0003,00,R,,");
    let (r, a) = run(&mut d, &mut f, "PINAC,LOAD");
    assert_eq!(r, "PINAR,OK,LOAD,B,2,0,0");
    assert!(a.is_some());
    assert_eq!(d.settings().depth.water_density_kg_m3, 1000.0);
    assert_eq!(run(&mut d, &mut f, "PINAC,STATUS").0, "PINAR,OK,STATUS,B,2,POR,0000,00,R,,");
    // A reboot finds the same.
    let d2 = Device::new(&persist::load(&f), "WDG");
    assert_eq!(d2.settings(), d.settings());
    assert_eq!(d2.source(), Source::Flash { page: Page::B, seq: 2 });
}

#[test]
fn the_pipeline_follows_the_settings_and_keeps_its_attitude() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    let mut s = *d.settings();
    s.filter.init.window_s = 0.2;
    let mut p = Pipeline::new(s);
    let mut n = Noise::new(9);
    for _ in 0..50 {
        p.step(&inputs([0.0; 3], [0.0, 0.0, 1.0], &mut n));
    }
    p.ekf_mut().set_yaw(mathf::deg(30.0));
    let before = Euler::from_quaternion(p.ekf().attitude());
    // GBIAS with the board's true bias of 0.5 °/s on the sensor's x.
    run(&mut d, &mut f, "PINAC,GBIAS,1");
    let mut action = None;
    for _ in 0..60 {
        let i = inputs([0.5, 0.0, 0.0], [0.0, 0.0, 1.0], &mut n);
        let sample = p.conditioned_sample(&i);
        let out = d.on_cycle(&i, &sample, Quaternion::IDENTITY);
        p.step(&i);
        if out.action.is_some() {
            action = out.action;
            break;
        }
    }
    assert!(matches!(action, Some(Action::ApplySettings { .. })));
    let bias_before = p.ekf().gyro_bias();
    let mut applied = *d.settings();
    applied.filter.init.window_s = 0.2;
    p.apply_settings(applied);
    let after = Euler::from_quaternion(p.ekf().attitude());
    assert!((after.yaw - before.yaw).abs() < mathf::deg(0.5), "{} {}", before.yaw, after.yaw);
    assert!(p.ekf().is_initialised());
    // The corrected rate is unchanged: the estimator's bias moved by the offset.
    let shift = applied.conditioning.gyro_offset;
    assert!(((bias_before - shift) - p.ekf().gyro_bias()).max_abs() < 1e-6);
    // The raw sample is exactly what the step feeds the estimator: conditioned, body FRD.
    let i = inputs([0.5, 0.0, 0.0], [0.0, 0.0, 1.0], &mut n);
    let sample = p.conditioned_sample(&i);
    assert!(sample.gyro.max_abs() < mathf::deg(0.2), "{:?}", sample.gyro);
    assert!((sample.accel.z + ekf_core::GRAVITY).abs() < 0.05);
    // Output-only changes leave the estimator alone.
    let q = p.ekf().attitude();
    let mut out_only = *p.settings();
    out_only.output_rate_hz = 1;
    p.apply_settings(out_only);
    assert_eq!(p.ekf().attitude(), q);
}

#[test]
fn docs_describe_every_verb_and_reason() {
    let doc = include_str!("../../docs/commands.md");
    for v in verb_names() {
        assert!(doc.contains(&format!("`{v}")), "verb {v} not in docs/commands.md");
    }
    for r in Reason::ALL {
        assert!(doc.contains(&format!("`{}`", r.as_str())), "reason {} not in docs", r.as_str());
    }
    assert!(doc.contains(&format!("{}", super::fuzz::FUZZ_INPUTS)), "fuzz count not in docs");
    // Every example sentence in the documentation carries its correct checksum.
    let mut examples = 0;
    for line in doc.lines().filter_map(|l| l.strip_prefix("> ").or_else(|| l.strip_prefix("< "))) {
        assert!(verify(line.as_bytes()).is_ok(), "{line}");
        examples += 1;
    }
    assert!(examples > 40, "{examples}");
}

/// Prints the example exchanges of `docs/commands.md`:
/// `cargo test -p inemo-ahrs --lib print_examples -- --ignored --nocapture`.
#[test]
#[ignore]
fn print_examples() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    let mut n = Noise::new(5);
    let show = |d: &mut Device, f: &mut SimFlash, body: &str| {
        let line = cmd(body);
        let r = d.execute(&line, f);
        println!("> {}", String::from_utf8_lossy(&line).trim_end());
        println!("< {}", r.reply.unwrap().as_str().trim_end());
    };
    for c in [
        "PINAC,VER",
        "PINAC,STATUS",
        "PINAC,LIST,0",
        "PINAC,GET,gate.norm_tolerance",
        "PINAC,SET,gate.norm_tolerance,0.08",
        "PINAC,SET,axes.gyro,x,y,-z",
        "PINAC,SET,ekf.yaw_drift_rate,16.2",
        "PINAC,SET,accel_cal.o,0.01,-0.02,0.03",
        "PINAC,GET,noise.gyro_var",
        "PINAC,SET,output.rate,60",
        "PINAC,SET,mag.norm_tolerance,abc",
        "PINAC,SET,lever.r,1,2",
        "PINAC,GET,nope",
        "PINAC,FLY",
        "PINAC,YAW,90",
        "PINAC,YAW0,-30",
        "PINAC,RATE,5",
        "PINAC,SENT,1,0",
        "PINAC,SENT,1,1,1,0,0,1,1",
        "PINAC,SENT,HDT,0",
        "PINAC,SET,output.talker,II",
        "PINAC,RAW,1",
        "PINAC,RAW,2",
        "PINAC,RAW,3",
        "PINAC,RAW,0",
        "PINAC,ZERO",
    ] {
        show(&mut d, &mut f, c);
    }
    cycle(&mut d, &Inputs { dt: 0.02, adc: Some(adc([0.0; 3], 0.1)), ..Inputs::default() });
    show(&mut d, &mut f, "PINAC,ZERO");
    show(&mut d, &mut f, "PINAC,GBIAS,2");
    for _ in 0..200 {
        if let Some(r) = cycle(&mut d, &inputs([1.62, 3.44, 0.0], [0.0, 0.0, 1.0], &mut n)).reply {
            println!("< {}", r.as_str().trim_end());
            break;
        }
    }
    show(&mut d, &mut f, "PINAC,GBIAS,2");
    for k in 0..200 {
        let rate = if k < 60 { [0.0; 3] } else { [20.0, 0.0, 0.0] };
        if let Some(r) = cycle(&mut d, &inputs(rate, [0.0, 0.0, 1.0], &mut n)).reply {
            println!("< {}", r.as_str().trim_end());
            break;
        }
    }
    show(&mut d, &mut f, "PINAC,ACAL,ZUP");
    for _ in 0..200 {
        if let Some(r) = cycle(&mut d, &inputs([0.0; 3], [0.01, -0.02, 1.03], &mut n)).reply {
            println!("< {}", r.as_str().trim_end());
            break;
        }
    }
    for c in [
        "PINAC,ACAL,CLEAR",
        "PINAC,ABORT",
        "PINAC,SAVE",
        "PINAC,SAVE",
        "PINAC,RESET",
        "PINAC,STATUS",
        "PINAC,LOAD",
        "PINAC,STATUS",
    ] {
        show(&mut d, &mut f, c);
    }
    let i = inputs([0.2, -0.1, 0.05], [0.0, 0.0, 1.0], &mut n);
    d.execute(&cmd("PINAC,RAW,1"), &mut f);
    let p = Pipeline::new(*d.settings());
    let mut i = i;
    i.mag_ut = Some([20.0, -3.0, 45.0]);
    for s in d.on_cycle(&i, &p.conditioned_sample(&i), Quaternion::IDENTITY).raw_sentences() {
        println!("< {}", s.as_str().trim_end());
    }
}

/// `STATUS`'s flags field, 4 hex digits, against the bit positions `docs/commands.md`
/// documents (bit 0 no valid record, 1 unsaved, 2 raw, 3 `GBIAS`, 4 `ACAL`, 5 skipped
/// entries, 6 missing settings): the literal values, not the constants.
#[test]
fn status_flags_sit_at_their_documented_bits() {
    let flags = |d: &mut Device, f: &mut SimFlash| -> String {
        let (r, _) = run(d, f, "PINAC,STATUS");
        r.split(',').nth(6).expect("flags field").to_string()
    };
    let mut f = SimFlash::new();
    let mut d = fresh();
    assert_eq!(flags(&mut d, &mut f), "0001", "boot without a record");
    run(&mut d, &mut f, "PINAC,SET,mag.norm_tolerance,0.3");
    assert_eq!(flags(&mut d, &mut f), "0003", "a setting changed");
    run(&mut d, &mut f, "PINAC,SAVE");
    assert_eq!(flags(&mut d, &mut f), "0001", "saved; bit 0 tells of the last load");
    run(&mut d, &mut f, "PINAC,LOAD");
    assert_eq!(flags(&mut d, &mut f), "0000", "loaded a record, nothing unsaved");
    run(&mut d, &mut f, "PINAC,RAW,1");
    assert_eq!(flags(&mut d, &mut f), "0004");
    run(&mut d, &mut f, "PINAC,RAW,0");
    run(&mut d, &mut f, "PINAC,GBIAS,10");
    assert_eq!(flags(&mut d, &mut f), "0008");
    run(&mut d, &mut f, "PINAC,ABORT");
    run(&mut d, &mut f, "PINAC,ACAL,ZUP");
    assert_eq!(flags(&mut d, &mut f), "0010");
    run(&mut d, &mut f, "PINAC,ABORT");
    assert_eq!(flags(&mut d, &mut f), "0000");
    // A record with skipped entries and missing settings (as `LOAD` reports them).
    let loaded = persist::Loaded { skipped: 2, missing: 0, ..persist::load(&f) };
    assert_eq!(flags(&mut Device::new(&loaded, "POR"), &mut f), "0020");
    let loaded = persist::Loaded { skipped: 0, missing: 3, ..persist::load(&f) };
    assert_eq!(flags(&mut Device::new(&loaded, "POR"), &mut f), "0040");
    // Raw mode 2 is raw mode too.
    run(&mut d, &mut f, "PINAC,RAW,2");
    assert_eq!(flags(&mut d, &mut f), "0004");
    assert!(d.raw_mode());
    run(&mut d, &mut f, "PINAC,RAW,0");
    assert!(!d.raw_mode());
}

/// A gyro at its rail (saturated) is no bias sample: `GBIAS` over such frames ends with
/// `sensor`, not with the rail's value as the offset.
#[test]
fn gyro_bias_calibration_skips_a_saturated_gyro() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    run(&mut d, &mut f, "PINAC,GBIAS,1");
    let before = *d.settings();
    let mut railed = adc([1.0, -2.0, 0.5], 0.5);
    railed.rails = crate::adc::Rails::GYRO_X;
    let mut reply = None;
    for _ in 0..100 {
        let i = Inputs {
            dt: 0.02,
            adc: Some(railed),
            accel_g: Some([0.0, 0.0, 1.0]),
            ..Inputs::default()
        };
        if let Some(r) = cycle(&mut d, &i).reply {
            reply = Some(check(&r));
            break;
        }
    }
    assert_eq!(reply.as_deref(), Some("PINAR,ERR,GBIAS,sensor"));
    assert_eq!(*d.settings(), before);
}

/// The raw clock (`$PINAW`'s `t`) counts only positive, finite cycle times.
#[test]
fn the_raw_clock_skips_a_bad_cycle_time() {
    let mut d = fresh();
    let mut f = SimFlash::new();
    let mut n = Noise::new(3);
    run(&mut d, &mut f, "PINAC,RAW,1");
    let p = Pipeline::new(*d.settings());
    let mut last = String::new();
    for dt in [0.02, f32::INFINITY, -0.5, f32::NAN, 0.02] {
        let i = Inputs { dt, ..inputs([0.0; 3], [0.0, 0.0, 1.0], &mut n) };
        let out = d.on_cycle(&i, &p.conditioned_sample(&i), Quaternion::IDENTITY);
        last = out.raw_sentences().map(check).next().expect("a $PINAW");
    }
    assert!(last.starts_with("PINAW,0.0400,"), "{last}");
}
