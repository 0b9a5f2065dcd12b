//! Blending poses, in the style of ozz-animation's `BlendingJob`, plus joint masks.
//!
//! A [`BlendJob`] combines any number of [`BlendLayer`]s, each a complete pose (node-local
//! transforms and flat morph weights) with a scalar weight and an optional per-node weight
//! mask. Per node `n`, a layer's weight is `layer.weight * mask[n]` (mask 1 when absent).
//!
//! 1. **Normal** layers are averaged: translations, scales and morph weights by their
//!    normalized weights; rotations as the normalized sum of the weighted quaternions, each
//!    sign-aligned with the running sum (nlerp accumulation). Where the accumulated weight is
//!    below [`BlendJob::threshold`], the rest pose fills the gap with weight
//!    `threshold - accumulated`, so a node no layer touches keeps its rest pose exactly.
//!    A node with exactly one contributing normal layer gets that layer's values bit for bit.
//! 2. **Override** and **Additive** layers are then applied in slice order on top:
//!    - override: `out = lerp(out, layer, min(w, 1))` (nlerp for rotations); `w ≥ 1` copies
//!      the layer exactly, `w = 0` leaves `out` untouched bit for bit;
//!    - additive (the layer minus its reference pose, per channel):
//!      rotation `out · slerp(identity, reference⁻¹ · layer, w)`,
//!      translation `out + w · (layer − reference)`,
//!      scale `out ⊙ lerp(1, layer / reference, w)` (a zero reference scale contributes 1),
//!      morph weights `out + w · (layer − reference)`.
//!
//! [`subtree_mask`] builds the per-node weights of a layer that acts on the subtree under
//! a root joint, with an optional per-depth falloff.

use super::sample::{nlerp, slerp};
use super::{check_eq, check_index, check_len};
use crate::asset::{Asset, NodeIndex};
use crate::error::JobError;
use crate::math::{Quat, QuatExt, Transform, Vec3, Vec4};

/// ozz-animation's default: below this accumulated weight the rest pose fills in.
pub const DEFAULT_THRESHOLD: f32 = 0.1;

/// How a [`BlendLayer`] combines with the others.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BlendMode {
    /// Part of the normalized weighted average.
    #[default]
    Normal,
    /// Replaces the result so far by `min(weight, 1)`, after the normal layers.
    Override,
    /// Adds its difference from a reference pose, after the normal layers.
    Additive,
}

/// One input pose of a [`BlendJob`].
#[derive(Clone, Copy, Debug)]
pub struct BlendLayer<'a> {
    /// How this layer combines.
    pub mode: BlendMode,
    /// Scalar weight (finite, ≥ 0); multiplied by `joint_weights[n]` per node.
    pub weight: f32,
    /// Local transform by node (as many as the rest pose).
    pub locals: &'a [Transform],
    /// Flat morph weights (as many as the rest pose's).
    pub morph_weights: &'a [f32],
    /// Per-node weight mask (finite, ≥ 0), or empty for 1 everywhere.
    pub joint_weights: &'a [f32],
    /// [`BlendMode::Additive`] only: the reference pose subtracted from `locals`.
    pub reference: &'a [Transform],
    /// [`BlendMode::Additive`] only: the reference morph weights.
    pub reference_weights: &'a [f32],
}

impl BlendLayer<'static> {
    /// A layer with no data and weight 0 (fills fixed-size layer arrays).
    pub const EMPTY: BlendLayer<'static> = BlendLayer {
        mode: BlendMode::Normal,
        weight: 0.0,
        locals: &[],
        morph_weights: &[],
        joint_weights: &[],
        reference: &[],
        reference_weights: &[],
    };
}

impl<'a> BlendLayer<'a> {
    /// A normal (averaged) layer.
    pub fn normal(locals: &'a [Transform], morph_weights: &'a [f32], weight: f32) -> Self {
        Self { mode: BlendMode::Normal, weight, locals, morph_weights, ..BlendLayer::EMPTY }
    }

