//! Skinning: the joint palette and linear blend skinning (the CPU reference of the GPU path).

use super::dqs::{DqsJob, JointDq, RigidJob, SkinningMethod};
use super::sjb::{SjbJob, SjbPlan};
use super::world::affine_mul;
use super::{check_eq, check_index, check_len};
use crate::error::JobError;
use crate::math::{Mat3, Mat4, Vec3, Vec4};

/// Computes `palette[j] = worlds[joints[j]] * inverse_bind[j]` for one skin.
#[derive(Debug)]
pub struct PaletteJob<'a> {
    /// Joint nodes of the skin.
    pub joints: &'a [u32],
    /// Inverse bind matrix of each joint.
    pub inverse_bind: &'a [Mat4],
    /// World matrix of each node.
    pub worlds: &'a [Mat4],
    /// Output: one matrix per joint.
    pub palette: &'a mut [Mat4],
}

impl PaletteJob<'_> {
    /// Checks lengths and joint indices.
    pub fn validate(&self) -> Result<(), JobError> {
        check_eq("inverse_bind", self.joints.len(), self.inverse_bind.len())?;
        check_len("palette", self.joints.len(), self.palette.len())?;
        for &j in self.joints {
            check_index("joints", j as usize, self.worlds.len())?;
        }
        Ok(())
    }

    /// Validates, then writes `palette`.
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        for ((out, &joint), ibm) in self.palette.iter_mut().zip(self.joints).zip(self.inverse_bind) {
            let world = &self.worlds[joint as usize];
            // Inverse bind matrices are affine in practice: then the cheaper product is the same.
            let affine = ibm.x_axis.w == 0.0 && ibm.y_axis.w == 0.0 && ibm.z_axis.w == 0.0 && ibm.w_axis.w == 1.0;
            *out = if affine { affine_mul(world, ibm) } else { *world * *ibm };
        }
        Ok(())
    }
}

/// Linear blend skinning of positions and normals with up to 8 influences per vertex:
/// `p' = Σ w_i · palette[j_i] · p`; normals use the inverse transpose of the blended
/// matrix and are renormalized.
#[derive(Debug)]
pub struct LbsJob<'a> {
    /// Bind-pose positions.
    pub positions: &'a [[f32; 3]],
    /// Bind-pose normals; empty to skip normals.
    pub normals: &'a [[f32; 3]],
    /// Joint indices (into `palette`) per vertex.
    pub joints: &'a [[u16; 8]],
    /// Weights per vertex (summing to 1; zero-weight slots are ignored).
    pub weights: &'a [[f32; 8]],
    /// Skinning matrices ([`PaletteJob`]).
    pub palette: &'a [Mat4],
    /// Output positions, at least `positions.len()`.
    pub out_positions: &'a mut [[f32; 3]],
    /// Output normals, at least `normals.len()`.
    pub out_normals: &'a mut [[f32; 3]],
}

