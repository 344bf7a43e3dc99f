//! Fixed-point number formatting for estimate files: `f32` values rounded exactly to a given
//! number of decimals, the time written shortest round trip, the flags as an integer.

use super::{fast_f64, POW10_U64};

/// `00`, `01`, …, `99`.
const DIGIT_PAIRS: &[u8; 200] = b"0001020304050607080910111213141516171819\
    2021222324252627282930313233343536373839\
    4041424344454647484950515253545556575859\
    6061626364656667686970717273747576777879\
    8081828384858687888990919293949596979899";

/// Append `v` rounded to `D ≤ 9` decimals, half away from zero, exactly: `v = m·2^e` with an
/// integer `m < 2^24`, so `v·10^D = m·5^D·2^(e+D)` has a significand below 2^45 and is exact
/// as an `f64` product; it is rounded from there, no error anywhere. Trailing zeros of the fraction are dropped (`1`, `0.5`, `-0.00012`),
/// a value that rounds to zero is written `0`, NaN or infinite values are written as nothing
/// (an empty cell). Returns false, writing nothing, for finite `|v| ≥ 1e9`.
#[cfg(test)]
fn fixed_f32<const D: usize>(v: f32, out: &mut Vec<u8>) -> bool {
    let mut b = [0u8; 24];
    match fixed_f32_into::<D>(v, &mut b) {
        Some(n) => {
            out.extend_from_slice(&b[..n]);
            true
        }
        None => false,
    }
}

/// [`fixed_f32`] into the start of `out`: the number of bytes written, `None` for finite
/// `|v| ≥ 1e9`. At most 1 + 9 + 1 + 9 = 20 bytes.
///
/// The product `|v|·10^D` is exact in `f64`: `|v| = m·2^e` with `m < 2^24` and
/// `10^D = 5^D·2^D` with `5^D ≤ 5^9 < 2^21`, so it is `m·5^D·2^(e+D)` with a significand
/// below 2^45 (and an exponent well inside the `f64` range, subnormal `f32` included);
/// [`round_half_away`] then rounds it exactly.
#[inline(always)]
pub(super) fn fixed_f32_into<const D: usize>(v: f32, out: &mut [u8; 24]) -> Option<usize> {
    const { assert!(D <= 9) };
    let a = v.abs();
    let x = f64::from(a) * POW10_F64[D];
    // The usual case (every Euler angle, quaternion component not rounding to ±1, bias below
    // 100 °/s): `n < 10^8`, all digits in one `digits8`. NaN fails the test too.
    if D <= 8 && x < 99_999_999.5 {
        let n = round_half_away_small(x);
        if n == 0 {
            out[0] = b'0';
            return Some(1);
        }
        return Some(write_fixed8::<D>(v < 0.0, n, out));
    }
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN is meant to take this branch
    if !(a < 1e9) {
        return if a.is_finite() { None } else { Some(0) };
    }
    let n = round_half_away(x);
    if n == 0 {
        out[0] = b'0';
        return Some(1);
    }
    Some(write_fixed::<D>(v < 0.0, n, out))
}

/// `t` (s) with at most 9 decimals, trailing zeros dropped, if that reads back as exactly
/// `t`; else `None`, writing garbage. For `|t| < 4e6` s these are then the digits of the
/// shortest round trip (`ryu`'s, without its `.0` or exponent form), found faster: `f64`
/// spacing there is below 1e-9, so one 9-decimal number at most reads back as `t`.
///
/// "Reads back" is what [`fast_f64`] (the reader's exact path) gives for the written text
/// `m·10^-k` (`m` the digits, `k ≤ 9` the decimals): the correctly rounded `m / 10^k`. That
/// is the same rational number as `n / 10^9` (`n = round(|t|·10^9)`), so while `n ≤ 2⁵³`
/// (exact in `f64`) the one correctly rounded division `n / 1e9` gives the same value
/// without parsing; larger `n` (`|t|` above about 9e6 s) parse the text back.
#[inline]
pub(super) fn time_fixed(t: f64, out: &mut [u8; 24]) -> Option<usize> {
    if !t.is_finite() || t.abs() >= 4e9 || t == 0.0 {
        return None;
    }
    let n = round_half_away(t.abs() * 1e9);
    if n == 0 {
        return None;
    }
    let k = write_fixed::<9>(t < 0.0, n, out);
    let back = if n <= 1 << 53 { n as f64 / 1e9 } else { fast_f64(&out[..k])?.abs() };
    (back == t.abs()).then_some(k)
}

