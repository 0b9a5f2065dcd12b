// Kloub mesh shader: static, GPU-morphed and GPU-skinned vertices (skinning.wgsl, prepended
// by the Rust side), shaded with glTF 2.0's metallic-roughness BRDF (Appendix B of the
// specification: GGX distribution, height-correlated Smith visibility, Schlick Fresnel, Lambert
// diffuse) under a key light and a hemisphere, with every core texture (base colour,
// metallic-roughness, normal, occlusion, emissive; each with its own texCoord set and
// KHR_texture_transform), vertex colours, unlit, alpha mask/blend, then exposure and tone
// mapping (output.wgsl).
//
// Valid on WebGPU, native and WebGL2 (wgpu downlevel): no storage buffers, no compute.
//
// Bind groups:
//   0: Frame uniform (camera, lights) + joint palette + morph deltas (per frame)
//   1: Material uniform + five textures, each with its sampler        (per material)
//   2: Draw uniform with a dynamic offset                           (per draw)
//   3: the environment: its specular chain (ibl.wgsl made it) and sampler
// The Frame struct is shared with environment.wgsl and must stay identical
// (tests/shaders.rs checks that same-named structs have the same layout in every file).

struct Frame {
    view_proj: mat4x4<f32>,
    // xyz: eye position in world space.
    camera_pos: vec4<f32>,
    // xyz: unit direction towards the key light, w: its intensity.
    light_dir: vec4<f32>,
    light_color: vec4<f32>,
    sky_color: vec4<f32>,
    ground_color: vec4<f32>,
    // x: ground height, y: grid cell size, z: fade radius, w: half extent of the grid quad.
    grid: vec4<f32>,
    // xyz: centre of the grid (on the ground plane).
    grid_center: vec4<f32>,
    background_top: vec4<f32>,
    background_bottom: vec4<f32>,
    // x: exposure (a factor), y: tone mapping (TONE_* in output.wgsl).
    tone: vec4<f32>,
    // Image-based light: x, y: cosine and sine of the environment's turn about +Y, z: its
    // intensity (0: none, the hemisphere lights), w: levels of its specular chain.
    environment: vec4<f32>,
    // The environment's irradiance over π as nine spherical-harmonic coefficients (rgb), the
    // basis constants and cosine lobe folded in (mesh.wgsl's `sh_irradiance`).
    irradiance: array<vec4<f32>, 9>,
}

struct Material {
    // Linear RGBA base colour factor.
    base_color: vec4<f32>,
    // rgb: emissive factor times KHR_materials_emissive_strength, w: alpha cutoff (mask mode).
    emissive: vec4<f32>,
    // x: metallic factor, y: roughness factor, z: normal scale, w: occlusion strength.
    pbr: vec4<f32>,
    // x: flags (MATERIAL_* below), y: bit TEX_* set when that texture reads TEXCOORD_1.
    flags: vec4<u32>,
    // KHR_texture_transform of texture TEX_* as a 2D affine matrix:
    // uv' = uv[2t].xy * u + uv[2t].zw * v + uv[2t + 1].xy.
    uv: array<vec4<f32>, 10>,
}

