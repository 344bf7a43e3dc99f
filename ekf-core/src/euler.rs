//! Intrinsic Z-Y-X Euler angles (yaw ψ about NED z, then pitch θ about the new y, then roll φ
//! about the new x) and their conversion to and from attitude quaternions, with the digest's
//! formulas.

use crate::{mathf, Quaternion};

/// Z-Y-X Euler angles, rad. Roll φ ∈ (−π, π] (positive: starboard down), pitch θ ∈ [−π/2, π/2]
/// (positive: bow up), yaw ψ ∈ (−π, π] (positive: clockwise seen from above, from north/initial
/// reference toward east).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Euler {
    /// Roll φ, rad.
    pub roll: f32,
    /// Pitch θ, rad.
    pub pitch: f32,
    /// Yaw ψ, rad.
    pub yaw: f32,
}

impl Euler {
    /// From roll, pitch and yaw in rad.
    pub const fn new(roll: f32, pitch: f32, yaw: f32) -> Self {
        Euler { roll, pitch, yaw }
    }

    /// Euler angles of an attitude quaternion (digest formulas, pitch through `atan2`), finite for
    /// any finite quaternion, including at ±90° pitch. The formulas are written homogeneously
    /// (`1 − 2(x² + y²)` as `w² − x² − y² + z²`, ...), so `q` need not be normalised.
    pub fn from_quaternion(q: Quaternion) -> Self {
        let Quaternion { w, x, y, z } = q;
        let (ww, xx, yy, zz) = (w * w, x * x, y * y, z * z);
        let r00 = ww + xx - yy - zz;
        let r10 = mathf::twice(x * y + w * z);
        Euler {
            roll: mathf::atan2(mathf::twice(y * z + w * x), ww - xx - yy + zz),
            // asin(2(wy − xz)) written as atan2 with cos θ = |first column of R projected on
            // the horizontal|: identical in exact arithmetic, well conditioned near ±90°.
            pitch: mathf::atan2(mathf::twice(w * y - x * z), mathf::sqrt(r00 * r00 + r10 * r10)),
            yaw: mathf::atan2(r10, r00),
        }
    }

    /// The attitude quaternion of these angles (digest formulas), scalar part ≥ 0.
    pub fn to_quaternion(self) -> Quaternion {
        let (sr, cr) = (mathf::sin(0.5 * self.roll), mathf::cos(0.5 * self.roll));
        let (sp, cp) = (mathf::sin(0.5 * self.pitch), mathf::cos(0.5 * self.pitch));
        let (sy, cy) = (mathf::sin(0.5 * self.yaw), mathf::cos(0.5 * self.yaw));
        Quaternion::new(
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        )
        .normalized()
    }

    /// [`Euler::from_quaternion`] for the output of a unit quaternion (the EKF's attitude,
    /// normalised at the end of every cycle to within 2.2e−8): `1 − 2(y² + z²)` and
    /// `1 − 2(x² + y²)` take two additions fewer than their homogeneous forms (an error ε in
    /// |q|² moves the angles by at most about ε rad), and the angles are within 1.3e−5 rad of
    /// the exact ones ([`mathf::atan2_display`]: the output prints 0.01°).
    pub fn from_unit_quaternion(q: Quaternion) -> Self {
        let Quaternion { w, x, y, z } = q;
        let (xx, yy) = (x * x, y * y);
        let r00 = 1.0 - mathf::twice(yy + z * z);
        let r10 = mathf::twice(x * y + w * z);
        Euler {
            roll: mathf::atan2_display(mathf::twice(y * z + w * x), 1.0 - mathf::twice(xx + yy)),
            pitch: mathf::atan2_display(
                mathf::twice(w * y - x * z),
                mathf::sqrt(r00 * r00 + r10 * r10),
            ),
            yaw: mathf::atan2_display(r10, r00),
        }
    }

    /// Yaw of an attitude quaternion alone, rad (cheaper than the full conversion; any norm).
    pub fn yaw_of(q: Quaternion) -> f32 {
        let r00 = q.w * q.w + q.x * q.x - q.y * q.y - q.z * q.z;
        mathf::atan2(mathf::twice(q.x * q.y + q.w * q.z), r00)
    }

