//! Tangents generated as MikkTSpace generates them, for normal-mapped primitives that come
//! without a TANGENT attribute (glTF 2.0: "When tangents are not specified, client
//! implementations SHOULD calculate tangents using default MikkTSpace algorithms with the
//! specified vertex positions, normals, and texture coordinates associated with the normal
//! texture"). Normal maps are baked against MikkTSpace's frame (Blender, Substance, xNormal),
//! so any other frame bends their detail.
//!
//! This follows Morten Mikkelsen's reference implementation (`genTangSpaceDefault`: an
//! angular threshold of 180°) step by step, for triangle lists (glTF has no quads):
//! 1. corners with equal position, normal and texture coordinate are welded;
//! 2. triangles with two equal positions are degenerate and set aside;
//! 3. each triangle's first-order derivatives of position along s and t, made unit length,
//!    their magnitudes, and whether the mapping preserves orientation (a triangle whose
//!    texture area is zero, or whose derivatives vanish, groups with anything);
//! 4. triangles sharing an edge (opposite directions) are neighbours;
//! 5. around each welded vertex, groups of triangles connected through neighbours with the
//!    same orientation;
//! 6. each vertex of each triangle takes the angle-weighted average of its group's
//!    derivatives, projected on the vertex normal;
//! 7. degenerate triangles copy the space of a good triangle at the same welded vertex.
//!
//! The result is one tangent per triangle corner; [`generate`] then splits the vertices whose
//! corners got different tangents (mirrored texture seams), as a welded mesh must.
//!
//! glTF's texture coordinates run down the image (v = 0 at the top), the other way from the
//! tools that bake normal maps (Blender's exporter flips v). Flipping v keeps MikkTSpace's
//! tangents and groups and turns every orientation round, so [`generate`] negates the sign
//! [`mikktspace`] gives: the tangents Blender writes into glTF files.

use std::collections::HashMap;

use crate::asset::{Primitive, TextureTransform, Topology};
use crate::math::Vec3;

const MARK_DEGENERATE: u8 = 1;
const GROUP_WITH_ANY: u8 = 4;
const ORIENT_PRESERVING: u8 = 8;
const NONE: u32 = u32::MAX;
/// Groups with more faces than this are not split by the angular threshold (step 6), and an edge
/// is looked for among at most this many later triangles on it (step 4): bounds on hostile
/// input that real meshes stay far within.
const LARGEST_COMPARED_GROUP: usize = 256;

/// The reference's `NotZero`: larger in magnitude than the smallest normal float.
fn not_zero(x: f32) -> bool {
    x.abs() > f32::MIN_POSITIVE
}

fn v_not_zero(v: Vec3) -> bool {
    not_zero(v.x) || not_zero(v.y) || not_zero(v.z)
}

/// `v` scaled to unit length where it is not zero.
fn normalized(v: Vec3) -> Vec3 {
    if v_not_zero(v) { v * (1.0 / v.length()) } else { v }
}

/// `v` less its component along the unit normal `n`, made unit length where not zero.
fn project(n: Vec3, v: Vec3) -> Vec3 {
    normalized(v - n * n.dot(v))
}

/// One good triangle's derivatives, neighbours and groups.
#[derive(Clone, Copy)]
struct Tri {
    /// Welded vertex (a representative corner) of each corner.
    verts: [u32; 3],
    /// The triangle's index in the primitive (its corners' output slots).
    original: u32,
    /// The neighbour across edge k (from corner k to corner k + 1), or NONE.
    neighbours: [u32; 3],
    /// The group of each corner, or NONE.
    groups: [u32; 3],
    os: Vec3,
    ot: Vec3,
    mag_s: f32,
    mag_t: f32,
    flags: u8,
}

/// A corner's tangent space as glTF keeps it: the tangent (the reference's `vOs`; its
/// bitangent `vOt` and magnitudes are not kept) and the orientation.
#[derive(Clone, Copy)]
struct Space {
    os: Vec3,
    orient: bool,
}

impl Default for Space {
    fn default() -> Self {
        Self { os: Vec3::X, orient: false }
    }
}

struct Group {
    faces: Vec<u32>,
    vertex: u32,
    orient: bool,
}

