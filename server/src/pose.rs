//! `kloub pose`: evaluate a glTF file headless with the same core code the viewer runs, and
//! describe the result as JSON (the contract of issue 2):
//!
//! ```text
//! { "asset": "<file name>",
//!   "clip": {"index": 0, "name": "Walk" | null, "duration": 0.708} | null,
//!   "frames": [ { "time": 0.25,
//!       "nodes": [ {"index": 0, "name": "root" | null, "world": [16 floats, column-major]}, ... ],
//!       "weights": { "<node index>": [morph weights], ... },
//!       "primitives": [ {"node": 3, "mesh": 0, "primitive": 0, "count": 1728,
//!                        "positions": [x0, y0, z0, x1, ...]}, ... ] } ] }
//! ```
//!
//! Every float is an `f32` of the core written as the `f64` of the same value, so parsing it
//! back as `f64` and narrowing gives the exact `f32` bits. `nodes` lists every glTF node by
//! index; `weights` every node that has morph weights; `primitives` one entry per (node,
//! primitive) for every node of the default scene that instances a mesh, in world space after
//! morphing and skinning ([`Instance::deform_primitive`]).

use crate::paths;
use kloub_core::asset::Asset;
use kloub_core::{ImportOptions, Instance, Resolver, Warning};
use serde::Serialize;
use serde::ser::SerializeMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// What to evaluate.
#[derive(Clone, Debug, Default)]
pub struct PoseRequest {
    /// Clip by name or decimal index; `None` = clip 0 when the file has clips.
    pub clip: Option<String>,
    /// Times in seconds; empty = `[0.0]`.
    pub times: Vec<f32>,
    /// Rest pose: no clip at all.
    pub rest: bool,
}

/// The JSON document `kloub pose` prints.
#[derive(Clone, Debug, Serialize)]
pub struct PoseDoc {
    /// File name of the input.
    pub asset: String,
    /// The clip evaluated; `None` for the rest pose.
    pub clip: Option<ClipInfo>,
    /// One frame per requested time.
    pub frames: Vec<Frame>,
}

/// The clip of a [`PoseDoc`].
#[derive(Clone, Debug, Serialize)]
pub struct ClipInfo {
    /// glTF animation index.
    pub index: usize,
    /// `name` from the file, `None` when it has none.
    pub name: Option<String>,
    /// Duration in seconds.
    pub duration: f64,
}

/// The pose at one time.
#[derive(Clone, Debug, Serialize)]
pub struct Frame {
    /// Requested time in seconds (the core clamps it to the clip's range).
    pub time: f64,
    /// Every node, by index.
    pub nodes: Vec<NodeOut>,
    /// Morph weights by node index, for nodes that have any.
    pub weights: NodeWeights,
    /// Deformed primitives of the default scene.
    pub primitives: Vec<PrimitiveOut>,
}

/// One node's world transform.
#[derive(Clone, Debug, Serialize)]
pub struct NodeOut {
    /// glTF node index.
    pub index: u32,
    /// `name` from the file.
    pub name: Option<String>,
    /// World matrix, column-major.
    pub world: [f64; 16],
}

/// Morph weights by node index, written as a JSON object keyed by the decimal index,
/// in increasing node order.
#[derive(Clone, Debug, Default)]
pub struct NodeWeights(pub Vec<(u32, Vec<f64>)>);

impl Serialize for NodeWeights {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.0.len()))?;
        for (node, weights) in &self.0 {
            map.serialize_entry(&node.to_string(), weights)?;
        }
        map.end()
    }
}

/// World-space positions of one primitive instanced by one node.
#[derive(Clone, Debug, Serialize)]
pub struct PrimitiveOut {
    /// Node instancing the mesh.
    pub node: u32,
    /// Mesh index.
    pub mesh: u32,
    /// Primitive index within the mesh.
    pub primitive: usize,
    /// Vertex count (`positions.len() / 3`).
    pub count: usize,
    /// `x0, y0, z0, x1, ...` after morphing and skinning.
    pub positions: Vec<f64>,
}

/// A pose document plus the importer's warnings.
#[derive(Clone, Debug)]
pub struct PoseReport {
    /// The document to print.
    pub doc: PoseDoc,
    /// Defects the importer repaired.
    pub warnings: Vec<Warning>,
}

/// Why `kloub pose` failed: a JSON pointer into the file when one applies, and a message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PoseError {
    /// JSON pointer of the offending element (`/animations/0`), if any.
    pub pointer: Option<String>,
    /// What went wrong.
    pub message: String,
}

impl PoseError {
    fn new(pointer: Option<String>, message: impl Into<String>) -> Self {
        Self {
            pointer,
            message: message.into(),
        }
    }
}

impl fmt::Display for PoseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.pointer {
            Some(p) => write!(f, "{p}: {}", self.message),
            None => f.write_str(&self.message),
        }
    }
}

