//! Signed axis permutation from a sensor's raw axes onto the body FRD axes.
//!
//! A sensor chip is soldered in some orientation on the board; its axes are a signed permutation
//! of the body axes (x forward, y starboard, z down). [`AxisMap`] stores that permutation as
//! `body[i] = sign[i] · raw[source[i]]`. The map is unit-free: it remaps whatever triplet it is
//! given (rad/s, m/s², µT) without scaling it.

use core::fmt;

use crate::Vec3;

/// Why [`AxisMap::new`] rejected its arguments.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AxisMapError {
    /// `source[body_axis]` is not a raw axis index 0, 1 or 2.
    SourceOutOfRange {
        /// Body axis (0 = x, 1 = y, 2 = z) whose source is invalid.
        body_axis: u8,
        /// The rejected source index.
        source: u8,
    },
    /// Raw axis `source` feeds more than one body axis, so `source` is not a permutation.
    DuplicateSource {
        /// The raw axis index that appears twice.
        source: u8,
    },
    /// `sign[body_axis]` is neither +1 nor −1.
    InvalidSign {
        /// Body axis (0 = x, 1 = y, 2 = z) whose sign is invalid.
        body_axis: u8,
        /// The rejected sign.
        sign: i8,
    },
}

impl fmt::Display for AxisMapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            AxisMapError::SourceOutOfRange { body_axis, source } => write!(
                f,
                "axis map: source {source} of body axis {body_axis} is not a raw axis 0..=2"
            ),
            AxisMapError::DuplicateSource { source } => {
                write!(f, "axis map: raw axis {source} is used more than once")
            }
            AxisMapError::InvalidSign { body_axis, sign } => {
                write!(f, "axis map: sign {sign} of body axis {body_axis} is not +1 or -1")
            }
        }
    }
}

/// A signed permutation `body[i] = sign[i] · raw[source[i]]` from a sensor's raw axes onto body
/// FRD axes (index 0 = x forward, 1 = y starboard, 2 = z down).
///
/// Always valid: `source` is a permutation of `{0, 1, 2}` and every sign is ±1 (enforced by
/// [`AxisMap::new`]; the fields are private). Unit-free: the output has the input's unit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisMap {
    source: [u8; 3],
    sign: [i8; 3],
}

impl Default for AxisMap {
    /// [`AxisMap::IDENTITY`].
    fn default() -> Self {
        AxisMap::IDENTITY
    }
}

impl AxisMap {
    /// The identity map: the sensor's axes already are body FRD axes.
    pub const IDENTITY: AxisMap = AxisMap { source: [0, 1, 2], sign: [1, 1, 1] };

    /// A map with `body[i] = sign[i] · raw[source[i]]`.
    ///
    /// `source` must be a permutation of `0, 1, 2` and every `sign` must be `+1` or `-1`;
    /// otherwise the first problem found is returned (signs are checked after sources).
    pub const fn new(source: [u8; 3], sign: [i8; 3]) -> Result<AxisMap, AxisMapError> {
        let mut used = [false; 3];
        let mut i = 0;
        while i < 3 {
            let s = source[i];
            if s > 2 {
                return Err(AxisMapError::SourceOutOfRange { body_axis: i as u8, source: s });
            }
            if used[s as usize] {
                return Err(AxisMapError::DuplicateSource { source: s });
            }
            used[s as usize] = true;
            i += 1;
        }
        let mut i = 0;
        while i < 3 {
            if sign[i] != 1 && sign[i] != -1 {
                return Err(AxisMapError::InvalidSign { body_axis: i as u8, sign: sign[i] });
            }
            i += 1;
        }
        Ok(AxisMap { source, sign })
    }

    /// Raw axis index feeding each body axis (`source[i]` feeds body axis `i`).
    pub const fn source(&self) -> [u8; 3] {
        self.source
    }

    /// Sign (±1) applied to each body axis.
    pub const fn sign(&self) -> [i8; 3] {
        self.sign
    }

    /// Remap a raw sensor-axis triplet onto body FRD axes. Same unit in and out; exact (only
    /// copies and sign flips, no rounding).
    ///
    /// Without branches: the sign is applied to the sign bit (what `-v` does, NaN included),
    /// the source picked from an array (`source[i] ≤ 2`, the `min` only spares the bounds
    /// check).
    pub fn apply(&self, raw: Vec3) -> Vec3 {
        let raw = [raw.x.to_bits(), raw.y.to_bits(), raw.z.to_bits()];
        let pick = |i: usize| {
            // −1 → all ones → the sign bit; +1 → 0.
            let flip = (i32::from(self.sign[i]) as u32) & 0x8000_0000;
            f32::from_bits(raw[usize::from(self.source[i]).min(2)] ^ flip)
        };
        Vec3::new(pick(0), pick(1), pick(2))
    }

