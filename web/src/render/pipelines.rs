//! Bind group layouts, shader modules and render pipelines (mesh variants built on demand).

use std::collections::HashMap;

use kloub_core::asset::Topology;

/// The wgpu topology of a glTF primitive.
pub fn topology(topology: Topology) -> wgpu::PrimitiveTopology {
    match topology {
        Topology::Points => wgpu::PrimitiveTopology::PointList,
        Topology::Lines => wgpu::PrimitiveTopology::LineList,
        Topology::Triangles => wgpu::PrimitiveTopology::TriangleList,
    }
}

use super::mesh::{ATTRIBUTE_STRIDE, GEOMETRY_STRIDE, PIVOT_STRIDE, SKIN_STRIDE, TANGENT_STRIDE};
use super::uniforms::{DrawUniform, FrameUniform, MaterialUniform};

/// Depth buffer format.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// `shaders/skinning.wgsl` + `shaders/output.wgsl` + `shaders/equirect.wgsl` +
/// `shaders/mesh.wgsl`: the mesh pipelines (vertex-shader skinning). Each file as `web/build.rs`
/// embeds it: without comments, indentation or blank lines.
pub const MESH_WGSL: &str = concat!(
    include_str!(concat!(env!("OUT_DIR"), "/skinning.wgsl")),
    include_str!(concat!(env!("OUT_DIR"), "/output.wgsl")),
    include_str!(concat!(env!("OUT_DIR"), "/equirect.wgsl")),
    include_str!(concat!(env!("OUT_DIR"), "/mesh.wgsl"))
);
/// `shaders/equirect.wgsl` + `shaders/ibl.wgsl`: prefiltering environments.
pub const IBL_WGSL: &str = concat!(
    include_str!(concat!(env!("OUT_DIR"), "/equirect.wgsl")),
    include_str!(concat!(env!("OUT_DIR"), "/ibl.wgsl"))
);
/// `shaders/skinning.wgsl` + `shaders/skin_compute.wgsl`: compute skinning (not on WebGL2).
pub const SKIN_COMPUTE_WGSL: &str = concat!(
    include_str!(concat!(env!("OUT_DIR"), "/skinning.wgsl")),
    include_str!(concat!(env!("OUT_DIR"), "/skin_compute.wgsl"))
);
/// `shaders/output.wgsl` + `shaders/environment.wgsl`.
pub const ENVIRONMENT_WGSL: &str = concat!(
    include_str!(concat!(env!("OUT_DIR"), "/output.wgsl")),
    include_str!(concat!(env!("OUT_DIR"), "/environment.wgsl"))
);

/// `shaders/mip.wgsl`: a mip level from the one above it, for images the browser decoded.
pub const MIP_WGSL: &str = include_str!(concat!(env!("OUT_DIR"), "/mip.wgsl"));

/// A shader module's source for `create_shader_module`: `$wgsl` (one of the consts above); in the
/// WebGL2 widget (Kloub's WebGL2 backend without WebGPU: `gl` without `webgpu`) only the key its
/// GLSL is filed under ([`crate::gl::hash::source_hash`], computed when the crate is compiled,
/// after [`crate::gl::KEYED`]), so that the WGSL text is not in that module (its first download
/// is ~12 KB gzip smaller).
macro_rules! shader_source {
    ($wgsl:expr) => {{
        #[cfg(all(feature = "gl", not(feature = "webgpu")))]
        let source = {
            const KEY: u64 = $crate::gl::hash::source_hash($wgsl);
            wgpu::ShaderSource::Wgsl(format!("{}{KEY:016x}", $crate::gl::KEYED).into())
        };
        #[cfg(not(all(feature = "gl", not(feature = "webgpu"))))]
        let source = wgpu::ShaderSource::Wgsl($wgsl.into());
        source
    }};
}
pub(crate) use shader_source;

/// Every shader module the renderer compiles: name, WGSL source, whether it runs on WebGL2.
pub const SHADER_MODULES: [(&str, &str, bool); 5] = [
    ("mesh", MESH_WGSL, true),
    ("ibl", IBL_WGSL, true),
    ("skin_compute", SKIN_COMPUTE_WGSL, false),
    ("environment", ENVIRONMENT_WGSL, true),
    ("mip", MIP_WGSL, true),
];

const GEOMETRY_ATTRIBUTES: [wgpu::VertexAttribute; 2] = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];
const ATTRIBUTE_ATTRIBUTES: [wgpu::VertexAttribute; 3] =
    wgpu::vertex_attr_array![2 => Float32x2, 10 => Float32x2, 3 => Float32x4];
const SKIN_ATTRIBUTES: [wgpu::VertexAttribute; 4] =
    wgpu::vertex_attr_array![4 => Uint16x4, 5 => Uint16x4, 6 => Float32x4, 7 => Float32x4];
const PIVOT_ATTRIBUTES: [wgpu::VertexAttribute; 2] = wgpu::vertex_attr_array![8 => Float32x3, 9 => Uint32];
const TANGENT_ATTRIBUTES: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![11 => Float32x4];
/// The world caster's positions (`vs_caster_world`).
const WORLD_ATTRIBUTES: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![0 => Float32x3];

