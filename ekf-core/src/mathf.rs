//! Scalar `f32` functions for `no_std` (thin wrappers over `libm`, so host and target compute
//! bit-identical results), and small helpers used across the crate.

/// Square root. `sqrt(x)` for `x < 0` is NaN, as in IEEE 754.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}
/// Sine of `x` rad.
#[inline]
pub fn sin(x: f32) -> f32 {
    libm::sinf(x)
}
/// Cosine of `x` rad.
#[inline]
pub fn cos(x: f32) -> f32 {
    libm::cosf(x)
}
/// Four-quadrant arctangent of `y / x`, rad in (−π, π].
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    libm::atan2f(y, x)
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
    fn asin_clamped_never_nan() {
        assert_eq!(asin_clamped(1.000_01), PI / 2.0);
        assert_eq!(asin_clamped(-7.0), -PI / 2.0);
    }
}
