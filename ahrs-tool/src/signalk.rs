//! `ahrs-tool bridge --signalk`: the device's attitude, heading, rate of turn and depth as
//! Signal K deltas (issue #38 point 1). Signal K's NMEA 0183 parser has no handler for `XDR`,
//! `$PRDID` or `$PINAH`, so through it a Signal K display shows a heading and nothing else;
//! these deltas, sent to a server's Signal K UDP input, carry the rest.
//!
//! From each `$PINAH` (the device's full state every output): `navigation.attitude` (roll,
//! pitch; yaw while the heading is referenced) while the tilt is valid, and
//! `navigation.headingTrue` while the attitude is valid and the heading referenced to true
//! north (`YAW`, or the magnetometer with `mag.declination`: status bits 20–21; a relative
//! heading is not sent), `environment.depth.belowSurface` while the depth is known. From each
//! `ROT` with `A`: `navigation.rateOfTurn`. SI units (rad, rad/s, m) as the Signal K
//! specification's paths require; a meta delta with the units goes first and every
//! [`META_EVERY`] (a UDP datagram can be lost). Built with `serde_json`.

use std::time::Duration;

use inemo_ahrs::{pipeline, status::Status};
use serde_json::{json, Value};

/// How often the meta delta is sent again.
pub const META_EVERY: Duration = Duration::from_secs(30);
/// The source label the deltas carry.
const SOURCE: &str = "inemo-ahrs";

/// The delta for one verified sentence `body` (between `$` and `*`), or `None` when it carries
/// nothing for Signal K (another sentence, or nothing valid in it).
pub fn delta(body: &str) -> Option<Value> {
    let f: Vec<&str> = body.split(',').collect();
    let values = match f.first().copied() {
        Some("PINAH") => pinah_values(&f)?,
        Some(s) if s.len() == 5 && s.ends_with("ROT") => rot_values(&f)?,
        _ => return None,
    };
    Some(json!({
        "context": "vessels.self",
        "updates": [{ "source": { "label": SOURCE }, "values": values }],
    }))
}

/// `$PINAH,<roll>,<pitch>,<yaw>,<qw>,<qx>,<qy>,<qz>,<depth>,<status>,<cycle>` (degrees, m).
fn pinah_values(f: &[&str]) -> Option<Vec<Value>> {
    let number = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).filter(|v| v.is_finite());
    let status = Status(u32::from_str_radix(f.get(9)?, 16).ok()?);
    let referenced =
        status.contains(Status::HEADING_TRUE) || status.contains(Status::HEADING_MAGNETIC);
    let mut values = Vec::new();
    if let (Some(roll), Some(pitch), true) = (number(1), number(2), pipeline::tilt_valid(status)) {
        let mut attitude = json!({ "roll": roll.to_radians(), "pitch": pitch.to_radians() });
        if let (Some(yaw), true) = (number(3), referenced && pipeline::attitude_valid(status)) {
            attitude["yaw"] = json!(yaw.to_radians());
        }
        values.push(json!({ "path": "navigation.attitude", "value": attitude }));
    }
    if let (Some(yaw), true) = (number(3), referenced && pipeline::attitude_valid(status)) {
        let heading = yaw.to_radians().rem_euclid(std::f64::consts::TAU);
        values.push(json!({ "path": "navigation.headingTrue", "value": heading }));
    }
    if let Some(depth) = number(8) {
        values.push(json!({ "path": "environment.depth.belowSurface", "value": depth }));
    }
    (!values.is_empty()).then_some(values)
}

/// `$--ROT,<rate °/min>,<A/V>`: the rate while valid, rad/s.
fn rot_values(f: &[&str]) -> Option<Vec<Value>> {
    if f.get(2) != Some(&"A") {
        return None;
    }
    let rate = f.get(1)?.parse::<f64>().ok().filter(|v| v.is_finite())?;
    Some(vec![json!({ "path": "navigation.rateOfTurn", "value": (rate / 60.0).to_radians() })])
}

