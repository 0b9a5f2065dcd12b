//! [`SceneRenderer`]: one loaded asset on the GPU, drawn into its own offscreen target.

use std::collections::HashMap;

use glam::{Mat4, Vec3};
use kloub_core::Instance;
use kloub_core::asset::{AlphaMode, Asset, Material};

use super::camera::Camera;
use kloub_core::job::sjb::SjbPlan;

use super::environment::{Builtin, GpuEnvironment, HdrImage, fallback_environment};
use super::mesh::{
    CasterSet, GeometryVertex, GpuPrimitive, TANGENT_STRIDE, interleave, pivot_buffer, sanitize_tangent, write_pivots,
};
use super::morph::{MorphSlot, MorphTexture};
use super::palette::PaletteTexture;
use super::pipelines::MATERIAL_TEXTURES;
use super::pipelines::{
    ComputeKit, DEPTH_FORMAT, Layouts, PipelineKey, Pipelines, SKIN_FROM_DRAW, SKIN_WORKGROUP, VertexPath,
    tangent_slot, topology,
};
use super::texture::{COLOR_FORMAT, SamplerKey, upload_decoded, upload_image};
use super::uniforms::EnvironmentChoice;
use super::uniforms::{DrawUniform, EnvironmentLight, FrameUniform, Ground, MaterialUniform, ShadowUniform, skin_code};

#[cfg(not(target_arch = "wasm32"))]
mod capture;
#[cfg(not(target_arch = "wasm32"))]
pub use capture::CapturedDraw;

/// Where skinned (and morphed) vertices are deformed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SkinningPath {
    /// Morphing and skinning (the instance's method) in the vertex shader, with the palette
    /// and morph textures. Primitives whose targets do not fit the morph texture are
    /// deformed on the CPU.
    #[default]
    Gpu,
    /// A compute pass morphs and skins every skinned primitive once per frame into a vertex
    /// buffer the draws read (WebGPU and native only: WebGL2 has no compute shaders).
    Compute,
    /// `kloub_core`'s CPU reference ([`Instance::deform_primitive`]: morph, then skin),
    /// uploaded every frame.
    Cpu,
}

impl SkinningPath {
    /// Every path, in menu order.
    pub const ALL: [SkinningPath; 3] = [SkinningPath::Gpu, SkinningPath::Compute, SkinningPath::Cpu];

    /// The name the page uses: `"gpu"`, `"compute"` or `"cpu"`.
    pub fn name(self) -> &'static str {
        match self {
            SkinningPath::Gpu => "gpu",
            SkinningPath::Compute => "compute",
            SkinningPath::Cpu => "cpu",
        }
    }

    /// The menu label.
    pub fn label(self) -> &'static str {
        match self {
            SkinningPath::Gpu => "GPU vertex shader",
            SkinningPath::Compute => "GPU compute",
            SkinningPath::Cpu => "CPU",
        }
    }

    /// The path named `name` ([`SkinningPath::name`]).
    ///
    /// # Errors
    /// A message listing the names.
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|p| p.name() == name)
            .ok_or_else(|| format!("skinning path {name:?}: expected \"gpu\", \"compute\" or \"cpu\""))
    }
}

/// The heatmap's full-scale distance as a fraction of the rest pose's bounding-box diagonal.
const HEATMAP_FULL_SCALE: f32 = 0.02;

/// The MSAA sample count for a viewer on screen: [`msaa_samples`], except on a CPU adapter
/// (SwiftShader, llvmpipe) in the browser, where 4× multisampling quadruples the fill cost of
/// every frame and the page's frame rate matters more (measured in BENCHMARKS.md, "Frame
/// cost"). Native rendering (the golden images on lavapipe) keeps 4×.
pub fn display_msaa(adapter: &wgpu::Adapter) -> u32 {
    if cpu_in_browser(adapter) { 1 } else { msaa_samples(adapter) }
}

/// Where a viewer deforms skinned vertices until its user chooses: on the CPU
/// ([`SkinningPath::Cpu`]) on a CPU adapter in the browser (SwiftShader, llvmpipe: the browser's
/// fallback where the GPU is blocklisted or absent), where vertex shaders run on the CPU anyway,
/// one core's worth, and the vertex-shader path would skin every vertex twice a frame (for the
/// ground shadow's map, then for the colour pass) while the page's main thread, another core,
/// waits; the GPU's vertex shader everywhere else (never the compute pass, which not every
/// device has). Measured in BENCHMARKS.md, "Frame cost".
pub fn default_skinning_path(adapter: &wgpu::Adapter) -> SkinningPath {
    if cpu_in_browser(adapter) { SkinningPath::Cpu } else { SkinningPath::Gpu }
}

/// Whether `adapter` is a CPU adapter in the browser: what [`display_msaa`] and
/// [`default_skinning_path`] choose by. A page that sets `__kloubProfileHardware` (the build's
/// profile of what first frames run, `scripts/wasm-split.mjs`, on SwiftShader) is answered as on a
/// hardware adapter, so that the profile sees the paths a GPU takes.
fn cpu_in_browser(adapter: &wgpu::Adapter) -> bool {
    #[cfg(target_arch = "wasm32")]
    {
        let profiled =
            js_sys::Reflect::get(&js_sys::global(), &"__kloubProfileHardware".into()).is_ok_and(|v| v.is_truthy());
        adapter.get_info().device_type == wgpu::DeviceType::Cpu && !profiled
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        let _ = adapter;
        false
    }
}

/// The colour format a viewer's scene draws into on a device whose canvas surfaces are in
/// `surface_format` on `backend`: `Rgba8Unorm` (shaders encode sRGB) where the browser's
/// WebGL2 canvas is drawn into, since wgpu presents an sRGB WebGL2 surface through an extra
/// full-screen shader pass (measured in BENCHMARKS.md, "Frame cost"); [`COLOR_FORMAT`]
/// everywhere else (WebGPU draws through an sRGB view of its canvas texture).
pub fn scene_format(backend: wgpu::Backend) -> wgpu::TextureFormat {
    if cfg!(target_arch = "wasm32") && backend == wgpu::Backend::Gl {
        wgpu::TextureFormat::Rgba8Unorm
    } else {
        COLOR_FORMAT
    }
}

/// 4× when the adapter can multisample the colour and depth formats, else 1.
pub fn msaa_samples(adapter: &wgpu::Adapter) -> u32 {
    let supports = |format| adapter.get_texture_format_features(format).flags.sample_count_supported(4);
    if supports(COLOR_FORMAT) && supports(DEPTH_FORMAT) { 4 } else { 1 }
}

/// A texture of `size` for `RENDER_ATTACHMENT` plus `usage`.
fn attachment(
    device: &wgpu::Device,
    label: &str,
    size: [u32; 2],
    format: wgpu::TextureFormat,
    samples: u32,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: size[0], height: size[1], depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: samples,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | usage,
        view_formats: &[],
    })
}

/// MSAA colour (when multisampling) and depth of one size: what a pass needs besides the
/// texture it ends in. Viewers that draw one after another into the same surface (the page's
/// WebGL2 canvas) share one set ([`SceneRenderer::draw_into`]).
pub struct Attachments {
    size: [u32; 2],
    samples: u32,
    format: wgpu::TextureFormat,
    msaa: Option<wgpu::TextureView>,
    depth: wgpu::TextureView,
}

impl Attachments {
    fn new(device: &wgpu::Device, size: [u32; 2], sample_count: u32, format: wgpu::TextureFormat) -> Self {
        let view = |t: wgpu::Texture| t.create_view(&wgpu::TextureViewDescriptor::default());
        let none = wgpu::TextureUsages::empty();
        let msaa =
            (sample_count > 1).then(|| view(attachment(device, "kloub scene msaa", size, format, sample_count, none)));
        let depth = view(attachment(device, "kloub scene depth", size, DEPTH_FORMAT, sample_count, none));
        Self { size, samples: sample_count, format, msaa, depth }
    }

    /// The pass's colour attachment and resolve target for a frame ending in `view`: the MSAA
    /// texture resolved into `view`, or `view` itself without multisampling.
    fn colour<'a>(&'a self, view: &'a wgpu::TextureView) -> (&'a wgpu::TextureView, Option<&'a wgpu::TextureView>) {
        match &self.msaa {
            Some(msaa) => (msaa, Some(view)),
            None => (view, None),
        }
    }
}

/// The render target: resolved colour (sampled by egui, copied by tests), MSAA colour, depth.
struct Target {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    attachments: Attachments,
}

impl Target {
    fn new(device: &wgpu::Device, size: [u32; 2], sample_count: u32, format: wgpu::TextureFormat) -> Self {
        let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC;
        let texture = attachment(device, "kloub scene colour", size, format, 1, usage);
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        Self { texture, view, attachments: Attachments::new(device, size, sample_count, format) }
    }
}

/// One (node, primitive) pair of the scene.
struct DrawItem {
    node: u32,
    mesh: usize,
    primitive: usize,
    /// Skin of the node when the primitive is skinned.
    skin: Option<usize>,
    /// Index into [`GpuScene::materials`].
    material: usize,
    blend: bool,
    /// Alpha-masked (its shadow caster discards as the material does).
    mask: bool,
    double_sided: bool,
    /// The material has a normal texture (only then are tangents read).
    normal_mapped: bool,
    /// The material's optional textures ([`super::uniforms::optional_textures`]).
    textures: u8,
    morphed: bool,
    /// Where the morph targets are on the GPU (`None`: not morphed, or morphed on the CPU).
    morph: Option<MorphSlot>,
    /// Spherical-joint-blend centres per vertex (skinned draws), written when a copy first
    /// chooses a method that reads them.
    pivots: Option<wgpu::Buffer>,
    /// Vertices of `pivots` that fall back to dual quaternions once written ([`PIVOTS_UNWRITTEN`]
    /// before; shared by every viewer of the upload).
    sjb_fallbacks: std::sync::Arc<std::sync::atomic::AtomicUsize>,
    /// Per copy: the geometry stream rewritten each frame when deformed on the CPU (created
    /// on first use).
    deformed: Vec<Option<wgpu::Buffer>>,
    /// Per copy: the tangent stream beside `deformed`. Where the primitive has no tangents, a
    /// one-tangent buffer the compute pass binds and never writes; the draw then binds the
    /// primitive's zeros.
    deformed_tangents: Vec<Option<wgpu::Buffer>>,
    /// Set each frame.
    key: Option<PipelineKey>,
    /// Set each frame: vertices come from `deformed`, written by the CPU.
    on_cpu: bool,
    /// Set each frame: vertices come from `deformed`, written by the compute pass.
    on_compute: bool,
    /// Set each frame: its copies' shadow casters are gathered into [`GpuScene::batch`] and
    /// drawn with it, not one draw each.
    batched: bool,
    /// Per copy: the compute pass's streams (created on first use).
    compute_groups: Vec<Option<wgpu::BindGroup>>,
}

impl DrawItem {
    /// Whether the last prepared frame draws this draw's casters itself (one draw per copy): it
    /// has a caster pipeline and was not gathered into the [`CasterBatch`].
    fn casts_alone(&self) -> bool {
        !self.batched && self.key.and_then(|k| k.caster(self.mask)).is_some()
    }
}

