//! Example poses for spherical joint blending by example ([`crate::job::sjbbe`]) in the
//! `<model>.kloub.json` sidecar:
//!
//! ```json
//! { "examples": {
//!     "arm_joint_L_2": [
//!       { "rotation": [0, 0, 0.7071068, 0.7071068], "target": "Flex", "space": "rest" },
//!       { "rotation": [0, 0, -0.5, 0.8660254], "mesh": "Body", "offsets": "AAAAAAAA…", "normals": "…" } ] },
//!   "example_sigma": { "arm_joint_L_2": 0.8 } }
//! ```
//!
//! - Joints and meshes are named as in the file (or given by index); `rotation` is the joint's
//!   local rotation `[x, y, z, w]` (unit) in the example, the other joints at the reference pose.
//! - `target` names (the mesh's `extras.targetNames`) or indexes a morph target of the skinned
//!   mesh; `space` says what it holds: `"rest"` (default), offsets already in the reference
//!   pose, as a corrective shape key; `"posed"`, the shape as seen in the example pose, taken
//!   back to the reference pose (seed 001 §5.3).
//! - Or inline offsets in the reference pose, as the viewer saves them: `offsets` (and
//!   optionally `normals`) is standard base64 of little-endian `f32` x, y, z per vertex of the
//!   mesh, its primitives one after another.
//! - `mesh` (name or index) defaults to the first mesh skinned by a skin with that joint.
//! - `example_sigma` sets a joint's σ (radians of arc, default 1 as in the seed).
//!
//! Every error names its JSON pointer; [`crate::instance::Instance::set_examples`] adds those
//! that need the rig (a joint with several children, examples too alike).

use base64::Engine;
use serde_json::{Map, Value, json};

use crate::asset::{Asset, MorphTarget};
use crate::error::JobError;
use crate::instance::Instance;
use crate::job::sjbbe::{ExamplePose, ExampleSpace, MAX_EXAMPLES, NO_SLOT, SjbbeAlphaJob, SjbbeRig};
use crate::math::{Quat, QuatExt};
use crate::rig::escape;

/// The example poses of one model.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Examples {
    /// Every example, in the sidecar's order.
    pub poses: Vec<JointExample>,
    /// σ per joint node, where set.
    pub sigma: Vec<(u32, f32)>,
}

/// One example pose.
#[derive(Clone, Debug, PartialEq)]
pub struct JointExample {
    /// The joint's node.
    pub node: u32,
    /// The skinned mesh it shapes.
    pub mesh: u32,
    /// The joint's local rotation in the example.
    pub rotation: Quat,
    /// Its shape.
    pub shape: ExampleShape,
    /// Its JSON pointer in the sidecar (`/examples/<joint>/<i>`), for errors found later.
    pub pointer: String,
}

/// Where an example's shape comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum ExampleShape {
    /// A morph target of the mesh (index), holding offsets or the posed shape.
    Target {
        /// The target's index.
        index: u32,
        /// What it holds.
        space: ExampleSpace,
    },
    /// Offsets in the reference pose per vertex of the mesh (its primitives in order, the
    /// importer's copies included; a sidecar holds them in the file's numbering).
    Inline {
        /// Position offsets.
        positions: Vec<[f32; 3]>,
        /// Normal offsets; empty for none.
        normals: Vec<[f32; 3]>,
    },
}

/// The vertex count of every primitive of `mesh` together.
/// Vertices of `mesh` as the file numbers them: its primitives' in turn, without the copies the
/// importer added ([`Primitive::copied_from`](crate::asset::Primitive::copied_from)).
fn file_vertices(asset: &Asset, mesh: u32) -> usize {
    asset
        .meshes
        .get(mesh as usize)
        .map_or(0, |m| m.primitives.iter().map(|p| p.positions.len().saturating_sub(p.copied_from.len())).sum())
}

/// Per-vertex data of `mesh` in the file's numbering ([`file_vertices`] long) in the mesh's:
/// each primitive's copies take their source's value.
fn from_file_numbering(asset: &Asset, mesh: u32, file: Vec<[f32; 3]>) -> Vec<[f32; 3]> {
    let Some(m) = asset.meshes.get(mesh as usize) else { return file };
    if m.primitives.iter().all(|p| p.copied_from.is_empty()) {
        return file;
    }
    let mut out = Vec::with_capacity(m.primitives.iter().map(|p| p.positions.len()).sum());
    let mut start = 0;
    for p in &m.primitives {
        let own = p.positions.len().saturating_sub(p.copied_from.len());
        let slice = file.get(start..start + own).unwrap_or(&[]);
        out.extend_from_slice(slice);
        out.extend(p.copied_from.iter().map(|&v| slice.get(v as usize).copied().unwrap_or_default()));
        start += own;
    }
    out
}

