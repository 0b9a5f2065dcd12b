//! What the native per-frame benchmarks (`frame.rs`, `frame_min.rs`) share: the characters and
//! loading them from disk; one frame of each measured kind is `frame_setup.rs`'s (the wasm
//! benchmark's too).

#[path = "../frame_setup.rs"]
#[allow(dead_code)]
mod frame_setup;

pub use frame_setup::*;
use kloub_core::NoResolver;
use kloub_core::asset::Asset;
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
