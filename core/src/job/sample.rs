//! Sampling a clip at a time into node-local transforms and morph weights.
//!
//! LINEAR translation, rotation and scale channels that share key times are sampled four at a
//! time, one per SIMD lane ([`crate::clip::LaneGroup`]); the rest one channel at a time. Each
//! key-time array keeps a key cursor in [`SampleContext`]: playback that moves forward (or
//! backward) by less than a key per frame finds its key in O(1); any other seek falls back to a
//! binary search, O(log keys).
//!
//! LINEAR rotations use shortest-arc slerp by default (the glTF spec); a context can switch
//! to normalized lerp ([`RotationLerp::Nlerp`]), which is cheaper and within ~0.2° of slerp for
//! the key spacings of typical clips (and at most ~8° for keys 180° apart).

use super::lanes::{Quat4, nlerp4, slerp_finish, slerp4};
use super::{check_eq, check_index, check_len};
use crate::asset::NodeIndex;
use crate::clip::{Channel, ChannelTarget, Clip, Interpolation, LaneGroup};
use crate::error::JobError;
use crate::math::{Mat4, Quat, QuatExt, Transform, Vec3, Vec4};

/// How LINEAR rotation keys are interpolated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RotationLerp {
    /// Spherical linear interpolation on the shortest arc (glTF's definition).
    #[default]
    Slerp,
    /// Normalized linear interpolation on the shortest arc: cheaper, slightly uneven speed.
    Nlerp,
}

/// Per-channel key cursors of one clip, reused from frame to frame, and sampling options.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SampleContext {
    /// Per channel (used by the channels sampled one at a time).
    cursors: Vec<u32>,
    /// Per four-lane group of the clip.
    group_cursors: Vec<u32>,
    rotation: RotationLerp,
    skip_constant: bool,
    /// A run completed since `new`/`reset`: constant channels have been written once.
    primed: bool,
}

impl SampleContext {
    /// A context for `clip` (one cursor per channel, all at the first key), slerping rotations.
    pub fn new(clip: &Clip) -> Self {
        let mut context = Self::default();
        context.reset(clip);
        context
    }

    /// How LINEAR rotations are interpolated (kept across [`SampleContext::reset`]).
    pub fn rotation_lerp(&self) -> RotationLerp {
        self.rotation
    }

    /// Chooses how LINEAR rotations are interpolated.
    pub fn set_rotation_lerp(&mut self, rotation: RotationLerp) {
        self.rotation = rotation;
    }

    /// Skips channels whose value never changes after they were written once (by the first
    /// successful run after [`SampleContext::new`] or [`SampleContext::reset`]). Only for a
    /// context that always samples into the same output buffers, where nothing else writes the
    /// properties this clip animates. Off by default; kept across `reset`.
    pub fn set_skip_constant(&mut self, skip: bool) {
        self.skip_constant = skip;
    }

    /// Rewinds all cursors and sets up for `clip`: allocates only when `clip` has more
    /// channels or lane groups than this context has room for.
    pub fn reset(&mut self, clip: &Clip) {
        self.cursors.clear();
        self.cursors.resize(clip.channels().len(), 0);
        self.group_cursors.clear();
        self.group_cursors.resize(clip.groups().len(), 0);
        self.primed = false;
    }

    /// Makes room for `clip` (without switching to it), so that a later
    /// [`SampleContext::reset`] to it does not allocate.
    pub(crate) fn reserve_for(&mut self, clip: &Clip) {
        let reserve = |v: &mut Vec<u32>, n: usize| v.reserve(n.saturating_sub(v.len()));
        reserve(&mut self.cursors, clip.channels().len());
        reserve(&mut self.group_cursors, clip.groups().len());
    }

    /// Number of channels this context serves.
    pub fn channel_count(&self) -> usize {
        self.cursors.len()
    }

    /// `Err` unless this context was set up for a clip shaped like `clip`.
    fn check(&self, clip: &Clip) -> Result<(), JobError> {
        check_eq("context cursors", clip.channels().len(), self.cursors.len())?;
        check_eq("context groups", clip.groups().len(), self.group_cursors.len())
    }
}

/// Samples `clip` at `time` into `locals` and `weights`, overwriting only the animated
/// properties (start from the rest pose for a complete pose).
#[derive(Debug)]
pub struct SampleJob<'a> {
    /// The clip.
    pub clip: &'a Clip,
    /// Time in seconds, clamped to `[0, clip.duration]`.
    pub time: f32,
    /// Key cursors of `clip` ([`SampleContext::new`]).
    pub context: &'a mut SampleContext,
    /// Start of each node's morph weights in `weights` ([`crate::asset::Asset::weight_offsets`]).
    pub weight_offsets: &'a [u32],
    /// Output: local transform by node.
    pub locals: &'a mut [Transform],
    /// Output: flat morph weights.
    pub weights: &'a mut [f32],
}

fn not_finite(time: f32) -> JobError {
    JobError::InvalidInput(format!("sample time {time} is not finite"))
}

