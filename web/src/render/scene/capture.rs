//! Readback of the GPU vertex stage (native only): the skinned draws run through the same
//! `skinned()` WGSL function as `vs_skinned`, but each vertex is drawn as one point on its
//! own pixel of two `rgba32uint` targets holding its world position and unit normal. This
//! is how the tests compare GPU skinning with `kloub_core`'s CPU reference without transform
//! feedback, on every backend wgpu has.

use kloub_core::{Asset, Instance};

use super::super::camera::Camera;
use super::super::offscreen::{read_buffer_bytes, read_texture_bytes};
use super::super::pipelines::{CAPTURE_FORMAT, VertexPath, tangent_slot};
use super::super::uniforms::DrawUniform;
use super::{SceneRenderer, SkinningPath};

/// Capture targets are at most this wide.
const CAPTURE_WIDTH: u32 = 1024;

/// One skinned draw as the vertex shader deformed it.
#[derive(Clone, Debug, PartialEq)]
pub struct CapturedDraw {
    /// Node instancing the mesh.
    pub node: u32,
    /// Mesh index.
    pub mesh: usize,
    /// Primitive index within the mesh.
    pub primitive: usize,
    /// World-space positions, one per vertex.
    pub positions: Vec<[f32; 3]>,
    /// Unit normals (zero where the vertex has none).
    pub normals: Vec<[f32; 3]>,
}

impl SceneRenderer {
    /// Deforms every skinned draw of the loaded asset on the GPU with `instance`'s skinning
    /// method (morph targets included) and reads the vertices back: through the vertex
    /// shader ([`SkinningPath::Gpu`]) or the compute pass ([`SkinningPath::Compute`]). Blocks
    /// until the GPU is done. Draws that this renderer deforms on the CPU are left out.
    ///
    /// # Errors
    /// [`SkinningPath::Cpu`], compute on a device without it, or a failed readback.
    pub fn capture_skinned(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        asset: &Asset,
        instance: &mut Instance,
        path: SkinningPath,
    ) -> Result<Vec<CapturedDraw>, String> {
        match path {
            SkinningPath::Gpu => self.capture_vertex_stage(device, queue, asset, instance),
            SkinningPath::Compute => self.capture_compute(device, queue, asset, instance),
            SkinningPath::Cpu => Err("capture reads back GPU skinning; the CPU path has nothing to capture".into()),
        }
    }