/// [`DrawItem::sjb_fallbacks`] before its pivots are written.
const PIVOTS_UNWRITTEN: usize = usize::MAX;

/// Writes the spherical-joint-blend centres of a skinned `draw` of `source` (a primitive of
/// `asset`) unless some viewer of the upload did: its plan is built then, when a method first
/// reads it, not while a page waits for the model's first frame.
fn write_pivots_once(queue: &wgpu::Queue, asset: &Asset, draw: &DrawItem, source: &kloub_core::asset::Primitive) {
    use std::sync::atomic::Ordering;
    let (Some(buffer), Some(skin)) = (&draw.pivots, draw.skin.and_then(|s| asset.skins.get(s))) else {
        return;
    };
    if draw.sjb_fallbacks.load(Ordering::Relaxed) != PIVOTS_UNWRITTEN {
        return;
    }
    let parents: Vec<Option<u32>> = asset.nodes.iter().map(|n| n.parent).collect();
    let plan = SjbPlan::build(skin, &parents, &source.joints, &source.weights);
    write_pivots(queue, buffer, &plan, source.positions.len());
    draw.sjb_fallbacks.store(plan.fallbacks, Ordering::Relaxed);
}

/// GPU resources of one asset.
struct GpuScene {
    primitives: Vec<Vec<Option<GpuPrimitive>>>,
    materials: Vec<wgpu::BindGroup>,
    draws: Vec<DrawItem>,
    draw_buffer: wgpu::Buffer,
    draw_bind_group: wgpu::BindGroup,
    /// First palette joint of each skin.
    skin_base: Vec<u32>,
    palette: PaletteTexture,
    /// The morph texture's view (bound with the palette).
    morph_view: wgpu::TextureView,
    /// Group 0 for the view (with [`SceneRenderer`]'s first frame buffer) and for the shadow
    /// map (the second: the light's view).
    frame_bind_groups: [wgpu::BindGroup; 2],
    node_count: usize,
    /// Palette joints of one copy of the character (all skins).
    joints: u32,
    /// Copies the palette and draw buffer have room for.
    copies: usize,
    /// Bounding-box diagonal of the rest pose (scales the heatmap).
    diagonal: f32,
    /// The compute pass's textures and draw-uniform bind groups (where compute exists).
    compute: Option<(wgpu::BindGroup, wgpu::BindGroup)>,
    /// Every copy's casters deformed on the CPU, in one draw.
    batch: CasterBatch,
}

/// The shadow casters of the copies deformed on the CPU, gathered into one buffer in world space
/// and drawn at once ([`super::pipelines::Pipelines::world_caster`]): one draw instead of one per
/// copy and primitive (50 copies were 50 caster draws of a few hundred triangles; BENCHMARKS.md,
/// "Frame cost", stop 54, has what it saves on SwiftShader, the CPU adapter that takes this path). Each draw's
/// simplified triangles ([`super::mesh::CasterSet`]) are gathered over only the vertices they
/// use, after the copy's deformation, so the main pass's vertices stay as they are.
#[derive(Default)]
struct CasterBatch {
    /// This frame's positions, draw by draw and copy by copy (kept: no allocation per frame).
    positions: Vec<[f32; 3]>,
    /// The positions on the GPU (grown when they do not fit).
    vertices: Option<wgpu::Buffer>,
    /// The triangles over them, and how many indices.
    indices: Option<wgpu::Buffer>,
    count: u32,
    /// How many positions the triangles are over (a frame whose gathering stopped short draws
    /// none).
    vertex_total: usize,
    /// What `indices` were made for: the copies, the level, and each gathered draw with its
    /// double-sidedness; `wanted`, this frame's (built again only when they differ).
    built: Vec<u32>,
    wanted: Vec<u32>,
}

/// The most indices the gathered casters make (64 MiB of them): draws beyond draw on their own.
const BATCH_MAX_INDICES: usize = 1 << 24;

impl CasterBatch {
    /// Whether this frame's gathering is complete and its triangles made for it: what
    /// [`GpuScene::encode_batch`] draws.
    fn ready(&self) -> bool {
        self.count > 0 && self.built == self.wanted && self.positions.len() == self.vertex_total
    }

    /// Makes the triangles again for `wanted` (copies, level, then pairs of draw and
    /// double-sidedness), with draw `i`'s set at the level `set_of(i)`: copy after copy, each over
    /// its own vertices; a double-sided draw's triangles twice, the second time turned, as the
    /// world caster culls one face.
    fn build_indices(&mut self, device: &wgpu::Device, set_of: impl Fn(usize) -> Option<std::sync::Arc<CasterSet>>) {
        use wgpu::util::DeviceExt as _;
        let mut indices: Vec<u32> = Vec::new();
        let copies = self.wanted.first().copied().unwrap_or(0);
        let mut base = 0u32;
        for pair in self.wanted.get(2..).unwrap_or_default().chunks_exact(2) {
            let Some(set) = set_of(pair[0] as usize) else { continue };
            for _ in 0..copies {
                for t in set.indices.chunks_exact(3) {
                    indices.extend([t[0] + base, t[1] + base, t[2] + base]);
                    if pair[1] != 0 {
                        indices.extend([t[0] + base, t[2] + base, t[1] + base]);
                    }
                }
                base += set.vertices.len() as u32;
            }
        }
        self.count = indices.len() as u32;
        self.vertex_total = base as usize;
        self.indices = (!indices.is_empty()).then(|| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("kloub batched caster indices"),
                contents: bytemuck::cast_slice(&indices),
                usage: wgpu::BufferUsages::INDEX,
            })
        });
        self.built.clone_from(&self.wanted);
    }

    /// Uploads this frame's positions (a bigger buffer when they outgrow it).
    fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) {
        let bytes: &[u8] = bytemuck::cast_slice(&self.positions);
        if bytes.is_empty() {
            return;
        }
        if self.vertices.as_ref().is_none_or(|b| b.size() < bytes.len() as u64) {
            self.vertices = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("kloub batched caster positions"),
                size: (bytes.len() as u64).next_power_of_two(),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        if let Some(buffer) = &self.vertices {
            queue.write_buffer(buffer, 0, bytes);
        }
    }
}

/// What of an asset lives on the GPU the same for every viewer: its meshes, materials (with
/// their textures), morph targets and SJB centres (per draw, in the order of the scene's draws).
/// A clone is the same GPU objects.
#[derive(Clone)]
struct Uploaded {
    primitives: Vec<Vec<Option<GpuPrimitive>>>,
    materials: Vec<wgpu::BindGroup>,
    pivots: Vec<Option<(wgpu::Buffer, std::sync::Arc<std::sync::atomic::AtomicUsize>)>>,
    morphs: MorphTexture,
}

/// An asset's static GPU part on a device, while any viewer shows the asset.
struct SharedUpload {
    asset: std::sync::Weak<Asset>,
    /// The page's key of the device it is on.
    share: u32,
    /// Whether its streams are readable by compute skinning.
    storage: bool,
    uploaded: Uploaded,
}

thread_local! {
    static UPLOADS: std::cell::RefCell<Vec<SharedUpload>> = const { std::cell::RefCell::new(Vec::new()) };
    static UPLOADS_MADE: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// How many assets were uploaded to a GPU on this thread (each shared one counts once per
/// device while it lives).
pub fn uploads_made() -> usize {
    UPLOADS_MADE.with(std::cell::Cell::get)
}

/// How many assets' static GPU parts are held for the viewers that show them.
pub fn live_uploads() -> usize {
    UPLOADS.with(|uploads| uploads.borrow().iter().filter(|u| u.asset.strong_count() > 0).count())
}

/// Releases the shared GPU parts of assets no viewer shows any more (and those on `lost`, the
/// key of a device that was lost, if given).
pub fn release_unused_uploads(lost: Option<u32>) {
    UPLOADS.with(|uploads| {
        uploads.borrow_mut().retain(|u| u.asset.strong_count() > 0 && lost != Some(u.share));
    });
    crate::decode::release_unused();
}

/// Per-frame scratch space, kept to avoid allocating every frame.
#[derive(Default)]
struct Scratch {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    tangents: Vec<[f32; 4]>,
    geometry: Vec<GeometryVertex>,
    draw_bytes: Vec<u8>,
    blend_order: Vec<(f32, usize)>,
    /// Time spent deforming on the CPU in the last prepare.
    cpu_skin: std::time::Duration,
    /// Time the last prepare took (palettes, CPU deformation, uploads).
    prepare: std::time::Duration,
    /// A sculpted shape drawn in place of the main character's deformation.
    sculpt: Option<SculptMesh>,
    /// Its (node, primitive) pairs already written to their deform buffers.
    sculpt_written: Vec<(u32, usize)>,
}

/// The vertices of a mesh node as a sculpt shows them ([`SceneRenderer::set_sculpt`]): per
/// primitive, positions and normals in model space, drawn as they are for the main character
/// and written to the GPU once per change (copies of the character deform on the CPU path
/// meanwhile).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SculptMesh {
    /// The node drawing the mesh.
    pub node: u32,
    /// Per sculpted primitive.
    pub primitives: Vec<SculptedPrimitive>,
}

/// `(primitive, positions, normals)` of a [`SculptMesh`] (normals empty for a primitive without).
pub type SculptedPrimitive = (usize, Vec<[f32; 3]>, Vec<[f32; 3]>);

/// CPU time of the renderer's stages in the last frame, in milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderTimes {
    /// Deforming primitives on the CPU (the CPU path, and morphs that do not fit the GPU).
    pub cpu_skin_ms: f32,
    /// Writing palettes, draw uniforms and CPU-deformed vertices to the GPU (CPU skinning
    /// excluded).
    pub upload_ms: f32,
    /// Recording and submitting the render pass.
    pub draw_ms: f32,
}

