//! World transforms: `world[n] = world[parent(n)] * local[n]`, parents first.

use super::{check_eq, check_index, check_len};
use crate::error::JobError;
use crate::math::{Mat4, Transform};

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

    /// Validates, then writes `worlds`.
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        for &node in self.order {
            let n = node as usize;
            let local = self.locals[n].to_mat4();
            self.worlds[n] = match self.parents[n] {
                Some(p) => self.worlds[p as usize] * local,
                None => local,
            };
        }
        Ok(())
    }
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
