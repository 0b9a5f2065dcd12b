//! Spherical joint blending by example (SJBBE; seed 001 §5.3, App. B): SJB plus example
//! poses that an artist adds for one bone at a time.
//!
//! - An example pose differs from the reference (bind) pose by the rotation of one joint `k`
//!   only. `k` needs a parent joint and exactly one child joint: the bone from `k` to that
//!   child gives the bone's direction. At most [`MAX_EXAMPLES`] per joint.
//! - The *support* of `k` is the set of vertices influenced by `k`'s parent but not by its
//!   grandparent (so that bending the forearm may bulge the upper arm); supports of different
//!   joints are disjoint.
//! - Each example's shape is taken back to the reference pose through the inverse of eq. 5.1
//!   (dual quaternions' inverse for vertices SJB hands to DQS): `v₀ᵖ = q⁻¹ (vᵖ − B_T) + A_T`,
//!   the offset is `v₀ᵖ − v` (normals likewise).
//! - Per frame the weights α of a joint's examples come from Gaussian radial basis functions
//!   `φ(r) = exp(−r²/σ²)` over the arc length `r` between the bone's direction in its parent's
//!   frame now and at each example, the reference pose being an example with α = 0:
//!   `α = Λ φ`, with `Λ = (G⁻¹ F)ᵀ` solved once in f64 ([`SjbbeRig::build`]), and
//!   `v' = SJB(v + Σₚ αₚ offsetₚ)` (morph targets applied before), normals renormalized.
//!
//! [`SjbbeRig`] is built once per skin, primitive and set of examples; [`SjbbeAlphaJob`]
//! computes α (a few numbers per joint: all a GPU path needs per frame) and [`SjbbeJob`]
//! deforms the vertices on the CPU.

use std::fmt;

use super::dqs::{DqPrepareJob, JointDq};
use super::sjb::{SjbPlan, Way, sjb_vertex_way};
use super::skin::check_vertex_streams;
use super::{check_eq, check_index, check_len};
use crate::asset::Skin;
use crate::error::JobError;
use crate::math::{Mat4, Quat, QuatExt, Vec3};

/// Example poses per joint at most (as in the seed).
pub const MAX_EXAMPLES: usize = 4;

/// The Gaussians' σ (radians of arc) where a joint does not set its own, as in the seed.
pub const DEFAULT_SIGMA: f32 = 1.0;

/// `vertex_slot` of a vertex outside every support.
pub const NO_SLOT: u32 = u32::MAX;

/// What an example's shape holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExampleSpace {
    /// Offsets already in the reference pose (a corrective shape key).
    Rest,
    /// The vertices as seen in the example pose, taken back to the reference pose (§5.3).
    Posed,
}

/// One example pose as an artist gives it.
#[derive(Clone, Debug, PartialEq)]
pub struct ExamplePose {
    /// The joint (index into the skin's joints) whose rotation differs from the reference.
    pub joint: u16,
    /// The joint's local rotation in the example (in its parent's frame, as a node's `rotation`).
    pub rotation: Quat,
    /// Per vertex of the primitive: offsets ([`ExampleSpace::Rest`]) or positions
    /// ([`ExampleSpace::Posed`]). Only the support's vertices are read.
    pub positions: Vec<[f32; 3]>,
    /// Per vertex, like `positions`, for normals; empty when the example leaves them.
    pub normals: Vec<[f32; 3]>,
    /// What `positions` and `normals` hold.
    pub space: ExampleSpace,
}

/// Why a set of examples cannot be used; `example` indexes the list given to
/// [`SjbbeRig::build`] (`None`: the joint's examples as a whole).
#[derive(Clone, Debug, PartialEq)]
pub struct SjbbeError {
    /// The offending example.
    pub example: Option<usize>,
    /// The joint concerned.
    pub joint: u16,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for SjbbeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.example {
            Some(e) => write!(f, "example {e} (joint {}): {}", self.joint, self.message),
            None => write!(f, "joint {}: {}", self.joint, self.message),
        }
    }
}

impl std::error::Error for SjbbeError {}

/// One joint with examples.
#[derive(Clone, Debug, PartialEq)]
pub struct SjbbeBone {
    /// The joint `k` (index into the skin).
    pub joint: u16,
    /// Its parent joint.
    pub parent: u16,
    /// Its one child joint.
    pub child: u16,
    /// The Gaussians' σ, radians of arc.
    pub sigma: f32,
    /// The examples' rotations of `k` (local), in the order of `directions[1..]`.
    pub rotations: Vec<Quat>,
    /// Unit bone directions in the parent's frame: the reference pose's, then each example's.
    pub directions: Vec<[f64; 3]>,
    /// `Λ`: one row of `directions.len()` RBF weights per example.
    pub lambda: Vec<Vec<f64>>,
    /// Bind-pose world matrices of the parent, `k` and the child (current ones are the
    /// palette times these).
    bind: [Mat4; 3],
}