/// `x.round() as u64` for `0 ≤ x < 2⁶³` without the library call: `x − trunc(x)` is exact
/// (below 2⁵² `x` has its fraction bits; above, `x` is an integer and the difference 0).
#[inline(always)]
fn round_half_away(x: f64) -> u64 {
    let i = x as i64;
    (i + i64::from(x - i as f64 >= 0.5)) as u64
}

/// `10^D` as `f64`.
const POW10_F64: [f64; 10] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9];

/// The ASCII `0` in every byte: digit values to digit characters.
const ZEROS: u64 = 0x3030_3030_3030_3030;

/// The 8 bytes of `w` (little-endian: byte 0 first) into `out` at `i`.
#[inline(always)]
fn put8(out: &mut [u8; 24], i: usize, w: u64) {
    out[i..i + 8].copy_from_slice(&w.to_le_bytes());
}

/// `±n·10^-D` (`0 < n < 10^8`, `D ≤ 8`) into the start of `out` as [`write_fixed`] writes it,
/// from the one word of 8 digits `d = digits8(n)` (text order, the integer digits then the
/// `D` fraction digits): the leading zero digits are the low zero bytes of `d`, the trailing
/// ones its high zero bytes, so the integer part is the word shifted right and the fraction
/// the top `D` bytes, each written as a whole word (the bytes after them are overwritten
/// next or lie past the end). At most 1 + 8 + 1 + 8 bytes; up to 18 of `out` are overwritten.
#[inline(always)]
fn write_fixed8<const D: usize>(neg: bool, n: u32, out: &mut [u8; 24]) -> usize {
    // (Instantiated for `D = 9` too, never called with it.)
    debug_assert!(D <= 8 && n > 0 && n < 100_000_000);
    let d = digits8(n);
    let ascii = d | ZEROS;
    out[0] = b'-';
    let k = usize::from(neg);
    // Trailing zero digits (< 8: `d ≠ 0`); the fraction is not zero iff fewer than `D`.
    let trail = d.leading_zeros() as usize / 8;
    if D == 8 {
        // No integer digit: `0.` then the fraction.
        out[k] = b'0';
        out[k + 1] = b'.';
        put8(out, k + 2, ascii);
        return k + 2 + 8 - trail;
    }
    // Leading zero digits, at most `7 − D` (so that one integer digit, maybe `0`, is left):
    // the lowest set bit of `d` or the marker bit at byte `7 − D`.
    let lead = (d | 1 << (8 * (7 - D))).trailing_zeros() as usize / 8;
    let ni = 8 - D - lead; // integer digits, 1..=8 − D
    put8(out, k, ascii >> (8 * lead));
    if D == 0 || trail >= D {
        return k + ni;
    }
    // The fraction after its `.`, over the fraction digits the integer word also wrote.
    out[k + ni] = b'.';
    put8(out, k + ni + 1, ascii >> (8 * (8 - D)));
    k + ni + 1 + D - trail
}

/// [`round_half_away`] for `0 ≤ x < 2^32 − 1/2` (so NaN is not an input), without converting a
/// float to an integer (whose saturation of out-of-range values costs as much again): adding
/// 2⁵² rounds `x` to an integer to nearest, ties to even, and that integer is then the low
/// bits of the sum's representation (the sum is in [2⁵², 2⁵³), where the spacing is 1). The
/// subtractions are exact, so the remainder `x − r` is exact and in [−1/2, 1/2]: it is 1/2
/// exactly where the tie went down, to be taken up instead (away from zero).
#[inline(always)]
fn round_half_away_small(x: f64) -> u32 {
    const MAGIC: f64 = 4_503_599_627_370_496.0; // 2⁵²
    let y = x + MAGIC;
    let r = y - MAGIC;
    y.to_bits() as u32 + u32::from(x - r >= 0.5)
}