/// MikkTSpace's tangent (xyz, unit length where defined) and bitangent sign (w: 1 where the
/// mapping preserves orientation, as the reference's `bOrient`) of every corner
/// of the triangle list `indices` (one tangent per index). `normals` are taken as given (unit
/// length in a valid glTF). Indices must be in range (the importer checked them).
///
/// Runs in time linear in the corners (a group of more than [`LARGEST_COMPARED_GROUP`] faces is
/// not compared pair by pair) and memory linear in them.
pub fn mikktspace(positions: &[[f32; 3]], normals: &[[f32; 3]], uvs: &[[f32; 2]], indices: &[u32]) -> Vec<[f32; 4]> {
    let corners = indices.len() / 3 * 3;
    let vertex = |c: u32| indices.get(c as usize).map_or(0, |&v| v as usize);
    let position = |c: u32| positions.get(vertex(c)).map_or(Vec3::ZERO, |&p| Vec3::from(p));
    let normal = |c: u32| normals.get(vertex(c)).map_or(Vec3::ZERO, |&n| Vec3::from(n));
    let uv = |c: u32| uvs.get(vertex(c)).copied().unwrap_or_default();

    // 1. Weld corners by value (-0 equals 0, as C's == has it; a NaN equals nothing).
    let mut welded = vec![0u32; corners];
    let mut seen: HashMap<[u32; 8], u32> = HashMap::with_capacity(corners);
    for (c, w) in welded.iter_mut().enumerate() {
        let c = c as u32;
        let values = {
            let (p, n, t) = (position(c), normal(c), uv(c));
            [p.x, p.y, p.z, n.x, n.y, n.z, t[0], t[1]]
        };
        *w = if values.iter().all(|v| v.is_finite()) {
            let key = values.map(|v| if v == 0.0 { 0 } else { v.to_bits() });
            *seen.entry(key).or_insert(c)
        } else {
            c
        };
    }

    // 2. Good triangles first, in order; degenerate ones after.
    let mut tris: Vec<Tri> = Vec::with_capacity(corners / 3);
    let mut degenerate: Vec<Tri> = Vec::new();
    for t in 0..corners / 3 {
        let verts = [welded[3 * t], welded[3 * t + 1], welded[3 * t + 2]];
        let [p0, p1, p2] = verts.map(position);
        let tri = Tri {
            verts,
            original: t as u32,
            neighbours: [NONE; 3],
            groups: [NONE; 3],
            os: Vec3::ZERO,
            ot: Vec3::ZERO,
            mag_s: 0.0,
            mag_t: 0.0,
            flags: GROUP_WITH_ANY,
        };
        if p0 == p1 || p0 == p2 || p1 == p2 {
            degenerate.push(Tri { flags: MARK_DEGENERATE, ..tri });
        } else {
            tris.push(tri);
        }
    }

    // 3. Derivatives (the reference's equations 18 and 19).
    for tri in &mut tris {
        let [v1, v2, v3] = tri.verts.map(position);
        let [t1, t2, t3] = tri.verts.map(uv);
        let (t21x, t21y, t31x, t31y) = (t2[0] - t1[0], t2[1] - t1[1], t3[0] - t1[0], t3[1] - t1[1]);
        let (d1, d2) = (v2 - v1, v3 - v1);
        let signed_area = t21x * t31y - t21y * t31x;
        let os = d1 * t31y - d2 * t21y;
        let ot = d1 * -t31x + d2 * t21x;
        if signed_area > 0.0 {
            tri.flags |= ORIENT_PRESERVING;
        }
        if not_zero(signed_area) {
            let area = signed_area.abs();
            let (len_s, len_t) = (os.length(), ot.length());
            let sign = if tri.flags & ORIENT_PRESERVING == 0 { -1.0 } else { 1.0 };
            if not_zero(len_s) {
                tri.os = os * (sign / len_s);
            }
            if not_zero(len_t) {
                tri.ot = ot * (sign / len_t);
            }
            tri.mag_s = len_s / area;
            tri.mag_t = len_t / area;
            if not_zero(tri.mag_s) && not_zero(tri.mag_t) {
                tri.flags &= !GROUP_WITH_ANY;
            }
        }
    }

    // 4. Neighbours: edges sorted by (lower vertex, higher vertex, triangle); each unpaired
    // edge pairs with the first later unpaired one of the same vertices in the other direction.
    let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(tris.len() * 3);
    for (f, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri.verts[k], tri.verts[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b), f as u32));
        }
    }
    edges.sort_unstable();
    for i in 0..edges.len() {
        let (i0, i1, f) = edges[i];
        let (a0, a1, edge_a) = edge_of(&tris[f as usize].verts, i0, i1);
        if tris[f as usize].neighbours[edge_a] != NONE {
            continue;
        }
        let mut j = i + 1;
        // An edge shared by more triangles than this (a hostile file) pairs within the first ones.
        let end = i + 1 + LARGEST_COMPARED_GROUP;
        while let Some(&(j0, j1, t)) = edges.get(j).filter(|e| j < end && e.0 == i0 && e.1 == i1) {
            // The other triangle's edge, read backwards.
            let (b1, b0, edge_b) = edge_of(&tris[t as usize].verts, j0, j1);
            if a0 == b0 && a1 == b1 && tris[t as usize].neighbours[edge_b] == NONE {
                tris[f as usize].neighbours[edge_a] = t;
                tris[t as usize].neighbours[edge_b] = f;
                break;
            }
            j += 1;
        }
    }

    // 5. Groups around each vertex (the reference's four rules), depth first as its recursion.
    let mut groups: Vec<Group> = Vec::new();
    let mut stack: Vec<u32> = Vec::new();
    for f in 0..tris.len() {
        for k in 0..3 {
            if tris[f].flags & GROUP_WITH_ANY != 0 || tris[f].groups[k] != NONE {
                continue;
            }
            let g = groups.len() as u32;
            let orient = tris[f].flags & ORIENT_PRESERVING != 0;
            groups.push(Group { faces: vec![f as u32], vertex: tris[f].verts[k], orient });
            tris[f].groups[k] = g;
            stack.clear();
            push_neighbours(&tris[f], k, &mut stack);
            while let Some(t) = stack.pop() {
                let group = &mut groups[g as usize];
                let tri = &mut tris[t as usize];
                let Some(i) = tri.verts.iter().position(|&v| v == group.vertex) else { continue };
                if tri.groups[i] != NONE {
                    continue;
                }
                // The first group to reach a group-with-anything triangle sets its orientation
                // (the reference's one order dependency).
                if tri.flags & GROUP_WITH_ANY != 0 && tri.groups == [NONE; 3] {
                    tri.flags = (tri.flags & !ORIENT_PRESERVING) | if group.orient { ORIENT_PRESERVING } else { 0 };
                }
                if (tri.flags & ORIENT_PRESERVING != 0) != group.orient {
                    continue;
                }
                group.faces.push(t);
                tri.groups[i] = g;
                push_neighbours(tri, i, &mut stack);
            }
        }
    }

    // 6. A space per corner: its group's triangles whose derivatives (projected on the vertex
    // normal) are not opposite to its own form a subgroup, averaged by corner angle.
    let mut spaces = vec![Space::default(); corners];
    let mut members: Vec<u32> = Vec::new();
    let mut subgroups: Vec<(Vec<u32>, Space)> = Vec::new();
    // cos(180°) as the reference computes it in single precision.
    let threshold = (std::f64::consts::PI as f32 as f64).cos() as f32;
    let mut projected: Vec<(Vec3, Vec3)> = Vec::new();
    for (g, group) in groups.iter().enumerate() {
        subgroups.clear();
        // Every face of a group has its corner on the group's vertex: one normal.
        let n = normal(group.vertex);
        if group.faces.len() > LARGEST_COMPARED_GROUP {
            // The threshold (180°) parts only exactly opposite tangents; a group this large (a fan
            // of hundreds of triangles on one vertex, or a hostile file) is one subgroup, not
            // compared pair by pair.
            members.clear();
            members.extend_from_slice(&group.faces);
            members.sort_unstable();
            let space = eval_space(&members, &tris, group.vertex, &position, &normal);
            for &f in &group.faces {
                let tri = &tris[f as usize];
                let Some(k) = tri.groups.iter().position(|&x| x == g as u32) else { continue };
                if let Some(slot) = spaces.get_mut(tri.original as usize * 3 + k) {
                    *slot = Space { orient: group.orient, ..space };
                }
            }
            continue;
        }
        projected.clear();
        projected
            .extend(group.faces.iter().map(|&t| (project(n, tris[t as usize].os), project(n, tris[t as usize].ot))));
        for (a, &f) in group.faces.iter().enumerate() {
            let tri = &tris[f as usize];
            let Some(k) = tri.groups.iter().position(|&x| x == g as u32) else { continue };
            let (os, ot) = projected[a];
            members.clear();
            for (b, &t) in group.faces.iter().enumerate() {
                let (os2, ot2) = projected[b];
                let any = (tri.flags | tris[t as usize].flags) & GROUP_WITH_ANY != 0;
                if any || f == t || (os.dot(os2) > threshold && ot.dot(ot2) > threshold) {
                    members.push(t);
                }
            }
            members.sort_unstable();
            let space = match subgroups.iter().find(|(m, _)| *m == members) {
                Some((_, space)) => *space,
                None => {
                    let space = eval_space(&members, &tris, group.vertex, &position, &normal);
                    subgroups.push((members.clone(), space));
                    space
                }
            };
            if let Some(slot) = spaces.get_mut(tri.original as usize * 3 + k) {
                *slot = Space { orient: group.orient, ..space };
            }
        }
    }

    // 7. Degenerate triangles: the space of the first good corner at the same welded vertex.
    if !degenerate.is_empty() {
        let mut first: HashMap<u32, usize> = HashMap::new();
        for good in &tris {
            for (j, &v) in good.verts.iter().enumerate() {
                first.entry(v).or_insert(good.original as usize * 3 + j);
            }
        }
        for tri in &degenerate {
            for (k, v) in tri.verts.iter().enumerate() {
                if let Some(&source) = first.get(v) {
                    spaces[tri.original as usize * 3 + k] = spaces[source];
                }
            }
        }
    }
    spaces.iter().map(|s| [s.os.x, s.os.y, s.os.z, if s.orient { 1.0 } else { -1.0 }]).collect()
}

