//! The trace reader under libFuzzer: a standard header (`t,gx,gy,gz,ax,ay,az`) and the input as
//! the rows. The oracle (issue #39 point 7):
//! - no panic; an error names its line;
//! - every row read is the file's line, split at commas and trimmed, each cell a decimal by
//!   Rust's float grammar whose value is the reader's, correctly rounded — checked exactly here
//!   with big integers ([`check_rounding`]), not with the `str::parse` the reader itself uses;
//! - a line longer than 64 KiB (the reader's limit, line break included) is refused with its
//!   number. An input that starts with 0xFF is repeated past that length, so that libFuzzer's
//!   small inputs reach the limit.
#![no_main]

use std::io::Cursor;

use host_tests::trace::{TraceError, TraceReader, MAX_LINE_BYTES};
use libfuzzer_sys::fuzz_target;
use num_bigint::BigUint;

/// A float format: mantissa bits with the hidden one, and the exponent of the smallest
/// subnormal's ulp.
struct Format {
    mant_bits: u32,
    min_exp: i64,
    max_exp: i64,
}
const F32: Format = Format { mant_bits: 24, min_exp: -149, max_exp: 104 };
const F64: Format = Format { mant_bits: 53, min_exp: -1074, max_exp: 971 };

/// `[+-]? (d+ (. d*)? | . d+) ([eE] [+-]? d+)?`: sign, the digits, and the power of ten of the
/// last digit (saturated); `None` when the cell is not such a decimal.
fn decimal(cell: &str) -> Option<(bool, Vec<u8>, i64)> {
    let b = cell.as_bytes();
    let mut i = 0;
    let neg = matches!(b.first(), Some(b'-'));
    if matches!(b.first(), Some(b'+' | b'-')) {
        i = 1;
    }
    let mut digits = Vec::new();
    let mut frac = 0i64;
    let start = i;
    while i < b.len() && b[i].is_ascii_digit() {
        digits.push(b[i] - b'0');
        i += 1;
    }
    let int_digits = i - start;
    let mut frac_digits = 0;
    if i < b.len() && b[i] == b'.' {
        i += 1;
        while i < b.len() && b[i].is_ascii_digit() {
            digits.push(b[i] - b'0');
            frac += 1;
            frac_digits += 1;
            i += 1;
        }
    }
    if int_digits == 0 && frac_digits == 0 {
        return None;
    }
    let mut exp = 0i64;
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        i += 1;
        let eneg = matches!(b.get(i), Some(b'-'));
        if matches!(b.get(i), Some(b'+' | b'-')) {
            i += 1;
        }
        let s = i;
        while i < b.len() && b[i].is_ascii_digit() {
            exp = exp.saturating_mul(10).saturating_add(i64::from(b[i] - b'0'));
            i += 1;
        }
        if i == s {
            return None;
        }
        if eneg {
            exp = -exp;
        }
    }
    (i == b.len()).then_some((neg, digits, exp.saturating_sub(frac)))
}

fn pow(base: u32, e: u64) -> BigUint {
    BigUint::from(base).pow(u32::try_from(e).expect("bounded exponent"))
}

/// `D·10^e10` against `n·2^q`: less, equal, greater.
fn cmp(d: &BigUint, e10: i64, n: &BigUint, q: i64) -> std::cmp::Ordering {
    let (mut l, mut r) = (d.clone(), n.clone());
    if e10 >= 0 {
        l *= pow(10, e10 as u64)
    } else {
        r *= pow(10, e10.unsigned_abs())
    }
    if q >= 0 {
        r <<= q as u64
    } else {
        l <<= q.unsigned_abs()
    }
    l.cmp(&r)
}

