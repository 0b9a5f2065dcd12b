//! CPU mirrors of the uniform structs in `shaders/*.wgsl` (WGSL uniform layout: every
//! field is a 16-byte vector or a matrix, so `repr(C)` matches without padding surprises).

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec2, Vec3};
use kloub_core::asset::{AlphaMode, Material};
use kloub_core::job::dqs::SkinningMethod;

use super::morph::MorphSlot;
use super::pipelines::MATERIAL_TEXTURES;

/// `Frame` in mesh.wgsl and environment.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameUniform {
    /// World to clip.
    pub view_proj: [[f32; 4]; 4],
    /// Eye position (xyz).
    pub camera_pos: [f32; 4],
    /// Unit direction towards the key light (xyz), intensity (w).
    pub light_dir: [f32; 4],
    /// Key light colour.
    pub light_color: [f32; 4],
    /// Hemisphere light from above.
    pub sky_color: [f32; 4],
    /// Hemisphere light from below.
    pub ground_color: [f32; 4],
    /// Ground height, grid cell size, fade radius, half extent of the grid quad.
    pub grid: [f32; 4],
    /// Grid centre (xyz).
    pub grid_center: [f32; 4],
    /// Background colour at the top of the view.
    pub background_top: [f32; 4],
    /// Background colour at the bottom of the view.
    pub background_bottom: [f32; 4],
    /// Exposure (x), tone mapping (y: [`ToneMapping::code`]).
    pub tone: [f32; 4],
    /// The environment's turn (cosine, sine), its intensity (0: none) and specular levels.
    pub environment: [f32; 4],
    /// The environment's irradiance as spherical-harmonic coefficients
    /// ([`super::environment::GpuEnvironment::irradiance`]).
    pub irradiance: [[f32; 4]; 9],
}

/// What the frame uniform says about the environment that lights the meshes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvironmentLight {
    /// Its intensity (0: none, the hemisphere lights instead).
    pub intensity: f32,
    /// Levels of its specular chain.
    pub levels: u32,
    /// Its irradiance ([`super::environment::GpuEnvironment::irradiance`]).
    pub irradiance: [[f32; 4]; 9],
}

impl EnvironmentLight {
    /// No environment: the hemisphere lights.
    pub const NONE: Self = Self { intensity: 0.0, levels: 0, irradiance: [[0.0; 4]; 9] };
}

/// Where the ground grid lies and how dense it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ground {
    /// Height of the ground plane.
    pub height: f32,
    /// Radius of the scene the grid is sized for.
    pub radius: f32,
    /// Centre of the scene (the grid is centred below it).
    pub center: Vec3,
    /// Half the size of the scene's box along each axis (the ground shadow's footprint).
    pub half: Vec3,
}

impl Ground {
    /// Ground under the box `min..max`.
    pub fn under(min: Vec3, max: Vec3) -> Self {
        Self {
            height: min.y,
            radius: (0.5 * (max - min).length()).max(1e-3),
            center: 0.5 * (min + max),
            half: (0.5 * (max - min)).max(Vec3::splat(0.0)),
        }
    }

    /// Grid cell size: a power of ten, about a tenth of the scene radius or finer.
    pub fn cell_size(&self) -> f32 {
        10f32.powf((self.radius * 0.25).log10().floor())
    }
}

impl Default for Ground {
    fn default() -> Self {
        Self { height: 0.0, radius: 1.0, center: Vec3::ZERO, half: Vec3::splat(0.5) }
    }
}

/// How the scene is lit: a key light and a hemisphere (sky above, ground below).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lighting {
    /// A warm key light over the viewer's left shoulder and a soft grey hemisphere.
    #[default]
    Studio,
    /// A bright sun from high up and a blue sky over brown ground.
    Outdoor,
    /// The hemisphere only, evenly bright: textures and vertex colours as authored.
    Flat,
    /// A key light from behind and to the side: silhouettes and rims.
    Rim,
}

impl Lighting {
    /// Every preset, in menu order.
    pub const ALL: [Lighting; 4] = [Lighting::Studio, Lighting::Outdoor, Lighting::Flat, Lighting::Rim];

