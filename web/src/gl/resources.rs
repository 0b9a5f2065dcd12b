//! Buffers, textures, samplers, bind groups and pipelines: wgpu's objects as handles of the
//! context's GL objects (`state`), each keeping what it refers to alive as wgpu's do.

use std::ops::Range;
use std::sync::{Arc, Mutex};

use web_sys::WebGl2RenderingContext as Gl;
use wgpu::custom::{
    BindGroupInterface, BindGroupLayoutInterface, BufferInterface, BufferMapCallback, BufferMappedRangeInterface,
    DispatchBindGroupLayout, DispatchBufferMappedRange, DispatchTextureView, PipelineLayoutInterface,
    QueueWriteBufferInterface, RenderPipelineInterface, SamplerInterface, ShaderModuleInterface, TextureInterface,
    TextureViewInterface,
};

use super::state::{self, Image};

/// A GL buffer, or for a `MAP_READ` buffer (copies read back) bytes in memory.
#[derive(Debug)]
pub(super) struct BufferInner {
    pub ctx: u32,
    /// The GL buffer (`None`: a readback buffer, or none could be made: the context is lost).
    pub id: Option<u32>,
    pub size: u64,
    pub usage: wgpu::BufferUsages,
    /// A readback buffer's bytes.
    pub memory: Mutex<Vec<u8>>,
}

impl BufferInner {
    /// The GL target this buffer is written through: WebGL2 never lets a buffer bound as
    /// indices be bound anywhere else.
    pub fn target(&self) -> u32 {
        if self.usage.contains(wgpu::BufferUsages::INDEX) { Gl::ELEMENT_ARRAY_BUFFER } else { Gl::COPY_WRITE_BUFFER }
    }

    /// Writes `data` at `offset`.
    pub fn write(&self, offset: u64, data: &[u8]) {
        if self.id.is_none() {
            if let Ok(mut memory) = self.memory.lock() {
                let start = offset as usize;
                if let Some(dst) = memory.get_mut(start..start + data.len()) {
                    dst.copy_from_slice(data);
                }
            }
            return;
        }
        let (Some(id), target) = (self.id, self.target()) else { return };
        state::with(self.ctx, |c| {
            if let Some(buffer) = c.buffers.get(id) {
                c.gl.bind_buffer(target, Some(buffer));
                c.gl.buffer_sub_data_with_f64_and_u8_array(target, offset as f64, data);
            }
        });
    }
}

impl Drop for BufferInner {
    fn drop(&mut self) {
        if let Some(id) = self.id {
            state::with_or_later(self.ctx, move |c| {
                if let Some(b) = c.buffers.remove(id) {
                    c.gl.delete_buffer(Some(&b));
                }
            });
        }
        state::release(self.ctx);
    }
}

/// A buffer handle.
#[derive(Debug)]
pub(super) struct Buffer {
    pub inner: Arc<BufferInner>,
}

impl Buffer {
    pub fn new(ctx: u32, desc: &wgpu::BufferDescriptor<'_>) -> Self {
        state::retain(ctx);
        let readback = desc.usage.contains(wgpu::BufferUsages::MAP_READ);
        let id = if readback {
            None
        } else {
            let target = if desc.usage.contains(wgpu::BufferUsages::INDEX) {
                Gl::ELEMENT_ARRAY_BUFFER
            } else {
                Gl::COPY_WRITE_BUFFER
            };
            state::with(ctx, |c| {
                let buffer = c.gl.create_buffer()?;
                c.gl.bind_buffer(target, Some(&buffer));
                c.gl.buffer_data_with_f64(target, desc.size as f64, Gl::DYNAMIC_DRAW);
                Some(c.buffers.insert(buffer))
            })
            .flatten()
        };
        let memory = if readback { vec![0; desc.size as usize] } else { Vec::new() };
        Self {
            inner: Arc::new(BufferInner { ctx, id, size: desc.size, usage: desc.usage, memory: Mutex::new(memory) }),
        }
    }
}

