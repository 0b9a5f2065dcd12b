//! Inverse kinematics in the viewer: end effectors dragged towards their targets, solved every
//! frame on top of the animation with kloub_core's [`IkJob`].

use glam::{Mat4, Vec3};
use kloub_core::Instance;
use kloub_core::asset::{Asset, NodeIndex};
use kloub_core::job::ik::{IkChain, IkGoal, IkJob, IkReport, IkSettings, IkSolver, JointLimit, MAX_GOALS};
use kloub_core::math::Transform;
use kloub_core::rig::JointSettings;

/// The IK goal of the shown model.
#[derive(Clone, Debug)]
pub struct IkState {
    /// The chain (effector last).
    pub chain: IkChain,
    /// The solver.
    pub solver: IkSolver,
    /// Most iterations per frame.
    pub iterations: u32,
    /// CCD: a pattern move after each sweep ([`IkSettings::accelerate`]).
    pub accelerate: bool,
    /// Two-bone: soft reach ([`IkSettings::softness`]).
    pub softness: f32,
    /// Two-bone: the middle joint bends towards this point (model space, like the target).
    pub pole: Option<Vec3>,
    /// World-space target.
    pub target: Vec3,
    /// How the last solve ended.
    pub report: IkReport,
    parents: Vec<Option<NodeIndex>>,
    rest: Vec<Transform>,
    /// World positions of the chain joints after the last solve (for the overlay).
    pub joints: Vec<Vec3>,
    /// Limits of the rotating joints, root first (inferred from humanoid joint names).
    pub limits: Vec<JointLimit>,
    /// Whether the solve respects [`IkState::limits`].
    pub use_limits: bool,
    /// Stiffness of the rotating joints, root first.
    pub stiffness: Vec<f32>,
    /// How much of the solve is applied over the animated pose (0: the animation, 1: the
    /// solved pose).
    pub weight: f32,
}

impl IkState {
    /// A goal for `effector` with `depth` rotating joints above it, aiming at `target` (default:
    /// where the effector is in `instance`'s current pose, so nothing jumps).
    ///
    /// # Errors
    /// An effector or depth the hierarchy does not have.
    pub fn new(
        asset: &Asset,
        instance: &Instance,
        settings: &JointSettings,
        effector: NodeIndex,
        depth: usize,
        target: Option<Vec3>,
    ) -> Result<Self, String> {
        let parents: Vec<Option<NodeIndex>> = asset.nodes.iter().map(|n| n.parent).collect();
        let chain = IkChain::new(&parents, effector, depth).map_err(|e| e.to_string())?;
        let here = instance.worlds().get(effector as usize).map_or(Vec3::ZERO, |w| w.w_axis.truncate());
        let solver = IkSolver::Ccd;
        let (limits, stiffness) = settings.chain(&chain);
        Ok(Self {
            stiffness,
            limits,
            use_limits: true,
            joints: chain.joints().iter().map(|&j| position(instance.worlds(), j)).collect(),
            chain,
            solver,
            iterations: 32,
            accelerate: true,
            softness: 0.0,
            pole: None,
            weight: 1.0,
            target: target.unwrap_or(here),
            report: IkReport::default(),
            parents,
            rest: asset.nodes.iter().map(|n| n.rest).collect(),
        })
    }

    /// Takes the chain's limits and stiffness from the model's joint settings.
    pub fn use_settings(&mut self, settings: &JointSettings) {
        (self.limits, self.stiffness) = settings.chain(&self.chain);
    }

    /// Where each rotating joint's limit lies in the world, root first, for drawing: the
    /// joint's position, the rotation of its rest frame (parent world × rest rotation), and
    /// the bone to the next chain joint in that frame (the child's rest offset).
    pub fn limit_frames(&self, worlds: &[Mat4]) -> Vec<(Vec3, glam::Quat, Vec3)> {
        let joints = self.chain.joints();
        joints[..self.chain.depth()]
            .iter()
            .zip(&joints[1..])
            .map(|(&j, &child)| {
                let parent = self.parents.get(j as usize).copied().flatten();
                let parent_rotation = parent
                    .and_then(|p| worlds.get(p as usize))
                    .map_or(glam::Quat::IDENTITY, |w| w.to_scale_rotation_translation().1);
                let rest = self.rest.get(j as usize).map_or(glam::Quat::IDENTITY, |t| t.rotation);
                let bone = self.rest.get(child as usize).map_or(Vec3::ZERO, |t| t.translation);
                let length = position(worlds, j).distance(position(worlds, child));
                let bone = bone.try_normalize().map_or(Vec3::ZERO, |d| d * length);
                (position(worlds, j), (parent_rotation * rest).normalize(), bone)
            })
            .collect()
    }

    /// The end effector.
    pub fn effector(&self) -> NodeIndex {
        self.chain.effector()
    }

    /// Rotating joints above the effector.
    pub fn depth(&self) -> usize {
        self.chain.depth()
    }

    /// The solver settings of this goal's job.
    fn settings(&self) -> IkSettings {
        IkSettings {
            solver: self.solver,
            iterations: self.iterations,
            tolerance: 1e-5,
            weight: self.weight.clamp(0.0, 1.0),
            accelerate: self.accelerate,
            softness: self.softness.clamp(0.0, 0.5),
        }
    }

