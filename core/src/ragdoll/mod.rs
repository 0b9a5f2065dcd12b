//! Ragdoll physics (seed 000 §3.4): the skinned character becomes a set of rigid capsules
//! joined by limited joints, simulated by rapier3d at a fixed 60 Hz over a ground plane, and
//! its skeleton is written back from the bodies every frame.
//!
//! - **Bodies**: one capsule per significant bone (a joint and its main child joint; a leaf
//!   joint reaches as far as the vertices it carries). The radius comes from the skinned
//!   vertices the joint influences most, the mass from the capsule's volume. Shorter bones
//!   (fingers, twist helpers, roots at one point) have no body and ride on their parent's.
//! - **Joints** at each body's joint, in the joint's rest frame, so the limits are the IK
//!   limits ([`JointSettings`]: a hinge becomes a revolute joint with its angle range, a ball
//!   a spherical joint with its swing cone and twist range) and an unlimited joint gets a
//!   moderate spherical range. Ragdoll bodies do not collide with each other; they collide
//!   with the ground, the obstacles ([`obstacles`]) and thrown balls.
//! - **Start** from any pose: each body keeps its offset to its joint (the bind of the
//!   moment it was built), and may inherit velocities from the previous frame's pose.
//! - **Units**: glTF's metres are trusted for nothing but proportions: gravity is scaled to
//!   the skeleton's size (a body as tall as a person falls like one), so a 100-unit fox and a
//!   1.7-unit man fall alike.
//!
//! [`Ragdoll::step`] advances by wall time in fixed steps; [`Ragdoll::write_pose`] writes the
//! interpolated pose into a [`Pose`]'s locals. Same inputs, same steps: the same output.

pub mod obstacles;

pub use obstacles::{Obstacle, Piece};

use rapier3d::prelude::{
    ColliderBuilder, GenericJointBuilder, Group, ImpulseJointHandle, InteractionGroups, InteractionTestMode,
    JointAxesMask, JointAxis, PhysicsWorld, RigidBodyBuilder, RigidBodyHandle,
};

use crate::asset::{Asset, NodeIndex};
use crate::instance::Instance;
use crate::job::ik::JointLimit;
use crate::math::{Mat4, Quat, Transform, Vec3};
use crate::pose::Pose;
use crate::rig::JointSettings;

/// Simulation steps per second.
pub const STEP_HZ: f32 = 60.0;

/// A person's height in metres: gravity is scaled so a skeleton this tall falls at 9.81 m/s².
const PERSON_HEIGHT: f32 = 1.75;

/// Bones shorter than this fraction of the skeleton's size get no body.
const MIN_BONE: f32 = 0.08;

/// Most wall time one [`Ragdoll::step`] simulates (a stalled tab does not run a second of
/// steps at once).
const MAX_FRAME: f32 = 0.25;

/// Speed under which a body counts as at rest, in skeleton sizes per second.
const REST_SPEED: f32 = 0.03;
/// A ragdoll whose every point moves slower than this (fraction of the skeleton's size per
/// second; rapier also asks for less than 90°/s of turn) for [`SLEEP_AFTER`] seconds is put
/// to sleep.
const SLEEP_SPEED: f32 = 0.2;
/// Seconds below [`SLEEP_SPEED`] before sleeping.
const SLEEP_AFTER: f32 = 1.0;

/// Speed under which the ragdoll counts as calm (fraction of its size per second, its fastest
/// body): calm, its damping rises towards [`SETTLE_DAMPING`] over [`SETTLE_AFTER`] seconds so
/// that a body rocking against a joint limit or the ground comes to rest; a push or a hit ends
/// the calm.
const CALM_SPEED: f32 = 1.0;
/// Damping (per second) added once the ragdoll has been calm for [`SETTLE_AFTER`] seconds.
const SETTLE_DAMPING: f32 = 6.0;
/// Seconds of calm over which the settling damping comes in.
const SETTLE_AFTER: f32 = 0.5;
/// Seconds after the start or the last push when the settling damping comes in for a ragdoll
/// lying on something even if it is not calm (a fall is over by then; a body still swinging is
/// the solver's). One in the air keeps falling.
const IDLE_SETTLE: f32 = 2.5;
/// Seconds of calm after the settling damping is in before the ragdoll is put to sleep.
const SLEEP_AFTER_SETTLED: f32 = 0.4;

/// How far (radians) the start pose may be outside a joint's limit before the ragdoll drops
/// that limit.
const START_LIMIT_SLACK: f32 = 0.1;

/// Most thrown balls in the world at once.
pub const MAX_BALLS: usize = 16;
/// A thrown ball's density (the bodies' is 1): heavy enough to knock a character.
const BALL_DENSITY: f32 = 4.0;
/// Powered ragdoll: the time in which a body's velocity would close the gap to its target.
const POWER_TIME: f32 = 0.04;
/// Powered ragdoll: the fraction of the velocity error removed each step at strength 1.
const POWER_GAIN: f32 = 1.0;

/// Solver substeps per fixed step: contacts and joints solved at 180 Hz keep the skin within
/// 1 % of the character's size of the ground when a limb lands (at 60 Hz, up to 3 %).
const SUBSTEPS: u32 = 3;

/// Most skinned vertices a body's hull is built from.
const MAX_HULL_POINTS: usize = 512;

/// Range of a joint without a limit of its own: swing and twist, radians.
const FREE_SWING: f32 = 0.7;
const FREE_TWIST: f32 = 0.5;

/// What shapes the simulation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RagdollOptions {
    /// Gravity in m/s² for a person-sized skeleton (scaled to the model's size).
    pub gravity: f32,
    /// Linear and angular velocity damping of every body (per second).
    pub damping: f32,
    /// Ground friction.
    pub friction: f32,
    /// Height of the ground plane; `None`: the lowest skinned vertex of the start pose.
    pub ground: Option<f32>,
    /// Powered ragdoll (seed 000's "animation + physics correction"): how strongly each body
    /// is driven towards the pose [`Ragdoll::set_targets`] gives, 0 (limp) to 1 (follows the
    /// clip, gravity compensated).
    pub strength: f32,
}

impl Default for RagdollOptions {
    fn default() -> Self {
        Self { gravity: 9.81, damping: 0.5, friction: 0.8, ground: None, strength: 0.0 }
    }
}

/// One simulated bone.
#[derive(Clone, Debug)]
pub struct RagdollBody {
    /// The joint the body carries.
    pub joint: NodeIndex,
    /// The capsule's radius and half-height of its straight part (model units).
    pub radius: f32,
    /// Half the length of the capsule's straight part.
    pub half_height: f32,
    /// The limit its joint to the parent body has (what the test and the overlay check; not
    /// enforced while the ragdoll is powered).
    pub limit: JointLimit,
    /// Whether a joint ties it to a parent body (else it is a root of the ragdoll).
    pub attached: bool,
    handle: RigidBodyHandle,
    /// Its joint to the parent body (rebuilt when the ragdoll is powered or let go).
    link: Option<Link>,
    /// The joint's world transform in the body's frame (rigid part) and its world scale.
    body_from_joint: (Quat, Vec3),
    scale: Vec3,
    /// Body pose before the last step (for interpolation).
    previous: (Quat, Vec3),
}

/// A body's joint to its parent body: the bodies, the joint's frames on each, its handle.
#[derive(Clone, Debug)]
struct Link {
    parent: RigidBodyHandle,
    frame1: rapier3d::math::Pose,
    frame2: rapier3d::math::Pose,
    joint: ImpulseJointHandle,
}