/// The vertex buffer slot of the tangent stream: after geometry and attributes in a static
/// draw, after the skin and pivot streams in a skinned one.
pub fn tangent_slot(vertex: VertexPath) -> u32 {
    match vertex {
        VertexPath::Static => 2,
        VertexPath::Skinned => 4,
    }
}

/// Format of the capture targets (the bits of the world position and unit normal).
pub const CAPTURE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Uint;

fn layout(stride: u64, attributes: &'static [wgpu::VertexAttribute]) -> Option<wgpu::VertexBufferLayout<'static>> {
    Some(wgpu::VertexBufferLayout { array_stride: stride, step_mode: wgpu::VertexStepMode::Vertex, attributes })
}

/// The vertex buffer layouts of a skinned draw: geometry, attributes, skin, pivots, tangents
/// ([`tangent_slot`]).
fn skinned_buffers() -> [Option<wgpu::VertexBufferLayout<'static>>; 5] {
    [
        layout(GEOMETRY_STRIDE, &GEOMETRY_ATTRIBUTES),
        layout(ATTRIBUTE_STRIDE, &ATTRIBUTE_ATTRIBUTES),
        layout(SKIN_STRIDE, &SKIN_ATTRIBUTES),
        layout(PIVOT_STRIDE, &PIVOT_ATTRIBUTES),
        layout(TANGENT_STRIDE, &TANGENT_ATTRIBUTES),
    ]
}

/// The vertex buffer layouts of a static draw: geometry, attributes, tangents.
fn static_buffers() -> [Option<wgpu::VertexBufferLayout<'static>>; 3] {
    [
        layout(GEOMETRY_STRIDE, &GEOMETRY_ATTRIBUTES),
        layout(ATTRIBUTE_STRIDE, &ATTRIBUTE_ATTRIBUTES),
        layout(TANGENT_STRIDE, &TANGENT_ATTRIBUTES),
    ]
}

/// A uniform buffer binding of `size` bytes.
pub(super) fn uniform_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    size: usize,
    dynamic: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: dynamic,
            min_binding_size: wgpu::BufferSize::new(size as u64),
        },
        count: None,
    }
}

/// A 2D texture binding.
pub(super) fn texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    sample_type: wgpu::TextureSampleType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// A sampler binding of `kind`.
pub(super) fn sampler_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    kind: wgpu::SamplerBindingType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry { binding, visibility, ty: wgpu::BindingType::Sampler(kind), count: None }
}

/// Textures of a material (`TEX_*` in mesh.wgsl): base colour, metallic-roughness, normal,
/// occlusion, emissive; texture `k` is bound at `1 + 2k`, its sampler at `2 + 2k`.
pub const MATERIAL_TEXTURES: usize = 5;

/// The bind group layouts shared by all pipelines.
#[derive(Clone)]
pub struct Layouts {
    /// Group 0: frame uniform + joint palette texture + morph texture.
    pub frame: wgpu::BindGroupLayout,
    /// Group 1: material uniform + [`MATERIAL_TEXTURES`] textures, each followed by its sampler.
    pub material: wgpu::BindGroupLayout,
    /// Group 2: draw uniform (dynamic offset).
    pub draw: wgpu::BindGroupLayout,
    /// Group 3: the environment's specular chain and its sampler.
    pub environment: wgpu::BindGroupLayout,
    /// Group 1 of the ground shadow's mask pass: its uniform, the shadow map and a comparison
    /// sampler.
    pub shadow: wgpu::BindGroupLayout,
    /// Group 1 of the ground shadow's ground pass: its uniform, the mask and a linear sampler.
    pub shadow_ground: wgpu::BindGroupLayout,
}

impl Layouts {
    /// Creates the layouts.
    pub fn new(device: &wgpu::Device) -> Self {
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let frame = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("kloub frame"),
            entries: &[
                uniform_entry(0, vf, size_of::<FrameUniform>(), false),
                texture_entry(1, wgpu::ShaderStages::VERTEX, wgpu::TextureSampleType::Float { filterable: false }),
                texture_entry(2, wgpu::ShaderStages::VERTEX, wgpu::TextureSampleType::Float { filterable: false }),
            ],
        });
        let mut entries = vec![uniform_entry(0, wgpu::ShaderStages::FRAGMENT, size_of::<MaterialUniform>(), false)];
        for slot in 0..MATERIAL_TEXTURES as u32 {
            let filterable = wgpu::TextureSampleType::Float { filterable: true };
            entries.push(texture_entry(1 + 2 * slot, wgpu::ShaderStages::FRAGMENT, filterable));
            entries.push(sampler_entry(
                2 + 2 * slot,
                wgpu::ShaderStages::FRAGMENT,
                wgpu::SamplerBindingType::Filtering,
            ));
        }
        let material = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("kloub material"),
            entries: &entries,
        });
        let draw = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("kloub draw"),
            entries: &[uniform_entry(0, vf, size_of::<DrawUniform>(), true)],
        });
        let f = wgpu::ShaderStages::FRAGMENT;
        let filterable = wgpu::TextureSampleType::Float { filterable: true };
        let environment = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("kloub environment"),
            entries: &[texture_entry(0, f, filterable), sampler_entry(1, f, wgpu::SamplerBindingType::Filtering)],
        });
        let shadow = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("kloub shadow"),
            entries: &[
                uniform_entry(0, vf, size_of::<super::uniforms::ShadowUniform>(), false),
                texture_entry(1, f, wgpu::TextureSampleType::Depth),
                sampler_entry(2, f, wgpu::SamplerBindingType::Comparison),
            ],
        });
        let shadow_ground = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("kloub shadow ground"),
            entries: &[
                uniform_entry(0, vf, size_of::<super::uniforms::ShadowUniform>(), false),
                texture_entry(3, f, filterable),
                sampler_entry(4, f, wgpu::SamplerBindingType::Filtering),
            ],
        });
        Self { frame, material, draw, environment, shadow, shadow_ground }
    }
}

