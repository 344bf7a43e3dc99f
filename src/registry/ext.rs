//! Binary floating point with a 64-bit mantissa in integer arithmetic only: the command
//! layer's number parser and printer and the registry's unit scaling use it instead of `f64`,
//! whose soft-float routines (≈ 2.5 KB) would otherwise be linked into the firmware.
//!
//! A value is `±m · 2^e` with `m` normalised (bit 63 set) or zero. Multiplication and division
//! keep 64 bits and fold everything dropped into the lowest bit ("sticky"), so the final
//! rounding to `f32` ([`Ext::to_f32`]) or to an integer ([`Ext::round_half_up`]) of the result
//! of one inexact operation is correctly rounded; after several, the relative error before that
//! rounding is below 2^−62 per operation.

use core::cmp::Ordering;

/// `±m · 2^e`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Ext {
    neg: bool,
    m: u64,
    e: i32,
}

/// Beyond this binary exponent a value is infinite, below its negative zero, for every use
/// here (`f32` reaches 2^128, its subnormals 2^−149).
const EXP_LIMIT: i32 = 1000;

impl Ext {
    /// Zero.
    pub const ZERO: Ext = Ext { neg: false, m: 0, e: 0 };

    /// `±m · 2^e`, normalised.
    pub const fn new(neg: bool, m: u64, e: i32) -> Ext {
        if m == 0 {
            return Ext { neg, m: 0, e: 0 };
        }
        let z = m.leading_zeros();
        Ext { neg, m: m << z, e: e - z as i32 }
    }

    /// An integer.
    pub const fn from_u64(m: u64) -> Ext {
        Ext::new(false, m, 0)
    }

    /// A finite `f32`, exactly (NaN and infinities are not expected: they give a finite value).
    pub fn from_f32(x: f32) -> Ext {
        let b = x.to_bits();
        let (exp, frac) = ((b >> 23) & 0xFF, u64::from(b & 0x7F_FFFF));
        let neg = b >> 31 != 0;
        if exp == 0 {
            Ext::new(neg, frac, -149)
        } else {
            Ext::new(neg, frac | 1 << 23, exp as i32 - 150)
        }
    }

    /// A finite normal `f64`, exactly, by its bits (no `f64` arithmetic: for constants).
    pub const fn from_f64(x: f64) -> Ext {
        let b = x.to_bits();
        let exp = ((b >> 52) & 0x7FF) as i32;
        if exp == 0 {
            return Ext::ZERO;
        }
        Ext::new(b >> 63 != 0, (b & ((1 << 52) - 1)) | 1 << 52, exp - 1075)
    }

    /// True for zero.
    pub fn is_zero(self) -> bool {
        self.m == 0
    }

    /// True for negative values (not for zero).
    pub fn is_negative(self) -> bool {
        self.neg && self.m != 0
    }

    /// The negated value.
    pub fn negated(self) -> Ext {
        Ext { neg: !self.neg, ..self }
    }

    /// The absolute value.
    pub fn abs(self) -> Ext {
        Ext { neg: false, ..self }
    }

    /// `self · o`, 64 bits kept, the rest sticky.
    pub fn times(self, o: Ext) -> Ext {
        let neg = self.neg != o.neg;
        if self.m == 0 || o.m == 0 {
            return Ext { neg, ..Ext::ZERO };
        }
        const LO: u64 = 0xFFFF_FFFF;
        let (ah, al, bh, bl) = (self.m >> 32, self.m & LO, o.m >> 32, o.m & LO);
        let (hh, hl, lh, ll) = (ah * bh, ah * bl, al * bh, al * bl);
        let mid = (ll >> 32) + (hl & LO) + (lh & LO);
        let hi = hh + (hl >> 32) + (lh >> 32) + (mid >> 32);
        let lo = (mid << 32) | (ll & LO);
        // Both factors are at least 2^63, so hi is at least 2^62: at most one shift.
        let e = self.e.saturating_add(o.e).saturating_add(64);
        let (m, rest, e) =
            if hi >> 63 == 0 { (hi << 1 | lo >> 63, lo << 1, e - 1) } else { (hi, lo, e) };
        Ext { neg, m: m | u64::from(rest != 0), e }.clamped()
    }

