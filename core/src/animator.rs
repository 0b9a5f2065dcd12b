//! The animation state of one character: what plays, how clips blend, and the layers on top.
//!
//! An [`Animator`] composes the jobs of [`crate::job`] into one pose per frame:
//!
//! ```text
//!  base: tracks (1 clip, or N clips with weights)  ─┐
//!        crossfade: outgoing (frozen snapshot or    ├─ BlendJob ─→ Instance pose ─→ worlds ─→ palettes
//!        still-playing tracks) → tracks, eased      │    (normal layers, then override /
//!  layers: clip on the subtree under a root joint  ─┘     additive layers in order)
//! ```
//!
//! - **Tracks** ([`Track`]): the base. Track 0 is the *main* track: [`Animator::play`] replaces
//!   everything with it, the timeline shows it ([`Animator::main`]). Several tracks blend by
//!   their weights, normalized to sum 1 ([`Animator::set_blend`]).
//! - **Crossfade** ([`Animator::crossfade_to`]): the base moves to a new clip over a duration
//!   with an easing. The outgoing side is, per [`Outgoing`], a snapshot of the current base pose
//!   (seed 000 §3.2.3, "from the current pose"), or the old tracks still playing, optionally
//!   with the target started at the same normalized time.
//! - **Layers** ([`Layer`]): a clip applied to the subtree under a root joint with a weight and
//!   a per-depth falloff ([`subtree_mask`]), overriding the base or added to it
//!   (additive: the clip's difference from its own first frame). Each has its own clock.
//!
//! Everything is allocated when the configuration changes (a clip switched, a track or layer
//! added, a crossfade started); [`Animator::advance`] and [`Animator::evaluate`] allocate
//! nothing. At most [`MAX_SOURCES`] poses blend at once.
//!
//! The animator does not own the asset: pass the same [`Asset`] to every call (a different
//! one is refused with a length error where its shape differs). Load a new model, make a new
//! animator.

use crate::asset::{Asset, NodeIndex};
use crate::error::JobError;
use crate::instance::Instance;
use crate::job::blend::{BlendJob, BlendLayer, DEFAULT_THRESHOLD, subtree_mask};
use crate::job::sample::{RotationLerp, SampleContext, SampleJob};
use crate::job::{check_eq, check_index, check_len};
use crate::player::{Player, PlayerEvents};
use crate::pose::Pose;

/// Most poses one evaluation blends: tracks, outgoing tracks or the snapshot, and layers.
pub const MAX_SOURCES: usize = 32;

/// Shape of a crossfade's progress curve.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Easing {
    /// Constant rate.
    Linear,
    /// `3u² − 2u³`: starts and ends gently.
    #[default]
    SmoothStep,
}

impl Easing {
    /// The eased value of `u`, clamped to `[0, 1]` (NaN gives 0).
    pub fn apply(self, u: f32) -> f32 {
        let u = if u.is_nan() { 0.0 } else { u.clamp(0.0, 1.0) };
        match self {
            Easing::Linear => u,
            Easing::SmoothStep => u * u * (3.0 - 2.0 * u),
        }
    }
}

/// What the outgoing side of a crossfade does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Outgoing {
    /// Blend from a snapshot of the base pose taken when the crossfade starts.
    #[default]
    Freeze,
    /// The outgoing tracks keep playing while they fade out.
    KeepPlaying,
    /// As [`Outgoing::KeepPlaying`], and the target starts at the main track's normalized time
    /// (e.g. Walk → Run with the feet in step).
    SyncTime,
}

/// How to crossfade ([`Animator::crossfade_to`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossfade {
    /// Seconds of wall time; 0 (or not finite) switches at once.
    pub duration: f32,
    /// Progress curve.
    pub easing: Easing,
    /// The outgoing side.
    pub outgoing: Outgoing,
}

impl Default for Crossfade {
    /// 0.25 s, smooth step, from a frozen snapshot.
    fn default() -> Self {
        Self { duration: 0.25, easing: Easing::SmoothStep, outgoing: Outgoing::Freeze }
    }
}

/// A crossfade in progress ([`Animator::crossfade`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrossfadeStatus {
    /// As started.
    pub settings: Crossfade,
    /// Seconds since it started.
    pub elapsed: f32,
    /// Current (eased) weight of the target, in `[0, 1]`.
    pub weight: f32,
    /// Whether the outgoing side is a frozen snapshot (a crossfade started during another
    /// always freezes).
    pub frozen: bool,
}

/// What happened during one [`Animator::advance`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AnimatorEvents {
    /// Events of the main track's clock.
    pub main: PlayerEvents,
    /// A crossfade reached its end during this advance.
    pub crossfade_finished: bool,
}

/// Samples one clip into its own pose, keeping the key cursors between frames.
#[derive(Clone, Debug, Default)]
struct Sampler {
    context: SampleContext,
    /// The clip `pose` and `context` are set up for.
    clip: Option<usize>,
    /// Rest pose overwritten by the clip's animated properties.
    pose: Pose,
}

impl Sampler {
    /// Buffers for `asset`, with room for the cursors of any of its clips (switching clips then
    /// never allocates).
    fn new(asset: &Asset) -> Self {
        let mut context = SampleContext::default();
        for clip in &asset.clips {
            context.reserve_for(clip);
        }
        // `pose` is written by this sampler alone, and reset with the context on a clip change.
        context.set_skip_constant(true);
        Self { context, clip: None, pose: Pose::rest(asset) }
    }