impl SampleJob<'_> {
    /// Checks the time, the context, and every channel's shape and target indices.
    pub fn validate(&self) -> Result<(), JobError> {
        if !self.time.is_finite() {
            return Err(not_finite(self.time));
        }
        self.context.check(self.clip)?;
        for group in self.clip.groups() {
            for &node in &group.nodes {
                check_index("channel node", node as usize, self.locals.len())?;
            }
        }
        for channel in self.clip.channels() {
            let node = channel.node as usize;
            let width = channel.width as usize;
            check_eq("channel width", channel.target_width(), width)?;
            if channel.times.is_empty() {
                return Err(JobError::InvalidInput("channel without keys".into()));
            }
            let per_key = width * channel.elements_per_key();
            check_eq("channel values", channel.times.len() * per_key, channel.values.len())?;
            if channel.target == ChannelTarget::Weights {
                check_index("weight_offsets", node, self.weight_offsets.len())?;
                check_len("weights", self.weight_offsets[node] as usize + width, self.weights.len())?;
            } else {
                check_index("channel node", node, self.locals.len())?;
            }
        }
        Ok(())
    }

    /// Samples every channel. Checks what [`SampleJob::validate`] checks as it goes (one
    /// pass over the channels): on an error, channels before the bad one were written.
    pub fn run(&mut self) -> Result<(), JobError> {
        if !self.time.is_finite() {
            return Err(not_finite(self.time));
        }
        let context = &mut *self.context;
        context.check(self.clip)?;
        let skip = context.skip_constant && context.primed;
        let duration = self.clip.duration.max(0.0);
        let time = self.time.max(0.0).min(duration);
        let lerp = context.rotation;
        let channels = self.clip.channels();
        let mut found: Option<(u32, At)> = None;
        for (group, cursor) in self.clip.groups().iter().zip(context.group_cursors.iter_mut()) {
            // Neighbouring groups with the same key times share the key found for the first.
            let at = match found {
                Some((times_of, at)) if times_of == group.times_of => at,
                _ => {
                    let times = channels.get(group.times_of as usize).map_or(&[][..], |c| &c.times[..]);
                    locate(times, time, cursor)
                }
            };
            found = Some((group.times_of, at));
            sample_group(group, at, lerp, self.locals)?;
        }
        for &i in self.clip.singles() {
            let i = i as usize;
            let constant = self.clip.is_constant(i);
            if skip && constant {
                continue;
            }
            let (Some(channel), Some(cursor)) = (channels.get(i), context.cursors.get_mut(i)) else {
                return Err(JobError::IndexOutOfRange { what: "clip channel", index: i, len: channels.len() });
            };
            // A constant channel's value at any time is its first key's (nothing to interpolate).
            let at = if constant { At::Key(0) } else { locate(&channel.times, time, cursor) };
            let node = channel.node as usize;
            let len = self.locals.len();
            let local = || JobError::IndexOutOfRange { what: "channel node", index: node, len };
            match channel.target {
                ChannelTarget::Translation => {
                    let v = Vec3::from(sample_fixed::<3>(channel, at)?);
                    self.locals.get_mut(node).ok_or_else(local)?.translation = v;
                }
                ChannelTarget::Scale => {
                    let v = Vec3::from(sample_fixed::<3>(channel, at)?);
                    self.locals.get_mut(node).ok_or_else(local)?.scale = v;
                }
                ChannelTarget::Rotation => {
                    let q = sample_rotation(channel, at, lerp)?;
                    let target = self.locals.get_mut(node).ok_or_else(local)?;
                    if let Some(q) = q {
                        target.rotation = q;
                    }
                }
                ChannelTarget::Weights => {
                    let offsets = self.weight_offsets.len();
                    let start = *self.weight_offsets.get(node).ok_or(JobError::IndexOutOfRange {
                        what: "weight_offsets",
                        index: node,
                        len: offsets,
                    })? as usize;
                    let needed = start + channel.width as usize;
                    let got = self.weights.len();
                    let out = self.weights.get_mut(start..needed).ok_or(JobError::BufferTooSmall {
                        what: "weights",
                        needed,
                        got,
                    })?;
                    interpolate(channel, at, out)?;
                }
            }
        }
        context.primed = true;
        Ok(())
    }
}

/// The local transform of `node`, or `Err` for a node outside `locals`.
#[inline]
fn local_mut(locals: &mut [Transform], node: NodeIndex) -> Result<&mut Transform, JobError> {
    let len = locals.len();
    locals.get_mut(node as usize).ok_or(JobError::IndexOutOfRange { what: "channel node", index: node as usize, len })
}

/// Samples the members of one four-lane group at `at` (their shared keys) into `locals`.
fn sample_group(group: &LaneGroup, at: At, lerp: RotationLerp, locals: &mut [Transform]) -> Result<(), JobError> {
    let (k0, k1, u) = match at {
        At::Key(k) => (k, k, 0.0),
        At::Between { index, u, .. } => (index, index + 1, u),
    };
    let stride = group.blocks() * group.width();
    let row = |k: usize| {
        let needed = (k + 1) * stride;
        group.values.get(k * stride..needed).ok_or(JobError::BufferTooSmall {
            what: "group values",
            needed,
            got: group.values.len(),
        })
    };
    let (from, to) = (row(k0)?, row(k1)?);
    let u = Vec4::splat(u);
    let width = group.width();
    let blocks_len = group.blocks();
    let blocks = from.chunks_exact(width).zip(to.chunks_exact(width)).zip(group.nodes.chunks(4));
    match group.target {
        ChannelTarget::Rotation if lerp == RotationLerp::Nlerp => {
            for ((a, b), nodes) in blocks {
                let q = nlerp4(&Quat4::from_block(a), &Quat4::from_block(b), u);
                for (&node, q) in nodes.iter().zip(q.to_quats()) {
                    local_mut(locals, node)?.rotation = q;
                }
            }
        }
        ChannelTarget::Rotation => {
            // The keys' angles were computed with the clip; at a key there is nothing to blend.
            let angles = match at {
                At::Between { index, .. } => group.angles.get(index * 2 * blocks_len..(index + 1) * 2 * blocks_len),
                At::Key(_) => None,
            };
            match angles {
                Some(angles) => {
                    for (((a, b), nodes), angle) in blocks.zip(angles.chunks_exact(2)) {
                        let q = slerp_finish(&Quat4::from_block(a), &Quat4::from_block(b), u, angle[0], angle[1]);
                        for (&node, q) in nodes.iter().zip(q.to_quats()) {
                            local_mut(locals, node)?.rotation = q;
                        }
                    }
                }
                None => {
                    for ((a, _), nodes) in blocks {
                        for (&node, q) in nodes.iter().zip(Quat4::from_block(a).to_quats()) {
                            local_mut(locals, node)?.rotation = q;
                        }
                    }
                }
            }
        }
        target => {
            let scale = target == ChannelTarget::Scale;
            for ((a, b), nodes) in blocks {
                // Exactly `a` at a key, as one channel at a time gives (even where b − a overflows).
                let at_key = u.cmpeq(Vec4::ZERO);
                let l = |c: usize| Vec4::select(at_key, a[c], a[c] + (b[c] - a[c]) * u);
                let m = Mat4::from_cols(l(0), l(1), l(2), Vec4::ZERO).transpose();
                for (&node, v) in nodes.iter().zip([m.x_axis, m.y_axis, m.z_axis, m.w_axis]) {
                    let local = local_mut(locals, node)?;
                    if scale {
                        local.scale = v.truncate();
                    } else {
                        local.translation = v.truncate();
                    }
                }
            }
        }
    }
    Ok(())
}

