//! Scalar-first Hamilton quaternions. An attitude quaternion rotates body (FRD) vectors into
//! the reference frame (NED): `v_ned = q ⊗ v_frd ⊗ q*`.

use core::ops::Mul;

use crate::{mathf, Vec3};

/// Quaternion `w + x i + y j + z k` (Hamilton, scalar first). Dimensionless.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Quaternion {
    /// Scalar part.
    pub w: f32,
    /// i component.
    pub x: f32,
    /// j component.
    pub y: f32,
    /// k component.
    pub z: f32,
}

impl Default for Quaternion {
    fn default() -> Self {
        Quaternion::IDENTITY
    }
}

/// A 3×3 rotation matrix, row-major: `m[row][col]`.
pub type Mat3 = [[f32; 3]; 3];

impl Quaternion {
    /// The identity rotation.
    pub const IDENTITY: Quaternion = Quaternion::new(1.0, 0.0, 0.0, 0.0);

    /// From components (scalar first). Not normalised.
    pub const fn new(w: f32, x: f32, y: f32, z: f32) -> Self {
        Quaternion { w, x, y, z }
    }

    /// Conjugate (the inverse of a unit quaternion).
    #[inline]
    pub fn conjugate(self) -> Self {
        Quaternion::new(self.w, -self.x, -self.y, -self.z)
    }

    /// Squared norm.
    #[inline]
    pub fn norm_sq(self) -> f32 {
        self.w * self.w + self.x * self.x + self.y * self.y + self.z * self.z
    }

