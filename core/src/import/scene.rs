//! Nodes (transforms, hierarchy, traversal order), scenes and skins.

use super::Cx;
use super::json::{Obj, Ptr, array, check_index, child, items, objects, opt_f32_array, opt_f32_list, opt_index};
use crate::asset::{Node, Scene, Skin};
use crate::error::ImportError;
use crate::math::{Mat4, Quat, QuatExt, Transform, Vec3};

/// Nodes with parents assigned, and every node once, parents first.
pub(crate) struct Graph {
    pub nodes: Vec<Node>,
    pub order: Vec<u32>,
    /// `node.weights` from the file, per node (applied once meshes are known).
    pub file_weights: Vec<Option<Vec<f32>>>,
}

/// Parses every node and checks the hierarchy: a forest (one parent at most, no cycle)
/// no deeper than `max_node_depth`. Iterative, so deep chains cannot overflow the stack.
pub(crate) fn nodes(cx: &mut Cx<'_>, mesh_count: usize, skin_count: usize) -> Result<Graph, ImportError> {
    let list = items(cx.root, "nodes", &"")?;
    let n = list.len();
    cx.budget.take_items(n as u64, (size_of::<Node>() + 16) as u64, "/nodes", "nodes")?;
    let mut nodes = Vec::with_capacity(n);
    let mut file_weights = Vec::with_capacity(n);
    for (node, ptr) in &list {
        let children = array(node, "children", ptr)?
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let p = Ptr::element(ptr, "children", i);
                let index = super::json::as_u64(c).ok_or_else(|| ImportError::new(p, "expected a node index"))?;
                check_index(index, n, "node", &p)
            })
            .collect::<Result<Vec<_>, _>>()?;
        nodes.push(Node {
            name: super::json::name(node),
            parent: None,
            children,
            rest: rest_transform(cx, node, ptr)?,
            mesh: opt_index(node, "mesh", ptr, mesh_count, "mesh")?,
            skin: opt_index(node, "skin", ptr, skin_count, "skin")?,
            weights: Vec::new(),
        });
        file_weights.push(opt_f32_list(node, "weights", ptr)?);
    }
    for p in 0..n {
        for i in 0..nodes[p].children.len() {
            let c = nodes[p].children[i];
            let ptr = || format!("/nodes/{p}/children/{i}");
            if c as usize == p {
                return Err(ImportError::new(ptr(), format!("node {p} is its own child (a cycle)")));
            }
            if let Some(other) = nodes[c as usize].parent {
                return Err(ImportError::new(
                    ptr(),
                    format!("node {c} already has parent {other}; a node may have only one parent"),
                ));
            }
            nodes[c as usize].parent = Some(p as u32);
        }
    }
    let order = traversal_order(&nodes, cx.options.max_node_depth)?;
    Ok(Graph { nodes, order, file_weights })
}

/// Breadth-first order from the roots; refuses nodes deeper than `max_depth` and nodes
/// never reached (which, with one parent each, sit on a cycle).
fn traversal_order(nodes: &[Node], max_depth: u32) -> Result<Vec<u32>, ImportError> {
    let mut order: Vec<u32> = Vec::with_capacity(nodes.len());
    let mut depth = vec![0u32; nodes.len()];
    for (i, node) in nodes.iter().enumerate() {
        if node.parent.is_none() {
            order.push(i as u32);
            depth[i] = 1;
        }
    }
    let mut head = 0;
    while let Some(&n) = order.get(head) {
        head += 1;
        for &c in &nodes[n as usize].children {
            let d = depth[n as usize] + 1;
            if d > max_depth {
                return Err(ImportError::new(
                    format!("/nodes/{c}"),
                    format!("node is nested deeper than the limit of {max_depth} levels"),
                ));
            }
            depth[c as usize] = d;
            order.push(c);
        }
    }
    if order.len() < nodes.len() {
        let stray = depth.iter().position(|&d| d == 0).unwrap_or(0);
        return Err(ImportError::new(format!("/nodes/{stray}"), "node is part of a cycle (no root node leads to it)"));
    }
    Ok(order)
}