const MATERIAL_UNLIT: u32 = 1u;
const MATERIAL_ALPHA_MASK: u32 = 2u;
const MATERIAL_ALPHA_BLEND: u32 = 4u;
// Which optional textures the material has (the base colour texture is always bound: white
// where the material has none).
const MATERIAL_METALLIC_ROUGHNESS_TEXTURE: u32 = 8u;
const MATERIAL_NORMAL_TEXTURE: u32 = 16u;
const MATERIAL_OCCLUSION_TEXTURE: u32 = 32u;
const MATERIAL_EMISSIVE_TEXTURE: u32 = 64u;
// Pipeline-overridable specialisation of fs_main (a CPU rasterizer such as SwiftShader runs
// every branch of a shader, taken or not): TEXTURES holds the optional textures compiled in
// (the material flags above shifted down by 3: metallic-roughness 1, normal 2, occlusion 4,
// emissive 8), ENVIRONMENT which ambient light is (1: the prefiltered environment, 0: the
// hemisphere). The defaults compile everything and read the material's flags and the frame.
override TEXTURES: u32 = 15u;
override ENVIRONMENT: u32 = 2u;
// Texture slots (the index of each one's transform, the bit of its texCoord set).
const TEX_BASE: u32 = 0u;
const TEX_METALLIC_ROUGHNESS: u32 = 1u;
const TEX_NORMAL: u32 = 2u;
const TEX_OCCLUSION: u32 = 3u;
const TEX_EMISSIVE: u32 = 4u;
const DRAW_HAS_NORMALS: u32 = 1u;
// Colour skinned vertices by their distance from another method's result.
const DRAW_HEATMAP: u32 = 2u;
const PI: f32 = 3.14159265358979;
const MIN_ROUGHNESS: f32 = 0.05;

@group(0) @binding(0) var<uniform> frame: Frame;
@group(1) @binding(0) var<uniform> material: Material;
// sRGB: base colour and emissive. Linear: metallic-roughness, normal, occlusion.
@group(1) @binding(1) var base_texture: texture_2d<f32>;
@group(1) @binding(2) var base_sampler: sampler;
@group(1) @binding(3) var metallic_roughness_texture: texture_2d<f32>;
@group(1) @binding(4) var metallic_roughness_sampler: sampler;
@group(1) @binding(5) var normal_texture: texture_2d<f32>;
@group(1) @binding(6) var normal_sampler: sampler;
@group(1) @binding(7) var occlusion_texture: texture_2d<f32>;
@group(1) @binding(8) var occlusion_sampler: sampler;
@group(1) @binding(9) var emissive_texture: texture_2d<f32>;
@group(1) @binding(10) var emissive_sampler: sampler;

@group(3) @binding(0) var environment_specular: texture_2d<f32>;
@group(3) @binding(1) var environment_sampler: sampler;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world_pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec4<f32>,
    @location(4) uv1: vec2<f32>,
    // World-space tangent and the bitangent's sign (0: none, the fragment shader derives a frame).
    @location(5) tangent: vec4<f32>,
}

/// `v`'s tangent in world space by the draw's model matrix, with the bitangent's sign from
/// `g` (flipped by a mirroring model matrix: `normal_matrix[3].w`, DrawUniform::new).
fn world_tangent(v: Vertex, g: GeometryIn) -> vec4<f32> {
    if TANGENTS == 0u {
        return vec4<f32>(0.0);
    }
    return vec4<f32>((draw.model * vec4<f32>(v.tangent, 0.0)).xyz, g.tangent.w * draw.normal_matrix[3].w);
}

fn finish(world_pos: vec3<f32>, normal: vec3<f32>, tangent: vec4<f32>, g: GeometryIn) -> VsOut {
    var out: VsOut;
    out.clip = frame.view_proj * vec4<f32>(world_pos, 1.0);
    out.world_pos = world_pos;
    out.normal = normal;
    out.tangent = tangent;
    out.uv = g.uv;
    out.uv1 = g.uv1;
    out.color = g.color;
    return out;
}

/// Vertices transformed by the draw's model matrix (unskinned meshes, CPU-deformed vertices).
@vertex
fn vs_static(g: GeometryIn) -> VsOut {
    let v = morphed(g);
    let world = draw.model * vec4<f32>(v.position, 1.0);
    let normal = (draw.normal_matrix * vec4<f32>(v.normal, 0.0)).xyz;
    return finish(world.xyz, normal, world_tangent(v, g), g);
}

