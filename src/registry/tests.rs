use super::*;
use ekf_core::mathf;

fn text(setting: &Setting, v: &Value) -> String {
    let mut s = Sentence::new();
    setting.write_value(v, &mut s).unwrap();
    s.body().to_string()
}

#[test]
fn ids_and_names_are_unique_and_wire_safe() {
    for (i, a) in SETTINGS.iter().enumerate() {
        assert!(!a.name.is_empty() && a.name.len() <= 24, "{}", a.name);
        assert!(
            a.name
                .bytes()
                .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'.' || b == b'_'),
            "{}",
            a.name
        );
        assert!(a.unit().is_ascii() && !a.unit().contains('|'));
        for b in SETTINGS.iter().skip(i + 1) {
            assert_ne!(a.id, b.id, "{} / {}", a.name, b.name);
            assert!(!a.name.eq_ignore_ascii_case(b.name));
        }
        assert_eq!(find(a.name).map(|s| s.id), Some(a.id));
        assert_eq!(find(&a.name.to_ascii_uppercase()).map(|s| s.id), Some(a.id));
        assert_eq!(by_id(a.id).map(|s| s.name), Some(a.name));
        assert!(a.min <= a.max);
        assert!(a.scale.factor() > 0.0);
    }
    assert!(find("no.such").is_none());
}

#[test]
fn defaults_are_valid_and_survive_encode_decode_and_text() {
    let d = PipelineSettings::default();
    for s in &SETTINGS {
        let v = s.get(&d);
        // A talker's code is a `u16`.
        let kind = if s.kind == Kind::Talker { Kind::U16 } else { s.kind };
        assert_eq!(v.kind(), kind, "{}", s.name);
        assert!(s.check(&v), "{} default {:?} out of range", s.name, v);
        let mut buf = [0u8; 16];
        let n = s.encode(&v, &mut buf);
        assert!(n > 0);
        assert_eq!(s.decode(&buf[..n]), Some(v), "{}", s.name);
        // Printed and parsed back: the same text again, and the value within 1e-6.
        let t = text(s, &v);
        let fields: Vec<&str> = t.split(',').collect();
        let back = s.parse(&fields).unwrap_or_else(|e| panic!("{} {t}: {e:?}", s.name));
        assert_eq!(text(s, &back), t, "{}", s.name);
        let mut e = d;
        assert!(s.set(&mut e, back));
        if let (Value::F32(a), Value::F32(b)) = (v, back) {
            assert!((a - b).abs() <= 1e-6 * a.abs().max(1e-30), "{} {a} {b}", s.name);
        }
    }
}

#[test]
fn every_setting_is_independent_of_the_others() {
    // Setting one entry to a non-default value changes that entry only.
    let d = PipelineSettings::default();
    for s in &SETTINGS {
        let v = match s.get(&d) {
            // The largest value, or the smallest where the default is the largest
            // (`gate.norm_tolerance`).
            Value::F32(x) => {
                let max = (f64::from(s.max) / s.scale.factor()) as f32;
                Value::F32(if x == max {
                    (f64::from(s.min) / s.scale.factor()) as f32
                } else {
                    max
                })
            }
            Value::Vec3(_) => Value::Vec3([(f64::from(s.min) / s.scale.factor()) as f32; 3]),
            Value::Bool(b) => Value::Bool(!b),
            Value::U16(_) if s.kind == Kind::Talker => Value::U16(super::talker_code(*b"II")),
            Value::U16(_) => Value::U16(s.max as u16),
            Value::Axes(m) => {
                Value::Axes(m.inverse().compose(&AxisMap::new([2, 0, 1], [-1, 1, 1]).unwrap()))
            }
        };
        let mut e = d;
        assert!(s.set(&mut e, v), "{}", s.name);
        assert_eq!(s.get(&e), v, "{}", s.name);
        assert_ne!(e, d, "{} did not change anything", s.name);
        for o in SETTINGS.iter().filter(|o| o.id != s.id) {
            // adc.vref also sets the gyro conversion's copy of the reference.
            assert_eq!(o.get(&e), o.get(&d), "{} changed {}", s.name, o.name);
        }
    }
}

