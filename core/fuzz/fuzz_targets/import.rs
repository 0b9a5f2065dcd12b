//! Any bytes as a GLB or .gltf: the importer must answer with an asset or an error, never a
//! panic, an abort or an allocation the budget did not allow (libFuzzer's `-rss_limit_mb`).
#![no_main]

use kloub_core::{NoResolver, import};
use libfuzzer_sys::fuzz_target;

mod common;

fuzz_target!(|data: &[u8]| {
    let _ = import(data, &NoResolver, &common::options());
});