    /// Samples `clip` at `time` into `self.pose` (the rest pose for `None`).
    fn sample(&mut self, asset: &Asset, clip: Option<usize>, time: f32, lerp: RotationLerp) -> Result<(), JobError> {
        if clip != self.clip || self.pose.locals.len() != asset.nodes.len() {
            // Properties a clip does not animate keep their rest value from here on.
            self.pose.reset_to_rest(asset);
            self.clip = None;
            if let Some(c) = clip {
                check_index("clip", c, asset.clips.len())?;
                self.context.reset(&asset.clips[c]);
            }
            self.clip = clip;
        }
        let Some(c) = clip else { return Ok(()) };
        check_index("clip", c, asset.clips.len())?;
        self.context.set_rotation_lerp(lerp);
        SampleJob {
            clip: &asset.clips[c],
            time,
            context: &mut self.context,
            weight_offsets: &asset.weight_offsets,
            locals: &mut self.pose.locals,
            weights: &mut self.pose.weights,
        }
        .run()
    }
}

/// One clip of the base blend: a clock and a weight.
#[derive(Clone, Debug)]
pub struct Track {
    /// The clip's clock (clip, time, speed, pause, loop mode).
    pub player: Player,
    /// Relative weight among the tracks (normalized to sum 1; not finite or negative counts 0).
    pub weight: f32,
    sampler: Sampler,
}

impl Track {
    fn new(asset: &Asset) -> Self {
        Self { player: Player::new(), weight: 1.0, sampler: Sampler::new(asset) }
    }

    /// The pose this track sampled at the last evaluation (tracks of weight 0 are not sampled).
    pub fn pose(&self) -> &Pose {
        &self.sampler.pose
    }
}

/// A clip applied on top of the base, to the subtree under `root`.
#[derive(Clone, Debug)]
pub struct Layer {
    /// The layer's own clock (clip, time, speed, pause, loop mode); no clip = no effect.
    pub player: Player,
    /// Root of the affected subtree (any node; usually a joint).
    pub root: NodeIndex,
    /// Strength: override layers clamp it to 1, additive layers may exaggerate above 1.
    /// Not finite or negative counts 0.
    pub weight: f32,
    /// Per-generation falloff below `root` in `[0, 1]` (clamped; not finite counts 0):
    /// a joint `d` generations below `root` weighs `weight · (1 − falloff)^d`.
    pub falloff: f32,
    /// Add the clip's difference from its first frame instead of overriding.
    pub additive: bool,
    sampler: Sampler,
    mask: Vec<f32>,
    /// `(root, falloff bits)` that `mask` was computed for.
    mask_for: Option<(NodeIndex, u32)>,
    /// The clip at time 0 (additive reference) and which clip that was.
    reference: Pose,
    reference_for: Option<usize>,
}

impl Layer {
    /// Plays `clip` on the subtree under `root`: weight 1, no falloff, overriding, its clock
    /// at 0, playing, repeating. Buffers are sized by [`Animator::add_layer`].
    pub fn new(clip: usize, root: NodeIndex) -> Self {
        let mut player = Player::new();
        player.set_clip(Some(clip));
        Self {
            player,
            root,
            weight: 1.0,
            falloff: 0.0,
            additive: false,
            sampler: Sampler::default(),
            mask: Vec::new(),
            mask_for: None,
            reference: Pose::default(),
            reference_for: None,
        }
    }

    /// Per-node weight mask (before `weight`) as of the last evaluation: 1 at `root`, falling
    /// off below it, 0 elsewhere.
    pub fn mask(&self) -> &[f32] {
        &self.mask
    }

    /// Sizes the buffers for `asset`.
    fn attach(&mut self, asset: &Asset) {
        self.sampler = Sampler::new(asset);
        self.reference = Pose::rest(asset);
        self.reference_for = None;
        self.mask = vec![0.0; asset.nodes.len()];
        self.mask_for = None;
    }

    /// Brings the mask, the sampled pose and (additive) the reference up to date.
    fn refresh(&mut self, asset: &Asset, lerp: RotationLerp) -> Result<(), JobError> {
        let falloff = if self.falloff.is_finite() { self.falloff.clamp(0.0, 1.0) } else { 0.0 };
        let key = (self.root, falloff.to_bits());
        if self.mask_for != Some(key) {
            self.mask_for = None;
            subtree_mask(asset, self.root, 1.0, falloff, &mut self.mask)?;
            self.mask_for = Some(key);
        }
        self.sampler.sample(asset, self.player.clip, self.player.time, lerp)?;
        if let Some(c) = self.player.clip.filter(|_| self.additive)
            && self.reference_for != Some(c)
        {
            self.reference_for = None;
            self.reference.reset_to_rest(asset);
            let clip = &asset.clips[c];
            SampleJob {
                clip,
                time: 0.0,
                // A configuration change: a fresh context may allocate.
                context: &mut SampleContext::new(clip),
                weight_offsets: &asset.weight_offsets,
                locals: &mut self.reference.locals,
                weights: &mut self.reference.weights,
            }
            .run()?;
            self.reference_for = Some(c);
        }
        Ok(())
    }
}

/// A crossfade in flight.
#[derive(Clone, Copy, Debug)]
struct Fade {
    settings: Crossfade,
    elapsed: f32,
    frozen: bool,
}

impl Fade {
    /// Eased weight of the target side.
    fn weight(&self) -> f32 {
        let d = self.settings.duration;
        self.settings.easing.apply(if d > 0.0 { self.elapsed / d } else { 1.0 })
    }
}

/// `w` when finite and positive, else 0.
fn sanitize(w: f32) -> f32 {
    if w.is_finite() && w > 0.0 { w } else { 0.0 }
}

/// Appends to a fixed-size layer list.
fn push<'a>(list: &mut [BlendLayer<'a>], len: &mut usize, layer: BlendLayer<'a>) -> Result<(), JobError> {
    let slot = list.get_mut(*len).ok_or_else(too_many)?;
    *slot = layer;
    *len += 1;
    Ok(())
}

