//! The backend itself (wasm32 only): the instance, adapter, device, queue and surface here,
//! the rest in `commands`, `resources`, `shaders` and `state` (see the module `gl`).

#[path = "commands.rs"]
mod commands;
#[path = "resources.rs"]
mod resources;
#[path = "shaders.rs"]
mod shaders;
#[path = "state.rs"]
mod state;

use super::table;

use std::pin::Pin;
use std::sync::{Arc, Mutex};

use wasm_bindgen::JsCast;
use web_sys::WebGl2RenderingContext as Gl;
use wgpu::custom::{
    AdapterInterface, BoxDeviceLostCallback, BoxSubmittedWorkDoneCallback, DeviceInterface, DispatchAdapter,
    DispatchBindGroup, DispatchBindGroupLayout, DispatchBlas, DispatchBuffer, DispatchCommandBuffer,
    DispatchCommandEncoder, DispatchComputePipeline, DispatchDevice, DispatchExternalTexture, DispatchPipelineCache,
    DispatchPipelineLayout, DispatchQuerySet, DispatchQueue, DispatchQueueWriteBuffer, DispatchRenderBundleEncoder,
    DispatchRenderPipeline, DispatchSampler, DispatchShaderModule, DispatchSurface, DispatchSurfaceOutputDetail,
    DispatchTexture, DispatchTlas, InstanceInterface, QueueInterface, SurfaceInterface, SurfaceOutputDetailInterface,
};

use resources::{
    BindGroup, BindGroupInner, BindGroupLayout, Buffer, PipelineInner, PipelineLayout, RenderPipeline, Resource,
    Sampler, ShaderModule, Staging, Texture, TextureView, VertexBuffer,
};

/// Makes a WebGL2 context on `canvas` with `attributes` and an instance of this backend on it
/// (its surface and adapter come from it as from any wgpu instance).
///
/// # Errors
/// When the browser gives no WebGL2 context.
pub fn instance(canvas: &web_sys::HtmlCanvasElement, attributes: &js_sys::Object) -> Result<wgpu::Instance, String> {
    let gl: Gl = canvas
        .get_context_with_context_options("webgl2", attributes)
        .ok()
        .flatten()
        .ok_or("the browser gives no WebGL2 context")?
        .dyn_into()
        .map_err(|_| "not a WebGL2 context")?;
    let float_render = gl.get_extension("EXT_color_buffer_float").ok().flatten().is_some();
    let float_linear = gl.get_extension("OES_texture_float_linear").ok().flatten().is_some();
    let renderer = gl
        .get_extension("WEBGL_debug_renderer_info")
        .ok()
        .flatten()
        .and_then(|_| gl.get_parameter(0x9246).ok())
        .or_else(|| gl.get_parameter(Gl::RENDERER).ok())
        .and_then(|v| v.as_string())
        .unwrap_or_else(|| "WebGL2".into());
    let max_texture = gl.get_parameter(Gl::MAX_TEXTURE_SIZE).ok().and_then(|v| v.as_f64()).unwrap_or(2048.0) as u32;
    // One vertex array, bound for good: every draw sets its attributes in it.
    gl.bind_vertex_array(gl.create_vertex_array().as_ref());
    let nearest = gl.create_sampler();
    if let Some(s) = &nearest {
        gl.sampler_parameteri(s, Gl::TEXTURE_MIN_FILTER, Gl::NEAREST as i32);
        gl.sampler_parameteri(s, Gl::TEXTURE_MAG_FILTER, Gl::NEAREST as i32);
    }
    gl.pixel_storei(Gl::UNPACK_ALIGNMENT, 1);
    gl.pixel_storei(Gl::PACK_ALIGNMENT, 1);
    let ctx = state::register(state::Context {
        gl,
        canvas: canvas.clone(),
        buffers: Default::default(),
        images: Default::default(),
        samplers: Default::default(),
        programs: Default::default(),
        framebuffers: Default::default(),
        nearest,
        enabled_attributes: 0,
        known: Default::default(),
        float_render,
        float_linear,
        max_texture,
        renderer,
        handles: 0,
    });
    Ok(wgpu::Instance::from_custom(Instance::new_on(ctx)))
}

/// Errors of a device: its handler and error scopes (see `wgpu::Device::on_uncaptured_error`).
#[derive(Default)]
pub(super) struct Errors {
    handler: Mutex<Option<Arc<dyn wgpu::UncapturedErrorHandler>>>,
    /// Open error scopes: what each catches and the first error it caught.
    scopes: Mutex<Vec<(wgpu::ErrorFilter, Option<wgpu::Error>)>>,
}

impl std::fmt::Debug for Errors {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Errors")
    }
}