/// Renders one loaded [`Asset`] posed by an [`Instance`] into an offscreen texture.
///
/// See the [module docs](super) for the frame flow and how the app and the tests use it.
pub struct SceneRenderer {
    /// The page's key of the device (`None`: nothing is shared with other renderers).
    share: Option<u32>,
    sample_count: u32,
    /// The colour format drawn into ([`COLOR_FORMAT`], or `Rgba8Unorm` with the shaders
    /// encoding sRGB: see [`SceneRenderer::with_format`]).
    format: wgpu::TextureFormat,
    draw_stride: u64,
    layouts: Layouts,
    pipelines: Pipelines,
    /// The frame uniforms of the view and of the shadow map (the light's view).
    frame_buffers: [wgpu::Buffer; 2],
    /// The ground shadow, made when first drawn.
    shadow: Option<ShadowMap>,
    white: wgpu::TextureView,
    samplers: HashMap<SamplerKey, wgpu::Sampler>,
    material_buffer: Option<wgpu::Buffer>,
    empty: GpuScene,
    scene: Option<GpuScene>,
    target: Option<Target>,
    target_version: u64,
    /// MSAA colour and depth for drawing straight into a canvas's surface.
    direct: Option<Attachments>,
    /// Copies prepared by the last [`SceneRenderer::prepare_copies`].
    prepared_copies: usize,
    /// The path chosen with [`SceneRenderer::set_skinning_path`]; `None` until then (the
    /// path is then [`SceneRenderer::skinning_path`]'s default for the adapter).
    skinning: Option<SkinningPath>,
    /// The default path when none was chosen ([`default_skinning_path`]).
    default_skinning: SkinningPath,
    ground: Ground,
    scratch: Scratch,
    times: RenderTimes,
    /// The compute skinning pipeline, where the device has compute shaders.
    compute: Option<ComputeKit>,
    /// Deviation heatmap on: the full-scale distance (a fraction of the model's size).
    heatmap: Option<f32>,
    /// Draw the ground grid.
    grid: bool,
    /// Lighting and background.
    look: super::uniforms::Look,
    /// Whether the adapter can prefilter environments ([`super::environment::supports_ibl`]).
    ibl_supported: bool,
    /// The environment image ([`EnvironmentChoice::Image`]) and its number (a new one per image).
    environment_image: Option<(u64, std::sync::Arc<HdrImage>)>,
    /// The environment bound now, what it is (`None`: none could be made) and its intensity.
    environment: (Option<EnvironmentKey>, GpuEnvironment, f32),
    /// The environment image's prefiltered textures, kept while it is the image (choosing it
    /// again after a named one does not prefilter it again).
    image_environment: Option<(u64, GpuEnvironment)>,
    /// Soft shadows' casters draw every triangle too ([`SceneRenderer::set_full_casters`]).
    full_casters: bool,
}

/// The shadow map's size in texels (square).
pub const SHADOW_MAP_SIZE: u32 = 512;

/// Size of the ground shadow's mask (square, over the ground rectangle the shadow can fall on)
/// for a sharp shadow (`shadow_softness` under [`SOFT_SHADOW`]).
pub const SHADOW_MASK_SIZE: u32 = 256;

/// The mask's size for a soft shadow (the default): its penumbra spans several of these texels,
/// and the mask pass costs up to 16 comparison taps per texel where the GPU is the CPU (a quarter
/// of them at this size; the measurements, noisy, in BENCHMARKS.md "Frame cost", stop 51). Fox
/// and CesiumMan drawn 640 pixels high differ from the larger mask's by at most 8 levels at the
/// default softness (15 for a sharp shadow, which keeps the larger mask).
pub const SOFT_SHADOW_MASK_SIZE: u32 = 128;

/// The softness from which the shadow's mask is [`SOFT_SHADOW_MASK_SIZE`] texels wide.
pub const SOFT_SHADOW: f32 = 0.5;

/// What [`GpuScene::encode`] records.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pass {
    /// The scene itself.
    Scene,
    /// The shadow casters, every triangle.
    Casters,
    /// The shadow casters, each primitive's simplified triangles where it has them
    /// ([`super::mesh::GpuPrimitive::caster_indices`]), `coarse` or not; alpha-masked materials'
    /// casters draw every triangle ([`caster_list`]).
    SimplifiedCasters { coarse: bool },
}

/// The index buffer and count `gpu` draws in `kind` of pass: its simplified caster list where
/// the pass asks for one and it has one, except for an alpha-masked material (`mask`), whose
/// caster cuts the shadow by the texture's alpha at interpolated UVs that a clustered triangle
/// would take from unrelated parts of the texture.
fn caster_list(gpu: &GpuPrimitive, kind: Pass, mask: bool) -> (&wgpu::Buffer, u32) {
    let simplified = match kind {
        Pass::SimplifiedCasters { coarse } if !mask => {
            gpu.caster_indices.get(usize::from(coarse)).and_then(Option::as_ref)
        }
        _ => None,
    };
    simplified.map_or((&gpu.indices, gpu.index_count), |(indices, count)| (indices, *count))
}

/// The ground shadow's GPU side: the map the casters draw into, the mask the shadow is
/// filtered into (and its size), the uniform, the mask pass's and the ground pass's bind
/// groups, and whether this frame draws it.
struct ShadowMap {
    view: wgpu::TextureView,
    mask: wgpu::TextureView,
    mask_size: u32,
    /// The copies are drawn small enough in the map for the coarse simplified casters
    /// ([`kloub_core::simplify::COARSE_SHADOW_CELLS`]).
    coarse: bool,
    uniform: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    ground_bind_group: wgpu::BindGroup,
    drawn: bool,
}

impl ShadowMap {
    fn new(device: &wgpu::Device, layouts: &Layouts, mask_size: u32) -> Self {
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("kloub shadow map"),
            size: wgpu::Extent3d { width: SHADOW_MAP_SIZE, height: SHADOW_MAP_SIZE, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: super::pipelines::SHADOW_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("kloub shadow"),
            size: size_of::<ShadowUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("kloub shadow"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("kloub shadow"),
            layout: &layouts.shadow,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&view) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&sampler) },
            ],
        });
        let mask = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("kloub shadow mask"),
                size: wgpu::Extent3d { width: mask_size, height: mask_size, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: super::pipelines::SHADOW_MASK_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
            .create_view(&wgpu::TextureViewDescriptor::default());
        let linear = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("kloub shadow mask"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let ground_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("kloub shadow ground"),
            layout: &layouts.shadow_ground,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&mask) },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::Sampler(&linear) },
            ],
        });
        Self { view, mask, mask_size, coarse: false, uniform, bind_group, ground_bind_group, drawn: false }
    }
}

/// What an environment on the GPU was made from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum EnvironmentKey {
    Named(Builtin),
    Image(u64),
}

/// Numbers the environment images given to renderers.
static ENVIRONMENT_IMAGES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

