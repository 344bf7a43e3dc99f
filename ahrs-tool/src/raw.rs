//! Raw-mode sentences (`$PINAW`, `$PINAX`) to trace rows, as `docs/commands.md` ("Rebuilding
//! a trace CSV") describes: join on `t`, skip rows with a missing field, unwrap `t`. In
//! `RAW,2`, the `$PRDID` after a row's `$PINAW` (and `$PINAX`) is the device's estimate from
//! that row's sample: [`Logged::device`].

use host_tests::trace::TraceRow;

/// Wrap period of the raw-mode timestamp, s.
const T_WRAP: f64 = inemo_ahrs::command::T_WRAP_S as f64;

/// The device's estimate from a row's sample, as its `$PRDID` printed it (degrees, the
/// sentence's text: roll and pitch with their sign, heading in [0, 360)).
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceEstimate {
    /// Roll, degrees.
    pub roll: String,
    /// Pitch, degrees.
    pub pitch: String,
    /// Heading (yaw), degrees.
    pub yaw: String,
}

/// A completed row, with the device's estimate when a `$PRDID` followed its `$PINAW`.
#[derive(Clone, Debug, PartialEq)]
pub struct Logged {
    /// The trace row.
    pub row: TraceRow,
    /// The device's estimate (`RAW,2` only).
    pub device: Option<DeviceEstimate>,
}

/// Joins `$PINAW` and `$PINAX` bodies into trace rows.
#[derive(Default)]
pub struct RawJoiner {
    pending: Option<(f64, Logged)>,
    offset: f64,
    last: Option<f64>,
    /// `$PINAW` sentences skipped (a field missing, `t` not increasing).
    pub skipped: u64,
}

fn num(s: &str) -> Option<f64> {
    if s.is_empty() {
        None
    } else {
        s.parse::<f64>().ok().filter(|v| v.is_finite())
    }
}

impl RawJoiner {
    /// Feed one checked sentence body; returns a completed row when one is.
    pub fn push(&mut self, body: &str) -> Option<Logged> {
        let f: Vec<&str> = body.split(',').collect();
        match f.first().copied() {
            Some("PINAW") => {
                let done = self.pending.take().map(|(_, r)| r);
                let v: Option<Vec<f64>> =
                    f.get(1..8).and_then(|c| c.iter().map(|s| num(s)).collect());
                match v {
                    Some(v) if v.len() == 7 => {
                        if self.last.is_some_and(|l| v[0] + self.offset < l) {
                            self.offset += T_WRAP;
                        }
                        let t = v[0] + self.offset;
                        if self.last.is_some_and(|l| t <= l) {
                            self.skipped += 1;
                        } else {
                            self.last = Some(t);
                            let row = TraceRow {
                                t,
                                gyro: [v[1] as f32, v[2] as f32, v[3] as f32],
                                accel: [v[4] as f32, v[5] as f32, v[6] as f32],
                                mag: None,
                                depth: None,
                                truth: None,
                                movement: None,
                            };
                            self.pending = Some((v[0], Logged { row, device: None }));
                        }
                    }
                    _ => self.skipped += 1,
                }
                done
            }
            Some("PINAX") => {
                if let (Some((raw_t, Logged { row, .. })), Some(t)) =
                    (self.pending.as_mut(), f.get(1).and_then(|s| num(s)))
                {
                    if (t - *raw_t).abs() < 1e-6 {
                        let m: Vec<Option<f64>> =
                            (2..5).map(|i| f.get(i).and_then(|s| num(s))).collect();
                        if let [Some(x), Some(y), Some(z)] = m[..] {
                            row.mag = Some([x as f32, y as f32, z as f32]);
                        }
                        row.depth = f.get(5).and_then(|s| num(s)).map(|d| d as f32);
                    }
                }
                None
            }
            Some("PRDID") => {
                // The estimate of the pending row: the first `$PRDID` after its `$PINAW` (a
                // second one belongs to a cycle whose `$PINAW` was lost).
                let fields: Vec<&str> = f.get(1..4).unwrap_or(&[]).to_vec();
                if let (Some((_, logged)), [pitch, roll, yaw]) =
                    (self.pending.as_mut(), &fields[..])
                {
                    let all = [pitch, roll, yaw].iter().all(|s| num(s).is_some());
                    if logged.device.is_none() && all {
                        logged.device = Some(DeviceEstimate {
                            roll: roll.to_string(),
                            pitch: pitch.to_string(),
                            yaw: yaw.to_string(),
                        });
                    }
                }
                None
            }
            _ => None,
        }
    }

    /// The last row, at the end of the log.
    pub fn finish(&mut self) -> Option<Logged> {
        self.pending.take().map(|(_, r)| r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joins_on_t_and_unwraps() {
        let mut j = RawJoiner::default();
        assert!(j.push("PINAW,5.2600,-0.02502,-0.06300,-0.00076,0.1009,0.1879,-10.1017").is_none());
        assert!(j.push("PINAX,5.2600,20.00,3.00,-45.00,48.235").is_none());
        let r = j.push("PINAW,99999.9900,0,0,0,0,0,-9.81").unwrap();
        assert_eq!(r.device, None);
        let r = r.row;
        assert_eq!(r.t, 5.26);
        assert_eq!(r.mag, Some([20.0, 3.0, -45.0]));
        assert_eq!(r.depth, Some(48.235));
        assert!(j.push("PINAX,5.2600,,,,1.0").is_none()); // other t: ignored
        let r = j.push("PINAW,0.0100,0,0,,0,0,-9.81").unwrap().row; // missing gz: skipped
        assert_eq!(r.depth, None);
        assert_eq!(j.skipped, 1);
        j.push("PINAW,0.0200,0,0,0,0,0,-9.81");
        let r = j.finish().unwrap().row;
        assert!((r.t - 100_000.02).abs() < 1e-6);
    }

    #[test]
    fn a_prdid_after_a_row_is_its_device_estimate() {
        let mut j = RawJoiner::default();
        j.push("PINAW,0.0200,0,0,0,0,0,-9.81");
        j.push("PINAX,0.0200,,,,2.500");
        j.push("PRDID,+1.25,-0.50,359.99");
        // A second $PRDID (its cycle's $PINAW lost) is not this row's.
        j.push("PRDID,+9.00,-9.00,9.00");
        let r = j.push("PINAW,0.0400,0,0,0,0,0,-9.81").unwrap();
        let d = r.device.unwrap();
        assert_eq!(
            (d.roll.as_str(), d.pitch.as_str(), d.yaw.as_str()),
            ("-0.50", "+1.25", "359.99")
        );
        // Empty fields: no estimate.
        j.push("PRDID,+1.00,,2.00");
        assert_eq!(j.finish().unwrap().device, None);
    }
}
