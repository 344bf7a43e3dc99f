//! The raw streaming sentences `$PINAW` (time, gyro, accelerometer) and `$PINAX` (time,
//! magnetometer, depth).

use ekf_core::ImuSample;

use crate::nmea::{NmeaError, Sentence, Sign};

/// Time field: seconds, 4 decimals, wrapping at this many seconds (so that `$PINAW` always
/// fits 82 characters).
pub const T_WRAP_S: u64 = 100_000;

/// Append `,` and `v` with `decimals` decimals, or an empty field when `v` is not finite or
/// `|v| ≥ limit`.
fn field(s: &mut Sentence, v: f32, decimals: u8, limit: f32) -> Result<(), NmeaError> {
    s.push_str(",")?;
    if v.is_finite() && v.abs() < limit {
        s.push_fixed(v, decimals, Sign::MinusOnly)
    } else {
        Ok(())
    }
}

/// Append `,` and the time `t_us` (µs) as seconds with 4 decimals, modulo [`T_WRAP_S`].
fn time(s: &mut Sentence, t_us: u64) -> Result<(), NmeaError> {
    s.push_str(",")?;
    let t100 = (t_us / 100) % (T_WRAP_S * 10_000);
    s.push_scaled(t100 as i64, 4, Sign::MinusOnly)
}

/// `$PINAW,<t>,<gx>,<gy>,<gz>,<ax>,<ay>,<az>*hh`: t in s (4 decimals, wraps at 100000 s),
/// gyro rad/s (5 decimals, empty beyond ±100), specific force m/s² (4 decimals, empty
/// beyond ±1000); body FRD, as fed to the estimator. At most 82 characters.
pub fn pinaw(t_us: u64, sample: &ImuSample) -> Result<Sentence, NmeaError> {
    let mut s = Sentence::new();
    s.push_str("PINAW")?;
    time(&mut s, t_us)?;
    for v in sample.gyro.to_array() {
        field(&mut s, v, 5, 100.0)?;
    }
    for v in sample.accel.to_array() {
        field(&mut s, v, 4, 1000.0)?;
    }
    s.finish()?;
    Ok(s)
}

/// `$PINAX,<t>,<mx>,<my>,<mz>,<depth>*hh`: t as in [`pinaw`], magnetic field µT body FRD
/// (2 decimals, empty when not read), depth m positive down (3 decimals, empty when unknown).
pub fn pinax(
    t_us: u64,
    mag: Option<[f32; 3]>,
    depth_m: Option<f32>,
) -> Result<Sentence, NmeaError> {
    let mut s = Sentence::new();
    s.push_str("PINAX")?;
    time(&mut s, t_us)?;
    let m = mag.unwrap_or([f32::NAN; 3]);
    for v in m {
        field(&mut s, v, 2, 10_000.0)?;
    }
    field(&mut s, depth_m.unwrap_or(f32::NAN), 3, 10_000.0)?;
    s.finish()?;
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nmea::verify;
    use ekf_core::Vec3;

    #[test]
    fn fields_and_worst_case_length() {
        let mut smp =
            ImuSample::new(0.02, Vec3::new(0.012_345_6, -1.5, 0.0), Vec3::new(0.1, -0.2, -9.80665));
        let s = pinaw(12_345_678_901, &smp).unwrap();
        assert_eq!(
            verify(s.as_bytes()).unwrap(),
            "PINAW,12345.6789,0.01235,-1.50000,0.00000,0.1000,-0.2000,-9.8067"
        );
        smp.gyro = Vec3::new(-99.999_99, -99.999_99, -99.999_99);
        smp.accel = Vec3::new(-999.999, -999.999, -999.999);
        let s = pinaw(T_WRAP_S * 1_000_000 - 1, &smp).unwrap();
        assert_eq!(s.len(), 82, "{}", s.as_str());
        smp.gyro = Vec3::new(f32::NAN, 100.0, 1.0);
        smp.accel = Vec3::new(1000.0, f32::INFINITY, 1.0);
        let s = pinaw(T_WRAP_S * 1_000_000 + 5_000, &smp).unwrap();
        assert_eq!(verify(s.as_bytes()).unwrap(), "PINAW,0.0050,,,1.00000,,,1.0000");
        let x = pinax(20_000, Some([20.5, -3.25, 42.0]), Some(12.345_6)).unwrap();
        assert_eq!(verify(x.as_bytes()).unwrap(), "PINAX,0.0200,20.50,-3.25,42.00,12.346");
        let x = pinax(20_000, None, None).unwrap();
        assert_eq!(verify(x.as_bytes()).unwrap(), "PINAX,0.0200,,,,");
        let x = pinax(T_WRAP_S * 1_000_000 - 1, Some([-9999.99; 3]), Some(-9999.999)).unwrap();
        assert!(x.len() <= 82);
    }
}