/// The reference's `GetEdge`: the edge of triangle `verts` joining `i0` and `i1`, as the
/// triangle runs it (from, to), and its number (edge k runs from corner k to k + 1).
fn edge_of(verts: &[u32; 3], i0: u32, i1: u32) -> (u32, u32, usize) {
    let on = |v: u32| v == i0 || v == i1;
    if on(verts[0]) {
        if on(verts[1]) { (verts[0], verts[1], 0) } else { (verts[2], verts[0], 2) }
    } else {
        (verts[1], verts[2], 1)
    }
}

/// Queues the neighbours of `tri` around its corner `k` so that the one across edge k is taken
/// (with all it reaches) before the one across the edge before it.
fn push_neighbours(tri: &Tri, k: usize, stack: &mut Vec<u32>) {
    let (left, right) = (tri.neighbours[k], tri.neighbours[(k + 2) % 3]);
    if right != NONE {
        stack.push(right);
    }
    if left != NONE {
        stack.push(left);
    }
}

/// The angle-weighted average of `members`' tangents at their corner on welded vertex
/// `vertex`, projected on its normal (the reference's `EvalTspace`).
fn eval_space(
    members: &[u32],
    tris: &[Tri],
    vertex: u32,
    position: &impl Fn(u32) -> Vec3,
    normal: &impl Fn(u32) -> Vec3,
) -> Space {
    let mut os = Vec3::ZERO;
    for &f in members {
        let tri = &tris[f as usize];
        if tri.flags & GROUP_WITH_ANY != 0 {
            continue;
        }
        let Some(i) = tri.verts.iter().position(|&v| v == vertex) else { continue };
        let n = normal(tri.verts[i]);
        let vos = project(n, tri.os);
        let (p0, p1, p2) = (position(tri.verts[(i + 2) % 3]), position(tri.verts[i]), position(tri.verts[(i + 1) % 3]));
        let (v1, v2) = (project(n, p0 - p1), project(n, p2 - p1));
        let cos = v1.dot(v2).clamp(-1.0, 1.0);
        let angle = f64::from(cos).acos() as f32;
        os += vos * angle;
    }
    Space { os: normalized(os), orient: false }
}

