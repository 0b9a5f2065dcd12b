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

impl Channel {
    /// Floats per element its target takes: 3 for translation and scale, 4 for rotation; a
    /// weights channel takes its own `width` (one per morph target).
    pub(crate) fn target_width(&self) -> usize {
        match self.target {
            ChannelTarget::Translation | ChannelTarget::Scale => 3,
            ChannelTarget::Rotation => 4,
            ChannelTarget::Weights => self.width as usize,
        }
    }

    /// Elements stored per key: 3 for CUBICSPLINE (in-tangent, value, out-tangent), else 1.
    pub(crate) fn elements_per_key(&self) -> usize {
        if self.interpolation == Interpolation::CubicSpline { 3 } else { 1 }
    }

    /// Whether `width` is its target's (and not 0) and the values hold one element per key
    /// (times `elements_per_key`).
    pub(crate) fn width_fits(&self) -> bool {
        self.width > 0 && self.width as usize == self.target_width()
    }

    /// [`Channel::width_fits`], at least one key, and `width` floats per element of every key.
    pub(crate) fn is_well_formed(&self) -> bool {
        let per_key = self.width as usize * self.elements_per_key();
        self.width_fits() && !self.times.is_empty() && self.values.len() == self.times.len() * per_key
    }
}

/// An animation clip.
///
/// Its channels are fixed at construction: the clip keeps, beside them, the layout the
/// four-lane sampler reads ([`LaneGroup`]) and which channels never change.
#[derive(Clone, Debug, Default)]
pub struct Clip {
    /// `name` from the file.
    pub name: Option<String>,
    /// Largest key time of any channel, in seconds; 0 for a single-pose clip.
    /// All channels share one clock from 0 (glTF), whatever their own key range.
    pub duration: f32,
    channels: Vec<Channel>,
    /// Per channel: it samples to the same value at every time (and no other channel of the
    /// clip targets the same property, so writing it once is enough).
    constant: Vec<bool>,
    groups: Vec<LaneGroup>,
    /// Channels not in a group, in clip order.
    singles: Vec<u32>,
}

/// LINEAR translation, rotation or scale channels of one clip that share one key-time array
/// and change over time, packed four to a block (one channel per SIMD lane) for
/// [`crate::job::sample::SampleJob`].
#[derive(Clone, Debug)]
pub(crate) struct LaneGroup {
    /// Translation, rotation (width 4) or scale (width 3).
    pub target: ChannelTarget,
    /// The channel whose key times all members share: the same for every group with those
    /// times (groups are sorted by it, so those are neighbours).
    pub times_of: u32,
    /// Target node per member, in clip order; the last block's lanes past the end are padding.
    pub nodes: Vec<NodeIndex>,
    /// Per key, per block of four members: `width` vectors, component-major (the x of four
    /// members, then their y, ...): `values[(key * blocks + block) * width + component]`.
    pub values: Vec<glam::Vec4>,
    /// Rotations only: per pair of neighbouring keys `(k, k + 1)`, per block, the two vectors
    /// of [`crate::job::lanes::slerp_angle`] (θ, then ±1/sinc θ): `angles[(k * blocks + block) * 2]`.
    /// Empty for translations and scales.
    pub angles: Vec<glam::Vec4>,
}

impl LaneGroup {
    /// Floats per element: 4 for rotations, else 3.
    pub fn width(&self) -> usize {
        lane_width(self.target)
    }

    /// Blocks of four members.
    pub fn blocks(&self) -> usize {
        self.nodes.len().div_ceil(4)
    }
}

/// Floats per element of a group of `target`: 4 for rotations, else 3.
fn lane_width(target: ChannelTarget) -> usize {
    if target == ChannelTarget::Rotation { 4 } else { 3 }
}

