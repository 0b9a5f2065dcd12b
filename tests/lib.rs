//! Cross-crate tests live in `tests/*.rs` beside this file; this library only hosts shared helpers.

use std::path::PathBuf;

/// The repository root.
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `tests/assets` in the repository (the test asset library), overridable with `KLOUB_SHARED_ASSETS`.
pub fn shared_assets() -> PathBuf {
    std::env::var_os("KLOUB_SHARED_ASSETS").map(PathBuf::from).unwrap_or_else(|| repo_root().join("tests/assets"))
}

/// Procedural material test scenes (issue 23's reference set): made in code, so a test needs no
/// file and every renderer sees exactly the same geometry, factors and texels.
pub mod materials {
    use kloub_core::asset::{Asset, Image, Material, Mesh, Node, Primitive, Scene, TextureRef, TextureTransform};

    /// Columns of the sphere grid (metallic 0 → 1, left to right) and rows (roughness 0 → 1,
    /// top to bottom).
    pub const GRID: usize = 5;

    /// A UV sphere of `radius` at `center`: positions, normals, uvs (u around from −Z, v from
    /// the top), counter-clockwise triangles seen from outside.
    fn sphere(center: [f32; 3], radius: f32, segments: usize, rings: usize) -> Primitive {
        let mut p = Primitive::default();
        for r in 0..=rings {
            let v = r as f32 / rings as f32;
            let theta = v * std::f32::consts::PI;
            for s in 0..=segments {
                let u = s as f32 / segments as f32;
                let phi = u * std::f32::consts::TAU;
                let n = [-theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos()];
                p.positions.push([center[0] + radius * n[0], center[1] + radius * n[1], center[2] + radius * n[2]]);
                p.normals.push(n);
                p.uv0.push([u, v]);
            }
        }
        let row = segments as u32 + 1;
        for r in 0..rings as u32 {
            for s in 0..segments as u32 {
                let (a, b) = (r * row + s, (r + 1) * row + s);
                p.indices.extend([a, b, a + 1, a + 1, b, b + 1]);
            }
        }
        finish(p)
    }

    fn finish(mut p: Primitive) -> Primitive {
        p.vertex_count = p.positions.len() as u32;
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for q in &p.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(q[k]);
                hi[k] = hi[k].max(q[k]);
            }
        }
        p.bounds = (lo, hi);
        p
    }

    /// One node showing `primitives` (one mesh) with `materials` and `images`.
    fn scene_of(name: &str, primitives: Vec<Primitive>, materials: Vec<Material>, images: Vec<Image>) -> Asset {
        Asset {
            nodes: vec![Node { name: Some(name.to_owned()), mesh: Some(0), ..Node::default() }],
            order: vec![0],
            scenes: vec![Scene { name: Some(name.to_owned()), roots: vec![0] }],
            default_scene: Some(0),
            meshes: vec![Mesh { name: Some(name.to_owned()), primitives, ..Mesh::default() }],
            materials,
            images,
            weight_offsets: vec![0],
            ..Asset::default()
        }
    }

    /// A 5×5 grid of spheres in the XY plane facing +Z: metallic grows to the right, roughness
    /// downwards, one base colour (a light copper) for all.
    pub fn sphere_grid() -> Asset {
        let mut primitives = Vec::new();
        let mut materials = Vec::new();
        for row in 0..GRID {
            for col in 0..GRID {
                let metallic = col as f32 / (GRID - 1) as f32;
                let roughness = row as f32 / (GRID - 1) as f32;
                let center = [col as f32 * 1.1 - 2.2, 2.2 - row as f32 * 1.1, 0.0];
                let mut p = sphere(center, 0.5, 48, 24);
                p.material = Some(materials.len() as u32);
                primitives.push(p);
                materials.push(Material {
                    name: Some(format!("metallic {metallic} roughness {roughness}")),
                    base_color: [0.95, 0.64, 0.54, 1.0],
                    metallic,
                    roughness,
                    ..Material::default()
                });
            }
        }
        scene_of("Sphere grid", primitives, materials, Vec::new())
    }

    /// Texels of the bump map: `BUMPS` × `BUMPS` round bumps, each a spherical cap, as a
    /// tangent-space normal map (+X right, +Y up in the image, as glTF defines it).
    pub const BUMPS: usize = 4;
    /// The normal map's size in texels.
    pub const BUMP_TEXELS: u32 = 128;

    /// The bump map's normal at texel centre (x, y) (y down the image): +Y of the result is up.
    pub fn bump_normal(x: u32, y: u32) -> [f32; 3] {
        let cell = BUMP_TEXELS as f32 / BUMPS as f32;
        let u = ((x as f32 + 0.5) % cell) / cell * 2.0 - 1.0;
        let v = -(((y as f32 + 0.5) % cell) / cell * 2.0 - 1.0);
        let r2 = u * u + v * v;
        if r2 >= 0.64 {
            return [0.0, 0.0, 1.0];
        }
        // A cap of a sphere of radius 0.8 (in cell units): its normal is the point itself.
        let z = (0.64 - r2).sqrt();
        let len = (r2 + z * z).sqrt();
        [u / len, v / len, z / len]
    }

    /// A unit quad in the XY plane facing +Z with a bump normal map over a grey dielectric;
    /// uv (0, 0) at its top left, as glTF's images are.
    pub fn normal_mapped_plane() -> Asset {
        let mut p = Primitive {
            positions: vec![[-0.5, 0.5, 0.0], [-0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [0.5, 0.5, 0.0]],
            normals: vec![[0.0, 0.0, 1.0]; 4],
            uv0: vec![[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]],
            indices: vec![0, 1, 2, 0, 2, 3],
            material: Some(0),
            ..Primitive::default()
        };
        p = finish(p);
        let mut rgba8 = Vec::with_capacity((BUMP_TEXELS * BUMP_TEXELS * 4) as usize);
        for y in 0..BUMP_TEXELS {
            for x in 0..BUMP_TEXELS {
                let n = bump_normal(x, y);
                rgba8.extend(n.map(|c| ((c * 0.5 + 0.5) * 255.0).round() as u8));
                rgba8.push(255);
            }
        }
        let image = Image { name: Some("bumps".into()), width: BUMP_TEXELS, height: BUMP_TEXELS, rgba8, encoded: None };
        let texture = TextureRef {
            image: 0,
            tex_coord: 0,
            transform: TextureTransform::default(),
            repeat: [true; 2],
            nearest: false,
        };
        let material = Material {
            name: Some("Bumps".into()),
            base_color: [0.6, 0.6, 0.6, 1.0],
            metallic: 0.0,
            roughness: 0.4,
            normal_texture: Some(texture),
            ..Material::default()
        };
        scene_of("Normal-mapped plane", vec![p], vec![material], vec![image])
    }
}
