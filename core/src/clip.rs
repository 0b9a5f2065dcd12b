//! Runtime clips: immutable, validated keyframe tracks in flat (SoA) arrays.
//!
//! Invariants (established by the importer or [`Clip::new`]): every channel has at least
//! one key; times are finite and strictly increasing; `values.len()` is
//! `times.len() * width * (3 if CubicSpline else 1)`; rotation values are unit quaternions
//! (`[x, y, z, w]`) for STEP/LINEAR; `duration` is the largest key time of any channel (≥ 0).

use crate::asset::NodeIndex;

/// What a channel animates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ChannelTarget {
    /// Node translation, width 3.
    Translation,
    /// Node rotation quaternion `[x, y, z, w]`, width 4.
    Rotation,
    /// Node scale, width 3.
    Scale,
    /// Morph target weights of the node's mesh, width = number of targets.
    Weights,
}

/// Keyframe interpolation, as glTF defines it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Interpolation {
    /// Hold the previous key.
    Step,
    /// Lerp; slerp for rotations (shortest arc).
    Linear,
    /// Cubic Hermite with explicit in/out tangents; values are `[in, value, out]` per key.
    CubicSpline,
}

/// One animated property of one node.
#[derive(Clone, Debug)]
pub struct Channel {
    /// Target node.
    pub node: NodeIndex,
    /// Target property.
    pub target: ChannelTarget,
    /// Interpolation.
    pub interpolation: Interpolation,
    /// Key times in seconds, strictly increasing.
    pub times: Vec<f32>,
    /// Key values, flat: `width` floats per element; CubicSpline stores 3 elements per key
    /// (in-tangent, value, out-tangent).
    pub values: Vec<f32>,
    /// Floats per element.
    pub width: u32,
}

/// An animation clip.
#[derive(Clone, Debug, Default)]
pub struct Clip {
    /// `name` from the file.
    pub name: Option<String>,
    /// Largest key time of any channel, in seconds; 0 for a single-pose clip.
    /// All channels share one clock from 0 (glTF), whatever their own key range.
    pub duration: f32,
    /// Channels.
    pub channels: Vec<Channel>,
}

impl Clip {
    /// A clip from channels, checking the invariants above; `duration` is computed.
    pub fn new(name: Option<String>, channels: Vec<Channel>) -> Result<Self, crate::error::JobError> {
        let invalid = |i: usize, what: &str| Err(crate::error::JobError::InvalidInput(format!("channel {i}: {what}")));
        for (i, c) in channels.iter().enumerate() {
            let width = c.width as usize;
            let expected = match c.target {
                ChannelTarget::Translation | ChannelTarget::Scale => 3,
                ChannelTarget::Rotation => 4,
                ChannelTarget::Weights => width.max(1),
            };
            let per_key = if c.interpolation == Interpolation::CubicSpline { 3 } else { 1 };
            if width != expected {
                return invalid(i, "width does not match its target");
            }
            if c.times.is_empty() || c.times.len() * width * per_key != c.values.len() {
                return invalid(i, "needs at least one key and width values per element");
            }
            if !c.times.iter().chain(&c.values).all(|x| x.is_finite()) || c.times.windows(2).any(|w| w[0] >= w[1]) {
                return invalid(i, "times must be finite and strictly increasing, values finite");
            }
            if c.target == ChannelTarget::Rotation
                && c.interpolation != Interpolation::CubicSpline
                && c.values.chunks_exact(4).any(|q| (q.iter().map(|x| x * x).sum::<f32>() - 1.0).abs() > 1e-4)
            {
                return invalid(i, "rotations must be unit quaternions");
            }
        }
        let duration = channels.iter().filter_map(|c| c.times.last().copied()).fold(0.0f32, f32::max);
        Ok(Self { name, duration, channels })
    }

    /// Display name: the file's name, or `"clip <index>"`.
    pub fn display_name(&self, index: usize) -> String {
        self.name.clone().unwrap_or_else(|| format!("clip {index}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(target: ChannelTarget, times: Vec<f32>, values: Vec<f32>, width: u32) -> Channel {
        Channel { node: 0, target, interpolation: Interpolation::Linear, times, values, width }
    }

    #[test]
    fn new_checks_invariants_and_computes_duration() {
        let ok = Clip::new(
            Some("c".into()),
            vec![
                channel(ChannelTarget::Translation, vec![0.0, 2.5], vec![0.0; 6], 3),
                channel(ChannelTarget::Rotation, vec![1.0], vec![0.0, 0.0, 0.0, 1.0], 4),
            ],
        )
        .expect("valid");
        assert_eq!(ok.duration, 2.5);
        assert_eq!(ok.display_name(3), "c");
        let bad = [
            channel(ChannelTarget::Translation, vec![], vec![], 3),
            channel(ChannelTarget::Translation, vec![0.0], vec![0.0; 4], 3),
            channel(ChannelTarget::Scale, vec![1.0, 1.0], vec![0.0; 6], 3),
            channel(ChannelTarget::Scale, vec![f32::NAN], vec![0.0; 3], 3),
            channel(ChannelTarget::Rotation, vec![0.0], vec![0.0, 0.0, 0.0, 2.0], 4),
            channel(ChannelTarget::Rotation, vec![0.0], vec![0.0; 3], 3),
        ];
        for c in bad {
            assert!(Clip::new(None, vec![c.clone()]).is_err(), "{c:?}");
        }
    }
}