#[test]
fn user_units_are_converted() {
    let mut d = PipelineSettings::default();
    let yaw = find("init.yaw0").unwrap();
    assert!(yaw.set(&mut d, yaw.parse(&["90"]).unwrap()));
    assert!((d.filter.init.initial_yaw - mathf::deg(90.0)).abs() < 1e-7);
    let drift = find("ekf.yaw_drift_rate").unwrap();
    assert!(drift.set(&mut d, drift.parse(&["16.2"]).unwrap()));
    assert!((d.filter.ekf.yaw_drift_rate - mathf::deg(16.2) / 3600.0).abs() < 1e-10);
    assert_eq!(text(drift, &drift.get(&d)), "16.2");
    let sens = find("gyro.sensitivity").unwrap();
    assert_eq!(text(sens, &sens.get(&PipelineSettings::default())), "3.33,3.33,3.752");
    let var = find("noise.gyro_var").unwrap();
    assert_eq!(text(var, &var.get(&PipelineSettings::default())), "0.337,0.275,0.00419");
    let rw = find("ekf.bias_random_walk").unwrap();
    assert_eq!(text(rw, &rw.get(&PipelineSettings::default())), "4e-6");
    let vref = find("adc.vref").unwrap();
    assert!(vref.set(&mut d, Value::F32(3.0)));
    assert_eq!((d.adc.vref_v, d.gyro.scale.vref_v), (3.0, 3.0));
    let axes = find("axes.accel").unwrap();
    assert_eq!(text(axes, &axes.get(&PipelineSettings::default())), "x,-y,-z");
    let v = axes.parse(&["-Y", "+x", "z"]).unwrap();
    assert_eq!(text(axes, &v), "-y,x,z");
}

/// `adc.vrefint` (issue #27): set from text, read back, bounded by the datasheet's 1.16–1.26 V
/// (DS5792), and used by both conversions. A part whose VREFINT is 1.23 V, at VDDA 3.3 V,
/// turning at 90 °/s about x: the ADC sees VREFINT at 1.23 / 3.3 · 4095 counts and the LPR430AL
/// output 90 · 3.33 mV above its reference. With the nominal 1.20 V the rate reads
/// 90 · 1.20 / 1.23 = 87.80 °/s and a 1.000 V depth signal 0.9756 V; with `adc.vrefint` 1.23
/// both read true.
#[test]
fn adc_vrefint_round_trips_and_scales_gyro_and_depth() {
    use crate::adc::AdcMean;
    let e = find("adc.vrefint").unwrap();
    let d = PipelineSettings::default();
    assert_eq!(e.get(&d), Value::F32(1.20));
    assert_eq!(e.parse(&["1.15"]), Err(ValueError::Range));
    assert_eq!(e.parse(&["1.27"]), Err(ValueError::Range));
    let mut s = d;
    assert!(e.set(&mut s, e.parse(&["1.23"]).unwrap()));
    assert_eq!(text(e, &e.get(&s)), "1.23");
    assert_eq!((s.adc.vrefint_v, s.gyro.scale.vrefint_v), (1.23, 1.23));

    let c = |v: f32| v / 3.3 * 4095.0;
    let mean = AdcMean {
        gyro_x: c(1.23 + 90.0 * 0.00333),
        gyro_y: c(1.23),
        gyro_xy_ref: c(1.23),
        gyro_z: c(1.5),
        gyro_z_ref: c(1.5),
        depth: c(1.0),
        vrefint: c(1.23),
        samples: 1,
        ..AdcMean::default()
    };
    let dps = |st: &PipelineSettings| st.gyro.rates(&mean).rate[0] / mathf::deg(1.0);
    assert!((dps(&s) - 90.0).abs() < 1e-3, "{}", dps(&s));
    assert!((dps(&d) - 87.805).abs() < 1e-3, "{}", dps(&d));
    let volts = |st: &PipelineSettings| st.depth.reading(&mean, &st.adc).volts;
    assert!((volts(&s) - 1.0).abs() < 1e-5, "{}", volts(&s));
    assert!((volts(&d) - 0.975_61).abs() < 1e-5, "{}", volts(&d));
}

