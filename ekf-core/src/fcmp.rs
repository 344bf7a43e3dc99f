//! Exact `f32` comparisons in integer arithmetic.
//!
//! On a Cortex-M3 (no FPU) every `<`, `<=`, `==`, `max` or `min` on floats is a soft-float
//! library call of 50–125 cycles (measured, `docs/performance.md`); the EKF makes about 40 of
//! them per update. These functions take a handful of integer instructions and return exactly
//! what the operators return for every input — NaN (always unordered) and `−0 == +0`
//! included — which the tests check against the operators on every pair of special values and
//! on random bit patterns. They change no result: host and target stay bit-identical.

/// Use the integer forms: on the Cortex-M3 (no FPU) they replace library calls; elsewhere the
/// float operators are single instructions. Both give the same answers (tested).
const INTEGER: bool = cfg!(target_arch = "arm");

/// `a < b`.
#[inline(always)]
pub fn lt(a: f32, b: f32) -> bool {
    if INTEGER {
        int::lt(a, b)
    } else {
        a < b
    }
}

/// `a <= b`.
#[inline(always)]
pub fn le(a: f32, b: f32) -> bool {
    if INTEGER {
        int::le(a, b)
    } else {
        a <= b
    }
}

/// `a > b`.
#[inline(always)]
pub fn gt(a: f32, b: f32) -> bool {
    lt(b, a)
}

/// `a >= b`.
#[inline(always)]
pub fn ge(a: f32, b: f32) -> bool {
    le(b, a)
}

/// `a == 0.0` (true for both zeros).
#[inline(always)]
pub fn is_zero(a: f32) -> bool {
    if INTEGER {
        int::is_zero(a)
    } else {
        a == 0.0
    }
}

/// `|a| <= limit` for `limit ≥ 0` (false when `a` is NaN; `limit` may be +∞).
#[inline(always)]
pub fn abs_le(a: f32, limit: f32) -> bool {
    if INTEGER {
        int::abs_le(a, limit)
    } else {
        a.abs() <= limit
    }
}

/// `0 < a <= max` for `max ≥ 0` (false for NaN, zeros and negative `a`).
#[inline(always)]
pub fn in_pos_range(a: f32, max: f32) -> bool {
    if INTEGER {
        int::in_pos_range(a, max)
    } else {
        a > 0.0 && a <= max
    }
}

/// The largest of three magnitudes, as `|a|.max(|b|).max(|c|)`: NaN only when all three are
/// NaN.
#[inline(always)]
pub fn max_abs3(a: f32, b: f32, c: f32) -> f32 {
    if INTEGER {
        int::max_abs3(a, b, c)
    } else {
        a.abs().max(b.abs()).max(c.abs())
    }
}

/// `a.min(b)`: the smaller, or the other operand when one is NaN.
#[inline(always)]
pub fn min(a: f32, b: f32) -> f32 {
    if INTEGER {
        int::min(a, b)
    } else {
        a.min(b)
    }
}

/// The integer forms.
mod int {
    /// Sign-magnitude bits → an `i32` whose order is the float order (−0 sorts just below +0).
    #[inline(always)]
    fn key(b: u32) -> i32 {
        let s = b as i32;
        s ^ (((s >> 31) as u32) >> 1) as i32
    }

    #[inline(always)]
    fn is_nan_bits(b: u32) -> bool {
        b & 0x7fff_ffff > 0x7f80_0000
    }

    /// `b`, hidden from the optimiser: LLVM turns `bits & 0x7fff_ffff == 0` back into a float
    /// comparison with zero, which is a library call again on a soft-float target.
    #[inline(always)]
    fn opaque(b: u32) -> u32 {
        core::hint::black_box(b)
    }

    /// Both operands are zeros (of any sign).
    #[inline(always)]
    fn both_zero(x: u32, y: u32) -> bool {
        opaque(x | y) & 0x7fff_ffff == 0
    }

    /// `a < b`.
    #[inline(always)]
    pub(super) fn lt(a: f32, b: f32) -> bool {
        let (x, y) = (a.to_bits(), b.to_bits());
        !(is_nan_bits(x) || is_nan_bits(y) || both_zero(x, y)) && key(x) < key(y)
    }

    /// `a <= b`.
    #[inline(always)]
    pub(super) fn le(a: f32, b: f32) -> bool {
        let (x, y) = (a.to_bits(), b.to_bits());
        !(is_nan_bits(x) || is_nan_bits(y)) && (both_zero(x, y) || key(x) <= key(y))
    }