/// The finite value `(neg, m·2^k)` is the decimal `cell` correctly rounded (to nearest, ties to
/// even) in `fmt`.
fn check_rounding(cell: &str, neg_got: bool, m: u64, k: i64, fmt: &Format) -> Result<(), String> {
    let Some((neg, digits, e10)) = decimal(cell) else {
        return Err(format!("{cell:?} is not a decimal, but was read"));
    };
    if neg != neg_got {
        return Err(format!("{cell:?}: the sign"));
    }
    let first = digits.iter().position(|&d| d != 0);
    let Some(first) = first else {
        return if m == 0 { Ok(()) } else { Err(format!("{cell:?} is zero, read as nonzero")) };
    };
    // Magnitude 10^(mag−1) ≤ |V| < 10^mag: far outside the format's range, no big numbers.
    let mag = (digits.len() - first) as i64 + e10;
    if mag > 330 {
        return Err(format!("{cell:?} overflows, but was read as finite"));
    }
    if mag < -340 {
        return if m == 0 {
            Ok(())
        } else {
            Err(format!("{cell:?} underflows to 0, read as {m}·2^{k}"))
        };
    }
    let d = BigUint::from_radix_be(&digits[first..], 10).expect("digits");
    let mant = BigUint::from(m);
    if m == 0 {
        // Zero: the decimal must be at most half the smallest subnormal (a tie goes to 0, even).
        return match cmp(&d, e10, &BigUint::from(1u8), fmt.min_exp - 1) {
            std::cmp::Ordering::Greater => Err(format!("{cell:?} read as 0")),
            _ => Ok(()),
        };
    }
    let even = m % 2 == 0;
    let top = 1u64 << (fmt.mant_bits - 1);
    // Half the gap to the next value up, and to the next down (a quarter at a binade's bottom,
    // where the spacing below halves; not for the smallest normal's binade, whose neighbour
    // below is a subnormal with the same spacing).
    let up = (&mant * 2u8 + 1u8, k - 1);
    let down = if m == top && k > fmt.min_exp {
        (&mant * 4u8 - 1u8, k - 2)
    } else {
        (&mant * 2u8 - 1u8, k - 1)
    };
    if k > fmt.max_exp {
        return Err(format!("{cell:?}: exponent {k} beyond the format"));
    }
    let above = cmp(&d, e10, &up.0, up.1);
    let below = cmp(&d, e10, &down.0, down.1);
    use std::cmp::Ordering::*;
    let ok = matches!(above, Less) && matches!(below, Greater)
        || (even && matches!(above, Equal))
        || (even && matches!(below, Equal));
    if ok {
        Ok(())
    } else {
        Err(format!("{cell:?} is not rounded to {m}·2^{k}"))
    }
}

fn f32_parts(x: f32) -> (bool, u64, i64) {
    let b = x.to_bits();
    let (e, f) = ((b >> 23) & 0xff, u64::from(b & 0x7f_ffff));
    let (m, k) = if e == 0 { (f, -149) } else { (f | 1 << 23, i64::from(e) - 150) };
    (b >> 31 == 1, m, k)
}

fn f64_parts(x: f64) -> (bool, u64, i64) {
    let b = x.to_bits();
    let (e, f) = ((b >> 52) & 0x7ff, b & 0xf_ffff_ffff_ffff);
    let (m, k) = if e == 0 { (f, -1074) } else { (f | 1 << 52, e as i64 - 1075) };
    (b >> 63 == 1, m, k)
}

fuzz_target!(|data: &[u8]| {
    // Past the line limit from a small input: 0xFF first, the rest repeated.
    let data: Vec<u8> = match data.split_first() {
        Some((0xFF, rest)) if !rest.is_empty() => {
            rest.iter().copied().cycle().take(MAX_LINE_BYTES + 2 + rest.len()).collect()
        }
        _ => data.to_vec(),
    };
    let mut file = b"t,gx,gy,gz,ax,ay,az\n".to_vec();
    file.extend_from_slice(&data);
    let Ok(mut reader) = TraceReader::new(Cursor::new(&file[..])) else { return };
    // The file's lines after the header, numbered, with their length in bytes (line break
    // included), and those that are neither comments nor blank as the rows should come.
    let mut numbered = Vec::new();
    let mut start = 0;
    for (n, chunk) in data.split_inclusive(|&b| b == b'\n').enumerate() {
        numbered.push((n + 2, start, chunk.len()));
        start += chunk.len();
    }
    let too_long = numbered.iter().find(|l| l.2 > MAX_LINE_BYTES).map(|l| l.0);
    let text = String::from_utf8_lossy(&data);
    let mut lines = text.split('\n').map(|l| l.trim_end_matches('\r')).filter(|l| {
        let t = l.trim();
        !t.is_empty() && !t.starts_with('#')
    });
    loop {
        match reader.next_row() {
            Ok(Some(row)) => {
                let Some(line) = lines.next() else { panic!("a row without a line: {row:?}") };
                let f: Vec<&str> = line.split(',').map(str::trim).collect();
                assert_eq!(f.len(), 7, "{line:?} read as {row:?}");
                let (neg, m, k) = f64_parts(row.t);
                check_rounding(f[0], neg, m, k, &F64).unwrap_or_else(|e| panic!("t: {e}"));
                for i in 0..3 {
                    let (neg, m, k) = f32_parts(row.gyro[i]);
                    check_rounding(f[1 + i], neg, m, k, &F32)
                        .unwrap_or_else(|e| panic!("g{i}: {e}"));
                    let (neg, m, k) = f32_parts(row.accel[i]);
                    check_rounding(f[4 + i], neg, m, k, &F32)
                        .unwrap_or_else(|e| panic!("a{i}: {e}"));
                }
            }
            Ok(None) => {
                assert!(too_long.is_none(), "line {too_long:?} is over the limit, and was read");
                break;
            }
            Err(e) => {
                let msg = e.to_string();
                assert!(msg.starts_with("line ") || msg.contains("line"), "{msg}");
                if matches!(e, TraceError::LineTooLong { .. }) {
                    assert_eq!(e.line(), too_long, "{msg}");
                } else if let Some(n) = too_long {
                    // Any other error comes from a line before the long one.
                    assert!(e.line().is_some_and(|l| l < n), "{msg}: line {n} is the long one");
                }
                break;
            }
        }
    }
});