/// Bytes of scratch memory [`plan`] may take per index of a primitive at most (the welding
/// table, triangles, edges, groups, spaces and the output), freed when it returns.
pub const SCRATCH_BYTES_PER_INDEX: u64 = 256;

/// Bytes per vertex [`plan`] takes besides, for the coordinates through a texture transform.
pub const TRANSFORMED_BYTES_PER_VERTEX: u64 = 8;

/// MikkTSpace's tangents for a primitive, and the vertices to split ([`plan`]).
#[derive(Debug)]
pub struct Split {
    /// The new index list (copies past the primitive's vertices).
    indices: Vec<u32>,
    /// A tangent per vertex, copies included (glTF's convention).
    tangents: Vec<[f32; 4]>,
    /// The vertex each copy is made from.
    sources: Vec<u32>,
}

impl Split {
    /// The vertices this split adds.
    pub fn copies(&self) -> usize {
        self.sources.len()
    }

    /// Bytes the primitive keeps once [`Split::apply`]'d: the tangents and the copies of every
    /// vertex stream and morph delta.
    pub fn kept_bytes(&self, primitive: &Primitive) -> u64 {
        let targets = primitive
            .targets
            .iter()
            .map(|t| !t.positions.is_empty() as u64 + !t.normals.is_empty() as u64 + !t.tangents.is_empty() as u64)
            .sum::<u64>();
        let per_copy = 12 + 12 + 8 + 8 + 16 + 16 + 32 + 16 + 12 * targets;
        (self.tangents.len() as u64 * 16).saturating_add((self.sources.len() as u64).saturating_mul(per_copy))
    }

