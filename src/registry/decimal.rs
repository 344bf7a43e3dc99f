//! A small decimal-to-binary number parser for the command line, in place of core's
//! `str::parse::<f64>` (whose correctly rounding algorithm and its 10 KB table of powers of five
//! do not fit the firmware's flash budget).
//!
//! Method: the significant digits become an integer mantissa `m` (`u64`, at most 19 digits;
//! further digits are dropped, a relative error below 1e−18) and a decimal exponent `e`; the
//! value is `m · 10^e` computed in `f64` with exact powers of ten `10^0 … 10^22`: one
//! multiplication or division when `|e| ≤ 22` (then correctly rounded whenever `m < 2^53`,
//! i.e. for up to 15 significant digits), else repeated steps of `10^22`.
//!
//! Accuracy: every step rounds once (half an ulp of `f64`): the mantissa conversion (exact
//! below 2^53), then one operation per power of ten. Any number in `f32`'s range written with
//! at most 19 significant digits needs at most three operations (|e| ≤ 66): relative error
//! below 2 ulp of `f64` (< 4.5e−16), tested against `str::parse::<f64>`. Converted to `f32`
//! (what the settings store) the result equals `str::parse::<f32>` except when the decimal
//! lies within that error of the midpoint between two `f32` values (double rounding); then it
//! is the other neighbour: at most 1 ulp of `f32` off (tested, with a proptest). Decimals of
//! up to 15 significant digits with |e| ≤ 22 are correctly rounded (one operation).

/// Powers of ten exact in `f64`: 10^k = 5^k · 2^k is exact while 5^k < 2^53, i.e. k ≤ 22.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Most significant digits kept in the mantissa (10^19 − 1 < 2^64).
const MAX_DIGITS: u32 = 19;

/// Parse a decimal number: optional sign, digits with an optional `.` (at least one digit in
/// all), optional exponent (`e`/`E`, optional sign, at least one digit). `None` for anything
/// else (`inf`, `nan`, hex, spaces, empty). A number too large for `f64` parses as infinite,
/// one too small as zero; the caller checks the range.
pub fn parse_number(text: &str) -> Option<f64> {
    let b = text.as_bytes();
    let mut i = 0;
    let at = |i: usize| b.get(i).copied();
    let negative = at(0) == Some(b'-');
    if matches!(at(0), Some(b'+' | b'-')) {
        i += 1;
    }
    let mut mantissa: u64 = 0;
    let mut kept: u32 = 0;
    let mut exp10: i32 = 0;
    let mut digits = 0;
    let mut fraction = false;
    loop {
        match at(i) {
            Some(c @ b'0'..=b'9') => {
                digits += 1;
                let d = u64::from(c - b'0');
                if kept < MAX_DIGITS {
                    if mantissa > 0 || d > 0 {
                        kept += 1;
                    }
                    mantissa = mantissa * 10 + d;
                    if fraction {
                        exp10 = exp10.saturating_sub(1);
                    }
                } else if !fraction {
                    // A dropped integer digit still scales the value.
                    exp10 = exp10.saturating_add(1);
                }
            }
            Some(b'.') if !fraction => fraction = true,
            _ => break,
        }
        i += 1;
    }
    if digits == 0 {
        return None;
    }
    if matches!(at(i), Some(b'e' | b'E')) {
        i += 1;
        let exp_negative = at(i) == Some(b'-');
        if matches!(at(i), Some(b'+' | b'-')) {
            i += 1;
        }
        let mut e: i32 = 0;
        let mut exp_digits = 0;
        while let Some(c @ b'0'..=b'9') = at(i) {
            // Beyond ±99999 the value is infinite or zero anyway.
            e = (e * 10 + i32::from(c - b'0')).min(99_999);
            exp_digits += 1;
            i += 1;
        }
        if exp_digits == 0 {
            return None;
        }
        exp10 = exp10.saturating_add(if exp_negative { -e } else { e });
    }
    if i != b.len() {
        return None;
    }
    let magnitude = scale(mantissa, exp10);
    Some(if negative { -magnitude } else { magnitude })
}

