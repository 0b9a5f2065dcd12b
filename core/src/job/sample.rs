//! Sampling a clip at a time into node-local transforms and morph weights.
//!
//! Each channel keeps a key cursor in [`SampleContext`]: playback that moves forward (or
//! backward) by less than a key per frame finds its key in O(1); any other seek falls
//! back to a binary search, O(log keys).

use super::{check_eq, check_index, check_len};
use crate::clip::{Channel, ChannelTarget, Clip, Interpolation};
use crate::error::JobError;
use crate::math::{Quat, QuatExt, Transform, Vec3, Vec4};

/// Per-channel key cursors of one clip, reused from frame to frame.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SampleContext {
    cursors: Vec<u32>,
}

impl SampleContext {
    /// A context for `clip` (one cursor per channel, all at the first key).
    pub fn new(clip: &Clip) -> Self {
        Self { cursors: vec![0; clip.channels.len()] }
    }

    /// Rewinds all cursors and resizes for `clip` (allocates only when `clip` has more
    /// channels than any clip this context served before).
    pub fn reset(&mut self, clip: &Clip) {
        self.cursors.clear();
        self.cursors.resize(clip.channels.len(), 0);
    }

    /// Number of channels this context serves.
    pub fn channel_count(&self) -> usize {
        self.cursors.len()
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

impl SampleJob<'_> {
    /// Checks the time, the context, and every channel's shape and target indices.
    pub fn validate(&self) -> Result<(), JobError> {
        if !self.time.is_finite() {
            return Err(JobError::InvalidInput(format!("sample time {} is not finite", self.time)));
        }
        check_eq("context cursors", self.clip.channels.len(), self.context.cursors.len())?;
        for channel in &self.clip.channels {
            let node = channel.node as usize;
            let width = channel.width as usize;
            let expected_width = match channel.target {
                ChannelTarget::Translation | ChannelTarget::Scale => 3,
                ChannelTarget::Rotation => 4,
                ChannelTarget::Weights => width,
            };
            check_eq("channel width", expected_width, width)?;
            if channel.times.is_empty() {
                return Err(JobError::InvalidInput("channel without keys".into()));
            }
            let per_key = if channel.interpolation == Interpolation::CubicSpline { 3 } else { 1 };
            check_eq("channel values", channel.times.len() * width * per_key, channel.values.len())?;
            if channel.target == ChannelTarget::Weights {
                check_index("weight_offsets", node, self.weight_offsets.len())?;
                check_len("weights", self.weight_offsets[node] as usize + width, self.weights.len())?;
            } else {
                check_index("channel node", node, self.locals.len())?;
            }
        }
        Ok(())
    }

    /// Validates, then samples every channel.
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        let duration = self.clip.duration.max(0.0);
        let time = self.time.max(0.0).min(duration);
        for (channel, cursor) in self.clip.channels.iter().zip(self.context.cursors.iter_mut()) {
            let at = locate(&channel.times, time, cursor);
            let node = channel.node as usize;
            match channel.target {
                ChannelTarget::Translation => {
                    let mut v = [0.0; 3];
                    interpolate(channel, at, &mut v);
                    self.locals[node].translation = Vec3::from(v);
                }
                ChannelTarget::Scale => {
                    let mut v = [0.0; 3];
                    interpolate(channel, at, &mut v);
                    self.locals[node].scale = Vec3::from(v);
                }
                ChannelTarget::Rotation => {
                    if let Some(q) = sample_rotation(channel, at) {
                        self.locals[node].rotation = q;
                    }
                }
                ChannelTarget::Weights => {
                    let start = self.weight_offsets[node] as usize;
                    interpolate(channel, at, &mut self.weights[start..start + channel.width as usize]);
                }
            }
        }
        Ok(())
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

/// The element (`width` floats) of key `k`: for cubic splines, `part` 0 = in-tangent,
/// 1 = value, 2 = out-tangent.
fn element(channel: &Channel, k: usize, part: usize) -> &[f32] {
    let w = channel.width as usize;
    let e = if channel.interpolation == Interpolation::CubicSpline { 3 * k + part } else { k };
    &channel.values[e * w..(e + 1) * w]
}

/// Component-wise interpolation into `out` (`channel.width` floats): step, lerp, or
/// cubic Hermite.
fn interpolate(channel: &Channel, at: At, out: &mut [f32]) {
    match at {
        At::Key(k) => out.copy_from_slice(element(channel, k, 1)),
        At::Between { index, u, dt } => match channel.interpolation {
            Interpolation::Step => out.copy_from_slice(element(channel, index, 1)),
            Interpolation::Linear => {
                let (a, b) = (element(channel, index, 1), element(channel, index + 1, 1));
                for ((o, &a), &b) in out.iter_mut().zip(a).zip(b) {
                    *o = if u == 0.0 { a } else { a + (b - a) * u };
                }
            }
            Interpolation::CubicSpline => {
                let v0 = element(channel, index, 1);
                let b0 = element(channel, index, 2);
                let v1 = element(channel, index + 1, 1);
                let a1 = element(channel, index + 1, 0);
                let (u2, u3) = (u * u, u * u * u);
                let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
                let h10 = (u3 - 2.0 * u2 + u) * dt;
                let h01 = -2.0 * u3 + 3.0 * u2;
                let h11 = (u3 - u2) * dt;
                for (i, o) in out.iter_mut().enumerate() {
                    *o = h00 * v0[i] + h10 * b0[i] + h01 * v1[i] + h11 * a1[i];
                }
            }
        },
    }
}

/// Samples a rotation channel: shortest-arc slerp for LINEAR, normalized Hermite for
/// CUBICSPLINE. `None` only for a degenerate (zero) cubic result.
fn sample_rotation(channel: &Channel, at: At) -> Option<Quat> {
    let quat = |s: &[f32]| Quat::from_xyzw(s[0], s[1], s[2], s[3]);
    match (at, channel.interpolation) {
        (At::Between { index, u, .. }, Interpolation::Linear) => {
            Some(slerp(quat(element(channel, index, 1)), quat(element(channel, index + 1, 1)), u))
        }
        (_, Interpolation::CubicSpline) => {
            let mut v = [0.0; 4];
            interpolate(channel, at, &mut v);
            Quat::from_array(v).try_normalize_quat()
        }
        _ => {
            let mut v = [0.0; 4];
            interpolate(channel, at, &mut v);
            Some(Quat::from_array(v))
        }
    }
}

/// Spherical linear interpolation along the shortest arc; exact at `u == 0`.
pub fn slerp(a: Quat, b: Quat, u: f32) -> Quat {
    let (va, mut vb) = (Vec4::from(a), Vec4::from(b));
    let mut d = va.dot(vb);
    if d < 0.0 {
        vb = -vb;
        d = -d;
    }
    if u == 0.0 {
        return a;
    }
    if d > 0.9995 {
        // Nearly parallel: nlerp is accurate and avoids dividing by sin(θ) ≈ 0.
        return Quat::from_vec4(va.lerp(vb, u).normalize());
    }
    let theta = d.min(1.0).acos();
    let s = theta.sin();
    Quat::from_vec4(va * (((1.0 - u) * theta).sin() / s) + vb * ((u * theta).sin() / s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::FRAC_PI_2;

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
        let duration = channels.iter().filter_map(|c| c.times.last().copied()).fold(0.0, f32::max);
        Clip { name: None, duration, channels }
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
        let mut bad = c.clone();
        bad.channels[0].node = 4;
        let mut job = SampleJob {
            clip: &bad,
            time: 0.0,
            context: &mut context,
            weight_offsets: &[],
            locals: &mut locals,
            weights: &mut [],
        };
        assert!(matches!(job.run(), Err(JobError::IndexOutOfRange { .. })));
        bad.channels[0] = channel(ChannelTarget::Weights, Interpolation::Linear, &[0.0], &[1.0, 2.0]);
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
