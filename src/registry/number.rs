//! Numbers as text on the command line: a strict decimal parser ([`parse_number`]), an integer
//! parser ([`parse_uint`]) and a 7-significant-digit writer ([`push_number`]).
//!
//! Both float routines are short scaled-integer code in `f64`: the digits of a number become an
//! integer and a power of ten, and back. core has both routines, but neither fits here:
//! `str::parse::<f64>` and `core::fmt`'s float formatting each link panic paths (bounds checks
//! and assertions the optimiser keeps; the no-panic proof of `scripts/size-report` fails with
//! either), and `core::fmt` rounds ties to even where this writer rounds them away from zero.
//! `f64` arithmetic is IEEE 754 on the host and in the Cortex-M3's soft-float library alike, so
//! both print the same bytes.

use crate::nmea::{NmeaError, Sentence};

/// Significant digits printed by [`push_number`] (an `f32` holds about 7.2).
pub const SIGNIFICANT_DIGITS: u32 = 7;

/// Most significant digits the parser keeps (10^19 − 1 < 2^64); further ones are dropped.
const MAX_DIGITS: u32 = 19;

/// 10^0 … 10^22, every one exact in `f64`.
const POW10: [f64; 23] = {
    let mut p = [1.0; 23];
    let mut k = 1;
    while k < p.len() {
        p[k] = p[k - 1] * 10.0;
        k += 1;
    }
    p
};

/// `x · 10^k`: one multiplication or division by an exact power for |k| ≤ 22 (correctly
/// rounded), one more per further 22 decades (|k| is taken at most 800: for every `x` used
/// here, beyond that the value is infinite or zero).
fn scale10(mut x: f64, k: i32) -> f64 {
    let mut k = k.clamp(-800, 800);
    while k > 22 {
        x *= 1e22;
        k -= 22;
    }
    while k < -22 {
        x /= 1e22;
        k += 22;
    }
    let p = POW10.get(k.unsigned_abs() as usize).copied().unwrap_or(1.0);
    if k < 0 {
        x / p
    } else {
        x * p
    }
}

/// Parse a decimal number: optional sign, digits with an optional `.` (at least one digit in
/// all), optional exponent (`e`/`E`, optional sign, at least one digit). `None` for anything
/// else (`inf`, `nan`, hex, spaces, empty). A number too large for `f64` parses as infinite,
/// one too small as zero; the caller checks the range.
///
/// The first 19 significant digits make an integer `m`, the value is `m · 10^e` (by exact
/// powers of ten): with at most 15 significant digits and |e| ≤ 22 (the numbers an operator
/// types) that is one correctly rounded operation, the `f64` nearest the decimal, as
/// `str::parse::<f64>` gives; otherwise, in `f32`'s range, within a few units in the last
/// place of `f64`.
pub fn parse_number(text: &str) -> Option<f64> {
    Decimal::parse(text).map(Decimal::value)
}

/// A decimal number as typed: `±m · 10^exp10`, `m` its first 19 significant digits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Decimal {
    negative: bool,
    m: u64,
    exp10: i32,
}

impl Decimal {
    /// [`parse_number`]'s grammar; the digits kept exactly.
    pub fn parse(text: &str) -> Option<Decimal> {
        let (negative, body) = match text.as_bytes() {
            [b'-', rest @ ..] => (true, rest),
            [b'+', rest @ ..] => (false, rest),
            all => (false, all),
        };
        let mut rest = body;
        let (mut m, mut kept, mut exp10, mut digits, mut fraction) =
            (0u64, 0u32, 0i32, 0u32, false);
        while let Some(c) = take(&mut rest, move |c| c.is_ascii_digit() || (c == b'.' && !fraction))
        {
            if c == b'.' {
                fraction = true;
                continue;
            }
            digits += 1;
            if kept < MAX_DIGITS {
                m = m * 10 + u64::from(c - b'0');
                kept += u32::from(m > 0);
                exp10 = exp10.saturating_sub(i32::from(fraction));
            } else if !fraction {
                // A dropped integer digit still scales the value.
                exp10 = exp10.saturating_add(1);
            }
        }
        if digits == 0 {
            return None;
        }
        if take(&mut rest, |c| c == b'e' || c == b'E').is_some() {
            let exp_negative = take(&mut rest, |c| c == b'+' || c == b'-') == Some(b'-');
            let (mut e, mut exp_digits) = (0i32, 0);
            while let Some(c) = take(&mut rest, |c| c.is_ascii_digit()) {
                // Beyond ±400 decades the value is infinite or zero anyway.
                e = (e * 10 + i32::from(c - b'0')).min(400);
                exp_digits += 1;
            }
            if exp_digits == 0 {
                return None;
            }
            exp10 = exp10.saturating_add(if exp_negative { -e } else { e });
        }
        if !rest.is_empty() {
            return None;
        }
        Some(Decimal { negative, m, exp10 })
    }

