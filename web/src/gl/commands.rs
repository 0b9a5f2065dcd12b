//! Command encoders and render passes record; the queue runs what they recorded on submit
//! ([`execute`]), so that writes made through the queue before a submit are seen by it, as in
//! WebGPU.

use std::sync::{Arc, Mutex};

use web_sys::WebGl2RenderingContext as Gl;
use wgpu::custom::{
    CommandBufferInterface, CommandEncoderInterface, DispatchBindGroup, DispatchBuffer, DispatchCommandBuffer,
    DispatchComputePass, DispatchQuerySet, DispatchRenderBundle, DispatchRenderPass, DispatchRenderPipeline,
    DispatchTexture, RenderPassInterface,
};

use super::resources::{
    BindGroup, BindGroupInner, Buffer, BufferInner, PipelineInner, RenderPipeline, Resource, TextureView,
};
use super::state::{self, Context, FramebufferKey, Image, changes};
use super::{Errors, Unsupported};

/// A colour attachment of a pass.
#[derive(Debug)]
pub(super) struct ColorAttachment {
    view: TextureView,
    resolve: Option<TextureView>,
    clear: Option<wgpu::Color>,
    discard: bool,
}

/// The depth attachment of a pass.
#[derive(Debug)]
pub(super) struct DepthAttachment {
    view: TextureView,
    clear: Option<f32>,
    discard: bool,
}

/// One recorded command.
#[derive(Debug)]
pub(super) enum Command {
    BeginPass {
        colors: Vec<ColorAttachment>,
        depth: Option<DepthAttachment>,
    },
    SetPipeline(Arc<PipelineInner>),
    SetBindGroup {
        index: u32,
        group: Option<Arc<BindGroupInner>>,
        offsets: Vec<u32>,
    },
    SetVertexBuffer {
        slot: u32,
        buffer: Option<Arc<BufferInner>>,
        offset: u64,
    },
    SetIndexBuffer {
        buffer: Arc<BufferInner>,
        format: wgpu::IndexFormat,
        offset: u64,
    },
    Viewport([f32; 6]),
    Scissor([u32; 4]),
    BlendConstant(wgpu::Color),
    Draw {
        vertices: std::ops::Range<u32>,
        instances: std::ops::Range<u32>,
    },
    DrawIndexed {
        indices: std::ops::Range<u32>,
        base_vertex: i32,
        instances: std::ops::Range<u32>,
    },
    EndPass,
    CopyBufferToBuffer {
        src: Arc<BufferInner>,
        src_offset: u64,
        dst: Arc<BufferInner>,
        dst_offset: u64,
        size: u64,
    },
    CopyTextureToBuffer {
        src: TextureView,
        origin: [u32; 2],
        dst: Arc<BufferInner>,
        layout: wgpu::TexelCopyBufferLayout,
        size: [u32; 2],
    },
    ClearBuffer {
        buffer: Arc<BufferInner>,
        offset: u64,
        size: Option<u64>,
    },
}

/// A command encoder: what it and its passes recorded.
#[derive(Debug)]
pub(super) struct CommandEncoder {
    pub commands: Arc<Mutex<Vec<Command>>>,
    pub errors: Arc<Errors>,
}

impl CommandEncoder {
    fn push(&self, command: Command) {
        if let Ok(mut c) = self.commands.lock() {
            c.push(command);
        }
    }
}

/// What was recorded, to run on submit.
#[derive(Debug)]
pub(super) struct CommandBuffer {
    pub commands: Mutex<Vec<Command>>,
}

impl CommandBufferInterface for CommandBuffer {}

fn buffer_of(b: &DispatchBuffer) -> Option<Arc<BufferInner>> {
    b.as_custom::<Buffer>().map(|b| b.inner.clone())
}

fn view_of(texture: &wgpu::Texture, mip: u32) -> Option<TextureView> {
    let t = texture.as_custom::<super::resources::Texture>()?;
    Some(TextureView { texture: t.inner.clone(), levels: (mip, mip), format: t.inner.format })
}

impl CommandEncoderInterface for CommandEncoder {
    fn copy_buffer_to_buffer(
        &self,
        source: &DispatchBuffer,
        source_offset: wgpu::BufferAddress,
        destination: &DispatchBuffer,
        destination_offset: wgpu::BufferAddress,
        copy_size: Option<wgpu::BufferAddress>,
    ) {
        let (Some(src), Some(dst)) = (buffer_of(source), buffer_of(destination)) else { return };
        let size = copy_size.unwrap_or(src.size.saturating_sub(source_offset));
        self.push(Command::CopyBufferToBuffer {
            src,
            src_offset: source_offset,
            dst,
            dst_offset: destination_offset,
            size,
        });
    }

    fn copy_buffer_to_texture(
        &self,
        _: wgpu::TexelCopyBufferInfo<'_>,
        _: wgpu::TexelCopyTextureInfo<'_>,
        _: wgpu::Extent3d,
    ) {
        self.errors.report("copy_buffer_to_texture: not in Kloub's WebGL2 backend (write_texture is)");
    }

    fn copy_texture_to_buffer(
        &self,
        source: wgpu::TexelCopyTextureInfo<'_>,
        destination: wgpu::TexelCopyBufferInfo<'_>,
        copy_size: wgpu::Extent3d,
    ) {
        let (Some(src), Some(dst)) = (
            view_of(source.texture, source.mip_level),
            destination.buffer.as_custom::<Buffer>().map(|b| b.inner.clone()),
        ) else {
            return;
        };
        self.push(Command::CopyTextureToBuffer {
            src,
            origin: [source.origin.x, source.origin.y],
            dst,
            layout: destination.layout,
            size: [copy_size.width, copy_size.height],
        });
    }

    fn copy_texture_to_texture(
        &self,
        _: wgpu::TexelCopyTextureInfo<'_>,
        _: wgpu::TexelCopyTextureInfo<'_>,
        _: wgpu::Extent3d,
    ) {
        self.errors.report("copy_texture_to_texture: not in Kloub's WebGL2 backend");
    }

