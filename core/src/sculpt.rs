//! Making an example pose by sculpting (seed 001 §5.3, as an artist would in the viewer).
//!
//! An example pose differs from the reference (bind) pose by one joint's rotation. The viewer
//! shows the skin in that pose ([`example_pose_locals`]), the artist moves the vertices of the
//! joint's support with brushes ([`Sculpt::dab`]: inflate, deflate, smooth, grab), and
//! [`Sculpt::finish`] takes the sculpted shape back to the reference pose through the inverse
//! of SJB (§5.3) as offsets the sidecar saves inline. The brushes move welded vertices (those
//! of a primitive that share a bind position across a UV seam) together, so its seams do not
//! open (a seam between two primitives of the mesh is not welded).
//!
//! Nothing here runs per frame: a dab is one user gesture.

use std::collections::HashMap;

use crate::asset::{Asset, Topology};
use crate::examples::ExampleShape;
use crate::instance::Instance;
use crate::job::sjbbe::{ExamplePose, ExampleSpace, SjbbeInput, SjbbeRig, in_support, support_joints};
use crate::math::{Mat4, Quat, QuatExt, Transform, Vec3};
use crate::pose::Pose;

/// The local transforms that put `pose`'s skeleton in the example pose of joint node `node`:
/// every joint of skin `skin` (the skin of the mesh being shaped) at its bind pose placed by
/// `placement` (world =
/// `placement` · inverse bind matrix⁻¹; the identity gives the palettes of
/// [`crate::job::sjbbe`]'s example poses, the world of the mesh's node shows the skin where
/// the model stands), `node` turned to `rotation` (its bind translation and scale kept). Nodes
/// outside the skin keep `pose`'s transforms.
///
/// # Errors
/// No skin `skin` or `node` not among its joints, a rotation that is not a unit quaternion,
/// or an inverse bind matrix that cannot be inverted or decomposed.
pub fn example_pose_locals(
    asset: &Asset,
    pose: &Pose,
    skin: usize,
    node: u32,
    rotation: Quat,
    placement: Mat4,
) -> Result<Vec<(u32, Transform)>, String> {
    let name = |n: u32| asset.nodes.get(n as usize).and_then(|x| x.name.clone()).unwrap_or_else(|| format!("node {n}"));
    rotation.check_unit().map_err(|length| format!("the rotation is not a unit quaternion (length {length})"))?;
    let skin = asset
        .skins
        .get(skin)
        .filter(|s| s.joints.contains(&node))
        .ok_or_else(|| format!("{} is not a joint of skin {skin}", name(node)))?;
    let n = asset.nodes.len();
    if pose.locals.len() != n {
        return Err(format!("the pose has {} nodes, the model {n}", pose.locals.len()));
    }
    // Wanted world matrices: the joints' from their inverse binds, the rest from the pose.
    let mut world: Vec<Option<Mat4>> = vec![None; n];
    for (&joint, ibm) in skin.joints.iter().zip(&skin.inverse_bind) {
        let det = ibm.determinant();
        if !(det.is_finite() && det.abs() > 1e-12) {
            return Err(format!("{}: its inverse bind matrix is not invertible", name(joint)));
        }
        if let Some(w) = world.get_mut(joint as usize) {
            *w = Some(placement * ibm.inverse());
        }
    }
    let resolve = |start: u32, world: &mut Vec<Option<Mat4>>| -> Mat4 {
        // Up to the first node whose world is known (or the root), then down again.
        let mut chain = Vec::new();
        let mut at = Some(start);
        while let Some(i) = at {
            if world.get(i as usize).copied().flatten().is_some() || chain.len() > n {
                break;
            }
            chain.push(i);
            at = asset.nodes.get(i as usize).and_then(|x| x.parent);
        }
        let mut m = at.and_then(|i| world.get(i as usize).copied().flatten()).unwrap_or(Mat4::IDENTITY);
        for &i in chain.iter().rev() {
            m *= pose.locals.get(i as usize).map_or(Mat4::IDENTITY, Transform::to_mat4);
            if let Some(w) = world.get_mut(i as usize) {
                *w = Some(m);
            }
        }
        m
    };
    let mut out = Vec::with_capacity(skin.joints.len());
    for &joint in &skin.joints {
        let own = world.get(joint as usize).copied().flatten().unwrap_or(Mat4::IDENTITY);
        let parent = match asset.nodes.get(joint as usize).and_then(|x| x.parent) {
            Some(p) => resolve(p, &mut world),
            None => Mat4::IDENTITY,
        };
        let mut local = Transform::from_mat4(&(parent.inverse() * own))
            .ok_or_else(|| format!("{}: its bind pose has no local transform", name(joint)))?;
        if joint == node {
            local.rotation = rotation.normalize();
        }
        out.push((joint, local));
    }
    Ok(out)
}

