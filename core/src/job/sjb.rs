//! Spherical joint blending (SJB; Hejl, seed 001 §5.2, eq. 5.1) on the CPU.
//!
//! Linear blend skinning written as rotation plus translation parts can blend the rotations
//! spherically when `A_Ri⁻¹ A_Ti` is the same for every influence of a vertex, i.e. when all
//! influencing bones start at one joint point (siblings), optionally plus the bone ending there
//! (their parent). The vertex is then rotated about that joint centre:
//!
//! `v' = q (v − A_T) + B_T`, `n' = q n`, `q = normalize(Σ wᵢ · qᵢ)`,
//!
//! with `A_T` the joint centre in the bind pose, `B_T` in the current pose, and the signs of
//! the `qᵢ` aligned to the parent's (the *driver*). Nothing collapses under twist; a slight
//! crease can appear on strong bends.
//!
//! Which vertices qualify depends only on the skeleton and the weights, so it is decided
//! once per (skin, primitive) by [`SjbPlan::build`]. Vertices whose influences do not share a
//! joint centre, and at run time vertices with a scaled or sheared joint, fall back to
//! dual-quaternion skinning ([`super::dqs`]); the plan counts the static fallbacks so the
//! viewer can report them per mesh.

use std::collections::HashMap;

use super::dqs::{JointDq, dqs_vertex_way};
use super::skin::{check_vertex_streams, joint_at};
use super::{check_eq, check_index};
use crate::asset::Skin;
use crate::error::JobError;
use crate::math::{Mat4, Quat, Vec3};

/// `vertex_pivots` value of a vertex that falls back to dual-quaternion skinning.
pub const NO_PIVOT: u32 = u32::MAX;

/// A joint centre vertices rotate about.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SjbPivot {
    /// Joint (index into the skin) whose skinning matrix carries the centre to the current pose.
    pub joint: u16,
    /// Joint whose rotation decides the hemisphere of the blended quaternion (the parent).
    pub driver: u16,
    /// The centre in the bind pose (`A_T`), in the mesh's bind space.
    pub bind: [f32; 3],
}

/// Per-vertex joint centres of one primitive under one skin.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SjbPlan {
    /// Distinct centres.
    pub pivots: Vec<SjbPivot>,
    /// Index into `pivots` per vertex, or [`NO_PIVOT`].
    pub vertex_pivots: Vec<u32>,
    /// Number of vertices with [`NO_PIVOT`].
    pub fallbacks: usize,
}

impl SjbPlan {
    /// Decides, per vertex, whether its influences share a joint centre.
    ///
    /// `parents` are the asset's node parents. A vertex qualifies when its weighted joints are
    /// one joint, or joints with one common parent node whose bind-pose origins coincide
    /// (within 1e-4 of the skeleton's extent), optionally plus that parent. Joint indices
    /// outside the skin, non-invertible inverse bind matrices and unknown nodes simply make a
    /// vertex fall back.
    pub fn build(skin: &Skin, parents: &[Option<u32>], joints: &[[u16; 8]], weights: &[[f32; 8]]) -> SjbPlan {
        let origins: Vec<Option<Vec3>> = skin
            .inverse_bind
            .iter()
            .map(|ibm| {
                let det = ibm.determinant();
                (det.is_finite() && det.abs() > 1e-12)
                    .then(|| ibm.inverse().w_axis.truncate())
                    .filter(|o| o.is_finite())
            })
            .collect();
        let extent = origins.iter().flatten().fold(0.0f32, |m, o| m.max(o.abs().max_element()));
        let tolerance = 1e-4 * extent.max(1.0);
        let parent_of = |j: u16| -> Option<u32> {
            let node = *skin.joints.get(j as usize)?;
            parents.get(node as usize).copied().flatten()
        };
        let node_of = |j: u16| skin.joints.get(j as usize).copied();

        let mut plan = SjbPlan { vertex_pivots: Vec::with_capacity(joints.len()), ..SjbPlan::default() };
        let mut index: HashMap<(u16, u16), u32> = HashMap::new();
        for (js, ws) in joints.iter().zip(weights) {
            let mut influences = [0u16; 8];
            let mut count = 0;
            for (&j, &w) in js.iter().zip(ws) {
                if w > 0.0 && !influences[..count].contains(&j) {
                    influences[count] = j;
                    count += 1;
                }
            }
            let influences = &influences[..count];
            let pivot = pivot_of(influences, &origins, tolerance, parent_of, node_of);
            let slot = match pivot {
                Some((joint, driver, bind)) => {
                    let next = plan.pivots.len() as u32;
                    *index.entry((joint, driver)).or_insert_with(|| {
                        plan.pivots.push(SjbPivot { joint, driver, bind: bind.to_array() });
                        next
                    })
                }
                None => {
                    plan.fallbacks += 1;
                    NO_PIVOT
                }
            };
            plan.vertex_pivots.push(slot);
        }
        plan
    }
}