    /// The `f64` value (see [`parse_number`]).
    pub fn value(self) -> f64 {
        let magnitude = scale10(self.m as f64, self.exp10);
        if self.negative {
            -magnitude
        } else {
            magnitude
        }
    }

    /// The seven significant digits, rounded half away from zero exactly (integer arithmetic on
    /// the digits as typed; see [`digits7`]); `None` for zero.
    fn digits7(self) -> Option<(u64, i32)> {
        // n digits, n ≤ 19.
        let n = self.m.checked_ilog10()? as i32 + 1;
        let (m, e) = (self.m, self.exp10.saturating_add(n - 1));
        let m = if n > 7 {
            let p = 10u64.pow((n - 7) as u32);
            let (q, r) = (m.checked_div(p)?, m.checked_rem(p)?);
            q + u64::from(r >= p / 2)
        } else {
            m * 10u64.pow((7 - n) as u32)
        };
        Some(if m == 10_000_000 { (1_000_000, e.saturating_add(1)) } else { (m, e) })
    }
}

/// The first byte of `rest`, consumed, if `accept` takes it.
fn take(rest: &mut &[u8], accept: impl Fn(u8) -> bool) -> Option<u8> {
    match rest.split_first() {
        Some((&c, tail)) if accept(c) => {
            *rest = tail;
            Some(c)
        }
        _ => None,
    }
}

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
/// otherwise `d.dddddde±x` (`2.376e-6`). Zero prints as `0`; NaN and infinities print
/// nothing (an empty field). At most 14 characters (`-0.00001234567`).
pub fn push_number(s: &mut Sentence, v: f64) -> Result<(), NmeaError> {
    let mut buf = [0u8; 24];
    let n = format_number(v, &mut buf);
    s.push_bytes(buf.get(..n).unwrap_or(&[]))
}

/// [`push_number`] of `v · scale` (`v` an `f32`, exact in `f64`; one rounding).
pub fn push_scaled(s: &mut Sentence, v: f32, scale: f64) -> Result<(), NmeaError> {
    push_number(s, f64::from(v) * scale)
}

/// [`push_number`] of an `f32`.
pub fn push_f32(s: &mut Sentence, v: f32) -> Result<(), NmeaError> {
    push_number(s, f64::from(v))
}

/// The seven significant digits of `a` (finite, above zero) and the decimal exponent `e` of the
/// first: `a ≈ m · 10^(e−6)`, `10^6 ≤ m < 10^7`, `m` rounded half up.
fn digits7(a: f64) -> (u64, i32) {
    // 2^k ≤ a < 2^(k+1) and ⌊k · log10 2⌋ (to within one: 78913 / 2^18 = 0.3010292) less
    // one: 10^e ≤ a < 2 · 10^(e+2), so at most three tries.
    let k = ((a.to_bits() >> 52) & 0x7FF) as i32 - 1023;
    let mut e = ((k * 78_913) >> 18) - 1;
    loop {
        let y = scale10(a, 6 - e);
        let int = y as u64;
        // Exact: y < 2^53, so its integer part and fraction are representable.
        let m = int.saturating_add(u64::from(y - int as f64 >= 0.5));
        if m < 10_000_000 || e > 400 {
            return (m, e);
        }
        e += 1;
    }
}