impl Errors {
    /// A validation error: to the innermost scope that catches it, else the handler, else the
    /// console.
    pub fn report(&self, description: &str) {
        let error =
            wgpu::Error::Validation { source: description.to_owned().into(), description: description.to_owned() };
        if let Ok(mut scopes) = self.scopes.lock()
            && let Some(scope) = scopes.iter_mut().rev().find(|(f, _)| *f == wgpu::ErrorFilter::Validation)
        {
            scope.1.get_or_insert(error);
            return;
        }
        match self.handler.lock().ok().and_then(|h| h.clone()) {
            Some(handler) => handler(error),
            None => log::error!("kloub: WebGL2: {description}"),
        }
    }
}

/// What this backend cannot make (compute, queries, bundles, ray tracing, caches): creating one
/// is an error through the device's handler, and the object does nothing.
#[derive(Debug)]
pub(super) struct Unsupported;

/// Takes one handle of `ctx` (see [`state::retain`]).
#[derive(Debug)]
struct Handle(u32);

impl Handle {
    fn new(ctx: u32) -> Self {
        state::retain(ctx);
        Self(ctx)
    }
}

impl Drop for Handle {
    fn drop(&mut self) {
        state::release(self.0);
    }
}

#[derive(Debug)]
struct Instance {
    ctx: Handle,
}

impl Instance {
    fn new_on(ctx: u32) -> Self {
        Self { ctx: Handle::new(ctx) }
    }
}

#[allow(unsafe_code, reason = "the trait declares create_surface unsafe; it does nothing unsafe")]
impl InstanceInterface for Instance {
    fn new(_desc: wgpu::InstanceDescriptor) -> Self {
        // Instances of this backend are made on a canvas (`gl::instance`); this one has none.
        Self { ctx: Handle(u32::MAX) }
    }

    unsafe fn create_surface(
        &self,
        _target: wgpu::SurfaceTargetUnsafe,
    ) -> Result<DispatchSurface, wgpu::CreateSurfaceError> {
        // The instance's own canvas: `gl::instance` made the context on it.
        Ok(DispatchSurface::custom(Surface { ctx: Handle::new(self.ctx.0), config: Mutex::new(None) }))
    }

    fn request_adapter(
        &self,
        _options: &wgpu::RequestAdapterOptions<'_, '_>,
    ) -> Pin<Box<dyn wgpu::custom::RequestAdapterFuture>> {
        let adapter = DispatchAdapter::custom(Adapter { ctx: Handle::new(self.ctx.0) });
        Box::pin(std::future::ready(Ok(adapter)))
    }

    fn poll_all_devices(&self, _force_wait: bool) -> bool {
        true
    }

    fn wgsl_language_features(&self) -> wgpu::WgslLanguageFeatures {
        wgpu::WgslLanguageFeatures::empty()
    }

    fn enumerate_adapters(&self, _backends: wgpu::Backends) -> Pin<Box<dyn wgpu::custom::EnumerateAdapterFuture>> {
        let adapter = DispatchAdapter::custom(Adapter { ctx: Handle::new(self.ctx.0) });
        Box::pin(std::future::ready(vec![adapter]))
    }
}

#[derive(Debug)]
struct Adapter {
    ctx: Handle,
}

fn limits(ctx: u32) -> wgpu::Limits {
    let max = state::with(ctx, |c| c.max_texture).unwrap_or(2048);
    wgpu::Limits {
        max_texture_dimension_2d: max,
        max_texture_dimension_1d: max,
        ..wgpu::Limits::downlevel_webgl2_defaults()
    }
}

fn adapter_info(ctx: u32) -> wgpu::AdapterInfo {
    let name = state::with(ctx, |c| c.renderer.clone()).unwrap_or_default();
    let lower = name.to_lowercase();
    let device_type = if ["swiftshader", "llvmpipe", "software", "mesa offscreen"].iter().any(|s| lower.contains(s)) {
        wgpu::DeviceType::Cpu
    } else {
        wgpu::DeviceType::Other
    };
    wgpu::AdapterInfo { name, driver: "Kloub WebGL2".into(), ..wgpu::AdapterInfo::new(device_type, wgpu::Backend::Gl) }
}

impl AdapterInterface for Adapter {
    fn request_device(&self, desc: &wgpu::DeviceDescriptor<'_>) -> Pin<Box<dyn wgpu::custom::RequestDeviceFuture>> {
        let ctx = self.ctx.0;
        let have = limits(ctx);
        let result = if desc.required_limits.max_texture_dimension_2d > have.max_texture_dimension_2d {
            Err(wgpu::RequestDeviceError::from_message(format!(
                "textures of {} texels asked, the context has {}",
                desc.required_limits.max_texture_dimension_2d, have.max_texture_dimension_2d
            )))
        } else {
            let errors = Arc::new(Errors::default());
            let device = Device { ctx: Handle::new(ctx), errors: errors.clone(), lost: Mutex::new(None) };
            let queue = Queue { ctx: Handle::new(ctx), errors, submissions: Mutex::new(0) };
            Ok((DispatchDevice::custom(device), DispatchQueue::custom(queue)))
        };
        Box::pin(std::future::ready(result))
    }

