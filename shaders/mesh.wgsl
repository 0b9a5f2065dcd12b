// Kloub mesh shader: static and GPU-skinned (linear blend skinning) vertices, base colour
// texture, vertex colours, hemisphere + directional lighting, unlit, alpha mask/blend.
//
// Valid on WebGPU, native and WebGL2 (wgpu downlevel): no storage buffers, no compute.
// The joint palette lives in an rgba32float texture read with textureLoad, three texels per
// joint (the rows of the affine 3x4 matrix), so any joint count fits and WebGL2 works.
//
// Bind groups:
//   0: Frame uniform (camera, lights) + joint palette texture      (per frame)
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

struct Draw {
    // Object to world (static path); identity for vertices already in world space.
    model: mat4x4<f32>,
    // Inverse transpose of `model` (upper 3x3 used).
    normal_matrix: mat4x4<f32>,
    // x: first palette joint of this draw's skin, y: flags (DRAW_* below).
    params: vec4<u32>,
}

const MATERIAL_UNLIT: u32 = 1u;
const MATERIAL_ALPHA_MASK: u32 = 2u;
const MATERIAL_ALPHA_BLEND: u32 = 4u;
const DRAW_HAS_NORMALS: u32 = 1u;

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var palette: texture_2d<f32>;
@group(1) @binding(0) var<uniform> material: Material;
@group(1) @binding(1) var base_texture: texture_2d<f32>;
@group(1) @binding(2) var base_sampler: sampler;
@group(2) @binding(0) var<uniform> draw: Draw;

struct GeometryIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec4<f32>,
}

struct SkinIn {
    @location(4) joints0: vec4<u32>,
    @location(5) joints1: vec4<u32>,
    @location(6) weights0: vec4<f32>,
    @location(7) weights1: vec4<f32>,
}

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
    let world = draw.model * vec4<f32>(g.position, 1.0);
    let normal = (draw.normal_matrix * vec4<f32>(g.normal, 0.0)).xyz;
    return finish(world.xyz, normal, g);
}

/// Row `r` (0..3) of palette joint `joint` (an absolute index into the palette texture).
fn palette_row(joint: u32, r: u32) -> vec4<f32> {
    let width = textureDimensions(palette).x;
    let texel = joint * 3u + r;
    return textureLoad(palette, vec2<u32>(texel % width, texel / width), 0);
}

/// A skinning matrix as its three affine rows.
struct Rows {
    r0: vec4<f32>,
    r1: vec4<f32>,
    r2: vec4<f32>,
}

fn add_influence(acc: Rows, joint: u32, weight: f32) -> Rows {
    if weight == 0.0 {
        return acc;
    }
    let j = draw.params.x + joint;
    return Rows(
        acc.r0 + weight * palette_row(j, 0u),
        acc.r1 + weight * palette_row(j, 1u),
        acc.r2 + weight * palette_row(j, 2u),
    );
}

/// `n` by the inverse transpose of the blended 3x3 (its cofactor matrix, signed by the
/// determinant), as kloub_core's CPU reference does; the fragment shader renormalizes.
fn cofactor_normal(m: Rows, n: vec3<f32>) -> vec3<f32> {
    let c0 = vec3<f32>(m.r0.x, m.r1.x, m.r2.x);
    let c1 = vec3<f32>(m.r0.y, m.r1.y, m.r2.y);
    let c2 = vec3<f32>(m.r0.z, m.r1.z, m.r2.z);
    let x = cross(c1, c2);
    let sign = select(1.0, -1.0, dot(c0, x) < 0.0);
    return sign * (n.x * x + n.y * cross(c2, c0) + n.z * cross(c0, c1));
}

/// Linear blend skinning, matrices blended first (3n + 6 form), up to 8 influences.
/// The palette is in world space (joint world * inverse bind), so the mesh node's own
/// transform is ignored, as glTF requires.
@vertex
fn vs_skinned(g: GeometryIn, s: SkinIn) -> VsOut {
    var m = Rows(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    for (var i = 0u; i < 4u; i += 1u) {
        m = add_influence(m, s.joints0[i], s.weights0[i]);
        m = add_influence(m, s.joints1[i], s.weights1[i]);
    }
    let p = vec4<f32>(g.position, 1.0);
    let world = vec3<f32>(dot(m.r0, p), dot(m.r1, p), dot(m.r2, p));
    return finish(world, cofactor_normal(m, g.normal), g);
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
    let vertex_len2 = dot(in.normal, in.normal);
    if (draw.params.y & DRAW_HAS_NORMALS) != 0u && vertex_len2 > 1e-12 {
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
    return vec4<f32>(rgb, color.a);
}
