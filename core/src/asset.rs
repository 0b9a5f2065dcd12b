//! The runtime asset: an immutable, validated scene graph with skins, meshes,
//! materials, images and clips, produced by [`crate::import()`].
//!
//! Invariants every consumer may rely on (established by the importer):
//! - every index stored here (node, mesh, skin, material, image, joint) is in range;
//! - [`Asset::order`] lists every node exactly once, parents before children
//!   (the node graph is a forest: no cycles, at most one parent per node);
//! - every vertex attribute of a [`Primitive`] has `vertex_count` entries (or is empty
//!   when absent), every index is `< vertex_count`;
//! - skin weights of every vertex are finite, non-negative and sum to 1;
//!   joint indices are `< skin.joints.len()` of the skin the primitive is drawn with;
//! - every quaternion is unit length and every float is finite.

use crate::clip::Clip;
use crate::math::Transform;
use glam::Mat4;

/// Index of a node in [`Asset::nodes`].
pub type NodeIndex = u32;

/// A whole imported glTF document, ready to animate and draw.
#[derive(Clone, Debug, Default)]
pub struct Asset {
    /// All nodes by glTF index.
    pub nodes: Vec<Node>,
    /// Every node index once, parents before children.
    pub order: Vec<NodeIndex>,
    /// Scenes by glTF index.
    pub scenes: Vec<Scene>,
    /// The scene to show: `scene` from the file, else 0. `None` when the file has no scenes
    /// (then every root node is shown).
    pub default_scene: Option<usize>,
    /// Meshes by glTF index.
    pub meshes: Vec<Mesh>,
    /// Skins by glTF index.
    pub skins: Vec<Skin>,
    /// Materials by glTF index.
    pub materials: Vec<Material>,
    /// Decoded images by glTF image index.
    pub images: Vec<Image>,
    /// Animations by glTF index.
    pub clips: Vec<Clip>,
    /// Start of each node's morph weights in a flat weights array
    /// ([`crate::pose::Pose::weights`]); `weight_offsets[n]..weight_offsets[n] + node.weight_count()`.
    pub weight_offsets: Vec<u32>,
    /// Total length of the flat morph weights array.
    pub weight_total: u32,
    /// The file's `extensionsUsed` and `extensionsRequired`.
    pub extensions: Extensions,
}

/// The glTF extensions a file says it uses (`kloub inspect` lists them).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Extensions {
    /// `extensionsUsed`, in file order.
    pub used: Vec<String>,
    /// `extensionsRequired`, in file order (each one supported: the import refuses the others).
    pub required: Vec<String>,
    /// The buffer views stored compressed, which the importer decoded.
    pub compressed_views: Vec<CompressedView>,
    /// The primitives stored compressed (`KHR_draco_mesh_compression`), which the importer decoded.
    pub compressed_primitives: Vec<CompressedPrimitive>,
}

/// A mesh primitive stored as a Draco stream (`KHR_draco_mesh_compression`), and what decoding
/// it cost.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct CompressedPrimitive {
    /// Index in `meshes`.
    pub mesh: u32,
    /// Index in the mesh's `primitives`.
    pub primitive: u32,
    /// The buffer view holding the stream.
    pub view: u32,
    /// The extension's name.
    pub extension: String,
    /// Bytes of the stream in the file.
    pub compressed_bytes: u64,
    /// Bytes of the accessors it decoded to (charged to the import budget).
    pub decoded_bytes: u64,
    /// Decoded vertices.
    pub points: u64,
    /// Decoded triangles.
    pub triangles: u64,
}

/// A buffer view stored compressed (`EXT_meshopt_compression` or `KHR_meshopt_compression`),
/// and what decoding it cost.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct CompressedView {
    /// Index in `bufferViews`.
    pub view: u32,
    /// The extension's name.
    pub extension: String,
    /// `ATTRIBUTES`, `TRIANGLES` or `INDICES`.
    pub mode: String,
    /// `NONE`, `OCTAHEDRAL`, `QUATERNION`, `EXPONENTIAL` or `COLOR`.
    pub filter: String,
    /// Bytes in the file.
    pub compressed_bytes: u64,
    /// Bytes once decoded (the view's `byteLength`, charged to the import budget).
    pub decoded_bytes: u64,
}

