//! `kloub pose` against an independent reference, on every model of `tests/assets`.
//!
//! The reference below reads the glTF files itself (serde_json, a GLB chunk reader, `data:`
//! URIs, a little-endian accessor reader with every component type, normalized integers,
//! `byteStride`, matrix column padding and sparse substitution) and applies the glTF 2.0
//! formulas in plain `f64`, sharing no code with kloub-core:
//!
//! - sampling: STEP (the key at or before `t`), LINEAR (slerp on the shortest arc for
//!   rotations), CUBICSPLINE (Hermite on in-tangent/value/out-tangent triplets, tangents scaled
//!   by the key interval, rotations normalized after); values held before the first and after
//!   the last key, so a time past the end of the clip gives its last pose;
//! - `local = matrix` or `T * R * S`, `world = world(parent) * local`;
//! - morphing `p = base + Σ wᵢ · δᵢ` (weights from the channel, else `node.weights`, else
//!   `mesh.weights`, else 0);
//! - skinning `p = Σ w · (world(joint) · inverseBind) · p` over JOINTS_n/WEIGHTS_n (the mesh
//!   node's own transform ignored), the weights divided by their sum: the spec says the
//!   engine treats skin weights as normalized, and kloub's importer documents that it
//!   renormalizes (RobotExpressive's weights do not sum to 1; see
//!   [`robot_expressive_skin_weights_are_renormalized`]);
//! - unskinned primitives: `world(node) · p`;
//! - the scene: `scene`, else scene 0 (RecursiveSkeletons has no `scene`; `kloub inspect`
//!   reports scene 0 as its default too).
//!
//! [`every_model_is_in_the_sweep`] checks that [`ASSETS`] names every model of the asset
//! library; one test per model (`sweep_*`) then evaluates the rest pose and every clip at 0, at
//! key times (every key when a clip has few, else an even pick over the union of its channels'
//! keys, first and last included), the midpoints after them (and the quarter points for
//! CUBICSPLINE clips), the end and a time past the end. The tolerance is 1e-5 × the diagonal
//! of the bounding box of the model in its rest pose (the reference's deformed, world-space
//! positions), `tol`: every deformed vertex of every primitive of the scene within `tol`
//! (Euclidean); every node's world translation within `tol`, and its linear part within 1e-5
//! per entry relative to its largest column (a point at distance `d` from the node moves by
//! about `|ΔL| · d`, and skinned points are up to a diagonal away); morph weights within 1e-5.
//!
//! The sweeps read the document [`kloub_server::pose::pose_asset`] builds (the one `kloub pose`
//! prints) for speed, importing each file once; [`check`] goes through
//! [`kloub_server::pose::pose_file`] and the printed JSON, parsed back, for the document's shape.
//! [`features_no_asset_uses_match_the_reference`] sweeps a generated file with what no model of
//! the library has (JOINTS_1, sparse accessors, normalized integer keys and targets, …).
//! [`interpolation_test_matches_hand_computed_values`] checks InterpolationTest's nine channels
//! against values worked out by hand from the spec, independent of the reference's sampler.

use base64::Engine as _;
use kloub_server::pose::{PoseDoc, PoseRequest, import_file, pose_asset, pose_file};
use kloub_tests::shared_assets;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::Instant;

type Mat = [f64; 16]; // column-major, like glTF
type Vec3 = [f64; 3];

// ---------------------------------------------------------------- reference: file reading

/// A glTF document and its buffers.
struct Gltf {
    json: Value,
    buffers: Vec<Vec<u8>>,
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"))
}

fn load(path: &Path) -> Gltf {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (json, bin) = if bytes.starts_with(b"glTF") {
        assert_eq!(u32_at(&bytes, 4), 2, "GLB version");
        let mut at = 12;
        let (mut json, mut bin) = (None, None);
        while at + 8 <= bytes.len() {
            let len = u32_at(&bytes, at) as usize;
            let kind = &bytes[at + 4..at + 8];
            let data = &bytes[at + 8..at + 8 + len];
            match kind {
                b"JSON" => json = Some(serde_json::from_slice::<Value>(data).expect("JSON chunk")),
                b"BIN\0" => bin = Some(data.to_vec()),
                _ => {}
            }
            at += 8 + len;
        }
        (json.expect("a JSON chunk"), bin)
    } else {
        (serde_json::from_slice(&bytes).expect(".gltf JSON"), None)
    };
    let dir = path.parent().expect("a folder");
    let buffers = json["buffers"]
        .as_array()
        .map(|b| {
            b.iter()
                .map(|buffer| match buffer["uri"].as_str() {
                    Some(uri) if uri.starts_with("data:") => {
                        let (_, data) = uri.split_once(";base64,").expect("a base64 data: URI");
                        base64::engine::general_purpose::STANDARD.decode(data).expect("valid base64")
                    }
                    Some(uri) => std::fs::read(dir.join(uri)).expect("external buffer"),
                    None => bin.clone().expect("the GLB BIN chunk"),
                })
                .collect()
        })
        .unwrap_or_default();
    Gltf { json, buffers }
}

fn index(v: &Value) -> usize {
    v.as_u64().expect("an index") as usize
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array().expect("an array").iter().map(|x| x.as_f64().expect("a number")).collect()
}

fn vec3(v: &[f64]) -> Vec3 {
    [v[0], v[1], v[2]]
}

/// One component of `componentType` at the start of `b`, as the spec maps it to a float:
/// normalized unsigned integers to [0, 1] (`c / (2ⁿ − 1)`), normalized signed ones to
/// [−1, 1] (`max(c / (2ⁿ⁻¹ − 1), −1)`).
fn component(component_type: usize, normalized: bool, b: &[u8]) -> f64 {
    match component_type {
        5120 => {
            let c = f64::from(i8::from_le_bytes([b[0]]));
            if normalized { (c / 127.0).max(-1.0) } else { c }
        }
        5121 => {
            let c = f64::from(b[0]);
            if normalized { c / 255.0 } else { c }
        }
        5122 => {
            let c = f64::from(i16::from_le_bytes([b[0], b[1]]));
            if normalized { (c / 32767.0).max(-1.0) } else { c }
        }
        5123 => {
            let c = f64::from(u16::from_le_bytes([b[0], b[1]]));
            if normalized { c / 65535.0 } else { c }
        }
        5125 => {
            assert!(!normalized, "UNSIGNED_INT cannot be normalized");
            f64::from(u32::from_le_bytes(b[..4].try_into().expect("4")))
        }
        5126 => {
            assert!(!normalized, "FLOAT cannot be normalized");
            f64::from(f32::from_le_bytes(b[..4].try_into().expect("4")))
        }
        other => panic!("componentType {other} is not in the spec"),
    }
}

fn component_size(component_type: usize) -> usize {
    match component_type {
        5120 | 5121 => 1,
        5122 | 5123 => 2,
        5125 | 5126 => 4,
        other => panic!("componentType {other} is not in the spec"),
    }
}

impl Gltf {
    /// `count` elements of `rows × columns` components of `component_type`, starting at
    /// byte `start` of buffer view `view`, `stride` bytes apart (`None`: the view's
    /// `byteStride`, else packed). Matrix columns start on 4-byte boundaries (the spec's data alignment).
    #[allow(clippy::too_many_arguments)]
    fn read(
        &self,
        view: usize,
        start: usize,
        count: usize,
        component_type: usize,
        normalized: bool,
        (rows, columns): (usize, usize),
        stride: Option<usize>,
    ) -> Vec<Vec<f64>> {
        let view = &self.json["bufferViews"][view];
        let buffer = &self.buffers[index(&view["buffer"])];
        let size = component_size(component_type);
        let column_bytes = if columns > 1 { (rows * size).div_ceil(4) * 4 } else { rows * size };
        let element = column_bytes * columns;
        let stride = stride.or_else(|| view["byteStride"].as_u64().map(|s| s as usize)).unwrap_or(element);
        let view_start = view["byteOffset"].as_u64().unwrap_or(0) as usize;
        let view_end = view_start + view["byteLength"].as_u64().expect("byteLength") as usize;
        let base = view_start + start;
        if count > 0 {
            assert!(
                base + (count - 1) * stride + element <= view_end.min(buffer.len()),
                "an accessor beyond its buffer view"
            );
        }
        (0..count)
            .map(|e| {
                let mut out = Vec::with_capacity(rows * columns);
                for col in 0..columns {
                    for row in 0..rows {
                        let at = base + e * stride + col * column_bytes + row * size;
                        out.push(component(component_type, normalized, &buffer[at..at + size]));
                    }
                }
                out
            })
            .collect()
    }

    /// An accessor's elements as `f64`: zeros without a buffer view, then sparse values
    /// substituted at their indices.
    fn accessor(&self, i: usize) -> Vec<Vec<f64>> {
        let a = &self.json["accessors"][i];
        let count = index(&a["count"]);
        let shape = match a["type"].as_str().expect("type") {
            "SCALAR" => (1, 1),
            "VEC2" => (2, 1),
            "VEC3" => (3, 1),
            "VEC4" => (4, 1),
            "MAT2" => (2, 2),
            "MAT3" => (3, 3),
            "MAT4" => (4, 4),
            other => panic!("type {other} is not in the spec"),
        };
        let component_type = index(&a["componentType"]);
        let normalized = a["normalized"].as_bool().unwrap_or(false);
        let offset = a["byteOffset"].as_u64().unwrap_or(0) as usize;
        let mut out = match a.get("bufferView") {
            Some(v) => self.read(index(v), offset, count, component_type, normalized, shape, None),
            None => vec![vec![0.0; shape.0 * shape.1]; count],
        };
        if let Some(sparse) = a.get("sparse") {
            let n = index(&sparse["count"]);
            let ix = &sparse["indices"];
            let indices = self.read(
                index(&ix["bufferView"]),
                ix["byteOffset"].as_u64().unwrap_or(0) as usize,
                n,
                index(&ix["componentType"]),
                false,
                (1, 1),
                Some(component_size(index(&ix["componentType"]))),
            );
            let vs = &sparse["values"];
            let values = self.read(
                index(&vs["bufferView"]),
                vs["byteOffset"].as_u64().unwrap_or(0) as usize,
                n,
                component_type,
                normalized,
                shape,
                None,
            );
            for (at, value) in indices.iter().zip(values) {
                out[at[0] as usize] = value;
            }
        }
        out
    }

    fn vec3s(&self, i: usize) -> Vec<Vec3> {
        self.accessor(i).iter().map(|v| vec3(v)).collect()
    }

    fn scalars(&self, i: usize) -> Vec<f64> {
        self.accessor(i).into_iter().map(|v| v[0]).collect()
    }
}

// ---------------------------------------------------------------- reference: math

