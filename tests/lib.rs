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
    use kloub_core::asset::{
        AlphaMode, Asset, Image, Material, Mesh, Node, Primitive, Scene, TextureRef, TextureTransform,
    };

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

    /// A reference to image 0 with glTF's default sampling (repeat, linear, trilinear).
    fn first_image() -> TextureRef {
        TextureRef {
            image: 0,
            tex_coord: 0,
            transform: TextureTransform::default(),
            repeat: [true; 2],
            nearest: false,
            min_filter: Default::default(),
        }
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
        let texture = first_image();
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

    /// Two normal-mapped quads side by side carrying TANGENT: the left one's tangents run up
    /// (+y, w = 1: its bumps' frame turned a quarter), the right one's along +x with w = −1
    /// (its bitangent mirrored, down the image). Without tangents both would look like
    /// [`normal_mapped_plane`]'s.
    pub fn tangent_planes() -> Asset {
        let mut plane = normal_mapped_plane();
        let mut left = quad([-0.55, 0.0, 0.0], 1.0, 0);
        left.tangents = vec![[0.0, 1.0, 0.0, 1.0]; 4];
        let mut right = quad([0.55, 0.0, 0.0], 1.0, 0);
        right.tangents = vec![[1.0, 0.0, 0.0, -1.0]; 4];
        plane.meshes[0].primitives = vec![left, right];
        plane.nodes[0].name = Some("Tangent planes".into());
        plane.meshes[0].name = Some("Tangent planes".into());
        plane.scenes[0].name = Some("Tangent planes".into());
        plane
    }

    /// A quad of `size` centred at `center` in a plane parallel to XY, facing +Z, uv (0, 0) at
    /// its top left, drawn with `material`.
    fn quad(center: [f32; 3], size: f32, material: u32) -> Primitive {
        let h = size * 0.5;
        let [x, y, z] = center;
        finish(Primitive {
            positions: vec![[x - h, y + h, z], [x - h, y - h, z], [x + h, y - h, z], [x + h, y + h, z]],
            normals: vec![[0.0, 0.0, 1.0]; 4],
            uv0: vec![[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]],
            indices: vec![0, 1, 2, 0, 2, 3],
            material: Some(material),
            ..Primitive::default()
        })
    }

    /// Alpha modes: on the left a MASK quad (cutoff 0.5) whose texture is opaque in rings and
    /// faint between them; on the right a BLEND quad (40 % opaque blue) over an opaque white
    /// quad behind it, half covering it.
    pub fn alpha_quads() -> Asset {
        let n = 64u32;
        let mut rgba8 = Vec::with_capacity((n * n * 4) as usize);
        for y in 0..n {
            for x in 0..n {
                let (u, v) = ((x as f32 + 0.5) / n as f32 - 0.5, (y as f32 + 0.5) / n as f32 - 0.5);
                let ring = ((u * u + v * v).sqrt() * 8.0).fract() < 0.5;
                rgba8.extend([230, 120, 40, if ring { 255 } else { 40 }]);
            }
        }
        let image = Image { name: Some("rings".into()), width: n, height: n, rgba8, encoded: None };
        let texture = first_image();
        let dielectric = |name: &str, base_color: [f32; 4]| Material {
            name: Some(name.into()),
            base_color,
            metallic: 0.0,
            roughness: 0.5,
            ..Material::default()
        };
        let materials = vec![
            Material {
                base_color_texture: Some(texture),
                alpha: AlphaMode::Mask(0.5),
                double_sided: true,
                ..dielectric("Mask rings", [1.0; 4])
            },
            Material { alpha: AlphaMode::Blend, ..dielectric("Blend blue", [0.1, 0.3, 0.9, 0.4]) },
            dielectric("Opaque white", [0.9, 0.9, 0.9, 1.0]),
        ];
        let primitives =
            vec![quad([-0.6, 0.0, 0.0], 1.0, 0), quad([0.85, 0.25, -0.3], 0.8, 2), quad([0.6, 0.0, 0.0], 1.0, 1)];
        scene_of("Alpha quads", primitives, materials, vec![image])
    }

    /// `asset` (one node, one mesh: what the scenes above make) as a GLB: positions, normals,
    /// texture coordinates and indices of each triangle primitive; its materials with their
    /// factors, alpha modes and base colour and normal textures (PNG, repeat, linear).
    ///
    /// # Panics
    /// On an asset with other parts (skins, clips, several meshes): the writer is for these
    /// test scenes only.
    pub fn to_glb(asset: &Asset) -> Vec<u8> {
        use serde_json::{Value, json};
        assert!(asset.meshes.len() == 1 && asset.skins.is_empty() && asset.clips.is_empty(), "a scene of this module");
        let mut bin: Vec<u8> = Vec::new();
        let mut views = Vec::new();
        let mut accessors = Vec::new();
        let mut push_view = |bin: &mut Vec<u8>, bytes: &[u8]| {
            while !bin.len().is_multiple_of(4) {
                bin.push(0);
            }
            views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
            bin.extend_from_slice(bytes);
            views.len() - 1
        };
        let floats = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let mut primitives = Vec::new();
        for p in &asset.meshes[0].primitives {
            let mut attributes = serde_json::Map::new();
            let (lo, hi) = p.bounds;
            let position = push_view(&mut bin, &floats(p.positions.as_flattened()));
            accessors.push(json!({"bufferView": position, "componentType": 5126, "count": p.positions.len(),
                "type": "VEC3", "min": lo, "max": hi}));
            attributes.insert("POSITION".into(), json!(accessors.len() - 1));
            let normal = push_view(&mut bin, &floats(p.normals.as_flattened()));
            accessors
                .push(json!({"bufferView": normal, "componentType": 5126, "count": p.normals.len(), "type": "VEC3"}));
            attributes.insert("NORMAL".into(), json!(accessors.len() - 1));
            let uv = push_view(&mut bin, &floats(p.uv0.as_flattened()));
            accessors.push(json!({"bufferView": uv, "componentType": 5126, "count": p.uv0.len(), "type": "VEC2"}));
            attributes.insert("TEXCOORD_0".into(), json!(accessors.len() - 1));
            if !p.uv1.is_empty() {
                let uv = push_view(&mut bin, &floats(p.uv1.as_flattened()));
                accessors.push(json!({"bufferView": uv, "componentType": 5126, "count": p.uv1.len(), "type": "VEC2"}));
                attributes.insert("TEXCOORD_1".into(), json!(accessors.len() - 1));
            }
            if !p.tangents.is_empty() {
                let tangent = push_view(&mut bin, &floats(p.tangents.as_flattened()));
                accessors.push(
                    json!({"bufferView": tangent, "componentType": 5126, "count": p.tangents.len(), "type": "VEC4"}),
                );
                attributes.insert("TANGENT".into(), json!(accessors.len() - 1));
            }
            let indices: Vec<u8> = p.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
            let index = push_view(&mut bin, &indices);
            accessors
                .push(json!({"bufferView": index, "componentType": 5125, "count": p.indices.len(), "type": "SCALAR"}));
            primitives.push(json!({"attributes": attributes, "indices": accessors.len() - 1, "material": p.material}));
        }
        let mut images = Vec::new();
        for image in &asset.images {
            let mut png = Vec::new();
            image::RgbaImage::from_raw(image.width, image.height, image.rgba8.clone())
                .expect("an image of its size")
                .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
                .expect("encoding a PNG");
            let view = push_view(&mut bin, &png);
            images.push(json!({"bufferView": view, "mimeType": "image/png"}));
        }
        let textures: Vec<Value> = (0..asset.images.len()).map(|i| json!({"source": i, "sampler": 0})).collect();
        let materials: Vec<Value> = asset
            .materials
            .iter()
            .map(|m| {
                let mut pbr = json!({"baseColorFactor": m.base_color, "metallicFactor": m.metallic, "roughnessFactor": m.roughness});
                if let Some(t) = m.base_color_texture {
                    pbr["baseColorTexture"] = json!({"index": t.image});
                }
                let mut material = json!({"name": m.name, "pbrMetallicRoughness": pbr, "doubleSided": m.double_sided});
                if let Some(t) = m.normal_texture {
                    material["normalTexture"] = json!({"index": t.image, "scale": m.normal_scale});
                    if t.tex_coord != 0 {
                        material["normalTexture"]["texCoord"] = json!(t.tex_coord);
                    }
                }
                match m.alpha {
                    AlphaMode::Opaque => {}
                    AlphaMode::Mask(cutoff) => {
                        material["alphaMode"] = json!("MASK");
                        material["alphaCutoff"] = json!(cutoff);
                    }
                    AlphaMode::Blend => material["alphaMode"] = json!("BLEND"),
                }
                material
            })
            .collect();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let name = asset.nodes[0].name.clone();
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": "kloub-tests materials"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": [{"name": name, "mesh": 0}],
            "meshes": [{"name": name, "primitives": primitives}],
            "materials": materials,
            "accessors": accessors,
            "bufferViews": views,
            "buffers": [{"byteLength": bin.len()}],
        });
        if !images.is_empty() {
            doc["images"] = json!(images);
            doc["textures"] = json!(textures);
            doc["samplers"] = json!([{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}]);
        }
        let mut json = serde_json::to_vec(&doc).expect("JSON");
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut glb = Vec::with_capacity(total);
        glb.extend(b"glTF");
        glb.extend(2u32.to_le_bytes());
        glb.extend((total as u32).to_le_bytes());
        glb.extend((json.len() as u32).to_le_bytes());
        glb.extend(b"JSON");
        glb.extend(&json);
        glb.extend((bin.len() as u32).to_le_bytes());
        glb.extend(b"BIN\0");
        glb.extend(&bin);
        glb
    }
}

/// Writes an equirectangular image of linear RGB (`width` × `height`, top row first) as a
/// Radiance `.hdr` file: flat RGBE scanlines (what three.js's HDRLoader and Kloub's reader take).
pub fn write_hdr(width: u32, height: u32, rgb: &[[f32; 3]]) -> Vec<u8> {
    let mut out = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n").into_bytes();
    for p in rgb {
        let m = p[0].max(p[1]).max(p[2]);
        if m < 1e-32 {
            out.extend([0, 0, 0, 0]);
            continue;
        }
        // m = f · 2^e with f in [0.5, 1): bytes of 256 · c / 2^e.
        let e = m.log2().floor() as i32 + 1;
        let scale = 256.0 / 2f32.powi(e);
        out.extend(p.map(|c| (c * scale).clamp(0.0, 255.0) as u8));
        out.push((e + 128) as u8);
    }
    out
}