    /// The goal as the job takes it.
    fn goal(&self) -> IkGoal<'_> {
        let limits: &[JointLimit] = if self.use_limits { &self.limits } else { &[] };
        IkGoal { chain: &self.chain, target: self.target, stiffness: &self.stiffness, limits, pole: self.active_pole() }
    }

    /// The pole, when the solver uses one (two-bone): shown and draggable only then.
    pub fn active_pole(&self) -> Option<Vec3> {
        self.pole.filter(|_| self.solver == IkSolver::TwoBone)
    }

    /// A pole that keeps the current bend: from the middle joint of the chain (after the last
    /// solve) away from the line between its ends, half the chain's length out; straight
    /// chains get one perpendicular to the line.
    pub fn default_pole(&self) -> Vec3 {
        let (Some(&root), Some(&tip)) = (self.joints.first(), self.joints.last()) else { return self.target };
        let middle = self.joints.get(self.joints.len() / 2).copied().unwrap_or(root);
        let length: f32 = self.joints.windows(2).map(|w| w[0].distance(w[1])).sum();
        let line = (tip - root).try_normalize().unwrap_or(Vec3::Y);
        let off = (middle - root) - line * (middle - root).dot(line);
        let out = off.try_normalize().unwrap_or_else(|| line.any_orthonormal_vector());
        middle + out * (0.5 * length).max(1e-3)
    }
}

/// Solves every goal on `instance`'s pose (already evaluated for this frame), then updates
/// its worlds and palettes once. Goals with the same settings are solved together, up to
/// [`MAX_GOALS`] per job: CCD sweeps them in turn, so chains sharing joints (two hands
/// reaching down to the spine) settle on a pose that serves both instead of the last goal
/// undoing the first.
///
/// # Errors
/// A job error (a goal the job rejects, e.g. two-bone on a chain that is not depth 2).
pub fn apply_all(states: &mut [IkState], asset: &Asset, instance: &mut Instance) -> Result<(), String> {
    if states.is_empty() {
        return Ok(());
    }
    for i in 0..states.len() {
        let settings = states[i].settings();
        // Goals with these settings, in order, go in runs of MAX_GOALS: each run starts at the
        // goal whose rank among them is a multiple of MAX_GOALS (without allocating per frame).
        let rank = states[..i].iter().filter(|s| s.settings() == settings).count();
        if rank % MAX_GOALS != 0 {
            continue;
        }
        let mut group = [i; MAX_GOALS];
        let mut goals = [states[i].goal(); MAX_GOALS];
        let mut n = 0;
        for k in (i..states.len()).filter(|&k| states[k].settings() == settings).take(MAX_GOALS) {
            (group[n], goals[n]) = (k, states[k].goal());
            n += 1;
        }
        let mut reports = [IkReport::default(); MAX_GOALS];
        // Every state of a model holds the same hierarchy.
        IkJob {
            parents: &states[i].parents,
            rest: &states[i].rest,
            locals: &mut instance.pose_mut().locals,
            goals: &goals[..n],
            settings,
            reports: &mut reports[..n],
        }
        .run()
        .map_err(|e| e.to_string())?;
        for (report, &k) in reports[..n].iter().zip(&group[..n]) {
            states[k].report = *report;
        }
    }
    instance.update(asset).map_err(|e| e.to_string())?;
    for state in states.iter_mut() {
        for (p, &j) in state.joints.iter_mut().zip(state.chain.joints()) {
            *p = position(instance.worlds(), j);
        }
    }
    Ok(())
}

fn position(worlds: &[Mat4], node: NodeIndex) -> Vec3 {
    worlds.get(node as usize).map_or(Vec3::ZERO, |w| w.w_axis.truncate())
}

/// Effectors worth offering, best first: joints named like hands, then feet, else the
/// deepest joint of the skins; each with the depth its hierarchy allows (up to 2).
pub fn default_effectors(asset: &Asset) -> Vec<(NodeIndex, usize)> {
    let joints: Vec<NodeIndex> = asset.skins.iter().flat_map(|s| s.joints.iter().copied()).collect();
    let names: Vec<String> = joints
        .iter()
        .map(|&j| asset.nodes.get(j as usize).and_then(|n| n.name.as_deref()).unwrap_or("").to_ascii_lowercase())
        .collect();
    let mut out: Vec<NodeIndex> = Vec::new();
    for keys in [
        &["hand", "wrist", "lowerarm", "arm_joint_l_3", "arm_joint_r_3"][..],
        &["foot", "ankle", "leg_joint_l_5", "leg_joint_r_5"][..],
    ] {
        for (&j, name) in joints.iter().zip(&names) {
            if keys.iter().any(|k| name.contains(k)) && !out.contains(&j) {
                out.push(j);
            }
        }
    }
    if out.is_empty()
        && let Some(deepest) = joints.iter().copied().max_by_key(|&j| ancestors(asset, j))
    {
        out.push(deepest);
    }
    out.into_iter().map(|j| (j, ancestors(asset, j).min(2))).filter(|&(_, depth)| depth >= 1).collect()
}

/// Number of ancestors of `node` (its depth in the node forest).
pub fn ancestors(asset: &Asset, node: NodeIndex) -> usize {
    let mut count = 0;
    let mut parent = asset.nodes.get(node as usize).and_then(|n| n.parent);
    // The importer guarantees a forest; the bound only guards a hand-made asset.
    while let Some(n) = parent
        && count < asset.nodes.len()
    {
        count += 1;
        parent = asset.nodes.get(n as usize).and_then(|n| n.parent);
    }
    count
}