/// Everything SJBBE needs beyond SJB for one primitive under one skin.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SjbbeRig {
    /// The joints with examples.
    pub bones: Vec<SjbbeBone>,
    /// Per vertex: its row in `offsets`, or [`NO_SLOT`] outside every support.
    pub vertex_slot: Vec<u32>,
    /// Per support vertex: its bone (index into `bones`).
    pub slot_bone: Vec<u16>,
    /// Per support vertex: the position offset of each example (zero past the bone's count).
    pub offsets: Vec<[[f32; 3]; MAX_EXAMPLES]>,
    /// Per support vertex: the normal offset of each example.
    pub normal_offsets: Vec<[[f32; 3]; MAX_EXAMPLES]>,
}

/// The primitive and skeleton a rig is built for.
#[derive(Clone, Copy, Debug)]
pub struct SjbbeInput<'a> {
    /// The skin.
    pub skin: &'a Skin,
    /// The asset's node parents.
    pub parents: &'a [Option<u32>],
    /// Bind-pose (morphed) positions.
    pub positions: &'a [[f32; 3]],
    /// Bind-pose normals; may be empty.
    pub normals: &'a [[f32; 3]],
    /// Joint indices per vertex.
    pub joints: &'a [[u16; 8]],
    /// Weights per vertex.
    pub weights: &'a [[f32; 8]],
    /// The SJB plan of this primitive.
    pub plan: &'a SjbPlan,
}

