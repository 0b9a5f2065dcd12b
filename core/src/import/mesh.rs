//! Meshes and primitives: vertex attributes, skin influences (renormalized), indices
//! (strips, fans and loops converted to lists), morph targets, bounds.

use super::Cx;
use super::accessor::Accessors;
use super::json::Value;
use super::json::{Obj, child, member_error, objects, opt_f32_list, opt_index, opt_object, opt_u64};
use crate::asset::{Mesh, MorphTarget, Primitive, Topology};
use crate::error::ImportError;
use crate::math::Vec4;

/// Largest deviation of a weight sum from 1 accepted without a warning (quantized
/// weights round to about 1/255 per component).
const WEIGHT_SUM_TOLERANCE: f32 = 8e-3;

/// A mesh plus, per primitive, its index in the file and its largest weighted joint index
/// (checked against the skins of the nodes that draw it).
pub(crate) struct ImportedMesh {
    pub mesh: Mesh,
    pub max_joints: Vec<(usize, Option<u16>)>,
}

/// Parses every mesh.
pub(crate) fn meshes(cx: &mut Cx<'_>, material_count: usize) -> Result<Vec<ImportedMesh>, ImportError> {
    let mut out = Vec::new();
    for (mesh, ptr) in objects(cx.root, "meshes", "")? {
        out.push(parse_mesh(cx, mesh, &ptr, material_count)?);
    }
    Ok(out)
}

fn parse_mesh(cx: &mut Cx<'_>, mesh: &Obj, ptr: &str, material_count: usize) -> Result<ImportedMesh, ImportError> {
    let prims = objects(mesh, "primitives", ptr)?;
    if prims.is_empty() {
        return Err(member_error(ptr, "primitives", "a mesh needs at least one primitive"));
    }
    let mut primitives = Vec::with_capacity(prims.len());
    let mut max_joints = Vec::with_capacity(prims.len());
    for (index, (prim, pptr)) in prims.iter().enumerate() {
        // Valid glTF, but nothing to draw: left out (the other primitives keep their indices in messages).
        if opt_object(prim, "attributes", pptr)?.is_some_and(|a| !a.contains_key("POSITION")) {
            cx.warn(
                child(pptr, "attributes"),
                "no POSITION attribute: the primitive has nothing to draw and is left out",
            );
            continue;
        }
        let (p, max_joint) = parse_primitive(cx, prim, pptr, material_count)?;
        if let Some(first) = primitives.first().map(|f: &Primitive| f.targets.len())
            && p.targets.len() != first
        {
            return Err(member_error(
                pptr,
                "targets",
                format!("{} morph targets, but primitive 0 has {first}", p.targets.len()),
            ));
        }
        primitives.push(p);
        max_joints.push((index, max_joint));
    }
    let target_count = primitives.first().map_or(0, |p| p.targets.len());
    let weights = match opt_f32_list(mesh, "weights", ptr)? {
        // Every primitive left out: the declared weights stay (nodes' weights are counted by them).
        Some(w) if primitives.is_empty() => w,
        Some(w) if w.len() != target_count => {
            return Err(member_error(ptr, "weights", format!("{} weights for {target_count} morph targets", w.len())));
        }
        Some(w) => w,
        None => vec![0.0; target_count],
    };
    let target_names = mesh
        .get("extras")
        .and_then(Value::as_object)
        .and_then(|e| e.get("targetNames"))
        .and_then(Value::as_array)
        .map(|names| names.iter().filter_map(Value::as_str).map(str::to_owned).collect())
        .unwrap_or_default();
    Ok(ImportedMesh { mesh: Mesh { name: super::json::name(mesh), primitives, weights, target_names }, max_joints })
}

