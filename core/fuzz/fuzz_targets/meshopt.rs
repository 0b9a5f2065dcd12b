//! Any bytes as a meshopt-compressed buffer view (`EXT_meshopt_compression` and its KHR
//! successor), inside a valid GLB. The first four bytes are the view's parameters: bit 0 of the
//! first picks the extension, bits 1–2 the mode, bits 3–5 the filter; the second is the stride;
//! the next two the element count (little-endian). The rest is the compressed data. The decoder
//! answers with data or an error, never a panic. Seeds: the views of tests/optimized's
//! gltfpack files (scripts/fuzz-seeds.mjs).
#![no_main]

use kloub_core::{NoResolver, import};
use libfuzzer_sys::fuzz_target;

mod common;
use common::glb;

const MODES: [&str; 3] = ["ATTRIBUTES", "TRIANGLES", "INDICES"];
const FILTERS: [&str; 5] = ["NONE", "OCTAHEDRAL", "QUATERNION", "EXPONENTIAL", "COLOR"];

fuzz_target!(|data: &[u8]| {
    let [pick, stride, c0, c1, stream @ ..] = data else { return };
    if stream.is_empty() {
        return;
    }
    let name = if pick & 1 == 1 { "KHR_meshopt_compression" } else { "EXT_meshopt_compression" };
    let mode = MODES[usize::from(pick >> 1 & 3) % MODES.len()];
    let filter = FILTERS[usize::from(pick >> 3 & 7) % FILTERS.len()];
    let count = u16::from_le_bytes([*c0, *c1]).max(1);
    let stride = u32::from(*stride).max(1);
    let length = stride * u32::from(count);
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsRequired":["{name}"],
        "buffers":[{{"byteLength":{n}}},{{"byteLength":{length},"extensions":{{"{name}":{{"fallback":true}}}}}}],
        "bufferViews":[{{"buffer":1,"byteLength":{length},
          "extensions":{{"{name}":{{"buffer":0,"byteLength":{n},"byteStride":{stride},"count":{count},
            "mode":"{mode}","filter":"{filter}"}}}}}}],
        "nodes":[{{}}],"scenes":[{{"nodes":[0]}}]}}"#,
        n = stream.len()
    );
    let _ = import(&glb(json.as_bytes(), stream), &NoResolver, &common::options());
});
