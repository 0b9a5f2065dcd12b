//! World transforms: `world[n] = world[parent(n)] * local[n]`, parents first.

use super::{check_eq, check_index, check_len};
use crate::error::JobError;
use crate::math::{Mat4, Transform, Vec4};
use glam::Vec4Swizzles;

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
            let lanes = Lanes::new(locals);
            // One lane at a time, in order: a node may be the parent of a later one in the chunk.
            self.node::<0>(&lanes, nodes[0])?;
            if chunk.len() > 1 {
                self.node::<1>(&lanes, nodes[1])?;
            }
            if chunk.len() > 2 {
                self.node::<2>(&lanes, nodes[2])?;
            }
            if chunk.len() > 3 {
                self.node::<3>(&lanes, nodes[3])?;
            }
        }
        Ok(())
    }

    /// The world matrix of `node`, whose local matrix is lane `K` of `lanes`.
    #[inline(always)]
    fn node<const K: usize>(&mut self, lanes: &Lanes<'_>, node: usize) -> Result<(), JobError> {
        let n = self.locals.len();
        let parent = match self.parents.get(node).copied().flatten() {
            Some(p) => {
                let p = p as usize;
                Some(*self.worlds.get(p).filter(|_| p < n).ok_or(JobError::IndexOutOfRange {
                    what: "parents",
                    index: p,
                    len: n,
                })?)
            }
            None => None,
        };
        let world = lanes.world::<K>(parent.as_ref());
        let out = self.worlds.get_mut(node).ok_or(JobError::IndexOutOfRange { what: "order", index: node, len: n })?;
        *out = world;
        Ok(())
    }
}

/// The local matrices `T * R * S` of four transforms, one per SIMD lane: the upper 3×3 as
/// nine vectors (`m[c][r]`: column `c`, row `r`, of the four nodes), computed with the same
/// operations, in the same order, as [`Transform::to_mat4`] (so the same bits).
struct Lanes<'a> {
    m: [[Vec4; 3]; 3],
    locals: [&'a Transform; 4],
}

impl<'a> Lanes<'a> {
    #[inline(always)]
    fn new(t: [&'a Transform; 4]) -> Self {
        let q = Mat4::from_cols(
            Vec4::from(t[0].rotation),
            Vec4::from(t[1].rotation),
            Vec4::from(t[2].rotation),
            Vec4::from(t[3].rotation),
        )
        .transpose();
        let s = Mat4::from_cols(
            t[0].scale.extend(0.0),
            t[1].scale.extend(0.0),
            t[2].scale.extend(0.0),
            t[3].scale.extend(0.0),
        )
        .transpose();
        let (x, y, z, w) = (q.x_axis, q.y_axis, q.z_axis, q.w_axis);
        let (x2, y2, z2) = (x + x, y + y, z + z);
        let (xx, xy, xz) = (x * x2, x * y2, x * z2);
        let (yy, yz, zz) = (y * y2, y * z2, z * z2);
        let (wx, wy, wz) = (w * x2, w * y2, w * z2);
        let one = Vec4::ONE;
        let (sx, sy, sz) = (s.x_axis, s.y_axis, s.z_axis);
        let m = [
            [(one - (yy + zz)) * sx, (xy + wz) * sx, (xz - wy) * sx],
            [(xy - wz) * sy, (one - (xx + zz)) * sy, (yz + wx) * sy],
            [(xz + wy) * sz, (yz - wx) * sz, (one - (xx + yy)) * sz],
        ];
        Self { m, locals: t }
    }

    /// Lane `K`'s local matrix, or `parent` times it ([`affine_mul`]'s arithmetic), with each
    /// entry broadcast straight from its lane.
    #[inline(always)]
    fn world<const K: usize>(&self, parent: Option<&Mat4>) -> Mat4 {
        let lane = |v: Vec4| match K {
            0 => v.xxxx(),
            1 => v.yyyy(),
            2 => v.zzzz(),
            _ => v.wwww(),
        };
        let t = self.locals[K].translation;
        let m = &self.m;
        match parent {
            Some(a) => {
                let column = |c: [Vec4; 3]| a.x_axis * lane(c[0]) + a.y_axis * lane(c[1]) + a.z_axis * lane(c[2]);
                let point = a.x_axis * t.x + a.y_axis * t.y + a.z_axis * t.z + a.w_axis;
                Mat4::from_cols(column(m[0]), column(m[1]), column(m[2]), point)
            }
            None => {
                let column = |c: [Vec4; 3]| Vec4::new(c[0][K], c[1][K], c[2][K], 0.0);
                Mat4::from_cols(column(m[0]), column(m[1]), column(m[2]), t.extend(1.0))
            }
        }
    }
}

/// `T * R * S` of four transforms through [`Lanes`] (the tests' view of the lanes).
#[cfg(test)]
fn local_matrices(t: [&Transform; 4]) -> [Mat4; 4] {
    let lanes = Lanes::new(t);
    [lanes.world::<0>(None), lanes.world::<1>(None), lanes.world::<2>(None), lanes.world::<3>(None)]
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