/// One channel's value at `time` (clamped to its keys), exactly as [`SampleJob`] computes it
/// (for a channel that is the only one of its property in its clip): `channel.width` floats
/// into `out` (a rotation as `[x, y, z, w]`, unit length); a channel whose keys are all equal
/// gives its first key. For a plot or a probe of one property; [`SampleJob`] is the per-frame
/// path for whole clips.
///
/// # Errors
/// `out` is not `channel.width` long, a non-finite `time`, or values shorter than the keys.
pub fn sample_channel(channel: &Channel, time: f32, rotation: RotationLerp, out: &mut [f32]) -> Result<(), JobError> {
    if !time.is_finite() {
        return Err(not_finite(time));
    }
    check_eq("output width", channel.width as usize, out.len())?;
    let at = if crate::clip::is_constant(channel) { At::Key(0) } else { locate(&channel.times, time, &mut 0) };
    match channel.target {
        ChannelTarget::Rotation => {
            let q = sample_rotation(channel, at, rotation)?.unwrap_or(Quat::IDENTITY);
            out.copy_from_slice(&q.to_array());
            Ok(())
        }
        _ => interpolate(channel, at, out),
    }
}

/// Where a time falls among a channel's keys.
#[derive(Clone, Copy, Debug, PartialEq)]
enum At {
    /// Exactly the value of this key (before the first, after the last, or a single key).
    Key(usize),
    /// Between key `index` and `index + 1`: normalized position `u` in `[0, 1)` and the
    /// segment length `dt` in seconds.
    Between { index: usize, u: f32, dt: f32 },
}

/// Finds the segment holding `t`, starting from `cursor` and updating it.
fn locate(times: &[f32], t: f32, cursor: &mut u32) -> At {
    let n = times.len();
    let (Some(&first), Some(&last)) = (times.first(), times.last()) else { return At::Key(0) };
    if n == 1 || t <= first {
        *cursor = 0;
        return At::Key(0);
    }
    if t >= last {
        *cursor = (n - 2) as u32;
        return At::Key(n - 1);
    }
    // Here first < t < last, so n >= 2 and a segment i with times[i] <= t < times[i + 1] exists.
    let mut i = (*cursor as usize).min(n - 2);
    if times[i] <= t {
        if t >= times[i + 1] {
            i = if i + 2 < n && t < times[i + 2] { i + 1 } else { segment_of(times, t) };
        }
    } else {
        i = if i > 0 && times[i - 1] <= t { i - 1 } else { segment_of(times, t) };
    }
    *cursor = i as u32;
    let dt = times[i + 1] - times[i];
    let u = if dt > 0.0 { ((t - times[i]) / dt).clamp(0.0, 1.0) } else { 0.0 };
    At::Between { index: i, u, dt }
}

/// Binary search: the last `i <= n - 2` with `times[i] <= t` (for `times[0] < t < times[n-1]`).
fn segment_of(times: &[f32], t: f32) -> usize {
    times.partition_point(|&k| k <= t).saturating_sub(1).min(times.len().saturating_sub(2))
}

/// `Err` for a channel whose values do not hold the element asked for.
fn short_values(channel: &Channel, needed: usize) -> JobError {
    JobError::BufferTooSmall { what: "channel values", needed, got: channel.values.len() }
}

/// The element (`width` floats) of key `k`: for cubic splines, `part` 0 = in-tangent,
/// 1 = value, 2 = out-tangent.
fn element(channel: &Channel, k: usize, part: usize) -> Result<&[f32], JobError> {
    let w = channel.width as usize;
    let e = if channel.interpolation == Interpolation::CubicSpline { 3 * k + part } else { k };
    channel.values.get(e * w..(e + 1) * w).ok_or_else(|| short_values(channel, (e + 1) * w))
}

/// [`element`] of a channel of width `W`.
#[inline]
fn fixed<const W: usize>(channel: &Channel, k: usize, part: usize) -> Result<[f32; W], JobError> {
    let e = if channel.interpolation == Interpolation::CubicSpline { 3 * k + part } else { k };
    channel
        .values
        .get(e * W..(e + 1) * W)
        .and_then(|s| <[f32; W]>::try_from(s).ok())
        .ok_or_else(|| short_values(channel, (e + 1) * W))
}