/// A brush of the sculpt.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Brush {
    /// Moves the surface out along its normal.
    Inflate,
    /// Moves the surface in against its normal.
    Deflate,
    /// Moves each vertex towards the mean of its neighbours.
    Smooth,
    /// Moves the vertices with the pointer.
    Grab,
}

impl Brush {
    /// Every brush, in menu order.
    pub const ALL: [Brush; 4] = [Brush::Inflate, Brush::Deflate, Brush::Smooth, Brush::Grab];

    /// The name the page uses.
    pub fn name(self) -> &'static str {
        match self {
            Brush::Inflate => "inflate",
            Brush::Deflate => "deflate",
            Brush::Smooth => "smooth",
            Brush::Grab => "grab",
        }
    }
}

/// How far one inflate or deflate dab at strength 1 moves the brush's centre, as a fraction
/// of its radius.
const INFLATE_STEP: f32 = 0.08;

/// One dab of a brush.
#[derive(Clone, Copy, Debug)]
pub struct Dab {
    /// The brush.
    pub brush: Brush,
    /// Where it touches the surface (model space).
    pub center: Vec3,
    /// Its radius (model units); the falloff is `(1 − (d/r)²)²`.
    pub radius: f32,
    /// 0..1: how much of a step one dab takes.
    pub strength: f32,
    /// For [`Brush::Grab`]: how far the pointer moved (model space).
    pub drag: Vec3,
}

/// The sculpt of one primitive.
#[derive(Clone, Debug)]
pub struct SculptPrimitive {
    /// The primitive's index in its mesh.
    pub primitive: usize,
    /// The sculpted positions (model space, in the example pose).
    pub positions: Vec<[f32; 3]>,
    /// Their normals.
    pub normals: Vec<[f32; 3]>,
    /// The vertices the brushes may move (the joint's support).
    pub support: Vec<u32>,
    /// The normals as shown when the sculpt began.
    base_normals: Vec<[f32; 3]>,
    /// The normals computed from the faces when the sculpt began.
    base_faces: Vec<[f32; 3]>,
    /// Per vertex: its weld group (vertices sharing a bind position), `u32::MAX` off the support.
    group_of: Vec<u32>,
    /// Each group's vertices.
    groups: Vec<Vec<u32>>,
    /// Each group's neighbouring groups (across the primitive's edges).
    neighbours: Vec<Vec<u32>>,
    /// Each group's neighbouring vertices off the support (they stay; smoothing averages them in).
    fixed: Vec<Vec<u32>>,
    /// Triangles, as vertex indices.
    triangles: Vec<[u32; 3]>,
}

/// An example pose being sculpted.
#[derive(Clone, Debug)]
pub struct Sculpt {
    /// The joint's node.
    pub joint: u32,
    /// Its rotation in the example.
    pub rotation: Quat,
    /// The node that draws the sculpted mesh.
    pub node: u32,
    /// The sculpted mesh.
    pub mesh: u32,
    /// Its skin's index of `joint`.
    skin_joint: u16,
    /// Where the example pose is shown: the joints' worlds are this times their bind pose.
    placement: Mat4,
    /// Per primitive of the mesh that the joint's support reaches.
    pub primitives: Vec<SculptPrimitive>,
}

