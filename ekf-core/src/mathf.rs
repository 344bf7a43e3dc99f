//! Scalar `f32` functions for `no_std`, and small helpers used across the crate. Each is pure
//! Rust with no platform call, so host and target compute bit-identical results: `sqrt`,
//! `asin_clamped`, `abs` and `wrap_pi`'s floor come from `libm`; `sin_cos` and `atan2` are this
//! file's own polynomials (Cephes' single-precision method, and a minimax `atan2` within
//! 2.1·10⁻⁶ rad), smaller and faster on the Cortex-M3 than `libm`'s and tested against it; the
//! power-of-two scalings (`twice`, `half`, `quarter`) work on the exponent bits on the target
//! (exactly the product elsewhere).

/// Square root. `sqrt(x)` for `x < 0` is NaN, as in IEEE 754.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}
/// Sine of `x` rad (see [`sin_cos`]).
#[inline]
pub fn sin(x: f32) -> f32 {
    sin_cos(x).0
}
/// Cosine of `x` rad (see [`sin_cos`]).
#[inline]
pub fn cos(x: f32) -> f32 {
    sin_cos(x).1
}

/// `(sin x, cos x)`, within 2.5e−7 of the exact values for |x| ≤ 8192 rad (tested against
/// `f64`); NaN for a non-finite `x`. Cephes' single-precision method: reduction to
/// [−π/4, π/4] by a three-part π/4, then degree-7 and degree-8 polynomials. Larger arguments
/// are first reduced by whole turns in `f32` (their error grows as |x|·1e−7; no angle of this
/// filter comes near). ≈ 400 bytes of code in place of `libm`'s 5.6 KB (`sinf`, `cosf` and the
/// exact large-argument reduction `rem_pio2f`).
pub fn sin_cos(x: f32) -> (f32, f32) {
    const FOPI: f32 = 1.273_239_5; // 4/π
    const DP1: f32 = 0.785_156_25;
    const DP2: f32 = 2.418_756_5e-4;
    const DP3: f32 = 3.774_895e-8;
    if !x.is_finite() {
        return (f32::NAN, f32::NAN);
    }
    let x = if x.abs() > 8192.0 { reduce_2pi(x) } else { x };
    let neg = x.is_sign_negative();
    let ax = x.abs();
    // Octant j (even), so that ax − j·π/4 ∈ [−π/4, π/4].
    let mut j = (ax * FOPI) as u32;
    j = (j + 1) & !1;
    let y = j as f32;
    let r = ((ax - y * DP1) - y * DP2) - y * DP3;
    let z = r * r;
    let s = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * r + r;
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    // Quadrant q = j/2 mod 4: (sin, cos) = (s, c), (c, −s), (−s, −c), (−c, s).
    let (sv, cv) = match (j >> 1) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    };
    (if neg { -sv } else { sv }, cv)
}
/// Four-quadrant arctangent of `y / x`, rad in [−π, π], within 2.1e−6 rad (1.2e−4°) of the
/// exact value for finite arguments; zeros, infinities and NaN as IEEE `atan2`
/// (`libm::atan2f`).
///
/// One division and a degree-11 odd polynomial on [0, 1] (coefficients fitted minimax to
/// `atan` with the value at 1 held at π/4, so 45° is exact to rounding; error 1.8e−6 before
/// `f32` rounding, the rest is the rounding of the result and of `π`), octant by octant: about
/// 790 cycles on the Cortex-M3 against 1,450 for `libm::atan2f` (docs/performance.md). Degree
/// 13 gave 6e−7 rad for one more multiply-add per call. Exercised against `libm::atan2f` in the
/// tests. For angles that are only printed, [`atan2_display`] is one multiply-add cheaper.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    const C: [f32; 6] =
        [0.999_975_7, -0.332_585_2, 0.193_293_69, -0.115_781_985, 0.051_923_502, -0.011_427_532];
    // Horner, written out (kept unrolled at every optimisation level).
    atan2_with(y, x, |u| (((((C[5] * u + C[4]) * u + C[3]) * u + C[2]) * u + C[1]) * u) + C[0])
}

/// [`atan2`] with a degree-9 polynomial (fitted the same way, error 1.25e−5 before `f32`
/// rounding): within 1.3e−5 rad (7.2e−4°), for the Euler angles of the output, which are
/// printed to 0.01° (1.7e−4 rad, 14× coarser) from an estimate good to a few hundredths of a
/// degree at best. Nothing in the estimator's state handling uses it.
#[inline]
pub fn atan2_display(y: f32, x: f32) -> f32 {
    const C: [f32; 5] = [0.999_855_5, -0.330_125_2, 0.179_388_31, -0.083_966_25, 0.020_245_78];
    atan2_with(y, x, |u| ((((C[4] * u + C[3]) * u + C[2]) * u + C[1]) * u) + C[0])
}