    fn is_surface_supported(&self, _surface: &DispatchSurface) -> bool {
        true
    }

    fn features(&self) -> wgpu::Features {
        wgpu::Features::empty()
    }

    fn limits(&self) -> wgpu::Limits {
        limits(self.ctx.0)
    }

    fn downlevel_capabilities(&self) -> wgpu::DownlevelCapabilities {
        wgpu::DownlevelCapabilities {
            flags: wgpu::DownlevelFlags::empty(),
            limits: wgpu::DownlevelLimits::default(),
            shader_model: wgpu::ShaderModel::Sm2,
        }
    }

    fn get_info(&self) -> wgpu::AdapterInfo {
        adapter_info(self.ctx.0)
    }

    fn get_texture_format_features(&self, format: wgpu::TextureFormat) -> wgpu::TextureFormatFeatures {
        use wgpu::{TextureFormat as F, TextureFormatFeatureFlags as Flags, TextureUsages as U};
        let (float_render, float_linear) =
            state::with(self.ctx.0, |c| (c.float_render, c.float_linear)).unwrap_or_default();
        let sampled = U::TEXTURE_BINDING | U::COPY_DST;
        let multisample = Flags::MULTISAMPLE_X4 | Flags::MULTISAMPLE_RESOLVE;
        let (allowed_usages, flags) = match format {
            F::Rgba8Unorm | F::Rgba8UnormSrgb => {
                (sampled | U::RENDER_ATTACHMENT | U::COPY_SRC, Flags::FILTERABLE | multisample)
            }
            F::R8Unorm | F::Rg8Unorm => (sampled | U::RENDER_ATTACHMENT | U::COPY_SRC, Flags::FILTERABLE),
            F::Rgba16Float => {
                let render = if float_render { U::RENDER_ATTACHMENT } else { U::empty() };
                (sampled | render, Flags::FILTERABLE)
            }
            F::Rgba32Float | F::R32Float => {
                let render = if float_render { U::RENDER_ATTACHMENT } else { U::empty() };
                (sampled | render, if float_linear { Flags::FILTERABLE } else { Flags::empty() })
            }
            F::Rgba32Uint | F::R32Uint => (sampled | U::RENDER_ATTACHMENT | U::COPY_SRC, Flags::empty()),
            F::Depth32Float | F::Depth24Plus | F::Depth24PlusStencil8 => {
                (U::TEXTURE_BINDING | U::RENDER_ATTACHMENT, Flags::MULTISAMPLE_X4)
            }
            _ => (U::empty(), Flags::empty()),
        };
        wgpu::TextureFormatFeatures { allowed_usages, flags }
    }

    fn get_presentation_timestamp(&self) -> wgpu::PresentationTimestamp {
        wgpu::PresentationTimestamp::INVALID_TIMESTAMP
    }

    fn cooperative_matrix_properties(&self) -> Vec<wgpu::wgt::CooperativeMatrixProperties> {
        Vec::new()
    }
}

struct Device {
    ctx: Handle,
    errors: Arc<Errors>,
    lost: Mutex<Option<BoxDeviceLostCallback>>,
}

impl std::fmt::Debug for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Device({})", self.ctx.0)
    }
}

fn unsupported<T>(errors: &Errors, what: &str, make: impl FnOnce(Unsupported) -> T) -> T {
    errors.report(&format!("{what}: not in Kloub's WebGL2 backend"));
    make(Unsupported)
}

#[allow(unsafe_code, reason = "the trait declares these unsafe; they do nothing unsafe")]
impl DeviceInterface for Device {
    fn features(&self) -> wgpu::Features {
        wgpu::Features::empty()
    }

    fn limits(&self) -> wgpu::Limits {
        limits(self.ctx.0)
    }

    fn adapter_info(&self) -> wgpu::AdapterInfo {
        adapter_info(self.ctx.0)
    }

    fn create_shader_module(
        &self,
        desc: wgpu::ShaderModuleDescriptor<'_>,
        _checks: wgpu::ShaderRuntimeChecks,
    ) -> DispatchShaderModule {
        let module = match &desc.source {
            wgpu::ShaderSource::Wgsl(source) => table::module_for(source),
            _ => None,
        };
        if module.is_none() {
            self.errors
                .report(&format!("shader module {:?}: not among the shaders translated at build time", desc.label));
        }
        DispatchShaderModule::custom(ShaderModule { module })
    }

    unsafe fn create_shader_module_passthrough(
        &self,
        _desc: &wgpu::ShaderModuleDescriptorPassthrough<'_>,
    ) -> DispatchShaderModule {
        self.errors.report("passthrough shaders: not in Kloub's WebGL2 backend");
        DispatchShaderModule::custom(ShaderModule { module: None })
    }

