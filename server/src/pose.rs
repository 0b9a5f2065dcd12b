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
//!
//! Blending (issue 3): with a crossfade or layers the pose comes from a
//! [`kloub_core::Animator`] whose clocks start at 0 and loop (as in the viewer); each `time` is
//! absolute from that start. The document then also has
//!
//! ```text
//!   "crossfade": {"from": <clip>, "to": <clip>, "duration": 0.5, "at": 1.0,
//!                 "easing": "linear" | "smoothstep", "outgoing": "freeze" | "keep" | "sync"},
//!   "layers": [ {"clip": <clip>, "root": {"index": 9, "name": "Abdomen" | null},
//!                "weight": 1.0, "falloff": 0.0, "additive": false}, ... ]
//! ```
//!
//! (`<clip>` as `clip` above; `clip` itself is then the clip playing at time 0: FROM, or the
//! `--clip`.) Both keys are absent without blending, so the plain document is unchanged.

use crate::paths;
use kloub_core::animator::{Crossfade, Easing, Layer, Outgoing};
use kloub_core::asset::{Asset, NodeIndex};
use kloub_core::examples::Examples;
use kloub_core::job::dqs::SkinningMethod;
use kloub_core::math::{Quat, QuatExt};
use kloub_core::{Animator, ImportOptions, Imported, Instance, Resolver, Warning};
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
    /// Crossfade from one clip to another (conflicts with `clip` and `rest`).
    pub crossfade: Option<CrossfadeRequest>,
    /// Layers over the base, applied in order.
    pub layers: Vec<LayerRequest>,
    /// How skinned vertices follow their joints (default: linear blend skinning).
    pub skinning: SkinningMethod,
    /// A `<model>.kloub.json` sidecar's text whose `examples` shape `sjbbe` skinning, and its
    /// name for messages.
    pub examples: Option<(String, String)>,
    /// `JOINT:x,y,z,w`: joints whose local rotation is set after the clip is sampled (joint by
    /// name or node index; the name may contain `:`).
    pub rotations: Vec<String>,
}

/// `--crossfade FROM:TO:DURATION --at T`: FROM plays from 0; at `at` seconds the base starts
/// to crossfade to TO over DURATION seconds.
#[derive(Clone, Debug, PartialEq)]
pub struct CrossfadeRequest {
    /// `FROM:TO:DURATION`, clips by name or index (names may contain `:`).
    pub spec: String,
    /// Start of the crossfade, seconds from the start.
    pub at: f32,
    /// Progress curve.
    pub easing: Easing,
    /// What the outgoing clip does.
    pub outgoing: Outgoing,
}

/// `--layer CLIP:ROOT_JOINT:WEIGHT`: CLIP, on its own clock from 0, on the subtree under
/// ROOT_JOINT.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerRequest {
    /// `CLIP:ROOT_JOINT:WEIGHT`; clip by name or index, joint by name (skin joints first) or
    /// node index (names may contain `:`).
    pub spec: String,
    /// Per-generation falloff in `[0, 1]`.
    pub falloff: f32,
    /// Add the clip's difference from its first frame instead of overriding.
    pub additive: bool,
}

/// The JSON document `kloub pose` prints.
#[derive(Clone, Debug, Serialize)]
pub struct PoseDoc {
    /// File name of the input.
    pub asset: String,
    /// The clip evaluated (with a crossfade: the one playing first); `None` for the rest pose.
    pub clip: Option<ClipInfo>,
    /// The crossfade, when one was asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crossfade: Option<CrossfadeInfo>,
    /// The layers, when any were asked for.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub layers: Vec<LayerInfo>,
    /// The skinning method (`"rigid"`, `"dqs"`, `"sjb"`), when not the default linear blend skinning.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub skinning: Option<&'static str>,
    /// One frame per requested time.
    pub frames: Vec<Frame>,
}

