//! glTF 2.0 import: bytes (GLB or .gltf JSON) → validated [`Asset`] plus warnings.
//!
//! Every size the document declares is checked before anything is allocated: buffer
//! lengths and decoded accessors against [`ImportOptions::budget_bytes`], accessor
//! layouts against their buffer views with checked 64-bit arithmetic, image dimensions
//! from their headers. Every index is checked, the node graph must be a forest no deeper
//! than [`ImportOptions::max_node_depth`]. Errors name the JSON pointer of the offending
//! element; repairable defects become [`Warning`]s.

mod accessor;
mod anim;
mod container;
mod draco;
pub use container::{glb, is_web_uri, percent_decode};
mod json;
mod material;
mod mesh;
/// `EXT_meshopt_compression` and `KHR_meshopt_compression`: the decoder is the `kloub-meshopt`
/// crate (built for speed in the web bundle).
mod meshopt {
    pub(crate) use kloub_meshopt::{Filter, Mode, check, decode};

    /// The extensions' names: the KHR successor first (a view naming both is read by it).
    pub(crate) const EXTENSIONS: [&str; 2] = ["KHR_meshopt_compression", "EXT_meshopt_compression"];
}
mod scene;
pub mod tangents;
mod tree;

use crate::asset::{Asset, TextureTransform};
use crate::error::{ImportError, Warning};
use accessor::Accessors;
use container::Budget;
use json::{Obj, array, child, opt_object, opt_str};
use std::collections::HashMap;

/// Extensions a file may require: everything else in `extensionsRequired` is refused.
pub const SUPPORTED_REQUIRED_EXTENSIONS: &[&str] = &[
    "KHR_texture_transform",
    "KHR_mesh_quantization",
    "KHR_materials_unlit",
    "EXT_texture_webp",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "KHR_draco_mesh_compression",
];

/// Bytes charged per JSON value: its place in the tree (a value and, in an object, its key: 40
/// bytes natively, 24 in wasm32) in the arena, which grows by doubling, and on the stack it is
/// parsed on. A JSON bomb of tiny values is refused before it is parsed.
const JSON_VALUE_BYTES: u64 = 96;

/// An upper estimate of the memory of the parsed JSON tree: the text itself plus
/// [`JSON_VALUE_BYTES`] per value (values are at most the separators and openers outside
/// strings, plus one). Outside strings the separators and openers are counted in chunks the
/// compiler turns into vector code, and a string is skipped to its closing quote (past escapes)
/// with one search: the same count as reading byte by byte with a string state, ~4× faster on a
/// glTF's JSON (CesiumMan's 28 KB: ~36 µs byte by byte).
fn json_tree_estimate(json: &[u8]) -> u64 {
    let structural = |text: &[u8]| -> u64 {
        // Per chunk a byte-sized count (at most 255 per chunk), summed wide.
        text.chunks(255)
            .map(|c| {
                u64::from(c.iter().map(|&b| u8::from(matches!(b, b',' | b'[' | b'{' | b':'))).fold(0, u8::wrapping_add))
            })
            .sum()
    };
    let (mut values, mut rest) = (1u64, json);
    loop {
        // Outside a string: up to the next quote.
        let Some(quote) = rest.iter().position(|&b| b == b'"') else {
            values += structural(rest);
            break;
        };
        values += structural(rest.get(..quote).unwrap_or_default());
        rest = rest.get(quote + 1..).unwrap_or_default();
        // Inside: to the closing quote, a backslash taking the byte after it with it.
        loop {
            match rest.iter().position(|&b| b == b'"' || b == b'\\') {
                None => rest = &[],
                Some(at) if rest.get(at) == Some(&b'\\') => {
                    rest = rest.get(at + 2..).unwrap_or_default();
                    continue;
                }
                Some(at) => rest = rest.get(at + 1..).unwrap_or_default(),
            }
            break;
        }
        if rest.is_empty() {
            break;
        }
    }
    (json.len() as u64).saturating_add(values.saturating_mul(JSON_VALUE_BYTES))
}

