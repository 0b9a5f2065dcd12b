//! Dual-quaternion skinning (Kavan et al. 2007) and rigid skinning on the CPU: the reference
//! for the methods that fix linear blend skinning's candy-wrapper collapse.
//!
//! Each palette matrix `M = [R | t] · S` is split once per frame ([`DqPrepareJob`]) into a unit
//! dual quaternion for its rigid part `[R | t]` and a 3×3 stretch `S = Rᵀ · M₃` (identity for
//! the usual rigid joints). [`DqsJob`] then blends, per vertex, the dual quaternions with their
//! signs aligned to the first influence's hemisphere and normalizes the result. The documented
//! fallback for scaled or sheared joints is Kavan's two-phase skinning: the stretches are
//! blended linearly and applied first, `p' = DQ(Σ wᵢ qᵢ) · (Σ wᵢ Sᵢ) · p`, which is exact for
//! a single influence and reduces to plain DQS where every `Sᵢ = I`.

use super::check_len;
use super::sjb::Way;
use super::skin::{check_vertex_streams, joint_at, transform_normal};
use crate::error::JobError;
use crate::math::{Mat3, Mat4, Quat, Vec3};

/// How vertices follow their joints.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SkinningMethod {
    /// The strongest influence only (ties: the first).
    Rigid,
    /// Linear blend skinning: the weighted sum of the joint matrices ([`super::skin::LbsJob`]).
    #[default]
    Linear,
    /// Dual-quaternion skinning: no collapse under twist, no volume loss under bend.
    DualQuaternion,
    /// Spherical joint blending ([`super::sjb`]): rotation about the shared joint centre,
    /// dual quaternions where the influences do not share one.
    SphericalJointBlend,
    /// Spherical joint blending by example ([`super::sjbbe`]): SJB after the example poses'
    /// offsets weighted by how close each joint is to its examples. Without examples it is
    /// SJB.
    SphericalJointBlendByExample,
}

impl SkinningMethod {
    /// Every method, in menu order.
    pub const ALL: [SkinningMethod; 5] = [
        SkinningMethod::Rigid,
        SkinningMethod::Linear,
        SkinningMethod::DualQuaternion,
        SkinningMethod::SphericalJointBlend,
        SkinningMethod::SphericalJointBlendByExample,
    ];

    /// The short name used by `kloub pose --skinning` and the page (`rigid`, `lbs`, `dqs`,
    /// `sjb`, `sjbbe`).
    pub fn name(self) -> &'static str {
        match self {
            SkinningMethod::Rigid => "rigid",
            SkinningMethod::Linear => "lbs",
            SkinningMethod::DualQuaternion => "dqs",
            SkinningMethod::SphericalJointBlend => "sjb",
            SkinningMethod::SphericalJointBlendByExample => "sjbbe",
        }
    }

    /// Whether the method reads dual quaternions ([`super::dqs::DqPrepareJob`]).
    pub fn uses_dual_quaternions(self) -> bool {
        !matches!(self, SkinningMethod::Rigid | SkinningMethod::Linear)
    }

    /// Whether the method needs a joint-centre plan ([`super::sjb::SjbPlan`]).
    pub fn uses_sjb_plan(self) -> bool {
        matches!(self, SkinningMethod::SphericalJointBlend | SkinningMethod::SphericalJointBlendByExample)
    }

    /// The method named `name` ([`SkinningMethod::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// A unit dual quaternion `real + ε·dual` representing a rotation followed by a translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DualQuat {
    /// The rotation.
    pub real: Quat,
    /// Half the translation times the rotation: `½ · (t, 0) · real`.
    pub dual: Quat,
}

impl DualQuat {
    /// The identity transform.
    pub const IDENTITY: DualQuat = DualQuat { real: Quat::IDENTITY, dual: Quat::from_xyzw(0.0, 0.0, 0.0, 0.0) };

