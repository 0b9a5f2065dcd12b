//! What `benches/import.rs` (native) and `wasm-bench/tests/wasm_decode.rs` (wasm32 in Node) measure, and
//! `scripts/bench-import.mjs` measures with the reference decoders and three.js in the same way:
//! - **decoding**: the Draco and meshopt decoders on the compressed copies of `tests/optimized`,
//!   called on each compressed stream as the reference decoders are ([`measure_streams`]:
//!   `kloub_core::import::decode_meshopt_view` per view into a new buffer, as meshoptimizer's
//!   `decodeGltfBuffer`; the build's Draco decoder per primitive with its attributes converted,
//!   as three.js's DRACOLoader), and through the importer ([`measure`]): each case is the file
//!   stripped to its compressed data (the buffers and views, the compressed primitives and their
//!   accessors), so an import is a few hundred bytes of JSON and the decoding. Speed is decoded
//!   bytes per second: the accessors' bytes for Draco (in their component types, indices as
//!   32-bit), the views' bytes for meshopt.
//! - **import**: bytes → ready asset for each character and its optimized copies, without its
//!   images (three.js's GLTFLoader cannot decode them in Node; Kloub's web builds leave them to
//!   the browser too): `images`, `textures`, `samplers` and the materials' texture references
//!   removed.

use kloub_core::{ImportOptions, NoResolver, import};
use serde_json::Value;

/// One file, stripped.
pub struct Case {
    /// File name.
    pub name: &'static str,
    /// `draco` or `meshopt` (decoding), the variant (import).
    pub codec: &'static str,
    /// The stripped GLB.
    pub glb: Vec<u8>,
    /// Bytes decoded per import (decoding cases).
    pub decoded: u64,
    /// The compressed streams (decoding cases).
    pub streams: Vec<Stream>,
}

/// One compressed stream of a decoding case, as its extension describes it.
pub enum Stream {
    /// A buffer view of `EXT_meshopt_compression` (`khr`: `KHR_meshopt_compression`).
    Meshopt { mode: String, filter: String, count: usize, stride: usize, khr: bool, src: Vec<u8> },
    /// A primitive's `KHR_draco_mesh_compression` stream and the attributes' unique ids.
    Draco { stream: Vec<u8>, wanted: Vec<u32> },
}

/// The compressed copies whose decoding is measured (compiled in: wasm has no file system).
pub const FILES: [(&str, &[u8]); 8] = [
    ("Fox.draco.glb", include_bytes!("../../tests/optimized/Fox.draco.glb")),
    ("CesiumMan.draco.glb", include_bytes!("../../tests/optimized/CesiumMan.draco.glb")),
    ("RobotExpressive.draco.glb", include_bytes!("../../tests/optimized/RobotExpressive.draco.glb")),
    ("Fox.gltfpack-cc.glb", include_bytes!("../../tests/optimized/Fox.gltfpack-cc.glb")),
    ("CesiumMan.gltfpack-cc.glb", include_bytes!("../../tests/optimized/CesiumMan.gltfpack-cc.glb")),
    ("RobotExpressive.gltfpack-cc.glb", include_bytes!("../../tests/optimized/RobotExpressive.gltfpack-cc.glb")),
    ("Fox.gltfpack-khr.glb", include_bytes!("../../tests/optimized/Fox.gltfpack-khr.glb")),
    ("CesiumMan.gltfpack-khr.glb", include_bytes!("../../tests/optimized/CesiumMan.gltfpack-khr.glb")),
];