/// How a mesh draw's vertices reach world space.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VertexPath {
    /// Transformed by the draw's model matrix (`vs_static`).
    Static,
    /// Morphed and skinned with the palette texture (`vs_skinned`).
    Skinned,
}

/// Everything that selects a mesh pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PipelineKey {
    /// Vertex shader entry and vertex buffers.
    pub vertex: VertexPath,
    /// Primitive topology.
    pub topology: wgpu::PrimitiveTopology,
    /// Alpha blended (drawn after opaque, no depth writes).
    pub blend: bool,
    /// No back-face culling.
    pub double_sided: bool,
    /// Clockwise front faces (a world matrix with negative determinant mirrors the winding).
    pub mirrored: bool,
    /// Skinned draws: the skinning method compiled in (a `SKIN_*` code of the shaders), or
    /// [`SKIN_FROM_DRAW`] to read it from each draw's uniform.
    pub skinning: u32,
    /// Skinned draws: the deviation heatmap compiled in.
    pub heatmap: bool,
    /// A shadow caster: depth only, into the single-sampled [`SHADOW_FORMAT`] map, with a
    /// slope-scaled depth bias; for a single-sided material only the faces turned towards the
    /// light (both for a double-sided one): a closed mesh's far side adds nothing to the
    /// ground's shadow, and the rasterizer skips it. An open single-sided sheet (a cape, a
    /// card) casts only where its front faces the light, the side it is seen from; three.js
    /// draws the back faces of such materials instead.
    pub caster: bool,
    /// A caster of an alpha-masked material: it discards where the material does (always
    /// false in colour pipelines: the material's flags say it there).
    pub mask: bool,
    /// The tangent stream compiled in (`TANGENTS` in skinning.wgsl): a normal-mapped primitive
    /// with tangents. Without, the vertex shader neither fetches nor transforms them.
    pub tangents: bool,
    /// The material's optional textures compiled into the fragment shader (`TEXTURES` in
    /// mesh.wgsl; [`super::uniforms::optional_textures`]).
    pub textures: u8,
    /// The ambient light compiled in (`ENVIRONMENT` in mesh.wgsl): the prefiltered environment,
    /// or the hemisphere where the frame has none.
    pub ibl: bool,
}

impl PipelineKey {
    /// The caster variant of this draw's pipeline, for an alpha-masked material with `mask`;
    /// `None` for what casts no shadow (blended draws, points and lines).
    pub fn caster(self, mask: bool) -> Option<Self> {
        (!self.blend && self.topology == wgpu::PrimitiveTopology::TriangleList).then_some(Self {
            // Winding matters only where a face is culled.
            mirrored: self.mirrored && !self.double_sided,
            heatmap: false,
            caster: true,
            mask,
            tangents: false,
            textures: 0,
            ibl: false,
            ..self
        })
    }
}

/// The shadow map's format.
pub const SHADOW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// The ground shadow mask's format (how much light is blocked, 0..1).
pub const SHADOW_MASK_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R8Unorm;

/// [`PipelineKey::skinning`] for a pipeline that reads the method from each draw.
pub const SKIN_FROM_DRAW: u32 = 4;

/// Shader modules and pipelines for one sample count.
#[derive(Clone)]
pub struct Pipelines {
    /// The page device's sharing key ([`kit`]): variants built here are offered to the other
    /// viewers of the device, and theirs taken (`None`: nothing shared).
    share: Option<u32>,
    sample_count: u32,
    format: wgpu::TextureFormat,
    mesh_module: wgpu::ShaderModule,
    mesh_layout: wgpu::PipelineLayout,
    /// The background and grid pipelines, built when first drawn (an embedded viewer draws
    /// neither by default), and the mip maker: shared by the clones of a kit.
    first_use: std::sync::Arc<FirstUse>,
    mesh: HashMap<PipelineKey, wgpu::RenderPipeline>,
}

