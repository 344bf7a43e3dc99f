//! `$PINAH`: the proprietary full-state sentence (field list in the module docs of
//! [`crate::nmea`]).

use ekf_core::{Euler, Quaternion};

use super::error::NmeaError;
use super::number::{round_scaled, AngleRange, Sign};
use super::sentence::Sentence;
use crate::status::HeadingRef;
use crate::status::Status;

/// Decimals of the Euler angles.
const ANGLE_DECIMALS: u8 = 2;
/// Decimals of the quaternion components (1e−4 ≈ 0.01° of rotation, the angles' resolution).
const QUATERNION_DECIMALS: u8 = 4;
/// Largest printed quaternion component magnitude, in units of 10^−4 (1.0000).
const QUATERNION_MAX_SCALED: i64 = 10_000;
/// Decimals of the depth.
const DEPTH_DECIMALS: u8 = 1;
/// Printed depth range in units of 0.1 m: −9.9 m to 999.9 m (a depth above the zeroed
/// surface is an offset of the sensor: the 82 characters keep a sign and one digit for it).
/// `XDR` prints the same range (issue #38 point 7: both sentences give a depth or neither).
pub(super) const DEPTH_MIN_SCALED: i64 = -99;
pub(super) const DEPTH_MAX_SCALED: i64 = 9_999;
/// Hex digits of the status word.
const STATUS_DIGITS: u8 = 6;
/// Largest printed cycle time, µs (4 digits; longer cycles print 9999).
pub const PINAH_CYCLE_MAX_US: u32 = 9_999;

/// What `$PINAH` reports for one filter cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PinahData {
    /// Attitude as Z-Y-X Euler angles, rad: roll φ (positive starboard down), pitch θ
    /// (positive bow up), yaw ψ (positive clockwise from north / the initial reference).
    pub euler: Euler,
    /// Attitude quaternion, scalar first, rotating body (FRD) vectors into NED.
    pub quaternion: Quaternion,
    /// Depth below the surface, m, positive down; `None` when unknown.
    pub depth_m: Option<f32>,
    /// Estimator flags and board bits.
    pub status: Status,
    /// Time the filter cycle took, µs.
    pub cycle_us: u32,
    /// What the heading is referenced to: status bits 20–21 ([`Status::heading_ref`]).
    pub heading_ref: HeadingRef,
}

/// Append a quaternion component, or nothing if it is not finite or beyond ±1.0000.
fn push_component(s: &mut Sentence, c: f32) -> Result<(), NmeaError> {
    match round_scaled(c, QUATERNION_DECIMALS) {
        Some(n) if n.abs() <= QUATERNION_MAX_SCALED => {
            s.push_scaled(n, QUATERNION_DECIMALS, Sign::MinusOnly)
        }
        _ => Ok(()),
    }
}