fn too_many() -> JobError {
    JobError::InvalidInput(format!("at most {MAX_SOURCES} clips, snapshots and layers blend at once"))
}

/// Each track as a normal layer, weights normalized to sum `scale`.
fn push_tracks<'a>(
    tracks: &'a [Track],
    scale: f32,
    list: &mut [BlendLayer<'a>],
    len: &mut usize,
) -> Result<(), JobError> {
    let total: f32 = tracks.iter().map(|t| sanitize(t.weight)).sum();
    if scale <= 0.0 || total <= 0.0 {
        return Ok(());
    }
    for t in tracks {
        let w = sanitize(t.weight);
        if w > 0.0 {
            let pose = &t.sampler.pose;
            push(list, len, BlendLayer::normal(&pose.locals, &pose.weights, scale * (w / total)))?;
        }
    }
    Ok(())
}

/// The base: tracks, and during a crossfade the outgoing side.
fn push_base<'a>(
    fade: Option<Fade>,
    snapshot: &'a Pose,
    outgoing: &'a [Track],
    tracks: &'a [Track],
    list: &mut [BlendLayer<'a>],
    len: &mut usize,
) -> Result<(), JobError> {
    let target = fade.map_or(1.0, |f| f.weight());
    if let Some(f) = fade {
        let w = 1.0 - target;
        if f.frozen && w > 0.0 {
            push(list, len, BlendLayer::normal(&snapshot.locals, &snapshot.weights, w))?;
        } else if !f.frozen {
            push_tracks(outgoing, w, list, len)?;
        }
    }
    push_tracks(tracks, target, list, len)
}

/// The animation state of one character. See the [module documentation](self).
#[derive(Clone, Debug)]
pub struct Animator {
    /// Never empty: track 0 is the main track.
    tracks: Vec<Track>,
    /// The old tracks during a live (not frozen) crossfade.
    outgoing: Vec<Track>,
    layers: Vec<Layer>,
    fade: Option<Fade>,
    /// The frozen outgoing pose of a crossfade.
    snapshot: Pose,
    /// Where a new snapshot is blended before it replaces `snapshot`.
    scratch: Pose,
    rest: Pose,
    rotation_lerp: RotationLerp,
}

impl Animator {
    /// An animator for `asset` showing its rest pose: one main track without a clip.
    pub fn new(asset: &Asset) -> Self {
        Self {
            tracks: vec![Track::new(asset)],
            outgoing: Vec::new(),
            layers: Vec::new(),
            fade: None,
            snapshot: Pose::rest(asset),
            scratch: Pose::rest(asset),
            rest: Pose::rest(asset),
            rotation_lerp: RotationLerp::Slerp,
        }
    }

    /// The main track's clock (track 0): what the timeline shows and scrubs.
    pub fn main(&self) -> &Player {
        &self.tracks.first().expect("invariant: an animator always has a main track").player
    }

    /// The main track's clock, to seek, pause, or change speed and loop mode.
    pub fn main_mut(&mut self) -> &mut Player {
        &mut self.main_track_mut().player
    }

    fn main_track_mut(&mut self) -> &mut Track {
        self.tracks.first_mut().expect("invariant: an animator always has a main track")
    }

    /// The base tracks (never empty; during a crossfade, the target side).
    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// The base tracks, to change their clocks and weights (a changed clip is picked up at
    /// the next evaluation).
    pub fn tracks_mut(&mut self) -> &mut [Track] {
        &mut self.tracks
    }

    /// The layers, in the order they apply.
    pub fn layers(&self) -> &[Layer] {
        &self.layers
    }

    /// The layers, to change clip, root, weight, falloff, mode or clock.
    pub fn layers_mut(&mut self) -> &mut [Layer] {
        &mut self.layers
    }

    /// How LINEAR rotation keys are sampled (slerp by default).
    pub fn rotation_lerp(&self) -> RotationLerp {
        self.rotation_lerp
    }

    /// Chooses how LINEAR rotation keys are sampled by every track and layer.
    pub fn set_rotation_lerp(&mut self, lerp: RotationLerp) {
        self.rotation_lerp = lerp;
    }

    /// Plays `clip` (`None`: the rest pose) on the main track alone, from its start: other
    /// tracks and any crossfade are dropped; speed and loop mode are kept; layers stay.
    pub fn play(&mut self, asset: &Asset, clip: Option<usize>) -> Result<(), JobError> {
        self.check_asset(asset)?;
        check_clip(asset, clip)?;
        self.fade = None;
        self.outgoing.clear();
        self.tracks.truncate(1);
        let main = self.main_track_mut();
        main.player.set_clip(clip);
        main.player.playing = true;
        main.weight = 1.0;
        Ok(())
    }

    /// Replaces the base with a weighted blend of clips (`None`: the rest pose): track `i`
    /// plays `clips[i]`, keeping its clock if it already played that clip; new tracks start at
    /// 0 with default settings. An empty list is the rest pose. Drops any crossfade.
    pub fn set_blend(&mut self, asset: &Asset, clips: &[(Option<usize>, f32)]) -> Result<(), JobError> {
        self.check_asset(asset)?;
        for &(clip, _) in clips {
            check_clip(asset, clip)?;
        }
        if clips.is_empty() {
            return self.play(asset, None);
        }
        if clips.len() + 1 + self.layers.len() > MAX_SOURCES {
            return Err(too_many());
        }
        self.fade = None;
        self.outgoing.clear();
        self.tracks.truncate(clips.len());
        while self.tracks.len() < clips.len() {
            self.tracks.push(Track::new(asset));
        }
        for (track, &(clip, weight)) in self.tracks.iter_mut().zip(clips) {
            if track.player.clip != clip {
                track.player.set_clip(clip);
                track.player.playing = true;
            }
            track.weight = weight;
        }
        Ok(())
    }

