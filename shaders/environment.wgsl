// Kloub environment: background gradient, the ground grid and the character's ground shadow.
//
// Valid on WebGPU, native and WebGL2 (wgpu downlevel). No vertex buffers: both passes
// generate their vertices from the vertex index.
// The Frame struct is shared with mesh.wgsl and must stay identical.

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

@group(0) @binding(0) var<uniform> frame: Frame;

struct BackgroundOut {
    @builtin(position) clip: vec4<f32>,
    // 0 at the bottom of the view, 1 at the top.
    @location(0) height: f32,
}

/// One triangle covering the whole viewport.
@vertex
fn vs_background(@builtin(vertex_index) index: u32) -> BackgroundOut {
    let x = f32((index << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(index & 2u) * 2.0 - 1.0;
    var out: BackgroundOut;
    out.clip = vec4<f32>(x, y, 0.0, 1.0);
    out.height = y * 0.5 + 0.5;
    return out;
}

@fragment
fn fs_background(in: BackgroundOut) -> @location(0) vec4<f32> {
    let t = clamp(in.height, 0.0, 1.0);
    return scene_output(vec4<f32>(mix(frame.background_bottom.rgb, frame.background_top.rgb, t * t), 1.0));
}

struct GridOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world_pos: vec3<f32>,
}

/// Vertex `index` of a rectangle on the ground plane (two triangles) centred on `center` (x, z)
/// with half sizes `half` (along x, z).
fn ground_rectangle(index: u32, center: vec2<f32>, half: vec2<f32>) -> GridOut {
    // Corners of the two triangles: (0,1,2) and (2,1,3) of the unit square.
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0),
        vec2<f32>(-1.0, 1.0),
        vec2<f32>(1.0, -1.0),
        vec2<f32>(1.0, -1.0),
        vec2<f32>(-1.0, 1.0),
        vec2<f32>(1.0, 1.0),
    );
    let c = center + corners[index % 6u] * half;
    let world = vec3<f32>(c.x, frame.grid.x, c.y);
    var out: GridOut;
    out.clip = frame.view_proj * vec4<f32>(world, 1.0);
    out.world_pos = world;
    return out;
}

/// A square on the ground plane, centred on `frame.grid_center`.
@vertex
fn vs_grid(@builtin(vertex_index) index: u32) -> GridOut {
    return ground_rectangle(index, frame.grid_center.xz, vec2<f32>(frame.grid.w));
}

/// Coverage (0..1) of anti-aliased lines about one pixel wide at integer values of `coord`,
/// whose screen-space change per pixel is `width`.
fn line_coverage(coord: vec2<f32>, width: vec2<f32>) -> f32 {
    let distance = abs(fract(coord - 0.5) - 0.5) / width;
    return 1.0 - min(min(distance.x, distance.y), 1.0);
}

@fragment
fn fs_grid(in: GridOut) -> @location(0) vec4<f32> {
    let coord = in.world_pos.xz / frame.grid.y;
    // One derivative for every line set (each costs a software rasteriser dearly).
    let width = max(fwidth(coord), vec2<f32>(1e-6));
    // Minor lines fade out where cells shrink to a few pixels (no moire in the distance).
    let density = max(width.x, width.y);
    let minor = line_coverage(coord, width) * (1.0 - smoothstep(0.15, 0.4, density));
    let major = line_coverage(coord * 0.1, width * 0.1);
    // The world axes through the origin: X reddish, Z bluish.
    let axis = min(abs(coord) / width, vec2<f32>(1.0));
    let on_z_axis = 1.0 - axis.x;
    let on_x_axis = 1.0 - axis.y;

    let distance = length(in.world_pos.xz - frame.grid_center.xz);
    let fade = 1.0 - smoothstep(frame.grid.z * 0.25, frame.grid.z, distance);

    var color = vec3<f32>(0.55, 0.57, 0.6);
    var alpha = max(minor * 0.35, major * 0.7);
    color = mix(color, vec3<f32>(0.8, 0.3, 0.3), on_x_axis);
    color = mix(color, vec3<f32>(0.3, 0.45, 0.85), on_z_axis);
    alpha = max(alpha, max(on_x_axis, on_z_axis) * 0.85) * fade;
    // Most of the quad lies between the lines: no blend where nothing would show (under half a
    // level of 8-bit colour). Saves little on SwiftShader (~1 ms of ~11: the fragment count costs).
    if alpha < 1.0 / 512.0 {
        discard;
    }
    return scene_output(vec4<f32>(color, alpha));
}

// The ground shadow, in two passes with group 1 laid out for each:
//   1. the mask (`vs_shadow_mask`, `fs_shadow_mask`; bindings 0–2): a small texture over the
//      ground rectangle under the character, each texel how much of the key light the shadow
//      map (drawn by the meshes' depth-only caster pipelines) says is blocked there, softened
//      by percentage-closer filtering — a fixed cost, whatever the size of the view;
//   2. the ground (`vs_shadow`, `fs_shadow`; bindings 0, 3, 4): the rectangle in the view,
//      darkened by one filtered lookup of the mask per pixel.
struct Shadow {
    // World to the shadow map's clip space (orthographic, along the light).
    light_view_proj: mat4x4<f32>,
    // x: intensity (0..1), y: filter radius in texels, z: 1 / map size.
    params: vec4<f32>,
    // The quad on the ground: x, y: its centre's x and z; z, w: its half sizes along x and z
    // (where the character's box can throw its shadow).
    quad: vec4<f32>,
}