    /// The inverse map (body FRD axes back onto raw sensor axes):
    /// `self.inverse().apply(self.apply(v)) == v` for every `v`.
    pub fn inverse(&self) -> AxisMap {
        // body[i] = s[i] · raw[src[i]]  ⇔  raw[src[i]] = s[i] · body[i].
        let mut source = [0u8; 3];
        let mut sign = [1i8; 3];
        for (i, (&src, &s)) in self.source.iter().zip(self.sign.iter()).enumerate() {
            if let Some(slot) = source.get_mut(usize::from(src)) {
                *slot = i as u8;
            }
            if let Some(slot) = sign.get_mut(usize::from(src)) {
                *slot = s;
            }
        }
        AxisMap { source, sign }
    }

    /// The map that applies `inner` first, then `self`:
    /// `self.compose(&inner).apply(v) == self.apply(inner.apply(v))`.
    pub fn compose(&self, inner: &AxisMap) -> AxisMap {
        let mut source = [0u8; 3];
        let mut sign = [1i8; 3];
        for i in 0..3 {
            let mid = usize::from(self.source[i]);
            let inner_source = inner.source.get(mid).copied().unwrap_or(0);
            let inner_sign = inner.sign.get(mid).copied().unwrap_or(1);
            source[i] = inner_source;
            sign[i] = self.sign[i] * inner_sign;
        }
        AxisMap { source, sign }
    }

    /// The map as a 3×3 matrix `m` (row-major) with `body = m · raw`; entries are 0 or ±1.
    pub fn matrix(&self) -> [[f32; 3]; 3] {
        let mut m = [[0.0f32; 3]; 3];
        for (row, (&src, &s)) in m.iter_mut().zip(self.source.iter().zip(self.sign.iter())) {
            if let Some(e) = row.get_mut(usize::from(src)) {
                *e = f32::from(s);
            }
        }
        m
    }

    /// Determinant of [`AxisMap::matrix`]: `+1` for a rotation, `−1` for a reflection.
    pub fn determinant(&self) -> i8 {
        let s = self.source;
        let mut inversions = 0;
        if s[0] > s[1] {
            inversions += 1;
        }
        if s[0] > s[2] {
            inversions += 1;
        }
        if s[1] > s[2] {
            inversions += 1;
        }
        let parity: i8 = if inversions % 2 == 0 { 1 } else { -1 };
        parity * self.sign[0] * self.sign[1] * self.sign[2]
    }