impl BufferInterface for Buffer {
    fn map_async(&self, _mode: wgpu::MapMode, _range: Range<wgpu::BufferAddress>, callback: BufferMapCallback) {
        // Copies into a readback buffer happen when submitted: it is ready now. The callback
        // runs later, as the browser's own would.
        let result = if self.inner.id.is_none() { Ok(()) } else { Err(wgpu::BufferAsyncError) };
        wasm_bindgen_futures::spawn_local(async move { callback(result) });
    }

    fn get_mapped_range(
        &self,
        sub_range: Range<wgpu::BufferAddress>,
    ) -> Result<DispatchBufferMappedRange, wgpu::MapRangeError> {
        let (start, end) = (sub_range.start as usize, sub_range.end as usize);
        let bytes = if self.inner.id.is_none() {
            self.inner.memory.lock().ok().and_then(|m| m.get(start..end).map(<[u8]>::to_vec)).unwrap_or_default()
        } else {
            vec![0; end.saturating_sub(start)]
        };
        Ok(DispatchBufferMappedRange::custom(MappedRange {
            buffer: self.inner.clone(),
            offset: sub_range.start,
            bytes,
            #[cfg(feature = "webgpu")]
            js: std::sync::OnceLock::new(),
        }))
    }

    fn unmap(&self) {}

    fn destroy(&self) {}
}

/// A mapped range: a copy of a readback buffer's bytes, or bytes written into a buffer mapped
/// at creation (uploaded when the range goes, before the buffer is unmapped).
#[derive(Debug)]
pub(super) struct MappedRange {
    buffer: Arc<BufferInner>,
    offset: u64,
    bytes: Vec<u8>,
    /// The bytes as a JavaScript array, made when asked for (`BufferView::as_uint8array`, which
    /// wgpu has where its WebGPU backend is built in too: wgpu's `cfg(webgpu)`, which Kloub cannot
    /// name; its `webgpu` feature is what turns wgpu's on, and nothing else does in these builds).
    #[cfg(feature = "webgpu")]
    js: std::sync::OnceLock<JsBytes>,
}

/// A JavaScript array in a `Send + Sync` handle, as wgpu's `fragile-send-sync-non-atomic-wasm`
/// makes its own JavaScript objects: the module runs on one thread (it is built without atomics).
#[cfg(feature = "webgpu")]
#[derive(Debug)]
pub(super) struct JsBytes(js_sys::Uint8Array);

#[cfg(all(feature = "webgpu", not(target_feature = "atomics")))]
#[allow(unsafe_code, reason = "wasm32 without atomics has one thread: no other thread can see it")]
unsafe impl Send for JsBytes {}
#[cfg(all(feature = "webgpu", not(target_feature = "atomics")))]
#[allow(unsafe_code, reason = "wasm32 without atomics has one thread: no other thread can see it")]
unsafe impl Sync for JsBytes {}

impl Drop for MappedRange {
    fn drop(&mut self) {
        if self.buffer.id.is_some() {
            self.buffer.write(self.offset, &self.bytes);
        }
    }
}

#[allow(unsafe_code, reason = "the trait declares these unsafe; they do nothing unsafe")]
impl BufferMappedRangeInterface for MappedRange {
    fn len(&self) -> usize {
        self.bytes.len()
    }

    unsafe fn read_slice(&self) -> &[u8] {
        &self.bytes
    }

    unsafe fn write_slice(&mut self) -> wgpu::WriteOnly<'_, [u8]> {
        wgpu::WriteOnly::from(&mut self.bytes[..])
    }

    /// A copy of the mapped bytes in JavaScript's memory (what was read back; writes to it do not
    /// reach the buffer).
    #[cfg(feature = "webgpu")]
    fn as_uint8array(&self) -> &js_sys::Uint8Array {
        &self.js.get_or_init(|| JsBytes(js_sys::Uint8Array::from(&self.bytes[..]))).0
    }
}

/// Bytes staged for `Queue::write_buffer_with`.
#[derive(Debug)]
pub(super) struct Staging {
    pub bytes: Vec<u8>,
}

#[allow(unsafe_code, reason = "the trait declares this unsafe; it does nothing unsafe")]
impl QueueWriteBufferInterface for Staging {
    fn len(&self) -> usize {
        self.bytes.len()
    }

    unsafe fn write_slice(&mut self) -> wgpu::WriteOnly<'_, [u8]> {
        wgpu::WriteOnly::from(&mut self.bytes[..])
    }
}