    /// Four-component dot product.
    #[inline]
    pub fn dot(self, o: Quaternion) -> f32 {
        self.w * o.w + self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Componentwise scaling.
    #[inline]
    pub fn scale(self, s: f32) -> Self {
        Quaternion::new(self.w * s, self.x * s, self.y * s, self.z * s)
    }

    /// True when every component is finite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.w.is_finite() && self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }

    /// Unit quaternion in the same direction with non-negative scalar part, or `None` when the
    /// norm is zero, tiny or not finite. Never produces NaN.
    pub fn try_normalized(self) -> Option<Self> {
        let n2 = self.norm_sq();
        if !(n2.is_finite() && crate::fcmp::gt(n2, 1e-30)) {
            return None;
        }
        // Near unit norm (every filter cycle: |q|² − 1 is the square of the small correction)
        // one Newton step of 1/√x at 1, 1.5 − 0.5·x, is exact to 3/8·(x − 1)² < 2.2e−8 for
        // |x − 1| < 2⁻¹², below f32's resolution: no square root, no division.
        let d = n2 - 1.0;
        let inv = if crate::fcmp::abs_le(d, 2.44e-4) {
            1.0 - mathf::half(d)
        } else {
            1.0 / mathf::sqrt(n2)
        };
        let s = if crate::fcmp::lt(self.w, 0.0) { -inv } else { inv };
        let q = self.scale(s);
        q.is_finite().then_some(q)
    }

    /// Unit quaternion in the same direction (scalar part ≥ 0); the identity when `self` has no
    /// usable direction (zero, tiny, NaN or infinite). Never produces NaN.
    #[inline]
    pub fn normalized(self) -> Self {
        self.try_normalized().unwrap_or(Quaternion::IDENTITY)
    }

    /// The rotation by angle `|v|` rad about axis `v/|v|` (exponential map of a rotation
    /// vector), for any angle.
    pub fn from_rotation_vector(v: Vec3) -> Self {
        let a2 = v.norm_sq();
        let (c, s_over_a) = if crate::fcmp::lt(a2, 0.25) {
            // Series in x = a/2 to x⁶: the truncation error (< x⁸/40320 ≈ 4e-10 for a < 0.5)
            // is far below f32 resolution, and it costs no trigonometric call.
            let x2 = mathf::quarter(a2);
            if crate::fcmp::lt(x2, 4.9e-4) {
                // |x| < 0.022 (a rate below 2.2 rad/s, 126 °/s, at 50 Hz): the x⁴ terms are
                // below x⁴/24 = 1e-8, a sixth of the last place of 1 (f32 resolution 6e-8).
                let c = 1.0 - mathf::half(x2);
                let s = mathf::half(1.0 - x2 * (1.0 / 6.0));
                (c, s)
            } else if crate::fcmp::lt(x2, 1e-3) {
                // |x| < 0.032 (a rate below 3.2 rad/s at 50 Hz): the x⁶ terms are below 2e-12,
                // under a hundred-thousandth of the last place of 1.
                let c = 1.0 - x2 * (0.5 - x2 * (1.0 / 24.0));
                let s = mathf::half(1.0 - x2 * (1.0 / 6.0 - x2 * (1.0 / 120.0)));
                (c, s)
            } else {
                let c = 1.0 - x2 * (0.5 - x2 * (1.0 / 24.0 - x2 * (1.0 / 720.0)));
                let s =
                    mathf::half(1.0 - x2 * (1.0 / 6.0 - x2 * (1.0 / 120.0 - x2 * (1.0 / 5040.0))));
                (c, s)
            }
        } else {
            let a = mathf::sqrt(a2);
            (mathf::cos(0.5 * a), mathf::sin(0.5 * a) / a)
        };
        Quaternion::new(c, v.x * s_over_a, v.y * s_over_a, v.z * s_over_a)
    }

    /// Small-angle form of [`Quaternion::from_rotation_vector`]: `(1, v/2)`, not normalised.
    /// Accurate to second order; used where the caller normalises afterwards.
    #[inline]
    pub fn from_small_rotation(v: Vec3) -> Self {
        Quaternion::new(1.0, 0.5 * v.x, 0.5 * v.y, 0.5 * v.z)
    }

    /// `(c, 0, 0, s) ⊗ self`: a rotation about the reference z axis given by an unnormalised
    /// `(cos, sin)` of half the angle, in 8 multiplications instead of 16.
    #[inline]
    pub fn pre_rotate_z(self, c: f32, s: f32) -> Quaternion {
        Quaternion::new(
            c * self.w - s * self.z,
            c * self.x - s * self.y,
            c * self.y + s * self.x,
            c * self.z + s * self.w,
        )
    }

    /// `(1, v/2) ⊗ self`: the small-angle rotation `v` (rad, reference frame) applied on the
    /// left, not normalised (12 multiplications).
    #[inline]
    pub fn pre_rotate_small(self, v: Vec3) -> Quaternion {
        let (a, b, c) = (mathf::half(v.x), mathf::half(v.y), mathf::half(v.z));
        Quaternion::new(
            self.w - a * self.x - b * self.y - c * self.z,
            self.x + a * self.w + b * self.z - c * self.y,
            self.y - a * self.z + b * self.w + c * self.x,
            self.z + a * self.y - b * self.x + c * self.w,
        )
    }

    /// [`Quaternion::pre_rotate_small`] for a rotation vector `(vx, vy, 0)` (a horizontal axis
    /// in the reference frame): 8 multiplications.
    #[inline]
    pub fn pre_rotate_small_xy(self, vx: f32, vy: f32) -> Quaternion {
        let (a, b) = (mathf::half(vx), mathf::half(vy));
        Quaternion::new(
            self.w - a * self.x - b * self.y,
            self.x + a * self.w + b * self.z,
            self.y - a * self.z + b * self.w,
            self.z + a * self.y - b * self.x,
        )
    }

    /// Rotation about the reference z axis (down) by `angle` rad: a pure yaw change.
    pub fn from_yaw(angle: f32) -> Self {
        Quaternion::new(mathf::cos(0.5 * angle), 0.0, 0.0, mathf::sin(0.5 * angle))
    }

    /// This attitude rotated about NED z so that its Z-Y-X yaw is `yaw` rad; roll and pitch
    /// are kept.
    pub fn with_yaw(self, yaw: f32) -> Quaternion {
        let d = mathf::wrap_pi(yaw - crate::Euler::yaw_of(self));
        (Quaternion::from_yaw(d) * self).normalized()
    }

    /// Rotation vector (axis × angle, rad) of a unit quaternion, angle in [0, π].
    pub fn to_rotation_vector(self) -> Vec3 {
        let q = if self.w < 0.0 { self.scale(-1.0) } else { self };
        let v = Vec3::new(q.x, q.y, q.z);
        let s = v.norm();
        if s < 1e-6 {
            return v * 2.0;
        }
        let angle = 2.0 * mathf::atan2(s, q.w);
        v * (angle / s)
    }

    /// Rotation matrix `R` with `v_ned = R · v_body` (for an attitude quaternion).
    pub fn to_rotation_matrix(self) -> Mat3 {
        let Quaternion { w, x, y, z } = self;
        let (xx, yy, zz) = (x * x, y * y, z * z);
        let (xy, xz, yz) = (x * y, x * z, y * z);
        let (wx, wy, wz) = (w * x, w * y, w * z);
        let two = mathf::twice;
        [
            [1.0 - two(yy + zz), two(xy - wz), two(xz + wy)],
            [two(xy + wz), 1.0 - two(xx + zz), two(yz - wx)],
            [two(xz - wy), two(yz + wx), 1.0 - two(xx + yy)],
        ]
    }

    /// Rotate a body vector into the reference frame: `q ⊗ v ⊗ q*`.
    pub fn rotate(self, v: Vec3) -> Vec3 {
        // v + 2 w (u × v) + 2 u × (u × v), with u the vector part.
        let u = Vec3::new(self.x, self.y, self.z);
        let t = u.cross(v) * 2.0;
        v + t * self.w + u.cross(t)
    }

    /// Rotate a reference-frame vector into the body frame: `q* ⊗ v ⊗ q`.
    #[inline]
    pub fn rotate_inverse(self, v: Vec3) -> Vec3 {
        self.conjugate().rotate(v)
    }

    /// The reference "down" axis (NED z) expressed in the body frame: the third row of `R`.
    /// A still accelerometer reads `−g` times this.
    #[inline]
    pub fn down_in_body(self) -> Vec3 {
        let Quaternion { w, x, y, z } = self;
        Vec3::new(2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y))
    }