    /// The page name: `studio`, `outdoor`, `flat`, `rim`.
    pub fn name(self) -> &'static str {
        match self {
            Lighting::Studio => "studio",
            Lighting::Outdoor => "outdoor",
            Lighting::Flat => "flat",
            Lighting::Rim => "rim",
        }
    }

    /// The preset named `name` (see [`Lighting::name`]).
    ///
    /// # Errors
    /// A message naming the accepted values.
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|l| l.name() == name)
            .ok_or_else(|| format!("lighting {name:?}: expected \"studio\", \"outdoor\", \"flat\" or \"rim\""))
    }

    /// The environment this preset lights with, and its intensity.
    pub fn environment(self) -> (super::environment::Procedural, f32) {
        use super::environment::Procedural;
        match self {
            Lighting::Studio => (Procedural::Studio, 1.0),
            Lighting::Outdoor => (Procedural::Outdoor, 1.0),
            Lighting::Flat => (Procedural::Flat, 1.0),
            // The studio, dimmed to the rim preset's dark hemisphere.
            Lighting::Rim => (Procedural::Studio, 0.38),
        }
    }

    /// Key light colour and intensity, sky and ground colours (linear RGB).
    fn colors(self) -> ([f32; 4], f32, [f32; 4], [f32; 4]) {
        match self {
            Lighting::Studio => ([1.0, 0.97, 0.92, 1.0], 0.85, [0.42, 0.44, 0.48, 1.0], [0.14, 0.13, 0.12, 1.0]),
            Lighting::Outdoor => ([1.0, 0.93, 0.8, 1.0], 1.1, [0.35, 0.45, 0.62, 1.0], [0.2, 0.16, 0.11, 1.0]),
            Lighting::Flat => ([1.0, 1.0, 1.0, 1.0], 0.0, [0.95, 0.95, 0.95, 1.0], [0.8, 0.8, 0.8, 1.0]),
            Lighting::Rim => ([0.85, 0.9, 1.0, 1.0], 1.3, [0.16, 0.17, 0.2, 1.0], [0.05, 0.05, 0.05, 1.0]),
        }
    }
}

/// The view's background gradient.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Background {
    /// Near black, lighter at the top.
    #[default]
    Dark,
    /// Mid grey.
    Grey,
    /// Near white.
    Light,
    /// None: what is behind the canvas shows through (the page, as with model-viewer). The
    /// canvas holds premultiplied alpha; the background pass is not drawn.
    Transparent,
}

impl Background {
    /// Every choice, in menu order.
    pub const ALL: [Background; 4] = [Background::Dark, Background::Grey, Background::Light, Background::Transparent];

    /// The page name: `dark`, `grey`, `light`, `transparent`.
    pub fn name(self) -> &'static str {
        match self {
            Background::Dark => "dark",
            Background::Grey => "grey",
            Background::Light => "light",
            Background::Transparent => "transparent",
        }
    }

    /// The background named `name` (see [`Background::name`]).
    ///
    /// # Errors
    /// A message naming the accepted values.
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|b| b.name() == name)
            .ok_or_else(|| format!("background {name:?}: expected \"dark\", \"grey\", \"light\" or \"transparent\""))
    }

    /// Whether the background pass is drawn (not for [`Background::Transparent`]).
    pub fn is_drawn(self) -> bool {
        self != Background::Transparent
    }

    /// Top and bottom colours (linear RGB, alpha).
    fn colors(self) -> ([f32; 4], [f32; 4]) {
        match self {
            Background::Dark => ([0.05, 0.055, 0.065, 1.0], [0.012, 0.013, 0.016, 1.0]),
            Background::Grey => ([0.2, 0.21, 0.22, 1.0], [0.09, 0.095, 0.1, 1.0]),
            Background::Light => ([0.9, 0.9, 0.92, 1.0], [0.62, 0.63, 0.65, 1.0]),
            Background::Transparent => ([0.0; 4], [0.0; 4]),
        }
    }
}

/// How the shaded colour is mapped to the screen's range (model-viewer's `tone-mapping`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ToneMapping {
    /// Khronos PBR Neutral: base colours shown as authored, highlights rolled off.
    #[default]
    Neutral,
    /// ACES filmic (Hill's fit, as three.js and the Khronos sample viewer).
    Aces,
    /// None: the exposed colour clamped to 1.
    None,
}