/// One glTF node.
#[derive(Clone, Debug, Default)]
pub struct Node {
    /// `name` from the file.
    pub name: Option<String>,
    /// Parent node, `None` for a root.
    pub parent: Option<NodeIndex>,
    /// Children in file order.
    pub children: Vec<NodeIndex>,
    /// Local transform from the file (`matrix` decomposed, or TRS).
    pub rest: Transform,
    /// Mesh instanced by this node.
    pub mesh: Option<u32>,
    /// Skin deforming that mesh.
    pub skin: Option<u32>,
    /// Default morph weights of this node: `node.weights`, else `mesh.weights`, else zeros;
    /// one per morph target of its mesh (empty without a mesh or targets).
    pub weights: Vec<f32>,
}

/// A scene: a list of root nodes.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// `name` from the file.
    pub name: Option<String>,
    /// Root nodes of the scene.
    pub roots: Vec<NodeIndex>,
}

/// A skin: joints and their inverse bind matrices.
#[derive(Clone, Debug, Default)]
pub struct Skin {
    /// `name` from the file.
    pub name: Option<String>,
    /// Joint nodes; a vertex's joint index `j` means `joints[j]`.
    pub joints: Vec<NodeIndex>,
    /// One per joint (identity when the file has none).
    pub inverse_bind: Vec<Mat4>,
    /// `skeleton` hint from the file.
    pub skeleton: Option<NodeIndex>,
}

/// A mesh: primitives plus default morph weights.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// `name` from the file.
    pub name: Option<String>,
    /// Drawable parts.
    pub primitives: Vec<Primitive>,
    /// `mesh.weights`, or zeros, one per morph target.
    pub weights: Vec<f32>,
    /// Morph target names (`extras.targetNames`) when present.
    pub target_names: Vec<String>,
}

/// Primitive topology. Triangle strips and fans are converted to lists on import.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Topology {
    /// Point list.
    Points,
    /// Line list (line strips and loops are converted).
    Lines,
    /// Triangle list.
    #[default]
    Triangles,
}

/// One drawable primitive, de-indexed nothing: attributes are per vertex, `indices` index them.
#[derive(Clone, Debug, Default)]
pub struct Primitive {
    /// Topology of `indices`.
    pub topology: Topology,
    /// Number of vertices.
    pub vertex_count: u32,
    /// POSITION, always present.
    pub positions: Vec<[f32; 3]>,
    /// NORMAL; empty when absent (the renderer then uses flat normals).
    pub normals: Vec<[f32; 3]>,
    /// TANGENT (xyz + handedness w); empty when absent. Generated (MikkTSpace) on import for a
    /// normal-mapped primitive without them.
    pub tangents: Vec<[f32; 4]>,
    /// Vertices the importer added to the file's, each a copy of this vertex of the file's (the
    /// last `copied_from.len()` vertices): where generated tangents split a vertex. Per-vertex
    /// data in sidecars is numbered without them.
    pub copied_from: Vec<u32>,
    /// TEXCOORD_0; empty when absent.
    pub uv0: Vec<[f32; 2]>,
    /// TEXCOORD_1; empty when absent (textures whose `texCoord` is 1 read it).
    pub uv1: Vec<[f32; 2]>,
    /// COLOR_0 as linear RGBA; empty when absent.
    pub colors: Vec<[f32; 4]>,
    /// Up to 8 influences per vertex (JOINTS_0 then JOINTS_1); unused slots have weight 0.
    /// Empty for an unskinned primitive.
    pub joints: Vec<[u16; 8]>,
    /// Weights matching `joints`, normalized to sum 1.
    pub weights: Vec<[f32; 8]>,
    /// Vertex indices (generated 0..n when the file has none).
    pub indices: Vec<u32>,
    /// Material, `None` for the glTF default material.
    pub material: Option<u32>,
    /// Morph targets (deltas), one per target of the mesh.
    pub targets: Vec<MorphTarget>,
    /// Object-space bounds of `positions` (min, max).
    pub bounds: ([f32; 3], [f32; 3]),
}

impl Primitive {
    /// Whether this primitive carries skinning attributes.
    pub fn is_skinned(&self) -> bool {
        !self.joints.is_empty()
    }

    /// Whether this primitive's TANGENT attribute is used: it has one for every vertex, and
    /// normals too (glTF: without normals, tangents are ignored).
    pub fn has_tangents(&self) -> bool {
        let n = self.positions.len();
        n > 0 && self.tangents.len() == n && self.normals.len() == n
    }
}

/// A morph target: per-vertex deltas. Absent attributes are empty.
#[derive(Clone, Debug, Default)]
pub struct MorphTarget {
    /// POSITION deltas.
    pub positions: Vec<[f32; 3]>,
    /// NORMAL deltas.
    pub normals: Vec<[f32; 3]>,
    /// TANGENT deltas (xyz).
    pub tangents: Vec<[f32; 3]>,
}

