//! Any bytes as a GLB or .gltf: the importer must answer with an asset or an error, never a
//! panic, an abort or an allocation the budget did not allow (libFuzzer's `-rss_limit_mb`).
#![no_main]

use kloub_core::{ImportOptions, NoResolver, import};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // A budget small enough that an honest refusal comes before libFuzzer's memory limit.
    let options = ImportOptions { budget_bytes: 256 << 20, decode_images: false, ..ImportOptions::default() };
    let _ = import(data, &NoResolver, &options);
});
