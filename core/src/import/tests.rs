//! Import tests: real sample files, and one hand-made broken document per defect class.
//!
//! The hand-made documents also run on wasm32 under Node (`scripts/test-wasm.sh`, through
//! wasm-bindgen-test); the tests reading `tests/assets` from disk are native-only.

use super::*;
#[cfg(not(target_arch = "wasm32"))]
use crate::clip::ChannelTarget;
use crate::clip::Interpolation;
use glam::{Mat4, Vec3, Vec4};
use serde_json::{Value, json};
#[cfg(not(target_arch = "wasm32"))]
use std::path::{Path, PathBuf};

/// `tests/assets`, or `$KLOUB_SHARED_ASSETS`.
#[cfg(not(target_arch = "wasm32"))]
fn shared_assets() -> PathBuf {
    std::env::var_os("KLOUB_SHARED_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/assets"))
}

/// Imports a file with its sibling files available through a [`MapResolver`].
#[cfg(not(target_arch = "wasm32"))]
fn import_file(path: &Path) -> Result<Imported, ImportError> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut resolver = MapResolver::new();
    let dir = path.parent().expect("a file has a folder");
    for entry in std::fs::read_dir(dir).expect("readable folder").flatten() {
        if entry.path().is_file() {
            let name = entry.file_name().to_string_lossy().into_owned();
            resolver.insert(name, std::fs::read(entry.path()).expect("readable file"));
        }
    }
    import(&bytes, &resolver, &ImportOptions::default())
}

#[cfg(not(target_arch = "wasm32"))]
fn model_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())).flatten() {
        let path = entry.path();
        if path.is_dir() {
            model_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "glb" || e == "gltf") {
            out.push(path);
        }
    }
}

#[cfg(not(target_arch = "wasm32"))]
fn asset(relative: &str) -> Imported {
    let path = shared_assets().join(relative);
    import_file(&path).unwrap_or_else(|e| panic!("{relative}: {e}"))
}

#[cfg(not(target_arch = "wasm32"))] // reads tests/assets from disk
#[test]
fn every_shared_asset_imports() {
    let mut files = Vec::new();
    model_files(&shared_assets(), &mut files);
    files.sort();
    assert!(files.len() >= 30, "expected the shared sample assets, found {} files", files.len());
    for path in files {
        let imported = import_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let draco = path.components().any(|c| c.as_os_str() == "glTF-Draco");
        assert_eq!(!imported.asset.extensions.compressed_primitives.is_empty(), draco, "{}", path.display());
        for w in &imported.warnings {
            eprintln!("{}: {w}", path.display());
        }
        let a = &imported.asset;
        assert_eq!(a.order.len(), a.nodes.len(), "{}", path.display());
        assert!(a.meshes.iter().flat_map(|m| &m.primitives).all(|p| p.positions.len() == p.vertex_count as usize));
    }
}

#[cfg(not(target_arch = "wasm32"))] // reads tests/assets from disk
#[test]
fn fox_has_its_three_clips() {
    let fox = asset("khronos/Fox/glTF-Binary/Fox.glb").asset;
    let names: Vec<_> = fox.clips.iter().map(|c| c.name.as_deref().unwrap_or("")).collect();
    assert_eq!(names, ["Survey", "Walk", "Run"]);
    assert_eq!(fox.skins.len(), 1);
    assert_eq!(fox.images.len(), 1);
    assert!(
        fox.images[0].width > 1
            && fox.images[0].rgba8.len() == (fox.images[0].width * fox.images[0].height * 4) as usize
    );
    let split = asset("khronos/Fox/glTF/Fox.gltf").asset;
    assert_eq!(split.clips.len(), 3);
    assert_eq!(split.meshes[0].primitives[0].positions, fox.meshes[0].primitives[0].positions);
}

#[cfg(not(target_arch = "wasm32"))] // reads tests/assets from disk
#[test]
fn robot_expressive_weights_are_renormalized_with_a_warning() {
    let robot = asset("threejs/RobotExpressive/RobotExpressive.glb");
    assert!(
        robot
            .warnings
            .iter()
            .any(|w| w.message.contains("skin weights") && w.pointer.ends_with("/attributes/WEIGHTS_0")),
        "{:?}",
        robot.warnings
    );
    for p in robot.asset.meshes.iter().flat_map(|m| &m.primitives) {
        for w in &p.weights {
            assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        }
    }
    let head = robot.asset.meshes.iter().find(|m| !m.target_names.is_empty()).expect("a mesh with target names");
    assert_eq!(head.target_names, ["Angry", "Surprised", "Sad"]);
}

#[cfg(not(target_arch = "wasm32"))] // reads tests/assets from disk
#[test]
fn clean_samples_load_without_warnings() {
    for file in [
        "khronos/Fox/glTF-Binary/Fox.glb",
        "khronos/CesiumMan/glTF-Binary/CesiumMan.glb",
        "khronos/InterpolationTest/glTF-Binary/InterpolationTest.glb",
        "khronos/AnimatedMorphCube/glTF-Quantized/AnimatedMorphCube.gltf",
        "kaykit/Knight/Knight.glb",
    ] {
        let imported = asset(file);
        assert!(imported.warnings.is_empty(), "{file}: {:?}", imported.warnings);
    }
}

#[cfg(not(target_arch = "wasm32"))] // reads tests/assets from disk
#[test]
fn interpolation_test_has_every_mode() {
    let a = asset("khronos/InterpolationTest/glTF-Binary/InterpolationTest.glb").asset;
    assert_eq!(a.clips.len(), 9);
    for mode in [Interpolation::Step, Interpolation::Linear, Interpolation::CubicSpline] {
        assert!(a.clips.iter().flat_map(|c| c.channels()).any(|c| c.interpolation == mode));
    }
}

/// Sampling every channel of InterpolationTest at each of its key times, in order and
/// with the cursor cache, returns exactly that key's value (for every interpolation).
#[cfg(not(target_arch = "wasm32"))] // reads tests/assets from disk
#[test]
fn interpolation_test_samples_its_keys_exactly() {
    use crate::job::sample::{SampleContext, SampleJob};
    let a = asset("khronos/InterpolationTest/glTF-Binary/InterpolationTest.glb").asset;
    let mut pose = crate::pose::Pose::rest(&a);
    for clip in &a.clips {
        let mut context = SampleContext::new(clip);
        for channel in clip.channels() {
            let w = channel.width as usize;
            let per_key = if channel.interpolation == Interpolation::CubicSpline { 3 } else { 1 };
            for (k, &t) in channel.times.iter().enumerate() {
                SampleJob {
                    clip,
                    time: t,
                    context: &mut context,
                    weight_offsets: &a.weight_offsets,
                    locals: &mut pose.locals,
                    weights: &mut pose.weights,
                }
                .run()
                .expect("valid");
                let value = &channel.values[(k * per_key + per_key / 2) * w..][..w];
                let local = pose.locals[channel.node as usize];
                let got: Vec<f32> = match channel.target {
                    ChannelTarget::Translation => local.translation.to_array().to_vec(),
                    ChannelTarget::Scale => local.scale.to_array().to_vec(),
                    ChannelTarget::Rotation => local.rotation.to_array().to_vec(),
                    ChannelTarget::Weights => unreachable!("InterpolationTest has no morph targets"),
                };
                for (g, v) in got.iter().zip(value) {
                    assert!((g - v).abs() < 1e-6, "{:?} {:?} key {k}: {got:?} vs {value:?}", clip.name, channel.target);
                }
            }
        }
    }
}

#[cfg(not(target_arch = "wasm32"))] // reads tests/assets from disk
#[test]
fn quantized_morph_weights_are_normalized_integers() {
    let a = asset("khronos/AnimatedMorphCube/glTF-Quantized/AnimatedMorphCube.gltf").asset;
    let weights = a.clips[0].channels().iter().find(|c| c.target == ChannelTarget::Weights).expect("weights channel");
    assert!(weights.values.iter().all(|&v| (0.0..=1.0).contains(&v)));
    assert!(weights.values.iter().any(|&v| v > 0.5));
}

// ---- Hand-made documents -------------------------------------------------------------

/// Little-endian bytes of floats.
fn f32s(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// A valid GLB document: a triangle (positions, u16 indices), one translation clip.
/// BIN layout: positions 0..36, indices 36..42 (+2 pad), times 44..52, values 52..76.
fn base() -> (Value, Vec<u8>) {
    let mut bin = f32s(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    bin.extend([0u16, 1, 2].iter().flat_map(|i| i.to_le_bytes()));
    bin.extend([0, 0]);
    bin.extend(f32s(&[0.0, 1.0]));
    bin.extend(f32s(&[0.0, 0.0, 0.0, 2.0, 4.0, 6.0]));
    let doc = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 6},
            {"buffer": 0, "byteOffset": 44, "byteLength": 8},
            {"buffer": 0, "byteOffset": 52, "byteLength": 24}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5126, "count": 2, "type": "SCALAR"},
            {"bufferView": 3, "componentType": 5126, "count": 2, "type": "VEC3"}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": [{"mesh": 0, "name": "tri"}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
        "animations": [{"name": "move", "samplers": [{"input": 2, "output": 3}],
                        "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]}]
    });
    (doc, bin)
}

fn glb_of(doc: &Value, bin: &[u8]) -> Vec<u8> {
    container::tests::glb(doc.to_string().as_bytes(), Some(bin))
}

fn run(doc: &Value, bin: &[u8]) -> Result<Imported, ImportError> {
    import(&glb_of(doc, bin), &NoResolver, &ImportOptions::default())
}

fn refused(doc: &Value, bin: &[u8]) -> ImportError {
    match run(doc, bin) {
        Ok(_) => panic!("document was accepted"),
        Err(e) => e,
    }
}

/// Appends `bytes` (4-byte aligned) to the BIN buffer and a view of them; returns the view index.
fn add_view(doc: &mut Value, bin: &mut Vec<u8>, bytes: &[u8], stride: Option<u32>) -> usize {
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let offset = bin.len();
    bin.extend(bytes);
    doc["buffers"][0]["byteLength"] = json!(bin.len());
    let views = doc["bufferViews"].as_array_mut().expect("views");
    let mut view = json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()});
    if let Some(s) = stride {
        view["byteStride"] = json!(s);
    }
    views.push(view);
    views.len() - 1
}