/// `(centre joint, driver joint, centre in bind space)` of a vertex influenced by `joints`.
fn pivot_of(
    joints: &[u16],
    origins: &[Option<Vec3>],
    tolerance: f32,
    parent_of: impl Fn(u16) -> Option<u32>,
    node_of: impl Fn(u16) -> Option<u32>,
) -> Option<(u16, u16, Vec3)> {
    let origin = |j: u16| origins.get(j as usize).copied().flatten();
    match joints {
        [] => None,
        [j] => Some((*j, *j, origin(*j)?)),
        _ => {
            // The parent among the influences, if one is the parent of all the others.
            let parent = joints.iter().copied().find(|&p| {
                let node = node_of(p);
                joints.iter().all(|&c| c == p || (node.is_some() && parent_of(c) == node))
            });
            let children: &mut [u16; 8] = &mut [0; 8];
            let mut n = 0;
            for &j in joints {
                if Some(j) != parent {
                    children[n] = j;
                    n += 1;
                }
            }
            let children = &children[..n];
            let first = *children.first()?;
            // Without the parent influencing, the children must still be siblings.
            let common = parent_of(first)?;
            if children.iter().any(|&c| parent_of(c) != Some(common)) {
                return None;
            }
            let centre = origin(first)?;
            for &c in children {
                if origin(c)?.distance(centre) > tolerance {
                    return None;
                }
            }
            Some((first, parent.unwrap_or(first), centre))
        }
    }
}

/// Spherical joint blending of positions and normals with up to 8 influences per vertex.
#[derive(Debug)]
pub struct SjbJob<'a> {
    /// Bind-pose positions.
    pub positions: &'a [[f32; 3]],
    /// Bind-pose normals; empty to skip normals.
    pub normals: &'a [[f32; 3]],
    /// Joint indices per vertex.
    pub joints: &'a [[u16; 8]],
    /// Weights per vertex (summing to 1; zero-weight slots are ignored).
    pub weights: &'a [[f32; 8]],
    /// Skinning matrices ([`super::skin::PaletteJob`]).
    pub palette: &'a [Mat4],
    /// The same palette prepared for dual quaternions ([`super::dqs::DqPrepareJob`]).
    pub joints_dq: &'a [JointDq],
    /// Joint centres of this primitive ([`SjbPlan::build`]).
    pub plan: &'a SjbPlan,
    /// Output positions, at least `positions.len()`.
    pub out_positions: &'a mut [[f32; 3]],
    /// Output normals, at least `normals.len()`.
    pub out_normals: &'a mut [[f32; 3]],
}