/// Pipelines built on first use: `shaders/environment.wgsl`'s, and the mips of the images the
/// browser decoded.
struct FirstUse {
    /// `environment.wgsl` and its layout.
    module: wgpu::ShaderModule,
    layout: wgpu::PipelineLayout,
    /// Background gradient (full-screen triangle).
    background: std::sync::OnceLock<wgpu::RenderPipeline>,
    /// Ground grid (blended quad).
    grid: std::sync::OnceLock<wgpu::RenderPipeline>,
    /// The ground shadow (blended quad) and its layout (frame, shadow ground).
    shadow: std::sync::OnceLock<wgpu::RenderPipeline>,
    shadow_ground_layout: wgpu::PipelineLayout,
    /// The ground shadow's mask pass and its layout (frame, shadow).
    shadow_mask: std::sync::OnceLock<wgpu::RenderPipeline>,
    shadow_layout: wgpu::PipelineLayout,
    /// Shadow casters in world space, every copy's in one draw ([`Pipelines::world_caster`]).
    world_caster: std::sync::OnceLock<wgpu::RenderPipeline>,
    /// Mip levels on the GPU (`shaders/mip.wgsl`), of colour and of data textures.
    mips: [std::sync::OnceLock<super::texture::MipMaker>; 2],
    /// Prefiltering environments (`None` inside: the device cannot).
    ibl: std::sync::OnceLock<Option<super::environment::IblKit>>,
    /// The environments Kloub ships (made in code, or photographs), prefiltered (each once per
    /// device).
    environments: std::sync::Mutex<HashMap<super::environment::Builtin, super::environment::GpuEnvironment>>,
}

/// The shadow casters' depth: into the [`SHADOW_FORMAT`] map, biased.
fn caster_depth() -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: SHADOW_FORMAT,
        depth_write_enabled: Some(true),
        depth_compare: Some(wgpu::CompareFunction::Less),
        stencil: wgpu::StencilState::default(),
        bias: wgpu::DepthBiasState { constant: 2, slope_scale: 2.0, clamp: 0.0 },
    }
}

fn depth_state(compare: wgpu::CompareFunction, write: bool) -> Option<wgpu::DepthStencilState> {
    Some(wgpu::DepthStencilState {
        format: DEPTH_FORMAT,
        depth_write_enabled: Some(write),
        depth_compare: Some(compare),
        stencil: wgpu::StencilState::default(),
        bias: wgpu::DepthBiasState::default(),
    })
}

fn color_target(format: wgpu::TextureFormat, blend: bool) -> [Option<wgpu::ColorTargetState>; 1] {
    let blend = blend.then_some(wgpu::BlendState {
        color: wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::SrcAlpha,
            dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
            operation: wgpu::BlendOperation::Add,
        },
        alpha: wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
            operation: wgpu::BlendOperation::Add,
        },
    });
    [Some(wgpu::ColorTargetState { format, blend, write_mask: wgpu::ColorWrites::ALL })]
}

/// What a [`vertexless_pipeline`] draws into.
struct Target<'a> {
    format: wgpu::TextureFormat,
    blend: bool,
    depth: Option<wgpu::DepthStencilState>,
    samples: u32,
    /// The fragment entry's override constants.
    constants: &'a [(&'a str, f64)],
}

/// A pipeline without vertex buffers (its vertex entry `vs` makes the positions: a full-screen
/// triangle or a quad), its fragment entry `fs` writing `target`.
fn vertexless_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    (vs, fs): (&str, &str),
    target: Target<'_>,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(vs),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: target.depth,
        multisample: wgpu::MultisampleState { count: target.samples, ..Default::default() },
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fs),
            compilation_options: wgpu::PipelineCompilationOptions { constants: target.constants, ..Default::default() },
            targets: &color_target(target.format, target.blend),
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A pipeline of one full-screen triangle (vertex entry `vs`, no vertex buffers) whose fragment
/// entry `fs` writes `format` unblended: the passes that fill a texture (mips, prefiltering, the
/// ground shadow's mask).
pub(super) fn fill_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    entries: (&str, &str),
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    let target = Target { format, blend: false, depth: None, samples: 1, constants: &[] };
    vertexless_pipeline(device, label, layout, module, entries, target)
}