    fn create_bind_group_layout(&self, desc: &wgpu::BindGroupLayoutDescriptor<'_>) -> DispatchBindGroupLayout {
        DispatchBindGroupLayout::custom(BindGroupLayout { inner: Arc::new(desc.entries.to_vec()) })
    }

    fn create_bind_group(&self, desc: &wgpu::BindGroupDescriptor<'_>) -> DispatchBindGroup {
        let layout = desc.layout.as_custom::<BindGroupLayout>().map(|l| l.inner.clone()).unwrap_or_default();
        let mut entries = Vec::with_capacity(desc.entries.len());
        for e in desc.entries {
            let resource = match &e.resource {
                wgpu::BindingResource::Buffer(b) => b.buffer.as_custom::<Buffer>().map(|buffer| Resource::Buffer {
                    buffer: buffer.inner.clone(),
                    offset: b.offset,
                    size: b.size.map_or(buffer.inner.size.saturating_sub(b.offset), std::num::NonZeroU64::get),
                }),
                wgpu::BindingResource::TextureView(v) => v.as_custom::<TextureView>().cloned().map(Resource::View),
                wgpu::BindingResource::Sampler(s) => {
                    s.as_custom::<Sampler>().map(|s| Resource::Sampler(s.inner.clone()))
                }
                _ => None,
            };
            match resource {
                Some(r) => entries.push((e.binding, r)),
                None => self.errors.report(&format!(
                    "bind group {:?}: binding {} of a kind this backend has not",
                    desc.label, e.binding
                )),
            }
        }
        let mut dynamic: Vec<u32> = layout
            .iter()
            .filter(|e| matches!(e.ty, wgpu::BindingType::Buffer { has_dynamic_offset: true, .. }))
            .map(|e| e.binding)
            .collect();
        dynamic.sort_unstable();
        DispatchBindGroup::custom(BindGroup { inner: Arc::new(BindGroupInner { entries, dynamic }) })
    }

    fn create_pipeline_layout(&self, desc: &wgpu::PipelineLayoutDescriptor<'_>) -> DispatchPipelineLayout {
        let groups = desc
            .bind_group_layouts
            .iter()
            .map(|l| l.and_then(|l| l.as_custom::<BindGroupLayout>()).map(|l| l.inner.clone()))
            .collect();
        DispatchPipelineLayout::custom(PipelineLayout { groups })
    }

    fn create_render_pipeline(&self, desc: &wgpu::RenderPipelineDescriptor<'_>) -> DispatchRenderPipeline {
        let ctx = self.ctx.0;
        let stage = |module: &wgpu::ShaderModule, entry: Option<&str>, kind, constants: &[(&str, f64)]| {
            let m = module.as_custom::<ShaderModule>().and_then(|m| m.module).ok_or("its module was not translated")?;
            table::stage(m, entry, kind, constants)
        };
        let vertex = stage(
            desc.vertex.module,
            desc.vertex.entry_point,
            table::GlStageKind::Vertex,
            desc.vertex.compilation_options.constants,
        );
        let fragment = desc
            .fragment
            .as_ref()
            .map(|f| stage(f.module, f.entry_point, table::GlStageKind::Fragment, f.compilation_options.constants))
            .transpose();
        let unreadable = desc
            .vertex
            .buffers
            .iter()
            .flatten()
            .flat_map(|b| b.attributes)
            .find(|a| commands::vertex_format(a.format).is_none());
        let vertex = match unreadable {
            Some(a) => Err(format!("vertex format {:?}", a.format)),
            None => vertex,
        };
        let (vertex, fragment) = match (vertex, fragment) {
            (Ok(v), Ok(f)) => (v, f),
            (Err(e), _) | (_, Err(e)) => {
                self.errors.report(&format!("render pipeline {:?}: {e}", desc.label));
                // An empty program: draws with it draw nothing.
                return DispatchRenderPipeline::custom(RenderPipeline {
                    inner: Arc::new(PipelineInner {
                        ctx: {
                            state::retain(ctx);
                            ctx
                        },
                        program: None,
                        buffers: Vec::new(),
                        primitive: desc.primitive,
                        depth: None,
                        targets: Vec::new(),
                        groups: Vec::new(),
                    }),
                });
            }
        };
        let groups =
            desc.layout.and_then(|l| l.as_custom::<PipelineLayout>()).map(|l| l.groups.clone()).unwrap_or_default();
        state::retain(ctx);
        // Linked now, checked at its first draw: the browser compiles it meanwhile.
        let program = state::with(ctx, |c| shaders::link(c, vertex, fragment)).flatten();
        DispatchRenderPipeline::custom(RenderPipeline {
            inner: Arc::new(PipelineInner {
                ctx,
                program,
                buffers: desc
                    .vertex
                    .buffers
                    .iter()
                    .map(|b| {
                        b.as_ref().map(|b| VertexBuffer {
                            stride: b.array_stride,
                            instance: b.step_mode == wgpu::VertexStepMode::Instance,
                            attributes: b.attributes.to_vec(),
                        })
                    })
                    .collect(),
                primitive: desc.primitive,
                depth: desc.depth_stencil.clone(),
                targets: desc.fragment.as_ref().map(|f| f.targets.to_vec()).unwrap_or_default(),
                groups,
            }),
        })
    }