/// The files whose import is measured: (variant, file).
pub const IMPORTS: [(&str, &str, &[u8]); 13] = [
    ("original", "Fox.glb", include_bytes!("../../tests/assets/khronos/Fox/glTF-Binary/Fox.glb")),
    ("gltfpack", "Fox.gltfpack.glb", include_bytes!("../../tests/optimized/Fox.gltfpack.glb")),
    ("meshopt", "Fox.gltfpack-cc.glb", include_bytes!("../../tests/optimized/Fox.gltfpack-cc.glb")),
    ("draco", "Fox.draco.glb", include_bytes!("../../tests/optimized/Fox.draco.glb")),
    ("original", "CesiumMan.glb", include_bytes!("../../tests/assets/khronos/CesiumMan/glTF-Binary/CesiumMan.glb")),
    ("gltfpack", "CesiumMan.gltfpack.glb", include_bytes!("../../tests/optimized/CesiumMan.gltfpack.glb")),
    ("meshopt", "CesiumMan.gltfpack-cc.glb", include_bytes!("../../tests/optimized/CesiumMan.gltfpack-cc.glb")),
    ("draco", "CesiumMan.draco.glb", include_bytes!("../../tests/optimized/CesiumMan.draco.glb")),
    (
        "original",
        "RobotExpressive.glb",
        include_bytes!("../../tests/assets/threejs/RobotExpressive/RobotExpressive.glb"),
    ),
    ("gltfpack", "RobotExpressive.gltfpack.glb", include_bytes!("../../tests/optimized/RobotExpressive.gltfpack.glb")),
    (
        "meshopt",
        "RobotExpressive.gltfpack-cc.glb",
        include_bytes!("../../tests/optimized/RobotExpressive.gltfpack-cc.glb"),
    ),
    ("draco", "RobotExpressive.draco.glb", include_bytes!("../../tests/optimized/RobotExpressive.draco.glb")),
    ("original", "Knight.glb", include_bytes!("../../tests/assets/kaykit/Knight/Knight.glb")),
];

pub fn options() -> ImportOptions {
    ImportOptions { decode_images: false, ..ImportOptions::default() }
}

/// Every file of [`IMPORTS`] without its images, checked to import.
pub fn import_cases() -> Vec<Case> {
    IMPORTS
        .iter()
        .map(|&(variant, name, bytes)| {
            let (mut doc, bin) = split(bytes);
            strip_images(&mut doc);
            let glb = glb(&doc, bin);
            import(&glb, &NoResolver, &options()).unwrap_or_else(|e| panic!("{name}: {e}"));
            Case { name, codec: variant, glb, decoded: 0, streams: Vec::new() }
        })
        .collect()
}

/// Removes the images, textures and samplers, and the materials' references to them.
fn strip_images(doc: &mut Value) {
    let root = doc.as_object_mut().expect("an object");
    for key in ["images", "textures", "samplers"] {
        root.remove(key);
    }
    for material in root.get_mut("materials").and_then(Value::as_array_mut).into_iter().flatten() {
        let material = material.as_object_mut().expect("a material");
        material.retain(|key, _| !key.ends_with("Texture"));
        if let Some(pbr) = material.get_mut("pbrMetallicRoughness").and_then(Value::as_object_mut) {
            pbr.retain(|key, _| !key.ends_with("Texture"));
        }
    }
}

/// Every file of [`FILES`], stripped and checked to import.
pub fn decode_cases() -> Vec<Case> {
    FILES
        .iter()
        .map(|&(name, bytes)| {
            let (mut doc, bin) = split(bytes);
            let draco = name.contains("draco");
            let streams = streams(&doc, bin);
            strip(&mut doc, draco);
            let glb = glb(&doc, bin);
            let imported = import(&glb, &NoResolver, &options()).unwrap_or_else(|e| panic!("{name}: {e}"));
            let ext = &imported.asset.extensions;
            let decoded = if draco {
                ext.compressed_primitives.iter().map(|c| c.decoded_bytes).sum()
            } else {
                ext.compressed_views.iter().map(|c| c.decoded_bytes).sum()
            };
            assert!(decoded > 0, "{name}: nothing compressed");
            Case { name, codec: if draco { "draco" } else { "meshopt" }, glb, decoded, streams }
        })
        .collect()
}

