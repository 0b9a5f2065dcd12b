//! A model being shown ([`Model`]): the immutable asset with its animation, evaluation, IK,
//! ragdoll and copies, and the methods that change them (the element's commands, the panels and
//! the viewport's input all go through these). Plain state: no GPU, no egui context, no page;
//! [`crate::app`], [`crate::ui`] and [`crate::overlay`] read and change it.

use glam::Vec3;
use kloub_core::animator::{Crossfade, Layer};
use kloub_core::asset::NodeIndex;
use kloub_core::clip::Clip;
use kloub_core::examples::{ExampleTargets, Examples};
use kloub_core::job::dqs::SkinningMethod;
use kloub_core::player::{LoopMode, Player};
use kloub_core::rig::JointSettings;
use kloub_core::{Animator, Asset, Instance, Warning};

use crate::candy::CandyPanel;
use crate::ik::IkState;
use crate::load::LoadedModel;

/// The layer panel's settings; applied to the animator's layer 0 by [`Model::sync_layer`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayerDraft {
    /// Whether the layer applies.
    pub enabled: bool,
    /// Clip index.
    pub clip: usize,
    /// Root node of the affected subtree.
    pub root: NodeIndex,
    /// Strength (override: 0..1; additive may exaggerate up to 2).
    pub weight: f32,
    /// Per-generation falloff below the root, 0..1.
    pub falloff: f32,
    /// The layer clock's speed.
    pub speed: f32,
    /// Add the clip's difference from its first frame instead of overriding.
    pub additive: bool,
}

/// A model being shown: the immutable asset and its animation and evaluation state.
pub struct Model {
    /// Display name (the file name).
    pub name: String,
    /// The imported asset.
    pub asset: std::sync::Arc<Asset>,
    /// Pose, world matrices and palettes, evaluated every frame.
    pub instance: Instance,
    /// What plays: tracks, crossfade, layers.
    pub animator: Animator,
    /// Import warnings.
    pub warnings: Vec<Warning>,
    /// Clip display names, by clip index.
    pub clip_names: Vec<String>,
    /// `clip_names` as a JSON array (for `dataset.clips`).
    pub clips_json: String,
    /// Sorted distinct key times of each clip (the timeline's markers).
    pub key_times: Vec<Vec<f32>>,
    /// Nodes the joint tree shows: joints and their ancestors (every node without skins).
    pub in_joint_tree: Vec<bool>,
    /// The blend panel's weight per clip.
    pub blend_weights: Vec<f32>,
    /// The layer panel's settings.
    pub layer: LayerDraft,
    /// Joint limits and stiffness for IK: humanoid defaults, edited by a dropped sidecar.
    pub joint_settings: JointSettings,
    /// The asset as imported: `asset` is this plus the example poses' morph targets when the
    /// sidecar has examples (spherical joint blending by example), else the same.
    pub base_asset: std::sync::Arc<Asset>,
    /// The sidecar's example poses and their morph targets' weights, when it has any.
    pub examples: Option<(Examples, ExampleTargets)>,
    /// The candy-wrapper sample's sliders and readout, when this model is that sample.
    pub candy: Option<CandyPanel>,
    /// Extra copies of the character in a grid (seed 000 demo 05): each plays what the main
    /// one plays, [`COPY_TIME_STEP`] later than the previous.
    pub copies: Vec<(Animator, Instance)>,
    /// Grid cell size: the larger horizontal extent of the framed bounds, plus a margin.
    pub copy_spacing: f32,
    /// World bounds the camera frames (animated, one copy).
    pub bounds: Option<(Vec3, Vec3)>,
    /// The inverse-kinematics goals, solved on the main character after animation, in order.
    pub ik: Vec<IkState>,
    /// The goal the panel edits and a joint click retargets.
    pub ik_selected: usize,
    /// The joint picked in the viewport or the joint tree: its axes are drawn and its
    /// channels plotted.
    pub selected_joint: Option<NodeIndex>,
    /// Morph weights set by the panel's sliders, by pose weight slot (`None`: animated).
    pub morph_overrides: Vec<Option<f32>>,
    /// Local rotations held over the animation, by node (`setJointRotation`; `None`: animated).
    pub rotation_overrides: Vec<Option<glam::Quat>>,
    /// Pose mode ("Animate | Pose"): the clip stopped, clicks select joints, the gizmo turns them.
    #[cfg(feature = "full")]
    pub pose_mode: bool,
    /// Whether the clip played when pose mode began (it plays again when it ends).
    #[cfg(feature = "full")]
    pub resume_playing: bool,
    /// Whether posing keeps each joint within its IK limits (the joint settings).
    #[cfg(feature = "full")]
    pub pose_within_limits: bool,
    /// The example pose being sculpted ([`crate::pose`]).
    #[cfg(feature = "full")]
    pub sculpt: Option<crate::pose::SculptState>,
    /// Joints worth offering as IK end effectors, best first, with their chain depth
    /// ([`crate::ik::default_effectors`], found once per model).
    pub ik_offers: Vec<(NodeIndex, usize)>,
    /// The ragdoll, while the character is one.
    #[cfg(feature = "full")]
    pub ragdoll: Option<crate::ragdoll::RagdollState>,
    /// Gravity and damping for the ragdoll (the panel's sliders).
    #[cfg(feature = "full")]
    pub ragdoll_options: kloub_core::ragdoll::RagdollOptions,
    /// The ragdoll's obstacles (kept across runs; the sidecar's `obstacles`). Changed through
    /// [`Model::set_obstacles`], which keeps `obstacles_json` and a running ragdoll in step.
    #[cfg(feature = "full")]
    pub obstacles: Vec<kloub_core::ragdoll::Obstacle>,
    /// `dataset.obstacles`: the obstacles as the JSON `setObstacles` takes; `""` without
    /// (written when they change, mirrored every frame).
    #[cfg(feature = "full")]
    pub obstacles_json: String,
    /// Last frame's worlds of the main character (a ragdoll inherits their velocity).
    #[cfg(feature = "full")]
    previous: crate::ragdoll::PreviousWorlds,
    /// The glTF-Validator's report on this model, once the panel's Validate ran it.
    #[cfg(feature = "full")]
    pub validation: Option<crate::validation::Validation>,
    /// Whether the validator is running on this model.
    #[cfg(feature = "full")]
    pub validating: bool,
}