/// Refuses an attribute accessor whose count differs from the vertex count.
fn check_count(cx: &Cx<'_>, accessor: u32, vertex_count: usize, ptr: &str) -> Result<(), ImportError> {
    let count = cx.accessors.get(accessor)?.count;
    if count != vertex_count as u64 {
        return Err(ImportError::new(
            ptr,
            format!("accessor {accessor} has {count} elements, POSITION has {vertex_count}"),
        ));
    }
    Ok(())
}

/// Reads the optional float attribute `name` of `attributes` (checked against the vertex count).
fn attribute<const N: usize>(
    cx: &mut Cx<'_>,
    attributes: &Obj,
    ptr: &str,
    name: &str,
    types: &[&str],
    vertex_count: usize,
) -> Result<Vec<[f32; N]>, ImportError> {
    let Some(a) = opt_index(attributes, name, ptr, cx.accessors.len(), "accessor")? else { return Ok(Vec::new()) };
    let p = child(ptr, name);
    check_count(cx, a, vertex_count, &p)?;
    cx.accessors.read_f32::<N>(a, &p, types, true, &mut cx.budget)
}

fn parse_primitive(
    cx: &mut Cx<'_>,
    prim: &Obj,
    ptr: &str,
    material_count: usize,
) -> Result<(Primitive, Option<u16>), ImportError> {
    let aptr = child(ptr, "attributes");
    let attributes = opt_object(prim, "attributes", ptr)?.ok_or_else(|| ImportError::new(&aptr, "missing"))?;
    let position = opt_index(attributes, "POSITION", &aptr, cx.accessors.len(), "accessor")?
        .ok_or_else(|| member_error(&aptr, "POSITION", "missing (primitives without positions are not supported)"))?;
    let position_ptr = child(&aptr, "POSITION");
    let positions = cx.accessors.read_f32::<3>(position, &position_ptr, &["VEC3"], true, &mut cx.budget)?;
    let vertex_count = positions.len();
    let vertex_count_u32 =
        u32::try_from(vertex_count).map_err(|_| ImportError::new(&position_ptr, "more than 2^32 vertices"))?;
    let normals = attribute::<3>(cx, attributes, &aptr, "NORMAL", &["VEC3"], vertex_count)?;
    let tangents = attribute::<4>(cx, attributes, &aptr, "TANGENT", &["VEC4"], vertex_count)?;
    let uv0 = attribute::<2>(cx, attributes, &aptr, "TEXCOORD_0", &["VEC2"], vertex_count)?;
    let uv1 = attribute::<2>(cx, attributes, &aptr, "TEXCOORD_1", &["VEC2"], vertex_count)?;
    let color_type = match opt_index(attributes, "COLOR_0", &aptr, cx.accessors.len(), "accessor")? {
        Some(a) => Some(cx.accessors.get(a)?.type_name),
        None => None,
    };
    let colors = match color_type {
        Some("VEC3") => attribute::<3>(cx, attributes, &aptr, "COLOR_0", &["VEC3"], vertex_count)?
            .into_iter()
            .map(|[r, g, b]| [r, g, b, 1.0])
            .collect(),
        _ => attribute::<4>(cx, attributes, &aptr, "COLOR_0", &["VEC4"], vertex_count)?,
    };
    let mut colors = colors;
    let outside = colors.iter().flatten().filter(|c| !(0.0..=1.0).contains(*c)).count();
    if outside > 0 {
        colors.iter_mut().flatten().for_each(|c| *c = c.clamp(0.0, 1.0));
        cx.warn(child(&aptr, "COLOR_0"), format!("{outside} colour components outside 0..1; clamped"));
    }
    let (joints, weights, max_joint) = influences(cx, attributes, &aptr, vertex_count)?;

    let mode = opt_u64(prim, "mode", ptr)?.unwrap_or(4);
    let indices_ptr = child(ptr, "indices");
    let raw: Vec<u32> = match opt_index(prim, "indices", ptr, cx.accessors.len(), "accessor")? {
        Some(a) => {
            let list = cx.accessors.read_u32::<1>(a, &indices_ptr, &["SCALAR"], &mut cx.budget)?;
            // The largest index found in the same pass (the one out of range looked for only
            // to name it).
            let mut largest = 0;
            let list: Vec<u32> = list
                .into_iter()
                .map(|[i]| {
                    largest = largest.max(i);
                    i
                })
                .collect();
            if largest >= vertex_count_u32
                && let Some((k, &i)) = list.iter().enumerate().find(|&(_, &i)| i >= vertex_count_u32)
            {
                return Err(ImportError::new(
                    indices_ptr,
                    format!("index {i} at position {k} is out of range (vertex count {vertex_count})"),
                ));
            }
            list
        }
        None => {
            cx.budget.take_items(vertex_count as u64, 4, ptr, "generated indices")?;
            (0..vertex_count_u32).collect()
        }
    };
    let (topology, indices) = to_list(cx, mode, raw, ptr)?;

    let mut targets = Vec::new();
    for (target, tptr) in objects(prim, "targets", ptr)? {
        // A target may move only what the primitive has.
        for (name, base) in [("NORMAL", normals.is_empty()), ("TANGENT", tangents.is_empty())] {
            if base && target.contains_key(name) {
                cx.warn(child(&tptr, name), format!("the primitive has no {name} for this target to move; ignored"));
            }
        }
        targets.push(MorphTarget {
            positions: attribute::<3>(cx, target, &tptr, "POSITION", &["VEC3"], vertex_count)?,
            normals: if normals.is_empty() {
                Vec::new()
            } else {
                attribute::<3>(cx, target, &tptr, "NORMAL", &["VEC3"], vertex_count)?
            },
            tangents: if tangents.is_empty() {
                Vec::new()
            } else {
                attribute::<3>(cx, target, &tptr, "TANGENT", &["VEC3"], vertex_count)?
            },
        });
    }
    let material = opt_index(prim, "material", ptr, material_count, "material")?;
    // Positions are finite (read so): a comparison and a select, all three axes at once (not
    // `f32::min`, whose NaN rule wasm has no instruction for: a call a component).
    let (lo, hi) = positions.iter().fold((Vec4::INFINITY, Vec4::NEG_INFINITY), |(lo, hi), &[x, y, z]| {
        let p = Vec4::new(x, y, z, 0.0);
        (Vec4::select(p.cmplt(lo), p, lo), Vec4::select(p.cmpgt(hi), p, hi))
    });
    let bounds = (lo.truncate().to_array(), hi.truncate().to_array());
    let primitive = Primitive {
        topology,
        vertex_count: vertex_count_u32,
        positions,
        normals,
        tangents,
        copied_from: Vec::new(),
        uv0,
        uv1,
        colors,
        joints,
        weights,
        indices,
        material,
        targets,
        bounds,
    };
    Ok((primitive, max_joint))
}

