//! Generated tangents against the reference MikkTSpace (issue 23): Kloub's port
//! (`kloub_core::import::tangents`) and three.js r187's port of Mikkelsen's reference C
//! (`scripts/mikktspace-reference.mjs`, run in Node) on the same corners, for meshes made in
//! code (a UV sphere whose poles hold degenerate triangles, a plane, a strip mirrored in u) and
//! for every primitive of the characters. Both ports weld, group and weight alike in single
//! precision; they differ in the order some sums are taken, so tangents may differ in their
//! last bits. Bound: every corner's handedness equal and its tangent within 0.01° (measured:
//! printed per mesh).

use std::path::PathBuf;
use std::process::Command;

use kloub_core::asset::{Primitive, TextureTransform, Topology};
use kloub_core::import::tangents::{generate, mikktspace};
use kloub_core::{ImportOptions, MapResolver};

fn repo() -> PathBuf {
    kloub_tests::repo_root()
}

/// The corners of `p` (positions, normals, the uv set) flattened, one triangle per three.
fn corners(p: &Primitive, uvs: &[[f32; 2]]) -> serde_json::Value {
    let whole = p.indices.len() / 3 * 3;
    let (mut positions, mut normals, mut texcoords) = (Vec::new(), Vec::new(), Vec::new());
    for &i in &p.indices[..whole] {
        positions.extend(p.positions[i as usize]);
        normals.extend(p.normals[i as usize]);
        texcoords.extend(uvs[i as usize]);
    }
    serde_json::json!({ "positions": positions, "normals": normals, "uvs": texcoords })
}

/// The reference's tangents of `p`'s corners.
fn reference(name: &str, p: &Primitive, uvs: &[[f32; 2]]) -> Vec<[f32; 4]> {
    let dir = repo().join("tests/out/tangents");
    std::fs::create_dir_all(&dir).expect("creating tests/out/tangents");
    let file = dir.join(format!("{}.json", name.replace(['/', ' '], "_")));
    std::fs::write(&file, corners(p, uvs).to_string()).expect("writing the corners");
    let out = Command::new("node")
        .arg(repo().join("scripts/mikktspace-reference.mjs"))
        .arg(&file)
        .current_dir(repo())
        .output()
        .expect("running node (the README's setup installs it)");
    assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
    let flat: Vec<f32> = serde_json::from_slice(&out.stdout).expect("the reference's JSON");
    flat.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect()
}

/// Compares Kloub's corners with the reference's; returns (largest angle in degrees, corners).
fn compare(name: &str, p: &Primitive, uvs: &[[f32; 2]]) -> (f64, usize) {
    let ours = mikktspace(&p.positions, &p.normals, uvs, &p.indices);
    let theirs = reference(name, p, uvs);
    assert_eq!(ours.len(), theirs.len(), "{name}: corner count");
    let mut worst = 0.0f64;
    for (c, (a, b)) in ours.iter().zip(&theirs).enumerate() {
        assert_eq!(a[3], b[3], "{name}: corner {c}: handedness {a:?} against the reference's {b:?}");
        let (u, v) = (
            glam::DVec3::new(a[0].into(), a[1].into(), a[2].into()),
            glam::DVec3::new(b[0].into(), b[1].into(), b[2].into()),
        );
        let angle = if u.length() == 0.0 && v.length() == 0.0 {
            0.0
        } else {
            u.normalize_or_zero().dot(v.normalize_or_zero()).clamp(-1.0, 1.0).acos().to_degrees()
        };
        worst = worst.max(angle);
    }
    eprintln!("{name}: {} corners, largest difference {worst:.2e}°", ours.len());
    assert!(worst < 0.01, "{name}: a tangent {worst}° from the reference's");
    (worst, ours.len())
}