/// Supplies the bytes of external files a .gltf refers to (buffers, images).
pub trait Resolver {
    /// The bytes of `uri` (the raw glTF uri, never a `data:` URI), or a message why not.
    fn resolve(&self, uri: &str) -> Result<Vec<u8>, String>;
}

/// A resolver without files: every external uri fails.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoResolver;

impl Resolver for NoResolver {
    fn resolve(&self, _uri: &str) -> Result<Vec<u8>, String> {
        Err("external files are not available".into())
    }
}

/// An in-memory resolver: files by relative path (e.g. dropped together with the .gltf).
#[derive(Clone, Debug, Default)]
pub struct MapResolver {
    files: HashMap<String, Vec<u8>>,
}

impl MapResolver {
    /// An empty resolver.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a file under its relative path (or bare file name).
    pub fn insert(&mut self, name: impl Into<String>, bytes: Vec<u8>) {
        self.files.insert(name.into(), bytes);
    }
}

/// `path` with `\\` as `/`, without `.` segments and with `..` applied.
fn normalize_path(path: &str) -> String {
    let mut parts: Vec<&str> = Vec::new();
    for segment in path.split(['/', '\\']) {
        match segment {
            "" | "." => {}
            ".." => {
                parts.pop();
            }
            s => parts.push(s),
        }
    }
    parts.join("/")
}

impl Resolver for MapResolver {
    /// Resolves the percent-decoded `uri` by exact relative path, else by file name
    /// (when exactly one file has that name).
    fn resolve(&self, uri: &str) -> Result<Vec<u8>, String> {
        let wanted = normalize_path(&container::percent_decode(uri));
        if let Some((_, bytes)) = self.files.iter().find(|(k, _)| normalize_path(k) == wanted) {
            return Ok(bytes.clone());
        }
        let file_name = |p: &str| p.rsplit(['/', '\\']).next().unwrap_or("").to_owned();
        let name = file_name(&wanted);
        let mut matches = self.files.iter().filter(|(k, _)| file_name(k) == name);
        match (matches.next(), matches.next()) {
            (Some((_, bytes)), None) => Ok(bytes.clone()),
            (Some(_), Some(_)) => Err(format!("several files are named '{name}'")),
            _ => Err(format!("file '{wanted}' was not provided")),
        }
    }
}

/// Import limits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImportOptions {
    /// Most bytes the document may declare (buffers, decoded accessors, images) before
    /// anything is allocated. Default 512 MiB.
    pub budget_bytes: u64,
    /// Deepest node hierarchy accepted. Default 1024.
    pub max_node_depth: u32,
    /// Decode PNG, JPEG and WebP images to RGBA8 ([`crate::asset::Image::rgba8`]); when false, or
    /// without the `images` feature, each image keeps its file bytes
    /// ([`crate::asset::Image::encoded`]) for the host to decode (the browser, in the web
    /// viewer), its size read from the header and checked against the budget all the same.
    /// Default: whether the `images` feature is on.
    pub decode_images: bool,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self { budget_bytes: 512 << 20, max_node_depth: 1024, decode_images: cfg!(feature = "images") }
    }
}

/// A successfully imported document.
#[derive(Clone, Debug)]
pub struct Imported {
    /// The validated asset.
    pub asset: Asset,
    /// Defects that were repaired, in document order.
    pub warnings: Vec<Warning>,
}

/// Import state shared by the element parsers.
pub(crate) struct Cx<'a> {
    root: &'a Obj<'a>,
    accessors: Accessors<'a>,
    budget: Budget,
    warnings: Vec<Warning>,
    resolver: &'a dyn Resolver,
    options: &'a ImportOptions,
}

impl Cx<'_> {
    /// Records a repaired defect.
    fn warn(&mut self, pointer: impl Into<String>, message: impl Into<String>) {
        self.warnings.push(Warning::new(pointer, message));
    }
}

