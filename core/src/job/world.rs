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
    ///
    /// Nodes go four at a time: their local matrices are built side by side (one node per SIMD
    /// lane, [`local_matrices`]), then each is multiplied by its parent's world matrix in order.
    pub fn run(&mut self) -> Result<(), JobError> {
        let n = self.locals.len();
        check_eq("parents", n, self.parents.len())?;
        check_eq("order", n, self.order.len())?;
        check_len("worlds", n, self.worlds.len())?;
        for chunk in self.order.chunks(4) {
            // A short last chunk repeats its last node (computed, not written twice).
            let last = chunk.last().copied().unwrap_or(0);
            let nodes: [usize; 4] = std::array::from_fn(|k| chunk.get(k).copied().unwrap_or(last) as usize);
            let mut locals = [&Transform::IDENTITY; 4];
            for (local, &i) in locals.iter_mut().zip(&nodes) {
                *local = self.locals.get(i).ok_or(JobError::IndexOutOfRange { what: "order", index: i, len: n })?;
            }
            let matrices = local_matrices(locals);
            for (&i, local) in nodes.iter().zip(&matrices).take(chunk.len()) {
                self.worlds[i] = match self.parents[i] {
                    Some(p) => {
                        let p = p as usize;
                        let parent = self.worlds.get(p).filter(|_| p < n).ok_or(JobError::IndexOutOfRange {
                            what: "parents",
                            index: p,
                            len: n,
                        })?;
                        affine_mul(parent, local)
                    }
                    None => *local,
                };
            }
        }
        Ok(())
    }
}

/// `T * R * S` of four transforms, computed in lanes (the quaternions and scales transposed
/// so that each lane holds one node): the same operations, in the same order, as
/// [`Transform::to_mat4`], so the same bits.
#[inline]
fn local_matrices(t: [&Transform; 4]) -> [Mat4; 4] {
    let q = Mat4::from_cols(
        Vec4::from(t[0].rotation),
        Vec4::from(t[1].rotation),
        Vec4::from(t[2].rotation),
        Vec4::from(t[3].rotation),
    )
    .transpose();
    let s =
        Mat4::from_cols(t[0].scale.extend(0.0), t[1].scale.extend(0.0), t[2].scale.extend(0.0), t[3].scale.extend(0.0))
            .transpose();
    let (x, y, z, w) = (q.x_axis, q.y_axis, q.z_axis, q.w_axis);
    let (x2, y2, z2) = (x + x, y + y, z + z);
    let (xx, xy, xz) = (x * x2, x * y2, x * z2);
    let (yy, yz, zz) = (y * y2, y * z2, z * z2);
    let (wx, wy, wz) = (w * x2, w * y2, w * z2);
    let one = Vec4::ONE;
    // Column c of all four matrices, one row per vector, then transposed back to one column per node.
    let column = |r0: Vec4, r1: Vec4, r2: Vec4, scale: Vec4| {
        Mat4::from_cols(r0 * scale, r1 * scale, r2 * scale, Vec4::ZERO).transpose()
    };
    let cx = column(one - (yy + zz), xy + wz, xz - wy, s.x_axis);
    let cy = column(xy - wz, one - (xx + zz), yz + wx, s.y_axis);
    let cz = column(xz + wy, yz - wx, one - (xx + yy), s.z_axis);
    let col = |m: &Mat4, k: usize| m.col(k);
    std::array::from_fn(|k| Mat4::from_cols(col(&cx, k), col(&cy, k), col(&cz, k), t[k].translation.extend(1.0)))
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
    fn four_lane_local_matrices_equal_to_mat4() {
        let t = |i: f32| Transform {
            translation: Vec3::new(i, -2.0 * i, 0.5),
            rotation: Quat::from_euler(glam::EulerRot::XYZ, 0.3 * i, -1.2 + i, 2.0 - i).normalize(),
            scale: Vec3::new(1.0 + i, 0.5, -1.0 - 0.1 * i),
        };
        let ts = [t(0.0), t(1.0), t(2.5), t(-3.0)];
        let got = local_matrices([&ts[0], &ts[1], &ts[2], &ts[3]]);
        for (m, t) in got.iter().zip(&ts) {
            assert_eq!(*m, t.to_mat4(), "bit for bit");
        }
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
