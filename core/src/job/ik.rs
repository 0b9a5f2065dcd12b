//! Inverse kinematics on a pose's local transforms, run after blending: cyclic coordinate
//! descent exactly as seed 000 §3.3.1 (eqs. 3.21–3.24: leaf to root, a stiffness η per joint,
//! several end effectors in one solve) and the analytic two-bone solution with a pole vector,
//! both respecting per-joint limits (hinge, ball) expressed in each joint's rest frame.
//!
//! A chain ([`IkChain`]) is an end effector and the `depth` joints above it; only those
//! `depth` joints rotate (the effector's own rotation does not move its origin). World
//! transforms are recomputed from the locals and the node parents as the solver goes, so
//! chains that share ancestors (two arms under one spine) see each other's changes.
//! [`IkJob`] allocates nothing: its scratch lives on the stack, chains are at most
//! [`MAX_CHAIN`] joints.

use super::check_index;
use crate::asset::NodeIndex;
use crate::error::JobError;
use crate::math::{Mat3, Mat4, Quat, Transform, Vec3};

/// Most joints in one chain (effector included).
pub const MAX_CHAIN: usize = 32;

/// Most goals one job solves together.
pub const MAX_GOALS: usize = 8;

/// Deepest node hierarchy the solver walks up to find a chain's parent transform.
const MAX_DEPTH: usize = 1024;

/// An end effector and the joints above it that move to reach a target.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IkChain {
    joints: Vec<NodeIndex>,
}

impl IkChain {
    /// The chain ending at `effector` with the `depth` ancestors above it (`depth ≥ 1`; at most
    /// [`MAX_CHAIN`] − 1), root first.
    ///
    /// # Errors
    /// An effector outside `parents`, a depth of 0, too deep, or deeper than the hierarchy.
    pub fn new(parents: &[Option<NodeIndex>], effector: NodeIndex, depth: usize) -> Result<Self, JobError> {
        check_index("effector", effector as usize, parents.len())?;
        if depth == 0 || depth >= MAX_CHAIN {
            return Err(JobError::InvalidInput(format!("chain depth {depth}: expected 1 to {}", MAX_CHAIN - 1)));
        }
        let mut joints = vec![effector];
        let mut node = effector;
        for _ in 0..depth {
            let Some(parent) = parents.get(node as usize).copied().flatten() else {
                return Err(JobError::InvalidInput(format!(
                    "node {effector} has only {} ancestors, chain depth {depth} asked",
                    joints.len() - 1
                )));
            };
            check_index("parent", parent as usize, parents.len())?;
            joints.push(parent);
            node = parent;
        }
        joints.reverse();
        Ok(Self { joints })
    }

    /// The joints, root first, the end effector last.
    pub fn joints(&self) -> &[NodeIndex] {
        &self.joints
    }

    /// The end effector.
    pub fn effector(&self) -> NodeIndex {
        self.joints[self.joints.len() - 1]
    }

    /// Number of joints that rotate (all but the effector).
    pub fn depth(&self) -> usize {
        self.joints.len() - 1
    }
}

/// How far a joint may turn from its rest rotation, in its rest frame (the parent's space
/// rotated by the rest rotation).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum JointLimit {
    /// Any rotation.
    #[default]
    Free,
    /// One degree of freedom about `axis` (unit, rest frame), between `min` and `max` radians.
    Hinge {
        /// Rotation axis.
        axis: Vec3,
        /// Smallest angle.
        min: f32,
        /// Largest angle.
        max: f32,
    },
    /// Swing of `axis` (the bone direction, unit, rest frame) within a cone of half-angle
    /// `swing` radians, and twist about it between `twist_min` and `twist_max`.
    Ball {
        /// The bone direction.
        axis: Vec3,
        /// Cone half-angle.
        swing: f32,
        /// Smallest twist.
        twist_min: f32,
        /// Largest twist.
        twist_max: f32,
    },
}

impl JointLimit {
    /// `rotation` (a local rotation) moved to the nearest allowed one, for a joint whose rest
    /// rotation is `rest`.
    pub fn clamp(&self, rest: Quat, rotation: Quat) -> Quat {
        let relative = (rest.conjugate() * rotation).normalize();
        let limited = match *self {
            JointLimit::Free => return rotation,
            JointLimit::Hinge { axis, min, max } => {
                let angle = twist_angle(relative, axis);
                Quat::from_axis_angle(axis, angle.clamp(min, max))
            }
            JointLimit::Ball { axis, swing, twist_min, twist_max } => {
                let (swing_q, twist) = swing_twist(relative, axis);
                let twist = twist.clamp(twist_min, twist_max);
                let swing_angle = 2.0 * swing_q.w.clamp(-1.0, 1.0).acos();
                let swing_q = if swing_angle > swing {
                    let swing_axis = Vec3::new(swing_q.x, swing_q.y, swing_q.z).try_normalize().unwrap_or(Vec3::X);
                    Quat::from_axis_angle(swing_axis, swing)
                } else {
                    swing_q
                };
                swing_q * Quat::from_axis_angle(axis, twist)
            }
        };
        (rest * limited).normalize()
    }

    /// Whether `rotation` is within the limit (up to `tolerance` radians).
    pub fn allows(&self, rest: Quat, rotation: Quat, tolerance: f32) -> bool {
        let clamped = self.clamp(rest, rotation);
        // The angle of the difference from its sine and cosine: precise near 0, where
        // `acos` of a dot product loses ~1e-3 rad to f32 rounding.
        let difference = clamped.conjugate() * rotation;
        2.0 * Vec3::new(difference.x, difference.y, difference.z).length().atan2(difference.w.abs()) <= tolerance
    }
}

/// Elbows and knees: one degree of freedom about the joint's local X (the usual bend axis of
/// rigs exported from Blender and Maya, bones along local Y), up to 150° either way (the
/// sign of a bend differs between rigs).
const HINGE_RANGE: f32 = 150.0 * std::f32::consts::PI / 180.0;
/// Shoulders and hips: the bone may swing this far from its rest direction.
const BALL_SWING: f32 = 100.0 * std::f32::consts::PI / 180.0;
/// Shoulders and hips: twist about the bone, either way.
const BALL_TWIST: f32 = 80.0 * std::f32::consts::PI / 180.0;

/// The direction of `node`'s bone in its rest frame: towards its first child (`Y` for a leaf
/// or a child at its origin).
pub fn bone_axis(asset: &crate::Asset, node: &crate::asset::Node) -> Vec3 {
    node.children
        .first()
        .and_then(|&c| asset.nodes.get(c as usize))
        .and_then(|c| c.rest.translation.try_normalize())
        .unwrap_or(Vec3::Y)
}

/// Default limits for every node of `asset`, inferred from common humanoid joint names:
/// elbows and knees (`elbow`, `knee`, `forearm`, `lowerarm`, `shin`, `calf`, `lowerleg`, and
/// RiggedFigure's `arm_joint_*_2`/`leg_joint_*_2`) are hinges about local X; shoulders and hips
/// (`shoulder`, `upperarm`, `thigh`, `upleg`, a `hip` that is not the `hips` root,
/// `arm_joint_*_1`, `leg_joint_*_1`) are ball joints around the direction of their first child;
/// everything else is free.
pub fn humanoid_limits(asset: &crate::asset::Asset) -> Vec<JointLimit> {
    asset
        .nodes
        .iter()
        .map(|node| {
            let name: String = node
                .name
                .as_deref()
                .unwrap_or("")
                .to_ascii_lowercase()
                .chars()
                .filter(|c| *c != '_' && *c != '.')
                .collect();
            let has = |keys: &[&str]| keys.iter().any(|k| name.contains(k));
            let numbered =
                |prefix: &str, n: char| name.starts_with(prefix) && name.ends_with(n) && name.len() <= prefix.len() + 2;
            if has(&["elbow", "knee", "forearm", "lowerarm", "shin", "calf", "lowerleg"])
                || numbered("armjoint", '2')
                || numbered("legjoint", '2')
            {
                JointLimit::Hinge { axis: Vec3::X, min: -HINGE_RANGE, max: HINGE_RANGE }
            } else if has(&["shoulder", "upperarm", "thigh", "upleg"])
                || (name.contains("hip") && !name.contains("hips"))
                || numbered("armjoint", '1')
                || numbered("legjoint", '1')
            {
                let axis = bone_axis(asset, node);
                JointLimit::Ball { axis, swing: BALL_SWING, twist_min: -BALL_TWIST, twist_max: BALL_TWIST }
            } else {
                JointLimit::Free
            }
        })
        .collect()
}