impl ToneMapping {
    /// Every choice, in menu order.
    pub const ALL: [ToneMapping; 3] = [ToneMapping::Neutral, ToneMapping::Aces, ToneMapping::None];

    /// The page name: `neutral`, `aces`, `none`.
    pub fn name(self) -> &'static str {
        match self {
            ToneMapping::Neutral => "neutral",
            ToneMapping::Aces => "aces",
            ToneMapping::None => "none",
        }
    }

    /// The choice named `name` (see [`ToneMapping::name`]; model-viewer's `auto` is `neutral`,
    /// its `linear` is `none`).
    ///
    /// # Errors
    /// A message naming the accepted values.
    pub fn from_name(name: &str) -> Result<Self, String> {
        match name {
            "auto" => Ok(ToneMapping::Neutral),
            "linear" => Ok(ToneMapping::None),
            _ => Self::ALL
                .into_iter()
                .find(|t| t.name() == name)
                .ok_or_else(|| format!("tone mapping {name:?}: expected \"neutral\", \"aces\" or \"none\"")),
        }
    }

    /// `TONE_*` in shaders/output.wgsl.
    pub fn code(self) -> f32 {
        match self {
            ToneMapping::None => 0.0,
            ToneMapping::Neutral => 1.0,
            ToneMapping::Aces => 2.0,
        }
    }
}

/// The exposures the page may set (model-viewer's `exposure` is any non-negative number; above
/// this everything is white).
pub const MAX_EXPOSURE: f32 = 64.0;

/// Which environment lights the meshes (image-based light).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EnvironmentChoice {
    /// The lighting preset's own ([`Lighting::environment`]).
    #[default]
    Preset,
    /// One of the page's names (made in code, or a photograph), at intensity 1.
    Named(super::environment::EnvironmentName),
    /// The image given to the renderer ([`super::scene::SceneRenderer::set_environment_image`]),
    /// at intensity 1.
    Image,
}

impl EnvironmentChoice {
    /// `data-environment`: `""` for the preset's own, a name, or `"image"`.
    pub fn name(self) -> &'static str {
        match self {
            EnvironmentChoice::Preset => "",
            EnvironmentChoice::Named(name) => name.name(),
            EnvironmentChoice::Image => "image",
        }
    }
}

/// Lighting, background, environment, exposure and tone mapping together: the look of the view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Look {
    /// The lights.
    pub lighting: Lighting,
    /// The background.
    pub background: Background,
    /// Multiplies the shaded colour before tone mapping (1: as lit; 0..=[`MAX_EXPOSURE`]).
    pub exposure: f32,
    /// The tone mapping.
    pub tone_mapping: ToneMapping,
    /// The environment.
    pub environment: EnvironmentChoice,
    /// The environment's turn about +Y, radians (counter-clockwise seen from above).
    pub environment_rotation: f32,
    /// The ground shadow's darkness, 0 (none: no shadow pass) to 1 (model-viewer's
    /// `shadow-intensity`).
    pub shadow_intensity: f32,
    /// The ground shadow's blur, 0 (sharp) to 1 (model-viewer's `shadow-softness`).
    pub shadow_softness: f32,
}

/// The ground shadow's default darkness.
pub const DEFAULT_SHADOW_INTENSITY: f32 = 0.6;

/// `Shadow` in environment.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ShadowUniform {
    /// World to the shadow map's clip space.
    pub light_view_proj: [[f32; 4]; 4],
    /// Intensity, filter radius in texels, 1 / map size.
    pub params: [f32; 4],
    /// The quad on the ground: centre x, z and half sizes along x, z.
    pub quad: [f32; 4],
}