impl std::error::Error for PoseError {}

/// Resolves a glTF file's external URIs to files in its folder (or below it).
/// URIs that leave the folder (`..`, absolute or drive paths, symlinks out) are refused.
#[derive(Clone, Debug)]
pub struct DirResolver {
    dir: PathBuf,
    max_bytes: u64,
}

impl DirResolver {
    /// A resolver for files under `dir`, refusing files larger than `max_bytes`.
    pub fn new(dir: &Path, max_bytes: u64) -> std::io::Result<Self> {
        Ok(Self {
            dir: paths::canonical_root(dir)?,
            max_bytes,
        })
    }
}

impl Resolver for DirResolver {
    fn resolve(&self, uri: &str) -> Result<Vec<u8>, String> {
        let path = paths::resolve_file(&self.dir, uri).map_err(|r| match r {
            paths::Refusal::Unsafe => "refused: the uri leaves the file's folder".to_owned(),
            paths::Refusal::NotFound => "no such file beside the glTF file".to_owned(),
        })?;
        read_limited(&path, self.max_bytes)
    }
}

fn read_limited(path: &Path, max_bytes: u64) -> Result<Vec<u8>, String> {
    let len = std::fs::metadata(path).map_err(|e| e.to_string())?.len();
    if len > max_bytes {
        return Err(format!("{len} bytes is over the {max_bytes}-byte budget"));
    }
    std::fs::read(path).map_err(|e| e.to_string())
}

/// Reads, imports and evaluates the file at `path` (external files from its folder).
pub fn pose_file(path: &Path, request: &PoseRequest) -> Result<PoseReport, PoseError> {
    let options = ImportOptions::default();
    let bytes = read_limited(path, options.budget_bytes)
        .map_err(|e| PoseError::new(None, format!("cannot read: {e}")))?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let resolver = DirResolver::new(dir, options.budget_bytes)
        .map_err(|e| PoseError::new(None, format!("cannot open its folder: {e}")))?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    pose_bytes(&name, &bytes, &resolver, &options, request)
}

/// Imports `bytes` (GLB or .gltf) and evaluates it; `asset_name` goes into the document.
pub fn pose_bytes(
    asset_name: &str,
    bytes: &[u8],
    resolver: &dyn Resolver,
    options: &ImportOptions,
    request: &PoseRequest,
) -> Result<PoseReport, PoseError> {
    let imported = kloub_core::import(bytes, resolver, options)
        .map_err(|e| PoseError::new(Some(e.pointer).filter(|p| !p.is_empty()), e.message))?;
    let doc = pose_asset(asset_name, &imported.asset, request)?;
    Ok(PoseReport {
        doc,
        warnings: imported.warnings,
    })
}

/// Picks the clip a request asks for: `None` for `rest` or a file without clips.
pub fn select_clip(asset: &Asset, request: &PoseRequest) -> Result<Option<usize>, PoseError> {
    if request.rest {
        return Ok(None);
    }
    let Some(wanted) = &request.clip else {
        return Ok((!asset.clips.is_empty()).then_some(0));
    };
    if let Some(index) = asset.find_clip(wanted) {
        return Ok(Some(index));
    }
    let available = if asset.clips.is_empty() {
        "the file has no clips".to_owned()
    } else {
        let list: Vec<String> = asset
            .clips
            .iter()
            .enumerate()
            .map(|(i, c)| match &c.name {
                Some(n) => format!("{i} {n:?}"),
                None => format!("{i} (unnamed)"),
            })
            .collect();
        format!("available: {}", list.join(", "))
    };
    Err(PoseError::new(
        Some("/animations".into()),
        format!("no clip {wanted:?}; {available}"),
    ))
}