    /// An override layer.
    pub fn overriding(locals: &'a [Transform], morph_weights: &'a [f32], weight: f32) -> Self {
        Self { mode: BlendMode::Override, ..Self::normal(locals, morph_weights, weight) }
    }

    /// An additive layer: `locals` minus `reference`.
    pub fn additive(
        locals: &'a [Transform],
        morph_weights: &'a [f32],
        reference: &'a [Transform],
        reference_weights: &'a [f32],
        weight: f32,
    ) -> Self {
        Self { mode: BlendMode::Additive, reference, reference_weights, ..Self::normal(locals, morph_weights, weight) }
    }

    /// The same layer restricted by a per-node weight mask.
    pub fn with_mask(self, joint_weights: &'a [f32]) -> Self {
        Self { joint_weights, ..self }
    }

    /// This layer's weight at `node`.
    #[inline]
    fn node_weight(&self, node: usize) -> f32 {
        match self.joint_weights.get(node) {
            Some(&m) => self.weight * m,
            None => self.weight,
        }
    }
}

/// Blends layers into one pose. See the [module documentation](self) for the formulas.
#[derive(Debug)]
pub struct BlendJob<'a> {
    /// The inputs.
    pub layers: &'a [BlendLayer<'a>],
    /// Rest pose locals: one per node; used where normal layers weigh less than `threshold`.
    pub rest: &'a [Transform],
    /// Rest pose morph weights (flat).
    pub rest_weights: &'a [f32],
    /// Start of each node's morph weights ([`Asset::weight_offsets`]): non-decreasing; node
    /// `n` owns `weight_offsets[n]..weight_offsets[n + 1]` (the last node up to the end).
    pub weight_offsets: &'a [u32],
    /// Accumulated normal weight below which the rest pose fills in (finite, > 0).
    pub threshold: f32,
    /// Output: local transform by node.
    pub locals: &'a mut [Transform],
    /// Output: flat morph weights.
    pub weights: &'a mut [f32],
}

fn invalid(message: String) -> JobError {
    JobError::InvalidInput(message)
}

fn check_weight(what: &str, layer: usize, w: f32) -> Result<(), JobError> {
    if w.is_finite() && w >= 0.0 {
        Ok(())
    } else {
        Err(invalid(format!("layer {layer}: {what} {w} is not a finite non-negative number")))
    }
}