/// A 2 × 1 strip of quads whose right half mirrors the left in u: the middle column's vertices
/// are shared, with the same uv on both sides, so MikkTSpace gives their corners opposite
/// orientations and a welded mesh must split them.
fn mirrored_strip() -> Primitive {
    let positions =
        vec![[-1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [-1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
    let uv0 = vec![[0.0, 1.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0], [1.0, 0.0], [0.0, 0.0]];
    Primitive {
        vertex_count: 6,
        positions,
        normals: vec![[0.0, 0.0, 1.0]; 6],
        uv0,
        colors: (0..6).map(|i| [i as f32 / 6.0, 0.0, 0.0, 1.0]).collect(),
        indices: vec![0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4],
        topology: Topology::Triangles,
        ..Primitive::default()
    }
}

#[test]
fn generated_tangents_match_the_reference_mikktspace() {
    let mut compared = 0;
    let sphere = kloub_tests::materials::sphere_grid();
    let p = &sphere.meshes[0].primitives[0];
    compared += compare("sphere", p, &p.uv0).1;
    let plane = kloub_tests::materials::normal_mapped_plane();
    let p = &plane.meshes[0].primitives[0];
    compared += compare("plane", p, &p.uv0).1;
    let strip = mirrored_strip();
    compared += compare("mirrored strip", &strip, &strip.uv0).1;
    for file in [
        "khronos/Fox/glTF-Binary/Fox.glb",
        "khronos/CesiumMan/glTF-Binary/CesiumMan.glb",
        "khronos/CesiumMilkTruck/glTF-Binary/CesiumMilkTruck.glb",
        "kaykit/Knight/Knight.glb",
    ] {
        let bytes = std::fs::read(repo().join("tests/assets").join(file)).expect("a test asset");
        let asset =
            kloub_core::import(&bytes, &MapResolver::default(), &ImportOptions::default()).expect("importing").asset;
        for (m, mesh) in asset.meshes.iter().enumerate() {
            for (k, p) in mesh.primitives.iter().enumerate() {
                if p.topology != Topology::Triangles
                    || p.normals.len() != p.positions.len()
                    || p.uv0.len() != p.positions.len()
                {
                    continue;
                }
                compared += compare(&format!("{file} mesh {m} primitive {k}"), p, &p.uv0).1;
            }
        }
    }
    assert!(compared > 10_000, "{compared} corners compared");
}

#[test]
fn a_mirrored_seam_splits_its_vertices_and_keeps_their_attributes() {
    let mut strip = mirrored_strip();
    let corners = mikktspace(&strip.positions, &strip.normals, &strip.uv0, &strip.indices);
    let before = strip.clone();
    assert!(generate(&mut strip, 0, &Default::default()));
    // The two shared middle vertices get a copy each for the mirrored half.
    assert_eq!(strip.positions.len(), 8);
    assert_eq!(strip.copied_from, [1, 4]);
    assert_eq!(strip.vertex_count, 8);
    for stream in [strip.normals.len(), strip.uv0.len(), strip.colors.len(), strip.tangents.len()] {
        assert_eq!(stream, 8);
    }
    for (c, (&new, &old)) in strip.indices.iter().zip(&before.indices).enumerate() {
        // Every corner keeps its vertex's attributes and takes its own tangent, w negated for
        // glTF's v (the tangents Blender writes).
        assert_eq!(strip.positions[new as usize], before.positions[old as usize]);
        assert_eq!(strip.uv0[new as usize], before.uv0[old as usize]);
        assert_eq!(strip.colors[new as usize], before.colors[old as usize]);
        let [x, y, z, w] = corners[c];
        assert_eq!(strip.tangents[new as usize], [x, y, z, -w], "corner {c}");
    }
    // The halves' frames: +x with w = 1 on the left (glTF's standard mapping: the bitangent
    // cross(n, t) · w = +y, up the image), −x with w = −1 on the right (mirrored).
    assert_eq!(strip.tangents[0], [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(strip.tangents[2], [-1.0, 0.0, 0.0, -1.0]);
    // Not a triangle list, or no texture coordinates: left as it is.
    let mut lines = mirrored_strip();
    lines.topology = Topology::Lines;
    assert!(!generate(&mut lines, 0, &Default::default()) && lines.tangents.is_empty());
    assert!(!generate(&mut mirrored_strip(), 1, &Default::default()));
}

/// Imported, a normal-mapped primitive without TANGENT takes MikkTSpace's tangents (those of
/// the normal texture's texCoord set), in glTF's convention: the plane's standard mapping gives
/// +x with w = 1, the frame the fragment shader otherwise derives. A primitive with tangents
/// keeps its own.
#[test]
fn import_generates_tangents_for_normal_maps_only_where_missing() {
    let asset = kloub_tests::materials::normal_mapped_plane();
    let glb = kloub_tests::materials::to_glb(&asset);
    let imported = kloub_core::import(&glb, &MapResolver::default(), &ImportOptions::default()).expect("importing");
    let p = &imported.asset.meshes[0].primitives[0];
    assert_eq!(p.tangents, vec![[1.0, 0.0, 0.0, 1.0]; 4]);
    assert_eq!(p.positions.len(), 4, "nothing to split");
    // The normal texture on TEXCOORD_1, whose v runs up: the mapping is mirrored, w = −1.
    let mut second = asset.clone();
    {
        let p = &mut second.meshes[0].primitives[0];
        p.uv1 = p.uv0.iter().map(|&[u, v]| [u, 1.0 - v]).collect();
        let texture = second.materials[0].normal_texture.as_mut().expect("a normal texture");
        texture.tex_coord = 1;
    }
    let imported = kloub_core::import(
        &kloub_tests::materials::to_glb(&second),
        &MapResolver::default(),
        &ImportOptions::default(),
    )
    .expect("importing");
    assert_eq!(imported.asset.meshes[0].primitives[0].tangents, vec![[1.0, 0.0, 0.0, -1.0]; 4]);
    // Without a normal texture nothing is generated.
    let mut plain = asset.clone();
    plain.materials[0].normal_texture = None;
    let imported =
        kloub_core::import(&kloub_tests::materials::to_glb(&plain), &MapResolver::default(), &ImportOptions::default())
            .expect("importing");
    assert!(imported.asset.meshes[0].primitives[0].tangents.is_empty());
}

/// Tangents in the file are kept as they are.
#[test]
fn tangents_in_the_file_are_kept() {
    let mut asset = kloub_tests::materials::normal_mapped_plane();
    asset.meshes[0].primitives[0].tangents = vec![[0.0, 1.0, 0.0, -1.0]; 4];
    let imported =
        kloub_core::import(&kloub_tests::materials::to_glb(&asset), &MapResolver::default(), &ImportOptions::default())
            .expect("importing");
    assert_eq!(imported.asset.meshes[0].primitives[0].tangents, vec![[0.0, 1.0, 0.0, -1.0]; 4]);
}

#[test]
fn a_texture_transform_turns_the_generated_frame_with_the_normal_map() {
    // A unit quad in the xy plane facing +z, glTF's standard mapping (u = x, v = 1 − y). The
    // normal map is sampled at M·uv (KHR_texture_transform): the tangent is ∂p/∂u' and the
    // bitangent cross(n, t)·w points against ∂p/∂v' (up the image), for a rotation, a mirror
    // and a non-uniform scale with an offset.
    let quad = || Primitive {
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
        normals: vec![[0.0, 0.0, 1.0]; 4],
        uv0: vec![[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]],
        indices: vec![0, 1, 2, 0, 2, 3],
        topology: Topology::Triangles,
        vertex_count: 4,
        ..Primitive::default()
    };
    let transforms = [
        TextureTransform { rotation: 0.7, ..TextureTransform::default() },
        TextureTransform { scale: [-1.0, 1.0], ..TextureTransform::default() },
        TextureTransform { offset: [0.3, -2.0], rotation: 2.0, scale: [0.5, 3.0] },
    ];
    for transform in transforms {
        let mut p = quad();
        assert!(generate(&mut p, 0, &transform));
        // ∂(u', v')/∂(x, y) = M₂ · diag(1, −1); its inverse's columns are ∂p/∂u' and ∂p/∂v'.
        let m = transform.matrix();
        let jacobian = glam::Mat2::from_cols(m.x_axis.truncate(), m.y_axis.truncate())
            * glam::Mat2::from_diagonal(glam::Vec2::new(1.0, -1.0));
        let inverse = jacobian.inverse();
        let (du, dv) = (inverse.x_axis.normalize(), inverse.y_axis.normalize());
        for (v, t) in p.tangents.iter().enumerate() {
            let tangent = glam::Vec2::new(t[0], t[1]);
            assert!(
                (tangent - du).length() < 1e-5 && t[2].abs() < 1e-6,
                "{transform:?}: vertex {v}: {t:?}, ∂p/∂u' {du}"
            );
            let bitangent = glam::Vec3::Z.cross(glam::Vec3::new(t[0], t[1], t[2])) * t[3];
            assert!(
                bitangent.truncate().dot(dv) < -0.1,
                "{transform:?}: vertex {v}: bitangent {bitangent} along ∂p/∂v' {dv}"
            );
        }
    }
}
