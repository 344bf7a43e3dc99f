//! Numbers as text on the command line: a strict decimal parser ([`parse_number`], in
//! `decimal.rs`), an integer parser and a 7-significant-digit writer (no `core::fmt` float
//! formatting, so the host and the Cortex-M3 print the same bytes).

use super::ext::Ext;
use crate::nmea::{NmeaError, Sentence};

/// Significant digits printed by [`push_number`] (an `f32` holds about 7.2).
pub const SIGNIFICANT_DIGITS: u32 = 7;

pub use super::decimal::parse_number;

/// Parse an unsigned decimal integer (digits only, optional leading `+`, at most 9 digits).
pub fn parse_uint(text: &str) -> Option<u32> {
    let digits = text.strip_prefix('+').unwrap_or(text);
    if digits.is_empty() || digits.len() > 9 || !digits.bytes().all(|c| c.is_ascii_digit()) {
        return None;
    }
    Some(digits.bytes().fold(0u32, |n, c| n * 10 + u32::from(c - b'0')))
}

/// Write `v` with [`SIGNIFICANT_DIGITS`] significant digits (rounded half away from zero),
/// trailing zeros removed: plain notation for 1e−5 ≤ |v| < 1e7 (`0.05`, `-12.5`, `1234567`),
/// otherwise `d.dddddde±x` (`2.376e-6`). Zero prints as `0`. At most 13 characters.
pub fn push_number(s: &mut Sentence, v: Ext) -> Result<(), NmeaError> {
    let mut buf = [0u8; 24];
    let n = format_number(v, &mut buf);
    s.push_bytes(buf.get(..n).unwrap_or(&[]))
}

/// [`push_number`] of `v · scale` (`v` an `f32`, `scale` exact as [`Ext`]); NaN and
/// infinities leave the field empty.
pub fn push_scaled(s: &mut Sentence, v: f32, scale: Ext) -> Result<(), NmeaError> {
    if !v.is_finite() {
        return s.push_bytes(&[]);
    }
    push_number(s, Ext::from_f32(v).times(scale))
}

/// [`push_scaled`] with scale 1.
pub fn push_f32(s: &mut Sentence, v: f32) -> Result<(), NmeaError> {
    push_scaled(s, v, Ext::from_u64(1))
}

/// The seven significant digits of `a` (not zero) and the decimal exponent `e` of the first:
/// `a ≈ m · 10^(e−6)`, `10^6 ≤ m < 10^7`.
fn digits7(a: Ext) -> (u32, i32) {
    // 2^k ≤ a < 2^(k+1) and ⌊k · log10 2⌋ (to within one: 78913 / 2^18 = 0.3010292) less
    // one: 10^e ≤ a < 2 · 10^(e+2), so at most three tries.
    let mut e = ((a.log2() * 78_913) >> 18) - 1;
    loop {
        let m = a.scale10(6 - e).round_half_up().unwrap_or(u64::MAX);
        if m < 10_000_000 || e > 400 {
            return (m as u32, e);
        }
        e += 1;
    }
}

/// [`push_number`] into a byte buffer; returns the length.
pub fn format_number(v: Ext, out: &mut [u8; 24]) -> usize {
    let mut w = Writer { out, len: 0 };
    if v.is_zero() {
        w.put(b'0');
        return w.len;
    }
    if v.is_negative() {
        w.put(b'-');
    }
    let (mut m, e) = digits7(v.abs());
    let mut digits = [0u8; SIGNIFICANT_DIGITS as usize];
    for d in digits.iter_mut().rev() {
        *d = b'0' + (m % 10) as u8;
        m /= 10;
    }
    let mut nd = digits.len();
    while nd > 1 && digits.get(nd - 1) == Some(&b'0') {
        nd -= 1;
    }
    let sig = digits.get(..nd).unwrap_or(&[]);
    // Plain notation for 1e−5 ≤ |v| < 1e7, else one digit before the point and an exponent.
    let plain = (-5..7).contains(&e);
    let point = if plain { e } else { 0 };
    if point < 0 {
        w.put(b'0');
        w.put(b'.');
        for _ in 0..(-point - 1) {
            w.put(b'0');
        }
        for &d in sig {
            w.put(d);
        }
    } else {
        let int_len = point as usize + 1;
        for k in 0..nd.max(int_len) {
            if k == int_len {
                w.put(b'.');
            }
            w.put(sig.get(k).copied().unwrap_or(b'0'));
        }
    }
    if !plain {
        w.put(b'e');
        if e < 0 {
            w.put(b'-');
        }
        let ev = e.unsigned_abs();
        if ev >= 100 {
            w.put(b'0' + (ev / 100 % 10) as u8);
        }
        if ev >= 10 {
            w.put(b'0' + (ev / 10 % 10) as u8);
        }
        w.put(b'0' + (ev % 10) as u8);
    }
    w.len
}