fn add_accessor(doc: &mut Value, accessor: Value) -> usize {
    let list = doc["accessors"].as_array_mut().expect("accessors");
    list.push(accessor);
    list.len() - 1
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn base_document_imports() {
    let (doc, bin) = base();
    let imported = run(&doc, &bin).expect("valid");
    assert!(imported.warnings.is_empty(), "{:?}", imported.warnings);
    let a = imported.asset;
    assert_eq!(a.meshes[0].primitives[0].positions[1], [1.0, 0.0, 0.0]);
    assert_eq!(a.meshes[0].primitives[0].indices, [0, 1, 2]);
    assert_eq!(a.meshes[0].primitives[0].bounds, ([0.0; 3], [1.0, 1.0, 0.0]));
    assert_eq!(a.clips[0].duration, 1.0);
    assert_eq!(a.clips[0].channels()[0].values, [0.0, 0.0, 0.0, 2.0, 4.0, 6.0]);
    assert_eq!(a.default_scene, Some(0));
    assert_eq!(a.find_clip("move"), Some(0));
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn truncated_or_inconsistent_glb_is_refused() {
    let (doc, bin) = base();
    let file = glb_of(&doc, &bin);
    let e = import(&file[..file.len() - 8], &NoResolver, &ImportOptions::default()).expect_err("truncated");
    assert!(e.message.contains("does not match the file size"), "{e}");
    let e = import(&file[..7], &NoResolver, &ImportOptions::default()).expect_err("header");
    assert!(e.message.contains("truncated header"), "{e}");
    let mut short_bin = doc.clone();
    short_bin["buffers"][0]["byteLength"] = json!(bin.len() + 100);
    let e = refused(&short_bin, &bin);
    assert_eq!(e.pointer, "/buffers/0");
    let e = import(b"{not json", &NoResolver, &ImportOptions::default()).expect_err("json");
    assert!(e.message.starts_with("invalid JSON"), "{e}");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn inconsistent_glb_chunks_are_refused() {
    let (doc, bin) = base();
    let file = glb_of(&doc, &bin);
    let json_len = u32::from_le_bytes([file[12], file[13], file[14], file[15]]) as usize;
    let bin_at = 20 + json_len; // the BIN chunk header
    let go = |bytes: &[u8]| import(bytes, &NoResolver, &ImportOptions::default()).expect_err("refused");
    let refuse = |bytes: &[u8], what: &str| {
        let e = go(bytes);
        assert_eq!(e.pointer, "", "{e}");
        assert!(e.message.starts_with("GLB container: ") && e.message.contains(what), "{what}: {e}");
    };
    // Header: wrong version, length larger than the file.
    let mut v = file.clone();
    v[4..8].copy_from_slice(&1u32.to_le_bytes());
    refuse(&v, "version 1 is not supported");
    let mut v = file.clone();
    v[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
    refuse(&v, "header length 4294967295 does not match");
    // Chunks: a BIN chunk declaring more bytes than remain (also u32::MAX), the JSON chunk
    // declaring more than the file, BIN first, a second JSON chunk, a dangling chunk header.
    for len in [bin.len() as u32 + 4, u32::MAX] {
        let mut v = file.clone();
        v[bin_at..bin_at + 4].copy_from_slice(&len.to_le_bytes());
        refuse(&v, &format!("declares {len} bytes"));
    }
    let mut v = file.clone();
    v[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    refuse(&v, "chunk 0 at byte 12 declares 4294967295 bytes");
    let mut v = file.clone();
    v[16..20].copy_from_slice(&0x004E_4942u32.to_le_bytes());
    refuse(&v, "the first chunk must be JSON");
    let mut v = file.clone();
    v[bin_at + 4..bin_at + 8].copy_from_slice(&0x4E4F_534Au32.to_le_bytes());
    refuse(&v, "a second JSON chunk");
    let fix_length = |v: &mut Vec<u8>| {
        let len = v.len() as u32;
        v[8..12].copy_from_slice(&len.to_le_bytes());
    };
    let mut v = file.clone();
    v.extend(4u32.to_le_bytes());
    v.extend(0x004E_4942u32.to_le_bytes());
    v.extend([0; 4]);
    fix_length(&mut v);
    refuse(&v, "only one BIN chunk is allowed");
    let mut v = file[..12].to_vec();
    v.extend([0; 4]);
    fix_length(&mut v);
    refuse(&v, "truncated chunk header at byte 12");
    // Fewer bytes after the last chunk than a chunk header: padding, ignored with a warning.
    let mut v = file.clone();
    v.extend([0; 6]);
    fix_length(&mut v);
    let padded = import(&v, &NoResolver, &ImportOptions::default()).expect("padding is not a chunk");
    assert_eq!(
        padded.warnings.iter().map(|w| w.message.as_str()).collect::<Vec<_>>(),
        ["6 bytes after the last GLB chunk are ignored"]
    );
    let mut v = file[..12].to_vec();
    fix_length(&mut v);
    refuse(&v, "the first chunk must be JSON");
    // An unknown chunk after BIN is ignored.
    let mut v = file;
    v.extend(4u32.to_le_bytes());
    v.extend(*b"XTRA");
    v.extend([0; 4]);
    fix_length(&mut v);
    assert!(import(&v, &NoResolver, &ImportOptions::default()).is_ok());
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn deeply_nested_json_is_refused_without_overflowing_the_stack() {
    let nested = format!("{}{}", "[".repeat(100_000), "]".repeat(100_000));
    let e = import(nested.as_bytes(), &NoResolver, &ImportOptions::default()).expect_err("too deep");
    assert!(e.message.contains("recursion limit"), "{e}");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn accessor_outside_its_view_is_refused() {
    let (mut doc, bin) = base();
    doc["accessors"][0]["byteOffset"] = json!(4);
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, "/accessors/0");
    assert!(e.message.starts_with("count 3 does not fit bufferView 0"), "{e}");
    let (mut doc, bin) = base();
    doc["bufferViews"][3]["byteLength"] = json!(1000);
    assert_eq!(refused(&doc, &bin).pointer, "/bufferViews/3");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn count_overflow_and_zero_are_refused() {
    let (mut doc, bin) = base();
    doc["accessors"][0]["count"] = json!(1u64 << 62);
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, "/accessors/0");
    assert!(e.message.starts_with("count 4611686018427387904 does not fit bufferView 0"), "{e}");
    doc["accessors"][0]["count"] = json!(u64::MAX);
    assert_eq!(refused(&doc, &bin).pointer, "/accessors/0");
    doc["accessors"][0]["count"] = json!(0);
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, "/accessors/0/count");
    doc["accessors"][0]["count"] = json!(-1);
    assert_eq!(refused(&doc, &bin).pointer, "/accessors/0/count");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn index_out_of_range_is_refused() {
    let (mut doc, mut bin) = base();
    bin[38..40].copy_from_slice(&7u16.to_le_bytes());
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, "/meshes/0/primitives/0/indices");
    assert!(e.message.contains("index 7 at position 1"), "{e}");
    let (_, bin) = base();
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, "/meshes/0/primitives/0/material");
    let (mut doc, _) = base();
    doc["nodes"][0]["mesh"] = json!(3);
    assert_eq!(refused(&doc, &bin).pointer, "/nodes/0/mesh");
    let (mut doc, _) = base();
    doc["animations"][0]["channels"][0]["target"]["node"] = json!(1);
    assert_eq!(refused(&doc, &bin).pointer, "/animations/0/channels/0/target/node");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn node_cycles_and_multiple_parents_are_refused() {
    let (mut doc, bin) = base();
    doc["nodes"] = json!([{"mesh": 0}, {"children": [2]}, {"children": [1]}]);
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, "/nodes/1");
    assert!(e.message.contains("cycle"), "{e}");
    doc["nodes"] = json!([{"mesh": 0, "children": [0]}]);
    assert_eq!(refused(&doc, &bin).pointer, "/nodes/0/children/0");
    doc["nodes"] = json!([{"mesh": 0, "children": [2]}, {"children": [2]}, {}]);
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, "/nodes/1/children/0");
    assert!(e.message.contains("only one parent"), "{e}");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn deep_chain_is_refused_quickly() {
    let (mut doc, bin) = base();
    let n = 100_000;
    let nodes: Vec<Value> =
        (0..n).map(|i| if i + 1 < n { json!({"children": [i + 1]}) } else { json!({"mesh": 0}) }).collect();
    doc["nodes"] = Value::Array(nodes);
    doc["animations"] = json!([]);
    let file = glb_of(&doc, &bin);
    let e = import(&file, &NoResolver, &ImportOptions::default()).expect_err("too deep");
    assert_eq!(e.pointer, "/nodes/1024");
    assert!(e.message.contains("deeper than the limit of 1024"), "{e}");
    // Within the limit, the same shape is fine.
    let options = ImportOptions { max_node_depth: n as u32, ..ImportOptions::default() };
    let a = import(&file, &NoResolver, &options).expect("deep but allowed").asset;
    assert_eq!(a.order.first(), Some(&0));
    assert_eq!(a.order.last(), Some(&(n as u32 - 1)));
}

/// A resolver that must never be asked.
struct Forbidden;
impl Resolver for Forbidden {
    fn resolve(&self, uri: &str) -> Result<Vec<u8>, String> {
        panic!("resolver called for {uri}")
    }
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn byte_length_bombs_are_refused_before_allocating() {
    let doc = json!({"asset": {"version": "2.0"}, "buffers": [{"byteLength": 1u64 << 50, "uri": "bomb.bin"}]});
    let e = import(doc.to_string().as_bytes(), &Forbidden, &ImportOptions::default()).expect_err("bomb");
    assert_eq!(e.pointer, "/buffers/0");
    assert!(e.message.contains("import budget"), "{e}");
    // Many buffers each under the budget, together over it.
    let many = json!({"asset": {"version": "2.0"},
        "buffers": [{"byteLength": 400u64 << 20, "uri": "a.bin"}, {"byteLength": 400u64 << 20, "uri": "b.bin"}]});
    let e = import(many.to_string().as_bytes(), &Forbidden, &ImportOptions::default()).expect_err("bomb");
    assert_eq!(e.pointer, "/buffers/1");
    // An accessor without a buffer view (zeros) declaring 2^40 elements.
    let (mut doc, bin) = base();
    doc["accessors"][0] = json!({"componentType": 5126, "count": 1u64 << 40, "type": "VEC3"});
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, "/accessors/0");
    assert!(e.message.contains("import budget"), "{e}");
    // A JSON document of many tiny values is charged for its parsed tree, not its text.
    let tiny_values = format!("[{}0]", "0,".repeat(1 << 20));
    let estimate = json_tree_estimate(tiny_values.as_bytes());
    assert!(estimate > 64 << 20, "{estimate}");
    let small = ImportOptions { budget_bytes: 32 << 20, ..ImportOptions::default() };
    let e = import(tiny_values.as_bytes(), &NoResolver, &small).expect_err("JSON bomb");
    assert!(e.message.contains("parsed JSON document"), "{e}");
    // The separators and openers outside strings, plus one; escaped quotes stay inside their string;
    // long runs outside strings (counted in chunks) and an unterminated string.
    assert_eq!(json_tree_estimate(br#"{"a":"x,[{:"}"#), 13 + 3 * JSON_VALUE_BYTES);
    assert_eq!(json_tree_estimate(br#"{"a\\":"x\",[{:","b":[1,2]}"#), 27 + 7 * JSON_VALUE_BYTES);
    assert_eq!(json_tree_estimate(b"{}"), 2 + 2 * JSON_VALUE_BYTES);
    let long = format!("[{}]", "1,".repeat(1000) + "1");
    assert_eq!(json_tree_estimate(long.as_bytes()), long.len() as u64 + 1002 * JSON_VALUE_BYTES);
    assert_eq!(json_tree_estimate(br#"[1,"a,b"#), 7 + 3 * JSON_VALUE_BYTES);
    // A small budget refuses the JSON itself.
    let tiny = ImportOptions { budget_bytes: 1000, ..ImportOptions::default() };
    assert!(import(&glb_of(&doc, &bin), &NoResolver, &tiny).is_err());
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn the_sampling_layout_of_clips_is_charged_to_the_budget() {
    // 64 nodes, each rotated by one channel of 2,000 keys through the same two accessors:
    // 64 decoded copies (~2.6 MB) plus their four-lane layout (~3.1 MB).
    let (mut doc, mut bin) = base();
    let keys = 2000;
    let times: Vec<f32> = (0..keys).map(|k| k as f32 / 30.0).collect();
    let quats: Vec<f32> =
        (0..keys).flat_map(|k| crate::math::Quat::from_rotation_z(k as f32 * 1e-3).to_array()).collect();
    let tv = add_view(&mut doc, &mut bin, &f32s(&times), None);
    let qv = add_view(&mut doc, &mut bin, &f32s(&quats), None);
    let t = add_accessor(&mut doc, json!({"bufferView": tv, "componentType": 5126, "count": keys, "type": "SCALAR"}));
    let q = add_accessor(&mut doc, json!({"bufferView": qv, "componentType": 5126, "count": keys, "type": "VEC4"}));
    let root = json!({"mesh": 0, "children": (1..=64).collect::<Vec<_>>()});
    let nodes: Vec<Value> = std::iter::once(root).chain((0..64).map(|i| json!({"name": format!("n{i}")}))).collect();
    doc["nodes"] = json!(nodes);
    let channels: Vec<Value> =
        (1..=64).map(|n| json!({"sampler": 0, "target": {"node": n, "path": "rotation"}})).collect();
    doc["animations"] = json!([{"samplers": [{"input": t, "output": q}], "channels": channels}]);
    let file = glb_of(&doc, &bin);
    let layout = {
        let imported = import(&file, &NoResolver, &ImportOptions::default()).expect("imports");
        let clip = &imported.asset.clips[0];
        assert_eq!(clip.channels().len(), 64);
        crate::clip::Clip::layout_bytes(clip.channels())
    };
    assert!(layout > 3_000_000, "{layout}");
    // Enough for the file and its decoded accessors, not for the layout as well.
    let tight = ImportOptions { budget_bytes: 5 << 20, ..ImportOptions::default() };
    let e = import(&file, &NoResolver, &tight).expect_err("over the budget");
    assert_eq!(e.pointer, "/animations/0");
    assert!(e.message.contains("animation sampling layout"), "{e}");
    let roomy = ImportOptions { budget_bytes: 8 << 20, ..ImportOptions::default() };
    assert!(import(&file, &NoResolver, &roomy).is_ok());
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn absolute_web_uris_come_from_the_resolver_other_schemes_are_refused() {
    let doc = |uri: &str| json!({"asset": {"version": "2.0"}, "buffers": [{"byteLength": 3, "uri": uri}]}).to_string();
    let mut files = MapResolver::new();
    files.insert("https://cdn.example/models/a.bin", vec![1, 2, 3]);
    let fetched = import(doc("https://cdn.example/models/a.bin").as_bytes(), &files, &ImportOptions::default());
    assert!(fetched.is_ok(), "{fetched:?}");
    let e =
        import(doc("http://other.example/b.bin").as_bytes(), &files, &ImportOptions::default()).expect_err("absent");
    assert_eq!(e.pointer, "/buffers/0/uri");
    assert!(e.message.contains("cannot load 'http://other.example/b.bin'"), "{e}");
    for uri in ["ftp://cdn.example/a.bin", "file:///etc/passwd", "https:a.bin"] {
        let e = import(doc(uri).as_bytes(), &files, &ImportOptions::default()).expect_err(uri);
        assert!(e.message.contains("only relative paths"), "{uri}: {e}");
    }
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn data_is_required_only_where_it_is_read() {
    // A second buffer with no uri (in a GLB only the first may be the BIN chunk), and a view of it.
    let (mut doc, bin) = base();
    doc["buffers"].as_array_mut().expect("buffers").push(json!({"byteLength": 64}));
    doc["bufferViews"].as_array_mut().expect("views").push(json!({"buffer": 1, "byteLength": 36}));
    let unread = run(&doc, &bin).expect("nothing reads the empty buffer");
    assert!(unread.warnings.is_empty(), "{:?}", unread.warnings);
    // Read by an accessor: refused where the data is missing.
    let views = doc["bufferViews"].as_array().expect("views").len() - 1;
    doc["accessors"][0]["bufferView"] = json!(views);
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, "/buffers/1");
    assert!(e.message.contains("no uri") && e.message.contains(&format!("bufferView {views}")), "{e}");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn a_primitive_without_positions_is_left_out_with_a_warning() {
    let (mut doc, bin) = base();
    doc["meshes"][0]["primitives"] =
        json!([{"attributes": {"TEXCOORD_0": 2}}, {"attributes": {"POSITION": 0}, "indices": 1}]);
    let imported = run(&doc, &bin).expect("the other primitive loads");
    assert_eq!(imported.warnings.len(), 1, "{:?}", imported.warnings);
    assert_eq!(imported.warnings[0].pointer, "/meshes/0/primitives/0/attributes");
    let primitives = &imported.asset.meshes[0].primitives;
    assert_eq!((primitives.len(), primitives[0].vertex_count), (1, 3));
    // Every primitive without positions: a mesh with nothing to draw, still valid.
    doc["meshes"][0]["primitives"] = json!([{"attributes": {"TEXCOORD_0": 2}}]);
    let empty = run(&doc, &bin).expect("nothing to draw is not an error");
    assert!(empty.asset.meshes[0].primitives.is_empty());
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn bad_data_uris_are_refused() {
    let doc = |uri: &str, len: u64| json!({"asset": {"version": "2.0"}, "buffers": [{"byteLength": len, "uri": uri}]});
    let go = |d: Value| import(d.to_string().as_bytes(), &NoResolver, &ImportOptions::default());
    let e = go(doc("data:application/octet-stream;base64,AQID", 8)).expect_err("short");
    assert_eq!(e.pointer, "/buffers/0");
    assert!(e.message.contains("exceeds the 3 bytes"), "{e}");
    let e = go(doc("data:application/octet-stream;base64,AQ!D", 3)).expect_err("bad char");
    assert_eq!(e.pointer, "/buffers/0/uri");
    // Not base64 (RFC 2397): the URI's own characters, percent-encoded.
    let plain = go(doc("data:application/octet-stream,A%01%02", 3)).expect("percent-encoded");
    assert!(plain.warnings.is_empty());
    let e = go(doc("data:application/octet-stream,AQ", 3)).expect_err("too short");
    assert!(e.message.contains("exceeds the 2 bytes"), "{e}");
    assert!(go(doc("data:application/octet-stream;base64,AQID", 3)).is_ok());
    let e = go(doc("../../x", 3)).expect_err("outside");
    assert_eq!(e.pointer, "/buffers/0/uri");
    let e = go(doc("missing.bin", 3)).expect_err("no resolver");
    assert!(e.message.contains("external files are not available"), "{e}");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn uris_outside_the_folder_are_never_resolved() {
    // A resolver holding `x` would serve `../../x` (it resolves by file name): the import
    // must refuse such URIs before asking it.
    let outside = [
        "../../x",
        "a/../../x",
        "..\\..\\x",
        "%2E%2E/%2E%2E/x",
        "/x",
        "\\\\server\\x",
        "file:///x",
        "ftp://e.invalid/x",
    ];
    // (Absolute http(s) addresses go to the resolver: the viewer fetched them, the kloub tool refuses them.)
    for uri in outside {
        let doc = json!({"asset": {"version": "2.0"}, "buffers": [{"byteLength": 4, "uri": uri}]});
        let e = import(doc.to_string().as_bytes(), &Forbidden, &ImportOptions::default()).expect_err(uri);
        assert_eq!(e.pointer, "/buffers/0/uri", "{uri}: {e}");
        assert!(e.message.contains(uri), "{uri}: {e}");
    }
    let e = import(
        json!({"asset": {"version": "2.0"}, "buffers": [{"byteLength": 4, "uri": "../../x"}]}).to_string().as_bytes(),
        &Forbidden,
        &ImportOptions::default(),
    )
    .expect_err("outside");
    assert!(e.message.contains("points outside the folder of the glTF file"), "{e}");
    // Images: skipped (white pixel) with a warning at their uri; the document loads.
    let (mut doc, bin) = base();
    doc["images"] = Value::Array(outside.iter().map(|u| json!({"uri": u})).collect());
    doc["textures"] = json!([{"source": 0}]);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    let imported = import(&glb_of(&doc, &bin), &Forbidden, &ImportOptions::default()).expect("images skipped");
    let pointers: Vec<_> = imported.warnings.iter().map(|w| w.pointer.clone()).collect();
    let expected: Vec<_> = (0..outside.len()).map(|i| format!("/images/{i}/uri")).collect();
    assert_eq!(pointers, expected, "{:?}", imported.warnings);
    assert!(imported.warnings[0].message.contains("points outside the folder"), "{}", imported.warnings[0]);
    assert!(imported.asset.images.iter().all(|i| (i.width, i.height, i.rgba8.as_slice()) == (1, 1, &[255u8; 4][..])));
    assert!(imported.asset.materials[0].base_color_texture.is_none());
}

/// The base document with a 2-joint skin; JOINTS_0 (u8) and WEIGHTS_0 (float) given per vertex.
fn skinned(joints: [[u8; 4]; 3], weights: [[f32; 4]; 3]) -> (Value, Vec<u8>) {
    let (doc, bin, _, _) = skinned_by((5121, &joints.concat(), None), (5126, &f32s(&weights.concat()), None));
    (doc, bin)
}

/// The base document with a 2-joint skin whose JOINTS_0 and WEIGHTS_0 are VEC4 accessors of three
/// elements, each `(componentType, bytes, byteStride)` in a view of its own (integer weights
/// normalized); with the two accessors' indices.
fn skinned_by(joints: (u32, &[u8], Option<u32>), weights: (u32, &[u8], Option<u32>)) -> (Value, Vec<u8>, u32, u32) {
    let (mut doc, mut bin) = base();
    let mut attribute = |(component, bytes, stride): (u32, &[u8], Option<u32>), normalized: bool| {
        let view = add_view(&mut doc, &mut bin, bytes, stride);
        let mut accessor = json!({"bufferView": view, "componentType": component, "count": 3, "type": "VEC4"});
        if normalized {
            accessor["normalized"] = json!(true);
        }
        add_accessor(&mut doc, accessor)
    };
    let j = attribute(joints, false);
    let w = attribute(weights, weights.0 != 5126);
    doc["meshes"][0]["primitives"][0]["attributes"]["JOINTS_0"] = json!(j);
    doc["meshes"][0]["primitives"][0]["attributes"]["WEIGHTS_0"] = json!(w);
    doc["nodes"] = json!([{"mesh": 0, "skin": 0}, {"children": [2]}, {}]);
    doc["scenes"] = json!([{"nodes": [0, 1]}]);
    doc["skins"] = json!([{"joints": [1, 2]}]);
    (doc, bin, j as u32, w as u32)
}

/// `f` of `doc`'s accessors over the one buffer `bin`, as the importer makes them, and a budget.
fn with_accessors<R>(
    doc: &Value,
    bin: Vec<u8>,
    f: impl FnOnce(&accessor::Accessors<'_>, &mut Budget) -> R,
) -> Result<R, ImportError> {
    let text = doc.to_string();
    let arena = super::tree::Arena::new();
    let tree = super::tree::parse(text.as_bytes(), &arena).expect("JSON");
    let mut budget = Budget::new(1 << 20);
    let accessors = accessor::Accessors::new(
        tree.as_object().expect("object"),
        vec![Some(std::borrow::Cow::Owned(bin))],
        &mut budget,
    )?;
    Ok(f(&accessors, &mut budget))
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn broken_inverse_bind_matrices_are_replaced_by_the_rest_pose_with_a_warning() {
    let (mut doc, mut bin) = skinned([[0, 1, 0, 0]; 3], [[0.5, 0.5, 0.0, 0.0]; 3]);
    doc["nodes"][1]["translation"] = json!([0.0, 2.0, 0.0]);
    doc["nodes"][2]["translation"] = json!([1.0, 0.0, 0.0]);
    // Joint 0's matrix is fine (the inverse of its rest pose, moved a little); joint 1's is zero.
    let good = Mat4::from_translation(Vec3::new(0.0, -2.5, 0.0));
    let matrices = [good.to_cols_array(), [0.0; 16]].concat();
    let view = add_view(&mut doc, &mut bin, &f32s(&matrices), None);
    let ibm = add_accessor(&mut doc, json!({"bufferView": view, "componentType": 5126, "count": 2, "type": "MAT4"}));
    doc["skins"][0]["inverseBindMatrices"] = json!(ibm);
    let imported = run(&doc, &bin).expect("repaired");
    assert_eq!(imported.warnings.len(), 1, "{:?}", imported.warnings);
    assert_eq!(imported.warnings[0].pointer, "/skins/0/inverseBindMatrices");
    assert!(imported.warnings[0].message.contains("1 matrices") && imported.warnings[0].message.contains("joints 1"));
    let skin = &imported.asset.skins[0];
    assert_eq!(skin.inverse_bind[0], good);
    assert!(skin.inverse_bind[1].abs_diff_eq(Mat4::from_translation(Vec3::new(-1.0, -2.0, 0.0)), 1e-6));
    // A projective matrix (its last row not 0, 0, 0, 1) is broken too.
    let mut projective = good.to_cols_array();
    projective[3] = 0.5;
    let matrices = [projective, good.to_cols_array()].concat();
    let view = add_view(&mut doc, &mut bin, &f32s(&matrices), None);
    let ibm = add_accessor(&mut doc, json!({"bufferView": view, "componentType": 5126, "count": 2, "type": "MAT4"}));
    doc["skins"][0]["inverseBindMatrices"] = json!(ibm);
    let imported = run(&doc, &bin).expect("repaired");
    assert!(imported.warnings[0].message.contains("joints 0"), "{}", imported.warnings[0]);
    assert!(
        imported.asset.skins[0].inverse_bind[0].abs_diff_eq(Mat4::from_translation(Vec3::new(0.0, -2.0, 0.0)), 1e-6)
    );
    // A tiny scale is not singular (gltfpack folds its dequantization scale, ~1e-4, into them);
    // a matrix whose axes lie in a plane is.
    let tiny = Mat4::from_scale(Vec3::splat(9e-5)) * good;
    let flat = Mat4::from_cols(Vec4::X, Vec4::X, Vec4::Z, good.w_axis);
    let matrices = [tiny.to_cols_array(), flat.to_cols_array()].concat();
    let view = add_view(&mut doc, &mut bin, &f32s(&matrices), None);
    let ibm = add_accessor(&mut doc, json!({"bufferView": view, "componentType": 5126, "count": 2, "type": "MAT4"}));
    doc["skins"][0]["inverseBindMatrices"] = json!(ibm);
    let imported = run(&doc, &bin).expect("repaired");
    assert_eq!(imported.warnings.len(), 1, "{:?}", imported.warnings);
    assert!(imported.warnings[0].message.contains("1 matrices") && imported.warnings[0].message.contains("joints 1"));
    assert_eq!(imported.asset.skins[0].inverse_bind[0], tiny);
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn an_animated_node_given_by_a_matrix_is_warned_about_once() {
    let (mut doc, bin) = base();
    doc["nodes"][0]["matrix"] = json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 3, 0, 0, 1]);
    let channel = doc["animations"][0]["channels"][0].clone();
    doc["animations"][0]["channels"] = json!([channel.clone(), channel]);
    let imported = run(&doc, &bin).expect("animated");
    assert_eq!(imported.warnings.len(), 1, "{:?}", imported.warnings);
    assert_eq!(imported.warnings[0].pointer, "/animations/0/channels/0/target/node");
    assert!(imported.warnings[0].message.contains("given by a matrix"), "{}", imported.warnings[0]);
    assert_eq!(imported.asset.nodes[0].rest.translation, Vec3::new(3.0, 0.0, 0.0));
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn joint_index_outside_the_skin_is_refused() {
    let (doc, bin) = skinned(
        [[0, 1, 0, 0], [5, 0, 0, 0], [1, 0, 0, 0]],
        [[0.5, 0.5, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]],
    );
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, "/meshes/0/primitives/0/attributes/JOINTS_0");
    assert!(e.message.contains("joint index 5 is outside skin 0 (2 joints)"), "{e}");
    // An out-of-range joint with zero weight is harmless and reset to joint 0.
    let (doc, bin) = skinned([[0, 9, 0, 0], [1, 0, 0, 0], [1, 0, 0, 0]], [[1.0, 0.0, 0.0, 0.0]; 3]);
    let a = run(&doc, &bin).expect("valid").asset;
    assert_eq!(a.meshes[0].primitives[0].joints[0], [0; 8]);
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn skin_weights_are_renormalized_with_one_warning() {
    let (doc, bin) =
        skinned([[0, 1, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0]], [[0.5, 0.25, 0.0, 0.0], [0.0; 4], [0.3, 0.7, 0.0, 0.0]]);
    let imported = run(&doc, &bin).expect("repaired");
    assert_eq!(imported.warnings.len(), 1, "{:?}", imported.warnings);
    assert_eq!(imported.warnings[0].pointer, "/meshes/0/primitives/0/attributes/WEIGHTS_0");
    assert!(imported.warnings[0].message.contains("2 of 3 vertices"), "{}", imported.warnings[0]);
    let p = &imported.asset.meshes[0].primitives[0];
    assert!((p.weights[0][0] - 2.0 / 3.0).abs() < 1e-6 && (p.weights[0][1] - 1.0 / 3.0).abs() < 1e-6);
    assert_eq!(p.weights[1], [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(p.joints[1][0], 1, "all-zero weights go to the vertex's first joint");
    assert_eq!(p.weights[2][..2], [0.3, 0.7]);
}

/// One set of skin influences packed as VEC4s is read in one pass (`mesh::one_dense_set`) with
/// the results of the general path, which reads the same values interleaved: joints of 8 and 16
/// bits, float and normalized 8- and 16-bit weights, weights to repair among them.
#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn packed_skin_influences_read_in_one_pass_as_interleaved_ones_do() {
    // Three vertices at a time (the base's triangle): weights in [0, 1] as codes scale them.
    let weights: [[f32; 4]; 12] = [
        [0.5, 0.25, 0.125, 0.125],
        [0.1, 0.2, 0.3, 0.4],
        [0.3, 0.3, 0.3, 0.3],
        [0.0; 4],
        [0.0, 1.0, 0.0, 0.0],
        [0.2, 0.0, 0.0, 0.0],
        [1.0, 1.0, 1.0, 1.0],
        [0.0, 0.0, 0.0, 0.6],
        [0.999, 0.001, 0.0, 0.0],
        [0.7, 0.1, 0.1, 0.1],
        [0.0, 0.0, 0.5, 0.0],
        [0.25, 0.25, 0.25, 0.25],
    ];
    let joints: [[u16; 4]; 12] = std::array::from_fn(|i| [(i % 2) as u16, 1, ((i / 2) % 2) as u16, (i / 3 % 2) as u16]);
    // Float weights the file may hold besides: non-finite and negative ones.
    let odd: [[f32; 4]; 3] = [[f32::NAN, 0.5, 0.5, 0.0], [-0.5, 0.6, 0.4, 0.0], [f32::INFINITY, 1.0, 0.0, 0.0]];
    let mut checked = 0;
    for joint_type in [5121, 5123] {
        for weight_type in [5126, 5121, 5123] {
            type Group = ([[u16; 4]; 3], [[f32; 4]; 3]);
            let groups: Vec<Group> = (0..5)
                .map(|g| match g {
                    4 if weight_type == 5126 => ([joints[0], joints[1], joints[2]], odd),
                    4 => ([joints[3], joints[4], joints[5]], [weights[3], weights[4], weights[5]]),
                    g => (
                        [joints[3 * g % 12], joints[(3 * g + 1) % 12], joints[(3 * g + 2) % 12]],
                        [weights[3 * g % 12], weights[(3 * g + 1) % 12], weights[(3 * g + 2) % 12]],
                    ),
                })
                .collect();
            for (js, ws) in groups {
                let encode = |component: u32, values: Vec<f32>| -> Vec<u8> {
                    match component {
                        5126 => f32s(&values),
                        5121 => values.iter().map(|&v| (v * 255.0).round() as u8).collect(),
                        _ => values.iter().flat_map(|&v| ((v * 65535.0).round() as u16).to_le_bytes()).collect(),
                    }
                };
                let joint_bytes: Vec<Vec<u8>> = js
                    .iter()
                    .map(|j| match joint_type {
                        5121 => j.iter().map(|&x| x as u8).collect(),
                        _ => j.iter().flat_map(|x| x.to_le_bytes()).collect(),
                    })
                    .collect();
                let weight_bytes: Vec<Vec<u8>> = ws.iter().map(|w| encode(weight_type, w.to_vec())).collect();
                let mut results = Vec::new();
                for packed in [true, false] {
                    // Interleaved: each element followed by four bytes of padding (another attribute's).
                    let layout = |elements: &[Vec<u8>]| -> (Vec<u8>, Option<u32>) {
                        if packed {
                            (elements.concat(), None)
                        } else {
                            let stride = elements[0].len() + 4;
                            (
                                elements.iter().flat_map(|e| e.iter().copied().chain([0xAB; 4])).collect(),
                                Some(stride as u32),
                            )
                        }
                    };
                    let ((jb, js), (wb, ws)) = (layout(&joint_bytes), layout(&weight_bytes));
                    let (doc, bin, j, w) = skinned_by((joint_type, &jb, js), (weight_type, &wb, ws));
                    // Which path reads it.
                    let one_pass =
                        with_accessors(&doc, bin.clone(), |accessors, _| mesh::one_dense_set(accessors, j, w, 3))
                            .expect("valid")
                            .expect("readable");
                    assert_eq!(one_pass.is_some(), packed, "{joint_type} {weight_type}");
                    let imported = run(&doc, &bin).expect("valid");
                    let p = &imported.asset.meshes[0].primitives[0];
                    let messages: Vec<String> =
                        imported.warnings.iter().map(|w| format!("{} {}", w.pointer, w.message)).collect();
                    results.push((
                        p.joints.clone(),
                        p.weights.iter().map(|w| w.map(f32::to_bits)).collect::<Vec<_>>(),
                        messages,
                    ));
                }
                assert_eq!(results[0], results[1], "joints {joint_type}, weights {weight_type}: {js:?} {ws:?}");
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 30);
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn float_attributes_read_tight_and_interleaved_and_non_finite_ones_are_refused() {
    // Positions and normals interleaved in one view (24-byte stride), the base's own positions
    // tight: both read whole, in order, with their bounds.
    let (mut doc, mut bin) = base();
    let interleaved = f32s(&[
        0.0, 0.0, 0.0, 0.0, 0.0, 1.0, //
        2.0, -1.0, 0.5, 0.0, 0.0, 1.0, //
        -3.0, 4.0, 0.25, 0.0, 1.0, 0.0,
    ]);
    let view = add_view(&mut doc, &mut bin, &interleaved, Some(24));
    let p = add_accessor(&mut doc, json!({"bufferView": view, "componentType": 5126, "count": 3, "type": "VEC3"}));
    let n = add_accessor(
        &mut doc,
        json!({"bufferView": view, "byteOffset": 12, "componentType": 5126, "count": 3, "type": "VEC3"}),
    );
    let mut two = doc.clone();
    two["meshes"][0]["primitives"][0]["attributes"] = json!({"POSITION": p, "NORMAL": n});
    let imported = run(&two, &bin).expect("interleaved");
    let prim = &imported.asset.meshes[0].primitives[0];
    assert_eq!(prim.positions, [[0.0, 0.0, 0.0], [2.0, -1.0, 0.5], [-3.0, 4.0, 0.25]]);
    assert_eq!(prim.normals, [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]);
    assert_eq!(prim.bounds, ([-3.0, -1.0, 0.0], [2.0, 4.0, 0.5]));
    let imported = run(&doc, &bin).expect("tight");
    assert_eq!(imported.asset.meshes[0].primitives[0].positions, [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);

    // A NaN or an infinity in a vertex attribute would be drawn as nothing or everywhere:
    // refused, naming the accessor and the element.
    for (value, attribute) in [(f32::NAN, "POSITION"), (f32::INFINITY, "NORMAL")] {
        let mut bad = bin.clone();
        let at = bin.len() - interleaved.len() + 24 + if attribute == "NORMAL" { 16 } else { 4 };
        bad[at..at + 4].copy_from_slice(&value.to_le_bytes());
        let e = refused(&two, &bad);
        let accessor = if attribute == "NORMAL" { n } else { p };
        assert_eq!(e.pointer, format!("/accessors/{accessor}"), "{e}");
        assert!(e.message.contains("element 1 is not finite"), "{e}");
    }
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn nan_and_non_increasing_keys_are_dropped_with_a_warning() {
    let (doc, mut bin) = base();
    bin[48..52].copy_from_slice(&f32::NAN.to_le_bytes());
    let imported = run(&doc, &bin).expect("repaired");
    let c = &imported.asset.clips[0].channels()[0];
    assert_eq!(c.times, [0.0]);
    assert_eq!(c.values, [0.0, 0.0, 0.0]);
    assert_eq!(imported.asset.clips[0].duration, 0.0);
    assert!(
        imported
            .warnings
            .iter()
            .any(|w| w.pointer == "/animations/0/samplers/0" && w.message.contains("dropped 1 of 2"))
    );

    // Times 0, 2, 1, 3: the key at 1 is dropped; an infinite value drops its key too.
    let (mut doc, mut bin) = base();
    let tv = add_view(&mut doc, &mut bin, &f32s(&[0.0, 2.0, 1.0, 3.0]), None);
    let vv = add_view(
        &mut doc,
        &mut bin,
        &f32s(&[0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0, f32::INFINITY, 0.0, 0.0]),
        None,
    );
    let t = add_accessor(&mut doc, json!({"bufferView": tv, "componentType": 5126, "count": 4, "type": "SCALAR"}));
    let v = add_accessor(&mut doc, json!({"bufferView": vv, "componentType": 5126, "count": 4, "type": "VEC3"}));
    doc["animations"][0]["samplers"][0] = json!({"input": t, "output": v, "interpolation": "STEP"});
    let imported = run(&doc, &bin).expect("repaired");
    let c = &imported.asset.clips[0].channels()[0];
    assert_eq!(c.times, [0.0, 2.0]);
    assert_eq!(c.values, [0.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
    assert_eq!(c.interpolation, Interpolation::Step);
    assert!(imported.warnings.iter().any(|w| w.message.contains("dropped 2 of 4")), "{:?}", imported.warnings);
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn rotation_keys_are_made_unit_and_those_with_no_direction_dropped() {
    // Each rotation divided by its length (the reader's rule); a key with no direction, zero or
    // too long for f32, is dropped wherever it is (first, between, last) and the keys after it
    // move up.
    let unit = |q: [f32; 4]| {
        let v = crate::math::Vec4::from_array(q);
        (v / v.length()).to_array()
    };
    let keys: [[f32; 4]; 6] = [
        [0.0, 0.0, 0.0, 1.0],
        [0.0, 0.0, 0.0, 0.0],
        [0.0, 2.0, 0.0, 0.0],
        [0.6, 0.0, 0.0, 0.8],
        [1e30, 1e30, 0.0, 0.0],
        [0.0, 0.0, 0.5, 0.5],
    ];
    for (skipped, kept, renormalized) in [
        (vec![], vec![0, 2, 3, 5], 2),
        (vec![1, 4], vec![0, 2, 3, 5], 2),
        (vec![0, 2, 3, 5], vec![], 0),
        (vec![1, 4, 5], vec![0, 2, 3], 1),
        (vec![0, 1, 4, 5], vec![2, 3], 1),
        (vec![0, 2, 4, 5], vec![3], 0),
    ] {
        let listed: Vec<usize> = (0..keys.len()).filter(|k| !skipped.contains(k)).collect();
        let (mut doc, mut bin) = base();
        let times: Vec<f32> = listed.iter().map(|&k| k as f32).collect();
        let values: Vec<f32> = listed.iter().flat_map(|&k| keys[k]).collect();
        let tv = add_view(&mut doc, &mut bin, &f32s(&times), None);
        let vv = add_view(&mut doc, &mut bin, &f32s(&values), None);
        let count = listed.len();
        let t =
            add_accessor(&mut doc, json!({"bufferView": tv, "componentType": 5126, "count": count, "type": "SCALAR"}));
        let v =
            add_accessor(&mut doc, json!({"bufferView": vv, "componentType": 5126, "count": count, "type": "VEC4"}));
        doc["animations"][0]["samplers"][0] = json!({"input": t, "output": v});
        doc["animations"][0]["channels"][0]["target"]["path"] = json!("rotation");
        let imported = run(&doc, &bin).expect("repaired");
        let messages: Vec<&str> = imported.warnings.iter().map(|w| w.message.as_str()).collect();
        let Some(c) = imported.asset.clips[0].channels().first() else {
            assert!(kept.is_empty() && messages.iter().any(|m| m.contains("no usable keyframes")), "{messages:?}");
            continue;
        };
        let expected_times: Vec<f32> = kept.iter().map(|&k| k as f32).collect();
        let expected_values: Vec<f32> = kept.iter().flat_map(|&k| unit(keys[k])).collect();
        assert_eq!(c.times, expected_times, "{listed:?}");
        assert_eq!(c.values, expected_values, "{listed:?}");
        let dropped = count - kept.len();
        assert_eq!(
            messages.iter().any(|m| m.contains(&format!("dropped {dropped} of {count}"))),
            dropped > 0,
            "{messages:?}"
        );
        let normalized = format!("{renormalized} rotation keyframes were not unit quaternions");
        assert_eq!(messages.iter().any(|m| m.contains(&normalized)), renormalized > 0, "{messages:?}");
    }
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn infinite_key_times_and_nan_values_are_dropped_with_a_warning() {
    let (mut doc, mut bin) = base();
    let times = [f32::NEG_INFINITY, 0.0, f32::INFINITY, 1.0, 2.0, f32::NAN];
    let tv = add_view(&mut doc, &mut bin, &f32s(&times), None);
    let mut values = Vec::new();
    for k in 0..times.len() {
        values.extend([k as f32; 3]);
    }
    values[3 * 4 + 1] = f32::NAN; // key 4 (time 2) has a NaN value
    let vv = add_view(&mut doc, &mut bin, &f32s(&values), None);
    let t = add_accessor(&mut doc, json!({"bufferView": tv, "componentType": 5126, "count": 6, "type": "SCALAR"}));
    let v = add_accessor(&mut doc, json!({"bufferView": vv, "componentType": 5126, "count": 6, "type": "VEC3"}));
    doc["animations"][0]["samplers"][0] = json!({"input": t, "output": v});
    let imported = run(&doc, &bin).expect("repaired");
    let c = &imported.asset.clips[0].channels()[0];
    assert_eq!(c.times, [0.0, 1.0]);
    assert_eq!(c.values, [1.0, 1.0, 1.0, 3.0, 3.0, 3.0]);
    assert_eq!(imported.asset.clips[0].duration, 1.0);
    assert_eq!(imported.warnings.len(), 1, "{:?}", imported.warnings);
    assert_eq!(imported.warnings[0].pointer, "/animations/0/samplers/0");
    assert!(imported.warnings[0].message.contains("dropped 4 of 6"), "{}", imported.warnings[0]);
    // Only infinite times: the channel is dropped, the document still loads.
    let (mut doc, mut bin) = base();
    let tv = add_view(&mut doc, &mut bin, &f32s(&[f32::INFINITY, f32::INFINITY]), None);
    let t = add_accessor(&mut doc, json!({"bufferView": tv, "componentType": 5126, "count": 2, "type": "SCALAR"}));
    doc["animations"][0]["samplers"][0]["input"] = json!(t);
    let imported = run(&doc, &bin).expect("repaired");
    assert!(imported.asset.clips[0].channels().is_empty());
    assert!(imported.warnings.iter().any(|w| w.message.contains("no usable keyframes")), "{:?}", imported.warnings);
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn unsupported_required_extension_is_refused() {
    let (mut doc, bin) = base();
    doc["extensionsRequired"] = json!(["KHR_texture_transform", "KHR_texture_basisu"]);
    let e = refused(&doc, &bin);
    assert_eq!(e.to_string(), "/extensionsRequired/1: required extension KHR_texture_basisu is not supported");
    doc["extensionsRequired"] = json!(["KHR_mesh_quantization", "KHR_materials_unlit"]);
    assert!(run(&doc, &bin).is_ok());
    doc["asset"]["version"] = json!("1.0");
    assert_eq!(refused(&doc, &bin).pointer, "/asset/version");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn sparse_accessors_substitute_and_are_checked() {
    let (mut doc, mut bin) = base();
    let iv = add_view(&mut doc, &mut bin, &[2u16, 0].iter().flat_map(|i| i.to_le_bytes()).collect::<Vec<_>>(), None);
    let idx = add_view(&mut doc, &mut bin, &[0u16, 2].iter().flat_map(|i| i.to_le_bytes()).collect::<Vec<_>>(), None);
    let vv = add_view(&mut doc, &mut bin, &f32s(&[9.0, 9.0, 9.0, 5.0, 5.0, 5.0]), None);
    let sparse = |indices_view: usize| json!({"count": 2, "indices": {"bufferView": indices_view, "componentType": 5123}, "values": {"bufferView": vv}});
    // Sparse on a dense accessor.
    doc["accessors"][0]["sparse"] = sparse(idx);
    let p = run(&doc, &bin).expect("valid").asset.meshes[0].primitives[0].clone();
    assert_eq!(p.positions, [[9.0, 9.0, 9.0], [1.0, 0.0, 0.0], [5.0, 5.0, 5.0]]);
    // Sparse without a buffer view: zeros elsewhere.
    doc["accessors"][0] = json!({"componentType": 5126, "count": 3, "type": "VEC3", "sparse": sparse(idx)});
    let p = run(&doc, &bin).expect("valid").asset.meshes[0].primitives[0].clone();
    assert_eq!(p.positions, [[9.0, 9.0, 9.0], [0.0; 3], [5.0, 5.0, 5.0]]);
    // Decreasing indices.
    doc["accessors"][0]["sparse"] = sparse(iv);
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, "/accessors/0/sparse/indices");
    assert!(e.message.contains("strictly increasing"), "{e}");
    // Index beyond the count.
    doc["accessors"][0]["count"] = json!(2);
    doc["accessors"][0]["sparse"] = sparse(idx);
    doc["meshes"][0]["primitives"][0].as_object_mut().expect("prim").remove("indices");
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, "/accessors/0/sparse/indices");
    assert!(e.message.contains("out of range"), "{e}");
    // Sparse count above the accessor count.
    doc["accessors"][0]["count"] = json!(1);
    assert_eq!(refused(&doc, &bin).pointer, "/accessors/0/sparse/count");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn sparse_indices_out_of_range_repeated_or_decreasing_are_refused() {
    let (mut doc, mut bin) = base();
    let vv = add_view(&mut doc, &mut bin, &f32s(&[9.0; 6]), None);
    // (index component type, index bytes, expected message)
    let cases: [(u32, Vec<u8>, &str); 5] = [
        (
            5125,
            [0u32, u32::MAX].iter().flat_map(|i| i.to_le_bytes()).collect(),
            "sparse index 4294967295 is out of range",
        ),
        (5125, [u32::MAX, 0].iter().flat_map(|i| i.to_le_bytes()).collect(), "sparse index 4294967295 is out of range"),
        (5121, vec![3, 200], "sparse index 3 is out of range (count 3)"),
        (5123, [1u16, 1].iter().flat_map(|i| i.to_le_bytes()).collect(), "strictly increasing: 1 follows 1"),
        (5125, [2u32, 1].iter().flat_map(|i| i.to_le_bytes()).collect(), "strictly increasing: 1 follows 2"),
    ];
    for (component, indices, message) in cases {
        let iv = add_view(&mut doc, &mut bin, &indices, None);
        doc["accessors"][0]["sparse"] = json!({"count": 2,
            "indices": {"bufferView": iv, "componentType": component}, "values": {"bufferView": vv}});
        let e = refused(&doc, &bin);
        assert_eq!(e.pointer, "/accessors/0/sparse/indices", "{message}: {e}");
        assert!(e.message.contains(message), "{message}: {e}");
    }
    // Indices as floats or signed integers, and a sparse count of 2^62.
    for component in [5126, 5122] {
        doc["accessors"][0]["sparse"]["indices"]["componentType"] = json!(component);
        assert_eq!(refused(&doc, &bin).pointer, "/accessors/0/sparse/indices/componentType");
    }
    doc["accessors"][0]["sparse"]["indices"]["componentType"] = json!(5125);
    doc["accessors"][0]["sparse"]["count"] = json!(1u64 << 62);
    assert_eq!(refused(&doc, &bin).pointer, "/accessors/0/sparse/count");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn strided_and_normalized_data_is_decoded() {
    let (mut doc, mut bin) = base();
    // Interleaved: position (3 floats) + 4 bytes of padding per vertex, stride 16.
    let mut interleaved = Vec::new();
    for p in [[0.0f32, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]] {
        interleaved.extend(f32s(&p));
        interleaved.extend([0xAA; 4]);
    }
    let v = add_view(&mut doc, &mut bin, &interleaved, Some(16));
    doc["accessors"][0] = json!({"bufferView": v, "componentType": 5126, "count": 3, "type": "VEC3"});
    // Normalized shorts and bytes for UVs.
    let uv: Vec<u8> = [32767i16, -32768, 0, 16384, 0, 0].iter().flat_map(|x| x.to_le_bytes()).collect();
    let uvv = add_view(&mut doc, &mut bin, &uv, None);
    let uva = add_accessor(
        &mut doc,
        json!({"bufferView": uvv, "componentType": 5122, "normalized": true, "count": 3, "type": "VEC2"}),
    );
    doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uva);
    let colors = add_view(&mut doc, &mut bin, &[255, 0, 51, 255, 0, 0, 0, 0, 255, 255, 255, 255], None);
    let ca = add_accessor(
        &mut doc,
        json!({"bufferView": colors, "componentType": 5121, "normalized": true, "count": 3, "type": "VEC4"}),
    );
    doc["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = json!(ca);
    let p = run(&doc, &bin).expect("valid").asset.meshes[0].primitives[0].clone();
    assert_eq!(p.positions, [[0.0; 3], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]);
    assert_eq!(p.uv0[0], [1.0, -1.0]);
    assert!((p.uv0[1][1] - 16384.0 / 32767.0).abs() < 1e-7);
    assert_eq!(p.colors[0], [1.0, 0.0, 0.2, 1.0]);
    // A stride smaller than the element is refused.
    doc["bufferViews"][v]["byteStride"] = json!(8);
    assert_eq!(refused(&doc, &bin).pointer, "/accessors/0");
    doc["bufferViews"][v]["byteStride"] = json!(6);
    assert_eq!(refused(&doc, &bin).pointer, format!("/bufferViews/{v}/byteStride"));
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn strips_fans_and_loops_become_lists() {
    let (mut doc, bin) = base();
    let prim = &mut doc["meshes"][0]["primitives"][0];
    prim.as_object_mut().expect("prim").remove("indices");
    prim["mode"] = json!(5);
    let a = run(&doc, &bin).expect("strip").asset;
    assert_eq!(a.meshes[0].primitives[0].indices, [0, 1, 2]);
    doc["accessors"][0]["count"] = json!(3);
    // Four vertices via a longer position view.
    let (mut doc, mut bin) = base();
    let v = add_view(&mut doc, &mut bin, &f32s(&[0.0; 12]), None);
    doc["accessors"][0] = json!({"bufferView": v, "componentType": 5126, "count": 4, "type": "VEC3"});
    let prim = &mut doc["meshes"][0]["primitives"][0];
    prim.as_object_mut().expect("prim").remove("indices");
    for (mode, topology, expected) in [
        (5, crate::asset::Topology::Triangles, vec![0, 1, 2, 1, 3, 2]),
        (6, crate::asset::Topology::Triangles, vec![1, 2, 0, 2, 3, 0]),
        (2, crate::asset::Topology::Lines, vec![0, 1, 1, 2, 2, 3, 3, 0]),
        (3, crate::asset::Topology::Lines, vec![0, 1, 1, 2, 2, 3]),
        (0, crate::asset::Topology::Points, vec![0, 1, 2, 3]),
    ] {
        doc["meshes"][0]["primitives"][0]["mode"] = json!(mode);
        let p = run(&doc, &bin).expect("valid").asset.meshes[0].primitives[0].clone();
        assert_eq!((p.topology, p.indices), (topology, expected), "mode {mode}");
    }
    doc["meshes"][0]["primitives"][0]["mode"] = json!(4);
    let imported = run(&doc, &bin).expect("valid");
    assert_eq!(imported.asset.meshes[0].primitives[0].indices, [0, 1, 2], "incomplete triangle dropped");
    assert_eq!(imported.warnings.len(), 1);
    doc["meshes"][0]["primitives"][0]["mode"] = json!(7);
    assert_eq!(refused(&doc, &bin).pointer, "/meshes/0/primitives/0/mode");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn node_transforms_are_decomposed_and_repaired() {
    let (mut doc, bin) = base();
    let m = crate::math::Mat4::from_scale_rotation_translation(
        crate::math::Vec3::new(1.0, 2.0, 3.0),
        crate::math::Quat::from_rotation_x(0.5),
        crate::math::Vec3::new(4.0, 5.0, 6.0),
    );
    doc["nodes"] = json!([
        {"mesh": 0, "matrix": m.to_cols_array()},
        {"matrix": vec![0.0; 16]},
        {"rotation": [0.0, 0.0, 0.0, 2.0]},
        {"rotation": [0.0, 0.0, 0.0, 0.0]}
    ]);
    doc["scenes"] = json!([{"nodes": [0, 1, 2, 3]}]);
    let imported = run(&doc, &bin).expect("repaired");
    let nodes = &imported.asset.nodes;
    assert!(nodes[0].rest.to_mat4().abs_diff_eq(m, 1e-5));
    assert_eq!(nodes[1].rest, crate::math::Transform::IDENTITY);
    assert_eq!(nodes[2].rest.rotation, crate::math::Quat::IDENTITY);
    assert_eq!(nodes[3].rest.rotation, crate::math::Quat::IDENTITY);
    let pointers: Vec<_> = imported.warnings.iter().map(|w| w.pointer.as_str()).collect();
    // Node 0 is animated by the base document's clip, and given by a matrix.
    assert_eq!(
        pointers,
        ["/nodes/1/matrix", "/nodes/2/rotation", "/nodes/3/rotation", "/animations/0/channels/0/target/node"]
    );
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn morph_targets_weights_and_names() {
    let (mut doc, mut bin) = base();
    let dv = add_view(&mut doc, &mut bin, &f32s(&[0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0, 3.0]), None);
    let d = add_accessor(&mut doc, json!({"bufferView": dv, "componentType": 5126, "count": 3, "type": "VEC3"}));
    doc["meshes"][0]["primitives"][0]["targets"] = json!([{"POSITION": d}, {"NORMAL": d}]);
    doc["meshes"][0]["weights"] = json!([0.25, 0.5]);
    doc["meshes"][0]["extras"] = json!({"targetNames": ["up", "tilt"]});
    doc["nodes"] = json!([{"mesh": 0, "weights": [1.0, 0.0]}, {"mesh": 0}, {"mesh": 0, "weights": [1.0]}]);
    doc["scenes"] = json!([{"nodes": [0, 1, 2]}]);
    let imported = run(&doc, &bin).expect("valid");
    let a = &imported.asset;
    assert_eq!(a.meshes[0].target_names, ["up", "tilt"]);
    assert_eq!(a.meshes[0].primitives[0].targets[0].positions[2], [0.0, 0.0, 3.0]);
    assert!(a.meshes[0].primitives[0].targets[0].normals.is_empty());
    assert_eq!(a.nodes[0].weights, [1.0, 0.0]);
    assert_eq!(a.nodes[1].weights, [0.25, 0.5]);
    assert_eq!(a.nodes[2].weights, [0.25, 0.5], "wrong-length node weights fall back to the mesh's");
    assert_eq!(a.weight_offsets, [0, 2, 4]);
    assert_eq!(a.weight_total, 6);
    // Node 2's weights, and target 1's NORMAL on a primitive without normals.
    let pointers: Vec<_> = imported.warnings.iter().map(|w| w.pointer.as_str()).collect();
    assert_eq!(pointers, ["/meshes/0/primitives/0/targets/1/NORMAL", "/nodes/2/weights"]);
    doc["meshes"][0]["weights"] = json!([0.25]);
    assert_eq!(refused(&doc, &bin).pointer, "/meshes/0/weights");
}

/// An image file of `width` × `height` pixels in `format`, made by the `image` crate.
fn image_file(width: u32, height: u32, format: image::ImageFormat) -> Vec<u8> {
    let mut bytes = Vec::new();
    image::RgbImage::from_fn(width, height, |x, y| image::Rgb([(x * 40 % 256) as u8, (y * 60 % 256) as u8, 200]))
        .write_to(&mut std::io::Cursor::new(&mut bytes), format)
        .expect("encode");
    bytes
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn images_kept_encoded_have_their_header_size_and_file_bytes() {
    let (mut doc, mut bin) = base();
    let png = image_file(5, 3, image::ImageFormat::Png);
    let jpeg = image_file(7, 2, image::ImageFormat::Jpeg);
    let a = add_view(&mut doc, &mut bin, &png, None);
    let b = add_view(&mut doc, &mut bin, &jpeg, None);
    let garbage = add_view(&mut doc, &mut bin, b"GIF89a not one of ours", None);
    // A header claiming more pixels than the budget holds: refused before anything is allocated.
    let mut huge = png[..24].to_vec();
    huge[16..24].copy_from_slice(&[0, 1, 0, 0, 0, 1, 0, 0]);
    let huge = add_view(&mut doc, &mut bin, &huge, None);
    doc["images"] = json!([{"bufferView": a, "mimeType": "image/png"}, {"bufferView": b, "mimeType": "image/jpeg"},
        {"bufferView": garbage, "mimeType": "image/png"}, {"bufferView": huge, "mimeType": "image/png"}]);
    doc["textures"] = json!([{"source": 0}, {"source": 1}, {"source": 2}]);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
        {"pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}},
        {"pbrMetallicRoughness": {"baseColorTexture": {"index": 2}}}]);
    let options = ImportOptions { decode_images: false, ..ImportOptions::default() };
    let imported = import(&glb_of(&doc, &bin), &NoResolver, &options).expect("imported");
    let images = &imported.asset.images;
    let encoded = |i: usize| images[i].encoded.as_ref().map(|e| (e.format, e.bytes.as_slice()));
    assert_eq!((images[0].width, images[0].height, images[0].rgba8.len()), (5, 3, 0));
    assert_eq!(encoded(0), Some((crate::asset::ImageFormat::Png, png.as_slice())));
    assert_eq!((images[1].width, images[1].height), (7, 2));
    assert_eq!(encoded(1), Some((crate::asset::ImageFormat::Jpeg, jpeg.as_slice())));
    let pointers: Vec<&str> = imported.warnings.iter().map(|w| w.pointer.as_str()).collect();
    assert_eq!(pointers, ["/images/2", "/images/3"], "{:?}", imported.warnings);
    assert!(imported.warnings[1].message.contains("65536×65536"), "{}", imported.warnings[1].message);
    assert!(images[2..].iter().all(|i| i.encoded.is_none() && i.rgba8 == [255; 4]));
    let textured: Vec<bool> = imported.asset.materials.iter().map(|m| m.base_color_texture.is_some()).collect();
    assert_eq!(textured, [true, true, false]);
    // Decoded, the same file gives the same size.
    let decoded = run(&doc, &bin).expect("imported");
    assert_eq!((decoded.asset.images[1].width, decoded.asset.images[1].height), (7, 2));
    assert!(decoded.asset.images[1].encoded.is_none());
}

#[test]
fn image_headers_are_read_without_trusting_them() {
    use super::material::header;
    use crate::asset::ImageFormat::{Jpeg, Png};
    let png = image_file(300, 20, image::ImageFormat::Png);
    assert_eq!(header(&png), Some((Png, 300, 20)));
    for cut in 0..24 {
        assert_eq!(header(&png[..cut]), None, "PNG cut at {cut}");
    }
    let jpeg = image_file(33, 17, image::ImageFormat::Jpeg);
    assert_eq!(header(&jpeg), Some((Jpeg, 33, 17)));
    // Every prefix of the file is answered without a panic; those cut before the frame header by None.
    let sof = jpeg.windows(2).position(|w| w == [0xFF, 0xC0]).expect("a baseline frame header");
    for cut in 0..jpeg.len() {
        let read = header(&jpeg[..cut]);
        assert_eq!(read.is_some(), cut >= sof + 9, "JPEG cut at {cut}");
    }
    // A progressive frame after fill bytes and a table; segments with absurd lengths end the search.
    let progressive = [0xFF, 0xD8, 0xFF, 0xC4, 0, 3, 9, 0xFF, 0xFF, 0xC2, 0, 11, 8, 0, 40, 1, 44, 3];
    assert_eq!(header(&progressive), Some((Jpeg, 300, 40)));
    assert_eq!(header(&[0xFF, 0xD8, 0xFF, 0xE0, 0xFF, 0xFF]), None);
    assert_eq!(header(&[0xFF, 0xD8, 0xFF, 0xDA, 0, 2]), None);
    assert_eq!(header(b"GIF89a"), None);
}

#[test]
fn webp_headers_give_their_size() {
    use super::material::header;
    use crate::asset::ImageFormat::Webp;
    // Lossless, as the `image` crate writes it.
    let lossless = image_file(300, 17, image::ImageFormat::WebP);
    assert_eq!(header(&lossless), Some((Webp, 300, 17)));
    for cut in 0..25 {
        assert_eq!(header(&lossless[..cut]), None, "WebP cut at {cut}");
    }
    // Lossy: a key frame's start code, then 14-bit width and height (the scale bits above are not size).
    let mut lossy = b"RIFF\0\0\0\0WEBPVP8 \0\0\0\0\0\0\0\x9d\x01\x2a".to_vec();
    lossy.extend([0x20, 0x43, 0x10, 0x00]); // 800 | scale 1 << 14, 16
    assert_eq!(header(&lossy), Some((Webp, 800, 16)));
    lossy[23] = 0;
    assert_eq!(header(&lossy), None, "no start code");
    // Extended: the canvas size minus one in 24 bits each.
    let mut extended = b"RIFF\0\0\0\0WEBPVP8X\0\0\0\0\x10\0\0\0".to_vec();
    extended.extend([0xFF, 0x0F, 0x00, 0x01, 0x00, 0x01]);
    assert_eq!(header(&extended), Some((Webp, 4096, 65538)));
    assert_eq!(header(b"RIFF\0\0\0\0WEBPVP9 \0\0\0\0"), None);
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn webp_textures_are_preferred_with_their_fallback_for_when_they_cannot_be_read() {
    let (mut doc, mut bin) = base();
    let png = image_file(2, 2, image::ImageFormat::Png);
    let webp = image_file(4, 3, image::ImageFormat::WebP);
    let views =
        [&png[..], &webp[..], &b"RIFF\0\0\0\0WEBPVP8L broken"[..]].map(|b| add_view(&mut doc, &mut bin, b, None));
    doc["extensionsUsed"] = json!(["EXT_texture_webp"]);
    doc["extensionsRequired"] = json!(["EXT_texture_webp"]);
    doc["images"] = json!([{"bufferView": views[0], "mimeType": "image/png"},
        {"bufferView": views[1], "mimeType": "image/webp"}, {"bufferView": views[2], "mimeType": "image/webp"}]);
    doc["textures"] = json!([
        {"source": 0, "extensions": {"EXT_texture_webp": {"source": 1}}},
        {"source": 0, "extensions": {"EXT_texture_webp": {"source": 2}}},
        {"extensions": {"EXT_texture_webp": {"source": 1}}},
    ]);
    doc["materials"] =
        Value::Array((0..3).map(|t| json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": t}}})).collect());
    let textured = |imported: &Imported| -> Vec<Option<u32>> {
        imported.asset.materials.iter().map(|m| m.base_color_texture.map(|t| t.image)).collect()
    };
    // Decoded: the WebP's pixels; the broken one warned about and replaced by the PNG fallback.
    let decoded = run(&doc, &bin).expect("imported");
    assert_eq!(textured(&decoded), [Some(1), Some(0), Some(1)]);
    let extensions = &decoded.asset.extensions;
    assert_eq!(
        (extensions.used.as_slice(), extensions.required.as_slice()),
        (&["EXT_texture_webp".to_owned()][..], &["EXT_texture_webp".to_owned()][..])
    );
    let image = &decoded.asset.images[1];
    assert_eq!((image.width, image.height, image.rgba8.len()), (4, 3, 48));
    assert_eq!(&image.rgba8[4..8], [40, 0, 200, 255]);
    assert_eq!(decoded.warnings.iter().map(|w| w.pointer.as_str()).collect::<Vec<_>>(), ["/images/2"]);
    // Kept encoded: the same choice, the file's format and size from its header.
    let options = ImportOptions { decode_images: false, ..ImportOptions::default() };
    let encoded = import(&glb_of(&doc, &bin), &NoResolver, &options).expect("imported");
    assert_eq!(textured(&encoded), [Some(1), Some(0), Some(1)]);
    let image = &encoded.asset.images[1];
    assert_eq!((image.width, image.height), (4, 3));
    assert_eq!(
        image.encoded.as_ref().map(|e| (e.format, e.format.mime())),
        Some((crate::asset::ImageFormat::Webp, "image/webp"))
    );
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn undecodable_images_are_skipped_with_a_warning() {
    let (mut doc, mut bin) = base();
    let garbage = add_view(&mut doc, &mut bin, b"\x89PNG\r\n\x1a\nnot really a png", None);
    let mut png = Vec::new();
    image::RgbaImage::from_pixel(2, 1, image::Rgba([10, 20, 30, 255]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .expect("encode");
    let good = add_view(&mut doc, &mut bin, &png, None);
    doc["images"] =
        json!([{"bufferView": garbage, "mimeType": "image/png"}, {"bufferView": good, "mimeType": "image/png"}]);
    doc["textures"] = json!([{"source": 0}, {"source": 1, "sampler": 0}]);
    doc["samplers"] = json!([{"wrapS": 33071, "magFilter": 9728}]);
    doc["materials"] = json!([
        {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
        {"pbrMetallicRoughness": {"baseColorFactor": [1, 0.5, 0.25, 1], "baseColorTexture": {"index": 1,
            "extensions": {"KHR_texture_transform": {"offset": [0.5, 0], "scale": [2, 2], "texCoord": 0}}}},
         "alphaMode": "MASK", "alphaCutoff": 0.3, "doubleSided": true, "extensions": {"KHR_materials_unlit": {}}}
    ]);
    let imported = run(&doc, &bin).expect("image skipped");
    assert_eq!(imported.warnings.len(), 1, "{:?}", imported.warnings);
    // Kept encoded, the bad file is found by its header, the good one kept.
    let options = ImportOptions { decode_images: false, ..ImportOptions::default() };
    let encoded = import(&glb_of(&doc, &bin), &NoResolver, &options).expect("image skipped");
    assert_eq!(encoded.warnings.iter().map(|w| w.pointer.as_str()).collect::<Vec<_>>(), ["/images/0"]);
    assert!(encoded.asset.images[1].encoded.is_some() && encoded.asset.materials[1].base_color_texture.is_some());
    assert_eq!(imported.warnings[0].pointer, "/images/0");
    let a = &imported.asset;
    assert_eq!((a.images[0].width, a.images[0].height), (1, 1));
    assert_eq!(a.images[1].rgba8, [10, 20, 30, 255, 10, 20, 30, 255]);
    assert!(a.materials[0].base_color_texture.is_none());
    let m = &a.materials[1];
    let t = m.base_color_texture.expect("texture");
    assert_eq!((t.image, t.repeat, t.nearest), (1, [false, true], true));
    assert_eq!((t.transform.offset, t.transform.scale), ([0.5, 0.0], [2.0, 2.0]));
    assert_eq!(m.base_color, [1.0, 0.5, 0.25, 1.0]);
    assert_eq!((m.alpha, m.double_sided, m.unlit), (crate::asset::AlphaMode::Mask(0.3), true, true));
    // References that resolve to nothing: reported where they are, the texture left out (or
    // drawn with the default sampler), the model still shown.
    doc["textures"][0]["source"] = json!(5);
    doc["textures"][1]["sampler"] = json!(3);
    doc["materials"][0]["emissiveTexture"] = json!({"index": 9});
    doc["materials"][0]["pbrMetallicRoughness"]["metallicRoughnessTexture"] = json!({"index": 1});
    let imported = run(&doc, &bin).expect("dangling references are warnings");
    let pointers: Vec<&str> = imported.warnings.iter().map(|w| w.pointer.as_str()).collect();
    assert_eq!(
        pointers,
        ["/images/0", "/textures/0/source", "/textures/1/sampler", "/materials/0/emissiveTexture/index"],
        "{:?}",
        imported.warnings
    );
    assert!(imported.warnings[1].message.contains("image index 5 is out of range"), "{:?}", imported.warnings[1]);
    assert!(imported.asset.materials[0].base_color_texture.is_none());
    let t = imported.asset.materials[1].base_color_texture.expect("drawn with the default sampler");
    assert_eq!((t.image, t.repeat, t.nearest), (1, [true, true], false));
    // A second texture coordinate set is drawn; a third is not: drawn with the first, and said so.
    doc["materials"][0]["emissiveTexture"] = json!({"index": 1});
    let transform = "/materials/1/pbrMetallicRoughness/baseColorTexture/extensions/KHR_texture_transform/texCoord";
    *doc.pointer_mut(transform).expect("the transform") = json!(1);
    let imported = run(&doc, &bin).expect("drawn with TEXCOORD_1");
    assert!(!imported.warnings.iter().any(|w| w.pointer.ends_with("texCoord")), "{:?}", imported.warnings);
    assert_eq!(imported.asset.materials[1].base_color_texture.map(|t| t.tex_coord), Some(1));
    *doc.pointer_mut(transform).expect("the transform") = json!(2);
    let imported = run(&doc, &bin).expect("drawn with TEXCOORD_0");
    assert!(
        imported.warnings.iter().any(|w| w.pointer == "/materials/1/pbrMetallicRoughness/baseColorTexture/texCoord"),
        "{:?}",
        imported.warnings
    );
    assert_eq!(imported.asset.materials[1].base_color_texture.map(|t| t.tex_coord), Some(0));
    // A textureInfo without its index is refused.
    doc["materials"][0]["emissiveTexture"] = json!({"texCoord": 0});
    assert_eq!(refused(&doc, &bin).pointer, "/materials/0/emissiveTexture/index");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn every_core_texture_of_a_material_is_read_with_its_factors() {
    let (mut doc, mut bin) = base();
    let mut png = Vec::new();
    image::RgbaImage::from_pixel(1, 1, image::Rgba([128, 128, 255, 255]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .expect("encode");
    let view = add_view(&mut doc, &mut bin, &png, None);
    let uv1 = add_view(&mut doc, &mut bin, &f32s(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]), None);
    let uv1 = add_accessor(&mut doc, json!({"bufferView": uv1, "componentType": 5126, "count": 3, "type": "VEC2"}));
    doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"] = json!(uv1);
    let normals = add_view(&mut doc, &mut bin, &f32s(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0]), None);
    let normals =
        add_accessor(&mut doc, json!({"bufferView": normals, "componentType": 5126, "count": 3, "type": "VEC3"}));
    doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(normals);
    let uv0 = add_view(&mut doc, &mut bin, &f32s(&[0.0, 1.0, 1.0, 1.0, 0.0, 0.0]), None);
    let uv0 = add_accessor(&mut doc, json!({"bufferView": uv0, "componentType": 5126, "count": 3, "type": "VEC2"}));
    doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv0);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["images"] = json!([{"bufferView": view, "mimeType": "image/png"}]);
    doc["textures"] = json!([{"source": 0, "sampler": 0}]);
    doc["samplers"] = json!([{"minFilter": 9986}]);
    doc["materials"] = json!([{
        "pbrMetallicRoughness": {"metallicFactor": 0.25, "roughnessFactor": 0.75,
            "baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 0, "texCoord": 1}},
        "normalTexture": {"index": 0, "scale": 0.5, "extensions": {"KHR_texture_transform": {"rotation": 1.5}}},
        "occlusionTexture": {"index": 0, "strength": 0.25, "texCoord": 1},
        "emissiveTexture": {"index": 0},
        "emissiveFactor": [1, 0.5, 0],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}
    }]);
    let imported = run(&doc, &bin).expect("a full material");
    assert!(imported.warnings.is_empty(), "{:?}", imported.warnings);
    let m = &imported.asset.materials[0];
    assert_eq!((m.metallic, m.roughness), (0.25, 0.75));
    assert_eq!(m.metallic_roughness_texture.map(|t| (t.image, t.tex_coord)), Some((0, 1)));
    assert_eq!(m.normal_texture.map(|t| t.transform.rotation), Some(1.5));
    // No TANGENT: MikkTSpace's, in the frame of the coordinates the normal map is sampled at
    // (TEXCOORD_0 turned by its transform), not of the bare TEXCOORD_0.
    let p = &imported.asset.meshes[0].primitives[0];
    let mut bare = p.clone();
    bare.tangents.clear();
    let mut turned = bare.clone();
    assert!(crate::import::tangents::generate(&mut bare, 0, &Default::default()));
    let transform = m.normal_texture.map(|t| t.transform).unwrap_or_default();
    assert!(crate::import::tangents::generate(&mut turned, 0, &transform));
    assert_eq!(p.tangents, turned.tangents);
    assert_ne!(p.tangents, bare.tangents);
    assert_eq!((m.normal_scale, m.occlusion_strength), (0.5, 0.25));
    assert_eq!(m.occlusion_texture.map(|t| t.tex_coord), Some(1));
    assert!(m.base_color_texture.is_some() && m.emissive_texture.is_some());
    assert_eq!((m.emissive, m.emissive_strength), ([1.0, 0.5, 0.0], 4.0));
    assert_eq!(imported.asset.meshes[0].primitives[0].uv1, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
    assert_eq!(m.base_color_texture.map(|t| t.min_filter), Some(crate::asset::MinFilter::NearestMipmapLinear));
    // Not a glTF filter: reported, and trilinear.
    doc["samplers"][0]["minFilter"] = json!(1234);
    let imported = run(&doc, &bin).expect("a bad filter is a warning");
    assert_eq!(imported.warnings.iter().map(|w| w.pointer.as_str()).collect::<Vec<_>>(), ["/samplers/0/minFilter"]);
    let t = imported.asset.materials[0].base_color_texture.expect("drawn");
    assert_eq!(t.min_filter, crate::asset::MinFilter::LinearMipmapLinear);
    doc["samplers"][0]["minFilter"] = json!(9986);
    // Out of range: an occlusion strength above 1, a negative emissive strength, each clamped
    // and reported where it is.
    doc["materials"][0]["occlusionTexture"]["strength"] = json!(3);
    doc["materials"][0]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] = json!(-1);
    let imported = run(&doc, &bin).expect("clamped");
    let pointers: Vec<&str> = imported.warnings.iter().map(|w| w.pointer.as_str()).collect();
    assert_eq!(
        pointers,
        [
            "/materials/0/occlusionTexture/strength",
            "/materials/0/extensions/KHR_materials_emissive_strength/emissiveStrength"
        ]
    );
    let m = &imported.asset.materials[0];
    assert_eq!((m.occlusion_strength, m.emissive_strength), (1.0, 0.0));
    // The defaults: no textures, unit scale and strengths.
    let plain = crate::asset::Material::default();
    assert_eq!((plain.normal_scale, plain.occlusion_strength, plain.emissive_strength), (1.0, 1.0, 1.0));
    assert!(plain.normal_texture.is_none() && plain.occlusion_texture.is_none() && plain.emissive_texture.is_none());
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn map_resolver_finds_files_by_path_then_name() {
    let mut r = MapResolver::new();
    r.insert("textures/a b.png", vec![1]);
    r.insert("x.bin", vec![2]);
    assert_eq!(r.resolve("textures/a%20b.png"), Ok(vec![1]));
    assert_eq!(r.resolve("./textures/../textures/a b.png"), Ok(vec![1]));
    assert_eq!(r.resolve("buffers/x.bin"), Ok(vec![2]));
    assert!(r.resolve("y.bin").is_err());
    r.insert("other/x.bin", vec![3]);
    assert_eq!(r.resolve("x.bin"), Ok(vec![2]), "an exact path wins");
    assert!(r.resolve("elsewhere/x.bin").is_err(), "ambiguous by name");
    assert!(NoResolver.resolve("x.bin").is_err());
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn integers_written_as_floats_are_read() {
    let (mut doc, bin) = base();
    doc["bufferViews"][0]["byteLength"] = json!(36.0);
    doc["accessors"][0]["count"] = json!(3.0);
    doc["scenes"][0]["nodes"] = json!([0.0]);
    let imported = run(&doc, &bin).expect("1.0 is the integer 1");
    assert_eq!(imported.asset.meshes[0].primitives[0].positions.len(), 3);
    doc["accessors"][0]["count"] = json!(2.5);
    assert_eq!(refused(&doc, &bin).pointer, "/accessors/0/count");
    doc["accessors"][0]["count"] = json!(-3.0);
    assert_eq!(refused(&doc, &bin).pointer, "/accessors/0/count");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn defects_that_change_what_is_shown_are_warnings() {
    // A node with a matrix and TRS: the matrix is used.
    let (mut doc, mut bin) = base();
    doc["nodes"]
        .as_array_mut()
        .expect("nodes")
        .push(json!({"matrix": [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1], "translation": [5, 0, 0]}));
    // A CUBICSPLINE sampler with one key (in, value, out tangents).
    let time = add_view(&mut doc, &mut bin, &f32s(&[0.0]), None);
    let values = add_view(&mut doc, &mut bin, &f32s(&[0.0; 9]), None);
    let input =
        add_accessor(&mut doc, json!({"bufferView": time, "componentType": 5126, "count": 1, "type": "SCALAR"}));
    let output =
        add_accessor(&mut doc, json!({"bufferView": values, "componentType": 5126, "count": 3, "type": "VEC3"}));
    doc["animations"].as_array_mut().expect("animations").push(json!({
        "samplers": [{"input": input, "output": output, "interpolation": "CUBICSPLINE"}],
        "channels": [{"sampler": 0, "target": {"node": 2, "path": "scale"}}]
    }));
    // A skin on a node whose mesh has no joints or weights (its joint is what the spline moves).
    doc["nodes"][0]["skin"] = json!(0);
    doc["nodes"].as_array_mut().expect("nodes").push(json!({"name": "joint"}));
    doc["skins"] = json!([{"joints": [2]}]);
    let imported = run(&doc, &bin).expect("warnings, not errors");
    let pointers: Vec<&str> = imported.warnings.iter().map(|w| w.pointer.as_str()).collect();
    assert_eq!(pointers, ["/nodes/1", "/nodes/0/skin", "/animations/1/samplers/0"], "{:?}", imported.warnings);
    assert!(imported.warnings[0].message.contains("matrix is used"), "{:?}", imported.warnings[0]);
    assert_eq!(imported.asset.nodes[1].rest.scale, glam::Vec3::splat(2.0));
    assert_eq!(imported.asset.nodes[1].rest.translation, glam::Vec3::ZERO);
    assert!(imported.warnings[2].message.contains("at least 2 keyframes"), "{:?}", imported.warnings[2]);
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn a_matrix_accessor_needs_no_padding_after_its_last_column() {
    // MAT2 of bytes: each column is 2 bytes padded to 4, so an element takes 8 bytes, but the last
    // element of the view needs only 6 (its last column's padding may be missing).
    let bytes = vec![1u8, 2, 0, 0, 3, 4, 0, 0, 5, 6, 0, 0, 7, 8];
    let doc = json!({
        "bufferViews": [{"buffer": 0, "byteLength": 14}],
        "accessors": [{"bufferView": 0, "componentType": 5121, "count": 2, "type": "MAT2"}]
    });
    let (values, components) = with_accessors(&doc, bytes, |accessors, budget| accessors.read_flat(0, budget))
        .expect("the view holds both elements")
        .expect("read");
    assert_eq!(components, 4);
    assert_eq!(values, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
    // One byte fewer and the last column does not fit.
    let doc = json!({
        "bufferViews": [{"buffer": 0, "byteLength": 13}],
        "accessors": [{"bufferView": 0, "componentType": 5121, "count": 2, "type": "MAT2"}]
    });
    let short = with_accessors(&doc, vec![0; 14], |short, budget| short.read_flat(0, budget).err().map(|e| e.pointer))
        .expect("refused where it is read");
    assert_eq!(short, Some("/accessors/0".to_owned()));
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn a_broken_accessor_is_refused_only_where_it_is_read() {
    let (mut doc, bin) = base();
    let broken =
        add_accessor(&mut doc, json!({"bufferView": 0, "componentType": 5126, "count": 3, "type": "NotaVEC3"}));
    let imported = run(&doc, &bin).expect("nothing reads it");
    assert!(imported.warnings.is_empty(), "{:?}", imported.warnings);
    doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(broken);
    let e = refused(&doc, &bin);
    assert_eq!(e.pointer, format!("/accessors/{broken}/type"));
    assert!(e.message.contains("not a valid accessor type"), "{e:?}");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn colours_outside_their_range_and_targets_without_a_base_are_warnings() {
    let (mut doc, mut bin) = base();
    let colors = add_view(&mut doc, &mut bin, &f32s(&[1.5, 0.5, -0.25, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0]), None);
    let color =
        add_accessor(&mut doc, json!({"bufferView": colors, "componentType": 5126, "count": 3, "type": "VEC3"}));
    let deltas = add_view(&mut doc, &mut bin, &f32s(&[0.0; 9]), None);
    let delta =
        add_accessor(&mut doc, json!({"bufferView": deltas, "componentType": 5126, "count": 3, "type": "VEC3"}));
    doc["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = json!(color);
    doc["meshes"][0]["primitives"][0]["targets"] = json!([{"POSITION": delta, "NORMAL": delta}]);
    let imported = run(&doc, &bin).expect("warnings");
    let pointers: Vec<&str> = imported.warnings.iter().map(|w| w.pointer.as_str()).collect();
    assert_eq!(
        pointers,
        ["/meshes/0/primitives/0/attributes/COLOR_0", "/meshes/0/primitives/0/targets/0/NORMAL"],
        "{:?}",
        imported.warnings
    );
    let p = &imported.asset.meshes[0].primitives[0];
    assert_eq!(p.colors[0], [1.0, 0.5, 0.0, 1.0]);
    assert!(p.targets[0].normals.is_empty() && p.targets[0].positions.len() == 3);
}

/// `tests/optimized/NAME` (gltfpack's copies of the shared characters; scripts/make-optimized.sh).
#[cfg(not(target_arch = "wasm32"))]
fn optimized(name: &str) -> Result<Imported, ImportError> {
    import_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/optimized").join(name))
}

/// Whether two imports of one model hold the same meshes and clips, within `tolerance` of the
/// model's size for positions and 3 × `tolerance` for unit quantities (normals, rotations,
/// weights: an 8-bit octahedral normal is within ~0.02 of its 16-bit twin). Vertices
/// and triangles are compared in any order (encoders reorder them for their caches), each
/// triangle keeping its winding.
#[cfg(not(target_arch = "wasm32"))]
fn assert_same_model(a: &Asset, b: &Asset, tolerance: f32, what: &str) {
    // Vertices by position and uv (exact: both files quantize them alike): normal, joints, weights.
    let vertices = |p: &crate::asset::Primitive| {
        let mut map: std::collections::HashMap<Vec<u32>, Vec<Vec<f32>>> = std::collections::HashMap::new();
        for i in 0..p.positions.len() {
            let mut key: Vec<u32> = p.positions[i].map(f32::to_bits).to_vec();
            key.extend(p.uv0.get(i).map_or(Vec::new(), |x| x.map(f32::to_bits).to_vec()));
            let mut rest = p.normals.get(i).map_or(Vec::new(), |x| x.to_vec());
            rest.extend(p.joints.get(i).map_or(Vec::new(), |j| j.iter().map(|&x| f32::from(x)).collect()));
            rest.extend(p.weights.get(i).map_or(&[][..], |x| &x[..]));
            map.entry(key).or_default().push(rest);
        }
        map
    };
    // Each triangle as its corners' positions, starting at the least, in a sorted list.
    let triangles = |p: &crate::asset::Primitive| -> Vec<[[u32; 3]; 3]> {
        let corner = |i: u32| p.positions[i as usize].map(f32::to_bits);
        let mut list: Vec<[[u32; 3]; 3]> = p
            .indices
            .chunks_exact(3)
            .map(|t| {
                let mut t = [corner(t[0]), corner(t[1]), corner(t[2])];
                let least = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
                t.rotate_left(least);
                t
            })
            .collect();
        list.sort();
        list
    };
    assert_eq!(a.meshes.len(), b.meshes.len(), "{what}: meshes");
    for (m, (ma, mb)) in a.meshes.iter().zip(&b.meshes).enumerate() {
        assert_eq!(ma.primitives.len(), mb.primitives.len(), "{what}: mesh {m}");
        for (p, (pa, pb)) in ma.primitives.iter().zip(&mb.primitives).enumerate() {
            let at = format!("{what}: mesh {m} primitive {p}");
            assert_eq!(triangles(pa), triangles(pb), "{at}: triangles");
            let (va, vb) = (vertices(pa), vertices(pb));
            assert_eq!(pa.positions.len(), pb.positions.len(), "{at}: vertices");
            for (key, list) in &va {
                let twins = vb.get(key).unwrap_or_else(|| panic!("{at}: no vertex at {key:?}"));
                assert_eq!(list.len(), twins.len(), "{at}: vertices at {key:?}");
                for x in list {
                    let close = |y: &Vec<f32>| {
                        x.len() == y.len() && x.iter().zip(y).all(|(u, v)| (u - v).abs() <= 3.0 * tolerance)
                    };
                    assert!(twins.iter().any(close), "{at}: vertex {x:?} against {twins:?}");
                }
            }
            assert_eq!(pa.targets.len(), pb.targets.len(), "{at}: targets");
        }
    }
    assert_eq!(a.clips.len(), b.clips.len(), "{what}: clips");
    for (ca, cb) in a.clips.iter().zip(&b.clips) {
        assert_eq!(ca.channels().len(), cb.channels().len(), "{what}: clip {:?}", ca.name);
        for (ha, hb) in ca.channels().iter().zip(cb.channels()) {
            assert_eq!((ha.node, ha.target, ha.times.len()), (hb.node, hb.target, hb.times.len()), "{what}: channel");
            let times = ha.times.iter().zip(&hb.times).all(|(u, v)| (u - v).abs() <= 1e-4);
            // A quaternion and its negation are one rotation; translations scale with the model.
            let scale = if ha.target == ChannelTarget::Rotation { 3.0 } else { 100.0 };
            let values = ha.values.chunks(ha.width as usize).zip(hb.values.chunks(hb.width as usize)).all(|(u, v)| {
                let same = u.iter().zip(v).all(|(x, y)| (x - y).abs() <= tolerance * scale);
                let negated = u.iter().zip(v).all(|(x, y)| (x + y).abs() <= tolerance * scale);
                same || (ha.target == ChannelTarget::Rotation && negated)
            });
            assert!(times && values, "{what}: clip {:?} node {} {:?}", ca.name, ha.node, ha.target);
        }
    }
}

#[cfg(not(target_arch = "wasm32"))] // reads tests/optimized from disk
#[test]
fn meshopt_compressed_files_decode_to_their_quantized_twins() {
    // `-c`: the same quantized data, compressed without filters: identical once decoded.
    let plain = optimized("Fox.gltfpack.glb").expect("quantized").asset;
    let compressed = optimized("Fox.gltfpack-c.glb").expect("EXT_meshopt_compression").asset;
    assert_same_model(&plain, &compressed, 0.0, "Fox -c");
    // `-cc`: filters re-encode normals (octahedral), rotations (quaternion) and translations and
    // scales (exponential) with fewer bits: the same within their precision.
    for model in ["Fox", "CesiumMan", "RobotExpressive", "AnimatedMorphCube"] {
        let plain = optimized(&format!("{model}.gltfpack.glb")).unwrap_or_else(|e| panic!("{model}: {e}"));
        let packed = optimized(&format!("{model}.gltfpack-cc.glb")).unwrap_or_else(|e| panic!("{model} -cc: {e}"));
        assert!(packed.warnings.is_empty() || !plain.warnings.is_empty(), "{model}: {:?}", packed.warnings);
        assert_same_model(&plain.asset, &packed.asset, 0.01, &format!("{model} -cc"));
    }
    // The KHR successor, with version 1 of the attribute codec (control modes, 16-bit and
    // rotated XOR channels): the same data as its EXT twin.
    for model in ["Fox", "CesiumMan"] {
        let ext = optimized(&format!("{model}.gltfpack-cc.glb")).expect("EXT").asset;
        let khr = optimized(&format!("{model}.gltfpack-khr.glb")).unwrap_or_else(|e| panic!("{model} KHR: {e}")).asset;
        assert_same_model(&ext, &khr, 0.0, &format!("{model} KHR against EXT"));
    }
}

mod draco;

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn whole_run_reads_equal_the_element_by_element_reads() {
    // Each component type, normalized or not, packed and interleaved (a 12-byte stride) at an
    // offset: accessor 0 is read as one run, accessor 1 (the same data with a sparse
    // substitution of element 0 by its own bytes) element by element; both bit for bit alike.
    let cases: [(u64, usize, &[f64]); 6] = [
        (5120, 1, &[-128.0, 127.0, 0.0, -1.0, 5.0, -7.0]),
        (5121, 1, &[255.0, 0.0, 128.0, 1.0, 2.0, 3.0]),
        (5122, 2, &[-32768.0, 32767.0, 0.0, -1.0, 300.0, -300.0]),
        (5123, 2, &[65535.0, 0.0, 32768.0, 1.0, 2.0, 3.0]),
        (5125, 4, &[16_777_217.0, 4_294_967_295.0, 0.0, 1.0, 2.0, 3.0]),
        (5126, 4, &[1.5, -0.0, f64::NAN, f64::INFINITY, -2.25, 1e-40]),
    ];
    for (ctype, size, values) in cases {
        let encode = |v: f64| -> Vec<u8> {
            match ctype {
                5120 => vec![(v as i8) as u8],
                5121 => vec![v as u8],
                5122 => (v as i16).to_le_bytes().to_vec(),
                5123 => (v as u16).to_le_bytes().to_vec(),
                5125 => (v as u32).to_le_bytes().to_vec(),
                _ => (v as f32).to_le_bytes().to_vec(),
            }
        };
        for stride in [None, Some(12usize)] {
            let element = 2 * size;
            let step = stride.unwrap_or(element);
            // The view: `size` bytes of padding, then 3 VEC2 elements `step` apart (filler between).
            let mut data = vec![0xA5u8; size + 2 * step + element];
            for (i, pair) in values.chunks(2).enumerate() {
                let at = size + i * step;
                let bytes: Vec<u8> = pair.iter().flat_map(|&v| encode(v)).collect();
                data[at..at + element].copy_from_slice(&bytes);
            }
            let main_len = data.len();
            while !data.len().is_multiple_of(4) {
                data.push(0);
            }
            let indices_at = data.len();
            data.extend([0u8, 0, 0, 0]);
            let values_at = data.len();
            data.extend_from_within(size..size + element);
            let mut main = json!({"buffer": 0, "byteLength": main_len});
            if let Some(s) = stride {
                main["byteStride"] = json!(s);
            }
            for normalized in [false, true] {
                if normalized && (ctype == 5125 || ctype == 5126) {
                    continue;
                }
                let accessor = json!({"bufferView": 0, "byteOffset": size, "componentType": ctype,
                    "normalized": normalized, "count": 3, "type": "VEC2"});
                let mut twin = accessor.clone();
                twin["sparse"] = json!({"count": 1,
                    "indices": {"bufferView": 1, "componentType": 5121},
                    "values": {"bufferView": 2}});
                let doc = json!({
                    "bufferViews": [main, {"buffer": 0, "byteOffset": indices_at, "byteLength": 1},
                        {"buffer": 0, "byteOffset": values_at, "byteLength": element}],
                    "accessors": [accessor, twin]
                });
                with_accessors(&doc, data.clone(), |accessors, budget| {
                    assert!(accessors.reads_as_one_run(0) && !accessors.reads_as_one_run(1), "the two paths");
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    let case = format!("type {ctype}, stride {stride:?}, normalized {normalized}");
                    let (run, n) = accessors.read_flat(0, budget).expect("read");
                    let (each, m) = accessors.read_flat(1, budget).expect("read");
                    assert_eq!((n, bits(&run)), (m, bits(&each)), "read_flat, {case}");
                    let run = accessors.read_f32::<2>(0, "", &["VEC2"], false, budget).expect("read");
                    let each = accessors.read_f32::<2>(1, "", &["VEC2"], false, budget).expect("read");
                    assert_eq!(bits(run.as_flattened()), bits(each.as_flattened()), "read_f32, {case}");
                    if normalized {
                        assert!(run.as_flattened().iter().all(|x| (-1.0..=1.0).contains(x)), "{case}: {run:?}");
                    }
                })
                .expect("valid");
            }
        }
    }
}
