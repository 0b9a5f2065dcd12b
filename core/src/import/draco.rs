//! `KHR_draco_mesh_compression`: a primitive's attributes and indices stored as one Draco
//! stream in a buffer view. Each such stream is decoded (draco-core, pure Rust, within the
//! import budget) before the meshes are read, and the primitive's accessors are pointed at
//! the decoded data, so everything after this reads them like any other accessor.

use super::accessor::{Accessors, Component};
use super::container::Budget;
use super::json::{Obj, child, member_error, objects, opt_object, opt_u64, req_index};
use crate::asset::CompressedPrimitive;
use crate::codecs::Codecs;
use crate::error::{ImportError, Warning};

/// The extension's name.
pub(crate) const EXTENSION: &str = "KHR_draco_mesh_compression";

/// An accessor that a Draco stream filled: which stream (buffer view) and attribute.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Source {
    Attribute { view: u32, id: u64 },
    Indices { view: u32 },
}

/// Decodes every Draco-compressed primitive of `root` into `accessors`. Returns what each
/// decode cost (for `kloub inspect`) and the repaired defects.
pub(crate) fn decode_all(
    root: &Obj,
    accessors: &mut Accessors<'_>,
    budget: &mut Budget,
    codecs: &dyn Codecs,
) -> Result<(Vec<CompressedPrimitive>, Vec<Warning>), ImportError> {
    let mut state = State { filled: vec![None; accessors.len()], streams: Vec::new(), warnings: Vec::new() };
    let mut costs = Vec::new();
    for (m, (mesh, mptr)) in objects(root, "meshes", "")?.into_iter().enumerate() {
        for (p, (prim, pptr)) in objects(mesh, "primitives", &mptr)?.into_iter().enumerate() {
            let Some(x) = super::json::extension(prim, EXTENSION, &pptr)? else { continue };
            let xptr = format!("{pptr}/extensions/{EXTENSION}");
            let cost = decode_primitive(prim, &pptr, x, &xptr, accessors, budget, &mut state, codecs)?;
            costs.push(CompressedPrimitive { mesh: m as u32, primitive: p as u32, ..cost });
        }
    }
    Ok((costs, state.warnings))
}

/// What the decoding of one file has done so far.
struct State {
    /// What filled each accessor: one accessor may be shared by primitives that share the stream.
    filled: Vec<Option<Source>>,
    /// The streams decoded so far (buffer view, points, triangles): a stream that primitives
    /// share is decoded once, unless one of them reads an attribute the others did not.
    streams: Vec<(u32, u64, u64)>,
    warnings: Vec<Warning>,
}

/// A compressed attribute of one primitive still to be written into its accessor.
struct Pending<'a> {
    name: &'a str,
    ptr: String,
    id: u64,
    accessor: u32,
}

