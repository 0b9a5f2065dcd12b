//! `KHR_draco_mesh_compression`: a real stream (glTF Transform's Draco copy of
//! AnimatedMorphCube, compiled in so that these run on wasm32 too) in hand-made documents, one
//! per defect class, and mutated streams that must be refused without a panic.

use super::*;

/// The Draco stream of AnimatedMorphCube.draco.glb: 24 points (NORMAL id 0, TANGENT id 1,
/// POSITION id 2), 12 triangles.
fn stream() -> Vec<u8> {
    let file = include_bytes!("../../../../tests/optimized/AnimatedMorphCube.draco.glb");
    let json_length = u32::from_le_bytes([file[12], file[13], file[14], file[15]]) as usize;
    let doc: Value = serde_json::from_slice(&file[20..20 + json_length]).expect("JSON chunk");
    let view = doc["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["bufferView"]
        .as_u64()
        .expect("the stream's view") as usize;
    let offset = doc["bufferViews"][view]["byteOffset"].as_u64().unwrap_or(0) as usize;
    let length = doc["bufferViews"][view]["byteLength"].as_u64().expect("length") as usize;
    let bin = 20 + json_length.next_multiple_of(4) + 8;
    file[bin + offset..bin + offset + length].to_vec()
}

/// A document with one Draco primitive: POSITION (accessor 0) and u16 indices (accessor 1),
/// neither with a buffer view, the stream in view 0.
fn draco_doc(stream: &[u8]) -> (Value, Vec<u8>) {
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_draco_mesh_compression"],
        "extensionsRequired": ["KHR_draco_mesh_compression"],
        "buffers": [{"byteLength": stream.len()}],
        "bufferViews": [{"buffer": 0, "byteLength": stream.len()}],
        "accessors": [
            {"componentType": 5126, "count": 24, "type": "VEC3"},
            {"componentType": 5123, "count": 36, "type": "SCALAR"}
        ],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0}, "indices": 1,
            "extensions": {"KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 2}}}
        }]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}]
    });
    (doc, stream.to_vec())
}

const X: &str = "/meshes/0/primitives/0/extensions/KHR_draco_mesh_compression";

