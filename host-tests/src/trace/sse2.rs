//! The common number form of a trace cell, `[-]digits.digits` with at most 16 digits, parsed
//! 16 bytes at a time with SSE2 (part of every x86-64 CPU, so no run-time detection).
//!
//! With it the replay's parse stage takes about 1,960 instructions per row of 11 cells, with
//! the portable parser alone ([`super::window_decimal`]) about 2,170 (docs/accuracy.md,
//! "Replay throughput").
//!
//! Method, for the digits after the optional sign at `p`:
//! - `A` = the 16 bytes at `p`, `B` = the 16 bytes at `p + 1`, each minus `'0'`; a byte is a
//!   digit iff that is at most 9 (unsigned). `k1` = the integer digits (the leading digits of
//!   `A`), which must be followed by `.`; the fraction's digits are then the lanes of `B` from
//!   `k1` on (`B` is `A` moved one byte left, so the `.` is squeezed out), `nf` of them.
//! - The `n = k1 + nf` digits, left-aligned and zero-filled: lanes `< k1` of `A`, lanes
//!   `k1..n` of `B`. As a 16-digit number they are `m·10^(16−n)`; pairs, quads and octets are
//!   combined with `pmaddwd` (10, 100, 10⁴), and the two octets in scalar.
//! - `m = (m·10^z) / 10^z` exactly, without a division: shift out the `2^z`, then multiply by
//!   the inverse of the odd `5^z` modulo 2⁶⁴ (exact because the quotient is an integer).

use core::arch::x86_64::{
    __m128i, _mm_and_si128, _mm_andnot_si128, _mm_cmpeq_epi8, _mm_cvtsi128_si64, _mm_loadu_si128,
    _mm_madd_epi16, _mm_min_epu8, _mm_movemask_epi8, _mm_or_si128, _mm_packs_epi32, _mm_set1_epi32,
    _mm_set1_epi8, _mm_setzero_si128, _mm_sub_epi8, _mm_unpackhi_epi8, _mm_unpacklo_epi8,
};

use super::{Decimal, WINDOW};

/// `0xff` then `0x00`, 16 of each: the 16 bytes at `16 − k` are `0xff` in lanes `< k`.
static LANES_BELOW: [u8; 32] = {
    let mut t = [0u8; 32];
    let mut i = 0;
    while i < 16 {
        t[i] = 0xff;
        i += 1;
    }
    t
};

/// The inverse of `5^z` modulo 2⁶⁴, `z = 0..=16` (Newton's iteration, each step doubling the
/// correct low bits: 5 steps from 3 bits reach 96).
const INV_POW5: [u64; 17] = {
    let mut t = [0u64; 17];
    let mut z = 0;
    let mut p: u64 = 1;
    while z <= 16 {
        let mut x = p; // p·p ≡ 1 (mod 8) for odd p: 3 correct bits
        let mut k = 0;
        while k < 5 {
            x = x.wrapping_mul(2u64.wrapping_sub(p.wrapping_mul(x)));
            k += 1;
        }
        t[z] = x;
        p = p.wrapping_mul(5);
        z += 1;
    }
    t
};

/// 16 bytes of `b` from `i` (`i + 16 ≤ b.len()`, checked).
#[inline(always)]
fn load(b: &[u8], i: usize) -> __m128i {
    let chunk: &[u8; 16] = b[i..i + 16].try_into().unwrap();
    // SAFETY: `chunk` is 16 readable bytes; `loadu` has no alignment requirement; SSE2 is
    // part of every x86-64 CPU.
    unsafe { _mm_loadu_si128(chunk.as_ptr().cast()) }
}

/// The number at the start of `w` in the form `[-]digits.digits`, at most 16 digits (at least
/// one), and where it ends; `None` for anything else (the caller falls back to the portable
/// parser). What follows the number is the caller's business, as in
/// [`super::window_decimal`], which this agrees with wherever both give a result.
#[inline(always)]
pub(super) fn window_decimal(w: &[u8; WINDOW]) -> Option<(Decimal, usize)> {
    // SAFETY: the intrinsics below only need SSE2, which every x86-64 CPU has (the Rust
    // target enables it); none of them touches memory (the loads are in `load`).
    unsafe { window_decimal_sse2(w) }
}