impl SceneRenderer {
    /// Creates the pipelines and shared resources. `sample_count` is 1 or 4
    /// (see [`msaa_samples`]); anything else is treated as 1. Draws into [`COLOR_FORMAT`].
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, sample_count: u32) -> Self {
        Self::with_format(device, queue, sample_count, COLOR_FORMAT)
    }

    /// [`SceneRenderer::new`] drawing into `format`: [`COLOR_FORMAT`] (the hardware encodes
    /// sRGB and blends in linear space), or `Rgba8Unorm`, where the shaders encode sRGB
    /// themselves and blending happens in gamma space, as three.js and the browser do. The
    /// WebGL2 canvas uses the latter: wgpu presents an sRGB surface there with an extra
    /// full-screen shader pass ([`scene_format`]); any other format is taken as `COLOR_FORMAT`.
    pub fn with_format(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        sample_count: u32,
        format: wgpu::TextureFormat,
    ) -> Self {
        Self::shared(device, queue, sample_count, format, None)
    }

    /// [`SceneRenderer::with_format`] for one of the page's viewers on the device `share`
    /// names: the pipelines are the device's kit, and [`SceneRenderer::set_shared_asset`]
    /// shares uploads with the device's other renderers (`None`: nothing is shared).
    pub fn shared(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        sample_count: u32,
        format: wgpu::TextureFormat,
        share: Option<u32>,
    ) -> Self {
        let sample_count = if sample_count == 4 { 4 } else { 1 };
        let format = if format == wgpu::TextureFormat::Rgba8Unorm { format } else { COLOR_FORMAT };
        let super::pipelines::Kit { layouts, pipelines, compute, white } =
            super::pipelines::kit(device, queue, format, sample_count, share);
        let frame_buffers = ["kloub frame", "kloub shadow frame"].map(|label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size_of::<FrameUniform>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        let align = u64::from(device.limits().min_uniform_buffer_offset_alignment).max(1);
        let draw_stride = (size_of::<DrawUniform>() as u64).div_ceil(align) * align;
        let empty = GpuScene::empty(device, queue, &layouts, &frame_buffers, draw_stride);
        let no_environment = fallback_environment(device, &layouts.environment, &white);
        Self {
            share,
            sample_count,
            format,
            draw_stride,
            layouts,
            pipelines,
            frame_buffers,
            shadow: None,
            white,
            samplers: HashMap::new(),
            material_buffer: None,
            empty,
            scene: None,
            target: None,
            target_version: 0,
            direct: None,
            prepared_copies: 1,
            skinning: None,
            default_skinning: SkinningPath::Gpu,
            ground: Ground::default(),
            scratch: Scratch::default(),
            times: RenderTimes::default(),
            compute,
            heatmap: None,
            grid: true,
            look: super::uniforms::Look::default(),
            ibl_supported: true,
            environment_image: None,
            environment: (None, no_environment, 0.0),
            image_environment: None,
            full_casters: false,
        }
    }

    /// Whether the adapter can prefilter environments ([`super::environment::supports_ibl`];
    /// assumed until said otherwise). Without, the meshes' ambient light is the hemisphere.
    pub fn set_ibl_supported(&mut self, supported: bool) {
        self.ibl_supported = supported;
    }

    /// The image [`EnvironmentChoice::Image`] lights with (prefiltered when first drawn).
    pub fn set_environment_image(&mut self, image: Option<std::sync::Arc<HdrImage>>) {
        self.environment_image =
            image.map(|i| (ENVIRONMENT_IMAGES.fetch_add(1, std::sync::atomic::Ordering::Relaxed), i));
    }

    /// Whether an environment image was given.
    pub fn has_environment_image(&self) -> bool {
        self.environment_image.is_some()
    }

    /// The image [`SceneRenderer::set_environment_image`] gave.
    pub fn environment_image(&self) -> Option<std::sync::Arc<HdrImage>> {
        self.environment_image.as_ref().map(|(_, i)| i.clone())
    }

    /// Writes this frame's ground shadow: the light's view into the shadow frame buffer and
    /// the ground pass's uniform, for a key light `light` (towards it, scaled by its intensity)
    /// and copies out to `extent`; nothing (and no shadow drawn) at intensity 0 or without a
    /// model.
    fn prepare_shadow(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, frame: &FrameUniform, extent: f32) {
        let on = self.look.shadow_intensity > 0.0 && self.scene.as_ref().is_some_and(|s| !s.draws.is_empty());
        if !on {
            if let Some(shadow) = &mut self.shadow {
                shadow.drawn = false;
            }
            return;
        }
        let light = Vec3::from_slice(&frame.light_dir[..3]) * frame.light_dir[3];
        let uniform = ShadowUniform::new(&self.ground, light, extent, SHADOW_MAP_SIZE, &self.look);
        // The shadow's GPU side made again (map, mask, bind groups) only when the softness crosses
        // SOFT_SHADOW.
        let mask_size = if self.look.shadow_softness >= SOFT_SHADOW { SOFT_SHADOW_MASK_SIZE } else { SHADOW_MASK_SIZE };
        if self.shadow.as_ref().is_some_and(|s| s.mask_size != mask_size) {
            self.shadow = None;
        }
        let shadow = self.shadow.get_or_insert_with(|| ShadowMap::new(device, &self.layouts, mask_size));
        queue.write_buffer(&shadow.uniform, 0, bytemuck::bytes_of(&uniform));
        // The map spans 1.5 radii of the scene's box beyond the farthest copy's offset
        // (`ShadowUniform::new`): a copy is drawn at 1.5 r / (1.5 r + extent) of one model's size.
        let r = 1.5 * self.ground.radius;
        shadow.coarse = r < kloub_core::simplify::COARSE_SCALE * (r + extent);
        let light_frame = FrameUniform { view_proj: uniform.light_view_proj, ..*frame };
        queue.write_buffer(&self.frame_buffers[1], 0, bytemuck::bytes_of(&light_frame));
        shadow.drawn = true;
    }

    /// Binds the environment the look asks for (prefiltering it if this device has not yet);
    /// returns what the frame uniform says of it.
    fn ensure_environment(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) -> EnvironmentLight {
        let (key, intensity) = match self.look.environment {
            EnvironmentChoice::Preset => {
                let (name, intensity) = self.look.lighting.environment();
                (Some(EnvironmentKey::Named(Builtin::Procedural(name))), intensity)
            }
            EnvironmentChoice::Named(name) => (Some(EnvironmentKey::Named(name.builtin())), 1.0),
            EnvironmentChoice::Image => {
                (self.environment_image.as_ref().map(|(id, _)| EnvironmentKey::Image(*id)), 1.0)
            }
        };
        if key != self.environment.0 {
            let made = match key {
                Some(EnvironmentKey::Named(name)) => {
                    self.pipelines.named_environment(device, queue, &self.layouts.environment, self.ibl_supported, name)
                }
                Some(EnvironmentKey::Image(id)) => match &self.image_environment {
                    Some((cached, env)) if *cached == id => Some(env.clone()),
                    _ => {
                        let image = self.environment_image.as_ref().map(|(_, i)| i.clone());
                        let kit = self.pipelines.ibl(device, self.ibl_supported);
                        let made = match (kit, image) {
                            (Some(kit), Some(image)) => kit
                                .environment(device, queue, &self.layouts.environment, &image)
                                .map_err(|e| log::warn!("kloub: environment image: {e}"))
                                .ok(),
                            _ => None,
                        };
                        self.image_environment = made.clone().map(|env| (id, env));
                        made
                    }
                },
                None => None,
            };
            match made {
                Some(env) => self.environment = (key, env, 1.0),
                // Nothing to light with: the hemisphere, asked again only when the look changes.
                None => {
                    self.environment.0 = key;
                    self.environment.2 = 0.0;
                }
            }
        }
        if self.environment.2 == 0.0 {
            return EnvironmentLight::NONE;
        }
        EnvironmentLight {
            intensity,
            levels: super::environment::SPECULAR_LEVELS,
            irradiance: self.environment.1.irradiance,
        }
    }

    /// Uploads `asset` (meshes of the default scene, materials, textures with mips, a palette
    /// texture sized for all skins) and places the ground under its rest pose. On error the
    /// previous asset stays loaded.
    pub fn set_asset(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, asset: &Asset) -> Result<(), String> {
        self.upload_asset(device, queue, asset, None).map(|_| ())
    }

    /// [`SceneRenderer::set_asset`] for an asset other viewers of the page may show too: what
    /// does not change per viewer (meshes, materials with their textures, morph targets, SJB
    /// centres) is uploaded once per device and shared while any viewer shows the asset; each
    /// viewer keeps only its own palette, uniforms and deformed streams.
    pub fn set_shared_asset(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        asset: &std::sync::Arc<Asset>,
    ) -> Result<(), String> {
        let Some(share) = self.share else { return self.set_asset(device, queue, asset) };
        let storage = self.compute.is_some();
        let cached = UPLOADS.with(|uploads| {
            let mut uploads = uploads.borrow_mut();
            uploads.retain(|u| u.asset.strong_count() > 0);
            uploads
                .iter()
                .find(|u| u.storage == storage && u.share == share && std::ptr::eq(u.asset.as_ptr(), &**asset))
                .map(|u| u.uploaded.clone())
        });
        let fresh = cached.is_none();
        let uploaded = self.upload_asset(device, queue, asset, cached)?;
        if fresh {
            UPLOADS.with(|uploads| {
                uploads.borrow_mut().push(SharedUpload {
                    asset: std::sync::Arc::downgrade(asset),
                    share,
                    storage,
                    uploaded,
                });
            });
        }
        Ok(())
    }

    /// Builds the GPU scene of `asset`, from `uploaded` (its static part, already on this
    /// device) or uploading it; returns the static part.
    fn upload_asset(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        asset: &Asset,
        uploaded: Option<Uploaded>,
    ) -> Result<Uploaded, String> {
        let storage = self.compute.is_some();
        let (primitives, materials) = match &uploaded {
            Some(u) => (u.primitives.clone(), u.materials.clone()),
            None => {
                UPLOADS_MADE.with(|n| n.set(n.get() + 1));
                let mut primitives = Vec::with_capacity(asset.meshes.len());
                for mesh in &asset.meshes {
                    primitives.push(
                        mesh.primitives.iter().map(|p| GpuPrimitive::new(device, p, storage)).collect::<Vec<_>>(),
                    );
                }
                (primitives, self.upload_materials(device, queue, asset)?)
            }
        };
        let default_material = materials.len().saturating_sub(1);

        let mut skin_base = Vec::with_capacity(asset.skins.len());
        let mut joints = 0u32;
        for skin in &asset.skins {
            skin_base.push(joints);
            joints =
                u32::try_from(skin.joints.len()).ok().and_then(|n| joints.checked_add(n)).ok_or("too many joints")?;
        }
        let palette = PaletteTexture::new(device, joints)?;

        let mut draws = Vec::new();
        for node_index in asset.scene_nodes() {
            let Some(node) = asset.nodes.get(node_index as usize) else {
                continue;
            };
            let Some(mesh_index) = node.mesh.map(|m| m as usize) else {
                continue;
            };
            let Some(mesh) = asset.meshes.get(mesh_index) else {
                continue;
            };
            for (p, primitive) in mesh.primitives.iter().enumerate() {
                if primitives.get(mesh_index).and_then(|m| m.get(p)).is_none_or(Option::is_none) {
                    continue;
                }
                let material_index = primitive.material.map(|m| m as usize).filter(|&m| m < default_material);
                let material = material_index.and_then(|m| asset.materials.get(m));
                let skin = node.skin.map(|s| s as usize).filter(|&s| s < asset.skins.len() && primitive.is_skinned());
                let pivots = match uploaded.as_ref().map(|u| u.pivots.get(draws.len()).cloned().flatten()) {
                    Some(shared) => shared,
                    None => skin.filter(|&s| s < asset.skins.len()).map(|_| {
                        let unwritten = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(PIVOTS_UNWRITTEN));
                        (pivot_buffer(device, primitive.positions.len(), storage), unwritten)
                    }),
                };
                draws.push(DrawItem {
                    node: node_index,
                    mesh: mesh_index,
                    primitive: p,
                    skin,
                    morph: None,
                    sjb_fallbacks: pivots.as_ref().map_or_else(Default::default, |p| p.1.clone()),
                    pivots: pivots.map(|p| p.0),
                    material: material_index.unwrap_or(default_material),
                    blend: material.is_some_and(|m| m.alpha == AlphaMode::Blend),
                    mask: material.is_some_and(|m| matches!(m.alpha, AlphaMode::Mask(_))),
                    double_sided: material.is_some_and(|m| m.double_sided),
                    normal_mapped: material.is_some_and(|m| m.normal_texture.is_some()),
                    textures: material.map_or(0, super::uniforms::optional_textures),
                    morphed: !primitive.targets.is_empty(),
                    deformed: Vec::new(),
                    deformed_tangents: Vec::new(),
                    key: None,
                    on_cpu: false,
                    on_compute: false,
                    batched: false,
                    compute_groups: Vec::new(),
                });
            }
        }
        let morphs = match &uploaded {
            Some(u) => u.morphs.clone(),
            None => MorphTexture::new(
                device,
                queue,
                asset,
                draws.iter().filter(|d| d.morphed).map(|d| (d.mesh, d.primitive)),
            ),
        };
        let shared = Uploaded {
            primitives: primitives.clone(),
            materials: materials.clone(),
            pivots: draws.iter().map(|d| d.pivots.clone().map(|p| (p, d.sjb_fallbacks.clone()))).collect(),
            morphs: morphs.clone(),
        };
        for draw in &mut draws {
            draw.morph = morphs.slot(draw.mesh, draw.primitive);
        }
        let (draw_buffer, draw_bind_group) = draw_resources(device, &self.layouts, 2 * draws.len(), self.draw_stride);
        let morph_view = morphs.view().clone();
        let frame_bind_groups = frame_bind_groups(device, &self.layouts, &self.frame_buffers, &palette, &morph_view);
        let compute = self.compute.as_ref().map(|kit| compute_groups(device, kit, &palette, &morph_view, &draw_buffer));

        let mut rest = Instance::new(asset);
        let bounds = rest.evaluate(asset, None, 0.0).ok().and_then(|()| rest.scene_bounds(asset));
        self.ground = match bounds {
            Some((min, max)) => Ground::under(min, max),
            None => Ground::default(),
        };
        let diagonal = bounds.map_or(1.0, |(min, max)| (max - min).length()).max(1e-6);
        self.scene = Some(GpuScene {
            primitives,
            materials,
            draws,
            draw_buffer,
            draw_bind_group,
            skin_base,
            palette,
            morph_view,
            frame_bind_groups,
            node_count: asset.nodes.len(),
            joints,
            copies: 1,
            diagonal,
            compute,
            batch: CasterBatch::default(),
        });
        Ok(shared)
    }

    /// Writes the spherical-joint-blend centres of every skinned draw of the loaded asset
    /// (`asset`) that no viewer of its upload has written yet (each frame that skins with SJB or
    /// SJBBE does too): what [`SceneRenderer::sjb_fallbacks`] counts.
    pub fn write_sjb_pivots(&self, queue: &wgpu::Queue, asset: &Asset) {
        let Some(scene) = &self.scene else { return };
        for draw in &scene.draws {
            if let Some(source) = asset.meshes.get(draw.mesh).and_then(|m| m.primitives.get(draw.primitive)) {
                write_pivots_once(queue, asset, draw, source);
            }
        }
    }

    /// Per skinned draw of the loaded asset: `(mesh, vertices, vertices without a shared joint
    /// centre)`; the latter are skinned by dual quaternions under spherical joint blending.
    pub fn sjb_fallbacks(&self) -> Vec<(usize, usize, usize)> {
        let Some(scene) = &self.scene else {
            return Vec::new();
        };
        scene
            .draws
            .iter()
            .filter(|d| d.skin.is_some())
            .filter_map(|d| {
                let gpu = scene.primitives.get(d.mesh)?.get(d.primitive)?.as_ref()?;
                let fallbacks = d.sjb_fallbacks.load(std::sync::atomic::Ordering::Relaxed);
                Some((d.mesh, gpu.vertex_count as usize, if fallbacks == PIVOTS_UNWRITTEN { 0 } else { fallbacks }))
            })
            .collect()
    }

    /// Drops the loaded asset (the view then shows only the background and grid).
    pub fn clear_asset(&mut self) {
        self.scene = None;
        self.ground = Ground::default();
    }

    /// Chooses where skinned vertices are deformed (takes effect at the next render).
    ///
    /// # Errors
    /// [`SkinningPath::Compute`] on a device without compute shaders (WebGL2); the path is
    /// then unchanged.
    pub fn set_skinning_path(&mut self, path: SkinningPath) -> Result<(), String> {
        if path == SkinningPath::Compute && self.compute.is_none() {
            return Err("compute skinning needs WebGPU or a native GPU: this backend has no compute shaders".into());
        }
        self.skinning = Some(path);
        Ok(())
    }

    /// The path used until one is chosen with [`SceneRenderer::set_skinning_path`]
    /// ([`default_skinning_path`] of the adapter, which every device has; [`SkinningPath::Gpu`]
    /// until said).
    pub fn set_default_skinning_path(&mut self, path: SkinningPath) {
        self.default_skinning = path;
    }

    /// The path chosen with [`SceneRenderer::set_skinning_path`], if one was.
    pub fn chosen_skinning_path(&self) -> Option<SkinningPath> {
        self.skinning
    }

    /// Colours skinned vertices by how far they are from linear blend skinning's result (from
    /// dual quaternions' when LBS is the method): blue for none, red at 2% of the rest
    /// pose's bounding-box diagonal. Only on the vertex-shader path (other paths draw normally).
    pub fn set_heatmap(&mut self, on: bool) {
        self.heatmap = on.then_some(HEATMAP_FULL_SCALE);
    }

    /// Draws `sculpt`'s vertices in place of its node's deformation (CPU path for those
    /// primitives) until set to `None`.
    pub fn set_sculpt(&mut self, sculpt: Option<SculptMesh>) {
        self.scratch.sculpt = sculpt;
        self.scratch.sculpt_written.clear();
    }

    /// Whether the deviation heatmap is on.
    pub fn heatmap(&self) -> bool {
        self.heatmap.is_some()
    }

    /// Whether a soft shadow's casters draw every triangle of their primitives instead of the
    /// simplified ones ([`kloub_core::simplify::cluster_triangles`], the default); a sharp
    /// shadow's always do. For comparing the two (tests/golden.rs, benchmarks).
    pub fn set_full_casters(&mut self, full: bool) {
        self.full_casters = full;
    }

    /// What the casters of `shadow` draw: a soft shadow's, their simplified triangles (the mask
    /// blurs finer detail), unless [`SceneRenderer::set_full_casters`].
    fn casters_pass(&self, shadow: &ShadowMap) -> Pass {
        if shadow.mask_size == SOFT_SHADOW_MASK_SIZE && !self.full_casters {
            Pass::SimplifiedCasters { coarse: shadow.coarse }
        } else {
            Pass::Casters
        }
    }

    /// How many indices the last prepared frame's shadow casters draw, over every copy; `None`
    /// when it draws no shadow. For checking which lists they draw (tests/golden.rs).
    pub fn caster_indices_drawn(&self) -> Option<u64> {
        let shadow = self.shadow.as_ref().filter(|s| s.drawn)?;
        let scene = self.scene.as_ref()?;
        let kind = self.casters_pass(shadow);
        let per_copy: u64 = scene
            .draws
            .iter()
            .filter(|d| d.casts_alone())
            .filter_map(|d| {
                let gpu = scene.primitives.get(d.mesh)?.get(d.primitive)?.as_ref()?;
                Some(u64::from(caster_list(gpu, kind, d.mask).1))
            })
            .sum();
        let batched = if scene.batch.ready() { u64::from(scene.batch.count) } else { 0 };
        Some(per_copy * self.prepared_copies as u64 + batched)
    }

    /// How many draws the last prepared frame's shadow casters make (the copies' gathered ones
    /// count once); `None` when it draws no shadow. For tests.
    pub fn caster_draws(&self) -> Option<u64> {
        self.shadow.as_ref().filter(|s| s.drawn)?;
        let scene = self.scene.as_ref()?;
        let each = scene.draws.iter().filter(|d| d.casts_alone());
        let batched = scene.batch.ready();
        Some(each.count() as u64 * self.prepared_copies as u64 + u64::from(batched))
    }

    /// Shows or hides the ground grid (on by default).
    pub fn set_grid(&mut self, on: bool) {
        self.grid = on;
    }

    /// Whether the ground grid is drawn.
    pub fn grid(&self) -> bool {
        self.grid
    }

    /// Sets the lighting and background.
    pub fn set_look(&mut self, look: super::uniforms::Look) {
        self.look = look;
    }

    /// The lighting and background.
    pub fn look(&self) -> super::uniforms::Look {
        self.look
    }

    /// Builds the fixed pipelines a first frame draws with ([`Pipelines::warm`]), for a viewer
    /// about to load its first model; on the CPU skinning path also the world caster its soft
    /// shadow's deformed casters are gathered into (those draw without their own caster
    /// pipelines, which depend on the model).
    pub fn warm_pipelines(&self, device: &wgpu::Device) {
        self.pipelines.warm(device, self.ibl_supported);
        if self.skinning_path() == SkinningPath::Cpu {
            let _ = self.pipelines.world_caster(device);
        }
    }

    /// Whether [`SkinningPath::Compute`] is available on this device.
    pub fn supports_compute(&self) -> bool {
        self.compute.is_some()
    }

    /// Where skinned vertices are deformed: the chosen path, else the adapter's default,
    /// except that the deviation heatmap (drawn by the vertex shader) takes an unchosen
    /// default to [`SkinningPath::Gpu`].
    pub fn skinning_path(&self) -> SkinningPath {
        match self.skinning {
            Some(path) => path,
            None if self.heatmap.is_some() => SkinningPath::Gpu,
            None => self.default_skinning,
        }
    }

    /// The ground the grid is drawn on (under the rest pose of the loaded asset).
    pub fn ground(&self) -> Ground {
        self.ground
    }

    /// Places the ground grid explicitly.
    pub fn set_ground(&mut self, ground: Ground) {
        self.ground = ground;
    }

    /// The colour format the scene draws into (see [`SceneRenderer::with_format`]).
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// Sample count of the scene pipelines (1 or 4).
    pub fn sample_count(&self) -> u32 {
        self.sample_count
    }

    /// The resolved colour texture of the last render (`Rgba8UnormSrgb`,
    /// `TEXTURE_BINDING | COPY_SRC`), `None` before the first render.
    pub fn target_texture(&self) -> Option<&wgpu::Texture> {
        self.target.as_ref().map(|t| &t.texture)
    }

    /// The view of [`SceneRenderer::target_texture`].
    pub fn target_view(&self) -> Option<&wgpu::TextureView> {
        self.target.as_ref().map(|t| &t.view)
    }

    /// Incremented whenever the target texture is recreated (its size changed): re-register
    /// the view with egui when this changes.
    pub fn target_version(&self) -> u64 {
        self.target_version
    }

    /// Draws `asset`, posed by `instance` (already evaluated by the caller), seen by
    /// `camera`, into the target of `size` pixels (clamped to 1..=device limit), and submits
    /// the work to `queue`. Returns the resolved target view.
    ///
    /// `asset` must be the one passed to [`SceneRenderer::set_asset`] and `instance` must
    /// be an instance of it; otherwise an error is returned.
    pub fn render(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        asset: &Asset,
        instance: &mut Instance,
        camera: &Camera,
        size: [u32; 2],
    ) -> Result<&wgpu::TextureView, String> {
        self.render_copies(device, queue, asset, &mut [instance], &[Vec3::ZERO], camera, size)
    }

    /// [`SceneRenderer::render`] for several copies of the character: `instances[c]` (each
    /// evaluated by the caller) drawn moved by `offsets[c]`.
    #[expect(clippy::too_many_arguments, reason = "render's arguments plus the copies")]
    pub fn render_copies(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        asset: &Asset,
        instances: &mut [&mut Instance],
        offsets: &[Vec3],
        camera: &Camera,
        size: [u32; 2],
    ) -> Result<&wgpu::TextureView, String> {
        let max = device.limits().max_texture_dimension_2d;
        let size = [size[0].clamp(1, max), size[1].clamp(1, max)];
        if self.target.as_ref().is_none_or(|t| t.attachments.size != size) {
            self.target = Some(Target::new(device, size, self.sample_count, self.format));
            self.target_version += 1;
        }
        self.prepare_copies(device, queue, asset, instances, offsets, camera, size[0] as f32 / size[1] as f32)?;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("kloub scene") });
        let target = self.target.take().ok_or("render target missing")?;
        let (color, resolve) = target.attachments.colour(&target.view);
        self.encode(device, &mut encoder, color, resolve, &target.attachments.depth, None);
        self.target = Some(target);
        queue.submit([encoder.finish()]);
        let target = self.target.as_ref().ok_or("render target missing")?;
        Ok(&target.view)
    }

    /// The first half of a frame drawn straight into a canvas ([`SceneRenderer::draw_into`]):
    /// the camera for a viewport of `aspect` (width / height), palettes, CPU deformation and
    /// uploads for `instances` moved by `offsets`.
    ///
    /// # Errors
    /// When `asset` is not the one passed to [`SceneRenderer::set_asset`] or an instance does
    /// not fit it.
    #[expect(clippy::too_many_arguments, reason = "render's arguments less the size, plus the aspect")]
    pub fn prepare_copies(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        asset: &Asset,
        instances: &mut [&mut Instance],
        offsets: &[Vec3],
        camera: &Camera,
        aspect: f32,
    ) -> Result<(), String> {
        let aspect = if aspect.is_finite() && aspect > 0.0 { aspect } else { 1.0 };
        let environment = self.ensure_environment(device, queue);
        let frame = FrameUniform::new(
            camera.view_proj(aspect),
            camera.eye(),
            camera.target,
            &self.ground,
            self.look,
            environment,
        );
        queue.write_buffer(&self.frame_buffers[0], 0, bytemuck::bytes_of(&frame));
        let extent = offsets.iter().map(|o| o.length()).fold(0.0f32, f32::max);
        self.prepare_shadow(device, queue, &frame, extent);

        let copies = instances.len();
        self.prepared_copies = copies;
        let path = self.skinning_path();
        // A soft shadow's simplified casters, on the coarse level or not (`None`: no casters, or
        // every triangle: neither is gathered).
        let casters = match self.shadow.as_ref().filter(|s| s.drawn).map(|s| self.casters_pass(s)) {
            Some(Pass::SimplifiedCasters { coarse }) => Some(coarse),
            _ => None,
        };
        if let Some(scene) = self.scene.as_mut() {
            scene.reserve(
                device,
                &self.layouts,
                &self.frame_buffers,
                self.compute.as_ref(),
                copies,
                self.draw_stride,
            )?;
            scene.prepare(
                device,
                queue,
                asset,
                instances,
                offsets,
                camera,
                path,
                self.compute.as_ref(),
                self.heatmap,
                // The frame's ambient light, as the frame uniform says it (its intensity 0: the
                // hemisphere): the draws' pipelines compile that one only.
                environment.intensity > 0.0,
                casters,
                self.draw_stride,
                &mut self.scratch,
            )?;
            if scene.batch.ready() {
                let _ = self.pipelines.world_caster(device);
            }
            let casting = self.shadow.as_ref().is_some_and(|s| s.drawn);
            for draw in &scene.draws {
                if let Some(key) = draw.key {
                    self.pipelines.prepare(device, key);
                    // A gathered draw's casters draw through the world caster.
                    if let Some(caster) = key.caster(draw.mask).filter(|_| casting && !draw.batched) {
                        self.pipelines.prepare(device, caster);
                    }
                }
            }
        }
        let ms = |d: std::time::Duration| d.as_secs_f32() * 1000.0;
        let prepared = f32::from(u8::from(self.scene.is_some()));
        self.times.cpu_skin_ms = ms(self.scratch.cpu_skin) * prepared;
        self.times.upload_ms = ms(self.scratch.prepare.saturating_sub(self.scratch.cpu_skin)) * prepared;
        Ok(())
    }

    /// The second half of a frame drawn straight into a canvas: records the frame prepared by
    /// [`SceneRenderer::prepare_copies`] into `encoder`, drawing into `view` (a surface texture
    /// of `size` pixels in [`COLOR_FORMAT`]) within `rect` (`[x, y, width, height]` in pixels;
    /// the rest of the surface is cleared to the background). No offscreen target and no
    /// second pass: the colour is resolved (or written, without MSAA) into the surface itself.
    /// `shared`: attachments kept by the surface's owner for every viewer drawing into it one
    /// after another (the page's WebGL2 canvas); `None`: this renderer's own.
    pub fn draw_into(
        &mut self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        size: [u32; 2],
        rect: [u32; 4],
        shared: Option<&mut Option<Attachments>>,
    ) {
        let max = device.limits().max_texture_dimension_2d;
        let size = [size[0].clamp(1, max), size[1].clamp(1, max)];
        // Within the surface and at least one pixel (a viewport outside it is a validation error).
        let x = rect[0].min(size[0] - 1);
        let y = rect[1].min(size[1] - 1);
        let rect = [x, y, rect[2].clamp(1, size[0] - x), rect[3].clamp(1, size[1] - y)];
        let mut shared = shared;
        let taken = match shared.as_deref_mut() {
            Some(slot) => {
                // Drawing through a shared set from now on: this renderer's own is not needed.
                self.direct = None;
                slot.take()
            }
            None => self.direct.take(),
        };
        let attachments = match taken {
            Some(a) if a.size == size && a.samples == self.sample_count && a.format == self.format => a,
            _ => Attachments::new(device, size, self.sample_count, self.format),
        };
        let (color, resolve) = attachments.colour(view);
        self.encode(device, encoder, color, resolve, &attachments.depth, Some(rect));
        match shared {
            Some(slot) => *slot = Some(attachments),
            None => self.direct = Some(attachments),
        }
    }

    /// Records compute skinning and the scene's render pass (background, opaque draws, grid,
    /// blended draws back to front) into `encoder`; `viewport`: the part of the attachments
    /// drawn into (all of them when `None`).
    fn encode(
        &mut self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        color: &wgpu::TextureView,
        resolve_target: Option<&wgpu::TextureView>,
        depth: &wgpu::TextureView,
        viewport: Option<[u32; 4]>,
    ) {
        let encode_started = web_time::Instant::now();
        let copies = self.prepared_copies;
        let scene = self.scene.as_ref().unwrap_or(&self.empty);
        if let Some(kit) = &self.compute {
            scene.dispatch_compute(
                encoder,
                kit,
                copies,
                self.draw_stride,
                device.limits().max_compute_workgroups_per_dimension,
            );
        }
        let draws = scene.draws.len();
        let opaque = |slot: &usize| scene.draws.get(slot % draws).is_some_and(|d| !d.blend);
        if let Some(shadow) = self.shadow.as_ref().filter(|s| s.drawn) {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("kloub shadow map"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &shadow.view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &scene.frame_bind_groups[1], &[]);
            pass.set_bind_group(3, &self.environment.1.bind_group, &[]);
            let pass_kind = self.casters_pass(shadow);
            scene.encode(&mut pass, &self.pipelines, (0..copies * draws).filter(opaque), self.draw_stride, pass_kind);
            if matches!(pass_kind, Pass::SimplifiedCasters { .. }) && scene.batch.ready() {
                scene.encode_batch(&mut pass, self.pipelines.world_caster(device));
            }
            drop(pass);
            // The shadow filtered once into the mask (a fixed cost), not per pixel of the view.
            let mut pass = super::pipelines::fill_pass(encoder, "kloub shadow mask", &shadow.mask);
            pass.set_pipeline(self.pipelines.shadow_mask(device));
            pass.set_bind_group(0, &scene.frame_bind_groups[0], &[]);
            pass.set_bind_group(1, &shadow.bind_group, &[]);
            pass.draw(0..3, 0..1);
        }
        {
            let background = self.look.background.is_drawn().then(|| self.pipelines.background(device));
            let grid = self.grid.then(|| self.pipelines.grid(device));
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("kloub scene"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: color,
                    depth_slice: None,
                    resolve_target,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(FrameUniform::clear_color(self.look.background, self.format)),
                        store: if resolve_target.is_some() { wgpu::StoreOp::Discard } else { wgpu::StoreOp::Store },
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: depth,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if let Some([x, y, w, h]) = viewport {
                pass.set_viewport(x as f32, y as f32, w as f32, h as f32, 0.0, 1.0);
                pass.set_scissor_rect(x, y, w, h);
            }
            pass.set_bind_group(0, &scene.frame_bind_groups[0], &[]);
            pass.set_bind_group(3, &self.environment.1.bind_group, &[]);
            if let Some(background) = background {
                pass.set_pipeline(background);
                pass.draw(0..3, 0..1);
            }
            if let Some(shadow) = self.shadow.as_ref().filter(|s| s.drawn) {
                pass.set_pipeline(self.pipelines.ground_shadow(device));
                pass.set_bind_group(1, &shadow.ground_bind_group, &[]);
                pass.draw(0..6, 0..1);
            }

            scene.encode(&mut pass, &self.pipelines, (0..copies * draws).filter(opaque), self.draw_stride, Pass::Scene);
            if let Some(grid) = grid {
                pass.set_pipeline(grid);
                pass.draw(0..6, 0..1);
            }
            let blended = self.scratch.blend_order.iter().map(|&(_, i)| i);
            scene.encode(&mut pass, &self.pipelines, blended, self.draw_stride, Pass::Scene);
        }
        self.times.draw_ms = encode_started.elapsed().as_secs_f32() * 1000.0;
    }

    /// CPU time of the stages of the last [`SceneRenderer::render`].
    pub fn times(&self) -> RenderTimes {
        self.times
    }

    /// One bind group per material plus a last one for the glTF default material.
    fn upload_materials(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        asset: &Asset,
    ) -> Result<Vec<wgpu::BindGroup>, String> {
        // Each image as colour and as data, uploaded once for each use it has.
        let mut images: Vec<[Option<wgpu::TextureView>; 2]> = vec![[None, None]; asset.images.len()];
        for material in &asset.materials {
            for (slot, t) in material.textures().iter().enumerate() {
                let Some(t) = t else { continue };
                let srgb = kloub_core::asset::texture_slot_is_srgb(slot);
                let slot = images
                    .get_mut(t.image as usize)
                    .ok_or("material references a missing image")?
                    .get_mut(usize::from(!srgb))
                    .ok_or("two kinds of texture")?;
                if slot.is_none() {
                    let image = &asset.images[t.image as usize];
                    let label = image.name.as_deref().unwrap_or("kloub image");
                    let texture = if image.encoded.is_some() {
                        upload_decoded(device, queue, &self.pipelines, asset, t.image as usize, label, srgb)
                    } else {
                        Some(
                            upload_image(device, queue, image, label, srgb)
                                .map_err(|e| format!("image {}: {e}", t.image))?,
                        )
                    };
                    if let Some(texture) = texture {
                        *slot = Some(texture.create_view(&wgpu::TextureViewDescriptor::default()));
                    }
                }
            }
        }
        let default_material = Material::default();
        let all: Vec<&Material> = asset.materials.iter().chain(std::iter::once(&default_material)).collect();
        let align = u64::from(device.limits().min_uniform_buffer_offset_alignment).max(1);
        let stride = (size_of::<MaterialUniform>() as u64).div_ceil(align) * align;
        let mut bytes = vec![0u8; stride as usize * all.len()];
        for (i, material) in all.iter().enumerate() {
            let start = i * stride as usize;
            let uniform = MaterialUniform::new(material);
            bytes[start..start + size_of::<MaterialUniform>()].copy_from_slice(bytemuck::bytes_of(&uniform));
        }
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("kloub materials"),
            size: bytes.len() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        queue.write_buffer(&buffer, 0, &bytes);
        let mut groups = Vec::with_capacity(all.len());
        for (i, material) in all.iter().enumerate() {
            let textures = material.textures();
            let mut views = Vec::with_capacity(MATERIAL_TEXTURES);
            let mut samplers = Vec::with_capacity(MATERIAL_TEXTURES);
            for (slot, texture) in textures.iter().enumerate() {
                let kind = usize::from(!kloub_core::asset::texture_slot_is_srgb(slot));
                // A texture that could not be uploaded draws white; the shader reads only the
                // optional slots the material's flags name.
                let view = texture
                    .and_then(|t| images.get(t.image as usize))
                    .and_then(|pair| pair[kind].as_ref())
                    .unwrap_or(&self.white);
                views.push(view);
                let key = SamplerKey::of(texture.as_ref());
                samplers.push(self.samplers.entry(key).or_insert_with(|| key.create(device)).clone());
            }
            let mut entries = vec![wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &buffer,
                    offset: i as u64 * stride,
                    size: wgpu::BufferSize::new(size_of::<MaterialUniform>() as u64),
                }),
            }];
            for (slot, (view, sampler)) in views.iter().zip(&samplers).enumerate() {
                let slot = slot as u32;
                entries.push(wgpu::BindGroupEntry {
                    binding: 1 + 2 * slot,
                    resource: wgpu::BindingResource::TextureView(view),
                });
                entries.push(wgpu::BindGroupEntry {
                    binding: 2 + 2 * slot,
                    resource: wgpu::BindingResource::Sampler(sampler),
                });
            }
            groups.push(device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: material.name.as_deref(),
                layout: &self.layouts.material,
                entries: &entries,
            }));
        }
        self.material_buffer = Some(buffer);
        Ok(groups)
    }
}

