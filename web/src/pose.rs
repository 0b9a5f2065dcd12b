//! Free posing and sculpted example poses (seed 001 App. C and §5.3) in the viewer.
//!
//! - **Pose mode** ("Animate | Pose"): the clip stops where it is, so posing starts from the
//!   pose on screen; a click on the model selects its nearest joint, and the three rings of the
//!   gizmo ([`crate::app`]'s viewport) or the joint panel's angle fields turn it, held over the
//!   animation ([`crate::model::Model::rotation_overrides`]), optionally within its IK limits.
//! - **Sculpt** ("Add example pose"): the selected joint's rotation is recorded, the skin is
//!   shown in that example pose (the bind pose with only that joint turned,
//!   [`kloub_core::sculpt::example_pose_locals`]) with the joint's support highlighted, and the
//!   brushes move the support's vertices ([`kloub_core::sculpt::Sculpt::dab`]). "Done" takes the
//!   shape back to the reference pose as the example's offsets and shows the model again with
//!   the example added (the stage reinstalls it, [`crate::stage::Stage::set_examples`]).

use kloub_core::Instance;
use kloub_core::examples::{Examples, JointExample};
use kloub_core::job::dqs::SkinningMethod;
use kloub_core::math::Transform;
use kloub_core::sculpt::{Brush, Dab, Sculpt};

use crate::model::Model;

/// The default brush radius, as a fraction of the model's bounding-box diagonal.
pub const DEFAULT_RADIUS: f32 = 0.06;

/// The default brush strength.
pub const DEFAULT_STRENGTH: f32 = 0.5;

/// An example pose being sculpted.
#[derive(Clone, Debug)]
pub struct SculptState {
    /// The sculpt.
    pub sculpt: Sculpt,
    /// The example pose's local transforms, written over the clip every frame.
    pub locals: Vec<(u32, Transform)>,
    /// The brush the viewport's drags use.
    pub brush: Brush,
    /// Its radius, as a fraction of the model's bounding-box diagonal.
    pub radius: f32,
    /// Its strength, 0..1.
    pub strength: f32,
    /// Bumped by every dab: the renderer uploads the shape again when it changes.
    pub version: u64,
    /// Dabs applied so far.
    pub dabs: u32,
    /// Tells this sculpt from the ones before it (with `version`, what the renderer shows).
    pub id: u64,
    /// The skinning method before the sculpt (Cancel goes back to it).
    pub previous: SkinningMethod,
}

/// The next sculpt's [`SculptState::id`].
static NEXT_SCULPT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

impl SculptState {
    /// The shape as the renderer draws it.
    pub fn mesh(&self, asset: &kloub_core::asset::Asset) -> crate::render::SculptMesh {
        let s = &self.sculpt;
        let mesh = asset.meshes.get(s.mesh as usize);
        let primitives = (s.primitives.iter())
            .map(|p| {
                let has_normals =
                    mesh.and_then(|m| m.primitives.get(p.primitive)).is_some_and(|x| !x.normals.is_empty());
                (p.primitive, p.positions.clone(), if has_normals { p.normals.clone() } else { Vec::new() })
            })
            .collect();
        crate::render::SculptMesh { node: s.node, primitives }
    }
}

impl Model {
    /// Enters or leaves pose mode. Entering stops the clip where it is (remembering whether it
    /// played), ends a ragdoll and shows the skeleton's joints to click (IK goals rest while
    /// posing); leaving plays again if it played and drops an unfinished sculpt.
    pub fn set_pose_mode(&mut self, on: bool) {
        if on == self.pose_mode {
            return;
        }
        self.pose_mode = on;
        if on {
            self.resume_playing = self.is_playing();
            self.set_playing(false);
            // Posing starts from the animation's pose: a ragdoll lets go of the skeleton.
            self.ragdoll = None;
        } else {
            self.sculpt = None;
            if self.resume_playing {
                self.set_playing(true);
            }
        }
    }

    /// The model's size (bounding-box diagonal), 1 when unknown.
    pub fn size(&self) -> f32 {
        self.bounds.map_or(1.0, |(lo, hi)| (hi - lo).length()).max(1e-6)
    }