impl LbsJob<'_> {
    /// Checks lengths. Joint indices are checked while running.
    pub fn validate(&self) -> Result<(), JobError> {
        check_vertex_streams(
            self.positions,
            self.normals,
            self.joints,
            self.weights,
            self.out_positions.len(),
            self.out_normals.len(),
        )
    }

    /// Validates, then skins every vertex. Stops with `IndexOutOfRange` at the first
    /// weighted joint index outside `palette`.
    ///
    /// Vertices go in blocks of [`BLOCK`]: the matrices are blended per vertex (four-wide
    /// column adds), then positions and normals are transformed across the block from
    /// structure-of-arrays scratch on the stack, a loop the compiler vectorizes (SSE natively,
    /// SIMD128 on wasm).
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        let n = self.positions.len();
        let with_normals = !self.normals.is_empty();
        let mut block = Block::default();
        // An empty palette with any weight is an error below; with none, nothing is read.
        let empty = [Mat4::ZERO];
        let palette = if self.palette.is_empty() { &empty[..] } else { self.palette };
        let last = palette.len() - 1;
        let mut start = 0;
        while start < n {
            let len = BLOCK.min(n - start);
            for i in 0..len {
                let v = start + i;
                let (mut c0, mut c1, mut c2, mut c3) = (Vec4::ZERO, Vec4::ZERO, Vec4::ZERO, Vec4::ZERO);
                let (joints, weights) = (&self.joints[v], &self.weights[v]);
                // JOINTS_0 without branches: a zero weight adds nothing, so its joint only has
                // to be a valid index (clamped; an out-of-range joint with a weight is an error).
                for k in 0..4 {
                    let (j, w) = (joints[k] as usize, weights[k]);
                    if j >= self.palette.len() && w != 0.0 {
                        return Err(out_of_range(j, self.palette.len()));
                    }
                    let m = &palette[j.min(last)];
                    c0 += m.x_axis * w;
                    c1 += m.y_axis * w;
                    c2 += m.z_axis * w;
                    c3 += m.w_axis * w;
                }
                // Most vertices have at most four influences: JOINTS_1 in one test.
                if weights[4..] != [0.0; 4] {
                    for k in 4..8 {
                        let w = weights[k];
                        if w != 0.0 {
                            let m = joint_at(self.palette, joints[k])?;
                            c0 += m.x_axis * w;
                            c1 += m.y_axis * w;
                            c2 += m.z_axis * w;
                            c3 += m.w_axis * w;
                        }
                    }
                }
                block.set_matrix(i, c0, c1, c2, c3);
                let p = self.positions[v];
                block.p[0][i] = p[0];
                block.p[1][i] = p[1];
                block.p[2][i] = p[2];
                if with_normals {
                    let q = self.normals[v];
                    block.n[0][i] = q[0];
                    block.n[1][i] = q[1];
                    block.n[2][i] = q[2];
                }
            }
            block.transform_points();
            for (i, out) in self.out_positions[start..start + len].iter_mut().enumerate() {
                *out = [block.o[0][i], block.o[1][i], block.o[2][i]];
            }
            if with_normals {
                block.transform_normals();
                for (i, out) in self.out_normals[start..start + len].iter_mut().enumerate() {
                    *out = [block.o[0][i], block.o[1][i], block.o[2][i]];
                }
            }
            start += len;
        }
        Ok(())
    }
}

fn out_of_range(index: usize, len: usize) -> JobError {
    JobError::IndexOutOfRange { what: "joints", index, len }
}

/// Vertices per block of [`LbsJob::run`].
pub const BLOCK: usize = 16;

/// Structure-of-arrays scratch of one block: blended matrices (`m[row * 4 + col]`, affine
/// rows only), inputs and outputs.
struct Block {
    m: [[f32; BLOCK]; 12],
    p: [[f32; BLOCK]; 3],
    n: [[f32; BLOCK]; 3],
    o: [[f32; BLOCK]; 3],
}

impl Default for Block {
    fn default() -> Self {
        Self { m: [[0.0; BLOCK]; 12], p: [[0.0; BLOCK]; 3], n: [[0.0; BLOCK]; 3], o: [[0.0; BLOCK]; 3] }
    }
}

impl Block {
    /// Stores the matrix with columns `c0..c3` as lane `i`.
    #[inline]
    fn set_matrix(&mut self, i: usize, c0: Vec4, c1: Vec4, c2: Vec4, c3: Vec4) {
        for (r, col) in [(0, c0), (1, c1), (2, c2), (3, c3)] {
            self.m[r][i] = col.x;
            self.m[4 + r][i] = col.y;
            self.m[8 + r][i] = col.z;
        }
    }

    /// `o = M · p` (as `Mat4::transform_point3`: `x·c0 + y·c1 + z·c2 + c3`).
    #[inline]
    fn transform_points(&mut self) {
        let m = &self.m;
        let [x, y, z] = &self.p;
        for row in 0..3 {
            let (a, b, c, d) = (&m[row * 4], &m[row * 4 + 1], &m[row * 4 + 2], &m[row * 4 + 3]);
            let out = &mut self.o[row];
            for i in 0..BLOCK {
                out[i] = a[i] * x[i] + b[i] * y[i] + c[i] * z[i] + d[i];
            }
        }
    }