/// How WebGL2 stores and reads a texture format: internal format, format, type, bytes per
/// texel.
pub(super) fn format(format: wgpu::TextureFormat) -> Option<(u32, u32, u32, u32)> {
    use wgpu::TextureFormat as F;
    Some(match format {
        F::Rgba8Unorm => (Gl::RGBA8, Gl::RGBA, Gl::UNSIGNED_BYTE, 4),
        F::Rgba8UnormSrgb => (Gl::SRGB8_ALPHA8, Gl::RGBA, Gl::UNSIGNED_BYTE, 4),
        F::R8Unorm => (Gl::R8, Gl::RED, Gl::UNSIGNED_BYTE, 1),
        F::Rg8Unorm => (Gl::RG8, Gl::RG, Gl::UNSIGNED_BYTE, 2),
        F::Rgba16Float => (Gl::RGBA16F, Gl::RGBA, Gl::HALF_FLOAT, 8),
        F::Rgba32Float => (Gl::RGBA32F, Gl::RGBA, Gl::FLOAT, 16),
        F::R32Float => (Gl::R32F, Gl::RED, Gl::FLOAT, 4),
        F::Rgba32Uint => (Gl::RGBA32UI, Gl::RGBA_INTEGER, Gl::UNSIGNED_INT, 16),
        F::R32Uint => (Gl::R32UI, Gl::RED_INTEGER, Gl::UNSIGNED_INT, 4),
        F::Depth32Float => (Gl::DEPTH_COMPONENT32F, Gl::DEPTH_COMPONENT, Gl::FLOAT, 4),
        F::Depth24Plus => (Gl::DEPTH_COMPONENT24, Gl::DEPTH_COMPONENT, Gl::UNSIGNED_INT, 4),
        F::Depth24PlusStencil8 => (Gl::DEPTH24_STENCIL8, Gl::DEPTH_STENCIL, Gl::UNSIGNED_INT_24_8, 4),
        _ => return None,
    })
}

/// The row pitch and byte length of a copy of `w` × `h` texels of `texel` bytes laid out in rows
/// of `bytes_per_row` (tightly packed without): `Err` for rows shorter than the copy or a length
/// beyond memory.
pub(super) fn copy_extent(
    w: u32,
    h: u32,
    texel: u32,
    bytes_per_row: Option<u32>,
) -> Result<(u32, usize), &'static str> {
    let tight = u64::from(w) * u64::from(texel);
    let row = u64::from(bytes_per_row.unwrap_or(u32::try_from(tight).map_err(|_| "rows too long")?));
    if row < tight {
        return Err("rows shorter than the copy");
    }
    let len = row * u64::from(h.saturating_sub(1)) + tight;
    Ok((row as u32, usize::try_from(len).map_err(|_| "a copy beyond memory")?))
}

/// `bytes` as the typed array WebGL2 takes for texels of type `kind` (it refuses bytes for
/// float, half-float and 32-bit integer texels): a copy in JavaScript's memory, and the same
/// memory as bytes (to copy a read back into).
pub(super) fn texel_array(kind: u32, bytes: &[u8]) -> (js_sys::Object, js_sys::Uint8Array) {
    let copy = js_sys::Uint8Array::new_with_length(bytes.len() as u32);
    copy.copy_from(bytes);
    let buffer = copy.buffer();
    let len = bytes.len() as u32;
    let typed: js_sys::Object = match kind {
        Gl::FLOAT => js_sys::Float32Array::new_with_byte_offset_and_length(&buffer, 0, len / 4).into(),
        Gl::HALF_FLOAT => js_sys::Uint16Array::new_with_byte_offset_and_length(&buffer, 0, len / 2).into(),
        Gl::UNSIGNED_INT => js_sys::Uint32Array::new_with_byte_offset_and_length(&buffer, 0, len / 4).into(),
        _ => copy.clone().into(),
    };
    (typed, copy)
}

/// A texture's GL image (`None` for the canvas's own framebuffer).
#[derive(Debug)]
pub(super) struct TextureInner {
    pub ctx: u32,
    /// The image (`None`: the canvas, or none could be made).
    pub id: Option<u32>,
    /// The canvas's framebuffer.
    pub surface: bool,
    pub format: wgpu::TextureFormat,
    pub size: [u32; 2],
    pub mips: u32,
}