struct Writer<'a> {
    out: &'a mut [u8; 24],
    len: usize,
}

impl Writer<'_> {
    fn put(&mut self, b: u8) {
        if let Some(slot) = self.out.get_mut(self.len) {
            *slot = b;
            self.len += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(v: f64) -> String {
        let mut buf = [0u8; 24];
        let n = format_number(Ext::from_f64(v), &mut buf);
        String::from_utf8(buf[..n].to_vec()).unwrap()
    }

    #[test]
    fn numbers_print_with_seven_digits() {
        assert_eq!(text(0.0), "0");
        assert_eq!(text(-0.0), "0");
        assert_eq!(text(0.05), "0.05");
        assert_eq!(text(f64::from(0.05f32)), "0.05");
        assert_eq!(text(-12.5), "-12.5");
        assert_eq!(text(50.0), "50");
        assert_eq!(text(1_234_567.0), "1234567");
        assert_eq!(text(12_345_678.0), "1.234568e7");
        assert_eq!(text(2.376e-6), "2.376e-6");
        assert_eq!(text(1.0e-5), "0.00001");
        assert_eq!(text(9.999_999_9), "10");
        assert_eq!(text(101_325.0), "101325");
        assert_eq!(text(f64::from(f32::MAX)), "3.402823e38");
        assert_eq!(text(-f64::from(f32::MIN_POSITIVE)), "-1.175494e-38");
        assert_eq!(text(1_234_567.5), "1234568");
        assert_eq!(text(1.0e-45), "1e-45");
        let f = |v: f32, scale: f64| {
            let mut s = Sentence::new();
            push_scaled(&mut s, v, Ext::from_f64(scale)).unwrap();
            s.body().to_string()
        };
        assert_eq!(f(f32::NAN, 1.0), "");
        assert_eq!(f(f32::INFINITY, 1.0), "");
        assert_eq!(f(0.25, 4.0), "1");
        assert_eq!(f(-2.5, 1e-3), "-0.0025");
        assert!(text(-1.234_567e-10).len() <= 13);
    }

    #[test]
    fn parsing_is_strict() {
        let parse_number = |t: &str| parse_number(t).map(Ext::to_f64);
        assert_eq!(parse_number("0.05"), Some(0.05));
        assert_eq!(parse_number("-1e3"), Some(-1000.0));
        assert_eq!(parse_number("+.5"), Some(0.5));
        assert_eq!(parse_number("5."), Some(5.0));
        assert_eq!(parse_number("2.376E-6"), Some(2.376e-6));
        for bad in ["", "-", ".", "e5", "1e", "1e+", "inf", "NaN", "0x10", " 1", "1 ", "1,2", "--1"]
        {
            assert_eq!(parse_number(bad), None, "{bad:?}");
        }
        assert_eq!(parse_number("1e999"), Some(f64::INFINITY));
        assert_eq!(parse_uint("50"), Some(50));
        assert_eq!(parse_uint("+7"), Some(7));
        for bad in ["", "-1", "1.0", "1e2", "1234567890", "+"] {
            assert_eq!(parse_uint(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn printed_f32_values_parse_back_within_an_ulp_or_two() {
        let mut x: u32 = 12345;
        for _ in 0..20_000 {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let v = f32::from_bits(x);
            if !v.is_finite() {
                continue;
            }
            let t = text(f64::from(v));
            let back = parse_number(&t).unwrap().to_f32();
            let rel = ((back - v) / v.abs().max(f32::MIN_POSITIVE)).abs();
            assert!(rel <= 1e-6 || back == v, "{v:e} -> {t} -> {back:e}");
        }
    }
}
