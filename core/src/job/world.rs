//! World transforms: `world[n] = world[parent(n)] * local[n]`, parents first.

use super::{check_eq, check_index, check_len};
use crate::error::JobError;
use crate::math::{Mat4, Transform, Vec4};

/// Computes world matrices of all nodes from their local transforms.
#[derive(Debug)]
pub struct WorldJob<'a> {
    /// Parent of each node (`None` for roots).
    pub parents: &'a [Option<u32>],
    /// Every node once, parents before children ([`crate::asset::Asset::order`]).
    pub order: &'a [u32],
    /// Local transform of each node.
    pub locals: &'a [Transform],
    /// Output: world matrix of each node.
    pub worlds: &'a mut [Mat4],
}

impl WorldJob<'_> {
    /// Checks lengths and that every index is in range.
    pub fn validate(&self) -> Result<(), JobError> {
        let n = self.locals.len();
        check_eq("parents", n, self.parents.len())?;
        check_eq("order", n, self.order.len())?;
        check_len("worlds", n, self.worlds.len())?;
        for &node in self.order {
            check_index("order", node as usize, n)?;
        }
        for &parent in self.parents.iter().flatten() {
            check_index("parents", parent as usize, n)?;
        }
        Ok(())
    }

    /// Writes `worlds`, checking what [`WorldJob::validate`] checks as it goes (one pass):
    /// on an error, nodes earlier in `order` were written.
    pub fn run(&mut self) -> Result<(), JobError> {
        let n = self.locals.len();
        check_eq("parents", n, self.parents.len())?;
        check_eq("order", n, self.order.len())?;
        check_len("worlds", n, self.worlds.len())?;
        for &node in self.order {
            let i = node as usize;
            let local = self.locals.get(i).ok_or(JobError::IndexOutOfRange { what: "order", index: i, len: n })?;
            let local = local.to_mat4();
            self.worlds[i] = match self.parents[i] {
                Some(p) => {
                    let p = p as usize;
                    let parent = self.worlds.get(p).filter(|_| p < n).ok_or(JobError::IndexOutOfRange {
                        what: "parents",
                        index: p,
                        len: n,
                    })?;
                    affine_mul(parent, &local)
                }
                None => local,
            };
        }
        Ok(())
    }
}

/// `a * b` where `b` is affine (bottom row `0 0 0 1`, as every TRS transform is): its first three
/// columns transform as vectors, the fourth as a point. Equal to `Mat4 * Mat4` (up to the sign
/// of zeros) with a quarter fewer multiplications.
#[inline]
pub(crate) fn affine_mul(a: &Mat4, b: &Mat4) -> Mat4 {
    let vector = |c: Vec4| a.x_axis * c.x + a.y_axis * c.y + a.z_axis * c.z;
    Mat4::from_cols(vector(b.x_axis), vector(b.y_axis), vector(b.z_axis), vector(b.w_axis) + a.w_axis)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Quat, Vec3};

    #[test]
    fn chain_composes_parent_first() {
        let locals = [
            Transform { translation: Vec3::new(1.0, 0.0, 0.0), ..Transform::IDENTITY },
            Transform {
                translation: Vec3::new(0.0, 2.0, 0.0),
                rotation: Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
                scale: Vec3::splat(2.0),
            },
            Transform { translation: Vec3::new(1.0, 0.0, 0.0), ..Transform::IDENTITY },
        ];
        let parents = [None, Some(0), Some(1)];
        let mut worlds = [Mat4::IDENTITY; 3];
        WorldJob { parents: &parents, order: &[0, 1, 2], locals: &locals, worlds: &mut worlds }
            .run()
            .expect("valid inputs");
        // Node 2's origin: node 1 frame at (1,2,0), rotated 90° about z, scaled 2: (1,0,0) -> (0,2,0).
        let p = worlds[2].transform_point3(Vec3::ZERO);
        assert!(p.abs_diff_eq(Vec3::new(1.0, 4.0, 0.0), 1e-5), "{p}");
    }

    #[test]
    fn affine_product_matches_the_full_product() {
        let a = Transform {
            translation: Vec3::new(1.0, -2.0, 3.0),
            rotation: Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.2, 2.0),
            scale: Vec3::new(2.0, 0.5, -1.0),
        }
        .to_mat4();
        let b = Transform {
            translation: Vec3::new(-4.0, 0.5, 1.0),
            rotation: Quat::from_rotation_y(0.7),
            scale: Vec3::ONE,
        }
        .to_mat4();
        assert!(affine_mul(&a, &b).abs_diff_eq(a * b, 1e-6));
    }

    #[test]
    fn bad_inputs_are_refused() {
        let locals = [Transform::IDENTITY; 2];
        let mut worlds = [Mat4::IDENTITY; 1];
        let mut job = WorldJob { parents: &[None, None], order: &[0, 1], locals: &locals, worlds: &mut worlds };
        assert!(matches!(job.run(), Err(JobError::BufferTooSmall { .. })));
        let mut worlds = [Mat4::IDENTITY; 2];
        let mut job = WorldJob { parents: &[None, Some(7)], order: &[0, 1], locals: &locals, worlds: &mut worlds };
        assert!(matches!(job.run(), Err(JobError::IndexOutOfRange { what: "parents", .. })));
        let mut job = WorldJob { parents: &[None, None], order: &[0, 2], locals: &locals, worlds: &mut worlds };
        assert!(matches!(job.run(), Err(JobError::IndexOutOfRange { what: "order", .. })));
    }
}
