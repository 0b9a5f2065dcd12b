//! GPU copies of a primitive's vertex streams (see [`super::pipelines`] for their layouts).

use bytemuck::{Pod, Zeroable};
use kloub_core::asset::Primitive;
use kloub_core::job::sjb::{NO_PIVOT, SjbPlan};
use wgpu::util::DeviceExt;

/// One vertex of the geometry stream.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GeometryVertex {
    /// Position.
    pub position: [f32; 3],
    /// Normal (zero when the primitive has none).
    pub normal: [f32; 3],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct AttributeVertex {
    uv: [f32; 2],
    uv1: [f32; 2],
    color: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct SkinVertex {
    joints: [u16; 8],
    weights: [f32; 8],
}

/// One vertex of the spherical-joint-blend stream (per draw: it depends on the skin).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct PivotVertex {
    pivot: [f32; 3],
    /// Carrying joint | driver joint << 16, or `NO_PIVOT`.
    joints: u32,
}

/// Byte stride of the spherical-joint-blend stream: the joint centre (`f32x3`) and its
/// joints (`u32`).
pub const PIVOT_STRIDE: u64 = size_of::<PivotVertex>() as u64;

/// The spherical-joint-blend stream of a draw of `vertices` vertices, its contents still to be
/// written ([`write_pivots`], when a copy first chooses a method that reads it): a model shown
/// with another method never builds its plan. Read before, it holds zeros.
pub fn pivot_buffer(device: &wgpu::Device, vertices: usize, storage: bool) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("kloub skin pivots"),
        size: PIVOT_STRIDE * vertices.max(1) as u64,
        usage: stream_usage(storage) | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Writes the per-vertex joint centres of `plan` into `buffer` ([`pivot_buffer`] of `vertices`;
/// vertices past the plan fall back to dual quaternions).
pub fn write_pivots(queue: &wgpu::Queue, buffer: &wgpu::Buffer, plan: &SjbPlan, vertices: usize) {
    let data: Vec<PivotVertex> = (0..vertices.max(1))
        .map(|v| {
            let pivot = plan.vertex_pivots.get(v).and_then(|&i| plan.pivots.get(i as usize));
            match pivot {
                Some(p) => PivotVertex { pivot: p.bind, joints: u32::from(p.joint) | (u32::from(p.driver) << 16) },
                None => PivotVertex { pivot: [0.0; 3], joints: NO_PIVOT },
            }
        })
        .collect();
    queue.write_buffer(buffer, 0, bytemuck::cast_slice(&data));
}

/// Byte stride of the geometry stream: position, normal (`f32x3` each). Skinned on the CPU,
/// this is the stream rewritten every frame.
pub const GEOMETRY_STRIDE: u64 = size_of::<GeometryVertex>() as u64;
/// Byte stride of the attribute stream: uv sets 0 and 1 (`f32x2` each), colour (`f32x4`).
pub const ATTRIBUTE_STRIDE: u64 = size_of::<AttributeVertex>() as u64;
/// Byte stride of the skin stream: 8 joints (`u16`), 8 weights (`f32`).
pub const SKIN_STRIDE: u64 = size_of::<SkinVertex>() as u64;
/// Byte stride of the tangent stream: the tangent (`f32x3`) and the bitangent's sign (`f32`).
pub const TANGENT_STRIDE: u64 = 16;

/// The tangent stream of `primitive`: its TANGENT attribute where it is used
/// ([`Primitive::has_tangents`]), each sign made ±1 and non-finite directions zero (the
/// fragment shader derives a frame there); `None` when unused.
pub fn tangents(primitive: &Primitive) -> Option<Vec<[f32; 4]>> {
    primitive.has_tangents().then(|| primitive.tangents.iter().copied().map(sanitize_tangent).collect())
}

/// A tangent as the shader reads it: a finite direction (else zero) and a sign of ±1.
pub fn sanitize_tangent([x, y, z, w]: [f32; 4]) -> [f32; 4] {
    let sign = if w < 0.0 { -1.0 } else { 1.0 };
    if x.is_finite() && y.is_finite() && z.is_finite() { [x, y, z, sign] } else { [0.0, 0.0, 0.0, sign] }
}

/// Interleaves positions and normals (zeros where normals are missing) into `out`.
pub fn interleave(positions: &[[f32; 3]], normals: &[[f32; 3]], out: &mut Vec<GeometryVertex>) {
    out.clear();
    out.extend(
        positions
            .iter()
            .enumerate()
            .map(|(i, &position)| GeometryVertex { position, normal: normals.get(i).copied().unwrap_or_default() }),
    );
}

/// The largest index list a primitive's casters are gathered for ([`GpuPrimitive::caster_sets`]):
/// bigger ones draw on their own, as a sharp shadow's do.
pub const BATCHED_CASTER_MAX_INDICES: usize = 3 << 16;

/// A shadow caster's triangles over the vertices they use: `vertices` lists those (indices into
/// the primitive's, ascending, each once) and `indices` the triangles as positions in that list.
#[derive(Debug, Default, PartialEq)]
pub struct CasterSet {
    pub vertices: Vec<u32>,
    pub indices: Vec<u32>,
}

impl CasterSet {
    /// The triangles of `indices` over a primitive of `vertex_count` vertices; `None` when an
    /// index is out of range.
    pub fn new(indices: &[u32], vertex_count: usize) -> Option<Self> {
        let mut slot = vec![u32::MAX; vertex_count];
        let mut used: Vec<u32> = Vec::new();
        for &i in indices {
            if *slot.get(i as usize)? == u32::MAX {
                slot[i as usize] = 0;
                used.push(i);
            }
        }
        used.sort_unstable();
        for (k, &v) in used.iter().enumerate() {
            slot[v as usize] = k as u32;
        }
        let indices = indices.iter().map(|&i| slot[i as usize]).collect();
        Some(Self { vertices: used, indices })
    }
}

/// A primitive's buffers on the GPU (a clone is the same buffers).
#[derive(Clone)]
pub struct GpuPrimitive {
    /// Rest positions and normals.
    pub geometry: wgpu::Buffer,
    /// UV sets 0 and 1 and colours.
    pub attributes: wgpu::Buffer,
    /// Joints and weights, for skinned primitives.
    pub skin: Option<wgpu::Buffer>,
    /// Rest tangents ([`TANGENT_STRIDE`]); zeros where the primitive has none.
    pub tangents: wgpu::Buffer,
    /// Whether the tangent stream holds the primitive's tangents.
    pub has_tangents: bool,
    /// `u32` indices.
    pub indices: wgpu::Buffer,
    /// Number of indices.
    pub index_count: u32,
    /// The triangles a soft ground shadow's casters draw instead, and their numbers of indices:
    /// the primitive clustered on [`kloub_core::simplify::SHADOW_CELLS`] and on
    /// [`kloub_core::simplify::COARSE_SHADOW_CELLS`] cells (the same vertices); `None` where that
    /// saves little ([`kloub_core::simplify::cluster_triangles`]). Alpha-masked materials' casters
    /// never draw them (see `caster_list` in `scene.rs`).
    pub caster_indices: [Option<(wgpu::Buffer, u32)>; 2],
    /// The same two levels' triangles on the CPU, over only the vertices they use, for
    /// gathering every copy's casters into one draw (`CasterBatch` in `scene.rs`); the whole
    /// primitive's where a level has no list of its own (one set for both levels when neither
    /// has). `None` where that level's list is over [`BATCHED_CASTER_MAX_INDICES`] indices (or names a
    /// vertex the primitive lacks).
    pub caster_sets: [Option<std::sync::Arc<CasterSet>>; 2],
    /// Number of vertices.
    pub vertex_count: u32,
    /// Whether the primitive has normals (else the fragment shader makes flat ones).
    pub has_normals: bool,
}

impl GpuPrimitive {
    /// Uploads `primitive`; `None` when it has nothing to draw. With `storage`, the geometry
    /// and skin streams are also readable by the compute skinning pass.
    pub fn new(device: &wgpu::Device, primitive: &Primitive, storage: bool) -> Option<Self> {
        let n = primitive.positions.len();
        if n == 0 || primitive.indices.is_empty() {
            return None;
        }
        let mut geometry = Vec::new();
        interleave(&primitive.positions, &primitive.normals, &mut geometry);
        let attributes: Vec<AttributeVertex> = (0..n)
            .map(|i| AttributeVertex {
                uv: primitive.uv0.get(i).copied().unwrap_or_default(),
                uv1: primitive.uv1.get(i).copied().unwrap_or_default(),
                color: primitive.colors.get(i).copied().unwrap_or([1.0; 4]),
            })
            .collect();
        let skin = primitive.is_skinned().then(|| {
            let skin: Vec<SkinVertex> = (0..n)
                .map(|i| SkinVertex {
                    joints: primitive.joints.get(i).copied().unwrap_or_default(),
                    weights: primitive.weights.get(i).copied().unwrap_or_default(),
                })
                .collect();
            buffer(device, "kloub skin", bytemuck::cast_slice(&skin), stream_usage(storage))
        });
        let has_normals = primitive.normals.len() == n;
        let tangent_data = tangents(primitive);
        let has_tangents = tangent_data.is_some();
        let tangents = match tangent_data {
            Some(t) => buffer(device, "kloub tangents", bytemuck::cast_slice(&t), stream_usage(storage)),
            // Zeros: a new buffer is zero-initialized.
            None => device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("kloub no tangents"),
                size: n as u64 * TANGENT_STRIDE,
                usage: stream_usage(storage),
                mapped_at_creation: false,
            }),
        };
        let lists = [kloub_core::simplify::SHADOW_CELLS, kloub_core::simplify::COARSE_SHADOW_CELLS]
            .map(|cells| kloub_core::simplify::cluster_triangles(primitive, cells).filter(|l| !l.is_empty()));
        let set = |list: &[u32]| {
            (list.len() <= BATCHED_CASTER_MAX_INDICES)
                .then(|| CasterSet::new(list, n))
                .flatten()
                .map(std::sync::Arc::new)
        };
        let whole = lists.iter().any(Option::is_none).then(|| set(&primitive.indices)).flatten();
        let caster_sets = lists.each_ref().map(|list| match list {
            Some(list) => set(list),
            None => whole.clone(),
        });
        let caster_indices = lists.map(|list| {
            list.map(|simplified| {
                let count = simplified.len() as u32;
                let contents = bytemuck::cast_slice(&simplified);
                (buffer(device, "kloub caster indices", contents, wgpu::BufferUsages::INDEX), count)
            })
        });
        Some(Self {
            geometry: buffer(device, "kloub geometry", bytemuck::cast_slice(&geometry), stream_usage(storage)),
            attributes: buffer(
                device,
                "kloub attributes",
                bytemuck::cast_slice(&attributes),
                wgpu::BufferUsages::VERTEX,
            ),
            skin,
            tangents,
            has_tangents,
            indices: buffer(
                device,
                "kloub indices",
                bytemuck::cast_slice(&primitive.indices),
                wgpu::BufferUsages::INDEX,
            ),
            index_count: primitive.indices.len() as u32,
            caster_indices,
            caster_sets,
            vertex_count: n as u32,
            has_normals,
        })
    }

    /// A geometry-stream buffer for vertices deformed every frame: written by the CPU, or with
    /// `storage` also by the compute skinning pass (and readable back).
    pub fn deform_buffer(&self, device: &wgpu::Device, storage: bool) -> wgpu::Buffer {
        let mut usage = wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST;
        if storage {
            usage |= wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        }
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("kloub deformed geometry"),
            size: u64::from(self.vertex_count) * GEOMETRY_STRIDE,
            usage,
            mapped_at_creation: false,
        })
    }

    /// A tangent-stream buffer for tangents deformed every frame (by the CPU, or with `storage`
    /// also by the compute skinning pass).
    pub fn deform_tangent_buffer(&self, device: &wgpu::Device, storage: bool) -> wgpu::Buffer {
        let mut usage = wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST;
        if storage {
            usage |= wgpu::BufferUsages::STORAGE;
        }
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("kloub deformed tangents"),
            size: u64::from(self.vertex_count) * TANGENT_STRIDE,
            usage,
            mapped_at_creation: false,
        })
    }
}

/// Vertex usage, plus storage for the compute pass when `storage`.
fn stream_usage(storage: bool) -> wgpu::BufferUsages {
    if storage { wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE } else { wgpu::BufferUsages::VERTEX }
}

fn buffer(device: &wgpu::Device, label: &str, contents: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
}