/// The crossfade of a [`PoseDoc`].
#[derive(Clone, Debug, Serialize)]
pub struct CrossfadeInfo {
    /// The clip playing from time 0.
    pub from: ClipInfo,
    /// The clip faded to.
    pub to: ClipInfo,
    /// Seconds the crossfade lasts.
    pub duration: f64,
    /// Seconds from the start when it begins.
    pub at: f64,
    /// `"linear"` or `"smoothstep"`.
    pub easing: &'static str,
    /// `"freeze"`, `"keep"` or `"sync"`.
    pub outgoing: &'static str,
}

/// One layer of a [`PoseDoc`].
#[derive(Clone, Debug, Serialize)]
pub struct LayerInfo {
    /// The layer's clip.
    pub clip: ClipInfo,
    /// Root of the affected subtree.
    pub root: NodeRef,
    /// Weight.
    pub weight: f64,
    /// Per-generation falloff.
    pub falloff: f64,
    /// Additive (true) or overriding (false).
    pub additive: bool,
}

/// A node by index and name.
#[derive(Clone, Debug, Serialize)]
pub struct NodeRef {
    /// glTF node index.
    pub index: u32,
    /// `name` from the file.
    pub name: Option<String>,
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
    /// With `--skinning sjb`, on skinned primitives: how many vertices have no shared joint
    /// centre and are skinned by dual quaternions instead.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sjb_fallbacks: Option<usize>,
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
        Self { pointer, message: message.into() }
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

/// Why the `kloub` tool does not load an absolute `http(s):` URI.
pub const WEB_URI: &str = "the kloub tool reads only local files (the viewer fetches web addresses): download it \
                           beside the glTF file and name it by a relative URI";

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
        Ok(Self { dir: paths::canonical_root(dir)?, max_bytes })
    }
}