/// The 8 decimal digits of `n < 10^8` (leading zeros included) as byte values 0..=9, the most
/// significant in byte 0 (little-endian order, i.e. text order), computed in parallel: split
/// into two 4-digit halves in 32-bit lanes, each split by 100 (`x·10486 >> 20` is `x / 100`
/// for `x < 10^4`), then each 2-digit lane by 10 (`x·103 >> 10` is `x / 10` for `x < 100`);
/// no product reaches the next lane.
#[inline(always)]
fn digits8(n: u32) -> u64 {
    let x = u64::from(n / 10_000) | u64::from(n % 10_000) << 32;
    let hundreds = ((x * 10_486) >> 20) & 0x0000_007f_0000_007f;
    let x = hundreds | (x - hundreds * 100) << 16;
    let tens = ((x * 103) >> 10) & 0x000f_000f_000f_000f;
    tens | (x - tens * 10) << 8
}

/// `±n·10^-D` (`n ≠ 0`, `n / 10^D < 2^32`) into the start of `out`, trailing zeros of the
/// fraction dropped: the number of bytes written (at most 1 + 10 + 1 + 9; up to 21 bytes of
/// `out` are overwritten).
#[inline]
fn write_fixed<const D: usize>(neg: bool, n: u64, out: &mut [u8; 24]) -> usize {
    const { assert!(D <= 9) };
    out[0] = b'-';
    let mut k = usize::from(neg);
    // `ip < 2^32` (< 1e9 from `fixed_f32_into`), `fp < 10^D ≤ 1e9`.
    let (mut ip, fp) = ((n / POW10_U64[D]) as u32, (n % POW10_U64[D]) as u32);
    if ip < 10 {
        out[k] = b'0' + ip as u8;
        k += 1;
    } else {
        // Count the digits, then write them right to left, two at a time.
        let mut len = 2;
        while len < 10 && u64::from(ip) >= POW10_U64[len] {
            len += 1;
        }
        let mut i = k + len;
        while ip >= 10 {
            let d = (ip % 100) as usize * 2;
            ip /= 100;
            out[i - 2..i].copy_from_slice(&DIGIT_PAIRS[d..d + 2]);
            i -= 2;
        }
        if i > k {
            out[k] = b'0' + ip as u8;
        }
        k += len;
    }
    if D > 0 && fp != 0 {
        // The D digits as 8 (or 1 + 8): the trailing zero digits are the top zero bytes.
        out[k] = b'.';
        k += 1;
        let rest = if D == 9 {
            out[k] = b'0' + (fp / 100_000_000) as u8;
            k += 1;
            fp % 100_000_000
        } else {
            fp * POW10_U64[8 - D.min(8)] as u32
        };
        if rest != 0 {
            let d = digits8(rest);
            out[k..k + 8].copy_from_slice(&(d | 0x3030_3030_3030_3030).to_le_bytes());
            k += 8 - (d.leading_zeros() / 8) as usize;
        }
    }
    k
}

/// The previous [`fixed_f32_into`] (rounding from the bits of `v`, all digits by
/// [`write_fixed`]), kept as a reference for the tests.
#[cfg(test)]
fn fixed_f32_into_reference<const D: usize>(v: f32, out: &mut [u8; 24]) -> Option<usize> {
    const { assert!(D <= 9) };
    if !v.is_finite() {
        return Some(0);
    }
    if v.abs() >= 1e9 {
        return None;
    }
    let bits = v.to_bits();
    let exp_bits = ((bits >> 23) & 0xff) as i32;
    let frac = u64::from(bits & 0x7f_ffff);
    // v = m · 2^e
    let (m, e) = if exp_bits == 0 { (frac, -149) } else { (frac | 1 << 23, exp_bits - 150) };
    let scaled = m * POW10_U64[D]; // < 2^24 · 10^9 < 2^54
    let n: u64 = if e >= 0 {
        // |v| < 1e9 bounds the shift: scaled · 2^e < 1e18.
        scaled << e
    } else if e > -64 {
        let s = -e as u32;
        (scaled + (1u64 << (s - 1))) >> s
    } else {
        0 // < 2^54 / 2^64: rounds to zero
    };
    if n == 0 {
        out[0] = b'0';
        return Some(1);
    }
    Some(write_fixed::<D>(v < 0.0, n, out))
}