/// Alpha handling of a material.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum AlphaMode {
    /// Alpha ignored.
    #[default]
    Opaque,
    /// Alpha below the cutoff is discarded.
    Mask(f32),
    /// Alpha blended.
    Blend,
}

/// `KHR_texture_transform` of a texture reference (identity by default).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureTransform {
    /// UV offset.
    pub offset: [f32; 2],
    /// Rotation in radians.
    pub rotation: f32,
    /// UV scale.
    pub scale: [f32; 2],
}

impl Default for TextureTransform {
    fn default() -> Self {
        Self { offset: [0.0, 0.0], rotation: 0.0, scale: [1.0, 1.0] }
    }
}

impl TextureTransform {
    /// The 3×3 UV matrix (column-major, as glTF's extension defines it).
    pub fn matrix(&self) -> glam::Mat3 {
        let t = glam::Mat3::from_translation(glam::Vec2::from(self.offset));
        let (s, c) = self.rotation.sin_cos();
        let r = glam::Mat3::from_cols(
            glam::Vec3::new(c, -s, 0.0),
            glam::Vec3::new(s, c, 0.0),
            glam::Vec3::new(0.0, 0.0, 1.0),
        );
        let sc = glam::Mat3::from_scale(glam::Vec2::from(self.scale));
        t * r * sc
    }
}

/// A texture reference of a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into [`Asset::images`].
    pub image: u32,
    /// `texCoord` set: 0 or 1 (the importer reads TEXCOORD_0 and TEXCOORD_1; a larger set
    /// is reported and read as 0).
    pub tex_coord: u32,
    /// `KHR_texture_transform`.
    pub transform: TextureTransform,
    /// Sampler wraps/filters: true for repeat, false for clamp (per axis u, v).
    pub repeat: [bool; 2],
    /// Nearest (true) or linear (false) magnification.
    pub nearest: bool,
    /// Minification (the sampler's `minFilter`).
    pub min_filter: MinFilter,
}

/// A sampler's minification filter (glTF's `minFilter`; absent: trilinear).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum MinFilter {
    /// NEAREST (9728): the nearest texel of the full image.
    Nearest,
    /// LINEAR (9729): bilinear in the full image.
    Linear,
    /// NEAREST_MIPMAP_NEAREST (9984).
    NearestMipmapNearest,
    /// LINEAR_MIPMAP_NEAREST (9985).
    LinearMipmapNearest,
    /// NEAREST_MIPMAP_LINEAR (9986).
    NearestMipmapLinear,
    /// LINEAR_MIPMAP_LINEAR (9987), also what an absent `minFilter` draws with.
    #[default]
    LinearMipmapLinear,
}

impl MinFilter {
    /// The filter of a glTF `minFilter` code; `None` for any other number.
    pub fn from_gl(code: u64) -> Option<Self> {
        Some(match code {
            9728 => Self::Nearest,
            9729 => Self::Linear,
            9984 => Self::NearestMipmapNearest,
            9985 => Self::LinearMipmapNearest,
            9986 => Self::NearestMipmapLinear,
            9987 => Self::LinearMipmapLinear,
            _ => return None,
        })
    }

    /// Whether texels within a level are filtered linearly.
    pub fn linear(self) -> bool {
        matches!(self, Self::Linear | Self::LinearMipmapNearest | Self::LinearMipmapLinear)
    }

    /// Whether mip levels are used; and if so whether between them linearly.
    pub fn mipmap(self) -> Option<bool> {
        match self {
            Self::Nearest | Self::Linear => None,
            Self::NearestMipmapNearest | Self::LinearMipmapNearest => Some(false),
            Self::NearestMipmapLinear | Self::LinearMipmapLinear => Some(true),
        }
    }
}