/// The octant reduction of [`atan2`] around an odd polynomial `t·p(t²)` for `atan` on [0, 1].
#[inline(always)]
fn atan2_with(y: f32, x: f32, p: impl Fn(f32) -> f32) -> f32 {
    let (ay, ax) = (y.to_bits() & 0x7fff_ffff, x.to_bits() & 0x7fff_ffff);
    if ax >= 0x7f80_0000 || ay >= 0x7f80_0000 || (ax | ay) == 0 {
        return atan2_special(y, x);
    }
    let swap = ay > ax;
    let (num, den) = if swap { (ay, ax) } else { (ax, ay) };
    let (num, den) = (f32::from_bits(den), f32::from_bits(num));
    let t = num / den; // in [0, 1]
    let mut a = p(t * t) * t;
    // The reflections out of line (`sub_from`): inline, LLVM would compute both on every call.
    if swap {
        a = sub_from(core::f32::consts::FRAC_PI_2, a);
    }
    if x.to_bits() >> 31 != 0 {
        a = sub_from(core::f32::consts::PI, a);
    }
    if y.to_bits() >> 31 != 0 {
        -a
    } else {
        a
    }
}
/// `x` minus a whole number of turns (three-part 2π), for |x| > 8192 (rare, out of line).
#[cold]
#[inline(never)]
fn reduce_2pi(x: f32) -> f32 {
    // 2π = T1 + T2 + T3; T1 has few significant bits, so k·T1 is exact.
    const T1: f32 = 6.281_25;
    const T2: f32 = 1.935_307_2e-3;
    const T3: f32 = 1.025_313_2e-11;
    let k = (x * (0.5 / core::f32::consts::PI)) as i32 as f32; // saturates beyond ±1.3e10
    ((x - k * T1) - k * T2) - k * T3
}

/// `atan2` of non-finite arguments or of two zeros, by the IEEE 754 rules.
#[cold]
fn atan2_special(y: f32, x: f32) -> f32 {
    use core::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    if x.is_nan() || y.is_nan() {
        return f32::NAN;
    }
    let x_neg = x.is_sign_negative();
    let a = if y.is_infinite() {
        if x.is_infinite() {
            if x_neg {
                3.0 * FRAC_PI_4
            } else {
                FRAC_PI_4
            }
        } else {
            FRAC_PI_2
        }
    } else if x_neg {
        PI // y finite; x = −∞ or −0
    } else {
        0.0 // y finite; x = +∞ or +0
    };
    if y.is_sign_negative() {
        -a
    } else {
        a
    }
}

/// Arcsine, rad, with the argument clamped to [−1, 1] so rounding never yields NaN.
#[inline]
pub fn asin_clamped(x: f32) -> f32 {
    libm::asinf(x.clamp(-1.0, 1.0))
}
/// Absolute value.
#[inline]
pub fn abs(x: f32) -> f32 {
    libm::fabsf(x)
}

/// `x · 2ᵏ` for `k` in −2..=1, bit-for-bit what the multiplication gives, by adding `k` to
/// the exponent field when the result is a normal number (a few integer instructions instead
/// of a ~45-cycle soft-float call on the Cortex-M3); zeros, subnormals, infinities, NaN and
/// results that would leave the normal range take the multiplication.
#[inline(always)]
fn scale_pow2<const K: i32>(x: f32, by: f32) -> f32 {
    let b = x.to_bits();
    let e = ((b >> 23) & 0xff) as i32;
    if e + K >= 1 && e + K <= 254 && e != 0 && e != 255 {
        f32::from_bits((b as i32 + (K << 23)) as u32)
    } else {
        mul_cold(x, by)
    }
}

/// The multiplication out of line: inline, LLVM would evaluate it speculatively on both
/// paths (it prices a float multiply as one instruction, not as a library call).
#[cold]
#[inline(never)]
fn mul_cold(x: f32, by: f32) -> f32 {
    x * by
}

/// `c − a` out of line, for a subtraction on one branch only: inline, LLVM evaluates it on both
/// (as `mul_cold`), which on the Cortex-M3 is a library call of ~60 cycles taken for nothing.
#[inline(never)]
fn sub_from(c: f32, a: f32) -> f32 {
    c - a
}