    fn begin_compute_pass(&self, _desc: &wgpu::ComputePassDescriptor<'_>) -> DispatchComputePass {
        self.errors.report("compute passes: WebGL2 has none");
        DispatchComputePass::custom(Unsupported)
    }

    fn begin_render_pass(&self, desc: &wgpu::RenderPassDescriptor<'_>) -> DispatchRenderPass {
        let last = desc.color_attachments.iter().rposition(Option::is_some).map_or(0, |i| i + 1);
        if desc.color_attachments.iter().take(last).any(Option::is_none) {
            self.errors.report(&format!("render pass {:?}: gaps between colour attachments", desc.label));
        }
        let colors = desc
            .color_attachments
            .iter()
            .flatten()
            .filter_map(|a| {
                Some(ColorAttachment {
                    view: a.view.as_custom::<TextureView>()?.clone(),
                    resolve: a.resolve_target.and_then(|r| r.as_custom::<TextureView>()).cloned(),
                    clear: match a.ops.load {
                        wgpu::LoadOp::Clear(c) => Some(c),
                        _ => None,
                    },
                    discard: a.ops.store == wgpu::StoreOp::Discard,
                })
            })
            .collect();
        let depth = desc.depth_stencil_attachment.as_ref().and_then(|d| {
            let ops = d.depth_ops.as_ref();
            Some(DepthAttachment {
                view: d.view.as_custom::<TextureView>()?.clone(),
                clear: match ops.map(|o| o.load) {
                    Some(wgpu::LoadOp::Clear(v)) => Some(v),
                    _ => None,
                },
                discard: ops.is_some_and(|o| o.store == wgpu::StoreOp::Discard),
            })
        });
        self.push(Command::BeginPass { colors, depth });
        DispatchRenderPass::custom(RenderPass { commands: self.commands.clone(), errors: self.errors.clone() })
    }

    fn finish(&mut self) -> DispatchCommandBuffer {
        let commands = self.commands.lock().map(|mut c| std::mem::take(&mut *c)).unwrap_or_default();
        DispatchCommandBuffer::custom(CommandBuffer { commands: Mutex::new(commands) })
    }

    fn clear_texture(&self, _: &DispatchTexture, _: &wgpu::ImageSubresourceRange) {
        self.errors.report("clear_texture: not in Kloub's WebGL2 backend (a pass's clear is)");
    }

    fn clear_buffer(&self, buffer: &DispatchBuffer, offset: wgpu::BufferAddress, size: Option<wgpu::BufferAddress>) {
        if let Some(buffer) = buffer_of(buffer) {
            self.push(Command::ClearBuffer { buffer, offset, size });
        }
    }

    fn insert_debug_marker(&self, _: &str) {}
    fn push_debug_group(&self, _: &str) {}
    fn pop_debug_group(&self) {}

    fn write_timestamp(&self, _: &DispatchQuerySet, _: u32) {
        self.errors.report("timestamps: not in WebGL2");
    }

    fn resolve_query_set(&self, _: &DispatchQuerySet, _: u32, _: u32, _: &DispatchBuffer, _: wgpu::BufferAddress) {
        self.errors.report("query sets: not in Kloub's WebGL2 backend");
    }

    fn mark_acceleration_structures_built<'a>(
        &self,
        _: &mut dyn Iterator<Item = &'a wgpu::Blas>,
        _: &mut dyn Iterator<Item = &'a wgpu::Tlas>,
    ) {
        self.errors.report("ray tracing: not in WebGL2");
    }

    fn build_acceleration_structures<'a>(
        &self,
        _: &mut dyn Iterator<Item = &'a wgpu::BlasBuildEntry<'a>>,
        _: &mut dyn Iterator<Item = &'a wgpu::Tlas>,
    ) {
        self.errors.report("ray tracing: not in WebGL2");
    }

    fn transition_resources<'a>(
        &mut self,
        _: &mut dyn Iterator<Item = wgpu::wgt::BufferTransition<&'a DispatchBuffer>>,
        _: &mut dyn Iterator<Item = wgpu::wgt::TextureTransition<&'a DispatchTexture>>,
    ) {
    }
}

/// A render pass: records into its encoder.
#[derive(Debug)]
pub(super) struct RenderPass {
    commands: Arc<Mutex<Vec<Command>>>,
    errors: Arc<Errors>,
}

impl RenderPass {
    fn push(&self, command: Command) {
        if let Ok(mut c) = self.commands.lock() {
            c.push(command);
        }
    }
}

impl Drop for RenderPass {
    fn drop(&mut self) {
        self.push(Command::EndPass);
    }
}

impl RenderPassInterface for RenderPass {
    fn set_pipeline(&mut self, pipeline: &DispatchRenderPipeline) {
        if let Some(p) = pipeline.as_custom::<RenderPipeline>() {
            self.push(Command::SetPipeline(p.inner.clone()));
        }
    }

    fn set_bind_group(&mut self, index: u32, bind_group: Option<&DispatchBindGroup>, offsets: &[wgpu::DynamicOffset]) {
        let group = bind_group.and_then(|g| g.as_custom::<BindGroup>()).map(|g| g.inner.clone());
        self.push(Command::SetBindGroup { index, group, offsets: offsets.to_vec() });
    }

    fn set_index_buffer(
        &mut self,
        buffer: &DispatchBuffer,
        index_format: wgpu::IndexFormat,
        offset: wgpu::BufferAddress,
        _size: Option<wgpu::BufferSize>,
    ) {
        if let Some(buffer) = buffer_of(buffer) {
            self.push(Command::SetIndexBuffer { buffer, format: index_format, offset });
        }
    }