/// The signed rotation angle of `q` about `axis` (its twist), in (−π, π].
fn twist_angle(q: Quat, axis: Vec3) -> f32 {
    let q = if q.w < 0.0 { -q } else { q };
    2.0 * Vec3::new(q.x, q.y, q.z).dot(axis).atan2(q.w)
}

/// `q = swing · twist(axis)`: the swing (moves `axis`) and the twist angle about `axis`.
fn swing_twist(q: Quat, axis: Vec3) -> (Quat, f32) {
    let twist = twist_angle(q, axis);
    let swing = (q * Quat::from_axis_angle(axis, -twist)).normalize();
    let swing = if swing.w < 0.0 { -swing } else { swing };
    (swing, twist)
}

/// The solver of an [`IkJob`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum IkSolver {
    /// Cyclic coordinate descent (seed 000 eqs. 3.21–3.24), any chain length, several goals.
    #[default]
    Ccd,
    /// The analytic two-bone solution (chains of depth 2: e.g. shoulder, elbow, wrist) with an
    /// optional pole vector bending the middle joint towards it.
    TwoBone,
    /// FABRIK (Aristidou & Lasenby 2011): joint positions moved back and forth along the
    /// chain, then turned into rotations (shortest arc per joint, limits applied). Converges
    /// in a few iterations where CCD is slow (near full reach); ignores stiffness.
    Fabrik,
    /// Damped least squares on the positional Jacobian (Buss 2004): every rotating joint
    /// turns at once by `Jᵀ (J Jᵀ + λ² I)⁻¹ e` (3 rotational degrees of freedom per joint,
    /// λ and the step scaled to the chain's length), stiffness scaling each joint's share.
    Dls,
}

impl IkSolver {
    /// Every solver.
    pub const ALL: [IkSolver; 4] = [IkSolver::Ccd, IkSolver::TwoBone, IkSolver::Fabrik, IkSolver::Dls];

    /// The name `kloub ik --solver` uses.
    pub fn name(self) -> &'static str {
        match self {
            IkSolver::Ccd => "ccd",
            IkSolver::TwoBone => "twobone",
            IkSolver::Fabrik => "fabrik",
            IkSolver::Dls => "dls",
        }
    }
}

/// One end effector to bring to a target.
#[derive(Clone, Copy, Debug)]
pub struct IkGoal<'a> {
    /// The chain.
    pub chain: &'a IkChain,
    /// Where the effector should be, in world space.
    pub target: Vec3,
    /// Stiffness η per rotating joint, root first (seed 000 eq. 3.23: the CCD step is scaled
    /// by η; 0 never moves, 1 turns fully). Empty: 1 for all.
    pub stiffness: &'a [f32],
    /// Limits per rotating joint, root first. Empty: all free.
    pub limits: &'a [JointLimit],
    /// Two-bone only: the middle joint bends towards this world point.
    pub pole: Option<Vec3>,
}

/// Solver settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkSettings {
    /// The solver.
    pub solver: IkSolver,
    /// Most CCD sweeps over all goals.
    pub iterations: u32,
    /// A goal is reached within this distance (world units).
    pub tolerance: f32,
    /// 1 applies the solution, 0 keeps the animated pose; in between rotations are slerped.
    pub weight: f32,
    /// CCD only: after each sweep, a Hooke–Jeeves pattern move extrapolates the turn the sweep
    /// made (×1, ×2, ×4, … while the error keeps falling). The sweep itself stays seed 000's;
    /// near full reach, where plain CCD creeps (its first-order step vanishes), this is what
    /// makes it converge in a few sweeps. `false`: plain CCD.
    pub accelerate: bool,
    /// Two-bone only: soft reach (Jones' "soft IK"). The last `softness` × chain length of the
    /// reach is approached asymptotically, so the middle joint eases into full extension instead
    /// of snapping straight as the target passes it; the effector stops short of targets in that
    /// band. 0: hard reach. In [0, 1).
    pub softness: f32,
}

impl Default for IkSettings {
    fn default() -> Self {
        Self { solver: IkSolver::Ccd, iterations: 32, tolerance: 1e-4, weight: 1.0, accelerate: true, softness: 0.0 }
    }
}

/// How a goal ended.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IkReport {
    /// Distance from the effector to the target after the solve.
    pub error: f32,
    /// Sweeps used (CCD), 1 for two-bone.
    pub iterations: u32,
}

/// Rotates chain joints of `locals` so each goal's effector reaches its target.
#[derive(Debug)]
pub struct IkJob<'a> {
    /// Parent of every node.
    pub parents: &'a [Option<NodeIndex>],
    /// Rest local transforms (limits are relative to their rotations).
    pub rest: &'a [Transform],
    /// The pose: read, and the chains' rotations written.
    pub locals: &'a mut [Transform],
    /// The goals, solved together.
    pub goals: &'a [IkGoal<'a>],
    /// Solver settings.
    pub settings: IkSettings,
    /// One report per goal.
    pub reports: &'a mut [IkReport],
}