/// The compressed streams of a GLB's JSON `doc` and BIN chunk `bin`.
fn streams(doc: &Value, bin: &[u8]) -> Vec<Stream> {
    let views = doc["bufferViews"].as_array().expect("views");
    let range = |v: &Value, offset: &str| {
        let at = v[offset].as_u64().unwrap_or(0) as usize;
        bin[at..at + v["byteLength"].as_u64().expect("byteLength") as usize].to_vec()
    };
    let mut out = Vec::new();
    for view in views {
        for (name, khr) in [("KHR_meshopt_compression", true), ("EXT_meshopt_compression", false)] {
            let x = &view["extensions"][name];
            if x.is_object() {
                out.push(Stream::Meshopt {
                    mode: x["mode"].as_str().expect("mode").to_owned(),
                    filter: x["filter"].as_str().unwrap_or("NONE").to_owned(),
                    count: x["count"].as_u64().expect("count") as usize,
                    stride: x["byteStride"].as_u64().expect("byteStride") as usize,
                    khr,
                    src: range(x, "byteOffset"),
                });
                break;
            }
        }
    }
    for mesh in doc["meshes"].as_array().into_iter().flatten() {
        for p in mesh["primitives"].as_array().expect("primitives") {
            let x = &p["extensions"]["KHR_draco_mesh_compression"];
            if x.is_object() {
                let view = &views[x["bufferView"].as_u64().expect("bufferView") as usize];
                let wanted = x["attributes"].as_object().expect("attributes");
                let wanted = wanted.values().map(|id| id.as_u64().expect("an id") as u32).collect();
                out.push(Stream::Draco { stream: range(view, "byteOffset"), wanted });
            }
        }
    }
    out
}

/// Runs every case's decoding (and import) for about `ms` milliseconds each, untimed, before
/// anything is measured: a wasm engine runs a function's first calls in baseline code and
/// swaps in optimised code some time later (in Node the first meshopt file measured read ~1.6×
/// slower than the same file a few seconds later). `scripts/bench-import.mjs` warms the
/// reference decoders and three.js's parse up before timing them too. Every figure is then the
/// steady state; a page's first import of a file runs in code just compiled (BENCHMARKS.md
/// "Time to first frame").
pub fn warm_up(cases: &[Case], ms: f64, now: &dyn Fn() -> f64) {
    let codecs = kloub_core::codecs::builtin();
    let options = options();
    for case in cases {
        let start = now();
        while now() - start < ms {
            std::hint::black_box((decode_all(case, codecs), import_once(case, &options)));
        }
    }
}

/// Decodes every stream of `case` as the reference decoders are called: whether all decoded.
fn decode_all(case: &Case, codecs: &dyn kloub_core::codecs::Codecs) -> bool {
    case.streams.iter().all(|stream| decode_stream(stream, codecs))
}

/// Imports `case` once: whether it imported.
fn import_once(case: &Case, options: &ImportOptions) -> bool {
    std::hint::black_box(import(std::hint::black_box(&case.glb), &NoResolver, options)).is_ok()
}

/// Milliseconds to decode every stream of `case` (as [`measure`] times an import).
pub fn measure_streams(case: &Case, now: &dyn Fn() -> f64) -> f64 {
    let codecs = kloub_core::codecs::builtin();
    let run = || decode_all(case, codecs);
    // A stream that fails would be timed as a quick no-op.
    assert!(run(), "{}: a stream does not decode", case.name);
    timed(&run, now)
}

/// Each meshopt view of `case` on its own (`KLOUB_BENCH_VIEWS=1 bash scripts/bench-import.sh`):
/// its mode, filter, count and stride, and the milliseconds per decode.
pub fn measure_views(case: &Case, now: &dyn Fn() -> f64) -> Vec<(String, f64)> {
    let codecs = kloub_core::codecs::builtin();
    let mut out = Vec::new();
    for (i, stream) in case.streams.iter().enumerate() {
        if let Stream::Meshopt { mode, filter, count, stride, .. } = stream {
            let run = || decode_stream(stream, codecs);
            assert!(run(), "{}: view {i} does not decode", case.name);
            out.push((format!("{i}:{mode}:{filter}:{count}x{stride}"), timed(&run, now)));
        }
    }
    out
}

