// Kloub skinning library: morph targets and the four skinning methods (rigid, linear blend,
// dual-quaternion, spherical joint blending; up to 8 influences), shared by mesh.wgsl (the
// vertex-shader path, WebGL2 included) and skin_compute.wgsl (the compute path on WebGPU and
// native). The Rust side prepends this file to each of them (pipelines.rs); the shader test
// validates the composed modules.
//
// Bindings it needs: group 0 binding 1 (joint palette texture), binding 2 (morph texture),
// group 2 binding 0 (the Draw uniform, dynamic offset).
// The joint palette is an rgba32float texture read with textureLoad, TEXELS_PER_JOINT texels
// per joint, so any joint count fits and WebGL2 works; morph target deltas live in a second
// rgba32float texture (two texels per vertex and target).

struct Draw {
    // Object to world (static path); for vertices already in world space (skinned, CPU
    // deformed) the placement of the character's copy (identity for the first).
    model: mat4x4<f32>,
    // Inverse transpose of `model` (upper 3x3 used).
    normal_matrix: mat4x4<f32>,
    // x: first palette joint of this draw's skin, y: flags (DRAW_* below),
    // z: skinning method (SKIN_* below), w: capture target width | height << 16 (vs_capture_*).
    params: vec4<u32>,
    // Morph targets in the morph texture: x: first texel, y: target count (0: none),
    // z: vertex count, w: MORPH_NORMALS | MORPH_TANGENTS (which deltas the targets carry).
    morph: vec4<u32>,
    // Morph weights, four per vec4 (target t: weights[t / 4][t % 4]).
    weights: array<vec4<f32>, 16>,
    // Deviation heatmap (DRAW_HEATMAP): x: the distance drawn fully red.
    heat: vec4<f32>,
}

const MORPH_NORMALS: u32 = 1u;
// With tangent deltas each vertex of each target takes three texels, else two.
const MORPH_TANGENTS: u32 = 2u;

const SKIN_RIGID: u32 = 0u;
const SKIN_LINEAR: u32 = 1u;
const SKIN_DUAL_QUATERNION: u32 = 2u;
const SKIN_SPHERICAL: u32 = 3u;
// Texels per joint in the palette texture: the three rows of the skinning matrix, the
// rotation quaternion, the dual part, and the three rows of the stretch (w of the first:
// 1 when the joint is rigid).
const TEXELS_PER_JOINT: u32 = 8u;
// Pipeline-overridable specialisation: a mesh pipeline built for one skinning method (SKIN_*)
// and without the heatmap compiles only that code (a CPU rasterizer such as SwiftShader runs
// every branch of a vertex shader otherwise). The defaults read both from the draw (compute pass,
// capture pipelines).
const SKIN_FROM_DRAW: u32 = 4u;
override SKIN_METHOD: u32 = 4u;
override HEATMAP: u32 = 1u;
// Whether the draw's tangent stream is read (a normal-mapped primitive with tangents): without,
// the pipeline compiles no tangent fetch or transform (0, the tangent stays zero).
override TANGENTS: u32 = 1u;

/// The draw's skinning method: the pipeline's when it was built for one, else the draw's own.
fn draw_method() -> u32 {
    if SKIN_METHOD < SKIN_FROM_DRAW {
        return SKIN_METHOD;
    }
    return draw.params.z;
}

// The palette texture's width in texels (render::palette::PALETTE_WIDTH; a test keeps them equal).
const PALETTE_WIDTH: u32 = 768u;
const NO_PIVOT: u32 = 0xffffffffu;

@group(0) @binding(1) var palette: texture_2d<f32>;
@group(0) @binding(2) var morphs: texture_2d<f32>;
@group(2) @binding(0) var<uniform> draw: Draw;

struct GeometryIn {
    @builtin(vertex_index) index: u32,
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec4<f32>,
    @location(10) uv1: vec2<f32>,
    // The tangent (xyz) and the bitangent's sign (w); all zero where the primitive has none.
    @location(11) tangent: vec4<f32>,
}