/// Cubic Hermite basis `(h00, h10, h01, h11)` at `u`, tangent terms scaled by `dt`.
#[inline]
fn hermite(u: f32, dt: f32) -> [f32; 4] {
    let (u2, u3) = (u * u, u * u * u);
    [2.0 * u3 - 3.0 * u2 + 1.0, (u3 - 2.0 * u2 + u) * dt, -2.0 * u3 + 3.0 * u2, (u3 - u2) * dt]
}

/// Step, lerp or cubic Hermite of a channel of width `W` (checked against `channel.width`).
#[inline]
fn sample_fixed<const W: usize>(channel: &Channel, at: At) -> Result<[f32; W], JobError> {
    check_eq("channel width", W, channel.width as usize)?;
    match at {
        At::Key(k) => fixed(channel, k, 1),
        At::Between { index, u, dt } => match channel.interpolation {
            Interpolation::Step => fixed(channel, index, 1),
            Interpolation::Linear => {
                let (mut a, b) = (fixed::<W>(channel, index, 1)?, fixed::<W>(channel, index + 1, 1)?);
                if u != 0.0 {
                    for (a, b) in a.iter_mut().zip(b) {
                        *a += (b - *a) * u;
                    }
                }
                Ok(a)
            }
            Interpolation::CubicSpline => {
                let [h00, h10, h01, h11] = hermite(u, dt);
                let (v0, b0) = (fixed::<W>(channel, index, 1)?, fixed::<W>(channel, index, 2)?);
                let (v1, a1) = (fixed::<W>(channel, index + 1, 1)?, fixed::<W>(channel, index + 1, 0)?);
                Ok(std::array::from_fn(|i| h00 * v0[i] + h10 * b0[i] + h01 * v1[i] + h11 * a1[i]))
            }
        },
    }
}

/// Component-wise interpolation into `out` (`channel.width` floats): step, lerp, or
/// cubic Hermite.
fn interpolate(channel: &Channel, at: At, out: &mut [f32]) -> Result<(), JobError> {
    check_eq("channel width", channel.width as usize, out.len())?;
    match at {
        At::Key(k) => out.copy_from_slice(element(channel, k, 1)?),
        At::Between { index, u, dt } => match channel.interpolation {
            Interpolation::Step => out.copy_from_slice(element(channel, index, 1)?),
            Interpolation::Linear => {
                let (a, b) = (element(channel, index, 1)?, element(channel, index + 1, 1)?);
                for ((o, &a), &b) in out.iter_mut().zip(a).zip(b) {
                    *o = if u == 0.0 { a } else { a + (b - a) * u };
                }
            }
            Interpolation::CubicSpline => {
                let [h00, h10, h01, h11] = hermite(u, dt);
                let (v0, b0) = (element(channel, index, 1)?, element(channel, index, 2)?);
                let (v1, a1) = (element(channel, index + 1, 1)?, element(channel, index + 1, 0)?);
                for (i, o) in out.iter_mut().enumerate() {
                    *o = h00 * v0[i] + h10 * b0[i] + h01 * v1[i] + h11 * a1[i];
                }
            }
        },
    }
    Ok(())
}

/// Samples a rotation channel: shortest-arc slerp (or nlerp) for LINEAR, normalized Hermite
/// for CUBICSPLINE. `Ok(None)` only for a degenerate (zero) cubic result.
fn sample_rotation(channel: &Channel, at: At, lerp: RotationLerp) -> Result<Option<Quat>, JobError> {
    match (at, channel.interpolation) {
        (At::Between { index, u, .. }, Interpolation::Linear) => {
            check_eq("channel width", 4, channel.width as usize)?;
            let (a, b) = (Quat::from_array(fixed(channel, index, 1)?), Quat::from_array(fixed(channel, index + 1, 1)?));
            Ok(Some(match lerp {
                RotationLerp::Slerp => slerp(a, b, u),
                RotationLerp::Nlerp => nlerp(a, b, u),
            }))
        }
        (_, Interpolation::CubicSpline) => Ok(Quat::from_array(sample_fixed(channel, at)?).try_normalize_quat()),
        _ => Ok(Some(Quat::from_array(sample_fixed(channel, at)?))),
    }
}

/// Spherical linear interpolation along the shortest arc; exact at `u == 0`. The same
/// arithmetic as one lane of [`SampleJob`]'s four-lane sampling (within 5e-7 of the exact
/// slerp of unit inputs).
pub fn slerp(a: Quat, b: Quat, u: f32) -> Quat {
    slerp4(&Quat4::splat(a), &Quat4::splat(b), Vec4::splat(u)).first()
}

/// Normalized linear interpolation along the shortest arc; exact at `u == 0`; `a` when the
/// inputs lerp through zero (possible only when they were not unit).
pub fn nlerp(a: Quat, b: Quat, u: f32) -> Quat {
    nlerp4(&Quat4::splat(a), &Quat4::splat(b), Vec4::splat(u)).first()
}

#[cfg(test)]
mod sample_channel_tests {
    use super::*;