    /// Normalised linear interpolation toward `o` by `t ∈ [0, 1]` along the shorter arc.
    pub fn nlerp(self, o: Quaternion, t: f32) -> Quaternion {
        let o = if self.dot(o) < 0.0 { o.scale(-1.0) } else { o };
        Quaternion::new(
            self.w + t * (o.w - self.w),
            self.x + t * (o.x - self.x),
            self.y + t * (o.y - self.y),
            self.z + t * (o.z - self.z),
        )
        .normalized()
    }

    /// Spherical linear interpolation toward `o` by `t ∈ [0, 1]` along the shorter arc.
    pub fn slerp(self, o: Quaternion, t: f32) -> Quaternion {
        let mut d = self.dot(o);
        let o = if d < 0.0 {
            d = -d;
            o.scale(-1.0)
        } else {
            o
        };
        if d > 0.9995 {
            return self.nlerp(o, t);
        }
        let theta = mathf::atan2(mathf::sqrt((1.0 - d * d).max(0.0)), d);
        let s = mathf::sin(theta);
        let a = mathf::sin((1.0 - t) * theta) / s;
        let b = mathf::sin(t * theta) / s;
        Quaternion::new(
            a * self.w + b * o.w,
            a * self.x + b * o.x,
            a * self.y + b * o.y,
            a * self.z + b * o.z,
        )
        .normalized()
    }

    /// Angle of the rotation between two attitudes, rad in [0, π].
    pub fn angle_to(self, o: Quaternion) -> f32 {
        let d = mathf::abs(self.dot(o)).min(1.0);
        let v = self.conjugate() * o;
        let s = mathf::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
        2.0 * mathf::atan2(s, d)
    }
}

impl Mul for Quaternion {
    type Output = Quaternion;
    /// Hamilton product `self ⊗ o` (apply `o` first, then `self`).
    #[inline]
    fn mul(self, o: Quaternion) -> Quaternion {
        Quaternion::new(
            self.w * o.w - self.x * o.x - self.y * o.y - self.z * o.z,
            self.w * o.x + self.x * o.w + self.y * o.z - self.z * o.y,
            self.w * o.y - self.x * o.z + self.y * o.w + self.z * o.x,
            self.w * o.z + self.x * o.y - self.y * o.x + self.z * o.w,
        )
    }
}