struct SkinIn {
    @location(4) joints0: vec4<u32>,
    @location(5) joints1: vec4<u32>,
    @location(6) weights0: vec4<f32>,
    @location(7) weights1: vec4<f32>,
    // Spherical joint blending: the joint centre in bind space, and the joint carrying it
    // (low 16 bits) and the joint deciding quaternion signs (high 16 bits), or NO_PIVOT.
    @location(8) pivot: vec3<f32>,
    @location(9) pivot_joints: u32,
}

/// A position, normal and tangent on their way through the vertex stage (the tangent moves
/// as a direction along the surface: the skinning transform without its translation).
struct Vertex {
    position: vec3<f32>,
    normal: vec3<f32>,
    tangent: vec3<f32>,
}

/// Texel `i` of a row-major texture of any height.
fn texel_at(t: texture_2d<f32>, i: u32) -> vec4<f32> {
    let width = textureDimensions(t).x;
    return textureLoad(t, vec2<u32>(i % width, i / width), 0);
}

/// The bind-pose vertex plus the draw's weighted morph targets (glTF: before skinning).
fn morphed(g: GeometryIn) -> Vertex {
    var v = Vertex(g.position, g.normal, vec3<f32>(0.0));
    if TANGENTS != 0u {
        v.tangent = g.tangent.xyz;
    }
    let count = draw.morph.y;
    // The texture's layout follows the primitive; whether the deltas are read, the pipeline.
    let stored = (draw.morph.w & MORPH_TANGENTS) != 0u;
    let tangents = TANGENTS != 0u && stored;
    let stride = select(2u, 3u, stored);
    for (var t = 0u; t < count; t += 1u) {
        let w = draw.weights[t / 4u][t % 4u];
        if w == 0.0 {
            continue;
        }
        let texel = draw.morph.x + (t * draw.morph.z + g.index) * stride;
        v.position += w * texel_at(morphs, texel).xyz;
        if (draw.morph.w & MORPH_NORMALS) != 0u {
            v.normal += w * texel_at(morphs, texel + 1u).xyz;
        }
        if tangents {
            v.tangent += w * texel_at(morphs, texel + 2u).xyz;
        }
    }
    return v;
}

/// Where palette joint `joint` (skin-relative) starts: its TEXELS_PER_JOINT texels lie in one
/// row, PALETTE_WIDTH being a multiple of it (one division per joint, no size query).
fn joint_coord(joint: u32) -> vec2<u32> {
    let t = (draw.params.x + joint) * TEXELS_PER_JOINT;
    return vec2<u32>(t % PALETTE_WIDTH, t / PALETTE_WIDTH);
}

/// Texel `r` (0..TEXELS_PER_JOINT) of palette joint `joint` (skin-relative).
fn joint_texel(joint: u32, r: u32) -> vec4<f32> {
    let c = joint_coord(joint);
    return textureLoad(palette, vec2<u32>(c.x + r, c.y), 0);
}

/// A skinning matrix as its three affine rows.
struct Rows {
    r0: vec4<f32>,
    r1: vec4<f32>,
    r2: vec4<f32>,
}

fn joint_rows(joint: u32) -> Rows {
    let c = joint_coord(joint);
    return Rows(
        textureLoad(palette, c, 0),
        textureLoad(palette, vec2<u32>(c.x + 1u, c.y), 0),
        textureLoad(palette, vec2<u32>(c.x + 2u, c.y), 0),
    );
}

/// `m` plus joint `joint`'s rows weighted by `w`.
fn add_rows(m: Rows, w: f32, joint: u32) -> Rows {
    let j = joint_rows(joint);
    return Rows(m.r0 + w * j.r0, m.r1 + w * j.r1, m.r2 + w * j.r2);
}

fn transform_rows(m: Rows, p: vec3<f32>) -> vec3<f32> {
    let h = vec4<f32>(p, 1.0);
    return vec3<f32>(dot(m.r0, h), dot(m.r1, h), dot(m.r2, h));
}