/// `i2c.clock` (issue #27): kHz, 100–400, default 300 (ST's `LSM_I2C_Speed` for this board).
#[test]
fn i2c_clock_round_trips_within_100_to_400_khz() {
    let e = find("i2c.clock").unwrap();
    let d = PipelineSettings::default();
    assert_eq!(e.get(&d), Value::U16(300));
    assert_eq!(d.i2c_clock_khz, 300);
    assert_eq!(e.parse(&["99"]), Err(ValueError::Range));
    assert_eq!(e.parse(&["401"]), Err(ValueError::Range));
    let mut s = d;
    assert!(e.set(&mut s, e.parse(&["400"]).unwrap()));
    assert_eq!((s.i2c_clock_khz, text(e, &e.get(&s)).as_str()), (400, "400"));
    assert!(e.set(&mut s, e.parse(&["100"]).unwrap()));
    assert_eq!(s.i2c_clock_khz, 100);
    // Not a setting of the filter or the conditioning: a `SET` rebuilds neither.
    assert_eq!(e.part(), Part::Other);
}

#[test]
fn bad_values_are_refused_with_the_right_reason() {
    let f = find("gate.norm_tolerance").unwrap();
    assert_eq!(f.parse(&[]), Err(ValueError::Args));
    assert_eq!(f.parse(&["0.1", "0.2"]), Err(ValueError::Args));
    assert_eq!(f.parse(&["abc"]), Err(ValueError::Type));
    assert_eq!(f.parse(&["nan"]), Err(ValueError::Type));
    assert_eq!(f.parse(&[""]), Err(ValueError::Type));
    assert_eq!(f.parse(&["2"]), Err(ValueError::Range));
    assert_eq!(f.parse(&["1e999"]), Err(ValueError::Range));
    assert_eq!(f.parse(&["0"]), Err(ValueError::Range));
    let r = find("filter.rate").unwrap();
    assert_eq!(r.parse(&["50.5"]), Err(ValueError::Type));
    assert_eq!(r.parse(&["-50"]), Err(ValueError::Type));
    assert_eq!(r.parse(&["201"]), Err(ValueError::Range));
    assert_eq!(r.parse(&["99999"]), Err(ValueError::Range));
    assert_eq!(r.parse(&["100"]), Ok(Value::U16(100)));
    let b = find("rest.enabled").unwrap();
    assert_eq!(b.parse(&["2"]), Err(ValueError::Type));
    assert_eq!(b.parse(&["true"]), Err(ValueError::Type));
    let v = find("lever.r").unwrap();
    assert_eq!(v.parse(&["1", "2"]), Err(ValueError::Args));
    assert_eq!(v.parse(&["1", "x", "99"]), Err(ValueError::Type));
    assert_eq!(v.parse(&["1", "99", "x"]), Err(ValueError::Type));
    assert_eq!(v.parse(&["1", "99", "0"]), Err(ValueError::Range));
    let a = find("axes.gyro").unwrap();
    assert_eq!(a.parse(&["x", "x", "z"]), Err(ValueError::Range));
    assert_eq!(a.parse(&["x", "w", "z"]), Err(ValueError::Type));
    assert_eq!(a.parse(&["x", "--y", "z"]), Err(ValueError::Type));
    let t = find("output.talker").unwrap();
    assert_eq!(t.parse(&["II"]), Ok(Value::U16(talker_code(*b"II"))));
    assert_eq!(t.parse(&["gp"]), Ok(Value::U16(talker_code(*b"GP"))));
    for bad in ["H", "HCX", "H-", "", "h ", "Hé"] {
        assert_eq!(t.parse(&[bad]), Err(ValueError::Type), "{bad:?}");
    }
    assert_eq!(t.parse(&["H", "C"]), Err(ValueError::Args));
    assert!(!t.check(&Value::U16(talker_code(*b"h1"))));
    assert_eq!(t.decode(&talker_code(*b"C*").to_le_bytes()), None);
    assert_eq!(t.decode(b"C"), None);
    // Decoding refuses wrong lengths, bad bytes and out-of-range values.
    assert_eq!(f.decode(&[0, 0, 0]), None);
    assert_eq!(f.decode(&2.0f32.to_le_bytes()), None);
    assert_eq!(f.decode(&f32::NAN.to_le_bytes()), None);
    assert_eq!(b.decode(&[2]), None);
    assert_eq!(a.decode(&[0, 0, 2]), None);
    assert_eq!(a.decode(&[0x04, 1, 2]), None);
    assert_eq!(r.decode(&500u16.to_le_bytes()), None);
    assert!(!f.set(&mut PipelineSettings::default(), Value::Bool(true)));
}

