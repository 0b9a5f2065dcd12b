//! `kloub pose` against an independent reference.
//!
//! The reference below reads the glTF files itself (serde_json + a little-endian accessor
//! reader) and applies the glTF 2.0 formulas in plain `f64`, sharing no code with kloub-core:
//! STEP/LINEAR keys (slerp on the shortest arc for rotations, values held outside the key
//! range), `local = matrix` or `T * R * S`, `world = world(parent) * local`, morphing
//! `p = base + Σ wᵢ · δᵢ`, skinning `p = Σ w · (world(joint) · inverseBind) · v` (the mesh
//! node's own transform ignored) and `world(node) · p` unskinned. `kloub pose`'s JSON (through
//! [`kloub_server::pose::pose_file`], serialized and parsed back) must match it within
//! 1e-5 × the bounding-box diagonal of the deformed scene.

use kloub_server::pose::{PoseRequest, pose_file};
use kloub_tests::shared_assets;
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

type Mat = [f64; 16]; // column-major, like glTF

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
                    Some(uri) => {
                        assert!(
                            !uri.starts_with("data:"),
                            "data: URIs are not in this reference"
                        );
                        std::fs::read(dir.join(uri)).expect("external buffer")
                    }
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
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

impl Gltf {
    /// An accessor's elements as `f64` (normalized integers mapped to [0, 1]).
    fn accessor(&self, i: usize) -> Vec<Vec<f64>> {
        let a = &self.json["accessors"][i];
        assert!(
            a.get("sparse").is_none(),
            "sparse accessors are not in this reference"
        );
        let count = index(&a["count"]);
        let width = match a["type"].as_str().expect("type") {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            "MAT4" => 16,
            other => panic!("type {other} is not in this reference"),
        };
        let component = index(&a["componentType"]);
        let size = match component {
            5126 => 4,
            5123 => 2,
            5121 => 1,
            other => panic!("componentType {other} is not in this reference"),
        };
        let normalized = a["normalized"].as_bool().unwrap_or(false);
        let view = &self.json["bufferViews"][index(&a["bufferView"])];
        let buffer = &self.buffers[index(&view["buffer"])];
        let start = view["byteOffset"].as_u64().unwrap_or(0) as usize
            + a["byteOffset"].as_u64().unwrap_or(0) as usize;
        let stride = view["byteStride"]
            .as_u64()
            .map_or(width * size, |s| s as usize);
        (0..count)
            .map(|e| {
                (0..width)
                    .map(|c| {
                        let at = start + e * stride + c * size;
                        let b = &buffer[at..at + size];
                        match component {
                            5126 => f64::from(f32::from_le_bytes(b.try_into().expect("4"))),
                            5123 => {
                                let v = f64::from(u16::from_le_bytes(b.try_into().expect("2")));
                                if normalized { v / 65535.0 } else { v }
                            }
                            _ => {
                                let v = f64::from(b[0]);
                                if normalized { v / 255.0 } else { v }
                            }
                        }
                    })
                    .collect()
            })
            .collect()
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

fn point(m: &Mat, v: &[f64]) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (row, o) in out.iter_mut().enumerate() {
        *o = m[row] * v[0] + m[4 + row] * v[1] + m[8 + row] * v[2] + m[12 + row];
    }
    out
}

const IDENTITY: Mat = [
    1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
];

fn normalize(q: &[f64]) -> Vec<f64> {
    let len = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    q.iter().map(|x| x / len).collect()
}

/// `T * R * S` with `r` = `[x, y, z, w]`.
fn trs(t: &[f64], r: &[f64], s: &[f64]) -> Mat {
    let q = normalize(r);
    let (x, y, z, w) = (q[0], q[1], q[2], q[3]);
    let rot = [
        [
            1. - 2. * (y * y + z * z),
            2. * (x * y + z * w),
            2. * (x * z - y * w),
        ],
        [
            2. * (x * y - z * w),
            1. - 2. * (x * x + z * z),
            2. * (y * z + x * w),
        ],
        [
            2. * (x * z + y * w),
            2. * (y * z - x * w),
            1. - 2. * (x * x + y * y),
        ],
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

fn slerp(a: &[f64], b: &[f64], u: f64) -> Vec<f64> {
    let mut d: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let b: Vec<f64> = if d < 0.0 {
        d = -d;
        b.iter().map(|x| -x).collect()
    } else {
        b.to_vec()
    };
    if d > 0.9999995 {
        return normalize(
            &a.iter()
                .zip(&b)
                .map(|(x, y)| x + (y - x) * u)
                .collect::<Vec<_>>(),
        );
    }
    let theta = d.acos();
    let (wa, wb) = (
        ((1.0 - u) * theta).sin() / theta.sin(),
        (u * theta).sin() / theta.sin(),
    );
    normalize(
        &a.iter()
            .zip(&b)
            .map(|(x, y)| wa * x + wb * y)
            .collect::<Vec<_>>(),
    )
}

// ---------------------------------------------------------------- reference: evaluation

/// (node, mesh, primitive).
type PrimitiveKey = (usize, usize, usize);

/// Reference result at one time: world matrices, morph weights, deformed primitives.
struct Expected {
    worlds: Vec<Mat>,
    weights: Vec<(usize, Vec<f64>)>,
    /// (node, mesh, primitive) → world positions.
    primitives: Vec<(PrimitiveKey, Vec<[f64; 3]>)>,
}

/// Samples one channel at `t` (values held before the first and after the last key).
fn sample(g: &Gltf, sampler: &Value, path: &str, t: f64) -> Vec<f64> {
    let times: Vec<f64> = g
        .accessor(index(&sampler["input"]))
        .into_iter()
        .map(|v| v[0])
        .collect();
    let mut values = g.accessor(index(&sampler["output"]));
    let interpolation = sampler["interpolation"].as_str().unwrap_or("LINEAR");
    if path == "weights" {
        // One scalar per target per key: regroup per key.
        let per_key = values.len() / times.len();
        values = values
            .chunks(per_key)
            .map(|c| c.iter().map(|v| v[0]).collect())
            .collect();
    }
    assert_ne!(
        interpolation, "CUBICSPLINE",
        "CUBICSPLINE is not in this reference"
    );
    let last = times.len() - 1;
    if t <= times[0] {
        return values[0].clone();
    }
    if t >= times[last] {
        return values[last].clone();
    }
    let k = times
        .iter()
        .rposition(|&x| x <= t)
        .expect("t is inside the keys");
    if interpolation == "STEP" {
        return values[k].clone();
    }
    let u = (t - times[k]) / (times[k + 1] - times[k]);
    if path == "rotation" {
        // Slerp is defined on unit quaternions; SimpleSkin's keys are off by ~2e-4 in length.
        slerp(&normalize(&values[k]), &normalize(&values[k + 1]), u)
    } else {
        values[k]
            .iter()
            .zip(&values[k + 1])
            .map(|(a, b)| a + (b - a) * u)
            .collect()
    }
}

fn expected(g: &Gltf, clip: Option<usize>, t: f64) -> Expected {
    let nodes = g.json["nodes"].as_array().cloned().unwrap_or_default();
    let n = nodes.len();
    let mut t_of: Vec<Vec<f64>> = nodes
        .iter()
        .map(|nd| nd.get("translation").map_or(vec![0.; 3], floats))
        .collect();
    let mut r_of: Vec<Vec<f64>> = nodes
        .iter()
        .map(|nd| nd.get("rotation").map_or(vec![0., 0., 0., 1.], floats))
        .collect();
    let mut s_of: Vec<Vec<f64>> = nodes
        .iter()
        .map(|nd| nd.get("scale").map_or(vec![1.; 3], floats))
        .collect();
    let meshes = g.json["meshes"].as_array().cloned().unwrap_or_default();
    let mut weights: Vec<Vec<f64>> = nodes
        .iter()
        .map(|nd| match (nd.get("weights"), nd.get("mesh")) {
            (Some(w), _) => floats(w),
            (None, Some(m)) => {
                let mesh = &meshes[index(m)];
                let targets = mesh["primitives"][0]["targets"]
                    .as_array()
                    .map_or(0, Vec::len);
                mesh.get("weights").map_or(vec![0.; targets], floats)
            }
            _ => vec![],
        })
        .collect();

    if let Some(c) = clip {
        let anim = &g.json["animations"][c];
        for ch in anim["channels"].as_array().expect("channels") {
            let node = index(&ch["target"]["node"]);
            let path = ch["target"]["path"].as_str().expect("path");
            let value = sample(g, &anim["samplers"][index(&ch["sampler"])], path, t);
            match path {
                "translation" => t_of[node] = value,
                "rotation" => r_of[node] = value,
                "scale" => s_of[node] = value,
                _ => weights[node] = value,
            }
        }
    }

    let mut parent = vec![None; n];
    for (p, nd) in nodes.iter().enumerate() {
        for c in nd
            .get("children")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            parent[index(c)] = Some(p);
        }
    }
    let local = |i: usize| -> Mat {
        match nodes[i].get("matrix") {
            Some(m) => floats(m).try_into().expect("16 floats"),
            None => trs(&t_of[i], &r_of[i], &s_of[i]),
        }
    };
    let worlds: Vec<Mat> = (0..n)
        .map(|mut i| {
            let mut m = local(i);
            while let Some(p) = parent[i] {
                m = mul(&local(p), &m);
                i = p;
            }
            m
        })
        .collect();

    // Nodes of the default scene: its roots and their descendants.
    let scene = g.json["scene"].as_u64().unwrap_or(0) as usize;
    let roots: BTreeSet<usize> = g.json["scenes"][scene]["nodes"]
        .as_array()
        .expect("roots")
        .iter()
        .map(index)
        .collect();
    let in_scene = |mut i: usize| loop {
        if roots.contains(&i) {
            return true;
        }
        match parent[i] {
            Some(p) => i = p,
            None => return false,
        }
    };

    let mut primitives = Vec::new();
    for i in (0..n).filter(|&i| in_scene(i)) {
        let Some(mesh) = nodes[i].get("mesh").map(index) else {
            continue;
        };
        let prims = meshes[mesh]["primitives"].as_array().expect("primitives");
        for (p, prim) in prims.iter().enumerate() {
            let attrs = &prim["attributes"];
            let mut positions = g.accessor(index(&attrs["POSITION"]));
            for (k, target) in prim["targets"].as_array().into_iter().flatten().enumerate() {
                let Some(acc) = target.get("POSITION") else {
                    continue;
                };
                for (v, d) in positions.iter_mut().zip(g.accessor(index(acc))) {
                    for c in 0..3 {
                        v[c] += weights[i][k] * d[c];
                    }
                }
            }
            let out: Vec<[f64; 3]> = match nodes[i].get("skin") {
                Some(s) => {
                    let skin = &g.json["skins"][index(s)];
                    let joints: Vec<usize> = skin["joints"]
                        .as_array()
                        .expect("joints")
                        .iter()
                        .map(index)
                        .collect();
                    let ibm: Vec<Mat> = match skin.get("inverseBindMatrices") {
                        Some(a) => g
                            .accessor(index(a))
                            .into_iter()
                            .map(|m| m.try_into().expect("16"))
                            .collect(),
                        None => vec![IDENTITY; joints.len()],
                    };
                    let palette: Vec<Mat> = joints
                        .iter()
                        .zip(&ibm)
                        .map(|(&j, b)| mul(&worlds[j], b))
                        .collect();
                    let js = g.accessor(index(&attrs["JOINTS_0"]));
                    let ws = g.accessor(index(&attrs["WEIGHTS_0"]));
                    positions
                        .iter()
                        .zip(js.iter().zip(&ws))
                        .map(|(v, (j, w))| {
                            let mut acc = [0.0; 3];
                            for k in 0..4 {
                                let q = point(&palette[j[k] as usize], v);
                                for c in 0..3 {
                                    acc[c] += w[k] * q[c];
                                }
                            }
                            acc
                        })
                        .collect()
                }
                None => positions.iter().map(|v| point(&worlds[i], v)).collect(),
            };
            primitives.push(((i, mesh, p), out));
        }
    }
    let weights = weights
        .into_iter()
        .enumerate()
        .filter(|(_, w)| !w.is_empty())
        .collect();
    Expected {
        worlds,
        weights,
        primitives,
    }
}

// ---------------------------------------------------------------- the checks

fn asset(rel: &str) -> PathBuf {
    shared_assets().join("khronos").join(rel)
}

/// Runs `kloub pose` in-process and returns its JSON as printed.
fn pose_json(path: &Path, request: &PoseRequest) -> Value {
    let report = pose_file(path, request).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let text = serde_json::to_string(&report.doc).expect("serializes");
    serde_json::from_str(&text).expect("parses back")
}

fn keys(v: &Value) -> Vec<&str> {
    let mut k: Vec<&str> = v
        .as_object()
        .expect("an object")
        .keys()
        .map(String::as_str)
        .collect();
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
            assert!(
                (exact - x).abs() <= 2.0 * f64::EPSILON * x.abs(),
                "{x} is not an exact f32"
            );
        }
        Value::Array(a) => a.iter().for_each(assert_f32_exact),
        Value::Object(o) => o.values().for_each(assert_f32_exact),
        _ => {}
    }
}