/// A metallic-roughness material (glTF 2.0 core, `KHR_materials_emissive_strength`,
/// `KHR_materials_unlit`, `KHR_texture_transform` on every texture).
#[derive(Clone, Debug)]
pub struct Material {
    /// `name` from the file.
    pub name: Option<String>,
    /// Linear RGBA base colour factor.
    pub base_color: [f32; 4],
    /// Base colour texture (sRGB).
    pub base_color_texture: Option<TextureRef>,
    /// Metallic factor.
    pub metallic: f32,
    /// Roughness factor.
    pub roughness: f32,
    /// Metallic-roughness texture (linear): roughness in G, metallic in B.
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Tangent-space normal texture (linear).
    pub normal_texture: Option<TextureRef>,
    /// `normalTexture.scale`: scales the texture's X and Y.
    pub normal_scale: f32,
    /// Occlusion texture (linear, R).
    pub occlusion_texture: Option<TextureRef>,
    /// `occlusionTexture.strength` (0: no occlusion, 1: full).
    pub occlusion_strength: f32,
    /// Emissive factor (linear RGB).
    pub emissive: [f32; 3],
    /// Emissive texture (sRGB).
    pub emissive_texture: Option<TextureRef>,
    /// `KHR_materials_emissive_strength` (1 without it): multiplies the emissive factor.
    pub emissive_strength: f32,
    /// Alpha mode.
    pub alpha: AlphaMode,
    /// Draw both faces.
    pub double_sided: bool,
    /// `KHR_materials_unlit`.
    pub unlit: bool,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: None,
            base_color: [1.0; 4],
            base_color_texture: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            emissive: [0.0; 3],
            emissive_texture: None,
            emissive_strength: 1.0,
            alpha: AlphaMode::Opaque,
            double_sided: false,
            unlit: false,
        }
    }
}

impl Material {
    /// The texture references in slot order: base colour, metallic-roughness, normal,
    /// occlusion, emissive.
    pub fn textures(&self) -> [Option<TextureRef>; 5] {
        [
            self.base_color_texture,
            self.metallic_roughness_texture,
            self.normal_texture,
            self.occlusion_texture,
            self.emissive_texture,
        ]
    }
}

/// Whether texture slot `slot` of [`Material::textures`] holds colour (sRGB-encoded: base
/// colour, emissive) rather than data (linear: metallic-roughness, normal, occlusion).
pub fn texture_slot_is_srgb(slot: usize) -> bool {
    matches!(slot, 0 | 4)
}

/// An image: decoded to RGBA8 (sRGB-encoded as stored in the file), or still encoded.
#[derive(Clone, Debug, Default)]
pub struct Image {
    /// `name` or URI from the file.
    pub name: Option<String>,
    /// Width in pixels (≥ 1).
    pub width: u32,
    /// Height in pixels (≥ 1).
    pub height: u32,
    /// `width * height * 4` bytes, row-major, top row first; empty while the image is
    /// [`Image::encoded`].
    pub rgba8: Vec<u8>,
    /// The file's bytes, not decoded: imported with
    /// [`crate::import::ImportOptions::decode_images`] off (the browser decodes them).
    /// `width` and `height` are then the header's.
    pub encoded: Option<EncodedImage>,
}

/// An image file as imported, left for the host to decode.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EncodedImage {
    /// Its format, from the file's signature.
    pub format: ImageFormat,
    /// The whole file.
    pub bytes: Vec<u8>,
}

/// An image format the importer reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// PNG.
    Png,
    /// JPEG (baseline or progressive).
    Jpeg,
    /// WebP, lossy or lossless (`EXT_texture_webp`).
    Webp,
}

impl ImageFormat {
    /// Its MIME type.
    pub fn mime(self) -> &'static str {
        match self {
            Self::Png => "image/png",
            Self::Jpeg => "image/jpeg",
            Self::Webp => "image/webp",
        }
    }
}

impl Asset {
    /// Nodes of the default scene (or all roots), each with its whole subtree, in `order`.
    pub fn scene_nodes(&self) -> Vec<NodeIndex> {
        let mut in_scene = vec![false; self.nodes.len()];
        let roots: Vec<NodeIndex> = match self.default_scene.and_then(|s| self.scenes.get(s)) {
            Some(scene) => scene.roots.clone(),
            None => (0..self.nodes.len() as u32).filter(|&n| self.nodes[n as usize].parent.is_none()).collect(),
        };
        for r in roots {
            if let Some(f) = in_scene.get_mut(r as usize) {
                *f = true;
            }
        }
        let mut out = Vec::new();
        for &n in &self.order {
            let node = &self.nodes[n as usize];
            if let Some(p) = node.parent
                && in_scene[p as usize]
            {
                in_scene[n as usize] = true;
            }
            if in_scene[n as usize] {
                out.push(n);
            }
        }
        out
    }

    /// Index of a clip by name, or by its decimal index.
    pub fn find_clip(&self, name_or_index: &str) -> Option<usize> {
        self.clips
            .iter()
            .position(|c| c.name.as_deref() == Some(name_or_index))
            .or_else(|| name_or_index.parse::<usize>().ok().filter(|&i| i < self.clips.len()))
    }
}