#[cfg(test)]
mod tests {

    use super::*;
    use core::f32::consts::FRAC_PI_2;

    fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
        (a - b).max_abs() < tol
    }

    #[test]
    fn rotation_about_z_by_90_deg_takes_north_to_east() {
        let q = Quaternion::from_rotation_vector(Vec3::new(0.0, 0.0, FRAC_PI_2));
        assert!(close(q.rotate(Vec3::new(1.0, 0.0, 0.0)), Vec3::new(0.0, 1.0, 0.0), 1e-6));
        let r = q.to_rotation_matrix();
        assert!((r[1][0] - 1.0).abs() < 1e-6 && (r[0][1] + 1.0).abs() < 1e-6);
        assert!(close(q.rotate_inverse(Vec3::new(0.0, 1.0, 0.0)), Vec3::new(1.0, 0.0, 0.0), 1e-6));
    }

    #[test]
    fn product_composes_rotations() {
        let a = Quaternion::from_rotation_vector(Vec3::new(0.3, -0.2, 0.9));
        let b = Quaternion::from_rotation_vector(Vec3::new(-1.1, 0.4, 0.2));
        let v = Vec3::new(0.2, -0.7, 1.3);
        assert!(close((a * b).rotate(v), a.rotate(b.rotate(v)), 1e-5));
    }

    #[test]
    fn rotation_vector_round_trip_and_small_angles() {
        for v in [Vec3::new(0.3, -0.2, 0.9), Vec3::new(1e-5, 2e-5, -1e-5), Vec3::new(0.0, 3.0, 0.0)]
        {
            let back = Quaternion::from_rotation_vector(v).to_rotation_vector();
            assert!(close(back, v, 1e-5), "{v:?} -> {back:?}");
        }
    }

    #[test]
    fn normalisation_never_yields_nan() {
        for q in [
            Quaternion::new(0.0, 0.0, 0.0, 0.0),
            Quaternion::new(f32::NAN, 1.0, 0.0, 0.0),
            Quaternion::new(f32::INFINITY, 0.0, 0.0, 0.0),
            Quaternion::new(1e-20, 0.0, 0.0, 0.0),
            Quaternion::new(3e38, 3e38, 3e38, 3e38),
        ] {
            let n = q.normalized();
            assert!(n.is_finite());
            assert!((n.norm_sq() - 1.0).abs() < 1e-6);
        }
        let n = Quaternion::new(-2.0, 0.0, 0.0, 0.0).normalized();
        assert_eq!(n, Quaternion::IDENTITY);
    }

    #[test]
    fn down_in_body_matches_inverse_rotation() {
        let q = Quaternion::from_rotation_vector(Vec3::new(0.4, -0.7, 2.0));
        assert!(close(q.down_in_body(), q.rotate_inverse(Vec3::new(0.0, 0.0, 1.0)), 1e-6));
    }

    #[test]
    fn structured_products_equal_the_full_product() {
        let q = Quaternion::from_rotation_vector(Vec3::new(0.3, -1.2, 0.7));
        let (c, s) = (0.8f32, -0.35f32);
        let full = Quaternion::new(c, 0.0, 0.0, s) * q;
        let fast = q.pre_rotate_z(c, s);
        for (a, b) in [(full.w, fast.w), (full.x, fast.x), (full.y, fast.y), (full.z, fast.z)] {
            assert!((a - b).abs() < 1e-6);
        }
        let v = Vec3::new(0.01, -0.02, 0.005);
        let full = Quaternion::from_small_rotation(v) * q;
        let fast = q.pre_rotate_small(v);
        for (a, b) in [(full.w, fast.w), (full.x, fast.x), (full.y, fast.y), (full.z, fast.z)] {
            assert!((a - b).abs() < 1e-6);
        }
    }

    #[test]
    fn slerp_halfway_is_half_the_angle() {
        let a = Quaternion::IDENTITY;
        let b = Quaternion::from_rotation_vector(Vec3::new(0.0, 1.2, 0.0));
        let h = a.slerp(b, 0.5);
        assert!((h.angle_to(a) - 0.6).abs() < 1e-5);
        assert!((a.angle_to(b) - 1.2).abs() < 1e-5);
    }
}