/// Whether `channel` samples to the same value at every time.
pub(crate) fn is_constant(channel: &Channel) -> bool {
    let w = channel.width as usize;
    let values = &channel.values;
    if w == 0 || values.is_empty() {
        return true;
    }
    if channel.interpolation == Interpolation::CubicSpline {
        let Some(first) = values.get(w..2 * w) else { return false };
        values.chunks_exact(3 * w).all(|k| k[..w].iter().chain(&k[2 * w..]).all(|&x| x == 0.0) && &k[w..2 * w] == first)
    } else {
        let first = &values[..w.min(values.len())];
        values.chunks_exact(w).all(|e| e == first)
    }
}

/// Whether `channel` goes into a [`LaneGroup`]: a well-formed, changing LINEAR channel of a
/// node's translation, rotation or scale (anything else is sampled one channel at a time,
/// which also reports malformed channels).
fn packable(channel: &Channel, constant: bool) -> bool {
    channel.target != ChannelTarget::Weights
        && channel.interpolation == Interpolation::Linear
        && !constant
        && channel.times.len() >= 2
        && channel.is_well_formed()
}

/// A group before its values are laid out: the target, the channel whose key times all its
/// members share (see [`LaneGroup::times_of`]), and the members in clip order.
struct Members {
    target: ChannelTarget,
    times_of: u32,
    list: Vec<u32>,
}

/// How a clip's channels are sampled, before any lane memory exists: which are constant,
/// which groups the packable ones form, and the channels sampled one at a time.
struct Plan {
    constant: Vec<bool>,
    groups: Vec<Members>,
    singles: Vec<u32>,
}

impl Plan {
    fn new(channels: &[Channel]) -> Self {
        // A property animated by several channels (the spec forbids it; files do it): the last
        // one wins, as in the file's order, so those are sampled one at a time, in that order.
        // Found by sorting the channels by their property (neighbours then share it).
        let mut by_target: Vec<(NodeIndex, u8, u32)> =
            channels.iter().enumerate().map(|(i, c)| (c.node, c.target as u8, i as u32)).collect();
        by_target.sort_unstable();
        let mut alone = vec![true; channels.len()];
        for pair in by_target.windows(2) {
            let [(node_a, target_a, a), (node_b, target_b, b)] = [pair[0], pair[1]];
            if (node_a, target_a) == (node_b, target_b) {
                alone[a as usize] = false;
                alone[b as usize] = false;
            }
        }
        // A malformed channel is never "constant": sampling it must report it.
        let constant: Vec<bool> =
            channels.iter().zip(&alone).map(|(c, &alone)| alone && c.is_well_formed() && is_constant(c)).collect();
        let packable: Vec<bool> =
            channels.iter().zip(constant.iter().zip(&alone)).map(|(c, (&k, &alone))| alone && packable(c, k)).collect();
        let (groups, singles) = group(channels, &packable);
        Self { constant, groups, singles }
    }

    /// Bytes the clip will keep besides its channels: the lane groups ([`LaneGroup::values`] and
    /// [`LaneGroup::angles`]) and the per-channel lists (at most 8 bytes a channel).
    fn layout_bytes(&self, channels: &[Channel]) -> u64 {
        let vec4 = size_of::<glam::Vec4>() as u64;
        let lanes: u64 = self
            .groups
            .iter()
            .map(|g| {
                let keys = channels[g.times_of as usize].times.len() as u64;
                let blocks = g.list.len().div_ceil(4) as u64;
                let angles = if g.target == ChannelTarget::Rotation { keys.saturating_sub(1) * 2 } else { 0 };
                (keys * lane_width(g.target) as u64 + angles) * blocks * vec4
            })
            .sum();
        lanes.saturating_add(channels.len() as u64 * 8)
    }
}