impl Sculpt {
    /// Starts a sculpt of joint node `joint` at `rotation` on the mesh node `node` of `asset`,
    /// from the shape `instance` draws (already in the example pose placed by `placement`,
    /// [`example_pose_locals`]): every primitive is deformed on the CPU once.
    ///
    /// # Errors
    /// `node` has no skinned mesh with `joint` in its skin, the joint has no parent joint, or
    /// the support is empty.
    pub fn start(
        asset: &Asset,
        instance: &mut Instance,
        node: u32,
        joint: u32,
        rotation: Quat,
        placement: Mat4,
    ) -> Result<Self, String> {
        let det = placement.determinant();
        if !(placement.is_finite() && det.abs() > 1e-12) {
            return Err("the placement of the example pose cannot be inverted".into());
        }
        let n = asset.nodes.get(node as usize).ok_or_else(|| format!("no node {node}"))?;
        let (Some(mesh), Some(skin)) = (n.mesh, n.skin) else {
            return Err(format!("node {node} draws no skinned mesh"));
        };
        let skin = asset.skins.get(skin as usize).ok_or_else(|| format!("no skin {skin}"))?;
        let skin_joint = skin.joints.iter().position(|&j| j == joint).ok_or("the joint is not in the mesh's skin")?;
        let parents: Vec<Option<u32>> = asset.nodes.iter().map(|x| x.parent).collect();
        let (parent, grandparent) = support_joints(skin, &parents, skin_joint as u16)
            .ok_or("the joint has no parent joint: an example pose shapes the vertices around a joint with a parent")?;
        let m = asset.meshes.get(mesh as usize).ok_or_else(|| format!("no mesh {mesh}"))?;
        let mut primitives = Vec::new();
        for (p, prim) in m.primitives.iter().enumerate() {
            if !prim.is_skinned() || prim.topology != Topology::Triangles {
                continue;
            }
            let support: Vec<u32> = (0..prim.positions.len())
                .filter(|&v| in_support(&prim.joints[v], &prim.weights[v], parent, grandparent))
                .map(|v| v as u32)
                .collect();
            if support.is_empty() {
                continue;
            }
            let (mut positions, mut normals) = (Vec::new(), Vec::new());
            instance.deform_primitive(asset, node, p, &mut positions, &mut normals).map_err(|e| e.to_string())?;
            if normals.len() != positions.len() {
                normals = vec![[0.0; 3]; positions.len()];
            }
            let triangles = triangles(prim.indices.as_slice(), positions.len());
            // Weld groups: support vertices with the same bind position move together.
            let mut group_of = vec![u32::MAX; positions.len()];
            let mut groups: Vec<Vec<u32>> = Vec::new();
            let mut by_position: HashMap<[u32; 3], u32> = HashMap::new();
            for &v in &support {
                let key = prim.positions[v as usize].map(f32::to_bits);
                let g = *by_position.entry(key).or_insert_with(|| {
                    groups.push(Vec::new());
                    groups.len() as u32 - 1
                });
                group_of[v as usize] = g;
                groups[g as usize].push(v);
            }
            let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); groups.len()];
            let mut fixed: Vec<Vec<u32>> = vec![Vec::new(); groups.len()];
            for t in &triangles {
                for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0]), (t[1], t[0]), (t[2], t[1]), (t[0], t[2])] {
                    let (ga, gb) = (group_of[a as usize], group_of[b as usize]);
                    if ga == u32::MAX {
                        continue;
                    }
                    if gb == u32::MAX {
                        if !fixed[ga as usize].contains(&b) {
                            fixed[ga as usize].push(b);
                        }
                    } else if ga != gb && !neighbours[ga as usize].contains(&gb) {
                        neighbours[ga as usize].push(gb);
                    }
                }
            }
            let mut s = SculptPrimitive {
                primitive: p,
                base_normals: normals.clone(),
                base_faces: Vec::new(),
                positions,
                normals,
                support,
                group_of,
                groups,
                neighbours,
                fixed,
                triangles,
            };
            s.base_faces = s.face_normals();
            if prim.normals.is_empty() {
                // Without normals of its own the surface's are the faces'.
                s.normals.clone_from(&s.base_faces);
                s.base_normals.clone_from(&s.base_faces);
            }
            primitives.push(s);
        }
        if primitives.is_empty() {
            return Err("the joint's support is empty: no vertex of the mesh follows its parent alone".into());
        }
        Ok(Sculpt { joint, rotation, node, mesh, skin_joint: skin_joint as u16, placement, primitives })
    }

    /// The nearest point where the ray from `origin` along `direction` meets the sculpted
    /// surface (any of its triangles, support or not).
    pub fn pick(&self, origin: Vec3, direction: Vec3) -> Option<Vec3> {
        let mut best: Option<f32> = None;
        for s in &self.primitives {
            for t in &s.triangles {
                let [a, b, c] = t.map(|v| Vec3::from(s.positions[v as usize]));
                if let Some(d) = ray_triangle(origin, direction, a, b, c)
                    && best.is_none_or(|b| d < b)
                {
                    best = Some(d);
                }
            }
        }
        best.map(|d| origin + direction * d)
    }

    /// Applies one dab to the support's vertices; returns how many moved.
    pub fn dab(&mut self, dab: &Dab) -> usize {
        let Dab { brush, center, radius, strength, drag } = *dab;
        if !(radius.is_finite() && radius > 0.0 && strength.is_finite() && center.is_finite() && drag.is_finite()) {
            return 0;
        }
        let strength = strength.clamp(0.0, 1.0);
        let mut moved = 0;
        for s in &mut self.primitives {
            let at = |g: &Vec<u32>, positions: &[[f32; 3]]| Vec3::from(positions[g[0] as usize]);
            let deltas: Vec<(usize, Vec3)> = (s.groups.iter().enumerate())
                .filter_map(|(g, members)| {
                    let p = at(members, &s.positions);
                    let d = (p - center).length();
                    if d >= radius {
                        return None;
                    }
                    let falloff = (1.0 - (d / radius).powi(2)).powi(2);
                    let normal =
                        || members.iter().map(|&v| Vec3::from(s.normals[v as usize])).sum::<Vec3>().normalize_or_zero();
                    let delta = match brush {
                        Brush::Inflate => normal() * (INFLATE_STEP * radius * strength * falloff),
                        Brush::Deflate => normal() * (-INFLATE_STEP * radius * strength * falloff),
                        Brush::Smooth => {
                            // Neighbours on the support and the fixed ones around it (the edge stays put).
                            let (around, fixed) = (&s.neighbours[g], &s.fixed[g]);
                            let count = around.len() + fixed.len();
                            if count == 0 {
                                return None;
                            }
                            let sum = around.iter().map(|&h| at(&s.groups[h as usize], &s.positions)).sum::<Vec3>()
                                + fixed.iter().map(|&v| Vec3::from(s.positions[v as usize])).sum::<Vec3>();
                            (sum / count as f32 - p) * (strength * falloff)
                        }
                        Brush::Grab => drag * falloff,
                    };
                    (delta != Vec3::ZERO).then_some((g, delta))
                })
                .collect();
            for &(g, delta) in &deltas {
                for &v in &s.groups[g] {
                    let p = &mut s.positions[v as usize];
                    *p = (Vec3::from(*p) + delta).to_array();
                }
            }
            moved += deltas.iter().map(|&(g, _)| s.groups[g].len()).sum::<usize>();
            if !deltas.is_empty() {
                s.update_normals();
            }
        }
        moved
    }

    /// The sculpted shape as an example's offsets in the reference pose (§5.3: each support
    /// vertex taken back through the inverse of SJB in the example pose), per vertex of the
    /// mesh, its primitives one after another; zero off the support.
    ///
    /// # Errors
    /// What [`SjbbeRig::build`] refuses: the joint without exactly one child joint, a rotation
    /// that leaves the bone where it is at rest, a shape that is not finite.
    pub fn finish(&self, asset: &Asset) -> Result<ExampleShape, String> {
        let mesh = asset.meshes.get(self.mesh as usize).ok_or("the mesh is gone")?;
        let n = asset.nodes.get(self.node as usize).ok_or("the node is gone")?;
        let skin = n.skin.and_then(|s| asset.skins.get(s as usize)).ok_or("the mesh is not skinned")?;
        let parents: Vec<Option<u32>> = asset.nodes.iter().map(|x| x.parent).collect();
        let mut instance = Instance::new(asset);
        let total: usize = mesh.primitives.iter().map(|p| p.positions.len()).sum();
        let (mut positions, mut normals) = (vec![[0.0; 3]; total], vec![[0.0; 3]; total]);
        // Back from where the pose was shown to the skin's bind space (normals by the transpose
        // of the placement's linear part, the inverse of their inverse-transpose).
        let back = self.placement.inverse();
        let linear = glam::Mat3::from_mat4(self.placement).transpose();
        let mut first = 0;
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(s) = self.primitives.iter().find(|s| s.primitive == p) {
                let bind_positions: Vec<[f32; 3]> =
                    s.positions.iter().map(|x| back.transform_point3(Vec3::from(*x)).to_array()).collect();
                let bind_normals: Vec<[f32; 3]> =
                    s.normals.iter().map(|n| (linear * Vec3::from(*n)).normalize_or_zero().to_array()).collect();
                let plan = instance.sjb_plan(asset, self.node, p).ok_or("the primitive has no SJB plan")?.clone();
                let example = ExamplePose {
                    joint: self.skin_joint,
                    rotation: self.rotation,
                    positions: bind_positions,
                    normals: if prim.normals.is_empty() { Vec::new() } else { bind_normals },
                    space: ExampleSpace::Posed,
                };
                let input = SjbbeInput {
                    skin,
                    parents: &parents,
                    positions: &prim.positions,
                    normals: &prim.normals,
                    joints: &prim.joints,
                    weights: &prim.weights,
                    plan: &plan,
                };
                let rig = SjbbeRig::build(input, &[example], &[]).map_err(|e| e.message)?;
                for (v, &slot) in rig.vertex_slot.iter().enumerate() {
                    if let (Some(o), Some(no), Some(out), Some(out_n)) = (
                        rig.offsets.get(slot as usize),
                        rig.normal_offsets.get(slot as usize),
                        positions.get_mut(first + v),
                        normals.get_mut(first + v),
                    ) {
                        *out = o[0];
                        *out_n = no[0];
                    }
                }
            }
            first += prim.positions.len();
        }
        if mesh.primitives.iter().all(|p| p.normals.is_empty()) {
            normals.clear();
        }
        Ok(ExampleShape::Inline { positions, normals })
    }

    /// How far the sculpt moved its vertices from where it began, at most (model units).
    pub fn largest_move(&self, base: &Sculpt) -> f32 {
        (self.primitives.iter().zip(&base.primitives))
            .flat_map(|(a, b)| a.positions.iter().zip(&b.positions))
            .map(|(a, b)| (Vec3::from(*a) - Vec3::from(*b)).length())
            .fold(0.0, f32::max)
    }
}