/// The inverse of [`from_file_numbering`]: the copies left out.
fn to_file_numbering(asset: &Asset, mesh: u32, values: &[[f32; 3]]) -> Vec<[f32; 3]> {
    let Some(m) = asset.meshes.get(mesh as usize) else { return values.to_vec() };
    let mut out = Vec::with_capacity(values.len());
    let mut start = 0;
    for p in &m.primitives {
        let own = p.positions.len().saturating_sub(p.copied_from.len());
        out.extend_from_slice(values.get(start..start + own).unwrap_or(&[]));
        start += p.positions.len();
    }
    out
}

impl Examples {
    /// Reads the `examples` and `example_sigma` members of a sidecar (absent: no examples).
    ///
    /// # Errors
    /// `"<pointer>: <message>"` for malformed JSON, an unknown joint, mesh or target, a
    /// rotation that is not a unit quaternion, an unknown `space`, more than
    /// [`MAX_EXAMPLES`] for a joint, inline data of the wrong length or not base64.
    pub fn from_json(asset: &Asset, json: &str) -> Result<Self, String> {
        let root: Value = serde_json::from_str(json).map_err(|e| format!("not JSON: {e}"))?;
        let mut out = Examples::default();
        let node_named = |name: &str, pointer: &str| -> Result<u32, String> {
            asset
                .nodes
                .iter()
                .position(|n| n.name.as_deref() == Some(name))
                .map(|n| n as u32)
                .ok_or_else(|| format!("{pointer}: no joint named {name:?} in the model"))
        };
        if let Some(examples) = root.get("examples") {
            let examples = examples.as_object().ok_or("/examples: expected an object of joints")?;
            for (joint, list) in examples {
                let jptr = format!("/examples/{}", escape(joint));
                let node = node_named(joint, &jptr)?;
                let skinned_by = |mesh: u32| {
                    asset.nodes.iter().any(|n| {
                        n.mesh == Some(mesh)
                            && n.skin
                                .and_then(|s| asset.skins.get(s as usize))
                                .is_some_and(|s| s.joints.contains(&node))
                    })
                };
                let list = list.as_array().ok_or_else(|| format!("{jptr}: expected a list of example poses"))?;
                if list.len() > MAX_EXAMPLES {
                    return Err(format!(
                        "{jptr}/{MAX_EXAMPLES}: {} example poses for {joint:?}; at most {MAX_EXAMPLES} per joint",
                        list.len()
                    ));
                }
                for (i, example) in list.iter().enumerate() {
                    let ptr = format!("{jptr}/{i}");
                    let example = example.as_object().ok_or_else(|| format!("{ptr}: expected an object"))?;
                    let mesh = match example.get("mesh") {
                        None => (0..asset.meshes.len() as u32)
                            .find(|&m| skinned_by(m))
                            .ok_or_else(|| format!("{ptr}: no mesh is skinned by a skin with joint {joint:?}"))?,
                        Some(m) => {
                            let mesh = match m {
                                Value::String(name) => {
                                    asset.meshes.iter().position(|x| x.name.as_deref() == Some(name.as_str()))
                                }
                                _ => m.as_u64().map(|i| i as usize).filter(|&i| i < asset.meshes.len()),
                            }
                            .ok_or_else(|| format!("{ptr}/mesh: no mesh {m} in the model"))?
                                as u32;
                            if !skinned_by(mesh) {
                                return Err(format!(
                                    "{ptr}/mesh: mesh {m} is not skinned by a skin with joint {joint:?}"
                                ));
                            }
                            mesh
                        }
                    };
                    let rotation = rotation(example.get("rotation"), &format!("{ptr}/rotation"))?;
                    let shape = shape(asset, mesh, example, &ptr)?;
                    out.poses.push(JointExample { node, mesh, rotation, shape, pointer: ptr });
                }
            }
        }
        if let Some(sigma) = root.get("example_sigma") {
            let sigma = sigma.as_object().ok_or("/example_sigma: expected an object of joints")?;
            for (joint, value) in sigma {
                let ptr = format!("/example_sigma/{}", escape(joint));
                let node = node_named(joint, &ptr)?;
                let s = value
                    .as_f64()
                    .map(|v| v as f32)
                    .filter(|v| v.is_finite() && *v >= 1e-3 && *v <= 10.0)
                    .ok_or_else(|| format!("{ptr}: expected σ in radians, from 0.001 to 10"))?;
                out.sigma.push((node, s));
            }
        }
        Ok(out)
    }