/// Decodes one primitive's stream (its extension object `x` at `xptr`) with `codecs`.
#[allow(clippy::too_many_arguments)]
fn decode_primitive(
    prim: &Obj,
    pptr: &str,
    x: &Obj,
    xptr: &str,
    accessors: &mut Accessors<'_>,
    budget: &mut Budget,
    state: &mut State,
    codecs: &dyn Codecs,
) -> Result<CompressedPrimitive, ImportError> {
    let mode = opt_u64(prim, "mode", pptr)?.unwrap_or(4);
    if mode != 4 {
        return Err(member_error(
            pptr,
            "mode",
            format!("a Draco-compressed primitive must be TRIANGLES (4), not mode {mode}"),
        ));
    }
    let view = req_index(x, "bufferView", xptr, accessors.view_count(), "bufferView")?;
    let compressed_bytes = accessors.view_bytes(view as usize)?.len() as u64;

    // Which accessors this primitive's stream fills that no primitive sharing it has filled.
    let attributes =
        opt_object(prim, "attributes", pptr)?.ok_or_else(|| ImportError::new(child(pptr, "attributes"), "missing"))?;
    let aptr = child(pptr, "attributes");
    let compressed_attributes =
        opt_object(x, "attributes", xptr)?.ok_or_else(|| ImportError::new(child(xptr, "attributes"), "missing"))?;
    let cptr = child(xptr, "attributes");
    let mut pending = Vec::new();
    for (name, id) in compressed_attributes {
        let idptr = child(&cptr, name);
        let id = super::json::as_u64(id).ok_or_else(|| ImportError::new(&idptr, "expected a Draco attribute id"))?;
        if !attributes.contains_key(name) {
            return Err(ImportError::new(
                &idptr,
                format!("{name} is compressed, but the primitive has no accessor for it"),
            ));
        }
        let accessor = req_index(attributes, name, &aptr, accessors.len(), "accessor")?;
        if claim(&mut state.filled, accessor, Source::Attribute { view, id }, &child(&aptr, name))? {
            pending.push(Pending { name, ptr: idptr, id, accessor });
        }
    }
    let indices = super::json::opt_index(prim, "indices", pptr, accessors.len(), "accessor")?.ok_or_else(|| {
        member_error(pptr, "indices", "a Draco-compressed primitive needs an indices accessor for its triangles")
    })?;
    let fill_indices = claim(&mut state.filled, indices, Source::Indices { view }, &child(pptr, "indices"))?;
    let cost = |points, triangles, decoded_bytes| CompressedPrimitive {
        mesh: 0,
        primitive: 0,
        view,
        extension: EXTENSION.to_owned(),
        compressed_bytes,
        decoded_bytes,
        points,
        triangles,
    };
    if pending.is_empty()
        && !fill_indices
        && let Some(&(_, points, triangles)) = state.streams.iter().find(|s| s.0 == view)
    {
        return Ok(cost(points, triangles, 0));
    }

    // The decoder's own ceiling is what is left of the import budget.
    let left = budget.left();
    let wanted: Vec<u32> = pending.iter().filter_map(|p| u32::try_from(p.id).ok()).collect();
    let mesh = codecs
        .draco(accessors.view_bytes(view as usize)?, &wanted, left)
        .map_err(|e| ImportError::new(child(xptr, "bufferView"), format!("the Draco stream does not decode: {e}")))?;
    let points = u64::from(mesh.points);
    let triangles = mesh.indices.len() as u64 / 3;
    if points == 0 || triangles == 0 {
        return Err(ImportError::new(
            child(xptr, "bufferView"),
            format!("the Draco stream holds {points} points and {triangles} triangles: nothing to draw"),
        ));
    }
    state.streams.push((view, points, triangles));

    let mut decoded_bytes = 0u64;
    for Pending { name, ptr, id, accessor: index } in pending {
        let attribute = mesh
            .attributes
            .iter()
            .find(|a| u64::from(a.id) == id)
            .ok_or_else(|| ImportError::new(&ptr, format!("the Draco stream has no attribute with id {id}")))?;
        let accessor = accessors.get(index)?;
        let (component, components) = (accessor.component(), accessor.components());
        if usize::from(attribute.components) != components
            || attribute.values.len() as u64 != points * components as u64
        {
            return Err(ImportError::new(
                &ptr,
                format!(
                    "the Draco attribute has {} components, accessor {index} ({}) has {components}",
                    attribute.components, accessor.type_name
                ),
            ));
        }
        if component != Component::F32 && attribute.float {
            return Err(ImportError::new(
                &ptr,
                format!("the Draco attribute holds floats, accessor {index} holds integers"),
            ));
        }
        let size = points
            .checked_mul(components as u64)
            .and_then(|n| n.checked_mul(component.size()))
            .filter(|&n| n <= left)
            .ok_or_else(|| ImportError::new(&ptr, "the decoded attribute exceeds the import budget"))?;
        // The f32 values draco-core hands out and the accessor's bytes.
        budget.take(size.checked_add(points * components as u64 * 4), &ptr, &format!("decoded {name}"))?;
        let bytes = convert(&attribute.values, component).map_err(|v| {
            ImportError::new(&ptr, format!("the Draco value {v} does not fit accessor {index}'s component type"))
        })?;
        count_warning(&mut state.warnings, index, accessor.count, points, "points");
        accessors.replace(index, bytes, points, component);
        decoded_bytes += size;
    }

    if fill_indices {
        let count = triangles * 3;
        count_warning(&mut state.warnings, indices, accessors.get(indices)?.count, count, "indices");
        // Written as 32-bit: a stream may decode to more points than its file declared.
        let size = count * 4;
        budget.take(Some(size), &child(pptr, "indices"), "decoded indices")?;
        let corners = &mesh.indices[..count as usize];
        if let Some(&corner) = corners.iter().max().filter(|&&c| u64::from(c) >= points) {
            return Err(ImportError::new(
                child(xptr, "bufferView"),
                format!("the Draco stream has a triangle corner {corner} outside its {points} points"),
            ));
        }
        let mut bytes = vec![0u8; size as usize];
        for (out, corner) in bytes.chunks_exact_mut(4).zip(corners) {
            out.copy_from_slice(&corner.to_le_bytes());
        }
        accessors.replace(indices, bytes, count, Component::U32);
        decoded_bytes += size;
    }
    Ok(cost(points, triangles, decoded_bytes))
}

