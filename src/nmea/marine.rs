//! The standard marine sentences (NMEA 0183 heading, rate of turn and transducer sentences), as
//! chart plotters (OpenCPN), Signal K servers and ROV stations read them. Each starts with a
//! configurable talker identifier (default `HC`, heading – magnetic compass).
//!
//! - `$--HDT,<heading>,T`: true heading, degrees, 1 decimal, [0, 360);
//! - `$--HDG,<heading>,,,<variation>,<E|W>`: magnetic sensor heading (deviation unknown:
//!   empty), magnetic variation (the configured declination), degrees, 1 decimal;
//! - `$--HDM,<heading>,M`: magnetic heading, degrees, 1 decimal;
//! - `$--ROT,<rate>,<A|V>`: rate of turn, degrees per minute, 1 decimal, negative when the bow
//!   turns to port; status `A` valid, `V` not;
//! - `$--XDR,A,<pitch>,D,PTCH,A,<roll>,D,ROLL,D,<depth>,M,DEPTH`: transducer measurements:
//!   pitch (positive bow up) and roll (positive starboard down) in degrees, 1 decimal, as
//!   OpenCPN's dashboard reads them (`PTCH`, `ROLL`), and depth below the surface (type `D`,
//!   linear displacement, metres, 1 decimal) named `DEPTH`. A quadruplet is left out when its
//!   value is unknown.
//!
//! HDT, HDG, HDM and XDR have no status field: the pipeline does not send them while their
//! data is invalid ([`crate::pipeline`]).

use super::error::NmeaError;
use super::number::{round_scaled, AngleRange, Sign};
use super::sentence::Sentence;

/// Decimals of headings, variation, rate of turn, pitch, roll and depth.
const DECIMALS: u8 = 1;
/// Printed depth range in units of 0.1 m: `$PINAH`'s, −9.9 m to 999.9 m, so that the two
/// sentences give a depth or neither (until issue #38, −99.9 to 9999.9 m here).
use super::pinah::{DEPTH_MAX_SCALED, DEPTH_MIN_SCALED};
/// Printed rate-of-turn magnitude limit, units of 0.1 °/min (99 999.9 °/min ≈ 1 667 °/s,
/// beyond any gyro's range).
const ROT_MAX_SCALED: i64 = 999_999;

/// `$`, the talker and the sentence formatter, then `,`.
fn start(talker: u16, formatter: &str) -> Result<Sentence, NmeaError> {
    let mut s = Sentence::new();
    s.push_bytes(&talker.to_be_bytes())?;
    s.push_str(formatter)?;
    s.push_str(",")?;
    Ok(s)
}

/// `$--HDT,<heading>,T`: true heading `heading` (rad, any value; printed in [0, 360)).
pub fn hdt(talker: u16, heading: f32) -> Result<Sentence, NmeaError> {
    let mut s = start(talker, "HDT")?;
    s.push_angle_deg(heading, DECIMALS, AngleRange::Heading, Sign::MinusOnly)?;
    s.push_str(",T")?;
    s.finish()?;
    Ok(s)
}

/// `$--HDM,<heading>,M`: magnetic heading `heading` (rad).
pub fn hdm(talker: u16, heading: f32) -> Result<Sentence, NmeaError> {
    let mut s = start(talker, "HDM")?;
    s.push_angle_deg(heading, DECIMALS, AngleRange::Heading, Sign::MinusOnly)?;
    s.push_str(",M")?;
    s.finish()?;
    Ok(s)
}

/// `$--HDG,<heading>,,,<variation>,<E|W>`: magnetic sensor heading `heading` (rad) and the
/// magnetic variation `variation` (rad, magnetic north east of true north positive: `E`). The
/// deviation fields are empty (the heading is already corrected by the calibration).
pub fn hdg(talker: u16, heading: f32, variation: f32) -> Result<Sentence, NmeaError> {
    let mut s = start(talker, "HDG")?;
    s.push_angle_deg(heading, DECIMALS, AngleRange::Heading, Sign::MinusOnly)?;
    s.push_str(",,,")?;
    let v = round_scaled(ekf_core::mathf::to_deg(variation), DECIMALS);
    match v {
        Some(n) if n.abs() <= 1800 => {
            s.push_scaled(n.abs(), DECIMALS, Sign::MinusOnly)?;
            s.push_str(if n < 0 { ",W" } else { ",E" })?;
        }
        _ => s.push_str(",")?,
    }
    s.finish()?;
    Ok(s)
}