    #[test]
    fn matches_the_job_and_rejects_bad_input() {
        let channel = Channel {
            node: 0,
            target: ChannelTarget::Translation,
            interpolation: Interpolation::Linear,
            times: vec![0.0, 1.0],
            values: vec![0.0, 0.0, 0.0, 2.0, 4.0, 6.0],
            width: 3,
        };
        let mut out = [0.0; 3];
        assert!(sample_channel(&channel, 0.25, RotationLerp::Slerp, &mut out).is_ok());
        assert_eq!(out, [0.5, 1.0, 1.5]);
        assert!(sample_channel(&channel, 7.0, RotationLerp::Slerp, &mut out).is_ok());
        assert_eq!(out, [2.0, 4.0, 6.0], "clamped to the last key");
        assert!(sample_channel(&channel, f32::NAN, RotationLerp::Slerp, &mut out).is_err());
        assert!(sample_channel(&channel, 0.5, RotationLerp::Slerp, &mut [0.0; 2]).is_err());
        let rotation = Channel {
            target: ChannelTarget::Rotation,
            values: vec![0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0],
            width: 4,
            ..channel
        };
        let mut q = [0.0; 4];
        assert!(sample_channel(&rotation, 0.5, RotationLerp::Slerp, &mut q).is_ok());
        let half = std::f32::consts::FRAC_1_SQRT_2;
        assert!((q[1] - half).abs() < 1e-5 && (q[3] - half).abs() < 1e-5, "{q:?}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::FRAC_PI_2;

    #[test]
    fn slerp_stays_unit_just_past_the_nlerp_cut_over() {
        // Keys 3.7°–10° apart (cos of the half angle just under 0.9995): where sin θ came from
        // 1 − d² in f32 the result was ~3e-5 off unit length.
        for degrees in [3.7f32, 4.0, 4.5, 6.0, 10.0] {
            let a = Quat::from_rotation_x(0.3) * Quat::from_rotation_z(-1.1);
            let b = a * Quat::from_rotation_y(degrees.to_radians());
            for u in [0.1, 0.25, 0.5, 0.75, 0.9] {
                let q = slerp(a, b, u);
                assert!((q.length() - 1.0).abs() < 2e-6, "{degrees}° at {u}: |q| = {}", q.length());
            }
        }
    }

    fn channel(target: ChannelTarget, interpolation: Interpolation, times: &[f32], values: &[f32]) -> Channel {
        let width = match target {
            ChannelTarget::Rotation => 4,
            ChannelTarget::Weights => {
                let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
                (values.len() / times.len() / per_key) as u32
            }
            _ => 3,
        };
        Channel { node: 0, target, interpolation, times: times.to_vec(), values: values.to_vec(), width }
    }

    fn clip(channels: Vec<Channel>) -> Clip {
        Clip::from_channels(None, channels)
    }

    /// Samples a one-node clip at `t` with a fresh context.
    fn sample(clip: &Clip, t: f32) -> (Transform, Vec<f32>) {
        let mut context = SampleContext::new(clip);
        sample_with(clip, t, &mut context)
    }

    fn sample_with(clip: &Clip, t: f32, context: &mut SampleContext) -> (Transform, Vec<f32>) {
        let mut locals = [Transform::IDENTITY];
        let mut weights = vec![0.0; 2];
        SampleJob { clip, time: t, context, weight_offsets: &[0], locals: &mut locals, weights: &mut weights }
            .run()
            .expect("valid clip");
        (locals[0], weights)
    }

    #[test]
    fn step_holds_the_previous_key() {
        let c = clip(vec![channel(
            ChannelTarget::Translation,
            Interpolation::Step,
            &[0.0, 1.0, 2.0],
            &[0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 5.0, 5.0, 5.0],
        )]);
        assert_eq!(sample(&c, 0.0).0.translation, Vec3::ZERO);
        assert_eq!(sample(&c, 0.999).0.translation, Vec3::ZERO);
        assert_eq!(sample(&c, 1.0).0.translation, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(sample(&c, 1.5).0.translation, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(sample(&c, 2.0).0.translation, Vec3::splat(5.0));
        assert_eq!(sample(&c, 9.0).0.translation, Vec3::splat(5.0), "clamped to duration");
        assert_eq!(sample(&c, -1.0).0.translation, Vec3::ZERO, "clamped to 0");
    }

    #[test]
    fn linear_is_exact_at_keys_and_midpoints() {
        let c = clip(vec![
            channel(ChannelTarget::Scale, Interpolation::Linear, &[1.0, 3.0], &[1.0, 1.0, 1.0, 3.0, 5.0, -1.0]),
            channel(ChannelTarget::Weights, Interpolation::Linear, &[0.0, 4.0], &[0.0, 1.0, 1.0, 0.0]),
        ]);
        // Before the first key of a channel: its first value (shared clock from 0).
        assert_eq!(sample(&c, 0.5).0.scale, Vec3::ONE);
        assert_eq!(sample(&c, 1.0).0.scale, Vec3::ONE);
        assert_eq!(sample(&c, 2.0).0.scale, Vec3::new(2.0, 3.0, 0.0));
        assert_eq!(sample(&c, 3.0).0.scale, Vec3::new(3.0, 5.0, -1.0));
        assert_eq!(sample(&c, 3.5).0.scale, Vec3::new(3.0, 5.0, -1.0), "held after its last key");
        assert_eq!(sample(&c, 1.0).1, vec![0.25, 0.75]);
        assert_eq!(sample(&c, 4.0).1, vec![1.0, 0.0]);
    }

    #[test]
    fn rotation_slerps_along_the_shortest_arc() {
        let q0 = Quat::IDENTITY;
        let q1 = Quat::from_rotation_y(FRAC_PI_2);
        // The second key is stored negated: same rotation, the long way round unless flipped.
        let v: Vec<f32> = [q0.to_array(), (-q1).to_array()].concat();
        let c = clip(vec![channel(ChannelTarget::Rotation, Interpolation::Linear, &[0.0, 1.0], &v)]);
        assert_eq!(sample(&c, 0.0).0.rotation, q0);
        let mid = sample(&c, 0.5).0.rotation;
        let expect = Quat::from_rotation_y(FRAC_PI_2 / 2.0);
        assert!(mid.abs_diff_eq(expect, 1e-6) || mid.abs_diff_eq(-expect, 1e-6), "{mid}");
        let quarter = sample(&c, 0.25).0.rotation;
        let expect = Quat::from_rotation_y(FRAC_PI_2 / 4.0);
        assert!(quarter.abs_diff_eq(expect, 1e-6) || quarter.abs_diff_eq(-expect, 1e-6), "{quarter}");
        assert!((sample(&c, 1.0).0.rotation.length() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn nlerp_option_follows_the_shortest_arc_close_to_slerp() {
        let q0 = Quat::IDENTITY;
        let q1 = Quat::from_rotation_y(FRAC_PI_2);
        let v: Vec<f32> = [q0.to_array(), (-q1).to_array()].concat();
        let c = clip(vec![channel(ChannelTarget::Rotation, Interpolation::Linear, &[0.0, 1.0], &v)]);
        let mut context = SampleContext::new(&c);
        assert_eq!(context.rotation_lerp(), RotationLerp::Slerp);
        context.set_rotation_lerp(RotationLerp::Nlerp);
        context.reset(&c);
        assert_eq!(context.rotation_lerp(), RotationLerp::Nlerp, "kept across reset");
        // At the midpoint nlerp and slerp agree exactly (symmetry).
        let mid = sample_with(&c, 0.5, &mut context).0.rotation;
        let expect = Quat::from_rotation_y(FRAC_PI_2 / 2.0);
        assert!(mid.abs_diff_eq(expect, 1e-6) || mid.abs_diff_eq(-expect, 1e-6), "{mid}");
        // Elsewhere nlerp is unit length, differs from slerp, but by less than a degree here.
        let quarter = sample_with(&c, 0.25, &mut context).0.rotation;
        let slerped = sample(&c, 0.25).0.rotation;
        assert!((quarter.length() - 1.0).abs() < 1e-6);
        assert_ne!(quarter, slerped);
        assert!(quarter.angle_between(slerped) < 1f32.to_radians(), "{quarter} vs {slerped}");
        assert_eq!(sample_with(&c, 0.0, &mut context).0.rotation, q0, "exact at keys");
        assert_eq!(nlerp(q0, q1, 0.0), q0);
        assert!(nlerp(q0, q1, 1.0).abs_diff_eq(q1, 1e-6));
    }

    #[test]
    fn cubic_spline_follows_hermite() {
        // One scalar weight: keys (t=0, v=0, out=1) and (t=2, in=3, v=1).
        // p(u) = h10·dt·1 + h01·1 + h11·dt·3 with dt = 2; at u = 0.5:
        // h10 = 0.125, h01 = 0.5, h11 = -0.125 -> 0.25 + 0.5 - 0.75 = 0.
        let c = clip(vec![channel(
            ChannelTarget::Weights,
            Interpolation::CubicSpline,
            &[0.0, 2.0],
            &[9.0, 0.0, 1.0, 3.0, 1.0, 9.0],
        )]);
        assert_eq!(sample(&c, 0.0).1[0], 0.0);
        assert!((sample(&c, 1.0).1[0] - 0.0).abs() < 1e-6, "{}", sample(&c, 1.0).1[0]);
        // u = 0.25: h10 = 0.140625, h01 = 0.15625, h11 = -0.046875 -> 0.28125 + 0.15625 - 0.28125.
        assert!((sample(&c, 0.5).1[0] - 0.15625).abs() < 1e-6, "{}", sample(&c, 0.5).1[0]);
        assert_eq!(sample(&c, 2.0).1[0], 1.0);
    }

    #[test]
    fn cubic_rotation_is_normalized() {
        let q0 = Quat::IDENTITY.to_array();
        let q1 = Quat::from_rotation_x(1.0).to_array();
        let zero = [0.0; 4];
        let v: Vec<f32> = [zero, q0, zero, zero, q1, zero].concat();
        let c = clip(vec![channel(ChannelTarget::Rotation, Interpolation::CubicSpline, &[0.0, 1.0], &v)]);
        let r = sample(&c, 0.3).0.rotation;
        assert!((r.length() - 1.0).abs() < 1e-6);
        assert_eq!(sample(&c, 1.0).0.rotation, Quat::from_array(q1));
    }

    /// Samples `clip` the reference way: each channel alone through [`sample_channel`], in clip
    /// order (a later channel of the same property wins), over the rest pose `base`.
    fn one_at_a_time(clip: &Clip, t: f32, lerp: RotationLerp, base: &[Transform]) -> Vec<Transform> {
        let mut out = base.to_vec();
        for c in clip.channels() {
            let mut v = vec![0.0; c.width as usize];
            sample_channel(c, t, lerp, &mut v).expect("valid channel");
            let local = &mut out[c.node as usize];
            match c.target {
                ChannelTarget::Translation => local.translation = Vec3::from_slice(&v),
                ChannelTarget::Scale => local.scale = Vec3::from_slice(&v),
                ChannelTarget::Rotation => local.rotation = Quat::from_slice(&v),
                ChannelTarget::Weights => {}
            }
        }
        out
    }

    #[test]
    fn lane_groups_sample_exactly_like_one_channel_at_a_time() {
        // 12 nodes; rotations on two key sets (one group of 8 rotations: two full blocks, one
        // of 1), translations sharing the first key set, a scale with its own keys, and sampled
        // one at a time: a STEP, a constant rotation, and node 3's rotation animated twice.
        let mut seed = 3u32;
        let mut next = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        let times_a: Vec<f32> = (0..12).map(|k| k as f32 * 0.1 + if k % 3 == 0 { 0.02 } else { 0.0 }).collect();
        let times_b = [0.0, 0.4, 0.45, 1.3];
        let mut rotation = |node: u32, times: &[f32], interpolation| {
            let values = times
                .iter()
                .flat_map(|_| {
                    let q = Quat::from_xyzw(next(), next(), next(), next()).normalize();
                    // Some keys on the far hemisphere, to exercise the shortest-arc sign.
                    let q = if next() > 0.0 { -q } else { q };
                    q.to_array()
                })
                .collect();
            Channel { node, target: ChannelTarget::Rotation, interpolation, times: times.to_vec(), values, width: 4 }
        };
        let mut channels: Vec<Channel> = (0..9).map(|n| rotation(n, &times_a, Interpolation::Linear)).collect();
        channels.push(rotation(9, &times_b, Interpolation::Linear));
        channels.push(rotation(3, &times_b, Interpolation::Linear));
        channels.push(rotation(10, &times_b, Interpolation::Step));
        let still = Quat::from_rotation_x(0.4).to_array().repeat(2);
        channels.push(channel(ChannelTarget::Rotation, Interpolation::Linear, &[0.0, 1.0], &still));
        channels.last_mut().expect("pushed").node = 11;
        for node in [0, 4, 5] {
            let values = times_a.iter().flat_map(|&t| [t, -2.0 * t, (node as f32 + t).sin()]).collect::<Vec<_>>();
            channels.push(Channel {
                node,
                ..channel(ChannelTarget::Translation, Interpolation::Linear, &times_a, &values)
            });
        }
        channels.push(Channel {
            node: 7,
            ..channel(
                ChannelTarget::Scale,
                Interpolation::Linear,
                &times_b,
                &[1.0, 1.0, 1.0, 2.0, 1.0, 0.5, 2.0, 3.0, 1.0, 1.0, 1.0, 1.0],
            )
        });
        let c = clip(channels);
        assert_eq!(c.groups().len(), 4, "rotations ×2 key sets, translations, scale");
        assert_eq!(c.singles(), [3, 10, 11, 12], "node 3's two, the STEP, the constant one");
        assert!(!c.is_constant(10) && c.is_constant(12), "node 3 twice is not constant; the still one is");
        let lanes: usize = c.groups().iter().map(|g| (g.values.len() + g.angles.len()) * size_of::<Vec4>()).sum();
        assert_eq!(
            Clip::layout_bytes(c.channels()),
            (lanes + 8 * c.channels().len()) as u64,
            "what the budget is charged"
        );

        let base: Vec<Transform> =
            (0..12).map(|i| Transform { translation: Vec3::splat(i as f32), ..Transform::IDENTITY }).collect();
        for lerp in [RotationLerp::Slerp, RotationLerp::Nlerp] {
            let mut context = SampleContext::new(&c);
            context.set_rotation_lerp(lerp);
            let times = (0..200).map(|i| i as f32 * 0.0071).chain([0.0, 0.3, 0.45, 1.1, 5.0, 0.02, 0.4]);
            for t in times {
                let mut locals = base.clone();
                SampleJob {
                    clip: &c,
                    time: t,
                    context: &mut context,
                    weight_offsets: &[0; 12],
                    locals: &mut locals,
                    weights: &mut [],
                }
                .run()
                .expect("valid clip");
                assert_eq!(locals, one_at_a_time(&c, t, lerp, &base), "{lerp:?} at {t}");
            }
        }
    }

    #[test]
    fn grouped_translations_are_exact_at_keys_even_where_the_difference_overflows() {
        let values = [f32::MAX, 0.0, 1.0, -f32::MAX, 0.0, 2.0, f32::MAX, 1.0, 3.0];
        let c = clip(vec![channel(ChannelTarget::Translation, Interpolation::Linear, &[0.0, 1.0, 2.0], &values)]);
        assert_eq!(c.groups().len(), 1);
        assert_eq!(sample(&c, 1.0).0.translation, Vec3::new(-f32::MAX, 0.0, 2.0));
        assert_eq!(sample(&c, 0.0).0.translation, Vec3::new(f32::MAX, 0.0, 1.0));
    }

    #[test]
    fn cursor_seeking_matches_binary_search() {
        let times: Vec<f32> = (0..50).map(|i| i as f32 * 0.1 + (i % 3) as f32 * 0.01).collect();
        let mut cursor = 0;
        let probe = |t: f32, cursor: &mut u32| {
            let cached = locate(&times, t, cursor);
            let fresh = locate(&times, t, &mut 0);
            assert_eq!(cached, fresh, "t = {t}");
            if let At::Between { index, .. } = fresh {
                assert!(times[index] <= t && t < times[index + 1]);
                assert_eq!(index, times.partition_point(|&k| k <= t) - 1);
            }
        };
        let forward = (0..600).map(|i| i as f32 / 120.0);
        let backward = (0..600).rev().map(|i| i as f32 / 120.0);
        let jumps = [4.0, 0.05, 2.5, 2.49, 4.95, 0.0, 10.0, 0.2, 3.0, 0.1];
        for t in forward.chain(backward).chain(jumps) {
            probe(t, &mut cursor);
        }
        // And through the job: a persistent context gives the same pose as a fresh one.
        let values: Vec<f32> = times.iter().flat_map(|&t| [t.sin(), t, 1.0]).collect();
        let c = clip(vec![channel(ChannelTarget::Translation, Interpolation::Linear, &times, &values)]);
        let mut context = SampleContext::new(&c);
        for t in [0.0, 0.3, 0.31, 2.0, 1.0, 0.95, 4.9, 0.0] {
            assert_eq!(sample_with(&c, t, &mut context), sample(&c, t));
        }
    }

    #[test]
    fn constant_channels_are_skipped_once_written_when_asked() {
        let c = clip(vec![
            channel(ChannelTarget::Translation, Interpolation::Linear, &[0.0, 1.0], &[1.0, 2.0, 3.0, 1.0, 2.0, 3.0]),
            channel(ChannelTarget::Scale, Interpolation::Linear, &[0.0, 1.0], &[1.0, 1.0, 1.0, 3.0, 3.0, 3.0]),
        ]);
        let cubic =
            channel(ChannelTarget::Weights, Interpolation::CubicSpline, &[0.0, 1.0], &[0.0, 5.0, 0.0, 0.0, 5.0, 0.0]);
        let bent =
            channel(ChannelTarget::Weights, Interpolation::CubicSpline, &[0.0, 1.0], &[0.0, 5.0, 1.0, 0.0, 5.0, 0.0]);
        assert!(c.is_constant(0) && !c.is_constant(1));
        assert!(crate::clip::is_constant(&cubic) && !crate::clip::is_constant(&bent), "a tangent moves the value");
        for skip in [false, true] {
            let mut context = SampleContext::new(&c);
            context.set_skip_constant(skip);
            let (mut locals, mut weights) = ([Transform::IDENTITY], [0.0; 2]);
            let mut run = |t: f32, locals: &mut [Transform; 1], context: &mut SampleContext| {
                SampleJob { clip: &c, time: t, context, weight_offsets: &[0], locals, weights: &mut weights }
                    .run()
                    .expect("valid");
            };
            run(0.5, &mut locals, &mut context);
            assert_eq!(locals[0].translation, Vec3::new(1.0, 2.0, 3.0), "written on the first run");
            locals[0].translation = Vec3::ZERO;
            run(0.75, &mut locals, &mut context);
            assert_eq!(locals[0].scale, Vec3::splat(2.5), "varying channels are always written");
            let expected = if skip { Vec3::ZERO } else { Vec3::new(1.0, 2.0, 3.0) };
            assert_eq!(locals[0].translation, expected, "skip = {skip}");
            context.reset(&c);
            run(0.75, &mut locals, &mut context);
            assert_eq!(locals[0].translation, Vec3::new(1.0, 2.0, 3.0), "written again after a reset");
        }
    }

    #[test]
    fn run_checks_channels_as_it_goes() {
        let good = channel(ChannelTarget::Translation, Interpolation::Linear, &[0.0, 1.0], &[0.0; 6]);
        let cases = [
            ("short values", Channel { values: vec![0.0; 4], ..good.clone() }),
            ("no keys", Channel { times: vec![], values: vec![], ..good.clone() }),
            ("wrong width", Channel { width: 4, values: vec![0.0; 8], ..good.clone() }),
            ("rotation width", Channel { target: ChannelTarget::Rotation, ..good.clone() }),
            ("cubic without tangents", Channel { interpolation: Interpolation::CubicSpline, ..good.clone() }),
            ("node", Channel { node: 3, ..good.clone() }),
            ("weights node", Channel { target: ChannelTarget::Weights, node: 3, width: 3, ..good.clone() }),
            ("weights buffer", Channel { target: ChannelTarget::Weights, width: 3, ..good.clone() }),
        ];
        let beside_good = cases.into_iter().map(|(what, bad)| (what, clip(vec![good.clone(), bad])));
        // Alone on its property, a short channel whose few values are all equal is still refused
        // (it is not "constant").
        let alone = ("short values alone", clip(vec![Channel { node: 1, values: vec![0.0; 4], ..good.clone() }]));
        for (what, c) in beside_good.chain([alone]) {
            let mut context = SampleContext::new(&c);
            let (mut locals, mut weights) = ([Transform::IDENTITY; 2], [0.0; 2]);
            let mut job = SampleJob {
                clip: &c,
                time: 0.5,
                context: &mut context,
                weight_offsets: &[0, 0],
                locals: &mut locals,
                weights: &mut weights,
            };
            assert!(job.validate().is_err(), "{what}: validate");
            assert!(job.run().is_err(), "{what}: run");
        }
    }

    #[test]
    fn invalid_jobs_are_refused() {
        let c = clip(vec![channel(ChannelTarget::Translation, Interpolation::Linear, &[0.0], &[1.0, 2.0, 3.0])]);
        let mut context = SampleContext::default();
        let mut locals = [Transform::IDENTITY];
        let mut job = SampleJob {
            clip: &c,
            time: 0.0,
            context: &mut context,
            weight_offsets: &[],
            locals: &mut locals,
            weights: &mut [],
        };
        assert!(job.run().is_err(), "context of another clip");
        let mut context = SampleContext::new(&c);
        let mut job = SampleJob {
            clip: &c,
            time: f32::NAN,
            context: &mut context,
            weight_offsets: &[],
            locals: &mut locals,
            weights: &mut [],
        };
        assert!(job.run().is_err(), "NaN time");
        let mut channels = c.channels().to_vec();
        channels[0].node = 4;
        let bad = clip(channels);
        let mut job = SampleJob {
            clip: &bad,
            time: 0.0,
            context: &mut context,
            weight_offsets: &[],
            locals: &mut locals,
            weights: &mut [],
        };
        assert!(matches!(job.run(), Err(JobError::IndexOutOfRange { .. })));
        let bad = clip(vec![channel(ChannelTarget::Weights, Interpolation::Linear, &[0.0], &[1.0, 2.0])]);
        let mut job = SampleJob {
            clip: &bad,
            time: 0.0,
            context: &mut context,
            weight_offsets: &[0],
            locals: &mut locals,
            weights: &mut [0.0],
        };
        assert!(matches!(job.run(), Err(JobError::BufferTooSmall { .. })));
        let zero = clip(vec![channel(ChannelTarget::Translation, Interpolation::Step, &[0.0], &[1.0, 2.0, 3.0])]);
        assert_eq!(sample(&zero, 5.0).0.translation, Vec3::new(1.0, 2.0, 3.0), "zero-duration clip");
    }
}