impl SjbJob<'_> {
    /// Checks lengths and the plan's pivot joints. Vertex joint indices are checked while
    /// running.
    pub fn validate(&self) -> Result<(), JobError> {
        check_vertex_streams(
            self.positions,
            self.normals,
            self.joints,
            self.weights,
            self.out_positions.len(),
            self.out_normals.len(),
        )?;
        check_eq("joints_dq", self.palette.len(), self.joints_dq.len())?;
        check_eq("plan vertices", self.positions.len(), self.plan.vertex_pivots.len())?;
        for p in &self.plan.pivots {
            check_index("pivot joint", p.joint as usize, self.palette.len())?;
            check_index("pivot driver", p.driver as usize, self.palette.len())?;
        }
        for &v in &self.plan.vertex_pivots {
            if v != NO_PIVOT {
                check_index("vertex pivot", v as usize, self.plan.pivots.len())?;
            }
        }
        Ok(())
    }

    /// Validates, then skins every vertex: about its joint centre where the plan has one and
    /// every influence is rigid, by dual quaternions otherwise.
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        for v in 0..self.positions.len() {
            let (p, n) = sjb_vertex_way(
                Way::Skin,
                self.palette,
                self.joints_dq,
                self.plan,
                v,
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

/// A skinned position and, when the vertex has one, its normal.
pub(crate) type SkinnedVertex = ([f32; 3], Option<[f32; 3]>);

/// Which way a per-vertex transform runs: skinning a bind-pose vertex, or its inverse (the
/// bind-pose vertex, and normal direction not normalized, that skins to a given one; §5.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Way {
    Skin,
    Unskin,
}

/// Vertex `v` (at `position`, `normal`) skinned as [`SjbJob`] does — about its joint centre
/// where the plan has one and every influence is rigid, by dual quaternions otherwise — or,
/// [`Way::Unskin`], taken back to the bind pose (eq. 5.1 solved for the bind-pose vertex).
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn sjb_vertex_way(
    way: Way,
    palette: &[Mat4],
    table: &[JointDq],
    plan: &SjbPlan,
    v: usize,
    joints: &[u16; 8],
    weights: &[f32; 8],
    position: [f32; 3],
    normal: Option<&[f32; 3]>,
) -> Result<SkinnedVertex, JobError> {
    if let Some(pivot) = plan.vertex_pivots.get(v).and_then(|&p| plan.pivots.get(p as usize))
        && let Some(q) = sjb_rotation(table, pivot, joints, weights)?
    {
        let bind = Vec3::from(pivot.bind);
        let current = joint_at(palette, pivot.joint)?.transform_point3(bind);
        let (p, n) = match way {
            Way::Skin => (
                q * (Vec3::from(position) - bind) + current,
                normal.map(|n| (q * Vec3::from(*n)).try_normalize().unwrap_or(Vec3::ZERO)),
            ),
            Way::Unskin => {
                let back = q.conjugate();
                (back * (Vec3::from(position) - current) + bind, normal.map(|n| back * Vec3::from(*n)))
            }
        };
        return Ok((p.to_array(), n.map(|n| n.to_array())));
    }
    dqs_vertex_way(way, table, joints, weights, position, normal)
}

/// The blended rotation of a vertex about its centre (signs aligned to the driver's), or
/// `None` when an influence is scaled or sheared (the caller then falls back to dual
/// quaternions).
fn sjb_rotation(
    table: &[JointDq],
    pivot: &SjbPivot,
    joints: &[u16; 8],
    weights: &[f32; 8],
) -> Result<Option<Quat>, JobError> {
    let driver = joint_at(table, pivot.driver)?.dq.real;
    let mut q = Quat::from_xyzw(0.0, 0.0, 0.0, 0.0);
    for (&j, &w) in joints.iter().zip(weights) {
        if w == 0.0 {
            continue;
        }
        let joint = joint_at(table, j)?;
        if !joint.rigid {
            return Ok(None);
        }
        let w = if driver.dot(joint.dq.real) < 0.0 { -w } else { w };
        q += joint.dq.real * w;
    }
    let length = q.length();
    Ok(Some(if length > 1e-12 && length.is_finite() { q * (1.0 / length) } else { Quat::IDENTITY }))
}

#[cfg(test)]
mod tests {
    use super::super::dqs::DqPrepareJob;
    use super::*;
    use std::f32::consts::PI;

    /// Two joints along X: joint 0 at the origin (node 0), joint 1 at x = 1 (node 1, child of 0).
    fn skin() -> (Skin, Vec<Option<u32>>) {
        let skin = Skin {
            name: None,
            joints: vec![0, 1, 2],
            inverse_bind: vec![
                Mat4::IDENTITY,
                Mat4::from_translation(-Vec3::X),
                // Node 2: a sibling of node 1 starting elsewhere.
                Mat4::from_translation(-Vec3::Y),
            ],
            skeleton: None,
        };
        (skin, vec![None, Some(0), Some(0)])
    }

    #[test]
    fn plan_accepts_parent_child_pairs_and_rejects_unrelated_joints() {
        let (skin, parents) = skin();
        let joints =
            [[0, 1, 0, 0, 0, 0, 0, 0], [1, 0, 0, 0, 0, 0, 0, 0], [1, 2, 0, 0, 0, 0, 0, 0], [0, 9, 0, 0, 0, 0, 0, 0]];
        let mut w = [[0.0; 8]; 4];
        w[0][..2].copy_from_slice(&[0.5, 0.5]);
        w[1][0] = 1.0;
        w[2][..2].copy_from_slice(&[0.5, 0.5]);
        w[3][..2].copy_from_slice(&[0.5, 0.5]);
        let plan = SjbPlan::build(&skin, &parents, &joints, &w);
        // Parent 0 + child 1: about joint 1's origin, signs from joint 0.
        let p0 = plan.pivots[plan.vertex_pivots[0] as usize];
        assert_eq!((p0.joint, p0.driver, p0.bind), (1, 0, [1.0, 0.0, 0.0]));
        // One influence: its own origin.
        assert_eq!(plan.pivots[plan.vertex_pivots[1] as usize].joint, 1);
        // Siblings starting at different points, and an index outside the skin, fall back.
        assert_eq!(plan.vertex_pivots[2], NO_PIVOT);
        assert_eq!(plan.vertex_pivots[3], NO_PIVOT);
        assert_eq!(plan.fallbacks, 2);
    }

    #[test]
    fn twisted_ring_keeps_its_radius_and_bent_ring_rotates_about_the_joint() {
        let (skin, parents) = skin();
        // A ring of 16 vertices around x = 1, half on each joint.
        let positions: Vec<[f32; 3]> =
            (0..16).map(|k| (k as f32 / 16.0 * 2.0 * PI).sin_cos()).map(|(s, c)| [1.0, 0.2 * c, 0.2 * s]).collect();
        let normals: Vec<[f32; 3]> = positions.iter().map(|p| [0.0, p[1] / 0.2, p[2] / 0.2]).collect();
        let joints = vec![[0u16, 1, 0, 0, 0, 0, 0, 0]; 16];
        let weights = vec![[0.5f32, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]; 16];
        let plan = SjbPlan::build(&skin, &parents, &joints, &weights);
        assert_eq!(plan.fallbacks, 0);
        let run = |palette: &[Mat4]| {
            let mut table = vec![JointDq::default(); 3];
            DqPrepareJob { palette, out: &mut table }.run().expect("sized");
            let (mut out, mut out_n) = (vec![[0.0; 3]; 16], vec![[0.0; 3]; 16]);
            SjbJob {
                positions: &positions,
                normals: &normals,
                joints: &joints,
                weights: &weights,
                palette,
                joints_dq: &table,
                plan: &plan,
                out_positions: &mut out,
                out_normals: &mut out_n,
            }
            .run()
            .expect("valid");
            (out, out_n)
        };
        // 180° twist of joint 1 about its own axis: LBS would collapse the ring to the axis.
        let twist = Mat4::from_translation(Vec3::X) * Mat4::from_rotation_x(PI) * Mat4::from_translation(-Vec3::X);
        let (out, out_n) = run(&[Mat4::IDENTITY, twist, Mat4::IDENTITY]);
        for (p, n) in out.iter().zip(&out_n) {
            assert!(((p[1] * p[1] + p[2] * p[2]).sqrt() - 0.2).abs() < 1e-5, "{p:?}");
            assert!((p[0] - 1.0).abs() < 1e-5);
            assert!((Vec3::from(*n).length() - 1.0).abs() < 1e-5);
        }
        // 90° bend about z at the joint: the ring turns 45° about the joint centre.
        let bend = Mat4::from_translation(Vec3::X) * Mat4::from_rotation_z(PI / 2.0) * Mat4::from_translation(-Vec3::X);
        let (out, _) = run(&[Mat4::IDENTITY, bend, Mat4::IDENTITY]);
        let half = Quat::from_rotation_z(PI / 4.0);
        for (p, bind) in out.iter().zip(&positions) {
            let want = half * (Vec3::from(*bind) - Vec3::X) + Vec3::X;
            assert!(Vec3::from(*p).abs_diff_eq(want, 1e-5), "{p:?} vs {want}");
        }
    }

    #[test]
    fn scaled_joints_and_fallback_vertices_match_dual_quaternions() {
        let (skin, parents) = skin();
        let positions = vec![[1.0, 0.2, 0.0], [0.5, 0.0, 0.3]];
        let joints = vec![[0u16, 1, 0, 0, 0, 0, 0, 0], [1, 2, 0, 0, 0, 0, 0, 0]];
        let weights = vec![[0.3f32, 0.7, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]; 2];
        let plan = SjbPlan::build(&skin, &parents, &joints, &weights);
        assert_eq!(plan.vertex_pivots[1], NO_PIVOT);
        let palette = [Mat4::IDENTITY, Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0)), Mat4::from_rotation_y(0.7)];
        let mut table = vec![JointDq::default(); 3];
        DqPrepareJob { palette: &palette, out: &mut table }.run().expect("sized");
        let mut out = vec![[0.0; 3]; 2];
        SjbJob {
            positions: &positions,
            normals: &[],
            joints: &joints,
            weights: &weights,
            palette: &palette,
            joints_dq: &table,
            plan: &plan,
            out_positions: &mut out,
            out_normals: &mut [],
        }
        .run()
        .expect("valid");
        for v in 0..2 {
            let (want, _) =
                super::super::dqs::dqs_vertex_way(Way::Skin, &table, &joints[v], &weights[v], positions[v], None)
                    .expect("valid");
            assert_eq!(out[v], want);
        }
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let (skin, parents) = skin();
        let positions = vec![[1.0, 0.2, 0.0]];
        let mut joints = vec![[0u16, 1, 0, 0, 0, 0, 0, 0]];
        let weights = vec![[0.5f32, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]];
        let plan = SjbPlan::build(&skin, &parents, &joints, &weights);
        let palette = [Mat4::IDENTITY; 3];
        let table = [JointDq::default(); 3];
        let mut out = vec![[0.0; 3]; 1];
        let mut job = |plan: &SjbPlan, joints: &[[u16; 8]], table: &[JointDq]| {
            SjbJob {
                positions: &positions,
                normals: &[],
                joints,
                weights: &weights,
                palette: &palette,
                joints_dq: table,
                plan,
                out_positions: &mut out,
                out_normals: &mut [],
            }
            .run()
        };
        assert!(job(&plan, &joints, &table).is_ok());
        assert!(matches!(job(&plan, &joints, &table[..2]), Err(JobError::LengthMismatch { .. })));
        assert!(matches!(job(&SjbPlan::default(), &joints, &table), Err(JobError::LengthMismatch { .. })));
        let mut broken = plan.clone();
        broken.pivots[0].joint = 7;
        assert!(matches!(job(&broken, &joints, &table), Err(JobError::IndexOutOfRange { .. })));
        broken = plan.clone();
        broken.vertex_pivots[0] = 5;
        assert!(matches!(job(&broken, &joints, &table), Err(JobError::IndexOutOfRange { .. })));
        joints[0][1] = 40;
        assert!(matches!(job(&plan, &joints, &table), Err(JobError::IndexOutOfRange { index: 40, .. })));
    }
}