/// Evaluates an imported asset at every requested time.
pub fn pose_asset(
    asset_name: &str,
    asset: &Asset,
    request: &PoseRequest,
) -> Result<PoseDoc, PoseError> {
    let clip = select_clip(asset, request)?;
    let clip_info = clip.and_then(|index| {
        let c = asset.clips.get(index)?;
        Some(ClipInfo {
            index,
            name: c.name.clone(),
            duration: f64::from(c.duration),
        })
    });
    let times: &[f32] = if request.times.is_empty() {
        &[0.0]
    } else {
        &request.times
    };
    if let Some(t) = times.iter().find(|t| !t.is_finite()) {
        return Err(PoseError::new(
            None,
            format!("time {t} is not a finite number"),
        ));
    }

    let scene = asset.scene_nodes();
    let mut instance = Instance::new(asset);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut frames = Vec::with_capacity(times.len());
    for &time in times {
        let clip_pointer = clip.map(|c| format!("/animations/{c}"));
        instance
            .evaluate(asset, clip, time)
            .map_err(|e| PoseError::new(clip_pointer, e.to_string()))?;

        let worlds = instance.worlds();
        if worlds.len() != asset.nodes.len() {
            return Err(PoseError::new(
                None,
                "internal: world matrices do not match the nodes",
            ));
        }
        let mut nodes = Vec::with_capacity(asset.nodes.len());
        for (index, (node, world)) in (0u32..).zip(asset.nodes.iter().zip(worlds)) {
            nodes.push(NodeOut {
                index,
                name: node.name.clone(),
                world: widen(&world.to_cols_array(), index)?,
            });
        }

        let mut weights = NodeWeights::default();
        for (index, node) in (0u32..).zip(&asset.nodes) {
            if !node.weights.is_empty() {
                let w = instance.node_weights(asset, index);
                weights.0.push((index, widen_vec(w, index)?));
            }
        }

        let mut primitives = Vec::new();
        for &node in &scene {
            let Some(mesh) = asset.nodes.get(node as usize).and_then(|n| n.mesh) else {
                continue;
            };
            let count = asset
                .meshes
                .get(mesh as usize)
                .map_or(0, |m| m.primitives.len());
            for primitive in 0..count {
                instance
                    .deform_primitive(asset, node, primitive, &mut positions, &mut normals)
                    .map_err(|e| {
                        PoseError::new(
                            Some(format!("/meshes/{mesh}/primitives/{primitive}")),
                            e.to_string(),
                        )
                    })?;
                let flat: Vec<f32> = positions.iter().flatten().copied().collect();
                primitives.push(PrimitiveOut {
                    node,
                    mesh,
                    primitive,
                    count: positions.len(),
                    positions: widen_vec(&flat, node)?,
                });
            }
        }
        frames.push(Frame {
            time: f64::from(time),
            nodes,
            weights,
            primitives,
        });
    }
    Ok(PoseDoc {
        asset: asset_name.to_owned(),
        clip: clip_info,
        frames,
    })
}

fn widen_vec(values: &[f32], node: u32) -> Result<Vec<f64>, PoseError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(values.iter().map(|&v| f64::from(v)).collect())
    } else {
        Err(PoseError::new(
            Some(format!("/nodes/{node}")),
            "the pose is not finite",
        ))
    }
}

fn widen(values: &[f32; 16], node: u32) -> Result<[f64; 16], PoseError> {
    let v = widen_vec(values, node)?;
    let mut out = [0.0; 16];
    out.copy_from_slice(&v);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_values_print_exactly() {
        let json = serde_json::to_string(&f64::from(0.1f32)).expect("serializes");
        let back: f64 = serde_json::from_str(&json).expect("parses");
        assert_eq!(back as f32, 0.1f32);
        assert_eq!(
            back,
            f64::from(0.1f32),
            "the exact f32 value, not the nearest f64 to 0.1"
        );
    }

    #[test]
    fn weights_serialize_as_an_object_in_node_order() {
        let w = NodeWeights(vec![(2, vec![0.5]), (10, vec![0.25, 1.0])]);
        assert_eq!(
            serde_json::to_string(&w).expect("ok"),
            r#"{"2":[0.5],"10":[0.25,1.0]}"#
        );
    }

    #[test]
    fn error_display_has_pointer_then_message() {
        let e = PoseError::new(Some("/animations".into()), "no clip");
        assert_eq!(e.to_string(), "/animations: no clip");
        assert_eq!(
            PoseError::new(None, "cannot read").to_string(),
            "cannot read"
        );
    }

    #[test]
    fn resolver_refuses_escaping_uris() {
        let base = std::env::temp_dir().join(format!("kloub-resolver-{}", std::process::id()));
        std::fs::create_dir_all(base.join("model")).expect("temp dir is writable");
        std::fs::write(base.join("model/a b.bin"), [1u8, 2, 3]).expect("write");
        std::fs::write(base.join("secret.bin"), [9u8]).expect("write");
        let r = DirResolver::new(&base.join("model"), 1 << 20).expect("folder exists");
        assert_eq!(r.resolve("a%20b.bin"), Ok(vec![1, 2, 3]));
        assert_eq!(r.resolve("./a%20b.bin"), Ok(vec![1, 2, 3]));
        for uri in [
            "../secret.bin",
            "%2e%2e/secret.bin",
            "/etc/passwd",
            "c:/x.bin",
            "..\\x",
        ] {
            let err = r.resolve(uri).expect_err(uri);
            assert!(
                err.contains("refused") || err.contains("no such file"),
                "{uri}: {err}"
            );
        }
        assert!(
            r.resolve("../secret.bin")
                .expect_err("escapes")
                .contains("refused")
        );
        let small = DirResolver::new(&base.join("model"), 2).expect("folder exists");
        assert!(
            small
                .resolve("a%20b.bin")
                .expect_err("too big")
                .contains("budget")
        );
        std::fs::remove_dir_all(&base).expect("cleanup");
    }
}