    /// The sidecar members that reproduce these examples (merge them into a sidecar's object);
    /// inline shapes as base64.
    pub fn to_json(&self, asset: &Asset) -> Map<String, Value> {
        let name = |node: u32| {
            asset.nodes.get(node as usize).and_then(|n| n.name.clone()).unwrap_or_else(|| format!("node {node}"))
        };
        let mut joints = Map::new();
        for e in &self.poses {
            let mut entry = Map::new();
            let q = e.rotation;
            entry.insert("rotation".into(), json!([q.x, q.y, q.z, q.w]));
            entry.insert("mesh".into(), json!(e.mesh));
            match &e.shape {
                ExampleShape::Target { index, space } => {
                    entry.insert("target".into(), json!(index));
                    let space = if *space == ExampleSpace::Rest { "rest" } else { "posed" };
                    entry.insert("space".into(), json!(space));
                }
                ExampleShape::Inline { positions, normals } => {
                    // In the file's numbering: a sidecar does not depend on how the importer split.
                    entry.insert("offsets".into(), json!(encode(&to_file_numbering(asset, e.mesh, positions))));
                    if !normals.is_empty() {
                        entry.insert("normals".into(), json!(encode(&to_file_numbering(asset, e.mesh, normals))));
                    }
                }
            }
            let list = joints.entry(name(e.node)).or_insert_with(|| json!([]));
            if let Value::Array(list) = list {
                list.push(Value::Object(entry));
            }
        }
        let mut out = Map::new();
        out.insert("examples".into(), Value::Object(joints));
        if !self.sigma.is_empty() {
            let sigma: Map<String, Value> = self.sigma.iter().map(|&(n, s)| (name(n), json!(s))).collect();
            out.insert("example_sigma".into(), Value::Object(sigma));
        }
        out
    }

    /// The examples that shape `primitive` of `mesh` under `skin`'s joints, as
    /// [`crate::job::sjbbe::SjbbeRig::build`] takes them.
    pub fn for_primitive(
        &self,
        asset: &Asset,
        skin: usize,
        mesh: u32,
        primitive: usize,
    ) -> Result<PrimitiveExamples, String> {
        let (Some(skin), Some(m)) = (asset.skins.get(skin), asset.meshes.get(mesh as usize)) else {
            return Ok(Default::default());
        };
        let Some(prim) = m.primitives.get(primitive) else { return Ok(Default::default()) };
        let first_vertex: usize = m.primitives[..primitive].iter().map(|p| p.positions.len()).sum();
        let joint_of = |node: u32| skin.joints.iter().position(|&j| j == node).map(|j| j as u16);
        let (mut poses, mut sources) = (Vec::new(), Vec::new());
        for (i, e) in self.poses.iter().enumerate() {
            let Some(joint) = joint_of(e.node).filter(|_| e.mesh == mesh) else { continue };
            let (positions, normals, space) = match &e.shape {
                ExampleShape::Target { index, space } => {
                    let target = prim.targets.get(*index as usize).ok_or_else(|| {
                        format!("{}/target: primitive {primitive} has no morph target {index}", e.pointer)
                    })?;
                    let (positions, normals) = match space {
                        // The posed shape: the reference vertices moved by the target.
                        ExampleSpace::Posed => (
                            add(&prim.positions, &target.positions),
                            if target.normals.is_empty() { Vec::new() } else { add(&prim.normals, &target.normals) },
                        ),
                        ExampleSpace::Rest => (target.positions.clone(), target.normals.clone()),
                    };
                    (positions, normals, *space)
                }
                ExampleShape::Inline { positions, normals } => {
                    let range = first_vertex..first_vertex + prim.positions.len();
                    let part = |v: &Vec<[f32; 3]>| v.get(range.clone()).map(<[_]>::to_vec).unwrap_or_default();
                    (part(positions), part(normals), ExampleSpace::Rest)
                }
            };
            poses.push(ExamplePose { joint, rotation: e.rotation, positions, normals, space });
            sources.push(i);
        }
        let sigma = self.sigma.iter().filter_map(|&(n, s)| Some((joint_of(n)?, s))).collect();
        Ok(PrimitiveExamples { poses, sources, sigma })
    }
}

/// The examples of one primitive ([`Examples::for_primitive`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PrimitiveExamples {
    /// The poses, with the skin's joint indices.
    pub poses: Vec<ExamplePose>,
    /// Each pose's index in [`Examples::poses`].
    pub sources: Vec<usize>,
    /// σ per skin joint, where set.
    pub sigma: Vec<(u16, f32)>,
}

/// Example poses compiled into morph targets, for renderers that morph and skin on the GPU:
/// `SJB(v + Σ α offset)` is SJB over morph targets whose weights are α. Each mesh shaped by
/// examples gains one target per (joint, example) of its rig, holding that example's offsets on
/// the joint's support and zero elsewhere; each frame [`ExampleTargets::write_weights`] sets
/// those targets' weights to α (or to zero for another skinning method). The asset's own
/// targets and the clips that animate them are unchanged.
#[derive(Clone, Debug, Default)]
pub struct ExampleTargets {
    /// Per node instancing a shaped mesh: its rig's bones and where their weights go.
    nodes: Vec<NodeTargets>,
    /// α scratch, sized for the largest rig.
    alphas: Vec<[f32; MAX_EXAMPLES]>,
}

/// One node's example weights.
#[derive(Clone, Debug)]
struct NodeTargets {
    node: u32,
    skin: usize,
    /// The rig whose bones give α (the node's first shaped primitive's; all of a mesh's
    /// primitives share the bones).
    rig: SjbbeRig,
    /// Index in the pose's weights of the first example target.
    first_weight: usize,
}