/// Build `$PINAH` (see [`crate::nmea`] for the fields). The worst case is 82 characters, so
/// this fails only on a bug (tested).
pub fn pinah(data: &PinahData) -> Result<Sentence, NmeaError> {
    let mut s = Sentence::new();
    s.push_str("PINAH,")?;
    let e = data.euler;
    s.push_angle_deg(e.roll, ANGLE_DECIMALS, AngleRange::Signed, Sign::MinusOnly)?;
    s.push_str(",")?;
    s.push_angle_deg(e.pitch, ANGLE_DECIMALS, AngleRange::Signed, Sign::MinusOnly)?;
    s.push_str(",")?;
    s.push_angle_deg(e.yaw, ANGLE_DECIMALS, AngleRange::Signed, Sign::MinusOnly)?;
    // q and −q are the same attitude: send the one with w ≥ 0 (w then needs no sign).
    let q = data.quaternion;
    let k = if q.w < 0.0 { -1.0 } else { 1.0 };
    for c in [q.w, q.x, q.y, q.z] {
        s.push_str(",")?;
        push_component(&mut s, k * c)?;
    }
    s.push_str(",")?;
    if let Some(n) = data.depth_m.and_then(|d| round_scaled(d, DEPTH_DECIMALS)) {
        if (DEPTH_MIN_SCALED..=DEPTH_MAX_SCALED).contains(&n) {
            s.push_scaled(n, DEPTH_DECIMALS, Sign::MinusOnly)?;
        }
    }
    s.push_str(",")?;
    let status =
        (data.status.0 & Status::BOARD_AND_FLAGS) | Status::heading_ref(data.heading_ref).0;
    s.push_hex(status, STATUS_DIGITS)?;
    s.push_str(",")?;
    s.push_uint(u64::from(data.cycle_us.min(PINAH_CYCLE_MAX_US)))?;
    s.finish()?;
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nmea::{verify, MAX_SENTENCE_LEN};
    use ekf_core::mathf::deg;
    use ekf_core::Flags;

    fn data(roll: f32, pitch: f32, yaw: f32) -> PinahData {
        let euler = Euler::new(deg(roll), deg(pitch), deg(yaw));
        PinahData {
            euler,
            quaternion: euler.to_quaternion(),
            depth_m: Some(12.34),
            status: Status::from(Flags::ACCEL_USED | Flags::AT_REST) | Status::I2C_FAULT,
            cycle_us: 1234,
            heading_ref: HeadingRef::True,
        }
    }

    fn fields(s: &Sentence) -> Vec<String> {
        verify(s.as_bytes()).unwrap().split(',').map(str::to_string).collect()
    }

    #[test]
    fn hand_values_and_field_count() {
        // Yaw 90°: q = (cos 45°, 0, 0, sin 45°) = (0.70711, 0, 0, 0.70711).
        let s = pinah(&data(0.0, 0.0, 90.0)).unwrap();
        let f = fields(&s);
        assert_eq!(f.len(), 11, "{f:?}");
        assert_eq!(
            f,
            [
                "PINAH", "0.00", "0.00", "90.00", "0.7071", "0.0000", "0.0000", "0.7071", "12.3",
                "110300", "1234"
            ]
        );
        assert!(s.as_str().ends_with("\r\n"));
        // Negative angles, yaw in (−180, 180], and a quaternion with w < 0 sent as −q.
        let mut d = data(-10.0, -5.25, 270.0);
        d.quaternion = Quaternion::new(-0.5, 0.5, -0.5, 0.5);
        d.depth_m = Some(-0.04);
        d.cycle_us = 20_000;
        d.heading_ref = HeadingRef::Relative;
        d.status = Status(0xFFFF_FFFF);
        let f = fields(&pinah(&d).unwrap());
        assert_eq!(&f[1..4], ["-10.00", "-5.25", "-90.00"]);
        assert_eq!(&f[4..8], ["0.5000", "-0.5000", "0.5000", "-0.5000"]);
        assert_eq!(f[8], "0.0");
        assert_eq!(f[9], "0FFFFF", "reserved bits 20–31 dropped, relative: bits 20–21 clear");
        assert_eq!(f[10], "9999");
        d.heading_ref = HeadingRef::Magnetic;
        assert_eq!(fields(&pinah(&d).unwrap())[9], "2FFFFF");
    }

    #[test]
    fn yaw_seam_and_rounding() {
        let f = fields(&pinah(&data(-179.996, 0.0, -180.0)).unwrap());
        assert_eq!((f[1].as_str(), f[3].as_str()), ("180.00", "180.00"));
        let f = fields(&pinah(&data(0.0, 0.0, 179.994)).unwrap());
        assert_eq!(f[3], "179.99");
    }

    #[test]
    fn unknown_and_invalid_fields_are_empty() {
        let mut d = data(1.0, 2.0, 3.0);
        d.depth_m = None;
        d.euler.pitch = f32::NAN;
        d.quaternion = Quaternion::new(f32::NAN, 2.0, f32::INFINITY, -1.000_04);
        let f = fields(&pinah(&d).unwrap());
        assert_eq!(f.len(), 11);
        assert_eq!(&f[2..9], ["", "3.00", "", "", "", "-1.0000", ""]);
        // Depth beyond the printable range −9.9 … 999.9 m is unknown too.
        for depth in [1000.0, -10.0, f32::NAN] {
            d.depth_m = Some(depth);
            assert_eq!(fields(&pinah(&d).unwrap())[8], "");
        }
        d.depth_m = Some(999.94);
        assert_eq!(fields(&pinah(&d).unwrap())[8], "999.9");
        d.depth_m = Some(-9.94);
        assert_eq!(fields(&pinah(&d).unwrap())[8], "-9.9");
    }

    #[test]
    fn worst_case_is_at_most_82_characters() {
        let worst = PinahData {
            euler: Euler::new(deg(-179.99), deg(-89.99), deg(-179.99)),
            // w ≥ 0 after canonicalisation; every other component negative and 7 wide.
            quaternion: Quaternion::new(0.1234, -0.9876, -0.5432, -1.0),
            depth_m: Some(-9.9),
            status: Status(u32::MAX),
            cycle_us: u32::MAX,
            heading_ref: HeadingRef::Magnetic,
        };
        let s = pinah(&worst).unwrap();
        assert_eq!(
            s.as_str(),
            "$PINAH,-179.99,-89.99,-179.99,0.1234,-0.9876,-0.5432,-1.0000,-9.9,2FFFFF,9999*03\r\n"
        );
        assert_eq!(s.len(), MAX_SENTENCE_LEN);
        // Every combination of extreme-width values fits (and checks).
        let angles = [-179.99f32, 180.0, -89.99, -0.001, f32::NAN];
        let comps = [-1.0f32, -0.99999, 1.0, -0.00001, f32::NAN];
        let depths = [Some(-9.9f32), Some(999.9), None];
        let mut n = 0;
        for &a in &angles {
            for &c in &comps {
                for &dep in &depths {
                    let d = PinahData {
                        euler: Euler::new(deg(a), deg(-a), deg(a)),
                        quaternion: Quaternion::new(c, c, -c, c),
                        depth_m: dep,
                        status: Status(0xFFFF_FFFF),
                        cycle_us: 123_456,
                        heading_ref: HeadingRef::Magnetic,
                    };
                    let s = pinah(&d).unwrap();
                    assert!(s.len() <= MAX_SENTENCE_LEN, "{}", s.as_str());
                    assert_eq!(fields(&s).len(), 11);
                    n += 1;
                }
            }
        }
        assert_eq!(n, 75);
    }
}
