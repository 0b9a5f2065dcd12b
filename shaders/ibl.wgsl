// Kloub image-based lighting: prefiltering an equirectangular HDR environment once per device
// (web/src/render/environment.rs), each entry point one full-screen pass (valid on WebGL2:
// fragment shaders, 2D textures) from the rgba16float source into the rgba8unorm specular
// chain, its texels encoded by `encode_radiance` (equirect.wgsl).
//
//   fs_specular:   one mip of the specular chain: the environment through glTF's GGX lobe at
//                  `params.x` roughness (N = V = R), importance sampled, each sample read from
//                  the source mip whose texels match its solid angle (Karis 2013, §"prefiltered
//                  environment map"; the "PDF-based filtering" of GPU Gems 3, ch. 20).
//
// The diffuse irradiance is nine spherical-harmonic coefficients summed on the CPU, and the
// split sum's scale and bias an analytic fit (mesh.wgsl): no pass here.

struct Prefilter {
    // x: roughness, y: samples (for
    // roughness 0: the source mip copied), z: source mip levels, w: source width (level 0).
    params: vec4<f32>,
}

@group(0) @binding(0) var<uniform> prefilter: Prefilter;
@group(0) @binding(1) var source: texture_2d<f32>;
@group(0) @binding(2) var source_sampler: sampler;

struct FullOut {
    @builtin(position) clip: vec4<f32>,
    // (0, 0) at the target's top left.
    @location(0) uv: vec2<f32>,
}

/// One triangle over the whole target.
@vertex
fn vs_full(@builtin(vertex_index) index: u32) -> FullOut {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    var out: FullOut;
    out.clip = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
    out.uv = uv;
    return out;
}

/// Van der Corput's radical inverse in base 2 (bit reversal without reverseBits, which GLSL ES
/// 3.0 lacks).
fn radical_inverse(i: u32) -> f32 {
    var b = (i << 16u) | (i >> 16u);
    b = ((b & 0x55555555u) << 1u) | ((b & 0xAAAAAAAAu) >> 1u);
    b = ((b & 0x33333333u) << 2u) | ((b & 0xCCCCCCCCu) >> 2u);
    b = ((b & 0x0F0F0F0Fu) << 4u) | ((b & 0xF0F0F0F0u) >> 4u);
    b = ((b & 0x00FF00FFu) << 8u) | ((b & 0xFF00FF00u) >> 8u);
    return f32(b) * 2.3283064365386963e-10;
}

/// A half vector around `n` distributed as GGX's D(h)·(n·h) for `alpha` (roughness²).
fn importance_ggx(xi: vec2<f32>, n: vec3<f32>, alpha: f32) -> vec3<f32> {
    let a2 = alpha * alpha;
    let phi = 2.0 * EQUIRECT_PI * xi.x;
    let cos_theta = sqrt((1.0 - xi.y) / (1.0 + (a2 - 1.0) * xi.y));
    let sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    let up = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 0.0, 1.0), abs(n.z) < 0.999);
    let tx = normalize(cross(up, n));
    let ty = cross(n, tx);
    return normalize(tx * (sin_theta * cos(phi)) + ty * (sin_theta * sin(phi)) + n * cos_theta);
}

fn ggx_d(nh: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let f = nh * nh * (a2 - 1.0) + 1.0;
    return a2 / (EQUIRECT_PI * f * f);
}

@fragment
fn fs_specular(in: FullOut) -> @location(0) vec4<f32> {
    let n = equirect_direction(in.uv);
    let roughness = prefilter.params.x;
    let samples = u32(prefilter.params.y);
    let levels = prefilter.params.z;
    let width = prefilter.params.w;
    if roughness <= 0.0 {
        return encode_radiance(textureSampleLevel(source, source_sampler, in.uv, prefilter.params.y).rgb);
    }
    let alpha = roughness * roughness;
    // Solid angle of one source texel (the average over the sphere).
    let texel = 4.0 * EQUIRECT_PI / (width * width * 0.5);
    var sum = vec3<f32>(0.0);
    var weight = 0.0;
    for (var i = 0u; i < samples; i += 1u) {
        let xi = vec2<f32>((f32(i) + 0.5) / f32(samples), radical_inverse(i));
        let h = importance_ggx(xi, n, alpha);
        let l = 2.0 * dot(n, h) * h - n;
        let nl = dot(n, l);
        if nl > 0.0 {
            // N = V: the pdf of l is D(h) / 4.
            let nh = max(dot(n, h), 0.0);
            let pdf = ggx_d(nh, alpha) * 0.25;
            let sample_angle = 1.0 / (f32(samples) * pdf + 1e-6);
            let lod = clamp(0.5 * log2(sample_angle / texel) + 1.0, 0.0, levels - 1.0);
            sum += textureSampleLevel(source, source_sampler, equirect_uv(l), lod).rgb * nl;
            weight += nl;
        }
    }
    return encode_radiance(sum / max(weight, 1e-6));
}