impl ShadowUniform {
    /// The shadow of a character standing on `ground` (with copies out to `extent` from it),
    /// cast along `light` (towards the light; tilted halfway to straight down, so the shadow
    /// stays under the character; straight down for a light from below the horizon), into a
    /// map of `size` texels, as `look` asks.
    pub fn new(ground: &Ground, light: Vec3, extent: f32, size: u32, look: &Look) -> Self {
        let center = Vec3::new(ground.center.x, ground.height, ground.center.z);
        let radius = ground.radius * 1.5 + extent;
        let toward =
            if light.y > 0.05 { (light.normalize_or(Vec3::Y) + Vec3::Y).normalize_or(Vec3::Y) } else { Vec3::Y };
        let eye = center + toward * radius * 3.0;
        let up = if toward.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
        let view = glam::camera::rh::view::look_at_mat4(eye, center, up);
        // The quad covers where the scene's box (with its copies) can throw its shadow: the box's
        // footprint and the footprint moved along the light by the box's height, grown by a
        // quarter for the animation, which the rest pose's box does not hold.
        let top = (ground.center.y + ground.half.y - ground.height).max(0.0);
        let reach = Vec2::new(toward.x, toward.z) * (top / toward.y.max(0.05));
        let half = Vec2::new(ground.half.x, ground.half.z) * 1.25 + Vec2::splat(extent + 0.1 * ground.radius);
        let footprint = Vec2::new(ground.center.x, ground.center.z);
        let (lo, hi) =
            ((footprint - half).min(footprint - half - reach), (footprint + half).max(footprint + half - reach));
        let (quad_center, quad_half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let projection =
            glam::camera::rh::proj::directx::orthographic(-radius, radius, -radius, radius, 0.0, radius * 6.0);
        Self {
            light_view_proj: (projection * view).to_cols_array_2d(),
            params: [
                look.shadow_intensity.clamp(0.0, 1.0),
                0.5 + 3.5 * look.shadow_softness.clamp(0.0, 1.0),
                1.0 / size.max(1) as f32,
                0.0,
            ],
            quad: [quad_center.x, quad_center.y, quad_half.x, quad_half.y],
        }
    }

    /// World to the shadow map's clip space.
    pub fn view_proj(&self) -> Mat4 {
        Mat4::from_cols_array_2d(&self.light_view_proj)
    }
}

impl Default for Look {
    fn default() -> Self {
        Self {
            lighting: Lighting::default(),
            background: Background::default(),
            exposure: 1.0,
            tone_mapping: ToneMapping::default(),
            environment: EnvironmentChoice::default(),
            environment_rotation: 0.0,
            shadow_intensity: DEFAULT_SHADOW_INTENSITY,
            shadow_softness: 1.0,
        }
    }
}

impl FrameUniform {
    /// Frame constants for a camera (`view_proj`, `eye`) over `ground`. The key light comes
    /// from above, over the viewer's left shoulder, so the lit side always faces the camera.
    /// Lit and cleared as `look` says (the key light follows the camera, except the sun), the
    /// meshes' ambient light from `environment` (intensity 0: none, the hemisphere instead).
    pub fn new(
        view_proj: Mat4,
        eye: Vec3,
        target: Vec3,
        ground: &Ground,
        look: Look,
        environment: EnvironmentLight,
    ) -> Self {
        let forward = (target - eye).normalize_or(Vec3::NEG_Z);
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        let light = match look.lighting {
            Lighting::Outdoor => Vec3::new(0.35, 1.0, 0.25).normalize_or(Vec3::Y),
            Lighting::Rim => (forward * 0.8 + right * 0.5 + Vec3::Y * 0.35).normalize_or(Vec3::Y),
            Lighting::Studio | Lighting::Flat => (-forward * 0.6 - right * 0.45 + Vec3::Y * 0.9).normalize_or(Vec3::Y),
        };
        let (light_color, intensity, sky, ground_color) = look.lighting.colors();
        let (top, bottom) = look.background.colors();
        let fade = ground.radius * 8.0;
        Self {
            view_proj: view_proj.to_cols_array_2d(),
            camera_pos: eye.extend(1.0).to_array(),
            light_dir: light.extend(intensity).to_array(),
            light_color,
            sky_color: sky,
            ground_color,
            grid: [ground.height, ground.cell_size(), fade, fade],
            grid_center: [ground.center.x, ground.height, ground.center.z, 0.0],
            background_top: top,
            background_bottom: bottom,
            tone: [look.exposure, look.tone_mapping.code(), 0.0, 0.0],
            environment: {
                let (s, c) = look.environment_rotation.sin_cos();
                [c, s, environment.intensity, environment.levels as f32]
            },
            irradiance: environment.irradiance,
        }
    }