/// Checks the document's shape, then every frame against the reference.
fn check(rel: &str, request: &PoseRequest, clip: Option<usize>) {
    let path = asset(rel);
    let g = load(&path);
    let doc = pose_json(&path, request);
    assert_eq!(keys(&doc), ["asset", "clip", "frames"]);
    assert_eq!(
        doc["asset"],
        path.file_name().expect("name").to_str().expect("utf-8")
    );
    assert_f32_exact(&doc["frames"]);

    match clip {
        None => assert!(doc["clip"].is_null(), "{rel}: clip should be null"),
        Some(c) => {
            let info = &doc["clip"];
            assert_eq!(keys(info), ["duration", "index", "name"]);
            assert_eq!(info["index"], c);
            assert_eq!(
                info["name"],
                g.json["animations"][c]
                    .get("name")
                    .cloned()
                    .unwrap_or_default()
            );
            let anim = &g.json["animations"][c];
            let duration = anim["samplers"]
                .as_array()
                .expect("samplers")
                .iter()
                .flat_map(|s| g.accessor(index(&s["input"])))
                .map(|v| v[0])
                .fold(0.0, f64::max);
            let got = info["duration"].as_f64().map(|d| d as f32);
            assert_eq!(got, Some(duration as f32), "{rel}: duration");
        }
    }

    let times: Vec<f32> = if request.times.is_empty() {
        vec![0.0]
    } else {
        request.times.clone()
    };
    let frames = doc["frames"].as_array().expect("frames");
    assert_eq!(frames.len(), times.len());
    let node_count = g.json["nodes"].as_array().map_or(0, Vec::len);
    for (frame, &time) in frames.iter().zip(&times) {
        assert_eq!(keys(frame), ["nodes", "primitives", "time", "weights"]);
        assert_eq!(frame["time"].as_f64().map(|t| t as f32), Some(time));
        let want = expected(&g, clip, f64::from(time));

        // Tolerance: 1e-5 of the deformed scene's bounding-box diagonal.
        let mut lo = [f64::MAX; 3];
        let mut hi = [f64::MIN; 3];
        for (_, ps) in &want.primitives {
            for p in ps {
                for c in 0..3 {
                    lo[c] = lo[c].min(p[c]);
                    hi[c] = hi[c].max(p[c]);
                }
            }
        }
        let diag = (0..3).map(|c| (hi[c] - lo[c]).powi(2)).sum::<f64>().sqrt();
        assert!(diag > 0.0, "{rel}: an empty reference scene");
        let tol = 1e-5 * diag;
        let ctx = |what: String| format!("{rel} t={time}: {what}");

        let nodes = frame["nodes"].as_array().expect("nodes");
        assert_eq!(nodes.len(), node_count, "{}", ctx("every node".into()));
        for (i, node) in nodes.iter().enumerate() {
            assert_eq!(keys(node), ["index", "name", "world"]);
            assert_eq!(node["index"], i);
            let name = g.json["nodes"][i]
                .get("name")
                .cloned()
                .unwrap_or(Value::Null);
            assert_eq!(node["name"], name);
            let world = floats(&node["world"]);
            assert_eq!(world.len(), 16);
            for (k, (got, exp)) in world.iter().zip(&want.worlds[i]).enumerate() {
                let tol = tol.max(1e-5);
                assert!(
                    (got - exp).abs() <= tol,
                    "{}",
                    ctx(format!("node {i} world[{k}] {got} vs {exp}"))
                );
            }
        }

        let weights = frame["weights"].as_object().expect("weights object");
        assert_eq!(
            weights.len(),
            want.weights.len(),
            "{}",
            ctx("weights keys".into())
        );
        for (node, w) in &want.weights {
            let got = floats(&weights[&node.to_string()]);
            assert_eq!(got.len(), w.len());
            for (a, b) in got.iter().zip(w) {
                assert!(
                    (a - b).abs() <= 1e-6,
                    "{}",
                    ctx(format!("node {node} weights {got:?} vs {w:?}"))
                );
            }
        }

        let prims = frame["primitives"].as_array().expect("primitives");
        assert_eq!(
            prims.len(),
            want.primitives.len(),
            "{}",
            ctx("primitive count".into())
        );
        for ((node, mesh, primitive), ps) in &want.primitives {
            let got = prims
                .iter()
                .find(|p| p["node"] == *node && p["primitive"] == *primitive)
                .unwrap_or_else(|| panic!("{}", ctx(format!("no primitive {node}/{primitive}"))));
            assert_eq!(
                keys(got),
                ["count", "mesh", "node", "positions", "primitive"]
            );
            assert_eq!(got["mesh"], *mesh);
            let positions = floats(&got["positions"]);
            assert_eq!(got["count"].as_u64(), Some(ps.len() as u64));
            assert_eq!(
                positions.len(),
                3 * ps.len(),
                "{}",
                ctx("count == positions / 3".into())
            );
            for (v, (g3, e3)) in positions.chunks(3).zip(ps).enumerate() {
                for c in 0..3 {
                    let (a, b) = (g3[c], e3[c]);
                    assert!(
                        (a - b).abs() <= tol,
                        "{}",
                        ctx(format!("vertex {v}: {g3:?} vs {e3:?} (tol {tol})"))
                    );
                }
            }
        }
    }
}

