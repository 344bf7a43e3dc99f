//! A small fixed-point number writer (no `core::fmt` float formatting).
//!
//! A value is scaled by 10^decimals in `f32`, then rounded half away from zero by integer
//! arithmetic, then printed digit by digit. Every step is exact or correctly-rounded IEEE 754,
//! so the host and the Cortex-M3 print identical bytes. NaN, infinities and values too large to
//! print leave the field empty.

use ekf_core::mathf;

use super::error::NmeaError;
use super::sentence::{hex_digit, Sentence};

/// Most decimals the writers print; larger requests are treated as this.
pub const MAX_DECIMALS: u8 = 6;
const POW10: [u32; MAX_DECIMALS as usize + 1] = [1, 10, 100, 1000, 10_000, 100_000, 1_000_000];

/// Sign style of a printed number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sign {
    /// `-` for negative values only (zero and positive values unsigned).
    MinusOnly,
    /// Always a sign: `+` for zero and positive values, `-` for negative ones.
    Explicit,
}

/// Which interval an angle is printed in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AngleRange {
    /// (−180°, 180°].
    Signed,
    /// [0°, 360°) (a compass heading).
    Heading,
}

fn pow10(decimals: u8) -> u32 {
    POW10.get(usize::from(decimals.min(MAX_DECIMALS))).copied().unwrap_or(1)
}

/// `value · 10^decimals` rounded half away from zero to an integer (the scaling is one `f32`
/// multiplication; the rounding is exact). `None` for NaN, infinities and magnitudes of
/// 4·10^18 or more after scaling.
pub fn round_scaled(value: f32, decimals: u8) -> Option<i64> {
    let s = value * pow10(decimals) as f32;
    if !(mathf::abs(s) < 4.0e18) {
        return None;
    }
    // Below 2^23 (the common case, in `i32`): truncation toward zero, then the fraction,
    // exactly (t and s are within a factor of two, or t = 0). From 2^23 on, s is an integer,
    // exact in `i64`.
    if mathf::abs(s) < 8_388_608.0 {
        let t = s as i32;
        let frac = s - t as f32;
        let t = i64::from(t);
        return Some(if frac >= 0.5 {
            t + 1
        } else if frac <= -0.5 {
            t - 1
        } else {
            t
        });
    }
    Some(s as i64)
}

impl Sentence {
    /// Append the integer `scaled` as a fixed-point number with `decimals` decimals
    /// (`scaled = 12345`, 2 decimals → `123.45`). A zero is never signed negative.
    pub fn push_scaled(&mut self, scaled: i64, decimals: u8, sign: Sign) -> Result<(), NmeaError> {
        let decimals = decimals.min(MAX_DECIMALS);
        let p = u64::from(pow10(decimals));
        let mag = scaled.unsigned_abs();
        let (mut int, mut frac) = (mag / p, mag % p);
        // Sign, 20 integer digits, point, 6 decimals.
        let mut tmp = [0u8; 28];
        let mut i = tmp.len();
        let mut put = |i: &mut usize, b: u8| {
            *i -= 1;
            if let Some(slot) = tmp.get_mut(*i) {
                *slot = b;
            }
        };
        for _ in 0..decimals {
            put(&mut i, b'0' + (frac % 10) as u8);
            frac /= 10;
        }
        if decimals > 0 {
            put(&mut i, b'.');
        }
        loop {
            put(&mut i, b'0' + (int % 10) as u8);
            int /= 10;
            if int == 0 {
                break;
            }
        }
        match (scaled < 0, sign) {
            (true, _) => put(&mut i, b'-'),
            (false, Sign::Explicit) => put(&mut i, b'+'),
            (false, Sign::MinusOnly) => {}
        }
        self.push_bytes(tmp.get(i..).unwrap_or(&[]))
    }

    /// Append `value` with `decimals` decimals, rounded half away from zero; nothing (an empty
    /// field) for NaN, infinities and values beyond ±4·10^18 / 10^decimals.
    pub fn push_fixed(&mut self, value: f32, decimals: u8, sign: Sign) -> Result<(), NmeaError> {
        match round_scaled(value, decimals) {
            Some(n) => self.push_scaled(n, decimals, sign),
            None => self.push_bytes(&[]),
        }
    }

    /// Append an angle given in rad as degrees with `decimals` decimals, in `range`. The
    /// wrap is applied after rounding, so 359.996° prints as `0.00` and −179.996° as
    /// `180.00`. Nothing (an empty field) for NaN and infinities.
    pub fn push_angle_deg(
        &mut self,
        rad: f32,
        decimals: u8,
        range: AngleRange,
        sign: Sign,
    ) -> Result<(), NmeaError> {
        let decimals = decimals.min(MAX_DECIMALS);
        let Some(n) = round_scaled(mathf::to_deg(mathf::wrap_pi(rad)), decimals) else {
            return self.push_bytes(&[]);
        };
        let turn = 360 * i64::from(pow10(decimals));
        let mut n = n.rem_euclid(turn);
        if range == AngleRange::Signed && n > turn / 2 {
            n -= turn;
        }
        self.push_scaled(n, decimals, sign)
    }

    /// Append an unsigned integer in decimal.
    pub fn push_uint(&mut self, value: u64) -> Result<(), NmeaError> {
        // `value` < 2^64 fits i64 only below 2^63: print the halves of larger ones.
        match i64::try_from(value) {
            Ok(v) => self.push_scaled(v, 0, Sign::MinusOnly),
            Err(_) => {
                self.push_scaled((value / 10) as i64, 0, Sign::MinusOnly)?;
                self.push_scaled((value % 10) as i64, 0, Sign::MinusOnly)
            }
        }
    }