/// Decodes one stream as the reference decoders are called: whether it decoded.
fn decode_stream(stream: &Stream, codecs: &dyn kloub_core::codecs::Codecs) -> bool {
    match stream {
        Stream::Meshopt { mode, filter, count, stride, khr, src } => {
            let mut out = vec![0u8; count * stride];
            let done = kloub_core::import::decode_meshopt_view(mode, filter, *count, *stride, src, *khr, &mut out);
            std::hint::black_box((done, out)).0.is_ok()
        }
        Stream::Draco { stream, wanted } => {
            std::hint::black_box(codecs.draco(std::hint::black_box(stream), wanted, u64::MAX)).is_ok()
        }
    }
}

/// The JSON and BIN chunks of a GLB.
fn split(bytes: &[u8]) -> (Value, &[u8]) {
    let word = |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]) as usize;
    let json_length = word(12);
    let doc = serde_json::from_slice(&bytes[20..20 + json_length]).expect("JSON chunk");
    let bin_at = 20 + json_length;
    (doc, &bytes[bin_at + 8..bin_at + 8 + word(bin_at)])
}

/// Leaves the buffers and views, and (for Draco) the compressed primitives with their
/// compressed attributes and indices and only the accessors these use.
fn strip(doc: &mut Value, draco: bool) {
    let root = doc.as_object_mut().expect("an object");
    for key in ["nodes", "scenes", "scene", "skins", "animations", "materials", "textures", "images", "samplers"] {
        root.remove(key);
    }
    let accessors = root.remove("accessors").unwrap_or_default();
    if !draco {
        root.remove("meshes");
        return;
    }
    let mut kept = Vec::new();
    let mut keep = |index: &mut Value| {
        let old = index.as_u64().expect("an accessor index") as usize;
        *index = Value::from(kept.len());
        kept.push(accessors[old].clone());
    };
    for mesh in root.get_mut("meshes").and_then(Value::as_array_mut).into_iter().flatten() {
        mesh.as_object_mut().expect("a mesh").remove("weights");
        let primitives = mesh["primitives"].as_array_mut().expect("primitives");
        primitives.retain(|p| p["extensions"]["KHR_draco_mesh_compression"].is_object());
        for p in primitives {
            let compressed = p["extensions"]["KHR_draco_mesh_compression"]["attributes"].clone();
            let attributes = p["attributes"].as_object_mut().expect("attributes");
            attributes.retain(|name, _| compressed.get(name).is_some());
            attributes.values_mut().for_each(&mut keep);
            let p = p.as_object_mut().expect("a primitive");
            p.get_mut("indices").map(&mut keep);
            p.remove("targets");
            p.remove("material");
        }
    }
    root.insert("accessors".into(), Value::Array(kept));
}

/// A GLB of `doc` and `bin`.
fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    kloub_core::import::glb(doc.to_string().as_bytes(), Some(bin)).expect("a small file")
}

/// Milliseconds per import of `case`: the median of 7 batches of about 150 ms, timed by `now`
/// (milliseconds).
pub fn measure(case: &Case, now: &dyn Fn() -> f64) -> f64 {
    let options = options();
    let run = || import_once(case, &options);
    timed(&run, now)
}

/// Milliseconds per call of `run`: the median of 7 batches of about 150 ms, timed by `now`.
fn timed(run: &dyn Fn() -> bool, now: &dyn Fn() -> f64) -> f64 {
    let start = now();
    let mut calibration = 0u32;
    while now() - start < 50.0 || calibration < 3 {
        run();
        calibration += 1;
    }
    let per_batch = ((150.0 / ((now() - start) / f64::from(calibration))) as u32).max(1);
    let mut rates: Vec<f64> = (0..7)
        .map(|_| {
            let t = now();
            for _ in 0..per_batch {
                run();
            }
            (now() - t) / f64::from(per_batch)
        })
        .collect();
    rates.sort_by(f64::total_cmp);
    rates[3]
}