impl ExampleTargets {
    /// `asset` with the example targets of every mesh that `examples` shape (through the rigs
    /// of `instance`, made for `asset` with [`Instance::set_examples`]), and what writes their
    /// weights. Without examples the asset is returned as it is.
    pub fn compile(asset: &Asset, instance: &Instance) -> (Asset, ExampleTargets) {
        let mut out = asset.clone();
        let mut added: Vec<usize> = vec![0; asset.meshes.len()];
        // Each mesh's targets come from the first node that instances it with a rig.
        for (m, mesh) in asset.meshes.iter().enumerate() {
            let Some(node) = (0..asset.nodes.len() as u32)
                .find(|&n| asset.nodes[n as usize].mesh == Some(m as u32) && instance.sjbbe_rig(n, 0).is_some())
            else {
                continue;
            };
            let Some(keys) = instance.sjbbe_rig(node, 0).map(rig_keys) else { continue };
            for (p, prim) in mesh.primitives.iter().enumerate() {
                let rig = instance.sjbbe_rig(node, p);
                for &(bone, example) in &keys {
                    let offsets = |normals: bool| -> Vec<[f32; 3]> {
                        (0..prim.positions.len())
                            .map(|v| {
                                let Some(rig) = rig else { return [0.0; 3] };
                                match rig.vertex_slot.get(v).copied() {
                                    Some(s) if s != NO_SLOT && rig.slot_bone.get(s as usize) == Some(&bone) => {
                                        let table = if normals { &rig.normal_offsets } else { &rig.offsets };
                                        table.get(s as usize).map_or([0.0; 3], |o| o[example])
                                    }
                                    _ => [0.0; 3],
                                }
                            })
                            .collect()
                    };
                    let normals = if prim.normals.is_empty() { Vec::new() } else { offsets(true) };
                    let tangents = if prim.targets.iter().any(|t| !t.tangents.is_empty()) && !prim.tangents.is_empty() {
                        vec![[0.0; 3]; prim.positions.len()]
                    } else {
                        Vec::new()
                    };
                    out.meshes[m].primitives[p].targets.push(MorphTarget {
                        positions: offsets(false),
                        normals,
                        tangents,
                    });
                }
            }
            for &(bone, example) in &keys {
                let joint = instance.sjbbe_rig(node, 0).and_then(|r| r.bones.get(bone as usize)).map_or(0, |b| b.joint);
                let name = asset
                    .skins
                    .iter()
                    .find_map(|s| s.joints.get(joint as usize))
                    .and_then(|&n| asset.nodes.get(n as usize)?.name.clone())
                    .unwrap_or_else(|| format!("joint {joint}"));
                out.meshes[m].weights.push(0.0);
                if !out.meshes[m].target_names.is_empty() {
                    out.meshes[m].target_names.push(format!("sjbbe {name} {example}"));
                }
            }
            added[m] = keys.len();
        }
        // Node weights, their offsets in the pose, and which nodes write α.
        let mut targets = ExampleTargets::default();
        let mut total = 0u32;
        for (n, node) in out.nodes.iter_mut().enumerate() {
            let extra = node.mesh.map_or(0, |m| added.get(m as usize).copied().unwrap_or(0));
            if let Some(offset) = out.weight_offsets.get_mut(n) {
                *offset = total;
            }
            let own = node.weights.len();
            if extra > 0 {
                node.weights.extend(std::iter::repeat_n(0.0, extra));
                let (Some(skin), Some(rig)) = (node.skin, instance.sjbbe_rig(n as u32, 0)) else { continue };
                targets.nodes.push(NodeTargets {
                    node: n as u32,
                    skin: skin as usize,
                    rig: rig.clone(),
                    first_weight: total as usize + own,
                });
            }
            total += node.weights.len() as u32;
        }
        out.weight_total = total;
        let bones = targets.nodes.iter().map(|t| t.rig.bones.len()).max().unwrap_or(0);
        targets.alphas = vec![[0.0; MAX_EXAMPLES]; bones];
        (out, targets)
    }

    /// Whether any node has example targets.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Writes each example target's weight into `instance`'s pose: α from the current palettes
    /// when `on`, zero otherwise. Call after the pose and palettes are updated, before
    /// deforming or drawing (the weights do not move the skeleton).
    ///
    /// # Errors
    /// A rig that does not fit the instance's palettes (made for another asset).
    pub fn write_weights(&mut self, instance: &mut Instance, on: bool) -> Result<(), JobError> {
        for t in &self.nodes {
            let alphas = &mut self.alphas[..t.rig.bones.len()];
            if on {
                SjbbeAlphaJob { rig: &t.rig, palette: instance.palette(t.skin), out: alphas }.run()?;
            } else {
                alphas.fill([0.0; MAX_EXAMPLES]);
            }
            let weights = &mut instance.pose_mut().weights;
            let mut k = t.first_weight;
            for (bone, alpha) in t.rig.bones.iter().zip(alphas.iter()) {
                for &a in &alpha[..bone.rotations.len()] {
                    if let Some(w) = weights.get_mut(k) {
                        *w = a;
                    }
                    k += 1;
                }
            }
        }
        Ok(())
    }
}