impl SculptPrimitive {
    /// Area-weighted vertex normals from the faces, welded across seams.
    fn face_normals(&self) -> Vec<[f32; 3]> {
        let mut sums = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.triangles {
            let [a, b, c] = t.map(|v| Vec3::from(self.positions[v as usize]));
            let n = (b - a).cross(c - a);
            for &v in t {
                sums[v as usize] += n;
            }
        }
        for members in &self.groups {
            let total: Vec3 = members.iter().map(|&v| sums[v as usize]).sum();
            for &v in members {
                sums[v as usize] = total;
            }
        }
        sums.into_iter().map(|n| n.normalize_or_zero().to_array()).collect()
    }

    /// The support's normals after a dab: the shown normals turned as the faces turned.
    fn update_normals(&mut self) {
        let faces = self.face_normals();
        for &v in &self.support {
            let v = v as usize;
            let base = Vec3::from(self.base_normals[v]);
            let turned = base + Vec3::from(faces[v]) - Vec3::from(self.base_faces[v]);
            self.normals[v] = turned.try_normalize().unwrap_or(base).to_array();
        }
    }

    /// Whether vertex `v` is on the support.
    pub fn on_support(&self, v: usize) -> bool {
        self.group_of.get(v).is_some_and(|&g| g != u32::MAX)
    }
}