/// The exponent arithmetic pays on the Cortex-M3 (no FPU); elsewhere a multiplication is one
/// instruction. Same results either way (tested).
const POW2_BY_EXPONENT: bool = cfg!(target_arch = "arm");

/// `2·x`, exactly as `2.0 * x` (see `scale_pow2`).
#[inline(always)]
pub fn twice(x: f32) -> f32 {
    if POW2_BY_EXPONENT {
        scale_pow2::<1>(x, 2.0)
    } else {
        2.0 * x
    }
}

/// `x / 2`, exactly as `0.5 * x`.
#[inline(always)]
pub fn half(x: f32) -> f32 {
    if POW2_BY_EXPONENT {
        scale_pow2::<-1>(x, 0.5)
    } else {
        0.5 * x
    }
}

/// `x / 4`, exactly as `0.25 * x`.
#[inline(always)]
pub fn quarter(x: f32) -> f32 {
    if POW2_BY_EXPONENT {
        scale_pow2::<-2>(x, 0.25)
    } else {
        0.25 * x
    }
}

/// Wrap an angle to (−π, π], rad. Non-finite input is returned unchanged.
pub fn wrap_pi(a: f32) -> f32 {
    if !a.is_finite() {
        return a;
    }
    let two_pi = 2.0 * core::f32::consts::PI;
    let mut w = a - two_pi * libm::floorf((a + core::f32::consts::PI) / two_pi);
    if w <= -core::f32::consts::PI {
        w += two_pi;
    }
    w
}

/// Degrees to radians.
#[inline]
pub fn deg(x: f32) -> f32 {
    x * (core::f32::consts::PI / 180.0)
}

