//! What the fuzz targets share.

use kloub_core::ImportOptions;

/// A budget small enough that an honest refusal comes before libFuzzer's memory limit.
pub fn options() -> ImportOptions {
    ImportOptions { budget_bytes: 256 << 20, decode_images: false, ..ImportOptions::default() }
}

/// A GLB of `json` and `bin` (each chunk padded to 4 bytes).
#[allow(dead_code)] // not every target builds a GLB
pub fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |n: usize| n.next_multiple_of(4);
    let total = 12 + 8 + pad(json.len()) + 8 + pad(bin.len());
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((pad(json.len()) as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.resize(20 + pad(json.len()), b' ');
    out.extend((pad(bin.len()) as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out.resize(total, 0);
    out
}