/// Skinned vertices are in world space; `draw.model` places a copy of the character (a
/// translation; the identity for the first).
@vertex
fn vs_skinned(g: GeometryIn, s: SkinIn) -> VsOut {
    let rest = morphed(g);
    let v = skin_with(rest, s, draw_method());
    let world = draw.model * vec4<f32>(v.position, 1.0);
    let normal = (draw.normal_matrix * vec4<f32>(v.normal, 0.0)).xyz;
    var out = finish(world.xyz, normal, world_tangent(v, g), g);
    if HEATMAP != 0u && (draw.params.y & DRAW_HEATMAP) != 0u {
        // Deviation from linear blend skinning (from dual quaternions when LBS is shown).
        let reference = select(SKIN_LINEAR, SKIN_DUAL_QUATERNION, draw_method() == SKIN_LINEAR);
        let other = skin_with(rest, s, reference);
        out.color = vec4<f32>(heat_color(distance(v.position, other.position) / max(draw.heat.x, 1e-20)), 1.0);
    }
    return out;
}

/// A shadow caster's vertex (depth only; masked materials' casters use `vs_static` or
/// `vs_skinned`, their fragment shader reads the texture coordinates): the position alone, so
/// the compiler drops the normal, the texture coordinates and the colours. The frame's
/// `view_proj` is the light's.
@vertex
fn vs_caster_static(g: GeometryIn) -> @builtin(position) vec4<f32> {
    return frame.view_proj * (draw.model * vec4<f32>(morphed(g).position, 1.0));
}

@vertex
fn vs_caster_skinned(g: GeometryIn, s: SkinIn) -> @builtin(position) vec4<f32> {
    let v = skin_with(morphed(g), s, draw_method());
    return frame.view_proj * (draw.model * vec4<f32>(v.position, 1.0));
}

/// Casters already in world space: every copy's, deformed on the CPU, gathered into one
/// buffer and drawn at once (one draw for the copies instead of one each).
@vertex
fn vs_caster_world(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return frame.view_proj * vec4<f32>(position, 1.0);
}

/// Blue (0) through green and yellow to red (1 and beyond).
fn heat_color(t: f32) -> vec3<f32> {
    let x = clamp(t, 0.0, 1.0);
    return clamp(vec3<f32>(2.0 * x - 0.5, 1.5 - abs(2.0 * x - 1.0) * 1.5, 1.0 - 2.0 * x), vec3<f32>(0.0), vec3<f32>(1.0));
}

/// Readback of the vertex stage (tests, CPU/GPU comparison): vertex `i` of a point-list draw
/// lands on pixel (i % width, i / width) of two rgba32uint targets, carrying the bits of its
/// world position and unit normal (integer targets are renderable everywhere, float32 ones
/// are not).
struct CaptureOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) position: vec4<f32>,
    @location(1) @interpolate(flat) normal: vec4<f32>,
}

fn capture(v: Vertex, index: u32) -> CaptureOut {
    let size = vec2<f32>(f32(draw.params.w & 0xffffu), f32(draw.params.w >> 16u));
    let pixel = vec2<f32>(f32(index % u32(size.x)), f32(index / u32(size.x))) + 0.5;
    var out: CaptureOut;
    out.clip = vec4<f32>(pixel.x / size.x * 2.0 - 1.0, 1.0 - pixel.y / size.y * 2.0, 0.5, 1.0);
    out.position = vec4<f32>(v.position, 1.0);
    let len2 = dot(v.normal, v.normal);
    out.normal = vec4<f32>(select(vec3<f32>(0.0), v.normal * inverseSqrt(len2), len2 > 1e-24), 1.0);
    return out;
}

@vertex
fn vs_capture_skinned(g: GeometryIn, s: SkinIn) -> CaptureOut {
    return capture(skinned(g, s), g.index);
}

struct CaptureTargets {
    @location(0) position: vec4<u32>,
    @location(1) normal: vec4<u32>,
}

@fragment
fn fs_capture(in: CaptureOut) -> CaptureTargets {
    return CaptureTargets(bitcast<vec4<u32>>(in.position), bitcast<vec4<u32>>(in.normal));
}