    /// Append the low `digits` hex digits (at most 8) of `value`, uppercase, zero-padded.
    pub fn push_hex(&mut self, value: u32, digits: u8) -> Result<(), NmeaError> {
        let digits = usize::from(digits.min(8));
        let mut tmp = [0u8; 8];
        for (k, slot) in tmp.iter_mut().take(digits).enumerate() {
            let shift = 4 * (digits - 1 - k);
            *slot = hex_digit((value >> shift) as u8);
        }
        self.push_bytes(tmp.get(..digits).unwrap_or(&[]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixed(v: f32, d: u8, sign: Sign) -> Sentence {
        let mut s = Sentence::new();
        s.push_fixed(v, d, sign).unwrap();
        s
    }

    fn body(v: f32, d: u8, sign: Sign) -> String {
        fixed(v, d, sign).body().to_string()
    }

    #[test]
    fn rounding_half_away_from_zero() {
        assert_eq!(round_scaled(0.125, 2), Some(13));
        assert_eq!(round_scaled(-0.125, 2), Some(-13));
        assert_eq!(round_scaled(0.124, 2), Some(12));
        assert_eq!(round_scaled(2.5, 0), Some(3));
        assert_eq!(round_scaled(-2.5, 0), Some(-3));
        assert_eq!(round_scaled(0.499_999_97, 0), Some(0));
        assert_eq!(round_scaled(8_388_609.0, 0), Some(8_388_609));
        assert_eq!(round_scaled(f32::NAN, 2), None);
        assert_eq!(round_scaled(f32::INFINITY, 2), None);
        assert_eq!(round_scaled(1.0e17, 2), None);
        assert_eq!(round_scaled(-8_388_608.0, 0), Some(-8_388_608));
        assert_eq!(round_scaled(8_388_607.5, 0), Some(8_388_608));
        assert_eq!(round_scaled(2_305_843_009_213_693_952.0, 0), Some(1 << 61));
        assert_eq!(round_scaled(-1.0e12, 0), Some(-999_999_995_904));
        // Against the f64 route, over the whole range.
        let mut x: u32 = 99;
        for _ in 0..200_000 {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let v = f32::from_bits(x);
            let s = v * 100.0;
            let want = (mathf::abs(s) < 4.0e18).then(|| {
                let r = f64::from(s).abs().floor()
                    + if f64::from(s).abs().fract() >= 0.5 { 1.0 } else { 0.0 };
                (r.copysign(f64::from(s))) as i64
            });
            assert_eq!(round_scaled(v, 2), want, "{v:e}");
        }
    }

    #[test]
    fn fixed_point_text() {
        assert_eq!(body(1.234, 2, Sign::Explicit), "+1.23");
        assert_eq!(body(-0.449, 2, Sign::Explicit), "-0.45");
        assert_eq!(body(-0.0, 2, Sign::Explicit), "+0.00");
        assert_eq!(body(-0.004, 2, Sign::Explicit), "+0.00");
        assert_eq!(body(-0.004, 2, Sign::MinusOnly), "0.00");
        assert_eq!(body(0.000_05, 4, Sign::MinusOnly), "0.0001");
        assert_eq!(body(-1.0, 4, Sign::MinusOnly), "-1.0000");
        assert_eq!(body(123_456.7, 1, Sign::MinusOnly), "123456.7");
        assert_eq!(body(42.0, 0, Sign::MinusOnly), "42");
        assert_eq!(body(0.5, 9, Sign::MinusOnly), "0.500000");
        assert_eq!(body(f32::NAN, 2, Sign::Explicit), "");
        assert_eq!(body(f32::NEG_INFINITY, 2, Sign::Explicit), "");
    }

    #[test]
    fn angles_wrap_after_rounding() {
        let a = |deg: f32, range| {
            let mut s = Sentence::new();
            s.push_angle_deg(mathf::deg(deg), 2, range, Sign::MinusOnly).unwrap();
            s.body().to_string()
        };
        assert_eq!(a(-0.004, AngleRange::Heading), "0.00");
        assert_eq!(a(-0.006, AngleRange::Heading), "359.99");
        assert_eq!(a(-90.0, AngleRange::Heading), "270.00");
        assert_eq!(a(180.0, AngleRange::Heading), "180.00");
        assert_eq!(a(-180.0, AngleRange::Signed), "180.00");
        assert_eq!(a(-179.996, AngleRange::Signed), "180.00");
        assert_eq!(a(-179.99, AngleRange::Signed), "-179.99");
        assert_eq!(a(725.0, AngleRange::Signed), "5.00");
        assert_eq!(a(f32::NAN, AngleRange::Signed), "");
    }

    #[test]
    fn integers_and_hex() {
        let mut s = Sentence::new();
        s.push_uint(0).unwrap();
        s.push_str(",").unwrap();
        s.push_uint(u64::MAX).unwrap();
        s.push_str(",").unwrap();
        s.push_hex(0x2A0F, 4).unwrap();
        s.push_str(",").unwrap();
        s.push_hex(0xDEAD_BEEF, 8).unwrap();
        s.push_str(",").unwrap();
        s.push_hex(0xF_FFFF, 5).unwrap();
        assert_eq!(s.body(), "0,18446744073709551615,2A0F,DEADBEEF,FFFFF");
    }
}
