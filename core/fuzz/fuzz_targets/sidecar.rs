//! Any text as Fox's sidecar (`Fox.kloub.json`: joint limits and stiffness, example poses):
//! applied or refused with its pointer, never a panic.
#![no_main]

use kloub_core::examples::{ExampleTargets, Examples};
use kloub_core::rig::JointSettings;
use kloub_core::{Instance, NoResolver, import};
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
    // Example poses: read, built into rigs and morph targets, written back unchanged.
    if let Ok(examples) = Examples::from_json(asset, text) {
        let json = serde_json::Value::Object(examples.to_json(asset)).to_string();
        let again = Examples::from_json(asset, &json).expect("examples the viewer wrote read back");
        assert_eq!(again, examples, "the examples changed on the way back");
        let mut instance = Instance::new(asset);
        if instance.set_examples(asset, &examples).is_ok() {
            let (_, mut targets) = ExampleTargets::compile(asset, &instance);
            let _ = targets.write_weights(&mut instance, true);
        }
    }
});
