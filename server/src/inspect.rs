//! `kloub inspect`: what a glTF file contains, as the core imported it — scenes, skins with
//! their joint hierarchy, clips with every channel, meshes with morph targets, and the
//! importer's warnings. Human-readable text, or JSON with these stable keys:
//!
//! ```text
//! { "asset": "Fox.glb", "default_scene": 0 | null,
//!   "nodes":   [ {"index", "name", "parent": node | null, "mesh": mesh | null, "skin": skin | null} ],
//!   "scenes":  [ {"index", "name", "roots": [node, ...]} ],
//!   "skins":   [ {"index", "name", "skeleton": node | null,
//!                 "joints": [ {"joint", "node", "name", "parent": node | null,
//!                              "parent_joint": joint | null, "depth"} ]} ],
//!   "clips":   [ {"index", "name", "duration", "channel_count",
//!                 "channels": [ {"node", "node_name", "path": "translation" | "rotation" | "scale" | "weights",
//!                                "interpolation": "STEP" | "LINEAR" | "CUBICSPLINE",
//!                                "keys", "start", "end"} ]} ],
//!   "meshes":  [ {"index", "name", "primitives", "vertices", "nodes": [node, ...],
//!                 "morph_targets", "target_names": [..]} ],
//!   "images":  [ {"index", "name", "width", "height", "decoded_bytes"} ],
//!   "extensions_used": ["KHR_...", ...], "extensions_required": [...],
//!   "compressed_views": [ {"view", "extension", "mode", "filter", "compressed_bytes", "decoded_bytes"} ],
//!   "compressed_primitives": [ {"mesh", "primitive", "view", "extension", "compressed_bytes",
//!                               "decoded_bytes", "points", "triangles"} ],
//!   "warnings": [ {"pointer", "message"} ] }
//! ```
//!
//! `name`s are `null` when the file has none. A joint's `parent` is its node's parent;
//! `parent_joint` the nearest ancestor that is a joint of the same skin, and `depth` the number
//! of such ancestors. `start`/`end` are a channel's first and last key times (all channels share
//! the clip's clock from 0).

use crate::pose::{PoseError, import_file};
use kloub_core::Warning;
use kloub_core::asset::{Asset, NodeIndex, Skin};
use kloub_core::clip::{ChannelTarget, Interpolation};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// The JSON document of `kloub inspect --json`.
#[derive(Clone, Debug, Serialize)]
pub struct InspectDoc {
    /// File name.
    pub asset: String,
    /// Every node.
    pub nodes: Vec<NodeOut>,
    /// The scene shown.
    pub default_scene: Option<usize>,
    /// Scenes.
    pub scenes: Vec<SceneOut>,
    /// Skins.
    pub skins: Vec<SkinOut>,
    /// Clips.
    pub clips: Vec<ClipOut>,
    /// Meshes.
    pub meshes: Vec<MeshOut>,
    /// Images, with what each costs decoded (RGBA8, before mips).
    pub images: Vec<ImageOut>,
    /// The file's `extensionsUsed`.
    pub extensions_used: Vec<String>,
    /// The file's `extensionsRequired`.
    pub extensions_required: Vec<String>,
    /// Buffer views stored compressed (meshopt), with what decoding them cost.
    pub compressed_views: Vec<kloub_core::asset::CompressedView>,
    /// Primitives stored compressed (Draco), with what decoding them cost.
    pub compressed_primitives: Vec<kloub_core::asset::CompressedPrimitive>,
    /// Defects the importer repaired.
    pub warnings: Vec<WarningOut>,
}

/// A node.
#[derive(Clone, Debug, Serialize)]
pub struct NodeOut {
    /// glTF index.
    pub index: NodeIndex,
    /// Name.
    pub name: Option<String>,
    /// Parent node.
    pub parent: Option<NodeIndex>,
    /// Mesh it instances.
    pub mesh: Option<u32>,
    /// Skin of that mesh.
    pub skin: Option<u32>,
}

/// A scene.
#[derive(Clone, Debug, Serialize)]
pub struct SceneOut {
    /// glTF index.
    pub index: usize,
    /// Name.
    pub name: Option<String>,
    /// Root nodes.
    pub roots: Vec<NodeIndex>,
}

/// A skin.
#[derive(Clone, Debug, Serialize)]
pub struct SkinOut {
    /// glTF index.
    pub index: usize,
    /// Name.
    pub name: Option<String>,
    /// `skeleton` hint.
    pub skeleton: Option<NodeIndex>,
    /// Joints in skin order.
    pub joints: Vec<JointOut>,
}