    fn set_vertex_buffer(
        &mut self,
        slot: u32,
        buffer: Option<&DispatchBuffer>,
        offset: wgpu::BufferAddress,
        _size: Option<wgpu::BufferSize>,
    ) {
        self.push(Command::SetVertexBuffer { slot, buffer: buffer.and_then(buffer_of), offset });
    }

    fn set_immediates(&mut self, _: u32, _: &[u8]) {
        self.errors.report("immediates: not in Kloub's WebGL2 backend");
    }

    fn set_blend_constant(&mut self, color: wgpu::Color) {
        self.push(Command::BlendConstant(color));
    }

    fn set_scissor_rect(&mut self, x: u32, y: u32, width: u32, height: u32) {
        self.push(Command::Scissor([x, y, width, height]));
    }

    fn set_viewport(&mut self, x: f32, y: f32, width: f32, height: f32, min_depth: f32, max_depth: f32) {
        self.push(Command::Viewport([x, y, width, height, min_depth, max_depth]));
    }

    fn set_stencil_reference(&mut self, _: u32) {}

    fn draw(&mut self, vertices: std::ops::Range<u32>, instances: std::ops::Range<u32>) {
        self.push(Command::Draw { vertices, instances });
    }

    fn draw_indexed(&mut self, indices: std::ops::Range<u32>, base_vertex: i32, instances: std::ops::Range<u32>) {
        self.push(Command::DrawIndexed { indices, base_vertex, instances });
    }

    fn draw_mesh_tasks(&mut self, _: u32, _: u32, _: u32) {
        self.errors.report("mesh shaders: not in WebGL2");
    }

    fn draw_indirect(&mut self, _: &DispatchBuffer, _: wgpu::BufferAddress) {
        self.errors.report("indirect draws: not in WebGL2");
    }

    fn draw_indexed_indirect(&mut self, _: &DispatchBuffer, _: wgpu::BufferAddress) {
        self.errors.report("indirect draws: not in WebGL2");
    }

    fn draw_mesh_tasks_indirect(&mut self, _: &DispatchBuffer, _: wgpu::BufferAddress) {
        self.errors.report("mesh shaders: not in WebGL2");
    }

    fn multi_draw_indirect(&mut self, _: &DispatchBuffer, _: wgpu::BufferAddress, _: u32) {
        self.errors.report("indirect draws: not in WebGL2");
    }

    fn multi_draw_indexed_indirect(&mut self, _: &DispatchBuffer, _: wgpu::BufferAddress, _: u32) {
        self.errors.report("indirect draws: not in WebGL2");
    }

    fn multi_draw_indirect_count(
        &mut self,
        _: &DispatchBuffer,
        _: wgpu::BufferAddress,
        _: &DispatchBuffer,
        _: wgpu::BufferAddress,
        _: u32,
    ) {
        self.errors.report("indirect draws: not in WebGL2");
    }

    fn multi_draw_mesh_tasks_indirect(&mut self, _: &DispatchBuffer, _: wgpu::BufferAddress, _: u32) {
        self.errors.report("mesh shaders: not in WebGL2");
    }

    fn multi_draw_indexed_indirect_count(
        &mut self,
        _: &DispatchBuffer,
        _: wgpu::BufferAddress,
        _: &DispatchBuffer,
        _: wgpu::BufferAddress,
        _: u32,
    ) {
        self.errors.report("indirect draws: not in WebGL2");
    }

    fn multi_draw_mesh_tasks_indirect_count(
        &mut self,
        _: &DispatchBuffer,
        _: wgpu::BufferAddress,
        _: &DispatchBuffer,
        _: wgpu::BufferAddress,
        _: u32,
    ) {
        self.errors.report("mesh shaders: not in WebGL2");
    }

    fn insert_debug_marker(&mut self, _: &str) {}
    fn push_debug_group(&mut self, _: &str) {}
    fn pop_debug_group(&mut self) {}

    fn write_timestamp(&mut self, _: &DispatchQuerySet, _: u32) {
        self.errors.report("timestamps: not in WebGL2");
    }

    fn begin_occlusion_query(&mut self, _: u32) {
        self.errors.report("occlusion queries: not in Kloub's WebGL2 backend");
    }

    fn end_occlusion_query(&mut self) {}

    fn begin_pipeline_statistics_query(&mut self, _: &DispatchQuerySet, _: u32) {
        self.errors.report("pipeline statistics: not in WebGL2");
    }

    fn end_pipeline_statistics_query(&mut self) {}

    fn execute_bundles(&mut self, _: &mut dyn Iterator<Item = &DispatchRenderBundle>) {
        self.errors.report("render bundles: not in Kloub's WebGL2 backend");
    }
}