    fn create_mesh_pipeline(&self, _desc: &wgpu::MeshPipelineDescriptor<'_>) -> DispatchRenderPipeline {
        unsupported(&self.errors, "mesh pipelines", DispatchRenderPipeline::custom)
    }

    fn create_compute_pipeline(&self, _desc: &wgpu::ComputePipelineDescriptor<'_>) -> DispatchComputePipeline {
        unsupported(&self.errors, "compute pipelines", DispatchComputePipeline::custom)
    }

    unsafe fn create_pipeline_cache(&self, _desc: &wgpu::PipelineCacheDescriptor<'_>) -> DispatchPipelineCache {
        unsupported(&self.errors, "pipeline caches", DispatchPipelineCache::custom)
    }

    fn create_buffer(&self, desc: &wgpu::BufferDescriptor<'_>) -> DispatchBuffer {
        DispatchBuffer::custom(Buffer::new(self.ctx.0, desc))
    }

    fn create_texture(&self, desc: &wgpu::TextureDescriptor<'_>) -> DispatchTexture {
        match Texture::new(self.ctx.0, desc) {
            Ok(t) => DispatchTexture::custom(t),
            Err(e) => {
                self.errors.report(&format!("texture {:?}: {e}", desc.label));
                DispatchTexture::custom(Texture::invalid(self.ctx.0, desc.format))
            }
        }
    }

    fn create_external_texture(
        &self,
        _desc: &wgpu::ExternalTextureDescriptor<'_>,
        _planes: &[&wgpu::TextureView],
    ) -> DispatchExternalTexture {
        unsupported(&self.errors, "external textures", DispatchExternalTexture::custom)
    }

    fn create_blas(
        &self,
        _desc: &wgpu::CreateBlasDescriptor<'_>,
        _sizes: wgpu::BlasGeometrySizeDescriptors,
    ) -> (Option<u64>, DispatchBlas) {
        (None, unsupported(&self.errors, "ray tracing", DispatchBlas::custom))
    }

    fn create_tlas(&self, _desc: &wgpu::CreateTlasDescriptor<'_>) -> DispatchTlas {
        unsupported(&self.errors, "ray tracing", DispatchTlas::custom)
    }

    fn create_sampler(&self, desc: &wgpu::SamplerDescriptor<'_>) -> DispatchSampler {
        DispatchSampler::custom(Sampler::new(self.ctx.0, desc))
    }

    fn create_query_set(&self, _desc: &wgpu::QuerySetDescriptor<'_>) -> DispatchQuerySet {
        unsupported(&self.errors, "query sets", DispatchQuerySet::custom)
    }

    fn create_command_encoder(&self, _desc: &wgpu::CommandEncoderDescriptor<'_>) -> DispatchCommandEncoder {
        DispatchCommandEncoder::custom(commands::CommandEncoder {
            commands: Default::default(),
            errors: self.errors.clone(),
        })
    }

    fn create_render_bundle_encoder(
        &self,
        _desc: &wgpu::RenderBundleEncoderDescriptor<'_>,
    ) -> DispatchRenderBundleEncoder {
        unsupported(&self.errors, "render bundles", DispatchRenderBundleEncoder::custom)
    }

    fn set_device_lost_callback(&self, callback: BoxDeviceLostCallback) {
        if let Ok(mut lost) = self.lost.lock() {
            *lost = Some(callback);
        }
    }

    fn on_uncaptured_error(&self, handler: Arc<dyn wgpu::UncapturedErrorHandler>) {
        if let Ok(mut h) = self.errors.handler.lock() {
            *h = Some(handler);
        }
    }

    fn push_error_scope(&self, filter: wgpu::ErrorFilter) -> u32 {
        self.errors
            .scopes
            .lock()
            .map(|mut s| {
                s.push((filter, None));
                s.len() as u32 - 1
            })
            .unwrap_or(0)
    }

    fn pop_error_scope(&self, index: u32) -> Pin<Box<dyn wgpu::custom::PopErrorScopeFuture>> {
        let error = self
            .errors
            .scopes
            .lock()
            .ok()
            .and_then(|mut s| if s.len() as u32 == index + 1 { s.pop().and_then(|(_, e)| e) } else { None });
        Box::pin(std::future::ready(error))
    }

    unsafe fn start_graphics_debugger_capture(&self) {}

    unsafe fn stop_graphics_debugger_capture(&self) {}