fn draw_resources(
    device: &wgpu::Device,
    layouts: &Layouts,
    draws: usize,
    stride: u64,
) -> (wgpu::Buffer, wgpu::BindGroup) {
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("kloub draws"),
        size: stride * draws.max(1) as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("kloub draws"),
        layout: &layouts.draw,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &buffer,
                offset: 0,
                size: wgpu::BufferSize::new(size_of::<DrawUniform>() as u64),
            }),
        }],
    });
    (buffer, group)
}

/// The compute pass's bind groups for the palette and morph textures, and the draw uniforms.
fn compute_groups(
    device: &wgpu::Device,
    kit: &ComputeKit,
    palette: &PaletteTexture,
    morphs: &wgpu::TextureView,
    draw_buffer: &wgpu::Buffer,
) -> (wgpu::BindGroup, wgpu::BindGroup) {
    let textures = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("kloub compute textures"),
        layout: &kit.textures,
        entries: &[
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(palette.view()) },
            wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(morphs) },
        ],
    });
    let draws = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("kloub compute draws"),
        layout: &kit.draw,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: draw_buffer,
                offset: 0,
                size: wgpu::BufferSize::new(size_of::<DrawUniform>() as u64),
            }),
        }],
    });
    (textures, draws)
}

/// Group 0 of the view and of the shadow map: each frame buffer of `frames` with the palette
/// and morph textures.
fn frame_bind_groups(
    device: &wgpu::Device,
    layouts: &Layouts,
    frames: &[wgpu::Buffer; 2],
    palette: &PaletteTexture,
    morphs: &wgpu::TextureView,
) -> [wgpu::BindGroup; 2] {
    frames.each_ref().map(|frame| {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("kloub frame"),
            layout: &layouts.frame,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: frame.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(palette.view()) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(morphs) },
            ],
        })
    })
}

