//! The digest's seven-state additive model: process, measurement, and the quaternion helpers.

use nalgebra::{SMatrix, SVector};

use super::{Real, Vector};

/// The digest's process model: `ω = gyro − b`, `q ← (I + ½ Ω(ω) dt) q`, bias constant.
pub(crate) fn process<T: Real>(x: &Vector<T>, gyro: &[T; 3], dt: T) -> Vector<T> {
    let h = dt * T::of(0.5);
    let w = x[0];
    let u = [x[1], x[2], x[3]];
    let o = [gyro[0] - x[4], gyro[1] - x[5], gyro[2] - x[6]];
    // Ω(ω) q = (−ω·u, w ω − ω × u).
    let dot = o[0] * u[0] + o[1] * u[1] + o[2] * u[2];
    let cr = [o[1] * u[2] - o[2] * u[1], o[2] * u[0] - o[0] * u[2], o[0] * u[1] - o[1] * u[0]];
    let mut y = *x;
    y[0] = w - h * dot;
    for k in 0..3 {
        y[1 + k] = u[k] + h * (w * o[k] - cr[k]);
    }
    y
}

/// Measurement model: the NED "down" axis in the body frame, `down_in_body(q)`, evaluated on
/// the (possibly not unit) quaternion part of `x`.
pub(crate) fn down<T: Real>(x: &Vector<T>) -> SVector<T, 3> {
    let (w, a, b, c) = (x[0], x[1], x[2], x[3]);
    let two = T::of(2.0);
    SVector::<T, 3>::new(
        two * (a * c - w * b),
        two * (b * c + w * a),
        T::one() - two * (a * a + b * b),
    )
}

/// `Γ(q)` (4×3): `δq = ½ Γ(q) δθ` for a small rotation `δθ` about NED axes applied on the left.
pub(super) fn gamma<T: Real>(x: &Vector<T>) -> SMatrix<T, 4, 3> {
    let (w, a, b, c) = (x[0], x[1], x[2], x[3]);
    SMatrix::<T, 4, 3>::new(-a, -b, -c, w, c, -b, -c, w, a, b, -a, w)
}

/// Normalise the quaternion part of `x` by its norm (no sign change). Leaves `x` alone when
/// the norm is zero or not finite (the health check handles that).
pub(super) fn normalise_quaternion<T: Real>(x: &mut Vector<T>) {
    let n2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3];
    let n = n2.sqrt();
    if n.is_finite() && n > T::of(1e-15) {
        for k in 0..4 {
            x[k] /= n;
        }
    }
}