    /// The clear colour matching the bottom of `background`'s gradient.
    /// In `format`: linear for an sRGB target, sRGB-encoded for `Rgba8Unorm` (what the shaders
    /// write there; see `SceneRenderer::with_format`).
    pub fn clear_color(background: Background, format: wgpu::TextureFormat) -> wgpu::Color {
        let bottom = background.colors().1;
        let encode = |c: f32| {
            let c = f64::from(c);
            if format.is_srgb() {
                c
            } else if c <= 0.003_130_8 {
                c * 12.92
            } else {
                1.055 * c.powf(1.0 / 2.4) - 0.055
            }
        };
        wgpu::Color { r: encode(bottom[0]), g: encode(bottom[1]), b: encode(bottom[2]), a: f64::from(bottom[3]) }
    }
}

/// `Material` in mesh.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct MaterialUniform {
    /// Base colour factor.
    pub base_color: [f32; 4],
    /// Emissive factor times its strength (rgb) and alpha cutoff (w).
    pub emissive: [f32; 4],
    /// Metallic, roughness, normal scale, occlusion strength.
    pub pbr: [f32; 4],
    /// Flags (x), texCoord-1 bits per texture slot (y).
    pub flags: [u32; 4],
    /// Per texture slot, its UV matrix: columns 0 and 1 (xy each), then column 2 (xy).
    pub uv: [[f32; 4]; 2 * MATERIAL_TEXTURES],
}

/// `MATERIAL_UNLIT` in mesh.wgsl.
const MATERIAL_UNLIT: u32 = 1;
/// `MATERIAL_ALPHA_MASK` in mesh.wgsl.
const MATERIAL_ALPHA_MASK: u32 = 2;
/// `MATERIAL_ALPHA_BLEND` in mesh.wgsl.
const MATERIAL_ALPHA_BLEND: u32 = 4;
/// `MATERIAL_METALLIC_ROUGHNESS_TEXTURE` in mesh.wgsl; the normal, occlusion and emissive
/// textures' flags follow it (one bit per texture slot after the base colour's).
const MATERIAL_METALLIC_ROUGHNESS_TEXTURE: u32 = 8;

/// Which optional textures `material` has, a bit each after the base colour's: metallic-roughness
/// 1, normal 2, occlusion 4, emissive 8. Shifted up by 3 they are its uniform's
/// `MATERIAL_*_TEXTURE` flags; as they are, the textures its pipelines compile in (`TEXTURES` in
/// mesh.wgsl, [`super::pipelines::PipelineKey::textures`]).
pub fn optional_textures(material: &Material) -> u8 {
    material.textures().iter().skip(1).enumerate().fold(0, |bits, (i, t)| bits | (u8::from(t.is_some()) << i))
}

impl MaterialUniform {
    /// The uniform of a glTF material.
    pub fn new(material: &Material) -> Self {
        let (mut flags, cutoff) = match material.alpha {
            AlphaMode::Opaque => (0, 0.0),
            AlphaMode::Mask(cutoff) => (MATERIAL_ALPHA_MASK, cutoff),
            AlphaMode::Blend => (MATERIAL_ALPHA_BLEND, 0.0),
        };
        if material.unlit {
            flags |= MATERIAL_UNLIT;
        }
        let mut uv = [[0.0; 4]; 2 * MATERIAL_TEXTURES];
        let mut sets = 0;
        for (slot, texture) in material.textures().iter().enumerate() {
            let m = texture.map(|t| t.transform.matrix()).unwrap_or(glam::Mat3::IDENTITY);
            uv[2 * slot] = [m.x_axis.x, m.x_axis.y, m.y_axis.x, m.y_axis.y];
            uv[2 * slot + 1] = [m.z_axis.x, m.z_axis.y, 0.0, 0.0];
            if texture.is_some_and(|t| t.tex_coord == 1) {
                sets |= 1 << slot;
            }
        }
        flags |= u32::from(optional_textures(material)) * MATERIAL_METALLIC_ROUGHNESS_TEXTURE;
        let e = material.emissive.map(|c| c * material.emissive_strength);
        Self {
            base_color: material.base_color,
            emissive: [e[0], e[1], e[2], cutoff],
            pbr: [material.metallic, material.roughness, material.normal_scale, material.occlusion_strength],
            flags: [flags, sets, 0, 0],
            uv,
        }
    }
}