impl Drop for TextureInner {
    fn drop(&mut self) {
        if let Some(id) = self.id {
            state::with_or_later(self.ctx, move |c| c.delete_image(id));
        }
        state::release(self.ctx);
    }
}

/// A texture handle.
#[derive(Debug)]
pub(super) struct Texture {
    pub inner: Arc<TextureInner>,
}

impl Texture {
    /// Allocates `desc`'s storage; `Err` for what WebGL2 or this backend does not have.
    pub fn new(ctx: u32, desc: &wgpu::TextureDescriptor<'_>) -> Result<Self, String> {
        let (internal, _, _, _) = format(desc.format).ok_or_else(|| format!("texture format {:?}", desc.format))?;
        if desc.dimension != wgpu::TextureDimension::D2 || desc.size.depth_or_array_layers != 1 {
            return Err(format!("a {:?} texture of {} layers", desc.dimension, desc.size.depth_or_array_layers));
        }
        if desc.mip_level_count == 0 || desc.size.width == 0 || desc.size.height == 0 {
            return Err("an empty texture".into());
        }
        let (w, h) = (desc.size.width as i32, desc.size.height as i32);
        state::retain(ctx);
        let id = state::with(ctx, |c| {
            let gl = &c.gl;
            let image = if desc.sample_count > 1 {
                let rb = gl.create_renderbuffer()?;
                gl.bind_renderbuffer(Gl::RENDERBUFFER, Some(&rb));
                gl.renderbuffer_storage_multisample(Gl::RENDERBUFFER, desc.sample_count as i32, internal, w, h);
                Image::Renderbuffer(rb)
            } else {
                let texture = gl.create_texture()?;
                gl.bind_texture(Gl::TEXTURE_2D, Some(&texture));
                gl.tex_storage_2d(Gl::TEXTURE_2D, desc.mip_level_count as i32, internal, w, h);
                gl.tex_parameteri(Gl::TEXTURE_2D, Gl::TEXTURE_MAX_LEVEL, desc.mip_level_count as i32 - 1);
                Image::Texture { texture, levels: (0, desc.mip_level_count - 1) }
            };
            Some(c.images.insert(image))
        })
        .flatten();
        Ok(Self {
            inner: Arc::new(TextureInner {
                ctx,
                id,
                surface: false,
                format: desc.format,
                size: [desc.size.width, desc.size.height],
                mips: desc.mip_level_count,
            }),
        })
    }

    /// A texture that could not be made (reported): nothing is drawn into or read from it.
    pub fn invalid(ctx: u32, format: wgpu::TextureFormat) -> Self {
        state::retain(ctx);
        Self { inner: Arc::new(TextureInner { ctx, id: None, surface: false, format, size: [1, 1], mips: 1 }) }
    }

    /// The canvas's framebuffer as a texture of `format` and `size`.
    pub fn surface(ctx: u32, format: wgpu::TextureFormat, size: [u32; 2]) -> Self {
        state::retain(ctx);
        Self { inner: Arc::new(TextureInner { ctx, id: None, surface: true, format, size, mips: 1 }) }
    }
}

impl TextureInterface for Texture {
    fn create_view(&self, desc: &wgpu::TextureViewDescriptor<'_>) -> DispatchTextureView {
        let mips = self.inner.mips.max(1);
        let base = desc.base_mip_level.min(mips - 1);
        let count = desc.mip_level_count.unwrap_or(mips - base).clamp(1, mips - base);
        DispatchTextureView::custom(TextureView {
            texture: self.inner.clone(),
            levels: (base, base + count - 1),
            format: desc.format.unwrap_or(self.inner.format),
        })
    }

    fn destroy(&self) {}
}

/// A view: mip levels of a texture (WebGL2 has no other kind of view of a 2D texture).
#[derive(Debug, Clone)]
pub(super) struct TextureView {
    pub texture: Arc<TextureInner>,
    /// The first and last mip level.
    pub levels: (u32, u32),
    pub format: wgpu::TextureFormat,
}