impl Resolver for DirResolver {
    fn resolve(&self, uri: &str) -> Result<Vec<u8>, String> {
        if kloub_core::import::is_web_uri(uri) {
            return Err(WEB_URI.to_owned());
        }
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

/// Reads and imports the file at `path` (external files from its folder); returns its file
/// name and the import result. A zip archive (`.zip`, by its contents) is read in memory by
/// [`kloub_core::archive`]: its first `.glb`/`.gltf` is imported, resolving URIs among the
/// archive's files; what the archive left out, and its other models, become warnings.
pub fn import_file(path: &Path) -> Result<(String, Imported), PoseError> {
    let options = ImportOptions::default();
    let bytes =
        read_limited(path, options.budget_bytes).map_err(|e| PoseError::new(None, format!("cannot read: {e}")))?;
    if kloub_core::archive::is_zip(&bytes) {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        return import_archive(&name, &bytes, &options);
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let resolver = DirResolver::new(dir, options.budget_bytes)
        .map_err(|e| PoseError::new(None, format!("cannot open its folder: {e}")))?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let imported = import_bytes(&bytes, &resolver, &options)?;
    Ok((name, imported))
}

/// Imports the first model of the zip archive `bytes` (named `archive_name`); its name is
/// `ARCHIVE/PATH/MODEL`.
///
/// # Errors
/// An unreadable or over-budget archive, one without a model, or the model's import error.
pub fn import_archive(
    archive_name: &str,
    bytes: &[u8],
    options: &ImportOptions,
) -> Result<(String, Imported), PoseError> {
    let limits = kloub_core::archive::ArchiveLimits { max_bytes: options.budget_bytes, ..Default::default() };
    let archive = kloub_core::archive::read_zip(bytes, &limits)
        .map_err(|e| PoseError::new(None, format!("{archive_name}: {e}")))?;
    let models: Vec<String> = archive.models().into_iter().map(str::to_owned).collect();
    let Some(first) = models.first().map(String::as_str) else {
        return Err(PoseError::new(None, format!("{archive_name}: the archive holds no .glb or .gltf model")));
    };
    let folder = first.rsplit_once('/').map_or("", |(dir, _)| dir);
    let mut resolver = kloub_core::MapResolver::new();
    let mut model = None;
    for entry in &archive.entries {
        if entry.path == first {
            model = Some(&entry.bytes);
        } else if folder.is_empty() {
            resolver.insert(entry.path.clone(), entry.bytes.clone());
        } else if let Some(rel) = entry.path.strip_prefix(folder).and_then(|r| r.strip_prefix('/')) {
            resolver.insert(rel.to_owned(), entry.bytes.clone());
        }
    }
    let model = model.ok_or_else(|| PoseError::new(None, format!("{archive_name}: {first} vanished")))?;
    let mut imported = import_bytes(model, &resolver, options)?;
    let mut notes: Vec<Warning> = archive.skipped.iter().map(|m| Warning::new("", m.as_str())).collect();
    if models.len() > 1 {
        notes.push(Warning::new(
            "",
            format!("the archive holds {} models ({}); this is {first}", models.len(), models.join(", ")),
        ));
    }
    imported.warnings.splice(0..0, notes);
    Ok((format!("{archive_name}/{first}"), imported))
}

/// Imports `bytes` (GLB or .gltf), turning an import error into a [`PoseError`].
pub fn import_bytes(bytes: &[u8], resolver: &dyn Resolver, options: &ImportOptions) -> Result<Imported, PoseError> {
    kloub_core::import(bytes, resolver, options)
        .map_err(|e| PoseError::new(Some(e.pointer).filter(|p| !p.is_empty()), e.message))
}

/// Reads, imports and evaluates the file at `path` (external files from its folder).
pub fn pose_file(path: &Path, request: &PoseRequest) -> Result<PoseReport, PoseError> {
    let (name, imported) = import_file(path)?;
    let doc = pose_asset(&name, &imported.asset, request)?;
    Ok(PoseReport { doc, warnings: imported.warnings })
}

/// Imports `bytes` (GLB or .gltf) and evaluates it; `asset_name` goes into the document.
pub fn pose_bytes(
    asset_name: &str,
    bytes: &[u8],
    resolver: &dyn Resolver,
    options: &ImportOptions,
    request: &PoseRequest,
) -> Result<PoseReport, PoseError> {
    let imported = import_bytes(bytes, resolver, options)?;
    let doc = pose_asset(asset_name, &imported.asset, request)?;
    Ok(PoseReport { doc, warnings: imported.warnings })
}

/// `"0 \"Walk\", 1 (unnamed)"`, or a note that there are none.
fn available_clips(asset: &Asset) -> String {
    if asset.clips.is_empty() {
        return "the file has no clips".to_owned();
    }
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
    Err(PoseError::new(Some("/animations".into()), format!("no clip {wanted:?}; {}", available_clips(asset))))
}

/// A node by name (a skin joint of that name first, then any node) or decimal index.
pub fn find_node(asset: &Asset, name_or_index: &str) -> Option<NodeIndex> {
    let named = |n: &NodeIndex| asset.nodes.get(*n as usize).and_then(|x| x.name.as_deref()) == Some(name_or_index);
    asset
        .skins
        .iter()
        .flat_map(|s| s.joints.iter().copied())
        .find(named)
        .or_else(|| (0..asset.nodes.len() as NodeIndex).find(named))
        .or_else(|| name_or_index.parse::<NodeIndex>().ok().filter(|&i| (i as usize) < asset.nodes.len()))
}

/// Splits `A:B` at the first `:` where both halves resolve (names may contain `:`).
fn split_pair<T, U>(text: &str, left: impl Fn(&str) -> Option<T>, right: impl Fn(&str) -> Option<U>) -> Option<(T, U)> {
    text.match_indices(':').find_map(|(i, _)| {
        let (a, b) = (&text[..i], &text[i + 1..]);
        Some((left(a)?, right(b)?))
    })
}

/// `…:NUMBER`: the text before the last `:` and the number after it (finite, ≥ 0).
fn split_number<'s>(spec: &'s str, flag: &str, shape: &str) -> Result<(&'s str, f32), PoseError> {
    let bad = |why: &str| PoseError::new(None, format!("{flag} {spec:?}: {why}; expected {shape}"));
    let (head, number) = spec.rsplit_once(':').ok_or_else(|| bad("no ':'"))?;
    let value: f32 = number.trim().parse().map_err(|_| bad(&format!("{number:?} is not a number")))?;
    if !(value.is_finite() && value >= 0.0) {
        return Err(bad(&format!("{number} must be a finite number ≥ 0")));
    }
    Ok((head, value))
}

fn clip_info(asset: &Asset, index: usize) -> Option<ClipInfo> {
    let c = asset.clips.get(index)?;
    Some(ClipInfo { index, name: c.name.clone(), duration: f64::from(c.duration) })
}

fn easing_name(e: Easing) -> &'static str {
    match e {
        Easing::Linear => "linear",
        Easing::SmoothStep => "smoothstep",
    }
}

fn outgoing_name(o: Outgoing) -> &'static str {
    match o {
        Outgoing::Freeze => "freeze",
        Outgoing::KeepPlaying => "keep",
        Outgoing::SyncTime => "sync",
    }
}