    /// `o = normalize(cofactor(M₃) · n · sign(det M₃))`, zero for a zero result (as
    /// [`transform_normal`]).
    #[inline]
    fn transform_normals(&mut self) {
        let m = &self.m;
        let [nx, ny, nz] = &self.n;
        let [ox, oy, oz] = &mut self.o;
        for i in 0..BLOCK {
            // Columns of the 3×3 part.
            let (c0x, c0y, c0z) = (m[0][i], m[4][i], m[8][i]);
            let (c1x, c1y, c1z) = (m[1][i], m[5][i], m[9][i]);
            let (c2x, c2y, c2z) = (m[2][i], m[6][i], m[10][i]);
            // c1 × c2, c2 × c0, c0 × c1.
            let (ax, ay, az) = (c1y * c2z - c1z * c2y, c1z * c2x - c1x * c2z, c1x * c2y - c1y * c2x);
            let (bx, by, bz) = (c2y * c0z - c2z * c0y, c2z * c0x - c2x * c0z, c2x * c0y - c2y * c0x);
            let (cx, cy, cz) = (c0y * c1z - c0z * c1y, c0z * c1x - c0x * c1z, c0x * c1y - c0y * c1x);
            let det = c0x * ax + c0y * ay + c0z * az;
            let sign = if det < 0.0 { -1.0 } else { 1.0 };
            let x = (ax * nx[i] + bx * ny[i] + cx * nz[i]) * sign;
            let y = (ay * nx[i] + by * ny[i] + cy * nz[i]) * sign;
            let z = (az * nx[i] + bz * ny[i] + cz * nz[i]) * sign;
            let len2 = x * x + y * y + z * z;
            let inv = if len2 > 0.0 && len2.is_finite() { 1.0 / len2.sqrt() } else { 0.0 };
            ox[i] = x * inv;
            oy[i] = y * inv;
            oz[i] = z * inv;
        }
    }
}

/// Skins with any [`SkinningMethod`]: the one entry point the instance, the tests and the
/// benchmarks use, dispatching to [`LbsJob`], [`RigidJob`], [`DqsJob`] or [`SjbJob`].
#[derive(Debug)]
pub struct SkinJob<'a> {
    /// The method.
    pub method: SkinningMethod,
    /// Bind-pose (morphed) positions.
    pub positions: &'a [[f32; 3]],
    /// Bind-pose normals; empty to skip normals.
    pub normals: &'a [[f32; 3]],
    /// Joint indices per vertex.
    pub joints: &'a [[u16; 8]],
    /// Weights per vertex.
    pub weights: &'a [[f32; 8]],
    /// Skinning matrices ([`PaletteJob`]).
    pub palette: &'a [Mat4],
    /// The palette split for dual quaternions ([`DqPrepareJob`](super::dqs::DqPrepareJob)); read
    /// by DQS and SJB only.
    pub joints_dq: &'a [JointDq],
    /// Joint centres of this primitive; required by SJB only.
    pub plan: Option<&'a SjbPlan>,
    /// Output positions, at least `positions.len()`.
    pub out_positions: &'a mut [[f32; 3]],
    /// Output normals, at least `normals.len()`.
    pub out_normals: &'a mut [[f32; 3]],
}