@group(1) @binding(0) var<uniform> shadow: Shadow;
@group(1) @binding(1) var shadow_map: texture_depth_2d;
@group(1) @binding(2) var shadow_sampler: sampler_comparison;
@group(1) @binding(3) var shadow_mask: texture_2d<f32>;
@group(1) @binding(4) var shadow_mask_sampler: sampler;

/// One triangle over the whole mask: texel (u, v) of the mask is the ground at (x, z) = the
/// rectangle's centre + (2u − 1, 2v − 1) × its half sizes.
@vertex
fn vs_shadow_mask(@builtin(vertex_index) index: u32) -> GridOut {
    let c = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u)) * 2.0 - 1.0;
    let xz = shadow.quad.xy + vec2<f32>(c.x, -c.y) * shadow.quad.zw;
    var out: GridOut;
    out.clip = vec4<f32>(c, 0.0, 1.0);
    out.world_pos = vec3<f32>(xz.x, frame.grid.x, xz.y);
    return out;
}

/// The shadow's rectangle on the ground.
@vertex
fn vs_shadow(@builtin(vertex_index) index: u32) -> GridOut {
    return ground_rectangle(index, shadow.quad.xy, shadow.quad.zw);
}

/// The ground darkened by the mask (which holds coverage only: the intensity is applied here).
@fragment
fn fs_shadow(in: GridOut) -> @location(0) vec4<f32> {
    let uv = (in.world_pos.xz - shadow.quad.xy) / max(shadow.quad.zw, vec2<f32>(1e-6)) * 0.5 + 0.5;
    let alpha = textureSampleLevel(shadow_mask, shadow_mask_sampler, uv, 0.0).r * shadow.params.x;
    if alpha < 1.0 / 512.0 {
        discard;
    }
    // Black, the same encoded or not: no `scene_output` (its sRGB encoding costs three `pow`s a
    // pixel where the shader encodes, over the whole rectangle).
    return vec4<f32>(0.0, 0.0, 0.0, alpha);
}

/// One tap of the shadow map: 0 where the map's depth at `uv + offset` is nearer the light than
/// `depth`, 1 where not (a hardware 2×2 comparison).
fn shadow_tap(uv: vec2<f32>, offset: vec2<f32>, depth: f32) -> f32 {
    return textureSampleCompareLevel(shadow_map, shadow_sampler, uv + offset, depth);
}

/// How much of the key light is blocked at a texel of the mask (0..1), faded out at the rim.
@fragment
fn fs_shadow_mask(in: GridOut) -> @location(0) vec4<f32> {
    let light = shadow.light_view_proj * vec4<f32>(in.world_pos, 1.0);
    let uv = vec2<f32>(light.x * 0.5 + 0.5, 0.5 - light.y * 0.5);
    // The ground itself casts nothing: what is above it in the map is a little nearer the light.
    let depth = light.z - 0.002;
    // A Poisson disc of 16 taps, each a hardware 2×2 comparison; the first four lie near its edge,
    // one each way. Written out tap by tap: a local array indexed in a loop is built per pixel
    // and read by a gather on a CPU rasterizer (SwiftShader), which cost more than the taps.
    let r = shadow.params.y * shadow.params.z;
    // Four taps at the disc's edge first: where they agree (most of the quad: wholly lit or
    // wholly shadowed) the other twelve would too.
    var lit = shadow_tap(uv, vec2<f32>(-0.94201624, -0.39906216) * r, depth)
        + shadow_tap(uv, vec2<f32>(0.94558609, -0.76890725) * r, depth)
        + shadow_tap(uv, vec2<f32>(-0.24188840, 0.99706507) * r, depth)
        + shadow_tap(uv, vec2<f32>(0.44323325, -0.97511554) * r, depth);
    if lit > 0.0 && lit < 4.0 {
        lit += shadow_tap(uv, vec2<f32>(-0.91588581, 0.45771432) * r, depth)
            + shadow_tap(uv, vec2<f32>(-0.81544232, -0.87912464) * r, depth)
            + shadow_tap(uv, vec2<f32>(-0.38277543, 0.27676845) * r, depth)
            + shadow_tap(uv, vec2<f32>(0.97484398, 0.75648379) * r, depth)
            + shadow_tap(uv, vec2<f32>(-0.09418410, -0.92938870) * r, depth)
            + shadow_tap(uv, vec2<f32>(0.53742981, -0.47373420) * r, depth)
            + shadow_tap(uv, vec2<f32>(-0.26496911, -0.41893023) * r, depth)
            + shadow_tap(uv, vec2<f32>(0.79197514, 0.19090188) * r, depth)
            + shadow_tap(uv, vec2<f32>(0.34495938, 0.29387760) * r, depth)
            + shadow_tap(uv, vec2<f32>(-0.81409955, 0.91437590) * r, depth)
            + shadow_tap(uv, vec2<f32>(0.19984126, 0.78641367) * r, depth)
            + shadow_tap(uv, vec2<f32>(0.14383161, -0.14100790) * r, depth);
        lit /= 16.0;
    } else {
        lit /= 4.0;
    }
    // Faded out at the rectangle's rim (the shadow should end inside it).
    let edge = abs(in.world_pos.xz - shadow.quad.xy) / max(shadow.quad.zw, vec2<f32>(1e-6));
    let fade = 1.0 - smoothstep(0.85, 1.0, max(edge.x, edge.y));
    return vec4<f32>((1.0 - lit) * fade, 0.0, 0.0, 1.0);
}