    fn poll(&self, _poll_type: wgpu::wgt::PollType<u64>) -> Result<wgpu::PollStatus, wgpu::PollError> {
        // Everything submitted ran when it was submitted.
        Ok(wgpu::PollStatus::QueueEmpty)
    }

    fn get_internal_counters(&self) -> wgpu::InternalCounters {
        wgpu::InternalCounters::default()
    }

    fn generate_allocator_report(&self) -> Option<wgpu::AllocatorReport> {
        None
    }

    fn destroy(&self) {
        // As WebGPU's `destroy`: the context is lost (the page hears `webglcontextlost`).
        state::with(self.ctx.0, |c| {
            if let Ok(Some(ext)) = c.gl.get_extension("WEBGL_lose_context")
                && let Ok(lose) = js_sys::Reflect::get(&ext, &"loseContext".into())
                && let Ok(lose) = lose.dyn_into::<js_sys::Function>()
            {
                let _ = lose.call0(&ext);
            }
        });
        if let Some(callback) = self.lost.lock().ok().and_then(|mut l| l.take()) {
            callback(wgpu::DeviceLostReason::Destroyed, String::new());
        }
    }
}

#[derive(Debug)]
struct Queue {
    ctx: Handle,
    errors: Arc<Errors>,
    submissions: Mutex<u64>,
}

impl QueueInterface for Queue {
    fn write_buffer(&self, buffer: &DispatchBuffer, offset: wgpu::BufferAddress, data: &[u8]) {
        if let Some(b) = buffer.as_custom::<Buffer>() {
            b.inner.write(offset, data);
        }
    }

    fn create_staging_buffer(&self, size: wgpu::BufferSize) -> Option<DispatchQueueWriteBuffer> {
        Some(DispatchQueueWriteBuffer::custom(Staging { bytes: vec![0; size.get() as usize] }))
    }

    fn validate_write_buffer(
        &self,
        buffer: &DispatchBuffer,
        offset: wgpu::BufferAddress,
        size: wgpu::BufferSize,
    ) -> Option<()> {
        let b = buffer.as_custom::<Buffer>()?;
        (offset + size.get() <= b.inner.size).then_some(())
    }

    fn write_staging_buffer(
        &self,
        buffer: &DispatchBuffer,
        offset: wgpu::BufferAddress,
        staging: &DispatchQueueWriteBuffer,
    ) {
        if let (Some(b), Some(s)) = (buffer.as_custom::<Buffer>(), staging.as_custom::<Staging>()) {
            b.inner.write(offset, &s.bytes);
        }
    }

    fn write_texture(
        &self,
        texture: wgpu::TexelCopyTextureInfo<'_>,
        data: &[u8],
        layout: wgpu::TexelCopyBufferLayout,
        size: wgpu::Extent3d,
    ) {
        let Some(t) = texture.texture.as_custom::<Texture>() else { return };
        let Some((_, format, kind, texel)) = resources::format(t.inner.format) else { return };
        let Some(id) = t.inner.id else { return };
        let data = data.get(layout.offset as usize..).unwrap_or(&[]);
        state::with(self.ctx.0, |c| {
            let Some(state::Image::Texture { texture: gl_texture, .. }) = c.images.get(id) else { return };
            let gl = &c.gl;
            gl.bind_texture(Gl::TEXTURE_2D, Some(gl_texture));
            let extent = resources::copy_extent(size.width, size.height, texel, layout.bytes_per_row);
            let (row, data) =
                match extent.and_then(|(row, len)| Ok((row, data.get(..len).ok_or("data shorter than the copy")?))) {
                    Ok(copy) => copy,
                    Err(e) => {
                        self.errors.report(&format!("write_texture: {e}"));
                        return;
                    }
                };
            gl.pixel_storei(Gl::UNPACK_ROW_LENGTH, (row / texel) as i32);
            let result = if kind == Gl::UNSIGNED_BYTE {
                gl.tex_sub_image_2d_with_i32_and_i32_and_u32_and_type_and_opt_u8_array(
                    Gl::TEXTURE_2D,
                    texture.mip_level as i32,
                    texture.origin.x as i32,
                    texture.origin.y as i32,
                    size.width as i32,
                    size.height as i32,
                    format,
                    kind,
                    Some(data),
                )
            } else {
                gl.tex_sub_image_2d_with_i32_and_i32_and_u32_and_type_and_opt_array_buffer_view(
                    Gl::TEXTURE_2D,
                    texture.mip_level as i32,
                    texture.origin.x as i32,
                    texture.origin.y as i32,
                    size.width as i32,
                    size.height as i32,
                    format,
                    kind,
                    Some(&resources::texel_array(kind, data).0),
                )
            };
            let _ = result;
            gl.pixel_storei(Gl::UNPACK_ROW_LENGTH, 0);
        });
    }