    /// Starts sculpting an example pose of joint node `joint` at its rotation on screen: the
    /// model is shown in that example pose (see the module docs) and the brushes move the
    /// joint's support. Enters pose mode. Nothing changes on error. `previous` is the skinning
    /// method to go back to on Cancel (the stage then shows SJB by example).
    ///
    /// # Errors
    /// A sculpt under way, no skinned mesh with that joint, a joint without a unique name (the
    /// sidecar names joints), without a parent joint or whose bone has no single child, a
    /// rotation that leaves the bone where it is at rest or where another example has it, a
    /// joint sharing its parent with a joint that has examples, already
    /// [`kloub_core::job::sjbbe::MAX_EXAMPLES`] examples for it.
    pub fn start_sculpt(&mut self, joint: u32, previous: SkinningMethod) -> Result<(), String> {
        let name = self.node_name(joint);
        if let Some(state) = &self.sculpt {
            return Err(format!(
                "{name}: finish or cancel the example pose of {} first",
                self.node_name(state.sculpt.joint)
            ));
        }
        let named = self.asset.nodes.get(joint as usize).and_then(|n| n.name.as_deref());
        match named {
            None => return Err(format!("{name}: the sidecar names joints, and this one has no name")),
            Some(n) if self.asset.nodes.iter().filter(|x| x.name.as_deref() == Some(n)).count() > 1 => {
                return Err(format!("{name}: the sidecar names joints, and another node has this name"));
            }
            Some(_) => {}
        }
        let rotation = self
            .instance
            .pose()
            .locals
            .get(joint as usize)
            .map(|l| l.rotation.normalize())
            .ok_or_else(|| format!("node {joint} does not exist"))?;
        let count = self.examples.as_ref().map_or(0, |(e, _)| e.poses.iter().filter(|p| p.node == joint).count());
        if count >= kloub_core::job::sjbbe::MAX_EXAMPLES {
            return Err(format!(
                "{name} has {count} example poses, the most a joint may have; delete one to add another"
            ));
        }
        let (node, skin) = (0..self.asset.nodes.len() as u32)
            .find_map(|n| {
                let node = &self.asset.nodes[n as usize];
                let skin = node.skin?;
                let joints = &self.asset.skins.get(skin as usize)?.joints;
                (node.mesh.is_some() && joints.contains(&joint)).then_some((n, skin as usize))
            })
            .ok_or_else(|| format!("{name}: no skinned mesh follows this joint"))?;
        // Shown where the model stands: the bind pose placed by the mesh node's world (a Z-up
        // file's root turn included).
        let placement = self.instance.worlds().get(node as usize).copied().unwrap_or(glam::Mat4::IDENTITY);
        let locals = kloub_core::sculpt::example_pose_locals(
            &self.asset,
            self.instance.pose(),
            skin,
            joint,
            rotation,
            placement,
        )
        .map_err(|e| format!("{name}: {e}"))?;
        // The surface to start from: SJB by example (the examples already made shape it), the
        // file's own morph targets at rest (an example's offsets are added before them).
        let mut instance = self.instance.clone();
        instance.set_skinning(&self.asset, SkinningMethod::SphericalJointBlendByExample);
        instance.pose_mut().weights.fill(0.0);
        for &(n, t) in &locals {
            if let Some(local) = instance.pose_mut().locals.get_mut(n as usize) {
                *local = t;
            }
        }
        instance.update(&self.asset).map_err(|e| e.to_string())?;
        if let Some((_, targets)) = &mut self.examples {
            targets.write_weights(&mut instance, true).map_err(|e| e.to_string())?;
        }
        let sculpt = Sculpt::start(&self.asset, &mut instance, node, joint, rotation, placement)
            .map_err(|e| format!("{name}: {e}"))?;
        // Refused now rather than at "Done": the examples with this one must make a rig (a bone
        // the rotation leaves where it is at rest or where another example has it, a joint
        // sharing its parent with one that has examples).
        let probe = self.examples_with(&sculpt)?;
        Instance::new(&self.base_asset).set_examples(&self.base_asset, &probe).map_err(|e| format!("{name}: {e}"))?;
        self.instance.set_skinning(&self.asset, SkinningMethod::SphericalJointBlendByExample);
        self.set_pose_mode(true);
        self.selected_joint = Some(joint);
        self.sculpt = Some(SculptState {
            sculpt,
            locals,
            brush: Brush::Inflate,
            radius: DEFAULT_RADIUS,
            strength: DEFAULT_STRENGTH,
            version: 1,
            dabs: 0,
            id: NEXT_SCULPT.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            previous,
        });
        Ok(())
    }