    /// `a == 0.0` (true for both zeros).
    #[inline(always)]
    pub(super) fn is_zero(a: f32) -> bool {
        opaque(a.to_bits()) & 0x7fff_ffff == 0
    }

    /// `|a| <= limit` for `limit ≥ 0` (false when `a` is NaN; `limit` may be +∞).
    #[inline(always)]
    pub(super) fn abs_le(a: f32, limit: f32) -> bool {
        debug_assert!(limit >= 0.0);
        // Magnitudes of non-negative floats order as their bits; a NaN's are above +∞'s.
        a.to_bits() & 0x7fff_ffff <= limit.to_bits() & 0x7fff_ffff
    }

    /// `0 < a <= max` for `max ≥ 0` (false for NaN, zeros and negative `a`).
    #[inline(always)]
    pub(super) fn in_pos_range(a: f32, max: f32) -> bool {
        debug_assert!(max >= 0.0);
        let b = a.to_bits();
        (b as i32) > 0 && b <= max.to_bits() & 0x7fff_ffff
    }

    /// The largest of three magnitudes, as `|a|.max(|b|).max(|c|)`: NaN only when all three are
    /// NaN.
    #[inline(always)]
    pub(super) fn max_abs3(a: f32, b: f32, c: f32) -> f32 {
        let m = [a, b, c].map(|v| v.to_bits() & 0x7fff_ffff);
        let pick = |x: u32, y: u32| {
            if is_nan_bits(x) || (!is_nan_bits(y) && y > x) {
                y
            } else {
                x
            }
        };
        f32::from_bits(pick(pick(m[0], m[1]), m[2]))
    }

    /// `a.min(b)`: the smaller, or the other operand when one is NaN.
    #[inline(always)]
    pub(super) fn min(a: f32, b: f32) -> f32 {
        if lt(b, a) || is_nan_bits(a.to_bits()) {
            b
        } else {
            a
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const SPECIAL: [f32; 16] = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        1e-45,
        -1e-45,
        f32::MAX,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        -f32::NAN,
        0.5,
        3.0e-39,
    ];

    fn agrees(a: f32, b: f32) -> Result<(), TestCaseError> {
        prop_assert_eq!(int::lt(a, b), a < b, "{} < {}", a, b);
        prop_assert_eq!(int::le(a, b), a <= b, "{} <= {}", a, b);
        prop_assert_eq!(int::lt(b, a), a > b, "{} > {}", a, b);
        prop_assert_eq!(int::le(b, a), a >= b, "{} >= {}", a, b);
        prop_assert_eq!(int::is_zero(a), a == 0.0);
        if b >= 0.0 {
            prop_assert_eq!(int::abs_le(a, b), a.abs() <= b, "|{}| <= {}", a, b);
            prop_assert_eq!(int::in_pos_range(a, b), a > 0.0 && a <= b, "0 < {} <= {}", a, b);
        }
        let (m, r) = (int::min(a, b), a.min(b));
        prop_assert!(m == r || (m.is_nan() && r.is_nan()), "int::min({}, {})", a, b);
        Ok(())
    }

    #[test]
    fn special_values_agree_with_the_operators() {
        for a in SPECIAL {
            for b in SPECIAL {
                agrees(a, b).unwrap();
                for c in SPECIAL {
                    let (m, r) = (int::max_abs3(a, b, c), a.abs().max(b.abs()).max(c.abs()));
                    assert!(m.to_bits() == r.to_bits() || (m.is_nan() && r.is_nan()));
                }
            }
        }
    }

    proptest! {
        #[test]
        fn random_bit_patterns_agree_with_the_operators(x in any::<u32>(), y in any::<u32>(),
                                                        z in any::<u32>()) {
            let (a, b, c) = (f32::from_bits(x), f32::from_bits(y), f32::from_bits(z));
            agrees(a, b)?;
            // Nearby values: same sign and exponent most of the time.
            agrees(a, f32::from_bits(x ^ (y & 0xff)))?;
            let (m, r) = (int::max_abs3(a, b, c), a.abs().max(b.abs()).max(c.abs()));
            prop_assert!(m.to_bits() == r.to_bits() || (m.is_nan() && r.is_nan()));
        }
    }
}