impl BlendJob<'_> {
    /// Checks the threshold, every length, the weight offsets, and that every weight is
    /// finite and non-negative (a NaN weight is an error, not a silent rest pose).
    pub fn validate(&self) -> Result<(), JobError> {
        let (n, m) = (self.rest.len(), self.rest_weights.len());
        check_len("locals", n, self.locals.len())?;
        check_len("weights", m, self.weights.len())?;
        check_eq("weight_offsets", n, self.weight_offsets.len())?;
        let mut previous = 0;
        for &offset in self.weight_offsets {
            if offset < previous {
                return Err(invalid("weight_offsets must not decrease".into()));
            }
            check_len("rest_weights", offset as usize, m)?;
            previous = offset;
        }
        if !(self.threshold.is_finite() && self.threshold > 0.0) {
            return Err(invalid(format!("blend threshold {} must be finite and positive", self.threshold)));
        }
        for (i, layer) in self.layers.iter().enumerate() {
            check_eq("layer locals", n, layer.locals.len())?;
            check_eq("layer morph weights", m, layer.morph_weights.len())?;
            if !layer.joint_weights.is_empty() {
                check_eq("layer joint weights", n, layer.joint_weights.len())?;
            }
            if layer.mode == BlendMode::Additive {
                check_eq("layer reference", n, layer.reference.len())?;
                check_eq("layer reference weights", m, layer.reference_weights.len())?;
            }
            check_weight("weight", i, layer.weight)?;
            for &w in layer.joint_weights {
                check_weight("joint weight", i, w)?;
            }
        }
        Ok(())
    }

    /// Validates, then writes every node's local transform and morph weights.
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        let (n, m) = (self.rest.len(), self.rest_weights.len());
        // One full-weight normal layer and nothing else: a copy.
        if let [only] = self.layers
            && only.mode == BlendMode::Normal
            && only.joint_weights.is_empty()
            && only.weight >= self.threshold
        {
            self.locals[..n].copy_from_slice(only.locals);
            self.weights[..m].copy_from_slice(only.morph_weights);
            return Ok(());
        }
        let layered = self.layers.iter().any(|l| l.mode != BlendMode::Normal);
        for node in 0..n {
            let start = self.weight_offsets[node] as usize;
            let end = self.weight_offsets.get(node + 1).map_or(m, |&o| o as usize);
            self.blend_normal(node, start..end);
            if layered {
                self.apply_layered(node, start..end);
            }
        }
        Ok(())
    }

    /// Step 1 for one node: the normalized average of the normal layers.
    fn blend_normal(&mut self, node: usize, morph: std::ops::Range<usize>) {
        let (mut t, mut s, mut r) = (Vec3::ZERO, Vec3::ZERO, Vec4::ZERO);
        let (mut total, mut count, mut single) = (0.0f32, 0u32, 0usize);
        for (i, layer) in self.layers.iter().enumerate() {
            let w = layer.node_weight(node);
            if layer.mode != BlendMode::Normal || w <= 0.0 {
                continue;
            }
            let x = &layer.locals[node];
            t += x.translation * w;
            s += x.scale * w;
            r += aligned(r, x.rotation) * w;
            total += w;
            count += 1;
            single = i;
        }
        let rest = &self.rest[node];
        let out_weights = &mut self.weights[morph.clone()];
        if count == 0 {
            self.locals[node] = *rest;
            out_weights.copy_from_slice(&self.rest_weights[morph]);
            return;
        }
        if count == 1 && total >= self.threshold {
            let layer = &self.layers[single];
            self.locals[node] = layer.locals[node];
            out_weights.copy_from_slice(&layer.morph_weights[morph]);
            return;
        }
        let rest_weight = (self.threshold - total).max(0.0);
        if rest_weight > 0.0 {
            t += rest.translation * rest_weight;
            s += rest.scale * rest_weight;
            r += aligned(r, rest.rotation) * rest_weight;
            total += rest_weight;
        }
        let inverse = 1.0 / total;
        self.locals[node] = Transform {
            translation: t * inverse,
            rotation: Quat::from_vec4(r).try_normalize_quat().unwrap_or(rest.rotation),
            scale: s * inverse,
        };
        if morph.is_empty() {
            return;
        }
        for (o, &x) in out_weights.iter_mut().zip(&self.rest_weights[morph.clone()]) {
            *o = x * rest_weight;
        }
        for layer in self.layers.iter().filter(|l| l.mode == BlendMode::Normal) {
            let w = layer.node_weight(node);
            if w > 0.0 {
                for (o, &x) in out_weights.iter_mut().zip(&layer.morph_weights[morph.clone()]) {
                    *o += x * w;
                }
            }
        }
        for o in out_weights.iter_mut() {
            *o *= inverse;
        }
    }

    /// Step 2 for one node: override and additive layers in order.
    fn apply_layered(&mut self, node: usize, morph: std::ops::Range<usize>) {
        for layer in self.layers {
            let w = layer.node_weight(node);
            if w <= 0.0 {
                continue;
            }
            let out = &mut self.locals[node];
            let out_weights = &mut self.weights[morph.clone()];
            let x = &layer.locals[node];
            let xw = &layer.morph_weights[morph.clone()];
            match layer.mode {
                BlendMode::Normal => {}
                BlendMode::Override if w >= 1.0 => {
                    *out = *x;
                    out_weights.copy_from_slice(xw);
                }
                BlendMode::Override => {
                    out.translation = out.translation.lerp(x.translation, w);
                    out.rotation = nlerp(out.rotation, x.rotation, w);
                    out.scale = out.scale.lerp(x.scale, w);
                    for (o, &v) in out_weights.iter_mut().zip(xw) {
                        *o += (v - *o) * w;
                    }
                }
                BlendMode::Additive => {
                    let reference = &layer.reference[node];
                    let delta = reference.rotation.conjugate() * x.rotation;
                    let delta = if w == 1.0 { delta } else { slerp(Quat::IDENTITY, delta, w) };
                    out.rotation = (out.rotation * delta).try_normalize_quat().unwrap_or(out.rotation);
                    out.translation += (x.translation - reference.translation) * w;
                    let ratio = Vec3::select(reference.scale.cmpeq(Vec3::ZERO), Vec3::ONE, x.scale / reference.scale);
                    out.scale *= Vec3::ONE.lerp(ratio, w);
                    for ((o, &v), &r) in out_weights.iter_mut().zip(xw).zip(&layer.reference_weights[morph.clone()]) {
                        *o += (v - r) * w;
                    }
                }
            }
        }
    }
}