fn mul(a: &Mat, b: &Mat) -> Mat {
    let mut c = [0.0; 16];
    for col in 0..4 {
        for row in 0..4 {
            c[col * 4 + row] = (0..4).map(|k| a[k * 4 + row] * b[col * 4 + k]).sum();
        }
    }
    c
}

fn point(m: &Mat, v: &Vec3) -> Vec3 {
    let mut out = [0.0; 3];
    for (row, o) in out.iter_mut().enumerate() {
        *o = m[row] * v[0] + m[4 + row] * v[1] + m[8 + row] * v[2] + m[12 + row];
    }
    out
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt()
}

const IDENTITY: Mat = [1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.];

fn normalize(q: &[f64]) -> Vec<f64> {
    let len = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    q.iter().map(|x| x / len).collect()
}

/// `T * R * S` with `r` = `[x, y, z, w]`.
fn trs(t: &[f64], r: &[f64], s: &[f64]) -> Mat {
    let q = normalize(r);
    let (x, y, z, w) = (q[0], q[1], q[2], q[3]);
    let rot = [
        [1. - 2. * (y * y + z * z), 2. * (x * y + z * w), 2. * (x * z - y * w)],
        [2. * (x * y - z * w), 1. - 2. * (x * x + z * z), 2. * (y * z + x * w)],
        [2. * (x * z + y * w), 2. * (y * z - x * w), 1. - 2. * (x * x + y * y)],
    ]; // rot[col][row]
    let mut m = IDENTITY;
    for col in 0..3 {
        for row in 0..3 {
            m[col * 4 + row] = rot[col][row] * s[col];
        }
        m[12 + col] = t[col];
    }
    m
}

/// Spherical interpolation on the shortest arc (glTF 2.0, appendix on interpolation).
fn slerp(a: &[f64], b: &[f64], u: f64) -> Vec<f64> {
    let mut d: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let b: Vec<f64> = if d < 0.0 {
        d = -d;
        b.iter().map(|x| -x).collect()
    } else {
        b.to_vec()
    };
    if d > 0.9999995 {
        return normalize(&a.iter().zip(&b).map(|(x, y)| x + (y - x) * u).collect::<Vec<_>>());
    }
    let theta = d.acos();
    let (wa, wb) = (((1.0 - u) * theta).sin() / theta.sin(), (u * theta).sin() / theta.sin());
    normalize(&a.iter().zip(&b).map(|(x, y)| wa * x + wb * y).collect::<Vec<_>>())
}

/// The cubic Hermite spline of the spec: `v0`, out-tangent `b0` of the key before, `v1`,
/// in-tangent `a1` of the key after, `td` the key interval, `u` in [0, 1].
fn hermite(v0: &[f64], b0: &[f64], v1: &[f64], a1: &[f64], td: f64, u: f64) -> Vec<f64> {
    let (u2, u3) = (u * u, u * u * u);
    let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
    let h10 = u3 - 2.0 * u2 + u;
    let h01 = -2.0 * u3 + 3.0 * u2;
    let h11 = u3 - u2;
    (0..v0.len()).map(|c| h00 * v0[c] + h10 * td * b0[c] + h01 * v1[c] + h11 * td * a1[c]).collect()
}