impl IkJob<'_> {
    /// Checks lengths, chain joints, stiffness and limit counts, finite targets and settings.
    pub fn validate(&self) -> Result<(), JobError> {
        let n = self.parents.len();
        super::check_eq("rest", n, self.rest.len())?;
        super::check_eq("locals", n, self.locals.len())?;
        super::check_len("reports", self.goals.len(), self.reports.len())?;
        if self.goals.len() > MAX_GOALS {
            return Err(JobError::InvalidInput(format!("{} goals: at most {MAX_GOALS}", self.goals.len())));
        }
        let s = &self.settings;
        if !(s.tolerance.is_finite() && s.tolerance >= 0.0 && s.weight.is_finite()) {
            return Err(JobError::InvalidInput("tolerance and weight must be finite, tolerance ≥ 0".into()));
        }
        if !(0.0..1.0).contains(&s.softness) {
            return Err(JobError::InvalidInput(format!("softness {} is not in [0, 1)", s.softness)));
        }
        for (g, goal) in self.goals.iter().enumerate() {
            let joints = goal.chain.joints();
            if joints.len() < 2 || joints.len() > MAX_CHAIN {
                return Err(JobError::InvalidInput(format!("goal {g}: chain of {} joints", joints.len())));
            }
            for (k, &j) in joints.iter().enumerate() {
                check_index("chain joint", j as usize, n)?;
                if k > 0 && self.parents[j as usize] != Some(joints[k - 1]) {
                    return Err(JobError::InvalidInput(format!(
                        "goal {g}: chain joint {j} is not a child of the previous"
                    )));
                }
            }
            let depth = goal.chain.depth();
            if !goal.stiffness.is_empty() {
                super::check_eq("stiffness", depth, goal.stiffness.len())?;
            }
            if !goal.limits.is_empty() {
                super::check_eq("limits", depth, goal.limits.len())?;
            }
            if !goal.target.is_finite() || goal.pole.is_some_and(|p| !p.is_finite()) {
                return Err(JobError::InvalidInput(format!("goal {g}: target and pole must be finite")));
            }
            if goal.stiffness.iter().any(|eta| !(eta.is_finite() && (0.0..=1.0).contains(eta))) {
                return Err(JobError::InvalidInput(format!("goal {g}: stiffness must be in [0, 1]")));
            }
            if s.solver == IkSolver::TwoBone && depth != 2 {
                return Err(JobError::InvalidInput(format!(
                    "goal {g}: two-bone needs a chain of depth 2, not {depth}"
                )));
            }
        }
        Ok(())
    }

    /// Validates, then solves. The animated rotations are kept per goal and blended back by
    /// `settings.weight`.
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        // The animated rotations, kept only when they are blended back in.
        let weight = self.settings.weight.clamp(0.0, 1.0);
        let mut original = [[Quat::IDENTITY; MAX_CHAIN]; MAX_GOALS];
        if weight < 1.0 {
            for (g, goal) in self.goals.iter().enumerate() {
                for (k, &j) in goal.chain.joints().iter().enumerate() {
                    original[g][k] = self.locals[j as usize].rotation;
                }
            }
        }
        match self.settings.solver {
            IkSolver::Ccd => self.ccd(),
            IkSolver::TwoBone => {
                for (g, goal) in self.goals.iter().enumerate() {
                    self.reports[g] = two_bone(self.parents, self.rest, self.locals, goal, self.settings.softness);
                }
            }
            IkSolver::Fabrik => {
                for (g, goal) in self.goals.iter().enumerate() {
                    self.reports[g] = fabrik(self.parents, self.rest, self.locals, goal, &self.settings);
                }
            }
            IkSolver::Dls => {
                for (g, goal) in self.goals.iter().enumerate() {
                    self.reports[g] = dls(self.parents, self.rest, self.locals, goal, &self.settings);
                }
            }
        }
        if weight < 1.0 {
            for (g, goal) in self.goals.iter().enumerate() {
                for (k, &j) in goal.chain.joints().iter().enumerate() {
                    // A joint in several chains is blended once.
                    if self.goals[..g].iter().any(|earlier| earlier.chain.joints().contains(&j)) {
                        continue;
                    }
                    let local = &mut self.locals[j as usize];
                    local.rotation = original[g][k].slerp(local.rotation, weight).normalize();
                }
            }
            for (g, goal) in self.goals.iter().enumerate() {
                let mut worlds = [Mat4::IDENTITY; MAX_CHAIN];
                chain_worlds(self.parents, self.locals, goal.chain.joints(), &mut worlds);
                let effector = worlds[goal.chain.joints().len() - 1].w_axis.truncate();
                self.reports[g].error = effector.distance(goal.target);
            }
        }
        Ok(())
    }

    /// Seed 000 §3.3.1: sweep every goal's chain from the effector towards the root, turning
    /// each joint by η times the angle between (effector − joint) and (target − joint).
    fn ccd(&mut self) {
        let tolerance = self.settings.tolerance;
        let mut worlds = [Mat4::IDENTITY; MAX_CHAIN];
        let mut done = 0u32;
        let accelerate = self.settings.accelerate;
        // Every chain's rotations when the sweep starts: the pattern move extrapolates the turn
        // of the whole sweep (all goals), judged by the summed error.
        let mut previous = [[Quat::IDENTITY; MAX_CHAIN]; MAX_GOALS];
        for sweep in 0..self.settings.iterations {
            let mut all_reached = true;
            for (g, goal) in self.goals.iter().enumerate() {
                for (k, &j) in goal.chain.joints().iter().enumerate() {
                    previous[g][k] = self.locals[j as usize].rotation;
                }
            }
            for goal in self.goals {
                let joints = goal.chain.joints();
                let last = joints.len() - 1;
                chain_worlds(self.parents, self.locals, joints, &mut worlds);
                if worlds[last].w_axis.truncate().distance(goal.target) <= tolerance {
                    continue;
                }
                all_reached = false;
                for k in (0..last).rev() {
                    let pj = worlds[k].w_axis.truncate();
                    let pe = worlds[last].w_axis.truncate();
                    // (3.21)
                    let (Some(v1), Some(v2)) = ((pe - pj).try_normalize(), (goal.target - pj).try_normalize()) else {
                        continue;
                    };
                    // (3.22): the axis; (3.23): the angle, scaled by the stiffness. The angle is
                    // atan2(|v1×v2|, v1·v2), which equals asin(|v1×v2|) up to 90° and stays right
                    // beyond it.
                    let axis = v1.cross(v2);
                    let sin = axis.length();
                    if sin < 1e-9 {
                        continue;
                    }
                    let eta = goal.stiffness.get(k).copied().unwrap_or(1.0);
                    let angle = sin.atan2(v1.dot(v2)) * eta;
                    if angle == 0.0 {
                        continue;
                    }
                    // (3.24), applied in world space about the joint.
                    let turn = Quat::from_axis_angle(axis / sin, angle);
                    let parent =
                        if k == 0 { parent_world(self.parents, self.locals, joints[0]) } else { worlds[k - 1] };
                    rotate_joint(self.locals, self.rest, joints[k], goal.limits.get(k), &parent, turn);
                    update_from(self.locals, joints, k, &parent, &mut worlds);
                }
            }
            if accelerate && !all_reached {
                pattern_move(self.parents, self.rest, self.locals, self.goals, &previous, &mut worlds);
            }
            done = sweep + 1;
            if all_reached {
                done = sweep;
                break;
            }
        }
        for (g, goal) in self.goals.iter().enumerate() {
            chain_worlds(self.parents, self.locals, goal.chain.joints(), &mut worlds);
            let effector = worlds[goal.chain.joints().len() - 1].w_axis.truncate();
            self.reports[g] = IkReport { error: effector.distance(goal.target), iterations: done };
        }
    }
}

/// Hooke–Jeeves pattern move after a CCD sweep over `goals`: the sweep turned each rotating
/// joint by Δ (from `previous` to now, in its parent's frame); Δ^s is tried on top for s = 1,
/// 2, 4, … (at most 32) while the summed error of the goals keeps falling, limits applied, and
/// the best kept. A joint in several chains moves once (with the first chain's limit); a joint
/// any goal holds still (η = 0) stays.
fn pattern_move(
    parents: &[Option<NodeIndex>],
    rest: &[Transform],
    locals: &mut [Transform],
    goals: &[IkGoal<'_>],
    previous: &[[Quat; MAX_CHAIN]; MAX_GOALS],
    worlds: &mut [Mat4; MAX_CHAIN],
) {
    let mut swept = [[Quat::IDENTITY; MAX_CHAIN]; MAX_GOALS];
    // The turn to extrapolate per joint; `None` for a joint this goal does not move.
    let mut delta = [[None::<(Vec3, f32)>; MAX_CHAIN]; MAX_GOALS];
    for (g, goal) in goals.iter().enumerate() {
        for (k, &j) in rotating(goal).iter().enumerate() {
            swept[g][k] = locals[j as usize].rotation;
            let first = !goals[..g].iter().any(|earlier| rotating(earlier).contains(&j));
            let frozen = goals.iter().any(|other| {
                rotating(other).iter().position(|&x| x == j).is_some_and(|i| other.stiffness.get(i) == Some(&0.0))
            });
            if first && !frozen {
                let d = swept[g][k] * previous[g][k].conjugate();
                delta[g][k] = Some(if d.w < 0.0 { -d } else { d }.normalize().to_axis_angle());
            }
        }
    }
    // Every moving joint at `scale` times its sweep's turn beyond where the sweep left it.
    let extrapolate = |locals: &mut [Transform], scale: f32| {
        for (g, goal) in goals.iter().enumerate() {
            for (k, &j) in rotating(goal).iter().enumerate() {
                let Some((axis, angle)) = delta[g][k] else { continue };
                let mut rotated = swept[g][k];
                if scale != 0.0 && angle != 0.0 {
                    let turned = (Quat::from_axis_angle(axis, angle * scale) * swept[g][k]).normalize();
                    let turned = match goal.limits.get(k) {
                        Some(limit) => limit.clamp(rest[j as usize].rotation, turned),
                        None => turned,
                    };
                    if turned.is_finite() {
                        rotated = turned;
                    }
                }
                locals[j as usize].rotation = rotated;
            }
        }
    };
    let error = |locals: &[Transform], worlds: &mut [Mat4; MAX_CHAIN]| {
        goals
            .iter()
            .map(|goal| {
                let joints = goal.chain.joints();
                chain_worlds(parents, locals, joints, worlds);
                worlds[joints.len() - 1].w_axis.truncate().distance(goal.target)
            })
            .sum::<f32>()
    };
    let mut best = (0.0f32, error(locals, worlds));
    let mut scale = 1.0f32;
    while scale <= 32.0 {
        extrapolate(locals, scale);
        let e = error(locals, worlds);
        if e >= best.1 {
            break;
        }
        best = (scale, e);
        scale *= 2.0;
    }
    extrapolate(locals, best.0);
}

/// The joints of `goal`'s chain that turn (all but the effector).
fn rotating<'a>(goal: &IkGoal<'a>) -> &'a [NodeIndex] {
    let joints = goal.chain.joints();
    &joints[..joints.len() - 1]
}