/// Joints and weights per vertex, and the largest weighted joint index.
type Influences = (Vec<[u16; 8]>, Vec<[f32; 8]>, Option<u16>);
/// [`Influences`] with how many vertices needed repair (what is warned about).
type Repaired = (Vec<[u16; 8]>, Vec<[f32; 8]>, Option<u16>, usize);

/// Skin influences from JOINTS_0/WEIGHTS_0 (and _1): up to 8 per vertex, renormalized
/// (one warning per primitive), zero-weight slots pointing at joint 0. Returns the largest
/// weighted joint index.
fn influences(cx: &mut Cx<'_>, attributes: &Obj, aptr: &str, vertex_count: usize) -> Result<Influences, ImportError> {
    let mut joints: Vec<[u16; 8]> = Vec::new();
    let mut weights: Vec<[f32; 8]> = Vec::new();
    // The slots the file fills: 4 per set (the others stay 0 and are left alone below, with the
    // same result as going over all 8: a zero weight adds nothing, divides to zero and points at
    // joint 0 already).
    let mut used = 0usize;
    for set in 0..2 {
        let (jname, wname) = (format!("JOINTS_{set}"), format!("WEIGHTS_{set}"));
        let j = opt_index(attributes, &jname, aptr, cx.accessors.len(), "accessor")?;
        let w = opt_index(attributes, &wname, aptr, cx.accessors.len(), "accessor")?;
        let (j, w) = match (j, w) {
            (None, None) => break,
            (Some(j), Some(w)) => (j, w),
            _ => return Err(ImportError::new(aptr, format!("{jname} and {wname} must come together"))),
        };
        let (jptr, wptr) = (child(aptr, &jname), child(aptr, &wname));
        check_count(cx, j, vertex_count, &jptr)?;
        check_count(cx, w, vertex_count, &wptr)?;
        if !cx.accessors.is_small_uint(j) {
            return Err(ImportError::new(&jptr, "joints must be UNSIGNED_BYTE or UNSIGNED_SHORT"));
        }
        if set == 0 {
            cx.budget.take_items(vertex_count as u64, 64, aptr, "skin influences")?;
            // The common skin, one set of dense VEC4s, read and renormalized in one pass (both
            // members looked up as the loop's next round would, a second set or any error there
            // leaving it to the loop).
            let second = |name: &str| opt_index(attributes, name, aptr, cx.accessors.len(), "accessor");
            if matches!((second("JOINTS_1"), second("WEIGHTS_1")), (Ok(None), Ok(None)))
                && let Some(found) = one_dense_set(&cx.accessors, j, w, vertex_count)?
            {
                return Ok(warn_repaired(cx, aptr, vertex_count, found));
            }
        }
        let js = cx.accessors.read_u32::<4>(j, &jptr, &["VEC4"], &mut cx.budget)?;
        let ws = cx.accessors.read_f32::<4>(w, &wptr, &["VEC4"], false, &mut cx.budget)?;
        // JOINTS are 8 or 16 bits (checked above), so they fit u16.
        let joint = |x: u32| u16::try_from(x).unwrap_or(u16::MAX);
        if set == 0 {
            joints = js.iter().map(|j| [joint(j[0]), joint(j[1]), joint(j[2]), joint(j[3]), 0, 0, 0, 0]).collect();
            weights = ws.iter().map(|w| [w[0], w[1], w[2], w[3], 0.0, 0.0, 0.0, 0.0]).collect();
        } else {
            for ((to_j, to_w), (jv, wv)) in joints.iter_mut().zip(weights.iter_mut()).zip(js.iter().zip(&ws)) {
                to_j[4..].copy_from_slice(&jv.map(joint));
                to_w[4..].copy_from_slice(wv);
            }
        }
        used = set * 4 + 4;
    }
    let mut repaired = 0usize;
    let mut max_joint: Option<u16> = None;
    for (j, w) in joints.iter_mut().zip(weights.iter_mut()) {
        // The slots the file fills, as fixed-size arrays (the loops below unroll).
        let (defect, most) = match used {
            4 => renormalize_four(j, w),
            _ => renormalize_eight(j, w),
        };
        repaired += usize::from(defect);
        // `None` (no weighted joint) orders below every joint.
        max_joint = max_joint.max(most);
    }
    Ok(warn_repaired(cx, aptr, vertex_count, (joints, weights, max_joint, repaired)))
}

