// Kloub equirectangular directions, shared by ibl.wgsl (prefiltering) and mesh.wgsl (lookup);
// web/src/render/environment.rs mirrors them on the CPU. u = 0.5 looks down −Z and u grows
// towards +X; v = 0 is straight up, v = 1 straight down.

const EQUIRECT_PI: f32 = 3.14159265358979;

/// The texture coordinates of unit direction `d`.
fn equirect_uv(d: vec3<f32>) -> vec2<f32> {
    let u = 0.5 + atan2(d.x, -d.z) / (2.0 * EQUIRECT_PI);
    let v = acos(clamp(d.y, -1.0, 1.0)) / EQUIRECT_PI;
    return vec2<f32>(u, v);
}

/// The unit direction of texture coordinates `uv`.
fn equirect_direction(uv: vec2<f32>) -> vec3<f32> {
    let phi = (uv.x - 0.5) * 2.0 * EQUIRECT_PI;
    let theta = uv.y * EQUIRECT_PI;
    return vec3<f32>(sin(theta) * sin(phi), cos(theta), -sin(theta) * cos(phi));
}