    /// Rotation `rotation` (unit) then translation `translation`.
    pub fn from_rotation_translation(rotation: Quat, translation: Vec3) -> Self {
        let t = Quat::from_xyzw(translation.x, translation.y, translation.z, 0.0);
        Self { real: rotation, dual: (t * rotation) * 0.5 }
    }

    /// The translation part: `2 · dual · conj(real)` (for a unit dual quaternion).
    pub fn translation(&self) -> Vec3 {
        let t = (self.dual * self.real.conjugate()) * 2.0;
        Vec3::new(t.x, t.y, t.z)
    }

    /// Transforms a point (rotation, then translation).
    pub fn transform_point(&self, p: Vec3) -> Vec3 {
        self.real * p + self.translation()
    }
}

/// One joint prepared for [`DqsJob`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointDq {
    /// Rigid part of the palette matrix.
    pub dq: DualQuat,
    /// `Rᵀ · M₃`: scale and shear left after the rotation is taken out (identity when rigid).
    pub stretch: Mat3,
    /// Whether `stretch` is the identity (within 1e-5).
    pub rigid: bool,
}

impl Default for JointDq {
    fn default() -> Self {
        Self { dq: DualQuat::IDENTITY, stretch: Mat3::IDENTITY, rigid: true }
    }
}

/// Splits each palette matrix into a dual quaternion and a stretch (once per frame per skin).
#[derive(Debug)]
pub struct DqPrepareJob<'a> {
    /// Skinning matrices ([`super::skin::PaletteJob`]).
    pub palette: &'a [Mat4],
    /// Output, at least `palette.len()`.
    pub out: &'a mut [JointDq],
}

impl DqPrepareJob<'_> {
    /// Checks lengths.
    pub fn validate(&self) -> Result<(), JobError> {
        check_len("out", self.palette.len(), self.out.len())
    }

    /// Validates, then prepares every joint. A matrix without a usable rotation (degenerate or
    /// not finite) becomes its stretch alone around the identity rotation, so nothing is NaN.
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        for (m, out) in self.palette.iter().zip(self.out.iter_mut()) {
            *out = prepare(m);
        }
        Ok(())
    }
}

fn prepare(m: &Mat4) -> JointDq {
    let m3 = Mat3::from_mat4(*m);
    let translation = m.w_axis.truncate();
    let rotation = rotation_of(&m3);
    let stretch = Mat3::from_quat(rotation.conjugate()) * m3;
    let stretch = if stretch.is_finite() { stretch } else { Mat3::IDENTITY };
    let rigid = stretch.abs_diff_eq(Mat3::IDENTITY, 1e-5);
    let translation = if translation.is_finite() { translation } else { Vec3::ZERO };
    JointDq {
        dq: DualQuat::from_rotation_translation(rotation, translation),
        stretch: if rigid { Mat3::IDENTITY } else { stretch },
        rigid,
    }
}

/// The rotation of `m3` (Gram–Schmidt on its columns, keeping a right-handed frame); identity
/// when degenerate.
pub(crate) fn rotation_of(m3: &Mat3) -> Quat {
    let x = m3.x_axis.try_normalize();
    let y = m3.y_axis;
    let Some(x) = x else { return Quat::IDENTITY };
    let Some(y) = (y - x * x.dot(y)).try_normalize() else { return Quat::IDENTITY };
    // Right-handed even for a mirroring matrix: the stretch then carries the reflection.
    let z = x.cross(y);
    let q = Quat::from_mat3(&Mat3::from_cols(x, y, z));
    if q.is_finite() { q.normalize() } else { Quat::IDENTITY }
}

/// Dual-quaternion skinning of positions and normals with up to 8 influences per vertex.
#[derive(Debug)]
pub struct DqsJob<'a> {
    /// Bind-pose positions.
    pub positions: &'a [[f32; 3]],
    /// Bind-pose normals; empty to skip normals.
    pub normals: &'a [[f32; 3]],
    /// Joint indices (into `joints_dq`) per vertex.
    pub joints: &'a [[u16; 8]],
    /// Weights per vertex (summing to 1; zero-weight slots are ignored).
    pub weights: &'a [[f32; 8]],
    /// Prepared joints ([`DqPrepareJob`]).
    pub joints_dq: &'a [JointDq],
    /// Output positions, at least `positions.len()`.
    pub out_positions: &'a mut [[f32; 3]],
    /// Output normals, at least `normals.len()`.
    pub out_normals: &'a mut [[f32; 3]],
}

