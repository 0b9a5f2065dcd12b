//! Animations → clips: channels validated against their nodes, keyframes repaired.

use super::Cx;
use super::json::{Ptr, child, items, member_error, opt_index, opt_object, opt_str, req_index};
use crate::asset::Node;
use crate::clip::{Channel, ChannelTarget, Clip, Interpolation};
use crate::error::ImportError;
use crate::math::{Vec4, unit_with_length};

/// Parses every animation.
pub(crate) fn clips(cx: &mut Cx<'_>, nodes: &[Node]) -> Result<Vec<Clip>, ImportError> {
    let mut clips = Vec::new();
    // Nodes given by a `matrix` (glTF animates only TRS nodes), warned about once each (the
    // nodes were read as objects already).
    let node_objects = super::json::array(cx.root, "nodes", "")?;
    let mut matrix_warned = vec![false; node_objects.len()];
    for (anim, ptr) in items(cx.root, "animations", &"")? {
        let samplers = items(anim, "samplers", &ptr)?;
        let mut channels = Vec::new();
        for (channel, cptr) in items(anim, "channels", &ptr)? {
            let sampler = req_index(channel, "sampler", &cptr, samplers.len(), "sampler")? as usize;
            let tptr = Ptr::member(&cptr, "target");
            let target = opt_object(channel, "target", &cptr)?.ok_or_else(|| ImportError::new(tptr, "missing"))?;
            let path = opt_str(target, "path", &tptr)?.ok_or_else(|| member_error(&tptr, "path", "missing"))?;
            let Some(node) = opt_index(target, "node", &tptr, nodes.len(), "node")? else {
                cx.warn(tptr, "channel without a target node; ignored");
                continue;
            };
            let (target, width) = match path {
                "translation" => (ChannelTarget::Translation, 3),
                "rotation" => (ChannelTarget::Rotation, 4),
                "scale" => (ChannelTarget::Scale, 3),
                "weights" => (ChannelTarget::Weights, nodes[node as usize].weights.len()),
                other => {
                    cx.warn(
                        child(&tptr, "path"),
                        format!("animation path '{other}' is not supported; channel ignored"),
                    );
                    continue;
                }
            };
            if width == 0 {
                cx.warn(tptr, format!("node {node} has no morph targets to animate; channel ignored"));
                continue;
            }
            let n = node as usize;
            if target != ChannelTarget::Weights
                && node_objects.get(n).and_then(super::json::Value::as_object).is_some_and(|o| o.contains_key("matrix"))
                && matrix_warned.get(n) == Some(&false)
            {
                matrix_warned[n] = true;
                cx.warn(
                    child(&tptr, "node"),
                    format!(
                        "node {node} is animated but given by a matrix (glTF animates only translation, rotation \
                         and scale); the matrix is taken apart into those"
                    ),
                );
            }
            let (s, sptr) = &samplers[sampler];
            if let Some(c) = channel_from_sampler(cx, s, sptr, node, target, width)? {
                channels.push(c);
            }
        }
        // The clip's sampling layout (channels packed in SIMD lanes) is charged before it exists.
        let budget = &mut cx.budget;
        let charge = |bytes| budget.take(Some(bytes), &ptr, "animation sampling layout");
        clips.push(Clip::from_channels_charged(super::json::name(anim), channels, charge)?);
    }
    Ok(clips)
}

/// Reads a sampler for one channel; drops keyframes with non-finite times or values or
/// non-increasing times (one warning), normalizes STEP/LINEAR rotations.
fn channel_from_sampler(
    cx: &mut Cx<'_>,
    s: &super::json::Obj,
    sptr: &Ptr<'_>,
    node: u32,
    target: ChannelTarget,
    width: usize,
) -> Result<Option<Channel>, ImportError> {
    let interpolation = match opt_str(s, "interpolation", sptr)?.unwrap_or("LINEAR") {
        "STEP" => Interpolation::Step,
        "LINEAR" => Interpolation::Linear,
        "CUBICSPLINE" => Interpolation::CubicSpline,
        other => return Err(member_error(sptr, "interpolation", format!("unknown interpolation '{other}'"))),
    };
    let input = req_index(s, "input", sptr, cx.accessors.len(), "accessor")?;
    let output = req_index(s, "output", sptr, cx.accessors.len(), "accessor")?;
    let iptr = Ptr::member(sptr, "input");
    let optr = Ptr::member(sptr, "output");
    let mut times: Vec<f32> = cx
        .accessors
        .read_f32::<1>(input, &iptr, &["SCALAR"], false, &mut cx.budget)?
        .into_iter()
        .map(|[t]| t)
        .collect();
    let (mut values, components) = cx.accessors.read_flat(output, &mut cx.budget)?;
    let expected_components = if target == ChannelTarget::Weights { 1 } else { width };
    if components != expected_components {
        return Err(ImportError::new(
            optr,
            format!("accessor {output} has {components} components per element, expected {expected_components}"),
        ));
    }
    let per_key = width * if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
    let keys = times.len();
    if values.len() as u64 != keys as u64 * per_key as u64 {
        return Err(ImportError::new(
            optr,
            format!("{} output values for {keys} keyframes; expected {per_key} per keyframe", values.len()),
        ));
    }

    // Compact the keys in place, dropping bad ones.
    let normalize = target == ChannelTarget::Rotation && interpolation != Interpolation::CubicSpline;
    let (mut kept, mut dropped, mut renormalized) = (0usize, 0usize, 0usize);
    let mut last: Option<f32> = None;
    for k in 0..keys {
        let t = times[k];
        let range = k * per_key..(k + 1) * per_key;
        let mut ok = t.is_finite() && last.is_none_or(|l| t > l) && values[range.clone()].iter().all(|v| v.is_finite());
        if ok && normalize {
            match unit_with_length(Vec4::from_slice(&values[range.clone()])) {
                Some((unit, len)) => {
                    renormalized += usize::from((len - 1.0).abs() > 1e-3);
                    values[range.clone()].copy_from_slice(&unit.to_array());
                }
                None => ok = false,
            }
        }
        if !ok {
            dropped += 1;
            continue;
        }
        if kept != k {
            times[kept] = t;
            values.copy_within(range, kept * per_key);
        }
        kept += 1;
        last = Some(t);
    }
    times.truncate(kept);
    values.truncate(kept * per_key);
    if renormalized > 0 {
        cx.warn(optr, format!("{renormalized} rotation keyframes were not unit quaternions; normalized"));
    }
    if dropped > 0 {
        cx.warn(
            *sptr,
            format!("dropped {dropped} of {keys} keyframes (non-finite or non-increasing time, or non-finite value)"),
        );
    }
    if kept == 0 {
        cx.warn(*sptr, "no usable keyframes; channel ignored");
        return Ok(None);
    }
    if interpolation == Interpolation::CubicSpline && kept < 2 {
        cx.warn(*sptr, "CUBICSPLINE needs at least 2 keyframes; the one key's value is held");
    }
    Ok(Some(Channel { node, target, interpolation, times, values, width: width as u32 }))
}