/// The joint for `limit` between two bodies at `frame1` and `frame2`: the limit's range, or
/// (`powered`) a free spherical joint, since the drive holds the clip's range.
fn joint_of(
    limit: JointLimit,
    frame1: rapier3d::math::Pose,
    frame2: rapier3d::math::Pose,
    powered: bool,
) -> rapier3d::prelude::GenericJoint {
    let joint = match limit {
        _ if powered => GenericJointBuilder::new(JointAxesMask::LOCKED_SPHERICAL_AXES),
        JointLimit::Hinge { min, max, .. } => {
            GenericJointBuilder::new(JointAxesMask::LOCKED_REVOLUTE_AXES).limits(JointAxis::AngX, [min, max])
        }
        JointLimit::Ball { swing, twist_min, twist_max, .. } => {
            let s = swing * std::f32::consts::FRAC_1_SQRT_2;
            GenericJointBuilder::new(JointAxesMask::LOCKED_SPHERICAL_AXES)
                .limits(JointAxis::AngX, [twist_min, twist_max])
                .limits(JointAxis::AngY, [-s, s])
                .limits(JointAxis::AngZ, [-s, s])
        }
        JointLimit::Free => GenericJointBuilder::new(JointAxesMask::LOCKED_SPHERICAL_AXES)
            .limits(JointAxis::AngX, [-FREE_TWIST, FREE_TWIST])
            .limits(JointAxis::AngY, [-FREE_SWING, FREE_SWING])
            .limits(JointAxis::AngZ, [-FREE_SWING, FREE_SWING]),
    };
    joint.local_frame1(frame1).local_frame2(frame2).build()
}

/// Why a ragdoll could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RagdollError {
    /// The asset has no skinned skeleton.
    #[error("no skin: a ragdoll needs a skinned skeleton")]
    NoSkeleton,
    /// No bone is long enough for a body.
    #[error("no bone is long enough to simulate")]
    NoBones,
    /// The instance does not belong to the asset.
    #[error("the pose does not match the asset: {0}")]
    Mismatch(String),
}

/// A running ragdoll of one character.
pub struct Ragdoll {
    world: PhysicsWorld,
    bodies: Vec<RagdollBody>,
    /// Body index of each node (`usize::MAX`: none).
    body_of: Vec<usize>,
    /// The locals when the ragdoll started (joints without a body keep theirs).
    start_locals: Vec<Transform>,
    /// Parents-first node order.
    order: Vec<NodeIndex>,
    parents: Vec<Option<NodeIndex>>,
    accumulator: f32,
    steps: u64,
    /// Seconds the ragdoll has been calm ([`CALM_SPEED`]).
    calm_for: f32,
    /// Seconds since it started or was last pushed, hit or given options.
    undisturbed: f32,
    /// The obstacles' fixed bodies.
    obstacles: Vec<RigidBodyHandle>,
    /// Thrown balls and their radii.
    balls: Vec<(RigidBodyHandle, f32)>,
    /// Ground friction (for the obstacles).
    friction: f32,
    /// Powered: the strength and each body's target (rotation, centre), from [`Ragdoll::set_targets`].
    strength: f32,
    targets: Vec<Option<(Quat, Vec3)>>,
    /// Each target's velocity (linear, angular) from the targets before.
    target_velocities: Vec<(Vec3, Vec3)>,
    /// Steps taken since the targets were set (the drive moves them on by their velocity).
    since_targets: u32,
    /// The damping asked for (the settling damping comes on top).
    damping: f32,
    ground: f32,
    size: f32,
    /// World transforms written by [`Ragdoll::write_pose`], kept to reuse the allocation.
    worlds: Vec<Mat4>,
}

impl std::fmt::Debug for Ragdoll {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ragdoll").field("bodies", &self.bodies.len()).field("steps", &self.steps).finish()
    }
}

fn rigid(m: &Mat4) -> (Vec3, Quat, Vec3) {
    let (scale, rotation, translation) = m.to_scale_rotation_translation();
    let rotation = if rotation.is_finite() { rotation.normalize() } else { Quat::IDENTITY };
    (scale, rotation, translation)
}

fn pose(rotation: Quat, translation: Vec3) -> rapier3d::math::Pose {
    rapier3d::math::Pose::from_parts(translation, rotation)
}

impl Ragdoll {
    /// Builds the ragdoll of `instance`'s current pose (evaluated: worlds up to date). With
    /// `previous` (the worlds one frame earlier, `dt` seconds before), the bodies start with
    /// the animation's velocities. `settings` gives the joint limits.
    ///
    /// # Errors
    /// No skin, no bone long enough, or an instance of another asset.
    pub fn new(
        asset: &Asset,
        instance: &mut Instance,
        settings: &JointSettings,
        previous: Option<(&[Mat4], f32)>,
        options: RagdollOptions,
    ) -> Result<Self, RagdollError> {
        let n = asset.nodes.len();
        let worlds: Vec<Mat4> = instance.worlds().to_vec();
        if worlds.len() != n {
            return Err(RagdollError::Mismatch(format!("{} worlds for {n} nodes", worlds.len())));
        }
        let mut is_joint = vec![false; n];
        for &j in asset.skins.iter().flat_map(|s| s.joints.iter()) {
            if let Some(slot) = is_joint.get_mut(j as usize) {
                *slot = true;
            }
        }
        if !is_joint.iter().any(|&j| j) {
            return Err(RagdollError::NoSkeleton);
        }
        let at = |j: usize| worlds[j].w_axis.truncate();
        let (lo, hi) = (0..n)
            .filter(|&j| is_joint[j])
            .map(at)
            .fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(a, b), p| (a.min(p), b.max(p)));
        let size = (hi - lo).length().max(1e-4);

        // The skinned vertices, each with the joint that moves it most.
        let mut vertices: Vec<Vec<Vec3>> = vec![Vec::new(); n];
        let (mut positions, mut normals) = (Vec::new(), Vec::new());
        let mut floor = f32::INFINITY;
        for (node_index, node) in asset.nodes.iter().enumerate() {
            let (Some(mesh), Some(skin)) = (node.mesh, node.skin) else { continue };
            let (Some(mesh), Some(skin)) = (asset.meshes.get(mesh as usize), asset.skins.get(skin as usize)) else {
                continue;
            };
            let Ok(node_index) = u32::try_from(node_index) else { continue };
            for (p, prim) in mesh.primitives.iter().enumerate() {
                if !prim.is_skinned()
                    || instance.deform_primitive(asset, node_index, p, &mut positions, &mut normals).is_err()
                {
                    continue;
                }
                for (v, (joints, weights)) in positions.iter().zip(prim.joints.iter().zip(&prim.weights)) {
                    let v = Vec3::from(*v);
                    if !v.is_finite() {
                        continue;
                    }
                    floor = floor.min(v.y);
                    let best = (0..8).max_by(|&a, &b| weights[a].total_cmp(&weights[b])).unwrap_or(0);
                    if let Some(&joint) = skin.joints.get(joints[best] as usize)
                        && let Some(list) = vertices.get_mut(joint as usize)
                    {
                        list.push(v);
                    }
                }
            }
        }
        if !floor.is_finite() {
            floor = lo.y;
        }
        if let Some(ground) = options.ground.filter(|g| g.is_finite()) {
            floor = ground;
        }

        // Children joints and subtree sizes (for the main child of a branching joint).
        let parents: Vec<Option<NodeIndex>> = asset.nodes.iter().map(|node| node.parent).collect();
        let mut subtree = vec![0usize; n];
        // Skinned vertices each joint's subtree carries: a joint that carries none (an IK
        // control or a weapon slot) gets no body.
        let mut carries = vec![0usize; n];
        for &node in asset.order.iter().rev() {
            let node = node as usize;
            if is_joint[node] {
                subtree[node] += 1;
            }
            carries[node] += vertices[node].len();
            if let Some(p) = parents[node] {
                let (s, c) = (subtree[node], carries[node]);
                subtree[p as usize] += s;
                carries[p as usize] += c;
            }
        }

