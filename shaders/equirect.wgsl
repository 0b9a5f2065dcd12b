// Kloub equirectangular directions, shared by ibl.wgsl (prefiltering) and mesh.wgsl (lookup);
// web/src/render/environment.rs mirrors them on the CPU. u = 0.5 looks down −Z and u grows
// towards +X; v = 0 is straight up, v = 1 straight down.

const EQUIRECT_PI: f32 = 3.14159265358979;

/// The texture coordinates of unit direction `d`: its longitude atan2(x, −z) and colatitude
/// acos(y) by polynomials rather than the built-in functions, for a GPU that is the CPU
/// (SwiftShader) evaluates this for every pixel of every mesh (BENCHMARKS.md, "Frame cost",
/// stop 52, measures it with the fragment shader's other cuts). Abramowitz and Stegun 4.4.49's
/// atan on [0, 1] is within 1.2e-5 radians and 4.4.45's acos within 7e-5: under a twentieth of a
/// texel of a 4096 × 2048 map (the specular chain is 256 wide).
fn equirect_uv(d: vec3<f32>) -> vec2<f32> {
    let x = d.x;
    let z = -d.z;
    let ax = abs(x);
    let az = abs(z);
    let a = min(ax, az) / max(max(ax, az), 1e-30);
    let s = a * a;
    var r = a * (0.9998660 + s * (-0.3302995 + s * (0.1801410 + s * (-0.0851330 + s * 0.0208351))));
    r = select(r, 1.57079637 - r, ax > az);
    r = select(r, 3.14159274 - r, z < 0.0);
    r = select(r, -r, x < 0.0);
    let y = clamp(d.y, -1.0, 1.0);
    let t = abs(y);
    var c = sqrt(1.0 - t) * (((-0.0187293 * t + 0.0742610) * t - 0.2121144) * t + 1.5707288);
    c = select(c, EQUIRECT_PI - c, y < 0.0);
    return vec2<f32>(0.5 + r / (2.0 * EQUIRECT_PI), c / EQUIRECT_PI);
}

/// The unit direction of texture coordinates `uv`.
fn equirect_direction(uv: vec2<f32>) -> vec3<f32> {
    let phi = (uv.x - 0.5) * 2.0 * EQUIRECT_PI;
    let theta = uv.y * EQUIRECT_PI;
    return vec3<f32>(sin(theta) * sin(phi), cos(theta), -sin(theta) * cos(phi));
}

// The specular chain's texels (rgba8unorm; ibl.wgsl writes them, mesh.wgsl reads them): RGB
// divided by a power of two shared by the texel, 2^(32·a − 16) with `a` in alpha, the smallest
// of 256 steps (each 2^(1/8) ≈ 1.09× the last) at or above the texel's largest channel: every
// value of the half-float source from 2^-16 to its largest keeps its largest channel within
// 0.4 %, and an 8-bit texel is filtered by a CPU rasterizer (SwiftShader) in a fraction of a
// half-float one's time (BENCHMARKS.md, "Frame cost", stop 61). The sampler interpolates RGB
// and the exponent apart: within smooth light (neighbours with equal or adjacent exponents, the
// mantissas making up the step) that is the radiance's own average; across an edge between a
// bright and a dark texel (a lamp mirrored by the smoothest levels) the result falls short of
// it, and the lamp's image ends up to half a texel of the level smaller.
const RADIANCE_EXPONENT_RANGE: f32 = 32.0;
const RADIANCE_EXPONENT_BIAS: f32 = 16.0;

/// `rgb` (non-negative linear radiance) as a texel of the specular chain.
fn encode_radiance(rgb: vec3<f32>) -> vec4<f32> {
    let c = max(rgb, vec3<f32>(0.0));
    let m = max(max(c.r, c.g), max(c.b, 1e-30));
    let code = clamp(ceil((log2(m) + RADIANCE_EXPONENT_BIAS) * (255.0 / RADIANCE_EXPONENT_RANGE)), 0.0, 255.0);
    let scale = exp2(code * (RADIANCE_EXPONENT_RANGE / 255.0) - RADIANCE_EXPONENT_BIAS);
    return vec4<f32>(min(c / scale, vec3<f32>(1.0)), code / 255.0);
}

/// The radiance of a (filtered) texel of the specular chain.
fn decode_radiance(texel: vec4<f32>) -> vec3<f32> {
    return texel.rgb * exp2(texel.a * RADIANCE_EXPONENT_RANGE - RADIANCE_EXPONENT_BIAS);
}