/// A joint of a skin.
#[derive(Clone, Debug, Serialize)]
pub struct JointOut {
    /// Index in the skin.
    pub joint: usize,
    /// Node.
    pub node: NodeIndex,
    /// Node name.
    pub name: Option<String>,
    /// Parent node.
    pub parent: Option<NodeIndex>,
    /// Nearest ancestor joint of the same skin.
    pub parent_joint: Option<usize>,
    /// Number of ancestor joints of the same skin.
    pub depth: usize,
}

/// A clip.
#[derive(Clone, Debug, Serialize)]
pub struct ClipOut {
    /// glTF animation index.
    pub index: usize,
    /// Name.
    pub name: Option<String>,
    /// Seconds.
    pub duration: f64,
    /// `channels.len()`.
    pub channel_count: usize,
    /// Channels.
    pub channels: Vec<ChannelOut>,
}

/// An animation channel.
#[derive(Clone, Debug, Serialize)]
pub struct ChannelOut {
    /// Target node.
    pub node: NodeIndex,
    /// Its name.
    pub node_name: Option<String>,
    /// `translation`, `rotation`, `scale` or `weights`.
    pub path: &'static str,
    /// `STEP`, `LINEAR` or `CUBICSPLINE`.
    pub interpolation: &'static str,
    /// Number of keys.
    pub keys: usize,
    /// First key time.
    pub start: f64,
    /// Last key time.
    pub end: f64,
}

/// A mesh.
#[derive(Clone, Debug, Serialize)]
pub struct MeshOut {
    /// glTF index.
    pub index: usize,
    /// Name.
    pub name: Option<String>,
    /// Number of primitives.
    pub primitives: usize,
    /// Vertices over all primitives.
    pub vertices: u64,
    /// Nodes instancing it.
    pub nodes: Vec<NodeIndex>,
    /// Number of morph targets.
    pub morph_targets: usize,
    /// Morph target names (`extras.targetNames`), empty when absent.
    pub target_names: Vec<String>,
}

/// An image.
#[derive(Clone, Debug, Serialize)]
pub struct ImageOut {
    /// glTF index.
    pub index: usize,
    /// Name or URI.
    pub name: Option<String>,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Bytes decoded, RGBA8 (a texture's mips add a third).
    pub decoded_bytes: u64,
}

/// An import warning.
#[derive(Clone, Debug, Serialize)]
pub struct WarningOut {
    /// JSON pointer.
    pub pointer: String,
    /// Message.
    pub message: String,
}

/// Reads and imports `path`, and describes it.
pub fn inspect_file(path: &Path) -> Result<InspectDoc, PoseError> {
    let (name, imported) = import_file(path)?;
    Ok(describe(&name, &imported.asset, &imported.warnings))
}

fn path_name(target: ChannelTarget) -> &'static str {
    match target {
        ChannelTarget::Translation => "translation",
        ChannelTarget::Rotation => "rotation",
        ChannelTarget::Scale => "scale",
        ChannelTarget::Weights => "weights",
    }
}

fn interpolation_name(i: Interpolation) -> &'static str {
    match i {
        Interpolation::Step => "STEP",
        Interpolation::Linear => "LINEAR",
        Interpolation::CubicSpline => "CUBICSPLINE",
    }
}

fn node_name(asset: &Asset, node: NodeIndex) -> Option<String> {
    asset.nodes.get(node as usize).and_then(|n| n.name.clone())
}

fn joints(asset: &Asset, skin: &Skin) -> Vec<JointOut> {
    let mut joint_of = vec![None; asset.nodes.len()];
    for (j, &node) in skin.joints.iter().enumerate() {
        if let Some(slot) = joint_of.get_mut(node as usize) {
            slot.get_or_insert(j);
        }
    }
    let parent = |n: NodeIndex| asset.nodes.get(n as usize).and_then(|x| x.parent);
    skin.joints
        .iter()
        .enumerate()
        .map(|(joint, &node)| {
            // The node graph is a forest, so walking up ends.
            let mut ancestors = std::iter::successors(parent(node), |&p| parent(p))
                .filter_map(|p| joint_of.get(p as usize).copied().flatten());
            let parent_joint = ancestors.next();
            let depth = parent_joint.map_or(0, |_| 1 + ancestors.count());
            JointOut { joint, node, name: node_name(asset, node), parent: parent(node), parent_joint, depth }
        })
        .collect()
}

