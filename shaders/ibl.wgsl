// Kloub image-based lighting: prefiltering an equirectangular HDR environment once per device
// (web/src/render/environment.rs), each entry point one full-screen pass into an rgba16float
// target (valid on WebGL2: fragment shaders, 2D textures).
//
//   fs_specular:   one mip of the specular chain: the environment through glTF's GGX lobe at
//                  `params.x` roughness (N = V = R), importance sampled, each sample read from
//                  the source mip whose texels match its solid angle (Karis 2013, §"prefiltered
//                  environment map"; the "PDF-based filtering" of GPU Gems 3, ch. 20).
//   fs_irradiance: cosine-weighted irradiance over π, summed over every texel of source mip
//                  `params.y`.
//   fs_brdf:       the split-sum table: GGX's directional albedo as scale (r) and bias (g) on F0,
//                  by N·V (u) and roughness (v), with the height-correlated Smith visibility
//                  mesh.wgsl's direct light uses.

struct Prefilter {
    // x: roughness (fs_specular) | the source mip to sum (fs_irradiance), y: samples (for
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
        return vec4<f32>(textureSampleLevel(source, source_sampler, in.uv, prefilter.params.y).rgb, 1.0);
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
    return vec4<f32>(sum / max(weight, 1e-6), 1.0);
}

@fragment
fn fs_irradiance(in: FullOut) -> @location(0) vec4<f32> {
    let n = equirect_direction(in.uv);
    let lod = i32(prefilter.params.x);
    let size = textureDimensions(source, lod);
    var sum = vec3<f32>(0.0);
    for (var y = 0u; y < size.y; y += 1u) {
        let v = (f32(y) + 0.5) / f32(size.y);
        let solid = (2.0 * EQUIRECT_PI / f32(size.x)) * (EQUIRECT_PI / f32(size.y)) * sin(v * EQUIRECT_PI);
        for (var x = 0u; x < size.x; x += 1u) {
            let d = equirect_direction(vec2<f32>((f32(x) + 0.5) / f32(size.x), v));
            let c = max(dot(n, d), 0.0) * solid;
            sum += textureLoad(source, vec2<i32>(i32(x), i32(y)), lod).rgb * c;
        }
    }
    return vec4<f32>(sum / EQUIRECT_PI, 1.0);
}

@fragment
fn fs_brdf(in: FullOut) -> @location(0) vec4<f32> {
    let nv = max(in.uv.x, 1e-3);
    let roughness = max(in.uv.y, 0.05);
    let alpha = roughness * roughness;
    let a2 = alpha * alpha;
    let v = vec3<f32>(sqrt(1.0 - nv * nv), 0.0, nv);
    let n = vec3<f32>(0.0, 0.0, 1.0);
    let samples = u32(prefilter.params.y);
    var a = 0.0;
    var b = 0.0;
    for (var i = 0u; i < samples; i += 1u) {
        let xi = vec2<f32>((f32(i) + 0.5) / f32(samples), radical_inverse(i));
        let h = importance_ggx(xi, n, alpha);
        let l = 2.0 * dot(v, h) * h - v;
        let nl = l.z;
        let nh = max(h.z, 0.0);
        let vh = clamp(dot(v, h), 0.0, 1.0);
        if nl > 0.0 && nh > 0.0 {
            let vis = 0.5 / (nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2));
            let g = vis * 4.0 * nl * vh / nh;
            let fc = pow(1.0 - vh, 5.0);
            a += (1.0 - fc) * g;
            b += fc * g;
        }
    }
    return vec4<f32>(a / f32(samples), b / f32(samples), 0.0, 1.0);
}
