/// FNV-1a (64 bits) of a shader's source: the key under which `web/build.rs` files the GLSL
/// of each WGSL module the renderer compiles, computed again when the renderer hands the
/// module over (the same text, the same key). Shared by the build script (`include!`).
pub const fn source_hash(source: &str) -> u64 {
    let bytes = source.as_bytes();
    let mut hash = 0xcbf2_9ce4_8422_2325_u64;
    let mut i = 0;
    while i < bytes.len() {
        hash ^= bytes[i] as u64;
        hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        i += 1;
    }
    hash
}