/// A resolved `--crossfade`.
struct Fade {
    from: usize,
    to: usize,
    at: f32,
    settings: Crossfade,
}

fn resolve_crossfade(asset: &Asset, request: &CrossfadeRequest) -> Result<Fade, PoseError> {
    let shape = "FROM:TO:DURATION with clips by name or index";
    let (pair, duration) = split_number(&request.spec, "--crossfade", shape)?;
    let (from, to) = split_pair(pair, |a| asset.find_clip(a), |b| asset.find_clip(b)).ok_or_else(|| {
        PoseError::new(
            Some("/animations".into()),
            format!("--crossfade {:?}: no such pair of clips; {}", request.spec, available_clips(asset)),
        )
    })?;
    if !(request.at.is_finite() && request.at >= 0.0) {
        return Err(PoseError::new(None, format!("--at {} must be a finite time ≥ 0", request.at)));
    }
    Ok(Fade {
        from,
        to,
        at: request.at,
        settings: Crossfade { duration, easing: request.easing, outgoing: request.outgoing },
    })
}

fn resolve_layer(asset: &Asset, request: &LayerRequest) -> Result<(Layer, LayerInfo), PoseError> {
    let shape = "CLIP:ROOT_JOINT:WEIGHT with the clip by name or index and the joint by name or node index";
    let (pair, weight) = split_number(&request.spec, "--layer", shape)?;
    let (clip, root) = split_pair(pair, |a| asset.find_clip(a), |b| find_node(asset, b)).ok_or_else(|| {
        PoseError::new(
            None,
            format!(
                "--layer {:?}: no clip and node of those names; clips {}; `kloub inspect` lists the joints",
                request.spec,
                available_clips(asset)
            ),
        )
    })?;
    if !(0.0..=1.0).contains(&request.falloff) {
        return Err(PoseError::new(None, format!("--layer-falloff {} is outside [0, 1]", request.falloff)));
    }
    let mut layer = Layer::new(clip, root);
    layer.weight = weight;
    layer.falloff = request.falloff;
    layer.additive = request.additive;
    let info = LayerInfo {
        clip: clip_info(asset, clip).ok_or_else(|| PoseError::new(None, "internal: clip vanished"))?,
        root: NodeRef { index: root, name: asset.nodes.get(root as usize).and_then(|n| n.name.clone()) },
        weight: f64::from(weight),
        falloff: f64::from(request.falloff),
        additive: request.additive,
    };
    Ok((layer, info))
}

/// The animator for one requested time: base clip, layers, crossfade, advanced to `time`.
fn animate(
    asset: &Asset,
    base: Option<usize>,
    fade: Option<&Fade>,
    layers: &[Layer],
    time: f32,
) -> Result<Animator, kloub_core::JobError> {
    let mut animator = Animator::new(asset);
    animator.play(asset, fade.map(|f| f.from).or(base))?;
    for layer in layers {
        animator.add_layer(asset, layer.clone())?;
    }
    match fade {
        Some(f) if time > f.at => {
            animator.advance(asset, f.at);
            animator.crossfade_to(asset, Some(f.to), f.settings)?;
            animator.advance(asset, time - f.at);
        }
        _ => {
            animator.advance(asset, time);
        }
    }
    Ok(animator)
}