    /// Adds a base track playing `clip` from 0 with `weight`; returns its index.
    pub fn add_track(&mut self, asset: &Asset, clip: Option<usize>, weight: f32) -> Result<usize, JobError> {
        self.check_asset(asset)?;
        check_clip(asset, clip)?;
        if self.sources() + 1 > MAX_SOURCES {
            return Err(too_many());
        }
        let mut track = Track::new(asset);
        track.player.set_clip(clip);
        track.weight = weight;
        self.tracks.push(track);
        Ok(self.tracks.len() - 1)
    }

    /// Removes base track `index`; the last remaining track cannot be removed.
    pub fn remove_track(&mut self, index: usize) -> Result<Track, JobError> {
        check_index("track", index, self.tracks.len())?;
        if self.tracks.len() == 1 {
            return Err(JobError::InvalidInput("the main track cannot be removed".into()));
        }
        Ok(self.tracks.remove(index))
    }

    /// Starts a crossfade of the base to `clip` (`None`: the rest pose) over `fade.duration`
    /// seconds. The target becomes the only track, inheriting the main track's speed and loop
    /// mode, playing from 0 ([`Outgoing::SyncTime`]: from the main track's normalized time).
    /// During another crossfade the outgoing side is always a frozen snapshot of the current
    /// base pose. Layers are unaffected. A zero duration is [`Animator::play`].
    pub fn crossfade_to(&mut self, asset: &Asset, clip: Option<usize>, fade: Crossfade) -> Result<(), JobError> {
        self.check_asset(asset)?;
        check_clip(asset, clip)?;
        if !(fade.duration.is_finite() && fade.duration > 0.0) {
            return self.play(asset, clip);
        }
        let main = self.main();
        let phase = main.normalized_time(asset);
        let mut target = Player { clip, time: 0.0, playing: true, reversed: false, ..main.clone() };
        if fade.outgoing == Outgoing::SyncTime {
            target.set_normalized_time(asset, phase);
        }
        let frozen = fade.outgoing == Outgoing::Freeze || self.fade.is_some();
        if frozen {
            // Snapshot the base as it is now (fresh samples at the current clock times).
            self.sample_base(asset)?;
            let mut list = [BlendLayer::EMPTY; MAX_SOURCES];
            let mut len = 0;
            push_base(self.fade, &self.snapshot, &self.outgoing, &self.tracks, &mut list, &mut len)?;
            blend(asset, &self.rest, &list[..len], &mut self.scratch)?;
            std::mem::swap(&mut self.snapshot, &mut self.scratch);
            self.outgoing.clear();
            self.tracks.truncate(1);
        } else {
            if self.tracks.len() + 1 + self.layers.len() > MAX_SOURCES {
                return Err(too_many());
            }
            let spare = self.outgoing.pop();
            self.outgoing.clear();
            std::mem::swap(&mut self.outgoing, &mut self.tracks);
            self.tracks.push(spare.unwrap_or_else(|| Track::new(asset)));
        }
        let track = self.main_track_mut();
        track.player = target;
        track.weight = 1.0;
        self.fade = Some(Fade { settings: fade, elapsed: 0.0, frozen });
        Ok(())
    }

    /// The crossfade in progress, if any.
    pub fn crossfade(&self) -> Option<CrossfadeStatus> {
        self.fade.map(|f| CrossfadeStatus {
            settings: f.settings,
            elapsed: f.elapsed,
            weight: f.weight(),
            frozen: f.frozen,
        })
    }

    /// Adds `layer` on top of the existing ones (sizing its buffers); returns its index.
    pub fn add_layer(&mut self, asset: &Asset, mut layer: Layer) -> Result<usize, JobError> {
        self.check_asset(asset)?;
        check_clip(asset, layer.player.clip)?;
        check_index("layer root", layer.root as usize, asset.nodes.len())?;
        if self.sources() + 1 > MAX_SOURCES {
            return Err(too_many());
        }
        layer.attach(asset);
        self.layers.push(layer);
        Ok(self.layers.len() - 1)
    }

    /// Removes layer `index`.
    pub fn remove_layer(&mut self, index: usize) -> Result<Layer, JobError> {
        check_index("layer", index, self.layers.len())?;
        Ok(self.layers.remove(index))
    }

    /// Advances every clock by `dt` seconds (each at its own speed) and the crossfade by `dt`;
    /// a finished crossfade drops its outgoing side. Allocates nothing.
    pub fn advance(&mut self, asset: &Asset, dt: f32) -> AnimatorEvents {
        let mut events = AnimatorEvents::default();
        for (i, track) in self.tracks.iter_mut().enumerate() {
            let e = track.player.advance(asset, dt);
            if i == 0 {
                events.main = e;
            }
        }
        if let Some(fade) = &mut self.fade {
            if !fade.frozen {
                for track in &mut self.outgoing {
                    track.player.advance(asset, dt);
                }
            }
            if dt.is_finite() && dt > 0.0 {
                fade.elapsed += dt;
            }
            events.crossfade_finished = fade.elapsed >= fade.settings.duration;
        }
        if events.crossfade_finished {
            self.fade = None;
            self.outgoing.clear();
        }
        for layer in &mut self.layers {
            layer.player.advance(asset, dt);
        }
        events
    }

    /// Samples, blends and writes the pose into `instance`, then its world transforms and
    /// palettes. Allocates nothing unless the configuration changed since the last call.
    pub fn evaluate(&mut self, asset: &Asset, instance: &mut Instance) -> Result<(), JobError> {
        self.evaluate_pose(asset, instance.pose_mut())?;
        instance.update(asset)
    }