        let mut world = PhysicsWorld::new();
        let scale = size / PERSON_HEIGHT;
        world.gravity = Vec3::new(0.0, -options.gravity * scale, 0.0);
        world.integration_parameters.dt = 1.0 / (STEP_HZ * SUBSTEPS as f32);
        world.integration_parameters.length_unit = scale.max(1e-3);
        world.integration_parameters.num_solver_iterations = 8;
        // Ragdoll bodies collide with the ground, the obstacles and thrown balls, not with each other.
        let bones = InteractionGroups::new(Group::GROUP_1, Group::GROUP_2 | Group::GROUP_3, InteractionTestMode::And);
        let ground_groups =
            InteractionGroups::new(Group::GROUP_2, Group::GROUP_1 | Group::GROUP_3, InteractionTestMode::And);
        let thick = size;
        world.insert(
            RigidBodyBuilder::fixed().translation(Vec3::new(lo.x.midpoint(hi.x), floor - thick, lo.z.midpoint(hi.z))),
            ColliderBuilder::cuboid(size * 50.0, thick, size * 50.0)
                .friction(options.friction)
                .collision_groups(ground_groups),
        );

        let mut bodies: Vec<RagdollBody> = Vec::new();
        let mut body_of = vec![usize::MAX; n];
        for &node in &asset.order {
            let j = node as usize;
            if !is_joint[j] {
                continue;
            }
            let origin = at(j);
            let main_child = asset.nodes[j]
                .children
                .iter()
                .copied()
                .filter(|&c| is_joint[c as usize] && carries[c as usize] > 0)
                .max_by_key(|&c| (subtree[c as usize], std::cmp::Reverse(c)));
            let tip = match main_child {
                Some(c) => at(c as usize),
                None => {
                    // A leaf reaches along its parent bone as far as its vertices go.
                    let dir = parents[j].map(|p| origin - at(p as usize)).and_then(Vec3::try_normalize);
                    let Some(dir) = dir else { continue };
                    let reach = vertices[j].iter().map(|v| (*v - origin).dot(dir)).fold(0.0f32, f32::max);
                    origin + dir * reach
                }
            };
            let bone = tip - origin;
            let length = bone.length();
            if length < MIN_BONE * size || !length.is_finite() || carries[j] == 0 {
                continue;
            }
            let dir = bone / length;
            let mut distances: Vec<f32> = vertices[j]
                .iter()
                .map(|v| {
                    let t = (*v - origin).dot(dir).clamp(0.0, length);
                    v.distance(origin + dir * t)
                })
                .filter(|d| d.is_finite())
                .collect();
            distances.sort_by(f32::total_cmp);
            let radius = distances.get(distances.len() * 7 / 10).copied().unwrap_or(length * 0.2);
            let radius = radius.clamp(length * 0.1, length * 0.5).max(size * 0.005);
            let half_height = (length * 0.5 - radius * 0.5).max(length * 0.05);
            let rotation = Quat::from_rotation_arc(Vec3::Y, dir);
            let center = origin + bone * 0.5;
            let mut builder = RigidBodyBuilder::dynamic()
                .pose(pose(rotation, center))
                .linear_damping(options.damping)
                .angular_damping(options.damping)
                .ccd_enabled(true);
            if let Some((before, dt)) = previous
                && dt > 0.0
                && before.len() == n
            {
                let (_, r0, t0) = rigid(&before[j]);
                let (_, r1, t1) = rigid(&worlds[j]);
                let moved = (t1 - t0) / dt;
                let (axis, angle) = (r1 * r0.conjugate()).normalize().to_axis_angle();
                let angle = if angle > std::f32::consts::PI { angle - std::f32::consts::TAU } else { angle };
                if moved.is_finite() && axis.is_finite() && angle.is_finite() {
                    let spin = axis * angle / dt;
                    builder = builder.linvel(moved + spin.cross(center - t1)).angvel(spin);
                }
            }
            let collider = ColliderBuilder::capsule_y(half_height, radius).density(1.0).collision_groups(bones);
            let (handle, _) = world.insert(builder, collider);
            if let Some(rb) = world.bodies.get_mut(handle) {
                let activation = rb.activation_mut();
                // rapier lets a body sleep when its farthest point moves less than twice this
                // threshold (times `length_unit`, the skeleton's size over PERSON_HEIGHT) per second.
                activation.normalized_linear_threshold = SLEEP_SPEED * PERSON_HEIGHT * 0.5;
                activation.time_until_sleep = SLEEP_AFTER;
            }
            let (scale_j, rot_j, trans_j) = rigid(&worlds[j]);
            let body_from_joint = (rotation.conjugate() * rot_j, rotation.conjugate() * (trans_j - center));

            // The joint to the parent body, in this joint's rest frame.
            let mut parent_body = parents[j];
            while let Some(p) = parent_body {
                if body_of[p as usize] != usize::MAX {
                    break;
                }
                parent_body = parents[p as usize];
            }
            let limit = settings.limits.get(j).copied().unwrap_or_default();
            // A limit the start pose is outside of (a hinge guessed from a name about the wrong
            // axis) would snap the bone into it and keep fighting the ground: such a joint gets
            // the moderate range of an unlimited one.
            let local = instance.pose().locals.get(j).map_or(asset.nodes[j].rest.rotation, |l| l.rotation);
            let limit = if limit.allows(asset.nodes[j].rest.rotation, local, START_LIMIT_SLACK) {
                limit
            } else {
                JointLimit::Free
            };
            let attached = parent_body.is_some();
            let mut link = None;
            if let Some(p) = parent_body {
                let parent = &bodies[body_of[p as usize]];
                let parent_pose = world.bodies[parent.handle].position();
                let parent_rotation = parents[j].map_or(Quat::IDENTITY, |pn| rigid(&worlds[pn as usize]).1);
                let rest_frame = (parent_rotation * asset.nodes[j].rest.rotation).normalize();
                let axis = match limit {
                    JointLimit::Hinge { axis, .. } | JointLimit::Ball { axis, .. } => axis,
                    JointLimit::Free => crate::job::ik::bone_axis(asset, &asset.nodes[j]),
                };
                let to_axis = Quat::from_rotation_arc(Vec3::X, axis.try_normalize().unwrap_or(Vec3::X));
                let frame1 = parent_pose.inverse() * pose(rest_frame * to_axis, origin);
                let frame2 = pose(rotation, center).inverse() * pose(rot_j * to_axis, origin);
                let powered = options.strength.is_finite() && options.strength > 0.0;
                let joint = world.insert_impulse_joint(parent.handle, handle, joint_of(limit, frame1, frame2, powered));
                link = Some(Link { parent: parent.handle, frame1, frame2, joint });
            }
            body_of[j] = bodies.len();
            bodies.push(RagdollBody {
                joint: node,
                radius,
                half_height,
                limit,
                attached,
                handle,
                link,
                body_from_joint,
                scale: scale_j,
                previous: (rotation, center),
            });
        }
        if bodies.is_empty() {
            return Err(RagdollError::NoBones);
        }
        // Each body also collides as the hull of the skinned vertices it carries (its joint's,
        // and those of the joints without a body that ride on it: fingers, toes), so that the
        // skin, not only the capsules, stays above the ground and on the obstacles. Massless:
        // the capsules keep the dynamics.
        let mut carried: Vec<Vec<Vec3>> = vec![Vec::new(); bodies.len()];
        for (j, list) in vertices.iter().enumerate() {
            let mut at = Some(j as NodeIndex);
            while let Some(node) = at {
                if body_of[node as usize] != usize::MAX {
                    break;
                }
                at = parents[node as usize];
            }
            let Some(b) = at.map(|node| body_of[node as usize]) else { continue };
            let Some(body) = bodies.get(b) else { continue };
            let p = world.bodies[body.handle].position();
            let (rotation, center) = (p.rotation, p.translation);
            carried[b].extend(list.iter().map(|v| rotation.conjugate() * (*v - center)));
        }
        for (body, points) in bodies.iter().zip(carried) {
            if points.len() < 4 {
                continue;
            }
            // Thinned to a bounded count (the hull's extremes survive thinning well on dense skins).
            let stride = points.len().div_ceil(MAX_HULL_POINTS);
            let points: Vec<Vec3> = points.into_iter().step_by(stride).collect();
            if let Some(hull) = ColliderBuilder::convex_hull(&points) {
                world.insert_collider(
                    hull.density(0.0).friction(options.friction).collision_groups(bones),
                    Some(body.handle),
                );
            }
        }
        Ok(Self {
            world,
            bodies,
            body_of,
            start_locals: instance.pose().locals.clone(),
            order: asset.order.clone(),
            parents,
            accumulator: 0.0,
            steps: 0,
            calm_for: 0.0,
            undisturbed: 0.0,
            obstacles: Vec::new(),
            balls: Vec::new(),
            friction: options.friction,
            strength: if options.strength.is_finite() { options.strength.clamp(0.0, 1.0) } else { 0.0 },
            targets: Vec::new(),
            target_velocities: Vec::new(),
            since_targets: 0,
            damping: options.damping,
            ground: floor,
            size,
            worlds: vec![Mat4::IDENTITY; n],
        })
    }

    /// The simulated bones.
    pub fn bodies(&self) -> &[RagdollBody] {
        &self.bodies
    }

    /// Height of the ground plane (the lowest skinned vertex when the ragdoll started).
    pub fn ground(&self) -> f32 {
        self.ground
    }

    /// The skeleton's size (its joints' bounding-box diagonal), the scale of the simulation.
    pub fn size(&self) -> f32 {
        self.size
    }

    /// Fixed steps taken so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// A body's world pose now (rotation, centre); `None` for an unknown index.
    pub fn body_pose(&self, body: usize) -> Option<(Quat, Vec3)> {
        let b = self.bodies.get(body)?;
        let p = self.world.bodies.get(b.handle)?.position();
        Some((p.rotation, p.translation))
    }

    /// The fastest body's speed, in model units per second (near 0: at rest).
    pub fn max_speed(&self) -> f32 {
        self.bodies
            .iter()
            .filter_map(|b| self.world.bodies.get(b.handle))
            .map(|rb| rb.linvel().length())
            .fold(0.0, f32::max)
    }

    /// Sets gravity (m/s² for a person-sized skeleton) and damping while running.
    pub fn set_options(&mut self, options: RagdollOptions) {
        let scale = self.size / PERSON_HEIGHT;
        self.world.gravity = Vec3::new(0.0, -options.gravity * scale, 0.0);
        self.damping = options.damping;
        self.calm_for = 0.0;
        self.undisturbed = 0.0;
        let strength = if options.strength.is_finite() { options.strength.clamp(0.0, 1.0) } else { 0.0 };
        // Powered joints are free (the drive holds the clip's range), limp ones limited: a
        // change of kind rebuilds every joint.
        if (strength > 0.0) != (self.strength > 0.0) {
            for b in &mut self.bodies {
                let Some(link) = &mut b.link else { continue };
                self.world.remove_impulse_joint(link.joint);
                let joint = joint_of(b.limit, link.frame1, link.frame2, strength > 0.0);
                link.joint = self.world.insert_impulse_joint(link.parent, b.handle, joint);
            }
        }
        self.strength = strength;
        for b in &self.bodies {
            if let Some(rb) = self.world.bodies.get_mut(b.handle) {
                rb.set_linear_damping(options.damping);
                rb.set_angular_damping(options.damping);
                // A sleeping ragdoll would not feel the new gravity.
                rb.wake_up(true);
            }
        }
    }

    /// Pushes body `body` at world point `at` so that it gains `velocity` (model units per
    /// second): an impulse of its mass times that velocity.
    pub fn push(&mut self, body: usize, velocity: Vec3, at: Vec3) {
        if !(velocity.is_finite() && at.is_finite()) {
            return;
        }
        if let Some(rb) = self.bodies.get(body).and_then(|b| self.world.bodies.get_mut(b.handle)) {
            let impulse = velocity * rb.mass();
            rb.apply_impulse_at_point(impulse, at, true);
            self.calm_for = 0.0;
            self.undisturbed = 0.0;
        }
    }

    /// Whether every body and thrown ball has come to rest: slower than 3 % of the skeleton's
    /// size per second, after at least half a second (a body dropped from stillness is not yet
    /// at rest). A ragdoll lying on something is damped once calm and put to sleep (velocities
    /// zero) once slower than 20 % of its size per second, until pushed, hit or given options.
    pub fn is_resting(&self) -> bool {
        self.steps as f32 >= STEP_HZ * 0.5
            && self.max_speed() < REST_SPEED * self.size
            && self.balls_speed() < REST_SPEED * self.size
    }

    /// The body nearest to the world-space ray `origin + t·dir` (within its capsule radius
    /// times `slack`), and the hit point.
    pub fn pick(&self, origin: Vec3, dir: Vec3, slack: f32) -> Option<(usize, Vec3)> {
        let dir = dir.try_normalize()?;
        let mut best: Option<(f32, usize, Vec3)> = None;
        for (i, b) in self.bodies.iter().enumerate() {
            let (rotation, center) = self.body_pose(i)?;
            let axis = rotation * Vec3::Y;
            // Closest points of the ray and the capsule's segment.
            let (a, bb) = (center - axis * b.half_height, center + axis * b.half_height);
            let (t, s) = closest_ray_segment(origin, dir, a, bb);
            let p = origin + dir * t;
            let q = a + (bb - a) * s;
            if p.distance(q) <= b.radius * slack && best.is_none_or(|(bt, _, _)| t < bt) {
                best = Some((t, i, q));
            }
        }
        best.map(|(_, i, q)| (i, q))
    }

    /// Advances the simulation by `dt` seconds of wall time in fixed 1/60 s steps (at most
    /// a quarter of a second per call).
    pub fn step(&mut self, dt: f32) {
        if !(dt.is_finite() && dt > 0.0) {
            return;
        }
        self.accumulator += dt.min(MAX_FRAME);
        let step = 1.0 / STEP_HZ;
        while self.accumulator >= step {
            self.step_once();
            self.accumulator -= step;
        }
    }

    /// Replaces the obstacles of the world (fixed: they do not move; the bodies and thrown
    /// balls collide with them). Sleeping bodies wake.
    pub fn set_obstacles(&mut self, obstacles: &[Obstacle]) {
        for handle in self.obstacles.drain(..) {
            self.world.remove_body(handle);
        }
        let groups = InteractionGroups::new(Group::GROUP_2, Group::GROUP_1 | Group::GROUP_3, InteractionTestMode::And);
        for obstacle in obstacles.iter().take(obstacles::MAX_OBSTACLES) {
            for piece in obstacle.pieces() {
                let (body, collider) = match piece {
                    Piece::Cuboid(center, half, rotation) => {
                        (pose(rotation, center), ColliderBuilder::cuboid(half.x, half.y, half.z))
                    }
                    Piece::Ball(center, radius) => (pose(Quat::IDENTITY, center), ColliderBuilder::ball(radius)),
                    Piece::Capsule(center, half, radius, rotation) => {
                        (pose(rotation, center), ColliderBuilder::capsule_y(half, radius))
                    }
                    Piece::Hull(points) => match ColliderBuilder::convex_hull(&points) {
                        Some(hull) => (pose(Quat::IDENTITY, Vec3::ZERO), hull),
                        None => continue,
                    },
                };
                let (handle, _) = self.world.insert(
                    RigidBodyBuilder::fixed().pose(body),
                    collider.friction(self.friction).collision_groups(groups),
                );
                self.obstacles.push(handle);
            }
        }
        self.wake();
    }

    /// Throws a ball of `radius` from `from` at `velocity` (model units): it collides with the
    /// bodies, the ground, the obstacles and other balls (at most [`MAX_BALLS`]; the oldest goes).
    pub fn throw_ball(&mut self, from: Vec3, velocity: Vec3, radius: f32) {
        if !(from.is_finite() && velocity.is_finite() && radius.is_finite() && radius > 0.0) {
            return;
        }
        if self.balls.len() >= MAX_BALLS {
            let (old, _) = self.balls.remove(0);
            self.world.remove_body(old);
        }
        let groups = InteractionGroups::new(Group::GROUP_3, Group::ALL, InteractionTestMode::And);
        let (handle, _) = self.world.insert(
            RigidBodyBuilder::dynamic().translation(from).linvel(velocity).ccd_enabled(true),
            ColliderBuilder::ball(radius).density(BALL_DENSITY).friction(self.friction).collision_groups(groups),
        );
        self.balls.push((handle, radius));
        self.wake();
    }

    /// The thrown balls now: centre and radius.
    pub fn balls(&self) -> Vec<(Vec3, f32)> {
        (self.balls.iter()).filter_map(|&(h, r)| Some((self.world.bodies.get(h)?.position().translation, r))).collect()
    }

    /// Powered ragdoll: the pose each body is driven towards from now on, as world transforms
    /// of every node (an instance's worlds after evaluating the animation), `dt` seconds of the
    /// animation after the targets before (0: the same moment; their velocities stay). Until
    /// the next call the targets move on at those velocities. Ignored with strength 0 or worlds
    /// of another asset.
    pub fn set_targets(&mut self, worlds: &[Mat4], dt: f32) {
        if self.strength <= 0.0 || worlds.len() != self.parents.len() {
            return;
        }
        self.targets.resize(self.bodies.len(), None);
        self.target_velocities.resize(self.bodies.len(), (Vec3::ZERO, Vec3::ZERO));
        let dt = if dt.is_finite() && dt > 1e-6 { Some(dt) } else { None };
        for ((b, target), velocity) in self.bodies.iter().zip(&mut self.targets).zip(&mut self.target_velocities) {
            let Some(world) = worlds.get(b.joint as usize) else { continue };
            // The body sits where its joint puts it: joint = body · body_from_joint.
            let (_, r, t) = rigid(world);
            let (jr, jt) = b.body_from_joint;
            let rotation = (r * jr.conjugate()).normalize();
            let center = t - rotation * jt;
            let next = (rotation.is_finite() && center.is_finite()).then_some((rotation, center));
            if let (Some(dt), Some((r0, c0)), Some((r1, c1))) = (dt, *target, next) {
                let (axis, angle) = (r1 * r0.conjugate()).normalize().to_axis_angle();
                let angle = if angle > std::f32::consts::PI { angle - std::f32::consts::TAU } else { angle };
                let spin = if axis.is_finite() && angle.is_finite() { axis * angle / dt } else { Vec3::ZERO };
                let moved = (c1 - c0) / dt;
                *velocity = if moved.is_finite() { (moved, spin) } else { (Vec3::ZERO, Vec3::ZERO) };
            } else if next.is_none() {
                *velocity = (Vec3::ZERO, Vec3::ZERO);
            }
            *target = next;
        }
        self.since_targets = 0;
    }

    /// Wakes every body and starts the calm over (something changed around them).
    fn wake(&mut self) {
        self.calm_for = 0.0;
        self.undisturbed = 0.0;
        for b in &self.bodies {
            if let Some(rb) = self.world.bodies.get_mut(b.handle) {
                rb.wake_up(true);
            }
        }
    }

    /// Drives each body's velocity towards its target (powered ragdoll): the velocity that
    /// closes the gap in [`POWER_TIME`] seconds, blended in by the strength each step, with
    /// gravity compensated in proportion.
    fn drive(&mut self) {
        if self.strength <= 0.0 || self.targets.len() != self.bodies.len() {
            return;
        }
        let dt = 1.0 / STEP_HZ;
        let k = (self.strength * POWER_GAIN).clamp(0.0, 1.0);
        let lift = -self.world.gravity * dt * self.strength;
        for ((b, target), (follow_v, follow_w)) in self.bodies.iter().zip(&self.targets).zip(&self.target_velocities) {
            let (Some((rotation, center)), Some(rb)) = (target, self.world.bodies.get_mut(b.handle)) else {
                continue;
            };
            let p = rb.position();
            // The target moved on at its velocity since it was set.
            let ahead = self.since_targets as f32 / STEP_HZ;
            let center = *center + *follow_v * ahead;
            let rotation = (Quat::from_scaled_axis(*follow_w * ahead) * *rotation).normalize();
            let want_v = (center - p.translation) / POWER_TIME + *follow_v;
            let (axis, angle) = (rotation * p.rotation.conjugate()).normalize().to_axis_angle();
            let angle = if angle > std::f32::consts::PI { angle - std::f32::consts::TAU } else { angle };
            let want_w =
                if axis.is_finite() && angle.is_finite() { axis * angle / POWER_TIME } else { Vec3::ZERO } + *follow_w;
            let (v, w) = (rb.linvel(), rb.angvel());
            rb.set_linvel(v + (want_v - v) * k + lift, true);
            rb.set_angvel(w + (want_w - w) * k, true);
        }
    }

    /// One fixed step.
    pub fn step_once(&mut self) {
        for b in &mut self.bodies {
            if let Some(rb) = self.world.bodies.get(b.handle) {
                let p = rb.position();
                b.previous = (p.rotation, p.translation);
            }
        }
        self.drive();
        for _ in 0..SUBSTEPS {
            self.world.step();
        }
        self.since_targets = self.since_targets.saturating_add(1);
        // Balls that rolled off the ground fall for ever: they go.
        let floor = self.ground - 10.0 * self.size;
        let world = &mut self.world;
        self.balls.retain(|&(h, _)| {
            let keep = world.bodies.get(h).is_some_and(|b| b.position().translation.y > floor);
            if !keep {
                world.remove_body(h);
            }
            keep
        });
        self.steps += 1;
        self.settle();
    }

    /// Raises the damping while the ragdoll is calm (see [`CALM_SPEED`]), back to what was
    /// asked for as soon as it is not.
    fn settle(&mut self) {
        // A powered ragdoll follows its targets: no settling damping, no sleep.
        if self.strength > 0.0 {
            self.calm_for = 0.0;
            for b in &self.bodies {
                if let Some(rb) = self.world.bodies.get_mut(b.handle)
                    && rb.linear_damping() != self.damping
                {
                    rb.set_linear_damping(self.damping);
                    rb.set_angular_damping(self.damping);
                }
            }
            return;
        }
        // A ball in flight is a disturbance until it has hit and slowed down.
        if self.balls_speed() > CALM_SPEED * self.size {
            self.calm_for = 0.0;
            self.undisturbed = 0.0;
        }
        // Only a ragdoll that lies on something settles: one falling through the air keeps its speed.
        let supported = self.touching();
        let speed = self.max_point_speed();
        let calm = supported && speed < CALM_SPEED * self.size;
        self.calm_for = if calm { self.calm_for + 1.0 / STEP_HZ } else { 0.0 };
        self.undisturbed += 1.0 / STEP_HZ;
        // Calm, or left alone long enough that a fall is over.
        let settling = if supported { self.calm_for.max(self.undisturbed - IDLE_SETTLE) } else { 0.0 };
        let t = (settling / SETTLE_AFTER).clamp(0.0, 1.0);
        let damping = self.damping + SETTLE_DAMPING * t * t * (3.0 - 2.0 * t);
        // Settled, calm and slow, what still moves is the solver rocking a body between a limit
        // and the ground: the ragdoll is put to sleep (a push, a hit or new options wake it).
        let sleep = calm && settling >= SETTLE_AFTER + SLEEP_AFTER_SETTLED && speed < SLEEP_SPEED * self.size;
        for b in &self.bodies {
            if let Some(rb) = self.world.bodies.get_mut(b.handle) {
                if rb.linear_damping() != damping {
                    rb.set_linear_damping(damping);
                    rb.set_angular_damping(damping);
                }
                if sleep && !rb.is_sleeping() {
                    rb.sleep();
                }
            }
        }
    }

    /// Whether any body touches the ground, an obstacle or a ball.
    fn touching(&self) -> bool {
        self.bodies.iter().filter_map(|b| self.world.bodies.get(b.handle)).any(|rb| {
            rb.colliders().iter().any(|&c| self.world.contact_pairs_with(c).any(|p| p.has_any_active_contact()))
        })
    }

    /// The fastest thrown ball that is awake, model units per second.
    fn balls_speed(&self) -> f32 {
        (self.balls.iter())
            .filter_map(|&(h, _)| self.world.bodies.get(h))
            .filter(|b| !b.is_sleeping())
            .map(|b| b.linvel().length())
            .fold(0.0, f32::max)
    }

    /// The fastest point of any body (centre speed plus spin times its half length), model
    /// units per second.
    fn max_point_speed(&self) -> f32 {
        self.bodies
            .iter()
            .filter_map(|b| Some((b, self.world.bodies.get(b.handle)?)))
            .map(|(b, rb)| rb.linvel().length() + rb.angvel().length() * (b.half_height + b.radius))
            .fold(0.0, f32::max)
    }

    /// Writes the skeleton as the bodies hold it into `pose`'s locals: joints with a body
    /// follow it (interpolated between the last two steps by the time left over), the others
    /// keep their locals from when the ragdoll started. With `weight` < 1 the result is
    /// blended (slerp) over the locals already in `pose` (the animation), to hand back.
    pub fn write_pose(&mut self, pose: &mut Pose, weight: f32) {
        let n = self.parents.len();
        if pose.locals.len() != n || self.start_locals.len() != n || self.worlds.len() != n {
            return;
        }
        let alpha = (self.accumulator * STEP_HZ).clamp(0.0, 1.0);
        let weight = weight.clamp(0.0, 1.0);
        let worlds = &mut self.worlds;
        for &node in &self.order {
            let j = node as usize;
            let parent_world = self.parents[j].map_or(Mat4::IDENTITY, |p| worlds[p as usize]);
            let body = self.body_of[j];
            let handle = self.bodies.get(body).map(|b| (b, self.world.bodies.get(b.handle)));
            let local = match handle {
                Some((b, Some(rb))) => {
                    let now = rb.position();
                    let rotation = b.previous.0.slerp(now.rotation, alpha).normalize();
                    let center = b.previous.1.lerp(now.translation, alpha);
                    let (jr, jt) = b.body_from_joint;
                    let start = self.start_locals[j];
                    if b.attached {
                        // A joint takes only its rotation from its body: its offset from the
                        // parent stays the bone's, so bones keep their lengths exactly even
                        // where the solver lets a joint's two anchors drift apart a little.
                        let parent_rotation = rigid(&parent_world).1;
                        let r = (parent_rotation.conjugate() * rotation * jr).normalize();
                        if r.is_finite() { Transform { rotation: r, ..start } } else { start }
                    } else {
                        let world =
                            Mat4::from_scale_rotation_translation(b.scale, rotation * jr, center + rotation * jt);
                        let (s, r, t) = (parent_world.inverse() * world).to_scale_rotation_translation();
                        if s.is_finite() && r.is_finite() && t.is_finite() {
                            Transform { translation: t, rotation: r.normalize(), scale: s }
                        } else {
                            start
                        }
                    }
                }
                // A joint without a body (or with one rapier no longer has) keeps its start local.
                _ => self.start_locals[j],
            };
            let out = &mut pose.locals[j];
            let blended = if weight >= 1.0 {
                local
            } else {
                Transform {
                    translation: out.translation.lerp(local.translation, weight),
                    rotation: out.rotation.slerp(local.rotation, weight).normalize(),
                    scale: out.scale.lerp(local.scale, weight),
                }
            };
            *out = blended;
            worlds[j] = parent_world * blended.to_mat4();
        }
    }
}