/// A render pass that clears `target` to black and draws into it alone (no depth): a
/// [`fill_pipeline`]'s.
pub(super) fn fill_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    target: &wgpu::TextureView,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: target,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// The fragment stage's override constants for a target in `format` (`SRGB_ENCODE` in
/// shaders/output.wgsl: the shader encodes sRGB where the target does not).
fn output_constants(format: wgpu::TextureFormat) -> [(&'static str, f64); 1] {
    [("SRGB_ENCODE", if format.is_srgb() { 0.0 } else { 1.0 })]
}

impl Pipelines {
    /// Compiles the shaders for `sample_count` samples of `format` (an sRGB format, or a plain
    /// one the shaders encode sRGB into); each pipeline is built when first drawn.
    pub fn new(device: &wgpu::Device, layouts: &Layouts, sample_count: u32, format: wgpu::TextureFormat) -> Self {
        let mesh_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("kloub mesh.wgsl"),
            source: shader_source!(MESH_WGSL),
        });
        let env_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("kloub environment.wgsl"),
            source: shader_source!(ENVIRONMENT_WGSL),
        });
        let mesh_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("kloub mesh"),
            bind_group_layouts: &[
                Some(&layouts.frame),
                Some(&layouts.material),
                Some(&layouts.draw),
                Some(&layouts.environment),
            ],
            immediate_size: 0,
        });
        let env_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("kloub environment"),
            bind_group_layouts: &[Some(&layouts.frame)],
            immediate_size: 0,
        });
        let shadow_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("kloub ground shadow mask"),
            bind_group_layouts: &[Some(&layouts.frame), Some(&layouts.shadow)],
            immediate_size: 0,
        });
        let shadow_ground_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("kloub ground shadow"),
            bind_group_layouts: &[Some(&layouts.frame), Some(&layouts.shadow_ground)],
            immediate_size: 0,
        });
        let first_use = std::sync::Arc::new(FirstUse {
            module: env_module,
            layout: env_layout,
            shadow: std::sync::OnceLock::new(),
            shadow_ground_layout,
            shadow_mask: std::sync::OnceLock::new(),
            world_caster: std::sync::OnceLock::new(),
            shadow_layout,
            background: std::sync::OnceLock::new(),
            grid: std::sync::OnceLock::new(),
            mips: [std::sync::OnceLock::new(), std::sync::OnceLock::new()],
            ibl: std::sync::OnceLock::new(),
            environments: std::sync::Mutex::new(HashMap::new()),
        });
        Self { share: None, sample_count, format, mesh_module, mesh_layout, first_use, mesh: HashMap::new() }
    }

    /// The background gradient's pipeline (full-screen triangle), built on first use.
    pub fn background(&self, device: &wgpu::Device) -> &wgpu::RenderPipeline {
        self.first_use.background.get_or_init(|| {
            self.environment_pipeline(
                device,
                "kloub background",
                "vs_background",
                "fs_background",
                depth_state(wgpu::CompareFunction::Always, false),
                false,
            )
        })
    }

    /// The ground grid's pipeline (blended quad), built on first use.
    pub fn grid(&self, device: &wgpu::Device) -> &wgpu::RenderPipeline {
        self.first_use.grid.get_or_init(|| {
            self.environment_pipeline(
                device,
                "kloub grid",
                "vs_grid",
                "fs_grid",
                depth_state(wgpu::CompareFunction::LessEqual, false),
                true,
            )
        })
    }

    /// The prefiltering kit, built on first use (`supported`: whether the adapter renders
    /// [`super::environment::HDR_FORMAT`]; `None` where it does not).
    pub fn ibl(&self, device: &wgpu::Device, supported: bool) -> Option<&super::environment::IblKit> {
        self.first_use.ibl.get_or_init(|| super::environment::IblKit::new(device, supported)).as_ref()
    }

    /// The environment `builtin` prefiltered for this device (made on first use, then shared by
    /// every viewer of the device); `None` without an [`super::environment::IblKit`], or for a
    /// photograph the page has not fetched yet ([`crate::photos::image`]).
    pub fn named_environment(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        layout: &wgpu::BindGroupLayout,
        supported: bool,
        builtin: super::environment::Builtin,
    ) -> Option<super::environment::GpuEnvironment> {
        use super::environment::Builtin;
        let kit = self.ibl(device, supported)?;
        let mut cache = self.first_use.environments.lock().ok()?;
        if let Some(env) = cache.get(&builtin) {
            return Some(env.clone());
        }
        let made = match builtin {
            Builtin::Procedural(p) => kit.environment(device, queue, layout, &p.image()),
            Builtin::Photo(p) => kit.environment(device, queue, layout, &*crate::photos::image(p)?),
        };
        let env = made.map_err(|e| log::warn!("kloub: environment {}: {e}", builtin.name())).ok()?;
        cache.insert(builtin, env.clone());
        ENVIRONMENTS_BUILT.with(|n| n.set(n.get() + 1));
        Some(env)
    }

    /// Builds now the fixed pipelines a viewer's first frame draws with by default: the
    /// prefiltering kit (`supported` as for [`Pipelines::ibl`]), the ground shadow's mask and
    /// quad, and the colour textures' mip maker. The browser then compiles them while the page
    /// imports and uploads its first model, instead of when the frame first draws with each (on
    /// WebGL2 the first draw of a program waits for its compile). What a default viewer does
    /// not draw (background, grid, data textures' mips) stays built on first use.
    pub fn warm(&self, device: &wgpu::Device, supported: bool) {
        let _ = self.ibl(device, supported);
        let _ = self.shadow_mask(device);
        let _ = self.ground_shadow(device);
        let _ = self.mip_maker(device, true);
    }

    /// The ground shadow's pipeline (blended quad, no depth writes), built on first use.
    pub fn ground_shadow(&self, device: &wgpu::Device) -> &wgpu::RenderPipeline {
        self.first_use.shadow.get_or_init(|| {
            self.environment_pipeline(
                device,
                "kloub ground shadow",
                "vs_shadow",
                "fs_shadow",
                depth_state(wgpu::CompareFunction::LessEqual, false),
                true,
            )
        })
    }

    /// The ground shadow's mask pass (full-screen triangle into the [`SHADOW_MASK_FORMAT`] mask),
    /// built on first use.
    pub fn shadow_mask(&self, device: &wgpu::Device) -> &wgpu::RenderPipeline {
        self.first_use.shadow_mask.get_or_init(|| {
            fill_pipeline(
                device,
                "kloub ground shadow mask",
                &self.first_use.shadow_layout,
                &self.first_use.module,
                ("vs_shadow_mask", "fs_shadow_mask"),
                SHADOW_MASK_FORMAT,
            )
        })
    }

    /// The shadow casters of vertices already in world space (positions only, `vs_caster_world`):
    /// the copies' casters deformed on the CPU, gathered into one buffer and drawn at once.
    /// Culled and biased as the single-sided casters of [`PipelineKey::caster`]; a double-sided
    /// material's triangles are gathered with both windings. Built on first use.
    pub fn world_caster(&self, device: &wgpu::Device) -> &wgpu::RenderPipeline {
        self.first_use.world_caster.get_or_init(|| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("kloub shadow casters in world space"),
                layout: Some(&self.mesh_layout),
                vertex: wgpu::VertexState {
                    module: &self.mesh_module,
                    entry_point: Some("vs_caster_world"),
                    compilation_options: Default::default(),
                    buffers: &[layout(12, &WORLD_ATTRIBUTES)],
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    front_face: wgpu::FrontFace::Ccw,
                    cull_mode: Some(wgpu::Face::Back),
                    ..Default::default()
                },
                depth_stencil: Some(caster_depth()),
                multisample: wgpu::MultisampleState::default(),
                fragment: None,
                multiview_mask: None,
                cache: None,
            })
        })
    }

    /// The mip maker for the colour (`srgb`) or data images the browser decoded, built on first
    /// use (one of each per kit: the page's viewers share them).
    pub fn mip_maker(&self, device: &wgpu::Device, srgb: bool) -> &super::texture::MipMaker {
        self.first_use.mips[usize::from(!srgb)]
            .get_or_init(|| super::texture::MipMaker::new(device, super::texture::image_format(srgb)))
    }

    fn environment_pipeline(
        &self,
        device: &wgpu::Device,
        label: &str,
        vs: &str,
        fs: &str,
        depth: Option<wgpu::DepthStencilState>,
        blend: bool,
    ) -> wgpu::RenderPipeline {
        let output = output_constants(self.format);
        let layout = if vs == "vs_shadow" { &self.first_use.shadow_ground_layout } else { &self.first_use.layout };
        let target = Target { format: self.format, blend, depth, samples: self.sample_count, constants: &output };
        vertexless_pipeline(device, label, layout, &self.first_use.module, (vs, fs), target)
    }

    /// Builds the mesh pipeline of `key` if it does not exist yet (here, or in the device's
    /// shared kit: another viewer of the page may have built it).
    pub fn prepare(&mut self, device: &wgpu::Device, key: PipelineKey) {
        if self.mesh.contains_key(&key) {
            return;
        }
        let (share, format, samples) = (self.share, self.format, self.sample_count);
        let built = KITS.with(|kits| {
            kits.borrow()
                .iter()
                .find(|k| k.matches(share, format, samples))
                .and_then(|k| k.pipelines.mesh.get(&key).cloned())
        });
        if let Some(pipeline) = built {
            self.mesh.insert(key, pipeline);
            return;
        }
        let skinned = skinned_buffers();
        let fixed = static_buffers();
        // Casters of opaque materials need the position only; masked ones' fragment shader reads
        // what the full vertex shader passes on.
        let position_only = key.caster && !key.mask;
        let (entry, buffers): (_, &[_]) = match (key.vertex, position_only) {
            (VertexPath::Static, false) => ("vs_static", &fixed[..]),
            (VertexPath::Static, true) => ("vs_caster_static", &fixed[..]),
            (VertexPath::Skinned, false) => ("vs_skinned", &skinned[..]),
            (VertexPath::Skinned, true) => ("vs_caster_skinned", &skinned[..]),
        };
        // Skinned pipelines are specialised: only the method and the heatmap they draw with are
        // compiled (`SKIN_METHOD`, `HEATMAP` in skinning.wgsl).
        let tangents = ("TANGENTS", f64::from(u8::from(key.tangents)));
        let constants = [
            ("SKIN_METHOD", f64::from(key.skinning.min(SKIN_FROM_DRAW))),
            ("HEATMAP", f64::from(u8::from(key.heatmap))),
            tangents,
        ];
        let compilation_options = match key.vertex {
            VertexPath::Static => wgpu::PipelineCompilationOptions { constants: &[tangents], ..Default::default() },
            VertexPath::Skinned => wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() },
        };
        let vertex =
            wgpu::VertexState { module: &self.mesh_module, entry_point: Some(entry), compilation_options, buffers };
        // The fragment shader compiles only the material's textures and the frame's kind of
        // ambient light (`TEXTURES`, `ENVIRONMENT` in mesh.wgsl), and the heatmap where drawn.
        let [srgb] = output_constants(self.format);
        let fragment_constants = [
            srgb,
            ("TEXTURES", f64::from(key.textures & 15)),
            ("ENVIRONMENT", f64::from(u8::from(key.ibl))),
            ("HEATMAP", f64::from(u8::from(key.heatmap))),
        ];
        let targets = color_target(self.format, key.blend);
        let descriptor = if key.caster {
            wgpu::RenderPipelineDescriptor {
                label: Some("kloub shadow caster"),
                layout: Some(&self.mesh_layout),
                vertex,
                primitive: wgpu::PrimitiveState {
                    topology: key.topology,
                    front_face: if key.mirrored { wgpu::FrontFace::Cw } else { wgpu::FrontFace::Ccw },
                    cull_mode: (!key.double_sided).then_some(wgpu::Face::Back),
                    ..Default::default()
                },
                depth_stencil: Some(caster_depth()),
                multisample: wgpu::MultisampleState::default(),
                // Masked materials cut their shadow as they cut themselves.
                fragment: key.mask.then_some(wgpu::FragmentState {
                    module: &self.mesh_module,
                    entry_point: Some("fs_caster_mask"),
                    compilation_options: Default::default(),
                    targets: &[],
                }),
                multiview_mask: None,
                cache: None,
            }
        } else {
            wgpu::RenderPipelineDescriptor {
                label: Some("kloub mesh"),
                layout: Some(&self.mesh_layout),
                vertex,
                primitive: wgpu::PrimitiveState {
                    topology: key.topology,
                    front_face: if key.mirrored { wgpu::FrontFace::Cw } else { wgpu::FrontFace::Ccw },
                    cull_mode: (!key.double_sided).then_some(wgpu::Face::Back),
                    ..Default::default()
                },
                depth_stencil: depth_state(wgpu::CompareFunction::Less, !key.blend),
                multisample: wgpu::MultisampleState { count: self.sample_count, ..Default::default() },
                fragment: Some(wgpu::FragmentState {
                    module: &self.mesh_module,
                    entry_point: Some("fs_main"),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &fragment_constants,
                        ..Default::default()
                    },
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: None,
            }
        };
        let pipeline = device.create_render_pipeline(&descriptor);
        KITS.with(|kits| {
            if let Some(kit) = kits.borrow_mut().iter_mut().find(|k| k.matches(share, format, samples)) {
                kit.pipelines.mesh.insert(key, pipeline.clone());
            }
        });
        self.mesh.insert(key, pipeline);
    }

    /// The capture pipeline: `vs_capture_skinned` over a point list into two
    /// [`CAPTURE_FORMAT`] targets, single-sampled, no depth.
    pub fn capture(&self, device: &wgpu::Device) -> wgpu::RenderPipeline {
        let target =
            Some(wgpu::ColorTargetState { format: CAPTURE_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("kloub capture"),
            layout: Some(&self.mesh_layout),
            vertex: wgpu::VertexState {
                module: &self.mesh_module,
                entry_point: Some("vs_capture_skinned"),
                compilation_options: Default::default(),
                buffers: &skinned_buffers(),
            },
            primitive: wgpu::PrimitiveState { topology: wgpu::PrimitiveTopology::PointList, ..Default::default() },
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &self.mesh_module,
                entry_point: Some("fs_capture"),
                compilation_options: Default::default(),
                targets: &[target.clone(), target],
            }),
            multiview_mask: None,
            cache: None,
        })
    }

    /// The mesh pipeline of `key`, if [`Pipelines::prepare`] built it.
    pub fn mesh(&self, key: &PipelineKey) -> Option<&wgpu::RenderPipeline> {
        self.mesh.get(key)
    }
}