/// `Draw` in mesh.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct DrawUniform {
    /// Object to world.
    pub model: [[f32; 4]; 4],
    /// Inverse transpose of `model`.
    pub normal_matrix: [[f32; 4]; 4],
    /// First palette joint, flags, skinning method, capture target size.
    pub params: [u32; 4],
    /// Morph slot: first texel, target count, vertex count, normal deltas.
    pub morph: [u32; 4],
    /// Morph weights, four per element.
    pub weights: [[f32; 4]; 16],
    /// Deviation heatmap: x = the distance drawn fully red.
    pub heat: [f32; 4],
}

/// `DRAW_HAS_NORMALS` in mesh.wgsl.
const DRAW_HAS_NORMALS: u32 = 1;
/// `DRAW_HEATMAP` in mesh.wgsl.
const DRAW_HEATMAP: u32 = 2;

/// The `SKIN_*` constant of mesh.wgsl for `method`.
pub fn skin_code(method: SkinningMethod) -> u32 {
    match method {
        SkinningMethod::Rigid => 0,
        SkinningMethod::Linear => 1,
        SkinningMethod::DualQuaternion => 2,
        // The examples' offsets come in as morph deltas: the shader's part is SJB's.
        SkinningMethod::SphericalJointBlend | SkinningMethod::SphericalJointBlendByExample => 3,
    }
}

impl DrawUniform {
    /// A draw with object-to-world `model`, its skin's first palette joint, and whether its
    /// vertices carry normals (no morphing, linear blend skinning).
    pub fn new(model: Mat4, joint_base: u32, has_normals: bool) -> Self {
        let normal = model.inverse().transpose();
        let mut normal = if normal.is_finite() { normal } else { Mat4::IDENTITY };
        // The fourth column is unused by normals (w = 0): it carries the sign a mirroring model
        // matrix gives the bitangent (mesh.wgsl's `world_tangent`).
        normal.w_axis = glam::Vec4::new(0.0, 0.0, 0.0, if model.determinant() < 0.0 { -1.0 } else { 1.0 });
        Self {
            model: model.to_cols_array_2d(),
            normal_matrix: normal.to_cols_array_2d(),
            params: [joint_base, if has_normals { DRAW_HAS_NORMALS } else { 0 }, skin_code(SkinningMethod::Linear), 0],
            morph: [0; 4],
            weights: [[0.0; 4]; 16],
            heat: [0.0; 4],
        }
    }

    /// Skins with `method` in the vertex shader.
    pub fn with_skinning(mut self, method: SkinningMethod) -> Self {
        self.params[2] = skin_code(method);
        self
    }

    /// Applies the morph targets in `slot` with `weights` (extra weights are ignored).
    pub fn with_morph(mut self, slot: MorphSlot, weights: &[f32]) -> Self {
        self.morph = [slot.base, slot.targets, slot.vertices, slot.flags()];
        for (i, &w) in weights.iter().take(slot.targets as usize).take(64).enumerate() {
            self.weights[i / 4][i % 4] = w;
        }
        self
    }

    /// Colours the skinned vertices by their distance from another method's result: blue at
    /// zero, red at `full_scale` (a skinned draw in the vertex shader only).
    pub fn with_heatmap(mut self, full_scale: f32) -> Self {
        self.params[1] |= DRAW_HEATMAP;
        self.heat[0] = full_scale;
        self
    }

    /// The vertex count a compute dispatch covers (`cs_skin` in skin_compute.wgsl).
    pub fn with_vertex_count(mut self, vertices: u32) -> Self {
        self.params[3] = vertices;
        self
    }

    /// Places vertex `i` of a capture draw on pixel `(i % width, i / width)`.
    pub fn with_capture_size(mut self, width: u32, height: u32) -> Self {
        self.params[3] = (width & 0xffff) | (height << 16);
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_are_multiples_of_16() {
        for size in [size_of::<FrameUniform>(), size_of::<MaterialUniform>(), size_of::<DrawUniform>()] {
            assert_eq!(size % 16, 0);
        }
    }

    #[test]
    fn grid_cell_is_a_power_of_ten() {
        let ground = Ground::under(Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 1.8, 0.5));
        assert!((ground.cell_size() - 0.1).abs() < 1e-6);
    }

    #[test]
    fn singular_model_gets_identity_normals() {
        let u = DrawUniform::new(Mat4::ZERO, 0, true);
        assert_eq!(u.normal_matrix, Mat4::IDENTITY.to_cols_array_2d());
    }
}