/// The influences with how many vertices needed repair, which is warned about.
fn warn_repaired(
    cx: &mut Cx<'_>,
    aptr: &str,
    vertex_count: usize,
    (joints, weights, max_joint, repaired): Repaired,
) -> Influences {
    if repaired > 0 {
        cx.warn(
            child(aptr, "WEIGHTS_0"),
            format!(
                "skin weights of {repaired} of {vertex_count} vertices did not sum to 1 (or were negative, non-finite or all zero); renormalized, all-zero vertices bound to their first joint"
            ),
        );
    }
    (joints, weights, max_joint)
}

/// [`influences`] of one set (JOINTS_0 and WEIGHTS_0 of `vertex_count` elements each, checked)
/// where both are tightly packed VEC4s, the joints unnormalized 8- or 16-bit integers: each
/// vertex read, renormalized ([`renormalize_four`]) and stored in one pass, with the same
/// results as reading both accessors whole first; with how many vertices needed repair. `None`
/// for anything else (the general path reads it, or names what is wrong).
pub(super) fn one_dense_set(
    accessors: &Accessors,
    j: u32,
    w: u32,
    vertex_count: usize,
) -> Result<Option<Repaired>, ImportError> {
    use super::accessor::{Component, DenseRun};
    let (Some(joints), Some(weights)) = (accessors.dense_vec4(j)?, accessors.dense_vec4(w)?) else {
        return Ok(None);
    };
    let (
        DenseRun { component: jc, normalized: false, bytes: jb, packed: true },
        DenseRun { component: wc, normalized: n, bytes: wb, packed: true },
    ) = (joints, weights)
    else {
        return Ok(None);
    };
    if !matches!(jc, Component::U8 | Component::U16) || !matches!(wc, Component::F32 | Component::U8 | Component::U16) {
        return Ok(None);
    }
    let mut out = (vec![[0_u16; 8]; vertex_count], vec![[0.0_f32; 8]; vertex_count], None, 0);
    let (narrow, wide) = (jb.as_chunks::<4>().0, jb.as_chunks::<8>().0);
    let (floats, bytes, shorts) = (wb.as_chunks::<16>().0, wb.as_chunks::<4>().0, wb.as_chunks::<8>().0);
    let scale = wc.normalized_scale().filter(|_| n);
    // One loop for each layout (its reads known in the loop).
    match (jc, wc) {
        (Component::U8, Component::F32) => fill_one_set(&mut out, narrow, floats, lanes_u8, weights_f32),
        (Component::U16, Component::F32) => fill_one_set(&mut out, wide, floats, lanes_u16, weights_f32),
        (Component::U8, Component::U8) => {
            fill_one_set(&mut out, narrow, bytes, lanes_u8, |b| weights_int(u8x4(b), scale))
        }
        (Component::U16, Component::U8) => {
            fill_one_set(&mut out, wide, bytes, lanes_u16, |b| weights_int(u8x4(b), scale))
        }
        (Component::U8, Component::U16) => {
            fill_one_set(&mut out, narrow, shorts, lanes_u8, |b| weights_int(u16x4(b), scale))
        }
        // Both 16-bit (the types are checked above).
        _ => fill_one_set(&mut out, wide, shorts, lanes_u16, |b| weights_int(u16x4(b), scale)),
    }
    Ok(Some(out))
}