/// `v` in decimal then `\n` into the start of `out`: the number of bytes written (2..=6; all
/// 8 are overwritten). The 5 digits (leading zeros included) as one word: the first by a
/// division, the other 4 in parallel as in [`digits8`] (`x·5243 >> 19` is `x / 100` for
/// `x < 10^4`); the leading zero bytes are shifted out and the newline put after the last.
#[inline(always)]
pub(super) fn u16_line_end(v: u16, out: &mut [u8; 8]) -> usize {
    let v = u32::from(v);
    let first = v / 10_000;
    let rest = v - first * 10_000;
    let hundreds = (rest * 5243) >> 19;
    let x = hundreds | (rest - hundreds * 100) << 16;
    let tens = ((x * 103) >> 10) & 0x000f_000f;
    let d = u64::from(first) | u64::from(tens | (x - tens * 10) << 8) << 8;
    // Leading zero digits, at most 4 (the marker bit at byte 4).
    let lead = (d | 1 << 32).trailing_zeros() as usize / 8;
    let len = 5 - lead;
    let w = (d | 0x30_3030_3030) >> (8 * lead) | u64::from(b'\n') << (8 * len);
    *out = w.to_le_bytes();
    len + 1
}

/// The previous flags writer, kept as a reference for the tests.
#[cfg(test)]
fn itoa_u16(mut v: u16, buf: &mut [u8; 5]) -> &[u8] {
    let mut i = buf.len();
    loop {
        i -= 1;
        buf[i] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            return &buf[i..];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits8_is_exact_for_every_input() {
        let mut d = [0u8; 8];
        for n in 0..100_000_000u32 {
            let got = digits8(n);
            // Incrementing the reference digits is cheaper than dividing for every n.
            if n > 0 {
                let mut i = 7;
                while d[i] == 9 {
                    d[i] = 0;
                    i -= 1;
                }
                d[i] += 1;
            }
            if got != u64::from_le_bytes(d) {
                panic!("digits8({n}) = {got:x}");
            }
        }
    }

    /// `v` rounded to `d` decimals half away from zero, as a signed integer count of 10^-d,
    /// from the exact decimal expansion of `v` (the standard library's formatting).
    fn reference_fixed(v: f32, d: usize) -> i128 {
        let s = format!("{:.200}", (v as f64).abs());
        let (ip, fp) = s.split_once('.').unwrap();
        let digits = format!("{ip}{}", &fp[..d]);
        let mut n: i128 = digits.parse().unwrap();
        if fp.as_bytes()[d] >= b'5' {
            n += 1;
        }
        if v < 0.0 {
            -n
        } else {
            n
        }
    }

    fn written_fixed(s: &str, d: usize) -> i128 {
        let (neg, s) = match s.strip_prefix('-') {
            Some(r) => (true, r),
            None => (false, s),
        };
        let (ip, fp) = s.split_once('.').unwrap_or((s, ""));
        assert!(!fp.ends_with('0') && fp.len() <= d, "{s:?}");
        let n: i128 = format!("{ip}{fp:0<d$}").parse().unwrap();
        assert!(!(neg && n == 0), "negative zero written: {s:?}");
        if neg {
            -n
        } else {
            n
        }
    }

    #[test]
    fn fixed_point_rounds_exactly_half_away_from_zero() {
        fn check<const D: usize>(v: f32) {
            let mut out = Vec::new();
            assert!(fixed_f32::<D>(v, &mut out));
            let s = std::str::from_utf8(&out).unwrap();
            assert_eq!(written_fixed(s, D), reference_fixed(v, D), "{v:e} with {D} decimals");
        }
        let fixed = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -0.5,
            0.001_953_125, // 2^-9: a tie at 8 decimals
            -0.001_953_125,
            0.000_003_814_697_3, // 2^-18
            1e-9,
            -1e-9,
            4e-9,
            5e-9,
            179.9,
            -180.0,
            1.619,
            f32::MIN_POSITIVE,
            1e-45,
            999_999_900.0,
            -999_999_900.0,
            0.999_999_94,
        ];
        for v in fixed {
            check::<8>(v);
            check::<5>(v);
            check::<6>(v);
            check::<0>(v);
            check::<9>(v);
        }
        let mut rng = crate::rng::Rng::new(7, 0);
        for k in 0..300_000u32 {
            let bits = rng.next_u64();
            // Random magnitudes 1e-12..1e9 and random bit patterns within that range.
            let v = (rng.normal() * 10f64.powi((k % 21) as i32 - 12)) as f32;
            let r = f32::from_bits(bits as u32);
            for v in [v, r] {
                if v.is_finite() && v.abs() < 1e9 {
                    check::<8>(v);
                    check::<5>(v);
                    check::<6>(v);
                }
            }
        }
        let mut out = Vec::new();
        assert!(!fixed_f32::<8>(1e9, &mut out) && out.is_empty());
        assert!(fixed_f32::<8>(f32::NAN, &mut out) && out.is_empty());
        assert!(fixed_f32::<8>(f32::NEG_INFINITY, &mut out) && out.is_empty());
        fixed_f32::<8>(0.707_106_77, &mut out);
        assert_eq!(out, b"0.70710677");
    }

    /// `fixed_f32_into::<D>` and the reference give the same bytes for `v`, every `D`.
    fn same_as_reference(v: f32) {
        fn same<const D: usize>(v: f32) {
            let (mut a, mut b) = ([0u8; 24], [0u8; 24]);
            let (ka, kb) =
                (fixed_f32_into::<D>(v, &mut a), fixed_f32_into_reference::<D>(v, &mut b));
            assert_eq!(ka, kb, "{v:e} ({:#x}) with {D} decimals", v.to_bits());
            if let Some(k) = ka {
                assert_eq!(a[..k], b[..k], "{v:e} ({:#x}) with {D} decimals", v.to_bits());
            }
        }
        same::<0>(v);
        same::<1>(v);
        same::<2>(v);
        same::<3>(v);
        same::<4>(v);
        same::<5>(v);
        same::<6>(v);
        same::<7>(v);
        same::<8>(v);
        same::<9>(v);
    }

    #[test]
    fn fixed_f32_into_writes_the_references_bytes() {
        let edges = [
            0.0,
            -0.0,
            1e-45,
            -1e-45,
            f32::MIN_POSITIVE,
            f32::from_bits(0x007f_ffff), // largest subnormal
            0.999_999_999,
            0.999_999_94,
            -0.999_999_94,
            0.999_999_97,
            9.999_999_9,
            99.999_999,
            359.999_996,
            -359.999_996,
            359.999_99,
            -179.999_99,
            4e-9,
            5e-9,
            -5e-9,
            -4.9e-9,
            -0.000_004,
            -0.000_005,
            -0.000_000_4,
            1.0,
            -1.0,
            10.0,
            100.0,
            99_999_999.0,
            100_000_000.0,
            999_999_940.0,
            -999_999_940.0,
            1e9,
            -1e9,
            3e38,
            f32::MAX,
            f32::MIN,
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for v in edges {
            same_as_reference(v);
            same_as_reference(v.next_up());
            same_as_reference(v.next_down());
        }
        // Every 997th bit pattern (all exponents, both signs).
        for bits in (0..=u32::MAX).step_by(997) {
            same_as_reference(f32::from_bits(bits));
        }
        let mut rng = crate::rng::Rng::new(5, 0);
        for k in 0..400_000u32 {
            // Random magnitudes 1e-12..1e9, and values at and next to the ties k + 1/2 of every
            // number of decimals.
            let v = (rng.normal() * 10f64.powi((k % 22) as i32 - 12)) as f32;
            same_as_reference(v);
            let d = (k % 10) as i32;
            let tie = ((rng.uniform() * 1e7).floor() + 0.5) / 10f64.powi(d);
            for t in [tie as f32, -tie as f32] {
                same_as_reference(t);
                same_as_reference(t.next_up());
                same_as_reference(t.next_down());
            }
        }
    }

    #[test]
    fn u16_line_end_is_itoa_for_every_input() {
        for v in 0..=u16::MAX {
            let mut out = [0; 8];
            let k = u16_line_end(v, &mut out);
            let mut buf = [0; 5];
            let want = itoa_u16(v, &mut buf);
            assert_eq!(out[..k - 1], *want, "{v}");
            assert_eq!(out[k - 1], b'\n', "{v}");
        }
    }

    #[test]
    fn round_half_away_is_round() {
        let mut rng = crate::rng::Rng::new(3, 0);
        let check = |x: f64| assert_eq!(round_half_away(x), x.round() as u64, "{x:e}");
        for k in 0..1_000_000u64 {
            let x = rng.uniform() * 2f64.powi((k % 63) as i32);
            let tie = (k >> 1) as f64 + 0.5;
            for x in [x, tie, f64::from_bits(tie.to_bits() - 1), f64::from_bits(x.to_bits() + 1)] {
                if x < 9.2e18 {
                    check(x);
                }
            }
        }
        for x in [0.0, 0.5, 0.49999999999999994, 1.5, 2.5, 4503599627370495.5, 4e18] {
            check(x);
        }
    }

    #[test]
    fn round_half_away_small_is_round() {
        let mut rng = crate::rng::Rng::new(4, 0);
        let check = |x: f64| {
            if x < 4_294_967_295.5 {
                assert_eq!(u64::from(round_half_away_small(x)), x.round() as u64, "{x:e}");
            }
        };
        for k in 0..1_000_000u64 {
            let x = rng.uniform() * 2f64.powi((k % 33) as i32 - 1);
            let tie = (k * 4_294_967 % 4_294_967_296) as f64 + 0.5;
            for x in [x, tie, tie.next_down(), tie.next_up(), x.next_up(), tie - 0.5] {
                check(x);
            }
        }
        for x in [0.0, 1e-300, 0.5, 0.49999999999999994, 1.5, 2.5, 99_999_999.49999999, 4e9] {
            check(x);
        }
    }

    #[test]
    fn time_is_written_shortest_round_trip() {
        let mut rng = crate::rng::Rng::new(11, 0);
        let mut fast = 0;
        let check = |t: f64| -> bool {
            let mut out = [0u8; 24];
            let Some(k) = time_fixed(t, &mut out) else { return false };
            let s = std::str::from_utf8(&out[..k]).unwrap();
            assert_eq!(s.parse::<f64>().map(f64::to_bits), Ok(t.to_bits()), "{t:e} → {s}");
            if t.abs() < 4e6 {
                assert_eq!(s, ryu::Buffer::new().format(t).trim_end_matches(".0"), "{t:e}");
            }
            true
        };
        for k in 0..200_000u64 {
            // Sample times as a simulator or a logger writes them, and arbitrary values.
            let rate = [50.0, 100.0, 104.0, 208.0, 833.0, 1000.0][(k % 6) as usize];
            for t in [
                k as f64 / rate,
                (k * 7919 % 360_000) as f64 * 0.01,
                rng.uniform() * 3600.0,
                -(k as f64) * 0.001,
                f64::from_bits(rng.next_u64()),
                // Every number of integer digits, 1 to 10 (one SWAR word up to 8).
                (rng.next_u64() % 10u64.pow((k % 10) as u32 + 1)) as f64 + 0.25,
                rng.uniform() * 4e9,
            ] {
                if check(t) {
                    fast += 1;
                }
            }
        }
        assert!(fast > 600_000, "{fast}");
        for t in [0.0, -0.0, 1e-12, 5e9, f64::NAN, f64::INFINITY] {
            assert!(time_fixed(t, &mut [0; 24]).is_none(), "{t}");
        }
    }
}