impl SkinJob<'_> {
    /// Runs the method's job (which validates its inputs first).
    ///
    /// # Errors
    /// The job's error; `InvalidInput` for SJB without a plan.
    pub fn run(&mut self) -> Result<(), JobError> {
        let (positions, normals, joints, weights) = (self.positions, self.normals, self.joints, self.weights);
        let (out_positions, out_normals) = (&mut *self.out_positions, &mut *self.out_normals);
        match self.method {
            SkinningMethod::Linear => {
                LbsJob { positions, normals, joints, weights, palette: self.palette, out_positions, out_normals }.run()
            }
            SkinningMethod::Rigid => {
                RigidJob { positions, normals, joints, weights, palette: self.palette, out_positions, out_normals }
                    .run()
            }
            SkinningMethod::DualQuaternion => {
                DqsJob { positions, normals, joints, weights, joints_dq: self.joints_dq, out_positions, out_normals }
                    .run()
            }
            SkinningMethod::SphericalJointBlend => {
                let plan =
                    self.plan.ok_or_else(|| JobError::InvalidInput("spherical joint blending needs a plan".into()))?;
                SjbJob {
                    positions,
                    normals,
                    joints,
                    weights,
                    palette: self.palette,
                    joints_dq: self.joints_dq,
                    plan,
                    out_positions,
                    out_normals,
                }
                .run()
            }
        }
    }
}

/// The length checks every skinning job makes: per-vertex streams of equal length (normals
/// may be empty) and outputs large enough.
pub(crate) fn check_vertex_streams(
    positions: &[[f32; 3]],
    normals: &[[f32; 3]],
    joints: &[[u16; 8]],
    weights: &[[f32; 8]],
    out_positions: usize,
    out_normals: usize,
) -> Result<(), JobError> {
    let n = positions.len();
    if !normals.is_empty() {
        check_eq("normals", n, normals.len())?;
    }
    check_eq("joints", n, joints.len())?;
    check_eq("weights", n, weights.len())?;
    check_len("out_positions", n, out_positions)?;
    check_len("out_normals", normals.len(), out_normals)?;
    Ok(())
}

/// `table[j]`, or `IndexOutOfRange` naming the vertex joint stream.
pub(crate) fn joint_at<T>(table: &[T], j: u16) -> Result<&T, JobError> {
    table.get(j as usize).ok_or(JobError::IndexOutOfRange { what: "joints", index: j as usize, len: table.len() })
}