impl ExampleTargets {
    /// Takes the rigs of `instance` (made for the asset [`ExampleTargets::compile`] was given,
    /// with the same examples but other σ): the targets' offsets do not depend on σ, only α does.
    ///
    /// # Errors
    /// A node whose rig is missing or has other joints or examples (different examples).
    pub fn update_rigs(&mut self, instance: &Instance) -> Result<(), String> {
        let mut rigs = Vec::with_capacity(self.nodes.len());
        for t in &self.nodes {
            let rig = instance.sjbbe_rig(t.node, 0).ok_or("the examples changed: no rig for a node that had one")?;
            if rig_keys(rig) != rig_keys(&t.rig) {
                return Err("the examples changed: other joints or examples".into());
            }
            rigs.push(rig.clone());
        }
        for (t, rig) in self.nodes.iter_mut().zip(rigs) {
            t.rig = rig;
        }
        Ok(())
    }

    /// The example weights in `instance`'s pose now, for the first node that draws examples:
    /// `(skin, joint in that skin, example of that joint, α)` (for a readout).
    pub fn current(&self, instance: &Instance) -> Vec<(usize, u16, usize, f32)> {
        let Some(t) = self.nodes.first() else { return Vec::new() };
        let weights = &instance.pose().weights;
        let mut out = Vec::new();
        let mut k = t.first_weight;
        for bone in &t.rig.bones {
            for e in 0..bone.rotations.len() {
                out.push((t.skin, bone.joint, e, weights.get(k).copied().unwrap_or(0.0)));
                k += 1;
            }
        }
        out
    }
}

/// A rig's (bone, example) pairs in order: its example targets.
fn rig_keys(rig: &SjbbeRig) -> Vec<(u16, usize)> {
    rig.bones.iter().enumerate().flat_map(|(b, bone)| (0..bone.rotations.len()).map(move |e| (b as u16, e))).collect()
}

/// `base + delta` per vertex (a target shorter than the base adds nothing past its end).
fn add(base: &[[f32; 3]], delta: &[[f32; 3]]) -> Vec<[f32; 3]> {
    base.iter()
        .enumerate()
        .map(|(i, b)| {
            let d = delta.get(i).copied().unwrap_or([0.0; 3]);
            [b[0] + d[0], b[1] + d[1], b[2] + d[2]]
        })
        .collect()
}

/// A unit quaternion `[x, y, z, w]` at `ptr`.
fn rotation(value: Option<&Value>, ptr: &str) -> Result<Quat, String> {
    let v = value.ok_or_else(|| format!("{ptr}: missing"))?;
    let xs: Vec<f32> = v
        .as_array()
        .filter(|a| a.len() == 4)
        .and_then(|a| a.iter().map(|x| x.as_f64().map(|x| x as f32)).collect())
        .ok_or_else(|| format!("{ptr}: expected [x, y, z, w]"))?;
    // Kept as written (the rig normalizes): a sidecar read and written back is unchanged.
    Quat::from_xyzw(xs[0], xs[1], xs[2], xs[3])
        .check_unit()
        .map_err(|length| format!("{ptr}: not a unit quaternion (length {length})"))
}

/// An example's shape: a morph target or inline offsets.
fn shape(asset: &Asset, mesh: u32, example: &Map<String, Value>, ptr: &str) -> Result<ExampleShape, String> {
    let m = &asset.meshes[mesh as usize];
    match (example.get("target"), example.get("offsets")) {
        (Some(_), Some(_)) => Err(format!("{ptr}: give either target or offsets, not both")),
        (None, None) => Err(format!("{ptr}: missing target (a morph target) or offsets (inline)")),
        (Some(t), None) => {
            let count = m.primitives.first().map_or(0, |p| p.targets.len());
            let index = match t {
                Value::String(name) => m.target_names.iter().position(|n| n == name),
                _ => t.as_u64().map(|i| i as usize).filter(|&i| i < count),
            }
            .filter(|&i| i < count)
            .ok_or_else(|| format!("{ptr}/target: mesh {mesh} has no morph target {t} ({count} targets)"))?;
            let space = match example.get("space").map(|s| s.as_str()) {
                None | Some(Some("rest")) => ExampleSpace::Rest,
                Some(Some("posed")) => ExampleSpace::Posed,
                Some(_) => return Err(format!("{ptr}/space: expected \"rest\" or \"posed\"")),
            };
            Ok(ExampleShape::Target { index: index as u32, space })
        }
        (None, Some(offsets)) => {
            let n = file_vertices(asset, mesh);
            let positions = from_file_numbering(asset, mesh, decode(offsets, n, &format!("{ptr}/offsets"))?);
            let normals = match example.get("normals") {
                Some(v) => from_file_numbering(asset, mesh, decode(v, n, &format!("{ptr}/normals"))?),
                None => Vec::new(),
            };
            Ok(ExampleShape::Inline { positions, normals })
        }
    }
}

