//! A small decimal-to-binary number parser for the command line, in place of core's
//! `str::parse::<f64>` (whose correctly rounding algorithm and its 10 KB table of powers of five
//! do not fit the firmware's flash budget).
//!
//! Method: the significant digits become an integer mantissa `m` (`u64`, at most 19 digits;
//! further digits are dropped, a relative error below 1e−18) and a decimal exponent `e`; the
//! value is `m · 10^e` computed in [`Ext`] (64-bit mantissa, integer arithmetic only: no `f64`
//! soft-float in the firmware) with exact powers of ten `10^0 … 10^27`: one multiplication or
//! division when `|e| ≤ 27`, else repeated steps of `10^27`.
//!
//! Accuracy: `m` is exact and one operation keeps everything it drops as a sticky bit, so for
//! `|e| ≤ 27` (every decimal of up to 19 significant digits between about 1e−8 and 1e27)
//! rounding the result to `f32` or `f64` is correctly rounded: equal to `str::parse` (tested).
//! Any number in `f32`'s range written with at most 19 significant digits needs at most three
//! operations (|e| ≤ 81): relative error below 2^−61 before the final rounding, so the `f32`
//! the settings store equals `str::parse::<f32>` except when the decimal lies within that
//! error of the midpoint between two `f32` values; then it is the other neighbour, 1 ulp off
//! (tested against core's parsers, with proptests).

use super::ext::Ext;

/// Most significant digits kept in the mantissa (10^19 − 1 < 2^64).
const MAX_DIGITS: u32 = 19;

/// Parse a decimal number: optional sign, digits with an optional `.` (at least one digit in
/// all), optional exponent (`e`/`E`, optional sign, at least one digit). `None` for anything
/// else (`inf`, `nan`, hex, spaces, empty). A number too large for `f64` parses as infinite,
/// one too small as zero; the caller checks the range.
pub fn parse_number(text: &str) -> Option<Ext> {
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
    let magnitude = Ext::from_u64(mantissa).scale10(exp10);
    Some(if negative { magnitude.negated() } else { magnitude })
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
        let ours64 = ours.to_f64();
        if exact.is_finite() && exact.abs() >= f64::MIN_POSITIVE {
            let rel = ((ours64 - exact) / exact).abs();
            assert!(rel <= f64::EPSILON, "{text}: {ours64:e} vs {exact:e}");
        } else if exact.is_infinite() {
            assert!(ours64.is_infinite() || ours64.abs() >= f64::MAX / 2.0, "{text}: {ours64:e}");
        }
        let want32: f32 = text.parse().unwrap();
        let got32 = ours.to_f32();
        assert!(ulps_f32(got32, want32) <= 1, "{text}: f32 {got32:e} vs {want32:e}");
        // One operation (|exponent| ≤ 27 after the digits are taken): correctly rounded.
        if single_step(text) {
            assert_eq!(got32, want32, "{text}");
            assert_eq!(ours64, exact, "{text}");
        }
    }

    /// True when the text's value is `m · 10^e` with at most 19 digits in `m` and |e| ≤ 27.
    fn single_step(text: &str) -> bool {
        let t = text.trim_start_matches(['+', '-']);
        let (num, exp) = match t.find(['e', 'E']) {
            Some(k) => (&t[..k], t[k + 1..].parse::<i64>().unwrap()),
            None => (t, 0),
        };
        let (int, frac) = num.split_once('.').unwrap_or((num, ""));
        let all = format!("{int}{frac}");
        let digits = all.trim_start_matches('0');
        digits.len() <= 19 && (exp - frac.len() as i64).abs() <= 27
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
        let p = |t: &str| parse_number(t).map(Ext::to_f64);
        assert_eq!(p("0.05"), Some(0.05));
        assert_eq!(p("-1e3"), Some(-1000.0));
        assert_eq!(p("1e999"), Some(f64::INFINITY));
        assert_eq!(p("-1e999"), Some(f64::NEG_INFINITY));
        assert_eq!(p("1e-999"), Some(0.0));
        assert_eq!(p("1e99999999999"), Some(f64::INFINITY));
        assert_eq!(p("1e-99999999999"), Some(0.0));
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
    fn up_to_nineteen_digits_with_small_exponents_are_correctly_rounded() {
        let mut x: u64 = 0x1234_5678_9abc_def1;
        for _ in 0..50_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let m = x % 10_000_000_000_000_000_000;
            let e = (x >> 50) as i32 % 28 - 14;
            let t = format!("{m}e{e}");
            let ours = parse_number(&t).unwrap();
            assert_eq!(ours.to_f64(), t.parse::<f64>().unwrap(), "{t}");
            assert_eq!(ours.to_f32(), t.parse::<f32>().unwrap(), "{t}");
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
                prop_assert_eq!(parse_number(&t).unwrap().to_f32(), v, "{}", t);
            }
        }
    }
}