#[test]
fn the_longest_get_reply_and_set_command_fit_a_sentence() {
    // Worst-case value text: 13 characters per number.
    for s in &SETTINGS {
        let value_len = match s.kind {
            Kind::F32 => 13,
            Kind::Vec3 => 3 * 13 + 2,
            Kind::Bool => 1,
            Kind::U16 => 5,
            Kind::Axes => 8,
            Kind::Talker => 2,
        };
        let reply = "PINAR,OK,GET,".len() + s.name.len() + 1 + value_len;
        assert!(reply <= crate::nmea::MAX_BODY_LEN, "{} reply {reply}", s.name);
        let cmd = "$PINAC,SET,".len() + s.name.len() + 1 + value_len + "*hh\r\n".len();
        assert!(cmd <= crate::nmea::MAX_SENTENCE_LEN, "{} command {cmd}", s.name);
    }
}

/// Ranges are inclusive and in user units: an integer at either limit is taken, one past it
/// refused; an internal value (radians) is checked after its conversion to degrees, by
/// `set` and by the flash record's `decode` alike.
#[test]
fn ranges_are_inclusive_and_checked_in_user_units() {
    let r = find("filter.rate").unwrap();
    assert_eq!(r.range(), (10.0, 200.0));
    assert_eq!(r.parse(&["10"]), Ok(Value::U16(10)));
    assert_eq!(r.parse(&["200"]), Ok(Value::U16(200)));
    assert_eq!(r.parse(&["9"]), Err(ValueError::Range));
    assert_eq!(r.parse(&["0"]), Err(ValueError::Range));
    // init.yaw0: −180° to 180°, stored in rad. 3.1 rad = 177.6°, 3.2 rad = 183.3°.
    let y = find("init.yaw0").unwrap();
    assert_eq!(y.range(), (-180.0, 180.0));
    for (rad, ok) in [(3.1f32, true), (core::f32::consts::PI, true), (3.2, false)] {
        for v in [rad, -rad] {
            assert_eq!(y.check(&Value::F32(v)), ok, "{v}");
            assert_eq!(y.decode(&v.to_le_bytes()).is_some(), ok, "{v}");
            let mut s = PipelineSettings::default();
            assert_eq!(y.set(&mut s, Value::F32(v)), ok, "{v}");
        }
    }
}

/// Whatever `parse` takes, `set` takes: the value is converted to internal units and back
/// before `check` compares it with the limits, which may move it by a rounding step past a
/// limit (hence the slack). Every scaled setting, at and just inside its limits.
#[test]
fn every_value_parse_takes_is_set() {
    let mut tried = 0;
    for s in SETTINGS.iter().filter(|s| s.scale != Scale::One) {
        let mut values = Vec::new();
        for k in 0..200u32 {
            let inward = |x: f32, up: bool| -> Option<f32> {
                // `k` steps of one unit in the last place from `x` toward the inside.
                let bits =
                    if (x > 0.0) == up { x.to_bits() + k } else { x.to_bits().checked_sub(k)? };
                (x != 0.0).then(|| f32::from_bits(bits))
            };
            values.extend(inward(s.max, false));
            values.extend(inward(s.min, true));
        }
        for u in values {
            let text = format!("{u}");
            let fields = vec![text.as_str(); s.kind.fields()];
            let v = s.parse(&fields).unwrap_or_else(|e| panic!("{} {text}: {e:?}", s.name));
            let mut d = PipelineSettings::default();
            assert!(s.set(&mut d, v), "{} {text} parsed but not set", s.name);
            tried += 1;
        }
    }
    assert!(tried > 1000, "{tried}");
}

/// The registry table of `docs/commands.md` matches the code row by row.
#[test]
fn docs_list_every_setting_exactly() {
    let doc = include_str!("../../docs/commands.md");
    let mut missing = Vec::new();
    for s in &SETTINGS {
        let mut row = String::new();
        s.doc_row(&mut row).unwrap();
        // (An empty row would match any empty line of the document.)
        assert!(row.starts_with(&format!("| `{}` | {} |", s.name, s.kind.name())), "{row}");
        if !doc.lines().any(|l| l == row) {
            missing.push(row);
        }
        assert!(doc.contains(&format!("`{}`", s.name)), "{} not in docs/commands.md", s.name);
    }
    assert!(missing.is_empty(), "rows missing from docs/commands.md:\n{}", missing.join("\n"));
}