    /// The compute pass's output buffers, read back.
    fn capture_compute(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        asset: &Asset,
        instance: &mut Instance,
    ) -> Result<Vec<CapturedDraw>, String> {
        let kit = self.compute.as_ref().ok_or("this device has no compute shaders")?;
        let Some(scene) = self.scene.as_mut() else {
            return Ok(Vec::new());
        };
        scene.prepare(
            device,
            queue,
            asset,
            &mut [instance],
            &[glam::Vec3::ZERO],
            &Camera::default(),
            SkinningPath::Compute,
            Some(kit),
            None,
            // No colour is drawn: the draws' pipeline keys are made again by the next frame.
            false,
            None,
            self.draw_stride,
            &mut self.scratch,
        )?;
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("kloub capture compute") });
        scene.dispatch_compute(
            &mut encoder,
            kit,
            1,
            self.draw_stride,
            device.limits().max_compute_workgroups_per_dimension,
        );
        queue.submit([encoder.finish()]);
        let mut captures = Vec::new();
        for draw in scene.draws.iter().filter(|d| d.on_compute) {
            let Some(output) = draw.deformed.first().and_then(Option::as_ref) else { continue };
            let bytes = read_buffer_bytes(device, queue, output)?;
            let floats: Vec<f32> =
                bytes.chunks_exact(4).map(|w| f32::from_ne_bytes([w[0], w[1], w[2], w[3]])).collect();
            let vertices: Vec<([f32; 3], [f32; 3])> =
                floats.chunks_exact(6).map(|v| ([v[0], v[1], v[2]], [v[3], v[4], v[5]])).collect();
            captures.push(CapturedDraw {
                node: draw.node,
                mesh: draw.mesh,
                primitive: draw.primitive,
                positions: vertices.iter().map(|v| v.0).collect(),
                normals: vertices.iter().map(|v| normalized(v.1)).collect(),
            });
        }
        Ok(captures)
    }

    /// The vertex stage, captured as points on two integer targets.
    fn capture_vertex_stage(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        asset: &Asset,
        instance: &mut Instance,
    ) -> Result<Vec<CapturedDraw>, String> {
        let Some(scene) = self.scene.as_mut() else {
            return Ok(Vec::new());
        };
        scene.prepare(
            device,
            queue,
            asset,
            &mut [instance],
            &[glam::Vec3::ZERO],
            &Camera::default(),
            SkinningPath::Gpu,
            None,
            None,
            // No colour is drawn: the draws' pipeline keys are made again by the next frame.
            false,
            None,
            self.draw_stride,
            &mut self.scratch,
        )?;
        let pipeline = self.pipelines.capture(device);
        let params = std::mem::offset_of!(DrawUniform, params);
        let mut captures = Vec::new();
        for (i, draw) in scene.draws.iter().enumerate() {
            if draw.skin.is_none() || draw.on_cpu {
                continue;
            }
            let Some(gpu) =
                scene.primitives.get(draw.mesh).and_then(|m| m.get(draw.primitive)).and_then(Option::as_ref)
            else {
                continue;
            };
            let (Some(skin), Some(pivots), Some(material)) =
                (&gpu.skin, &draw.pivots, scene.materials.get(draw.material))
            else {
                continue;
            };
            let count = gpu.vertex_count;
            let width = count.clamp(1, CAPTURE_WIDTH);
            let height = count.div_ceil(width).max(1);
            let start = i * self.draw_stride as usize + params + 12;
            let size = (width & 0xffff) | (height << 16);
            self.scratch.draw_bytes[start..start + 4].copy_from_slice(&size.to_ne_bytes());
            queue.write_buffer(&scene.draw_buffer, 0, &self.scratch.draw_bytes);

            let target = |label| {
                device.create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: CAPTURE_FORMAT,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                    view_formats: &[],
                })
            };
            let targets = [target("kloub capture positions"), target("kloub capture normals")];
            let views = targets.each_ref().map(|t| t.create_view(&wgpu::TextureViewDescriptor::default()));
            let mut encoder =
                device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("kloub capture") });
            {
                let attachment = |view| {
                    Some(wgpu::RenderPassColorAttachment {
                        view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                            store: wgpu::StoreOp::Store,
                        },
                    })
                };
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("kloub capture"),
                    color_attachments: &[attachment(&views[0]), attachment(&views[1])],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &scene.frame_bind_groups[0], &[]);
                pass.set_bind_group(3, &self.environment.1.bind_group, &[]);
                pass.set_bind_group(1, material, &[]);
                pass.set_bind_group(2, &scene.draw_bind_group, &[(i as u64 * self.draw_stride) as u32]);
                pass.set_vertex_buffer(0, gpu.geometry.slice(..));
                pass.set_vertex_buffer(1, gpu.attributes.slice(..));
                pass.set_vertex_buffer(2, skin.slice(..));
                pass.set_vertex_buffer(3, pivots.slice(..));
                pass.set_vertex_buffer(tangent_slot(VertexPath::Skinned), gpu.tangents.slice(..));
                pass.draw(0..count, 0..1);
            }
            queue.submit([encoder.finish()]);
            let [positions, normals] = targets.each_ref().map(|t| read_texels(device, queue, t));
            let (positions, normals) = (positions?, normals?);
            captures.push(CapturedDraw {
                node: draw.node,
                mesh: draw.mesh,
                primitive: draw.primitive,
                positions: positions.into_iter().take(count as usize).collect(),
                normals: normals.into_iter().take(count as usize).collect(),
            });
        }
        Ok(captures)
    }
}

/// A unit vector along `v` (zero stays zero), as the capture shader normalizes.
fn normalized(v: [f32; 3]) -> [f32; 3] {
    glam::Vec3::from(v).normalize_or_zero().to_array()
}

/// The xyz of every texel of a capture texture (float bits in `rgba32uint`), row-major.
fn read_texels(device: &wgpu::Device, queue: &wgpu::Queue, texture: &wgpu::Texture) -> Result<Vec<[f32; 3]>, String> {
    let bytes = read_texture_bytes(device, queue, texture, 16)?;
    let f = |b: &[u8]| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]);
    Ok(bytes.chunks_exact(16).map(|t| [f(&t[0..4]), f(&t[4..8]), f(&t[8..12])]).collect())
}