/// A change to a document and its BIN buffer.
type Edit = dyn Fn(&mut Value, &mut Vec<u8>);

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn a_draco_primitive_decodes_into_its_accessors() {
    let (doc, bin) = draco_doc(&stream());
    let imported = run(&doc, &bin).expect("imports");
    assert!(imported.warnings.is_empty(), "{:?}", imported.warnings);
    let p = &imported.asset.meshes[0].primitives[0];
    assert_eq!((p.positions.len(), p.indices.len()), (24, 36));
    // The cube is 0.02 wide, centred on the origin.
    for v in &p.positions {
        assert!(v.iter().all(|x| (x.abs() - 0.01).abs() < 1e-5 || x.abs() < 1e-5), "{v:?}");
        assert!(v.iter().filter(|x| (x.abs() - 0.01).abs() < 1e-5).count() == 3, "a corner: {v:?}");
    }
    let cost = &imported.asset.extensions.compressed_primitives;
    assert_eq!(cost.len(), 1);
    assert_eq!((cost[0].points, cost[0].triangles, cost[0].view), (24, 12, 0));
    assert_eq!(cost[0].decoded_bytes, 24 * 12 + 36 * 4);
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn a_stream_that_primitives_share_is_decoded_once_per_set_of_attributes() {
    let (mut doc, bin) = draco_doc(&stream());
    // A second mesh with the same primitive: its accessors are filled already.
    let prim = doc["meshes"][0]["primitives"][0].clone();
    doc["meshes"].as_array_mut().expect("meshes").push(json!({"primitives": [prim.clone()]}));
    let imported = run(&doc, &bin).expect("imports");
    let cost = &imported.asset.extensions.compressed_primitives;
    assert_eq!(cost.len(), 2);
    assert_eq!(cost[0].decoded_bytes, 24 * 12 + 36 * 4);
    assert_eq!((cost[1].decoded_bytes, cost[1].points, cost[1].triangles), (0, 24, 12), "decoded again");
    assert_eq!(imported.asset.meshes[1].primitives[0].positions, imported.asset.meshes[0].primitives[0].positions);
    // A third one that also reads the normals (a new accessor) decodes the stream for them.
    doc["accessors"]
        .as_array_mut()
        .expect("accessors")
        .push(json!({"componentType": 5126, "count": 24, "type": "VEC3"}));
    let mut third = prim;
    third["attributes"]["NORMAL"] = json!(2);
    third["extensions"]["KHR_draco_mesh_compression"]["attributes"]["NORMAL"] = json!(0);
    doc["meshes"].as_array_mut().expect("meshes").push(json!({"primitives": [third]}));
    let imported = run(&doc, &bin).expect("imports");
    let cost = &imported.asset.extensions.compressed_primitives;
    assert_eq!(cost[2].decoded_bytes, 24 * 12, "only the normals are new");
    assert!(
        imported.asset.meshes[2].primitives[0]
            .normals
            .iter()
            .all(|n| (n[0].hypot(n[1]).hypot(n[2]) - 1.0).abs() < 1e-3)
    );
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn a_draco_count_unlike_the_accessors_is_a_warning() {
    let (mut doc, bin) = draco_doc(&stream());
    doc["accessors"][0]["count"] = json!(20);
    let imported = run(&doc, &bin).expect("imports");
    assert_eq!(imported.warnings.len(), 1, "{:?}", imported.warnings);
    assert_eq!(imported.warnings[0].pointer, "/accessors/0/count");
    assert_eq!(imported.asset.meshes[0].primitives[0].positions.len(), 24, "the stream's points are used");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn broken_draco_primitives_are_refused_at_their_pointer() {
    let good = stream();
    let cases: Vec<(&str, Box<Edit>, String, &str)> = vec![
        ("cut stream", Box::new(|_, bin| bin.truncate(bin.len() / 2)), format!("{X}/bufferView"), "does not decode"),
        ("not a stream", Box::new(|_, bin| bin.fill(7)), format!("{X}/bufferView"), "does not decode"),
        (
            "unknown attribute id",
            Box::new(|doc, _| {
                doc["meshes"][0]["primitives"][0]["extensions"][EXT]["attributes"]["POSITION"] = json!(9)
            }),
            format!("{X}/attributes/POSITION"),
            "no attribute with id 9",
        ),
        (
            "compressed attribute without an accessor",
            Box::new(|doc, _| doc["meshes"][0]["primitives"][0]["extensions"][EXT]["attributes"]["NORMAL"] = json!(0)),
            format!("{X}/attributes/NORMAL"),
            "no accessor for it",
        ),
        (
            "attribute accessor out of range",
            Box::new(|doc, _| doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(9)),
            "/meshes/0/primitives/0/attributes/POSITION".into(),
            "",
        ),
        (
            "components unlike the accessor's",
            Box::new(|doc, _| doc["accessors"][0]["type"] = json!("VEC4")),
            format!("{X}/attributes/POSITION"),
            "3 components",
        ),
        (
            "floats into an integer accessor",
            Box::new(|doc, _| doc["accessors"][0]["componentType"] = json!(5123)),
            format!("{X}/attributes/POSITION"),
            "holds floats",
        ),
        (
            "lines",
            Box::new(|doc, _| doc["meshes"][0]["primitives"][0]["mode"] = json!(1)),
            "/meshes/0/primitives/0/mode".into(),
            "TRIANGLES",
        ),
        (
            "no indices",
            Box::new(|doc, _| {
                doc["meshes"][0]["primitives"][0].as_object_mut().expect("object").remove("indices");
            }),
            "/meshes/0/primitives/0/indices".into(),
            "needs an indices accessor",
        ),
        (
            "view out of range",
            Box::new(|doc, _| doc["meshes"][0]["primitives"][0]["extensions"][EXT]["bufferView"] = json!(3)),
            format!("{X}/bufferView"),
            "",
        ),
    ];
    for (what, edit, pointer, message) in cases {
        let (mut doc, mut bin) = draco_doc(&good);
        edit(&mut doc, &mut bin);
        doc["buffers"][0]["byteLength"] = json!(bin.len());
        doc["bufferViews"][0]["byteLength"] = json!(bin.len());
        let e = refused(&doc, &bin);
        assert_eq!(e.pointer, pointer, "{what}: {e}");
        assert!(e.message.contains(message), "{what}: {e}");
    }
}

const EXT: &str = "KHR_draco_mesh_compression";

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn a_draco_stream_over_the_budget_is_refused() {
    let (doc, bin) = draco_doc(&stream());
    let glb = glb_of(&doc, &bin);
    // Budgets from nothing up to enough: some of them hold the file but not what it decodes to.
    let mut draco_refusals = 0;
    for budget in (0..100_000).step_by(16) {
        let options = ImportOptions { budget_bytes: budget, ..ImportOptions::default() };
        match import(&glb, &NoResolver, &options) {
            Ok(_) => break,
            Err(e) if e.pointer.starts_with(X) || e.pointer == "/meshes/0/primitives/0/indices" => {
                assert!(e.message.contains("budget") || e.message.contains("ceiling"), "{e}");
                draco_refusals += 1;
            }
            Err(e) => assert!(e.message.contains("budget"), "{budget}: {e}"),
        }
    }
    assert!(draco_refusals >= 10, "{draco_refusals} budgets refused at the Draco primitive");
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn mutated_draco_streams_are_refused_or_decoded_never_a_panic() {
    let good = stream();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let (mut decoded, mut refused_count) = (0, 0);
    for round in 0..400 {
        let mut bytes = good.clone();
        for _ in 0..1 + next() % 6 {
            let at = (next() as usize) % bytes.len();
            bytes[at] = next() as u8;
        }
        if round % 4 == 0 {
            bytes.truncate((next() as usize) % bytes.len() + 1);
        }
        let (mut doc, _) = draco_doc(&bytes);
        doc["buffers"][0]["byteLength"] = json!(bytes.len());
        match run(&doc, &bytes) {
            Ok(_) => decoded += 1,
            Err(e) => {
                assert!(e.pointer.starts_with("/meshes/0/primitives/0") || e.pointer.starts_with("/accessors"), "{e}");
                refused_count += 1;
            }
        }
    }
    assert!(refused_count > 100 && decoded + refused_count == 400, "{decoded} decoded, {refused_count} refused");
}