/// [`window_decimal`]'s body (see there).
#[inline(always)]
unsafe fn window_decimal_sse2(w: &[u8; WINDOW]) -> Option<(Decimal, usize)> {
    let neg = w[0] == b'-';
    let p = usize::from(neg);
    let zero_char = _mm_set1_epi8(b'0' as i8);
    let nine = _mm_set1_epi8(9);
    let a = _mm_sub_epi8(load(w, p), zero_char);
    let b = _mm_sub_epi8(load(w, p + 1), zero_char);
    let digits = |v: __m128i| _mm_movemask_epi8(_mm_cmpeq_epi8(_mm_min_epu8(v, nine), v)) as u32;
    let k1 = (!digits(a) | 1 << 16).trailing_zeros() as usize;
    if k1 == 16 || w[p + k1] != b'.' {
        return None;
    }
    let nf = ((!digits(b) | 1 << 16) >> k1).trailing_zeros() as usize;
    let n = k1 + nf;
    // `n == 16`: the fraction reaches the last lane of B, and may go on.
    if n == 0 || n == 16 && w[p + 17].is_ascii_digit() {
        return None;
    }
    // Lanes `< k1` of A, lanes `k1..n` of B.
    let below = |k: usize| load(&LANES_BELOW, 16 - k);
    let (mask_a, mask_n) = (below(k1), below(n));
    let v =
        _mm_or_si128(_mm_and_si128(a, mask_a), _mm_and_si128(_mm_andnot_si128(mask_a, mask_n), b));
    // Digits → 2-digit → 4-digit → 8-digit lanes.
    let z = _mm_setzero_si128();
    let tens = _mm_set1_epi32(0x0001_000a); // (10, 1) per pair of 16-bit lanes
    let pairs = _mm_packs_epi32(
        _mm_madd_epi16(_mm_unpacklo_epi8(v, z), tens),
        _mm_madd_epi16(_mm_unpackhi_epi8(v, z), tens),
    );
    let quads = _mm_madd_epi16(pairs, _mm_set1_epi32(0x0001_0064));
    let octs = _mm_madd_epi16(_mm_packs_epi32(quads, quads), _mm_set1_epi32(0x0001_2710));
    let o = _mm_cvtsi128_si64(octs) as u64;
    let padded = (o & 0xffff_ffff) * 100_000_000 + (o >> 32);
    let zeros = 16 - n;
    let m = (padded >> zeros).wrapping_mul(INV_POW5[zeros]);
    Some((Decimal { neg, m, e: -(nf as i32) }, p + k1 + 1 + nf))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverses() {
        let mut p: u64 = 1;
        for (z, &inv) in INV_POW5.iter().enumerate() {
            assert_eq!(p.wrapping_mul(inv), 1, "5^{z}");
            p = p.wrapping_mul(5);
        }
    }

    fn window(text: &str) -> [u8; WINDOW] {
        let mut w = [b','; WINDOW];
        w[..text.len()].copy_from_slice(text.as_bytes());
        w
    }

    /// Hand-written cases: the value, the exponent, where it ends; the forms it declines.
    #[test]
    fn hand_cases() {
        let got = |t: &str| window_decimal(&window(t)).map(|(d, n)| (d.neg, d.m, d.e, n));
        assert_eq!(got("0.0"), Some((false, 0, -1, 3)));
        assert_eq!(got("-9.833959"), Some((true, 9_833_959, -6, 9)));
        assert_eq!(got("3599.98"), Some((false, 359_998, -2, 7)));
        assert_eq!(got("-0.0015485486"), Some((true, 15_485_486, -10, 13)));
        assert_eq!(got(".5"), Some((false, 5, -1, 2)));
        assert_eq!(got("5."), Some((false, 5, 0, 2)));
        assert_eq!(got("1234567890.123456"), Some((false, 1_234_567_890_123_456, -6, 17)));
        assert_eq!(got("9999999999999999."), None); // 16 integer digits: no `.` in A
        assert_eq!(got("0.1234567890123456"), None); // 17 digits
        assert_eq!(got("-.123456789012345"), Some((true, 123_456_789_012_345, -15, 17)));
        assert_eq!(got("-.1234567890123456"), Some((true, 1_234_567_890_123_456, -16, 18)));
        assert_eq!(got("-.12345678901234567"), None); // a 17th digit after the 16
        for declined in [".", "-", "-.", "5", "1e5", "+1.0", " 1.0"] {
            assert_eq!(got(declined), None, "{declined}");
        }
        // The number stops before an exponent: the caller's end test then rejects the cell.
        assert_eq!(got("1.0e5"), Some((false, 10, -1, 3)));
    }

    /// Agrees with the exact scanner ([`super::super::scan_decimal`]) wherever the number it
    /// finds ends at a separator (the caller's test), and takes every cell of that form with
    /// at most 16 digits.
    #[test]
    fn agrees_with_the_scanner() {
        let mut rng = crate::rng::Rng::new(5, 0);
        let mut taken = 0;
        for _ in 0..200_000 {
            let k1 = (rng.next_u64() % 11) as usize;
            let nf = (rng.next_u64() % 19) as usize;
            let mut t = String::new();
            if rng.next_u64() % 2 == 0 {
                t.push('-');
            }
            for _ in 0..k1 {
                t.push((b'0' + (rng.next_u64() % 10) as u8) as char);
            }
            t.push('.');
            for _ in 0..nf {
                t.push((b'0' + (rng.next_u64() % 10) as u8) as char);
            }
            if rng.next_u64() % 8 == 0 {
                let i = (rng.next_u64() % t.len() as u64) as usize;
                t.replace_range(i..i + 1, ["e", "x", ",", "+", "-", ".", "\n"][i % 7]);
            }
            let w = window(&t);
            let ends_cell = |n: usize| matches!(w[n], b',' | b'\n' | b'\r');
            let scanned = super::super::scan_decimal(&w)
                .filter(|&(_, n)| ends_cell(n))
                .map(|(d, n)| (d.neg, d.m, d.e, n));
            match window_decimal(&w).filter(|&(_, n)| ends_cell(n)) {
                Some((d, n)) => {
                    assert_eq!(Some((d.neg, d.m, d.e, n)), scanned, "{t:?}");
                    taken += 1;
                }
                None => {
                    // Declined: not `[-]digits.digits`, or more than 16 digits.
                    let cell = &t[..t.find([',', '\n']).unwrap_or(t.len())];
                    let body = cell.strip_prefix('-').unwrap_or(cell);
                    let plain = body.matches('.').count() == 1
                        && body.bytes().all(|c| c == b'.' || c.is_ascii_digit())
                        && (1..=16).contains(&(body.len() - 1));
                    assert!(!plain, "{t:?}: declined");
                }
            }
        }
        assert!(taken > 100_000, "{taken}");
    }
}