// ---------------------------------------------------------------- reference: the model

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Target {
    Translation,
    Rotation,
    Scale,
    Weights,
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Interpolation {
    Step,
    Linear,
    CubicSpline,
}

struct Channel {
    node: usize,
    target: Target,
    interpolation: Interpolation,
    times: Vec<f64>,
    /// One element per key; for CUBICSPLINE three per key: in-tangent, value, out-tangent.
    values: Vec<Vec<f64>>,
}

impl Channel {
    fn value(&self, k: usize) -> &[f64] {
        match self.interpolation {
            Interpolation::CubicSpline => &self.values[3 * k + 1],
            _ => &self.values[k],
        }
    }

    /// The channel at `t`: held before the first and after the last key.
    fn sample(&self, t: f64) -> Vec<f64> {
        let last = self.times.len() - 1;
        if t <= self.times[0] {
            return self.value(0).to_vec();
        }
        if t >= self.times[last] {
            return self.value(last).to_vec();
        }
        // The key at or before t (STEP holds it until the next key's time).
        let k = self.times.partition_point(|&x| x <= t) - 1;
        let td = self.times[k + 1] - self.times[k];
        let u = (t - self.times[k]) / td;
        let rotation = self.target == Target::Rotation;
        match self.interpolation {
            Interpolation::Step => self.value(k).to_vec(),
            Interpolation::Linear if rotation => slerp(&normalize(self.value(k)), &normalize(self.value(k + 1)), u),
            Interpolation::Linear => {
                self.value(k).iter().zip(self.value(k + 1)).map(|(a, b)| a + (b - a) * u).collect()
            }
            Interpolation::CubicSpline => {
                let p = hermite(
                    self.value(k),
                    &self.values[3 * k + 2],
                    self.value(k + 1),
                    &self.values[3 * (k + 1)],
                    td,
                    u,
                );
                if rotation { normalize(&p) } else { p }
            }
        }
    }
}

struct Clip {
    name: Option<String>,
    channels: Vec<Channel>,
    /// The latest key time of any channel.
    duration: f64,
}

impl Clip {
    fn has_cubic(&self) -> bool {
        self.channels.iter().any(|c| c.interpolation == Interpolation::CubicSpline)
    }

    /// Every key time of every channel, sorted, without repeats.
    fn key_times(&self) -> Vec<f64> {
        let mut times: Vec<f64> = self.channels.iter().flat_map(|c| c.times.iter().copied()).collect();
        times.sort_by(f64::total_cmp);
        times.dedup();
        times
    }
}

struct Node {
    name: Value,
    matrix: Option<Mat>,
    t: Vec<f64>,
    r: Vec<f64>,
    s: Vec<f64>,
    mesh: Option<usize>,
    skin: Option<usize>,
    /// The morph weights without animation (empty without morph targets).
    weights: Vec<f64>,
}

struct Primitive {
    positions: Vec<Vec3>,
    /// POSITION displacement of each morph target (`None`: the target moves no position).
    targets: Vec<Option<Vec<Vec3>>>,
    /// Per vertex: (joint slot in the skin, weight divided by the vertex's weight sum).
    influences: Vec<Vec<(usize, f64)>>,
    /// Per vertex: the weight sum as stored in the file.
    weight_sums: Vec<f64>,
}

struct Skin {
    joints: Vec<usize>,
    inverse_bind: Vec<Mat>,
}

/// (node, mesh, primitive).
type PrimitiveKey = (usize, usize, usize);

/// A glTF file read into what the formulas need.
struct Model {
    nodes: Vec<Node>,
    parent: Vec<Option<usize>>,
    /// Parents before children.
    order: Vec<usize>,
    meshes: Vec<Vec<Primitive>>,
    skins: Vec<Skin>,
    clips: Vec<Clip>,
    /// Nodes of the default scene (`scene`, else scene 0, else every root) with their subtrees.
    scene: Vec<usize>,
}

/// The reference at one time.
struct Expected {
    worlds: Vec<Mat>,
    /// (node, morph weights) for every node with morph targets.
    weights: Vec<(usize, Vec<f64>)>,
    /// World positions of every primitive instanced by a node of the scene.
    primitives: Vec<(PrimitiveKey, Vec<Vec3>)>,
}

impl Model {
    fn load(path: &Path) -> Self {
        let g = load(path);
        let j = &g.json;
        let list = |key: &str| j[key].as_array().cloned().unwrap_or_default();

        let meshes: Vec<Vec<Primitive>> = list("meshes")
            .iter()
            .map(|mesh| {
                mesh["primitives"].as_array().expect("primitives").iter().map(|prim| read_primitive(&g, prim)).collect()
            })
            .collect();
        let mesh_json = list("meshes");

        let nodes: Vec<Node> = list("nodes")
            .iter()
            .map(|nd| {
                let mesh = nd.get("mesh").map(index);
                let targets = mesh.map_or(0, |m| meshes[m].first().map_or(0, |p| p.targets.len()));
                let weights = match (nd.get("weights"), mesh) {
                    (Some(w), _) => floats(w),
                    (None, Some(m)) => mesh_json[m].get("weights").map_or(vec![0.0; targets], floats),
                    _ => vec![],
                };
                Node {
                    name: nd.get("name").cloned().unwrap_or(Value::Null),
                    matrix: nd.get("matrix").map(|m| floats(m).try_into().expect("16 floats")),
                    t: nd.get("translation").map_or(vec![0.; 3], floats),
                    r: nd.get("rotation").map_or(vec![0., 0., 0., 1.], floats),
                    s: nd.get("scale").map_or(vec![1.; 3], floats),
                    mesh,
                    skin: nd.get("skin").map(index),
                    weights,
                }
            })
            .collect();
        let n = nodes.len();

        let mut parent = vec![None; n];
        let mut children = vec![Vec::new(); n];
        for (p, nd) in list("nodes").iter().enumerate() {
            for c in nd["children"].as_array().into_iter().flatten() {
                assert!(parent[index(c)].is_none(), "node {} has two parents", index(c));
                parent[index(c)] = Some(p);
                children[p].push(index(c));
            }
        }
        let mut order = Vec::with_capacity(n);
        let mut stack: Vec<usize> = (0..n).rev().filter(|&i| parent[i].is_none()).collect();
        while let Some(i) = stack.pop() {
            order.push(i);
            stack.extend(children[i].iter().rev());
        }
        assert_eq!(order.len(), n, "the node graph is a forest");

        let roots: Vec<usize> = match j["scenes"].as_array() {
            Some(scenes) if !scenes.is_empty() => {
                let s = j["scene"].as_u64().unwrap_or(0) as usize;
                scenes[s]["nodes"].as_array().into_iter().flatten().map(index).collect()
            }
            _ => (0..n).filter(|&i| parent[i].is_none()).collect(),
        };
        let mut scene = Vec::new();
        let mut stack = roots;
        while let Some(i) = stack.pop() {
            scene.push(i);
            stack.extend(&children[i]);
        }
        scene.sort_unstable();

        let skins = list("skins")
            .iter()
            .map(|skin| {
                let joints: Vec<usize> = skin["joints"].as_array().expect("joints").iter().map(index).collect();
                let inverse_bind = match skin.get("inverseBindMatrices") {
                    Some(a) => g.accessor(index(a)).into_iter().map(|m| m.try_into().expect("16")).collect(),
                    None => vec![IDENTITY; joints.len()],
                };
                Skin { joints, inverse_bind }
            })
            .collect();

        let clips = list("animations")
            .iter()
            .map(|anim| {
                let samplers = anim["samplers"].as_array().expect("samplers");
                let channels: Vec<Channel> = anim["channels"]
                    .as_array()
                    .expect("channels")
                    .iter()
                    .filter_map(|ch| {
                        let node = ch["target"].get("node").map(index)?;
                        let target = match ch["target"]["path"].as_str().expect("path") {
                            "translation" => Target::Translation,
                            "rotation" => Target::Rotation,
                            "scale" => Target::Scale,
                            "weights" => Target::Weights,
                            other => panic!("path {other} is not in the spec"),
                        };
                        let sampler = &samplers[index(&ch["sampler"])];
                        let interpolation = match sampler["interpolation"].as_str() {
                            None | Some("LINEAR") => Interpolation::Linear,
                            Some("STEP") => Interpolation::Step,
                            Some("CUBICSPLINE") => Interpolation::CubicSpline,
                            Some(other) => panic!("interpolation {other} is not in the spec"),
                        };
                        let times = g.scalars(index(&sampler["input"]));
                        let mut values = g.accessor(index(&sampler["output"]));
                        let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
                        if target == Target::Weights {
                            // One scalar per morph target per element: regroup per element
                            // (for CUBICSPLINE: all in-tangents, all values, all out-tangents).
                            let targets = values.len() / (per_key * times.len());
                            values = values.chunks(targets).map(|c| c.iter().map(|v| v[0]).collect()).collect();
                        }
                        assert_eq!(values.len(), per_key * times.len(), "output count");
                        Some(Channel { node, target, interpolation, times, values })
                    })
                    .collect();
                let duration = samplers.iter().flat_map(|s| g.scalars(index(&s["input"]))).fold(0.0, f64::max);
                Clip { name: anim["name"].as_str().map(str::to_owned), channels, duration }
            })
            .collect();

        Model { nodes, parent, order, meshes, skins, clips, scene }
    }

    /// The pose of `clip` at `t` (`None`: the rest pose).
    fn evaluate(&self, clip: Option<usize>, t: f64) -> Expected {
        let n = self.nodes.len();
        let mut ts: Vec<Vec<f64>> = self.nodes.iter().map(|nd| nd.t.clone()).collect();
        let mut rs: Vec<Vec<f64>> = self.nodes.iter().map(|nd| nd.r.clone()).collect();
        let mut ss: Vec<Vec<f64>> = self.nodes.iter().map(|nd| nd.s.clone()).collect();
        let mut weights: Vec<Vec<f64>> = self.nodes.iter().map(|nd| nd.weights.clone()).collect();
        for ch in clip.iter().flat_map(|&c| &self.clips[c].channels) {
            let v = ch.sample(t);
            match ch.target {
                Target::Translation => ts[ch.node] = v,
                Target::Rotation => rs[ch.node] = v,
                Target::Scale => ss[ch.node] = v,
                Target::Weights => weights[ch.node] = v,
            }
        }
        let mut worlds = vec![IDENTITY; n];
        for &i in &self.order {
            let local = match self.nodes[i].matrix {
                Some(m) => m,
                None => trs(&ts[i], &rs[i], &ss[i]),
            };
            worlds[i] = match self.parent[i] {
                Some(p) => mul(&worlds[p], &local),
                None => local,
            };
        }

        let mut primitives = Vec::new();
        for &i in &self.scene {
            let node = &self.nodes[i];
            let Some(mesh) = node.mesh else { continue };
            let palette: Option<Vec<Mat>> = node.skin.map(|s| {
                let skin = &self.skins[s];
                skin.joints.iter().zip(&skin.inverse_bind).map(|(&j, ibm)| mul(&worlds[j], ibm)).collect()
            });
            for (p, prim) in self.meshes[mesh].iter().enumerate() {
                let out: Vec<Vec3> = prim
                    .positions
                    .iter()
                    .enumerate()
                    .map(|(v, base)| {
                        let mut pos = *base;
                        for (target, w) in prim.targets.iter().zip(&weights[i]) {
                            if let Some(d) = target {
                                for c in 0..3 {
                                    pos[c] += w * d[v][c];
                                }
                            }
                        }
                        match &palette {
                            Some(palette) => {
                                let mut acc = [0.0; 3];
                                for &(j, w) in &prim.influences[v] {
                                    let q = point(&palette[j], &pos);
                                    for c in 0..3 {
                                        acc[c] += w * q[c];
                                    }
                                }
                                acc
                            }
                            None => point(&worlds[i], &pos),
                        }
                    })
                    .collect();
                primitives.push(((i, mesh, p), out));
            }
        }
        let weights = weights.into_iter().enumerate().filter(|(_, w)| !w.is_empty()).collect();
        Expected { worlds, weights, primitives }
    }

    /// The diagonal of the bounding box of the deformed scene in its rest pose.
    fn rest_diagonal(&self) -> f64 {
        let rest = self.evaluate(None, 0.0);
        let mut lo = [f64::MAX; 3];
        let mut hi = [f64::MIN; 3];
        for p in rest.primitives.iter().flat_map(|(_, ps)| ps) {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let diag = distance(&lo, &hi);
        assert!(diag > 0.0 && diag.is_finite(), "an empty reference scene");
        diag
    }
}

fn read_primitive(g: &Gltf, prim: &Value) -> Primitive {
    let attrs = &prim["attributes"];
    let positions = g.vec3s(index(&attrs["POSITION"]));
    let targets = prim["targets"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|t| t.get("POSITION").map(|a| g.vec3s(index(a))))
        .collect();
    let mut influences = vec![Vec::new(); positions.len()];
    let mut weight_sums = vec![0.0; positions.len()];
    for set in 0.. {
        let (Some(j), Some(w)) = (attrs.get(format!("JOINTS_{set}")), attrs.get(format!("WEIGHTS_{set}"))) else {
            break;
        };
        let (js, ws) = (g.accessor(index(j)), g.accessor(index(w)));
        for (v, (j4, w4)) in js.iter().zip(&ws).enumerate() {
            for (&j, &w) in j4.iter().zip(w4) {
                assert!(w >= 0.0, "negative skin weight");
                if w > 0.0 {
                    influences[v].push((j as usize, w));
                    weight_sums[v] += w;
                }
            }
        }
    }
    for (inf, &sum) in influences.iter_mut().zip(&weight_sums) {
        if !inf.is_empty() {
            for (_, w) in inf.iter_mut() {
                *w /= sum;
            }
        }
    }
    if attrs.get("JOINTS_0").is_some() {
        assert!(influences.iter().all(|i| !i.is_empty()), "a skinned vertex without weights is not in this reference");
    }
    Primitive { positions, targets, influences, weight_sums }
}

// ---------------------------------------------------------------- kloub's side

/// One frame of `kloub pose`, borrowed from the document or from its parsed JSON.
struct FrameView<'a> {
    time: f64,
    names: Vec<&'a Value>,
    worlds: Vec<&'a [f64]>,
    weights: Vec<(usize, &'a [f64])>,
    primitives: Vec<(PrimitiveKey, &'a [f64])>,
}

/// The frames of a parsed JSON document, owned.
struct JsonFrame {
    time: f64,
    names: Vec<Value>,
    worlds: Vec<Vec<f64>>,
    weights: Vec<(usize, Vec<f64>)>,
    primitives: Vec<(PrimitiveKey, Vec<f64>)>,
}

impl JsonFrame {
    fn parse(frame: &Value) -> Self {
        let nodes = frame["nodes"].as_array().expect("nodes");
        for (i, node) in nodes.iter().enumerate() {
            assert_eq!(keys(node), ["index", "name", "world"]);
            assert_eq!(node["index"], i);
        }
        let primitives = frame["primitives"]
            .as_array()
            .expect("primitives")
            .iter()
            .map(|p| {
                assert_eq!(keys(p), ["count", "mesh", "node", "positions", "primitive"]);
                let positions = floats(&p["positions"]);
                assert_eq!(index(&p["count"]) * 3, positions.len(), "count == positions / 3");
                ((index(&p["node"]), index(&p["mesh"]), index(&p["primitive"])), positions)
            })
            .collect();
        JsonFrame {
            time: frame["time"].as_f64().expect("time"),
            names: nodes.iter().map(|n| n["name"].clone()).collect(),
            worlds: nodes.iter().map(|n| floats(&n["world"])).collect(),
            weights: frame["weights"]
                .as_object()
                .expect("weights object")
                .iter()
                .map(|(k, w)| (k.parse().expect("a node index"), floats(w)))
                .collect(),
            primitives,
        }
    }

    fn view(&self) -> FrameView<'_> {
        FrameView {
            time: self.time,
            names: self.names.iter().collect(),
            worlds: self.worlds.iter().map(Vec::as_slice).collect(),
            weights: self.weights.iter().map(|(n, w)| (*n, w.as_slice())).collect(),
            primitives: self.primitives.iter().map(|(k, p)| (*k, p.as_slice())).collect(),
        }
    }
}

/// The frames of a document as built in process (what `kloub pose` serializes).
fn doc_frames(doc: &PoseDoc) -> (Vec<Value>, Vec<FrameView<'_>>) {
    let names: Vec<Value> = doc
        .frames
        .first()
        .map(|f| f.nodes.iter().map(|n| n.name.clone().map_or(Value::Null, Value::String)).collect())
        .unwrap_or_default();
    let frames = doc
        .frames
        .iter()
        .map(|f| {
            for (i, node) in f.nodes.iter().enumerate() {
                assert_eq!(node.index as usize, i);
            }
            FrameView {
                time: f.time,
                names: vec![],
                worlds: f.nodes.iter().map(|n| n.world.as_slice()).collect(),
                weights: f.weights.0.iter().map(|(n, w)| (*n as usize, w.as_slice())).collect(),
                primitives: f
                    .primitives
                    .iter()
                    .map(|p| {
                        assert_eq!(p.count * 3, p.positions.len(), "count == positions / 3");
                        ((p.node as usize, p.mesh as usize, p.primitive), p.positions.as_slice())
                    })
                    .collect(),
            }
        })
        .collect();
    (names, frames)
}

// ---------------------------------------------------------------- comparison

/// Differences found: per kind (node translation, node linear part, morph weights, vertex) how
/// many went beyond the tolerance and the worst one; the first few; the worst error relative to
/// its tolerance over all; and how much was compared.
#[derive(Default)]
struct Findings {
    failures: Vec<String>,
    by_kind: BTreeMap<&'static str, Beyond>,
    worst: f64,
    worst_at: String,
    frames: usize,
    vertices: usize,
}

/// The differences of one kind beyond the tolerance.
#[derive(Default, Debug)]
struct Beyond {
    count: usize,
    worst: f64,
    worst_at: String,
}

impl Findings {
    fn record(&mut self, kind: &'static str, err: f64, tol: f64, what: impl FnOnce() -> String) {
        let ratio = err / tol;
        let failed = err.is_nan() || err > tol;
        let worst_of_kind = failed && self.by_kind.get(kind).is_none_or(|b| ratio > b.worst || ratio.is_nan());
        if !(failed || ratio > self.worst) {
            return;
        }
        let what = format!("{} (error {err:e}, tolerance {tol:e})", what());
        if failed {
            let beyond = self.by_kind.entry(kind).or_default();
            beyond.count += 1;
            if worst_of_kind {
                beyond.worst = ratio;
                beyond.worst_at.clone_from(&what);
            }
            if self.failures.len() < 20 {
                self.failures.push(what.clone());
            }
        }
        if ratio > self.worst || ratio.is_nan() {
            self.worst = ratio;
            self.worst_at = what;
        }
    }

    fn failures(&self) -> usize {
        self.by_kind.values().map(|b| b.count).sum()
    }

    fn assert_ok(&self, label: &str) {
        let kinds: Vec<String> = self
            .by_kind
            .iter()
            .map(|(kind, b)| format!("{} × {kind}, the worst {:.2} × its tolerance: {}", b.count, b.worst, b.worst_at))
            .collect();
        assert!(
            self.failures() == 0,
            "{label}: differences beyond the tolerance:\n{}\nthe first ones:\n{}",
            kinds.join("\n"),
            self.failures.join("\n")
        );
    }
}

/// Compares one frame of kloub against the reference: every node world, every morph weight,
/// every vertex of every primitive. `tol` is 1e-5 × the rest-pose diagonal.
fn compare(model: &Model, label: &str, want: &Expected, got: &FrameView<'_>, tol: f64, out: &mut Findings) {
    let time = got.time;
    let ctx = |what: String| format!("{label} t={time}: {what}");
    out.frames += 1;

    assert_eq!(got.worlds.len(), model.nodes.len(), "{}", ctx("every node".into()));
    for (i, (g, e)) in got.worlds.iter().zip(&want.worlds).enumerate() {
        assert_eq!(g.len(), 16);
        // The translation column is a position; the linear part is compared relative to
        // its own scale (a point at distance d from the node moves by |ΔL|·d).
        let err = distance(&g[12..15], &e[12..15]);
        out.record("node translation", err, tol, || {
            ctx(format!("node {i} {} world translation {:?} vs {:?}", model.nodes[i].name, &g[12..15], &e[12..15]))
        });
        let scale = (0..3).map(|c| distance(&e[4 * c..4 * c + 3], &[0.0; 3])).fold(1.0, f64::max);
        let lin = [0, 1, 2, 4, 5, 6, 8, 9, 10].iter().map(|&k| (g[k] - e[k]).abs()).fold(0.0, f64::max);
        out.record("node linear part", lin, 1e-5 * scale, || {
            // Lengths and directions of the columns apart: a scale error or a rotation error.
            let length = |m: &[f64], c: usize| distance(&m[4 * c..4 * c + 3], &[0.0; 3]);
            let ratios: Vec<f64> = (0..3).map(|c| length(g, c) / length(e, c)).collect();
            let turn = (0..3)
                .map(|c| {
                    let (lg, le) = (length(g, c), length(e, c));
                    let cos: f64 = (0..3).map(|r| g[4 * c + r] * e[4 * c + r]).sum::<f64>() / (lg * le);
                    cos.clamp(-1.0, 1.0).acos()
                })
                .fold(0.0, f64::max);
            ctx(format!(
                "node {i} {} world linear part {:?} vs {:?}; column lengths ÷ reference {ratios:?}, \
                 largest column turn {turn:e} rad",
                model.nodes[i].name, g, e
            ))
        });
        let last_row = [3, 7, 11, 15].iter().map(|&k| (g[k] - e[k]).abs()).fold(0.0, f64::max);
        out.record("node last row", last_row, 1e-9, || ctx(format!("node {i} world last row {g:?}")));
    }
    if !got.names.is_empty() {
        for (i, (g, node)) in got.names.iter().zip(&model.nodes).enumerate() {
            assert_eq!(**g, node.name, "{}", ctx(format!("node {i} name")));
        }
    }

    let got_weights: BTreeSet<usize> = got.weights.iter().map(|(n, _)| *n).collect();
    let want_weights: BTreeSet<usize> = want.weights.iter().map(|(n, _)| *n).collect();
    assert_eq!(got_weights, want_weights, "{}", ctx("nodes with weights".into()));
    for (node, w) in &want.weights {
        let g = got.weights.iter().find(|(n, _)| n == node).map(|(_, g)| *g).expect("listed");
        assert_eq!(g.len(), w.len(), "{}", ctx(format!("node {node} weight count")));
        let err = g.iter().zip(w).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        out.record("morph weights", err, 1e-5, || ctx(format!("node {node} morph weights {g:?} vs {w:?}")));
    }

    let got_keys: BTreeSet<PrimitiveKey> = got.primitives.iter().map(|(k, _)| *k).collect();
    let want_keys: BTreeSet<PrimitiveKey> = want.primitives.iter().map(|(k, _)| *k).collect();
    assert_eq!(got.primitives.len(), got_keys.len(), "{}", ctx("a primitive listed twice".into()));
    assert_eq!(got_keys, want_keys, "{}", ctx("(node, mesh, primitive) listed".into()));
    for (key, ps) in &want.primitives {
        let positions = got.primitives.iter().find(|(k, _)| k == key).map(|(_, p)| *p).expect("listed");
        assert_eq!(positions.len(), 3 * ps.len(), "{}", ctx(format!("primitive {key:?} vertex count")));
        for (v, e) in ps.iter().enumerate() {
            let g = &positions[3 * v..3 * v + 3];
            out.vertices += 1;
            out.record("vertex", distance(g, e), tol, || {
                ctx(format!("(node, mesh, primitive) {key:?} vertex {v}: {g:?} vs {e:?}"))
            });
        }
    }
}

// ---------------------------------------------------------------- JSON document checks

fn khronos(rel: &str) -> PathBuf {
    shared_assets().join("khronos").join(rel)
}

/// Runs `kloub pose` in-process and returns its JSON as printed.
fn pose_json(path: &Path, request: &PoseRequest) -> Value {
    let report = pose_file(path, request).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let text = serde_json::to_string(&report.doc).expect("serializes");
    serde_json::from_str(&text).expect("parses back")
}

fn keys(v: &Value) -> Vec<&str> {
    let mut k: Vec<&str> = v.as_object().expect("an object").keys().map(String::as_str).collect();
    k.sort_unstable();
    k
}

/// Every number of `v` is an `f32` value printed in full (`0.1f32` as `0.10000000149011612`,
/// not `0.1`). serde_json's default parser may land 1 ulp off in `f64`, hence the slack.
fn assert_f32_exact(v: &Value) {
    match v {
        Value::Number(n) => {
            let x = n.as_f64().expect("a number");
            let exact = f64::from(x as f32);
            assert!((exact - x).abs() <= 2.0 * f64::EPSILON * x.abs(), "{x} is not an exact f32");
        }
        Value::Array(a) => a.iter().for_each(assert_f32_exact),
        Value::Object(o) => o.values().for_each(assert_f32_exact),
        _ => {}
    }
}

/// Checks the printed document's shape, then every frame against the reference.
fn check(rel: &str, request: &PoseRequest, clip: Option<usize>) {
    let path = khronos(rel);
    let model = Model::load(&path);
    let doc = pose_json(&path, request);
    assert_eq!(keys(&doc), ["asset", "clip", "frames"]);
    assert_eq!(doc["asset"], path.file_name().expect("name").to_str().expect("utf-8"));
    assert_f32_exact(&doc["frames"]);

    match clip {
        None => assert!(doc["clip"].is_null(), "{rel}: clip should be null"),
        Some(c) => {
            let info = &doc["clip"];
            assert_eq!(keys(info), ["duration", "index", "name"]);
            assert_eq!(info["index"], c);
            assert_eq!(info["name"], model.clips[c].name.clone().map_or(Value::Null, Value::String));
            let got = info["duration"].as_f64().map(|d| d as f32);
            assert_eq!(got, Some(model.clips[c].duration as f32), "{rel}: duration");
        }
    }

    let times: Vec<f32> = if request.times.is_empty() { vec![0.0] } else { request.times.clone() };
    let frames = doc["frames"].as_array().expect("frames");
    assert_eq!(frames.len(), times.len());
    let tol = 1e-5 * model.rest_diagonal();
    let mut findings = Findings::default();
    for (frame, &time) in frames.iter().zip(&times) {
        assert_eq!(keys(frame), ["nodes", "primitives", "time", "weights"]);
        assert_eq!(frame["time"].as_f64().map(|t| t as f32), Some(time));
        let parsed = JsonFrame::parse(frame);
        let want = model.evaluate(clip, f64::from(time));
        compare(&model, rel, &want, &parsed.view(), tol, &mut findings);
    }
    findings.assert_ok(rel);
}

const TIMES: [f32; 6] = [0.0, 0.5, 1.04, 2.0, 2.5, 7.0];

fn request(clip: Option<&str>, rest: bool) -> PoseRequest {
    PoseRequest { clip: clip.map(str::to_owned), times: TIMES.to_vec(), rest, ..Default::default() }
}

#[test]
fn rigged_simple_glb_matches_the_reference() {
    let rel = "RiggedSimple/glTF-Binary/RiggedSimple.glb";
    check(rel, &request(None, false), Some(0));
    check(rel, &request(Some("0"), false), Some(0));
    check(rel, &request(None, true), None);
}

#[test]
fn simple_skin_gltf_with_external_buffers_matches_the_reference() {
    let rel = "SimpleSkin/glTF/SimpleSkin.gltf";
    check(rel, &request(None, false), Some(0));
    let mut times = request(None, false);
    times.times = vec![3.3, 5.5, 0.25];
    check(rel, &times, Some(0));
    check(rel, &request(None, true), None);
}

#[test]
fn animated_morph_cube_weights_match_the_reference() {
    let rel = "AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb";
    check(rel, &request(Some("Square"), false), Some(0));
    check(rel, &request(None, true), None);
}

#[test]
fn embedded_data_uri_variants_match_the_reference() {
    // CesiumMan's embedded variant has other key times than the binary one (1.917 s).
    check("CesiumMan/glTF-Embedded/CesiumMan.gltf", &request(None, false), Some(0));
    check("SimpleMorph/glTF-Embedded/SimpleMorph.gltf", &request(None, false), Some(0));
}

#[test]
fn default_time_is_zero_and_names_are_null_when_absent() {
    let path = khronos("SimpleSkin/glTF/SimpleSkin.gltf");
    let doc = pose_json(&path, &PoseRequest::default());
    let frames = doc["frames"].as_array().expect("frames");
    assert_eq!(frames.len(), 1);
    assert_eq!(frames[0]["time"], 0.0);
    assert!(frames[0]["nodes"][0]["name"].is_null());
    assert!(doc["clip"]["name"].is_null(), "SimpleSkin's animation has no name");
    assert_eq!(frames[0]["weights"], serde_json::json!({}));
}

#[test]
fn unknown_clip_lists_the_available_ones() {
    let path = khronos("RiggedSimple/glTF-Binary/RiggedSimple.glb");
    for wanted in ["Walk", "1", "-1"] {
        let err = pose_file(&path, &PoseRequest { clip: Some(wanted.into()), ..Default::default() })
            .expect_err("no such clip");
        assert_eq!(err.pointer.as_deref(), Some("/animations"));
        assert!(err.message.contains(&format!("no clip {wanted:?}")), "{err}");
        assert!(err.message.contains("available: 0"), "{err}");
    }
}

// ---------------------------------------------------------------- the sweep

/// Every model of the asset library, one variant each (relative to `tests/assets`):
/// glTF-Binary where there is one. RiggedSimple's Draco variant is not readable by the reference
/// (kloub's decode is compared with its original in server/tests/optimized.rs); the embedded variants are in
/// [`embedded_data_uri_variants_match_the_reference`]. The quantized AnimatedMorphCube is here
/// as well for its normalized BYTE/SHORT attributes, `byteStride` and normalized UNSIGNED_BYTE
/// weight keys (KHR_mesh_quantization only widens the component types allowed; the reference
/// reads them all).
const ASSETS: &[&str] = &[
    "khronos/AnimatedCube/glTF/AnimatedCube.gltf",
    "khronos/AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb",
    "khronos/AnimatedMorphCube/glTF-Quantized/AnimatedMorphCube.gltf",
    "khronos/AnimatedMorphSphere/glTF-Binary/AnimatedMorphSphere.glb",
    "khronos/AnimatedTriangle/glTF/AnimatedTriangle.gltf",
    "khronos/BoxAnimated/glTF-Binary/BoxAnimated.glb",
    "khronos/CesiumMan/glTF-Binary/CesiumMan.glb",
    "khronos/CesiumMilkTruck/glTF-Binary/CesiumMilkTruck.glb",
    "khronos/Fox/glTF-Binary/Fox.glb",
    "khronos/InterpolationTest/glTF-Binary/InterpolationTest.glb",
    "khronos/MorphPrimitivesTest/glTF-Binary/MorphPrimitivesTest.glb",
    "khronos/MorphStressTest/glTF-Binary/MorphStressTest.glb",
    "khronos/RecursiveSkeletons/glTF-Binary/RecursiveSkeletons.glb",
    "khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb",
    "khronos/RiggedSimple/glTF-Binary/RiggedSimple.glb",
    "khronos/SimpleMorph/glTF/SimpleMorph.gltf",
    "khronos/SimpleSkin/glTF/SimpleSkin.gltf",
    "khronos/TextureTransformMultiTest/glTF-Binary/TextureTransformMultiTest.glb",
    "khronos/TextureTransformTest/glTF/TextureTransformTest.gltf",
    "threejs/RobotExpressive/RobotExpressive.glb",
    "kaykit/Knight/Knight.glb",
];

/// The most key times checked per clip: 12, and 6 for Knight (76 clips of up to 121 keys,
/// 7024 vertices) to keep its test within seconds in a debug build.
fn max_keys(rel: &str) -> usize {
    if rel.contains("Knight") { 6 } else { 12 }
}

/// The times a clip is checked at: 0, up to `max_keys` key times (all of them, or an even
/// pick with the first and the last), the midpoint after each picked key (and the quarter
/// point for CUBICSPLINE clips, where the in- and out-tangents weigh differently), the end
/// and 0.25 s past the end. As `f32`, the type `kloub pose` takes.
fn clip_times(clip: &Clip, max_keys: usize) -> Vec<f32> {
    let keys = clip.key_times();
    let picked: Vec<usize> = if keys.len() <= max_keys {
        (0..keys.len()).collect()
    } else {
        let mut p: Vec<usize> = (0..max_keys).map(|i| i * (keys.len() - 1) / (max_keys - 1)).collect();
        p.dedup();
        p
    };
    let mut times = vec![0.0];
    for &k in &picked {
        times.push(keys[k]);
        if let Some(next) = keys.get(k + 1) {
            times.push((keys[k] + next) / 2.0);
            if clip.has_cubic() {
                times.push(keys[k] + (next - keys[k]) / 4.0);
            }
        }
    }
    times.push(clip.duration);
    times.push(clip.duration + 0.25);
    let mut times: Vec<f32> = times.into_iter().map(|t| t as f32).collect();
    times.sort_by(f32::total_cmp);
    times.dedup();
    times
}

/// Imports `rel` (in the asset library) once with kloub and compares the rest pose and every
/// clip at [`clip_times`] with the reference.
fn sweep(rel: &str) {
    sweep_file(&shared_assets().join(rel), rel, max_keys(rel));
}

/// [`sweep`] for the file at `path`, named `rel` in messages.
fn sweep_file(path: &Path, rel: &str, max_keys: usize) {
    let started = Instant::now();
    let model = Model::load(path);
    let (name, imported) = import_file(path).unwrap_or_else(|e| panic!("{rel}: {e}"));
    let asset = &imported.asset;
    let tol = 1e-5 * model.rest_diagonal();
    let mut findings = Findings::default();
    assert_eq!(asset.clips.len(), model.clips.len(), "{rel}: clip count");

    let rest = pose_asset(&name, asset, &PoseRequest { rest: true, times: vec![0.0, 1.0], ..Default::default() })
        .unwrap_or_else(|e| panic!("{rel} rest: {e}"));
    assert!(rest.clip.is_none());
    let want = model.evaluate(None, 0.0);
    let (names, frames) = doc_frames(&rest);
    assert_eq!(frames.len(), 2);
    for frame in &frames {
        let label = format!("{rel} rest pose");
        compare(&model, &label, &want, frame, tol, &mut findings);
    }
    for (i, (got, node)) in names.iter().zip(&model.nodes).enumerate() {
        assert_eq!(*got, node.name, "{rel}: node {i} name");
    }

    for (c, clip) in model.clips.iter().enumerate() {
        let times = clip_times(clip, max_keys);
        let doc = pose_asset(
            &name,
            asset,
            &PoseRequest { clip: Some(c.to_string()), times: times.clone(), ..Default::default() },
        )
        .unwrap_or_else(|e| panic!("{rel} clip {c}: {e}"));
        let info = doc.clip.as_ref().expect("a clip");
        assert_eq!(info.index, c, "{rel}: clip index");
        assert_eq!(info.name, clip.name, "{rel}: clip {c} name");
        assert_eq!(info.duration as f32, clip.duration as f32, "{rel}: clip {c} duration");
        let (_, frames) = doc_frames(&doc);
        assert_eq!(frames.len(), times.len());
        let label = format!("{rel} clip {c} {:?}", clip.name.as_deref().unwrap_or("(unnamed)"));
        for (frame, &time) in frames.iter().zip(&times) {
            assert_eq!(frame.time as f32, time);
            let want = model.evaluate(Some(c), f64::from(time));
            compare(&model, &label, &want, frame, tol, &mut findings);
        }
    }
    eprintln!(
        "{rel}: {} clips, {} frames, {} vertices compared in {:.2} s; tolerance {tol:e}; \
         worst error {:.3} × its tolerance at {}; beyond: {:?}",
        model.clips.len(),
        findings.frames,
        findings.vertices,
        started.elapsed().as_secs_f64(),
        findings.worst,
        findings.worst_at,
        findings.by_kind.iter().map(|(k, b)| (k, b.count, b.worst)).collect::<Vec<_>>(),
    );
    findings.assert_ok(rel);
}

fn sweep_named(file: &str) {
    let rel = ASSETS.iter().find(|rel| rel.ends_with(file)).unwrap_or_else(|| panic!("{file} is not in ASSETS"));
    sweep(rel);
}

#[test]
fn every_model_is_in_the_sweep() {
    // A model = a folder of variants (khronos/<Model>/<variant>/) or a folder with a model file.
    fn walk(dir: &Path, found: &mut BTreeSet<PathBuf>) {
        for entry in std::fs::read_dir(dir).expect("readable") {
            let path = entry.expect("an entry").path();
            if path.is_dir() {
                walk(&path, found);
            } else if matches!(path.extension().and_then(|e| e.to_str()), Some("glb" | "gltf")) {
                found.insert(path);
            }
        }
    }
    let root = shared_assets();
    let mut files = BTreeSet::new();
    walk(&root, &mut files);
    assert!(files.len() >= 30, "the asset library is at {}", root.display());
    let model_of = |file: &Path| -> PathBuf {
        let rel = file.strip_prefix(&root).expect("under the root");
        let parts: Vec<_> = rel.components().collect();
        if parts.first().map(|c| c.as_os_str()) == Some("khronos".as_ref()) {
            parts[..2].iter().collect()
        } else {
            rel.parent().expect("a folder").to_path_buf()
        }
    };
    let models: BTreeSet<PathBuf> = files.iter().map(|f| model_of(f)).collect();
    let swept: BTreeSet<PathBuf> = ASSETS
        .iter()
        .map(|rel| {
            let file = root.join(rel);
            assert!(file.is_file(), "{rel} is missing");
            model_of(&file)
        })
        .collect();
    let missing: Vec<_> = models.difference(&swept).collect();
    assert!(missing.is_empty(), "models not in ASSETS: {missing:?}");
}

macro_rules! sweeps {
    ($($test:ident: $file:literal;)*) => {
        $(
            #[test]
            fn $test() {
                sweep_named($file);
            }
        )*
    };
}

sweeps! {
    sweep_animated_cube: "AnimatedCube.gltf";
    sweep_animated_morph_cube: "glTF-Binary/AnimatedMorphCube.glb";
    sweep_animated_morph_cube_quantized: "glTF-Quantized/AnimatedMorphCube.gltf";
    sweep_animated_morph_sphere: "AnimatedMorphSphere.glb";
    sweep_animated_triangle: "AnimatedTriangle.gltf";
    sweep_box_animated: "BoxAnimated.glb";
    sweep_cesium_man: "CesiumMan.glb";
    sweep_cesium_milk_truck: "CesiumMilkTruck.glb";
    sweep_fox: "Fox.glb";
    sweep_interpolation_test: "InterpolationTest.glb";
    sweep_morph_primitives_test: "MorphPrimitivesTest.glb";
    sweep_morph_stress_test: "MorphStressTest.glb";
    sweep_recursive_skeletons: "RecursiveSkeletons.glb";
    sweep_rigged_figure: "RiggedFigure.glb";
    sweep_rigged_simple: "RiggedSimple.glb";
    sweep_simple_morph: "SimpleMorph.gltf";
    sweep_simple_skin: "SimpleSkin.gltf";
    sweep_texture_transform_multi_test: "TextureTransformMultiTest.glb";
    sweep_texture_transform_test: "TextureTransformTest.gltf";
    sweep_robot_expressive: "RobotExpressive.glb";
    sweep_knight: "Knight.glb";
}

#[test]
fn every_sweep_entry_has_a_test() {
    // The macro above lists one test per ASSETS entry, by a unique file-name suffix.
    let suffixes = [
        "AnimatedCube.gltf",
        "glTF-Binary/AnimatedMorphCube.glb",
        "glTF-Quantized/AnimatedMorphCube.gltf",
        "AnimatedMorphSphere.glb",
        "AnimatedTriangle.gltf",
        "BoxAnimated.glb",
        "CesiumMan.glb",
        "CesiumMilkTruck.glb",
        "Fox.glb",
        "InterpolationTest.glb",
        "MorphPrimitivesTest.glb",
        "MorphStressTest.glb",
        "RecursiveSkeletons.glb",
        "RiggedFigure.glb",
        "RiggedSimple.glb",
        "SimpleMorph.gltf",
        "SimpleSkin.gltf",
        "TextureTransformMultiTest.glb",
        "TextureTransformTest.gltf",
        "RobotExpressive.glb",
        "Knight.glb",
    ];
    assert_eq!(suffixes.len(), ASSETS.len());
    for rel in ASSETS {
        let matching = suffixes.iter().filter(|s| rel.ends_with(*s)).count();
        assert_eq!(matching, 1, "{rel}: one sweep test");
    }
}

// ---------------------------------------------------------------- weights renormalized

#[test]
fn robot_expressive_skin_weights_are_renormalized() {
    // RobotExpressive's skin weights do not sum to 1 (FBX2glTF). The spec says the engine
    // treats them as normalized; kloub's importer renormalizes them and warns per primitive.
    let rel = "threejs/RobotExpressive/RobotExpressive.glb";
    let path = shared_assets().join(rel);
    let model = Model::load(&path);
    let (name, imported) = import_file(&path).unwrap_or_else(|e| panic!("{rel}: {e}"));

    // The primitives with weights that do not sum to 1, by the reference.
    let mut off = BTreeSet::new();
    let mut off_vertices = 0;
    for (m, mesh) in model.meshes.iter().enumerate() {
        for (p, prim) in mesh.iter().enumerate() {
            let n = prim.weight_sums.iter().filter(|&&s| s > 0.0 && (s - 1.0).abs() > 1e-3).count();
            if n > 0 {
                off.insert(format!("/meshes/{m}/primitives/{p}/attributes/WEIGHTS_0"));
                off_vertices += n;
            }
        }
    }
    assert!(off_vertices > 100, "the case is still in the file");
    let warned: BTreeSet<String> =
        imported.warnings.iter().filter(|w| w.message.contains("renormalized")).map(|w| w.pointer.clone()).collect();
    assert_eq!(warned, off, "a warning for each primitive with unnormalized weights");

    // kloub matches the normalized reference (the sweep checks every clip); without the
    // normalization it would be far off: the check discriminates.
    let clip = model.clips.iter().position(|c| c.name.as_deref() == Some("Wave")).expect("a Wave clip");
    let doc = pose_asset(
        &name,
        &imported.asset,
        &PoseRequest { clip: Some("Wave".into()), times: vec![0.5], ..Default::default() },
    )
    .expect("poses");
    let (_, frames) = doc_frames(&doc);
    let want = model.evaluate(Some(clip), 0.5);
    let tol = 1e-5 * model.rest_diagonal();
    let mut findings = Findings::default();
    compare(&model, rel, &want, &frames[0], tol, &mut findings);
    findings.assert_ok(rel);

    let mut unnormalized = model;
    for prim in unnormalized.meshes.iter_mut().flatten() {
        for (inf, &sum) in prim.influences.iter_mut().zip(&prim.weight_sums) {
            for (_, w) in inf.iter_mut() {
                *w *= sum;
            }
        }
    }
    let raw = unnormalized.evaluate(Some(clip), 0.5);
    let mut findings = Findings::default();
    compare(&unnormalized, rel, &raw, &frames[0], tol, &mut findings);
    assert!(
        findings.failures() > 100 && findings.worst > 100.0,
        "unnormalized weights would have been caught ({} vertices, worst {} × tolerance)",
        findings.failures(),
        findings.worst
    );
}

// ---------------------------------------------------------------- InterpolationTest by hand

/// kloub's world matrix of `node` in clip `clip` at each time of `times`.
fn interpolation_worlds(clip: &str, node: usize, times: &[f32]) -> Vec<[f64; 16]> {
    let path = khronos("InterpolationTest/glTF-Binary/InterpolationTest.glb");
    let report =
        pose_file(&path, &PoseRequest { clip: Some(clip.into()), times: times.to_vec(), ..Default::default() })
            .unwrap_or_else(|e| panic!("{clip}: {e}"));
    assert_eq!(report.doc.clip.as_ref().and_then(|c| c.name.as_deref()), Some(clip));
    report.doc.frames.iter().map(|f| f.nodes[node].world).collect()
}

/// `(a + b) / 2` and `a + (b − a) / 4` of two key times, as the `f32` `kloub pose` takes.
fn mid(a: f32, b: f32) -> f32 {
    ((f64::from(a) + f64::from(b)) / 2.0) as f32
}

fn quarter(a: f32, b: f32) -> f32 {
    (f64::from(a) + (f64::from(b) - f64::from(a)) / 4.0) as f32
}

/// Hermite basis at `u` for the value before and the value after (the tangent terms are
/// computed by hand where the tangents are not 0).
fn h00(u: f64) -> f64 {
    2.0 * u.powi(3) - 3.0 * u * u + 1.0
}

fn h01(u: f64) -> f64 {
    -2.0 * u.powi(3) + 3.0 * u * u
}

#[test]
fn interpolation_test_matches_hand_computed_values() {
    // Key times and values as stored in InterpolationTest (f32), from its accessors. The
    // expected values below follow from the spec's formulas worked by hand: STEP holds the
    // key at or before t; LINEAR interpolates (for rotations about one axis, slerp turns the
    // angle linearly); CUBICSPLINE with zero tangents (translation and scale here) is
    // h00(u)·v0 + h01(u)·v1, 0.5/0.5 at the midpoint and 0.84375/0.15625 at u = 1/4.
    let tol = 1e-5;
    let close = |got: f64, want: f64, what: &str| {
        assert!((got - want).abs() <= tol, "{what}: kloub {got}, by hand {want}");
    };
    let col_norm = |m: &[f64; 16], c: usize| distance(&m[4 * c..4 * c + 3], &[0.0; 3]);

    // Scale: keys at these times, uniform scale 1, 0.5, 1, 0.5, 1.
    let st: [f32; 5] = [0.041666668, 0.41666666, 0.875, 1.25, 1.6666666];
    let sv = [1.0, 0.5, 1.0, 0.5, 1.0];
    // (time, STEP, LINEAR, CUBICSPLINE)
    let mut scale_cases: Vec<(f32, f64, f64, f64)> = vec![(0.0, 1.0, 1.0, 1.0), (2.0, 1.0, 1.0, 1.0)];
    for k in 0..5 {
        scale_cases.push((st[k], sv[k], sv[k], sv[k]));
    }
    for k in 0..4 {
        let (a, b) = (sv[k], sv[k + 1]);
        scale_cases.push((mid(st[k], st[k + 1]), a, (a + b) / 2.0, (a + b) / 2.0));
        scale_cases.push((quarter(st[k], st[k + 1]), a, a + (b - a) / 4.0, 0.84375 * a + 0.15625 * b));
    }
    for (clip, node, which) in [("Step Scale", 0, 0), ("Linear Scale", 3, 1), ("CubicSpline Scale", 4, 2)] {
        let times: Vec<f32> = scale_cases.iter().map(|c| c.0).collect();
        let worlds = interpolation_worlds(clip, node, &times);
        for (m, case) in worlds.iter().zip(&scale_cases) {
            let want = [case.1, case.2, case.3][which];
            for c in 0..3 {
                close(col_norm(m, c), want, &format!("{clip} t={} scale {c}", case.0));
            }
        }
    }
    // Spot values, written out: LINEAR 0.75 and CUBICSPLINE 0.578125 between 0.5 and 1.
    assert_eq!(0.84375 * 0.5 + 0.15625 * 1.0, 0.578125);
    assert_eq!(h00(0.25), 0.84375);
    assert_eq!(h01(0.25), 0.15625);

    // Translation, STEP: y = 6.6652265, 10, 6, 10, 6 at these times (x = 0, z = 0).
    let tt: [f32; 5] = [0.0, 0.45833334, 0.8333333, 1.2916666, 1.7083334];
    let ty = [6.6652265f32, 10.0, 6.0, 10.0, 6.0].map(f64::from);
    let mut cases = vec![(2.5f32, ty[4])];
    for k in 0..5 {
        cases.push((tt[k], ty[k]));
        if k < 4 {
            cases.push((mid(tt[k], tt[k + 1]), ty[k]));
        }
    }
    let times: Vec<f32> = cases.iter().map(|c| c.0).collect();
    for (m, (t, y)) in interpolation_worlds("Step Translation", 8, &times).iter().zip(&cases) {
        close(m[12], 0.0, &format!("Step Translation t={t} x"));
        close(m[13], *y, &format!("Step Translation t={t} y"));
        close(m[14], 0.0, &format!("Step Translation t={t} z"));
    }

    // Translation, LINEAR (x = -3.2975807) and CUBICSPLINE (x = 3.3051798, zero tangents):
    // y = (6.6210146 | 6.640117), 10, 6, 10, 6 at these times.
    let lt: [f32; 5] = [0.0, 0.41666666, 0.8333333, 1.25, 1.6666666];
    for (clip, node, x, y0, cubic) in [
        ("Linear Translation", 10, -3.2975807f32, 6.6210146f32, false),
        ("CubicSpline Translation", 9, 3.3051798, 6.640117, true),
    ] {
        let ys = [f64::from(y0), 10.0, 6.0, 10.0, 6.0];
        let mut cases = vec![(0.0f32, ys[0]), (2.0, ys[4])];
        for k in 0..5 {
            cases.push((lt[k], ys[k]));
            if k < 4 {
                let (a, b) = (ys[k], ys[k + 1]);
                cases.push((mid(lt[k], lt[k + 1]), (a + b) / 2.0));
                let q = if cubic { 0.84375 * a + 0.15625 * b } else { a + (b - a) / 4.0 };
                cases.push((quarter(lt[k], lt[k + 1]), q));
            }
        }
        let times: Vec<f32> = cases.iter().map(|c| c.0).collect();
        for (m, (t, y)) in interpolation_worlds(clip, node, &times).iter().zip(&cases) {
            close(m[12], f64::from(x), &format!("{clip} t={t} x"));
            close(m[13], *y, &format!("{clip} t={t} y"));
            close(m[14], 0.0, &format!("{clip} t={t} z"));
        }
    }
    // The first LINEAR midpoint, written out.
    assert!(((f64::from(6.6210146f32) + 10.0) / 2.0 - 8.3105073).abs() < 1e-6);

    // Rotation about -z: keys 0°, -45°, -90°, -135°, -180° at these times; the angle is
    // read back from the world matrix (column 0 = (cos θ, sin θ, 0) times the scale).
    let rt: [f32; 5] = [0.0, 0.41666666, 0.875, 1.25, 1.7083334];
    let angle = |m: &[f64; 16]| m[1].atan2(m[0]).to_degrees();
    let close_angle = |got: f64, want: f64, what: &str| {
        let d = (got - want + 540.0).rem_euclid(360.0) - 180.0;
        assert!(d.abs() <= 1e-4, "{what}: kloub {got}°, by hand {want}°");
    };
    let key_angle = |k: usize| -45.0 * k as f64;
    // (time, STEP, LINEAR)
    let mut cases: Vec<(f32, f64, f64)> = vec![(3.0, -180.0, -180.0)];
    for k in 0..5 {
        cases.push((rt[k], key_angle(k), key_angle(k)));
        if k < 4 {
            cases.push((mid(rt[k], rt[k + 1]), key_angle(k), key_angle(k) - 22.5));
            cases.push((quarter(rt[k], rt[k + 1]), key_angle(k), key_angle(k) - 11.25));
        }
    }
    let times: Vec<f32> = cases.iter().map(|c| c.0).collect();
    let step = interpolation_worlds("Step Rotation", 5, &times);
    let linear = interpolation_worlds("Linear Rotation", 7, &times);
    for ((s, l), (t, a_step, a_linear)) in step.iter().zip(&linear).zip(&cases) {
        close_angle(angle(s), *a_step, &format!("Step Rotation t={t}"));
        close_angle(angle(l), *a_linear, &format!("Linear Rotation t={t}"));
        close(s[10], 1.0, "Step Rotation stays about z");
        close(l[10], 1.0, "Linear Rotation stays about z");
    }

    use std::f32::consts::FRAC_1_SQRT_2;
    // Rotation, CUBICSPLINE: (z, w) of the in-tangent, value and out-tangent of each key.
    // The tangents are not 0, so p = h00·v0 + h10·td·b0 + h01·v1 + h11·td·a1, then normalized;
    // θ = 2·atan2(z, w). With h10 = u³ − 2u² + u and h11 = u³ − u²: at u = 1/2 they are
    // 1/8 and −1/8; at u = 1/4, 9/64 and −3/64.
    let keys: [[(f32, f32); 3]; 5] = [
        [(-0.0, 1.0), (-0.0, 1.0), (-0.0, 1.0)],
        [(-0.0478909, 0.99885267), (-0.38268346, 0.92387956), (-0.0478909, 0.99885267)],
        [(-0.035464317, 0.999371), (-FRAC_1_SQRT_2, FRAC_1_SQRT_2), (-0.035464317, 0.999371)],
        [(-0.050318874, 0.9987332), (-0.9238795, 0.3826835), (-0.050318874, 0.9987332)],
        [(-0.0, 1.0), (-1.0, -4.371139e-8), (-0.0, 1.0)],
    ];
    let f = |p: (f32, f32)| (f64::from(p.0), f64::from(p.1));
    assert_eq!(FRAC_1_SQRT_2, 0.70710677, "the file's 0.7071068");
    let mut cases: Vec<(f32, f64)> = vec![(2.0, 180.0)];
    for k in 0..5 {
        let (z, w) = f(keys[k][1]);
        cases.push((rt[k], 2.0 * z.atan2(w).to_degrees()));
    }
    for k in 0..4 {
        let td = f64::from(rt[k + 1]) - f64::from(rt[k]);
        let (v0, b0, v1, a1) = (f(keys[k][1]), f(keys[k][2]), f(keys[k + 1][1]), f(keys[k + 1][0]));
        for (u, time, h10, h11) in
            [(0.5, mid(rt[k], rt[k + 1]), 0.125, -0.125), (0.25, quarter(rt[k], rt[k + 1]), 9.0 / 64.0, -3.0 / 64.0)]
        {
            // The key interval kloub sees is between the f32 times; u as kloub computes it.
            let u_exact = (f64::from(time) - f64::from(rt[k])) / td;
            assert!((u_exact - u).abs() < 1e-6);
            let z = h00(u) * v0.0 + h10 * td * b0.0 + h01(u) * v1.0 + h11 * td * a1.0;
            let w = h00(u) * v0.1 + h10 * td * b0.1 + h01(u) * v1.1 + h11 * td * a1.1;
            cases.push((time, 2.0 * z.atan2(w).to_degrees()));
        }
    }
    let times: Vec<f32> = cases.iter().map(|c| c.0).collect();
    for (m, (t, want)) in interpolation_worlds("CubicSpline Rotation", 6, &times).iter().zip(&cases) {
        close_angle(angle(m), *want, &format!("CubicSpline Rotation t={t}"));
        close(m[10], 1.0, "CubicSpline Rotation stays about z");
    }
}

// ---------------------------------------------------------------- slerp stays on the unit sphere

#[test]
fn slerped_rotations_keep_unit_length() {
    // Slerp of two unit quaternions is a unit quaternion (spec, appendix on interpolation), so
    // a joint animated by LINEAR rotations only keeps the column lengths of its rest scale.
    // Fox's Walk at 0.4375 s is the midpoint of two keys of b_LeftUpperArm_09 that are 4°
    // apart (dot 0.99937): where sin θ comes out of 1 − d² in f32 and the result is not
    // renormalized, the quaternion's length is off by 1e-5 and the matrix gets a spurious
    // scale of 1.00003 along two axes.
    let path = khronos("Fox/glTF-Binary/Fox.glb");
    let model = Model::load(&path);
    let report =
        pose_file(&path, &PoseRequest { clip: Some("Walk".into()), times: vec![0.4375], ..Default::default() })
            .expect("poses");
    let clip = model.clips.iter().position(|c| c.name.as_deref() == Some("Walk")).expect("Walk");
    let want = model.evaluate(Some(clip), 0.4375);
    let norm = |m: &[f64], c: usize| distance(&m[4 * c..4 * c + 3], &[0.0; 3]);
    let mut bad = Vec::new();
    for (i, node) in report.doc.frames[0].nodes.iter().enumerate() {
        for c in 0..3 {
            let (got, exp) = (norm(&node.world, c), norm(&want.worlds[i], c));
            if (got - exp).abs() > 4e-6 {
                bad.push(format!("node {i} {:?} column {c}: length {got} (reference {exp})", node.name));
            }
        }
    }
    assert!(bad.is_empty(), "world matrices with a spurious scale:\n{}", bad.join("\n"));
}

// ---------------------------------------------------------------- spec features no asset uses

/// A glTF buffer with its views and accessors, for [`features_gltf`].
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    /// A buffer view of `bytes` (4-byte aligned), with `stride` as its byteStride.
    fn view(&mut self, bytes: &[u8], stride: Option<usize>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = serde_json::json!({
            "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()
        });
        if let Some(s) = stride {
            v["byteStride"] = serde_json::json!(s);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn accessor(&mut self, a: Value) -> usize {
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// A plain FLOAT accessor of `values` (`kind` components each) in a view of its own.
    fn floats(&mut self, values: &[f32], kind: &str) -> usize {
        let width = match kind {
            "SCALAR" => 1,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => 16,
        };
        let view = self.view(&le_f32(values), None);
        self.accessor(serde_json::json!({
            "bufferView": view, "componentType": 5126, "count": values.len() / width, "type": kind
        }))
    }
}

fn le_f32(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn le_u16(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn le_i16(v: &[i16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// A .gltf (buffer as a data: URI) with what none of the library's models has: JOINTS_1 and
/// WEIGHTS_1 (8 influences), normalized UNSIGNED_SHORT/UNSIGNED_BYTE weights, an interleaved
/// view (POSITION and JOINTS_0, byteStride 16), sparse accessors with and without a buffer
/// view, normalized BYTE and SHORT morph targets (KHR_mesh_quantization) with byteStride 8,
/// normalized SHORT and BYTE rotation keys and UNSIGNED_BYTE weight keys, CUBICSPLINE weights,
/// translation and rotation with tangents that are not 0, a STEP scale, a root `matrix`, one
/// mesh under two skins (one without inverse bind matrices), `node.weights` over
/// `mesh.weights`, a rigid mesh under a joint, two scenes with `scene` = 1, and sampler inputs
/// shared by two channels.
fn features_gltf() -> Value {
    use serde_json::json;
    let mut b = Builder::default();

    // Mesh 0: 6 vertices; POSITION interleaved with JOINTS_0, then sparse-patched.
    let positions: [[f32; 3]; 6] =
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [2.0, 1.0, 0.0]];
    let joints0: [[u8; 4]; 6] = [[0, 1, 2, 3], [1, 2, 3, 4], [2, 3, 4, 0], [3, 4, 0, 1], [4, 0, 1, 2], [0, 2, 4, 1]];
    let mut interleaved = Vec::new();
    for (p, j) in positions.iter().zip(&joints0) {
        interleaved.extend(le_f32(p));
        interleaved.extend(j);
    }
    let iv = b.view(&interleaved, Some(16));
    let sparse_ix = b.view(&[2u8, 5], None);
    let sparse_val = b.view(&le_f32(&[2.0, 0.5, 0.0, 2.5, 1.2, 0.3]), None);
    let position = b.accessor(json!({
        "bufferView": iv, "componentType": 5126, "count": 6, "type": "VEC3",
        "min": [0.0, 0.0, 0.0], "max": [2.5, 1.2, 0.3],
        "sparse": {"count": 2,
            "indices": {"bufferView": sparse_ix, "componentType": 5121},
            "values": {"bufferView": sparse_val}}
    }));
    let joints_0 = b.accessor(json!({
        "bufferView": iv, "byteOffset": 12, "componentType": 5121, "count": 6, "type": "VEC4"
    }));
    let w0: [[f64; 4]; 6] = [
        [0.4, 0.2, 0.1, 0.1],
        [0.25, 0.25, 0.25, 0.0],
        [1.0, 0.0, 0.0, 0.0],
        [0.5, 0.5, 0.0, 0.0],
        [0.1, 0.1, 0.1, 0.1],
        [0.3, 0.3, 0.2, 0.1],
    ];
    let w1 = [0.2, 0.25, 0.0, 0.0, 0.6, 0.1];
    let w0_u16: Vec<u16> = w0.iter().flatten().map(|w| (w * 65535.0).round() as u16).collect();
    let view = b.view(&le_u16(&w0_u16), None);
    let weights_0 = b.accessor(json!({
        "bufferView": view, "componentType": 5123, "normalized": true, "count": 6, "type": "VEC4"
    }));
    let j1: Vec<u16> = [4u16, 0, 1, 2, 3, 3].iter().flat_map(|&j| [j, 0, 0, 0]).collect();
    let view = b.view(&le_u16(&j1), None);
    let joints_1 = b.accessor(json!({
        "bufferView": view, "componentType": 5123, "count": 6, "type": "VEC4"
    }));
    let w1_u8: Vec<u8> = w1.iter().flat_map(|w| [(w * 255.0_f64).round() as u8, 0, 0, 0]).collect();
    let view = b.view(&w1_u8, None);
    let weights_1 = b.accessor(json!({
        "bufferView": view, "componentType": 5121, "normalized": true, "count": 6, "type": "VEC4"
    }));
    // Target 0: sparse only (no buffer view), normalized BYTE; target 1: normalized SHORT,
    // 6-byte elements 8 bytes apart.
    let t0_ix = b.view(&le_u16(&[1, 5]), None);
    let t0_val = b.view(&[127u8, 0, (-64i8) as u8, 0, (-127i8) as u8, 100], None);
    let target_0 = b.accessor(json!({
        "componentType": 5120, "normalized": true, "count": 6, "type": "VEC3",
        "sparse": {"count": 2,
            "indices": {"bufferView": t0_ix, "componentType": 5123},
            "values": {"bufferView": t0_val}}
    }));
    let t1: Vec<i16> = (0..6i16).flat_map(|v| [1000 * v, 16384, -3000 * v, 0]).collect();
    let view = b.view(&le_i16(&t1), Some(8));
    let target_1 = b.accessor(json!({
        "bufferView": view, "componentType": 5122, "normalized": true, "count": 6, "type": "VEC3"
    }));
    let view = b.view(&le_u16(&[0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4]), None);
    let indices = b.accessor(json!({
        "bufferView": view, "componentType": 5123, "count": 12, "type": "SCALAR"
    }));

    // Mesh 1: a triangle whose POSITION is sparse over zeros (no buffer view).
    let tri_ix = b.view(&[1u8, 2], None);
    let tri_val = b.view(&le_f32(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]), None);
    let triangle = b.accessor(json!({
        "componentType": 5126, "count": 3, "type": "VEC3",
        "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0],
        "sparse": {"count": 2,
            "indices": {"bufferView": tri_ix, "componentType": 5121},
            "values": {"bufferView": tri_val}}
    }));

    // Skin 0's inverse bind matrices: translations.
    let ibm: Vec<f32> = (0..5)
        .flat_map(|j| {
            let mut m = [1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.];
            m[12] = -0.5 * j as f32;
            m[13] = -1.0;
            m[14] = 0.1 * j as f32;
            m
        })
        .collect();
    let ibm = b.floats(&ibm, "MAT4");

    // Clip 0 "Cubic".
    let t3 = b.floats(&[0.0, 1.0, 2.5], "SCALAR");
    let cubic_weights = b.floats(
        &[
            0.0, 0.0, 0.0, 0.0, 1.0, -0.5, // key 0: in, value, out (2 targets each)
            0.5, 0.2, 1.0, 0.5, -0.5, 0.3, // key 1
            0.2, 0.0, 0.3, 1.0, 0.0, 0.0, // key 2
        ],
        "SCALAR",
    );
    let cubic_translation = b.floats(
        &[
            0., 0., 0., 1., 0., 0., 0., 1., 0., // key 0
            1., 0., 0., 1., 1., 0., 0., 0., 1., // key 1
            0., 0., 0., 2., 0., 1., 0., 0., 0., // key 2
        ],
        "VEC3",
    );
    let step_times = b.floats(&[0.0, 0.5, 1.5], "SCALAR");
    let step_scale = b.floats(&[1., 1., 1., 1., 2., 1., 0.5, 0.5, 0.5], "VEC3");
    let t2 = b.floats(&[0.0, 2.0], "SCALAR");
    let view = b.view(&le_i16(&[0, 0, 0, 32767, 0, 0, 28377, 16384]), None);
    let short_rotation = b.accessor(json!({
        "bufferView": view, "componentType": 5122, "normalized": true, "count": 2, "type": "VEC4"
    }));
    let t_late = b.floats(&[0.5, 1.5], "SCALAR");
    let cubic_rotation = b.floats(
        &[
            0., 0., 0., 0., 0., 0., 0., 1., 0.5, 0., 0., 0., // key 0
            0., 0.5, 0., 0., 0.70710677, 0., 0., 0.70710677, 0., 0., 0., 0., // key 1
        ],
        "VEC4",
    );
    // Clip 1 "Linear".
    let t01 = b.floats(&[0.0, 1.0], "SCALAR");
    let view = b.view(&[0u8, 255, 128, 64], None);
    let ubyte_weights = b.accessor(json!({
        "bufferView": view, "componentType": 5121, "normalized": true, "count": 4, "type": "SCALAR"
    }));
    let t012 = b.floats(&[0.0, 1.0, 2.0], "SCALAR");
    let linear_translation = b.floats(&[0., 1., 0., 0., 1.5, 0., 0.5, 1., 0.], "VEC3");
    let step_rotation = b.floats(&[0., 0., 0., 1., 0., 0.70710677, 0., 0.70710677], "VEC4");
    let view = b.view(&[0u8, 0, 0, 127, 0, (-90i8) as u8, 0, 90], None);
    let byte_rotation = b.accessor(json!({
        "bufferView": view, "componentType": 5120, "normalized": true, "count": 2, "type": "VEC4"
    }));

    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&b.bin));
    json!({
        "asset": {"version": "2.0", "generator": "kloub tests/pose.rs"},
        "extensionsUsed": ["KHR_mesh_quantization"],
        "extensionsRequired": ["KHR_mesh_quantization"],
        "scene": 1,
        "scenes": [{"nodes": [8]}, {"nodes": [0, 7]}],
        "nodes": [
            {"name": "root", "children": [1, 6],
             "matrix": [0., 0., -2., 0., 0., 2., 0., 0., 2., 0., 0., 0., 1., 2., 3., 1.]},
            {"name": "j0", "translation": [0., 1., 0.], "children": [2]},
            {"name": "j1", "translation": [1., 0., 0.], "rotation": [0., 0., 0.38268343, 0.92387953],
             "children": [3]},
            {"name": "j2", "translation": [1., 0., 0.], "scale": [1., 2., 1.], "children": [4]},
            {"name": "j3", "translation": [0., 1., 0.], "children": [5, 9]},
            {"name": "j4", "translation": [0., 0., 1.]},
            {"name": "skinned", "mesh": 0, "skin": 0, "translation": [5., 5., 5.],
             "weights": [0.3, 0.6]},
            {"name": "second", "mesh": 0, "skin": 1, "rotation": [0., 1., 0., 0.]},
            {"name": "other scene", "mesh": 1},
            {"name": "rigid", "mesh": 1, "translation": [0., 0.5, 0.], "scale": [0.5, 0.5, 0.5]}
        ],
        "meshes": [
            {"weights": [0.1, 0.2], "primitives": [{
                "attributes": {"POSITION": position, "JOINTS_0": joints_0, "WEIGHTS_0": weights_0,
                               "JOINTS_1": joints_1, "WEIGHTS_1": weights_1},
                "indices": indices,
                "targets": [{"POSITION": target_0}, {"POSITION": target_1}]}]},
            {"primitives": [{"attributes": {"POSITION": triangle}}]}
        ],
        "skins": [
            {"joints": [1, 2, 3, 4, 5], "inverseBindMatrices": ibm},
            {"joints": [5, 4, 3, 2, 1]}
        ],
        "animations": [
            {"name": "Cubic",
             "samplers": [
                {"input": t3, "output": cubic_weights, "interpolation": "CUBICSPLINE"},
                {"input": t3, "output": cubic_translation, "interpolation": "CUBICSPLINE"},
                {"input": step_times, "output": step_scale, "interpolation": "STEP"},
                {"input": t2, "output": short_rotation},
                {"input": t_late, "output": cubic_rotation, "interpolation": "CUBICSPLINE"}],
             "channels": [
                {"sampler": 0, "target": {"node": 6, "path": "weights"}},
                {"sampler": 1, "target": {"node": 2, "path": "translation"}},
                {"sampler": 2, "target": {"node": 3, "path": "scale"}},
                {"sampler": 3, "target": {"node": 4, "path": "rotation"}},
                {"sampler": 4, "target": {"node": 5, "path": "rotation"}}]},
            {"name": "Linear",
             "samplers": [
                {"input": t01, "output": ubyte_weights, "interpolation": "LINEAR"},
                {"input": t012, "output": linear_translation},
                {"input": t01, "output": step_rotation, "interpolation": "STEP"},
                {"input": t01, "output": byte_rotation}],
             "channels": [
                {"sampler": 0, "target": {"node": 7, "path": "weights"}},
                {"sampler": 1, "target": {"node": 1, "path": "translation"}},
                {"sampler": 2, "target": {"node": 9, "path": "rotation"}},
                {"sampler": 3, "target": {"node": 2, "path": "rotation"}}]}
        ],
        "buffers": [{"byteLength": b.bin.len(), "uri": uri}],
        "bufferViews": b.views,
        "accessors": b.accessors
    })
}

#[test]
fn features_no_asset_uses_match_the_reference() {
    let dir = std::env::temp_dir().join(format!("kloub-pose-features-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary folder");
    let path = dir.join("features.gltf");
    let text = serde_json::to_string_pretty(&features_gltf()).expect("serializes");
    std::fs::write(&path, text).expect("writes");

    // The reference reads what it should: the sparse substitutions, normalized values and
    // both influence sets.
    let model = Model::load(&path);
    let prim = &model.meshes[0][0];
    assert_eq!(prim.positions[2], [2.0, 0.5, 0.0]);
    assert_eq!(prim.positions[5], [2.5, f64::from(1.2f32), f64::from(0.3f32)]);
    let t0 = prim.targets[0].as_ref().expect("target 0");
    assert_eq!(t0[0], [0.0; 3]);
    assert_eq!(t0[1], [1.0, 0.0, -64.0 / 127.0]);
    assert_eq!(t0[5], [0.0, -1.0, 100.0 / 127.0]);
    let t1 = prim.targets[1].as_ref().expect("target 1");
    assert_eq!(t1[2], [2000.0 / 32767.0, 16384.0 / 32767.0, -6000.0 / 32767.0]);
    assert_eq!(prim.influences[0].len(), 5, "4 from JOINTS_0, 1 from JOINTS_1");
    assert_eq!(prim.influences[0][4].0, 4);
    assert_eq!(model.meshes[1][0].positions, [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    assert_eq!(model.scene, [0, 1, 2, 3, 4, 5, 6, 7, 9], "scene 1, not scene 0");
    assert_eq!(model.clips[0].channels[0].values.len(), 9, "3 keys × (in, value, out)");

    sweep_file(&path, "features.gltf", 12);
    std::fs::remove_dir_all(&dir).expect("cleans up");
}
