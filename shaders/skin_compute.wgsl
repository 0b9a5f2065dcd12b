// Kloub compute skinning (WebGPU and native; WebGL2 has no compute): morphs and skins one
// primitive of one character copy per dispatch, one invocation per vertex, with the same
// `skinned()` as the vertex-shader path (skinning.wgsl, prepended by the Rust side), into a
// vertex buffer in the geometry-stream layout that the draws then read as static vertices.
//
// Bind groups:
//   0: joint palette + morph textures (binding 1, 2)           (per frame)
//   1: unused (keeps the group numbers of mesh.wgsl)
//   2: Draw uniform with a dynamic offset; params.w = vertex count (per dispatch)
//   3: the primitive's streams and the output                    (per primitive and copy)

// Geometry stream: position xyz, normal xyz per vertex.
@group(3) @binding(0) var<storage, read> geometry_in: array<f32>;
// Skin stream: 8 joints as u16 pairs (4 words), then 8 weights (their f32 bits).
@group(3) @binding(1) var<storage, read> skin_in: array<u32>;
// Pivot stream: the joint centre xyz (f32 bits), then its joints word.
@group(3) @binding(2) var<storage, read> pivots_in: array<u32>;
// Output in the geometry-stream layout.
@group(3) @binding(3) var<storage, read_write> geometry_out: array<f32>;
// Tangent stream (xyz, w: the bitangent's sign; zeros for none) and its output. A primitive
// without tangents binds a one-tangent output (WebGPU needs every binding bound), which this
// shader never writes: it writes only where w is not zero.
@group(3) @binding(4) var<storage, read> tangents_in: array<vec4<f32>>;
@group(3) @binding(5) var<storage, read_write> tangents_out: array<vec4<f32>>;

fn unpack_joints(a: u32, b: u32) -> vec4<u32> {
    return vec4<u32>(a & 0xffffu, a >> 16u, b & 0xffffu, b >> 16u);
}

fn word_f32(i: u32) -> f32 {
    return bitcast<f32>(skin_in[i]);
}

@compute @workgroup_size(64)
fn cs_skin(@builtin(global_invocation_id) id: vec3<u32>) {
    let v = id.x;
    if v >= draw.params.w {
        return;
    }
    let gi = v * 6u;
    var g: GeometryIn;
    g.index = v;
    g.position = vec3<f32>(geometry_in[gi], geometry_in[gi + 1u], geometry_in[gi + 2u]);
    g.normal = vec3<f32>(geometry_in[gi + 3u], geometry_in[gi + 4u], geometry_in[gi + 5u]);
    g.uv = vec2<f32>(0.0);
    g.uv1 = vec2<f32>(0.0);
    g.color = vec4<f32>(1.0);
    g.tangent = tangents_in[v];
    let si = v * 12u;
    var s: SkinIn;
    s.joints0 = unpack_joints(skin_in[si], skin_in[si + 1u]);
    s.joints1 = unpack_joints(skin_in[si + 2u], skin_in[si + 3u]);
    s.weights0 = vec4<f32>(word_f32(si + 4u), word_f32(si + 5u), word_f32(si + 6u), word_f32(si + 7u));
    s.weights1 = vec4<f32>(word_f32(si + 8u), word_f32(si + 9u), word_f32(si + 10u), word_f32(si + 11u));
    let pi = v * 4u;
    s.pivot = vec3<f32>(bitcast<f32>(pivots_in[pi]), bitcast<f32>(pivots_in[pi + 1u]), bitcast<f32>(pivots_in[pi + 2u]));
    s.pivot_joints = pivots_in[pi + 3u];
    let out = skinned(g, s);
    geometry_out[gi] = out.position.x;
    geometry_out[gi + 1u] = out.position.y;
    geometry_out[gi + 2u] = out.position.z;
    geometry_out[gi + 3u] = out.normal.x;
    geometry_out[gi + 4u] = out.normal.y;
    geometry_out[gi + 5u] = out.normal.z;
    if g.tangent.w != 0.0 {
        tangents_out[v] = vec4<f32>(out.tangent, g.tangent.w);
    }
}