/// Whether `device` can run the compute skinning pass (WebGPU and native; not WebGL2).
pub fn supports_compute(device: &wgpu::Device) -> bool {
    let limits = device.limits();
    limits.max_storage_buffers_per_shader_stage >= 6
        && limits.max_compute_invocations_per_workgroup >= 64
        && limits.max_compute_workgroup_size_x >= 64
        && limits.max_compute_workgroups_per_dimension > 0
}

/// Workgroup size of `cs_skin` in skin_compute.wgsl.
pub const SKIN_WORKGROUP: u32 = 64;

/// The compute skinning pipeline and its bind group layouts (see skin_compute.wgsl).
#[derive(Clone)]
pub struct ComputeKit {
    /// Group 0: palette and morph textures.
    pub textures: wgpu::BindGroupLayout,
    /// Group 1: empty.
    pub empty_group: wgpu::BindGroup,
    /// Group 2: the Draw uniform with a dynamic offset.
    pub draw: wgpu::BindGroupLayout,
    /// Group 3: the primitive's streams and the output.
    pub io: wgpu::BindGroupLayout,
    /// `cs_skin`.
    pub pipeline: wgpu::ComputePipeline,
}

impl ComputeKit {
    /// Builds the pipeline; `None` where compute is not available ([`supports_compute`]).
    pub fn new(device: &wgpu::Device) -> Option<Self> {
        if !supports_compute(device) {
            return None;
        }
        let c = wgpu::ShaderStages::COMPUTE;
        let float = wgpu::TextureSampleType::Float { filterable: false };
        let textures = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("kloub compute textures"),
            entries: &[texture_entry(1, c, float), texture_entry(2, c, float)],
        });
        let empty = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("kloub compute empty"),
            entries: &[],
        });
        let empty_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("kloub compute empty"),
            layout: &empty,
            entries: &[],
        });
        let draw = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("kloub compute draw"),
            entries: &[uniform_entry(0, c, size_of::<DrawUniform>(), true)],
        });
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: c,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let io = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("kloub compute streams"),
            entries: &[
                storage(0, true),
                storage(1, true),
                storage(2, true),
                storage(3, false),
                storage(4, true),
                storage(5, false),
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("kloub compute skinning"),
            bind_group_layouts: &[Some(&textures), Some(&empty), Some(&draw), Some(&io)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("kloub skin_compute.wgsl"),
            source: shader_source!(SKIN_COMPUTE_WGSL),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("kloub compute skinning"),
            layout: Some(&layout),
            module: &module,
            entry_point: Some("cs_skin"),
            compilation_options: Default::default(),
            cache: None,
        });
        Some(Self { textures, empty_group, draw, io, pipeline })
    }
}