    fn copy_external_image_to_texture(
        &self,
        source: &wgpu::CopyExternalImageSourceInfo,
        dest: wgpu::CopyExternalImageDestInfo<&wgpu::Texture>,
        size: wgpu::Extent3d,
    ) {
        let Some(t) = dest.texture.as_custom::<Texture>() else { return };
        let Some((_, format, kind, _)) = resources::format(t.inner.format) else { return };
        let Some(id) = t.inner.id else { return };
        let wgpu::ExternalImageSource::ImageBitmap(bitmap) = &source.source else {
            self.errors.report("copy_external_image_to_texture: only image bitmaps in Kloub's WebGL2 backend");
            return;
        };
        if source.origin.x != 0
            || source.origin.y != 0
            || size.width != bitmap.width()
            || size.height != bitmap.height()
        {
            self.errors.report("copy_external_image_to_texture: only whole images in Kloub's WebGL2 backend");
            return;
        }
        state::with(self.ctx.0, |c| {
            let Some(state::Image::Texture { texture, .. }) = c.images.get(id) else { return };
            let gl = &c.gl;
            gl.bind_texture(Gl::TEXTURE_2D, Some(texture));
            gl.pixel_storei(Gl::UNPACK_FLIP_Y_WEBGL, i32::from(source.flip_y));
            gl.pixel_storei(Gl::UNPACK_PREMULTIPLY_ALPHA_WEBGL, i32::from(dest.premultiplied_alpha));
            gl.pixel_storei(Gl::UNPACK_COLORSPACE_CONVERSION_WEBGL, Gl::NONE as i32);
            let _ = gl.tex_sub_image_2d_with_u32_and_u32_and_image_bitmap(
                Gl::TEXTURE_2D,
                dest.mip_level as i32,
                dest.origin.x as i32,
                dest.origin.y as i32,
                format,
                kind,
                bitmap,
            );
            gl.pixel_storei(Gl::UNPACK_FLIP_Y_WEBGL, 0);
            gl.pixel_storei(Gl::UNPACK_PREMULTIPLY_ALPHA_WEBGL, 0);
        });
    }

    fn submit(&self, command_buffers: &mut dyn Iterator<Item = DispatchCommandBuffer>) -> u64 {
        for buffer in command_buffers {
            if let Some(b) = buffer.as_custom::<commands::CommandBuffer>() {
                let list = b.commands.lock().map(|mut c| std::mem::take(&mut *c)).unwrap_or_default();
                commands::execute(self.ctx.0, &list, &self.errors);
            }
        }
        self.submissions
            .lock()
            .map(|mut n| {
                *n += 1;
                *n
            })
            .unwrap_or(0)
    }

    fn get_timestamp_period(&self) -> f32 {
        1.0
    }

    fn on_submitted_work_done(&self, callback: BoxSubmittedWorkDoneCallback) {
        wasm_bindgen_futures::spawn_local(async move { callback() });
    }

    fn compact_blas(&self, _blas: &DispatchBlas) -> (Option<u64>, DispatchBlas) {
        (None, unsupported(&self.errors, "ray tracing", DispatchBlas::custom))
    }

    fn present(&self, _detail: &DispatchSurfaceOutputDetail) {
        // The browser shows the canvas's framebuffer when the task ends: it was drawn into.
    }
}

/// The canvas of the context, as a surface.
#[derive(Debug)]
struct Surface {
    ctx: Handle,
    config: Mutex<Option<(wgpu::TextureFormat, [u32; 2])>>,
}

impl SurfaceInterface for Surface {
    fn get_capabilities(&self, _adapter: &DispatchAdapter) -> wgpu::SurfaceCapabilities {
        wgpu::SurfaceCapabilities {
            formats: vec![wgpu::TextureFormat::Rgba8Unorm],
            present_modes: vec![wgpu::PresentMode::Fifo],
            alpha_modes: vec![wgpu::CompositeAlphaMode::PreMultiplied],
            usages: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            ..Default::default()
        }
    }

    fn configure(&self, _device: &DispatchDevice, config: &wgpu::SurfaceConfiguration) {
        state::with(self.ctx.0, |c| {
            if c.canvas.width() != config.width {
                c.canvas.set_width(config.width);
            }
            if c.canvas.height() != config.height {
                c.canvas.set_height(config.height);
            }
        });
        if let Ok(mut c) = self.config.lock() {
            *c = Some((config.format, [config.width, config.height]));
        }
    }

    fn get_current_texture(&self) -> (Option<DispatchTexture>, wgpu::SurfaceStatus, DispatchSurfaceOutputDetail) {
        let config = self.config.lock().ok().and_then(|c| *c);
        let lost = state::with(self.ctx.0, |c| c.gl.is_context_lost()).unwrap_or(true);
        let detail = DispatchSurfaceOutputDetail::custom(OutputDetail);
        match config {
            Some((format, size)) if !lost => (
                Some(DispatchTexture::custom(Texture::surface(self.ctx.0, format, size))),
                wgpu::SurfaceStatus::Good,
                detail,
            ),
            Some(_) => (None, wgpu::SurfaceStatus::Lost, detail),
            None => (None, wgpu::SurfaceStatus::Outdated, detail),
        }
    }
}

