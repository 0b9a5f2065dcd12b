//! `kloub ik`: solve one end effector towards a target on a posed file and print the result as
//! JSON, with the same core job the viewer runs ([`kloub_core::job::ik::IkJob`]).
//!
//! ```json
//! { "asset": "RiggedFigure.glb", "solver": "ccd", "clip": null, "time": 0.0,
//!   "effector": {"index": 18, "name": "arm_joint_L_3"},
//!   "target": [x, y, z], "reached": [x, y, z], "error": 0.00002, "iterations": 9,
//!   "chain": [ {"index": 16, "name": "arm_joint_L_1", "rotation": [x, y, z, w], "world": [x, y, z]}, ... ] }
//! ```
//! `chain` lists the joints root first, the effector last; `rotation` is each joint's local
//! rotation after the solve, `world` its world position.

use std::path::Path;

use kloub_core::Instance;
use kloub_core::asset::Asset;
use kloub_core::job::ik::{IkChain, IkGoal, IkJob, IkReport, IkSettings, JointLimit};
use kloub_core::math::{Mat4, Transform, Vec3};
use kloub_core::rig::JointSettings;
use serde::Serialize;

use crate::pose::{PoseError, import_file};

/// What to solve.
#[derive(Clone, Debug)]
pub struct IkRequest {
    /// Clip name or index to pose the file with first (`None`: the rest pose).
    pub clip: Option<String>,
    /// Time in the clip, seconds.
    pub time: f32,
    /// End effector: a node name or index.
    pub effector: String,
    /// Rotating joints above the effector.
    pub depth: usize,
    /// World-space target.
    pub target: [f32; 3],
    /// Two-bone's pole point, world space.
    pub pole: Option<[f32; 3]>,
    /// Stiffness per rotating joint, root first (empty: 1 for all).
    pub stiffness: Vec<f32>,
    /// Respect limits inferred from humanoid joint names.
    pub humanoid_limits: bool,
    /// A `<model>.kloub.json` sidecar's text: limits and stiffness over those defaults.
    pub sidecar: Option<String>,
    /// Solver and its settings.
    pub settings: IkSettings,
}

/// A node of the output.
#[derive(Clone, Debug, Serialize)]
pub struct NodeRef {
    /// Node index.
    pub index: u32,
    /// Node name, if any.
    pub name: Option<String>,
}

/// One chain joint after the solve.
#[derive(Clone, Debug, Serialize)]
pub struct ChainJoint {
    /// Node index.
    pub index: u32,
    /// Node name, if any.
    pub name: Option<String>,
    /// Local rotation `[x, y, z, w]`.
    pub rotation: [f64; 4],
    /// World position.
    pub world: [f64; 3],
}

/// The JSON document `kloub ik` prints.
#[derive(Clone, Debug, Serialize)]
pub struct IkDoc {
    /// File name of the input.
    pub asset: String,
    /// `"ccd"`, `"twobone"`, `"fabrik"` or `"dls"`.
    pub solver: &'static str,
    /// The clip posed first, if any.
    pub clip: Option<NodeRef>,
    /// Time in that clip.
    pub time: f64,
    /// The end effector.
    pub effector: NodeRef,
    /// The target.
    pub target: [f64; 3],
    /// Where the effector ended.
    pub reached: [f64; 3],
    /// Distance from `reached` to `target`.
    pub error: f64,
    /// Iterations the solver used.
    pub iterations: u32,
    /// The chain, root first.
    pub chain: Vec<ChainJoint>,
}

fn widen<const N: usize>(v: [f32; N]) -> [f64; N] {
    v.map(f64::from)
}

/// Reads the file at `path`, poses it and solves.
pub fn ik_file(path: &Path, request: &IkRequest) -> Result<IkDoc, PoseError> {
    let (name, imported) = import_file(path)?;
    ik_asset(&name, &imported.asset, request)
}

/// Poses `asset` and solves `request`.
pub fn ik_asset(asset_name: &str, asset: &Asset, request: &IkRequest) -> Result<IkDoc, PoseError> {
    let err = |message: String| PoseError { pointer: None, message };
    let clip = match &request.clip {
        Some(c) => Some(asset.find_clip(c).ok_or_else(|| err(format!("no clip {c:?}")))?),
        None => None,
    };
    let effector = crate::pose::find_node(asset, &request.effector)
        .ok_or_else(|| err(format!("no node {:?}", request.effector)))?;
    let parents: Vec<Option<u32>> = asset.nodes.iter().map(|n| n.parent).collect();
    let chain = IkChain::new(&parents, effector, request.depth).map_err(|e| err(e.to_string()))?;
    let mut instance = Instance::new(asset);
    instance.evaluate(asset, clip, request.time).map_err(|e| err(e.to_string()))?;
    let rest: Vec<Transform> = kloub_core::pose::Pose::rest(asset).locals;
    let mut joints = JointSettings::humanoid(asset);
    if let Some(text) = &request.sidecar {
        joints.apply_json(asset, text).map_err(|e| err(format!("limits: {e}")))?;
    }
    let (chain_limits, chain_stiffness) = joints.chain(&chain);
    let limits: Vec<JointLimit> = if request.humanoid_limits { chain_limits } else { Vec::new() };
    let stiffness: Vec<f32> = match (&request.sidecar, request.stiffness.is_empty()) {
        (Some(_), true) => chain_stiffness,
        _ => request.stiffness.clone(),
    };
    let goal = IkGoal {
        chain: &chain,
        target: Vec3::from(request.target),
        stiffness: &stiffness,
        limits: &limits,
        pole: request.pole.map(Vec3::from),
    };
    let mut reports = [IkReport::default()];
    IkJob {
        parents: &parents,
        rest: &rest,
        locals: &mut instance.pose_mut().locals,
        goals: &[goal],
        settings: request.settings,
        reports: &mut reports,
    }
    .run()
    .map_err(|e| err(e.to_string()))?;
    instance.update(asset).map_err(|e| err(e.to_string()))?;
    let worlds: &[Mat4] = instance.worlds();
    let position = |n: u32| worlds[n as usize].w_axis.truncate().to_array();
    let node = |n: u32| NodeRef { index: n, name: asset.nodes[n as usize].name.clone() };
    let chain_out = chain
        .joints()
        .iter()
        .map(|&j| ChainJoint {
            index: j,
            name: asset.nodes[j as usize].name.clone(),
            rotation: widen(instance.pose().locals[j as usize].rotation.to_array()),
            world: widen(position(j)),
        })
        .collect();
    let report = reports[0];
    if !report.error.is_finite() {
        return Err(err("the solve is not finite".into()));
    }
    Ok(IkDoc {
        asset: asset_name.to_owned(),
        solver: request.settings.solver.name(),
        clip: clip.map(|c| NodeRef { index: c as u32, name: asset.clips[c].name.clone() }),
        time: f64::from(request.time),
        effector: node(effector),
        target: widen(request.target),
        reached: widen(position(effector)),
        error: f64::from(report.error),
        iterations: report.iterations,
        chain: chain_out,
    })
}
