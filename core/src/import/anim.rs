//! Animations → clips: channels validated against their nodes, keyframes repaired.

use super::Cx;
use super::json::{Ptr, child, items, member_error, opt_index, opt_object, opt_str, req_index};
use crate::asset::Node;
use crate::clip::{Channel, ChannelTarget, Clip, Interpolation};
use crate::error::ImportError;
use crate::math::{Vec4, all_finite, unit_with_length};

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

    let normalize = target == ChannelTarget::Rotation && interpolation != Interpolation::CubicSpline;
    // Files as exporters write them keep every key: times and values are checked in one pass
    // each, the rotations made unit in another; a key to drop sends the rest to `compact_keys`.
    let (kept, dropped, renormalized) = match keys_are_sound(&times, &values) {
        true if normalize => match normalize_rotations(&mut values) {
            Ok(renormalized) => (keys, 0, renormalized),
            Err((start, renormalized)) => compact_keys(&mut times, &mut values, per_key, true, start, renormalized),
        },
        true => (keys, 0, 0),
        false => compact_keys(&mut times, &mut values, per_key, normalize, 0, 0),
    };
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

/// Whether the times are finite and strictly increasing and the values finite: four at a time,
/// without a branch a value.
fn keys_are_sound(times: &[f32], values: &[f32]) -> bool {
    // Each time against the one before it (NaN is greater than nothing).
    let later = times.get(1..).unwrap_or(&[]);
    let (earlier_fours, earlier_rest) = times[..later.len()].as_chunks::<4>();
    let (later_fours, later_rest) = later.as_chunks::<4>();
    let increasing = earlier_fours
        .iter()
        .zip(later_fours)
        .fold(glam::BVec4A::splat(true), |ok, (&a, &b)| ok & Vec4::from_array(b).cmpgt(Vec4::from_array(a)))
        .all()
        & earlier_rest.iter().zip(later_rest).fold(true, |ok, (a, b)| ok & (b > a));
    all_finite(times) & increasing & all_finite(values)
}

/// Divides each rotation (four finite floats) by its length, as [`unit_with_length`] does: how
/// many were more than 1e-3 from unit; or, at the first one with no direction, its index and that
/// count so far (the rotations before it made unit).
fn normalize_rotations(values: &mut [f32]) -> Result<usize, (usize, usize)> {
    let mut renormalized = 0;
    for (i, q) in values.as_chunks_mut::<4>().0.iter_mut().enumerate() {
        let Some((unit, len)) = unit_with_length(Vec4::from_array(*q)) else {
            return Err((i, renormalized));
        };
        *q = unit.to_array();
        renormalized += usize::from((len - 1.0).abs() > 1e-3);
    }
    Ok(renormalized)
}

/// Compacts the keys in place, dropping bad ones (see [`channel_from_sampler`]) and making
/// rotations unit where `normalize`: (kept, dropped, renormalized). `values` holds `per_key`
/// floats a key. The first `start` keys are already kept (and made unit: `renormalized` of them
/// were not).
fn compact_keys(
    times: &mut [f32],
    values: &mut [f32],
    per_key: usize,
    normalize: bool,
    start: usize,
    renormalized: usize,
) -> (usize, usize, usize) {
    let keys = times.len();
    let (mut kept, mut dropped, mut renormalized) = (start, 0usize, renormalized);
    let mut last: Option<f32> = start.checked_sub(1).and_then(|k| times.get(k).copied());
    for k in start..keys {
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
    (kept, dropped, renormalized)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_sound_as_checked_one_at_a_time() {
        let naive = |times: &[f32], values: &[f32]| {
            times.iter().all(|t| t.is_finite())
                && times.windows(2).all(|w| w[1] > w[0])
                && values.iter().all(|v| v.is_finite())
        };
        for len in 0..13 {
            let times: Vec<f32> = (0..len).map(|k| k as f32 * 0.5).collect();
            let values: Vec<f32> = (0..len * 3).map(|k| k as f32 - 4.0).collect();
            assert!(keys_are_sound(&times, &values), "{len}");
            for at in 0..len {
                for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0, 0.5 * at as f32 - 0.5] {
                    let mut t = times.clone();
                    t[at] = bad;
                    assert_eq!(keys_are_sound(&t, &values), naive(&t, &values), "times {t:?}");
                }
            }
            for at in 0..values.len() {
                for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                    let mut v = values.clone();
                    v[at] = bad;
                    assert!(!keys_are_sound(&times, &v), "values {v:?}");
                }
            }
        }
    }
}