    /// The angles in degrees `(roll, pitch, yaw)`.
    pub fn to_degrees(self) -> [f32; 3] {
        [mathf::to_deg(self.roll), mathf::to_deg(self.pitch), mathf::to_deg(self.yaw)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_output_form_agrees_with_the_homogeneous_one_within_its_bound() {
        let mut worst = 0.0f32;
        for (r, p, y) in [
            (0.1, -0.2, 0.3),
            (2.9, 1.2, -3.0),
            (-1.0, 1.57, 0.5),
            (0.4, -1.571, -2.2),
            (3.1, 0.0, 1.0),
            (-0.7, 0.9, 3.1),
        ] {
            let q = Euler::new(r, p, y).to_quaternion();
            let (a, b) = (Euler::from_quaternion(q), Euler::from_unit_quaternion(q));
            // Roll and yaw are ill-conditioned at ±90° pitch (only their sum or difference is
            // defined there): pitch alone.
            let n = if p.abs() < 1.56 { 3 } else { 1 };
            for (x, z) in [(a.pitch, b.pitch), (a.roll, b.roll), (a.yaw, b.yaw)].into_iter().take(n)
            {
                let d = crate::mathf::wrap_pi(x - z).abs();
                assert!(d < 1.5e-5, "{r} {p} {y}: {x} vs {z}");
                worst = worst.max(d);
            }
        }
        assert!(worst > 1e-7, "the two forms differ by their polynomials: {worst}");
    }
    use crate::Vec3;
    use mathf::deg;

    #[test]
    fn known_values() {
        // 90° yaw: body x points east.
        let q = Euler::new(0.0, 0.0, deg(90.0)).to_quaternion();
        let x = q.rotate(Vec3::new(1.0, 0.0, 0.0));
        assert!((x - Vec3::new(0.0, 1.0, 0.0)).max_abs() < 1e-6);
        // 30° pitch (bow up): body x points north and up (negative z in NED).
        let q = Euler::new(0.0, deg(30.0), 0.0).to_quaternion();
        let x = q.rotate(Vec3::new(1.0, 0.0, 0.0));
        assert!((x - Vec3::new(deg(30.0).cos(), 0.0, -0.5)).max_abs() < 1e-6);
        // 20° roll (starboard down): body y points east and down.
        let q = Euler::new(deg(20.0), 0.0, 0.0).to_quaternion();
        let y = q.rotate(Vec3::new(0.0, 1.0, 0.0));
        assert!((y - Vec3::new(0.0, deg(20.0).cos(), deg(20.0).sin())).max_abs() < 1e-6);
    }

    #[test]
    fn round_trip_over_the_sphere_including_near_gimbal_lock() {
        let pitches = [-89.999, -89.9, -89.0, -60.0, -10.0, 0.0, 10.0, 45.0, 89.0, 89.9, 89.999];
        for &p in &pitches {
            for r in (-175..=180).step_by(35) {
                for y in (-170..=180).step_by(50) {
                    let e = Euler::new(deg(r as f32), deg(p), deg(y as f32));
                    let q = e.to_quaternion();
                    let back = Euler::from_quaternion(q).to_quaternion();
                    // The rotation must come back even where roll and yaw are not separable.
                    // f32 limit: at 89.999° pitch cos θ ≈ 1.7e−5, so rounding of ~1e−7 in R
                    // moves roll and yaw by ~1e−2 rad in opposite senses.
                    let tol = if p.abs() > 89.99 { 2e-2 } else { 2e-4 };
                    assert!(q.angle_to(back) < tol, "r {r} p {p} y {y}: {}", q.angle_to(back));
                    if p.abs() < 89.5 {
                        let b = Euler::from_quaternion(q);
                        assert!((b.pitch - e.pitch).abs() < 1e-4);
                        assert!(mathf::wrap_pi(b.roll - e.roll).abs() < 5e-4);
                        assert!(mathf::wrap_pi(b.yaw - e.yaw).abs() < 5e-4);
                    }
                }
            }
        }
    }

    #[test]
    fn conversion_does_not_depend_on_the_norm() {
        let e = Euler::new(deg(-20.0), deg(35.0), deg(120.0));
        let q = e.to_quaternion().scale(1.7);
        let b = Euler::from_quaternion(q);
        assert!((b.roll - e.roll).abs() < 1e-5 && (b.pitch - e.pitch).abs() < 1e-5);
        assert!((b.yaw - e.yaw).abs() < 1e-5 && (Euler::yaw_of(q) - e.yaw).abs() < 1e-5);
    }

    #[test]
    fn to_degrees_converts_each_angle_in_order() {
        use core::f32::consts::PI;
        let [r, p, y] = Euler::new(PI / 6.0, -PI / 4.0, PI).to_degrees();
        assert!((r - 30.0).abs() < 1e-5 && (p + 45.0).abs() < 1e-5 && (y - 180.0).abs() < 1e-4);
    }

    #[test]
    fn yaw_of_matches_full_conversion() {
        let q = Euler::new(deg(12.0), deg(-33.0), deg(140.0)).to_quaternion();
        assert!((Euler::yaw_of(q) - deg(140.0)).abs() < 1e-5);
    }
}