    /// Samples and blends into `pose` (node-local transforms and morph weights only).
    pub fn evaluate_pose(&mut self, asset: &Asset, pose: &mut Pose) -> Result<(), JobError> {
        self.check_asset(asset)?;
        self.sample_base(asset)?;
        let lerp = self.rotation_lerp;
        for layer in &mut self.layers {
            if sanitize(layer.weight) > 0.0 && layer.player.clip.is_some() {
                layer.refresh(asset, lerp)?;
            }
        }
        let layered = self.layers.iter().any(|l| sanitize(l.weight) > 0.0 && l.player.clip.is_some());
        if let ([only], None, false) = (&self.tracks[..], self.fade, layered)
            && sanitize(only.weight) > 0.0
        {
            // One clip and nothing on top (the common case): a copy, as the blend job would do.
            let src = &only.sampler.pose;
            check_len("pose locals", src.locals.len(), pose.locals.len())?;
            check_len("pose weights", src.weights.len(), pose.weights.len())?;
            pose.locals[..src.locals.len()].copy_from_slice(&src.locals);
            pose.weights[..src.weights.len()].copy_from_slice(&src.weights);
            return Ok(());
        }
        let mut list = [BlendLayer::EMPTY; MAX_SOURCES];
        let mut len = 0;
        push_base(self.fade, &self.snapshot, &self.outgoing, &self.tracks, &mut list, &mut len)?;
        for layer in &self.layers {
            let w = sanitize(layer.weight);
            if w <= 0.0 || layer.player.clip.is_none() {
                continue;
            }
            let pose = &layer.sampler.pose;
            let blend = if layer.additive {
                let r = &layer.reference;
                BlendLayer::additive(&pose.locals, &pose.weights, &r.locals, &r.weights, w)
            } else {
                BlendLayer::overriding(&pose.locals, &pose.weights, w)
            };
            push(&mut list, &mut len, blend.with_mask(&layer.mask))?;
        }
        blend(asset, &self.rest, &list[..len], pose)
    }

    /// Samples the tracks (and live outgoing tracks) that weigh anything now.
    fn sample_base(&mut self, asset: &Asset) -> Result<(), JobError> {
        let target = self.fade.map_or(1.0, |f| f.weight());
        let lerp = self.rotation_lerp;
        let outgoing = match self.fade {
            Some(f) if !f.frozen && target < 1.0 => &mut self.outgoing[..],
            _ => &mut [],
        };
        let tracks = if target > 0.0 { &mut self.tracks[..] } else { &mut [] };
        for track in tracks.iter_mut().chain(outgoing) {
            if sanitize(track.weight) > 0.0 {
                track.sampler.sample(asset, track.player.clip, track.player.time, lerp)?;
            }
        }
        Ok(())
    }

    /// Poses blended at once if nothing changed: tracks, outgoing side, layers.
    fn sources(&self) -> usize {
        self.tracks.len() + self.outgoing.len().max(1) + self.layers.len()
    }

    /// Refuses an asset whose shape differs from the one this animator was made for.
    fn check_asset(&self, asset: &Asset) -> Result<(), JobError> {
        check_eq("asset nodes", self.rest.locals.len(), asset.nodes.len())?;
        check_eq("asset morph weights", self.rest.weights.len(), asset.weight_total as usize)?;
        check_eq("asset weight offsets", asset.nodes.len(), asset.weight_offsets.len())
    }
}