/// The pass of [`one_dense_set`]: element `i` of both runs into vertex `i`.
#[inline(always)]
fn fill_one_set<const J: usize, const W: usize>(
    (joints, weights, most, repaired): &mut Repaired,
    joint_elements: &[[u8; J]],
    weight_elements: &[[u8; W]],
    read_joints: impl Fn(&[u8; J]) -> u64,
    read_weights: impl Fn(&[u8; W]) -> [f32; 4],
) {
    // Every vertex has a weighted joint ([`renormalized`]), so the largest is `Some` as soon as
    // there is a vertex.
    let mut largest = 0_u16;
    for ((j, w), (jb, wb)) in joints.iter_mut().zip(weights.iter_mut()).zip(joint_elements.iter().zip(weight_elements))
    {
        let (vertex_joints, vertex_weights, defect) = renormalized(read_joints(jb), Vec4::from_array(read_weights(wb)));
        let vertex_joints = unlaned(vertex_joints);
        [j[0], j[1], j[2], j[3]] = vertex_joints;
        [w[0], w[1], w[2], w[3]] = vertex_weights.to_array();
        *repaired += usize::from(defect);
        largest = largest.max(largest_of(vertex_joints));
    }
    if !joints.is_empty() {
        *most = (*most).max(Some(largest));
    }
}