/// Parameters `(t ≥ 0, s ∈ [0, 1])` of the closest points of the ray `o + t·d` (unit `d`) and
/// the segment `a..b`.
fn closest_ray_segment(o: Vec3, d: Vec3, a: Vec3, b: Vec3) -> (f32, f32) {
    let e = b - a;
    let w = o - a;
    let (dd, de, ee) = (1.0, d.dot(e), e.dot(e));
    let (dw, ew) = (d.dot(w), e.dot(w));
    let denom = dd * ee - de * de;
    let s = if denom.abs() > 1e-12 { ((dd * ew - de * dw) / denom).clamp(0.0, 1.0) } else { 0.0 };
    let t = (a + e * s - o).dot(d).max(0.0);
    (t, s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::load;

    const MODELS: [&str; 5] = [
        "khronos/CesiumMan/glTF-Binary/CesiumMan.glb",
        "khronos/Fox/glTF-Binary/Fox.glb",
        "khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb",
        "threejs/RobotExpressive/RobotExpressive.glb",
        "kaykit/Knight/Knight.glb",
    ];

    /// Simulates `asset` from its first clip at 0.3 s for `seconds`; returns every node's
    /// world position at the end, the start worlds, and the ragdoll.
    fn simulate(asset: &Asset, seconds: f32) -> (Vec<Vec3>, Vec<Mat4>, Ragdoll, Instance) {
        let mut instance = Instance::new(asset);
        let clip = (!asset.clips.is_empty()).then_some(0);
        instance.evaluate(asset, clip, 0.3).expect("evaluate");
        let start = instance.worlds().to_vec();
        let settings = JointSettings::humanoid(asset);
        let mut ragdoll =
            Ragdoll::new(asset, &mut instance, &settings, None, RagdollOptions::default()).expect("ragdoll");
        let steps = (seconds * STEP_HZ).round() as u32;
        for _ in 0..steps {
            ragdoll.step_once();
            ragdoll.write_pose(instance.pose_mut(), 1.0);
            instance.update(asset).expect("update");
            assert!(instance.worlds().iter().all(|w| w.is_finite()), "NaN after {} steps", ragdoll.steps());
        }
        let positions = instance.worlds().iter().map(|w| w.w_axis.truncate()).collect();
        (positions, start, ragdoll, instance)
    }

    #[test]
    fn every_model_falls_and_settles_deterministically_keeping_bones_and_limits() {
        for path in MODELS {
            let asset = load(path);
            let (a, start, ragdoll, instance) = simulate(&asset, 12.0);
            let (b, _, _, _) = simulate(&asset, 12.0);
            assert!(a == b, "{path}: two runs differ");
            let size = ragdoll.size();
            // Bone lengths: each joint to its parent joint.
            let joints: std::collections::HashSet<u32> =
                asset.skins.iter().flat_map(|s| s.joints.iter().copied()).collect();
            let mut worst = 0.0f32;
            for &j in &joints {
                let Some(p) = asset.nodes[j as usize].parent.filter(|p| joints.contains(p)) else { continue };
                let before = start[j as usize].w_axis.truncate().distance(start[p as usize].w_axis.truncate());
                if before < size * 1e-3 {
                    continue;
                }
                let after = a[j as usize].distance(a[p as usize]);
                worst = worst.max((after / before - 1.0).abs());
            }
            assert!(worst <= 0.01, "{path}: a bone changed length by {:.2}%", worst * 100.0);
            // At rest, above the ground.
            let speed = ragdoll.max_speed();
            assert!(ragdoll.is_resting(), "{path}: still moving at {speed} (size {size})");
            let start_height = start.iter().map(|w| w.w_axis.y).fold(f32::NEG_INFINITY, f32::max);
            let end_height = a.iter().map(|p| p.y).fold(f32::NEG_INFINITY, f32::max);
            assert!(end_height < start_height - 0.1 * size, "{path}: did not fall ({start_height} -> {end_height})");
            for (i, body) in ragdoll.bodies().iter().enumerate() {
                let (rotation, center) = ragdoll.body_pose(i).expect("a body");
                let reach = (rotation * Vec3::Y * body.half_height).y.abs() + body.radius;
                let bottom = center.y - reach;
                assert!(
                    bottom >= ragdoll.ground() - 0.01 * size,
                    "{path}: body {i} sank to {bottom} (ground {})",
                    ragdoll.ground()
                );
            }
            // Joint limits (in the joints' rest frames) within 2°.
            let tolerance = 2f32.to_radians();
            for body in ragdoll.bodies() {
                let j = body.joint as usize;
                let (rest, local) = (asset.nodes[j].rest.rotation, instance.pose().locals[j].rotation);
                if !matches!(body.limit, JointLimit::Free) {
                    let clamped = body.limit.clamp(rest, local);
                    let off = clamped.angle_between(local).to_degrees();
                    assert!(
                        body.limit.allows(rest, local, tolerance),
                        "{path}: {:?} leaves its limit by {off:.2}°",
                        asset.nodes[j].name
                    );
                }
            }
            // Asleep, a push still wakes it.
            let mut pushed = ragdoll;
            let (_, center) = pushed.body_pose(0).expect("a body");
            pushed.push(0, Vec3::Y * size, center);
            pushed.step_once();
            assert!(pushed.max_speed() > REST_SPEED * size, "{path}: a push does not wake the ragdoll");
            eprintln!(
                "{path}: {} bodies, size {size:.3}, bones within {:.3}%, speed {speed:.4}",
                pushed.bodies().len(),
                worst * 100.0
            );
        }
    }

    /// Every skinned vertex of `instance` now (model space).
    fn skinned(asset: &Asset, instance: &mut Instance) -> Vec<Vec3> {
        let (mut positions, mut normals, mut out) = (Vec::new(), Vec::new(), Vec::new());
        for (n, node) in asset.nodes.iter().enumerate() {
            let (Some(mesh), Some(_)) = (node.mesh, node.skin) else { continue };
            for p in 0..asset.meshes[mesh as usize].primitives.len() {
                if instance.deform_primitive(asset, n as u32, p, &mut positions, &mut normals).is_ok() {
                    out.extend(positions.iter().map(|v| Vec3::from(*v)));
                }
            }
        }
        out
    }

    /// Drops `asset` from its first clip at 0.3 s for `seconds` (on `obstacles`, with the
    /// ground at `ground` when given, the start pose lifted by `lift`) and returns the deepest any
    /// skinned vertex went below the ground, the fastest one moved after `settle` seconds (both
    /// as fractions of the skeleton's size, per second for the speed), and the last vertices.
    fn vertex_report(
        asset: &Asset,
        seconds: f32,
        settle: f32,
        obstacles: &[Obstacle],
        lift: f32,
    ) -> (f32, f32, Vec<Vec3>, f32, f32) {
        vertex_report_with(asset, seconds, settle, obstacles, lift, RagdollOptions::default())
    }

    /// [`vertex_report`] with `options` (their ground is the start pose's floor).
    fn vertex_report_with(
        asset: &Asset,
        seconds: f32,
        settle: f32,
        obstacles: &[Obstacle],
        lift: f32,
        options: RagdollOptions,
    ) -> (f32, f32, Vec<Vec3>, f32, f32) {
        let mut instance = Instance::new(asset);
        let clip = (!asset.clips.is_empty()).then_some(0);
        instance.evaluate(asset, clip, 0.3).expect("evaluate");
        let floor = skinned(asset, &mut instance).iter().map(|v| v.y).fold(f32::INFINITY, f32::min);
        if lift != 0.0 {
            let roots: Vec<usize> = (0..asset.nodes.len()).filter(|&n| asset.nodes[n].parent.is_none()).collect();
            for r in roots {
                instance.pose_mut().locals[r].translation.y += lift;
            }
            instance.update(asset).expect("update");
        }
        let settings = JointSettings::humanoid(asset);
        let options = RagdollOptions { ground: Some(floor), ..options };
        let mut ragdoll = Ragdoll::new(asset, &mut instance, &settings, None, options).expect("ragdoll");
        ragdoll.set_obstacles(obstacles);
        let (size, ground) = (ragdoll.size(), ragdoll.ground());
        let (mut deepest, mut fastest) = (0.0f32, 0.0f32);
        let mut last: Vec<Vec3> = Vec::new();
        for step in 0..(seconds * STEP_HZ).round() as u32 {
            ragdoll.step_once();
            ragdoll.write_pose(instance.pose_mut(), 1.0);
            instance.update(asset).expect("update");
            let now = skinned(asset, &mut instance);
            deepest = deepest.max(now.iter().map(|v| ground - v.y).fold(0.0, f32::max) / size);
            if step as f32 >= settle * STEP_HZ && last.len() == now.len() {
                let speed = now.iter().zip(&last).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max) * STEP_HZ;
                fastest = fastest.max(speed / size);
            }
            last = now;
        }
        (deepest, fastest, last, size, ground)
    }

    #[test]
    fn skinned_vertices_stay_above_the_ground_and_come_to_rest() {
        for path in MODELS {
            let asset = load(path);
            let (deepest, fastest, last, size, ground) = vertex_report(&asset, 6.0, 4.0, &[], 0.0);
            // At rest on the ground, not stopped above it.
            let lowest = last.iter().map(|v| v.y).fold(f32::INFINITY, f32::min) - ground;
            assert!(lowest < 0.01 * size, "{path}: resting {:.2}% of the size above the ground", lowest / size * 100.0);
            eprintln!(
                "{path}: deepest {:.3}% of the size, fastest after 4 s {:.3}%/s",
                deepest * 100.0,
                fastest * 100.0
            );
            assert!(
                deepest < 0.01,
                "{path}: a skinned vertex went {:.2}% of the size below the ground",
                deepest * 100.0
            );
            assert!(
                fastest < 0.01,
                "{path}: a skinned vertex still moves {:.2}% of the size a second",
                fastest * 100.0
            );
        }
    }

    #[test]
    fn a_slow_fall_from_a_height_is_not_stopped_in_the_air() {
        // A fifth of the usual gravity, dropped from over half its height: the fall lasts
        // seconds, and the settling must wait until it lies on the ground.
        let asset = load("khronos/CesiumMan/glTF-Binary/CesiumMan.glb");
        let options = RagdollOptions { gravity: 2.0, ..RagdollOptions::default() };
        let (_, _, last, size, ground) = vertex_report_with(&asset, 10.0, 9.0, &[], 0.7, options);
        let lowest = last.iter().map(|v| v.y).fold(f32::INFINITY, f32::min) - ground;
        assert!(lowest < 0.01 * size, "stopped {:.2}% of the size above the ground", lowest / size * 100.0);
    }

    #[test]
    fn a_character_dropped_on_the_stairs_rests_on_a_step_the_same_every_time() {
        let asset = load("khronos/CesiumMan/glTF-Binary/CesiumMan.glb");
        let mut probe = Instance::new(&asset);
        probe.evaluate(&asset, Some(0), 0.3).expect("evaluate");
        let verts = skinned(&asset, &mut probe);
        let (lo, hi) = verts
            .iter()
            .fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(a, b), v| (a.min(*v), b.max(*v)));
        let height = hi.y - lo.y;
        // Eight steps rising towards +Z, wide and deep, the character above the middle one
        // (the fifth), lifted off it: whichever way it falls, it tumbles down steps.
        let (rise, run, steps) = (0.8 * height, 4.0 * height, 8u32);
        let feet = Vec3::new(0.5 * (lo.x + hi.x), lo.y, 0.5 * (lo.z + hi.z));
        let tread_depth = run / steps as f32;
        let middle = 4u32;
        let stairs = Obstacle::Stairs {
            // Step `middle`'s centre is `-run/2 + tread_depth (middle + 0.5)` from the centre.
            center: feet - Vec3::new(0.0, 0.0, -run * 0.5 + tread_depth * (middle as f32 + 0.5)),
            size: Vec3::new(3.0 * height, rise, run),
            steps,
            rotation: Quat::IDENTITY,
        };
        let lift = rise * (middle + 1) as f32 / steps as f32 + 0.02 * height;
        let run_once = || vertex_report(&asset, 8.0, 6.0, &[stairs], lift);
        let (deepest, fastest, a, size, ground) = run_once();
        let (_, _, b, ..) = run_once();
        assert!(a == b, "two runs on the stairs differ");
        assert!(deepest < 0.01, "through the floor by {:.2}%", deepest * 100.0);
        assert!(fastest < 0.01, "still moving on the stairs: {:.2}%/s", fastest * 100.0);
        // Resting on a step: the lowest vertex at a tread's height (not on the floor, not
        // inside a step), and no vertex inside the staircase's solid.
        let lowest = a.iter().map(|v| v.y).fold(f32::INFINITY, f32::min) - ground;
        let tread = rise / steps as f32;
        let nearest = (lowest / tread).round() * tread;
        assert!(lowest > 0.5 * tread, "the character fell off the stairs (lowest point {lowest:.3} above the floor)");
        assert!(
            (lowest - nearest).abs() < 0.02 * size,
            "lowest point {lowest:.3} is not on a tread (every {tread:.3})"
        );
        let pieces = stairs.pieces();
        let inside = a.iter().any(|v| {
            pieces.iter().any(|p| match p {
                Piece::Cuboid(c, h, _) => ((*v - *c).abs() - *h).max_element() < -0.01 * size,
                _ => false,
            })
        });
        assert!(!inside, "a skinned vertex is inside a step");
    }

    #[test]
    fn a_powered_ragdoll_follows_the_clip_and_recovers_from_a_ball() {
        let asset = load("khronos/CesiumMan/glTF-Binary/CesiumMan.glb");
        let mut instance = Instance::new(&asset);
        instance.evaluate(&asset, Some(0), 0.0).expect("evaluate");
        let settings = JointSettings::humanoid(&asset);
        // The ground under the whole clip (its lowest point), as the viewer's grid is.
        let mut probe = Instance::new(&asset);
        let floor = (0..30)
            .map(|i| {
                probe.evaluate(&asset, Some(0), i as f32 / 15.0).expect("evaluate");
                skinned(&asset, &mut probe).iter().map(|v| v.y).fold(f32::INFINITY, f32::min)
            })
            .fold(f32::INFINITY, f32::min);
        // CesiumMan walks in place: its planted foot slides back as on a treadmill, and the
        // floor's friction would hold it. The floor sits a little under the clip's lowest point.
        let height = {
            probe.evaluate(&asset, Some(0), 0.0).expect("evaluate");
            let v = skinned(&asset, &mut probe);
            v.iter().map(|p| p.y).fold(f32::NEG_INFINITY, f32::max)
                - v.iter().map(|p| p.y).fold(f32::INFINITY, f32::min)
        };
        const CLEARANCE: f32 = 0.01;
        let options =
            RagdollOptions { strength: 1.0, ground: Some(floor - CLEARANCE * height), ..RagdollOptions::default() };
        let mut ragdoll = Ragdoll::new(&asset, &mut instance, &settings, None, options).expect("ragdoll");
        let size = ragdoll.size();
        let joints: Vec<usize> = ragdoll.bodies().iter().map(|b| b.joint as usize).collect();
        let mut animated = Instance::new(&asset);
        let mut off = |ragdoll: &mut Ragdoll, instance: &mut Instance, t: f32| -> f32 {
            animated.evaluate(&asset, Some(0), t).expect("evaluate");
            ragdoll.set_targets(animated.worlds(), 1.0 / STEP_HZ);
            ragdoll.step_once();
            ragdoll.write_pose(instance.pose_mut(), 1.0);
            instance.update(&asset).expect("update");
            joints
                .iter()
                .map(|&j| instance.worlds()[j].w_axis.truncate().distance(animated.worlds()[j].w_axis.truncate()))
                .fold(0.0f32, f32::max)
                / size
        };
        let mut worst = 0.0f32;
        let mut t = 0.0;
        for _ in 0..180 {
            t += 1.0 / STEP_HZ;
            worst = worst.max(off(&mut ragdoll, &mut instance, t));
        }
        assert!(worst < 0.02, "strength 1 strays {:.2}% of the size from the clip", worst * 100.0);
        // A ball at the chest knocks it; it is back within 2 % in 2 s.
        let torso =
            asset.nodes.iter().position(|n| n.name.as_deref() == Some("Skeleton_torso_joint_2")).expect("a torso");
        let chest_body = ragdoll.bodies().iter().position(|b| b.joint as usize == torso).expect("a torso body");
        let (_, chest) = ragdoll.body_pose(chest_body).expect("a body");
        let from = chest + Vec3::new(0.0, 0.0, size);
        ragdoll.throw_ball(from, Vec3::new(0.0, 0.0, -6.0 * size), 0.08 * size);
        // The largest displacement, when it came, and when it was back within 2 %.
        let (mut hit, mut peak, mut back) = (0.0f32, 0u32, None);
        for step in 0..180u32 {
            t += 1.0 / STEP_HZ;
            let d = off(&mut ragdoll, &mut instance, t);
            if d > hit {
                (hit, peak, back) = (d, step, None);
            } else if d < 0.02 && back.is_none() && hit > 0.02 {
                back = Some(step);
            }
        }
        let back_after = back.map(|b| (b - peak) as f32 / STEP_HZ);
        // And it stays back.
        let mut after = 0.0f32;
        for _ in 0..60 {
            t += 1.0 / STEP_HZ;
            after = after.max(off(&mut ragdoll, &mut instance, t));
        }
        assert!(after < 0.02, "back, it strays again by {:.2}%", after * 100.0);
        eprintln!(
            "powered: within {:.2}% following, {:.2}% after the hit, back within 2 % {back_after:?} s after the peak",
            worst * 100.0,
            hit * 100.0
        );
        assert!(hit > 0.05, "the ball displaced it only {:.2}%", hit * 100.0);
        assert!(back_after.is_some_and(|s| s <= 2.0), "not back within 2 s of the hit: {back_after:?}");
    }

    #[test]
    fn bad_inputs_are_errors() {
        let asset = load("khronos/BoxAnimated/glTF-Binary/BoxAnimated.glb");
        let mut instance = Instance::new(&asset);
        instance.update(&asset).expect("update");
        let settings = JointSettings::humanoid(&asset);
        let err = Ragdoll::new(&asset, &mut instance, &settings, None, RagdollOptions::default()).err();
        assert_eq!(err, Some(RagdollError::NoSkeleton));
        let fox = load("khronos/Fox/glTF-Binary/Fox.glb");
        let err =
            Ragdoll::new(&fox, &mut instance, &JointSettings::humanoid(&fox), None, RagdollOptions::default()).err();
        assert!(matches!(err, Some(RagdollError::Mismatch(_))), "{err:?}");
    }
}