/// Transforms a normal by the inverse transpose of `m`'s upper 3×3 (as its cofactor
/// matrix, signed by the determinant) and renormalizes; zero stays zero.
pub fn transform_normal(m: &Mat4, n: Vec3) -> Vec3 {
    let a = Mat3::from_mat4(*m);
    let (c0, c1, c2) = (a.x_axis, a.y_axis, a.z_axis);
    let cofactor = Mat3::from_cols(c1.cross(c2), c2.cross(c0), c0.cross(c1));
    let sign = if a.determinant() < 0.0 { -1.0 } else { 1.0 };
    (cofactor * n * sign).normalize_or_zero()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Quat, Transform};

    #[test]
    fn palette_multiplies_world_by_inverse_bind() {
        let worlds = [Mat4::from_translation(Vec3::X), Mat4::from_rotation_z(1.0)];
        let ibm = [Mat4::from_translation(-Vec3::Y), Mat4::from_scale(Vec3::splat(2.0))];
        let mut palette = [Mat4::ZERO; 2];
        PaletteJob { joints: &[1, 0], inverse_bind: &ibm, worlds: &worlds, palette: &mut palette }
            .run()
            .expect("valid");
        assert_eq!(palette[0], worlds[1] * ibm[0]);
        assert_eq!(palette[1], worlds[0] * ibm[1]);
        let mut job = PaletteJob { joints: &[2], inverse_bind: &ibm[..1], worlds: &worlds, palette: &mut palette };
        assert!(matches!(job.run(), Err(JobError::IndexOutOfRange { .. })));
    }

    #[test]
    fn normals_use_inverse_transpose() {
        let m = Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0));
        // A 45° normal in xy under x-scale 2 tilts towards y.
        let n = transform_normal(&m, Vec3::new(1.0, 1.0, 0.0).normalize());
        assert!(n.abs_diff_eq(Vec3::new(1.0, 2.0, 0.0).normalize(), 1e-6), "{n}");
        let mirrored = transform_normal(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)), Vec3::X);
        assert!(mirrored.abs_diff_eq(-Vec3::X, 1e-6));
    }

    /// A two-joint rig by hand: joint 0 at the origin, joint 1 one unit up, bent 90° about z.
    #[test]
    fn two_joint_rig_matches_hand_computation() {
        let rest = [Transform::IDENTITY, Transform { translation: Vec3::Y, ..Transform::IDENTITY }];
        let posed = [
            Transform::IDENTITY,
            Transform {
                translation: Vec3::Y,
                rotation: Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
                ..Transform::IDENTITY
            },
        ];
        let parents = [None, Some(0)];
        let mut bind = [Mat4::IDENTITY; 2];
        crate::job::world::WorldJob { parents: &parents, order: &[0, 1], locals: &rest, worlds: &mut bind }
            .run()
            .expect("valid");
        let inverse_bind = [bind[0].inverse(), bind[1].inverse()];
        let mut worlds = [Mat4::IDENTITY; 2];
        crate::job::world::WorldJob { parents: &parents, order: &[0, 1], locals: &posed, worlds: &mut worlds }
            .run()
            .expect("valid");
        let mut palette = [Mat4::ZERO; 2];
        PaletteJob { joints: &[0, 1], inverse_bind: &inverse_bind, worlds: &worlds, palette: &mut palette }
            .run()
            .expect("valid");
        // Vertex 0 at (1, 2, 0) fully on joint 1: rotating (1, 1, 0) about z by 90° around (0, 1, 0)
        // gives (-1, 1, 0) + (0, 1, 0) = (-1, 2, 0). Vertex 1 half on each: mean of (1, 2) and (-1, 2)
        // = (0, 2, 0). Normal +x on joint 1 becomes +y; half/half: (1,0)+(0,1) normalized.
        let positions = [[1.0, 2.0, 0.0], [1.0, 2.0, 0.0]];
        let normals = [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let joints = [[1, 0, 0, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0, 0, 0]];
        let weights = [[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]];
        let mut out_p = [[0.0; 3]; 2];
        let mut out_n = [[0.0; 3]; 2];
        LbsJob {
            positions: &positions,
            normals: &normals,
            joints: &joints,
            weights: &weights,
            palette: &palette,
            out_positions: &mut out_p,
            out_normals: &mut out_n,
        }
        .run()
        .expect("valid");
        let close = |a: [f32; 3], b: [f32; 3]| Vec3::from(a).abs_diff_eq(Vec3::from(b), 1e-5);
        assert!(close(out_p[0], [-1.0, 2.0, 0.0]), "{:?}", out_p[0]);
        assert!(close(out_p[1], [0.0, 2.0, 0.0]), "{:?}", out_p[1]);
        assert!(close(out_n[0], [0.0, 1.0, 0.0]), "{:?}", out_n[0]);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        assert!(close(out_n[1], [h, h, 0.0]), "{:?}", out_n[1]);
    }

    #[test]
    fn lbs_refuses_bad_joints_and_short_outputs() {
        let palette = [Mat4::IDENTITY];
        let mut out = [[0.0; 3]; 1];
        let mut job = LbsJob {
            positions: &[[0.0; 3]],
            normals: &[],
            joints: &[[3, 0, 0, 0, 0, 0, 0, 0]],
            weights: &[[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]],
            palette: &palette,
            out_positions: &mut out,
            out_normals: &mut [],
        };
        assert!(matches!(job.run(), Err(JobError::IndexOutOfRange { index: 3, .. })));
        let mut job = LbsJob {
            positions: &[[0.0; 3]; 2],
            normals: &[],
            joints: &[[0; 8]; 2],
            weights: &[[0.0; 8]; 2],
            palette: &palette,
            out_positions: &mut out,
            out_normals: &mut [],
        };
        assert!(matches!(job.run(), Err(JobError::BufferTooSmall { .. })));
    }
}