/// Imports a GLB or a .gltf JSON document (detected by the `glTF` magic), decoding Draco
/// streams with this build's decoders ([`crate::codecs::builtin`]).
pub fn import(bytes: &[u8], resolver: &dyn Resolver, options: &ImportOptions) -> Result<Imported, ImportError> {
    import_with(bytes, resolver, crate::codecs::builtin(), options)
}

/// Decodes one buffer view stored by `EXT_meshopt_compression` (or, with `khr`, its successor
/// `KHR_meshopt_compression`) into `out`, as meshoptimizer's `decodeGltfBuffer` does: `mode`
/// and `filter` are the extension's strings, `count` and `stride` its members, `src` the
/// compressed bytes, and `out` holds `count × stride` bytes. The importer decodes every such
/// view this way; a host can call it on its own (the benchmarks do, beside the reference).
///
/// # Errors
/// An unknown mode or filter, sizes the extension does not allow, or malformed data.
pub fn decode_meshopt_view(
    mode: &str,
    filter: &str,
    count: usize,
    stride: usize,
    src: &[u8],
    khr: bool,
    out: &mut [u8],
) -> Result<(), String> {
    let m = meshopt::Mode::parse(mode).ok_or_else(|| format!("unknown mode '{mode}'"))?;
    let f = meshopt::Filter::parse(filter).ok_or_else(|| format!("unknown filter '{filter}'"))?;
    meshopt::check(m, f, count as u64, stride as u64, khr)?;
    meshopt::decode(m, f, count, stride, src, out, khr)
}