/// Texture `slot`'s coordinates: its texCoord set through its KHR_texture_transform.
fn texture_uv(slot: u32, in: VsOut) -> vec2<f32> {
    let uv = select(in.uv, in.uv1, ((material.flags.y >> slot) & 1u) != 0u);
    let a = material.uv[2u * slot];
    return a.xy * uv.x + a.zw * uv.y + material.uv[2u * slot + 1u].xy;
}

/// The normal texture's tangent-space normal `t` (scaled) in world space, around the surface
/// normal `n`, by the cotangent frame of the screen-space derivatives of the position `dp` and
/// texture coordinates `duv` (no tangent attribute needed; mirrored and skinned UVs included).
/// `dpy` and `duvy` are taken along screen-up (`fs_main` turns them: the sign of `dpdy` differs
/// between backends). glTF's texture space has +Y up in the image, towards decreasing v.
fn perturb_normal(n: vec3<f32>, dpx: vec3<f32>, dpy: vec3<f32>, duvx: vec2<f32>, duvy: vec2<f32>, t: vec3<f32>) -> vec3<f32> {
    let dpy_perp = cross(dpy, n);
    let dpx_perp = cross(n, dpx);
    let tangent = dpy_perp * duvx.x + dpx_perp * duvy.x;
    let bitangent = -(dpy_perp * duvx.y + dpx_perp * duvy.y);
    let len2 = max(dot(tangent, tangent), dot(bitangent, bitangent));
    if len2 < 1e-30 {
        return n;
    }
    let scale = inverseSqrt(len2);
    let perturbed = tangent * (t.x * scale) + bitangent * (t.y * scale) + n * t.z;
    let p2 = dot(perturbed, perturbed);
    return select(n, perturbed * inverseSqrt(p2), p2 > 1e-30);
}

/// Light reflected towards `v` from a key light from `l` of radiance `radiance` (irradiance
/// `radiance` × N·L), glTF's BRDF: the metal and dielectric lobes mixed by metalness (Appendix
/// B's `mix(dielectric_brdf, metal_brdf, metallic)`): GGX specular with F0 = mix(0.04, base,
/// metallic), Lambert diffuse of the dielectric part weighted by its own 1 − F (F0 = 0.04).
fn direct_light(n: vec3<f32>, v: vec3<f32>, l: vec3<f32>, c_diff: vec3<f32>, f0: vec3<f32>, alpha: f32, radiance: vec3<f32>) -> vec3<f32> {
    let nl = dot(n, l);
    if nl <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = normalize(l + v);
    let nv = clamp(dot(n, v), 1e-4, 1.0);
    let nh = clamp(dot(n, h), 0.0, 1.0);
    let vh = clamp(dot(v, h), 0.0, 1.0);
    let a2 = alpha * alpha;
    // Schlick's (1 − v·h)⁵ by multiplication (pow is two transcendental functions).
    let m = 1.0 - vh;
    let m5 = m * m * m * m * m;
    let f = f0 + (vec3<f32>(1.0) - f0) * m5;
    let d_den = nh * nh * (a2 - 1.0) + 1.0;
    let d = a2 / (PI * d_den * d_den);
    let vis_den = nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2);
    let vis = select(0.0, 0.5 / vis_den, vis_den > 0.0);
    // The lights' intensities are irradiances over π: a white Lambert surface facing a light
    // of intensity 1 reflects 1.
    let diffuse = (1.0 - (0.04 + 0.96 * m5)) * c_diff;
    let specular = PI * f * d * vis;
    return (diffuse + specular) * radiance * nl;
}

/// The split-sum environment BRDF: the scale (x) and bias (y) on F0 of GGX's directional
/// albedo, by Karis's analytic fit ("Physically Based Shading on Mobile", 2014; no table to look
/// up — three.js r187 reads a 16×16 table of the integral instead, within ~2–3 %). The fit's
/// bias dips just below 0 for rough surfaces seen head-on: held at 0.
fn environment_ab(roughness: f32, nv: f32) -> vec2<f32> {
    let r = roughness * vec4<f32>(-1.0, -0.0275, -0.572, 0.022) + vec4<f32>(1.0, 0.0425, 1.04, -0.04);
    let a004 = min(r.x * r.x, exp2(-9.28 * nv)) * r.x + r.y;
    return max(vec2<f32>(-1.04, 1.04) * a004 + r.zw, vec2<f32>(0.0));
}

