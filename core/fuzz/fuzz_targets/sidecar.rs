//! Any text as Fox's sidecar (`Fox.kloub.json`: joint limits and stiffness): applied or refused
//! with its pointer, never a panic.
#![no_main]

use kloub_core::rig::JointSettings;
use kloub_core::{NoResolver, import};
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

mod common;

fn fox() -> &'static kloub_core::Asset {
    static FOX: OnceLock<kloub_core::Asset> = OnceLock::new();
    FOX.get_or_init(|| {
        let bytes = include_bytes!("../../../tests/assets/khronos/Fox/glTF-Binary/Fox.glb");
        import(bytes, &NoResolver, &common::options()).expect("Fox imports").asset
    })
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let asset = fox();
    let defaults = JointSettings::humanoid(asset);
    let mut settings = defaults.clone();
    if settings.apply_json(asset, text).is_ok() {
        // What was applied writes back and reads again.
        let json = settings.to_json(asset, &defaults);
        let mut again = defaults.clone();
        again.apply_json(asset, &json).expect("a sidecar the viewer wrote reads back");
    }
});