/// The `obstacles` of a sidecar (none when it has none).
///
/// # Errors
/// Not JSON, or a bad list, naming its pointer (`/obstacles/2/radius: …`).
#[cfg(feature = "full")]
pub fn obstacles_in_sidecar(text: &str) -> Result<Vec<kloub_core::ragdoll::Obstacle>, String> {
    let doc: serde_json::Value = serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
    match doc.get("obstacles") {
        None => Ok(Vec::new()),
        Some(list) => kloub_core::ragdoll::Obstacle::list_from_value(list, "/obstacles"),
    }
}

/// `x` rounded to five decimals, for the JSON state mirrors (stable text for equal values).
fn round5(x: f32) -> f64 {
    (f64::from(x) * 1e5).round() / 1e5
}

/// Most copies of the character the grid shows.
pub const MAX_COPIES: usize = 100;

/// Time offset between neighbouring copies, in seconds.
pub const COPY_TIME_STEP: f32 = 0.37;

/// Frames sampled across a clip to frame the camera on the animated (skinned) bounds.
const FIT_SAMPLES: u32 = 8;

/// Key times closer than this (seconds) share a timeline marker.
const KEY_EPSILON: f32 = 1e-4;

impl Model {
    /// Wraps a loaded model, playing `clip` from its start, and evaluates it once.
    ///
    /// # Errors
    /// The evaluation error (an asset the jobs reject).
    pub fn new(loaded: LoadedModel, clip: Option<usize>) -> Result<Self, String> {
        let LoadedModel { name, asset, warnings, sidecar } = loaded;
        let mut joint_settings = JointSettings::humanoid(&asset);
        let base_asset = asset.clone();
        let mut examples = None;
        let mut asset = asset;
        if let Some(text) = &sidecar {
            joint_settings.apply_json(&asset, text).map_err(|e| format!("{name}: sidecar: {e}"))?;
            let read = Examples::from_json(&asset, text).map_err(|e| format!("{name}: sidecar: {e}"))?;
            if !read.poses.is_empty() {
                // The examples become morph targets whose weights are α (drawn by SJB on the GPU).
                let mut rigs = Instance::new(&asset);
                rigs.set_examples(&asset, &read).map_err(|e| format!("{name}: sidecar: {e}"))?;
                let (derived, targets) = ExampleTargets::compile(&asset, &rigs);
                asset = std::sync::Arc::new(derived);
                crate::decode::share(&base_asset, &asset);
                examples = Some((read, targets));
            }
        }
        // The ragdoll's obstacles, saved in the sidecar.
        #[cfg(feature = "full")]
        let obstacles = match &sidecar {
            Some(text) => obstacles_in_sidecar(text).map_err(|e| format!("{name}: sidecar: {e}"))?,
            None => Vec::new(),
        };
        let mut instance = Instance::new(&asset);
        let mut animator = Animator::new(&asset);
        animator.play(&asset, clip).map_err(|e| format!("{name}: {e}"))?;
        animator.evaluate(&asset, &mut instance).map_err(|e| format!("{name}: {e}"))?;
        let clip_names: Vec<String> = asset.clips.iter().enumerate().map(|(i, c)| c.display_name(i)).collect();
        let clips_json = serde_json::to_string(&clip_names).map_err(|e| e.to_string())?;
        let key_times = asset.clips.iter().map(key_times).collect();
        let in_joint_tree = joint_tree_nodes(&asset);
        let asset_weight_slots = instance.pose().weights.len();
        let node_count = asset.nodes.len();
        let ik_offers = crate::ik::default_effectors(&asset);
        let mut blend_weights = vec![0.0; asset.clips.len()];
        if let Some(w) = clip.and_then(|c| blend_weights.get_mut(c)) {
            *w = 1.0;
        }
        let layer = LayerDraft {
            enabled: false,
            // Another clip than the base when there is one, to make the layer visible.
            clip: if asset.clips.len() > 1 && clip == Some(0) { 1 } else { 0 },
            root: default_layer_root(&asset),
            weight: 1.0,
            falloff: 0.0,
            speed: 1.0,
            additive: false,
        };
        Ok(Self {
            name,
            asset,
            instance,
            animator,
            warnings,
            clip_names,
            clips_json,
            key_times,
            in_joint_tree,
            blend_weights,
            layer,
            joint_settings,
            base_asset,
            examples,
            candy: None,
            copies: Vec::new(),
            copy_spacing: 1.0,
            bounds: None,
            ik: Vec::new(),
            ik_selected: 0,
            selected_joint: None,
            morph_overrides: vec![None; asset_weight_slots],
            rotation_overrides: vec![None; node_count],
            ik_offers,
            #[cfg(feature = "full")]
            pose_mode: false,
            #[cfg(feature = "full")]
            resume_playing: false,
            #[cfg(feature = "full")]
            pose_within_limits: false,
            #[cfg(feature = "full")]
            sculpt: None,
            #[cfg(feature = "full")]
            ragdoll: None,
            #[cfg(feature = "full")]
            ragdoll_options: kloub_core::ragdoll::RagdollOptions::default(),
            #[cfg(feature = "full")]
            obstacles_json: if obstacles.is_empty() {
                String::new()
            } else {
                kloub_core::ragdoll::Obstacle::list_to_json(&obstacles)
            },
            #[cfg(feature = "full")]
            obstacles,
            #[cfg(feature = "full")]
            previous: crate::ragdoll::PreviousWorlds::default(),
            #[cfg(feature = "full")]
            validation: None,
            #[cfg(feature = "full")]
            validating: false,
        })
    }