    /// Gives `primitive` the tangents and the copies (each carrying every attribute and morph
    /// delta of its source), and records where the copies come from
    /// ([`Primitive::copied_from`], which sidecars' per-vertex data is numbered without).
    pub fn apply(self, primitive: &mut Primitive) {
        let Split { indices, tangents, sources } = self;
        fn extend<T: Copy>(stream: &mut Vec<T>, sources: &[u32]) {
            if stream.is_empty() {
                return;
            }
            let copies: Vec<T> = sources.iter().filter_map(|&s| stream.get(s as usize).copied()).collect();
            stream.extend(copies);
        }
        primitive.indices = indices;
        primitive.tangents = tangents;
        if sources.is_empty() {
            return;
        }
        extend(&mut primitive.positions, &sources);
        extend(&mut primitive.normals, &sources);
        extend(&mut primitive.uv0, &sources);
        extend(&mut primitive.uv1, &sources);
        extend(&mut primitive.colors, &sources);
        extend(&mut primitive.joints, &sources);
        extend(&mut primitive.weights, &sources);
        for target in &mut primitive.targets {
            extend(&mut target.positions, &sources);
            extend(&mut target.normals, &sources);
            extend(&mut target.tangents, &sources);
        }
        primitive.vertex_count = primitive.positions.len() as u32;
        primitive.copied_from.extend(sources);
    }
}