/// `m · 10^e` in `f64`.
fn scale(m: u64, mut e: i32) -> f64 {
    let mut v = m as f64;
    if m == 0 {
        return 0.0;
    }
    while e > 22 {
        v *= POW10[22];
        e -= 22;
        if v.is_infinite() {
            return v;
        }
    }
    while e < -22 {
        v /= POW10[22];
        e += 22;
        if v == 0.0 {
            return v;
        }
    }
    let p = POW10.get(e.unsigned_abs() as usize).copied().unwrap_or(1.0);
    if e >= 0 {
        v * p
    } else {
        v / p
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// `f32` values one unit in the last place apart count as 1.
    fn ulps_f32(a: f32, b: f32) -> u32 {
        if a == b {
            return 0;
        }
        let (x, y) = (a.to_bits() as i64, b.to_bits() as i64);
        if (x < 0) != (y < 0) || a.signum() != b.signum() {
            return u32::MAX;
        }
        (x - y).unsigned_abs() as u32
    }

    /// Checks one text against core's correctly rounded parsers.
    fn check(text: &str) {
        let ours = parse_number(text).unwrap_or_else(|| panic!("{text:?} refused"));
        let exact: f64 = text.parse().unwrap();
        if exact.is_finite() && exact.abs() >= f64::MIN_POSITIVE {
            let rel = ((ours - exact) / exact).abs();
            assert!(rel <= 4.0 * f64::EPSILON, "{text}: {ours:e} vs {exact:e}");
        } else if exact.is_infinite() {
            assert!(ours.is_infinite() || ours.abs() >= f64::MAX / 4.0, "{text}: {ours:e}");
        }
        let want32: f32 = text.parse().unwrap();
        let got32 = ours as f32;
        if want32.is_finite() && got32.is_finite() {
            assert!(ulps_f32(got32, want32) <= 1, "{text}: f32 {got32:e} vs {want32:e}");
        }
    }

    #[test]
    fn matches_core_on_typical_command_values() {
        for t in [
            "0",
            "-0",
            "0.05",
            "-12.5",
            "+.5",
            "5.",
            "2.376e-6",
            "2.376E-6",
            "1e3",
            "-1e-3",
            "9.80665",
            "101325",
            "1212121",
            "0.29725",
            "-0.196",
            "0.0803",
            "3.33",
            "3.752",
            "1e9",
            "1e-9",
            "16.2",
            "0.337",
            "0.00419",
            "4e-6",
            "1e22",
            "1e23",
            "1e-22",
            "1e-23",
            "123456789012345678901234567890",
            "0.000000000000000000000000000001234",
            "3.4028235e38",
            "1.17549435e-38",
            "1.4e-45",
            "1797693134862315700e289",
            "0.1",
            "0.2",
            "0.3",
            "0.7",
            "33554431",
            "16777217",
            "9007199254740993",
        ] {
            check(t);
        }
        assert_eq!(parse_number("0.05"), Some(0.05));
        assert_eq!(parse_number("-1e3"), Some(-1000.0));
        assert_eq!(parse_number("1e999"), Some(f64::INFINITY));
        assert_eq!(parse_number("-1e999"), Some(f64::NEG_INFINITY));
        assert_eq!(parse_number("1e-999"), Some(0.0));
        assert_eq!(parse_number("1e99999999999"), Some(f64::INFINITY));
    }

    #[test]
    fn refuses_what_is_not_a_plain_decimal() {
        for bad in [
            "", "-", "+", ".", "-.", "e5", ".e5", "1e", "1e+", "1e-", "inf", "NaN", "infinity",
            "0x10", " 1", "1 ", "1,2", "--1", "+-1", "1.2.3", "1e5.5", "1e5e5", "١",
        ] {
            assert_eq!(parse_number(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn up_to_fifteen_digits_with_small_exponents_are_correctly_rounded() {
        let mut x: u64 = 0x1234_5678_9abc_def1;
        for _ in 0..50_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let m = x % 1_000_000_000_000_000;
            let e = (x >> 50) as i32 % 23 - 11;
            let t = format!("{m}e{e}");
            assert_eq!(parse_number(&t), t.parse::<f64>().ok(), "{t}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]

        /// Random decimals: digits, a point anywhere, an exponent.
        #[test]
        fn random_decimals_match_core(
            neg in any::<bool>(),
            int in "[0-9]{0,12}",
            frac in "[0-9]{0,12}",
            exp in proptest::option::of(-60i32..60),
        ) {
            prop_assume!(!(int.is_empty() && frac.is_empty()));
            let mut t = String::new();
            if neg { t.push('-'); }
            t.push_str(&int);
            if !frac.is_empty() { t.push('.'); t.push_str(&frac); }
            if let Some(e) = exp { t.push_str(&format!("e{e}")); }
            check(&t);
        }

        /// Every finite f32, printed shortest (as the host tool writes it) and with 9 digits.
        #[test]
        fn printed_f32_parse_back(bits in any::<u32>()) {
            let v = f32::from_bits(bits);
            prop_assume!(v.is_finite());
            for t in [format!("{v}"), format!("{v:e}"), format!("{v:.8e}")] {
                check(&t);
                prop_assert_eq!(parse_number(&t).unwrap() as f32, v, "{}", t);
            }
        }
    }
}