/// [`push_number`] into a byte buffer; returns the length.
pub fn format_number(v: f64, out: &mut [u8; 24]) -> usize {
    if !v.is_finite() {
        return 0;
    }
    layout(v < 0.0, (v != 0.0).then(|| digits7(v.abs())), out)
}

/// A typed number with [`SIGNIFICANT_DIGITS`] significant digits, as [`push_number`] but
/// rounded exactly from the digits typed (`99.708795` → `99.7088`, where the `f64` read may lie
/// on either side of the tie).
pub fn push_decimal(s: &mut Sentence, d: Decimal) -> Result<(), NmeaError> {
    let mut buf = [0u8; 24];
    let n = layout(d.negative, d.digits7(), &mut buf);
    s.push_bytes(buf.get(..n).unwrap_or(&[]))
}

/// The text of the digits `m` (`10^6 ≤ m < 10^7`) with the decimal exponent `e` of the first
/// ([`push_number`]'s notation), or `0` for `None`; returns the length.
fn layout(negative: bool, digits7: Option<(u64, i32)>, out: &mut [u8; 24]) -> usize {
    let mut w = Writer { out, len: 0 };
    let Some((mut m, e)) = digits7 else {
        w.put(b'0');
        return w.len;
    };
    if negative {
        w.put(b'-');
    }
    let mut digits = [0u8; SIGNIFICANT_DIGITS as usize];
    for d in digits.iter_mut().rev() {
        *d = b'0' + (m % 10) as u8;
        m /= 10;
    }
    let nd = digits.iter().rposition(|&d| d != b'0').map_or(1, |k| k + 1);
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
    use crate::test_rng::TestRng;

    fn text(v: f64) -> String {
        let mut buf = [0u8; 24];
        let n = format_number(v, &mut buf);
        String::from_utf8(buf[..n].to_vec()).unwrap()
    }

    /// The independent truth: `v`'s exact decimal expansion (std prints every digit of an
    /// `f64` with 800 decimals), rounded to 7 significant digits half away from zero:
    /// `(digits, exponent of the first)`.
    fn exact_digits7(v: f64) -> (String, i32) {
        let s = format!("{:.800e}", v.abs());
        let (mant, exp) = s.split_once('e').unwrap();
        let mut e: i32 = exp.parse().unwrap();
        let digits: Vec<u8> = mant.bytes().filter(u8::is_ascii_digit).collect();
        let mut m: u64 = digits[..7].iter().fold(0, |m, &d| m * 10 + u64::from(d - b'0'));
        if digits[7] >= b'5' {
            m += 1;
        }
        if m == 10_000_000 {
            m = 1_000_000;
            e += 1;
        }
        (m.to_string().trim_end_matches('0').to_string(), e)
    }

    /// The digits and exponent of a text of `format_number`.
    fn read_digits(t: &str) -> (String, i32) {
        let t = t.trim_start_matches('-');
        let (mant, exp) = t.split_once('e').unwrap_or((t, "0"));
        let digits: String = mant.chars().filter(|c| *c != '.').collect();
        let lead = digits.len() - digits.trim_start_matches('0').len();
        let int_len = mant.find('.').unwrap_or(mant.len()) as i32;
        let e = exp.parse::<i32>().unwrap() + int_len - 1 - lead as i32;
        (digits.trim_matches('0').to_string(), e)
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
        assert_eq!(text(9.999_999e-6), "9.999999e-6");
        assert_eq!(text(9_999_999.0), "9999999");
        assert_eq!(text(9_999_999.5), "1e7");
        assert_eq!(text(9.999_999_9), "10");
        assert_eq!(text(101_325.0), "101325");
        assert_eq!(text(f64::from(f32::MAX)), "3.402823e38");
        assert_eq!(text(-f64::from(f32::MIN_POSITIVE)), "-1.175494e-38");
        assert_eq!(text(1.0e-45), "1e-45");
        assert_eq!(text(1.0e-300), "1e-300");
        assert_eq!(text(-1.234_567e-10), "-1.234567e-10");
        assert_eq!(text(f64::NAN), "");
        assert_eq!(text(f64::NEG_INFINITY), "");
        // Ties (exact in binary) are rounded away from zero, not to even.
        assert_eq!(text(1_234_567.5), "1234568");
        assert_eq!(text(1_234_566.5), "1234567");
        assert_eq!(text(-1_234_566.5), "-1234567");
        assert_eq!(text(12_345_665.0), "1.234567e7");
        assert_eq!(text(0.123_456_75), "0.1234568");
        let f = |v: f32, scale: f64| {
            let mut s = Sentence::new();
            push_scaled(&mut s, v, scale).unwrap();
            s.body().to_string()
        };
        assert_eq!(f(f32::NAN, 1.0), "");
        assert_eq!(f(f32::INFINITY, 1.0), "");
        assert_eq!(f(0.25, 4.0), "1");
        assert_eq!(f(-2.5, 1e-3), "-0.0025");
    }

    /// Every finite `f32` (random bits), unscaled and in each unit of the registry: the text
    /// is the exact value rounded half away from zero, at most 13 characters.
    #[test]
    fn printed_digits_are_the_exact_value_rounded_half_away() {
        let mut rng = TestRng::new(18);
        let scales = crate::registry::Scale::ALL.map(crate::registry::Scale::factor);
        let mut checked = 0;
        while checked < 20_000 {
            let v = f32::from_bits(rng.next_u64() as u32);
            if !v.is_finite() || v == 0.0 {
                continue;
            }
            checked += 1;
            for scale in scales {
                let x = f64::from(v) * scale;
                let t = text(x);
                assert!(t.len() <= 14, "{t}");
                assert_eq!(t.starts_with('-'), x < 0.0, "{t}");
                assert_eq!(read_digits(&t), exact_digits7(x), "{v:e} · {scale}: {t}");
            }
        }
    }

    #[test]
    fn parsing_is_strict() {
        assert_eq!(parse_number("0.05"), Some(0.05));
        assert_eq!(parse_number("-1e3"), Some(-1000.0));
        assert_eq!(parse_number("+.5"), Some(0.5));
        assert_eq!(parse_number(".5"), Some(0.5));
        assert_eq!(parse_number("5."), Some(5.0));
        assert_eq!(parse_number("-0"), Some(0.0));
        assert_eq!(parse_number("2.376E-6"), Some(2.376e-6));
        assert_eq!(parse_number("1e+3"), Some(1000.0));
        for bad in [
            "", "-", "+", ".", "-.", "e5", ".e5", "1e", "1e+", "1e-", "inf", "-inf", "NaN", "nan",
            "infinity", "0x10", " 1", "1 ", "1,2", "--1", "+-1", "1.2.3", "1e5.5", "1e5e5",
            "1e+-5", "١", "1_000",
        ] {
            assert_eq!(parse_number(bad), None, "{bad:?}");
        }
        assert_eq!(parse_number("1e999"), Some(f64::INFINITY));
        assert_eq!(parse_number("-1e999"), Some(f64::NEG_INFINITY));
        assert_eq!(parse_number("1e-999"), Some(0.0));
        assert_eq!(parse_number("1e99999999999"), Some(f64::INFINITY));
        assert_eq!(parse_number("1e-99999999999"), Some(0.0));
        assert_eq!(
            parse_number("123456789012345678901234567890"),
            Some(1.234_567_890_123_456_8e29)
        );
        // Twenty significant digits: the twentieth is dropped (with it the digits would
        // overflow their `u64`) and still scales the value.
        assert_eq!(parse_number("99999999999999999999"), Some(1e20));
        assert_eq!(parse_number("18446744073709551616"), Some(18_446_744_073_709_551_616.0));
        assert_eq!(parse_number("18446744073709551616"), "18446744073709551616".parse().ok());
        assert_eq!(parse_number(&format!("0.{}1", "0".repeat(70))).map(|v| v as f32), Some(0.0));
        assert_eq!(parse_number(&format!("0.{}1", "0".repeat(40))).map(|v| v as f32), Some(1e-41));
        assert_eq!(parse_uint("50"), Some(50));
        assert_eq!(parse_uint("+7"), Some(7));
        assert_eq!(parse_uint("999999999"), Some(999_999_999));
        for bad in ["", "-1", "1.0", "1e2", "1234567890", "+", " 1", "0x1"] {
            assert_eq!(parse_uint(bad), None, "{bad:?}");
        }
    }

    /// What an operator types (up to 15 significant digits, |exponent| ≤ 22 after the digits
    /// are taken) gives the `f64` nearest the decimal, as core's parser; the `f32` the
    /// settings keep is then core's `f32` for up to 8 digits.
    #[test]
    fn typed_numbers_match_core() {
        for t in [
            "0", "0.05", "-12.5", "2.376e-6", "9.80665", "101325", "0.29725", "-0.196", "0.0803",
            "3.33", "3.752", "1e9", "1e-9", "16.2", "0.337", "0.00419", "4e-6", "1e22", "0.1",
            "0.7", "16777217", "1e-22",
        ] {
            assert_eq!(parse_number(t), Some(t.parse::<f64>().unwrap()), "{t}");
        }
        // Beyond: several operations, the `f32` still core's.
        for t in ["3.4028235e38", "1.17549435e-38", "1.4e-45", "9007199254740993", "1e-30"] {
            assert_eq!(parse_number(t).map(|v| v as f32), Some(t.parse::<f32>().unwrap()), "{t}");
        }
        let mut rng = TestRng::new(1818);
        for _ in 0..50_000 {
            let digits = 1 + rng.below(15) as u32;
            let m = rng.next_u64() % 10u64.pow(digits);
            let e = rng.below(45) as i32 - 22;
            let t = format!("{}{m}e{e}", if rng.below(2) == 0 { "-" } else { "" });
            let v = parse_number(&t).unwrap();
            assert_eq!(v, t.parse::<f64>().unwrap(), "{t}");
            if digits <= 8 {
                assert_eq!(v as f32, t.parse::<f32>().unwrap(), "{t}");
            }
        }
    }

    fn echo(t: &str) -> String {
        let mut s = Sentence::new();
        push_decimal(&mut s, Decimal::parse(t).unwrap()).unwrap();
        s.body().to_string()
    }

    /// A typed number is echoed rounded from its digits: ties away from zero, whichever side
    /// of the tie its `f64` lies; otherwise as the `f64` prints.
    #[test]
    fn typed_numbers_echo_exactly() {
        for (t, want) in [
            ("0", "0"),
            ("-0.0", "0"),
            ("123", "123"),
            ("1e-7", "1e-7"),
            ("-12.5", "-12.5"),
            ("99.708795", "99.7088"),
            ("-615.00765", "-615.0077"),
            ("41307.145", "41307.15"),
            ("0.000012345675", "0.00001234568"),
            ("4.99999995", "5"),
            ("4.99999949999", "4.999999"),
            ("9999999.5", "1e7"),
            ("12345678901234567890123", "1.234568e22"),
            ("0.000000000000000000000000000000123456749", "1.234567e-31"),
        ] {
            assert_eq!(echo(t), want, "{t}");
        }
        let mut rng = TestRng::new(99);
        for _ in 0..50_000 {
            let digits = 1 + rng.below(15) as u32;
            let m = rng.next_u64() % 10u64.pow(digits);
            let e = rng.below(31) as i32 - 15;
            let t = format!("{}{m}e{e}", if rng.below(2) == 0 { "-" } else { "" });
            let rest = m % 10u64.pow(digits.saturating_sub(7));
            let tie = digits > 7 && rest == 5 * 10u64.pow(digits - 8);
            if !tie {
                assert_eq!(echo(&t), text(parse_number(&t).unwrap()), "{t}");
            }
        }
    }

    #[test]
    fn printed_f32_values_parse_back() {
        let mut rng = TestRng::new(7);
        for _ in 0..20_000 {
            let v = f32::from_bits(rng.next_u64() as u32);
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