/// Runs the blend job over `layers` into `out`.
fn blend(asset: &Asset, rest: &Pose, layers: &[BlendLayer<'_>], out: &mut Pose) -> Result<(), JobError> {
    BlendJob {
        layers,
        rest: &rest.locals,
        rest_weights: &rest.weights,
        weight_offsets: &asset.weight_offsets,
        threshold: DEFAULT_THRESHOLD,
        locals: &mut out.locals,
        weights: &mut out.weights,
    }
    .run()
}

/// `Err` when `clip` is not a clip of `asset`.
fn check_clip(asset: &Asset, clip: Option<usize>) -> Result<(), JobError> {
    match clip {
        Some(c) => check_index("clip", c, asset.clips.len()),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::blend::BlendMode;
    use crate::math::{Transform, Vec3};
    use crate::player::LoopMode;
    use crate::testutil::{allocations, load};

    const FOX: &str = "khronos/Fox/glTF-Binary/Fox.glb";
    const ROBOT: &str = "threejs/RobotExpressive/RobotExpressive.glb";

    fn clip(asset: &Asset, name: &str) -> usize {
        asset.find_clip(name).unwrap_or_else(|| panic!("no clip {name}"))
    }

    fn node(asset: &Asset, name: &str) -> NodeIndex {
        asset.nodes.iter().position(|n| n.name.as_deref() == Some(name)).unwrap_or_else(|| panic!("no node {name}"))
            as NodeIndex
    }

    /// The pose `Instance::evaluate` gives for one clip at one time (the reference path).
    fn sampled(asset: &Asset, clip: usize, time: f32) -> Pose {
        let mut instance = Instance::new(asset);
        instance.evaluate(asset, Some(clip), time).expect("valid");
        instance.pose().clone()
    }

    fn blend_poses(asset: &Asset, layers: &[BlendLayer<'_>]) -> Pose {
        let mut out = Pose::rest(asset);
        blend(asset, &Pose::rest(asset), layers, &mut out).expect("valid");
        out
    }

    fn distance(a: &Transform, b: &Transform) -> (f32, f32) {
        (a.translation.distance(b.translation), a.rotation.angle_between(b.rotation))
    }

    #[test]
    fn one_clip_matches_instance_evaluate_bit_for_bit() {
        let asset = load(FOX);
        let walk = clip(&asset, "Walk");
        let mut animator = Animator::new(&asset);
        animator.play(&asset, Some(walk)).expect("valid");
        let (mut got, mut want) = (Instance::new(&asset), Instance::new(&asset));
        for _ in 0..60 {
            animator.advance(&asset, 1.0 / 60.0);
            animator.evaluate(&asset, &mut got).expect("valid");
            want.evaluate(&asset, Some(walk), animator.main().time).expect("valid");
            assert_eq!(got.pose(), want.pose());
            assert_eq!(got.worlds(), want.worlds());
            assert_eq!(got.palette(0), want.palette(0));
        }
        animator.play(&asset, None).expect("valid");
        animator.evaluate(&asset, &mut got).expect("valid");
        assert_eq!(got.pose(), &Pose::rest(&asset), "no clip: the rest pose");
    }

    #[test]
    fn crossfade_goes_from_the_current_pose_to_the_target_monotonically() {
        let asset = load(FOX);
        let (walk, run) = (clip(&asset, "Walk"), clip(&asset, "Run"));
        let mut animator = Animator::new(&asset);
        animator.play(&asset, Some(walk)).expect("valid");
        animator.advance(&asset, 0.3);
        let mut pose = Pose::rest(&asset);
        animator.evaluate_pose(&asset, &mut pose).expect("valid");
        let source = pose.clone();
        assert_eq!(source, sampled(&asset, walk, 0.3));
        let fade = Crossfade { duration: 0.5, easing: Easing::Linear, outgoing: Outgoing::Freeze };
        animator.crossfade_to(&asset, Some(run), fade).expect("valid");
        // Hold the target at its first frame so the blend runs between two fixed poses.
        animator.main_mut().playing = false;
        animator.evaluate_pose(&asset, &mut pose).expect("valid");
        assert_eq!(pose, source, "at the start: exactly the source pose");
        let target = sampled(&asset, run, 0.0);
        let mut previous: Vec<(f32, f32)> =
            source.locals.iter().zip(&target.locals).map(|(a, b)| distance(a, b)).collect();
        assert!(previous.iter().any(|&(t, r)| t > 1e-3 || r > 1e-2), "Walk and Run differ");
        for step in 1..=8 {
            let events = animator.advance(&asset, 0.0625);
            assert_eq!(events.crossfade_finished, step == 8);
            animator.evaluate_pose(&asset, &mut pose).expect("valid");
            if step == 4 {
                let status = animator.crossfade().expect("in progress");
                assert!((status.weight - 0.5).abs() < 1e-6 && status.frozen);
                for ((o, s), t) in pose.locals.iter().zip(&source.locals).zip(&target.locals) {
                    assert!(o.translation.abs_diff_eq(s.translation.lerp(t.translation, 0.5), 1e-5));
                }
            }
            for (n, (o, t)) in pose.locals.iter().zip(&target.locals).enumerate() {
                let (dt, dr) = distance(o, t);
                assert!(dt <= previous[n].0 + 1e-6 && dr <= previous[n].1 + 1e-4, "node {n} step {step}");
                previous[n] = (dt, dr);
            }
        }
        assert!(animator.crossfade().is_none());
        assert_eq!(pose, target, "at the end: exactly the target pose");
    }

    #[test]
    fn live_crossfade_blends_the_playing_source_and_syncs_time() {
        let asset = load(FOX);
        let (walk, run) = (clip(&asset, "Walk"), clip(&asset, "Run"));
        let (walk_len, run_len) = (asset.clips[walk].duration, asset.clips[run].duration);
        let mut animator = Animator::new(&asset);
        animator.play(&asset, Some(walk)).expect("valid");
        animator.main_mut().speed = 0.5;
        animator.advance(&asset, walk_len * 0.5); // a quarter of the way through
        let fade = Crossfade { duration: 1.0, easing: Easing::SmoothStep, outgoing: Outgoing::SyncTime };
        animator.crossfade_to(&asset, Some(run), fade).expect("valid");
        assert!((animator.main().time - 0.25 * run_len).abs() < 1e-5, "target starts in step");
        assert_eq!(animator.main().speed, 0.5, "inherits the speed");
        assert!(!animator.crossfade().expect("started").frozen);
        animator.advance(&asset, 0.2);
        let mut pose = Pose::rest(&asset);
        animator.evaluate_pose(&asset, &mut pose).expect("valid");
        let w = animator.crossfade().expect("in progress").weight;
        assert!((w - Easing::SmoothStep.apply(0.2)).abs() < 1e-6);
        let from = sampled(&asset, walk, 0.25 * walk_len + 0.1);
        let to = sampled(&asset, run, animator.main().time);
        let want = blend_poses(
            &asset,
            &[BlendLayer::normal(&from.locals, &from.weights, 1.0 - w), BlendLayer::normal(&to.locals, &to.weights, w)],
        );
        assert_eq!(pose, want, "the outgoing clip kept playing");
        // A crossfade during a crossfade freezes the current pose.
        animator
            .crossfade_to(&asset, Some(walk), Crossfade { outgoing: Outgoing::KeepPlaying, ..fade })
            .expect("valid");
        assert!(animator.crossfade().expect("restarted").frozen);
        let mut restarted = Pose::rest(&asset);
        animator.evaluate_pose(&asset, &mut restarted).expect("valid");
        assert_eq!(restarted, pose, "starts from the pose it interrupted");
    }

    #[test]
    fn weighted_blend_normalizes_and_ignores_bad_weights() {
        let asset = load(FOX);
        let (survey, walk, run) = (clip(&asset, "Survey"), clip(&asset, "Walk"), clip(&asset, "Run"));
        let mut animator = Animator::new(&asset);
        let mut pose = Pose::rest(&asset);
        animator.set_blend(&asset, &[(Some(walk), 2.0), (Some(run), 6.0)]).expect("valid");
        animator.advance(&asset, 0.2);
        animator.evaluate_pose(&asset, &mut pose).expect("valid");
        let (a, b) = (sampled(&asset, walk, 0.2), sampled(&asset, run, 0.2));
        let want = blend_poses(
            &asset,
            &[BlendLayer::normal(&a.locals, &a.weights, 0.25), BlendLayer::normal(&b.locals, &b.weights, 0.75)],
        );
        assert_eq!(pose, want);
        // Same clips again: clocks kept; a NaN or negative weight counts as 0.
        animator.set_blend(&asset, &[(Some(walk), 1.0), (Some(run), f32::NAN), (Some(survey), -1.0)]).expect("valid");
        assert_eq!(animator.tracks()[1].player.time, 0.2);
        animator.evaluate_pose(&asset, &mut pose).expect("valid");
        assert_eq!(pose, a);
        animator.tracks_mut()[0].weight = 0.0;
        animator.evaluate_pose(&asset, &mut pose).expect("valid");
        assert_eq!(pose, Pose::rest(&asset), "nothing weighs: the rest pose");
        animator.set_blend(&asset, &[]).expect("valid");
        assert_eq!((animator.tracks().len(), animator.main().clip), (1, None));
        let index = animator.add_track(&asset, Some(run), 1.0).expect("valid");
        assert_eq!(index, 1);
        assert!(animator.remove_track(0).is_ok());
        assert!(animator.remove_track(0).is_err(), "the last track stays");
    }

    #[test]
    fn morph_weights_blend_like_the_other_channels() {
        let asset = load("khronos/MorphStressTest/glTF-Binary/MorphStressTest.glb");
        let animated: Vec<usize> = (0..asset.clips.len())
            .filter(|&c| asset.clips[c].channels().iter().any(|ch| ch.target == crate::clip::ChannelTarget::Weights))
            .collect();
        let (a, b) = animated
            .iter()
            .flat_map(|&a| animated.iter().map(move |&b| (a, b)))
            .find(|&(a, b)| sampled(&asset, a, 0.3).weights != sampled(&asset, b, 0.3).weights)
            .expect("two clips with different expressions");
        let mut animator = Animator::new(&asset);
        animator.set_blend(&asset, &[(Some(a), 1.0), (Some(b), 3.0)]).expect("valid");
        animator.advance(&asset, 0.3);
        let mut pose = Pose::rest(&asset);
        animator.evaluate_pose(&asset, &mut pose).expect("valid");
        let (wa, wb) = (sampled(&asset, a, 0.3).weights, sampled(&asset, b, 0.3).weights);
        for ((p, x), y) in pose.weights.iter().zip(&wa).zip(&wb) {
            assert!((p - (0.25 * x + 0.75 * y)).abs() < 1e-6, "{p} vs {x}, {y}");
        }
    }

    #[test]
    fn a_layer_changes_only_its_subtree() {
        let asset = load(ROBOT);
        let (walking, wave) = (clip(&asset, "Walking"), clip(&asset, "Wave"));
        let root = node(&asset, "Abdomen");
        let mut base = Animator::new(&asset);
        base.play(&asset, Some(walking)).expect("valid");
        let mut layered = base.clone();
        let index = layered.add_layer(&asset, Layer::new(wave, root)).expect("valid");
        let (mut want, mut got) = (Instance::new(&asset), Instance::new(&asset));
        for (weight, falloff) in [(1.0, 0.0), (0.6, 0.3)] {
            layered.layers_mut()[index].weight = weight;
            layered.layers_mut()[index].falloff = falloff;
            for _ in 0..3 {
                base.advance(&asset, 0.35);
                layered.advance(&asset, 0.35);
                base.evaluate(&asset, &mut want).expect("valid");
                layered.evaluate(&asset, &mut got).expect("valid");
                let mask = layered.layers()[index].mask();
                assert_eq!(mask[root as usize], 1.0);
                let mut changed = 0;
                for (n, &m) in mask.iter().enumerate() {
                    if m == 0.0 {
                        assert_eq!(got.pose().locals[n], want.pose().locals[n], "node {n} outside the subtree");
                        assert_eq!(got.worlds()[n], want.worlds()[n], "node {n} outside the subtree");
                    } else if got.worlds()[n] != want.worlds()[n] {
                        changed += 1;
                    }
                }
                assert!(changed > 10, "the upper body waves: {changed} nodes moved");
                assert_eq!(got.pose().weights, want.pose().weights, "no morph weights under Abdomen's skeleton");
            }
        }
        let mask = layered.layers()[index].mask();
        let upper_arm = node(&asset, "UpperArm.R") as usize;
        assert!(mask[upper_arm] < 0.7f32.powi(3) + 1e-6 && mask[upper_arm] > 0.0, "falloff with depth");
        assert_eq!(mask[node(&asset, "UpperLeg.L") as usize], 0.0);
    }

    #[test]
    fn additive_layer_at_its_reference_adds_nothing() {
        let asset = load(ROBOT);
        let (walking, yes) = (clip(&asset, "Walking"), clip(&asset, "Yes"));
        let root = node(&asset, "Abdomen");
        let mut animator = Animator::new(&asset);
        animator.play(&asset, Some(walking)).expect("valid");
        animator.advance(&asset, 0.5);
        let mut base = Pose::rest(&asset);
        animator.evaluate_pose(&asset, &mut base).expect("valid");
        let mut layer = Layer::new(yes, root);
        layer.additive = true;
        layer.player.playing = false; // at time 0: the reference itself
        let index = animator.add_layer(&asset, layer).expect("valid");
        let mut pose = Pose::rest(&asset);
        animator.evaluate_pose(&asset, &mut pose).expect("valid");
        for (n, (p, b)) in pose.locals.iter().zip(&base.locals).enumerate() {
            assert_eq!(p.translation, b.translation, "node {n}");
            assert_eq!(p.scale, b.scale, "node {n}");
            assert!(p.rotation.abs_diff_eq(b.rotation, 1e-6) || p.rotation.abs_diff_eq(-b.rotation, 1e-6), "node {n}");
        }
        // Further into the clip: its motion adds to Walking's on the subtree.
        animator.layers_mut()[index].player.seek(&asset, 0.5);
        animator.evaluate_pose(&asset, &mut pose).expect("valid");
        let head = node(&asset, "Head") as usize;
        assert!(pose.locals[head].rotation.angle_between(base.locals[head].rotation) > 1e-3, "the head nods");
        let leg = node(&asset, "UpperLeg.L") as usize;
        assert_eq!(pose.locals[leg], base.locals[leg]);
    }

    #[test]
    fn main_clock_events_reach_the_caller() {
        let asset = load(FOX);
        let walk = clip(&asset, "Walk");
        let len = asset.clips[walk].duration;
        let mut animator = Animator::new(&asset);
        animator.play(&asset, Some(walk)).expect("valid");
        animator.main_mut().loop_mode = LoopMode::PingPong;
        animator.main_mut().speed = -1.0;
        let events = animator.advance(&asset, len * 2.5);
        assert_eq!(events.main.looped, 3, "bounces at 0, the end, and 0 again");
        animator.main_mut().loop_mode = LoopMode::Once;
        animator.main_mut().speed = 1.0;
        let events = animator.advance(&asset, len * 3.0);
        assert!(events.main.finished && !events.crossfade_finished);
    }

    #[test]
    fn misuse_is_an_error_not_a_panic() {
        let asset = load(FOX);
        let other = load(ROBOT);
        let mut animator = Animator::new(&asset);
        let mut instance = Instance::new(&asset);
        assert!(animator.play(&asset, Some(99)).is_err());
        assert!(animator.crossfade_to(&asset, Some(99), Crossfade::default()).is_err());
        assert!(animator.set_blend(&asset, &[(Some(0), 1.0), (Some(99), 1.0)]).is_err());
        assert!(animator.add_track(&asset, Some(99), 1.0).is_err());
        assert!(animator.add_layer(&asset, Layer::new(99, 0)).is_err());
        assert!(animator.add_layer(&asset, Layer::new(0, 999)).is_err());
        assert!(animator.remove_layer(0).is_err());
        assert!(animator.evaluate(&other, &mut instance).is_err(), "another asset");
        assert!(animator.play(&other, Some(0)).is_err());
        let index = animator.add_layer(&asset, Layer::new(0, 3)).expect("valid");
        animator.layers_mut()[index].root = 999;
        assert!(animator.evaluate(&asset, &mut instance).is_err(), "root out of range");
        animator.layers_mut()[index].root = 3;
        animator.layers_mut()[index].falloff = f32::NAN;
        animator.layers_mut()[index].weight = f32::INFINITY;
        animator.evaluate(&asset, &mut instance).expect("bad weights are sanitized");
        animator.tracks_mut()[0].player.clip = Some(99);
        assert!(animator.evaluate(&asset, &mut instance).is_err(), "clip out of range");
        animator.play(&asset, Some(1)).expect("valid");
        // A zero-length crossfade switches at once.
        animator.crossfade_to(&asset, Some(2), Crossfade { duration: 0.0, ..Crossfade::default() }).expect("valid");
        assert!(animator.crossfade().is_none());
        assert_eq!(animator.main().clip, Some(2));
        // The source limit.
        let mut added = 0;
        while animator.add_track(&asset, Some(0), 1.0).is_ok() {
            added += 1;
            assert!(added <= MAX_SOURCES);
        }
        assert!(animator.add_layer(&asset, Layer::new(0, 3)).is_err());
        animator.evaluate(&asset, &mut instance).expect("the full animator still evaluates");
        assert!(BlendLayer::EMPTY.mode == BlendMode::Normal);
    }

    /// Advance + evaluate with a live crossfade, an override layer and an additive layer: no
    /// allocation per frame, through the crossfade's end.
    #[test]
    fn frames_with_crossfade_and_layers_do_not_allocate() {
        for (file, from, to, over, add, root) in [
            (FOX, "Walk", "Run", "Survey", "Run", "b_Spine01_02"),
            (ROBOT, "Walking", "Running", "Wave", "Yes", "Abdomen"),
        ] {
            let asset = load(file);
            let mut animator = Animator::new(&asset);
            let mut instance = Instance::new(&asset);
            animator.play(&asset, Some(clip(&asset, from))).expect("valid");
            let mut layer = Layer::new(clip(&asset, over), node(&asset, root));
            layer.weight = 0.7;
            layer.falloff = 0.2;
            animator.add_layer(&asset, layer).expect("valid");
            let mut layer = Layer::new(clip(&asset, add), node(&asset, root));
            layer.additive = true;
            layer.player.speed = -0.5;
            animator.add_layer(&asset, layer).expect("valid");
            animator.set_rotation_lerp(RotationLerp::Nlerp);
            let fade = Crossfade { duration: 1.5, easing: Easing::SmoothStep, outgoing: Outgoing::KeepPlaying };
            animator.crossfade_to(&asset, Some(clip(&asset, to)), fade).expect("valid");
            animator.evaluate(&asset, &mut instance).expect("valid");
            let before = allocations();
            let mut finished = 0;
            for _ in 0..200 {
                finished += u32::from(animator.advance(&asset, 1.0 / 60.0).crossfade_finished);
                animator.evaluate(&asset, &mut instance).expect("valid");
            }
            assert_eq!(allocations() - before, 0, "{file}");
            assert_eq!(finished, 1);
            assert!(instance.worlds().iter().all(|m| m.is_finite()));
            assert!(instance.worlds()[0].transform_point3(Vec3::ZERO).is_finite());
        }
    }
}
