//! Lighter triangle lists of a primitive for what needs its outline and not its detail: the
//! ground shadow's casters, drawn a second time for every copy of a model each frame.
//!
//! [`cluster_triangles`] is vertex clustering (Rossignac and Borrel): the primitive's bounds are
//! cut into cubic cells, the vertices in one cell become one (the vertex nearest their mean, so
//! the list indexes the same vertex streams and follows them as they are skinned or morphed),
//! and the triangles whose corners fall into fewer than three cells go. Vertices are merged only
//! with vertices that the same joint moves most, so that clustering never ties a limb to the
//! body beside it in the bind pose. Runs once per primitive at upload, not per frame.

use std::collections::{HashMap, HashSet};

use crate::asset::{Primitive, Topology};

/// Cells along the longest side of a primitive's bounds for its ground-shadow casters: a few
/// texels of the soft shadow's 128² mask for one model alone, which the mask's filter blurs
/// over, so the simplified casters' shadow is the full mesh's within a few levels
/// (tests/golden.rs measures it).
pub const SHADOW_CELLS: u32 = 32;

/// Cells for casters drawn at under [`COARSE_SCALE`] of the size one model alone is drawn at in
/// the shadow map (many copies share it): a cell is then no more texels than
/// [`SHADOW_CELLS`]' are for one model.
pub const COARSE_SHADOW_CELLS: u32 = 16;

/// See [`COARSE_SHADOW_CELLS`].
pub const COARSE_SCALE: f32 = 0.5;

/// Primitives with fewer triangles than this keep their own list: a second index buffer would
/// save next to nothing.
pub const MIN_TRIANGLES: usize = 64;

/// A simplified list is kept only when it has at most this share of the triangles.
pub const MAX_KEPT: f32 = 0.8;

/// Primitives with more triangles than this keep their own list: the clustering's time and
/// memory at upload stay bounded whatever a file declares.
pub const MAX_TRIANGLES: usize = 1 << 20;

/// No joint: the group of an unskinned primitive's vertices.
const NO_JOINT: u32 = u32::MAX;

/// The triangle list of `primitive` clustered on a grid of `cells` cells along its bounds'
/// longest side (see the module's documentation): indices into the primitive's own vertices,
/// each triangle's winding kept, no degenerate or repeated triangle. `None` when there is
/// nothing to gain: not a triangle list, fewer than [`MIN_TRIANGLES`] or more than
/// [`MAX_TRIANGLES`] triangles, bounds that are empty or not finite, an index out of range, or
/// more than [`MAX_KEPT`] of the triangles kept. Vertices with a non-finite position are never
/// merged.
pub fn cluster_triangles(primitive: &Primitive, cells: u32) -> Option<Vec<u32>> {
    let indices = &primitive.indices;
    let triangles = indices.len() / 3;
    if primitive.topology != Topology::Triangles || !(MIN_TRIANGLES..=MAX_TRIANGLES).contains(&triangles) {
        return None;
    }
    let representative = representatives(primitive, cells)?;
    let mut seen: HashSet<[u32; 3]> = HashSet::new();
    let mut out = Vec::new();
    for t in indices.chunks_exact(3) {
        let mut corner = [0u32; 3];
        for (c, &i) in corner.iter_mut().zip(t) {
            *c = *representative.get(i as usize)?;
        }
        let [a, b, c] = corner;
        if a == b || b == c || a == c {
            continue;
        }
        // The same triangle with the same winding, whichever corner it starts from.
        let first = if a < b && a < c {
            [a, b, c]
        } else if b < c {
            [b, c, a]
        } else {
            [c, a, b]
        };
        if seen.insert(first) {
            out.extend_from_slice(&corner);
        }
    }
    (out.len() as f32 <= MAX_KEPT * indices.len() as f32).then_some(out)
}

