// One mip level from the level above it (web/src/render/texture.rs, `MipMaker`): a triangle
// over the target level, each pixel the bilinear sample at the centre of its 2×2 block of the
// source — the box filter. The texture is sRGB, so sampling decodes to linear light before
// filtering and the target encodes again: the average is taken in linear light, as the CPU
// mip chain does; alpha is averaged as it is.

@group(0) @binding(0) var source: texture_2d<f32>;
@group(0) @binding(1) var source_sampler: sampler;

struct MipVertex {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs_mip(@builtin(vertex_index) index: u32) -> MipVertex {
    // (0,0), (2,0), (0,2) in uv: one triangle covering the whole target.
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    var out: MipVertex;
    out.position = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
    out.uv = uv;
    return out;
}

@fragment
fn fs_mip(in: MipVertex) -> @location(0) vec4<f32> {
    return textureSampleLevel(source, source_sampler, in.uv, 0.0);
}