/// The direction `d` through the 3x3 part of `m` (a tangent: no translation).
fn rotate_rows(m: Rows, d: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(m.r0.xyz, d), dot(m.r1.xyz, d), dot(m.r2.xyz, d));
}

/// Influence `k` (0..8) in kloub_core's order: JOINTS_0 then JOINTS_1.
fn joint_of(s: SkinIn, k: u32) -> u32 {
    if k < 4u {
        return s.joints0[k];
    }
    return s.joints1[k - 4u];
}

fn weight_of(s: SkinIn, k: u32) -> f32 {
    if k < 4u {
        return s.weights0[k];
    }
    return s.weights1[k - 4u];
}

/// The 3x3 `m` given by rows, applied to a normal as its cofactor matrix signed by the
/// determinant (the inverse transpose up to scale), as kloub_core's CPU reference does; the
/// fragment shader renormalizes.
fn cofactor_normal(r0: vec3<f32>, r1: vec3<f32>, r2: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let c0 = vec3<f32>(r0.x, r1.x, r2.x);
    let c1 = vec3<f32>(r0.y, r1.y, r2.y);
    let c2 = vec3<f32>(r0.z, r1.z, r2.z);
    let x = cross(c1, c2);
    let sign = select(1.0, -1.0, dot(c0, x) < 0.0);
    return sign * (n.x * x + n.y * cross(c2, c0) + n.z * cross(c0, c1));
}

/// Rotates `v` by the unit quaternion `q` (xyz: vector part, w: scalar part).
fn rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}