/// Groups the packable channels by (target, key times), and lists the channels left to sample
/// one at a time. Channels with equal key times (compared exactly, found through a hash) share
/// the first of them as their `times_of`.
fn group(channels: &[Channel], packable: &[bool]) -> (Vec<Members>, Vec<u32>) {
    use std::collections::HashMap;
    use std::collections::hash_map::Entry;
    use std::hash::{Hash, Hasher};
    let mut reps: HashMap<u64, Vec<u32>> = HashMap::new();
    let mut index: HashMap<(u8, u32), usize> = HashMap::new();
    let (mut groups, mut singles): (Vec<Members>, Vec<u32>) = (Vec::new(), Vec::new());
    // The last channel's `times_of`: files mostly give the channels of an animation one key-time
    // accessor, so a comparison with it mostly spares the hash.
    let mut last: Option<u32> = None;
    for (i, c) in channels.iter().enumerate() {
        let i = i as u32;
        if !packable[i as usize] {
            singles.push(i);
            continue;
        }
        let times_of = match last.filter(|&r| channels[r as usize].times == c.times) {
            Some(r) => r,
            None => {
                let mut hasher = std::collections::hash_map::DefaultHasher::new();
                c.times.iter().for_each(|t| t.to_bits().hash(&mut hasher));
                let candidates = reps.entry(hasher.finish()).or_default();
                match candidates.iter().find(|&&r| channels[r as usize].times == c.times) {
                    Some(&r) => r,
                    None => {
                        candidates.push(i);
                        i
                    }
                }
            }
        };
        last = Some(times_of);
        // Channels of one property and key times mostly come one after another.
        if let Some(g) = groups.last_mut().filter(|g| g.target == c.target && g.times_of == times_of) {
            g.list.push(i);
            continue;
        }
        match index.entry((c.target as u8, times_of)) {
            Entry::Occupied(g) => groups[*g.get()].list.push(i),
            Entry::Vacant(slot) => {
                slot.insert(groups.len());
                groups.push(Members { target: c.target, times_of, list: vec![i] });
            }
        }
    }
    (groups, singles)
}

/// Lays the values of each group out in lanes ([`LaneGroup`]), groups with the same key times
/// side by side (so the sampler finds the key once for them all).
fn pack(channels: &[Channel], members: Vec<Members>) -> Vec<LaneGroup> {
    let mut groups: Vec<LaneGroup> = members
        .into_iter()
        .map(|Members { target, times_of, list }| {
            let width = lane_width(target);
            let keys = channels[times_of as usize].times.len();
            let blocks = list.len().div_ceil(4);
            let mut values = vec![glam::Vec4::ZERO; keys * blocks * width];
            for (block, members) in list.chunks(4).enumerate() {
                // The members' values, a lane each (the last block's missing lanes stay zero).
                let mut lanes: [&[f32]; 4] = [&[]; 4];
                for (lane, &c) in lanes.iter_mut().zip(members) {
                    *lane = &channels[c as usize].values;
                }
                if target == ChannelTarget::Rotation {
                    pack_block::<4>(&mut values, blocks, block, lanes, glam::Vec4::from_array);
                } else {
                    pack_block::<3>(&mut values, blocks, block, lanes, |e| glam::Vec3::from_array(e).extend(0.0));
                }
            }
            let nodes = list.iter().map(|&c| channels[c as usize].node).collect();
            let angles = if target == ChannelTarget::Rotation { segment_angles(&values, blocks) } else { Vec::new() };
            LaneGroup { target, times_of, nodes, values, angles }
        })
        .collect();
    groups.sort_by_key(|g| g.times_of);
    groups
}

/// Lays out block `block` of a group of `W`-float elements (of `blocks`) in `values`
/// ([`LaneGroup::values`]): `lanes` holds its members' values, a member a lane (empty for a
/// padding lane, which stays zero); `vec4` widens an element to four floats.
fn pack_block<const W: usize>(
    values: &mut [glam::Vec4],
    blocks: usize,
    block: usize,
    lanes: [&[f32]; 4],
    vec4: impl Fn([f32; W]) -> glam::Vec4,
) {
    let lanes = lanes.map(|values| values.as_chunks::<W>().0);
    for (k, key) in values.chunks_exact_mut(blocks * W).enumerate() {
        let element = |lane: &[[f32; W]]| lane.get(k).map_or(glam::Vec4::ZERO, |&e| vec4(e));
        let [a, b, c, d] = lanes;
        // Members as columns, transposed: the rows are the components of the four members.
        let rows = glam::Mat4::from_cols(element(a), element(b), element(c), element(d)).transpose();
        let rows = [rows.x_axis, rows.y_axis, rows.z_axis, rows.w_axis];
        if let Some(out) = key.chunks_exact_mut(W).nth(block) {
            for (out, row) in out.iter_mut().zip(rows) {
                *out = row;
            }
        }
    }
}

