//! `$PRDID`: the Teledyne RDI attitude sentence.

use ekf_core::Euler;

use super::error::NmeaError;
use super::number::{AngleRange, Sign};
use super::sentence::Sentence;

/// `$PRDID,<pitch>,<roll>,<heading>*hh` — Teledyne RDI's attitude sentence, as DVLs and
/// ADCPs accept it from an external attitude source.
///
/// - pitch: degrees, 2 decimals, explicit sign, positive bow up (θ);
/// - roll: degrees, 2 decimals, explicit sign, positive starboard down (φ);
/// - heading: degrees, 2 decimals, in [0, 360), 0 = north (or the initial yaw reference),
///   clockwise seen from above (ψ wrapped; 359.996° prints as `0.00`).
///
/// The pipeline does not send it while the attitude is not trustworthy (it has no status
/// field: [`crate::pipeline::attitude_valid`]).
///
/// Example: `$PRDID,+1.23,-0.45,359.99*hh`. `attitude` is in rad with `ekf-core`'s Z-Y-X
/// convention, whose signs are RDI's. A NaN or infinite angle gives an empty field. Angles are
/// wrapped into (−180°, 180°] (pitch from `ekf-core` is within ±90° already), so the sentence
/// is at most 34 characters and this never fails in practice.
pub fn prdid(attitude: &Euler) -> Result<Sentence, NmeaError> {
    let mut s = Sentence::new();
    s.push_str("PRDID,")?;
    s.push_angle_deg(attitude.pitch, 2, AngleRange::Signed, Sign::Explicit)?;
    s.push_str(",")?;
    s.push_angle_deg(attitude.roll, 2, AngleRange::Signed, Sign::Explicit)?;
    s.push_str(",")?;
    s.push_angle_deg(attitude.yaw, 2, AngleRange::Heading, Sign::MinusOnly)?;
    s.finish()?;
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nmea::verify;
    use ekf_core::mathf::deg;

    fn text(roll: f32, pitch: f32, yaw: f32) -> String {
        prdid(&Euler::new(deg(roll), deg(pitch), deg(yaw))).unwrap().as_str().to_string()
    }

    #[test]
    fn hand_values() {
        // Checksums computed by hand (XOR of the body), cross-checked by `verify`.
        assert_eq!(text(-0.45, 1.23, -0.01), "$PRDID,+1.23,-0.45,359.99*71\r\n");
        assert_eq!(text(10.0, -20.5, 90.0), "$PRDID,-20.50,+10.00,90.00*40\r\n");
        assert_eq!(text(-179.99, -89.99, 180.0), "$PRDID,-89.99,-179.99,180.00*4E\r\n");
    }

    #[test]
    fn heading_wrap_and_negative_zero() {
        // 359.996° (= −0.004°) rounds to 360.00: printed 0.00.
        assert!(text(0.0, 0.0, -0.004).starts_with("$PRDID,+0.00,+0.00,0.00*"));
        assert!(text(0.0, 0.0, 359.996).starts_with("$PRDID,+0.00,+0.00,0.00*"));
        assert!(text(0.0, 0.0, -0.006).contains(",359.99*"));
        assert!(text(0.0, 0.0, -90.0).contains(",270.00*"));
        // Negative zero and tiny negatives are "+0.00", never "-0.00".
        assert!(text(-0.0, -0.0, -0.0).starts_with("$PRDID,+0.00,+0.00,0.00*"));
        assert!(text(-0.004, -0.001, 0.0).starts_with("$PRDID,+0.00,+0.00,0.00*"));
    }

    #[test]
    fn nan_fields_are_empty_and_round_trip() {
        let s = prdid(&Euler::new(f32::NAN, deg(5.0), f32::INFINITY)).unwrap();
        assert_eq!(verify(s.as_bytes()), Ok("PRDID,+5.00,,"));
        for (r, p, y) in [(1.0, 2.0, 3.0), (-179.99, -89.99, 359.99), (0.5, -0.5, 0.0)] {
            let s = prdid(&Euler::new(deg(r), deg(p), deg(y))).unwrap();
            assert_eq!(verify(s.as_bytes()), Ok(s.body()));
            assert!(s.len() <= 34);
        }
    }
}