impl SjbbeRig {
    /// Builds the rig: supports, the examples' offsets in the reference pose and each joint's
    /// RBF weights. `sigmas` sets σ per joint (others get [`DEFAULT_SIGMA`]).
    ///
    /// # Errors
    /// An example for a joint outside the skin, without a parent joint or without exactly one
    /// child joint; a rotation that is not a unit quaternion; shapes of the wrong length; more
    /// than [`MAX_EXAMPLES`] for a joint; two joints sharing a support; examples whose bone
    /// directions coincide with each other or the reference (G singular or ill-conditioned).
    pub fn build(input: SjbbeInput<'_>, examples: &[ExamplePose], sigmas: &[(u16, f32)]) -> Result<Self, SjbbeError> {
        let SjbbeInput { skin, parents, positions, normals, joints, weights, plan } = input;
        let n = positions.len();
        let error = |example: Option<usize>, joint: u16, message: String| SjbbeError { example, joint, message };
        if joints.len() != n || weights.len() != n || (!normals.is_empty() && normals.len() != n) {
            return Err(error(None, 0, "the primitive's vertex streams differ in length".into()));
        }
        // Bind-pose world matrices from the inverse binds.
        let bind_world = |j: u16, example: Option<usize>| -> Result<Mat4, SjbbeError> {
            let ibm = skin.inverse_bind.get(j as usize).ok_or_else(|| {
                error(example, j, format!("joint {j} is not in the skin ({} joints)", skin.joints.len()))
            })?;
            let det = ibm.determinant();
            if !(det.is_finite() && det.abs() > 1e-12) {
                return Err(error(example, j, "its inverse bind matrix is not invertible".into()));
            }
            Ok(ibm.inverse())
        };
        let joint_of_node = |node: u32| skin.joints.iter().position(|&j| j == node).map(|j| j as u16);
        let parent_joint = |j: u16| -> Option<u16> {
            let node = *skin.joints.get(j as usize)?;
            joint_of_node(parents.get(node as usize).copied().flatten()?)
        };

        let mut rig = SjbbeRig { vertex_slot: vec![NO_SLOT; n], ..SjbbeRig::default() };
        // Examples grouped by joint, in the order joints first appear.
        let mut order: Vec<u16> = Vec::new();
        for e in examples {
            if !order.contains(&e.joint) {
                order.push(e.joint);
            }
        }
        for joint in order {
            let mine: Vec<usize> = (0..examples.len()).filter(|&i| examples[i].joint == joint).collect();
            if mine.len() > MAX_EXAMPLES {
                return Err(error(
                    mine.get(MAX_EXAMPLES).copied(),
                    joint,
                    format!("{} example poses; at most {MAX_EXAMPLES} per joint", mine.len()),
                ));
            }
            let first = mine.first().copied();
            if joint as usize >= skin.joints.len() {
                return Err(error(
                    first,
                    joint,
                    format!("joint {joint} is not in the skin ({} joints)", skin.joints.len()),
                ));
            }
            let parent = parent_joint(joint)
                .ok_or_else(|| error(first, joint, "the joint has no parent joint in the skin".into()))?;
            let children: Vec<u16> =
                (0..skin.joints.len() as u16).filter(|&c| parent_joint(c) == Some(joint)).collect();
            let [child] = children[..] else {
                return Err(error(
                    first,
                    joint,
                    format!(
                        "the joint has {} child joints; an example pose needs exactly one (the bone's direction)",
                        children.len()
                    ),
                ));
            };
            let grandparent = parent_joint(parent);
            let bind = [bind_world(parent, first)?, bind_world(joint, first)?, bind_world(child, first)?];
            // k's bind-pose local transform, split so that an example replaces its rotation.
            let local = bind[0].inverse() * bind[1];
            let (scale, _, translation) = local.to_scale_rotation_translation();
            let child_in_k = bind[1].inverse() * bind[2];

            let mut directions = vec![
                direction(&bind[0], &bind[1], &bind[2])
                    .ok_or_else(|| error(first, joint, "the bone from the joint to its child has no length".into()))?,
            ];
            let mut rotations = Vec::with_capacity(mine.len());
            let mut palettes = Vec::with_capacity(mine.len());
            for &i in &mine {
                let e = &examples[i];
                if let Err(length) = e.rotation.check_unit() {
                    return Err(error(
                        Some(i),
                        joint,
                        format!("the rotation is not a unit quaternion (length {length})"),
                    ));
                }
                if e.positions.len() != n || (!e.normals.is_empty() && e.normals.len() != n) {
                    return Err(error(
                        Some(i),
                        joint,
                        format!(
                            "the shape has {} positions and {} normals for {n} vertices",
                            e.positions.len(),
                            e.normals.len()
                        ),
                    ));
                }
                let rotation = e.rotation.normalize();
                let k = bind[0] * Mat4::from_scale_rotation_translation(scale, rotation, translation);
                let c = k * child_in_k;
                directions.push(
                    direction(&bind[0], &k, &c)
                        .ok_or_else(|| error(Some(i), joint, "the bone has no length in this pose".into()))?,
                );
                rotations.push(rotation);
                // The example pose's palette: k and its descendants carried by k's new rotation.
                let carry = k * bind[1].inverse();
                let palette: Vec<Mat4> = (0..skin.joints.len() as u16)
                    .map(|j| if j == joint || descends(j, joint, &parent_joint) { carry } else { Mat4::IDENTITY })
                    .collect();
                palettes.push(palette);
            }
            let sigma = sigmas.iter().find(|(j, _)| *j == joint).map_or(DEFAULT_SIGMA, |&(_, s)| s);
            if !(sigma.is_finite() && sigma > 1e-3) {
                return Err(error(None, joint, format!("σ {sigma} must be a positive number of radians")));
            }
            let lambda = solve_rbf(&directions, f64::from(sigma)).map_err(|(a, b, why)| {
                let name = |p: usize| {
                    if p == 0 { "the reference pose".to_owned() } else { format!("example {}", mine[p - 1]) }
                };
                error(mine.get(b.max(1) - 1).copied(), joint, format!("{} and {}: {why}", name(a), name(b)))
            })?;

            // The support and its offsets.
            let bone = rig.bones.len() as u16;
            for v in 0..n {
                if !in_support(&joints[v], &weights[v], parent, grandparent) {
                    continue;
                }
                if rig.vertex_slot[v] != NO_SLOT {
                    let other = rig.bones[rig.slot_bone[rig.vertex_slot[v] as usize] as usize].joint;
                    return Err(error(
                        first,
                        joint,
                        format!(
                            "joints {other} and {joint} share their parent joint {parent}; its vertices can follow only one of them"
                        ),
                    ));
                }
                rig.vertex_slot[v] = rig.offsets.len() as u32;
                rig.slot_bone.push(bone);
                let mut offsets = [[0.0; 3]; MAX_EXAMPLES];
                let mut normal_offsets = [[0.0; 3]; MAX_EXAMPLES];
                for (slot, &i) in mine.iter().enumerate() {
                    let e = &examples[i];
                    let normal = e.normals.get(v);
                    let (p, nn) = match e.space {
                        ExampleSpace::Rest => (e.positions[v], normal.copied()),
                        ExampleSpace::Posed => {
                            let mut table = vec![JointDq::default(); palettes[slot].len()];
                            DqPrepareJob { palette: &palettes[slot], out: &mut table }
                                .run()
                                .map_err(|x| error(Some(i), joint, x.to_string()))?;
                            let (p0, n0) = sjb_vertex_way(
                                Way::Unskin,
                                &palettes[slot],
                                &table,
                                plan,
                                v,
                                &joints[v],
                                &weights[v],
                                e.positions[v],
                                normal,
                            )
                            .map_err(|x| error(Some(i), joint, x.to_string()))?;
                            let base = Vec3::from(positions[v]);
                            let n0 = n0.map(|n0| {
                                let base = normals.get(v).map_or(Vec3::ZERO, |b| Vec3::from(*b));
                                (Vec3::from(n0).try_normalize().unwrap_or(base) - base).to_array()
                            });
                            ((Vec3::from(p0) - base).to_array(), n0)
                        }
                    };
                    if !p.iter().chain(nn.iter().flatten()).all(|x| x.is_finite()) {
                        return Err(error(Some(i), joint, format!("vertex {v}'s shape is not finite")));
                    }
                    offsets[slot] = p;
                    normal_offsets[slot] = nn.unwrap_or([0.0; 3]);
                }
                rig.offsets.push(offsets);
                rig.normal_offsets.push(normal_offsets);
            }
            rig.bones.push(SjbbeBone { joint, parent, child, sigma, rotations, directions, lambda, bind });
        }
        Ok(rig)
    }
}