/// The analytic two-bone solve of one goal (chain: upper, middle, effector).
fn two_bone(
    parents: &[Option<NodeIndex>],
    rest: &[Transform],
    locals: &mut [Transform],
    goal: &IkGoal<'_>,
    softness: f32,
) -> IkReport {
    let joints = goal.chain.joints();
    // Start from the middle joint on its limit (an animated pose may lie off a hinge).
    let middle = joints[1] as usize;
    if let Some(limit) = goal.limits.get(1) {
        locals[middle].rotation = limit.clamp(rest[middle].rotation, locals[middle].rotation);
    }
    let mut worlds = [Mat4::IDENTITY; MAX_CHAIN];
    chain_worlds(parents, locals, joints, &mut worlds);
    let (a, b, c) = (worlds[0].w_axis.truncate(), worlds[1].w_axis.truncate(), worlds[2].w_axis.truncate());
    let (l1, l2) = (a.distance(b), b.distance(c));
    let parent = parent_world(parents, locals, joints[0]);
    if l1 > 1e-9 && l2 > 1e-9 {
        let reach = soft_reach(goal.target.distance(a), l1 + l2, softness * (l1 + l2));
        let reach = reach.clamp((l1 - l2).abs() + 1e-6, l1 + l2 - 1e-6);
        // Bend the middle joint to the interior angle that makes |a − c| = reach.
        let current = (a - b).normalize_or_zero().dot((c - b).normalize_or_zero()).clamp(-1.0, 1.0).acos();
        let wanted = ((l1 * l1 + l2 * l2 - reach * reach) / (2.0 * l1 * l2)).clamp(-1.0, 1.0).acos();
        let bend_axis = (c - b).cross(a - b).try_normalize().or_else(|| {
            // Straight chain: bend towards the pole, else about any perpendicular.
            let pole = goal.pole.map(|p| p - a).unwrap_or(Vec3::Y);
            (c - a).cross(pole).try_normalize()
        });
        let turn = match goal.limits.get(1) {
            // A hinge turns about its own axis only: find the angle about it that gives the
            // reach (a bend about the plane's normal would be clamped off it).
            // Of the two angles, the one whose result within [min, max] comes closest.
            Some(&JointLimit::Hinge { axis: hinge, min, max }) => {
                let frame = rotation_of(&worlds[0]) * rest[middle].rotation;
                let h = (frame * hinge).normalize_or_zero();
                let theta =
                    twist_angle((rest[middle].rotation.conjugate() * locals[middle].rotation).normalize(), hinge);
                let (u, v) = (a - b, c - b);
                let miss = |phi: f32| ((u - Quat::from_axis_angle(h, phi) * v).length() - reach).abs();
                hinge_turn(u, v, h, reach).map(|roots| {
                    let [p, q] = roots.map(|phi| (theta + phi).clamp(min, max) - theta);
                    // Equally good (both within the limit): the smaller turn.
                    let (mp, mq) = (miss(p), miss(q));
                    let phi = if (mp - mq).abs() <= 1e-6 * (l1 + l2) {
                        if p.abs() <= q.abs() { p } else { q }
                    } else if mp < mq {
                        p
                    } else {
                        q
                    };
                    Quat::from_axis_angle(h, phi)
                })
            }
            // Opening the interior angle at b means rotating c away from a about `axis`.
            _ => bend_axis.map(|axis| Quat::from_axis_angle(axis, current - wanted)),
        };
        if let Some(turn) = turn {
            rotate_joint(locals, rest, joints[1], goal.limits.get(1), &worlds[0], turn);
        }
        // Swing the upper joint so the effector points at the target.
        let swing = |locals: &mut [Transform], worlds: &mut [Mat4; MAX_CHAIN]| {
            chain_worlds(parents, locals, joints, worlds);
            let c = worlds[2].w_axis.truncate();
            if let (Some(from), Some(to)) = ((c - a).try_normalize(), (goal.target - a).try_normalize()) {
                rotate_joint(locals, rest, joints[0], goal.limits.first(), &parent, Quat::from_rotation_arc(from, to));
            }
        };
        swing(locals, &mut worlds);
        // Turn the chain about the shoulder-target line so the middle joint faces the pole.
        if let Some(pole) = goal.pole {
            chain_worlds(parents, locals, joints, &mut worlds);
            let b = worlds[1].w_axis.truncate();
            if let Some(line) = (goal.target - a).try_normalize() {
                let off = |p: Vec3| (p - a) - line * (p - a).dot(line);
                if let (Some(from), Some(to)) = (off(b).try_normalize(), off(pole).try_normalize()) {
                    let angle = from.cross(to).dot(line).atan2(from.dot(to));
                    let turn = Quat::from_axis_angle(line, angle);
                    rotate_joint(locals, rest, joints[0], goal.limits.first(), &parent, turn);
                }
            }
            // A limit may have cut the turn short and taken the effector off the line: aim again.
            if !goal.limits.is_empty() {
                swing(locals, &mut worlds);
            }
        }
    }
    chain_worlds(parents, locals, joints, &mut worlds);
    IkReport { error: worlds[2].w_axis.truncate().distance(goal.target), iterations: 1 }
}

/// The angle to turn the bone `v` (middle joint → effector) about the unit axis `h` so the
/// effector ends `reach` from the root (`u`: middle joint → root): with `R v = v∥ + cos φ v⊥ +
/// sin φ (h × v)`, `|u − R v|² = reach²` is `B cos φ + C sin φ = K − A`: its two solutions in
/// (−π, π] (the closest reach when none is exact); `None` when turning about `h` cannot change
/// the reach.
fn hinge_turn(u: Vec3, v: Vec3, h: Vec3, reach: f32) -> Option<[f32; 2]> {
    if h == Vec3::ZERO {
        return None;
    }
    let parallel = h * h.dot(v);
    let (a, b, c) = (u.dot(parallel), u.dot(v - parallel), u.dot(h.cross(v)));
    let k = 0.5 * (u.length_squared() + v.length_squared() - reach * reach);
    let amplitude = b.hypot(c);
    if amplitude < 1e-9 {
        return None;
    }
    let delta = c.atan2(b);
    let spread = ((k - a) / amplitude).clamp(-1.0, 1.0).acos();
    let wrap = |x: f32| (x + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU) - std::f32::consts::PI;
    Some([wrap(delta + spread), wrap(delta - spread)])
}

/// The distance a chain of length `length` reaches towards a target `distance` away with a soft
/// band `soft` wide: unchanged up to `length − soft`, then `length − soft + soft·(1 − e^(−x/soft))`
/// for the `x` beyond it, approaching `length` without reaching it (continuous and smooth at
/// the band's start).
fn soft_reach(distance: f32, length: f32, soft: f32) -> f32 {
    let start = length - soft;
    if soft <= 0.0 || distance <= start {
        return distance;
    }
    start + soft * (1.0 - (-(distance - start) / soft).exp())
}

