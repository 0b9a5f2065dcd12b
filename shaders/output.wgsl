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


// Tone mapping operators (Frame.tone.y).
const TONE_NONE: f32 = 0.0;
const TONE_NEUTRAL: f32 = 1.0;
const TONE_ACES: f32 = 2.0;

/// Khronos PBR Neutral: colours up to ~0.76 keep their hue and (after a small offset that
/// cancels a dielectric's 4 % reflection) their value; brighter ones roll off towards white.
fn tone_neutral(c: vec3<f32>) -> vec3<f32> {
    let start = 0.8 - 0.04;
    let desaturation = 0.15;
    let x = min(c.r, min(c.g, c.b));
    let offset = select(0.04, x - 6.25 * x * x, x < 0.08);
    var color = c - offset;
    let peak = max(color.r, max(color.g, color.b));
    if peak < start {
        return color;
    }
    let d = 1.0 - start;
    let new_peak = 1.0 - d * d / (peak + d - start);
    color *= new_peak / peak;
    let g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0);
    return mix(color, vec3<f32>(new_peak), g);
}

/// ACES filmic (Stephen Hill's fit of the RRT and ODT, with the 1/0.6 exposure three.js and
/// the Khronos sample viewer use).
fn tone_aces(c: vec3<f32>) -> vec3<f32> {
    // The sRGB → ACES AP1 (with the RRT's saturation) and back matrices, by columns.
    let input = mat3x3<f32>(
        vec3<f32>(0.59719, 0.07600, 0.02840),
        vec3<f32>(0.35458, 0.90834, 0.13383),
        vec3<f32>(0.04823, 0.01566, 0.83777),
    );
    let output = mat3x3<f32>(
        vec3<f32>(1.60475, -0.10208, -0.00327),
        vec3<f32>(-0.53108, 1.10813, -0.07276),
        vec3<f32>(-0.07367, -0.00605, 1.07602),
    );
    let v = input * (c / 0.6);
    let a = v * (v + 0.0245786) - 0.000090537;
    let b = v * (0.983729 * v + 0.4329510) + 0.238081;
    return clamp(output * (a / b), vec3<f32>(0.0), vec3<f32>(1.0));
}

/// The frame's exposure and tone mapping applied to a linear scene colour.
fn tone_map(c: vec3<f32>) -> vec3<f32> {
    let exposed = max(c, vec3<f32>(0.0)) * frame.tone.x;
    if frame.tone.y == TONE_NEUTRAL {
        return tone_neutral(exposed);
    }
    if frame.tone.y == TONE_ACES {
        return tone_aces(exposed);
    }
    return exposed;
}