/// [`LaneGroup::angles`] of rotation values laid out as in [`LaneGroup::values`].
fn segment_angles(values: &[glam::Vec4], blocks: usize) -> Vec<glam::Vec4> {
    use crate::job::lanes::{Quat4, slerp_angle};
    let keys: Vec<&[glam::Vec4]> = values.chunks_exact(blocks * 4).collect();
    let mut angles = Vec::with_capacity(keys.len().saturating_sub(1) * blocks * 2);
    for pair in keys.windows(2) {
        for (a, b) in pair[0].chunks_exact(4).zip(pair[1].chunks_exact(4)) {
            let (theta, inv_signed) = slerp_angle(&Quat4::from_block(a), &Quat4::from_block(b));
            angles.extend([theta, inv_signed]);
        }
    }
    angles
}

impl Clip {
    /// A clip from channels, checking the invariants above; `duration` is computed.
    pub fn new(name: Option<String>, channels: Vec<Channel>) -> Result<Self, crate::error::JobError> {
        let invalid = |i: usize, what: &str| Err(crate::error::JobError::InvalidInput(format!("channel {i}: {what}")));
        for (i, c) in channels.iter().enumerate() {
            if !c.width_fits() {
                return invalid(i, "width does not match its target");
            }
            if !c.is_well_formed() {
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
        Ok(Self::from_channels(name, channels))
    }

    /// A clip from channels the caller has already checked (the importer repairs what
    /// [`Clip::new`] would refuse); `duration` is computed. A malformed channel is still
    /// memory-safe: the sampling job reports it.
    pub(crate) fn from_channels(name: Option<String>, channels: Vec<Channel>) -> Self {
        let plan = Plan::new(&channels);
        Self::from_plan(name, channels, plan)
    }

    /// Bytes [`Clip::from_channels`] will allocate for the sampling layout of `channels`, beyond
    /// the channels themselves.
    #[cfg(test)]
    pub(crate) fn layout_bytes(channels: &[Channel]) -> u64 {
        Plan::new(channels).layout_bytes(channels)
    }

    /// [`Clip::from_channels`], after `charge` accepted [`Clip::layout_bytes`] (the importer's
    /// budget, checked before the layout is allocated).
    pub(crate) fn from_channels_charged<E>(
        name: Option<String>,
        channels: Vec<Channel>,
        charge: impl FnOnce(u64) -> Result<(), E>,
    ) -> Result<Self, E> {
        let plan = Plan::new(&channels);
        charge(plan.layout_bytes(&channels))?;
        Ok(Self::from_plan(name, channels, plan))
    }

    fn from_plan(name: Option<String>, channels: Vec<Channel>, plan: Plan) -> Self {
        let duration = channels.iter().filter_map(|c| c.times.last().copied()).fold(0.0f32, f32::max);
        let Plan { constant, groups, singles } = plan;
        let groups = pack(&channels, groups);
        Self { name, duration, channels, constant, groups, singles }
    }

    /// The channels, in the file's order.
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// Whether channel `i` has the same value at every time and is the only channel of its
    /// target property (false for an unknown index).
    pub fn is_constant(&self, i: usize) -> bool {
        self.constant.get(i).copied().unwrap_or(false)
    }

    /// The four-lane groups (see [`LaneGroup`]).
    pub(crate) fn groups(&self) -> &[LaneGroup] {
        &self.groups
    }

    /// Channels sampled one at a time: not LINEAR, constant, morph weights, or malformed.
    pub(crate) fn singles(&self) -> &[u32] {
        &self.singles
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
