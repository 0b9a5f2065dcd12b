//! `kloub ragdoll`: drop a posed file as a ragdoll and print its joints, frame by frame, as
//! JSON, with the same core simulation the viewer runs ([`kloub_core::ragdoll::Ragdoll`]).
//!
//! ```json
//! { "asset": "Fox.glb", "clip": {"index": 1, "name": "Walk"}, "time": 0.25, "hz": 60,
//!   "ground": 0.0, "bodies": 21, "obstacles": 0, "strength": 0.0,
//!   "joints": [ {"index": 2, "name": "_rootJoint"}, ... ],
//!   "frames": [ {"time": 0.0, "positions": [x0, y0, z0, x1, ...]}, ... ] }
//! ```
//! `frames[0]` is the pose it starts from; then one frame per 1/60 s step. `positions` holds
//! every joint's world position, in the order of `joints`. `--obstacles FILE.json` puts
//! obstacles in its world ([`kloub_core::ragdoll::Obstacle`]'s JSON; an error names its
//! pointer in that file); `--strength S` powers it towards the clip as it plays on from
//! `--time`.

use std::path::Path;

use kloub_core::Instance;
use kloub_core::asset::Asset;
use kloub_core::ragdoll::{Obstacle, Ragdoll, RagdollOptions, STEP_HZ};
use kloub_core::rig::JointSettings;
use serde::Serialize;

use crate::ik::NodeRef;
use crate::pose::{PoseError, import_file};

/// One 1/60 s frame.
#[derive(Clone, Debug, Serialize)]
pub struct RagdollFrame {
    /// Seconds since the ragdoll started.
    pub time: f64,
    /// World positions of the joints, flat `[x, y, z, ...]`.
    pub positions: Vec<f64>,
}

/// The JSON document.
#[derive(Clone, Debug, Serialize)]
pub struct RagdollDoc {
    /// File name.
    pub asset: String,
    /// The clip posed first, if any.
    pub clip: Option<NodeRef>,
    /// Time in that clip.
    pub time: f32,
    /// Steps per second.
    pub hz: f32,
    /// Height of the ground plane.
    pub ground: f32,
    /// Simulated bodies.
    pub bodies: usize,
    /// Obstacles in its world.
    pub obstacles: usize,
    /// The powered ragdoll's strength (0: limp).
    pub strength: f32,
    /// The joints, in the order of each frame's positions.
    pub joints: Vec<NodeRef>,
    /// The frames.
    pub frames: Vec<RagdollFrame>,
}

/// What the ragdoll falls into.
#[derive(Clone, Debug, Default)]
pub struct RagdollWorld {
    /// Seconds to simulate.
    pub seconds: f32,
    /// A JSON file of obstacles.
    pub obstacles: Option<std::path::PathBuf>,
    /// Powered ragdoll strength, 0..1.
    pub strength: f32,
}

/// Reads the file at `path`, poses it with `clip` at `time` and simulates it in `world`.
///
/// # Errors
/// An unreadable or invalid file or obstacles file, an unknown clip, a model without a skin.
pub fn ragdoll_file(path: &Path, clip: Option<&str>, time: f32, world: &RagdollWorld) -> Result<RagdollDoc, PoseError> {
    let obstacles = match &world.obstacles {
        None => Vec::new(),
        Some(file) => {
            let name = file.display().to_string();
            let text = std::fs::read_to_string(file)
                .map_err(|e| PoseError { pointer: None, message: format!("--obstacles {name}: {e}") })?;
            Obstacle::list_from_json(&text).map_err(|e| {
                let (pointer, message) = e.split_once(": ").unwrap_or(("", e.as_str()));
                PoseError {
                    pointer: pointer.starts_with('/').then(|| pointer.to_owned()),
                    message: format!("--obstacles {name}: {message}"),
                }
            })?
        }
    };
    let (name, imported) = import_file(path)?;
    ragdoll_asset(&name, &imported.asset, clip, time, world.seconds, &obstacles, world.strength)
}

/// Poses `asset` and simulates it among `obstacles`, powered by `strength`.
///
/// # Errors
/// An unknown clip, a bad time, duration or strength, a model without a skin.
pub fn ragdoll_asset(
    asset_name: &str,
    asset: &Asset,
    clip: Option<&str>,
    time: f32,
    seconds: f32,
    obstacles: &[Obstacle],
    strength: f32,
) -> Result<RagdollDoc, PoseError> {
    let err = |message: String| PoseError { pointer: None, message };
    if !(seconds.is_finite() && (0.0..=600.0).contains(&seconds)) {
        return Err(err(format!("--seconds {seconds}: expected 0 to 600")));
    }
    let clip_index = match clip {
        Some(c) => Some(asset.find_clip(c).ok_or_else(|| err(format!("no clip {c:?}")))?),
        None => None,
    };
    let mut instance = Instance::new(asset);
    instance.evaluate(asset, clip_index, time).map_err(|e| err(e.to_string()))?;
    if !(strength.is_finite() && (0.0..=1.0).contains(&strength)) {
        return Err(err(format!("--strength {strength}: expected 0 to 1")));
    }
    let settings = JointSettings::humanoid(asset);
    let options = RagdollOptions { strength, ..RagdollOptions::default() };
    let mut ragdoll = Ragdoll::new(asset, &mut instance, &settings, None, options).map_err(|e| err(e.to_string()))?;
    ragdoll.set_obstacles(obstacles);
    // Powered: the clip plays on from `time`, and its pose is each step's target.
    let mut animated = (strength > 0.0).then(|| Instance::new(asset));
    let mut joints: Vec<u32> = asset.skins.iter().flat_map(|s| s.joints.iter().copied()).collect();
    joints.sort_unstable();
    joints.dedup();
    let frame = |instance: &Instance, step: u64| RagdollFrame {
        time: step as f64 / f64::from(STEP_HZ),
        positions: joints
            .iter()
            .flat_map(|&j| {
                let p = instance.worlds()[j as usize].w_axis;
                [f64::from(p.x), f64::from(p.y), f64::from(p.z)]
            })
            .collect(),
    };
    let steps = (seconds * STEP_HZ).round() as u64;
    let mut frames = Vec::with_capacity(steps as usize + 1);
    frames.push(frame(&instance, 0));
    for step in 1..=steps {
        if let Some(animated) = &mut animated {
            let t = time + step as f32 / STEP_HZ;
            animated.evaluate(asset, clip_index, t).map_err(|e| err(e.to_string()))?;
            ragdoll.set_targets(animated.worlds(), 1.0 / STEP_HZ);
        }
        ragdoll.step_once();
        ragdoll.write_pose(instance.pose_mut(), 1.0);
        instance.update(asset).map_err(|e| err(e.to_string()))?;
        frames.push(frame(&instance, step));
    }
    Ok(RagdollDoc {
        asset: asset_name.to_owned(),
        clip: clip_index.map(|c| NodeRef { index: c as u32, name: asset.clips[c].name.clone() }),
        time,
        hz: STEP_HZ,
        ground: ragdoll.ground(),
        bodies: ragdoll.bodies().len(),
        obstacles: obstacles.len(),
        strength,
        joints: joints.iter().map(|&j| NodeRef { index: j, name: asset.nodes[j as usize].name.clone() }).collect(),
        frames,
    })
}