impl GpuScene {
    /// A scene with nothing to draw (background and grid only).
    fn empty(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        layouts: &Layouts,
        frames: &[wgpu::Buffer; 2],
        stride: u64,
    ) -> Self {
        let palette = PaletteTexture::with_rows(device, 1);
        let morph_view = MorphTexture::empty(device, queue).view().clone();
        let (draw_buffer, draw_bind_group) = draw_resources(device, layouts, 0, stride);
        let frame_bind_groups = frame_bind_groups(device, layouts, frames, &palette, &morph_view);
        Self {
            primitives: Vec::new(),
            materials: Vec::new(),
            draws: Vec::new(),
            draw_buffer,
            draw_bind_group,
            skin_base: Vec::new(),
            palette,
            morph_view,
            frame_bind_groups,
            node_count: 0,
            joints: 0,
            copies: 1,
            diagonal: 1.0,
            compute: None,
            batch: CasterBatch::default(),
        }
    }

    /// Makes room in the palette texture and the draw buffer for `copies` copies of the
    /// character (grows only; rebuilds the bind groups that point at them).
    fn reserve(
        &mut self,
        device: &wgpu::Device,
        layouts: &Layouts,
        frames: &[wgpu::Buffer; 2],
        kit: Option<&ComputeKit>,
        copies: usize,
        stride: u64,
    ) -> Result<(), String> {
        if copies <= self.copies {
            return Ok(());
        }
        let joints = u32::try_from(copies)
            .ok()
            .and_then(|c| c.checked_mul(self.joints))
            .ok_or("too many copies for the joint palette")?;
        self.palette = PaletteTexture::new(device, joints)?;
        self.frame_bind_groups = frame_bind_groups(device, layouts, frames, &self.palette, &self.morph_view);
        let (buffer, group) = draw_resources(device, layouts, 2 * self.draws.len() * copies, stride);
        self.draw_buffer = buffer;
        self.draw_bind_group = group;
        self.compute = kit.map(|kit| compute_groups(device, kit, &self.palette, &self.morph_view, &self.draw_buffer));
        self.copies = copies;
        Ok(())
    }