/// The environment's irradiance over π at the unit direction `d` (environment frame) from the
/// frame's spherical-harmonic coefficients (environment.rs's `irradiance_from_sh`).
fn sh_irradiance(d: vec3<f32>) -> vec3<f32> {
    let c = frame.irradiance;
    let e = c[0].rgb + c[1].rgb * d.y + c[2].rgb * d.z + c[3].rgb * d.x + c[4].rgb * (d.x * d.y)
        + c[5].rgb * (d.y * d.z) + c[6].rgb * (3.0 * d.z * d.z - 1.0) + c[7].rgb * (d.x * d.z)
        + c[8].rgb * (d.x * d.x - d.y * d.y);
    return max(e, vec3<f32>(0.0));
}

/// World direction `d` in the environment's frame (it is turned about +Y by the frame's angle).
fn environment_direction(d: vec3<f32>) -> vec3<f32> {
    let c = frame.environment.x;
    let s = frame.environment.y;
    return vec3<f32>(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
}

/// The shadow caster of an alpha-masked material (depth only): discards where `fs_main` does.
@fragment
fn fs_caster_mask(in: VsOut) {
    let texel = textureSample(base_texture, base_sampler, texture_uv(TEX_BASE, in));
    if material.base_color.a * texel.a * in.color.a < material.emissive.w {
        discard;
    }
}

/// The split-sum scattering of a specular lobe of F0 `f0` with the fit's `ab`: single
/// scattering (F0·A + B) and, after Fdez-Agüera 2019, the multiple scattering GGX's single
/// scattering loses.
struct Scattering {
    single: vec3<f32>,
    multiple: vec3<f32>,
}

fn scattering(f0: vec3<f32>, ab: vec2<f32>) -> Scattering {
    let single = f0 * ab.x + ab.y;
    let ems = 1.0 - (ab.x + ab.y);
    let f_avg = f0 + (vec3<f32>(1.0) - f0) / 21.0;
    return Scattering(single, ems * single * f_avg / (vec3<f32>(1.0) - ems * f_avg));
}

/// The environment's light reflected towards `v` by a surface facing `n`, before occlusion: the
/// split sum (one lookup of the specular chain; the diffuse from the spherical harmonics) for
/// the dielectric (F0 0.04) and metal (F0 = base) lobes mixed
/// by metalness, multiple scattering included, and the diffuse part of the dielectric weighted
/// by what its specular lobe leaves (as glTF's Appendix B, and three.js, mix them).
fn environment_light(n: vec3<f32>, v: vec3<f32>, base: vec3<f32>, metallic: f32, roughness: f32) -> vec3<f32> {
    let intensity = frame.environment.z;
    let nv = clamp(dot(n, v), 1e-4, 1.0);
    let r = reflect(-v, n);
    let lod = roughness * (frame.environment.w - 1.0);
    let radiance = decode_radiance(textureSampleLevel(environment_specular, environment_sampler, equirect_uv(environment_direction(r)), lod));
    let irradiance = sh_irradiance(environment_direction(n));
    let ab = environment_ab(roughness, nv);
    let dielectric = scattering(vec3<f32>(0.04), ab);
    let metal = scattering(base, ab);
    let single = mix(dielectric.single, metal.single, metallic);
    let multiple = mix(dielectric.multiple, metal.multiple, metallic);
    let diffuse = base * (1.0 - metallic) * (vec3<f32>(1.0) - dielectric.single - dielectric.multiple);
    return (single * radiance + (multiple + diffuse) * irradiance) * intensity;
}

/// The hemisphere's radiance from direction `d` (sky above, ground below).
fn hemisphere(d: vec3<f32>) -> vec3<f32> {
    return mix(frame.ground_color.rgb, frame.sky_color.rgb, d.y * 0.5 + 0.5);
}

@fragment
fn fs_main(in: VsOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    // Derivatives and texture sampling first: they need uniform control flow (the material's
    // flags are uniform, so its optional textures are sampled only where it has them).
    let dpx = dpdx(in.world_pos);
    let dpy = dpdy(in.world_pos);
    let face = cross(dpy, dpx);
    let flags = material.flags.x;
    let texel = textureSample(base_texture, base_sampler, texture_uv(TEX_BASE, in));
    var metallic_roughness = vec4<f32>(1.0);
    if (TEXTURES & (MATERIAL_METALLIC_ROUGHNESS_TEXTURE >> 3u)) != 0u && (flags & MATERIAL_METALLIC_ROUGHNESS_TEXTURE) != 0u {
        metallic_roughness = textureSample(metallic_roughness_texture, metallic_roughness_sampler, texture_uv(TEX_METALLIC_ROUGHNESS, in));
    }
    let normal_uv = texture_uv(TEX_NORMAL, in);
    let duvx = dpdx(normal_uv);
    let duvy = dpdy(normal_uv);
    var normal_texel = vec4<f32>(0.5, 0.5, 1.0, 1.0);
    let normal_mapped = (TEXTURES & (MATERIAL_NORMAL_TEXTURE >> 3u)) != 0u && (flags & MATERIAL_NORMAL_TEXTURE) != 0u;
    if normal_mapped {
        normal_texel = textureSample(normal_texture, normal_sampler, normal_uv);
    }
    var occlusion = 1.0;
    if (TEXTURES & (MATERIAL_OCCLUSION_TEXTURE >> 3u)) != 0u && (flags & MATERIAL_OCCLUSION_TEXTURE) != 0u {
        let ao = textureSample(occlusion_texture, occlusion_sampler, texture_uv(TEX_OCCLUSION, in)).r;
        occlusion = 1.0 + material.pbr.w * (ao - 1.0);
    }
    var emissive = material.emissive.rgb;
    if (TEXTURES & (MATERIAL_EMISSIVE_TEXTURE >> 3u)) != 0u && (flags & MATERIAL_EMISSIVE_TEXTURE) != 0u {
        emissive *= textureSample(emissive_texture, emissive_sampler, texture_uv(TEX_EMISSIVE, in)).rgb;
    }

    var color = material.base_color * texel * in.color;
    var metallic = clamp(material.pbr.x * metallic_roughness.b, 0.0, 1.0);
    // A perfectly smooth surface's highlight would be a point no pixel hits (and GGX divides by
    // zero there): roughness stays at or above MIN_ROUGHNESS, as three.js and Filament keep it.
    var roughness = clamp(material.pbr.y * metallic_roughness.g, MIN_ROUGHNESS, 1.0);
    let heatmap = HEATMAP != 0u && (draw.params.y & DRAW_HEATMAP) != 0u;
    if heatmap {
        color = vec4<f32>(in.color.rgb, 1.0);
        metallic = 0.0;
        roughness = 0.8;
        emissive = vec3<f32>(0.0);
    }
    if (flags & MATERIAL_ALPHA_MASK) != 0u {
        if color.a < material.emissive.w {
            discard;
        }
        color.a = 1.0;
    } else if (flags & MATERIAL_ALPHA_BLEND) == 0u {
        color.a = 1.0;
    }

    let to_eye = frame.camera_pos.xyz - in.world_pos;
    var n: vec3<f32>;
    // Only a zero normal is missing: one skinned with a tiny scale is short, not absent (the
    // cofactor of a matrix that scales by s scales normals by s²; gltfpack's quantized meshes
    // fold a dequantization scale of ~1e-4 into the inverse bind matrices).
    let vertex_len2 = dot(in.normal, in.normal);
    if (draw.params.y & DRAW_HAS_NORMALS) != 0u && vertex_len2 > 1e-36 {
        n = in.normal * inverseSqrt(vertex_len2);
        if !front {
            n = -n;
        }
    } else {
        // Flat normal from screen-space derivatives, turned towards the eye (the sign of
        // dpdy differs between backends).
        let face_len2 = dot(face, face);
        if face_len2 > 1e-30 {
            n = face * inverseSqrt(face_len2);
        } else {
            n = normalize(to_eye + vec3<f32>(0.0, 1e-6, 0.0));
        }
        if dot(n, to_eye) < 0.0 {
            n = -n;
        }
    }

    if normal_mapped && !heatmap {
        let t = normal_texel.xyz * 2.0 - 1.0;
        let scaled = vec3<f32>(t.xy * material.pbr.z, t.z);
        // The vertex's tangent frame where the primitive has tangents (and normals: glTF ignores
        // tangents without them), as the Khronos sample viewer builds it: the tangent made
        // orthogonal to the normal, the bitangent cross(normal, tangent) · w, all three turned
        // round on back faces.
        let tangent = in.tangent.xyz - n * dot(n, in.tangent.xyz);
        let tangent_len2 = dot(tangent, tangent);
        if abs(in.tangent.w) > 0.5 && tangent_len2 > 1e-30 && (draw.params.y & DRAW_HAS_NORMALS) != 0u && vertex_len2 > 1e-36 {
            let face_sign = select(-1.0, 1.0, front);
            let tn = tangent * (inverseSqrt(tangent_len2) * face_sign);
            let bn = cross(n * face_sign, tn * face_sign) * (sign(in.tangent.w) * face_sign);
            let perturbed = tn * scaled.x + bn * scaled.y + n * scaled.z;
            let p2 = dot(perturbed, perturbed);
            n = select(n, perturbed * inverseSqrt(p2), p2 > 1e-30);
        } else {
            // Screen-right × screen-up on the surface faces the eye: where dpdy runs down the
            // screen the cross product faces away, and the y derivatives are turned round.
            let up = select(-1.0, 1.0, dot(cross(dpx, dpy), to_eye) >= 0.0);
            n = perturb_normal(n, dpx, dpy * up, duvx, duvy * up, scaled);
        }
    }
    let v = normalize(to_eye + vec3<f32>(0.0, 1e-9, 0.0));
    let c_diff = color.rgb * (1.0 - metallic);
    let f0 = mix(vec3<f32>(0.04), color.rgb, metallic);
    let alpha = roughness * roughness;
    let radiance = frame.light_color.rgb * frame.light_dir.w;
    var rgb = direct_light(n, v, frame.light_dir.xyz, c_diff, f0, alpha, radiance);
    if ENVIRONMENT == 1u || (ENVIRONMENT == 2u && frame.environment.z > 0.0) {
        rgb += environment_light(n, v, color.rgb, metallic, roughness) * occlusion;
    } else {
        // Without an environment (a device that cannot prefilter one), the hemisphere: diffuse
        // from around the normal, specular from around the reflection (the normal's side for
        // rough surfaces), weighted by the analytic environment BRDF; occlusion dims both.
        let nv = clamp(dot(n, v), 1e-4, 1.0);
        let reflected = mix(hemisphere(reflect(-v, n)), hemisphere(n), roughness);
        let ab = environment_ab(roughness, nv);
        rgb += (c_diff * hemisphere(n) + reflected * (f0 * ab.x + ab.y)) * occlusion;
    }
    rgb += emissive;
    // An unlit material's colour replaces the lit one here rather than returning early: a GPU that
    // is the CPU runs both sides of a branch, and the tone mapping and output once are cheaper.
    if (flags & MATERIAL_UNLIT) != 0u {
        rgb = color.rgb;
    } else if heatmap {
        return scene_output(vec4<f32>(rgb, color.a));
    }
    return scene_output(vec4<f32>(tone_map(rgb), color.a));
}