/// The largest of four joints (two comparisons deep).
#[inline(always)]
fn largest_of(j: [u16; 4]) -> u16 {
    j[0].max(j[1]).max(j[2].max(j[3]))
}

/// Four joints in the 16-bit lanes of a word, the first lowest (as [`renormalized`] keeps them).
#[inline(always)]
fn laned(j: [u16; 4]) -> u64 {
    u64::from(j[0]) | u64::from(j[1]) << 16 | u64::from(j[2]) << 32 | u64::from(j[3]) << 48
}

/// The four joints of [`laned`].
#[inline(always)]
fn unlaned(j: u64) -> [u16; 4] {
    // Truncations: each takes its lane.
    [j as u16, (j >> 16) as u16, (j >> 32) as u16, (j >> 48) as u16]
}

/// Four 8-bit joints as [`laned`].
#[inline(always)]
fn lanes_u8(b: &[u8; 4]) -> u64 {
    laned(u8x4(b))
}

/// Four 16-bit little-endian joints as [`laned`]: the bytes as they are.
#[inline(always)]
fn lanes_u16(b: &[u8; 8]) -> u64 {
    u64::from_le_bytes(*b)
}

/// The lanes of [`laned`] joints kept for each four-bit mask of weighted slots.
const KEPT_LANES: [u64; 16] = {
    let mut masks = [0_u64; 16];
    let mut i = 0;
    while i < 16 {
        let mut lane = 0;
        while lane < 4 {
            if i & (1 << lane) != 0 {
                masks[i] |= 0xffff << (16 * lane);
            }
            lane += 1;
        }
        i += 1;
    }
    masks
};

/// Four 8-bit unsigned integers (joints, or weights before [`weights_int`]).
#[inline(always)]
fn u8x4(b: &[u8; 4]) -> [u16; 4] {
    [u16::from(b[0]), u16::from(b[1]), u16::from(b[2]), u16::from(b[3])]
}

/// The four little-endian pairs of eight bytes.
#[inline(always)]
fn pairs(b: &[u8; 8]) -> [[u8; 2]; 4] {
    [[b[0], b[1]], [b[2], b[3]], [b[4], b[5]], [b[6], b[7]]]
}

/// Four 16-bit little-endian unsigned integers (as [`u8x4`]).
#[inline(always)]
fn u16x4(b: &[u8; 8]) -> [u16; 4] {
    let [x, y, z, w] = pairs(b);
    [u16::from_le_bytes(x), u16::from_le_bytes(y), u16::from_le_bytes(z), u16::from_le_bytes(w)]
}

/// Four unsigned integer weights as floats, divided by `scale` (their type's largest value)
/// where they are normalized, four lanes at once (each as the accessor's reads divide one).
#[inline(always)]
fn weights_int(v: [u16; 4], scale: Option<f32>) -> [f32; 4] {
    let v = Vec4::new(f32::from(v[0]), f32::from(v[1]), f32::from(v[2]), f32::from(v[3]));
    scale.map_or(v, |s| v / Vec4::splat(s)).to_array()
}

/// Four little-endian floats.
#[inline(always)]
fn weights_f32(b: &[u8; 16]) -> [f32; 4] {
    [
        f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        f32::from_le_bytes([b[4], b[5], b[6], b[7]]),
        f32::from_le_bytes([b[8], b[9], b[10], b[11]]),
        f32::from_le_bytes([b[12], b[13], b[14], b[15]]),
    ]
}

/// [`renormalize_eight`] of the first four slots in one vector: the same results (each lane's
/// division is correctly rounded, the sum is taken in the same order).
fn renormalize_four(j: &mut [u16; 8], w: &mut [f32; 8]) -> (bool, Option<u16>) {
    let (joints, weights, defect) = renormalized(laned([j[0], j[1], j[2], j[3]]), Vec4::new(w[0], w[1], w[2], w[3]));
    let joints = unlaned(joints);
    [j[0], j[1], j[2], j[3]] = joints;
    [w[0], w[1], w[2], w[3]] = weights.to_array();
    (defect, Some(largest_of(joints)))
}