const TIMES: [f32; 6] = [0.0, 0.5, 1.04, 2.0, 2.5, 7.0];

fn request(clip: Option<&str>, rest: bool) -> PoseRequest {
    PoseRequest {
        clip: clip.map(str::to_owned),
        times: TIMES.to_vec(),
        rest,
        ..Default::default()
    }
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
fn default_time_is_zero_and_names_are_null_when_absent() {
    let path = asset("SimpleSkin/glTF/SimpleSkin.gltf");
    let doc = pose_json(&path, &PoseRequest::default());
    let frames = doc["frames"].as_array().expect("frames");
    assert_eq!(frames.len(), 1);
    assert_eq!(frames[0]["time"], 0.0);
    assert!(frames[0]["nodes"][0]["name"].is_null());
    assert!(
        doc["clip"]["name"].is_null(),
        "SimpleSkin's animation has no name"
    );
    assert_eq!(frames[0]["weights"], serde_json::json!({}));
}

#[test]
fn unknown_clip_lists_the_available_ones() {
    let path = asset("RiggedSimple/glTF-Binary/RiggedSimple.glb");
    for wanted in ["Walk", "1", "-1"] {
        let err = pose_file(
            &path,
            &PoseRequest {
                clip: Some(wanted.into()),
                ..Default::default()
            },
        )
        .expect_err("no such clip");
        assert_eq!(err.pointer.as_deref(), Some("/animations"));
        assert!(
            err.message.contains(&format!("no clip {wanted:?}")),
            "{err}"
        );
        assert!(err.message.contains("available: 0"), "{err}");
    }
}