/// Radians to degrees.
#[inline]
pub fn to_deg(x: f32) -> f32 {
    x * (180.0 / core::f32::consts::PI)
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f32::consts::PI;

    #[test]
    fn wrap_pi_maps_into_half_open_interval() {
        assert!((wrap_pi(3.0 * PI) - PI).abs() < 1e-5);
        // −3π lies on the seam: either end of the interval is within rounding.
        assert!((wrap_pi(-3.0 * PI).abs() - PI).abs() < 1e-5);
        assert!((wrap_pi(0.5) - 0.5).abs() < 1e-7);
        assert!((wrap_pi(2.0 * PI + 0.25) - 0.25).abs() < 1e-5);
        assert!((wrap_pi(-PI / 2.0 - 4.0 * PI) + PI / 2.0).abs() < 1e-5);
    }

    #[test]
    fn power_of_two_scaling_is_the_multiplication_bit_for_bit() {
        let mut s = 0x1234_5678u32;
        let check = |b: u32| {
            let x = f32::from_bits(b);
            for (got, want) in [
                (scale_pow2::<1>(x, 2.0), 2.0 * x),
                (scale_pow2::<-1>(x, 0.5), 0.5 * x),
                (scale_pow2::<-2>(x, 0.25), 0.25 * x),
            ] {
                assert!(
                    got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                    "{b:#x}"
                );
            }
        };
        // Every exponent (with its edges) and sign, then random patterns.
        for e in 0..=255u32 {
            for m in [0, 1, 2, 3, 0x40_0000, 0x7f_fffe, 0x7f_ffff] {
                check(e << 23 | m);
                check(0x8000_0000 | e << 23 | m);
            }
        }
        for _ in 0..200_000 {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            check(s);
        }
    }

    #[test]
    fn atan2_is_within_its_bound_of_libm_everywhere() {
        // Each function with its bound and a floor its worst error must reach (the check sees
        // the approximation error, not only rounding).
        type Atan2 = fn(f32, f32) -> f32;
        let cases: [(Atan2, f64, f64); 2] = [(atan2, 2.1e-6, 1e-6), (atan2_display, 1.3e-5, 1e-5)];
        for (f, bound, floor) in cases {
            let mut worst = 0.0f64;
            let mut s = 0x9e37_79b9u32;
            let mut check = |y: f32, x: f32| {
                let (got, exact) = (f(y, x), libm::atan2(y as f64, x as f64));
                let e = (got as f64 - exact).abs();
                assert!(e <= bound, "atan2({y}, {x}) = {got}, exact {exact}");
                worst = worst.max(e);
            };
            // Every direction on a fine circle, then random magnitudes and ratios.
            for k in 0..100_000 {
                let a = -PI + 2.0 * PI * k as f32 / 100_000.0;
                check(libm::sinf(a), libm::cosf(a));
            }
            for _ in 0..200_000 {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let y = f32::from_bits(s & 0x83ff_ffff | 0x3800_0000); // ±[2⁻¹⁵, 2⁸)
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let x = f32::from_bits(s & 0x83ff_ffff | 0x3800_0000);
                check(y, x);
            }
            assert!(worst > floor, "the check must see the approximation error: {worst}");
        }
        // Special cases as libm.
        for (y, x) in [
            (0.0, 0.0),
            (-0.0, -0.0),
            (0.0, -1.0),
            (-0.0, -1.0),
            (1.0, f32::INFINITY),
            (f32::INFINITY, f32::INFINITY),
            (f32::NAN, 1.0),
            (1.0, 0.0),
            (-1.0, -0.0),
        ] {
            for a in [atan2(y, x), atan2_display(y, x)] {
                let b = libm::atan2f(y, x);
                assert!(
                    a.to_bits() == b.to_bits()
                        || (a.is_nan() && b.is_nan())
                        || (a - b).abs() < 3e-7,
                    "atan2({y}, {x}): {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn sin_cos_are_within_their_bound() {
        let mut worst = 0.0f64;
        let mut check = |x: f32| {
            let (s, c) = sin_cos(x);
            let es = (s as f64 - libm::sin(x as f64)).abs();
            let ec = (c as f64 - libm::cos(x as f64)).abs();
            assert!(es <= 2.5e-7 && ec <= 2.5e-7, "sin_cos({x}) = ({s}, {c})");
            assert_eq!((sin(x), cos(x)), (s, c));
            worst = worst.max(es).max(ec);
        };
        for k in -200_000..=200_000 {
            check(k as f32 * 1e-4); // ±20 rad, fine steps
        }
        let mut r = 0x2545_f491u32;
        for _ in 0..200_000 {
            r = r.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            check((r >> 8) as f32 / (1u32 << 24) as f32 * 16384.0 - 8192.0);
        }
        for x in [0.0, -0.0, 1e-30, -1e-30, core::f32::consts::FRAC_PI_4, core::f32::consts::PI] {
            check(x);
        }
        assert!(worst > 1e-9, "the check must see the rounding");
        assert_eq!(sin_cos(-0.0).0.to_bits(), (-0.0f32).to_bits());
        let (s, c) = sin_cos(1.0e7);
        assert!(s.abs() <= 1.0001 && c.abs() <= 1.0001 && (s * s + c * c - 1.0).abs() < 1e-5);
        for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let (s, c) = sin_cos(x);
            assert!(s.is_nan() && c.is_nan());
        }
    }

    /// Beyond 8192 rad the argument is first reduced by whole turns (`reduce_2pi`); without
    /// that the octant's three-part π/4 product loses bits (at 10⁵ rad, 6·10⁻³ off). The
    /// bound here is the reduction's (the f32 argument itself is exact, so libm's f64 value of
    /// it is the truth). Up to 2·10⁵ rad: a yaw integrated for weeks stays far below.
    #[test]
    fn sin_cos_of_large_arguments_reduce_by_whole_turns() {
        let mut worst = 0.0f64;
        let mut x = 8192.0f32;
        while x < 2.0e5 {
            for v in [x, -x] {
                let (s, c) = sin_cos(v);
                let es = (s as f64 - libm::sin(v as f64)).abs();
                let ec = (c as f64 - libm::cos(v as f64)).abs();
                worst = worst.max(es).max(ec);
            }
            x = x * 1.000_37 + 0.013;
        }
        // 2.1e−6 measured: the rounding of k·T2 for k up to 3·10⁴ turns.
        assert!(worst <= 4e-6, "worst error {worst} beyond 8192 rad");
        assert!(worst > 1e-7, "the check must see the reduction's rounding");
    }

    #[test]
    fn atan2_special_cases_follow_ieee() {
        let v = [0.0, -0.0, 1.0, -1.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
        for y in v {
            for x in v {
                let (a, b) = (atan2(y, x), libm::atan2f(y, x));
                assert!(
                    a.to_bits() == b.to_bits()
                        || (a.is_nan() && b.is_nan())
                        || (a - b).abs() < 6e-7,
                    "atan2({y}, {x}): {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn asin_clamped_never_nan() {
        assert_eq!(asin_clamped(1.000_01), PI / 2.0);
        assert_eq!(asin_clamped(-7.0), -PI / 2.0);
    }
}