/// The triangles of a triangle list (`indices`, or every three vertices without), those that
/// index past `vertices` left out.
fn triangles(indices: &[u32], vertices: usize) -> Vec<[u32; 3]> {
    let list: Vec<u32> = if indices.is_empty() { (0..vertices as u32).collect() } else { indices.to_vec() };
    list.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).filter(|t| t.iter().all(|&v| (v as usize) < vertices)).collect()
}

/// Distance along the ray to triangle `abc` (Möller–Trumbore, both faces), if it hits.
fn ray_triangle(origin: Vec3, direction: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Option<f32> {
    let (e1, e2) = (b - a, c - a);
    let p = direction.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = direction.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > 0.0 && t.is_finite()).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::candy::{CandyWrapper, EXAMPLE_BEND, JOINT_NODE, joint_rotation};
    use crate::examples::{Examples, JointExample};
    use crate::job::dqs::SkinningMethod;

    /// Where the tests show the example pose: turned and moved, as a Z-up file's root would.
    const PLACE: Mat4 =
        Mat4::from_cols_array(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.25, -1.0, 1.0]);

    /// The candy wrapper in the example pose of its joint bent `bend` degrees (placed by
    /// [`PLACE`]): the asset, an instance there, and the node drawing the mesh.
    fn candy_at(bend: f32) -> (CandyWrapper, Instance, u32) {
        let candy = CandyWrapper::new();
        let asset = &candy.asset;
        let mut instance = Instance::new(asset);
        let locals = example_pose_locals(asset, instance.pose(), 0, JOINT_NODE, joint_rotation(0.0, bend), PLACE)
            .unwrap_or_else(|e| panic!("{e}"));
        for (node, t) in locals {
            instance.pose_mut().locals[node as usize] = t;
        }
        instance.update(asset).unwrap_or_else(|e| panic!("{e}"));
        let node = asset.nodes.iter().position(|n| n.mesh.is_some()).unwrap_or_else(|| panic!("no mesh node")) as u32;
        (candy, instance, node)
    }

    fn diagonal(asset: &Asset) -> f32 {
        let (lo, hi) = asset.meshes[0].primitives[0].bounds;
        (Vec3::from(hi) - Vec3::from(lo)).length()
    }

    #[test]
    fn the_example_pose_is_the_bind_pose_with_the_joint_turned() {
        let (candy, instance, _) = candy_at(EXAMPLE_BEND);
        let skin = &candy.asset.skins[0];
        let q = joint_rotation(0.0, EXAMPLE_BEND);
        for (j, &node) in skin.joints.iter().enumerate() {
            // The palette without the placement: the identity above the turned joint, a turn from it down.
            let palette = PLACE.inverse() * instance.palette(0)[j];
            let turned = node == JOINT_NODE || candy.asset.nodes[node as usize].parent == Some(JOINT_NODE);
            if turned {
                let bind = skin.inverse_bind[j].inverse();
                let centre = bind.w_axis.truncate();
                let moved = palette.transform_point3(centre);
                if node == JOINT_NODE {
                    assert!(moved.distance(centre) < 1e-5, "the joint's centre stays: {moved} vs {centre}");
                }
                let (_, r, _) = palette.to_scale_rotation_translation();
                assert!(r.dot(q).abs() > 1.0 - 1e-6, "turned by {r}, not {q}");
            } else {
                assert!(palette.abs_diff_eq(Mat4::IDENTITY, 1e-5), "joint {j}: {palette}");
            }
        }
        assert!(example_pose_locals(&candy.asset, instance.pose(), 0, 99, q, Mat4::IDENTITY).is_err());
        let long = Quat::from_xyzw(0.0, 0.0, 2.0, 0.0);
        assert!(example_pose_locals(&candy.asset, instance.pose(), 0, JOINT_NODE, long, Mat4::IDENTITY).is_err());
    }

    #[test]
    fn brushes_move_the_support_only_and_finish_reproduces_the_sculpt() {
        let (candy, mut instance, node) = candy_at(60.0);
        let asset = &candy.asset;
        let q = joint_rotation(0.0, 60.0);
        let mut sculpt =
            Sculpt::start(asset, &mut instance, node, JOINT_NODE, q, PLACE).unwrap_or_else(|e| panic!("{e}"));
        let start = sculpt.clone();
        let s = &sculpt.primitives[0];
        assert!(!s.support.is_empty() && s.support.len() < s.positions.len());
        // A dab on the outside of the bend, where the support is.
        let bind = |p: Vec3| PLACE.inverse().transform_point3(p);
        let joint = bind(instance.worlds()[JOINT_NODE as usize].w_axis.truncate());
        let from = PLACE.transform_point3(joint + Vec3::new(-0.3, 0.0, 2.0));
        let to = PLACE.transform_point3(joint + Vec3::new(-0.3, 0.0, 0.0));
        let hit = sculpt.pick(from, (to - from).normalize()).unwrap_or_else(|| panic!("no hit"));
        assert!((bind(hit).z - 0.25).abs() < 0.02, "the surface facing +Z in the bind pose: {}", bind(hit));
        let inflate = Dab { brush: Brush::Inflate, center: hit, radius: 0.3, strength: 1.0, drag: Vec3::ZERO };
        assert!(sculpt.dab(&inflate) > 0);
        let s = &sculpt.primitives[0];
        for v in 0..s.positions.len() {
            let moved = Vec3::from(s.positions[v]).distance(Vec3::from(start.primitives[0].positions[v]));
            if !s.on_support(v) {
                assert_eq!(moved, 0.0, "vertex {v} off the support moved");
            }
        }
        let largest = sculpt.largest_move(&start);
        assert!((largest - INFLATE_STEP * 0.3).abs() < 0.01, "inflate moves the centre out by a step: {largest}");
        // Grab follows the pointer at the centre; smooth takes some of it back.
        let grab = Dab { brush: Brush::Grab, center: hit, radius: 0.2, strength: 1.0, drag: Vec3::new(0.0, 0.05, 0.0) };
        assert!(sculpt.dab(&grab) > 0);
        let before_smooth = sculpt.largest_move(&start);
        let smooth = Dab { brush: Brush::Smooth, center: hit, radius: 0.3, strength: 1.0, drag: Vec3::ZERO };
        for _ in 0..5 {
            sculpt.dab(&smooth);
        }
        assert!(sculpt.largest_move(&start) < before_smooth, "smoothing lowers the peak");
        // Nothing moves for a dab off the surface or with bad numbers.
        let far = Dab { center: Vec3::splat(100.0), ..inflate };
        assert_eq!(sculpt.dab(&far), 0);
        assert_eq!(sculpt.dab(&Dab { radius: f32::NAN, ..inflate }), 0);

        // Done: the offsets, added as an example, give the sculpted shape at the example pose.
        let shape = sculpt.finish(asset).unwrap_or_else(|e| panic!("{e}"));
        let examples = Examples {
            poses: vec![JointExample {
                node: JOINT_NODE,
                mesh: 0,
                rotation: q,
                shape,
                pointer: "/examples/Joint/0".into(),
            }],
            sigma: Vec::new(),
        };
        let mut check = Instance::new(asset);
        check.set_skinning(asset, SkinningMethod::SphericalJointBlendByExample);
        check.set_examples(asset, &examples).unwrap_or_else(|e| panic!("{e}"));
        let locals =
            example_pose_locals(asset, check.pose(), 0, JOINT_NODE, q, PLACE).unwrap_or_else(|e| panic!("{e}"));
        for (n, t) in locals {
            check.pose_mut().locals[n as usize] = t;
        }
        check.update(asset).unwrap_or_else(|e| panic!("{e}"));
        let (mut positions, mut normals) = (Vec::new(), Vec::new());
        check.deform_primitive(asset, node, 0, &mut positions, &mut normals).unwrap_or_else(|e| panic!("{e}"));
        let worst = positions
            .iter()
            .zip(&sculpt.primitives[0].positions)
            .map(|(a, b)| Vec3::from(*a).distance(Vec3::from(*b)))
            .fold(0.0, f32::max);
        assert!(worst <= 1e-5 * diagonal(asset), "SJBBE at the example differs from the sculpt by {worst}");
    }

    #[test]
    fn a_mesh_without_normals_inflates_along_its_faces_and_smoothing_keeps_the_edge() {
        let (mut candy, _, node) = candy_at(60.0);
        candy.asset.meshes[0].primitives[0].normals.clear();
        let asset = &candy.asset;
        let q = joint_rotation(0.0, 60.0);
        let mut instance = Instance::new(asset);
        for (n, t) in
            example_pose_locals(asset, instance.pose(), 0, JOINT_NODE, q, PLACE).unwrap_or_else(|e| panic!("{e}"))
        {
            instance.pose_mut().locals[n as usize] = t;
        }
        instance.update(asset).unwrap_or_else(|e| panic!("{e}"));
        let mut sculpt =
            Sculpt::start(asset, &mut instance, node, JOINT_NODE, q, PLACE).unwrap_or_else(|e| panic!("{e}"));
        let start = sculpt.clone();
        let s = &sculpt.primitives[0];
        let v = s.support[s.support.len() / 2] as usize;
        let at = Vec3::from(s.positions[v]);
        let inflate = Dab { brush: Brush::Inflate, center: at, radius: 0.3, strength: 1.0, drag: Vec3::ZERO };
        assert!(sculpt.dab(&inflate) > 0);
        let moved = Vec3::from(sculpt.primitives[0].positions[v]) - at;
        assert!((moved.length() - INFLATE_STEP * 0.3).abs() < 0.01, "inflated by {moved}");
        // Outwards: away from the bone's axis through the joint.
        let joint = instance.worlds()[JOINT_NODE as usize].w_axis.truncate();
        assert!(moved.dot(at - joint) > 0.0, "inflate moved {moved} towards the inside");
        // Smoothing over the support's edge leaves the vertices off it where they are.
        let smooth = Dab { brush: Brush::Smooth, center: at, radius: 5.0, strength: 1.0, drag: Vec3::ZERO };
        for _ in 0..20 {
            sculpt.dab(&smooth);
        }
        let p = &sculpt.primitives[0];
        for i in 0..p.positions.len() {
            if !p.on_support(i) {
                assert_eq!(p.positions[i], start.primitives[0].positions[i]);
            }
        }
    }

    #[test]
    fn a_joint_without_a_parent_or_an_unturned_bone_is_refused() {
        let (candy, mut instance, node) = candy_at(0.0);
        let root = candy.asset.skins[0].joints[0];
        let e = Sculpt::start(&candy.asset, &mut instance, node, root, Quat::IDENTITY, PLACE).err().unwrap_or_default();
        assert!(e.contains("no parent joint"), "{e}");
        let sculpt = Sculpt::start(&candy.asset, &mut instance, node, JOINT_NODE, Quat::IDENTITY, PLACE)
            .unwrap_or_else(|e| panic!("{e}"));
        let e = sculpt.finish(&candy.asset).err().unwrap_or_default();
        assert!(e.contains("same way"), "an example at the reference pose: {e}");
    }
}