/// [`import`] with the decoders `codecs` (a host that loads them on demand, such as the web
/// widget).
pub fn import_with(
    bytes: &[u8],
    resolver: &dyn Resolver,
    codecs: &dyn crate::codecs::Codecs,
    options: &ImportOptions,
) -> Result<Imported, ImportError> {
    let mut warnings = Vec::new();
    let mut budget = Budget::new(options.budget_bytes);
    let container = container::split(bytes, &mut warnings)?;
    // Where even a value per byte fits the budget, the tree's values are counted as they are
    // parsed and charged then (the count before the parse costs ~5 % of a small character's
    // import); otherwise they are estimated and charged first, so that a JSON bomb of tiny
    // values is refused before it is parsed.
    let json_bytes = container.json.len() as u64;
    let counted =
        json_bytes.saturating_add(json_bytes.saturating_add(1).saturating_mul(JSON_VALUE_BYTES)) <= budget.left();
    if !counted {
        budget.take(Some(json_tree_estimate(container.json)), "", "the parsed JSON document")?;
    }
    // The tree's arrays, objects and escaped strings: one arena, freed with the tree.
    let arena = tree::Arena::for_document(container.json.len());
    let (value, values) =
        tree::parse_counted(container.json, &arena).map_err(|e| ImportError::new("", format!("invalid JSON: {e}")))?;
    if counted {
        budget.take(json_bytes.checked_add(values.saturating_mul(JSON_VALUE_BYTES)), "", "the parsed JSON document")?;
    }
    let root = json::object(&value, "")?;
    check_version(root)?;
    check_required_extensions(root)?;
    let buffers = container::load_buffers(root, &container, resolver, &mut budget)?;
    let mut accessors = Accessors::new(root, buffers, &mut budget)?;
    let (compressed_primitives, draco_warnings) = draco::decode_all(root, &mut accessors, &mut budget, codecs)?;
    warnings.extend(draco_warnings);
    let mut cx = Cx { root, accessors, budget, warnings, resolver, options };

    let (images, usable_images) = material::images(&mut cx, options.decode_images)?;
    let materials = material::materials(&mut cx, &usable_images)?;
    let mesh_count = array(root, "meshes", "")?.len();
    let skin_count = array(root, "skins", "")?.len();
    let scene::Graph { mut nodes, order, file_weights } = scene::nodes(&mut cx, mesh_count, skin_count)?;
    let (scenes, default_scene) = scene::scenes(&mut cx, &nodes)?;
    let mut imported_meshes = mesh::meshes(&mut cx, materials.len())?;
    // glTF: a normal-mapped primitive without tangents takes MikkTSpace's.
    for (m, imported) in imported_meshes.iter_mut().enumerate() {
        for (k, primitive) in imported.mesh.primitives.iter_mut().enumerate() {
            let normal_texture =
                primitive.material.and_then(|i| materials.get(i as usize)).and_then(|m| m.normal_texture);
            let Some(texture) = normal_texture.filter(|_| primitive.tangents.is_empty()) else { continue };
            let ptr = format!("/meshes/{m}/primitives/{k}");
            // The scratch is freed once the tangents are made: checked against the budget, not taken.
            let transformed = if texture.transform == TextureTransform::default() {
                Some(0)
            } else {
                (primitive.positions.len() as u64).checked_mul(tangents::TRANSFORMED_BYTES_PER_VERTEX)
            };
            let scratch = (primitive.indices.len() as u64)
                .checked_mul(tangents::SCRATCH_BYTES_PER_INDEX)
                .zip(transformed)
                .and_then(|(a, b)| a.checked_add(b));
            if scratch.is_none_or(|b| b > cx.budget.left()) {
                return Err(ImportError::new(
                    ptr,
                    format!(
                        "generating tangents for {} indices needs more than the {} bytes left of the import budget",
                        primitive.indices.len(),
                        cx.budget.left()
                    ),
                ));
            }
            let Some(split) = tangents::plan(primitive, texture.tex_coord, &texture.transform) else { continue };
            cx.budget.take(Some(split.kept_bytes(primitive)), &ptr, "the generated tangents")?;
            split.apply(primitive);
        }
    }
    let mut skins = scene::skins(&mut cx, nodes.len())?;
    repair_inverse_binds(&mut cx, &mut skins, &nodes);

    // Joint indices against the skin each node draws its mesh with.
    for (n, node) in nodes.iter().enumerate() {
        let (Some(m), Some(s)) = (node.mesh, node.skin) else { continue };
        let joint_count = skins[s as usize].joints.len();
        let primitives = &imported_meshes[m as usize].max_joints;
        if !primitives.is_empty() && primitives.iter().all(|(_, j)| j.is_none()) {
            cx.warn(
                format!("/nodes/{n}/skin"),
                format!("mesh {m} has no JOINTS_0/WEIGHTS_0 to skin with; skin {s} is not used for it"),
            );
        }
        for &(p, max_joint) in primitives {
            if let Some(j) = max_joint.filter(|&j| usize::from(j) >= joint_count) {
                return Err(ImportError::new(
                    format!("/meshes/{m}/primitives/{p}/attributes/JOINTS_0"),
                    format!(
                        "joint index {j} is outside skin {s} ({joint_count} joints), which node {n} draws this mesh with"
                    ),
                ));
            }
        }
    }

    // Default morph weights per node, and their place in the flat weights array.
    let mut weight_offsets = Vec::with_capacity(nodes.len());
    let mut total = 0u64;
    for (n, (node, file)) in nodes.iter_mut().zip(file_weights).enumerate() {
        let defaults = node.mesh.map(|m| imported_meshes[m as usize].mesh.weights.clone()).unwrap_or_default();
        node.weights = match file {
            Some(w) if node.mesh.is_some() && w.len() != defaults.len() => {
                cx.warn(
                    format!("/nodes/{n}/weights"),
                    format!("{} weights for {} morph targets; the mesh's weights are used", w.len(), defaults.len()),
                );
                defaults
            }
            Some(w) if node.mesh.is_some() => w,
            _ => defaults,
        };
        weight_offsets.push(u32::try_from(total).map_err(|_| ImportError::new("/nodes", "too many morph weights"))?);
        total += node.weights.len() as u64;
    }
    let weight_total = u32::try_from(total).map_err(|_| ImportError::new("/nodes", "too many morph weights"))?;

    let clips = anim::clips(&mut cx, &nodes)?;
    let asset = Asset {
        nodes,
        order,
        scenes,
        default_scene,
        meshes: imported_meshes.into_iter().map(|m| m.mesh).collect(),
        skins,
        materials,
        images,
        clips,
        weight_offsets,
        weight_total,
        extensions: crate::asset::Extensions {
            used: names(root, "extensionsUsed")?,
            required: names(root, "extensionsRequired")?,
            compressed_views: std::mem::take(&mut cx.accessors.compressed),
            compressed_primitives,
        },
    };
    Ok(Imported { asset, warnings: cx.warnings })
}