/// Describes an imported asset.
pub fn describe(asset_name: &str, asset: &Asset, warnings: &[Warning]) -> InspectDoc {
    InspectDoc {
        asset: asset_name.to_owned(),
        nodes: (0..)
            .zip(&asset.nodes)
            .map(|(index, n)| NodeOut { index, name: n.name.clone(), parent: n.parent, mesh: n.mesh, skin: n.skin })
            .collect(),
        default_scene: asset.default_scene,
        scenes: asset
            .scenes
            .iter()
            .enumerate()
            .map(|(index, s)| SceneOut { index, name: s.name.clone(), roots: s.roots.clone() })
            .collect(),
        skins: asset
            .skins
            .iter()
            .enumerate()
            .map(|(index, s)| SkinOut { index, name: s.name.clone(), skeleton: s.skeleton, joints: joints(asset, s) })
            .collect(),
        clips: asset
            .clips
            .iter()
            .enumerate()
            .map(|(index, c)| ClipOut {
                index,
                name: c.name.clone(),
                duration: f64::from(c.duration),
                channel_count: c.channels().len(),
                channels: c
                    .channels()
                    .iter()
                    .map(|ch| ChannelOut {
                        node: ch.node,
                        node_name: node_name(asset, ch.node),
                        path: path_name(ch.target),
                        interpolation: interpolation_name(ch.interpolation),
                        keys: ch.times.len(),
                        start: ch.times.first().map_or(0.0, |&t| f64::from(t)),
                        end: ch.times.last().map_or(0.0, |&t| f64::from(t)),
                    })
                    .collect(),
            })
            .collect(),
        meshes: asset
            .meshes
            .iter()
            .enumerate()
            .map(|(index, m)| MeshOut {
                index,
                name: m.name.clone(),
                primitives: m.primitives.len(),
                vertices: m.primitives.iter().map(|p| u64::from(p.vertex_count)).sum(),
                nodes: (0..asset.nodes.len() as NodeIndex)
                    .filter(|&n| asset.nodes[n as usize].mesh == Some(index as u32))
                    .collect(),
                morph_targets: m.weights.len(),
                target_names: m.target_names.clone(),
            })
            .collect(),
        images: asset
            .images
            .iter()
            .enumerate()
            .map(|(index, i)| ImageOut {
                index,
                name: i.name.clone(),
                width: i.width,
                height: i.height,
                decoded_bytes: u64::from(i.width) * u64::from(i.height) * 4,
            })
            .collect(),
        extensions_used: asset.extensions.used.clone(),
        extensions_required: asset.extensions.required.clone(),
        compressed_views: asset.extensions.compressed_views.clone(),
        compressed_primitives: asset.extensions.compressed_primitives.clone(),
        warnings: warnings
            .iter()
            .map(|w| WarningOut { pointer: w.pointer.clone(), message: w.message.clone() })
            .collect(),
    }
}

/// `"name"` quoted, or `(unnamed)`.
fn label(name: Option<&str>) -> String {
    name.map_or_else(|| "(unnamed)".to_owned(), |n| format!("{n:?}"))
}

/// The human-readable report.
pub fn to_text(doc: &InspectDoc) -> String {
    let mut out = String::new();
    // Writing to a String cannot fail.
    let _ = write_text(doc, &mut out);
    out
}