    /// `self / o` (`o` not zero; a zero divisor gives zero), 64 bits kept, the rest sticky.
    pub fn over(self, o: Ext) -> Ext {
        let neg = self.neg != o.neg;
        if self.m == 0 || o.m == 0 {
            return Ext { neg, ..Ext::ZERO };
        }
        // Long division: q = floor(a · 2^63 / d) in [2^62, 2^64); r < 2d is 65 bits wide.
        let (d, mut r, mut carry, mut q) = (o.m, self.m, false, 0u64);
        for _ in 0..64 {
            q <<= 1;
            if carry || r >= d {
                r = r.wrapping_sub(d);
                q |= 1;
            }
            carry = r >> 63 != 0;
            r <<= 1;
        }
        let sticky = u64::from(r != 0 || carry);
        let e = self.e.saturating_sub(o.e).saturating_sub(63);
        Ext::new(neg, q | sticky, e).clamped()
    }

    /// `self · 10^k`.
    pub fn scale10(mut self, mut k: i32) -> Ext {
        // 10^27 = 5^27 · 2^27 with 5^27 < 2^64: exact in 64 bits.
        while k != 0 && self.m != 0 && self.e.abs() < EXP_LIMIT {
            let step = k.clamp(-27, 27);
            let mut p: u64 = 1;
            for _ in 0..step.unsigned_abs() {
                p *= 5;
            }
            let p = Ext::new(false, p, step.abs());
            self = if step > 0 { self.times(p) } else { self.over(p) };
            k -= step;
        }
        self
    }

    /// Far beyond every range used here: kept bounded (infinite or zero for `f32`).
    fn clamped(self) -> Ext {
        if self.e < -EXP_LIMIT {
            Ext { neg: self.neg, ..Ext::ZERO }
        } else {
            Ext { e: self.e.min(EXP_LIMIT), ..self }
        }
    }

    /// The bits (sign excluded) of the nearest value (ties to even) of an IEEE 754 binary
    /// format with `frac_bits` fraction bits and `exp_max` the all-ones biased exponent;
    /// overflow gives infinity.
    fn ieee_bits(self, frac_bits: u32, exp_max: i32) -> u64 {
        if self.m == 0 {
            return 0;
        }
        let bias = exp_max / 2;
        let biased = self.e.saturating_add(63 + bias);
        let eff = biased.max(1);
        // Bits dropped from m: 63 − frac_bits, more for subnormals.
        let shift = (63 - frac_bits as i32).saturating_add(eff - biased) as u32;
        let (mant, rest, half) = match shift {
            1..=63 => (self.m >> shift, self.m & ((1 << shift) - 1), 1u64 << (shift - 1)),
            0 => (self.m, 0, 1),
            64 => (0, self.m, 1 << 63),
            _ => (0, 1, u64::MAX),
        };
        let up = rest > half || (rest == half && mant & 1 == 1);
        // The implicit bit carries into the exponent field (and a rounding overflow too).
        let bits = ((eff - 1) as u64) << frac_bits;
        let bits = bits + mant + u64::from(up);
        bits.min((exp_max as u64) << frac_bits)
    }

    /// The nearest `f32` (ties to even); ±infinity beyond its range.
    pub fn to_f32(self) -> f32 {
        let bits = self.ieee_bits(23, 255) as u32 | u32::from(self.neg) << 31;
        f32::from_bits(bits)
    }

    /// The nearest `f64` (ties to even): for tests on the host.
    #[cfg(test)]
    pub fn to_f64(self) -> f64 {
        f64::from_bits(self.ieee_bits(52, 2047) | u64::from(self.neg) << 63)
    }

