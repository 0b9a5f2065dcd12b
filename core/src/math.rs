//! Math types shared by every job: glam re-exports and a TRS [`Transform`].

pub use glam::{Mat3, Mat4, Quat, Vec2, Vec3, Vec4};

/// A local transform as translation, rotation, scale (glTF's TRS), applied as `T * R * S`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Translation.
    pub translation: Vec3,
    /// Unit rotation.
    pub rotation: Quat,
    /// Non-uniform scale.
    pub scale: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    /// The identity transform.
    pub const IDENTITY: Self = Self { translation: Vec3::ZERO, rotation: Quat::IDENTITY, scale: Vec3::ONE };

    /// The matrix `T * R * S`.
    #[inline]
    pub fn to_mat4(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }

    /// Decomposes an affine matrix into TRS. Returns `None` when the matrix is not finite
    /// or its upper 3×3 is singular. Shear is lost (glTF forbids it for animated nodes).
    pub fn from_mat4(m: &Mat4) -> Option<Self> {
        if !m.is_finite() || m.determinant().abs() < f32::MIN_POSITIVE {
            return None;
        }
        let (scale, rotation, translation) = m.to_scale_rotation_translation();
        let rotation = rotation.try_normalize_quat()?;
        (scale.is_finite() && translation.is_finite()).then_some(Self { translation, rotation, scale })
    }
}

/// `try_normalize` for quaternions, in the style of glam's `Vec3::try_normalize`.
pub trait QuatExt: Sized {
    /// The unit quaternion, or `None` when the length is zero or not finite.
    fn try_normalize_quat(self) -> Option<Self>;

    /// `Err(length)` when a rotation given as input (a sidecar, the CLI, the page) is not a unit
    /// quaternion within [`UNIT_QUAT_TOLERANCE`] of length 1; its reader normalizes it after.
    fn check_unit(self) -> Result<Self, f32>;
}

/// Whether every value is finite: four at a time, without a branch a value (the importer's
/// checks of float attributes and keyframes).
pub(crate) fn all_finite(xs: &[f32]) -> bool {
    let (fours, rest) = xs.as_chunks::<4>();
    let lanes = fours.iter().fold(glam::BVec4A::splat(true), |ok, &x| ok & Vec4::from_array(x).is_finite_mask());
    lanes.all() & rest.iter().fold(true, |ok, x| ok & x.is_finite())
}

/// The square root of each lane, correctly rounded (one `f32x4.sqrt` as wasm with SIMD).
pub(crate) use kloub_meshopt::sqrt4;

/// `v` divided by its length, and that length; `None` when the length is zero, tiny or not
/// finite ([`QuatExt::try_normalize_quat`]'s test).
#[inline]
pub fn unit_with_length(v: Vec4) -> Option<(Vec4, f32)> {
    let len = v.length();
    (len.is_finite() && len > 1e-12).then(|| (v / len, len))
}

/// How far from length 1 a rotation given as input may be.
pub const UNIT_QUAT_TOLERANCE: f32 = 1e-3;

impl QuatExt for Quat {
    #[inline]
    fn try_normalize_quat(self) -> Option<Self> {
        unit_with_length(Vec4::from(self)).map(|(unit, _)| Quat::from_vec4(unit))
    }

    #[inline]
    fn check_unit(self) -> Result<Self, f32> {
        let length = self.length();
        if length.is_finite() && (length - 1.0).abs() <= UNIT_QUAT_TOLERANCE { Ok(self) } else { Err(length) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trs_round_trip() {
        let t = Transform {
            translation: Vec3::new(1.0, 2.0, 3.0),
            rotation: Quat::from_rotation_y(0.7),
            scale: Vec3::new(2.0, 0.5, 1.5),
        };
        let back = Transform::from_mat4(&t.to_mat4()).expect("decomposes");
        assert!(back.translation.abs_diff_eq(t.translation, 1e-5));
        assert!(back.rotation.abs_diff_eq(t.rotation, 1e-5) || back.rotation.abs_diff_eq(-t.rotation, 1e-5));
        assert!(back.scale.abs_diff_eq(t.scale, 1e-5));
    }

    #[test]
    fn singular_and_nan_matrices_are_refused() {
        assert!(Transform::from_mat4(&Mat4::ZERO).is_none());
        assert!(Transform::from_mat4(&Mat4::from_cols_array(&[f32::NAN; 16])).is_none());
        assert!(Quat::from_xyzw(0.0, 0.0, 0.0, 0.0).try_normalize_quat().is_none());
    }
}