    /// World bounds of the drawable meshes over `clip` (sampled at a few times, skinning
    /// included), or of the rest pose without a clip. The next [`Model::evaluate`] restores
    /// the animated pose. `None` when nothing is drawable.
    pub fn animated_bounds(&mut self, clip: Option<usize>) -> Option<(Vec3, Vec3)> {
        let duration = clip.and_then(|c| self.asset.clips.get(c)).map_or(0.0, |c| c.duration);
        let samples = if duration > 0.0 { FIT_SAMPLES } else { 1 };
        let mut bounds: Option<(Vec3, Vec3)> = None;
        for i in 0..samples {
            let t = duration * i as f32 / samples as f32;
            if self.instance.evaluate(&self.asset, clip, t).is_err() {
                continue;
            }
            // A file without meshes (a bare skeleton) is framed on its joints.
            let sample = self.instance.scene_bounds(&self.asset).or_else(|| node_bounds(self.instance.worlds()));
            if let Some((lo, hi)) = sample {
                bounds = Some(bounds.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
            }
        }
        // Joints alone may lie on a line or a point: give the box some thickness.
        bounds.map(|(lo, hi)| {
            let pad = ((hi - lo).max_element() * 0.05).max(1e-3);
            if self.has_meshes() { (lo, hi) } else { (lo - Vec3::splat(pad), hi + Vec3::splat(pad)) }
        })
    }

    /// Display name of `clip`, `""` for the rest pose.
    pub fn clip_name(&self, clip: Option<usize>) -> &str {
        clip.and_then(|c| self.clip_names.get(c)).map_or("", String::as_str)
    }

    /// Display name of node `node` (its name, else `node N`).
    pub fn node_name(&self, node: NodeIndex) -> String {
        match self.asset.nodes.get(node as usize).and_then(|n| n.name.as_deref()) {
            Some(name) if !name.is_empty() => name.to_owned(),
            _ => format!("node {node}"),
        }
    }

    /// Samples, blends and writes the pose, worlds and palettes for this frame.
    ///
    /// # Errors
    /// The job error (not expected for an asset the importer accepted).
    pub fn evaluate(&mut self) -> Result<(), String> {
        // Kept (without reallocating) so a ragdoll can start with the animation's velocities.
        #[cfg(feature = "full")]
        {
            self.previous.worlds.clear();
            self.previous.worlds.extend_from_slice(self.instance.worlds());
        }
        self.animator.evaluate(&self.asset, &mut self.instance).map_err(|e| e.to_string())?;
        for (animator, instance) in &mut self.copies {
            animator.evaluate(&self.asset, instance).map_err(|e| e.to_string())?;
        }
        if let Some(candy) = &mut self.candy {
            candy.apply(&self.asset, &mut self.instance)?;
            for (_, instance) in &mut self.copies {
                candy.apply(&self.asset, instance)?;
            }
            candy.update_quality(self.instance.pose());
        }
        // While an example pose is sculpted the skin holds that pose, its examples weighted in.
        #[cfg(feature = "full")]
        if let Some(state) = &self.sculpt {
            for &(n, t) in &state.locals {
                if let Some(local) = self.instance.pose_mut().locals.get_mut(n as usize) {
                    *local = t;
                }
            }
            self.instance.update(&self.asset).map_err(|e| e.to_string())?;
            if let Some((_, targets)) = &mut self.examples {
                targets.write_weights(&mut self.instance, true).map_err(|e| e.to_string())?;
            }
            return Ok(());
        }
        // Held joint rotations win over the clip (the main character only), before IK solves on top.
        if self.rotation_overrides.iter().any(Option::is_some) {
            for (local, held) in self.instance.pose_mut().locals.iter_mut().zip(&self.rotation_overrides) {
                if let Some(q) = held {
                    local.rotation = *q;
                }
            }
            self.instance.update(&self.asset).map_err(|e| e.to_string())?;
        }
        // The ragdoll's bodies own the skeleton (blended over the animation while handing back).
        #[cfg(feature = "full")]
        let ragdoll_owns = match &mut self.ragdoll {
            Some(ragdoll) => {
                // Powered: the animation's pose (in the worlds now) is what the bodies follow.
                // Seconds of the clip since the targets before (0 when evaluated again in a frame;
                // a frame's time when the clip wrapped round).
                let now = self.animator.main().time;
                let dt = match ragdoll.target_time {
                    Some(t) if now >= t => now - t,
                    _ => self.previous.dt,
                };
                ragdoll.target_time = Some(now);
                ragdoll.ragdoll.set_targets(self.instance.worlds(), dt);
                ragdoll.ragdoll.write_pose(self.instance.pose_mut(), ragdoll.weight());
                self.instance.update(&self.asset).map_err(|e| e.to_string())?;
                true
            }
            None => false,
        };
        #[cfg(not(feature = "full"))]
        let ragdoll_owns = false;
        // IK goals rest while posing (the gizmo turns what IK would otherwise own).
        #[cfg(feature = "full")]
        let posing = self.pose_mode;
        #[cfg(not(feature = "full"))]
        let posing = false;
        if !ragdoll_owns && !posing {
            crate::ik::apply_all(&mut self.ik, &self.asset, &mut self.instance)?;
        }
        // The example poses' weights (α under SJBBE, zero under the other methods).
        if let Some((_, targets)) = &mut self.examples {
            let on = self.instance.skinning() == SkinningMethod::SphericalJointBlendByExample;
            targets.write_weights(&mut self.instance, on).map_err(|e| e.to_string())?;
            for (_, instance) in &mut self.copies {
                targets.write_weights(instance, on).map_err(|e| e.to_string())?;
            }
        }
        // The morph sliders win over the clip (the main character only: copies keep the clip's).
        if self.morph_overrides.iter().any(Option::is_some) {
            let weights = &mut self.instance.pose_mut().weights;
            for (w, o) in weights.iter_mut().zip(&self.morph_overrides) {
                if let Some(o) = o {
                    *w = *o;
                }
            }
        }
        Ok(())
    }

    /// The `<model>.kloub.json` sidecar of the current joint settings (what differs from the
    /// humanoid defaults).
    pub fn sidecar_json(&self) -> String {
        self.sidecar_json_with(self.examples.as_ref().map(|(e, _)| e))
    }

    /// The file this model was shown from, with `sidecar` in place of its own, to install again
    /// (example poses change the morph targets): the images the browser decoded stay shared and
    /// their warnings are not counted twice.
    pub fn reloaded(&self, sidecar: String) -> crate::load::LoadedModel {
        let decoded = crate::decode::warnings(&self.base_asset);
        crate::load::LoadedModel {
            name: self.name.clone(),
            asset: self.base_asset.clone(),
            warnings: self.warnings.iter().filter(|w| !decoded.contains(w)).cloned().collect(),
            sidecar: Some(sidecar),
        }
    }

    /// [`Model::sidecar_json`] with `examples` in place of the model's.
    pub fn sidecar_json_with(&self, examples: Option<&Examples>) -> String {
        let text = self.joint_settings.to_json(&self.base_asset, &JointSettings::humanoid(&self.base_asset));
        #[cfg(feature = "full")]
        let obstacles = !self.obstacles.is_empty();
        #[cfg(not(feature = "full"))]
        let obstacles = false;
        if examples.is_none() && !obstacles {
            return text;
        }
        // The example poses and obstacles too, so that dropping the file back restores them.
        let mut doc: serde_json::Map<String, serde_json::Value> = serde_json::from_str(&text).unwrap_or_default();
        if let Some(examples) = examples {
            doc.extend(examples.to_json(&self.base_asset));
        }
        #[cfg(feature = "full")]
        if obstacles {
            let list = self.obstacles.iter().map(kloub_core::ragdoll::Obstacle::to_value).collect();
            doc.insert("obstacles".into(), serde_json::Value::Array(list));
        }
        serde_json::to_string_pretty(&doc).unwrap_or(text)
    }

    /// Sets σ (radians of arc) of joint node `node`'s example poses: their weights are solved
    /// again; the morph targets stay.
    ///
    /// # Errors
    /// No examples, or σ the rig refuses (too small for examples this far apart, or too large).
    pub fn set_example_sigma(&mut self, node: NodeIndex, sigma: f32) -> Result<(), String> {
        let Some((examples, targets)) = &mut self.examples else { return Err("the model has no example poses".into()) };
        let mut next = examples.clone();
        next.sigma.retain(|&(n, _)| n != node);
        next.sigma.push((node, sigma));
        let mut rigs = Instance::new(&self.base_asset);
        rigs.set_examples(&self.base_asset, &next).map_err(|e| format!("{}: σ {sigma}: {e}", self.name))?;
        targets.update_rigs(&rigs)?;
        *examples = next;
        Ok(())
    }

    /// `dataset.pose`: the held joint rotations as a JSON object `{"JOINT": [x, y, z, w]}` (five
    /// decimals); `""` when none is held.
    pub fn pose_json(&self) -> String {
        if self.rotation_overrides.iter().all(Option::is_none) {
            return String::new();
        }
        let held: serde_json::Map<String, serde_json::Value> = (0u32..)
            .zip(&self.rotation_overrides)
            .filter_map(|(n, q)| {
                let q = (*q)?;
                Some((self.node_name(n), serde_json::json!([round5(q.x), round5(q.y), round5(q.z), round5(q.w)])))
            })
            .collect();
        serde_json::Value::Object(held).to_string()
    }

    /// `dataset.ik`: `"EFFECTOR:ERROR"` per goal (error with five decimals), `;`-separated;
    /// `""` without IK.
    pub fn ik_summary(&self) -> String {
        let goals: Vec<String> =
            self.ik.iter().map(|ik| format!("{}:{:.5}", self.node_name(ik.effector()), ik.report.error)).collect();
        goals.join(";")
    }

    /// `dataset.blend`: the clips weighted in the base blend as a JSON array of `[name, weight]`,
    /// when two or more are (`""` while one clip plays alone).
    pub fn blend_summary(&self) -> String {
        // Mirrored every frame: nothing is built while one clip plays alone (the usual case).
        if self.blend_weights.iter().filter(|w| w.is_finite() && **w > 0.0).count() < 2 {
            return String::new();
        }
        let weighted: Vec<serde_json::Value> = (self.clip_names.iter().zip(&self.blend_weights))
            .filter(|(_, w)| w.is_finite() && **w > 0.0)
            .map(|(name, w)| serde_json::json!([name, round5(*w)]))
            .collect();
        serde_json::Value::Array(weighted).to_string()
    }

    /// `dataset.ikGoals`: every IK goal as the page would set it again (`setIkTarget` +
    /// `setIkSolver`), a JSON array; `""` without IK.
    pub fn ik_goals_json(&self) -> String {
        if self.ik.is_empty() {
            return String::new();
        }
        let v3 = |v: Vec3| serde_json::json!([round5(v.x), round5(v.y), round5(v.z)]);
        let goals: Vec<serde_json::Value> = (self.ik.iter())
            .map(|ik| {
                serde_json::json!({
                    "effector": self.node_name(ik.effector()),
                    "depth": ik.depth(),
                    "target": v3(ik.target),
                    "solver": ik.solver.name(),
                    "iterations": ik.iterations,
                    "softness": round5(ik.softness),
                    "patternMove": ik.accelerate,
                    "pole": ik.pole.map(v3),
                })
            })
            .collect();
        serde_json::Value::Array(goals).to_string()
    }

    /// `dataset.morphs`: the morph weights held by the page or the panel, a JSON array of
    /// `[node name, target index, weight]`; `""` when the clip drives every weight.
    pub fn morphs_json(&self) -> String {
        // Mirrored every frame: no walk over the nodes while the clip drives every weight.
        if self.morph_overrides.iter().all(Option::is_none) {
            return String::new();
        }
        let mut held = Vec::new();
        for (node, n) in self.asset.nodes.iter().enumerate() {
            let start = self.asset.weight_offsets.get(node).copied().unwrap_or(0) as usize;
            for target in 0..n.weights.len() {
                if let Some(Some(w)) = self.morph_overrides.get(start + target) {
                    let name = self.node_name(NodeIndex::try_from(node).unwrap_or(NodeIndex::MAX));
                    held.push(serde_json::json!([name, target, round5(*w)]));
                }
            }
        }
        if held.is_empty() { String::new() } else { serde_json::Value::Array(held).to_string() }
    }

    /// A new goal for `effector` keeping `like`'s solver and iterations where they apply.
    pub(crate) fn ik_goal(
        &self,
        effector: NodeIndex,
        depth: usize,
        target: Option<Vec3>,
        like: Option<&IkState>,
    ) -> Result<IkState, String> {
        let mut state = IkState::new(&self.asset, &self.instance, &self.joint_settings, effector, depth, target)?;
        if let Some(like) = like {
            state.iterations = like.iterations;
            state.accelerate = like.accelerate;
            state.softness = like.softness;
            state.use_limits = like.use_limits;
            if like.solver != kloub_core::job::ik::IkSolver::TwoBone || state.depth() == 2 {
                state.solver = like.solver;
            }
            // The same chain again (a new target for it): its pole stays.
            if like.effector() == effector && like.depth() == state.depth() {
                state.pole = like.pole;
            }
        }
        Ok(state)
    }

    /// Number of characters shown (the main one plus its copies).
    pub fn copy_count(&self) -> usize {
        1 + self.copies.len()
    }

    /// Shows `n` characters (clamped to 1..=[`MAX_COPIES`]).
    pub fn set_copies(&mut self, n: usize) {
        let n = n.clamp(1, MAX_COPIES);
        self.copies.truncate(n - 1);
        self.copies.reserve(n - 1 - self.copies.len());
        while self.copies.len() < n - 1 {
            self.copies.push((self.animator.clone(), self.instance.clone()));
        }
        self.sync_copies();
    }

    /// Makes every copy play what the main character plays (clips, crossfade, layers, speed,
    /// skinning method), copy `c` offset by `c ·` [`COPY_TIME_STEP`].
    pub fn sync_copies(&mut self) {
        for (c, (animator, instance)) in self.copies.iter_mut().enumerate() {
            animator.clone_from(&self.animator);
            let offset = (c + 1) as f32 * COPY_TIME_STEP;
            let asset = &self.asset;
            let shift = |player: &mut Player| {
                let d = player.duration(asset);
                if d > 0.0 && player.time.is_finite() {
                    player.time = (player.time + offset).rem_euclid(d);
                }
            };
            animator.tracks_mut().iter_mut().for_each(|t| shift(&mut t.player));
            animator.layers_mut().iter_mut().for_each(|l| shift(&mut l.player));
            instance.set_skinning(asset, self.instance.skinning());
        }
    }

    /// Where copy `c` stands: a square grid centred on the main character's place.
    pub fn copy_offset(&self, c: usize) -> Vec3 {
        let n = self.copy_count();
        let columns = (n as f32).sqrt().ceil().max(1.0) as usize;
        let rows = n.div_ceil(columns);
        let (column, row) = (c % columns, c / columns);
        let centre = |i: usize, count: usize| (i as f32 - (count - 1) as f32 / 2.0) * self.copy_spacing;
        Vec3::new(centre(column, columns), 0.0, centre(row, rows))
    }

    /// The bounds of every copy together (for framing the camera).
    pub fn grid_bounds(&self) -> Option<(Vec3, Vec3)> {
        let (min, max) = self.bounds?;
        let (mut lo, mut hi) = (min, max);
        for c in 0..self.copy_count() {
            let o = self.copy_offset(c);
            lo = lo.min(min + o);
            hi = hi.max(max + o);
        }
        Some((lo, hi))
    }

    /// Plays `clip` (`None`: rest pose) as a click in the clip list does: crossfades with
    /// `fade` when something is playing and `fade.duration > 0`, else cuts. The blend panel
    /// follows (weight 1 on `clip`).
    ///
    /// # Errors
    /// A clip index out of range.
    pub fn play_clip(&mut self, clip: Option<usize>, fade: Crossfade) -> Result<(), String> {
        let current = self.animator.main().clip;
        let blended = self.animator.tracks().len() > 1;
        let fades = fade.duration.is_finite() && fade.duration > 0.0 && (current.is_some() || blended);
        let result = if fades {
            self.animator.crossfade_to(&self.asset, clip, fade)
        } else {
            self.animator.play(&self.asset, clip)
        };
        result.map_err(|e| e.to_string())?;
        if let Some(candy) = &mut self.candy {
            // A clip takes over from the sliders.
            candy.manual = clip.is_none();
        }
        self.blend_weights.iter_mut().for_each(|w| *w = 0.0);
        if let Some(w) = clip.and_then(|c| self.blend_weights.get_mut(c)) {
            *w = 1.0;
        }
        self.set_playing(true);
        Ok(())
    }

    /// Makes the base a blend of the clips with a positive weight in [`Model::blend_weights`]
    /// (none: the rest pose). Tracks already playing their clip keep their clocks.
    ///
    /// # Errors
    /// Too many clips at once ([`kloub_core::animator::MAX_SOURCES`]).
    pub fn apply_blend(&mut self) -> Result<(), String> {
        let clips: Vec<(Option<usize>, f32)> = self
            .blend_weights
            .iter()
            .enumerate()
            .filter(|(_, w)| w.is_finite() && **w > 0.0)
            .map(|(i, w)| (Some(i), *w))
            .collect();
        let (speed, loop_mode) = (self.animator.main().speed, self.animator.main().loop_mode);
        self.animator.set_blend(&self.asset, &clips).map_err(|e| e.to_string())?;
        for track in self.animator.tracks_mut() {
            track.player.speed = speed;
            track.player.loop_mode = loop_mode;
        }
        Ok(())
    }

    /// Applies [`Model::layer`] to the animator: adds, updates or removes the layer.
    ///
    /// # Errors
    /// A clip or root out of range, or too many sources.
    pub fn sync_layer(&mut self) -> Result<(), String> {
        let draft = self.layer;
        if !draft.enabled {
            while !self.animator.layers().is_empty() {
                self.animator.remove_layer(0).map_err(|e| e.to_string())?;
            }
            return Ok(());
        }
        if draft.clip >= self.asset.clips.len() {
            return Err(format!("layer clip {} is not a clip of {}", draft.clip, self.name));
        }
        if draft.root as usize >= self.asset.nodes.len() {
            return Err(format!("layer root {} is not a node of {}", draft.root, self.name));
        }
        let playing = self.animator.main().playing;
        if self.animator.layers().is_empty() {
            let mut layer = Layer::new(draft.clip, draft.root);
            layer.player.playing = playing;
            self.animator.add_layer(&self.asset, layer).map_err(|e| e.to_string())?;
        }
        if let Some(layer) = self.animator.layers_mut().first_mut() {
            if layer.player.clip != Some(draft.clip) {
                layer.player.set_clip(Some(draft.clip));
                layer.player.playing = playing;
            }
            layer.root = draft.root;
            layer.weight = draft.weight;
            layer.falloff = draft.falloff;
            layer.player.speed = draft.speed;
            layer.additive = draft.additive;
        }
        Ok(())
    }

    /// Whether the main clock runs.
    pub fn is_playing(&self) -> bool {
        self.animator.main().playing
    }

    /// Starts or stops every clock (tracks and layers). Starting a one-shot clip that has
    /// finished restarts it from its start (or its end, playing backwards).
    pub fn set_playing(&mut self, playing: bool) {
        let asset = &self.asset;
        for track in self.animator.tracks_mut() {
            if playing {
                restart_if_finished(&mut track.player, asset);
            }
            track.player.playing = playing;
        }
        for layer in self.animator.layers_mut() {
            if playing {
                restart_if_finished(&mut layer.player, asset);
            }
            layer.player.playing = playing;
        }
    }

    /// Moves the main clock to `seconds` (clamped to the clip), and each layer's clock to the
    /// same time within its clip (wrapped), so the pose at a time does not depend on when the
    /// layer was added: a scrubbed or linked view is reproducible.
    pub fn seek(&mut self, seconds: f32) {
        self.animator.main_mut().seek(&self.asset, seconds);
        let asset = &self.asset;
        for layer in self.animator.layers_mut() {
            let duration = layer.player.duration(asset);
            let t = if duration > 0.0 && seconds.is_finite() { seconds.rem_euclid(duration) } else { 0.0 };
            layer.player.seek(asset, t);
        }
    }

    /// Sets the speed of every base track (negative plays backwards).
    pub fn set_speed(&mut self, speed: f32) {
        if speed.is_finite() {
            self.animator.tracks_mut().iter_mut().for_each(|t| t.player.speed = speed);
        }
    }

    /// Sets the loop mode of every base track.
    pub fn set_loop_mode(&mut self, mode: LoopMode) {
        self.animator.tracks_mut().iter_mut().for_each(|t| t.player.loop_mode = mode);
    }

    /// Whether anything moves without input: a clock with a clip runs (a base track or a
    /// layer). A crossfade moves only while a clock runs.
    pub fn is_animating(&self) -> bool {
        let runs = |p: &Player| p.playing && p.clip.is_some();
        self.animator.tracks().iter().any(|t| runs(&t.player)) || self.animator.layers().iter().any(|l| runs(&l.player))
    }

    /// Advances the animation by `dt` seconds of wall time. While everything is paused the
    /// crossfade holds too, so a paused character does not move. Returns what the main clock
    /// did (looped, finished).
    pub fn advance(&mut self, dt: f32) -> kloub_core::player::PlayerEvents {
        let dt = if self.is_animating() { dt } else { 0.0 };
        let events = self.animator.advance(&self.asset, dt).main;
        for (animator, _) in &mut self.copies {
            animator.advance(&self.asset, dt);
        }
        events
    }

    /// Turns the character into a ragdoll from the pose on screen, moving as the animation
    /// moved in the last frame.
    ///
    /// # Errors
    /// A model without a skinned skeleton.
    #[cfg(feature = "full")]
    pub fn start_ragdoll(&mut self) -> Result<(), String> {
        let previous = (self.previous.worlds.len() == self.asset.nodes.len() && self.previous.dt > 0.0)
            .then_some((self.previous.worlds.as_slice(), self.previous.dt));
        let ragdoll = kloub_core::ragdoll::Ragdoll::new(
            &self.asset,
            &mut self.instance,
            &self.joint_settings,
            previous,
            self.ragdoll_options,
        )
        .map_err(|e| format!("{}: {e}", self.name))?;
        let mut ragdoll = ragdoll;
        ragdoll.set_obstacles(&self.obstacles);
        self.ragdoll = Some(crate::ragdoll::RagdollState { ragdoll, blend_back: None, target_time: None });
        Ok(())
    }

    /// Advances the ragdoll by `dt` seconds of wall time (ending it once handed back).
    #[cfg(feature = "full")]
    pub fn advance_ragdoll(&mut self, dt: f32) {
        self.previous.dt = dt;
        if let Some(ragdoll) = &mut self.ragdoll
            && !ragdoll.advance(dt)
        {
            self.ragdoll = None;
        }
    }

    /// Whether the ragdoll still moves (the view needs frames).
    pub fn ragdoll_moving(&self) -> bool {
        #[cfg(feature = "full")]
        return self.ragdoll.as_ref().is_some_and(|r| r.blend_back.is_some() || !r.ragdoll.is_resting());
        #[cfg(not(feature = "full"))]
        false
    }

    /// Whether any node draws a mesh (else the viewport shows the skeleton).
    pub fn has_meshes(&self) -> bool {
        self.asset.nodes.iter().any(|n| n.mesh.is_some())
    }

    /// The main clip's duration in seconds (0 for the rest pose).
    pub fn duration(&self) -> f32 {
        self.animator.main().duration(&self.asset)
    }

    /// `dataset.layer`: `"CLIP@ROOT:WEIGHT"` (weight with two decimals), `""` without a layer.
    pub fn layer_summary(&self) -> String {
        match self.animator.layers().first() {
            Some(layer) => {
                format!("{}@{}:{:.2}", self.clip_name(layer.player.clip), self.node_name(layer.root), layer.weight)
            }
            None => String::new(),
        }
    }
}

/// A finished one-shot clock restarts from its start (its end, playing backwards).
fn restart_if_finished(player: &mut Player, asset: &Asset) {
    if player.loop_mode != LoopMode::Once || player.playing {
        return;
    }
    let duration = player.duration(asset);
    if player.speed >= 0.0 && player.time >= duration {
        player.time = 0.0;
    } else if player.speed < 0.0 && player.time <= 0.0 {
        player.time = duration;
    }
}

/// Bounds of the nodes' world positions (`None` without nodes).
fn node_bounds(worlds: &[glam::Mat4]) -> Option<(Vec3, Vec3)> {
    let mut points = worlds.iter().map(|w| w.w_axis.truncate()).filter(|p| p.is_finite());
    let first = points.next()?;
    Some(points.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
}

/// Sorted distinct key times of `clip`.
fn key_times(clip: &Clip) -> Vec<f32> {
    let mut times: Vec<f32> =
        clip.channels().iter().flat_map(|c| c.times.iter().copied()).filter(|t| t.is_finite()).collect();
    times.sort_by(f32::total_cmp);
    times.dedup_by(|a, b| (*a - *b).abs() < KEY_EPSILON);
    times
}

/// Joints of every skin and their ancestors; every node when there are no skins.
fn joint_tree_nodes(asset: &Asset) -> Vec<bool> {
    let n = asset.nodes.len();
    if asset.skins.is_empty() {
        return vec![true; n];
    }
    let mut shown = vec![false; n];
    for &joint in asset.skins.iter().flat_map(|s| &s.joints) {
        // Walk up until a node already shown; the importer guarantees an acyclic graph, and the
        // walk is bounded by the node count regardless.
        let mut node = Some(joint);
        let mut steps = 0;
        while let Some(i) = node.filter(|_| steps <= n) {
            let Some(slot) = shown.get_mut(i as usize) else { break };
            if *slot {
                break;
            }
            *slot = true;
            node = asset.nodes.get(i as usize).and_then(|nd| nd.parent);
            steps += 1;
        }
    }
    shown
}

/// The layer's default root: an upper-body joint of the first skin when one is named like
/// it (spine, abdomen, chest, torso), else its first joint, else node 0.
fn default_layer_root(asset: &Asset) -> NodeIndex {
    let joints = asset.skins.first().map_or(&[][..], |s| &s.joints[..]);
    let upper = |j: &NodeIndex| {
        asset.nodes.get(*j as usize).and_then(|n| n.name.as_deref()).is_some_and(|name| {
            let name = name.to_ascii_lowercase();
            ["spine", "abdomen", "chest", "torso"].iter().any(|k| name.contains(k))
        })
    };
    joints.iter().copied().find(upper).or_else(|| joints.first().copied()).unwrap_or(0)
}