/// Warns when accessor `index` declares `declared` elements and the stream decoded `decoded` `what`.
fn count_warning(warnings: &mut Vec<Warning>, index: u32, declared: u64, decoded: u64, what: &str) {
    if declared != decoded {
        warnings.push(Warning::new(
            format!("/accessors/{index}/count"),
            format!("count {declared} differs from the {decoded} {what} of the Draco stream, which are used"),
        ));
    }
}

/// Records that `source` fills accessor `index`: false when it already did (a primitive
/// sharing the stream), an error when another stream or attribute did.
fn claim(filled: &mut [Option<Source>], index: u32, source: Source, ptr: &str) -> Result<bool, ImportError> {
    match filled.get_mut(index as usize) {
        Some(Some(s)) if *s == source => Ok(false),
        Some(Some(_)) => Err(ImportError::new(
            ptr,
            format!("accessor {index} is filled from two different Draco attributes or streams"),
        )),
        Some(slot) => {
            *slot = Some(source);
            Ok(true)
        }
        None => Err(ImportError::new(ptr, format!("accessor {index} does not exist"))),
    }
}

/// `values` as components of type `c`, little-endian (integers must be whole and in range):
/// the bytes, or the first value that does not fit. One pass per type, into a buffer of the
/// final size.
fn convert(values: &[f32], c: Component) -> Result<Vec<u8>, f32> {
    fn each<const N: usize>(values: &[f32], write: impl Fn(f32) -> Option<[u8; N]>) -> Result<Vec<u8>, f32> {
        let mut bytes = vec![0u8; values.len() * N];
        for (out, &v) in bytes.chunks_exact_mut(N).zip(values) {
            out.copy_from_slice(&write(v).ok_or(v)?);
        }
        Ok(bytes)
    }
    // Whole and within `lo..=hi` (NaN is neither).
    let int = |v: f32, lo: f32, hi: f32| (v.fract() == 0.0 && v >= lo && v <= hi).then_some(v);
    match c {
        Component::F32 => each(values, |v| Some(v.to_le_bytes())),
        Component::I8 => each(values, |v| Some([int(v, -128.0, 127.0)? as i8 as u8])),
        Component::U8 => each(values, |v| Some([int(v, 0.0, 255.0)? as u8])),
        Component::I16 => each(values, |v| Some((int(v, -32768.0, 32767.0)? as i16).to_le_bytes())),
        Component::U16 => each(values, |v| Some((int(v, 0.0, 65535.0)? as u16).to_le_bytes())),
        Component::U32 => each(values, |v| Some((int(v, 0.0, 16_777_216.0)? as u32).to_le_bytes())),
    }
}