/// Each vertex's representative after clustering on `cells` cells along the bounds' longest
/// side: the vertex nearest the mean of those in its cell moved most by the same joint (itself
/// for a non-finite position). `None` for no cells or bounds that are empty or not finite.
fn representatives(primitive: &Primitive, cells: u32) -> Option<Vec<u32>> {
    let positions = &primitive.positions;
    let (min, max) = primitive.bounds;
    let extent = (0..3).map(|a| max[a] - min[a]).fold(0.0f32, f32::max);
    let finite_bounds = min.iter().chain(&max).all(|v| v.is_finite());
    if cells == 0 || !(finite_bounds && extent.is_finite() && extent > 0.0) {
        return None;
    }
    let scale = cells as f32 / extent;
    let skinned = primitive.joints.len() == positions.len() && primitive.weights.len() == positions.len();
    // `cells` cells an axis: the bounds' far face and any position outside them (bounds that
    // lie) fall into the edge cells.
    let last = (cells - 1) as f32;

    // Each vertex's cluster, and each cluster's sum of positions and count.
    let mut lookup: HashMap<([u32; 3], u32), u32> = HashMap::new();
    let mut sums: Vec<([f32; 3], u32)> = Vec::new();
    let mut cluster_of: Vec<u32> = Vec::with_capacity(positions.len());
    for (v, p) in positions.iter().enumerate() {
        let next = sums.len() as u32;
        let finite = p.iter().all(|c| c.is_finite());
        let id = if finite {
            let cell = [0, 1, 2].map(|a| ((p[a] - min[a]) * scale).clamp(0.0, last) as u32);
            let group = match (primitive.joints.get(v), primitive.weights.get(v)) {
                (Some(j), Some(w)) if skinned => crate::job::strongest_joint(j, w).map_or(NO_JOINT, u32::from),
                _ => NO_JOINT,
            };
            *lookup.entry((cell, group)).or_insert(next)
        } else {
            // A cluster of its own, never summed.
            next
        };
        if id == next {
            sums.push(([0.0; 3], 0));
        }
        if let Some((sum, n)) = sums.get_mut(id as usize)
            && finite
        {
            for a in 0..3 {
                sum[a] += p[a];
            }
            *n += 1;
        }
        cluster_of.push(id);
    }
    // Each cluster's representative: its vertex nearest the cluster's mean.
    let mut nearest: Vec<(u32, f32)> = vec![(u32::MAX, f32::INFINITY); sums.len()];
    for (v, (p, &id)) in positions.iter().zip(&cluster_of).enumerate() {
        let (Some(&(sum, n)), Some(best)) = (sums.get(id as usize), nearest.get_mut(id as usize)) else {
            continue;
        };
        let d = if n == 0 { 0.0 } else { (0..3).map(|a| (p[a] - sum[a] / n as f32).powi(2)).sum::<f32>() };
        if best.0 == u32::MAX || d < best.1 {
            *best = (v as u32, d);
        }
    }
    cluster_of.iter().map(|&id| nearest.get(id as usize).map(|n| n.0)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `n` × `n` grid of quads in the XY plane over [0, 1]², two triangles each,
    /// counter-clockwise seen from +Z.
    fn sheet(n: u32) -> Primitive {
        let mut positions = Vec::new();
        for y in 0..=n {
            for x in 0..=n {
                positions.push([x as f32 / n as f32, y as f32 / n as f32, 0.0]);
            }
        }
        let mut indices = Vec::new();
        let at = |x: u32, y: u32| y * (n + 1) + x;
        for y in 0..n {
            for x in 0..n {
                indices.extend_from_slice(&[at(x, y), at(x + 1, y), at(x + 1, y + 1)]);
                indices.extend_from_slice(&[at(x, y), at(x + 1, y + 1), at(x, y + 1)]);
            }
        }
        Primitive {
            vertex_count: positions.len() as u32,
            positions,
            indices,
            bounds: ([0.0; 3], [1.0, 1.0, 0.0]),
            ..Primitive::default()
        }
    }

    /// Twice the signed area seen from +Z.
    fn area(p: &Primitive, t: &[u32]) -> f32 {
        let [a, b, c] = [0, 1, 2].map(|i| p.positions[t[i] as usize]);
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    }

    #[test]
    fn a_dense_sheet_keeps_its_outline_with_fewer_triangles_of_the_same_winding() {
        let p = sheet(64);
        let out = cluster_triangles(&p, 16).expect("worth simplifying");
        let (before, after) = (p.indices.len() / 3, out.len() / 3);
        assert!(after * 8 < before, "{after} of {before} triangles kept");
        assert!(after >= 2 * 16 * 16 / 2, "{after} triangles cannot cover the sheet");
        // Every index is one of the primitive's vertices, every triangle faces +Z, and the
        // triangles still cover the sheet (their areas sum to most of its 1 × 1).
        let mut covered = 0.0;
        for t in out.chunks_exact(3) {
            assert!(t.iter().all(|&i| (i as usize) < p.positions.len()));
            let a = area(&p, t);
            assert!(a >= 0.0, "triangle {t:?} flipped");
            covered += a / 2.0;
        }
        assert!(covered > 0.85 && covered < 1.0001, "the triangles cover {covered} of the sheet");
        // No triangle twice, in any rotation.
        let mut seen = HashSet::new();
        for t in out.chunks_exact(3) {
            let mut k = [t[0], t[1], t[2]];
            while k[0] > k[1] || k[0] > k[2] {
                k.rotate_left(1);
            }
            assert!(seen.insert(k), "{t:?} twice");
        }
    }

    #[test]
    fn vertices_moved_most_by_different_joints_are_not_merged() {
        let mut p = sheet(64);
        // Columns 0..=33 follow joint 1, the rest joint 2: the seam cuts through the cells
        // [0.5, 0.5625) of a 16-cell grid.
        p.joints = p.positions.iter().map(|v| [if v[0] < 0.52 { 1 } else { 2 }, 0, 0, 0, 0, 0, 0, 0]).collect();
        p.weights = p.positions.iter().map(|_| [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]).collect();
        let joint_of = |i: u32| p.joints[i as usize][0];
        let rep = representatives(&p, 16).expect("clusters");
        for (v, &r) in rep.iter().enumerate() {
            assert_eq!(joint_of(v as u32), joint_of(r), "vertex {v} represented by {r}");
        }
        // Unskinned, the same cells merge across the seam: fewer triangles.
        let skinned = cluster_triangles(&p, 16).expect("worth simplifying").len();
        let plain = cluster_triangles(&sheet(64), 16).expect("worth simplifying").len();
        assert!(skinned > plain, "{skinned} indices skinned, {plain} without joints");
        // And the two sides stay joined: triangles with corners of both joints remain.
        let out = cluster_triangles(&p, 16).expect("worth simplifying");
        assert!(
            out.chunks_exact(3).any(|t| t.iter().any(|&i| joint_of(i) == 1) && t.iter().any(|&i| joint_of(i) == 2))
        );
    }

    #[test]
    fn nothing_to_gain_or_nothing_to_trust_gives_none() {
        // Too few triangles.
        assert!(cluster_triangles(&sheet(4), 2).is_none());
        // Already coarser than the grid: everything kept.
        assert!(cluster_triangles(&sheet(8), 64).is_none());
        // Not triangles.
        let lines = Primitive { topology: Topology::Lines, ..sheet(64) };
        assert!(cluster_triangles(&lines, 16).is_none());
        // Bounds that are not finite, or empty.
        let nan = Primitive { bounds: ([f32::NAN; 3], [1.0; 3]), ..sheet(64) };
        assert!(cluster_triangles(&nan, 16).is_none());
        let nan_max = Primitive { bounds: ([0.0; 3], [1.0, f32::NAN, 0.0]), ..sheet(64) };
        assert!(cluster_triangles(&nan_max, 16).is_none());
        let huge = Primitive { bounds: ([-3e38; 3], [3e38; 3]), ..sheet(64) };
        assert!(cluster_triangles(&huge, 16).is_none());
        let flat = Primitive { bounds: ([0.0; 3], [0.0; 3]), ..sheet(64) };
        assert!(cluster_triangles(&flat, 16).is_none());
        // An index past the vertices.
        let mut broken = sheet(64);
        broken.indices[7] = 1_000_000;
        assert!(cluster_triangles(&broken, 16).is_none());
        // No cells.
        assert!(cluster_triangles(&sheet(64), 0).is_none());
    }

    #[test]
    fn a_non_finite_vertex_is_never_merged_and_nothing_panics() {
        let mut p = sheet(64);
        p.positions[100] = [f32::NAN, 0.0, f32::INFINITY];
        p.positions[101] = [f32::NAN, 0.0, 0.0];
        let out = cluster_triangles(&p, 16).expect("worth simplifying");
        // The non-finite vertices stand for themselves alone.
        let rep = representatives(&p, 16).expect("clusters");
        assert_eq!((rep[100], rep[101]), (100, 101));
        assert!(rep.iter().enumerate().all(|(v, &r)| v == 100 || v == 101 || (r != 100 && r != 101)));
        assert!(out.contains(&100) && out.iter().all(|&i| (i as usize) < p.positions.len()));
        // Positions outside the bounds (a lying `bounds`) fall into the edge cells.
        let mut lying = sheet(64);
        lying.bounds = ([0.25; 3], [0.75, 0.75, 0.0]);
        let out = cluster_triangles(&lying, 16).expect("worth simplifying");
        assert!(out.iter().all(|&i| (i as usize) < lying.positions.len()));
    }
}