/// Whether a vertex with `joints` and `weights` is in the support of a joint whose parent joint
/// is `parent` and grandparent `grandparent` (§5.3): influenced by the parent, not by the
/// grandparent. Supports of different joints are disjoint unless they share a parent.
pub fn in_support(joints: &[u16; 8], weights: &[f32; 8], parent: u16, grandparent: Option<u16>) -> bool {
    let influenced = |j: u16| joints.iter().zip(weights).any(|(&x, &w)| x == j && w > 0.0);
    influenced(parent) && !grandparent.is_some_and(influenced)
}

/// The parent and grandparent joints of skin joint `joint` (the joints its support is read
/// from, [`in_support`]); `None` when it has no parent joint.
pub fn support_joints(skin: &Skin, parents: &[Option<u32>], joint: u16) -> Option<(u16, Option<u16>)> {
    let parent_joint = |j: u16| -> Option<u16> {
        let node = *skin.joints.get(j as usize)?;
        let parent = parents.get(node as usize).copied().flatten()?;
        skin.joints.iter().position(|&n| n == parent).map(|p| p as u16)
    };
    let parent = parent_joint(joint)?;
    Some((parent, parent_joint(parent)))
}

/// Whether joint `j` descends from joint `ancestor`.
fn descends(j: u16, ancestor: u16, parent_joint: &impl Fn(u16) -> Option<u16>) -> bool {
    let mut at = j;
    // A skin's joints form a tree (the importer refuses cycles); the bound guards anyway.
    for _ in 0..u16::MAX {
        match parent_joint(at) {
            Some(p) if p == ancestor => return true,
            Some(p) => at = p,
            None => return false,
        }
    }
    false
}

/// The unit direction from `k`'s origin to `child`'s, in `parent`'s frame.
fn direction(parent: &Mat4, k: &Mat4, child: &Mat4) -> Option<[f64; 3]> {
    let d = parent.inverse().transform_vector3(child.w_axis.truncate() - k.w_axis.truncate());
    let d = d.as_dvec3();
    let length = d.length();
    (length > 1e-9 && length.is_finite()).then(|| (d / length).to_array())
}

/// Arc length between unit vectors `a` and `b` (`2 asin(|a − b| / 2)`: exact near zero).
fn arc(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    2.0 * (d / 2.0).min(1.0).asin()
}

/// Smallest arc between two poses of one bone that the interpolation tells apart (radians).
const MIN_ARC: f64 = 1e-3;

/// `Λ = (G⁻¹ F)ᵀ` for points `directions` (reference first) with `F` = 0 at the reference and
/// the identity at the examples. Errors name two points that are too close, or the pivot.
fn solve_rbf(directions: &[[f64; 3]], sigma: f64) -> Result<Vec<Vec<f64>>, (usize, usize, String)> {
    let m = directions.len();
    for a in 0..m {
        for b in a + 1..m {
            let r = arc(&directions[a], &directions[b]);
            if r < MIN_ARC {
                return Err((
                    a,
                    b,
                    format!(
                        "the bone points the same way ({:.3}° apart; a twist alone is SJB's, not an example's)",
                        r.to_degrees()
                    ),
                ));
            }
        }
    }
    let phi = |r: f64| (-(r / sigma).powi(2)).exp();
    // Gaussian elimination with partial pivoting on [G | F].
    let mut g: Vec<Vec<f64>> = (0..m)
        .map(|i| {
            let mut row: Vec<f64> = (0..m).map(|j| phi(arc(&directions[i], &directions[j]))).collect();
            row.extend((1..m).map(|p| if i == p { 1.0 } else { 0.0 }));
            row
        })
        .collect();
    for col in 0..m {
        let pivot = (col..m).max_by(|&a, &b| g[a][col].abs().total_cmp(&g[b][col].abs())).unwrap_or(col);
        if g[pivot][col].abs() < 1e-12 {
            return Err((col.saturating_sub(1), col, "the interpolation matrix is singular".into()));
        }
        g.swap(col, pivot);
        for row in 0..m {
            if row != col {
                let f = g[row][col] / g[col][col];
                if f != 0.0 {
                    for k in col..g[row].len() {
                        g[row][k] -= f * g[col][k];
                    }
                }
            }
        }
    }
    // Column p of the solution is example p's weights over the points.
    let lambda: Vec<Vec<f64>> = (0..m - 1).map(|p| (0..m).map(|i| g[i][m + p] / g[i][i]).collect()).collect();
    if lambda.iter().flatten().any(|x| !x.is_finite() || x.abs() > 1e8) {
        return Err((
            0,
            m - 1,
            format!("the interpolation is ill-conditioned at σ = {sigma}; spread the examples or lower σ"),
        ));
    }
    Ok(lambda)
}

/// Per frame: each bone's example weights α from the current palette.
#[derive(Debug)]
pub struct SjbbeAlphaJob<'a> {
    /// The rig.
    pub rig: &'a SjbbeRig,
    /// Skinning matrices ([`super::skin::PaletteJob`]).
    pub palette: &'a [Mat4],
    /// α per bone of the rig (zero past each bone's examples), at least `rig.bones.len()`.
    pub out: &'a mut [[f32; MAX_EXAMPLES]],
}