/// The meta delta: the units of every path sent.
pub fn meta() -> Value {
    let m = |path: &str, units: &str, description: &str| json!({ "path": path, "value": { "units": units, "description": description } });
    json!({
        "context": "vessels.self",
        "updates": [{
            "source": { "label": SOURCE },
            "meta": [
                m("navigation.attitude", "rad", "roll, pitch and yaw of the iNEMO AHRS"),
                m("navigation.headingTrue", "rad", "true heading of the iNEMO AHRS"),
                m("navigation.rateOfTurn", "rad/s", "rate of turn: the gyros' share of the heading's change"),
                m("environment.depth.belowSurface", "m", "depth from the pressure sensor, positive down"),
            ],
        }],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use inemo_ahrs::nmea::verify;

    fn values(body: &str) -> Vec<(String, Value)> {
        delta(body).map_or(vec![], |d| {
            assert_eq!(d["context"], "vessels.self");
            d["updates"][0]["values"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| (v["path"].as_str().unwrap().to_string(), v["value"].clone()))
                .collect()
        })
    }

    /// A referenced, valid `$PINAH` gives the attitude with its yaw, the true heading in
    /// [0, 2π) and the depth, in rad and m; by hand from the degrees.
    #[test]
    fn a_valid_referenced_pinah_gives_attitude_heading_and_depth() {
        let line = "$PINAH,-1.50,10.00,-90.00,0.7071,0.0000,0.0000,-0.7071,12.3,100100,1200*";
        let body = line.trim_start_matches('$').trim_end_matches('*');
        let v = values(body);
        let att = &v.iter().find(|p| p.0 == "navigation.attitude").unwrap().1;
        assert!((att["roll"].as_f64().unwrap() - (-1.5f64).to_radians()).abs() < 1e-12);
        assert!((att["pitch"].as_f64().unwrap() - 10f64.to_radians()).abs() < 1e-12);
        assert!((att["yaw"].as_f64().unwrap() - (-90f64).to_radians()).abs() < 1e-12);
        let h = v.iter().find(|p| p.0 == "navigation.headingTrue").unwrap().1.as_f64().unwrap();
        assert!((h - 270f64.to_radians()).abs() < 1e-12, "{h}");
        let d = v.iter().find(|p| p.0 == "environment.depth.belowSurface").unwrap();
        assert_eq!(d.1.as_f64(), Some(12.3));
    }

    /// Nothing invalid or relative as valid: a relative heading gives no heading and no yaw;
    /// initialising (flag bit 0) gives no attitude or heading, the depth still; an unknown
    /// depth none; `ROT` only with `A`.
    #[test]
    fn nothing_invalid_or_relative_goes_out() {
        let rel = values("PINAH,1.00,2.00,30.00,1.0000,0.0000,0.0000,0.0000,,000100,1200");
        assert_eq!(rel.len(), 1);
        assert_eq!(rel[0].0, "navigation.attitude");
        assert!(rel[0].1.get("yaw").is_none());
        let init = values("PINAH,1.00,2.00,30.00,1.0000,0.0000,0.0000,0.0000,3.0,100001,1200");
        assert_eq!(
            init.iter().map(|p| p.0.as_str()).collect::<Vec<_>>(),
            ["environment.depth.belowSurface"]
        );
        assert!(values("PINAH,,,,,,,,,000001,1200").is_empty());
        let rot = values("HCROT,-120.0,A");
        assert_eq!(rot[0].0, "navigation.rateOfTurn");
        assert!((rot[0].1.as_f64().unwrap() - (-2f64).to_radians()).abs() < 1e-12);
        assert!(values("HCROT,,V").is_empty() && values("HCROT,12.0,V").is_empty());
        assert!(values("HCHDT,12.0,T").is_empty());
        // A real sentence, checksum and all, through the device's own verifier first.
        let s = "$PINAH,0.06,0.00,45.00,1.0000,0.0005,0.0000,0.0000,,100000,1200*";
        let body = &s[1..s.len() - 1];
        let line = format!("{s}{:02X}", body.bytes().fold(0u8, |x, b| x ^ b));
        assert_eq!(values(verify(line.as_bytes()).unwrap()).len(), 2);
    }

    /// The meta delta names every path the deltas use, with the specification's units.
    #[test]
    fn the_meta_delta_gives_every_path_its_units() {
        let m = meta();
        let meta = m["updates"][0]["meta"].as_array().unwrap();
        let units: Vec<(&str, &str)> = meta
            .iter()
            .map(|e| (e["path"].as_str().unwrap(), e["value"]["units"].as_str().unwrap()))
            .collect();
        assert_eq!(
            units,
            [
                ("navigation.attitude", "rad"),
                ("navigation.headingTrue", "rad"),
                ("navigation.rateOfTurn", "rad/s"),
                ("environment.depth.belowSurface", "m"),
            ]
        );
    }
}