/// `docs/commands.md`'s `LIST` row and example quote the registry's size: the indices
/// `0…<count − 1>` and the count in the reply (issue #30: it said 0…73 with 77 settings).
#[test]
fn docs_quote_the_registry_size() {
    let doc = include_str!("../../docs/commands.md");
    let n = SETTINGS.len();
    let row = doc.lines().find(|l| l.starts_with("| `LIST,<i>` |")).expect("LIST row");
    assert!(row.contains(&format!("registry, 0…{} ", n - 1)), "{row}");
    assert!(doc.contains(&format!("< $PINAR,OK,LIST,0,{n},")), "LIST example");
    assert!(
        doc.contains(&format!("< $PINAR,OK,VER,inemo-ahrs,{},1,{n}*", crate::command::VERSION)),
        "VER"
    );
}

/// Prints the registry table for `docs/commands.md`:
/// `cargo test -p inemo-ahrs --lib print_doc_rows -- --ignored --nocapture`.
#[test]
#[ignore]
fn print_doc_rows() {
    for s in &SETTINGS {
        let mut row = String::new();
        s.doc_row(&mut row).unwrap();
        println!("{row}");
    }
}

/// `same` agrees with the derived `PartialEq` of the whole settings and of `filter` and
/// `conditioning`, for one setting changed at a time, for several, for −0 against 0 and for NaN.
#[test]
fn same_agrees_with_the_derived_equality() {
    let d = PipelineSettings::default();
    let agree = |a: &PipelineSettings, b: &PipelineSettings| {
        assert_eq!(same(a, b, None), a == b);
        assert_eq!(same(a, b, Some(Part::Filter)), a.filter == b.filter);
        assert_eq!(same(a, b, Some(Part::Conditioning)), a.conditioning == b.conditioning);
        let rest = |x: &PipelineSettings| PipelineSettings {
            filter: d.filter,
            conditioning: d.conditioning,
            ..*x
        };
        assert_eq!(same(a, b, Some(Part::Other)), rest(a) == rest(b));
    };
    agree(&d, &d);
    let mut several = d;
    for (k, s) in SETTINGS.iter().enumerate() {
        // Another valid value: the other end of the range (the smallest where the default is
        // the largest), the other bool, a swapped axis map.
        let default = s.get(&d);
        let v = match default {
            Value::U16(_) if s.kind == Kind::Talker => s.parse(&["ii"]).unwrap(),
            Value::F32(_) | Value::Vec3(_) | Value::U16(_) => {
                let text = |x: f32| {
                    let mut t = Sentence::new();
                    number::push_f32(&mut t, x).unwrap();
                    t.body().to_string()
                };
                let fields: Vec<String> = (0..s.kind.fields())
                    .map(|i| text(if i == 0 { s.max } else { s.min }))
                    .collect();
                let refs: Vec<&str> = fields.iter().map(String::as_str).collect();
                let v = s.parse(&refs).unwrap();
                if v == default {
                    s.parse(&vec![text(s.min).as_str(); s.kind.fields()]).unwrap()
                } else {
                    v
                }
            }
            Value::Bool(b) => Value::Bool(!b),
            Value::Axes(_) => Value::Axes(AxisMap::new([1, 0, 2], [1, 1, -1]).unwrap()),
        };
        let mut one = d;
        assert!(s.set(&mut one, v), "{}", s.name);
        assert_ne!(one, d, "{} did not change anything", s.name);
        agree(&d, &one);
        agree(&one, &d);
        if k % 3 == 0 {
            assert!(s.set(&mut several, v));
            agree(&d, &several);
        }
    }
    // −0 = 0 and NaN ≠ NaN, as for f32.
    let (mut z, mut n) = (d, d);
    z.filter.init.initial_yaw = 0.0;
    n.filter.init.initial_yaw = -0.0;
    agree(&z, &n);
    n.filter.init.initial_yaw = f32::NAN;
    agree(&n, &n);
    agree(&z, &n);
}
