//! The joint palette texture: every skin's skinning matrices, as affine 3×4 rows, and their
//! dual-quaternion split, in one `rgba32float` texture read by the vertex shader with
//! `textureLoad`.
//!
//! Layout: joint `j` (absolute: a skin's first joint plus the joint index) occupies texels
//! `8j .. 8j+8` in row-major order over a texture [`PALETTE_WIDTH`] texels wide: rows 0–2 of
//! the matrix, the rotation quaternion, its dual part, and rows 0–2 of the stretch with `w`
//! of the first set to 1 when the joint is rigid (`TEXELS_PER_JOINT` in mesh.wgsl). The
//! dual-quaternion texels are written only for the methods that read them. Textures (not
//! storage buffers) keep this working on WebGL2; the width keeps any joint count inside the
//! 2048-texel limit of WebGL2 for up to 196 608 joints.

use glam::Mat4;
use kloub_core::job::dqs::JointDq;

/// Width of the palette texture in texels (a multiple of 8: a joint never straddles rows).
pub const PALETTE_WIDTH: u32 = 768;

/// Texels per joint.
pub const TEXELS_PER_JOINT: u32 = 8;

/// CPU staging and GPU texture of the joint palette.
pub struct PaletteTexture {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    texels: Vec<[f32; 4]>,
    height: u32,
}

impl PaletteTexture {
    /// A palette with room for `joints` joints (at least one row); fails when the texture
    /// would exceed the device's size limit.
    pub fn new(device: &wgpu::Device, joints: u32) -> Result<Self, String> {
        let texels = u64::from(joints) * u64::from(TEXELS_PER_JOINT);
        let height = texels.div_ceil(u64::from(PALETTE_WIDTH)).max(1);
        let max = device.limits().max_texture_dimension_2d;
        match u32::try_from(height) {
            Ok(height) if height <= max => Ok(Self::with_rows(device, height)),
            _ => Err(format!("{joints} joints do not fit a {PALETTE_WIDTH}x{max} palette texture")),
        }
    }

    /// A palette of `height` rows (1 ≤ `height` ≤ the device's texture size limit).
    pub fn with_rows(device: &wgpu::Device, height: u32) -> Self {
        let height = height.max(1);
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("kloub joint palette"),
            size: wgpu::Extent3d { width: PALETTE_WIDTH, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let texels = vec![[0.0; 4]; (PALETTE_WIDTH * height) as usize];
        Self { texture, view, texels, height }
    }

    /// The view bound to the vertex shader.
    pub fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    /// Number of joints the texture holds.
    pub fn capacity(&self) -> u32 {
        PALETTE_WIDTH * self.height / TEXELS_PER_JOINT
    }

    /// Writes `matrices` (and, when given, their dual-quaternion split `dqs`, one per matrix)
    /// into the staging copy starting at joint `first`. Fails (writing nothing) when they do
    /// not fit.
    pub fn set(&mut self, first: u32, matrices: &[Mat4], dqs: Option<&[JointDq]>) -> Result<(), String> {
        let per = TEXELS_PER_JOINT as usize;
        let start = first as usize * per;
        let end = start + matrices.len() * per;
        let Some(dst) = self.texels.get_mut(start..end) else {
            return Err(format!(
                "palette joints {first}..{} exceed the capacity {}",
                first as usize + matrices.len(),
                self.capacity()
            ));
        };
        for (joint, (texels, m)) in dst.chunks_exact_mut(per).zip(matrices).enumerate() {
            for (r, row) in texels[..3].iter_mut().enumerate() {
                *row = m.row(r).to_array();
            }
            if let Some(dq) = dqs.and_then(|d| d.get(joint)) {
                texels[3] = dq.dq.real.to_array();
                texels[4] = dq.dq.dual.to_array();
                for (r, row) in texels[5..8].iter_mut().enumerate() {
                    *row = dq.stretch.row(r).extend(0.0).to_array();
                }
                texels[5][3] = if dq.rigid { 1.0 } else { 0.0 };
            }
        }
        Ok(())
    }

    /// Uploads the staging copy.
    pub fn upload(&self, queue: &wgpu::Queue) {
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &self.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&self.texels),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(PALETTE_WIDTH * 16),
                rows_per_image: Some(self.height),
            },
            wgpu::Extent3d { width: PALETTE_WIDTH, height: self.height, depth_or_array_layers: 1 },
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shaders_address_the_palette_with_its_width() {
        // skinning.wgsl finds a joint's row and column with this constant (no size query per
        // texel), and relies on a joint's texels sharing one row.
        let declared = format!("const PALETTE_WIDTH: u32 = {PALETTE_WIDTH}u;");
        assert!(crate::render::pipelines::MESH_WGSL.contains(&declared), "mesh shaders lack `{declared}`");
        assert!(crate::render::pipelines::SKIN_COMPUTE_WGSL.contains(&declared), "compute shader lacks `{declared}`");
        assert_eq!(PALETTE_WIDTH % TEXELS_PER_JOINT, 0);
    }
}
