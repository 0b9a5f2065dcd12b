//! The morph texture: every GPU-morphed primitive's target deltas in one `rgba32float`
//! texture, read by the vertex shader (`morphed` in mesh.wgsl) before skinning.
//!
//! Layout: a primitive placed at texel `base` with `n` vertices stores target `t`, vertex `v`
//! at texels `base + (t·n + v)·s` (position delta), `+ 1` (normal delta, zero when the
//! target has none) and, with `s = 3` where the primitive's tangents are used, `+ 2` (tangent
//! delta; else `s = 2`), row-major over [`MORPH_WIDTH`] texels. Like the palette it is a texture,
//! not a storage buffer, so WebGL2 morphs on the GPU too. Primitives with more than
//! [`MAX_GPU_TARGETS`] targets, or that would grow the texture past the device's limit, are
//! left out and morphed on the CPU.

use std::collections::HashMap;

use kloub_core::asset::{Asset, Primitive};

/// Width of the morph texture in texels (WebGL2 guarantees 2048).
pub const MORPH_WIDTH: u32 = 2048;
/// Most morph targets one draw applies on the GPU (the draw uniform holds 16 × 4 weights).
pub const MAX_GPU_TARGETS: usize = 64;
/// Largest morph texture, in texels (64 MiB of rgba32float).
const MAX_TEXELS: u64 = 4 << 20;

/// Where one primitive's targets live in the texture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MorphSlot {
    /// First texel.
    pub base: u32,
    /// Number of targets.
    pub targets: u32,
    /// Vertices per target.
    pub vertices: u32,
    /// Whether any target carries normal deltas.
    pub normals: bool,
    /// Whether the targets' tangent deltas are stored (three texels per vertex and target).
    pub tangents: bool,
}

impl MorphSlot {
    /// The draw uniform's `morph.w`: `MORPH_NORMALS` | `MORPH_TANGENTS` (skinning.wgsl).
    pub fn flags(&self) -> u32 {
        u32::from(self.normals) | (u32::from(self.tangents) << 1)
    }
}

/// The texture and where each (mesh, primitive) went.
#[derive(Clone)]
pub struct MorphTexture {
    view: wgpu::TextureView,
    slots: HashMap<(usize, usize), MorphSlot>,
}

impl MorphTexture {
    /// Packs the targets of `primitives` ((mesh, primitive) pairs of `asset`; repeats and
    /// primitives without targets are skipped) and uploads them.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        asset: &Asset,
        primitives: impl IntoIterator<Item = (usize, usize)>,
    ) -> Self {
        let max_rows = u64::from(device.limits().max_texture_dimension_2d);
        let limit = MAX_TEXELS.min(max_rows * u64::from(MORPH_WIDTH));
        let mut slots = HashMap::new();
        let mut texels: Vec<[f32; 4]> = Vec::new();
        for (mesh, primitive) in primitives {
            let Some(p) = asset.meshes.get(mesh).and_then(|m| m.primitives.get(primitive)) else {
                continue;
            };
            if slots.contains_key(&(mesh, primitive)) || p.targets.is_empty() || p.targets.len() > MAX_GPU_TARGETS {
                continue;
            }
            let tangents = p.has_tangents() && p.targets.iter().any(|t| !t.tangents.is_empty());
            let needed = (2 + u64::from(tangents)) * p.targets.len() as u64 * p.positions.len() as u64;
            if texels.len() as u64 + needed > limit {
                log::info!(
                    "mesh {mesh} primitive {primitive}: morph targets exceed the GPU texture; morphing on the CPU"
                );
                continue;
            }
            let base = texels.len() as u32;
            pack(p, tangents, &mut texels);
            slots.insert(
                (mesh, primitive),
                MorphSlot {
                    base,
                    targets: p.targets.len() as u32,
                    vertices: p.positions.len() as u32,
                    normals: p.targets.iter().any(|t| !t.normals.is_empty()),
                    tangents,
                },
            );
        }
        let rows = (texels.len() as u64).div_ceil(u64::from(MORPH_WIDTH)).max(1) as u32;
        texels.resize((rows * MORPH_WIDTH) as usize, [0.0; 4]);
        let size = wgpu::Extent3d { width: MORPH_WIDTH, height: rows, depth_or_array_layers: 1 };
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("kloub morph targets"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        queue.write_texture(
            texture.as_image_copy(),
            bytemuck::cast_slice(&texels),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(MORPH_WIDTH * 16),
                rows_per_image: Some(rows),
            },
            size,
        );
        Self { view: texture.create_view(&wgpu::TextureViewDescriptor::default()), slots }
    }

    /// An empty texture (nothing morphs on the GPU).
    pub fn empty(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        Self::new(device, queue, &Asset::default(), [])
    }

    /// The view bound to the vertex shader.
    pub fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    /// Where the targets of `mesh`'s `primitive` are, when they are on the GPU.
    pub fn slot(&self, mesh: usize, primitive: usize) -> Option<MorphSlot> {
        self.slots.get(&(mesh, primitive)).copied()
    }
}

fn pack(p: &Primitive, tangents: bool, texels: &mut Vec<[f32; 4]>) {
    for target in &p.targets {
        for v in 0..p.positions.len() {
            let [x, y, z] = target.positions.get(v).copied().unwrap_or_default();
            let [nx, ny, nz] = target.normals.get(v).copied().unwrap_or_default();
            texels.push([x, y, z, 0.0]);
            texels.push([nx, ny, nz, 0.0]);
            if tangents {
                let [tx, ty, tz] = target.tangents.get(v).copied().unwrap_or_default();
                texels.push([tx, ty, tz, 0.0]);
            }
        }
    }
}
