// Kloub colour output: what every scene fragment shader returns goes through `scene_output`.
//
// SRGB_ENCODE (pipeline override): 0 when the target is sRGB (Rgba8UnormSrgb: the hardware
// encodes and blends in linear space); 1 when it is plain Rgba8Unorm and the shader encodes
// sRGB itself (the browser's WebGL2 canvas, whose sRGB surface wgpu presents through an extra
// full-screen pass). Blending then happens in gamma space, as in three.js and the browser.
override SRGB_ENCODE: u32 = 0u;

/// Linear colour to sRGB (IEC 61966-2-1), clamped to [0, 1] first.
fn encode_srgb(linear: vec3<f32>) -> vec3<f32> {
    let c = clamp(linear, vec3<f32>(0.0), vec3<f32>(1.0));
    let low = c * 12.92;
    let high = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(high, low, c <= vec3<f32>(0.0031308));
}

/// The value written to the colour target for the linear colour `color`.
fn scene_output(color: vec4<f32>) -> vec4<f32> {
    if SRGB_ENCODE != 0u {
        return vec4<f32>(encode_srgb(color.rgb), color.a);
    }
    return color;
}