/// MikkTSpace's tangents for `primitive` from its positions, normals and texture coordinate
/// set `tex_coord` (the normal texture's) through `transform` (its `KHR_texture_transform`: the
/// frame follows the coordinates the normal map is sampled at, as the Khronos sample viewer's
/// derivative frame does; a rotated or mirrored map turns it), with each vertex whose corners
/// got different tangents split: the first tangent a vertex gets keeps it, each other one
/// makes a copy. `None` for a primitive that is not a triangle list, or lacks normals or that
/// set. Takes up to [`SCRATCH_BYTES_PER_INDEX`] per index (and [`TRANSFORMED_BYTES_PER_VERTEX`]
/// per vertex with a transform) while it runs; the importer checks that against its budget
/// first, and charges [`Split::kept_bytes`] before applying.
pub fn plan(primitive: &Primitive, tex_coord: u32, transform: &TextureTransform) -> Option<Split> {
    let n = primitive.positions.len();
    let uvs = if tex_coord == 1 { &primitive.uv1 } else { &primitive.uv0 };
    if primitive.topology != Topology::Triangles || primitive.normals.len() != n || uvs.len() != n || n == 0 {
        return None;
    }
    let transformed: Vec<[f32; 2]>;
    let uvs = if *transform == TextureTransform::default() {
        uvs
    } else {
        let m = transform.matrix();
        transformed = uvs.iter().map(|&[u, v]| m.transform_point2(glam::Vec2::new(u, v)).to_array()).collect();
        &transformed
    };
    let corner_tangents = mikktspace(&primitive.positions, &primitive.normals, uvs, &primitive.indices);
    let mut indices = primitive.indices.clone();
    let mut tangents: Vec<Option<[f32; 4]>> = vec![None; n];
    let mut copies: HashMap<(u32, [u32; 4]), u32> = HashMap::new();
    let mut sources: Vec<u32> = Vec::new();
    let mut extra: Vec<[f32; 4]> = Vec::new();
    let whole = indices.len() / 3 * 3;
    for (index, tangent) in indices[..whole].iter_mut().zip(corner_tangents) {
        let v = *index as usize;
        let Some(slot) = tangents.get_mut(v) else { continue };
        match slot {
            None => *slot = Some(tangent),
            Some(kept) if kept.map(f32::to_bits) == tangent.map(f32::to_bits) => {}
            Some(_) => {
                let key = (*index, tangent.map(f32::to_bits));
                let next = (n + sources.len()) as u32;
                let copy = *copies.entry(key).or_insert_with(|| {
                    sources.push(key.0);
                    extra.push(tangent);
                    next
                });
                *index = copy;
            }
        }
    }
    // glTF's v runs the other way (see the module's documentation).
    for t in tangents.iter_mut().flatten().chain(&mut extra) {
        t[3] = -t[3];
    }
    // Vertices no triangle uses get a tangent along +X.
    let tangents = tangents.into_iter().map(|t| t.unwrap_or([1.0, 0.0, 0.0, 1.0])).chain(extra).collect();
    Some(Split { indices, tangents, sources })
}

/// [`plan`] and [`Split::apply`] without a budget; whether the primitive took tangents.
pub fn generate(primitive: &mut Primitive, tex_coord: u32, transform: &TextureTransform) -> bool {
    match plan(primitive, tex_coord, transform) {
        Some(split) => {
            split.apply(primitive);
            true
        }
        None => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hostile_meshes_give_a_tangent_per_corner() {
        // A fan of 4,000 triangles on one vertex, an edge 4,000 triangles share, non-finite and
        // degenerate corners, indices out of range and a trailing partial triangle.
        let m = 4000u32;
        let mut positions = vec![[0.0, 0.0, 0.0]];
        let mut uvs = vec![[0.5, 0.5]];
        for k in 0..=m {
            let a = k as f32 / m as f32 * std::f32::consts::TAU;
            positions.push([a.cos(), a.sin(), 0.0]);
            uvs.push([0.5 + 0.5 * a.cos(), 0.5 - 0.5 * a.sin()]);
        }
        let normals = vec![[0.0, 0.0, 1.0]; positions.len()];
        let fan: Vec<u32> = (0..m).flat_map(|k| [0, k + 1, k + 2]).collect();
        let t = mikktspace(&positions, &normals, &uvs, &fan);
        assert_eq!(t.len(), fan.len());
        assert!(t.iter().all(|c| c.iter().all(|x| x.is_finite())));
        let shared: Vec<u32> = (0..m).flat_map(|k| [0, 1, k + 2]).collect();
        assert_eq!(mikktspace(&positions, &normals, &uvs, &shared).len(), shared.len());
        let mut broken = positions.clone();
        broken[3] = [f32::NAN, 0.0, f32::INFINITY];
        let odd = [0, 1, 1, 0, 2, 3, 9_999_999, 1, 2, 0];
        let t = mikktspace(&broken, &normals, &uvs, &odd);
        assert_eq!(t.len(), 9);
    }

    #[test]
    fn a_quad_mapped_straight_gets_the_u_direction() {
        let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        let normals = [[0.0, 0.0, 1.0]; 4];
        // v runs down the image: +y in space is −v.
        let uvs = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
        let t = mikktspace(&positions, &normals, &uvs, &[0, 1, 2, 0, 2, 3]);
        assert_eq!(t.len(), 6);
        for corner in t {
            assert!(Vec3::new(corner[0], corner[1], corner[2]).abs_diff_eq(Vec3::X, 1e-6), "{corner:?}");
            // The texture is mirrored (v runs down the image while y runs up): w = −1.
            assert_eq!(corner[3], -1.0);
        }
    }
}