impl DqsJob<'_> {
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
    /// weighted joint index outside `joints_dq`.
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        let table = self.joints_dq;
        for v in 0..self.positions.len() {
            let (p, n) = dqs_vertex_way(
                Way::Skin,
                table,
                &self.joints[v],
                &self.weights[v],
                self.positions[v],
                self.normals.get(v),
            )?;
            self.out_positions[v] = p;
            if let (Some(out), Some(n)) = (self.out_normals.get_mut(v), n) {
                *out = n;
            }
        }
        Ok(())
    }
}

/// The blended, normalized dual quaternion of one vertex's influences, their blended stretch,
/// and whether every influence is rigid.
pub(crate) fn dq_blend(
    table: &[JointDq],
    joints: &[u16; 8],
    weights: &[f32; 8],
) -> Result<(DualQuat, Mat3, bool), JobError> {
    let (mut real, mut dual) = (Quat::from_xyzw(0.0, 0.0, 0.0, 0.0), Quat::from_xyzw(0.0, 0.0, 0.0, 0.0));
    let mut stretch = Mat3::ZERO;
    let mut all_rigid = true;
    let mut pivot: Option<Quat> = None;
    for (&j, &w) in joints.iter().zip(weights) {
        if w == 0.0 {
            continue;
        }
        let joint = joint_at(table, j)?;
        // Hemisphere alignment to the first influence: q and −q are the same rotation.
        let first = *pivot.get_or_insert(joint.dq.real);
        let w_signed = if first.dot(joint.dq.real) < 0.0 { -w } else { w };
        real += joint.dq.real * w_signed;
        dual += joint.dq.dual * w_signed;
        stretch += joint.stretch * w;
        all_rigid &= joint.rigid;
    }
    let length = real.length();
    Ok(if length > 1e-12 && length.is_finite() {
        (DualQuat { real: real * (1.0 / length), dual: dual * (1.0 / length) }, stretch, all_rigid)
    } else {
        (DualQuat::IDENTITY, Mat3::IDENTITY, true)
    })
}

/// Dual-quaternion skinning of one vertex ([`Way::Skin`]; shared with the spherical-joint-blend
/// fallback) or ([`Way::Unskin`]) its inverse: the bind-pose position (and normal direction,
/// not normalized) that the influences carry to `position` (`normal`).
#[inline]
pub(crate) fn dqs_vertex_way(
    way: Way,
    table: &[JointDq],
    joints: &[u16; 8],
    weights: &[f32; 8],
    position: [f32; 3],
    normal: Option<&[f32; 3]>,
) -> Result<([f32; 3], Option<[f32; 3]>), JobError> {
    let (dq, stretch, all_rigid) = dq_blend(table, joints, weights)?;
    let (p, n) = (Vec3::from(position), normal.map(|n| Vec3::from(*n)));
    Ok(match way {
        Way::Skin => {
            let p = if all_rigid { p } else { stretch * p };
            let n = n.map(|n| {
                let n = if all_rigid { n } else { stretch.inverse().transpose() * n };
                (dq.real * n).try_normalize().unwrap_or(Vec3::ZERO).to_array()
            });
            (dq.transform_point(p).to_array(), n)
        }
        Way::Unskin => {
            let back = dq.real.conjugate();
            let p = back * (p - dq.translation());
            let p = if all_rigid { p } else { stretch.inverse() * p };
            let n = n.map(|n| {
                let n = back * n;
                (if all_rigid { n } else { stretch.transpose() * n }).to_array()
            });
            (p.to_array(), n)
        }
    })
}