fn write_text(doc: &InspectDoc, out: &mut String) -> std::fmt::Result {
    writeln!(
        out,
        "{}: {} nodes, {} scenes, {} skins, {} clips, {} meshes, {} warnings",
        doc.asset,
        doc.nodes.len(),
        doc.scenes.len(),
        doc.skins.len(),
        doc.clips.len(),
        doc.meshes.len(),
        doc.warnings.len()
    )?;
    writeln!(out, "\nscenes:")?;
    for s in &doc.scenes {
        let default = if doc.default_scene == Some(s.index) { " (default)" } else { "" };
        writeln!(out, "  {} {}{default}: roots {:?}", s.index, label(s.name.as_deref()), s.roots)?;
    }
    writeln!(out, "\nskins:")?;
    for s in &doc.skins {
        writeln!(out, "  {} {}: {} joints", s.index, label(s.name.as_deref()), s.joints.len())?;
        // Tree order: each joint after its parent joint, siblings by joint index.
        let mut stack: Vec<&JointOut> = s.joints.iter().filter(|j| j.parent_joint.is_none()).rev().collect();
        while let Some(j) = stack.pop() {
            let indent = "  ".repeat(j.depth);
            writeln!(out, "    {indent}{} {} (node {})", j.joint, label(j.name.as_deref()), j.node)?;
            stack.extend(s.joints.iter().filter(|c| c.parent_joint == Some(j.joint)).rev());
        }
    }
    writeln!(out, "\nclips:")?;
    for c in &doc.clips {
        writeln!(out, "  {} {}: {:.3} s, {} channels", c.index, label(c.name.as_deref()), c.duration, c.channel_count)?;
        for ch in &c.channels {
            writeln!(
                out,
                "    node {} {}: {} {}, {} keys, {:.3}–{:.3} s",
                ch.node,
                label(ch.node_name.as_deref()),
                ch.path,
                ch.interpolation,
                ch.keys,
                ch.start,
                ch.end
            )?;
        }
    }
    writeln!(out, "\nmeshes:")?;
    for m in &doc.meshes {
        write!(
            out,
            "  {} {}: {} primitives, {} vertices, nodes {:?}",
            m.index,
            label(m.name.as_deref()),
            m.primitives,
            m.vertices,
            m.nodes
        )?;
        if m.morph_targets > 0 {
            let names = if m.target_names.is_empty() { "unnamed".to_owned() } else { m.target_names.join(", ") };
            write!(out, ", {} morph targets ({names})", m.morph_targets)?;
        }
        writeln!(out)?;
    }
    writeln!(out, "\nimages:")?;
    for i in &doc.images {
        let mb = i.decoded_bytes as f64 / f64::from(1u32 << 20);
        writeln!(out, "  {} {}: {}×{}, {mb:.1} MB decoded", i.index, label(i.name.as_deref()), i.width, i.height)?;
    }
    let list = |names: &[String]| if names.is_empty() { "(none)".to_owned() } else { names.join(", ") };
    writeln!(out, "\nextensions: used {}; required {}", list(&doc.extensions_used), list(&doc.extensions_required))?;
    if !doc.compressed_views.is_empty() {
        let packed: u64 = doc.compressed_views.iter().map(|c| c.compressed_bytes).sum();
        let decoded: u64 = doc.compressed_views.iter().map(|c| c.decoded_bytes).sum();
        writeln!(out, "compressed: {} buffer views, {packed} B decoded to {decoded} B", doc.compressed_views.len())?;
    }
    if !doc.compressed_primitives.is_empty() {
        let packed: u64 = doc.compressed_primitives.iter().map(|c| c.compressed_bytes).sum();
        let decoded: u64 = doc.compressed_primitives.iter().map(|c| c.decoded_bytes).sum();
        writeln!(
            out,
            "compressed: {} Draco primitives, {packed} B decoded to {decoded} B",
            doc.compressed_primitives.len()
        )?;
    }
    writeln!(out, "\nwarnings:")?;
    if doc.warnings.is_empty() {
        writeln!(out, "  (none)")?;
    }
    for w in &doc.warnings {
        writeln!(out, "  {}: {}", w.pointer, w.message)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use kloub_core::asset::{Mesh, Node, Scene};

    /// 0 → 1 → 2 and 0 → 3 (3 not a joint) → 4; skin joints [2, 0, 4].
    fn asset() -> Asset {
        let parents = [None, Some(0), Some(1), Some(0), Some(3)];
        let mut nodes: Vec<Node> = parents
            .iter()
            .enumerate()
            .map(|(i, &parent)| Node { parent, name: Some(format!("n{i}")), ..Node::default() })
            .collect();
        nodes[4].mesh = Some(0);
        Asset {
            nodes,
            order: vec![0, 1, 2, 3, 4],
            scenes: vec![Scene { name: None, roots: vec![0] }],
            default_scene: Some(0),
            skins: vec![Skin {
                name: Some("rig".into()),
                joints: vec![2, 0, 4],
                inverse_bind: vec![Default::default(); 3],
                skeleton: None,
            }],
            meshes: vec![Mesh {
                weights: vec![0.0, 0.0],
                target_names: vec!["a".into(), "b".into()],
                ..Mesh::default()
            }],
            weight_offsets: vec![0; 5],
            ..Asset::default()
        }
    }

    #[test]
    fn joints_know_their_parent_joint_and_depth() {
        let a = asset();
        let doc = describe("x.glb", &a, &[Warning::new("/nodes/1", "fixed")]);
        let j = &doc.skins[0].joints;
        assert_eq!((j[0].node, j[0].parent, j[0].parent_joint, j[0].depth), (2, Some(1), Some(1), 1));
        assert_eq!((j[1].node, j[1].parent, j[1].parent_joint, j[1].depth), (0, None, None, 0));
        assert_eq!((j[2].node, j[2].parent, j[2].parent_joint, j[2].depth), (4, Some(3), Some(1), 1));
        assert_eq!(doc.meshes[0].nodes, vec![4]);
        assert_eq!((doc.nodes[4].parent, doc.nodes[4].mesh), (Some(3), Some(0)));
        assert_eq!(doc.meshes[0].morph_targets, 2);
        let text = to_text(&doc);
        assert!(text.contains("    1 \"n0\" (node 0)\n      0 \"n2\" (node 2)\n      2 \"n4\" (node 4)\n"), "{text}");
        assert!(text.contains("2 morph targets (a, b)"), "{text}");
        assert!(text.contains("  /nodes/1: fixed"), "{text}");
        assert!(text.contains("0 (unnamed) (default): roots [0]"), "{text}");
    }
}