/// The state of the pass being run: what it binds, borrowed from the commands.
struct Pass<'a> {
    /// Drawing unflipped, into the canvas (or an attachment resolved into it).
    canvas: bool,
    /// The attachments' size.
    size: [u32; 2],
    /// The framebuffer (`None`: the canvas's).
    framebuffer: Option<web_sys::WebGlFramebuffer>,
    colors: &'a [ColorAttachment],
    depth: Option<&'a DepthAttachment>,
    pipeline: Option<&'a PipelineInner>,
    program: Option<u32>,
    groups: [Option<(&'a BindGroupInner, &'a [u32])>; 4],
    vertex: [Option<(&'a BufferInner, u64)>; 8],
    index: Option<(&'a BufferInner, wgpu::IndexFormat, u64)>,
    /// Bindings changed since the last draw.
    dirty: bool,
}

/// The framebuffer of `key`, made on first use.
fn framebuffer(c: &mut Context, key: FramebufferKey) -> Option<web_sys::WebGlFramebuffer> {
    if let Some(fb) = c.framebuffers.get(&key) {
        return Some(fb.clone());
    }
    let gl = &c.gl;
    let fb = gl.create_framebuffer()?;
    gl.bind_framebuffer(Gl::FRAMEBUFFER, Some(&fb));
    let attach = |attachment: u32, (image, level): (u32, u32)| match c.images.get(image) {
        Some(Image::Texture { texture, .. }) => {
            gl.framebuffer_texture_2d(Gl::FRAMEBUFFER, attachment, Gl::TEXTURE_2D, Some(texture), level as i32);
        }
        Some(Image::Renderbuffer(rb)) => {
            gl.framebuffer_renderbuffer(Gl::FRAMEBUFFER, attachment, Gl::RENDERBUFFER, Some(rb));
        }
        None => {}
    };
    let buffers = js_sys::Array::new();
    for (i, &color) in key.colors.iter().enumerate() {
        attach(Gl::COLOR_ATTACHMENT0 + i as u32, color);
        buffers.push(&(Gl::COLOR_ATTACHMENT0 + i as u32).into());
    }
    if let Some(depth) = key.depth {
        attach(Gl::DEPTH_ATTACHMENT, depth);
    }
    if key.colors.is_empty() {
        buffers.push(&Gl::NONE.into());
        gl.read_buffer(Gl::NONE);
    }
    gl.draw_buffers(&buffers);
    c.framebuffers.insert(key, fb.clone());
    Some(fb)
}

fn attachment_key(view: &TextureView) -> Option<(u32, u32)> {
    view.texture.id.map(|id| (id, view.levels.0))
}

/// Runs `commands` on their context. They stay the caller's, so that the resources only they
/// held are released after, not while the context's table is in use.
pub(super) fn execute(ctx: u32, commands: &[Command], errors: &Errors) {
    state::with(ctx, |c| {
        // What was bound before this submit is not known (uploads bind buffers and textures).
        c.known = Default::default();
        let mut pass: Option<Pass<'_>> = None;
        for command in commands {
            match command {
                Command::BeginPass { colors, depth } => pass = begin(c, colors, depth.as_ref()),
                Command::EndPass => {
                    if let Some(p) = pass.take() {
                        end(c, p);
                    }
                }
                Command::SetPipeline(pipeline) => {
                    if let Some(p) = &mut pass {
                        set_pipeline(c, p, pipeline, errors);
                    }
                }
                Command::SetBindGroup { index, group, offsets } => {
                    if let Some(p) = &mut pass
                        && let Some(slot) = p.groups.get_mut(*index as usize)
                    {
                        *slot = group.as_deref().map(|g| (g, offsets.as_slice()));
                        p.dirty = true;
                    }
                }
                Command::SetVertexBuffer { slot, buffer, offset } => {
                    if let Some(p) = &mut pass
                        && let Some(s) = p.vertex.get_mut(*slot as usize)
                    {
                        *s = buffer.as_deref().map(|b| (b, *offset));
                        p.dirty = true;
                    }
                }
                Command::SetIndexBuffer { buffer, format, offset } => {
                    if let Some(p) = &mut pass {
                        p.index = Some((buffer, *format, *offset));
                    }
                }
                &Command::Viewport([x, y, w, h, near, far]) => {
                    if let Some(p) = &pass {
                        let y = if p.canvas { p.size[1] as f32 - y - h } else { y };
                        c.gl.viewport(x as i32, y as i32, w as i32, h as i32);
                        c.gl.depth_range(near, far);
                    }
                }
                &Command::Scissor([x, y, w, h]) => {
                    if let Some(p) = &pass {
                        let y = if p.canvas { p.size[1].saturating_sub(y.saturating_add(h)) } else { y };
                        c.gl.enable(Gl::SCISSOR_TEST);
                        c.gl.scissor(x as i32, y as i32, w as i32, h as i32);
                    }
                }
                Command::BlendConstant(k) => c.gl.blend_color(k.r as f32, k.g as f32, k.b as f32, k.a as f32),
                Command::Draw { vertices, instances } => {
                    if let Some(p) = &mut pass
                        && prepare_draw(c, p, 0, instances.start)
                        && let Some(mode) = p.pipeline.map(|pl| topology(pl.primitive.topology))
                    {
                        c.gl.draw_arrays_instanced(
                            mode,
                            vertices.start as i32,
                            vertices.len() as i32,
                            instances.len() as i32,
                        );
                    }
                }
                Command::DrawIndexed { indices, base_vertex, instances } => {
                    if let Some(p) = &mut pass
                        && prepare_draw(c, p, *base_vertex, instances.start)
                        && let Some(mode) = p.pipeline.map(|pl| topology(pl.primitive.topology))
                        && let Some((buffer, format, offset)) = p.index
                        && let Some(b) = buffer.id.and_then(|id| c.buffers.get(id))
                    {
                        let (kind, size) = match format {
                            wgpu::IndexFormat::Uint16 => (Gl::UNSIGNED_SHORT, 2),
                            wgpu::IndexFormat::Uint32 => (Gl::UNSIGNED_INT, 4),
                        };
                        if changes(Some(&mut c.known.element_buffer), buffer.id.unwrap_or(u32::MAX)) {
                            c.gl.bind_buffer(Gl::ELEMENT_ARRAY_BUFFER, Some(b));
                        }
                        c.gl.draw_elements_instanced_with_f64(
                            mode,
                            indices.len() as i32,
                            kind,
                            (offset + u64::from(indices.start) * size) as f64,
                            instances.len() as i32,
                        );
                    }
                }
                Command::CopyBufferToBuffer { src, src_offset, dst, dst_offset, size } => {
                    copy_buffer(c, src, *src_offset, dst, *dst_offset, *size);
                }
                Command::CopyTextureToBuffer { src, origin, dst, layout, size } => {
                    read_pixels(c, src, *origin, dst, *layout, *size, errors);
                }
                Command::ClearBuffer { buffer, offset, size } => {
                    let size = size.unwrap_or(buffer.size.saturating_sub(*offset));
                    if let Some(b) = buffer.id.and_then(|id| c.buffers.get(id)) {
                        let target = buffer.target();
                        c.gl.bind_buffer(target, Some(b));
                        if target == Gl::ELEMENT_ARRAY_BUFFER {
                            c.known.element_buffer = None;
                        }
                        c.gl.buffer_sub_data_with_f64_and_u8_array(target, *offset as f64, &vec![0; size as usize]);
                    }
                }
            }
        }
        if let Some(p) = pass.take() {
            end(c, p);
        }
    });
}

fn begin<'a>(c: &mut Context, colors: &'a [ColorAttachment], depth: Option<&'a DepthAttachment>) -> Option<Pass<'a>> {
    let canvas = colors.iter().any(|a| a.view.texture.surface || a.resolve.as_ref().is_some_and(|r| r.texture.surface));
    let mut size = colors.first().map(|a| a.view.size()).or_else(|| depth.as_ref().map(|d| d.view.size()))?;
    // Straight into the canvas, its own depth buffer standing for the depth attachment (a GL
    // framebuffer is the canvas's or made of textures, never both; the renderer's depth
    // attachments are sized to the canvas and cleared by the pass that uses them).
    let to_canvas = colors.len() == 1 && colors.first().is_some_and(|a| a.view.texture.surface);
    let framebuffer = if to_canvas {
        None
    } else {
        let key = FramebufferKey {
            colors: colors.iter().filter_map(|a| attachment_key(&a.view)).collect(),
            depth: depth.as_ref().and_then(|d| attachment_key(&d.view)),
        };
        Some(framebuffer(c, key)?)
    };
    let gl = &c.gl;
    if to_canvas {
        // What the browser gave the canvas (it may cap a huge one).
        size = [gl.drawing_buffer_width().max(1) as u32, gl.drawing_buffer_height().max(1) as u32];
    }
    gl.bind_framebuffer(Gl::FRAMEBUFFER, framebuffer.as_ref());
    gl.viewport(0, 0, size[0] as i32, size[1] as i32);
    // WebGPU starts every pass with a zero blend constant.
    gl.blend_color(0.0, 0.0, 0.0, 0.0);
    gl.depth_range(0.0, 1.0);
    // Clears are masked and scissored as draws are: open both.
    gl.disable(Gl::SCISSOR_TEST);
    for (i, a) in colors.iter().enumerate() {
        if let Some(k) = a.clear {
            if changes(Some(&mut c.known.color_mask), [true; 4]) {
                gl.color_mask(true, true, true, true);
            }
            if matches!(a.view.format, wgpu::TextureFormat::Rgba32Uint | wgpu::TextureFormat::R32Uint) {
                let v = [k.r as u32, k.g as u32, k.b as u32, k.a as u32];
                gl.clear_bufferuiv_with_u32_array(Gl::COLOR, i as i32, &v);
            } else {
                let v = [k.r as f32, k.g as f32, k.b as f32, k.a as f32];
                gl.clear_bufferfv_with_f32_array(Gl::COLOR, i as i32, &v);
            }
        }
    }
    if let Some(d) = &depth
        && let Some(v) = d.clear
    {
        if changes(Some(&mut c.known.depth_mask), true) {
            gl.depth_mask(true);
        }
        gl.clear_bufferfv_with_f32_array(Gl::DEPTH, 0, &[v]);
    }
    Some(Pass {
        canvas,
        size,
        framebuffer,
        colors,
        depth,
        pipeline: None,
        program: None,
        groups: Default::default(),
        vertex: Default::default(),
        index: None,
        dirty: true,
    })
}

fn end(c: &mut Context, pass: Pass<'_>) {
    let gl = &c.gl;
    gl.disable(Gl::SCISSOR_TEST);
    for (i, a) in pass.colors.iter().enumerate() {
        let Some(resolve) = &a.resolve else { continue };
        let target = if resolve.texture.surface {
            None
        } else {
            let Some(key) = attachment_key(resolve) else { continue };
            framebuffer(c, FramebufferKey { colors: vec![key], depth: None })
        };
        let gl = &c.gl;
        gl.bind_framebuffer(Gl::READ_FRAMEBUFFER, pass.framebuffer.as_ref());
        gl.read_buffer(Gl::COLOR_ATTACHMENT0 + i as u32);
        gl.bind_framebuffer(Gl::DRAW_FRAMEBUFFER, target.as_ref());
        let [w, h] = pass.size;
        gl.blit_framebuffer(0, 0, w as i32, h as i32, 0, 0, w as i32, h as i32, Gl::COLOR_BUFFER_BIT, Gl::NEAREST);
    }
    let gl = &c.gl;
    if pass.framebuffer.is_some() {
        let discard = js_sys::Array::new();
        for (i, a) in pass.colors.iter().enumerate() {
            if a.discard {
                discard.push(&(Gl::COLOR_ATTACHMENT0 + i as u32).into());
            }
        }
        if pass.depth.as_ref().is_some_and(|d| d.discard) {
            discard.push(&Gl::DEPTH_ATTACHMENT.into());
        }
        if discard.length() > 0 {
            gl.bind_framebuffer(Gl::FRAMEBUFFER, pass.framebuffer.as_ref());
            let _ = gl.invalidate_framebuffer(Gl::FRAMEBUFFER, &discard);
        }
    }
    gl.bind_framebuffer(Gl::FRAMEBUFFER, None);
}

fn blend_factor(f: wgpu::BlendFactor) -> u32 {
    use wgpu::BlendFactor as B;
    match f {
        B::Zero => Gl::ZERO,
        B::One => Gl::ONE,
        B::Src => Gl::SRC_COLOR,
        B::OneMinusSrc => Gl::ONE_MINUS_SRC_COLOR,
        B::SrcAlpha => Gl::SRC_ALPHA,
        B::OneMinusSrcAlpha => Gl::ONE_MINUS_SRC_ALPHA,
        B::Dst => Gl::DST_COLOR,
        B::OneMinusDst => Gl::ONE_MINUS_DST_COLOR,
        B::DstAlpha => Gl::DST_ALPHA,
        B::OneMinusDstAlpha => Gl::ONE_MINUS_DST_ALPHA,
        B::SrcAlphaSaturated => Gl::SRC_ALPHA_SATURATE,
        B::Constant => Gl::CONSTANT_COLOR,
        B::OneMinusConstant => Gl::ONE_MINUS_CONSTANT_COLOR,
        _ => Gl::ONE,
    }
}

fn blend_op(op: wgpu::BlendOperation) -> u32 {
    match op {
        wgpu::BlendOperation::Add => Gl::FUNC_ADD,
        wgpu::BlendOperation::Subtract => Gl::FUNC_SUBTRACT,
        wgpu::BlendOperation::ReverseSubtract => Gl::FUNC_REVERSE_SUBTRACT,
        wgpu::BlendOperation::Min => Gl::MIN,
        wgpu::BlendOperation::Max => Gl::MAX,
    }
}

fn topology(t: wgpu::PrimitiveTopology) -> u32 {
    match t {
        wgpu::PrimitiveTopology::PointList => Gl::POINTS,
        wgpu::PrimitiveTopology::LineList => Gl::LINES,
        wgpu::PrimitiveTopology::LineStrip => Gl::LINE_STRIP,
        wgpu::PrimitiveTopology::TriangleList => Gl::TRIANGLES,
        wgpu::PrimitiveTopology::TriangleStrip => Gl::TRIANGLE_STRIP,
    }
}

fn set_pipeline<'a>(c: &mut Context, pass: &mut Pass<'a>, pipeline: &'a PipelineInner, errors: &Errors) {
    // The same pipeline again (a draw per copy sets it each time): nothing changes.
    if pass.pipeline.is_some_and(|p| std::ptr::eq(p, pipeline)) {
        return;
    }
    // No program (its stages were not translated, reported when it was made; or the context is
    // lost), or one that did not link: the pipeline draws nothing.
    let first_check = pipeline.program.and_then(|id| c.programs.get(id)).is_some_and(|p| p.pending.is_some());
    let program = pipeline.program.filter(|&id| match super::shaders::check(c, id) {
        Ok(()) => c.programs.get(id).is_some_and(|p| !p.failed),
        Err(e) => {
            errors.report(&format!("a WebGL2 program: {e}"));
            false
        }
    });
    // A program's first check uses it (unless it failed to link).
    if first_check {
        c.known.program = None;
    }
    let Context { gl, programs, known, .. } = c;
    let gl = &*gl;
    if let Some(id) = program
        && let Some(p) = programs.get_mut(id)
    {
        if changes(Some(&mut known.program), id) {
            gl.use_program(Some(&p.program));
        }
        let flip = if pass.canvas { 1.0 } else { -1.0 };
        if p.flipped != flip {
            gl.uniform1f(p.flip.as_ref(), flip);
            p.flipped = flip;
        }
    }
    // State: faces (the flip reverses the winding), depth, blending, colour writes.
    let primitive = &pipeline.primitive;
    let cull = primitive.cull_mode.map(|face| if face == wgpu::Face::Front { Gl::FRONT } else { Gl::BACK });
    if changes(Some(&mut known.cull), cull) {
        capability(gl, Gl::CULL_FACE, cull, |face| gl.cull_face(face));
    }
    let ccw = (primitive.front_face == wgpu::FrontFace::Ccw) == pass.canvas;
    let front = if ccw { Gl::CCW } else { Gl::CW };
    if changes(Some(&mut known.front_face), front) {
        gl.front_face(front);
    }
    let (test, mask, offset) = match &pipeline.depth {
        Some(d) => {
            let func = super::resources::compare(d.depth_compare.unwrap_or(wgpu::CompareFunction::Always));
            let biased = d.bias.constant != 0 || d.bias.slope_scale != 0.0;
            let offset = biased.then(|| (d.bias.slope_scale.to_bits(), (d.bias.constant as f32).to_bits()));
            (Some(func), Some(d.depth_write_enabled.unwrap_or(false)), offset)
        }
        None => (None, None, None),
    };
    if changes(Some(&mut known.depth_test), test) {
        capability(gl, Gl::DEPTH_TEST, test, |func| gl.depth_func(func));
    }
    if let Some(mask) = mask
        && changes(Some(&mut known.depth_mask), mask)
    {
        gl.depth_mask(mask);
    }
    if changes(Some(&mut known.polygon_offset), offset) {
        capability(gl, Gl::POLYGON_OFFSET_FILL, offset, |(factor, units)| {
            gl.polygon_offset(f32::from_bits(factor), f32::from_bits(units));
        });
    }
    let target = pipeline.targets.first().and_then(Option::as_ref);
    let blend = target.and_then(|t| t.blend).map(|b| {
        [
            blend_factor(b.color.src_factor),
            blend_factor(b.color.dst_factor),
            blend_factor(b.alpha.src_factor),
            blend_factor(b.alpha.dst_factor),
            blend_op(b.color.operation),
            blend_op(b.alpha.operation),
        ]
    });
    if changes(Some(&mut known.blend), blend) {
        capability(gl, Gl::BLEND, blend, |[cs, cd, as_, ad, co, ao]| {
            gl.blend_func_separate(cs, cd, as_, ad);
            gl.blend_equation_separate(co, ao);
        });
    }
    if let Some(target) = target {
        let m = target.write_mask;
        let mask = [
            m.contains(wgpu::ColorWrites::RED),
            m.contains(wgpu::ColorWrites::GREEN),
            m.contains(wgpu::ColorWrites::BLUE),
            m.contains(wgpu::ColorWrites::ALPHA),
        ];
        if changes(Some(&mut known.color_mask), mask) {
            gl.color_mask(mask[0], mask[1], mask[2], mask[3]);
        }
    }
    pass.program = program;
    pass.pipeline = Some(pipeline);
    pass.dirty = true;
}

/// Turns GL capability `cap` on and sets its parameters with `set` (`value` given), or off.
fn capability<T>(gl: &Gl, cap: u32, value: Option<T>, set: impl FnOnce(T)) {
    match value {
        Some(v) => {
            gl.enable(cap);
            set(v);
        }
        None => gl.disable(cap),
    }
}

/// The vertex format's GL components, type, normalisation and whether it is read as integers
/// (`None`: one this backend does not read; a pipeline with it is refused when made).
pub(super) fn vertex_format(f: wgpu::VertexFormat) -> Option<(i32, u32, bool, bool)> {
    use wgpu::VertexFormat as V;
    Some(match f {
        V::Float32 => (1, Gl::FLOAT, false, false),
        V::Float32x2 => (2, Gl::FLOAT, false, false),
        V::Float32x3 => (3, Gl::FLOAT, false, false),
        V::Float32x4 => (4, Gl::FLOAT, false, false),
        V::Uint32 => (1, Gl::UNSIGNED_INT, false, true),
        V::Uint32x2 => (2, Gl::UNSIGNED_INT, false, true),
        V::Uint32x3 => (3, Gl::UNSIGNED_INT, false, true),
        V::Uint32x4 => (4, Gl::UNSIGNED_INT, false, true),
        V::Sint32 => (1, Gl::INT, false, true),
        V::Sint32x4 => (4, Gl::INT, false, true),
        V::Uint16x2 => (2, Gl::UNSIGNED_SHORT, false, true),
        V::Uint16x4 => (4, Gl::UNSIGNED_SHORT, false, true),
        V::Unorm16x2 => (2, Gl::UNSIGNED_SHORT, true, false),
        V::Unorm16x4 => (4, Gl::UNSIGNED_SHORT, true, false),
        V::Uint8x4 => (4, Gl::UNSIGNED_BYTE, false, true),
        V::Unorm8x4 => (4, Gl::UNSIGNED_BYTE, true, false),
        V::Uint8x2 => (2, Gl::UNSIGNED_BYTE, false, true),
        V::Unorm8x2 => (2, Gl::UNSIGNED_BYTE, true, false),
        _ => return None,
    })
}

/// Binds what the next draw reads: the groups' buffers and textures where the program reads
/// them, and the vertex attributes (their first vertex and instance moved to `base_vertex` and
/// `first_instance`, which WebGL2 draws cannot take). `false` when there is nothing to draw
/// with.
fn prepare_draw(c: &mut Context, pass: &mut Pass<'_>, base_vertex: i32, first_instance: u32) -> bool {
    let (Some(pipeline), Some(program)) = (pass.pipeline, pass.program) else { return false };
    let rebase = base_vertex != 0 || first_instance != 0;
    if !pass.dirty && !rebase {
        return true;
    }
    pass.dirty = rebase;
    // The table's parts apart: the program's lists are read while the images' levels change.
    // Every binding is compared with what is known to be bound (`Known`): what the previous
    // draw left in place is not set again.
    let Context { gl, buffers, images, samplers, programs, nearest, enabled_attributes, known, .. } = c;
    let gl = &*gl;
    let Some(p) = programs.get(program) else { return false };
    let groups = &pass.groups;
    let resource = |(group, binding): (u32, u32)| -> Option<(&Resource, u64)> {
        let (g, offsets) = groups.get(group as usize)?.as_ref()?;
        let dynamic = g.dynamic.iter().position(|&b| b == binding).and_then(|i| offsets.get(i)).copied().unwrap_or(0);
        Some((g.get(binding)?, u64::from(dynamic)))
    };
    for (slot, &gb) in p.uniforms.iter().enumerate() {
        if let Some((&Resource::Buffer { ref buffer, offset, size }, dynamic)) = resource(gb)
            && let Some(id) = buffer.id
            && let Some(b) = buffers.get(id)
            && changes(known.uniforms.get_mut(slot), (id, offset + dynamic, size))
        {
            gl.bind_buffer_range_with_f64_and_f64(
                Gl::UNIFORM_BUFFER,
                slot as u32,
                Some(b),
                (offset + dynamic) as f64,
                size as f64,
            );
        }
    }
    for (unit, &(t, s)) in p.textures.iter().enumerate() {
        let Some((Resource::View(view), _)) = resource(t) else { continue };
        let Some(id) = view.texture.id else { continue };
        if let Some(Image::Texture { texture, levels }) = images.get_mut(id) {
            let bind = changes(known.textures.get_mut(unit), id);
            let limit = *levels != view.levels;
            if (bind || limit) && changes(Some(&mut known.active_unit), unit as u32) {
                gl.active_texture(Gl::TEXTURE0 + unit as u32);
            }
            if bind {
                gl.bind_texture(Gl::TEXTURE_2D, Some(texture));
            }
            if limit {
                gl.tex_parameteri(Gl::TEXTURE_2D, Gl::TEXTURE_BASE_LEVEL, view.levels.0 as i32);
                gl.tex_parameteri(Gl::TEXTURE_2D, Gl::TEXTURE_MAX_LEVEL, view.levels.1 as i32);
                *levels = view.levels;
            }
        }
        let (sampler, key) = match s.and_then(&resource) {
            Some((Resource::Sampler(sampler), _)) => match sampler.id {
                Some(id) => (samplers.get(id), id),
                None => (None, u32::MAX - 1),
            },
            _ => (nearest.as_ref(), u32::MAX),
        };
        if changes(known.samplers.get_mut(unit), key) {
            gl.bind_sampler(unit as u32, sampler);
        }
    }
    let mut enabled = 0u32;
    for (slot, layout) in pipeline.buffers.iter().enumerate() {
        let Some(layout) = layout else { continue };
        let Some(Some((buffer, offset))) = pass.vertex.get(slot) else { continue };
        let Some(id) = buffer.id else { continue };
        let Some(b) = buffers.get(id) else { continue };
        let shift = if layout.instance { i64::from(first_instance) } else { i64::from(base_vertex) };
        let start = *offset as i64 + shift * layout.stride as i64;
        for a in &layout.attributes {
            let Some((count, kind, normalized, integer)) = vertex_format(a.format) else { continue };
            let at = (start + a.offset as i64).max(0);
            enabled |= 1 << a.shader_location.min(31);
            let source = (id, at, layout.stride as i32, a.format, layout.instance);
            if !changes(known.attributes.get_mut(a.shader_location as usize), source) {
                continue;
            }
            if changes(Some(&mut known.array_buffer), id) {
                gl.bind_buffer(Gl::ARRAY_BUFFER, Some(b));
            }
            if integer {
                gl.vertex_attrib_i_pointer_with_f64(a.shader_location, count, kind, layout.stride as i32, at as f64);
            } else {
                gl.vertex_attrib_pointer_with_f64(
                    a.shader_location,
                    count,
                    kind,
                    normalized,
                    layout.stride as i32,
                    at as f64,
                );
            }
            gl.vertex_attrib_divisor(a.shader_location, u32::from(layout.instance));
        }
    }
    let changed = enabled ^ *enabled_attributes;
    for location in 0..32 {
        if changed & (1 << location) != 0 {
            if enabled & (1 << location) != 0 {
                gl.enable_vertex_attrib_array(location);
            } else {
                gl.disable_vertex_attrib_array(location);
            }
        }
    }
    *enabled_attributes = enabled;
    true
}

fn copy_buffer(c: &mut Context, src: &BufferInner, src_offset: u64, dst: &BufferInner, dst_offset: u64, size: u64) {
    let gl = &c.gl;
    let Some(s) = src.id.and_then(|id| c.buffers.get(id)) else { return };
    gl.bind_buffer(Gl::COPY_READ_BUFFER, Some(s));
    match dst.id.and_then(|id| c.buffers.get(id)) {
        Some(d) => {
            gl.bind_buffer(Gl::COPY_WRITE_BUFFER, Some(d));
            gl.copy_buffer_sub_data_with_f64_and_f64_and_f64(
                Gl::COPY_READ_BUFFER,
                Gl::COPY_WRITE_BUFFER,
                src_offset as f64,
                dst_offset as f64,
                size as f64,
            );
        }
        None if dst.id.is_none() => {
            if let Ok(mut memory) = dst.memory.lock() {
                let start = dst_offset as usize;
                if let Some(out) = memory.get_mut(start..start + size as usize) {
                    gl.get_buffer_sub_data_with_f64_and_u8_array(Gl::COPY_READ_BUFFER, src_offset as f64, out);
                }
            }
        }
        None => {}
    }
}

fn read_pixels(
    c: &mut Context,
    src: &TextureView,
    origin: [u32; 2],
    dst: &BufferInner,
    layout: wgpu::TexelCopyBufferLayout,
    [w, h]: [u32; 2],
    errors: &Errors,
) {
    let Some((_, format, kind, texel)) = super::resources::format(src.format) else {
        errors.report(&format!("reading back {:?}", src.format));
        return;
    };
    let (row, len) = match super::resources::copy_extent(w, h, texel, layout.bytes_per_row) {
        Ok(extent) => extent,
        Err(e) => {
            errors.report(&format!("copy_texture_to_buffer: {e}"));
            return;
        }
    };
    let Some(end) = (layout.offset as usize).checked_add(len) else {
        errors.report("copy_texture_to_buffer: beyond the buffer");
        return;
    };
    let fb = if src.texture.surface {
        None
    } else {
        let Some(key) = attachment_key(src) else { return };
        framebuffer(c, FramebufferKey { colors: vec![key], depth: None })
    };
    let gl = &c.gl;
    gl.bind_framebuffer(Gl::READ_FRAMEBUFFER, fb.as_ref());
    gl.read_buffer(if fb.is_some() { Gl::COLOR_ATTACHMENT0 } else { Gl::BACK });
    gl.pixel_storei(Gl::PACK_ROW_LENGTH, (row / texel) as i32);
    // The canvas's row 0 is the bottom of the picture: read from the bottom up, then turn.
    let height = if src.texture.surface { gl.drawing_buffer_height().max(0) as u32 } else { src.texture.size[1] };
    let y = if src.texture.surface { height.saturating_sub(origin[1].saturating_add(h)) } else { origin[1] };
    if let Ok(mut memory) = dst.memory.lock()
        && let Some(out) = memory.get_mut(layout.offset as usize..end)
    {
        let (x, y, width, height) = (origin[0] as i32, y as i32, w as i32, h as i32);
        if kind == Gl::UNSIGNED_BYTE {
            let _ = gl.read_pixels_with_opt_u8_array(x, y, width, height, format, kind, Some(out));
        } else {
            // WebGL2 reads float and integer texels only into the matching typed array.
            let (array, bytes) = super::resources::texel_array(kind, out);
            let _ = gl.read_pixels_with_opt_array_buffer_view(x, y, width, height, format, kind, Some(&array));
            bytes.copy_to(out);
        }
        if src.texture.surface {
            // Rows as WebGPU's (the top first): swap them end for end.
            let (row, tight) = (row as usize, w as usize * texel as usize);
            for i in 0..(h as usize / 2) {
                let j = h as usize - 1 - i;
                let (top, bottom) = out.split_at_mut(j * row);
                if let (Some(a), Some(b)) = (top.get_mut(i * row..i * row + tight), bottom.get_mut(..tight)) {
                    a.swap_with_slice(b);
                }
            }
        }
    }
    gl.pixel_storei(Gl::PACK_ROW_LENGTH, 0);
    gl.bind_framebuffer(Gl::READ_FRAMEBUFFER, None);
}