/// FABRIK on one goal: positions first, then rotations.
fn fabrik(
    parents: &[Option<NodeIndex>],
    rest: &[Transform],
    locals: &mut [Transform],
    goal: &IkGoal<'_>,
    settings: &IkSettings,
) -> IkReport {
    let joints = goal.chain.joints();
    let n = joints.len();
    let mut worlds = [Mat4::IDENTITY; MAX_CHAIN];
    chain_worlds(parents, locals, joints, &mut worlds);
    let mut p = [Vec3::ZERO; MAX_CHAIN];
    let mut d = [0.0f32; MAX_CHAIN];
    for k in 0..n {
        p[k] = worlds[k].w_axis.truncate();
    }
    for k in 0..n - 1 {
        d[k] = p[k].distance(p[k + 1]);
    }
    let (root, target) = (p[0], goal.target);
    let total: f32 = d[..n - 1].iter().sum();
    let mut iterations = 0;
    if root.distance(target) >= total {
        // Out of reach: straighten towards the target.
        let dir = (target - root).try_normalize().unwrap_or(Vec3::Y);
        for k in 1..n {
            p[k] = p[k - 1] + dir * d[k - 1];
        }
        iterations = 1;
    } else {
        let toward = |from: Vec3, to: Vec3, length: f32| {
            let gap = to.distance(from);
            if gap > 1e-12 { to + (from - to) * (length / gap) } else { from }
        };
        while iterations < settings.iterations && p[n - 1].distance(target) > settings.tolerance {
            // Backward: pin the effector on the target.
            p[n - 1] = target;
            for k in (0..n - 1).rev() {
                p[k] = toward(p[k], p[k + 1], d[k]);
            }
            // Forward: pin the root back.
            p[0] = root;
            for k in 0..n - 1 {
                p[k + 1] = toward(p[k + 1], p[k], d[k]);
            }
            iterations += 1;
        }
    }
    // Rotations: turn each joint, root first, so its child lands on the solved position.
    let parent = parent_world(parents, locals, joints[0]);
    for k in 0..n - 1 {
        chain_worlds(parents, locals, joints, &mut worlds);
        let (pk, child) = (worlds[k].w_axis.truncate(), worlds[k + 1].w_axis.truncate());
        if let (Some(from), Some(to)) = ((child - pk).try_normalize(), (p[k + 1] - pk).try_normalize()) {
            let frame = if k == 0 { parent } else { worlds[k - 1] };
            rotate_joint(locals, rest, joints[k], goal.limits.get(k), &frame, Quat::from_rotation_arc(from, to));
        }
    }
    chain_worlds(parents, locals, joints, &mut worlds);
    IkReport { error: worlds[n - 1].w_axis.truncate().distance(target), iterations }
}

/// Damping λ of [`IkSolver::Dls`] as a fraction of the chain's length.
const DLS_DAMPING: f32 = 0.02;
/// Largest error step of one [`IkSolver::Dls`] iteration, as a fraction of the chain's length.
const DLS_MAX_STEP: f32 = 0.5;

/// Damped least squares on one goal.
fn dls(
    parents: &[Option<NodeIndex>],
    rest: &[Transform],
    locals: &mut [Transform],
    goal: &IkGoal<'_>,
    settings: &IkSettings,
) -> IkReport {
    let joints = goal.chain.joints();
    let n = joints.len();
    let mut worlds = [Mat4::IDENTITY; MAX_CHAIN];
    chain_worlds(parents, locals, joints, &mut worlds);
    let length: f32 = (0..n - 1).map(|k| worlds[k].w_axis.truncate().distance(worlds[k + 1].w_axis.truncate())).sum();
    let (lambda, max_step) = (DLS_DAMPING * length, DLS_MAX_STEP * length);
    let mut iterations = 0;
    loop {
        let effector = worlds[n - 1].w_axis.truncate();
        let error = goal.target - effector;
        if error.length() <= settings.tolerance || iterations >= settings.iterations || length <= 0.0 {
            break;
        }
        let e = if error.length() > max_step { error * (max_step / error.length()) } else { error };
        // J Jᵀ = Σ over joints and world axes a of (a × r)(a × r)ᵀ, r = effector − joint; for the
        // three axes that sum is |r|² I − r rᵀ.
        let mut jjt = Mat3::IDENTITY * (lambda * lambda);
        for (k, world) in worlds[..n - 1].iter().enumerate() {
            let r = effector - world.w_axis.truncate();
            let eta = goal.stiffness.get(k).copied().unwrap_or(1.0);
            jjt += (Mat3::IDENTITY * r.length_squared() - outer(r, r)) * eta;
        }
        let Some(y) = Some(jjt.inverse() * e).filter(|y| y.is_finite()) else { break };
        // Δθ_k = Jₖᵀ y: for the axes x, y, z the rotation vector is r × y.
        for k in (0..n - 1).rev() {
            let r = effector - worlds[k].w_axis.truncate();
            let eta = goal.stiffness.get(k).copied().unwrap_or(1.0);
            let omega = r.cross(y) * eta;
            if omega.length_squared() > 0.0 {
                let parent = if k == 0 { parent_world(parents, locals, joints[0]) } else { worlds[k - 1] };
                rotate_joint(locals, rest, joints[k], goal.limits.get(k), &parent, Quat::from_scaled_axis(omega));
            }
        }
        chain_worlds(parents, locals, joints, &mut worlds);
        iterations += 1;
    }
    IkReport { error: worlds[n - 1].w_axis.truncate().distance(goal.target), iterations }
}

