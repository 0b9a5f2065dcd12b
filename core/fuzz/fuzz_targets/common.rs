//! What the fuzz targets share.

use kloub_core::ImportOptions;

/// A budget small enough that an honest refusal comes before libFuzzer's memory limit.
pub fn options() -> ImportOptions {
    ImportOptions { budget_bytes: 256 << 20, decode_images: false, ..ImportOptions::default() }
}

/// A GLB of `json` and `bin`.
#[allow(dead_code)] // not every target builds a GLB
pub fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    kloub_core::import::glb(json, Some(bin)).unwrap_or_default()
}