/// [`renormalize_four`] of one vertex's four joints ([`laned`]) and weights: the joints
/// (zero-weight ones pointed at joint 0), the weights and whether they needed repair. At least
/// one weight is nonzero afterwards (the largest is at least a quarter of the sum it is divided
/// by). Weights that are all at least zero and sum to 1 within the tolerance (every vertex of a
/// sound file) take one test and a division; any others go to [`repair_weights`].
#[inline(always)]
fn renormalized(joints: u64, v: Vec4) -> (u64, Vec4, bool) {
    let sum = v.x + v.y + v.z + v.w;
    // Every lane at least zero (so none is NaN) and the sum near 1 (so none is infinite): as
    // `repair_weights` would leave them, and sound.
    let (v, defect) = if v.cmpge(Vec4::ZERO).all() && (sum - 1.0).abs() <= WEIGHT_SUM_TOLERANCE {
        (v / sum, false)
    } else {
        repair_weights(v)
    };
    let weighted = v.cmpne(Vec4::ZERO).bitmask();
    (joints & KEPT_LANES[(weighted & 15) as usize], v, defect)
}

/// The weights of [`renormalized`] that need repair: negative and non-finite ones zeroed and
/// the rest divided by their sum, or all zero: bound to the first joint.
#[cold]
#[inline(never)]
fn repair_weights(v: Vec4) -> (Vec4, bool) {
    let v = Vec4::select(!v.is_finite_mask() | v.cmplt(Vec4::ZERO), Vec4::ZERO, v);
    let sum = v.x + v.y + v.z + v.w;
    if sum > 0.0 && sum.is_finite() { (v / sum, true) } else { (Vec4::X, true) }
}

/// Renormalizes one vertex's eight weights (negative or non-finite ones zeroed; all zero:
/// bound to its first joint) and points its zero-weight slots at joint 0; returns whether it
/// needed repair and its largest weighted joint.
fn renormalize_eight(j: &mut [u16; 8], w: &mut [f32; 8]) -> (bool, Option<u16>) {
    let mut defect = false;
    for x in w.iter_mut() {
        if !x.is_finite() || *x < 0.0 {
            *x = 0.0;
            defect = true;
        }
    }
    let sum: f32 = w.iter().sum();
    if sum <= 0.0 || !sum.is_finite() {
        *w = [0.0; 8];
        w[0] = 1.0;
        defect = true;
    } else {
        defect |= (sum - 1.0).abs() > WEIGHT_SUM_TOLERANCE;
        for x in w.iter_mut() {
            *x /= sum;
        }
    }
    (defect, weighted_joints::<8>(j, w))
}

/// Points the zero-weight slots among the first `N` at joint 0; returns the largest joint with
/// a weight.
fn weighted_joints<const N: usize>(j: &mut [u16; 8], w: &[f32; 8]) -> Option<u16> {
    let mut most: Option<u16> = None;
    for (joint, &weight) in j.iter_mut().zip(w).take(N) {
        if weight == 0.0 {
            *joint = 0;
        } else {
            most = Some(most.map_or(*joint, |m| m.max(*joint)));
        }
    }
    most
}