/// Rigid skinning: each vertex follows its strongest influence only.
#[derive(Debug)]
pub struct RigidJob<'a> {
    /// Bind-pose positions.
    pub positions: &'a [[f32; 3]],
    /// Bind-pose normals; empty to skip normals.
    pub normals: &'a [[f32; 3]],
    /// Joint indices (into `palette`) per vertex.
    pub joints: &'a [[u16; 8]],
    /// Weights per vertex.
    pub weights: &'a [[f32; 8]],
    /// Skinning matrices ([`super::skin::PaletteJob`]).
    pub palette: &'a [Mat4],
    /// Output positions, at least `positions.len()`.
    pub out_positions: &'a mut [[f32; 3]],
    /// Output normals, at least `normals.len()`.
    pub out_normals: &'a mut [[f32; 3]],
}

impl RigidJob<'_> {
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

    /// Validates, then moves every vertex with its strongest joint (a vertex without a
    /// positive weight stays where it is).
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        for v in 0..self.positions.len() {
            let m = match super::strongest_joint(&self.joints[v], &self.weights[v]) {
                Some(j) => *joint_at(self.palette, j)?,
                None => Mat4::IDENTITY,
            };
            self.out_positions[v] = m.transform_point3(Vec3::from(self.positions[v])).to_array();
            if let Some(n) = self.normals.get(v) {
                self.out_normals[v] = transform_normal(&m, Vec3::from(*n)).to_array();
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::skin::SkinJob;
    use super::*;
    use std::f32::consts::PI;

    /// Positions, normals, joints, weights.
    type Rig = (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<[u16; 8]>, Vec<[f32; 8]>);

    /// A cylinder along X from −1 to 1 (radius 0.2, 41 rings of 16 vertices), bound to joint 0
    /// (x < −0.25), joint 1 (x > 0.25) and blended linearly in between.
    fn candy_wrapper() -> Rig {
        let (mut p, mut n, mut j, mut w) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for ring in 0..=40 {
            let x = -1.0 + ring as f32 / 20.0;
            let w1 = ((x + 0.25) / 0.5).clamp(0.0, 1.0);
            for k in 0..16 {
                let a = k as f32 / 16.0 * 2.0 * PI;
                p.push([x, 0.2 * a.cos(), 0.2 * a.sin()]);
                n.push([0.0, a.cos(), a.sin()]);
                j.push([0, 1, 0, 0, 0, 0, 0, 0]);
                w.push([1.0 - w1, w1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
            }
        }
        (p, n, j, w)
    }

    /// Mean distance from the X axis of the skinned ring at x = 0 (ring 20), over 0.2.
    fn radius_kept(out: &[[f32; 3]]) -> f32 {
        let ring = &out[20 * 16..21 * 16];
        ring.iter().map(|v| (v[1] * v[1] + v[2] * v[2]).sqrt()).sum::<f32>() / 16.0 / 0.2
    }

    fn skin(method: SkinningMethod, palette: &[Mat4]) -> Vec<[f32; 3]> {
        let (p, n, j, w) = candy_wrapper();
        let (mut out, mut out_n) = (vec![[0.0; 3]; p.len()], vec![[0.0; 3]; n.len()]);
        let mut table = vec![JointDq::default(); palette.len()];
        DqPrepareJob { palette, out: &mut table }.run().expect("sized");
        // Joint 1 is a child of joint 0; both bind at the origin (the twist centre).
        let skin = crate::asset::Skin {
            name: None,
            joints: vec![0, 1],
            inverse_bind: vec![Mat4::IDENTITY; 2],
            skeleton: None,
        };
        let plan = super::super::sjb::SjbPlan::build(&skin, &[None, Some(0)], &j, &w);
        SkinJob {
            method,
            positions: &p,
            normals: &n,
            joints: &j,
            weights: &w,
            palette,
            joints_dq: &table,
            plan: Some(&plan),
            examples: None,
            out_positions: &mut out,
            out_normals: &mut out_n,
        }
        .run()
        .expect("valid input");
        assert!(out_n.iter().all(|v| Vec3::from(*v).is_finite()));
        out
    }

    #[test]
    fn candy_wrapper_twist_collapses_lbs_but_not_dqs_or_sjb() {
        let twist = [Mat4::IDENTITY, Mat4::from_rotation_x(PI)];
        let lbs = radius_kept(&skin(SkinningMethod::Linear, &twist));
        let dqs = radius_kept(&skin(SkinningMethod::DualQuaternion, &twist));
        let sjb = radius_kept(&skin(SkinningMethod::SphericalJointBlend, &twist));
        let rigid = radius_kept(&skin(SkinningMethod::Rigid, &twist));
        assert!(lbs < 0.10, "LBS keeps {lbs} of the radius at 180° twist");
        assert!(dqs >= 0.95, "DQS keeps {dqs} of the radius at 180° twist");
        assert!(sjb >= 0.95, "SJB keeps {sjb} of the radius at 180° twist");
        assert!((rigid - 1.0).abs() < 1e-5, "rigid moves whole rings: {rigid}");
    }

    #[test]
    fn one_influence_matches_the_matrix_for_every_method_even_with_scale() {
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(1.5, 0.5, 2.0),
            Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.2, 2.0),
            Vec3::new(1.0, -2.0, 0.5),
        );
        let palette = [m, m];
        let expected: Vec<Vec3> = candy_wrapper().0.iter().map(|p| m.transform_point3(Vec3::from(*p))).collect();
        for method in SkinningMethod::ALL {
            for (got, want) in skin(method, &palette).iter().zip(&expected) {
                assert!(Vec3::from(*got).abs_diff_eq(*want, 1e-4), "{method:?}: {got:?} vs {want}");
            }
        }
    }

    #[test]
    fn rigid_transforms_blend_without_the_stretch_path() {
        let a = Mat4::from_rotation_translation(Quat::from_rotation_z(0.4), Vec3::new(0.0, 1.0, 0.0));
        let mut table = [JointDq::default()];
        DqPrepareJob { palette: &[a], out: &mut table }.run().expect("sized");
        assert!(table[0].rigid);
        let p = Vec3::new(0.3, -0.2, 0.9);
        assert!(table[0].dq.transform_point(p).abs_diff_eq(a.transform_point3(p), 1e-6));
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let (p, n, mut j, w) = candy_wrapper();
        let mut table = vec![JointDq::default(); 2];
        let (mut out, mut out_n) = (vec![[0.0; 3]; p.len()], vec![[0.0; 3]; n.len()]);
        j[320][1] = 9; // ring 20, weights 0.5 / 0.5
        let err = DqsJob {
            positions: &p,
            normals: &n,
            joints: &j,
            weights: &w,
            joints_dq: &table,
            out_positions: &mut out,
            out_normals: &mut out_n,
        }
        .run();
        assert!(matches!(err, Err(JobError::IndexOutOfRange { index: 9, .. })), "{err:?}");
        let short = DqsJob {
            positions: &p,
            normals: &n[1..],
            joints: &j,
            weights: &w,
            joints_dq: &table,
            out_positions: &mut out,
            out_normals: &mut out_n,
        }
        .run();
        assert!(matches!(short, Err(JobError::LengthMismatch { .. })));
        assert!(DqPrepareJob { palette: &[Mat4::IDENTITY; 3], out: &mut table }.run().is_err());
        // Degenerate and non-finite matrices prepare to something finite.
        let mut one = [JointDq::default()];
        for m in [Mat4::ZERO, Mat4::from_cols_array(&[f32::NAN; 16])] {
            DqPrepareJob { palette: &[m], out: &mut one }.run().expect("sized");
            assert!(one[0].dq.real.is_finite() && one[0].dq.dual.is_finite());
        }
    }

    #[test]
    fn method_names_round_trip() {
        for m in SkinningMethod::ALL {
            assert_eq!(SkinningMethod::from_name(m.name()), Some(m));
        }
        assert_eq!(SkinningMethod::from_name("vsp"), None);
    }
}
