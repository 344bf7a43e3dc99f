//! Numbers as text on the command line: a strict decimal parser ([`parse_number`], in
//! `decimal.rs`), an integer parser and a 7-significant-digit writer (no `core::fmt` float
//! formatting, so the host and the Cortex-M3 print the same bytes).

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

/// Write `v` with [`SIGNIFICANT_DIGITS`] significant digits, trailing zeros removed: plain
/// notation for 1e−5 ≤ |v| < 1e7 (`0.05`, `-12.5`, `1234567`), otherwise `d.dddddde±x`
/// (`2.376e-6`). Zero prints as `0`; NaN and infinities leave the field empty. At most 13
/// characters.
pub fn push_number(s: &mut Sentence, v: f64) -> Result<(), NmeaError> {
    let mut buf = [0u8; 24];
    let n = format_number(v, &mut buf);
    s.push_bytes(buf.get(..n).unwrap_or(&[]))
}

/// [`push_number`] into a byte buffer; returns the length.
pub fn format_number(v: f64, out: &mut [u8; 24]) -> usize {
    let mut w = Writer { out, len: 0 };
    if !v.is_finite() {
        return 0;
    }
    if v == 0.0 {
        w.put(b'0');
        return w.len;
    }
    if v < 0.0 {
        w.put(b'-');
    }
    let mut a = if v < 0.0 { -v } else { v };
    // 10^e ≤ a < 10^(e+1), by repeated scaling (f64 error far below the 7 digits kept).
    let mut e: i32 = 0;
    while a >= 10.0 && e < 400 {
        a /= 10.0;
        e += 1;
    }
    while a < 1.0 && e > -400 {
        a *= 10.0;
        e -= 1;
    }
    let scale = 10u64.pow(SIGNIFICANT_DIGITS - 1);
    let mut m = (a * scale as f64 + 0.5) as u64;
    if m >= scale * 10 {
        m /= 10;
        e += 1;
    }
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
    if (-5..7).contains(&e) {
        if e >= 0 {
            let int_len = e as usize + 1;
            for k in 0..int_len {
                w.put(sig.get(k).copied().unwrap_or(b'0'));
            }
            if nd > int_len {
                w.put(b'.');
                for &d in sig.iter().skip(int_len) {
                    w.put(d);
                }
            }
        } else {
            w.put(b'0');
            w.put(b'.');
            for _ in 0..(-e - 1) {
                w.put(b'0');
            }
            for &d in sig {
                w.put(d);
            }
        }
    } else {
        w.put(sig.first().copied().unwrap_or(b'0'));
        if nd > 1 {
            w.put(b'.');
            for &d in sig.iter().skip(1) {
                w.put(d);
            }
        }
        w.put(b'e');
        if e < 0 {
            w.put(b'-');
        }
        let mut ebuf = [0u8; 3];
        let mut ev = e.unsigned_abs();
        let mut k = 0;
        loop {
            if let Some(slot) = ebuf.get_mut(k) {
                *slot = b'0' + (ev % 10) as u8;
            }
            k += 1;
            ev /= 10;
            if ev == 0 || k == ebuf.len() {
                break;
            }
        }
        for &d in ebuf.get(..k).unwrap_or(&[]).iter().rev() {
            w.put(d);
        }
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
        let n = format_number(v, &mut buf);
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
        assert_eq!(text(f64::NAN), "");
        assert!(text(-1.234_567e-10).len() <= 13);
    }

    #[test]
    fn parsing_is_strict() {
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
            let back = parse_number(&t).unwrap() as f32;
            let rel = ((back - v) / v.abs().max(f32::MIN_POSITIVE)).abs();
            assert!(rel <= 1e-6 || back == v, "{v:e} -> {t} -> {back:e}");
        }
    }
}