/// Converts `mode` (glTF primitive mode) and its index sequence into a list topology.
fn to_list(cx: &mut Cx<'_>, mode: u64, raw: Vec<u32>, ptr: &str) -> Result<(Topology, Vec<u32>), ImportError> {
    let n = raw.len();
    let take = |cx: &mut Cx<'_>, count: usize| cx.budget.take_items(count as u64, 4, ptr, "converted indices");
    let (topology, mut list) = match mode {
        0 => (Topology::Points, raw),
        1 => (Topology::Lines, raw),
        2 | 3 => {
            // Line loop (2) or strip (3) -> segments.
            let segments = if mode == 2 && n > 2 { n } else { n.saturating_sub(1) };
            take(cx, 2 * segments)?;
            let list = (0..segments).flat_map(|i| [raw[i], raw[(i + 1) % n]]).collect();
            (Topology::Lines, list)
        }
        4 => (Topology::Triangles, raw),
        5 | 6 => {
            let triangles = n.saturating_sub(2);
            take(cx, 3 * triangles)?;
            let list = (0..triangles)
                .flat_map(|i| match (mode, i % 2) {
                    (5, 0) => [raw[i], raw[i + 1], raw[i + 2]],
                    (5, _) => [raw[i], raw[i + 2], raw[i + 1]],
                    _ => [raw[i + 1], raw[i + 2], raw[0]],
                })
                .collect();
            (Topology::Triangles, list)
        }
        _ => return Err(member_error(ptr, "mode", format!("{mode} is not a valid primitive mode"))),
    };
    let per = match topology {
        Topology::Points => 1,
        Topology::Lines => 2,
        Topology::Triangles => 3,
    };
    if list.len() % per != 0 {
        cx.warn(
            ptr,
            format!("{} indices do not form whole {topology:?}; the last {} dropped", list.len(), list.len() % per),
        );
        list.truncate(list.len() - list.len() % per);
    }
    Ok((topology, list))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn four_weights_renormalize_as_eight_with_four_zero() {
        // Sums whose rounding depends on their order (left to right in both) among them.
        let q = |x: u8| f32::from(x) / 255.0;
        // Sums just inside and just outside the tolerance, either side of 1.
        let (above, below) = (1.0 + WEIGHT_SUM_TOLERANCE, 1.0 - WEIGHT_SUM_TOLERANCE);
        let cases: [[f32; 4]; 21] = [
            [above, 0.0, 0.0, 0.0],
            [f32::from_bits(above.to_bits() + 1), 0.0, 0.0, 0.0],
            [below, 0.0, 0.0, 0.0],
            [f32::from_bits(below.to_bits() - 1), 0.0, 0.0, 0.0],
            [0.5, 0.5, 0.004, 0.003],
            [0.5, 0.5, 0.005, 0.005],
            [0.5, 0.5, 0.01, -1e-30],
            [1.0, f32::MIN_POSITIVE / 4.0, 0.0, 0.0],
            [0.5, 0.25, 0.125, 0.125],
            [0.3, 0.3, 0.3, 0.3],
            [0.1, 0.2, 0.3, 0.4],
            [q(77), q(51), q(64), q(63)],
            [1e-8, 1.0, 1e8, 0.7],
            [f32::NAN, 0.5, 0.5, 0.0],
            [f32::INFINITY, 1.0, 0.0, 0.0],
            [f32::NEG_INFINITY, 0.7, 0.3, 0.0],
            [-0.5, 0.6, 0.4, 0.0],
            [-0.0, 1.0, 0.0, 0.0],
            [-0.0, -0.0, 0.0, 0.0],
            [f32::MAX, f32::MAX, 0.0, 0.0],
            [0.0; 4],
        ];
        for w4 in cases {
            let joints = [3u16, 9, 65535, 1];
            let (mut j4, mut w4a) = ([joints[0], joints[1], joints[2], joints[3], 0, 0, 0, 0], [0.0f32; 8]);
            w4a[..4].copy_from_slice(&w4);
            let (mut j8, mut w8) = (j4, w4a);
            let four = renormalize_four(&mut j4, &mut w4a);
            let eight = renormalize_eight(&mut j8, &mut w8);
            assert_eq!(four, eight, "{w4:?}");
            assert_eq!(j4, j8, "{w4:?}");
            assert_eq!(w4a.map(f32::to_bits), w8.map(f32::to_bits), "{w4:?}");
        }
    }
}