/// `$--ROT,<rate>,<A|V>`: rate of turn `rate` (rad/s, positive bow to starboard; printed in
/// °/min; empty when unknown or beyond ±99 999.9 °/min) and the status, `A` when `valid`.
pub fn rot(talker: u16, rate: Option<f32>, valid: bool) -> Result<Sentence, NmeaError> {
    let mut s = start(talker, "ROT")?;
    let scaled = rate.and_then(|r| round_scaled(ekf_core::mathf::to_deg(r) * 60.0, DECIMALS));
    if let Some(n) = scaled.filter(|n| n.abs() <= ROT_MAX_SCALED) {
        s.push_scaled(n, DECIMALS, Sign::MinusOnly)?;
    }
    s.push_str(if valid { ",A" } else { ",V" })?;
    s.finish()?;
    Ok(s)
}

/// `$--XDR` with pitch and roll (`tilt`: (pitch, roll), rad) and the depth (m, positive down),
/// each quadruplet only when its value is known (and the depth within −9.9 to 999.9 m).
/// `None` when neither is: the sentence is not sent.
pub fn xdr(
    talker: u16,
    tilt: Option<(f32, f32)>,
    depth_m: Option<f32>,
) -> Option<Result<Sentence, NmeaError>> {
    let depth = depth_m
        .and_then(|d| round_scaled(d, DECIMALS))
        .filter(|n| (DEPTH_MIN_SCALED..=DEPTH_MAX_SCALED).contains(n));
    let tilt = tilt.filter(|(p, r)| p.is_finite() && r.is_finite());
    if tilt.is_none() && depth.is_none() {
        return None;
    }
    let build = || {
        let mut s = start(talker, "XDR")?;
        let mut first = true;
        if let Some((pitch, roll)) = tilt {
            s.push_str("A,")?;
            s.push_angle_deg(pitch, DECIMALS, AngleRange::Signed, Sign::MinusOnly)?;
            s.push_str(",D,PTCH,A,")?;
            s.push_angle_deg(roll, DECIMALS, AngleRange::Signed, Sign::MinusOnly)?;
            s.push_str(",D,ROLL")?;
            first = false;
        }
        if let Some(n) = depth {
            s.push_str(if first { "D," } else { ",D," })?;
            s.push_scaled(n, DECIMALS, Sign::MinusOnly)?;
            s.push_str(",M,DEPTH")?;
        }
        s.finish()?;
        Ok(s)
    };
    Some(build())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nmea::{verify, MAX_SENTENCE_LEN};
    use crate::settings::talker_code;
    use ekf_core::mathf::deg;

    const HC: u16 = talker_code(*b"HC");

    #[test]
    fn headings_by_hand() {
        // Checksums: XOR of the body, computed independently (Python: functools.reduce).
        assert_eq!(hdt(HC, deg(123.44)).unwrap().as_str(), "$HCHDT,123.4,T*2D\r\n");
        assert_eq!(hdt(HC, deg(-90.0)).unwrap().as_str(), "$HCHDT,270.0,T*2C\r\n");
        assert_eq!(hdt(HC, deg(-0.04)).unwrap().as_str(), "$HCHDT,0.0,T*29\r\n");
        let ii = talker_code(*b"II");
        assert_eq!(hdm(ii, deg(359.96)).unwrap().as_str(), "$IIHDM,0.0,M*22\r\n");
        assert_eq!(
            hdg(HC, deg(100.0), deg(-25.5)).unwrap().as_str(),
            "$HCHDG,100.0,,,25.5,W*08\r\n"
        );
        assert_eq!(hdg(HC, deg(10.0), deg(3.0)).unwrap().as_str(), "$HCHDG,10.0,,,3.0,E*1B\r\n");
        // NaN: empty fields, still a valid sentence.
        assert_eq!(verify(hdt(HC, f32::NAN).unwrap().as_bytes()), Ok("HCHDT,,T"));
        assert_eq!(verify(hdg(HC, f32::NAN, f32::NAN).unwrap().as_bytes()), Ok("HCHDG,,,,,"));
    }

    #[test]
    fn rate_of_turn_in_degrees_per_minute_with_status() {
        // 1 °/s = 60 °/min; bow to port negative.
        assert_eq!(rot(HC, Some(deg(1.0)), true).unwrap().as_str(), "$HCROT,60.0,A*1B\r\n");
        assert_eq!(
            verify(rot(HC, Some(deg(-0.205)), true).unwrap().as_bytes()),
            Ok("HCROT,-12.3,A")
        );
        assert_eq!(verify(rot(HC, None, false).unwrap().as_bytes()), Ok("HCROT,,V"));
        assert_eq!(verify(rot(HC, Some(deg(2.0)), false).unwrap().as_bytes()), Ok("HCROT,120.0,V"));
        assert_eq!(verify(rot(HC, Some(f32::INFINITY), true).unwrap().as_bytes()), Ok("HCROT,,A"));
        assert_eq!(verify(rot(HC, Some(deg(2000.0)), true).unwrap().as_bytes()), Ok("HCROT,,A"));
    }

    #[test]
    fn transducers_pitch_roll_and_depth() {
        let x = |tilt, depth| xdr(HC, tilt, depth).map(|s| s.unwrap().as_str().to_string());
        assert_eq!(
            x(Some((deg(1.23), deg(-0.46))), Some(12.34)).unwrap(),
            "$HCXDR,A,1.2,D,PTCH,A,-0.5,D,ROLL,D,12.3,M,DEPTH*26\r\n"
        );
        let only_tilt = x(Some((deg(-10.0), deg(179.99))), None).unwrap();
        assert_eq!(verify(only_tilt.as_bytes()), Ok("HCXDR,A,-10.0,D,PTCH,A,180.0,D,ROLL"));
        let only_depth = x(None, Some(2.5)).unwrap();
        assert_eq!(verify(only_depth.as_bytes()), Ok("HCXDR,D,2.5,M,DEPTH"));
        assert_eq!(x(None, None), None);
        assert_eq!(x(Some((f32::NAN, 0.0)), Some(f32::NAN)), None);
        // `$PINAH`'s depth range: 999.9 m is printed, 999.96 m (1000.0 rounded) is not, nor
        // −9.96 m; both sentences agree (issue #38 point 7).
        assert_eq!(verify(x(None, Some(999.9)).unwrap().as_bytes()), Ok("HCXDR,D,999.9,M,DEPTH"));
        assert_eq!(x(None, Some(999.96)), None);
        assert_eq!(x(None, Some(-9.96)), None);
        assert_eq!(x(None, Some(10_000.0)), None);
        // The widest sentence fits.
        let widest = x(Some((deg(-89.99), deg(-179.9))), Some(-9.9)).unwrap();
        assert!(widest.len() <= MAX_SENTENCE_LEN, "{widest}");
        assert_eq!(
            verify(widest.as_bytes()),
            Ok("HCXDR,A,-90.0,D,PTCH,A,-179.9,D,ROLL,D,-9.9,M,DEPTH")
        );
    }

    /// `XDR` and `$PINAH` give a depth for the same depths and none for the others (issue #38
    /// point 7: `XDR` printed up to 9999.9 m, `$PINAH` up to 999.9 m), and the same value.
    #[test]
    fn xdr_and_pinah_agree_on_the_depth() {
        use crate::nmea::{pinah, PinahData};
        let mut n = 0;
        for k in -300..=11_000 {
            let depth = k as f32 * 0.0917;
            let x = xdr(HC, None, Some(depth)).map(|s| s.unwrap().as_str().to_string());
            let p = pinah(&PinahData { depth_m: Some(depth), ..PinahData::default() }).unwrap();
            let p_depth = p.as_str().split(',').nth(8).unwrap_or("").to_string();
            let x_depth = x.as_deref().and_then(|x| x.split(',').nth(2)).unwrap_or("").to_string();
            assert_eq!(x_depth, p_depth, "{depth} m: {x:?} / {}", p.as_str());
            n += usize::from(!p_depth.is_empty());
        }
        assert!(n > 10_000 && n < 11_200, "{n}");
    }
}