/// `q` as a 4-vector, negated when it points away from `sum` (shortest-arc accumulation).
#[inline]
fn aligned(sum: Vec4, q: Quat) -> Vec4 {
    let v = Vec4::from(q);
    if sum.dot(v) < 0.0 { -v } else { v }
}

/// Writes a per-node weight mask selecting the subtree under `root`:
/// `out[n] = weight · (1 − falloff)^depth` for `root` (depth 0) and its descendants (depth =
/// generations below `root`), 0 for every other node. `falloff` 0 gives the whole subtree the
/// same weight; 0.5 halves it per generation; 1 selects `root` alone.
///
/// Errors: `root` out of range, `out` shorter than the node count, `weight` not finite or
/// negative, `falloff` outside `[0, 1]`.
pub fn subtree_mask(
    asset: &Asset,
    root: NodeIndex,
    weight: f32,
    falloff: f32,
    out: &mut [f32],
) -> Result<(), JobError> {
    let n = asset.nodes.len();
    check_index("root", root as usize, n)?;
    check_len("mask", n, out.len())?;
    check_eq("order", n, asset.order.len())?;
    check_weight("weight", 0, weight)?;
    if !(0.0..=1.0).contains(&falloff) {
        return Err(invalid(format!("falloff {falloff} is outside [0, 1]")));
    }
    let out = &mut out[..n];
    out.fill(0.0);
    out[root as usize] = weight;
    let keep = 1.0 - falloff;
    // Parents come first in `order`, and a mask value never grows with depth, so "the parent
    // is in the subtree" is "the parent's value is positive" (a zero parent has zero children).
    for &node in &asset.order {
        let node = node as usize;
        if node == root as usize {
            continue;
        }
        let parent = asset.nodes.get(node).and_then(|x| x.parent).map(|p| p as usize);
        if let Some(&value) = parent.and_then(|p| out.get(p))
            && value > 0.0
            && let Some(o) = out.get_mut(node)
        {
            *o = value * keep;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::asset::Node;
    use std::f32::consts::FRAC_PI_2;

    fn tf(t: [f32; 3], angle_y: f32, s: f32) -> Transform {
        Transform { translation: Vec3::from(t), rotation: Quat::from_rotation_y(angle_y), scale: Vec3::splat(s) }
    }

    /// Runs a blend over three nodes with one morph weight on node 1.
    fn blend(layers: &[BlendLayer<'_>], rest: &[Transform; 3]) -> Result<([Transform; 3], [f32; 1]), JobError> {
        let mut locals = [Transform::IDENTITY; 3];
        let mut weights = [0.0; 1];
        BlendJob {
            layers,
            rest,
            rest_weights: &[0.5],
            weight_offsets: &[0, 0, 1],
            threshold: DEFAULT_THRESHOLD,
            locals: &mut locals,
            weights: &mut weights,
        }
        .run()?;
        Ok((locals, weights))
    }

    const REST: [Transform; 3] = [Transform::IDENTITY; 3];

    #[test]
    fn normal_layers_average_by_normalized_weight() {
        let a = [tf([0.0; 3], 0.0, 1.0), tf([2.0, 0.0, 0.0], 0.0, 1.0), tf([0.0; 3], 0.0, 1.0)];
        let b = [tf([4.0, 0.0, 0.0], FRAC_PI_2, 3.0); 3];
        // Weights 1 and 3 → 0.25 / 0.75.
        let (out, w) =
            blend(&[BlendLayer::normal(&a, &[0.0], 1.0), BlendLayer::normal(&b, &[1.0], 3.0)], &REST).expect("valid");
        assert!(out[0].translation.abs_diff_eq(Vec3::new(3.0, 0.0, 0.0), 1e-6));
        assert!(out[1].translation.abs_diff_eq(Vec3::new(3.5, 0.0, 0.0), 1e-6));
        assert!(out[0].scale.abs_diff_eq(Vec3::splat(2.5), 1e-6));
        assert!((out[0].rotation.length() - 1.0).abs() < 1e-6);
        // nlerp of identity and 90° at 0.75 (normalized weighted sum): the angle is between
        // slerp's 67.5° and 90° and closer to 90°.
        let angle = out[0].rotation.angle_between(Quat::IDENTITY).to_degrees();
        assert!(angle > 67.5 && angle < 90.0, "{angle}");
        assert!((w[0] - 0.75).abs() < 1e-6);
    }

    #[test]
    fn opposite_signed_quaternions_are_aligned() {
        let q = Quat::from_rotation_x(0.3);
        let a = [Transform { rotation: q, ..Transform::IDENTITY }; 3];
        let b = [Transform { rotation: -q, ..Transform::IDENTITY }; 3];
        let (out, _) =
            blend(&[BlendLayer::normal(&a, &[0.0], 1.0), BlendLayer::normal(&b, &[0.0], 1.0)], &REST).expect("valid");
        assert!(out[0].rotation.abs_diff_eq(q, 1e-6) || out[0].rotation.abs_diff_eq(-q, 1e-6), "{}", out[0].rotation);
    }

    #[test]
    fn single_contributor_and_untouched_nodes_are_bit_exact() {
        let rest = [tf([1.0, 2.0, 3.0], 0.1, 1.0), tf([0.1, 0.2, 0.3], 0.7, 0.9), tf([5.0; 3], 1.3, 2.0)];
        let a = [tf([0.3, 0.1, 0.7], 0.3, 1.1); 3];
        let b = [tf([9.0; 3], 2.0, 4.0); 3];
        // Mask: b only on node 2; a weight 0.7 everywhere.
        let mask = [0.0, 0.0, 1.0];
        let layers = [BlendLayer::normal(&a, &[0.25], 0.7), BlendLayer::normal(&b, &[0.75], 1.0).with_mask(&mask)];
        let (out, w) = blend(&layers, &rest).expect("valid");
        assert_eq!(out[0], a[0], "one contributor above the threshold: its bits");
        assert_eq!(out[1], a[1]);
        assert_eq!(w[0], 0.25);
        assert_ne!(out[2], a[2]);
        // No layer at all: the rest pose, bit for bit.
        let (out, w) = blend(&[], &rest).expect("valid");
        assert_eq!((out, w), (rest, [0.5]));
        let zero = [BlendLayer::normal(&a, &[0.25], 0.0)];
        assert_eq!(blend(&zero, &rest).expect("valid").0, rest);
    }

    #[test]
    fn rest_pose_fills_in_below_the_threshold() {
        let a = [tf([1.0, 0.0, 0.0], 0.0, 1.0); 3];
        // Weight 0.05 < 0.1: the rest pose (identity) gets the other 0.05 → halfway.
        let (out, w) = blend(&[BlendLayer::normal(&a, &[1.0], 0.05)], &REST).expect("valid");
        assert!(out[0].translation.abs_diff_eq(Vec3::new(0.5, 0.0, 0.0), 1e-6), "{}", out[0].translation);
        assert!((w[0] - 0.75).abs() < 1e-6, "half of 1.0 and half of the rest 0.5: {w:?}");
    }

    #[test]
    fn override_lerps_by_weight_and_clamps_at_one() {
        let base = [tf([0.0; 3], 0.0, 1.0); 3];
        let top = [tf([2.0, 0.0, 0.0], FRAC_PI_2, 3.0); 3];
        let mask = [1.0, 0.5, 0.0];
        let layers =
            [BlendLayer::normal(&base, &[0.0], 1.0), BlendLayer::overriding(&top, &[1.0], 1.0).with_mask(&mask)];
        let (out, w) = blend(&layers, &REST).expect("valid");
        assert_eq!(out[0], top[0], "full weight: exact copy");
        assert!(out[1].translation.abs_diff_eq(Vec3::new(1.0, 0.0, 0.0), 1e-6));
        assert!(out[1].scale.abs_diff_eq(Vec3::splat(2.0), 1e-6));
        assert!(out[1].rotation.abs_diff_eq(Quat::from_rotation_y(FRAC_PI_2 / 2.0), 1e-6));
        assert!((w[0] - 0.5).abs() < 1e-6);
        assert_eq!(out[2], base[2], "mask 0: untouched");
        let heavy = [BlendLayer::normal(&base, &[0.0], 1.0), BlendLayer::overriding(&top, &[1.0], 7.0)];
        assert_eq!(blend(&heavy, &REST).expect("valid").0, top, "weight above 1 clamps");
    }

    #[test]
    fn additive_of_the_reference_is_the_identity() {
        let base = [tf([1.0, 2.0, 3.0], 0.4, 1.5), tf([0.0; 3], -0.2, 1.0), tf([0.5; 3], 1.0, 2.0)];
        let reference = [tf([0.2, 0.0, 0.0], 0.9, 2.0); 3];
        let layers =
            [BlendLayer::normal(&base, &[0.3], 1.0), BlendLayer::additive(&reference, &[0.6], &reference, &[0.6], 1.0)];
        let (out, w) = blend(&layers, &REST).expect("valid");
        for (o, b) in out.iter().zip(&base) {
            assert!(o.translation.abs_diff_eq(b.translation, 1e-6));
            assert!(o.rotation.abs_diff_eq(b.rotation, 1e-6), "{} vs {}", o.rotation, b.rotation);
            assert!(o.scale.abs_diff_eq(b.scale, 1e-6));
        }
        assert!((w[0] - 0.3).abs() < 1e-6);
    }

    #[test]
    fn additive_adds_the_difference_scaled_by_weight() {
        let base = [tf([1.0, 0.0, 0.0], 0.5, 2.0); 3];
        let reference = [tf([0.0; 3], 0.1, 1.0); 3];
        let clip = [tf([0.0, 4.0, 0.0], 0.1 + 1.0, 3.0); 3];
        let layers =
            [BlendLayer::normal(&base, &[0.0], 1.0), BlendLayer::additive(&clip, &[1.0], &reference, &[0.5], 0.5)];
        let (out, w) = blend(&layers, &REST).expect("valid");
        assert!(out[0].translation.abs_diff_eq(Vec3::new(1.0, 2.0, 0.0), 1e-6));
        // Rotation: 0.5 rad (base) + half of the 1 rad difference.
        assert!(out[0].rotation.abs_diff_eq(Quat::from_rotation_y(1.0), 1e-6), "{}", out[0].rotation);
        // Scale: 2 · lerp(1, 3, 0.5) = 4.
        assert!(out[0].scale.abs_diff_eq(Vec3::splat(4.0), 1e-6));
        assert!((w[0] - 0.25).abs() < 1e-6);
        // A zero reference scale adds nothing to the scale.
        let zero = [Transform { scale: Vec3::ZERO, ..reference[0] }; 3];
        let layers = [BlendLayer::normal(&base, &[0.0], 1.0), BlendLayer::additive(&clip, &[1.0], &zero, &[0.5], 1.0)];
        assert_eq!(blend(&layers, &REST).expect("valid").0[0].scale, Vec3::splat(2.0));
    }

    #[test]
    fn invalid_inputs_are_refused() {
        let a = [Transform::IDENTITY; 3];
        let short = [Transform::IDENTITY; 2];
        let nan_mask = [1.0, f32::NAN, 1.0];
        let short_mask = [1.0];
        let cases: Vec<(&str, Vec<BlendLayer<'_>>)> = vec![
            ("short locals", vec![BlendLayer::normal(&short, &[0.0], 1.0)]),
            ("morph length", vec![BlendLayer::normal(&a, &[], 1.0)]),
            ("NaN weight", vec![BlendLayer::normal(&a, &[0.0], f32::NAN)]),
            ("negative weight", vec![BlendLayer::normal(&a, &[0.0], -1.0)]),
            ("infinite weight", vec![BlendLayer::overriding(&a, &[0.0], f32::INFINITY)]),
            ("NaN mask", vec![BlendLayer::normal(&a, &[0.0], 1.0).with_mask(&nan_mask)]),
            ("short mask", vec![BlendLayer::normal(&a, &[0.0], 1.0).with_mask(&short_mask)]),
            ("additive without reference", vec![BlendLayer::additive(&a, &[0.0], &[], &[], 1.0)]),
        ];
        for (what, layers) in cases {
            assert!(blend(&layers, &REST).is_err(), "{what}");
        }
        let ok = [BlendLayer::normal(&a, &[0.0], 1.0)];
        let mut locals = [Transform::IDENTITY; 3];
        let mut weights = [0.0; 1];
        let mut job = BlendJob {
            layers: &ok,
            rest: &REST,
            rest_weights: &[0.0],
            weight_offsets: &[0, 1, 0],
            threshold: DEFAULT_THRESHOLD,
            locals: &mut locals,
            weights: &mut weights,
        };
        assert!(job.run().is_err(), "decreasing offsets");
        job.weight_offsets = &[0, 0, 2];
        assert!(job.run().is_err(), "offset past the weights");
        job.weight_offsets = &[0, 0];
        assert!(matches!(job.run(), Err(JobError::LengthMismatch { .. })));
        job.weight_offsets = &[0, 0, 1];
        job.threshold = f32::NAN;
        assert!(job.run().is_err(), "NaN threshold");
        job.threshold = 0.0;
        assert!(job.run().is_err(), "zero threshold");
        job.threshold = DEFAULT_THRESHOLD;
        job.locals = &mut [];
        assert!(matches!(job.run(), Err(JobError::BufferTooSmall { .. })));
    }

    /// 0 → 1 → {2, 3}, 3 → 4; node 5 is a separate root.
    fn tree() -> Asset {
        let parents = [None, Some(0), Some(1), Some(1), Some(3), None];
        Asset {
            nodes: parents.iter().map(|&parent| Node { parent, ..Node::default() }).collect(),
            order: vec![0, 5, 1, 3, 4, 2],
            ..Asset::default()
        }
    }

    #[test]
    fn subtree_mask_selects_descendants_with_falloff() {
        let asset = tree();
        let mut mask = [9.0; 6];
        subtree_mask(&asset, 1, 1.0, 0.0, &mut mask).expect("valid");
        assert_eq!(mask, [0.0, 1.0, 1.0, 1.0, 1.0, 0.0]);
        subtree_mask(&asset, 1, 0.8, 0.5, &mut mask).expect("valid");
        assert_eq!(mask, [0.0, 0.8, 0.4, 0.4, 0.2, 0.0]);
        subtree_mask(&asset, 3, 1.0, 1.0, &mut mask).expect("valid");
        assert_eq!(mask, [0.0, 0.0, 0.0, 1.0, 0.0, 0.0], "falloff 1: the root alone");
        subtree_mask(&asset, 0, 0.0, 0.0, &mut mask).expect("valid");
        assert_eq!(mask, [0.0; 6]);
        assert!(subtree_mask(&asset, 6, 1.0, 0.0, &mut mask).is_err(), "root out of range");
        assert!(subtree_mask(&asset, 0, f32::NAN, 0.0, &mut mask).is_err());
        assert!(subtree_mask(&asset, 0, 1.0, 1.5, &mut mask).is_err());
        assert!(subtree_mask(&asset, 0, 1.0, f32::NAN, &mut mask).is_err());
        assert!(subtree_mask(&asset, 0, 1.0, 0.0, &mut [0.0; 3]).is_err());
    }
}