    /// True when the map is a proper rotation (determinant +1), false for a reflection: a
    /// reflection turns a right-handed sensor frame into a left-handed one, which is a wiring or
    /// configuration error for a physical sensor.
    pub fn is_proper(&self) -> bool {
        self.determinant() > 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// All 48 signed permutations.
    fn all_maps() -> impl Iterator<Item = AxisMap> {
        const PERMS: [[u8; 3]; 6] =
            [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
        PERMS.into_iter().flat_map(|p| {
            (0..8).map(move |bits: u8| {
                let sg = |b: u8| if bits & (1 << b) != 0 { -1 } else { 1 };
                AxisMap::new(p, [sg(0), sg(1), sg(2)]).unwrap()
            })
        })
    }

    fn det3(m: [[f32; 3]; 3]) -> f32 {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    }

    #[test]
    fn inemo_like_mapping_matches_hand_values() {
        // body = [raw.y, raw.x, -raw.z]
        let m = AxisMap::new([1, 0, 2], [1, 1, -1]).unwrap();
        assert_eq!(m.apply(Vec3::new(1.0, 2.0, 3.0)), Vec3::new(2.0, 1.0, -3.0));
        assert_eq!(m.apply(Vec3::new(-0.5, 7.25, -9.0)), Vec3::new(7.25, -0.5, 9.0));
        assert_eq!(m.source(), [1, 0, 2]);
        assert_eq!(m.sign(), [1, 1, -1]);
        // Swap (odd) and one flip (odd): a rotation (180° about the x = y diagonal).
        assert!(m.is_proper());
        // body = [raw.y, raw.z, raw.x]: cyclic, a rotation.
        let c = AxisMap::new([1, 2, 0], [1, 1, 1]).unwrap();
        assert_eq!(c.apply(Vec3::new(1.0, 2.0, 3.0)), Vec3::new(2.0, 3.0, 1.0));
        assert!(c.is_proper());
    }

    #[test]
    fn identity_is_identity() {
        let v = Vec3::new(0.1, -2.0, 30.0);
        assert_eq!(AxisMap::IDENTITY.apply(v), v);
        assert_eq!(AxisMap::default(), AxisMap::IDENTITY);
        assert_eq!(AxisMap::new([0, 1, 2], [1, 1, 1]), Ok(AxisMap::IDENTITY));
        assert!(AxisMap::IDENTITY.is_proper());
    }

    #[test]
    fn every_invalid_source_is_rejected() {
        let mut valid = 0;
        for a in 0..=3u8 {
            for b in 0..=3u8 {
                for c in 0..=3u8 {
                    let src = [a, b, c];
                    let is_perm = src.iter().all(|&s| s <= 2) && a != b && b != c && a != c;
                    let r = AxisMap::new(src, [1, 1, 1]);
                    assert_eq!(r.is_ok(), is_perm, "{src:?}");
                    if is_perm {
                        valid += 1;
                    }
                }
            }
        }
        assert_eq!(valid, 6);
        assert_eq!(
            AxisMap::new([0, 3, 1], [1, 1, 1]),
            Err(AxisMapError::SourceOutOfRange { body_axis: 1, source: 3 })
        );
        assert_eq!(
            AxisMap::new([0, 2, 2], [1, 1, 1]),
            Err(AxisMapError::DuplicateSource { source: 2 })
        );
        assert!(AxisMap::new([255, 0, 1], [1, 1, 1]).is_err());
    }

    #[test]
    fn every_invalid_sign_is_rejected() {
        for s in i8::MIN..=i8::MAX {
            for axis in 0..3 {
                let mut sign = [1i8; 3];
                sign[axis] = s;
                let r = AxisMap::new([2, 0, 1], sign);
                if s == 1 || s == -1 {
                    assert!(r.is_ok());
                } else {
                    assert_eq!(
                        r,
                        Err(AxisMapError::InvalidSign { body_axis: axis as u8, sign: s })
                    );
                }
            }
        }
    }

    #[test]
    fn errors_name_the_axis_and_the_value() {
        let says = crate::test_text::assert_displays::<AxisMapError>;
        says(
            AxisMap::new([0, 3, 1], [1, 1, 1]).unwrap_err(),
            "axis map: source 3 of body axis 1 is not a raw axis 0..=2",
        );
        says(
            AxisMap::new([0, 2, 2], [1, 1, 1]).unwrap_err(),
            "axis map: raw axis 2 is used more than once",
        );
        says(
            AxisMap::new([0, 1, 2], [1, 1, 0]).unwrap_err(),
            "axis map: sign 0 of body axis 2 is not +1 or -1",
        );
    }

    /// The branch-free `apply` against the definition `sign[i] · raw[source[i]]` written the
    /// plain way, bit for bit: zeros of both signs, a subnormal, infinities and NaN payloads.
    #[test]
    fn apply_is_the_definition_bit_for_bit() {
        let specials = [
            0.0,
            -0.0,
            1.5e-42,
            -9.80665,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::from_bits(0x7fc0_1234),
            f32::from_bits(0xff80_0001),
        ];
        for m in all_maps() {
            for w in specials.windows(3) {
                let raw = Vec3::new(w[0], w[1], w[2]);
                let out = m.apply(raw);
                for i in 0..3 {
                    let v = [raw.x, raw.y, raw.z][usize::from(m.source()[i])];
                    let want = if m.sign()[i] < 0 { -v } else { v };
                    assert_eq!(out[i].to_bits(), want.to_bits(), "{m:?} {raw:?} axis {i}");
                }
            }
        }
    }

    #[test]
    fn inverse_undoes_apply_for_all_maps() {
        let vs = [Vec3::new(1.0, 2.0, 3.0), Vec3::new(-0.25, 1e-3, -9.80665)];
        for m in all_maps() {
            let inv = m.inverse();
            for v in vs {
                assert_eq!(inv.apply(m.apply(v)), v, "{m:?}");
                assert_eq!(m.apply(inv.apply(v)), v, "{m:?}");
            }
            assert_eq!(m.compose(&inv), AxisMap::IDENTITY);
            assert_eq!(inv.compose(&m), AxisMap::IDENTITY);
            assert_eq!(inv.inverse(), m);
        }
    }

    #[test]
    fn compose_applies_inner_first() {
        let v = Vec3::new(1.0, -2.0, 4.0);
        for a in all_maps() {
            for b in all_maps() {
                assert_eq!(a.compose(&b).apply(v), a.apply(b.apply(v)));
            }
        }
    }

    #[test]
    fn matrix_agrees_with_apply_and_determinant() {
        let v = Vec3::new(1.5, -2.0, 4.0);
        let mut proper = 0;
        for m in all_maps() {
            let mx = m.matrix();
            let mv = Vec3::new(
                mx[0][0] * v.x + mx[0][1] * v.y + mx[0][2] * v.z,
                mx[1][0] * v.x + mx[1][1] * v.y + mx[1][2] * v.z,
                mx[2][0] * v.x + mx[2][1] * v.y + mx[2][2] * v.z,
            );
            assert_eq!(mv, m.apply(v));
            assert_eq!(det3(mx), f32::from(m.determinant()), "{m:?}");
            assert_eq!(m.is_proper(), det3(mx) > 0.0);
            if m.is_proper() {
                proper += 1;
            }
        }
        // Half of the 48 signed permutations are rotations.
        assert_eq!(proper, 24);
        // Pure reflections.
        assert!(!AxisMap::new([0, 1, 2], [1, 1, -1]).unwrap().is_proper());
        assert!(!AxisMap::new([1, 0, 2], [1, 1, 1]).unwrap().is_proper());
        assert!(!AxisMap::new([0, 1, 2], [-1, -1, -1]).unwrap().is_proper());
    }
}