/// `count` vectors from base64 of little-endian `f32` triples, finite.
fn decode(value: &Value, count: usize, ptr: &str) -> Result<Vec<[f32; 3]>, String> {
    let text = value.as_str().ok_or_else(|| format!("{ptr}: expected base64 text"))?;
    let expected = count * 12;
    // Checked against the mesh before decoding: 4 characters per 3 bytes.
    if text.len() != expected.div_ceil(3) * 4 {
        return Err(format!(
            "{ptr}: {} base64 characters; {count} vertices need {}",
            text.len(),
            expected.div_ceil(3) * 4
        ));
    }
    let bytes =
        base64::engine::general_purpose::STANDARD.decode(text).map_err(|e| format!("{ptr}: not base64 ({e})"))?;
    if bytes.len() != expected {
        return Err(format!("{ptr}: {} bytes; {count} vertices need {expected}", bytes.len()));
    }
    let mut out = Vec::with_capacity(count);
    for (v, chunk) in bytes.chunks_exact(12).enumerate() {
        let f = |k: usize| f32::from_le_bytes([chunk[4 * k], chunk[4 * k + 1], chunk[4 * k + 2], chunk[4 * k + 3]]);
        let xyz = [f(0), f(1), f(2)];
        if !xyz.iter().all(|x| x.is_finite()) {
            return Err(format!("{ptr}: vertex {v} is not finite"));
        }
        out.push(xyz);
    }
    Ok(out)
}