impl TextureView {
    /// The size of the view's first level.
    pub fn size(&self) -> [u32; 2] {
        let [w, h] = self.texture.size;
        let level = |n: u32| n.checked_shr(self.levels.0).unwrap_or(0).max(1);
        [level(w), level(h)]
    }
}

impl TextureViewInterface for TextureView {}

fn wrap(mode: wgpu::AddressMode) -> i32 {
    match mode {
        wgpu::AddressMode::Repeat => Gl::REPEAT as i32,
        wgpu::AddressMode::MirrorRepeat => Gl::MIRRORED_REPEAT as i32,
        _ => Gl::CLAMP_TO_EDGE as i32,
    }
}

/// The GL comparison of `f`.
pub(super) fn compare(f: wgpu::CompareFunction) -> u32 {
    match f {
        wgpu::CompareFunction::Never => Gl::NEVER,
        wgpu::CompareFunction::Less => Gl::LESS,
        wgpu::CompareFunction::Equal => Gl::EQUAL,
        wgpu::CompareFunction::LessEqual => Gl::LEQUAL,
        wgpu::CompareFunction::Greater => Gl::GREATER,
        wgpu::CompareFunction::NotEqual => Gl::NOTEQUAL,
        wgpu::CompareFunction::GreaterEqual => Gl::GEQUAL,
        wgpu::CompareFunction::Always => Gl::ALWAYS,
    }
}

/// A GL sampler object.
#[derive(Debug)]
pub(super) struct SamplerInner {
    pub ctx: u32,
    pub id: Option<u32>,
}

impl Drop for SamplerInner {
    fn drop(&mut self) {
        if let Some(id) = self.id {
            state::with_or_later(self.ctx, move |c| {
                if let Some(s) = c.samplers.remove(id) {
                    c.gl.delete_sampler(Some(&s));
                }
            });
        }
        state::release(self.ctx);
    }
}

/// A sampler handle.
#[derive(Debug)]
pub(super) struct Sampler {
    pub inner: Arc<SamplerInner>,
}

impl Sampler {
    pub fn new(ctx: u32, desc: &wgpu::SamplerDescriptor<'_>) -> Self {
        state::retain(ctx);
        let linear = |f| f == wgpu::FilterMode::Linear;
        let min = match (linear(desc.min_filter), desc.mipmap_filter) {
            (false, wgpu::MipmapFilterMode::Nearest) => Gl::NEAREST_MIPMAP_NEAREST,
            (false, wgpu::MipmapFilterMode::Linear) => Gl::NEAREST_MIPMAP_LINEAR,
            (true, wgpu::MipmapFilterMode::Nearest) => Gl::LINEAR_MIPMAP_NEAREST,
            (true, wgpu::MipmapFilterMode::Linear) => Gl::LINEAR_MIPMAP_LINEAR,
        };
        let id = state::with(ctx, |c| {
            let gl = &c.gl;
            let s = gl.create_sampler()?;
            gl.sampler_parameteri(&s, Gl::TEXTURE_MIN_FILTER, min as i32);
            let mag = if linear(desc.mag_filter) { Gl::LINEAR } else { Gl::NEAREST };
            gl.sampler_parameteri(&s, Gl::TEXTURE_MAG_FILTER, mag as i32);
            gl.sampler_parameteri(&s, Gl::TEXTURE_WRAP_S, wrap(desc.address_mode_u));
            gl.sampler_parameteri(&s, Gl::TEXTURE_WRAP_T, wrap(desc.address_mode_v));
            gl.sampler_parameteri(&s, Gl::TEXTURE_WRAP_R, wrap(desc.address_mode_w));
            gl.sampler_parameterf(&s, Gl::TEXTURE_MIN_LOD, desc.lod_min_clamp);
            gl.sampler_parameterf(&s, Gl::TEXTURE_MAX_LOD, desc.lod_max_clamp);
            if let Some(f) = desc.compare {
                gl.sampler_parameteri(&s, Gl::TEXTURE_COMPARE_MODE, Gl::COMPARE_REF_TO_TEXTURE as i32);
                gl.sampler_parameteri(&s, Gl::TEXTURE_COMPARE_FUNC, compare(f) as i32);
            }
            Some(c.samplers.insert(s))
        })
        .flatten();
        Self { inner: Arc::new(SamplerInner { ctx, id }) }
    }
}

