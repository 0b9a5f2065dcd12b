//! What the per-frame benchmarks (`frame.rs`, `frame_min.rs`) share: the characters, loading
//! them, and one frame of each measured kind.

use kloub_core::asset::Asset;
use kloub_core::job::world::WorldJob;
use kloub_core::math::Mat4;
use kloub_core::pose::Pose;
use kloub_core::{Animator, Instance, NoResolver};
use std::hint::black_box;
use std::path::PathBuf;

/// (name, file, base clip, crossfade target, layer clip, layer root joint)
pub const CHARACTERS: [(&str, &str, &str, &str, &str, &str); 4] = [
    ("Fox", "khronos/Fox/glTF-Binary/Fox.glb", "Walk", "Run", "Survey", "b_Spine01_02"),
    ("CesiumMan", "khronos/CesiumMan/glTF-Binary/CesiumMan.glb", "0", "0", "0", "Skeleton_torso_joint_2"),
    ("RobotExpressive", "threejs/RobotExpressive/RobotExpressive.glb", "Walking", "Running", "Wave", "Abdomen"),
    ("Knight", "kaykit/Knight/Knight.glb", "Walking_A", "Running_A", "Cheer", "chest"),
];

/// three.js r187 on this machine kind, µs per character per frame for the same work (the figures).
#[allow(dead_code)]
pub const THREE_JS_US: [f64; 4] = [6.0, 7.0, 20.0, 22.0];

pub const DT: f32 = 1.0 / 60.0;

fn shared_assets() -> PathBuf {
    std::env::var_os("KLOUB_SHARED_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/assets"))
}

pub fn load(file: &str) -> Asset {
    let path = shared_assets().join(file);
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    kloub_core::import(&bytes, &NoResolver, &Default::default()).unwrap_or_else(|e| panic!("{file}: {e}")).asset
}

pub fn clip(asset: &Asset, name: &str) -> usize {
    asset.find_clip(name).unwrap_or_else(|| panic!("no clip {name}"))
}

#[allow(dead_code)]
pub fn node(asset: &Asset, name: &str) -> u32 {
    let index = asset.nodes.iter().position(|n| n.name.as_deref() == Some(name));
    index.unwrap_or_else(|| panic!("no node {name}")) as u32
}

/// Buffers of the `pose` measure: a pose and world matrices outside any instance.
pub struct Posed {
    parents: Vec<Option<u32>>,
    pub pose: Pose,
    pub worlds: Vec<Mat4>,
}

impl Posed {
    pub fn new(asset: &Asset) -> Self {
        Self {
            parents: asset.nodes.iter().map(|n| n.parent).collect(),
            pose: Pose::rest(asset),
            worlds: vec![Mat4::IDENTITY; asset.nodes.len()],
        }
    }

    /// `pose`: advance + sample + blend + world transforms of all nodes (no palettes).
    pub fn frame(&mut self, asset: &Asset, animator: &mut Animator) {
        animator.advance(asset, DT);
        animator.evaluate_pose(asset, &mut self.pose).expect("valid");
        WorldJob { parents: &self.parents, order: &asset.order, locals: &self.pose.locals, worlds: &mut self.worlds }
            .run()
            .expect("valid");
        black_box(&self.worlds);
    }
}

/// `single` and `crossfade_layer`: advance + evaluate into an instance (worlds and palettes).
pub fn instance_frame(asset: &Asset, animator: &mut Animator, instance: &mut Instance) {
    animator.advance(asset, DT);
    animator.evaluate(asset, instance).expect("valid");
    black_box(instance.worlds());
}