    /// One dab of the sculpt's brush at `center` (model space); `drag` is the pointer's move
    /// for the grab brush.
    pub fn sculpt_dab(&mut self, center: glam::Vec3, drag: glam::Vec3) {
        let size = self.size();
        let Some(state) = &mut self.sculpt else { return };
        let dab = Dab { brush: state.brush, center, radius: state.radius * size, strength: state.strength, drag };
        if state.sculpt.dab(&dab) > 0 {
            state.version += 1;
            state.dabs += 1;
        }
    }

    /// The examples with the sculpted one added (for [`crate::stage::Stage::set_examples`],
    /// which shows the model again with them and so ends the sculpt; on error it stays).
    ///
    /// # Errors
    /// No sculpt, or the shape cannot be taken back to the reference pose.
    pub fn finish_sculpt(&self) -> Result<Examples, String> {
        let state = self.sculpt.as_ref().ok_or("no example pose is being sculpted")?;
        self.examples_with(&state.sculpt)
    }

    /// The model's examples and `sculpt`'s shape as one more.
    fn examples_with(&self, sculpt: &Sculpt) -> Result<Examples, String> {
        let name = self.node_name(sculpt.joint);
        let shape = sculpt.finish(&self.base_asset).map_err(|e| format!("{name}: {e}"))?;
        let mut next = self.examples.as_ref().map(|(e, _)| e.clone()).unwrap_or_default();
        let index = next.poses.iter().filter(|p| p.node == sculpt.joint).count();
        next.poses.push(JointExample {
            node: sculpt.joint,
            mesh: sculpt.mesh,
            rotation: sculpt.rotation,
            shape,
            pointer: format!("/examples/{}/{index}", kloub_core::rig::escape(&name)),
        });
        Ok(next)
    }

    /// The examples without example `index` (in [`Examples::poses`]' order).
    ///
    /// # Errors
    /// No such example.
    pub fn without_example(&self, index: usize) -> Result<Examples, String> {
        let mut next = self.examples.as_ref().map(|(e, _)| e.clone()).ok_or("the model has no example poses")?;
        if index >= next.poses.len() {
            return Err(format!("example {index} does not exist ({} examples)", next.poses.len()));
        }
        next.poses.remove(index);
        // Pointers follow the sidecar's order again (each joint's list renumbered).
        let mut seen: Vec<(u32, usize)> = Vec::new();
        for p in &mut next.poses {
            let i = match seen.iter_mut().find(|(n, _)| *n == p.node) {
                Some((_, i)) => {
                    *i += 1;
                    *i
                }
                None => {
                    seen.push((p.node, 0));
                    0
                }
            };
            let name = self.node_name(p.node);
            p.pointer = format!("/examples/{}/{i}", kloub_core::rig::escape(&name));
        }
        next.sigma.retain(|(n, _)| next.poses.iter().any(|p| p.node == *n));
        Ok(next)
    }

    /// `dataset.mode`: `"animate"`, `"pose"`, or `"sculpt"` while an example pose is sculpted.
    pub fn mode_name(&self) -> &'static str {
        match (self.pose_mode, self.sculpt.is_some()) {
            (_, true) => "sculpt",
            (true, false) => "pose",
            (false, false) => "animate",
        }
    }
}

/// The brush named `name` ([`Brush::name`]).
///
/// # Errors
/// A message listing the names.
pub fn brush_named(name: &str) -> Result<Brush, String> {
    Brush::ALL
        .into_iter()
        .find(|b| b.name() == name)
        .ok_or_else(|| format!("brush {name:?}: expected \"inflate\", \"deflate\", \"smooth\" or \"grab\""))
}