/// The outer product `a bᵀ`.
fn outer(a: Vec3, b: Vec3) -> Mat3 {
    Mat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// Turns `joint` by the world-space rotation `turn` about its own origin (given its parent's
/// world matrix), then applies its limit.
fn rotate_joint(
    locals: &mut [Transform],
    rest: &[Transform],
    joint: NodeIndex,
    limit: Option<&JointLimit>,
    parent: &Mat4,
    turn: Quat,
) {
    let p = rotation_of(parent);
    let local = &mut locals[joint as usize];
    let rotated = (p.conjugate() * turn * p * local.rotation).normalize();
    let rotated = match limit {
        Some(limit) => limit.clamp(rest[joint as usize].rotation, rotated),
        None => rotated,
    };
    if rotated.is_finite() {
        local.rotation = rotated;
    }
}

/// The rotation of an affine matrix (Gram–Schmidt on its columns; identity when degenerate).
fn rotation_of(m: &Mat4) -> Quat {
    super::dqs::rotation_of(&Mat3::from_mat4(*m))
}

/// World matrix of `node`'s parent, from the locals (identity for a root).
fn parent_world(parents: &[Option<NodeIndex>], locals: &[Transform], node: NodeIndex) -> Mat4 {
    let mut world = Mat4::IDENTITY;
    let mut current = parents.get(node as usize).copied().flatten();
    for _ in 0..MAX_DEPTH {
        let Some(n) = current else { break };
        world = locals[n as usize].to_mat4() * world;
        current = parents.get(n as usize).copied().flatten();
    }
    world
}

/// World matrices of the chain joints into `out[..joints.len()]`.
fn chain_worlds(
    parents: &[Option<NodeIndex>],
    locals: &[Transform],
    joints: &[NodeIndex],
    out: &mut [Mat4; MAX_CHAIN],
) {
    let parent = parent_world(parents, locals, joints[0]);
    update_from(locals, joints, 0, &parent, out);
}

/// Recomputes `out[k..]` after joint `k` changed (`parent`: the world of joint `k`'s parent).
fn update_from(locals: &[Transform], joints: &[NodeIndex], k: usize, parent: &Mat4, out: &mut [Mat4; MAX_CHAIN]) {
    let mut world = *parent;
    for (i, &j) in joints.iter().enumerate().skip(k) {
        world *= locals[j as usize].to_mat4();
        out[i] = world;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::{FRAC_PI_2, PI};

    /// A straight chain along +Y: node 0 at the origin, then unit bones; node `n` the tip.
    fn arm(bones: usize) -> (Vec<Option<NodeIndex>>, Vec<Transform>) {
        let parents = (0..=bones).map(|i| if i == 0 { None } else { Some(i as u32 - 1) }).collect();
        let locals = (0..=bones)
            .map(|i| Transform { translation: if i == 0 { Vec3::ZERO } else { Vec3::Y }, ..Transform::IDENTITY })
            .collect();
        (parents, locals)
    }

    fn tip(parents: &[Option<NodeIndex>], locals: &[Transform], node: NodeIndex) -> Vec3 {
        (parent_world(parents, locals, node) * locals[node as usize].to_mat4()).w_axis.truncate()
    }

    /// RiggedFigure, with the parent and rest local transform of every node.
    fn rigged_figure() -> (crate::asset::Asset, Vec<Option<NodeIndex>>, Vec<Transform>) {
        let asset = crate::testutil::load("khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb");
        let parents = asset.nodes.iter().map(|n| n.parent).collect();
        let rest = asset.nodes.iter().map(|n| n.rest).collect();
        (asset, parents, rest)
    }

    /// The node of `asset` named `name`.
    fn node(asset: &crate::asset::Asset, name: &str) -> NodeIndex {
        asset.nodes.iter().position(|n| n.name.as_deref() == Some(name)).expect("a RiggedFigure joint") as NodeIndex
    }

    /// The length of `chain` in the rest pose.
    fn rest_length(parents: &[Option<NodeIndex>], rest: &[Transform], chain: &IkChain) -> f32 {
        chain.joints().windows(2).map(|w| tip(parents, rest, w[0]).distance(tip(parents, rest, w[1]))).sum()
    }

    /// A random unit axis from three of `random`'s numbers.
    fn random_axis(random: &mut impl FnMut() -> f32) -> Vec3 {
        Vec3::new(random() - 0.5, random() - 0.5, random() - 0.5).try_normalize().unwrap_or(Vec3::X)
    }

    fn solve(
        parents: &[Option<NodeIndex>],
        rest: &[Transform],
        locals: &mut [Transform],
        goal: IkGoal<'_>,
        settings: IkSettings,
    ) -> IkReport {
        solve_together(parents, rest, locals, &[goal], settings)[0]
    }

    /// Default settings with the two-bone solver.
    fn two_bone_settings() -> IkSettings {
        IkSettings { solver: IkSolver::TwoBone, ..IkSettings::default() }
    }

    /// Solves `goals` in one job (at most two here).
    fn solve_together(
        parents: &[Option<NodeIndex>],
        rest: &[Transform],
        locals: &mut [Transform],
        goals: &[IkGoal<'_>],
        settings: IkSettings,
    ) -> [IkReport; 2] {
        let mut reports = [IkReport::default(); 2];
        IkJob { parents, rest, locals, goals, settings, reports: &mut reports[..goals.len()] }.run().expect("valid");
        reports
    }

    #[test]
    fn ccd_reaches_a_reachable_target_and_reports_it() {
        let (parents, rest) = arm(3);
        let chain = IkChain::new(&parents, 3, 3).expect("chain");
        assert_eq!(chain.joints(), &[0, 1, 2, 3]);
        let mut locals = rest.clone();
        let target = Vec3::new(1.5, 1.2, 0.4);
        let goal = IkGoal { chain: &chain, target, stiffness: &[], limits: &[], pole: None };
        let report = solve(&parents, &rest, &mut locals, goal, IkSettings::default());
        assert!(report.error <= 1e-4, "{report:?}");
        assert!(tip(&parents, &locals, 3).distance(target) <= 1e-4);
        assert!(report.iterations <= 32);
    }

    #[test]
    fn unreachable_targets_straighten_the_chain_towards_them() {
        let (parents, rest) = arm(2);
        let chain = IkChain::new(&parents, 2, 2).expect("chain");
        for solver in IkSolver::ALL {
            let mut locals = rest.clone();
            locals[1].rotation = Quat::from_rotation_z(1.0);
            let target = Vec3::new(10.0, 3.0, -2.0);
            let goal = IkGoal { chain: &chain, target, stiffness: &[], limits: &[], pole: None };
            let settings = IkSettings { solver, ..IkSettings::default() };
            let report = solve(&parents, &rest, &mut locals, goal, settings);
            let end = tip(&parents, &locals, 2);
            assert!(end.is_finite() && report.error.is_finite());
            // Fully stretched (length 2) and pointing at the target.
            assert!((end.length() - 2.0).abs() < 1e-2, "{solver:?}: {end}");
            assert!(end.normalize().dot(target.normalize()) > 0.999, "{solver:?}: {end}");
        }
    }

    #[test]
    fn a_joint_with_zero_stiffness_never_moves() {
        let (parents, rest) = arm(3);
        let chain = IkChain::new(&parents, 3, 3).expect("chain");
        let mut locals = rest.clone();
        let goal = IkGoal {
            chain: &chain,
            target: Vec3::new(1.0, 1.0, 1.0),
            stiffness: &[1.0, 0.0, 1.0],
            limits: &[],
            pole: None,
        };
        solve(&parents, &rest, &mut locals, goal, IkSettings::default());
        assert_eq!(locals[1].rotation, rest[1].rotation);
        assert_ne!(locals[0].rotation, rest[0].rotation);
    }

    #[test]
    fn limits_hold_after_the_solve() {
        let (parents, rest) = arm(2);
        let chain = IkChain::new(&parents, 2, 2).expect("chain");
        let hinge = JointLimit::Hinge { axis: Vec3::Z, min: 0.0, max: FRAC_PI_2 };
        let ball = JointLimit::Ball { axis: Vec3::Y, swing: 0.5, twist_min: -0.2, twist_max: 0.2 };
        let limits = [ball, hinge];
        for target in [Vec3::new(-1.5, 0.5, 0.3), Vec3::new(0.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 1.0)] {
            let mut locals = rest.clone();
            let goal = IkGoal { chain: &chain, target, stiffness: &[], limits: &limits, pole: None };
            solve(&parents, &rest, &mut locals, goal, IkSettings::default());
            for (k, limit) in limits.iter().enumerate() {
                assert!(limit.allows(rest[k].rotation, locals[k].rotation, 1e-4), "joint {k} at {target}");
            }
        }
        // A hinge keeps one degree of freedom: an off-axis rotation projects onto its axis.
        let q = hinge.clamp(Quat::IDENTITY, Quat::from_rotation_x(0.7) * Quat::from_rotation_z(0.4));
        assert!(
            (twist_angle(q, Vec3::Z) - 0.4).abs() < 0.05
                && q.angle_between(Quat::from_rotation_z(twist_angle(q, Vec3::Z))) < 1e-5
        );
        // Angles near ±π stay in range (three.js #29682).
        let near_pi = hinge.clamp(Quat::IDENTITY, Quat::from_rotation_z(PI - 1e-3));
        assert!(hinge.allows(Quat::IDENTITY, near_pi, 1e-4));
    }

    #[test]
    fn two_bone_reaches_and_bends_towards_the_pole() {
        let (parents, rest) = arm(2);
        let chain = IkChain::new(&parents, 2, 2).expect("chain");
        for pole in [Vec3::new(0.0, 1.0, 5.0), Vec3::new(0.0, 1.0, -5.0)] {
            let mut locals = rest.clone();
            let target = Vec3::new(1.2, 0.8, 0.0);
            let goal = IkGoal { chain: &chain, target, stiffness: &[], limits: &[], pole: Some(pole) };
            let settings = two_bone_settings();
            let report = solve(&parents, &rest, &mut locals, goal, settings);
            assert!(report.error < 1e-4, "{report:?}");
            let elbow = tip(&parents, &locals, 1);
            assert!(elbow.z * pole.z > 0.0, "the elbow {elbow} does not face the pole {pole}");
        }
    }

    /// Soft reach: inside the band the effector stops short of the target on the line to it,
    /// at the distance the soft curve gives, and as the target moves out the reach grows
    /// smoothly towards the full length; before the band the target is reached exactly.
    #[test]
    fn two_bone_soft_reach_eases_into_full_extension() {
        let (parents, rest) = arm(3);
        let chain = IkChain::new(&parents, 3, 2).expect("chain");
        let root = tip(&parents, &rest, 1);
        let length = 2.0;
        let softness = 0.1;
        let mut reached = Vec::new();
        for distance in [1.5, 1.79, 1.85, 1.9, 2.0, 2.2, 3.0] {
            let target = root + Vec3::new(0.6, 0.0, 0.8) * distance;
            let mut locals = rest.clone();
            let goal = IkGoal { chain: &chain, target, stiffness: &[], limits: &[], pole: Some(root + Vec3::X) };
            let settings = IkSettings { solver: IkSolver::TwoBone, softness, ..IkSettings::default() };
            solve(&parents, &rest, &mut locals, goal, settings);
            let effector = tip(&parents, &locals, 3);
            let wanted = soft_reach(distance, length, softness * length);
            assert!((effector.distance(root) - wanted).abs() < 1e-4, "{distance}: reach {}", effector.distance(root));
            assert!(
                (effector - root).normalize().abs_diff_eq(Vec3::new(0.6, 0.0, 0.8), 1e-4),
                "{distance}: off the line"
            );
            reached.push(effector.distance(root));
        }
        assert!((reached[0] - 1.5).abs() < 1e-4 && (reached[1] - 1.79).abs() < 1e-4, "before the band: exact");
        assert!(reached.windows(2).all(|w| w[1] > w[0]), "reach grows with the target: {reached:?}");
        assert!(reached[6] < length && reached[6] > length - 0.01, "far away: nearly straight {}", reached[6]);
        // Hard reach (0) straightens fully as soon as the target is at the chain's length.
        assert_eq!(soft_reach(1.95, 2.0, 0.0), 1.95);
        let mut locals = rest.clone();
        let target = root + Vec3::new(0.6, 0.0, 0.8) * 1.9;
        let goal = IkGoal { chain: &chain, target, stiffness: &[], limits: &[], pole: Some(root + Vec3::X) };
        let report = solve(&parents, &rest, &mut locals, goal, two_bone_settings());
        assert!(report.error < 1e-4);
    }

    #[test]
    fn weight_blends_back_to_the_animated_pose() {
        let (parents, rest) = arm(2);
        let chain = IkChain::new(&parents, 2, 2).expect("chain");
        let mut locals = rest.clone();
        let goal = IkGoal { chain: &chain, target: Vec3::new(1.0, 1.0, 0.0), stiffness: &[], limits: &[], pole: None };
        solve(&parents, &rest, &mut locals, goal, IkSettings { weight: 0.0, ..IkSettings::default() });
        assert!(locals.iter().zip(&rest).all(|(a, b)| a.rotation.abs_diff_eq(b.rotation, 1e-6)));
    }

    /// 1000 random reachable targets (the effector's position in a random pose of the chain,
    /// each rotating joint turned up to 2 rad about a random axis) per chain, solver and
    /// iteration budget on RiggedFigure, solved from another random pose; reached = within
    /// 1e-3 of the chain's length. The floors are this implementation's measured rates minus
    /// a margin (BENCHMARKS.md "Inverse kinematics"): plain CCD converges slowly near full
    /// reach; with its pattern move it reaches ≥ 99 % within 32 sweeps.
    #[test]
    fn solvers_reach_random_targets_on_rigged_figure() {
        let (asset, parents, rest) = rigged_figure();
        let arm = IkChain::new(&parents, node(&asset, "arm_joint_L_3"), 2).expect("arm");
        let leg = IkChain::new(&parents, node(&asset, "leg_joint_L_5"), 3).expect("leg");
        // (chain, solver, accelerated CCD, most iterations, floor of targets reached)
        let cases = [
            ("arm", &arm, IkSolver::Ccd, true, 32, 990),
            ("arm", &arm, IkSolver::Ccd, false, 32, 690),
            ("arm", &arm, IkSolver::Ccd, false, 128, 970),
            ("arm", &arm, IkSolver::TwoBone, true, 1, 1000),
            ("arm", &arm, IkSolver::Fabrik, true, 32, 950),
            ("arm", &arm, IkSolver::Dls, true, 32, 980),
            ("leg", &leg, IkSolver::Ccd, true, 32, 990),
            ("leg", &leg, IkSolver::Ccd, false, 32, 740),
            ("leg", &leg, IkSolver::Ccd, false, 128, 985),
            ("leg", &leg, IkSolver::Fabrik, true, 32, 950),
            ("leg", &leg, IkSolver::Dls, true, 32, 980),
        ];
        for (name, chain, solver, accelerate, iterations, floor) in cases {
            let mut random = crate::testutil::xorshift(0x9e37_79b9_u32);
            let joints = chain.joints();
            let length = rest_length(&parents, &rest, chain);
            let mut random_pose = |locals: &mut [Transform]| {
                for &j in &joints[..joints.len() - 1] {
                    let axis = random_axis(&mut random);
                    locals[j as usize].rotation =
                        rest[j as usize].rotation * Quat::from_axis_angle(axis, random() * 2.0);
                }
            };
            let (mut reached, mut sweeps) = (0, 0);
            for _ in 0..1000 {
                let mut posed = rest.clone();
                random_pose(&mut posed);
                let target = tip(&parents, &posed, chain.effector());
                let mut locals = rest.clone();
                random_pose(&mut locals);
                let goal = IkGoal { chain, target, stiffness: &[], limits: &[], pole: None };
                let settings =
                    IkSettings { solver, iterations, tolerance: 1e-4 * length, weight: 1.0, accelerate, softness: 0.0 };
                let report = solve(&parents, &rest, &mut locals, goal, settings);
                assert!(report.error.is_finite() && locals.iter().all(|l| l.rotation.is_finite()));
                if report.error <= 1e-3 * length {
                    reached += 1;
                }
                sweeps += report.iterations;
            }
            let solver = match (solver, accelerate) {
                (IkSolver::Ccd, false) => "plain ccd",
                _ => solver.name(),
            };
            eprintln!(
                "{name} ({} joints) {solver} ≤ {iterations}: {reached}/1000 reached, {:.1} iterations on average",
                joints.len(),
                sweeps as f32 / 1000.0
            );
            assert!(reached >= floor, "{name} {solver} ≤ {iterations}: {reached} of 1000 reached (floor {floor})");
        }
    }

    /// RiggedFigure's names give hinge elbows and knees and ball shoulders and hips; solving
    /// 1000 random targets with them never leaves a limit, with any solver that takes limits.
    #[test]
    fn humanoid_limits_from_names_hold_on_rigged_figure() {
        let (asset, parents, rest) = rigged_figure();
        let limits = humanoid_limits(&asset);
        assert!(matches!(limits[node(&asset, "arm_joint_L_2") as usize], JointLimit::Hinge { .. }));
        assert!(matches!(limits[node(&asset, "leg_joint_R_2") as usize], JointLimit::Hinge { .. }));
        assert!(matches!(limits[node(&asset, "arm_joint_R_1") as usize], JointLimit::Ball { .. }));
        assert!(matches!(limits[node(&asset, "leg_joint_L_1") as usize], JointLimit::Ball { .. }));
        assert_eq!(limits[node(&asset, "torso_joint_2") as usize], JointLimit::Free);
        assert_eq!(limits[node(&asset, "arm_joint_L_3") as usize], JointLimit::Free);
        let chain = IkChain::new(&parents, node(&asset, "arm_joint_L_3"), 2).expect("arm");
        let chain_limits: Vec<JointLimit> = chain.joints()[..2].iter().map(|&j| limits[j as usize]).collect();
        let shoulder = tip(&parents, &rest, chain.joints()[0]);
        let runs = [
            (IkSolver::Ccd, true),
            (IkSolver::Ccd, false),
            (IkSolver::TwoBone, true),
            (IkSolver::Fabrik, true),
            (IkSolver::Dls, true),
        ];
        let length = rest_length(&parents, &rest, &chain);
        for (solver, accelerate) in runs {
            let mut random = crate::testutil::xorshift(0x2545_f491_u32);
            // 1000 targets around the shoulder, out to 1.2 × the arm's length (some unreachable).
            for _ in 0..1000 {
                let direction = random_axis(&mut random);
                let target = shoulder + direction * random() * 1.2 * length;
                let mut locals = rest.clone();
                let goal = IkGoal { chain: &chain, target, stiffness: &[], limits: &chain_limits, pole: None };
                let settings = IkSettings { solver, accelerate, ..IkSettings::default() };
                let report = solve(&parents, &rest, &mut locals, goal, settings);
                assert!(report.error.is_finite());
                for (k, &j) in chain.joints()[..2].iter().enumerate() {
                    assert!(
                        chain_limits[k].allows(rest[j as usize].rotation, locals[j as usize].rotation, 1e-4),
                        "{solver:?} (accelerate {accelerate}): joint {j} left its limit"
                    );
                }
            }
        }
    }

    /// Two hands whose chains share the spine (depth 4: elbow, shoulder, two torso joints),
    /// targets from random poses of all of them: solved in one job, CCD reaches both nearly
    /// always (199 of 200); solved one after the other, the second goal's turn of the spine drags the
    /// first hand off its target.
    #[test]
    fn goals_sharing_joints_are_solved_together() {
        let (asset, parents, rest) = rigged_figure();
        let left = IkChain::new(&parents, node(&asset, "arm_joint_L_3"), 4).expect("left");
        let right = IkChain::new(&parents, node(&asset, "arm_joint_R_3"), 4).expect("right");
        assert_eq!(left.joints()[..2], right.joints()[..2], "the chains share the spine");
        let mut random = crate::testutil::xorshift(0x1234_5678_u32);
        let (mut together, mut apart) = (0, 0);
        for _ in 0..200 {
            let mut posed = rest.clone();
            for &j in left.joints()[..4].iter().chain(&right.joints()[2..4]) {
                let axis = random_axis(&mut random);
                posed[j as usize].rotation = rest[j as usize].rotation * Quat::from_axis_angle(axis, random() * 0.8);
            }
            let targets = [tip(&parents, &posed, left.effector()), tip(&parents, &posed, right.effector())];
            let goals = [
                IkGoal { chain: &left, target: targets[0], stiffness: &[], limits: &[], pole: None },
                IkGoal { chain: &right, target: targets[1], stiffness: &[], limits: &[], pole: None },
            ];
            let settings = IkSettings::default();
            let reached = |locals: &[Transform]| {
                [&left, &right]
                    .iter()
                    .zip(&targets)
                    .all(|(c, t)| tip(&parents, locals, c.effector()).distance(*t) < 1e-3)
            };
            let mut locals = rest.clone();
            solve_together(&parents, &rest, &mut locals, &goals, settings);
            assert!(locals.iter().all(|l| l.rotation.is_finite()));
            together += usize::from(reached(&locals));
            let mut locals = rest.clone();
            for goal in goals {
                solve(&parents, &rest, &mut locals, goal, settings);
            }
            apart += usize::from(reached(&locals));
        }
        eprintln!("both hands reached: {together}/200 solved together, {apart}/200 one after the other");
        assert!(together >= 195, "together: {together} of 200");
        assert!(apart < together, "one after the other: {apart}, together: {together}");
    }

    /// Two-bone with RiggedFigure's hinge elbow: targets from poses the hinge allows (shoulder
    /// turned anywhere, elbow bent about its own axis) are reached, bending about the hinge.
    #[test]
    fn two_bone_bends_a_hinge_elbow_about_its_axis() {
        let (asset, parents, rest) = rigged_figure();
        let limits = humanoid_limits(&asset);
        let hand = node(&asset, "arm_joint_L_3");
        let chain = IkChain::new(&parents, hand, 2).expect("arm");
        let [shoulder, elbow] = [chain.joints()[0] as usize, chain.joints()[1] as usize];
        let JointLimit::Hinge { axis, .. } = limits[elbow] else { panic!("a hinge elbow") };
        let chain_limits = [JointLimit::Free, limits[elbow]];
        let length = rest_length(&parents, &rest, &chain);
        let mut random = crate::testutil::xorshift(0x0bad_cafe);
        let mut reached = 0;
        for _ in 0..500 {
            let mut posed = rest.clone();
            let turn = random_axis(&mut random);
            posed[shoulder].rotation = rest[shoulder].rotation * Quat::from_axis_angle(turn, random() * 2.0);
            posed[elbow].rotation = rest[elbow].rotation * Quat::from_axis_angle(axis, (random() - 0.5) * 4.0);
            let target = tip(&parents, &posed, hand);
            let mut locals = rest.clone();
            let goal = IkGoal { chain: &chain, target, stiffness: &[], limits: &chain_limits, pole: None };
            let settings = two_bone_settings();
            let report = solve(&parents, &rest, &mut locals, goal, settings);
            assert!(
                chain_limits[1].allows(rest[elbow].rotation, locals[elbow].rotation, 1e-4),
                "the elbow left its hinge"
            );
            if report.error <= 1e-3 * length {
                reached += 1;
            }
        }
        assert!(reached >= 495, "{reached} of 500 reached");
    }

    /// A one-sided hinge (bends one way only, 0..150°) from a straight chain: two-bone bends
    /// the allowed way and reaches, whichever side the target is on.
    #[test]
    fn two_bone_bends_a_one_sided_hinge_the_allowed_way() {
        let (parents, rest) = arm(3);
        let chain = IkChain::new(&parents, 3, 2).expect("chain");
        let root = tip(&parents, &rest, 1);
        let hinge = JointLimit::Hinge { axis: Vec3::X, min: 0.0, max: 150f32.to_radians() };
        for target in [Vec3::new(0.0, 1.2, 0.9), Vec3::new(0.0, 1.2, -0.9), Vec3::new(0.3, 0.5, 0.2)] {
            let target = root + target;
            let mut locals = rest.clone();
            let goal = IkGoal { chain: &chain, target, stiffness: &[], limits: &[JointLimit::Free, hinge], pole: None };
            let report = solve(&parents, &rest, &mut locals, goal, two_bone_settings());
            assert!(report.error < 1e-4, "{target}: error {}", report.error);
            assert!(hinge.allows(rest[2].rotation, locals[2].rotation, 1e-4), "{target}: the hinge bent the wrong way");
            let bend = twist_angle(rest[2].rotation.conjugate() * locals[2].rotation, Vec3::X);
            assert!(bend > 0.1, "{target}: bend {bend}");
        }
    }

    /// With weight < 1, a joint two goals share is blended back once (w, not w²).
    #[test]
    fn a_shared_joint_is_weighted_once() {
        let (asset, parents, rest) = rigged_figure();
        let left = IkChain::new(&parents, node(&asset, "arm_joint_L_3"), 4).expect("left");
        let right = IkChain::new(&parents, node(&asset, "arm_joint_R_3"), 4).expect("right");
        let spine = left.joints()[0] as usize;
        let targets = [
            tip(&parents, &rest, left.effector()) + Vec3::new(0.2, 0.1, 0.3),
            tip(&parents, &rest, right.effector()) + Vec3::new(-0.1, 0.3, 0.2),
        ];
        let goals = [
            IkGoal { chain: &left, target: targets[0], stiffness: &[], limits: &[], pole: None },
            IkGoal { chain: &right, target: targets[1], stiffness: &[], limits: &[], pole: None },
        ];
        let run = |weight: f32| {
            let mut locals = rest.clone();
            solve_together(&parents, &rest, &mut locals, &goals, IkSettings { weight, ..IkSettings::default() });
            locals[spine].rotation
        };
        let solved = run(1.0);
        assert!(solved.angle_between(rest[spine].rotation) > 0.01, "the spine did not turn");
        let half = run(0.5);
        let wanted = rest[spine].rotation.slerp(solved, 0.5);
        assert!(half.abs_diff_eq(wanted, 1e-5), "{half} vs {wanted}");
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let (parents, rest) = arm(3);
        assert!(IkChain::new(&parents, 3, 0).is_err());
        assert!(IkChain::new(&parents, 3, 4).is_err(), "deeper than the hierarchy");
        assert!(IkChain::new(&parents, 9, 1).is_err());
        let chain = IkChain::new(&parents, 3, 2).expect("chain");
        let mut locals = rest.clone();
        let mut reports = [IkReport::default()];
        let mut run = |goal: IkGoal<'_>, settings: IkSettings, locals: &mut [Transform]| {
            IkJob { parents: &parents, rest: &rest, locals, goals: &[goal], settings, reports: &mut reports }.run()
        };
        let good = IkGoal { chain: &chain, target: Vec3::ONE, stiffness: &[], limits: &[], pole: None };
        assert!(run(IkGoal { target: Vec3::NAN, ..good }, IkSettings::default(), &mut locals).is_err());
        assert!(run(IkGoal { stiffness: &[1.0], ..good }, IkSettings::default(), &mut locals).is_err());
        assert!(run(IkGoal { stiffness: &[2.0, 1.0], ..good }, IkSettings::default(), &mut locals).is_err());
        assert!(run(IkGoal { limits: &[JointLimit::Free; 3], ..good }, IkSettings::default(), &mut locals).is_err());
        let three = IkChain::new(&parents, 3, 3).expect("chain");
        let twobone = two_bone_settings();
        assert!(run(IkGoal { chain: &three, ..good }, twobone, &mut locals).is_err(), "two-bone needs depth 2");
        assert!(run(good, IkSettings { tolerance: f32::NAN, ..IkSettings::default() }, &mut locals).is_err());
        assert!(run(good, IkSettings { softness: 1.0, ..IkSettings::default() }, &mut locals).is_err());
        assert!(run(good, IkSettings { softness: f32::NAN, ..IkSettings::default() }, &mut locals).is_err());
        assert!(run(good, IkSettings::default(), &mut locals[..2]).is_err());
        assert!(run(good, IkSettings::default(), &mut locals).is_ok());
    }
}