impl SjbbeAlphaJob<'_> {
    /// Checks the bones' joints against the palette and the output's length.
    pub fn validate(&self) -> Result<(), JobError> {
        check_len("out", self.rig.bones.len(), self.out.len())?;
        for b in &self.rig.bones {
            for j in [b.parent, b.joint, b.child] {
                check_index("bone joint", j as usize, self.palette.len())?;
            }
        }
        Ok(())
    }

    /// Validates, then computes α.
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        for (b, out) in self.rig.bones.iter().zip(self.out.iter_mut()) {
            let world = |slot: usize, j: u16| self.palette[j as usize] * b.bind[slot];
            let now = direction(&world(0, b.parent), &world(1, b.joint), &world(2, b.child));
            *out = [0.0; MAX_EXAMPLES];
            let Some(now) = now else { continue };
            let sigma = f64::from(b.sigma);
            let mut phi = [0.0f64; MAX_EXAMPLES + 1];
            for (p, d) in phi.iter_mut().zip(&b.directions) {
                *p = (-(arc(&now, d) / sigma).powi(2)).exp();
            }
            for (alpha, row) in out.iter_mut().zip(&b.lambda) {
                *alpha = row.iter().zip(&phi).map(|(l, p)| l * p).sum::<f64>() as f32;
            }
        }
        Ok(())
    }
}

/// SJBBE on the CPU: `v' = SJB(v + Σₚ αₚ offsetₚ)`, normals likewise and renormalized.
#[derive(Debug)]
pub struct SjbbeJob<'a> {
    /// Bind-pose (morphed) positions.
    pub positions: &'a [[f32; 3]],
    /// Bind-pose normals; empty to skip normals.
    pub normals: &'a [[f32; 3]],
    /// Joint indices per vertex.
    pub joints: &'a [[u16; 8]],
    /// Weights per vertex.
    pub weights: &'a [[f32; 8]],
    /// Skinning matrices.
    pub palette: &'a [Mat4],
    /// The palette prepared for dual quaternions.
    pub joints_dq: &'a [JointDq],
    /// The SJB plan of this primitive.
    pub plan: &'a SjbPlan,
    /// The rig of this primitive.
    pub rig: &'a SjbbeRig,
    /// α per bone ([`SjbbeAlphaJob`]).
    pub alphas: &'a [[f32; MAX_EXAMPLES]],
    /// Output positions, at least `positions.len()`.
    pub out_positions: &'a mut [[f32; 3]],
    /// Output normals, at least `normals.len()`.
    pub out_normals: &'a mut [[f32; 3]],
}