impl SamplerInterface for Sampler {}

/// A bind group layout: which of its bindings take a dynamic offset.
#[derive(Debug)]
pub(super) struct BindGroupLayout {
    pub inner: Arc<Vec<wgpu::BindGroupLayoutEntry>>,
}

impl BindGroupLayoutInterface for BindGroupLayout {}

/// What a binding holds.
#[derive(Debug, Clone)]
pub(super) enum Resource {
    Buffer { buffer: Arc<BufferInner>, offset: u64, size: u64 },
    View(TextureView),
    Sampler(Arc<SamplerInner>),
}

/// A bind group: its resources by binding, and which bindings take a dynamic offset (in
/// binding order, as the offsets come).
#[derive(Debug)]
pub(super) struct BindGroupInner {
    pub entries: Vec<(u32, Resource)>,
    pub dynamic: Vec<u32>,
}

impl BindGroupInner {
    pub fn get(&self, binding: u32) -> Option<&Resource> {
        self.entries.iter().find(|(b, _)| *b == binding).map(|(_, r)| r)
    }
}

/// A bind group handle.
#[derive(Debug)]
pub(super) struct BindGroup {
    pub inner: Arc<BindGroupInner>,
}

impl BindGroupInterface for BindGroup {}

/// A pipeline layout: its groups' layouts.
#[derive(Debug)]
pub(super) struct PipelineLayout {
    pub groups: Vec<Option<Arc<Vec<wgpu::BindGroupLayoutEntry>>>>,
}

impl PipelineLayoutInterface for PipelineLayout {}

/// A shader module: the translated module its WGSL is (`None`: the build did not translate it,
/// an error when a pipeline uses it).
#[derive(Debug)]
pub(super) struct ShaderModule {
    pub module: Option<usize>,
}

impl ShaderModuleInterface for ShaderModule {
    fn get_compilation_info(&self) -> std::pin::Pin<Box<dyn wgpu::custom::ShaderCompilationInfoFuture>> {
        Box::pin(std::future::ready(wgpu::CompilationInfo { messages: Vec::new() }))
    }
}

/// A vertex buffer's layout, owned.
#[derive(Debug, Clone)]
pub(super) struct VertexBuffer {
    pub stride: u64,
    pub instance: bool,
    pub attributes: Vec<wgpu::VertexAttribute>,
}

/// A render pipeline: its program (linked when made, checked at its first draw) and its fixed
/// state.
#[derive(Debug)]
pub(super) struct PipelineInner {
    pub ctx: u32,
    /// Its program (`None`: its stages were not translated, reported when it was made, or the
    /// context was lost: it draws nothing).
    pub program: Option<u32>,
    /// Vertex buffer layouts by slot.
    pub buffers: Vec<Option<VertexBuffer>>,
    pub primitive: wgpu::PrimitiveState,
    pub depth: Option<wgpu::DepthStencilState>,
    pub targets: Vec<Option<wgpu::ColorTargetState>>,
    pub groups: Vec<Option<Arc<Vec<wgpu::BindGroupLayoutEntry>>>>,
}

impl Drop for PipelineInner {
    fn drop(&mut self) {
        if let Some(id) = self.program {
            state::with_or_later(self.ctx, move |c| {
                if let Some(p) = c.programs.remove(id) {
                    // Never drawn with: its shaders wait for the check that deletes them.
                    if let Some((vs, fs, _, _)) = &p.pending {
                        c.gl.delete_shader(Some(vs));
                        c.gl.delete_shader(Some(fs));
                    }
                    c.gl.delete_program(Some(&p.program));
                }
            });
        }
        state::release(self.ctx);
    }
}

/// A render pipeline handle.
#[derive(Debug)]
pub(super) struct RenderPipeline {
    pub inner: Arc<PipelineInner>,
}

impl RenderPipelineInterface for RenderPipeline {
    fn get_bind_group_layout(&self, index: u32) -> DispatchBindGroupLayout {
        let entries = self.inner.groups.get(index as usize).cloned().flatten().unwrap_or_default();
        DispatchBindGroupLayout::custom(BindGroupLayout { inner: entries })
    }
}