/// Refuses documents that are not glTF 2.x.
fn check_version(root: &Obj) -> Result<(), ImportError> {
    let asset = opt_object(root, "asset", "")?.ok_or_else(|| ImportError::new("/asset", "missing"))?;
    let version = opt_str(asset, "version", "/asset")?.ok_or_else(|| ImportError::new("/asset/version", "missing"))?;
    if version.split('.').next() != Some("2") {
        return Err(ImportError::new("/asset/version", format!("glTF version {version} is not supported (only 2.x)")));
    }
    Ok(())
}

/// Replaces each inverse bind matrix that is not affine or not invertible (it would tear the
/// mesh apart) by the inverse of its joint's rest world transform, with a warning per skin.
fn repair_inverse_binds(cx: &mut Cx<'_>, skins: &mut [crate::asset::Skin], nodes: &[crate::asset::Node]) {
    let world = |mut n: usize| {
        let mut m = glam::Mat4::IDENTITY;
        // Parents form a tree (checked when the nodes were read); the depth is bounded by the node count.
        for _ in 0..=nodes.len() {
            let Some(node) = nodes.get(n) else { break };
            m = node.rest.to_mat4() * m;
            match node.parent {
                Some(p) => n = p as usize,
                None => break,
            }
        }
        m
    };
    for (s, skin) in skins.iter_mut().enumerate() {
        let mut repaired = Vec::new();
        for (j, (matrix, &joint)) in skin.inverse_bind.iter_mut().zip(&skin.joints).enumerate() {
            let affine = matrix.row(3).abs_diff_eq(glam::Vec4::W, 1e-4);
            // Invertible whatever the scale (gltfpack folds its dequantization scale, ~1e-4, into
            // the matrices): the determinant against the product of the column lengths, 1 for a
            // rotation and 0 for a singular matrix.
            let m3 = glam::Mat3::from_mat4(*matrix);
            let lengths = m3.x_axis.length() * m3.y_axis.length() * m3.z_axis.length();
            let shape = m3.determinant() / lengths;
            if affine && matrix.is_finite() && lengths > 0.0 && shape.is_finite() && shape.abs() > 1e-6 {
                continue;
            }
            let rest = world(joint as usize).inverse();
            *matrix = if rest.is_finite() { rest } else { glam::Mat4::IDENTITY };
            repaired.push(j);
        }
        if !repaired.is_empty() {
            let list: Vec<String> = repaired.iter().take(8).map(ToString::to_string).collect();
            cx.warn(
                format!("/skins/{s}/inverseBindMatrices"),
                format!(
                    "{} matrices are not affine or not invertible (joints {}{}); each joint's rest pose is used instead",
                    repaired.len(),
                    list.join(", "),
                    if repaired.len() > 8 { ", …" } else { "" }
                ),
            );
        }
    }
}

/// The extension names listed under `key` (`extensionsUsed` / `extensionsRequired`); an entry
/// that is not a string says nothing and is left out (a required one was refused already).
fn names(root: &Obj, key: &str) -> Result<Vec<String>, ImportError> {
    Ok(array(root, key, "")?.iter().filter_map(|v| v.as_str().map(str::to_owned)).collect())
}

/// Refuses documents that require an extension Kloub does not implement.
fn check_required_extensions(root: &Obj) -> Result<(), ImportError> {
    for (i, ext) in array(root, "extensionsRequired", "")?.iter().enumerate() {
        let ptr = child("/extensionsRequired", i);
        let name = ext.as_str().ok_or_else(|| ImportError::new(&ptr, "expected an extension name"))?;
        if !SUPPORTED_REQUIRED_EXTENSIONS.contains(&name) {
            return Err(ImportError::new(ptr, format!("required extension {name} is not supported")));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