/// What every renderer of a device draws with, built once per device, colour format and sample
/// count and shared by every viewer of the page (wgpu's handles are reference counted: a clone
/// is the same GPU object). Compiling the shaders and pipelines per viewer cost each one its
/// own programs in the GPU process.
#[derive(Clone)]
pub struct Kit {
    /// The bind group layouts.
    pub layouts: Layouts,
    /// The environment pipelines and every mesh variant built so far.
    pub pipelines: Pipelines,
    /// Compute skinning, where the device has it.
    pub compute: Option<ComputeKit>,
    /// A 1×1 white texture (materials without a base colour texture).
    pub white: wgpu::TextureView,
}

struct SharedKit {
    /// The device's sharing key (wgpu compares devices by an id that another instance reuses:
    /// the page numbers its devices instead).
    share: u32,
    kit: Kit,
}

impl SharedKit {
    fn matches(&self, share: Option<u32>, format: wgpu::TextureFormat, samples: u32) -> bool {
        share == Some(self.share) && self.kit.pipelines.format == format && self.kit.pipelines.sample_count == samples
    }
}

impl std::ops::Deref for SharedKit {
    type Target = Kit;
    fn deref(&self) -> &Kit {
        &self.kit
    }
}

impl std::ops::DerefMut for SharedKit {
    fn deref_mut(&mut self) -> &mut Kit {
        &mut self.kit
    }
}