#[derive(Debug)]
struct OutputDetail;

impl SurfaceOutputDetailInterface for OutputDetail {
    fn texture_discard(&self) {}
    fn texture_release(&self) {}
}

mod unsupported_impls {
    //! [`Unsupported`](super::Unsupported) as every object this backend does not make.

    use wgpu::custom::*;

    use super::Unsupported;

    impl ComputePipelineInterface for Unsupported {
        fn get_bind_group_layout(&self, _index: u32) -> DispatchBindGroupLayout {
            DispatchBindGroupLayout::custom(super::BindGroupLayout { inner: Default::default() })
        }
    }
    impl RenderPipelineInterface for Unsupported {
        fn get_bind_group_layout(&self, _index: u32) -> DispatchBindGroupLayout {
            DispatchBindGroupLayout::custom(super::BindGroupLayout { inner: Default::default() })
        }
    }
    impl PipelineCacheInterface for Unsupported {
        fn get_data(&self) -> Option<Vec<u8>> {
            None
        }
    }
    impl ExternalTextureInterface for Unsupported {
        fn destroy(&self) {}
    }
    impl BlasInterface for Unsupported {
        fn prepare_compact_async(&self, _callback: BlasCompactCallback) {}
        fn ready_for_compaction(&self) -> bool {
            false
        }
    }
    impl TlasInterface for Unsupported {}
    impl QuerySetInterface for Unsupported {
        fn destroy(&self) {}
    }
    impl RenderBundleInterface for Unsupported {}
    impl RenderBundleEncoderInterface for Unsupported {
        fn set_pipeline(&mut self, _: &DispatchRenderPipeline) {}
        fn set_bind_group(&mut self, _: u32, _: Option<&DispatchBindGroup>, _: &[wgpu::DynamicOffset]) {}
        fn set_index_buffer(
            &mut self,
            _: &DispatchBuffer,
            _: wgpu::IndexFormat,
            _: wgpu::BufferAddress,
            _: Option<wgpu::BufferSize>,
        ) {
        }
        fn set_vertex_buffer(
            &mut self,
            _: u32,
            _: Option<&DispatchBuffer>,
            _: wgpu::BufferAddress,
            _: Option<wgpu::BufferSize>,
        ) {
        }
        fn set_immediates(&mut self, _: u32, _: &[u8]) {}
        fn draw(&mut self, _: std::ops::Range<u32>, _: std::ops::Range<u32>) {}
        fn draw_indexed(&mut self, _: std::ops::Range<u32>, _: i32, _: std::ops::Range<u32>) {}
        fn draw_indirect(&mut self, _: &DispatchBuffer, _: wgpu::BufferAddress) {}
        fn draw_indexed_indirect(&mut self, _: &DispatchBuffer, _: wgpu::BufferAddress) {}
        fn finish(self, _desc: &wgpu::RenderBundleDescriptor<'_>) -> DispatchRenderBundle {
            DispatchRenderBundle::custom(Unsupported)
        }
        fn finish_boxed(self: Box<Self>, desc: &wgpu::RenderBundleDescriptor<'_>) -> DispatchRenderBundle {
            (*self).finish(desc)
        }
    }
    impl Drop for Unsupported {
        fn drop(&mut self) {}
    }
    impl ComputePassInterface for Unsupported {
        fn set_pipeline(&mut self, _: &DispatchComputePipeline) {}
        fn set_bind_group(&mut self, _: u32, _: Option<&DispatchBindGroup>, _: &[wgpu::DynamicOffset]) {}
        fn set_immediates(&mut self, _: u32, _: &[u8]) {}
        fn insert_debug_marker(&mut self, _: &str) {}
        fn push_debug_group(&mut self, _: &str) {}
        fn pop_debug_group(&mut self) {}
        fn write_timestamp(&mut self, _: &DispatchQuerySet, _: u32) {}
        fn begin_pipeline_statistics_query(&mut self, _: &DispatchQuerySet, _: u32) {}
        fn end_pipeline_statistics_query(&mut self) {}
        fn dispatch_workgroups(&mut self, _: u32, _: u32, _: u32) {}
        fn dispatch_workgroups_indirect(&mut self, _: &DispatchBuffer, _: wgpu::BufferAddress) {}
        fn transition_resources<'a>(
            &mut self,
            _: &mut dyn Iterator<Item = wgpu::wgt::BufferTransition<&'a DispatchBuffer>>,
            _: &mut dyn Iterator<Item = wgpu::wgt::TextureTransition<&'a DispatchTextureView>>,
        ) {
        }
    }
}