/// The local transform of a node: `matrix` decomposed, or TRS with the rotation normalized.
fn rest_transform(cx: &mut Cx<'_>, node: &Obj, ptr: &Ptr<'_>) -> Result<Transform, ImportError> {
    if let Some(m) = opt_f32_array::<16>(node, "matrix", ptr)? {
        let trs: Vec<&str> =
            ["translation", "rotation", "scale"].into_iter().filter(|k| node.contains_key(k)).collect();
        if !trs.is_empty() {
            cx.warn(
                ptr.to_string(),
                format!("the node has a matrix and {}; the matrix is used (glTF allows only one)", trs.join(", ")),
            );
        }
        let matrix = Mat4::from_cols_array(&m);
        if matrix == Mat4::IDENTITY {
            return Ok(Transform::IDENTITY);
        }
        return Ok(Transform::from_mat4(&matrix).unwrap_or_else(|| {
            cx.warn(child(ptr, "matrix"), "matrix is singular or not affine; the identity is used");
            Transform::IDENTITY
        }));
    }
    let translation = Vec3::from(opt_f32_array::<3>(node, "translation", ptr)?.unwrap_or([0.0; 3]));
    let scale = Vec3::from(opt_f32_array::<3>(node, "scale", ptr)?.unwrap_or([1.0; 3]));
    let rotation = match opt_f32_array::<4>(node, "rotation", ptr)? {
        None => Quat::IDENTITY,
        Some(q) => normalize_rotation(cx, Quat::from_array(q), &Ptr::member(ptr, "rotation")),
    };
    Ok(Transform { translation, rotation, scale })
}

/// A unit quaternion from `q`, warning when it was not (identity when it cannot be normalized).
pub(crate) fn normalize_rotation(cx: &mut Cx<'_>, q: Quat, ptr: &(impl std::fmt::Display + ?Sized)) -> Quat {
    match q.try_normalize_quat() {
        Some(unit) => {
            if (q.length() - 1.0).abs() > 1e-3 {
                cx.warn(ptr.to_string(), format!("rotation {q} has length {}; normalized", q.length()));
            }
            unit
        }
        None => {
            cx.warn(ptr.to_string(), format!("rotation {q} cannot be normalized; the identity is used"));
            Quat::IDENTITY
        }
    }
}

/// Scenes (root lists) and the default scene index.
pub(crate) fn scenes(cx: &mut Cx<'_>, nodes: &[Node]) -> Result<(Vec<Scene>, Option<usize>), ImportError> {
    let mut scenes = Vec::new();
    for (scene, ptr) in objects(cx.root, "scenes", "")? {
        let nodes_ptr = child(&ptr, "nodes");
        let mut roots = Vec::new();
        for (i, v) in array(scene, "nodes", &ptr)?.iter().enumerate() {
            let p = child(&nodes_ptr, i);
            let index = super::json::as_u64(v).ok_or_else(|| ImportError::new(&p, "expected a node index"))?;
            let r = check_index(index, nodes.len(), "node", &p)?;
            if nodes[r as usize].parent.is_some() {
                cx.warn(&p, format!("scene node {r} is not a root node"));
            }
            if !roots.contains(&r) {
                roots.push(r);
            }
        }
        scenes.push(Scene { name: super::json::name(scene), roots });
    }
    let default_scene = match opt_index(cx.root, "scene", "", scenes.len(), "scene")? {
        Some(s) => Some(s as usize),
        None => (!scenes.is_empty()).then_some(0),
    };
    Ok((scenes, default_scene))
}

/// Skins: joints (at least one, valid nodes), inverse bind matrices (finite, one per joint).
pub(crate) fn skins(cx: &mut Cx<'_>, node_count: usize) -> Result<Vec<Skin>, ImportError> {
    let mut skins = Vec::new();
    for (skin, ptr) in objects(cx.root, "skins", "")? {
        // The pointers are written out only for an error.
        let joints_ptr = Ptr::member(&ptr, "joints");
        let joints = array(skin, "joints", &ptr)?
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let p = Ptr::element(&ptr, "joints", i);
                let index = super::json::as_u64(v).ok_or_else(|| ImportError::new(p, "expected a node index"))?;
                check_index(index, node_count, "node", &p)
            })
            .collect::<Result<Vec<_>, _>>()?;
        if joints.is_empty() || joints.len() > usize::from(u16::MAX) + 1 {
            return Err(ImportError::new(joints_ptr, format!("a skin needs 1 to 65536 joints, got {}", joints.len())));
        }
        let inverse_bind = match opt_index(skin, "inverseBindMatrices", &ptr, cx.accessors.len(), "accessor")? {
            None => vec![Mat4::IDENTITY; joints.len()],
            Some(a) => {
                let p = Ptr::member(&ptr, "inverseBindMatrices");
                let m = cx.accessors.read_f32::<16>(a, &p, &["MAT4"], true, &mut cx.budget)?;
                if m.len() < joints.len() {
                    return Err(ImportError::new(p, format!("{} matrices for {} joints", m.len(), joints.len())));
                }
                m.iter().take(joints.len()).map(Mat4::from_cols_array).collect()
            }
        };
        let skeleton = opt_index(skin, "skeleton", &ptr, node_count, "node")?;
        skins.push(Skin { name: super::json::name(skin), joints, inverse_bind, skeleton });
    }
    Ok(skins)
}