impl SjbbeJob<'_> {
    /// Checks lengths, the plan and the rig against the primitive.
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
        check_eq("rig vertices", self.positions.len(), self.rig.vertex_slot.len())?;
        check_len("alphas", self.rig.bones.len(), self.alphas.len())?;
        check_eq("rig offsets", self.rig.slot_bone.len(), self.rig.offsets.len())?;
        check_eq("rig normal offsets", self.rig.slot_bone.len(), self.rig.normal_offsets.len())?;
        for &s in &self.rig.vertex_slot {
            if s != NO_SLOT {
                check_index("vertex slot", s as usize, self.rig.slot_bone.len())?;
            }
        }
        for &b in &self.rig.slot_bone {
            check_index("slot bone", b as usize, self.rig.bones.len())?;
        }
        Ok(())
    }

    /// Validates, then deforms every vertex.
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        for v in 0..self.positions.len() {
            let mut p = Vec3::from(self.positions[v]);
            let mut n = self.normals.get(v).map(|n| Vec3::from(*n));
            let slot = self.rig.vertex_slot[v];
            if slot != NO_SLOT {
                let s = slot as usize;
                let alpha = &self.alphas[self.rig.slot_bone[s] as usize];
                for (e, &a) in alpha.iter().enumerate() {
                    if a != 0.0 {
                        p += Vec3::from(self.rig.offsets[s][e]) * a;
                        n = n.map(|n| n + Vec3::from(self.rig.normal_offsets[s][e]) * a);
                    }
                }
            }
            let normal = n.map(|n| n.to_array());
            let (p, n) = sjb_vertex_way(
                Way::Skin,
                self.palette,
                self.joints_dq,
                self.plan,
                v,
                &self.joints[v],
                &self.weights[v],
                p.to_array(),
                normal.as_ref(),
            )?;
            self.out_positions[v] = p;
            if let (Some(out), Some(n)) = (self.out_normals.get_mut(v), n) {
                *out = n;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::super::sjb::SjbJob;
    use super::*;
    use std::f32::consts::{FRAC_PI_2, PI};

    /// A chain along X: joints 0..4 at x = 0, 1, 2, 3 (node j = joint j, each the parent of the
    /// next), plus joint 4 at x = 2 on joint 1 with joint 5 at x = 3 on it when `branch`.
    pub(crate) fn skin(branch: bool) -> (Skin, Vec<Option<u32>>) {
        let mut xs = vec![0.0, 1.0, 2.0, 3.0];
        let mut parents = vec![None, Some(0), Some(1), Some(2)];
        if branch {
            xs.extend([2.0, 3.0]);
            parents.extend([Some(1), Some(4)]);
        }
        let skin = Skin {
            name: None,
            joints: (0..xs.len() as u32).collect(),
            inverse_bind: xs.iter().map(|&x| Mat4::from_translation(Vec3::new(-x, 0.0, 0.0))).collect(),
            skeleton: None,
        };
        (skin, parents)
    }

    /// A tube of radius 0.2 from x = 0 to 3, rings every 0.125, blended half and half at the
    /// joints x = 1 and x = 2.
    pub(crate) struct Tube {
        pub(crate) positions: Vec<[f32; 3]>,
        pub(crate) normals: Vec<[f32; 3]>,
        pub(crate) joints: Vec<[u16; 8]>,
        pub(crate) weights: Vec<[f32; 8]>,
    }

    pub(crate) fn tube() -> Tube {
        let mut t = Tube { positions: Vec::new(), normals: Vec::new(), joints: Vec::new(), weights: Vec::new() };
        for ring in 0..=24 {
            let x = ring as f32 * 0.125;
            let (js, ws): ([u16; 2], [f32; 2]) = match ring {
                0..8 => ([0, 0], [1.0, 0.0]),
                8 => ([0, 1], [0.5, 0.5]),
                9..16 => ([1, 0], [1.0, 0.0]),
                16 => ([1, 2], [0.5, 0.5]),
                _ => ([2, 0], [1.0, 0.0]),
            };
            for k in 0..8 {
                let (s, c) = (k as f32 / 8.0 * 2.0 * PI).sin_cos();
                t.positions.push([x, 0.2 * c, 0.2 * s]);
                t.normals.push([0.0, c, s]);
                t.joints.push([js[0], js[1], 0, 0, 0, 0, 0, 0]);
                t.weights.push([ws[0], ws[1], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
            }
        }
        t
    }

    /// The palette with joint 2 (and 3) turned by `rotation` about joint 2's centre.
    pub(crate) fn palette(rotation: Quat, joints: usize) -> Vec<Mat4> {
        let carry = Mat4::from_translation(Vec3::new(2.0, 0.0, 0.0))
            * Mat4::from_quat(rotation)
            * Mat4::from_translation(Vec3::new(-2.0, 0.0, 0.0));
        (0..joints).map(|j| if j == 2 || j == 3 { carry } else { Mat4::IDENTITY }).collect()
    }

    pub(crate) fn sjb(t: &Tube, plan: &SjbPlan, palette: &[Mat4]) -> Vec<[f32; 3]> {
        let mut table = vec![JointDq::default(); palette.len()];
        DqPrepareJob { palette, out: &mut table }.run().expect("sized");
        let (mut out, mut out_n) = (vec![[0.0; 3]; t.positions.len()], vec![[0.0; 3]; t.normals.len()]);
        SjbJob {
            positions: &t.positions,
            normals: &t.normals,
            joints: &t.joints,
            weights: &t.weights,
            palette,
            joints_dq: &table,
            plan,
            out_positions: &mut out,
            out_normals: &mut out_n,
        }
        .run()
        .expect("skins");
        out
    }

    fn sjbbe(t: &Tube, plan: &SjbPlan, rig: &SjbbeRig, palette: &[Mat4]) -> (Vec<[f32; 3]>, Vec<[f32; MAX_EXAMPLES]>) {
        let mut alphas = vec![[0.0; MAX_EXAMPLES]; rig.bones.len()];
        SjbbeAlphaJob { rig, palette, out: &mut alphas }.run().expect("alphas");
        let mut table = vec![JointDq::default(); palette.len()];
        DqPrepareJob { palette, out: &mut table }.run().expect("sized");
        let (mut out, mut out_n) = (vec![[0.0; 3]; t.positions.len()], vec![[0.0; 3]; t.normals.len()]);
        SjbbeJob {
            positions: &t.positions,
            normals: &t.normals,
            joints: &t.joints,
            weights: &t.weights,
            palette,
            joints_dq: &table,
            plan,
            rig,
            alphas: &alphas,
            out_positions: &mut out,
            out_normals: &mut out_n,
        }
        .run()
        .expect("skins");
        (out, alphas)
    }

    fn max_distance(a: &[[f32; 3]], b: &[[f32; 3]]) -> f32 {
        a.iter().zip(b).map(|(a, b)| Vec3::from(*a).distance(Vec3::from(*b))).fold(0.0, f32::max)
    }

    /// The tube's bounding-box diagonal.
    const DIAGONAL: f32 = 3.026_549;

    /// Example: joint 2 bent by `degrees` about Z, its support (the upper segment past the
    /// shoulder, x in 1.125..=2) bulged by `bulge` along its ring normal, as seen in that pose.
    fn posed_example(t: &Tube, plan: &SjbPlan, degrees: f32, bulge: f32) -> ExamplePose {
        let rotation = Quat::from_rotation_z(degrees.to_radians());
        let mut positions = sjb(t, plan, &palette(rotation, 4));
        for (p, (bind, n)) in positions.iter_mut().zip(t.positions.iter().zip(&t.normals)) {
            if bind[0] > 1.0 && bind[0] <= 2.0 {
                // The ring normals of the support keep their direction at x ≤ 2 (joint 1 is still).
                *p = (Vec3::from(*p) + Vec3::from(*n) * bulge).to_array();
            }
        }
        ExamplePose { joint: 2, rotation, positions, normals: Vec::new(), space: ExampleSpace::Posed }
    }

    fn input<'a>(skin: &'a Skin, parents: &'a [Option<u32>], t: &'a Tube, plan: &'a SjbPlan) -> SjbbeInput<'a> {
        SjbbeInput {
            skin,
            parents,
            positions: &t.positions,
            normals: &t.normals,
            joints: &t.joints,
            weights: &t.weights,
            plan,
        }
    }

    #[test]
    fn the_support_is_the_parents_vertices_without_the_grandparents() {
        let (skin, parents) = skin(false);
        let t = tube();
        let plan = SjbPlan::build(&skin, &parents, &t.joints, &t.weights);
        let rig = SjbbeRig::build(input(&skin, &parents, &t, &plan), &[posed_example(&t, &plan, 90.0, 0.05)], &[])
            .expect("builds");
        assert_eq!((rig.bones[0].joint, rig.bones[0].parent, rig.bones[0].child), (2, 1, 3));
        for (v, p) in t.positions.iter().enumerate() {
            let inside = p[0] > 1.0 && p[0] <= 2.0;
            assert_eq!(rig.vertex_slot[v] != NO_SLOT, inside, "vertex {v} at x = {}", p[0]);
        }
        assert_eq!(rig.offsets.len(), 8 * 8);
    }

    #[test]
    fn an_example_pose_is_reproduced_and_the_reference_pose_is_sjb() {
        let (skin, parents) = skin(false);
        let t = tube();
        let plan = SjbPlan::build(&skin, &parents, &t.joints, &t.weights);
        let examples = [posed_example(&t, &plan, 90.0, 0.05), posed_example(&t, &plan, -60.0, -0.03)];
        let rig = SjbbeRig::build(input(&skin, &parents, &t, &plan), &examples, &[]).expect("builds");
        for (i, e) in examples.iter().enumerate() {
            let (out, alphas) = sjbbe(&t, &plan, &rig, &palette(e.rotation, 4));
            let mut expected = [0.0; MAX_EXAMPLES];
            expected[i] = 1.0;
            assert!(
                alphas[0].iter().zip(expected).all(|(a, e)| (a - e).abs() < 1e-5),
                "example {i}: α {:?}",
                alphas[0]
            );
            let error = max_distance(&out, &e.positions) / DIAGONAL;
            assert!(error < 1e-5, "example {i} reproduced within {error:e} of the diagonal");
        }
        let identity = palette(Quat::IDENTITY, 4);
        let (out, alphas) = sjbbe(&t, &plan, &rig, &identity);
        assert!(alphas[0].iter().all(|a| a.abs() < 1e-6), "α at the reference {:?}", alphas[0]);
        let error = max_distance(&out, &sjb(&t, &plan, &identity)) / DIAGONAL;
        assert!(error < 1e-7, "the reference pose differs from SJB by {error:e} of the diagonal");
        // Half way: a part of the bulge, and only inside the support.
        let (half, alphas) = sjbbe(&t, &plan, &rig, &palette(Quat::from_rotation_z(45f32.to_radians()), 4));
        assert!(alphas[0][0] > 0.2 && alphas[0][0] < 0.9, "α half way {:?}", alphas[0]);
        let plain = sjb(&t, &plan, &palette(Quat::from_rotation_z(45f32.to_radians()), 4));
        for (v, (a, b)) in half.iter().zip(&plain).enumerate() {
            let moved = Vec3::from(*a).distance(Vec3::from(*b));
            assert_eq!(moved > 1e-4, rig.vertex_slot[v] != NO_SLOT, "vertex {v} moved {moved}");
        }
    }

    #[test]
    fn rest_offsets_are_added_before_sjb() {
        let (skin, parents) = skin(false);
        let t = tube();
        let plan = SjbPlan::build(&skin, &parents, &t.joints, &t.weights);
        let rotation = Quat::from_rotation_z(FRAC_PI_2);
        let offsets: Vec<[f32; 3]> = t.normals.iter().map(|n| [0.0, n[1] * 0.04, n[2] * 0.04]).collect();
        let example = ExamplePose {
            joint: 2,
            rotation,
            positions: offsets.clone(),
            normals: Vec::new(),
            space: ExampleSpace::Rest,
        };
        let rig = SjbbeRig::build(input(&skin, &parents, &t, &plan), &[example], &[]).expect("builds");
        let (out, _) = sjbbe(&t, &plan, &rig, &palette(rotation, 4));
        let mut moved = Tube { positions: t.positions.clone(), ..tube() };
        for (v, p) in moved.positions.iter_mut().enumerate() {
            if rig.vertex_slot[v] != NO_SLOT {
                *p = (Vec3::from(*p) + Vec3::from(offsets[v])).to_array();
            }
        }
        let error = max_distance(&out, &sjb(&moved, &plan, &palette(rotation, 4))) / DIAGONAL;
        assert!(error < 1e-6, "{error:e}");
    }

    #[test]
    fn the_examples_weights_change_continuously_along_random_paths() {
        let (skin, parents) = skin(false);
        let t = tube();
        let plan = SjbPlan::build(&skin, &parents, &t.joints, &t.weights);
        let examples = [posed_example(&t, &plan, 90.0, 0.05), posed_example(&t, &plan, -60.0, -0.03)];
        let rig = SjbbeRig::build(input(&skin, &parents, &t, &plan), &examples, &[]).expect("builds");
        // The examples' part of the deformation (SJBBE − SJB) moves by at most 1e-3 of the
        // diagonal between poses 0.5° apart.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut random = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f32 / (1u64 << 53) as f32 * 2.0 - 1.0
        };
        for _ in 0..4 {
            let axis = Vec3::new(random(), random(), random()).try_normalize().unwrap_or(Vec3::Z);
            let mut rotation = Quat::IDENTITY;
            let mut last: Option<Vec<Vec3>> = None;
            for _ in 0..360 {
                let palette = palette(rotation, 4);
                let (out, _) = sjbbe(&t, &plan, &rig, &palette);
                let extra: Vec<Vec3> =
                    out.iter().zip(sjb(&t, &plan, &palette)).map(|(a, b)| Vec3::from(*a) - Vec3::from(b)).collect();
                if let Some(last) = &last {
                    let step = extra.iter().zip(last).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max) / DIAGONAL;
                    assert!(step <= 1e-3, "the examples' part jumped by {step:e} of the diagonal");
                }
                last = Some(extra);
                rotation = Quat::from_axis_angle(axis, 0.5f32.to_radians()) * rotation;
            }
        }
    }

    #[test]
    fn broken_examples_are_refused_naming_the_example() {
        let (skin, parents) = skin(false);
        let t = tube();
        let plan = SjbPlan::build(&skin, &parents, &t.joints, &t.weights);
        let good = posed_example(&t, &plan, 90.0, 0.05);
        let refuse = |examples: &[ExamplePose]| {
            SjbbeRig::build(input(&skin, &parents, &t, &plan), examples, &[]).expect_err("refused")
        };
        let with = |f: &dyn Fn(&mut ExamplePose)| {
            let mut e = good.clone();
            f(&mut e);
            e
        };
        let e = refuse(&[with(&|e| e.joint = 9)]);
        assert!(e.message.contains("not in the skin"), "{e}");
        let e = refuse(&[with(&|e| e.joint = 0)]);
        assert!(e.message.contains("no parent joint"), "{e}");
        let e = refuse(&[with(&|e| e.joint = 3)]);
        assert!(e.message.contains("0 child joints"), "{e}");
        let e = refuse(&[good.clone(), with(&|e| e.rotation = Quat::from_xyzw(0.0, 0.0, 0.5, 0.5))]);
        assert_eq!(e.example, Some(1), "{e}");
        assert!(e.message.contains("unit quaternion"), "{e}");
        let e = refuse(&[with(&|e| e.positions.truncate(3))]);
        assert!(e.message.contains("for 200 vertices"), "{e}");
        let five: Vec<ExamplePose> = (0..5)
            .map(|i| with(&|e| e.rotation = Quat::from_rotation_z((20.0 + 30.0 * i as f32).to_radians())))
            .collect();
        let e = refuse(&five);
        assert_eq!(e.example, Some(4), "{e}");
        // The same bend twice, and a twist alone (the bone keeps its direction).
        let e = refuse(&[good.clone(), good.clone()]);
        assert!(e.message.starts_with("example 0 and example 1"), "{e}");
        let e = refuse(&[with(&|e| e.rotation = Quat::from_rotation_x(1.0))]);
        assert!(e.message.starts_with("the reference pose and example 0"), "{e}");
        // Two joints under one parent would share its vertices.
        let (branched, branched_parents) = super::tests::skin(true);
        let mut joints = t.joints.clone();
        joints[0] = [4, 0, 0, 0, 0, 0, 0, 0];
        let branched_plan = SjbPlan::build(&branched, &branched_parents, &joints, &t.weights);
        let mut other = good.clone();
        other.joint = 4;
        let e = SjbbeRig::build(
            SjbbeInput {
                skin: &branched,
                parents: &branched_parents,
                joints: &joints,
                plan: &branched_plan,
                ..input(&skin, &parents, &t, &plan)
            },
            &[good.clone(), other],
            &[],
        )
        .expect_err("shared support");
        assert!(e.message.contains("share their parent joint 1"), "{e}");
    }
}