/// Linear blend skinning, matrices blended first (the 3n + 6 form).
fn skin_linear(v: Vertex, s: SkinIn) -> Vertex {
    // The first four influences without a loop or branches, the same sums in the same order as
    // skipping zero weights (a zero weight adds exactly zero: palettes are finite); the second
    // four only where the vertex has them. Loops with per-vertex branches cost a CPU rasterizer
    // (SwiftShader) several times more per vertex.
    var m = Rows(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    m = add_rows(m, s.weights0.x, s.joints0.x);
    m = add_rows(m, s.weights0.y, s.joints0.y);
    m = add_rows(m, s.weights0.z, s.joints0.z);
    m = add_rows(m, s.weights0.w, s.joints0.w);
    if any(s.weights1 != vec4<f32>(0.0)) {
        for (var k = 4u; k < 8u; k += 1u) {
            let w = weight_of(s, k);
            if w != 0.0 {
                m = add_rows(m, w, joint_of(s, k));
            }
        }
    }
    return Vertex(
        transform_rows(m, v.position),
        cofactor_normal(m.r0.xyz, m.r1.xyz, m.r2.xyz, v.normal),
        rotate_rows(m, v.tangent),
    );
}

/// The strongest influence only (ties: the first); no influence leaves the vertex in place.
fn skin_rigid(v: Vertex, s: SkinIn) -> Vertex {
    var best = NO_PIVOT;
    var best_w = 0.0;
    for (var k = 0u; k < 8u; k += 1u) {
        let w = weight_of(s, k);
        if w > 0.0 && (best == NO_PIVOT || w > best_w) {
            best = joint_of(s, k);
            best_w = w;
        }
    }
    if best == NO_PIVOT {
        return v;
    }
    let m = joint_rows(best);
    return Vertex(
        transform_rows(m, v.position),
        cofactor_normal(m.r0.xyz, m.r1.xyz, m.r2.xyz, v.normal),
        rotate_rows(m, v.tangent),
    );
}

/// Dual-quaternion skinning with hemisphere alignment to the first influence; joints with
/// scale or shear blend their stretches linearly and apply them first (kloub_core's
/// documented fallback).
fn skin_dual_quaternion(v: Vertex, s: SkinIn) -> Vertex {
    var real = vec4<f32>(0.0);
    var dual = vec4<f32>(0.0);
    var s0 = vec3<f32>(0.0);
    var s1 = vec3<f32>(0.0);
    var s2 = vec3<f32>(0.0);
    var all_rigid = true;
    var first = vec4<f32>(0.0);
    var have_first = false;
    for (var k = 0u; k < 8u; k += 1u) {
        let w = weight_of(s, k);
        if w == 0.0 {
            continue;
        }
        let j = joint_of(s, k);
        let q = joint_texel(j, 3u);
        if !have_first {
            first = q;
            have_first = true;
        }
        let ws = select(w, -w, dot(first, q) < 0.0);
        real += ws * q;
        dual += ws * joint_texel(j, 4u);
        let t0 = joint_texel(j, 5u);
        s0 += w * t0.xyz;
        s1 += w * joint_texel(j, 6u).xyz;
        s2 += w * joint_texel(j, 7u).xyz;
        all_rigid = all_rigid && t0.w > 0.5;
    }
    let len = length(real);
    if len > 1e-12 {
        real /= len;
        dual /= len;
    } else {
        real = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        dual = vec4<f32>(0.0);
        s0 = vec3<f32>(1.0, 0.0, 0.0);
        s1 = vec3<f32>(0.0, 1.0, 0.0);
        s2 = vec3<f32>(0.0, 0.0, 1.0);
    }
    var p = v.position;
    var n = v.normal;
    var tangent = v.tangent;
    if !all_rigid {
        p = vec3<f32>(dot(s0, p), dot(s1, p), dot(s2, p));
        n = cofactor_normal(s0, s1, s2, n);
        tangent = vec3<f32>(dot(s0, tangent), dot(s1, tangent), dot(s2, tangent));
    }
    // Translation: 2 · dual · conj(real).
    let t = 2.0 * (real.w * dual.xyz - dual.w * real.xyz + cross(real.xyz, dual.xyz));
    return Vertex(rotate(real, p) + t, rotate(real, n), rotate(real, tangent));
}

/// Spherical joint blending: rotation about the shared joint centre by the normalized,
/// sign-aligned quaternion sum; dual quaternions where the vertex has no centre or a joint
/// is scaled.
fn skin_spherical(v: Vertex, s: SkinIn) -> Vertex {
    if s.pivot_joints == NO_PIVOT {
        return skin_dual_quaternion(v, s);
    }
    let driver = joint_texel(s.pivot_joints >> 16u, 3u);
    var q = vec4<f32>(0.0);
    for (var k = 0u; k < 8u; k += 1u) {
        let w = weight_of(s, k);
        if w == 0.0 {
            continue;
        }
        let j = joint_of(s, k);
        if joint_texel(j, 5u).w < 0.5 {
            return skin_dual_quaternion(v, s);
        }
        let r = joint_texel(j, 3u);
        q += select(w, -w, dot(driver, r) < 0.0) * r;
    }
    let len = length(q);
    if len > 1e-12 {
        q /= len;
    } else {
        q = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let centre = transform_rows(joint_rows(s.pivot_joints & 0xffffu), s.pivot);
    return Vertex(rotate(q, v.position - s.pivot) + centre, rotate(q, v.normal), rotate(q, v.tangent));
}

/// Morph, then skin with the draw's method. The palette is in world space (joint world *
/// inverse bind), so the mesh node's own transform is ignored, as glTF requires.
fn skinned(g: GeometryIn, s: SkinIn) -> Vertex {
    return skin_with(morphed(g), s, draw_method());
}

/// Skins the (morphed) vertex `v` with `method` (a SKIN_* constant).
fn skin_with(v: Vertex, s: SkinIn, method: u32) -> Vertex {
    switch method {
        case SKIN_RIGID: {
            return skin_rigid(v, s);
        }
        case SKIN_DUAL_QUATERNION: {
            return skin_dual_quaternion(v, s);
        }
        case SKIN_SPHERICAL: {
            return skin_spherical(v, s);
        }
        default: {
            return skin_linear(v, s);
        }
    }
}
