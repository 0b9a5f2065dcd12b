// Kloub mesh shader: static, GPU-morphed and GPU-skinned vertices (skinning.wgsl, prepended
// by the Rust side), base colour texture, vertex colours, hemisphere + directional lighting,
// unlit, alpha mask/blend.
//
// Valid on WebGPU, native and WebGL2 (wgpu downlevel): no storage buffers, no compute.
//
// Bind groups:
//   0: Frame uniform (camera, lights) + joint palette + morph deltas (per frame)
//   1: Material uniform + base colour texture + sampler             (per material)
//   2: Draw uniform with a dynamic offset                           (per draw)
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
}

struct Material {
    // Linear RGBA base colour factor.
    base_color: vec4<f32>,
    // KHR_texture_transform as a 2D affine matrix: uv' = (a.xy * u + a.zw * v + b.xy).
    uv_a: vec4<f32>,
    uv_b: vec4<f32>,
    // rgb: emissive factor, w: alpha cutoff (mask mode).
    emissive: vec4<f32>,
    // x: flags (MATERIAL_* below).
    flags: vec4<u32>,
}

const MATERIAL_UNLIT: u32 = 1u;
const MATERIAL_ALPHA_MASK: u32 = 2u;
const MATERIAL_ALPHA_BLEND: u32 = 4u;
const DRAW_HAS_NORMALS: u32 = 1u;
// Colour skinned vertices by their distance from another method's result.
const DRAW_HEATMAP: u32 = 2u;

@group(0) @binding(0) var<uniform> frame: Frame;
@group(1) @binding(0) var<uniform> material: Material;
@group(1) @binding(1) var base_texture: texture_2d<f32>;
@group(1) @binding(2) var base_sampler: sampler;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world_pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec4<f32>,
}

fn finish(world_pos: vec3<f32>, normal: vec3<f32>, g: GeometryIn) -> VsOut {
    var out: VsOut;
    out.clip = frame.view_proj * vec4<f32>(world_pos, 1.0);
    out.world_pos = world_pos;
    out.normal = normal;
    out.uv = g.uv;
    out.color = g.color;
    return out;
}

/// Vertices transformed by the draw's model matrix (unskinned meshes, CPU-deformed vertices).
@vertex
fn vs_static(g: GeometryIn) -> VsOut {
    let v = morphed(g);
    let world = draw.model * vec4<f32>(v.position, 1.0);
    let normal = (draw.normal_matrix * vec4<f32>(v.normal, 0.0)).xyz;
    return finish(world.xyz, normal, g);
}

/// Skinned vertices are in world space; `draw.model` places a copy of the character (a
/// translation; the identity for the first).
@vertex
fn vs_skinned(g: GeometryIn, s: SkinIn) -> VsOut {
    let rest = morphed(g);
    let v = skin_with(rest, s, draw_method());
    let world = draw.model * vec4<f32>(v.position, 1.0);
    let normal = (draw.normal_matrix * vec4<f32>(v.normal, 0.0)).xyz;
    var out = finish(world.xyz, normal, g);
    if HEATMAP != 0u && (draw.params.y & DRAW_HEATMAP) != 0u {
        // Deviation from linear blend skinning (from dual quaternions when LBS is shown).
        let reference = select(SKIN_LINEAR, SKIN_DUAL_QUATERNION, draw_method() == SKIN_LINEAR);
        let other = skin_with(rest, s, reference);
        out.color = vec4<f32>(heat_color(distance(v.position, other.position) / max(draw.heat.x, 1e-20)), 1.0);
    }
    return out;
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

fn shade(base: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let hemi = mix(frame.ground_color.rgb, frame.sky_color.rgb, n.y * 0.5 + 0.5);
    let lambert = max(dot(n, frame.light_dir.xyz), 0.0) * frame.light_dir.w;
    return base * (hemi + lambert * frame.light_color.rgb);
}

@fragment
fn fs_main(in: VsOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    // Derivatives and texture sampling first: they need uniform control flow.
    let face = cross(dpdy(in.world_pos), dpdx(in.world_pos));
    let uv = material.uv_a.xy * in.uv.x + material.uv_a.zw * in.uv.y + material.uv_b.xy;
    let texel = textureSample(base_texture, base_sampler, uv);

    let flags = material.flags.x;
    var color = material.base_color * texel * in.color;
    if (draw.params.y & DRAW_HEATMAP) != 0u {
        color = vec4<f32>(in.color.rgb, 1.0);
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

    var rgb = color.rgb;
    if (flags & MATERIAL_UNLIT) == 0u {
        rgb = shade(color.rgb, n) + material.emissive.rgb;
    }
    return scene_output(vec4<f32>(rgb, color.a));
}