    /// Uploads this frame's palettes and draw uniforms for every copy (`instances[c]` placed
    /// at `offsets[c]`), deforms CPU-path primitives, picks each draw's pipeline and orders
    /// the blended draws back to front. Draw slot `c * draws + i` is copy `c` of draw `i`.
    #[expect(clippy::too_many_arguments, reason = "one call site; the pieces are disjoint borrows of the renderer")]
    fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        asset: &Asset,
        instances: &mut [&mut Instance],
        offsets: &[Vec3],
        camera: &Camera,
        path: SkinningPath,
        kit: Option<&ComputeKit>,
        heatmap: Option<f32>,
        ibl: bool,
        casters: Option<bool>,
        stride: u64,
        scratch: &mut Scratch,
    ) -> Result<(), String> {
        if asset.nodes.len() != self.node_count
            || asset.skins.len() != self.skin_base.len()
            || instances.iter().any(|i| i.worlds().len() != self.node_count)
            || instances.len() > self.copies
            || offsets.len() != instances.len()
        {
            return Err("the asset or instances do not match the ones uploaded with set_asset".into());
        }
        let started = web_time::Instant::now();
        let draws = self.draws.len();
        for (c, instance) in instances.iter().enumerate() {
            let method = instance.skinning();
            let dual = method.uses_dual_quaternions();
            let first = c as u32 * self.joints;
            for (skin, &base) in self.skin_base.iter().enumerate() {
                let dqs = dual.then(|| instance.joint_dqs(skin));
                self.palette.set(first + base, instance.palette(skin), dqs)?;
            }
        }
        if !self.skin_base.is_empty() {
            self.palette.upload(queue);
        }

        let eye = camera.eye();
        scratch.draw_bytes.clear();
        // Render uniforms first, then the compute pass's (slot `n · draws + c · draws + i`).
        let compute_base = draws * instances.len();
        scratch.draw_bytes.resize(2 * stride as usize * compute_base, 0);
        scratch.blend_order.clear();
        scratch.cpu_skin = std::time::Duration::ZERO;
        let batch = &mut self.batch;
        batch.positions.clear();
        batch.wanted.clear();
        let mut batch_indices = 0usize;
        for draw in &mut self.draws {
            draw.batched = false;
        }
        if let Some(coarse) = casters {
            batch.wanted.extend([instances.len() as u32, u32::from(coarse)]);
        }
        for (i, draw) in self.draws.iter_mut().enumerate() {
            let primitive = self.primitives.get(draw.mesh).and_then(|m| m.get(draw.primitive)).and_then(Option::as_ref);
            let (Some(gpu), Some(source)) =
                (primitive, asset.meshes.get(draw.mesh).and_then(|m| m.primitives.get(draw.primitive)))
            else {
                draw.key = None;
                continue;
            };
            let deforms = draw.morphed || draw.skin.is_some();
            let sculpted = (scratch.sculpt.as_ref())
                .is_some_and(|s| s.node == draw.node && s.primitives.iter().any(|p| p.0 == draw.primitive));
            draw.on_cpu = sculpted || (deforms && path == SkinningPath::Cpu) || (draw.morphed && draw.morph.is_none());
            draw.on_compute = !draw.on_cpu
                && path == SkinningPath::Compute
                && kit.is_some()
                && draw.skin.is_some()
                && gpu.skin.is_some()
                && draw.pivots.is_some();
            // The copies' soft-shadow casters gathered on the CPU, where their vertices are
            // deformed anyway (not a sculpt's, written once; not a mirrored unskinned node's,
            // whose winding its world matrix turns).
            let batch_set = casters.and_then(|coarse| gpu.caster_sets.get(usize::from(coarse)).cloned().flatten());
            draw.batched = batch_set.is_some()
                && draw.on_cpu
                && !sculpted
                && !draw.blend
                && !draw.mask
                && topology(source.topology) == wgpu::PrimitiveTopology::TriangleList
                && (draw.skin.is_some()
                    || instances
                        .iter()
                        .all(|c| c.worlds().get(draw.node as usize).is_some_and(|w| w.determinant() >= 0.0)));
            if let Some(set) = batch_set.as_ref().filter(|_| draw.batched) {
                let more = set.indices.len() * instances.len() * (1 + usize::from(draw.double_sided));
                draw.batched = batch_indices + more <= BATCH_MAX_INDICES;
                if draw.batched {
                    batch_indices += more;
                    batch.wanted.extend([i as u32, u32::from(draw.double_sided)]);
                }
            }
            if instances.iter().any(|i| i.skinning().uses_sjb_plan()) {
                write_pivots_once(queue, asset, draw, source);
            }
            if draw.deformed.len() < instances.len() {
                draw.deformed.resize_with(instances.len(), || None);
            }
            if draw.deformed_tangents.len() < instances.len() {
                draw.deformed_tangents.resize_with(instances.len(), || None);
            }
            if draw.compute_groups.len() < instances.len() {
                draw.compute_groups.resize_with(instances.len(), || None);
            }
            let mut mirrored = false;
            // The method compiled into a skinned draw's pipeline: the copies' common one, or
            // read per draw when they differ.
            let mut method: Option<u32> = None;
            for (c, instance) in instances.iter_mut().enumerate() {
                let place = Mat4::from_translation(offsets[c]);
                let world = instance.worlds()[draw.node as usize];
                // An unskinned draw's world matrix mirrors its triangles wherever it is applied (in
                // the vertex shader, or baked into vertices deformed on the CPU); a skinned one's
                // is ignored (glTF), its joints place it.
                if draw.skin.is_none() {
                    mirrored = world.determinant() < 0.0;
                }
                let morph = |u: DrawUniform| match draw.morph {
                    Some(slot) => u.with_morph(slot, instance.node_weights(asset, draw.node)),
                    None => u,
                };
                let (uniform, vertex) = if draw.on_cpu {
                    let skin_started = web_time::Instant::now();
                    let shown = (scratch.sculpt.as_ref())
                        .filter(|s| c == 0 && s.node == draw.node)
                        .and_then(|s| s.primitives.iter().find(|p| p.0 == draw.primitive));
                    // A sculpt's shape is written once per change (its buffer keeps it meanwhile).
                    let already = shown.is_some()
                        && draw.deformed.first().is_some_and(Option::is_some)
                        && scratch.sculpt_written.contains(&(draw.node, draw.primitive));
                    let has_normals = if let Some((_, positions, normals)) = shown.filter(|_| already) {
                        normals.len() == positions.len()
                    } else {
                        if let Some((_, positions, normals)) = shown {
                            scratch.positions.clone_from(positions);
                            scratch.normals.clone_from(normals);
                            scratch.sculpt_written.push((draw.node, draw.primitive));
                            // A sculpted shape has no tangents of its own: zeros, the fragment
                            // shader derives a frame.
                            scratch.tangents.clear();
                            scratch.tangents.resize(positions.len(), [0.0; 4]);
                        } else {
                            let failed = |e| format!("deforming node {} primitive {}: {e}", draw.node, draw.primitive);
                            instance
                                .deform_primitive(
                                    asset,
                                    draw.node,
                                    draw.primitive,
                                    &mut scratch.positions,
                                    &mut scratch.normals,
                                )
                                .map_err(failed)?;
                            if gpu.has_tangents {
                                instance
                                    .deform_tangents(
                                        asset,
                                        draw.node,
                                        draw.primitive,
                                        &scratch.positions,
                                        &mut scratch.tangents,
                                    )
                                    .map_err(failed)?;
                                scratch.tangents.iter_mut().for_each(|t| *t = sanitize_tangent(*t));
                            }
                        }
                        scratch.cpu_skin += skin_started.elapsed();
                        if scratch.positions.len() != gpu.vertex_count as usize {
                            return Err(format!(
                                "node {} primitive {}: deformed vertex count differs",
                                draw.node, draw.primitive
                            ));
                        }
                        if let Some(set) = batch_set.as_ref().filter(|_| draw.batched) {
                            let offset = offsets[c];
                            batch.positions.extend(set.vertices.iter().map(|&v| {
                                let p = scratch.positions.get(v as usize).copied().unwrap_or_default();
                                (Vec3::from(p) + offset).to_array()
                            }));
                        }
                        interleave(&scratch.positions, &scratch.normals, &mut scratch.geometry);
                        let storage = kit.is_some();
                        let buffer = draw.deformed[c].get_or_insert_with(|| gpu.deform_buffer(device, storage));
                        queue.write_buffer(buffer, 0, bytemuck::cast_slice(&scratch.geometry));
                        if gpu.has_tangents && scratch.tangents.len() == scratch.positions.len() {
                            let tangents = draw.deformed_tangents[c]
                                .get_or_insert_with(|| gpu.deform_tangent_buffer(device, storage));
                            queue.write_buffer(tangents, 0, bytemuck::cast_slice(&scratch.tangents));
                        }
                        scratch.normals.len() == scratch.positions.len()
                    };
                    (DrawUniform::new(place, 0, has_normals), VertexPath::Static)
                } else if let (true, Some(skin), Some(kit)) = (draw.on_compute, draw.skin, kit) {
                    let base = c as u32 * self.joints + self.skin_base[skin];
                    let skinning = morph(DrawUniform::new(Mat4::IDENTITY, base, gpu.has_normals))
                        .with_skinning(instance.skinning())
                        .with_vertex_count(gpu.vertex_count);
                    let start = (compute_base + c * draws + i) * stride as usize;
                    scratch.draw_bytes[start..start + size_of::<DrawUniform>()]
                        .copy_from_slice(bytemuck::bytes_of(&skinning));
                    let output = draw.deformed[c].get_or_insert_with(|| gpu.deform_buffer(device, true));
                    let tangents_out = draw.deformed_tangents[c].get_or_insert_with(|| {
                        if gpu.has_tangents {
                            gpu.deform_tangent_buffer(device, true)
                        } else {
                            device.create_buffer(&wgpu::BufferDescriptor {
                                label: Some("kloub no deformed tangents"),
                                size: TANGENT_STRIDE,
                                usage: wgpu::BufferUsages::STORAGE,
                                mapped_at_creation: false,
                            })
                        }
                    });
                    if draw.compute_groups[c].is_none() {
                        let (Some(skin_stream), Some(pivots)) = (&gpu.skin, &draw.pivots) else {
                            return Err("a compute-skinned draw lacks its skin streams".into());
                        };
                        draw.compute_groups[c] = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
                            label: Some("kloub compute streams"),
                            layout: &kit.io,
                            entries: &[
                                wgpu::BindGroupEntry { binding: 0, resource: gpu.geometry.as_entire_binding() },
                                wgpu::BindGroupEntry { binding: 1, resource: skin_stream.as_entire_binding() },
                                wgpu::BindGroupEntry { binding: 2, resource: pivots.as_entire_binding() },
                                wgpu::BindGroupEntry { binding: 3, resource: output.as_entire_binding() },
                                wgpu::BindGroupEntry { binding: 4, resource: gpu.tangents.as_entire_binding() },
                                wgpu::BindGroupEntry { binding: 5, resource: tangents_out.as_entire_binding() },
                            ],
                        }));
                    }
                    (DrawUniform::new(place, 0, gpu.has_normals), VertexPath::Static)
                } else if let Some(skin) = draw.skin {
                    let base = c as u32 * self.joints + self.skin_base[skin];
                    let uniform =
                        morph(DrawUniform::new(place, base, gpu.has_normals).with_skinning(instance.skinning()));
                    let uniform = match heatmap {
                        Some(scale) => uniform.with_heatmap(scale * self.diagonal),
                        None => uniform,
                    };
                    let code = skin_code(instance.skinning());
                    method = Some(if method.is_none_or(|m| m == code) { code } else { SKIN_FROM_DRAW });
                    (uniform, VertexPath::Skinned)
                } else {
                    (morph(DrawUniform::new(place * world, 0, gpu.has_normals)), VertexPath::Static)
                };
                let start = (c * draws + i) * stride as usize;
                scratch.draw_bytes[start..start + size_of::<DrawUniform>()]
                    .copy_from_slice(bytemuck::bytes_of(&uniform));
                draw.key = Some(PipelineKey {
                    vertex,
                    topology: topology(source.topology),
                    blend: draw.blend,
                    double_sided: draw.double_sided,
                    mirrored,
                    skinning: method.unwrap_or(SKIN_FROM_DRAW),
                    heatmap: heatmap.is_some(),
                    caster: false,
                    mask: false,
                    tangents: gpu.has_tangents && draw.normal_mapped,
                    textures: draw.textures,
                    ibl,
                });
                if draw.blend {
                    let (min, max) = source.bounds;
                    let center = world.transform_point3(0.5 * (Vec3::from(min) + Vec3::from(max))) + offsets[c];
                    scratch.blend_order.push((-(center - eye).length_squared(), c * draws + i));
                }
            }
        }
        if self.batch.wanted != self.batch.built {
            let (draws, primitives) = (&self.draws, &self.primitives);
            let level = casters.map_or(0, usize::from);
            self.batch.build_indices(device, |i| {
                let draw = draws.get(i)?;
                let gpu = primitives.get(draw.mesh)?.get(draw.primitive)?.as_ref()?;
                gpu.caster_sets.get(level)?.clone()
            });
        }
        self.batch.upload(device, queue);
        scratch.blend_order.sort_by(|a, b| a.0.total_cmp(&b.0));
        if !scratch.draw_bytes.is_empty() {
            queue.write_buffer(&self.draw_buffer, 0, &scratch.draw_bytes);
        }
        scratch.prepare = started.elapsed();
        Ok(())
    }

    /// Records the compute pass that skins every draw prepared for it (nothing when none is).
    fn dispatch_compute(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        kit: &ComputeKit,
        copies: usize,
        stride: u64,
        max_groups: u32,
    ) {
        let Some((textures, draw_group)) = &self.compute else { return };
        if !self.draws.iter().any(|d| d.on_compute) {
            return;
        }
        let draws = self.draws.len();
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("kloub skinning"), timestamp_writes: None });
        pass.set_pipeline(&kit.pipeline);
        pass.set_bind_group(0, textures, &[]);
        pass.set_bind_group(1, &kit.empty_group, &[]);
        for c in 0..copies {
            for (i, draw) in self.draws.iter().enumerate() {
                let group = draw.compute_groups.get(c).and_then(Option::as_ref);
                let vertices =
                    self.primitives.get(draw.mesh).and_then(|m| m.get(draw.primitive)).and_then(Option::as_ref);
                let (true, Some(group), Some(gpu)) = (draw.on_compute, group, vertices) else { continue };
                let groups = gpu.vertex_count.div_ceil(SKIN_WORKGROUP);
                if groups > max_groups {
                    log::warn!("mesh {}: {} vertices exceed one compute dispatch", draw.mesh, gpu.vertex_count);
                    continue;
                }
                let slot = copies * draws + c * draws + i;
                pass.set_bind_group(2, draw_group, &[(slot as u64 * stride) as u32]);
                pass.set_bind_group(3, group, &[]);
                pass.dispatch_workgroups(groups, 1, 1);
            }
        }
    }

    /// Records the copies' gathered shadow casters ([`CasterBatch`]) with `pipeline` (the world
    /// caster's), if any were gathered this frame.
    fn encode_batch(&self, pass: &mut wgpu::RenderPass<'_>, pipeline: &wgpu::RenderPipeline) {
        let batch = &self.batch;
        let (Some(vertices), Some(indices), Some(material)) = (&batch.vertices, &batch.indices, self.materials.first())
        else {
            return;
        };
        if !batch.ready() {
            return;
        }
        pass.set_pipeline(pipeline);
        // The layout's groups, which this vertex shader does not read: any material and slot 0.
        pass.set_bind_group(1, material, &[]);
        pass.set_bind_group(2, &self.draw_bind_group, &[0]);
        pass.set_vertex_buffer(0, vertices.slice(..));
        pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..batch.count, 0, 0..1);
    }

    /// Records the draw slots `slots` (copy `c` of draw `i` is slot `c * draws + i`; those
    /// prepared this frame) for `pass`: the scene, or their shadow casters (into the shadow map).
    fn encode(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        pipelines: &Pipelines,
        slots: impl Iterator<Item = usize>,
        stride: u64,
        kind: Pass,
    ) {
        let caster = kind != Pass::Scene;
        let draws = self.draws.len().max(1);
        for slot in slots {
            let (c, i) = (slot / draws, slot % draws);
            let Some(draw) = self.draws.get(i) else {
                continue;
            };
            if draw.batched && matches!(kind, Pass::SimplifiedCasters { .. }) {
                continue;
            }
            let key = if caster { draw.key.and_then(|k| k.caster(draw.mask)) } else { draw.key };
            let Some(pipeline) = key.as_ref().and_then(|k| pipelines.mesh(k)) else {
                continue;
            };
            let Some(gpu) = self.primitives.get(draw.mesh).and_then(|m| m.get(draw.primitive)).and_then(Option::as_ref)
            else {
                continue;
            };
            let Some(material) = self.materials.get(draw.material) else {
                continue;
            };
            let geometry = if draw.on_cpu || draw.on_compute {
                draw.deformed.get(c).and_then(Option::as_ref)
            } else {
                Some(&gpu.geometry)
            };
            let Some(geometry) = geometry else { continue };
            let tangents = if (draw.on_cpu || draw.on_compute) && gpu.has_tangents {
                draw.deformed_tangents.get(c).and_then(Option::as_ref)
            } else {
                Some(&gpu.tangents)
            };
            let (Some(tangents), Some(vertex)) = (tangents, draw.key.map(|k| k.vertex)) else { continue };
            pass.set_pipeline(pipeline);
            pass.set_bind_group(1, material, &[]);
            // `i * stride` is within the draw buffer sized `draws.len() * stride`.
            pass.set_bind_group(2, &self.draw_bind_group, &[(slot as u64 * stride) as u32]);
            pass.set_vertex_buffer(0, geometry.slice(..));
            pass.set_vertex_buffer(1, gpu.attributes.slice(..));
            pass.set_vertex_buffer(tangent_slot(vertex), tangents.slice(..));
            if vertex == VertexPath::Skinned {
                let (Some(skin), Some(pivots)) = (&gpu.skin, &draw.pivots) else {
                    continue;
                };
                pass.set_vertex_buffer(2, skin.slice(..));
                pass.set_vertex_buffer(3, pivots.slice(..));
            }
            let (indices, count) = caster_list(gpu, kind, draw.mask);
            pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..count, 0, 0..1);
        }
    }
}
