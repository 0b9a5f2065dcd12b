//! Any bytes as the Draco stream of a primitive (`KHR_draco_mesh_compression`), inside a valid
//! GLB: the decoder and the importer around it answer with an asset or an error, never a panic
//! or an allocation the budget did not allow. Seeds: the streams of tests/optimized/*.draco.glb.
#![no_main]

use kloub_core::{NoResolver, import};
use libfuzzer_sys::fuzz_target;

mod common;
use common::glb;

fuzz_target!(|data: &[u8]| {
    if data.is_empty() {
        return;
    }
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsRequired":["KHR_draco_mesh_compression"],
        "buffers":[{{"byteLength":{n}}}],"bufferViews":[{{"buffer":0,"byteLength":{n}}}],
        "accessors":[{{"componentType":5126,"count":3,"type":"VEC3"}},{{"componentType":5126,"count":3,"type":"VEC3"}},
                     {{"componentType":5126,"count":3,"type":"VEC2"}},{{"componentType":5123,"count":3,"type":"VEC4"}},
                     {{"componentType":5126,"count":3,"type":"VEC4"}},{{"componentType":5123,"count":3,"type":"SCALAR"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2,"JOINTS_0":3,"WEIGHTS_0":4}},"indices":5,
          "extensions":{{"KHR_draco_mesh_compression":{{"bufferView":0,
            "attributes":{{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2,"JOINTS_0":3,"WEIGHTS_0":4}}}}}}}}]}}],
        "nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}]}}"#,
        n = data.len()
    );
    let _ = import(&glb(json.as_bytes(), data), &NoResolver, &common::options());
});