    /// `|self|` rounded to an integer, halves up; `None` at 2^63 or more.
    pub fn round_half_up(self) -> Option<u64> {
        if self.m == 0 {
            return Some(0);
        }
        if self.e >= 0 {
            return None;
        }
        let shift = self.e.unsigned_abs();
        Some(match shift {
            1..=63 => {
                let (int, rest) = (self.m >> shift, self.m & ((1 << shift) - 1));
                int + u64::from(rest >= 1 << (shift - 1))
            }
            64 => u64::from(self.m >= 1 << 63),
            _ => 0,
        })
    }

    /// The order of the values (−0 = +0).
    pub fn compare(self, o: Ext) -> Ordering {
        let mag = |a: Ext, b: Ext| match (a.m == 0, b.m == 0) {
            (false, false) => (a.e, a.m).cmp(&(b.e, b.m)),
            (za, zb) => zb.cmp(&za),
        };
        match (self.is_negative(), o.is_negative()) {
            (false, false) => mag(self, o),
            (true, true) => mag(o, self),
            (false, true) => Ordering::Greater,
            (true, false) => Ordering::Less,
        }
    }

    /// ⌊log2 |self|⌋ (zero: 0).
    pub fn log2(self) -> i32 {
        if self.m == 0 {
            0
        } else {
            self.e + 63
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_round_trips_exactly() {
        let mut x: u32 = 7;
        for _ in 0..100_000 {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let v = f32::from_bits(x);
            if v.is_finite() {
                assert_eq!(Ext::from_f32(v).to_f32().to_bits(), v.to_bits(), "{v:e}");
                assert_eq!(Ext::from_f32(v).to_f64(), f64::from(v));
            }
        }
    }

    #[test]
    fn operations_round_like_f64() {
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        for _ in 0..100_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let a = f32::from_bits(x as u32);
            let b = f32::from_bits((x >> 32) as u32);
            if !(a.is_finite() && b.is_finite() && b != 0.0) {
                continue;
            }
            let (ea, eb) = (Ext::from_f32(a), Ext::from_f32(b));
            // Exact in f64 (48-bit product), and to f32 correctly rounded from it.
            assert_eq!(ea.times(eb).to_f64(), f64::from(a) * f64::from(b), "{a:e}*{b:e}");
            assert_eq!(ea.times(eb).to_f32(), a * b, "{a:e}*{b:e}");
            assert_eq!(ea.over(eb).to_f32(), a / b, "{a:e}/{b:e}");
            assert_eq!(ea.over(eb).to_f64(), f64::from(a) / f64::from(b), "{a:e}/{b:e}");
        }
        assert_eq!(Ext::from_f64(3.5).to_f64(), 3.5);
        assert_eq!(Ext::from_f64(-1e300).times(Ext::from_f64(1e300)).to_f32(), f32::NEG_INFINITY);
        assert_eq!(Ext::from_f64(1e-300).times(Ext::from_f64(1e-300)).to_f64(), 0.0);
    }

    #[test]
    fn order_matches_f32() {
        let v = [-3.5f32, -1.0, -1e-30, -0.0, 0.0, 1e-40, 0.5, 1.0, 1.000_000_1, 7e20];
        for a in v {
            for b in v {
                let want = a.partial_cmp(&b).unwrap();
                assert_eq!(Ext::from_f32(a).compare(Ext::from_f32(b)), want, "{a:e} {b:e}");
            }
        }
    }

    #[test]
    fn integer_rounding() {
        assert_eq!(Ext::from_f32(2.5).round_half_up(), Some(3));
        assert_eq!(Ext::from_f32(2.499_999_8).round_half_up(), Some(2));
        assert_eq!(Ext::from_f32(0.5).round_half_up(), Some(1));
        assert_eq!(Ext::from_f32(0.499_999_97).round_half_up(), Some(0));
        assert_eq!(Ext::from_f32(1e-30).round_half_up(), Some(0));
        assert_eq!(Ext::from_u64(1234).round_half_up(), Some(1234));
        assert_eq!(Ext::from_f32(1e30).round_half_up(), None);
        assert_eq!(Ext::from_u64(3).scale10(-1).scale10(1).round_half_up(), Some(3));
        assert_eq!(Ext::from_u64(12_345).scale10(30).to_f64(), 1.2345e34);
    }
}