thread_local! {
    static KITS: std::cell::RefCell<Vec<SharedKit>> = const { std::cell::RefCell::new(Vec::new()) };
    static KITS_BUILT: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
    static ENVIRONMENTS_BUILT: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// The kit of `device` for `format` and `sample_count`: with `share` (the page's key of the
/// device), the one every viewer of the device shares, built on first use; without, a kit of
/// its own.
pub fn kit(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    format: wgpu::TextureFormat,
    sample_count: u32,
    share: Option<u32>,
) -> Kit {
    if let Some(kit) =
        KITS.with(|kits| kits.borrow().iter().find(|k| k.matches(share, format, sample_count)).map(|k| k.kit.clone()))
    {
        return kit;
    }
    let layouts = Layouts::new(device);
    let mut pipelines = Pipelines::new(device, &layouts, sample_count, format);
    pipelines.share = share;
    let compute = ComputeKit::new(device);
    let white = super::texture::white_texture(device, queue).create_view(&wgpu::TextureViewDescriptor::default());
    let kit = Kit { layouts, pipelines, compute, white };
    KITS_BUILT.with(|n| n.set(n.get() + 1));
    if let Some(share) = share {
        KITS.with(|kits| kits.borrow_mut().push(SharedKit { share, kit: kit.clone() }));
    }
    kit
}

/// Forgets the kits of the device `share` names (it was lost: its pipelines are of no use).
pub fn forget_device(share: u32) {
    KITS.with(|kits| kits.borrow_mut().retain(|k| k.share != share));
}

/// How many named environments were prefiltered on this thread (tests: one per pipeline kit —
/// device, colour format and sample count — and name, whatever the number of viewers).
pub fn environments_built() -> usize {
    ENVIRONMENTS_BUILT.with(std::cell::Cell::get)
}

/// How many kits were built on this thread (tests: one per device, format and sample count).
pub fn kits_built() -> usize {
    KITS_BUILT.with(std::cell::Cell::get)
}