/// Base64 of little-endian `f32` triples.
fn encode(values: &[[f32; 3]]) -> String {
    let bytes: Vec<u8> = values.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::asset::{Mesh, MorphTarget, Node, Primitive, Scene, Topology};
    use crate::instance::Instance;
    use crate::job::dqs::SkinningMethod;
    use crate::job::sjbbe::tests::{skin, tube};
    use crate::math::{Transform, Vec3};

    /// The SJBBE test tube as a model: joints Root, Upper, Lower, End along X, mesh "Tube" with
    /// one morph target "Bulge" (the ring normals × 0.04).
    fn model() -> Asset {
        let (skin, parents) = skin(false);
        let t = tube();
        let names = ["Root", "Upper", "Lower", "End"];
        let mut nodes: Vec<Node> = (0..4)
            .map(|j| Node {
                name: Some(names[j].into()),
                parent: parents[j],
                children: if j < 3 { vec![j as u32 + 1] } else { Vec::new() },
                rest: Transform {
                    translation: Vec3::new(if j == 0 { 0.0 } else { 1.0 }, 0.0, 0.0),
                    ..Transform::IDENTITY
                },
                ..Node::default()
            })
            .collect();
        nodes.push(Node {
            name: Some("Body".into()),
            mesh: Some(0),
            skin: Some(0),
            weights: vec![0.0],
            ..Node::default()
        });
        let bulge: Vec<[f32; 3]> = t.normals.iter().map(|n| [0.0, n[1] * 0.04, n[2] * 0.04]).collect();
        let primitive = Primitive {
            topology: Topology::Points,
            vertex_count: t.positions.len() as u32,
            indices: (0..t.positions.len() as u32).collect(),
            positions: t.positions,
            normals: t.normals,
            joints: t.joints,
            weights: t.weights,
            targets: vec![MorphTarget { positions: bulge, ..MorphTarget::default() }],
            ..Primitive::default()
        };
        Asset {
            nodes,
            order: vec![0, 1, 2, 3, 4],
            scenes: vec![Scene { name: None, roots: vec![0, 4] }],
            default_scene: Some(0),
            meshes: vec![Mesh {
                name: Some("Tube".into()),
                primitives: vec![primitive],
                weights: vec![0.0],
                target_names: vec!["Bulge".into()],
            }],
            skins: vec![skin],
            weight_offsets: vec![0; 5],
            weight_total: 1,
            ..Asset::default()
        }
    }

    const BENT: &str = "[0, 0, 0.70710677, 0.70710677]";

    fn sidecar(examples: &str) -> String {
        format!(r#"{{ "examples": {{ {examples} }} }}"#)
    }

    fn refused(asset: &Asset, json: &str) -> String {
        match Examples::from_json(asset, json) {
            Err(e) => e,
            Ok(examples) => Instance::new(asset).set_examples(asset, &examples).expect_err("refused"),
        }
    }

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn broken_examples_name_their_pointer() {
        let asset = model();
        let cases = [
            (sidecar(&format!(r#""Nope": [{{"rotation": {BENT}, "target": 0}}]"#)), "/examples/Nope: no joint"),
            (
                sidecar(r#""Lower": [{"rotation": [0, 0, 0.5, 0.5], "target": 0}]"#),
                "/examples/Lower/0/rotation: not a unit",
            ),
            (sidecar(&format!(r#""Lower": [{{"rotation": {BENT}, "target": "Flex"}}]"#)), "/examples/Lower/0/target:"),
            (sidecar(&format!(r#""Lower": [{{"rotation": {BENT}, "target": 3}}]"#)), "/examples/Lower/0/target:"),
            (
                sidecar(&format!(r#""Lower": [{{"rotation": {BENT}, "target": 0, "space": "wherever"}}]"#)),
                "/examples/Lower/0/space:",
            ),
            (
                sidecar(&format!(r#""Lower": [{{"rotation": {BENT}, "offsets": "AAAA"}}]"#)),
                "/examples/Lower/0/offsets: 4 base64",
            ),
            (sidecar(&format!(r#""Lower": [{{"rotation": {BENT}}}]"#)), "/examples/Lower/0: missing target"),
            (
                sidecar(&format!(r#""Lower": [{{"rotation": {BENT}, "target": 0, "mesh": "Hat"}}]"#)),
                "/examples/Lower/0/mesh:",
            ),
            (
                sidecar(&format!(
                    r#""Lower": [{}]"#,
                    [BENT; 5].map(|q| format!(r#"{{"rotation": {q}, "target": 0}}"#)).join(",")
                )),
                "/examples/Lower/4:",
            ),
            (
                sidecar(&format!(r#""End": [{{"rotation": {BENT}, "target": 0}}]"#)),
                "/examples/End/0: the joint has 0 child joints",
            ),
            (
                sidecar(&format!(
                    r#""Lower": [{{"rotation": {BENT}, "target": 0}}, {{"rotation": {BENT}, "target": "Bulge"}}]"#
                )),
                "/examples/Lower/1: example 0 and example 1",
            ),
            (r#"{ "examples": {}, "example_sigma": { "Lower": -1 } }"#.to_owned(), "/example_sigma/Lower:"),
            ("{ \"examples\": [] }".to_owned(), "/examples: expected an object"),
        ];
        for (json, expected) in cases {
            let e = refused(&asset, &json);
            assert!(e.starts_with(expected), "{json}\n  gave {e}\n  expected {expected}…");
        }
    }

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn inline_examples_round_trip_exactly() {
        let asset = model();
        let offsets: Vec<[f32; 3]> = (0..200).map(|v| [v as f32 * 1e-3, 0.1 / (v as f32 + 1.0), -0.3]).collect();
        let examples = Examples {
            poses: vec![JointExample {
                node: 2,
                mesh: 0,
                rotation: Quat::from_rotation_z(0.7),
                shape: ExampleShape::Inline { positions: offsets.clone(), normals: offsets },
                pointer: "/examples/Lower/0".into(),
            }],
            sigma: vec![(2, 0.8)],
        };
        let json = serde_json::to_string(&examples.to_json(&asset)).expect("JSON");
        let back = Examples::from_json(&asset, &json).expect("reads back");
        assert_eq!(back, examples);
    }

    /// A mesh whose vertices the importer split (generated tangents) reads and writes inline
    /// shapes in the file's numbering: the copies take their source's offsets.
    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn inline_examples_are_numbered_as_the_file_is() {
        let mut asset = model();
        {
            let p = &mut asset.meshes[0].primitives[0];
            for source in [3u32, 7] {
                let v = source as usize;
                p.positions.push(p.positions[v]);
                p.normals.push(p.normals[v]);
                p.joints.push(p.joints[v]);
                p.weights.push(p.weights[v]);
                for t in &mut p.targets {
                    t.positions.push(t.positions[v]);
                    if !t.normals.is_empty() {
                        t.normals.push(t.normals[v]);
                    }
                }
                p.copied_from.push(source);
            }
            p.vertex_count += 2;
        }
        let file: Vec<[f32; 3]> = (0..200).map(|v| [v as f32, 0.0, 0.0]).collect();
        let json = sidecar(&format!(r#""Lower": [{{"rotation": {BENT}, "offsets": "{}"}}]"#, super::encode(&file)));
        let examples = Examples::from_json(&asset, &json).expect("200 offsets: the file's vertices");
        let ExampleShape::Inline { positions, .. } = &examples.poses[0].shape else { panic!("inline") };
        assert_eq!(positions.len(), 202);
        assert_eq!(&positions[..200], &file[..]);
        assert_eq!(positions[200..], [[3.0, 0.0, 0.0], [7.0, 0.0, 0.0]]);
        let written = examples.to_json(&asset);
        let offsets = &written["examples"]["Lower"][0]["offsets"];
        assert_eq!(offsets.as_str(), Some(super::encode(&file).as_str()), "written back as read");
        // 202 offsets are not the file's count.
        let json =
            sidecar(&format!(r#""Lower": [{{"rotation": {BENT}, "offsets": "{}"}}]"#, super::encode(&positions[..])));
        assert!(Examples::from_json(&asset, &json).is_err());
    }

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn an_instance_with_examples_bulges_only_near_the_example_pose() {
        let asset = model();
        let json = sidecar(&format!(r#""Lower": [{{"rotation": {BENT}, "target": "Bulge", "space": "rest"}}]"#));
        let examples = Examples::from_json(&asset, &json).expect("reads");
        let mut instance = Instance::new(&asset);
        instance.set_skinning(&asset, SkinningMethod::SphericalJointBlendByExample);
        instance.set_examples(&asset, &examples).expect("builds");
        let rig = instance.sjbbe_rig(4, 0).expect("a rig for the tube").clone();
        let deform = |instance: &mut Instance, method, rotation: Quat| {
            instance.set_skinning(&asset, method);
            instance.evaluate(&asset, None, 0.0).expect("rest");
            instance.pose_mut().locals[2].rotation = rotation;
            instance.update(&asset).expect("update");
            let (mut p, mut n) = (Vec::new(), Vec::new());
            instance.deform_primitive(&asset, 4, 0, &mut p, &mut n).expect("deform");
            p
        };
        let bent = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let by_example = deform(&mut instance, SkinningMethod::SphericalJointBlendByExample, bent);
        let plain = deform(&mut instance, SkinningMethod::SphericalJointBlend, bent);
        for (v, (a, b)) in by_example.iter().zip(&plain).enumerate() {
            let moved = Vec3::from(*a).distance(Vec3::from(*b));
            let expected = if rig.vertex_slot[v] == crate::job::sjbbe::NO_SLOT { 0.0 } else { 0.04 };
            assert!((moved - expected).abs() < 1e-4, "vertex {v} moved {moved}, expected {expected}");
        }
        // At the reference pose SJBBE is SJB.
        let rest = deform(&mut instance, SkinningMethod::SphericalJointBlendByExample, Quat::IDENTITY);
        let rest_sjb = deform(&mut instance, SkinningMethod::SphericalJointBlend, Quat::IDENTITY);
        assert!(rest.iter().zip(&rest_sjb).all(|(a, b)| Vec3::from(*a).distance(Vec3::from(*b)) < 1e-6));
    }

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn examples_as_morph_targets_weighted_by_alpha_are_sjbbe() {
        let asset = model();
        let json = sidecar(&format!(
            r#""Lower": [{{"rotation": {BENT}, "target": "Bulge"}}, {{"rotation": [0, 0, -0.5, 0.8660254], "offsets": "{}"}}]"#,
            super::encode(&vec![[0.0, 0.0, 0.03]; 200])
        ));
        let examples = Examples::from_json(&asset, &json).expect("reads");
        let mut reference = Instance::new(&asset);
        reference.set_skinning(&asset, SkinningMethod::SphericalJointBlendByExample);
        reference.set_examples(&asset, &examples).expect("builds");
        let (derived, mut targets) = ExampleTargets::compile(&asset, &reference);
        assert_eq!(derived.meshes[0].primitives[0].targets.len(), 3, "the asset's target and two examples");
        assert_eq!(derived.weight_total, 3);
        let mut gpu_like = Instance::new(&derived);
        gpu_like.set_skinning(&derived, SkinningMethod::SphericalJointBlend);
        for degrees in [0.0f32, 30.0, 90.0, -60.0, -100.0] {
            let rotation = Quat::from_rotation_z(degrees.to_radians());
            let run = |instance: &mut Instance, asset: &Asset, targets: Option<(&mut ExampleTargets, bool)>| {
                instance.evaluate(asset, None, 0.0).expect("rest");
                instance.pose_mut().locals[2].rotation = rotation;
                instance.update(asset).expect("update");
                if let Some((t, on)) = targets {
                    t.write_weights(instance, on).expect("weights");
                }
                let (mut p, mut n) = (Vec::new(), Vec::new());
                instance.deform_primitive(asset, 4, 0, &mut p, &mut n).expect("deform");
                (p, n)
            };
            let (want, want_n) = run(&mut reference, &asset, None);
            let (got, got_n) = run(&mut gpu_like, &derived, Some((&mut targets, true)));
            let far = |a: &[[f32; 3]], b: &[[f32; 3]]| {
                a.iter().zip(b).map(|(a, b)| Vec3::from(*a).distance(Vec3::from(*b))).fold(0.0, f32::max)
            };
            assert!(far(&want, &got) < 1e-5, "{degrees}°: {}", far(&want, &got));
            assert!(far(&want_n, &got_n) < 1e-4, "{degrees}°: normals {}", far(&want_n, &got_n));
            // Off: plain SJB.
            reference.set_skinning(&asset, SkinningMethod::SphericalJointBlend);
            let (sjb, _) = run(&mut reference, &asset, None);
            reference.set_skinning(&asset, SkinningMethod::SphericalJointBlendByExample);
            let (off, _) = run(&mut gpu_like, &derived, Some((&mut targets, false)));
            assert!(far(&sjb, &off) < 1e-6, "{degrees}°: off is not SJB");
        }
    }
}