/// Evaluates an imported asset at every requested time.
pub fn pose_asset(asset_name: &str, asset: &Asset, request: &PoseRequest) -> Result<PoseDoc, PoseError> {
    let fade = request.crossfade.as_ref().map(|c| resolve_crossfade(asset, c)).transpose()?;
    let clip = match &fade {
        Some(f) => Some(f.from),
        None => select_clip(asset, request)?,
    };
    let playing = clip.and_then(|index| clip_info(asset, index));
    let crossfade = match (&fade, &request.crossfade) {
        (Some(f), Some(r)) => Some(CrossfadeInfo {
            from: clip_info(asset, f.from).ok_or_else(|| PoseError::new(None, "internal: clip vanished"))?,
            to: clip_info(asset, f.to).ok_or_else(|| PoseError::new(None, "internal: clip vanished"))?,
            duration: f64::from(f.settings.duration),
            at: f64::from(f.at),
            easing: easing_name(r.easing),
            outgoing: outgoing_name(r.outgoing),
        }),
        _ => None,
    };
    let (layers, layer_infos): (Vec<Layer>, Vec<LayerInfo>) =
        request.layers.iter().map(|l| resolve_layer(asset, l)).collect::<Result<Vec<_>, _>>()?.into_iter().unzip();
    let blending = fade.is_some() || !layers.is_empty();
    let times: &[f32] = if request.times.is_empty() { &[0.0] } else { &request.times };
    if let Some(t) = times.iter().find(|t| !t.is_finite()) {
        return Err(PoseError::new(None, format!("time {t} is not a finite number")));
    }
    if let Some(t) = times.iter().find(|&&t| blending && t < 0.0) {
        return Err(PoseError::new(
            None,
            format!("time {t}: with --crossfade or --layer, times count from the start and must be ≥ 0"),
        ));
    }

    let rotations = request.rotations.iter().map(|spec| parse_rotation(asset, spec)).collect::<Result<Vec<_>, _>>()?;
    let scene = asset.scene_nodes();
    let mut instance = Instance::new(asset);
    instance.set_skinning(asset, request.skinning);
    if let Some((name, text)) = &request.examples {
        let examples = Examples::from_json(asset, text).map_err(|e| PoseError::new(None, format!("{name}: {e}")))?;
        instance.set_examples(asset, &examples).map_err(|e| PoseError::new(None, format!("{name}: {e}")))?;
    }
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut frames = Vec::with_capacity(times.len());
    for &time in times {
        let clip_pointer = clip.map(|c| format!("/animations/{c}"));
        let evaluated = if blending {
            animate(asset, clip, fade.as_ref(), &layers, time)
                .and_then(|mut animator| animator.evaluate(asset, &mut instance))
        } else {
            instance.evaluate(asset, clip, time)
        };
        evaluated.map_err(|e| PoseError::new(clip_pointer, e.to_string()))?;
        if !rotations.is_empty() {
            for &(node, rotation) in &rotations {
                if let Some(local) = instance.pose_mut().locals.get_mut(node as usize) {
                    local.rotation = rotation;
                }
            }
            instance.update(asset).map_err(|e| PoseError::new(None, e.to_string()))?;
        }

        let worlds = instance.worlds();
        if worlds.len() != asset.nodes.len() {
            return Err(PoseError::new(None, "internal: world matrices do not match the nodes"));
        }
        let mut nodes = Vec::with_capacity(asset.nodes.len());
        for (index, (node, world)) in (0u32..).zip(asset.nodes.iter().zip(worlds)) {
            nodes.push(NodeOut { index, name: node.name.clone(), world: widen(&world.to_cols_array(), index)? });
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
            let count = asset.meshes.get(mesh as usize).map_or(0, |m| m.primitives.len());
            for primitive in 0..count {
                instance.deform_primitive(asset, node, primitive, &mut positions, &mut normals).map_err(|e| {
                    PoseError::new(Some(format!("/meshes/{mesh}/primitives/{primitive}")), e.to_string())
                })?;
                let flat: Vec<f32> = positions.iter().flatten().copied().collect();
                let sjb_fallbacks = request
                    .skinning
                    .uses_sjb_plan()
                    .then(|| instance.sjb_plan(asset, node, primitive).map(|p| p.fallbacks))
                    .flatten();
                primitives.push(PrimitiveOut {
                    node,
                    mesh,
                    primitive,
                    count: positions.len(),
                    positions: widen_vec(&flat, node)?,
                    sjb_fallbacks,
                });
            }
        }
        frames.push(Frame { time: f64::from(time), nodes, weights, primitives });
    }
    Ok(PoseDoc {
        asset: asset_name.to_owned(),
        clip: playing,
        crossfade,
        layers: layer_infos,
        skinning: (request.skinning != SkinningMethod::Linear).then(|| request.skinning.name()),
        frames,
    })
}

/// `JOINT:x,y,z,w` → (node, unit rotation).
fn parse_rotation(asset: &Asset, spec: &str) -> Result<(u32, Quat), PoseError> {
    let bad = |why: String| PoseError::new(None, format!("--rotate {spec:?}: {why}"));
    let (joint, quat) = spec.rsplit_once(':').ok_or_else(|| bad("expected JOINT:x,y,z,w".into()))?;
    let node = asset
        .nodes
        .iter()
        .position(|n| n.name.as_deref() == Some(joint))
        .or_else(|| joint.parse::<usize>().ok().filter(|&i| i < asset.nodes.len()))
        .ok_or_else(|| bad(format!("no joint named {joint:?} (or node index) in the file")))?;
    let xs: Vec<f32> =
        quat.split(',').map(|x| x.trim().parse::<f32>()).collect::<Result<_, _>>().map_err(|e| bad(e.to_string()))?;
    let [x, y, z, w] = xs[..] else { return Err(bad(format!("{} numbers; expected x,y,z,w", xs.len()))) };
    let q = Quat::from_xyzw(x, y, z, w)
        .check_unit()
        .map_err(|length| bad(format!("not a unit quaternion (length {length})")))?;
    Ok((node as u32, q.normalize()))
}

fn widen_vec(values: &[f32], node: u32) -> Result<Vec<f64>, PoseError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(values.iter().map(|&v| f64::from(v)).collect())
    } else {
        Err(PoseError::new(Some(format!("/nodes/{node}")), "the pose is not finite"))
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
        assert_eq!(back, f64::from(0.1f32), "the exact f32 value, not the nearest f64 to 0.1");
    }

    #[test]
    fn weights_serialize_as_an_object_in_node_order() {
        let w = NodeWeights(vec![(2, vec![0.5]), (10, vec![0.25, 1.0])]);
        assert_eq!(serde_json::to_string(&w).expect("ok"), r#"{"2":[0.5],"10":[0.25,1.0]}"#);
    }

    #[test]
    fn error_display_has_pointer_then_message() {
        let e = PoseError::new(Some("/animations".into()), "no clip");
        assert_eq!(e.to_string(), "/animations: no clip");
        assert_eq!(PoseError::new(None, "cannot read").to_string(), "cannot read");
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
        for uri in ["../secret.bin", "%2e%2e/secret.bin", "/etc/passwd", "c:/x.bin", "..\\x"] {
            let err = r.resolve(uri).expect_err(uri);
            assert!(err.contains("refused") || err.contains("no such file"), "{uri}: {err}");
        }
        assert!(r.resolve("../secret.bin").expect_err("escapes").contains("refused"));
        // A web address: not downloaded, and said so (the whole import names the URI's pointer).
        assert_eq!(r.resolve("https://cdn.example/a%20b.bin"), Err(WEB_URI.to_owned()));
        let gltf =
            br#"{"asset": {"version": "2.0"}, "buffers": [{"byteLength": 3, "uri": "HTTPS://cdn.example/a.bin"}]}"#;
        let e = kloub_core::import(gltf, &r, &ImportOptions::default()).expect_err("not fetched");
        assert_eq!(e.pointer, "/buffers/0/uri");
        assert!(e.message.contains("HTTPS://cdn.example/a.bin") && e.message.contains("local files"), "{e}");
        let small = DirResolver::new(&base.join("model"), 2).expect("folder exists");
        assert!(small.resolve("a%20b.bin").expect_err("too big").contains("budget"));
        std::fs::remove_dir_all(&base).expect("cleanup");
    }
}
